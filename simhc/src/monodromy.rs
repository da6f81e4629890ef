//! Monodromy solving: all isolated solutions of a generic complex instance of a square
//! parametrized system `F(x; p) = 0`, after HomotopyContinuation.jl's `monodromy_solve`.
//!
//! 1. **Seed pair.** A random complex `x*` and a random complex `p`; `x*` is first projected
//!    onto the equations that do not involve parameters (min-norm Newton in `x`, e.g. onto
//!    `q . q = 1`), then `p` is corrected by the complex minimum-norm Gauss-Newton step
//!    `p <- p - Jp^H (Jp Jp^H)^-1 F(x*; p)` until `F(x*; p*) = 0` ([`seed_pair`]). That is the
//!    generic simulator of the paper in complex arithmetic; for generic data `(x*, p*)` is a
//!    regular solution of a generic instance.
//! 2. **Loops.** Each loop draws two fresh random complex parameter points `p1`, `p2` and
//!    tracks every known solution around the triangle `p* -> p1 -> p2 -> p*` (three complex
//!    parameter homotopies, [`ParameterHomotopy`] on straight segments: the end points are
//!    random complex, so the segments miss the discriminant with probability one). End points
//!    not yet known are added and sent around the same loop too, so after a loop the set is
//!    closed under that loop's monodromy permutation.
//! 3. **Stopping rule.** Stop after `stall_loops` (`k`, default 5, HC.jl's
//!    `max_loops_no_progress`) consecutive loops without a new solution, or when a known
//!    `target_count` is reached, or after `max_loops`. The trace test is not implemented; the
//!    count is checked independently (PHCpack, see the built-in start systems' notes).
//!
//! **Symmetries.** A system with a sign symmetry (a quaternion `q` and `-q` give the same
//! rotation, [`SignFlip`]) has its solutions in pairs `x`, `g(x)`; the parameter homotopy
//! commutes with `g`, so only one representative per orbit is stored and tracked, and end points
//! are compared modulo `g`. Counts are then *orbits* (GRPS: 140 rotations, 280 solution vectors).
//!
//! Paths can run in parallel (rayon, [`MonodromyOptions::parallel`]); results are inserted in
//! path order, so the outcome does not depend on the thread count.

use crate::homotopy::ParameterHomotopy;
use crate::tracker::{track, TrackerOptions};
use crate::{ParamDerivative, Scalar};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::time::{Duration, Instant};
use thiserror::Error;

/// The complex scalar.
pub use crate::scalar::C;

/// The sign symmetry `x_i -> -x_i` for the listed indices (all other coordinates fixed), e.g.
/// `q -> -q` for a quaternion in `x[0..4]`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SignFlip {
    /// The coordinates that change sign.
    pub indices: Vec<usize>,
}

impl SignFlip {
    /// The flip of `indices`.
    pub fn new(indices: impl Into<Vec<usize>>) -> Self {
        Self { indices: indices.into() }
    }

    /// `g(x)`.
    pub fn apply<S: Scalar, const N: usize>(&self, x: &SVector<S, N>) -> SVector<S, N> {
        let mut y = *x;
        for &i in &self.indices {
            if i < N {
                y[i] = -y[i];
            }
        }
        y
    }

    /// The representative of `{x, g(x)}` whose first flipped coordinate of modulus above
    /// `1e-12` has a non-negative real part (for a real quaternion: `q0 >= 0`, the convention
    /// of the pose metrics).
    pub fn canonical<S: Scalar, const N: usize>(&self, x: &SVector<S, N>) -> SVector<S, N> {
        for &i in &self.indices {
            if i < N && x[i].modulus() > 1e-12 {
                return if x[i].real() < 0.0 { self.apply(x) } else { *x };
            }
        }
        *x
    }
}

/// Relative distance `max_i |a_i - b_i| / max(1, |a_i|)`.
#[inline]
pub fn relative_distance<S: Scalar, const N: usize>(a: &SVector<S, N>, b: &SVector<S, N>) -> f64 {
    let mut m = 0.0f64;
    for i in 0..N {
        let d = (a[i] - b[i]).modulus() / a[i].modulus().max(1.0);
        if d.is_nan() {
            return f64::NAN;
        }
        m = m.max(d);
    }
    m
}

/// A set of solutions deduplicated by relative distance, modulo an optional [`SignFlip`].
#[derive(Debug, Clone)]
pub struct SolutionSet<const N: usize> {
    solutions: Vec<SVector<C, N>>,
    symmetry: Option<SignFlip>,
    tolerance: f64,
}

impl<const N: usize> SolutionSet<N> {
    /// An empty set; two points closer than `tolerance` (relative max-norm) are the same.
    pub fn new(symmetry: Option<SignFlip>, tolerance: f64) -> Self {
        Self { solutions: Vec::new(), symmetry, tolerance }
    }

    /// Index of a known solution equal to `x` (or to its symmetric image).
    pub fn find(&self, x: &SVector<C, N>) -> Option<usize> {
        let gx = self.symmetry.as_ref().map(|g| g.apply(x));
        self.solutions.iter().position(|s| {
            relative_distance(s, x) <= self.tolerance || gx.as_ref().is_some_and(|gx| relative_distance(s, gx) <= self.tolerance)
        })
    }

    /// Adds `x` (as its canonical representative) unless known; returns whether it was new.
    pub fn insert(&mut self, x: &SVector<C, N>) -> bool {
        if self.find(x).is_some() {
            return false;
        }
        let x = match &self.symmetry {
            Some(g) => g.canonical(x),
            None => *x,
        };
        self.solutions.push(x);
        true
    }

    /// The representatives found so far.
    pub fn solutions(&self) -> &[SVector<C, N>] {
        &self.solutions
    }

    /// Number of representatives.
    pub fn len(&self) -> usize {
        self.solutions.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.solutions.is_empty()
    }

    /// The representatives, consuming the set.
    pub fn into_vec(self) -> Vec<SVector<C, N>> {
        self.solutions
    }
}

/// Settings of [`monodromy_solve`].
#[derive(Debug, Clone)]
pub struct MonodromyOptions {
    /// Seed of every random choice (seed pair, loop points). Default `1`.
    pub seed: u64,
    /// Loops at most. Default `200`.
    pub max_loops: usize,
    /// `k`: stop after this many consecutive loops without a new solution. Default `5`.
    pub stall_loops: usize,
    /// Stop as soon as this many solutions (orbits) are known, when the count is known from
    /// theory. Default `None`.
    pub target_count: Option<usize>,
    /// Path tracker settings. Default: the adaptive tracker ([`TrackerOptions::default`]), a
    /// faithful tracker (no drag steps).
    pub tracker: TrackerOptions,
    /// Two solutions closer than this (relative max-norm) are the same. Default `1e-6`.
    pub dedup_tolerance: f64,
    /// An end point is accepted when `max |F(x; p*)|` is below this. Default `1e-8`.
    pub residual_tolerance: f64,
    /// Sign symmetry of the solutions, if any (see the module docs). Default `None`.
    pub symmetry: Option<SignFlip>,
    /// Track the paths of a loop in parallel with rayon. Default `false`.
    pub parallel: bool,
    /// Standard deviation of the real and imaginary parts of random parameters. Default `1`.
    pub param_scale: f64,
}

impl Default for MonodromyOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            max_loops: 200,
            stall_loops: 5,
            target_count: None,
            tracker: TrackerOptions::default(),
            dedup_tolerance: 1e-6,
            residual_tolerance: 1e-8,
            symmetry: None,
            parallel: false,
            param_scale: 1.0,
        }
    }
}

/// Why the loops stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// `stall_loops` consecutive loops found nothing new.
    Stalled,
    /// `target_count` reached.
    TargetReached,
    /// `max_loops` done.
    MaxLoops,
}

/// Why monodromy could not start.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum MonodromyError {
    /// No regular seed pair `(x*, p*)` was found (the parameter-free equations cannot be
    /// satisfied, or the parameter correction did not converge, or the Jacobian is singular).
    #[error("no regular seed pair: residual {residual:e}, smallest singular value {sigma_min:e}")]
    NoSeedPair {
        /// Max-norm residual reached.
        residual: f64,
        /// Smallest singular value of `dF/dx` at the pair.
        sigma_min: f64,
    },
}

/// The outcome of [`monodromy_solve`].
#[derive(Debug, Clone)]
pub struct MonodromyResult<const N: usize, const NP: usize> {
    /// The generic complex instance `p*`.
    pub params: SVector<C, NP>,
    /// One representative per solution orbit of `F(.; p*) = 0`.
    pub solutions: Vec<SVector<C, N>>,
    /// Loops done.
    pub loops: usize,
    /// Number of solutions after each loop.
    pub history: Vec<usize>,
    /// Paths (edges) tracked.
    pub paths_tracked: usize,
    /// Paths that failed or ended with a residual above the tolerance.
    pub paths_failed: usize,
    /// Why the loops stopped.
    pub stop: StopReason,
    /// Wall-clock time, seed pair included.
    pub elapsed: Duration,
    /// Largest `max |F(x; p*)|` over the stored solutions.
    pub max_residual: f64,
}

fn complex_normal(rng: &mut ChaCha8Rng, scale: f64) -> C {
    // Box-Muller: two independent normals.
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    let r = (-2.0 * u1.ln()).sqrt() * scale;
    let a = std::f64::consts::TAU * u2;
    C::new(r * a.cos(), r * a.sin())
}

/// A random complex vector with independent complex normal entries (`re`, `im` each with
/// standard deviation `scale`).
pub fn random_complex_vector<const N: usize>(rng: &mut ChaCha8Rng, scale: f64) -> SVector<C, N> {
    SVector::from_fn(|_, _| complex_normal(rng, scale))
}

/// `Jp` as a dense matrix, its rows' norms, and the residual at `(x, p)`.
fn dense_jacobians<P, const N: usize, const NP: usize>(
    x: &SVector<C, N>,
    p: &SVector<C, NP>,
) -> (SVector<C, N>, SMatrix<C, N, N>, SMatrix<C, N, NP>)
where
    P: ParamDerivative<N, N, NP>,
{
    let mut f = SVector::<C, N>::zeros();
    let mut jx = SMatrix::<C, N, N>::zeros();
    let mut jp = SMatrix::<C, N, NP>::zeros();
    P::residual_jacobian(x, p, &mut f, &mut jx);
    P::param_jacobian(x, p, &mut jp);
    (f, jx, jp)
}

/// Minimum-norm solution `d = A^H (A A^H)^-1 b` of an underdetermined `A d = b` (full row rank;
/// `None` when singular).
fn min_norm_step(a: &DMatrix<C>, b: &DVector<C>) -> Option<DVector<C>> {
    if a.nrows() == 0 {
        return Some(DVector::zeros(a.ncols()));
    }
    let ah = a.adjoint();
    let gram = a * &ah;
    let y = gram.lu().solve(b)?;
    Some(ah * y)
}

/// Smallest singular value of `dF/dx`.
fn sigma_min<const N: usize>(jx: &SMatrix<C, N, N>) -> f64 {
    let d = DMatrix::from_iterator(N, N, jx.iter().copied());
    d.singular_values().iter().copied().fold(f64::INFINITY, f64::min)
}

/// A regular solution `(x*, p*)` of a generic complex instance: random `x`, projected onto the
/// parameter-free equations, then random `p` corrected by complex minimum-norm Gauss-Newton
/// (see the module docs). Tries a few random draws.
pub fn seed_pair<P, const N: usize, const NP: usize>(
    rng: &mut ChaCha8Rng,
    param_scale: f64,
) -> Result<(SVector<C, N>, SVector<C, NP>), MonodromyError>
where
    P: ParamDerivative<N, N, NP>,
{
    let mut last = MonodromyError::NoSeedPair { residual: f64::INFINITY, sigma_min: 0.0 };
    for _attempt in 0..8 {
        let mut x = random_complex_vector::<N>(rng, 1.0);
        let mut p = random_complex_vector::<NP>(rng, param_scale);
        // Rows of dF/dp that vanish: equations without parameters.
        let (_, _, jp) = dense_jacobians::<P, N, NP>(&x, &p);
        let jp_scale = jp.iter().map(|z| z.norm()).fold(0.0, f64::max).max(1e-300);
        let free: Vec<usize> = (0..N).filter(|&r| (0..NP).all(|c| jp[(r, c)].norm() <= 1e-14 * jp_scale)).collect();
        let bound: Vec<usize> = (0..N).filter(|r| !free.contains(r)).collect();
        // 1. x onto the parameter-free equations.
        let mut ok = true;
        for _ in 0..50 {
            let (f, jx, _) = dense_jacobians::<P, N, NP>(&x, &p);
            let res = free.iter().map(|&r| f[r].norm()).fold(0.0, f64::max);
            if res <= 1e-15 {
                break;
            }
            let a = DMatrix::from_fn(free.len(), N, |i, c| jx[(free[i], c)]);
            let b = DVector::from_fn(free.len(), |i, _| f[free[i]]);
            match min_norm_step(&a, &b) {
                Some(d) => {
                    for c in 0..N {
                        x[c] -= d[c];
                    }
                }
                None => {
                    ok = false;
                    break;
                }
            }
        }
        if !ok {
            continue;
        }
        // 2. p by minimum-norm Gauss-Newton on the other equations.
        let mut residual = f64::INFINITY;
        for _ in 0..50 {
            let (f, _, jp) = dense_jacobians::<P, N, NP>(&x, &p);
            residual = f.iter().map(|z| z.norm()).fold(0.0, f64::max);
            let pmax = p.iter().map(|z| z.norm()).fold(1.0, f64::max);
            if residual <= 1e-14 * pmax {
                break;
            }
            let a = DMatrix::from_fn(bound.len(), NP, |i, c| jp[(bound[i], c)]);
            let b = DVector::from_fn(bound.len(), |i, _| f[bound[i]]);
            match min_norm_step(&a, &b) {
                Some(d) => {
                    for c in 0..NP {
                        p[c] -= d[c];
                    }
                }
                None => break,
            }
            if !p.iter().all(|z| z.is_finite_value()) {
                break;
            }
        }
        let (f, jx, _) = dense_jacobians::<P, N, NP>(&x, &p);
        residual = residual.min(f.iter().map(|z| z.norm()).fold(0.0, f64::max));
        let s = sigma_min(&jx);
        if residual <= 1e-12 && s > 1e-8 {
            return Ok((x, p));
        }
        last = MonodromyError::NoSeedPair { residual, sigma_min: s };
    }
    Err(last)
}

/// Tracks `x` along `pa -> pb` (complex parameter homotopy); the end point if the path
/// succeeded with a residual below `tol`.
pub fn track_edge<P, const N: usize, const NP: usize>(
    x: &SVector<C, N>,
    pa: &SVector<C, NP>,
    pb: &SVector<C, NP>,
    options: &TrackerOptions,
    tol: f64,
) -> Option<SVector<C, N>>
where
    P: ParamDerivative<N, N, NP>,
{
    let h = ParameterHomotopy::<P, C, NP>::new(*pa, *pb);
    match track(&h, x, options) {
        Ok(r) if r.residual <= tol => Some(r.x),
        _ => None,
    }
}

/// Tracks `x` around the loop `p0 -> p1 -> p2 -> p0`; the end point, if every edge succeeded.
fn track_loop<P, const N: usize, const NP: usize>(
    x: &SVector<C, N>,
    points: &[SVector<C, NP>; 3],
    options: &TrackerOptions,
    tol: f64,
) -> (Option<SVector<C, N>>, usize)
where
    P: ParamDerivative<N, N, NP>,
{
    let mut y = *x;
    for e in 0..3 {
        match track_edge::<P, N, NP>(&y, &points[e], &points[(e + 1) % 3], options, tol) {
            Some(z) => y = z,
            None => return (None, e + 1),
        }
    }
    (Some(y), 3)
}

/// Runs monodromy from a fresh random seed pair (see the module docs).
pub fn monodromy_solve<P, const N: usize, const NP: usize>(options: &MonodromyOptions) -> Result<MonodromyResult<N, NP>, MonodromyError>
where
    P: ParamDerivative<N, N, NP>,
{
    let start = Instant::now();
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let (x0, p0) = seed_pair::<P, N, NP>(&mut rng, options.param_scale)?;
    let mut result = monodromy_from::<P, N, NP>(&p0, &[x0], options, &mut rng);
    result.elapsed = start.elapsed();
    Ok(result)
}

/// Runs the monodromy loops from known solutions `known` of `F(.; p0) = 0` (e.g. to extend a
/// stored start system); `rng` draws the loop points.
pub fn monodromy_from<P, const N: usize, const NP: usize>(
    p0: &SVector<C, NP>,
    known: &[SVector<C, N>],
    options: &MonodromyOptions,
    rng: &mut ChaCha8Rng,
) -> MonodromyResult<N, NP>
where
    P: ParamDerivative<N, N, NP>,
{
    let start = Instant::now();
    let mut set = SolutionSet::<N>::new(options.symmetry.clone(), options.dedup_tolerance);
    for x in known {
        set.insert(x);
    }
    let tol = options.residual_tolerance;
    let mut loops = 0;
    let mut stall = 0;
    let mut history = Vec::new();
    let mut paths_tracked = 0;
    let mut paths_failed = 0;
    let stop = loop {
        if options.target_count.is_some_and(|n| set.len() >= n) {
            break StopReason::TargetReached;
        }
        if stall >= options.stall_loops {
            break StopReason::Stalled;
        }
        if loops >= options.max_loops {
            break StopReason::MaxLoops;
        }
        let points = [*p0, random_complex_vector::<NP>(rng, options.param_scale), random_complex_vector::<NP>(rng, options.param_scale)];
        let before = set.len();
        let mut next = 0;
        while next < set.len() {
            let batch: Vec<SVector<C, N>> = set.solutions()[next..].to_vec();
            next = set.len();
            let ends: Vec<(Option<SVector<C, N>>, usize)> = if options.parallel {
                batch.par_iter().map(|x| track_loop::<P, N, NP>(x, &points, &options.tracker, tol)).collect()
            } else {
                batch.iter().map(|x| track_loop::<P, N, NP>(x, &points, &options.tracker, tol)).collect()
            };
            for (end, edges) in ends {
                paths_tracked += edges;
                match end {
                    Some(y) => {
                        set.insert(&y);
                    }
                    None => paths_failed += 1,
                }
                if options.target_count.is_some_and(|n| set.len() >= n) {
                    break;
                }
            }
            if options.target_count.is_some_and(|n| set.len() >= n) {
                break;
            }
        }
        loops += 1;
        history.push(set.len());
        if set.len() > before {
            stall = 0;
        } else {
            stall += 1;
        }
    };
    let mut max_residual = 0.0f64;
    let mut f = SVector::<C, N>::zeros();
    for x in set.solutions() {
        P::residual(x, p0, &mut f);
        max_residual = max_residual.max(f.iter().map(|z| z.norm()).fold(0.0, f64::max));
    }
    MonodromyResult {
        params: *p0,
        solutions: set.into_vec(),
        loops,
        history,
        paths_tracked,
        paths_failed,
        stop,
        elapsed: start.elapsed(),
        max_residual,
    }
}
