//! Where the GRPS7 all-roots time goes: per-evaluation costs of the generated code, and step
//! statistics of the 140 paths of a few noise-free solves (the homotopy of `solve_grps7`,
//! without its path-jump repair and polishing), tracked one path at a time and with the batch
//! tracker (`simhc::tracker::batch`, one path per SIMD lane) with either row kernel: from each
//! row's parameters (the default of `solve_grps7`; `BATCHONLY=1` times it alone) and from the
//! coefficients of the expansion (`BATCHONLY=coefficients`).
//!
//! ```sh
//! cargo run --release -p simhc-problems --example allroots_diag --features diagnostics -- 3   # seeds 0..3
//! ```
//!
//! It also prints where along `t` the one-path tracker's steps go (accepted and rejected
//! attempts per path, by distance `1 - t` to the target). On noise-free GRPS7 targets the steps
//! shrink about like `1 - t` from `t = 0.5` on, so nearly half of the accepted steps start
//! within `0.1` of the target (measured on seeds 0-3).

use nalgebra::{SMatrix, SVector};
use simhc::all_roots::{AllRootsOptions, CoefficientParameterHomotopy};
use simhc::homotopy::{Homotopy, ParameterHomotopy};
use simhc::scalar::C;
use simhc::tracker::batch::{track_batch, LaneSystem};
use simhc::tracker::{TrackError, TrackStats, Tracker, TrackerOptions, TrackerStatus};
use simhc::{CoefficientForm, Problem};
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{self, Grps7};
use simhc_problems::start_systems::{grps7_aligned_target, grps7_start, solve_grps7};
use std::hint::black_box;
use std::time::Instant;

/// Mean time of `f` in microseconds over `n` calls.
fn time_us(n: usize, mut f: impl FnMut()) -> f64 {
    let t0 = Instant::now();
    for _ in 0..n {
        f();
    }
    t0.elapsed().as_secs_f64() * 1e6 / n as f64
}

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(3);
    let start = grps7_start();
    let (x, p) = (start.solutions[0], start.params);
    let (xr, pr) = (x.map(|z| z.re), p.map(|z| z.re));
    let mut f = SVector::<C, 8>::zeros();
    let mut j = SMatrix::<C, 8, 8>::zeros();
    let mut fr = SVector::<f64, 8>::zeros();
    let mut jr = SMatrix::<f64, 8, 8>::zeros();
    let n = if std::env::var("BATCHONLY").is_ok() { 1 } else { 200_000 };
    println!("per evaluation (us):");
    let t = time_us(n, || Grps7::residual_jacobian(black_box(&x), black_box(&p), &mut f, &mut j));
    println!("  complex residual + Jacobian  {t:.3}");
    let t = time_us(n, || Grps7::residual(black_box(&x), black_box(&p), &mut f));
    println!("  complex residual             {t:.3}");
    let t = time_us(n, || Grps7::residual_jacobian(black_box(&xr), black_box(&pr), &mut fr, &mut jr));
    println!("  real residual + Jacobian     {t:.3}");
    let mut c = SVector::<C, { Grps7::NC }>::zeros();
    Grps7::coefficients(&p, &mut c);
    let t = time_us(n, || Grps7::coefficients(black_box(&p), &mut c));
    println!("  complex coefficients c(p)    {t:.3}");
    let t = time_us(n, || Grps7::residual_jacobian_coeffs(black_box(&x), black_box(&c), &mut f, &mut j));
    println!("  complex residual + Jacobian from c  {t:.3}");
    let t = time_us(n, || Grps7::coefficient_part(black_box(&x), black_box(&c), &mut f));
    println!("  complex coefficient part (linear in c)  {t:.3}");
    let t = time_us(n, || {
        let lu = black_box(&j).lu();
        black_box(lu.solve(&f));
    });
    println!("  nalgebra complex LU + solve  {t:.3} (reference)");

    let options = AllRootsOptions::default();
    println!("paths of solve_grps7's homotopy ({} start solutions):", start.solutions.len());
    for seed in 0..seeds {
        let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(seed).unwrap();
        let target = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
        let aligned = grps7_aligned_target(&start.params, &target);
        let base = ParameterHomotopy::<Grps7, C, 84>::new(start.params, aligned);
        let Some(h) = CoefficientParameterHomotopy::<Grps7, 84, { Grps7::NC }>::new::<8>(base) else {
            println!("  seed {seed}: coefficients not polynomial in t");
            continue;
        };
        if seed == 0 {
            let poly = h.coefficient_poly();
            let degree = |i: usize| (0..poly.len()).rev().find(|&k| poly[k][i].norm() > 0.0).unwrap_or(0);
            let mut by_degree = [0usize; 8];
            for i in 0..Grps7::NC {
                by_degree[degree(i).min(7)] += 1;
            }
            println!("  coefficients by degree in t (0, 1, 2, ...): {:?}", &by_degree[..poly.len()]);
            let (x0, t) = (start.solutions[0], 0.37);
            let mut hv = SVector::<C, 8>::zeros();
            let mut hj = SMatrix::<C, 8, 8>::zeros();
            let e = time_us(n, || h.evaluate(black_box(&x0), black_box(t), &mut hv, &mut hj));
            let d = time_us(n, || h.dt(black_box(&x0), black_box(t), &mut hv));
            let jd = time_us(n, || h.jacobian_dt(black_box(&x0), black_box(t), &mut hj, &mut hv));
            println!("  homotopy calls (us): evaluate {e:.3}, dt {d:.3}, jacobian_dt {jd:.3}");
            if std::env::var("DTLOOP").is_ok() {
                let d = time_us(20 * n, || h.dt(black_box(&x0), black_box(t), &mut hv));
                println!("  dt loop {d:.3}");
                return;
            }
        }
        let t0 = Instant::now();
        let (mut acc, mut rej, mut fact, mut newton, mut failed) = (0, 0, 0, 0, 0);
        let mut bins = StepBins::default();
        let batch_only = std::env::var("BATCHONLY").is_ok();
        for x0 in start.solutions.iter().filter(|_| !batch_only) {
            match track_binned(&h, x0, &options.tracker, &mut bins) {
                Ok(stats) => {
                    acc += stats.accepted_steps;
                    rej += stats.rejected_steps;
                    fact += stats.factorizations;
                    newton += stats.newton_iterations;
                }
                Err(_) => failed += 1,
            }
        }
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let k = start.solutions.len() as f64;
        let coefficients = LaneSystem::<Grps7, 8, { Grps7::NC }>::new::<84>(h.coefficient_poly());
        let parameters = LaneSystem::<Grps7, 8, { Grps7::NC }>::from_parameter_path::<84>(&h.parameter_path().param_poly());
        if let (Some(coefficients), Some(parameters)) = (coefficients, parameters) {
            let all: Vec<usize> = (0..start.solutions.len()).collect();
            let batch = |system: &LaneSystem<Grps7, 8, { Grps7::NC }>| {
                track_batch::<Grps7, _, 8, 84, { Grps7::NC }>(system, &h, &start.solutions, &all, &options.tracker)
            };
            if let Ok(which) = std::env::var("BATCHONLY") {
                let system = if which == "coefficients" { &coefficients } else { &parameters };
                for _ in 0..20 {
                    let _ = black_box(batch(system));
                }
                continue;
            }
            for (kernel, system) in [("parameter rows", &parameters), ("coefficient rows", &coefficients)] {
                let t1 = Instant::now();
                let paths = batch(system);
                let batch_ms = t1.elapsed().as_secs_f64() * 1e3;
                let paths = paths.unwrap_or_default();
                let ops: usize = paths.iter().flatten().map(|r| r.stats.factorizations).sum();
                let failed = paths.iter().filter(|r| r.is_err()).count();
                println!(
                    "  seed {seed}: batch tracker (path lanes, {kernel}) {batch_ms:.1} ms; {:.1} operations per path; {failed} failed",
                    ops as f64 / k
                );
            }
            let t2 = Instant::now();
            let full = solve_grps7(&target, &options);
            let full_ms = t2.elapsed().as_secs_f64() * 1e3;
            let t3 = Instant::now();
            let bare = solve_grps7(&target, &AllRootsOptions { retrack: None, ..options });
            let bare_ms = t3.elapsed().as_secs_f64() * 1e3;
            println!(
                "  seed {seed}: solve_grps7 {full_ms:.1} ms ({} retracked, {} failed); without the repair {bare_ms:.1} ms ({} failed, {} duplicates)",
                full.retracked, full.failed, bare.failed, bare.duplicates
            );
        }
        let per_path = |v: [usize; GAPS.len()]| v.map(|n| format!("{:.1}", n as f64 / k)).join(" / ");
        println!(
            "  seed {seed}: attempts per path by 1 - t in (0.5,1] / (0.1,0.5] / (0.01,0.1] / (0.001,0.01] / [0,0.001]: accepted {}, rejected {}",
            per_path(bins.accepted),
            per_path(bins.rejected)
        );
        println!(
            "  seed {seed}: {ms:.1} ms; per path {:.1} accepted, {:.1} rejected steps, {:.1} factorizations, {:.1} Newton iterations; {failed} failed",
            acc as f64 / k,
            rej as f64 / k,
            fact as f64 / k,
            newton as f64 / k,
        );
    }
}

/// Upper ends of the bins of `1 - t` in [`StepBins`], largest first.
const GAPS: [f64; 5] = [1.0, 0.5, 0.1, 0.01, 0.001];

/// Attempts (accepted and rejected steps) by the distance `1 - t` of the point they start from:
/// bins `(0.5, 1]`, `(0.1, 0.5]`, `(0.01, 0.1]`, `(0.001, 0.01]`, `[0, 0.001]`.
#[derive(Default)]
struct StepBins {
    accepted: [usize; GAPS.len()],
    rejected: [usize; GAPS.len()],
}

/// [`simhc::tracker::track`] through the public `Tracker::step`, adding each attempt to `bins`; the work
/// counters of a successful path.
fn track_binned<H: Homotopy<C, 8, 8>>(
    h: &H,
    x0: &SVector<C, 8>,
    options: &TrackerOptions,
    bins: &mut StepBins,
) -> Result<TrackStats, TrackError> {
    let mut tracker = Tracker::<C, H, 8, 8>::new(h, *options);
    tracker.start(x0)?;
    loop {
        let before = tracker.state().stats;
        let bin = GAPS.iter().rposition(|&g| 1.0 - tracker.state().t <= g).unwrap_or(0);
        let status = tracker.step();
        let after = tracker.state().stats;
        bins.accepted[bin] += after.accepted_steps - before.accepted_steps;
        bins.rejected[bin] += after.rejected_steps - before.rejected_steps;
        match status {
            TrackerStatus::Tracking => {}
            TrackerStatus::Success => return Ok(after),
            TrackerStatus::Failed(e) => return Err(e),
            TrackerStatus::Idle => return Err(TrackError::NonFinite { t: 0.0 }),
        }
    }
}
