//! The number types of generated code and of the tracker.
//!
//! Two levels: [`Ring`] is what the emitted residual and Jacobian need (`+`, `-`, `*`, unary
//! `-`, real constants and scaling by a real constant), so that an interval type
//! ([`crate::interval::Interval`]) can evaluate them honestly; [`Scalar`] adds nalgebra's
//! `ComplexField` (norms, division, LU) for the tracker, which no interval type can provide
//! with its intended meaning.

use nalgebra::ComplexField;
use num_complex::Complex;
use std::ops::{Add, Mul, Neg, Sub};

/// The complex scalar of all-roots tracking, monodromy and the batch tracker.
pub type C = Complex<f64>;

/// A commutative ring with real constants: everything the generated residual and Jacobian
/// (`Problem::residual`, `jacobian`, `residual_jacobian`) compute with.
///
/// The method names differ from nalgebra's (`from_real`, `scale`) on purpose: a [`Scalar`] is
/// both, and one name in two supertraits would make every `S::from_real` in generic tracker
/// code ambiguous.
pub trait Ring: nalgebra::Scalar + Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self> {
    /// [`crate::lanes::LANES`] values of this ring, for row kernels.
    type Lanes: crate::lanes::Lanes<Scalar = Self>;
    /// The real constant `c` (generated code hoists each literal once per function).
    fn constant(c: f64) -> Self;
    /// `self` times the real constant `c` (for complex numbers: 2 real products, not a
    /// complex product).
    fn scale_by(self, c: f64) -> Self;
}

/// A field element that the tracker works in.
///
/// Implemented for `f64` (real single-path tracking) and `Complex<f64>` (all-roots tracking and
/// complex detours). Generated code needs the [`Ring`] operations; the tracker additionally uses
/// `ComplexField` (with `RealField = f64`) for norms and solves.
pub trait Scalar: Ring + ComplexField<RealField = f64> + Copy {
    /// Whether every component is finite (no NaN, no infinity).
    fn is_finite_value(self) -> bool;
}

impl Ring for f64 {
    type Lanes = crate::lanes::F64x4;
    #[inline(always)]
    fn constant(c: f64) -> Self {
        c
    }
    #[inline(always)]
    fn scale_by(self, c: f64) -> Self {
        self * c
    }
}

impl Scalar for f64 {
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.is_finite()
    }
}

impl Ring for Complex<f64> {
    type Lanes = crate::lanes::C64x4;
    #[inline(always)]
    fn constant(c: f64) -> Self {
        Complex::new(c, 0.0)
    }
    #[inline(always)]
    fn scale_by(self, c: f64) -> Self {
        Complex::new(self.re * c, self.im * c)
    }
}

impl Scalar for Complex<f64> {
    #[inline(always)]
    fn is_finite_value(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}
