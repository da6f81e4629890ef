use simhc::simhc_problem;

#[simhc_problem]
mod twice {
    pub struct Unknowns {
        a: Scalar,
        a: Scalar,
    }
    pub fn global_equations() -> [Scalar; 2] {
        [a - 1, a + 1]
    }
}

fn main() {}
