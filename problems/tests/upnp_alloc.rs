//! The UPnP library solver allocates nothing on its common paths: a solve that Gauss-Newton
//! from the linear start or from the learned start validates (the check, the cost matrix, the
//! starts, with the learned start's input rows on the stack up to 32 correspondences,
//! Gauss-Newton and the validation are all fixed-size), and a RANSAC sample, validated or not.
//! The simulator (the reprojected correspondences) and the fallback allocate; they run only
//! when those attempts fail.

#[path = "../../simhc/tests/counting_alloc/mod.rs"]
mod counting_alloc;

use counting_alloc::counted;
use simhc::pipeline::Method;
use simhc::solver::{SolverAttempt, SolverOrigin, StartId};
use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpSceneConfig;

#[test]
fn a_solve_validated_by_the_linear_start_allocates_nothing() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default(); // 2 px
    let scenes: Vec<_> = (0..50).map(|seed| config.sample_seeded(2000 + seed).expect("valid config").correspondences).collect();
    let linear_gn = SolverOrigin::Attempt(SolverAttempt::new(StartId::Other(0), Method::GaussNewton));
    let (mut common, mut allocations) = (0, 0);
    for (seed, corrs) in scenes.iter().enumerate() {
        let (result, n) = counted(|| solver.solve(&corrs[..]));
        let s = result.unwrap_or_else(|e| panic!("seed {}: {e}", 2000 + seed));
        if s.origin == linear_gn {
            common += 1;
            allocations += n;
        }
    }
    println!("seeds 2000..2050: {common} validated by Gauss-Newton from the linear start");
    assert!(common >= 45, "the common path is the linear start's Gauss-Newton: {common}/50");
    assert_eq!(allocations, 0, "allocations over {common} solves on the common path");
    // The learned start's Gauss-Newton allocates nothing either.
    let learned_only = UpnpLibrarySolver::new(UpnpProblem { linear_start: false, ..UpnpProblem::default() }).expect("weights");
    let learned_gn = SolverOrigin::Attempt(SolverAttempt::new(StartId::LEARNED, Method::GaussNewton));
    let (mut learned, mut learned_allocations) = (0, 0);
    for corrs in &scenes {
        let (result, n) = counted(|| learned_only.solve(&corrs[..]));
        if result.is_ok_and(|s| s.origin == learned_gn) {
            learned += 1;
            learned_allocations += n;
        }
    }
    println!("seeds 2000..2050: {learned} validated by Gauss-Newton from the learned start");
    assert!(learned >= 20, "the learned start's Gauss-Newton validated {learned}/50");
    assert_eq!(learned_allocations, 0, "allocations over {learned} solves from the learned start");
    // The counter is armed: the all-roots fallback allocates its candidates.
    let (result, n) = counted(|| solver.run_pipeline(&scenes[0][..], &[], true, None));
    assert!(result.is_ok() && n > 0, "{n} allocations from the fallback");
}

/// RANSAC samples (4 correspondences, a quarter of them wrong matches) allocate nothing,
/// whether they validate or not.
#[test]
fn a_ransac_sample_allocates_nothing() {
    use rand::{Rng, SeedableRng};
    use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
    let solver = UpnpLibrarySolver::new(UpnpProblem { max_angle: 0.01, ..UpnpProblem::default() }).expect("UPnP network");
    let config = UpnpSceneConfig { points: 100, noise_px: 1.0, ..UpnpSceneConfig::default() };
    let mut scene = config.sample_seeded(7).expect("valid config").correspondences;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for c in scene.iter_mut().step_by(4) {
        c.p.x += rng.random_range(2.0..4.0);
    }
    let mut out = Vec::with_capacity(8);
    let (mut kept, mut allocations) = (0, 0);
    for _ in 0..200 {
        let sample: Vec<usize> = rand::seq::index::sample(&mut rng, scene.len(), 4).into_vec();
        out.clear();
        let ((), n) = counted(|| solver.solve_sample(&scene, &sample, &mut out));
        kept += out.len();
        allocations += n;
    }
    println!("seed 7: {kept} of 200 samples gave a pose");
    assert!((10..200).contains(&kept), "{kept} of 200 samples gave a pose: both kinds must be counted");
    assert_eq!(allocations, 0, "allocations over 200 samples");
}
