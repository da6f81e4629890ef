//! The declared GRPS solve ([`Grps8Problem`] through the runtime's library solver) allocates
//! nothing unless it reaches the all-roots fallback: the canonical frame (its maps held inline,
//! `simhc::solver::CanonicalFrame`), the learned hypotheses, the predicted starts (on the
//! stack), the paths, the restarts and the validation are fixed-size, and a flagged end point
//! is returned without a box. So a RANSAC sample that does not validate allocates nothing
//! either.

#[path = "../../simhc/tests/counting_alloc/mod.rs"]
mod counting_alloc;

use counting_alloc::counted;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::Method;
use simhc::solver::{sample_schedule, Scenes, Solver, SolverAttempt, SolverOrigin, StartId};
use simhc_problems::grps::declared::Grps8Problem;
use simhc_problems::grps::learned::GrpsNetwork;
use simhc_problems::grps::scene::GrpsSceneConfig;

#[test]
fn a_solve_short_of_the_fallback_allocates_nothing() {
    let seed = 41;
    println!("seed {seed}");
    let solver = Solver::new(Grps8Problem::new()).expect("shipped weights");
    let problem = solver.problem();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut paths, mut later_than_first, mut allocations) = (0, 0, 0);
    for k in 0..60 {
        let (p, x) = problem.scene(&mut rng, 0.0);
        // Every other scene in random frames: the canonical frame's maps do real work.
        let p = if k % 2 == 1 { problem.move_frames(&mut rng, &p, &x).expect("a frame").0 } else { p };
        let (result, n) = counted(|| solver.solve(&p));
        match result.map(|s| s.origin) {
            Ok(SolverOrigin::Attempt(SolverAttempt { start, .. })) => {
                paths += 1;
                later_than_first += usize::from(!matches!(start, StartId::Learned { rank: 0, .. }));
                allocations += n;
            }
            other => println!("scene {k}: {other:?}, {n} allocations"),
        }
    }
    println!("{paths} of 60 solved short of the fallback, {later_than_first} by a start after the first hypothesis's");
    assert!(paths >= 55, "{paths} of 60");
    assert!(later_than_first > 0, "no solve reached the later starts: they are untested here");
    assert_eq!(allocations, 0, "allocations over {paths} solves");
}

#[test]
fn a_sample_that_does_not_validate_allocates_nothing() {
    let solver = Solver::new(Grps8Problem::new()).expect("shipped weights");
    let problem = solver.problem();
    let mut rng = ChaCha8Rng::seed_from_u64(43);
    let mut rejected = 0;
    for _ in 0..20 {
        // A wrong match: the last correspondence of another scene.
        let (mut p, _) = problem.scene(&mut rng, 0.0);
        let (q, _) = problem.scene(&mut rng, 0.0);
        p.rows_mut(84, 12).copy_from(&q.rows(84, 12));
        let (result, n) = counted(|| solver.run_pipeline(&p, sample_schedule(true), false, None));
        if result.is_err() {
            rejected += 1;
            assert_eq!(n, 0, "a rejected sample allocated");
        }
    }
    assert!(rejected >= 15, "{rejected} of 20 samples with a wrong match rejected");
    // The counter is armed: the all-roots fallback allocates its roots.
    let (p, _) = problem.scene(&mut rng, 0.0);
    let (result, n) = counted(|| solver.run_pipeline(&p, &[], true, None));
    assert!(result.is_ok() && n > 0, "{n} allocations from the fallback");
}

/// The predicted starts ([`simhc_problems::grps::declared::PredictedStart`]: the network's
/// rotation with least-squares `(t, s)`, the swapped views, and the swapped rotation), each
/// run alone with Gauss-Newton: they allocate nothing, whether or not they validate.
#[test]
fn the_predicted_starts_allocate_nothing() {
    let solver = Solver::new(Grps8Problem::new()).expect("shipped weights");
    let problem = solver.problem();
    let mut rng = ChaCha8Rng::seed_from_u64(44);
    let (mut validated, mut allocations) = (0, 0);
    for k in 0..20 {
        let (p, x) = problem.scene(&mut rng, 0.0);
        let p = if k % 2 == 1 { problem.move_frames(&mut rng, &p, &x).expect("a frame").0 } else { p };
        for j in 0..3 {
            let attempt = SolverAttempt::new(StartId::Other(j), Method::GaussNewton);
            let (result, n) = counted(|| solver.run_pipeline(&p, &[attempt], false, None));
            validated += usize::from(result.is_ok());
            allocations += n;
        }
    }
    println!("seed 44: {validated} of 60 predicted starts validated");
    assert!(validated >= 30, "{validated} of 60: the predicted starts must run and mostly validate");
    assert_eq!(allocations, 0, "allocations over 60 predicted starts");
}

/// [`GrpsNetwork::predict`], which the predicted starts run inside a solve, allocates nothing
/// for 8 correspondences (on the stack), and gives a pose for 12 (the heap path).
#[test]
fn predict_allocates_nothing_for_eight_correspondences() {
    let network = GrpsNetwork::shipped().expect("shipped weights");
    let mut rng = ChaCha8Rng::seed_from_u64(45);
    for points in [8, 12] {
        let config = GrpsSceneConfig { points, noise_px: 1.0, ..GrpsSceneConfig::default() };
        for _ in 0..10 {
            let corrs = config.sample(&mut rng).expect("valid config").correspondences;
            let (pose, n) = counted(|| network.predict(&corrs));
            assert!(pose.is_ok(), "{points} correspondences: {pose:?}");
            if points == 8 {
                assert_eq!(n, 0, "allocations of a prediction from 8 correspondences");
            }
        }
    }
}
