//! The UPnP library solver ([`simhc::solver::InstanceProblem`], the one assembly every command
//! and binding goes through): exact on noise-free data, a true stationary point no worse than a
//! local minimization from the ground truth on noisy data, holds on every distribution, never
//! returns a wrong pose unflagged (not even from a random start), tracks perturbed starts to the
//! truth, names the correspondence and field of bad input, and its batch call is the single call.

use nalgebra::SVector;
use nalgebra::Vector3;
use rand::SeedableRng;
use simhc::pipeline::learned::NonFiniteParameter;
use simhc::pipeline::{AttemptError, Method, PipelineError};
use simhc::solver::{DegenerateInput, FirstRowsError, LearnedHypotheses, SolveError, SolverAttempt, SolverOrigin, StartId};
use simhc_problems::metrics::{quat_from_rotation, rotation_error_deg, translation_error_pct};
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::learned::UpnpLearned;
use simhc_problems::upnp::refine::{levenberg_marquardt, LmOptions};
use simhc_problems::upnp::scene::{PointBox, UpnpSceneConfig};

use simhc::solver::GivenStart as Given;

/// One Simulator HC path from the caller's start, validated, no fallback.
const FROM_GIVEN: [SolverAttempt; 1] = [SolverAttempt::new(StartId::Given, Method::SimulatorHc)];

#[test]
fn noise_free_scenes_are_solved_exactly() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    // The linear start (the problem's other start) is tried first: Gauss-Newton, then the
    // learned start's; then a path from each.
    let gn = |start| SolverAttempt::new(start, Method::GaussNewton);
    let path = |start| SolverAttempt::new(start, Method::SimulatorHc);
    let (linear, learned) = (StartId::Other(0), StartId::LEARNED);
    assert_eq!(solver.schedule(), [gn(linear), gn(learned), path(linear), path(learned)]);
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
/// 2 px noise: all but at most one of 60 validated, no unflagged wrong pose.
#[test]
fn holds_on_every_distribution() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default();
    for (layout, frames) in [(PointBox::Viewer, false), (PointBox::World, false), (PointBox::Viewer, true), (PointBox::World, true)] {
        let seed = 77;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (mut ok, n) = (0, 60);
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
        }
        println!("{layout:?} box, random frames {frames}, seed {seed}: {ok}/{n} validated");
        assert!(ok >= n - 1, "{layout:?} frames {frames}: {ok}/{n}");
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

/// The solver (and so its estimator) needs UPnP's network: another shape is a typed error, not
/// a panic.
#[test]
fn a_network_of_another_shape_is_an_error() {
    use simhc::regressor::{DenseLayer, FoldedNetwork};
    let point = DenseLayer::new(12, 1, vec![0.0; 12], vec![0.0]).expect("layer");
    let head = DenseLayer::new(1, 4, vec![0.0; 4], vec![1.0, 0.0, 0.0, 0.0]).expect("layer");
    let network = FoldedNetwork::new(12, vec![point], vec![head], true).expect("network");
    let e = UpnpLearned::new(network).err().expect("rows of 12, not 9");
    assert!(e.to_string().contains("input width"), "{e}");
    let problem = std::sync::Arc::new(UpnpProblem { max_angle: 0.01, ..UpnpProblem::default() });
    assert!(UpnpLibrarySolver::with_learned(problem, UpnpLearned::shipped().expect("shipped"), 0.0).is_ok());
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

/// An attempt from a start that this solve does not have (no given start, a rank beyond the
/// learned start's hypotheses, an other start or a restart beyond the problem's) is no attempt:
/// not counted, its reason the last error when nothing else ran, and the attempts after it run
/// as they would alone.
#[test]
fn an_attempt_from_a_start_the_solve_does_not_have_is_no_attempt() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let hypotheses = solver.learned_start().hypotheses();
    let scene = UpnpSceneConfig::default().sample_seeded(3).expect("valid config");
    let corrs = &scene.correspondences[..];
    let linear = SolverAttempt::new(StartId::Other(0), Method::GaussNewton);
    let alone = solver.run_pipeline(corrs, &[linear], false, None).expect("the linear start's Gauss-Newton validates");
    assert_eq!((alone.origin, alone.attempts), (SolverOrigin::Attempt(linear), 1));
    let missing = [
        StartId::Given,
        StartId::Learned { rank: hypotheses, refined: false },
        StartId::Learned { rank: hypotheses, refined: true },
        StartId::Other(1),
        StartId::Restart(0),
    ];
    for start in missing {
        let attempt = SolverAttempt::new(start, Method::GaussNewton);
        match solver.run_pipeline(corrs, &[attempt], false, None) {
            Err(PipelineError::NoEndPoint { attempts: 0, last: Some(AttemptError::Start(_)) }) => {}
            other => panic!("{start}: {other:?}"),
        }
        let after = solver.run_pipeline(corrs, &[attempt, linear], false, None).expect("the linear start still runs");
        assert_eq!((after.x, after.origin, after.attempts), (alone.x, alone.origin, 1), "{start}");
    }
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

#[test]
fn noisy_solution_is_a_stationary_point_no_worse_than_local_refinement_of_the_truth() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default(); // 2 px noise
    let mut checked = 0;
    for seed in 100..140u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let Ok(s) = solver.solve(&scene.correspondences[..]) else { continue };
        let pose = upnp_pose(&s.x, &scene.correspondences).expect("a pose");
        let system = upnp_system(&scene.correspondences).expect("valid scene");
        let (cost, grad) = system.cost_gradient(pose.quaternion);
        let scale = system.m.amax().max(1.0);
        let gnorm = grad.iter().map(|g| g * g).sum::<f64>().sqrt();
        assert!(gnorm < 1e-9 * scale, "seed {seed}: tangential gradient {gnorm:e}");
        // A local minimization started from the ground truth.
        let lm = levenberg_marquardt(&scene.rotation, &scene.translation, &scene.correspondences, &LmOptions::default());
        let cost_lm = system.cost(quat_from_rotation(&lm.rotation));
        if rotation_error_deg(&pose.rotation, &scene.rotation) < 2.0 {
            assert!(cost <= cost_lm * (1.0 + 1e-6) + 1e-12 * scale, "seed {seed}: cost {cost:e} > {cost_lm:e}");
            checked += 1;
        }
    }
    assert!(checked >= 35, "only {checked}/40 noisy scenes reached the true basin");
}

#[test]
fn perturbed_starts_are_tracked_to_the_truth() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    let seed = 11;
    println!("seed {seed}");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    for (i, angle) in [5.0, 20.0, 40.0, 60.0].into_iter().cycle().take(40).enumerate() {
        let scene = config.sample_seeded(1000 + i as u64).expect("valid config");
        let r0 = simhc_problems::metrics::random_rotation_perturbation(&scene.rotation, angle, &mut rng);
        let given = Given(SVector::from(quat_from_rotation(&r0)));
        let s = solver.run_pipeline(&scene.correspondences, &FROM_GIVEN, false, Some(&given)).expect("tracks");
        let pose = upnp_pose(&s.x, &scene.correspondences).expect("a pose");
        let err = rotation_error_deg(&pose.rotation, &scene.rotation);
        assert!(err < 1e-6, "scene {i}, start {angle} deg off: error {err} deg");
    }
}

/// One path from a random start often ends on the wrong stationary point: those come back
/// flagged, and whatever comes back unflagged is right.
#[test]
fn wrong_end_points_from_random_starts_are_flagged() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default();
    let seed = 5;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (mut right, mut flagged) = (0, 0);
    for i in 0..80u64 {
        let scene = config.sample_seeded(2000 + i).expect("valid config");
        let given = Given(SVector::from(simhc_problems::metrics::random_unit_quaternion(&mut rng)));
        match solver.run_pipeline(&scene.correspondences, &FROM_GIVEN, false, Some(&given)) {
            Ok(s) => {
                let pose = upnp_pose(&s.x, &scene.correspondences).expect("a pose");
                let err = rotation_error_deg(&pose.rotation, &scene.rotation);
                assert!(err < 2.0, "seed {seed} trial {i}: unflagged end point {err} deg off");
                assert!(s.check.passes(0.02, 0));
                right += 1;
            }
            Err(PipelineError::NotValidated(s)) => {
                assert!(!s.check.passes(0.02, 0));
                flagged += 1;
            }
            Err(_) => {}
        }
    }
    println!("seed {seed}: {right} right, {flagged} flagged of 80 random starts");
    // Both branches must be exercised for the test to mean anything.
    assert!(right >= 10 && flagged >= 10, "right {right}, flagged {flagged}");
}

/// Noise-free solves come with a certificate (an interval Krawczyk proof on the tracked
/// system), its enclosure holds the true rotation (up to the quaternion's sign), and a solver
/// that requires certificates returns the same solutions.
#[test]
fn noise_free_solutions_are_certified_around_the_truth() {
    let solver =
        UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load").certifying(simhc::solver::Certification::Require);
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    let (mut certified, n) = (0, 40);
    for seed in 300..300 + n {
        let scene = config.sample_seeded(seed).expect("valid config");
        let s = solver.solve(&scene.correspondences[..]).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let c = s.certified.expect("asked").expect("a required certificate");
        let q = quat_from_rotation(&scene.rotation);
        let truth = SVector::from(q);
        assert!(c.encloses(&truth) || c.encloses(&-truth), "seed {seed}: the enclosure misses the truth");
        assert!(c.error_bound() < 1e-8, "seed {seed}: bound {}", c.error_bound());
        certified += 1;
    }
    println!("seeds 300..340: {certified}/{n} certified");
}
