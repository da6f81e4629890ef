//! The generic RANSAC loop on a toy problem (a 2D line through two points) with outliers:
//! recovery, adaptive stopping, refinement, determinism and edge cases. Seeds fixed and printed.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::ransac::{ransac, required_iterations, Estimator, RansacOptions};

/// A line `a x + b y = c` with `a² + b² = 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Line {
    a: f64,
    b: f64,
    c: f64,
}

struct LineEstimator {
    refine: bool,
}

impl Estimator for LineEstimator {
    type Datum = (f64, f64);
    type Model = Line;

    fn sample_size(&self) -> usize {
        2
    }

    fn solve(&self, data: &[(f64, f64)], indices: &[usize], out: &mut Vec<Line>) {
        let (p, q) = (data[indices[0]], data[indices[1]]);
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let n = (dx * dx + dy * dy).sqrt();
        if n > 1e-12 {
            let (a, b) = (-dy / n, dx / n);
            out.push(Line { a, b, c: a * p.0 + b * p.1 });
        }
    }

    fn residual(&self, m: &Line, d: &(f64, f64)) -> f64 {
        (m.a * d.0 + m.b * d.1 - m.c).abs()
    }

    /// Total least squares on the inliers.
    fn refine(&self, _m: &Line, data: &[(f64, f64)], inliers: &[usize]) -> Option<Line> {
        if !self.refine {
            return None;
        }
        let n = inliers.len() as f64;
        let (mx, my) = inliers.iter().fold((0.0, 0.0), |(x, y), &i| (x + data[i].0 / n, y + data[i].1 / n));
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for &i in inliers {
            let (x, y) = (data[i].0 - mx, data[i].1 - my);
            sxx += x * x;
            sxy += x * y;
            syy += y * y;
        }
        // normal = eigenvector of the smaller eigenvalue of the scatter matrix
        let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (a, b) = (-theta.sin(), theta.cos());
        Some(Line { a, b, c: a * mx + b * my })
    }
}

/// Points on `y = 0.5 x + 1` with noise in [-0.01, 0.01], a fraction replaced by uniform
/// outliers in [-10, 10]².
fn data(n: usize, outliers: f64, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            if rng.random::<f64>() < outliers {
                (rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0))
            } else {
                let x = rng.random_range(-10.0..10.0);
                (x, 0.5 * x + 1.0 + rng.random_range(-0.01..0.01))
            }
        })
        .collect()
}

fn angle_error(m: &Line) -> f64 {
    // true normal (-0.5, 1) / |.|
    let (ta, tb) = (-0.5 / 1.25f64.sqrt(), 1.0 / 1.25f64.sqrt());
    (m.a * tb - m.b * ta).abs()
}

#[test]
fn recovers_a_line_with_half_outliers() {
    let seed = 5;
    println!("seed {seed}");
    let pts = data(300, 0.5, seed);
    let options = RansacOptions { threshold: 0.03, seed, ..RansacOptions::default() };
    let r = ransac(&LineEstimator { refine: true }, &pts, &options).expect("a model");
    assert!(angle_error(&r.model) < 1e-3, "{:?}", r.model);
    assert!(r.inliers.len() > 120 && r.inliers.len() < 180, "{} inliers", r.inliers.len());
    // adaptive stopping: 50 % inliers, samples of 2 -> about 17 iterations, far below 200
    assert!(r.iterations < 60, "{} iterations", r.iterations);
    assert!(r.inliers.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn refinement_does_not_lose_inliers_and_runs_are_deterministic() {
    let seed = 8;
    println!("seed {seed}");
    let pts = data(200, 0.3, seed);
    let options = RansacOptions { threshold: 0.03, seed, ..RansacOptions::default() };
    let plain = ransac(&LineEstimator { refine: false }, &pts, &RansacOptions { refine_rounds: 0, ..options }).unwrap();
    let refined = ransac(&LineEstimator { refine: true }, &pts, &options).unwrap();
    assert!(!plain.refined);
    assert!(refined.inliers.len() >= plain.inliers.len());
    assert_eq!(ransac(&LineEstimator { refine: true }, &pts, &options).unwrap(), refined);
}

#[test]
fn edge_cases() {
    let est = LineEstimator { refine: true };
    assert!(ransac(&est, &[(0.0, 0.0)], &RansacOptions::default()).is_none(), "fewer data than a sample");
    // all points identical: no hypothesis is ever produced
    assert!(ransac(&est, &[(1.0, 1.0); 10], &RansacOptions::default()).is_none());
    // the iteration cap holds when the inlier ratio is tiny
    let pts = data(100, 0.97, 3);
    let r = ransac(&est, &pts, &RansacOptions { max_iterations: 25, threshold: 1e-6, ..RansacOptions::default() });
    assert!(r.is_some_and(|r| r.iterations <= 25));
    assert_eq!(required_iterations(0.5, 2, 0.99), 17);
}

#[test]
fn poselib_defaults_run_at_least_their_minimum_and_report_what_they_did() {
    let seed = 9;
    println!("seed {seed}");
    let pts = data(200, 0.4, seed);
    let options = RansacOptions { seed, ..RansacOptions::poselib(0.03) };
    let r = ransac(&LineEstimator { refine: true }, &pts, &options).expect("a model");
    // 60 % inliers and pairs need about 10 samples; PoseLib's minimum is 1000.
    assert_eq!(r.iterations, 1000);
    assert!(angle_error(&r.model) < 1e-3, "{:?}", r.model);
    assert_eq!(r.inlier_mask.len(), pts.len());
    assert_eq!(r.inlier_mask.iter().filter(|m| **m).count(), r.inliers.len());
    assert!(r.inliers.iter().all(|&i| r.inlier_mask[i]));
    assert!((r.inlier_ratio() - r.inliers.len() as f64 / 200.0).abs() < 1e-15);
    assert!(r.refinements >= 1, "local optimization on every new best model keeps at least one refinement");
    assert!(r.score > 0.0 && r.score <= 200.0 * 0.03 * 0.03);
}
