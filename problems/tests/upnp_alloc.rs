//! The UPnP library solver allocates nothing on its common path: a solve that Gauss-Newton
//! from the linear start validates (the check, the cost matrix, the linear start, Gauss-Newton
//! and the validation are all fixed-size). The learned start (its input rows), the simulator
//! (the reprojected correspondences) and the fallback allocate; they run only when that
//! attempt fails.

#[path = "../../simhc/tests/counting_alloc/mod.rs"]
mod counting_alloc;

use counting_alloc::counted;
use simhc::pipeline::{Method, Origin};
use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpSceneConfig;

#[test]
fn a_solve_validated_by_the_linear_start_allocates_nothing() {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig::default(); // 2 px
    let scenes: Vec<_> = (0..50).map(|seed| config.sample_seeded(2000 + seed).expect("valid config").correspondences).collect();
    let linear_gn = Origin::Path { provider: 3, method: Method::GaussNewton };
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
    // The counter is armed: a solve that needs the learned start allocates its rows.
    let learned_only = UpnpLibrarySolver::new(UpnpProblem { linear_start: false, ..UpnpProblem::default() }).expect("weights");
    let (result, n) = counted(|| learned_only.solve(&scenes[0][..]));
    assert!(result.is_ok() && n > 0, "{n} allocations from the learned start");
}
