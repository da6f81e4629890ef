//! Closed intervals of `f64` with outward rounding: the arithmetic of [`crate::certify`].
//!
//! Every operation computes its endpoints in ordinary round-to-nearest `f64` arithmetic and then
//! moves the lower endpoint one ulp down and the upper one ulp up. Round-to-nearest is off by at
//! most half an ulp (of the spacing on the side the exact value lies, also for subnormal
//! results and on overflow to infinity), so the widened interval contains the exact result of
//! the operation on any points of the operands. That is one ulp wider than directed rounding
//! would give, and needs no change of the FPU's rounding mode.
//!
//! An operation whose endpoints would be NaN (`∞ - ∞`, `0 · ∞`) returns [`Interval::ENTIRE`],
//! which contains every result; a certificate rejects it as non-finite.

use crate::lanes::{Lanes, LANES};
use crate::Ring;
use std::ops::{Add, Mul, Neg, Sub};

/// The closed interval `[lo, hi]` of the real line (`lo <= hi`; endpoints may be infinite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    lo: f64,
    hi: f64,
}

/// The next `f64` above `x` (`+∞` stays, NaN stays NaN; both zeros go to the smallest positive
/// subnormal). `f64::next_up` does this from Rust 1.86; the workspace supports 1.85.
#[inline]
pub fn next_up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f64::from_bits(1);
    }
    let bits = x.to_bits();
    // Positive: the next larger magnitude; negative: the next smaller magnitude (-MIN_SUBNORMAL
    // goes to -0.0, -∞ to -MAX).
    f64::from_bits(if x > 0.0 { bits + 1 } else { bits - 1 })
}

/// The next `f64` below `x` (the mirror of [`next_up`]).
#[inline]
pub fn next_down(x: f64) -> f64 {
    -next_up(-x)
}

impl Interval {
    /// The whole real line, the result of an operation that has no finite enclosure.
    pub const ENTIRE: Self = Self { lo: f64::NEG_INFINITY, hi: f64::INFINITY };

    /// `[lo, hi]`, or `None` when `lo > hi` or either is NaN.
    pub fn new(lo: f64, hi: f64) -> Option<Self> {
        (lo <= hi).then_some(Self { lo, hi })
    }

    /// The degenerate interval `[v, v]` (exact: `v` is an `f64`). A NaN gives [`Self::ENTIRE`].
    #[inline]
    pub fn point(v: f64) -> Self {
        if v.is_nan() {
            Self::ENTIRE
        } else {
            Self { lo: v, hi: v }
        }
    }

    /// An interval containing `[c - r, c + r]` (rounded outward; `r >= 0`, a negative or NaN
    /// `r` gives [`Self::ENTIRE`]).
    pub fn around(c: f64, r: f64) -> Self {
        if r.is_nan() || r < 0.0 {
            return Self::ENTIRE;
        }
        Self::rounded_out(c - r, c + r)
    }

    /// Lower endpoint.
    #[inline]
    pub fn lo(self) -> f64 {
        self.lo
    }

    /// Upper endpoint.
    #[inline]
    pub fn hi(self) -> f64 {
        self.hi
    }

    /// Both endpoints finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }

    /// The largest absolute value in the interval (the magnitude, `max(|lo|, |hi|)`).
    #[inline]
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// Whether `v` lies in `[lo, hi]`.
    #[inline]
    pub fn contains(self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// Whether `self` lies in the interior of `outer` (`outer.lo < lo` and `hi < outer.hi`).
    #[inline]
    pub fn strictly_inside(self, outer: Self) -> bool {
        outer.lo < self.lo && self.hi < outer.hi
    }

    /// `[lo, hi]` computed in round-to-nearest, widened by one ulp each way; NaN endpoints (an
    /// undefined operation on infinite endpoints) give [`Self::ENTIRE`].
    #[inline]
    fn rounded_out(lo: f64, hi: f64) -> Self {
        if lo.is_nan() || hi.is_nan() {
            Self::ENTIRE
        } else {
            Self { lo: next_down(lo), hi: next_up(hi) }
        }
    }
}

impl Add for Interval {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self::rounded_out(self.lo + o.lo, self.hi + o.hi)
    }
}

impl Sub for Interval {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::rounded_out(self.lo - o.hi, self.hi - o.lo)
    }
}

impl Neg for Interval {
    type Output = Self;
    /// Exact: negation of an `f64` does not round.
    #[inline]
    fn neg(self) -> Self {
        Self { lo: -self.hi, hi: -self.lo }
    }
}

impl Mul for Interval {
    type Output = Self;
    /// The hull of the four endpoint products (each rounded to nearest, then the hull widened).
    #[inline]
    fn mul(self, o: Self) -> Self {
        let (a, b, c, d) = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi);
        if a.is_nan() || b.is_nan() || c.is_nan() || d.is_nan() {
            // 0 · ∞ at an endpoint: no finite bound to give.
            return Self::ENTIRE;
        }
        Self::rounded_out(a.min(b).min(c.min(d)), a.max(b).max(c.max(d)))
    }
}

impl Ring for Interval {
    type Lanes = IntervalLanes;
    #[inline]
    fn constant(c: f64) -> Self {
        Self::point(c)
    }
    #[inline]
    fn scale_by(self, c: f64) -> Self {
        self * Self::point(c)
    }
}

/// [`LANES`] intervals, so that generated row kernels (generic over [`Lanes`]) evaluate the
/// residual and Jacobian of instances with rows over intervals too. Plain lane-wise loops: the
/// certificate evaluates once per root, speed is secondary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntervalLanes(pub [Interval; LANES]);

macro_rules! interval_lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for IntervalLanes {
            type Output = Self;
            #[inline]
            fn $method(self, o: Self) -> Self {
                let mut out = self;
                for (a, b) in out.0.iter_mut().zip(o.0) {
                    *a = *a $op b;
                }
                out
            }
        }
    };
}
interval_lanewise!(Add, add, +);
interval_lanewise!(Sub, sub, -);
interval_lanewise!(Mul, mul, *);

impl Neg for IntervalLanes {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Self(self.0.map(|a| -a))
    }
}

impl Lanes for IntervalLanes {
    type Scalar = Interval;
    #[inline]
    fn from_real(c: f64) -> Self {
        Self([Interval::point(c); LANES])
    }
    #[inline]
    fn scale(self, c: f64) -> Self {
        Self(self.0.map(|a| a.scale_by(c)))
    }
    #[inline]
    fn splat(v: Interval) -> Self {
        Self([v; LANES])
    }
    #[inline]
    fn get(&self, i: usize) -> Interval {
        self.0[i]
    }
    #[inline]
    fn set(&mut self, i: usize, v: Interval) {
        self.0[i] = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulp_steps_at_the_edges() {
        assert_eq!(next_up(0.0), f64::from_bits(1));
        assert_eq!(next_up(-0.0), f64::from_bits(1));
        assert_eq!(next_down(0.0), -f64::from_bits(1));
        assert_eq!(next_up(-f64::from_bits(1)), -0.0);
        assert_eq!(next_up(f64::MAX), f64::INFINITY);
        assert_eq!(next_up(f64::INFINITY), f64::INFINITY);
        assert_eq!(next_up(f64::NEG_INFINITY), -f64::MAX);
        assert_eq!(next_down(f64::NEG_INFINITY), f64::NEG_INFINITY);
        assert_eq!(next_up(1.0), 1.0 + f64::EPSILON);
        assert_eq!(next_down(1.0), 1.0 - f64::EPSILON / 2.0);
        assert_eq!(next_up(f64::MIN_POSITIVE - f64::from_bits(1)), f64::MIN_POSITIVE);
        assert!(next_up(f64::NAN).is_nan());
    }

    #[test]
    fn undefined_endpoint_operations_give_the_whole_line() {
        let inf = Interval::new(1.0, f64::INFINITY).unwrap();
        assert_eq!(inf - inf, Interval::ENTIRE);
        assert_eq!(Interval::point(0.0) * inf, Interval::ENTIRE);
        assert_eq!(Interval::point(f64::NAN), Interval::ENTIRE);
        assert_eq!(Interval::around(1.0, -1.0), Interval::ENTIRE);
        assert!(Interval::new(2.0, 1.0).is_none());
        assert!(Interval::new(f64::NAN, 1.0).is_none());
    }

    #[test]
    fn strictly_inside_is_the_interior() {
        let x = Interval::new(-1.0, 1.0).unwrap();
        assert!(Interval::new(-0.5, 0.5).unwrap().strictly_inside(x));
        assert!(!Interval::new(-1.0, 0.5).unwrap().strictly_inside(x));
        assert!(!x.strictly_inside(x));
    }
}
