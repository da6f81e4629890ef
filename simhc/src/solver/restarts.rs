//! Restarts around the learned start: when no attempt from the learned hypotheses or the other
//! starts validated, Gauss-Newton from starts near the first-ranked hypothesis
//! ([`super::DeclaredProblem::restart`]). Why near the prediction, and not random: a learned start
//! that fails is usually off by a rotation of tens of degrees, outside Gauss-Newton's basin
//! but inside the one of a start rotated towards the truth; rotating the prediction about
//! fixed axes by growing angles ([`rotated_restart`]) covers that neighbourhood first and the
//! whole rotation group last, at a few microseconds per restart against the all-roots
//! fallback's milliseconds.
//!
//! A schedule names restart `k` as [`super::StartId::Restart`]`(k)`, and the restarts'
//! attempts come last before the fallback ([`super::schedule::restart_attempts`]).

use super::hypotheses::{LearnedHypotheses, RankedStarts};
use super::instance::InstanceProblem;
use crate::layout::{FieldKind, Layout};
use crate::metrics::{quat_from_rotation, rotation_from_quat};
use crate::pipeline::{StartError, StartProvider};
use nalgebra::{Rotation3, SVector, Unit, Vector3};

/// Most restarts a problem may ask for ([`super::Plan::restarts`]): a solve holds their
/// providers in a fixed array, without allocation.
pub const MAX_RESTARTS: usize = 96;

/// Thirteen fixed unit axes spread over the sphere: the cube's 4 diagonals, 3 face normals and
/// 6 edge directions (one of each pair of opposite axes).
pub const RESTART_AXES: [[f64; 3]; 13] = [
    [0.577, 0.577, 0.577],
    [-0.577, -0.577, 0.577],
    [0.577, -0.577, -0.577],
    [-0.577, 0.577, -0.577],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.707, 0.707, 0.0],
    [0.707, -0.707, 0.0],
    [0.707, 0.0, 0.707],
    [-0.707, 0.0, 0.707],
    [0.0, 0.707, 0.707],
    [0.0, 0.707, -0.707],
];

/// The `k`-th rotation of a restart schedule over `angles_deg`: by `angles_deg[k / 13]` degrees
/// about [`RESTART_AXES`]`[k % 13]`, the sign alternating with `k` (13 is odd, so each axis
/// changes sense from one angle to the next); `None` past the end (`k >= 13 * angles_deg.len()`).
pub fn restart_rotation(k: usize, angles_deg: &[f64]) -> Option<Rotation3<f64>> {
    let angle = angles_deg.get(k / RESTART_AXES.len())?;
    let axis = Unit::new_normalize(Vector3::from(RESTART_AXES[k % RESTART_AXES.len()]));
    let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
    Some(Rotation3::from_axis_angle(&axis, sign * angle.to_radians()))
}

/// `x` with the rotation of its first quaternion unknown (`layout`'s order `[w, x, y, z]`)
/// turned by [`restart_rotation`]`(k, angles_deg)` on the left (`R' = Q R`), the other unknowns
/// kept: a [`super::DeclaredProblem::restart`] for any layout with a rotation. `None` past the end of
/// the schedule, for a layout without a quaternion unknown, or for a zero quaternion.
pub fn rotated_restart<const NX: usize>(layout: &Layout, x: &SVector<f64, NX>, k: usize, angles_deg: &[f64]) -> Option<SVector<f64, NX>> {
    let turn = restart_rotation(k, angles_deg)?;
    let field = layout.unknowns.iter().find(|f| f.kind == FieldKind::Quat)?;
    let range = field.offset..field.offset + 4;
    let q: [f64; 4] = x.as_slice().get(range.clone())?.try_into().ok()?;
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let turned = turn.into_inner() * rotation_from_quat(q.map(|v| v / norm));
    let mut out = *x;
    out.as_mut_slice()[range].copy_from_slice(&quat_from_rotation(&turned));
    Some(out)
}

/// Restart `k` around the first-ranked hypothesis of a solve, as a start provider.
pub struct RestartStart<'h, 'a, S, L, const NX: usize, const NF: usize, const NP: usize, const NC: usize> {
    /// The solve's hypotheses.
    pub set: &'h RankedStarts<'a, L, NX>,
    /// The problem.
    pub problem: &'a S,
    /// Which restart.
    pub k: usize,
}

impl<S, L, D: ?Sized, const NX: usize, const NF: usize, const NP: usize, const NC: usize> StartProvider<D, NX>
    for RestartStart<'_, '_, S, L, NX, NF, NP, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
    L: LearnedHypotheses<D, NX>,
{
    fn name(&self) -> &'static str {
        "restart around the learned start"
    }
    fn start(&self, data: &D) -> Result<SVector<f64, NX>, StartError> {
        let x = self.set.start(data, 0)?;
        self.problem.restart(data, &x, self.k).ok_or_else(|| StartError {
            provider: "restart",
            reason: format!("the problem has no restart {} around this start", self.k).into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::schedule::{restart_attempts, SolverAttempt, StartId};
    use super::*;
    use crate::layout::FieldLayout;
    use crate::metrics::rotation_error_deg;
    use crate::pipeline::Method;

    const LAYOUT: Layout = Layout {
        unknowns: &[
            FieldLayout { name: "t", kind: FieldKind::Vector(3), offset: 0 },
            FieldLayout { name: "q", kind: FieldKind::Quat, offset: 3 },
        ],
        row: &[],
        globals: &[],
        rows: 0,
        per_row: 0,
        equations_per_row: 0,
        parameter_free: &[],
        norms: &[],
    };

    #[test]
    fn a_restart_turns_the_rotation_by_its_angle_and_keeps_the_other_unknowns() {
        let q = crate::metrics::quat_from_rotation(&Rotation3::from_euler_angles(0.3, -0.2, 1.1).into_inner());
        let x = SVector::<f64, 7>::from_column_slice(&[1.0, 2.0, 3.0, q[0], q[1], q[2], q[3]]);
        let angles = [20.0, 90.0];
        for k in 0..26 {
            let y = rotated_restart(&LAYOUT, &x, k, &angles).expect("in the schedule");
            assert_eq!(&y.as_slice()[..3], &[1.0, 2.0, 3.0]);
            let (ry, rx) = (rotation_from_quat([y[3], y[4], y[5], y[6]]), rotation_from_quat(q));
            assert!((rotation_error_deg(&ry, &rx) - angles[k / 13]).abs() < 1e-9, "restart {k}");
            assert!((ry * rx.transpose() - restart_rotation(k, &angles).unwrap().into_inner()).norm() < 1e-12);
        }
        assert_eq!(rotated_restart(&LAYOUT, &x, 26, &angles), None, "past the end");
        let mut zero = x;
        zero.as_mut_slice()[3..].fill(0.0);
        assert_eq!(rotated_restart(&LAYOUT, &zero, 0, &angles), None);
        assert_eq!(rotated_restart(&Layout { unknowns: &LAYOUT.unknowns[..1], ..LAYOUT }, &x, 0, &angles), None);
    }

    #[test]
    fn the_restarts_attempts_are_gauss_newton_from_each_in_order() {
        let a: Vec<SolverAttempt> = restart_attempts(2).collect();
        assert_eq!(a, [0, 1].map(|k| SolverAttempt { start: StartId::Restart(k), method: Method::GaussNewton }));
    }
}
