//! The shipped start systems (GRPS7: 140 solutions, UPnP-Lagrange: 40, modulo `q -> -q`) and
//! all-roots solving from them: the ground truth of noise-free scenes is among the real
//! solutions. Seeds are fixed and printed; no timing is asserted.

use nalgebra::{DMatrix, SMatrix, SVector};
use simhc::all_roots::{AllRootsOptions, StartSystem};
use simhc::monodromy::{relative_distance, SignFlip, C};
use simhc::{ParamDerivative, Problem};
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{self, Grps7};
use simhc_problems::metrics::{rotation_error_deg, rotation_from_quat};
use simhc_problems::start_systems::{
    best_real_solution, grps7_start, grps7_start_file, quaternion_sign, run_monodromy_grps7, run_monodromy_upnp, solve_grps7, solve_upnp,
    upnp_lagrange, upnp_start, upnp_start_file, MonodromyConfig, Selection, StartSystemFile, UpnpLagrange, GRPS7_SOLUTIONS, UPNP_SOLUTIONS,
};
use simhc_problems::upnp::geometry::upnp_cost_matrix;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::upnp::{self, Upnp};

/// Residuals, distinctness modulo the sign, canonical sign and regularity of a start system.
fn check_start<P, const N: usize, const NP: usize>(start: &StartSystem<N, NP>, count: usize)
where
    P: ParamDerivative<N, N, NP>,
{
    assert_eq!(start.solutions.len(), count);
    let g = start.symmetry.clone().expect("quaternion sign symmetry");
    assert_eq!(g, quaternion_sign());
    let mut f = SVector::<C, N>::zeros();
    let mut j = SMatrix::<C, N, N>::zeros();
    let mut worst = 0.0f64;
    let mut smallest_sigma = f64::INFINITY;
    for x in &start.solutions {
        P::residual_jacobian(x, &start.params, &mut f, &mut j);
        worst = worst.max(f.iter().map(|z| z.norm()).fold(0.0, f64::max));
        let sv = DMatrix::from_iterator(N, N, j.iter().copied()).singular_values();
        smallest_sigma = smallest_sigma.min(sv.min());
        assert_eq!(g.canonical(x), *x, "stored representative is canonical");
    }
    println!("{count} solutions: max residual {worst:e}, smallest sigma_min(J) {smallest_sigma:e}");
    assert!(worst < 1e-8, "start solutions must satisfy F to 1e-8: {worst:e}");
    assert!(smallest_sigma > 1e-8, "start solutions are regular");
    assert!(start.max_residual::<P>() < 1e-8);
    for a in 0..count {
        for b in 0..a {
            let (xa, xb) = (&start.solutions[a], &start.solutions[b]);
            let d = relative_distance(xa, xb).min(relative_distance(&g.apply(xa), xb));
            assert!(d > 1e-6, "solutions {a} and {b} coincide modulo q -> -q");
        }
    }
}

#[test]
fn shipped_grps7_start_system_has_140_regular_solutions() {
    check_start::<Grps7, 8, 84>(grps7_start(), GRPS7_SOLUTIONS);
    let file = grps7_start_file();
    assert_eq!((file.problem.as_str(), file.count), ("grps7", 140));
    assert_eq!(file.monodromy.stop, "stalled");
}

#[test]
fn shipped_upnp_start_system_has_40_regular_solutions() {
    check_start::<UpnpLagrange, 5, 66>(upnp_start(), UPNP_SOLUTIONS);
    assert_eq!(upnp_start_file().problem, "upnp_lagrange");
}

#[test]
fn start_system_file_round_trips_and_rejects_bad_shapes() {
    let file = upnp_start_file();
    let again = StartSystemFile::from_json(&file.to_json()).unwrap();
    assert_eq!(file, again, "JSON round trip is exact");
    let start = again.start_system::<5, 66>().unwrap();
    assert_eq!(start.params, upnp_start().params);
    assert_eq!(start.solutions, upnp_start().solutions);
    assert!(file.start_system::<8, 66>().is_err(), "wrong unknown count");
    assert!(file.start_system::<5, 84>().is_err(), "wrong parameter count");
    let mut short = file.clone();
    short.solutions.pop();
    assert!(short.start_system::<5, 66>().is_err(), "count mismatch");
    assert!(StartSystemFile::from_json("{\"problem\": 1}").is_err());
}

#[test]
fn all_roots_contains_the_ground_truth_on_noise_free_grps7() {
    let config = GrpsSceneConfig { points: 7, ..Default::default() };
    let options = AllRootsOptions::default();
    for seed in 0..6 {
        let scene = config.sample_seeded(seed).unwrap();
        let rows = grps::rows_of::<7>(&scene.correspondences).unwrap();
        let p = Grps7::params(&rows);
        let gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        let res = solve_grps7(&p, &options);
        let (best, d) = res.closest_real(&gt).expect("some real solution");
        println!(
            "seed {seed}: {} finite, {} failed, {} real, {} retracked, {} duplicates; ground truth at {d:.1e}",
            res.finite(),
            res.failed,
            res.real.len(),
            res.retracked,
            res.duplicates
        );
        assert!(d < 1e-6, "seed {seed}: ground truth not among the real solutions ({d:e})");
        assert!(best.residual < 1e-10, "seed {seed}: residual {:e}", best.residual);
        assert!(best.x[0] >= 0.0, "canonical sign");
        let picked = best_real_solution(&res, Selection::ClosestTo(&gt)).unwrap();
        assert_eq!(picked, *best);
        // Every real solution solves the target.
        let mut f = SVector::<f64, 8>::zeros();
        for s in &res.real {
            Grps7::residual(&s.x, &p, &mut f);
            assert!(f.amax() < 1e-8 * (1.0 + s.x.amax().powi(3)), "seed {seed}: {:e}", f.amax());
        }
        assert!(res.real.windows(2).all(|w| w[0].residual <= w[1].residual));
        assert!(res.finite() >= 138, "seed {seed}: only {} finite end points", res.finite());
    }
}

#[test]
fn all_roots_in_parallel_gives_the_same_solutions() {
    let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(42).unwrap();
    let p = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
    let seq = solve_grps7(&p, &AllRootsOptions::default());
    let par = solve_grps7(&p, &AllRootsOptions { parallel: true, ..Default::default() });
    assert_eq!(seq.real, par.real);
    assert_eq!(seq.failed, par.failed);
}

/// The UPnP-Lagrange parameters are the UPnP parameters (`M`'s upper triangle row by row).
#[test]
fn upnp_lagrange_shares_the_upnp_parameter_layout() {
    let scene = UpnpSceneConfig { noise_px: 0.0, ..Default::default() }.sample_seeded(5).unwrap();
    let m = upnp_cost_matrix(&scene.correspondences).unwrap();
    let mut globals = upnp_lagrange::Globals::default();
    for i in 0..11 {
        for j in 0..11 {
            globals.m[i][j] = m[(i, j)];
        }
    }
    let p = upnp::params_of(&m);
    assert_eq!(UpnpLagrange::params(&globals), p);
    // At the ground truth with lambda = 4 E(q) the Lagrange system vanishes iff Upnp does.
    let q = simhc_problems::metrics::quat_from_rotation(&scene.rotation);
    let xq = SVector::<f64, 4>::from(q);
    let mut fu = SVector::<f64, 5>::zeros();
    Upnp::residual(&xq, &p, &mut fu);
    let s = simhc_problems::upnp::geometry::quat_monomials(q);
    let mut s11 = s;
    s11[10] = xq.dot(&xq);
    let e = s11.dot(&(m * s11));
    let x = SVector::<f64, 5>::from([q[0], q[1], q[2], q[3], 4.0 * e]);
    let mut fl = SVector::<f64, 5>::zeros();
    UpnpLagrange::residual(&x, &p, &mut fl);
    println!("Upnp residual {:e}, Lagrange residual {:e}", fu.amax(), fl.amax());
    assert!(fu.amax() < 1e-9 && fl.amax() < 1e-9);
}

#[test]
fn all_roots_upnp_finds_the_ground_truth_and_the_global_minimum() {
    for (seed, noise) in [(1u64, 0.0), (2, 0.0), (3, 2.0), (4, 2.0)] {
        let scene = UpnpSceneConfig { noise_px: noise, ..Default::default() }.sample_seeded(seed).unwrap();
        let m = upnp_cost_matrix(&scene.correspondences).unwrap();
        let res = solve_upnp(&upnp::params_of(&m), &AllRootsOptions::default());
        // The global minimum of the cost is the real critical point with the smallest
        // lambda = 4 E.
        let by_cost = best_real_solution(&res, Selection::MinScore(&|x: &SVector<f64, 5>| x[4])).unwrap();
        let r = rotation_from_quat([by_cost.x[0], by_cost.x[1], by_cost.x[2], by_cost.x[3]]);
        let err = rotation_error_deg(&r, &scene.rotation);
        println!(
            "seed {seed}, {noise} px: {} finite, {} real critical points, global minimum at {err:.2e} deg",
            res.finite(),
            res.real.len()
        );
        assert!(res.real.len() >= 2, "a minimum and a maximum at least");
        if noise == 0.0 {
            assert!(err < 1e-6, "seed {seed}: {err} deg");
        } else {
            assert!(err < 2.0, "seed {seed}: {err} deg");
        }
    }
}

#[test]
fn upnp_monodromy_finds_40_solutions() {
    let report = run_monodromy_upnp(&MonodromyConfig { seed: 9, ..Default::default() }).unwrap();
    println!("{report}");
    assert_eq!(report.count, UPNP_SOLUTIONS);
    assert_eq!(report.vectors, 80);
    assert!(report.file.max_residual < 1e-10);
    assert!(report.written.is_none());
    let start = report.file.start_system::<5, 66>().unwrap();
    check_start::<UpnpLagrange, 5, 66>(&start, UPNP_SOLUTIONS);
}

/// About 3 s in release; slow in the unoptimised test profile, so opt-in:
/// `cargo test --release -p simhc-problems --test all_roots_grps -- --ignored`.
#[test]
#[ignore]
fn grps7_monodromy_finds_140_solutions() {
    for seed in [2, 3] {
        let report = run_monodromy_grps7(&MonodromyConfig { seed, ..Default::default() }).unwrap();
        println!("{report}");
        assert_eq!(report.count, GRPS7_SOLUTIONS);
        assert_eq!(report.vectors, 280);
    }
}

#[test]
fn sign_flip_of_a_real_solution_is_the_same_rotation() {
    let g = SignFlip::new(vec![0, 1, 2, 3]);
    let x = SVector::<f64, 8>::from([-0.5, 0.5, 0.5, 0.5, 1.0, 2.0, 3.0, 0.7]);
    let y = g.canonical(&x);
    assert_eq!(y[0], 0.5);
    assert_eq!(&y.as_slice()[4..], &x.as_slice()[4..]);
    let r = |v: &SVector<f64, 8>| rotation_from_quat([v[0], v[1], v[2], v[3]]);
    assert!((r(&x) - r(&y)).amax() < 1e-15);
}

/// The aligned target is the same problem (the ground truth solves it, row `i` of the residual
/// is the target's times the product of that row's two bearing scales) and a different point
/// of parameter space (closer to the start system's bearings).
#[test]
fn aligned_target_has_the_same_solutions() {
    use simhc_problems::start_systems::grps7_aligned_target;
    let start = grps7_start();
    for seed in [3u64, 4, 5] {
        let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(seed).unwrap();
        let target = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
        let gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale).map(|v| C::new(v, 0.0));
        let aligned = grps7_aligned_target(&start.params, &target);
        let mut f = SVector::<C, 8>::zeros();
        Grps7::residual(&gt, &aligned, &mut f);
        let worst = f.iter().map(|z| z.norm()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "seed {seed}: residual {worst:e}");
        // Closer to the start's bearings than the unit target bearings are.
        let dist = |p: &SVector<C, 84>| {
            (0..7).flat_map(|r| [0usize, 1, 2, 6, 7, 8].map(|k| r * 12 + k)).map(|i| (p[i] - start.params[i]).norm_sqr()).sum::<f64>()
        };
        let plain = target.map(|v| C::new(v, 0.0));
        assert!(dist(&aligned) < dist(&plain), "seed {seed}");
        // Origins untouched.
        for r in 0..7 {
            for k in [3usize, 4, 5, 9, 10, 11] {
                assert_eq!(aligned[r * 12 + k], plain[r * 12 + k]);
            }
        }
    }
}

/// The batch tracker (one path per SIMD lane) follows the same paths as the one-path tracker:
/// path by path the same end points, and a path's result does not depend on the other paths in
/// its batch (bit for bit). Checked for every instruction set this CPU runs (8 paths per
/// operation with AVX-512, 4 with AVX2, 4 unfused on the baseline), and for both row kernels
/// (from the coefficients of the expansion, and from the parameters, unexpanded). The all-roots
/// solver gives the same real solutions either way.
#[test]
fn batch_tracking_agrees_with_one_path_at_a_time() {
    use simhc::all_roots::{all_roots_tracker, CoefficientParameterHomotopy};
    use simhc::homotopy::ParameterHomotopy;
    use simhc::tracker::batch::{track_batch_with, LaneIsa, LaneSystem};
    use simhc::tracker::track;
    use simhc_problems::start_systems::grps7_aligned_target;
    let start = grps7_start();
    let opts = all_roots_tracker();
    let isas: Vec<LaneIsa> = LaneIsa::ALL.into_iter().filter(|isa| isa.available()).collect();
    println!("instruction sets: {isas:?}");
    assert!(isas.contains(&LaneIsa::Baseline));
    for seed in [0u64, 1] {
        let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(seed).unwrap();
        let target = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
        let aligned = grps7_aligned_target(&start.params, &target);
        let h = CoefficientParameterHomotopy::<Grps7, 84, { Grps7::NC }>::new::<8>(ParameterHomotopy::new(start.params, aligned))
            .expect("GRPS7 coefficients are polynomial along the segment");
        let coefficients = LaneSystem::<Grps7, 8, { Grps7::NC }>::new::<84>(h.coefficient_poly()).expect("GRPS7 has path-lane code");
        let parameters = LaneSystem::<Grps7, 8, { Grps7::NC }>::from_parameter_path::<84>(&h.parameter_path().param_poly())
            .expect("GRPS7 has a parameter row kernel");
        let all: Vec<usize> = (0..start.solutions.len()).collect();
        let one_path: Vec<_> = start.solutions.iter().map(|x0| track(&h, x0, &opts)).collect();
        for (&isa, (kernel, system)) in
            isas.iter().flat_map(|isa| [("coefficients", &coefficients), ("parameters", &parameters)].map(|k| (isa, k)))
        {
            let run = |idx: &[usize]| {
                track_batch_with::<Grps7, _, 8, 84, { Grps7::NC }>(isa, system, &h, &start.solutions, idx, &opts)
                    .expect("Heun + adaptive is supported on an available instruction set")
            };
            let batch = run(&all);
            assert_eq!(batch.len(), all.len());
            let (mut both, mut same) = (0, 0);
            for (i, (r, b)) in batch.iter().zip(&one_path).enumerate() {
                if let (Ok(a), Ok(b)) = (r, b) {
                    both += 1;
                    assert!(a.residual < 1e-8, "{isa:?} seed {seed} path {i}: residual {:e}", a.residual);
                    if relative_distance(&a.x, &b.x) < 1e-8 {
                        same += 1;
                    }
                }
            }
            println!("{isa:?} {kernel} seed {seed}: {both} paths tracked by both, {same} with the same end point");
            assert!(both >= 136, "{isa:?} {kernel} seed {seed}: {both}");
            assert!(same + 3 >= both, "{isa:?} {kernel} seed {seed}: {same} of {both} agree");
            let subset = [7usize, 3, 139, 64, 0, 99];
            let again = run(&subset);
            for (k, &i) in subset.iter().enumerate() {
                assert_eq!(again[k], batch[i], "{isa:?} {kernel} seed {seed} path {i}: depends on its batch");
            }
        }

        // The solver with one path at a time, and with each instruction set forced.
        let a = solve_grps7(&target, &AllRootsOptions::default());
        let one_by_one = AllRootsOptions { batch: false, ..AllRootsOptions::default() };
        let coefficient_rows = AllRootsOptions { param_lanes: false, ..AllRootsOptions::default() };
        let forced = isas.iter().map(|&isa| AllRootsOptions { lane_isa: Some(isa), ..AllRootsOptions::default() });
        for (k, options) in [one_by_one, coefficient_rows].into_iter().chain(forced).enumerate() {
            let b = solve_grps7(&target, &options);
            assert_eq!(a.real.len(), b.real.len(), "seed {seed} run {k}: real solution counts");
            for s in &a.real {
                let (_, d) = b.closest_real(&s.x).unwrap();
                assert!(d < 1e-8, "seed {seed} run {k}: a real solution of the default run is missing ({d:e})");
            }
        }
    }
}

/// The batch tracker reports bad start points as typed errors in their slots (the other paths
/// are unaffected), an exhausted step budget as `MaxSteps`; misuse — settings it does not run
/// (fixed steps, drag steps, Euler), start or settings indices that do not exist — is a
/// `BatchError`, apart from the paths' `TrackError`s.
#[test]
fn batch_tracker_reports_bad_input_per_path() {
    use simhc::all_roots::{all_roots_tracker, CoefficientParameterHomotopy};
    use simhc::homotopy::ParameterHomotopy;
    use simhc::tracker::batch::{track_batch, BatchError, LaneSystem};
    use simhc::tracker::{Predictor, TrackError, TrackerOptions};
    let start = grps7_start();
    let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(11).unwrap();
    let target = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
    let h = CoefficientParameterHomotopy::<Grps7, 84, { Grps7::NC }>::new::<8>(ParameterHomotopy::new(
        start.params,
        target.map(|v| C::new(v, 0.0)),
    ))
    .unwrap();
    let system = LaneSystem::<Grps7, 8, { Grps7::NC }>::new::<84>(h.coefficient_poly()).unwrap();
    let mut starts = start.solutions[..5].to_vec();
    starts[1][3] = C::new(f64::NAN, 0.0);
    starts[3][0] = C::new(1e12, 0.0);
    let opts = all_roots_tracker();
    let run = |idx: &[usize], o: &TrackerOptions| track_batch::<Grps7, _, 8, 84, { Grps7::NC }>(&system, &h, &starts, idx, o);
    assert_eq!(run(&[0, 1, 9], &opts), Err(BatchError::NoStartPoint { index: 9, available: 5 }));
    let r = run(&[0, 1, 2, 3, 4], &opts).unwrap();
    assert_eq!(r[1], Err(TrackError::NonFinite { t: 0.0 }));
    assert_eq!(r[3], Err(TrackError::DivergedToInfinity { t: 0.0 }));
    for k in [0, 2, 4] {
        let ok = r[k].as_ref().expect("a regular start point is tracked");
        assert_eq!(ok.t, 1.0);
        assert!(ok.residual < 1e-8);
    }
    let tight = TrackerOptions { max_steps: 3, ..opts };
    assert!(matches!(run(&[0], &tight).unwrap()[0], Err(TrackError::MaxSteps { .. })));
    let unsupported = Err(BatchError::UnsupportedSettings { index: 0 });
    assert_eq!(run(&[0], &TrackerOptions::paper(0.05)), unsupported, "fixed steps");
    assert_eq!(run(&[0], &TrackerOptions::single_path()), unsupported, "drag steps");
    assert_eq!(run(&[0], &TrackerOptions { predictor: Predictor::Euler, ..opts }), unsupported);
    // A queue naming a start point or settings that do not exist gets a typed error for that
    // job (the others are tracked); settings the lanes do not run decline the whole call.
    use simhc::tracker::batch::{track_batch_queue, LaneIsa, PathJob, PathQueue, PathResult};
    struct Jobs(Vec<PathJob>, Vec<(PathJob, PathResult<8>)>, Vec<(PathJob, BatchError)>);
    impl PathQueue<8> for Jobs {
        fn next(&mut self) -> Option<PathJob> {
            self.0.pop()
        }
        fn finished(&mut self, job: PathJob, result: PathResult<8>) {
            self.1.push((job, result));
        }
        fn refused(&mut self, job: PathJob, error: BatchError) {
            self.2.push((job, error));
        }
    }
    let jobs =
        vec![PathJob { id: 0, start: 0, settings: 1 }, PathJob { id: 1, start: 2, settings: 0 }, PathJob { id: 2, start: 5, settings: 0 }];
    let mut queue = Jobs(jobs.clone(), Vec::new(), Vec::new());
    let isa = LaneIsa::detect();
    assert_eq!(track_batch_queue::<Grps7, _, _, 8, 84, { Grps7::NC }>(isa, &system, &h, &starts, &[opts], &mut queue), Ok(()));
    assert_eq!(queue.1.len(), 1);
    assert_eq!(queue.1[0].0.id, 1);
    assert!(queue.1[0].1.is_ok(), "{:?}", queue.1[0].1);
    assert_eq!(
        queue.2,
        [
            (jobs[2], BatchError::NoStartPoint { index: 5, available: 5 }),
            (jobs[0], BatchError::NoTrackerSettings { index: 1, available: 1 }),
        ]
    );
    let mut queue = Jobs(jobs, Vec::new(), Vec::new());
    let settings = [opts, TrackerOptions::paper(0.05)];
    let declined = track_batch_queue::<Grps7, _, _, 8, 84, { Grps7::NC }>(isa, &system, &h, &starts, &settings, &mut queue);
    assert_eq!(declined, Err(BatchError::UnsupportedSettings { index: 1 }));
    assert!(queue.1.is_empty() && queue.2.is_empty(), "nothing tracked");
}

/// The batch tracker's parameter rows along a *bent* parameter path (`p(t)` quadratic in `t`:
/// three Horner terms per input, `ParameterHomotopy::param_poly`) follow the same paths as the
/// one-path tracker on that homotopy.
#[test]
fn parameter_rows_follow_a_bent_path() {
    use rand::SeedableRng;
    use simhc::all_roots::all_roots_tracker;
    use simhc::homotopy::ParameterHomotopy;
    use simhc::monodromy::random_complex_vector;
    use simhc::tracker::batch::{track_batch, LaneSystem};
    use simhc::tracker::track;
    use simhc_problems::start_systems::grps7_aligned_target;
    let start = grps7_start();
    let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(3).unwrap();
    let target = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
    let aligned = grps7_aligned_target(&start.params, &target);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let bend = random_complex_vector::<84>(&mut rng, 0.2 * (aligned - start.params).norm() / 84f64.sqrt());
    let h = ParameterHomotopy::<Grps7, C, 84>::with_bend(start.params, aligned, bend);
    let poly = h.param_poly();
    assert_eq!(poly.len(), 3, "a bent path is quadratic in t");
    let system = LaneSystem::<Grps7, 8, { Grps7::NC }>::from_parameter_path::<84>(&poly).expect("GRPS7 has a parameter row kernel");
    let opts = all_roots_tracker();
    let idx: Vec<usize> = (0..40).collect();
    let batch =
        track_batch::<Grps7, _, 8, 84, { Grps7::NC }>(&system, &h, &start.solutions, &idx, &opts).expect("Heun + adaptive is supported");
    let (mut both, mut same) = (0, 0);
    for (&i, b) in idx.iter().zip(&batch) {
        if let (Ok(b), Ok(a)) = (b, track(&h, &start.solutions[i], &opts)) {
            both += 1;
            assert!(b.residual < 1e-8, "path {i}: residual {:e}", b.residual);
            same += usize::from(relative_distance(&a.x, &b.x) < 1e-8);
        }
    }
    println!("bent path: {both} of 40 paths tracked by both, {same} with the same end point");
    assert!(both >= 38 && same + 1 >= both, "{same} of {both} agree");
}
