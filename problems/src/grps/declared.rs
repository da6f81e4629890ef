//! GRPS as a declared problem ([`simhc::solver::DeclaredProblem`]): the same compiled
//! instances, shipped weights, canonical frames, geometric simulator and all-roots start system
//! as [`super::solver::GrpsSolver`], assembled by the runtime's generic [`Solver`] instead of by
//! hand. `simhc bench grps8` runs it beside `simhc bench grps` (the hand-assembled solver),
//! so the two assemblies are compared on the same trials.
//!
//! - tracked and data instance [`Grps8`]: measured, one path on all 8 correspondences
//!   validates more often than one on the square first 7 (81 against 53 % with the geometric
//!   simulator, `simhc bench grps --experiment stability`), although its intermediate systems
//!   are inconsistent;
//! - the tracked instance's own simulator is the geometric one (`simulator = custom`,
//!   [`super::simulator`]); the minimum-norm one is the other simulator;
//! - the learned start reads [`GrpsFrame`] rows of the canonical data and decodes a 6D
//!   rotation, the translation and the log scale ([`GrpsOutputs`]);
//! - the other starts are the network's predicted rotation with least-squares `(t, s)`, and the
//!   network on the swapped views ([`PredictedStart`]).
//!
//! What the hand-assembled solver has and this one has not: the 65 rotated restarts, the
//! least-squares `(t, s)` of a predicted rotation, and the ranking of hypotheses by
//! [`super::refine::rotation_residual`]. They are the measured differences in BENCHMARKS.md.
//!
//! [`Solver`]: simhc::solver::Solver

use super::features::{swap_pose, swap_views, GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use super::refine::{angular_residual, translation_scale_for_rotation};
use super::scene::{GrpsCorrespondence, GrpsScene, GrpsSceneConfig};
use super::solver::{GrpsPose, GrpsSolver, GrpsSolverOptions, GrpsValidator, GRPS_WEIGHTS};
use super::{correspondence_of_row, correspondences_of, rows_of, unknowns_of, Grps8, ROW_LEN};
use crate::metrics::{random_unit_quaternion, rotation_error_deg, rotation_from_quat, scale_error_pct, translation_error_pct};
use crate::start_systems::{run_monodromy_grps7, solve_grps7};
use nalgebra::{Matrix3, SVector, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::all_roots::AllRootsOptions;
use simhc::pipeline::path::gauss_newton;
use simhc::pipeline::{Generic, InputRows, OutputDecoding, StartError, StartProvider};
use simhc::solver::{AllRoots, CanonicalFrame, DeclaredProblem, OtherSimulator, OtherStart, Refinement};
use simhc::start_system::{MonodromyConfig, MonodromyReport, StartSystemError};
use simhc::MinNormSimulator;

/// Data parameters: 8 correspondences of 12 numbers.
pub type Params = SVector<f64, 96>;
/// Unknowns `[q, t, s]`.
pub type Unknowns = SVector<f64, 8>;

/// GRPS on 8 correspondences through the generic assembly (module docs).
pub struct Grps8Problem {
    all_roots: GrpsAllRoots,
    outputs: GrpsOutputs,
    rows: GrpsRows,
}

impl Grps8Problem {
    /// The problem with the shipped start system.
    pub fn new() -> Self {
        Self { all_roots: GrpsAllRoots, outputs: GrpsOutputs, rows: GrpsRows }
    }
}

impl Default for Grps8Problem {
    fn default() -> Self {
        Self::new()
    }
}

/// The 8 correspondences of a data vector, on the stack.
fn correspondences(p: &Params) -> [GrpsCorrespondence; 8] {
    correspondences_of::<8>(p.as_slice())
}

/// The data vector of 8 correspondences.
fn params_of(corrs: &[GrpsCorrespondence]) -> Option<Params> {
    rows_of::<8>(corrs).map(|rows| Grps8::params(&rows))
}

/// Pose errors: rotation (deg), translation and scale (percent).
fn errors(x: &Unknowns, truth: &Unknowns) -> [f64; 3] {
    match (GrpsPose::from_unknowns(x), GrpsPose::from_unknowns(truth)) {
        (Some(a), Some(b)) => [
            rotation_error_deg(&a.rotation, &b.rotation),
            translation_error_pct(&a.translation, &b.translation),
            scale_error_pct(a.scale, b.scale),
        ],
        _ => [f64::INFINITY; 3],
    }
}

/// The unknowns of `(R, t, s)` mapped by `map`.
fn map_unknowns(x: &Unknowns, map: impl Fn(&Matrix3<f64>, &Vector3<f64>, f64) -> (Matrix3<f64>, Vector3<f64>, f64)) -> Unknowns {
    match GrpsPose::from_unknowns(x) {
        Some(p) => {
            let (r, t, s) = map(&p.rotation, &p.translation, p.scale);
            unknowns_of(&r, &t, s)
        }
        None => Unknowns::from_element(f64::NAN),
    }
}

/// The learned start's input rows: [`GrpsFrame`] rows of the (canonical) correspondences.
pub struct GrpsRows;

impl InputRows for GrpsRows {
    fn shape(&self) -> (usize, usize) {
        (8, GRPS_ROW_WIDTH)
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        let Ok(p) = <&[f64; 96]>::try_from(p) else { return false };
        GrpsFrame::IDENTITY.rows(&correspondences(&Params::from(*p)), out)
    }
}

/// The network's outputs `[a1, a2, t, ln s]` (a 6D rotation, the translation, the log scale)
/// as unknowns `[q, t, s]` ([`GrpsFrame::decode`] in the identity frame: the data is already
/// canonical).
pub struct GrpsOutputs;

impl OutputDecoding for GrpsOutputs {
    fn width(&self) -> usize {
        GRPS_OUTPUTS
    }
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
        let (Ok(out), true) = (<&[f64; GRPS_OUTPUTS]>::try_from(out), x.len() == 8) else { return false };
        match GrpsFrame::IDENTITY.decode(out) {
            Some((r, t, s)) => {
                x.copy_from_slice(unknowns_of(&r, &t, s).as_slice());
                true
            }
            None => false,
        }
    }
}

/// A start from the shipped network beside the learned start's own hypotheses, as in
/// [`GrpsSolver`]'s starts of the same names: the network on the swapped views (view 2 first,
/// its pose mapped back by [`swap_pose`]: a second, different input), and the predicted or
/// swapped rotation with its least-squares translation and scale. Tried only after the learned
/// hypotheses; each runs the network again and allocates (a `Vec` of correspondences).
pub struct PredictedStart {
    solver: GrpsSolver,
    /// The network on the swapped views.
    swapped: bool,
    /// Only the rotation, with its least-squares `(t, s)` (`s > 0`).
    least_squares: bool,
}

impl StartProvider<Params, 8> for PredictedStart {
    fn name(&self) -> &'static str {
        match (self.swapped, self.least_squares) {
            (false, false) => "learned",
            (false, true) => "learned rotation, least-squares (t, s)",
            (true, false) => "learned, swapped views",
            (true, true) => "learned, swapped views, rotation with least-squares (t, s)",
        }
    }
    fn start(&self, p: &Params) -> Result<Unknowns, StartError> {
        let fail = |reason: String| StartError { provider: "predicted", reason };
        let corrs = correspondences(p);
        let (r, t, s) = if self.swapped {
            let pose = self.solver.predict(&swap_views(&corrs)).map_err(|e| fail(e.to_string()))?;
            swap_pose(&pose.rotation, &pose.translation, pose.scale)
        } else {
            let pose = self.solver.predict(&corrs).map_err(|e| fail(e.to_string()))?;
            (pose.rotation, pose.translation, pose.scale)
        };
        if !self.least_squares {
            return Ok(unknowns_of(&r, &t, s));
        }
        match translation_scale_for_rotation(&r, &corrs) {
            Some((t, s)) if s > 0.0 => Ok(unknowns_of(&r, &t, s)),
            _ => Err(fail("no least-squares translation with a positive scale".into())),
        }
    }
}

/// All real roots of the first 7 correspondences from the shipped start system
/// ([`solve_grps7`]).
pub struct GrpsAllRoots;

impl AllRoots<8, 96> for GrpsAllRoots {
    fn candidates(&self, p: &Params) -> Vec<Unknowns> {
        let p7 = SVector::<f64, 84>::from_column_slice(&p.as_slice()[..84]);
        solve_grps7(&p7, &AllRootsOptions::default()).real.iter().map(|s| s.x).collect()
    }
    fn has_start_system(&self) -> bool {
        true
    }
    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
        run_monodromy_grps7(config)
    }
}

impl DeclaredProblem<8, 9, 96, { Grps8::NC }, 96> for Grps8Problem {
    type Tracked = Grps8;
    type Data = Grps8;
    type Validator = GrpsValidator;
    const NAME: &'static str = "grps8";
    const ABOUT: &'static str = "Generalized relative pose and scale, 8 correspondences, through the generic solver assembly";
    const ERRORS: &'static [&'static str] = &["E_R deg", "E_t %", "E_s %"];
    const REFINES: bool = true;

    fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (Params, Unknowns) {
        let config = GrpsSceneConfig { noise_px: noise, ..GrpsSceneConfig::default() };
        loop {
            // A config error cannot happen for a finite noise; a degenerate draw is redrawn.
            let Ok(scene) = config.sample(rng) else { continue };
            if let Some(p) = params_of(&scene.correspondences) {
                return (p, unknowns_of(&scene.rotation, &scene.translation, scene.scale));
            }
        }
    }
    fn validator(&self, noise: f64) -> GrpsValidator {
        let options = if noise > 0.0 {
            GrpsSolverOptions::for_noise(noise, GrpsSceneConfig::default().focal_px)
        } else {
            GrpsSolverOptions::default()
        };
        GrpsValidator::of(&options)
    }
    fn errors(&self, x: &Unknowns, truth: &Unknowns) -> Vec<f64> {
        errors(x, truth).to_vec()
    }
    /// The paper's criterion: `E_R < 2 deg`, `E_t < 5 %`, `E_s < 5 %`.
    fn correct(&self, e: &[f64]) -> bool {
        e.len() == 3 && e[0] < 2.0 && e[1] < 5.0 && e[2] < 5.0
    }
    fn refine(&self, p: &Params, x0: &Unknowns) -> Refinement<8> {
        gauss_newton::<Grps8, 8, 9, 96>(x0, p, &Default::default()).map(|(x, _)| x).into()
    }
    fn canonicalize(&self, p: &Params) -> Option<(Params, CanonicalFrame<8>)> {
        let corrs = correspondences(p);
        let frame = GrpsFrame::new(&corrs)?;
        let canonical = params_of(&frame.canonical(&corrs))?;
        let to_canonical = Box::new(move |x: &Unknowns| map_unknowns(x, |r, t, s| frame.to_canonical(r, t, s)));
        let to_user = Box::new(move |x: &Unknowns| map_unknowns(x, |r, t, s| frame.from_canonical(r, t, s)));
        Some((canonical, CanonicalFrame { to_canonical, to_user }))
    }
    fn input_rows(&self) -> Option<&dyn InputRows> {
        Some(&self.rows)
    }
    fn outputs(&self) -> Option<&dyn OutputDecoding> {
        Some(&self.outputs)
    }
    fn weights(&self) -> Option<&'static [u8]> {
        Some(GRPS_WEIGHTS)
    }
    /// Random rotations of both views, random offsets of their origins, and random units of
    /// view 2 (a factor in `[0.1, 10]`): [`GrpsScene::transformed`].
    fn move_frames(&self, rng: &mut ChaCha8Rng, p: &Params, x: &Unknowns) -> Option<(Params, Unknowns)> {
        let pose = GrpsPose::from_unknowns(x)?;
        let scene = GrpsScene {
            correspondences: correspondences(p).to_vec(),
            rotation: pose.rotation,
            translation: pose.translation,
            scale: pose.scale,
        };
        let mut frame = || (rotation_from_quat(random_unit_quaternion(rng)), Vector3::from_fn(|_, _| rng.random_range(-10.0..10.0)));
        let (v1, v2) = (frame(), frame());
        let units = 10f64.powf(rng.random_range(-1.0..1.0));
        let moved = scene.transformed((&v1.0, &v1.1), (&v2.0, &v2.1), units);
        Some((params_of(&moved.correspondences)?, unknowns_of(&moved.rotation, &moved.translation, moved.scale)))
    }
    /// The predicted rotation with least-squares `(t, s)`, the swapped prediction and its
    /// rotation with least-squares `(t, s)` ([`PredictedStart`]).
    fn other_starts(&self) -> Vec<OtherStart<8, 96>> {
        let Ok(solver) = GrpsSolver::new() else { return Vec::new() };
        [(false, true), (true, false), (true, true)]
            .into_iter()
            .map(|(swapped, least_squares)| {
                Box::new(PredictedStart { solver: solver.clone(), swapped, least_squares }) as OtherStart<8, 96>
            })
            .collect()
    }
    fn other_simulators(&self) -> Vec<OtherSimulator<8, 9, 96, 96>> {
        vec![Box::new(Generic(MinNormSimulator::<Grps8>::new()))]
    }
    fn all_roots(&self) -> Option<&dyn AllRoots<8, 96>> {
        Some(&self.all_roots)
    }
    /// The robust estimator's error: the angular residual of the correspondence (radians).
    fn row_error(&self, x: &Unknowns, row: &[f64], _globals: &[f64]) -> f64 {
        match (GrpsPose::from_unknowns(x), row.len() == ROW_LEN) {
            (Some(pose), true) => {
                let e = angular_residual(&pose.rotation, &pose.translation, pose.scale, &correspondence_of_row(row)).abs();
                if e.is_nan() {
                    f64::INFINITY
                } else {
                    e
                }
            }
            _ => f64::INFINITY,
        }
    }
}
