//! The paper's benchmark rows for any problem: each row solves the same trials with one
//! configuration (a start alone, Gauss-Newton, one Simulator HC path from a learned or a random
//! start, the full pipeline), and counts what came back. Timing is wall time per solve, single
//! thread; report ratios within one run.

use super::{AttemptError, PipelineError, Solved};
use nalgebra::SVector;
use std::fmt::Write as _;
use std::time::Instant;

/// What one configuration did on the trials.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchRow {
    /// The row's name.
    pub name: String,
    /// Trials run.
    pub trials: usize,
    /// Returned as validated and correct (by the bench's criterion).
    pub solved: usize,
    /// Returned as validated but not correct: a wrong answer unflagged (must stay 0 for the
    /// rows that validate).
    pub wrong: usize,
    /// Returned flagged ([`PipelineError::NotValidated`]).
    pub flagged: usize,
    /// No end point, or an input error.
    pub failed: usize,
    /// Why the `failed` trials failed (the last attempt's error); the `flagged` ones failed
    /// validation.
    pub failures: Failures,
    /// Median solve time, microseconds.
    pub median_us: f64,
    /// Mean solve time, microseconds.
    pub mean_us: f64,
    /// Median of each error of the [`Score`] over the returned estimates (validated or not,
    /// flagged excluded), with its name.
    pub median_errors: Vec<(&'static str, f64)>,
}

/// What stopped the trials that produced no end point, by the last attempt's error.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Failures {
    /// The data was not a problem instance.
    pub input: usize,
    /// No start (or no attempt ran).
    pub start: usize,
    /// The online simulator failed, before any tracking.
    pub simulator: usize,
    /// The path failed.
    pub tracker: usize,
}

impl Failures {
    fn count<E: std::error::Error, C: std::fmt::Debug, const NX: usize, O: std::fmt::Debug>(&mut self, e: &PipelineError<E, C, NX, O>) {
        match e {
            PipelineError::Input(_) => self.input += 1,
            PipelineError::NoEndPoint { last: Some(AttemptError::Simulator(_)), .. } => self.simulator += 1,
            PipelineError::NoEndPoint { last: Some(AttemptError::Tracker(_)), .. } => self.tracker += 1,
            PipelineError::NoEndPoint { .. } => self.start += 1,
            PipelineError::NotValidated(_) => {}
        }
    }

    /// `"sim 3, track 1"`: the kinds that occurred, `"-"` for none.
    pub fn summary(&self) -> String {
        let kinds = [("input", self.input), ("start", self.start), ("sim", self.simulator), ("track", self.tracker)];
        let parts: Vec<String> = kinds.iter().filter(|(_, n)| *n > 0).map(|(k, n)| format!("{k} {n}")).collect();
        if parts.is_empty() {
            "-".to_string()
        } else {
            parts.join(", ")
        }
    }
}

/// How a bench scores an estimate against the truth: named errors (for the table) and the
/// success criterion. Any `Fn(&x, &truth) -> bool` is a score without named errors.
pub trait Score<const NX: usize> {
    /// Names of the errors, for example `["E_R deg", "E_t %"]`.
    fn names(&self) -> &[&'static str] {
        &[]
    }
    /// The errors of `x` against `truth`, in the order of [`Score::names`].
    fn errors(&self, _x: &SVector<f64, NX>, _truth: &SVector<f64, NX>) -> Vec<f64> {
        Vec::new()
    }
    /// Whether `x` counts as a correct solution.
    fn correct(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> bool;
}

impl<F, const NX: usize> Score<NX> for F
where
    F: Fn(&SVector<f64, NX>, &SVector<f64, NX>) -> bool,
{
    fn correct(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> bool {
        self(x, truth)
    }
}

impl BenchRow {
    /// `100 * solved / trials`.
    pub fn success_pct(&self) -> f64 {
        100.0 * self.solved as f64 / self.trials.max(1) as f64
    }
}

/// Where one trial's result is counted.
enum Outcome<const NX: usize> {
    /// An estimate, scored against the truth.
    Returned(SVector<f64, NX>),
    Flagged,
    Failed(Failures),
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Times `run` on every trial and counts `classify` of its result (not timed).
fn tally<D, R, const NX: usize>(
    name: &str,
    trials: &[(D, SVector<f64, NX>)],
    score: &dyn Score<NX>,
    mut run: impl FnMut(&D) -> R,
    classify: impl Fn(R) -> Outcome<NX>,
) -> BenchRow {
    let mut row = BenchRow {
        name: name.to_string(),
        trials: trials.len(),
        solved: 0,
        wrong: 0,
        flagged: 0,
        failed: 0,
        failures: Failures::default(),
        median_us: f64::NAN,
        mean_us: f64::NAN,
        median_errors: Vec::new(),
    };
    let mut micros = Vec::with_capacity(trials.len());
    let mut errors: Vec<Vec<f64>> = vec![Vec::new(); score.names().len()];
    for (data, truth) in trials {
        let t = Instant::now();
        let result = run(data);
        micros.push(t.elapsed().as_secs_f64() * 1e6);
        match classify(result) {
            Outcome::Returned(x) => {
                for (all, e) in errors.iter_mut().zip(score.errors(&x, truth)) {
                    all.push(e);
                }
                if score.correct(&x, truth) {
                    row.solved += 1;
                } else {
                    row.wrong += 1;
                }
            }
            Outcome::Flagged => row.flagged += 1,
            Outcome::Failed(why) => {
                row.failed += 1;
                row.failures.input += why.input;
                row.failures.start += why.start;
                row.failures.simulator += why.simulator;
                row.failures.tracker += why.tracker;
            }
        }
    }
    if !micros.is_empty() {
        row.mean_us = micros.iter().sum::<f64>() / micros.len() as f64;
        row.median_us = median(micros);
    }
    row.median_errors = score.names().iter().copied().zip(errors.into_iter().map(median)).collect();
    row
}

/// Runs `solve` on every trial `(data, truth)`; `score` is the bench's criterion (a closure
/// `|x, truth| -> bool`, or a [`Score`] with named errors). The solution's origin, of any kind
/// (the pipeline's or the library solver's), is not looked at.
pub fn bench_row<D, C, E, O, F, const NX: usize>(name: &str, trials: &[(D, SVector<f64, NX>)], score: &dyn Score<NX>, solve: F) -> BenchRow
where
    E: std::error::Error,
    C: std::fmt::Debug,
    O: std::fmt::Debug,
    F: FnMut(&D) -> Result<Solved<C, NX, O>, PipelineError<E, C, NX, O>>,
{
    tally(name, trials, score, solve, |result| match result {
        Ok(s) => Outcome::Returned(s.x),
        Err(PipelineError::NotValidated(_)) => Outcome::Flagged,
        Err(e) => {
            let mut why = Failures::default();
            why.count(&e);
            Outcome::Failed(why)
        }
    })
}

/// A row for an estimate that is not validated (a start alone, "Pred Initial"): `estimate`
/// returns `None` when it has nothing; a correct estimate counts as solved, any other as wrong.
pub fn bench_estimate_row<D, const NX: usize>(
    name: &str,
    trials: &[(D, SVector<f64, NX>)],
    score: &dyn Score<NX>,
    estimate: impl FnMut(&D) -> Option<SVector<f64, NX>>,
) -> BenchRow {
    tally(name, trials, score, estimate, |x| match x {
        Some(x) => Outcome::Returned(x),
        None => Outcome::Failed(Failures { start: 1, ..Failures::default() }),
    })
}

/// The rows as a text table (median errors after the counts, when the score names them; last,
/// why the failed trials failed: [`Failures::summary`]).
pub fn table(rows: &[BenchRow]) -> String {
    let names: Vec<&str> = rows.first().map(|r| r.median_errors.iter().map(|(n, _)| *n).collect()).unwrap_or_default();
    let mut out = format!("{:<36} {:>7} {:>6} {:>6} {:>6}", "method", "succ%", "wrong", "flag", "fail");
    for n in &names {
        let _ = write!(out, " {:>10}", format!("med {n}"));
    }
    let _ = writeln!(out, " {:>9} {:>9}  fail: why", "t med us", "t mean us");
    for r in rows {
        let _ = write!(out, "{:<36} {:>7.1} {:>6} {:>6} {:>6}", r.name, r.success_pct(), r.wrong, r.flagged, r.failed);
        for (_, e) in &r.median_errors {
            let _ = write!(out, " {e:>10.3e}");
        }
        let _ = writeln!(out, " {:>9.1} {:>9.1}  {}", r.median_us, r.mean_us, r.failures.summary());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Origin, StageTimes};
    use crate::tracker::TrackStats;

    #[derive(Debug, Clone, PartialEq, thiserror::Error)]
    #[error("bad")]
    struct Bad;

    #[test]
    fn outcomes_are_counted_where_they_belong() {
        let trials: Vec<(u8, SVector<f64, 1>)> = (0..4).map(|k| (k, SVector::from([1.0]))).collect();
        let solved = |x: f64| Solved {
            x: SVector::from([x]),
            start: SVector::from([0.0]),
            origin: Origin::Fallback { candidate: 0 },
            attempts: 1,
            check: (),
            stats: TrackStats::default(),
            times: StageTimes::default(),
        };
        let row = bench_row("r", &trials, &|x: &SVector<f64, 1>, t: &SVector<f64, 1>| (x[0] - t[0]).abs() < 1e-9, |k: &u8| match k {
            0 => Ok(solved(1.0)),
            1 => Ok(solved(2.0)),
            2 => Err(PipelineError::<Bad, (), 1>::NotValidated(solved(3.0))),
            _ => Err(PipelineError::Input(Bad)),
        });
        assert_eq!((row.solved, row.wrong, row.flagged, row.failed, row.trials), (1, 1, 1, 1, 4));
        assert_eq!(row.failures, Failures { input: 1, ..Failures::default() });
        assert!(row.median_us >= 0.0 && row.mean_us >= 0.0);
        assert_eq!(row.success_pct(), 25.0);
        let est = bench_estimate_row("e", &trials, &|x: &SVector<f64, 1>, t: &SVector<f64, 1>| (x[0] - t[0]).abs() < 1e-9, |k: &u8| {
            (*k < 3).then(|| SVector::from([f64::from(*k)]))
        });
        assert_eq!((est.solved, est.wrong, est.failed), (1, 2, 1));
        assert_eq!(est.failures.summary(), "start 1");
        assert!(table(&[row, est]).lines().count() == 3);
    }

    #[test]
    fn a_failure_is_counted_by_the_last_attempt_error() {
        use crate::tracker::TrackError;
        use crate::SimulatorError;
        let trials: Vec<(u8, SVector<f64, 1>)> = (0..5).map(|k| (k, SVector::from([1.0]))).collect();
        let row = bench_row("r", &trials, &|_: &SVector<f64, 1>, _: &SVector<f64, 1>| true, |k: &u8| {
            let last = match k {
                0 | 1 => Some(AttemptError::Simulator(SimulatorError::ParameterFree { equation: 6, residual: 1.0 })),
                2 => Some(AttemptError::Tracker(TrackError::MaxSteps { t: 0.5 })),
                3 => None,
                _ => return Err(PipelineError::<Bad, (), 1>::Input(Bad)),
            };
            Err(PipelineError::NoEndPoint { attempts: 1, last })
        });
        assert_eq!(row.failed, 5);
        assert_eq!(row.failures, Failures { input: 1, start: 1, simulator: 2, tracker: 1 });
        assert_eq!(row.failures.summary(), "input 1, start 1, sim 2, track 1");
        assert!(table(&[row]).contains("sim 2"));
    }
}
