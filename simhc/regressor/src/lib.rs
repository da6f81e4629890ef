//! Pose regression network for Simulator HC (paper section "Find a Good Starting Solution:
//! Regression Network"), trained with burn on simulated scenes.
//!
//! - [`model`]: the PointNet-style network (per-correspondence dense layers = 1D convolutions
//!   with kernel size 1, batch norm, ReLU, max-pool, fully connected head, unit quaternion);
//! - [`data`]: a generic in-memory data set built from a sample function;
//! - [`training`]: a small Adam loop with a sign-invariant quaternion loss and rotation-error
//!   validation;
//! - [`inference`]: the shipped weights, batch-1 and batched prediction, and the export to the
//!   runtime's allocation-free [`simhc::regressor::FoldedNetwork`];
//! - [`generic`]: the trainer every problem goes through ([`generic::train_with_hook`]): a
//!   problem's [`generic::FeatureHook`] turns its scenes into input rows and targets and scores
//!   predictions; a declared problem's default hook reads its layout
//!   ([`generic::train_learned_start`]);
//! - [`upnp`]: UPnP's hook (canonical frames, a quaternion) and [`upnp::train_upnp`];
//! - [`grps`]: GRPS's hook (canonical frames; 6D rotation, translation, log scale) and
//!   [`grps::train_grps`].
//!
//! Train the shipped weights with
//! `cargo run --release -p simhc-regressor --example train_upnp`.

pub mod data;
pub mod generic;
pub mod grps;
pub mod inference;
pub mod model;
pub mod training;
pub mod upnp;

pub use inference::{export_folded, fold, load_bpk_bytes, predict, predict_batch};
pub use model::{PoseRegressor, RegressorConfig};
pub use training::{RotationStats, TrainConfig, TrainReport};
pub use upnp::{train_upnp, UpnpTrainConfig, UpnpTrained};
