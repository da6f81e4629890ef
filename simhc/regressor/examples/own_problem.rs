//! Your own problem, end to end: declare it, write its scene sampler, train its learned start,
//! solve with the Simulator HC pipeline, measure, calling the pipeline and the trainer directly
//! (the README's tutorial does the same through `simhc_cli::Declared`);
//! `simhc/regressor/tests/learned_start.rs` runs the same code with a smaller training.
//!
//!     cargo run --release -p simhc-regressor --example own_problem -- train [seed]
//!     cargo run --release -p simhc-regressor --example own_problem -- sample FILE [seed]
//!     cargo run --release -p simhc-regressor --example own_problem -- solve FILE
//!
//! `train` trains, writes `target/own_problem.folded` and prints the paper's rows on 1000
//! unseen scenes; `sample` writes one scene's correspondences as JSON; `solve` reads such a
//! file (`{"correspondences": [{"f": [..], "p": [..]}, ..]}`, read through the layout) and
//! prints the validated pose, or why there is none.
//!
//! The problem: central absolute pose (PnP) from 6 bearings `f` of world points `p`,
//! `f x (R p + t) = 0`, over all rotations.

use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::bench::{bench_estimate_row, bench_row, table, BenchRow};
use simhc::pipeline::{Attempt, Generic, LearnedStart, Method, ParameterVector, Pipeline, StartError, StartProvider, Validator, Verdict};
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
            // NaN counts as behind.
            behind += usize::from(f.dot(&y).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater));
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

/// The bench's criterion: rotation within 2 degrees of the truth (the paper's, for UPnP).
pub fn correct(x: &Unknowns, truth: &Unknowns) -> bool {
    let r = |v: &Unknowns| rotation_from_quat([v[0], v[1], v[2], v[3]]);
    rotation_error_deg(&r(x), &r(truth)) < 2.0
}

// 5. Solving and benchmarking: the pipeline with the learned start, the generic simulator and
//    validation; the paper's rows on the same scenes.
/// Pred Initial, Pred + Gauss-Newton, Rand + Sim HC, Pred + Sim HC (one path), and the learned
/// start with Gauss-Newton first, then Simulator HC.
pub fn bench(learned: &LearnedStart, scenes: &[(Params, Unknowns)], seed: u64) -> Vec<BenchRow> {
    let (target, simulator) = (ParameterVector::<Pnp>::new(), Generic(MinNormSimulator::<Pnp>::new()));
    let random = RandomStart(std::cell::RefCell::new(ChaCha8Rng::seed_from_u64(seed)));
    let starts: [&dyn StartProvider<Params, 7>; 2] = [learned, &random];
    let run = |name: &str, schedule: &[Attempt]| {
        let p =
            Pipeline::<Pnp, _, _, _, _, 7, 19, 36, { Pnp::NC }>::new(&target, &starts, &simulator, &Reprojection).with_schedule(schedule);
        bench_row(name, scenes, &correct, |d| p.solve(d))
    };
    let (pred, rand) = (0, 1);
    vec![
        bench_estimate_row("Pred Initial", scenes, &correct, |p| StartProvider::<Params, 7>::start(learned, p).ok()),
        run("Pred + Gauss-Newton", &[Attempt { provider: pred, method: Method::GaussNewton }]),
        run("Rand + Sim HC", &[Attempt { provider: rand, method: Method::SimulatorHc }]),
        run("Pred + Sim HC (one path)", &[Attempt { provider: pred, method: Method::SimulatorHc }]),
        run(
            "Pred: Gauss-Newton, then Sim HC",
            &[Attempt { provider: pred, method: Method::GaussNewton }, Attempt { provider: pred, method: Method::SimulatorHc }],
        ),
    ]
}

const WEIGHTS: &str = "target/own_problem.folded";

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed_at = |i: usize| -> Result<u64, Box<dyn std::error::Error>> { Ok(args.get(i).map(|s| s.parse()).transpose()?.unwrap_or(1)) };
    match args.first().map(String::as_str).unwrap_or("train") {
        "train" => train_and_bench(seed_at(1)?),
        "sample" => {
            let file = args.get(1).ok_or("usage: own_problem sample FILE [seed]")?;
            let (p, _) = scene(&mut ChaCha8Rng::seed_from_u64(seed_at(2)?));
            let rows: Vec<String> = (0..6)
                .map(|i| format!(r#"{{"f": {:?}, "p": {:?}}}"#, &p.as_slice()[6 * i..6 * i + 3], &p.as_slice()[6 * i + 3..6 * i + 6]))
                .collect();
            std::fs::write(file, format!("{{\"correspondences\": [\n  {}\n]}}\n", rows.join(",\n  ")))?;
            println!("wrote {file}");
            Ok(())
        }
        "solve" => {
            let file = args.get(1).ok_or("usage: own_problem solve FILE")?;
            let text = std::fs::read_to_string(file)?;
            let p = simhc_problems::input::parse_layout_params(&Pnp::LAYOUT, &text).map_err(|e| format!("{file}: {e}"))?;
            let network = simhc::regressor::FoldedNetwork::from_bytes(
                &std::fs::read(WEIGHTS).map_err(|e| format!("{WEIGHTS}: {e} (run `train` first)"))?,
            )?;
            let learned = LearnedStart::new(network, Pnp::LAYOUT)?;
            let (target, simulator) = (ParameterVector::<Pnp>::new(), Generic(MinNormSimulator::<Pnp>::new()));
            let starts: [&dyn StartProvider<Params, 7>; 1] = [&learned];
            let schedule = [Attempt { provider: 0, method: Method::GaussNewton }, Attempt { provider: 0, method: Method::SimulatorHc }];
            let pipeline = Pipeline::<Pnp, _, _, _, _, 7, 19, 36, { Pnp::NC }>::new(&target, &starts, &simulator, &Reprojection)
                .with_schedule(&schedule);
            let solved = pipeline.solve(&Params::from_column_slice(&p)).map_err(|e| format!("{file}: {e}"))?;
            let x = solved.x;
            println!(
                "{{\"q\": {:?}, \"t\": {:?}, \"validated\": true, \"largest_angle_rad\": {:e}}}",
                &x.as_slice()[..4],
                &x.as_slice()[4..],
                solved.check.1
            );
            Ok(())
        }
        other => Err(format!("unknown command `{other}`: train [seed] | sample FILE [seed] | solve FILE").into()),
    }
}

fn train_and_bench(seed: u64) -> Result<(), Box<dyn std::error::Error>> {
    println!("own_problem: central PnP, 6 correspondences, seed {seed}");
    let config = LearnedStartConfig {
        samples: 100_000,
        train: TrainConfig { epochs: 12, batch_size: 128, learning_rate: 2e-3, final_learning_rate: 2e-5, seed, progress: true },
        ..LearnedStartConfig::default()
    };
    let trained = train(&config)?;
    println!("trained {} samples x {} epochs in {:.1} s", config.samples, config.train.epochs, trained.run.train_seconds);
    let weights = std::path::Path::new(WEIGHTS);
    std::fs::write(weights, trained.start.network().to_bytes())?;
    println!("weights: {} (load with FoldedNetwork::from_bytes, then LearnedStart::new(network, Pnp::LAYOUT))", weights.display());

    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1_000_000));
    let scenes: Vec<_> = (0..1000).map(|_| scene(&mut rng)).collect();
    println!("1000 unseen scenes, noise-free; success: validated and rotation within 2 deg");
    print!("{}", table(&bench(&trained.start, &scenes, seed.wrapping_add(2))));
    Ok(())
}
