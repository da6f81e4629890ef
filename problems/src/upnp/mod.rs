//! Generalized absolute pose via UPnP: declaration, scene sampler, cost matrix, simulator.
pub mod estimate;
pub mod features;
pub mod geometry;
pub mod instance;
pub mod learned;
pub mod linear;
pub mod pose;
pub mod refine;
pub mod scene;
pub mod simulator;
mod system;

pub use system::upnp::*;

use nalgebra::{SMatrix, SVector};

/// The parameter vector of [`Upnp`] (upper triangle of `M`, row by row) from the cost matrix.
pub fn params_of(m: &SMatrix<f64, 11, 11>) -> SVector<f64, 66> {
    let mut globals = Globals::default();
    for i in 0..11 {
        for j in 0..11 {
            globals.m[i][j] = m[(i, j)];
        }
    }
    Upnp::params(&globals)
}
