//! What the Krawczyk certificate costs against a solve, and how often it certifies: UPnP and
//! GRPS (8 correspondences) on seeded scenes, noise-free and with bearing noise.
//!
//! `cargo run --release -p simhc-problems --example certify_cost -- [trials] [noise_px]`
//! (defaults 1000 and 0; scene seeds `0..trials`). Each solved scene is certified on the rows
//! `choose_rows` picks (UPnP: 4 of its 5 equations; GRPS: 8 of 9), and GRPS also as the square
//! tracked instance `Grps7` on its first 7 correspondences. Times are medians of single calls
//! (`Instant`), solve and certificate in the same loop. Noise-free, a certified box that misses
//! the ground truth (`±q`) is counted as wrong; with noise the truth is no root, so only the
//! certified fraction is reported.

use nalgebra::SVector;
use simhc::certify::{certify, certify_rows, choose_rows, Certificate};
use simhc_problems::grps::declared::params_of as grps_params;
use simhc_problems::grps::declared::GrpsSolvers;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{unknowns_of, Grps7, Grps8};
use simhc_problems::metrics::quat_from_rotation;
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::upnp::{params_of as upnp_params, Upnp};
use std::hint::black_box;
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn holds_truth<const N: usize>(cert: &Certificate<N>, truth: &SVector<f64, N>) -> bool {
    let mut flipped = *truth;
    for k in 0..4 {
        flipped[k] = -flipped[k];
    }
    cert.box_contains(truth) || cert.box_contains(&flipped)
}

#[derive(Default)]
struct Row {
    solved: usize,
    certified: usize,
    wrong: usize,
    solve_us: Vec<f64>,
    certify_us: Vec<f64>,
}

impl Row {
    fn print(&mut self, name: &str, trials: usize, noise: f64) {
        let (s, c) = (median(&mut self.solve_us), median(&mut self.certify_us));
        println!(
            "{name:<22} noise {noise} px: solved {}/{trials}, certified {}/{} ({:.1}%), wrong certified {}, median solve {s:.2} us, median certify {c:.2} us (ratio {:.3})",
            self.solved,
            self.certified,
            self.solved,
            100.0 * self.certified as f64 / self.solved.max(1) as f64,
            self.wrong,
            c / s
        );
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let trials: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let noise: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(0.0);
    println!("scene seeds 0..{trials}");

    let solver = UpnpLibrarySolver::new(UpnpProblem::default()).expect("shipped weights load");
    let config = UpnpSceneConfig { noise_px: noise, ..UpnpSceneConfig::default() };
    let mut upnp = Row::default();
    for seed in 0..trials as u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let t = Instant::now();
        let solution = solver.solve(black_box(&scene.correspondences[..]));
        let solve = t.elapsed().as_secs_f64() * 1e6;
        let Ok(solution) = solution else { continue };
        upnp.solved += 1;
        upnp.solve_us.push(solve);
        // The parameters are the solver's input, built before it runs: not part of the cost.
        let p = upnp_params(&upnp_system(&scene.correspondences).expect("valid scene").m);
        let x = solution.x;
        let t = Instant::now();
        let cert = choose_rows::<Upnp, 4, 5, 66>(black_box(&x), &p).and_then(|rows| certify_rows::<Upnp, 4, 5, 66>(&x, &p, &rows));
        upnp.certify_us.push(t.elapsed().as_secs_f64() * 1e6);
        if let Ok(cert) = cert {
            upnp.certified += 1;
            let truth = SVector::<f64, 4>::from(quat_from_rotation(&scene.rotation));
            upnp.wrong += usize::from(noise == 0.0 && !holds_truth(&cert, &truth));
        }
    }
    upnp.print("upnp (rows chosen)", trials, noise);

    let config = GrpsSceneConfig { noise_px: noise, ..GrpsSceneConfig::default() };
    // With noise, no end point is an exact root: the solver compares plausible ones instead.
    let solver = GrpsSolvers::new(noise).expect("shipped weights load");
    let (mut data, mut tracked, mut polished) = (Row::default(), Row::default(), Row::default());
    let mut polish_moves = Vec::new();
    for seed in 0..trials as u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let t = Instant::now();
        let pose = solver.solve(black_box(&scene.correspondences));
        let solve = t.elapsed().as_secs_f64() * 1e6;
        let Ok(solution) = pose else { continue };
        let truth = unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        let p8 = grps_params::<96>(&scene.correspondences).expect("8 correspondences");
        let p7 = grps_params::<84>(&scene.correspondences[..7]).expect("7 correspondences");
        let x = solution.x;
        for (row, which) in [(&mut data, 8), (&mut tracked, 7)] {
            row.solved += 1;
            row.solve_us.push(solve);
            let t = Instant::now();
            let cert = if which == 8 {
                choose_rows::<Grps8, 8, 9, 96>(black_box(&x), &p8).and_then(|rows| certify_rows::<Grps8, 8, 9, 96>(&x, &p8, &rows))
            } else {
                certify::<Grps7, 8, 8, 84>(black_box(&x), &p7)
            };
            row.certify_us.push(t.elapsed().as_secs_f64() * 1e6);
            if let Ok(cert) = cert {
                row.certified += 1;
                row.wrong += usize::from(noise == 0.0 && !holds_truth(&cert, &truth));
            }
        }
        // With noise the answer is a least-squares point, no root of any 8 rows: Newton on the
        // chosen rows first (explicitly: the certified point is then another point), certify that.
        if let Ok(rows) = choose_rows::<Grps8, 8, 9, 96>(&x, &p8) {
            polished.solved += 1;
            polished.solve_us.push(solve);
            let t = Instant::now();
            let y = newton_on_rows(&x, &p8, &rows);
            let cert = y.ok_or(()).and_then(|y| certify_rows::<Grps8, 8, 9, 96>(&y, &p8, &rows).map_err(|_| ()));
            polished.certify_us.push(t.elapsed().as_secs_f64() * 1e6);
            if let (Ok(cert), Some(y)) = (cert, y) {
                polished.certified += 1;
                polished.wrong += usize::from(noise == 0.0 && !holds_truth(&cert, &truth));
                polish_moves.push((y - x).amax());
            }
        }
    }
    data.print("grps8 (rows chosen)", trials, noise);
    polished.print("grps8 polished on rows", trials, noise);
    println!("  polish moved the answer by (max-norm) median {:.2e}", median(&mut polish_moves));
    tracked.print("grps8 as Grps7 (first 7)", trials, noise);
}

/// Five Newton steps on the rows `rows` of GRPS 8 from `x` (`None` if singular or non-finite).
fn newton_on_rows(x: &SVector<f64, 8>, p: &SVector<f64, 96>, rows: &[usize; 8]) -> Option<SVector<f64, 8>> {
    use simhc::Problem;
    let mut y = *x;
    for _ in 0..5 {
        let mut f = SVector::<f64, 9>::zeros();
        let mut j = nalgebra::SMatrix::<f64, 9, 8>::zeros();
        Grps8::residual_jacobian(&y, p, &mut f, &mut j);
        let g = nalgebra::SMatrix::<f64, 8, 8>::from_fn(|r, c| j[(rows[r], c)]);
        let b = SVector::<f64, 8>::from_fn(|r, _| f[rows[r]]);
        y -= g.lu().solve(&b)?;
    }
    y.iter().all(|v| v.is_finite()).then_some(y)
}
