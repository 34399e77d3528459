//! A simulated ArduCopter roll rate loop written as a DataFlash log: PARM messages, RATE (the
//! desired rate, the achieved rate, the output) and CTUN (throttle), with the DataFlash writer the
//! reader's own tests use.

use super::writer::{Writer, V};

/// One control step: (time µs, desired rate, logged rate, output), rates in deg/s.
pub type Step = (u64, f64, f64, f64);

/// The log of `steps` with the parameters `params`, RATE written every `every`-th step and CTUN
/// every 40th.
pub fn rate_log(params: &[(&str, f64)], steps: &[Step], every: usize) -> Vec<u8> {
    let mut w = Writer::new();
    w.define_units();
    w.define(133, "MSG", "QZ", "TimeUS,Message");
    w.define(135, "RATE", "Qfffffffff", "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut");
    w.define(136, "CTUN", "Qf", "TimeUS,ThO");
    w.define(137, "PARM", "QNf", "TimeUS,Name,Value");
    w.units(0, 135, "skkk-kk-kk", "F000000000");
    w.units(0, 136, "s-", "F0");
    w.msg("UNIT", &[V::I(0), V::N(f64::from(b's')), V::T("s".into())]);
    w.msg("MULT", &[V::I(0), V::N(f64::from(b'F')), V::N(1e-6)]);
    w.msg("MSG", &[V::I(100), V::T("ArduCopter V4.5.7 (2a3dc4b7)".into())]);
    for (name, v) in params {
        w.msg("PARM", &[V::I(200), V::T((*name).into()), V::N(*v)]);
    }
    for (k, &(t, des, r, u)) in steps.iter().enumerate() {
        if k % every != 0 {
            continue;
        }
        let mut fields = vec![V::I(t.into()), V::N(des), V::N(r), V::N(u)];
        fields.extend((0..6).map(|_| V::N(0.0)));
        w.msg("RATE", &fields);
        if k % 40 == 0 {
            w.msg("CTUN", &[V::I(t.into()), V::N(0.45)]);
        }
    }
    w.bytes
}

/// A reproducible uniform random number in [−0.5, 0.5) per call (an LCG, so the flights are the
/// same on every machine).
pub fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// A roll tune request for the simulated log `name`, with two optimizer starts (the tests' pace).
pub fn roll_request(name: &str) -> skyloop::tune::log::LogTuneRequest {
    let mut req = skyloop::tune::log::LogTuneRequest::new(
        name.into(),
        skyloop::firmware::Axis::Roll,
        skyloop::tune::Firmware::Ardupilot,
    );
    req.starts = 2;
    req
}

/// `n` steps of a 400 Hz ArduCopter-style rate loop: a PID on the error e = desired − rate (per
/// deg/s: `gains` = (P, I, D), D the raw difference of e), its output clamped to ±1, held over the
/// period and delayed by `delay_s`, into `plant(u, h)`, which advances the airframe by `h` s and
/// returns its rate (deg/s); 20 plant steps per control period. `desired(k, t)` is the pilot's rate.
pub fn fly_rate_loop(
    n: u64,
    gains: (f64, f64, f64),
    delay_s: f64,
    mut desired: impl FnMut(u64, f64) -> f64,
    mut plant: impl FnMut(f64, f64) -> f64,
) -> Vec<Step> {
    let dt = 1.0 / 400.0;
    let sub = 20;
    let h = dt / f64::from(sub);
    let delay_steps = (delay_s / h).round() as usize;
    let (kp, ki, kd) = gains;
    let mut buf = vec![0.0; delay_steps + 1];
    let (mut rate, mut integ, mut prev_e) = (0.0f64, 0.0f64, 0.0f64);
    let mut out = Vec::new();
    for k in 0..n {
        let t = k as f64 * dt;
        let des = desired(k, t);
        let e = des - rate;
        integ += e * dt;
        let d = (e - prev_e) / dt;
        prev_e = e;
        let u = (kp * e + ki * integ + kd * d).clamp(-1.0, 1.0);
        out.push(((1_000_000.0 + t * 1e6) as u64, des, rate, u));
        for _ in 0..sub {
            buf.rotate_right(1);
            buf[0] = u;
            rate = plant(buf[delay_steps], h);
        }
    }
    out
}
