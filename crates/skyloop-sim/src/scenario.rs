//! Scenario files (TOML): vehicle, simulation settings, controller, gyro, reference steps, disturbances
//! and an optional Monte Carlo section. See `examples/*.toml` for commented files.

use crate::cascade::{ControllerSpec, Mode};
use crate::disturbance::DisturbanceSpec;
use crate::error::{check_pos, Result, SimError};
use crate::geometry::V3;
use crate::sensors::GyroSpec;
use crate::vehicle::VehicleSpec;

/// Most physics steps one run may take (sim.duration_s × sim.physics_hz): a step costs 1–3 µs,
/// so the bound is about 10 minutes of CPU.
pub const MAX_STEPS: f64 = 2e8;

/// Most trace samples one run may log (sim.duration_s × sim.log_hz): about 500 MB in memory.
pub const MAX_TRACE_SAMPLES: f64 = 2e6;

/// A vehicle given by preset name (with optional overrides of the rigid body) or in full.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum VehicleEntry {
    /// `preset = "quadrotor-ssi"` (see `presets::NAMES`).
    Preset {
        /// Preset name.
        preset: String,
        /// Replaces the preset's mass (kg).
        #[serde(default)]
        mass_kg: Option<f64>,
        /// Replaces the preset's inertia (kg·m²).
        #[serde(default)]
        inertia_kg_m2: Option<V3>,
    },
    /// All parameters, with `kind`.
    Full(VehicleSpec),
}

impl VehicleEntry {
    /// The parameters this entry names.
    pub fn resolve(&self) -> Result<VehicleSpec> {
        match self {
            VehicleEntry::Preset {
                preset,
                mass_kg,
                inertia_kg_m2,
            } => {
                let mut v = crate::presets::vehicle(preset)?;
                if let Some(m) = mass_kg {
                    v.body_mut().mass_kg = *m;
                }
                if let Some(j) = inertia_kg_m2 {
                    v.body_mut().inertia_kg_m2 = *j;
                    if let VehicleSpec::Bicopter(b) = &mut v {
                        // keep the identified ratio Im/(Ib + Im)
                        let r = b.im_kg_m2 / b.jx();
                        b.im_kg_m2 = r * j[0];
                        b.ib_kg_m2 = (1.0 - r) * j[0];
                    }
                }
                Ok(v)
            }
            VehicleEntry::Full(v) => Ok(*v),
        }
    }
}

/// Simulation settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimSpec {
    /// Simulated time (s).
    pub duration_s: f64,
    /// RK4 step frequency (Hz); controller rates must divide it.
    pub physics_hz: f64,
    /// Initial hover altitude (m).
    #[serde(default = "alt")]
    pub altitude_m: f64,
    /// Logging frequency (Hz); 0 = every rate-loop sample.
    #[serde(default)]
    pub log_hz: f64,
    /// Roll or pitch beyond this counts as a crash (rad).
    #[serde(default = "crash_tilt")]
    pub crash_tilt_rad: f64,
    /// Settling band (absolute, in the tracked unit); the band is max(this, 2 % of the last step).
    #[serde(default = "settle")]
    pub settle_band: f64,
    /// Actuator slew-rate limits (input units per s), one per input; empty = none.
    #[serde(default)]
    pub actuator_rate_limit: Vec<f64>,
    /// Random seed (gyro noise, turbulence).
    #[serde(default)]
    pub seed: u64,
}

fn alt() -> f64 {
    10.0
}
fn crash_tilt() -> f64 {
    1.4
}
fn settle() -> f64 {
    0.01
}

/// One reference step: from `t_s` on the setpoint is the entry matching the controller mode.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefStep {
    /// Time (s).
    pub t_s: f64,
    /// Roll, pitch, yaw (rad), attitude mode.
    #[serde(default)]
    pub attitude_rad: Option<V3>,
    /// NED position relative to the start (m), position mode.
    #[serde(default)]
    pub position_m: Option<V3>,
    /// Body rates (rad/s), rate mode.
    #[serde(default)]
    pub rate_rad_s: Option<V3>,
}

impl RefStep {
    /// The value for `mode`.
    pub fn value(&self, mode: Mode) -> Result<V3> {
        let (v, name) = match mode {
            Mode::Attitude => (self.attitude_rad, "attitude_rad"),
            Mode::Position => (self.position_m, "position_m"),
            Mode::Rate => (self.rate_rad_s, "rate_rad_s"),
        };
        let v = v.ok_or_else(|| SimError::Scenario(format!("reference at t_s = {} needs {name}", self.t_s)))?;
        if v.iter().all(|x| x.is_finite()) && self.t_s.is_finite() {
            Ok(v)
        } else {
            Err(SimError::Scenario(format!(
                "reference at t_s = {} is not finite",
                self.t_s
            )))
        }
    }
}

/// A whole scenario file.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Free-text title.
    #[serde(default)]
    pub name: String,
    /// The vehicle.
    pub vehicle: VehicleEntry,
    /// Simulation settings.
    pub sim: SimSpec,
    /// The flight controller.
    pub controller: ControllerSpec,
    /// Gyro model.
    #[serde(default)]
    pub gyro: GyroSpec,
    /// Reference steps (sorted by time).
    #[serde(default)]
    pub reference: Vec<RefStep>,
    /// Disturbances.
    #[serde(default)]
    pub disturbance: Vec<DisturbanceSpec>,
    /// Monte Carlo settings (used by `montecarlo::run`).
    #[serde(default)]
    pub monte_carlo: Option<MonteCarloSpec>,
}

impl Scenario {
    /// Parses TOML text.
    pub fn from_toml(text: &str) -> Result<Self> {
        let s: Scenario = toml::from_str(text).map_err(|e| SimError::Scenario(e.to_string()))?;
        s.validate()?;
        Ok(s)
    }

    /// Checks what can be checked without building.
    pub fn validate(&self) -> Result<()> {
        let tree = toml::Value::try_from(self).map_err(|e| SimError::Scenario(e.to_string()))?;
        check_numbers(&tree, "")?;
        check_pos(self.sim.duration_s, "sim.duration_s")?;
        check_pos(self.sim.physics_hz, "sim.physics_hz")?;
        let steps = self.sim.duration_s * self.sim.physics_hz;
        if steps > MAX_STEPS {
            return Err(SimError::Param(format!(
                "sim.duration_s × sim.physics_hz = {steps:.3e} physics steps exceeds {MAX_STEPS:.0e} \
                 (about 10 minutes at a few µs per step): shorten sim.duration_s or lower sim.physics_hz"
            )));
        }
        // The trace is kept in memory (≈ 250 bytes a sample) and written as CSV and a plot.
        let log_hz = if self.sim.log_hz > 0.0 {
            self.sim.log_hz
        } else {
            self.controller.rate_hz
        };
        let samples = self.sim.duration_s * log_hz;
        if samples > MAX_TRACE_SAMPLES {
            return Err(SimError::Param(format!(
                "sim.duration_s × sim.log_hz = {samples:.3e} trace samples exceeds {MAX_TRACE_SAMPLES:.0e} \
                 (≈ 250 bytes each in memory, more as CSV): lower sim.log_hz (it defaults to the controller's rate_hz)"
            )));
        }
        for r in &self.reference {
            r.value(self.controller.mode)?;
        }
        if self.reference.windows(2).any(|w| w[1].t_s < w[0].t_s) {
            return Err(SimError::Scenario("reference steps must be sorted by t_s".into()));
        }
        if let Some(mc) = &self.monte_carlo {
            mc.validate()?;
        }
        Ok(())
    }
}

/// Every number of a scenario must be finite, and every limit (a key with `max` in its name: rate,
/// torque, tilt, thrust, deflection limits) ≥ 0: a NaN or a negative limit would otherwise reach
/// `f64::clamp` deep in a run and abort it, or silently disable the limit.
fn check_numbers(v: &toml::Value, path: &str) -> Result<()> {
    let is_limit = path.rsplit('.').next().is_some_and(|k| k.contains("max"));
    match v {
        toml::Value::Float(x) => {
            if !x.is_finite() {
                return Err(SimError::Param(format!("{path} = {x} (must be finite)")));
            }
            if is_limit && *x < 0.0 {
                return Err(SimError::Param(format!("{path} = {x} (a limit must be ≥ 0)")));
            }
        }
        toml::Value::Integer(x) if is_limit && *x < 0 => {
            return Err(SimError::Param(format!("{path} = {x} (a limit must be ≥ 0)")));
        }
        toml::Value::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                // Elements of a limit array are limits too: keep the key's name last.
                let p = if matches!(item, toml::Value::Table(_)) {
                    format!("{path}[{i}]")
                } else {
                    path.to_string()
                };
                check_numbers(item, &p)?;
            }
        }
        toml::Value::Table(t) => {
            for (k, item) in t {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                check_numbers(item, &p)?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// Monte Carlo settings as written in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloSpec {
    /// Number of runs.
    pub runs: usize,
    /// Base seed; run i uses seed + i.
    #[serde(default)]
    pub seed: u64,
    /// Relative standard deviation of the mass.
    #[serde(default)]
    pub mass_sd: f64,
    /// Relative standard deviation of each principal inertia.
    #[serde(default)]
    pub inertia_sd: f64,
    /// Relative standard deviation of disturbance magnitudes.
    #[serde(default)]
    pub disturbance_sd: f64,
}

impl MonteCarloSpec {
    /// Checks the study's size and spreads. Called when a scenario is parsed, so no path (a
    /// CSV/Parquet output that lists the run indices first, Python, the browser) sees an unbounded
    /// `runs`: an index list of 10¹² runs is 8 TB, and the allocation aborts the process.
    ///
    /// # Errors
    /// `runs` outside 1..=[`MAX_RUNS`](crate::montecarlo::MAX_RUNS), or a spread out of range.
    pub fn validate(&self) -> Result<()> {
        let max = crate::montecarlo::MAX_RUNS;
        if self.runs == 0 || self.runs > max {
            return Err(SimError::Param(format!(
                "monte_carlo.runs = {} must be in 1..={max} (split a larger campaign with --seeds A..B)",
                self.runs
            )));
        }
        self.validate_spreads()
    }

    /// Checks the spreads alone (a `--seeds A..B` campaign does not use `runs`).
    ///
    /// # Errors
    /// A relative spread outside 0..=1 or a negative disturbance standard deviation.
    pub fn validate_spreads(&self) -> Result<()> {
        // A relative standard deviation above 1 samples masses and inertias mostly at the clamp
        // (0.2 of nominal) or many times nominal: not a study of one craft.
        crate::error::check_range(self.mass_sd, 0.0, 1.0, "monte_carlo.mass_sd (relative)")?;
        crate::error::check_range(self.inertia_sd, 0.0, 1.0, "monte_carlo.inertia_sd (relative)")?;
        crate::error::check_min(self.disturbance_sd, 0.0, "monte_carlo.disturbance_sd")
    }
}

#[cfg(test)]
mod number_tests {
    use super::*;

    #[test]
    fn nan_and_negative_limits_are_named() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/bicopter-hinf.toml"
        ))
        .expect("example");
        Scenario::from_toml(&text).expect("the example is valid");
        let bad = text.replacen("max_rate_rad_s = 4.0", "max_rate_rad_s = -4.0", 1);
        assert_ne!(bad, text);
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("controller.max_rate_rad_s") && e.contains("≥ 0"), "{e}");
        let bad = text.replacen("duration_s = 8.0", "duration_s = nan", 1);
        assert_ne!(bad, text);
        let e = Scenario::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("sim.duration_s") && e.contains("finite"), "{e}");
    }

    /// Runs whose steps or trace would take more than ~10 minutes or ~500 MB are refused up front
    /// with the keys named; a long legal run reports its progress to the end.
    #[test]
    fn long_runs_are_bounded_and_report_progress() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/bicopter-hinf.toml"
        ))
        .expect("example");
        let e = Scenario::from_toml(&text.replacen("duration_s = 8.0", "duration_s = 360000.0", 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("sim.physics_hz") && e.contains("2e8"), "{e}");
        let e = Scenario::from_toml(&text.replacen("duration_s = 8.0", "duration_s = 36000.0", 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("sim.log_hz") && e.contains("2e6"), "{e}");
        let scn = Scenario::from_toml(&text.replacen("duration_s = 8.0", "duration_s = 200.0", 1)).expect("valid");
        let mut calls = Vec::new();
        crate::simulate_with_progress(&scn, &mut |d, t| calls.push((d, t))).expect("runs");
        let total = (200.0 * scn.sim.physics_hz) as u64;
        assert!(calls.len() >= 3, "{calls:?}");
        assert_eq!(calls.last(), Some(&(total, total)));
        assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0));
    }
}
