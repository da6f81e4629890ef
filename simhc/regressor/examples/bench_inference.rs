//! Times the shipped UPnP regressor: the runtime's `FoldedNetwork` at batch 1, burn (flex) at
//! batch 1 and burn batched, on one sampled scene, single-threaded loops of wall-clock time.
//!
//! `cargo run --release -p simhc-regressor --example bench_inference`

use burn::prelude::*;
use simhc_problems::upnp::scene::UpnpSceneConfig;
use simhc_regressor::inference::{upnp_embedded, upnp_folded_embedded};
use simhc_regressor::upnp::scene_sample;
use simhc_regressor::{predict, predict_batch};
use std::hint::black_box;
use std::time::Instant;

fn time_us(iters: usize, mut f: impl FnMut()) -> f64 {
    for _ in 0..iters / 10 + 1 {
        f();
    }
    let start = Instant::now();
    for _ in 0..iters {
        f();
    }
    start.elapsed().as_secs_f64() / iters as f64 * 1e6
}

fn main() {
    let device = Device::flex();
    let model = upnp_embedded();
    let folded = upnp_folded_embedded();
    let scene = UpnpSceneConfig::default().sample_seeded(5).expect("valid config");
    let rows = scene_sample(&scene).expect("valid scene").rows;
    let points = scene.correspondences.len();
    println!("network: {} parameters", folded.num_params());
    for round in 0..3 {
        let mut q = [0.0f64; 4];
        let folded_us = time_us(200_000, || {
            folded.forward(black_box(&rows), &mut q).expect("valid rows");
            black_box(&q);
        });
        let burn_us = time_us(5_000, || {
            black_box(predict(&model, black_box(&rows), points, &device));
        });
        let batch = 256;
        let many: Vec<f32> = (0..batch).flat_map(|_| rows.iter().copied()).collect();
        let batched_us = time_us(40, || {
            black_box(predict_batch(&model, black_box(&many), batch, points, &device));
        }) / batch as f64;
        println!(
            "round {round}: FoldedNetwork batch 1: {folded_us:.2} us; burn batch 1: {burn_us:.1} us; \
             burn batch {batch}: {batched_us:.2} us per sample"
        );
    }
}
