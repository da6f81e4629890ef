//! UPnP through the runtime's problem trait ([`simhc::solver::InstanceProblem`]): the library
//! solver holds on every distribution `UpnpSolver` is tested on, agrees with it, never returns
//! a wrong pose unflagged, names the correspondence and field of bad input, and its batch call
//! is the single call.

use nalgebra::Vector3;
use rand::SeedableRng;
use simhc::pipeline::learned::NonFiniteParameter;
use simhc::pipeline::{Attempt, Method};
use simhc::solver::{DegenerateInput, FirstRowsError, SolveError};
use simhc_problems::metrics::{rotation_error_deg, translation_error_pct};
use simhc_problems::upnp::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::{PointBox, UpnpSceneConfig};
use simhc_problems::upnp::solver::UpnpSolver;

#[test]
fn noise_free_scenes_are_solved_exactly() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    // The linear start (provider 3, after the learned start's 0 and 1 and the caller's 2) is
    // tried first: Gauss-Newton, then the learned start's; then a path from each.
    let gn = |provider| Attempt { provider, method: Method::GaussNewton };
    let path = |provider| Attempt { provider, method: Method::SimulatorHc };
    assert_eq!(solver.schedule(), [gn(3), gn(0), path(3), path(0)]);
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    for seed in 0..50u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let s = solver.solve(&scene.correspondences[..]).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let pose = upnp_pose(&s.x, &scene.correspondences).expect("a pose");
        let err = rotation_error_deg(&pose.rotation, &scene.rotation);
        assert!(err < 1e-6, "seed {seed}: {err} deg");
        assert!(translation_error_pct(&pose.translation, &scene.translation) < 1e-4, "seed {seed}");
    }
}

/// simhc's sampler, the peers' world-box scenes, both with random rigid changes of the frames,
/// 2 px noise: at least `UpnpSolver`'s successes, no unflagged wrong pose.
#[test]
fn holds_on_every_distribution_and_matches_the_shipped_solver() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let shipped = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig::default();
    for (layout, frames) in [(PointBox::Viewer, false), (PointBox::World, false), (PointBox::Viewer, true), (PointBox::World, true)] {
        let seed = 77;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (mut ok, mut ok_shipped, n) = (0, 0, 60);
        for i in 0..n {
            let scene = config.sample_with(layout, frames, &mut rng).expect("valid config");
            match solver.solve(&scene.correspondences[..]) {
                Ok(s) => {
                    let pose = upnp_pose(&s.x, &scene.correspondences).expect("a pose");
                    let err = rotation_error_deg(&pose.rotation, &scene.rotation);
                    assert!(err < 2.0, "{layout:?} frames {frames} seed {seed} trial {i}: unflagged pose {err} deg off");
                    ok += 1;
                }
                Err(SolveError::NotValidated { .. }) => {}
                Err(e) => panic!("{layout:?} frames {frames} trial {i}: {e}"),
            }
            ok_shipped += shipped.solve(&scene.correspondences).is_ok() as usize;
        }
        println!("{layout:?} box, random frames {frames}, seed {seed}: {ok}/{n} validated (UpnpSolver {ok_shipped})");
        assert!(ok >= ok_shipped && ok >= n - 1, "{layout:?} frames {frames}: {ok}/{n}, UpnpSolver {ok_shipped}");
    }
}

#[test]
fn bad_input_names_the_correspondence_and_field() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let scene = UpnpSceneConfig::default().sample_seeded(3).expect("valid config");
    let input = |c: &[_]| match solver.solve(c) {
        Err(SolveError::Input(e)) => e,
        other => panic!("not an input error: {other:?}"),
    };
    assert_eq!(input(&scene.correspondences[..2]), FirstRowsError::TooFew { got: 2, need: 3 });
    assert_eq!(input(&[]), FirstRowsError::TooFew { got: 0, need: 3 });

    let mut nan = scene.correspondences.clone();
    nan[4].f.y = f64::NAN;
    let e = input(&nan);
    assert_eq!(e, FirstRowsError::NonFinite(NonFiniteParameter { row: Some(4), field: "f", index: 9 * 4 + 3 + 1 }));
    assert!(e.to_string().contains("row 4, field `f`"), "{e}");

    let mut zero = scene.correspondences.clone();
    zero[2].f = Vector3::zeros();
    assert!(matches!(input(&zero), FirstRowsError::Degenerate(DegenerateInput { row: Some(2), .. })));

    // World points on one line leave the rotation about it free.
    let mut line = scene.correspondences.clone();
    for (i, c) in line.iter_mut().enumerate() {
        c.p = Vector3::new(1.0, 2.0, 3.0) * i as f64;
    }
    assert!(matches!(input(&line), FirstRowsError::Degenerate(DegenerateInput { row: None, .. })));
    // All bearings parallel from one centre: the translation along them is free.
    let mut parallel = scene.correspondences.clone();
    for c in &mut parallel {
        (c.f, c.v) = (Vector3::z(), Vector3::zeros());
    }
    assert!(matches!(input(&parallel), FirstRowsError::Degenerate(DegenerateInput { row: None, .. })));
}

/// Without the linear start and the fallback, the learned start alone: still at least 95 % on
/// the training distribution, so the assembly really runs the learned start (a broken one
/// would leave only flagged end points).
#[test]
fn the_learned_start_alone_solves_the_training_distribution() {
    let problem = UpnpProblem { linear_start: false, fallback: false, ..UpnpProblem::default() };
    let solver = UpnpLibrarySolver::new(problem).expect("shipped weights load");
    assert_eq!(solver.schedule().len(), 2, "Gauss-Newton, then one path, from the learned start");
    let config = UpnpSceneConfig::default();
    let n = 60;
    let ok = (0..n).filter(|&seed| solver.solve(&config.sample_seeded(500 + seed).expect("valid").correspondences[..]).is_ok()).count();
    println!("seeds 500..560: {ok}/{n} from the learned start alone");
    assert!(ok >= 57, "{ok}/{n}");
}

#[test]
fn the_batch_call_is_the_single_call() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default();
    let scenes: Vec<Vec<_>> = (0..16).map(|seed| config.sample_seeded(900 + seed).expect("valid").correspondences).collect();
    let batch = solver.solve_batch(&scenes);
    for (scene, b) in scenes.iter().zip(&batch) {
        assert_eq!(&solver.solve(&scene[..]), b);
    }
    assert!(batch.iter().filter(|r| r.is_ok()).count() >= 15);
}
