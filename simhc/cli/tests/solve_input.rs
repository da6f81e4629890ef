//! `simhc solve` and `--trials-file` on good and bad JSON: the errors name the file, the
//! correspondence (or trial) and the field, and a good file gives a validated pose.

use std::path::PathBuf;
use std::process::Command;

fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simhc-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write input");
    path
}

fn simhc(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_simhc")).args(args).output().expect("runs simhc");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Noise-free correspondences of a known pose (identity rotation, t = (0.1, -0.2, 0.3)) seen by
/// four ray origins; `bearing_3` replaces the bearing of correspondence 3.
fn upnp_input(bearing_3: Option<&str>) -> String {
    let origins = [[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0], [0.0, 0.5, 0.2], [0.0, -0.5, -0.2]];
    let t = [0.1, -0.2, 0.3];
    let mut rows = Vec::new();
    for i in 0..12 {
        let p = [(i as f64 * 0.7).sin(), (i as f64 * 1.3).cos(), 5.0 + (i as f64 * 0.9).sin()];
        let v = origins[i % 4];
        let d: Vec<f64> = (0..3).map(|k| p[k] + t[k] - v[k]).collect();
        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        let f = match bearing_3 {
            Some(text) if i == 3 => text.to_string(),
            _ => format!("[{}, {}, {}]", d[0] / n, d[1] / n, d[2] / n),
        };
        rows.push(format!(r#"{{"p": [{}, {}, {}], "f": {f}, "v": [{}, {}, {}]}}"#, p[0], p[1], p[2], v[0], v[1], v[2]));
    }
    format!("{{\"correspondences\": [\n{}\n]}}", rows.join(",\n"))
}

#[test]
fn solve_upnp_reports_a_validated_pose() {
    let path = write("good.json", &upnp_input(None));
    let (ok, out, err) = simhc(&["solve", "upnp", "--input", path.to_str().expect("utf-8 path")]);
    assert!(ok, "stderr: {err}");
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON output");
    assert_eq!(doc["validated"], serde_json::Value::Bool(true), "{out}");
    // Noise-free: the library solver's first attempt, Gauss-Newton from the linear start.
    assert_eq!(
        (doc["start"].as_str(), doc["method"].as_str(), doc["attempts"].as_u64()),
        (Some("linear"), Some("GaussNewton"), Some(1)),
        "{out}"
    );
    let t: Vec<f64> = doc["translation"].as_array().expect("translation").iter().map(|x| x.as_f64().expect("number")).collect();
    for (k, want) in [0.1, -0.2, 0.3].into_iter().enumerate() {
        assert!((t[k] - want).abs() < 1e-8, "translation {t:?}");
    }
}

/// A seeded GRPS scene's first `n` correspondences as the `solve grps` input.
fn grps_input(n: usize, seed: u64) -> String {
    let scene = simhc_problems::grps::scene::GrpsSceneConfig { points: n, ..Default::default() }.sample_seeded(seed).expect("a scene");
    let v3 = |v: &nalgebra::Vector3<f64>| format!("[{}, {}, {}]", v.x, v.y, v.z);
    let rows: Vec<String> = scene
        .correspondences
        .iter()
        .map(|c| format!(r#"{{"f": {}, "v": {}, "fp": {}, "vp": {}}}"#, v3(&c.f), v3(&c.v), v3(&c.fp), v3(&c.vp)))
        .collect();
    format!("{{\"correspondences\": [{}]}}", rows.join(", "))
}

/// With 8 correspondences the pose is unique; with the minimal 7 the output says that other
/// poses may fit them as exactly.
#[test]
fn solve_grps_says_when_the_data_is_minimal() {
    for (n, minimal) in [(8, false), (7, true)] {
        let path = write(&format!("grps{n}.json"), &grps_input(n, 5));
        let (ok, out, err) = simhc(&["solve", "grps", "--input", path.to_str().expect("utf-8 path")]);
        assert!(ok, "stderr: {err}");
        let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON output");
        assert_eq!(doc["validated"], serde_json::Value::Bool(true), "{out}");
        assert_eq!(doc["minimal"], serde_json::Value::Bool(minimal), "{n} correspondences: {out}");
    }
}

/// A declared problem's answer in JSON: a scalar unknown (GRPS's scale) is a number, a vector
/// an array, the origin names the start and the method (or the fallback's candidate), and the
/// validator's check is an object of its named figures.
#[test]
fn solve_of_a_declared_problem_prints_json_values() {
    let path = write("grps8_declared.json", &grps_input(8, 5));
    let (ok, out, err) = simhc(&["solve", "grps8", "--input", path.to_str().expect("utf-8 path")]);
    assert!(ok, "stderr: {err}");
    let doc: serde_json::Value = serde_json::from_str(&out).expect("JSON output");
    assert_eq!(doc["validated"], serde_json::Value::Bool(true), "{out}");
    let s = doc["unknowns"]["s"].as_f64().expect("the scale is a number");
    assert!(s.is_finite() && s > 0.0, "{out}");
    assert_eq!(doc["unknowns"]["t"].as_array().map(|t| t.len()), Some(3), "{out}");
    let origin = &doc["origin"];
    // A method is its name, or `{"OtherSimulatorHc": k}` for another simulator.
    let method = &origin["method"];
    assert!(
        (origin["start"].is_string() && (method.is_string() || method["OtherSimulatorHc"].is_u64())) || origin["fallback"].is_u64(),
        "{out}"
    );
    let check = &doc["check"];
    assert!(check["max_angle"].as_f64().is_some_and(|a| (0.0..1e-6).contains(&a)), "{out}");
    assert_eq!((check["behind"].as_u64(), check["positive_scale"].as_bool()), (Some(0), Some(true)), "{out}");
    // Noise-free data: the answer is certified on 8 of the 9 equations.
    let certificate = &doc["certificate"];
    assert_eq!(certificate["certified"], serde_json::Value::Bool(true), "{out}");
    assert!(certificate["error_bound"].as_f64().is_some_and(|b| b < 1e-6), "{out}");
    assert_eq!(certificate["rows"].as_array().map(|r| r.len()), Some(8), "{out}");
}

#[test]
fn bad_solve_inputs_say_where() {
    let cases = [
        ("short.json", upnp_input(Some("[0.0, 1.0]")), "correspondence 3, field `f`: expected an array of 3 numbers, got an array of 2"),
        ("nan.json", upnp_input(Some("[0.0, NaN, 1.0]")), "NaN and Infinity are not JSON numbers"),
        ("string.json", upnp_input(Some("\"up\"")), "correspondence 3, field `f`: expected an array of 3 numbers, got a string"),
    ];
    for (name, text, want) in cases {
        let path = write(name, &text);
        let (ok, _, err) = simhc(&["solve", "upnp", "--input", path.to_str().expect("utf-8 path")]);
        assert!(!ok, "{name} was accepted");
        assert!(err.contains(want), "{name}: {err}");
        assert!(err.contains(name), "{name}: the error does not name the file: {err}");
    }
    // Well-formed but too few correspondences: the solver's typed error.
    let two = r#"[{"p": [0,0,5], "f": [0,0,1], "v": [0,0,0]}, {"p": [1,0,5], "f": [0.2,0,1], "v": [0,0,0]}]"#;
    let path = write("two.json", two);
    let (ok, _, err) = simhc(&["solve", "upnp", "--input", path.to_str().expect("utf-8 path")]);
    assert!(!ok);
    assert!(err.contains("too few correspondences: got 2"), "{err}");
    // GRPS reads through the same code.
    let grps = r#"{"correspondences": [{"f": [0,0,1], "v": [0,0,0], "fp": [0,0,1], "vq": [1,0,0]}]}"#;
    let path = write("grps.json", grps);
    let (ok, _, err) = simhc(&["solve", "grps", "--input", path.to_str().expect("utf-8 path")]);
    assert!(!ok);
    assert!(err.contains("correspondence 0: unknown field `vq`"), "{err}");
}

#[test]
fn bad_trials_files_say_where() {
    let trial = format!(r#"{{"correspondences": {}, "rotation": [[1,0,0],[0,1,0],[0,0,1]], "translation": [0.1,-0.2]}}"#, "[]");
    let path = write("trials.json", &format!("[{trial}]"));
    let (ok, _, err) = simhc(&["bench", "upnp", "--trials-file", path.to_str().expect("utf-8 path")]);
    assert!(!ok);
    assert!(err.contains("trial 0, field `translation`: expected an array of 3 numbers, got an array of 2"), "{err}");
}
