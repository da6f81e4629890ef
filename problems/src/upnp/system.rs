//! The UPnP polynomial system: first-order optimality of the object-space cost on the unit
//! quaternion sphere.
//!
//! With `s(q)` the 10 quadratic monomials of `q` followed by `q . q` (the homogenized form of
//! UPnP's constant monomial `1`), the cost `E(q) = s^T M s` is a quartic form, so Euler's
//! theorem gives `q . grad E = 4 E`. The Lagrange conditions of `min E` subject to `q . q = 1`
//! are `grad E = lambda q`, and dotting with `q` gives `lambda = 4 E`: hence the five equations
//! `grad E(q) - 4 E(q) q = 0`, `q . q - 1 = 0` in four unknowns. They hold at every stationary
//! point of the cost on the sphere, with or without noise (the paper's display drops the
//! multiplier and is consistent only on noise-free data).
//!
//! `M` is a derived parameter: [`super::geometry::upnp_cost_matrix`] builds it from the
//! correspondences `(p, f, v)` with depths and translation eliminated.

use simhc::simhc_problem;

#[simhc_problem]
pub mod upnp {
    pub struct Unknowns {
        /// Rotation quaternion `[w, x, y, z]`.
        q: Quat,
    }

    pub struct Globals {
        /// The symmetric 11x11 UPnP cost matrix.
        m: Sym<11>,
    }

    pub fn global_equations() -> [Scalar; 5] {
        let n = q.dot(q);
        let s = [
            q[0] * q[0],
            q[1] * q[1],
            q[2] * q[2],
            q[3] * q[3],
            q[0] * q[1],
            q[0] * q[2],
            q[0] * q[3],
            q[1] * q[2],
            q[1] * q[3],
            q[2] * q[3],
            n,
        ];
        let e = s.dot(m * s);
        let g = grad(e, q) - 4 * e * q;
        [g[0], g[1], g[2], g[3], n - 1]
    }
}
