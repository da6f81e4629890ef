//! The generic Simulator HC pipeline ([`simhc::pipeline`]) on a problem declared as a user
//! would: central P3P from three rows, with a fourth correspondence that only validation sees.
//! Retries, the fallback, flagged results and bad input, each with a case that fails if the
//! executor stops doing it.

use nalgebra::{Matrix3, SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::pipeline::{
    Attempt, AttemptError, Canonicalize, Fallback, Generic, Method, Origin, Pipeline, PipelineError, PipelineOptions, StartError,
    StartProvider, StartSimulator, TargetParameters, Validator, Verdict,
};
use simhc::tracker::{Predictor, TrackerOptions};
use simhc::{MinNormSimulator, SimulatorError};
use simhc_problems::metrics::{quat_from_rotation, random_rotation_perturbation, rotation_error_deg, rotation_from_quat};
use simhc_problems::upnp::scene::random_rotation;

#[simhc::simhc_problem]
mod p3p {
    pub struct Unknowns {
        q: Quat,
        t: Vec3,
    }
    pub struct Row {
        f: Vec3,
        p: Vec3,
    }
    pub const ROWS: [usize; 1] = [3];
    pub fn row_equations() -> Vec3 {
        f.cross(rotation(q) * p + t)
    }
    pub fn global_equations() -> [Scalar; 1] {
        [q.dot(q) - 1]
    }
}

/// Four bearings and world points; the system uses the first three.
#[derive(Clone)]
struct Data {
    f: [Vector3<f64>; 4],
    p: [Vector3<f64>; 4],
}

/// Bad input, with where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("correspondence {index}, field `{field}`: not finite")]
struct NotFinite {
    index: usize,
    field: &'static str,
}

struct Target;

impl TargetParameters<Data, 18> for Target {
    type Error = NotFinite;
    fn params(&self, d: &Data) -> Result<SVector<f64, 18>, NotFinite> {
        for i in 0..4 {
            for (field, v) in [("f", &d.f[i]), ("p", &d.p[i])] {
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(NotFinite { index: i, field });
                }
            }
        }
        let rows: [p3p::Row; 3] = std::array::from_fn(|i| p3p::Row { f: d.f[i].into(), p: d.p[i].into() });
        Ok(p3p::P3p3::params(&rows))
    }
}

/// The largest angle between a bearing and its point under the pose, over all four.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
struct Angle(f64);

struct AngleValidator {
    accept: f64,
    plausible: f64,
}

impl Validator<Data, 7> for AngleValidator {
    type Check = Angle;
    fn check(&self, d: &Data, x: &SVector<f64, 7>) -> Angle {
        let (r, t) = pose(x);
        let worst = (0..4)
            .map(|i| {
                let y = r * d.p[i] + t;
                let a = d.f[i].cross(&y).norm().atan2(d.f[i].dot(&y));
                if a.is_nan() {
                    f64::INFINITY
                } else {
                    a
                }
            })
            .fold(0.0, f64::max);
        Angle(worst)
    }
    fn verdict(&self, c: &Angle) -> Verdict {
        if c.0 <= self.accept {
            Verdict::Accept
        } else if c.0 <= self.plausible {
            Verdict::Plausible
        } else {
            Verdict::Reject
        }
    }
    fn better(&self, a: &Angle, b: &Angle) -> bool {
        a.0 < b.0
    }
}

fn pose(x: &SVector<f64, 7>) -> (Matrix3<f64>, Vector3<f64>) {
    let n = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]).sqrt();
    (rotation_from_quat([x[0] / n, x[1] / n, x[2] / n, x[3] / n]), Vector3::new(x[4], x[5], x[6]))
}

/// A fixed start.
struct Fixed(&'static str, SVector<f64, 7>);

impl StartProvider<Data, 7> for Fixed {
    fn name(&self) -> &'static str {
        self.0
    }
    fn start(&self, _: &Data) -> Result<SVector<f64, 7>, StartError> {
        Ok(self.1)
    }
}

/// A provider with no start (a regressor that cannot run on this input).
struct Unavailable;

impl StartProvider<Data, 7> for Unavailable {
    fn name(&self) -> &'static str {
        "unavailable"
    }
    fn start(&self, _: &Data) -> Result<SVector<f64, 7>, StartError> {
        Err(StartError { provider: "unavailable", reason: "no start for this input".into() })
    }
}

/// Fixed candidates.
struct Candidates(Vec<SVector<f64, 7>>);

impl Fallback<Data, 7, 18> for Candidates {
    fn candidates(&self, _: &Data, _: &SVector<f64, 18>) -> Vec<SVector<f64, 7>> {
        self.0.clone()
    }
}

/// A noise-free scene (points in front of the camera) with its true unknowns.
fn scene(seed: u64) -> (Data, SVector<f64, 7>, Matrix3<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let r = random_rotation(&mut rng);
    let t = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let mut d = Data { f: [Vector3::zeros(); 4], p: [Vector3::zeros(); 4] };
    for i in 0..4 {
        let y = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(4.0..8.0));
        d.f[i] = y.normalize();
        d.p[i] = r.transpose() * (y - t);
    }
    let q = quat_from_rotation(&r);
    (d, SVector::from([q[0], q[1], q[2], q[3], t.x, t.y, t.z]), r)
}

fn near(x: &SVector<f64, 7>, r: &Matrix3<f64>, angle: f64, seed: u64) -> SVector<f64, 7> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q = quat_from_rotation(&random_rotation_perturbation(r, angle, &mut rng));
    SVector::from([q[0], q[1], q[2], q[3], x[4] * 1.1, x[5] * 0.9, x[6] * 1.1])
}

fn simulator() -> Generic<MinNormSimulator<p3p::P3p3>> {
    Generic(MinNormSimulator::new())
}

const STRICT: AngleValidator = AngleValidator { accept: 1e-8, plausible: 1e-8 };

#[test]
fn retries_after_a_start_that_is_not_available() {
    let seed = 3;
    println!("seed {seed}");
    let (data, truth, r) = scene(seed);
    let starts: [&dyn StartProvider<Data, 7>; 2] = [&Unavailable, &Fixed("near", near(&truth, &r, 10.0, seed))];
    let sim = simulator();
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT);
    let solved = pipeline.solve(&data).expect("the second start validates");
    assert_eq!(solved.origin, Origin::Path { provider: 1, method: Method::SimulatorHc });
    // A provider without a start makes no attempt.
    assert_eq!(solved.attempts, 1);
    assert!(solved.check.0 < 1e-8);
    assert!(rotation_error_deg(&pose(&solved.x).0, &r) < 1e-6);
}

#[test]
fn a_solution_that_does_not_explain_all_the_data_is_flagged() {
    let seed = 4;
    println!("seed {seed}");
    let (mut data, truth, r) = scene(seed);
    // The fourth correspondence, which the system does not see, is an outlier.
    data.f[3] = Vector3::new(0.3, -0.2, 1.0).normalize();
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&Fixed("near", near(&truth, &r, 5.0, seed))];
    let sim = simulator();
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT);
    match pipeline.solve(&data) {
        Err(PipelineError::NotValidated(best)) => {
            // The path did reach the exact root of the three rows; only validation tells.
            assert!(rotation_error_deg(&pose(&best.x).0, &r) < 1e-6);
            assert!(best.check.0 > 1e-3, "outlier angle {}", best.check.0);
            assert_eq!(best.attempts, 1);
        }
        other => panic!("expected a flagged result, got {other:?}"),
    }
}

#[test]
fn the_fallback_runs_when_no_path_validates_and_is_validated_too() {
    let seed = 5;
    println!("seed {seed}");
    let (data, truth, _) = scene(seed);
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&Unavailable];
    let wrong = SVector::from([0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 5.0]);
    let fallback = Candidates(vec![wrong, truth]);
    let sim = simulator();
    let pipeline =
        Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT).with_fallback(&fallback);
    let solved = pipeline.solve(&data).expect("the true candidate validates");
    assert_eq!(solved.origin, Origin::Fallback { candidate: 1 });
    // The provider had no start (no attempt); the fallback counts as one.
    assert_eq!(solved.attempts, 1);
    // Without the fallback: nothing at all.
    let off = pipeline.with_options(PipelineOptions { fallback: false, ..PipelineOptions::default() });
    assert!(matches!(off.solve(&data), Err(PipelineError::NoEndPoint { attempts: 0, last: Some(AttemptError::Start(_)) })));
    // Only wrong candidates: flagged, not returned.
    let only_wrong = Candidates(vec![wrong]);
    let pipeline =
        Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT).with_fallback(&only_wrong);
    assert!(matches!(pipeline.solve(&data), Err(PipelineError::NotValidated(b)) if b.origin == Origin::Fallback { candidate: 0 }));
}

#[test]
fn plausible_end_points_get_extra_attempts_and_the_best_is_returned() {
    let seed = 6;
    println!("seed {seed}");
    let (mut data, truth, r) = scene(seed);
    // Noise on the unseen fourth bearing: no end point is exact, the true root is plausible.
    data.f[3] = (data.f[3] + Vector3::new(2e-4, -1e-4, 0.0)).normalize();
    let loose = AngleValidator { accept: 1e-12, plausible: 1e-2 };
    let starts: [&dyn StartProvider<Data, 7>; 3] =
        [&Fixed("a", near(&truth, &r, 5.0, 1)), &Fixed("b", near(&truth, &r, 5.0, 2)), &Fixed("c", near(&truth, &r, 5.0, 3))];
    let sim = simulator();
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &loose);
    let one = pipeline.solve(&data).expect("plausible");
    assert_eq!((one.attempts, one.origin), (1, Origin::Path { provider: 0, method: Method::SimulatorHc }));
    let two = pipeline.with_options(PipelineOptions { extra_attempts: 1, ..PipelineOptions::default() }).solve(&data).expect("plausible");
    assert_eq!(two.attempts, 2, "one extra attempt after the first plausible end point");
    assert!(two.check.0 <= one.check.0);
}

#[test]
fn bad_input_is_a_typed_error_that_says_where() {
    let (mut data, truth, r) = scene(7);
    data.p[2].y = f64::NAN;
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&Fixed("near", near(&truth, &r, 5.0, 7))];
    let sim = simulator();
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT);
    let err = pipeline.solve(&data).unwrap_err();
    assert_eq!(err, PipelineError::Input(NotFinite { index: 2, field: "p" }));
    assert_eq!(err.to_string(), "input: correspondence 2, field `p`: not finite");
}

/// The world points centred on their mean: `R p + t = R (p - m) + (t + R m)`.
struct CentredWorld;

impl simhc::pipeline::Canonicalize<Data, 7> for CentredWorld {
    type Frame = Vector3<f64>;
    type Canonical = Data;
    fn canonicalize(&self, d: &Data) -> Option<(Vector3<f64>, Data)> {
        let m = d.p.iter().sum::<Vector3<f64>>() / 4.0;
        m.iter().all(|v| v.is_finite()).then(|| (m, Data { f: d.f, p: d.p.map(|p| p - m) }))
    }
    fn to_user(&self, m: &Vector3<f64>, x: &SVector<f64, 7>) -> SVector<f64, 7> {
        let (r, t) = pose(x);
        let t = t - r * m;
        SVector::from([x[0], x[1], x[2], x[3], t.x, t.y, t.z])
    }
}

#[test]
fn canonical_frames_give_the_same_solution_in_the_users_frame() {
    let seed = 8;
    println!("seed {seed}");
    let (mut data, truth, r) = scene(seed);
    // The user's world frame far from the points.
    let shift = Vector3::new(300.0, -120.0, 45.0);
    data.p = data.p.map(|p| p + shift);
    let t_user = Vector3::new(truth[4], truth[5], truth[6]) - r * shift;
    // Start providers see the canonical data, so this fixed start is given in the canonical
    // frame (points centred): `t~ = t + R m`.
    let (m, _) = CentredWorld.canonicalize(&data).expect("a frame");
    let mut start = near(&truth, &r, 10.0, seed);
    let t_can = Vector3::new(start[4], start[5], start[6]) + r * (m - shift);
    start.fixed_rows_mut::<3>(4).copy_from(&t_can);
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&Fixed("near", start)];
    let sim = simulator();
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT);
    let solved = pipeline.solve_canonical(&CentredWorld, &data).expect("validated in the user's frame");
    let (r_hat, t_hat) = pose(&solved.x);
    assert!(rotation_error_deg(&r_hat, &r) < 1e-6);
    assert!((t_hat - t_user).norm() < 1e-7 * t_user.norm(), "translation {t_hat} vs {t_user}");
    // The check is the user's: recomputed on the data as given.
    assert_eq!(solved.check, STRICT.check(&data, &solved.x));
    // The start is reported in the user's frame too.
    assert_eq!(solved.start, CentredWorld.to_user(&m, &start));
}

/// A fixed start that counts how often it was asked.
struct Counted(SVector<f64, 7>, std::cell::Cell<usize>);

impl StartProvider<Data, 7> for Counted {
    fn name(&self) -> &'static str {
        "counted"
    }
    fn start(&self, _: &Data) -> Result<SVector<f64, 7>, StartError> {
        self.1.set(self.1.get() + 1);
        Ok(self.0)
    }
}

#[test]
fn a_schedule_tries_methods_in_order_and_computes_each_start_once() {
    let seed = 9;
    println!("seed {seed}");
    let (data, truth, r) = scene(seed);
    // A start no method can use (NaN): both of its attempts fail.
    let counted = Counted(SVector::from_element(f64::NAN), std::cell::Cell::new(0));
    let near_start = Fixed("near", near(&truth, &r, 5.0, seed));
    let starts: [&dyn StartProvider<Data, 7>; 2] = [&counted, &near_start];
    let schedule = [
        Attempt { provider: 0, method: Method::GaussNewton },
        Attempt { provider: 0, method: Method::SimulatorHc },
        Attempt { provider: 7, method: Method::SimulatorHc },
        Attempt { provider: 1, method: Method::GaussNewton },
    ];
    let sim = simulator();
    let pipeline =
        Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT).with_schedule(&schedule);
    let solved = pipeline.solve(&data).expect("some attempt validates");
    println!("origin {:?} after {} attempts", solved.origin, solved.attempts);
    assert_eq!(counted.1.get(), 1, "one start per provider, shared by its methods");
    assert!(rotation_error_deg(&pose(&solved.x).0, &r) < 1e-6);
    // The near start by Gauss-Newton, after both methods failed on the first start and the
    // missing provider 7 was skipped (not counted as an attempt).
    assert_eq!(solved.origin, Origin::Path { provider: 1, method: Method::GaussNewton });
    assert_eq!(solved.attempts, 3);
}

#[test]
fn other_simulators_are_named_by_index_in_the_schedule() {
    let seed = 10;
    println!("seed {seed}");
    let (data, truth, r) = scene(seed);
    let near_start = Fixed("near", near(&truth, &r, 10.0, seed));
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&near_start];
    // Other simulator 3 does not exist (skipped, not an attempt); 0 is the generic one.
    let schedule =
        [Attempt { provider: 0, method: Method::OtherSimulatorHc(3) }, Attempt { provider: 0, method: Method::OtherSimulatorHc(0) }];
    let (sim, other) = (Broken, simulator());
    let others: [&dyn StartSimulator<Data, 7, 10, 18>; 1] = [&other];
    let pipeline = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT)
        .with_schedule(&schedule)
        .with_other_simulators(&others);
    let solved = pipeline.solve(&data).expect("the other simulator's path validates");
    assert_eq!(solved.origin, Origin::Path { provider: 0, method: Method::OtherSimulatorHc(0) });
    assert!(rotation_error_deg(&pose(&solved.x).0, &r) < 1e-6);
    // The pipeline's own simulator fails on every start: no end point.
    let own = [Attempt { provider: 0, method: Method::SimulatorHc }];
    let failing = Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT)
        .with_schedule(&own)
        .with_other_simulators(&others);
    assert!(matches!(failing.solve(&data), Err(PipelineError::NoEndPoint { attempts: 1, last: Some(AttemptError::Simulator(_)) })));
}

/// A simulator that always fails.
struct Broken;

impl StartSimulator<Data, 7, 10, 18> for Broken {
    fn simulate(&self, _data: &Data, _x0: &SVector<f64, 7>, _p: &SVector<f64, 18>) -> Result<SVector<f64, 18>, SimulatorError> {
        Err(SimulatorError::Singular)
    }
}

#[test]
fn the_polish_refines_end_points_a_lenient_tracker_returns_short() {
    let seed = 12;
    println!("seed {seed}");
    let (data, truth, r) = scene(seed);
    let near_start = Fixed("near", near(&truth, &r, 10.0, seed));
    let starts: [&dyn StartProvider<Data, 7>; 1] = [&near_start];
    let sim = simulator();
    // One Euler step of the whole path, one corrector update, no final refinement: the end point
    // is returned short of the final tolerance, as the paper's tracker returns them.
    let lenient =
        TrackerOptions { predictor: Predictor::Euler, max_newton_iterations: 1, final_newton_iterations: 0, ..TrackerOptions::paper(1.0) };
    let pipeline = |options| {
        Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT).with_options(options)
    };
    let options = PipelineOptions { tracker: lenient, fallback: false, ..PipelineOptions::default() };
    let short = match pipeline(options).solve(&data) {
        Err(PipelineError::NotValidated(best)) => best,
        other => panic!("expected the lenient end point to be flagged, got {other:?}"),
    };
    println!("without the polish: max angle {:e}, {} Newton iterations", short.check.0, short.stats.newton_iterations);
    let polished = pipeline(PipelineOptions { polish: true, ..options }).solve(&data).expect("the polished end point validates");
    println!("with the polish: max angle {:e}, {} Newton iterations", polished.check.0, polished.stats.newton_iterations);
    assert!(polished.check.0 <= STRICT.accept);
    assert!(polished.stats.newton_iterations > short.stats.newton_iterations);
    assert!(rotation_error_deg(&pose(&polished.x).0, &r) < 1e-6);
}

#[test]
fn a_start_attempt_validates_the_start_as_it_is() {
    let seed = 13;
    println!("seed {seed}");
    let (data, truth, r) = scene(seed);
    let (exact, off) = (Fixed("exact", truth), Fixed("near", near(&truth, &r, 10.0, seed)));
    let starts: [&dyn StartProvider<Data, 7>; 2] = [&off, &exact];
    let schedule = [Attempt { provider: 0, method: Method::Start }, Attempt { provider: 1, method: Method::Start }];
    let sim = simulator();
    let pipeline =
        Pipeline::<p3p::P3p3, _, _, _, _, 7, 10, 18, { p3p::P3p3::NC }>::new(&Target, &starts, &sim, &STRICT).with_schedule(&schedule);
    let solved = pipeline.solve(&data).expect("the exact start validates");
    // The 10-degree start is rejected as it is (no path, no Newton step); the exact one is returned.
    assert_eq!((solved.origin, solved.attempts), (Origin::Path { provider: 1, method: Method::Start }, 2));
    assert_eq!(solved.x, truth);
    assert_eq!(solved.stats.newton_iterations, 0);
}
