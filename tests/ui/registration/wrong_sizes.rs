// A declared problem registered with sizes that are not its tracked instance's: `Line2` has
// 1 unknown, 2 equations and 4 parameters, not 2 equations and 3 parameters.
use nalgebra::SVector;
use simhc::pipeline::{Validator, Verdict};

#[simhc::simhc_problem]
pub mod line {
    pub struct Unknowns {
        a: Scalar,
    }
    pub struct Row {
        x: Scalar,
        y: Scalar,
    }
    pub const ROWS: [usize; 1] = [2];
    pub fn row_equations() -> Scalar {
        a * x - y
    }
}

struct Line;
struct Exact;

impl Validator<SVector<f64, 4>, 1> for Exact {
    type Check = f64;
    fn check(&self, _: &SVector<f64, 4>, _: &SVector<f64, 1>) -> f64 {
        0.0
    }
    fn verdict(&self, _: &f64) -> Verdict {
        Verdict::Accept
    }
    fn better(&self, a: &f64, b: &f64) -> bool {
        a < b
    }
}

impl simhc::solver::DeclaredProblem<1, 2, 3, { line::Line2::NC }, 4> for Line {
    type Tracked = line::Line2;
    type Data = line::Line2;
    type Validator = Exact;
    const NAME: &'static str = "line";
    fn validator(&self, _: f64) -> Exact {
        Exact
    }
}

fn main() {}
