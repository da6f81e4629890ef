//! Workspace knowledge the solver compiler does not need: which declarations of this workspace
//! are expanded into which checked-in files of `generated/`, and the command that refreshes
//! them (the `xtask` pattern, as rust-analyzer's sourcegen). The test
//! `tests/tests/generated.rs` uses [`built_in_outputs`] to fail when `generated/` is stale.

use std::path::{Path, PathBuf};

/// The built-in problems: (declaration source, generated file), relative to the workspace root.
pub const BUILT_INS: &[(&str, &str)] = &[
    ("problems/src/upnp/system.rs", "generated/upnp.rs"),
    ("problems/src/grps/system.rs", "generated/grps.rs"),
];

/// The command that refreshes `generated/` (named in the `@generated` header of its files).
pub const REGENERATE_COMMAND: &str = "cargo run -p xtask -- regenerate";

/// The workspace root (this crate sits one level below it).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh expansion of one built-in problem, and whether the checked-in file differs from it.
#[derive(Debug, Clone)]
pub struct Output {
    /// The generated file, relative to the workspace root.
    pub path: &'static str,
    /// Its fresh content.
    pub fresh: String,
    /// Whether the checked-in content differs (or the file is missing).
    pub stale: bool,
}

/// The fresh expansion of every built-in problem, compared with the checked-in files under
/// `root`.
pub fn built_in_outputs(root: &Path) -> Result<Vec<Output>, String> {
    let mut out = Vec::new();
    for &(src, path) in BUILT_INS {
        let source = std::fs::read_to_string(root.join(src)).map_err(|e| format!("cannot read {src}: {e}"))?;
        let fresh = solvergen::generate_file(&source).map_err(|e| format!("{src}: {e}"))?;
        let current = std::fs::read_to_string(root.join(path)).unwrap_or_default();
        let stale = current != fresh;
        out.push(Output { path, fresh, stale });
    }
    Ok(out)
}
