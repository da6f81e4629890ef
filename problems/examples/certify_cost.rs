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
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::solver::GrpsSolver;
use simhc_problems::grps::{unknowns_of, Grps7, Grps8};
use simhc_problems::metrics::quat_from_rotation;
use simhc_problems::upnp::geometry::upnp_system;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_problems::upnp::solver::UpnpSolver;
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

    let solver = UpnpSolver::new().expect("shipped weights load");
    let config = UpnpSceneConfig { noise_px: noise, ..UpnpSceneConfig::default() };
    let mut upnp = Row::default();
    for seed in 0..trials as u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let t = Instant::now();
        let pose = solver.solve(black_box(&scene.correspondences));
        let solve = t.elapsed().as_secs_f64() * 1e6;
        let Ok(pose) = pose else { continue };
        upnp.solved += 1;
        upnp.solve_us.push(solve);
        // The parameters are the solver's input, built before it runs: not part of the cost.
        let p = upnp_params(&upnp_system(&scene.correspondences).expect("valid scene").m);
        let x = SVector::<f64, 4>::from(pose.quaternion);
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

    let solver = GrpsSolver::new().expect("shipped weights load");
    let config = GrpsSceneConfig { noise_px: noise, ..GrpsSceneConfig::default() };
    let (mut data, mut tracked) = (Row::default(), Row::default());
    for seed in 0..trials as u64 {
        let scene = config.sample_seeded(seed).expect("valid config");
        let t = Instant::now();
        let pose = solver.solve(black_box(&scene.correspondences));
        let solve = t.elapsed().as_secs_f64() * 1e6;
        let Ok(pose) = pose else { continue };
        let truth = unknowns_of(&scene.rotation, &scene.translation, scene.scale);
        let p8 = grps_params::<96>(&scene.correspondences).expect("8 correspondences");
        let p7 = grps_params::<84>(&scene.correspondences[..7]).expect("7 correspondences");
        let x = pose.unknowns();
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
    }
    data.print("grps8 (rows chosen)", trials, noise);
    tracked.print("grps8 as Grps7 (first 7)", trials, noise);
}
