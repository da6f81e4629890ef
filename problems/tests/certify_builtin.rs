//! The Krawczyk certificate on the built-ins cannot lie: over 1000 seeded noise-free scenes of
//! UPnP and of GRPS (8 correspondences), the solver's answers are certified (on a chosen square
//! subsystem) and every certified box must hold the ground truth; the exact truth certifies;
//! points moved off the truth are certified only with a box that holds it. Seeds are the scene
//! seeds `0..1000` of each sampler (printed with any failure).
//!
//! Rows: UPnP's tracked instance has 5 equations in 4 unknowns (the gradient condition, whose
//! component along `q` vanishes on the sphere, and `q.q = 1`); GRPS 8 has 9 (8 correspondences
//! and `q.q = 1`). Both are certified on the rows [`choose_rows`] picks at the point; GRPS is
//! also certified as the square tracked instance `Grps7` on its first 7 correspondences. Both
//! systems are invariant under `q -> -q`, so the truth is `±q`.

use nalgebra::SVector;
use simhc::certify::{certify, certify_rows, choose_rows, Certificate};
use simhc_problems::grps::declared::params_of as grps_params;
use simhc_problems::grps::declared::GrpsSolvers;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{unknowns_of, Grps7, Grps8};
use simhc_problems::metrics::quat_from_rotation;
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::upnp::{params_of as upnp_params, Upnp};

/// `x` with its quaternion (the first 4 entries) negated.
fn flipped<const N: usize>(x: &SVector<f64, N>) -> SVector<f64, N> {
    let mut y = *x;
    for k in 0..4 {
        y[k] = -y[k];
    }
    y
}

/// Whether the certificate's box holds the truth `±q`.
fn holds_truth<const N: usize>(cert: &Certificate<N>, truth: &SVector<f64, N>) -> bool {
    cert.box_contains(truth) || cert.box_contains(&flipped(truth))
}

#[derive(Debug, Default)]
struct Tally {
    solved: usize,
    certified: usize,
    wrong: usize,
    truth_certified: usize,
}

#[test]
fn upnp_noise_free_answers_certify_and_no_certificate_misses_the_truth() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
    let mut t = Tally::default();
    for seed in 0..1000u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let p = upnp_params(&upnp_system(&scene.correspondences).expect("valid scene").m);
        let truth = SVector::<f64, 4>::from(quat_from_rotation(&scene.rotation));
        let rows = choose_rows::<Upnp, 4, 5, 66>(&truth, &p).expect("independent rows at the truth");
        if certify_rows::<Upnp, 4, 5, 66>(&truth, &p, &rows).is_ok_and(|c| holds_truth(&c, &truth)) {
            t.truth_certified += 1;
        }
        let Ok(solution) = solver.solve(&scene.correspondences[..]) else { continue };
        t.solved += 1;
        let x = solution.x;
        let Ok(rows) = choose_rows::<Upnp, 4, 5, 66>(&x, &p) else { continue };
        if let Ok(cert) = certify_rows::<Upnp, 4, 5, 66>(&x, &p, &rows) {
            t.certified += 1;
            if !holds_truth(&cert, &truth) {
                t.wrong += 1;
                println!("seed {seed}: certified box misses the truth: {cert:?}, truth {truth:?}");
            }
        }
    }
    println!("UPnP noise-free seeds 0..1000: {t:?}");
    assert_eq!(t.wrong, 0);
    // The truth of a noise-free scene is a simple root: it must certify (a scene whose truth
    // is nearly singular may not; none is among these seeds).
    assert!(t.truth_certified >= 990, "{t:?}");
    assert!(t.certified * 100 >= t.solved * 95, "{t:?}");
}

#[test]
fn grps8_noise_free_answers_certify_and_no_certificate_misses_the_truth() {
    let solver = GrpsSolvers::new(0.0).expect("shipped weights load");
    let config = GrpsSceneConfig::default(); // 8 points, noise-free
    let (mut data, mut tracked) = (Tally::default(), Tally::default());
    for seed in 0..1000u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let p8 = grps_params::<96>(&scene.correspondences).expect("8 correspondences");
        let p7 = grps_params::<84>(&scene.correspondences[..7]).expect("7 correspondences");
        let truth = unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        if choose_rows::<Grps8, 8, 9, 96>(&truth, &p8)
            .and_then(|rows| certify_rows::<Grps8, 8, 9, 96>(&truth, &p8, &rows))
            .is_ok_and(|c| holds_truth(&c, &truth))
        {
            data.truth_certified += 1;
        }
        if certify::<Grps7, 8, 8, 84>(&truth, &p7).is_ok_and(|c| holds_truth(&c, &truth)) {
            tracked.truth_certified += 1;
        }
        let Ok(solution) = solver.solve(&scene.correspondences) else { continue };
        data.solved += 1;
        tracked.solved += 1;
        let x = solution.x;
        if let Ok(cert) = choose_rows::<Grps8, 8, 9, 96>(&x, &p8).and_then(|rows| certify_rows::<Grps8, 8, 9, 96>(&x, &p8, &rows)) {
            data.certified += 1;
            if !holds_truth(&cert, &truth) {
                data.wrong += 1;
                println!("seed {seed}: Grps8 certified box misses the truth: {cert:?}, truth {truth:?}");
            }
        }
        if let Ok(cert) = certify::<Grps7, 8, 8, 84>(&x, &p7) {
            tracked.certified += 1;
            if !holds_truth(&cert, &truth) {
                tracked.wrong += 1;
                println!("seed {seed}: Grps7 certified box misses the truth: {cert:?}, truth {truth:?}");
            }
        }
    }
    println!("GRPS 8 points noise-free seeds 0..1000: Grps8 chosen rows {data:?}; Grps7 first 7 {tracked:?}");
    assert_eq!(data.wrong + tracked.wrong, 0);
    assert!(data.truth_certified >= 990 && tracked.truth_certified >= 990, "{data:?} {tracked:?}");
    assert!(data.certified * 100 >= data.solved * 95, "{data:?}");
}

#[test]
fn points_off_the_truth_certify_only_with_a_box_that_holds_it() {
    // GRPS scenes 0..50, the truth moved by 1e-12 .. 1e-2 (relative) in a seeded direction:
    // any certificate must hold the truth, and the small moves must certify.
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    println!("seed 2026, scenes 0..50");
    let config = GrpsSceneConfig::default();
    let (mut certified, mut small, mut small_certified) = (0, 0, 0);
    for seed in 0..50u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let p7 = grps_params::<84>(&scene.correspondences[..7]).expect("7 correspondences");
        let truth = unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        for k in 0..20 {
            let size = 10f64.powf(-12.0 + 10.0 * k as f64 / 20.0);
            let x = truth + SVector::<f64, 8>::from_fn(|i, _| rng.random_range(-1.0..1.0) * size * truth[i].abs().max(1.0));
            let result = certify::<Grps7, 8, 8, 84>(&x, &p7);
            if let Ok(cert) = result {
                certified += 1;
                assert!(holds_truth(&cert, &truth), "scene {seed}, move {size:e}: {cert:?}");
            }
            if size <= 1e-8 {
                small += 1;
                small_certified += usize::from(result.is_ok());
            }
        }
    }
    println!("{certified}/1000 moved points certified; {small_certified}/{small} of those moved by at most 1e-8");
    assert!(small_certified * 100 >= small * 95, "{small_certified}/{small}");
}
