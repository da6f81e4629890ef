//! `grp train|bench|solve|monodromy grp`: the four simhc commands for this crate's problem, from
//! one registration.

fn main() -> std::process::ExitCode {
    simhc_cli::App::new("grp", "Generalized relative pose with known scale, solved by Simulator HC")
        .register(simhc_cli::Declared::new(generalized_relative_pose::GenRelPose::new()))
        .main()
}
