//! UPnP training data and the training command: scenes from the paper's sampler
//! ([`UpnpSceneConfig`]), input rows from [`simhc::regressor::upnp_rows`] (the same function
//! the runtime calls at inference), targets the ground-truth quaternion `[w, x, y, z]` with
//! `w >= 0` ([`quat_from_rotation`]).
//!
//! Seeds: the training scenes are drawn one after another from
//! `ChaCha8Rng::seed_from_u64(seed)`; validation scene `i` is
//! `UpnpSceneConfig::sample_seeded(valid_first_seed + i)`, a different stream, so the two sets
//! do not overlap.

use crate::data::{DataError, InMemoryDataset, Sample};
use crate::model::{PoseRegressor, RegressorConfig};
use crate::training::{self, RotationStats, TrainConfig, TrainReport};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use simhc::regressor::{upnp_rows, RegressorError, UPNP_ROW_WIDTH};
use simhc_problems::metrics::quat_from_rotation;
use simhc_problems::upnp::scene::{UpnpCorrespondence, UpnpScene, UpnpSceneConfig};
use std::time::Instant;

/// Writes the regressor's input rows of `correspondences` into `out`
/// (`9 * correspondences.len()` numbers); see [`upnp_rows`] for the normalization.
pub fn correspondence_rows(
    correspondences: &[UpnpCorrespondence],
    out: &mut [f32],
) -> Result<(), RegressorError> {
    upnp_rows(
        correspondences.len(),
        |i| {
            let c = &correspondences[i];
            (c.p.into(), c.f.into(), c.v.into())
        },
        out,
    )
}

/// The training sample of a scene: its rows and its ground-truth quaternion (`w >= 0`).
pub fn scene_sample(scene: &UpnpScene) -> Result<Sample, RegressorError> {
    let mut rows = vec![0.0f32; UPNP_ROW_WIDTH * scene.correspondences.len()];
    correspondence_rows(&scene.correspondences, &mut rows)?;
    let target = quat_from_rotation(&scene.rotation)
        .map(|v| v as f32)
        .to_vec();
    Ok(Sample { rows, target })
}

/// Builds a data set from scenes (all with `scene_config.points` correspondences).
fn dataset_of(
    scene_config: &UpnpSceneConfig,
    count: usize,
    mut scene: impl FnMut(usize) -> UpnpScene,
) -> Result<InMemoryDataset, DataError> {
    InMemoryDataset::from_fn(count, scene_config.points, UPNP_ROW_WIDTH, 4, |i| {
        // Sampled scenes have unit, finite bearings; a failure here is a sampler bug.
        scene_sample(&scene(i)).expect("sampled scene gives valid rows")
    })
}

/// `count` training scenes drawn in order from `ChaCha8Rng::seed_from_u64(seed)`.
pub fn training_dataset(
    scene_config: &UpnpSceneConfig,
    count: usize,
    seed: u64,
) -> Result<InMemoryDataset, DataError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    dataset_of(scene_config, count, |_| {
        scene_config.sample(&mut rng).expect("valid scene config")
    })
}

/// `count` validation scenes, scene `i` = `scene_config.sample_seeded(first_seed + i)`.
pub fn validation_dataset(
    scene_config: &UpnpSceneConfig,
    count: usize,
    first_seed: u64,
) -> Result<InMemoryDataset, DataError> {
    dataset_of(scene_config, count, |i| {
        scene_config
            .sample_seeded(first_seed + i as u64)
            .expect("valid scene config")
    })
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
    Ok(UpnpTrained {
        model,
        report,
        data_seconds,
    })
}

/// Rotation-error statistics of `predict` (rows -> quaternion `[w, x, y, z]`, normalized here) on `count` scenes
/// `scene_config.sample_seeded(first_seed + i)`.
pub fn evaluate_scenes(
    scene_config: &UpnpSceneConfig,
    count: usize,
    first_seed: u64,
    mut predict: impl FnMut(&[f32]) -> [f64; 4],
) -> RotationStats {
    let errors: Vec<f64> = (0..count)
        .map(|i| {
            let scene = scene_config
                .sample_seeded(first_seed + i as u64)
                .expect("valid config");
            let sample = scene_sample(&scene).expect("valid scene");
            let q = predict(&sample.rows);
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            let r = simhc_problems::metrics::rotation_from_quat(q.map(|v| v / n));
            simhc_problems::metrics::rotation_error_deg(&r, &scene.rotation)
        })
        .collect();
    RotationStats::from_errors(&errors)
}

/// Trains with `config`, prints the seed, sizes, timing and validation figures, and writes
/// `upnp.bpk` (burn) and `upnp.folded` (the runtime format) into `out_dir`. This is
/// `simhc train upnp`.
pub fn train_and_write(out_dir: &std::path::Path, config: &UpnpTrainConfig) -> Result<(), Box<dyn std::error::Error>> {
    use burn::prelude::*;
    use simhc::regressor::FoldedNetwork;
    use crate::{export_folded, predict};
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
    let stats = evaluate_scenes(
        &config.scene,
        config.valid_samples,
        config.valid_first_seed,
        |rows| {
            let mut q = [0.0; 4];
            folded.forward(rows, &mut q).expect("valid rows");
            q
        },
    );
    println!("validation (folded, batch 1): {stats}");
    let device = Device::flex();
    let stats = evaluate_scenes(&config.scene, 200, config.valid_first_seed, |rows| {
        let q = predict(&trained.model, rows, config.scene.points, &device);
        [q[0], q[1], q[2], q[3]].map(f64::from)
    });
    println!("validation (burn, batch 1, first 200): {stats}");
    Ok(())
}
