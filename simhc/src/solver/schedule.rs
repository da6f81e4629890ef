//! What a solve tries, in which order: the attempts of a schedule over the slots of a solve's
//! start providers. A solve lays its providers out as [`provider`] says: the first-ranked
//! hypothesis plain and refined at 0 and 1 (where a schedule of one hypothesis,
//! [`shipped_schedule`], expects them), slot 2 free for a caller's extra provider (the bench's
//! random start), then the other ranks in pairs ([`super::hypotheses`]), the problem's other
//! starts ([`other_provider`]) and its restarts ([`restart_provider`], [`super::restarts`]).
//! The bottom of the solver's modules: it imports none of them.

use crate::pipeline::{Attempt, Method};

/// The attempts of a shipped solve, over the start providers `[learned, learned refined on all
/// rows]`: with a refine hook ([`super::DeclaredProblem::REFINES`]), its least-squares point on all
/// rows as it is, then Gauss-Newton on the tracked rows from it (with noise the first validates
/// more often: the tracked rows' exact root carries their noise to the other rows); without
/// one, Gauss-Newton on the tracked rows from the learned start; last, one Simulator HC path
/// from the learned start. The fallback comes after them.
pub fn shipped_schedule(refines: bool) -> &'static [Attempt] {
    const SIMULATOR_HC: Attempt = Attempt { provider: 0, method: Method::SimulatorHc };
    const REFINED: [Attempt; 3] =
        [Attempt { provider: 1, method: Method::Start }, Attempt { provider: 1, method: Method::GaussNewton }, SIMULATOR_HC];
    const PLAIN: [Attempt; 2] = [Attempt { provider: 0, method: Method::GaussNewton }, SIMULATOR_HC];
    if refines {
        &REFINED
    } else {
        &PLAIN
    }
}

/// The attempts on a RANSAC sample: the first of [`shipped_schedule`] only (Gauss-Newton from
/// the learned start, on all rows where the problem refines): most samples hold an outlier and
/// no attempt validates them, and among the many samples one that is all inliers and in the
/// basin comes soon, so a sample that does not validate at once is dropped.
pub fn sample_schedule(refines: bool) -> &'static [Attempt] {
    &shipped_schedule(refines)[..1]
}

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
/// 5. Gauss-Newton from every restart ([`super::schedule::restart_provider`]).
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
    out.extend(restart_attempts(hypotheses, starts, restarts));
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

/// The index of restart `k` in a solve's provider list: after the `others` other starts.
pub const fn restart_provider(hypotheses: usize, others: usize, k: usize) -> usize {
    other_provider(hypotheses, others) + k
}

/// The attempts of `restarts` restarts: Gauss-Newton on the tracked rows from each, in order.
pub fn restart_attempts(hypotheses: usize, others: usize, restarts: usize) -> impl Iterator<Item = Attempt> {
    (0..restarts).map(move |k| Attempt { provider: restart_provider(hypotheses, others, k), method: Method::GaussNewton })
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
        let base = shipped_schedule(true);
        let plain = solver_schedule(base, 3, 0, 1, 4);
        let mut first = plain.clone();
        other_starts_first(&mut first, 3, 0, 4);
        assert_eq!(first, plain);
    }

    #[test]
    fn every_start_gets_gauss_newton_before_the_first_path_and_restarts_come_last() {
        let a = |provider, method| Attempt { provider, method };
        let base = shipped_schedule(false);
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
        let base = shipped_schedule(true);
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
