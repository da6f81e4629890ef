//! `simhc bench upnp` (the paper's Table 1) and `simhc solve upnp`.

use crate::stats::{MethodRecord, Outcome, Summary, Thresholds};
use nalgebra::Matrix3;
use nalgebra::SVector;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use simhc::pipeline::{Method, PipelineError, Solved, StartProvider};
use simhc::solver::{FirstRowsError, GivenStart, LearnedHypotheses, SolveError as LibraryError, SolverAttempt, SolverOrigin, StartId};
use simhc_problems::metrics::{quat_from_rotation, random_unit_quaternion, rotation_error_deg, translation_error_pct};
use simhc_problems::start_systems::{best_real_solution, solve_upnp, Selection};
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::instance::{upnp_pose, LinearStart, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::learned::UpnpLearned;
use simhc_problems::upnp::pose::{UpnpPose, UpnpValidation};
use simhc_problems::upnp::refine::{levenberg_marquardt, LmOptions};
use simhc_problems::upnp::scene::{PointBox, UpnpCorrespondence, UpnpScene, UpnpSceneConfig};
use std::time::Instant;

/// Success as in the paper's Table 1: rotation error below 2 degrees.
pub const THRESHOLDS: Thresholds = Thresholds { rotation_deg: 2.0, translation_pct: None, scale_pct: None };

/// `simhc bench upnp` options beyond the shared ones.
#[derive(Debug, Clone, clap::Args)]
pub struct UpnpArgs {
    /// Frame of the sampled point box `[-1,1]^2 x [4,8]`: `viewer` (simhc's training
    /// distribution) or `world` (the paper's text read literally, as the peers' generators do).
    #[arg(long, value_enum, default_value_t = Layout::Viewer)]
    pub layout: Layout,
    /// Bearing noise in pixels at 800 px focal length.
    #[arg(long, default_value_t = 2.0)]
    pub noise_px: f64,
}

/// The `--layout` values.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Layout {
    /// Points in front of the rig (viewer frame).
    Viewer,
    /// Points in a world-frame box.
    World,
}

impl UpnpArgs {
    /// The benchmark options of these arguments.
    pub fn options(&self, trials: usize, seed: u64, random_frames: bool) -> BenchOptions {
        let layout = match self.layout {
            Layout::Viewer => PointBox::Viewer,
            Layout::World => PointBox::World,
        };
        let scene = UpnpSceneConfig { noise_px: self.noise_px, ..UpnpSceneConfig::default() };
        BenchOptions { trials, seed, scene, layout, random_frames }
    }
}

/// Options of the benchmark.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Trials to sample (ignored with a trials file).
    pub trials: usize,
    /// Seed of the trial sampler (the random starts use `seed + 1`).
    pub seed: u64,
    /// Scene settings.
    pub scene: UpnpSceneConfig,
    /// Frame of the sampler's point box.
    pub layout: PointBox,
    /// Random rigid changes of the world and viewer frames.
    pub random_frames: bool,
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
    /// Rows in the paper's order, then the linear start and the shipped solver.
    pub rows: Vec<Summary>,
    /// How the shipped solver's poses were produced, counted over the trials: by an attempt
    /// from the linear start, from the learned start, or by the all-roots fallback.
    pub shipped_attempts: [usize; 3],
    /// The certificates of the shipped solver's validated poses.
    pub certificates: crate::certificates::CertificateStats,
}

/// The row of the shipped solver: the library solver a user calls ([`UpnpLibrarySolver`]:
/// starts, validation, fallback).
pub const SHIPPED_ROW: &str = "simhc UPnP solver (shipped)";
/// The paper's row: one path from the regressor's start.
pub const PRED_HC_ROW: &str = "Pred Initial + Simulator HC";
/// The all-roots row.
pub const ALL_ROOTS_ROW: &str = "All-roots HC (1 thread)";

/// Samples `n` seeded trials.
pub fn sample_trials(options: &BenchOptions) -> Result<Vec<UpnpScene>, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    (0..options.trials)
        .map(|_| options.scene.sample_with(options.layout, options.random_frames, &mut rng).map_err(|e| e.to_string()))
        .collect()
}

fn outcome(r: &Matrix3<f64>, t: &nalgebra::Vector3<f64>, scene: &UpnpScene, micros: f64, split: Option<[f64; 3]>) -> Outcome {
    Outcome {
        rotation_deg: Some(rotation_error_deg(r, &scene.rotation)),
        translation_pct: Some(translation_error_pct(t, &scene.translation)),
        scale_pct: None,
        micros,
        split,
        flagged: false,
    }
}

fn failed(micros: f64) -> Outcome {
    Outcome { micros, ..Outcome::default() }
}

fn us(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// The outcome of a solve over the library solver's pipeline: a validated pose, a flagged one
/// (scored all the same), or none; with the stage split of the attempt that produced it.
fn solved(result: &PipelineOutcome, scene: &UpnpScene, micros: f64) -> Outcome {
    let corrs = &scene.correspondences[..];
    let (s, flagged) = match result {
        Ok(s) => (s, false),
        Err(PipelineError::NotValidated(s)) => (s, true),
        Err(_) => return failed(micros),
    };
    let Some(pose) = upnp_pose(&s.x, corrs) else { return failed(micros) };
    let split = [us(s.times.start), us(s.times.simulator), us(s.times.tracking)];
    Outcome { flagged, ..outcome(&pose.rotation, &pose.translation, scene, micros, Some(split)) }
}

/// What one pipeline run of the UPnP library solver returns.
type PipelineOutcome = Result<Solved<UpnpValidation, 4, SolverOrigin>, PipelineError<FirstRowsError, UpnpValidation, 4, SolverOrigin>>;

/// A rotation start with its optimal translation.
fn start_outcome(q: Option<SVector<f64, 4>>, corrs: &[UpnpCorrespondence], scene: &UpnpScene, micros: f64) -> Outcome {
    match q.and_then(|q| upnp_pose(&q, corrs)) {
        Some(pose) => outcome(&pose.rotation, &pose.translation, scene, micros, None),
        None => failed(micros),
    }
}

/// Every row is a schedule over one solver, the library solver a user calls
/// ([`UpnpLibrarySolver`]): its starts are the learned start, the caller's start and the linear
/// start (the problem's only other start).
const LEARNED: StartId = StartId::LEARNED;
const GIVEN: StartId = StartId::Given;
const LINEAR: StartId = StartId::Other(0);
const fn one_path(start: StartId) -> [SolverAttempt; 1] {
    [SolverAttempt::new(start, Method::SimulatorHc)]
}

/// Runs every row on the same trials, single-threaded.
pub fn bench(trials: &[UpnpScene], options: &BenchOptions, source: String, progress: bool) -> Result<BenchReport, String> {
    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).map_err(|e| format!("loading the shipped regressor: {e}"))?;
    let learned = solver.learned_start();
    let mut start_rng = ChaCha8Rng::seed_from_u64(options.seed.wrapping_add(1));
    let mut pred = MethodRecord::new("Pred Initial");
    let mut pred_lm = MethodRecord::new("Pred Initial + LM");
    let mut rand_hc = MethodRecord::new("Rand Initial + Simulator HC");
    let mut pred_hc = MethodRecord::new(PRED_HC_ROW);
    let mut linear = MethodRecord::new("Linear Initial");
    let mut linear_hc = MethodRecord::new("Linear Initial + Simulator HC");
    let mut full = MethodRecord::new(SHIPPED_ROW);
    let mut all_roots = MethodRecord::new(ALL_ROOTS_ROW);
    let mut shipped_attempts = [0usize; 3];
    let (mut certificates, mut certificate_times) = (crate::certificates::CertificateStats::default(), Vec::new());
    let all_roots_options = simhc::all_roots::AllRootsOptions::default();
    let bar = crate::app::progress_bar(trials.len() as u64, progress);
    let first = |corrs: &[UpnpCorrespondence]| learned.rank(corrs).ok().map(|r| r.x[0]);
    for scene in trials {
        let corrs: &[UpnpCorrespondence] = &scene.correspondences;

        // Pred Initial: the regressor's rotation with its optimal translation.
        let t0 = Instant::now();
        let q0 = first(corrs);
        let micros = us(t0.elapsed());
        pred.outcomes.push(start_outcome(q0, corrs, scene, micros));

        // Pred Initial + LM: local refinement of the object-space cost from the prediction.
        let t0 = Instant::now();
        let refined = first(corrs)
            .and_then(|q| upnp_pose(&q, corrs))
            .map(|p| levenberg_marquardt(&p.rotation, &p.translation, corrs, &LmOptions::default()));
        let micros = us(t0.elapsed());
        pred_lm.outcomes.push(match refined {
            Some(lm) => outcome(&lm.rotation, &lm.translation, scene, micros, None),
            None => failed(micros),
        });

        // Rand Initial + Simulator HC (the random start is drawn outside the timing).
        let given = GivenStart(SVector::from(random_unit_quaternion(&mut start_rng)));
        let t0 = Instant::now();
        let result = solver.run_pipeline(corrs, &one_path(GIVEN), false, Some(&given));
        rand_hc.outcomes.push(solved(&result, scene, us(t0.elapsed())));

        // Pred Initial + Simulator HC: the paper's one path from the regressor.
        let t0 = Instant::now();
        let result = solver.run_pipeline(corrs, &one_path(LEARNED), false, None);
        pred_hc.outcomes.push(solved(&result, scene, us(t0.elapsed())));

        // Linear Initial, and one path from it.
        let t0 = Instant::now();
        let q0 = LinearStart.start(corrs).ok();
        let micros = us(t0.elapsed());
        linear.outcomes.push(start_outcome(q0, corrs, scene, micros));
        let t0 = Instant::now();
        let result = solver.run_pipeline(corrs, &one_path(LINEAR), false, None);
        linear_hc.outcomes.push(solved(&result, scene, us(t0.elapsed())));

        // The shipped solve: the solver's own schedule, validation, all-roots fallback.
        let t0 = Instant::now();
        let result = solver.run_pipeline(corrs, solver.schedule(), true, None);
        full.outcomes.push(solved(&result, scene, us(t0.elapsed())));
        match result.as_ref().map(|s| s.origin) {
            Ok(SolverOrigin::Attempt(a)) => shipped_attempts[usize::from(a.start != LINEAR)] += 1,
            Ok(SolverOrigin::Fallback { .. }) => shipped_attempts[2] += 1,
            Err(_) => {}
        }
        // Its certificate, timed alone.
        if let Ok(s) = &result {
            let t0 = Instant::now();
            let certified = solver.certify(corrs, &s.x).is_ok();
            let micros = us(t0.elapsed());
            let correct =
                upnp_pose(&s.x, corrs).is_some_and(|p| rotation_error_deg(&p.rotation, &scene.rotation) < THRESHOLDS.rotation_deg);
            certificates.push(certified, correct, micros, &mut certificate_times);
        }

        // All-roots HC: every path of the Lagrange system from the shipped start system, the
        // real solution closest to the ground truth kept (the paper's choice).
        let t0 = Instant::now();
        let solved = upnp_system(corrs).ok().map(|sys| (sys, solve_upnp(&simhc_problems::upnp::params_of(&sys.m), &all_roots_options)));
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
        all_roots.outcomes.push(match best.and_then(|(sys, s)| UpnpPose::of_quaternion(sys, [s.x[0], s.x[1], s.x[2], s.x[3]])) {
            Some(pose) => outcome(&pose.rotation, &pose.translation, scene, micros, None),
            None => failed(micros),
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let rows: Vec<Summary> =
        [pred, pred_lm, rand_hc, pred_hc, linear, linear_hc, full, all_roots].iter().map(|m| m.summary(&THRESHOLDS)).collect();
    let shipped_median = rows.iter().find(|r| r.method == SHIPPED_ROW).map_or(f64::NAN, |r| r.time_median_us);
    let certificates = certificates.finish(certificate_times, shipped_median);
    Ok(BenchReport {
        problem: "upnp",
        seed: options.seed,
        trials: trials.len(),
        source,
        thresholds: THRESHOLDS,
        rows,
        shipped_attempts,
        certificates,
    })
}

/// `simhc solve upnp --input F`: the pose of the correspondences in a JSON file
/// (`{"correspondences": [{"p": [..], "f": [..], "v": [..]}, ..]}`, or a bare array of them),
/// by the UPnP library solver ([`UpnpLibrarySolver`]).
pub fn solve_file(text: &str) -> Result<serde_json::Value, String> {
    let corrs: Vec<UpnpCorrespondence> = simhc_problems::input::parse_correspondences(text).map_err(|e| e.to_string())?;
    let solver = UpnpLibrarySolver::new(UpnpProblem::default())
        .map_err(|e| format!("loading the shipped regressor: {e}"))?
        .certifying(simhc::solver::Certification::Report);
    // A pose that did not validate is printed with `"validated": false`, never as a plain pose.
    let (x, origin, attempts, check, validated, certificate) = match solver.solve(&corrs[..]) {
        Ok(s) => (s.x, Some(s.origin), s.attempts, s.check, true, crate::certificates::json(&s.certified)),
        Err(LibraryError::NotValidated { best, check, attempts }) => (best, None, attempts, check, false, serde_json::Value::Null),
        Err(e) => return Err(e.to_string()),
    };
    let pose = upnp_pose(&x, &corrs).ok_or("the end point has no pose (a zero quaternion)")?;
    let (start, method) = match origin {
        Some(SolverOrigin::Attempt(SolverAttempt { start, method })) => {
            let start = if start == LINEAR { "linear" } else { "learned" };
            (start, serde_json::to_value(method).map_err(|e| e.to_string())?)
        }
        Some(SolverOrigin::Fallback { .. }) => ("all roots", serde_json::json!("AllRoots")),
        None => ("none validated", serde_json::json!("-")),
    };
    let r = pose.rotation;
    Ok(serde_json::json!({
        "rotation": [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
        "translation": [pose.translation.x, pose.translation.y, pose.translation.z],
        "quaternion_wxyz": pose.quaternion,
        "convention": "alpha_i f_i + v_i = R p_i + t",
        "validated": validated,
        "max_angular_residual": check.max_angle,
        "behind_ray_origin": check.behind,
        "start": start,
        "method": method,
        "attempts": attempts,
        "certificate": certificate,
    }))
}

/// `simhc ransac upnp`: the UPnP library solver's robust estimate
/// ([`simhc::solver::InstanceSolver::estimate`]) on scenes of the UPnP
/// sampler (`--rows` correspondences, `--noise` px) in which a wrong match takes the world
/// point of another scene; success is the paper's (E_R < 2 deg) and E_t < 5 %. A row of the
/// trials is `[p, f, v]`, the truth (and an estimate) the rotation (row-major) and translation.
pub fn ransac(a: &crate::ransac::RansacArgs) -> Result<(crate::ransac::TrialsFile, String, crate::ransac::RansacReport), String> {
    use crate::ransac::{Estimated, Field, Sampled, TrialSpec};
    use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
    let spec = TrialSpec {
        problem: "upnp",
        row_fields: vec![Field::new("p", 3), Field::new("f", 3), Field::new("v", 3)],
        global_fields: Vec::new(),
        truth_fields: vec![Field::new("rotation", 9), Field::new("translation", 3)],
        min_rows: simhc_problems::upnp::geometry::UPNP_MIN_CORRESPONDENCES,
    };
    let pose_numbers = |r: &Matrix3<f64>, t: &nalgebra::Vector3<f64>| -> Vec<f64> {
        r.transpose().as_slice().iter().chain(t.as_slice()).copied().collect()
    };
    let (file, source) = crate::ransac::trials(a, &spec, |rng, rows, noise, ratio| {
        let scenes = UpnpSceneConfig { points: rows, noise_px: noise, ..UpnpSceneConfig::default() };
        let mut scene = scenes.sample(rng).map_err(|e| e.to_string())?;
        let inlier = crate::ransac::draw_inliers(rng, rows, ratio);
        for (c, _) in scene.correspondences.iter_mut().zip(&inlier).filter(|(_, keep)| !**keep) {
            let other = UpnpSceneConfig { points: 1, ..scenes }.sample(rng).map_err(|e| e.to_string())?;
            c.p = other.correspondences[0].p;
        }
        let rows = scene.correspondences.iter().flat_map(|c| c.p.iter().chain(c.f.iter()).chain(c.v.iter()).copied()).collect();
        Ok(Sampled { rows, globals: Vec::new(), truth: pose_numbers(&scene.rotation, &scene.translation), inlier })
    })?;
    let learned = match &a.weights {
        Some(path) => {
            let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
            let network = simhc::regressor::FoldedNetwork::from_bytes(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
            UpnpLearned::new(network).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => UpnpLearned::shipped().map_err(|e| e.to_string())?,
    };
    let focal_px = UpnpSceneConfig::default().focal_px;
    // A sample's pose may miss its own correspondences by 8 times the noise.
    let problem = UpnpProblem { max_angle: (8.0 * file.noise / focal_px).max(1e-6), ..UpnpProblem::default() };
    let solver = UpnpLibrarySolver::with_learned(std::sync::Arc::new(problem), learned, 0.0).map_err(|e| e.to_string())?;
    let report = crate::ransac::evaluate(&file, a.skip_explained, |trial, options| {
        let corrs: Vec<UpnpCorrespondence> = trial.rows.iter().map(|r| UpnpCorrespondence::from_row(r)).collect();
        let (rotation, translation) =
            (Matrix3::from_row_slice(&trial.truth[..9]), nalgebra::Vector3::from_column_slice(&trial.truth[9..12]));
        let t0 = Instant::now();
        let result = solver.estimate(&corrs, options);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let estimate = result.ok().map(|(pose, info)| {
            let correct =
                rotation_error_deg(&pose.rotation, &rotation) < 2.0 && translation_error_pct(&pose.translation, &translation) < 5.0;
            (pose_numbers(&pose.rotation, &pose.translation), correct, info.inlier_mask)
        });
        Ok(Estimated { estimate, ms })
    })?;
    Ok((file, source, report))
}

#[cfg(test)]
mod tests {
    use crate::ransac::RansacArgs;

    #[test]
    fn the_ransac_rows_find_every_pose_and_its_inliers() {
        let a = RansacArgs::sampled(3, 5, 40, 0.0, vec![0.0, 0.4], 1e-4);
        let (_, _, report) = super::ransac(&a).expect("runs");
        let rows = report.rows;
        assert_eq!(rows.len(), 2);
        for r in &rows {
            assert_eq!((r.success_pct, r.recall_pct, r.wrong_taken, r.no_model), (100.0, 100.0, 0.0, 0), "{r:?}");
        }
        let bad = RansacArgs { rows: 2, ..a };
        assert!(super::ransac(&bad).unwrap_err().contains("--rows 2"));
    }
}
