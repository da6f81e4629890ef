//! A problem declared with `#[simhc_problem(simulator = custom)]` brings its own
//! `OnlineSimulator`, and the registration uses it (`bench` and `solve` build the same
//! pipeline from `DeclaredProblem::Tracked`), not the generic one. A problem's lists of other
//! starts and other simulators (`DeclaredProblem::plan`) run after
//! the learned start's attempts, and its restarts (`DeclaredProblem::restart`) last, around the
//! learned start's hypothesis.

use nalgebra::SVector;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::PipelineError;
use simhc::pipeline::{Method, StartError, StartProvider, StartSimulator};
use simhc::solver::{DeclaredProblem, Plan, Scenes, Solver, SolverAttempt, SolverError, SolverOrigin, StartId, MAX_OTHERS, MAX_RESTARTS};
use simhc::{MinNormSimulator, OnlineSimulator, SimulatorError};
use simhc_cli::{App, Declared};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

mod support;
use support::Residual;

#[simhc::simhc_problem(simulator = custom)]
pub mod line {
    pub struct Unknowns {
        a: Scalar,
    }
    pub struct Row {
        x: Scalar,
        y: Scalar,
    }
    pub const ROWS: [usize; 1] = [3];
    pub fn row_equations() -> Scalar {
        a * x - y
    }
}

type Line3 = line::Line3;

/// Calls of the custom simulator.
static CALLS: AtomicUsize = AtomicUsize::new(0);

/// The user's simulator: here the minimum-norm one, counted.
impl OnlineSimulator<1, 3, 6> for Line3 {
    fn simulate(&self, x0: &SVector<f64, 1>, p: &SVector<f64, 6>) -> Result<SVector<f64, 6>, SimulatorError> {
        CALLS.fetch_add(1, Ordering::SeqCst);
        MinNormSimulator::<Line3>::new().run::<1, 3, 6>(x0, p)
    }
}

struct Line;

impl DeclaredProblem<1, 3, 6, { Line3::NC }, 6> for Line {
    type Tracked = Line3;
    type Data = Line3;
    type Validator = Residual;
    const NAME: &'static str = "line";
    fn validator(&self, _: f64) -> Residual {
        Residual
    }
}

impl Scenes<1, 3, 6, { Line3::NC }, 6> for Line {
    const ABOUT: &'static str = "a line through the origin";
    const ERRORS: &'static [&'static str] = &["slope error"];
    fn scene(&self, rng: &mut ChaCha8Rng, _: f64) -> (SVector<f64, 6>, SVector<f64, 1>) {
        let a = rng.random_range(-2.0..2.0);
        let mut p = SVector::<f64, 6>::zeros();
        for r in 0..3 {
            p[2 * r] = rng.random_range(0.5..2.0);
            p[2 * r + 1] = a * p[2 * r];
        }
        (p, SVector::from([a]))
    }
    fn errors(&self, x: &SVector<f64, 1>, truth: &SVector<f64, 1>) -> Vec<f64> {
        vec![(x[0] - truth[0]).abs()]
    }
    fn correct(&self, errors: &[f64]) -> bool {
        errors[0] < 1e-6
    }
}

/// The items every variant of the line shares with [`Line`]: its instances and validator (a
/// variant adds its name and the hook it tests). The variants are solved, never registered, so
/// they have no `Scenes`: their scenes are [`Line`]'s.
macro_rules! like_line {
    () => {
        type Tracked = Line3;
        type Data = Line3;
        type Validator = Residual;
        fn validator(&self, noise: f64) -> Residual {
            Line.validator(noise)
        }
    };
}

/// Weights for the line, trained here by the `train` command (a small network).
fn trained_weights(dir: &std::path::Path) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let weights = dir.join("line.folded");
    let app = App::new("lines", "test").register(Declared::new(Line));
    // One hypothesis, no context stage: the schedules below are written for one learned start.
    app.run_from([
        "lines",
        "train",
        "line",
        "--samples",
        "256",
        "--epochs",
        "2",
        "--seed",
        "3",
        "--hypotheses",
        "1",
        "--context-after",
        "0",
        "--out",
        weights.to_str().unwrap(),
    ])
    .expect("trains");
    weights
}

#[test]
fn bench_calls_the_custom_simulator() {
    let dir = std::env::temp_dir().join(format!("simhc-custom-simulator-{}", std::process::id()));
    let weights = trained_weights(&dir);
    let weights = weights.to_str().unwrap();
    let app = || App::new("lines", "test").register(Declared::new(Line));

    // Rand + Sim HC tracks from a random start on every trial: the simulator runs each time.
    let before = CALLS.load(Ordering::SeqCst);
    app().run_from(["lines", "bench", "line", "--trials", "20", "--seed", "4", "--weights", weights, "--json"]).expect("benches");
    let bench = CALLS.load(Ordering::SeqCst) - before;
    assert!(bench >= 20, "the custom simulator ran {bench} times in a bench of 20 trials");

    std::fs::remove_dir_all(&dir).ok();
}

/// Calls of the listed problem's other start and other simulator.
static OTHER_STARTS: AtomicUsize = AtomicUsize::new(0);
static OTHER_SIMULATIONS: AtomicUsize = AtomicUsize::new(0);

/// The slope of least squares through the origin: a closed-form start, counted.
struct LeastSquares;

impl StartProvider<SVector<f64, 6>, 1> for LeastSquares {
    fn name(&self) -> &'static str {
        "least squares"
    }
    fn start(&self, p: &SVector<f64, 6>) -> Result<SVector<f64, 1>, StartError> {
        OTHER_STARTS.fetch_add(1, Ordering::SeqCst);
        let (xy, xx) = p.as_slice().chunks_exact(2).fold((0.0, 0.0), |(xy, xx), r| (xy + r[0] * r[1], xx + r[0] * r[0]));
        Ok(SVector::from([xy / xx]))
    }
}

/// Another simulator: the minimum-norm one, counted.
struct Counted;

impl StartSimulator<SVector<f64, 6>, 1, 3, 6> for Counted {
    fn simulate(&self, _: &SVector<f64, 6>, x0: &SVector<f64, 1>, p: &SVector<f64, 6>) -> Result<SVector<f64, 6>, SimulatorError> {
        OTHER_SIMULATIONS.fetch_add(1, Ordering::SeqCst);
        MinNormSimulator::<Line3>::new().run::<1, 3, 6>(x0, p)
    }
}

/// The line with `starts` other starts and `simulators` other simulators.
struct Listed {
    starts: usize,
    simulators: usize,
}

impl DeclaredProblem<1, 3, 6, { Line3::NC }, 6> for Listed {
    like_line!();
    const NAME: &'static str = "listed";
    fn plan(&self) -> Plan<SVector<f64, 6>, 1, 3, 6> {
        Plan {
            other_starts: (0..self.starts).map(|_| Box::new(LeastSquares) as _).collect(),
            other_simulators: (0..self.simulators).map(|_| Box::new(Counted) as _).collect(),
            ..Plan::default()
        }
    }
}

#[test]
fn the_other_starts_and_simulators_run_after_the_learned_start() {
    use rand::SeedableRng;
    let dir = std::env::temp_dir().join(format!("simhc-listed-{}", std::process::id()));
    let weights = std::fs::read(trained_weights(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let solver = Solver::with_weights(Listed { starts: 1, simulators: 1 }, &weights, 0.0).expect("builds");

    // One hypothesis and one other start: Gauss-Newton from the learned start and from the
    // other start, then the learned start's paths with both
    // simulators, then the other start's.
    let a = SolverAttempt::new;
    let (learned, other) = (StartId::LEARNED, StartId::Other(0));
    let schedule = solver.schedule();
    let expect = [
        a(learned, Method::GaussNewton),
        a(other, Method::GaussNewton),
        a(learned, Method::SimulatorHc),
        a(learned, Method::OtherSimulatorHc(0)),
        a(other, Method::SimulatorHc),
        a(other, Method::OtherSimulatorHc(0)),
    ];
    assert_eq!(schedule, expect);
    let listed = [
        a(learned, Method::OtherSimulatorHc(0)),
        a(other, Method::GaussNewton),
        a(other, Method::SimulatorHc),
        a(other, Method::OtherSimulatorHc(0)),
    ];

    let seed = 11;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..10 {
        let (p, truth) = Line.scene(&mut rng, 0.0);
        // Each attempt with the listed start or simulator alone: it runs them and solves.
        for attempt in listed {
            let (starts, simulations) = (OTHER_STARTS.load(Ordering::SeqCst), OTHER_SIMULATIONS.load(Ordering::SeqCst));
            let solved = solver.run_pipeline(&p, &[attempt], false, None).expect("the listed attempt solves the line");
            assert!((solved.x[0] - truth[0]).abs() < 1e-9, "{attempt:?}: slope {} for {}", solved.x[0], truth[0]);
            assert_eq!(solved.origin, SolverOrigin::Attempt(attempt));
            let ran_start = OTHER_STARTS.load(Ordering::SeqCst) > starts;
            let ran_simulator = OTHER_SIMULATIONS.load(Ordering::SeqCst) > simulations;
            assert_eq!(ran_start, attempt.start == other, "{attempt:?}: the other start ran: {ran_start}");
            assert_eq!(
                ran_simulator,
                attempt.method == Method::OtherSimulatorHc(0),
                "{attempt:?}: the other simulator ran: {ran_simulator}"
            );
        }
    }
}

#[test]
fn more_other_starts_or_simulators_than_a_solver_holds_are_an_error() {
    let dir = std::env::temp_dir().join(format!("simhc-listed-many-{}", std::process::id()));
    let weights = std::fs::read(trained_weights(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let many = MAX_OTHERS + 1;
    for (problem, what) in
        [(Listed { starts: many, simulators: 0 }, "other starts"), (Listed { starts: 0, simulators: many }, "other simulators")]
    {
        match Solver::with_weights(problem, &weights, 0.0) {
            Err(e @ SolverError::TooMany { .. }) => {
                assert_eq!(e, SolverError::TooMany { problem: "listed", what, count: many, most: MAX_OTHERS });
                assert!(e.to_string().contains(&format!("at most {MAX_OTHERS}")), "{e}");
            }
            other => panic!("{what}: {:?}", other.map(|_| "a solver")),
        }
    }
    assert!(Solver::with_weights(Listed { starts: MAX_OTHERS, simulators: MAX_OTHERS }, &weights, 0.0).is_ok());
}

/// The starts the restart hook was called with, and for which `k`.
static RESTARTED_FROM: Mutex<Vec<(usize, f64)>> = Mutex::new(Vec::new());

/// The line with `R` restarts: restart `k` is the hypothesis plus `k + 1`, except restart 1,
/// which the problem does not have.
struct Restarted<const R: usize>;

impl<const R: usize> DeclaredProblem<1, 3, 6, { Line3::NC }, 6> for Restarted<R> {
    like_line!();
    const NAME: &'static str = "restarted";
    fn plan(&self) -> Plan<SVector<f64, 6>, 1, 3, 6> {
        Plan { restarts: R, ..Plan::default() }
    }
    fn restart(&self, _p: &SVector<f64, 6>, x: &SVector<f64, 1>, k: usize) -> Option<SVector<f64, 1>> {
        RESTARTED_FROM.lock().unwrap().push((k, x[0]));
        (k != 1).then(|| SVector::from([x[0] + (k + 1) as f64]))
    }
}

#[test]
fn restarts_start_from_the_learned_hypothesis_and_come_last() {
    use rand::SeedableRng;
    let dir = std::env::temp_dir().join(format!("simhc-restarted-{}", std::process::id()));
    let weights = std::fs::read(trained_weights(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let solver = Solver::with_weights(Restarted::<3>, &weights, 0.0).expect("builds");

    // One hypothesis, no other starts: the three restarts, Gauss-Newton each, after every other
    // attempt.
    let restarts: Vec<SolverAttempt> = (0..3).map(|k| SolverAttempt::new(StartId::Restart(k), Method::GaussNewton)).collect();
    let schedule = solver.schedule();
    assert!(schedule.len() > 3 && schedule.ends_with(&restarts), "schedule {schedule:?}");
    assert_eq!(schedule.iter().filter(|a| matches!(a.start, StartId::Restart(_))).count(), 3, "no other attempt from a restart");

    let seed = 12;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..5 {
        let (p, truth) = Line.scene(&mut rng, 0.0);
        // The learned hypothesis, as the pipeline's own start attempt returns it (validated or not).
        let hypothesis = match solver.run_pipeline(&p, &[SolverAttempt::new(StartId::LEARNED, Method::Start)], false, None) {
            Ok(s) => s.x[0],
            Err(PipelineError::NotValidated(s)) => s.x[0],
            Err(e) => panic!("the learned start: {e:?}"),
        };
        for (k, attempt) in restarts.iter().enumerate() {
            RESTARTED_FROM.lock().unwrap().clear();
            let result = solver.run_pipeline(&p, &[*attempt], false, None);
            assert_eq!(*RESTARTED_FROM.lock().unwrap(), [(k, hypothesis)], "restart {k} is built on the learned hypothesis");
            match (k, result) {
                (1, Err(PipelineError::NoEndPoint { last: Some(e), .. })) => {
                    assert!(e.to_string().contains("no restart 1"), "{e}")
                }
                (1, other) => panic!("restart 1 does not exist, yet: {other:?}"),
                (_, Ok(solved)) => {
                    assert!((solved.x[0] - truth[0]).abs() < 1e-9, "restart {k}: slope {} for {}", solved.x[0], truth[0]);
                    assert_eq!(solved.origin, SolverOrigin::Attempt(*attempt));
                }
                (_, Err(e)) => panic!("restart {k}: {e:?}"),
            }
        }
    }

    match Solver::with_weights(Restarted::<{ MAX_RESTARTS + 1 }>, &weights, 0.0) {
        Err(e) => {
            assert_eq!(e, SolverError::TooMany { problem: "restarted", what: "restarts", count: MAX_RESTARTS + 1, most: MAX_RESTARTS })
        }
        Ok(_) => panic!("a solver with more restarts than it holds"),
    }
}

/// The line whose solve settings (the plan's options) allow a path one step.
struct OneStep;

impl DeclaredProblem<1, 3, 6, { Line3::NC }, 6> for OneStep {
    like_line!();
    const NAME: &'static str = "one-step";
    fn plan(&self) -> Plan<SVector<f64, 6>, 1, 3, 6> {
        let mut plan = Plan::default();
        plan.options.tracker.max_steps = 1;
        plan
    }
}

#[test]
fn the_problems_solve_settings_reach_every_path() {
    use rand::SeedableRng;
    let dir = std::env::temp_dir().join(format!("simhc-one-step-{}", std::process::id()));
    let weights = std::fs::read(trained_weights(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let (line, one_step) = (Solver::with_weights(Line, &weights, 0.0).unwrap(), Solver::with_weights(OneStep, &weights, 0.0).unwrap());
    let path = [SolverAttempt::new(StartId::LEARNED, Method::SimulatorHc)];
    let seed = 13;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut limited = 0;
    for _ in 0..5 {
        let (p, _) = Line.scene(&mut rng, 0.0);
        // The same path with the default settings solves; with one step it stops at the limit
        // (unless the learned start is already the root).
        let solved = line.run_pipeline(&p, &path, false, None).expect("the default settings track the line");
        assert_eq!(solved.origin, SolverOrigin::Attempt(path[0]));
        match one_step.run_pipeline(&p, &path, false, None) {
            Err(PipelineError::NoEndPoint { last: Some(e), .. }) => {
                assert!(e.to_string().to_lowercase().contains("step"), "{e}");
                limited += 1;
            }
            Ok(_) => {}
            other => panic!("one step: {other:?}"),
        }
    }
    assert!(limited >= 4, "{limited} of 5 paths stopped at the one-step limit");
}

/// A start at a fixed slope, for a plan the caller gives.
struct At(f64);

impl StartProvider<SVector<f64, 6>, 1> for At {
    fn name(&self) -> &'static str {
        "fixed slope"
    }
    fn start(&self, _: &SVector<f64, 6>) -> Result<SVector<f64, 1>, StartError> {
        Ok(SVector::from([self.0]))
    }
}

/// A plan given to the solver replaces the problem's: its other start is scheduled and solves,
/// its options reach every path, and a plan that asks for more than a solve holds is an error.
#[test]
fn a_callers_plan_replaces_the_problems() {
    use rand::SeedableRng;
    let dir = std::env::temp_dir().join(format!("simhc-planned-{}", std::process::id()));
    let weights = std::fs::read(trained_weights(&dir)).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let line = Solver::with_weights(Line, &weights, 0.0).unwrap();
    assert!(line.plan().other_starts.is_empty() && !line.schedule().iter().any(|a| a.start == StartId::Other(0)));
    let mut options = simhc::pipeline::PipelineOptions::default();
    options.tracker.max_steps = 1;
    let plan = Plan { other_starts: vec![Box::new(At(0.5))], options, fallback: false, ..Plan::default() };
    let planned = line.with_plan(plan).expect("the plan fits");
    assert!(planned.schedule().iter().any(|a| a.start == StartId::Other(0)), "{:?}", planned.schedule());
    assert!(!planned.has_fallback() && !planned.plan().fallback);
    let (from_other, path) =
        (SolverAttempt::new(StartId::Other(0), Method::GaussNewton), [SolverAttempt::new(StartId::LEARNED, Method::SimulatorHc)]);
    let seed = 14;
    println!("seed {seed}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut limited = 0;
    for _ in 0..5 {
        let (p, truth) = Line.scene(&mut rng, 0.0);
        let solved = planned.run_pipeline(&p, &[from_other], false, None).expect("Gauss-Newton from the plan's start solves the line");
        assert!((solved.x[0] - truth[0]).abs() < 1e-9, "slope {} for {}", solved.x[0], truth[0]);
        assert_eq!(solved.origin, SolverOrigin::Attempt(from_other));
        if let Err(PipelineError::NoEndPoint { last: Some(e), .. }) = planned.run_pipeline(&p, &path, false, None) {
            assert!(e.to_string().to_lowercase().contains("step"), "{e}");
            limited += 1;
        }
    }
    assert!(limited >= 4, "{limited} of 5 paths stopped at the plan's one-step limit");
    let too_many = Plan { restarts: MAX_RESTARTS + 1, ..Plan::default() };
    match Solver::with_weights(Line, &weights, 0.0).unwrap().with_plan(too_many) {
        Err(e) => assert_eq!(e, SolverError::TooMany { problem: "line", what: "restarts", count: MAX_RESTARTS + 1, most: MAX_RESTARTS }),
        Ok(_) => panic!("a plan with more restarts than a solve holds"),
    }
}
