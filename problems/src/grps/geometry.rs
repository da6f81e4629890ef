//! GRPS geometry: the paper's depth-free constraint, input validation, least-squares
//! triangulation, and the paper's geometric online simulator (reprojected first-view ray), plus
//! a minimal-angle variant.
//!
//! # Constraint
//!
//! For `alpha f + v = R (alpha' f' + s v') + t` ([`super::scene`]) the depths are eliminated by
//! coplanarity of `f`, `R f'` and `c = t + s R v' - v`:
//!
//! ```text
//! t.(f x R f') - s f^T R [v']x f' + f^T [v]x R f'  =  f . (R f' x c)  =  0.
//! ```
//!
//! It is linear (homogeneous) in `f` and in `f'`, so flipping a bearing keeps it satisfied.
//!
//! # Geometric simulator ([`simulate_first_view`])
//!
//! For a predicted `(R, t, s)` and each correspondence: depths by linear least squares
//! (paper eq. "getdepths")
//!
//! ```text
//! [f, -R f'] [alpha; alpha'] = -(v - s R v' - t) = c,
//! ```
//!
//! then `f_hat = normalize(R (alpha' f' + s v') + t - v) = normalize(alpha' R f' + c)`, which lies
//! in the plane spanned by `R f'` and `c`, so `(R, t, s)` satisfies the constraint for
//! `(f_hat, v, f', v')` exactly. When `alpha < 0` the triangulated point lies behind the first
//! camera and `f_hat` points away from `f` (`sign(f_hat . f) = sign(alpha)` for least squares);
//! then the simulated ray is flipped, `f_hat <- -f_hat`, which keeps the constraint and the start
//! problem close to the target. Per-correspondence flags are reported in [`TriangulationInfo`].
//! If `f` and `R f'` are parallel (sin of the angle below `1e-10`) or the triangulated point
//! coincides with `v`, the least-squares depths are undefined; the ray is then simulated by
//! [`project_ray`] and flagged `parallel`.
//!
//! [`project_first_view`] is the minimal-angle alternative: `f_hat` is the normalized projection
//! of `f` onto the plane orthogonal to `w = R f' x c`, i.e. the closest unit vector to `f` that
//! satisfies the constraint.

use super::scene::GrpsCorrespondence;
use nalgebra::{Matrix3, Vector3};
use thiserror::Error;

/// Fewest correspondences for the minimal problem (7 unknowns: rotation 3, translation 3, scale).
pub const GRPS_MIN_CORRESPONDENCES: usize = 7;

/// A bearing whose norm is at most this counts as zero.
pub const ZERO_BEARING_NORM: f64 = 1e-12;

/// Bad or degenerate GRPS input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum GrpsError {
    /// Fewer correspondences than the minimal problem needs.
    #[error("too few correspondences: got {got}, need at least {need}")]
    TooFewCorrespondences {
        /// Number given.
        got: usize,
        /// Number needed ([`GRPS_MIN_CORRESPONDENCES`]).
        need: usize,
    },
    /// A NaN or infinite value in a correspondence (`index == usize::MAX`: in the pose).
    #[error("non-finite value in correspondence {index}")]
    NonFinite {
        /// Index of the offending correspondence (`usize::MAX`: the pose).
        index: usize,
    },
    /// A bearing (`f` or `f'`) of norm at most [`ZERO_BEARING_NORM`].
    #[error("zero-length bearing in correspondence {index}")]
    ZeroBearing {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// All correspondences come from one camera pair (all `v` equal and all `v'` equal): the
    /// scale and the translation length are unobservable.
    #[error("all correspondences from one camera pair: scale unobservable")]
    SingleCameraPair,
    /// All rays of one view share one origin (that view is a central camera): the scale is
    /// unobservable. View 1 central: `(R, v + l (t - v), l s)` solves for every `l`; view 2
    /// central: `(R, t + (s - s2) R v', s2)` solves for every `s2`.
    #[error("all rays of view {view} share one origin: scale unobservable")]
    CentralView {
        /// 1 or 2.
        view: u8,
    },
    /// The simulated ray of this correspondence is undefined: `f` is orthogonal to the plane of
    /// `R f'` and `c` (probability zero for real data).
    #[error("degenerate simulated ray in correspondence {index}")]
    Degenerate {
        /// Index of the offending correspondence.
        index: usize,
    },
}

/// Checks count (at least 7), finiteness, non-zero bearings, and that the scale is observable
/// (neither view central, i.e. not all `v` equal, not all `v'` equal; "equal" means within
/// `1e-12 (1 + max |v|)`). A single camera pair is reported as
/// [`GrpsError::SingleCameraPair`], one central view as [`GrpsError::CentralView`].
pub fn validate(corrs: &[GrpsCorrespondence]) -> Result<(), GrpsError> {
    if corrs.len() < GRPS_MIN_CORRESPONDENCES {
        return Err(GrpsError::TooFewCorrespondences { got: corrs.len(), need: GRPS_MIN_CORRESPONDENCES });
    }
    check_correspondences(corrs)?;
    let central1 = all_equal(corrs.iter().map(|c| c.v));
    let central2 = all_equal(corrs.iter().map(|c| c.vp));
    match (central1, central2) {
        (true, true) => Err(GrpsError::SingleCameraPair),
        (true, false) => Err(GrpsError::CentralView { view: 1 }),
        (false, true) => Err(GrpsError::CentralView { view: 2 }),
        (false, false) => Ok(()),
    }
}

/// The paper's constraint evaluated directly (no normalization of the bearings; it is linear in
/// `f` and in `f'`): `t.(f x R f') - s f^T R [v']x f' + f^T [v]x R f'`.
pub fn grps_residual_direct(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> f64 {
    let g = r * c.fp;
    t.dot(&c.f.cross(&g)) - s * c.f.dot(&(r * c.vp.cross(&c.fp))) + c.f.dot(&c.v.cross(&g))
}

/// Least-squares depths `(alpha, alpha')` of `[f, -R f'] [alpha; alpha'] = s R v' + t - v`, or
/// `None` when `f` and `R f'` are parallel (sin of the angle below `1e-10`). With unit bearings
/// `alpha` is the distance along `f` from `v` and `alpha'` along `R f'` from `s R v' + t`, both in
/// view-1 units; negative values mean the point is behind that camera.
pub fn triangulate_depths(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> Option<(f64, f64)> {
    let g = r * c.fp;
    let cv = offset(r, t, s, c);
    depths(&c.f, &g, &cv)
}

/// Diagnostics of one simulated ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangulationInfo {
    /// Least-squares depth along `f` (view-1 units); NaN when `parallel`.
    pub alpha: f64,
    /// Least-squares depth along `R f'` (view-1 units); NaN when `parallel`.
    pub alpha_prime: f64,
    /// `alpha < 0`: the triangulated point is behind the first camera; the simulated ray was
    /// flipped.
    pub behind_first: bool,
    /// `alpha' < 0`: the triangulated point is behind the second camera.
    pub behind_second: bool,
    /// The depths were undefined and [`project_ray`] was used instead.
    pub parallel: bool,
}

/// The output of [`simulate_first_view`].
#[derive(Debug, Clone, PartialEq)]
pub struct GrpsSimulation {
    /// The input correspondences with `f` replaced by the simulated unit ray.
    pub correspondences: Vec<GrpsCorrespondence>,
    /// Per-correspondence diagnostics, same order.
    pub info: Vec<TriangulationInfo>,
}

/// The simulated first-view ray of one correspondence under `(R, t, s)` (module docs), or `None`
/// for a degenerate ray ([`GrpsError::Degenerate`]). No input checks.
pub fn simulate_ray(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> Option<(Vector3<f64>, TriangulationInfo)> {
    let g = r * c.fp;
    let cv = offset(r, t, s, c);
    if let Some((alpha, alpha_prime)) = depths(&c.f, &g, &cv) {
        let d = g * alpha_prime + cv;
        let n = d.norm();
        if n > 1e-12 * (alpha_prime.abs() * g.norm() + cv.norm()) {
            let behind_first = alpha < 0.0;
            let f = if behind_first { -d / n } else { d / n };
            let info = TriangulationInfo { alpha, alpha_prime, behind_first, behind_second: alpha_prime < 0.0, parallel: false };
            return Some((f, info));
        }
    }
    let f = project_direction(&c.f, &g.cross(&cv))?;
    let info = TriangulationInfo { alpha: f64::NAN, alpha_prime: f64::NAN, behind_first: false, behind_second: false, parallel: true };
    Some((f, info))
}

/// The paper's geometric online simulator (module docs): every `f` replaced by the simulated
/// ray, so that `(R, t, s)` solves the returned correspondences exactly. Checks the pose and
/// correspondences for non-finite values and zero bearings (not the count or the camera
/// configuration: see [`validate`]).
pub fn simulate_first_view(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, corrs: &[GrpsCorrespondence]) -> Result<GrpsSimulation, GrpsError> {
    let mut correspondences = corrs.to_vec();
    let mut info = Vec::with_capacity(corrs.len());
    simulate_first_view_in_place(r, t, s, &mut correspondences, &mut info)?;
    Ok(GrpsSimulation { correspondences, info })
}

/// [`simulate_first_view`] overwriting `f` in place; `info` is cleared and refilled (its
/// allocation is reused). On error the slice may be partly updated.
pub fn simulate_first_view_in_place(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    s: f64,
    corrs: &mut [GrpsCorrespondence],
    info: &mut Vec<TriangulationInfo>,
) -> Result<(), GrpsError> {
    check_pose(r, t, s)?;
    check_correspondences(corrs)?;
    info.clear();
    for (index, c) in corrs.iter_mut().enumerate() {
        let (f, i) = simulate_ray(r, t, s, c).ok_or(GrpsError::Degenerate { index })?;
        c.f = f;
        info.push(i);
    }
    Ok(())
}

/// The minimal-angle simulated ray: the normalized projection of `f` onto the plane orthogonal to
/// `w = R f' x c` (`c = t + s R v' - v`), i.e. the unit vector closest to `f` that satisfies the
/// constraint; `f / |f|` itself if `w` vanishes (every `f` satisfies it then). `None` if `f` is
/// parallel to `w`. No input checks.
pub fn project_ray(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> Option<Vector3<f64>> {
    let g = r * c.fp;
    project_direction(&c.f, &g.cross(&offset(r, t, s, c)))
}

/// The minimal-angle simulator: every `f` replaced by [`project_ray`]. Same checks as
/// [`simulate_first_view`].
pub fn project_first_view(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    s: f64,
    corrs: &[GrpsCorrespondence],
) -> Result<Vec<GrpsCorrespondence>, GrpsError> {
    check_pose(r, t, s)?;
    check_correspondences(corrs)?;
    corrs
        .iter()
        .enumerate()
        .map(|(index, c)| {
            let f = project_ray(r, t, s, c).ok_or(GrpsError::Degenerate { index })?;
            Ok(GrpsCorrespondence { f, ..*c })
        })
        .collect()
}

/// `c = s R v' + t - v`.
fn offset(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> Vector3<f64> {
    r * c.vp * s + t - c.v
}

/// Least squares `[f, -g] [a; b] = c`.
fn depths(f: &Vector3<f64>, g: &Vector3<f64>, c: &Vector3<f64>) -> Option<(f64, f64)> {
    let ff = f.norm_squared();
    let gg = g.norm_squared();
    let fg = f.dot(g);
    let det = f.cross(g).norm_squared(); // = ff gg - fg², without cancellation
    if det.is_nan() || det <= 1e-20 * ff * gg {
        return None;
    }
    let fc = f.dot(c);
    let gc = g.dot(c);
    Some(((gg * fc - fg * gc) / det, (fg * fc - ff * gc) / det))
}

/// Normalized projection of `f` onto the plane orthogonal to `w`.
fn project_direction(f: &Vector3<f64>, w: &Vector3<f64>) -> Option<Vector3<f64>> {
    let fu = f.normalize();
    let wn = w.norm();
    if wn.is_nan() {
        return None;
    }
    if wn <= 1e-300 {
        return Some(fu);
    }
    let wu = w / wn;
    let p = fu - wu * fu.dot(&wu);
    let n = p.norm();
    (n > 1e-12).then(|| p / n)
}

fn check_pose(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64) -> Result<(), GrpsError> {
    if r.iter().chain(t.iter()).all(|x| x.is_finite()) && s.is_finite() {
        Ok(())
    } else {
        Err(GrpsError::NonFinite { index: usize::MAX })
    }
}

fn check_correspondences(corrs: &[GrpsCorrespondence]) -> Result<(), GrpsError> {
    for (index, c) in corrs.iter().enumerate() {
        let all = c.f.iter().chain(c.v.iter()).chain(c.fp.iter()).chain(c.vp.iter());
        if !all.copied().all(f64::is_finite) {
            return Err(GrpsError::NonFinite { index });
        }
        if c.f.norm() <= ZERO_BEARING_NORM || c.fp.norm() <= ZERO_BEARING_NORM {
            return Err(GrpsError::ZeroBearing { index });
        }
    }
    Ok(())
}

fn all_equal(mut vs: impl Iterator<Item = Vector3<f64>> + Clone) -> bool {
    let Some(first) = vs.next() else { return true };
    let scale = vs.clone().fold(first.amax(), |m, v| m.max(v.amax()));
    let tol = 1e-12 * (1.0 + scale);
    vs.all(|v| (v - first).amax() <= tol)
}
