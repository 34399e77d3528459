//! `skyloop identify DATA --input COL --output COL [--excitation COL] [--method ..] [--model EXPR
//! --init ..]`: frequency response from a log (open loop, or closed loop with a measured excitation),
//! optionally a parametric fit; `--json` prints `{"frf": {...}, "fit": {...}}`.

use std::collections::HashMap;
use std::path::PathBuf;

use num_complex::Complex64 as C64;
use skyloop_plot::bode::BodeData;
use skyloop_plot::frf::{plot_frf, FrfEstimate};
use skyloop_sysid::fit::{fit_expr, fit_tf, DelaySpec, FitOptions, FitResult, ParamSpec, TfFit};
use skyloop_sysid::logs::{segments_where, Condition, Log, OpenOptions};
use skyloop_sysid::spectral::{estimate, Frf, IoData, Method, Options, Window};

use crate::output::print_json;

/// Arguments of `skyloop identify`.
#[derive(clap::Args)]
pub struct Args {
    /// Log file: CSV with a time_s column, PX4 ULog, or Betaflight blackbox.
    data: PathBuf,
    /// Plant input column (e.g. `axisP[0]+axisI[0]+axisD[0]+axisF[0]`, `actuator_controls_0.control[0]`).
    #[arg(long)]
    input: String,
    /// Plant output column (e.g. `gyroADC[0]`, `vehicle_angular_velocity.xyz[0]`).
    #[arg(long)]
    output: String,
    /// Measured excitation for a closed-loop estimate G = Φ_yr/Φ_ur.
    #[arg(long)]
    excitation: Option<String>,
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
    /// Write the measured FRF with its 95 % band and the fitted models to this SVG/PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

fn parse_pairs(text: &str, what: &str) -> Result<Vec<(String, String)>, String> {
    text.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(|t| {
            let (k, v) = t
                .split_once('=')
                .ok_or_else(|| format!("{what}: '{t}' is not NAME=VALUE"))?;
            Ok((k.trim().to_string(), v.trim().to_string()))
        })
        .collect()
}

fn num(v: &str, what: &str) -> Result<f64, String> {
    let x: f64 = v.parse().map_err(|_| format!("{what}: '{v}' is not a number"))?;
    if x.is_nan() {
        return Err(format!("{what}: NaN"));
    }
    Ok(x)
}

fn param_specs(a: &Args) -> Result<Vec<ParamSpec>, String> {
    let init = a
        .init
        .as_deref()
        .ok_or("--model needs --init NAME=V,.. for its parameters")?;
    let mut specs = Vec::new();
    for (k, v) in parse_pairs(init, "--init")? {
        specs.push(ParamSpec::new(&k, num(&v, &format!("--init {k}"))?));
    }
    if let Some(b) = &a.bounds {
        for (k, v) in parse_pairs(b, "--bounds")? {
            let (lo, hi) = v
                .split_once(':')
                .ok_or_else(|| format!("--bounds {k}: '{v}' is not LO:HI"))?;
            let p = specs
                .iter_mut()
                .find(|p| p.name == k)
                .ok_or_else(|| format!("--bounds names '{k}', which has no --init value"))?;
            if !lo.trim().is_empty() {
                p.lower = num(lo.trim(), &format!("--bounds {k}"))?;
            }
            if !hi.trim().is_empty() {
                p.upper = num(hi.trim(), &format!("--bounds {k}"))?;
            }
        }
    }
    Ok(specs)
}

/// Estimates the FRF (and fits) and prints or plots them.
pub fn run(a: Args) -> Result<(), String> {
    let method: Method = a.method.parse().map_err(|e: skyloop_sysid::SysidError| e.to_string())?;
    let window: Window = a.window.parse().map_err(|e: skyloop_sysid::SysidError| e.to_string())?;
    let log = Log::open(
        &a.data,
        &OpenOptions {
            session: a.session,
            ..Default::default()
        },
    )
    .map_err(|e| e.to_string())?;
    let mut cols: Vec<&str> = vec![a.input.as_str(), a.output.as_str()];
    if let Some(r) = &a.excitation {
        cols.push(r);
    }
    let cond = a
        .condition
        .as_deref()
        .map(Condition::parse)
        .transpose()
        .map_err(|e| e.to_string())?;
    if let Some(c) = &cond {
        cols.push(&c.column);
    }
    let mut data = log.uniform(&cols, a.rate, a.from, a.to).map_err(|e| e.to_string())?;
    if let Some(c) = &cond {
        let mask: Vec<bool> = data.columns[cols.len() - 1].iter().map(|&x| c.holds(x)).collect();
        let min_len = (2.0 / data.dt_s).ceil() as usize;
        let seg = segments_where(&mask, min_len)
            .into_iter()
            .max_by_key(|r| r.len())
            .ok_or_else(|| {
                format!(
                    "'{}' never holds for 2 s or more in the selected span",
                    a.condition.as_deref().unwrap_or("")
                )
            })?;
        eprintln!(
            "using {:.2} s .. {:.2} s where {}",
            data.t0_s + seg.start as f64 * data.dt_s,
            data.t0_s + seg.end as f64 * data.dt_s,
            a.condition.as_deref().unwrap_or("")
        );
        data = data.slice(seg).map_err(|e| e.to_string())?;
    }
    let io = IoData {
        u: &data.columns[0],
        y: &data.columns[1],
        r: a.excitation.as_ref().map(|_| data.columns[2].as_slice()),
        dt_s: data.dt_s,
    };
    let opts = Options {
        method,
        fmin_hz: a.fmin_hz,
        fmax_hz: a.fmax_hz,
        nfft: a.nfft,
        window,
        overlap: a.overlap,
        lag_window: a.lag_window,
        n_freq: a.n_freq,
        resolution: a.resolution,
        ..Options::default()
    };
    let frf = estimate(&io, &opts).map_err(|e| e.to_string())?;
    let fit_opts = FitOptions {
        error: match a.error.as_str() {
            "log" => skyloop_sysid::fit::ErrorKind::Log,
            "complex" => skyloop_sysid::fit::ErrorKind::Complex,
            o => return Err(format!("unknown --error '{o}' (log or complex)")),
        },
        weighting: match a.weighting.as_str() {
            "inverse-variance" => skyloop_sysid::fit::Weighting::InverseVariance,
            "coherence" => skyloop_sysid::fit::Weighting::Coherence,
            "none" => skyloop_sysid::fit::Weighting::None,
            o => return Err(format!("unknown --weighting '{o}' (inverse-variance, coherence, none)")),
        },
        ..FitOptions::default()
    };
    let fit = match &a.model {
        Some(text) => {
            let expr = skyloop_lti::expr::parse(text).map_err(|e| format!("--model: {e}"))?;
            let specs = param_specs(&a)?;
            let r = fit_expr(&frf, &expr, &specs, &fit_opts).map_err(|e| e.to_string())?;
            Some((expr, r))
        }
        None => {
            if a.init.is_some() || a.bounds.is_some() {
                return Err("--init and --bounds need --model".into());
            }
            None
        }
    };
    let tf = match &a.tf {
        Some(orders) => {
            let (nz, np) = orders
                .split_once('/')
                .ok_or_else(|| format!("--tf '{orders}' is not NZ/NP"))?;
            let nz: usize = nz.trim().parse().map_err(|_| format!("--tf: '{nz}' is not a count"))?;
            let np: usize = np.trim().parse().map_err(|_| format!("--tf: '{np}' is not a count"))?;
            let delay = match a.delay_s {
                Some(d) => DelaySpec::Fixed(d),
                None => DelaySpec::Estimate { max_s: a.max_delay_s },
            };
            Some(fit_tf(&frf, nz, np, delay, &fit_opts).map_err(|e| e.to_string())?)
        }
        None => None,
    };
    if let Some(p) = &a.plot {
        plot(p, &a, &frf, fit.as_ref(), tf.as_ref())?;
    }
    if a.json {
        let mut v = serde_json::json!({
            "frf": {
                "freq_hz": frf.freq_hz,
                "mag": frf.mag(),
                "phase_deg": frf.phase_deg(),
                "coherence": frf.coherence,
            }
        });
        if let Some((_, r)) = &fit {
            v["fit"] = serde_json::json!({
                "params": r.params,
                "stderr": r.stderr.iter().map(|(k, s)| (k.clone(), if s.is_finite() { serde_json::json!(s) } else { serde_json::Value::Null })).collect::<serde_json::Map<_, _>>(),
                "fit_percent": r.fit_percent,
            });
        }
        if let Some(t) = &tf {
            v["tf"] =
                serde_json::json!({"num": t.num, "den": t.den, "delay_s": t.delay_s, "fit_percent": t.fit_percent});
        }
        return print_json(&v);
    }
    print_table(&frf, fit.as_ref().map(|f| &f.1), tf.as_ref());
    Ok(())
}

fn print_table(frf: &Frf, fit: Option<&FitResult>, tf: Option<&TfFit>) {
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
        for (k, v) in &r.params {
            println!("  {k} = {v:.6} ± {:.3e}", r.stderr[k]);
        }
        if !r.at_bounds.is_empty() {
            println!("  at a bound: {}", r.at_bounds.join(", "));
        }
    }
    if let Some(t) = tf {
        println!(
            "tf: num {:?}, den {:?}, delay {:.4} s, fit {:.1} %",
            t.num, t.den, t.delay_s, t.fit_percent
        );
    }
}

fn plot(
    path: &std::path::Path,
    a: &Args,
    frf: &Frf,
    fit: Option<&(skyloop_lti::expr::Expr, FitResult)>,
    tf: Option<&TfFit>,
) -> Result<(), String> {
    let est = FrfEstimate {
        freq_hz: frf.freq_hz.clone(),
        mag_db: frf.mag_db(),
        phase_deg: frf.phase_deg(),
        mag_band_db: frf.mag_band_db(1.96),
        phase_band_deg: frf.phase_band_deg(1.96),
        coherence: frf.coherence.clone(),
    };
    let mut fits = Vec::new();
    let s_of = |f: f64| C64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let bode = |label: String, g: Vec<C64>| BodeData {
        label,
        freq_hz: frf.freq_hz.clone(),
        mag_db: g.iter().map(|g| 20.0 * g.norm().log10()).collect(),
        phase_deg: skyloop_sysid::spectral::unwrap_deg(g.iter().map(|g| g.arg().to_degrees())),
    };
    if let Some((expr, r)) = fit {
        let params: HashMap<String, f64> = r.params.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let g = frf
            .freq_hz
            .iter()
            .map(|f| expr.eval(s_of(*f), &params))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        fits.push(bode(format!("fit ({:.1} %)", r.fit_percent), g));
    }
    if let Some(t) = tf {
        fits.push(bode(
            format!("tf fit ({:.1} %)", t.fit_percent),
            frf.freq_hz.iter().map(|f| t.eval(s_of(*f))).collect(),
        ));
    }
    let title = format!("{} → {}", a.input, a.output);
    plot_frf(path, &title, &est, &fits).map_err(|e| e.to_string())?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
