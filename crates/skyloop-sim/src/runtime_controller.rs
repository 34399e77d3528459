//! Runtime controllers from LTI models: Tustin discretization (skyloop-lti `c2d`) into the
//! state-space form and into cascaded second-order sections of skyloop-control.

use crate::error::{Result, SimError};
use skyloop_control::{Biquad, SosController, SsController};
use skyloop_lti::discretize::{c2d, Method};
use skyloop_lti::StateSpace;

/// A discrete SISO controller given by its matrices (row-major), sample time `dt_s`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DiscreteSiso {
    /// A (n×n).
    pub a: Vec<Vec<f64>>,
    /// B (n×1).
    pub b: Vec<Vec<f64>>,
    /// C (1×n).
    pub c: Vec<Vec<f64>>,
    /// D (1×1).
    pub d: Vec<Vec<f64>>,
    /// Sample time (s).
    pub dt: f64,
}

/// The controller as a discrete model at `dt_s`: continuous ones by Tustin (no prewarp, as the bicopter
/// paper's Step 5), discrete ones must already have that sample time. Delays are not allowed.
pub fn discretize(sys: &StateSpace, dt_s: f64) -> Result<StateSpace> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(SimError::Param(format!("dt = {dt_s} s must be finite and > 0")));
    }
    if sys.has_delay() {
        return Err(SimError::Param(
            "a runtime controller cannot have time delays (use pade first)".into(),
        ));
    }
    if sys.is_continuous() {
        Ok(c2d(sys, dt_s, Method::Tustin { prewarp_rad_s: None })?)
    } else if (sys.dt - dt_s).abs() <= 1e-9 * dt_s {
        Ok(sys.clone())
    } else {
        Err(SimError::Param(format!(
            "controller has dt = {} s, expected {dt_s} s",
            sys.dt
        )))
    }
}

fn rows(m: &faer::Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// A discrete SISO model as the scenario's `DiscreteSiso` matrices.
pub fn to_discrete_siso(d: &StateSpace) -> Result<DiscreteSiso> {
    if d.nu() != 1 || d.ny() != 1 || d.is_continuous() {
        return Err(SimError::Param(format!(
            "need a discrete SISO controller, got {}×{} with dt = {}",
            d.ny(),
            d.nu(),
            d.dt
        )));
    }
    Ok(DiscreteSiso {
        a: rows(&d.a),
        b: rows(&d.b),
        c: rows(&d.c),
        d: rows(&d.d),
        dt: d.dt,
    })
}

/// The discrete model as a runtime state-space controller (MIMO up to the capacities).
pub fn to_ss_controller<const NX: usize, const NU: usize, const NY: usize>(
    d: &StateSpace,
) -> Result<SsController<f64, NX, NU, NY>> {
    let flat = |m: &faer::Mat<f64>| rows(m).into_iter().flatten().collect::<Vec<f64>>();
    Ok(SsController::new(
        d.nx(),
        d.nu(),
        d.ny(),
        &flat(&d.a),
        &flat(&d.b),
        &flat(&d.c),
        &flat(&d.d),
    )?)
}

/// The discrete SISO model as a gain and biquads (the factorization is `skyloop_lti::sos::to_sos`).
pub fn to_sos(d: &StateSpace) -> Result<(Vec<Biquad<f64>>, f64)> {
    to_discrete_siso(d)?;
    let sos = skyloop_lti::sos::to_sos(d)?;
    let secs = sos
        .sections
        .iter()
        .map(|s| Biquad {
            b0: s.b0,
            b1: s.b1,
            b2: s.b2,
            a1: s.a1,
            a2: s.a2,
        })
        .collect();
    Ok((secs, sos.gain))
}

/// The discrete SISO model as a runtime SOS controller with output limits.
pub fn to_sos_controller<const N: usize>(d: &StateSpace, out_min: f64, out_max: f64) -> Result<SosController<f64, N>> {
    let (secs, k) = to_sos(d)?;
    Ok(SosController::new(&secs, k, out_min, out_max)?)
}
