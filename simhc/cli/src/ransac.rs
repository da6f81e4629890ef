//! `<app> ransac <problem>`: a problem's robust estimator on seeded scenes with wrong matches,
//! at several outlier ratios: success (the problem's own criterion on its errors), inlier
//! recall, wrong matches taken and time per call. One implementation for every problem (UPnP
//! and every declared problem with a many-row sampler, [`Scenes::scene_rows`]): the
//! problem brings a sampler and an estimator call; the trials, the trials file, the statistics
//! and the output are here.
//!
//! A wrong match is a row of another scene from the same sampler, a new scene for each wrong
//! row: it looks like any correspondence and fits no pose of this one, and the wrong rows agree
//! on no common pose either (rows of one other scene would: at 50 % they could outvote the
//! true ones). Every ratio starts from the same seed, so the scenes of a trial are the same
//! until the wrong rows are drawn.
//!
//! `--dump-trials FILE` writes the trials ([`TrialsFile`]: every correspondence, wrong ones
//! included, which rows are true matches, the true unknowns, the estimator's seed, and the
//! noise, threshold and seed they were made with); `--trials-file FILE` runs on such a file
//! instead of sampling, so a peer and simhc run on bit-identical numbers (`serde_json`'s
//! `float_roundtrip`; Python's `json` reads and writes them exactly too).

use crate::stats::{mean, median};
use clap::Args;
use nalgebra::SVector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use simhc::layout::FieldLayout;
use simhc::ransac::RansacOptions;
use simhc::solver::{Scenes, Solver};
use simhc::ProblemLayout;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `<app> ransac <problem>`.
#[derive(Args, Debug, Clone)]
pub struct RansacArgs {
    /// Scenes per outlier ratio.
    #[arg(long, default_value_t = 100, conflicts_with = "trials_file")]
    pub trials: usize,
    /// Seed of the scenes, the wrong matches and the estimator's samples (printed).
    #[arg(long, default_value_t = 1, conflicts_with = "trials_file")]
    pub seed: u64,
    /// Correspondences per scene.
    #[arg(long, default_value_t = 100, conflicts_with = "trials_file")]
    pub rows: usize,
    /// Noise of the scenes (the problem's unit); also the validator's tolerance on a sample
    /// (default 1; with --trials-file, the file's).
    #[arg(long)]
    pub noise: Option<f64>,
    /// Fractions of wrong matches, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.2, 0.4, 0.5], conflicts_with = "trials_file")]
    pub outliers: Vec<f64>,
    /// Inlier threshold, in the units of the problem's per-correspondence error
    /// (`DeclaredProblem::row_error`); required unless --trials-file gives it.
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// Run on the trials of this file (written by --dump-trials) instead of sampling them.
    #[arg(long)]
    pub trials_file: Option<PathBuf>,
    /// Write the trials run (correspondences, true-match mask, true unknowns, seeds) to this
    /// JSON file.
    #[arg(long)]
    pub dump_trials: Option<PathBuf>,
    /// Print one JSON object (the summary rows and every trial's result) instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Past the confidence, do not solve samples whose rows are all inliers of the best model
    /// (`RansacOptions::skip_explained`): much faster with few outliers, about one point of
    /// success less at 20-40 % outliers on problems with several roots per sample.
    #[arg(long)]
    pub skip_explained: bool,
}

impl RansacArgs {
    /// The arguments of a sampled run (tests and examples).
    pub fn sampled(trials: usize, seed: u64, rows: usize, noise: f64, outliers: Vec<f64>, threshold: f64) -> Self {
        Self {
            trials,
            seed,
            rows,
            noise: Some(noise),
            outliers,
            threshold: Some(threshold),
            weights: None,
            trials_file: None,
            dump_trials: None,
            json: false,
            skip_explained: false,
        }
    }
}

/// The noise of sampled scenes without `--noise`.
const DEFAULT_NOISE: f64 = 1.0;

/// One named block of numbers (a row's field, a global, an unknown) in a [`TrialsFile`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Field {
    /// Its name (`p`, `f`, `rotation`).
    pub name: String,
    /// How many numbers it has.
    pub len: usize,
}

impl Field {
    /// A field of `len` numbers.
    pub fn new(name: &str, len: usize) -> Self {
        Self { name: name.to_string(), len }
    }

    /// The fields of a declared layout's block.
    pub fn of_layout(fields: &[FieldLayout]) -> Vec<Self> {
        fields.iter().map(|f| Self::new(f.name, f.kind.len())).collect()
    }
}

fn total(fields: &[Field]) -> usize {
    fields.iter().map(|f| f.len).sum()
}

fn names(fields: &[Field]) -> String {
    fields.iter().map(|f| format!("{} {}", f.name, f.len)).collect::<Vec<_>>().join(", ")
}

/// What the trials of one problem hold: the problem's name, the fields of a row, of the
/// globals and of the true unknowns, and the fewest rows an estimate needs.
#[derive(Debug, Clone)]
pub struct TrialSpec {
    /// The problem's name on the command line.
    pub problem: &'static str,
    /// The fields of one correspondence, in order.
    pub row_fields: Vec<Field>,
    /// The fields of the globals.
    pub global_fields: Vec<Field>,
    /// The fields of the true unknowns (and of an estimate in `--json`).
    pub truth_fields: Vec<Field>,
    /// The fewest correspondences of a trial.
    pub min_rows: usize,
}

/// One trial: the correspondences given to the estimator, which are true matches, the true
/// unknowns and the estimator's seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RansacTrial {
    /// The fraction of wrong matches it was drawn with (the summary row it counts in).
    pub outliers: f64,
    /// Seed of the estimator's samples.
    pub estimator_seed: u64,
    /// Whether each row is a true match (`false`: an injected wrong match).
    pub inlier: Vec<bool>,
    /// The correspondences, each the numbers of [`TrialsFile::row_fields`] in order.
    pub rows: Vec<Vec<f64>>,
    /// The globals ([`TrialsFile::global_fields`]).
    pub globals: Vec<f64>,
    /// The true unknowns ([`TrialsFile::truth_fields`]).
    pub truth: Vec<f64>,
}

/// A `--dump-trials` / `--trials-file` document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialsFile {
    /// The problem they are for.
    pub problem: String,
    /// The fields of a row.
    pub row_fields: Vec<Field>,
    /// The fields of the globals.
    pub global_fields: Vec<Field>,
    /// The fields of the true unknowns.
    pub truth_fields: Vec<Field>,
    /// The seed they were sampled with.
    pub seed: u64,
    /// The scenes' noise (the problem's unit); the validator's tolerance.
    pub noise: f64,
    /// The inlier threshold (the unit of the problem's per-correspondence error).
    pub threshold: f64,
    /// The trials, grouped by outlier ratio.
    pub trials: Vec<RansacTrial>,
}

/// A `--trials-file` that cannot be used: where, and why.
#[derive(Debug, thiserror::Error)]
pub enum TrialsFileError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not JSON.
    #[error("{path}: line {line}, column {column}: {message}")]
    Json {
        /// The file.
        path: String,
        /// Line of the error.
        line: usize,
        /// Column of the error.
        column: usize,
        /// What serde_json said.
        message: String,
    },
    /// A field of the header, of a trial or of one of its rows is missing or wrong.
    #[error("{path}: {}`{field}`: {message}", at(.trial, .row))]
    Field {
        /// The file.
        path: String,
        /// The trial (its index in `trials`), if the field is a trial's.
        trial: Option<usize>,
        /// The row (correspondence) of the trial, if the field is a row's.
        row: Option<usize>,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
}

fn at(trial: &Option<usize>, row: &Option<usize>) -> String {
    match (trial, row) {
        (Some(t), Some(r)) => format!("trial {t}, row {r}, "),
        (Some(t), None) => format!("trial {t}, "),
        _ => String::new(),
    }
}

impl TrialsFile {
    /// Reads and checks a trials file for `spec`'s problem.
    pub fn read(path: &Path, spec: &TrialSpec) -> Result<Self, TrialsFileError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| TrialsFileError::Read { path: p.clone(), source })?;
        Self::parse(&text, &p, spec)
    }

    /// Parses and checks the text of a trials file (`path` names it in errors).
    pub fn parse(text: &str, path: &str, spec: &TrialSpec) -> Result<Self, TrialsFileError> {
        let json =
            |e: serde_json::Error| TrialsFileError::Json { path: path.into(), line: e.line(), column: e.column(), message: e.to_string() };
        let bad = |trial: Option<usize>, row: Option<usize>, field: &str, message: String| TrialsFileError::Field {
            path: path.into(),
            trial,
            row,
            field: field.into(),
            message,
        };
        let mut value: serde_json::Value = serde_json::from_str(text).map_err(json)?;
        let object = value.as_object_mut().ok_or_else(|| bad(None, None, "trials", "the file is not a JSON object".into()))?;
        let trials = object.remove("trials").ok_or_else(|| bad(None, None, "trials", "missing".into()))?;
        let trials = match trials {
            serde_json::Value::Array(a) => a,
            _ => return Err(bad(None, None, "trials", "not an array".into())),
        };
        // The header, one field at a time, so that an error names it.
        let header = |name: &str| object.get(name).cloned().ok_or_else(|| bad(None, None, name, "missing".into()));
        fn typed<T: serde::de::DeserializeOwned>(v: serde_json::Value) -> Result<T, String> {
            serde_json::from_value(v).map_err(|e| e.to_string())
        }
        let field = |name: &str| -> Result<Vec<Field>, TrialsFileError> { typed(header(name)?).map_err(|m| bad(None, None, name, m)) };
        let number = |name: &str| -> Result<f64, TrialsFileError> { typed(header(name)?).map_err(|m| bad(None, None, name, m)) };
        let problem: String = typed(header("problem")?).map_err(|m| bad(None, None, "problem", m))?;
        if problem != spec.problem {
            return Err(bad(None, None, "problem", format!("the trials are for `{problem}`, not `{}`", spec.problem)));
        }
        let mut file = TrialsFile {
            problem,
            row_fields: field("row_fields")?,
            global_fields: field("global_fields")?,
            truth_fields: field("truth_fields")?,
            seed: typed(header("seed")?).map_err(|m| bad(None, None, "seed", m))?,
            noise: number("noise")?,
            threshold: number("threshold")?,
            trials: Vec::with_capacity(trials.len()),
        };
        for (name, found, expected) in [
            ("row_fields", &file.row_fields, &spec.row_fields),
            ("global_fields", &file.global_fields, &spec.global_fields),
            ("truth_fields", &file.truth_fields, &spec.truth_fields),
        ] {
            if found != expected {
                return Err(bad(None, None, name, format!("[{}], but {} has [{}]", names(found), spec.problem, names(expected))));
            }
        }
        if !(file.noise.is_finite() && file.noise >= 0.0) {
            return Err(bad(None, None, "noise", format!("{}: expected a number >= 0", file.noise)));
        }
        if !(file.threshold.is_finite() && file.threshold > 0.0) {
            return Err(bad(None, None, "threshold", format!("{}: expected a positive number", file.threshold)));
        }
        if trials.is_empty() {
            return Err(bad(None, None, "trials", "no trials".into()));
        }
        let (per_row, globals, unknowns) = (total(&spec.row_fields), total(&spec.global_fields), total(&spec.truth_fields));
        for (k, t) in trials.into_iter().enumerate() {
            // serde names the missing or mistyped field of the trial.
            let t: RansacTrial = serde_json::from_value(t).map_err(|e| bad(Some(k), None, "trial", e.to_string()))?;
            if !(0.0..1.0).contains(&t.outliers) {
                return Err(bad(Some(k), None, "outliers", format!("{}: expected a fraction in [0, 1)", t.outliers)));
            }
            if t.rows.len() < spec.min_rows {
                return Err(bad(Some(k), None, "rows", format!("{} rows, a trial needs at least {}", t.rows.len(), spec.min_rows)));
            }
            if let Some((r, row)) = t.rows.iter().enumerate().find(|(_, row)| row.len() != per_row) {
                return Err(bad(
                    Some(k),
                    Some(r),
                    "rows",
                    format!("{} numbers, expected {per_row} ({})", row.len(), names(&spec.row_fields)),
                ));
            }
            if t.inlier.len() != t.rows.len() {
                return Err(bad(Some(k), None, "inlier", format!("{} flags for {} rows", t.inlier.len(), t.rows.len())));
            }
            if t.globals.len() != globals {
                return Err(bad(Some(k), None, "globals", format!("{} numbers, expected {globals}", t.globals.len())));
            }
            if t.truth.len() != unknowns {
                return Err(bad(
                    Some(k),
                    None,
                    "truth",
                    format!("{} numbers, expected {unknowns} ({})", t.truth.len(), names(&spec.truth_fields)),
                ));
            }
            file.trials.push(t);
        }
        Ok(file)
    }

    /// The outlier ratios of the trials, in order of first appearance.
    pub fn ratios(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for t in &self.trials {
            if !out.iter().any(|r| r.to_bits() == t.outliers.to_bits()) {
                out.push(t.outliers);
            }
        }
        out
    }
}

/// One sampled scene with wrong matches, as a problem's sampler gives it: the rows (flat, the
/// row fields of each in order), the globals, the true unknowns and which rows are true.
pub struct Sampled {
    /// The rows' numbers, row after row.
    pub rows: Vec<f64>,
    /// The globals.
    pub globals: Vec<f64>,
    /// The true unknowns.
    pub truth: Vec<f64>,
    /// Whether each row is a true match.
    pub inlier: Vec<bool>,
}

/// Checks the arguments of a sampled run before any scene is drawn.
pub fn check(a: &RansacArgs, min_rows: usize) -> Result<(), String> {
    if a.trials == 0 {
        return Err("--trials: at least 1".into());
    }
    if a.rows < min_rows {
        return Err(format!("--rows {}: a scene needs at least the problem's {min_rows} rows", a.rows));
    }
    if let Some(noise) = a.noise.filter(|n| !(n.is_finite() && *n >= 0.0)) {
        return Err(format!("--noise {noise}: expected a number >= 0"));
    }
    match a.threshold {
        None if a.trials_file.is_none() => return Err("--threshold: required (unless --trials-file gives it)".into()),
        Some(t) if !(t.is_finite() && t > 0.0) => return Err(format!("--threshold {t}: expected a positive number")),
        _ => {}
    }
    if let Some(o) = a.outliers.iter().find(|o| !(0.0..1.0).contains(*o)) {
        return Err(format!("--outliers {o}: expected fractions in [0, 1)"));
    }
    Ok(())
}

/// The trials of `a`: those of `--trials-file`, or sampled (`sample(rng, rows, noise, ratio)`
/// draws one scene with that fraction of wrong matches from `rng`, seeded with `--seed` at
/// every ratio; trial `k`'s estimator seed is `seed + k`), with `--noise` and `--threshold`
/// in effect; written to `--dump-trials` when asked. Also returns where they came from.
pub fn trials(
    a: &RansacArgs,
    spec: &TrialSpec,
    mut sample: impl FnMut(&mut ChaCha8Rng, usize, f64, f64) -> Result<Sampled, String>,
) -> Result<(TrialsFile, String), String> {
    check(a, spec.min_rows)?;
    let (mut file, source) = match &a.trials_file {
        Some(path) => {
            let file = TrialsFile::read(path, spec).map_err(|e| e.to_string())?;
            let source = format!("{} trials from {} (sampled with seed {})", file.trials.len(), path.display(), file.seed);
            (file, source)
        }
        None => {
            let noise = a.noise.unwrap_or(DEFAULT_NOISE);
            let per_row = total(&spec.row_fields);
            let mut trials = Vec::with_capacity(a.trials * a.outliers.len());
            for &ratio in &a.outliers {
                // The same scenes at every ratio: only the wrong rows differ.
                let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
                for k in 0..a.trials {
                    let s = sample(&mut rng, a.rows, noise, ratio)?;
                    if s.rows.len() != a.rows * per_row || s.inlier.len() != a.rows || s.truth.len() != total(&spec.truth_fields) {
                        return Err(format!(
                            "{}'s sampler gave {} numbers, {} flags and {} unknowns for {} rows of {per_row}",
                            spec.problem,
                            s.rows.len(),
                            s.inlier.len(),
                            s.truth.len(),
                            a.rows
                        ));
                    }
                    trials.push(RansacTrial {
                        outliers: ratio,
                        estimator_seed: a.seed.wrapping_add(k as u64),
                        inlier: s.inlier,
                        rows: s.rows.chunks_exact(per_row).map(<[f64]>::to_vec).collect(),
                        globals: s.globals,
                        truth: s.truth,
                    });
                }
            }
            let file = TrialsFile {
                problem: spec.problem.to_string(),
                row_fields: spec.row_fields.clone(),
                global_fields: spec.global_fields.clone(),
                truth_fields: spec.truth_fields.clone(),
                seed: a.seed,
                noise,
                threshold: a.threshold.ok_or("--threshold: required")?,
                trials,
            };
            (file, format!("{} scenes of {} rows per outlier ratio, sampled with seed {}", a.trials, a.rows, a.seed))
        }
    };
    // The command line's noise and threshold win over the file's.
    file.noise = a.noise.unwrap_or(file.noise);
    file.threshold = a.threshold.unwrap_or(file.threshold);
    if let Some(path) = &a.dump_trials {
        let text = serde_json::to_string(&file).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok((file, source))
}

/// What the estimator gave on one trial.
pub struct Estimated {
    /// The estimate (in the truth's fields), whether it meets the problem's criterion, and
    /// its inlier mask; `None`: no model.
    pub estimate: Option<(Vec<f64>, bool, Vec<bool>)>,
    /// Time of the estimator's call (ms).
    pub ms: f64,
}

/// One outlier ratio's figures.
#[derive(Debug, Clone, Serialize)]
pub struct RansacRow {
    /// Fraction of wrong matches asked for.
    pub outliers: f64,
    /// Trials at this ratio.
    pub trials: usize,
    /// Trials whose estimate meets the problem's success criterion, in percent.
    pub success_pct: f64,
    /// Median over trials of the true matches marked inliers, in percent.
    pub recall_pct: f64,
    /// Median over trials of the wrong matches marked inliers.
    pub wrong_taken: f64,
    /// Trials without a model.
    pub no_model: usize,
    /// Median time per call (ms).
    pub ms_median: f64,
    /// Mean time per call (ms).
    pub ms_mean: f64,
}

/// One trial's result.
#[derive(Debug, Clone, Serialize)]
pub struct TrialResult {
    /// The trial's outlier ratio.
    pub outliers: f64,
    /// Whether the estimate meets the problem's criterion (`false` without a model).
    pub success: bool,
    /// The estimate, in the truth's fields (`null`: no model).
    pub estimate: Option<Vec<f64>>,
    /// The estimator's inlier mask (`null`: no model).
    pub inlier_mask: Option<Vec<bool>>,
    /// True matches marked inliers, in percent (0 without a model).
    pub recall_pct: f64,
    /// Wrong matches marked inliers.
    pub wrong_taken: usize,
    /// Time of the call (ms).
    pub ms: f64,
}

/// The summary rows (one per outlier ratio) and every trial's result.
#[derive(Debug, Clone, Serialize)]
pub struct RansacReport {
    /// One row per outlier ratio, in the order of the trials.
    pub rows: Vec<RansacRow>,
    /// Every trial's result, in the order of the trials.
    pub trials: Vec<TrialResult>,
}

/// Runs `estimate(trial, options)` on every trial of `file` (options: PoseLib's iteration
/// defaults, the file's threshold, the trial's seed, `skip_explained`) and sums up.
pub fn evaluate(
    file: &TrialsFile,
    skip_explained: bool,
    mut estimate: impl FnMut(&RansacTrial, &RansacOptions) -> Result<Estimated, String>,
) -> Result<RansacReport, String> {
    let mut results = Vec::with_capacity(file.trials.len());
    for t in &file.trials {
        let options = RansacOptions { seed: t.estimator_seed, skip_explained, ..RansacOptions::poselib(file.threshold) };
        let e = estimate(t, &options)?;
        let result = match e.estimate {
            Some((x, success, mask)) => {
                let true_count = t.inlier.iter().filter(|t| **t).count().max(1);
                let kept = mask.iter().zip(&t.inlier).filter(|(m, t)| **m && **t).count();
                let wrong_taken = mask.iter().zip(&t.inlier).filter(|(m, t)| **m && !**t).count();
                let recall_pct = 100.0 * kept as f64 / true_count as f64;
                TrialResult { outliers: t.outliers, success, estimate: Some(x), inlier_mask: Some(mask), recall_pct, wrong_taken, ms: e.ms }
            }
            None => TrialResult {
                outliers: t.outliers,
                success: false,
                estimate: None,
                inlier_mask: None,
                recall_pct: 0.0,
                wrong_taken: 0,
                ms: e.ms,
            },
        };
        results.push(result);
    }
    let rows = file
        .ratios()
        .into_iter()
        .map(|ratio| {
            let of: Vec<&TrialResult> = results.iter().filter(|r| r.outliers.to_bits() == ratio.to_bits()).collect();
            let values = |f: fn(&TrialResult) -> f64| of.iter().map(|r| f(r)).collect::<Vec<f64>>();
            RansacRow {
                outliers: ratio,
                trials: of.len(),
                success_pct: 100.0 * of.iter().filter(|r| r.success).count() as f64 / of.len() as f64,
                recall_pct: median(&values(|r| r.recall_pct)),
                wrong_taken: median(&values(|r| r.wrong_taken as f64)),
                no_model: of.iter().filter(|r| r.estimate.is_none()).count(),
                ms_median: median(&values(|r| r.ms)),
                ms_mean: mean(&values(|r| r.ms)),
            }
        })
        .collect();
    Ok(RansacReport { rows, trials: results })
}

/// The trials of a declared problem's `ransac` ([`trials`] with the problem's many-row
/// sampler, [`Scenes::scene_rows`]): the fields are the layout's, a trial has at least
/// the data instance's rows.
pub fn declared_trials<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    a: &RansacArgs,
) -> Result<(TrialsFile, String), String>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    let layout = S::Data::LAYOUT;
    let spec = TrialSpec {
        problem: S::NAME,
        row_fields: Field::of_layout(layout.row),
        global_fields: Field::of_layout(layout.globals),
        truth_fields: Field::of_layout(layout.unknowns),
        min_rows: layout.rows,
    };
    let (data_rows, per_row) = (layout.rows, layout.per_row);
    let missing = || format!("{} has no many-row sampler (Scenes::scene_rows)", S::NAME);
    trials(a, &spec, |rng, rows, noise, ratio| {
        let (mut data, globals, truth) = problem.scene_rows(rng, rows, noise).ok_or_else(missing)?;
        let short = |n: usize, rows: usize| format!("{}'s sampler gave {n} numbers for {rows} rows of {per_row}", S::NAME);
        if data.len() != rows * per_row {
            return Err(short(data.len(), rows));
        }
        let inlier = draw_inliers(rng, rows, ratio);
        for (k, _) in inlier.iter().enumerate().filter(|(_, keep)| !**keep) {
            let (other, _, _) = problem.scene_rows(rng, data_rows, noise).ok_or_else(missing)?;
            if other.len() != data_rows * per_row {
                return Err(short(other.len(), data_rows));
            }
            // Row k of the other scene, or its last when it has fewer.
            let j = k.min(data_rows - 1);
            data[k * per_row..(k + 1) * per_row].copy_from_slice(&other[j * per_row..(j + 1) * per_row]);
        }
        Ok(Sampled { rows: data, globals, truth: truth.as_slice().to_vec(), inlier })
    })
}

/// A declared problem's robust estimator ([`Solver::estimate`]) on every trial of `file`;
/// success is the problem's criterion on its errors.
pub fn estimate_declared<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    solver: &Solver<S, NX, NF, NP, NC, ND>,
    file: &TrialsFile,
    skip_explained: bool,
) -> Result<RansacReport, String>
where
    S: Scenes<NX, NF, NP, NC, ND>,
{
    evaluate(file, skip_explained, |trial, options| {
        let rows: Vec<f64> = trial.rows.concat();
        let truth = SVector::<f64, NX>::from_column_slice(&trial.truth);
        let t0 = Instant::now();
        let result = solver.estimate((&rows, &trial.globals), options);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let estimate = result.ok().map(|(x, info)| (x.as_slice().to_vec(), problem.correct(&problem.errors(&x, &truth)), info.inlier_mask));
        Ok(Estimated { estimate, ms })
    })
}

/// Prints the report: the table after a line naming the trials' source, seed, noise and
/// threshold, or (`--json`) one JSON object.
pub fn print(a: &RansacArgs, file: &TrialsFile, source: &str, report: &RansacReport) -> Result<(), String> {
    if a.json {
        let value = serde_json::json!({
            "problem": file.problem, "source": source, "seed": file.seed, "noise": file.noise, "threshold": file.threshold,
            "skip_explained": a.skip_explained, "rows": report.rows, "trials": report.trials,
        });
        println!("{}", serde_json::to_string_pretty(&value).map_err(|e| e.to_string())?);
        return Ok(());
    }
    let skip = if a.skip_explained { " (samples the best model explains skipped past the confidence)" } else { "" };
    println!(
        "{} ransac: {source}; noise {}, threshold {}, PoseLib's iteration defaults{skip}, single thread",
        file.problem, file.noise, file.threshold
    );
    print!("{}", table(&report.rows));
    Ok(())
}

/// Which of `rows` rows are true matches at the fraction `ratio` of wrong ones.
pub fn draw_inliers(rng: &mut ChaCha8Rng, rows: usize, ratio: f64) -> Vec<bool> {
    (0..rows).map(|_| rng.random::<f64>() >= ratio).collect()
}

/// The rows as a text table.
pub fn table(rows: &[RansacRow]) -> String {
    let mut out = format!(
        "{:>9} {:>7} {:>7} {:>9} {:>7} {:>8} {:>9} {:>9}\n",
        "outliers", "trials", "succ%", "recall%", "wrong", "no model", "t med ms", "t mean ms"
    );
    for r in rows {
        out.push_str(&format!(
            "{:>9.2} {:>7} {:>7.1} {:>9.1} {:>7.1} {:>8} {:>9.2} {:>9.2}\n",
            r.outliers, r.trials, r.success_pct, r.recall_pct, r.wrong_taken, r.no_model, r.ms_median, r.ms_mean
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(rows: usize, threshold: f64, outliers: Vec<f64>) -> RansacArgs {
        RansacArgs::sampled(1, 1, rows, 0.0, outliers, threshold)
    }

    #[test]
    fn bad_arguments_say_which() {
        assert!(check(&args(10, 1e-3, vec![0.2]), 7).is_ok());
        assert!(check(&args(5, 1e-3, vec![0.2]), 7).unwrap_err().contains("--rows 5"));
        assert!(check(&args(10, -1.0, vec![0.2]), 7).unwrap_err().contains("--threshold"));
        assert!(check(&args(10, 1e-3, vec![1.0]), 7).unwrap_err().contains("--outliers 1"));
        let no_threshold = RansacArgs { threshold: None, ..args(10, 1e-3, vec![0.2]) };
        assert!(check(&no_threshold, 7).unwrap_err().contains("--threshold: required"));
    }

    fn spec() -> TrialSpec {
        TrialSpec {
            problem: "line",
            row_fields: vec![Field::new("x", 1), Field::new("y", 1)],
            global_fields: vec![],
            truth_fields: vec![Field::new("a", 1)],
            min_rows: 2,
        }
    }

    /// Two trials of `y = 2 x` sampled through [`trials`] with an exact sampler.
    fn sampled_file() -> TrialsFile {
        let a = RansacArgs::sampled(2, 3, 4, 0.0, vec![0.0, 0.5], 0.1);
        let (file, source) = trials(&a, &spec(), |rng, rows, _, ratio| {
            let inlier = draw_inliers(rng, rows, ratio);
            let mut data = Vec::new();
            for keep in &inlier {
                let x: f64 = rng.random();
                data.extend([x, if *keep { 2.0 * x } else { -x }]);
            }
            Ok(Sampled { rows: data, globals: vec![], truth: vec![2.0], inlier })
        })
        .expect("samples");
        assert!(source.contains("seed 3"), "{source}");
        file
    }

    #[test]
    fn a_written_file_reads_back_bit_identical() {
        let file = sampled_file();
        assert_eq!(file.trials.len(), 4);
        assert_eq!(file.ratios(), vec![0.0, 0.5]);
        let text = serde_json::to_string(&file).expect("writes");
        let back = TrialsFile::parse(&text, "t.json", &spec()).expect("reads");
        let bits = |f: &TrialsFile| f.trials.iter().flat_map(|t| t.rows.iter().flatten().map(|v| v.to_bits())).collect::<Vec<u64>>();
        assert_eq!(bits(&back), bits(&file));
        assert_eq!(back, file);
    }

    #[test]
    fn a_bad_file_names_the_trial_row_and_field() {
        let file = sampled_file();
        let mut value = serde_json::to_value(&file).expect("value");
        let err = |v: &serde_json::Value| TrialsFile::parse(&v.to_string(), "t.json", &spec()).unwrap_err().to_string();
        let mut short_row = value.clone();
        short_row["trials"][1]["rows"][2] = serde_json::json!([1.0]);
        assert_eq!(err(&short_row), "t.json: trial 1, row 2, `rows`: 1 numbers, expected 2 (x 1, y 1)");
        let mut no_mask = value.clone();
        no_mask["trials"][3].as_object_mut().expect("object").remove("inlier");
        let e = err(&no_mask);
        assert!(e.starts_with("t.json: trial 3, `trial`: missing field `inlier`"), "{e}");
        let mut text_number = value.clone();
        text_number["trials"][0]["truth"][0] = serde_json::json!("two");
        assert!(err(&text_number).starts_with("t.json: trial 0, `trial`: invalid type: string \"two\""), "{}", err(&text_number));
        value["problem"] = serde_json::json!("upnp");
        assert_eq!(err(&value), "t.json: `problem`: the trials are for `upnp`, not `line`");
        let e = TrialsFile::parse("{\"trials\": [", "t.json", &spec()).unwrap_err().to_string();
        assert!(e.starts_with("t.json: line 1, column "), "{e}");
    }

    #[test]
    fn the_rows_sum_up_each_ratio() {
        let file = sampled_file();
        // An "estimator" that marks every row inlier and succeeds on the noise-free ratio only.
        let report = evaluate(&file, true, |t, o| {
            assert_eq!((o.seed, o.skip_explained), (t.estimator_seed, true));
            Ok(Estimated { estimate: Some((vec![2.0], t.outliers == 0.0, vec![true; t.rows.len()])), ms: 1.0 })
        })
        .expect("runs");
        assert_eq!(report.rows.len(), 2);
        assert_eq!((report.rows[0].success_pct, report.rows[0].recall_pct, report.rows[0].wrong_taken), (100.0, 100.0, 0.0));
        assert_eq!(report.rows[1].success_pct, 0.0);
        let wrong: Vec<usize> = file.trials[2..].iter().map(|t| t.inlier.iter().filter(|i| !**i).count()).collect();
        assert_eq!(report.trials[2..].iter().map(|r| r.wrong_taken).collect::<Vec<_>>(), wrong);
    }
}
