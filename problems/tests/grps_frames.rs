//! Frame invariance of the shipped 8-point GRPS solver ([`GrpsSolvers`], proptest): the pose transforms exactly
//! with rigid changes of either view's frame, with a change of units of view 2, and with any
//! order of the correspondences.
//!
//! With `f1 = V1 f + 0`, `v1 = V1 v + t1` (view 1) and `fp2 = V2 fp`, `vp2 = c V2 vp + t2`
//! (view 2, new units: one new unit is `1/c` old ones), the relation
//! `alpha f + v = R (alpha' fp + s vp) + t` holds with
//! `R' = V1 R V2^T`, `s' = s / c`, `t' = V1 t + t1 - s' R' t2`.

use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use simhc_problems::grps::declared::GrpsSolvers;
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::scene::{GrpsCorrespondence, GrpsSceneConfig};
use simhc_problems::upnp::scene::random_rotation;

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn noise_free_poses_follow_the_frames(seed in 0u64..1_000_000, frame_seed in 0u64..1_000_000, shift in 0usize..8, units in 0.2f64..5.0) {
        let solvers = GrpsSolvers::new(0.0).expect("shipped weights load");
        let solve = |c: &[GrpsCorrespondence]| solvers.solve(c).map(|s| GrpsPose::from_unknowns(&s.x).expect("a pose"));
        let scene = GrpsSceneConfig::default().sample_seeded(seed).expect("valid config");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(frame_seed);
        let (v1, v2) = (random_rotation(&mut rng), random_rotation(&mut rng));
        let t1 = Vector3::new(3.0, -2.0, 7.0) * ((frame_seed % 5) as f64 - 2.0);
        let t2 = Vector3::new(-1.0, 4.0, 0.5) * ((frame_seed % 3) as f64 - 1.0);
        let mut moved: Vec<GrpsCorrespondence> = scene
            .correspondences
            .iter()
            .map(|c| GrpsCorrespondence { f: v1 * c.f, v: v1 * c.v + t1, fp: v2 * c.fp, vp: v2 * c.vp * units + t2 })
            .collect();
        moved.rotate_left(shift);
        let a = solve(&scene.correspondences);
        let b = solve(&moved);
        // Noise-free 8-point scenes always validate (1000 / 1000 in `simhc bench grps`).
        prop_assert!(a.is_ok() && b.is_ok(), "not validated: {:?} / {:?}", a.err(), b.err());
        if let (Ok(a), Ok(b)) = (a, b) {
            let r: Matrix3<f64> = v1 * a.rotation * v2.transpose();
            let s = a.scale / units;
            let t = v1 * a.translation + t1 - r * t2 * s;
            prop_assert!((r - b.rotation).amax() < 1e-8, "rotation differs by {:e}", (r - b.rotation).amax());
            prop_assert!((s - b.scale).abs() < 1e-8 * s, "scale {} vs {}", s, b.scale);
            prop_assert!((t - b.translation).amax() < 1e-8 * (1.0 + t.norm()), "translation differs by {:e}", (t - b.translation).amax());
        }
    }
}
