//! The built-in problems (UPnP, GRPS) and the tracker benchmark as [`Registration`]s: the
//! `simhc` binary is `App::new(..)` with these registered, like a user's crate with its own.

use crate::app::{Registration, Verb};
use crate::{grps, stats, tracker_bench, upnp};
use clap::{ArgMatches, Args, Command, FromArgMatches};
use std::path::{Path, PathBuf};

/// The trial arguments every built-in bench shares.
#[derive(Args, Debug, Clone)]
pub struct TrialArgs {
    /// Number of sampled trials.
    #[arg(long, default_value_t = 1000)]
    pub trials: usize,
    /// Seed of the trial sampler (printed; rerun with it to get the same trials).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Read the trials from this JSON file instead of sampling them.
    #[arg(long)]
    pub trials_file: Option<PathBuf>,
    /// Write the trials used to this JSON file.
    #[arg(long)]
    pub dump_trials: Option<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Move every sampled trial to random frames: random rigid changes of the world and
    /// viewer frames (UPnP), of both views' frames and of view 2's units in [1/4, 4] (GRPS).
    #[arg(long)]
    pub random_frames: bool,
}

#[derive(Args)]
struct UpnpBench {
    #[command(flatten)]
    trials: TrialArgs,
    #[command(flatten)]
    upnp: upnp::UpnpArgs,
}

#[derive(Args)]
struct GrpsBench {
    #[command(flatten)]
    trials: TrialArgs,
    #[command(flatten)]
    grps: grps::GrpsArgs,
}

/// `simhc train upnp|grps`, where the `train` feature builds the trainer.
#[cfg(feature = "train")]
mod train {
    use super::parse;
    use clap::{ArgMatches, Args};
    use std::path::PathBuf;

    /// `simhc train upnp|grps`.
    #[derive(Args)]
    pub(super) struct TrainArgs {
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
        /// Start hypotheses per prediction, 1 to 8 (GRPS; default: that of the shipped
        /// weights).
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=8))]
        hypotheses: Option<u8>,
        /// GRPS: a context stage after this many of the 4 per-row layers, 1 to 3 (every later
        /// per-row layer also reads the max-pooled features of all rows; default: that of the
        /// shipped weights).
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=3))]
        context_after: Option<u8>,
    }

    impl TrainArgs {
        fn apply(&self, train: &mut simhc_regressor::TrainConfig, samples: &mut usize) {
            if let Some(seed) = self.seed {
                train.seed = seed;
            }
            if let Some(n) = self.samples {
                *samples = n;
            }
            if let Some(e) = self.epochs {
                train.epochs = e;
            }
        }

        fn out(&self) -> PathBuf {
            self.out.clone().unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../problems/weights"))
        }
    }

    pub(super) fn upnp(args: &ArgMatches) -> Result<(), String> {
        let a: TrainArgs = parse(args)?;
        if a.hypotheses.is_some_and(|k| k != 1) {
            // One path from the single prediction already validates 99.9 % of UPnP trials.
            return Err("upnp trains one start hypothesis: drop --hypotheses".to_string());
        }
        if a.context_after.is_some() {
            return Err("upnp trains its shipped architecture: drop --context-after".to_string());
        }
        let mut config = simhc_regressor::upnp::UpnpTrainConfig::default();
        a.apply(&mut config.train, &mut config.train_samples);
        simhc_regressor::upnp::train_and_write(&a.out(), &config).map_err(|e| e.to_string())
    }

    pub(super) fn grps(args: &ArgMatches) -> Result<(), String> {
        let a: TrainArgs = parse(args)?;
        let mut config = simhc_regressor::grps::GrpsTrainConfig::default();
        a.apply(&mut config.train, &mut config.train_samples);
        if let Some(k) = a.hypotheses {
            config.hypotheses = k.into();
            config.model = simhc_regressor::grps::grps_model(config.hypotheses);
        }
        if let Some(k) = a.context_after {
            config.model = config.model.with_context_after(k.into());
        }
        simhc_regressor::grps::train_and_write(&a.out(), &config).map_err(|e| e.to_string())
    }
}

/// `simhc train <name>`: `None` where the `train` feature is off (no trainer is built).
fn train_command(name: &'static str, about: &'static str) -> Option<Command> {
    #[cfg(feature = "train")]
    return Some(command::<train::TrainArgs>(name, about));
    #[cfg(not(feature = "train"))]
    {
        let _ = (name, about);
        None
    }
}

/// What `train` says where the `train` feature is off (its commands are not registered then).
#[cfg(not(feature = "train"))]
pub(crate) const NO_TRAINER: &str = "this build has no trainer: enable simhc-cli's `train` feature";

/// `ransac` on a built-in that has none (GRPS's is `bench grps --experiment ransac`).
const NO_RANSAC: &str = "this problem has no `ransac` command";

/// `simhc monodromy <problem>`.
#[derive(Args, Debug, Clone)]
pub struct MonodromyArgs {
    /// Seed of the run.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop after this many loops without a new solution.
    #[arg(long, default_value_t = 5)]
    pub stall_loops: usize,
    /// Write the start system (JSON) here.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Track paths in parallel (rayon).
    #[arg(long)]
    pub parallel: bool,
}

impl MonodromyArgs {
    /// The settings of [`simhc_problems::start_systems::run_monodromy`].
    pub fn config(&self) -> simhc_problems::start_systems::MonodromyConfig {
        simhc_problems::start_systems::MonodromyConfig {
            seed: self.seed,
            stall_loops: self.stall_loops,
            parallel: self.parallel,
            output: self.output.clone(),
            ..Default::default()
        }
    }

    /// `simhc monodromy <problem>`: parses the arguments, prints the seed, runs `monodromy` and
    /// prints its report.
    pub fn run<R: std::fmt::Display, E: std::fmt::Display>(
        args: &ArgMatches,
        monodromy: impl FnOnce(&simhc_problems::start_systems::MonodromyConfig) -> Result<R, E>,
    ) -> Result<(), String> {
        let a: MonodromyArgs = parse(args)?;
        println!("monodromy: seed {}, stop after {} loops without a new solution", a.seed, a.stall_loops);
        let report = monodromy(&a.config()).map_err(|e| e.to_string())?;
        println!("{report}");
        Ok(())
    }
}

/// `simhc solve <problem>`.
#[derive(Args)]
struct SolveArgs {
    /// Input file.
    #[arg(long)]
    input: PathBuf,
}

fn parse<A: FromArgMatches>(m: &ArgMatches) -> Result<A, String> {
    A::from_arg_matches(m).map_err(|e| e.to_string())
}

fn command<A: Args>(name: &'static str, about: &'static str) -> Command {
    A::augment_args(Command::new(name)).about(about)
}

/// A `--trials-file`: errors name the file, the trial, the correspondence and the field.
fn read_trials<T: simhc_problems::input::TrialFields>(path: &Path) -> Result<Vec<T>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    simhc_problems::input::parse_trials(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn dump<T: serde::Serialize>(path: &Option<PathBuf>, scenes: &T) -> Result<(), String> {
    if let Some(path) = path {
        let text = serde_json::to_string(scenes).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

fn print_json<T: serde::Serialize>(value: &T) -> Result<(), String> {
    println!("{}", serde_json::to_string_pretty(value).map_err(|e| e.to_string())?);
    Ok(())
}

fn solve(args: &ArgMatches, solve_file: fn(&str) -> Result<serde_json::Value, String>) -> Result<(), String> {
    let SolveArgs { input } = parse(args)?;
    let text = std::fs::read_to_string(&input).map_err(|e| format!("{}: {e}", input.display()))?;
    print_json(&solve_file(&text).map_err(|e| format!("{}: {e}", input.display()))?)
}

/// Generalized absolute pose (UPnP): the paper's Table 1.
#[derive(Debug, Clone, Copy, Default)]
pub struct Upnp;

impl Registration for Upnp {
    fn name(&self) -> &'static str {
        "upnp"
    }

    fn command(&self, verb: Verb) -> Option<Command> {
        Some(match verb {
            Verb::Ransac => command::<crate::ransac::RansacArgs>(
                "upnp",
                "UPnP's robust estimator (4-correspondence samples) on scenes with wrong matches; --noise in px, --threshold in radians",
            ),
            Verb::Bench => command::<UpnpBench>("upnp", "Generalized absolute pose (UPnP): the paper's Table 1"),
            Verb::Train => return train_command("upnp", "Train the UPnP regressor (defaults: the shipped weights' settings)"),
            Verb::Solve => command::<SolveArgs>("upnp", "Solve UPnP correspondences {\"correspondences\": [{\"p\", \"f\", \"v\"}, ..]}"),
            Verb::Monodromy => {
                command::<MonodromyArgs>("upnp", "UPnP as the square Lagrange system [q, lambda] (40 solutions modulo q -> -q)")
            }
        })
    }

    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        match verb {
            Verb::Bench => {
                let UpnpBench { trials: t, upnp: args } = parse(args)?;
                let options = args.options(t.trials, t.seed, t.random_frames);
                let (scenes, source) = match &t.trials_file {
                    Some(path) => (read_trials(path)?, format!("file {}", path.display())),
                    None => (
                        upnp::sample_trials(&options)?,
                        format!(
                            "sampled, seed {}, {:?} box, random frames {}, {} px",
                            t.seed, options.layout, options.random_frames, options.scene.noise_px
                        ),
                    ),
                };
                dump(&t.dump_trials, &scenes)?;
                if !t.json {
                    println!("simhc bench upnp: {} trials ({source}), single thread", scenes.len());
                }
                let report = upnp::bench(&scenes, &options, source, !t.json)?;
                if t.json {
                    return print_json(&report);
                }
                print!("{}", stats::table(&report.rows));
                println!(
                    "success: E_R < {} deg; errors over returned poses; times in microseconds per solve",
                    report.thresholds.rotation_deg
                );
                println!("flag: returned flagged as not validated; wrong: returned unflagged yet over the threshold");
                println!("{}", report.certificates.line());
                let [linear, learned, fallback] = report.shipped_attempts;
                println!("shipped solver, validated from: the linear start {linear}, the learned start {learned}, the all-roots fallback {fallback}");
                for row in [upnp::PRED_HC_ROW, upnp::SHIPPED_ROW] {
                    if let Some(ratio) = stats::median_time_ratio(&report.rows, upnp::ALL_ROOTS_ROW, row) {
                        println!("median time, All-roots HC / {row}: {ratio:.1}x");
                    }
                }
                Ok(())
            }
            #[cfg(feature = "train")]
            Verb::Train => train::upnp(args),
            #[cfg(not(feature = "train"))]
            Verb::Train => Err(NO_TRAINER.into()),
            Verb::Solve => solve(args, upnp::solve_file),
            Verb::Monodromy => MonodromyArgs::run(args, simhc_problems::start_systems::run_monodromy_upnp),
            Verb::Ransac => {
                let a: crate::ransac::RansacArgs = parse(args)?;
                let (file, source, report) = upnp::ransac(&a)?;
                crate::ransac::print(&a, &file, &source, &report)
            }
        }
    }
}

/// Generalized relative pose and scale (GRPS).
#[derive(Debug, Clone, Copy, Default)]
pub struct Grps;

impl Registration for Grps {
    fn name(&self) -> &'static str {
        "grps"
    }

    fn command(&self, verb: Verb) -> Option<Command> {
        Some(match verb {
            Verb::Bench => {
                command::<GrpsBench>("grps", "Generalized relative pose and scale: stability, start errors, noise, RANSAC, figures")
            }
            Verb::Train => return train_command("grps", "Train the GRPS regressor (defaults: the shipped weights' settings)"),
            Verb::Solve => {
                command::<SolveArgs>("grps", "Solve GRPS correspondences {\"correspondences\": [{\"f\", \"v\", \"fp\", \"vp\"}, ..]}")
            }
            Verb::Monodromy => command::<MonodromyArgs>("grps", "GRPS with 7 correspondences (140 solutions modulo q -> -q)"),
            // `bench grps --experiment ransac` is GRPS's.
            Verb::Ransac => return None,
        })
    }

    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        match verb {
            Verb::Bench => {
                let GrpsBench { trials: t, grps: args } = parse(args)?;
                let (scenes, source) = match &t.trials_file {
                    Some(path) => (read_trials(path)?, format!("file {}", path.display())),
                    None => (
                        grps::sample_trials(t.trials, t.seed, t.random_frames)?,
                        format!("sampled, seed {}, random frames {}", t.seed, t.random_frames),
                    ),
                };
                dump(&t.dump_trials, &scenes)?;
                if !t.json {
                    println!("simhc bench grps: {} trials ({source}), seed {}, single thread", scenes.len(), t.seed);
                }
                let report = grps::bench(&scenes, t.seed, source, &args, !t.json)?;
                if t.json {
                    return print_json(&report);
                }
                print!("{}", grps::text(&report));
                Ok(())
            }
            #[cfg(feature = "train")]
            Verb::Train => train::grps(args),
            #[cfg(not(feature = "train"))]
            Verb::Train => Err(NO_TRAINER.into()),
            Verb::Solve => solve(args, grps::solve_file),
            Verb::Monodromy => MonodromyArgs::run(args, simhc_problems::start_systems::run_monodromy_grps7),
            Verb::Ransac => Err(NO_RANSAC.into()),
        }
    }
}

/// `simhc bench tracker`.
#[derive(Args)]
struct TrackerArgs {
    /// Paths per problem.
    #[arg(long, default_value_t = 1000)]
    trials: usize,
    /// Seed of the sampled paths.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Rotation error of the starts in degrees.
    #[arg(long, default_value_t = 20.0)]
    start_angle: f64,
}

/// The tracker itself: step control, predictor and homotopy on UPnP and GRPS paths (a bench
/// only).
#[derive(Debug, Clone, Copy, Default)]
pub struct TrackerBench;

impl Registration for TrackerBench {
    fn name(&self) -> &'static str {
        "tracker"
    }

    fn command(&self, verb: Verb) -> Option<Command> {
        (verb == Verb::Bench)
            .then(|| command::<TrackerArgs>("tracker", "The tracker itself: step control, predictor and homotopy on UPnP and GRPS paths"))
    }

    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        if verb != Verb::Bench {
            return Err(format!("tracker has no `{}` command", verb.name()));
        }
        let TrackerArgs { trials, seed, json, start_angle } = parse(args)?;
        if !json {
            println!("simhc bench tracker: {trials} paths per problem, seed {seed}, starts {start_angle} deg off, single thread");
        }
        let mut rows = tracker_bench::grps_rows(trials, seed, start_angle);
        rows.extend(tracker_bench::grps7_rows(trials, seed, start_angle));
        rows.extend(tracker_bench::upnp_rows(trials, seed, start_angle));
        if json {
            return print_json(&serde_json::json!({"seed": seed, "paths": trials, "start_angle_deg": start_angle, "rows": rows}));
        }
        print!("{}", tracker_bench::table(&rows));
        println!("success: GRPS rotation < 1 deg, |t| and s within 1 %; UPnP rotation < 2 deg. t/paper: median per-path time ratio to the first row of the problem (the paper's schedule; for grps7 the real parameter homotopy)");
        Ok(())
    }
}
