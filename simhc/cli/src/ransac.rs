//! `<app> ransac <problem>`: the robust estimator ([`simhc::solver::Solver::estimate`]) of any
//! declared problem with a many-row sampler ([`DeclaredProblem::scene_rows`]) on seeded scenes
//! with wrong matches, at several outlier ratios: success (the problem's own criterion on its
//! errors), inlier recall, wrong matches taken and time per call.
//!
//! A wrong match is a row of another scene from the same sampler, a new scene for each wrong
//! row: it looks like any correspondence and fits no pose of this one, and the wrong rows agree
//! on no common pose either (rows of one other scene would: at 50 % they could outvote the
//! true ones). Every ratio starts from the same seed, so the scenes of a trial are the same
//! until the wrong rows are drawn.

use crate::stats::{mean, median};
use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::ransac::RansacOptions;
use simhc::solver::{DeclaredProblem, Solver};
use std::time::Instant;

/// `<app> ransac <problem>`.
#[derive(Args, Debug)]
pub struct RansacArgs {
    /// Scenes per outlier ratio.
    #[arg(long, default_value_t = 100)]
    pub trials: usize,
    /// Seed of the scenes, the wrong matches and the estimator's samples (printed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Correspondences per scene.
    #[arg(long, default_value_t = 100)]
    pub rows: usize,
    /// Noise of the scenes (the problem's unit); also the validator's tolerance on a sample.
    #[arg(long, default_value_t = 1.0)]
    pub noise: f64,
    /// Fractions of wrong matches, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.2, 0.4, 0.5])]
    pub outliers: Vec<f64>,
    /// Inlier threshold, in the units of the problem's per-correspondence error
    /// (`DeclaredProblem::row_error`).
    #[arg(long)]
    pub threshold: f64,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    pub weights: Option<std::path::PathBuf>,
}

/// One outlier ratio's figures.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RansacRow {
    /// Fraction of wrong matches asked for.
    pub outliers: f64,
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

/// Checks the arguments before any scene is drawn.
pub fn check(a: &RansacArgs, data_rows: usize) -> Result<(), String> {
    if a.trials == 0 {
        return Err("--trials: at least 1".into());
    }
    if a.rows < data_rows {
        return Err(format!("--rows {}: a scene needs at least the problem's {data_rows} rows", a.rows));
    }
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        return Err(format!("--noise {}: expected a number >= 0", a.noise));
    }
    if !(a.threshold.is_finite() && a.threshold > 0.0) {
        return Err(format!("--threshold {}: expected a positive number", a.threshold));
    }
    if let Some(o) = a.outliers.iter().find(|o| !(0.0..1.0).contains(*o)) {
        return Err(format!("--outliers {o}: expected fractions in [0, 1)"));
    }
    Ok(())
}

/// What one trial gave: which rows are true matches, and the estimate's success and inlier
/// mask (`None`: no model).
pub struct TrialOutcome {
    /// Whether each row is a true match.
    pub inlier: Vec<bool>,
    /// Whether the estimate meets the problem's criterion, and its inlier mask.
    pub estimate: Option<(bool, Vec<bool>)>,
    /// Time of the estimator's call (ms).
    pub ms: f64,
}

/// The rows of every outlier ratio of `a`: `trial(rng, ratio, seed)` draws one scene with that
/// fraction of wrong matches from `rng` (seeded with `a.seed` at every ratio) and runs the
/// estimator with the sampler seed `seed`.
pub fn rows_of(
    a: &RansacArgs,
    mut trial: impl FnMut(&mut ChaCha8Rng, f64, u64) -> Result<TrialOutcome, String>,
) -> Result<Vec<RansacRow>, String> {
    let mut out = Vec::new();
    for &ratio in &a.outliers {
        // The same scenes at every ratio: only the wrong rows differ.
        let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
        let (mut succeeded, mut no_model) = (0, 0);
        let (mut recall, mut wrong, mut ms) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..a.trials {
            let t = trial(&mut rng, ratio, a.seed.wrapping_add(k as u64))?;
            ms.push(t.ms);
            match t.estimate {
                Some((correct, mask)) => {
                    succeeded += usize::from(correct);
                    let true_count = t.inlier.iter().filter(|t| **t).count().max(1);
                    let kept = mask.iter().zip(&t.inlier).filter(|(m, t)| **m && **t).count();
                    recall.push(100.0 * kept as f64 / true_count as f64);
                    wrong.push(mask.iter().zip(&t.inlier).filter(|(m, t)| **m && !**t).count() as f64);
                }
                None => {
                    no_model += 1;
                    recall.push(0.0);
                    wrong.push(0.0);
                }
            }
        }
        out.push(RansacRow {
            outliers: ratio,
            success_pct: 100.0 * succeeded as f64 / a.trials as f64,
            recall_pct: median(&recall),
            wrong_taken: median(&wrong),
            no_model,
            ms_median: median(&ms),
            ms_mean: mean(&ms),
        });
    }
    Ok(out)
}

/// Which of `rows` rows are true matches at the fraction `ratio` of wrong ones.
pub fn draw_inliers(rng: &mut ChaCha8Rng, rows: usize, ratio: f64) -> Vec<bool> {
    (0..rows).map(|_| rng.random::<f64>() >= ratio).collect()
}

/// Runs a declared problem's estimator on the scenes of every outlier ratio and returns the rows.
pub fn run<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    solver: &Solver<S, NX, NF, NP, NC, ND>,
    data_rows: usize,
    a: &RansacArgs,
) -> Result<Vec<RansacRow>, String>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    check(a, data_rows)?;
    let missing = || format!("{} has no many-row sampler (DeclaredProblem::scene_rows)", S::NAME);
    rows_of(a, |rng, ratio, seed| {
        let (mut rows, globals, truth) = problem.scene_rows(rng, a.rows, a.noise).ok_or_else(missing)?;
        let per_row = rows.len() / a.rows;
        let inlier = draw_inliers(rng, a.rows, ratio);
        for (k, _) in inlier.iter().enumerate().filter(|(_, keep)| !**keep) {
            let (other, _, _) = problem.scene_rows(rng, data_rows, a.noise).ok_or_else(missing)?;
            // Row k of the other scene, or its last when it has fewer.
            let j = k.min(data_rows - 1);
            rows[k * per_row..(k + 1) * per_row].copy_from_slice(&other[j * per_row..(j + 1) * per_row]);
        }
        let options = RansacOptions { seed, ..RansacOptions::poselib(a.threshold) };
        let t0 = Instant::now();
        let result = solver.estimate(&rows, &globals, &options);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let estimate = result.ok().map(|(x, info)| (problem.correct(&problem.errors(&x, &truth)), info.inlier_mask));
        Ok(TrialOutcome { inlier, estimate, ms })
    })
}

/// The rows as a text table.
pub fn table(rows: &[RansacRow]) -> String {
    let mut out = format!(
        "{:>9} {:>7} {:>9} {:>7} {:>8} {:>9} {:>9}\n",
        "outliers", "succ%", "recall%", "wrong", "no model", "t med ms", "t mean ms"
    );
    for r in rows {
        out.push_str(&format!(
            "{:>9.2} {:>7.1} {:>9.1} {:>7.1} {:>8} {:>9.2} {:>9.2}\n",
            r.outliers, r.success_pct, r.recall_pct, r.wrong_taken, r.no_model, r.ms_median, r.ms_mean
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(rows: usize, threshold: f64, outliers: Vec<f64>) -> RansacArgs {
        RansacArgs { trials: 1, seed: 1, rows, noise: 0.0, outliers, threshold, weights: None }
    }

    #[test]
    fn bad_arguments_say_which() {
        assert!(check(&args(10, 1e-3, vec![0.2]), 7).is_ok());
        assert!(check(&args(5, 1e-3, vec![0.2]), 7).unwrap_err().contains("--rows 5"));
        assert!(check(&args(10, -1.0, vec![0.2]), 7).unwrap_err().contains("--threshold"));
        assert!(check(&args(10, 1e-3, vec![1.0]), 7).unwrap_err().contains("--outliers 1"));
    }
}
