//! The `simhc` command: benchmarks of the built-in problems, solving from files, training,
//! monodromy. Every command comes from a registration (`simhc_cli::simhc_app`).

fn main() -> std::process::ExitCode {
    simhc_cli::simhc_app().main()
}
