//! `identify LOG --axis roll` and `tune LOG` on a PX4 high-rate ULog (SDLOG_PROFILE's high-rate
//! bits): a closed rate loop simulated at 800 Hz (a known plant K·e^(−Td·s)/(s·(τs+1)), torque
//! setpoint normalized → rad/s, under PX4's parallel rate PID with D on the measured rate lowpassed
//! by IMU_DGYRO_CUTOFF) with broadband stick excitation, written with the ULog writer of the reader's
//! tests as `vehicle_angular_velocity`, `vehicle_torque_setpoint`, `vehicle_rates_setpoint` and
//! `actuator_motors` at 800 Hz plus the flown MC_ROLLRATE_* and IMU_* parameters. A test-stand log
//! (motors idle or saturated throughout) is refused with the reason.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

#[path = "../../skyloop-sysid/tests/common/ulog_writer.rs"]
mod ulog_writer;

use skyloop::identify::{identify_bytes, IdentifyRequest};
use skyloop::lti::c64;
use skyloop::tune::log::{tune_from_log_bytes, LogTuneRequest};
use skyloop::tune::Firmware;
use std::f64::consts::PI;
#[path = "common/loop_margins.rs"]
mod common;

use ulog_writer::{Writer, F};

const K: f64 = 200.0; // rad/s² per unit of normalized torque
const TAU: f64 = 0.02; // s
const TD: f64 = 0.004; // s
const LOOP_HZ: f64 = 800.0;
/// MC_ROLLRATE_K, P, I, D, FF.
const FLOWN: (f64, f64, f64, f64, f64) = (1.0, 0.15, 0.2, 0.003, 0.0);
const DGYRO_HZ: f64 = 30.0;

/// A 2nd-order Butterworth lowpass as PX4's `math::LowPassFilter2p` (bilinear, prewarped cutoff).
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Biquad {
    fn new(fc: f64, fs: f64) -> Biquad {
        let fr = fs / fc;
        let ohm = (PI / fr).tan();
        let c = 1.0 + 2.0 * (PI / 4.0).cos() * ohm + ohm * ohm;
        let b0 = ohm * ohm / c;
        Biquad {
            b: [b0, 2.0 * b0, b0],
            a: [
                2.0 * (ohm * ohm - 1.0) / c,
                (1.0 - 2.0 * (PI / 4.0).cos() * ohm + ohm * ohm) / c,
            ],
            z: [0.0; 2],
        }
    }

    /// Transposed direct form II.
    fn apply(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }

    /// H(z) at z = e^{jωT}.
    fn response(&self, z: c64) -> c64 {
        let zi = z.inv();
        (self.b[0] + self.b[1] * zi + self.b[2] * zi * zi) / (1.0 + self.a[0] * zi + self.a[1] * zi * zi)
    }
}

/// One control step: (time µs, rate setpoint, rate, torque setpoint), rad/s and normalized.
type Step = (u64, f64, f64, f64);

/// `secs` of an 800 Hz roll rate loop, logger start at 1 s.
fn flight(secs: f64) -> Vec<Step> {
    let dt = 1.0 / LOOP_HZ;
    let sub = 10;
    let h = dt / sub as f64;
    let delay_steps = (TD / h).round() as usize;
    let (kk, kp, ki, kd, kff) = FLOWN;
    let mut dfilt = Biquad::new(DGYRO_HZ, LOOP_HZ);
    let mut buf = vec![0.0; delay_steps + 1];
    let (mut rate, mut acc, mut integ, mut prev_rate) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut seed = 2024u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut stick = 0.0;
    let mut out = Vec::new();
    for k in 0..(secs * LOOP_HZ) as u64 {
        let t = k as f64 * dt;
        // Stick steps every 0.1 s (3 rad/s) plus a little noise and a 9 Hz sine: broadband.
        if k % 80 == 0 {
            stick = 6.0 * rnd();
        }
        let sp = stick + 0.4 * rnd() + 0.8 * (2.0 * PI * 9.0 * t).sin();
        let e = sp - rate;
        integ += e * dt;
        // PX4: D on the measured rate's derivative, lowpassed by IMU_DGYRO_CUTOFF; negative sign.
        let d_meas = dfilt.apply((rate - prev_rate) / dt);
        prev_rate = rate;
        let u = (kk * (kp * e + ki * integ - kd * d_meas) + kff * sp).clamp(-1.0, 1.0);
        out.push(((1_000_000.0 + t * 1e6).round() as u64, sp, rate, u));
        for _ in 0..sub {
            buf.rotate_right(1);
            buf[0] = u;
            let ud = buf[delay_steps];
            acc += h * (K * ud - acc) / TAU;
            rate += h * acc;
        }
    }
    out
}

/// What the motors do: `flying` keeps them in (0.01, 0.99) around hover; otherwise a test stand.
#[derive(Clone, Copy, PartialEq)]
enum Motors {
    Flying,
    Idle,
    Saturated,
    /// Motors in range but no collective thrust (`thrust_body[2]` = 0).
    NoThrust,
}

/// The flight as a ULog with PX4's topics at 800 Hz.
fn log_bytes(steps: &[Step], motors: Motors) -> Vec<u8> {
    log_bytes_jitter(steps, motors, 0, 1)
}

/// The flight as a ULog whose time stamps jitter by up to `jitter_us` (the sample times of a real
/// IMU and scheduler) and whose rate setpoint is logged every `sp_every`-th step (PX4's attitude
/// controller publishes `vehicle_rates_setpoint` slower than the rate loop runs).
fn log_bytes_jitter(steps: &[Step], motors: Motors, jitter_us: u64, sp_every: usize) -> Vec<u8> {
    let mut seed = 99u64;
    let mut jitter = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 33) % (jitter_us + 1)
    };
    let mut w = Writer::new(1_000_000);
    w.format(
        "vehicle_angular_velocity",
        &[
            "uint64_t timestamp",
            "uint64_t timestamp_sample",
            "float[3] xyz",
            "float[3] xyz_derivative",
        ],
    );
    w.format(
        "vehicle_torque_setpoint",
        &["uint64_t timestamp", "uint64_t timestamp_sample", "float[3] xyz"],
    );
    w.format(
        "vehicle_rates_setpoint",
        &[
            "uint64_t timestamp",
            "float roll",
            "float pitch",
            "float yaw",
            "float[3] thrust_body",
            "bool reset_integral",
            "uint8_t[7] _padding0",
        ],
    );
    w.format(
        "actuator_motors",
        &[
            "uint64_t timestamp",
            "uint64_t timestamp_sample",
            "float[12] control",
            "uint16_t reversible_flags",
            "uint8_t[6] _padding0",
        ],
    );
    w.info("sys_name", "PX4");
    w.info("ver_hw", "PX4_SITL");
    w.info("ver_sw", "v1.15.0");
    let (kk, kp, ki, kd, kff) = FLOWN;
    for (n, v) in [
        ("MC_ROLLRATE_K", kk),
        ("MC_ROLLRATE_P", kp),
        ("MC_ROLLRATE_I", ki),
        ("MC_ROLLRATE_D", kd),
        ("MC_ROLLRATE_FF", kff),
        ("MC_PITCHRATE_K", 1.0),
        ("MC_PITCHRATE_P", 0.15),
        ("MC_PITCHRATE_I", 0.2),
        ("MC_PITCHRATE_D", 0.003),
        ("MC_PITCHRATE_FF", 0.0),
        // The simulated gyro is not lowpassed: IMU_GYRO_CUTOFF off.
        ("IMU_GYRO_CUTOFF", 0.0),
        ("IMU_DGYRO_CUTOFF", DGYRO_HZ),
    ] {
        w.param_f32(n, v as f32);
    }
    w.param_i32("IMU_GYRO_RATEMAX", LOOP_HZ as i32);
    w.param_i32("SDLOG_PROFILE", 1 | 2 | 4 | 64 | 128);
    for (i, n) in [
        "vehicle_angular_velocity",
        "vehicle_torque_setpoint",
        "vehicle_rates_setpoint",
        "actuator_motors",
    ]
    .iter()
    .enumerate()
    {
        w.add_logged(n, 0, i as u16);
    }
    let mut prev = 0.0;
    for (k, &(t, sp, r, u)) in steps.iter().enumerate() {
        let t = t + jitter();
        let ts = F::U64(t);
        w.data(
            0,
            &[
                ts.clone(),
                ts.clone(),
                F::F32s(vec![r as f32, 0.0, 0.0]),
                F::F32s(vec![((r - prev) * LOOP_HZ) as f32, 0.0, 0.0]),
            ],
        );
        prev = r;
        w.data(1, &[ts.clone(), ts.clone(), F::F32s(vec![u as f32, 0.0, 0.0])]);
        if k % sp_every == 0 {
            w.data(
                2,
                &[
                    ts.clone(),
                    F::F32(sp as f32),
                    F::F32(0.0),
                    F::F32(0.0),
                    F::F32s(vec![0.0, 0.0, if motors == Motors::NoThrust { 0.0 } else { -0.45 }]),
                    F::Bytes(vec![0]), // reset_integral; the trailing padding is not written
                ],
            );
        }
        // A quad's roll mix around hover; PX4 logs NaN for the outputs the frame does not use.
        let mut control = vec![f32::NAN; 12];
        for (k, side) in [-1.0, 1.0, 1.0, -1.0].iter().enumerate() {
            control[k] = match motors {
                Motors::Flying | Motors::NoThrust => (0.45 + 0.3 * side * u) as f32,
                Motors::Idle => 0.0,
                Motors::Saturated => 1.0,
            };
        }
        w.data(3, &[ts.clone(), ts, F::F32s(control), F::U16(0)]);
    }
    w.bytes
}

fn request() -> IdentifyRequest {
    IdentifyRequest {
        data: "px4-highrate.ulg".into(),
        axis: Some("roll".into()),
        ..Default::default()
    }
}

#[test]
fn an_800_hz_px4_log_identifies_the_rate_loop_at_its_own_rate() {
    let bytes = log_bytes(&flight(25.0), Motors::Flying);
    let id = identify_bytes(&bytes, &request()).unwrap();
    let (k, tau, td) = common::fitted(&id);
    let f_max = id.frf.freq_hz.last().copied().unwrap_or(0.0);
    eprintln!(
        "identified K {k:.1} (true {K}), tau {tau:.4} ({TAU}), Td {td:.4} ({TD}); input {}, output {}, instrument {:?}; FRF up to {f_max:.1} Hz; notes {:?}; warnings {:?}",
        id.input, id.output, id.instrument, id.notes, id.warnings
    );
    assert_eq!(id.input, "vehicle_torque_setpoint.xyz[0]");
    assert_eq!(id.output, "vehicle_angular_velocity.xyz[0]");
    // Every channel is read at its own 800 Hz: the estimate reaches past what 400 Hz would allow.
    assert!(f_max > 0.4 * 400.0, "FRF stops at {f_max} Hz");
    assert!((k / K - 1.0).abs() < 0.15, "K {k} vs {K}");
    assert!((tau - TAU).abs() < 0.3 * TAU, "tau {tau} vs {TAU}");
    // The logged rate is read before the step's command: up to half a period of hold more delay.
    assert!(td > TD - 0.001 && td < TD + 0.002, "Td {td} vs {TD}");
}

/// (crossover Hz, phase margin deg) of the simulated loop in closed form: the discrete controller
/// C(z) = K·(P + I·T/(1 − z⁻¹) + D·(1 − z⁻¹)/T·H_dgyro(z)) at z = e^{jωT} on the plant with its delay
/// and half a period of hold.
fn true_margins(k: f64, p: f64, i: f64, d: f64) -> (f64, f64) {
    let dt = 1.0 / LOOP_HZ;
    let filt = Biquad::new(DGYRO_HZ, LOOP_HZ);
    let l = |w: f64| {
        let s = c64::new(0.0, w);
        let z = (s * dt).exp();
        let back = 1.0 - z.inv();
        let c = k * (p + i * dt / back + d * back / dt * filt.response(z));
        let g = K * (-s * (TD + 0.5 * dt)).exp() / (s * (TAU * s + 1.0));
        c * g
    };
    common::crossover_and_phase_margin(l, 1.0, 2000.0)
}

#[test]
fn tune_from_a_px4_high_rate_log_rates_the_flown_tune_and_prints_param_set_lines() {
    let bytes = log_bytes(&flight(25.0), Motors::Flying);
    let mut req = LogTuneRequest::new("px4-highrate.ulg".into(), skyloop::firmware::Axis::Roll, Firmware::Px4);
    req.starts = 2;
    let out = tune_from_log_bytes(&req, &bytes).unwrap();
    let cur = out.current.as_ref().expect("the flown MC_ROLLRATE_* are read");
    let (kk, kp, ki, kd, _) = FLOWN;
    let truth = true_margins(kk, kp, ki, kd);
    eprintln!(
        "flown: model crossover {:.2} Hz PM {:.1} deg; true {:.2} Hz PM {:.1} deg; verdict {}; lines {:?}",
        cur.margins.crossover_hz, cur.margins.phase_margin_deg, truth.0, truth.1, out.verdict.text, out.proposed.cli
    );
    assert!((cur.margins.crossover_hz / truth.0 - 1.0).abs() < 0.15);
    assert!((cur.margins.phase_margin_deg - truth.1).abs() < 8.0);
    let lines = &out.proposed.cli;
    for n in ["MC_ROLLRATE_P", "MC_ROLLRATE_I", "MC_ROLLRATE_D"] {
        assert!(
            lines.iter().any(|l| l.starts_with(&format!("param set {n} "))),
            "{lines:?}"
        );
    }
    // `--tune-filters`: IMU_GYRO_CUTOFF is off here, so only IMU_DGYRO_CUTOFF may move, by its
    // own `param set` line, never below 1.5× the crossover, within the noise budget.
    req.tune_filters = true;
    let out = tune_from_log_bytes(&req, &bytes).unwrap();
    let lines = &out.proposed.cli;
    eprintln!("--tune-filters: {}; {lines:?}", out.verdict.text);
    let xo = out.proposed_analysis.margins.crossover_hz;
    for c in &out.filter_changes {
        assert_eq!(c.name, "IMU_DGYRO_CUTOFF");
        assert!(
            lines.contains(&format!("param set IMU_DGYRO_CUTOFF {}", c.proposed_hz)),
            "{lines:?}"
        );
        assert!(c.proposed_hz >= 1.5 * xo && c.reason.contains("every axis"), "{c:?}");
    }
    assert!(out.noise.as_ref().is_none_or(|n| n.ratio() <= req.noise_budget + 1e-9));
}

#[test]
fn a_test_stand_log_is_refused_with_the_reason() {
    let steps = flight(6.0);
    for (motors, reason) in [
        (Motors::Idle, "motors at idle"),
        (Motors::Saturated, "motor saturation"),
        (Motors::NoThrust, "idle throttle"),
    ] {
        let e = identify_bytes(&log_bytes(&steps, motors), &request())
            .unwrap_err()
            .to_string();
        eprintln!("{e}");
        assert!(
            e.contains(&format!("{reason} for the whole log")) && e.contains("fly"),
            "{e}"
        );
    }
}

#[test]
fn jittered_time_stamps_and_a_slower_setpoint_keep_each_channel_at_its_own_rate() {
    let bytes = log_bytes_jitter(&flight(25.0), Motors::Flying, 300, 3);
    let id = identify_bytes(&bytes, &request()).unwrap();
    let (k, tau, td) = common::fitted(&id);
    let f_max = id.frf.freq_hz.last().copied().unwrap_or(0.0);
    eprintln!(
        "jittered, setpoint at 267 Hz: K {k:.1} tau {tau:.4} Td {td:.4}, FRF up to {f_max:.1} Hz; warnings {:?}",
        id.warnings
    );
    // The band stops at the setpoint's 267 Hz / 2.5, and the warning says so.
    assert!((f_max - 800.0 / 3.0 / 2.5).abs() < 3.0, "{f_max}");
    assert!(
        id.warnings
            .iter()
            .any(|w| w.contains("vehicle_rates_setpoint.roll") && w.contains("resampled to")),
        "{:?}",
        id.warnings
    );
    assert!((k / K - 1.0).abs() < 0.15, "K {k} vs {K}");
    assert!((tau - TAU).abs() < 0.3 * TAU, "tau {tau} vs {TAU}");
    assert!(td > TD - 0.001 && td < TD + 0.002, "Td {td} vs {TD}");
}

/// The same flight in PX4's default logging (every topic at 50 Hz) cannot show the rate loop; the
/// warning says so and names the setting that logs it at the loop's rate.
#[test]
fn a_50_hz_px4_log_names_sdlog_profile() {
    let steps: Vec<Step> = flight(25.0).into_iter().step_by(16).collect();
    let id = identify_bytes(&log_bytes(&steps, Motors::Flying), &request()).unwrap();
    assert!(
        id.warnings.iter().any(
            |w| w.contains("logged at 50.0 Hz, too slow") && w.contains("SDLOG_PROFILE bit 4 (High rate, value 16")
        ),
        "{:?}",
        id.warnings
    );
}
