//! The `pvrsim` binary: parses the command line, sets up logging, and maps
//! errors to a message and a non-zero exit code (never a panic on bad input).
//! A closed stdout (`pvrsim ... | head -1`) is a normal stop, exit 0, for
//! every command (see `pvrsim::job::output`).

use clap::Parser;

fn main() {
    pvrsim::job::output::install_broken_pipe_handler();
    let cli = pvrsim::cli::Cli::parse();
    pvrsim::cli::init_logging(cli.verbose);
    if let Err(e) = pvrsim::cli::run(cli) {
        if pvrsim::job::output::is_broken_pipe(&e) {
            std::process::exit(0);
        }
        eprint!("{}", pvrsim::cli::error_text(&e));
        std::process::exit(1);
    }
}
