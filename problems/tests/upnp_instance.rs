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

    // Each field of a correspondence, at its place in the row `[p, f, v]`.
    for (field, k) in [("p", 0), ("f", 1), ("v", 2)] {
        let mut nan = scene.correspondences.clone();
        let c = &mut nan[4];
        [&mut c.p, &mut c.f, &mut c.v][k].y = f64::NAN;
        let e = input(&nan);
        assert_eq!(e, FirstRowsError::NonFinite(NonFiniteParameter { row: Some(4), field, index: 9 * 4 + 3 * k + 1 }));
        assert!(e.to_string().contains(&format!("row 4, field `{field}`")), "{e}");
    }

    let reason = |e: FirstRowsError| match e {
        FirstRowsError::Degenerate(DegenerateInput { row, reason }) => (row, reason),
        other => panic!("not degenerate: {other:?}"),
    };
    let mut zero = scene.correspondences.clone();
    zero[2].f = Vector3::zeros();
    let (row, why) = reason(input(&zero));
    assert_eq!(row, Some(2));
    assert!(why.contains("bearing `f`"), "{why}");

    // World points on one line leave the rotation about it free.
    let mut line = scene.correspondences.clone();
    for (i, c) in line.iter_mut().enumerate() {
        c.p = Vector3::new(1.0, 2.0, 3.0) * i as f64;
    }
    let (row, why) = reason(input(&line));
    assert!(row.is_none() && why.contains("one line"), "{why}");
    // All bearings parallel from one centre: the translation along them is free.
    let mut parallel = scene.correspondences.clone();
    for c in &mut parallel {
        (c.f, c.v) = (Vector3::z(), Vector3::zeros());
    }
    let (row, why) = reason(input(&parallel));
    assert!(row.is_none() && why.contains("parallel"), "{why}");
}

/// The estimator's samples need UPnP's network: another shape is a typed error, not a panic.
#[test]
fn an_estimator_with_a_network_of_another_shape_is_an_error() {
    use simhc::regressor::{DenseLayer, FoldedNetwork};
    use simhc_problems::upnp::ransac::UpnpEstimator;
    let point = DenseLayer::new(12, 1, vec![0.0; 12], vec![0.0]).expect("layer");
    let head = DenseLayer::new(1, 4, vec![0.0; 4], vec![1.0, 0.0, 0.0, 0.0]).expect("layer");
    let network = FoldedNetwork::new(12, vec![point], vec![head], true).expect("network");
    let e = UpnpEstimator::new(UpnpSolver::with_network(network), 0.01).expect_err("rows of 12, not 9");
    assert!(e.to_string().contains("input width"), "{e}");
    assert!(UpnpEstimator::new(UpnpSolver::new().expect("shipped"), 0.01).is_ok());
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
