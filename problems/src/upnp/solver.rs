//! The UPnP Simulator HC solver: regressor -> geometric online simulator -> single-path
//! homotopy continuation on the compiled UPnP system.
//!
//! Pose convention: `alpha_i f_i + v_i = R p_i + t` (world point `p_i`, bearing `f_i` and ray
//! origin `v_i` in the viewer frame); [`UpnpPose`] holds that `R` and `t`.

use super::geometry::{reproject_in_place, upnp_system, UpnpError, UpnpSystem};
use super::scene::UpnpCorrespondence;
use super::{params_of, Upnp};
use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, SVector, Vector3};
use simhc::homotopy::CoefficientLine;
use simhc::regressor::{upnp_rows, FoldedNetwork, RegressorError, UPNP_ROW_WIDTH};
use simhc::tracker::{track, TrackError, TrackStats, TrackerOptions};
use std::time::{Duration, Instant};
use thiserror::Error;

/// The shipped UPnP regressor (trained by `simhc train upnp`).
pub static UPNP_WEIGHTS: &[u8] = include_bytes!("../../weights/upnp.folded");

/// A generalized camera pose: `alpha f + v = R p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpPose {
    /// Rotation world -> viewer.
    pub rotation: Matrix3<f64>,
    /// Translation world -> viewer.
    pub translation: Vector3<f64>,
    /// The unit quaternion `[w, x, y, z]` of `rotation` as tracked.
    pub quaternion: [f64; 4],
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolveError {
    /// Bad input: too few correspondences, non-finite values, zero bearings, degenerate rays.
    #[error(transparent)]
    Input(#[from] UpnpError),
    /// The regressor could not run on the input.
    #[error("regressor: {0}")]
    Regressor(#[from] RegressorError),
    /// The homotopy path failed; the code says how.
    #[error("tracking failed: {0}")]
    Tracker(#[from] TrackError),
}

/// Wall time of each stage of one solve.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Building the input rows and the forward pass.
    pub regressor: Duration,
    /// Cost matrices of the target and of the simulated start problem.
    pub simulator: Duration,
    /// Coefficients and path tracking.
    pub tracking: Duration,
}

/// A solve with its diagnostics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpSolveReport {
    /// The pose.
    pub pose: UpnpPose,
    /// The start quaternion (regressor output or caller's).
    pub start: [f64; 4],
    /// Path statistics.
    pub stats: TrackStats,
    /// Stage timings.
    pub times: StageTimes,
}

/// Simulator HC for generalized absolute pose.
#[derive(Debug, Clone)]
pub struct UpnpSolver {
    network: FoldedNetwork,
    /// Tracker settings; default: the adaptive single-path preset.
    pub options: TrackerOptions,
}

impl UpnpSolver {
    /// The solver with the shipped regressor weights.
    pub fn new() -> Result<Self, RegressorError> {
        Ok(Self::with_network(FoldedNetwork::from_bytes(UPNP_WEIGHTS)?))
    }

    /// The solver with a given network (input rows of width [`UPNP_ROW_WIDTH`], 4 outputs).
    pub fn with_network(network: FoldedNetwork) -> Self {
        Self { network, options: TrackerOptions::single_path() }
    }

    /// Solves for the pose (regressor start).
    pub fn solve(&self, corrs: &[UpnpCorrespondence]) -> Result<UpnpPose, SolveError> {
        self.solve_report(corrs).map(|r| r.pose)
    }

    /// The regressor's quaternion for the correspondences (unit, `[w, x, y, z]`).
    pub fn predict(&self, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], SolveError> {
        super::geometry::validate(corrs)?;
        let mut rows = vec![0.0f32; UPNP_ROW_WIDTH * corrs.len()];
        upnp_rows(corrs.len(), |i| (corrs[i].p.into(), corrs[i].f.into(), corrs[i].v.into()), &mut rows)?;
        let mut q = [0.0f64; 4];
        self.network.forward(&rows, &mut q)?;
        Ok(q)
    }

    /// Solves with the regressor start and reports stage timings.
    pub fn solve_report(&self, corrs: &[UpnpCorrespondence]) -> Result<UpnpSolveReport, SolveError> {
        let t0 = Instant::now();
        let q0 = self.predict(corrs)?;
        let regressor = t0.elapsed();
        let mut report = self.solve_from(corrs, q0)?;
        report.times.regressor = regressor;
        Ok(report)
    }

    /// Solves from a given start quaternion (e.g. a random one, for the ablation).
    pub fn solve_from(&self, corrs: &[UpnpCorrespondence], q0: [f64; 4]) -> Result<UpnpSolveReport, SolveError> {
        let t0 = Instant::now();
        let target = upnp_system(corrs)?;
        let q0 = normalized(q0).ok_or(UpnpError::NonFinite { index: usize::MAX })?;
        let start = simulate(&target, corrs, q0)?;
        let simulator = t0.elapsed();

        let t1 = Instant::now();
        let h = CoefficientLine::<Upnp, f64, 66, 35>::new::<4, 5>(&params_of(&start), &params_of(&target.m));
        let result = track(&h, &SVector::<f64, 4>::from(q0), &self.options)?;
        let tracking = t1.elapsed();

        let q = normalized([result.x[0], result.x[1], result.x[2], result.x[3]])
            .ok_or(TrackError::NonFinite { t: 1.0 })?;
        let pose = UpnpPose { rotation: rotation_from_quat(q), translation: target.translation(q), quaternion: q };
        Ok(UpnpSolveReport { pose, start: q0, stats: result.stats, times: StageTimes { regressor: Duration::ZERO, simulator, tracking } })
    }
}

/// The paper's geometric simulator: reproject the points under `(R(q0), t*(q0))` and rebuild
/// `M`; `q0` then solves the start system exactly (its simulated cost is zero).
pub fn simulate(target: &UpnpSystem, corrs: &[UpnpCorrespondence], q0: [f64; 4]) -> Result<nalgebra::SMatrix<f64, 11, 11>, UpnpError> {
    let r0 = rotation_from_quat(q0);
    let t0 = target.translation(q0);
    let mut simulated = corrs.to_vec();
    reproject_in_place(&r0, &t0, &mut simulated)?;
    Ok(upnp_system(&simulated)?.m)
}

fn normalized(q: [f64; 4]) -> Option<[f64; 4]> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    (n > 0.0 && n.is_finite()).then(|| q.map(|v| v / n))
}
