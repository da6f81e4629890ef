//! Pose error metrics of the paper, the quaternion convention of `Quat` unknowns (shared by the
//! built-in problems) and random perturbations of a pose ("start = ground truth perturbed by theta").
//!
//! # Quaternion convention
//!
//! A quaternion is `q = [q0, q1, q2, q3] = [w, x, y, z]` and maps to the *unnormalized*
//! rotation matrix ([`rotation_from_quat`])
//!
//! ```text
//! R(q) = [[q0²+q1²-q2²-q3², 2(q1q2-q0q3),    2(q1q3+q0q2)   ],
//!         [2(q1q2+q0q3),    q0²-q1²+q2²-q3², 2(q2q3-q0q1)   ],
//!         [2(q1q3-q0q2),    2(q2q3+q0q1),    q0²-q1²-q2²+q3²]]
//! ```
//!
//! which is the rotation of the unit quaternion `q` (same as nalgebra's `UnitQuaternion`, which
//! stores `[x, y, z, w]` internally) and `|q|² R(q/|q|)` otherwise. `q` and `-q` give the same
//! rotation; [`quat_from_rotation`] returns the representative with `q0 >= 0`.
//!
//! # Metrics (paper, section "Experiments")
//!
//! - rotation: `E_R = 2 asin(||R - R_gt||_F / (2 sqrt 2))` in degrees ([`rotation_error_deg`]),
//!   which is the angle of `R_gt^T R` for rotation matrices;
//! - translation: `E_t = ||t - t_gt|| / ||t_gt|| * 100` in percent ([`translation_error_pct`]);
//! - scale: `E_s = |s - s_gt| / s_gt * 100` in percent ([`scale_error_pct`]).

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::Rng;

/// The unnormalized rotation matrix `R(q)` of `q = [w, x, y, z]` (module docs). For a unit `q`
/// this is the rotation of `q`; every entry is a quadratic form in `q`.
#[inline]
pub fn rotation_from_quat(q: [f64; 4]) -> Matrix3<f64> {
    let [q0, q1, q2, q3] = q;
    Matrix3::new(
        q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3,
        2.0 * (q1 * q2 - q0 * q3),
        2.0 * (q1 * q3 + q0 * q2),
        2.0 * (q1 * q2 + q0 * q3),
        q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3,
        2.0 * (q2 * q3 - q0 * q1),
        2.0 * (q1 * q3 - q0 * q2),
        2.0 * (q2 * q3 + q0 * q1),
        q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3,
    )
}

/// The unit quaternion `[w, x, y, z]` of a rotation matrix, with `q0 >= 0` (if `q0 == 0` the first
/// non-zero of `q1, q2, q3` is made positive). Inverse of [`rotation_from_quat`] on unit
/// quaternions up to sign.
///
/// Uses Shepperd's method (pivot on the largest of `4 q_k²`), so it is accurate for every
/// rotation. A matrix that is only approximately orthonormal gives a nearby unit quaternion; a
/// non-finite input gives non-finite output.
#[inline]
pub fn quat_from_rotation(r: &Matrix3<f64>) -> [f64; 4] {
    let (m00, m01, m02) = (r[(0, 0)], r[(0, 1)], r[(0, 2)]);
    let (m10, m11, m12) = (r[(1, 0)], r[(1, 1)], r[(1, 2)]);
    let (m20, m21, m22) = (r[(2, 0)], r[(2, 1)], r[(2, 2)]);
    // 4 q_k² up to the common factor, from the diagonal.
    let d = [1.0 + m00 + m11 + m22, 1.0 + m00 - m11 - m22, 1.0 - m00 + m11 - m22, 1.0 - m00 - m11 + m22];
    let mut k = 0;
    for i in 1..4 {
        if d[i] > d[k] {
            k = i;
        }
    }
    let s = 2.0 * d[k].max(0.0).sqrt(); // = 4 |q_k|
    let q = if s == 0.0 || !s.is_finite() {
        // Only reachable for non-finite or wildly non-orthonormal input.
        [f64::NAN; 4]
    } else {
        match k {
            0 => [s / 4.0, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s],
            1 => [(m21 - m12) / s, s / 4.0, (m01 + m10) / s, (m02 + m20) / s],
            2 => [(m02 - m20) / s, (m01 + m10) / s, s / 4.0, (m12 + m21) / s],
            _ => [(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, s / 4.0],
        }
    };
    canonical_quat(q)
}

/// `q / |q|` with the sign chosen so that `q0 >= 0` (tie: first non-zero component positive).
/// Returns NaNs for a zero or non-finite `q`.
#[inline]
pub fn canonical_quat(q: [f64; 4]) -> [f64; 4] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if n == 0.0 || !n.is_finite() {
        return [f64::NAN; 4];
    }
    let sign = q.iter().find(|v| **v != 0.0).map_or(1.0, |v| v.signum());
    q.map(|v| sign * v / n)
}

/// Rotation error `E_R = 2 asin(||R - R_gt||_F / (2 sqrt 2))` in degrees, the asin argument
/// clamped to `[0, 1]` (so the result is in `[0, 180]`). For rotation matrices this is the angle
/// of the relative rotation `R_gt^T R`. NaN if an input is non-finite.
pub fn rotation_error_deg(r: &Matrix3<f64>, r_gt: &Matrix3<f64>) -> f64 {
    let x = (r - r_gt).norm() / (2.0 * std::f64::consts::SQRT_2);
    if x.is_nan() {
        return f64::NAN;
    }
    (2.0 * x.clamp(0.0, 1.0).asin()).to_degrees()
}

/// Relative translation error `E_t = ||t - t_gt|| / ||t_gt|| * 100` in percent. Infinite (or
/// NaN when also `t == t_gt`) for a zero ground-truth translation.
pub fn translation_error_pct(t: &Vector3<f64>, t_gt: &Vector3<f64>) -> f64 {
    (t - t_gt).norm() / t_gt.norm() * 100.0
}

/// Relative scale error `E_s = |s - s_gt| / s_gt * 100` in percent (`s_gt > 0` expected).
pub fn scale_error_pct(s: f64, s_gt: f64) -> f64 {
    (s - s_gt).abs() / s_gt * 100.0
}

/// A direction drawn uniformly on the unit sphere (Archimedes: `z` uniform in `[-1, 1]`, azimuth
/// uniform in `[0, 2 pi)`). Consumes exactly two `f64` draws.
pub fn random_unit_vector<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let rho = (1.0 - z * z).max(0.0).sqrt();
    Vector3::new(rho * phi.cos(), rho * phi.sin(), z)
}

/// A unit quaternion drawn uniformly on `S³` (uniform rotation), canonical sign `q0 >= 0`.
/// Rejection sampling in the unit 4-ball; consumes a multiple of four `f64` draws.
pub fn random_unit_quaternion<R: Rng + ?Sized>(rng: &mut R) -> [f64; 4] {
    loop {
        let q: [f64; 4] = std::array::from_fn(|_| rng.random_range(-1.0..=1.0));
        let n2: f64 = q.iter().map(|v| v * v).sum();
        if n2 > 1e-6 && n2 <= 1.0 {
            return canonical_quat(q);
        }
    }
}

/// The rotation by `angle_rad` about the unit `axis` (Rodrigues), as a matrix.
pub fn axis_angle_rotation(axis: &Unit<Vector3<f64>>, angle_rad: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(axis, angle_rad).into_inner()
}

/// `R` rotated by exactly `angle_deg` about a uniformly random axis: returns `Exp(angle * a) R`
/// (left, i.e. world-side, perturbation), so `rotation_error_deg(result, R) == angle_deg` for
/// `angle_deg` in `[0, 180]` and a rotation `R`. This is the paper's "start = ground truth
/// perturbed by theta".
pub fn random_rotation_perturbation<R: Rng + ?Sized>(r: &Matrix3<f64>, angle_deg: f64, rng: &mut R) -> Matrix3<f64> {
    let axis = Unit::new_normalize(random_unit_vector(rng));
    axis_angle_rotation(&axis, angle_deg.to_radians()) * r
}

/// `t + rel * ||t|| * u` with `u` a uniformly random unit direction, so that
/// `translation_error_pct(result, t) == rel * 100` exactly (up to rounding).
pub fn perturb_translation<R: Rng + ?Sized>(t: &Vector3<f64>, rel: f64, rng: &mut R) -> Vector3<f64> {
    t + random_unit_vector(rng) * (rel * t.norm())
}

/// `s * (1 ± rel)` with a random sign, so that `scale_error_pct(result, s) == rel * 100`.
/// Keep `rel < 1` for a positive result.
pub fn perturb_scale<R: Rng + ?Sized>(s: f64, rel: f64, rng: &mut R) -> f64 {
    if rng.random::<bool>() {
        s * (1.0 + rel)
    } else {
        s * (1.0 - rel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn quaternion_convention_matches_nalgebra() {
        let seed = 11;
        println!("seed {seed}");
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..200 {
            let q = random_unit_quaternion(&mut rng);
            let uq = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
            let r = rotation_from_quat(q);
            assert!((r - uq.to_rotation_matrix().into_inner()).norm() < 1e-14);
            let back = quat_from_rotation(&r);
            assert!(back[0] >= 0.0);
            let d: f64 = back.iter().zip(q.iter()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(d < 1e-13, "{q:?} -> {back:?}");
        }
    }

    #[test]
    fn unnormalized_rotation_scales_quadratically() {
        let q = [0.3, -1.2, 0.7, 2.0];
        let n2: f64 = q.iter().map(|v| v * v).sum();
        let r = rotation_from_quat(q);
        let ru = rotation_from_quat(canonical_quat(q));
        assert!((r - ru * n2).norm() < 1e-13);
    }

    #[test]
    fn quat_from_rotation_near_pi_and_identity() {
        for (axis, angle) in [
            (Vector3::x(), std::f64::consts::PI),
            (Vector3::new(1.0, 1.0, 0.0), std::f64::consts::PI),
            (Vector3::z(), 0.0),
            (Vector3::new(0.0, -1.0, 1.0), std::f64::consts::PI - 1e-5),
        ] {
            let r = axis_angle_rotation(&Unit::new_normalize(axis), angle);
            let q = quat_from_rotation(&r);
            assert!((rotation_from_quat(q) - r).norm() < 1e-12);
            assert!(q[0] >= 0.0);
        }
    }

    #[test]
    fn perturbations_have_exact_size() {
        let seed = 12;
        println!("seed {seed}");
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for k in 0..100 {
            let r = rotation_from_quat(random_unit_quaternion(&mut rng));
            let angle = k as f64 * 1.7;
            let rp = random_rotation_perturbation(&r, angle, &mut rng);
            assert!((rotation_error_deg(&rp, &r) - angle).abs() < 1e-6, "{angle}");
            let t = Vector3::new(0.3, -2.0, 1.0);
            let tp = perturb_translation(&t, 0.1, &mut rng);
            assert!((translation_error_pct(&tp, &t) - 10.0).abs() < 1e-9);
            assert!((scale_error_pct(perturb_scale(2.0, 0.05, &mut rng), 2.0) - 5.0).abs() < 1e-9);
        }
    }

    #[test]
    fn metric_edge_cases() {
        let i = Matrix3::identity();
        assert_eq!(rotation_error_deg(&i, &i), 0.0);
        // ||R - R_gt||_F is at most 2 sqrt 2 for rotations; beyond it is clamped.
        assert_eq!(rotation_error_deg(&(i * 5.0), &(-i)), 180.0);
        assert!(rotation_error_deg(&(i * f64::NAN), &i).is_nan());
        assert!(translation_error_pct(&Vector3::x(), &Vector3::zeros()).is_infinite());
        assert!(canonical_quat([0.0; 4])[0].is_nan());
        assert!(quat_from_rotation(&(i * f64::NAN))[0].is_nan());
    }
}
