//! The vehicles, behind one enum so the step loop dispatches without allocation or dynamic calls.

pub mod bicopter;
pub mod ducted_fan;
pub mod quadrotor;

pub use bicopter::{Bicopter, BicopterParams};
pub use ducted_fan::{DuctedFan, DuctedFanParams};
pub use quadrotor::{QuadParams, Quadrotor};

use crate::error::Result;
use crate::geometry::V3;
use crate::rigid::{Body, External, Input, State, RATE};

/// Vehicle parameters as written in a scenario file (`kind = "quadrotor" | "bicopter" | "ducted_fan"`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum VehicleSpec {
    /// The SSI-PI paper's quadrotor.
    Quadrotor(QuadParams),
    /// The bicopter paper's tilt-rotor bicopter.
    Bicopter(BicopterParams),
    /// The ducted-fan paper's VTOL.
    DuctedFan(DuctedFanParams),
}

/// A vehicle model.
#[derive(Debug, Clone)]
pub enum Vehicle {
    /// Quadrotor.
    Quadrotor(Quadrotor),
    /// Bicopter.
    Bicopter(Bicopter),
    /// Ducted fan.
    DuctedFan(DuctedFan),
}

impl VehicleSpec {
    /// Checks the parameters and builds the model.
    pub fn build(&self) -> Result<Vehicle> {
        Ok(match *self {
            VehicleSpec::Quadrotor(p) => {
                p.validate()?;
                Vehicle::Quadrotor(Quadrotor { p })
            }
            VehicleSpec::Bicopter(p) => {
                p.validate()?;
                Vehicle::Bicopter(Bicopter { p })
            }
            VehicleSpec::DuctedFan(p) => {
                p.validate()?;
                Vehicle::DuctedFan(DuctedFan { p })
            }
        })
    }

    /// The rigid body part (mutable, for payloads and Monte Carlo perturbations).
    pub fn body_mut(&mut self) -> &mut Body {
        match self {
            VehicleSpec::Quadrotor(p) => &mut p.body,
            VehicleSpec::Bicopter(p) => &mut p.body,
            VehicleSpec::DuctedFan(p) => &mut p.body,
        }
    }

    /// Adds a point mass `m_kg` rigidly at body point `r_m` (a payload): mass and inertia about the
    /// centre of mass (the centre itself is not moved). The bicopter's roll inertia is Ib + Im,
    /// not `body.inertia_kg_m2[0]`, so its Ib takes the payload's m·(y² + z²) as well.
    pub fn add_point_mass(&mut self, m_kg: f64, r_m: V3) {
        self.body_mut().add_point_mass(m_kg, r_m);
        if let VehicleSpec::Bicopter(p) = self {
            p.ib_kg_m2 += m_kg * (r_m[1] * r_m[1] + r_m[2] * r_m[2]);
        }
    }
}

impl Vehicle {
    /// Number of vehicle states (rigid body + actuators).
    pub fn nx(&self) -> usize {
        match self {
            Vehicle::Quadrotor(_) => Quadrotor::NX,
            Vehicle::Bicopter(_) => Bicopter::NX,
            Vehicle::DuctedFan(_) => DuctedFan::NX,
        }
    }

    /// Number of actuator inputs.
    pub fn nu(&self) -> usize {
        match self {
            Vehicle::Quadrotor(_) => Quadrotor::NU,
            Vehicle::Bicopter(_) => Bicopter::NU,
            Vehicle::DuctedFan(_) => DuctedFan::NU,
        }
    }

    /// Rigid-body parameters.
    pub fn body(&self) -> &Body {
        match self {
            Vehicle::Quadrotor(v) => &v.p.body,
            Vehicle::Bicopter(v) => &v.p.body,
            Vehicle::DuctedFan(v) => &v.p.body,
        }
    }

    /// Principal inertias the controllers should assume (kg·m²).
    pub fn inertia(&self) -> V3 {
        match self {
            Vehicle::Bicopter(v) => [v.p.jx(), v.p.body.inertia_kg_m2[1], v.p.body.inertia_kg_m2[2]],
            _ => self.body().inertia_kg_m2,
        }
    }

    /// State derivative ẋ = f(x, u) (first `nx` entries written).
    #[inline]
    pub fn derivative(&self, x: &State, u: &Input, ext: &External, dx: &mut State) {
        match self {
            Vehicle::Quadrotor(v) => v.derivative(x, u, ext, dx),
            Vehicle::Bicopter(v) => v.derivative(x, u, ext, dx),
            Vehicle::DuctedFan(v) => v.derivative(x, u, ext, dx),
        }
    }

    /// True body rates p, q, r (rad/s).
    #[inline]
    pub fn rates(&self, x: &State, u: &Input) -> V3 {
        match self {
            Vehicle::Bicopter(v) => v.rates(x, u),
            _ => [x[RATE], x[RATE + 1], x[RATE + 2]],
        }
    }

    /// Actuator commands for total thrust (N, upward) and body torque (N·m); true if any saturated.
    pub fn allocate(&self, x: &State, thrust_n: f64, torque: V3, u: &mut Input) -> bool {
        match self {
            Vehicle::Quadrotor(v) => v.allocate(thrust_n, torque, u),
            Vehicle::Bicopter(v) => v.allocate(thrust_n, torque, u),
            Vehicle::DuctedFan(v) => v.allocate(x[crate::rigid::AUX + 8], thrust_n, torque, u),
        }
    }

    /// Lower and upper actuator limits (first `nu` entries).
    pub fn input_limits(&self) -> (Input, Input) {
        let mut lo = [0.0; crate::rigid::MAXU];
        let mut hi = [0.0; crate::rigid::MAXU];
        match self {
            Vehicle::Quadrotor(v) => {
                let (a, b) = v.input_limits();
                lo[..4].copy_from_slice(&a);
                hi[..4].copy_from_slice(&b);
            }
            Vehicle::Bicopter(v) => {
                let (a, b) = v.input_limits();
                lo[..4].copy_from_slice(&a);
                hi[..4].copy_from_slice(&b);
            }
            Vehicle::DuctedFan(v) => {
                let (a, b) = v.input_limits();
                lo[..5].copy_from_slice(&a);
                hi[..5].copy_from_slice(&b);
            }
        }
        (lo, hi)
    }

    /// Pure input delays (s), one per input.
    pub fn input_delays(&self) -> Vec<f64> {
        match self {
            Vehicle::Bicopter(v) => v.input_delays().to_vec(),
            _ => vec![0.0; self.nu()],
        }
    }

    /// Hover trim at NED altitude `-altitude_m` and yaw `yaw_rad`: state and inputs with ẋ = 0.
    pub fn trim_hover(&self, altitude_m: f64, yaw_rad: f64) -> (State, Input) {
        let mut x = [0.0; crate::rigid::MAXS];
        let mut u = [0.0; crate::rigid::MAXU];
        x[2] = -altitude_m;
        let q = crate::geometry::from_euler(0.0, 0.0, yaw_rad);
        x[crate::rigid::QUAT..crate::rigid::QUAT + 4].copy_from_slice(&q);
        match self {
            Vehicle::Quadrotor(v) => v.trim(&mut x, &mut u),
            Vehicle::Bicopter(v) => v.trim(&mut x, &mut u),
            Vehicle::DuctedFan(v) => v.trim(&mut x, &mut u),
        }
        (x, u)
    }

    /// Names of the vehicle-specific states and of the inputs.
    pub fn names(&self) -> (Vec<String>, Vec<String>) {
        match self {
            Vehicle::Quadrotor(v) => v.names(),
            Vehicle::Bicopter(v) => v.names(),
            Vehicle::DuctedFan(v) => v.names(),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_payload_adds_roll_inertia_to_the_bicopter_too() {
        // The 324 g bottle 0.15 m to the side: m·y² on roll for every vehicle kind.
        for mut spec in [
            VehicleSpec::Bicopter(crate::presets::bicopter_li()),
            VehicleSpec::Quadrotor(crate::presets::quadrotor_ssi()),
        ] {
            let before = spec.build().unwrap().inertia();
            spec.add_point_mass(0.324, [0.0, 0.15, 0.0]);
            let after = spec.build().unwrap().inertia();
            let want = 0.324 * 0.15 * 0.15;
            assert!((after[0] - before[0] - want).abs() < 1e-12, "{before:?} → {after:?}");
            assert!((after[2] - before[2] - want).abs() < 1e-12);
            assert!((after[1] - before[1]).abs() < 1e-12);
        }
    }
}
