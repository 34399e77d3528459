//! The skyloop command-line tool: parses arguments, calls the crates, prints tables or JSON.
//!
//! Every failure prints `error: ...` on stderr and exits with status 2.

mod cmd;
mod input;
mod output;

use clap::Parser;

/// Robust flight-control design: from a flight log to a flyable, verified controller.
#[derive(Parser)]
#[command(name = "skyloop", version, about)]
struct Cli {
    #[command(subcommand)]
    command: cmd::Command,
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    if let Err(e) = cmd::run(cli.command) {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}
