//! Trains the GRPS regressor and writes `problems/weights/grps.{bpk,folded}` (or the folder
//! given as the first argument); same as `simhc train grps`. Optional further arguments:
//! training scenes, epochs and start hypotheses per prediction.
//!
//! `cargo run --release -p simhc-regressor --example train_grps [OUT_DIR [SAMPLES [EPOCHS [HYPOTHESES]]]]`

use simhc_regressor::grps::{train_and_write, GrpsTrainConfig};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).map(PathBuf::from).unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights"));
    let mut config = GrpsTrainConfig::default();
    if let Some(n) = args.get(2) {
        config.train_samples = n.parse()?;
    }
    if let Some(e) = args.get(3) {
        config.train.epochs = e.parse()?;
    }
    if let Some(k) = args.get(4) {
        config.hypotheses = k.parse()?;
        config.model = simhc_regressor::grps::grps_model(config.hypotheses);
    }
    train_and_write(&out, &config)
}
