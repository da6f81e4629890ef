//! The scalar type of generated code and of the tracker.

use nalgebra::ComplexField;
use num_complex::Complex;

/// A field element that generated residuals and Jacobians are evaluated in.
///
/// Implemented for `f64` (real single-path tracking) and `Complex<f64>` (all-roots tracking and
/// complex detours). Everything the generated code needs is arithmetic plus [`Scalar::from_f64`];
/// the tracker additionally uses nalgebra's `ComplexField` for linear solves and norms.
pub trait Scalar: ComplexField<RealField = f64> + Copy {
    /// Embeds a real constant.
    fn from_f64(v: f64) -> Self;
    /// Whether every component is finite (no NaN, no infinity).
    fn is_finite_value(self) -> bool;
}

impl Scalar for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.is_finite()
    }
}

impl Scalar for Complex<f64> {
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        Complex::new(v, 0.0)
    }
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}
