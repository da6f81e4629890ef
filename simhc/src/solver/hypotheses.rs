//! Several start hypotheses from one forward pass: a learned start trained with a
//! winner-takes-all loss predicts [`crate::pipeline::LearnedStart::hypotheses`] guesses of the unknowns and a
//! score for each; they are ranked by their scores (an unscored network's by how well each
//! explains all of the data's rows, [`super::DeclaredProblem::row_error`] squared and summed) and
//! tracked in that order before any fallback. Why rank: the network is trained so that *one*
//! of its guesses is close, not a given one; its scores are trained to say which.
//!
//! The start providers of a solve are laid out as [`provider`] says: the first-ranked guess
//! plain and refined at 0 and 1 (where a schedule of one hypothesis, [`super::shipped_schedule`],
//! expects them), index 2 free for a caller's extra provider (the bench's random start), then
//! the other ranks in pairs.

use super::instance::{LearnedHypotheses, Ranked};
use crate::pipeline::{Attempt, Method, StartError, StartProvider};
use nalgebra::SVector;
use std::cell::RefCell;

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

/// The index of the problem's `j`-th other start ([`super::DeclaredProblem::other_starts`]) in a
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

/// `schedule` (of [`solver_schedule`], with `restarts` restarts at its end) with the other
/// starts' attempts first within the cheap attempts and within the paths, otherwise in order:
/// for a problem whose other start is cheaper than the learned one and as good on its data
/// ([`super::InstanceProblem::other_starts_first`]: UPnP's closed-form linear start, about 3 us
/// against the network's 10 us on 10 correspondences, exact on noise-free data).
pub fn other_starts_first(schedule: &mut [Attempt], hypotheses: usize, starts: usize, restarts: usize) {
    let others = other_provider(hypotheses, 0)..other_provider(hypotheses, starts);
    let end = schedule.len().saturating_sub(restarts);
    let first_path = schedule[..end].iter().position(is_path).unwrap_or(end);
    let learned = |a: &Attempt| !others.contains(&a.provider);
    // Stable: each group keeps its order.
    schedule[..first_path].sort_by_key(learned);
    schedule[first_path..end].sort_by_key(learned);
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

/// The ranked hypotheses of one solve, computed at the first request and kept for the datum
/// they were computed from: a solve asks for them on one (canonical) datum. A set serves one
/// datum: it is keyed by the datum's address, so make a new set for each datum (one at a
/// reused address, a stack slot in a loop, would get the old hypotheses).
pub struct RankedStarts<'a, L, const NX: usize> {
    learned: &'a L,
    ranked: RefCell<Option<(DatumKey, Result<Ranked<NX>, StartError>)>>,
}

impl<'a, L, const NX: usize> RankedStarts<'a, L, NX> {
    /// The hypotheses of `learned`, not yet computed.
    pub fn new(learned: &'a L) -> Self {
        Self { learned, ranked: RefCell::new(None) }
    }

    /// How many hypotheses a forward pass makes.
    pub fn count<D: ?Sized>(&self) -> usize
    where
        L: LearnedHypotheses<D, NX>,
    {
        self.learned.hypotheses()
    }

    /// The hypothesis of `rank` for `data` (an error when the network gave fewer).
    pub fn start<D: ?Sized>(&self, data: &D, rank: usize) -> Result<SVector<f64, NX>, StartError>
    where
        L: LearnedHypotheses<D, NX>,
    {
        let key: DatumKey = (data as *const D as *const u8, std::mem::size_of_val(data));
        let mut cache = self.ranked.borrow_mut();
        if !matches!(&*cache, Some((k, _)) if *k == key) {
            *cache = Some((key, self.learned.rank(data)));
        }
        let Some((_, ranked)) = &*cache else { unreachable!("just filled") };
        match ranked {
            Ok(r) if rank < r.count => Ok(r.x[rank]),
            Ok(_) => Err(StartError { provider: "learned", reason: format!("no hypothesis of rank {rank}").into() }),
            Err(e) => Err(e.clone()),
        }
    }
}

/// Where a datum is and how many bytes it spans (a slice and its prefix differ).
type DatumKey = (*const u8, usize);

/// The hypothesis of one rank, as a start provider.
pub struct RankedStart<'h, 'a, L, const NX: usize> {
    /// The solve's hypotheses.
    pub set: &'h RankedStarts<'a, L, NX>,
    /// Which one (0: the best).
    pub rank: usize,
}

impl<L, D: ?Sized, const NX: usize> StartProvider<D, NX> for RankedStart<'_, '_, L, NX>
where
    L: LearnedHypotheses<D, NX>,
{
    fn name(&self) -> &'static str {
        if self.rank == 0 {
            "learned"
        } else {
            "learned, another hypothesis"
        }
    }
    fn start(&self, data: &D) -> Result<SVector<f64, NX>, StartError> {
        self.set.start(data, self.rank)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::MAX_HYPOTHESES;

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
    fn other_starts_first_without_other_starts_keeps_the_schedule() {
        let base = super::super::shipped_schedule(true);
        let plain = solver_schedule(base, 3, 0, 1, 4);
        let mut first = plain.clone();
        other_starts_first(&mut first, 3, 0, 4);
        assert_eq!(first, plain);
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
        let mut first = solver_schedule(base, 2, 1, 1, 2);
        other_starts_first(&mut first, 2, 1, 2);
        let order = [2, 0, 1, 7, 8, 3, 4, 5, 6, 9, 10].map(|i| expect[i]);
        assert_eq!(first, order, "the other start's Gauss-Newton, then its paths, come first; restarts stay last");
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
