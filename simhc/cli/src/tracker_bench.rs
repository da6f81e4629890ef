//! `simhc bench tracker`: step-size control, predictor and homotopy compared on the same paths
//! of the built-in systems (success, steps, Newton iterations, time), as ratios against the
//! paper's fixed schedule measured in the same run.

use nalgebra::SVector;
use num_complex::Complex;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use simhc::homotopy::{real_if_close, to_complex, CoefficientLine, Homotopy, ParameterHomotopy, SquaredUp};
use simhc::tracker::{solve_newton, track, NewtonOptions, TrackerOptions};
use simhc::OnlineSimulator;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::metrics::{
    perturb_scale, perturb_translation, quat_from_rotation, random_rotation_perturbation, rotation_error_deg, rotation_from_quat,
};
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::{grps, upnp};
use std::time::Instant;

/// One row of the comparison.
#[derive(Debug, Clone, Serialize)]
pub struct TrackerRow {
    /// Problem.
    pub problem: &'static str,
    /// Method label.
    pub method: String,
    /// Paths.
    pub paths: usize,
    /// Paths ending at the ground truth (percent).
    pub success_pct: f64,
    /// Mean accepted steps.
    pub accepted_steps: f64,
    /// Mean rejected steps.
    pub rejected_steps: f64,
    /// Mean (Gauss-)Newton iterations.
    pub newton_iterations: f64,
    /// Median time per path (microseconds).
    pub time_median_us: f64,
    /// Median of the per-path time ratio to the paper's schedule on the same path.
    pub time_ratio_to_paper: f64,
}

struct PathOutcome {
    ok: bool,
    accepted: usize,
    rejected: usize,
    newton: usize,
    micros: f64,
}

fn row(problem: &'static str, method: &str, outcomes: &[PathOutcome], paper: &[PathOutcome]) -> TrackerRow {
    let n = outcomes.len().max(1) as f64;
    let times: Vec<f64> = outcomes.iter().map(|o| o.micros).collect();
    let ratios: Vec<f64> = outcomes.iter().zip(paper).map(|(a, b)| a.micros / b.micros.max(1e-3)).collect();
    TrackerRow {
        problem,
        method: method.to_string(),
        paths: outcomes.len(),
        success_pct: 100.0 * outcomes.iter().filter(|o| o.ok).count() as f64 / n,
        accepted_steps: outcomes.iter().map(|o| o.accepted as f64).sum::<f64>() / n,
        rejected_steps: outcomes.iter().map(|o| o.rejected as f64).sum::<f64>() / n,
        newton_iterations: outcomes.iter().map(|o| o.newton as f64).sum::<f64>() / n,
        time_median_us: crate::stats::median(&times),
        time_ratio_to_paper: crate::stats::median(&ratios),
    }
}

fn run<H, const NX: usize, const NF: usize>(
    h: &H,
    x0: &SVector<f64, NX>,
    options: &TrackerOptions,
    ok: impl Fn(&SVector<f64, NX>) -> bool,
) -> PathOutcome
where
    H: Homotopy<f64, NX, NF>,
{
    let t0 = Instant::now();
    let result = track(h, x0, options);
    let micros = t0.elapsed().as_secs_f64() * 1e6;
    match result {
        Ok(r) => PathOutcome {
            ok: ok(&r.x),
            accepted: r.stats.accepted_steps,
            rejected: r.stats.rejected_steps,
            newton: r.stats.newton_iterations,
            micros,
        },
        Err(_) => PathOutcome { ok: false, accepted: 0, rejected: 0, newton: 0, micros },
    }
}

/// GRPS with 8 correspondences, noise-free, start = truth rotated by `angle` deg with 10 %
/// translation and scale error, generic simulator.
pub fn grps_rows(paths: usize, seed: u64, angle: f64) -> Vec<TrackerRow> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let config = GrpsSceneConfig::default();
    let methods = [
        "paper fixed dt=0.05, straight line",
        "adaptive, straight line",
        "adaptive+drag (single_path), straight line",
        "adaptive+drag, parameter homotopy",
        "adaptive, squared-up parameter homotopy",
        "Gauss-Newton only (no homotopy)",
    ];
    let mut outcomes: Vec<Vec<PathOutcome>> = methods.iter().map(|_| Vec::new()).collect();
    let mut done = 0;
    while done < paths {
        let Some((scene, x0)) = perturbed_grps_start(&config, angle, &mut rng) else { continue };
        let Some(rows) = grps::rows_of::<8>(&scene.correspondences) else { continue };
        let p1 = grps::Grps8::params(&rows);
        let Ok(p0) = simhc::MinNormSimulator::<grps::Grps8>::new().simulate(&x0, &p1) else { continue };
        let ok = |x: &SVector<f64, 8>| grps_ok(x, &scene);
        let line = CoefficientLine::<grps::Grps8, f64, 96, 304>::new::<8, 9>(&p0, &p1);
        let param = ParameterHomotopy::<grps::Grps8, f64, 96>::new(p0, p1);
        outcomes[0].push(run(&line, &x0, &TrackerOptions::paper(0.05), ok));
        outcomes[1].push(run(&line, &x0, &TrackerOptions::default(), ok));
        outcomes[2].push(run(&line, &x0, &TrackerOptions::single_path(), ok));
        outcomes[3].push(run(&param, &x0, &TrackerOptions::single_path(), ok));
        outcomes[4].push(run(&SquaredUp::new(param, seed), &x0, &TrackerOptions::default(), ok));
        let t = Instant::now();
        let gn = solve_newton::<grps::Grps8, f64, 8, 9, 96>(&x0, &p1, &NewtonOptions { max_iterations: 20, ..NewtonOptions::default() });
        let micros = t.elapsed().as_secs_f64() * 1e6;
        outcomes[5].push(match gn {
            Ok(r) => PathOutcome { ok: ok(&r.x), accepted: 0, rejected: 0, newton: r.iterations, micros },
            Err(_) => PathOutcome { ok: false, accepted: 0, rejected: 0, newton: 0, micros },
        });
        done += 1;
    }
    methods.iter().zip(&outcomes).map(|(m, o)| row("grps8", m, o, &outcomes[0])).collect()
}

/// GRPS with 7 correspondences (square): real tracking against the complex detour, which
/// tracks the real start in complex arithmetic around the real folds.
pub fn grps7_rows(paths: usize, seed: u64, angle: f64) -> Vec<TrackerRow> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let config = GrpsSceneConfig { points: 7, ..GrpsSceneConfig::default() };
    let methods = [
        "adaptive, parameter homotopy (real)",
        "adaptive+drag, straight line (real)",
        "adaptive, complex detour g=0.3",
        "adaptive, complex detour g=1",
    ];
    let mut outcomes: Vec<Vec<PathOutcome>> = methods.iter().map(|_| Vec::new()).collect();
    let mut done = 0;
    while done < paths {
        let Some((scene, x0)) = perturbed_grps_start(&config, angle, &mut rng) else { continue };
        let Some(rows) = grps::rows_of::<7>(&scene.correspondences) else { continue };
        let p1 = grps::Grps7::params(&rows);
        let Ok(p0) = simhc::MinNormSimulator::<grps::Grps7>::new().simulate(&x0, &p1) else { continue };
        let ok = |x: &SVector<f64, 8>| grps_ok(x, &scene);
        let param = ParameterHomotopy::<grps::Grps7, f64, 84>::new(p0, p1);
        outcomes[0].push(run(&param, &x0, &TrackerOptions::default(), ok));
        let line = CoefficientLine::<grps::Grps7, f64, 84, 266>::new::<8, 8>(&p0, &p1);
        outcomes[1].push(run(&line, &x0, &TrackerOptions::single_path(), ok));
        for (k, g) in [(2, 0.3), (3, 1.0)] {
            let detour = ParameterHomotopy::<grps::Grps7, Complex<f64>, 84>::with_complex_detour(&p0, &p1, g, seed ^ done as u64);
            let t = Instant::now();
            let result = track(&detour, &to_complex(&x0), &TrackerOptions::default());
            let micros = t.elapsed().as_secs_f64() * 1e6;
            outcomes[k].push(match result {
                Ok(r) => PathOutcome {
                    ok: real_if_close(&r.x, 1e-6).is_some_and(|x| ok(&x)),
                    accepted: r.stats.accepted_steps,
                    rejected: r.stats.rejected_steps,
                    newton: r.stats.newton_iterations,
                    micros,
                },
                Err(_) => PathOutcome { ok: false, accepted: 0, rejected: 0, newton: 0, micros },
            });
        }
        done += 1;
    }
    methods.iter().zip(&outcomes).map(|(m, o)| row("grps7", m, o, &outcomes[0])).collect()
}

/// A sampled scene and a start: the truth rotated by `angle` degrees about a random axis, with
/// translation and scale 10 % off.
fn perturbed_grps_start(
    config: &GrpsSceneConfig,
    angle: f64,
    rng: &mut ChaCha8Rng,
) -> Option<(simhc_problems::grps::scene::GrpsScene, SVector<f64, 8>)> {
    let scene = config.sample(rng).ok()?;
    let r0 = random_rotation_perturbation(&scene.rotation, angle, rng);
    let t0 = perturb_translation(&scene.translation, 0.1, rng);
    let s0 = perturb_scale(scene.scale, 0.1, rng);
    let x0 = grps::unknowns_of(&r0, &t0, s0);
    Some((scene, x0))
}

fn grps_ok(x: &SVector<f64, 8>, scene: &simhc_problems::grps::scene::GrpsScene) -> bool {
    let q = [x[0], x[1], x[2], x[3]];
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let r = rotation_from_quat(q.map(|v| v / n));
    let t = nalgebra::Vector3::new(x[4], x[5], x[6]);
    rotation_error_deg(&r, &scene.rotation) < 1.0
        && (t - scene.translation).norm() < 0.01 * scene.translation.norm()
        && (x[7] - scene.scale).abs() < 0.01 * scene.scale
}

/// UPnP, 2 px noise, start = truth rotated by `angle` deg, geometric simulator.
pub fn upnp_rows(paths: usize, seed: u64, angle: f64) -> Vec<TrackerRow> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let config = UpnpSceneConfig::default();
    let methods = ["paper fixed dt=0.02, straight line", "adaptive, straight line", "adaptive+drag (single_path), straight line"];
    let mut outcomes: Vec<Vec<PathOutcome>> = methods.iter().map(|_| Vec::new()).collect();
    let mut done = 0;
    while done < paths {
        let Ok(scene) = config.sample(&mut rng) else { continue };
        let r0 = random_rotation_perturbation(&scene.rotation, angle, &mut rng);
        let q0 = quat_from_rotation(&r0);
        let Ok(target) = upnp_system(&scene.correspondences) else { continue };
        let Ok(m0) = simhc_problems::upnp::simulator::simulate(&target, &scene.correspondences, q0) else { continue };
        let line = CoefficientLine::<upnp::Upnp, f64, 66, 35>::new::<4, 5>(&upnp::params_of(&m0), &upnp::params_of(&target.m));
        let x0 = SVector::<f64, 4>::from(q0);
        let ok = |x: &SVector<f64, 4>| {
            let n = x.norm();
            let r = rotation_from_quat([x[0] / n, x[1] / n, x[2] / n, x[3] / n]);
            rotation_error_deg(&r, &scene.rotation) < 2.0
        };
        outcomes[0].push(run(&line, &x0, &TrackerOptions::paper(0.02), ok));
        outcomes[1].push(run(&line, &x0, &TrackerOptions::default(), ok));
        outcomes[2].push(run(&line, &x0, &TrackerOptions::single_path(), ok));
        done += 1;
    }
    methods.iter().zip(&outcomes).map(|(m, o)| row("upnp", m, o, &outcomes[0])).collect()
}

/// The rows as text.
pub fn table(rows: &[TrackerRow]) -> String {
    let mut out = format!(
        "{:<8} {:<46} {:>6} {:>7} {:>8} {:>8} {:>8} {:>9} {:>9}\n",
        "problem", "method", "paths", "succ%", "acc st", "rej st", "newton", "t med us", "t/paper"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<8} {:<46} {:>6} {:>7.1} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>9.3}\n",
            r.problem,
            r.method,
            r.paths,
            r.success_pct,
            r.accepted_steps,
            r.rejected_steps,
            r.newton_iterations,
            r.time_median_us,
            r.time_ratio_to_paper
        ));
    }
    out
}
