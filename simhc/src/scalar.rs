//! The scalar type of generated code and of the tracker.

use nalgebra::ComplexField;
use num_complex::Complex;

/// The complex scalar of all-roots tracking, monodromy and the batch tracker.
pub type C = Complex<f64>;

/// A field element that generated residuals and Jacobians are evaluated in.
///
/// Implemented for `f64` (real single-path tracking) and `Complex<f64>` (all-roots tracking and
/// complex detours). Generated code needs arithmetic plus `S::from_real(c)` (from nalgebra's
/// `ComplexField`, with `RealField = f64`) to embed real constants; the tracker additionally uses
/// `ComplexField` for norms.
pub trait Scalar: ComplexField<RealField = f64> + Copy {
    /// [`crate::lanes::LANES`] values of this scalar, for row kernels.
    type Lanes: crate::lanes::Lanes<Scalar = Self>;
    /// Whether every component is finite (no NaN, no infinity).
    fn is_finite_value(self) -> bool;
}

impl Scalar for f64 {
    type Lanes = crate::lanes::F64x4;
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.is_finite()
    }
}

impl Scalar for Complex<f64> {
    type Lanes = crate::lanes::C64x4;
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}
