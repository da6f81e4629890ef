//! The paper's pose regression network (section "Find a Good Starting Solution"), PointNet
//! style so that it is invariant to the order of the correspondences:
//!
//! ```text
//! x [B, N, C] -> reshape [B*N, C]
//!   -> 4 x (Linear -> BatchNorm -> ReLU)      per-correspondence features ("1D conv, kernel 1")
//!   -> reshape [B, N, W] -> max over N        permutation-invariant pooling
//!   -> head: Linear (-> ReLU -> Linear)*      to `outputs` numbers
//!   -> divide by the Euclidean norm           unit quaternion [w, x, y, z]
//! ```
//!
//! With `context_after = k > 0`, the features after point layer `k` are max-pooled over the N
//! rows and concatenated to every row (`[h_i, g]`) before layer `k + 1` (PointNet's
//! segmentation network): each row's later features can then depend on the others, which a
//! pose, a function of comparisons between correspondences, needs
//! (`simhc::regressor::FoldedNetwork::with_context` runs it at inference).
//!
//! A 1D convolution with kernel size 1 over the N correspondences is exactly a dense layer
//! applied to every row, so it is written as [`Linear`] on the `[B*N, C]` reshape (faster on the
//! flex backend, same function); batch norm then normalizes each channel over all `B*N` rows,
//! as `BatchNorm1d` does over `[B, C, N]`.

use burn::nn::{BatchNorm, BatchNormConfig, Linear, LinearConfig, Relu};
use burn::prelude::*;

/// Architecture of a [`PoseRegressor`].
#[derive(Config, Debug)]
pub struct RegressorConfig {
    /// Numbers per input row (correspondence); 9 for UPnP (`p, f, v`).
    pub input_width: usize,
    /// Widths of the point layers (Linear + BatchNorm + ReLU each); the last one is pooled.
    pub point_widths: Vec<usize>,
    /// Widths of the hidden head layers (Linear + ReLU each), may be empty.
    pub head_widths: Vec<usize>,
    /// Number of outputs (4 for a quaternion).
    #[config(default = 4)]
    pub outputs: usize,
    /// Divide the output by its norm (unit quaternion).
    #[config(default = true)]
    pub normalize_output: bool,
    /// Point layers before the context stage (module docs); 0: none.
    #[config(default = 0)]
    pub context_after: usize,
}

impl RegressorConfig {
    /// The UPnP network shipped with simhc: 9 -> 32 -> 64 -> 64 -> 128, max-pool, 128 -> 64 -> 4.
    pub fn upnp() -> Self {
        Self::new(simhc_problems::upnp::features::UPNP_ROW_WIDTH, vec![32, 64, 64, 128], vec![64])
    }

    /// Builds the network with freshly initialized parameters on `device`.
    pub fn init(&self, device: &Device) -> PoseRegressor {
        assert!(!self.point_widths.is_empty(), "need at least one point layer");
        assert!(self.context_after < self.point_widths.len(), "the context stage must precede a point layer");
        let mut width = self.input_width;
        let mut point_layers = Vec::new();
        let mut point_norms = Vec::new();
        for (k, &w) in self.point_widths.iter().enumerate() {
            if self.context_after > 0 && k == self.context_after {
                width *= 2;
            }
            point_layers.push(LinearConfig::new(width, w).init(device));
            point_norms.push(BatchNormConfig::new(w).init(device));
            width = w;
        }
        let mut head_layers = Vec::new();
        for &w in self.head_widths.iter().chain(std::iter::once(&self.outputs)) {
            head_layers.push(LinearConfig::new(width, w).init(device));
            width = w;
        }
        PoseRegressor {
            point_layers,
            point_norms,
            head_layers,
            activation: Relu::new(),
            normalize_output: self.normalize_output,
            context_after: self.context_after,
        }
    }
}

/// The regression network (module docs).
#[derive(Module, Debug)]
pub struct PoseRegressor {
    /// Per-correspondence dense layers ("1D convolutions with kernel size 1").
    pub point_layers: Vec<Linear>,
    /// Batch norm after each point layer.
    pub point_norms: Vec<BatchNorm>,
    /// Head layers; ReLU between them, none after the last.
    pub head_layers: Vec<Linear>,
    /// ReLU.
    pub activation: Relu,
    /// Divide the output by its norm.
    pub normalize_output: bool,
    /// Point layers before the context stage; 0: none.
    pub context_after: usize,
}

impl PoseRegressor {
    /// `x`: `[B, N, C]` rows; returns `[B, outputs]` (unit norm if `normalize_output`).
    pub fn forward(&self, x: Tensor<3>) -> Tensor<2> {
        let [b, n, c] = x.dims();
        let mut h = x.reshape([b * n, c]);
        for (k, (layer, norm)) in self.point_layers.iter().zip(&self.point_norms).enumerate() {
            if self.context_after > 0 && k == self.context_after {
                let [_, w] = h.dims();
                let rows = h.reshape([b, n, w]);
                let pooled = rows.clone().max_dim(1).repeat_dim(1, n);
                h = Tensor::cat(vec![rows, pooled], 2).reshape([b * n, 2 * w]);
            }
            h = self.activation.forward(norm.forward(layer.forward(h)));
        }
        let [_, w] = h.dims();
        // max over the N correspondences; squeeze_dim, not squeeze (batch 1 keeps its axis)
        let mut h: Tensor<2> = h.reshape([b, n, w]).max_dim(1).squeeze_dim(1);
        let last = self.head_layers.len() - 1;
        for (k, layer) in self.head_layers.iter().enumerate() {
            h = layer.forward(h);
            if k != last {
                h = self.activation.forward(h);
            }
        }
        if self.normalize_output {
            let norm = h.clone().square().sum_dim(1).sqrt().clamp_min(1e-8);
            h = h / norm;
        }
        h
    }
}
