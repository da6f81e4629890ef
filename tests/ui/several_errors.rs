use simhc::simhc_problem;

// Every mistake below is reported in one compiler run, each at its own tokens.
#[simhc_problem(simulator = geometric)]
mod many {
    pub struct Unknowns {
        q: Quat,
        w: Matrix,
    }
    pub struct Globals {
        n: Vec3,
    }
    pub fn global_equations() -> [Scalar; 3] {
        let a = q.cross(n);
        let b = n ^ 2;
        [q.dot(q) - 1, missing * 2, n.frobnicate()]
    }
}

fn main() {}
