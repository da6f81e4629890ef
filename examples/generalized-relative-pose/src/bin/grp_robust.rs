//! The robust estimator on a trials file, for the peers harness (`bench/peers/robust_grp.py`):
//! `grp_robust TRIALS.json --threshold RAD --noise PX [--seed S]` reads
//! `{"trials": [{"rows": [[f, v, fp, vp] as 12 numbers, ..]}, ..]}` and prints one JSON line per
//! trial: the pose (`X1 = R X2 + t`), the inlier mask, the info and the wall time of the call.

use generalized_relative_pose::{pose, GenRelPose, WEIGHTS};
use simhc::ransac::RansacOptions;
use std::time::Instant;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let value = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let path = args.get(1).ok_or("usage: grp_robust TRIALS.json --threshold RAD --noise PX [--seed S] [--min-iterations M]")?;
    let threshold: f64 = value("--threshold").ok_or("--threshold RAD")?.parse().map_err(|e| format!("--threshold: {e}"))?;
    let noise: f64 = value("--noise").ok_or("--noise PX")?.parse().map_err(|e| format!("--noise: {e}"))?;
    let seed: u64 = value("--seed").map_or(Ok(1), |s| s.parse()).map_err(|e| format!("--seed: {e}"))?;
    // PoseLib's default minimum unless told: the side-by-side runs both with the same one.
    let min_iterations: usize = value("--min-iterations").map_or(Ok(1000), |s| s.parse()).map_err(|e| format!("--min-iterations: {e}"))?;
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let doc: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
    let trials = doc["trials"].as_array().ok_or("no \"trials\" array")?;
    let solver = simhc::solver::Solver::with_weights(GenRelPose::new(), WEIGHTS, noise).map_err(|e| e.to_string())?;
    eprintln!(
        "grp_robust: {} trials, threshold {threshold} rad, noise {noise} px, seed {seed}, min_iterations {min_iterations}",
        trials.len()
    );
    for (i, trial) in trials.iter().enumerate() {
        let rows: Vec<f64> = trial["rows"]
            .as_array()
            .ok_or(format!("trial {i}: no rows"))?
            .iter()
            .flat_map(|r| r.as_array().into_iter().flatten().map(|v| v.as_f64().unwrap_or(f64::NAN)))
            .collect();
        let options = RansacOptions { seed: seed.wrapping_add(i as u64), min_iterations, ..RansacOptions::poselib(threshold) };
        let t = Instant::now();
        let result = solver.estimate((&rows, &[]), &options);
        let micros = t.elapsed().as_secs_f64() * 1e6;
        let line = match result {
            Ok((x, info)) => {
                let (r, t) = pose(&x);
                serde_json::json!({"solver": "simhc.estimate", "trial": i, "micros": micros,
                    "rotation": [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
                    "translation": [t.x, t.y, t.z], "inlier_mask": info.inlier_mask, "iterations": info.iterations,
                    "refinements": info.refinements})
            }
            Err(e) => {
                serde_json::json!({"solver": "simhc.estimate", "trial": i, "micros": micros, "rotation": null, "translation": null, "error": e.to_string()})
            }
        };
        println!("{line}");
    }
    Ok(())
}
