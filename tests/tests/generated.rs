//! `generated/` holds the current expansion of every built-in declaration (`xtask::BUILT_INS`).

#[test]
fn generated_files_are_current() {
    let outputs = xtask::built_in_outputs(&xtask::workspace_root()).unwrap_or_else(|e| panic!("{e}"));
    let stale: Vec<&str> = outputs.iter().filter(|o| o.stale).map(|o| o.path).collect();
    assert!(stale.is_empty(), "stale generated files: {stale:?}\nregenerate with: {}", xtask::REGENERATE_COMMAND);
}

#[test]
fn generated_files_carry_the_header() {
    let root = xtask::workspace_root();
    for (_, path) in xtask::BUILT_INS {
        let text = std::fs::read_to_string(root.join(path)).unwrap_or_default();
        assert!(text.starts_with("// @generated"), "{path} lacks the @generated header");
        assert!(text.contains(xtask::REGENERATE_COMMAND), "{path} does not name the regenerate command");
    }
}
