//! The learned start of UPnP: the shipped network on the canonical rows of all correspondences
//! ([`super::features`]), one hypothesis, decoded back to the input frames.

use super::features::{UpnpFrame, UPNP_OUTPUTS, UPNP_ROW_WIDTH};
use super::scene::UpnpCorrespondence;
use nalgebra::SVector;
use simhc::pipeline::StartError;
use simhc::regressor::{FoldedNetwork, RegressorError};
use simhc::solver::{LearnedHypotheses, Ranked};
use std::sync::Arc;

/// The shipped UPnP regressor (trained by `simhc train upnp`).
pub static UPNP_WEIGHTS: &[u8] = include_bytes!("../../weights/upnp.folded");

/// Correspondences whose input rows are held on the stack (a RANSAC sample, a usual solve): no
/// heap allocation for them.
const STACK_ROWS: usize = 32;

/// The regressor's unit quaternion for the correspondences: `network` on their canonical rows,
/// decoded to the input frames. The correspondences are not checked; a failure is a start
/// error with a fixed message (no allocation) but for the network's own errors.
pub fn predict(network: &FoldedNetwork, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], StartError> {
    let fail = |reason: &'static str| StartError { provider: "learned", reason: reason.into() };
    let frame = UpnpFrame::new(corrs).ok_or(fail("all world points on one line: no canonical frame"))?;
    let mut stack = [0.0f32; UPNP_ROW_WIDTH * STACK_ROWS];
    let mut heap = Vec::new();
    let rows = if corrs.len() <= STACK_ROWS {
        &mut stack[..UPNP_ROW_WIDTH * corrs.len()]
    } else {
        heap.resize(UPNP_ROW_WIDTH * corrs.len(), 0.0f32);
        &mut heap[..]
    };
    if !frame.rows(corrs, rows) {
        return Err(fail("an input row is not finite"));
    }
    let mut out = [0.0f64; UPNP_OUTPUTS];
    network.forward(rows, &mut out).map_err(|e| StartError { provider: "learned", reason: e.to_string().into() })?;
    frame.decode(&out).ok_or(fail("the network's output is not finite"))
}

/// The learned start of UPnP, one hypothesis. Clones share the network (an estimator per
/// threshold costs no copy of the weights).
#[derive(Clone)]
pub struct UpnpLearned {
    network: Arc<FoldedNetwork>,
}

impl UpnpLearned {
    /// The learned start of `network` (input rows of width [`UPNP_ROW_WIDTH`], 4 outputs).
    pub fn new(network: FoldedNetwork) -> Result<Self, RegressorError> {
        if network.input_width() != UPNP_ROW_WIDTH {
            return Err(RegressorError::Format("network input width differs from UPnP's rows (9)"));
        }
        if network.output_width() != UPNP_OUTPUTS {
            return Err(RegressorError::Format("network outputs are not UPnP's 4"));
        }
        Ok(Self { network: Arc::new(network) })
    }

    /// The learned start of the shipped weights ([`UPNP_WEIGHTS`]).
    pub fn shipped() -> Result<Self, RegressorError> {
        Self::new(FoldedNetwork::from_bytes(UPNP_WEIGHTS)?)
    }

    /// The network (shared by the clones of this learned start).
    pub fn network(&self) -> &FoldedNetwork {
        &self.network
    }
}

impl LearnedHypotheses<[UpnpCorrespondence], 4> for UpnpLearned {
    fn hypotheses(&self) -> usize {
        1
    }
    fn rank(&self, corrs: &[UpnpCorrespondence]) -> Result<Ranked<4>, StartError> {
        Ok(Ranked::one(SVector::from(predict(&self.network, corrs)?)))
    }
}
