//! Times the all-roots solvers from the shipped start systems: GRPS7 (140 roots, 280 paths)
//! and UPnP (40), on noise-free scenes (seeds `0..N`), checking that the ground truth is among
//! the real solutions; median and mean wall time per solve on 1 thread and on rayon's pool.
//! GRPS7 also runs on one thread with the row kernel on the coefficients of the expansion
//! instead of the parameters, and with each narrower lane instruction set this CPU runs.
//!
//! ```sh
//! cargo run --release -p simhc-problems --example all_roots_speed -- 200   # 200 trials each
//! ```
//!
//! The start systems themselves are computed by `simhc monodromy grps|upnp`.

use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{self, Grps7};

/// All-roots timing on `trials` noise-free scenes per problem (see the module docs).
fn bench(trials: u64) {
    use simhc::all_roots::AllRootsOptions;
    use simhc::tracker::batch::LaneIsa;
    use simhc_problems::start_systems::{solve_grps7, solve_upnp};
    use simhc_problems::upnp::{self, geometry::upnp_cost_matrix, scene::UpnpSceneConfig};
    use std::time::Instant;
    // The default (widest instruction set, 1 and 2 threads), then GRPS7 on one thread with the
    // coefficient row kernel (`param_lanes: false`, the same paths) and with each narrower
    // instruction set this CPU runs.
    let isas = LaneIsa::ALL.into_iter().filter(|isa| isa.available()).skip(1);
    let runs = [(false, None, true), (true, None, true), (false, None, false)].into_iter().chain(isas.map(|isa| (false, Some(isa), true)));
    for (parallel, lane_isa, param_lanes) in runs {
        let options = AllRootsOptions { parallel, lane_isa, param_lanes, ..AllRootsOptions::default() };
        let threads = if parallel { rayon_threads() } else { 1 };
        let isa = lane_isa.unwrap_or_else(LaneIsa::detect);
        // GRPS7.
        let (mut times, mut found, mut paths, mut failed, mut retracked) = (Vec::new(), 0, 0, 0, 0);
        for seed in 0..trials {
            let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(seed).unwrap();
            let p = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
            let gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
            let t0 = Instant::now();
            let res = solve_grps7(&p, &options);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            found += res.closest_real(&gt).is_some_and(|(_, d)| d < 1e-6) as usize;
            paths += res.endpoints.len();
            failed += res.failed;
            retracked += res.retracked;
        }
        println!(
            "grps7 all-roots ({threads} thread{}, {isa:?} lanes{}): ground truth found {found}/{trials}, median {:.2} ms, mean {:.2} ms per solve ({} paths, {:.2} failed, {:.2} re-tracked per solve)",
            if threads == 1 { "" } else { "s" },
            if param_lanes { "" } else { ", coefficient rows" },
            median(times.clone()),
            times.iter().sum::<f64>() / times.len() as f64,
            paths / trials as usize,
            failed as f64 / trials as f64,
            retracked as f64 / trials as f64,
        );
        if lane_isa.is_some() || !param_lanes {
            continue;
        }
        // UPnP (noise-free: the global minimum is the ground truth; no path lanes).
        let (mut times, mut found) = (Vec::new(), 0);
        for seed in 0..trials {
            let scene = UpnpSceneConfig { noise_px: 0.0, ..Default::default() }.sample_seeded(seed).unwrap();
            let p = upnp::params_of(&upnp_cost_matrix(&scene.correspondences).unwrap());
            let t0 = Instant::now();
            let res = solve_upnp(&p, &options);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            let q = simhc_problems::metrics::quat_from_rotation(&scene.rotation);
            let gt = nalgebra::SVector::<f64, 5>::from([q[0], q[1], q[2], q[3], 0.0]);
            found += res.real.iter().any(|s| (0..4).all(|k| (s.x[k] - gt[k]).abs() < 1e-6)) as usize;
        }
        println!(
            "upnp  all-roots ({threads} thread{}): ground truth found {found}/{trials}, median {:.3} ms, mean {:.3} ms per solve (40 paths)",
            if threads == 1 { "" } else { "s" },
            median(times.clone()),
            times.iter().sum::<f64>() / times.len() as f64,
        );
    }
}

/// Median of a non-empty sample.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Threads of rayon's global pool.
fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn main() {
    let trials = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(100);
    println!("all-roots speed: {trials} noise-free scenes per problem, scene seeds 0..{trials}");
    bench(trials);
}
