//! The generalized plant of Pross, Fig. 2–3 and eq. (8)–(10): the hover linearization at yaw 45°
//! split into actuators G_a and rigid body G_lin, input filters F_u, reference filters F_r, the
//! 3rd-order Padé measurement delay G_m, performance weights, and the uncertainty channels of the
//! structure (7): Δ_α (4×4, flap aerodynamics), δ_ω (propeller aerodynamics), Δ_x (9×9, linearization
//! error on the velocity, attitude and rate equations).
//!
//! Channel order (MATLAB/hinfsyn convention, controls and measurements last):
//! inputs  [v_α (4), v_ω (1), v_x (9) | d (5), r (3), n (12) | u (5)],
//! outputs [z_α (4), z_ω (1), z_x (9) | e_u (5), e_P (3), e_v (3), e_Θ (3), e_Ω (3) | y_m (12)]
//! (e_x = [r − y; Ṗ; Θ; Ω] as in the caption of Fig. 2).
//! u is normalized to (−1, 1) (Section II-C): flap angle / α_max, propeller speed deviation / ω_scale.
//! The nominal plant G_nom of eq. (11) drops the uncertainty channels.
//!
//! The paper's w = [w_α; r] has a disturbance w_α besides the reference. We take it as an input
//! disturbance d on all five normalized commands (the propeller too, else the vertical and yaw
//! integrators would not be excited by any w, and the H∞ problem would be singular), and add
//! measurement noise n on every measurement so that D21 has full row rank (the Riccati solution needs
//! it); both are standard regularity terms the paper leaves implicit.

use crate::error::Result;
use faer::Mat;
use skyloop_lti::interconnect::{append, lft_lower};
use skyloop_lti::StateSpace;
use skyloop_robust::uncertainty::weights::makeweight_mag;
use skyloop_sim::linear_models::actuator_split;
use skyloop_sim::linearize::linearize;
use skyloop_sim::vehicle::{DuctedFanParams, Vehicle, VehicleSpec};

/// Design parameters: the paper's printed values and, where it prints none, ASSUMED ones.
#[derive(Debug, Clone, Copy)]
pub struct Design {
    /// Flap input-filter time constant T_α of eq. (9a) (s); paper: ≈ 0.13 s.
    pub t_alpha_s: f64,
    /// Propeller input-filter time constant T_ω of eq. (9a) (s); paper: ≈ 0.1 s.
    pub t_omega_s: f64,
    /// Reference-filter time constant T_xy = T_z of eq. (9b) (s); paper: ≈ 6 s.
    pub t_ref_s: f64,
    /// Measurement delay T_m (s). ASSUMED: 10 ms, one sample of a 100 Hz IMU sensor-fusion output.
    pub t_m_s: f64,
    /// Padé order of the delay; paper: 3.
    pub pade_order: usize,
    /// Hover yaw (rad); paper: 45°.
    pub yaw_rad: f64,
    /// Percentage errors ε_S, ε_d, ε_ℓ, ε_T, ε_r of eq. (10). ASSUMED: 5 %, 10 %, 10 %, 10 %, 5 %.
    pub eps: [f64; 5],
    /// Linearization-error weight: high-frequency level (paper: "below 20 %") and DC level
    /// ("decreasing but not vanishing at lower frequencies"; ASSUMED 5 %) and its midpoint frequency
    /// (ASSUMED 2 rad/s, between the position and attitude bandwidths).
    pub lin_err: (f64, f64, f64),
    /// Propeller-speed normalization ω_scale (rad/s): ASSUMED ω_max − ω_0 (the headroom above hover).
    pub omega_scale_rad_s: f64,
    /// Performance weights (Fig. 4a, not printed; ASSUMED): position error DC gain, crossover (rad/s)
    /// and high-frequency gain, per axis group xy and z.
    pub w_pos: [(f64, f64, f64); 2],
    /// Velocity weights xy, z (static; ASSUMED).
    pub w_vel: [f64; 2],
    /// Euler-angle weights ϕϑ, ψ (static; ASSUMED).
    pub w_att: [f64; 2],
    /// Body-rate weights pq, r (static; ASSUMED). Without them the gyroscopic nutation mode
    /// (Jr·ω0/J ≈ 7.5 rad/s) stays almost undamped: it hardly shows in the angles.
    pub w_rate: [f64; 2],
    /// Common factor on all performance outputs e (ASSUMED): chosen so that γ of the H∞ design is
    /// ≈ 0.6 as printed in Section III-C; scaling e uniformly leaves the H∞ controller unchanged and
    /// sets how much robust performance asks beside robust stability.
    pub perf_scale: f64,
    /// Actuator weights flaps, propeller on the normalized commands (static; ASSUMED).
    pub w_u: [f64; 2],
    /// Input-disturbance levels on the normalized flap and propeller commands (ASSUMED).
    pub w_dist: [f64; 2],
    /// Measurement-noise levels: position (m), velocity (m/s), angle (rad), rate (rad/s) (ASSUMED).
    pub noise: [f64; 4],
}

impl Default for Design {
    fn default() -> Self {
        Design {
            t_alpha_s: 0.13,
            t_omega_s: 0.1,
            t_ref_s: 6.0,
            t_m_s: 0.01,
            pade_order: 3,
            yaw_rad: std::f64::consts::FRAC_PI_4,
            eps: [0.05, 0.10, 0.10, 0.10, 0.05],
            lin_err: (0.2, 0.05, 2.0),
            omega_scale_rad_s: 0.0,
            w_pos: [(50.0, 0.3, 0.2), (50.0, 0.3, 0.2)],
            w_vel: [0.5, 0.5],
            w_att: [0.5, 0.2],
            w_rate: [2.0, 0.5],
            perf_scale: 5.5,
            w_u: [0.5, 0.5],
            w_dist: [0.1, 0.1],
            noise: [0.001, 0.02, 0.005, 0.01],
        }
    }
}

impl Design {
    /// Equivalent input errors of eq. (10): (ε_α, ε_ω).
    pub fn input_errors(&self) -> (f64, f64) {
        let [es, ed, el, et, er] = self.eps;
        let ew = (et / 2.0).max(er);
        let ea = (el + es + 2.0 * ew).max(es + ed + ew);
        (ea, ew)
    }
}

/// The assembled plants and what the reproduction needs to run the controllers.
#[derive(Debug, Clone)]
pub struct Plants {
    /// Full generalized plant G of eq. (8) (uncertainty, performance and control channels).
    pub g: StateSpace,
    /// Nominal plant G_nom of eq. (11).
    pub g_nom: StateSpace,
    /// G with the positions P (m, from hover) as three more outputs after e and before y_m, for
    /// time responses of the linear loop (not used in synthesis).
    pub g_pos: StateSpace,
    /// Number of uncertainty channels (14 = 4 + 1 + 9).
    pub n_unc: usize,
    /// Exogenous inputs w and performance outputs e.
    pub n_w: usize,
    /// Performance outputs.
    pub n_e: usize,
    /// Physical units per normalized command: α_max (rad) ×4, ω_scale (rad/s).
    pub u_scale: [f64; 5],
    /// Reference filter F_r (3 inputs, 3 outputs).
    pub f_r: StateSpace,
    /// Input filter F_u (5 inputs, 5 outputs).
    pub f_u: StateSpace,
    /// The nominal vehicle.
    pub vehicle: Vehicle,
    /// Its parameters.
    pub params: DuctedFanParams,
    /// Equivalent input errors (ε_α, ε_ω) of eq. (10).
    pub eps_in: (f64, f64),
}

/// Measured outputs y_m and controls u.
pub const NMEAS: usize = 12;
/// Controls u.
pub const NCON: usize = 5;

/// n copies of a SISO model on the diagonal.
fn repeat(g: &StateSpace, n: usize) -> Result<StateSpace> {
    let mut acc = g.clone();
    for _ in 1..n {
        acc = append(&acc, g)?;
    }
    Ok(acc)
}

fn append_all(parts: &[StateSpace]) -> Result<StateSpace> {
    let mut acc = parts[0].clone();
    for p in &parts[1..] {
        acc = append(&acc, p)?;
    }
    Ok(acc)
}

/// First-order low pass 1/(T s + 1).
fn lowpass1(t: f64) -> Result<StateSpace> {
    Ok(StateSpace::from_rows(
        &[vec![-1.0 / t]],
        &[vec![1.0]],
        &[vec![1.0 / t]],
        &[vec![0.0]],
        0.0,
    )?)
}

/// Critically damped 1/(T²s² + 2Ts + 1) of eq. (9b).
fn lowpass2(t: f64) -> Result<StateSpace> {
    let w = 1.0 / t;
    Ok(StateSpace::from_rows(
        &[vec![0.0, 1.0], vec![-w * w, -2.0 * w]],
        &[vec![0.0], vec![1.0]],
        &[vec![w * w, 0.0]],
        &[vec![0.0]],
        0.0,
    )?)
}

/// A signal source in a static interconnection: an external input or an output of component c.
#[derive(Clone, Copy)]
pub(super) enum Sig {
    Ext(usize),
    Out(usize, usize),
}

/// Static wiring of components (MATLAB `connect` by indices): every component input and every
/// external output is a weighted sum of external inputs and component outputs. The result is
/// lft_lower(S, blkdiag(components)) for the static matrix S that does the summing.
pub(super) struct Wiring {
    comps: Vec<StateSpace>,
    n_ext_in: usize,
    comp_in: Vec<Vec<Vec<(f64, Sig)>>>,
    ext_out: Vec<Vec<(f64, Sig)>>,
}

impl Wiring {
    pub(super) fn new(n_ext_in: usize) -> Self {
        Wiring {
            comps: vec![],
            n_ext_in,
            comp_in: vec![],
            ext_out: vec![],
        }
    }

    /// Adds a component; returns its index. Its inputs start unconnected (zero).
    pub(super) fn add(&mut self, g: StateSpace) -> usize {
        self.comp_in.push(vec![vec![]; g.nu()]);
        self.comps.push(g);
        self.comps.len() - 1
    }

    /// Adds `k·s` to input `i` of component `c`.
    pub(super) fn feed(&mut self, c: usize, i: usize, k: f64, s: Sig) {
        self.comp_in[c][i].push((k, s));
    }

    /// Appends an external output Σ k·s.
    pub(super) fn output(&mut self, terms: Vec<(f64, Sig)>) {
        self.ext_out.push(terms);
    }

    pub(super) fn build(&self) -> Result<StateSpace> {
        let all = append_all(&self.comps)?;
        let mut in_off = vec![0];
        let mut out_off = vec![0];
        for g in &self.comps {
            in_off.push(in_off.last().copied().unwrap_or(0) + g.nu());
            out_off.push(out_off.last().copied().unwrap_or(0) + g.ny());
        }
        let (nu_all, ny_all) = (all.nu(), all.ny());
        let n_out = self.ext_out.len();
        let mut s = Mat::<f64>::zeros(n_out + nu_all, self.n_ext_in + ny_all);
        let col = |sig: Sig| -> Result<usize> {
            match sig {
                Sig::Ext(i) if i < self.n_ext_in => Ok(i),
                Sig::Out(c, i) if c < self.comps.len() && i < self.comps[c].ny() => Ok(self.n_ext_in + out_off[c] + i),
                _ => Err("wiring refers to a signal that does not exist".into()),
            }
        };
        for (r, terms) in self.ext_out.iter().enumerate() {
            for &(k, sig) in terms {
                s[(r, col(sig)?)] += k;
            }
        }
        for (c, ins) in self.comp_in.iter().enumerate() {
            for (i, terms) in ins.iter().enumerate() {
                for &(k, sig) in terms {
                    s[(n_out + in_off[c] + i, col(sig)?)] += k;
                }
            }
        }
        let s = StateSpace::gain(s, 0.0)?;
        Ok(lft_lower(&s, &all)?)
    }
}

/// The linearization-error weight: first order from `lin_err.1` at DC to `lin_err.0` at high
/// frequency, geometric midpoint at `lin_err.2` rad/s.
pub fn lin_err_weight(d: &Design) -> Result<StateSpace> {
    let (hf, dc, wmid) = d.lin_err;
    Ok(makeweight_mag(dc, wmid, (dc * hf).sqrt(), hf)?)
}

/// Builds G and G_nom for the nominal vehicle `spec` and the design `d`.
pub fn build(params: DuctedFanParams, d: &Design) -> Result<Plants> {
    let vehicle = VehicleSpec::DuctedFan(params).build()?;
    let (x0, u0) = vehicle.trim_hover(10.0, d.yaw_rad);
    let lin = linearize(&vehicle, &x0, &u0)?;
    let (aux, _) = vehicle.names();
    let act_states: Vec<&str> = aux.iter().map(|s| s.as_str()).collect();
    let drive = ["alpha1_rad", "alpha2_rad", "alpha3_rad", "alpha4_rad", "omega_rad_s"];
    let (ga, body) = actuator_split(&lin, &act_states, &drive)?;
    let amax = params.flap_max_rad;
    let wscale = if d.omega_scale_rad_s > 0.0 {
        d.omega_scale_rad_s
    } else {
        params.omega_max_rad_s - u0[4]
    };
    if wscale.is_nan() || wscale <= 0.0 {
        return Err("hover propeller speed is at or above omega_max".into());
    }
    let u_scale = [amax, amax, amax, amax, wscale];
    let (ea, ew) = d.input_errors();

    // G_lin with the Δ_x input (added to the velocity, attitude and rate derivatives) and the output
    // f_x = those derivatives (the signal Δ_x scales: a relative error of the linearized dynamics).
    let b = &body.ss;
    let n = b.nx();
    let aug = StateSpace::new(
        b.a.clone(),
        Mat::from_fn(n, 9 + 5, |i, j| {
            if j < 9 {
                f64::from(u8::from(i == j + 3))
            } else {
                b.b[(i, j - 9)]
            }
        }),
        Mat::from_fn(9 + 12, n, |i, j| if i < 9 { b.a[(i + 3, j)] } else { b.c[(i - 9, j)] }),
        Mat::from_fn(
            9 + 12,
            9 + 5,
            |i, j| if i < 9 && j >= 9 { b.b[(i + 3, j - 9)] } else { 0.0 },
        ),
        0.0,
    )?;

    let f_u = append(&repeat(&lowpass1(d.t_alpha_s)?, 4)?, &lowpass1(d.t_omega_s)?)?;
    let f_r = repeat(&lowpass2(d.t_ref_s)?, 3)?;
    let delay = StateSpace::gain(Mat::identity(12, 12), 0.0)?
        .with_delays(vec![0.0; 12], vec![d.t_m_s; 12])?
        .pade(d.pade_order);
    let w_x = repeat(&lin_err_weight(d)?, 9)?;
    let wp = |k: usize| makeweight_mag(d.w_pos[k].0, d.w_pos[k].1, 1.0, d.w_pos[k].2);
    let w_p = append_all(&[wp(0)?, wp(0)?, wp(1)?])?;

    let ks = d.perf_scale;
    let plant = |with_unc: bool, with_pos: bool| -> Result<StateSpace> {
        let n_unc = if with_unc { 14 } else { 0 };
        let (d0, r0, n0, u_0) = (n_unc, n_unc + 5, n_unc + 8, n_unc + 20);
        let mut wr = Wiring::new(n_unc + 25);
        let cfu = wr.add(f_u.clone());
        let cga = wr.add(ga.ss.clone());
        let clin = wr.add(aug.clone());
        let cfr = wr.add(f_r.clone());
        let cgm = wr.add(delay.clone());
        let cwp = wr.add(w_p.clone());
        let cwx = if with_unc { Some(wr.add(w_x.clone())) } else { None };
        for i in 0..5 {
            wr.feed(cfu, i, 1.0, Sig::Ext(u_0 + i));
            wr.feed(cfu, i, d.w_dist[usize::from(i == 4)], Sig::Ext(d0 + i));
            wr.feed(cga, i, u_scale[i], Sig::Out(cfu, i));
            // Actuator output plus its percentage error, v in normalized units.
            wr.feed(clin, 9 + i, 1.0, Sig::Out(cga, i));
            if with_unc {
                wr.feed(clin, 9 + i, u_scale[i], Sig::Ext(i));
            }
        }
        if let Some(cwx) = cwx {
            for i in 0..9 {
                wr.feed(clin, i, 1.0, Sig::Ext(5 + i));
                wr.feed(cwx, i, 1.0, Sig::Out(clin, i));
            }
        }
        for i in 0..3 {
            wr.feed(cfr, i, 1.0, Sig::Ext(r0 + i));
            wr.feed(cwp, i, 1.0, Sig::Out(cfr, i));
            wr.feed(cwp, i, -1.0, Sig::Out(clin, 9 + i));
        }
        for i in 0..12 {
            wr.feed(cgm, i, 1.0, Sig::Out(clin, 9 + i));
        }
        if with_unc {
            for i in 0..5 {
                let e = if i < 4 { ea } else { ew };
                wr.output(vec![(e / u_scale[i], Sig::Out(cga, i))]);
            }
            for i in 0..9 {
                wr.output(vec![(1.0, Sig::Out(cwx.unwrap_or(0), i))]);
            }
        }
        for i in 0..5 {
            wr.output(vec![(ks * d.w_u[usize::from(i == 4)], Sig::Ext(u_0 + i))]);
        }
        for i in 0..3 {
            wr.output(vec![(ks, Sig::Out(cwp, i))]);
        }
        for i in 0..3 {
            wr.output(vec![(ks * d.w_vel[usize::from(i == 2)], Sig::Out(clin, 9 + 3 + i))]);
        }
        for i in 0..3 {
            wr.output(vec![(ks * d.w_att[usize::from(i == 2)], Sig::Out(clin, 9 + 6 + i))]);
        }
        for i in 0..3 {
            wr.output(vec![(ks * d.w_rate[usize::from(i == 2)], Sig::Out(clin, 9 + 9 + i))]);
        }
        if with_pos {
            for i in 0..3 {
                wr.output(vec![(1.0, Sig::Out(clin, 9 + i))]);
            }
        }
        for i in 0..12 {
            let level = d.noise[i / 3];
            let mut terms = vec![(level, Sig::Ext(n0 + i))];
            if i < 3 {
                terms.push((1.0, Sig::Out(cfr, i)));
                terms.push((-1.0, Sig::Out(cgm, i)));
            } else {
                terms.push((1.0, Sig::Out(cgm, i)));
            }
            wr.output(terms);
        }
        wr.build()
    };
    Ok(Plants {
        g: plant(true, false)?,
        g_nom: plant(false, false)?,
        g_pos: plant(true, true)?,
        n_unc: 14,
        n_w: 20,
        n_e: 17,
        u_scale,
        f_r,
        f_u,
        vehicle,
        params,
        eps_in: (ea, ew),
    })
}

/// The runtime controller: inputs [r (3), measured linearization outputs (12): position, velocity,
/// ξ, body rates], outputs actuator-command deviations in physical units (rad ×4, rad/s), i.e.
/// diag(u_scale)·F_u·K applied to [F_r·r − P; Ṗ; Θ; Ω].
pub fn runtime_controller(p: &Plants, k: &StateSpace) -> Result<StateSpace> {
    if k.nu() != NMEAS || k.ny() != NCON {
        return Err(format!("controller is {}×{}, expected {NCON}×{NMEAS}", k.ny(), k.nu()).into());
    }
    let mut wr = Wiring::new(15);
    let cfr = wr.add(p.f_r.clone());
    let ck = wr.add(k.clone());
    let cfu = wr.add(p.f_u.clone());
    for i in 0..3 {
        wr.feed(cfr, i, 1.0, Sig::Ext(i));
        wr.feed(ck, i, 1.0, Sig::Out(cfr, i));
        wr.feed(ck, i, -1.0, Sig::Ext(3 + i));
    }
    for i in 3..12 {
        wr.feed(ck, i, 1.0, Sig::Ext(3 + i));
    }
    for i in 0..5 {
        wr.feed(cfu, i, 1.0, Sig::Out(ck, i));
        wr.output(vec![(p.u_scale[i], Sig::Out(cfu, i))]);
    }
    wr.build()
}

/// Row/column selection of a static-free helper: the block of `g` from inputs `ins` to outputs `outs`.
pub fn sub(g: &StateSpace, outs: std::ops::Range<usize>, ins: std::ops::Range<usize>) -> Result<StateSpace> {
    let c = Mat::from_fn(outs.len(), g.nx(), |i, j| g.c[(outs.start + i, j)]);
    let b = Mat::from_fn(g.nx(), ins.len(), |i, j| g.b[(i, ins.start + j)]);
    let dd = Mat::from_fn(outs.len(), ins.len(), |i, j| g.d[(outs.start + i, ins.start + j)]);
    Ok(StateSpace::new(g.a.clone(), b, c, dd, g.dt)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use skyloop_lti::c64;
    use skyloop_lti::freqresp::evalfr;

    fn plants() -> Plants {
        build(skyloop_sim::presets::ducted_fan_pross(), &Design::default()).expect("builds")
    }

    #[test]
    fn eq10_equivalent_input_errors() {
        // eq. (10) with ε = (5, 10, 10, 10, 5) %: ε_ω = max(10/2, 5) = 5 %,
        // ε_α = max(10 + 5 + 2·5, 5 + 10 + 5) = 25 %.
        let (ea, ew) = Design::default().input_errors();
        assert!((ew - 0.05).abs() < 1e-15 && (ea - 0.25).abs() < 1e-15);
    }

    #[test]
    fn dimensions_follow_eq8() {
        let p = plants();
        assert_eq!((p.g.nu(), p.g.ny()), (14 + 20 + 5, 14 + 17 + 12));
        assert_eq!((p.g_nom.nu(), p.g_nom.ny()), (20 + 5, 17 + 12));
        // 5 F_u + 9 actuator + 12 body + 6 F_r + 36 Padé + 3 position weights (+ 9 Δ_x weights).
        assert_eq!(p.g_nom.nx(), 5 + 9 + 12 + 6 + 36 + 3);
        assert_eq!(p.g.nx(), p.g_nom.nx() + 9);
    }

    #[test]
    fn weights_at_dc_and_high_frequency() {
        let p = plants();
        let d = Design::default();
        let at = |w: f64| evalfr(&p.g, c64::new(0.0, w)).expect("eval");
        // Low frequency 0.05 rad/s against closed forms: closer to DC the open-loop rigid-body
        // integrators (gain 1/ω²) amplify rounding into the other channels.
        let w_lo = 0.05;
        let (lo, hi) = (at(w_lo), at(1e6));
        let s_lo = c64::new(0.0, w_lo);
        let (u0, r0, n0) = (14 + 20, 14 + 5, 14 + 8);
        let close = |got: c64, want: c64, what: &str| {
            assert!(
                (got - want).norm() <= 1e-6 * want.norm().max(1e-3),
                "{what}: {got} vs {want}"
            );
        };
        // e_u = W_u·u: a static weight, equal at all frequencies (rows 14..19).
        for w in [&lo, &hi] {
            close(
                w[(14, u0)],
                c64::new(d.perf_scale * d.w_u[0], 0.0),
                "flap effort weight",
            );
            close(
                w[(18, u0 + 4)],
                c64::new(d.perf_scale * d.w_u[1], 0.0),
                "propeller effort weight",
            );
        }
        // eq. (9b): F_r = 1/(T s + 1)² from r_x to the measured r − y (row 31) and to the position error
        // weight (row 19, times W_p), rolling off at high frequency.
        let fr = c64::new(1.0, 0.0) / ((s_lo * d.t_ref_s + 1.0) * (s_lo * d.t_ref_s + 1.0));
        close(lo[(31, r0)], fr, "F_r in y_m");
        assert!(hi[(31, r0)].norm() < 1e-9);
        let wpos = makeweight_mag(d.w_pos[0].0, d.w_pos[0].1, 1.0, d.w_pos[0].2).expect("w");
        let wp = evalfr(&wpos, s_lo).expect("eval")[(0, 0)];
        close(lo[(19, r0)], wp * fr * d.perf_scale, "W_p·F_r");
        let wp0 = evalfr(&wpos, c64::new(0.0, 0.0)).expect("eval")[(0, 0)];
        assert!((wp0.norm() - d.w_pos[0].0).abs() < 1e-9 * d.w_pos[0].0);
        // Measurement noise enters y_m directly with its level (D21).
        close(hi[(31, n0)], c64::new(d.noise[0], 0.0), "noise level");
        // eq. (9a) and (10): z_α = ε_α·α/α_max with α = α_max·G_a·F_u·u, so z_α/u = ε_α·F_u·G_a
        // (→ ε_α at DC, 0 at high frequency); likewise z_ω with ε_ω and the first-order propeller.
        let (ea, ew) = p.eps_in;
        let wn = p.params.flap_wn_rad_s;
        let fu_a = c64::new(1.0, 0.0) / (s_lo * d.t_alpha_s + 1.0);
        let ga = c64::new(wn * wn, 0.0) / ((s_lo + wn) * (s_lo + wn));
        close(lo[(0, u0)], fu_a * ga * ea, "z_α/u");
        let fu_w = c64::new(1.0, 0.0) / (s_lo * d.t_omega_s + 1.0);
        let gw = c64::new(1.0, 0.0) / (s_lo * p.params.prop_tau_s + 1.0);
        close(lo[(4, u0 + 4)], fu_w * gw * ew, "z_ω/u");
        assert!(hi[(0, u0)].norm() < 1e-9);
        // Δ_x weight: "below 20 %" at high frequency, decreasing but not vanishing (5 %) at DC.
        let wx = lin_err_weight(&d).expect("weight");
        let mag = |w: f64| evalfr(&wx, c64::new(0.0, w)).expect("eval")[(0, 0)].norm();
        assert!((mag(0.0) - 0.05).abs() < 1e-12 && (mag(1e9) - 0.2).abs() < 1e-6);
        assert!(mag(0.1) < mag(2.0) && mag(2.0) < mag(50.0));
    }

    #[test]
    fn runtime_controller_wires_reference_filter_and_scaling() {
        let p = plants();
        // A static K = unit gain from the x-position error to flap 1: the runtime controller's DC gain
        // from r_x is u_scale·F_u(0)·F_r(0) = α_max, and from the measured x position −α_max.
        let mut kd = Mat::<f64>::zeros(5, 12);
        kd[(0, 0)] = 1.0;
        let k = StateSpace::gain(kd, 0.0).expect("gain");
        let rt = runtime_controller(&p, &k).expect("wires");
        let g = evalfr(&rt, c64::new(0.0, 0.0)).expect("dc");
        let amax = p.params.flap_max_rad;
        assert!((g[(0, 0)].re - amax).abs() < 1e-12 && (g[(0, 3)].re + amax).abs() < 1e-12);
        assert!(g[(1, 0)].norm() < 1e-15);
        assert!(runtime_controller(&p, &StateSpace::gain(Mat::zeros(4, 12), 0.0).expect("g")).is_err());
    }
}
