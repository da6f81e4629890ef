//! What the commands show of a solution's certificate (`simhc::certify`): `solve`'s JSON, and
//! `bench`'s line of how many of the shipped solver's validated solutions an interval Krawczyk
//! test certifies, how many certified ones are wrong by the bench's criterion (must stay 0),
//! and the certificate's own time against the shipped solve's.

use serde::Serialize;
use simhc::certify::{Certificate, CertifyError};

/// A solution's certificate as JSON: `{"certified": true, "error_bound": .., "rows": [..]}`
/// (the equations of the square system certified), `{"certified": false, "reason": ..}`, or
/// `null` from a solver that does not certify.
pub fn json<const NX: usize>(c: &Option<Result<Certificate<NX>, CertifyError>>) -> serde_json::Value {
    match c {
        Some(Ok(c)) => serde_json::json!({ "certified": true, "error_bound": c.error_bound(), "rows": c.rows.to_vec() }),
        Some(Err(e)) => serde_json::json!({ "certified": false, "reason": e.to_string() }),
        None => serde_json::Value::Null,
    }
}

/// The certificates of a bench's validated solutions.
#[derive(Debug, Clone, Default, Serialize)]
pub struct CertificateStats {
    /// Validated solutions looked at.
    pub validated: usize,
    /// Of those, certified.
    pub certified: usize,
    /// Certified, yet wrong by the bench's success criterion.
    pub certified_wrong: usize,
    /// Median time of one certificate, microseconds.
    pub median_us: f64,
    /// `median_us` over the shipped row's median solve time (same run).
    pub ratio_to_shipped: f64,
}

impl CertificateStats {
    /// Adds one validated solution: whether it certified, whether it is correct, and the
    /// certificate's time.
    pub fn push(&mut self, certified: bool, correct: bool, micros: f64, times: &mut Vec<f64>) {
        self.validated += 1;
        self.certified += usize::from(certified);
        self.certified_wrong += usize::from(certified && !correct);
        times.push(micros);
    }

    /// Closes the tally: the median of `times` and its ratio to the shipped median.
    pub fn finish(mut self, mut times: Vec<f64>, shipped_median_us: f64) -> Self {
        times.sort_by(f64::total_cmp);
        self.median_us = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
        self.ratio_to_shipped = self.median_us / shipped_median_us;
        self
    }

    /// The bench's line.
    pub fn line(&self) -> String {
        format!(
            "certificates (interval Krawczyk, f64) of the shipped solver's validated solutions: {} of {} certified ({:.1} %), {} certified yet wrong; {:.2} us median a certificate, {:.3}x the shipped median solve",
            self.certified,
            self.validated,
            100.0 * self.certified as f64 / self.validated.max(1) as f64,
            self.certified_wrong,
            self.median_us,
            self.ratio_to_shipped
        )
    }
}
