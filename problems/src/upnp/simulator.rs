//! The paper's geometric simulator for UPnP: the correspondences' bearings reprojected under a
//! start pose, so that the start solves the simulated cost exactly.

use super::geometry::{reproject_in_place, upnp_system, UpnpError, UpnpSystem};
use super::scene::UpnpCorrespondence;
use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// The cost matrix of the correspondences reprojected under `(R(q0), t*(q0))`; `q0` then solves
/// the start system exactly (its simulated cost is zero).
pub fn simulate(target: &UpnpSystem, corrs: &[UpnpCorrespondence], q0: [f64; 4]) -> Result<SMatrix<f64, 11, 11>, UpnpError> {
    reprojected_cost(&rotation_from_quat(q0), &target.translation(q0), corrs)
}

/// The cost matrix of the correspondences with their bearings reprojected under `(r, t)`,
/// which `(r, t)` then solves exactly.
pub fn reprojected_cost(r: &Matrix3<f64>, t: &Vector3<f64>, corrs: &[UpnpCorrespondence]) -> Result<SMatrix<f64, 11, 11>, UpnpError> {
    let mut simulated = corrs.to_vec();
    reproject_in_place(r, t, &mut simulated)?;
    Ok(upnp_system(&simulated)?.m)
}
