//! The generic minimum-norm simulator on natural declarations whose equations are dependent:
//! cross products `f x d` have rank two (`f . (f x d) = 0`), so `dF/dp dF/dp^T` is singular or,
//! as the residual vanishes, ill-conditioned. Declared as a new user would from the README:
//! generalized absolute pose with scale from 4 points, and central P3P.
//!
//! The simulator must succeed on at least 99.9 % of noise-free starts up to 45 degrees off, and
//! from 10-degree starts the tracker must reach the ground truth in at least 99 %. The rates at
//! 20 and 45 degrees are printed (a minimal problem has several real roots: a far start may
//! honestly end on another one).

use nalgebra::{Matrix3, SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::homotopy::ParameterHomotopy;
use simhc::tracker::{track, TrackerOptions};
use simhc::MinNormSimulator;
use simhc_problems::metrics::{
    quat_from_rotation, random_rotation_perturbation, random_unit_vector, rotation_error_deg, rotation_from_quat,
};
use simhc_problems::upnp::scene::random_rotation;

#[simhc::simhc_problem]
mod gaps {
    pub struct Unknowns {
        q: Quat,
        t: Vec3,
        s: Scalar,
    }
    pub struct Row {
        f: Vec3,
        v: Vec3,
        p: Vec3,
    }
    pub const ROWS: [usize; 1] = [4];
    pub fn row_equations() -> Vec3 {
        f.cross(s * (rotation(q) * p) + t - v)
    }
    pub fn global_equations() -> [Scalar; 1] {
        [q.dot(q) - 1]
    }
}

#[simhc::simhc_problem]
mod central_p3p {
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

/// A noise-free scene: pose, points in front of the cameras.
struct Scene {
    r: Matrix3<f64>,
    t: Vector3<f64>,
    s: f64,
    points: Vec<Vector3<f64>>,
    origins: Vec<Vector3<f64>>,
}

fn scene(rng: &mut ChaCha8Rng, n: usize, central: bool) -> Scene {
    let r = random_rotation(rng);
    let s = if central { 1.0 } else { rng.random_range(0.5..2.0) };
    let t = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let origins = (0..n).map(|_| if central { Vector3::zeros() } else { Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)) }).collect();
    // Viewer-frame points X in [-1,1]^2 x [4,8], world points p with X = s R p + t.
    let points = (0..n)
        .map(|_| {
            let x = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(4.0..8.0));
            r.transpose() * (x - t) / s
        })
        .collect();
    Scene { r, t, s, points, origins }
}

fn perturbed_start(sc: &Scene, angle: f64, rng: &mut ChaCha8Rng, with_scale: bool) -> Vec<f64> {
    let q = quat_from_rotation(&random_rotation_perturbation(&sc.r, angle, rng));
    let t = sc.t + random_unit_vector(rng) * 0.2 * sc.t.norm().max(1.0);
    let mut x = vec![q[0], q[1], q[2], q[3], t.x, t.y, t.z];
    if with_scale {
        x.push(sc.s * if rng.random::<bool>() { 1.2 } else { 0.8 });
    }
    x
}

struct Rates {
    simulated: usize,
    reached: usize,
    trials: usize,
}

fn run<P, const NX: usize, const NF: usize, const NP: usize>(
    angle: f64,
    trials: usize,
    seed: u64,
    central: bool,
    params: impl Fn(&Scene) -> SVector<f64, NP>,
) -> Rates
where
    P: simhc::ParamDerivative<NX, NF, NP>,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = NP / if central { 6 } else { 9 };
    let mut rates = Rates { simulated: 0, reached: 0, trials };
    for _ in 0..trials {
        let sc = scene(&mut rng, n, central);
        let p = params(&sc);
        let x0 = SVector::<f64, NX>::from_column_slice(&perturbed_start(&sc, angle, &mut rng, !central));
        let Ok(p0) = MinNormSimulator::<P>::new().run::<NX, NF, NP>(&x0, &p) else { continue };
        rates.simulated += 1;
        let h = ParameterHomotopy::<P, f64, NP>::new(p0, p);
        if let Ok(end) = track(&h, &x0, &TrackerOptions::single_path()) {
            let x = end.x;
            let r = rotation_from_quat([x[0], x[1], x[2], x[3]]);
            if rotation_error_deg(&r, &sc.r) < 1e-4 {
                rates.reached += 1;
            }
        }
    }
    rates
}

fn gaps_params(sc: &Scene) -> SVector<f64, 36> {
    let rows: [gaps::Row; 4] = std::array::from_fn(|i| {
        let d = sc.r * sc.points[i] * sc.s + sc.t - sc.origins[i];
        gaps::Row { f: d.normalize().into(), v: sc.origins[i].into(), p: sc.points[i].into() }
    });
    gaps::Gaps4::params(&rows)
}

fn p3p_params(sc: &Scene) -> SVector<f64, 18> {
    let rows: [central_p3p::Row; 3] = std::array::from_fn(|i| {
        let d = sc.r * sc.points[i] + sc.t;
        central_p3p::Row { f: d.normalize().into(), p: sc.points[i].into() }
    });
    central_p3p::CentralP3p3::params(&rows)
}

fn check(name: &str, rates: [(f64, Rates); 3]) {
    for (angle, r) in &rates {
        println!(
            "{name}, starts {angle} deg off: simulator {}/{} ({:.2} %), truth reached {}/{} ({:.1} %)",
            r.simulated,
            r.trials,
            100.0 * r.simulated as f64 / r.trials as f64,
            r.reached,
            r.trials,
            100.0 * r.reached as f64 / r.trials as f64
        );
        assert!(r.simulated * 1000 >= r.trials * 999, "{name} at {angle} deg: simulator {}/{}", r.simulated, r.trials);
    }
    let (_, ten) = &rates[0];
    assert!(ten.reached * 100 >= ten.trials * 99, "{name} from 10 deg: truth reached {}/{}", ten.reached, ten.trials);
}

#[test]
fn generalized_absolute_pose_with_scale() {
    let seed = 15;
    println!("seed {seed}");
    check("gaps4", [10.0, 20.0, 45.0].map(|a| (a, run::<gaps::Gaps4, 8, 13, 36>(a, 1000, seed + a as u64, false, gaps_params))));
}

#[test]
fn central_p3p() {
    let seed = 16;
    println!("seed {seed}");
    check("p3p", [10.0, 20.0, 45.0].map(|a| (a, run::<central_p3p::CentralP3p3, 7, 10, 18>(a, 1000, seed + a as u64, true, p3p_params))));
}
