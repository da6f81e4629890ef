//! UPnP Simulator HC end to end: exact on noise-free data, a true stationary point no worse than
//! a local minimization from the ground truth on noisy data, typed errors on bad input.

use nalgebra::Vector3;
use simhc_problems::metrics::{quat_from_rotation, rotation_error_deg, translation_error_pct};
use simhc_problems::upnp::geometry::{upnp_system, UpnpError};
use simhc_problems::upnp::refine::{levenberg_marquardt, LmOptions};
use simhc_problems::upnp::scene::{UpnpCorrespondence, UpnpSceneConfig};
use simhc_problems::upnp::solver::{SolveError, UpnpSolver};

#[test]
fn noise_free_scenes_are_solved_exactly() {
    let solver = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    let mut solved = 0;
    for seed in 0..50u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let Ok(pose) = solver.solve(&scene.correspondences) else { continue };
        if rotation_error_deg(&pose.rotation, &scene.rotation) < 1e-6 {
            assert!(translation_error_pct(&pose.translation, &scene.translation) < 1e-4, "seed {seed}");
            solved += 1;
        }
    }
    println!("seeds 0..50: {solved} solved to 1e-6 deg");
    assert!(solved >= 45, "only {solved}/50 noise-free scenes solved exactly");
}

#[test]
fn noisy_solution_is_a_stationary_point_no_worse_than_local_refinement_of_the_truth() {
    let solver = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig::default(); // 2 px noise
    let mut checked = 0;
    for seed in 100..140u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let Ok(pose) = solver.solve(&scene.correspondences) else { continue };
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
fn bad_input_gets_typed_errors() {
    let solver = UpnpSolver::new().expect("shipped weights load");
    let scene = UpnpSceneConfig::default().sample_seeded(3).expect("valid config");
    let two = &scene.correspondences[..2];
    assert!(matches!(solver.solve(two), Err(SolveError::Input(UpnpError::TooFewCorrespondences { .. }))));

    let mut nan = scene.correspondences.clone();
    nan[4].p.x = f64::NAN;
    assert!(matches!(solver.solve(&nan), Err(SolveError::Input(UpnpError::NonFinite { index: 4 }))));

    let mut zero = scene.correspondences.clone();
    zero[2].f = Vector3::zeros();
    assert!(matches!(solver.solve(&zero), Err(SolveError::Input(UpnpError::ZeroBearing { index: 2 }))));

    // Degenerate geometry: world points on one line leave the rotation about it free.
    let mut line = scene.correspondences.clone();
    for (i, c) in line.iter_mut().enumerate() {
        c.p = Vector3::new(1.0, 2.0, 3.0) * i as f64;
    }
    assert!(matches!(solver.solve(&line), Err(SolveError::Input(UpnpError::CollinearPoints))));
    let mut same = scene.correspondences.clone();
    for c in &mut same {
        c.p = Vector3::new(1.0, 2.0, 3.0);
    }
    assert!(matches!(solver.solve(&same), Err(SolveError::Input(UpnpError::CollinearPoints))));

    let empty: Vec<UpnpCorrespondence> = Vec::new();
    assert!(solver.solve(&empty).is_err());
}

#[test]
fn perturbed_starts_are_tracked_to_the_truth() {
    use rand::SeedableRng;
    use simhc::regressor::{DenseLayer, FoldedNetwork};
    // solve_from does not use the network: a minimal valid one keeps this test independent of
    // the shipped weights.
    let point = DenseLayer::new(9, 1, vec![0.0; 9], vec![0.0]).expect("layer");
    let head = DenseLayer::new(1, 4, vec![0.0; 4], vec![1.0, 0.0, 0.0, 0.0]).expect("layer");
    let network = FoldedNetwork::new(9, vec![point], vec![head], true).expect("network");
    let solver = UpnpSolver::with_network(network);
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    let seed = 11;
    println!("seed {seed}");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    for (i, angle) in [5.0, 20.0, 40.0, 60.0].into_iter().cycle().take(40).enumerate() {
        let scene = config.sample_seeded(1000 + i as u64).expect("valid config");
        let r0 = simhc_problems::metrics::random_rotation_perturbation(&scene.rotation, angle, &mut rng);
        let report = solver.solve_from(&scene.correspondences, quat_from_rotation(&r0)).expect("tracks");
        let err = rotation_error_deg(&report.pose.rotation, &scene.rotation);
        assert!(err < 1e-6, "scene {i}, start {angle} deg off: error {err} deg");
    }
}

/// Every distribution the solver may meet: simhc's own sampler, the peers' world-box scenes,
/// and both with random rigid changes of the world and viewer frames. The shipped solver must
/// succeed and must never return a wrong pose unflagged.
#[test]
fn shipped_solver_holds_on_every_distribution() {
    use rand::SeedableRng;
    use simhc_problems::upnp::scene::PointBox;
    let solver = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig::default(); // 2 px
    for (layout, frames) in [(PointBox::Viewer, false), (PointBox::World, false), (PointBox::Viewer, true), (PointBox::World, true)] {
        let seed = 77;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (mut ok, mut flagged, n) = (0, 0, 60);
        for i in 0..n {
            let scene = config.sample_with(layout, frames, &mut rng).expect("valid config");
            match solver.solve(&scene.correspondences) {
                Ok(pose) => {
                    let err = rotation_error_deg(&pose.rotation, &scene.rotation);
                    assert!(err < 2.0, "{layout:?} frames {frames} seed {seed} trial {i}: unflagged pose {err} deg off");
                    ok += 1;
                }
                Err(SolveError::NotValidated(_)) => flagged += 1,
                Err(e) => panic!("{layout:?} frames {frames} trial {i}: {e}"),
            }
        }
        println!("{layout:?} box, random frames {frames}, seed {seed}: {ok}/{n} validated, {flagged} flagged");
        assert!(ok >= n - 1, "{layout:?} frames {frames}: only {ok}/{n}");
    }
}

/// One path from a random start often ends on the wrong stationary point: those come back
/// flagged, and whatever comes back unflagged is right.
#[test]
fn wrong_end_points_are_flagged() {
    use rand::SeedableRng;
    let solver = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig::default();
    let seed = 5;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (mut right, mut flagged) = (0, 0);
    for i in 0..80u64 {
        let scene = config.sample_seeded(2000 + i).expect("valid config");
        let q0 = simhc_problems::metrics::random_unit_quaternion(&mut rng);
        match solver.solve_from(&scene.correspondences, q0) {
            Ok(r) => {
                let err = rotation_error_deg(&r.pose.rotation, &scene.rotation);
                assert!(err < 2.0, "seed {seed} trial {i}: unflagged end point {err} deg off");
                assert!(r.validation.passes(solver.options.max_angle, 0));
                right += 1;
            }
            Err(SolveError::NotValidated(r)) => {
                assert!(!r.validation.passes(solver.options.max_angle, solver.options.max_behind));
                flagged += 1;
            }
            Err(_) => {}
        }
    }
    println!("seed {seed}: {right} right, {flagged} flagged of 80 random starts");
    // Both branches must be exercised for the test to mean anything.
    assert!(right >= 10 && flagged >= 10, "right {right}, flagged {flagged}");
}
