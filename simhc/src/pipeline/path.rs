//! One Simulator HC attempt: the simulated start problem, the straight line in coefficient
//! form to the target, the adaptive tracker (stage 3 of the paper).

use super::{AttemptError, StageTimes, StartSimulator};
use crate::homotopy::CoefficientLine;
use crate::tracker::{track, TrackStats, TrackerOptions};
use crate::CoefficientForm;
use nalgebra::SVector;
use std::time::Instant;

/// Tracks `x0` from the simulated start problem to the target parameters `p`; adds the
/// simulator's and the tracker's time to `times`.
pub fn simulator_hc<P, D, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(
    data: &D,
    simulator: &S,
    x0: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    tracker: &TrackerOptions,
    times: &mut StageTimes,
) -> Result<(SVector<f64, NX>, TrackStats), AttemptError>
where
    P: CoefficientForm<NX, NF, NP, NC>,
    D: ?Sized,
    S: StartSimulator<D, NX, NF, NP> + ?Sized,
{
    let ts = Instant::now();
    let p0 = simulator.simulate(data, x0, p);
    times.simulator += ts.elapsed();
    let p0 = p0?;
    let tt = Instant::now();
    let h = CoefficientLine::<P, f64, NP, NC>::new::<NX, NF>(&p0, p);
    let result = track(&h, x0, tracker);
    times.tracking += tt.elapsed();
    let result = result?;
    Ok((result.x, result.stats))
}
