//! `geneva`: the command-line entry point. All argument parsing and user-facing printing lives
//! in `cli/`; the library does the work. Errors are reported with anyhow's context chain.

mod cli;

fn main() {
    if let Err(error) = cli::main() {
        eprintln!("error: {error:#}");
        std::process::exit(1);
    }
}
