//! Runtime controllers from LTI models: Tustin discretization (skyloop-lti `c2d`) into the
//! state-space form and into cascaded second-order sections of skyloop-control.

use crate::error::{Result, SimError};
use crate::flight::DiscreteSiso;
use skyloop_control::{Biquad, SosController, SsController};
use skyloop_lti::discretize::{c2d, Method};
use skyloop_lti::{c64, StateSpace};

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

/// Pairs roots into conjugate pairs and leftover reals (closest reals together).
fn pair(mut r: Vec<c64>) -> Vec<(c64, Option<c64>)> {
    let mut out = Vec::new();
    let tol = 1e-9;
    let mut reals: Vec<f64> = Vec::new();
    r.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    while let Some(z) = r.pop() {
        if z.im.abs() <= tol * z.norm().max(1.0) {
            reals.push(z.re);
        } else {
            let k = r
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1 - z.conj()).norm().total_cmp(&(b.1 - z.conj()).norm()));
            let idx = k.map(|(i, _)| i);
            if let Some(i) = idx {
                let w = r.remove(i);
                out.push((z, Some(w)));
            } else {
                reals.push(z.re);
            }
        }
    }
    reals.sort_by(|a, b| a.total_cmp(b));
    let mut it = reals.into_iter();
    while let Some(a) = it.next() {
        out.push((c64::new(a, 0.0), it.next().map(|b| c64::new(b, 0.0))));
    }
    out
}

/// Monic polynomial coefficients [1, c1, c2] of a root pair (or [0, 1, −z] for a single root, [0, 0, 1] for none),
/// as coefficients of z², z¹, z⁰.
fn quad(p: Option<(c64, Option<c64>)>) -> [f64; 3] {
    match p {
        Some((a, Some(b))) => [1.0, -(a + b).re, (a * b).re],
        Some((a, None)) => [0.0, 1.0, -a.re],
        None => [0.0, 0.0, 1.0],
    }
}

/// The discrete SISO model as a gain and biquads (poles and zeros paired in order of magnitude).
pub fn to_sos(d: &StateSpace) -> Result<(Vec<Biquad<f64>>, f64)> {
    to_discrete_siso(d)?;
    let poles = skyloop_lti::analysis::poles(d)?;
    let zeros = skyloop_lti::analysis::zeros(d)?;
    if zeros.len() > poles.len() {
        return Err(SimError::Param("more zeros than poles".into()));
    }
    let pp = pair(poles.clone());
    let zp = pair(zeros.clone());
    let mut secs = Vec::with_capacity(pp.len());
    let mut zi = zp.into_iter();
    for p in pp {
        let den = quad(Some(p));
        let num = quad(zi.next());
        // section (n0 z² + n1 z + n2)/(z² + d1 z + d2) in z⁻¹ form when the denominator is 2nd order;
        // a 1st-order denominator [0, 1, −p] is shifted up to (z − p)·z / z².
        let (n, dd) = if den[0] == 0.0 {
            ([num[1], num[2], 0.0], [den[1], den[2], 0.0])
        } else {
            (num, den)
        };
        let n = if den[0] == 0.0 && num[0] != 0.0 {
            return Err(SimError::Param(
                "cannot place a 2nd-order numerator over a 1st-order section".into(),
            ));
        } else {
            n
        };
        secs.push(Biquad {
            b0: n[0],
            b1: n[1],
            b2: n[2],
            a1: dd[1],
            a2: dd[2],
        });
    }
    // Gain from one evaluation point on the unit circle, away from poles and zeros.
    let z0 = c64::from_polar(1.0, 0.77);
    let w = 0.77 / d.dt;
    let h = skyloop_lti::freqresp::freqresp(d, &[w])?[0][(0, 0)];
    let mut prod = c64::new(1.0, 0.0);
    let zinv = 1.0 / z0;
    for s in &secs {
        let num = s.b0 + s.b1 * zinv + s.b2 * zinv * zinv;
        let den = 1.0 + s.a1 * zinv + s.a2 * zinv * zinv;
        prod *= num / den;
    }
    if prod.norm() == 0.0 || !prod.norm().is_finite() {
        return Err(SimError::Param("cannot determine the SOS gain".into()));
    }
    let k = h / prod;
    if k.im.abs() > 1e-6 * k.norm() {
        return Err(SimError::Param(format!(
            "SOS factorization does not match the model (gain {k})"
        )));
    }
    Ok((secs, k.re))
}

/// The discrete SISO model as a runtime SOS controller with output limits.
pub fn to_sos_controller<const N: usize>(d: &StateSpace, out_min: f64, out_max: f64) -> Result<SosController<f64, N>> {
    let (secs, k) = to_sos(d)?;
    Ok(SosController::new(&secs, k, out_min, out_max)?)
}
