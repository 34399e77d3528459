//! One module per subcommand; `run` dispatches.

mod augw;
mod bode;
mod c2d;
mod connect;
mod design;
mod export;
mod freqresp;
mod hinfstruct;
mod hinfsyn;
mod identify;
mod log;
mod margins;
mod minreal;
mod mu;
mod musyn;
mod ncfsyn;
mod nichols;
mod noise;
mod norm;
mod nyquist;
mod pade;
mod plot_args;
mod poles;
mod pzmap;
mod reduce;
mod reproduce;
mod roots_out;
mod show;
mod sigma;
mod signal;
mod simulate;
mod step;
mod timeverbs;
mod tune;
mod zeros;

use clap::Subcommand;

/// Every skyloop subcommand.
// Parsed once per process: the size of the largest variant costs nothing worth boxing for.
#[allow(clippy::large_enum_variant)]
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
    /// Singular values of the frequency response (dB vs Hz) of one or more models (MATLAB sigma).
    Sigma(sigma::Args),
    /// Nichols chart (open-loop gain dB vs phase deg, with M-circles) of SISO loop transfers.
    Nichols(nichols::Args),
    /// Pole-zero map of one or more models (imaginary axis, or unit circle when discrete).
    Pzmap(pzmap::Args),
    /// Root locus of a SISO loop transfer under a swept gain k (closed loop 1 + k·L = 0).
    Rlocus(pzmap::RlocusArgs),
    /// Structured singular value (mu) bounds of a model against a block structure, over frequency.
    Mu(mu::Args),
    /// H∞ norm with its peak frequency, and the H2 norm (null where infinite).
    Norm(norm::Args),
    /// Excitation signals (chirp, PRBS, multisine) written as CSV.
    Signal(signal::Args),
    /// Frequency response (and parametric fit) from a flight log.
    Identify(identify::Args),
    /// Inspect flight logs (ULog, blackbox, CSV).
    Log(log::Args),
    /// Complex frequency response at given frequencies (Hz), exact with delays.
    Freqresp(freqresp::Args),
    /// Gain, phase, delay and disk margins of a SISO loop transfer L = P·C, and closed-loop stability.
    Margins(margins::Args),
    /// Balanced model reduction (truncation or singular perturbation) keeping unstable poles.
    Reduce(reduce::Args),
    /// Minimal realization: removes uncontrollable and unobservable states.
    Minreal(minreal::Args),
    /// Nonlinear 6-DOF closed-loop simulation of a scenario (TOML) → trajectory CSV, metrics JSON, plot.
    Simulate(simulate::Args),
    /// Reproduce a paper's claims (bicopter, quadrotor-ssi, ducted-fan) and check them.
    Reproduce(reproduce::Args),
    /// Discretize a continuous model (zoh, foh, tustin with optional prewarp, matched).
    C2d(c2d::Args),
    /// Poles of a model (eigenvalues of A).
    Poles(poles::Args),
    /// Replace delays by Padé approximants (MATLAB pade).
    Pade(pade::Args),
    /// Transmission zeros of a model.
    Zeros(zeros::Args),
    /// Discretize a controller (Tustin) and write a self-contained C header for flight firmware.
    Export(export::Args),
    /// H∞ output-feedback synthesis (u = K·y, closed loop lft(P,K)): γ and controller.
    Hinfsyn(hinfsyn::Args),
    /// Fixed-order H∞ synthesis by nonsmooth optimization (u = K·y): γ and a controller of the given order.
    Hinfstruct(hinfstruct::Args),
    /// Response to an input signal or CSV samples (MATLAB lsim), as CSV, plot or JSON.
    Lsim(timeverbs::LsimArgs),
    /// Impulse response (MATLAB impulse), as CSV, plot or JSON.
    Impulse(timeverbs::ImpulseArgs),
    /// Continuous model of a discrete one (MATLAB d2c: zoh or tustin), the inverse of c2d.
    D2c(timeverbs::D2cArgs),
    /// Mixed-sensitivity generalized plant (MATLAB augw: W1·S, W2·KS, W3·T) as LTI JSON for hinfsyn.
    Augw(augw::Args),
    /// Series connection: the output of A drives B (MATLAB series(A, B) = B·A).
    Series(connect::Args),
    /// Parallel connection A + B (MATLAB parallel).
    Parallel(connect::Args),
    /// Closed loop y = A·(u + sign·B·y) (MATLAB feedback(A, B); --sign -1 by default).
    Feedback(connect::FeedbackArgs),
    /// MATLAB loopsens(P, C): S, T, CS and PS of u = C·(r − y) with their peaks, and stability.
    Loopsens(connect::LoopsensArgs),
    /// The noise picture of a flight: gyro, D-term and motor spectra, spectrograms against throttle and time, named peaks, the filter chain's delay, and a filter what-if (--filters).
    Noise(noise::Args),
    /// Tune a PID/PIDF of a firmware's structure against margin goals: gains, CLI lines, verified margins.
    Tune(tune::Args),
    /// Glover–McFarlane H∞ loop shaping: γ_min, γ and the controller for u = C·(r − y).
    Ncfsyn(ncfsyn::Args),
    /// Controller design from a TOML spec: synthesis, gain boost, reduction, Tustin; summary, plots, report.
    Design(design::Args),
    /// μ-synthesis by DK-iteration from a TOML spec: per-iteration γ and μ peaks, the best controller.
    Musyn(musyn::Args),
}

/// Runs one subcommand; the error's text is what the user sees.
pub fn run(cmd: Command) -> skyloop::Result<()> {
    match cmd {
        Command::Show(a) => show::run(a),
        Command::Step(a) => step::run(a),
        Command::Bode(a) => bode::run(a),
        Command::Nyquist(a) => nyquist::run(a),
        Command::Sigma(a) => sigma::run(a),
        Command::Nichols(a) => nichols::run(a),
        Command::Pzmap(a) => pzmap::run(a),
        Command::Rlocus(a) => pzmap::run_rlocus(a),
        Command::Mu(a) => mu::run(a),
        Command::Norm(a) => norm::run(a),
        Command::Signal(a) => signal::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Log(a) => log::run(a),
        Command::Freqresp(a) => freqresp::run(a),
        Command::Margins(a) => margins::run(a),
        Command::Reduce(a) => reduce::run(a),
        Command::Minreal(a) => minreal::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::C2d(a) => c2d::run(a),
        Command::Poles(a) => poles::run(a),
        Command::Pade(a) => pade::run(a),
        Command::Zeros(a) => zeros::run(a),
        Command::Export(a) => export::run(a),
        Command::Hinfsyn(a) => hinfsyn::run(a),
        Command::Hinfstruct(a) => hinfstruct::run(a),
        Command::Tune(a) => tune::run(a),
        Command::Noise(a) => noise::run(a),
        Command::Lsim(a) => timeverbs::run_lsim(a),
        Command::Impulse(a) => timeverbs::run_impulse(a),
        Command::D2c(a) => timeverbs::run_d2c(a),
        Command::Augw(a) => augw::run(a),
        Command::Series(a) => connect::run(connect::Verb::Series, a),
        Command::Parallel(a) => connect::run(connect::Verb::Parallel, a),
        Command::Feedback(a) => connect::run_feedback(a),
        Command::Loopsens(a) => connect::run_loopsens(a),
        Command::Ncfsyn(a) => ncfsyn::run(a),
        Command::Design(a) => design::run(a),
        Command::Musyn(a) => musyn::run(a),
    }
}
