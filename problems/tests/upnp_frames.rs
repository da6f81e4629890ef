//! Frame invariance of the UPnP library solver (proptest): the pose transforms exactly with any
//! rigid change of the world and viewer frames and with any order of the correspondences.

use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use simhc_problems::upnp::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::pose::UpnpPose;
use simhc_problems::upnp::scene::{random_rotation, PointBox, UpnpScene, UpnpSceneConfig};

/// A rigid frame change `x -> rotation x + translation`.
type Rigid = (Matrix3<f64>, Vector3<f64>);

fn frames(seed: u64) -> (Rigid, Rigid) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let w = random_rotation(&mut rng);
    let v = random_rotation(&mut rng);
    let tw = Vector3::new(3.0, -7.0, 11.0) * ((seed % 5) as f64 - 2.0);
    let tv = Vector3::new(-5.0, 2.0, 1.0) * ((seed % 3) as f64 - 1.0);
    ((w, tw), (v, tv))
}

/// The pose of the original scene mapped into the transformed frames.
fn mapped(pose: &UpnpPose, world: &Rigid, viewer: &Rigid) -> Rigid {
    let rw = pose.rotation * world.0.transpose();
    (viewer.0 * rw, viewer.0 * (pose.translation - rw * world.1) + viewer.1)
}

fn check(scene: &UpnpScene, frame_seed: u64, shift: usize, tol: f64) -> Result<(), TestCaseError> {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let (world, viewer) = frames(frame_seed);
    let mut moved = scene.transformed((&world.0, &world.1), (&viewer.0, &viewer.1));
    moved.correspondences.rotate_left(shift % scene.correspondences.len());
    let pose = |corrs: &[_]| solver.solve(corrs).map(|s| upnp_pose(&s.x, corrs).expect("a pose"));
    let a = pose(&scene.correspondences[..]);
    let b = pose(&moved.correspondences[..]);
    // The shipped solver validated 1000 / 1000 trials of every distribution in `simhc bench upnp`.
    prop_assert!(a.is_ok() && b.is_ok(), "not validated: {:?} / {:?}", a.as_ref().err(), b.as_ref().err());
    if let (Ok(a), Ok(b)) = (a, b) {
        let (r, t) = mapped(&a, &world, &viewer);
        prop_assert!((r - b.rotation).amax() < tol, "rotation differs by {:e}", (r - b.rotation).amax());
        let scale = 1.0 + t.norm();
        prop_assert!((t - b.translation).amax() < tol * scale, "translation differs by {:e}", (t - b.translation).amax());
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn noise_free_poses_follow_the_frames(seed in 0u64..1_000_000, frame_seed in 0u64..1_000_000, shift in 0usize..16, world_box in any::<bool>()) {
        let layout = if world_box { PointBox::World } else { PointBox::Viewer };
        let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
        let scene = config.sample_with(layout, false, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed)).expect("valid config");
        check(&scene, frame_seed, shift, 1e-9)?;
    }

    #[test]
    fn noisy_poses_follow_the_frames(seed in 0u64..1_000_000, frame_seed in 0u64..1_000_000, shift in 0usize..16, world_box in any::<bool>()) {
        // With noise the pose is the cost's minimum, which the frames do not change: both
        // solves must land on it.
        let layout = if world_box { PointBox::World } else { PointBox::Viewer };
        let scene = UpnpSceneConfig::default().sample_with(layout, false, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed)).expect("valid config");
        check(&scene, frame_seed, shift, 1e-7)?;
    }
}
