//! The problem added through the public API: its derivatives, its shipped start system and
//! weights, and its four commands from the registration, run as a user runs them.

use generalized_relative_pose::{
    canonicalize, errors, grp, move_frames, scene, Coplanarity, GenRelPose, Grp6, Grp7, Params, Unknowns, START_SYSTEM,
};
use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::all_roots::StartSystem;
use simhc::pipeline::{Validator, Verdict};
use simhc::Problem;
use std::process::Command;

/// Central differences of the residual of instance `P` (a value, so that its sizes are
/// inferred) against the generated Jacobian.
fn jacobian_matches<P: Problem<{ grp::NX }, NF, NP>, const NF: usize, const NP: usize>(_: P, x: &Unknowns, p: &SVector<f64, NP>) -> f64 {
    let mut j = SMatrix::<f64, NF, { grp::NX }>::zeros();
    P::jacobian(x, p, &mut j);
    let mut worst = 0.0f64;
    for k in 0..grp::NX {
        let h = 1e-6;
        let (mut xp, mut xm) = (*x, *x);
        xp[k] += h;
        xm[k] -= h;
        let (mut fp, mut fm) = (SVector::<f64, NF>::zeros(), SVector::<f64, NF>::zeros());
        P::residual(&xp, p, &mut fp);
        P::residual(&xm, p, &mut fm);
        let numeric = (fp - fm) / (2.0 * h);
        worst = worst.max((numeric - j.column(k)).amax() / (1.0 + j.column(k).amax()));
    }
    worst
}

#[test]
fn generated_jacobians_match_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..20 {
        let (p, x) = scene(&mut rng, 0.0);
        let x = x + SVector::from_fn(|i, _| 0.1 * (i as f64 - 3.0));
        assert!(jacobian_matches(Grp7, &x, &p) < 1e-7);
        let p6 = Grp6::first_rows(p.as_slice()).unwrap();
        assert!(jacobian_matches(Grp6, &x, &p6) < 1e-7);
    }
}

#[test]
fn the_sampler_and_the_frame_change_keep_the_truth_a_solution() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let v = Coplanarity::for_noise(0.0);
    for _ in 0..50 {
        let (p, x) = scene(&mut rng, 0.0);
        assert_eq!(v.verdict(&v.check(&p, &x)), Verdict::Accept);
        let (pm, xm) = move_frames(&mut rng, &p, &x);
        assert_eq!(v.verdict(&v.check(&pm, &xm)), Verdict::Accept, "{:?}", v.check(&pm, &xm));
        // The canonical frame: the canonical truth solves the canonical data, and maps back.
        let (pc, frame) = canonicalize(&pm).expect("a frame");
        let xc = frame.to_canonical(&xm);
        assert_eq!(v.verdict(&v.check(&pc, &xc)), Verdict::Accept, "{:?}", v.check(&pc, &xc));
        let [e_r, e_t] = errors(&frame.to_user(&xc), &xm);
        assert!(e_r < 1e-5 && e_t < 1e-7, "{e_r} deg, {e_t} %");
        // A wrong pose is rejected: rotation off by a few degrees.
        let mut wrong: Unknowns = xm;
        wrong[1] += 0.05;
        assert_eq!(v.verdict(&v.check(&pm, &wrong)), Verdict::Reject);
    }
}

/// The shipped start system with its solutions removed, as JSON: a start system that is read
/// and used, but finds nothing.
fn empty_start_system() -> String {
    let mut empty = simhc::start_system::StartSystemFile::from_json(START_SYSTEM).expect("parses");
    empty.solutions.clear();
    empty.count = 0;
    empty.to_json()
}

/// The bootstrap without a rebuild: a start system read at run time is the solver's all-roots
/// fallback (`InstanceSolver::with_fallback`, the commands' `--start-system`), not the one built
/// in: with it the fallback alone solves, with a start system of no solutions it finds nothing.
#[test]
fn a_start_system_read_at_run_time_is_the_fallback() {
    use simhc::solver::{AllRootsFallback, Solver};
    let seed = 21;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let fallback = |json: &str| AllRootsFallback::new(Grp6::square_subsystem(Some(json), Some(64)).expect("parses"));
    let full = Solver::new(GenRelPose::new()).expect("shipped").with_fallback(fallback(START_SYSTEM));
    let none = Solver::new(GenRelPose::new()).expect("shipped").with_fallback(fallback(&empty_start_system()));
    assert!(full.has_fallback() && none.has_fallback());
    let mut solved = 0;
    for trial in 0..6 {
        let (p, x) = scene(&mut rng, 0.0);
        // No attempt before the fallback: its candidates alone.
        if let Ok(s) = full.run_pipeline(&p, &[], true, None) {
            let [e_r, e_t] = errors(&s.x, &x);
            assert!(e_r < 1e-4 && e_t < 1e-4, "trial {trial}: {e_r} deg, {e_t} %");
            solved += 1;
        }
        assert!(none.run_pipeline(&p, &[], true, None).is_err(), "trial {trial}: the built-in start system was used");
    }
    assert!(solved >= 5, "{solved} of 6 solved by the fallback");
    // A plan without the fallback keeps the solver's start system unused.
    use simhc::solver::{InstanceProblem, Plan};
    let plan = Plan { fallback: false, ..full.problem().plan() };
    let without = full.with_plan(plan).expect("the problem's plan fits");
    assert!(!without.has_fallback());
    let (p, _) = scene(&mut rng, 0.0);
    assert!(without.run_pipeline(&p, &[], true, None).is_err(), "a plan without the fallback ran it");
}

#[test]
fn the_shipped_start_system_has_64_solutions_of_small_residual() {
    let file = simhc::start_system::StartSystemFile::from_json(START_SYSTEM).expect("parses");
    let start: StartSystem<{ grp::NX }, { Grp6::NP }> = file.start_system().expect("sizes");
    assert_eq!(start.solutions.len(), 64);
    assert!(start.max_residual::<Grp6>() < 1e-9, "{}", start.max_residual::<Grp6>());
    let _ = GenRelPose::new();
}

fn grp(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_grp")).args(args).output().expect("runs grp");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// `grp bench grp --json` rows by name: (success %, wrong).
fn bench(extra: &[&str]) -> Vec<(String, f64, u64)> {
    let mut args = vec!["bench", "grp", "--trials", "40", "--seed", "5", "--all-roots", "5", "--json"];
    args.extend_from_slice(extra);
    let (ok, out, err) = grp(&args);
    assert!(ok, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    doc["rows"]
        .as_array()
        .expect("rows")
        .iter()
        .map(|r| {
            (
                r["method"].as_str().unwrap_or("").to_string(),
                r["success_pct"].as_f64().unwrap_or(-1.0),
                r["wrong"].as_u64().unwrap_or(u64::MAX),
            )
        })
        .collect()
}

fn row<'a>(rows: &'a [(String, f64, u64)], prefix: &str) -> &'a (String, f64, u64) {
    rows.iter().find(|r| r.0.starts_with(prefix)).unwrap_or_else(|| panic!("no row {prefix} in {rows:?}"))
}

#[test]
fn bench_holds_on_the_sampler_in_random_frames_and_permuted() {
    for extra in [&[][..], &["--random-frames", "--permute"][..]] {
        let rows = bench(extra);
        let shipped = row(&rows, "Shipped");
        assert!(shipped.1 >= 97.5, "{extra:?}: {rows:?}");
        assert_eq!(shipped.2, 0, "a wrong answer came back unflagged: {rows:?}");
        assert_eq!(row(&rows, "All-roots").1, 100.0, "{rows:?}");
        // The rows that validate never return a wrong answer unflagged.
        for r in rows.iter().filter(|r| r.0 != "Pred Initial") {
            assert_eq!(r.2, 0, "{r:?}");
        }
    }
}

/// `bench --start-system FILE` reads the start system at run time: the shipped file's All-roots
/// row solves every trial, a file of no solutions none; a missing file is an error naming it.
#[test]
fn bench_reads_the_start_system_at_run_time() {
    let dir = std::env::temp_dir().join(format!("grp-start-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let empty_path = dir.join("empty.json");
    std::fs::write(&empty_path, empty_start_system()).expect("write");
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/data/grp6_start.json");
    for (file, expected) in [(shipped, 100.0), (empty_path.to_str().expect("utf-8"), 0.0)] {
        let args = ["bench", "grp", "--trials", "4", "--seed", "5", "--all-roots", "4", "--json", "--start-system", file];
        let (ok, out, err) = grp(&args);
        assert!(ok, "{err}");
        let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON");
        let rows = doc["rows"].as_array().expect("rows");
        let all_roots = rows.iter().find(|r| r["method"].as_str().is_some_and(|m| m.starts_with("All-roots"))).expect("All-roots row");
        assert_eq!(all_roots["success_pct"].as_f64(), Some(expected), "{file}: {all_roots}");
    }
    let missing = dir.join("missing.json");
    let (ok, _, err) = grp(&["bench", "grp", "--trials", "1", "--start-system", missing.to_str().expect("utf-8")]);
    assert!(!ok && err.contains("missing.json"), "{err}");
}

fn input(p: &Params, replace: Option<(usize, &str)>) -> String {
    let rows: Vec<String> = (0..7)
        .map(|i| {
            let field = |k: usize| format!("{:?}", &p.as_slice()[12 * i + 3 * k..12 * i + 3 * k + 3]);
            let f = match replace {
                Some((row, text)) if row == i => text.to_string(),
                _ => field(0),
            };
            format!(r#"{{"f": {f}, "v": {}, "fp": {}, "vp": {}}}"#, field(1), field(2), field(3))
        })
        .collect();
    format!("{{\"correspondences\": [{}]}}", rows.join(", "))
}

#[test]
fn solve_reads_a_file_and_says_where_bad_input_is() {
    let dir = std::env::temp_dir().join(format!("grp-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (p, x) = scene(&mut ChaCha8Rng::seed_from_u64(21), 0.0);
    let good = dir.join("good.json");
    std::fs::write(&good, input(&p, None)).expect("write");
    let (ok, out, err) = grp(&["solve", "grp", "--input", good.to_str().expect("utf-8")]);
    assert!(ok, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    assert_eq!(doc["validated"], true);
    let num = |v: &serde_json::Value| v.as_f64().expect("number");
    let q: Vec<f64> = doc["unknowns"]["q"].as_array().expect("q").iter().map(num).collect();
    let t: Vec<f64> = doc["unknowns"]["t"].as_array().expect("t").iter().map(num).collect();
    let found = Unknowns::from_iterator(q.into_iter().chain(t));
    let [e_r, e_t] = errors(&found, &x);
    assert!(e_r < 1e-6 && e_t < 1e-6, "{e_r} deg, {e_t} %");
    // What produced it, by name: a learned hypothesis (or a restart, another start) and a
    // method, or the fallback's candidate; JSON, not a Rust debug string.
    assert_eq!(doc["certificate"]["certified"], true, "{out}");
    let origin = &doc["origin"];
    let named =
        origin["start"].as_str().is_some_and(|s| s.starts_with("learned") || s.starts_with("restart")) && origin["method"].is_string();
    assert!(named || origin["fallback"].is_u64(), "{origin}");
    // The validator's check as JSON (the example's is the tuple `(behind, largest angle)`):
    // exact data, no ray behind a rig.
    let check = &doc["check"];
    assert_eq!(check[0].as_u64(), Some(0), "{out}");
    assert!(check[1].as_f64().is_some_and(|a| (0.0..1e-7).contains(&a)), "{out}");

    let bad = dir.join("bad.json");
    std::fs::write(&bad, input(&p, Some((3, "[0.1, 0.2]")))).expect("write");
    let (ok, _, err) = grp(&["solve", "grp", "--input", bad.to_str().expect("utf-8")]);
    assert!(!ok);
    assert!(err.contains("correspondence 3") && err.contains("`f`") && err.contains("3 numbers"), "{err}");

    let short = dir.join("short.json");
    let text = input(&p, None);
    let cut = text.rfind(", {").expect("a row");
    std::fs::write(&short, format!("{}]}}", &text[..cut])).expect("write");
    let (ok, _, err) = grp(&["solve", "grp", "--input", short.to_str().expect("utf-8")]);
    assert!(!ok);
    assert!(err.contains('6') && err.contains('7'), "{err}");

    let malformed = dir.join("malformed.json");
    std::fs::write(&malformed, "{\"correspondences\": [").expect("write");
    let (ok, _, err) = grp(&["solve", "grp", "--input", malformed.to_str().expect("utf-8")]);
    assert!(!ok);
    assert!(err.contains("malformed JSON at line 1"), "{err}");
}

/// A setting that describes no network is refused before training starts, naming the setting,
/// and no weights file is written.
#[test]
fn train_refuses_a_context_stage_outside_the_network() {
    let out = std::env::temp_dir().join(format!("grp-train-refused-{}.folded", std::process::id()));
    let (ok, _, err) = grp(&["train", "grp", "--context-after", "3", "--out", out.to_str().expect("utf-8")]);
    assert!(!ok);
    assert!(err.contains("context_after 3") && err.contains("at most 2"), "{err}");
    assert!(!out.exists());
}

/// The compiled solver as a library value, as a user's program calls it: built once, then
/// called on seeded scenes in random frames, one by one and as a batch across cores.
#[test]
fn the_library_solver_solves_seeded_scenes_in_random_frames() {
    let seed = 31;
    println!("seed {seed}");
    let solver = simhc::solver::Solver::new(GenRelPose::new()).expect("shipped weights");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scenes: Vec<(Params, Unknowns)> = (0..40)
        .map(|k| {
            let (p, x) = scene(&mut rng, 0.0);
            if k % 2 == 1 {
                move_frames(&mut rng, &p, &x)
            } else {
                (p, x)
            }
        })
        .collect();
    let (mut solved, mut wrong) = (0, 0);
    for (p, x) in &scenes {
        if let Ok(s) = solver.solve(p) {
            let [e_r, e_t] = errors(&s.x, x);
            if e_r < 2.0 && e_t < 5.0 {
                solved += 1;
            } else {
                wrong += 1;
            }
        }
    }
    println!("solved {solved} of {}", scenes.len());
    assert_eq!(wrong, 0, "a wrong answer came back unflagged");
    assert!(solved >= 39, "{solved} of {}", scenes.len());
    let data: Vec<Params> = scenes.iter().map(|(p, _)| *p).collect();
    let batch = solver.solve_batch(&data);
    assert_eq!(batch.iter().filter(|r| r.is_ok()).count(), solved, "the batch solves what one solve solves");

    let mut bad = data[0];
    bad[12 * 4 + 7] = f64::NAN;
    let err = solver.solve(&bad).expect_err("NaN");
    assert!(
        matches!(err, simhc::solver::SolveError::Input(_)) && err.to_string().contains("row 4") && err.to_string().contains("`fp`"),
        "{err}"
    );
    // A ray origin: the canonical frame centres the origins, so a NaN there would spread to
    // every row if the data were not checked before the frame is made.
    let mut bad = data[0];
    bad[12 * 2 + 9] = f64::INFINITY;
    let err = solver.solve(&bad).expect_err("infinity");
    assert!(err.to_string().contains("row 2") && err.to_string().contains("`vp`"), "{err}");
}

/// `n` correspondences of two rigs of 4 cameras under `(r, t)`, bearings with angular noise
/// `sigma` (no draw at all when 0), and a random bearing in rig 2 where `good(k)` is false:
/// the rows (12 numbers each) and which of them are true matches.
fn rig_matches(
    rng: &mut ChaCha8Rng,
    r: &nalgebra::Matrix3<f64>,
    t: &nalgebra::Vector3<f64>,
    n: usize,
    sigma: f64,
    good: impl Fn(usize) -> bool,
) -> (Vec<f64>, Vec<bool>) {
    use nalgebra::Vector3;
    use rand::Rng;
    let gaussian = |rng: &mut ChaCha8Rng| -> f64 {
        let (u1, u2): (f64, f64) = (rng.random::<f64>().max(f64::MIN_POSITIVE), rng.random());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let perturb = |f: Vector3<f64>, rng: &mut ChaCha8Rng| {
        if sigma == 0.0 {
            return f;
        }
        let d = Vector3::from_fn(|_, _| gaussian(rng) * sigma);
        (f + (d - f * f.dot(&d))).normalize()
    };
    let cams =
        |rng: &mut ChaCha8Rng| -> Vec<Vector3<f64>> { (0..4).map(|_| Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0))).collect() };
    let (rig1, rig2) = (cams(rng), cams(rng));
    let (mut rows, mut inlier) = (Vec::new(), Vec::new());
    for k in 0..n {
        let x = Vector3::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(4.0..20.0));
        let (v, vp) = (rig1[rng.random_range(0..4)], rig2[rng.random_range(0..4)]);
        let f = perturb((x - v).normalize(), rng);
        let fp = if good(k) {
            perturb((r.transpose() * (x - t) - vp).normalize(), rng)
        } else {
            Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)).normalize()
        };
        rows.extend(f.iter().chain(v.iter()).chain(fp.iter()).chain(vp.iter()));
        inlier.push(good(k));
    }
    (rows, inlier)
}

/// The robust estimator on 60 correspondences of two rigs, 20 % of them wrong matches.
#[test]
fn the_robust_estimator_finds_the_pose_among_wrong_matches() {
    use nalgebra::Vector3;
    use simhc::solver::DeclaredProblem;
    let seed = 41;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q = generalized_relative_pose::random_rotation(&mut rng);
    let (r, t) = (q.to_rotation_matrix().into_inner(), Vector3::new(0.5, -1.0, 0.8));
    let (rows, inlier) = rig_matches(&mut rng, &r, &t, 60, 0.0, |k| k % 5 != 0);
    let problem = GenRelPose::new();
    let truth = Unknowns::from([q.w, q.i, q.j, q.k, t.x, t.y, t.z]);
    assert!(problem.row_error(&truth, &rows[12..24], &[]) < 1e-12, "an inlier's error at the truth is zero");
    assert!(problem.row_error(&truth, &rows[..12], &[]) > 1e-3, "a wrong match's is not");
    let solver = simhc::solver::Solver::new(problem).expect("shipped weights");
    let options = simhc::ransac::RansacOptions { seed, max_iterations: 200, ..simhc::ransac::RansacOptions::poselib(1e-6) };
    let (x, info) = solver.estimate((&rows, &[]), &options).expect("a pose");
    let [e_r, e_t] = errors(&x, &truth);
    println!("E_R {e_r:.2e} deg, E_t {e_t:.2e} %, {} inliers, {} iterations", info.inliers.len(), info.iterations);
    assert!(e_r < 1e-6 && e_t < 1e-6, "{e_r} deg, {e_t} %");
    assert_eq!(info.inlier_mask, inlier, "exactly the true matches are inliers");
}

/// With 1 px of noise and 30 % wrong matches, the estimate is within the noise (the peers
/// harness's success, E_t < 5 %) and keeps the true matches. A local optimization that stops
/// short of the error's minimum (Gauss-Newton on the algebraic equations with the error's scale
/// frozen, before 2026-12-03 evening) leaves the translation off by several percent on such
/// data (`bench/peers/robust_grp.py`, `BENCHMARKS.md`).
#[test]
fn the_robust_estimate_is_within_the_noise() {
    use nalgebra::Vector3;
    use simhc::solver::DeclaredProblem;
    let seed = 43;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sigma = 1.0 / generalized_relative_pose::FOCAL_PX;
    let q = generalized_relative_pose::random_rotation(&mut rng);
    let (r, t) = (q.to_rotation_matrix().into_inner(), Vector3::new(1.2, -0.6, 0.9));
    let (rows, inlier) = rig_matches(&mut rng, &r, &t, 150, sigma, |k| k % 10 >= 3);
    let threshold = 3.0 * std::f64::consts::SQRT_2 * sigma;
    let problem = GenRelPose::new();
    let truth = Unknowns::from([q.w, q.i, q.j, q.k, t.x, t.y, t.z]);
    let cost = |x: &Unknowns| -> f64 {
        rows.chunks_exact(12)
            .zip(&inlier)
            .filter(|(_, good)| **good)
            .map(|(row, _)| (1.0 + (problem.row_error(x, row, &[]) / threshold).powi(2)).ln())
            .sum()
    };
    let solver = simhc::solver::Solver::with_weights(GenRelPose::new(), generalized_relative_pose::WEIGHTS, 1.0).expect("shipped weights");
    let options = simhc::ransac::RansacOptions { seed, max_iterations: 300, ..simhc::ransac::RansacOptions::poselib(threshold) };
    let (x, info) = solver.estimate((&rows, &[]), &options).expect("a pose");
    let [e_r, e_t] = errors(&x, &truth);
    let (at_estimate, at_truth) = (cost(&x), cost(&truth));
    println!("E_R {e_r:.3} deg, E_t {e_t:.2} %, cost {at_estimate:.3} (truth {at_truth:.3}), {} inliers", info.inliers.len());
    assert!(e_r < 0.5 && e_t < 5.0, "{e_r} deg, {e_t} %");
    let recalled = info.inlier_mask.iter().zip(&inlier).filter(|(a, b)| **a && **b).count();
    assert!(recalled as f64 >= 0.95 * inlier.iter().filter(|b| **b).count() as f64, "{recalled} true matches kept");
}

/// Exactly one sample's worth of correspondences: the estimator solves them once, as `solve`
/// does (before 2026-12-05 it drew up to 100,000 identical samples, each with Gauss-Newton from
/// the learned start only, and could fail where `solve` succeeds).
#[test]
fn the_estimator_on_one_sample_solves_it_once_as_solve_does() {
    let seed = 44;
    println!("seed {seed}");
    let solver = simhc::solver::Solver::new(GenRelPose::new()).expect("shipped weights");
    let options = simhc::ransac::RansacOptions { seed, ..simhc::ransac::RansacOptions::poselib(1e-6) };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut agree, n) = (0, 10);
    for _ in 0..n {
        let (p, truth) = scene(&mut rng, 0.0);
        let solved = solver.solve(&p);
        let estimated = solver.estimate((p.as_slice(), &[]), &options);
        match (&solved, &estimated) {
            (Ok(s), Ok((x, info))) => {
                assert_eq!(s.x, *x, "the estimate is the solve's solution");
                assert_eq!(info.iterations, 1, "one solve, not a loop of identical samples");
                assert!(info.inlier_mask.iter().all(|&m| m), "noise-free rows are all inliers");
                let [e_r, e_t] = errors(x, &truth);
                assert!(e_r < 1e-6 && e_t < 1e-6, "{e_r} deg, {e_t} %");
                agree += 1;
            }
            (Err(_), Err(simhc::solver::EstimateError::NotSolved { rows: 7, .. })) => {}
            other => panic!("solve and estimate disagree: {other:?}"),
        }
    }
    assert!(agree >= 9, "{agree} of {n} solved");
}

/// A correspondence given twice adds no equation: `solve` rejects it as degenerate input,
/// naming the repeated row, and the estimator drops every sample that draws it twice (before
/// 2026-12-05 such a sample was fitted and validated on fewer distinct rows than it needs).
#[test]
fn a_repeated_correspondence_is_degenerate_input_naming_its_row() {
    use simhc::solver::{DegenerateInput, FirstRowsError, SolveError};
    let seed = 45;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut p, _) = scene(&mut rng, 0.0);
    let per_row = 12;
    let row2: Vec<f64> = p.as_slice()[2 * per_row..3 * per_row].to_vec();
    p.as_mut_slice()[5 * per_row..6 * per_row].copy_from_slice(&row2);
    let solver = simhc::solver::Solver::new(GenRelPose::new()).expect("shipped weights");
    match solver.solve(&p) {
        Err(SolveError::Input(FirstRowsError::Degenerate(DegenerateInput { row: Some(5), reason }))) => {
            assert!(reason.contains("repeated"), "{reason}")
        }
        other => panic!("not the repeated row's error: {other:?}"),
    }
    // The estimator on those 7 rows is the one solve of them: the same error, as a string.
    let options = simhc::ransac::RansacOptions::poselib(1e-6);
    let e = solver.estimate((p.as_slice(), &[]), &options).expect_err("degenerate");
    assert!(e.to_string().contains("row 5"), "{e}");
}

/// The certificate comes with every solution of a user's problem, through the compiler, with
/// no line in the problem: noise-free solves (half in random frames) certify, the certified
/// box holds the truth (up to the quaternion's sign), and a point moved off the root is
/// certified, if at all, with a bound that covers the move.
#[test]
fn a_users_problem_is_certified_without_a_line_of_its_own() {
    let seed = 46;
    println!("seed {seed}");
    let solver = simhc::solver::Solver::new(GenRelPose::new()).expect("shipped weights").certifying(simhc::solver::Certification::Report);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut certified, mut solved) = (0, 0);
    for k in 0..20 {
        let (p, x) = scene(&mut rng, 0.0);
        let (p, x) = if k % 2 == 1 { move_frames(&mut rng, &p, &x) } else { (p, x) };
        let Ok(s) = solver.solve(&p) else { continue };
        solved += 1;
        if let Some(Ok(c)) = s.certified {
            let mut flipped = x;
            flipped.rows_mut(0, 4).neg_mut();
            assert!(c.box_contains(&x) || c.box_contains(&flipped), "trial {k}: the certified box misses the truth");
            certified += 1;
            // A point 1e-3 off the root: a certificate of it, if any, must enclose the root and
            // bound the distance to it by at least that much.
            let mut off = s.x;
            off[4] += 1e-3;
            if let Ok(c) = solver.certify(&p, &off) {
                assert!(c.encloses(&s.x) && c.error_bound() >= 0.999e-3, "trial {k}: bound {} for a point 1e-3 off", c.error_bound());
            }
        }
    }
    println!("{certified} of {solved} solutions certified");
    assert!(solved >= 19 && certified >= solved - 1, "{certified} certified of {solved} solved");
}

/// More correspondences than the data instance's 7: solved on the first 7, refined and
/// validated on all (`Solver::solve_rows`, and `grp solve` on such a file); a wrong match among
/// them is an error that names a run of rows holding it, and too few rows say how many.
#[test]
fn more_rows_than_the_instance_are_solved_on_the_first_and_validated_on_all() {
    use simhc::solver::{EstimateError, Scenes, Solver};
    let seed = 31;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let solver = Solver::new(GenRelPose::new()).expect("shipped weights");
    let (rows, truth) = generalized_relative_pose::scene_rows(&mut rng, 20, 0.0);
    let s = solver.solve_rows(&rows, &[]).expect("20 exact correspondences");
    assert_eq!(s.rows, 20);
    assert!(solver.problem().correct(&errors(&s.x, &truth)), "{:?}", errors(&s.x, &truth));
    assert!(s.max_row_error < 1e-6, "{}", s.max_row_error);

    let (other, _) = generalized_relative_pose::scene_rows(&mut rng, 20, 0.0);
    let mut wrong = rows.clone();
    wrong[12 * 12..13 * 12].copy_from_slice(&other[12 * 12..13 * 12]);
    match solver.solve_rows(&wrong, &[]) {
        Err(EstimateError::NotValidatedOnAll { rows: 20, instance: 7, first, last, .. }) => {
            assert!((first..=last).contains(&12), "rows {first}..={last}")
        }
        other => panic!("a wrong match at row 12: {other:?}"),
    }
    assert!(matches!(solver.solve_rows(&rows[..6 * 12], &[]), Err(EstimateError::TooFew { rows: 6, needed: 7 })));

    // The command: a file of 20 correspondences.
    let json = |rows: &[f64]| {
        let items: Vec<String> = rows
            .chunks_exact(12)
            .map(|r| format!(r#"{{"f": {:?}, "v": {:?}, "fp": {:?}, "vp": {:?}}}"#, &r[0..3], &r[3..6], &r[6..9], &r[9..12]))
            .collect();
        format!("{{\"correspondences\": [{}]}}", items.join(", "))
    };
    let dir = std::env::temp_dir().join(format!("grp-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (good, bad) = (dir.join("twenty.json"), dir.join("wrong.json"));
    std::fs::write(&good, json(&rows)).expect("write");
    std::fs::write(&bad, json(&wrong)).expect("write");
    let (ok, out, err) = grp(&["solve", "grp", "--input", good.to_str().expect("utf-8")]);
    assert!(ok, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    assert_eq!((doc["validated"].as_bool(), doc["rows"].as_u64()), (Some(true), Some(20)), "{out}");
    let q: Vec<f64> = doc["unknowns"]["q"].as_array().expect("q").iter().map(|v| v.as_f64().expect("number")).collect();
    let dot: f64 = q.iter().zip(truth.iter().take(4)).map(|(a, b)| a * b).sum();
    assert!(dot.abs() > 1.0 - 1e-9, "q {q:?} against the truth");
    let (ok, _, err) = grp(&["solve", "grp", "--input", bad.to_str().expect("utf-8")]);
    assert!(!ok && err.contains("does not validate on correspondences"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
