//! `geneva`: the command-line entry point. All argument parsing and user-facing printing lives
//! in `cli/`; the library does the work. Errors are reported with anyhow's context chain,
//! each cause once (`cli::error_text`).

mod cli;

fn main() {
    // Rust ignores SIGPIPE, so `geneva … | head` panicked in `println!` once `head` closed the
    // pipe (exit 101 and a panic message). With the default action the process ends quietly
    // when its reader goes away, as every Unix tool does.
    #[cfg(unix)]
    // SAFETY: called first thing on the main thread, before any other thread exists; it only
    // resets a signal's disposition to the default.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    if let Err(error) = cli::main() {
        eprintln!("error: {}", cli::error_text(&error));
        std::process::exit(1);
    }
}
