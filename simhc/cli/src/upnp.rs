//! `simhc bench upnp` (the paper's Table 1) and `simhc solve upnp`.

use crate::stats::{MethodRecord, Outcome, Summary, Thresholds};
use nalgebra::Matrix3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use simhc_problems::metrics::{
    quat_from_rotation, random_unit_quaternion, rotation_error_deg, rotation_from_quat, translation_error_pct,
};
use simhc_problems::start_systems::{best_real_solution, solve_upnp, Selection};
use simhc_problems::upnp::geometry::{translation_from_rotation, upnp_system};
use simhc_problems::upnp::refine::{levenberg_marquardt, LmOptions};
use simhc_problems::upnp::scene::{UpnpCorrespondence, UpnpScene, UpnpSceneConfig};
use simhc_problems::upnp::solver::UpnpSolver;
use std::time::Instant;

/// Success as in the paper's Table 1: rotation error below 2 degrees.
pub const THRESHOLDS: Thresholds = Thresholds { rotation_deg: 2.0, translation_pct: None, scale_pct: None };

/// Options of the benchmark.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Trials to sample (ignored with a trials file).
    pub trials: usize,
    /// Seed of the trial sampler (the random starts use `seed + 1`).
    pub seed: u64,
    /// Scene settings.
    pub scene: UpnpSceneConfig,
}

/// The benchmark's JSON document.
#[derive(Debug, Serialize)]
pub struct BenchReport {
    /// Problem name.
    pub problem: &'static str,
    /// Seed.
    pub seed: u64,
    /// Trials run.
    pub trials: usize,
    /// Where the trials came from.
    pub source: String,
    /// Success criterion.
    pub thresholds: Thresholds,
    /// Rows in the paper's order.
    pub rows: Vec<Summary>,
}

/// Samples `n` seeded trials.
pub fn sample_trials(options: &BenchOptions) -> Result<Vec<UpnpScene>, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    (0..options.trials)
        .map(|_| options.scene.sample(&mut rng).map_err(|e| e.to_string()))
        .collect()
}

fn outcome(r: &Matrix3<f64>, t: &nalgebra::Vector3<f64>, scene: &UpnpScene, micros: f64, split: Option<[f64; 3]>) -> Outcome {
    Outcome {
        rotation_deg: Some(rotation_error_deg(r, &scene.rotation)),
        translation_pct: Some(translation_error_pct(t, &scene.translation)),
        scale_pct: None,
        micros,
        split,
    }
}

fn failed(micros: f64) -> Outcome {
    Outcome { micros, ..Outcome::default() }
}

fn us(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// Runs every row on the same trials, single-threaded.
pub fn bench(trials: &[UpnpScene], options: &BenchOptions, source: String, progress: bool) -> Result<BenchReport, String> {
    let solver = UpnpSolver::new().map_err(|e| format!("loading the shipped regressor: {e}"))?;
    let mut start_rng = ChaCha8Rng::seed_from_u64(options.seed.wrapping_add(1));
    let mut pred = MethodRecord::new("Pred Initial");
    let mut pred_lm = MethodRecord::new("Pred Initial + LM");
    let mut rand_hc = MethodRecord::new("Rand Initial + Simulator HC");
    let mut pred_hc = MethodRecord::new("Pred Initial + Simulator HC");
    let mut all_roots = MethodRecord::new("All-roots HC (1 thread)");
    let all_roots_options = simhc::all_roots::AllRootsOptions::default();
    let bar = crate::progress_bar(trials.len() as u64, progress);
    for scene in trials {
        let corrs: &[UpnpCorrespondence] = &scene.correspondences;

        // Pred Initial: the regressor's rotation with its optimal translation.
        let t0 = Instant::now();
        let q0 = solver.predict(corrs);
        let prediction = q0.as_ref().ok().and_then(|q| {
            let r = rotation_from_quat(*q);
            translation_from_rotation(&r, corrs).ok().map(|t| (r, t))
        });
        let micros = us(t0.elapsed());
        pred.outcomes.push(match prediction {
            Some((r, t)) => outcome(&r, &t, scene, micros, None),
            None => failed(micros),
        });

        // Pred Initial + LM: local refinement of the object-space cost from the prediction.
        let t0 = Instant::now();
        let refined = solver.predict(corrs).ok().and_then(|q| {
            let r = rotation_from_quat(q);
            let t = translation_from_rotation(&r, corrs).ok()?;
            Some(levenberg_marquardt(&r, &t, corrs, &LmOptions::default()))
        });
        let micros = us(t0.elapsed());
        pred_lm.outcomes.push(match refined {
            Some(lm) => outcome(&lm.rotation, &lm.translation, scene, micros, None),
            None => failed(micros),
        });

        // Rand Initial + Simulator HC (the random start is drawn outside the timing).
        let q_rand = random_unit_quaternion(&mut start_rng);
        let t0 = Instant::now();
        let result = solver.solve_from(corrs, q_rand);
        let micros = us(t0.elapsed());
        rand_hc.outcomes.push(match result {
            Ok(r) => outcome(&r.pose.rotation, &r.pose.translation, scene, micros, Some([0.0, us(r.times.simulator), us(r.times.tracking)])),
            Err(_) => failed(micros),
        });

        // Pred Initial + Simulator HC: the full solver.
        let t0 = Instant::now();
        let result = solver.solve_report(corrs);
        let micros = us(t0.elapsed());
        pred_hc.outcomes.push(match result {
            Ok(r) => outcome(
                &r.pose.rotation,
                &r.pose.translation,
                scene,
                micros,
                Some([us(r.times.regressor), us(r.times.simulator), us(r.times.tracking)]),
            ),
            Err(_) => failed(micros),
        });

        // All-roots HC: every path of the Lagrange system from the shipped start system, the
        // real solution closest to the ground truth kept (the paper's choice).
        let t0 = Instant::now();
        let solved = upnp_system(corrs).ok().map(|sys| {
            (sys, solve_upnp(&simhc_problems::upnp::params_of(&sys.m), &all_roots_options))
        });
        let micros = us(t0.elapsed());
        let q_gt = quat_from_rotation(&scene.rotation);
        let best = solved.as_ref().and_then(|(sys, result)| {
            let score = |x: &nalgebra::SVector<f64, 5>| {
                let n = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]).sqrt();
                let dot = (x[0] * q_gt[0] + x[1] * q_gt[1] + x[2] * q_gt[2] + x[3] * q_gt[3]) / n;
                -dot.abs()
            };
            best_real_solution(result, Selection::MinScore(&score)).map(|s| (sys, s))
        });
        all_roots.outcomes.push(match best {
            Some((sys, s)) => {
                let n = (s.x[0] * s.x[0] + s.x[1] * s.x[1] + s.x[2] * s.x[2] + s.x[3] * s.x[3]).sqrt();
                let q = [s.x[0] / n, s.x[1] / n, s.x[2] / n, s.x[3] / n];
                outcome(&rotation_from_quat(q), &sys.translation(q), scene, micros, None)
            }
            None => failed(micros),
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let rows: Vec<Summary> = [pred, pred_lm, rand_hc, pred_hc, all_roots].iter().map(|m| m.summary(&THRESHOLDS)).collect();
    Ok(BenchReport { problem: "upnp", seed: options.seed, trials: trials.len(), source, thresholds: THRESHOLDS, rows })
}

/// `simhc solve upnp --input F`: the pose of the correspondences in a JSON file
/// (`{"correspondences": [{"p": [..], "f": [..], "v": [..]}, ..]}`, or a bare array of them).
pub fn solve_file(text: &str) -> Result<serde_json::Value, String> {
    #[derive(serde::Deserialize)]
    struct Input {
        correspondences: Vec<UpnpCorrespondence>,
    }
    let corrs: Vec<UpnpCorrespondence> = match serde_json::from_str::<Input>(text) {
        Ok(input) => input.correspondences,
        Err(_) => serde_json::from_str(text).map_err(|e| format!("invalid input JSON: {e}"))?,
    };
    let solver = UpnpSolver::new().map_err(|e| format!("loading the shipped regressor: {e}"))?;
    let report = solver.solve_report(&corrs).map_err(|e| e.to_string())?;
    let r = report.pose.rotation;
    Ok(serde_json::json!({
        "rotation": [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
        "translation": [report.pose.translation.x, report.pose.translation.y, report.pose.translation.z],
        "quaternion_wxyz": quat_from_rotation(&r),
        "convention": "alpha_i f_i + v_i = R p_i + t",
        "track": {"accepted_steps": report.stats.accepted_steps, "rejected_steps": report.stats.rejected_steps, "newton_iterations": report.stats.newton_iterations},
    }))
}
