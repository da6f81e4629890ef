//! The path-jump repair's test — which paths are suspicious — and the batch queue that starts
//! re-tracking them while the main pass still runs.
//!
//! Why stream: the repair's first round used to run after the main pass, as a batch of a few
//! paths (GRPS7: about 5 of 140) at a fraction of the lanes' width, costing about a sixth of a
//! solve. [`RepairQueue`] flags a path as soon as it fails or its end point coincides with one
//! already known, and hands it out again with the repair settings ahead of the remaining main
//! paths, so re-tracks fill lanes that would otherwise idle. The set of paths re-tracked in the
//! first round is still exactly [`suspicious_paths`] of the main pass's results (the same
//! pairwise test, [`coincide`]), so the solve's result does not depend on when a suspect was
//! found, nor on how the paths were split over threads.

use crate::monodromy::{relative_distance, SignFlip, C};
use crate::tracker::batch::{BatchError, InOrder, PathJob, PathQueue};
use crate::tracker::{TrackError, TrackResult};
use nalgebra::SVector;
use std::collections::VecDeque;

/// One path's outcome.
pub(super) type PathResult<const N: usize> = Result<TrackResult<C, N>, TrackError>;

/// The main-pass results in the order of their indices, and the re-tracks (start index, result).
pub(super) type Passes<const N: usize> = (Vec<PathResult<N>>, Vec<(usize, PathResult<N>)>);

/// Something with an end point: a [`crate::tracker::TrackResult`] or a bare point.
pub trait EndPoint<const N: usize> {
    /// The point.
    fn point(&self) -> &SVector<C, N>;
}

impl<const N: usize> EndPoint<N> for SVector<C, N> {
    fn point(&self) -> &SVector<C, N> {
        self
    }
}

impl<const N: usize> EndPoint<N> for TrackResult<C, N> {
    fn point(&self) -> &SVector<C, N> {
        &self.x
    }
}

/// Indices of the paths that failed or whose end point coincides with another path's (modulo
/// the symmetry).
pub fn suspicious_paths<T: EndPoint<N>, const N: usize>(
    results: &[Result<T, TrackError>],
    symmetry: Option<&SignFlip>,
    tolerance: f64,
) -> Vec<usize> {
    let mut flagged = vec![false; results.len()];
    // Sort by a cheap key (the largest modulus, symmetric under sign flips) so that only
    // neighbours in the key need the full comparison.
    let mut order: Vec<(f64, usize)> = results
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match r {
            Ok(r) => Some((key(r.point()), i)),
            Err(_) => {
                flagged[i] = true;
                None
            }
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    for a in 0..order.len() {
        let (ka, ia) = order[a];
        let Ok(ra) = &results[ia] else { continue };
        let xa = ra.point();
        for &(kb, ib) in &order[a + 1..] {
            if !within_key(ka, kb, tolerance) {
                break;
            }
            if let Ok(rb) = &results[ib] {
                if coincide(xa, rb.point(), symmetry, tolerance) {
                    flagged[ia] = true;
                    flagged[ib] = true;
                }
            }
        }
    }
    (0..results.len()).filter(|&i| flagged[i]).collect()
}

/// Sort key of an end point: the largest modulus over its coordinates (sign-flip invariant).
pub(super) fn key<const N: usize>(x: &SVector<C, N>) -> f64 {
    x.iter().map(|z| z.norm()).fold(0.0, f64::max)
}

/// Whether key `kb >= ka` is close enough to `ka` for the end points to be compared.
fn within_key(ka: f64, kb: f64, tolerance: f64) -> bool {
    kb - ka <= tolerance * ka.max(1.0) * 2.0 + 1e-300
}

/// Whether end points `a` (the one first in key order) and `b` are the same, modulo the
/// symmetry: relative distance at most `tolerance`.
fn coincide<const N: usize>(a: &SVector<C, N>, b: &SVector<C, N>, symmetry: Option<&SignFlip>, tolerance: f64) -> bool {
    let d = relative_distance(a, b).min(symmetry.map_or(f64::INFINITY, |g| relative_distance(&g.apply(a), b)));
    d <= tolerance
}

/// The main pass over `indices` (settings `0`) with the repair's first round (settings `1`)
/// streamed in: see the module docs.
pub(super) struct RepairQueue<'a, const N: usize> {
    /// The main pass (settings `0`) and its results.
    main: InOrder<'a, N>,
    /// Re-track suspects (settings `1`); `false`: the main pass only.
    repair: bool,
    symmetry: Option<&'a SignFlip>,
    tolerance: f64,
    /// Positions of the successful main-pass results so far, with their keys.
    ended: Vec<(f64, usize)>,
    flagged: Vec<bool>,
    pending: VecDeque<usize>,
    /// First-round re-tracks: (start index, result).
    retracked: Vec<(usize, PathResult<N>)>,
}

impl<'a, const N: usize> RepairQueue<'a, N> {
    pub(super) fn new(indices: &'a [usize], repair: bool, symmetry: Option<&'a SignFlip>, tolerance: f64) -> Self {
        Self {
            main: InOrder::new(indices),
            repair,
            symmetry,
            tolerance,
            ended: Vec::with_capacity(indices.len()),
            flagged: vec![false; indices.len()],
            pending: VecDeque::new(),
            retracked: Vec::new(),
        }
    }

    /// The main-pass results in the order of `indices`, and the first-round re-tracks (or the
    /// error of a refused job).
    pub(super) fn into_results(self) -> Result<Passes<N>, BatchError> {
        Ok((self.main.into_results()?, self.retracked))
    }

    fn flag(&mut self, k: usize) {
        if self.repair && !self.flagged[k] {
            self.flagged[k] = true;
            self.pending.push_back(k);
        }
    }

    /// A main-pass result at position `k`: flags it if it failed, and it and every earlier end
    /// point it coincides with (the test of [`suspicious_paths`], pair by pair in key order).
    fn ended_main(&mut self, k: usize, result: &PathResult<N>) {
        let Ok(r) = result else {
            self.flag(k);
            return;
        };
        let kk = key(&r.x);
        let mut hits = Vec::new();
        let indices = self.main.indices();
        for &(kj, j) in &self.ended {
            let Some(Ok(rj)) = self.main.result(j) else { continue };
            // The pair in `suspicious_paths`' order: by key, then by start index.
            let k_first = (kk, indices[k]) < (kj, indices[j]);
            let ((ka, xa), (kb, xb)) = if k_first { ((kk, &r.x), (kj, &rj.x)) } else { ((kj, &rj.x), (kk, &r.x)) };
            if within_key(ka, kb, self.tolerance) && coincide(xa, xb, self.symmetry, self.tolerance) {
                hits.push(j);
            }
        }
        if !hits.is_empty() {
            self.flag(k);
        }
        for j in hits {
            self.flag(j);
        }
        self.ended.push((kk, k));
    }
}

impl<const N: usize> PathQueue<N> for RepairQueue<'_, N> {
    fn next(&mut self) -> Option<PathJob> {
        // Re-tracks first: a late start would lengthen the tail of the pass.
        if let Some(k) = self.pending.pop_front() {
            return Some(PathJob { id: k, start: self.main.indices()[k], settings: 1 });
        }
        self.main.next()
    }

    fn finished(&mut self, job: PathJob, result: PathResult<N>) {
        if job.settings == 0 {
            self.ended_main(job.id, &result);
            self.main.finished(job, result);
        } else {
            self.retracked.push((job.start, result));
        }
    }

    fn refused(&mut self, job: PathJob, error: BatchError) {
        self.main.refused(job, error);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::TrackStats;
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn ended(x: SVector<C, 3>) -> PathResult<3> {
        Ok(TrackResult { x, t: 1.0, stats: TrackStats::default(), accuracy: 0.0, residual: 0.0 })
    }

    /// End points with failures, exact and near duplicates, sign-flipped duplicates, equal keys
    /// and points just outside the tolerance.
    fn endpoints(rng: &mut ChaCha8Rng, n: usize) -> Vec<PathResult<3>> {
        let mut out: Vec<PathResult<3>> = Vec::new();
        for _ in 0..n {
            let kind = rng.random_range(0..7);
            let pick = |rng: &mut ChaCha8Rng, out: &Vec<PathResult<3>>| {
                out.iter().filter_map(|r| r.as_ref().ok()).nth(rng.random_range(0..out.len().max(1))).map(|r| r.x)
            };
            let r = match (kind, pick(rng, &out)) {
                (0, _) => Err(TrackError::CorrectorDidNotConverge { t: 1.0 }),
                (1, Some(x)) => ended(x),
                (2, Some(x)) => ended(x.map(|z| z * (1.0 + 3e-9))),
                (3, Some(x)) => ended(x.map(|z| z * (1.0 + 3e-8))),
                (4, Some(x)) => ended(SVector::from([-x[0], -x[1], x[2]])),
                _ => ended(SVector::from_fn(|_, _| C::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)))),
            };
            out.push(r);
        }
        out
    }

    /// Streaming the results in any order flags exactly `suspicious_paths`' set, so the first
    /// round re-tracks the same paths whenever the suspects are found.
    #[test]
    fn the_queue_flags_exactly_the_suspicious_paths_in_any_finishing_order() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let g = SignFlip::new([0, 1]);
        let (mut flagged_total, mut paths_total) = (0, 0);
        for case in 0..200 {
            let results = endpoints(&mut rng, 2 + case % 40);
            let symmetry = (case % 2 == 0).then_some(&g);
            let expected = suspicious_paths(&results, symmetry, 1e-8);
            // All paths handed out, then finishing in a shuffled order.
            let indices: Vec<usize> = (0..results.len()).collect();
            let mut order = indices.clone();
            order.shuffle(&mut rng);
            let mut queue = RepairQueue::<3>::new(&indices, true, symmetry, 1e-8);
            let jobs: Vec<PathJob> = std::iter::from_fn(|| queue.next()).collect();
            assert_eq!(jobs.len(), results.len());
            for &i in &order {
                queue.finished(jobs[i], results[i]);
            }
            let mut flagged: Vec<usize> = std::iter::from_fn(|| queue.next())
                .map(|job| {
                    assert_eq!(job.settings, 1);
                    job.start
                })
                .collect();
            flagged.sort();
            assert_eq!(flagged, expected, "case {case}");
            flagged_total += flagged.len();
            paths_total += results.len();
            let (main, retracked) = queue.into_results().unwrap();
            assert!(retracked.is_empty());
            assert_eq!(main, results);
        }
        // The cases are neither all clean nor all suspicious.
        assert!(flagged_total > paths_total / 10 && flagged_total < paths_total * 9 / 10, "{flagged_total} of {paths_total}");
    }

    /// The relative distance is not symmetric (it divides by the first point's moduli): a pair
    /// is measured from the point first in key order, in either finishing order.
    #[test]
    fn pairs_are_measured_from_the_smaller_key_in_either_finishing_order() {
        let a = SVector::from([C::new(4.0, 0.0), C::new(0.0, 0.0), C::new(0.0, 0.0)]);
        let b = SVector::from([C::new(4.42, 0.0), C::new(0.0, 0.0), C::new(0.0, 0.0)]);
        // From a: 0.42 / 4 = 0.105 > 0.1; from b it would be 0.42 / 4.42 = 0.095.
        let results = vec![ended(a), ended(b)];
        assert!(suspicious_paths(&results, None, 0.1).is_empty());
        for order in [[0, 1], [1, 0]] {
            let indices = [0, 1];
            let mut queue = RepairQueue::<3>::new(&indices, true, None, 0.1);
            let jobs = [queue.next().unwrap(), queue.next().unwrap()];
            for i in order {
                queue.finished(jobs[i], results[i]);
            }
            assert_eq!(queue.next(), None, "finishing order {order:?}");
        }
    }

    #[test]
    fn without_repair_the_queue_hands_out_the_main_pass_only() {
        let results = vec![Err(TrackError::NonFinite { t: 0.5 }), ended(SVector::zeros()), ended(SVector::zeros())];
        let indices = [4, 7, 9];
        let mut queue = RepairQueue::<3>::new(&indices, false, None, 1e-8);
        let mut starts = Vec::new();
        while let Some(job) = queue.next() {
            assert_eq!(job.settings, 0);
            starts.push(job.start);
            queue.finished(job, results[job.id]);
        }
        assert_eq!(starts, indices);
        assert_eq!(queue.into_results().unwrap().0, results);
    }
}
