//! Start systems for all-roots solving of the built-in problems, found by monodromy and
//! shipped as JSON under `problems/data/` (embedded with `include_str!`, so they work on a
//! fresh machine).
//!
//! | problem | file | unknowns | solutions (orbits of `q -> -q`) | solution vectors |
//! |---|---|---|---|---|
//! | [`crate::grps::Grps7`] | `grps7_start.json` | `[q, t, s]` | 140 | 280 |
//! | [`upnp_lagrange::UpnpLagrange`] | `upnp_start.json` | `[q, lambda]` | 40 | 80 |
//!
//! **Counts.** A quaternion `q` and `-q` give the same rotation and both solve the systems, so
//! solutions come in pairs; a start system stores one representative per pair (canonical sign,
//! [`simhc::monodromy::SignFlip::canonical`]) and the all-roots solver tracks 140 (GRPS) or 40
//! (UPnP) paths: the parameter homotopy commutes with the sign flip, so the partner's path is the
//! negated one. GRPS: 140 = the number of rotations of Kneip et al. (paper, GRPS section);
//! UPnP: the Lagrange system `grad E(q) = lambda q, q.q = 1` of a generic quartic form `E` in
//! four variables has `((d-1)^n - 1) / (d - 2) = (3^4 - 1) / 2 = 40` eigenvector directions
//! (Cartwright-Sturmfels), each giving `+-q`. The monodromy runs that produced the files, and
//! the independent PHCpack count on a GRPS7 instance, are recorded in each file's `notes`.
//!
//! **Layout of the JSON files** ([`StartSystemFile`]): `params` and `solutions` are complex
//! numbers as `[re, im]` pairs; `params` uses the problem's own parameter layout (GRPS7: 7 rows
//! of `f, v, fp, vp`, 12 scalars each, as [`crate::grps::Grps7::params`]; UPnP: the upper
//! triangle of the 11x11 `M` row by row, 66 scalars, as [`crate::upnp::params_of`]).
//!
//! Regenerate with `cargo run --release -p simhc-cli -- monodromy grps --seed 1 --output
//! problems/data/grps7_start.json` (and `monodromy upnp ... upnp_start.json`), which call
//! [`run_monodromy_grps7`] / [`run_monodromy_upnp`]; `--example phc_input` writes the PHCpack
//! check and `--example all_roots_speed` times the all-roots solvers.

use crate::grps::Grps7;
use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use simhc::all_roots::{solve_all_fast, solve_all_fast_via, AllRootsOptions, AllRootsResult, RealSolution, StartSystem};
use simhc::monodromy::{monodromy_solve, MonodromyOptions, SignFlip, StopReason, C};
use simhc::tracker::{newton, NewtonOptions};
use simhc::{simhc_problem, ParamDerivative, ProblemInfo};
use std::path::PathBuf;
use std::sync::OnceLock;
use thiserror::Error;

/// The UPnP first-order conditions with the Lagrange multiplier as an unknown: a *square*
/// system (5 x 5), as all-roots tracking needs (the built-in [`crate::upnp::Upnp`] has 5
/// equations in 4 unknowns).
///
/// `E(q) = s^T M s` with `s(q)` the 10 quadratic monomials of `q` and `q.q` (exactly as in
/// [`crate::upnp::Upnp`]); the equations are `grad E(q) - lambda q = 0` (4) and `q.q - 1 = 0`.
/// At a solution `lambda = 4 E(q)` (Euler), so the `q` of every solution solves
/// [`crate::upnp::Upnp`] and vice versa. Unknowns `[q0, q1, q2, q3, lambda]`; parameters: the
/// upper triangle of `M` row by row (66), the same vector as [`crate::upnp::params_of`].
#[simhc_problem]
pub mod upnp_lagrange {
    pub struct Unknowns {
        /// Rotation quaternion `[w, x, y, z]`.
        q: Quat,
        /// Lagrange multiplier of `q . q = 1` (equals `4 E(q)` at a solution).
        lambda: Scalar,
    }

    pub struct Globals {
        /// The symmetric 11x11 UPnP cost matrix.
        m: Sym<11>,
    }

    pub fn global_equations() -> [Scalar; 5] {
        let n = q.dot(q);
        let s = [
            q[0] * q[0],
            q[1] * q[1],
            q[2] * q[2],
            q[3] * q[3],
            q[0] * q[1],
            q[0] * q[2],
            q[0] * q[3],
            q[1] * q[2],
            q[1] * q[3],
            q[2] * q[3],
            n,
        ];
        let e = s.dot(m * s);
        let g = grad(e, q) - lambda * q;
        [g[0], g[1], g[2], g[3], n - 1]
    }
}

pub use upnp_lagrange::UpnpLagrange;

/// Number of GRPS7 start solutions (rotations; `q` and `-q` counted once).
pub const GRPS7_SOLUTIONS: usize = 140;
/// Number of UPnP-Lagrange start solutions (`q` and `-q` counted once).
pub const UPNP_SOLUTIONS: usize = 40;

/// The sign flip `q -> -q` of the quaternion in `x[0..4]` (both built-in problems).
pub fn quaternion_sign() -> SignFlip {
    SignFlip::new(vec![0, 1, 2, 3])
}

/// Errors of reading, writing and computing start systems.
#[derive(Debug, Error)]
pub enum StartSystemError {
    /// The JSON does not parse or has the wrong shape.
    #[error("invalid start system file: {0}")]
    Format(String),
    /// Monodromy could not start.
    #[error(transparent)]
    Monodromy(#[from] simhc::monodromy::MonodromyError),
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

static GRPS7_JSON: &str = include_str!("../data/grps7_start.json");
static UPNP_JSON: &str = include_str!("../data/upnp_start.json");

/// The shipped GRPS7 start system (140 solutions, parsed once).
pub fn grps7_start() -> &'static StartSystem<8, 84> {
    static START: OnceLock<StartSystem<8, 84>> = OnceLock::new();
    START.get_or_init(|| {
        StartSystemFile::from_json(GRPS7_JSON)
            .and_then(|f| f.start_system())
            .expect("shipped problems/data/grps7_start.json is valid (tested)")
    })
}

/// The shipped UPnP-Lagrange start system (40 solutions, parsed once).
pub fn upnp_start() -> &'static StartSystem<5, 66> {
    static START: OnceLock<StartSystem<5, 66>> = OnceLock::new();
    START.get_or_init(|| {
        StartSystemFile::from_json(UPNP_JSON)
            .and_then(|f| f.start_system())
            .expect("shipped problems/data/upnp_start.json is valid (tested)")
    })
}

/// The shipped files' metadata (provenance, notes).
pub fn grps7_start_file() -> StartSystemFile {
    StartSystemFile::from_json(GRPS7_JSON).expect("shipped file is valid (tested)")
}

/// The shipped UPnP file's metadata.
pub fn upnp_start_file() -> StartSystemFile {
    StartSystemFile::from_json(UPNP_JSON).expect("shipped file is valid (tested)")
}

/// All roots of a GRPS7 instance (parameters from [`Grps7::params`]) from the shipped start
/// system: 140 complex paths ([`solve_all_fast_via`] to the representative of the target from
/// [`grps7_aligned_target`]); the real ones in `result.real`.
pub fn solve_grps7(target: &SVector<f64, 84>, options: &AllRootsOptions) -> AllRootsResult<8> {
    let start = grps7_start();
    let aligned = grps7_aligned_target(&start.params, target);
    solve_all_fast_via::<Grps7, 8, 84, { Grps7::NC }>(start, target, &aligned, options)
}

/// The GRPS7 parameters `target` with each row's bearings rescaled by complex factors, `f_i`
/// by `a_i` and `fp_i` by `b_i`, chosen as the least-squares fits `a_i f_i ~ f*_i`,
/// `b_i fp_i ~ fp*_i` to the start parameters `start`.
///
/// Why this is the same problem: row `i` of the system is linear in `f_i` and in `fp_i`, so the
/// rescaled system is `a_i b_i` times the original, with the same solutions. Why it helps: the
/// homotopy segment from the start to this representative is shorter than to the unit
/// bearings (measured with `examples/allroots_diag.rs`: about 25 % fewer factorizations per
/// path on seeds 0-2). A zero bearing, or one orthogonal to the start's, keeps its scale.
pub fn grps7_aligned_target(start: &SVector<C, 84>, target: &SVector<f64, 84>) -> SVector<C, 84> {
    const ROW: usize = 12;
    let mut out = simhc::homotopy::to_complex(target);
    for r in 0..7 {
        // f at offset 0, fp at offset 6 of each row (see `Grps7::params`).
        for off in [0, 6] {
            let idx = |k: usize| r * ROW + off + k;
            let den: f64 = (0..3).map(|k| target[idx(k)] * target[idx(k)]).sum();
            if den <= 0.0 || !den.is_finite() {
                continue;
            }
            let num: C = (0..3).map(|k| start[idx(k)] * target[idx(k)]).sum();
            let scale = num / den;
            // A start bearing (numerically) orthogonal to the target's: keep the target's.
            if scale.norm().is_nan() || scale.norm() <= 1e-12 || !scale.re.is_finite() || !scale.im.is_finite() {
                continue;
            }
            for k in 0..3 {
                out[idx(k)] = C::new(target[idx(k)], 0.0) * scale;
            }
        }
    }
    out
}

/// All critical points of a UPnP cost (parameters from [`crate::upnp::params_of`]) from the
/// shipped start system: 40 complex paths; real solutions are `[q, lambda]` with
/// `lambda = 4 E(q)`.
pub fn solve_upnp(target: &SVector<f64, 66>, options: &AllRootsOptions) -> AllRootsResult<5> {
    solve_all_fast::<UpnpLagrange, 5, 66, { UpnpLagrange::NC }>(upnp_start(), target, options)
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

/// Settings of [`run_monodromy_grps7`] / [`run_monodromy_upnp`].
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
    let fixed = simhc::homotopy::FixedSystem::<P, C, NP>::new(r.params);
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

/// `simhc monodromy grps7`: monodromy on [`Grps7`] (expected 140 solutions modulo `q -> -q`).
pub fn run_monodromy_grps7(config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
    run_monodromy::<Grps7, 8, 84>(
        config,
        Some(quaternion_sign()),
        "7 rows of 12 scalars [f(3), v(3), fp(3), vp(3)], as Grps7::params",
        Some(GRPS7_SOLUTIONS),
    )
}

/// `simhc monodromy upnp`: monodromy on [`UpnpLagrange`] (expected 40 solutions modulo
/// `q -> -q`).
pub fn run_monodromy_upnp(config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
    run_monodromy::<UpnpLagrange, 5, 66>(
        config,
        Some(quaternion_sign()),
        "upper triangle of the symmetric 11x11 M, row by row (66), as upnp::params_of",
        Some(UPNP_SOLUTIONS),
    )
}
