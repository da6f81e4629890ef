//! All-roots solving by a complex parameter homotopy from a stored start system (the "CPU HC"
//! baseline of the paper), after HomotopyContinuation.jl's
//! `solve(F, starts; start_parameters, target_parameters)`.
//!
//! A [`StartSystem`] is a generic complex instance `p*` with all its isolated solutions (one per
//! symmetry orbit), found once by [`crate::monodromy`]. To solve a (real) target `p`, every start
//! solution is tracked in `Complex<f64>` along `p(t) = (1-t) p* + t p + t (1-t) b`:
//! - `b = 0` (default): the straight segment. `p*` is random complex, which is what the gamma
//!   trick provides: for almost every `p*` no path meets a singular instance for `t < 1`, and
//!   every isolated solution of the target is the end point of some path (coefficient-parameter
//!   homotopy, Sommese-Wampler Thm. 7.1.1);
//! - `bend > 0`: additionally a seeded random complex bend `b` of size `bend |p - p*|`, the
//!   gamma trick drawn afresh per solve ([`AllRootsOptions::bend`]).
//!
//! End points are classified as real when every imaginary part is at most `real_tolerance`
//! (relative), polished by real Newton on the target, and returned sorted by residual. Paths run
//! sequentially or in parallel (rayon); the result does not depend on the thread count.

use crate::homotopy::{real_if_close, to_complex, Homotopy, ParameterHomotopy};
use crate::lanes::{C64x4, Lanes, LANES};
use crate::monodromy::{relative_distance, SignFlip, C};
use crate::tracker::batch::{batch_supported, track_batch_queue, LaneIsa, LaneSystem};
use crate::tracker::{newton, track, AdaptiveStep, NewtonOptions, Predictor, StepControl, TrackError, TrackStats, TrackerOptions};
use crate::{CoefficientForm, ParamDerivative, ParamLanes, RowLanes, RowLayout};
use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
pub use repair::{suspicious_paths, EndPoint};
use repair::{PathResult, RepairQueue};

mod repair;

/// A generic complex instance `p*` and its solutions (one representative per orbit of
/// `symmetry`).
#[derive(Debug, Clone)]
pub struct StartSystem<const N: usize, const NP: usize> {
    /// The start parameters `p*`.
    pub params: SVector<C, NP>,
    /// The solutions of `F(.; p*) = 0`.
    pub solutions: Vec<SVector<C, N>>,
    /// The sign symmetry the solutions are taken modulo, if any.
    pub symmetry: Option<SignFlip>,
}

impl<const N: usize, const NP: usize> StartSystem<N, NP> {
    /// Max-norm residual `max |F(x; p*)|` over the start solutions.
    pub fn max_residual<P: ParamDerivative<N, N, NP>>(&self) -> f64 {
        let mut f = SVector::<C, N>::zeros();
        self.solutions
            .iter()
            .map(|x| {
                P::residual(x, &self.params, &mut f);
                f.iter().map(|z| z.norm()).fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    }
}

/// Settings of [`solve_all`].
#[derive(Debug, Clone, Copy)]
pub struct AllRootsOptions {
    /// Path tracker settings. Default: [`all_roots_tracker`].
    pub tracker: TrackerOptions,
    /// Size of the random complex bend of the parameter path relative to `|p - p*|`; `0`
    /// (default) tracks the straight segment (see the module docs).
    pub bend: f64,
    /// Seed of the bend direction. Default `0`.
    pub seed: u64,
    /// An end point is real when every `|Im x_i| <= real_tolerance * max(1, |x_i|)`.
    /// Default `1e-6`.
    pub real_tolerance: f64,
    /// Real end points are polished by this many real Newton iterations on the target (`0`:
    /// none). Default `2`.
    pub polish_iterations: usize,
    /// Track in parallel with rayon. Default `false`.
    pub parallel: bool,
    /// Track several paths at a time, one per SIMD lane ([`crate::tracker::batch`]; 8 with
    /// AVX-512, 4 otherwise), when the problem has path-lane code
    /// ([`CoefficientForm::PATH_LANES`], via [`solve_all_fast`]) and the tracker settings allow
    /// it ([`batch_supported`]); otherwise, and with `false`, one path at a time. Default `true`.
    pub batch: bool,
    /// The instruction set of the batch tracker ([`LaneIsa`]); `None` (default): the widest
    /// this CPU runs. One this CPU does not run tracks one path at a time.
    pub lane_isa: Option<LaneIsa>,
    /// The batch tracker's row kernel: `true` (default) evaluates each row from its parameters
    /// `p(t)` ([`ParamLanes::row_params`], the unexpanded declaration) where the
    /// problem has it and solvergen estimates it cheaper ([`crate::ParamRowLayout::preferred`]),
    /// `false` always from the coefficients of the expansion
    /// ([`crate::PathLanes::row`]). The same paths either way, to rounding (GRPS7: 0.8x the
    /// time with parameters); `false` is there to compare them.
    pub param_lanes: bool,
    /// Path-jump repair: paths that failed or whose end points coincide with another path's
    /// (relative distance below `duplicate_tolerance`, modulo the symmetry) are tracked again
    /// with these stricter settings, up to `retrack_rounds` times (each round halves the largest
    /// step). Two paths of a parameter homotopy from a generic start never meet before `t = 1`,
    /// so coinciding regular end points mean that one path jumped onto another (losing a root);
    /// coinciding singular end points (a multiple root of the target) stay duplicated. With the
    /// batch tracker the first round runs inside the main pass: a path is re-tracked as soon as
    /// it is known to be suspicious, in lanes that would otherwise idle (the same paths as
    /// after the pass, so the result is the same). `None` disables the repair. Default:
    /// [`strict_tracker`].
    pub retrack: Option<TrackerOptions>,
    /// Rounds of the path-jump repair. Default `2`.
    pub retrack_rounds: usize,
    /// End points closer than this (relative max-norm) are the same. Default `1e-8`.
    pub duplicate_tolerance: f64,
}

/// The all-roots tracker: the adaptive tracker ([`TrackerOptions::default`], faithful, no drag
/// steps) with the Heun predictor and the end-point tolerance [`ALL_ROOTS_FINAL_TOLERANCE`].
/// Calibration (GRPS7 from the shipped start, 200 noise-free scenes, this machine): RK4 146 ms
/// per solve, Heun about 25 % less at the same success (every ground truth found, with the
/// path-jump repair); Heun needs more but cheaper steps, and the complex evaluation of `J_x` and
/// `dH/dt` dominates the cost.
pub fn all_roots_tracker() -> TrackerOptions {
    TrackerOptions { predictor: Predictor::Heun, final_tolerance: ALL_ROOTS_FINAL_TOLERANCE, ..TrackerOptions::default() }
}

/// The estimated relative error an end point must reach at `t = 1` in an all-roots solve:
/// `1e-10`. Why not the tracker's default `1e-12`: many targets have complex solutions of
/// large modulus that are ill-conditioned (GRPS7: `|x|` about `1e3`, condition number
/// `1e7`-`1e8`), where double precision stalls near `1e-12` and the point counted as a failed
/// path that the repair then re-tracked twice, mostly in vain (measured, 200 noise-free GRPS7
/// solves: 145 of 28000 paths failed after the repair with `1e-12`, 5 with `1e-10`). `1e-10` is
/// still far below what the results need: [`AllRootsOptions::duplicate_tolerance`] (`1e-8`)
/// and [`AllRootsOptions::real_tolerance`] (`1e-6`); real solutions are polished on the target.
pub const ALL_ROOTS_FINAL_TOLERANCE: f64 = 1e-10;

/// The tracker for re-tracking suspicious paths: the adaptive tracker with a tighter
/// contraction test, path-jump guard and largest step (`0.1`), the RK4 predictor, and the
/// all-roots end-point tolerance.
pub fn strict_tracker() -> TrackerOptions {
    TrackerOptions {
        final_tolerance: ALL_ROOTS_FINAL_TOLERANCE,
        ..TrackerOptions::adaptive(AdaptiveStep {
            initial: 0.02,
            max: 0.1,
            max_contraction: 0.1,
            max_relative_correction: 0.1,
            target_contraction: 0.02,
            ..AdaptiveStep::default()
        })
    }
}

impl Default for AllRootsOptions {
    fn default() -> Self {
        Self {
            tracker: all_roots_tracker(),
            bend: 0.0,
            seed: 0,
            real_tolerance: 1e-6,
            polish_iterations: 2,
            parallel: false,
            batch: true,
            lane_isa: None,
            param_lanes: true,
            retrack: Some(strict_tracker()),
            retrack_rounds: 2,
            duplicate_tolerance: 1e-8,
        }
    }
}

/// A real solution of the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealSolution<const N: usize> {
    /// The solution (canonical representative of its symmetry orbit).
    pub x: SVector<f64, N>,
    /// `max |F(x; p)|` on the target.
    pub residual: f64,
    /// Index of the start solution whose path ended here.
    pub path: usize,
}

/// The outcome of [`solve_all`].
#[derive(Debug, Clone)]
pub struct AllRootsResult<const N: usize> {
    /// End point of every path (`Err` for failed paths), in start-solution order.
    pub endpoints: Vec<Result<SVector<C, N>, TrackError>>,
    /// The real end points, polished, sorted by residual (smallest first).
    pub real: Vec<RealSolution<N>>,
    /// Summed work counters of the successful paths (last attempt of re-tracked ones).
    pub stats: TrackStats,
    /// Number of failed paths.
    pub failed: usize,
    /// The symmetry of the start system (for [`AllRootsResult::closest_real`]).
    pub symmetry: Option<SignFlip>,
    /// Paths tracked again by the path-jump repair ([`AllRootsOptions::retrack`]).
    pub retracked: usize,
    /// Successful paths whose end point still coincides with another's after the repair
    /// (multiple roots of the target, or unrepaired jumps).
    pub duplicates: usize,
}

impl<const N: usize> AllRootsResult<N> {
    /// The real solution closest to `x` (relative max-norm, modulo the symmetry): the
    /// benchmark's "best real solution" against the ground truth.
    pub fn closest_real(&self, x: &SVector<f64, N>) -> Option<(&RealSolution<N>, f64)> {
        let gx = self.symmetry.as_ref().map(|g| g.apply(x));
        self.real
            .iter()
            .map(|s| {
                let mut d = relative_distance(x, &s.x);
                if let Some(gx) = &gx {
                    d = d.min(relative_distance(gx, &s.x));
                }
                (s, d)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The real solution with the smallest `score` (a selection criterion, e.g. a reprojection
    /// error or the distance to the ground truth).
    pub fn best_real_by<F: Fn(&RealSolution<N>) -> f64>(&self, score: F) -> Option<&RealSolution<N>> {
        self.real.iter().map(|s| (s, score(s))).min_by(|a, b| a.1.total_cmp(&b.1)).map(|(s, _)| s)
    }

    /// Number of finite (successful) end points.
    pub fn finite(&self) -> usize {
        self.endpoints.len() - self.failed
    }
}

/// The parameter path of one solve, to `p1` (the target or an equivalent point).
fn homotopy_for<P, const N: usize, const NP: usize>(
    start: &StartSystem<N, NP>,
    p1: SVector<C, NP>,
    options: &AllRootsOptions,
) -> ParameterHomotopy<P, C, NP>
where
    P: ParamDerivative<N, N, NP>,
{
    if options.bend > 0.0 {
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
        let mut b = crate::monodromy::random_complex_vector::<NP>(&mut rng, 1.0);
        let len = (p1 - start.params).norm();
        let bn = b.norm();
        if bn > 0.0 {
            b *= C::new(options.bend * len / bn, 0.0);
        }
        ParameterHomotopy::with_bend(start.params, p1, b)
    } else {
        ParameterHomotopy::new(start.params, p1)
    }
}

/// Tracks every start solution to the real target `p` along a [`ParameterHomotopy`] and
/// returns all end points and the real solutions (see the module docs). Works for any square
/// [`ParamDerivative`]; [`solve_all_fast`] is the same path at a lower cost per step for
/// problems with a [`CoefficientForm`].
pub fn solve_all<P, const N: usize, const NP: usize>(
    start: &StartSystem<N, NP>,
    target: &SVector<f64, NP>,
    options: &AllRootsOptions,
) -> AllRootsResult<N>
where
    P: ParamDerivative<N, N, NP>,
{
    let h = homotopy_for::<P, N, NP>(start, to_complex(target), options);
    solve_along::<P, _, N, NP>(&h, start, target, options, None)
}

/// [`solve_all`] with `dH/dt` from the coefficient form ([`CoefficientParameterHomotopy`]):
/// the same paths, cheaper steps. Falls back to [`solve_all`] when the coefficients are not
/// polynomials of degree at most [`MAX_COEFFICIENT_DEGREE`] along the path.
pub fn solve_all_fast<P, const N: usize, const NP: usize, const NC: usize>(
    start: &StartSystem<N, NP>,
    target: &SVector<f64, NP>,
    options: &AllRootsOptions,
) -> AllRootsResult<N>
where
    P: ParamDerivative<N, N, NP> + CoefficientForm<N, N, NP, NC>,
{
    solve_all_fast_via::<P, N, NP, NC>(start, target, &to_complex(target), options)
}

/// [`solve_all_fast`] along the segment to `equivalent`, a complex parameter point whose system
/// has the same solutions as the target's (`F(x; equivalent) = D F(x; target)` with `D`
/// invertible and independent of `x`, e.g. rescaled equations). Problems whose parameters have
/// such redundancy (GRPS: the scale of each bearing) pick the representative closest to the
/// start system, which shortens the paths; real end points are still polished on `target`.
pub fn solve_all_fast_via<P, const N: usize, const NP: usize, const NC: usize>(
    start: &StartSystem<N, NP>,
    target: &SVector<f64, NP>,
    equivalent: &SVector<C, NP>,
    options: &AllRootsOptions,
) -> AllRootsResult<N>
where
    P: ParamDerivative<N, N, NP> + CoefficientForm<N, N, NP, NC>,
{
    let base = homotopy_for::<P, N, NP>(start, *equivalent, options);
    let Some(h) = CoefficientParameterHomotopy::<P, NP, NC>::new::<N>(base) else {
        return solve_along::<P, _, N, NP>(&base, start, target, options, None);
    };
    let isa = options.lane_isa.unwrap_or_else(LaneIsa::detect);
    let lanes = if options.batch && batch_supported(&options.tracker) && isa.available() {
        (options.param_lanes && P::PARAM_LANES.is_some_and(|kernels| kernels.param_layout().preferred))
            .then(|| LaneSystem::<P, N, NC>::from_parameter_path::<NP>(&h.parameter_path().param_poly()))
            .flatten()
            .or_else(|| LaneSystem::<P, N, NC>::new::<NP>(h.coefficient_poly()))
    } else {
        None
    };
    match lanes {
        Some(system) => {
            // The main pass with the repair's first round streamed in (`repair`), or one round.
            let batch = |indices: &[usize], opts: &TrackerOptions, repair: Option<&TrackerOptions>| {
                let settings: Vec<TrackerOptions> = std::iter::once(*opts).chain(repair.copied()).collect();
                let run = |part: &[usize]| {
                    let mut queue = RepairQueue::new(part, repair.is_some(), start.symmetry.as_ref(), options.duplicate_tolerance);
                    // The jobs are valid by construction; a declined call falls back to one path
                    // at a time.
                    track_batch_queue(isa, &system, &h, &start.solutions, &settings, &mut queue).and_then(|()| queue.into_results()).ok()
                };
                if options.parallel {
                    let parts = rayon::current_num_threads().max(1);
                    let size = indices.len().div_ceil(parts).max(1);
                    let done: Option<Vec<_>> = indices.par_chunks(size).map(run).collect();
                    done.map(|done| {
                        let (mut main, mut retracked) = (Vec::new(), Vec::new());
                        for (m, r) in done {
                            main.extend(m);
                            retracked.extend(r);
                        }
                        (main, retracked)
                    })
                } else {
                    run(indices)
                }
            };
            solve_along::<P, _, N, NP>(&h, start, target, options, Some(&batch))
        }
        None => solve_along::<P, _, N, NP>(&h, start, target, options, None),
    }
}

/// Tracks the start solutions of the given indices with the given settings in path lanes;
/// with repair settings, also re-tracks the suspicious ones ([`repair::RepairQueue`]). Returns
/// the results in the order of the indices and the re-tracks (start index, result), or `None`
/// when the lanes do not run the settings.
type BatchTracking<'a, const N: usize> =
    dyn Fn(&[usize], &TrackerOptions, Option<&TrackerOptions>) -> Option<(Vec<PathResult<N>>, Vec<(usize, PathResult<N>)>)> + Sync + 'a;

/// The settings of each round of the path-jump repair: [`AllRootsOptions::retrack`], the
/// largest step halved from one round to the next.
fn repair_rounds(options: &AllRootsOptions) -> Vec<TrackerOptions> {
    let Some(mut opts) = options.retrack else {
        return Vec::new();
    };
    (0..options.retrack_rounds)
        .map(|_| {
            let round = opts;
            if let StepControl::Adaptive(a) = &mut opts.step {
                a.max *= 0.5;
                a.initial = a.initial.min(a.max);
            }
            round
        })
        .collect()
}

/// Tracks all start solutions along `h` (sequentially or with rayon) and collects the result.
fn solve_along<P, H, const N: usize, const NP: usize>(
    h: &H,
    start: &StartSystem<N, NP>,
    target: &SVector<f64, NP>,
    options: &AllRootsOptions,
    batch: Option<&BatchTracking<'_, N>>,
) -> AllRootsResult<N>
where
    P: ParamDerivative<N, N, NP>,
    H: Homotopy<C, N, N> + Sync,
{
    let one_by_one = |indices: &[usize], opts: &TrackerOptions| -> Vec<_> {
        let one = |&i: &usize| track(h, &start.solutions[i], opts);
        if options.parallel {
            indices.par_iter().map(one).collect()
        } else {
            indices.iter().map(one).collect()
        }
    };
    let lanes = |opts: &TrackerOptions| batch.filter(|_| batch_supported(opts));
    let rounds = repair_rounds(options);
    let all: Vec<usize> = (0..start.solutions.len()).collect();
    let streamed = rounds.first().filter(|o| batch_supported(o));
    let (mut results, mut early) = match lanes(&options.tracker).and_then(|b| b(&all, &options.tracker, streamed)) {
        Some(done) => done,
        None => (one_by_one(&all, &options.tracker), Vec::new()),
    };
    let mut retracked = 0;
    for (round, opts) in rounds.iter().enumerate() {
        let suspects = suspicious_paths(&results, start.symmetry.as_ref(), options.duplicate_tolerance);
        if suspects.is_empty() {
            break;
        }
        retracked += suspects.len();
        // First round: take the re-tracks the main pass already did, track the rest.
        let mut again: Vec<Option<PathResult<N>>> = vec![None; suspects.len()];
        if round == 0 {
            for (i, r) in early.drain(..) {
                if let Ok(pos) = suspects.binary_search(&i) {
                    again[pos] = Some(r);
                }
            }
        }
        let rest: Vec<usize> = suspects.iter().zip(&again).filter(|(_, r)| r.is_none()).map(|(&i, _)| i).collect();
        let rest_results = match lanes(opts).and_then(|b| b(&rest, opts, None)) {
            Some((done, _)) => done,
            None => one_by_one(&rest, opts),
        };
        let mut rest_results = rest_results.into_iter();
        for (&i, r) in suspects.iter().zip(again) {
            let Some(r) = r.or_else(|| rest_results.next()) else { continue };
            // Keep a success over a failure.
            if r.is_ok() || results[i].is_err() {
                results[i] = r;
            }
        }
    }
    let mut result = finish::<P, N, NP>(results, target, options, start.symmetry.clone());
    result.retracked = retracked;
    result.duplicates = suspicious_paths(&result.endpoints, start.symmetry.as_ref(), options.duplicate_tolerance)
        .iter()
        .filter(|&&i| result.endpoints[i].is_ok())
        .count();
    result
}

/// Largest degree in `t` of the coefficients `c(p(t))` that [`CoefficientParameterHomotopy`]
/// interpolates.
pub const MAX_COEFFICIENT_DEGREE: usize = 4;

/// The parameter homotopy `H(x, t) = F(x; p(t))` of a [`ParameterHomotopy`], with
/// `dH/dt = dFc/dc (x) * dc(p(t))/dt` taken from the coefficient form instead of
/// [`ParamDerivative::param_directional`].
///
/// Along a straight or bent parameter path (`p(t)` quadratic in `t`) the coefficients `c(p(t))`
/// are polynomials in `t` (degree `deg c` on a straight segment, `2 deg c` with a bend); they
/// are interpolated once per solve at `MAX_COEFFICIENT_DEGREE + 1` equispaced points and
/// checked at one more, so `dc/dt` costs a short Horner loop and `dH/dt` one evaluation of
/// [`CoefficientForm::coefficient_part`] (GRPS7: 0.6 us against 5.3 us in `Complex<f64>`).
/// `H` and `J_x` still come from the parameter form (cheaper than the coefficient form there).
pub struct CoefficientParameterHomotopy<P, const NP: usize, const NC: usize> {
    base: ParameterHomotopy<P, C, NP>,
    /// `c(t) = sum_k c[k] t^k`.
    c: Vec<SVector<C, NC>>,
    /// `dc/dt = sum_k dc[k] t^k`.
    dc: Vec<SVector<C, NC>>,
    /// The same polynomial in the row-lane layout of [`RowLanes::coefficient_part_poly`]
    /// (empty when the problem has no row kernels).
    dc_lanes: Vec<C64x4>,
}

impl<P, const NP: usize, const NC: usize> std::fmt::Debug for CoefficientParameterHomotopy<P, NP, NC> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CoefficientParameterHomotopy").field("base", &self.base).field("degree", &self.dc.len()).finish()
    }
}

impl<P, const NP: usize, const NC: usize> CoefficientParameterHomotopy<P, NP, NC> {
    /// Interpolates `c(p(t))` for the path of `base`; `None` if its degree exceeds
    /// [`MAX_COEFFICIENT_DEGREE`] (checked at an extra point).
    pub fn new<const N: usize>(base: ParameterHomotopy<P, C, NP>) -> Option<Self>
    where
        P: ParamDerivative<N, N, NP> + CoefficientForm<N, N, NP, NC>,
    {
        const D: usize = MAX_COEFFICIENT_DEGREE;
        let ts: [f64; D + 1] = std::array::from_fn(|j| j as f64 / D as f64);
        let mut samples = Vec::with_capacity(D + 1);
        for &t in &ts {
            let mut c = SVector::<C, NC>::zeros();
            P::coefficients(&base.params_at(t), &mut c);
            samples.push(c);
        }
        // Newton's divided differences, then the monomial coefficients.
        let mut dd = samples.clone();
        for k in 1..=D {
            for j in (k..=D).rev() {
                let inv = C::new(1.0 / (ts[j] - ts[j - k]), 0.0);
                dd[j] = (dd[j] - dd[j - 1]) * inv;
            }
        }
        // Newton form to monomial form: a(t) = dd[0] + (t - t0)(dd[1] + (t - t1)(...)).
        let mut a = [SVector::<C, NC>::zeros(); D + 1];
        for j in (0..=D).rev() {
            // a <- a * (t - ts[j]) + dd[j]
            for k in (1..=D).rev() {
                a[k] = a[k - 1] - a[k] * C::new(ts[j], 0.0);
            }
            a[0] = dd[j] - a[0] * C::new(ts[j], 0.0);
        }
        // Check at an extra point.
        let tc = 0.377;
        let mut c = SVector::<C, NC>::zeros();
        P::coefficients(&base.params_at(tc), &mut c);
        let mut e = a[D];
        for k in (0..D).rev() {
            e = e * C::new(tc, 0.0) + a[k];
        }
        let scale = samples.iter().map(|s| s.camax()).fold(1.0, f64::max);
        if (e - c).camax() > 1e-9 * scale {
            return None;
        }
        let mut dc: Vec<SVector<C, NC>> = (1..=D).map(|k| a[k] * C::new(k as f64, 0.0)).collect();
        while dc.len() > 1 && dc.last().is_some_and(|v| v.camax() <= 1e-13 * scale) {
            dc.pop();
        }
        let dc_lanes = match P::ROW_LANES.map(RowLanes::layout) {
            Some(RowLayout { rows, per_row }) if rows * per_row == NC && rows > 0 => {
                let chunks = rows.div_ceil(LANES);
                let mut lanes = vec![C64x4::default(); dc.len() * chunks * per_row];
                for (k, dck) in dc.iter().enumerate() {
                    for r in 0..rows {
                        let (chunk, lane) = (r / LANES, r % LANES);
                        for m in 0..per_row {
                            lanes[(k * chunks + chunk) * per_row + m].set(lane, dck[r * per_row + m]);
                        }
                    }
                }
                lanes
            }
            _ => Vec::new(),
        };
        let mut c = a.to_vec();
        while c.len() > 1 && c.last().is_some_and(|v| v.camax() <= 1e-13 * scale) {
            c.pop();
        }
        Some(Self { base, c, dc, dc_lanes })
    }

    /// The coefficients along the path, `c(t) = sum_k t^k poly[k]`.
    pub fn coefficient_poly(&self) -> &[SVector<C, NC>] {
        &self.c
    }

    /// The parameter path the coefficients follow.
    pub fn parameter_path(&self) -> &ParameterHomotopy<P, C, NP> {
        &self.base
    }

    /// `dH/dt` at `(x, t)`.
    #[inline]
    fn dh_dt<const N: usize>(&self, x: &SVector<C, N>, t: f64, dh: &mut SVector<C, N>)
    where
        P: ParamDerivative<N, N, NP> + CoefficientForm<N, N, NP, NC>,
    {
        match P::ROW_LANES {
            Some(kernel) if !self.dc_lanes.is_empty() => kernel.coefficient_part_poly(x, t, &self.dc_lanes, dh),
            _ => P::coefficient_part(x, &self.dc_at(t), dh),
        }
    }

    /// `dc/dt (t)` by Horner in the real `t` (real scalings over plain slices, which
    /// vectorize; nalgebra's strided iterators did not).
    #[inline]
    fn dc_at(&self, t: f64) -> SVector<C, NC> {
        let mut v = self.dc[self.dc.len() - 1];
        for k in (0..self.dc.len() - 1).rev() {
            for (vi, di) in v.as_mut_slice().iter_mut().zip(self.dc[k].as_slice()) {
                *vi = C::new(vi.re * t + di.re, vi.im * t + di.im);
            }
        }
        v
    }
}

impl<P, const N: usize, const NP: usize, const NC: usize> Homotopy<C, N, N> for CoefficientParameterHomotopy<P, NP, NC>
where
    P: ParamDerivative<N, N, NP> + CoefficientForm<N, N, NP, NC>,
{
    #[inline]
    fn evaluate(&self, x: &SVector<C, N>, t: f64, h: &mut SVector<C, N>, jx: &mut SMatrix<C, N, N>) {
        P::residual_jacobian(x, &self.base.params_at(t), h, jx);
    }

    #[inline]
    fn dt(&self, x: &SVector<C, N>, t: f64, dh: &mut SVector<C, N>) {
        self.dh_dt(x, t, dh);
    }

    #[inline]
    fn residual(&self, x: &SVector<C, N>, t: f64, h: &mut SVector<C, N>) {
        P::residual(x, &self.base.params_at(t), h);
    }

    #[inline]
    fn jacobian_dt(&self, x: &SVector<C, N>, t: f64, jx: &mut SMatrix<C, N, N>, dh: &mut SVector<C, N>) {
        P::jacobian(x, &self.base.params_at(t), jx);
        self.dh_dt(x, t, dh);
    }
}

/// Collects the path results: statistics, real end points (polished, canonical, sorted).
fn finish<P, const N: usize, const NP: usize>(
    results: Vec<Result<crate::tracker::TrackResult<C, N>, TrackError>>,
    target: &SVector<f64, NP>,
    options: &AllRootsOptions,
    symmetry: Option<SignFlip>,
) -> AllRootsResult<N>
where
    P: ParamDerivative<N, N, NP>,
{
    let mut stats = TrackStats::default();
    let mut failed = 0;
    let mut real = Vec::new();
    let fixed = crate::homotopy::FixedSystem::<P, f64, NP>::new(*target);
    let newton_options = NewtonOptions { max_iterations: options.polish_iterations, ..NewtonOptions::default() };
    let endpoints = results
        .into_iter()
        .enumerate()
        .map(|(i, r)| match r {
            Ok(r) => {
                stats.accepted_steps += r.stats.accepted_steps;
                stats.rejected_steps += r.stats.rejected_steps;
                stats.newton_iterations += r.stats.newton_iterations;
                stats.factorizations += r.stats.factorizations;
                stats.drag_steps += r.stats.drag_steps;
                if let Some(mut xr) = real_if_close(&r.x, options.real_tolerance) {
                    if options.polish_iterations > 0 {
                        if let Ok(n) = newton::<f64, _, N, N>(&fixed, &xr, 1.0, &newton_options) {
                            if n.residual <= fixed.validation_residual(&xr, 1.0) {
                                xr = n.x;
                            }
                        }
                    }
                    if let Some(g) = &symmetry {
                        xr = g.canonical(&xr);
                    }
                    let residual = fixed.validation_residual(&xr, 1.0);
                    real.push(RealSolution { x: xr, residual, path: i });
                }
                Ok(r.x)
            }
            Err(e) => {
                failed += 1;
                Err(e)
            }
        })
        .collect();
    real.sort_by(|a, b| a.residual.total_cmp(&b.residual));
    AllRootsResult { endpoints, real, stats, failed, symmetry, retracked: 0, duplicates: 0 }
}

/// Moves a start system to new complex parameters `params` by tracking every solution along the
/// straight complex segment (both ends generic, so no path is singular with probability one).
/// Returns the moved system and the number of paths that failed (their solutions are missing:
/// recover them with [`crate::monodromy::monodromy_from`]). End points are deduplicated modulo
/// the symmetry with relative tolerance `1e-6`.
pub fn move_start_system<P, const N: usize, const NP: usize>(
    start: &StartSystem<N, NP>,
    params: &SVector<C, NP>,
    options: &AllRootsOptions,
) -> (StartSystem<N, NP>, usize)
where
    P: ParamDerivative<N, N, NP>,
{
    let h = ParameterHomotopy::<P, C, NP>::new(start.params, *params);
    let one = |x: &SVector<C, N>| track(&h, x, &options.tracker);
    let results: Vec<_> =
        if options.parallel { start.solutions.par_iter().map(one).collect() } else { start.solutions.iter().map(one).collect() };
    let mut set = crate::monodromy::SolutionSet::<N>::new(start.symmetry.clone(), 1e-6);
    let mut failed = 0;
    for r in results {
        match r {
            Ok(r) => {
                set.insert(&r.x);
            }
            Err(_) => failed += 1,
        }
    }
    failed += start.solutions.len() - failed - set.len();
    (StartSystem { params: *params, solutions: set.into_vec(), symmetry: start.symmetry.clone() }, failed)
}
