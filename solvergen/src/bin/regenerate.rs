//! Regenerates `generated/` from the built-in declarations, or with `--check` fails when a
//! checked-in file is stale. Run from the workspace root:
//! `cargo run -p solvergen --bin regenerate [-- --check]`.

use std::path::Path;
use std::process::ExitCode;

/// (declaration source, generated file), relative to the workspace root.
const BUILT_INS: &[(&str, &str)] = &[
    ("problems/src/upnp/system.rs", "generated/upnp.rs"),
    ("problems/src/grps/system.rs", "generated/grps.rs"),
];

fn main() -> ExitCode {
    let check = std::env::args().any(|a| a == "--check");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut stale = false;
    for (src, dst) in BUILT_INS {
        let source = match std::fs::read_to_string(root.join(src)) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("cannot read {src}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let generated = match solvergen::generate_file(&source) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("{src}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let current = std::fs::read_to_string(root.join(dst)).unwrap_or_default();
        if current == generated {
            continue;
        }
        if check {
            eprintln!("{dst} is stale");
            stale = true;
        } else if let Err(e) = std::fs::write(root.join(dst), generated) {
            eprintln!("cannot write {dst}: {e}");
            return ExitCode::FAILURE;
        } else {
            println!("wrote {dst}");
        }
    }
    if stale {
        eprintln!("regenerate with: cargo run -p solvergen --bin regenerate");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
