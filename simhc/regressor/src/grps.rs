//! GRPS training data and the training command (`simhc train grps`).
//!
//! Network: [`grps_model`], the UPnP PointNet made deeper, with one head of 10 outputs that are
//! the paper's three heads concatenated: rotation in the continuous 6D representation (Zhou et
//! al. 2019), translation, log scale, all in the canonical frames of
//! [`simhc_problems::grps::features`] (the same function builds the rows at inference).
//!
//! Loss ([`grps_loss`]): `|b1 - r1|² + |b2 - r2|²` on the Gram-Schmidt columns of the 6D output
//! against the true rotation's first two columns, plus `w_t |t~ - t~_gt|²` and
//! `w_s (ln s~ - ln s~_gt)²`.
//!
//! Data ([`sample`]): the paper's scene sampler ([`GrpsSceneConfig`]) with, per scene, a random
//! number of cameras per view from [`GrpsTrainConfig::cameras`], bearing noise uniform in
//! `[0, max_noise_px]` for a fraction `noisy_fraction` of the scenes (noise-free otherwise),
//! 8 correspondences, or 7 for a fraction `seven_fraction` (the 7 rows are padded to 8 by
//! repeating the last row, which the max-pool ignores, so the network also learns the minimal
//! case), and with probability 1/2 the views swapped ([`swap_views`]: the same problem seen
//! from view 2, a free doubling of the data that makes the swapped prediction a meaningful
//! second hypothesis). Seeds: training scenes from `ChaCha8Rng::seed_from_u64(train.seed)`, in
//! order; validation scene `i` is the benchmark's (3 cameras, noise-free, 8 points)
//! `sample_seeded(valid_first_seed + i)`.
//!
//! Shipped weights (the default configuration, `simhc train grps`), trained 2026-12-04 with the
//! context stage after the first layer: 921 s of training on this project's 2-core machine
//! beside a CI run (about 740 s beside another training run); validation (folded network,
//! 2,000 scenes): median rotation error 11.03 deg (44.9 % under 10 deg, 76.0 % under 20 deg),
//! translation 83.1 %, scale 23.0 %. The weights before it (2026-12-01, no context stage):
//! 12.87 deg (38.1 %, 70.4 %), 90.4 %, 23.9 %.

use crate::data::{InMemoryDataset, Sample};
use crate::generic::{scene_dataset, train_with_hook, FeatureHook, LearnedStartError, WinnerTakesAll};
use crate::model::{PoseRegressor, RegressorConfig};
use crate::training::{TrainConfig, TrainRun};
use burn::prelude::*;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::regressor::HypothesisBlocks;
use simhc::solver::{DeclaredProblem, LearnedHypotheses};
use simhc_problems::grps::declared::{params_of, GrpsSolvers};
use simhc_problems::grps::features::{swap_pose, swap_views, GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::scene::{GrpsScene, GrpsSceneConfig};
use simhc_problems::metrics::{rotation_error_deg, scale_error_pct, translation_error_pct};
use std::time::Instant;

/// The GRPS network with `hypotheses` start hypotheses: 18 -> 64, a context stage (every row
/// also reads the max-pooled 64 features of all rows), [64 + 64] -> 128 -> 128 -> 256,
/// max-pool, 256 -> 128 -> 10 per hypothesis and, with two or more, a score each
/// ([`HypothesisBlocks::trained`]).
pub fn grps_model(hypotheses: usize) -> RegressorConfig {
    RegressorConfig::new(GRPS_ROW_WIDTH, vec![64, 128, 128, 256], vec![256, 128])
        .with_outputs(HypothesisBlocks::trained(GRPS_OUTPUTS, hypotheses).outputs())
        .with_normalize_output(false)
        .with_context_after(1)
}

/// Settings of [`train_grps`]; the default is the configuration of the shipped weights.
#[derive(Debug, Clone)]
pub struct GrpsTrainConfig {
    /// Cameras per view, one drawn uniformly per training scene.
    pub cameras: Vec<usize>,
    /// Largest bearing noise of the noisy scenes (pixels at `focal_px`).
    pub max_noise_px: f64,
    /// Fraction of noisy training scenes.
    pub noisy_fraction: f64,
    /// Fraction of 7-correspondence training scenes.
    pub seven_fraction: f64,
    /// Weight of the translation loss.
    pub translation_weight: f64,
    /// Weight of the log-scale loss.
    pub scale_weight: f64,
    /// Start hypotheses per prediction ([`WinnerTakesAll`]); the model's outputs must be
    /// [`grps_model`]'s for this.
    pub hypotheses: usize,
    /// Weight of the mean over all hypotheses in the winner-takes-all loss.
    pub relax: f64,
    /// Network architecture.
    pub model: RegressorConfig,
    /// Optimizer settings; `train.seed` also seeds the training scenes.
    pub train: TrainConfig,
    /// Number of training scenes (the paper: 64000).
    pub train_samples: usize,
    /// Number of validation scenes.
    pub valid_samples: usize,
    /// Seed of the first validation scene.
    pub valid_first_seed: u64,
}

/// First seed of the validation scenes (disjoint from the benchmark's sampled stream).
pub const VALID_FIRST_SEED: u64 = 2_000_000;

impl Default for GrpsTrainConfig {
    fn default() -> Self {
        Self {
            cameras: vec![2, 3, 3, 3, 4, 5],
            max_noise_px: 2.0,
            noisy_fraction: 0.5,
            seven_fraction: 0.2,
            translation_weight: 0.2,
            scale_weight: 0.5,
            hypotheses: 1,
            relax: 0.05,
            model: grps_model(1),
            train: TrainConfig { epochs: 12, batch_size: 128, learning_rate: 2e-3, final_learning_rate: 2e-5, seed: 7, progress: true },
            train_samples: 160_000,
            valid_samples: 2_000,
            valid_first_seed: VALID_FIRST_SEED,
        }
    }
}

/// GRPS's feature hook ([`crate::generic`]): 8 rows in the canonical frames of [`GrpsFrame`]
/// (7 correspondences padded by repeating the last row) and the 10 targets of the module docs,
/// scored by [`grps_loss`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsFeatures {
    /// Weight of the translation loss.
    pub translation_weight: f64,
    /// Weight of the log-scale loss.
    pub scale_weight: f64,
}

impl GrpsFeatures {
    /// The hook of a training configuration.
    pub fn of(config: &GrpsTrainConfig) -> Self {
        Self { translation_weight: config.translation_weight, scale_weight: config.scale_weight }
    }
}

impl FeatureHook for GrpsFeatures {
    type Scene = GrpsScene;

    fn input_shape(&self) -> (usize, usize) {
        (8, GRPS_ROW_WIDTH)
    }

    fn target_width(&self) -> usize {
        GRPS_OUTPUTS
    }

    fn features(&self, _: usize, scene: &GrpsScene, rows: &mut [f32], target: &mut [f64]) -> Result<bool, LearnedStartError> {
        let corrs = &scene.correspondences;
        let Some(frame) = GrpsFrame::new(corrs) else { return Ok(false) };
        let n = corrs.len().min(8);
        if n == 0 || !frame.rows(&corrs[..n], &mut rows[..GRPS_ROW_WIDTH * n]) {
            return Ok(false);
        }
        for k in n..8 {
            rows.copy_within(GRPS_ROW_WIDTH * (n - 1)..GRPS_ROW_WIDTH * n, GRPS_ROW_WIDTH * k);
        }
        let t = frame.target(&scene.rotation, &scene.translation, scene.scale);
        // Finite as the network's f32.
        if !t.iter().all(|v| (*v as f32).is_finite()) {
            return Ok(false);
        }
        target.copy_from_slice(&t);
        Ok(true)
    }

    fn sample_losses(&self, prediction: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
        grps_loss(prediction, target, self.translation_weight, self.scale_weight)
    }
}

/// The training sample of a scene ([`GrpsFeatures`]): 8 rows (7 padded) and the 10 targets.
pub fn scene_sample(scene: &GrpsScene) -> Option<Sample> {
    let (mut rows, mut target) = (vec![0.0f32; GRPS_ROW_WIDTH * 8], [0.0f64; GRPS_OUTPUTS]);
    let hook = GrpsFeatures { translation_weight: 0.0, scale_weight: 0.0 };
    hook.features(0, scene, &mut rows, &mut target).ok()?.then(|| Sample { rows, target: target.map(|v| v as f32).to_vec() })
}

/// One training scene from `rng` (module docs).
pub fn sample(config: &GrpsTrainConfig, rng: &mut ChaCha8Rng) -> GrpsScene {
    loop {
        let cameras = config.cameras[rng.random_range(0..config.cameras.len())];
        let noisy = rng.random::<f64>() < config.noisy_fraction;
        let noise_px = if noisy { rng.random_range(0.0..=config.max_noise_px) } else { 0.0 };
        let points = if rng.random::<f64>() < config.seven_fraction { 7 } else { 8 };
        let swap = rng.random::<bool>();
        let scene_config = GrpsSceneConfig { points, cameras_per_view: cameras, noise_px, ..GrpsSceneConfig::default() };
        let Ok(mut scene) = scene_config.sample(rng) else { continue };
        if swap {
            let (r, t, s) = swap_pose(&scene.rotation, &scene.translation, scene.scale);
            scene = GrpsScene { correspondences: swap_views(&scene.correspondences), rotation: r, translation: t, scale: s };
        }
        return scene;
    }
}

/// The benchmark's scene configuration (3 cameras, noise-free, 8 points).
pub fn validation_scene(first_seed: u64, i: usize) -> GrpsScene {
    GrpsSceneConfig::default().sample_seeded(first_seed + i as u64).expect("valid config")
}

/// `count` training scenes drawn in order from `ChaCha8Rng::seed_from_u64(seed)`, through
/// [`GrpsFeatures`] (a scene without features is replaced by the next).
pub fn training_dataset(config: &GrpsTrainConfig, count: usize, seed: u64) -> Result<InMemoryDataset, LearnedStartError> {
    scene_dataset(&GrpsFeatures::of(config), count, seed, |_, rng| sample(config, rng))
}

/// The loss of the module docs per sample, `[B]`; `pred` and `target` are `[B, 10]`.
pub fn grps_loss(pred: Tensor<2>, target: Tensor<2>, translation_weight: f64, scale_weight: f64) -> Tensor<1> {
    let batch = pred.dims()[0];
    let unit = |v: Tensor<2>| v.clone() / v.square().sum_dim(1).sqrt().clamp_min(1e-6);
    let a1 = pred.clone().narrow(1, 0, 3);
    let a2 = pred.clone().narrow(1, 3, 3);
    let b1 = unit(a1);
    let b2 = unit(a2.clone() - b1.clone() * (b1.clone() * a2).sum_dim(1));
    let r1 = target.clone().narrow(1, 0, 3);
    let r2 = target.clone().narrow(1, 3, 3);
    let rot = (b1 - r1).square().sum_dim(1) + (b2 - r2).square().sum_dim(1);
    let tra = (pred.clone().narrow(1, 6, 3) - target.clone().narrow(1, 6, 3)).square().sum_dim(1);
    let sca = (pred.narrow(1, 9, 1) - target.narrow(1, 9, 1)).square();
    (rot + tra * translation_weight + sca * scale_weight).reshape([batch])
}

/// Median errors of a pose predictor on scenes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseStats {
    /// Scenes.
    pub count: usize,
    /// Median rotation error (degrees).
    pub rotation_median_deg: f64,
    /// Percent of rotation errors below 10 / 20 degrees.
    pub rotation_under_10_pct: f64,
    /// Percent below 20 degrees.
    pub rotation_under_20_pct: f64,
    /// Median translation error (percent).
    pub translation_median_pct: f64,
    /// Median scale error (percent).
    pub scale_median_pct: f64,
    /// Start hypotheses per prediction.
    pub hypotheses: usize,
    /// Median over scenes of the smallest rotation error of any hypothesis (degrees; the
    /// first-ranked one's with one hypothesis).
    pub best_rotation_median_deg: f64,
    /// Percent of scenes with some hypothesis under 10 degrees.
    pub best_under_10_pct: f64,
}

impl std::fmt::Display for PoseStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "n={} E_R median {:.2} deg (<10: {:.1}%, <20: {:.1}%), E_t median {:.1}%, E_s median {:.1}%; best of {} hypotheses: E_R median {:.2} deg (<10: {:.1}%)",
            self.count,
            self.rotation_median_deg,
            self.rotation_under_10_pct,
            self.rotation_under_20_pct,
            self.translation_median_pct,
            self.scale_median_pct,
            self.hypotheses,
            self.best_rotation_median_deg,
            self.best_under_10_pct
        )
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// The learned start's hypotheses of `corrs` (8 correspondences) through the library solver:
/// ranked as a solve ranks them, in the user's frame.
fn predictions(solvers: &GrpsSolvers, corrs: &[simhc_problems::grps::scene::GrpsCorrespondence]) -> Option<Vec<GrpsPose>> {
    let solver = &solvers.eight;
    let p = params_of::<96>(corrs)?;
    let (canonical, frame) = solver.problem().canonicalize(&p)?;
    let ranked = solver.learned_start().rank(&canonical).ok()?;
    let poses: Vec<GrpsPose> = ranked.x[..ranked.count].iter().filter_map(|x| GrpsPose::from_unknowns(&frame.to_user(x))).collect();
    (!poses.is_empty()).then_some(poses)
}

/// Errors of the learned start of `solvers` (its first-ranked hypothesis, and the best of all)
/// on validation scenes `first_seed + i`.
pub fn evaluate_solver(solvers: &GrpsSolvers, count: usize, first_seed: u64) -> PoseStats {
    let (mut er, mut et, mut es, mut best) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..count {
        let scene = validation_scene(first_seed, i);
        match predictions(solvers, &scene.correspondences) {
            Some(all) => {
                let p = all[0];
                er.push(rotation_error_deg(&p.rotation, &scene.rotation));
                et.push(translation_error_pct(&p.translation, &scene.translation));
                es.push(scale_error_pct(p.scale, scene.scale));
                best.push(all.iter().map(|p| rotation_error_deg(&p.rotation, &scene.rotation)).fold(180.0, f64::min));
            }
            None => {
                er.push(180.0);
                et.push(f64::INFINITY);
                es.push(f64::INFINITY);
                best.push(180.0);
            }
        }
    }
    let pct = |v: &[f64], th: f64| 100.0 * v.iter().filter(|&&x| x < th).count() as f64 / v.len().max(1) as f64;
    PoseStats {
        count,
        hypotheses: solvers.eight.learned_start().hypotheses(),
        best_under_10_pct: pct(&best, 10.0),
        best_rotation_median_deg: median(best),
        rotation_under_10_pct: pct(&er, 10.0),
        rotation_under_20_pct: pct(&er, 20.0),
        rotation_median_deg: median(er),
        translation_median_pct: median(et),
        scale_median_pct: median(es),
    }
}

/// A trained GRPS regressor.
#[derive(Debug)]
pub struct GrpsTrained {
    /// The model, in inference mode.
    pub model: PoseRegressor,
    /// The training run.
    pub run: TrainRun,
    /// Seconds spent generating the training set.
    pub data_seconds: f64,
}

/// Trains the regressor through the generic trainer with [`GrpsFeatures`]
/// ([`train_with_hook`]).
pub fn train_grps(config: &GrpsTrainConfig) -> Result<GrpsTrained, LearnedStartError> {
    let start = Instant::now();
    let hook = WinnerTakesAll { hook: GrpsFeatures::of(config), hypotheses: config.hypotheses, relax: config.relax };
    let trained = train_with_hook(&hook, &config.model, &config.train, config.train_samples, |_, rng| sample(config, rng))?;
    let data_seconds = start.elapsed().as_secs_f64() - trained.run.train_seconds;
    Ok(GrpsTrained { model: trained.model, run: trained.run, data_seconds })
}

/// Trains with `config`, prints the seed, sizes, timing and validation figures, and writes
/// `grps.bpk` (burn) and `grps.folded` (the runtime format) into `out_dir`. This is
/// `simhc train grps`.
pub fn train_and_write(out_dir: &std::path::Path, config: &GrpsTrainConfig) -> Result<(), Box<dyn std::error::Error>> {
    use crate::export_folded;
    println!("seed {}", config.train.seed);
    println!(
        "training scenes {} (cameras per view {:?}, {:.0}% noisy up to {} px, {:.0}% with 7 points, views swapped half the time), epochs {}, batch {}, lr {:e} -> {:e}",
        config.train_samples,
        config.cameras,
        100.0 * config.noisy_fraction,
        config.max_noise_px,
        100.0 * config.seven_fraction,
        config.train.epochs,
        config.train.batch_size,
        config.train.learning_rate,
        config.train.final_learning_rate
    );
    println!("model {:?}, {} start hypotheses (winner takes all, relax {})", config.model, config.hypotheses, config.relax);
    let trained = train_grps(config)?;
    let r = &trained.run;
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

    std::fs::create_dir_all(out_dir)?;
    let bpk = out_dir.join("grps.bpk");
    trained.model.clone().save_file(&bpk)?;
    let folded_bytes = export_folded(&trained.model);
    let folded_path = out_dir.join("grps.folded");
    std::fs::write(&folded_path, &folded_bytes)?;
    println!("wrote {} and {}", bpk.display(), folded_path.display());

    let solvers = GrpsSolvers::with_weights(&folded_bytes, 0.0)?;
    let stats = evaluate_solver(&solvers, config.valid_samples, config.valid_first_seed);
    println!("validation (folded, batch 1; 3 cameras, noise-free, 8 points): {stats}");
    Ok(())
}
