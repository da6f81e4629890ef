use simhc::simhc_problem;

#[simhc_problem]
mod circle {
    pub struct Unknowns {
        x: Vec2,
    }
    pub struct Globals {
        r2: Scalar,
    }
    pub fn global_equations() -> [Scalar; 2] {
        [x.dot(x) - radius, x[0] - x[1]]
    }
}

fn main() {}
