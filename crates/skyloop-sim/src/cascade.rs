//! The cascaded flight controller: position → attitude → rate → allocation, each loop at its own rate.
//!
//! Position: P on NED position → velocity setpoint, PID on velocity → acceleration → thrust vector →
//! roll/pitch setpoint and thrust. Attitude: P on the Euler-angle error, ω_r = k·(θ_r − θ), as in the
//! SSI-PI paper's loop of eq. (32) (k = 1 there). Rate: per axis a PID, the SSI-PI law of eq. (31), or
//! a discrete LTI controller (e.g. the bicopter's H∞ design, in the forward path as in its Fig. 13).

use crate::error::{check_min, check_pos, Result, SimError};
use crate::geometry::V3;
use crate::rigid::G;
use crate::runtime_controller::DiscreteSiso;
use skyloop_control::{AntiWindup, Pid, PidGains, SsController, SsiPi, SsiPiGains};

/// Largest discrete LTI rate controller the simulator runs.
pub const LTI_MAX_ORDER: usize = 24;

/// One axis' rate law as written in a scenario (`kind = "pid" | "ssi_pi" | "lti"`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RateLaw {
    /// PX4-style PID on the rate error (torque out, N·m per rad/s).
    Pid {
        /// Proportional gain.
        kp: f64,
        /// Integral gain.
        #[serde(default)]
        ki: f64,
        /// Derivative gain.
        #[serde(default)]
        kd: f64,
        /// Derivative filter time constant (s).
        #[serde(default)]
        tf_s: f64,
        /// Integrator limit (N·m).
        #[serde(default = "big")]
        i_limit_n_m: f64,
    },
    /// SSI-PI of eq. (31): u = Kp·e + Ki·Kp·∫e − Ki·Jm·ω.
    SsiPi {
        /// Kp (N·m per rad/s).
        kp: f64,
        /// Ki (1/s).
        ki: f64,
        /// Jm as a fraction of the vehicle's nominal inertia on this axis (1 = perfect identification).
        #[serde(default = "one")]
        jm_fraction: f64,
    },
    /// A discrete LTI controller C(z) on the rate error; its output times `output_scale` is torque.
    Lti {
        /// The controller.
        controller: DiscreteSiso,
        /// Output → N·m factor (e.g. servo command → roll torque for the bicopter).
        #[serde(default = "one")]
        output_scale: f64,
        /// Anti-windup by Hanus conditioning (needs D ≠ 0).
        #[serde(default)]
        hanus: bool,
    },
    /// A two-degree-of-freedom discrete law u = C_r(z)·r − C_fb(z)·y, as flight firmware runs its
    /// PID (P and I on the error, D on the measurement, feedforward on the setpoint, filters on
    /// the gyro only); its output times `output_scale` is torque, clipped at the axis' torque limit.
    TwoDof {
        /// C_fb: measured rate (rad/s) → output.
        feedback: DiscreteSiso,
        /// C_r: rate setpoint (rad/s) → output.
        reference: DiscreteSiso,
        /// Output → N·m factor.
        #[serde(default = "one")]
        output_scale: f64,
    },
    /// A controller given as a transfer-function expression or an LTI JSON path (relative to the
    /// working directory); continuous models are discretized by Tustin at the rate-loop sample time.
    LtiModel {
        /// Expression such as "24.02*(s+54.01)/(s*(s+8))" or a path to an LTI JSON file.
        model: String,
        /// Output → N·m factor.
        #[serde(default = "one")]
        output_scale: f64,
        /// Anti-windup by Hanus conditioning (needs D ≠ 0).
        #[serde(default)]
        hanus: bool,
    },
}

fn big() -> f64 {
    1e9
}
fn one() -> f64 {
    1.0
}

/// What the pilot commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Body rates (rad/s); altitude held.
    Rate,
    /// Roll, pitch, yaw (rad); altitude held.
    Attitude,
    /// NED position (m).
    Position,
}

/// Cascade settings as written in a scenario.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// Commanded quantity.
    pub mode: Mode,
    /// Rate-loop frequency (Hz).
    pub rate_hz: f64,
    /// Attitude-loop frequency (Hz).
    pub attitude_hz: f64,
    /// Position-loop frequency (Hz).
    pub position_hz: f64,
    /// Rate laws for roll, pitch, yaw.
    pub rate: Vec<RateLaw>,
    /// Attitude P gains (1/s).
    pub attitude_kp: V3,
    /// Rate setpoint limit (rad/s).
    #[serde(default = "max_rate")]
    pub max_rate_rad_s: f64,
    /// Position P gains (1/s).
    pub position_kp: V3,
    /// Velocity PID proportional gains (1/s).
    pub velocity_kp: V3,
    /// Velocity PID integral gains (1/s²).
    #[serde(default)]
    pub velocity_ki: V3,
    /// Velocity PID derivative gains.
    #[serde(default)]
    pub velocity_kd: V3,
    /// Tilt limit (rad).
    #[serde(default = "max_tilt")]
    pub max_tilt_rad: f64,
    /// Torque limits per axis (N·m) before allocation.
    #[serde(default = "max_torque")]
    pub max_torque_n_m: V3,
}

fn max_rate() -> f64 {
    10.0
}
fn max_tilt() -> f64 {
    0.6
}
fn max_torque() -> V3 {
    [1e9; 3]
}

enum RateCtl {
    Pid(Pid<f64>),
    Ssi(SsiPi<f64>),
    Lti(Box<SsController<f64, LTI_MAX_ORDER, 1, 1>>, f64),
    TwoDof(Box<[SsController<f64, LTI_MAX_ORDER, 1, 1>; 2]>, f64),
}

/// The running cascade.
pub struct Cascade {
    spec: ControllerSpec,
    rate: [RateCtl; 3],
    vel: [Pid<f64>; 3],
    mass: f64,
    /// Current rate setpoint (rad/s).
    pub rate_sp: V3,
    /// Current attitude setpoint (rad).
    pub att_sp: V3,
    /// Current thrust command (N).
    pub thrust: f64,
    /// Current torque command (N·m).
    pub torque: V3,
}

fn build_rate(law: &RateLaw, j_axis: f64, dt: f64, lim: f64) -> Result<RateCtl> {
    Ok(match law {
        RateLaw::Pid {
            kp,
            ki,
            kd,
            tf_s,
            i_limit_n_m,
        } => {
            let g = PidGains {
                tf_s: *tf_s,
                out_min: -lim,
                out_max: lim,
                i_limit: *i_limit_n_m,
                anti_windup: AntiWindup::Conditional,
                ..PidGains::new(*kp, *ki, *kd)
            };
            RateCtl::Pid(Pid::new(g)?)
        }
        RateLaw::SsiPi { kp, ki, jm_fraction } => {
            check_min(*jm_fraction, 0.0, "jm_fraction")?;
            let g = SsiPiGains {
                kp: *kp,
                ki: *ki,
                jm: jm_fraction * j_axis,
                out_min: -lim,
                out_max: lim,
                kt: 0.0,
            };
            RateCtl::Ssi(SsiPi::new(g)?)
        }
        RateLaw::Lti {
            controller,
            output_scale,
            hanus,
        } => {
            let mut k = ss_controller(controller, dt)?;
            if *hanus {
                let l = lim / output_scale.abs().max(1e-300);
                k = k.with_limits(&[-l], &[l])?.with_hanus_aw()?;
            }
            RateCtl::Lti(Box::new(k), *output_scale)
        }
        RateLaw::TwoDof {
            feedback,
            reference,
            output_scale,
        } => RateCtl::TwoDof(
            Box::new([ss_controller(reference, dt)?, ss_controller(feedback, dt)?]),
            *output_scale,
        ),
        RateLaw::LtiModel {
            model,
            output_scale,
            hanus,
        } => {
            let path = std::path::Path::new(model);
            let sys = if path.is_file() {
                let text =
                    skyloop_lti::json::read_text_file(path).map_err(|e| SimError::Param(format!("{model}: {e}")))?;
                skyloop_lti::json::from_json_str(&text)?
            } else {
                skyloop_lti::expr::parse_model(model)?
            };
            let d = crate::runtime_controller::discretize(&sys, dt)?;
            let law = RateLaw::Lti {
                controller: crate::runtime_controller::to_discrete_siso(&d)?,
                output_scale: *output_scale,
                hanus: *hanus,
            };
            return build_rate(&law, j_axis, dt, lim);
        }
    })
}

/// The runtime form of a discrete SISO controller running at `dt` (s).
fn ss_controller(c: &DiscreteSiso, dt: f64) -> Result<SsController<f64, LTI_MAX_ORDER, 1, 1>> {
    if (c.dt - dt).abs() > 1e-9 * dt {
        return Err(SimError::Param(format!(
            "LTI rate controller has dt = {} s but the rate loop runs at dt = {dt} s",
            c.dt
        )));
    }
    let flat = |m: &Vec<Vec<f64>>| m.iter().flatten().copied().collect::<Vec<f64>>();
    Ok(SsController::<f64, LTI_MAX_ORDER, 1, 1>::new(
        c.a.len(),
        1,
        1,
        &flat(&c.a),
        &flat(&c.b),
        &flat(&c.c),
        &flat(&c.d),
    )?)
}

impl Cascade {
    /// Builds the cascade for a vehicle of `mass` (kg) and nominal `inertia` (kg·m²).
    pub fn new(spec: &ControllerSpec, mass: f64, inertia: V3) -> Result<Self> {
        check_pos(spec.rate_hz, "rate_hz")?;
        check_pos(spec.attitude_hz, "attitude_hz")?;
        check_pos(spec.position_hz, "position_hz")?;
        check_pos(spec.max_rate_rad_s, "max_rate_rad_s")?;
        check_pos(spec.max_tilt_rad, "max_tilt_rad")?;
        if spec.rate.len() != 3 {
            return Err(SimError::Param(format!(
                "controller.rate needs 3 laws (roll, pitch, yaw), got {}",
                spec.rate.len()
            )));
        }
        let dt = 1.0 / spec.rate_hz;
        let r0 = build_rate(&spec.rate[0], inertia[0], dt, spec.max_torque_n_m[0])?;
        let r1 = build_rate(&spec.rate[1], inertia[1], dt, spec.max_torque_n_m[1])?;
        let r2 = build_rate(&spec.rate[2], inertia[2], dt, spec.max_torque_n_m[2])?;
        let mk = |i: usize| -> Result<Pid<f64>> {
            let g = PidGains {
                i_limit: 5.0,
                out_min: -2.0 * G,
                out_max: 2.0 * G,
                anti_windup: AntiWindup::Conditional,
                ..PidGains::new(spec.velocity_kp[i], spec.velocity_ki[i], spec.velocity_kd[i])
            };
            Ok(Pid::new(g)?)
        };
        Ok(Cascade {
            spec: spec.clone(),
            rate: [r0, r1, r2],
            vel: [mk(0)?, mk(1)?, mk(2)?],
            mass,
            rate_sp: [0.0; 3],
            att_sp: [0.0; 3],
            thrust: mass * G,
            torque: [0.0; 3],
        })
    }

    /// The settings.
    pub fn spec(&self) -> &ControllerSpec {
        &self.spec
    }

    /// Position loop: NED position/velocity and position setpoint → attitude setpoint and thrust (N).
    // The arguments are the loop's measured and commanded state, each with its own unit.
    #[allow(clippy::too_many_arguments)]
    pub fn position_step(&mut self, pos: V3, vel: V3, pos_sp: V3, euler: V3, yaw_sp: f64, dt: f64, horizontal: bool) {
        let s = &self.spec;
        let mut acc = [0.0; 3];
        for i in 0..3 {
            if i < 2 && !horizontal {
                continue;
            }
            let v_sp = s.position_kp[i] * (pos_sp[i] - pos[i]);
            acc[i] = self.vel[i].step(v_sp, vel[i], dt);
        }
        // Specific force the rotors must supply (NED): f = a − g·ẑ.
        let f = [acc[0], acc[1], acc[2] - G];
        let (sy, cy) = euler[2].sin_cos();
        let fx = cy * f[0] + sy * f[1];
        let fy = -sy * f[0] + cy * f[1];
        let tilt = s.max_tilt_rad;
        if horizontal {
            let pitch = (-fx).atan2(-f[2]).clamp(-tilt, tilt);
            let roll = fy.atan2((fx * fx + f[2] * f[2]).sqrt()).clamp(-tilt, tilt);
            self.att_sp = [roll, pitch, yaw_sp];
        }
        let (r, p) = (euler[0], euler[1]);
        let c = (r.cos() * p.cos()).max(0.3);
        self.thrust = self.mass * (-f[2]).max(0.0) / c;
    }

    /// Attitude loop: Euler angles → rate setpoint.
    pub fn attitude_step(&mut self, euler: V3) {
        let s = &self.spec;
        for i in 0..3 {
            let mut e = self.att_sp[i] - euler[i];
            if i == 2 {
                e = (e + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI;
            }
            self.rate_sp[i] = (s.attitude_kp[i] * e).clamp(-s.max_rate_rad_s, s.max_rate_rad_s);
        }
    }

    /// Sets the attitude setpoint directly (attitude mode).
    pub fn set_attitude(&mut self, att: V3) {
        self.att_sp = att;
    }

    /// Sets the rate setpoint directly (rate mode).
    pub fn set_rate(&mut self, rate: V3) {
        self.rate_sp = rate;
    }

    /// Rate loop: measured rates → torque command (N·m).
    #[inline]
    pub fn rate_step(&mut self, gyro: V3, dt: f64) -> V3 {
        for i in 0..3 {
            let lim = self.spec.max_torque_n_m[i];
            let t = match &mut self.rate[i] {
                RateCtl::Pid(c) => c.step(self.rate_sp[i], gyro[i], dt),
                RateCtl::Ssi(c) => c.step(self.rate_sp[i], gyro[i], dt),
                RateCtl::Lti(c, k) => *k * c.step_siso(self.rate_sp[i] - gyro[i]),
                RateCtl::TwoDof(c, k) => {
                    let [cr, cfb] = &mut **c;
                    *k * (cr.step_siso(self.rate_sp[i]) - cfb.step_siso(gyro[i]))
                }
            };
            self.torque[i] = t.clamp(-lim, lim);
        }
        self.torque
    }
}
