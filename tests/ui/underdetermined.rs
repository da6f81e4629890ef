use simhc::simhc_problem;

#[simhc_problem]
mod too_few {
    pub struct Unknowns {
        q: Quat,
        t: Vec3,
    }
    pub struct Row {
        f: Vec3,
    }
    pub const ROWS: [usize; 2] = [3, 6];
    pub fn row_equations() -> Scalar {
        t.dot(rotation(q) * f)
    }
    pub fn global_equations() -> [Scalar; 1] {
        [q.dot(q) - 1]
    }
}

fn main() {}
