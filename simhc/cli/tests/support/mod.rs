//! What the line-through-the-origin tests of `simhc-cli` share.

use nalgebra::SVector;
use simhc::pipeline::{Validator, Verdict};

/// Every row's residual below `1e-9`.
pub struct Residual;

impl Validator<SVector<f64, 6>, 1> for Residual {
    type Check = f64;
    fn check(&self, p: &SVector<f64, 6>, x: &SVector<f64, 1>) -> f64 {
        p.as_slice().chunks_exact(2).map(|r| (x[0] * r[0] - r[1]).abs()).fold(0.0, f64::max)
    }
    fn verdict(&self, c: &f64) -> Verdict {
        Verdict::accept_if(*c <= 1e-9)
    }
    fn better(&self, a: &f64, b: &f64) -> bool {
        a < b
    }
}
