//! One module per subcommand; `run` dispatches.

mod bode;
mod freqresp;
mod margins;
mod nyquist;
mod plot_args;
mod show;
mod step;

use clap::Subcommand;

/// Every skyloop subcommand.
#[derive(Subcommand)]
pub enum Command {
    /// Print a model's dimensions and matrices (or its LTI JSON with --json).
    Show(show::Args),
    /// Unit-step responses (optionally of the closed loop T = L/(1+L)), plotted and/or as JSON.
    Step(step::Args),
    /// Bode plot (magnitude dB, phase deg vs Hz) of one or more models to an SVG or PNG file.
    Bode(bode::Args),
    /// Nyquist plot of one or more SISO loop transfers to an SVG or PNG file.
    Nyquist(nyquist::Args),
    /// Complex frequency response at given frequencies (Hz), exact with delays.
    Freqresp(freqresp::Args),
    /// Gain, phase, delay and disk margins of a SISO loop transfer L = P·C, and closed-loop stability.
    Margins(margins::Args),
}

/// Runs one subcommand; the error text is what the user sees.
pub fn run(cmd: Command) -> Result<(), String> {
    match cmd {
        Command::Show(a) => show::run(a),
        Command::Step(a) => step::run(a),
        Command::Bode(a) => bode::run(a),
        Command::Nyquist(a) => nyquist::run(a),
        Command::Freqresp(a) => freqresp::run(a),
        Command::Margins(a) => margins::run(a),
    }
}
