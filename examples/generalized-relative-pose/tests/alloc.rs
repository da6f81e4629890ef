//! A user's problem with a canonical frame, solved by the library solver without a heap
//! allocation: the frame's maps are held inline (`simhc::solver::CanonicalFrame`), so a solve
//! that does not reach the all-roots fallback allocates nothing, in the user's frame or in
//! random frames.

#[path = "../../../simhc/tests/counting_alloc/mod.rs"]
mod counting_alloc;

use counting_alloc::counted;
use generalized_relative_pose::{canonicalize, move_frames, scene, GenRelPose};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::solver::SolverOrigin;

#[test]
fn a_solve_in_a_canonical_frame_allocates_nothing() {
    let seed = 32;
    println!("seed {seed}");
    let solver = simhc::solver::Solver::new(GenRelPose::new()).expect("shipped weights");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut paths, mut allocations) = (0, 0);
    for k in 0..40 {
        let (p, x) = scene(&mut rng, 0.0);
        let (p, _) = if k % 2 == 1 { move_frames(&mut rng, &p, &x) } else { (p, x) };
        assert!(canonicalize(&p).expect("a frame").1.is_inline(), "the frame's maps fit inline");
        let (result, n) = counted(|| solver.solve(&p));
        if matches!(result.map(|s| s.origin), Ok(SolverOrigin::Attempt(_))) {
            paths += 1;
            allocations += n;
        }
    }
    println!("{paths} of 40 solved short of the fallback");
    assert!(paths >= 36, "{paths} of 40");
    assert_eq!(allocations, 0, "allocations over {paths} solves");
}
