//! One module per subcommand; `run` dispatches.

mod c2d;
mod poles;
mod roots_out;
mod show;
mod zeros;

use clap::Subcommand;

/// Every skyloop subcommand.
#[derive(Subcommand)]
pub enum Command {
    /// Print a model's dimensions and matrices (or its LTI JSON with --json).
    Show(show::Args),
    /// Discretize a continuous model (zoh, foh, tustin with optional prewarp, matched).
    C2d(c2d::Args),
    /// Poles of a model (eigenvalues of A).
    Poles(poles::Args),
    /// Transmission zeros of a model.
    Zeros(zeros::Args),
}

/// Runs one subcommand; the error text is what the user sees.
pub fn run(cmd: Command) -> Result<(), String> {
    match cmd {
        Command::Show(a) => show::run(a),
        Command::C2d(a) => c2d::run(a),
        Command::Poles(a) => poles::run(a),
        Command::Zeros(a) => zeros::run(a),
    }
}
