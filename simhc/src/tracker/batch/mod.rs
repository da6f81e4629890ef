//! Batch tracking: several paths of a coefficient-parameter homotopy at once, one path per
//! SIMD lane (`W` = 8 with AVX-512, 4 with AVX2 or the baseline; [`LaneIsa`]).
//!
//! Why: with row lanes ([`crate::lanes`]) only the row equations run in SIMD; the parameter
//! gathering, the global equations, the LU and the solves stay scalar, and 7 rows fill 8 lanes.
//! With one *path* per lane every part of a step is element-wise across lanes: the coefficients
//! `c(t)` at each path's own `t`, the generated row kernels, the global equations, Gaussian
//! elimination (threshold pivoting per lane, `wide`) and the solves. That is the all-roots
//! situation: many independent paths of the same homotopy (HomotopyContinuation.jl and GPU-HC
//! track paths in parallel for the same reason).
//!
//! Every request a path makes is the same operation: at its `(x, t)`, evaluate `H`, `J_x` and
//! `dH/dt`, factor `J_x` and return the Newton update `J_x^-1 H` together with the tangent
//! `-J_x^-1 dH/dt`. A path is a small state machine (`Path`) running the adaptive tracker of
//! [`super::Tracker`] with the Heun or RK4 predictor — same step rules (shared code in
//! `step_size`), same corrector decisions (the corrector's shared `apply_update`) — one request
//! at a time;
//! a lane whose path ends takes the next start point ([`PathQueue`]: a caller's queue may add
//! paths as results come in). Lanes never mix, so a path's result does
//! not depend on its lane or its neighbours (nor on the thread count when batches run in
//! parallel). Differences from [`super::Tracker`]: the tangent after an accepted step uses
//! `dH/dt` at the last corrector iterate (within the corrector's last update of the accepted
//! point) instead of at the accepted point, and all arithmetic is the path-lane code's (fused
//! multiply-adds where the CPU has them, threshold pivoting), so end points agree to rounding,
//! not bit for bit.

use super::corrector::{apply_update, max_abs, norm_weights, weighted_norm, CorrectorReport, CorrectorSettings};
use super::options::{AdaptiveStep, Predictor, StepControl, TrackerOptions};
use super::predictor::all_finite;
use super::step_size;
use super::{TrackError, TrackResult, TrackStats, Trouble, OMEGA_NOISE_FLOOR};
use crate::homotopy::Homotopy;
use crate::lanes::{dispatch, Kernel, Lanes};
use crate::CoefficientForm;
use nalgebra::SVector;
use std::marker::PhantomData;
use wide::{horner, solve_lanes, Factor, Wide};

mod wide;

use crate::scalar::C;

/// `H(x, t)` for path lanes, in one of two forms:
/// - [`LaneSystem::new`]: `F_c(x; c(t))` with `c(t) = sum_k t^k c_k`, problem `P`'s generated
///   [`CoefficientForm::lanes_row`] on the coefficients of the expansion;
/// - [`LaneSystem::from_parameter_path`]: `F(x; p(t))` with `p(t) = sum_k t^k p_k`,
///   [`CoefficientForm::lanes_row_params`] on each row's parameters (the unexpanded
///   declaration: fewer inputs per row and shared structure; GRPS7 measured 0.8x the time).
///
/// Either way [`CoefficientForm::lanes_globals`] gives the global equations. Each row's inputs
/// are stored as polynomials in `t`, input-major: entry `(r * per_row + i) * terms + k` is the
/// degree-`k` coefficient of row `r`'s input `i`.
#[derive(Debug, Clone)]
pub struct LaneSystem<P, const N: usize, const NC: usize> {
    c: Vec<C>,
    terms: usize,
    rows: usize,
    per_row: usize,
    epr: usize,
    /// Whether the row inputs are parameters (`lanes_row_params`), not coefficients.
    params: bool,
    /// Entries of the parameter kernel's shared part (`lanes_params_shared`).
    shared: usize,
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
        Some(Self { c, terms, rows, per_row, epr, params: false, shared: 0, _problem: PhantomData })
    }

    /// The system along the parameter path `p(t) = sum_k t^k poly[k]` (e.g. `[p0, p1 - p0]`
    /// for the segment from `p0` to `p1`: [`crate::homotopy::ParameterHomotopy::param_poly`]),
    /// or `None` when `P` has no parameter row kernel (`PARAM_LANES`, `PATH_LANES` and
    /// `ROW_LAYOUT` not all set, or sizes inconsistent with `NP`) or `poly` is empty.
    pub fn from_parameter_path<const NP: usize>(poly: &[SVector<C, NP>]) -> Option<Self>
    where
        P: CoefficientForm<N, N, NP, NC>,
    {
        let (Some(epr), Some((rows, _)), Some(layout)) = (P::PATH_LANES, P::ROW_LAYOUT, P::PARAM_LANES) else {
            return None;
        };
        let (row_len, k) = (layout.row_len, layout.inputs);
        if poly.is_empty() || rows == 0 || k < row_len || rows * row_len + (k - row_len) != NP || rows * epr > N {
            return None;
        }
        let terms = poly.len();
        let mut c = vec![C::new(0.0, 0.0); rows * k * terms];
        for r in 0..rows {
            for i in 0..k {
                // The row's own parameters, then the globals (stored after all rows).
                let src = if i < row_len { r * row_len + i } else { rows * row_len + (i - row_len) };
                for (d, pd) in poly.iter().enumerate() {
                    c[(r * k + i) * terms + d] = pd[src];
                }
            }
        }
        Some(Self { c, terms, rows, per_row: k, epr, params: true, shared: layout.shared, _problem: PhantomData })
    }
}

/// Lane `l` of an `N`-vector of lanes as an `SVector`.
#[inline]
fn lane_of<const W: usize, const FMA: bool, const N: usize>(v: &[Wide<W, FMA>; N], l: usize) -> SVector<C, N> {
    SVector::from_fn(|i, _| v[i].get(l))
}

/// The instruction set of the batch operation, and with it the paths per operation.
///
/// Why a choice: the operation's arithmetic fills whole vector registers of the CPU (see
/// `wide`), so the width follows the instruction set. [`LaneIsa::detect`] picks the widest
/// available; the others stay selectable ([`track_batch_with`]) to compare and test them on
/// one machine. End points agree across instruction sets to rounding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LaneIsa {
    /// 8 paths per operation in AVX-512 registers, fused multiply-adds.
    Avx512,
    /// 4 paths in AVX2 registers, fused multiply-adds.
    Avx2,
    /// 4 paths, the baseline instruction set, unfused arithmetic (any CPU).
    Baseline,
}

impl LaneIsa {
    /// Every instruction set, widest first.
    pub const ALL: [LaneIsa; 3] = [LaneIsa::Avx512, LaneIsa::Avx2, LaneIsa::Baseline];

    /// The widest instruction set this CPU runs.
    pub fn detect() -> Self {
        Self::ALL.into_iter().find(|isa| isa.available()).unwrap_or(LaneIsa::Baseline)
    }

    /// Whether this CPU runs it (checked at run time).
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            LaneIsa::Avx512 => {
                std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512vl")
                    && LaneIsa::Avx2.available()
            }
            #[cfg(target_arch = "x86_64")]
            LaneIsa::Avx2 => std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            LaneIsa::Baseline => true,
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Paths per operation with AVX-512 (one register per part).
    const WIDE: usize = 8;
    /// Paths per operation with AVX2 and the baseline.
    const NARROW: usize = 4;

    /// Paths per operation.
    pub fn width(self) -> usize {
        match self {
            LaneIsa::Avx512 => Self::WIDE,
            LaneIsa::Avx2 | LaneIsa::Baseline => Self::NARROW,
        }
    }

    /// Runs `kernel` compiled for this instruction set. Callers check [`LaneIsa::available`].
    #[inline(always)]
    fn run<K: Kernel>(self, kernel: K) {
        match self {
            #[cfg(target_arch = "x86_64")]
            LaneIsa::Avx512 if self.available() => {
                // SAFETY: `run_avx512` requires AVX-512F/VL, AVX2 and FMA, just checked (the
                // standard library caches the detection).
                #[allow(unsafe_code)]
                unsafe {
                    run_avx512(kernel)
                }
            }
            LaneIsa::Avx2 => dispatch(kernel),
            _ => kernel.run(),
        }
    }
}

/// [`Kernel::run`] compiled for AVX-512 (the inlined operation's 8-lane loops become 512-bit
/// instructions).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
#[allow(unsafe_code)]
unsafe fn run_avx512<K: Kernel>(kernel: K) {
    kernel.run()
}

/// One batch operation: at each lane's `(x, t)`, `u = J_x^-1 H` and `v = -J_x^-1 dH/dt`.
struct Operation<'a, P, const N: usize, const NP: usize, const NC: usize, const W: usize, const FMA: bool> {
    system: &'a LaneSystem<P, N, NC>,
    /// `P`'s trait has `NP` too.
    _np: PhantomData<[(); NP]>,
    x: &'a [Wide<W, FMA>; N],
    t: [f64; W],
    u: &'a mut [Wide<W, FMA>; N],
    v: &'a mut [Wide<W, FMA>; N],
    status: &'a mut [Factor; W],
    /// Scratch for one row's inputs and their derivatives (`2 * per_row`), then the parameter
    /// kernel's shared part.
    scratch: &'a mut [Wide<W, FMA>],
}

impl<P, const N: usize, const NP: usize, const NC: usize, const W: usize, const FMA: bool> Kernel
    for Operation<'_, P, N, NP, NC, W, FMA>
where
    P: CoefficientForm<N, N, NP, NC>,
{
    #[inline(always)]
    fn run(self) {
        let op = self;
        let s = op.system;
        let mut j = [[Wide::<W, FMA>::default(); N]; N];
        let mut f = [Wide::<W, FMA>::default(); N];
        let mut d = [Wide::<W, FMA>::default(); N];
        let (cl, rest) = op.scratch.split_at_mut(s.per_row);
        let (dcl, shared) = rest.split_at_mut(s.per_row);
        if s.params {
            P::lanes_params_shared(op.x, shared);
        }
        for r in 0..s.rows {
            let row = &s.c[r * s.per_row * s.terms..(r + 1) * s.per_row * s.terms];
            // The degree is fixed per system: one branch per row, not per coefficient.
            match s.terms {
                1 => coefficients::<1, W, FMA>(row, &op.t, cl, dcl),
                2 => coefficients::<2, W, FMA>(row, &op.t, cl, dcl),
                3 => coefficients::<3, W, FMA>(row, &op.t, cl, dcl),
                4 => coefficients::<4, W, FMA>(row, &op.t, cl, dcl),
                k => {
                    for ((cm, dm), p) in cl.iter_mut().zip(dcl.iter_mut()).zip(row.chunks_exact(k)) {
                        (*cm, *dm) = horner(p, &op.t);
                    }
                }
            }
            let (e0, e1) = (r * s.epr, (r + 1) * s.epr);
            let (fr, jr, dr) = (&mut f[e0..e1], &mut j.as_flattened_mut()[e0 * N..e1 * N], &mut d[e0..e1]);
            if s.params {
                P::lanes_row_params(op.x, &*shared, &*cl, &*dcl, fr, jr, dr);
            } else {
                P::lanes_row(op.x, &*cl, &*dcl, fr, jr, dr);
            }
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

/// `c(t)` and `c'(t)` of one row's coefficients, each a polynomial of `K` terms (`row`:
/// coefficient-major) into `c` and `dc`.
#[inline(always)]
fn coefficients<const K: usize, const W: usize, const FMA: bool>(
    row: &[C],
    t: &[f64; W],
    c: &mut [Wide<W, FMA>],
    dc: &mut [Wide<W, FMA>],
) {
    for ((cm, dm), p) in c.iter_mut().zip(dc.iter_mut()).zip(row.chunks_exact(K)) {
        if let Ok(p) = <&[C; K]>::try_from(p) {
            (*cm, *dm) = horner(p, t);
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
            settings: CorrectorSettings::refine(0, 0.0, f64::INFINITY),
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
                    max_contraction: a.max_contraction,
                    omega: self.omega,
                    max_first_update: a.max_relative_correction * self.moved
                        + 2.0 * self.accuracy.max(o.path_tolerance),
                    ..CorrectorSettings::adaptive_step(o.max_newton_iterations, o.path_tolerance, o.path_reduction, o.max_norm)
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
            self.settings = CorrectorSettings::refine(o.final_newton_iterations, o.final_tolerance, o.max_norm);
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

/// Tracks the start points `starts[i]` for every `i` in `indices` along `system`, several at a
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
    track_batch_with(LaneIsa::detect(), system, h, starts, indices, options)
}

/// [`track_batch`] with the batch operation compiled for `isa` (`None` also when this CPU does
/// not run it).
pub fn track_batch_with<P, H, const N: usize, const NP: usize, const NC: usize>(
    isa: LaneIsa,
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
    let mut queue = InOrder::new(indices);
    track_batch_queue(isa, system, h, starts, std::slice::from_ref(options), &mut queue).then(|| queue.into_results())
}

/// One path for [`track_batch_queue`]: start point `starts[start]` tracked with
/// `settings[settings]`; `id` is the queue's own tag, handed back with the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PathJob {
    /// The queue's tag of this job.
    pub id: usize,
    /// Index of the start point.
    pub start: usize,
    /// Index of the tracker settings.
    pub settings: usize,
}

/// Where [`track_batch_queue`] takes its paths from and leaves their results. The queue sees
/// every result as soon as its path ends, so it can decide further paths from them — the
/// all-roots path-jump repair re-tracks a suspicious path at once, in lanes that the tail of
/// the main pass would leave idle.
pub trait PathQueue<const N: usize> {
    /// The next path to track, `None` when there is none now (asked again after the next
    /// operation; tracking ends when no path is in flight and the queue has none).
    fn next(&mut self) -> Option<PathJob>;
    /// The result of a job that [`PathQueue::next`] returned.
    fn finished(&mut self, job: PathJob, result: Result<TrackResult<C, N>, TrackError>);
}

/// The queue of [`track_batch_with`]: the start points `indices` in order, all with settings
/// `0`, each job's `id` its position in `indices`; results kept by position.
#[derive(Debug, Clone)]
pub struct InOrder<'a, const N: usize> {
    indices: &'a [usize],
    next: usize,
    results: Vec<Option<Result<TrackResult<C, N>, TrackError>>>,
}

impl<'a, const N: usize> InOrder<'a, N> {
    /// The jobs for `indices`, none handed out yet.
    pub fn new(indices: &'a [usize]) -> Self {
        Self { indices, next: 0, results: vec![None; indices.len()] }
    }

    /// The start indices, by job `id`.
    pub fn indices(&self) -> &'a [usize] {
        self.indices
    }

    /// The result of job `id`, if it has finished.
    pub fn result(&self, id: usize) -> Option<&Result<TrackResult<C, N>, TrackError>> {
        self.results.get(id)?.as_ref()
    }

    /// The results in the order of `indices` (a job never handed out, which tracking to the
    /// end does not leave: `NonFinite` at `t = 0`).
    pub fn into_results(self) -> Vec<Result<TrackResult<C, N>, TrackError>> {
        self.results.into_iter().map(|r| r.unwrap_or(Err(TrackError::NonFinite { t: 0.0 }))).collect()
    }
}

impl<const N: usize> PathQueue<N> for InOrder<'_, N> {
    fn next(&mut self) -> Option<PathJob> {
        let id = self.next;
        let start = *self.indices.get(id)?;
        self.next += 1;
        Some(PathJob { id, start, settings: 0 })
    }

    fn finished(&mut self, job: PathJob, result: Result<TrackResult<C, N>, TrackError>) {
        if let Some(slot) = self.results.get_mut(job.id) {
            *slot = Some(result);
        }
    }
}

/// Tracks the paths that `queue` hands out along `system`, one per lane of `isa`'s batch
/// operation (see [`track_batch`]), each with its job's entry of `settings`. Returns `false`
/// without tracking when `isa` does not run on this CPU or some entry of `settings` is not
/// [`batch_supported`]. A job whose start point or settings index does not exist ends with
/// [`TrackError::NoStartPoint`] / [`TrackError::NoTrackerSettings`].
pub fn track_batch_queue<P, H, Q, const N: usize, const NP: usize, const NC: usize>(
    isa: LaneIsa,
    system: &LaneSystem<P, N, NC>,
    h: &H,
    starts: &[SVector<C, N>],
    settings: &[TrackerOptions],
    queue: &mut Q,
) -> bool
where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
    Q: PathQueue<N>,
{
    if !isa.available() {
        return false;
    }
    let mut steps = Vec::with_capacity(settings.len());
    for o in settings {
        match o.step {
            StepControl::Adaptive(a) if batch_supported(o) => steps.push((*o, a)),
            _ => return false,
        }
    }
    let run = (system, h, starts, steps.as_slice(), isa);
    match isa {
        LaneIsa::Avx512 => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::WIDE }, true>(run, queue),
        LaneIsa::Avx2 => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::NARROW }, true>(run, queue),
        LaneIsa::Baseline => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::NARROW }, false>(run, queue),
    }
    true
}

/// The arguments of [`track_lanes`].
type Run<'a, P, H, const N: usize, const NC: usize> =
    (&'a LaneSystem<P, N, NC>, &'a H, &'a [SVector<C, N>], &'a [(TrackerOptions, AdaptiveStep)], LaneIsa);

/// [`track_batch_queue`] with `W` paths per operation and fused (`FMA`) or plain arithmetic.
fn track_lanes<P, H, Q, const N: usize, const NP: usize, const NC: usize, const W: usize, const FMA: bool>(
    (system, h, starts, settings, isa): Run<'_, P, H, N, NC>,
    queue: &mut Q,
) where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
    Q: PathQueue<N>,
{
    let mut slots: [Option<(PathJob, Path<N>)>; W] = [None; W];
    let mut scratch = vec![Wide::<W, FMA>::default(); 2 * system.per_row + system.shared];
    // Fills a free lane with the queue's next path that starts cleanly.
    let refill = |slot: &mut Option<(PathJob, Path<N>)>, queue: &mut Q| {
        while let Some(job) = queue.next() {
            let started = match (starts.get(job.start), settings.get(job.settings)) {
                (None, _) => Err(TrackError::NoStartPoint { index: job.start, available: starts.len() }),
                (_, None) => Err(TrackError::NoTrackerSettings { index: job.settings, available: settings.len() }),
                (Some(x0), Some((o, a))) => Path::start(x0, o, a),
            };
            match started {
                Ok(p) => {
                    *slot = Some((job, p));
                    return;
                }
                Err(e) => queue.finished(job, Err(e)),
            }
        }
    };
    let mut x = [Wide::<W, FMA>::default(); N];
    let mut u = [Wide::<W, FMA>::default(); N];
    let mut v = [Wide::<W, FMA>::default(); N];
    loop {
        for slot in slots.iter_mut().filter(|s| s.is_none()) {
            refill(slot, queue);
        }
        let Some(filler) = slots.iter().flatten().next().map(|(_, p)| (p.at, p.at_t)) else {
            break;
        };
        let mut t = [0.0; W];
        for (l, slot) in slots.iter().enumerate() {
            // Idle lanes repeat an active lane's request (finite, discarded).
            let (at, at_t) = slot.as_ref().map_or(filler, |(_, p)| (p.at, p.at_t));
            for i in 0..N {
                x[i].set(l, at[i]);
            }
            t[l] = at_t;
        }
        let mut status = [Factor::Ok; W];
        isa.run(Operation::<P, N, NP, NC, W, FMA> {
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
            let Some((job, path)) = slot.as_mut() else {
                continue;
            };
            let (o, a) = &settings[job.settings];
            let (ul, vl) = (lane_of(&u, l), lane_of(&v, l));
            if let Next::Done(r) = path.feed(&ul, &vl, status[l], o, a) {
                let job = *job;
                *slot = None;
                queue.finished(
                    job,
                    r.map(|mut tr| {
                        tr.residual = h.validation_residual(&tr.x, 1.0);
                        tr
                    }),
                );
            }
        }
    }
}
