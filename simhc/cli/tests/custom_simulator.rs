//! A problem declared with `#[simhc_problem(simulator = custom)]` brings its own
//! `OnlineSimulator`, and the registration uses it (`bench` and `solve` build the same
//! pipeline from `DeclaredProblem::Tracked`), not the generic one.

use nalgebra::SVector;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::solver::DeclaredProblem;
use simhc::{MinNormSimulator, OnlineSimulator, SimulatorError};
use simhc_cli::{App, Declared};
use std::sync::atomic::{AtomicUsize, Ordering};

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
    fn validator(&self, _: f64) -> Residual {
        Residual
    }
    fn errors(&self, x: &SVector<f64, 1>, truth: &SVector<f64, 1>) -> Vec<f64> {
        vec![(x[0] - truth[0]).abs()]
    }
    fn correct(&self, errors: &[f64]) -> bool {
        errors[0] < 1e-6
    }
}

#[test]
fn bench_calls_the_custom_simulator() {
    let dir = std::env::temp_dir().join(format!("simhc-custom-simulator-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let weights = dir.join("line.folded");
    let weights = weights.to_str().unwrap();
    let app = || App::new("lines", "test").register(Declared::new(Line));
    app().run_from(["lines", "train", "line", "--samples", "256", "--epochs", "2", "--seed", "3", "--out", weights]).expect("trains");

    // Rand + Sim HC tracks from a random start on every trial: the simulator runs each time.
    let before = CALLS.load(Ordering::SeqCst);
    app().run_from(["lines", "bench", "line", "--trials", "20", "--seed", "4", "--weights", weights, "--json"]).expect("benches");
    let bench = CALLS.load(Ordering::SeqCst) - before;
    assert!(bench >= 20, "the custom simulator ran {bench} times in a bench of 20 trials");

    std::fs::remove_dir_all(&dir).ok();
}
