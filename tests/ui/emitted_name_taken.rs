// An item of the module that takes a name the expansion emits (the size aliases) is an error
// on that item.
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
    pub type Params2 = [f64; 4];
    pub const NX: usize = 1;
}

fn main() {}
