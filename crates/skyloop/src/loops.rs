//! Loops formed from a plant and a controller, as MATLAB's `series`, `parallel`, `feedback` and
//! `loopsens` form them: L = P·C, the closed loop, and the four sensitivities with their peaks.
//!
//! Convention (MATLAB's): the controller acts on the error, u = C·(r − y), so the loop transfer at
//! the plant output is L = P·C, S = (I + P·C)⁻¹, T = I − S, and at the plant input
//! Sᵢ = (I + C·P)⁻¹; CS = C·S (control effort from r or output noise), PS = P·Sᵢ (output from an
//! input disturbance).

use crate::error::{Error, Result};
use crate::model::load_model;
use skyloop_lti::interconnect::{feedback, parallel, series};
use skyloop_lti::{Mat, StateSpace};

/// g2·g1: `first` then `second` (MATLAB `series(first, second)`).
///
/// # Errors
/// Dimensions that do not match, different sample times, or unequal delays on the connecting signals.
pub fn in_series(first: &StateSpace, second: &StateSpace) -> Result<StateSpace> {
    Ok(series(first, second)?)
}

/// g1 + g2 (MATLAB `parallel`).
///
/// # Errors
/// Dimensions or sample times that differ.
pub fn in_parallel(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    Ok(parallel(g1, g2)?)
}

/// The closed loop y = g1·(u + sign·g2·y) (MATLAB `feedback(g1, g2, sign)`; −1: negative feedback).
///
/// # Errors
/// A sign other than ±1, dimensions that do not match, an algebraic loop, or a delay inside the
/// loop (replace it by `pade` first).
pub fn closed(g1: &StateSpace, g2: &StateSpace, sign: f64) -> Result<StateSpace> {
    Ok(feedback(g1, g2, sign)?)
}

/// The loop transfer L = P·C of a plant and a controller named on a command line (expressions or
/// LTI JSON files).
///
/// # Errors
/// Models that do not load, or a controller whose outputs are not the plant's inputs.
///
/// # Examples
/// ```
/// let l = skyloop::loops::open_loop("10/(s*(s+1))", "(s+2)/(s+20)")?;
/// let all = skyloop::lti::margins::allmargin(&l)?;
/// assert!(all.stable);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn open_loop(plant: &str, controller: &str) -> Result<StateSpace> {
    let (p, c) = (load_model(plant)?, load_model(controller)?);
    if c.ny() != p.nu() {
        return Err(Error::Input(format!(
            "the controller has {} output(s) but the plant {} input(s): L = P·C needs them equal",
            c.ny(),
            p.nu()
        )));
    }
    Ok(series(&c, &p)?)
}

/// One sensitivity of [`loopsens`]: its model (None when a delay sits inside the loop: no exact
/// state-space form) and its peak gain.
#[derive(Debug, Clone)]
pub struct Sensitivity {
    /// "S", "T", "CS" or "PS".
    pub name: &'static str,
    /// What it maps, for a reader.
    pub meaning: &'static str,
    /// The model, when the loop has no delay.
    pub model: Option<StateSpace>,
    /// Peak gain (largest singular value over frequency; ∞ for an unstable loop).
    pub peak: f64,
    /// Its frequency, rad/s (NaN when infinite).
    pub peak_w_rad_s: f64,
}

/// MATLAB's `loopsens(P, C)`: S, T, CS and PS with their peaks, and whether the loop is stable.
/// With a delay (SISO only) the peaks are found on the exact frequency response and no models are
/// returned.
///
/// # Errors
/// Dimensions that do not match, or a MIMO loop with delays.
///
/// # Examples
/// ```
/// let p = skyloop::model::load_model("1/(s+1)")?;
/// let c = skyloop::model::load_model("4")?;
/// let (stable, s) = skyloop::loops::loopsens(&p, &c)?;
/// // S = (s+1)/(s+5): peak 1 at high frequency; T = 4/(s+5): peak 0.8 at DC.
/// assert!(stable && (s[0].peak - 1.0).abs() < 1e-6 && (s[1].peak - 0.8).abs() < 1e-6);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn loopsens(p: &StateSpace, c: &StateSpace) -> Result<(bool, Vec<Sensitivity>)> {
    if c.ny() != p.nu() || c.nu() != p.ny() {
        return Err(Error::Input(format!(
            "loopsens: the plant is {}x{} (outputs x inputs), so the controller must be {}x{}, not {}x{}",
            p.ny(),
            p.nu(),
            p.nu(),
            p.ny(),
            c.ny(),
            c.nu()
        )));
    }
    let l = series(c, p)?;
    let names = [
        (
            "S",
            "sensitivity (I + PC)⁻¹: reference → error, output disturbance → output",
        ),
        (
            "T",
            "complementary sensitivity PC(I + PC)⁻¹: reference → output, sensor noise → output",
        ),
        ("CS", "C(I + PC)⁻¹: reference or sensor noise → control"),
        ("PS", "P(I + CP)⁻¹: input disturbance → output"),
    ];
    let delayed = has_delay(p) || has_delay(c);
    if !delayed {
        let eye_y = StateSpace::gain(Mat::identity(p.ny(), p.ny()), p.dt)?;
        let eye_u = StateSpace::gain(Mat::identity(p.nu(), p.nu()), p.dt)?;
        let s = feedback(&eye_y, &l, -1.0)?;
        let t = feedback(&l, &eye_y, -1.0)?;
        let cs = series(&s, c)?;
        let si = feedback(&eye_u, &series(p, c)?, -1.0)?;
        let ps = series(&si, p)?;
        let stable = skyloop_lti::poles_zeros::poles(&s)?
            .iter()
            .all(|z| skyloop_lti::stabsep::is_stable_pole(*z, s.dt));
        // The plant's and controller's modes that the interconnection leaves uncontrollable or
        // unobservable (P's integrator in P·(I + CP)⁻¹) would read as poles on the axis.
        let out = [s, t, cs, ps]
            .into_iter()
            .map(|m| skyloop_lti::minreal::minreal(&m, None))
            .zip(names)
            .map(|(m, (name, meaning))| {
                let m = m?;
                let (peak, w) = skyloop_lti::norms::hinf_norm(&m)?;
                Ok(Sensitivity {
                    name,
                    meaning,
                    model: Some(m),
                    peak,
                    peak_w_rad_s: w,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        return Ok((stable, out));
    }
    if p.nu() != 1 || p.ny() != 1 {
        return Err(Error::Input(
            "loopsens: a MIMO loop with delays has no exact form here; replace the delays with `skyloop pade` first"
                .into(),
        ));
    }
    let all = skyloop_lti::margins::allmargin(&l)?;
    // The margins' band, widened: a sensitivity may peak at DC or approach its peak as ω → ∞
    // (a proper controller's CS tends to its feedthrough).
    let (lo, hi) = (all.w_range_rad_s.0 / 10.0, all.w_range_rad_s.1 * 1e4);
    let w: Vec<f64> = (0..8000).map(|k| lo * (hi / lo).powf(k as f64 / 7999.0)).collect();
    let (pr, cr) = (
        skyloop_lti::freqresp::freqresp_flat(p, &w)?,
        skyloop_lti::freqresp::freqresp_flat(c, &w)?,
    );
    let out = names
        .iter()
        .enumerate()
        .map(|(k, (name, meaning))| {
            let (peak, at) = pr
                .iter()
                .zip(&cr)
                .zip(&w)
                .map(|((pv, cv), wk)| {
                    let s = 1.0 / (1.0 + pv * cv);
                    let v = match k {
                        0 => s,
                        1 => 1.0 - s,
                        2 => cv * s,
                        _ => pv * s,
                    };
                    (v.norm(), *wk)
                })
                .fold((0.0, f64::NAN), |a, b| if b.0 > a.0 { b } else { a });
            let peak = if all.stable { peak } else { f64::INFINITY };
            Sensitivity {
                name,
                meaning,
                model: None,
                peak,
                peak_w_rad_s: if all.stable { at } else { f64::NAN },
            }
        })
        .collect();
    Ok((all.stable, out))
}

fn has_delay(g: &StateSpace) -> bool {
    g.input_delay.iter().chain(&g.output_delay).any(|d| *d != 0.0)
}
