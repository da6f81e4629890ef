//! The GRPS polynomial system, declared once and instantiated for 7 (minimal, square) and
//! 8 (overdetermined) correspondences.
//!
//! Unknowns: the unnormalized quaternion `q = [w, x, y, z]` of the relative rotation `R(q)`,
//! the translation `t` and the scale `s`. Per correspondence `(f, v) <-> (fp, vp)` (bearing and
//! ray origin in the first view, and in the second), with `alpha f + v = R (alpha' fp + s vp) + t`,
//! the depths are eliminated by the triple product (paper eq. GRPS):
//! `t . (f x R fp) - s f^T R [vp]x fp + f^T [v]x R fp = 0`; plus `q . q - 1 = 0`.

//!
//! Declared with `simulator = custom`: the online simulator of both instances is the paper's
//! geometric one ([`super::simulator`]); the generic minimum-norm one stays available as
//! `simhc::MinNormSimulator::<Grps7>`.

use simhc::simhc_problem;

#[simhc_problem(simulator = custom)]
pub mod grps {
    pub struct Unknowns {
        /// Rotation quaternion `[w, x, y, z]`.
        q: Quat,
        /// Translation (view 2 into view 1 frame).
        t: Vec3,
        /// Scale of view 2 relative to view 1.
        s: Scalar,
    }

    pub struct Row {
        /// Unit bearing in view 1.
        f: Vec3,
        /// Ray origin in view 1.
        v: Vec3,
        /// Unit bearing in view 2.
        fp: Vec3,
        /// Ray origin in view 2.
        vp: Vec3,
    }

    pub const ROWS: [usize; 2] = [7, 8];

    pub fn row_equations() -> Scalar {
        let r = rotation(q);
        let rfp = r * fp;
        t.dot(f.cross(rfp)) - s * f.dot(r * (skew(vp) * fp)) + f.dot(skew(v) * rfp)
    }

    pub fn global_equations() -> [Scalar; 1] {
        [q.dot(q) - 1]
    }
}
