//! Inference with burn (the reference path) and export to the runtime's
//! [`FoldedNetwork`](simhc::regressor::FoldedNetwork).
//!
//! Shipped weights (written by `examples/train_upnp.rs`):
//! - `problems/weights/upnp.bpk`: the burn record of [`RegressorConfig::upnp`] (burnpack);
//! - `problems/weights/upnp.folded`: the same network with batch norm folded, in the binary
//!   format of [`simhc::regressor`], read by `FoldedNetwork::from_bytes`.

use crate::model::{PoseRegressor, RegressorConfig};
use burn::prelude::*;
use burn::store::{ModuleRecord, RecordError};
use simhc::regressor::{DenseLayer, FoldedNetwork, RegressorError};

/// The shipped burn weights of the UPnP regressor (`problems/weights/upnp.bpk`).
pub static UPNP_BPK: &[u8] = include_bytes!("../../../problems/weights/upnp.bpk");

/// The shipped folded weights of the UPnP regressor (`problems/weights/upnp.folded`).
pub static UPNP_FOLDED: &[u8] = include_bytes!("../../../problems/weights/upnp.folded");

/// Loads a burnpack record (bytes of a `.bpk` file) into a `config` network on the plain flex
/// device, in inference mode.
pub fn load_bpk_bytes(config: &RegressorConfig, bytes: &[u8]) -> Result<PoseRegressor, RecordError> {
    let device = Device::flex();
    let record = ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes.to_vec()))?;
    Ok(config.init(&device).load_record(record).valid())
}

/// The shipped UPnP regressor ([`UPNP_BPK`], architecture [`RegressorConfig::upnp`]).
pub fn upnp_embedded() -> PoseRegressor {
    load_bpk_bytes(&RegressorConfig::upnp(), UPNP_BPK).expect("shipped upnp.bpk is valid")
}

/// The shipped folded UPnP regressor ([`UPNP_FOLDED`]).
pub fn upnp_folded_embedded() -> FoldedNetwork {
    FoldedNetwork::from_bytes(UPNP_FOLDED).expect("shipped upnp.folded is valid")
}

/// Runs `model` on one sample: `rows` flat, `points` rows of the model's input width. Returns
/// the outputs (a unit quaternion for UPnP).
pub fn predict(model: &PoseRegressor, rows: &[f32], points: usize, device: &Device) -> Vec<f32> {
    predict_batch(model, rows, 1, points, device)
}

/// Runs `model` on `batch` samples at once: `rows` flat, sample after sample, each `points`
/// rows. Returns the outputs flat (`outputs` numbers per sample).
pub fn predict_batch(model: &PoseRegressor, rows: &[f32], batch: usize, points: usize, device: &Device) -> Vec<f32> {
    let channels = rows.len() / (batch * points);
    assert_eq!(rows.len(), batch * points * channels, "rows not [batch, points, channels]");
    let x = Tensor::<3>::from_data(TensorData::new(rows.to_vec(), [batch, points, channels]), device);
    model.forward(x).into_data().try_to_vec::<f32>().expect("f32 output")
}

fn tensor_values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().try_to_vec::<f32>().expect("f32 parameters")
}

/// The model with each batch norm (running statistics, inference mode) folded into the
/// preceding dense layer: `W' = W diag(s)`, `b' = (b - mean) s + beta`,
/// `s = gamma / sqrt(var + eps)`.
pub fn fold(model: &PoseRegressor) -> Result<FoldedNetwork, RegressorError> {
    let dense = |layer: &burn::nn::Linear| -> (usize, usize, Vec<f32>, Vec<f32>) {
        let [i, o] = layer.weight.dims();
        let w = tensor_values(layer.weight.val());
        let b = match &layer.bias {
            Some(b) => tensor_values(b.val()),
            None => vec![0.0; o],
        };
        (i, o, w, b)
    };
    let input_width = model.point_layers[0].weight.dims()[0];
    let mut point = Vec::new();
    for (layer, norm) in model.point_layers.iter().zip(&model.point_norms) {
        let (i, o, w, b) = dense(layer);
        let gamma = tensor_values(norm.gamma.val());
        let beta = tensor_values(norm.beta.val());
        let mean = tensor_values(norm.running_mean.value());
        let var = tensor_values(norm.running_var.value());
        // fold in f64, round once
        let s: Vec<f64> = (0..o).map(|j| f64::from(gamma[j]) / (f64::from(var[j]) + norm.epsilon).sqrt()).collect();
        let w: Vec<f32> = (0..i * o).map(|k| (f64::from(w[k]) * s[k % o]) as f32).collect();
        let b: Vec<f32> = (0..o).map(|j| ((f64::from(b[j]) - f64::from(mean[j])) * s[j] + f64::from(beta[j])) as f32).collect();
        point.push(DenseLayer::new(i, o, w, b)?);
    }
    let mut head = Vec::new();
    for layer in &model.head_layers {
        let (i, o, w, b) = dense(layer);
        head.push(DenseLayer::new(i, o, w, b)?);
    }
    FoldedNetwork::with_context(input_width, point, head, model.normalize_output, model.context_after)
}

/// [`fold`] serialized in the runtime's binary format (`problems/weights/upnp.folded`).
pub fn export_folded(model: &PoseRegressor) -> Vec<u8> {
    fold(model).expect("a trained model has finite weights and chained widths").to_bytes()
}
