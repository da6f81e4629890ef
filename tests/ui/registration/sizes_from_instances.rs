// `#[simhc::declared_problem]` takes the sizes from `type Tracked` and `type Data`, and sizes a
// `Scenes` impl of the same type alike; every mistake of a block is reported at once, at the
// user's tokens: sizes written as well (on the trait and on `fn plan`'s `Plan`), a missing
// `type Data`, a type that is no compiled instance, a `Scenes` signature written with another
// instance's parameter vector, and a `Scenes` impl of a type whose `DeclaredProblem` impl is not
// under the attribute.
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::{Validator, Verdict};
use simhc::solver::{DeclaredProblem, Scenes};

#[simhc::simhc_problem]
pub mod line {
    pub struct Unknowns {
        a: Scalar,
    }
    pub struct Row {
        x: Scalar,
        y: Scalar,
    }
    pub const ROWS: [usize; 2] = [2, 3];
    pub fn row_equations() -> Scalar {
        a * x - y
    }
}

struct Line;
struct Exact;

impl Validator<line::Params3, { line::NX }> for Exact {
    type Check = f64;
    fn check(&self, _: &line::Params3, _: &line::UnknownVector) -> f64 {
        0.0
    }
    fn verdict(&self, _: &f64) -> Verdict {
        Verdict::Accept
    }
    fn better(&self, a: &f64, b: &f64) -> bool {
        a < b
    }
}

#[simhc::declared_problem]
impl DeclaredProblem<1, 2, 4, 4, 6> for Line {
    type Tracked = line::Line2;
    type Validator = Exact;
    const NAME: &'static str = "line";
    fn plan(&self) -> simhc::solver::Plan<line::Params3, 1, 2, 4> {
        simhc::solver::Plan::default()
    }
}

struct Other;

#[simhc::declared_problem]
impl DeclaredProblem for Other {
    type Tracked = line::Line2;
    type Data = Line;
    type Validator = Exact;
    const NAME: &'static str = "other";
    fn validator(&self, _: f64) -> Exact {
        Exact
    }
}

struct Wrong;

#[simhc::declared_problem]
impl DeclaredProblem for Wrong {
    type Tracked = line::Line2;
    type Data = line::Line3;
    type Validator = Exact;
    const NAME: &'static str = "wrong";
    fn validator(&self, _: f64) -> Exact {
        Exact
    }
}

#[simhc::declared_problem]
impl Scenes for Wrong {
    const ABOUT: &'static str = "a line through the origin";
    const ERRORS: &'static [&'static str] = &[];
    fn scene(&self, _: &mut ChaCha8Rng, _: f64) -> (line::Params2, line::UnknownVector) {
        unimplemented!()
    }
    fn errors(&self, _: &line::UnknownVector, _: &line::UnknownVector) -> Vec<f64> {
        Vec::new()
    }
    fn correct(&self, _: &[f64]) -> bool {
        true
    }
}

struct HandSized;

impl DeclaredProblem<1, 2, 4, { line::Line2::NC }, 6> for HandSized {
    type Tracked = line::Line2;
    type Data = line::Line3;
    type Validator = Exact;
    const NAME: &'static str = "unsized";
    fn validator(&self, _: f64) -> Exact {
        Exact
    }
}

#[simhc::declared_problem]
impl Scenes for HandSized {
    const ABOUT: &'static str = "a line through the origin";
    const ERRORS: &'static [&'static str] = &[];
    fn scene(&self, _: &mut ChaCha8Rng, _: f64) -> (line::Params3, line::UnknownVector) {
        unimplemented!()
    }
    fn errors(&self, _: &line::UnknownVector, _: &line::UnknownVector) -> Vec<f64> {
        Vec::new()
    }
    fn correct(&self, _: &[f64]) -> bool {
        true
    }
}

fn main() {}
