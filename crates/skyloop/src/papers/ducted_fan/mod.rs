//! Pross, H∞ and μ-synthesis of a ducted-fan VTOL micro-UAV ("H∞ and μ-synthesis of a ducted-fan VTOL micro-UAV"):
//! the generalized plant of Fig. 2–3 (see `plant`), H∞ synthesis on G_nom (eq. (11); paper: γ ≈ 0.6),
//! μ analysis of the H∞ loop against the structure (7) (robust stability and, by the main loop theorem
//! with the augmented structure (13), robust performance, as Fig. 4b), μ-synthesis by DK-iteration
//! (`skyloop_robust::musyn`, per-iteration γ and μ peaks), reduction of K_μ by balanced truncation
//! (smallest order keeping the loop stable and the RP μ within 2 %), and the 50 cm x-step of Fig. 5–6
//! in the nonlinear 6-DOF model with each controller (Tustin at the flight-controller rate), nominal
//! and with the flap and propeller aerodynamics at either corner of eq. (10)'s percentage errors.
//! Those corners hardly excite either loop, so Fig. 6's claim is checked with the worst-case
//! perturbation: K∞'s destabilizing Δ from its robust-stability μ sweep, realized as a stable
//! real-rational Δ(s) (`skyloop_robust::uncertainty::worst`), scaled between K∞'s and K_μ's robust
//! stability margins and closed around both linear loops F_u(Δ, F_l(G, K)).
//!
//! The paper prints neither the vehicle parameters nor the performance weights of Fig. 4a: the
//! vehicle is `presets::ducted_fan_pross` (ASSUMED values, documented there) and the weights are in
//! `plant::Design` (ASSUMED, each marked). So γ and the μ peaks are ours, not the paper's numbers; the
//! claims checked are the qualitative ones the paper makes.

pub mod plant;
mod stages;

use super::Reproduction;
use crate::error::Result;
use plant::{Design, Plants};
use skyloop_lti::interconnect::{lft_lower, lft_upper};
use skyloop_lti::reduce::{balred, Method};
use skyloop_lti::StateSpace;
use skyloop_robust::mu::{mu_system, robust_performance, MuOptions, MuSweep};
use skyloop_robust::uncertainty::blocks::BlockStructure;
use skyloop_sim::lti_loop::{simulate_lti_loop, LoopRun, LtiLoopSpec};
use skyloop_sim::vehicle::{DuctedFanParams, Vehicle};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Flight-controller rate (Hz). ASSUMED: the paper does not give it; 100 Hz matches the 10 ms
/// measurement delay of one IMU fusion sample.
const CONTROL_HZ: f64 = 100.0;
/// Physics rate of the nonlinear simulation (Hz).
const PHYSICS_HZ: f64 = 1000.0;
/// Step size along x (m), paper Section IV.
const STEP_M: f64 = 0.5;

/// μ analysis results of one closed loop.
pub struct MuReport {
    /// Robust stability sweep (structure (7)).
    pub rs: MuSweep,
    /// Robust performance sweep (structure (13)).
    pub rp: MuSweep,
    /// Nominal performance ‖e/w‖∞.
    pub np: f64,
}

fn structure() -> Result<BlockStructure> {
    // Structure (7): Δ_α ∈ C^{4×4}, δ_ω ∈ C, Δ_x ∈ C^{9×9}.
    Ok(BlockStructure::parse("f4x4,c1x1,f9x9")?)
}

/// μ analysis of lft(G, K): robust stability over the uncertainty channels, robust performance with the
/// performance block appended, nominal performance.
pub fn analyse(p: &Plants, k: &StateSpace, w: &[f64]) -> Result<MuReport> {
    let n = lft_lower(&p.g, k)?;
    let nu = p.n_unc;
    let s = structure()?;
    let opts = mu_options();
    let n_rs = plant::sub(&n, 0..nu, 0..nu)?;
    let rs = mu_system(&n_rs, w, &s, &opts)?;
    let ev = skyloop_lti::freqresp::FreqEvaluator::new(&n)?;
    let rp = robust_performance(|x| ev.eval(skyloop_lti::c64::new(0.0, x)), w, &s, p.n_e, p.n_w, &opts)?;
    let n_np = balanced(&plant::sub(&n, nu..nu + p.n_e, nu..nu + p.n_w)?)?;
    let (np, _) = skyloop_lti::norms::hinf_norm(&n_np)?;
    Ok(MuReport { rs, rp, np })
}

/// μ options of the analyses: 0.1 % on the upper bound, one power-iteration start.
fn mu_options() -> MuOptions {
    MuOptions {
        rel_tol: 1e-3,
        power_iters: 60,
        random_starts: 1,
        ..MuOptions::default()
    }
}

/// Peak robust-performance μ (upper bound) of lft(G, K) on `w`.
fn rp_peak(p: &Plants, k: &StateSpace, w: &[f64]) -> Result<f64> {
    let n = lft_lower(&p.g, k)?;
    let ev = skyloop_lti::freqresp::FreqEvaluator::new(&n)?;
    let rp = robust_performance(
        |x| ev.eval(skyloop_lti::c64::new(0.0, x)),
        w,
        &structure()?,
        p.n_e,
        p.n_w,
        &mu_options(),
    )?;
    Ok(rp.peak.upper)
}

/// A reduced controller, its robust-performance μ peak and the orders tried (with their outcome).
pub struct Reduction {
    /// The reduced controller.
    pub k: StateSpace,
    /// Its robust-performance μ peak (upper bound).
    pub rp: f64,
    /// Orders tried by the bisection and what each gave.
    pub tried: Vec<(usize, String)>,
}

/// Controller reduction: the smallest balanced truncation of `k` (unstable part kept) whose loop with
/// G_nom is stable and whose robust-performance μ peak is at most `1 + rise` times `rp_full`, by
/// bisection over the order (assuming that a larger order never does worse, which need not hold: the
/// result is the smallest order the bisection found, not a global minimum).
pub fn reduce_controller(p: &Plants, k: &StateSpace, w: &[f64], rp_full: f64, rise: f64) -> Result<Reduction> {
    let kb = balanced(k)?;
    let mut tried = Vec::new();
    let mut best = (k.clone(), rp_full);
    let (mut lo, mut hi) = (1usize, k.nx());
    while lo < hi {
        let mid = (lo + hi) / 2;
        let ok = match balred(&kb, mid, Method::Balanced) {
            Err(e) => {
                tried.push((mid, format!("balred: {e}")));
                None
            }
            Ok(r) => {
                let ab = closed_loop_abscissa(p, &r.sys)?;
                if ab >= 0.0 {
                    tried.push((r.sys.nx(), format!("unstable loop (max Re {ab:.2e})")));
                    None
                } else {
                    let rp = rp_peak(p, &r.sys, w)?;
                    tried.push((r.sys.nx(), format!("RP μ {rp:.4}")));
                    (rp <= (1.0 + rise) * rp_full).then_some((r.sys, rp))
                }
            }
        };
        match ok {
            Some(x) => {
                best = x;
                hi = mid;
            }
            None => lo = mid + 1,
        }
    }
    Ok(Reduction {
        k: best.0,
        rp: best.1,
        tried,
    })
}

/// `sys` with its outputs scaled by `k`.
fn scaled(sys: &StateSpace, k: f64) -> Result<StateSpace> {
    let c = faer::Mat::from_fn(sys.c.nrows(), sys.c.ncols(), |i, j| k * sys.c[(i, j)]);
    let d = faer::Mat::from_fn(sys.d.nrows(), sys.d.ncols(), |i, j| k * sys.d[(i, j)]);
    Ok(StateSpace::new(sys.a.clone(), sys.b.clone(), c, d, sys.dt)?)
}

/// `sys` with the outputs in `rows` set to zero.
fn zero_outputs(sys: &StateSpace, rows: std::ops::Range<usize>) -> Result<StateSpace> {
    let keep = |i: usize| if rows.contains(&i) { 0.0 } else { 1.0 };
    let c = faer::Mat::from_fn(sys.c.nrows(), sys.c.ncols(), |i, j| keep(i) * sys.c[(i, j)]);
    let d = faer::Mat::from_fn(sys.d.nrows(), sys.d.ncols(), |i, j| keep(i) * sys.d[(i, j)]);
    Ok(StateSpace::new(sys.a.clone(), sys.b.clone(), c, d, sys.dt)?)
}

/// The actuator channels of a structured Δ(s) (its first 5 inputs and outputs: Δ_α, δ_ω) as the
/// input-multiplicative factor I + diag(u_scale)·Δ_act(s)·diag(ε/u_scale) on physical command
/// deviations (rad ×4, rad/s), the map z = ε·a/u_scale → v → a + u_scale·v of `plant::build`.
pub fn actuator_factor(p: &Plants, delta: &StateSpace) -> Result<StateSpace> {
    let da = plant::sub(delta, 0..5, 0..5)?;
    let (ea, ew) = p.eps_in;
    let eps = [ea, ea, ea, ea, ew];
    let b = faer::Mat::from_fn(da.nx(), 5, |i, j| da.b[(i, j)] * eps[j] / p.u_scale[j]);
    let c = faer::Mat::from_fn(5, da.nx(), |i, j| p.u_scale[i] * da.c[(i, j)]);
    let d = faer::Mat::from_fn(5, 5, |i, j| {
        f64::from(u8::from(i == j)) + p.u_scale[i] * da.d[(i, j)] * eps[j] / p.u_scale[j]
    });
    Ok(StateSpace::new(da.a.clone(), b, c, d, 0.0)?)
}

/// Largest real part of the poles of `sys`.
fn spectral_abscissa(sys: &StateSpace) -> Result<f64> {
    let ev = skyloop_lti::poles_zeros::poles(sys)?;
    Ok(ev.iter().fold(f64::NEG_INFINITY, |m, z| m.max(z.re)))
}

/// A linear x-step (r_x → x) of lft(G_pos, K), with the uncertainty channels closed by `delta`
/// (None: open, the nominal loop): the loop's spectral abscissa and x(t) (m) for a `STEP_M` step.
pub fn linear_x_step(p: &Plants, k: &StateSpace, delta: Option<&StateSpace>, t_s: &[f64]) -> Result<(f64, Vec<f64>)> {
    let n = lft_lower(&p.g_pos, k)?;
    // w = [d (5), r (3), n (12)]: r_x is w's sixth input; x is the first output after e.
    let (r_x, x_out) = (5, p.n_e);
    let cl = match delta {
        Some(dl) => lft_upper(&n, dl)?,
        None => plant::sub(&n, p.n_unc..n.ny(), p.n_unc..n.nu())?,
    };
    let ab = spectral_abscissa(&cl)?;
    let siso = balanced(&plant::sub(&cl, x_out..x_out + 1, r_x..r_x + 1)?)?;
    let y = skyloop_lti::timeresp::step(&siso, Some(t_s))?;
    Ok((ab, y.y[0][0].iter().map(|v| STEP_M * v).collect()))
}

/// Step numbers of a linear x trace: settling time (2 %, None if not settled 5 s before the end),
/// overshoot (%), largest |F_r·r − x| (m), largest |x| (m).
pub fn linear_step_stats(t_s: &[f64], x: &[f64], t_ref_s: f64) -> (Option<f64>, f64, f64, f64) {
    let end = t_s.last().copied().unwrap_or(0.0);
    let mut last_out = None;
    let (mut peak, mut track, mut big) = (f64::NEG_INFINITY, 0.0f64, 0.0f64);
    for (&t, &v) in t_s.iter().zip(x) {
        if !v.is_finite() {
            return (None, f64::INFINITY, f64::INFINITY, f64::INFINITY);
        }
        let tau = t / t_ref_s;
        track = track.max((STEP_M * (1.0 - (1.0 + tau) * (-tau).exp()) - v).abs());
        if (v - STEP_M).abs() > 0.02 * STEP_M {
            last_out = Some(t);
        }
        peak = peak.max(v);
        big = big.max(v.abs());
    }
    let settle = match last_out {
        None => Some(0.0),
        Some(t) if t < end - 5.0 => Some(t),
        _ => None,
    };
    (settle, 100.0 * ((peak - STEP_M) / STEP_M).max(0.0), track, big)
}

/// The model after diagonal state balancing: the loop's states range from metres to Padé states of a
/// 10 ms delay, and unbalanced, its slow poles look like integrators to the norm computation.
fn balanced(sys: &StateSpace) -> Result<StateSpace> {
    Ok(sys.balance_states()?)
}

/// Damping ratio and natural frequency (rad/s) of the least-damped oscillatory pole of lft(G_nom, K).
pub fn least_damped(p: &Plants, k: &StateSpace) -> Result<(f64, f64)> {
    let cl = lft_lower(&p.g_nom, k)?;
    let poles = skyloop_lti::poles_zeros::poles(&cl)?;
    Ok(poles
        .iter()
        .filter(|z| z.im.abs() > 1e-6 * z.norm().max(1.0))
        .map(|z| (-z.re / z.norm(), z.norm()))
        .fold((f64::INFINITY, 0.0), |m, x| if x.0 < m.0 { x } else { m }))
}

/// Largest real part of the closed-loop poles of lft(G_nom, K).
pub fn closed_loop_abscissa(p: &Plants, k: &StateSpace) -> Result<f64> {
    let cl = lft_lower(&p.g_nom, k)?;
    let ev = skyloop_lti::poles_zeros::poles(&cl)?;
    Ok(ev.iter().fold(f64::NEG_INFINITY, |m, z| m.max(z.re)))
}

/// A perturbed vehicle of Fig. 6, at a corner of the percentage errors of eq. (10) (so inside the
/// uncertainty weights): `sign` = −1 takes flap area, lift slope and thrust coefficient at their low
/// end and drag and rotor inertia at their high end (less control authority); +1 the opposite corner.
pub fn perturbed(p: &DuctedFanParams, d: &Design, sign: f64) -> DuctedFanParams {
    let [es, ed, el, et, er] = d.eps;
    let mut q = *p;
    q.s_m2 *= 1.0 + sign * es;
    q.cd *= 1.0 - sign * ed;
    q.cl *= 1.0 + sign * el;
    q.kt *= 1.0 + sign * et;
    q.jr_kg_m2 *= 1.0 - sign * er;
    q
}

/// Step-response numbers of a run along x.
#[derive(Debug, Clone, Copy)]
pub struct StepStats {
    /// Time after the step until |x − 0.5 m| stays within 2 % of the step (s), None if never.
    pub settling_s: Option<f64>,
    /// Overshoot beyond the step (% of the step).
    pub overshoot_pct: f64,
    /// Largest |y|, |z| excursion (m).
    pub cross_m: f64,
    /// Largest roll/pitch (rad).
    pub tilt_rad: f64,
    /// Crashed or diverged.
    pub crashed: bool,
    /// Final x error (m).
    pub final_err_m: f64,
    /// Time to reach 90 % of the step (s), None if never.
    pub t90_s: Option<f64>,
    /// Largest |F_r·r − x| (m): how closely the filtered reference of eq. (9b) is tracked.
    pub track_err_m: f64,
}

/// Statistics of an x-step run (step at t = 0) with reference-filter time constant `t_ref_s`.
pub fn step_stats(run: &LoopRun, t_ref_s: f64) -> StepStats {
    let band = 0.02 * STEP_M;
    let mut last_out = None;
    let (mut peak, mut cross, mut tilt) = (f64::NEG_INFINITY, 0.0f64, 0.0f64);
    let (mut t90, mut track) = (None, 0.0f64);
    for s in &run.trace {
        let x = s.y[0];
        // Step response of the critically damped F_r of eq. (9b).
        let tau = s.t / t_ref_s;
        let r_f = STEP_M * (1.0 - (1.0 + tau) * (-tau).exp());
        track = track.max((r_f - x).abs());
        if t90.is_none() && x >= 0.9 * STEP_M {
            t90 = Some(s.t);
        }
        if (x - STEP_M).abs() > band {
            last_out = Some(s.t);
        }
        peak = peak.max(x);
        cross = cross.max(s.y[1].abs()).max(s.y[2].abs());
        tilt = tilt.max(s.euler[0].abs()).max(s.euler[1].abs());
    }
    let end = run.trace.last().map_or(0.0, |s| s.t);
    let settling = match last_out {
        None => Some(0.0),
        Some(t) if t < end && !run.crashed => Some(t),
        _ => None,
    };
    StepStats {
        settling_s: settling,
        overshoot_pct: 100.0 * ((peak - STEP_M) / STEP_M).max(0.0),
        cross_m: cross,
        tilt_rad: tilt,
        crashed: run.crashed,
        final_err_m: run.trace.last().map_or(f64::INFINITY, |s| (s.y[0] - STEP_M).abs()),
        t90_s: t90,
        track_err_m: if run.crashed { f64::INFINITY } else { track },
    }
}

/// Runs the x-step of Fig. 5–6 with runtime controller `k_rt` (continuous) on `actual`.
pub fn x_step(p: &Plants, k_rt: &StateSpace, actual: &Vehicle, d: &Design, duration_s: f64) -> Result<LoopRun> {
    let (x_init, _) = actual.trim_hover(10.0, d.yaw_rad);
    run_loop(p, k_rt, actual, d, duration_s, [STEP_M, 0.0, 0.0], &x_init)
}

/// Runs `k_rt` (continuous, discretized by Tustin at the flight-controller rate) on `actual` from
/// `x_init` with the constant position reference `r` (m, relative to the hover point).
pub fn run_loop(
    p: &Plants,
    k_rt: &StateSpace,
    actual: &Vehicle,
    d: &Design,
    duration_s: f64,
    r: [f64; 3],
    x_init: &skyloop_sim::rigid::State,
) -> Result<LoopRun> {
    // Balanced first: the μ controller's D-scale states make I − A·dt/2 look singular unbalanced.
    let kd = skyloop_sim::runtime_controller::discretize(&balanced(k_rt)?, 1.0 / CONTROL_HZ)?;
    let (x0, u0) = p.vehicle.trim_hover(10.0, d.yaw_rad);
    let spec = LtiLoopSpec {
        physics_hz: PHYSICS_HZ,
        controller: kd,
        measured: (0..12).collect(),
        measurement_delay_s: d.t_m_s,
        reference: vec![(0.0, r.to_vec())],
        duration_s,
        log_every: 5,
        crash_tilt_rad: 1.2,
    };
    Ok(simulate_lti_loop(actual, &x0, &u0, x_init, &spec)?)
}

/// Hover recovery: from 0.3 m off in x and y, 0.2 m low, tilted `tilt_rad` in roll and pitch and
/// yawed 0.1 rad, back to the hover point; returns the largest final deviation (m or rad) and
/// whether the run crashed.
pub fn hover_recovery(p: &Plants, k_rt: &StateSpace, d: &Design, tilt_rad: f64) -> Result<(f64, bool)> {
    use skyloop_sim::rigid::{POS, QUAT};
    let (x0, _) = p.vehicle.trim_hover(10.0, d.yaw_rad);
    let mut xi = x0;
    xi[POS] += 0.3;
    xi[POS + 1] -= 0.3;
    xi[POS + 2] += 0.2;
    let q = skyloop_sim::geometry::from_euler(tilt_rad, -tilt_rad, d.yaw_rad + 0.1);
    xi[QUAT..QUAT + 4].copy_from_slice(&q);
    let run = run_loop(p, k_rt, &p.vehicle, d, 60.0, [0.0; 3], &xi)?;
    let last = run.trace.last().ok_or("empty trace")?;
    let dev = last.y[..9].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    Ok((dev, run.crashed))
}

fn write_csv(path: &Path, run: &LoopRun) -> Result<()> {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?,
    );
    let io = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    writeln!(
        f,
        "t_s,r_x_m,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,roll_rad,pitch_rad,yaw_rad,p_rad_s,q_rad_s,r_rad_s,\
         alpha1_rad,alpha2_rad,alpha3_rad,alpha4_rad,omega_rad_s"
    )
    .map_err(io)?;
    for s in &run.trace {
        write!(f, "{},{}", s.t, s.reference[0]).map_err(io)?;
        for v in s.y[..6]
            .iter()
            .chain(s.euler.iter())
            .chain(s.y[9..12].iter())
            .chain(s.u.iter())
        {
            write!(f, ",{v}").map_err(io)?;
        }
        writeln!(f).map_err(io)?;
    }
    Ok(())
}

/// CPU time (user + system) of this process in seconds, from /proc/self/stat (Linux; fields 14–15
/// in clock ticks of 1/100 s, the USER_HZ every Linux ABI uses); None elsewhere. Wall time on a
/// shared CI machine says little about the cost of the run.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) is parenthesized and may contain spaces: split after it.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Runs the reproduction, writing traces and plots to `out`; `quick` uses a coarser μ grid.
///
/// The stages (in `stages`) run in the order the account prints them; the μ figure is written
/// once both loops are analysed, the step figure once every run is done.
pub fn run(out: &Path, quick: bool) -> Result<Reproduction> {
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let t_start = Instant::now();
    let d = Design::default();
    let p = plant::build(skyloop_sim::presets::ducted_fan_pross(), &d)?;
    let mut s = stages::Stages {
        rep: Reproduction::new("ducted-fan"),
        d,
        p,
        out,
        quick,
        w: stages::mu_grid(quick),
    };
    s.plant_notes();
    let hinf = s.hinf_synthesis()?;
    let hinf = s.hinf_mu_analysis(hinf)?;
    let (k_mu, mm) = s.mu_synthesis(&hinf)?;
    let mu = s.mu_reduction(&k_mu, mm)?;
    let mu_path = s.mu_figure(&hinf, &mu)?;
    let mut nl = s.nonlinear_steps(&hinf, &mu)?;
    let wc = s.worst_case_linear(&hinf, &mu)?;
    s.worst_case_actuator(&hinf, &mu, &wc, &mut nl)?;
    let fig = s.step_figure(&nl, &wc)?;
    let mut rep = s.rep;
    rep.note(format!(
        "\nwrote {}, {} and CSV traces in {} (wall {:.1} s, cpu {})",
        mu_path.display(),
        fig.display(),
        out.display(),
        t_start.elapsed().as_secs_f64(),
        cpu_seconds().map_or("n/a".into(), |c| format!("{c:.1} s"))
    ));
    rep.artifact(&mu_path);
    rep.artifact(&fig);
    super::write_report(&mut rep, "Ducted-fan VTOL (Pross): claims reproduced", out)?;
    Ok(rep)
}
