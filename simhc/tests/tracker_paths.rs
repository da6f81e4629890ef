//! Paths with known end points: closed-form univariate and circle-line paths, random square
//! systems with solutions known by construction, and an overdetermined system tracked by
//! Gauss-Newton and squared up. Every end point is checked to 1e-10.

mod tracker_support;

use nalgebra::{SVector, Vector1, Vector2};
use simhc::homotopy::{FixedSystem, Homotopy, ParameterHomotopy, SquaredUp, StraightLine};
use simhc::tracker::{newton, solve_newton, track, NewtonOptions, Predictor, TrackResult, Tracker, TrackerOptions, TrackerStatus};
use tracker_support::*;

/// The tracker settings every closed-form path must pass with.
fn all_options() -> Vec<(&'static str, TrackerOptions)> {
    vec![
        ("adaptive", TrackerOptions::default()),
        ("paper dt=0.05", TrackerOptions::paper(0.05)),
        ("paper dt=0.02", TrackerOptions::paper(0.02)),
        ("adaptive heun", TrackerOptions { predictor: Predictor::Heun, ..Default::default() }),
        ("single path", TrackerOptions::single_path()),
        ("hermite 2", TrackerOptions { predictor: Predictor::Hermite { points: 2 }, ..Default::default() }),
        ("hermite 3", TrackerOptions { predictor: Predictor::Hermite { points: 3 }, ..Default::default() }),
    ]
}

/// The multistep predictor factorizes only to start (the start tangent, then Heun until the
/// first accepted step gives it a history); Heun factorizes once more per step.
#[test]
fn hermite_predictor_needs_no_stage_factorizations() {
    let (p0, p1) = circle_line_pair(12);
    let [s0, _] = circle_line_intersections(&p0).unwrap();
    let [s1, _] = circle_line_intersections(&p1).unwrap();
    let h = ParameterHomotopy::<CircleLine, f64, 6>::new(p0, p1);
    // Small steps so that the path has many of them.
    let step = simhc::tracker::AdaptiveStep { max: 0.05, ..Default::default() };
    for points in [2u8, 3] {
        let opts = TrackerOptions { predictor: Predictor::Hermite { points }, ..TrackerOptions::adaptive(step) };
        let r = track(&h, &s0, &opts).unwrap();
        assert_close("hermite", &r.x, &s1);
        let s = r.stats;
        assert!(s.accepted_steps >= 20, "{s:?}");
        assert!(s.factorizations - s.newton_iterations <= 2 + s.rejected_steps, "{points}: {s:?}");
        let heun = track(&h, &s0, &TrackerOptions { predictor: Predictor::Heun, ..TrackerOptions::adaptive(step) }).unwrap();
        assert_eq!(heun.stats.factorizations - heun.stats.newton_iterations, 1 + heun.stats.steps(), "{:?}", heun.stats);
    }
}

fn assert_close<const N: usize>(name: &str, got: &SVector<f64, N>, want: &SVector<f64, N>) {
    let err = (got - want).amax();
    assert!(err <= 1e-10, "{name}: |x - x*| = {err:e}, got {got}, want {want}");
}

fn report<const N: usize>(name: &str, r: &TrackResult<f64, N>) {
    println!(
        "{name}: accepted {} rejected {} newton {} factorizations {} residual {:e} accuracy {:e}",
        r.stats.accepted_steps, r.stats.rejected_steps, r.stats.newton_iterations, r.stats.factorizations, r.residual, r.accuracy
    );
}

#[test]
fn univariate_root_moving_with_parameter() {
    // x^3 + a x - a^3 - a^2 has the single real root x = a for a > 0.
    let (a0, a1) = (0.5, 2.0);
    let p0 = Vector1::new(a0);
    let p1 = Vector1::new(a1);
    let x0 = Vector1::new(a0);
    let param = ParameterHomotopy::<Cubic, f64, 1>::new(p0, p1);
    let line = StraightLine::<Cubic, f64, 1>::new(p0, p1);
    for (name, opts) in all_options() {
        let r = track(&param, &x0, &opts).unwrap_or_else(|e| panic!("{name} parameter: {e}"));
        report(name, &r);
        assert_eq!(r.t, 1.0);
        assert_close(name, &r.x, &Vector1::new(a1));
        assert!(r.residual < 1e-12);
        // Straight line: (1-t) F0 + t F1 = x^3 + A x - C with A > 0 is monotone, one real root.
        let r = track(&line, &x0, &opts).unwrap_or_else(|e| panic!("{name} line: {e}"));
        assert_close(name, &r.x, &Vector1::new(a1));
    }

    // Along the parameter path every accepted point is on x(t) = a(t).
    let mut tracker = Tracker::new(&param, TrackerOptions::default());
    tracker.start(&x0).unwrap();
    while tracker.step() == TrackerStatus::Tracking {
        let s = tracker.state();
        let want = a0 + s.t * (a1 - a0);
        assert!((s.x[0] - want).abs() < 1e-8, "t = {}: {} vs {}", s.t, s.x[0], want);
    }
    assert_eq!(tracker.status(), TrackerStatus::Success);
}

#[test]
fn paper_schedule_takes_exactly_its_steps() {
    let h = ParameterHomotopy::<Cubic, f64, 1>::new(Vector1::new(0.5), Vector1::new(2.0));
    for (dt, steps) in [(0.05, 20), (0.02, 50), (0.25, 4)] {
        let r = track(&h, &Vector1::new(0.5), &TrackerOptions::paper(dt)).unwrap();
        assert_eq!(r.stats.accepted_steps, steps, "dt = {dt}");
        assert_eq!(r.stats.rejected_steps, 0);
        assert!(r.stats.newton_iterations <= 5 * steps);
        assert_close("paper", &r.x, &Vector1::new(2.0));
    }
}

/// Circle-line instances whose line stays secant to the circle along `p(t)`.
fn circle_line_pair(seed: u64) -> (SVector<f64, 6>, SVector<f64, 6>) {
    let mut rng = rng(seed);
    loop {
        let mut draw = || {
            let ang: f64 = uniform(&mut rng, 0.0, std::f64::consts::TAU);
            SVector::<f64, 6>::from_column_slice(&[
                uniform(&mut rng, -1.0, 1.0),
                uniform(&mut rng, -1.0, 1.0),
                uniform(&mut rng, 1.0, 2.0),
                ang.cos(),
                ang.sin(),
                0.0,
            ])
        };
        let (mut p0, mut p1) = (draw(), draw());
        // Line through a point well inside the circle.
        for p in [&mut p0, &mut p1] {
            let off = 0.3 * p[2];
            p[5] = p[3] * (p[0] + off) + p[4] * p[1];
        }
        let ok = (0..=200).all(|i| {
            let t = i as f64 / 200.0;
            circle_line_intersections(&((1.0 - t) * p0 + t * p1)).is_some_and(|[a, b]| (a - b).norm() > 0.2)
        });
        if ok {
            return (p0, p1);
        }
    }
}

/// The straight-line combination of two circle-line systems is again a circle-line system:
/// centre and line coefficients interpolate, `r^2 = |c|^2 - ((1-t) k0 + t k1)`,
/// `k = |c|^2 - r^2`.
fn straight_line_instance(p0: &SVector<f64, 6>, p1: &SVector<f64, 6>, t: f64) -> SVector<f64, 6> {
    let kk = |p: &SVector<f64, 6>| p[0] * p[0] + p[1] * p[1] - p[2] * p[2];
    let mut p = (1.0 - t) * p0 + t * p1;
    let c2 = p[0] * p[0] + p[1] * p[1];
    let r2 = c2 - ((1.0 - t) * kk(p0) + t * kk(p1));
    p[2] = r2.max(0.0).sqrt();
    if r2 <= 0.0 {
        p[2] = -1.0;
    }
    p
}

#[test]
fn circle_line_intersection_closed_form() {
    for seed in [11u64, 12, 13, 14, 15] {
        let (p0, p1) = circle_line_pair(seed);
        let [s0a, s0b] = circle_line_intersections(&p0).unwrap();
        let [s1a, s1b] = circle_line_intersections(&p1).unwrap();
        let param = ParameterHomotopy::<CircleLine, f64, 6>::new(p0, p1);
        for (name, opts) in all_options() {
            for (x0, want) in [(s0a, s1a), (s0b, s1b)] {
                let r = track(&param, &x0, &opts).unwrap_or_else(|e| panic!("{seed} {name}: {e}"));
                report(name, &r);
                assert_close(name, &r.x, &want);
            }
        }
        // Straight line: closed form at every t when the combined line stays secant.
        let secant = (0..=200).all(|i| {
            let q = straight_line_instance(&p0, &p1, i as f64 / 200.0);
            q[2] > 0.0 && circle_line_intersections(&q).is_some_and(|[a, b]| (a - b).norm() > 0.2)
        });
        if secant {
            let line = StraightLine::<CircleLine, f64, 6>::new(p0, p1);
            let r = track(&line, &s0b, &TrackerOptions::default()).unwrap();
            assert_close("straight line", &r.x, &s1b);
            let r = track(&line, &s0a, &TrackerOptions::paper(0.05)).unwrap();
            assert_close("straight line paper", &r.x, &s1a);
        } else {
            println!("seed {seed}: straight-line path not secant throughout, skipped");
        }
    }
}

#[test]
fn random_square_system_parameter_homotopy() {
    for seed in 100u64..110 {
        let mut rng = rng(seed);
        let p0 = quad4_params(&mut rng);
        let p1 = quad4_params(&mut rng);
        let x0 = quad4_solution(&p0);
        let want = quad4_solution(&p1);
        let h = ParameterHomotopy::<Quad4, f64, Q4_NP>::new(p0, p1);
        assert!(h.validation_residual(&x0, 0.0) < 1e-12);
        for (name, opts) in all_options() {
            let r = track(&h, &x0, &opts).unwrap_or_else(|e| panic!("seed {seed} {name}: {e}"));
            report(name, &r);
            assert_close(name, &r.x, &want);
            assert!(r.residual < 1e-10);
        }
        // Every accepted point lies on x(t) = u(t)^3.
        let mut tracker = Tracker::new(&h, TrackerOptions::default());
        tracker.start(&x0).unwrap();
        while tracker.step() == TrackerStatus::Tracking {
            let s = tracker.state();
            let on_path = quad4_solution(&((1.0 - s.t) * p0 + s.t * p1));
            assert!((s.x - on_path).amax() < 1e-7, "seed {seed} t = {}", s.t);
        }
        assert_eq!(tracker.status(), TrackerStatus::Success);
    }
}

/// A start instance and a target near it (every coefficient and the root moved by up to
/// `scale`), the simulator-HC situation.
fn over_pair(seed: u64, scale: f64) -> (SVector<f64, O_NP>, SVector<f64, O_NP>) {
    let mut rng = rng(seed);
    let p0 = over_params(&mut rng);
    let mut p1 = p0;
    for v in p1.iter_mut() {
        *v += uniform(&mut rng, -scale, scale);
    }
    (p0, p1)
}

#[test]
fn overdetermined_gauss_newton_and_squared_up() {
    for seed in 200u64..210 {
        let (p0, p1) = over_pair(seed, 0.3);
        let x0 = Vector2::new(p0[15], p0[16]);
        let want = Vector2::new(p1[15], p1[16]);

        // Parameter homotopy: consistent at every t, Gauss-Newton on 3 x 2.
        let param = ParameterHomotopy::<Over3x2, f64, O_NP>::new(p0, p1);
        // Straight line: inconsistent in between (least-squares path), exact at t = 1.
        let line = StraightLine::<Over3x2, f64, O_NP>::new(p0, p1);
        // Squared up (random 2 x 3 combination), Newton on the square system; validated by the
        // full residual.
        let sq_line = SquaredUp::new(line, 7 + seed);
        let sq_param = SquaredUp::new(param, 8 + seed);
        for (name, opts) in all_options() {
            let r = track(&param, &x0, &opts).unwrap_or_else(|e| panic!("{seed} {name}: {e}"));
            report(name, &r);
            assert_close(name, &r.x, &want);
            assert!(r.residual < 1e-12, "{seed} {name}: residual {:e}", r.residual);
            let r = track(&line, &x0, &opts).unwrap_or_else(|e| panic!("{seed} line {name}: {e}"));
            report(name, &r);
            assert_close(name, &r.x, &want);
            assert!(r.residual < 1e-12);
            let r = track(&sq_line, &x0, &opts).unwrap_or_else(|e| panic!("{seed} sq {name}: {e}"));
            report(name, &r);
            assert_close(name, &r.x, &want);
            assert!(r.residual < 1e-12, "full residual {:e}", r.residual);
            let r = track(&sq_param, &x0, &opts).unwrap_or_else(|e| panic!("{seed} sqp {name}: {e}"));
            assert_close(name, &r.x, &want);
            assert!(r.residual < 1e-12);
        }

        let mut tracker = Tracker::new(&line, TrackerOptions::paper(0.05));
        tracker.start(&x0).unwrap();
        let mut max_mid_residual = 0.0f64;
        while tracker.step() == TrackerStatus::Tracking {
            let s = tracker.state();
            max_mid_residual = max_mid_residual.max(line.validation_residual(&s.x, s.t));
        }
        assert_eq!(tracker.status(), TrackerStatus::Success);
        println!("seed {seed}: straight-line max residual on the way {max_mid_residual:e}");
        assert!(max_mid_residual > 1e-6, "the straight line of a 3x2 system is inconsistent");
    }
}

/// Unrelated start and target: the consistent parameter path still reaches the root; a
/// squared-up straight line may end at a spurious root of the 2 x 2 combination, and then the
/// full residual reports it.
#[test]
fn squared_up_spurious_end_points_are_flagged_by_full_residual() {
    let (mut exact, mut flagged) = (0, 0);
    for seed in 200u64..220 {
        let mut rng = rng(seed);
        let p0 = over_params(&mut rng);
        let p1 = over_params(&mut rng);
        let x0 = Vector2::new(p0[15], p0[16]);
        let want = Vector2::new(p1[15], p1[16]);
        let param = ParameterHomotopy::<Over3x2, f64, O_NP>::new(p0, p1);
        let r = track(&param, &x0, &TrackerOptions::default()).unwrap();
        assert_close("parameter", &r.x, &want);
        let sq_line = SquaredUp::new(StraightLine::<Over3x2, f64, O_NP>::new(p0, p1), seed);
        if let Ok(r) = track(&sq_line, &x0, &TrackerOptions::default()) {
            if (r.x - want).amax() <= 1e-10 {
                assert!(r.residual < 1e-12);
                exact += 1;
            } else {
                assert!(r.residual > 1e-6, "seed {seed}: wrong end point with small residual");
                flagged += 1;
            }
        }
    }
    println!("squared-up straight line: {exact} exact, {flagged} spurious and flagged");
    assert!(exact > 0);
}

#[test]
fn squared_up_matrix_has_orthonormal_rows_and_is_seeded() {
    let line = StraightLine::<Over3x2, f64, O_NP>::new(SVector::zeros(), SVector::zeros());
    let a = SquaredUp::<f64, _, 2, 3>::new(line, 42).a;
    let b = SquaredUp::<f64, _, 2, 3>::new(line, 42).a;
    assert_eq!(a, b);
    assert!((a * a.transpose() - nalgebra::Matrix2::identity()).amax() < 1e-14);
}

#[test]
fn plain_newton_and_gauss_newton() {
    let mut rng = rng(300);
    let p = quad4_params(&mut rng);
    let sol = quad4_solution(&p);
    let sys = FixedSystem::<Quad4, f64, Q4_NP>::new(p);
    let x0 = sol + SVector::<f64, 4>::repeat(0.05);
    let r = newton(&sys, &x0, 1.0, &NewtonOptions::default()).unwrap();
    println!("newton: {} iterations, accuracy {:e}", r.iterations, r.accuracy);
    assert!(r.converged);
    assert_close("newton", &r.x, &sol);
    // One iteration from a perturbed start is not enough.
    let r = newton(&sys, &x0, 1.0, &NewtonOptions { max_iterations: 1, ..Default::default() }).unwrap();
    assert!(!r.converged);
    assert_eq!(r.iterations, 1);

    let q = over_params(&mut rng);
    let sys = FixedSystem::<Over3x2, f64, O_NP>::new(q);
    let want = Vector2::new(q[15], q[16]);
    let r = newton(&sys, &(want + Vector2::new(0.03, -0.02)), 1.0, &NewtonOptions::default()).unwrap();
    assert!(r.converged);
    assert_close("gauss-newton", &r.x, &want);
    assert!(r.residual < 1e-12);
    // The same through the Problem-level entry point.
    let x0 = want + Vector2::new(0.03, -0.02);
    let r2 = solve_newton::<Over3x2, f64, 2, 3, O_NP>(&x0, &q, &NewtonOptions::default()).unwrap();
    assert_eq!(r2.x, r.x);
}
