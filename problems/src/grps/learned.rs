//! The shipped GRPS network ([`GRPS_WEIGHTS`], trained by `simhc train grps`) and its
//! prediction outside a solve's learned start: [`GrpsNetwork::predict`], which the declared
//! problems' other starts ([`super::declared::PredictedStart`]: the predicted rotation with
//! least-squares `(t, s)`, the network on the swapped views) run inside a solve, without heap
//! allocation.

use super::features::{GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use super::geometry::{validate, GrpsError};
use super::pose::GrpsPose;
use super::refine::rotation_residual;
use super::scene::GrpsCorrespondence;
use simhc::pipeline::MAX_HYPOTHESES;
use simhc::regressor::{FoldedNetwork, HypothesisBlocks, RegressorError};
use thiserror::Error;

/// The shipped GRPS regressor (trained by `simhc train grps`).
pub static GRPS_WEIGHTS: &[u8] = include_bytes!("../../weights/grps.folded");

/// Why the network gave no pose.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PredictError {
    /// Bad or degenerate input.
    #[error(transparent)]
    Input(#[from] GrpsError),
    /// The network could not run on the input.
    #[error("regressor: {0}")]
    Regressor(#[from] RegressorError),
    /// The network's output is not a pose (degenerate 6D rotation or non-finite values).
    #[error("regressor output is not a valid pose")]
    BadPrediction,
    /// The input has no canonical frame: its values are too large to centre and scale.
    #[error("the correspondences have no canonical frame (values too large to centre and scale)")]
    NoCanonicalFrame,
}

/// A GRPS network: rows of width [`GRPS_ROW_WIDTH`] in, blocks of [`GRPS_OUTPUTS`] per start
/// hypothesis out (at most [`MAX_HYPOTHESES`]).
#[derive(Debug, Clone)]
pub struct GrpsNetwork {
    network: FoldedNetwork,
}

impl GrpsNetwork {
    /// The shipped network.
    pub fn shipped() -> Result<Self, RegressorError> {
        Self::from_bytes(GRPS_WEIGHTS)
    }

    /// The network of a `.folded` file's bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, RegressorError> {
        Ok(Self { network: FoldedNetwork::from_bytes(bytes)? })
    }

    /// A network already loaded.
    pub fn new(network: FoldedNetwork) -> Self {
        Self { network }
    }

    /// How the network's outputs hold its start hypotheses (blocks of [`GRPS_OUTPUTS`], scored
    /// when there are several); an error for outputs that are not such blocks.
    pub fn blocks(&self) -> Result<HypothesisBlocks, RegressorError> {
        HypothesisBlocks::of(self.network.output_width(), GRPS_OUTPUTS, MAX_HYPOTHESES)
            .ok_or(RegressorError::Format("GRPS network outputs are not 1 to 8 blocks of 10 (and their scores)"))
    }

    /// Start hypotheses per prediction (1 for a network of the wrong outputs, which
    /// [`GrpsNetwork::predict`] reports).
    pub fn hypotheses(&self) -> usize {
        self.blocks().map_or(1, |b| b.count)
    }

    /// The network's pose for `corrs` (checked input): its first-ranked hypothesis (ranked by
    /// [`rotation_residual`] on the data when there are several; the first of the lowest
    /// rank). Makes no heap allocation for up to 8 correspondences.
    pub fn predict(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, PredictError> {
        /// Correspondences held on the stack.
        const STACK: usize = 8;
        validate(corrs)?;
        let frame = GrpsFrame::new(corrs).ok_or(PredictError::NoCanonicalFrame)?;
        let mut best: Option<(f64, GrpsPose)> = None;
        let mut keep = |rank: f64, pose: GrpsPose| {
            if best.is_none_or(|(b, _)| rank.total_cmp(&b).is_lt()) {
                best = Some((rank, pose));
            }
        };
        if let Some(&first) = corrs.first().filter(|_| corrs.len() <= STACK) {
            let mut canonical = [first; STACK];
            for (out, c) in canonical.iter_mut().zip(corrs) {
                *out = frame.canonical_one(c);
            }
            let mut rows = [0.0f32; GRPS_ROW_WIDTH * STACK];
            self.forward_canonical(&canonical[..corrs.len()], &mut rows[..GRPS_ROW_WIDTH * corrs.len()], &mut keep)?;
        } else {
            let mut rows = vec![0.0f32; GRPS_ROW_WIDTH * corrs.len()];
            self.forward_canonical(&frame.canonical(corrs), &mut rows, &mut keep)?;
        }
        let (_, pose) = best.ok_or(PredictError::BadPrediction)?;
        let (rotation, translation, scale) = frame.from_canonical(&pose.rotation, &pose.translation, pose.scale);
        Ok(GrpsPose { rotation, translation, scale })
    }

    /// Runs the network on canonical correspondences (`rows`: a buffer of their input rows)
    /// and hands each decoded hypothesis to `each` with its rank (lower is better; 0 for a
    /// network of one hypothesis); an error when none decodes.
    fn forward_canonical(
        &self,
        canonical: &[GrpsCorrespondence],
        rows: &mut [f32],
        mut each: impl FnMut(f64, GrpsPose),
    ) -> Result<(), PredictError> {
        let frame = GrpsFrame::IDENTITY;
        if !frame.rows(canonical, rows) {
            return Err(PredictError::NoCanonicalFrame);
        }
        let blocks = self.blocks()?;
        let mut out = [0.0f64; (GRPS_OUTPUTS + 1) * MAX_HYPOTHESES];
        let out = &mut out[..blocks.outputs()];
        self.network.forward(rows, out)?;
        let mut decoded = 0;
        for block in out[..blocks.count * GRPS_OUTPUTS].chunks_exact(GRPS_OUTPUTS) {
            let Some((rotation, translation, scale)) = block.try_into().ok().and_then(|b| frame.decode(b)) else { continue };
            // The data ranks better than the network's scores here (measured, see
            // `rotation_residual`).
            let rank = if blocks.count > 1 { rotation_residual(&rotation, canonical) } else { 0.0 };
            each(rank, GrpsPose { rotation, translation, scale });
            decoded += 1;
        }
        if decoded == 0 {
            return Err(PredictError::BadPrediction);
        }
        Ok(())
    }
}
