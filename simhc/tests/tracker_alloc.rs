//! Proof of the zero-allocation claim: a counting global allocator, armed only on this test's
//! thread while `track` / `newton` run, for square, overdetermined, squared-up, complex and
//! failing paths, and while a learned start predicts.

mod counting_alloc;
mod tracker_support;

use counting_alloc::counted;
use nalgebra::{SVector, Vector1, Vector2};
use num_complex::Complex;
use simhc::homotopy::{random_gamma, to_complex, FixedSystem, ParameterHomotopy, SquaredUp, StraightLine};
use simhc::tracker::{newton, track, NewtonOptions, TrackError, Tracker, TrackerOptions};
use tracker_support::*;

#[test]
fn tracking_does_not_allocate() {
    // The counter works (so a zero below means something).
    let (v, n) = counted(|| vec![1u8; 16]);
    assert_eq!(v.len(), 16);
    assert!(n >= 1, "counting allocator is not armed");

    let options = [TrackerOptions::default(), TrackerOptions::paper(0.05), TrackerOptions::single_path()];

    // Square system, real, parameter homotopy.
    let mut rng = rng(700);
    let p0 = quad4_params(&mut rng);
    let p1 = quad4_params(&mut rng);
    let square = ParameterHomotopy::<Quad4, f64, Q4_NP>::new(p0, p1);
    let x0 = quad4_solution(&p0);
    for opts in &options {
        let (r, n) = counted(|| track(&square, &x0, opts));
        let r = r.unwrap();
        assert!((r.x - quad4_solution(&p1)).amax() < 1e-10);
        assert_eq!(n, 0, "square system: {n} allocations");
        // The step-by-step interface too.
        let (status, n) = counted(|| {
            let mut tracker = Tracker::new(&square, *opts);
            tracker.track(&x0).map(|r| r.stats)
        });
        assert!(status.is_ok());
        assert_eq!(n, 0, "Tracker::track: {n} allocations");
    }

    // Overdetermined 3 x 2: Gauss-Newton on the straight line and the parameter path, and the
    // squared-up system.
    let q0 = over_params(&mut rng);
    let mut q1 = q0;
    for v in q1.iter_mut() {
        *v += uniform(&mut rng, -0.3, 0.3);
    }
    let y0 = Vector2::new(q0[15], q0[16]);
    let want = Vector2::new(q1[15], q1[16]);
    let line = StraightLine::<Over3x2, f64, O_NP>::new(q0, q1);
    let param = ParameterHomotopy::<Over3x2, f64, O_NP>::new(q0, q1);
    let (sq, n) = counted(|| SquaredUp::new(line, 3));
    assert_eq!(n, 0, "SquaredUp::new: {n} allocations");
    for opts in &options {
        for (name, res) in [
            ("gauss-newton line", counted(|| track(&line, &y0, opts))),
            ("gauss-newton parameter", counted(|| track(&param, &y0, opts))),
            ("squared up", counted(|| track(&sq, &y0, opts))),
        ] {
            let (r, n) = res;
            let r = r.unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!((r.x - want).amax() < 1e-10, "{name}");
            assert_eq!(n, 0, "{name}: {n} allocations");
        }
    }
    let (r, n) = counted(|| newton(&FixedSystem::<Over3x2, f64, O_NP>::new(q1), &want, 1.0, &NewtonOptions::default()));
    assert!(r.unwrap().converged);
    assert_eq!(n, 0, "newton: {n} allocations");

    // Complex: gamma trick over all six roots, and the complex detour.
    let mut c = SVector::<Complex<f64>, 7>::zeros();
    for k in 0..6 {
        c[k] = Complex::new(uniform(&mut rng, -2.0, 2.0), uniform(&mut rng, -2.0, 2.0));
    }
    c[6] = Complex::new(1.0, 0.0);
    let mut start = SVector::<Complex<f64>, 7>::zeros();
    start[0] = Complex::new(-1.0, 0.0);
    start[6] = Complex::new(1.0, 0.0);
    let gamma_line = StraightLine::<Poly6, Complex<f64>, 7>::with_gamma(start, c, random_gamma(5));
    let (results, n) = counted(|| {
        let mut ok = 0;
        for k in 0..6 {
            let s = Complex::from_polar(1.0, std::f64::consts::TAU * k as f64 / 6.0);
            ok += track(&gamma_line, &Vector1::new(s), &TrackerOptions::default()).is_ok() as usize;
        }
        ok
    });
    assert_eq!(results, 6);
    assert_eq!(n, 0, "complex gamma trick: {n} allocations");
    let detour = ParameterHomotopy::<Quad4, Complex<f64>, Q4_NP>::with_complex_detour(&p0, &p1, 0.3, 11);
    let cx0 = to_complex(&x0);
    let (r, n) = counted(|| track(&detour, &cx0, &TrackerOptions::default()));
    assert!(r.is_ok());
    assert_eq!(n, 0, "complex detour: {n} allocations");

    // Failing paths return their error without allocating either.
    let fold = ParameterHomotopy::<FoldCubic, f64, 1>::new(Vector1::new(0.0), Vector1::new(3.0));
    let (r, n) = counted(|| track(&fold, &Vector1::new(-(3.0f64.sqrt())), &TrackerOptions::default()));
    assert!(matches!(r, Err(TrackError::StepSizeTooSmall { .. })));
    assert_eq!(n, 0, "failing path: {n} allocations");
    // Drag steps over the fold.
    let (r, n) = counted(|| track(&fold, &Vector1::new(-(3.0f64.sqrt())), &TrackerOptions::single_path()).map(|r| r.stats));
    assert!(r.map_or(true, |s| s.drag_steps > 0));
    assert_eq!(n, 0, "drag steps: {n} allocations");
}

/// The layout of a learned start's tests: unknowns `q` (quaternion) and `t` (3-vector), `rows`
/// rows of one 3-vector `f`.
fn quat_and_vector_layout(rows: usize) -> simhc::layout::Layout {
    use simhc::layout::{FieldKind, FieldLayout, Layout};
    const UNKNOWNS: &[FieldLayout] =
        &[FieldLayout { name: "q", kind: FieldKind::Quat, offset: 0 }, FieldLayout { name: "t", kind: FieldKind::Vector(3), offset: 4 }];
    const ROW: &[FieldLayout] = &[FieldLayout { name: "f", kind: FieldKind::Vector(3), offset: 0 }];
    Layout { unknowns: UNKNOWNS, row: ROW, globals: &[], rows, per_row: 3, equations_per_row: 1, parameter_free: &[], norms: &[] }
}

#[test]
fn a_learned_start_predicts_without_allocating() {
    use simhc::pipeline::LearnedStart;
    use simhc::regressor::{DenseLayer, FoldedNetwork};
    let layout = quat_and_vector_layout(5);
    let point = DenseLayer::new(3, 8, (0..24).map(|i| (i as f32 * 0.37).sin()).collect(), vec![0.1; 8]).unwrap();
    let head = DenseLayer::new(8, 7, (0..56).map(|i| (i as f32 * 0.11).cos()).collect(), vec![0.2; 7]).unwrap();
    let start = LearnedStart::new(FoldedNetwork::new(3, vec![point], vec![head], false).unwrap(), layout).unwrap();
    let p: Vec<f64> = (0..15).map(|i| f64::from(i) * 0.1 - 0.5).collect();
    let mut x = [0.0; 7];
    let (result, allocations) = counted(|| start.predict(&p, &mut x));
    result.expect("a prediction");
    assert_eq!(allocations, 0);
    // The quaternion comes out normalized.
    assert!((x[..4].iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-12, "{x:?}");
}

/// A network with a context stage (the pooled features of the first point layer concatenated to
/// every row before the second) predicts without allocating, for any number of rows.
#[test]
fn a_learned_start_with_a_context_stage_predicts_without_allocating() {
    use simhc::pipeline::LearnedStart;
    use simhc::regressor::{DenseLayer, FoldedNetwork};
    for rows in [1, 5, 37] {
        let layout = quat_and_vector_layout(rows);
        let first = DenseLayer::new(3, 8, (0..24).map(|i| (i as f32 * 0.37).sin()).collect(), vec![0.1; 8]).unwrap();
        let second = DenseLayer::new(16, 6, (0..96).map(|i| (i as f32 * 0.23).cos()).collect(), vec![0.0; 6]).unwrap();
        let head = DenseLayer::new(6, 7, (0..42).map(|i| (i as f32 * 0.11).cos()).collect(), vec![0.2; 7]).unwrap();
        let network = FoldedNetwork::with_context(3, vec![first, second], vec![head], false, 1).unwrap();
        let start = LearnedStart::new(network, layout).unwrap();
        let p: Vec<f64> = (0..3 * rows).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut x = [0.0; 7];
        let (result, allocations) = counted(|| start.predict(&p, &mut x));
        result.expect("a prediction");
        assert_eq!(allocations, 0, "{rows} rows");
        assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
    }
}

/// A network of two scored hypotheses: `predict` returns the better-scored one, normalized,
/// without allocating; outputs that are not blocks of the unknowns are refused.
#[test]
fn a_learned_start_with_hypotheses_returns_the_best_scored_one() {
    use simhc::pipeline::LearnedStart;
    use simhc::regressor::{DenseLayer, FoldedNetwork, HypothesisBlocks};
    let layout = quat_and_vector_layout(2);
    // Zero weights: the outputs are the head's biases, two blocks of 7 and their scores.
    let network = |bias: Vec<f32>| {
        let point = DenseLayer::new(3, 4, vec![0.0; 12], vec![0.0; 4]).unwrap();
        let head = DenseLayer::new(4, bias.len(), vec![0.0; 4 * bias.len()], bias).unwrap();
        FoldedNetwork::new(3, vec![point], vec![head], false).unwrap()
    };
    let first = [2.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0];
    let second = [0.0, 0.0, 0.0, 3.0, -1.0, -2.0, -3.0];
    let bias: Vec<f32> = first.iter().chain(&second).chain(&[0.5, 1.5]).map(|v| *v as f32).collect();
    let start = LearnedStart::new(network(bias), layout).unwrap();
    assert_eq!(start.blocks(), HypothesisBlocks { width: 7, count: 2, scored: true });
    let mut x = [0.0; 7];
    let (result, allocations) = counted(|| start.predict(&[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], &mut x));
    result.expect("a prediction");
    assert_eq!(allocations, 0);
    assert_eq!(x, [0.0, 0.0, 0.0, 1.0, -1.0, -2.0, -3.0], "the second block scores higher");
    // 15 outputs are neither 7, nor scored blocks of 8, nor blocks of 7.
    assert!(LearnedStart::new(network(vec![0.1; 15]), layout).is_err());
}

/// A network that outputs another representation: two scored hypotheses of 3 numbers
/// `[angle, tx, ty]`, decoded into the 7 unknowns `[q, t]` (a rotation about z and `t_z = 0`).
/// `predict` decodes the better-scored one without allocating; a block the decoding refuses is
/// `NoDecoding` naming the hypothesis; a network of blocks of the unknowns' width is refused.
#[test]
fn a_learned_start_with_its_own_output_decoding_decodes_the_best_hypothesis() {
    use simhc::pipeline::{LayoutRows, LearnedStart, OutputDecoding};
    use simhc::regressor::{DenseLayer, FoldedNetwork, HypothesisBlocks, RegressorError};
    struct AngleAndShift;
    impl OutputDecoding for AngleAndShift {
        fn width(&self) -> usize {
            3
        }
        fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
            if out.len() != 3 || x.len() != 7 || out[0].abs() > 10.0 {
                return false;
            }
            let h = out[0] / 2.0;
            x.copy_from_slice(&[h.cos(), 0.0, 0.0, h.sin(), out[1], out[2], 0.0]);
            true
        }
    }
    let layout = quat_and_vector_layout(2);
    let network = |bias: Vec<f32>| {
        let point = DenseLayer::new(3, 4, vec![0.0; 12], vec![0.0; 4]).unwrap();
        let head = DenseLayer::new(4, bias.len(), vec![0.0; 4 * bias.len()], bias).unwrap();
        FoldedNetwork::new(3, vec![point], vec![head], false).unwrap()
    };
    let p = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    // Scores 0.5 and 1.5: the second block wins.
    let start =
        LearnedStart::with_outputs(network(vec![0.0, 9.0, 9.0, 1.0, 2.0, 3.0, 0.5, 1.5]), layout, LayoutRows(layout), AngleAndShift)
            .expect("blocks of 3 and their scores");
    assert_eq!(start.blocks(), HypothesisBlocks { width: 3, count: 2, scored: true });
    let mut x = [0.0; 7];
    let (result, allocations) = counted(|| start.predict(&p, &mut x));
    result.expect("a prediction");
    assert_eq!(allocations, 0);
    let expect = [0.5f64.cos(), 0.0, 0.0, 0.5f64.sin(), 2.0, 3.0, 0.0];
    assert!(x.iter().zip(&expect).all(|(a, b)| (a - b).abs() < 1e-6), "{x:?}");
    // The winner decodes to nothing (an angle the decoding refuses).
    let refused =
        LearnedStart::with_outputs(network(vec![0.0, 9.0, 9.0, 50.0, 2.0, 3.0, 0.5, 1.5]), layout, LayoutRows(layout), AngleAndShift)
            .unwrap();
    assert_eq!(refused.predict(&p, &mut x), Err(RegressorError::NoDecoding { hypothesis: 1 }));
    // Seven outputs are not blocks of 3 (and scores).
    assert!(LearnedStart::with_outputs(network(vec![0.1; 7]), layout, LayoutRows(layout), AngleAndShift).is_err());
}

#[test]
fn certifying_does_not_allocate() {
    use simhc::certify::{certify, certify_rows, choose_rows};
    let (_, n) = counted(|| vec![1u8; 16]);
    assert!(n >= 1, "counting allocator is not armed");
    let mut rng = rng(701);
    let p = quad4_params(&mut rng);
    let x = quad4_solution(&p);
    let (cert, n) = counted(|| certify::<Quad4, 4, 4, Q4_NP>(&x, &p));
    // `x` is the root rounded to f64: within the certified error bound of the exact one.
    assert!(cert.expect("a simple root certifies").error_bound() < 1e-12);
    assert_eq!(n, 0, "certify: {n} allocations");
    // Chosen rows of the overdetermined 3 x 2 at its known root.
    let q = over_params(&mut rng);
    let y = Vector2::new(q[15], q[16]);
    let (cert, n) =
        counted(|| choose_rows::<Over3x2, 2, 3, O_NP>(&y, &q).and_then(|rows| certify_rows::<Over3x2, 2, 3, O_NP>(&y, &q, &rows)));
    assert!(cert.expect("a simple root certifies").encloses(&y));
    assert_eq!(n, 0, "choose_rows + certify_rows: {n} allocations");
}
