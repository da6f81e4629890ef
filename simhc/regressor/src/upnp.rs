//! UPnP training data and the training command: scenes from the paper's sampler
//! ([`UpnpSceneConfig::sample_with`]) over every frame, input rows in canonical frames
//! ([`UpnpFrame`], the same code the runtime calls at inference), targets the quaternion of the
//! canonical rotation `V R W^T`.
//!
//! The distribution covers all rotations and both point layouts: scene `i` has its points in
//! the viewer box for even `i` and in the world box for odd `i`, and its world and viewer frames
//! changed by uniformly random rigid motions. The canonical frames remove the frames again up
//! to their sign and axis choices, so what the network learns does not depend on them.
//!
//! Seeds: the training scenes are drawn one after another from
//! `ChaCha8Rng::seed_from_u64(seed)`; validation scene `i` is drawn from
//! `ChaCha8Rng::seed_from_u64(valid_first_seed + i)`, a different stream, so the two sets do not
//! overlap.

use crate::data::{DataError, InMemoryDataset, Sample};
use crate::model::{PoseRegressor, RegressorConfig};
use crate::training::{self, RotationStats, TrainConfig, TrainReport};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc_problems::upnp::features::{UpnpFrame, UPNP_OUTPUTS, UPNP_ROW_WIDTH};
use simhc_problems::upnp::scene::{PointBox, UpnpScene, UpnpSceneConfig};
use std::time::Instant;

/// The training sample of a scene: its canonical rows and canonical quaternion; `None` for a
/// scene without canonical frames (coincident points, which the sampler does not produce).
pub fn scene_sample(scene: &UpnpScene) -> Option<Sample> {
    let frame = UpnpFrame::new(&scene.correspondences)?;
    let mut rows = vec![0.0f32; UPNP_ROW_WIDTH * scene.correspondences.len()];
    frame.rows(&scene.correspondences, &mut rows).then_some(())?;
    let target = frame.encode(&scene.rotation).map(|v| v as f32).to_vec();
    Some(Sample { rows, target })
}

/// Scene `i` of a stream (module docs): viewer box for even `i`, world box for odd `i`, random
/// frames.
pub fn sample_scene<R: Rng + ?Sized>(config: &UpnpSceneConfig, i: usize, rng: &mut R) -> UpnpScene {
    let layout = if i.is_multiple_of(2) { PointBox::Viewer } else { PointBox::World };
    config.sample_with(layout, true, rng).expect("valid scene config")
}

/// Validation scene `i` (its own seed, `first_seed + i`).
pub fn validation_scene(config: &UpnpSceneConfig, first_seed: u64, i: usize) -> UpnpScene {
    sample_scene(config, i, &mut ChaCha8Rng::seed_from_u64(first_seed + i as u64))
}

/// Builds a data set from scenes (all with `scene_config.points` correspondences).
fn dataset_of(
    scene_config: &UpnpSceneConfig,
    count: usize,
    mut scene: impl FnMut(usize) -> UpnpScene,
) -> Result<InMemoryDataset, DataError> {
    InMemoryDataset::from_fn(count, scene_config.points, UPNP_ROW_WIDTH, UPNP_OUTPUTS, |i| {
        // Sampled scenes have spread points and unit, finite bearings; a failure here is a
        // sampler bug.
        scene_sample(&scene(i)).expect("sampled scene has canonical frames")
    })
}

/// `count` training scenes drawn in order from `ChaCha8Rng::seed_from_u64(seed)`.
pub fn training_dataset(scene_config: &UpnpSceneConfig, count: usize, seed: u64) -> Result<InMemoryDataset, DataError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    dataset_of(scene_config, count, |i| sample_scene(scene_config, i, &mut rng))
}

/// `count` validation scenes ([`validation_scene`]).
pub fn validation_dataset(scene_config: &UpnpSceneConfig, count: usize, first_seed: u64) -> Result<InMemoryDataset, DataError> {
    dataset_of(scene_config, count, |i| validation_scene(scene_config, first_seed, i))
}

/// Settings of [`train_upnp`]; the default is the configuration of the shipped weights.
#[derive(Debug, Clone)]
pub struct UpnpTrainConfig {
    /// Scene sampler (default: the paper's, 4 cameras, 16 points, 2 px).
    pub scene: UpnpSceneConfig,
    /// Network architecture.
    pub model: RegressorConfig,
    /// Optimizer settings; `train.seed` also seeds the training scenes.
    pub train: TrainConfig,
    /// Number of training scenes.
    pub train_samples: usize,
    /// Number of validation scenes.
    pub valid_samples: usize,
    /// Seed of the first validation scene.
    pub valid_first_seed: u64,
}

/// First seed of the validation scenes used by [`train_upnp`] by default.
pub const VALID_FIRST_SEED: u64 = 1_000_000;

impl Default for UpnpTrainConfig {
    fn default() -> Self {
        Self {
            scene: UpnpSceneConfig::default(),
            model: RegressorConfig::upnp(),
            train: TrainConfig::default(),
            train_samples: 100_000,
            valid_samples: 2_000,
            valid_first_seed: VALID_FIRST_SEED,
        }
    }
}

/// A trained UPnP regressor and its report.
#[derive(Debug)]
pub struct UpnpTrained {
    /// The model, in inference mode.
    pub model: PoseRegressor,
    /// Training report (timing, losses, validation statistics).
    pub report: TrainReport,
    /// Seconds spent generating the data sets.
    pub data_seconds: f64,
}

/// Samples the training and validation scenes and trains the regressor.
pub fn train_upnp(config: &UpnpTrainConfig) -> Result<UpnpTrained, DataError> {
    let start = Instant::now();
    let train = training_dataset(&config.scene, config.train_samples, config.train.seed)?;
    let valid = validation_dataset(&config.scene, config.valid_samples, config.valid_first_seed)?;
    let data_seconds = start.elapsed().as_secs_f64();
    let (model, report) = training::train(&config.model, &train, &valid, &config.train);
    Ok(UpnpTrained { model, report, data_seconds })
}

/// Rotation-error statistics of `predict` (canonical rows -> canonical quaternion, decoded
/// here) on `count` validation scenes ([`validation_scene`]).
pub fn evaluate_scenes(
    scene_config: &UpnpSceneConfig,
    count: usize,
    first_seed: u64,
    mut predict: impl FnMut(&[f32]) -> [f64; 4],
) -> RotationStats {
    let errors: Vec<f64> = (0..count)
        .map(|i| {
            let scene = validation_scene(scene_config, first_seed, i);
            let frame = UpnpFrame::new(&scene.correspondences).expect("sampled scene has canonical frames");
            let sample = scene_sample(&scene).expect("sampled scene has canonical frames");
            let q = frame.decode(&predict(&sample.rows)).expect("finite prediction");
            let r = simhc_problems::metrics::rotation_from_quat(q);
            simhc_problems::metrics::rotation_error_deg(&r, &scene.rotation)
        })
        .collect();
    RotationStats::from_errors(&errors)
}

/// Trains with `config`, prints the seed, sizes, timing and validation figures, and writes
/// `upnp.bpk` (burn) and `upnp.folded` (the runtime format) into `out_dir`. This is
/// `simhc train upnp`.
pub fn train_and_write(out_dir: &std::path::Path, config: &UpnpTrainConfig) -> Result<(), Box<dyn std::error::Error>> {
    use crate::{export_folded, predict};
    use burn::prelude::*;
    use simhc::regressor::FoldedNetwork;
    let config = config.clone();
    println!("seed {}", config.train.seed);
    println!(
        "training scenes {} (validation {} from seed {}), epochs {}, batch {}, lr {:e} -> {:e}",
        config.train_samples,
        config.valid_samples,
        config.valid_first_seed,
        config.train.epochs,
        config.train.batch_size,
        config.train.learning_rate,
        config.train.final_learning_rate
    );
    println!("model {:?}", config.model);
    let trained = train_upnp(&config)?;
    let r = &trained.report;
    println!("parameters {}", trained.model.num_params());
    println!("data generation {:.1} s", trained.data_seconds);
    println!(
        "training {:.1} s ({} steps, {:.0} samples/s)",
        r.train_seconds,
        r.steps,
        (r.steps * config.train.batch_size) as f64 / r.train_seconds
    );
    let losses: Vec<String> = r.epoch_losses.iter().map(|l| format!("{l:.4}")).collect();
    println!("epoch losses {}", losses.join(" "));
    println!("validation (burn, batched): {}", r.valid);

    std::fs::create_dir_all(out_dir)?;
    let bpk = out_dir.join("upnp.bpk");
    trained.model.clone().save_file(&bpk)?;
    let folded_bytes = export_folded(&trained.model);
    let folded_path = out_dir.join("upnp.folded");
    std::fs::write(&folded_path, &folded_bytes)?;
    println!("wrote {} and {}", bpk.display(), folded_path.display());

    let folded = FoldedNetwork::from_bytes(&folded_bytes)?;
    let stats = evaluate_scenes(&config.scene, config.valid_samples, config.valid_first_seed, |rows| {
        let mut q = [0.0; 4];
        folded.forward(rows, &mut q).expect("valid rows");
        q
    });
    println!("validation (folded, batch 1): {stats}");
    let device = Device::flex();
    let stats = evaluate_scenes(&config.scene, 200, config.valid_first_seed, |rows| {
        let q = predict(&trained.model, rows, config.scene.points, &device);
        [q[0], q[1], q[2], q[3]].map(f64::from)
    });
    println!("validation (burn, batch 1, first 200): {stats}");
    Ok(())
}
