//! Disturbances: constant or gusting torques, 1-cosine and Dryden wind, a hanging pendulum and an
//! off-centre payload.

use crate::error::{check_min, check_pos, Result, SimError};
use crate::geometry::{self, V3};
use crate::rigid::{quat, External, State, G};
use rand::rngs::SmallRng;
use rand_distr::{Distribution, StandardNormal};

/// A disturbance as written in a scenario (`kind = ...`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DisturbanceSpec {
    /// Body torque switched on at `t_on_s`.
    Torque {
        /// Torque (N·m, body axes).
        torque_n_m: V3,
        /// Switch-on time (s).
        t_on_s: f64,
    },
    /// Body torque rising as a 1-cosine from 0 to `peak_n_m` over `rise_s`, then held (a gust that
    /// settles to a constant angular acceleration, as in the SSI-PI paper's Fig. 6–8) or released.
    TorqueGust {
        /// Peak torque (N·m, body axes).
        peak_n_m: V3,
        /// Start (s).
        t_on_s: f64,
        /// Rise time (s).
        rise_s: f64,
        /// Keep the peak after the rise (true) or return to zero as a 1-cosine bump (false).
        hold: bool,
    },
    /// Discrete 1-cosine wind gust (NED, m/s), as in MIL-F-8785C: v = V/2·(1 − cos(2πτ/T)), 0 ≤ τ ≤ T.
    Gust1Cos {
        /// Peak wind velocity (NED, m/s).
        velocity_m_s: V3,
        /// Start (s).
        t_on_s: f64,
        /// Duration T (s).
        duration_s: f64,
    },
    /// Dryden-like turbulence: each NED axis a first-order Gauss–Markov process with the Dryden
    /// longitudinal spectrum σ²·2L/(πV)/(1 + (LΩ)²) (MIL-F-8785C); lateral axes use the same form.
    Dryden {
        /// Intensity σ (m/s).
        sigma_m_s: f64,
        /// Scale length L (m).
        length_m: f64,
        /// Mean airspeed V (m/s) setting the correlation time L/V.
        airspeed_m_s: f64,
    },
    /// A point mass on a massless string hanging from a body point; it swings at √(g/L) (the bicopter
    /// test: 1 m, 134 g, 0.5 Hz). The pivot is treated as inertial for the swing (vehicle mass ≫ bob),
    /// and the string tension acts on the vehicle at the attachment point.
    Pendulum {
        /// Bob mass (kg).
        mass_kg: f64,
        /// String length (m).
        length_m: f64,
        /// Attachment point (body, m).
        attach_m: V3,
        /// Initial swing angles about NED x and y (rad).
        angle0_rad: [f64; 2],
        /// Linear damping (1/s).
        damping_1_s: f64,
    },
    /// A point mass rigidly attached at a body point (the bicopter's 324 g bottle): adds mass and
    /// inertia, and its weight acts at the offset.
    Payload {
        /// Mass (kg).
        mass_kg: f64,
        /// Position (body, m).
        position_m: V3,
    },
}

impl DisturbanceSpec {
    /// Checks the numbers.
    pub fn validate(&self) -> Result<()> {
        let fin = |v: &[f64], w: &str| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(SimError::Param(format!("{w} is not finite")))
            }
        };
        match self {
            DisturbanceSpec::Torque { torque_n_m, t_on_s } => {
                fin(torque_n_m, "torque_n_m")?;
                check_min(*t_on_s, 0.0, "t_on_s")
            }
            DisturbanceSpec::TorqueGust {
                peak_n_m,
                t_on_s,
                rise_s,
                ..
            } => {
                fin(peak_n_m, "peak_n_m")?;
                check_min(*t_on_s, 0.0, "t_on_s")?;
                check_pos(*rise_s, "rise_s")
            }
            DisturbanceSpec::Gust1Cos {
                velocity_m_s,
                t_on_s,
                duration_s,
            } => {
                fin(velocity_m_s, "velocity_m_s")?;
                check_min(*t_on_s, 0.0, "t_on_s")?;
                check_pos(*duration_s, "duration_s")
            }
            DisturbanceSpec::Dryden {
                sigma_m_s,
                length_m,
                airspeed_m_s,
            } => {
                check_min(*sigma_m_s, 0.0, "sigma_m_s")?;
                check_pos(*length_m, "length_m")?;
                check_pos(*airspeed_m_s, "airspeed_m_s")
            }
            DisturbanceSpec::Pendulum {
                mass_kg,
                length_m,
                attach_m,
                angle0_rad,
                damping_1_s,
            } => {
                check_pos(*mass_kg, "pendulum mass_kg")?;
                check_pos(*length_m, "pendulum length_m")?;
                fin(attach_m, "attach_m")?;
                fin(angle0_rad, "angle0_rad")?;
                check_min(*damping_1_s, 0.0, "damping_1_s")
            }
            DisturbanceSpec::Payload { mass_kg, position_m } => {
                check_pos(*mass_kg, "payload mass_kg")?;
                fin(position_m, "position_m")
            }
        }
    }

    /// Number of extra ODE states this disturbance owns.
    pub fn n_states(&self) -> usize {
        match self {
            DisturbanceSpec::Pendulum { .. } => 4,
            _ => 0,
        }
    }
}

/// All disturbances of a run, with their state offsets and the Dryden filter state.
#[derive(Debug, Clone)]
pub struct Disturbances {
    specs: Vec<(DisturbanceSpec, usize)>,
    dryden: V3,
}

impl Disturbances {
    /// Assigns pendulum states from index `first` on; returns the set and the next free index.
    pub fn new(specs: &[DisturbanceSpec], first: usize) -> Result<(Self, usize)> {
        let mut at = first;
        let mut v = Vec::with_capacity(specs.len());
        for s in specs {
            s.validate()?;
            v.push((*s, at));
            at += s.n_states();
        }
        Ok((
            Disturbances {
                specs: v,
                dryden: [0.0; 3],
            },
            at,
        ))
    }

    /// Writes initial pendulum states into x.
    pub fn init_state(&self, x: &mut State) {
        for (s, at) in &self.specs {
            if let DisturbanceSpec::Pendulum { angle0_rad, .. } = s {
                x[*at] = angle0_rad[0];
                x[*at + 1] = angle0_rad[1];
                x[*at + 2] = 0.0;
                x[*at + 3] = 0.0;
            }
        }
    }

    /// Advances the stochastic (Dryden) state by one physics step `dt` (exact discretization).
    pub fn advance(&mut self, dt: f64, rng: &mut SmallRng) {
        for (s, _) in &self.specs {
            if let DisturbanceSpec::Dryden {
                sigma_m_s,
                length_m,
                airspeed_m_s,
            } = *s
            {
                let phi = (-airspeed_m_s * dt / length_m).exp();
                let k = sigma_m_s * (1.0 - phi * phi).sqrt();
                for i in 0..3 {
                    let n: f64 = StandardNormal.sample(rng);
                    self.dryden[i] = phi * self.dryden[i] + k * n;
                }
            }
        }
    }

    /// External forces at time t and state x; writes pendulum state derivatives into dx.
    #[inline]
    pub fn external(&self, t: f64, x: &State, dx: &mut State) -> External {
        let mut e = External::default();
        let q = quat(x);
        for &(s, at) in &self.specs {
            match s {
                DisturbanceSpec::Torque { torque_n_m, t_on_s } => {
                    if t >= t_on_s {
                        e.torque_body = geometry::add(e.torque_body, torque_n_m);
                    }
                }
                DisturbanceSpec::TorqueGust {
                    peak_n_m,
                    t_on_s,
                    rise_s,
                    hold,
                } => {
                    let tau = t - t_on_s;
                    let k = if tau < 0.0 {
                        0.0
                    } else if hold {
                        if tau >= rise_s {
                            1.0
                        } else {
                            0.5 * (1.0 - (std::f64::consts::PI * tau / rise_s).cos())
                        }
                    } else if tau <= rise_s {
                        0.5 * (1.0 - (2.0 * std::f64::consts::PI * tau / rise_s).cos())
                    } else {
                        0.0
                    };
                    e.torque_body = geometry::add(e.torque_body, geometry::scale(peak_n_m, k));
                }
                DisturbanceSpec::Gust1Cos {
                    velocity_m_s,
                    t_on_s,
                    duration_s,
                } => {
                    let tau = t - t_on_s;
                    if (0.0..=duration_s).contains(&tau) {
                        let k = 0.5 * (1.0 - (2.0 * std::f64::consts::PI * tau / duration_s).cos());
                        e.wind_world = geometry::add(e.wind_world, geometry::scale(velocity_m_s, k));
                    }
                }
                DisturbanceSpec::Dryden { .. } => {
                    e.wind_world = geometry::add(e.wind_world, self.dryden);
                }
                DisturbanceSpec::Pendulum {
                    mass_kg,
                    length_m,
                    attach_m,
                    damping_1_s,
                    ..
                } => {
                    let (a, b, ad, bd) = (x[at], x[at + 1], x[at + 2], x[at + 3]);
                    dx[at] = ad;
                    dx[at + 1] = bd;
                    dx[at + 2] = -(G / length_m) * a.sin() - damping_1_s * ad;
                    dx[at + 3] = -(G / length_m) * b.sin() - damping_1_s * bd;
                    let (sa, sb) = (a.sin(), b.sin());
                    let dir = [sb, -sa, (1.0 - sa * sa - sb * sb).max(0.0).sqrt()];
                    let tension = mass_kg * (G * dir[2] + length_m * (ad * ad + bd * bd));
                    let f = geometry::scale(dir, tension);
                    e.force_world = geometry::add(e.force_world, f);
                    let fb = geometry::rotate_inv(q, f);
                    e.torque_body = geometry::add(e.torque_body, geometry::cross(attach_m, fb));
                }
                DisturbanceSpec::Payload { mass_kg, position_m } => {
                    let w = geometry::rotate_inv(q, [0.0, 0.0, mass_kg * G]);
                    e.torque_body = geometry::add(e.torque_body, geometry::cross(position_m, w));
                }
            }
        }
        e
    }
}
