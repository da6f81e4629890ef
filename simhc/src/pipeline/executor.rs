//! The executor: runs the attempts of a [`Pipeline`] in order until one validates.

use super::path::{gauss_newton, simulator_hc};
use super::{
    Attempt, AttemptError, Canonicalize, Fallback, Method, Origin, PipelineError, Schedule, Solved, StageTimes, StartError, StartProvider,
    StartSimulator, TargetParameters, Validator, Verdict,
};
use crate::tracker::{NewtonOptions, TrackStats, TrackerOptions};
use crate::{CoefficientForm, ProblemLayout};
use nalgebra::SVector;
use std::borrow::Borrow;
use std::marker::PhantomData;
use std::time::{Duration, Instant};

/// Settings of the executor, apart from the problem's pieces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PipelineOptions {
    /// Tracker settings of every path. Default: [`TrackerOptions::single_path`].
    pub tracker: TrackerOptions,
    /// After the first plausible end point ([`Verdict::Plausible`]), this many more attempts,
    /// then the best plausible one. Default `0`.
    pub extra_attempts: usize,
    /// Whether to ask the [`Fallback`] when no path validated. Default `true`.
    pub fallback: bool,
    /// Settings of [`Method::GaussNewton`] attempts, and of the polish.
    pub newton: NewtonOptions,
    /// Whether an end point that a tracker without `require_final_convergence` returns short of
    /// the accuracy `1e-7` is polished by Gauss-Newton (and fails when that does not converge)
    /// before validation. Default `false`: it is validated as it is.
    pub polish: bool,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        Self { tracker: TrackerOptions::single_path(), extra_attempts: 0, fallback: true, newton: NewtonOptions::default(), polish: false }
    }
}

/// A problem's pieces and the executor's settings. `P` is the compiled system
/// (`#[simhc_problem]`), `D` the user's data, `A` the schedule's kind ([`Schedule`]: a slice of
/// [`Attempt`]s unless [`Pipeline::with_schedule_of`] gave another).
pub struct Pipeline<
    'a,
    P,
    D: ?Sized,
    T,
    S: ?Sized,
    V,
    const NX: usize,
    const NF: usize,
    const NP: usize,
    const NC: usize,
    A: ?Sized = [Attempt],
> {
    /// Target parameters of the data.
    pub target: &'a T,
    /// Start providers, tried in this order.
    pub starts: &'a [&'a dyn StartProvider<D, NX>],
    /// The online simulator.
    pub simulator: &'a S,
    /// Other simulators, for [`Method::OtherSimulatorHc`] attempts.
    pub other_simulators: &'a [&'a dyn StartSimulator<D, NX, NF, NP>],
    /// The validation of end points.
    pub validator: &'a V,
    /// Candidates when no path validated.
    pub fallback: Option<&'a dyn Fallback<D, NX, NP>>,
    /// The attempts in order; `None`: one Simulator HC path per start provider.
    pub schedule: Option<&'a A>,
    /// Executor settings.
    pub options: PipelineOptions,
    problem: PhantomData<fn() -> P>,
}

type Outcome<T, V, D, const NX: usize, const NP: usize> = Result<
    Solved<<V as Validator<D, NX>>::Check, NX>,
    PipelineError<<T as TargetParameters<D, NP>>::Error, <V as Validator<D, NX>>::Check, NX>,
>;

impl<'a, P, D, T, S, V, const NX: usize, const NF: usize, const NP: usize, const NC: usize> Pipeline<'a, P, D, T, S, V, NX, NF, NP, NC>
where
    P: CoefficientForm<NX, NF, NP, NC> + ProblemLayout,
    D: ?Sized,
    T: TargetParameters<D, NP>,
    S: StartSimulator<D, NX, NF, NP> + ?Sized,
    V: Validator<D, NX>,
{
    /// The pipeline of these pieces with default options and no fallback.
    pub fn new(target: &'a T, starts: &'a [&'a dyn StartProvider<D, NX>], simulator: &'a S, validator: &'a V) -> Self {
        Self {
            target,
            starts,
            simulator,
            other_simulators: &[],
            validator,
            fallback: None,
            schedule: None,
            options: PipelineOptions::default(),
            problem: PhantomData,
        }
    }
}

impl<'a, P, D, T, S, V, const NX: usize, const NF: usize, const NP: usize, const NC: usize, A>
    Pipeline<'a, P, D, T, S, V, NX, NF, NP, NC, A>
where
    P: CoefficientForm<NX, NF, NP, NC> + ProblemLayout,
    D: ?Sized,
    T: TargetParameters<D, NP>,
    S: StartSimulator<D, NX, NF, NP> + ?Sized,
    V: Validator<D, NX>,
    A: Schedule + ?Sized,
{
    /// The same pipeline with other simulators, which [`Method::OtherSimulatorHc`] attempts of
    /// the schedule name by index.
    pub fn with_other_simulators(mut self, simulators: &'a [&'a dyn StartSimulator<D, NX, NF, NP>]) -> Self {
        self.other_simulators = simulators;
        self
    }

    /// The same pipeline with a fallback.
    pub fn with_fallback(mut self, fallback: &'a dyn Fallback<D, NX, NP>) -> Self {
        self.fallback = Some(fallback);
        self
    }

    /// The same pipeline with an explicit schedule of attempts (for example each start first
    /// with Gauss-Newton, then with Simulator HC). A start is computed once for attempts of its
    /// provider in a row.
    pub fn with_schedule(self, schedule: &'a [Attempt]) -> Pipeline<'a, P, D, T, S, V, NX, NF, NP, NC> {
        self.with_schedule_of(schedule)
    }

    /// [`Pipeline::with_schedule`] with a schedule of another kind, read one attempt at a time
    /// ([`Schedule`]: a caller's attempts in its own terms).
    pub fn with_schedule_of<Q: Schedule + ?Sized>(self, schedule: &'a Q) -> Pipeline<'a, P, D, T, S, V, NX, NF, NP, NC, Q> {
        let Pipeline { target, starts, simulator, other_simulators, validator, fallback, schedule: _, options, problem } = self;
        Pipeline { target, starts, simulator, other_simulators, validator, fallback, schedule: Some(schedule), options, problem }
    }

    /// The same pipeline with other options.
    pub fn with_options(mut self, options: PipelineOptions) -> Self {
        self.options = options;
        self
    }

    /// Solves `data` with the pipeline's schedule and, if nothing validated, its fallback.
    pub fn solve(&self, data: &D) -> Outcome<T, V, D, NX, NP> {
        self.run(data, self.starts, self.schedule, self.options.fallback)
    }

    /// Solves `data` in the canonical frame of `canon`: the starts, the simulator, the paths and
    /// the fallback run on the canonical data; the solution (and its start) is mapped back and
    /// checked again on the user's data, so the verdict and the check are the user's. Data
    /// without a frame is solved as given.
    pub fn solve_canonical<C>(&self, canon: &C, data: &D) -> Outcome<T, V, D, NX, NP>
    where
        C: Canonicalize<D, NX>,
    {
        let Some((frame, canonical)) = canon.canonicalize(data) else {
            return self.solve(data);
        };
        let back = |s: &mut Solved<V::Check, NX>| {
            s.x = canon.to_user(&frame, &s.x);
            s.start = canon.to_user(&frame, &s.start);
            s.check = self.validator.check(data, &s.x);
        };
        match self.solve(canonical.borrow()) {
            Ok(mut s) => {
                back(&mut s);
                if self.validator.verdict(&s.check) == Verdict::Reject {
                    // Accepted in the canonical frame, not in the user's (rounding at a
                    // threshold): flagged, never returned as a solution.
                    Err(PipelineError::NotValidated(s))
                } else {
                    Ok(s)
                }
            }
            Err(PipelineError::NotValidated(mut s)) => {
                back(&mut s);
                Err(PipelineError::NotValidated(s))
            }
            Err(e) => Err(e),
        }
    }

    /// Solves `data` with other start providers (a caller's guess, an ablation), in order.
    /// One Simulator HC path per provider; the pipeline's schedule is not used.
    pub fn solve_with(&self, data: &D, starts: &[&dyn StartProvider<D, NX>], fallback: bool) -> Outcome<T, V, D, NX, NP> {
        self.run::<[Attempt]>(data, starts, None, fallback)
    }

    /// Up to `max` end points that are accepted or plausible, in the order of the schedule,
    /// leaving out those `same` as one already found; no fallback. The hypotheses of a RANSAC
    /// sample: with a minimal sample every real root is exact, and the consensus picks.
    pub fn plausible_end_points(
        &self,
        data: &D,
        max: usize,
        same: impl Fn(&SVector<f64, NX>, &SVector<f64, NX>) -> bool,
    ) -> Result<Vec<Solved<V::Check, NX>>, T::Error> {
        let mut times = StageTimes::default();
        let p = self.target.params(data)?;
        let mut found: Vec<Solved<V::Check, NX>> = Vec::new();
        let mut attempts = 0;
        for (Attempt { provider, method }, x0) in Plan::new(self.starts, self.schedule, self.other_simulators.len(), data) {
            if found.len() >= max {
                break;
            }
            let Ok(x0) = x0 else { continue };
            attempts += 1;
            let Ok((x, stats)) = self.attempt(data, &x0, &p, method, &mut times) else { continue };
            let check = self.validator.check(data, &x);
            if self.validator.verdict(&check) != Verdict::Reject && !found.iter().any(|s| same(&s.x, &x)) {
                found.push(Solved { x, start: x0, origin: Origin::Path { provider, method }, attempts, check, stats, times });
            }
        }
        Ok(found)
    }

    /// [`Pipeline::plausible_end_points`] in the canonical frame of `canon` (as
    /// [`Pipeline::solve_canonical`]): each end point is mapped back and kept only when it is
    /// still accepted or plausible on the user's data, its check the user's. Data without a
    /// frame is searched as given.
    pub fn plausible_end_points_canonical<C>(
        &self,
        canon: &C,
        data: &D,
        max: usize,
        same: impl Fn(&SVector<f64, NX>, &SVector<f64, NX>) -> bool,
    ) -> Result<Vec<Solved<V::Check, NX>>, T::Error>
    where
        C: Canonicalize<D, NX>,
    {
        let Some((frame, canonical)) = canon.canonicalize(data) else {
            return self.plausible_end_points(data, max, same);
        };
        let mut found = self.plausible_end_points(canonical.borrow(), max, same)?;
        for s in &mut found {
            s.x = canon.to_user(&frame, &s.x);
            s.start = canon.to_user(&frame, &s.start);
            s.check = self.validator.check(data, &s.x);
        }
        found.retain(|s| self.validator.verdict(&s.check) != Verdict::Reject);
        Ok(found)
    }

    /// One attempt from `x0` with `method`; adds its time to `times`.
    fn attempt(
        &self,
        data: &D,
        x0: &SVector<f64, NX>,
        p: &SVector<f64, NP>,
        method: Method,
        times: &mut StageTimes,
    ) -> Result<(SVector<f64, NX>, TrackStats), AttemptError> {
        let o = &self.options;
        match method {
            Method::SimulatorHc => simulator_hc::<P, D, S, NX, NF, NP, NC>(data, self.simulator, x0, p, o, times),
            Method::OtherSimulatorHc(k) => match self.other_simulators.get(k) {
                Some(&other) => simulator_hc::<P, D, dyn StartSimulator<D, NX, NF, NP>, NX, NF, NP, NC>(data, other, x0, p, o, times),
                None => Err(no_other_simulator(k)),
            },
            Method::GaussNewton => {
                let t = Instant::now();
                let end = gauss_newton::<P, NX, NF, NP>(x0, p, &o.newton);
                times.tracking += t.elapsed();
                end.map_err(AttemptError::from)
            }
            Method::Start => Ok((*x0, TrackStats::default())),
        }
    }

    fn run<Q: Schedule + ?Sized>(
        &self,
        data: &D,
        starts: &[&dyn StartProvider<D, NX>],
        schedule: Option<&Q>,
        fallback: bool,
    ) -> Outcome<T, V, D, NX, NP> {
        let o = &self.options;
        let mut times = StageTimes::default();
        let t0 = Instant::now();
        let p = self.target.params(data).map_err(PipelineError::Input);
        times.target += t0.elapsed();
        let p = p?;

        let mut attempts = 0;
        let mut deadline = usize::MAX;
        let mut best: Option<Solved<V::Check, NX>> = None;
        let mut plausible: Option<Solved<V::Check, NX>> = None;
        let mut last = None;
        let mut plan = Plan::new(starts, schedule, self.other_simulators.len(), data);
        // The deadline is checked before the plan computes the next start.
        while attempts < deadline {
            let Some((Attempt { provider, method }, x0)) = plan.next() else { break };
            times.start = plan.start_time;
            // An attempt that cannot run (no start for this data, no such provider or
            // simulator) is no attempt.
            let x0 = match x0 {
                Ok(x0) => x0,
                Err(e) => {
                    last = Some(e);
                    continue;
                }
            };
            attempts += 1;
            let (x, stats) = match self.attempt(data, &x0, &p, method, &mut times) {
                Ok(r) => r,
                Err(e) => {
                    last = Some(e);
                    continue;
                }
            };
            let tv = Instant::now();
            let check = self.validator.check(data, &x);
            times.tracking += tv.elapsed();
            let solved = Solved { x, start: x0, origin: Origin::Path { provider, method }, attempts, check, stats, times };
            match self.validator.verdict(&check) {
                Verdict::Accept => return Ok(solved),
                Verdict::Plausible => {
                    if plausible.as_ref().is_none_or(|b| self.validator.better(&check, &b.check)) {
                        plausible = Some(solved);
                    }
                    deadline = deadline.min(attempts + o.extra_attempts);
                }
                Verdict::Reject => {}
            }
            if best.as_ref().is_none_or(|b| self.validator.better(&check, &b.check)) {
                best = Some(solved);
            }
        }
        if let Some(mut p) = plausible {
            p.attempts = attempts;
            p.times = times;
            return Ok(p);
        }
        if let (true, Some(fb)) = (fallback, self.fallback) {
            let tf = Instant::now();
            let candidates = fb.candidates(data, &p);
            attempts += 1;
            let mut best_fallback: Option<Solved<V::Check, NX>> = None;
            for (candidate, x) in candidates.into_iter().enumerate() {
                let check = self.validator.check(data, &x);
                let solved =
                    Solved { x, start: x, origin: Origin::Fallback { candidate }, attempts, check, stats: TrackStats::default(), times };
                if best_fallback.as_ref().is_none_or(|b| self.validator.better(&check, &b.check)) {
                    best_fallback = Some(solved);
                }
            }
            times.fallback += tf.elapsed();
            if let Some(mut b) = best_fallback {
                b.times = times;
                if self.validator.verdict(&b.check) != Verdict::Reject {
                    return Ok(b);
                }
                if best.as_ref().is_none_or(|a| self.validator.better(&b.check, &a.check)) {
                    best = Some(b);
                }
            }
        }
        match best {
            Some(mut b) => {
                b.attempts = attempts;
                b.times = times;
                Err(PipelineError::NotValidated(b))
            }
            None => Err(PipelineError::NoEndPoint { attempts, last }),
        }
    }
}

fn no_other_simulator(k: usize) -> AttemptError {
    AttemptError::Start(StartError { provider: "schedule", reason: format!("no other simulator {k}").into() })
}

/// The attempts of a schedule (by default one Simulator HC path per provider), each with its
/// start or the reason it cannot run. A provider's start is computed once for attempts of it in
/// a row; `start_time` adds up the time spent in the providers.
struct Plan<'s, D: ?Sized, const NX: usize, Q: ?Sized> {
    starts: &'s [&'s dyn StartProvider<D, NX>],
    schedule: Option<&'s Q>,
    other_simulators: usize,
    data: &'s D,
    next: usize,
    current: Option<(usize, Result<SVector<f64, NX>, StartError>)>,
    start_time: Duration,
}

impl<'s, D: ?Sized, const NX: usize, Q: Schedule + ?Sized> Plan<'s, D, NX, Q> {
    fn new(starts: &'s [&'s dyn StartProvider<D, NX>], schedule: Option<&'s Q>, other_simulators: usize, data: &'s D) -> Self {
        Self { starts, schedule, other_simulators, data, next: 0, current: None, start_time: Duration::ZERO }
    }
}

impl<D: ?Sized, const NX: usize, Q: Schedule + ?Sized> Iterator for Plan<'_, D, NX, Q> {
    type Item = (Attempt, Result<SVector<f64, NX>, AttemptError>);

    fn next(&mut self) -> Option<Self::Item> {
        let attempt = match self.schedule {
            Some(schedule) => schedule.attempt(self.next)?,
            None if self.next < self.starts.len() => Attempt { provider: self.next, method: Method::SimulatorHc },
            None => return None,
        };
        self.next += 1;
        let Attempt { provider, method } = attempt;
        let Some(start) = self.starts.get(provider) else {
            let reason = format!("no start provider {provider}");
            return Some((attempt, Err(AttemptError::Start(StartError { provider: "schedule", reason: reason.into() }))));
        };
        if let Method::OtherSimulatorHc(k) = method {
            if k >= self.other_simulators {
                return Some((attempt, Err(no_other_simulator(k))));
            }
        }
        let x0 = match &self.current {
            Some((k, x0)) if *k == provider => x0.clone(),
            _ => {
                let t = Instant::now();
                let x0 = start.start(self.data);
                self.start_time += t.elapsed();
                self.current = Some((provider, x0.clone()));
                x0
            }
        };
        Some((attempt, x0.map_err(AttemptError::from)))
    }
}
