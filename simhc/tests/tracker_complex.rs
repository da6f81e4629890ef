//! Complex tracking: all roots of a degree-6 polynomial from the total-degree start system
//! `x^6 - 1` with the gamma trick, and the complex detour around a real fold.

mod tracker_support;

use nalgebra::{SMatrix, SVector, Vector1};
use simhc::homotopy::{random_gamma, real_if_close, to_complex, GammaTrick, Homotopy, ParameterHomotopy, StraightLine};
use simhc::scalar::C;
use simhc::tracker::{track, TrackError, TrackerOptions};
use tracker_support::*;

/// Seeded random monic degree-6 polynomial `x^6 + c5 x^5 + ... + c0` with complex coefficients.
fn random_monic(seed: u64) -> SVector<C, 7> {
    let mut rng = rng(seed);
    let mut c = SVector::<C, 7>::zeros();
    for k in 0..6 {
        c[k] = C::new(uniform(&mut rng, -2.0, 2.0), uniform(&mut rng, -2.0, 2.0));
    }
    c[6] = C::new(1.0, 0.0);
    c
}

/// Roots of the monic polynomial as eigenvalues of its companion matrix (complex Schur form):
/// an independent reference for the tracked roots.
fn companion_roots(c: &SVector<C, 7>) -> Vec<C> {
    let mut m = SMatrix::<C, 6, 6>::zeros();
    for i in 1..6 {
        m[(i, i - 1)] = C::new(1.0, 0.0);
    }
    for i in 0..6 {
        m[(i, 5)] = -c[i];
    }
    let ev = m.schur().eigenvalues().expect("Schur eigenvalues of the companion matrix");
    ev.iter().copied().collect()
}

fn start_roots() -> Vec<C> {
    (0..6).map(|k| C::from_polar(1.0, std::f64::consts::TAU * k as f64 / 6.0)).collect()
}

/// Tracks the six start roots along `h` and checks the end points against the reference roots.
fn check_all_roots<H: Homotopy<C, 1, 1>>(name: &str, h: &H, c: &SVector<C, 7>, opts: &TrackerOptions) {
    let reference = companion_roots(c);
    let mut found = Vec::new();
    for (i, s) in start_roots().into_iter().enumerate() {
        let r = track(h, &Vector1::new(s), opts).unwrap_or_else(|e| panic!("{name} path {i}: {e}"));
        println!(
            "{name} path {i}: {:.6} accepted {} rejected {} newton {} residual {:e}",
            r.x[0], r.stats.accepted_steps, r.stats.rejected_steps, r.stats.newton_iterations, r.residual
        );
        // |p(x)| small, relative to the size of the terms.
        let scale: f64 = (0..7).map(|k| c[k].norm() * r.x[0].norm().powi(k as i32)).sum();
        assert!(r.residual <= 1e-12 * scale, "{name} path {i}: residual {:e}", r.residual);
        found.push(r.x[0]);
    }
    // Distinct end points ...
    for i in 0..6 {
        for j in 0..i {
            assert!((found[i] - found[j]).norm() > 1e-6, "{name}: paths {i} and {j} ended together");
        }
    }
    // ... matching the companion eigenvalues one to one.
    for (i, z) in found.iter().enumerate() {
        let d = reference.iter().map(|e| (e - z).norm()).fold(f64::INFINITY, f64::min);
        assert!(d < 1e-9, "{name} path {i}: {z} is {d:e} from every reference root");
    }
    for e in &reference {
        let d = found.iter().map(|z| (e - z).norm()).fold(f64::INFINITY, f64::min);
        assert!(d < 1e-9, "{name}: reference root {e} not found");
    }
}

#[test]
fn all_six_roots_by_gamma_trick_from_total_degree_start() {
    for seed in [1u64, 2, 3, 4] {
        let c = random_monic(seed);
        let gamma = random_gamma(1000 + seed);
        println!("gamma = {gamma}");
        // Same family: x^6 - 1 is Poly6 with c = (-1, 0, 0, 0, 0, 0, 1).
        let mut start = SVector::<C, 7>::zeros();
        start[0] = C::new(-1.0, 0.0);
        start[6] = C::new(1.0, 0.0);
        let same_family = StraightLine::<Poly6, C, 7>::with_gamma(start, c, gamma);
        // Two systems: the start system as its own problem type.
        let two_systems = GammaTrick::<Start6, Poly6, C, 0, 7>::between(gamma, SVector::zeros(), c);
        for (name, opts) in [
            ("adaptive", TrackerOptions::default()),
            ("paper dt=0.02", TrackerOptions { final_newton_iterations: 3, ..TrackerOptions::paper(0.02) }),
        ] {
            check_all_roots(&format!("seed {seed} straight line {name}"), &same_family, &c, &opts);
            check_all_roots(&format!("seed {seed} gamma trick {name}"), &two_systems, &c, &opts);
        }
    }
}

#[test]
fn complex_detour_passes_a_real_fold() {
    // x^3 - 3x - a: the left real root -sqrt(3) at a = 0 meets the middle one at the fold
    // a = 2 (x = -1); beyond it both are complex. Real tracking to a = 3 must fail there.
    let (a0, a1) = (SVector::<f64, 1>::new(0.0), SVector::<f64, 1>::new(3.0));
    let x0 = Vector1::new(-(3.0f64.sqrt()));
    let real = ParameterHomotopy::<FoldCubic, f64, 1>::new(a0, a1);
    match track(&real, &x0, &TrackerOptions::default()) {
        Err(TrackError::StepSizeTooSmall { t }) => {
            assert!((t - 2.0 / 3.0).abs() < 1e-3, "stopped at t = {t}, the fold is at 2/3")
        }
        other => panic!("real tracking through the fold: {other:?}"),
    }
    // The complex detour goes around the fold and ends at a root of x^3 - 3x - 3.
    for seed in [5u64, 6, 7] {
        println!("detour seed = {seed}");
        let detour = ParameterHomotopy::<FoldCubic, C, 1>::with_complex_detour(&a0, &a1, 0.5, seed);
        let r = track(&detour, &to_complex(&x0), &TrackerOptions::default()).unwrap();
        let z = r.x[0];
        println!("ended at {z}, residual {:e}", r.residual);
        assert!((z * z * z - 3.0 * z - 3.0).norm() < 1e-12);
        // The only real root of x^3 - 3x - 3 is the continuation of the right branch; the left
        // branch has no real continuation, so the end point is one of the complex pair.
        assert!(z.im.abs() > 0.1);
    }
}

#[test]
fn complex_detour_returns_real_roots_on_fold_free_paths() {
    // Right branch of x^3 - 3x - a, from sqrt(3) at a = 0 to the real root at a = 3.
    let (a0, a1) = (SVector::<f64, 1>::new(0.0), SVector::<f64, 1>::new(3.0));
    let x0 = Vector1::new(3.0f64.sqrt());
    let real = track(&ParameterHomotopy::<FoldCubic, f64, 1>::new(a0, a1), &x0, &TrackerOptions::default()).unwrap();
    let detour = ParameterHomotopy::<FoldCubic, C, 1>::with_complex_detour(&a0, &a1, 0.5, 9);
    let r = track(&detour, &to_complex(&x0), &TrackerOptions::default()).unwrap();
    let back = real_if_close(&r.x, 1e-10).expect("real end point");
    assert!((back - real.x).amax() < 1e-10);

    // A 4-unknown system: the detour ends at the real solution known by construction.
    for seed in [400u64, 401, 402] {
        let mut rng = rng(seed);
        let p0 = quad4_params(&mut rng);
        let p1 = quad4_params(&mut rng);
        let h = ParameterHomotopy::<Quad4, C, Q4_NP>::with_complex_detour(&p0, &p1, 0.3, seed);
        let r = track(&h, &to_complex(&quad4_solution(&p0)), &TrackerOptions::default()).unwrap();
        let x = real_if_close(&r.x, 1e-10).expect("real end point");
        assert!((x - quad4_solution(&p1)).amax() < 1e-10, "seed {seed}");
        println!("seed {seed}: accepted {} rejected {}", r.stats.accepted_steps, r.stats.rejected_steps);
    }
}
