//! A small custom training loop: Adam with a cosine learning-rate schedule, seeded shuffling
//! and initialization, a sign-invariant quaternion loss, indicatif progress and rotation-error
//! validation.
//!
//! Determinism: parameters are initialized after `device.seed(config.seed)` and the epoch
//! shuffles come from `ChaCha8Rng::seed_from_u64(config.seed)`, so a run is reproducible
//! (bit-identical within a process on the flex backend, see the burn notes) given the same data.

use crate::data::InMemoryDataset;
use crate::model::{PoseRegressor, RegressorConfig};
use burn::optim::{AdamConfig, GradientsParams};
use burn::prelude::*;
use indicatif::{ProgressBar, ProgressStyle};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc_problems::metrics::{rotation_error_deg, rotation_from_quat};
use std::time::Instant;

/// Settings of [`train`] (plain data in the runtime).
pub use simhc::training::TrainConfig;

/// Rotation-error statistics in degrees (the paper's `E_R`) over a set of predictions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotationStats {
    /// Number of predictions.
    pub count: usize,
    /// Mean error.
    pub mean_deg: f64,
    /// Median error.
    pub median_deg: f64,
    /// Percent of errors below 2 degrees (the paper's success criterion).
    pub pct_under_2: f64,
    /// Percent below 10 degrees.
    pub pct_under_10: f64,
    /// Percent below 20 degrees.
    pub pct_under_20: f64,
    /// Percent below 30 degrees.
    pub pct_under_30: f64,
    /// Largest error.
    pub max_deg: f64,
}

impl RotationStats {
    /// Statistics of `errors` (degrees; NaN counts as 180).
    pub fn from_errors(errors: &[f64]) -> Self {
        let mut e: Vec<f64> = errors.iter().map(|&x| if x.is_nan() { 180.0 } else { x }).collect();
        e.sort_by(f64::total_cmp);
        let n = e.len();
        let pct = |t: f64| 100.0 * e.iter().filter(|&&x| x < t).count() as f64 / n.max(1) as f64;
        let median = match n {
            0 => f64::NAN,
            _ if n % 2 == 1 => e[n / 2],
            _ => 0.5 * (e[n / 2 - 1] + e[n / 2]),
        };
        Self {
            count: n,
            mean_deg: e.iter().sum::<f64>() / n.max(1) as f64,
            median_deg: median,
            pct_under_2: pct(2.0),
            pct_under_10: pct(10.0),
            pct_under_20: pct(20.0),
            pct_under_30: pct(30.0),
            max_deg: e.last().copied().unwrap_or(f64::NAN),
        }
    }
}

impl std::fmt::Display for RotationStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "n={} mean {:.2} deg, median {:.2} deg, max {:.1} deg; <2: {:.1}%, <10: {:.1}%, <20: {:.1}%, <30: {:.1}%",
            self.count,
            self.mean_deg,
            self.median_deg,
            self.max_deg,
            self.pct_under_2,
            self.pct_under_10,
            self.pct_under_20,
            self.pct_under_30
        )
    }
}

/// What [`train`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    /// Seed of initialization and shuffling.
    pub seed: u64,
    /// Training samples.
    pub train_samples: usize,
    /// Epochs run.
    pub epochs: usize,
    /// Optimizer steps run.
    pub steps: usize,
    /// Wall-clock training time in seconds (without data generation and validation).
    pub train_seconds: f64,
    /// Mean training loss of every epoch.
    pub epoch_losses: Vec<f64>,
    /// Validation statistics of the final model.
    pub valid: RotationStats,
}

/// Sign-invariant quaternion loss `mean_b (1 - (q_b . q_gt_b)²)` = mean `sin²(theta/2)`, theta
/// the rotation angle between prediction and target (`q` and `-q` are the same rotation).
/// Both inputs `[B, 4]`, unit norm.
pub fn quaternion_loss(pred: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
    (quaternion_dot(pred, target).square().neg() + 1.0).mean()
}

/// `q_b . q_gt_b` per sample, `[B, 1]`.
pub fn quaternion_dot(pred: Tensor<2>, target: Tensor<2>) -> Tensor<2> {
    (pred * target).sum_dim(1)
}

/// Predicts quaternions for all samples of `data` (batches of 1024) with `model` in inference
/// mode on the plain flex device; returns them flat (`4` numbers per sample).
pub fn predict_dataset(model: &PoseRegressor, data: &InMemoryDataset) -> Vec<f32> {
    let device = Device::flex();
    let model = model.valid();
    let indices: Vec<usize> = (0..data.len()).collect();
    let mut out = Vec::with_capacity(4 * data.len());
    for chunk in indices.chunks(1024) {
        let (x, _) = data.batch(chunk, &device);
        let q = model.forward(x).into_data();
        out.extend(q.try_to_vec::<f32>().expect("f32 output"));
    }
    out
}

/// Rotation error in degrees between two quaternions `[w, x, y, z]` (normalized first).
pub fn quaternion_error_deg(q: &[f32], q_gt: &[f32]) -> f64 {
    let unit = |q: &[f32]| {
        let v = [q[0], q[1], q[2], q[3]].map(f64::from);
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.map(|x| x / n)
    };
    rotation_error_deg(&rotation_from_quat(unit(q)), &rotation_from_quat(unit(q_gt)))
}

/// Validation statistics of `model` on `data` (targets are quaternions).
pub fn evaluate(model: &PoseRegressor, data: &InMemoryDataset) -> RotationStats {
    let pred = predict_dataset(model, data);
    let errors: Vec<f64> = (0..data.len()).map(|i| quaternion_error_deg(&pred[4 * i..4 * i + 4], data.target(i))).collect();
    RotationStats::from_errors(&errors)
}

/// Trains a fresh [`PoseRegressor`] (`model_config`) on `train` (quaternion targets) and
/// validates it on `valid`. Returns the model in inference mode and the report.
pub fn train(
    model_config: &RegressorConfig,
    train: &InMemoryDataset,
    valid: &InMemoryDataset,
    config: &TrainConfig,
) -> (PoseRegressor, TrainReport) {
    let (model, run) = train_with_loss(model_config, train, config, quaternion_loss);
    let valid_stats = evaluate(&model, valid);
    let report = TrainReport {
        seed: config.seed,
        train_samples: train.len(),
        epochs: config.epochs,
        steps: run.steps,
        train_seconds: run.train_seconds,
        epoch_losses: run.epoch_losses,
        valid: valid_stats,
    };
    (model, report)
}

/// What [`train_with_loss`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainRun {
    /// Optimizer steps run.
    pub steps: usize,
    /// Wall-clock training time in seconds.
    pub train_seconds: f64,
    /// Mean training loss of every epoch.
    pub epoch_losses: Vec<f64>,
}

/// The training loop of [`train`] with any loss `loss(prediction [B, outputs], target [B, T])`:
/// Adam, cosine learning rate, seeded initialization and shuffling. Returns the model in
/// inference mode.
pub fn train_with_loss<L>(
    model_config: &RegressorConfig,
    train: &InMemoryDataset,
    config: &TrainConfig,
    loss_fn: L,
) -> (PoseRegressor, TrainRun)
where
    L: Fn(Tensor<2>, Tensor<2>) -> Tensor<1>,
{
    assert!(config.batch_size >= 2, "batch norm needs batches of at least 2");
    assert!(train.len() >= config.batch_size, "fewer training samples than one batch");
    let device = Device::flex().autodiff();
    device.seed(config.seed);
    let mut model = model_config.init(&device);
    let mut optim = AdamConfig::new().init();
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let steps_per_epoch = train.len() / config.batch_size;
    let total_steps = steps_per_epoch * config.epochs;
    let bar = if config.progress {
        ProgressBar::new(total_steps as u64).with_style(
            ProgressStyle::default_bar().template("{elapsed_precise} [{bar:30}] {pos}/{len} steps {msg}").expect("valid template"),
        )
    } else {
        ProgressBar::hidden()
    };
    let start = Instant::now();
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut epoch_losses = Vec::with_capacity(config.epochs);
    let mut step = 0usize;
    for epoch in 0..config.epochs {
        order.shuffle(&mut rng);
        let mut loss_sum = 0.0;
        for batch in order.chunks_exact(config.batch_size) {
            let progress = step as f64 / total_steps.max(1) as f64;
            let cosine = 0.5 * (1.0 + (std::f64::consts::PI * progress).cos());
            let lr = config.final_learning_rate + (config.learning_rate - config.final_learning_rate) * cosine;
            let (x, y) = train.batch(batch, &device);
            let loss = loss_fn(model.forward(x), y);
            loss_sum += loss.clone().into_scalar::<f32>() as f64;
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(lr, model, grads);
            step += 1;
            bar.inc(1);
            // The running loss from the first steps on, not only after a whole epoch (an epoch
            // of 100,000 scenes takes minutes on two cores).
            if step.is_multiple_of(50) {
                let done = step - epoch * steps_per_epoch;
                bar.set_message(format!("epoch {}/{} loss {:.5}", epoch + 1, config.epochs, loss_sum / done as f64));
            }
        }
        let mean = loss_sum / steps_per_epoch as f64;
        bar.set_message(format!("epoch {}/{} loss {mean:.5}", epoch + 1, config.epochs));
        epoch_losses.push(mean);
    }
    bar.finish_and_clear();
    let train_seconds = start.elapsed().as_secs_f64();
    let run = TrainRun { steps: step, train_seconds, epoch_losses };
    (model.valid(), run)
}
