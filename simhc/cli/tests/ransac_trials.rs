//! `simhc ransac --dump-trials / --trials-file`, through the binary: a dumped file reads back
//! bit-identical (it is written again unchanged), holds what was run (the true pose fits the
//! true matches and not the wrong ones), and the estimator on the file gives the very results of
//! the run on the seed; a malformed file is an error naming the trial, row and field. (The
//! declared problems' path, the same code, is tested on a line in `library_solver.rs`: GRPS's
//! estimator takes seconds a call unoptimized.)

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simhc-ransac-trials-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

/// Runs `simhc args..`; its stdout, or its stderr when it fails.
fn simhc(args: &[&str]) -> Result<String, String> {
    let out = Command::new(env!("CARGO_BIN_EXE_simhc")).args(args).output().expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "{stderr}");
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).to_string())
    } else {
        Err(stderr)
    }
}

fn json(text: &str) -> Value {
    serde_json::from_str(text).expect("JSON")
}

fn read(path: &Path) -> Value {
    json(&std::fs::read_to_string(path).expect("the file"))
}

/// Every number of a JSON value as bits, in order (so equal lists mean bit-identical numbers).
fn bits(v: &Value, out: &mut Vec<u64>) {
    match v {
        Value::Number(n) => out.push(n.as_f64().expect("a number").to_bits()),
        Value::Array(a) => a.iter().for_each(|v| bits(v, out)),
        Value::Object(o) => o.values().for_each(|v| bits(v, out)),
        _ => {}
    }
}

fn all_bits(v: &Value) -> Vec<u64> {
    let mut out = Vec::new();
    bits(v, &mut out);
    out
}

/// The per-trial results of a `--json` report without the times: estimate, mask, success.
fn results(report: &Value) -> Vec<Value> {
    report["trials"]
        .as_array()
        .expect("trials")
        .iter()
        .map(|t| serde_json::json!([t["outliers"], t["success"], t["estimate"], t["inlier_mask"], t["wrong_taken"]]))
        .collect()
}

/// Dumps `problem`'s sampled trials, runs again on the dump, and checks both runs agree.
fn dump_and_rerun(problem: &str, sampled: &[&str]) -> (Value, Value) {
    let dir = dir();
    let (dump, again) = (dir.join(format!("{problem}.json")), dir.join(format!("{problem}-again.json")));
    let (dump_s, again_s) = (dump.to_str().expect("utf-8"), again.to_str().expect("utf-8"));
    let mut args = vec!["ransac", problem, "--json", "--dump-trials", dump_s];
    args.extend_from_slice(sampled);
    let on_seed = json(&simhc(&args).expect("the sampled run"));
    let on_file =
        json(&simhc(&["ransac", problem, "--json", "--trials-file", dump_s, "--dump-trials", again_s]).expect("the run on the file"));
    let (first, second) = (read(&dump), read(&again));
    // Read back and written again: the same numbers, bit for bit, and the same document.
    assert_eq!(all_bits(&first), all_bits(&second));
    assert_eq!(first, second);
    // The same estimates, masks and successes on the file as on the seed.
    assert_eq!(results(&on_seed), results(&on_file));
    assert_eq!(on_seed["rows"].as_array().map(Vec::len), on_file["rows"].as_array().map(Vec::len));
    assert!(on_file["source"].as_str().expect("source").contains(dump_s), "{}", on_file["source"]);
    (first, on_seed)
}

#[test]
fn upnp_trials_dump_read_back_and_run_the_same() {
    let (file, report) = dump_and_rerun(
        "upnp",
        &["--trials", "3", "--rows", "30", "--outliers", "0,0.3", "--noise", "0", "--threshold", "1e-4", "--seed", "11"],
    );
    assert_eq!((file["seed"].as_u64(), file["noise"].as_f64(), file["threshold"].as_f64()), (Some(11), Some(0.0), Some(1e-4)));
    let trials = file["trials"].as_array().expect("trials");
    assert_eq!(trials.len(), 6);
    // The file holds the data that was run: noise-free, the true pose puts every true match's
    // world point on its ray (alpha f + v = R p + t), and no wrong match's.
    let mut wrong = 0;
    for (k, t) in trials.iter().enumerate() {
        let num = |v: &Value| v.as_f64().expect("a number");
        let truth: Vec<f64> = t["truth"].as_array().expect("truth").iter().map(num).collect();
        let rows = t["rows"].as_array().expect("rows");
        assert_eq!(rows.len(), 30);
        for (r, (row, inlier)) in rows.iter().zip(t["inlier"].as_array().expect("inlier")).enumerate() {
            let x: Vec<f64> = row.as_array().expect("row").iter().map(num).collect();
            let (p, f, v) = (&x[0..3], &x[3..6], &x[6..9]);
            let d: Vec<f64> = (0..3).map(|i| (0..3).map(|j| truth[3 * i + j] * p[j]).sum::<f64>() + truth[9 + i] - v[i]).collect();
            let cross = [d[1] * f[2] - d[2] * f[1], d[2] * f[0] - d[0] * f[2], d[0] * f[1] - d[1] * f[0]];
            let sine = cross.iter().map(|c| c * c).sum::<f64>().sqrt() / d.iter().map(|c| c * c).sum::<f64>().sqrt();
            let on_ray = sine < 1e-9 && d.iter().zip(f).map(|(a, b)| a * b).sum::<f64>() > 0.0;
            assert_eq!(on_ray, inlier.as_bool().expect("a flag"), "trial {k}, row {r}: sine {sine}");
            wrong += usize::from(!on_ray);
        }
    }
    assert!(wrong > 0, "the 30 % trials have wrong matches");
    // Noise-free: every pose found, no wrong match taken.
    for row in report["rows"].as_array().expect("rows") {
        assert_eq!((row["success_pct"].as_f64(), row["no_model"].as_u64()), (Some(100.0), Some(0)), "{row}");
    }
}

#[test]
fn a_malformed_trials_file_names_the_trial_row_and_field() {
    let dir = dir();
    let good = dir.join("good.json");
    simhc(&[
        "ransac",
        "upnp",
        "--trials",
        "2",
        "--rows",
        "10",
        "--outliers",
        "0.2",
        "--threshold",
        "1e-3",
        "--dump-trials",
        good.to_str().expect("utf-8"),
        "--json",
    ])
    .expect("the sampled run");
    let file = read(&good);
    let run = |name: &str, edit: &dyn Fn(&mut Value)| -> String {
        let mut bad = file.clone();
        edit(&mut bad);
        let path = dir.join(name);
        std::fs::write(&path, bad.to_string()).expect("written");
        simhc(&["ransac", "upnp", "--trials-file", path.to_str().expect("utf-8")]).expect_err("a malformed file fails")
    };
    let e = run("short-row.json", &|v| v["trials"][1]["rows"][3] = serde_json::json!([1.0, 2.0]));
    assert!(e.contains("trial 1, row 3, `rows`: 2 numbers, expected 9 (p 3, f 3, v 3)"), "{e}");
    let e = run("no-mask.json", &|v| {
        v["trials"][0].as_object_mut().expect("a trial").remove("inlier");
    });
    assert!(e.contains("trial 0, `trial`: missing field `inlier`"), "{e}");
    let e = run("short-mask.json", &|v| {
        v["trials"][1]["inlier"].as_array_mut().expect("mask").pop();
    });
    assert!(e.contains("trial 1, `inlier`: 9 flags for 10 rows"), "{e}");
    let e = run("null-number.json", &|v| v["trials"][0]["truth"][4] = Value::Null);
    assert!(e.contains("trial 0, `trial`: invalid type: null, expected f64"), "{e}");
    let e = run("other-problem.json", &|v| v["problem"] = serde_json::json!("grps8"));
    assert!(e.contains("`problem`: the trials are for `grps8`, not `upnp`"), "{e}");
    // Sampling flags with a file are refused rather than ignored.
    let e = simhc(&["ransac", "upnp", "--trials-file", good.to_str().expect("utf-8"), "--rows", "50"]).expect_err("conflict");
    assert!(e.contains("--rows"), "{e}");
}
