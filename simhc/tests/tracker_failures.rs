//! Every failure code from a constructed case, and no panic on garbage input.

mod tracker_support;

use nalgebra::{SMatrix, SVector, Vector1, Vector2, Vector3};
use simhc::homotopy::{FixedSystem, Homotopy, ParameterHomotopy, SquaredUp, StraightLine};
use simhc::tracker::{
    newton, track, AdaptiveStep, DragStep, NewtonOptions, StepControl, TrackError, Tracker, TrackerOptions, TrackerStatus,
};
use tracker_support::*;

/// `H(x, t) = (1 - 2t)(x - 1 - t)`: the solution `x = 1 + t` is regular except at `t = 1/2`, where
/// `J_x = 1 - 2t` vanishes for every `x` (a path through a singular point).
struct SingularMidway;

impl Homotopy<f64, 1, 1> for SingularMidway {
    fn evaluate(&self, x: &SVector<f64, 1>, t: f64, h: &mut SVector<f64, 1>, jx: &mut SMatrix<f64, 1, 1>) {
        h[0] = (1.0 - 2.0 * t) * (x[0] - 1.0 - t);
        jx[(0, 0)] = 1.0 - 2.0 * t;
    }
    fn dt(&self, x: &SVector<f64, 1>, t: f64, dh: &mut SVector<f64, 1>) {
        dh[0] = -2.0 * (x[0] - 1.0 - t) - (1.0 - 2.0 * t);
    }
}

/// `H(x, t) = x - 1 / (t - 1/2)`: the homotopy itself blows up at `t = 1/2`.
struct PoleMidway;

impl Homotopy<f64, 1, 1> for PoleMidway {
    fn evaluate(&self, x: &SVector<f64, 1>, t: f64, h: &mut SVector<f64, 1>, jx: &mut SMatrix<f64, 1, 1>) {
        h[0] = x[0] - 1.0 / (t - 0.5);
        jx[(0, 0)] = 1.0;
    }
    fn dt(&self, _x: &SVector<f64, 1>, t: f64, dh: &mut SVector<f64, 1>) {
        dh[0] = 1.0 / ((t - 0.5) * (t - 0.5));
    }
}

#[test]
fn step_size_too_small_at_a_real_fold() {
    // x^3 - 3x - a from the left root at a = 0 to a = 3: the real path turns back at a = 2.
    let h = ParameterHomotopy::<FoldCubic, f64, 1>::new(Vector1::new(0.0), Vector1::new(3.0));
    let e = track(&h, &Vector1::new(-(3.0f64.sqrt())), &TrackerOptions::default()).unwrap_err();
    println!("{e}");
    assert!(matches!(e, TrackError::StepSizeTooSmall { .. }), "{e:?}");
    assert!((e.t() - 2.0 / 3.0).abs() < 1e-3);
    // Invalid step settings are reported the same way, not by a panic or an endless loop.
    for step in [
        StepControl::Fixed { dt: 0.0 },
        StepControl::Fixed { dt: f64::NAN },
        StepControl::Adaptive(AdaptiveStep { initial: -1.0, ..Default::default() }),
    ] {
        let opts = TrackerOptions { step, ..Default::default() };
        let e = track(&h, &Vector1::new(-(3.0f64.sqrt())), &opts).unwrap_err();
        assert_eq!(e, TrackError::StepSizeTooSmall { t: 0.0 });
    }
}

#[test]
fn singular_jacobian_at_start_and_on_the_path() {
    // Double root x = 1 of x^2 - 2x + 1 at t = 0.
    let p = Vector3::new(1.0, -2.0, 1.0);
    let h = StraightLine::<Quadratic, f64, 3>::new(p, Vector3::new(1.0, 0.0, -4.0));
    let e = track(&h, &Vector1::new(1.0), &TrackerOptions::default()).unwrap_err();
    assert_eq!(e, TrackError::SingularJacobian { t: 0.0 });

    // The fixed schedule t = 0.25, 0.5, ... evaluates J_x at t = 1/2 exactly.
    let e = track(&SingularMidway, &Vector1::new(1.0), &TrackerOptions::paper(0.25)).unwrap_err();
    assert_eq!(e, TrackError::SingularJacobian { t: 0.25 });
    // The adaptive tracker also meets t = 1/2 exactly (steps 0.1, then 0.4) and shrinks its
    // steps on the singular Jacobian; with a large minimum step it gives up, naming the cause.
    let opts = TrackerOptions::adaptive(AdaptiveStep { min: 0.3, ..Default::default() });
    match track(&SingularMidway, &Vector1::new(1.0), &opts) {
        Err(TrackError::SingularJacobian { t }) => assert!(t < 0.5),
        Ok(r) => {
            // Stepping over t = 1/2 is legitimate too; the end point must then be right.
            assert!((r.x[0] - 2.0).abs() < 1e-10);
        }
        Err(e) => panic!("{e:?}"),
    }

    // Plain Newton at a singular point.
    let sys = FixedSystem::<Quadratic, f64, 3>::new(p);
    let e = newton(&sys, &Vector1::new(1.0), 1.0, &NewtonOptions::default()).unwrap_err();
    assert_eq!(e, TrackError::SingularJacobian { t: 1.0 });
}

#[test]
fn diverged_to_infinity_when_the_leading_coefficient_vanishes() {
    // (1-t) x^2 + t x - 1: at t = 1 the system is linear and one root has gone to infinity,
    // x(t) ~ -1 / (1 - t) on the path from x0 = -1.
    let h = ParameterHomotopy::<Quadratic, f64, 3>::new(Vector3::new(1.0, 0.0, -1.0), Vector3::new(0.0, 1.0, -1.0));
    let e = track(&h, &Vector1::new(-1.0), &TrackerOptions::default()).unwrap_err();
    println!("{e}");
    assert!(matches!(e, TrackError::DivergedToInfinity { .. }), "{e:?}");
    assert!(e.t() > 0.999);
    // The other root stays finite: x(t) -> 1.
    let r = track(&h, &Vector1::new(1.0), &TrackerOptions::default()).unwrap();
    assert!((r.x[0] - 1.0).abs() < 1e-10);
    // A start point beyond max_norm.
    let e = track(&h, &Vector1::new(1e9), &TrackerOptions::default()).unwrap_err();
    assert_eq!(e, TrackError::DivergedToInfinity { t: 0.0 });
}

#[test]
fn max_steps() {
    let mut rng = rng(500);
    let p0 = quad4_params(&mut rng);
    let p1 = quad4_params(&mut rng);
    let h = ParameterHomotopy::<Quad4, f64, Q4_NP>::new(p0, p1);
    let x0 = quad4_solution(&p0);
    let opts = TrackerOptions { max_steps: 3, ..TrackerOptions::paper(0.05) };
    let e = track(&h, &x0, &opts).unwrap_err();
    assert!(matches!(e, TrackError::MaxSteps { t } if (t - 0.15).abs() < 1e-12), "{e:?}");
    let opts = TrackerOptions { max_steps: 1, ..Default::default() };
    let e = track(&h, &x0, &opts).unwrap_err();
    assert!(matches!(e, TrackError::MaxSteps { .. }), "{e:?}");
}

#[test]
fn corrector_did_not_converge() {
    // x^2 - 1 -> x^2 + 1 in real arithmetic: the real path ends at the fold t = 1/2; the paper's
    // fixed schedule keeps accepting steps, and at t = 1 Newton on x^2 + 1 has no real root to
    // converge to.
    let h = StraightLine::<Quadratic, f64, 3>::new(Vector3::new(1.0, 0.0, -1.0), Vector3::new(1.0, 0.0, 1.0));
    let opts = TrackerOptions { require_final_convergence: true, final_newton_iterations: 3, ..TrackerOptions::paper(0.05) };
    let e = track(&h, &Vector1::new(1.0), &opts).unwrap_err();
    assert_eq!(e, TrackError::CorrectorDidNotConverge { t: 1.0 });
    // Without require_final_convergence (the paper) the point comes back with its accuracy.
    let r = track(&h, &Vector1::new(1.0), &TrackerOptions::paper(0.05)).unwrap();
    assert!(r.accuracy > 1e-6 && r.residual > 0.5, "{r:?}");
    // Plain Newton reports non-convergence as a flag.
    let sys = FixedSystem::<Quadratic, f64, 3>::new(Vector3::new(1.0, 0.0, 1.0));
    let r = newton(&sys, &Vector1::new(0.3), 1.0, &NewtonOptions::default()).unwrap();
    assert!(!r.converged);
}

#[test]
fn non_finite_input_and_evaluations() {
    let h = ParameterHomotopy::<Cubic, f64, 1>::new(Vector1::new(0.5), Vector1::new(2.0));
    for x0 in [f64::NAN, f64::INFINITY] {
        let e = track(&h, &Vector1::new(x0), &TrackerOptions::default()).unwrap_err();
        assert_eq!(e, TrackError::NonFinite { t: 0.0 });
        let sys = FixedSystem::<Cubic, f64, 1>::new(Vector1::new(0.5));
        let e = newton(&sys, &Vector1::new(x0), 1.0, &NewtonOptions::default()).unwrap_err();
        assert!(matches!(e, TrackError::NonFinite { .. }));
    }
    // NaN in the start parameters: the first Jacobian is NaN.
    let bad = ParameterHomotopy::<Cubic, f64, 1>::new(Vector1::new(f64::NAN), Vector1::new(2.0));
    let e = track(&bad, &Vector1::new(0.5), &TrackerOptions::default()).unwrap_err();
    assert_eq!(e, TrackError::NonFinite { t: 0.0 });
    // NaN in the target parameters: every step fails, the adaptive tracker shrinks and gives up.
    let bad = ParameterHomotopy::<Cubic, f64, 1>::new(Vector1::new(0.5), Vector1::new(f64::NAN));
    let e = track(&bad, &Vector1::new(0.5), &TrackerOptions::default()).unwrap_err();
    assert_eq!(e, TrackError::NonFinite { t: 0.0 });
    let e = track(&bad, &Vector1::new(0.5), &TrackerOptions::paper(0.05)).unwrap_err();
    assert_eq!(e, TrackError::NonFinite { t: 0.0 });
    // A pole of the homotopy on the fixed schedule.
    let e = track(&PoleMidway, &Vector1::new(-2.0), &TrackerOptions::paper(0.25)).unwrap_err();
    assert_eq!(e, TrackError::NonFinite { t: 0.25 });
}

#[test]
fn tracker_status_after_failure_and_reuse() {
    let h = ParameterHomotopy::<FoldCubic, f64, 1>::new(Vector1::new(0.0), Vector1::new(3.0));
    let mut tracker = Tracker::new(&h, TrackerOptions::default());
    let e = tracker.track(&Vector1::new(-(3.0f64.sqrt()))).unwrap_err();
    assert_eq!(tracker.status(), TrackerStatus::Failed(e));
    // Further steps keep the status; the state shows where it stopped.
    assert_eq!(tracker.step(), TrackerStatus::Failed(e));
    assert!((tracker.state().x[0] + 1.0).abs() < 0.05);
    // The same tracker tracks the right branch fine afterwards.
    let r = tracker.track(&Vector1::new(3.0f64.sqrt())).unwrap();
    assert!((r.x[0].powi(3) - 3.0 * r.x[0] - 3.0).abs() < 1e-12);
    assert_eq!(Tracker::new(&h, TrackerOptions::default()).status(), TrackerStatus::Idle);
}

/// Garbage in (NaN, infinities, huge and tiny values, random parameters): typed errors or
/// results, never a panic.
#[test]
fn no_panic_on_garbage() {
    let mut rng = rng(600);
    let specials = [f64::NAN, f64::INFINITY, -f64::INFINITY, 1e300, -1e300, 1e-300, 0.0];
    // Per instance, the share of special values: none, a few, many.
    let pick = |rng: &mut rand_chacha::ChaCha8Rng, share: f64| {
        if uniform(rng, 0.0, 1.0) < share {
            specials[(uniform(rng, 0.0, specials.len() as f64) as usize).min(specials.len() - 1)]
        } else {
            uniform(rng, -3.0, 3.0)
        }
    };
    let options = [TrackerOptions::default(), TrackerOptions::paper(0.05), TrackerOptions { max_steps: 50, ..Default::default() }];
    let (mut ok, mut err) = (0, 0);
    for i in 0..300 {
        let share = [0.0, 0.02, 0.3][i % 3];
        let p0 = SVector::<f64, O_NP>::from_fn(|_, _| pick(&mut rng, share));
        let p1 = SVector::<f64, O_NP>::from_fn(|_, _| pick(&mut rng, share));
        let x0 = Vector2::new(pick(&mut rng, share), pick(&mut rng, share));
        let line = StraightLine::<Over3x2, f64, O_NP>::new(p0, p1);
        let param = ParameterHomotopy::<Over3x2, f64, O_NP>::new(p0, p1);
        for opts in &options {
            for res in [track(&line, &x0, opts), track(&param, &x0, opts), track(&SquaredUp::new(line, 1), &x0, opts)] {
                match res {
                    Ok(r) => {
                        assert_eq!(r.t, 1.0);
                        ok += 1
                    }
                    Err(_) => err += 1,
                }
            }
        }
        let _ = newton(&FixedSystem::<Over3x2, f64, O_NP>::new(p1), &x0, 1.0, &NewtonOptions::default());
        let q = Vector1::new(pick(&mut rng, share));
        let _ = track(
            &ParameterHomotopy::<Cubic, f64, 1>::new(q, Vector1::new(pick(&mut rng, share))),
            &Vector1::new(pick(&mut rng, share)),
            &TrackerOptions::default(),
        );
    }
    println!("garbage: {ok} ok, {err} errors");
    assert!(ok > 0 && err > 0);
}

#[test]
fn drag_steps_jump_a_hysteresis_fold_like_the_paper() {
    // x^3 - 3x - a for a from -3 to 3: the only real root at a = -3 is on the left branch, which
    // folds at a = 2; beyond it the only real root is on the right branch (hysteresis).
    let a0 = Vector1::new(-3.0);
    let x0 = newton(&FixedSystem::<FoldCubic, f64, 1>::new(a0), &Vector1::new(-2.0), 0.0, &NewtonOptions::default()).unwrap().x;
    let h = ParameterHomotopy::<FoldCubic, f64, 1>::new(a0, Vector1::new(3.0));
    // The faithful tracker stops at the fold (a = 2 is t = 5/6) ...
    let e = track(&h, &x0, &TrackerOptions::default()).unwrap_err();
    assert!(matches!(e, TrackError::StepSizeTooSmall { t } if (t - 5.0 / 6.0).abs() < 1e-3), "{e:?}");
    // ... a drag step jumps to the right branch, as the paper's fixed schedule does.
    let drag = AdaptiveStep { drag: Some(DragStep::default()), ..Default::default() };
    let r = track(&h, &x0, &TrackerOptions::adaptive(drag)).unwrap();
    println!("{:?}", r.stats);
    assert!(r.stats.drag_steps >= 1);
    assert!((r.x[0].powi(3) - 3.0 * r.x[0] - 3.0).abs() < 1e-12 && r.x[0] > 2.0);
    let paper = track(&h, &x0, &TrackerOptions::paper(0.05)).unwrap();
    assert!((paper.x - r.x).amax() < 1e-10);
}
