//! `tetbench`: the command line over the `algorithms` library (CONVENTIONS §8).

use std::process::ExitCode;

use clap::Parser;

#[global_allocator]
static ALLOC: algorithms::util::alloc::CountingAlloc = algorithms::util::alloc::CountingAlloc;

fn main() -> ExitCode {
    // `tetbench list | head` must end quietly, not panic on a closed pipe: restore the default
    // SIGPIPE action (Rust ignores it, turning a closed pipe into a failing print).
    #[cfg(unix)]
    // SAFETY: called before any thread starts; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    quiet_runtime_dir();
    let cli = tetbench::cli::Cli::parse();
    // Ctrl-C (or SIGTERM, SIGHUP): the first stops the run at the next frame (finished rows
    // are already on disk; peers end as their renderers are dropped), the second exits at once,
    // ending every peer's process group first (their `Drop` does not run on exit).
    let _ = ctrlc::set_handler(|| {
        use std::sync::atomic::Ordering;
        if tetbench::measure::INTERRUPTED.swap(true, Ordering::SeqCst) {
            algorithms::render::peer::end_all();
            std::process::exit(130);
        }
        eprintln!(
            "tetbench: interrupted, stopping after the current frame (Ctrl-C again to quit now)"
        );
    });
    match tetbench::commands::run(cli) {
        // 0, or 3 when some rows failed (each is in results.csv with its message): the run
        // went on, but says so.
        Ok(finished) => ExitCode::from(finished.exit_code()),
        Err(e) => {
            eprintln!("tetbench: {e}");
            if tetbench::measure::interrupted() {
                return ExitCode::from(130);
            }
            ExitCode::from(if e.is_user_error() { 2 } else { 1 })
        }
    }
}

/// The GPU stack (the Vulkan/EGL loaders under wgpu) prints "XDG_RUNTIME_DIR is invalid or not
/// set" on machines without a login session (containers, CI). Give it a private directory
/// when there is none, before any thread starts, so the message does not reach the user.
fn quiet_runtime_dir() {
    #[cfg(unix)]
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        use std::os::unix::fs::PermissionsExt;
        // SAFETY: getuid has no preconditions.
        let uid = unsafe { libc::getuid() };
        let d = std::env::temp_dir().join(format!("tetbench-runtime-{uid}"));
        if std::fs::create_dir_all(&d).is_ok()
            && std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o700)).is_ok()
        {
            // Single-threaded here: nothing else reads the environment concurrently.
            std::env::set_var("XDG_RUNTIME_DIR", &d);
        }
    }
}
