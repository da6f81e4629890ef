//! Writes one noise-free GRPS7 instance (scene seed `N`, default 0) as a PHCpack input file,
//! the independent check of the 140-root count of the shipped start system:
//!
//! ```sh
//! cargo run --release -p simhc-problems --example phc_input -- 0 > /tmp/grps7.phc
//! phc -b /tmp/grps7.phc /tmp/grps7.out        # or problems/scripts/phc_grps7.sh
//! ```
//!
//! The start systems themselves are computed by `simhc monodromy grps|upnp`.

use nalgebra::Vector3;
use simhc::Problem;
use simhc_problems::grps::scene::GrpsSceneConfig;
use simhc_problems::grps::{self, Grps7};
use simhc_problems::metrics::rotation_from_quat;
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
    let scene = GrpsSceneConfig { points: 7, ..Default::default() }.sample_seeded(seed).map_err(|e| e.to_string())?;
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
                let k = [fp[b] * fv[a], -fp[b] * cross[a][0], -fp[b] * cross[a][1], -fp[b] * cross[a][2], -f[a] * g[b]];
                let t = Vector3::new(gt[4], gt[5], gt[6]);
                check += r_gt[(a, b)] * (k[0] + k[1] * t.x + k[2] * t.y + k[3] * t.z + k[4] * gt[7]);
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
            return Err(format!("row {i}: PHC form {check:e} vs generated {:e}", f_gt[i]));
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

fn main() -> ExitCode {
    let seed = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    match phc_input(seed) {
        Ok(t) => {
            print!("{t}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
