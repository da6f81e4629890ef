//! A declared problem with its own learned-start input rows ([`DeclaredProblem::input_rows`]):
//! `train` and `bench` read its parameters through the same rows, and weights trained on them
//! do not load as the layout's rows.

use nalgebra::SVector;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::InputRows;
use simhc::solver::{DeclaredProblem, Scenes};
use simhc_cli::{App, Declared};
use std::cell::Cell;
use std::rc::Rc;

mod support;
use support::Residual;

#[simhc::simhc_problem]
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

/// The slope seen by each row, `y / x`; none when a row has `x` near zero. Counts its calls.
struct Slopes(Rc<Cell<usize>>);

impl InputRows for Slopes {
    fn shape(&self) -> (usize, usize) {
        (3, 1)
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        self.0.set(self.0.get() + 1);
        if p.len() != 6 || out.len() != 3 || p.chunks_exact(2).any(|r| r[0].abs() < 1e-6) {
            return false;
        }
        p.chunks_exact(2).zip(out.iter_mut()).for_each(|(r, o)| *o = (r[1] / r[0]) as f32);
        true
    }
}

/// The line problem, with its own rows or with the layout's.
struct Line {
    rows: Option<Slopes>,
}

impl DeclaredProblem<1, 3, 6, { Line3::NC }, 6> for Line {
    type Tracked = Line3;
    type Data = Line3;
    type Validator = Residual;
    const NAME: &'static str = "line";
    fn validator(&self, _: f64) -> Residual {
        Residual
    }
    fn input_rows(&self) -> Option<&dyn InputRows> {
        self.rows.as_ref().map(|r| r as &dyn InputRows)
    }
}

impl Scenes<1, 3, 6, { Line3::NC }, 6> for Line {
    const ABOUT: &'static str = "a line through the origin";
    const ERRORS: &'static [&'static str] = &["slope error"];
    fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (SVector<f64, 6>, SVector<f64, 1>) {
        let a = rng.random_range(-2.0..2.0);
        let mut p = SVector::<f64, 6>::zeros();
        for r in 0..3 {
            let x = rng.random_range(0.5..2.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            p[2 * r] = x;
            p[2 * r + 1] = a * x + noise * rng.random_range(-1.0..1.0);
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

fn app(rows: Option<Slopes>) -> App {
    App::new("lines", "test").register(Declared::new(Line { rows }))
}

#[test]
fn train_and_bench_read_the_problems_own_rows() {
    let dir = std::env::temp_dir().join(format!("simhc-declared-rows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let weights = dir.join("line.folded");
    let weights = weights.to_str().unwrap();
    let calls = Rc::new(Cell::new(0));
    let own = || app(Some(Slopes(calls.clone())));

    own().run_from(["lines", "train", "line", "--samples", "256", "--epochs", "2", "--seed", "3", "--out", weights]).expect("trains");
    let trained = calls.get();
    assert!(trained >= 256, "the trainer read {trained} scenes through the rows");

    own().run_from(["lines", "bench", "line", "--trials", "20", "--seed", "4", "--weights", weights, "--json"]).expect("benches");
    assert!(calls.get() > trained, "bench predicted through the rows");

    // The layout's rows are 2 numbers wide, the problem's 1: the weights do not load there.
    let err = app(None).run_from(["lines", "bench", "line", "--trials", "5", "--weights", weights]).expect_err("other rows");
    assert!(err.contains("input rows' width"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
