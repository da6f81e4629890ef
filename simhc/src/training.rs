//! Settings of a learned start's training, as plain data: a problem returns them from
//! [`crate::solver::DeclaredProblem::training`] whatever features are enabled, and the trainer
//! (`simhc-regressor`, with burn) reads them.

/// Settings of the training loop (`simhc_regressor::train`).
#[derive(Debug, Clone, PartialEq)]
pub struct TrainConfig {
    /// Passes over the training set.
    pub epochs: usize,
    /// Samples per step (the last partial batch of an epoch is dropped).
    pub batch_size: usize,
    /// Adam learning rate at the start.
    pub learning_rate: f64,
    /// Learning rate at the end of the cosine schedule.
    pub final_learning_rate: f64,
    /// Seed of parameter initialization and shuffling.
    pub seed: u64,
    /// Show an indicatif progress bar (hidden anyway when stderr is not a terminal).
    pub progress: bool,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self { epochs: 12, batch_size: 128, learning_rate: 4e-3, final_learning_rate: 4e-5, seed: 42, progress: true }
    }
}

/// Settings of the generic learned start's training (`simhc_regressor::generic`): the network's
/// widths, the number of training scenes and the optimizer.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedStartConfig {
    /// Widths of the point layers (per row).
    pub point_widths: Vec<usize>,
    /// Widths of the hidden head layers.
    pub head_widths: Vec<usize>,
    /// Point layers before the context stage (every row then also reads the max-pooled
    /// features of all rows; `simhc::regressor::FoldedNetwork::with_context`); 0: none.
    pub context_after: usize,
    /// Training scenes.
    pub samples: usize,
    /// Start hypotheses per prediction (winner-takes-all training; the solver ranks them on
    /// the data and tracks them in order). 1: a single prediction.
    pub hypotheses: usize,
    /// Weight of the mean over all hypotheses in the winner-takes-all loss.
    pub relax: f64,
    /// Optimizer settings; `train.seed` also seeds the sampler.
    pub train: TrainConfig,
}

impl Default for LearnedStartConfig {
    fn default() -> Self {
        Self {
            point_widths: vec![64, 128, 128],
            head_widths: vec![128],
            context_after: 0,
            samples: 50_000,
            hypotheses: 1,
            relax: 0.05,
            train: TrainConfig { learning_rate: 2e-3, final_learning_rate: 2e-5, ..TrainConfig::default() },
        }
    }
}
