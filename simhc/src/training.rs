//! Settings of a learned start's training, as plain data: a problem returns them from
//! [`crate::solver::Scenes::training`] whatever features are enabled, and the trainer
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
            // The settings the shipped weights of the example problem were trained with: eight
            // ranked hypotheses brought its shipped mean from 32x its median to 3.9x, the
            // context stage to 2.1x (BENCHMARKS.md, 2026-12-02 to 2026-12-04). A user who
            // trained with the old defaults (1 hypothesis, no context) saw a mean 10x the median.
            context_after: 1,
            samples: 100_000,
            hypotheses: 8,
            relax: 0.05,
            train: TrainConfig { learning_rate: 2e-3, final_learning_rate: 2e-5, ..TrainConfig::default() },
        }
    }
}

/// Why a [`LearnedStartConfig`] describes no network that can be trained. Checked by the
/// trainer before it draws a scene, and by the `train` command before it starts the trainer.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LearnedStartConfigError {
    /// No per-row layer, or a layer of width 0.
    #[error("point_widths {0:?}: at least one per-row layer, each of width at least 1")]
    PointWidths(Vec<usize>),
    /// A head layer of width 0.
    #[error("head_widths {0:?}: every head layer needs width at least 1")]
    HeadWidths(Vec<usize>),
    /// The context stage is not between two per-row layers.
    #[error(
        "context_after {context_after}: the context stage must follow one of the {layers} per-row layers and precede another (0 for none, at most {})",
        layers.saturating_sub(1)
    )]
    ContextAfter {
        /// The setting.
        context_after: usize,
        /// Per-row layers of the network.
        layers: usize,
    },
    /// Not 1 to [`crate::pipeline::MAX_HYPOTHESES`] start hypotheses.
    #[error("hypotheses {0}: 1 to {max}", max = crate::pipeline::MAX_HYPOTHESES)]
    Hypotheses(usize),
    /// No training scene.
    #[error("samples 0: training needs at least one scene")]
    Samples,
}

impl LearnedStartConfig {
    /// Whether these settings describe a network that can be trained; the first thing wrong.
    pub fn check(&self) -> Result<(), LearnedStartConfigError> {
        if self.point_widths.is_empty() || self.point_widths.contains(&0) {
            return Err(LearnedStartConfigError::PointWidths(self.point_widths.clone()));
        }
        if self.head_widths.contains(&0) {
            return Err(LearnedStartConfigError::HeadWidths(self.head_widths.clone()));
        }
        if self.context_after >= self.point_widths.len() {
            return Err(LearnedStartConfigError::ContextAfter { context_after: self.context_after, layers: self.point_widths.len() });
        }
        if !(1..=crate::pipeline::MAX_HYPOTHESES).contains(&self.hypotheses) {
            return Err(LearnedStartConfigError::Hypotheses(self.hypotheses));
        }
        if self.samples == 0 {
            return Err(LearnedStartConfigError::Samples);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_settings_check_and_each_mistake_is_named() {
        let ok = LearnedStartConfig::default();
        assert_eq!(ok.check(), Ok(()));
        let with = |f: fn(&mut LearnedStartConfig)| {
            let mut c = ok.clone();
            f(&mut c);
            c.check()
        };
        assert_eq!(with(|c| c.context_after = 2), Ok(()));
        assert_eq!(with(|c| c.context_after = 3), Err(LearnedStartConfigError::ContextAfter { context_after: 3, layers: 3 }));
        assert_eq!(with(|c| c.point_widths = vec![]), Err(LearnedStartConfigError::PointWidths(vec![])));
        assert_eq!(with(|c| c.point_widths = vec![64, 0]), Err(LearnedStartConfigError::PointWidths(vec![64, 0])));
        assert_eq!(with(|c| c.head_widths = vec![0]), Err(LearnedStartConfigError::HeadWidths(vec![0])));
        assert_eq!(with(|c| c.hypotheses = 0), Err(LearnedStartConfigError::Hypotheses(0)));
        assert_eq!(with(|c| c.hypotheses = 9), Err(LearnedStartConfigError::Hypotheses(9)));
        assert_eq!(with(|c| c.samples = 0), Err(LearnedStartConfigError::Samples));
        let message = with(|c| c.context_after = 3).unwrap_err().to_string();
        assert!(message.contains("context_after 3") && message.contains("at most 2"), "{message}");
    }
}
