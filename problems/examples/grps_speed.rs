//! Times the shipped GRPS solver alone (no other rows interleaved, so its network stays in
//! cache) on the benchmark's 1000 noise-free 8-point scenes (seed 1): median, p90, mean.
//!
//! `cargo run --release -p simhc-problems --example grps_speed`

use rand::SeedableRng;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::solver::*;
use std::time::Instant;
fn main() {
    let solver = GrpsSolver::new().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let scenes: Vec<_> = (0..1000).map(|_| GrpsSceneConfig::default().sample(&mut rng).unwrap()).collect();
    for round in 0..2 {
        let mut t: Vec<f64> = scenes.iter().map(|s| { let t0 = Instant::now(); let _ = std::hint::black_box(solver.solve_report(&s.correspondences)); t0.elapsed().as_secs_f64() * 1e6 }).collect();
        let mean = t.iter().sum::<f64>() / t.len() as f64;
        t.sort_by(f64::total_cmp);
        println!("round {round}: shipped solver alone, 1000 noise-free 8-pt scenes: median {:.1} us, p90 {:.1} us, mean {:.1} us", t[500], t[900], mean);
    }
}
