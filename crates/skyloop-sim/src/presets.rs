//! Named parameter sets for the three papers' vehicles, with where each number comes from.

use crate::error::{Result, SimError};
use crate::rigid::Body;
use crate::vehicle::{BicopterParams, DuctedFanParams, QuadParams, VehicleSpec};

/// Known preset names.
pub const NAMES: [&str; 3] = ["quadrotor-ssi", "bicopter-li", "ducted-fan-pross"];

/// The parameter set called `name`.
pub fn vehicle(name: &str) -> Result<VehicleSpec> {
    match name {
        "quadrotor-ssi" => Ok(VehicleSpec::Quadrotor(quadrotor_ssi())),
        "bicopter-li" => Ok(VehicleSpec::Bicopter(bicopter_li())),
        "ducted-fan-pross" => Ok(VehicleSpec::DuctedFan(ducted_fan_pross())),
        _ => Err(SimError::Param(format!(
            "unknown vehicle preset '{name}' (known: {})",
            NAMES.join(", ")
        ))),
    }
}

/// Quadrotor of the SSI-PI paper. The paper takes T-Lion's parameters from its ref. \[19\] but prints
/// none, so these are ASSUMED values of a 1 kg, 0.4 m X-quadrotor: J within the 1e-3…1e-6·(10) kg·m²
/// range the paper quotes for small UAVs (Sec. IV-A), thrust-to-weight ≈ 3.6 (racing class, Sec. I).
pub fn quadrotor_ssi() -> QuadParams {
    QuadParams {
        body: Body {
            mass_kg: 1.0,
            inertia_kg_m2: [0.010, 0.010, 0.018],
            drag_n_s_m: 0.1,
        },
        arm_m: 0.2,
        kt: 1.2e-5,
        kq: 2.0e-7,
        km_rad_s: 900.0,
        delta_star: 0.05,
        tau_m_s: 0.02,
    }
}

/// Bicopter of Li et al. Fixed by the identified model eq. (8): zero √(GH/Im) = 42 rad/s, gain
/// A·Im/(Ib + Im) = 0.0887 with the servo gain A = 0.764 of eq. (6) ⇒ Im/(Ib + Im) = 0.1161; servo
/// time constant 0.0256 s and delay 0.032 s as identified in flight (eq. (8)). ASSUMED: mass 1.5 kg
/// (the paper: "up to 1.8 kg"), Ib + Im = 0.012 kg·m² (then H = 42²·Im/G = 0.167 m), arm, Jy, Jz.
pub fn bicopter_li() -> BicopterParams {
    let mass = 1.5;
    let jx = 0.012;
    let im = jx * 0.0887 / 0.764;
    let h = 42.0 * 42.0 * im / (mass * crate::rigid::G);
    BicopterParams {
        body: Body {
            mass_kg: mass,
            inertia_kg_m2: [jx, 0.020, 0.025],
            drag_n_s_m: 0.1,
        },
        ib_kg_m2: jx - im,
        im_kg_m2: im,
        h_m: h,
        arm_m: 0.17,
        servo_gain: 0.764,
        servo_tau_s: 0.0256,
        servo_delay_s: 0.032,
        servo_max: 0.6,
        motor_tau_s: 0.02,
        thrust_max_n: 15.0,
    }
}

/// Ducted fan of Pross. The paper prints the model (eq. (3)–(4)) but not its parameter values
/// (credited to T. Rothlin), so all numbers here are ASSUMED for a 0.8 kg ducted fan: hover propeller
/// speed ≈ 1500 rad/s, duct constant a = 0.08 m (so the yaw lever a/3 is 2.7 cm; eq. (3) then gives a
/// duct velocity ≈ 2 m/s), flap area 0.01 m², thin-airfoil-like lift slope cℓ = 3 /rad.
pub fn ducted_fan_pross() -> DuctedFanParams {
    DuctedFanParams {
        body: Body {
            mass_kg: 0.8,
            inertia_kg_m2: [0.010, 0.010, 0.006],
            drag_n_s_m: 0.0,
        },
        kt: 3.5e-6,
        a_m: 0.08,
        s_m2: 0.01,
        rho_kg_m3: 1.225,
        cl: 3.0,
        cd: 0.5,
        c0: 0.05,
        d_m: 0.15,
        jr_kg_m2: 5e-5,
        flap_wn_rad_s: 40.0,
        prop_tau_s: 0.05,
        flap_max_rad: 0.35,
        omega_max_rad_s: 2500.0,
    }
}

/// Unused-field guard so presets stay in sync with `VehicleSpec::body_mut`.
#[cfg(test)]
mod tests {
    #[test]
    fn presets_validate() {
        for n in super::NAMES {
            super::vehicle(n).expect("preset").build().expect("valid");
        }
        assert!(super::vehicle("nope").is_err());
    }
}
