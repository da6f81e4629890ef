//! Several start hypotheses from one forward pass: a learned start trained with a
//! winner-takes-all loss predicts [`LearnedStart::hypotheses`] guesses of the unknowns and a
//! score for each; they are ranked by their scores (an unscored network's by how well each
//! explains all of the data's rows, [`DeclaredProblem::row_error`] squared and summed) and
//! tracked in that order before any fallback. Why rank: the network is trained so that *one*
//! of its guesses is close, not a given one; its scores are trained to say which.
//!
//! The start providers of a solve are laid out as [`provider`] says: the first-ranked guess
//! plain and refined at 0 and 1 (where a schedule of one hypothesis, [`super::shipped_schedule`],
//! expects them), index 2 free for a caller's extra provider (the bench's random start), then
//! the other ranks in pairs.

use super::problem::DeclaredProblem;
use crate::pipeline::{Attempt, InputRows, LearnedStart, Method, OutputDecoding, StartError, StartProvider, MAX_HYPOTHESES};
use crate::ProblemLayout;
use nalgebra::SVector;
use std::cell::RefCell;
use std::marker::PhantomData;

/// The index of the start provider of hypothesis `rank` (0 is the first-ranked), plain or
/// refined on all rows, in a solve's provider list (module docs).
pub const fn provider(rank: usize, refined: bool) -> usize {
    let pair = if rank == 0 { 0 } else { 1 + 2 * rank };
    pair + refined as usize
}

/// The providers' slots a solve with `hypotheses` hypotheses needs.
pub const fn provider_count(hypotheses: usize) -> usize {
    provider(if hypotheses == 0 { 0 } else { hypotheses - 1 }, true) + 1
}

/// The index of the problem's `j`-th other start ([`DeclaredProblem::other_starts`]) in a
/// solve's provider list: after the hypotheses' providers and slot 2.
pub const fn other_provider(hypotheses: usize, j: usize) -> usize {
    let first = provider_count(hypotheses);
    (if first > 3 { first } else { 3 }) + j
}

/// Whether an attempt tracks a path (the costly kind: tens of microseconds and more, against a
/// few for Gauss-Newton).
fn is_path(a: &Attempt) -> bool {
    matches!(a.method, Method::SimulatorHc | Method::OtherSimulatorHc(_))
}

/// The attempts of a solver over `hypotheses` ranked hypotheses of `base` (a schedule of one
/// hypothesis, [`super::shipped_schedule`]), `starts` other starts, `simulators` other
/// simulators and `restarts` restarts, cheap attempts before paths:
///
/// 1. the cheap attempts of [`ranked_schedule`] (refinements, Gauss-Newton) on every hypothesis;
/// 2. Gauss-Newton from every other start ([`other_provider`]);
/// 3. the paths of [`ranked_schedule`] on every hypothesis, then a path from every hypothesis
///    with each other simulator;
/// 4. from every other start, a path with the own simulator and one with each other simulator;
/// 5. Gauss-Newton from every restart ([`super::restarts::restart_provider`]).
///
/// Why this order: a start that Gauss-Newton brings to a validated solution costs a few
/// microseconds, a path tens to hundreds, so every start's Gauss-Newton comes before the first
/// path (on GRPS this halves the retries' mean time at the same success, BENCHMARKS.md,
/// 2026-12-04); restarts come last, as they are many.
pub fn solver_schedule(base: &[Attempt], hypotheses: usize, starts: usize, simulators: usize, restarts: usize) -> Vec<Attempt> {
    let ranked = ranked_schedule(base, hypotheses);
    let (cheap, paths) = ranked.split_at(ranked.iter().position(is_path).unwrap_or(ranked.len()));
    let other = |j: usize| other_provider(hypotheses, j);
    let mut out = cheap.to_vec();
    out.extend((0..starts).map(|j| Attempt { provider: other(j), method: Method::GaussNewton }));
    out.extend_from_slice(paths);
    for k in 0..simulators {
        out.extend((0..hypotheses.max(1)).map(|rank| Attempt { provider: provider(rank, false), method: Method::OtherSimulatorHc(k) }));
    }
    for j in 0..starts {
        out.push(Attempt { provider: other(j), method: Method::SimulatorHc });
        out.extend((0..simulators).map(|k| Attempt { provider: other(j), method: Method::OtherSimulatorHc(k) }));
    }
    out.extend(super::restarts::restart_attempts(hypotheses, starts, restarts));
    out
}

/// `base` (a schedule of one hypothesis over providers 0 and 1, [`super::shipped_schedule`])
/// for `hypotheses` ranked hypotheses: its attempts other than Simulator HC on every hypothesis
/// in rank order (cheap: a refinement and Gauss-Newton, a few microseconds each), then its
/// Simulator HC attempts on every hypothesis in rank order. With one hypothesis, `base` itself.
pub fn ranked_schedule(base: &[Attempt], hypotheses: usize) -> Vec<Attempt> {
    let mut out = Vec::with_capacity(base.len() * hypotheses.max(1));
    let map = |a: &Attempt, rank: usize| Attempt { provider: provider(rank, a.provider == 1), method: a.method };
    for rank in 0..hypotheses.max(1) {
        out.extend(base.iter().filter(|a| !is_path(a)).map(|a| map(a, rank)));
    }
    for rank in 0..hypotheses.max(1) {
        out.extend(base.iter().filter(|a| is_path(a)).map(|a| map(a, rank)));
    }
    out
}

/// The ranked hypotheses of one solve, computed at the first request and kept for the data
/// they were computed from (a solve asks for them on one canonical data vector).
pub struct RankedStarts<'a, S, R, O, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    learned: &'a LearnedStart<R, O>,
    problem: &'a S,
    ranked: RefCell<Option<Cached<NX, ND>>>,
    sizes: PhantomData<fn() -> [(); NF]>,
}

/// The data the hypotheses were ranked for, and the ranking.
type Cached<const NX: usize, const ND: usize> = (SVector<f64, ND>, Result<Ranked<NX>, StartError>);

/// Hypotheses in rank order.
#[derive(Clone, Copy)]
struct Ranked<const NX: usize> {
    x: [SVector<f64, NX>; MAX_HYPOTHESES],
    count: usize,
}

impl<'a, S, R, O, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>
    RankedStarts<'a, S, R, O, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
    R: InputRows,
    O: OutputDecoding,
{
    /// The hypotheses of `learned`, ranked on `problem`'s rows.
    pub fn new(learned: &'a LearnedStart<R, O>, problem: &'a S) -> Self {
        Self { learned, problem, ranked: RefCell::new(None), sizes: PhantomData }
    }

    /// Hypotheses per prediction.
    pub fn count(&self) -> usize {
        self.learned.hypotheses()
    }

    /// The hypothesis of rank `rank` for data `p`.
    pub fn start(&self, p: &SVector<f64, ND>, rank: usize) -> Result<SVector<f64, NX>, StartError> {
        let mut cache = self.ranked.borrow_mut();
        let stale = !matches!(&*cache, Some((q, _)) if q == p);
        if stale {
            *cache = Some((*p, self.rank(p)));
        }
        let Some((_, ranked)) = &*cache else { unreachable!("just filled") };
        match ranked {
            Ok(r) if rank < r.count => Ok(r.x[rank]),
            Ok(_) => Err(StartError { provider: "learned", reason: format!("no hypothesis of rank {rank}") }),
            Err(e) => Err(e.clone()),
        }
    }

    /// Predicts every hypothesis and sorts them by the data's summed squared row errors
    /// (stable: ties keep the network's order). A hypothesis that decodes to no unknowns is
    /// left out; an error when none decodes.
    fn rank(&self, p: &SVector<f64, ND>) -> Result<Ranked<NX>, StartError> {
        let blocks = self.learned.blocks();
        let fail = |e: crate::regressor::RegressorError| StartError { provider: "learned", reason: e.to_string() };
        let mut out = [0.0f64; crate::regressor::MAX_WIDTH];
        let out = &mut out[..blocks.outputs()];
        self.learned.predict_all(p.as_slice(), out).map_err(fail)?;
        let mut decoded = [SVector::<f64, NX>::zeros(); MAX_HYPOTHESES];
        let mut ok = [false; MAX_HYPOTHESES];
        let mut last = None;
        for k in 0..blocks.count {
            match self.learned.decode(out, k, decoded[k].as_mut_slice()) {
                Ok(()) => ok[k] = true,
                Err(e) => last = Some(e),
            }
        }
        // An unscored network of several hypotheses: ranked by the data's residual. One that
        // does not decode ranks last and is dropped below.
        let order = blocks.ranked::<MAX_HYPOTHESES>(out, |k| if ok[k] { self.score(&decoded[k], p) } else { f64::INFINITY });
        let mut ranked = Ranked { x: [SVector::zeros(); MAX_HYPOTHESES], count: 0 };
        for &k in order[..blocks.count].iter().filter(|&&k| ok[k]) {
            ranked.x[ranked.count] = decoded[k];
            ranked.count += 1;
        }
        match (ranked.count, last) {
            (0, Some(e)) => Err(fail(e)),
            _ => Ok(ranked),
        }
    }

    /// Summed squared row errors of `x` over all rows of the data `p` (NaN counts as infinite).
    fn score(&self, x: &SVector<f64, NX>, p: &SVector<f64, ND>) -> f64 {
        let layout = S::Data::LAYOUT;
        let (rows, per_row) = (layout.rows, layout.per_row);
        let globals = &p.as_slice()[rows * per_row..];
        let total: f64 = (0..rows).map(|i| self.problem.row_error(x, &p.as_slice()[i * per_row..(i + 1) * per_row], globals).powi(2)).sum();
        if total.is_nan() {
            f64::INFINITY
        } else {
            total
        }
    }
}

/// The hypothesis of one rank as a start provider.
pub struct RankedStart<'h, 'a, S, R, O, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    /// The solve's hypotheses.
    pub set: &'h RankedStarts<'a, S, R, O, NX, NF, NP, NC, ND>,
    /// Its rank (0: the best-ranked).
    pub rank: usize,
}

impl<S, R, O, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> StartProvider<SVector<f64, ND>, NX>
    for RankedStart<'_, '_, S, R, O, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
    R: InputRows,
    O: OutputDecoding,
{
    fn name(&self) -> &'static str {
        if self.rank == 0 {
            "learned"
        } else {
            "learned, another hypothesis"
        }
    }
    fn start(&self, p: &SVector<f64, ND>) -> Result<SVector<f64, NX>, StartError> {
        self.set.start(p, self.rank)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn providers_keep_the_one_hypothesis_slots_and_never_collide() {
        assert_eq!((provider(0, false), provider(0, true)), (0, 1));
        assert_eq!((provider(1, false), provider(1, true)), (3, 4));
        assert_eq!(provider_count(1), 2);
        assert_eq!(provider_count(3), 7);
        let mut seen: Vec<usize> = (0..MAX_HYPOTHESES).flat_map(|k| [provider(k, false), provider(k, true)]).collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 2 * MAX_HYPOTHESES);
        assert!(!seen.contains(&2), "slot 2 is the caller's");
        assert_eq!(other_provider(1, 0), 3, "after slot 2");
        assert_eq!(other_provider(3, 1), provider_count(3) + 1);
    }

    #[test]
    fn every_start_gets_gauss_newton_before_the_first_path_and_restarts_come_last() {
        let a = |provider, method| Attempt { provider, method };
        let base = super::super::shipped_schedule(false);
        // Two hypotheses (providers 0 and 3), one other start (5), one other simulator, two
        // restarts (6, 7).
        let expect = [
            a(0, Method::GaussNewton),
            a(3, Method::GaussNewton),
            a(5, Method::GaussNewton),
            a(0, Method::SimulatorHc),
            a(3, Method::SimulatorHc),
            a(0, Method::OtherSimulatorHc(0)),
            a(3, Method::OtherSimulatorHc(0)),
            a(5, Method::SimulatorHc),
            a(5, Method::OtherSimulatorHc(0)),
            a(6, Method::GaussNewton),
            a(7, Method::GaussNewton),
        ];
        assert_eq!(solver_schedule(base, 2, 1, 1, 2), expect);
        assert_eq!(solver_schedule(base, 4, 0, 0, 0), ranked_schedule(base, 4));
    }

    #[test]
    fn ranked_schedule_tries_the_cheap_attempts_of_every_hypothesis_before_paths() {
        let base = super::super::shipped_schedule(true);
        assert_eq!(ranked_schedule(base, 1), base.to_vec());
        let s = ranked_schedule(base, 2);
        let expect = [
            (1, Method::Start),
            (1, Method::GaussNewton),
            (4, Method::Start),
            (4, Method::GaussNewton),
            (0, Method::SimulatorHc),
            (3, Method::SimulatorHc),
        ];
        assert_eq!(s.iter().map(|a| (a.provider, a.method)).collect::<Vec<_>>(), expect);
    }
}
