//! Trains the shipped UPnP regressor with the default configuration and writes
//! `problems/weights/upnp.bpk` (burn) and `problems/weights/upnp.folded` (runtime format).
//! Same as `simhc train upnp`.
//!
//! `cargo run --release -p simhc-regressor --example train_upnp [-- OUT_DIR]`

use simhc_regressor::upnp::{train_and_write, UpnpTrainConfig};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights"));
    train_and_write(&out_dir, &UpnpTrainConfig::default())
}
