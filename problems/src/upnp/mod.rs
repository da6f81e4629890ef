//! Generalized absolute pose via UPnP.
pub mod geometry;
pub mod scene;
