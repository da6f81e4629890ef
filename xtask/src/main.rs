//! Workspace chores. `cargo run -p xtask -- regenerate` rewrites the stale files of
//! `generated/` from the built-in declarations ([`xtask::BUILT_INS`]);
//! `cargo run -p xtask -- regenerate --check` only reports them and fails.

use std::process::ExitCode;

const USAGE: &str = "usage: cargo run -p xtask -- regenerate [--check]";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["regenerate"] => regenerate(false),
        ["regenerate", "--check"] => regenerate(true),
        _ => {
            eprintln!("{USAGE}");
            ExitCode::FAILURE
        }
    }
}

fn regenerate(check: bool) -> ExitCode {
    let root = xtask::workspace_root();
    let outputs = match xtask::built_in_outputs(&root) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let mut stale = false;
    for output in outputs.into_iter().filter(|o| o.stale) {
        let path = output.path;
        if check {
            eprintln!("{path} is stale");
            stale = true;
        } else if let Err(e) = std::fs::write(root.join(path), output.fresh) {
            eprintln!("cannot write {path}: {e}");
            return ExitCode::FAILURE;
        } else {
            println!("wrote {path}");
        }
    }
    if stale {
        eprintln!("regenerate with: {}", xtask::REGENERATE_COMMAND);
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
