//! The `simhc` command line of any set of problems: `<app> train|bench|ransac|solve|monodromy <problem>
//! [args]`. Each problem registers once ([`App::register`]) and brings the arguments and the
//! code of the commands it has; the app dispatches by name, so no problem has a match arm here.
//! The `simhc` binary registers the built-ins this way; a user's crate registers its own
//! problem with [`crate::Declared`] and gets the same four commands.

use clap::{ArgMatches, Command};
use std::ffi::OsString;
use std::process::ExitCode;

/// One of the commands a problem may have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verb {
    /// Train the learned start on the problem's simulated scenes and write its weights.
    Train,
    /// The paper's benchmark rows, measured in one run on the same trials.
    Bench,
    /// Solve the user's correspondences from a JSON file and print the solution as JSON.
    Solve,
    /// Find all solutions of a generic instance by monodromy and write the start system.
    Monodromy,
    /// The robust estimator on scenes with wrong matches: success, inlier recall and time.
    Ransac,
}

impl Verb {
    /// Every verb, in help order.
    pub const ALL: [Verb; 5] = [Verb::Bench, Verb::Ransac, Verb::Train, Verb::Solve, Verb::Monodromy];

    /// The subcommand's name.
    pub fn name(self) -> &'static str {
        match self {
            Verb::Train => "train",
            Verb::Bench => "bench",
            Verb::Solve => "solve",
            Verb::Monodromy => "monodromy",
            Verb::Ransac => "ransac",
        }
    }

    fn about(self) -> &'static str {
        match self {
            Verb::Train => "Train a problem's learned start on simulated scenes and write its weights",
            Verb::Bench => "The paper's benchmark rows, measured in one run on the same trials",
            Verb::Solve => "Solve correspondences from a JSON file and print the solution as JSON",
            Verb::Monodromy => "Find all solutions of a generic instance by monodromy and write the start system",
            Verb::Ransac => "The robust estimator on scenes with wrong matches: success, inlier recall and time per call",
        }
    }
}

/// A problem (or a benchmark) as the command line sees it: a name, the arguments of each
/// command it has, and the code that runs it.
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a simhc command-line registration",
    label = "register a problem here",
    note = "wrap a declared problem as `simhc_cli::Declared::new(..)` (its type implements `simhc::solver::DeclaredProblem` and `simhc::solver::Scenes`), or implement `simhc_cli::Registration`"
)]
pub trait Registration {
    /// The name on the command line (`upnp`, `grps`): lower case, no spaces.
    fn name(&self) -> &'static str;
    /// The arguments of `<app> <verb> <name>` as a clap command named [`Registration::name`],
    /// or `None` when the problem has no such command (no start system: no `monodromy`).
    fn command(&self, verb: Verb) -> Option<Command>;
    /// Runs `<app> <verb> <name>` with its parsed arguments.
    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String>;
}

/// A command-line application made of registered problems.
pub struct App {
    name: &'static str,
    about: &'static str,
    problems: Vec<Box<dyn Registration>>,
}

impl App {
    /// An application without problems.
    pub fn new(name: &'static str, about: &'static str) -> Self {
        Self { name, about, problems: Vec::new() }
    }

    /// The same application with one more problem.
    pub fn register(mut self, problem: impl Registration + 'static) -> Self {
        self.problems.push(Box::new(problem));
        self
    }

    /// The clap command (for help, completion or tests). A name registered twice, or a name
    /// that is not a lower-case word, is an error.
    pub fn command(&self) -> Result<Command, String> {
        for (i, p) in self.problems.iter().enumerate() {
            let name = p.name();
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_') {
                return Err(format!("registered problem {i}: name `{name}` is not a lower-case word"));
            }
            if self.problems[..i].iter().any(|q| q.name() == name) {
                return Err(format!("problem `{name}` is registered twice"));
            }
        }
        let mut app = Command::new(self.name)
            .about(self.about)
            .version(env!("CARGO_PKG_VERSION"))
            .subcommand_required(true)
            .arg_required_else_help(true);
        for verb in Verb::ALL {
            let subs: Vec<Command> = self.problems.iter().filter_map(|p| p.command(verb)).collect();
            if !subs.is_empty() {
                app = app.subcommand(Command::new(verb.name()).about(verb.about()).subcommand_required(true).subcommands(subs));
            }
        }
        Ok(app)
    }

    /// Parses `args` (the program name first) and runs the command. `--help` and argument
    /// errors come back as the error text.
    pub fn run_from<I, T>(&self, args: I) -> Result<(), String>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        let matches = self.command()?.try_get_matches_from(args).map_err(|e| e.render().to_string())?;
        self.dispatch(&matches)
    }

    fn dispatch(&self, matches: &ArgMatches) -> Result<(), String> {
        let (verb_name, verb_args) = matches.subcommand().ok_or("no command")?;
        let verb = Verb::ALL.into_iter().find(|v| v.name() == verb_name).ok_or_else(|| format!("unknown command `{verb_name}`"))?;
        let (name, args) = verb_args.subcommand().ok_or("no problem")?;
        let problem = self.problems.iter().find(|p| p.name() == name).ok_or_else(|| format!("unknown problem `{name}`"))?;
        problem.run(verb, args)
    }

    /// Parses the process arguments, runs, and turns an error into a message on stderr and a
    /// failing exit code (help and version print normally).
    pub fn main(&self) -> ExitCode {
        let command = match self.command() {
            Ok(c) => c,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        };
        let matches = command.get_matches();
        match self.dispatch(&matches) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        }
    }
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
