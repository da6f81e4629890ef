//! Homotopies `H(x, t)`, `t` in `[0, 1]`, between a start system (`t = 0`, solution known) and a
//! target system (`t = 1`), built from compiled [`Problem`]s.
//!
//! The tracker only needs `H`, `J_x = dH/dx` and `dH/dt`, so a homotopy is a small trait,
//! [`Homotopy`], generic over the scalar `S` (`f64` or `Complex<f64>`) and the sizes. All
//! evaluations write into caller-provided fixed-size buffers: no heap allocation anywhere.
//!
//! Which homotopy when:
//! - [`StraightLine`]: the paper's `H = (1-t) F(x; p0) + t F(x; p1)` (optionally `gamma`-scaled
//!   start). For a *square* system it is the classic choice. For an *overdetermined* system it is
//!   inconsistent between the end points (no exact zero for `0 < t < 1`), so Gauss-Newton
//!   tracks a least-squares path; use [`ParameterHomotopy`] or [`SquaredUp`] instead.
//! - [`ParameterHomotopy`]: `H = F(x; p(t))` with `p(t) = (1-t) p0 + t p1 + t(1-t) q`. When every
//!   `p(t)` is a consistent instance (it is for square systems, and for overdetermined systems
//!   whose parameters are moved consistently) the path is a path of exact zeros. With
//!   `S = Complex<f64>` and `q = i g d` it is the *complex detour*: a real start and a real
//!   target, but the path leaves the reals in between and so passes around the folds where a
//!   real path turns back ([`ParameterHomotopy::with_complex_detour`]).
//! - [`GammaTrick`]: `H = (1-t) gamma G(x; pg) + t F(x; pf)` for two different systems, e.g. a
//!   total-degree start system `G` and the target `F`; with a random complex `gamma` all paths
//!   are regular for `t < 1` with probability one (the gamma trick), which is what all-roots
//!   tracking needs.
//! - [`SquaredUp`]: wraps any homotopy with `NF > NX` equations into a square one,
//!   `A H(x, t)` with a fixed random `NX x NF` matrix `A` of orthonormal rows. The square system
//!   has extra (spurious) solutions, so the full residual is kept for validation at the end:
//!   [`Homotopy::validation_residual`] of the wrapper reports the *full* system.
//! - [`FixedSystem`]: `H(x, t) = F(x; p)`, constant in `t`; the target for plain (Gauss-)Newton.

use crate::{CoefficientForm, ParamDerivative, Problem, Scalar};
use nalgebra::{SMatrix, SVector};
use num_complex::Complex;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::marker::PhantomData;

/// A homotopy `H(x, t): S^NX x [0, 1] -> S^NF` with its derivatives.
///
/// `t` is real even in complex arithmetic: complex paths are made by complex coefficients
/// (`gamma`, complex parameter detours), not by a complex time. Implementations must not
/// allocate and must not panic; non-finite values are allowed in the outputs (the tracker checks
/// them and reports [`crate::tracker::TrackError::NonFinite`]).
pub trait Homotopy<S: Scalar, const NX: usize, const NF: usize> {
    /// `H(x, t)` and `J_x = dH/dx (x, t)`.
    fn evaluate(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>, jx: &mut SMatrix<S, NF, NX>);

    /// `dH/dt (x, t)`.
    fn dt(&self, x: &SVector<S, NX>, t: f64, dh: &mut SVector<S, NF>);

    /// `H(x, t)` alone. The default evaluates the Jacobian too; override when cheaper.
    #[inline]
    fn residual(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>) {
        let mut jx = SMatrix::<S, NF, NX>::zeros();
        self.evaluate(x, t, h, &mut jx);
    }

    /// `J_x` and `dH/dt` at once: what a predictor stage needs. The default calls
    /// [`Homotopy::evaluate`] and [`Homotopy::dt`]; override to share subexpressions.
    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, t: f64, jx: &mut SMatrix<S, NF, NX>, dh: &mut SVector<S, NF>) {
        let mut h = SVector::<S, NF>::zeros();
        self.evaluate(x, t, &mut h, jx);
        self.dt(x, t, dh);
    }

    /// Max-norm of the residual by which an end point is judged (a solution has it near zero).
    /// Wrappers that change the system ([`SquaredUp`]) report the residual of the original one.
    #[inline]
    fn validation_residual(&self, x: &SVector<S, NX>, t: f64) -> f64 {
        let mut h = SVector::<S, NF>::zeros();
        self.residual(x, t, &mut h);
        max_modulus(&h)
    }
}

/// Max-norm `max_i |v_i|` (NaN if any entry is NaN).
#[inline]
pub fn max_modulus<S: Scalar, const N: usize>(v: &SVector<S, N>) -> f64 {
    let mut m = 0.0f64;
    for e in v.iter() {
        let a = e.modulus_squared();
        if a.is_nan() {
            return f64::NAN;
        }
        m = m.max(a);
    }
    m.sqrt()
}

/// `out = a * u + b * v`, element-wise over fixed-size matrices (no temporaries).
#[inline]
fn lincomb<S: Scalar, const R: usize, const C: usize>(out: &mut SMatrix<S, R, C>, a: S, u: &SMatrix<S, R, C>, b: S, v: &SMatrix<S, R, C>) {
    for ((o, &ui), &vi) in out.iter_mut().zip(u.iter()).zip(v.iter()) {
        *o = a * ui + b * vi;
    }
}

/// A real vector embedded in complex arithmetic (real start points for complex tracking).
#[inline]
pub fn to_complex<const N: usize>(v: &SVector<f64, N>) -> SVector<Complex<f64>, N> {
    v.map(|e| Complex::new(e, 0.0))
}

/// The real part of `v` if every imaginary part is at most `tol * max(1, |v_i|)`, else `None`:
/// decides whether a complex end point is a real solution.
#[inline]
pub fn real_if_close<const N: usize>(v: &SVector<Complex<f64>, N>, tol: f64) -> Option<SVector<f64, N>> {
    if v.iter().all(|z| z.im.abs() <= tol * z.norm().max(1.0)) {
        Some(v.map(|z| z.re))
    } else {
        None
    }
}

/// A seeded random complex number of modulus one, the usual `gamma` of the gamma trick.
pub fn random_gamma(seed: u64) -> Complex<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let angle = rng.random::<f64>() * std::f64::consts::TAU;
    Complex::from_polar(1.0, angle)
}

/// Standard normal samples by Box-Muller (keeps the dependency list to `rand` + `rand_chacha`).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// `Clone`, `Copy` and `Debug` without bounds on the phantom problem types (derives would demand
/// them of the problem marker types).
macro_rules! phantom_impls {
    ([$($gen:tt)*], $ty:ty, $name:expr, [$($field:ident),*]) => {
        impl<$($gen)*> Clone for $ty {
            #[inline]
            fn clone(&self) -> Self {
                *self
            }
        }
        impl<$($gen)*> Copy for $ty {}
        impl<$($gen)*> std::fmt::Debug for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.debug_struct($name)$(.field(stringify!($field), &self.$field))*.finish()
            }
        }
    };
}

phantom_impls!(
    [G, F, S: Scalar, const NPG: usize, const NPF: usize],
    GammaTrick<G, F, S, NPG, NPF>,
    "GammaTrick",
    [p0, p1, gamma]
);
phantom_impls!(
    [P, S: Scalar, const NP: usize],
    ParameterHomotopy<P, S, NP>,
    "ParameterHomotopy",
    [p0, p1, bend]
);
phantom_impls!([P, S: Scalar, const NP: usize], FixedSystem<P, S, NP>, "FixedSystem", [p]);

// ---------------------------------------------------------------------------------------------
// Straight line and gamma trick
// ---------------------------------------------------------------------------------------------

/// The paper's straight-line homotopy evaluated in coefficient space:
/// `H(x, t) = Fc(x; c0 + t (c1 - c0)) = (1-t) F(x; p0) + t F(x; p1)`, with `c = c(p)` computed
/// once at construction ([`CoefficientForm`]). Same path as [`StraightLine`] with `gamma = 1`,
/// at the cost of one coefficient-form evaluation per step instead of two full ones.
pub struct CoefficientLine<P, S: Scalar, const NP: usize, const NC: usize> {
    /// Start coefficients `c(p0)`.
    pub c0: SVector<S, NC>,
    /// `c(p1) - c(p0)`.
    pub dc: SVector<S, NC>,
    problem: PhantomData<fn() -> P>,
}

impl<P, S: Scalar, const NP: usize, const NC: usize> CoefficientLine<P, S, NP, NC> {
    /// The line from `F(.; p0)` to `F(.; p1)`.
    pub fn new<const NX: usize, const NF: usize>(p0: &SVector<S, NP>, p1: &SVector<S, NP>) -> Self
    where
        P: CoefficientForm<NX, NF, NP, NC>,
    {
        let mut c0 = SVector::<S, NC>::zeros();
        let mut c1 = SVector::<S, NC>::zeros();
        P::coefficients(p0, &mut c0);
        P::coefficients(p1, &mut c1);
        Self { c0, dc: c1 - c0, problem: PhantomData }
    }

    #[inline]
    fn at(&self, t: f64) -> SVector<S, NC> {
        let mut c = self.dc * S::from_real(t);
        c += self.c0;
        c
    }
}

impl<P, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize> Homotopy<S, NX, NF> for CoefficientLine<P, S, NP, NC>
where
    P: CoefficientForm<NX, NF, NP, NC>,
    S: Scalar,
{
    #[inline]
    fn evaluate(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>, jx: &mut SMatrix<S, NF, NX>) {
        P::residual_jacobian_coeffs(x, &self.at(t), h, jx);
    }

    #[inline]
    fn dt(&self, x: &SVector<S, NX>, _t: f64, dh: &mut SVector<S, NF>) {
        P::coefficient_part(x, &self.dc, dh);
    }

    #[inline]
    fn residual(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>) {
        P::residual_coeffs(x, &self.at(t), h);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, t: f64, jx: &mut SMatrix<S, NF, NX>, dh: &mut SVector<S, NF>) {
        let mut h = SVector::<S, NF>::zeros();
        P::residual_jacobian_coeffs(x, &self.at(t), &mut h, jx);
        P::coefficient_part(x, &self.dc, dh);
    }
}

/// The paper's straight-line homotopy within one problem family,
/// `H(x, t) = gamma (1-t) F(x; p0) + t F(x; p1)`, `gamma = 1` unless set: the [`GammaTrick`]
/// from a system to itself (one implementation serves both).
///
/// `J_x = gamma (1-t) J(x; p0) + t J(x; p1)` and `dH/dt = F(x; p1) - gamma F(x; p0)`; every
/// evaluation costs two residual/Jacobian evaluations of the problem. For overdetermined
/// systems this homotopy is inconsistent for `0 < t < 1` (see the module docs).
pub type StraightLine<P, S, const NP: usize> = GammaTrick<P, P, S, NP, NP>;

impl<P, S: Scalar, const NP: usize> StraightLine<P, S, NP> {
    /// The straight line from `F(.; p0)` to `F(.; p1)` with `gamma = 1`.
    pub fn new(p0: SVector<S, NP>, p1: SVector<S, NP>) -> Self {
        Self::between(S::one(), p0, p1)
    }

    /// Same with a `gamma` factor on the start system.
    pub fn with_gamma(p0: SVector<S, NP>, p1: SVector<S, NP>, gamma: S) -> Self {
        Self::between(gamma, p0, p1)
    }
}

/// The gamma trick between two systems, `H(x, t) = gamma (1-t) G(x; p0) + t F(x; p1)`.
///
/// `G` is typically a total-degree start system (`x_i^{d_i} - 1`, solutions known) and `F` the
/// target; with `gamma` from [`random_gamma`] no path meets a singularity for `t < 1` with
/// probability one. Track in `Complex<f64>`. With `G = F` it is the [`StraightLine`].
pub struct GammaTrick<G, F, S: Scalar, const NPG: usize, const NPF: usize> {
    /// Parameters of the start system `G` (`t = 0`).
    pub p0: SVector<S, NPG>,
    /// Parameters of the target system `F` (`t = 1`).
    pub p1: SVector<S, NPF>,
    /// Factor of the start system.
    pub gamma: S,
    systems: PhantomData<fn() -> (G, F)>,
}

impl<G, F, S: Scalar, const NPG: usize, const NPF: usize> GammaTrick<G, F, S, NPG, NPF> {
    /// `gamma (1-t) G(x; p0) + t F(x; p1)`.
    pub fn between(gamma: S, p0: SVector<S, NPG>, p1: SVector<S, NPF>) -> Self {
        Self { p0, p1, gamma, systems: PhantomData }
    }

    /// `G` and `F` at `x`: residuals, and Jacobians when asked for.
    #[inline]
    fn both<const NX: usize, const NF: usize>(
        &self,
        x: &SVector<S, NX>,
        jacobians: Option<(&mut SMatrix<S, NF, NX>, &mut SMatrix<S, NF, NX>)>,
    ) -> (SVector<S, NF>, SVector<S, NF>)
    where
        G: Problem<NX, NF, NPG>,
        F: Problem<NX, NF, NPF>,
    {
        let mut f0 = SVector::<S, NF>::zeros();
        let mut f1 = SVector::<S, NF>::zeros();
        match jacobians {
            Some((j0, j1)) => {
                G::residual_jacobian(x, &self.p0, &mut f0, j0);
                F::residual_jacobian(x, &self.p1, &mut f1, j1);
            }
            None => {
                G::residual(x, &self.p0, &mut f0);
                F::residual(x, &self.p1, &mut f1);
            }
        }
        (f0, f1)
    }
}

impl<G, F, S, const NX: usize, const NF: usize, const NPG: usize, const NPF: usize> Homotopy<S, NX, NF> for GammaTrick<G, F, S, NPG, NPF>
where
    G: Problem<NX, NF, NPG>,
    F: Problem<NX, NF, NPF>,
    S: Scalar,
{
    #[inline]
    fn evaluate(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>, jx: &mut SMatrix<S, NF, NX>) {
        let mut j0 = SMatrix::<S, NF, NX>::zeros();
        let mut j1 = SMatrix::<S, NF, NX>::zeros();
        let (f0, f1) = self.both(x, Some((&mut j0, &mut j1)));
        let a = self.gamma * S::from_real(1.0 - t);
        let b = S::from_real(t);
        lincomb(h, a, &f0, b, &f1);
        lincomb(jx, a, &j0, b, &j1);
    }

    #[inline]
    fn dt(&self, x: &SVector<S, NX>, _t: f64, dh: &mut SVector<S, NF>) {
        let (f0, f1) = self.both::<NX, NF>(x, None);
        lincomb(dh, -self.gamma, &f0, S::one(), &f1);
    }

    #[inline]
    fn residual(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>) {
        let (f0, f1) = self.both::<NX, NF>(x, None);
        lincomb(h, self.gamma * S::from_real(1.0 - t), &f0, S::from_real(t), &f1);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, t: f64, jx: &mut SMatrix<S, NF, NX>, dh: &mut SVector<S, NF>) {
        let mut j0 = SMatrix::<S, NF, NX>::zeros();
        let mut j1 = SMatrix::<S, NF, NX>::zeros();
        let (f0, f1) = self.both(x, Some((&mut j0, &mut j1)));
        lincomb(jx, self.gamma * S::from_real(1.0 - t), &j0, S::from_real(t), &j1);
        lincomb(dh, -self.gamma, &f0, S::one(), &f1);
    }
}

// ---------------------------------------------------------------------------------------------
// Parameter homotopy (with optional complex detour)
// ---------------------------------------------------------------------------------------------

/// The parameter homotopy `H(x, t) = F(x; p(t))` along
/// `p(t) = (1-t) p0 + t p1 + t (1-t) q`.
///
/// `dH/dt = dF/dp (x; p(t)) * (p1 - p0 + (1 - 2t) q)` comes from
/// [`ParamDerivative::param_directional`], so an evaluation costs one residual/Jacobian plus one
/// directional parameter derivative (cheaper than the straight line's two full evaluations).
/// `q = 0` is the straight segment in parameter space; a non-zero `q` bends the path while
/// keeping both end points (see [`ParameterHomotopy::with_complex_detour`]).
pub struct ParameterHomotopy<P, S: Scalar, const NP: usize> {
    /// Start parameters (`t = 0`).
    pub p0: SVector<S, NP>,
    /// Target parameters (`t = 1`).
    pub p1: SVector<S, NP>,
    /// Bend of the parameter path, weighted by `t (1 - t)` (read it with
    /// [`ParameterHomotopy::bend`]; private so that `bent` stays true to it).
    bend: SVector<S, NP>,
    /// Whether `bend` has a non-zero entry.
    bent: bool,
    problem: PhantomData<fn() -> P>,
}

impl<P, S: Scalar, const NP: usize> ParameterHomotopy<P, S, NP> {
    /// The straight parameter segment from `p0` to `p1`.
    pub fn new(p0: SVector<S, NP>, p1: SVector<S, NP>) -> Self {
        Self { p0, p1, bend: SVector::zeros(), bent: false, problem: PhantomData }
    }

    /// The parameter path with an explicit bend `q`.
    pub fn with_bend(p0: SVector<S, NP>, p1: SVector<S, NP>, bend: SVector<S, NP>) -> Self {
        let bent = bend.iter().any(|b| !b.is_zero());
        Self { p0, p1, bend, bent, problem: PhantomData }
    }

    /// The bend of the parameter path (zero for a straight segment).
    pub fn bend(&self) -> &SVector<S, NP> {
        &self.bend
    }

    /// `p(t)`. Real weights scale each component (two real products per complex entry, not a
    /// complex product: `p(t)` is formed at every evaluation); at `t = 1` it is exactly `p1`.
    #[inline]
    pub fn params_at(&self, t: f64) -> SVector<S, NP> {
        let (a, b) = (1.0 - t, t);
        let mut p = SVector::<S, NP>::zeros();
        for i in 0..NP {
            p[i] = self.p0[i].scale(a) + self.p1[i].scale(b);
        }
        if self.bent {
            let c = t * (1.0 - t);
            for i in 0..NP {
                p[i] += self.bend[i].scale(c);
            }
        }
        p
    }

    /// `p(t)` as a polynomial in `t`, lowest degree first: `[p0, p1 - p0]`, or with a bend `q`
    /// `[p0, p1 - p0 + q, -q]`.
    pub fn param_poly(&self) -> Vec<SVector<S, NP>> {
        let slope = self.p1 - self.p0;
        if self.bent {
            vec![self.p0, slope + self.bend, -self.bend]
        } else {
            vec![self.p0, slope]
        }
    }

    /// `dp/dt (t)`.
    #[inline]
    pub fn params_dt(&self, t: f64) -> SVector<S, NP> {
        let c = 1.0 - 2.0 * t;
        let mut d = SVector::<S, NP>::zeros();
        for i in 0..NP {
            d[i] = self.p1[i] - self.p0[i];
        }
        if self.bent {
            for i in 0..NP {
                d[i] += self.bend[i].scale(c);
            }
        }
        d
    }
}

impl<P, const NP: usize> ParameterHomotopy<P, Complex<f64>, NP> {
    /// The complex detour `p(t) = (1-t) p0 + t p1 + i g t (1-t) d` between *real* parameters.
    ///
    /// `d` is a seeded random direction with standard normal entries, rescaled so that
    /// `|d| = |p1 - p0|` (Euclidean; `|d| = 1` when `p0 = p1`): `g` is the size of the detour
    /// relative to the length of the path (`g ~ 0.1 .. 1`). At `t = 0` and `t = 1` the
    /// parameters are real, so a real start solution is tracked in complex arithmetic and the
    /// end point of a real target root comes back real; in between the path avoids the real
    /// folds (where two real roots meet and a real path turns back) with probability one.
    pub fn with_complex_detour(p0: &SVector<f64, NP>, p1: &SVector<f64, NP>, g: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut d = SVector::<f64, NP>::zeros();
        for e in d.iter_mut() {
            *e = gaussian(&mut rng);
        }
        let len = (p1 - p0).norm();
        let len = if len > 0.0 { len } else { 1.0 };
        let dn = d.norm();
        let scale = if dn > 0.0 { g * len / dn } else { 0.0 };
        let bend = d.map(|e| Complex::new(0.0, e * scale));
        Self::with_bend(to_complex(p0), to_complex(p1), bend)
    }
}

impl<P, S, const NX: usize, const NF: usize, const NP: usize> Homotopy<S, NX, NF> for ParameterHomotopy<P, S, NP>
where
    P: ParamDerivative<NX, NF, NP>,
    S: Scalar,
{
    #[inline]
    fn evaluate(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>, jx: &mut SMatrix<S, NF, NX>) {
        P::residual_jacobian(x, &self.params_at(t), h, jx);
    }

    #[inline]
    fn dt(&self, x: &SVector<S, NX>, t: f64, dh: &mut SVector<S, NF>) {
        P::param_directional(x, &self.params_at(t), &self.params_dt(t), dh);
    }

    #[inline]
    fn residual(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NF>) {
        P::residual(x, &self.params_at(t), h);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, t: f64, jx: &mut SMatrix<S, NF, NX>, dh: &mut SVector<S, NF>) {
        let p = self.params_at(t);
        P::jacobian(x, &p, jx);
        P::param_directional(x, &p, &self.params_dt(t), dh);
    }
}

// ---------------------------------------------------------------------------------------------
// Constant system (for plain Newton / Gauss-Newton)
// ---------------------------------------------------------------------------------------------

/// `H(x, t) = F(x; p)` for every `t` (`dH/dt = 0`): the system that
/// [`crate::tracker::newton`] refines on, e.g. the "Gauss-Newton only" baseline.
pub struct FixedSystem<P, S: Scalar, const NP: usize> {
    /// The parameters.
    pub p: SVector<S, NP>,
    problem: PhantomData<fn() -> P>,
}

impl<P, S: Scalar, const NP: usize> FixedSystem<P, S, NP> {
    /// `F(.; p)` as a constant homotopy.
    pub fn new(p: SVector<S, NP>) -> Self {
        Self { p, problem: PhantomData }
    }
}

impl<P, S, const NX: usize, const NF: usize, const NP: usize> Homotopy<S, NX, NF> for FixedSystem<P, S, NP>
where
    P: Problem<NX, NF, NP>,
    S: Scalar,
{
    #[inline]
    fn evaluate(&self, x: &SVector<S, NX>, _t: f64, h: &mut SVector<S, NF>, jx: &mut SMatrix<S, NF, NX>) {
        P::residual_jacobian(x, &self.p, h, jx);
    }

    #[inline]
    fn dt(&self, _x: &SVector<S, NX>, _t: f64, dh: &mut SVector<S, NF>) {
        dh.fill(S::zero());
    }

    #[inline]
    fn residual(&self, x: &SVector<S, NX>, _t: f64, h: &mut SVector<S, NF>) {
        P::residual(x, &self.p, h);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, _t: f64, jx: &mut SMatrix<S, NF, NX>, dh: &mut SVector<S, NF>) {
        P::jacobian(x, &self.p, jx);
        dh.fill(S::zero());
    }
}

// ---------------------------------------------------------------------------------------------
// Square-up wrapper for overdetermined systems
// ---------------------------------------------------------------------------------------------

/// A square homotopy `A H(x, t)` from an overdetermined one (`NF > NX` equations), with a fixed
/// random `A` (`NX x NF`, orthonormal rows, seeded).
///
/// Why: the straight-line homotopy of an overdetermined system has no exact zeros between the
/// end points, and Gauss-Newton then follows a least-squares path that need not end at a root.
/// `A H = 0` is square, so Newton tracks a path of exact zeros of the combined equations; at
/// `t = 1` a root of `H(., 1)` is a root of `A H(., 1)`. The converse fails (the square system
/// has spurious roots), so [`Homotopy::validation_residual`] here evaluates the *full* `H` and
/// the tracker reports that as the final residual. Orthonormal rows keep `A` from worsening the
/// conditioning (`|A v| <= |v|`). `A` is real; in complex tracking that is enough, since the
/// randomness that avoids singular paths comes from `gamma` or the detour.
#[derive(Debug, Clone, Copy)]
pub struct SquaredUp<S: Scalar, H, const NX: usize, const NF: usize> {
    /// The overdetermined homotopy.
    pub inner: H,
    /// The combination matrix.
    pub a: SMatrix<S, NX, NF>,
}

impl<S: Scalar, H, const NX: usize, const NF: usize> SquaredUp<S, H, NX, NF> {
    /// Squares `inner` with a random `A` drawn from `seed`: Gaussian rows, orthonormalised by
    /// modified Gram-Schmidt (a Gaussian `NX x NF` matrix has full rank with probability one; a
    /// numerically dependent row, which needs an astronomically unlucky seed, is replaced by a
    /// unit vector).
    pub fn new(inner: H, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut a = SMatrix::<f64, NX, NF>::zeros();
        for e in a.iter_mut() {
            *e = gaussian(&mut rng);
        }
        for i in 0..NX {
            for k in 0..i {
                let d: f64 = (0..NF).map(|c| a[(i, c)] * a[(k, c)]).sum();
                for c in 0..NF {
                    a[(i, c)] -= d * a[(k, c)];
                }
            }
            let n: f64 = (0..NF).map(|c| a[(i, c)] * a[(i, c)]).sum::<f64>().sqrt();
            if n > 1e-8 {
                for c in 0..NF {
                    a[(i, c)] /= n;
                }
            } else {
                for c in 0..NF {
                    a[(i, c)] = if c == i { 1.0 } else { 0.0 };
                }
            }
        }
        Self { inner, a: a.map(S::from_real) }
    }

    /// Squares `inner` with a given combination matrix.
    pub fn with_matrix(inner: H, a: SMatrix<S, NX, NF>) -> Self {
        Self { inner, a }
    }
}

impl<S, H, const NX: usize, const NF: usize> Homotopy<S, NX, NX> for SquaredUp<S, H, NX, NF>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    #[inline]
    fn evaluate(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NX>, jx: &mut SMatrix<S, NX, NX>) {
        let mut hf = SVector::<S, NF>::zeros();
        let mut jf = SMatrix::<S, NF, NX>::zeros();
        self.inner.evaluate(x, t, &mut hf, &mut jf);
        self.a.mul_to(&hf, h);
        self.a.mul_to(&jf, jx);
    }

    #[inline]
    fn dt(&self, x: &SVector<S, NX>, t: f64, dh: &mut SVector<S, NX>) {
        let mut df = SVector::<S, NF>::zeros();
        self.inner.dt(x, t, &mut df);
        self.a.mul_to(&df, dh);
    }

    #[inline]
    fn residual(&self, x: &SVector<S, NX>, t: f64, h: &mut SVector<S, NX>) {
        let mut hf = SVector::<S, NF>::zeros();
        self.inner.residual(x, t, &mut hf);
        self.a.mul_to(&hf, h);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<S, NX>, t: f64, jx: &mut SMatrix<S, NX, NX>, dh: &mut SVector<S, NX>) {
        let mut jf = SMatrix::<S, NF, NX>::zeros();
        let mut df = SVector::<S, NF>::zeros();
        self.inner.jacobian_dt(x, t, &mut jf, &mut df);
        self.a.mul_to(&jf, jx);
        self.a.mul_to(&df, dh);
    }

    #[inline]
    fn validation_residual(&self, x: &SVector<S, NX>, t: f64) -> f64 {
        self.inner.validation_residual(x, t)
    }
}
