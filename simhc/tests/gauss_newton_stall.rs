//! Gauss-Newton accepts only stationary points: a run whose updates became small at a point that
//! is no root (square) or no stationary point of `|F|²` (overdetermined) is
//! `TrackError::Stalled`, while roots and least-squares points are accepted. Starts are a fixed
//! grid (no randomness).

use nalgebra::{SMatrix, SVector, Vector1, Vector2};
use simhc::pipeline::path::gauss_newton;
use simhc::tracker::{solve_newton, NewtonOptions, TrackError};
use simhc::{Problem, ProblemInfo, Ring};

/// `x² + a`: for `a > 0` no real root, and `|F|²` has its minimum `a²` at `x = 0`, where the
/// Jacobian vanishes. Newton's iterates `(x² - a) / 2x` wander about `±sqrt(a)` with updates of
/// that size: below the `1e-7` the old rule accepted, for `a = 1e-15`.
struct ShiftedSquare;

impl ProblemInfo for ShiftedSquare {
    const NAME: &'static str = "shifted_square";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
    const PARAM_NAMES: &'static [&'static str] = &["a"];
}

impl Problem<1, 1, 1> for ShiftedSquare {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
        f[0] = x[0] * x[0] + p[0];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        j[(0, 0)] = x[0].scale_by(2.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// Two rows in one unknown, `x² + a` and `2x - b`: inconsistent for `a = -0.01, b = 0.25`, with
/// a least-squares point.
struct SquareAndLine;

impl ProblemInfo for SquareAndLine {
    const NAME: &'static str = "square_and_line";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
    const PARAM_NAMES: &'static [&'static str] = &["a", "b"];
}

impl Problem<1, 2, 2> for SquareAndLine {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 2>, f: &mut SVector<S, 2>) {
        f[0] = x[0] * x[0] + p[0];
        f[1] = x[0].scale_by(2.0) - p[1];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 2>, j: &mut SMatrix<S, 2, 1>) {
        j[(0, 0)] = x[0].scale_by(2.0);
        j[(1, 0)] = S::constant(2.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 2>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// Two rows in one unknown, `x² + a` and `2x² + b`: for `b = 2a > 0` the only stationary
/// point of `|F|²` (gradient `10 x (x² + a)`) is `x = 0`, and Gauss-Newton's update is Newton's
/// on `x² + a`, wandering about `±sqrt(a)`.
struct DoubledSquare;

impl ProblemInfo for DoubledSquare {
    const NAME: &'static str = "doubled_square";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
    const PARAM_NAMES: &'static [&'static str] = &["a", "b"];
}

impl Problem<1, 2, 2> for DoubledSquare {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 2>, f: &mut SVector<S, 2>) {
        f[0] = x[0] * x[0] + p[0];
        f[1] = (x[0] * x[0]).scale_by(2.0) + p[1];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 2>, j: &mut SMatrix<S, 2, 1>) {
        j[(0, 0)] = x[0].scale_by(2.0);
        j[(1, 0)] = x[0].scale_by(4.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 2>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// Starts `±10^e` for `e` in `[-9, -6)`.
fn starts() -> impl Iterator<Item = f64> {
    (0..300).map(|k| 10f64.powf(-9.0 + 3.0 * (k / 2) as f64 / 150.0) * if k % 2 == 0 { 1.0 } else { -1.0 })
}

#[test]
fn a_stall_near_a_real_minimum_of_the_residual_is_rejected() {
    let options = NewtonOptions::default();
    let p = Vector1::new(1e-15);
    let mut stalls = 0;
    for x0 in starts() {
        let x0 = Vector1::new(x0);
        // There is no real root: nothing may be accepted.
        let end = gauss_newton::<ShiftedSquare, 1, 1, 1>(&x0, &p, &options);
        assert!(end.is_err(), "x0 {x0:?}: accepted {end:?}");
        // The starts where the old rule (last update below 1e-7) accepted: now `Stalled`.
        if let Ok(r) = solve_newton::<ShiftedSquare, f64, 1, 1, 1>(&x0, &p, &options) {
            if !r.converged && r.accuracy <= 1e-7 {
                stalls += 1;
                assert!(matches!(end, Err(TrackError::Stalled { .. })), "x0 {x0:?}: {end:?}");
            }
        }
    }
    println!("{stalls}/300 starts stalled with updates below 1e-7");
    assert!(stalls > 0, "the grid no longer reaches a stall: the test checks nothing");
}

#[test]
fn an_overdetermined_stall_away_from_the_stationary_point_is_rejected() {
    let options = NewtonOptions::default();
    let p = Vector2::new(1e-15, 2e-15);
    let mut stalls = 0;
    for x0 in starts() {
        let x0 = Vector1::new(x0);
        let end = gauss_newton::<DoubledSquare, 1, 2, 2>(&x0, &p, &options);
        // The only stationary point is x = 0, where the Jacobian vanishes: nothing may be
        // accepted away from it.
        if let Ok((x, _)) = end {
            assert!(x[0].abs() < 1e-12, "x0 {x0:?}: accepted {x:?}");
        }
        if let Ok(r) = solve_newton::<DoubledSquare, f64, 1, 2, 2>(&x0, &p, &options) {
            if !r.converged && r.accuracy <= 1e-7 {
                stalls += 1;
                assert!(matches!(end, Err(TrackError::Stalled { .. })), "x0 {x0:?}: {end:?}");
            }
        }
    }
    println!("{stalls}/300 starts stalled with updates below 1e-7");
    assert!(stalls > 0, "the grid no longer reaches a stall: the test checks nothing");
}

#[test]
fn roots_and_least_squares_points_are_accepted() {
    let options = NewtonOptions::default();
    // Square: x² - 0.01, roots ±0.1.
    for x0 in [0.3, -0.05, 0.1000001, 7.0] {
        let (x, _) =
            gauss_newton::<ShiftedSquare, 1, 1, 1>(&Vector1::new(x0), &Vector1::new(-0.01), &options).expect("converges to a root");
        // Within Newton's tolerance (1e-12, default), not necessarily at round-off: from 7 the
        // last update of 10 is still 4e-14.
        assert!((x[0].abs() - 0.1).abs() < 1e-12, "x0 {x0}: {x:?}");
    }
    // Overdetermined and inconsistent: x² = 0.01 and 2x = 0.25 have no common root; the
    // least-squares point near x = 0.11 is stationary and accepted.
    let p = Vector2::new(-0.01, 0.25);
    let (x, _) = gauss_newton::<SquareAndLine, 1, 2, 2>(&Vector1::new(0.12), &p, &options).expect("least-squares point");
    let (f0, f1) = (x[0] * x[0] - 0.01, 2.0 * x[0] - 0.25);
    let gradient = 2.0 * x[0] * f0 + 2.0 * f1;
    // Stationary to what an error of Newton's tolerance (1e-12) explains: |JᵀJ| ~ 4, so the
    // gradient is below 4e-12 times a margin; the residual stays (inconsistent rows).
    assert!(gradient.abs() < 1e-10 && f1.abs() > 1e-4, "x {x:?}: gradient {gradient:e}, residual {f1:e}");
}
