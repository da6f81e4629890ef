//! Levenberg-Marquardt on the object-space residual, the local-refinement baseline of the
//! paper's Table 1 ("Pred Initial + LM").
//!
//! Residuals `r_i = V_i (R p_i + t - v_i)` with `V_i = I - f_i f_i^T`; the rotation is updated on
//! the left, `R <- exp([w]x) R`, so `dr_i/dw = -V_i [R p_i]x` and `dr_i/dt = V_i`.

use super::scene::UpnpCorrespondence;
use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};

pub use crate::lm::LmOptions;

/// The refined pose and its final cost `sum |r_i|^2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmResult {
    /// Rotation.
    pub rotation: Matrix3<f64>,
    /// Translation.
    pub translation: Vector3<f64>,
    /// Final cost.
    pub cost: f64,
    /// Iterations run.
    pub iterations: usize,
}

fn cost(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &[UpnpCorrespondence]) -> f64 {
    corrs
        .iter()
        .map(|c| {
            let f = c.f.normalize();
            let d = r * c.p + t - c.v;
            (d - f * f.dot(&d)).norm_squared()
        })
        .sum()
}

/// Minimizes the object-space cost from `(r, t)`. Never fails: a non-finite step ends the
/// iteration with the last finite pose.
pub fn levenberg_marquardt(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &[UpnpCorrespondence], options: &LmOptions) -> LmResult {
    let (mut r, mut t) = (*r, *t);
    let mut current = cost(&r, &t, corrs);
    let mut lambda = options.initial_lambda;
    let mut iterations = 0;
    while iterations < options.max_iterations {
        iterations += 1;
        let mut a = Matrix6::<f64>::zeros();
        let mut g = Vector6::<f64>::zeros();
        for c in corrs {
            let f = c.f.normalize();
            let v = Matrix3::identity() - f * f.transpose();
            let rp = r * c.p;
            let res = v * (rp + t - c.v);
            let jw = -(v * rp.cross_matrix());
            let mut j = nalgebra::SMatrix::<f64, 3, 6>::zeros();
            j.fixed_view_mut::<3, 3>(0, 0).copy_from(&jw);
            j.fixed_view_mut::<3, 3>(0, 3).copy_from(&v);
            a += j.transpose() * j;
            g += j.transpose() * res;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut damped = a;
            for k in 0..6 {
                damped[(k, k)] += lambda * a[(k, k)].max(1e-12);
            }
            let Some(step) = damped.cholesky().map(|ch| -ch.solve(&g)) else {
                lambda *= 10.0;
                continue;
            };
            if !step.iter().all(|s| s.is_finite()) {
                break;
            }
            let w = Vector3::new(step[0], step[1], step[2]);
            let r_new = Rotation3::new(w).matrix() * r;
            let t_new = t + Vector3::new(step[3], step[4], step[5]);
            let c_new = cost(&r_new, &t_new, corrs);
            if c_new < current {
                r = r_new;
                t = t_new;
                current = c_new;
                lambda = (lambda * 0.1).max(1e-12);
                improved = true;
                if step.norm() < options.step_tolerance {
                    return LmResult { rotation: r, translation: t, cost: current, iterations };
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    LmResult { rotation: r, translation: t, cost: current, iterations }
}
