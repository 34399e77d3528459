//! The ducted-fan VTOL of Pross (ETH), Section II-B: propeller thrust −kT·ω²·ẑ, a duct velocity field
//! ν = (ω/π)·√(kT/(2aϱ)) (eq. (3)), four flaps with drag ½ϱS(cd·α² + c0)ν² along ẑ and lift
//! ½ϱS·cℓ·α·ν² along their normal n̂ᵢ (eq. (4a)), per-flap torque (a/3·t̂ + d·ẑ) × (F_d + F_ℓ) with
//! t̂ = n̂ × ẑ, and the propeller's gyroscopic torque. Flap normals: +x, +y, −x, −y.
//! Actuators as in Section II-D: flaps critically damped 2nd order, propeller speed 1st order.
//!
//! Checked against the paper's equations (tests/ducted_fan.rs derives the hover partials by hand):
//! - eq. (4b) as printed keeps only the d·ẑ × ℓ part of the per-flap torque; the derivation's
//!   (a/3)·t̂ × ℓ term (t̂ × n̂ = ẑ) is the flaps' yaw authority, without which yaw would be
//!   uncontrollable, so we keep the full per-flap torque the text derives. Its drag part
//!   (a/3)·t̂ × F_d cancels over opposite flaps at equal angles and is second order in α.
//! - The paper writes the gyroscopic torque as ω·Jr·Rᵀ(k̂ × Ω), which mixes frames (Rᵀ maps body to
//!   inertial); we use the body-frame form ω·Jr·(ẑ × Ω) = −Ω × (Jr·ω·ẑ), the reaction of a rotor
//!   spinning about body z. At the paper's yaw-45° hover the two differ by that 45° rotation.
//! - Gravity acts in the inertial frame (eq. (2a)'s mg·Rᵀk̂ inside F is the same force written in
//!   body axes); the thrust uses ω·|ω| so a reversed propeller pushes the other way.

use crate::error::{check_min, check_pos, Result};
use crate::geometry::{self, V3};
use crate::rigid::{self, Body, External, Input, State, AUX, RATE};
use std::f64::consts::PI;

const NORMALS: [V3; 4] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
const Z: V3 = [0.0, 0.0, 1.0];

/// Ducted-fan parameters (SI units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DuctedFanParams {
    /// Rigid body.
    pub body: Body,
    /// Thrust coefficient kT (N·s²/rad²).
    pub kt: f64,
    /// Duct geometry constant a of eq. (3) (m) and the flap lever a/3 of the torque.
    pub a_m: f64,
    /// Flap area S (m²).
    pub s_m2: f64,
    /// Air density ϱ (kg/m³).
    pub rho_kg_m3: f64,
    /// Lift slope cℓ (1/rad).
    pub cl: f64,
    /// Quadratic drag coefficient cd (1/rad²).
    pub cd: f64,
    /// Zero-angle drag coefficient c0.
    pub c0: f64,
    /// Distance d of the flaps below the centre of mass (m).
    pub d_m: f64,
    /// Propeller inertia about its spin axis Jr (kg·m²).
    pub jr_kg_m2: f64,
    /// Flap actuator natural frequency (rad/s), critically damped.
    pub flap_wn_rad_s: f64,
    /// Propeller speed time constant (s).
    pub prop_tau_s: f64,
    /// Flap angle limit (rad, symmetric).
    pub flap_max_rad: f64,
    /// Maximum propeller speed (rad/s).
    pub omega_max_rad_s: f64,
}

impl DuctedFanParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        self.body.validate()?;
        for (v, n) in [
            (self.kt, "kt"),
            (self.a_m, "a_m"),
            (self.s_m2, "s_m2"),
            (self.rho_kg_m3, "rho_kg_m3"),
            (self.cl, "cl"),
            (self.flap_wn_rad_s, "flap_wn_rad_s"),
            (self.prop_tau_s, "prop_tau_s"),
            (self.flap_max_rad, "flap_max_rad"),
            (self.omega_max_rad_s, "omega_max_rad_s"),
        ] {
            check_pos(v, n)?;
        }
        check_min(self.cd, 0.0, "cd")?;
        check_min(self.c0, 0.0, "c0")?;
        check_min(self.d_m, 0.0, "d_m")?;
        check_min(self.jr_kg_m2, 0.0, "jr_kg_m2")
    }

    /// Dynamic pressure times flap area, ½ϱSν² (N per unit coefficient), at propeller speed ω.
    #[inline]
    pub fn q_s(&self, omega: f64) -> f64 {
        let nu2 = omega * omega / (PI * PI) * self.kt / (2.0 * self.a_m * self.rho_kg_m3);
        0.5 * self.rho_kg_m3 * self.s_m2 * nu2
    }
}

/// The ducted-fan model. States: α1..α4 (rad), α̇1..α̇4 (rad/s), ω (rad/s). Inputs: α1c..α4c, ωc.
#[derive(Debug, Clone)]
pub struct DuctedFan {
    /// Parameters.
    pub p: DuctedFanParams,
}

impl DuctedFan {
    /// Number of states.
    pub const NX: usize = AUX + 9;
    /// Number of inputs.
    pub const NU: usize = 5;

    /// State derivative.
    #[inline]
    pub fn derivative(&self, x: &State, u: &Input, ext: &External, dx: &mut State) {
        let p = &self.p;
        let omega = x[AUX + 8];
        let qs = p.q_s(omega);
        let mut f = [0.0, 0.0, -p.kt * omega * omega.abs()];
        let w = [x[RATE], x[RATE + 1], x[RATE + 2]];
        let mut m = geometry::scale(geometry::cross(Z, w), p.jr_kg_m2 * omega);
        for (i, n) in NORMALS.iter().enumerate() {
            let a = x[AUX + i];
            let fd = geometry::scale(Z, qs * (p.cd * a * a + p.c0));
            let fl = geometry::scale(*n, qs * p.cl * a);
            let ff = geometry::add(fd, fl);
            f = geometry::add(f, ff);
            let t = geometry::cross(*n, Z);
            let lever = geometry::add(geometry::scale(t, p.a_m / 3.0), geometry::scale(Z, p.d_m));
            m = geometry::add(m, geometry::cross(lever, ff));
        }
        let va = rigid::air_velocity_body(x, ext.wind_world);
        f = geometry::add(f, p.body.drag(va));
        rigid::rigid_derivative(p.body.mass_kg, p.body.inertia_kg_m2, x, w, f, m, ext, dx);
        let wn = p.flap_wn_rad_s;
        for i in 0..4 {
            dx[AUX + i] = x[AUX + 4 + i];
            dx[AUX + 4 + i] = wn * wn * (u[i] - x[AUX + i]) - 2.0 * wn * x[AUX + 4 + i];
        }
        dx[AUX + 8] = (u[4] - omega) / p.prop_tau_s;
    }

    /// Commands for total thrust (N) and body torque (N·m) at propeller speed `omega`; true if saturated.
    pub fn allocate(&self, omega: f64, thrust_n: f64, torque: V3, u: &mut Input) -> bool {
        let p = &self.p;
        let mut sat = false;
        // Vertical force per ω²: kT minus the zero-angle flap drag (eq. (4a) with α = 0).
        let k_eff = p.kt - 4.0 * p.c0 * p.q_s(1.0);
        let wc = (thrust_n.max(0.0) / k_eff.max(1e-12)).sqrt();
        let wcc = wc.min(p.omega_max_rad_s);
        sat |= wcc != wc;
        u[4] = wcc;
        // Flap torque map from the torque model (lift only): Mx = d·k·(α4 − α2), My = d·k·(α1 − α3),
        // Mz = (a/3)·k·Σα with k = cℓ·½ϱSν²; minimum-norm inverse.
        let k = p.cl * p.q_s(omega.max(0.2 * wcc));
        if k <= 0.0 {
            return true;
        }
        let sum = 3.0 * torque[2] / (p.a_m * k);
        let dp = torque[1] / (2.0 * p.d_m.max(1e-9) * k);
        let dr = torque[0] / (2.0 * p.d_m.max(1e-9) * k);
        let a = [0.25 * sum + dp, 0.25 * sum - dr, 0.25 * sum - dp, 0.25 * sum + dr];
        for i in 0..4 {
            let c = a[i].clamp(-p.flap_max_rad, p.flap_max_rad);
            sat |= c != a[i];
            u[i] = c;
        }
        sat
    }

    /// Input limits.
    pub fn input_limits(&self) -> ([f64; 5], [f64; 5]) {
        let m = self.p.flap_max_rad;
        ([-m, -m, -m, -m, 0.0], [m, m, m, m, self.p.omega_max_rad_s])
    }

    /// Hover trim: propeller speed such that thrust minus flap drag equals weight; flaps at zero.
    pub fn trim(&self, x: &mut State, u: &mut Input) {
        let p = &self.p;
        let k_eff = p.kt - 4.0 * p.c0 * p.q_s(1.0);
        let w = (p.body.mass_kg * rigid::G / k_eff).sqrt();
        x[AUX + 8] = w;
        u[4] = w;
    }

    /// Names of the vehicle-specific states and of the inputs.
    pub fn names(&self) -> (Vec<String>, Vec<String>) {
        let mut s: Vec<String> = (1..=4).map(|i| format!("alpha{i}_rad")).collect();
        s.extend((1..=4).map(|i| format!("alpha{i}_dot_rad_s")));
        s.push("omega_rad_s".into());
        let mut i: Vec<String> = (1..=4).map(|i| format!("alpha{i}_cmd_rad")).collect();
        i.push("omega_cmd_rad_s".into());
        (s, i)
    }
}
