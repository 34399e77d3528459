//! Step responses with MATLAB's `stepinfo` marks, open loop or with the loop closed (a loop delay
//! kept exact by a delay-line simulation), on a window fitted to the slowest *dominant* dynamics.

use super::{channel, Labeled};
use crate::error::Result;
use serde::Serialize;
use skyloop_lti::interconnect::feedback;
use skyloop_lti::timeresp::{self, stepinfo, StepInfo};
use skyloop_lti::StateSpace;
use skyloop_plot::figure::Figure;
use skyloop_plot::traces::{step_figure, Trace};

/// The step responses of one model: `y[output][input][k]` at `t_s[k]`, and the `stepinfo` of each
/// channel, `info[output][input]`.
#[derive(Debug, Clone, Serialize)]
pub struct StepRun {
    /// The model's legend text.
    pub label: String,
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// Responses indexed \[output\]\[input\]\[sample\].
    pub y: Vec<Vec<Vec<f64>>>,
    /// Step characteristics of each channel (against the DC gain when the response is stable).
    pub info: Vec<Vec<StepInfo>>,
}

/// A model ready to simulate: what is stepped, and the delayed loop when the loop is closed around
/// a delay (then the response comes from the delay-line simulation of that loop).
struct Prepared {
    label: String,
    sys: StateSpace,
    delayed_loop: Option<StateSpace>,
    stable: bool,
}

/// Step responses of the models and their figure with `stepinfo` marks (rise, settling, overshoot,
/// undershoot, peak).
///
/// With `closed_loop`, each SISO model is the loop transfer L and the response is that of
/// T = L/(1+L) (negative unity feedback), exact with a loop delay. Without `t_final_s`, the window is
/// fitted to the responses: simulated first over about seven time constants of the slowest pole,
/// then cut to 1.5× the latest 2 % settling time, so a slow pole with a tiny residue (a PI zero
/// almost cancelling it) no longer stretches the plot of a response that settles in a fraction of it.
///
/// # Examples
/// ```
/// use skyloop::figures::{step, Labeled};
/// let l = Labeled::new("L", skyloop::prelude::parse_model("20*exp(-0.02*s)/(s*(0.05*s+1))")?);
/// let (_fig, runs) = step(&[l], true, None)?;
/// let info = &runs[0].info[0][0];
/// assert!((info.final_value - 1.0).abs() < 1e-9);
/// assert!(info.settling_time_s.unwrap() < 1.0 && info.overshoot_pct.unwrap() > 0.0);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn step(models: &[Labeled], closed_loop: bool, t_final_s: Option<f64>) -> Result<(Figure, Vec<StepRun>)> {
    if models.is_empty() {
        return Err("give at least one model".into());
    }
    if closed_loop {
        for m in models {
            super::check_order(&m.sys, &m.label, "a closed-loop step", super::MAX_CLOSED_LOOP_ORDER)?;
        }
    }
    let prepared = models
        .iter()
        .map(|m| prepare(m, closed_loop))
        .collect::<Result<Vec<_>>>()?;
    let runs = match t_final_s {
        Some(t) => with_fine_info(simulate_all(&prepared, Some(t))?, &prepared, t)?,
        None => {
            let first = simulate_all(&prepared, None)?;
            let t_auto = first.iter().map(|r| *r.t_s.last().unwrap_or(&0.0)).fold(0.0, f64::max);
            let settle = first
                .iter()
                .flat_map(|r| r.info.iter().flatten())
                .map(|i| i.settling_time_s)
                .try_fold(0.0f64, |a, s| s.map(|s| a.max(s)));
            match settle {
                // Every channel settles well inside the window: show 1.5× the latest settling.
                Some(ts) if ts > 0.0 && 1.5 * ts < 0.5 * t_auto => simulate_all(&prepared, Some(1.5 * ts))?,
                _ => first,
            }
        }
    };
    let mut traces = Vec::new();
    let mut infos = Vec::new();
    for (r, p) in runs.iter().zip(&prepared) {
        for (i, row) in r.y.iter().enumerate() {
            for (j, y) in row.iter().enumerate() {
                traces.push(Trace {
                    label: format!("{}{}", r.label, channel(&p.sys, i, j)),
                    t: r.t_s.clone(),
                    y: y.clone(),
                });
                infos.push(r.info[i][j]);
            }
        }
    }
    let title = if closed_loop {
        "Closed-loop step response"
    } else {
        "Step response"
    };
    Ok((step_figure(title, &traces, &infos), runs))
}

/// A window much longer than the dynamics leaves few samples in the transient (`--tfinal 1e9` on
/// 1/(s+1) put the rise time at 800 s): where a channel settles inside its automatic window and
/// that window is shorter than `t_final_s`, its step characteristics come from the automatic (fine)
/// grid, on which the same response is resolved.
fn with_fine_info(mut runs: Vec<StepRun>, prepared: &[Prepared], t_final_s: f64) -> Result<Vec<StepRun>> {
    let fine = simulate_all(prepared, None)?;
    for (r, f) in runs.iter_mut().zip(&fine) {
        let end = f.t_s.last().copied().unwrap_or(0.0);
        if end >= t_final_s {
            continue;
        }
        for (row, frow) in r.info.iter_mut().zip(&f.info) {
            for (info, fi) in row.iter_mut().zip(frow) {
                if fi.settling_time_s.is_some_and(|ts| ts < end) {
                    *info = *fi;
                }
            }
        }
    }
    Ok(runs)
}

/// Closes the loop when asked, and decides whether the response has a final value.
fn prepare(m: &Labeled, closed_loop: bool) -> Result<Prepared> {
    let mut sys = m.sys.clone();
    let mut delayed_loop = None;
    if closed_loop {
        m.siso("--closed-loop")?;
        let unity = StateSpace::gain(skyloop_lti::Mat::identity(1, 1), sys.dt)?;
        if sys.has_delay() && sys.is_continuous() {
            // The response is simulated with the exact delay; the Padé closed loop only sets the
            // time scale of the automatic window and the DC gain (Padé keeps it).
            let rational = sys.try_pade(3)?;
            let cl = feedback(&rational, &unity, -1.0).map_err(|e| format!("{}: {e}", m.label))?;
            delayed_loop = Some(std::mem::replace(&mut sys, cl));
        } else {
            sys = feedback(&sys, &unity, -1.0).map_err(|e| format!("{}: {e}", m.label))?;
        }
    }
    let stable = match &delayed_loop {
        Some(l) => skyloop_lti::margins::nyquist_stable(l).map_err(|e| format!("{}: {e}", m.label))?,
        None => skyloop_lti::poles_zeros::poles(&sys)?.iter().all(|p| {
            if sys.is_continuous() {
                p.re < 0.0
            } else {
                p.norm() < 1.0
            }
        }),
    };
    Ok(Prepared {
        label: m.label.clone(),
        sys,
        delayed_loop,
        stable,
    })
}

/// Simulates every model on one shared window (the longest automatic one when `t_final_s` is None).
fn simulate_all(models: &[Prepared], t_final_s: Option<f64>) -> Result<Vec<StepRun>> {
    let tf = match t_final_s {
        Some(t) => t,
        None => {
            let mut t: f64 = 0.0;
            for p in models {
                let g = timeresp::auto_grid(&p.sys, None).map_err(|e| format!("{}: {e}", p.label))?;
                t = t.max(g[g.len() - 1]);
            }
            t
        }
    };
    models
        .iter()
        .map(|p| {
            let grid = timeresp::auto_grid(&p.sys, Some(tf)).map_err(|e| format!("{}: {e}", p.label))?;
            let y =
                match &p.delayed_loop {
                    Some(l) => vec![vec![skyloop_sim::delayed_loop::closed_loop_step(l, &grid)
                        .map_err(|e| format!("{}: {e}", p.label))?]],
                    None => {
                        timeresp::step(&p.sys, Some(&grid))
                            .map_err(|e| format!("{}: {e}", p.label))?
                            .y
                    }
                };
            let dc = if p.stable {
                Some(skyloop_lti::poles_zeros::dcgain(&p.sys)?)
            } else {
                None
            };
            let info = (0..y.len())
                .map(|i| {
                    (0..y[i].len())
                        .map(|j| {
                            // An unstable or integrating response has no final value to measure against.
                            let yf = dc.as_ref().map_or(f64::NAN, |d| d[(i, j)]);
                            stepinfo(&grid, &y[i][j], Some(yf))
                        })
                        .collect()
                })
                .collect();
            Ok(StepRun {
                label: p.label.clone(),
                t_s: grid,
                y,
                info,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prelude::parse_model;

    /// A PI loop whose zero almost cancels a slow plant pole: the slow pole's residue is tiny, so the
    /// window follows the fast settling, not seven slow time constants.
    #[test]
    fn window_follows_the_dominant_dynamics() {
        let l = Labeled::new("L", parse_model("50*(s+0.1001)/(s*(s+0.1)*(0.02*s+1))").unwrap());
        let (_f, runs) = step(&[l], true, None).unwrap();
        let t_end = *runs[0].t_s.last().unwrap();
        let ts = runs[0].info[0][0].settling_time_s.unwrap();
        assert!(t_end < 5.0, "window {t_end} s");
        assert!((t_end - 1.5 * ts).abs() < 0.05 * t_end, "{t_end} vs settling {ts}");
    }

    /// An unstable response gets no final value, so no percentages.
    #[test]
    fn unstable_has_no_final_value() {
        let g = Labeled::new("G", parse_model("1/(s-1)").unwrap());
        let (_f, runs) = step(&[g], false, Some(2.0)).unwrap();
        assert_eq!(runs[0].info[0][0].overshoot_pct, None);
    }

    /// Closing a delayed loop simulates the delay exactly: nothing moves before the delay.
    #[test]
    fn delayed_loop_waits_for_its_delay() {
        let l = Labeled::new("L", parse_model("10*exp(-0.05*s)/(s+10)").unwrap());
        let (_f, runs) = step(&[l], true, Some(0.5)).unwrap();
        let r = &runs[0];
        for (t, y) in r.t_s.iter().zip(&r.y[0][0]) {
            if *t < 0.049 {
                assert!(y.abs() < 1e-12, "y({t}) = {y}");
            }
        }
        assert!((r.info[0][0].final_value - 0.5).abs() < 1e-9);
    }
}
