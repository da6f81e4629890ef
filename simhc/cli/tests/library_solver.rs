//! A declared problem's solver as a library value ([`simhc::solver::Solver`]): built once, then
//! called many times, from several threads, without heap allocation per solve; bad input is a
//! typed error that says where, and data no solution explains never comes back as `Ok`.

#[path = "../../tests/counting_alloc/mod.rs"]
mod counting_alloc;

use counting_alloc::counted;
use nalgebra::SVector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::{Validator, Verdict};
use simhc::ransac::RansacOptions;
use simhc::solver::{CanonicalFrame, DeclaredProblem, EstimateError, Scenes, SolveError, Solver};
use simhc_cli::{App, Declared};

#[simhc::simhc_problem]
pub mod line {
    pub struct Unknowns {
        a: Scalar,
        b: Scalar,
    }
    pub struct Row {
        x: Scalar,
        y: Scalar,
    }
    pub const ROWS: [usize; 1] = [4];
    pub fn row_equations() -> Scalar {
        a * x + b - y
    }
}

type Line4 = line::Line4;
type P = SVector<f64, 8>;
type X = SVector<f64, 2>;

/// Every row's residual below the tolerance (`1e-9` plus 6 noise sigmas).
struct Residual(f64);

impl Validator<P, 2> for Residual {
    type Check = f64;
    fn check(&self, p: &P, x: &X) -> f64 {
        p.as_slice().chunks_exact(2).map(|r| (x[0] * r[0] + x[1] - r[1]).abs()).fold(0.0, f64::max)
    }
    fn verdict(&self, c: &f64) -> Verdict {
        Verdict::accept_if(*c <= self.0)
    }
    fn better(&self, a: &f64, b: &f64) -> bool {
        a < b
    }
}

struct Line;

impl DeclaredProblem<2, 4, 8, { Line4::NC }, 8> for Line {
    type Tracked = Line4;
    type Data = Line4;
    type Validator = Residual;
    const NAME: &'static str = "line";
    fn validator(&self, noise: f64) -> Residual {
        Residual(1e-9 + 6.0 * noise)
    }
}

impl Scenes<2, 4, 8, { Line4::NC }, 8> for Line {
    const ABOUT: &'static str = "a line y = a x + b";
    const ERRORS: &'static [&'static str] = &["error"];
    fn scene(&self, rng: &mut ChaCha8Rng, _: f64) -> (P, X) {
        let (a, b) = (rng.random_range(-2.0..2.0), rng.random_range(-1.0..1.0));
        let mut p = P::zeros();
        for r in 0..4 {
            p[2 * r] = rng.random_range(-2.0..2.0);
            p[2 * r + 1] = a * p[2 * r] + b;
        }
        (p, X::new(a, b))
    }
    fn errors(&self, x: &X, truth: &X) -> Vec<f64> {
        vec![(x - truth).amax()]
    }
    fn correct(&self, errors: &[f64]) -> bool {
        errors[0] < 1e-6
    }
    fn scene_rows(&self, rng: &mut ChaCha8Rng, rows: usize, noise: f64) -> Option<(Vec<f64>, Vec<f64>, X)> {
        let (a, b) = (rng.random_range(-2.0..2.0), rng.random_range(-1.0..1.0));
        let mut out = Vec::with_capacity(2 * rows);
        for _ in 0..rows {
            let x = rng.random_range(-2.0..2.0);
            out.extend([x, a * x + b + noise * rng.random_range(-1.0..1.0)]);
        }
        Some((out, Vec::new(), X::new(a, b)))
    }
}

fn assert_send_sync<T: Send + Sync>(_: &T) {}

/// A solver with weights trained here (a small network; the solve validates whatever it gets).
fn solver() -> Solver<Line, 2, 4, 8, { Line4::NC }, 8> {
    noisy_solver(0.0)
}

/// The same for data with noise of `noise` (the validator's tolerance).
fn noisy_solver(noise: f64) -> Solver<Line, 2, 4, 8, { Line4::NC }, 8> {
    Solver::with_weights(Line, &line_weights(), noise).expect("the weights load")
}

/// Weights for the line, trained here (a small network; the solve validates whatever it gets).
fn line_weights() -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("simhc-library-solver-{}-{:?}", std::process::id(), std::thread::current().id()));
    std::fs::create_dir_all(&dir).unwrap();
    let weights = dir.join("line.folded");
    let app = App::new("lines", "test").register(Declared::new(Line));
    app.run_from(["lines", "train", "line", "--samples", "512", "--epochs", "2", "--seed", "3", "--out", weights.to_str().unwrap()])
        .expect("trains");
    let bytes = std::fs::read(&weights).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    bytes
}

/// The line with a canonical frame that turns every number into NaN (a degenerate frame).
struct NanFrame;

impl DeclaredProblem<2, 4, 8, { Line4::NC }, 8> for NanFrame {
    type Tracked = Line4;
    type Data = Line4;
    type Validator = Residual;
    const NAME: &'static str = "nan-frame";
    fn validator(&self, noise: f64) -> Residual {
        Line.validator(noise)
    }
    fn canonicalize(&self, _: &P) -> Option<(P, CanonicalFrame<2>)> {
        Some((P::from_element(f64::NAN), CanonicalFrame::new(|x| *x, |x| *x)))
    }
}

impl Scenes<2, 4, 8, { Line4::NC }, 8> for NanFrame {
    const ABOUT: &'static str = "a line whose canonical frame is degenerate";
    const ERRORS: &'static [&'static str] = &["error"];
    fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (P, X) {
        Line.scene(rng, noise)
    }
    fn errors(&self, x: &X, truth: &X) -> Vec<f64> {
        Line.errors(x, truth)
    }
    fn correct(&self, errors: &[f64]) -> bool {
        Line.correct(errors)
    }
}

#[test]
fn solves_many_scenes_without_allocating_and_across_threads() {
    let seed = 7;
    println!("seed {seed}");
    let solver = solver();
    assert_send_sync(&solver);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scenes: Vec<(P, X)> = (0..200).map(|_| Line.scene(&mut rng, 0.0)).collect();
    // Warm up once (lazy statics of the runtime, if any), then count.
    let _ = solver.solve(&scenes[0].0);
    let solved = scenes.iter().filter(|(p, truth)| solver.solve(p).is_ok_and(|s| (s.x - truth).amax() < 1e-9)).count();
    assert_eq!(solved, 200, "every noise-free scene solves");
    let mut per_solve = 0;
    for (p, _) in &scenes[..50] {
        let (r, n) = counted(|| solver.solve(p));
        assert!(r.is_ok());
        per_solve += n;
    }
    assert_eq!(per_solve, 0, "a validated solve allocates nothing");
    let data: Vec<P> = scenes.iter().map(|(p, _)| *p).collect();
    let batch = solver.solve_batch(&data);
    for (b, p) in batch.iter().zip(&data) {
        assert_eq!(b.as_ref().map(|s| s.x).ok(), solver.solve(p).map(|s| s.x).ok(), "the batch gives what one solve gives");
    }
}

#[test]
fn bad_input_is_a_typed_error_and_no_fit_is_never_ok() {
    let solver = solver();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let (mut p, _) = Line.scene(&mut rng, 0.0);
    p[3] = f64::NAN;
    match solver.solve(&p) {
        Err(e @ SolveError::Input(_)) => {
            let msg = e.to_string();
            assert!(msg.contains("row 1") && msg.contains("`y`"), "{msg}");
        }
        other => panic!("expected an input error, got {other:?}"),
    }
    // Four points on no line: whatever comes back is flagged, never a solution.
    let p = P::from_column_slice(&[0.0, 0.0, 1.0, 1.0, 2.0, 0.0, 3.0, 5.0]);
    match solver.solve(&p) {
        Err(SolveError::NotValidated { check, .. }) => assert!(check > 1e-3, "{check}"),
        Err(SolveError::NoEndPoint { .. }) => {}
        other => panic!("four points on no line must not solve: {other:?}"),
    }
}

/// 100 points, 40 % of them outliers, inliers with noise `sigma`: rows `[x, y]` and which are
/// inliers.
fn outlier_data(seed: u64, sigma: f64) -> (Vec<f64>, Vec<bool>, X) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (a, b) = (rng.random_range(-2.0..2.0), rng.random_range(-1.0..1.0));
    let mut rows = Vec::new();
    let mut inlier = Vec::new();
    for i in 0..100 {
        let x: f64 = rng.random_range(-2.0..2.0);
        let is_inlier = i % 5 >= 2;
        let y = if is_inlier { a * x + b + sigma * rng.random_range(-1.0..1.0) } else { rng.random_range(-6.0..6.0) };
        rows.extend([x, y]);
        inlier.push(is_inlier);
    }
    (rows, inlier, X::new(a, b))
}

#[test]
fn the_robust_estimator_finds_the_inliers_among_40_percent_outliers() {
    let (seed, sigma) = (12, 1e-3);
    println!("seed {seed}, noise {sigma}");
    let solver = noisy_solver(sigma);
    let (rows, truth_mask, truth) = outlier_data(seed, sigma);
    let options = RansacOptions { seed, ..RansacOptions::poselib(0.01) };
    let (x, info) = solver.estimate((&rows, &[]), &options).expect("a model");
    println!("{x:?} against {truth:?}: {info:?}");
    let found = info.inlier_mask.iter().zip(&truth_mask).filter(|(m, t)| **m && **t).count();
    let true_inliers = truth_mask.iter().filter(|t| **t).count();
    assert!(found * 100 >= true_inliers * 95, "recall {found} of {true_inliers}");
    assert!((x - truth).amax() < 3e-3, "{x:?} against {truth:?}");
    assert_eq!(info.inlier_mask.iter().filter(|m| **m).count(), info.inliers.len());
    assert!((info.inlier_ratio - info.inliers.len() as f64 / 100.0).abs() < 1e-15);
    assert!(info.iterations >= 1000, "PoseLib's minimum: {}", info.iterations);
    assert!(info.refinements >= 1, "local optimization on the noisy inliers");
}

#[test]
fn the_robust_estimator_names_bad_input() {
    let solver = solver();
    let (mut rows, _, _) = outlier_data(13, 0.0);
    let options = RansacOptions { max_iterations: 50, ..RansacOptions::poselib(0.01) };
    assert_eq!(solver.estimate((&rows[..7], &[]), &options).unwrap_err(), EstimateError::Length { len: 7, per_row: 2 });
    assert_eq!(solver.estimate((&rows[..6], &[]), &options).unwrap_err(), EstimateError::TooFew { rows: 3, needed: 4 });
    assert_eq!(solver.estimate((&rows, &[1.0]), &options).unwrap_err(), EstimateError::Globals { got: 1, expected: 0 });
    rows[2 * 7 + 1] = f64::NAN;
    let err = solver.estimate((&rows, &[]), &options).unwrap_err();
    assert!(err.to_string().contains("row 7") && err.to_string().contains("`y`"), "{err}");
}

#[test]
fn a_canonical_frame_that_makes_nan_of_finite_data_is_not_used() {
    let solver = Solver::with_weights(NanFrame, &line_weights(), 0.0).expect("the weights load");
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for _ in 0..20 {
        let (p, truth) = NanFrame.scene(&mut rng, 0.0);
        let s = solver.solve(&p).expect("solved in the user's frame");
        assert!((s.x - truth).amax() < 1e-9);
    }
}

#[test]
fn the_ransac_command_measures_the_estimator_and_needs_a_many_row_sampler() {
    use clap::{Args, FromArgMatches};
    let solver = solver();
    let command = simhc_cli::ransac::RansacArgs::augment_args(clap::Command::new("line"));
    let matches = command
        .try_get_matches_from(["line", "--trials", "4", "--rows", "40", "--noise", "0", "--threshold", "1e-6", "--outliers", "0,0.4"])
        .expect("arguments parse");
    let args = simhc_cli::ransac::RansacArgs::from_arg_matches(&matches).expect("arguments");
    let (file, source) = simhc_cli::ransac::declared_trials(&Line, &args).expect("samples");
    assert!(source.contains("seed 1"), "{source}");
    let rows = simhc_cli::ransac::estimate_declared(&Line, &solver, &file, false).expect("runs").rows;
    assert_eq!(rows.iter().map(|r| r.outliers).collect::<Vec<_>>(), vec![0.0, 0.4]);
    for r in &rows {
        assert_eq!(r.success_pct, 100.0, "{r:?}");
        assert_eq!(r.recall_pct, 100.0, "{r:?}");
        assert_eq!((r.wrong_taken, r.no_model), (0.0, 0), "{r:?}");
    }
    // The command exists for the line (it has `scene_rows`) and not for a problem without one.
    let app = App::new("lines", "test").register(Declared::new(Line)).register(Declared::new(NanFrame));
    let ransac = app.command().expect("builds").find_subcommand("ransac").cloned().expect("a ransac command");
    assert!(ransac.find_subcommand("line").is_some());
    assert!(ransac.find_subcommand("nan-frame").is_none());
}

#[test]
fn the_ransac_command_runs_the_same_on_its_dumped_trials() {
    use clap::{Args, FromArgMatches};
    use simhc_cli::ransac::{declared_trials, estimate_declared, RansacArgs};
    let solver = solver();
    let dir = std::env::temp_dir().join(format!("simhc-library-solver-ransac-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a folder");
    let dump = dir.join("line-trials.json");
    let dump = dump.to_str().expect("utf-8");
    let parse = |args: &[&str]| {
        let matches = RansacArgs::augment_args(clap::Command::new("line")).try_get_matches_from(args).expect("arguments parse");
        RansacArgs::from_arg_matches(&matches).expect("arguments")
    };
    let sampled = parse(&[
        "line",
        "--trials",
        "6",
        "--rows",
        "30",
        "--noise",
        "0",
        "--threshold",
        "1e-6",
        "--outliers",
        "0,0.3",
        "--seed",
        "8",
        "--dump-trials",
        dump,
    ]);
    let (file, _) = declared_trials(&Line, &sampled).expect("samples");
    let on_seed = estimate_declared(&Line, &solver, &file, false).expect("runs");
    let (read, source) = declared_trials(&Line, &parse(&["line", "--trials-file", dump])).expect("reads");
    assert!(source.contains(dump) && source.contains("seed 8"), "{source}");
    // Bit-identical numbers and the same masks, truths and seeds.
    let bits = |f: &simhc_cli::ransac::TrialsFile| -> Vec<u64> {
        f.trials.iter().flat_map(|t| t.rows.iter().flatten().chain(&t.truth).map(|v| v.to_bits())).collect()
    };
    assert_eq!(bits(&read), bits(&file));
    assert_eq!(read, file);
    assert_eq!(file.trials.len(), 12);
    // The mask is the data's: a true row lies on the true line, a wrong one (another scene's) not.
    for t in &file.trials {
        for (row, inlier) in t.rows.iter().zip(&t.inlier) {
            assert_eq!((t.truth[0] * row[0] + t.truth[1] - row[1]).abs() < 1e-12, *inlier, "{row:?}");
        }
    }
    assert!(file.trials[6..].iter().any(|t| t.inlier.contains(&false)));
    // The same estimates, masks and successes on the file as on the seed.
    let on_file = estimate_declared(&Line, &solver, &read, false).expect("runs");
    for (k, (a, b)) in on_seed.trials.iter().zip(&on_file.trials).enumerate() {
        let bits = |e: &Option<Vec<f64>>| e.as_ref().map(|x| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        assert_eq!((bits(&a.estimate), &a.inlier_mask, a.success), (bits(&b.estimate), &b.inlier_mask, b.success), "trial {k}");
    }
    assert!(on_seed.rows.iter().all(|r| r.success_pct == 100.0), "{:?}", on_seed.rows);
    std::fs::remove_dir_all(&dir).ok();
}
