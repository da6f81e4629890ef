//! Monodromy and all-roots solving on small square systems with known solution counts:
//! two generic plane conics (Bezout: 4), a conic and a line (2), and a sign-symmetric system
//! (4 solutions, 2 modulo `(x, y) -> (-x, -y)`) with a parameter-free equation.

use nalgebra::{SMatrix, SVector, Vector2};
use simhc::all_roots::{move_start_system, solve_all, suspicious_paths, AllRootsOptions, StartSystem};
use simhc::monodromy::{monodromy_solve, relative_distance, seed_pair, MonodromyOptions, SignFlip, SolutionSet, StopReason};
use simhc::scalar::C;
use simhc::tracker::TrackError;
use simhc::{ParamDerivative, Problem, ProblemInfo, Ring, Scalar};

/// The six monomials `[x^2, xy, y^2, x, y, 1]` and their derivatives.
fn conic_monomials<S: Ring>(x: &SVector<S, 2>) -> [S; 6] {
    let (a, b) = (x[0], x[1]);
    [a * a, a * b, b * b, a, b, S::constant(1.0)]
}

fn conic_gradients<S: Ring>(x: &SVector<S, 2>) -> [[S; 2]; 6] {
    let (a, b) = (x[0], x[1]);
    let (z, one, two) = (S::constant(0.0), S::constant(1.0), S::constant(2.0));
    [[two * a, z], [b, a], [z, two * b], [one, z], [z, one], [z, z]]
}

/// Two general conics: `f_k = sum_j p[6k + j] m_j(x, y)`; 4 solutions.
struct TwoConics;

impl ProblemInfo for TwoConics {
    const NAME: &'static str = "two_conics";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &[];
}

impl Problem<2, 2, 12> for TwoConics {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 12>, f: &mut SVector<S, 2>) {
        let m = conic_monomials(x);
        for k in 0..2 {
            f[k] = (0..6).fold(S::constant(0.0), |acc, j| acc + p[6 * k + j] * m[j]);
        }
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 12>, j: &mut SMatrix<S, 2, 2>) {
        let g = conic_gradients(x);
        for k in 0..2 {
            for c in 0..2 {
                j[(k, c)] = (0..6).fold(S::constant(0.0), |acc, m| acc + p[6 * k + m] * g[m][c]);
            }
        }
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 12>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<2, 2, 12> for TwoConics {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 2>, _p: &SVector<S, 12>, jp: &mut SMatrix<S, 2, 12>) {
        let m = conic_monomials(x);
        jp.fill(S::constant(0.0));
        for k in 0..2 {
            for j in 0..6 {
                jp[(k, 6 * k + j)] = m[j];
            }
        }
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 2>, _p: &SVector<S, 12>, dp: &SVector<S, 12>, out: &mut SVector<S, 2>) {
        let m = conic_monomials(x);
        for k in 0..2 {
            out[k] = (0..6).fold(S::constant(0.0), |acc, j| acc + dp[6 * k + j] * m[j]);
        }
    }
}

/// A circle `(x - a)^2 + (y - b)^2 - r` and a line `c x + d y + e`: 2 solutions.
struct CircleLine;

impl ProblemInfo for CircleLine {
    const NAME: &'static str = "circle_line";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &["a", "b", "r", "c", "d", "e"];
}

impl Problem<2, 2, 6> for CircleLine {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, f: &mut SVector<S, 2>) {
        let (u, v) = (x[0] - p[0], x[1] - p[1]);
        f[0] = u * u + v * v - p[2];
        f[1] = p[3] * x[0] + p[4] * x[1] + p[5];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, j: &mut SMatrix<S, 2, 2>) {
        let two = S::constant(2.0);
        j[(0, 0)] = two * (x[0] - p[0]);
        j[(0, 1)] = two * (x[1] - p[1]);
        j[(1, 0)] = p[3];
        j[(1, 1)] = p[4];
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<2, 2, 6> for CircleLine {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, 6>, jp: &mut SMatrix<S, 2, 6>) {
        let two = S::constant(2.0);
        jp.fill(S::constant(0.0));
        jp[(0, 0)] = -two * (x[0] - p[0]);
        jp[(0, 1)] = -two * (x[1] - p[1]);
        jp[(0, 2)] = -S::constant(1.0);
        jp[(1, 3)] = x[0];
        jp[(1, 4)] = x[1];
        jp[(1, 5)] = S::constant(1.0);
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, 6>, dp: &SVector<S, 6>, out: &mut SVector<S, 2>) {
        let mut jp = SMatrix::<S, 2, 6>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        *out = jp * dp;
    }
}

/// `x^2 + y^2 - 1` (no parameters) and `a x^2 + b x y + c y^2 + d`: both even, so solutions
/// come as `+-(x, y)`; 4 solutions, 2 modulo the sign.
struct EvenPair;

impl ProblemInfo for EvenPair {
    const NAME: &'static str = "even_pair";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &["a", "b", "c", "d"];
}

impl Problem<2, 2, 4> for EvenPair {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 4>, f: &mut SVector<S, 2>) {
        let (u, v) = (x[0], x[1]);
        f[0] = u * u + v * v - S::constant(1.0);
        f[1] = p[0] * u * u + p[1] * u * v + p[2] * v * v + p[3];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 4>, j: &mut SMatrix<S, 2, 2>) {
        let (u, v) = (x[0], x[1]);
        let two = S::constant(2.0);
        j[(0, 0)] = two * u;
        j[(0, 1)] = two * v;
        j[(1, 0)] = two * p[0] * u + p[1] * v;
        j[(1, 1)] = p[1] * u + two * p[2] * v;
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 4>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<2, 2, 4> for EvenPair {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 2>, _p: &SVector<S, 4>, jp: &mut SMatrix<S, 2, 4>) {
        let (u, v) = (x[0], x[1]);
        jp.fill(S::constant(0.0));
        jp[(1, 0)] = u * u;
        jp[(1, 1)] = u * v;
        jp[(1, 2)] = v * v;
        jp[(1, 3)] = S::constant(1.0);
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, 4>, dp: &SVector<S, 4>, out: &mut SVector<S, 2>) {
        let mut jp = SMatrix::<S, 2, 4>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        *out = jp * dp;
    }
}

fn max_residual<P: Problem<2, 2, NP>, const NP: usize>(xs: &[SVector<C, 2>], p: &SVector<C, NP>) -> f64 {
    let mut f = SVector::<C, 2>::zeros();
    xs.iter()
        .map(|x| {
            P::residual(x, p, &mut f);
            f.iter().map(|z| z.norm()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn pairwise_distinct(xs: &[SVector<C, 2>], g: Option<&SignFlip>) -> bool {
    for i in 0..xs.len() {
        for j in 0..i {
            let mut d = relative_distance(&xs[i], &xs[j]);
            if let Some(g) = g {
                d = d.min(relative_distance(&g.apply(&xs[i]), &xs[j]));
            }
            if d < 1e-6 {
                return false;
            }
        }
    }
    true
}

#[test]
fn two_generic_conics_have_four_solutions() {
    for seed in [1, 2, 3] {
        let r = monodromy_solve::<TwoConics, 2, 12>(&MonodromyOptions { seed, ..Default::default() }).expect("seed pair");
        println!("seed {seed}: {} solutions, {} loops, history {:?}", r.solutions.len(), r.loops, r.history);
        assert_eq!(r.solutions.len(), 4, "seed {seed}");
        assert_eq!(r.stop, StopReason::Stalled);
        assert!(r.loops >= 5 && r.history.len() == r.loops);
        assert!(r.max_residual < 1e-10, "residual {:e}", r.max_residual);
        assert!(max_residual::<TwoConics, 12>(&r.solutions, &r.params) < 1e-10);
        assert!(pairwise_distinct(&r.solutions, None));
    }
}

#[test]
fn circle_and_line_have_two_solutions() {
    let r = monodromy_solve::<CircleLine, 2, 6>(&MonodromyOptions { seed: 7, ..Default::default() }).unwrap();
    assert_eq!(r.solutions.len(), 2);
    assert!(max_residual::<CircleLine, 6>(&r.solutions, &r.params) < 1e-10);
}

#[test]
fn target_count_stops_early_and_parallel_matches_sequential() {
    let opts = MonodromyOptions { seed: 5, target_count: Some(4), ..Default::default() };
    let r = monodromy_solve::<TwoConics, 2, 12>(&opts).unwrap();
    assert_eq!((r.solutions.len(), r.stop), (4, StopReason::TargetReached));
    let par = monodromy_solve::<TwoConics, 2, 12>(&MonodromyOptions { parallel: true, ..opts }).unwrap();
    assert_eq!(r.solutions, par.solutions, "rayon must not change the result");
}

#[test]
fn sign_symmetry_stores_one_representative_per_pair() {
    let g = SignFlip::new(vec![0, 1]);
    // The seed pair satisfies the parameter-free circle too.
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
    let (x, p) = seed_pair::<EvenPair, 2, 4>(&mut rng, 1.0).unwrap();
    let mut f = SVector::<C, 2>::zeros();
    EvenPair::residual(&x, &p, &mut f);
    assert!(f.iter().all(|z| z.norm() < 1e-12), "{f:?}");

    let with = monodromy_solve::<EvenPair, 2, 4>(&MonodromyOptions { seed: 3, symmetry: Some(g.clone()), ..Default::default() }).unwrap();
    let without = monodromy_solve::<EvenPair, 2, 4>(&MonodromyOptions { seed: 3, ..Default::default() }).unwrap();
    println!("with symmetry {}, without {}", with.solutions.len(), without.solutions.len());
    assert_eq!(with.solutions.len(), 2);
    assert_eq!(without.solutions.len(), 4);
    assert!(pairwise_distinct(&with.solutions, Some(&g)));
    // Representatives are canonical (first coordinate with non-negative real part).
    assert!(with.solutions.iter().all(|x| g.canonical(x) == *x));
}

#[test]
fn solution_set_dedups_modulo_the_symmetry() {
    let g = SignFlip::new(vec![0]);
    let mut set = SolutionSet::<2>::new(Some(g), 1e-8);
    let x = SVector::<C, 2>::new(C::new(-1.0, 0.5), C::new(2.0, 0.0));
    assert!(set.insert(&x));
    let gx = SVector::<C, 2>::new(C::new(1.0, -0.5), C::new(2.0, 0.0));
    assert!(!set.insert(&gx), "g(x) is the same orbit");
    assert!(!set.insert(&(x + SVector::repeat(C::new(1e-10, 0.0)))));
    assert!(set.insert(&SVector::<C, 2>::new(C::new(1.0, 0.5), C::new(2.0, 0.0))));
    assert_eq!(set.len(), 2);
    // Stored canonically: Re x0 >= 0.
    assert!(set.solutions()[0][0].re > 0.0);
}

#[test]
fn all_roots_of_real_conics_from_a_monodromy_start() {
    let r = monodromy_solve::<TwoConics, 2, 12>(&MonodromyOptions { seed: 11, ..Default::default() }).unwrap();
    let start = StartSystem { params: r.params, solutions: r.solutions, symmetry: None };
    // Target: x^2 - 1 = 0 and y^2 - 4 = 0 mixed, f1 = (x^2 - 1) + (y^2 - 4), f2 = (x^2 - 1) - 2 (y^2 - 4):
    // four real solutions (+-1, +-2).
    let target = SVector::<f64, 12>::from_row_slice(&[
        1.0, 0.0, 1.0, 0.0, 0.0, -5.0, //
        1.0, 0.0, -2.0, 0.0, 0.0, 7.0,
    ]);
    for parallel in [false, true] {
        let res = solve_all::<TwoConics, 2, 12>(&start, &target, &AllRootsOptions { parallel, ..Default::default() });
        assert_eq!(res.failed, 0);
        assert_eq!(res.real.len(), 4, "{:?}", res.real);
        for (sx, sy) in [(1.0, 2.0), (1.0, -2.0), (-1.0, 2.0), (-1.0, -2.0)] {
            let (best, d) = res.closest_real(&Vector2::new(sx, sy)).unwrap();
            assert!(d < 1e-10, "({sx}, {sy}): {d:e}");
            assert!(best.residual < 1e-12);
        }
        assert!(res.real.windows(2).all(|w| w[0].residual <= w[1].residual), "sorted by residual");
        assert_eq!(res.duplicates, 0);
    }
    // A target with two real and two complex solutions: x^2 + y^2 = 4 and y = x^2 + 1 (complex
    // pair where x^2 < 0).
    let target = SVector::<f64, 12>::from_row_slice(&[
        1.0, 0.0, 1.0, 0.0, 0.0, -4.0, //
        1.0, 0.0, 0.0, 0.0, -1.0, 1.0,
    ]);
    let res = solve_all::<TwoConics, 2, 12>(&start, &target, &AllRootsOptions::default());
    assert_eq!(res.finite(), 4);
    assert_eq!(res.real.len(), 2, "{:?}", res.real);
    for s in &res.real {
        assert!((s.x[0] * s.x[0] + s.x[1] * s.x[1] - 4.0).abs() < 1e-12);
    }
}

#[test]
fn suspicious_paths_flags_failures_and_coinciding_end_points() {
    let a = SVector::<C, 2>::new(C::new(1.0, 0.0), C::new(2.0, 1.0));
    let b = SVector::<C, 2>::new(C::new(-1.0, 0.0), C::new(-2.0, -1.0)); // = g(a)
    let c = SVector::<C, 2>::new(C::new(3.0, 0.0), C::new(0.0, 1.0));
    let results: Vec<Result<SVector<C, 2>, TrackError>> = vec![Ok(a), Ok(c), Err(TrackError::MaxSteps { t: 0.5 }), Ok(b)];
    assert_eq!(suspicious_paths(&results, None, 1e-8), vec![2]);
    let g = SignFlip::new(vec![0, 1]);
    assert_eq!(suspicious_paths(&results, Some(&g), 1e-8), vec![0, 2, 3]);
}

#[test]
fn a_start_system_moves_to_new_generic_parameters() {
    let r = monodromy_solve::<TwoConics, 2, 12>(&MonodromyOptions { seed: 4, ..Default::default() }).unwrap();
    let start = StartSystem { params: r.params, solutions: r.solutions, symmetry: None };
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(8);
    let p = simhc::monodromy::random_complex_vector::<12>(&mut rng, 1.0);
    let (moved, failed) = move_start_system::<TwoConics, 2, 12>(&start, &p, &AllRootsOptions::default());
    assert_eq!((moved.solutions.len(), failed), (4, 0));
    assert_eq!(moved.params, p);
    assert!(moved.max_residual::<TwoConics>() < 1e-10);
}
