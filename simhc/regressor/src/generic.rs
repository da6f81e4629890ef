//! The generic learned start: trains a [`simhc::pipeline::learned::LearnedStart`] for any
//! declared problem from its scene sampler, reading parameters and unknowns through the
//! problem's [`Layout`] (emitted by `#[simhc_problem]`).
//!
//! - Input rows: [`layout_rows`] (a row's parameters and the globals), standardized per channel
//!   over the training set.
//! - Outputs: the unknowns in layout order. Quaternion unknowns get the sign-invariant loss
//!   `1 - (q^ . q)²` on the normalized prediction (`q` and `-q` are one rotation); the other
//!   unknowns are standardized over the training set and get the squared error.
//! - The standardizations are folded into the first and last dense layers of the exported
//!   [`FoldedNetwork`], which therefore maps raw parameters to raw unknowns.
//!
//! Seeds: the samples come from `ChaCha8Rng::seed_from_u64(config.train.seed)` in order, and the
//! training loop ([`train_with_loss`]) is seeded the same way, so a run is reproducible.

use crate::data::{DataError, InMemoryDataset, Sample};
use crate::inference::fold;
use crate::model::RegressorConfig;
use crate::training::{train_with_loss, TrainConfig, TrainRun};
use burn::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::layout::{FieldKind, Layout};
use simhc::pipeline::learned::{layout_row_count, layout_row_width, layout_rows, LearnedStart};
use simhc::regressor::{DenseLayer, FoldedNetwork, RegressorError};
use thiserror::Error;

/// Settings of [`train_learned_start`].
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedStartConfig {
    /// Widths of the point layers (per row).
    pub point_widths: Vec<usize>,
    /// Widths of the hidden head layers.
    pub head_widths: Vec<usize>,
    /// Training scenes.
    pub samples: usize,
    /// Optimizer settings; `train.seed` also seeds the sampler.
    pub train: TrainConfig,
}

impl Default for LearnedStartConfig {
    fn default() -> Self {
        Self {
            point_widths: vec![64, 128, 128],
            head_widths: vec![128],
            samples: 50_000,
            train: TrainConfig { learning_rate: 2e-3, final_learning_rate: 2e-5, ..TrainConfig::default() },
        }
    }
}

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
    /// The data set could not be built.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The trained network could not be exported.
    #[error(transparent)]
    Export(#[from] RegressorError),
}

/// A trained learned start.
#[derive(Debug, Clone)]
pub struct TrainedStart {
    /// The start provider (its network has the standardizations folded in).
    pub start: LearnedStart,
    /// What the training loop did.
    pub run: TrainRun,
}

/// Trains a learned start for a problem of `layout` on `config.samples` draws of
/// `sample(rng) -> (p, x)` (parameters and true unknowns).
pub fn train_learned_start<F>(layout: &Layout, config: &LearnedStartConfig, mut sample: F) -> Result<TrainedStart, LearnedStartError>
where
    F: FnMut(&mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>),
{
    let (rows_n, width, nx) = (layout_row_count(layout), layout_row_width(layout), layout.unknown_len());
    let mut rng = ChaCha8Rng::seed_from_u64(config.train.seed);
    let mut inputs: Vec<Vec<f32>> = Vec::with_capacity(config.samples);
    let mut targets: Vec<Vec<f64>> = Vec::with_capacity(config.samples);
    for index in 0..config.samples {
        let (p, mut x) = sample(&mut rng);
        let check =
            |what, got, expected| if got == expected { Ok(()) } else { Err(LearnedStartError::Length { index, what, got, expected }) };
        check("parameters", p.len(), layout.param_len())?;
        check("unknowns", x.len(), nx)?;
        let mut rows = vec![0.0f32; rows_n * width];
        if !layout_rows(layout, &p, &mut rows) || !simhc::pipeline::learned::normalize_quaternions(layout, &mut x) {
            return Err(LearnedStartError::NonFinite { index });
        }
        inputs.push(rows);
        targets.push(x);
    }

    // Standardizations: inputs per channel, non-quaternion outputs per unknown.
    let in_std = Standardization::of(inputs.iter().flat_map(|r| r.chunks_exact(width)).map(|c| c.iter().map(|v| f64::from(*v))), width);
    let mut out_std = Standardization::of(targets.iter().map(|x| x.iter().copied()), nx);
    for f in layout.unknowns.iter().filter(|f| f.kind == FieldKind::Quat) {
        for k in f.offset..f.offset + 4 {
            out_std.mean[k] = 0.0;
            out_std.scale[k] = 1.0;
        }
    }
    let mut next = 0;
    let data = InMemoryDataset::from_fn(config.samples, rows_n, width, nx, |_| {
        let i = next;
        next += 1;
        let rows =
            inputs[i].chunks_exact(width).flat_map(|c| c.iter().enumerate().map(|(k, v)| in_std.apply(k, f64::from(*v)) as f32)).collect();
        let target = targets[i].iter().enumerate().map(|(k, v)| out_std.apply(k, *v) as f32).collect();
        Sample { rows, target }
    })?;

    let quats: Vec<usize> = layout.unknowns.iter().filter(|f| f.kind == FieldKind::Quat).map(|f| f.offset).collect();
    let others: Vec<(usize, usize)> =
        layout.unknowns.iter().filter(|f| f.kind != FieldKind::Quat).map(|f| (f.offset, f.kind.len())).collect();
    let model =
        RegressorConfig::new(width, config.point_widths.clone(), config.head_widths.clone()).with_outputs(nx).with_normalize_output(false);
    let (trained, run) = train_with_loss(&model, &data, &config.train, |pred, target| {
        let mut terms: Vec<Tensor<1>> = Vec::new();
        for &o in &quats {
            let a = pred.clone().narrow(1, o, 4);
            let a = a.clone() / a.square().sum_dim(1).sqrt().clamp_min(1e-6);
            let dot = (a * target.clone().narrow(1, o, 4)).sum_dim(1);
            terms.push((dot.square().neg() + 1.0).mean());
        }
        for &(o, n) in &others {
            let d = pred.clone().narrow(1, o, n) - target.clone().narrow(1, o, n);
            terms.push(d.square().sum_dim(1).mean());
        }
        terms.into_iter().reduce(|a, b| a + b).expect("a problem has unknowns")
    });
    let network = fold_standardizations(&fold(&trained)?, &in_std, &out_std)?;
    Ok(TrainedStart { start: LearnedStart::new(network, *layout)?, run })
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
    for o in 0..no {
        for i in 0..ni {
            w[i * no + o] *= output.scale[o];
        }
        b[o] = b[o] * output.scale[o] + output.mean[o];
    }
    let n = head.len();
    head[n - 1] = DenseLayer::new(ni, no, w.iter().map(|v| *v as f32).collect(), b.iter().map(|v| *v as f32).collect())?;
    FoldedNetwork::new(net.input_width(), point, head, false)
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
        let layout = Layout { unknowns: UNKNOWNS, row: ROW, globals: &[], rows: 2, per_row: 3 };
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

    #[test]
    fn constant_columns_get_unit_scale() {
        let s = Standardization::of([vec![1.0, 5.0], vec![5.0, 5.0]].iter().map(|r| r.iter().copied()), 2);
        assert_eq!(s.mean, vec![3.0, 5.0]);
        assert_eq!(s.scale, vec![2.0, 1.0]);
    }
}
