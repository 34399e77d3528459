//! The X-configuration quadrotor of Tai, Phang & Hoo (2018), Section II: thrust/torque maps T = kT·Ω²,
//! Q = kQ·Ω² (eq. (11)–(12)), first-order motors with normalized PWM input (eq. (16)–(17)), body drag
//! (eq. (15)), rotor moments (eq. (14)). Rotors: 1 front-right, 2 front-left, 3 rear-left, 4 rear-right.

use crate::error::{check_min, check_pos, Result};
use crate::geometry::V3;
use crate::rigid::{self, Body, External, Input, State, AUX, RATE};

/// Quadrotor parameters (SI units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadParams {
    /// Rigid body.
    pub body: Body,
    /// Arm length l from centre to rotor (m).
    pub arm_m: f64,
    /// Thrust coefficient kT (N·s²/rad²).
    pub kt: f64,
    /// Torque coefficient kQ (N·m·s²/rad²).
    pub kq: f64,
    /// Motor steady-state gain km (rad/s per unit normalized input), eq. (16).
    pub km_rad_s: f64,
    /// Normalized input δ* at which the motor starts spinning, eq. (16).
    pub delta_star: f64,
    /// Motor time constant τm (s), eq. (16).
    pub tau_m_s: f64,
}

impl QuadParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        self.body.validate()?;
        check_pos(self.arm_m, "arm_m")?;
        check_pos(self.kt, "kt")?;
        check_min(self.kq, 0.0, "kq")?;
        check_pos(self.km_rad_s, "km_rad_s")?;
        check_min(self.delta_star, 0.0, "delta_star")?;
        check_pos(self.tau_m_s, "tau_m_s")
    }
}

/// The quadrotor model.
#[derive(Debug, Clone)]
pub struct Quadrotor {
    /// Parameters.
    pub p: QuadParams,
}

const S2: f64 = std::f64::consts::FRAC_1_SQRT_2;
// Signs of eq. (14): Mx ∝ (T2 + T3 − T1 − T4), My ∝ (T1 + T2 − T3 − T4), Mz = Q1 + Q3 − Q2 − Q4.
const MX: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
const MY: [f64; 4] = [1.0, 1.0, -1.0, -1.0];
const MZ: [f64; 4] = [1.0, -1.0, 1.0, -1.0];

impl Quadrotor {
    /// Number of states.
    pub const NX: usize = AUX + 4;
    /// Number of inputs (normalized PWM δn ∈ [0, 1], eq. (17)).
    pub const NU: usize = 4;

    /// Rotor thrusts (N) at rotor speeds Ω (rad/s).
    #[inline]
    fn thrusts(&self, x: &State) -> [f64; 4] {
        let mut t = [0.0; 4];
        for (i, ti) in t.iter_mut().enumerate() {
            let w = x[AUX + i];
            *ti = self.p.kt * w * w.abs();
        }
        t
    }

    /// State derivative.
    #[inline]
    pub fn derivative(&self, x: &State, u: &Input, ext: &External, dx: &mut State) {
        let p = &self.p;
        let t = self.thrusts(x);
        let s = S2 * p.arm_m;
        let ratio = p.kq / p.kt;
        let mut m = [0.0; 3];
        for i in 0..4 {
            m[0] += s * MX[i] * t[i];
            m[1] += s * MY[i] * t[i];
            m[2] += ratio * MZ[i] * t[i];
        }
        let va = rigid::air_velocity_body(x, ext.wind_world);
        let d = p.body.drag(va);
        let f = [d[0], d[1], -(t[0] + t[1] + t[2] + t[3])];
        let w = [x[RATE], x[RATE + 1], x[RATE + 2]];
        rigid::rigid_derivative(p.body.mass_kg, p.body.inertia_kg_m2, x, w, f, m, ext, dx);
        for i in 0..4 {
            // A motor below δ* does not spin backwards (eq. (16) holds for δ ≥ δ*).
            let target = p.km_rad_s * (u[i] - p.delta_star).max(0.0);
            dx[AUX + i] = (target - x[AUX + i]) / p.tau_m_s;
        }
    }

    /// Actuator commands for a total thrust (N) and body torque (N·m); true when any input saturated.
    pub fn allocate(&self, thrust_n: f64, torque: V3, u: &mut Input) -> bool {
        let p = &self.p;
        let s = S2 * p.arm_m;
        let mut sat = false;
        for i in 0..4 {
            let mz = if p.kq > 0.0 { torque[2] * p.kt / p.kq } else { 0.0 };
            let ti = 0.25 * (thrust_n + MX[i] * torque[0] / s + MY[i] * torque[1] / s + MZ[i] * mz);
            let omega = (ti.max(0.0) / p.kt).sqrt();
            let d = omega / p.km_rad_s + p.delta_star;
            sat |= !(0.0..=1.0).contains(&d) || ti < 0.0;
            u[i] = d.clamp(0.0, 1.0);
        }
        sat
    }

    /// Input limits (normalized PWM).
    pub fn input_limits(&self) -> ([f64; 4], [f64; 4]) {
        ([0.0; 4], [1.0; 4])
    }

    /// Hover trim: rotor speeds and inputs such that thrust equals weight.
    pub fn trim(&self, x: &mut State, u: &mut Input) {
        let p = &self.p;
        let w = (p.body.mass_kg * rigid::G / (4.0 * p.kt)).sqrt();
        for i in 0..4 {
            x[AUX + i] = w;
            u[i] = w / p.km_rad_s + p.delta_star;
        }
    }

    /// Names of the vehicle-specific states and of the inputs.
    pub fn names(&self) -> (Vec<String>, Vec<String>) {
        (
            (1..=4).map(|i| format!("omega{i}_rad_s")).collect(),
            (1..=4).map(|i| format!("delta{i}")).collect(),
        )
    }
}
