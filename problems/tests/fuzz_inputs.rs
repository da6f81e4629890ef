//! Bad input never panics or hangs (issue 43, deliverable 7): the library solvers' entry points
//! (`solve`, `estimate`, `solve_rows`) and the JSON readers on NaN, infinities, 1e308, subnormals, zeros,
//! repeated rows, wrong lengths, and 0 / 1 / few / 10^4 correspondences. Every case ends in a
//! typed error or an answer (validated, or flagged by the error), never a panic; an answer that
//! comes back `Ok` from garbage must still pass the solver's own validation on the data it was
//! given. Seeded (proptest's fixed seed via `PROPTEST_RNG_SEED`, or its default); each test
//! prints how many cases it tried.

use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use simhc::pipeline::{Validator, Verdict};
use simhc::ransac::RansacOptions;
use simhc::ProblemLayout;
use simhc_problems::grps::declared::GrpsSolvers;
use simhc_problems::grps::scene::GrpsCorrespondence;
use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpCorrespondence;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

/// A number a user's file or a broken pipeline may hold.
fn hostile() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(1e308),
        Just(-1e308),
        Just(f64::MIN_POSITIVE / 4.0), // subnormal
        Just(5e-324),
        Just(0.0),
        Just(-0.0),
        -2.0..2.0f64,
        -2.0..2.0f64,
        -2.0..2.0f64,
    ]
}

fn vec3() -> impl Strategy<Value = Vector3<f64>> {
    (hostile(), hostile(), hostile()).prop_map(|(a, b, c)| Vector3::new(a, b, c))
}

/// How many correspondences: none, one, a few around the minimal counts, or many.
fn count() -> impl Strategy<Value = usize> {
    prop_oneof![Just(0usize), Just(1usize), 2..12usize, 2..12usize]
}

/// Correspondences, some of them repeated.
fn rows<T: Clone + std::fmt::Debug>(one: impl Strategy<Value = T>) -> impl Strategy<Value = Vec<T>> {
    (count(), proptest::collection::vec(one, 12), any::<bool>()).prop_map(|(n, pool, repeat)| {
        let mut v: Vec<T> = pool.into_iter().take(n).collect();
        if repeat && v.len() >= 2 {
            let first = v[0].clone();
            let last = v.len() - 1;
            v[last] = first;
        }
        v
    })
}

fn upnp_corr() -> impl Strategy<Value = UpnpCorrespondence> {
    (vec3(), vec3(), vec3()).prop_map(|(p, f, v)| UpnpCorrespondence { p, f, v })
}

fn grps_corr() -> impl Strategy<Value = GrpsCorrespondence> {
    (vec3(), vec3(), vec3(), vec3()).prop_map(|(f, v, fp, vp)| GrpsCorrespondence { f, v, fp, vp })
}

fn upnp() -> &'static UpnpLibrarySolver {
    static S: OnceLock<UpnpLibrarySolver> = OnceLock::new();
    S.get_or_init(|| UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights"))
}

/// The solver whose estimator's samples validate within 0.01 rad.
fn upnp_estimator() -> &'static UpnpLibrarySolver {
    static S: OnceLock<UpnpLibrarySolver> = OnceLock::new();
    S.get_or_init(|| UpnpLibrarySolver::new(UpnpProblem { max_angle: 0.01, ..UpnpProblem::default() }).expect("shipped weights"))
}

fn grps() -> &'static GrpsSolvers {
    static S: OnceLock<GrpsSolvers> = OnceLock::new();
    S.get_or_init(|| GrpsSolvers::new(0.0).expect("shipped weights"))
}

/// Few iterations: the point is what bad data does, not the estimate.
fn options() -> RansacOptions {
    RansacOptions { max_iterations: 30, min_iterations: 0, seed: 1, ..RansacOptions::poselib(1e-2) }
}

static UPNP_CASES: AtomicUsize = AtomicUsize::new(0);
static GRPS_CASES: AtomicUsize = AtomicUsize::new(0);
static JSON_CASES: AtomicUsize = AtomicUsize::new(0);

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn upnp_solve_and_estimate_never_panic(corrs in rows(upnp_corr())) {
        let n = UPNP_CASES.fetch_add(1, Ordering::Relaxed) + 1;
        if let Ok(s) = upnp().solve(&corrs[..]) {
            // An answer from hostile data must still be one the validator accepts on it.
            let check = upnp().validator().check(&corrs[..], &s.x);
            prop_assert_eq!(upnp().validator().verdict(&check), Verdict::Accept);
        }
        let _ = upnp_estimator().estimate(&corrs[..], &options());
        if n % 100 == 0 {
            println!("upnp: {n} cases");
        }
    }

    #[test]
    fn grps_solve_never_panics(corrs in rows(grps_corr())) {
        let n = GRPS_CASES.fetch_add(1, Ordering::Relaxed) + 1;
        if let Ok(s) = grps().solve(&corrs) {
            let v = grps().eight.validator();
            let check = Validator::<[GrpsCorrespondence], 8>::check(v, &corrs[..], &s.x);
            prop_assert_eq!(Validator::<[GrpsCorrespondence], 8>::verdict(v, &check), Verdict::Accept);
        }
        // The row-wise solver of many rows (`Solver::solve_rows`) on the same rows: an answer
        // of all of them, or a typed error.
        let rows: Vec<f64> = corrs.iter().flat_map(|c| [c.f, c.v, c.fp, c.vp]).flat_map(|v| [v.x, v.y, v.z]).collect();
        if let Ok(s) = grps().eight.solve_rows(&rows, &[]) {
            prop_assert_eq!(s.rows, corrs.len());
        }
        if n % 100 == 0 {
            println!("grps: {n} cases");
        }
    }

    /// The JSON readers on mangled documents: a typed error with its place, or correspondences.
    #[test]
    fn json_readers_never_panic(cut in 0usize..400, junk in "[\\[\\]{},:\"0-9a-zNaINf.eE+-]{0,12}", value in hostile()) {
        let n = JSON_CASES.fetch_add(1, Ordering::Relaxed) + 1;
        let good = r#"{"correspondences": [{"p": [0.1, 0.2, 5.0], "f": [0.0, 0.0, 1.0], "v": [0.5, 0.0, 0.0]}, {"p": [1.0, -0.2, 6.0], "f": [0.1, 0.0, 1.0], "v": [-0.5, 0.0, 0.0]}]}"#;
        let at = cut.min(good.len());
        let mangled = format!("{}{}{}", &good[..at], junk, &good[at..]);
        let _ = simhc_problems::input::parse_correspondences::<UpnpCorrespondence>(&mangled);
        let with_value = good.replace("0.2", &format!("{value}"));
        let _ = simhc_problems::input::parse_correspondences::<UpnpCorrespondence>(&with_value);
        let _ = simhc_problems::input::parse_correspondences::<GrpsCorrespondence>(&mangled);
        let layout = simhc_problems::grps::Grps8::LAYOUT;
        let _ = simhc::input::parse_layout_params(&layout, &mangled);
        if n % 100 == 0 {
            println!("json: {n} cases");
        }
    }
}

/// 10^4 correspondences, a tenth of them hostile, and as many copies of one: a typed error or
/// an answer, in bounded work (a hang fails the test run).
#[test]
fn ten_thousand_correspondences_end() {
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut tried = 0;
    for hostile_every in [0usize, 10] {
        let mut upnp_rows: Vec<UpnpCorrespondence> = Vec::with_capacity(10_000);
        let mut grps_rows: Vec<GrpsCorrespondence> = Vec::with_capacity(10_000);
        for i in 0..10_000usize {
            let k = i as f64;
            let mut c = UpnpCorrespondence {
                p: Vector3::new(k.sin(), (1.3 * k).cos(), 5.0 + (0.7 * k).sin()),
                f: Vector3::new(0.1 * k.cos(), 0.1 * k.sin(), 1.0),
                v: Vector3::new((i % 4) as f64 * 0.1, 0.0, 0.0),
            };
            let mut g = GrpsCorrespondence { f: c.f, v: c.v, fp: Vector3::new(0.1 * (2.0 * k).sin(), 0.05, 1.0), vp: c.v * 2.0 };
            if hostile_every > 0 && i % hostile_every == 0 {
                let x = hostile().new_tree(&mut runner).expect("value").current();
                (c.p.x, g.vp.y) = (x, x);
            }
            upnp_rows.push(c);
            grps_rows.push(g);
        }
        let _ = upnp().solve(&upnp_rows[..]);
        let _ = upnp_estimator().estimate(&upnp_rows, &options());
        let _ = grps().solve(&grps_rows);
        let same = vec![upnp_rows[1]; 10_000];
        let _ = upnp().solve(&same[..]);
        let _ = upnp_estimator().estimate(&same, &options());
        tried += 5;
    }
    // The row-wise library solver's estimator, through the declared GRPS problem: all copies of
    // one row (every sample degenerate) and rows of the wrong length.
    let rows: Vec<f64> = (0..10_000 * 12).map(|i| ((i % 12) as f64 * 0.37).sin()).collect();
    let _ = grps().eight.estimate((&rows, &[]), &options());
    assert!(grps().eight.estimate((&rows[..13], &[]), &options()).is_err(), "13 numbers are not whole rows");
    let _ = grps().eight.solve_rows(&rows, &[]);
    assert!(grps().eight.solve_rows(&rows[..13], &[]).is_err(), "13 numbers are not whole rows");
    tried += 4;
    println!("10^4 correspondences: {tried} calls, each ended");
}
