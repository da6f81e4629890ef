//! `simhc bench grps` (numerical stability, success vs start error, noise resilience, RANSAC,
//! figures), `simhc solve grps` and the settings of `simhc train grps`.

use crate::plots::{log10_histogram, write_figure, Panel, Series};
use crate::stats::{mean, median, MethodRecord, Outcome, Summary, Thresholds};
use nalgebra::SVector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use simhc::all_roots::AllRootsOptions;
use simhc::pipeline::{Method, PipelineError, Solved, StartError, StartProvider};
use simhc::ransac::RansacOptions;
use simhc::solver::{DeclaredProblem, FirstRowsError, LearnedHypotheses, SolveError, Solver, SolverAttempt, SolverOrigin, StartId};
use simhc_problems::grps::declared::{
    grps_pipeline_options, params_of, sample_attempts, sample_candidates, GrpsSolvers, GrpsSolversError, RANSAC_NOISE_PX, RESTARTS,
};
use simhc_problems::grps::learned::GRPS_WEIGHTS;
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::refine::{lm_polynomial, refine_pose, LmOptions};
use simhc_problems::grps::scene::{GrpsCorrespondence, GrpsScene, GrpsSceneConfig};
use simhc_problems::grps::validation::Validation;
use simhc_problems::grps::{self, row_numbers, Grps7, Grps8};
use simhc_problems::metrics::{
    perturb_scale, perturb_translation, random_rotation_perturbation, rotation_error_deg, scale_error_pct, translation_error_pct,
};
use simhc_problems::start_systems::{best_real_solution, solve_grps7, Selection};
use std::path::PathBuf;
use std::time::Instant;

/// The paper's success criterion for GRPS: `E_R < 2 deg`, `E_t < 5 %`, `E_s < 5 %`.
pub const THRESHOLDS: Thresholds = Thresholds { rotation_deg: 2.0, translation_pct: Some(5.0), scale_pct: Some(5.0) };

/// Experiments of `bench grps`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Experiment {
    /// Numerical stability: every method on the same noise-free trials, error histograms.
    Stability,
    /// Success vs start error (ground truth perturbed by 5..45 deg) per simulator and for
    /// Gauss-Newton.
    Starts,
    /// Noise resilience: 0.2..1.0 px, 1 / 3 / 5 cameras per view.
    Noise,
    /// RANSAC: 200 correspondences, 5 cameras, 10..40 % outliers.
    Ransac,
    /// All of the above.
    All,
}

/// Options of `bench grps` (ignored by the other benchmarks).
#[derive(clap::Args, Debug, Clone)]
pub struct GrpsArgs {
    /// bench grps: experiment to run (repeat the flag for several; default all).
    #[arg(long = "experiment", value_enum)]
    pub experiments: Vec<Experiment>,
    /// bench grps: run All-roots HC (about 0.1 s per solve) on the first N stability trials.
    #[arg(long, default_value_t = 200)]
    pub all_roots: usize,
    /// bench grps: folder of the figures (PNG and SVG).
    #[arg(long, default_value = "target/figures")]
    pub figures: PathBuf,
    /// bench grps: trials per noise level and camera count.
    #[arg(long, default_value_t = 300)]
    pub noise_trials: usize,
    /// bench grps: RANSAC runs per outlier ratio.
    #[arg(long, default_value_t = 300)]
    pub ransac_trials: usize,
    /// bench grps: correspondences per RANSAC sample (7: minimal, up to 4 validated roots a
    /// sample; 8: overdetermined).
    #[arg(long, default_value_t = 7)]
    pub ransac_sample: usize,
    /// bench grps: RANSAC with local optimization (refine every new best model on its inliers).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub ransac_lo: bool,
    /// bench grps: the regressor's weights, a `.folded` file written by `simhc train grps`
    /// (default: the shipped ones), to compare a training run with the shipped weights on the
    /// same trials.
    #[arg(long)]
    pub weights: Option<PathBuf>,
}

impl GrpsArgs {
    /// The GRPS solvers with the regressor of `--weights` (the shipped one without),
    /// validating for noise of `noise_px` pixels.
    fn solvers(&self, noise_px: f64) -> Result<GrpsSolvers, String> {
        match &self.weights {
            None => GrpsSolvers::new(noise_px).map_err(|e| format!("loading the shipped regressor: {e}")),
            Some(path) => {
                let bytes = std::fs::read(path).map_err(|e| format!("--weights {}: {e}", path.display()))?;
                GrpsSolvers::with_weights(&bytes, noise_px).map_err(|e| format!("--weights {}: {e}", path.display()))
            }
        }
    }

    fn runs(&self, e: Experiment) -> bool {
        self.experiments.is_empty() || self.experiments.contains(&Experiment::All) || self.experiments.contains(&e)
    }
}

/// Samples `n` seeded noise-free 8-point trials (3 cameras per view), each in random frames
/// ([`GrpsScene::random_frames`], drawn from the same stream right after its scene) when
/// `random_frames` is set.
pub fn sample_trials(n: usize, seed: u64, random_frames: bool) -> Result<Vec<GrpsScene>, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let config = GrpsSceneConfig::default();
    (0..n)
        .map(|_| {
            let scene = config.sample(&mut rng).map_err(|e| e.to_string())?;
            Ok(if random_frames { scene.random_frames(&mut rng) } else { scene })
        })
        .collect()
}

fn us(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

fn outcome(pose: &GrpsPose, scene: &GrpsScene, micros: f64, split: Option<[f64; 3]>) -> Outcome {
    Outcome {
        rotation_deg: Some(rotation_error_deg(&pose.rotation, &scene.rotation)),
        translation_pct: Some(translation_error_pct(&pose.translation, &scene.translation)),
        scale_pct: Some(scale_error_pct(pose.scale, scene.scale)),
        micros,
        split,
        flagged: false,
    }
}

fn failed(micros: f64) -> Outcome {
    Outcome { micros, ..Outcome::default() }
}

fn ok(o: &Outcome) -> bool {
    o.rotation_deg.is_some_and(|e| e < THRESHOLDS.rotation_deg)
        && o.translation_pct.is_some_and(|e| e < 5.0)
        && o.scale_pct.is_some_and(|e| e < 5.0)
}

/// What one run of a GRPS library solver's pipeline returns.
type PipelineOutcome = Result<Solved<Validation, 8, SolverOrigin>, PipelineError<FirstRowsError, Validation, 8, SolverOrigin>>;

/// The end point a run returned: validated, or flagged (`NotValidated` carries the best one).
fn returned(result: &PipelineOutcome) -> Option<(&Solved<Validation, 8, SolverOrigin>, bool)> {
    match result {
        Ok(s) => Some((s, false)),
        Err(PipelineError::NotValidated(s)) => Some((s, true)),
        Err(_) => None,
    }
}

/// A solver row: outcomes plus the count of flagged (not validated) results and attempts.
struct SolverRow {
    record: MethodRecord,
    flagged: usize,
    fallbacks: usize,
    attempts: Vec<f64>,
}

impl SolverRow {
    fn new(name: &str) -> Self {
        Self { record: MethodRecord::new(name), flagged: 0, fallbacks: 0, attempts: Vec::new() }
    }

    fn push(&mut self, result: &PipelineOutcome, scene: &GrpsScene, micros: f64) {
        match returned(result).and_then(|(s, flagged)| Some((s, flagged, GrpsPose::from_unknowns(&s.x)?))) {
            Some((s, flagged, pose)) => {
                self.flagged += usize::from(flagged);
                self.fallbacks += usize::from(matches!(s.origin, SolverOrigin::Fallback { .. }));
                self.attempts.push(s.attempts as f64);
                let split = [us(s.times.start), us(s.times.simulator), us(s.times.target + s.times.tracking + s.times.fallback)];
                let o = outcome(&pose, scene, micros, Some(split));
                self.record.outcomes.push(Outcome { flagged, ..o });
            }
            None => self.record.outcomes.push(failed(micros)),
        }
    }
}

/// A start given by the caller (a perturbed ground truth), already in the problem's canonical
/// frame: the solver's pipeline hands its providers canonical data.
struct GivenStart(SVector<f64, 8>);

impl<const NP: usize> StartProvider<SVector<f64, NP>, 8> for GivenStart {
    fn name(&self) -> &'static str {
        "given"
    }
    fn start(&self, _: &SVector<f64, NP>) -> Result<SVector<f64, 8>, StartError> {
        Ok(self.0)
    }
}

/// The start providers of the GRPS library solver with `hypotheses` learned hypotheses, in the
/// order the hand-wired solver tried them: the learned start's ranked hypotheses (plain), then
/// the three predicted starts (the predicted rotation with least-squares `(t, s)`, the swapped
/// prediction and its rotation with least-squares `(t, s)`).
fn start_providers(hypotheses: usize) -> Vec<StartId> {
    let mut starts: Vec<StartId> = (0..hypotheses.max(1)).map(|rank| StartId::Learned { rank, refined: false }).collect();
    starts.extend((0..3).map(StartId::Other));
    starts
}

/// The retries of the stability rows as a schedule: `methods` on every start
/// ([`start_providers`]), all of them on one start before the next (`by_method` false) or each
/// method on every start before the next method; then Gauss-Newton from every restart; at most
/// 80 attempts; no fallback.
fn retries(hypotheses: usize, methods: &[Method], by_method: bool) -> Vec<SolverAttempt> {
    let starts = start_providers(hypotheses);
    let mut out: Vec<SolverAttempt> = if by_method {
        methods.iter().flat_map(|&method| starts.iter().map(move |&start| SolverAttempt { start, method })).collect()
    } else {
        starts.iter().flat_map(|&start| methods.iter().map(move |&method| SolverAttempt { start, method })).collect()
    };
    out.extend((0..RESTARTS).map(|k| SolverAttempt::new(StartId::Restart(k), Method::GaussNewton)));
    out.truncate(80);
    out
}

/// The geometric simulator (the tracked instance's own) and the generic minimum-norm one.
const GEOMETRIC: Method = Method::SimulatorHc;
const GENERIC: Method = Method::OtherSimulatorHc(0);

/// Notes of a stability row beyond [`Summary`].
#[derive(Debug, Clone, Serialize)]
pub struct RowNotes {
    /// Row label.
    pub method: String,
    /// Results returned flagged (no end point passed validation).
    pub flagged: usize,
    /// Mean attempts per solve.
    pub attempts_mean: f64,
    /// Largest number of attempts.
    pub attempts_max: f64,
    /// Results from the all-roots fallback.
    pub fallbacks: usize,
}

/// The numerical-stability section.
#[derive(Debug, Serialize)]
pub struct StabilityReport {
    /// Rows (same trials; All-roots on the first `all_roots_trials`).
    pub rows: Vec<Summary>,
    /// Flag and attempt counts of the solver rows.
    pub notes: Vec<RowNotes>,
    /// Trials of the All-roots row.
    pub all_roots_trials: usize,
}

/// One cell of the success-vs-start-error table.
#[derive(Debug, Clone, Serialize)]
pub struct StartCell {
    /// Method.
    pub method: String,
    /// Start rotation error (degrees).
    pub start_deg: f64,
    /// Success (percent).
    pub success_pct: f64,
    /// Median time per solve (microseconds).
    pub time_median_us: f64,
}

/// One row of the noise table.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseRow {
    /// Cameras per view.
    pub cameras: usize,
    /// Noise (pixels).
    pub noise_px: f64,
    /// Trials.
    pub trials: usize,
    /// Typed errors (e.g. a single camera pair: scale unobservable).
    pub errors: usize,
    /// The most common typed error, if any.
    pub error: Option<String>,
    /// Success (percent).
    pub success_pct: f64,
    /// Median errors.
    pub rotation_median_deg: f64,
    /// Median translation error (percent).
    pub translation_median_pct: f64,
    /// Median scale error (percent).
    pub scale_median_pct: f64,
    /// Median time per solve (microseconds).
    pub time_median_us: f64,
    /// Reference: median rotation error of Gauss-Newton on the same system started at the
    /// ground truth (the accuracy the noisy 8-point system allows).
    pub reference_rotation_median_deg: f64,
    /// Reference median translation error (percent).
    pub reference_translation_median_pct: f64,
    /// Reference median scale error (percent).
    pub reference_scale_median_pct: f64,
}

/// One row of the RANSAC table.
#[derive(Debug, Clone, Serialize)]
pub struct RansacRow {
    /// Outlier ratio.
    pub outlier_ratio: f64,
    /// Runs.
    pub trials: usize,
    /// Success with the paper's RANSAC criterion (`E_R < 2 deg`), percent.
    pub success_pct: f64,
    /// Success with all three thresholds, percent.
    pub success_all_pct: f64,
    /// Mean errors over the successful runs (as the paper).
    pub rotation_mean_deg: f64,
    /// Mean translation error (percent).
    pub translation_mean_pct: f64,
    /// Mean scale error (percent).
    pub scale_mean_pct: f64,
    /// Mean iterations.
    pub iterations_mean: f64,
    /// Mean time per run (milliseconds).
    pub time_mean_ms: f64,
    /// Median time per run (milliseconds).
    pub time_median_ms: f64,
    /// Reference: mean errors of Levenberg-Marquardt from the ground truth on the true inliers
    /// (the accuracy the noisy inliers allow).
    pub reference_mean: [f64; 3],
}

/// The benchmark's JSON document.
#[derive(Debug, Serialize)]
pub struct BenchReport {
    /// Problem.
    pub problem: &'static str,
    /// Seed.
    pub seed: u64,
    /// Stability / start trials.
    pub trials: usize,
    /// Where the trials came from.
    pub source: String,
    /// Success criterion.
    pub thresholds: Thresholds,
    /// Numerical stability.
    pub stability: Option<StabilityReport>,
    /// Success vs start error.
    pub starts: Vec<StartCell>,
    /// Noise resilience.
    pub noise: Vec<NoiseRow>,
    /// RANSAC.
    pub ransac: Vec<RansacRow>,
    /// RANSAC sample size.
    pub ransac_sample: usize,
    /// RANSAC with local optimization.
    pub ransac_lo: bool,
    /// Hypotheses per RANSAC sample.
    pub ransac_hypotheses: usize,
    /// Solver attempts per RANSAC sample.
    pub ransac_attempts: usize,
    /// Figures written.
    pub figures: Vec<PathBuf>,
}

/// One run of `solver`'s pipeline on `corrs` (exactly the instance's count) with `schedule`,
/// with or without the fallback, and with `given` (a start in the user's frame, mapped into the
/// problem's canonical frame) as the run's given start; `None` for another count.
fn run<S, const NF: usize, const NP: usize, const NC: usize>(
    solver: &Solver<S, 8, NF, NP, NC, NP>,
    corrs: &[GrpsCorrespondence],
    schedule: &[SolverAttempt],
    fallback: bool,
    given: Option<&SVector<f64, 8>>,
) -> Option<PipelineOutcome>
where
    S: DeclaredProblem<8, NF, NP, NC, NP, Validator = simhc_problems::grps::validation::GrpsValidator>,
{
    let p = params_of::<NP>(corrs)?;
    let start = given.map(|x| match solver.problem().canonicalize(&p) {
        Some((_, frame)) => GivenStart(frame.to_canonical(x)),
        None => GivenStart(*x),
    });
    let given = start.as_ref().map(|s| s as &dyn StartProvider<SVector<f64, NP>, 8>);
    Some(solver.run_pipeline(&p, schedule, fallback, given))
}

/// A run's end point as a pose (validated or flagged), scored against the scene.
fn pose_outcome(result: Option<&PipelineOutcome>, scene: &GrpsScene, micros: f64) -> Outcome {
    match result.and_then(returned).and_then(|(s, _)| GrpsPose::from_unknowns(&s.x)) {
        Some(pose) => outcome(&pose, scene, micros, None),
        None => failed(micros),
    }
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let r = f();
    (r, us(t.elapsed()))
}

/// Runs the selected experiments.
pub fn bench(trials: &[GrpsScene], seed: u64, source: String, args: &GrpsArgs, progress: bool) -> Result<BenchReport, String> {
    let mut report = BenchReport {
        problem: "grps",
        seed,
        trials: trials.len(),
        source,
        thresholds: THRESHOLDS,
        stability: None,
        starts: Vec::new(),
        noise: Vec::new(),
        ransac: Vec::new(),
        ransac_sample: args.ransac_sample,
        ransac_lo: args.ransac_lo,
        ransac_hypotheses: sample_candidates(args.ransac_sample),
        ransac_attempts: sample_attempts(args.ransac_sample),
        figures: Vec::new(),
    };
    if args.runs(Experiment::Stability) {
        report.stability = Some(stability(trials, args, progress, &mut report.figures)?);
    }
    if args.runs(Experiment::Starts) {
        report.starts = starts(trials, seed, args, progress)?;
    }
    if args.runs(Experiment::Noise) {
        report.noise = noise(seed, args, progress, &mut report.figures)?;
    }
    if args.runs(Experiment::Ransac) {
        report.ransac = ransac_bench(seed, args, progress)?;
    }
    Ok(report)
}

fn stability(trials: &[GrpsScene], args: &GrpsArgs, progress: bool, figures: &mut Vec<PathBuf>) -> Result<StabilityReport, String> {
    let solvers = args.solvers(0.0)?;
    let (seven, eight) = (&solvers.seven, &solvers.eight);
    let hypotheses = eight.learned_start().hypotheses();
    let learned = StartId::LEARNED;
    // Every row is a schedule over the one solver (`GrpsSolvers`): the retries' rows without
    // the fallback, the shipped rows its own schedule with it.
    let one_geometric = [SolverAttempt { start: learned, method: GEOMETRIC }];
    let one_generic = [SolverAttempt { start: learned, method: GENERIC }];
    let retry_geometric = retries(hypotheses, &[GEOMETRIC, Method::GaussNewton, GENERIC], false);
    let retry_generic = retries(hypotheses, &[GENERIC, Method::GaussNewton, GEOMETRIC], false);
    let retry_gn_first = retries(hypotheses, &[Method::GaussNewton, GENERIC, GEOMETRIC], true);
    let mut pred = MethodRecord::new("Pred Initial");
    let mut pred_lm = MethodRecord::new("Pred + LM (8 pts)");
    let mut pred_gn = MethodRecord::new("Pred + pipeline Gauss-Newton (8 pts)");
    let mut rows = [
        SolverRow::new("Sim HC 7 pts, geometric, 1 path"),
        SolverRow::new("Sim HC 7 pts, generic, 1 path"),
        SolverRow::new("Sim HC 8 pts, geometric, 1 path"),
        SolverRow::new("Sim HC 8 pts, generic, 1 path"),
        SolverRow::new("Sim HC 8 pts, geometric + retries"),
        SolverRow::new("Sim HC 8 pts, generic + retries"),
        SolverRow::new("GN on every start, then Sim HC, 8 pts"),
        SolverRow::new("Sim HC 7 pts, geometric + retries"),
        SolverRow::new("GN on every start, then Sim HC, 7 pts"),
        SolverRow::new("Shipped 7 pts (retries+fallback)"),
        SolverRow::new("Shipped 8 pts (retries+fallback)"),
    ];
    let all_roots_trials = args.all_roots.min(trials.len());
    let mut all_roots = MethodRecord::new("All-roots HC 7 pts (1 thread)");
    let all_roots_options = AllRootsOptions::default();
    let bar = crate::app::progress_bar(trials.len() as u64, progress);
    for (i, scene) in trials.iter().enumerate() {
        let c8: &[GrpsCorrespondence] = &scene.correspondences[..8.min(scene.correspondences.len())];
        let c7 = &c8[..7.min(c8.len())];

        // Pred Initial: the learned start as it is (its first-ranked hypothesis).
        let start_only = [SolverAttempt { start: learned, method: Method::Start }];
        let (p, micros) = timed(|| run(eight, c8, &start_only, false, None));
        pred.outcomes.push(pose_outcome(p.as_ref(), scene, micros));
        let lm = |x0: SVector<f64, 8>| -> Option<GrpsPose> {
            let rows = grps::rows_of::<8>(c8)?;
            let r = lm_polynomial::<Grps8, 9, 96>(&x0, &Grps8::params(&rows), &LmOptions::default());
            GrpsPose::from_unknowns(&r.x)
        };
        let (r, micros) = timed(|| {
            let p = run(eight, c8, &start_only, false, None)?;
            lm(returned(&p)?.0.x)
        });
        pred_lm.outcomes.push(r.map_or(failed(micros), |p| outcome(&p, scene, micros, None)));
        // The pipeline's Gauss-Newton: an end point that does not converge is no end point (the
        // hand-wired row scored it all the same, as a wrong pose).
        let gn_only = [SolverAttempt { start: learned, method: Method::GaussNewton }];
        let (r, micros) = timed(|| run(eight, c8, &gn_only, false, None));
        pred_gn.outcomes.push(pose_outcome(r.as_ref(), scene, micros));

        let runs: [(bool, &[SolverAttempt], bool); 11] = [
            (false, &one_geometric, false),
            (false, &one_generic, false),
            (true, &one_geometric, false),
            (true, &one_generic, false),
            (true, &retry_geometric, false),
            (true, &retry_generic, false),
            (true, &retry_gn_first, false),
            (false, &retry_geometric, false),
            (false, &retry_gn_first, false),
            (false, seven.schedule(), true),
            (true, eight.schedule(), true),
        ];
        // The rows of one solver run one after the other (those of 7 points, then those of 8),
        // so that each row finds its solver's network in the cache, as the rows of one
        // hand-wired solver did; the table keeps the order above.
        let mut order: Vec<usize> = (0..runs.len()).collect();
        order.sort_by_key(|&k| runs[k].0);
        for k in order {
            let (row, (on_eight, schedule, fallback)) = (&mut rows[k], runs[k]);
            let (r, micros) =
                timed(|| if on_eight { run(eight, c8, schedule, fallback, None) } else { run(seven, c7, schedule, fallback, None) });
            match r {
                Some(r) => row.push(&r, scene, micros),
                None => row.record.outcomes.push(failed(micros)),
            }
        }

        if i < all_roots_trials {
            let x_gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
            let (best, micros) = timed(|| {
                let rows = grps::rows_of::<7>(c7)?;
                let result = solve_grps7(&Grps7::params(&rows), &all_roots_options);
                best_real_solution(&result, Selection::ClosestTo(&x_gt))
            });
            all_roots.outcomes.push(match best.and_then(|s| GrpsPose::from_unknowns(&s.x)) {
                Some(p) => outcome(&p, scene, micros, None),
                None => failed(micros),
            });
        }
        bar.inc(1);
    }
    bar.finish_and_clear();

    let mut records = vec![pred, pred_lm, pred_gn];
    let mut notes = Vec::new();
    for row in rows {
        notes.push(RowNotes {
            method: row.record.name.clone(),
            flagged: row.flagged,
            attempts_mean: mean(&row.attempts),
            attempts_max: row.attempts.iter().copied().fold(0.0, f64::max),
            fallbacks: row.fallbacks,
        });
        records.push(row.record);
    }
    if all_roots_trials > 0 {
        records.push(all_roots);
    }

    // Figure: log10 error histograms of the main rows.
    let shown = [
        "Pred Initial",
        "Pred + LM (8 pts)",
        "Pred + pipeline Gauss-Newton (8 pts)",
        "Sim HC 7 pts, geometric, 1 path",
        "Sim HC 8 pts, geometric, 1 path",
        "Shipped 8 pts (retries+fallback)",
        "All-roots HC 7 pts (1 thread)",
    ];
    let panel = |title: &str, unit: &str, get: fn(&Outcome) -> Option<f64>| Panel {
        title: title.to_string(),
        x_label: format!("log10 error ({unit})"),
        y_label: "trials (%)".to_string(),
        series: records
            .iter()
            .filter(|r| shown.contains(&r.name.as_str()))
            .map(|r| {
                let v: Vec<f64> = r.outcomes.iter().map(|o| get(o).unwrap_or(f64::INFINITY)).collect();
                (r.name.clone(), log10_histogram(&v, -13.0, 3.0, 32))
            })
            .collect::<Vec<Series>>(),
    };
    let panels = [
        panel("rotation error", "deg", |o| o.rotation_deg),
        panel("translation error", "%", |o| o.translation_pct),
        panel("scale error", "%", |o| o.scale_pct),
    ];
    figures.extend(write_figure(&args.figures.join("grps_stability"), "GRPS numerical stability (noise-free)", &panels, true)?);

    Ok(StabilityReport { rows: records.iter().map(|m| m.summary(&THRESHOLDS)).collect(), notes, all_roots_trials })
}

/// Start angles of the success-vs-start-error table.
pub const START_ANGLES: [f64; 5] = [5.0, 10.0, 20.0, 30.0, 45.0];

fn starts(trials: &[GrpsScene], seed: u64, args: &GrpsArgs, progress: bool) -> Result<Vec<StartCell>, String> {
    let solvers = args.solvers(0.0)?;
    // One attempt from the given start, no retries, no fallback.
    let methods: [(&str, Method, usize); 5] = [
        ("HC 8 pts, geometric", GEOMETRIC, 8),
        ("HC 8 pts, generic", GENERIC, 8),
        ("Gauss-Newton 8 pts", Method::GaussNewton, 8),
        ("HC 7 pts, geometric", GEOMETRIC, 7),
        ("HC 7 pts, generic", GENERIC, 7),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(2));
    let mut cells = Vec::new();
    let bar = crate::app::progress_bar((START_ANGLES.len() * trials.len()) as u64, progress);
    for angle in START_ANGLES {
        let mut oks = vec![0usize; methods.len()];
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); methods.len()];
        for scene in trials {
            let start = GrpsPose {
                rotation: random_rotation_perturbation(&scene.rotation, angle, &mut rng),
                translation: perturb_translation(&scene.translation, 0.1, &mut rng),
                scale: perturb_scale(scene.scale, 0.1, &mut rng),
            }
            .unknowns();
            for (k, &(_, method, n)) in methods.iter().enumerate() {
                let c = &scene.correspondences[..n];
                let schedule = [SolverAttempt { start: StartId::Given, method }];
                let (r, micros) = timed(|| {
                    if n == 8 {
                        run(&solvers.eight, c, &schedule, false, Some(&start))
                    } else {
                        run(&solvers.seven, c, &schedule, false, Some(&start))
                    }
                });
                times[k].push(micros);
                if ok(&pose_outcome(r.as_ref(), scene, 0.0)) {
                    oks[k] += 1;
                }
            }
            bar.inc(1);
        }
        for (k, (name, _, _)) in methods.iter().enumerate() {
            cells.push(StartCell {
                method: name.to_string(),
                start_deg: angle,
                success_pct: 100.0 * oks[k] as f64 / trials.len().max(1) as f64,
                time_median_us: median(&times[k]),
            });
        }
    }
    bar.finish_and_clear();
    Ok(cells)
}

/// Noise levels (pixels) and cameras per view of the noise experiment.
pub const NOISE_LEVELS: [f64; 5] = [0.2, 0.4, 0.6, 0.8, 1.0];
/// Cameras per view of the noise experiment.
pub const NOISE_CAMERAS: [usize; 3] = [1, 3, 5];

fn noise(seed: u64, args: &GrpsArgs, progress: bool, figures: &mut Vec<PathBuf>) -> Result<Vec<NoiseRow>, String> {
    let mut rows = Vec::new();
    let bar = crate::app::progress_bar((NOISE_LEVELS.len() * NOISE_CAMERAS.len() * args.noise_trials) as u64, progress);
    for cameras in NOISE_CAMERAS {
        for noise_px in NOISE_LEVELS {
            let config = GrpsSceneConfig { cameras_per_view: cameras, noise_px, ..GrpsSceneConfig::default() };
            let s = args.solvers(noise_px)?;
            let newton = grps_pipeline_options().newton;
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(100 + cameras as u64));
            let mut record = MethodRecord::new("noise");
            let mut reference = MethodRecord::new("reference");
            let mut errors = std::collections::BTreeMap::<String, usize>::new();
            for _ in 0..args.noise_trials {
                let scene = config.sample(&mut rng).map_err(|e| e.to_string())?;
                let truth = GrpsPose { rotation: scene.rotation, translation: scene.translation, scale: scene.scale };
                let from_truth = grps::rows_of::<8>(&scene.correspondences).and_then(|rows| {
                    let r = simhc::tracker::solve_newton::<Grps8, f64, 8, 9, 96>(&truth.unknowns(), &Grps8::params(&rows), &newton).ok()?;
                    GrpsPose::from_unknowns(&r.x)
                });
                reference.outcomes.push(from_truth.map_or(failed(0.0), |p| outcome(&p, &scene, 0.0, None)));
                let (r, micros) = timed(|| s.solve(&scene.correspondences));
                // A flagged end point is scored too, as a validated one.
                let x = match &r {
                    Ok(solution) => Some(solution.x),
                    Err(GrpsSolversError::Solve(SolveError::NotValidated { best, .. })) => Some(*best),
                    Err(_) => None,
                };
                match x.and_then(|x| GrpsPose::from_unknowns(&x)) {
                    Some(pose) => record.outcomes.push(outcome(&pose, &scene, micros, None)),
                    None => {
                        if let Err(e) = &r {
                            *errors.entry(e.to_string()).or_default() += 1;
                        }
                        record.outcomes.push(failed(micros));
                    }
                }
                bar.inc(1);
            }
            let sm = record.summary(&THRESHOLDS);
            let rf = reference.summary(&THRESHOLDS);
            rows.push(NoiseRow {
                cameras,
                noise_px,
                trials: args.noise_trials,
                errors: sm.failures,
                error: errors.into_iter().max_by_key(|e| e.1).map(|e| e.0),
                success_pct: sm.success_pct,
                rotation_median_deg: sm.rotation_median_deg,
                translation_median_pct: sm.translation_median_pct,
                scale_median_pct: sm.scale_median_pct.unwrap_or(f64::NAN),
                time_median_us: sm.time_median_us,
                reference_rotation_median_deg: rf.rotation_median_deg,
                reference_translation_median_pct: rf.translation_median_pct,
                reference_scale_median_pct: rf.scale_median_pct.unwrap_or(f64::NAN),
            });
        }
    }
    bar.finish_and_clear();
    let panel = |title: &str, unit: &str, get: fn(&NoiseRow) -> f64| Panel {
        title: title.to_string(),
        x_label: "noise (px)".to_string(),
        y_label: format!("median error ({unit})"),
        series: NOISE_CAMERAS
            .iter()
            .filter(|&&c| rows.iter().any(|r| r.cameras == c && get(r).is_finite()))
            .map(|&c| (format!("{c} cameras per view"), rows.iter().filter(|r| r.cameras == c).map(|r| (r.noise_px, get(r))).collect()))
            .collect(),
    };
    let panels = [
        panel("rotation", "deg", |r| r.rotation_median_deg),
        panel("translation", "%", |r| r.translation_median_pct),
        panel("scale", "%", |r| r.scale_median_pct),
    ];
    figures.extend(write_figure(&args.figures.join("grps_noise"), "GRPS noise resilience (the shipped solver, 8 pts)", &panels, false)?);
    Ok(rows)
}

/// Outlier ratios of the RANSAC experiment.
pub const OUTLIER_RATIOS: [f64; 4] = [0.1, 0.2, 0.3, 0.4];

/// The RANSAC scene: 200 correspondences between 5 cameras per view, noise uniform in
/// `[-2, 2]` px on both image coordinates at `f = 800` (the sampler's noise model draws each
/// tangent coordinate in `[-n/sqrt 2, n/sqrt 2]`, so `n = 2 sqrt 2`), and
/// `round(ratio * 200)` outliers: correspondences (chosen uniformly) whose second-view ray
/// (bearing and origin) is replaced by that of another, random correspondence (a mismatch).
pub fn ransac_scene(ratio: f64, rng: &mut ChaCha8Rng) -> Result<(GrpsScene, Vec<bool>), String> {
    let config = GrpsSceneConfig { points: 200, cameras_per_view: 5, noise_px: 2.0 * std::f64::consts::SQRT_2, focal_px: 800.0 };
    let mut scene = config.sample(rng).map_err(|e| e.to_string())?;
    let n = scene.correspondences.len();
    let mut idx: Vec<usize> = (0..n).collect();
    let outliers = (ratio * n as f64).round() as usize;
    let original = scene.correspondences.clone();
    let mut is_outlier = vec![false; n];
    for k in 0..outliers {
        let j = rng.random_range(k..n);
        idx.swap(k, j);
        let i = idx[k];
        let mut other = rng.random_range(0..n - 1);
        if other >= i {
            other += 1;
        }
        scene.correspondences[i].fp = original[other].fp;
        scene.correspondences[i].vp = original[other].vp;
        is_outlier[i] = true;
    }
    Ok((scene, is_outlier))
}

fn ransac_bench(seed: u64, args: &GrpsArgs, progress: bool) -> Result<Vec<RansacRow>, String> {
    // A sample's pose is validated on the sample as the estimator of `simhc.grps.estimate` does.
    let solvers = args.solvers(RANSAC_NOISE_PX)?;
    let mut rows = Vec::new();
    let bar = crate::app::progress_bar((OUTLIER_RATIOS.len() * args.ransac_trials) as u64, progress);
    for ratio in OUTLIER_RATIOS {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(200 + (ratio * 100.0) as u64));
        let (mut succ, mut succ_all) = (0usize, 0usize);
        let (mut er, mut et, mut es, mut iters, mut times) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut refs: Vec<[f64; 3]> = Vec::new();
        for trial in 0..args.ransac_trials {
            let (scene, is_outlier) = ransac_scene(ratio, &mut rng)?;
            let inliers: Vec<GrpsCorrespondence> =
                scene.correspondences.iter().zip(&is_outlier).filter(|(_, &o)| !o).map(|(c, _)| *c).collect();
            let reference = refine_pose(&scene.rotation, &scene.translation, scene.scale, &inliers, &LmOptions::default());
            let rp = GrpsPose { rotation: reference.rotation, translation: reference.translation, scale: reference.scale };
            let ro = outcome(&rp, &scene, 0.0, None);
            refs.push([ro.rotation_deg.unwrap_or(f64::NAN), ro.translation_pct.unwrap_or(f64::NAN), ro.scale_pct.unwrap_or(f64::NAN)]);
            let options = RansacOptions {
                seed: seed.wrapping_mul(1_000_003).wrapping_add(trial as u64),
                local_optimization: args.ransac_lo,
                ..RansacOptions::default()
            };
            let data: Vec<f64> = row_numbers(&scene.correspondences).collect();
            let t = Instant::now();
            let result = if args.ransac_sample == 8 {
                solvers.eight.estimate((&data, &[]), &options)
            } else {
                solvers.seven.estimate((&data, &[]), &options)
            };
            times.push(t.elapsed().as_secs_f64() * 1e3);
            match result.ok().and_then(|(x, info)| Some((GrpsPose::from_unknowns(&x)?, info))) {
                Some((pose, info)) => {
                    iters.push(info.iterations as f64);
                    let o = outcome(&pose, &scene, 0.0, None);
                    if o.rotation_deg.is_some_and(|e| e < 2.0) {
                        succ += 1;
                        er.push(o.rotation_deg.unwrap_or(f64::NAN));
                        et.push(o.translation_pct.unwrap_or(f64::NAN));
                        es.push(o.scale_pct.unwrap_or(f64::NAN));
                    }
                    succ_all += usize::from(ok(&o));
                }
                None => iters.push(options.max_iterations as f64),
            }
            bar.inc(1);
        }
        let n = args.ransac_trials.max(1) as f64;
        rows.push(RansacRow {
            outlier_ratio: ratio,
            trials: args.ransac_trials,
            success_pct: 100.0 * succ as f64 / n,
            success_all_pct: 100.0 * succ_all as f64 / n,
            rotation_mean_deg: mean(&er),
            translation_mean_pct: mean(&et),
            scale_mean_pct: mean(&es),
            iterations_mean: mean(&iters),
            time_mean_ms: mean(&times),
            time_median_ms: median(&times),
            reference_mean: [0, 1, 2].map(|k| mean(&refs.iter().map(|r| r[k]).collect::<Vec<_>>())),
        });
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// The report as text tables.
pub fn text(report: &BenchReport) -> String {
    let mut out = String::new();
    if let Some(s) = &report.stability {
        out.push_str(&format!(
            "\nNumerical stability, noise-free, {} trials (All-roots HC on the first {}):\n",
            report.trials, s.all_roots_trials
        ));
        out.push_str(&crate::stats::table(&s.rows));
        out.push_str("success: E_R < 2 deg, E_t < 5 %, E_s < 5 %; errors over returned poses (flagged ones included); times in microseconds per solve, all retries included\n");
        for n in &s.notes {
            out.push_str(&format!(
                "  {:<34} flagged (not validated) {:>4}, attempts mean {:.2}, max {}, all-roots fallback used {}\n",
                n.method, n.flagged, n.attempts_mean, n.attempts_max, n.fallbacks
            ));
        }
        if let Some(ratio) = crate::stats::median_time_ratio(&s.rows, "All-roots HC 7 pts (1 thread)", "Shipped 8 pts (retries+fallback)") {
            out.push_str(&format!("median time, All-roots HC / shipped 8 pts: {ratio:.0}x\n"));
        }
    }
    if !report.starts.is_empty() {
        out.push_str(&format!("\nSuccess (%) vs start error: start = ground truth rotated by the angle, t and s off by 10 %; one path, no retries; {} trials\n", report.trials));
        let methods: Vec<&str> = {
            let mut m: Vec<&str> = Vec::new();
            for c in &report.starts {
                if !m.contains(&c.method.as_str()) {
                    m.push(&c.method);
                }
            }
            m
        };
        out.push_str(&format!("{:>8}", "start"));
        for m in &methods {
            out.push_str(&format!(" {m:>22}"));
        }
        out.push('\n');
        for a in START_ANGLES {
            out.push_str(&format!("{:>6} d", a));
            for m in &methods {
                let c = report.starts.iter().find(|c| c.start_deg == a && c.method == *m);
                out.push_str(&format!(
                    " {:>13.1} ({:>4.0} us)",
                    c.map_or(f64::NAN, |c| c.success_pct),
                    c.map_or(f64::NAN, |c| c.time_median_us)
                ));
            }
            out.push('\n');
        }
    }
    if !report.noise.is_empty() {
        out.push_str("\nNoise resilience (the shipped solver, 8 pts; ref: Gauss-Newton on the same system from the ground truth):\n");
        out.push_str(&format!(
            "{:>7} {:>8} {:>7} {:>7} {:>8} {:>9} {:>9} {:>9} {:>9}   {:>9} {:>9} {:>9}  {}\n",
            "cameras",
            "noise px",
            "trials",
            "errors",
            "succ%",
            "E_R med",
            "E_t med",
            "E_s med",
            "t med us",
            "ref E_R",
            "ref E_t",
            "ref E_s",
            "typed error"
        ));
        for r in &report.noise {
            out.push_str(&format!(
                "{:>7} {:>8.1} {:>7} {:>7} {:>8.1} {:>9.3} {:>9.3} {:>9.3} {:>9.1}   {:>9.3} {:>9.3} {:>9.3}  {}\n",
                r.cameras,
                r.noise_px,
                r.trials,
                r.errors,
                r.success_pct,
                r.rotation_median_deg,
                r.translation_median_pct,
                r.scale_median_pct,
                r.time_median_us,
                r.reference_rotation_median_deg,
                r.reference_translation_median_pct,
                r.reference_scale_median_pct,
                r.error.as_deref().unwrap_or("")
            ));
        }
    }
    if !report.ransac.is_empty() {
        out.push_str(&format!(
            "\nRANSAC: 200 correspondences, 5 cameras per view, noise U[-2, 2] px at f = 800, samples of {}, the first {} attempts of the solver's schedule (no minimum-norm paths) and <= {} validated roots per sample, <= 200 iterations, 99 % confidence, threshold 0.01 on the angular residual{}:\n",
            report.ransac_sample,
            report.ransac_attempts,
            report.ransac_hypotheses,
            if report.ransac_lo { ", local optimization" } else { "" }
        ));
        out.push_str(&format!(
            "{:>6} {:>7} {:>7} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9} {:>9}   {:>8} {:>8} {:>8}\n",
            "ratio",
            "trials",
            "succ%",
            "succ all%",
            "E_R mean",
            "E_t mean",
            "E_s mean",
            "iters",
            "t mean ms",
            "t med ms",
            "ref E_R",
            "ref E_t",
            "ref E_s"
        ));
        for r in &report.ransac {
            out.push_str(&format!(
                "{:>5.0}% {:>7} {:>7.1} {:>9.1} {:>9.3} {:>9.3} {:>9.3} {:>8.1} {:>9.2} {:>9.2}   {:>8.3} {:>8.3} {:>8.3}\n",
                100.0 * r.outlier_ratio,
                r.trials,
                r.success_pct,
                r.success_all_pct,
                r.rotation_mean_deg,
                r.translation_mean_pct,
                r.scale_mean_pct,
                r.iterations_mean,
                r.time_mean_ms,
                r.time_median_ms,
                r.reference_mean[0],
                r.reference_mean[1],
                r.reference_mean[2]
            ));
        }
        out.push_str("succ%: E_R < 2 deg (the paper's RANSAC criterion); succ all%: also E_t, E_s < 5 %; errors: means over the E_R-successful runs; ref: LM from the ground truth on the true inliers, mean over all runs\n");
    }
    if !report.figures.is_empty() {
        out.push_str("\nfigures:");
        for f in &report.figures {
            out.push_str(&format!(" {}", f.display()));
        }
        out.push('\n');
    }
    out
}

/// `simhc solve grps --input F`: the pose of the correspondences in a JSON file
/// (`{"correspondences": [{"f": [..], "v": [..], "fp": [..], "vp": [..]}, ..]}`, or a bare
/// array of them). `"minimal": true` (exactly 7 correspondences): the pose fits them exactly,
/// and so may other poses.
pub fn solve_file(text: &str) -> Result<serde_json::Value, String> {
    let corrs: Vec<GrpsCorrespondence> = simhc_problems::input::parse_correspondences(text).map_err(|e| e.to_string())?;
    let solvers = GrpsSolvers::with_weights(GRPS_WEIGHTS, 0.0)
        .map_err(|e| format!("loading the shipped regressor: {e}"))?
        .certifying(simhc::solver::Certification::Report);
    let (x, check, attempts, validated, certificate) = match solvers.solve(&corrs) {
        Ok(s) => (s.x, s.check, s.attempts, true, crate::certificates::json(&s.certified)),
        Err(GrpsSolversError::Solve(SolveError::NotValidated { best, check, attempts })) => {
            (best, check, attempts, false, serde_json::Value::Null)
        }
        Err(e) => return Err(e.to_string()),
    };
    let pose = GrpsPose::from_unknowns(&x).ok_or_else(|| format!("the end point {x:?} is not a pose"))?;
    let r = pose.rotation;
    let t = pose.translation;
    Ok(serde_json::json!({
    "rotation": [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
        "translation": [t.x, t.y, t.z],
        "scale": pose.scale,
        "convention": "alpha_i f_i + v_i = R (alpha'_i fp_i + s vp_i) + t",
        "validated": validated,
        // 7 correspondences are minimal: every real root fits them exactly, so `validated`
        // cannot mean "the" pose.
        "minimal": corrs.len() == 7,
        "max_angular_residual": check.max_angle,
        "behind_camera": check.behind,
        "attempts": attempts,
        "certificate": certificate,
    }))
}
