//! Per-method benchmark records, their summary statistics and the table / JSON output.

use serde::Serialize;

/// The outcome of one method on one trial.
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    /// Rotation error in degrees (`None` when the method returned no pose).
    pub rotation_deg: Option<f64>,
    /// Translation error in percent.
    pub translation_pct: Option<f64>,
    /// Scale error in percent (problems with a scale only).
    pub scale_pct: Option<f64>,
    /// Wall time of the solve in microseconds.
    pub micros: f64,
    /// Stage split (start, simulator, tracking) in microseconds, where the method has one.
    pub split: Option<[f64; 3]>,
    /// The method returned its pose flagged as not validated (it is scored all the same).
    pub flagged: bool,
}

/// A method's outcomes over all trials.
#[derive(Debug, Clone, Default)]
pub struct MethodRecord {
    /// Row label.
    pub name: String,
    /// One outcome per trial, in trial order.
    pub outcomes: Vec<Outcome>,
}

/// Success thresholds.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Thresholds {
    /// Rotation error below this (degrees).
    pub rotation_deg: f64,
    /// Translation error below this (percent); `None`: not required.
    pub translation_pct: Option<f64>,
    /// Scale error below this (percent); `None`: not required.
    pub scale_pct: Option<f64>,
}

/// Summary of one row.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Row label.
    pub method: String,
    /// Trials.
    pub trials: usize,
    /// Trials with no pose (typed failure).
    pub failures: usize,
    /// Success rate in percent (failures count as unsuccessful).
    pub success_pct: f64,
    /// Poses returned flagged as not validated.
    pub flagged: usize,
    /// Poses returned unflagged that miss the success thresholds: wrong answers a caller would
    /// take for right ones (methods without validation flag nothing).
    pub wrong_unflagged: usize,
    /// Mean / median rotation error over the returned poses (degrees).
    pub rotation_mean_deg: f64,
    /// Median rotation error.
    pub rotation_median_deg: f64,
    /// Mean translation error (percent).
    pub translation_mean_pct: f64,
    /// Median translation error.
    pub translation_median_pct: f64,
    /// Mean scale error (percent), problems with a scale.
    pub scale_mean_pct: Option<f64>,
    /// Median scale error.
    pub scale_median_pct: Option<f64>,
    /// Median time per solve (microseconds).
    pub time_median_us: f64,
    /// Mean time per solve.
    pub time_mean_us: f64,
    /// Median regressor / simulator / tracking time (microseconds), where split.
    pub split_median_us: Option<[f64; 3]>,
}

/// Median of a slice (NaN when empty).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Mean of a slice (NaN when empty).
pub fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        f64::NAN
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}

impl MethodRecord {
    /// A new, empty row.
    pub fn new(name: &str) -> Self {
        Self { name: name.to_string(), outcomes: Vec::new() }
    }

    /// Summary statistics with the given success thresholds.
    pub fn summary(&self, th: &Thresholds) -> Summary {
        let ok = |o: &Outcome| {
            o.rotation_deg.is_some_and(|e| e < th.rotation_deg)
                && th.translation_pct.is_none_or(|t| o.translation_pct.is_some_and(|e| e < t))
                && th.scale_pct.is_none_or(|t| o.scale_pct.is_some_and(|e| e < t))
        };
        let n = self.outcomes.len();
        let successes = self.outcomes.iter().filter(|o| ok(o)).count();
        let er: Vec<f64> = self.outcomes.iter().filter_map(|o| o.rotation_deg).collect();
        let et: Vec<f64> = self.outcomes.iter().filter_map(|o| o.translation_pct).collect();
        let es: Vec<f64> = self.outcomes.iter().filter_map(|o| o.scale_pct).collect();
        let times: Vec<f64> = self.outcomes.iter().map(|o| o.micros).collect();
        let splits: Vec<[f64; 3]> = self.outcomes.iter().filter_map(|o| o.split).collect();
        let split_median_us = (!splits.is_empty()).then(|| [0, 1, 2].map(|k| median(&splits.iter().map(|s| s[k]).collect::<Vec<_>>())));
        Summary {
            method: self.name.clone(),
            trials: n,
            failures: self.outcomes.iter().filter(|o| o.rotation_deg.is_none()).count(),
            success_pct: if n == 0 { f64::NAN } else { 100.0 * successes as f64 / n as f64 },
            flagged: self.outcomes.iter().filter(|o| o.flagged).count(),
            wrong_unflagged: self.outcomes.iter().filter(|o| o.rotation_deg.is_some() && !o.flagged && !ok(o)).count(),
            rotation_mean_deg: mean(&er),
            rotation_median_deg: median(&er),
            translation_mean_pct: mean(&et),
            translation_median_pct: median(&et),
            scale_mean_pct: (!es.is_empty()).then(|| mean(&es)),
            scale_median_pct: (!es.is_empty()).then(|| median(&es)),
            time_median_us: median(&times),
            time_mean_us: mean(&times),
            split_median_us,
        }
    }
}

/// The rows as a fixed-width text table.
pub fn table(rows: &[Summary]) -> String {
    let with_scale = rows.iter().any(|r| r.scale_mean_pct.is_some());
    let mut out = String::new();
    out.push_str(&format!(
        "{:<34} {:>7} {:>5} {:>5} {:>6} {:>9} {:>9} {:>9} {:>9}",
        "method", "succ%", "fail", "flag", "wrong", "E_R mean", "E_R med", "E_t mean", "E_t med"
    ));
    if with_scale {
        out.push_str(&format!(" {:>9} {:>9}", "E_s mean", "E_s med"));
    }
    out.push_str(&format!(" {:>10} {:>10}  {}\n", "t med us", "t mean us", "split med us (start/sim/track)"));
    for r in rows {
        out.push_str(&format!(
            "{:<34} {:>7.1} {:>5} {:>5} {:>6} {:>9.3} {:>9.3} {:>9.3} {:>9.3}",
            r.method,
            r.success_pct,
            r.failures,
            r.flagged,
            r.wrong_unflagged,
            r.rotation_mean_deg,
            r.rotation_median_deg,
            r.translation_mean_pct,
            r.translation_median_pct
        ));
        if with_scale {
            out.push_str(&format!(" {:>9.3} {:>9.3}", r.scale_mean_pct.unwrap_or(f64::NAN), r.scale_median_pct.unwrap_or(f64::NAN)));
        }
        let split = r.split_median_us.map(|s| format!("{:.1} / {:.1} / {:.1}", s[0], s[1], s[2])).unwrap_or_default();
        out.push_str(&format!(" {:>10.1} {:>10.1}  {}\n", r.time_median_us, r.time_mean_us, split));
    }
    out
}

/// Ratio of two rows' median times (`numerator / denominator`), when both rows exist.
pub fn median_time_ratio(rows: &[Summary], numerator: &str, denominator: &str) -> Option<f64> {
    let find = |name: &str| rows.iter().find(|r| r.method == name).map(|r| r.time_median_us);
    Some(find(numerator)? / find(denominator)?)
}
