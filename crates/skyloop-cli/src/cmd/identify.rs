//! `skyloop identify LOG --axis roll|pitch|yaw` (the pilot's preset) or `skyloop identify DATA --input
//! COL --output COL [--excitation COL] [--method ..] [--model EXPR --init ..]`: frequency response
//! from a log (open loop, or closed loop with the setpoint as instrument), a parametric fit with
//! honest errors and a held-out validation; `--json` prints the fields of
//! [`skyloop::identify::Identification::to_json`]. Warnings go to stderr as `warning: ...` lines.

use std::path::PathBuf;

use crate::output::print_json;
use skyloop::identify::{identify, plot_identification, Identification, IdentifyRequest};

/// Arguments of `skyloop identify`.
#[derive(clap::Args)]
pub struct Args {
    /// Log file: CSV with a time_s column, PX4 ULog, or Betaflight blackbox.
    data: PathBuf,
    /// roll, pitch or yaw: the firmware's rate-loop channels (PID sum → gyro, setpoint as instrument),
    /// all airborne segments and the model K*exp(-Td*s)/(s*(tau*s+1)); other flags override it.
    #[arg(long)]
    axis: Option<String>,
    /// Plant input column (e.g. `axisP[0]+axisI[0]+axisD[0]+axisF[0]`, `actuator_controls_0.control[0]`).
    #[arg(long)]
    input: Option<String>,
    /// Plant output column (e.g. `gyroADC[0]`, `vehicle_angular_velocity.xyz[0]`).
    #[arg(long)]
    output: Option<String>,
    /// Measured excitation (instrument) for a closed-loop estimate G = Φ_yr/Φ_ur; `none` for open loop.
    #[arg(long)]
    excitation: Option<String>,
    /// Measured disturbance whose linear effect on the output is removed before the estimate
    /// (conditioned spectra; welch and spafdr). `--axis` uses the throttle (`rcCommand[3]`, PX4's
    /// thrust setpoint, ArduPilot's `RATE.AOut`); `none` turns it off.
    #[arg(long)]
    disturbance: Option<String>,
    /// etfe, welch, spa or spafdr.
    #[arg(long, default_value = "spafdr")]
    method: String,
    /// Lowest frequency, Hz.
    #[arg(long)]
    fmin_hz: Option<f64>,
    /// Highest frequency, Hz.
    #[arg(long)]
    fmax_hz: Option<f64>,
    /// Start of the segment used, s.
    #[arg(long)]
    from: Option<f64>,
    /// End of the segment used, s.
    #[arg(long)]
    to: Option<f64>,
    /// Use the longest stretch where this holds, e.g. `rcCommand[3]>1100` (throttle above idle).
    #[arg(long = "where")]
    condition: Option<String>,
    /// Resampling rate, Hz (default: the fastest of the columns).
    #[arg(long)]
    rate: Option<f64>,
    /// Blackbox session (counted from 1); default: the longest.
    #[arg(long)]
    session: Option<usize>,
    /// Number of output frequencies (spa, spafdr).
    #[arg(long, default_value_t = 100)]
    n_freq: usize,
    /// Welch segment length (samples).
    #[arg(long)]
    nfft: Option<usize>,
    /// Welch window: hann, hamming, blackman, rectangular.
    #[arg(long, default_value = "hann")]
    window: String,
    /// Welch overlap fraction.
    #[arg(long, default_value_t = 0.5)]
    overlap: f64,
    /// SPA lag-window half width M (samples).
    #[arg(long)]
    lag_window: Option<usize>,
    /// SPAFDR relative resolution (smoothing width / frequency).
    #[arg(long, default_value_t = 0.15)]
    resolution: f64,
    /// Model expression with named parameters, e.g. `K*exp(-Td*s)/(tau*s+1)`.
    #[arg(long)]
    model: Option<String>,
    /// Initial values NAME=V,.. of every model parameter.
    #[arg(long)]
    init: Option<String>,
    /// Bounds NAME=LO:HI,.. (either side may be empty).
    #[arg(long)]
    bounds: Option<String>,
    /// Residual: log (default) or complex.
    #[arg(long, default_value = "log")]
    error: String,
    /// Frequency weights: inverse-variance (default), coherence (CIFER) or none.
    #[arg(long, default_value = "inverse-variance")]
    weighting: String,
    /// Also fit a rational TF with NZ zeros and NP poles, given as NZ/NP (e.g. 2/4).
    #[arg(long)]
    tf: Option<String>,
    /// Delay of the rational fit, s; estimated within [0, --max-delay-s] when absent.
    #[arg(long)]
    delay_s: Option<f64>,
    /// Largest delay the rational fit considers, s.
    #[arg(long, default_value_t = 0.1)]
    max_delay_s: f64,
    /// Blocks of the jackknife errors and the held-out validation (2..=64; 0: off).
    #[arg(long, default_value_t = 8)]
    blocks: usize,
    /// Report a fit whose fit percentage is below 0 instead of failing.
    #[arg(long)]
    allow_poor_fit: bool,
    /// Write the measured FRF with its 95 % band and the fitted models to this SVG/PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// Estimates the FRF (and fits) and prints or plots them.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (plot, json) = (a.plot.clone(), a.json);
    let req = IdentifyRequest {
        data: a.data,
        axis: a.axis,
        input: a.input,
        output: a.output,
        excitation: a.excitation,
        disturbance: a.disturbance,
        method: a.method,
        fmin_hz: a.fmin_hz,
        fmax_hz: a.fmax_hz,
        from: a.from,
        to: a.to,
        condition: a.condition,
        rate: a.rate,
        session: a.session,
        n_freq: a.n_freq,
        nfft: a.nfft,
        window: a.window,
        overlap: a.overlap,
        lag_window: a.lag_window,
        resolution: a.resolution,
        model: a.model,
        init: a.init,
        bounds: a.bounds,
        error: a.error,
        weighting: a.weighting,
        tf: a.tf,
        delay_s: a.delay_s,
        max_delay_s: a.max_delay_s,
        blocks: a.blocks,
        allow_poor_fit: a.allow_poor_fit,
    };
    let id = identify(&req)?;
    for n in &id.notes {
        eprintln!("{n}");
    }
    for w in &id.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(p) = &plot {
        plot_identification(p, &id)?;
        eprintln!("wrote {}", p.display());
    }
    if json {
        return print_json(&id.to_json());
    }
    print_table(&id);
    Ok(())
}

fn print_table(id: &Identification) {
    let (frf, fit, tf) = (&id.frf, id.fit.as_ref().map(|f| &f.1), id.tf.as_ref());
    println!(
        "{:>10} {:>12} {:>11} {:>10}",
        "freq_hz", "mag_db", "phase_deg", "coherence"
    );
    let (m, p) = (frf.mag_db(), frf.phase_deg());
    for i in 0..frf.freq_hz.len() {
        println!(
            "{:>10.4} {:>12.3} {:>11.2} {:>10.3}",
            frf.freq_hz[i], m[i], p[i], frf.coherence[i]
        );
    }
    if let Some(r) = fit {
        println!(
            "fit: {:.1} %{}",
            r.fit_percent,
            if r.converged { "" } else { " (iteration limit reached)" }
        );
        let unit = |k: &str| {
            id.units
                .as_ref()
                .and_then(|u| u.params.get(k))
                .map(|u| format!(" {u}"))
                .unwrap_or_default()
        };
        for (k, v) in &r.params {
            println!("  {k} = {v:.6} ± {:.3e}{}", r.stderr[k], unit(k));
        }
        if !r.at_bounds.is_empty() {
            println!("  at a bound: {}", r.at_bounds.join(", "));
        }
    }
    if !id.segments.is_empty() {
        let total: f64 = id.segments.iter().map(|s| s.to_s - s.from_s).sum();
        println!("segments: {} ({total:.1} s)", id.segments.len());
    }
    if let Some((lo, hi)) = id.coherent_band_hz {
        println!("coherent band: {lo:.2} .. {hi:.2} Hz");
    }
    if let Some((lo, hi)) = id.fit_band_hz {
        println!("fit band: {lo:.2} .. {hi:.2} Hz");
    }
    if let Some(v) = &id.validation {
        println!(
            "validation (held-out blocks {:?}): fit {:.1} % (inverse-variance weighted, log magnitude and phase: {:.1} %), FRF residual {:.3} (training fit {:.1} %)",
            v.test_blocks, v.fit_percent, v.weighted_fit_percent, v.frf_residual, v.train_fit_percent
        );
    }
    if let Some(t) = tf {
        println!(
            "tf: num {:?}, den {:?}, delay {:.4} s, fit {:.1} %",
            t.num, t.den, t.delay_s, t.fit_percent
        );
    }
}
