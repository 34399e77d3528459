//! A vehicle closed by one discrete MIMO LTI controller on the linearization's outputs (full-state
//! designs such as H∞ or μ controllers), rather than by the cascade of `flight`.
//!
//! The controller reads [reference; measured outputs] and writes actuator-command deviations from the
//! trim inputs. Measurements are the linearization outputs (`linearize::output_deviation`) seen through
//! an exact pure delay (a ring buffer at the physics rate); the controller runs at its own sample time
//! with zero-order hold; commands are clamped to the vehicle's limits, and the controller is
//! conditioned on the clamped command (Hanus) when its D matrix is invertible.

use crate::error::{Result, SimError};
use crate::geometry::{self, V3};
use crate::linearize::output_deviation;
use crate::rigid::{External, Input, State, MAXS, MAXU, POS, QUAT};
use crate::vehicle::Vehicle;
use skyloop_control::SsController;
use skyloop_lti::StateSpace;

/// Largest controller order the loop runs.
pub const MAX_ORDER: usize = 192;
/// Largest number of controller inputs (references + measurements).
pub const MAX_IN: usize = 32;

type Ctrl = SsController<f64, MAX_ORDER, MAX_IN, MAXU>;

/// What to simulate.
#[derive(Debug, Clone)]
pub struct LtiLoopSpec {
    /// Physics (RK4) rate (Hz); must be a multiple of the controller rate.
    pub physics_hz: f64,
    /// Discrete controller (dt = its sample time): inputs [reference (nref); measurements], outputs
    /// actuator-command deviations from `u0` in the vehicle's input units.
    pub controller: StateSpace,
    /// Indices of the measured linearization outputs, in the controller's input order.
    pub measured: Vec<usize>,
    /// Pure measurement delay (s), rounded to physics steps.
    pub measurement_delay_s: f64,
    /// Piecewise-constant reference: (time s, value) pairs in increasing time; zero before the first.
    pub reference: Vec<(f64, Vec<f64>)>,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Log every this many controller samples.
    pub log_every: usize,
    /// Roll or pitch beyond this (rad) counts as a crash.
    pub crash_tilt_rad: f64,
}

/// One logged sample.
#[derive(Debug, Clone)]
pub struct LoopSample {
    /// Time (s).
    pub t: f64,
    /// Linearization outputs (deviations from the trim state), undelayed.
    pub y: Vec<f64>,
    /// Roll, pitch, yaw (rad).
    pub euler: V3,
    /// Applied actuator inputs (absolute, vehicle units).
    pub u: Vec<f64>,
    /// Reference at this time.
    pub reference: Vec<f64>,
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct LoopRun {
    /// The trace.
    pub trace: Vec<LoopSample>,
    /// Tilt limit exceeded or a non-finite state.
    pub crashed: bool,
    /// Fraction of controller samples with a clamped command.
    pub saturated_fraction: f64,
}

/// Runs `vehicle` from state `x_init` under the controller of `spec`. `x0`, `u0` are the trim point the
/// controller was designed at (measurements are deviations from `x0`, commands add to `u0`); for a
/// perturbed vehicle they differ from its own equilibrium.
pub fn simulate_lti_loop(
    vehicle: &Vehicle,
    x0: &State,
    u0: &Input,
    x_init: &State,
    spec: &LtiLoopSpec,
) -> Result<LoopRun> {
    let (nref, div) = check_spec(vehicle, spec)?;
    let nu = vehicle.nu();
    let (mut ctrl, dlo, dhi) = loop_controller(vehicle, u0, &spec.controller)?;
    let (lo, hi) = vehicle.input_limits();

    let h = 1.0 / spec.physics_hz;
    let steps = (spec.duration_s * spec.physics_hz).round() as u64;
    let delay_steps = (spec.measurement_delay_s / h).round() as usize;
    let n = vehicle.nx();
    let mut x = *x_init;
    let mut u: Input = *u0;
    let y_init = output_deviation(vehicle, x0, &x, &u);
    let mut ring: Vec<Vec<f64>> = vec![y_init; delay_steps + 1];
    let mut head = 0usize;
    let mut e = [0.0; MAX_IN];
    let mut r_now = vec![0.0; nref];
    let mut ref_idx = 0usize;
    let (mut sat_count, mut ctl_count) = (0u64, 0u64);
    let mut trace = Vec::new();
    let mut crashed = false;
    let log_every = spec.log_every.max(1) as u64;
    let ext = External::default();
    let deriv = |x: &State, u: &Input, dx: &mut State| vehicle.derivative(x, u, &ext, dx);
    for step in 0..=steps {
        let t = step as f64 * h;
        let y = output_deviation(vehicle, x0, &x, &u);
        ring[head] = y.clone();
        let y_meas = &ring[(head + 1) % ring.len()];
        head = (head + 1) % ring.len();
        while ref_idx < spec.reference.len() && spec.reference[ref_idx].0 <= t + 1e-12 {
            r_now.clone_from(&spec.reference[ref_idx].1);
            ref_idx += 1;
        }
        if step % div == 0 {
            e[..nref].copy_from_slice(&r_now);
            for (j, &i) in spec.measured.iter().enumerate() {
                e[nref + j] = y_meas[i];
            }
            let du = ctrl.step(&e);
            let mut sat = false;
            for i in 0..nu {
                let c = (u0[i] + du[i]).clamp(lo[i], hi[i]);
                sat |= (du[i] - dlo[i]).abs() < 1e-12 || (du[i] - dhi[i]).abs() < 1e-12;
                u[i] = c;
            }
            sat_count += sat as u64;
            ctl_count += 1;
            if (step / div) % log_every == 0 {
                let q = [x[QUAT], x[QUAT + 1], x[QUAT + 2], x[QUAT + 3]];
                trace.push(LoopSample {
                    t,
                    y,
                    euler: geometry::to_euler(q),
                    u: u[..nu].to_vec(),
                    reference: r_now.clone(),
                });
            }
        }
        if step == steps {
            break;
        }
        rk4(&deriv, &mut x, &u, h, n);
        let q = geometry::qnormalize([x[QUAT], x[QUAT + 1], x[QUAT + 2], x[QUAT + 3]]);
        x[QUAT..QUAT + 4].copy_from_slice(&q);
        let eu = geometry::to_euler(q);
        if x[..n].iter().any(|v| !v.is_finite())
            || eu[0].abs() > spec.crash_tilt_rad
            || eu[1].abs() > spec.crash_tilt_rad
            || x[POS..POS + 3].iter().any(|p| p.abs() > 1e4)
        {
            crashed = true;
            break;
        }
    }
    Ok(LoopRun {
        trace,
        crashed,
        saturated_fraction: if ctl_count > 0 {
            sat_count as f64 / ctl_count as f64
        } else {
            0.0
        },
    })
}

/// Checks a loop spec against the vehicle; returns the reference width and the physics steps per
/// controller sample.
///
/// # Errors
/// A continuous or delayed controller, sizes that do not match the vehicle or the references, a
/// controller beyond the loop's capacity, rates and durations out of range, or a controller sample
/// time that is not a multiple of the physics step.
fn check_spec(vehicle: &Vehicle, spec: &LtiLoopSpec) -> Result<(usize, u64)> {
    let k = &spec.controller;
    k.validate()?;
    if k.is_continuous() {
        return Err(SimError::Param("the loop controller must be discrete (dt > 0)".into()));
    }
    if k.has_delay() {
        return Err(SimError::Param("the loop controller cannot have delays".into()));
    }
    let nu = vehicle.nu();
    let ny_lin = vehicle.nx() - 1;
    if k.ny() != nu {
        return Err(SimError::Param(format!(
            "controller has {} outputs, the vehicle {nu} inputs",
            k.ny()
        )));
    }
    if let Some(&i) = spec.measured.iter().find(|&&i| i >= ny_lin) {
        return Err(SimError::Param(format!(
            "measured output {i} does not exist (the model has {ny_lin})"
        )));
    }
    let nm = spec.measured.len();
    if k.nu() < nm {
        return Err(SimError::Param(format!(
            "controller has {} inputs, fewer than the {nm} measurements",
            k.nu()
        )));
    }
    let nref = k.nu() - nm;
    for (t, r) in &spec.reference {
        if r.len() != nref || !t.is_finite() || r.iter().any(|v| !v.is_finite()) {
            return Err(SimError::Param(format!(
                "reference at t = {t} s must have {nref} finite values"
            )));
        }
    }
    if k.nx() > MAX_ORDER || k.nu() > MAX_IN {
        return Err(SimError::Param(format!(
            "controller of order {} with {} inputs exceeds the loop's capacity ({MAX_ORDER}, {MAX_IN})",
            k.nx(),
            k.nu()
        )));
    }
    crate::error::check_pos(spec.physics_hz, "physics_hz")?;
    crate::error::check_min(spec.measurement_delay_s, 0.0, "measurement_delay_s")?;
    crate::error::check_min(spec.duration_s, 0.0, "duration_s")?;
    let ratio = k.dt * spec.physics_hz;
    let div = ratio.round();
    if !(div >= 1.0 && (ratio - div).abs() < 1e-6 * ratio) {
        return Err(SimError::Param(format!(
            "controller sample time {} s is not a multiple of the physics step 1/{} s",
            k.dt, spec.physics_hz
        )));
    }
    Ok((nref, div as u64))
}

/// The discrete controller `k` as the loop runs it: its command limited to the vehicle's input
/// range around `u0` (returned as deviations, lower and upper), with Hanus anti-windup when its D
/// is square and invertible.
///
/// # Errors
/// A controller the fixed-size runtime cannot hold.
fn loop_controller(vehicle: &Vehicle, u0: &Input, k: &StateSpace) -> Result<(Box<Ctrl>, Vec<f64>, Vec<f64>)> {
    let nu = vehicle.nu();
    // Built right into its box, not through runtime_controller::to_ss_controller: the controller's
    // fixed arrays are large enough that one more by-value Result frame overflows a test thread's
    // stack.
    let flat = |m: &faer::Mat<f64>| {
        (0..m.nrows())
            .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
            .collect::<Vec<f64>>()
    };
    let mut ctrl: Box<Ctrl> = Box::new(Ctrl::new(
        k.nx(),
        k.nu(),
        k.ny(),
        &flat(&k.a),
        &flat(&k.b),
        &flat(&k.c),
        &flat(&k.d),
    )?);
    let (lo, hi) = vehicle.input_limits();
    let dlo: Vec<f64> = (0..nu).map(|i| lo[i] - u0[i]).collect();
    let dhi: Vec<f64> = (0..nu).map(|i| hi[i] - u0[i]).collect();
    *ctrl = ctrl.with_limits(&dlo, &dhi)?;
    // Hanus conditioning needs a square invertible D; otherwise run unconditioned.
    if k.nu() == k.ny() {
        if let Ok(c) = ctrl.with_hanus_aw() {
            *ctrl = c;
        }
    }
    Ok((ctrl, dlo, dhi))
}

fn rk4(f: &impl Fn(&State, &Input, &mut State), x: &mut State, u: &Input, h: f64, n: usize) {
    let (mut k1, mut k2, mut k3, mut k4) = ([0.0; MAXS], [0.0; MAXS], [0.0; MAXS], [0.0; MAXS]);
    let x0 = *x;
    let mut xt = x0;
    f(&x0, u, &mut k1);
    for i in 0..n {
        xt[i] = x0[i] + 0.5 * h * k1[i];
    }
    f(&xt, u, &mut k2);
    for i in 0..n {
        xt[i] = x0[i] + 0.5 * h * k2[i];
    }
    f(&xt, u, &mut k3);
    for i in 0..n {
        xt[i] = x0[i] + h * k3[i];
    }
    f(&xt, u, &mut k4);
    for i in 0..n {
        x[i] = x0[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::presets;
    use faer::Mat;

    fn zero_controller(nin: usize, nu: usize, dt: f64) -> StateSpace {
        StateSpace::new(
            Mat::zeros(0, 0),
            Mat::zeros(0, nin),
            Mat::zeros(nu, 0),
            Mat::zeros(nu, nin),
            dt,
        )
        .expect("ss")
    }

    fn spec(k: StateSpace) -> LtiLoopSpec {
        LtiLoopSpec {
            physics_hz: 1000.0,
            controller: k,
            measured: (0..12).collect(),
            measurement_delay_s: 0.01,
            reference: vec![(0.0, vec![0.0; 3])],
            duration_s: 1.0,
            log_every: 1,
            crash_tilt_rad: 1.0,
        }
    }

    #[test]
    fn trim_is_an_equilibrium_of_the_loop() {
        // With zero feedback the trimmed hover must stay put (ẋ = 0 at the trim point).
        let v = presets::vehicle("ducted-fan-pross")
            .expect("preset")
            .build()
            .expect("valid");
        let (x0, u0) = v.trim_hover(5.0, std::f64::consts::FRAC_PI_4);
        let run = simulate_lti_loop(&v, &x0, &u0, &x0, &spec(zero_controller(15, 5, 0.01))).expect("run");
        assert!(!run.crashed);
        let last = run.trace.last().expect("trace");
        let drift = last.y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(drift < 1e-9, "hover drifted by {drift}");
        assert_eq!(run.trace.len(), 101);
    }

    #[test]
    fn bad_specs_are_errors() {
        let v = presets::vehicle("ducted-fan-pross")
            .expect("preset")
            .build()
            .expect("valid");
        let (x0, u0) = v.trim_hover(5.0, 0.0);
        let cont = zero_controller(15, 5, 0.0);
        assert!(simulate_lti_loop(&v, &x0, &u0, &x0, &spec(cont)).is_err());
        let wrong_out = zero_controller(15, 4, 0.01);
        assert!(simulate_lti_loop(&v, &x0, &u0, &x0, &spec(wrong_out)).is_err());
        let odd_rate = zero_controller(15, 5, 0.0123);
        assert!(simulate_lti_loop(&v, &x0, &u0, &x0, &spec(odd_rate)).is_err());
        let mut s = spec(zero_controller(15, 5, 0.01));
        s.measured[0] = 99;
        assert!(simulate_lti_loop(&v, &x0, &u0, &x0, &s).is_err());
        let mut s = spec(zero_controller(15, 5, 0.01));
        s.reference = vec![(0.0, vec![0.0; 2])];
        assert!(simulate_lti_loop(&v, &x0, &u0, &x0, &s).is_err());
    }

    #[test]
    fn measurement_delay_shifts_the_controller_input() {
        // A static gain u4 = 100·y_z with a 50 ms delay on a vehicle sinking at 1 m/s: each command
        // equals 100 × the altitude deviation logged 50 ms (5 controller samples) earlier.
        let v = presets::vehicle("ducted-fan-pross")
            .expect("preset")
            .build()
            .expect("valid");
        let (x0, u0) = v.trim_hover(5.0, 0.0);
        let mut xi = x0;
        xi[crate::rigid::VEL + 2] = 1.0;
        let mut d = Mat::<f64>::zeros(5, 15);
        d[(4, 3 + 2)] = 100.0;
        let k = StateSpace::new(Mat::zeros(0, 0), Mat::zeros(0, 15), Mat::zeros(5, 0), d, 0.01).expect("ss");
        let mut s = spec(k);
        s.measurement_delay_s = 0.05;
        s.duration_s = 0.2;
        let run = simulate_lti_loop(&v, &x0, &u0, &xi, &s).expect("run");
        for i in 5..run.trace.len() {
            let du = run.trace[i].u[4] - u0[4];
            let want = 100.0 * run.trace[i - 5].y[2];
            assert!(
                (du - want).abs() < 1e-9 * want.abs().max(1.0),
                "sample {i}: {du} vs {want}"
            );
        }
        assert!(run.trace[10].y[2] > 0.05, "the vehicle did not sink");
    }
}
