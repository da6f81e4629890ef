//! Row lanes: generated code evaluates the equations of [`LANES`] rows (correspondences) at
//! once, one row per lane.
//!
//! Why: every row of a declared problem runs the *same* straight-line code on its own
//! parameters, so the rows are the natural SIMD dimension for tracking one path. When many
//! paths of one homotopy are tracked (all-roots solving), the same kernels run with one *path*
//! per lane instead ([`crate::PathLanes::row`], [`crate::tracker::batch`]). A lane value is a struct of `[f64; LANES]` arrays ([`F64x4`], and [`C64x4`]
//! with split real and imaginary parts, so a complex product is six lane-wise operations and
//! never a shuffle); the element-wise loops compile to vector instructions. Generated row
//! kernels are generic over [`Lanes`]; [`crate::Ring::Lanes`] names the lane type of a scalar,
//! and [`gather_rows`] / [`scatter_residual`] / [`scatter_jacobian`] move rows between the packed parameter vector and the
//! lanes.

use crate::Ring;
use nalgebra::{Complex, SMatrix, SVector};
use std::ops::{Add, Mul, Neg, Sub};

/// Rows evaluated together.
pub const LANES: usize = 4;

/// Arithmetic on `LANES` values of a scalar at once: what generated row kernels need.
pub trait Lanes: Copy + std::fmt::Debug + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self> {
    /// The scalar of one lane.
    type Scalar: Ring;
    /// The real constant `c` in every lane.
    fn from_real(c: f64) -> Self;
    /// Every lane multiplied by the real `c`.
    fn scale(self, c: f64) -> Self;
    /// `v` in every lane.
    fn splat(v: Self::Scalar) -> Self;
    /// Lane `i`.
    fn get(&self, i: usize) -> Self::Scalar;
    /// Sets lane `i`.
    fn set(&mut self, i: usize, v: Self::Scalar);
    /// `self * b + c`. Generated lane kernels call the fused forms (this and the three below)
    /// where a product feeds one sum; the defaults are the two operations in that order, so
    /// types without fused arithmetic compute exactly what the unfused code would.
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        self * b + c
    }
    /// `self * b - c`.
    #[inline(always)]
    fn mul_sub(self, b: Self, c: Self) -> Self {
        self * b - c
    }
    /// `c - self * b`.
    #[inline(always)]
    fn neg_mul_add(self, b: Self, c: Self) -> Self {
        c - self * b
    }
    /// `self * k + c` with a real `k`.
    #[inline(always)]
    fn scale_add(self, k: f64, c: Self) -> Self {
        self.scale(k) + c
    }
}

/// Four `f64`, one per lane (32-byte aligned).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C, align(32))]
pub struct F64x4(pub [f64; LANES]);

/// Four complex numbers, real and imaginary parts in separate [`F64x4`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct C64x4 {
    /// Real parts.
    pub re: F64x4,
    /// Imaginary parts.
    pub im: F64x4,
}

// The lane-wise operations are written out, not loops: generated kernels hold thousands of
// them, and LLVM's loop passes (rotate, full unroll, LICM) on as many four-trip loops took
// most of a problem binary's release build (`-Z llvm-time-trace`, 2026-12-05). The code after
// unrolling is the same, operation for operation.
const _: () = assert!(LANES == 4, "the lane-wise operations below are written for four lanes");

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F64x4 {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let (a, b) = (self.0, o.0);
                F64x4([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);

impl Neg for F64x4 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let a = self.0;
        F64x4([-a[0], -a[1], -a[2], -a[3]])
    }
}

impl F64x4 {
    #[inline(always)]
    fn times(self, c: f64) -> Self {
        let a = self.0;
        F64x4([a[0] * c, a[1] * c, a[2] * c, a[3] * c])
    }
}

impl Lanes for F64x4 {
    type Scalar = f64;
    #[inline(always)]
    fn from_real(c: f64) -> Self {
        F64x4([c; LANES])
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        self.times(c)
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        F64x4([v; LANES])
    }
    #[inline(always)]
    fn get(&self, i: usize) -> f64 {
        self.0[i]
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: f64) {
        self.0[i] = v;
    }
}

/// One `f64` as a single lane: the lane kernels evaluated for one row or one path, where
/// gathering four lanes would waste three (the robust estimator's one-row kernel,
/// [`crate::ParamLanes::row_equations`]). Lane index `i` is ignored.
impl Lanes for f64 {
    type Scalar = f64;
    #[inline(always)]
    fn from_real(c: f64) -> Self {
        c
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        self * c
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn get(&self, _: usize) -> f64 {
        *self
    }
    #[inline(always)]
    fn set(&mut self, _: usize, v: f64) {
        *self = v;
    }
}

impl Add for C64x4 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        C64x4 { re: self.re + o.re, im: self.im + o.im }
    }
}

impl Sub for C64x4 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        C64x4 { re: self.re - o.re, im: self.im - o.im }
    }
}

impl Mul for C64x4 {
    type Output = Self;
    /// `(a + ib)(c + id) = (ac - bd) + i(ad + bc)`, the same operations as `Complex<f64>`'s
    /// product (so the lanes agree with scalar evaluation bit for bit).
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        C64x4 { re: self.re * o.re - self.im * o.im, im: self.re * o.im + self.im * o.re }
    }
}

impl Neg for C64x4 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        C64x4 { re: -self.re, im: -self.im }
    }
}

impl Lanes for C64x4 {
    type Scalar = Complex<f64>;
    #[inline(always)]
    fn from_real(c: f64) -> Self {
        C64x4 { re: F64x4::splat(c), im: F64x4::splat(0.0) }
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        C64x4 { re: self.re.times(c), im: self.im.times(c) }
    }
    #[inline(always)]
    fn splat(v: Complex<f64>) -> Self {
        C64x4 { re: F64x4::splat(v.re), im: F64x4::splat(v.im) }
    }
    #[inline(always)]
    fn get(&self, i: usize) -> Complex<f64> {
        Complex::new(self.re.0[i], self.im.0[i])
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: Complex<f64>) {
        self.re.0[i] = v.re;
        self.im.0[i] = v.im;
    }
}

/// A row-kernel evaluation, run by [`dispatch`] with the widest vector instructions the CPU
/// has. Generated code wraps each row-kernel call's arguments in a small struct implementing
/// this, with `run` marked `#[inline(always)]` so that the kernel is compiled inside each of
/// [`dispatch`]'s instruction-set variants (once per kernel and scalar type, not per caller).
pub trait Kernel {
    /// Evaluates.
    fn run(self);
}

/// A kernel whose code depends on the instruction set it is compiled for (tile widths, fused
/// arithmetic): [`Isa::run_for`] tells it which one (a constant in each compiled variant, so the
/// choice folds away when `run` is `#[inline(always)]`).
pub trait IsaKernel {
    /// Evaluates, compiled for `isa`.
    fn run(self, isa: Isa);
}

/// A [`Kernel`] as an [`IsaKernel`] that does not look at the instruction set.
struct Same<K>(K);

impl<K: Kernel> IsaKernel for Same<K> {
    #[inline(always)]
    fn run(self, _isa: Isa) {
        self.0.run()
    }
}

/// An instruction set that kernels are compiled for, chosen at run time: the one run-time
/// dispatcher of the crate (row kernels through [`dispatch`], the batch tracker's operation,
/// the regressor's forward pass). The detection is cached by the standard library; callers
/// dispatch once per kernel call, never inside its loops.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512 (F and VL), with AVX2 and FMA.
    Avx512,
    /// AVX2 with FMA.
    Avx2,
    /// The baseline instruction set (any CPU).
    Baseline,
}

impl Isa {
    /// Every instruction set, widest first.
    pub const ALL: [Isa; 3] = [Isa::Avx512, Isa::Avx2, Isa::Baseline];

    /// The widest instruction set this CPU runs.
    pub fn detect() -> Self {
        Self::ALL.into_iter().find(|isa| isa.available()).unwrap_or(Isa::Baseline)
    }

    /// Whether this CPU runs it (checked at run time, cached by the standard library).
    #[inline]
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512vl") && Isa::Avx2.available(),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            Isa::Baseline => true,
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Runs `kernel` compiled for this instruction set, or for the baseline when the CPU does
    /// not run it.
    #[inline(always)]
    pub fn run<K: Kernel>(self, kernel: K) {
        self.run_for(Same(kernel))
    }

    /// Runs `kernel` compiled for this instruction set (told which), or for the widest narrower
    /// one the CPU runs (AVX2, else the baseline).
    #[inline(always)]
    pub fn run_for<K: IsaKernel>(self, kernel: K) {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 if self.available() => {
                // SAFETY: `run_avx512` requires AVX-512F/VL, AVX2 and FMA, just checked.
                #[allow(unsafe_code)]
                unsafe {
                    run_avx512(kernel)
                }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 | Isa::Avx2 if Isa::Avx2.available() => {
                // SAFETY: `run_avx2` requires AVX2 and FMA, just checked.
                #[allow(unsafe_code)]
                unsafe {
                    run_avx2(kernel)
                }
            }
            _ => kernel.run(Isa::Baseline),
        }
    }
}

/// Runs `kernel` with AVX2 and FMA code when the CPU has both (checked at run time, cached by
/// the standard library), else with the baseline instruction set: [`Isa::Avx2`]`.run`. (AVX-512
/// measured slower on this Xeon for the GRPS7 kernels: 0.68 us with 4 lanes and 1.0 us with 8,
/// against 0.45 us for AVX2 with 4 lanes; 8 lanes on AVX2 0.65 us.) Both variants compute the
/// same operations in the same order (Rust does not contract `a * b + c` into an FMA), so the
/// results are bit-identical.
#[inline(always)]
pub fn dispatch<K: Kernel>(kernel: K) {
    Isa::Avx2.run(kernel)
}

/// [`IsaKernel::run`] compiled for AVX2 + FMA (the inlined kernel's lane loops become 256-bit
/// vector instructions).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(unsafe_code)]
unsafe fn run_avx2<K: IsaKernel>(kernel: K) {
    kernel.run(Isa::Avx2)
}

/// [`IsaKernel::run`] compiled for AVX-512 (8-lane loops become 512-bit instructions).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[allow(unsafe_code)]
unsafe fn run_avx512<K: IsaKernel>(kernel: K) {
    kernel.run(Isa::Avx512)
}

/// The unknowns, each broadcast to every lane.
#[inline(always)]
pub fn splat_all<S: Ring, const NX: usize>(x: &SVector<S, NX>) -> [S::Lanes; NX] {
    // Plain loops: `std::array::from_fn` was left out of line here (measured).
    let mut out = [<S::Lanes as Lanes>::from_real(0.0); NX];
    for k in 0..NX {
        out[k] = <S::Lanes as Lanes>::splat(x[k]);
    }
    out
}

/// The kernel parameters of rows `first .. first + LANES` (one row per lane; lanes past
/// `rows` get zeros): the `row_len` parameters of each row, then the `K - row_len` global
/// parameters (stored after all rows in `p`) broadcast.
#[inline(always)]
pub fn gather_rows<S: Ring, const NP: usize, const K: usize>(
    p: &SVector<S, NP>,
    first: usize,
    rows: usize,
    row_len: usize,
) -> [S::Lanes; K] {
    let lanes = (rows - first).min(LANES);
    let mut out = [<S::Lanes as Lanes>::from_real(0.0); K];
    for lane in 0..lanes {
        let row = &p.as_slice()[(first + lane) * row_len..(first + lane + 1) * row_len];
        for (o, &v) in out.iter_mut().zip(row) {
            o.set(lane, v);
        }
    }
    for k in row_len..K {
        out[k] = <S::Lanes as Lanes>::splat(p[rows * row_len + (k - row_len)]);
    }
    out
}

/// Writes the residuals `f` (`E` equations per row) of rows `first ..` into `out` (row-major:
/// row `r`'s equations at `r * E ..`).
#[inline(always)]
pub fn scatter_residual<S: Ring, const NF: usize, const E: usize>(f: &[S::Lanes; E], first: usize, rows: usize, out: &mut SVector<S, NF>) {
    for lane in 0..(rows - first).min(LANES) {
        for e in 0..E {
            out[(first + lane) * E + e] = f[e].get(lane);
        }
    }
}

/// Writes the Jacobian rows `j` (`E` equations per row, row-major `E x NX`) of rows `first ..`
/// into `out`.
#[inline(always)]
pub fn scatter_jacobian<S: Ring, const NF: usize, const NX: usize, const EX: usize>(
    j: &[S::Lanes; EX],
    first: usize,
    rows: usize,
    out: &mut SMatrix<S, NF, NX>,
) {
    let e_per_row = EX / NX;
    for lane in 0..(rows - first).min(LANES) {
        for e in 0..e_per_row {
            let r = (first + lane) * e_per_row + e;
            for k in 0..NX {
                out[(r, k)] = j[e * NX + k].get(lane);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complex_lanes_match_complex_arithmetic_bit_for_bit() {
        let a = [Complex::new(1.5, -2.0), Complex::new(0.3, 0.7), Complex::new(-4.0, 1e-3), Complex::new(2.0, 0.0)];
        let b = [Complex::new(-0.5, 3.0), Complex::new(1e5, -2.5), Complex::new(0.0, 1.0), Complex::new(7.0, -7.0)];
        let mut la = C64x4::default();
        let mut lb = C64x4::default();
        for i in 0..LANES {
            la.set(i, a[i]);
            lb.set(i, b[i]);
        }
        let (p, s, d, n, k) = (la * lb, la + lb, la - lb, -la, la.scale(0.25));
        for i in 0..LANES {
            assert_eq!(p.get(i), a[i] * b[i]);
            assert_eq!(s.get(i), a[i] + b[i]);
            assert_eq!(d.get(i), a[i] - b[i]);
            assert_eq!(n.get(i), -a[i]);
            assert_eq!(k.get(i), a[i] * 0.25);
        }
        assert_eq!(C64x4::from_real(2.0).get(3), Complex::new(2.0, 0.0));
        assert_eq!(C64x4::splat(a[1]).get(2), a[1]);
    }

    #[test]
    fn rows_round_trip_through_lanes() {
        // 5 rows of 2 parameters, then one global: lanes of rows 4.. hold row 4 and zeros.
        let p = SVector::<f64, 11>::from_fn(|i, _| i as f64 + 1.0);
        let first: [F64x4; 3] = gather_rows::<f64, 11, 3>(&p, 0, 5, 2);
        assert_eq!(first[0].0, [1.0, 3.0, 5.0, 7.0]);
        assert_eq!(first[1].0, [2.0, 4.0, 6.0, 8.0]);
        assert_eq!(first[2].0, [11.0; 4]);
        let last: [F64x4; 3] = gather_rows::<f64, 11, 3>(&p, 4, 5, 2);
        assert_eq!(last[0].0, [9.0, 0.0, 0.0, 0.0]);
        let mut f = SVector::<f64, 5>::zeros();
        scatter_residual::<f64, 5, 1>(&[first[0]], 0, 5, &mut f);
        scatter_residual::<f64, 5, 1>(&[last[0]], 4, 5, &mut f);
        assert_eq!(f.as_slice(), &[1.0, 3.0, 5.0, 7.0, 9.0]);
        let mut j = SMatrix::<f64, 5, 2>::zeros();
        scatter_jacobian::<f64, 5, 2, 2>(&[first[0], first[1]], 0, 5, &mut j);
        assert_eq!((j[(3, 0)], j[(3, 1)], j[(4, 0)]), (7.0, 8.0, 0.0));
    }
}
