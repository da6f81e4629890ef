//! Tests live in tests/; this library holds what several of them share.

/// Runs `f` on a thread with a 256 MiB stack and returns its result (a panic in `f` is
/// re-raised here). This crate is built unoptimized (the workspace `Cargo.toml` says why), and
/// unoptimized, a generated function keeps each of its thousands of temporaries in a stack
/// slot of its own: GRPS's overflow the test harness's 2 MiB threads.
pub fn on_large_stack<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    std::thread::scope(|scope| {
        let thread = std::thread::Builder::new().stack_size(256 << 20).spawn_scoped(scope, f);
        match thread.map(|t| t.join()) {
            Ok(Ok(r)) => r,
            Ok(Err(panic)) => std::panic::resume_unwind(panic),
            Err(e) => panic!("cannot start a test thread with a large stack: {e}"),
        }
    })
}
