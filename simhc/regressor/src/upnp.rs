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
use crate::generic::{scene_dataset, train_with_hook, FeatureHook, LearnedStartError};
use crate::model::{PoseRegressor, RegressorConfig};
use crate::training::{evaluate, quaternion_dot, RotationStats, TrainConfig, TrainReport};
use burn::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc_problems::upnp::features::{UpnpFrame, UPNP_OUTPUTS, UPNP_ROW_WIDTH};
use simhc_problems::upnp::scene::{PointBox, UpnpScene, UpnpSceneConfig};
use std::time::Instant;

/// UPnP's feature hook ([`crate::generic`]): a scene's rows in its canonical frames
/// ([`UpnpFrame`]) and the quaternion of its canonical rotation, scored by the sign-invariant
/// [`crate::training::quaternion_loss`]; the network ([`RegressorConfig::upnp`]) normalizes its quaternion
/// itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UpnpFeatures {
    /// Correspondences per scene.
    pub points: usize,
}

impl FeatureHook for UpnpFeatures {
    type Scene = UpnpScene;

    fn input_shape(&self) -> (usize, usize) {
        (self.points, UPNP_ROW_WIDTH)
    }

    fn target_width(&self) -> usize {
        UPNP_OUTPUTS
    }

    fn features(&self, _: usize, scene: &UpnpScene, rows: &mut [f32], target: &mut [f64]) -> Result<bool, LearnedStartError> {
        let corrs = &scene.correspondences;
        let Some(frame) = UpnpFrame::new(corrs) else { return Ok(false) };
        if corrs.len() != self.points || !frame.rows(corrs, rows) {
            return Ok(false);
        }
        target.copy_from_slice(&frame.encode(&scene.rotation));
        Ok(true)
    }

    fn sample_losses(&self, prediction: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
        let batch = prediction.dims()[0];
        (quaternion_dot(prediction, target).square().neg() + 1.0).reshape([batch])
    }
}

/// The training sample of a scene ([`UpnpFeatures`]): its canonical rows and canonical
/// quaternion; `None` for a scene without canonical frames (coincident points, which the
/// sampler does not produce).
pub fn scene_sample(scene: &UpnpScene) -> Option<Sample> {
    let hook = UpnpFeatures { points: scene.correspondences.len() };
    let (mut rows, mut target) = (vec![0.0f32; UPNP_ROW_WIDTH * hook.points], [0.0f64; UPNP_OUTPUTS]);
    hook.features(0, scene, &mut rows, &mut target).ok()?.then(|| Sample { rows, target: target.map(|v| v as f32).to_vec() })
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

/// `count` training scenes drawn in order from `ChaCha8Rng::seed_from_u64(seed)`, through
/// [`UpnpFeatures`].
pub fn training_dataset(scene_config: &UpnpSceneConfig, count: usize, seed: u64) -> Result<InMemoryDataset, LearnedStartError> {
    scene_dataset(&UpnpFeatures { points: scene_config.points }, count, seed, |i, rng| sample_scene(scene_config, i, rng))
}

/// `count` validation scenes ([`validation_scene`]).
pub fn validation_dataset(scene_config: &UpnpSceneConfig, count: usize, first_seed: u64) -> Result<InMemoryDataset, DataError> {
    InMemoryDataset::from_fn(count, scene_config.points, UPNP_ROW_WIDTH, UPNP_OUTPUTS, |i| {
        // Sampled scenes have spread points and unit, finite bearings; a failure here is a
        // sampler bug.
        scene_sample(&validation_scene(scene_config, first_seed, i)).expect("sampled scene has canonical frames")
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

/// Trains the regressor through the generic trainer with [`UpnpFeatures`]
/// ([`train_with_hook`]), then validates it.
pub fn train_upnp(config: &UpnpTrainConfig) -> Result<UpnpTrained, LearnedStartError> {
    let start = Instant::now();
    let hook = UpnpFeatures { points: config.scene.points };
    let trained = train_with_hook(&hook, &config.model, &config.train, config.train_samples, |i, rng| sample_scene(&config.scene, i, rng))?;
    let valid = validation_dataset(&config.scene, config.valid_samples, config.valid_first_seed)?;
    let run = trained.run;
    let data_seconds = start.elapsed().as_secs_f64() - run.train_seconds;
    let report = TrainReport {
        seed: config.train.seed,
        train_samples: config.train_samples,
        epochs: config.train.epochs,
        steps: run.steps,
        train_seconds: run.train_seconds,
        epoch_losses: run.epoch_losses,
        valid: evaluate(&trained.model, &valid),
    };
    Ok(UpnpTrained { model: trained.model, report, data_seconds })
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
