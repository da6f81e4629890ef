//! The trainer of every learned start: draws scenes from a problem's sampler, turns each into
//! network input rows and a target through the problem's [`FeatureHook`], and runs the shared
//! burn loop ([`train_with_loss`]) on the hook's loss.
//!
//! - A declared problem's default hook is [`LayoutFeatures`]: its parameters read through the
//!   [`Layout`] emitted by `#[simhc_problem]`, one input row per row, `[row parameters, global
//!   parameters]`; outputs the unknowns in layout order. Quaternion unknowns get the
//!   sign-invariant loss `1 - (q^ . q)²` on the normalized prediction (`q` and `-q` are one
//!   rotation); the inputs and the other unknowns are standardized over the training set, and
//!   the standardizations are folded into the first and last dense layers of the exported
//!   [`FoldedNetwork`] ([`HookTrained::folded`]), which therefore maps raw parameters to raw
//!   unknowns. [`train_learned_start`] trains it into a [`LearnedStart`].
//!   [`train_learned_start_with`] does the same on the problem's own [`InputRows`] (for example
//!   distances or ratios instead of raw coordinates); the trained start reads its parameters
//!   through the same value at run time.
//! - UPnP and GRPS have their own hooks ([`crate::upnp::UpnpFeatures`],
//!   [`crate::grps::GrpsFeatures`]): rows in canonical frames, built by the same code the
//!   runtime calls, and their own output encodings and losses.
//!
//! Seeds: scene `i` is drawn by `scene(i, rng)` from `ChaCha8Rng::seed_from_u64(train.seed)`, in
//! order, and the training loop is seeded the same way, so a run is reproducible.

use crate::data::{DataError, InMemoryDataset, Sample};
use crate::inference::fold;
use crate::model::{PoseRegressor, RegressorConfig};
use crate::training::{train_with_loss, TrainConfig, TrainRun};
use burn::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::layout::{FieldKind, Layout};
use simhc::pipeline::learned::{InputRows, LayoutRows, LearnedStart};
use simhc::regressor::{DenseLayer, FoldedNetwork, HypothesisBlocks, RegressorError};
use thiserror::Error;

/// A problem's feature hook: what the trainer learns from one of its scenes, and how a
/// prediction is scored.
pub trait FeatureHook {
    /// What the problem's sampler draws.
    type Scene;
    /// Network input rows per scene, and numbers per row.
    fn input_shape(&self) -> (usize, usize);
    /// Numbers per target.
    fn target_width(&self) -> usize;
    /// The input rows (`rows`, flat, row after row; zeroed) and the target (zeroed) of scene
    /// `index`: `Ok(true)` when written, `Ok(false)` for a scene without features (the trainer
    /// draws another), an error for a sampler that cannot be trained on.
    fn features(&self, index: usize, scene: &Self::Scene, rows: &mut [f32], target: &mut [f64]) -> Result<bool, LearnedStartError>;
    /// Whether the inputs and targets are standardized over the training set before training
    /// (and the standardizations folded into the exported network).
    fn standardize(&self) -> Standardize {
        Standardize::No
    }
    /// The loss of every sample of a batch, `[B]`: predictions `[B, outputs]` against targets
    /// `[B, target_width]` (standardized where [`FeatureHook::standardize`] says). The trainer
    /// minimizes the mean; [`WinnerTakesAll`] takes the best of several predictions per sample.
    fn sample_losses(&self, prediction: Tensor<2>, target: Tensor<2>) -> Tensor<1>;
}

/// Several start hypotheses per prediction: the network outputs `hypotheses` blocks of the
/// inner hook's outputs and one score per block ([`HypothesisBlocks::trained`]). A sample's
/// loss is that of its best block (winner takes all), plus `relax` times the mean over all
/// blocks so that no block is left untrained ("relaxed" winner-takes-all, Rupprecht et al.
/// 2017), plus `score_weight` times the cross-entropy of the scores' softmax against the
/// winning block. Why: a scene whose pose the network cannot tell from a few others gets one
/// block per guess instead of one prediction between them; the runtime tracks the blocks in
/// the order of their scores before any fallback.
#[derive(Debug, Clone, Copy)]
pub struct WinnerTakesAll<H> {
    /// The hook of one hypothesis.
    pub hook: H,
    /// Blocks of outputs per prediction (1: the inner hook unchanged).
    pub hypotheses: usize,
    /// Weight of the mean over all blocks (0: pure winner-takes-all).
    pub relax: f64,
}

/// Weight of the scores' cross-entropy in [`WinnerTakesAll`].
pub const SCORE_WEIGHT: f64 = 0.1;

impl<H: FeatureHook> FeatureHook for WinnerTakesAll<H> {
    type Scene = H::Scene;

    fn input_shape(&self) -> (usize, usize) {
        self.hook.input_shape()
    }

    fn target_width(&self) -> usize {
        self.hook.target_width()
    }

    fn features(&self, index: usize, scene: &Self::Scene, rows: &mut [f32], target: &mut [f64]) -> Result<bool, LearnedStartError> {
        self.hook.features(index, scene, rows, target)
    }

    fn standardize(&self) -> Standardize {
        self.hook.standardize()
    }

    fn sample_losses(&self, prediction: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
        let k = self.hypotheses.max(1);
        if k == 1 {
            return self.hook.sample_losses(prediction, target);
        }
        let [batch, outputs] = prediction.dims();
        let width = (outputs - k) / k;
        let losses: Vec<Tensor<2>> = (0..k)
            .map(|h| self.hook.sample_losses(prediction.clone().narrow(1, h * width, width), target.clone()).reshape([batch, 1]))
            .collect();
        let losses = Tensor::cat(losses, 1);
        let best: Tensor<1> = losses.clone().min_dim(1).reshape([batch]);
        let winner = losses.clone().detach().argmin(1);
        let scores = burn::tensor::activation::log_softmax(prediction.narrow(1, k * width, k), 1);
        let cross_entropy: Tensor<1> = scores.gather(1, winner).neg().reshape([batch]);
        let mean: Tensor<1> = losses.mean_dim(1).reshape([batch]);
        best * (1.0 - self.relax) + mean * self.relax + cross_entropy * SCORE_WEIGHT
    }
}

/// What [`FeatureHook::standardize`] standardizes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Standardize {
    /// Nothing: the hook's rows and targets are already in the network's convention.
    No,
    /// Every input channel, and every target number except these (for example a quaternion's,
    /// whose loss is sign-invariant).
    AllBut(Vec<usize>),
}

/// Settings of [`train_learned_start`] (plain data in the runtime).
pub use simhc::training::LearnedStartConfig;

/// Why training failed.
#[derive(Debug, Error)]
pub enum LearnedStartError {
    /// The sampler returned a parameter or unknown vector of the wrong length.
    #[error("sample {index}: {what} has {got} numbers, the layout has {expected}")]
    Length {
        /// Sample index.
        index: usize,
        /// `"parameters"` or `"unknowns"`.
        what: &'static str,
        /// Length returned.
        got: usize,
        /// The layout's length.
        expected: usize,
    },
    /// The sampler returned a non-finite value (or a zero quaternion).
    #[error("sample {index}: non-finite value or zero quaternion")]
    NonFinite {
        /// Sample index.
        index: usize,
    },
    /// The sampler drew `draws` scenes in a row without features.
    #[error("sample {index}: {draws} scenes in a row without features (a degenerate sampler?)")]
    NoFeatures {
        /// Sample index.
        index: usize,
        /// Scenes drawn for it.
        draws: usize,
    },
    /// The settings describe no network that can be trained.
    #[error("settings: {0}")]
    Config(#[from] simhc::training::LearnedStartConfigError),
    /// The data set could not be built.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The trained network could not be exported.
    #[error(transparent)]
    Export(#[from] RegressorError),
}

/// Scenes drawn in a row without features before the trainer gives up.
pub const MAX_DRAWS: usize = 1000;

/// Sample `index`'s features: scenes from `scene(index, rng)` until one has features.
fn draw<H: FeatureHook>(
    hook: &H,
    index: usize,
    rng: &mut ChaCha8Rng,
    scene: &mut impl FnMut(usize, &mut ChaCha8Rng) -> H::Scene,
    rows: &mut [f32],
    target: &mut [f64],
) -> Result<(), LearnedStartError> {
    for _ in 0..MAX_DRAWS {
        rows.fill(0.0);
        target.fill(0.0);
        if hook.features(index, &scene(index, rng), rows, target)? {
            return Ok(());
        }
    }
    Err(LearnedStartError::NoFeatures { index, draws: MAX_DRAWS })
}

/// `count` samples of `hook`, unstandardized: scene `i` drawn by `scene(i, rng)` from
/// `ChaCha8Rng::seed_from_u64(seed)` in order (a scene without features is replaced by the next
/// draw).
pub fn scene_dataset<H: FeatureHook>(
    hook: &H,
    count: usize,
    seed: u64,
    mut scene: impl FnMut(usize, &mut ChaCha8Rng) -> H::Scene,
) -> Result<InMemoryDataset, LearnedStartError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let ((points, width), nt) = (hook.input_shape(), hook.target_width());
    let (mut rows, mut target) = (vec![0.0f32; points * width], vec![0.0f64; nt]);
    let mut failed = None;
    let data = InMemoryDataset::from_fn(count, points, width, nt, |i| {
        if failed.is_none() {
            if let Err(e) = draw(hook, i, &mut rng, &mut scene, &mut rows, &mut target) {
                failed = Some(e);
            }
        }
        Sample { rows: rows.clone(), target: target.iter().map(|v| *v as f32).collect() }
    });
    match failed {
        Some(e) => Err(e),
        None => Ok(data?),
    }
}

/// A network trained through a [`FeatureHook`].
#[derive(Debug)]
pub struct HookTrained {
    /// The model, in inference mode (on standardized inputs and targets where the hook
    /// standardizes).
    pub model: PoseRegressor,
    /// What the training loop did.
    pub run: TrainRun,
    /// Input and target standardizations, where the hook standardizes.
    standardization: Option<(Standardization, Standardization)>,
}

impl HookTrained {
    /// The runtime network: the model with its standardizations folded in, so that it maps the
    /// hook's raw rows to raw targets.
    pub fn folded(&self) -> Result<FoldedNetwork, RegressorError> {
        let net = fold(&self.model)?;
        match &self.standardization {
            Some((input, output)) => fold_standardizations(&net, input, output),
            None => Ok(net),
        }
    }
}

/// Trains network `model` on `samples` scenes of `hook` (module docs) with `train`.
pub fn train_with_hook<H: FeatureHook>(
    hook: &H,
    model: &RegressorConfig,
    train: &TrainConfig,
    samples: usize,
    mut scene: impl FnMut(usize, &mut ChaCha8Rng) -> H::Scene,
) -> Result<HookTrained, LearnedStartError> {
    // Drawing the scenes takes a while before the first training step: show it.
    let bar = if train.progress {
        indicatif::ProgressBar::new(samples as u64).with_style(
            indicatif::ProgressStyle::default_bar()
                .template("{elapsed_precise} [{bar:30}] {pos}/{len} scenes drawn")
                .expect("valid template"),
        )
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut scene = |i: usize, rng: &mut ChaCha8Rng| {
        bar.inc(1);
        scene(i, rng)
    };
    let (data, standardization) = match hook.standardize() {
        Standardize::No => (scene_dataset(hook, samples, train.seed, scene)?, None),
        Standardize::AllBut(raw) => {
            let mut rng = ChaCha8Rng::seed_from_u64(train.seed);
            let ((rows_n, width), nt) = (hook.input_shape(), hook.target_width());
            let mut inputs: Vec<Vec<f32>> = Vec::with_capacity(samples);
            let mut targets: Vec<Vec<f64>> = Vec::with_capacity(samples);
            for index in 0..samples {
                let (mut rows, mut target) = (vec![0.0f32; rows_n * width], vec![0.0f64; nt]);
                draw(hook, index, &mut rng, &mut scene, &mut rows, &mut target)?;
                inputs.push(rows);
                targets.push(target);
            }
            let in_std =
                Standardization::of(inputs.iter().flat_map(|r| r.chunks_exact(width)).map(|c| c.iter().map(|v| f64::from(*v))), width);
            let mut out_std = Standardization::of(targets.iter().map(|x| x.iter().copied()), nt);
            for &k in raw.iter().filter(|&&k| k < nt) {
                out_std.mean[k] = 0.0;
                out_std.scale[k] = 1.0;
            }
            let mut next = 0;
            let data = InMemoryDataset::from_fn(samples, rows_n, width, nt, |_| {
                let i = next;
                next += 1;
                let rows = inputs[i]
                    .chunks_exact(width)
                    .flat_map(|c| c.iter().enumerate().map(|(k, v)| in_std.apply(k, f64::from(*v)) as f32))
                    .collect();
                let target = targets[i].iter().enumerate().map(|(k, v)| out_std.apply(k, *v) as f32).collect();
                Sample { rows, target }
            })?;
            (data, Some((in_std, out_std)))
        }
    };
    bar.finish_and_clear();
    let (model, run) = train_with_loss(model, &data, train, |p, t| hook.sample_losses(p, t).mean());
    Ok(HookTrained { model, run, standardization })
}

/// A declared problem's hook (module docs): a scene is `(p, x)`, the parameters and the true
/// unknowns; the inputs are the rows of `R` ([`InputRows`]: by default [`LayoutRows`], the
/// layout's rows), the targets the unknowns in layout order.
#[derive(Debug, Clone, Copy)]
pub struct LayoutFeatures<'a, R = LayoutRows> {
    layout: &'a Layout,
    rows: R,
}

impl<'a> LayoutFeatures<'a> {
    /// The hook of a problem of this layout, on the layout's rows.
    pub fn new(layout: &'a Layout) -> Self {
        Self { layout, rows: LayoutRows(*layout) }
    }
}

impl<'a, R: InputRows> LayoutFeatures<'a, R> {
    /// The hook of a problem of this layout, on the problem's own input rows.
    pub fn with_rows(layout: &'a Layout, rows: R) -> Self {
        Self { layout, rows }
    }

    /// The network of `config` for this hook.
    pub fn model(&self, config: &LearnedStartConfig) -> RegressorConfig {
        RegressorConfig::new(self.rows.shape().1, config.point_widths.clone(), config.head_widths.clone())
            .with_outputs(HypothesisBlocks::trained(self.layout.unknown_len(), config.hypotheses).outputs())
            .with_normalize_output(false)
            .with_context_after(config.context_after)
    }
}

impl<R: InputRows> FeatureHook for LayoutFeatures<'_, R> {
    type Scene = (Vec<f64>, Vec<f64>);

    fn input_shape(&self) -> (usize, usize) {
        self.rows.shape()
    }

    fn target_width(&self) -> usize {
        self.layout.unknown_len()
    }

    fn features(&self, index: usize, (p, x): &Self::Scene, rows: &mut [f32], target: &mut [f64]) -> Result<bool, LearnedStartError> {
        let layout = self.layout;
        let check =
            |what, got, expected| if got == expected { Ok(()) } else { Err(LearnedStartError::Length { index, what, got, expected }) };
        check("parameters", p.len(), layout.param_len())?;
        check("unknowns", x.len(), layout.unknown_len())?;
        target.copy_from_slice(x);
        if p.iter().any(|v| !v.is_finite()) || !layout.normalize_unknowns(target) {
            return Err(LearnedStartError::NonFinite { index });
        }
        // A scene whose rows cannot be made (degenerate for the problem's own rows) is redrawn.
        Ok(self.rows.write(p, rows) && rows.iter().all(|v| v.is_finite()))
    }

    fn standardize(&self) -> Standardize {
        let quats = self.layout.unknowns.iter().filter(|f| f.kind == FieldKind::Quat);
        Standardize::AllBut(quats.flat_map(|f| f.offset..f.offset + 4).collect())
    }

    fn sample_losses(&self, pred: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
        let unknowns = self.layout.unknowns;
        let batch = pred.dims()[0];
        let mut terms: Vec<Tensor<1>> = Vec::new();
        for f in unknowns.iter().filter(|f| f.kind == FieldKind::Quat) {
            let a = pred.clone().narrow(1, f.offset, 4);
            let a = a.clone() / a.square().sum_dim(1).sqrt().clamp_min(1e-6);
            let dot = (a * target.clone().narrow(1, f.offset, 4)).sum_dim(1);
            terms.push((dot.square().neg() + 1.0).reshape([batch]));
        }
        for f in unknowns.iter().filter(|f| f.kind != FieldKind::Quat) {
            let n = f.kind.len();
            let d = pred.clone().narrow(1, f.offset, n) - target.clone().narrow(1, f.offset, n);
            terms.push(d.square().sum_dim(1).reshape([batch]));
        }
        terms.into_iter().reduce(|a, b| a + b).expect("a problem has unknowns")
    }
}

/// A trained learned start.
#[derive(Debug, Clone)]
pub struct TrainedStart<R = LayoutRows> {
    /// The start provider (its network has the standardizations folded in).
    pub start: LearnedStart<R>,
    /// What the training loop did.
    pub run: TrainRun,
}

/// Trains a learned start for a problem of `layout` on `config.samples` draws of
/// `sample(rng) -> (p, x)` (parameters and true unknowns), on the layout's rows
/// ([`LayoutFeatures`]).
pub fn train_learned_start<F>(layout: &Layout, config: &LearnedStartConfig, sample: F) -> Result<TrainedStart, LearnedStartError>
where
    F: FnMut(&mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>),
{
    train_learned_start_with(layout, LayoutRows(*layout), config, sample)
}

/// [`train_learned_start`] on the problem's own input rows `rows`; the trained start reads
/// its parameters through the same `rows`. A scene whose rows cannot be made is redrawn.
pub fn train_learned_start_with<R, F>(
    layout: &Layout,
    rows: R,
    config: &LearnedStartConfig,
    mut sample: F,
) -> Result<TrainedStart<R>, LearnedStartError>
where
    R: InputRows,
    F: FnMut(&mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>),
{
    let (network, run) = train_network(layout, &rows, config, &mut sample)?;
    Ok(TrainedStart { start: LearnedStart::with_rows(network, *layout, rows)?, run })
}

/// Draws a scene: its parameters and its true unknowns.
type SceneSampler<'a> = dyn FnMut(&mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>) + 'a;

/// The network and the run of [`train_learned_start_with`]. Not generic, so that burn's
/// training loop is compiled once, here, and not again in every problem's binary: it was a
/// fifth of the LLVM IR of the example's `grp` (`cargo llvm-lines`, 2026-12-05).
fn train_network(
    layout: &Layout,
    rows: &dyn InputRows,
    config: &LearnedStartConfig,
    sample: &mut SceneSampler<'_>,
) -> Result<(FoldedNetwork, TrainRun), LearnedStartError> {
    config.check()?;
    let hook = LayoutFeatures::with_rows(layout, rows);
    let model = hook.model(config);
    let hook = WinnerTakesAll { hook, hypotheses: config.hypotheses, relax: config.relax };
    let trained = train_with_hook(&hook, &model, &config.train, config.samples, |_, rng| sample(rng))?;
    Ok((trained.folded()?, trained.run))
}

/// Per-column mean and scale (standard deviation, 1 for a constant column).
#[derive(Debug, Clone, PartialEq)]
struct Standardization {
    mean: Vec<f64>,
    scale: Vec<f64>,
}

impl Standardization {
    fn of<I, R>(rows: I, width: usize) -> Self
    where
        I: Iterator<Item = R> + Clone,
        R: Iterator<Item = f64>,
    {
        let (mut sum, mut count) = (vec![0.0f64; width], 0.0f64);
        for row in rows.clone() {
            row.enumerate().for_each(|(k, v)| sum[k] += v);
            count += 1.0;
        }
        let mean: Vec<f64> = sum.iter().map(|s| s / count.max(1.0)).collect();
        let mut var = vec![0.0; width];
        for row in rows {
            row.enumerate().for_each(|(k, v)| var[k] += (v - mean[k]).powi(2));
        }
        let scale = var.iter().map(|v| (v / count.max(1.0)).sqrt()).map(|s| if s > 1e-12 { s } else { 1.0 }).collect();
        Self { mean, scale }
    }

    fn apply(&self, k: usize, v: f64) -> f64 {
        (v - self.mean[k]) / self.scale[k]
    }
}

/// The network with `input` folded into its first layer and `output` undone in its last:
/// `W' = W / s_in`, `b' = b - W (m_in / s_in)` and `W'' = W s_out`, `b'' = b s_out + m_out`
/// (weights stored input-major, `w[i * outputs + o]`).
fn fold_standardizations(net: &FoldedNetwork, input: &Standardization, output: &Standardization) -> Result<FoldedNetwork, RegressorError> {
    let mut point: Vec<DenseLayer> = net.point_layers().to_vec();
    let mut head: Vec<DenseLayer> = net.head_layers().to_vec();
    let first = &point[0];
    let (ni, no) = (first.inputs(), first.outputs());
    let mut w: Vec<f64> = first.weights().iter().map(|v| f64::from(*v)).collect();
    let mut b: Vec<f64> = first.bias().iter().map(|v| f64::from(*v)).collect();
    for i in 0..ni {
        for o in 0..no {
            b[o] -= w[i * no + o] * input.mean[i] / input.scale[i];
            w[i * no + o] /= input.scale[i];
        }
    }
    point[0] = DenseLayer::new(ni, no, w.iter().map(|v| *v as f32).collect(), b.iter().map(|v| *v as f32).collect())?;
    let last = head.last().expect("a folded network has a head");
    let (ni, no) = (last.inputs(), last.outputs());
    let mut w: Vec<f64> = last.weights().iter().map(|v| f64::from(*v)).collect();
    let mut b: Vec<f64> = last.bias().iter().map(|v| f64::from(*v)).collect();
    // With several hypotheses the outputs are blocks of the targets' width, each undone alike;
    // the scores after them stay as they are.
    let width = output.scale.len();
    let blocks = HypothesisBlocks::of(no, width, usize::MAX).ok_or(RegressorError::Format("outputs are not blocks of the targets"))?;
    for o in 0..no {
        let (scale, mean) = if o < blocks.count * width { (output.scale[o % width], output.mean[o % width]) } else { (1.0, 0.0) };
        for i in 0..ni {
            w[i * no + o] *= scale;
        }
        b[o] = b[o] * scale + mean;
    }
    let n = head.len();
    head[n - 1] = DenseLayer::new(ni, no, w.iter().map(|v| *v as f32).collect(), b.iter().map(|v| *v as f32).collect())?;
    FoldedNetwork::with_context(net.input_width(), point, head, false, net.context_after())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The folded network on raw inputs gives the raw outputs of the original network on
    /// standardized inputs.
    #[test]
    fn standardizations_fold_exactly() {
        let point = DenseLayer::new(2, 3, vec![0.5, -1.0, 0.25, 2.0, 0.75, -0.5], vec![0.1, 0.2, -0.3]).unwrap();
        let head = DenseLayer::new(3, 2, vec![1.0, -2.0, 0.5, 0.25, -1.5, 1.0], vec![0.05, -0.1]).unwrap();
        let net = FoldedNetwork::new(2, vec![point], vec![head], false).unwrap();
        let input = Standardization { mean: vec![3.0, -1.0], scale: vec![2.0, 0.5] };
        let output = Standardization { mean: vec![10.0, -4.0], scale: vec![3.0, 0.25] };
        let folded = fold_standardizations(&net, &input, &output).unwrap();
        let raw = [4.0f32, -0.5, 1.0, 0.0, 2.5, -2.0];
        let standardized: Vec<f32> = raw.chunks(2).flat_map(|r| [(r[0] - 3.0) / 2.0, (r[1] + 1.0) / 0.5]).collect();
        let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
        net.forward(&standardized, &mut a).unwrap();
        folded.forward(&raw, &mut b).unwrap();
        let expected = [a[0] * 3.0 + 10.0, a[1] * 0.25 - 4.0];
        for k in 0..2 {
            assert!((b[k] - expected[k]).abs() < 1e-5 * (1.0 + expected[k].abs()), "{b:?} vs {expected:?}");
        }
    }

    /// A bad sampler is a typed error naming the sample, before any training.
    #[test]
    fn bad_samples_are_typed_errors() {
        use simhc::layout::FieldLayout;
        const UNKNOWNS: &[FieldLayout] =
            &[FieldLayout { name: "q", kind: FieldKind::Quat, offset: 0 }, FieldLayout { name: "s", kind: FieldKind::Scalar, offset: 4 }];
        const ROW: &[FieldLayout] = &[FieldLayout { name: "f", kind: FieldKind::Vector(3), offset: 0 }];
        let layout = Layout {
            unknowns: UNKNOWNS,
            row: ROW,
            globals: &[],
            rows: 2,
            per_row: 3,
            equations_per_row: 1,
            parameter_free: &[],
            norms: &[],
        };
        let config = LearnedStartConfig { samples: 4, ..LearnedStartConfig::default() };
        let good = |_: &mut ChaCha8Rng| (vec![0.1; 6], vec![1.0, 0.0, 0.0, 0.0, 2.0]);
        let mut calls = 0;
        let short = train_learned_start(&layout, &config, |rng| {
            calls += 1;
            if calls == 3 {
                (vec![0.1; 5], vec![1.0, 0.0, 0.0, 0.0, 2.0])
            } else {
                good(rng)
            }
        });
        assert!(matches!(short, Err(LearnedStartError::Length { index: 2, what: "parameters", got: 5, expected: 6 })), "{short:?}");
        let unknowns = train_learned_start(&layout, &config, |_| (vec![0.1; 6], vec![1.0, 0.0, 0.0, 0.0]));
        assert!(matches!(unknowns, Err(LearnedStartError::Length { index: 0, what: "unknowns", got: 4, expected: 5 })));
        let nan = train_learned_start(&layout, &config, |_| (vec![0.1, f64::NAN, 0.1, 0.1, 0.1, 0.1], vec![1.0, 0.0, 0.0, 0.0, 2.0]));
        assert!(matches!(nan, Err(LearnedStartError::NonFinite { index: 0 })));
        let zero_quaternion = train_learned_start(&layout, &config, |_| (vec![0.1; 6], vec![0.0, 0.0, 0.0, 0.0, 2.0]));
        assert!(matches!(zero_quaternion, Err(LearnedStartError::NonFinite { index: 0 })));
    }

    /// A sampler whose scenes never have features is a typed error naming the sample, not an
    /// endless loop.
    #[test]
    fn a_sampler_without_features_is_a_typed_error() {
        struct Never;
        impl FeatureHook for Never {
            type Scene = ();
            fn input_shape(&self) -> (usize, usize) {
                (1, 1)
            }
            fn target_width(&self) -> usize {
                1
            }
            fn features(&self, _: usize, _: &(), _: &mut [f32], _: &mut [f64]) -> Result<bool, LearnedStartError> {
                Ok(false)
            }
            fn sample_losses(&self, prediction: Tensor<2>, _: Tensor<2>) -> Tensor<1> {
                prediction.sum()
            }
        }
        let mut draws = 0;
        let err = scene_dataset(&Never, 3, 0, |_, _| draws += 1).unwrap_err();
        assert!(matches!(err, LearnedStartError::NoFeatures { index: 0, draws: MAX_DRAWS }), "{err:?}");
        assert_eq!(draws, MAX_DRAWS);
    }

    /// A scene that the problem's own input rows refuse is redrawn, and the rows are the
    /// trainer's input.
    #[test]
    fn scenes_without_own_rows_are_redrawn() {
        use simhc::layout::FieldLayout;
        struct Positive;
        impl InputRows for Positive {
            fn shape(&self) -> (usize, usize) {
                (1, 2)
            }
            fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
                out.copy_from_slice(&[p[0] as f32, (p[0] * p[0]) as f32]);
                p[0] > 0.0
            }
        }
        const ONE: &[FieldLayout] = &[FieldLayout { name: "a", kind: FieldKind::Scalar, offset: 0 }];
        let layout =
            Layout { unknowns: ONE, row: ONE, globals: &[], rows: 1, per_row: 1, equations_per_row: 1, parameter_free: &[], norms: &[] };
        let hook = LayoutFeatures::with_rows(&layout, Positive);
        assert_eq!(hook.input_shape(), (1, 2));
        let mut draws = 0;
        let data = scene_dataset(&hook, 3, 0, |_, _| {
            draws += 1;
            (vec![if draws % 2 == 0 { f64::from(draws) } else { -1.0 }], vec![0.5])
        })
        .unwrap();
        assert_eq!(draws, 6);
        for (i, v) in [2.0f32, 4.0, 6.0].into_iter().enumerate() {
            assert_eq!(data.rows(i), &[v, v * v]);
            assert_eq!(data.target(i), &[0.5]);
        }
    }

    #[test]
    fn constant_columns_get_unit_scale() {
        let s = Standardization::of([vec![1.0, 5.0], vec![5.0, 5.0]].iter().map(|r| r.iter().copied()), 2);
        assert_eq!(s.mean, vec![3.0, 5.0]);
        assert_eq!(s.scale, vec![2.0, 1.0]);
    }
}
