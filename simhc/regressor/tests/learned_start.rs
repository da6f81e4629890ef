//! The whole pipeline on a problem declared as a user would, with a learned start trained by
//! the generic trainer in a few seconds: central PnP from 6 correspondences over all rotations.
//! Declaration -> sampler -> `train_learned_start` -> `Pipeline` with the generic simulator and
//! validation -> success rate on unseen scenes, against random starts on the same scenes.

use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::learned::{NonFiniteParameter, ParameterVector};
use simhc::pipeline::{Generic, Pipeline, PipelineError, StartError, StartProvider, Validator, Verdict};
use simhc::{MinNormSimulator, ProblemLayout};
use simhc_problems::metrics::{quat_from_rotation, random_unit_quaternion, rotation_error_deg, rotation_from_quat};
use simhc_problems::upnp::scene::random_rotation;
use simhc_regressor::generic::{train_learned_start, LearnedStartConfig};
use simhc_regressor::TrainConfig;

#[simhc::simhc_problem]
mod pnp {
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

type P = pnp::Pnp6;

/// One scene: parameters and true unknowns (any rotation, points in front of the camera).
fn scene(rng: &mut ChaCha8Rng) -> (SVector<f64, 36>, SVector<f64, 7>) {
    let r = random_rotation(rng);
    let t = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let rows: [pnp::Row; 6] = std::array::from_fn(|_| {
        let y = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(4.0..8.0));
        pnp::Row { f: y.normalize().into(), p: (r.transpose() * (y - t)).into() }
    });
    let q = quat_from_rotation(&r);
    (P::params(&rows), SVector::from([q[0], q[1], q[2], q[3], t.x, t.y, t.z]))
}

/// Every bearing within `1e-7` rad of its point, every point in front.
struct Reprojection;

impl Validator<SVector<f64, 36>, 7> for Reprojection {
    type Check = (usize, f64);
    fn check(&self, p: &SVector<f64, 36>, x: &SVector<f64, 7>) -> (usize, f64) {
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
        if c.0 == 0 && c.1 <= 1e-7 { Verdict::Accept } else { Verdict::Reject }
    }
    fn better(&self, a: &(usize, f64), b: &(usize, f64)) -> bool {
        a < b
    }
}

/// A uniformly random rotation and `t = 0`, seeded: the baseline.
struct RandomStart(std::cell::RefCell<ChaCha8Rng>);

impl StartProvider<SVector<f64, 36>, 7> for RandomStart {
    fn name(&self) -> &'static str {
        "random"
    }
    fn start(&self, _: &SVector<f64, 36>) -> Result<SVector<f64, 7>, StartError> {
        let q = random_unit_quaternion(&mut *self.0.borrow_mut());
        Ok(SVector::from([q[0], q[1], q[2], q[3], 0.0, 0.0, 0.0]))
    }
}

#[test]
fn a_declared_problem_trains_and_solves_through_the_pipeline() {
    let seed = 11;
    println!("seed {seed}");
    let config = LearnedStartConfig {
        point_widths: vec![32, 64, 64],
        head_widths: vec![64],
        samples: 20_000,
        train: TrainConfig { epochs: 8, batch_size: 64, learning_rate: 3e-3, final_learning_rate: 3e-5, seed, progress: false },
    };
    let trained = train_learned_start(&P::LAYOUT, &config, |rng| {
        let (p, x) = scene(rng);
        (p.as_slice().to_vec(), x.as_slice().to_vec())
    })
    .expect("training runs");
    println!("trained in {:.1} s, epoch losses {:?}", trained.run.train_seconds, trained.run.epoch_losses);

    let simulator = Generic(MinNormSimulator::<P>::new());
    let target = ParameterVector::<P>::new();
    let learned: [&dyn StartProvider<SVector<f64, 36>, 7>; 1] = [&trained.start];
    let random_start = RandomStart(std::cell::RefCell::new(ChaCha8Rng::seed_from_u64(seed + 1)));
    let random: [&dyn StartProvider<SVector<f64, 36>, 7>; 1] = [&random_start];
    let with_learned = Pipeline::<P, _, _, _, _, 7, 19, 36, { P::NC }>::new(&target, &learned, &simulator, &Reprojection);
    let with_random = Pipeline::<P, _, _, _, _, 7, 19, 36, { P::NC }>::new(&target, &random, &simulator, &Reprojection);

    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1000);
    let trials = 300;
    let (mut ok_learned, mut ok_random, mut wrong_unflagged, mut start_errors) = (0, 0, 0, Vec::new());
    for _ in 0..trials {
        let (p, x) = scene(&mut rng);
        let truth = rotation_from_quat([x[0], x[1], x[2], x[3]]);
        let x0: SVector<f64, 7> = trained.start.start(&p).expect("a start");
        start_errors.push(rotation_error_deg(&rotation_from_quat([x0[0], x0[1], x0[2], x0[3]]), &truth));
        for (pipeline, ok) in [(&with_learned, &mut ok_learned), (&with_random, &mut ok_random)] {
            if let Ok(solved) = pipeline.solve(&p) {
                let r = rotation_from_quat([solved.x[0], solved.x[1], solved.x[2], solved.x[3]]);
                if rotation_error_deg(&r, &truth) < 1e-4 {
                    *ok += 1;
                } else {
                    wrong_unflagged += 1;
                }
            }
        }
    }
    start_errors.sort_by(f64::total_cmp);
    let median = start_errors[trials / 2];
    println!("learned start: median rotation error {median:.1} deg; success {ok_learned}/{trials} learned, {ok_random}/{trials} random; wrong unflagged {wrong_unflagged}");
    // A random rotation is 126 deg off at the median; the tiny network must do far better.
    assert!(median < 45.0, "median start error {median}");
    assert!(ok_learned * 100 >= trials * 90, "learned: {ok_learned}/{trials}");
    assert!(ok_learned >= ok_random + trials / 10, "learned {ok_learned} vs random {ok_random}");
    assert_eq!(wrong_unflagged, 0, "six exact correspondences have one solution: anything validated is the truth");

    // Bad input through the pipeline: a typed error that names the row and field.
    let (mut p, _) = scene(&mut rng);
    p[6 * 4 + 4] = f64::NAN;
    let err = with_learned.solve(&p).unwrap_err();
    assert_eq!(err, PipelineError::Input(NonFiniteParameter { row: Some(4), field: "p", index: 28 }));
    assert_eq!(err.to_string(), "input: row 4, field `p`: not finite (parameter 28)");
}
