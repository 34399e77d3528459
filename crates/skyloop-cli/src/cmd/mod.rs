//! One module per subcommand; `run` dispatches.

mod bode;
mod nyquist;
mod plot_args;
mod reproduce;
mod show;
mod simulate;

use clap::Subcommand;

/// Every skyloop subcommand.
#[derive(Subcommand)]
pub enum Command {
    /// Print a model's dimensions and matrices (or its LTI JSON with --json).
    Show(show::Args),
    /// Bode plot (magnitude dB, phase deg vs Hz) of one or more models to an SVG or PNG file.
    Bode(bode::Args),
    /// Nyquist plot of one or more SISO loop transfers to an SVG or PNG file.
    Nyquist(nyquist::Args),
    /// Nonlinear 6-DOF closed-loop simulation of a scenario (TOML) → trajectory CSV, metrics JSON, plot.
    Simulate(simulate::Args),
    /// Reproduce a paper's claims (quadrotor-ssi) and check them.
    Reproduce(reproduce::Args),
}

/// Runs one subcommand; the error text is what the user sees.
pub fn run(cmd: Command) -> Result<(), String> {
    match cmd {
        Command::Show(a) => show::run(a),
        Command::Bode(a) => bode::run(a),
        Command::Nyquist(a) => nyquist::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Reproduce(a) => reproduce::run(a),
    }
}
