//! Regenerates `generated/` from the built-in declarations (`solvergen::BUILT_INS`), or with
//! `--check` fails when a checked-in file is stale. Run from anywhere in the workspace:
//! `cargo run -p solvergen --bin regenerate [-- --check]`.

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let check = std::env::args().any(|a| a == "--check");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let outputs = match solvergen::built_in_outputs(&root) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let mut stale = false;
    for (dst, fresh, differs) in outputs {
        if !differs {
            continue;
        }
        if check {
            eprintln!("{dst} is stale");
            stale = true;
        } else if let Err(e) = std::fs::write(root.join(&dst), fresh) {
            eprintln!("cannot write {dst}: {e}");
            return ExitCode::FAILURE;
        } else {
            println!("wrote {dst}");
        }
    }
    if stale {
        eprintln!("regenerate with: {}", solvergen::REGENERATE_COMMAND);
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
