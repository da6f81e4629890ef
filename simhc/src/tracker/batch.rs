//! Batch tracking: [`LANES`] paths of a coefficient-parameter homotopy at once, one path per
//! SIMD lane ([`C64x4`]).
//!
//! Why: with row lanes ([`crate::lanes`]) only the row equations run in SIMD; the parameter
//! gathering, the global equations, the LU and the solves stay scalar, and 7 rows fill 8 lanes.
//! With one *path* per lane every part of a step is element-wise across lanes: the coefficients
//! `c(t)` at each path's own `t`, the generated row kernels, the global equations, Gaussian
//! elimination with partial pivoting (per lane) and the solves. That is the all-roots
//! situation: many independent paths of the same homotopy (HomotopyContinuation.jl and GPU-HC
//! track paths in parallel for the same reason).
//!
//! Every request a path makes is the same operation: at its `(x, t)`, evaluate `H`, `J_x` and
//! `dH/dt`, factor `J_x` and return the Newton update `J_x^-1 H` together with the tangent
//! `-J_x^-1 dH/dt`. A path is a small state machine (`Path`) running the adaptive tracker of
//! [`super::Tracker`] with the Heun or RK4 predictor — same step rules (shared code in
//! `step_size`), same corrector decisions (the corrector's shared `apply_update`) — one request
//! at a time;
//! a lane whose path ends takes the next start point. Lanes never mix, so a path's result does
//! not depend on its lane or its neighbours (nor on the thread count when batches run in
//! parallel). Differences from [`super::Tracker`]: the tangent after an accepted step uses
//! `dH/dt` at the last corrector iterate (within the corrector's last update of the accepted
//! point) instead of at the accepted point, and all arithmetic is the path-lane code's, so end
//! points agree to rounding, not bit for bit.

use super::corrector::{apply_update, max_abs, norm_weights, weighted_norm, CorrectorReport, CorrectorSettings};
use super::options::{AdaptiveStep, Predictor, StepControl, TrackerOptions};
use super::predictor::all_finite;
use super::step_size;
use super::{TrackError, TrackResult, TrackStats, Trouble, OMEGA_NOISE_FLOOR};
use crate::homotopy::Homotopy;
use crate::lanes::{dispatch, C64x4, F64x4, Kernel, Lanes, LANES};
use crate::CoefficientForm;
use nalgebra::{Complex, SVector};
use std::marker::PhantomData;

type C = Complex<f64>;

/// `H(x, t) = F_c(x; c(t))` with `c(t) = sum_k t^k c_k`, for path lanes: problem `P`'s
/// generated [`CoefficientForm::lanes_row`] / [`CoefficientForm::lanes_globals`] and the
/// coefficient polynomials (coefficient-major: entry `i * (degree + 1) + k` is `c_k[i]`).
#[derive(Debug, Clone)]
pub struct LaneSystem<P, const N: usize, const NC: usize> {
    c: Vec<C>,
    terms: usize,
    rows: usize,
    per_row: usize,
    epr: usize,
    _problem: PhantomData<fn() -> P>,
}

impl<P, const N: usize, const NC: usize> LaneSystem<P, N, NC> {
    /// The system with coefficients `c(t) = sum_k t^k poly[k]`, or `None` when `P` has no
    /// path-lane code (`PATH_LANES` / `ROW_LAYOUT` not both set, or inconsistent sizes) or
    /// `poly` is empty.
    pub fn new<const NP: usize>(poly: &[SVector<C, NC>]) -> Option<Self>
    where
        P: CoefficientForm<N, N, NP, NC>,
    {
        let (Some(epr), Some((rows, per_row))) = (P::PATH_LANES, P::ROW_LAYOUT) else {
            return None;
        };
        if poly.is_empty() || rows == 0 || rows * per_row != NC || rows * epr > N {
            return None;
        }
        let terms = poly.len();
        let mut c = vec![C::new(0.0, 0.0); NC * terms];
        for i in 0..NC {
            for (k, pk) in poly.iter().enumerate() {
                c[i * terms + k] = pk[i];
            }
        }
        Some(Self { c, terms, rows, per_row, epr, _problem: PhantomData })
    }
}

/// Lane `l` of an `N`-vector of lanes as an `SVector`.
#[inline]
fn lane_of<const N: usize>(v: &[C64x4; N], l: usize) -> SVector<C, N> {
    SVector::from_fn(|i, _| v[i].get(l))
}

/// `a * t + b` per lane (fused multiply-adds: correctly rounded with and without FMA hardware,
/// so both [`dispatch`] variants agree).
#[inline(always)]
fn fma(a: C64x4, t: F64x4, b: C64x4) -> C64x4 {
    let mut out = b;
    for l in 0..LANES {
        out.re.0[l] = a.re.0[l].mul_add(t.0[l], b.re.0[l]);
        out.im.0[l] = a.im.0[l].mul_add(t.0[l], b.im.0[l]);
    }
    out
}

/// `p(t) = sum_k t^k p[k]` and `p'(t)` in every lane, each lane at its own real `t` (Horner for
/// both at once). Unrolled for the usual lengths (GRPS: cubic coefficients).
#[inline(always)]
fn horner(p: &[C], t: F64x4) -> (C64x4, C64x4) {
    let s = C64x4::splat;
    let zero = C64x4::default();
    match *p {
        [a] => (s(a), zero),
        [a, b] => (fma(s(b), t, s(a)), s(b)),
        [a, b, c] => {
            let (v, d) = (fma(s(c), t, s(b)), s(c));
            (fma(v, t, s(a)), fma(d, t, v))
        }
        [a, b, c, e] => {
            let (v, d) = (fma(s(e), t, s(c)), s(e));
            let (v, d) = (fma(v, t, s(b)), fma(d, t, v));
            (fma(v, t, s(a)), fma(d, t, v))
        }
        _ => {
            let n = p.len();
            let mut v = if n == 0 { zero } else { s(p[n - 1]) };
            let mut d = zero;
            for &pk in p[..n.saturating_sub(1)].iter().rev() {
                d = fma(d, t, v);
                v = fma(v, t, s(pk));
            }
            (v, d)
        }
    }
}

/// `|re| + |im|` per lane (the pivot measure of [`super::linalg`]).
#[inline(always)]
fn magnitude(z: C64x4) -> F64x4 {
    let mut m = F64x4::default();
    for l in 0..LANES {
        m.0[l] = z.re.0[l].abs() + z.im.0[l].abs();
    }
    m
}

/// `1 / z` per lane.
#[inline(always)]
fn reciprocal(z: C64x4) -> C64x4 {
    let mut out = C64x4::default();
    for l in 0..LANES {
        let (a, b) = (z.re.0[l], z.im.0[l]);
        let d = 1.0 / (a * a + b * b);
        out.re.0[l] = a * d;
        out.im.0[l] = -b * d;
    }
    out
}

/// Per-lane outcome of the linear algebra.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Factor {
    Ok,
    Singular,
    NonFinite,
}

/// Gaussian elimination with partial pivoting, per lane, of `a` (row-major, `N x N`) applied to
/// the two right-hand sides, then back substitution: `f <- a^-1 f`, `d <- a^-1 d`. A lane is
/// singular when a pivot is at most `N * eps * |A|_1` (the scalar LUs' rule) and non-finite
/// when `A` has a non-finite entry; its outputs are then meaningless.
#[inline(always)]
fn solve_lanes<const N: usize>(
    a: &mut [[C64x4; N]; N],
    f: &mut [C64x4; N],
    d: &mut [C64x4; N],
) -> [Factor; LANES] {
    let mut status = [Factor::Ok; LANES];
    // |A|_1 per lane (largest column sum of |re| + |im|) and finiteness.
    let mut norm = [0.0f64; LANES];
    for c in 0..N {
        let mut sum = F64x4::default();
        for row in a.iter() {
            sum = sum + magnitude(row[c]);
        }
        for l in 0..LANES {
            if !sum.0[l].is_finite() {
                status[l] = Factor::NonFinite;
            }
            norm[l] = norm[l].max(sum.0[l]);
        }
    }
    let threshold: [f64; LANES] = std::array::from_fn(|l| norm[l] * N as f64 * f64::EPSILON);
    let mut inv_diag = [C64x4::default(); N];
    for k in 0..N {
        // Pivot search and row swap, lane by lane.
        for l in 0..LANES {
            let mag = |z: &C64x4| z.re.0[l].abs() + z.im.0[l].abs();
            let mut best = k;
            let mut best_mag = mag(&a[k][k]);
            for (i, row) in a.iter().enumerate().skip(k + 1) {
                let m = mag(&row[k]);
                if m > best_mag {
                    best = i;
                    best_mag = m;
                }
            }
            // Not above the threshold, NaN included.
            let regular = best_mag.partial_cmp(&threshold[l]) == Some(std::cmp::Ordering::Greater);
            if !regular && status[l] == Factor::Ok {
                status[l] = Factor::Singular;
            }
            if best != k {
                for c in k..N {
                    let (u, v) = (a[k][c].get(l), a[best][c].get(l));
                    a[k][c].set(l, v);
                    a[best][c].set(l, u);
                }
                for rhs in [&mut *f, &mut *d] {
                    let (u, v) = (rhs[k].get(l), rhs[best].get(l));
                    rhs[k].set(l, v);
                    rhs[best].set(l, u);
                }
            }
            if status[l] != Factor::Ok {
                // Keep the lane's arithmetic finite; its results are discarded.
                a[k][k].set(l, C::new(1.0, 0.0));
            }
        }
        let inv = reciprocal(a[k][k]);
        inv_diag[k] = inv;
        let (top, below) = a.split_at_mut(k + 1);
        let pivot_row = &top[k];
        for (i, row) in below.iter_mut().enumerate() {
            let i = i + k + 1;
            let m = row[k] * inv;
            for c in k + 1..N {
                row[c] = row[c] - m * pivot_row[c];
            }
            f[i] = f[i] - m * f[k];
            d[i] = d[i] - m * d[k];
        }
    }
    for i in (0..N).rev() {
        let (mut sf, mut sd) = (f[i], d[i]);
        for c in i + 1..N {
            sf = sf - a[i][c] * f[c];
            sd = sd - a[i][c] * d[c];
        }
        f[i] = sf * inv_diag[i];
        d[i] = sd * inv_diag[i];
    }
    status
}

/// One batch operation: at each lane's `(x, t)`, `u = J_x^-1 H` and `v = -J_x^-1 dH/dt`.
struct Operation<'a, P, const N: usize, const NP: usize, const NC: usize> {
    system: &'a LaneSystem<P, N, NC>,
    /// `P`'s trait has `NP` too.
    _np: PhantomData<[(); NP]>,
    x: &'a [C64x4; N],
    t: F64x4,
    u: &'a mut [C64x4; N],
    v: &'a mut [C64x4; N],
    status: &'a mut [Factor; LANES],
    /// Scratch for one row's coefficients and their derivatives (`2 * per_row`).
    scratch: &'a mut [C64x4],
}

impl<P, const N: usize, const NP: usize, const NC: usize> Kernel for Operation<'_, P, N, NP, NC>
where
    P: CoefficientForm<N, N, NP, NC>,
{
    #[inline(always)]
    fn run(self) {
        let op = self;
        let s = op.system;
        let mut j = [[C64x4::default(); N]; N];
        let mut f = [C64x4::default(); N];
        let mut d = [C64x4::default(); N];
        let (cl, dcl) = op.scratch.split_at_mut(s.per_row);
        for r in 0..s.rows {
            let row = &s.c[r * s.per_row * s.terms..(r + 1) * s.per_row * s.terms];
            for ((cm, dm), p) in cl.iter_mut().zip(dcl.iter_mut()).zip(row.chunks_exact(s.terms)) {
                (*cm, *dm) = horner(p, op.t);
            }
            let (e0, e1) = (r * s.epr, (r + 1) * s.epr);
            P::lanes_row(
                op.x,
                &*cl,
                &dcl[..s.per_row],
                &mut f[e0..e1],
                &mut j.as_flattened_mut()[e0 * N..e1 * N],
                &mut d[e0..e1],
            );
        }
        let g = s.rows * s.epr;
        P::lanes_globals(op.x, &mut f[g..], &mut j.as_flattened_mut()[g * N..]);
        *op.status = solve_lanes(&mut j, &mut f, &mut d);
        *op.u = f;
        for (vi, di) in op.v.iter_mut().zip(d) {
            *vi = -di;
        }
    }
}

/// What a path does with the next operation's result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Tangent at the start point.
    Start,
    /// A predictor stage's tangent: Heun's one at the Euler point, or RK4's three.
    Stage(u8),
    /// A corrector update at `t1`.
    Correct,
    /// The final refinement at `t = 1`.
    Final,
}

/// One path's tracker state (see the module docs).
#[derive(Debug, Clone, Copy)]
struct Path<const N: usize> {
    x: SVector<C, N>,
    t: f64,
    dt: f64,
    accuracy: f64,
    omega: Option<f64>,
    stats: TrackStats,
    last_rejected: bool,
    tangent: SVector<C, N>,
    weights: SVector<f64, N>,
    phase: Phase,
    /// The step in progress: target time, step, predicted point / corrector iterate.
    t1: f64,
    h: f64,
    /// RK4's second and third stage tangents.
    k2: SVector<C, N>,
    k3: SVector<C, N>,
    iterate: SVector<C, N>,
    moved: f64,
    settings: CorrectorSettings,
    report: CorrectorReport,
    prev: f64,
    /// The point and time of the next request.
    at: SVector<C, N>,
    at_t: f64,
}

/// The result of feeding a path one operation.
enum Next<const N: usize> {
    Request,
    Done(Result<TrackResult<C, N>, TrackError>),
}

impl<const N: usize> Path<N> {
    /// Checks `x0` like [`super::Tracker::start`] and asks for the start tangent.
    fn start(x0: &SVector<C, N>, o: &TrackerOptions, a: &AdaptiveStep) -> Result<Self, TrackError> {
        let dt = a.initial.min(a.max);
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(TrackError::StepSizeTooSmall { t: 0.0 });
        }
        if !all_finite(x0) {
            return Err(TrackError::NonFinite { t: 0.0 });
        }
        if max_abs(x0) > o.max_norm {
            return Err(TrackError::DivergedToInfinity { t: 0.0 });
        }
        Ok(Self {
            x: *x0,
            t: 0.0,
            dt,
            accuracy: f64::NAN,
            omega: None,
            stats: TrackStats::default(),
            last_rejected: false,
            tangent: SVector::zeros(),
            weights: norm_weights(x0),
            phase: Phase::Start,
            t1: 0.0,
            h: 0.0,
            k2: SVector::zeros(),
            k3: SVector::zeros(),
            iterate: *x0,
            moved: 0.0,
            settings: CorrectorSettings {
                max_iterations: 0,
                tolerance: 0.0,
                reduction: 0.0,
                max_contraction: f64::INFINITY,
                omega: None,
                estimate_error: true,
                max_norm: f64::INFINITY,
                max_first_update: f64::INFINITY,
            },
            report: CorrectorReport::new(),
            prev: f64::NAN,
            at: *x0,
            at_t: 0.0,
        })
    }

    /// Starts the next predictor-corrector attempt (or fails on the step budget).
    fn begin_step(&mut self, o: &TrackerOptions) -> Next<N> {
        if self.stats.steps() >= o.max_steps {
            return Next::Done(Err(TrackError::MaxSteps { t: self.t }));
        }
        self.t1 = if self.t + 1.05 * self.dt >= 1.0 { 1.0 } else { self.t + self.dt };
        self.h = self.t1 - self.t;
        if o.predictor == Predictor::Rk4 {
            self.at = self.x + self.tangent * C::new(0.5 * self.h, 0.0);
            self.at_t = self.t + 0.5 * self.h;
        } else {
            self.at = self.x + self.tangent * C::new(self.h, 0.0);
            self.at_t = self.t1;
        }
        self.phase = Phase::Stage(0);
        Next::Request
    }

    /// Feeds the operation's result at the requested point.
    fn feed(
        &mut self,
        u: &SVector<C, N>,
        v: &SVector<C, N>,
        status: Factor,
        o: &TrackerOptions,
        a: &AdaptiveStep,
    ) -> Next<N> {
        self.stats.factorizations += 1;
        let trouble = match status {
            Factor::Ok => None,
            Factor::Singular => Some(Trouble::Singular),
            Factor::NonFinite => Some(Trouble::NonFinite),
        };
        match self.phase {
            Phase::Start => {
                if let Some(tr) = trouble {
                    return Next::Done(Err(tr.into_error(0.0)));
                }
                if !all_finite(v) {
                    return Next::Done(Err(TrackError::NonFinite { t: 0.0 }));
                }
                self.tangent = *v;
                self.begin_step(o)
            }
            Phase::Stage(stage) => {
                if let Some(tr) = trouble {
                    return self.reject(tr, None, o, a);
                }
                let xp = match (o.predictor, stage) {
                    (Predictor::Rk4, 0) => {
                        self.k2 = *v;
                        self.at = self.x + v * C::new(0.5 * self.h, 0.0);
                        self.phase = Phase::Stage(1);
                        return Next::Request;
                    }
                    (Predictor::Rk4, 1) => {
                        self.k3 = *v;
                        self.at = self.x + v * C::new(self.h, 0.0);
                        self.at_t = self.t1;
                        self.phase = Phase::Stage(2);
                        return Next::Request;
                    }
                    (Predictor::Rk4, _) => {
                        let sum = self.tangent + (self.k2 + self.k3) * C::new(2.0, 0.0) + v;
                        self.x + sum * C::new(self.h / 6.0, 0.0)
                    }
                    _ => self.x + (self.tangent + v) * C::new(0.5 * self.h, 0.0),
                };
                if !all_finite(&xp) {
                    return self.reject(Trouble::NonFinite, None, o, a);
                }
                self.moved = weighted_norm(&(xp - self.x), &self.weights);
                self.settings = CorrectorSettings {
                    max_iterations: o.max_newton_iterations,
                    tolerance: o.path_tolerance,
                    reduction: o.path_reduction,
                    max_contraction: a.max_contraction,
                    omega: self.omega,
                    estimate_error: true,
                    max_norm: o.max_norm,
                    max_first_update: a.max_relative_correction * self.moved
                        + 2.0 * self.accuracy.max(o.path_tolerance),
                };
                self.report = CorrectorReport::new();
                self.prev = f64::NAN;
                self.iterate = xp;
                self.at = xp;
                self.phase = Phase::Correct;
                Next::Request
            }
            Phase::Correct | Phase::Final => {
                let last = self.phase == Phase::Final;
                self.stats.newton_iterations += 1;
                self.report.iterations += 1;
                let stop = match trouble {
                    Some(tr) => {
                        self.report.outcome = Err(tr);
                        true
                    }
                    None => apply_update(
                        &mut self.iterate,
                        u,
                        &self.weights,
                        &self.settings,
                        &mut self.report,
                        &mut self.prev,
                        true,
                    ),
                };
                if !stop && self.report.iterations < self.settings.max_iterations {
                    self.at = self.iterate;
                    return Next::Request;
                }
                if !stop {
                    self.report.outcome = Err(Trouble::NotConverged);
                }
                if last {
                    return self.finished_refinement(o);
                }
                if self.moved > 0.0 {
                    self.report.relative_correction = self.report.norm_dx0 / self.moved;
                }
                match self.report.outcome {
                    Ok(()) => self.accept(v, o, a),
                    Err(tr) => {
                        let report = self.report;
                        self.reject(tr, Some(&report), o, a)
                    }
                }
            }
        }
    }

    fn accept(&mut self, v: &SVector<C, N>, o: &TrackerOptions, a: &AdaptiveStep) -> Next<N> {
        let after_rejection = self.last_rejected;
        let report = self.report;
        self.x = self.iterate;
        self.t = self.t1;
        self.stats.accepted_steps += 1;
        self.last_rejected = false;
        self.accuracy = report.accuracy;
        if max_abs(&self.x) > o.max_norm {
            return Next::Done(Err(TrackError::DivergedToInfinity { t: self.t }));
        }
        let omega_before = self.omega;
        if report.norm_dx1 > OMEGA_NOISE_FLOOR && report.norm_dx0 > 0.0 {
            self.omega = Some(2.0 * step_size::step_theta(&report) / report.norm_dx0);
        } else if report.theta1.is_finite() {
            self.omega = None;
        }
        self.weights = norm_weights(&self.x);
        if self.t >= 1.0 {
            return self.finish(o);
        }
        if !all_finite(v) {
            return Next::Done(Err(TrackError::NonFinite { t: self.t }));
        }
        self.tangent = *v;
        let f = step_size::grow_factor(a, o.predictor.order(), &report, omega_before, after_rejection);
        self.dt = (self.dt * f).min(a.max);
        self.begin_step(o)
    }

    fn reject(
        &mut self,
        trouble: Trouble,
        report: Option<&CorrectorReport>,
        o: &TrackerOptions,
        a: &AdaptiveStep,
    ) -> Next<N> {
        self.stats.rejected_steps += 1;
        self.last_rejected = true;
        self.dt *= step_size::shrink_factor(a, o.predictor.order(), trouble, report, self.omega);
        if self.dt < a.min {
            return Next::Done(Err(trouble.into_stall_error(self.t)));
        }
        self.begin_step(o)
    }

    /// At `t = 1`: refine to `final_tolerance` if needed (like [`super::Tracker`]'s `finish`).
    fn finish(&mut self, o: &TrackerOptions) -> Next<N> {
        if !reached(self.accuracy, o.final_tolerance) && o.final_newton_iterations > 0 {
            self.settings = CorrectorSettings {
                max_iterations: o.final_newton_iterations,
                tolerance: o.final_tolerance,
                reduction: 0.0,
                max_contraction: f64::INFINITY,
                omega: None,
                estimate_error: true,
                max_norm: o.max_norm,
                max_first_update: f64::INFINITY,
            };
            self.report = CorrectorReport::new();
            self.prev = f64::NAN;
            self.iterate = self.x;
            self.at = self.x;
            self.at_t = 1.0;
            self.phase = Phase::Final;
            return Next::Request;
        }
        self.success(o)
    }

    fn finished_refinement(&mut self, o: &TrackerOptions) -> Next<N> {
        match self.report.outcome {
            Ok(()) | Err(Trouble::NotConverged) | Err(Trouble::Contraction) => {
                self.x = self.iterate;
                self.accuracy = self.report.accuracy;
                self.success(o)
            }
            Err(other) => Next::Done(Err(other.into_error(1.0))),
        }
    }

    fn success(&mut self, o: &TrackerOptions) -> Next<N> {
        if o.require_final_convergence && !reached(self.accuracy, o.final_tolerance) {
            return Next::Done(Err(TrackError::CorrectorDidNotConverge { t: 1.0 }));
        }
        if !all_finite(&self.x) {
            return Next::Done(Err(TrackError::NonFinite { t: 1.0 }));
        }
        Next::Done(Ok(TrackResult { x: self.x, t: 1.0, stats: self.stats, accuracy: self.accuracy, residual: f64::NAN }))
    }
}

/// Whether the estimated error `accuracy` (NaN: unknown) is within `tolerance`.
#[inline]
fn reached(accuracy: f64, tolerance: f64) -> bool {
    accuracy <= tolerance
}

/// Whether [`track_batch`] runs `options`: the adaptive tracker without drag steps, with the
/// Heun or the RK4 predictor.
pub fn batch_supported(options: &TrackerOptions) -> bool {
    matches!(options.step, StepControl::Adaptive(AdaptiveStep { drag: None, .. }))
        && matches!(options.predictor, Predictor::Heun | Predictor::Rk4)
}

/// Tracks the start points `starts[i]` for every `i` in `indices` along `system`, [`LANES`] at a
/// time, with `options` (see [`batch_supported`]; otherwise `None`). Results are in the order
/// of `indices`; `h` — the same homotopy in scalar form — gives each end point's
/// [`Homotopy::validation_residual`]. Allocates only its output and a scratch buffer.
pub fn track_batch<P, H, const N: usize, const NP: usize, const NC: usize>(
    system: &LaneSystem<P, N, NC>,
    h: &H,
    starts: &[SVector<C, N>],
    indices: &[usize],
    options: &TrackerOptions,
) -> Option<Vec<Result<TrackResult<C, N>, TrackError>>>
where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
{
    if !batch_supported(options) {
        return None;
    }
    let StepControl::Adaptive(a) = options.step else {
        return None;
    };
    let mut results: Vec<Option<Result<TrackResult<C, N>, TrackError>>> = vec![None; indices.len()];
    let mut slots: [Option<(usize, Path<N>)>; LANES] = [None; LANES];
    let mut next = 0;
    let mut scratch = vec![C64x4::default(); 2 * system.per_row];
    // Fills a free lane with the next start point that starts cleanly.
    let refill = |slot: &mut Option<(usize, Path<N>)>, results: &mut Vec<Option<_>>, next: &mut usize| {
        while *next < indices.len() {
            let k = *next;
            *next += 1;
            match starts.get(indices[k]).ok_or(TrackError::NonFinite { t: 0.0 }).and_then(|x0| Path::start(x0, options, &a)) {
                Ok(p) => {
                    *slot = Some((k, p));
                    return;
                }
                Err(e) => results[k] = Some(Err(e)),
            }
        }
        *slot = None;
    };
    for slot in slots.iter_mut() {
        refill(slot, &mut results, &mut next);
    }
    let mut x = [C64x4::default(); N];
    let mut u = [C64x4::default(); N];
    let mut v = [C64x4::default(); N];
    while let Some(filler) = slots.iter().flatten().next().map(|(_, p)| (p.at, p.at_t)) {
        let mut t = F64x4::default();
        for (l, slot) in slots.iter().enumerate() {
            // Idle lanes repeat an active lane's request (finite, discarded).
            let (at, at_t) = slot.as_ref().map_or(filler, |(_, p)| (p.at, p.at_t));
            for i in 0..N {
                x[i].set(l, at[i]);
            }
            t.0[l] = at_t;
        }
        let mut status = [Factor::Ok; LANES];
        dispatch(Operation::<P, N, NP, NC> {
            system,
            _np: PhantomData,
            x: &x,
            t,
            u: &mut u,
            v: &mut v,
            status: &mut status,
            scratch: &mut scratch,
        });
        for (l, slot) in slots.iter_mut().enumerate() {
            let Some((k, path)) = slot.as_mut() else {
                continue;
            };
            let (ul, vl) = (lane_of(&u, l), lane_of(&v, l));
            if let Next::Done(r) = path.feed(&ul, &vl, status[l], options, &a) {
                let k = *k;
                results[k] = Some(r.map(|mut tr| {
                    tr.residual = h.validation_residual(&tr.x, 1.0);
                    tr
                }));
                refill(slot, &mut results, &mut next);
            }
        }
    }
    Some(results.into_iter().map(|r| r.unwrap_or(Err(TrackError::NonFinite { t: 0.0 }))).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_c(rng: &mut ChaCha8Rng) -> C {
        C::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
    }

    #[test]
    fn lane_elimination_matches_nalgebra_and_flags_singular_lanes() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        const N: usize = 8;
        let mats: [SMatrix<C, N, N>; LANES] = std::array::from_fn(|_| SMatrix::from_fn(|_, _| random_c(&mut rng)));
        let f: [SVector<C, N>; LANES] = std::array::from_fn(|_| SVector::from_fn(|_, _| random_c(&mut rng)));
        let d: [SVector<C, N>; LANES] = std::array::from_fn(|_| SVector::from_fn(|_, _| random_c(&mut rng)));
        let mut mats = mats;
        // Lane 2: rank deficient (two equal rows); lane 3: a NaN entry.
        let row = mats[2].row(1).into_owned();
        mats[2].set_row(5, &row);
        mats[3][(4, 4)] = C::new(f64::NAN, 0.0);
        let mut a = [[C64x4::default(); N]; N];
        let (mut fl, mut dl) = ([C64x4::default(); N], [C64x4::default(); N]);
        for l in 0..LANES {
            for i in 0..N {
                for j in 0..N {
                    a[i][j].set(l, mats[l][(i, j)]);
                }
                fl[i].set(l, f[l][i]);
                dl[i].set(l, d[l][i]);
            }
        }
        let status = solve_lanes(&mut a, &mut fl, &mut dl);
        assert_eq!(status, [Factor::Ok, Factor::Ok, Factor::Singular, Factor::NonFinite]);
        for l in 0..2 {
            let lu = mats[l].lu();
            let (xf, xd) = (lu.solve(&f[l]).unwrap(), lu.solve(&d[l]).unwrap());
            let (gf, gd) = (lane_of(&fl, l), lane_of(&dl, l));
            assert!((gf - xf).camax() < 1e-12 * xf.camax(), "lane {l}: {:e}", (gf - xf).camax());
            assert!((gd - xd).camax() < 1e-12 * xd.camax(), "lane {l}: {:e}", (gd - xd).camax());
        }
    }

    #[test]
    fn horner_gives_value_and_derivative_per_lane() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let t = F64x4([0.0, 0.3, -1.2, 1.0]);
        for len in 1..=6 {
            let p: Vec<C> = (0..len).map(|_| random_c(&mut rng)).collect();
            let (v, d) = horner(&p, t);
            for l in 0..LANES {
                let tl = t.0[l];
                let value: C = p.iter().enumerate().map(|(k, c)| c * tl.powi(k as i32)).sum();
                let slope: C = p.iter().enumerate().skip(1).map(|(k, c)| c * (k as f64 * tl.powi(k as i32 - 1))).sum();
                assert!((v.get(l) - value).norm() < 1e-13, "len {len} lane {l}");
                assert!((d.get(l) - slope).norm() < 1e-13, "len {len} lane {l}");
            }
        }
    }
}
