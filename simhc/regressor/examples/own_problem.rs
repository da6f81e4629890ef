//! Your own problem, end to end: declare it, write its scene sampler, train its learned start,
//! solve with the Simulator HC pipeline, measure. The README's tutorial walks through this
//! file; `simhc/regressor/tests/learned_start.rs` runs the same code with a smaller training.
//!
//!     cargo run --release -p simhc-regressor --example own_problem -- [seed]
//!
//! The problem: central absolute pose (PnP) from 6 bearings `f` of world points `p`,
//! `f x (R p + t) = 0`, over all rotations.

use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::{Generic, LearnedStart, ParameterVector, Pipeline, StartError, StartProvider, Validator, Verdict};
use simhc::{MinNormSimulator, ProblemLayout};
use simhc_problems::metrics::{quat_from_rotation, random_unit_quaternion, rotation_error_deg, rotation_from_quat};
use simhc_problems::upnp::scene::random_rotation;
use simhc_regressor::generic::{train_learned_start, LearnedStartConfig, LearnedStartError, TrainedStart};
use simhc_regressor::TrainConfig;

// 1. The declaration: unknowns, per-correspondence parameters, equations, row counts.
#[simhc::simhc_problem]
pub mod pnp {
    pub struct Unknowns {
        q: Quat,
        t: Vec3,
    }
    pub struct Row {
        f: Vec3,
        p: Vec3,
    }
    pub const ROWS: [usize; 1] = [6];
    pub fn row_equations() -> Vec3 {
        f.cross(rotation(q) * p + t)
    }
    pub fn global_equations() -> [Scalar; 1] {
        [q.dot(q) - 1]
    }
}

/// The compiled 6-correspondence instance.
pub type Pnp = pnp::Pnp6;
/// The pipeline's data: the parameter vector (6 rows of `f, p`).
pub type Params = SVector<f64, 36>;
/// The unknowns `[q, t]`.
pub type Unknowns = SVector<f64, 7>;

// 2. The scene sampler: parameters and the true unknowns.
/// A scene with any rotation, `t` in the unit cube, points 4-8 units in front of the camera.
pub fn scene(rng: &mut ChaCha8Rng) -> (Params, Unknowns) {
    let r = random_rotation(rng);
    let t = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let rows: [pnp::Row; 6] = std::array::from_fn(|_| {
        let y = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(4.0..8.0));
        pnp::Row { f: y.normalize().into(), p: (r.transpose() * (y - t)).into() }
    });
    let q = quat_from_rotation(&r);
    (Pnp::params(&rows), SVector::from([q[0], q[1], q[2], q[3], t.x, t.y, t.z]))
}

// 3. Validation: what makes an end point a solution of *all* the data.
/// Every bearing within `1e-7` rad of its point under the pose, every point in front.
pub struct Reprojection;

impl Validator<Params, 7> for Reprojection {
    /// (points behind, largest angle in radians)
    type Check = (usize, f64);
    fn check(&self, p: &Params, x: &Unknowns) -> (usize, f64) {
        let n = x.fixed_rows::<4>(0).norm();
        let r = rotation_from_quat([x[0] / n, x[1] / n, x[2] / n, x[3] / n]);
        let t = Vector3::new(x[4], x[5], x[6]);
        let (mut behind, mut worst) = (0, 0.0f64);
        for i in 0..6 {
            let f = Vector3::new(p[6 * i], p[6 * i + 1], p[6 * i + 2]);
            let y = r * Vector3::new(p[6 * i + 3], p[6 * i + 4], p[6 * i + 5]) + t;
            behind += usize::from(!(f.dot(&y) > 0.0));
            let a = f.cross(&y).norm().atan2(f.dot(&y));
            worst = if a.is_nan() { f64::INFINITY } else { worst.max(a) };
        }
        (behind, worst)
    }
    fn verdict(&self, c: &(usize, f64)) -> Verdict {
        if c.0 == 0 && c.1 <= 1e-7 {
            Verdict::Accept
        } else {
            Verdict::Reject
        }
    }
    fn better(&self, a: &(usize, f64), b: &(usize, f64)) -> bool {
        a < b
    }
}

// 4. Training: the generic trainer reads the layout `#[simhc_problem]` emitted.
/// Trains the learned start on `config.samples` scenes (seeded by `config.train.seed`).
pub fn train(config: &LearnedStartConfig) -> Result<TrainedStart, LearnedStartError> {
    train_learned_start(&Pnp::LAYOUT, config, |rng| {
        let (p, x) = scene(rng);
        (p.as_slice().to_vec(), x.as_slice().to_vec())
    })
}

/// A uniformly random rotation and `t = 0`: the baseline start.
pub struct RandomStart(pub std::cell::RefCell<ChaCha8Rng>);

impl StartProvider<Params, 7> for RandomStart {
    fn name(&self) -> &'static str {
        "random"
    }
    fn start(&self, _: &Params) -> Result<Unknowns, StartError> {
        let q = random_unit_quaternion(&mut *self.0.borrow_mut());
        Ok(SVector::from([q[0], q[1], q[2], q[3], 0.0, 0.0, 0.0]))
    }
}

/// Success counts and times of one start provider on scenes.
#[derive(Debug, Clone, Default)]
pub struct Tally {
    /// Solved and validated, at the truth.
    pub solved: usize,
    /// Returned as validated but not at the truth (must stay 0).
    pub wrong_unflagged: usize,
    /// Solve times in microseconds.
    pub micros: Vec<f64>,
}

// 5. Solving: the pipeline with the learned start, the generic simulator and validation.
/// Solves `scenes` with `start` and counts the outcomes.
pub fn evaluate(start: &dyn StartProvider<Params, 7>, scenes: &[(Params, Unknowns)]) -> Tally {
    let (target, simulator) = (ParameterVector::<Pnp>::new(), Generic(MinNormSimulator::<Pnp>::new()));
    let starts = [start];
    let pipeline = Pipeline::<Pnp, _, _, _, _, 7, 19, 36, { Pnp::NC }>::new(&target, &starts, &simulator, &Reprojection);
    let mut tally = Tally::default();
    for (p, x) in scenes {
        let t0 = std::time::Instant::now();
        let result = pipeline.solve(p);
        tally.micros.push(t0.elapsed().as_secs_f64() * 1e6);
        if let Ok(solved) = result {
            let truth = rotation_from_quat([x[0], x[1], x[2], x[3]]);
            let r = rotation_from_quat([solved.x[0], solved.x[1], solved.x[2], solved.x[3]]);
            if rotation_error_deg(&r, &truth) < 1e-4 {
                tally.solved += 1;
            } else {
                tally.wrong_unflagged += 1;
            }
        }
    }
    tally
}

/// The median of `v`.
pub fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(1);
    println!("own_problem: central PnP, 6 correspondences, seed {seed}");
    let config = LearnedStartConfig {
        samples: 100_000,
        train: TrainConfig { epochs: 12, batch_size: 128, learning_rate: 2e-3, final_learning_rate: 2e-5, seed, progress: true },
        ..LearnedStartConfig::default()
    };
    let trained = train(&config)?;
    println!("trained {} samples x {} epochs in {:.1} s", config.samples, config.train.epochs, trained.run.train_seconds);
    let weights = std::path::Path::new("target/own_problem.folded");
    std::fs::write(weights, trained.start.network().to_bytes())?;
    println!("weights: {} (load with FoldedNetwork::from_bytes, then LearnedStart::new(network, Pnp::LAYOUT))", weights.display());

    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1_000_000));
    let scenes: Vec<_> = (0..1000).map(|_| scene(&mut rng)).collect();
    let learned: &LearnedStart = &trained.start;
    let random = RandomStart(std::cell::RefCell::new(ChaCha8Rng::seed_from_u64(seed.wrapping_add(2))));
    println!("{:<28} {:>7} {:>7} {:>9}", "start", "succ %", "wrong", "t med us");
    for (name, start) in [("learned + Simulator HC", learned as &dyn StartProvider<Params, 7>), ("random + Simulator HC", &random)] {
        let t = evaluate(start, &scenes);
        println!("{name:<28} {:>7.1} {:>7} {:>9.1}", 100.0 * t.solved as f64 / scenes.len() as f64, t.wrong_unflagged, median(&t.micros));
    }
    Ok(())
}
