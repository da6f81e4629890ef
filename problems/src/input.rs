//! Reading correspondences and trials from JSON with errors that say where: the runtime's
//! [`simhc::input`], re-exported here; the built-ins' correspondence and trial types implement
//! its [`VectorFields`] and [`TrialFields`] (in their `scene` modules), and the tests below read
//! them.

pub use simhc::input::*;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grps::scene::{GrpsCorrespondence, GrpsScene};
    use crate::upnp::scene::{UpnpCorrespondence, UpnpScene};
    use serde_json::Value;

    const GOOD: &str = r#"{"correspondences": [
        {"p": [1, 2, 3], "f": [0, 0, 1], "v": [0.5, 0, 0]},
        {"p": [2, 2, 3], "f": [0, 1, 0], "v": [0, 0, 0]}
    ]}"#;

    #[test]
    fn layout_params_match_the_generated_packing() {
        use simhc::ProblemLayout;
        let scene = crate::grps::scene::GrpsSceneConfig::default().sample_seeded(5).unwrap();
        let rows: Vec<String> = scene
            .correspondences
            .iter()
            .map(|c| {
                format!(
                    r#"{{"f": {:?}, "v": {:?}, "fp": {:?}, "vp": {:?}}}"#,
                    c.f.as_slice(),
                    c.v.as_slice(),
                    c.fp.as_slice(),
                    c.vp.as_slice()
                )
            })
            .collect();
        let text = format!(r#"{{"correspondences": [{}]}}"#, rows.join(", "));
        let p = parse_layout_params(&crate::grps::Grps8::LAYOUT, &text).unwrap();
        let rows8: [crate::grps::Row; 8] = std::array::from_fn(|i| crate::grps::Row::from(&scene.correspondences[i]));
        assert_eq!(p.as_slice(), crate::grps::Grps8::params(&rows8).as_slice());

        // A problem with a symmetric global and no rows.
        let m: Vec<Vec<f64>> = (0..11).map(|i| (0..11).map(|j| (i.min(j) * 11 + i.max(j)) as f64).collect()).collect();
        let text = format!(r#"{{"globals": {{"m": {m:?}}}}}"#);
        let p = parse_layout_params(&crate::upnp::Upnp::LAYOUT, &text).unwrap();
        let upper: Vec<f64> = (0..11).flat_map(|i| (i..11).map(move |j| (i * 11 + j) as f64)).collect();
        assert_eq!(p, upper);
    }

    #[test]
    fn layout_params_errors_say_where() {
        use simhc::ProblemLayout;
        let layout = crate::grps::Grps7::LAYOUT;
        let row = r#"{"f": [0, 0, 1], "v": [0, 0, 0], "fp": [0, 0, 1], "vp": [1, 0, 0]}"#;
        let seven = [row; 7].join(", ");
        assert!(parse_layout_params(&layout, &format!(r#"{{"correspondences": [{seven}]}}"#)).is_ok());
        let e = parse_layout_params(&layout, &format!(r#"{{"correspondences": [{}]}}"#, [row; 6].join(", "))).unwrap_err();
        assert_eq!(e.to_string(), "field `correspondences`: expected 7 correspondences, got 6");
        let mut rows = vec![row.to_string(); 7];
        rows[3] = row.replace(r#""vp": [1, 0, 0]"#, r#""vp": [1, 0]"#);
        let bad = rows.join(", ");
        let e = parse_layout_params(&layout, &format!(r#"{{"correspondences": [{bad}]}}"#)).unwrap_err();
        assert_eq!(e.to_string(), "correspondence 3, field `vp`: expected an array of 3 numbers, got an array of 2");
        let typo = seven.replacen(r#""fp""#, r#""fq""#, 1);
        let e = parse_layout_params(&layout, &format!(r#"{{"correspondences": [{typo}]}}"#)).unwrap_err();
        assert!(e.to_string().starts_with("correspondence 0: unknown field `fq`"), "{e}");
        let e = parse_layout_params(&layout, r#"{"correspondences": [{"f": [0, NaN, 1]}]}"#).unwrap_err();
        assert!(matches!(e, InputError::Syntax { line: 1, .. }), "{e}");
        let mut m = vec![vec![0.0; 11]; 11];
        m[2][5] = 1.0;
        let e = parse_layout_params(&crate::upnp::Upnp::LAYOUT, &format!(r#"{{"globals": {{"m": {m:?}}}}}"#)).unwrap_err();
        assert!(e.to_string().starts_with("field `m`, row 5: expected a symmetric matrix"), "{e}");
        let e = parse_layout_params(&crate::upnp::Upnp::LAYOUT, "{}").unwrap_err();
        assert_eq!(e.to_string(), "document: missing field `globals`");
    }

    #[test]
    fn both_forms_parse() {
        let a: Vec<UpnpCorrespondence> = parse_correspondences(GOOD).unwrap();
        assert_eq!(a.len(), 2);
        assert_eq!(a[0].v.x, 0.5);
        let bare = r#"[{"p": [1, 2, 3], "f": [0, 0, 1], "v": [0.5, 0, 0]}]"#;
        let b: Vec<UpnpCorrespondence> = parse_correspondences(bare).unwrap();
        assert_eq!(b[0], a[0]);
    }

    #[test]
    fn errors_say_where() {
        let short = GOOD.replace(r#""f": [0, 1, 0]"#, r#""f": [0, 1]"#);
        let e = parse_correspondences::<UpnpCorrespondence>(&short).unwrap_err();
        assert_eq!(e.to_string(), "correspondence 1, field `f`: expected an array of 3 numbers, got an array of 2");

        let text = GOOD.replace(r#""v": [0.5, 0, 0]"#, r#""v": [0.5, "x", 0]"#);
        let e = parse_correspondences::<UpnpCorrespondence>(&text).unwrap_err();
        assert_eq!(e.to_string(), "correspondence 0, field `v`: expected an array of 3 numbers, got a string at index 1");

        let missing = GOOD.replace(r#", "v": [0, 0, 0]"#, "");
        let e = parse_correspondences::<UpnpCorrespondence>(&missing).unwrap_err();
        assert_eq!(e, InputError::Missing { at: Location { correspondence: Some(1), ..Location::default() }, field: "v" });

        let typo = GOOD.replace(r#""p": [2"#, r#""P": [2"#);
        let e = parse_correspondences::<UpnpCorrespondence>(&typo).unwrap_err();
        assert!(e.to_string().starts_with("correspondence 1: unknown field `P`, expected one of `p`, `f`, `v`"), "{e}");

        let e = parse_correspondences::<UpnpCorrespondence>(r#"{"correspondences": 3}"#).unwrap_err();
        assert_eq!(e.to_string(), "field `correspondences`: expected an array of correspondences, got a number");
    }

    #[test]
    fn nan_is_a_syntax_error_with_a_hint() {
        let text = GOOD.replace(r#""f": [0, 0, 1]"#, r#""f": [0, NaN, 1]"#);
        match parse_correspondences::<UpnpCorrespondence>(&text).unwrap_err() {
            InputError::Syntax { line, column, message } => {
                assert_eq!(line, 2);
                assert!(column > 20, "column {column}");
                assert!(message.contains("NaN and Infinity are not JSON numbers"), "{message}");
            }
            e => panic!("{e}"),
        }
        let e = parse_correspondences::<UpnpCorrespondence>("{\"correspondences\": [").unwrap_err();
        assert!(matches!(e, InputError::Syntax { line: 1, .. }), "{e}");
    }

    #[test]
    fn trials_round_trip_and_report_their_index() {
        let scenes: Vec<UpnpScene> = (0..3).map(|s| crate::upnp::scene::UpnpSceneConfig::default().sample_seeded(s).unwrap()).collect();
        let text = serde_json::to_string(&scenes).unwrap();
        let back: Vec<UpnpScene> = parse_trials(&text).unwrap();
        assert_eq!(back, scenes);

        let mut doc: Value = serde_json::from_str(&text).unwrap();
        doc[2]["rotation"][1] = Value::String("x".into());
        let e = parse_trials::<UpnpScene>(&doc.to_string()).unwrap_err();
        assert_eq!(e.to_string(), "trial 2, field `rotation`, row 1: expected an array of 3 numbers, got a string");

        let grps: Vec<GrpsScene> = (0..2).map(|s| crate::grps::scene::GrpsSceneConfig::default().sample_seeded(s).unwrap()).collect();
        let text = serde_json::to_string(&grps).unwrap();
        assert_eq!(parse_trials::<GrpsScene>(&text).unwrap(), grps);
        let mut doc: Value = serde_json::from_str(&text).unwrap();
        doc[1].as_object_mut().unwrap().remove("scale");
        let e = parse_trials::<GrpsScene>(&doc.to_string()).unwrap_err();
        assert_eq!(e.to_string(), "trial 1: missing field `scale`");
        let _: Vec<GrpsCorrespondence> = parse_correspondences(r#"[{"f": [0,0,1], "v": [0,0,0], "fp": [0,0,1], "vp": [1,0,0]}]"#).unwrap();
    }
}
