//! The bi-copter of Li, Qin, Xu & Zhang: two tandem rotors (front at x = +d, rear at x = −d, both a
//! height H above the centre of mass) tilted about body-x axes by servos. A collective tilt δ gives the
//! roll torque T·H·sin δ (eq. (1)); the servo's reaction torque −Im·(φ̈ + δ̈) on the body (eq. (2)–(4))
//! produces the right-half-plane zero of eq. (5). Differential tilt gives yaw, differential thrust pitch.
//!
//! The servo is first order with gain and delay (eq. (6)): δ̇ = (ks·δc(t − Td) − δ)/τs. Because a
//! kinematic servo makes δ̈ impulsive at command steps, the roll state is the roll angular momentum of
//! body plus rotors, h = (Ib + Im)·p + (Im/2)(δ̇1 + δ̇2), which stays continuous; p is recovered from h.
//! Terms of order Im·δ̇·(q, r) (gyroscopic coupling of the tilting rotors) are neglected.

use crate::error::{check_min, check_pos, Result};
use crate::geometry::{self, V3};
use crate::rigid::{self, Body, External, Input, State, AUX, RATE};

/// Bicopter parameters (SI units). `body.inertia_kg_m2[0]` is ignored: roll inertia is Ib + Im.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BicopterParams {
    /// Rigid body (mass, Jy, Jz, drag).
    pub body: Body,
    /// Roll inertia of the body without the rotor assemblies, Ib (kg·m²).
    pub ib_kg_m2: f64,
    /// Total inertia of both tilting rotor assemblies about their tilt axes, Im (kg·m²).
    pub im_kg_m2: f64,
    /// Height H of the rotors above the centre of mass (m).
    pub h_m: f64,
    /// Distance d of each rotor from the centre along body x (m).
    pub arm_m: f64,
    /// Servo static gain ks (rad per command unit), eq. (6).
    pub servo_gain: f64,
    /// Servo time constant τs (s), eq. (6).
    pub servo_tau_s: f64,
    /// Servo pure delay Td (s), eq. (6).
    pub servo_delay_s: f64,
    /// Servo command limit (command units, symmetric).
    pub servo_max: f64,
    /// Rotor thrust time constant (s).
    pub motor_tau_s: f64,
    /// Maximum thrust per rotor (N).
    pub thrust_max_n: f64,
}

impl BicopterParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        self.body.validate()?;
        check_pos(self.ib_kg_m2, "ib_kg_m2")?;
        check_min(self.im_kg_m2, 0.0, "im_kg_m2")?;
        check_pos(self.h_m, "h_m")?;
        check_pos(self.arm_m, "arm_m")?;
        check_pos(self.servo_gain, "servo_gain")?;
        check_pos(self.servo_tau_s, "servo_tau_s")?;
        check_min(self.servo_delay_s, 0.0, "servo_delay_s")?;
        check_pos(self.servo_max, "servo_max")?;
        check_pos(self.motor_tau_s, "motor_tau_s")?;
        check_pos(self.thrust_max_n, "thrust_max_n")
    }

    /// Total roll inertia Ib + Im (kg·m²).
    pub fn jx(&self) -> f64 {
        self.ib_kg_m2 + self.im_kg_m2
    }
}

/// The bicopter model. Vehicle states: δ1, δ2 (rad), T1, T2 (N). Inputs: T1c, T2c (N), δ1c, δ2c.
#[derive(Debug, Clone)]
pub struct Bicopter {
    /// Parameters.
    pub p: BicopterParams,
}

impl Bicopter {
    /// Number of states.
    pub const NX: usize = AUX + 4;
    /// Number of inputs.
    pub const NU: usize = 4;

    fn inertia(&self) -> V3 {
        [self.p.jx(), self.p.body.inertia_kg_m2[1], self.p.body.inertia_kg_m2[2]]
    }

    /// Servo rates δ̇1, δ̇2 (rad/s) under command u.
    #[inline]
    fn servo_rates(&self, x: &State, u: &Input) -> [f64; 2] {
        let p = &self.p;
        [
            (p.servo_gain * u[2] - x[AUX]) / p.servo_tau_s,
            (p.servo_gain * u[3] - x[AUX + 1]) / p.servo_tau_s,
        ]
    }

    /// True body rates p, q, r (rad/s): p from the roll momentum state.
    #[inline]
    pub fn rates(&self, x: &State, u: &Input) -> V3 {
        let sd = self.servo_rates(x, u);
        let p = (x[RATE] - 0.5 * self.p.im_kg_m2 * (sd[0] + sd[1])) / self.p.jx();
        [p, x[RATE + 1], x[RATE + 2]]
    }

    /// State derivative.
    #[inline]
    pub fn derivative(&self, x: &State, u: &Input, ext: &External, dx: &mut State) {
        let p = &self.p;
        let (d1, d2, t1, t2) = (x[AUX], x[AUX + 1], x[AUX + 2], x[AUX + 3]);
        let (s1, c1) = d1.sin_cos();
        let (s2, c2) = d2.sin_cos();
        let f1 = [0.0, t1 * s1, -t1 * c1];
        let f2 = [0.0, t2 * s2, -t2 * c2];
        let m = geometry::add(
            geometry::cross([p.arm_m, 0.0, -p.h_m], f1),
            geometry::cross([-p.arm_m, 0.0, -p.h_m], f2),
        );
        let va = rigid::air_velocity_body(x, ext.wind_world);
        let f = geometry::add(geometry::add(f1, f2), p.body.drag(va));
        let w = self.rates(x, u);
        let j = self.inertia();
        rigid::rigid_derivative(p.body.mass_kg, j, x, w, f, m, ext, dx);
        // Roll momentum h: ḣ = Mx − (ω × Jω)x; undo the division by Jx done for a plain body rate.
        dx[RATE] *= j[0];
        let sd = self.servo_rates(x, u);
        dx[AUX] = sd[0];
        dx[AUX + 1] = sd[1];
        dx[AUX + 2] = (u[0] - t1) / p.motor_tau_s;
        dx[AUX + 3] = (u[1] - t2) / p.motor_tau_s;
    }

    /// Commands for total thrust (N) and body torque (N·m) at the current thrusts; true if saturated.
    pub fn allocate(&self, thrust_n: f64, torque: V3, u: &mut Input) -> bool {
        let p = &self.p;
        let mut sat = false;
        let t1 = 0.5 * (thrust_n + torque[1] / p.arm_m);
        let t2 = 0.5 * (thrust_n - torque[1] / p.arm_m);
        let lat1 = 0.5 * (torque[0] / p.h_m + torque[2] / p.arm_m);
        let lat2 = 0.5 * (torque[0] / p.h_m - torque[2] / p.arm_m);
        for (i, (t, lat)) in [(t1, lat1), (t2, lat2)].into_iter().enumerate() {
            let tc = t.clamp(0.0, p.thrust_max_n);
            sat |= tc != t;
            u[i] = tc;
            let sd = if tc > 1e-6 { (lat / tc).clamp(-1.0, 1.0) } else { 0.0 };
            let cmd = sd.asin() / p.servo_gain;
            let cc = cmd.clamp(-p.servo_max, p.servo_max);
            sat |= cc != cmd;
            u[2 + i] = cc;
        }
        sat
    }

    /// Input limits.
    pub fn input_limits(&self) -> ([f64; 4], [f64; 4]) {
        let p = &self.p;
        (
            [0.0, 0.0, -p.servo_max, -p.servo_max],
            [p.thrust_max_n, p.thrust_max_n, p.servo_max, p.servo_max],
        )
    }

    /// Pure delays of each input (s): the servo delay of eq. (6).
    pub fn input_delays(&self) -> [f64; 4] {
        [0.0, 0.0, self.p.servo_delay_s, self.p.servo_delay_s]
    }

    /// Hover trim: each rotor carries half the weight, servos centred.
    pub fn trim(&self, x: &mut State, u: &mut Input) {
        let t = 0.5 * self.p.body.mass_kg * rigid::G;
        x[AUX + 2] = t;
        x[AUX + 3] = t;
        u[0] = t;
        u[1] = t;
    }

    /// Names of the vehicle-specific states and of the inputs.
    pub fn names(&self) -> (Vec<String>, Vec<String>) {
        (
            vec![
                "delta1_rad".into(),
                "delta2_rad".into(),
                "thrust1_n".into(),
                "thrust2_n".into(),
            ],
            vec![
                "thrust1_cmd_n".into(),
                "thrust2_cmd_n".into(),
                "servo1_cmd".into(),
                "servo2_cmd".into(),
            ],
        )
    }
}
