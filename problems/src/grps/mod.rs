//! Generalized relative pose and scale (GRPS): declaration, scene sampler, geometric simulator.
pub mod features;
pub mod geometry;
pub mod ransac;
pub mod refine;
pub mod scene;
pub mod solver;
mod system;

pub use system::grps::*;

use nalgebra::{Matrix3, SVector, Vector3};
use scene::GrpsCorrespondence;

impl From<&GrpsCorrespondence> for Row {
    fn from(c: &GrpsCorrespondence) -> Self {
        Row { f: c.f.into(), v: c.v.into(), fp: c.fp.into(), vp: c.vp.into() }
    }
}

/// Packs `N` correspondences as the rows of a GRPS parameter vector (`N x 12` scalars), or
/// `None` when the slice does not hold exactly `N`.
pub fn rows_of<const N: usize>(corrs: &[GrpsCorrespondence]) -> Option<[Row; N]> {
    if corrs.len() != N {
        return None;
    }
    let mut rows = [Row::default(); N];
    for (row, c) in rows.iter_mut().zip(corrs) {
        *row = Row::from(c);
    }
    Some(rows)
}

/// The solver's unknown vector `[q, t, s]` of a pose (quaternion with `q0 >= 0`).
pub fn unknowns_of(rotation: &Matrix3<f64>, translation: &Vector3<f64>, scale: f64) -> SVector<f64, 8> {
    let q = crate::metrics::quat_from_rotation(rotation);
    SVector::<f64, 8>::from([q[0], q[1], q[2], q[3], translation.x, translation.y, translation.z, scale])
}
