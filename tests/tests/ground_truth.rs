//! The generated systems vanish at the ground truth of noise-free synthetic scenes (paper
//! sections 5 and 6), and the generic simulator makes a perturbed start consistent.

use nalgebra::SVector;
use simhc::{OnlineSimulator, Problem};
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::upnp::geometry::upnp_cost_matrix;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::{grps, metrics, upnp};

#[test]
fn grps_residual_vanishes_at_ground_truth() {
    for seed in 0..200u64 {
        let scene = GrpsSceneConfig::default().sample_seeded(seed).expect("valid config");
        let x = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        let rows = grps::rows_of::<8>(&scene.correspondences).expect("8 correspondences");
        let mut f = SVector::<f64, 9>::zeros();
        grps::Grps8::residual(&x, &grps::Grps8::params(&rows), &mut f);
        assert!(f.amax() < 1e-10, "seed {seed}: |F(x_gt)| = {:e}", f.amax());

        let rows7 = grps::rows_of::<7>(&scene.correspondences[..7]).expect("7 correspondences");
        let mut f7 = SVector::<f64, 8>::zeros();
        grps::Grps7::residual(&x, &grps::Grps7::params(&rows7), &mut f7);
        assert!(f7.amax() < 1e-10, "seed {seed}: |F7(x_gt)| = {:e}", f7.amax());
    }
}

#[test]
fn upnp_residual_vanishes_at_ground_truth() {
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    for seed in 0..200u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let m = upnp_cost_matrix(&scene.correspondences).expect("non-degenerate scene");
        let q = metrics::quat_from_rotation(&scene.rotation);
        let x = SVector::<f64, 4>::from(q);
        let mut f = SVector::<f64, 5>::zeros();
        upnp::Upnp::residual(&x, &upnp::params_of(&m), &mut f);
        let scale = m.amax().max(1.0);
        assert!(f.amax() < 1e-9 * scale, "seed {seed}: |F(q_gt)| = {:e} (|M| = {scale:e})", f.amax());
    }
}

#[test]
fn generic_simulator_makes_a_perturbed_start_exact() {
    use rand::SeedableRng;
    let seed = 7;
    println!("seed {seed}");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let scene = GrpsSceneConfig::default().sample_seeded(seed).expect("valid config");
    let r0 = metrics::random_rotation_perturbation(&scene.rotation, 20.0, &mut rng);
    let x0 = grps::unknowns_of(&r0, &(scene.translation * 1.1), scene.scale * 0.9);
    let p = grps::Grps8::params(&grps::rows_of::<8>(&scene.correspondences).expect("8 rows"));
    let p0 = simhc::MinNormSimulator::<grps::Grps8>::new().simulate(&x0, &p).expect("simulator converges");
    let mut f = SVector::<f64, 9>::zeros();
    grps::Grps8::residual(&x0, &p0, &mut f);
    assert!(f.amax() < 1e-12, "|F(x0; p0)| = {:e}", f.amax());
    // The correction is small relative to the parameters and actually moved them.
    assert!((p0 - p).norm() > 1e-6 && (p0 - p).norm() < p.norm());
}
