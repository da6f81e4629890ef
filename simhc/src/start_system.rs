//! Start systems of all-roots solving: the JSON file a monodromy run writes and the all-roots
//! solve reads ([`StartSystemFile`]), the monodromy driver that makes one for any square
//! problem ([`run_monodromy`]), and the rule that picks one real solution out of many
//! ([`best_real_solution`]).
//!
//! **Layout of a file**: `params` and `solutions` are complex numbers as `[re, im]` pairs;
//! `params` uses the problem's own parameter layout (`P::params`), `symmetry` lists the
//! coordinates a sign symmetry flips (solutions are stored modulo it), and `monodromy` and
//! `notes` record how the solutions were found. The built-ins' files are under
//! `problems/data/`.

use crate::all_roots::{AllRootsResult, RealSolution, StartSystem};
use crate::monodromy::{monodromy_solve, MonodromyOptions, SignFlip, StopReason, C};
use crate::tracker::{newton, NewtonOptions};
use crate::{ParamDerivative, ProblemInfo};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use thiserror::Error;

/// Errors of reading, writing and computing start systems.
#[derive(Debug, Error)]
pub enum StartSystemError {
    /// The JSON does not parse or has the wrong shape.
    #[error("invalid start system file: {0}")]
    Format(String),
    /// Monodromy could not start.
    #[error(transparent)]
    Monodromy(#[from] crate::monodromy::MonodromyError),
    /// Writing the file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Provenance of a start system: the monodromy run that produced it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonodromyRecord {
    /// Seed of [`MonodromyOptions::seed`].
    pub seed: u64,
    /// `k` of the stopping rule (loops without a new solution).
    pub stall_loops: usize,
    /// Loops run.
    pub loops: usize,
    /// Solutions after each loop.
    pub history: Vec<usize>,
    /// Paths tracked.
    pub paths_tracked: usize,
    /// Paths that failed.
    pub paths_failed: usize,
    /// Why the loops stopped (`"stalled"`, `"target"`, `"max_loops"`).
    pub stop: String,
    /// Wall-clock seconds of the run (single thread unless noted).
    pub seconds: f64,
}

/// The JSON form of a start system (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StartSystemFile {
    /// Problem name ([`ProblemInfo::NAME`]).
    pub problem: String,
    /// Unknown names in vector order.
    pub unknowns: Vec<String>,
    /// Parameter layout, in words.
    pub parameter_layout: String,
    /// Coordinates flipped by the sign symmetry (solutions are stored modulo it).
    pub symmetry: Vec<usize>,
    /// Number of stored solutions.
    pub count: usize,
    /// Max-norm residual `max |F(x; p*)|` over the stored solutions.
    pub max_residual: f64,
    /// How the solutions were found.
    pub monodromy: MonodromyRecord,
    /// Free-form notes (independent checks).
    pub notes: Vec<String>,
    /// `p*` as `[re, im]` pairs.
    pub params: Vec<[f64; 2]>,
    /// The solutions, each as `[re, im]` pairs.
    pub solutions: Vec<Vec<[f64; 2]>>,
}

fn pairs<const N: usize>(v: &SVector<C, N>) -> Vec<[f64; 2]> {
    v.iter().map(|z| [z.re, z.im]).collect()
}

fn from_pairs<const N: usize>(v: &[[f64; 2]], what: &str) -> Result<SVector<C, N>, StartSystemError> {
    if v.len() != N {
        return Err(StartSystemError::Format(format!("{what}: {} entries, expected {N}", v.len())));
    }
    if !v.iter().flatten().all(|x| x.is_finite()) {
        return Err(StartSystemError::Format(format!("{what}: non-finite entry")));
    }
    Ok(SVector::from_fn(|i, _| C::new(v[i][0], v[i][1])))
}

impl StartSystemFile {
    /// Parses the JSON text.
    pub fn from_json(text: &str) -> Result<Self, StartSystemError> {
        serde_json::from_str(text).map_err(|e| StartSystemError::Format(e.to_string()))
    }

    /// Pretty JSON text, with every array of numbers, and every array of such arrays, on one
    /// line (one solution per line).
    pub fn to_json(&self) -> String {
        let pretty = serde_json::to_string_pretty(self).expect("plain data always serializes");
        compact_numeric_arrays(&compact_numeric_arrays(&pretty))
    }

    /// The start system with checked sizes.
    pub fn start_system<const N: usize, const NP: usize>(&self) -> Result<StartSystem<N, NP>, StartSystemError> {
        let params = from_pairs::<NP>(&self.params, "params")?;
        let solutions =
            self.solutions.iter().enumerate().map(|(i, s)| from_pairs::<N>(s, &format!("solution {i}"))).collect::<Result<Vec<_>, _>>()?;
        if solutions.len() != self.count {
            return Err(StartSystemError::Format(format!("count {} but {} solutions", self.count, solutions.len())));
        }
        let symmetry = (!self.symmetry.is_empty()).then(|| SignFlip::new(self.symmetry.clone()));
        Ok(StartSystem { params, solutions, symmetry })
    }
}

/// Joins the lines of arrays whose elements are all numbers or one-line arrays of numbers (as
/// left by a previous pass) into one line.
fn compact_numeric_arrays(pretty: &str) -> String {
    let lines: Vec<&str> = pretty.lines().collect();
    let mut out = String::with_capacity(pretty.len());
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if line.trim_end().ends_with('[') {
            // Look for a closing bracket with only numbers in between.
            let mut j = i + 1;
            let mut items = Vec::new();
            while j < lines.len() {
                let t = lines[j].trim().trim_end_matches(',');
                let flat_array = t.starts_with('[') && t.ends_with(']') && !t[1..].contains('[');
                if t.parse::<f64>().is_ok() || flat_array {
                    items.push(t);
                    j += 1;
                } else {
                    break;
                }
            }
            if j < lines.len() && !items.is_empty() && lines[j].trim().starts_with(']') {
                out.push_str(line.trim_end());
                out.push_str(&items.join(", "));
                out.push_str(lines[j].trim());
                out.push('\n');
                i = j + 1;
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
        i += 1;
    }
    out
}

/// How the benchmark picks one real solution out of many.
#[derive(Clone, Copy)]
pub enum Selection<'a, const N: usize> {
    /// Closest to a ground truth (relative max-norm, modulo the symmetry): the paper's accuracy
    /// rows ("best solution with the smallest error").
    ClosestTo(&'a SVector<f64, N>),
    /// Smallest value of a score (e.g. a reprojection error, or a rotation error for UPnP).
    MinScore(&'a dyn Fn(&SVector<f64, N>) -> f64),
    /// Smallest residual.
    SmallestResidual,
}

/// The best real solution of an all-roots result by a [`Selection`] rule.
pub fn best_real_solution<const N: usize>(result: &AllRootsResult<N>, selection: Selection<'_, N>) -> Option<RealSolution<N>> {
    match selection {
        Selection::ClosestTo(x) => result.closest_real(x).map(|(s, _)| *s),
        Selection::MinScore(f) => result.best_real_by(|s| f(&s.x)).copied(),
        Selection::SmallestResidual => result.real.first().copied(),
    }
}

/// Settings of [`run_monodromy`].
#[derive(Debug, Clone)]
pub struct MonodromyConfig {
    /// Seed of the run.
    pub seed: u64,
    /// `k`: stop after this many loops without a new solution. Default `5`.
    pub stall_loops: usize,
    /// Loops at most. Default `200`.
    pub max_loops: usize,
    /// Track in parallel (rayon).
    pub parallel: bool,
    /// Write the start system here (JSON), if set.
    pub output: Option<PathBuf>,
    /// Notes to record in the file.
    pub notes: Vec<String>,
}

impl Default for MonodromyConfig {
    fn default() -> Self {
        Self { seed: 1, stall_loops: 5, max_loops: 200, parallel: false, output: None, notes: Vec::new() }
    }
}

/// What a monodromy run found.
#[derive(Debug, Clone)]
pub struct MonodromyReport {
    /// Problem name.
    pub problem: String,
    /// Solutions found (orbits of the sign symmetry).
    pub count: usize,
    /// Solution vectors including the symmetric partners (`2 * count` with a sign symmetry).
    pub vectors: usize,
    /// The expected count from theory, if known.
    pub expected: Option<usize>,
    /// The file written, if any.
    pub written: Option<PathBuf>,
    /// The start system file (also when not written).
    pub file: StartSystemFile,
}

impl std::fmt::Display for MonodromyReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = &self.file.monodromy;
        writeln!(
            f,
            "{}: {} solutions modulo q -> -q ({} solution vectors){}",
            self.problem,
            self.count,
            self.vectors,
            match self.expected {
                Some(e) if e == self.count => format!(", as expected ({e})"),
                Some(e) => format!(", EXPECTED {e}"),
                None => String::new(),
            }
        )?;
        writeln!(
            f,
            "  {} loops (stop: {}, k = {}), {} paths tracked, {} failed, {:.2} s, max residual {:.1e}",
            m.loops, m.stop, m.stall_loops, m.paths_tracked, m.paths_failed, m.seconds, self.file.max_residual
        )?;
        write!(f, "  solutions after each loop: {:?}", m.history)?;
        if let Some(p) = &self.written {
            write!(f, "\n  written to {}", p.display())?;
        }
        Ok(())
    }
}

/// Monodromy on any square problem with a quaternion sign symmetry in `x[0..4]`, the solutions
/// polished by complex Newton at `p*`, packed as a [`StartSystemFile`] and optionally written.
pub fn run_monodromy<P, const N: usize, const NP: usize>(
    config: &MonodromyConfig,
    symmetry: Option<SignFlip>,
    parameter_layout: &str,
    expected: Option<usize>,
) -> Result<MonodromyReport, StartSystemError>
where
    P: ParamDerivative<N, N, NP> + ProblemInfo,
{
    let options = MonodromyOptions {
        seed: config.seed,
        stall_loops: config.stall_loops,
        max_loops: config.max_loops,
        parallel: config.parallel,
        symmetry: symmetry.clone(),
        ..MonodromyOptions::default()
    };
    let r = monodromy_solve::<P, N, NP>(&options)?;
    let fixed = crate::homotopy::FixedSystem::<P, C, NP>::new(r.params);
    let polish = NewtonOptions { max_iterations: 5, tolerance: 1e-15, ..NewtonOptions::default() };
    let mut solutions = Vec::with_capacity(r.solutions.len());
    let mut max_residual = 0.0f64;
    for x in &r.solutions {
        let mut x = *x;
        if let Ok(n) = newton::<C, _, N, N>(&fixed, &x, 1.0, &polish) {
            let mut f = SVector::<C, N>::zeros();
            P::residual(&x, &r.params, &mut f);
            if n.residual <= f.iter().map(|z| z.norm()).fold(0.0, f64::max) {
                x = n.x;
            }
        }
        if let Some(g) = &symmetry {
            x = g.canonical(&x);
        }
        let mut f = SVector::<C, N>::zeros();
        P::residual(&x, &r.params, &mut f);
        max_residual = max_residual.max(f.iter().map(|z| z.norm()).fold(0.0, f64::max));
        solutions.push(x);
    }
    let stop = match r.stop {
        StopReason::Stalled => "stalled",
        StopReason::TargetReached => "target",
        StopReason::MaxLoops => "max_loops",
    };
    let file = StartSystemFile {
        problem: P::NAME.to_string(),
        unknowns: P::UNKNOWN_NAMES.iter().map(|s| s.to_string()).collect(),
        parameter_layout: parameter_layout.to_string(),
        symmetry: symmetry.as_ref().map(|g| g.indices.clone()).unwrap_or_default(),
        count: solutions.len(),
        max_residual,
        monodromy: MonodromyRecord {
            seed: config.seed,
            stall_loops: config.stall_loops,
            loops: r.loops,
            history: r.history.clone(),
            paths_tracked: r.paths_tracked,
            paths_failed: r.paths_failed,
            stop: stop.to_string(),
            seconds: r.elapsed.as_secs_f64(),
        },
        notes: config.notes.clone(),
        params: pairs(&r.params),
        solutions: solutions.iter().map(pairs).collect(),
    };
    let written = match &config.output {
        Some(path) => {
            std::fs::write(path, file.to_json()).map_err(|source| StartSystemError::Io { path: path.clone(), source })?;
            Some(path.clone())
        }
        None => None,
    };
    let count = solutions.len();
    Ok(MonodromyReport {
        problem: P::NAME.to_string(),
        count,
        vectors: if symmetry.is_some() { 2 * count } else { count },
        expected,
        written,
        file,
    })
}
