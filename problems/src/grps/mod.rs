//! Generalized relative pose and scale (GRPS).
pub mod geometry;
pub mod scene;
