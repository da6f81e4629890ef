// Registering a type that is neither a `Registration` nor a `Declared` problem.
struct NotAProblem;

fn main() {
    let _ = simhc_cli::App::new("mine", "my problem").register(NotAProblem);
}
