//! Computes the built-in start systems by monodromy and writes them to `problems/data/`.
//!
//! ```sh
//! cargo run --release -p simhc-problems --example monodromy -- all            # both problems
//! cargo run --release -p simhc-problems --example monodromy -- grps7 --seed 3 --parallel
//! cargo run --release -p simhc-problems --example monodromy -- upnp --dry-run  # count only
//! ```
//!
//! The PHCpack cross-check writes one noise-free GRPS7 instance (scene seed `N`) as a PHCpack
//! input file (`phc -b in out` then solves it, see `problems/scripts/phc_grps7.sh`):
//!
//! ```sh
//! cargo run --release -p simhc-problems --example monodromy -- phc-input 0 > /tmp/grps7.phc
//! ```
//!
//! Timing of the all-roots solvers from the shipped start systems (noise-free scenes, ground
//! truth among the real solutions, median and mean wall time per solve, 1 thread and rayon;
//! GRPS7 also on one thread with the row kernel on the coefficients of the expansion instead of
//! the parameters, and with each narrower lane instruction set this CPU runs):
//!
//! ```sh
//! cargo run --release -p simhc-problems --example monodromy -- bench 200   # 200 trials each
//! ```
//!
//! Options: `--seed N` (default 1), `--stall K` (loops without a new solution before stopping,
//! default 5), `--parallel` (rayon), `--dry-run` (do not write), `--out DIR` (default
//! `problems/data`), `--note TEXT` (recorded in the file; repeatable).

use nalgebra::Vector3;
use simhc::Problem;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{self, Grps7};
use simhc_problems::metrics::rotation_from_quat;
use simhc_problems::start_systems::{run_monodromy_grps7, run_monodromy_upnp, MonodromyConfig};
use std::path::PathBuf;
use std::process::ExitCode;

/// The unnormalized rotation matrix of `q = [w, x, y, z]` in PHCpack syntax (same as
/// [`rotation_from_quat`]).
const R_PHC: [[&str; 3]; 3] = [
    ["(w^2 + x^2 - y^2 - z^2)", "2*(x*y - w*z)", "2*(x*z + w*y)"],
    ["2*(x*y + w*z)", "(w^2 - x^2 + y^2 - z^2)", "2*(y*z - w*x)"],
    ["2*(x*z - w*y)", "2*(y*z + w*x)", "(w^2 - x^2 - y^2 + z^2)"],
];

/// PHCpack input for the GRPS7 instance of scene `seed` (noise-free, paper's sampler), in the
/// variables `w, x, y, z` (quaternion), `t1, t2, t3` (translation), `sc` (scale). Each row is
/// `sum_ab R_ab (fp_b ((t x f)_a + (f x v)_a) - sc f_a (vp x fp)_b)`, which is the declared
/// `t.(f x R fp) - s f.R (vp x fp) + f.(v x R fp)`; checked against `Grps7::residual` at the
/// ground truth before printing.
fn phc_input(seed: u64) -> Result<String, String> {
    let scene = GrpsSceneConfig {
        points: 7,
        ..Default::default()
    }
    .sample_seeded(seed)
    .map_err(|e| e.to_string())?;
    let rows = grps::rows_of::<7>(&scene.correspondences).ok_or("7 correspondences")?;
    let gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
    let r_gt = rotation_from_quat([gt[0], gt[1], gt[2], gt[3]]);
    let mut f_gt = nalgebra::SVector::<f64, 8>::zeros();
    Grps7::residual(&gt, &Grps7::params(&rows), &mut f_gt);
    let mut text = String::from("8 8\n");
    for (i, c) in scene.correspondences.iter().enumerate() {
        let (f, v, fp, vp) = (c.f, c.v, c.fp, c.vp);
        let g = vp.cross(&fp);
        let fv = f.cross(&v);
        // (f x t)_a = sum_k cross[a][k] t_k, and t x f = -(f x t).
        let cross = [[0.0, -f.z, f.y], [f.z, 0.0, -f.x], [-f.y, f.x, 0.0]];
        let mut terms = Vec::new();
        let mut check = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                // Coefficient of R_ab: k0 + k1 t1 + k2 t2 + k3 t3 + k4 sc.
                let k = [
                    fp[b] * fv[a],
                    -fp[b] * cross[a][0],
                    -fp[b] * cross[a][1],
                    -fp[b] * cross[a][2],
                    -f[a] * g[b],
                ];
                let t = Vector3::new(gt[4], gt[5], gt[6]);
                check +=
                    r_gt[(a, b)] * (k[0] + k[1] * t.x + k[2] * t.y + k[3] * t.z + k[4] * gt[7]);
                terms.push(format!(
                    "{}*({}{}*t1{}*t2{}*t3{}*sc)",
                    R_PHC[a][b],
                    num(k[0], false),
                    num(k[1], true),
                    num(k[2], true),
                    num(k[3], true),
                    num(k[4], true)
                ));
            }
        }
        if (check - f_gt[i]).abs() > 1e-10 || f_gt[i].abs() > 1e-10 {
            return Err(format!(
                "row {i}: PHC form {check:e} vs generated {:e}",
                f_gt[i]
            ));
        }
        text += &terms.join("\n + ");
        text += ";\n";
    }
    text += "w^2 + x^2 + y^2 + z^2 - 1;\n";
    Ok(text)
}

/// `x` in PHCpack's scientific notation, with a leading ` + ` / ` - ` when `signed`.
fn num(x: f64, signed: bool) -> String {
    let m = format!("{:.17E}", x.abs());
    match (signed, x < 0.0) {
        (true, true) => format!(" - {m}"),
        (true, false) => format!(" + {m}"),
        (false, true) => format!("-{m}"),
        (false, false) => m,
    }
}

/// Median of a non-empty sample.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// All-roots timing on `trials` noise-free scenes per problem (see the module docs).
fn bench(trials: u64) {
    use simhc::all_roots::AllRootsOptions;
    use simhc::tracker::batch::LaneIsa;
    use simhc_problems::start_systems::{solve_grps7, solve_upnp};
    use simhc_problems::upnp::{self, geometry::upnp_cost_matrix, scene::UpnpSceneConfig};
    use std::time::Instant;
    // The default (widest instruction set, 1 and 2 threads), then GRPS7 on one thread with the
    // coefficient row kernel (`param_lanes: false`, the same paths) and with each narrower
    // instruction set this CPU runs.
    let isas = LaneIsa::ALL.into_iter().filter(|isa| isa.available()).skip(1);
    let runs = [(false, None, true), (true, None, true), (false, None, false)]
        .into_iter()
        .chain(isas.map(|isa| (false, Some(isa), true)));
    for (parallel, lane_isa, param_lanes) in runs {
        let options = AllRootsOptions {
            parallel,
            lane_isa,
            param_lanes,
            ..AllRootsOptions::default()
        };
        let threads = if parallel { rayon_threads() } else { 1 };
        let isa = lane_isa.unwrap_or_else(LaneIsa::detect);
        // GRPS7.
        let (mut times, mut found, mut paths, mut failed, mut retracked) = (Vec::new(), 0, 0, 0, 0);
        for seed in 0..trials {
            let scene = GrpsSceneConfig {
                points: 7,
                ..Default::default()
            }
            .sample_seeded(seed)
            .unwrap();
            let p = Grps7::params(&grps::rows_of::<7>(&scene.correspondences).unwrap());
            let gt = grps::unknowns_of(&scene.rotation, &scene.translation, scene.scale);
            let t0 = Instant::now();
            let res = solve_grps7(&p, &options);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            found += res.closest_real(&gt).is_some_and(|(_, d)| d < 1e-6) as usize;
            paths += res.endpoints.len();
            failed += res.failed;
            retracked += res.retracked;
        }
        println!(
            "grps7 all-roots ({threads} thread{}, {isa:?} lanes{}): ground truth found {found}/{trials}, median {:.2} ms, mean {:.2} ms per solve ({} paths, {:.2} failed, {:.2} re-tracked per solve)",
            if threads == 1 { "" } else { "s" },
            if param_lanes { "" } else { ", coefficient rows" },
            median(times.clone()),
            times.iter().sum::<f64>() / times.len() as f64,
            paths / trials as usize,
            failed as f64 / trials as f64,
            retracked as f64 / trials as f64,
        );
        if lane_isa.is_some() || !param_lanes {
            continue;
        }
        // UPnP (noise-free: the global minimum is the ground truth; no path lanes).
        let (mut times, mut found) = (Vec::new(), 0);
        for seed in 0..trials {
            let scene = UpnpSceneConfig {
                noise_px: 0.0,
                ..Default::default()
            }
            .sample_seeded(seed)
            .unwrap();
            let p = upnp::params_of(&upnp_cost_matrix(&scene.correspondences).unwrap());
            let t0 = Instant::now();
            let res = solve_upnp(&p, &options);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            let q = simhc_problems::metrics::quat_from_rotation(&scene.rotation);
            let gt = nalgebra::SVector::<f64, 5>::from([q[0], q[1], q[2], q[3], 0.0]);
            found += res
                .real
                .iter()
                .any(|s| (0..4).all(|k| (s.x[k] - gt[k]).abs() < 1e-6))
                as usize;
        }
        println!(
            "upnp  all-roots ({threads} thread{}): ground truth found {found}/{trials}, median {:.3} ms, mean {:.3} ms per solve (40 paths)",
            if threads == 1 { "" } else { "s" },
            median(times.clone()),
            times.iter().sum::<f64>() / times.len() as f64,
        );
    }
}

/// Threads of rayon's global pool.
fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn main() -> ExitCode {
    if std::env::args().nth(1).as_deref() == Some("bench") {
        bench(
            std::env::args()
                .nth(2)
                .and_then(|s| s.parse().ok())
                .unwrap_or(100),
        );
        return ExitCode::SUCCESS;
    }
    let mut args = std::env::args().skip(1);
    if std::env::args().nth(1).as_deref() == Some("phc-input") {
        let seed = std::env::args()
            .nth(2)
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        return match phc_input(seed) {
            Ok(t) => {
                print!("{t}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("{e}");
                ExitCode::FAILURE
            }
        };
    }
    let mut problems = Vec::new();
    let mut config = MonodromyConfig::default();
    let mut dry_run = false;
    let mut out = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data");
    while let Some(a) = args.next() {
        let mut value = |name: &str| match args.next() {
            Some(v) => v,
            None => {
                eprintln!("{name} needs a value");
                std::process::exit(2);
            }
        };
        match a.as_str() {
            "grps7" | "grps" => problems.push("grps7"),
            "upnp" => problems.push("upnp"),
            "all" => problems.extend(["grps7", "upnp"]),
            "--seed" => config.seed = value("--seed").parse().unwrap_or(1),
            "--stall" => config.stall_loops = value("--stall").parse().unwrap_or(5),
            "--parallel" => config.parallel = true,
            "--dry-run" => dry_run = true,
            "--out" => out = PathBuf::from(value("--out")),
            "--note" => config.notes.push(value("--note")),
            other => {
                eprintln!("unknown argument {other:?}; usage: monodromy (grps7|upnp|all) [--seed N] [--stall K] [--parallel] [--dry-run] [--out DIR] [--note TEXT]");
                return ExitCode::from(2);
            }
        }
    }
    if problems.is_empty() {
        problems.push("grps7");
    }
    let mut ok = true;
    for p in problems {
        let mut c = config.clone();
        if !dry_run {
            c.output = Some(out.join(format!("{p}_start.json")));
        }
        let report = match p {
            "grps7" => run_monodromy_grps7(&c),
            _ => run_monodromy_upnp(&c),
        };
        match report {
            Ok(r) => {
                println!("{r}");
                ok &= r.expected.is_none_or(|e| e == r.count);
            }
            Err(e) => {
                eprintln!("{p}: {e}");
                ok = false;
            }
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
