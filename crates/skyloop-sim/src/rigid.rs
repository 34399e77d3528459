//! Rigid-body 6-DOF (Newton–Euler) and the state layout all vehicles share.
//!
//! State: NED position (m), NED velocity (m/s), attitude quaternion body→NED, body rates (rad/s; the
//! bicopter stores its roll angular momentum there instead, see `vehicle::bicopter`), then vehicle
//! actuator states, then disturbance states (pendulum).

use crate::geometry::{self, Quat, V3};

/// Capacity of the state vector.
pub const MAXS: usize = 32;
/// Capacity of the actuator-command vector.
pub const MAXU: usize = 6;
/// Full state vector (first `n` entries used).
pub type State = [f64; MAXS];
/// Actuator commands (first `nu` entries used).
pub type Input = [f64; MAXU];

/// Index of NED position x, y, z (m).
pub const POS: usize = 0;
/// Index of NED velocity (m/s).
pub const VEL: usize = 3;
/// Index of the quaternion w, x, y, z.
pub const QUAT: usize = 6;
/// Index of body rates p, q, r (rad/s).
pub const RATE: usize = 10;
/// First vehicle-specific state.
pub const AUX: usize = 13;

/// Standard gravity (m/s²).
pub const G: f64 = 9.80665;

/// Forces and torques from the environment, evaluated before each derivative call.
#[derive(Debug, Clone, Copy, Default)]
pub struct External {
    /// Extra force in NED (N), e.g. a pendulum's string tension.
    pub force_world: V3,
    /// Extra torque about the reference point in body axes (N·m).
    pub torque_body: V3,
    /// Wind velocity in NED (m/s); drag acts on the air-relative velocity.
    pub wind_world: V3,
}

/// Position, velocity, quaternion and body-rate slots of a state.
#[inline]
pub fn quat(x: &State) -> Quat {
    [x[QUAT], x[QUAT + 1], x[QUAT + 2], x[QUAT + 3]]
}

/// Body-frame air-relative velocity (m/s).
#[inline]
pub fn air_velocity_body(x: &State, wind_world: V3) -> V3 {
    let v = [
        x[VEL] - wind_world[0],
        x[VEL + 1] - wind_world[1],
        x[VEL + 2] - wind_world[2],
    ];
    geometry::rotate_inv(quat(x), v)
}

/// Writes translational and attitude derivatives, and body-rate derivatives by Euler's equation
/// J·ω̇ = M − ω × J·ω (diagonal J), given body force/torque and the true body rates `w`.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn rigid_derivative(mass: f64, j: V3, x: &State, w: V3, f_body: V3, m_body: V3, ext: &External, dx: &mut State) {
    let q = quat(x);
    let f_world = geometry::add(geometry::rotate(q, f_body), ext.force_world);
    dx[POS] = x[VEL];
    dx[POS + 1] = x[VEL + 1];
    dx[POS + 2] = x[VEL + 2];
    dx[VEL] = f_world[0] / mass;
    dx[VEL + 1] = f_world[1] / mass;
    dx[VEL + 2] = f_world[2] / mass + G;
    let qd = geometry::qdot(q, w);
    dx[QUAT..QUAT + 4].copy_from_slice(&qd);
    let jw = [j[0] * w[0], j[1] * w[1], j[2] * w[2]];
    let gyro = geometry::cross(w, jw);
    for i in 0..3 {
        dx[RATE + i] = (m_body[i] + ext.torque_body[i] - gyro[i]) / j[i];
    }
}

/// Rigid-body parameters shared by every vehicle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// Total mass (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia Jx, Jy, Jz (kg·m²).
    pub inertia_kg_m2: V3,
    /// Linear drag coefficient b_w of eq. (15) of the SSI-PI paper, on body x and y (N·s/m).
    #[serde(default)]
    pub drag_n_s_m: f64,
}

impl Body {
    /// Adds a point mass m at body position r (m): mass and the diagonal of m(|r|²I − r rᵀ).
    pub fn add_point_mass(&mut self, m: f64, r: V3) {
        let r2 = geometry::dot(r, r);
        self.mass_kg += m;
        for i in 0..3 {
            self.inertia_kg_m2[i] += m * (r2 - r[i] * r[i]);
        }
    }

    /// Checks positivity of mass and inertia.
    pub fn validate(&self) -> crate::error::Result<()> {
        crate::error::check_pos(self.mass_kg, "mass_kg")?;
        for (i, n) in ["inertia_kg_m2[0]", "inertia_kg_m2[1]", "inertia_kg_m2[2]"]
            .iter()
            .enumerate()
        {
            crate::error::check_pos(self.inertia_kg_m2[i], n)?;
        }
        crate::error::check_min(self.drag_n_s_m, 0.0, "drag_n_s_m")
    }

    /// Drag force of eq. (15) in body axes (N) for body air velocity `v`.
    #[inline]
    pub fn drag(&self, v: V3) -> V3 {
        [-self.drag_n_s_m * v[0], -self.drag_n_s_m * v[1], 0.0]
    }
}
