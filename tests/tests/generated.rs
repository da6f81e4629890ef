//! `generated/` holds the current expansion of every built-in declaration.

use std::path::Path;

#[test]
fn generated_files_are_current() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let outputs = solvergen::built_in_outputs(&root).unwrap_or_else(|e| panic!("{e}"));
    let stale: Vec<&str> = outputs.iter().filter(|(_, _, d)| *d).map(|(p, _, _)| p.as_str()).collect();
    assert!(
        stale.is_empty(),
        "stale generated files: {stale:?}\nregenerate with: {}",
        solvergen::REGENERATE_COMMAND
    );
}

#[test]
fn generated_files_carry_the_header() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for (_, dst) in solvergen::BUILT_INS {
        let text = std::fs::read_to_string(root.join(dst)).unwrap_or_default();
        assert!(text.starts_with("// @generated"), "{dst} lacks the @generated header");
        assert!(text.contains(solvergen::REGENERATE_COMMAND), "{dst} does not name the regenerate command");
    }
}
