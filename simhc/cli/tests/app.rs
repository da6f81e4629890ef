//! The registration app: dispatch by name to the registered problem with its parsed
//! arguments, commands only where a problem has them, and clear errors for registration
//! mistakes found at run time (a name registered twice, a name that is not a word).

use clap::{Arg, ArgMatches, Command};
use simhc_cli::{App, Registration, Verb};
use std::cell::RefCell;
use std::rc::Rc;

/// The commands a [`Recorder`] ran, with their `--value`.
type Calls = Rc<RefCell<Vec<(Verb, String)>>>;

/// A problem with a `bench` command only, recording what it was asked to run.
struct Recorder {
    name: &'static str,
    calls: Calls,
}

impl Registration for Recorder {
    fn name(&self) -> &'static str {
        self.name
    }
    fn command(&self, verb: Verb) -> Option<Command> {
        (verb == Verb::Bench).then(|| Command::new(self.name).arg(Arg::new("value").long("value").required(true)))
    }
    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        let value = args.get_one::<String>("value").cloned().ok_or("no value")?;
        self.calls.borrow_mut().push((verb, value));
        Ok(())
    }
}

fn recorder(name: &'static str) -> (Recorder, Calls) {
    let calls = Rc::new(RefCell::new(Vec::new()));
    (Recorder { name, calls: calls.clone() }, calls)
}

#[test]
fn dispatches_to_the_named_problem_with_its_arguments() {
    let (a, calls_a) = recorder("alpha");
    let (b, calls_b) = recorder("beta");
    let app = App::new("app", "test").register(a).register(b);
    app.run_from(["app", "bench", "beta", "--value", "7"]).expect("runs");
    assert!(calls_a.borrow().is_empty());
    assert_eq!(*calls_b.borrow(), vec![(Verb::Bench, "7".to_string())]);
}

#[test]
fn commands_exist_only_where_a_problem_has_them() {
    let (a, _) = recorder("alpha");
    let app = App::new("app", "test").register(a);
    let err = app.run_from(["app", "train", "alpha"]).expect_err("alpha has no train");
    assert!(err.contains("unrecognized subcommand 'train'"), "{err}");
    let err = app.run_from(["app", "bench", "gamma", "--value", "1"]).expect_err("gamma is not registered");
    assert!(err.contains("unrecognized subcommand 'gamma'"), "{err}");
    let err = app.run_from(["app", "bench", "alpha"]).expect_err("--value is required");
    assert!(err.contains("--value"), "{err}");
}

#[test]
fn registration_mistakes_are_errors_that_name_the_problem() {
    let (a, _) = recorder("alpha");
    let (b, _) = recorder("alpha");
    let err = App::new("app", "test").register(a).register(b).command().expect_err("twice");
    assert_eq!(err, "problem `alpha` is registered twice");
    let (c, _) = recorder("Not A Word");
    let err = App::new("app", "test").register(c).command().expect_err("bad name");
    assert!(err.contains("`Not A Word` is not a lower-case word"), "{err}");
}

#[test]
fn the_simhc_app_registers_the_built_ins() {
    let app = simhc_cli::simhc_app().command().expect("valid registrations");
    let names = |verb: &str| -> Vec<String> {
        app.find_subcommand(verb).map(|c| c.get_subcommands().map(|s| s.get_name().to_string()).collect()).unwrap_or_default()
    };
    // `grps7`, `grps8`: GRPS through the generic assembly (their `train` refuses, below).
    assert_eq!(names("bench"), ["upnp", "grps", "grps7", "grps8", "tracker"]);
    assert_eq!(names("train"), ["upnp", "grps", "grps7", "grps8"]);
    assert_eq!(names("solve"), ["upnp", "grps", "grps7", "grps8"]);
    assert_eq!(names("monodromy"), ["upnp", "grps", "grps7", "grps8"]);
}

/// `train` on a problem that decodes its own network outputs (GRPS through the generic
/// assembly: a 6D rotation, not its quaternion) is refused with the problem's name, before any
/// training, and writes no weights.
#[cfg(feature = "train")]
#[test]
fn train_refuses_a_problem_with_its_own_output_decoding() {
    let out = std::env::temp_dir().join(format!("simhc-app-grps8-{}.folded", std::process::id()));
    let err = simhc_cli::simhc_app()
        .run_from(["simhc", "train", "grps8", "--samples", "16", "--epochs", "1", "--out", out.to_str().unwrap()])
        .expect_err("refused");
    assert!(err.contains("grps8") && err.contains("decodes its own network outputs"), "{err}");
    assert!(!out.exists(), "no weights written");
}
