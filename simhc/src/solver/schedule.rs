//! What a solve tries, in which order: the attempts of a schedule, each naming its start
//! ([`StartId`]): a learned hypothesis by its rank, plain or refined on all the data
//! ([`super::hypotheses`]), one of the problem's other starts, a restart around the
//! first-ranked hypothesis ([`super::restarts`]), or the start a caller gives a run
//! ([`super::InstanceSolver::run_pipeline`]: the bench's random start). Where each start sits
//! in the pipeline's list of providers is the solver's own business ([`super::library`]): an
//! attempt naming a start that the solve does not have (a rank beyond the learned start's
//! hypotheses, an other start beyond the problem's, no given start) is no attempt.
//! The bottom of the solver's modules: it imports none of them.

use crate::pipeline::Method;

/// Where an attempt of a solver starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StartId {
    /// Learned hypothesis `rank` (0: the first-ranked), as predicted or refined on all the data
    /// ([`super::DeclaredProblem::refine`]).
    Learned {
        /// Its rank among the hypotheses.
        rank: usize,
        /// Whether it was refined on all the data first.
        refined: bool,
    },
    /// The problem's `j`-th other start ([`super::Plan::other_starts`]).
    Other(usize),
    /// Restart `k` around the first-ranked hypothesis ([`super::restarts`]).
    Restart(usize),
    /// The caller's start ([`super::InstanceSolver::run_pipeline`]'s `given`).
    Given,
}

impl StartId {
    /// The first-ranked learned hypothesis, as predicted.
    pub const LEARNED: StartId = StartId::Learned { rank: 0, refined: false };
    /// The first-ranked learned hypothesis, refined on all the data.
    pub const REFINED: StartId = StartId::Learned { rank: 0, refined: true };
}

impl std::fmt::Display for StartId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StartId::Learned { rank, refined: false } => write!(f, "learned {rank}"),
            StartId::Learned { rank, refined: true } => write!(f, "learned {rank}, refined"),
            StartId::Given => write!(f, "given"),
            StartId::Other(j) => write!(f, "other {j}"),
            StartId::Restart(k) => write!(f, "restart {k}"),
        }
    }
}

/// One attempt of a solver's schedule: a start by name and a method. (The low-level
/// [`crate::pipeline::Attempt`] names its start by its index in the pipeline's providers.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SolverAttempt {
    /// Where it starts.
    pub start: StartId,
    /// How it goes from there to an end point.
    pub method: Method,
}

impl SolverAttempt {
    /// The attempt from `start` with `method`.
    pub const fn new(start: StartId, method: Method) -> Self {
        Self { start, method }
    }
}

/// The attempts of a shipped solve, over the first-ranked learned hypothesis, predicted and
/// refined on all rows: with a refine hook ([`super::Plan::refine`]), its
/// least-squares point on all rows as it is, then Gauss-Newton on the tracked rows from it
/// (with noise the first validates more often: the tracked rows' exact root carries their
/// noise to the other rows); without one, Gauss-Newton on the tracked rows from the learned
/// start; last, one Simulator HC path from the learned start. The fallback comes after them.
pub fn shipped_schedule(refines: bool) -> &'static [SolverAttempt] {
    const SIMULATOR_HC: SolverAttempt = SolverAttempt::new(StartId::LEARNED, Method::SimulatorHc);
    const REFINED: [SolverAttempt; 3] =
        [SolverAttempt::new(StartId::REFINED, Method::Start), SolverAttempt::new(StartId::REFINED, Method::GaussNewton), SIMULATOR_HC];
    const PLAIN: [SolverAttempt; 2] = [SolverAttempt::new(StartId::LEARNED, Method::GaussNewton), SIMULATOR_HC];
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
pub fn sample_schedule(refines: bool) -> &'static [SolverAttempt] {
    &shipped_schedule(refines)[..1]
}

/// Whether an attempt tracks a path (the costly kind: tens of microseconds and more, against a
/// few for Gauss-Newton).
fn is_path(a: &SolverAttempt) -> bool {
    matches!(a.method, Method::SimulatorHc | Method::OtherSimulatorHc(_))
}

/// The attempts of a solver over `hypotheses` ranked hypotheses of `base` (a schedule of one
/// hypothesis, [`super::shipped_schedule`]), `starts` other starts, `simulators` other
/// simulators and `restarts` restarts, cheap attempts before paths:
///
/// 1. the cheap attempts of [`ranked_schedule`] (refinements, Gauss-Newton) on every hypothesis;
/// 2. Gauss-Newton from every other start ([`StartId::Other`]);
/// 3. the paths of [`ranked_schedule`] on every hypothesis, then a path from every hypothesis
///    with each other simulator;
/// 4. from every other start, a path with the own simulator and one with each other simulator;
/// 5. Gauss-Newton from every restart ([`StartId::Restart`]).
///
/// Why this order: a start that Gauss-Newton brings to a validated solution costs a few
/// microseconds, a path tens to hundreds, so every start's Gauss-Newton comes before the first
/// path (on GRPS this halves the retries' mean time at the same success, BENCHMARKS.md,
/// 2026-12-04); restarts come last, as they are many.
pub fn solver_schedule(base: &[SolverAttempt], hypotheses: usize, starts: usize, simulators: usize, restarts: usize) -> Vec<SolverAttempt> {
    let ranked = ranked_schedule(base, hypotheses);
    let (cheap, paths) = ranked.split_at(ranked.iter().position(is_path).unwrap_or(ranked.len()));
    let mut out = cheap.to_vec();
    out.extend((0..starts).map(|j| SolverAttempt::new(StartId::Other(j), Method::GaussNewton)));
    out.extend_from_slice(paths);
    for k in 0..simulators {
        out.extend(
            (0..hypotheses.max(1)).map(|rank| SolverAttempt::new(StartId::Learned { rank, refined: false }, Method::OtherSimulatorHc(k))),
        );
    }
    for j in 0..starts {
        out.push(SolverAttempt::new(StartId::Other(j), Method::SimulatorHc));
        out.extend((0..simulators).map(|k| SolverAttempt::new(StartId::Other(j), Method::OtherSimulatorHc(k))));
    }
    out.extend(restart_attempts(restarts));
    out
}

/// `schedule` (of [`solver_schedule`], with `restarts` restarts at its end) with the other
/// starts' attempts first within the cheap attempts and within the paths, otherwise in order:
/// for a problem whose other start is cheaper than the learned one and as good on its data
/// ([`super::Plan::other_starts_first`]: UPnP's closed-form linear start, about 3 us
/// against the network's 10 us on 10 correspondences, exact on noise-free data).
pub fn other_starts_first(schedule: &mut [SolverAttempt], restarts: usize) {
    let end = schedule.len().saturating_sub(restarts);
    let first_path = schedule[..end].iter().position(is_path).unwrap_or(end);
    let learned = |a: &SolverAttempt| !matches!(a.start, StartId::Other(_));
    // Stable: each group keeps its order.
    schedule[..first_path].sort_by_key(learned);
    schedule[first_path..end].sort_by_key(learned);
}

/// `base` (a schedule of one hypothesis, over the first-ranked one predicted and refined,
/// [`super::shipped_schedule`]) for `hypotheses` ranked hypotheses: its attempts other than
/// Simulator HC on every hypothesis in rank order (cheap: a refinement and Gauss-Newton, a few
/// microseconds each), then its Simulator HC attempts on every hypothesis in rank order. An
/// attempt of `base` from another start than a learned one is repeated as it is. With one
/// hypothesis, `base` itself.
pub fn ranked_schedule(base: &[SolverAttempt], hypotheses: usize) -> Vec<SolverAttempt> {
    let mut out = Vec::with_capacity(base.len() * hypotheses.max(1));
    let map = |a: &SolverAttempt, rank: usize| match a.start {
        StartId::Learned { refined, .. } => SolverAttempt::new(StartId::Learned { rank, refined }, a.method),
        _ => *a,
    };
    for rank in 0..hypotheses.max(1) {
        out.extend(base.iter().filter(|a| !is_path(a)).map(|a| map(a, rank)));
    }
    for rank in 0..hypotheses.max(1) {
        out.extend(base.iter().filter(|a| is_path(a)).map(|a| map(a, rank)));
    }
    out
}

/// The attempts of `restarts` restarts: Gauss-Newton on the tracked rows from each, in order.
pub fn restart_attempts(restarts: usize) -> impl Iterator<Item = SolverAttempt> {
    (0..restarts).map(|k| SolverAttempt::new(StartId::Restart(k), Method::GaussNewton))
}

#[cfg(test)]
mod tests {
    use super::*;

    const fn learned(rank: usize) -> StartId {
        StartId::Learned { rank, refined: false }
    }

    #[test]
    fn other_starts_first_without_other_starts_keeps_the_schedule() {
        let base = shipped_schedule(true);
        let plain = solver_schedule(base, 3, 0, 1, 4);
        let mut first = plain.clone();
        other_starts_first(&mut first, 4);
        assert_eq!(first, plain);
    }

    #[test]
    fn every_start_gets_gauss_newton_before_the_first_path_and_restarts_come_last() {
        let a = SolverAttempt::new;
        let base = shipped_schedule(false);
        // Two hypotheses, one other start, one other simulator, two restarts.
        let expect = [
            a(learned(0), Method::GaussNewton),
            a(learned(1), Method::GaussNewton),
            a(StartId::Other(0), Method::GaussNewton),
            a(learned(0), Method::SimulatorHc),
            a(learned(1), Method::SimulatorHc),
            a(learned(0), Method::OtherSimulatorHc(0)),
            a(learned(1), Method::OtherSimulatorHc(0)),
            a(StartId::Other(0), Method::SimulatorHc),
            a(StartId::Other(0), Method::OtherSimulatorHc(0)),
            a(StartId::Restart(0), Method::GaussNewton),
            a(StartId::Restart(1), Method::GaussNewton),
        ];
        assert_eq!(solver_schedule(base, 2, 1, 1, 2), expect);
        assert_eq!(solver_schedule(base, 4, 0, 0, 0), ranked_schedule(base, 4));
        let mut first = solver_schedule(base, 2, 1, 1, 2);
        other_starts_first(&mut first, 2);
        let order = [2, 0, 1, 7, 8, 3, 4, 5, 6, 9, 10].map(|i| expect[i]);
        assert_eq!(first, order, "the other start's Gauss-Newton, then its paths, come first; restarts stay last");
    }

    #[test]
    fn ranked_schedule_tries_the_cheap_attempts_of_every_hypothesis_before_paths() {
        let base = shipped_schedule(true);
        assert_eq!(ranked_schedule(base, 1), base.to_vec());
        let s = ranked_schedule(base, 2);
        let refined = |rank| StartId::Learned { rank, refined: true };
        let expect = [
            (refined(0), Method::Start),
            (refined(0), Method::GaussNewton),
            (refined(1), Method::Start),
            (refined(1), Method::GaussNewton),
            (learned(0), Method::SimulatorHc),
            (learned(1), Method::SimulatorHc),
        ];
        assert_eq!(s.iter().map(|a| (a.start, a.method)).collect::<Vec<_>>(), expect);
    }

    #[test]
    fn the_shipped_schedule_starts_from_the_first_hypothesis_only() {
        for refines in [false, true] {
            assert!(shipped_schedule(refines).iter().all(|a| matches!(a.start, StartId::Learned { rank: 0, .. })));
            assert_eq!(sample_schedule(refines), &shipped_schedule(refines)[..1]);
        }
        assert_eq!(shipped_schedule(true)[0], SolverAttempt::new(StartId::REFINED, Method::Start));
    }
}
