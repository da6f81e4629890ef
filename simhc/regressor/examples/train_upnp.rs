//! Trains the shipped UPnP regressor with the default configuration and writes
//! `problems/weights/upnp.bpk` (burn) and `problems/weights/upnp.folded` (runtime format).
//!
//! `cargo run --release -p simhc-regressor --example train_upnp [-- OUT_DIR]`

use burn::prelude::*;
use simhc::regressor::FoldedNetwork;
use simhc_regressor::upnp::{evaluate_scenes, train_upnp, UpnpTrainConfig};
use simhc_regressor::{export_folded, predict};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights")
        });
    let config = UpnpTrainConfig::default();
    println!("seed {}", config.train.seed);
    println!(
        "training scenes {} (validation {} from seed {}), epochs {}, batch {}, lr {:e} -> {:e}",
        config.train_samples,
        config.valid_samples,
        config.valid_first_seed,
        config.train.epochs,
        config.train.batch_size,
        config.train.learning_rate,
        config.train.final_learning_rate
    );
    println!("model {:?}", config.model);
    let trained = train_upnp(&config)?;
    let r = &trained.report;
    println!("parameters {}", trained.model.num_params());
    println!("data generation {:.1} s", trained.data_seconds);
    println!(
        "training {:.1} s ({} steps, {:.0} samples/s)",
        r.train_seconds,
        r.steps,
        (r.steps * config.train.batch_size) as f64 / r.train_seconds
    );
    let losses: Vec<String> = r.epoch_losses.iter().map(|l| format!("{l:.4}")).collect();
    println!("epoch losses {}", losses.join(" "));
    println!("validation (burn, batched): {}", r.valid);

    std::fs::create_dir_all(&out_dir)?;
    let bpk = out_dir.join("upnp.bpk");
    trained.model.clone().save_file(&bpk)?;
    let folded_bytes = export_folded(&trained.model);
    let folded_path = out_dir.join("upnp.folded");
    std::fs::write(&folded_path, &folded_bytes)?;
    println!("wrote {} and {}", bpk.display(), folded_path.display());

    let folded = FoldedNetwork::from_bytes(&folded_bytes)?;
    let stats = evaluate_scenes(
        &config.scene,
        config.valid_samples,
        config.valid_first_seed,
        |rows| {
            let mut q = [0.0; 4];
            folded.forward(rows, &mut q).expect("valid rows");
            q
        },
    );
    println!("validation (folded, batch 1): {stats}");
    let device = Device::flex();
    let stats = evaluate_scenes(&config.scene, 200, config.valid_first_seed, |rows| {
        let q = predict(&trained.model, rows, config.scene.points, &device);
        [q[0], q[1], q[2], q[3]].map(f64::from)
    });
    println!("validation (burn, batch 1, first 200): {stats}");
    Ok(())
}
