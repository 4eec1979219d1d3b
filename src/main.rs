//! `geneva`: the command-line entry point. All argument parsing and user-facing printing lives
//! in `cli/`; the library does the work. Errors are reported with anyhow's context chain,
//! each cause once (`cli::error_text`).

mod cli;

fn main() {
    if let Err(error) = cli::main() {
        eprintln!("error: {}", cli::error_text(&error));
        std::process::exit(1);
    }
}
