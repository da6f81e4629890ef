//! The Krawczyk certificate cannot lie, on systems whose roots are known exactly: a root
//! certifies and its box holds it; a box that misses the root, a point between two close roots
//! and a singular root do not certify; the typed errors. Random points are seeded; the seed is
//! printed.

use nalgebra::{SMatrix, SVector, Vector1, Vector2};
use num_rational::BigRational;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::certify::{certify, certify_box, certify_rows, choose_rows, CertifyError};
use simhc::{Problem, ProblemInfo, Ring};

/// Circle and horizontal line: `x² + y² - r2 = 0`, `y - c = 0`, `p = (r2, c)`. Roots
/// `(±sqrt(r2 - c²), c)`: two close roots when `r2 - c²` is tiny, one double root when it is 0.
struct CircleLine;

impl ProblemInfo for CircleLine {
    const NAME: &'static str = "circle_line";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &["r2", "c"];
}

impl Problem<2, 2, 2> for CircleLine {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 2>, f: &mut SVector<S, 2>) {
        f[0] = x[0] * x[0] + x[1] * x[1] - p[0];
        f[1] = x[1] - p[1];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, _p: &SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        j[(0, 0)] = x[0].scale_by(2.0);
        j[(0, 1)] = x[1].scale_by(2.0);
        j[(1, 0)] = S::constant(0.0);
        j[(1, 1)] = S::constant(1.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 2>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// The same two equations plus `x - y - d = 0`: three rows in two unknowns, consistent at
/// `(0.5, 0.75)` for `d = -0.25`.
struct CircleLineDiagonal;

impl ProblemInfo for CircleLineDiagonal {
    const NAME: &'static str = "circle_line_diagonal";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &["r2", "c", "d"];
}

impl Problem<2, 3, 3> for CircleLineDiagonal {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 3>, f: &mut SVector<S, 3>) {
        f[0] = x[0] * x[0] + x[1] * x[1] - p[0];
        f[1] = x[1] - p[1];
        f[2] = x[0] - x[1] - p[2];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, _p: &SVector<S, 3>, j: &mut SMatrix<S, 3, 2>) {
        j[(0, 0)] = x[0].scale_by(2.0);
        j[(0, 1)] = x[1].scale_by(2.0);
        j[(1, 0)] = S::constant(0.0);
        j[(1, 1)] = S::constant(1.0);
        j[(2, 0)] = S::constant(1.0);
        j[(2, 1)] = S::constant(-1.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 3>, f: &mut SVector<S, 3>, j: &mut SMatrix<S, 3, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// `x² - a = 0` in one unknown.
struct Square;

impl ProblemInfo for Square {
    const NAME: &'static str = "square";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
    const PARAM_NAMES: &'static [&'static str] = &["a"];
}

impl Problem<1, 1, 1> for Square {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
        f[0] = x[0] * x[0] - p[0];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        j[(0, 0)] = x[0].scale_by(2.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// Exact in binary: the root `(0.5, 0.75)` of `x² + y² = 0.8125`, `y = 0.75`.
const R2: f64 = 0.8125;
const C: f64 = 0.75;
const ROOT: [f64; 2] = [0.5, 0.75];

fn rng(seed: u64) -> ChaCha8Rng {
    println!("seed {seed}");
    ChaCha8Rng::seed_from_u64(seed)
}

#[test]
fn an_exact_root_certifies_and_its_enclosure_holds_it() {
    let root = Vector2::from(ROOT);
    let cert = certify::<CircleLine, 2, 2, 2>(&root, &Vector2::new(R2, C)).expect("a simple exact root certifies");
    assert!(cert.encloses(&root) && cert.box_contains(&root));
    assert_eq!(cert.center, root);
    assert_eq!(cert.rows, [0, 1]);
    assert!(cert.error_bound() < 1e-12, "bound {:e}", cert.error_bound());
    // The mirror root too.
    let mirror = Vector2::new(-0.5, 0.75);
    assert!(certify::<CircleLine, 2, 2, 2>(&mirror, &Vector2::new(R2, C)).expect("certifies").encloses(&mirror));
}

#[test]
fn approximate_roots_certify_and_every_certificate_holds_the_root() {
    // Points near the root at distances from 1e-15 to 1e-1: whenever one certifies, the root
    // is in its box and its enclosure (the mirror root at x = -0.5 is far from all of them
    // but the largest).
    let mut rng = rng(44);
    let root = Vector2::from(ROOT);
    let mut certified = 0;
    for k in 0..400 {
        let scale = 10f64.powf(-15.0 + 14.0 * (k as f64) / 400.0);
        let x = root + Vector2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * scale;
        if let Ok(cert) = certify::<CircleLine, 2, 2, 2>(&x, &Vector2::new(R2, C)) {
            assert!(cert.box_contains(&root) && cert.encloses(&root), "offset {scale:e}: {cert:?}");
            certified += 1;
        }
    }
    println!("{certified}/400 certified");
    // Newton's basin is wide here: the small offsets must certify.
    assert!(certified >= 300, "only {certified}/400");
}

#[test]
fn a_box_that_misses_the_root_does_not_certify() {
    let root = Vector2::from(ROOT);
    let p = Vector2::new(R2, C);
    let mut rng = rng(7);
    for _ in 0..200 {
        let rho = 10f64.powf(rng.random_range(-12.0..-2.0));
        // The center moved by 2 to 4 radii in each coordinate: the root is outside the box,
        // the only other root (-0.5, 0.75) far away.
        let dir = Vector2::new(rng.random_range(2.0..4.0), rng.random_range(2.0..4.0))
            .component_mul(&Vector2::new(if rng.random_bool(0.5) { 1.0 } else { -1.0 }, if rng.random_bool(0.5) { 1.0 } else { -1.0 }));
        let x = root + dir * rho;
        let result = certify_box::<CircleLine, 2, 2, 2>(&x, &p, &[0, 1], &Vector2::repeat(rho));
        assert!(matches!(result, Err(CertifyError::NotContracting { .. })), "rho {rho:e}, center {x:?}: {result:?}");
    }
}

#[test]
fn a_point_between_two_close_roots_does_not_certify_both() {
    // Roots (±d, 0.75) with d = 2^-20 (r2 = 0.5625 + 2^-40 exactly).
    let d = 2f64.powi(-20);
    let p = Vector2::new(C * C + d * d, C);
    let (a, b) = (Vector2::new(d, C), Vector2::new(-d, C));
    assert!(matches!(certify::<CircleLine, 2, 2, 2>(&Vector2::new(0.0, C), &p), Err(CertifyError::Singular)));
    let mut rng = rng(11);
    let mut certified = 0;
    for _ in 0..300 {
        let x = Vector2::new(rng.random_range(-0.9..0.9) * d, C + rng.random_range(-1.0..1.0) * d);
        if let Ok(cert) = certify::<CircleLine, 2, 2, 2>(&x, &p) {
            // Uniqueness: a certified box holds exactly one of the two roots.
            assert!(cert.box_contains(&a) != cert.box_contains(&b), "x {x:?}: {cert:?}");
            assert!(cert.encloses(&a) || cert.encloses(&b));
            certified += 1;
        }
    }
    println!("{certified}/300 points between the roots certified one of them");
    // Midway points (within a tenth of d of the middle) have a Newton step larger than d:
    // their box would hold both roots, so none certifies.
    for k in 0..50 {
        let x = Vector2::new((k as f64 - 25.0) / 250.0 * d, C);
        assert!(certify::<CircleLine, 2, 2, 2>(&x, &p).is_err(), "x {x:?}");
    }
}

#[test]
fn a_singular_root_does_not_certify() {
    // The tangent line: the double root (0, 0.75).
    let p = Vector2::new(C * C, C);
    assert!(matches!(certify::<CircleLine, 2, 2, 2>(&Vector2::new(0.0, C), &p), Err(CertifyError::Singular)));
    let mut rng = rng(5);
    for _ in 0..200 {
        let x = Vector2::new(10f64.powf(rng.random_range(-12.0..-1.0)) * if rng.random_bool(0.5) { 1.0 } else { -1.0 }, C);
        let result = certify::<CircleLine, 2, 2, 2>(&x, &p);
        assert!(result.is_err(), "x {x:?}: {result:?}");
    }
    // The double root of x² = 0 in one unknown.
    for k in 1..40 {
        let x = Vector1::new(2f64.powi(-k));
        assert!(certify::<Square, 1, 1, 1>(&x, &Vector1::new(0.0)).is_err(), "x {x:?}");
    }
}

#[test]
fn sqrt2_is_enclosed() {
    let x = Vector1::new(std::f64::consts::SQRT_2);
    let cert = certify::<Square, 1, 1, 1>(&x, &Vector1::new(2.0)).expect("certifies");
    let k = cert.enclosure[0];
    // sqrt(2) lies in [lo, hi] iff lo² <= 2 <= hi² (0 < lo), checked in exact rationals.
    let sq = |v: f64| {
        let r = BigRational::from_float(v).expect("finite");
        &r * &r
    };
    let two = BigRational::from_integer(2.into());
    assert!(k.lo() > 0.0 && sq(k.lo()) <= two && two <= sq(k.hi()), "{k:?}");
}

#[test]
fn chosen_rows_of_an_overdetermined_system_certify() {
    let root = Vector2::from(ROOT);
    let p = SVector::<f64, 3>::new(R2, C, -0.25);
    for rows in [[0, 1], [0, 2], [1, 2], [2, 0]] {
        let cert = certify_rows::<CircleLineDiagonal, 2, 3, 3>(&root, &p, &rows).expect("certifies");
        assert_eq!(cert.rows, rows);
        assert!(cert.encloses(&root));
    }
    let rows = choose_rows::<CircleLineDiagonal, 2, 3, 3>(&root, &p).expect("rows");
    assert!(rows[0] != rows[1] && rows.iter().all(|&r| r < 3));
    assert!(certify_rows::<CircleLineDiagonal, 2, 3, 3>(&root, &p, &rows).expect("certifies").encloses(&root));
}

#[test]
fn bad_calls_get_typed_errors() {
    let root = Vector2::from(ROOT);
    let p3 = SVector::<f64, 3>::new(R2, C, -0.25);
    assert_eq!(certify::<CircleLineDiagonal, 2, 3, 3>(&root, &p3), Err(CertifyError::NotSquare { nx: 2, nf: 3 }));
    assert_eq!(certify_rows::<CircleLineDiagonal, 2, 3, 3>(&root, &p3, &[0, 3]), Err(CertifyError::BadRow { row: 3, nf: 3 }));
    assert_eq!(certify_rows::<CircleLineDiagonal, 2, 3, 3>(&root, &p3, &[1, 1]), Err(CertifyError::BadRow { row: 1, nf: 3 }));
    let p = Vector2::new(R2, C);
    assert_eq!(certify::<CircleLine, 2, 2, 2>(&Vector2::new(f64::NAN, C), &p), Err(CertifyError::NonFinite));
    assert_eq!(certify::<CircleLine, 2, 2, 2>(&root, &Vector2::new(R2, f64::INFINITY)), Err(CertifyError::NonFinite));
    // The residual overflows (1e400), the Jacobian (2e200) does not.
    assert_eq!(certify::<Square, 1, 1, 1>(&Vector1::new(1e200), &Vector1::new(2.0)), Err(CertifyError::NonFinite));
    // Badly conditioned (pivot 1 against a norm 2e300): no C to steer by.
    assert_eq!(certify::<CircleLine, 2, 2, 2>(&Vector2::new(1e300, 1e300), &p), Err(CertifyError::Singular));
    assert_eq!(certify_box::<CircleLine, 2, 2, 2>(&root, &p, &[0, 1], &Vector2::new(0.0, 1e-9)), Err(CertifyError::Singular));
    assert_eq!(certify_box::<CircleLine, 2, 2, 2>(&root, &p, &[0, 1], &Vector2::new(-1.0, 1e-9)), Err(CertifyError::NonFinite));
}

/// `x + y - a`, `x - y - b`: linear, root `((a + b) / 2, (a - b) / 2)`.
struct Linear;

impl ProblemInfo for Linear {
    const NAME: &'static str = "linear";
    const UNKNOWN_NAMES: &'static [&'static str] = &["x", "y"];
    const PARAM_NAMES: &'static [&'static str] = &["a", "b"];
}

impl Problem<2, 2, 2> for Linear {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 2>, f: &mut SVector<S, 2>) {
        f[0] = x[0] + x[1] - p[0];
        f[1] = x[0] - x[1] - p[1];
    }
    fn jacobian<S: Ring>(_x: &SVector<S, 2>, _p: &SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        j[(0, 0)] = S::constant(1.0);
        j[(0, 1)] = S::constant(1.0);
        j[(1, 0)] = S::constant(1.0);
        j[(1, 1)] = S::constant(-1.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 2>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

#[test]
fn a_root_at_the_origin_certifies() {
    // Zero Newton step and zero point: the radius floor keeps the box nonempty.
    let zero = Vector2::zeros();
    let cert = certify::<Linear, 2, 2, 2>(&zero, &Vector2::zeros()).expect("the origin certifies");
    assert!(cert.encloses(&zero) && cert.radius.iter().all(|r| *r > 0.0));
    // A point off the origin certifies with a box that holds it.
    let x = Vector2::new(1e-3, -2e-3);
    assert!(certify::<Linear, 2, 2, 2>(&x, &Vector2::zeros()).expect("linear: certifies").encloses(&zero));
}
