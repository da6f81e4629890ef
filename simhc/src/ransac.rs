//! A reusable RANSAC loop for any minimal solver: vanilla RANSAC (Fischler and Bolles 1981)
//! with adaptive stopping at a confidence, an iteration cap, an inlier threshold on a residual,
//! and an optional non-minimal refinement of the best model on its inliers.
//!
//! A problem plugs in through [`Estimator`]: the minimal sample size, a solver for a sample
//! (zero or more hypotheses: a minimal solver may fail, or return several roots), and the
//! residual of one datum under a model. [`Estimator::refine`] (default: none) fits a model to
//! many inliers, e.g. Levenberg-Marquardt from the best minimal model.
//!
//! # Loop ([`ransac`])
//!
//! Each iteration draws `sample_size` distinct indices uniformly (seeded ChaCha8, so a run is
//! reproducible), solves the sample, and scores every hypothesis by the MSAC cost
//! `sum_i min(r_i², threshold²)` (Torr and Zisserman 2000: inliers, `r_i <= threshold`, count
//! by their squared residual, outliers by a constant; plain inlier counting cannot tell two
//! models with the same inliers apart, which matters for accepting a refinement). After a new
//! best model with `I` inliers of `n` data, the number of iterations needed to draw at least one
//! all-inlier sample with probability `confidence` is `k = log(1 - confidence) / log(1 - p)`,
//! with `p` the exact probability that a sample of `m` distinct data is all inliers,
//! `p = prod_{j < m} (I - j) / (n - j)` ([`all_inlier_probability`]; the usual `w^m`, `w = I / n`,
//! overstates it for small `n` and stops too early); the loop runs at least `min_iterations`
//! and stops at `min(max(k, min_iterations), max_iterations)` (with [`RansacOptions::local_optimization`], each new best
//! model is first refined on its inliers, LO-RANSAC). Then, if enabled, the best model is refined on its
//! inliers, the inliers recomputed, and the refinement kept when it lowers the MSAC cost
//! (`refine_rounds` times).
//!
//! With [`RansacOptions::skip_explained`] (off by default and in PoseLib's), once the
//! confidence is reached (the iterations beyond `k` that only `min_iterations` asks for), a
//! drawn sample whose data are all inliers of the best model is not solved (it still counts as
//! an iteration). That model was refitted on all its inliers (local optimization), and the
//! solve is the loop's whole cost: with few outliers nearly every sample is such, and PoseLib's
//! minimum of 1000 iterations costs 1000 solves for little. Measured (BENCHMARKS.md,
//! 2026-12-05): clean data 36-330x faster, and about one point of success lost at 20-40 %
//! outliers on generalized relative pose, where a later sample's several roots sometimes beat the
//! locally optimized model; hence off by default. Never before the confidence is reached: a
//! sample of the inliers of a wrong best model may hold the true one among its roots (GRPS lost
//! 7 points at 50 % outliers when every such sample was skipped).
//!
//! # Why a trait of our own and not rust-cv's `sample-consensus`
//!
//! `sample-consensus` 1.x has the same three ideas (`Estimator::MIN_SAMPLES`,
//! `Estimator::estimate(data iterator) -> models`, `Model::residual`) and leaves the loop to a
//! `Consensus` implementation (e.g. the `arrsac` crate). We keep a 3-method trait here because
//! (1) our minimal solvers are fallible and produce a variable number of hypotheses with
//! diagnostics, which a `&mut Vec` output expresses without allocation per iteration,
//! (2) the non-minimal refinement on the inliers is part of the algorithm we benchmark and has
//! no place in those traits, (3) the report needs iteration counts and per-stage numbers, and
//! (4) it adds no dependency. An adapter in either direction is a dozen lines: an
//! `impl<E: sample_consensus::Estimator<D>> Estimator for Wrapper<E>` forwards `MIN_SAMPLES`,
//! `estimate` and `residual`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A minimal solver and its residual, for [`ransac`].
pub trait Estimator {
    /// One datum (e.g. a correspondence).
    type Datum;
    /// A model (e.g. a pose).
    type Model: Clone;

    /// Number of data a minimal sample has.
    fn sample_size(&self) -> usize;

    /// Solves the sample `data[indices]` and pushes zero or more hypotheses onto `out` (which
    /// is empty on entry).
    fn solve(&self, data: &[Self::Datum], indices: &[usize], out: &mut Vec<Self::Model>);

    /// Residual of one datum under a model (non-negative; `f64::INFINITY` for impossible, e.g.
    /// a point behind a camera).
    fn residual(&self, model: &Self::Model, datum: &Self::Datum) -> f64;

    /// A model fitted to the inliers `data[inliers]`, starting from `model`; `None` (default)
    /// when the estimator has no non-minimal refinement.
    fn refine(&self, model: &Self::Model, data: &[Self::Datum], inliers: &[usize]) -> Option<Self::Model> {
        let _ = (model, data, inliers);
        None
    }
}

/// Settings of [`ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacOptions {
    /// Iterations (samples) at most. Default `200` (the paper's GRPS experiment).
    pub max_iterations: usize,
    /// Iterations (samples) at least, whatever the stopping rule says. Default `0`.
    pub min_iterations: usize,
    /// Stop once an all-inlier sample has been drawn with this probability (for the current
    /// best inlier ratio). Default `0.99`.
    pub confidence: f64,
    /// A datum is an inlier when its residual is at most this.
    pub threshold: f64,
    /// Rounds of non-minimal refinement of the best model on its inliers (`0`: none).
    /// Default `2`.
    pub refine_rounds: usize,
    /// Seed of the sampler. Default `0`.
    pub seed: u64,
    /// Local optimization (LO-RANSAC, Chum et al. 2003): every new best minimal model is
    /// refined on its inliers at once ([`Estimator::refine`]) and replaced when that gains
    /// inliers, so that the stopping rule and later comparisons use the better model.
    /// Default `false`.
    pub local_optimization: bool,
    /// Past the confidence, samples whose data are all inliers of the best model are not
    /// solved (module docs): much faster with few outliers, about one point of success less at
    /// 20-40 % outliers on problems with several roots per sample. Needs
    /// [`RansacOptions::local_optimization`]. Default `false`, also in
    /// [`RansacOptions::poselib`].
    pub skip_explained: bool,
}

impl Default for RansacOptions {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            min_iterations: 0,
            confidence: 0.99,
            threshold: 0.01,
            refine_rounds: 2,
            seed: 0,
            local_optimization: false,
            skip_explained: false,
        }
    }
}

impl RansacOptions {
    /// The same options with [`RansacOptions::skip_explained`] set to `skip`.
    pub fn skipping_explained(self, skip: bool) -> Self {
        Self { skip_explained: skip, ..self }
    }

    /// PoseLib's defaults (`RansacOptions` of PoseLib 2.x): confidence `0.9999`, at least 1000
    /// and at most 100000 iterations, local optimization on; `threshold` is the caller's.
    pub fn poselib(threshold: f64) -> Self {
        Self {
            max_iterations: 100_000,
            min_iterations: 1000,
            confidence: 0.9999,
            threshold,
            refine_rounds: 2,
            seed: 0,
            local_optimization: true,
            skip_explained: false,
        }
    }
}

/// The result of [`ransac`].
#[derive(Debug, Clone, PartialEq)]
pub struct RansacResult<M> {
    /// The best model (refined if refinement was enabled and helped).
    pub model: M,
    /// Indices of its inliers, increasing.
    pub inliers: Vec<usize>,
    /// Whether each datum is an inlier of the model.
    pub inlier_mask: Vec<bool>,
    /// The model's MSAC cost `sum_i min(r_i², threshold²)` (lower is better).
    pub score: f64,
    /// Iterations (samples) run.
    pub iterations: usize,
    /// Hypotheses scored.
    pub hypotheses: usize,
    /// Whether a refinement of the final rounds was kept.
    pub refined: bool,
    /// Refinements kept, local optimizations and final rounds together.
    pub refinements: usize,
}

impl<M> RansacResult<M> {
    /// Inliers over data.
    pub fn inlier_ratio(&self) -> f64 {
        self.inliers.len() as f64 / self.inlier_mask.len().max(1) as f64
    }
}

/// The probability that `m` data drawn without replacement out of `n`, `inliers` of which are
/// inliers, are all inliers: `prod_{j < m} (inliers - j) / (n - j)`.
pub fn all_inlier_probability(inliers: usize, n: usize, m: usize) -> f64 {
    if inliers < m || n < m {
        return 0.0;
    }
    (0..m).map(|j| (inliers - j) as f64 / (n - j) as f64).product()
}

/// Iterations needed for one all-inlier sample with probability `confidence`, from the
/// probability `p` that one sample is all inliers (`usize::MAX` for `p = 0`).
fn iterations_for(p: f64, confidence: f64) -> usize {
    if p >= 1.0 {
        return 1;
    }
    if p <= 0.0 {
        return usize::MAX;
    }
    let k = (1.0 - confidence.clamp(0.0, 1.0 - 1e-15)).ln() / (1.0 - p).ln();
    if k.is_finite() {
        k.ceil().max(1.0) as usize
    } else {
        usize::MAX
    }
}

/// Iterations needed to draw an all-inlier sample of `m` of `n` data, `inliers` of them
/// inliers, with probability `confidence` (the exact rule of [`ransac`]).
pub fn required_iterations_exact(inliers: usize, n: usize, m: usize, confidence: f64) -> usize {
    iterations_for(all_inlier_probability(inliers, n, m), confidence)
}

/// Iterations needed to draw an all-inlier sample of size `m` with probability `confidence`
/// when a fraction `w` of the data are inliers, by the approximation `p = w^m` (with
/// replacement; [`required_iterations_exact`] is what [`ransac`] uses). `usize::MAX` when `w^m`
/// underflows to zero.
pub fn required_iterations(w: f64, m: usize, confidence: f64) -> usize {
    iterations_for(w.clamp(0.0, 1.0).powi(m as i32), confidence)
}

/// Inlier count, MSAC cost `sum_i min(r_i², threshold²)`, and (optionally) the inlier indices
/// of `model`.
fn score<E: Estimator>(
    estimator: &E,
    model: &E::Model,
    data: &[E::Datum],
    threshold: f64,
    inliers: Option<&mut Vec<usize>>,
) -> (usize, f64) {
    let mut count = 0;
    let mut sum = 0.0;
    let mut list = inliers;
    if let Some(l) = list.as_deref_mut() {
        l.clear();
    }
    for (i, d) in data.iter().enumerate() {
        let r = estimator.residual(model, d);
        if r <= threshold {
            count += 1;
            sum += r * r;
            if let Some(l) = list.as_deref_mut() {
                l.push(i);
            }
        }
    }
    sum += (data.len() - count) as f64 * threshold * threshold;
    (count, sum)
}

/// Draws `m` distinct indices out of `0..n` into `out` (partial Fisher-Yates on `pool`).
fn draw(rng: &mut ChaCha8Rng, pool: &mut [usize], m: usize, out: &mut Vec<usize>) {
    out.clear();
    let n = pool.len();
    for k in 0..m {
        let j = rng.random_range(k..n);
        pool.swap(k, j);
        out.push(pool[k]);
    }
}

/// Runs RANSAC (module docs). Returns `None` when there are fewer data than a sample needs or
/// no hypothesis was ever produced.
pub fn ransac<E: Estimator>(estimator: &E, data: &[E::Datum], options: &RansacOptions) -> Option<RansacResult<E::Model>> {
    let m = estimator.sample_size();
    let n = data.len();
    if m == 0 || n < m {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut pool: Vec<usize> = (0..n).collect();
    let mut sample = Vec::with_capacity(m);
    let mut hypotheses = Vec::new();
    let mut best: Option<(E::Model, usize, f64)> = None;
    let mut needed = options.max_iterations;
    let mut iterations = 0;
    let mut scored = 0;
    let mut lo_inliers = Vec::new();
    let mut refined_inliers = Vec::new();
    let mut refinements = 0;
    // Whether each datum is an inlier of the best model so far (module docs: past the
    // confidence, its samples are not solved).
    let skip = options.skip_explained && options.local_optimization;
    let mut best_inliers = vec![false; if skip { n } else { 0 }];
    while iterations < needed.max(options.min_iterations).min(options.max_iterations) {
        iterations += 1;
        draw(&mut rng, &mut pool, m, &mut sample);
        if skip && iterations > needed && best.is_some() && sample.iter().all(|&i| best_inliers[i]) {
            continue;
        }
        hypotheses.clear();
        estimator.solve(data, &sample, &mut hypotheses);
        for h in hypotheses.drain(..) {
            scored += 1;
            let (count, sum) = score(estimator, &h, data, options.threshold, None);
            let better = match &best {
                None => true,
                Some((_, c, s)) => sum < *s || (sum == *s && count > *c),
            };
            if better {
                let (mut h, mut count, mut sum) = (h, count, sum);
                // `lo_inliers` holds the inliers of `h` when `known`.
                let mut known = false;
                if options.local_optimization && count >= m {
                    score(estimator, &h, data, options.threshold, Some(&mut lo_inliers));
                    known = true;
                    if let Some(r) = estimator.refine(&h, data, &lo_inliers) {
                        let (c, s) = score(estimator, &r, data, options.threshold, Some(&mut refined_inliers));
                        if s < sum || (s == sum && c > count) {
                            (h, count, sum) = (r, c, s);
                            std::mem::swap(&mut lo_inliers, &mut refined_inliers);
                            refinements += 1;
                        }
                    }
                }
                // The mask follows every new best, with or without its local optimization.
                if skip {
                    if !known {
                        score(estimator, &h, data, options.threshold, Some(&mut lo_inliers));
                    }
                    best_inliers.iter_mut().for_each(|b| *b = false);
                    lo_inliers.iter().for_each(|&i| best_inliers[i] = true);
                }
                best = Some((h, count, sum));
                needed = required_iterations_exact(count, n, m, options.confidence);
            }
        }
    }
    let (mut model, _, _) = best?;
    let mut inliers = Vec::new();
    let (mut count, mut sum) = score(estimator, &model, data, options.threshold, Some(&mut inliers));
    let mut refined = false;
    let mut candidate_inliers = Vec::new();
    for _ in 0..options.refine_rounds {
        if inliers.len() < m {
            break;
        }
        let Some(r) = estimator.refine(&model, data, &inliers) else { break };
        let (c, s) = score(estimator, &r, data, options.threshold, Some(&mut candidate_inliers));
        if s < sum || (s == sum && c > count) {
            model = r;
            (count, sum) = (c, s);
            std::mem::swap(&mut inliers, &mut candidate_inliers);
            refined = true;
            refinements += 1;
        } else {
            break;
        }
    }
    let mut inlier_mask = vec![false; n];
    inliers.iter().for_each(|&i| inlier_mask[i] = true);
    Some(RansacResult { model, inliers, inlier_mask, score: sum, iterations, hypotheses: scored, refined, refinements })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant fitted to numbers: a sample of one gives its number, the refinement the mean
    /// of the inliers; counts its solves.
    struct Constant {
        solves: std::cell::Cell<usize>,
    }

    impl Estimator for Constant {
        type Datum = f64;
        type Model = f64;
        fn sample_size(&self) -> usize {
            1
        }
        fn solve(&self, data: &[f64], indices: &[usize], out: &mut Vec<f64>) {
            self.solves.set(self.solves.get() + 1);
            out.push(data[indices[0]]);
        }
        fn residual(&self, model: &f64, datum: &f64) -> f64 {
            (model - datum).abs()
        }
        fn refine(&self, _: &f64, data: &[f64], inliers: &[usize]) -> Option<f64> {
            Some(inliers.iter().map(|&i| data[i]).sum::<f64>() / inliers.len() as f64)
        }
    }

    #[test]
    fn with_skip_explained_samples_of_the_best_models_inliers_are_not_solved() {
        // 40 numbers near 1 and 10 far away: every sample is one number, and those near 1 are
        // inliers of the best model once one of them was drawn.
        let data: Vec<f64> = (0..50).map(|i| if i < 40 { 1.0 + 1e-3 * (i as f64).sin() } else { 50.0 + i as f64 }).collect();
        let options = RansacOptions { min_iterations: 200, max_iterations: 200, ..RansacOptions::poselib(0.01) };
        let run = |skip_explained| {
            let constant = Constant { solves: std::cell::Cell::new(0) };
            let r = ransac(&constant, &data, &RansacOptions { skip_explained, ..options }).expect("a model");
            (r, constant.solves.get())
        };
        let (with, solves_with) = run(true);
        let (without, solves_without) = run(false);
        assert_eq!((with.iterations, without.iterations), (200, 200));
        assert_eq!(solves_without, 200, "every sample solved");
        // Past the confidence (6 samples at 80 % inliers), only the outliers drawn (a fifth of
        // the samples) are solved.
        assert!(solves_with < 80, "{solves_with} solves of 200 samples");
        assert_eq!(with.inliers, (0..40).collect::<Vec<_>>());
        assert_eq!(with.inliers, without.inliers);
        assert!((with.model - 1.0).abs() < 1e-3, "{}", with.model);
    }

    #[test]
    fn required_iterations_matches_the_formula() {
        // w = 0.5, m = 2: log(0.01) / log(0.75) = 16.0078 -> 17
        assert_eq!(required_iterations(0.5, 2, 0.99), 17);
        assert_eq!(required_iterations(1.0, 7, 0.99), 1);
        assert_eq!(required_iterations(0.0, 7, 0.99), usize::MAX);
        // 60 % inliers, 7-point samples: about 163 iterations
        assert_eq!(required_iterations(0.6, 7, 0.99), 163);
    }

    #[test]
    fn the_exact_rule_draws_without_replacement() {
        // 5 inliers of 10, pairs: p = 5/10 * 4/9 = 2/9, log(0.01) / log(7/9) = 18.33 -> 19,
        // where w^m = 1/4 gives 17 and stops early.
        assert!((all_inlier_probability(5, 10, 2) - 2.0 / 9.0).abs() < 1e-15);
        assert_eq!(required_iterations_exact(5, 10, 2, 0.99), 19);
        assert_eq!(required_iterations_exact(10, 10, 7, 0.99), 1);
        assert_eq!(required_iterations_exact(6, 10, 7, 0.99), usize::MAX);
        // Many data: the two rules agree.
        assert_eq!(required_iterations_exact(600_000, 1_000_000, 7, 0.99), required_iterations(0.6, 7, 0.99));
    }
}
