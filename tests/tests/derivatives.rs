//! Every generated Jacobian and parameter derivative against central differences, on random
//! inputs (proptest), in f64 and in complex arithmetic; and the fused/separate entry points
//! against each other.

use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::scalar::C;
use simhc::{CoefficientForm, ParamDerivative, Scalar};
use simhc_problems::{grps, upnp};

#[simhc::simhc_problem]
mod circle_line {
    pub struct Unknowns {
        x: Vec2,
    }
    pub struct Globals {
        c: Vec2,
        r2: Scalar,
        a: Vec2,
        b: Scalar,
    }
    pub fn global_equations() -> [Scalar; 2] {
        let d = x - c;
        [d.dot(d) - r2, a.dot(x) - b]
    }
}

#[simhc::simhc_problem]
mod p3p {
    pub struct Unknowns {
        d: Vec3,
    }
    pub struct Globals {
        f1: Vec3,
        f2: Vec3,
        f3: Vec3,
        s: Vec3,
    }
    pub fn global_equations() -> [Scalar; 3] {
        let a = d[0] * f1;
        let b = d[1] * f2;
        let c = d[2] * f3;
        [(a - b).norm_squared() - s[0], (b - c).norm_squared() - s[1], (a - c).norm_squared() - s[2]]
    }
}

/// Exercises matrices, transposes, powers, division by constants and grad in one system.
#[simhc::simhc_problem]
mod kitchen_sink {
    pub struct Unknowns {
        q: Quat,
        u: Scalar,
    }
    pub struct Row {
        a: Vec3,
        w: Scalar,
    }
    pub struct Globals {
        k: Mat<3, 3>,
        h: Sym<3>,
    }
    pub const ROWS: [usize; 2] = [3, 4];
    pub fn row_equations() -> Scalar {
        let r = rotation(q);
        let b = (k * r.transpose()) * a;
        b.dot(h * a) * u.powi(2) / 2.0 - w + a.cross(b)[1]
    }
    pub fn global_equations() -> [Scalar; 2] {
        let e = q.dot(q).powi(2) * u;
        let g = grad(e, q);
        [g.sum() - 4, q.norm_squared() - 1]
    }
}

fn random_vec<S: Scalar, const N: usize>(rng: &mut ChaCha8Rng, complex: bool) -> SVector<S, N> {
    SVector::from_fn(|_, _| {
        let re = rng.random_range(-1.5..1.5);
        let im = if complex { rng.random_range(-1.0..1.0) } else { 0.0 };
        S::from_real(re) + S::from_real(im) * imaginary_unit::<S>(complex)
    })
}

fn imaginary_unit<S: Scalar>(complex: bool) -> S {
    // For f64 the imaginary part is never used (complex == false).
    if complex {
        S::from_complex_parts()
    } else {
        S::from_real(0.0)
    }
}

trait ComplexParts {
    fn from_complex_parts() -> Self;
}
impl<T: Scalar> ComplexParts for T {
    fn from_complex_parts() -> Self {
        // sqrt(-1) in the scalar's field: NaN for f64, i for Complex.
        T::from_real(-1.0).sqrt()
    }
}

/// Relative closeness with a floor at scale 1.
fn close<S: Scalar>(a: S, b: S, tol: f64, scale: f64) -> bool {
    (a - b).modulus() <= tol * scale.max(1.0)
}

fn check<P, S, const NX: usize, const NF: usize, const NP: usize>(seed: u64, complex: bool)
where
    P: ParamDerivative<NX, NF, NP>,
    S: Scalar,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x: SVector<S, NX> = random_vec(&mut rng, complex);
    let p: SVector<S, NP> = random_vec(&mut rng, complex);
    let dp: SVector<S, NP> = random_vec(&mut rng, complex);

    let mut f = SVector::<S, NF>::zeros();
    let mut j = SMatrix::<S, NF, NX>::zeros();
    let mut f2 = SVector::<S, NF>::zeros();
    let mut j2 = SMatrix::<S, NF, NX>::zeros();
    P::residual(&x, &p, &mut f);
    P::jacobian(&x, &p, &mut j);
    P::residual_jacobian(&x, &p, &mut f2, &mut j2);
    let fscale = f.camax();
    for i in 0..NF {
        assert!(close(f[i], f2[i], 1e-12, fscale), "{}: fused residual differs, seed {seed}", P::NAME);
    }
    let jscale = j.camax();
    for k in 0..NX * NF {
        assert!(close(j[k], j2[k], 1e-12, jscale), "{}: fused Jacobian differs, seed {seed}", P::NAME);
    }

    // dF/dx by central differences.
    let h = 1e-6;
    let (mut fp, mut fm) = (SVector::<S, NF>::zeros(), SVector::<S, NF>::zeros());
    for k in 0..NX {
        let (mut xp, mut xm) = (x, x);
        xp[k] += S::from_real(h);
        xm[k] -= S::from_real(h);
        P::residual(&xp, &p, &mut fp);
        P::residual(&xm, &p, &mut fm);
        for i in 0..NF {
            let fd = (fp[i] - fm[i]) / S::from_real(2.0 * h);
            assert!(
                close(j[(i, k)], fd, 1e-6, jscale),
                "{}: dF{i}/dx{k} = {:?}, central difference {:?}, seed {seed}",
                P::NAME,
                j[(i, k)],
                fd
            );
        }
    }

    // dF/dp by central differences, and the directional derivative against the matrix.
    let mut jp = SMatrix::<S, NF, NP>::zeros();
    P::param_jacobian(&x, &p, &mut jp);
    let jpscale = jp.camax();
    for m in 0..NP {
        let (mut pp, mut pm) = (p, p);
        pp[m] += S::from_real(h);
        pm[m] -= S::from_real(h);
        P::residual(&x, &pp, &mut fp);
        P::residual(&x, &pm, &mut fm);
        for i in 0..NF {
            let fd = (fp[i] - fm[i]) / S::from_real(2.0 * h);
            assert!(
                close(jp[(i, m)], fd, 1e-6, jpscale),
                "{}: dF{i}/dp{m} = {:?}, central difference {:?}, seed {seed}",
                P::NAME,
                jp[(i, m)],
                fd
            );
        }
    }
    let mut dir = SVector::<S, NF>::zeros();
    P::param_directional(&x, &p, &dp, &mut dir);
    let expected = jp * dp;
    for i in 0..NF {
        assert!(close(dir[i], expected[i], 1e-11, expected.camax()), "{}: dF/dp * dp differs, seed {seed}", P::NAME);
    }
}

/// The coefficient form reproduces the system, and its linear part is the straight line's
/// `dH/dt = F(x; p1) - F(x; p0)`.
fn check_coefficients<P, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(seed: u64, complex: bool)
where
    P: CoefficientForm<NX, NF, NP, NC>,
    S: Scalar,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let x: SVector<S, NX> = random_vec(&mut rng, complex);
    let p0: SVector<S, NP> = random_vec(&mut rng, complex);
    let p1: SVector<S, NP> = random_vec(&mut rng, complex);
    let (mut c0, mut c1) = (SVector::<S, NC>::zeros(), SVector::<S, NC>::zeros());
    P::coefficients(&p0, &mut c0);
    P::coefficients(&p1, &mut c1);
    let (mut f, mut fc, mut fc2) = (SVector::<S, NF>::zeros(), SVector::<S, NF>::zeros(), SVector::<S, NF>::zeros());
    let (mut j, mut jc) = (SMatrix::<S, NF, NX>::zeros(), SMatrix::<S, NF, NX>::zeros());
    P::residual_jacobian(&x, &p0, &mut f, &mut j);
    P::residual_jacobian_coeffs(&x, &c0, &mut fc, &mut jc);
    P::residual_coeffs(&x, &c0, &mut fc2);
    let (fs, js) = (f.camax(), j.camax());
    for i in 0..NF {
        assert!(close(f[i], fc[i], 1e-11, fs) && close(f[i], fc2[i], 1e-11, fs), "{}: Fc differs from F, seed {seed}", P::NAME);
    }
    for k in 0..NF * NX {
        assert!(close(j[k], jc[k], 1e-11, js), "{}: Jc differs from J, seed {seed}", P::NAME);
    }
    let mut f1 = SVector::<S, NF>::zeros();
    P::residual(&x, &p1, &mut f1);
    let mut part = SVector::<S, NF>::zeros();
    P::coefficient_part(&x, &(c1 - c0), &mut part);
    let expected = f1 - f;
    for i in 0..NF {
        assert!(close(part[i], expected[i], 1e-11, expected.camax()), "{}: linear part differs, seed {seed}", P::NAME);
    }
}

/// The path-lane row kernel from the parameters ([`simhc::ParamLanes::row_params`], the
/// declaration lowered without expansion, differentiated on its DAG) against the parameter form
/// (`residual_jacobian`, `param_directional`, both checked against central differences in
/// [`check`]): `LANES` different complex paths, one per lane, every row. Returns whether the
/// problem has the kernel.
fn check_param_lanes<P, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(seed: u64) -> bool
where
    P: CoefficientForm<NX, NF, NP, NC> + ParamDerivative<NX, NF, NP>,
{
    use simhc::lanes::{C64x4, Lanes, LANES};
    use simhc::{ParamLanes, PathLanes, RowLanes};
    let Some(kernels) = P::PARAM_LANES else {
        return false;
    };
    let (rows, epr, layout) = (kernels.layout().rows, kernels.equations_per_row(), kernels.param_layout());
    let (row_len, k) = (layout.row_len, layout.inputs);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x1a7e5);
    let xs: Vec<SVector<C, NX>> = (0..LANES).map(|_| random_vec(&mut rng, true)).collect();
    let ps: Vec<SVector<C, NP>> = (0..LANES).map(|_| random_vec(&mut rng, true)).collect();
    let dps: Vec<SVector<C, NP>> = (0..LANES).map(|_| random_vec(&mut rng, true)).collect();
    let mut xl = [C64x4::from_real(0.0); NX];
    for (i, v) in xl.iter_mut().enumerate() {
        for l in 0..LANES {
            v.set(l, xs[l][i]);
        }
    }
    // Expected per lane: the full system's rows.
    let expected: Vec<(SVector<C, NF>, SMatrix<C, NF, NX>, SVector<C, NF>)> = (0..LANES)
        .map(|l| {
            let (mut f, mut j, mut d) = (SVector::zeros(), SMatrix::zeros(), SVector::zeros());
            P::residual_jacobian(&xs[l], &ps[l], &mut f, &mut j);
            P::param_directional(&xs[l], &ps[l], &dps[l], &mut d);
            (f, j, d)
        })
        .collect();
    let mut shared = vec![C64x4::from_real(f64::NAN); layout.shared];
    kernels.shared(&xl, &mut shared);
    for r in 0..rows {
        // Row r's inputs: its own parameters, then the globals stored after all rows.
        let src = |i: usize| if i < row_len { r * row_len + i } else { rows * row_len + (i - row_len) };
        let mut pl = vec![C64x4::from_real(0.0); k];
        let mut dpl = vec![C64x4::from_real(0.0); k];
        for i in 0..k {
            for l in 0..LANES {
                pl[i].set(l, ps[l][src(i)]);
                dpl[i].set(l, dps[l][src(i)]);
            }
        }
        let mut f = vec![C64x4::from_real(f64::NAN); epr];
        let mut j = vec![C64x4::from_real(f64::NAN); epr * NX];
        let mut d = vec![C64x4::from_real(f64::NAN); epr];
        kernels.row_params(&xl, &shared, &pl, &dpl, &mut f, &mut j, &mut d);
        for (l, (fe, je, de)) in expected.iter().enumerate() {
            let (fs, js, ds) = (fe.camax(), je.camax(), de.camax());
            for e in 0..epr {
                let row = r * epr + e;
                assert!(close(f[e].get(l), fe[row], 1e-11, fs), "{}: row {r} residual, lane {l}, seed {seed}", P::NAME);
                assert!(close(d[e].get(l), de[row], 1e-11, ds), "{}: row {r} dF/dp dp, lane {l}, seed {seed}", P::NAME);
                for x in 0..NX {
                    let got = j[e * NX + x].get(l);
                    assert!(close(got, je[(row, x)], 1e-11, js), "{}: row {r} J[{x}], lane {l}, seed {seed}", P::NAME);
                }
            }
        }
    }
    // The one-row `f64` kernel ([`simhc::ParamLanes::row_equations`], the robust estimator's)
    // against the same full system at a real point, row by row.
    let (xr, pr) = (xs[0].map(|v| v.re), ps[0].map(|v| v.re));
    let (mut fe, mut je) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
    P::residual_jacobian(&xr, &pr, &mut fe, &mut je);
    let xa: [f64; NX] = std::array::from_fn(|i| xr[i]);
    for r in 0..rows {
        let p: Vec<f64> = (0..k).map(|i| pr[if i < row_len { r * row_len + i } else { rows * row_len + (i - row_len) }]).collect();
        let (mut f, mut j) = (vec![f64::NAN; epr], vec![f64::NAN; epr * NX]);
        assert!(kernels.row_equations(&xa, &p, &mut f, &mut j), "{}: row_equations refused its layout", P::NAME);
        for e in 0..epr {
            let row = r * epr + e;
            assert!(close(f[e], fe[row], 1e-11, fe.amax()), "{}: one-row kernel, row {r} residual, seed {seed}", P::NAME);
            for x in 0..NX {
                assert!(close(j[e * NX + x], je[(row, x)], 1e-11, je.amax()), "{}: one-row kernel, row {r} J[{x}], seed {seed}", P::NAME);
            }
        }
        // Wrong lengths are refused and leave the outputs untouched.
        let before = f.clone();
        assert!(!kernels.row_equations(&xa, &p[1..], &mut f, &mut j), "{}: row_equations took a short row", P::NAME);
        assert_eq!(f, before);
    }
    true
}

fn check_both<P, const NX: usize, const NF: usize, const NP: usize>(seed: u64)
where
    P: ParamDerivative<NX, NF, NP>,
{
    check::<P, f64, NX, NF, NP>(seed, false);
    check::<P, C, NX, NF, NP>(seed, true);
}

fn check_coefficients_both<P, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(seed: u64)
where
    P: CoefficientForm<NX, NF, NP, NC>,
{
    check_coefficients::<P, f64, NX, NF, NP, NC>(seed, false);
    check_coefficients::<P, C, NX, NF, NP, NC>(seed, true);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn circle_line_derivatives(seed in any::<u64>()) {
        simhc_tests::on_large_stack(move || {
            check_both::<circle_line::CircleLine, 2, 2, 6>(seed);
            check_coefficients_both::<circle_line::CircleLine, 2, 2, 6, 6>(seed);
        });
    }

    #[test]
    fn p3p_derivatives(seed in any::<u64>()) {
        simhc_tests::on_large_stack(move || {
            check_both::<p3p::P3p, 3, 3, 12>(seed);
        });
    }

    #[test]
    fn kitchen_sink_derivatives(seed in any::<u64>()) {
        simhc_tests::on_large_stack(move || {
            check_both::<kitchen_sink::KitchenSink3, 5, 5, 27>(seed);
            check_coefficients_both::<kitchen_sink::KitchenSink3, 5, 5, 27, 63>(seed);
            assert!(check_param_lanes::<kitchen_sink::KitchenSink3, 5, 5, 27, 63>(seed));
            check_both::<kitchen_sink::KitchenSink4, 5, 6, 31>(seed);
        });
    }

    #[test]
    fn grps_derivatives(seed in any::<u64>()) {
        simhc_tests::on_large_stack(move || {
            check_both::<grps::Grps7, 8, 8, 84>(seed);
            check_both::<grps::Grps8, 8, 9, 96>(seed);
            check_coefficients_both::<grps::Grps7, 8, 8, 84, 266>(seed);
            check_coefficients_both::<grps::Grps8, 8, 9, 96, 304>(seed);
            assert!(check_param_lanes::<grps::Grps7, 8, 8, 84, 266>(seed));
            // The operation counts favour the unexpanded rows (rotation(q) kept): the batch
            // tracker uses them by default.
            assert!(<grps::Grps7 as CoefficientForm<8, 8, 84, 266>>::PARAM_LANES.is_some_and(|k| simhc::ParamLanes::param_layout(k).preferred));
            assert!(check_param_lanes::<grps::Grps8, 8, 9, 96, 304>(seed));
        });
    }

    #[test]
    fn upnp_derivatives(seed in any::<u64>()) {
        simhc_tests::on_large_stack(move || {
            check_both::<upnp::Upnp, 4, 5, 66>(seed);
            check_coefficients_both::<upnp::Upnp, 4, 5, 66, 35>(seed);
        });
    }
}

#[test]
fn kitchen_sink_matches_hand_computation() {
    // One point evaluated by hand-written nalgebra code, independent of the generator.
    use nalgebra::{Matrix3, Vector3};
    let q = [0.3, -0.2, 0.5, 0.7];
    let u = 1.3;
    let a = Vector3::new(0.4, -1.1, 0.9);
    let w = 0.25;
    let k = Matrix3::new(1.0, 2.0, -1.0, 0.5, 0.0, 3.0, -2.0, 1.0, 0.5);
    let h = Matrix3::new(2.0, 0.3, -0.4, 0.3, 1.0, 0.2, -0.4, 0.2, 3.0);
    let r = simhc_problems::metrics::rotation_from_quat(q);
    let b = k * r.transpose() * a;
    let expected_row = b.dot(&(h * a)) * u * u / 2.0 - w + a.cross(&b)[1];

    let mut globals = kitchen_sink::Globals::default();
    for i in 0..3 {
        for j in 0..3 {
            globals.k[i][j] = k[(i, j)];
            globals.h[i][j] = h[(i, j)];
        }
    }
    let row = kitchen_sink::Row { a: a.into(), w };
    let p = kitchen_sink::KitchenSink3::params(&[row; 3], &globals);
    let x = SVector::<f64, 5>::from([q[0], q[1], q[2], q[3], u]);
    let mut f = SVector::<f64, 5>::zeros();
    <kitchen_sink::KitchenSink3 as simhc::Problem<5, 5, 27>>::residual(&x, &p, &mut f);
    assert!((f[0] - expected_row).abs() < 1e-12, "{} vs {expected_row}", f[0]);
    let n: f64 = q.iter().map(|v| v * v).sum();
    // grad of n^2 u is 4 n u q; its sum minus 4.
    let expected_g = 4.0 * n * u * q.iter().sum::<f64>() - 4.0;
    assert!((f[3] - expected_g).abs() < 1e-12);
    assert!((f[4] - (n - 1.0)).abs() < 1e-12);
}
