use simhc::simhc_problem;

#[simhc_problem]
mod not_polynomial {
    pub struct Unknowns {
        x: Scalar,
        y: Scalar,
    }
    pub fn global_equations() -> [Scalar; 2] {
        [x / y, if x { y } else { x }]
    }
}

fn main() {}
