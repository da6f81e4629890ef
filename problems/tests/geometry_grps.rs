//! GRPS geometry: sampler and ground truth, the depth-free constraint, triangulation, the
//! geometric and minimal-angle simulators, degeneracies and errors.
//! Every randomized test uses fixed seeds and prints them.

use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc_problems::grps::geometry::{
    grps_residual_direct, project_first_view, simulate_first_view, simulate_first_view_in_place, triangulate_depths, validate, GrpsError,
};
use simhc_problems::grps::scene::{GrpsCorrespondence, GrpsScene, GrpsSceneConfig};
use simhc_problems::metrics::{perturb_scale, perturb_translation, random_rotation_perturbation};

fn rng(seed: u64) -> ChaCha8Rng {
    println!("seed {seed}");
    ChaCha8Rng::seed_from_u64(seed)
}

fn configs() -> Vec<GrpsSceneConfig> {
    vec![
        GrpsSceneConfig::default(),
        GrpsSceneConfig { points: 7, ..Default::default() },
        GrpsSceneConfig { points: 20, cameras_per_view: 5, ..Default::default() },
        GrpsSceneConfig { points: 9, cameras_per_view: 2, ..Default::default() },
    ]
}

/// Scale of the terms of the constraint, for relative tolerances.
fn term_scale(t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> f64 {
    1.0 + t.norm() + s * c.vp.norm() + c.v.norm()
}

/// Same as the paper's constraint, written independently with explicit skew matrices.
fn constraint_skew(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> f64 {
    let skew = |v: &Vector3<f64>| Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0);
    let rf2 = r * c.fp;
    t.dot(&c.f.cross(&rf2)) - s * (c.f.transpose() * r * skew(&c.vp) * c.fp)[0] + (c.f.transpose() * skew(&c.v) * rf2)[0]
}

#[test]
fn noise_free_scenes_satisfy_the_model() {
    for (k, cfg) in configs().into_iter().enumerate() {
        let seed = 1000 + k as u64;
        let mut rng = rng(seed);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let scene = cfg.sample(&mut rng).unwrap();
            let (r, t, s) = (scene.rotation, scene.translation, scene.scale);
            assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-14);
            assert!((r.determinant() - 1.0).abs() < 1e-14);
            assert!((0.1..=5.0).contains(&s));
            assert_eq!(scene.correspondences.len(), cfg.points);
            for (i, c) in scene.correspondences.iter().enumerate() {
                let res = grps_residual_direct(&r, &t, s, c);
                worst = worst.max(res.abs());
                assert!(res.abs() <= 1e-10, "seed {seed}: residual {res:e}");
                assert!((res - constraint_skew(&r, &t, s, c)).abs() <= 1e-12 * term_scale(&t, s, c));
                // alpha f + v = R (alpha' f' + s v') + t with positive depths.
                let (a, a2) = triangulate_depths(&r, &t, s, c).unwrap();
                assert!(a > 0.0 && a2 > 0.0, "seed {seed}: depths {a} {a2}");
                let gap = c.f * a + c.v - (r * (c.fp * a2 + c.vp * s) + t);
                assert!(gap.norm() <= 1e-10 * (1.0 + a + a2), "seed {seed}: gap {gap}");
                // Offsets in [-1, 1]³ of each view; round robin over cameras in both views.
                assert!(c.v.amax() <= 1.0 && c.vp.amax() <= 1.0);
                let first = &scene.correspondences[i % cfg.cameras_per_view];
                assert_eq!((c.v, c.vp), (first.v, first.vp));
                assert!((c.f.norm() - 1.0).abs() < 1e-15 && (c.fp.norm() - 1.0).abs() < 1e-15);
            }
            assert_eq!(validate(&scene.correspondences), Ok(()));
        }
        println!("config {k}: worst |residual| at truth {worst:e}");
    }
}

/// Rebuilds the world from the documented generative model, independently of the sampler's
/// bookkeeping: view poses are recovered as X = R1 Y1 + o1 etc. through the relation itself.
#[test]
fn ground_truth_maps_view2_into_view1() {
    let mut rng = rng(1100);
    for _ in 0..100 {
        let scene = GrpsSceneConfig::default().sample(&mut rng).unwrap();
        let (r, t, s) = (scene.rotation, scene.translation, scene.scale);
        for c in &scene.correspondences {
            let (a, a2) = triangulate_depths(&r, &t, s, c).unwrap();
            // Point in view 2's own units and in view 1.
            let y2 = c.fp * (a2 / s) + c.vp;
            let y1 = c.f * a + c.v;
            assert!((r * (y2 * s) + t - y1).norm() <= 1e-9 * (1.0 + y1.norm()));
        }
        // A wrong scale or translation breaks the constraint (the model is not trivially satisfied).
        let bad = scene.correspondences.iter().map(|c| grps_residual_direct(&r, &(t * 1.1), s * 0.9, c).abs());
        assert!(bad.fold(0.0, f64::max) > 1e-6);
    }
}

fn perturbed_pose<R: Rng>(scene: &GrpsScene, theta_deg: f64, rho: f64, rng: &mut R) -> (Matrix3<f64>, Vector3<f64>, f64) {
    (
        random_rotation_perturbation(&scene.rotation, theta_deg, rng),
        perturb_translation(&scene.translation, rho, rng),
        perturb_scale(scene.scale, rho, rng),
    )
}

#[test]
fn geometric_simulator_is_exact_for_perturbed_poses() {
    for (k, cfg) in configs().into_iter().enumerate() {
        let seed = 1200 + k as u64;
        let mut rng = rng(seed);
        let (mut flipped, mut behind2, mut total, mut worst) = (0usize, 0usize, 0usize, 0.0f64);
        for trial in 0..300 {
            let noisy = trial % 2 == 1;
            let cfg = GrpsSceneConfig { noise_px: if noisy { 1.0 } else { 0.0 }, ..cfg };
            let scene = cfg.sample(&mut rng).unwrap();
            let theta = [5.0, 10.0, 20.0, 30.0, 45.0][trial % 5];
            let (r, t, s) = perturbed_pose(&scene, theta, 0.1, &mut rng);
            let sim = simulate_first_view(&r, &t, s, &scene.correspondences).unwrap();
            assert_eq!(sim.correspondences.len(), scene.correspondences.len());
            for ((c, orig), info) in sim.correspondences.iter().zip(&scene.correspondences).zip(&sim.info) {
                let res = grps_residual_direct(&r, &t, s, c);
                let rel = res.abs() / term_scale(&t, s, c);
                worst = worst.max(rel);
                assert!(rel <= 1e-12, "seed {seed}: residual {res:e}");
                assert_eq!((c.v, c.fp, c.vp), (orig.v, orig.fp, orig.vp));
                assert!((c.f.norm() - 1.0).abs() <= 1e-15);
                assert!(!info.parallel);
                // The flip keeps the simulated ray on the side of the measured one.
                assert_eq!(info.behind_first, info.alpha < 0.0);
                assert!(c.f.dot(&orig.f) >= 0.0);
                flipped += info.behind_first as usize;
                behind2 += info.behind_second as usize;
                total += 1;
            }
        }
        println!(
            "config {k}: worst relative residual {worst:e}; behind first camera {:.1}%, behind second {:.1}%",
            100.0 * flipped as f64 / total as f64,
            100.0 * behind2 as f64 / total as f64
        );
    }
}

#[test]
fn simulator_at_the_truth_returns_the_measurements() {
    let mut rng = rng(1300);
    for _ in 0..100 {
        let scene = GrpsSceneConfig::default().sample(&mut rng).unwrap();
        let sim = simulate_first_view(&scene.rotation, &scene.translation, scene.scale, &scene.correspondences).unwrap();
        for ((a, b), info) in sim.correspondences.iter().zip(&scene.correspondences).zip(&sim.info) {
            assert!((a.f - b.f).norm() <= 1e-9, "{} vs {}", a.f, b.f);
            assert!(!info.behind_first && !info.behind_second && !info.parallel);
        }
        let proj = project_first_view(&scene.rotation, &scene.translation, scene.scale, &scene.correspondences).unwrap();
        for (a, b) in proj.iter().zip(&scene.correspondences) {
            assert!((a.f - b.f).norm() <= 1e-9);
        }
    }
}

#[test]
fn minimal_angle_simulator_is_exact_and_closest() {
    let mut rng = rng(1400);
    let mut buf = Vec::new();
    for trial in 0..200 {
        let scene = GrpsSceneConfig { noise_px: 0.5, ..Default::default() }.sample(&mut rng).unwrap();
        let (r, t, s) = perturbed_pose(&scene, 5.0 + (trial % 9) as f64 * 5.0, 0.1, &mut rng);
        let proj = project_first_view(&r, &t, s, &scene.correspondences).unwrap();
        let mut geo = scene.correspondences.clone();
        simulate_first_view_in_place(&r, &t, s, &mut geo, &mut buf).unwrap();
        assert_eq!(buf.len(), geo.len());
        for ((p, g), orig) in proj.iter().zip(&geo).zip(&scene.correspondences) {
            assert!(grps_residual_direct(&r, &t, s, p).abs() <= 1e-12 * term_scale(&t, s, p));
            let angle = |a: &Vector3<f64>| a.cross(&orig.f).norm().atan2(a.dot(&orig.f));
            assert!(angle(&p.f) <= angle(&g.f) + 1e-12);
        }
    }
}

#[test]
fn degenerate_camera_configurations() {
    let seed = 1500;
    println!("seed {seed}");
    // One camera per view: a single camera pair.
    let single = GrpsSceneConfig { cameras_per_view: 1, ..Default::default() }.sample_seeded(seed).unwrap();
    assert_eq!(validate(&single.correspondences), Err(GrpsError::SingleCameraPair));
    // One central view: the scale is unobservable, as the families in the docs show.
    let scene = GrpsSceneConfig::default().sample_seeded(seed).unwrap();
    let (r, t, s) = (scene.rotation, scene.translation, scene.scale);
    let mut central1 = scene.correspondences.clone();
    let v0 = central1[0].v;
    for c in &mut central1 {
        // Re-centre every view-1 ray on v0 while keeping the same 3D point.
        let (a, _) = triangulate_depths(&r, &t, s, c).unwrap();
        c.f = (c.f * a + c.v - v0).normalize();
        c.v = v0;
    }
    assert_eq!(validate(&central1), Err(GrpsError::CentralView { view: 1 }));
    for l in [0.5, 2.0, 7.0] {
        let t_l = v0 + (t - v0) * l;
        for c in &central1 {
            assert!(grps_residual_direct(&r, &t, s, c).abs() <= 1e-10);
            assert!(grps_residual_direct(&r, &t_l, l * s, c).abs() <= 1e-9, "lambda {l}");
        }
    }
    let mut central2 = scene.correspondences.clone();
    let w0 = central2[0].vp;
    for c in &mut central2 {
        let (_, a2) = triangulate_depths(&r, &t, s, c).unwrap();
        c.fp = (c.fp * (a2 / s) + c.vp - w0).normalize();
        c.vp = w0;
    }
    assert_eq!(validate(&central2), Err(GrpsError::CentralView { view: 2 }));
    for s2 in [0.3, 1.0, 4.0] {
        let t2 = t + r * w0 * (s - s2);
        for c in &central2 {
            assert!(grps_residual_direct(&r, &t, s, c).abs() <= 1e-10);
            assert!(grps_residual_direct(&r, &t2, s2, c).abs() <= 1e-9, "s2 {s2}");
        }
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let scene = GrpsSceneConfig::default().sample_seeded(1600).unwrap();
    let (r, t, s) = (scene.rotation, scene.translation, scene.scale);
    let good = scene.correspondences;
    assert_eq!(validate(&good[..6]), Err(GrpsError::TooFewCorrespondences { got: 6, need: 7 }));
    assert_eq!(validate(&[]), Err(GrpsError::TooFewCorrespondences { got: 0, need: 7 }));
    assert_eq!(validate(&good[..7]), Ok(()));
    let mut bad = good.clone();
    bad[3].vp.x = f64::NAN;
    assert_eq!(validate(&bad), Err(GrpsError::NonFinite { index: 3 }));
    assert_eq!(simulate_first_view(&r, &t, s, &bad).unwrap_err(), GrpsError::NonFinite { index: 3 });
    let mut bad = good.clone();
    bad[6].fp = Vector3::zeros();
    assert_eq!(validate(&bad), Err(GrpsError::ZeroBearing { index: 6 }));
    assert_eq!(project_first_view(&r, &t, s, &bad).unwrap_err(), GrpsError::ZeroBearing { index: 6 });
    let mut bad = good.clone();
    bad[1].f = Vector3::new(1e-13, 0.0, 0.0);
    assert_eq!(validate(&bad), Err(GrpsError::ZeroBearing { index: 1 }));
    let nan = GrpsError::NonFinite { index: usize::MAX };
    assert_eq!(simulate_first_view(&r, &t, f64::NAN, &good).unwrap_err(), nan);
    assert_eq!(simulate_first_view(&(r * f64::INFINITY), &t, s, &good).unwrap_err(), nan);
    // Bad sampler settings.
    assert!(GrpsSceneConfig { cameras_per_view: 0, ..Default::default() }.sample_seeded(1).is_err());
    assert!(GrpsSceneConfig { points: 0, ..Default::default() }.sample_seeded(1).is_err());
    assert!(GrpsSceneConfig { noise_px: f64::NAN, ..Default::default() }.sample_seeded(1).is_err());
}

#[test]
fn parallel_rays_fall_back_to_projection() {
    let scene = GrpsSceneConfig::default().sample_seeded(1700).unwrap();
    let (r, t, s) = (scene.rotation, scene.translation, scene.scale);
    let mut corrs = scene.correspondences.clone();
    // Make f exactly parallel to R f'.
    corrs[0].f = r * corrs[0].fp;
    let sim = simulate_first_view(&r, &t, s, &corrs).unwrap();
    assert!(sim.info[0].parallel && sim.info[0].alpha.is_nan());
    assert!(!sim.info[1].parallel);
    for c in &sim.correspondences {
        assert!(grps_residual_direct(&r, &t, s, c).abs() <= 1e-12 * term_scale(&t, s, c));
    }
    assert!(triangulate_depths(&r, &t, s, &corrs[0]).is_none());
}

#[test]
fn sampler_is_seeded_and_noise_is_bounded() {
    let cfg = GrpsSceneConfig { noise_px: 1.0, ..Default::default() };
    let seed = 1800;
    println!("seed {seed}");
    let a = cfg.sample_seeded(seed).unwrap();
    assert_eq!(a, cfg.sample_seeded(seed).unwrap());
    let clean = GrpsSceneConfig { noise_px: 0.0, ..cfg }.sample_seeded(seed).unwrap();
    assert_eq!((a.rotation, a.translation, a.scale), (clean.rotation, clean.translation, clean.scale));
    let bound = (cfg.noise_px / cfg.focal_px).atan() * (1.0 + 1e-9);
    let angle = |x: &Vector3<f64>, y: &Vector3<f64>| x.cross(y).norm().atan2(x.dot(y));
    for (n, c) in a.correspondences.iter().zip(&clean.correspondences) {
        assert_eq!((n.v, n.vp), (c.v, c.vp));
        assert!(angle(&n.f, &c.f) <= bound && angle(&n.fp, &c.fp) <= bound);
        assert!(n.f != c.f && n.fp != c.fp);
    }
}
