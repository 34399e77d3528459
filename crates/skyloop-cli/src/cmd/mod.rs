//! One module per subcommand; `run` dispatches.

mod show;

use clap::Subcommand;

/// Every skyloop subcommand.
#[derive(Subcommand)]
pub enum Command {
    /// Print a model's dimensions and matrices (or its LTI JSON with --json).
    Show(show::Args),
}

/// Runs one subcommand; the error text is what the user sees.
pub fn run(cmd: Command) -> Result<(), String> {
    match cmd {
        Command::Show(a) => show::run(a),
    }
}
