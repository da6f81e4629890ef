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
//! `-J_x^-1 dH/dt`. Each lane runs the path state machine of [`super::Tracker`] (module
//! `path`: the same algorithm, the same code) with the Heun or RK4 predictor, one request at a
//! time;
//! a lane whose path ends takes the next start point ([`PathQueue`]: a caller's queue may add
//! paths as results come in). Lanes never mix, so a path's result does
//! not depend on its lane or its neighbours (nor on the thread count when batches run in
//! parallel). Differences from [`super::Tracker`]: the tangent after an accepted step uses
//! `dH/dt` at the last corrector iterate (within the corrector's last update of the accepted
//! point) instead of at the accepted point, and all arithmetic is the path-lane code's (fused
//! multiply-adds where the CPU has them, threshold pivoting), so end points agree to rounding,
//! not bit for bit.

use super::options::{AdaptiveStep, Predictor, StepControl, TrackerOptions};
use super::path::{Eval, Next, TrackerState};
use super::{TrackError, TrackResult, Trouble};
use crate::homotopy::Homotopy;
use crate::lanes::{Kernel, Lanes};
use crate::{CoefficientForm, ParamLanes, PathLanes, RowLanes, RowLayout};
use nalgebra::SVector;
use std::marker::PhantomData;
use thiserror::Error;
use wide::{horner, solve_lanes, Factor, Wide};

mod wide;

use crate::scalar::C;

/// `H(x, t)` for path lanes, in one of two forms:
/// - [`LaneSystem::new`]: `F_c(x; c(t))` with `c(t) = sum_k t^k c_k`, problem `P`'s generated
///   [`PathLanes::row`] on the coefficients of the expansion;
/// - [`LaneSystem::from_parameter_path`]: `F(x; p(t))` with `p(t) = sum_k t^k p_k`,
///   [`ParamLanes::row_params`] on each row's parameters (the unexpanded
///   declaration: fewer inputs per row and shared structure; GRPS7 measured 0.8x the time).
///
/// Either way [`PathLanes::globals`] gives the global equations. Each row's inputs
/// are stored as polynomials in `t`, input-major: entry `(r * per_row + i) * terms + k` is the
/// degree-`k` coefficient of row `r`'s input `i`.
#[derive(Debug, Clone)]
pub struct LaneSystem<P, const N: usize, const NC: usize> {
    c: Vec<C>,
    terms: usize,
    rows: usize,
    per_row: usize,
    epr: usize,
    /// Whether the row inputs are parameters ([`ParamLanes::row_params`]), not coefficients.
    params: bool,
    /// Entries of the parameter kernel's shared part ([`ParamLanes::shared`]).
    shared: usize,
    _problem: PhantomData<fn() -> P>,
}

impl<P, const N: usize, const NC: usize> LaneSystem<P, N, NC> {
    /// The system with coefficients `c(t) = sum_k t^k poly[k]`, or `None` when `P` has no
    /// path-lane kernels ([`CoefficientForm::PATH_LANES`] is `None`), its sizes are
    /// inconsistent, or `poly` is empty.
    pub fn new<const NP: usize>(poly: &[SVector<C, NC>]) -> Option<Self>
    where
        P: CoefficientForm<N, N, NP, NC>,
    {
        let kernels = P::PATH_LANES?;
        let (RowLayout { rows, per_row }, epr) = (kernels.layout(), kernels.equations_per_row());
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
    /// or `None` when `P` has no parameter row kernel ([`CoefficientForm::PARAM_LANES`] is
    /// `None`), its sizes are inconsistent with `NP`, or `poly` is empty.
    pub fn from_parameter_path<const NP: usize>(poly: &[SVector<C, NP>]) -> Option<Self>
    where
        P: CoefficientForm<N, N, NP, NC>,
    {
        let kernels = P::PARAM_LANES?;
        let (RowLayout { rows, .. }, epr, layout) = (kernels.layout(), kernels.equations_per_row(), kernels.param_layout());
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

/// The instruction set of the batch operation, and with it the paths per operation: the
/// crate's one run-time dispatcher, [`crate::lanes::Isa`].
///
/// Why a choice: the operation's arithmetic fills whole vector registers of the CPU (see
/// `wide`), so the width follows the instruction set. [`LaneIsa::detect`] picks the widest
/// available; the others stay selectable ([`track_batch_with`]) to compare and test them on
/// one machine. End points agree across instruction sets to rounding.
pub use crate::lanes::Isa as LaneIsa;

impl LaneIsa {
    /// Paths per operation with AVX-512 (one register per part).
    const WIDE: usize = 8;
    /// Paths per operation with AVX2 and the baseline.
    const NARROW: usize = 4;

    /// Paths per batch operation: 8 with AVX-512, 4 with AVX2 (fused multiply-adds) and the
    /// baseline (unfused arithmetic).
    pub fn width(self) -> usize {
        match self {
            LaneIsa::Avx512 => Self::WIDE,
            LaneIsa::Avx2 | LaneIsa::Baseline => Self::NARROW,
        }
    }
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

impl<P, const N: usize, const NP: usize, const NC: usize, const W: usize, const FMA: bool> Kernel for Operation<'_, P, N, NP, NC, W, FMA>
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
        // A `LaneSystem` of `P` exists only where `P` has path lanes (`LaneSystem::new`), and
        // with `params` only where it has parameter row kernels.
        let Some(kernels) = P::PATH_LANES else {
            return;
        };
        let params = if s.params { P::PARAM_LANES } else { None };
        if let Some(params) = params {
            params.shared(op.x, shared);
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
            match params {
                Some(params) => params.row_params(op.x, &*shared, &*cl, &*dcl, fr, jr, dr),
                None => kernels.row(op.x, &*cl, &*dcl, fr, jr, dr),
            }
        }
        // The global equations from the same kernel value as the rows (`ParamLanes: PathLanes`).
        let g = s.rows * s.epr;
        let (fg, jg) = (&mut f[g..], &mut j.as_flattened_mut()[g * N..]);
        match params {
            Some(params) => params.globals(op.x, fg, jg),
            None => kernels.globals(op.x, fg, jg),
        }
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
fn coefficients<const K: usize, const W: usize, const FMA: bool>(row: &[C], t: &[f64; W], c: &mut [Wide<W, FMA>], dc: &mut [Wide<W, FMA>]) {
    for ((cm, dm), p) in c.iter_mut().zip(dc.iter_mut()).zip(row.chunks_exact(K)) {
        if let Ok(p) = <&[C; K]>::try_from(p) {
            (*cm, *dm) = horner(p, t);
        }
    }
}

/// One lane's path: its job, the path state machine ([`TrackerState`], run exactly as the
/// scalar driver runs it), what the machine asked for, and the tangent that came with its last
/// corrector update (the lanes' answer to [`Eval::TangentAtAccepted`]).
#[derive(Debug, Clone, Copy)]
struct Lane<const N: usize> {
    job: PathJob,
    path: TrackerState<C, N>,
    eval: Eval,
    v: SVector<C, N>,
}

impl<const N: usize> Lane<N> {
    /// Runs the machine on to its next request for the batch operation (answering the ones the
    /// lane answers itself, and starting each next attempt); `false` when the path has ended.
    #[inline]
    fn advance(&mut self, mut next: Next, o: &TrackerOptions) -> bool {
        loop {
            next = match next {
                Next::Eval(Eval::TangentAtAccepted) => self.path.feed(o, true, Ok(self.v)),
                Next::Eval(eval) => {
                    self.eval = eval;
                    return true;
                }
                Next::Ready => self.path.begin_step(o, true),
                Next::Ended => return false,
            }
        }
    }

    /// The ended path's result, with `h`'s validation residual at the end point.
    fn result<H: Homotopy<C, N, N>>(&self, h: &H) -> Result<TrackResult<C, N>, TrackError> {
        self.path.result().map(|mut r| {
            r.residual = h.validation_residual(&r.x, 1.0);
            r
        })
    }
}

/// Whether [`track_batch`] runs `options`: the adaptive tracker without drag steps, with the
/// Heun or the RK4 predictor.
pub fn batch_supported(options: &TrackerOptions) -> bool {
    matches!(options.step, StepControl::Adaptive(AdaptiveStep { drag: None, .. }))
        && matches!(options.predictor, Predictor::Heun | Predictor::Rk4)
}

/// A batch call or job the lanes do not run: misuse of the batch API, never the numerics of a
/// path (those end a path with a [`TrackError`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum BatchError {
    /// The instruction set does not run on this CPU ([`LaneIsa::available`]).
    #[error("the {0:?} instruction set does not run on this CPU")]
    UnavailableIsa(LaneIsa),
    /// Tracker settings the lanes do not run ([`batch_supported`]: fixed or drag steps, or a
    /// predictor other than Heun and RK4).
    #[error("tracker settings {index} are not supported in lanes")]
    UnsupportedSettings {
        /// Index of the settings.
        index: usize,
    },
    /// A job named a start point that does not exist.
    #[error("no start point with index {index} ({available} given)")]
    NoStartPoint {
        /// The requested index.
        index: usize,
        /// How many start points there are.
        available: usize,
    },
    /// A job named tracker settings that do not exist ([`PathJob::settings`] beyond the
    /// settings given to [`track_batch_queue`]).
    #[error("no tracker settings with index {index} ({available} given)")]
    NoTrackerSettings {
        /// The requested index.
        index: usize,
        /// How many settings there are.
        available: usize,
    },
}

/// One path's result in a batch: its end point or why the path was given up.
pub type PathResult<const N: usize> = Result<TrackResult<C, N>, TrackError>;

/// Tracks the start points `starts[i]` for every `i` in `indices` along `system`, several at a
/// time, with `options` (see [`batch_supported`]). Results are in the order of `indices`; `h` —
/// the same homotopy in scalar form — gives each end point's
/// [`Homotopy::validation_residual`]. A [`BatchError`] (unsupported settings, an index beyond
/// `starts`) comes before any tracking. Allocates only its output and a scratch buffer.
pub fn track_batch<P, H, const N: usize, const NP: usize, const NC: usize>(
    system: &LaneSystem<P, N, NC>,
    h: &H,
    starts: &[SVector<C, N>],
    indices: &[usize],
    options: &TrackerOptions,
) -> Result<Vec<PathResult<N>>, BatchError>
where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
{
    track_batch_with(LaneIsa::detect(), system, h, starts, indices, options)
}

/// [`track_batch`] with the batch operation compiled for `isa`
/// ([`BatchError::UnavailableIsa`] when this CPU does not run it).
pub fn track_batch_with<P, H, const N: usize, const NP: usize, const NC: usize>(
    isa: LaneIsa,
    system: &LaneSystem<P, N, NC>,
    h: &H,
    starts: &[SVector<C, N>],
    indices: &[usize],
    options: &TrackerOptions,
) -> Result<Vec<PathResult<N>>, BatchError>
where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
{
    if let Some(&index) = indices.iter().find(|&&i| i >= starts.len()) {
        return Err(BatchError::NoStartPoint { index, available: starts.len() });
    }
    let mut queue = InOrder::new(indices);
    track_batch_queue(isa, system, h, starts, std::slice::from_ref(options), &mut queue)?;
    queue.into_results()
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
    /// The result of a tracked job that [`PathQueue::next`] returned.
    fn finished(&mut self, job: PathJob, result: PathResult<N>);
    /// A job that [`PathQueue::next`] returned and that was not tracked: its start point or
    /// settings index does not exist.
    fn refused(&mut self, job: PathJob, error: BatchError);
}

/// The queue of [`track_batch_with`]: the start points `indices` in order, all with settings
/// `0`, each job's `id` its position in `indices`; results kept by position.
#[derive(Debug, Clone)]
pub struct InOrder<'a, const N: usize> {
    indices: &'a [usize],
    next: usize,
    results: Vec<Option<PathResult<N>>>,
    refused: Option<BatchError>,
}

impl<'a, const N: usize> InOrder<'a, N> {
    /// The jobs for `indices`, none handed out yet.
    pub fn new(indices: &'a [usize]) -> Self {
        Self { indices, next: 0, results: vec![None; indices.len()], refused: None }
    }

    /// The start indices, by job `id`.
    pub fn indices(&self) -> &'a [usize] {
        self.indices
    }

    /// The result of job `id`, if it has finished.
    pub fn result(&self, id: usize) -> Option<&PathResult<N>> {
        self.results.get(id)?.as_ref()
    }

    /// The results in the order of `indices` (a job never handed out, which tracking to the
    /// end does not leave: `NonFinite` at `t = 0`), or the first refused job's error.
    pub fn into_results(self) -> Result<Vec<PathResult<N>>, BatchError> {
        if let Some(e) = self.refused {
            return Err(e);
        }
        Ok(self.results.into_iter().map(|r| r.unwrap_or(Err(TrackError::NonFinite { t: 0.0 }))).collect())
    }
}

impl<const N: usize> PathQueue<N> for InOrder<'_, N> {
    fn next(&mut self) -> Option<PathJob> {
        let id = self.next;
        let start = *self.indices.get(id)?;
        self.next += 1;
        Some(PathJob { id, start, settings: 0 })
    }

    fn finished(&mut self, job: PathJob, result: PathResult<N>) {
        if let Some(slot) = self.results.get_mut(job.id) {
            *slot = Some(result);
        }
    }

    fn refused(&mut self, _job: PathJob, error: BatchError) {
        self.refused.get_or_insert(error);
    }
}

/// Tracks the paths that `queue` hands out along `system`, one per lane of `isa`'s batch
/// operation (see [`track_batch`]), each with its job's entry of `settings`. Fails without
/// tracking when `isa` does not run on this CPU or some entry of `settings` is not
/// [`batch_supported`]. A job whose start point or settings index does not exist goes back to
/// [`PathQueue::refused`]; the other jobs are tracked.
pub fn track_batch_queue<P, H, Q, const N: usize, const NP: usize, const NC: usize>(
    isa: LaneIsa,
    system: &LaneSystem<P, N, NC>,
    h: &H,
    starts: &[SVector<C, N>],
    settings: &[TrackerOptions],
    queue: &mut Q,
) -> Result<(), BatchError>
where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
    Q: PathQueue<N>,
{
    if !isa.available() {
        return Err(BatchError::UnavailableIsa(isa));
    }
    if let Some(index) = settings.iter().position(|o| !batch_supported(o)) {
        return Err(BatchError::UnsupportedSettings { index });
    }
    let run = (system, h, starts, settings, isa);
    match isa {
        LaneIsa::Avx512 => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::WIDE }, true>(run, queue),
        LaneIsa::Avx2 => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::NARROW }, true>(run, queue),
        LaneIsa::Baseline => track_lanes::<P, H, Q, N, NP, NC, { LaneIsa::NARROW }, false>(run, queue),
    }
    Ok(())
}

/// The arguments of [`track_lanes`].
type Run<'a, P, H, const N: usize, const NC: usize> = (&'a LaneSystem<P, N, NC>, &'a H, &'a [SVector<C, N>], &'a [TrackerOptions], LaneIsa);

/// [`track_batch_queue`] with `W` paths per operation and fused (`FMA`) or plain arithmetic:
/// the lane driver of the path state machine.
fn track_lanes<P, H, Q, const N: usize, const NP: usize, const NC: usize, const W: usize, const FMA: bool>(
    (system, h, starts, settings, isa): Run<'_, P, H, N, NC>,
    queue: &mut Q,
) where
    P: CoefficientForm<N, N, NP, NC>,
    H: Homotopy<C, N, N>,
    Q: PathQueue<N>,
{
    let mut slots: [Option<Lane<N>>; W] = [None; W];
    let mut scratch = vec![Wide::<W, FMA>::default(); 2 * system.per_row + system.shared];
    // Fills a free lane with the queue's next path that starts cleanly.
    let refill = |slot: &mut Option<Lane<N>>, queue: &mut Q| {
        while let Some(job) = queue.next() {
            let (x0, o) = match (starts.get(job.start), settings.get(job.settings)) {
                (None, _) => {
                    queue.refused(job, BatchError::NoStartPoint { index: job.start, available: starts.len() });
                    continue;
                }
                (_, None) => {
                    let e = BatchError::NoTrackerSettings { index: job.settings, available: settings.len() };
                    queue.refused(job, e);
                    continue;
                }
                (Some(x0), Some(o)) => (x0, o),
            };
            let mut lane = Lane { job, path: TrackerState::new(true), eval: Eval::Tangent, v: SVector::zeros() };
            let next = lane.path.start(x0, o);
            if lane.advance(next, o) {
                *slot = Some(lane);
                return;
            }
            queue.finished(job, lane.result(h));
        }
    };
    let mut x = [Wide::<W, FMA>::default(); N];
    let mut u = [Wide::<W, FMA>::default(); N];
    let mut v = [Wide::<W, FMA>::default(); N];
    loop {
        for slot in slots.iter_mut().filter(|s| s.is_none()) {
            refill(slot, queue);
        }
        let Some(filler) = slots.iter().flatten().next().map(|lane| lane.path.at()).map(|(at, t)| (*at, t)) else {
            break;
        };
        let mut t = [0.0; W];
        for (l, slot) in slots.iter().enumerate() {
            // Idle lanes repeat an active lane's request (finite, discarded).
            let (at, at_t) = slot.as_ref().map_or((&filler.0, filler.1), |lane| lane.path.at());
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
            let Some(lane) = slot.as_mut() else {
                continue;
            };
            let o = &settings[lane.job.settings];
            let result = match status[l] {
                Factor::Ok if lane.eval == Eval::Update => {
                    lane.v = lane_of(&v, l);
                    Ok(lane_of(&u, l))
                }
                Factor::Ok => Ok(lane_of(&v, l)),
                Factor::Singular => Err(Trouble::Singular),
                Factor::NonFinite => Err(Trouble::NonFinite),
            };
            let next = lane.path.feed(o, true, result);
            if !lane.advance(next, o) {
                let (job, result) = (lane.job, lane.result(h));
                *slot = None;
                queue.finished(job, result);
            }
        }
    }
}
