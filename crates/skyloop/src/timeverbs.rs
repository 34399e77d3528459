//! MATLAB's `lsim` and `impulse` on a model named on a command line: inputs from a CSV file or a
//! signal spec (`step`, `ramp`, `sin:F[:A]`, `square:F[:A]`, `pulse:W[:A]`), sampled on a uniform
//! grid, held between samples (zero-order hold), as `lsim` does.

use crate::error::{Error, Result};
use skyloop_lti::timeresp;
use skyloop_lti::StateSpace;
use std::f64::consts::PI;

/// Most samples one simulation may take (a million already takes a second to print).
pub const MAX_SAMPLES: usize = 1_000_000;

/// Simulated outputs `y[k][output]` at `t_s[k]`, with the inputs that drove them.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Simulation {
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// Inputs `u[k][input]`.
    pub u: Vec<Vec<f64>>,
    /// Outputs `y[k][output]`.
    pub y: Vec<Vec<f64>>,
}

/// A uniform grid 0, dt, …, t_final (s).
///
/// # Errors
/// A step or final time that is not finite and positive, or more than [`MAX_SAMPLES`] samples.
pub fn grid(dt_s: f64, t_final_s: f64) -> Result<Vec<f64>> {
    if !(dt_s.is_finite() && dt_s > 0.0 && t_final_s.is_finite() && t_final_s > 0.0) {
        return Err(Error::Input(format!(
            "--dt and --tfinal must be finite positive times in s, got {dt_s} and {t_final_s}"
        )));
    }
    let n = (t_final_s / dt_s).round() + 1.0;
    if n > MAX_SAMPLES as f64 {
        return Err(Error::Input(format!(
            "--tfinal {t_final_s} s at --dt {dt_s} s is {n:.0} samples; at most {MAX_SAMPLES}"
        )));
    }
    Ok((0..n as usize).map(|k| k as f64 * dt_s).collect())
}

/// The signal a spec names at time `t` (s): `step`, `ramp` (slope 1/s), `sin:F[:A]` (F Hz,
/// amplitude A, default 1), `square:F[:A]`, `pulse:W[:A]` (A for the first W seconds).
///
/// # Errors
/// An unknown spec, or a frequency, width or amplitude that is not a finite number (frequency and
/// width positive).
pub fn signal(spec: &str) -> Result<impl Fn(f64) -> f64> {
    let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
    let num = |i: usize, what: &str, default: Option<f64>| -> Result<f64> {
        match (parts.get(i), default) {
            (Some(s), _) => s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| Error::Input(format!("--input {spec}: {what} '{s}' is not a finite number"))),
            (None, Some(d)) => Ok(d),
            (None, None) => Err(Error::Input(format!(
                "--input {spec}: give the {what}, e.g. {}:2",
                parts[0]
            ))),
        }
    };
    let kind = parts[0];
    let (a, b) = match kind {
        "step" | "ramp" => (0.0, 1.0),
        "sin" | "square" | "pulse" => {
            let a = num(
                1,
                if kind == "pulse" {
                    "width in s"
                } else {
                    "frequency in Hz"
                },
                None,
            )?;
            if a <= 0.0 {
                return Err(Error::Input(format!(
                    "--input {spec}: the {} must be positive",
                    if kind == "pulse" { "width" } else { "frequency" }
                )));
            }
            (a, num(2, "amplitude", Some(1.0))?)
        }
        _ => {
            return Err(Error::Input(format!(
                "--input '{spec}' is not one of step, ramp, sin:F[:A], square:F[:A], pulse:W[:A], or a CSV file"
            )))
        }
    };
    let kind = kind.to_string();
    Ok(move |t: f64| match kind.as_str() {
        "step" => 1.0,
        "ramp" => t,
        "sin" => b * (2.0 * PI * a * t).sin(),
        "square" => b * if (a * t).fract() < 0.5 { 1.0 } else { -1.0 },
        _ => {
            if t < a {
                b
            } else {
                0.0
            }
        }
    })
}

/// Refuses a signal spec that the grid of step `dt_s` (s) cannot carry: a `sin`/`square` at or above
/// the grid's Nyquist frequency 1/(2·dt) (its samples would be another frequency's: an aliased,
/// silently wrong input), or a `pulse` shorter than one step.
///
/// # Errors
/// Either case, naming the spec, the limit and the `--dt` that would carry it.
pub fn check_sampling(spec: &str, dt_s: f64) -> Result<()> {
    let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
    let Some(x) = parts.get(1).and_then(|s| s.parse::<f64>().ok()) else {
        return Ok(());
    };
    let nyquist = 0.5 / dt_s;
    match parts[0] {
        "sin" | "square" if x >= nyquist => Err(Error::Input(format!(
            "--input {spec}: {x} Hz is at or above the Nyquist frequency {nyquist} Hz of --dt {dt_s} s, so its samples would be those of another frequency; use --dt below {}",
            0.5 / x
        ))),
        "pulse" if x < dt_s => Err(Error::Input(format!(
            "--input {spec}: a pulse of {x} s is shorter than one step (--dt {dt_s} s); use --dt at most {x}"
        ))),
        _ => Ok(()),
    }
}

/// Reads inputs from a CSV file: a header, then rows of time (s) and one column per input; the
/// times must be uniform (as `lsim` needs).
///
/// # Errors
/// An unreadable file, non-numeric cells, fewer than two rows, or non-uniform times.
pub fn read_inputs(path: &std::path::Path, nu: usize) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
    let text = skyloop_lti::json::read_text_file(path).map_err(|e| Error::read(path, e))?;
    let (mut t, mut u) = (Vec::new(), Vec::new());
    for (k, line) in text.lines().enumerate().skip(1).filter(|(_, l)| !l.trim().is_empty()) {
        let v: Vec<f64> = line
            .split(',')
            .map(|c| c.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| {
                Error::Input(format!(
                    "{}: line {} has a cell that is not a finite number",
                    path.display(),
                    k + 1
                ))
            })?;
        if v.len() != nu + 1 {
            return Err(Error::Input(format!(
                "{}: line {} has {} columns; the model has {nu} input(s), so time plus {nu}",
                path.display(),
                k + 1,
                v.len()
            )));
        }
        t.push(v[0]);
        u.push(v[1..].to_vec());
        if t.len() > MAX_SAMPLES {
            return Err(Error::Input(format!(
                "{}: more than {MAX_SAMPLES} rows",
                path.display()
            )));
        }
    }
    if t.len() < 2 {
        return Err(Error::Input(format!(
            "{}: needs at least two rows of samples",
            path.display()
        )));
    }
    let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    if !(h > 0.0)
        || t.windows(2)
            .any(|w| ((w[1] - w[0]) - h).abs() > 1e-6 * h.max(1e-12) + 1e-9)
    {
        return Err(Error::Input(format!(
            "{}: the times must increase in equal steps (lsim holds each input for one step)",
            path.display()
        )));
    }
    Ok((t, u))
}

/// `lsim`: the response to inputs `u[k][input]` at the uniform times `t_s[k]`.
///
/// # Errors
/// Inputs that do not match the model, or a model that cannot be discretized on the grid.
///
/// # Examples
/// ```
/// use skyloop::timeverbs::{grid, lsim, signal};
/// let g = skyloop::model::load_model("1/(s+1)")?;
/// let t = grid(0.01, 5.0)?;
/// let step = signal("step")?;
/// let u: Vec<Vec<f64>> = t.iter().map(|&x| vec![step(x)]).collect();
/// let r = lsim(&g, &t, u)?;
/// assert!((r.y[500][0] - (1.0 - (-5.0f64).exp())).abs() < 1e-9);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn lsim(sys: &StateSpace, t_s: &[f64], u: Vec<Vec<f64>>) -> Result<Simulation> {
    let r = timeresp::lsim(sys, &u, t_s, None)?;
    Ok(Simulation { t_s: r.t_s, u, y: r.y })
}

/// `impulse`: the response to a unit impulse on each input in turn, `y[k][output·nu + input]`.
///
/// # Errors
/// A grid that is not uniform, or a model that cannot be simulated.
pub fn impulse(sys: &StateSpace, t_s: Option<&[f64]>) -> Result<Simulation> {
    let r = timeresp::impulse(sys, t_s)?;
    let n = r.t_s.len();
    let y = (0..n)
        .map(|k| r.y.iter().flat_map(|row| row.iter().map(move |ch| ch[k])).collect())
        .collect();
    Ok(Simulation {
        t_s: r.t_s,
        u: Vec::new(),
        y,
    })
}
