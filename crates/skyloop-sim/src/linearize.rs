//! Linearization of a vehicle at a trim point by central-difference Jacobians → `StateSpace`.
//!
//! The attitude is perturbed in the body frame, q = q0 ⊗ exp(ξ), so the linear model has n − 1 states
//! (no redundant quaternion direction): [position, velocity, ξ (roll, pitch, yaw perturbation, rad),
//! rate states, actuator states]. Outputs: [position, velocity, ξ, true body rates p q r, actuator
//! states]. ξ̇ = ω + ½ ξ × ω, whose Jacobian is exact at the trim point. Input delays of the vehicle
//! (the bicopter servo's eq. (6) delay) are kept as exact `input_delay`.

use crate::error::{Result, SimError};
use crate::geometry;
use crate::rigid::{External, Input, State, AUX, MAXS, POS, QUAT, RATE, VEL};
use crate::vehicle::Vehicle;
use faer::Mat;
use skyloop_lti::StateSpace;

/// A linear model with the names of its states, inputs and outputs.
#[derive(Debug, Clone)]
pub struct Linearization {
    /// The continuous model.
    pub ss: StateSpace,
    /// State names.
    pub states: Vec<String>,
    /// Input names.
    pub inputs: Vec<String>,
    /// Output names.
    pub outputs: Vec<String>,
}

impl Linearization {
    /// Index of the output called `name`.
    pub fn output(&self, name: &str) -> Result<usize> {
        self.outputs
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| SimError::Param(format!("no output '{name}'")))
    }

    /// Index of the input called `name`.
    pub fn input(&self, name: &str) -> Result<usize> {
        self.inputs
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| SimError::Param(format!("no input '{name}'")))
    }
}

fn expand(v: &Vehicle, x0: &State, r: &[f64]) -> State {
    let n = v.nx();
    let mut x = *x0;
    x[POS..POS + 3].copy_from_slice(&r[0..3]);
    x[VEL..VEL + 3].copy_from_slice(&r[3..6]);
    let q0 = [x0[QUAT], x0[QUAT + 1], x0[QUAT + 2], x0[QUAT + 3]];
    let q = geometry::qmul(q0, geometry::qexp([r[6], r[7], r[8]]));
    x[QUAT..QUAT + 4].copy_from_slice(&q);
    x[RATE..n].copy_from_slice(&r[9..n - 1]);
    x
}

fn reduced_fy(v: &Vehicle, x0: &State, r: &[f64], u: &Input, f: &mut [f64], y: &mut [f64]) {
    let n = v.nx();
    let x = expand(v, x0, r);
    let mut dx = [0.0; MAXS];
    v.derivative(&x, u, &External::default(), &mut dx);
    let w = v.rates(&x, u);
    let xi = [r[6], r[7], r[8]];
    let xid = geometry::add(w, geometry::scale(geometry::cross(xi, w), 0.5));
    f[0..6].copy_from_slice(&dx[0..6]);
    f[6..9].copy_from_slice(&xid);
    f[9..n - 1].copy_from_slice(&dx[RATE..n]);
    y[0..9].copy_from_slice(&r[0..9]);
    y[9..12].copy_from_slice(&w);
    y[12..n - 1].copy_from_slice(&r[12..n - 1]);
}

/// The linearization's output vector at a nonlinear state `x` with inputs `u`, as deviations from
/// the trim state `x0`: [position (m), velocity (m/s), ξ = log(q0⁻¹ ⊗ q) (rad), true body rates (rad/s),
/// actuator states]. This is what the linear model's outputs approximate, so a controller designed on
/// `linearize(v, x0, u0)` is fed these values in a nonlinear simulation.
pub fn output_deviation(v: &Vehicle, x0: &State, x: &State, u: &Input) -> Vec<f64> {
    let n = v.nx();
    let mut y = vec![0.0; n - 1];
    for i in 0..6 {
        y[i] = x[i] - x0[i];
    }
    let q0 = [x0[QUAT], x0[QUAT + 1], x0[QUAT + 2], x0[QUAT + 3]];
    let q = [x[QUAT], x[QUAT + 1], x[QUAT + 2], x[QUAT + 3]];
    let q0_inv = [q0[0], -q0[1], -q0[2], -q0[3]];
    y[6..9].copy_from_slice(&geometry::qlog(geometry::qmul(q0_inv, q)));
    let w = v.rates(x, u);
    let w0 = v.rates(x0, u);
    for i in 0..3 {
        y[9 + i] = w[i] - w0[i];
    }
    for i in 12..n - 1 {
        y[i] = x[i + 1] - x0[i + 1];
    }
    y
}

/// Linearizes `v` at state `x0` and inputs `u0` (e.g. from `Vehicle::trim_hover`).
pub fn linearize(v: &Vehicle, x0: &State, u0: &Input) -> Result<Linearization> {
    let n = v.nx();
    let nr = n - 1;
    let nu = v.nu();
    for (i, val) in x0[..n].iter().chain(u0[..nu].iter()).enumerate() {
        if !val.is_finite() {
            return Err(SimError::Param(format!("trim point entry {i} is not finite")));
        }
    }
    let mut r0 = vec![0.0; nr];
    r0[0..6].copy_from_slice(&x0[0..6]);
    r0[9..nr].copy_from_slice(&x0[RATE..n]);
    let (mut fp, mut fm, mut yp, mut ym) = (vec![0.0; nr], vec![0.0; nr], vec![0.0; nr], vec![0.0; nr]);
    let mut a = Mat::<f64>::zeros(nr, nr);
    let mut c = Mat::<f64>::zeros(nr, nr);
    for j in 0..nr {
        let h = 1e-5 * r0[j].abs().max(1.0);
        let mut rp = r0.clone();
        rp[j] += h;
        let mut rm = r0.clone();
        rm[j] -= h;
        reduced_fy(v, x0, &rp, u0, &mut fp, &mut yp);
        reduced_fy(v, x0, &rm, u0, &mut fm, &mut ym);
        for i in 0..nr {
            a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
            c[(i, j)] = (yp[i] - ym[i]) / (2.0 * h);
        }
    }
    let mut b = Mat::<f64>::zeros(nr, nu);
    let mut d = Mat::<f64>::zeros(nr, nu);
    for j in 0..nu {
        let h = 1e-5 * u0[j].abs().max(1.0);
        let mut up = *u0;
        up[j] += h;
        let mut um = *u0;
        um[j] -= h;
        reduced_fy(v, x0, &r0, &up, &mut fp, &mut yp);
        reduced_fy(v, x0, &r0, &um, &mut fm, &mut ym);
        for i in 0..nr {
            b[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
            d[(i, j)] = (yp[i] - ym[i]) / (2.0 * h);
        }
    }
    let ss = StateSpace::new(a, b, c, d, 0.0)?.with_delays(v.input_delays(), vec![0.0; nr])?;
    let (aux, inputs) = v.names();
    let base = [
        "x_m",
        "y_m",
        "z_m",
        "vx_m_s",
        "vy_m_s",
        "vz_m_s",
        "roll_rad",
        "pitch_rad",
        "yaw_rad",
    ];
    let mut states: Vec<String> = base.iter().map(|s| s.to_string()).collect();
    let mut outputs = states.clone();
    let rate_states: [&str; 3] = match v {
        Vehicle::Bicopter(_) => ["roll_momentum_n_m_s", "q_rad_s", "r_rad_s"],
        _ => ["p_rad_s", "q_rad_s", "r_rad_s"],
    };
    states.extend(rate_states.iter().map(|s| s.to_string()));
    outputs.extend(["p_rad_s", "q_rad_s", "r_rad_s"].iter().map(|s| s.to_string()));
    states.extend(aux.iter().cloned());
    outputs.extend(aux);
    debug_assert_eq!(states.len(), nr);
    debug_assert_eq!(AUX - 1, 12);
    Ok(Linearization {
        ss,
        states,
        inputs,
        outputs,
    })
}
