//! The paper's geometric online simulator as the GRPS instances' own
//! [`simhc::OnlineSimulator`] (`#[simhc_problem(simulator = custom)]`): every first-view
//! bearing `f` is replaced by the ray that the start pose `x0 = [q, t, s]` sees
//! ([`super::geometry::simulate_ray`]), so that `x0` solves the start problem exactly and only
//! the `f` change along the path. The generic minimum-norm simulator spreads its correction
//! over all twelve numbers of every row instead.

use super::geometry::simulate_ray;
use super::pose::GrpsPose;
use super::{correspondence_of_row, Grps7, Grps8, ROW_LEN};
use nalgebra::SVector;
use simhc::{OnlineSimulator, SimulatorError};

/// The start parameters of the geometric simulator for the `rows` correspondences of `p`.
fn geometric<const NP: usize>(rows: usize, x0: &SVector<f64, 8>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError> {
    let start = GrpsPose::from_unknowns(x0).ok_or(SimulatorError::NonFinite)?;
    let mut p0 = *p;
    for row in p0.as_mut_slice().chunks_exact_mut(ROW_LEN).take(rows) {
        let c = correspondence_of_row(row);
        let (f, _) = simulate_ray(&start.rotation, &start.translation, start.scale, &c).ok_or(SimulatorError::Singular)?;
        row[..3].copy_from_slice(f.as_slice());
    }
    Ok(p0)
}

impl OnlineSimulator<8, 8, 84> for Grps7 {
    fn simulate(&self, x0: &SVector<f64, 8>, p: &SVector<f64, 84>) -> Result<SVector<f64, 84>, SimulatorError> {
        geometric(7, x0, p)
    }
}

impl OnlineSimulator<8, 9, 96> for Grps8 {
    fn simulate(&self, x0: &SVector<f64, 8>, p: &SVector<f64, 96>) -> Result<SVector<f64, 96>, SimulatorError> {
        geometric(8, x0, p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grps::scene::GrpsSceneConfig;
    use crate::grps::{rows_of, unknowns_of};
    use simhc::{MinNormSimulator, Problem};

    /// The start pose solves the simulated problem exactly, only the first-view bearings
    /// change, and the result differs from the generic simulator's (so a test of the custom
    /// simulator cannot pass on the generic one).
    #[test]
    fn the_start_pose_solves_the_geometric_start_problem_and_only_f_moves() {
        for seed in 0..20 {
            let scene = GrpsSceneConfig::default().sample_seeded(seed).expect("valid config");
            let corrs = &scene.correspondences[..8];
            let p = Grps8::params(&rows_of::<8>(corrs).expect("8 rows"));
            let truth = unknowns_of(&scene.rotation, &scene.translation, scene.scale);
            // A start pose away from the truth, its quaternion of unit norm (the generic
            // simulator needs the parameter-free equation to hold).
            let mut x0 = truth;
            x0[1] += 0.05;
            x0[4] += 0.1;
            x0[7] *= 1.1;
            let n = x0.fixed_rows::<4>(0).norm();
            x0.fixed_rows_mut::<4>(0).scale_mut(1.0 / n);
            let p0 = Grps8.simulate(&x0, &p).expect("geometric start");
            let mut f = SVector::<f64, 9>::zeros();
            Grps8::residual(&x0, &p0, &mut f);
            assert!(f.amax() < 1e-12, "seed {seed}: residual {}", f.amax());
            for (r, (row0, row)) in p0.as_slice().chunks(ROW_LEN).zip(p.as_slice().chunks(ROW_LEN)).enumerate() {
                assert_eq!(row0[3..], row[3..], "seed {seed}, row {r}: only f moves");
                assert!((row0[..3].iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-12, "unit bearing");
            }
            let generic = MinNormSimulator::<Grps8>::new().simulate(&x0, &p).expect("generic start");
            assert!((generic - p0).amax() > 1e-6, "seed {seed}: the geometric start equals the generic one");
        }
    }

    #[test]
    fn a_non_finite_start_is_an_error() {
        let p = SVector::<f64, 84>::from_element(0.5);
        assert_eq!(Grps7.simulate(&SVector::from_element(f64::NAN), &p), Err(SimulatorError::NonFinite));
    }
}
