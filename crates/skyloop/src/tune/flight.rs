//! The nonlinear check of a tune: the gains flown in skyloop-sim's 6-DOF quadrotor, as
//! `simulate` runs it (RK4 rigid body, four motors with their lag and saturation, gyro noise and
//! delay), in rate mode through two roll-rate doublets: a moderate one (200 deg/s) and a hard one
//! (500 deg/s) that drives the output into its limit. Each setpoint move ramps over 25 ms, as a
//! fast stick move arrives after RC smoothing.
//!
//! The vehicle is made to match the identified rate-loop model K·e^(−Td·s)/(s·(τ·s + 1)):
//! - the firmware's two-degree-of-freedom law u = C_r·r − C_fb·y runs at the loop rate (Tustin),
//!   so P and I act on the error, D on the gyro, feedforward on the setpoint, filters on the gyro;
//! - the motor time constant is τ and the gyro is delayed by Td;
//! - roll and pitch inertia J are chosen so that the firmware's output limit (Betaflight's PID-sum
//!   limit 500, PX4's normalized torque 1) is the quad's full differential thrust at hover; the
//!   torque per controller unit is then J·K (K in the gyro's unit per s² per controller unit), so
//!   the linearized roll axis is exactly the identified model, and saturation sits where the
//!   firmware's does;
//! - gyro noise: 1 deg/s RMS per sample (a stated assumption, not read from the log).
//!
//! The preset's other numbers (1 kg, arm 0.2 m, thrust-to-weight ≈ 4) are those of `quadrotor-ssi`.
//! Not modelled: Betaflight's I-term relax and windup limit, TPA, anti-gravity, d_min's boost, RC
//! smoothing beyond the 25 ms ramp: an output held at its limit winds the integrator up, as with
//! iterm_relax off.

use crate::error::{Error, Result};
use serde_json::{json, Value};
use skyloop_lti::StateSpace;
use skyloop_sim::cascade::{ControllerSpec, Mode, RateLaw};
use skyloop_sim::runtime_controller::{discretize, to_discrete_siso};
use skyloop_sim::scenario::{RefStep, Scenario, SimSpec, VehicleEntry};
use skyloop_sim::sensors::GyroSpec;
use skyloop_sim::sim::Sample;
use skyloop_sim::vehicle::VehicleSpec;
use std::f64::consts::PI;

/// The identified axis and the firmware's limits, as the check needs them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightSetup {
    /// K: gyro unit per s² per controller output unit.
    pub k: f64,
    /// τ: motor time constant, s.
    pub tau_s: f64,
    /// Td: delay, s.
    pub td_s: f64,
    /// Rate-loop frequency, Hz.
    pub loop_hz: f64,
    /// The gyro unit in rad/s (π/180 for Betaflight's deg/s, 1 for PX4's rad/s).
    pub gyro_unit_rad_s: f64,
    /// The controller output's limit (Betaflight 500, PX4 1).
    pub output_limit: f64,
    /// The firmware's limit on the rate target's acceleration, deg/s² (ArduPilot's
    /// `ATC_ACCEL_R_MAX`); None: a stick move arrives over [`RAMP_S`], as after Betaflight's RC
    /// smoothing.
    pub setpoint_accel_deg_s2: Option<f64>,
}

/// One doublet: +r, −r, then 0, each held for `hold_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Doublet {
    /// Commanded rate, deg/s.
    pub rate_deg_s: f64,
    /// Largest overshoot of the three moves (0 → r, r → −r, −r → 0) past their targets, in % of
    /// the move's size.
    pub overshoot_pct: f64,
    /// Rise time 10–90 % of the first half, s (None: not reached).
    pub rise_time_s: Option<f64>,
    /// RMS tracking error over the doublet, deg/s.
    pub rms_error_deg_s: f64,
    /// Fraction of rate-loop updates with a motor saturated over the doublet.
    pub saturated_fraction: f64,
}

/// The outcome of the nonlinear check.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightCheck {
    /// The two doublets (200 and 500 deg/s).
    pub doublets: Vec<Doublet>,
    /// RMS of the roll output (in the firmware's units) while hovering with gyro noise alone:
    /// how much of the noise reaches the motors.
    pub hover_output_rms: f64,
    /// The vehicle crashed or a state became non-finite.
    pub crashed: bool,
    /// The roll-rate trace (at most about 2000 points): time (s), setpoint and true rate (deg/s).
    pub t_s: Vec<f64>,
    /// See `t_s`.
    pub setpoint_deg_s: Vec<f64>,
    /// See `t_s`.
    pub rate_deg_s: Vec<f64>,
}

const HOLD_S: f64 = 0.15;
const RATES_DEG_S: [f64; 2] = [200.0, 500.0];
const T_FIRST_S: f64 = 0.3;
const GAP_S: f64 = 0.35;
const NOISE_DEG_S: f64 = 1.0;
/// Setpoint ramp time of each move, s (Betaflight's RC smoothing delivers a fast stick move over
/// a few tens of milliseconds); the shortest ramp when the setpoint's acceleration is limited.
pub const RAMP_S: f64 = 0.025;
const RAMP_STEPS: usize = 25;

/// One setpoint move of a doublet: from → to (deg/s), starting at `t_s` and ramping over `ramp_s`;
/// the next move starts `ramp_s − RAMP_S + HOLD_S` later (a slower ramp holds its target as long).
#[derive(Debug, Clone, Copy)]
struct Move {
    t_s: f64,
    ramp_s: f64,
    from: f64,
    to: f64,
}

impl Move {
    /// The end of the move's window (the next move's start).
    fn end_s(&self) -> f64 {
        self.t_s + self.ramp_s - RAMP_S + HOLD_S
    }
}

/// The doublets' moves, three per rate of [`RATES_DEG_S`], with `accel` (deg/s²) limiting each
/// ramp; the trace's end.
fn schedule(accel: Option<f64>) -> (Vec<[Move; 3]>, f64) {
    let mut t = T_FIRST_S;
    let mut out = Vec::new();
    for r in RATES_DEG_S {
        let mut prev = 0.0;
        let moves = [r, -r, 0.0].map(|to| {
            let ramp_s = accel.map_or(RAMP_S, |a| (to - prev).abs() / a).max(RAMP_S);
            let m = Move {
                t_s: t,
                ramp_s,
                from: prev,
                to,
            };
            t = m.end_s();
            prev = to;
            m
        });
        out.push(moves);
        t += GAP_S - HOLD_S;
    }
    (out, t)
}

/// Flies C_fb (gyro → output) and C_r (setpoint → output), continuous and in the plant's units.
///
/// # Errors
/// Non-physical setup numbers (named), controllers the simulator cannot run (delays, order above
/// 24), or a simulation error.
pub fn fly(setup: &FlightSetup, c_fb: &StateSpace, c_r: &StateSpace) -> Result<FlightCheck> {
    let s = setup;
    for (name, v) in [
        ("K", s.k),
        ("tau", s.tau_s),
        ("loop rate", s.loop_hz),
        ("gyro unit", s.gyro_unit_rad_s),
        ("output limit", s.output_limit),
        ("setpoint acceleration limit", s.setpoint_accel_deg_s2.unwrap_or(1.0)),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Input(format!(
                "flight check: {name} = {v} must be finite and > 0"
            )));
        }
    }
    if !(s.td_s.is_finite() && (0.0..=1.0).contains(&s.td_s)) {
        return Err(Error::Input(format!(
            "flight check: Td = {} s must be in [0, 1] s",
            s.td_s
        )));
    }
    if !(50.0..=32_000.0).contains(&s.loop_hz) {
        return Err(Error::Input(format!(
            "flight check: loop rate {} Hz outside 50..=32000 Hz",
            s.loop_hz
        )));
    }
    let dt = 1.0 / s.loop_hz;
    let law = |c: &StateSpace| -> Result<_> { Ok(to_discrete_siso(&discretize(c, dt)?)?) };
    let (fb, rf) = (law(c_fb)?, law(c_r)?);

    let mut quad = match skyloop_sim::presets::vehicle("quadrotor-ssi")? {
        VehicleSpec::Quadrotor(q) => q,
        _ => return Err(Error::Failed("preset quadrotor-ssi is not a quadrotor".into())),
    };
    // Full differential thrust at hover: two motors at 2·T_hover, two at 0, on arms l/√2.
    let torque_max = quad.arm_m / 2f64.sqrt() * quad.body.mass_kg * skyloop_sim::rigid::G;
    let k_rad = s.k * s.gyro_unit_rad_s; // rad/s² per output unit
    let j = torque_max / (k_rad * s.output_limit);
    quad.body.inertia_kg_m2 = [j, j, 1.8 * j];
    // RK4 at the loop rate needs the motor lag resolved: τ ≥ 2 steps.
    quad.tau_m_s = s.tau_s.max(2.0 * dt);
    let out_scale = j * s.k; // N·m per output unit, on rad/s inputs (the units cancel)
    let yaw_kp = 30.0 * 1.8 * j;

    let mut refs = vec![RefStep {
        t_s: 0.0,
        attitude_rad: None,
        position_m: None,
        rate_rad_s: Some([0.0; 3]),
    }];
    let (moves, duration) = schedule(s.setpoint_accel_deg_s2);
    // Acceleration-limited moves last long enough to roll the craft through inverted (500 deg/s
    // reached after 0.45 s is a flip) and to sink while it is: neither is a crash of the rate
    // loop, so only a diverging state or the ground far below counts.
    let shaped = s.setpoint_accel_deg_s2.is_some();
    for m in moves.iter().flatten() {
        // A stair of RAMP_STEPS steps over the ramp: the setpoint of a fast stick move after RC
        // smoothing or the firmware's acceleration limit (an ideal step would send the
        // feedforward's derivative to its limit).
        for i in 0..RAMP_STEPS {
            let f = (i + 1) as f64 / RAMP_STEPS as f64;
            refs.push(RefStep {
                t_s: m.t_s + m.ramp_s * i as f64 / RAMP_STEPS as f64,
                attitude_rad: None,
                position_m: None,
                rate_rad_s: Some([(m.from + f * (m.to - m.from)).to_radians(), 0.0, 0.0]),
            });
        }
    }
    let scn = Scenario {
        name: "tune: nonlinear check".into(),
        vehicle: VehicleEntry::Full(VehicleSpec::Quadrotor(quad)),
        sim: SimSpec {
            duration_s: duration,
            physics_hz: s.loop_hz,
            altitude_m: if shaped { 500.0 } else { 20.0 },
            log_hz: 0.0,
            crash_tilt_rad: if shaped { PI } else { 3.0 },
            settle_band: 0.01,
            actuator_rate_limit: Vec::new(),
            seed: 1,
        },
        controller: ControllerSpec {
            mode: Mode::Rate,
            rate_hz: s.loop_hz,
            attitude_hz: s.loop_hz,
            position_hz: s.loop_hz / 8.0,
            rate: vec![
                RateLaw::TwoDof {
                    feedback: fb.clone(),
                    reference: rf.clone(),
                    output_scale: out_scale,
                },
                RateLaw::TwoDof {
                    feedback: fb,
                    reference: rf,
                    output_scale: out_scale,
                },
                RateLaw::Pid {
                    kp: yaw_kp,
                    ki: 0.0,
                    kd: 0.0,
                    tf_s: 0.0,
                    i_limit_n_m: 1e9,
                },
            ],
            attitude_kp: [0.0; 3],
            max_rate_rad_s: 50.0,
            position_kp: [0.0, 0.0, 1.0],
            velocity_kp: [0.0, 0.0, 3.0],
            velocity_ki: [0.0, 0.0, 1.0],
            velocity_kd: [0.0; 3],
            max_tilt_rad: 0.6,
            max_torque_n_m: [torque_max, torque_max, 1e9],
        },
        gyro: GyroSpec {
            noise_rad_s: NOISE_DEG_S.to_radians(),
            bias_rad_s: [0.0; 3],
            lpf_hz: 0.0,
            delay_s: s.td_s,
        },
        reference: refs,
        disturbance: Vec::new(),
        monte_carlo: None,
    };
    let (trace, metrics) = skyloop_sim::simulate(&scn)?;
    // Torque per firmware output unit: J·K·unit (the controller ran on rad/s).
    Ok(summarize(
        &trace,
        metrics.crashed,
        out_scale * s.gyro_unit_rad_s,
        &moves,
    ))
}

fn summarize(trace: &[Sample], crashed: bool, torque_per_unit: f64, moves: &[[Move; 3]]) -> FlightCheck {
    let deg = 180.0 / PI;
    let t: Vec<f64> = trace.iter().map(|x| x.t).collect();
    let sp: Vec<f64> = trace.iter().map(|x| x.reference[0] * deg).collect();
    let y: Vec<f64> = trace.iter().map(|x| x.rates[0] * deg).collect();
    let hover: Vec<f64> = trace
        .iter()
        .filter(|x| x.t > 0.1 && x.t < T_FIRST_S)
        .map(|x| x.torque[0] / torque_per_unit)
        .collect();
    let mean = hover.iter().sum::<f64>() / hover.len().max(1) as f64;
    let hover_output_rms = (hover.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / hover.len().max(1) as f64).sqrt();
    let mut doublets = Vec::new();
    for (r, ms) in RATES_DEG_S.into_iter().zip(moves) {
        let t0 = ms[0].t_s;
        // Overshoot of each move (0 → r, r → −r, −r → 0) past its target, relative to its size.
        let mut overshoot: f64 = 0.0;
        for m in ms {
            let (a, b, from, to) = (m.t_s, m.end_s(), m.from, m.to);
            let dir = (to - from).signum();
            let past = t
                .iter()
                .zip(&y)
                .filter(|(x, _)| **x >= a && **x < b)
                .map(|(_, v)| dir * (v - to))
                .fold(0.0, f64::max);
            overshoot = overshoot.max(past / (to - from).abs());
        }
        // Rise time 10–90 % of the first move, as `stepinfo` reads it.
        let (tf, yf): (Vec<f64>, Vec<f64>) = t
            .iter()
            .zip(&y)
            .filter(|(x, _)| **x >= t0 && **x < ms[0].end_s())
            .unzip();
        let rise_time_s = skyloop_lti::timeresp::stepinfo(&tf, &yf, Some(r)).rise_time_s;
        let win = |x: &Sample| x.t >= t0 && x.t < ms[2].end_s();
        let w: Vec<&Sample> = trace.iter().filter(|x| win(x)).collect();
        let n = w.len().max(1) as f64;
        let rms = (w
            .iter()
            .map(|x| ((x.reference[0] - x.rates[0]) * deg).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let sat = w.iter().filter(|x| x.saturated).count() as f64 / n;
        doublets.push(Doublet {
            rate_deg_s: r,
            overshoot_pct: 100.0 * overshoot,
            rise_time_s,
            rms_error_deg_s: rms,
            saturated_fraction: sat,
        });
    }
    // The trace for plots and JSON: at most about 2000 points (the metrics used every sample).
    let every = t.len().div_ceil(2000).max(1);
    let thin = |v: Vec<f64>| v.into_iter().step_by(every).collect::<Vec<_>>();
    FlightCheck {
        doublets,
        hover_output_rms,
        crashed,
        t_s: thin(t),
        setpoint_deg_s: thin(sp),
        rate_deg_s: thin(y),
    }
}

impl FlightCheck {
    /// The largest overshoot over the doublets' moves, %.
    pub fn worst_overshoot_pct(&self) -> f64 {
        self.doublets.iter().map(|d| d.overshoot_pct).fold(0.0, f64::max)
    }

    /// `{doublets: [{rate_deg_s, overshoot_pct, rise_time_s, rms_error_deg_s, saturated_fraction}],
    /// hover_output_rms, crashed, gyro_noise_deg_s, trace: {t_s, setpoint_deg_s, rate_deg_s}}`.
    pub fn to_json(&self) -> Value {
        json!({
            "doublets": self.doublets.iter().map(|d| json!({
                "rate_deg_s": d.rate_deg_s,
                "overshoot_pct": d.overshoot_pct,
                "rise_time_s": d.rise_time_s,
                "rms_error_deg_s": d.rms_error_deg_s,
                "saturated_fraction": d.saturated_fraction,
            })).collect::<Vec<_>>(),
            "hover_output_rms": self.hover_output_rms,
            "crashed": self.crashed,
            "gyro_noise_deg_s": NOISE_DEG_S,
            "trace": {"t_s": self.t_s, "setpoint_deg_s": self.setpoint_deg_s, "rate_deg_s": self.rate_deg_s},
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::expr::parse_model;

    /// The btfl_all roll axis as identified (K deg/s² per PID unit, τ, Td), Betaflight units.
    fn setup() -> FlightSetup {
        FlightSetup {
            k: 126.5,
            tau_s: 0.00876,
            td_s: 0.00343,
            loop_hz: 8000.0,
            gyro_unit_rad_s: PI / 180.0,
            output_limit: 500.0,
            setpoint_accel_deg_s2: None,
        }
    }

    #[test]
    fn a_damped_loop_tracks_and_an_unstable_one_does_not() {
        // kp 0.5: crossover ≈ 55 rad/s, PM ≈ 54° on the identified model.
        let good = parse_model("0.5 + 2/s").unwrap();
        let f = fly(&setup(), &good, &good).unwrap();
        assert!(!f.crashed);
        let d = &f.doublets[0];
        assert!(d.overshoot_pct < 30.0, "{d:?}");
        assert!(d.rms_error_deg_s < 80.0, "{d:?}");
        let rise = d.rise_time_s.unwrap();
        // First order near crossover: 10–90 % in about 2.2/ω_c after the 25 ms ramp's own share.
        assert!(rise > 0.02 && rise < 0.08, "rise {rise}");
        // The hover output is gyro noise times the loop's high-frequency gain kp, in PID units.
        assert!(
            f.hover_output_rms > 0.1 && f.hover_output_rms < 1.5,
            "{}",
            f.hover_output_rms
        );
        // kp 5: crossover near 500 rad/s, far past −180° with the delay and lag: unstable.
        let bad = parse_model("5 + 2/s").unwrap();
        let f = fly(&setup(), &bad, &bad).unwrap();
        assert!(
            f.crashed || f.doublets[0].rms_error_deg_s > 150.0,
            "an unstable loop must fail the check: {:?}",
            f.doublets
        );
    }

    /// ArduPilot's ATC_ACCEL_R_MAX shapes the rate target: with 1100 deg/s² the 200 deg/s move
    /// takes 0.18 s, the 1000 deg/s reversal 0.91 s, and each move is held as long again; the
    /// metrics follow the moves (an overshoot measured in a window that ends mid-ramp would be
    /// the ramp, not the loop).
    #[test]
    fn an_acceleration_limit_slows_the_moves_and_the_windows_follow() {
        let (moves, end) = schedule(Some(1100.0));
        assert!((moves[0][0].ramp_s - 200.0 / 1100.0).abs() < 1e-12);
        assert!((moves[1][1].ramp_s - 1000.0 / 1100.0).abs() < 1e-12);
        assert!((moves[1][1].t_s - moves[1][0].end_s()).abs() < 1e-12);
        let (fast, fast_end) = schedule(None);
        assert!(fast.iter().flatten().all(|m| m.ramp_s == RAMP_S));
        assert!(end > fast_end + 2.0, "{end} vs {fast_end}");
        let c = parse_model("0.5 + 2/s").unwrap();
        let quick = fly(&setup(), &c, &c).unwrap();
        let shaped = fly(
            &FlightSetup {
                setpoint_accel_deg_s2: Some(1100.0),
                ..setup()
            },
            &c,
            &c,
        )
        .unwrap();
        // The setpoint reaches 200 deg/s only after 0.18 s.
        let at = |f: &FlightCheck, t: f64| {
            let k = f.t_s.iter().position(|x| *x >= t).unwrap();
            f.setpoint_deg_s[k]
        };
        assert!((at(&shaped, T_FIRST_S + 0.09) - 100.0).abs() < 10.0);
        assert!((at(&quick, T_FIRST_S + 0.09) - 200.0).abs() < 1e-9);
        let (q, sh) = (&quick.doublets[1], &shaped.doublets[1]);
        assert!(sh.rms_error_deg_s < q.rms_error_deg_s, "{sh:?} vs {q:?}");
        assert!(sh.overshoot_pct < q.overshoot_pct, "{sh:?} vs {q:?}");
    }

    #[test]
    fn bad_setups_are_named() {
        let c = parse_model("0.5 + 2/s").unwrap();
        let mut s = setup();
        s.k = f64::NAN;
        assert!(fly(&s, &c, &c).unwrap_err().to_string().contains("K"));
        let mut s = setup();
        s.loop_hz = 10.0;
        assert!(fly(&s, &c, &c).unwrap_err().to_string().contains("loop rate"));
    }
}
