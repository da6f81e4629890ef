//! When a GRPS end point is a solution: [`Validation`] of a pose on all correspondences and
//! [`GrpsValidator`], its thresholds for exact and for noisy data.
//!
//! An end point is accepted at once when its largest angular residual
//! ([`super::refine::angular_residual`]) is at most `accept_angle` (an exact root) with `s > 0`
//! and every triangulated point in front of both cameras; *plausible* when at most
//! `plausible_angle` with at most `max_behind` points behind a camera (the pipeline then makes
//! its extra attempts and keeps the best). Why: with 8 correspondences there is one redundant
//! equation, and wrong least-squares points of failed paths have residuals of 1e-4 .. 1e-3
//! (measured), so only exactness (noise-free) or comparison (noisy) tells them from the truth.

use super::geometry::triangulate_depths;
use super::pose::GrpsPose;
use super::refine::angular_residual;
use super::scene::GrpsCorrespondence;
use nalgebra::SVector;
use simhc::pipeline::{Validator, Verdict};

/// How well an end point explains the correspondences.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Validation {
    /// Largest angular residual over the correspondences ([`angular_residual`]).
    pub max_angle: f64,
    /// Correspondences whose triangulated point is behind one of its cameras (or undefined).
    pub behind: usize,
    /// `s > 0`.
    pub positive_scale: bool,
}

impl Validation {
    /// Validates `pose` on `corrs`.
    pub fn of(pose: &GrpsPose, corrs: &[GrpsCorrespondence]) -> Self {
        let (r, t, s) = (&pose.rotation, &pose.translation, pose.scale);
        let mut max_angle = 0.0f64;
        let mut behind = 0;
        for c in corrs {
            let a = angular_residual(r, t, s, c).abs();
            max_angle = if a.is_nan() { f64::INFINITY } else { max_angle.max(a) };
            match triangulate_depths(r, t, s, c) {
                Some((a1, a2)) if a1 > 0.0 && a2 > 0.0 => {}
                _ => behind += 1,
            }
        }
        Self { max_angle, behind, positive_scale: s > 0.0 }
    }

    /// Whether the end point has `s > 0`, at most `max_behind` points behind a camera and a
    /// residual of at most `angle`.
    pub fn passes(&self, angle: f64, max_behind: usize) -> bool {
        self.positive_scale && self.behind <= max_behind && self.max_angle <= angle
    }

    /// Ordering key of candidates: fewer violations first, then the smaller residual.
    pub fn key(&self) -> (usize, f64) {
        (self.behind + usize::from(!self.positive_scale) * 1000, self.max_angle)
    }
}

/// Largest angular residual of an exact root (noise-free data): accepted at once.
pub const ACCEPT_ANGLE: f64 = 1e-9;

/// Largest angular residual of a plausible end point on noise-free data.
pub const EXACT_PLAUSIBLE_ANGLE: f64 = 1e-6;

/// [`Validation`] on every correspondence, with thresholds for the data's noise: of a slice of
/// correspondences or of a parameter vector ([`super::declared::GrpsProblem`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsValidator {
    /// Accepted at once at most this residual, no point behind a camera.
    pub accept_angle: f64,
    /// Plausible at most this residual.
    pub plausible_angle: f64,
    /// Points allowed behind a camera in a plausible end point.
    pub max_behind: usize,
}

impl Default for GrpsValidator {
    /// For noise-free data: [`ACCEPT_ANGLE`], [`EXACT_PLAUSIBLE_ANGLE`], no point behind.
    fn default() -> Self {
        Self { accept_angle: ACCEPT_ANGLE, plausible_angle: EXACT_PLAUSIBLE_ANGLE, max_behind: 0 }
    }
}

impl GrpsValidator {
    /// For bearing noise of `noise_px` pixels at focal length `focal_px`: plausible end points
    /// up to `max(1e-3, 10 noise_px / focal_px)`, two points behind a camera allowed (with
    /// noise the least-squares depth of a far point, nearly parallel rays, can change sign);
    /// the exact thresholds for `noise_px <= 0`.
    pub fn for_noise(noise_px: f64, focal_px: f64) -> Self {
        if noise_px > 0.0 {
            Self { plausible_angle: (10.0 * noise_px / focal_px).max(1e-3), max_behind: 2, ..Self::default() }
        } else {
            Self::default()
        }
    }

    /// The validation of the unknowns `x` on `corrs`.
    pub fn check_slice(&self, corrs: &[GrpsCorrespondence], x: &SVector<f64, 8>) -> Validation {
        match GrpsPose::from_unknowns(x) {
            Some(pose) => Validation::of(&pose, corrs),
            None => Validation { max_angle: f64::INFINITY, behind: corrs.len(), positive_scale: false },
        }
    }

    fn verdict_of(&self, v: &Validation) -> Verdict {
        if v.passes(self.accept_angle, 0) {
            Verdict::Accept
        } else if v.passes(self.plausible_angle, self.max_behind) {
            Verdict::Plausible
        } else {
            Verdict::Reject
        }
    }
}

impl Validator<[GrpsCorrespondence], 8> for GrpsValidator {
    type Check = Validation;

    fn check(&self, corrs: &[GrpsCorrespondence], x: &SVector<f64, 8>) -> Validation {
        self.check_slice(corrs, x)
    }
    fn verdict(&self, v: &Validation) -> Verdict {
        self.verdict_of(v)
    }
    fn better(&self, a: &Validation, b: &Validation) -> bool {
        a.key() < b.key()
    }
}

/// Of a parameter vector of up to 8 correspondences (`NP / 12`; more validate nothing).
impl<const NP: usize> Validator<SVector<f64, NP>, 8> for GrpsValidator {
    type Check = Validation;

    fn check(&self, p: &SVector<f64, NP>, x: &SVector<f64, 8>) -> Validation {
        let n = NP / super::ROW_LEN;
        if n > 8 {
            return Validation { max_angle: f64::INFINITY, behind: n, positive_scale: false };
        }
        let mut corrs = [GrpsCorrespondence::default(); 8];
        for (c, row) in corrs.iter_mut().zip(p.as_slice().chunks_exact(super::ROW_LEN)) {
            *c = super::correspondence_of_row(row);
        }
        self.check_slice(&corrs[..n], x)
    }
    fn verdict(&self, v: &Validation) -> Verdict {
        self.verdict_of(v)
    }
    fn better(&self, a: &Validation, b: &Validation) -> bool {
        a.key() < b.key()
    }
}
