//! UPnP geometry: cost matrix, translation recovery, gradient, simulator, sampler, errors.
//! Every randomized test uses fixed seeds and prints them.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc_problems::metrics::{quat_from_rotation, random_rotation_perturbation, random_unit_quaternion, rotation_from_quat};
use simhc_problems::upnp::geometry::{
    object_space_cost, reproject, reproject_in_place, translation_from_rotation, upnp_cost, upnp_cost_gradient, upnp_cost_matrix,
    upnp_system, validate, UpnpError,
};
use simhc_problems::upnp::scene::{UpnpCorrespondence, UpnpSceneConfig};

fn rng(seed: u64) -> ChaCha8Rng {
    println!("seed {seed}");
    ChaCha8Rng::seed_from_u64(seed)
}

/// Independent reference: min over t of sum ||(I - f f^T)(R p + t - v)||², t from a 3x3 solve.
fn reference_cost(r: &Matrix3<f64>, corrs: &[UpnpCorrespondence]) -> f64 {
    let mut h = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for c in corrs {
        let f = c.f.normalize();
        let v = Matrix3::identity() - f * f.transpose();
        h += v;
        b += v * (r * c.p - c.v);
    }
    let t = -h.lu().solve(&b).unwrap();
    corrs
        .iter()
        .map(|c| {
            let f = c.f.normalize();
            let e = r * c.p + t - c.v;
            (e - f * f.dot(&e)).norm_squared()
        })
        .sum()
}

fn configs() -> Vec<UpnpSceneConfig> {
    vec![
        UpnpSceneConfig::default(),
        UpnpSceneConfig { cameras: 1, points: 6, ..Default::default() }, // central
        UpnpSceneConfig { cameras: 3, points: 3, ..Default::default() }, // minimal
        UpnpSceneConfig { cameras: 5, points: 40, noise_px: 10.0, ..Default::default() },
    ]
}

#[test]
fn quadratic_form_equals_direct_cost() {
    for (k, cfg) in configs().into_iter().enumerate() {
        let seed = 100 + k as u64;
        let mut rng = rng(seed);
        let mut worst: f64 = 0.0;
        for _ in 0..50 {
            let scene = cfg.sample(&mut rng).unwrap();
            let sys = upnp_system(&scene.correspondences).unwrap();
            assert_eq!(sys.m, sys.m.transpose());
            for _ in 0..10 {
                let q = random_unit_quaternion(&mut rng);
                let r = rotation_from_quat(q);
                let want = reference_cost(&r, &scene.correspondences);
                let via_m = sys.cost(q);
                let direct = upnp_cost(q, &scene.correspondences).unwrap();
                let scale = want.abs().max(1e-300);
                worst = worst.max((via_m - want).abs() / scale);
                assert!((via_m - want).abs() <= 1e-9 * scale, "seed {seed}: {via_m} vs {want}");
                assert!((direct - want).abs() <= 1e-9 * scale, "seed {seed}: {direct} vs {want}");
                // Translation map agrees with the direct linear solve.
                let t1 = sys.translation(q);
                let t2 = translation_from_rotation(&r, &scene.correspondences).unwrap();
                assert!((t1 - t2).norm() <= 1e-9 * (1.0 + t2.norm()));
                assert!((object_space_cost(&r, &t2, &scene.correspondences) - want).abs() <= 1e-9 * scale);
            }
        }
        println!("config {k}: worst relative error of s^T M s {worst:e}");
    }
}

#[test]
fn cost_matrix_is_psd() {
    let mut rng = rng(200);
    for _ in 0..100 {
        let scene = UpnpSceneConfig::default().sample(&mut rng).unwrap();
        let m = upnp_cost_matrix(&scene.correspondences).unwrap();
        let eig = SymmetricEigen::new(m);
        assert!(eig.eigenvalues.min() >= -1e-10 * m.trace(), "{}", eig.eigenvalues.min());
    }
}

#[test]
fn ground_truth_is_exact_on_noise_free_scenes() {
    for (k, cfg) in configs().into_iter().enumerate() {
        let cfg = UpnpSceneConfig { noise_px: 0.0, ..cfg };
        let seed = 300 + k as u64;
        let mut rng = rng(seed);
        let (mut worst_cost, mut worst_t): (f64, f64) = (0.0, 0.0);
        for _ in 0..100 {
            let scene = cfg.sample(&mut rng).unwrap();
            let corrs = &scene.correspondences;
            let sys = upnp_system(corrs).unwrap();
            let q = quat_from_rotation(&scene.rotation);
            let (cost, grad) = sys.cost_gradient(q);
            let scale = sys.m.trace();
            worst_cost = worst_cost.max(cost.abs() / scale);
            assert!(cost.abs() <= 1e-12 * scale, "seed {seed}: cost {cost:e}, trace {scale:e}");
            assert!(grad.iter().all(|g| g.abs() <= 1e-10 * scale), "seed {seed}: {grad:?}");
            let t = translation_from_rotation(&scene.rotation, corrs).unwrap();
            worst_t = worst_t.max((t - scene.translation).norm());
            assert!((t - scene.translation).norm() <= 1e-9, "seed {seed}: {t} vs {}", scene.translation);
            assert!((sys.translation(q) - scene.translation).norm() <= 1e-9);
            // The model alpha f + v = R p + t with positive depths.
            for c in corrs {
                let x = scene.rotation * c.p + scene.translation - c.v;
                assert!(x.dot(&c.f) > 0.0);
                assert!((x.normalize() - c.f).norm() <= 1e-12);
            }
        }
        println!("config {k}: worst cost/trace(M) at truth {worst_cost:e}, worst |t - t_gt| {worst_t:e}");
    }
}

#[test]
fn gradient_via_matrix_matches_direct_and_finite_differences() {
    let mut rng = rng(400);
    for _ in 0..30 {
        let scene = UpnpSceneConfig::default().sample(&mut rng).unwrap();
        let corrs = &scene.correspondences;
        let sys = upnp_system(corrs).unwrap();
        let q = random_unit_quaternion(&mut rng);
        let (e1, g1) = sys.cost_gradient(q);
        let (e2, g2) = upnp_cost_gradient(q, corrs).unwrap();
        let gscale = g2.iter().map(|g| g.abs()).fold(0.0, f64::max) + 1e-12 * e2;
        assert!((e1 - e2).abs() <= 1e-9 * e2);
        for k in 0..4 {
            assert!((g1[k] - g2[k]).abs() <= 1e-8 * gscale, "{g1:?} vs {g2:?}");
            assert!((g2.iter().zip(q.iter()).map(|(a, b)| a * b).sum::<f64>()).abs() <= 1e-12 * gscale);
        }
        // Central differences along a tangent direction (the cost normalizes q).
        let mut d: [f64; 4] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let dq: f64 = d.iter().zip(q.iter()).map(|(a, b)| a * b).sum();
        d = std::array::from_fn(|k| d[k] - dq * q[k]);
        let h = 1e-6;
        let plus = std::array::from_fn(|k| q[k] + h * d[k]);
        let minus = std::array::from_fn(|k| q[k] - h * d[k]);
        let fd = (upnp_cost(plus, corrs).unwrap() - upnp_cost(minus, corrs).unwrap()) / (2.0 * h);
        let an: f64 = g2.iter().zip(d.iter()).map(|(a, b)| a * b).sum();
        let dn = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((fd - an).abs() <= 1e-5 * (gscale * dn + e2), "fd {fd} vs {an}");
    }
}

#[test]
fn reprojection_simulator() {
    let mut rng = rng(500);
    for k in 0..100 {
        // Under the true pose of a noise-free scene the bearings come back unchanged.
        let scene = UpnpSceneConfig { noise_px: 0.0, ..Default::default() }.sample(&mut rng).unwrap();
        let back = reproject(&scene.rotation, &scene.translation, &scene.correspondences).unwrap();
        for (a, b) in back.iter().zip(&scene.correspondences) {
            assert!((a.f - b.f).norm() <= 1e-12 && a.p == b.p && a.v == b.v);
        }
        // Under a perturbed pose of a noisy scene the predicted pose solves the simulated problem.
        let noisy = UpnpSceneConfig::default().sample(&mut rng).unwrap();
        let r = random_rotation_perturbation(&noisy.rotation, 2.0 + k as f64 * 0.4, &mut rng);
        let t = noisy.translation + Vector3::new(0.1, -0.2, 0.05);
        let mut sim = noisy.correspondences.clone();
        reproject_in_place(&r, &t, &mut sim).unwrap();
        let sys = upnp_system(&sim).unwrap();
        let q = quat_from_rotation(&r);
        let (cost, grad) = sys.cost_gradient(q);
        assert!(cost.abs() <= 1e-12 * sys.m.trace() && grad.iter().all(|g| g.abs() <= 1e-10 * sys.m.trace()));
        assert!((translation_from_rotation(&r, &sim).unwrap() - t).norm() <= 1e-9);
        assert!(sim.iter().all(|c| (c.f.norm() - 1.0).abs() <= 1e-15));
    }
}

#[test]
fn sampler_follows_the_paper() {
    let cfg = UpnpSceneConfig::default();
    let seed = 600;
    println!("seed {seed}");
    let a = cfg.sample_seeded(seed).unwrap();
    assert_eq!(a, cfg.sample_seeded(seed).unwrap(), "same seed, same scene");
    assert_ne!(a, cfg.sample_seeded(seed + 1).unwrap());
    // Same geometry for a different noise level; the noise stays within the pixel bound.
    let clean = UpnpSceneConfig { noise_px: 0.0, ..cfg }.sample_seeded(seed).unwrap();
    let bound = (cfg.noise_px / cfg.focal_px).atan();
    let mut max_angle: f64 = 0.0;
    for (n, c) in a.correspondences.iter().zip(&clean.correspondences) {
        assert_eq!((n.p, n.v), (c.p, c.v));
        let angle = n.f.cross(&c.f).norm().atan2(n.f.dot(&c.f));
        assert!(angle <= bound * (1.0 + 1e-9));
        max_angle = max_angle.max(angle);
    }
    assert!(max_angle > 0.1 * bound);
    assert_eq!(a.rotation, clean.rotation);
    let mut rng = rng(601);
    for _ in 0..200 {
        let s = cfg.sample(&mut rng).unwrap();
        assert_eq!(s.correspondences.len(), 16);
        assert!((s.rotation.transpose() * s.rotation - Matrix3::identity()).norm() < 1e-14);
        assert!((s.rotation.determinant() - 1.0).abs() < 1e-14);
        assert!(s.translation.amax() <= 1.0);
        for (i, c) in s.correspondences.iter().enumerate() {
            let x = s.rotation * c.p + s.translation; // viewer frame
            assert!(x.x.abs() <= 1.0 + 1e-12 && x.y.abs() <= 1.0 + 1e-12);
            assert!((4.0 - 1e-12..=8.0 + 1e-12).contains(&x.z));
            assert!(c.v.amax() <= 1.0);
            assert_eq!(c.v, s.correspondences[i % 4].v, "round robin");
            assert!((c.f.norm() - 1.0).abs() < 1e-15);
        }
        let distinct: std::collections::HashSet<_> =
            s.correspondences.iter().map(|c| c.v.iter().map(|x| x.to_bits()).collect::<Vec<_>>()).collect();
        assert_eq!(distinct.len(), 4);
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let scene = UpnpSceneConfig::default().sample_seeded(700).unwrap();
    let good = scene.correspondences;
    assert_eq!(validate(&good), Ok(()));
    assert_eq!(upnp_cost_matrix(&good[..2]).unwrap_err(), UpnpError::TooFewCorrespondences { got: 2, need: 3 });
    assert_eq!(upnp_system(&[]).unwrap_err(), UpnpError::TooFewCorrespondences { got: 0, need: 3 });
    assert!(upnp_cost_matrix(&good[..3]).is_ok());

    let mut bad = good.clone();
    bad[5].p.y = f64::NAN;
    assert_eq!(upnp_cost_matrix(&bad).unwrap_err(), UpnpError::NonFinite { index: 5 });
    assert_eq!(reproject(&scene.rotation, &scene.translation, &bad).unwrap_err(), UpnpError::NonFinite { index: 5 });
    let mut bad = good.clone();
    bad[2].v.z = f64::INFINITY;
    assert_eq!(translation_from_rotation(&scene.rotation, &bad).unwrap_err(), UpnpError::NonFinite { index: 2 });
    let mut bad = good.clone();
    bad[7].f = Vector3::zeros();
    assert_eq!(upnp_cost_matrix(&bad).unwrap_err(), UpnpError::ZeroBearing { index: 7 });
    assert_eq!(upnp_cost([1.0, 0.0, 0.0, 0.0], &bad).unwrap_err(), UpnpError::ZeroBearing { index: 7 });

    // All bearings parallel (from one or several centres): translation along them undetermined.
    let mut bad = good.clone();
    for c in &mut bad {
        c.f = Vector3::new(0.2, -0.3, 1.0).normalize();
    }
    assert_eq!(upnp_cost_matrix(&bad).unwrap_err(), UpnpError::Degenerate);
    assert_eq!(translation_from_rotation(&scene.rotation, &bad).unwrap_err(), UpnpError::Degenerate);

    // A point on its ray origin under the pose cannot be reprojected.
    let mut bad = good.clone();
    bad[4].v = scene.rotation * bad[4].p + scene.translation;
    assert_eq!(reproject(&scene.rotation, &scene.translation, &bad).unwrap_err(), UpnpError::ZeroBearing { index: 4 });
    // Non-finite pose or quaternion.
    let nan_r = scene.rotation * f64::NAN;
    assert_eq!(reproject(&nan_r, &scene.translation, &good).unwrap_err(), UpnpError::NonFinite { index: usize::MAX });
    assert_eq!(upnp_cost([0.0; 4], &good).unwrap_err(), UpnpError::NonFinite { index: usize::MAX });
    assert_eq!(upnp_cost([f64::NAN, 0.0, 0.0, 1.0], &good).unwrap_err(), UpnpError::NonFinite { index: usize::MAX });
    // Bad sampler settings.
    assert!(UpnpSceneConfig { cameras: 0, ..Default::default() }.sample_seeded(1).is_err());
    assert!(UpnpSceneConfig { points: 0, ..Default::default() }.sample_seeded(1).is_err());
    assert!(UpnpSceneConfig { noise_px: -1.0, ..Default::default() }.sample_seeded(1).is_err());
    assert!(UpnpSceneConfig { focal_px: 0.0, ..Default::default() }.sample_seeded(1).is_err());
}

#[test]
fn unnormalized_bearings_are_accepted() {
    let mut rng = rng(800);
    let scene = UpnpSceneConfig::default().sample(&mut rng).unwrap();
    let scaled: Vec<_> = scene.correspondences.iter().map(|c| UpnpCorrespondence { f: c.f * rng.random_range(0.1..10.0), ..*c }).collect();
    let a = upnp_cost_matrix(&scene.correspondences).unwrap();
    let b = upnp_cost_matrix(&scaled).unwrap();
    assert!((a - b).norm() <= 1e-10 * a.norm());
}
