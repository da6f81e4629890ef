//! The commands for any `#[simhc_problem]`: a user implements
//! [`simhc::solver::DeclaredProblem`] (the compiled instances, a validator) and
//! [`simhc::solver::Scenes`] (a scene sampler, the errors a bench reports) and registers
//! `Declared::new(problem)` in an [`crate::App`]:
//!
//! - `train`: the generic learned start ([`simhc_regressor::generic`]) on the sampler's scenes,
//!   with a progress bar; writes a `.folded` weights file;
//! - `bench`: the paper's rows on the same seeded trials (Pred Initial, Pred + Gauss-Newton,
//!   Rand + Sim HC, Pred + Sim HC, the full pipeline, All-roots), as a table or `--json`, on
//!   the sampler's scenes, with noise, permuted rows, or in random frames;
//! - `ransac`: the robust estimator on scenes with wrong matches at several outlier ratios
//!   ([`crate::ransac`]), for a problem with a many-row sampler;
//! - `solve`: a JSON file of correspondences (read through the layout) to a validated solution;
//! - `monodromy`: all solutions of a generic instance of the problem's square subsystem
//!   ([`simhc::solver::SquareSubsystem`]), written as the start system of the fallback and the
//!   All-roots row.

use crate::app::{progress_bar, Registration, Verb};
use crate::builtin::MonodromyArgs;
use crate::ransac::RansacArgs;
use clap::{ArgMatches, Args, Command, FromArgMatches};
use nalgebra::SVector;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use simhc::layout::Layout;
use simhc::pipeline::bench::{bench_estimate_row, bench_row, table, BenchRow, Score};
use simhc::pipeline::{Method, PipelineError};
use simhc::solver::hypotheses::RankedStarts;
use simhc::solver::{
    shipped_schedule, AllRootsFallback, LearnedHypotheses, RandomStart, Scenes, SolveError, Solver, SolverAttempt, SolverOrigin, StartId,
};
use simhc::ProblemLayout;
#[cfg(feature = "train")]
use simhc_regressor::generic::train_learned_start_with;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A declared problem as a [`Registration`]: `train`, `bench`, `solve` and, with a square
/// subsystem, `monodromy`.
pub struct Declared<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    problem: Arc<S>,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Declared<S, NX, NF, NP, NC, ND>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    /// Registers `problem`.
    pub fn new(problem: S) -> Self {
        Self { problem: Arc::new(problem) }
    }

    /// The problem.
    pub fn problem(&self) -> &S {
        &self.problem
    }
}

/// `<app> train <problem>`.
#[cfg(feature = "train")]
#[derive(Args, Debug)]
struct TrainArgs {
    /// Training scenes (default: the problem's training settings).
    #[arg(long)]
    samples: Option<usize>,
    /// Epochs (default: the problem's training settings).
    #[arg(long)]
    epochs: Option<usize>,
    /// Seed of the scenes and of the training loop.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise of the training scenes (the problem's unit).
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Start hypotheses per prediction, 1 to 8 (default: the problem's training settings):
    /// winner-takes-all training; the solver ranks them on the data and tracks them in order.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=8))]
    hypotheses: Option<u8>,
    /// Widths of the per-row layers, comma-separated, for example `64,128,128` (default: the
    /// problem's training settings); each at most 256, the runtime's widest layer.
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u16).range(1..=256))]
    point_widths: Option<Vec<u16>>,
    /// Widths of the hidden layers after the pooling, comma-separated (default: the problem's
    /// training settings); each at most 256.
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u16).range(1..=256))]
    head_widths: Option<Vec<u16>>,
    /// A context stage after this many per-row layers: every later per-row layer also reads
    /// the max-pooled features of all rows, so one correspondence can be compared with the
    /// others (0: none; default: the problem's training settings). Less than the number of
    /// per-row layers.
    #[arg(long)]
    context_after: Option<usize>,
    /// The weights file to write (default: `<problem>.folded` here).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `<app> bench <problem>`.
#[derive(Args, Debug)]
struct BenchArgs {
    /// Number of sampled trials.
    #[arg(long, default_value_t = 1000)]
    trials: usize,
    /// Seed of the trials and of the random starts (printed; rerun with it to get the same).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise of the sampled scenes (the problem's unit, for example pixels); also sets the
    /// validator's tolerance.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Move every sampled scene to random frames (the problem's `move_frames`).
    #[arg(long)]
    random_frames: bool,
    /// Shuffle the rows (correspondences) of every trial.
    #[arg(long)]
    permute: bool,
    /// Read the trials from this JSON file (`[{"params": [..], "truth": [..]}, ..]`).
    #[arg(long)]
    trials_file: Option<PathBuf>,
    /// Write the trials used to this JSON file.
    #[arg(long)]
    dump_trials: Option<PathBuf>,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    weights: Option<PathBuf>,
    /// Start system of the all-roots fallback, a file made by `monodromy` (default: the
    /// problem's built-in one): read at run time, no rebuild.
    #[arg(long)]
    start_system: Option<PathBuf>,
    /// Trials of the All-roots row (the first ones; 0: no row).
    #[arg(long, default_value_t = 100)]
    all_roots: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

/// `<app> solve <problem>`.
#[derive(Args, Debug)]
struct SolveArgs {
    /// The correspondences: `{"correspondences": [{field: value, ..}, ..], "globals": {..}}`;
    /// more than the data instance has are solved on the first, refined and validated on all
    /// (`Solver::solve_rows`).
    #[arg(long)]
    input: PathBuf,
    /// Noise level of the data (the problem's unit): the validator's tolerance.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    weights: Option<PathBuf>,
    /// Start system of the all-roots fallback, a file made by `monodromy` (default: the
    /// problem's built-in one): read at run time, no rebuild.
    #[arg(long)]
    start_system: Option<PathBuf>,
}

/// Trials: the data's parameters and the true unknowns.
type Trials<const ND: usize, const NX: usize> = Vec<(SVector<f64, ND>, SVector<f64, NX>)>;

/// One trial of a `--trials-file`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Trial {
    params: Vec<f64>,
    truth: Vec<f64>,
}

fn parse<A: FromArgMatches>(m: &ArgMatches) -> Result<A, String> {
    A::from_arg_matches(m).map_err(|e| e.to_string())
}

fn print_json(value: &serde_json::Value) -> Result<(), String> {
    println!("{}", serde_json::to_string_pretty(value).map_err(|e| e.to_string())?);
    Ok(())
}

/// The errors and criterion of a problem as a bench [`Score`].
struct ProblemScore<'a, S, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(&'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Score<NX>
    for ProblemScore<'_, S, NF, NP, NC, ND>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    fn names(&self) -> &[&'static str] {
        S::ERRORS
    }
    fn errors(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> Vec<f64> {
        self.0.errors(x, truth)
    }
    fn correct(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> bool {
        self.0.correct(&self.0.errors(x, truth))
    }
}

fn bench_json(rows: &[BenchRow]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let errors: serde_json::Map<String, serde_json::Value> =
                    r.median_errors.iter().map(|(n, e)| (n.to_string(), serde_json::json!(e))).collect();
                serde_json::json!({
                    "method": r.name, "trials": r.trials, "success_pct": r.success_pct(), "solved": r.solved, "wrong": r.wrong,
                    "flagged": r.flagged, "failed": r.failed, "median_errors": errors, "median_us": r.median_us, "mean_us": r.mean_us,
                    "failures": {"input": r.failures.input, "start": r.failures.start, "simulator": r.failures.simulator, "tracker": r.failures.tracker},
                })
            })
            .collect(),
    )
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Declared<S, NX, NF, NP, NC, ND>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    fn score(&self) -> ProblemScore<'_, S, NF, NP, NC, ND> {
        ProblemScore(&self.problem)
    }

    fn weights(&self, weights: &Option<PathBuf>) -> Result<std::borrow::Cow<'static, [u8]>, String> {
        Ok(match weights {
            Some(path) => std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?.into(),
            None => self
                .problem
                .weights()
                .ok_or_else(|| format!("{} has no shipped weights: pass --weights FILE (made by `train {}`)", S::NAME, S::NAME))?
                .into(),
        })
    }

    fn solver(&self, weights: &Option<PathBuf>, noise: f64) -> Result<Solver<S, NX, NF, NP, NC, ND>, String> {
        Solver::with_shared(self.problem.clone(), &self.weights(weights)?, noise).map_err(|e| e.to_string())
    }

    /// [`Self::solver`] with the all-roots fallback of the start system file given, if one is.
    fn solver_with(
        &self,
        weights: &Option<PathBuf>,
        start_system: &Option<PathBuf>,
        noise: f64,
    ) -> Result<Solver<S, NX, NF, NP, NC, ND>, String> {
        let solver = self.solver(weights, noise)?;
        let Some(path) = start_system else { return Ok(solver) };
        let json = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let roots = self
            .problem
            .all_roots()
            .ok_or_else(|| format!("--start-system: {} has no square subsystem (DeclaredProblem::all_roots)", S::NAME))?;
        let roots = roots.with_start_system(&json).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(solver.with_fallback(AllRootsFallback(roots)))
    }

    #[cfg(feature = "train")]
    fn train(&self, a: TrainArgs) -> Result<(), String> {
        // The generic trainer fits the unknowns; a network of another output representation
        // is trained by the problem's own trainer.
        if self.problem.outputs().is_some() {
            return Err(format!(
                "train {}: the problem decodes its own network outputs (`DeclaredProblem::outputs`); the generic trainer fits the unknowns, so train its weights with the problem's own trainer",
                S::NAME
            ));
        }
        let mut config = self.problem.training();
        config.samples = a.samples.unwrap_or(config.samples);
        config.train.epochs = a.epochs.unwrap_or(config.train.epochs);
        config.train.seed = a.seed;
        config.train.progress = true;
        config.hypotheses = a.hypotheses.map_or(config.hypotheses, usize::from);
        let widths = |w: Vec<u16>| w.into_iter().map(usize::from).collect::<Vec<_>>();
        config.point_widths = a.point_widths.map_or(config.point_widths, widths);
        config.head_widths = a.head_widths.map_or(config.head_widths, widths);
        config.context_after = a.context_after.unwrap_or(config.context_after);
        // The flags' mistakes are reported before the trainer starts (and without a panic).
        config.check().map_err(|e| format!("train {}: {e}", S::NAME))?;
        let out = a.out.unwrap_or_else(|| PathBuf::from(format!("{}.folded", S::NAME)));
        println!(
            "train {}: {} scenes (noise {}), {} epochs, {} start hypotheses, layers {:?} (context after {}) then {:?}, seed {}",
            S::NAME,
            config.samples,
            a.noise,
            config.train.epochs,
            config.hypotheses,
            config.point_widths,
            config.context_after,
            config.head_widths,
            a.seed
        );
        let rows = simhc::solver::ProblemRows::<S, NX, NF, NP, NC, ND>::new(self.problem.clone());
        let trained = train_learned_start_with(&S::Data::LAYOUT, rows, &config, |rng| {
            let (mut p, mut x) = self.problem.scene(rng, a.noise);
            if let Some((pc, frame)) = self.problem.canonicalize(&p) {
                (p, x) = (pc, frame.to_canonical(&x));
            }
            (p.as_slice().to_vec(), x.as_slice().to_vec())
        })
        .map_err(|e| e.to_string())?;
        std::fs::write(&out, trained.start.network().to_bytes()).map_err(|e| format!("{}: {e}", out.display()))?;
        println!(
            "trained in {:.1} s; last epoch loss {:.4e}; weights: {}",
            trained.run.train_seconds,
            trained.run.epoch_losses.last().copied().unwrap_or(f64::NAN),
            out.display()
        );
        Ok(())
    }

    fn trials(&self, a: &BenchArgs) -> Result<(Trials<ND, NX>, String), String> {
        if let Some(path) = &a.trials_file {
            return Ok((read_trials(path)?, format!("file {}", path.display())));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
        let mut trials = Vec::with_capacity(a.trials);
        for i in 0..a.trials {
            let (mut p, mut x) = self.problem.scene(&mut rng, a.noise);
            if a.random_frames {
                (p, x) = self
                    .problem
                    .move_frames(&mut rng, &p, &x)
                    .ok_or_else(|| format!("{} has no random frames (Scenes::move_frames)", S::NAME))?;
            }
            if a.permute {
                p = permute_rows(&S::Data::LAYOUT, &p, &mut rng);
            }
            if !p.iter().chain(x.iter()).all(|v| v.is_finite()) {
                return Err(format!("the sampler gave a non-finite trial {i}"));
            }
            trials.push((p, x));
        }
        Ok((trials, format!("sampled, seed {}, noise {}, random frames {}, permuted {}", a.seed, a.noise, a.random_frames, a.permute)))
    }

    fn ransac(&self, a: RansacArgs) -> Result<(), String> {
        let (file, source) = crate::ransac::declared_trials(&*self.problem, &a)?;
        let solver = self.solver(&a.weights, file.noise)?;
        let report = crate::ransac::estimate_declared(&*self.problem, &solver, &file, a.skip_explained)?;
        crate::ransac::print(&a, &file, &source, &report)
    }

    fn bench(&self, a: BenchArgs) -> Result<(), String> {
        let (trials, source) = self.trials(&a)?;
        if let Some(path) = &a.dump_trials {
            let file: Vec<Trial> =
                trials.iter().map(|(p, x)| Trial { params: p.as_slice().to_vec(), truth: x.as_slice().to_vec() }).collect();
            std::fs::write(path, serde_json::to_string(&file).map_err(|e| e.to_string())?)
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
        let solver = self.solver_with(&a.weights, &a.start_system, a.noise)?;
        let random = RandomStart::new(S::Data::LAYOUT, a.seed.wrapping_add(1));
        let has_refine = solver.plan().refine;
        let has_fallback = solver.has_fallback();
        let progress = !a.json;
        if progress {
            println!("{} bench: {} trials ({source}), single thread", S::NAME, trials.len());
        }
        let score = self.score();
        // Every row runs the library solver's own assembly (its ranked hypotheses), the random
        // start given to every run (only the row that names it uses it).
        let row = |name: &str, schedule: &[SolverAttempt], with_fallback: bool, trials: &[(SVector<f64, ND>, SVector<f64, NX>)]| {
            let bar = progress_bar(trials.len() as u64, progress);
            bar.set_message(name.to_string());
            let row = bench_row(name, trials, &score, |d| {
                bar.inc(1);
                solver.run_pipeline(d, schedule, with_fallback, Some(&random))
            });
            bar.finish_and_clear();
            row
        };
        let one = shipped_schedule(has_refine);
        let (gauss_newton, simulator_hc) = one.split_at(one.len() - 1);
        let hypotheses = solver.learned_start().hypotheses();
        // One set of hypotheses per trial: a set keeps those of the datum it was first asked
        // about.
        let first = |p: &SVector<f64, ND>| RankedStarts::new(solver.learned_start()).start(p, 0).ok();
        let mut rows = vec![
            bench_estimate_row("Pred Initial", &trials, &score, |p| match self.problem.canonicalize(p) {
                Some((pc, frame)) => first(&pc).map(|x| frame.to_user(&x)),
                None => first(p),
            }),
            row(if has_refine { "Pred + Gauss-Newton (all rows)" } else { "Pred + Gauss-Newton" }, gauss_newton, false, &trials),
            row("Rand + Sim HC (one path)", &[SolverAttempt::new(StartId::Given, Method::SimulatorHc)], false, &trials),
            row("Pred + Sim HC (one path)", simulator_hc, false, &trials),
        ];
        if hypotheses > 1 {
            let name = format!("Shipped attempts ({hypotheses} hypotheses), no fallback");
            rows.push(row(&name, solver.schedule(), false, &trials));
        }
        let shipped_name = match (has_fallback, hypotheses > 1) {
            (true, true) => "Shipped (ranked hypotheses: GN, Sim HC; all roots)",
            (true, false) => "Shipped (GN, Sim HC, all roots)",
            (false, true) => "Shipped (ranked hypotheses: GN, then Sim HC)",
            (false, false) => "Shipped (GN, then Sim HC)",
        };
        // The shipped row also counts the trials the all-roots fallback ended (validated or
        // flagged): the ones whose time is the fallback's.
        let fallbacks = std::cell::Cell::new(0usize);
        let bar = progress_bar(trials.len() as u64, progress);
        bar.set_message(shipped_name.to_string());
        rows.push(bench_row(shipped_name, &trials, &score, |d| {
            bar.inc(1);
            let result = solver.run_pipeline(d, solver.schedule(), true, Some(&random));
            let origin = match &result {
                Ok(s) => Some(s.origin),
                Err(PipelineError::NotValidated(s)) => Some(s.origin),
                Err(_) => None,
            };
            fallbacks.set(fallbacks.get() + usize::from(matches!(origin, Some(SolverOrigin::Fallback { .. }))));
            result
        }));
        bar.finish_and_clear();
        let fallbacks = fallbacks.get();
        // The certificates of the shipped solves that validate, timed alone (not in any row).
        let certificates = {
            let (mut stats, mut times) = (crate::certificates::CertificateStats::default(), Vec::new());
            for (d, truth) in &trials {
                if let Ok(s) = solver.run_pipeline(d, solver.schedule(), true, None) {
                    let t0 = std::time::Instant::now();
                    let certified = solver.certify(d, &s.x).is_ok();
                    let micros = t0.elapsed().as_secs_f64() * 1e6;
                    stats.push(certified, score.correct(&s.x, truth), micros, &mut times);
                }
            }
            let shipped_median = rows.last().map_or(f64::NAN, |r| r.median_us);
            stats.finish(times, shipped_median)
        };
        if has_fallback && a.all_roots > 0 {
            rows.push(row("All-roots HC (validated)", &[], true, &trials[..a.all_roots.min(trials.len())]));
        }
        if a.json {
            return print_json(
                &serde_json::json!({"problem": S::NAME, "source": source, "seed": a.seed, "noise": a.noise, "rows": bench_json(&rows), "shipped_fallbacks": fallbacks, "certificates": certificates}),
            );
        }
        print!("{}", table(&rows));
        println!(
            "success: validated (rows after Pred Initial) and {}; errors: medians over returned estimates; times: microseconds per solve; flag: failed validation; fail: why, by the last attempt's error",
            S::ERRORS.join(", ")
        );
        if has_fallback {
            println!("shipped: {fallbacks} of {} trials ended in the all-roots fallback", trials.len());
        }
        println!("{}", certificates.line());
        if let [.., shipped, all] = rows.as_slice() {
            if all.name.starts_with("All-roots") && shipped.median_us > 0.0 {
                println!("median time, All-roots / Shipped: {:.1}x", all.median_us / shipped.median_us);
            }
        }
        Ok(())
    }

    fn solve(&self, a: SolveArgs) -> Result<(), String> {
        let layout = S::Data::LAYOUT;
        let text = std::fs::read_to_string(&a.input).map_err(|e| format!("{}: {e}", a.input.display()))?;
        let (rows, globals) = simhc::input::parse_layout_rows(&layout, &text).map_err(|e| format!("{}: {e}", a.input.display()))?;
        let solver = self.solver_with(&a.weights, &a.start_system, a.noise)?.certifying(simhc::solver::Certification::Report);
        let unknowns = |x: &SVector<f64, NX>| -> serde_json::Value {
            layout
                .unknowns
                .iter()
                .map(|f| {
                    let v = &x.as_slice()[f.offset..f.offset + f.kind.len()];
                    // A scalar unknown is a number, a vector or quaternion an array.
                    (
                        f.name.to_string(),
                        if f.kind == simhc::layout::FieldKind::Scalar { serde_json::json!(v[0]) } else { serde_json::json!(v) },
                    )
                })
                .collect::<serde_json::Map<_, _>>()
                .into()
        };
        if rows.len() > layout.rows * layout.per_row {
            // More rows than the data instance: solved on the first, refined and validated on all.
            let s = solver.solve_rows(&rows, &globals).map_err(|e| format!("{}: {e}", a.input.display()))?;
            return print_json(&serde_json::json!({
                "problem": S::NAME, "validated": true, "unknowns": unknowns(&s.x), "rows": s.rows, "refined": s.refined, "max_row_error": s.max_row_error,
            }));
        }
        let p = SVector::<f64, ND>::from_iterator(rows.into_iter().chain(globals));
        match solver.solve(&p) {
            Ok(s) => print_json(&serde_json::json!({
                "problem": S::NAME, "validated": true, "unknowns": unknowns(&s.x), "origin": origin_json(s.origin)?, "attempts": s.attempts, "check": to_json(&s.check)?, "certificate": crate::certificates::json(&s.certified),
            })),
            Err(SolveError::NotValidated { best, check, attempts }) => Err(format!(
                "{}: no solution validated after {attempts} attempts (noise {}; pass --noise for noisy data); best, flagged, NOT a solution: {} (check {})",
                a.input.display(),
                a.noise,
                unknowns(&best),
                to_json(&check)?,
            )),
            Err(e) => Err(format!("{}: {e}", a.input.display())),
        }
    }
}

/// What produced a solution, as JSON: `{"start": "learned 0", "method": "GaussNewton"}` for
/// an attempt (the start by name, [`simhc::solver::StartId`]; the method as
/// [`simhc::pipeline::Method`] serializes), `{"fallback": k}` for the all-roots fallback's
/// candidate `k`.
fn origin_json(origin: SolverOrigin) -> Result<serde_json::Value, String> {
    Ok(match origin {
        SolverOrigin::Attempt(SolverAttempt { start, method }) => {
            serde_json::json!({ "start": start.to_string(), "method": to_json(&method)? })
        }
        SolverOrigin::Fallback { candidate } => serde_json::json!({ "fallback": candidate }),
    })
}

/// `value` as JSON. Fails only for a user's `Serialize` that fails (a map with non-string
/// keys), which is then an error of the command, not a panic.
fn to_json<T: Serialize>(value: &T) -> Result<serde_json::Value, String> {
    serde_json::to_value(value).map_err(|e| format!("printing the solve as JSON: {e}"))
}

/// The rows of `p` in a random order (globals stay).
fn permute_rows<const NP: usize>(layout: &Layout, p: &SVector<f64, NP>, rng: &mut ChaCha8Rng) -> SVector<f64, NP> {
    let mut order: Vec<usize> = (0..layout.rows).collect();
    order.shuffle(rng);
    let mut out = *p;
    for (to, &from) in order.iter().enumerate() {
        for k in 0..layout.per_row {
            out[to * layout.per_row + k] = p[from * layout.per_row + k];
        }
    }
    out
}

fn read_trials<const NP: usize, const NX: usize>(path: &Path) -> Result<Trials<NP, NX>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let trials: Vec<Trial> =
        serde_json::from_str(&text).map_err(|e| format!("{}: line {}, column {}: {e}", path.display(), e.line(), e.column()))?;
    trials
        .into_iter()
        .enumerate()
        .map(|(i, t)| {
            if t.params.len() != NP || t.truth.len() != NX {
                return Err(format!(
                    "{}: trial {i}: {} params and {} unknowns, expected {NP} and {NX}",
                    path.display(),
                    t.params.len(),
                    t.truth.len()
                ));
            }
            Ok((SVector::from_column_slice(&t.params), SVector::from_column_slice(&t.truth)))
        })
        .collect()
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Registration
    for Declared<S, NX, NF, NP, NC, ND>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    fn name(&self) -> &'static str {
        S::NAME
    }

    fn command(&self, verb: Verb) -> Option<Command> {
        let c = Command::new(S::NAME);
        let c = match verb {
            #[cfg(feature = "train")]
            Verb::Train => TrainArgs::augment_args(c),
            #[cfg(not(feature = "train"))]
            Verb::Train => return None,
            Verb::Bench => BenchArgs::augment_args(c),
            Verb::Ransac => {
                // Only for a problem with a many-row sampler (one scene drawn to see).
                let rows = S::Data::LAYOUT.rows;
                self.problem.scene_rows(&mut ChaCha8Rng::seed_from_u64(0), rows, 0.0)?;
                RansacArgs::augment_args(c)
            }
            Verb::Solve => SolveArgs::augment_args(c),
            Verb::Monodromy => {
                self.problem.all_roots()?;
                MonodromyArgs::augment_args(c)
            }
        };
        Some(c.about(S::ABOUT))
    }

    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        // The sizes are checked by the trait's bounds at compile time; that the tracked rows are
        // the first rows of the data is not a size.
        let (data, tracked) = (S::Data::LAYOUT, S::Tracked::LAYOUT);
        if tracked.rows > data.rows || tracked.per_row != data.per_row {
            return Err(format!(
                "{}: the tracked instance ({} rows of {}) is not the first rows of the data instance ({} rows of {})",
                S::NAME,
                tracked.rows,
                tracked.per_row,
                data.rows,
                data.per_row
            ));
        }
        match verb {
            #[cfg(feature = "train")]
            Verb::Train => self.train(parse(args)?),
            #[cfg(not(feature = "train"))]
            Verb::Train => Err(crate::builtin::NO_TRAINER.into()),
            Verb::Bench => self.bench(parse(args)?),
            Verb::Ransac => self.ransac(parse(args)?),
            Verb::Solve => self.solve(parse(args)?),
            Verb::Monodromy => {
                let roots =
                    self.problem.all_roots().ok_or_else(|| format!("{} has no square subsystem (DeclaredProblem::all_roots)", S::NAME))?;
                MonodromyArgs::run(args, |config| roots.monodromy(config))
            }
        }
    }
}
