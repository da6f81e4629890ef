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
use simhc::all_roots::{solve_all_fast, solve_all_fast_via, AllRootsOptions, AllRootsResult, StartSystem};
use simhc::monodromy::{SignFlip, C};
use simhc::simhc_problem;
use std::sync::OnceLock;

/// The runtime's start-system file, monodromy driver and selection rule, which the functions
/// below apply to the built-ins.
pub use simhc::start_system::{
    best_real_solution, run_monodromy, MonodromyConfig, MonodromyRecord, MonodromyReport, Selection, StartSystemError, StartSystemFile,
};

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
