//! UPnP geometry: the 11x11 cost matrix `M` of Kneip, Li and Seo (ECCV 2014), linear translation
//! recovery, the direct object-space cost and its gradient, and the paper's geometric online
//! simulator (reprojection under a predicted pose).
//!
//! # Cost
//!
//! With the convention `alpha_i f_i + v_i = R p_i + t` ([`super::scene`]) and the projector
//! `V_i = I - f_i f_i^T` onto the plane orthogonal to the (normalized) bearing, the object-space
//! cost with depths eliminated is
//!
//! ```text
//! E(R, t) = sum_i || V_i (R p_i + t - v_i) ||²,
//! t*(R)   = -(sum_i V_i)^-1 sum_i V_i (R p_i - v_i)       (the minimizer over t),
//! E(R)    = E(R, t*(R)).
//! ```
//!
//! For a quaternion `q = [q0, q1, q2, q3]` ([`crate::metrics`]) let
//! `s(q) = [q0², q1², q2², q3², q0q1, q0q2, q0q3, q1q2, q1q3, q2q3, 1]` ([`quat_monomials`]).
//! `R(q) p = Phi(p) s[..10]` is linear in the ten quadratic monomials ([`rotation_monomials`]),
//! so with `C_i = [Phi(p_i) | -v_i]` (3x11) the residual is `e_i = V_i (C_i - T) s` where
//! `T = (sum V_i)^-1 sum V_i C_i` and `t*(q) = -T s(q)`. Then
//!
//! ```text
//! M = sum_i (C_i - T)^T V_i (C_i - T)          (symmetric positive semi-definite),
//! s(q)^T M s(q) = E(R(q))                      for every unit q.
//! ```
//!
//! (Written as `M = [[B^T Q B, B^T c], [c^T B, d]]` in the blocks of the 10 quadratic monomials
//! and the constant.) For non-unit `q` the constant slot `1` is not homogeneous; a solver that
//! wants a quartic form substitutes `(q.q)` resp. `(q.q)²` for it.

use super::scene::UpnpCorrespondence;
use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use thiserror::Error;

/// Fewest correspondences for which UPnP is well posed (minimal case: 3).
pub const UPNP_MIN_CORRESPONDENCES: usize = 3;

/// A bearing whose norm is at most this counts as zero.
pub const ZERO_BEARING_NORM: f64 = 1e-12;

/// Bad or degenerate UPnP input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum UpnpError {
    /// Fewer correspondences than the minimal problem needs.
    #[error("too few correspondences: got {got}, need at least {need}")]
    TooFewCorrespondences {
        /// Number given.
        got: usize,
        /// Number needed ([`UPNP_MIN_CORRESPONDENCES`]).
        need: usize,
    },
    /// A NaN or infinite value in a correspondence (or in the pose, for `index == usize::MAX`).
    #[error("non-finite value in correspondence {index}")]
    NonFinite {
        /// Index of the offending correspondence (`usize::MAX`: the pose).
        index: usize,
    },
    /// A bearing of (near) zero length (norm at most [`ZERO_BEARING_NORM`]), or, in
    /// [`reproject`], a point that coincides with its ray origin under the pose.
    #[error("zero-length bearing in correspondence {index}")]
    ZeroBearing {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// `sum_i V_i` is singular: all bearings are parallel, the translation is not determined.
    #[error("degenerate configuration: all bearings parallel, translation not determined")]
    Degenerate,
    /// The world points lie on one line (or coincide): the rotation about it is not determined.
    #[error("degenerate configuration: all world points on one line, rotation not determined")]
    CollinearPoints,
}

/// Checks count, finiteness and non-zero bearings.
pub fn validate(corrs: &[UpnpCorrespondence]) -> Result<(), UpnpError> {
    if corrs.len() < UPNP_MIN_CORRESPONDENCES {
        return Err(UpnpError::TooFewCorrespondences { got: corrs.len(), need: UPNP_MIN_CORRESPONDENCES });
    }
    for (index, c) in corrs.iter().enumerate() {
        if !c.p.iter().chain(c.f.iter()).chain(c.v.iter()).all(|x| x.is_finite()) {
            return Err(UpnpError::NonFinite { index });
        }
        if c.f.norm() <= ZERO_BEARING_NORM {
            return Err(UpnpError::ZeroBearing { index });
        }
    }
    Ok(())
}

/// [`UpnpError::CollinearPoints`] when the second principal spread of the world points is at most
/// `1e-12` of the first (all on one line, or all equal).
pub fn check_spread(corrs: &[UpnpCorrespondence]) -> Result<(), UpnpError> {
    let n = corrs.len().max(1) as f64;
    let mean = corrs.iter().map(|c| c.p).sum::<Vector3<f64>>() / n;
    let cov = corrs.iter().fold(Matrix3::zeros(), |acc, c| acc + (c.p - mean) * (c.p - mean).transpose());
    let mut eig = cov.symmetric_eigenvalues();
    eig.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    if eig[0] > 0.0 && eig[1] > 1e-12 * eig[0] {
        Ok(())
    } else {
        Err(UpnpError::CollinearPoints)
    }
}

/// `s(q) = [q0², q1², q2², q3², q0q1, q0q2, q0q3, q1q2, q1q3, q2q3, 1]` (no normalization).
pub fn quat_monomials(q: [f64; 4]) -> SVector<f64, 11> {
    let [a, b, c, d] = q;
    SVector::<f64, 11>::from([a * a, b * b, c * c, d * d, a * b, a * c, a * d, b * c, b * d, c * d, 1.0])
}

/// `ds/dq` (11x4) of [`quat_monomials`]; the last row (the constant) is zero.
pub fn quat_monomials_jacobian(q: [f64; 4]) -> SMatrix<f64, 11, 4> {
    let [a, b, c, d] = q;
    #[rustfmt::skip]
    let j = SMatrix::<f64, 11, 4>::from_row_slice(&[
        2.0 * a, 0.0, 0.0, 0.0,
        0.0, 2.0 * b, 0.0, 0.0,
        0.0, 0.0, 2.0 * c, 0.0,
        0.0, 0.0, 0.0, 2.0 * d,
        b, a, 0.0, 0.0,
        c, 0.0, a, 0.0,
        d, 0.0, 0.0, a,
        0.0, c, b, 0.0,
        0.0, d, 0.0, b,
        0.0, 0.0, d, c,
        0.0, 0.0, 0.0, 0.0,
    ]);
    j
}

/// `Phi(p)` (3x10) with `R(q) p = Phi(p) s(q)[..10]` for the unnormalized `R(q)` of
/// [`rotation_from_quat`].
pub fn rotation_monomials(p: &Vector3<f64>) -> SMatrix<f64, 3, 10> {
    let (x, y, z) = (p.x, p.y, p.z);
    #[rustfmt::skip]
    let phi = SMatrix::<f64, 3, 10>::from_row_slice(&[
        x, x, -x, -x, 0.0, 2.0 * z, -2.0 * y, 2.0 * y, 2.0 * z, 0.0,
        y, -y, y, -y, -2.0 * z, 0.0, 2.0 * x, 2.0 * x, 0.0, 2.0 * z,
        z, -z, -z, z, 2.0 * y, -2.0 * x, 0.0, 0.0, 2.0 * x, 2.0 * y,
    ]);
    phi
}

/// The UPnP cost matrix together with the linear translation map (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpSystem {
    /// `M`, symmetric PSD: `s(q)^T M s(q) = E(R(q))` for unit `q`.
    pub m: SMatrix<f64, 11, 11>,
    /// `-T`: the optimal translation is `t*(q) = t_map * s(q)` for unit `q`.
    pub t_map: SMatrix<f64, 3, 11>,
}

impl UpnpSystem {
    /// `E(R(q))` via `M`; `q` is normalized first.
    pub fn cost(&self, q: [f64; 4]) -> f64 {
        let s = quat_monomials(normalized(q));
        s.dot(&(self.m * s))
    }

    /// `t*(R(q))` via the linear map; `q` is normalized first.
    pub fn translation(&self, q: [f64; 4]) -> Vector3<f64> {
        self.t_map * quat_monomials(normalized(q))
    }

    /// Cost and tangential (Riemannian) gradient on the unit sphere at `q / |q|`:
    /// `g = 2 (ds/dq)^T M s`, returned as `g - (g.q) q`.
    pub fn cost_gradient(&self, q: [f64; 4]) -> (f64, [f64; 4]) {
        let q = normalized(q);
        let s = quat_monomials(q);
        let ms = self.m * s;
        let g = quat_monomials_jacobian(q).transpose() * ms * 2.0;
        (s.dot(&ms), tangential(q, [g[0], g[1], g[2], g[3]]))
    }
}

/// Checks that the rays determine a translation (`sum_i V_i` regular, as [`upnp_system`]
/// needs) without building the cost matrix.
pub fn check_rays(corrs: &[UpnpCorrespondence]) -> Result<(), UpnpError> {
    validate(corrs)?;
    let h = corrs.iter().fold(Matrix3::<f64>::zeros(), |h, c| h + projector(&c.f));
    inverse_checked(&h).map(|_| ())
}

/// Builds `M` and the translation map from the correspondences (module docs).
pub fn upnp_system(corrs: &[UpnpCorrespondence]) -> Result<UpnpSystem, UpnpError> {
    validate(corrs)?;
    let mut h = Matrix3::<f64>::zeros();
    let mut l = SMatrix::<f64, 3, 11>::zeros();
    for c in corrs {
        let f = c.f / c.f.norm();
        let cm = c_matrix(c);
        h -= f * f.transpose();
        l += cm - f * (f.transpose() * cm);
    }
    h += Matrix3::identity() * corrs.len() as f64;
    let h_inv = inverse_checked(&h)?;
    let t = h_inv * l;
    // M = sum A_i^T A_i with A_i = V_i (C_i - T) = D - f (f^T D); upper triangle accumulated
    // row by row, then mirrored (exactly symmetric).
    let mut m = SMatrix::<f64, 11, 11>::zeros();
    for c in corrs {
        let f = c.f / c.f.norm();
        let d = c_matrix(c) - t;
        let a = d - f * (f.transpose() * d);
        for r in 0..3 {
            for k in 0..11 {
                let ark = a[(r, k)];
                for j in k..11 {
                    m[(k, j)] += ark * a[(r, j)];
                }
            }
        }
    }
    for k in 0..11 {
        for j in 0..k {
            m[(k, j)] = m[(j, k)];
        }
    }
    Ok(UpnpSystem { m, t_map: -t })
}

/// The symmetric 11x11 UPnP cost matrix `M` with `s(q)^T M s(q) = min_t E(R(q), t)` for every
/// unit quaternion `q` (module docs).
pub fn upnp_cost_matrix(corrs: &[UpnpCorrespondence]) -> Result<SMatrix<f64, 11, 11>, UpnpError> {
    upnp_system(corrs).map(|s| s.m)
}

/// The translation minimizing the object-space cost for a given rotation:
/// `t* = -(sum V_i)^-1 sum V_i (R p_i - v_i)`.
pub fn translation_from_rotation(r: &Matrix3<f64>, corrs: &[UpnpCorrespondence]) -> Result<Vector3<f64>, UpnpError> {
    validate(corrs)?;
    check_pose(r, &Vector3::zeros())?;
    checked_translation(r, corrs)
}

/// [`translation_from_rotation`] for correspondences already checked ([`validate`]): what a
/// validator calls on every end point of a solve, without checking the data again.
pub fn checked_translation(r: &Matrix3<f64>, corrs: &[UpnpCorrespondence]) -> Result<Vector3<f64>, UpnpError> {
    let mut h = Matrix3::<f64>::zeros();
    let mut b = Vector3::<f64>::zeros();
    for c in corrs {
        let v = projector(&c.f);
        h += v;
        b += v * (r * c.p - c.v);
    }
    Ok(-(inverse_checked(&h)? * b))
}

/// `E(R, t) = sum_i ||V_i (R p_i + t - v_i)||²` for a fixed translation (no minimization, no
/// validation; bearings are normalized, so a zero bearing gives NaN).
pub fn object_space_cost(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &[UpnpCorrespondence]) -> f64 {
    corrs.iter().map(|c| (projector(&c.f) * (r * c.p + t - c.v)).norm_squared()).sum()
}

/// The UPnP cost `min_t E(R(q), t)` evaluated directly from the correspondences (not via `M`);
/// `q` is normalized first (a zero or non-finite `q` is `NonFinite { index: usize::MAX }`).
pub fn upnp_cost(q: [f64; 4], corrs: &[UpnpCorrespondence]) -> Result<f64, UpnpError> {
    upnp_cost_gradient(q, corrs).map(|(e, _)| e)
}

/// The UPnP cost and its tangential gradient on the unit quaternion sphere at `q / |q|`, directly
/// from the correspondences: with `e_i = V_i (R(q) p_i + t* - v_i)`, the envelope theorem gives
/// `grad = 2 sum_i (Phi(p_i) ds/dq)^T e_i`, projected onto the tangent space of `q`.
pub fn upnp_cost_gradient(q: [f64; 4], corrs: &[UpnpCorrespondence]) -> Result<(f64, [f64; 4]), UpnpError> {
    if !q.iter().all(|x| x.is_finite()) || q.iter().all(|x| *x == 0.0) {
        return Err(UpnpError::NonFinite { index: usize::MAX });
    }
    let q = normalized(q);
    let r = rotation_from_quat(q);
    let t = translation_from_rotation(&r, corrs)?;
    let ds = quat_monomials_jacobian(q).fixed_rows::<10>(0).into_owned();
    let mut cost = 0.0;
    let mut g = SVector::<f64, 4>::zeros();
    for c in corrs {
        let e = projector(&c.f) * (r * c.p + t - c.v);
        cost += e.norm_squared();
        g += (rotation_monomials(&c.p) * ds).tr_mul(&e) * 2.0;
    }
    Ok((cost, tangential(q, [g[0], g[1], g[2], g[3]])))
}

/// The paper's online simulator: the correspondences with each bearing replaced by
/// `f_i' = normalize(R p_i + t - v_i)`, so that `(R, t)` solves them exactly.
pub fn reproject(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &[UpnpCorrespondence]) -> Result<Vec<UpnpCorrespondence>, UpnpError> {
    let mut out = corrs.to_vec();
    reproject_in_place(r, t, &mut out)?;
    Ok(out)
}

/// [`reproject`] overwriting the bearings in place (no allocation). On error the slice may be
/// partly updated.
pub fn reproject_in_place(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &mut [UpnpCorrespondence]) -> Result<(), UpnpError> {
    check_pose(r, t)?;
    for (index, c) in corrs.iter_mut().enumerate() {
        if !c.p.iter().chain(c.v.iter()).all(|x| x.is_finite()) {
            return Err(UpnpError::NonFinite { index });
        }
        let x = r * c.p + t;
        let d = x - c.v;
        let n = d.norm();
        if n <= ZERO_BEARING_NORM * (1.0 + x.norm() + c.v.norm()) {
            return Err(UpnpError::ZeroBearing { index });
        }
        c.f = d / n;
    }
    Ok(())
}

fn check_pose(r: &Matrix3<f64>, t: &Vector3<f64>) -> Result<(), UpnpError> {
    if r.iter().chain(t.iter()).all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(UpnpError::NonFinite { index: usize::MAX })
    }
}

/// `I - f f^T / |f|²`.
fn projector(f: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::identity() - f * f.transpose() / f.norm_squared()
}

/// `C = [Phi(p) | -v]` (3x11): `R(q) p - v = C s(q)` for unit `q`.
fn c_matrix(c: &UpnpCorrespondence) -> SMatrix<f64, 3, 11> {
    let mut m = SMatrix::<f64, 3, 11>::zeros();
    m.fixed_columns_mut::<10>(0).copy_from(&rotation_monomials(&c.p));
    m.set_column(10, &(-c.v));
    m
}

/// Inverse of the PSD `H = sum V_i`, or [`UpnpError::Degenerate`] when
/// `det H <= 1e-12 (tr H / 3)³` (smallest eigenvalue below ~4e-14 tr H).
fn inverse_checked(h: &Matrix3<f64>) -> Result<Matrix3<f64>, UpnpError> {
    let tr = h.trace();
    let det = h.determinant();
    if det.is_nan() || det <= 1e-12 * (tr / 3.0).powi(3) {
        return Err(UpnpError::Degenerate);
    }
    h.try_inverse().ok_or(UpnpError::Degenerate)
}

fn normalized(q: [f64; 4]) -> [f64; 4] {
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.map(|x| x / n)
}

fn tangential(q: [f64; 4], g: [f64; 4]) -> [f64; 4] {
    let gq: f64 = q.iter().zip(g.iter()).map(|(a, b)| a * b).sum();
    std::array::from_fn(|k| g[k] - gq * q[k])
}
