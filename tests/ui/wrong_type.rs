use simhc::simhc_problem;

#[simhc_problem]
mod scalar_dot {
    pub struct Unknowns {
        s: Scalar,
        v: Vec3,
    }
    pub fn global_equations() -> [Scalar; 4] {
        let bad = s.dot(v);
        [bad, v[0], v[1], v[2]]
    }
}

fn main() {}
