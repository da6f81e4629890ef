//! The `simhc` command: benchmarks of the built-in problems, solving from files, training.

mod grps;
mod plots;
mod stats;
mod tracker_bench;
mod upnp;

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "simhc", version, about = "Simulator HC: regression + online simulator + single-path homotopy continuation")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum ProblemName {
    /// Generalized absolute pose (UPnP).
    Upnp,
    /// Generalized relative pose and scale (GRPS).
    Grps,
}

#[derive(Clone, Copy, ValueEnum)]
enum BenchName {
    /// Generalized absolute pose (UPnP): the paper's Table 1.
    Upnp,
    /// The tracker itself: step control, predictor and homotopy on UPnP and GRPS paths.
    Tracker,
    /// Generalized relative pose and scale: stability, start errors, noise, RANSAC, figures.
    Grps,
}

#[derive(Clone, Copy, ValueEnum)]
enum MonodromyProblem {
    /// GRPS with 7 correspondences (140 solutions modulo q -> -q).
    Grps7,
    /// UPnP as the square Lagrange system [q, lambda] (40 solutions modulo q -> -q).
    Upnp,
}

#[derive(Subcommand)]
enum Command {
    /// The paper's benchmark rows, measured in one run on the same trials.
    Bench {
        /// What to benchmark.
        problem: BenchName,
        /// Number of sampled trials.
        #[arg(long, default_value_t = 1000)]
        trials: usize,
        /// Seed of the trial sampler (printed; rerun with it to get the same trials).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Read the trials from this JSON file instead of sampling them.
        #[arg(long)]
        trials_file: Option<PathBuf>,
        /// Write the trials used to this JSON file.
        #[arg(long)]
        dump_trials: Option<PathBuf>,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
        /// Move every sampled trial to random frames: random rigid changes of the world and
        /// viewer frames (UPnP), of both views' frames and of view 2's units in [1/4, 4] (GRPS).
        #[arg(long)]
        random_frames: bool,
        /// `bench tracker`: rotation error of the starts in degrees.
        #[arg(long, default_value_t = 20.0)]
        start_angle: f64,
        #[command(flatten)]
        grps: grps::GrpsArgs,
        #[command(flatten)]
        upnp: upnp::UpnpArgs,
    },
    /// Train a built-in problem's regressor on simulated scenes and write its weights.
    Train {
        /// Built-in problem.
        problem: ProblemName,
        /// Output folder (default: the shipped weights, problems/weights).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the training stream (default: that of the shipped weights).
        #[arg(long)]
        seed: Option<u64>,
        /// Training scenes (default: that of the shipped weights).
        #[arg(long)]
        samples: Option<usize>,
        /// Epochs (default: that of the shipped weights).
        #[arg(long)]
        epochs: Option<usize>,
    },
    /// Find all solutions of a generic instance by monodromy and write the start system
    /// (solution counts are reported against theory).
    Monodromy {
        /// Built-in square problem.
        problem: MonodromyProblem,
        /// Seed of the run.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Stop after this many loops without a new solution.
        #[arg(long, default_value_t = 5)]
        stall_loops: usize,
        /// Write the start system (JSON) here; the shipped ones are problems/data/*_start.json.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Track paths in parallel (rayon).
        #[arg(long)]
        parallel: bool,
    },
    /// Solve a user's correspondences from a JSON file and print the pose as JSON.
    Solve {
        /// Built-in problem.
        problem: ProblemName,
        /// Input file.
        #[arg(long)]
        input: PathBuf,
    },
}

/// A progress bar on stderr, hidden when not wanted.
pub fn progress_bar(len: u64, visible: bool) -> indicatif::ProgressBar {
    if visible {
        let bar = indicatif::ProgressBar::new(len);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    }
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Bench { problem: BenchName::Tracker, trials, seed, json, start_angle, .. } => {
            if !json {
                println!("simhc bench tracker: {trials} paths per problem, seed {seed}, starts {start_angle} deg off, single thread");
            }
            let mut rows = tracker_bench::grps_rows(trials, seed, start_angle);
            rows.extend(tracker_bench::grps7_rows(trials, seed, start_angle));
            rows.extend(tracker_bench::upnp_rows(trials, seed, start_angle));
            if json {
                let doc = serde_json::json!({"seed": seed, "paths": trials, "start_angle_deg": start_angle, "rows": rows});
                println!("{}", serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?);
            } else {
                print!("{}", tracker_bench::table(&rows));
                println!("success: GRPS rotation < 1 deg, |t| and s within 1 %; UPnP rotation < 2 deg. t/paper: median per-path time ratio to the first row of the problem (the paper's schedule; for grps7 the real parameter homotopy)");
            }
            Ok(())
        }
        Command::Bench { problem: BenchName::Upnp, trials, seed, trials_file, dump_trials, json, random_frames, upnp: args, .. } => {
            let options = args.options(trials, seed, random_frames);
            let (scenes, source) = match &trials_file {
                Some(path) => (read_trials(path)?, format!("file {}", path.display())),
                None => (
                    upnp::sample_trials(&options)?,
                    format!("sampled, seed {seed}, {:?} box, random frames {}, {} px", options.layout, options.random_frames, options.scene.noise_px),
                ),
            };
            if let Some(path) = &dump_trials {
                let text = serde_json::to_string(&scenes).map_err(|e| e.to_string())?;
                std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
            if !json {
                println!("simhc bench upnp: {} trials ({source}), single thread", scenes.len());
            }
            let report = upnp::bench(&scenes, &options, source, !json)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?);
            } else {
                print!("{}", stats::table(&report.rows));
                println!("success: E_R < {} deg; errors over returned poses; times in microseconds per solve", report.thresholds.rotation_deg);
                println!("flag: returned flagged as not validated; wrong: returned unflagged yet over the threshold");
                let [first, second, fallback] = report.shipped_attempts;
                println!("shipped solver, validated at: first start {first}, second start {second}, all-roots fallback {fallback}");
                for row in [upnp::PRED_HC_ROW, upnp::SHIPPED_ROW] {
                    if let Some(ratio) = stats::median_time_ratio(&report.rows, upnp::ALL_ROOTS_ROW, row) {
                        println!("median time, All-roots HC / {row}: {ratio:.1}x");
                    }
                }
            }
            Ok(())
        }
        Command::Bench { problem: BenchName::Grps, trials, seed, trials_file, dump_trials, json, random_frames, grps: args, .. } => {
            let (scenes, source) = match &trials_file {
                Some(path) => (read_trials(path)?, format!("file {}", path.display())),
                None => (
                    grps::sample_trials(trials, seed, random_frames)?,
                    format!("sampled, seed {seed}, random frames {random_frames}"),
                ),
            };
            if let Some(path) = &dump_trials {
                let text = serde_json::to_string(&scenes).map_err(|e| e.to_string())?;
                std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
            if !json {
                println!("simhc bench grps: {} trials ({source}), seed {seed}, single thread", scenes.len());
            }
            let report = grps::bench(&scenes, seed, source, &args, !json)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?);
            } else {
                print!("{}", grps::text(&report));
            }
            Ok(())
        }
        Command::Train { problem: ProblemName::Grps, out, seed, samples, epochs } => {
            let mut config = simhc_regressor::grps::GrpsTrainConfig::default();
            if let Some(seed) = seed {
                config.train.seed = seed;
            }
            if let Some(n) = samples {
                config.train_samples = n;
            }
            if let Some(e) = epochs {
                config.train.epochs = e;
            }
            let out = out.unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights"));
            simhc_regressor::grps::train_and_write(&out, &config).map_err(|e| e.to_string())
        }
        Command::Solve { problem: ProblemName::Grps, input } => {
            let text = std::fs::read_to_string(&input).map_err(|e| format!("{}: {e}", input.display()))?;
            let out = grps::solve_file(&text).map_err(|e| format!("{}: {e}", input.display()))?;
            println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
            Ok(())
        }
        Command::Train { problem: ProblemName::Upnp, out, seed, samples, epochs } => {
            let mut config = simhc_regressor::upnp::UpnpTrainConfig::default();
            if let Some(seed) = seed {
                config.train.seed = seed;
            }
            if let Some(n) = samples {
                config.train_samples = n;
            }
            if let Some(e) = epochs {
                config.train.epochs = e;
            }
            let out = out.unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights"));
            simhc_regressor::upnp::train_and_write(&out, &config).map_err(|e| e.to_string())
        }
        Command::Monodromy { problem, seed, stall_loops, output, parallel } => {
            use simhc_problems::start_systems::{run_monodromy_grps7, run_monodromy_upnp, MonodromyConfig};
            let config = MonodromyConfig { seed, stall_loops, parallel, output, ..MonodromyConfig::default() };
            println!("simhc monodromy: seed {seed}, stop after {stall_loops} loops without a new solution");
            let report = match problem {
                MonodromyProblem::Grps7 => run_monodromy_grps7(&config),
                MonodromyProblem::Upnp => run_monodromy_upnp(&config),
            }
            .map_err(|e| e.to_string())?;
            println!("{report}");
            Ok(())
        }
        Command::Solve { problem: ProblemName::Upnp, input } => {
            let text = std::fs::read_to_string(&input).map_err(|e| format!("{}: {e}", input.display()))?;
            let out = upnp::solve_file(&text).map_err(|e| format!("{}: {e}", input.display()))?;
            println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
            Ok(())
        }
    }
}

/// A `--trials-file`: errors name the file, the trial, the correspondence and the field.
fn read_trials<T: simhc_problems::input::TrialFields>(path: &std::path::Path) -> Result<Vec<T>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    simhc_problems::input::parse_trials(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
