//! The closed-loop simulation: RK4 at a fixed physics rate, controllers at their own rates with
//! zero-order hold, actuator limits, slew rates and pure delays. The step loop does not allocate.

use crate::cascade::{Cascade, Mode};
use crate::disturbance::{DisturbanceSpec, Disturbances};
use crate::error::{Result, SimError};
use crate::geometry::{self, V3};
use crate::rigid::{Input, State, MAXS, MAXU, POS, QUAT, VEL};
use crate::scenario::Scenario;
use crate::sensors::Gyro;
use crate::vehicle::Vehicle;
use rand::rngs::SmallRng;
use rand::SeedableRng;

/// One logged sample.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Sample {
    /// Time (s).
    pub t: f64,
    /// NED position (m).
    pub pos: V3,
    /// Roll, pitch, yaw (rad).
    pub euler: V3,
    /// True body rates (rad/s).
    pub rates: V3,
    /// Reference of the tracked quantity.
    pub reference: V3,
    /// Tracked quantity (attitude, position relative to start, or rates, by mode).
    pub tracked: V3,
    /// Rate setpoint (rad/s).
    pub rate_sp: V3,
    /// Torque command (N·m).
    pub torque: V3,
    /// Applied actuator inputs.
    pub u: Input,
    /// Any actuator saturated at the last control update.
    pub saturated: bool,
}

/// Summary numbers of a run (the `skyloop simulate` metrics JSON).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Metrics {
    /// max over time of ‖reference − tracked‖∞.
    pub max_abs_error: f64,
    /// √(mean over time of ‖reference − tracked‖₂²).
    pub rms_error: f64,
    /// Time after the last reference change until the error stays inside the band (s); None if never.
    pub settling_time_s: Option<f64>,
    /// Fraction of control updates with a saturated actuator.
    pub saturated_fraction: f64,
    /// The vehicle crashed (tilt beyond the limit, hit the ground, or a non-finite state).
    pub crashed: bool,
}

/// A configured simulation.
pub struct Simulation {
    vehicle: Vehicle,
    dist: Disturbances,
    gyro: Gyro,
    cascade: Cascade,
    mode: Mode,
    x: State,
    n: usize,
    nu: usize,
    u_cmd: Input,
    u: Input,
    ring: Vec<Input>,
    head: usize,
    delay_steps: [usize; MAXU],
    lo: Input,
    hi: Input,
    slew: Input,
    t: f64,
    k: u64,
    dt: f64,
    div_rate: u64,
    div_att: u64,
    div_pos: u64,
    rng: SmallRng,
    refs: Vec<(f64, V3)>,
    ref_idx: usize,
    ref_now: V3,
    origin: V3,
    yaw0: f64,
    sat_now: bool,
    sat_count: u64,
    ctl_count: u64,
    crashed: bool,
    /// Crash tilt limit as (cos, sin) of the angle.
    crash_tilt: (f64, f64),
    ground: bool,
}

fn divider(physics_hz: f64, hz: f64, what: &str) -> Result<u64> {
    let r = physics_hz / hz;
    let d = r.round();
    if !(d >= 1.0 && (r - d).abs() < 1e-6 * r) {
        return Err(SimError::Param(format!(
            "{what} = {hz} Hz must divide sim.physics_hz = {physics_hz} Hz"
        )));
    }
    Ok(d as u64)
}

impl Simulation {
    /// Builds a simulation from a scenario, with `seed` for noise and turbulence.
    pub fn new(scn: &Scenario, seed: u64) -> Result<Self> {
        scn.validate()?;
        let nominal = scn.vehicle.resolve()?;
        let nominal_vehicle = nominal.build()?;
        let mut spec = nominal;
        for d in &scn.disturbance {
            if let DisturbanceSpec::Payload { mass_kg, position_m } = d {
                spec.add_point_mass(*mass_kg, *position_m);
            }
        }
        Self::with_vehicle(scn, spec.build()?, &nominal_vehicle, &scn.disturbance, seed)
    }

    /// Builds with an explicit (possibly perturbed) vehicle; controllers use `nominal`'s mass and inertia.
    pub fn with_vehicle(
        scn: &Scenario,
        vehicle: Vehicle,
        nominal: &Vehicle,
        disturbances: &[DisturbanceSpec],
        seed: u64,
    ) -> Result<Self> {
        let s = &scn.sim;
        let c = &scn.controller;
        let div_rate = divider(s.physics_hz, c.rate_hz, "controller.rate_hz")?;
        let div_att = divider(s.physics_hz, c.attitude_hz, "controller.attitude_hz")?;
        let div_pos = divider(s.physics_hz, c.position_hz, "controller.position_hz")?;
        let dt = 1.0 / s.physics_hz;
        let n0 = vehicle.nx();
        let (dist, n) = Disturbances::new(disturbances, n0)?;
        if n > MAXS {
            return Err(SimError::Param(format!("{n} states exceed the capacity {MAXS}")));
        }
        let nu = vehicle.nu();
        let (mut x, u0) = vehicle.trim_hover(s.altitude_m, 0.0);
        dist.init_state(&mut x);
        let mut gyro = Gyro::new(scn.gyro, c.rate_hz)?;
        gyro.prime(vehicle.rates(&x, &u0));
        let cascade = Cascade::new(c, nominal.body().mass_kg, nominal.inertia())?;
        let delays = vehicle.input_delays();
        let mut delay_steps = [0usize; MAXU];
        for i in 0..nu {
            delay_steps[i] = (delays[i] / dt).round() as usize;
        }
        let max_delay = delay_steps.iter().copied().max().unwrap_or(0);
        let (lo, hi) = vehicle.input_limits();
        let mut slew = [f64::INFINITY; MAXU];
        if !s.actuator_rate_limit.is_empty() {
            if s.actuator_rate_limit.len() != nu {
                return Err(SimError::Param(format!(
                    "sim.actuator_rate_limit has {} entries, the vehicle has {nu} inputs",
                    s.actuator_rate_limit.len()
                )));
            }
            for (i, r) in s.actuator_rate_limit.iter().enumerate() {
                crate::error::check_pos(*r, "actuator_rate_limit")?;
                slew[i] = *r;
            }
        }
        let mut refs = Vec::with_capacity(scn.reference.len());
        for r in &scn.reference {
            refs.push((r.t_s, r.value(c.mode)?));
        }
        let origin = [x[POS], x[POS + 1], x[POS + 2]];
        Ok(Simulation {
            vehicle,
            dist,
            gyro,
            cascade,
            mode: c.mode,
            x,
            n,
            nu,
            u_cmd: u0,
            u: u0,
            ring: vec![u0; max_delay + 1],
            head: 0,
            delay_steps,
            lo,
            hi,
            slew,
            t: 0.0,
            k: 0,
            dt,
            div_rate,
            div_att,
            div_pos,
            rng: SmallRng::seed_from_u64(seed),
            refs,
            ref_idx: 0,
            ref_now: [0.0; 3],
            origin,
            yaw0: 0.0,
            sat_now: false,
            sat_count: 0,
            ctl_count: 0,
            crashed: false,
            crash_tilt: (s.crash_tilt_rad.cos(), s.crash_tilt_rad.sin()),
            ground: s.altitude_m > 0.0,
        })
    }

    /// Current state.
    pub fn state(&self) -> &State {
        &self.x
    }

    /// Current time (s).
    pub fn time(&self) -> f64 {
        self.t
    }

    /// True once the vehicle crashed.
    pub fn crashed(&self) -> bool {
        self.crashed
    }

    fn deriv(&self, t: f64, x: &State, dx: &mut State) {
        let ext = self.dist.external(t, x, dx);
        self.vehicle.derivative(x, &self.u, &ext, dx);
    }

    fn control(&mut self) {
        // Euler angles cost three inverse trig calls; only the outer loops need them, and those run
        // at a fraction of the physics rate.
        let outer = self.k % self.div_pos == 0 || self.k % self.div_att == 0;
        let euler = if outer {
            geometry::to_euler([self.x[QUAT], self.x[QUAT + 1], self.x[QUAT + 2], self.x[QUAT + 3]])
        } else {
            [0.0; 3]
        };
        while self.ref_idx < self.refs.len() && self.refs[self.ref_idx].0 <= self.t + 1e-12 {
            self.ref_now = self.refs[self.ref_idx].1;
            self.ref_idx += 1;
        }
        if self.k % self.div_pos == 0 {
            let pos = [self.x[POS], self.x[POS + 1], self.x[POS + 2]];
            let vel = [self.x[VEL], self.x[VEL + 1], self.x[VEL + 2]];
            let dtp = self.div_pos as f64 * self.dt;
            match self.mode {
                Mode::Position => {
                    let sp = geometry::add(self.origin, self.ref_now);
                    self.cascade.position_step(pos, vel, sp, euler, self.yaw0, dtp, true);
                }
                _ => self
                    .cascade
                    .position_step(pos, vel, self.origin, euler, self.yaw0, dtp, false),
            }
        }
        if self.k % self.div_att == 0 {
            match self.mode {
                Mode::Attitude => {
                    self.cascade.set_attitude(self.ref_now);
                    self.cascade.attitude_step(euler);
                }
                Mode::Position => self.cascade.attitude_step(euler),
                Mode::Rate => self.cascade.set_rate(self.ref_now),
            }
        }
        if self.k % self.div_rate == 0 {
            let w = self.vehicle.rates(&self.x, &self.u);
            let meas = self.gyro.sample(w, &mut self.rng);
            let dtr = self.div_rate as f64 * self.dt;
            let torque = self.cascade.rate_step(meas, dtr);
            let mut cmd = self.u_cmd;
            let mut sat = self.vehicle.allocate(&self.x, self.cascade.thrust, torque, &mut cmd);
            for i in 0..self.nu {
                let lim = self.slew[i] * dtr;
                let c = cmd[i]
                    .clamp(self.u_cmd[i] - lim, self.u_cmd[i] + lim)
                    .clamp(self.lo[i], self.hi[i]);
                sat |= c != cmd[i];
                self.u_cmd[i] = c;
            }
            self.sat_now = sat;
            self.ctl_count += 1;
            self.sat_count += sat as u64;
        }
    }

    /// Advances one physics step (controllers first when their sample is due, then RK4).
    #[inline]
    pub fn step(&mut self) {
        if self.crashed {
            return;
        }
        self.control();
        let len = self.ring.len();
        self.ring[self.head] = self.u_cmd;
        for i in 0..self.nu {
            self.u[i] = self.ring[(self.head + len - self.delay_steps[i]) % len][i];
        }
        self.head = (self.head + 1) % len;
        self.dist.advance(self.dt, &mut self.rng);
        let (n, h, t) = (self.n, self.dt, self.t);
        let x = self.x;
        let mut k1 = [0.0; MAXS];
        let mut k2 = [0.0; MAXS];
        let mut k3 = [0.0; MAXS];
        let mut k4 = [0.0; MAXS];
        let mut xt = x;
        self.deriv(t, &x, &mut k1);
        for i in 0..n {
            xt[i] = x[i] + 0.5 * h * k1[i];
        }
        self.deriv(t + 0.5 * h, &xt, &mut k2);
        for i in 0..n {
            xt[i] = x[i] + 0.5 * h * k2[i];
        }
        self.deriv(t + 0.5 * h, &xt, &mut k3);
        for i in 0..n {
            xt[i] = x[i] + h * k3[i];
        }
        self.deriv(t + h, &xt, &mut k4);
        for i in 0..n {
            self.x[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        let q = geometry::qnormalize([self.x[QUAT], self.x[QUAT + 1], self.x[QUAT + 2], self.x[QUAT + 3]]);
        self.x[QUAT..QUAT + 4].copy_from_slice(&q);
        self.k += 1;
        self.t = self.k as f64 * h;
        let finite = self.x[..n].iter().all(|v| v.is_finite());
        if !finite || geometry::tilt_exceeds(q, self.crash_tilt) || (self.ground && self.x[POS + 2] > 0.0) {
            self.crashed = true;
        }
    }

    /// The current log sample.
    pub fn sample(&self) -> Sample {
        let q = [self.x[QUAT], self.x[QUAT + 1], self.x[QUAT + 2], self.x[QUAT + 3]];
        let euler = geometry::to_euler(q);
        let rates = self.vehicle.rates(&self.x, &self.u);
        let pos = [self.x[POS], self.x[POS + 1], self.x[POS + 2]];
        let tracked = match self.mode {
            Mode::Attitude => euler,
            Mode::Position => geometry::sub(pos, self.origin),
            Mode::Rate => rates,
        };
        Sample {
            t: self.t,
            pos,
            euler,
            rates,
            reference: self.ref_now,
            tracked,
            rate_sp: self.cascade.rate_sp,
            torque: self.cascade.torque,
            u: self.u,
            saturated: self.sat_now,
        }
    }

    /// Runs to `duration_s`, logging every `log_every` steps; returns the trace and its metrics.
    pub fn run(&mut self, duration_s: f64, log_every: u64, settle_band: f64) -> (Vec<Sample>, Metrics) {
        self.run_with_progress(duration_s, log_every, settle_band, &mut |_, _| {})
    }

    /// [`Simulation::run`], calling `progress(steps done, steps in all)` every 65 536 physics steps
    /// and at the end (long runs show progress).
    pub fn run_with_progress(
        &mut self,
        duration_s: f64,
        log_every: u64,
        settle_band: f64,
        progress: &mut dyn FnMut(u64, u64),
    ) -> (Vec<Sample>, Metrics) {
        let steps = (duration_s / self.dt).round() as u64;
        let log_every = log_every.max(1);
        let mut trace = Vec::with_capacity((steps / log_every + 2) as usize);
        trace.push(self.sample());
        for i in 0..steps {
            if i % 65_536 == 0 {
                progress(i, steps);
            }
            self.step();
            if self.k % log_every == 0 || self.crashed {
                trace.push(self.sample());
            }
            if self.crashed {
                break;
            }
        }
        progress(steps, steps);
        let m = metrics(
            &trace,
            &self.refs,
            settle_band,
            self.sat_count,
            self.ctl_count,
            self.crashed,
        );
        (trace, m)
    }
}

/// Metrics of a trace given the reference steps.
pub fn metrics(trace: &[Sample], refs: &[(f64, V3)], band_abs: f64, sat: u64, ctl: u64, crashed: bool) -> Metrics {
    let mut max_abs: f64 = 0.0;
    let mut sum2 = 0.0;
    let (mut t_last, mut step) = (0.0, 0.0f64);
    let mut prev = [0.0; 3];
    for (t, v) in refs {
        let d = geometry::sub(*v, prev).iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if d > 0.0 {
            t_last = *t;
            step = d;
        }
        prev = *v;
    }
    let band = band_abs.max(0.02 * step);
    let mut last_out: Option<f64> = None;
    for s in trace {
        let e = geometry::sub(s.reference, s.tracked);
        let inf = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let inf = if inf.is_finite() { inf } else { f64::INFINITY };
        max_abs = max_abs.max(inf);
        sum2 += geometry::dot(e, e);
        if s.t >= t_last && inf > band {
            last_out = Some(s.t);
        }
    }
    let rms = if trace.is_empty() {
        0.0
    } else {
        (sum2 / trace.len() as f64).sqrt()
    };
    let end = trace.last().map_or(0.0, |s| s.t);
    // A crashed run never settled, whatever its trace shows before the crash.
    let settling = match last_out {
        _ if crashed => None,
        None => Some(0.0),
        Some(t) if t < end && !crashed => Some(t - t_last),
        _ => None,
    };
    Metrics {
        max_abs_error: max_abs,
        rms_error: rms,
        settling_time_s: settling,
        saturated_fraction: if ctl > 0 { sat as f64 / ctl as f64 } else { 0.0 },
        crashed,
    }
}

/// Builds and runs a scenario (seed from the file); returns the trace and metrics.
///
/// # Errors
/// A vehicle, controller or disturbance the scenario gets wrong (the message names the key).
///
/// # Examples
/// The SSI-PI paper's quadrotor (`examples/quadrotor-ssi.toml`) follows its roll step without a crash:
/// ```
/// let text = include_str!("../../../examples/quadrotor-ssi.toml");
/// let scn = skyloop_sim::Scenario::from_toml(text)?;
/// let (trace, m) = skyloop_sim::simulate(&scn)?;
/// assert!(!m.crashed);
/// assert!(trace.len() > 100);
/// assert!(m.max_abs_error.is_finite());
/// # Ok::<(), skyloop_sim::SimError>(())
/// ```
pub fn simulate(scn: &Scenario) -> Result<(Vec<Sample>, Metrics)> {
    simulate_with_progress(scn, &mut |_, _| {})
}

/// [`simulate`], calling `progress(physics steps done, steps in all)` as it goes.
///
/// # Errors
/// As [`simulate`].
pub fn simulate_with_progress(scn: &Scenario, progress: &mut dyn FnMut(u64, u64)) -> Result<(Vec<Sample>, Metrics)> {
    let mut sim = Simulation::new(scn, scn.sim.seed)?;
    let every = log_every(scn)?;
    Ok(sim.run_with_progress(scn.sim.duration_s, every, scn.sim.settle_band, progress))
}

/// Physics steps between log samples.
pub fn log_every(scn: &Scenario) -> Result<u64> {
    let hz = if scn.sim.log_hz > 0.0 {
        scn.sim.log_hz
    } else {
        scn.controller.rate_hz
    };
    divider(scn.sim.physics_hz, hz, "sim.log_hz")
}

/// Writes a trace as CSV (header + one row per sample).
pub fn write_csv<W: std::io::Write>(w: &mut W, trace: &[Sample], nu: usize) -> std::io::Result<()> {
    write!(
        w,
        "t_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad,p_rad_s,q_rad_s,r_rad_s,ref0,ref1,ref2,tracked0,tracked1,tracked2,\
         p_sp_rad_s,q_sp_rad_s,r_sp_rad_s,mx_n_m,my_n_m,mz_n_m"
    )?;
    for i in 0..nu {
        write!(w, ",u{i}")?;
    }
    writeln!(w, ",saturated")?;
    for s in trace {
        write!(w, "{}", s.t)?;
        for v in s
            .pos
            .iter()
            .chain(&s.euler)
            .chain(&s.rates)
            .chain(&s.reference)
            .chain(&s.tracked)
            .chain(&s.rate_sp)
            .chain(&s.torque)
        {
            write!(w, ",{v}")?;
        }
        for v in &s.u[..nu] {
            write!(w, ",{v}")?;
        }
        writeln!(w, ",{}", s.saturated as u8)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// A crashed run has no settling time, even when nothing in its trace left the band (it used to
    /// report 0 s and count as settled).
    #[test]
    fn a_crashed_run_never_settles() {
        assert_eq!(metrics(&[], &[], 0.1, 0, 0, true).settling_time_s, None);
        assert_eq!(metrics(&[], &[], 0.1, 0, 0, false).settling_time_s, Some(0.0));
    }
}
