//! The stages of the ducted-fan reproduction ([`super::run`]), in the order they print: the plant,
//! H∞ synthesis, μ analysis of the H∞ loop, μ-synthesis by DK-iteration, reduction of K_μ, the
//! nonlinear 6-DOF x-steps, Fig. 6 by the worst-case perturbation (linear loops, then its actuator
//! part in the nonlinear model), and the figures. Each stage adds its notes, measures and checks to
//! the account and hands the next stages only what they use.

use super::plant::{self, Design, Plants, NCON, NMEAS};
use super::{
    actuator_factor, analyse, closed_loop_abscissa, hover_recovery, least_damped, linear_step_stats, linear_x_step,
    perturbed, reduce_controller, scaled, spectral_abscissa, step_stats, structure, write_csv, x_step, zero_outputs,
    MuReport, Reduction, StepStats, CONTROL_HZ, PHYSICS_HZ, STEP_M,
};
use crate::error::Result;
use crate::papers::Reproduction;
use skyloop_lti::interconnect::{lft_lower, lft_upper};
use skyloop_lti::StateSpace;
use skyloop_plot::traces::{plot_traces, Trace, TracePanel};
use skyloop_robust::hinfsyn::HinfSolution;
use skyloop_robust::mu::{robust_stability, StabilityMargin};
use skyloop_robust::musyn::{musyn, MusynOptions};
use skyloop_robust::uncertainty::worst::realize_perturbation_detailed;
use skyloop_sim::lti_loop::LoopRun;
use skyloop_sim::vehicle::VehicleSpec;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Length of every nonlinear x-step run (s).
const RUN_S: f64 = 40.0;

/// What every stage reads (the design, its plants, the μ frequency grid, where files go) and the
/// account every stage adds to.
pub(super) struct Stages<'a> {
    /// The account: notes, checks, measures and artifacts, in the order they were made.
    pub rep: Reproduction,
    /// The design choices (ASSUMED weights, delays, filters).
    pub d: Design,
    /// The generalized plants built from the design.
    pub p: Plants,
    /// The output directory.
    pub out: &'a Path,
    /// Coarser μ grid and fewer DK-iterations.
    pub quick: bool,
    /// Frequency grid of the μ analyses (rad/s): 0.01–1000, 30 points quick, 80 otherwise.
    pub w: Vec<f64>,
}

/// The H∞ design and its μ analysis, which later stages compare against and perturb.
pub(super) struct HinfLoop {
    /// hinfsyn's solution on G_nom (controller u = K∞·y).
    pub sol: HinfSolution,
    /// μ analysis of lft(G, K∞).
    pub mu: MuReport,
    /// K∞'s robust-stability margin, with its destabilizing Δ.
    pub rs_margin: StabilityMargin,
}

/// K_μ's μ analysis and its reduction (the controller flown below) with its own.
pub(super) struct MuLoop {
    /// μ analysis of lft(G, K_μ), the full-order μ controller.
    pub mu: MuReport,
    /// The reduced controller, the one flown below.
    pub k_red: StateSpace,
    /// μ analysis of lft(G, reduced K_μ).
    pub mu_red: MuReport,
}

/// The nonlinear runs so far: the runtime controllers and every (label, run) for the figure.
pub(super) struct NonlinearSteps {
    /// K∞ as the runtime controller (continuous).
    pub k_rt: StateSpace,
    /// The reduced K_μ as the runtime controller (continuous).
    pub k_rt_mu: StateSpace,
    /// Every nonlinear run, labelled, in the order they were flown.
    pub runs: Vec<(String, LoopRun)>,
}

/// One linear x-step (x in m at the common time grid), its spectral abscissa (1/s) and its numbers
/// from [`linear_step_stats`].
pub(super) struct LinearRun {
    /// Largest real part of the loop's poles (1/s).
    pub abscissa: f64,
    /// x(t) (m).
    pub x_m: Vec<f64>,
    /// Settling time (s), overshoot (%), largest |F_r·r − x| (m), largest |x| (m).
    pub stats: (Option<f64>, f64, f64, f64),
}

/// The linear x-steps of Fig. 6: one controller's loop nominal and with the worst-case Δ.
pub(super) struct LinearPair {
    /// "H∞" or "μ".
    pub label: &'static str,
    /// The loop with the uncertainty channels open.
    pub nominal: LinearRun,
    /// The loop closed by the applied worst-case Δ.
    pub perturbed: LinearRun,
}

/// The worst-case perturbation and the linear loops it was closed around.
pub(super) struct WorstCase {
    /// The applied Δ(s), K∞'s destabilizing Δ scaled to `size`.
    pub delta: StateSpace,
    /// Its ‖Δ‖∞ (fraction of the modelled uncertainty).
    pub size: f64,
    /// Time grid of the linear steps (s): 0–40 s at 10 ms.
    pub t_s: Vec<f64>,
    /// H∞ then μ.
    pub loops: Vec<LinearPair>,
}

/// The μ analysis frequency grid (rad/s): 0.01–1000, 30 points with `quick`, 80 otherwise.
pub(super) fn mu_grid(quick: bool) -> Vec<f64> {
    let npts = if quick { 30 } else { 80 };
    skyloop_lti::freqresp::logspace(-2.0, 3.0, npts)
}

impl Stages<'_> {
    /// Notes the plant: hover point, delays and filters (s), eq. (10)'s uncertainty sizes (%), and
    /// the generalized plants' dimensions.
    pub fn plant_notes(&mut self) {
        let (d, p) = (&self.d, &self.p);
        let (ea, ew) = p.eps_in;
        let rep = &mut self.rep;
        rep.note("Ducted-fan VTOL (Pross): H∞ and μ analysis, 50 cm x-step in the 6-DOF model");
        rep.note(format!(
            "  plant: hover at yaw {:.0}°, {}-order Padé of T_m = {} s, F_u (T_α = {} s, T_ω = {} s), F_r (T = {} s)",
            d.yaw_rad.to_degrees(),
            d.pade_order,
            d.t_m_s,
            d.t_alpha_s,
            d.t_omega_s,
            d.t_ref_s
        ));
        rep.note(format!(
            "  eq. (10): ε_α = {:.0} %, ε_ω = {:.0} %; linearization error {:.0} % → {:.0} %",
            100.0 * ea,
            100.0 * ew,
            100.0 * d.lin_err.1,
            100.0 * d.lin_err.0
        ));
        rep.note(format!(
            "  G: {} states, {} inputs [v 14 | w 20 | u 5], {} outputs [z 14 | e 17 | y_m 12]; G_nom: {} states",
            p.g.nx(),
            p.g.nu(),
            p.g.ny(),
            p.g_nom.nx()
        ));
    }

    /// H∞ synthesis on G_nom (eq. (11)): γ, the least-damped closed-loop pole (rad/s) beside the
    /// gyroscopic nutation frequency, and the check that K∞ stabilizes the linear plant.
    pub fn hinf_synthesis(&mut self) -> Result<HinfSolution> {
        let (d, p, rep) = (&self.d, &self.p, &mut self.rep);
        rep.note("\nH∞ synthesis on G_nom (eq. (11)):");
        let t = Instant::now();
        let hinf = skyloop_robust::hinfsyn::hinfsyn(&p.g_nom, NMEAS, NCON).map_err(|e| format!("hinfsyn: {e}"))?;
        rep.note(format!(
            "  γ = {:.4} (bisection lower bound {:.4}), ‖lft(G_nom, K∞)‖∞ = {:.4}, controller order {}, {:.2} s",
            hinf.gamma,
            hinf.gamma_lower,
            hinf.closed_loop_norm,
            hinf.controller.nx(),
            t.elapsed().as_secs_f64()
        ));
        rep.note("  paper: γ ≈ 0.6 with its (unprinted) weights of Fig. 4a");
        rep.measure("hinf_gamma", hinf.gamma);
        let abscissa = closed_loop_abscissa(p, &hinf.controller)?;
        let (zeta, wn) = least_damped(p, &hinf.controller)?;
        rep.note(format!(
            "  least-damped closed-loop pole: ζ = {zeta:.3} at {wn:.2} rad/s (gyroscopic nutation Jr·ω0/Jx ≈ {:.2} rad/s)",
            p.params.jr_kg_m2 * p.vehicle.trim_hover(10.0, d.yaw_rad).1[4] / p.params.body.inertia_kg_m2[0]
        ));
        rep.check(
            abscissa < 0.0,
            format!("K∞ stabilizes the linear plant (max Re pole {abscissa:.3e})"),
        );
        Ok(hinf)
    }

    /// μ analysis of the H∞ loop (Fig. 4b) on the grid `w`: robust stability, robust performance and
    /// nominal performance, with the checks that the bounds are ordered and that nominal performance
    /// is hinfsyn's closed-loop norm.
    pub fn hinf_mu_analysis(&mut self, hinf: HinfSolution) -> Result<HinfLoop> {
        let (p, w, rep) = (&self.p, &self.w, &mut self.rep);
        rep.note(format!(
            "\nμ analysis of the H∞ loop (Fig. 4b), {} frequencies 0.01–1000 rad/s:",
            w.len()
        ));
        let t = Instant::now();
        let mh = analyse(p, &hinf.controller, w)?;
        let rsm = robust_stability(&mh.rs);
        rep.measure("hinf_rs_mu_peak", mh.rs.peak.upper);
        rep.measure("hinf_rp_mu_peak", mh.rp.peak.upper);
        rep.note(format!(
            "  robust stability μ peak {:.3} at {:.2} rad/s (margin {:.3}); robust performance μ peak {:.3} at {:.2} rad/s; nominal performance {:.3}; {:.2} s",
            mh.rs.peak.upper,
            mh.rs.peak.w_rad_s,
            rsm.lower,
            mh.rp.peak.upper,
            mh.rp.peak.w_rad_s,
            mh.np,
            t.elapsed().as_secs_f64()
        ));
        rep.check(
            mh.rs.upper.iter().zip(&mh.rs.lower).all(|(u, l)| u + 1e-9 >= *l),
            "μ upper bound ≥ lower bound at every frequency".into(),
        );
        rep.check(
            (mh.np - hinf.closed_loop_norm).abs() <= 1e-3 * hinf.closed_loop_norm,
            format!(
                "nominal performance of lft(G, K∞) equals hinfsyn's closed-loop norm ({:.4} vs {:.4})",
                mh.np, hinf.closed_loop_norm
            ),
        );
        Ok(HinfLoop {
            sol: hinf,
            mu: mh,
            rs_margin: rsm,
        })
    }

    /// μ-synthesis by DK-iteration on G with the structure (13): per-iteration γ and RP μ peak, the
    /// μ analysis of K_μ, and the checks that it stabilizes, beats K∞'s RP μ, and that the D-steps
    /// pay off within the paper's 3 iterations. Returns K_μ and its analysis.
    pub fn mu_synthesis(&mut self, hinf: &HinfLoop) -> Result<(StateSpace, MuReport)> {
        let (p, w, quick, rep) = (&self.p, &self.w, self.quick, &mut self.rep);
        let mh = &hinf.mu;
        rep.note(format!(
            "\nμ-synthesis by DK-iteration (skyloop_robust::musyn) on G with the structure (13), {} iterations at most:",
            if quick { 2 } else { 4 }
        ));
        let t = Instant::now();
        let mopts = MusynOptions {
            max_iter: if quick { 2 } else { 4 },
            // The D-step needs the grid only where the scalings vary; --quick halves it.
            w_rad_s: if quick {
                skyloop_lti::freqresp::logspace(-2.0, 3.0, 20)
            } else {
                w.clone()
            },
            ..MusynOptions::default()
        };
        let ms = musyn(&p.g, &structure()?, NMEAS, NCON, &mopts).map_err(|e| format!("musyn: {e}"))?;
        for (i, it) in ms.iterations.iter().enumerate() {
            rep.note(format!(
                "  iteration {}: γ = {:.4}, robust-performance μ peak {:.4}{}",
                i + 1,
                it.gamma,
                it.mu_peak,
                if i == ms.best { " (best)" } else { "" }
            ));
        }
        let k_mu = ms.controller.clone();
        rep.measure("musyn_first_gamma", ms.iterations[0].gamma);
        // A K-step, analysis or D-fit that failed ends the iteration early; the best iterate so far
        // stands, but the run says so as a claim that did not hold rather than hiding it.
        let step_failed = ms.stop_reason.contains("failed");
        rep.check(
            !step_failed,
            format!(
                "every DK-iteration step succeeded ({} iterations; stop: {})",
                ms.iterations.len(),
                ms.stop_reason
            ),
        );
        rep.measure("k_mu_order", k_mu.nx() as f64);
        rep.note(format!(
            "  K_μ: {} states, {:.1} s; paper: 3 iterations, RP μ below the H∞ design's (Fig. 4b)",
            k_mu.nx(),
            t.elapsed().as_secs_f64()
        ));
        let mm = analyse(p, &k_mu, w)?;
        rep.note(format!(
            "  K_μ: robust stability μ peak {:.3} at {:.2} rad/s; robust performance μ peak {:.3} at {:.2} rad/s; nominal performance {:.3}",
            mm.rs.peak.upper, mm.rs.peak.w_rad_s, mm.rp.peak.upper, mm.rp.peak.w_rad_s, mm.np
        ));
        let abs_mu = closed_loop_abscissa(p, &k_mu)?;
        rep.check(
            abs_mu < 0.0,
            format!("K_μ stabilizes the linear plant (max Re pole {abs_mu:.3e})"),
        );
        rep.check(
            mm.rp.peak.upper < mh.rp.peak.upper,
            format!(
                "robust-performance μ of K_μ below K∞'s ({:.3} < {:.3}), as Fig. 4b",
                mm.rp.peak.upper, mh.rp.peak.upper
            ),
        );
        // The D-steps must pay off: the best iterate beats the first (D = I) K-step, and does so within
        // the paper's 3 iterations.
        rep.check(
            ms.best > 0 && ms.best < 3 && ms.iterations[ms.best].mu_peak < ms.iterations[0].mu_peak,
            format!(
                "D-scaling improves on the unscaled K-step; best RP μ at iteration {} (paper: converged in 3); stop: {}",
                ms.best + 1,
                ms.stop_reason
            ),
        );
        Ok((k_mu, mm))
    }

    /// Reduction of K_μ ([`reduce_controller`], RP μ allowed to rise 2 %): the orders tried, the
    /// reduced controller's μ analysis, and the check that it keeps the loop stable and the RP μ.
    pub fn mu_reduction(&mut self, k_mu: &StateSpace, mm: MuReport) -> Result<MuLoop> {
        let (p, w, rep) = (&self.p, &self.w, &mut self.rep);
        rep.note("\nReduction of K_μ (balanced truncation, unstable part kept; bisection on the order): smallest order with a stable loop and RP μ peak within +2 %:");
        let t = Instant::now();
        let Reduction {
            k: k_red,
            rp: rp_red,
            tried,
        } = reduce_controller(p, k_mu, w, mm.rp.peak.upper, 0.02)?;
        rep.note(format!(
            "  tried: {}",
            tried
                .iter()
                .map(|(n, r)| format!("{n} states → {r}"))
                .collect::<Vec<_>>()
                .join("; ")
        ));
        let mr = analyse(p, &k_red, w)?;
        rep.measure("k_mu_reduced_order", k_red.nx() as f64);
        let abs_red = closed_loop_abscissa(p, &k_red)?;
        rep.note(format!(
            "  K_μ reduced: {} → {} states; RP μ peak {:.4} → {:.4} ({:+.2} %); robust stability μ peak {:.3} (margin {:.3}); {:.1} s",
            k_mu.nx(),
            k_red.nx(),
            mm.rp.peak.upper,
            mr.rp.peak.upper,
            100.0 * (mr.rp.peak.upper / mm.rp.peak.upper - 1.0),
            mr.rs.peak.upper,
            robust_stability(&mr.rs).lower,
            t.elapsed().as_secs_f64()
        ));
        rep.check(
            abs_red < 0.0 && k_red.nx() < k_mu.nx() && rp_red <= 1.02 * mm.rp.peak.upper,
            format!(
                "reduced K_μ ({} states) keeps the loop stable (max Re {abs_red:.2e}) and the RP μ within 2 % ({:.4} vs {:.4}); used below",
                k_red.nx(),
                rp_red,
                mm.rp.peak.upper
            ),
        );
        Ok(MuLoop {
            mu: mm,
            k_red,
            mu_red: mr,
        })
    }

    /// Fig. 4b: the μ bounds (robust stability and performance) of the H∞ and μ loops against
    /// frequency (Hz), written as `fig4b_mu.svg`; returns its path.
    pub fn mu_figure(&self, hinf: &HinfLoop, mu: &MuLoop) -> Result<PathBuf> {
        let hz: Vec<f64> = self.w.iter().map(|x| x / (2.0 * std::f64::consts::PI)).collect();
        let curves: Vec<skyloop_plot::mu::MuCurve> = [
            ("H∞: robust stability", &hinf.mu.rs),
            ("H∞: robust performance", &hinf.mu.rp),
            ("K_μ: robust stability", &mu.mu.rs),
            ("K_μ: robust performance", &mu.mu.rp),
        ]
        .into_iter()
        .map(|(label, sweep)| skyloop_plot::mu::MuCurve {
            label: label.into(),
            freq_hz: hz.clone(),
            upper: sweep.upper.clone(),
            lower: sweep.lower.clone(),
        })
        .collect();
        let mu_path = self.out.join("fig4b_mu.svg");
        skyloop_plot::mu::plot_mu(&mu_path, "Ducted fan: μ of the H∞ and μ loops", &curves)
            .map_err(|e| format!("plot: {e}"))?;
        Ok(mu_path)
    }

    /// The nonlinear 6-DOF x-step of Fig. 5–6 (`STEP_M` m, `RUN_S` s): K∞'s hover recovery, then both
    /// controllers nominal and at either corner of eq. (10) (one CSV each), their table and checks.
    pub fn nonlinear_steps(&mut self, hinf: &HinfLoop, mu: &MuLoop) -> Result<NonlinearSteps> {
        let (d, p) = (&self.d, &self.p);
        self.rep.note(format!(
            "\nNonlinear 6-DOF x-step of {STEP_M} m (RK4 {PHYSICS_HZ} Hz, controller Tustin at {CONTROL_HZ} Hz, exact {} s measurement delay, actuator limits):",
            d.t_m_s
        ));
        let k_rt = plant::runtime_controller(p, &hinf.sol.controller)?;
        self.hover_checks(&k_rt)?;
        let (d, p) = (&self.d, &self.p);
        let pert = |sign: f64| VehicleSpec::DuctedFan(perturbed(&p.params, d, sign)).build();
        let (lo, hi) = (pert(-1.0)?, pert(1.0)?);
        let mut rows = Vec::new();
        let mut runs = Vec::new();
        let k_rt_mu = plant::runtime_controller(p, &mu.k_red)?;
        for (stem, label, veh, k) in [
            ("hinf_nominal", "H∞, nominal (Fig. 5)", &p.vehicle, &k_rt),
            ("hinf_perturbed", "H∞, perturbed − (Fig. 6)", &lo, &k_rt),
            ("hinf_perturbed_high", "H∞, perturbed +", &hi, &k_rt),
            ("mu_nominal", "μ, nominal (Fig. 5)", &p.vehicle, &k_rt_mu),
            ("mu_perturbed", "μ, perturbed − (Fig. 6)", &lo, &k_rt_mu),
            ("mu_perturbed_high", "μ, perturbed +", &hi, &k_rt_mu),
        ] {
            let run = x_step(p, k, veh, d, RUN_S)?;
            write_csv(&self.out.join(format!("{stem}.csv")), &run)?;
            self.rep.artifact(&self.out.join(format!("{stem}.csv")));
            let st = step_stats(&run, d.t_ref_s);
            rows.push((label.to_string(), st));
            runs.push((label.to_string(), run));
        }
        step_table(&mut self.rep, &rows);
        corner_checks(&mut self.rep, &rows);
        Ok(NonlinearSteps { k_rt, k_rt_mu, runs })
    }

    /// K∞'s hover recovery in the nonlinear model: checked from a 0.1 rad tilt (final deviation in
    /// m and rad), noted from 0.15 rad, where the flaps saturate.
    fn hover_checks(&mut self, k_rt: &StateSpace) -> Result<()> {
        let (d, p, rep) = (&self.d, &self.p, &mut self.rep);
        let (dev, crashed) = hover_recovery(p, k_rt, d, 0.1)?;
        rep.check(
            !crashed && dev < 0.02,
            format!(
                "K∞ stabilizes the nonlinear hover: back from a 0.3 m / 0.1 rad upset to within {dev:.4} (m, rad) in 60 s"
            ),
        );
        let (dev15, crashed15) = hover_recovery(p, k_rt, d, 0.15)?;
        rep.note(format!(
            "  (from a 0.15 rad tilt: final deviation {dev15:.3}, crashed {crashed15}; the flaps saturate at {:.2} rad)",
            p.params.flap_max_rad
        ));
        Ok(())
    }

    /// Fig. 6 by the worst-case perturbation: K∞'s destabilizing Δ realized as a stable Δ(s),
    /// checked to be K∞'s margin, scaled midway between K∞'s destabilizing size and the reduced
    /// K_μ's guaranteed margin, and closed around both linear loops (x-steps in m over 0–40 s, one
    /// CSV), with the check that the μ loop holds where the H∞ loop fails or degrades.
    pub fn worst_case_linear(&mut self, hinf: &HinfLoop, mu: &MuLoop) -> Result<WorstCase> {
        let (delta, size) = self.worst_case_delta(hinf, mu)?;
        let (d, p, rep) = (&self.d, &self.p, &mut self.rep);
        let t_lin: Vec<f64> = (0..=4000).map(|i| i as f64 * 0.01).collect();
        let mut lin = Vec::new();
        for (label, k) in [("H∞", &hinf.sol.controller), ("μ", &mu.k_red)] {
            let linear_run = |delta: Option<&StateSpace>| -> Result<LinearRun> {
                let (abscissa, x_m) = linear_x_step(p, k, delta, &t_lin)?;
                let stats = linear_step_stats(&t_lin, &x_m, d.t_ref_s);
                Ok(LinearRun { abscissa, x_m, stats })
            };
            let pair = LinearPair {
                label,
                nominal: linear_run(None)?,
                perturbed: linear_run(Some(&delta))?,
            };
            for (what, r) in [("nominal", &pair.nominal), ("worst-case Δ", &pair.perturbed)] {
                let (ab, st) = (r.abscissa, r.stats);
                rep.note(format!(
                    "  {label:<3} {what:<13} max Re pole {ab:+.3e}; settle 2 % {:>6}; overshoot {:6.2} %; |r_f−x| {:9.4} m; max|x| {:9.3} m",
                    st.0.map_or("never".into(), |t| format!("{t:.1} s")),
                    st.1,
                    st.2,
                    st.3
                ));
            }
            lin.push(pair);
        }
        let path = self.out.join("fig6_worst_case_linear.csv");
        rep.artifact(&path);
        write_linear_csv(&path, &t_lin, &lin)?;
        fig6_check(rep, size, &lin[0], &lin[1]);
        Ok(WorstCase {
            delta,
            size,
            t_s: t_lin,
            loops: lin,
        })
    }

    /// K∞'s destabilizing Δ from its robust-stability sweep, realized as Δ_wc(s) (its blocks' σ̄
    /// noted, and the check that it sits exactly at K∞'s margin), then scaled to the applied size;
    /// returns the applied Δ(s) and its ‖Δ‖∞.
    fn worst_case_delta(&mut self, hinf: &HinfLoop, mu: &MuLoop) -> Result<(StateSpace, f64)> {
        let (p, rep) = (&self.p, &mut self.rep);
        let rsm = &hinf.rs_margin;
        rep.note(
            "\nFig. 6 by the worst-case perturbation: K∞'s destabilizing Δ from its robust-stability μ sweep, realized \
             as a stable real-rational Δ(s) (skyloop_robust::uncertainty::worst), one Δ for both loops F_u(Δ, F_l(G, K)):",
        );
        let rsm_mu = robust_stability(&mu.mu_red.rs);
        let real = realize_perturbation_detailed(rsm.delta.as_ref(), &structure()?, rsm.w_rad_s)
            .map_err(|e| format!("worst-case Δ: {e}"))?;
        let size_wc = rsm.upper;
        rep.note(format!("  K∞'s destabilizing Δ by block: {}", block_sizes(rsm)?));
        let (norm_wc, _) = skyloop_lti::norms::hinf_norm(&real.sys)?;
        rep.note(format!(
            "  Δ_wc at {:.3} rad/s: σ̄ = {:.4} (K∞'s margin bounds [{:.4}, {:.4}]), ‖Δ_wc(s)‖∞ = {:.4}, {} states, \
             rank-one truncation dropped {:.1e} of a block",
            rsm.w_rad_s,
            size_wc,
            rsm.lower,
            rsm.upper,
            norm_wc,
            real.sys.nx(),
            real.dropped_rel
        ));
        let n_h = lft_lower(&p.g, &hinf.sol.controller)?;
        let ab_at = |k: f64| -> Result<f64> { spectral_abscissa(&lft_upper(&n_h, &scaled(&real.sys, k)?)?) };
        let (ab_lo, ab_hi) = (ab_at(0.98)?, ab_at(1.02)?);
        rep.check(
            (norm_wc - size_wc).abs() <= 1e-6 * size_wc && ab_lo < 0.0 && ab_hi > 0.0,
            format!(
                "Δ_wc(s) is K∞'s margin: ‖Δ_wc‖∞ = σ̄ = {size_wc:.4}, the K∞ loop with 0.98·Δ_wc is stable (max Re pole \
                 {ab_lo:.3e}) and with 1.02·Δ_wc unstable ({ab_hi:.3e})"
            ),
        );
        let size = 0.5 * (size_wc + rsm_mu.lower);
        rep.measure("fig6_delta_percent", 100.0 * size);
        rep.note(format!(
            "  applied Δ = Δ_wc scaled to ‖Δ‖∞ = {size:.4}: {:.0} % of the modelled uncertainty, midway between K∞'s \
             destabilizing size {size_wc:.4} and the reduced K_μ's guaranteed margin {:.4}",
            100.0 * size,
            rsm_mu.lower
        ));
        Ok((scaled(&real.sys, size / size_wc)?, size))
    }

    /// The actuator part of the applied Δ in the nonlinear model: the linear loops' abscissas
    /// (1/s) with that part alone noted, then both controllers' x-steps with it as an
    /// input-multiplicative factor (one CSV each, added to `nl`'s runs) and the μ loop's check.
    pub fn worst_case_actuator(
        &mut self,
        hinf: &HinfLoop,
        mu: &MuLoop,
        wc: &WorstCase,
        nl: &mut NonlinearSteps,
    ) -> Result<()> {
        let (d, p, rep) = (&self.d, &self.p, &mut self.rep);
        // The actuator part of the same Δ in the nonlinear model: Δ_α and δ_ω act on the actuator outputs,
        // α_eff = (I + ε_α·Δ_α)·α and δω_eff = (1 + ε_ω·δ_ω)·δω (eq. (10), Fig. 3). The four flap actuators
        // are identical and δ_ω is scalar, so in the linear regime the factor commutes with the actuators
        // and is applied to the command deviations the controller sends. Δ_x (linearization error) has no
        // counterpart in the nonlinear model, which is the truth model, so it is left out there.
        let d_act = zero_outputs(&wc.delta, 5..wc.delta.ny())?;
        rep.note(format!(
            "  nonlinear 6-DOF x-step with the actuator part of the applied Δ (Δ_α, δ_ω as input-multiplicative \
             factors; Δ_x left out: the nonlinear model is the truth); the linear loops with this part alone: max Re pole \
             H∞ {:+.3e}, μ {:+.3e}",
            linear_x_step(p, &hinf.sol.controller, Some(&d_act), &wc.t_s[..2])?.0,
            linear_x_step(p, &mu.k_red, Some(&d_act), &wc.t_s[..2])?.0
        ));
        let factor = actuator_factor(p, &wc.delta)?;
        let mut nl_wc = Vec::new();
        for (stem, label, k) in [
            ("hinf_worst_case_actuator", "H∞, worst-case Δ_act", &nl.k_rt),
            ("mu_worst_case_actuator", "μ, worst-case Δ_act", &nl.k_rt_mu),
        ] {
            let kp = skyloop_lti::interconnect::series(k, &factor)?;
            let run = x_step(p, &kp, &p.vehicle, d, RUN_S)?;
            write_csv(&self.out.join(format!("{stem}.csv")), &run)?;
            rep.artifact(&self.out.join(format!("{stem}.csv")));
            let st = step_stats(&run, d.t_ref_s);
            rep.note(step_row(label, &st));
            nl_wc.push(st);
            nl.runs.push((label.to_string(), run));
        }
        rep.check(
            settles(&nl_wc[1]),
            format!(
                "nonlinear, actuator part of the worst-case Δ: μ step {} (the Δ_x part that \
             destabilizes the linear H∞ loop is not in the nonlinear model)",
                if settles(&nl_wc[1]) {
                    "stable and settles"
                } else {
                    "does not settle"
                }
            ),
        );
        Ok(())
    }

    /// Fig. 5–6: x (m) of every nonlinear run beside the filtered reference, their roll and pitch
    /// (rad), and the linear worst-case steps, written as `fig5_6_x_step.svg`; returns its path.
    pub fn step_figure(&self, nl: &NonlinearSteps, wc: &WorstCase) -> Result<PathBuf> {
        let (d, runs) = (&self.d, &nl.runs);
        let panels = vec![
            TracePanel {
                y_label: "x [m]".into(),
                traces: std::iter::once(Trace {
                    label: "F_r·r (filtered reference)".into(),
                    t: runs[0].1.trace.iter().map(|s| s.t).collect(),
                    y: runs[0]
                        .1
                        .trace
                        .iter()
                        .map(|s| {
                            let tau = s.t / d.t_ref_s;
                            STEP_M * (1.0 - (1.0 + tau) * (-tau).exp())
                        })
                        .collect(),
                })
                .chain(runs.iter().map(|(l, r)| Trace {
                    label: l.clone(),
                    t: r.trace.iter().map(|s| s.t).collect(),
                    y: r.trace.iter().map(|s| s.y[0]).collect(),
                }))
                .collect(),
                references: vec![(STEP_M, "step 0.5 m".into())],
            },
            TracePanel {
                y_label: "roll, pitch [rad]".into(),
                traces: runs
                    .iter()
                    .flat_map(|(l, r)| {
                        (0..2).map(move |k| Trace {
                            label: format!("{l} {}", ["roll", "pitch"][k]),
                            t: r.trace.iter().map(|s| s.t).collect(),
                            y: r.trace.iter().map(|s| s.euler[k]).collect(),
                        })
                    })
                    .collect(),
                references: vec![],
            },
            TracePanel {
                y_label: "x [m], linear loop, worst-case Δ (Fig. 6)".into(),
                traces: linear_traces(wc),
                references: vec![(STEP_M, "step 0.5 m".into())],
            },
        ];
        let fig = self.out.join("fig5_6_x_step.svg");
        plot_traces(&fig, "Ducted fan: 50 cm x-step", &panels).map_err(|e| format!("plot: {e}"))?;
        Ok(fig)
    }
}

/// Whether a nonlinear x-step stayed up and settled at least 5 s before the end of its run.
fn settles(st: &StepStats) -> bool {
    !st.crashed && st.settling_s.is_some_and(|t| t < RUN_S - 5.0)
}

/// The x-step table's header row from its nine cells (widths match [`step_row`]).
fn step_header(c: [&str; 9]) -> String {
    format!(
        "  {:<26} {:>7} {:>10} {:>10} {:>11} {:>9} {:>9} {:>9} {:>8}",
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8]
    )
}

/// A run's numbers as a row of the x-step table: t90 and settling (s), overshoot (%), tracking
/// error, final error, cross-axis excursion (m), tilt (rad), crashed.
fn step_row(label: &str, st: &StepStats) -> String {
    format!(
        "  {label:<26} {:>7} {:>10} {:>9.2}% {:>11.4} {:>9.4} {:>9.4} {:>9.4} {:>8}",
        st.t90_s.map_or("never".into(), |t| format!("{t:.1}")),
        st.settling_s.map_or("never".into(), |t| format!("{t:.1}")),
        st.overshoot_pct,
        st.track_err_m,
        st.final_err_m,
        st.cross_m,
        st.tilt_rad,
        st.crashed
    )
}

/// The x-step table: header, the paper's row, one row per run.
fn step_table(rep: &mut Reproduction, rows: &[(String, StepStats)]) {
    rep.note(step_header([
        "run",
        "t90 s",
        "settle 2%",
        "overshoot",
        "|r_f−x| m",
        "final m",
        "y,z m",
        "tilt rad",
        "crashed",
    ]));
    rep.note(step_header([
        "paper (Fig. 5–6)",
        "-",
        "≈ 20",
        "-",
        "-",
        "-",
        "-",
        "-",
        "no",
    ]));
    for (label, st) in rows {
        rep.note(step_row(label, st));
    }
}

/// The nonlinear x-step checks on `rows` (H∞ nominal, −, +; μ nominal, −, +): both nominal steps
/// and the μ corners settle, and the H∞ step degrades more than the μ one at the corners.
fn corner_checks(rep: &mut Reproduction, rows: &[(String, StepStats)]) {
    rep.check(
        settles(&rows[0].1),
        "H∞ nominal: the nonlinear x-step settles within the run".into(),
    );
    rep.check(
        settles(&rows[3].1),
        "μ nominal: the nonlinear x-step settles within the run".into(),
    );
    rep.check(
        settles(&rows[4].1) && settles(&rows[5].1),
        "μ perturbed: the nonlinear x-step stays stable and settles at both corners".into(),
    );
    // The paper's claim (Fig. 6): where the H∞ design degrades under the perturbation, the μ design
    // does not. Reported, not enforced: it depends on the paper's unprinted weights and parameters.
    let degrade = |n: &StepStats, q: &StepStats| q.track_err_m - n.track_err_m;
    let dh = degrade(&rows[0].1, &rows[1].1).max(degrade(&rows[0].1, &rows[2].1));
    let dm = degrade(&rows[3].1, &rows[4].1).max(degrade(&rows[3].1, &rows[5].1));
    let h_crash = rows[1].1.crashed || rows[2].1.crashed;
    let reproduced = h_crash || dh > dm;
    rep.check(
        reproduced,
        format!(
            "nonlinear parametric corners (eq. (10), inside the weights): the H∞ step degrades more than the μ one \
         (worst tracking-error growth H∞ {:+.4} m, μ {:+.4} m{}); these corners barely excite either loop, so Fig. 6 \
         is checked below with the worst-case Δ in the linear loop (the Δ is not injected into the nonlinear model)",
            dh,
            dm,
            if h_crash { "; H∞ perturbed crashed" } else { "" }
        ),
    );
}

/// σ̄ of each block (Δ_α, δ_ω, Δ_x) of K∞'s destabilizing Δ, as "σ̄(name) = value" joined by commas.
fn block_sizes(rsm: &StabilityMargin) -> Result<String> {
    let st = structure()?;
    let sizes: Vec<String> = ["Δ_α", "δ_ω", "Δ_x"]
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let (cr, rr) = (st.col_range(j), st.row_range(j));
            let b = faer::Mat::from_fn(cr.len(), rr.len(), |i, k| rsm.delta[(cr.start + i, rr.start + k)]);
            let s = b
                .singular_values()
                .ok()
                .and_then(|v| v.first().copied())
                .unwrap_or(f64::NAN);
            format!("σ̄({name}) = {s:.4}")
        })
        .collect();
    Ok(sizes.join(", "))
}

/// Writes the linear x-steps (m) of `lin` (H∞ then μ, nominal and worst case) against `t_s` (s).
fn write_linear_csv(path: &Path, t_s: &[f64], lin: &[LinearPair]) -> Result<()> {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?,
    );
    let io = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    writeln!(
        f,
        "t_s,x_hinf_nominal_m,x_hinf_worst_case_m,x_mu_nominal_m,x_mu_worst_case_m"
    )
    .map_err(io)?;
    for (i, t) in t_s.iter().enumerate() {
        writeln!(
            f,
            "{t},{},{},{},{}",
            lin[0].nominal.x_m[i], lin[0].perturbed.x_m[i], lin[1].nominal.x_m[i], lin[1].perturbed.x_m[i]
        )
        .map_err(io)?;
    }
    Ok(())
}

/// The Fig. 6 claim on the linear loops with the applied Δ (`size` of the modelled uncertainty):
/// the μ loop `m` stays stable and settles, the H∞ loop `h` goes unstable or its tracking error grows
/// by more than a tenth of the step.
fn fig6_check(rep: &mut Reproduction, size: f64, h: &LinearPair, m: &LinearPair) {
    let mu_ok = m.perturbed.abscissa < 0.0 && m.perturbed.stats.0.is_some();
    let h_unstable = h.perturbed.abscissa >= 0.0;
    let h_degraded = h.perturbed.stats.2 - h.nominal.stats.2 > 0.1 * STEP_M;
    rep.check(
        mu_ok && (h_unstable || h_degraded),
        format!(
            "Fig. 6 (worst-case Δ at {:.0} % of the modelled uncertainty): the μ loop stays stable (max Re {:.2e}) and {}; \
             the H∞ loop {} (max Re {:.2e}, |r_f−x| {:.3} m vs {:.3} m nominal)",
            100.0 * size,
            m.perturbed.abscissa,
            m.perturbed
                .stats
                .0
                .map_or("does not settle".to_string(), |t| format!("settles in {t:.1} s")),
            if h_unstable {
                "is unstable"
            } else if h_degraded {
                "degrades"
            } else {
                "neither goes unstable nor degrades"
            },
            h.perturbed.abscissa,
            h.perturbed.stats.2,
            h.nominal.stats.2
        ),
    );
}

/// The linear x-steps of `wc` as traces (m), each drawn up to where it leaves ±3 steps, so that
/// diverging ones leave the others readable.
fn linear_traces(wc: &WorstCase) -> Vec<Trace> {
    let clip = |x: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let n = x
            .iter()
            .position(|v| v.is_nan() || v.abs() > 3.0 * STEP_M)
            .unwrap_or(x.len());
        (wc.t_s[..n].to_vec(), x[..n].to_vec())
    };
    wc.loops
        .iter()
        .flat_map(|pair| {
            let (tn, yn) = clip(&pair.nominal.x_m);
            let (tp, yp) = clip(&pair.perturbed.x_m);
            [
                Trace {
                    label: format!("{}, linear nominal", pair.label),
                    t: tn,
                    y: yn,
                },
                Trace {
                    label: format!("{}, linear, worst-case Δ ({:.0} %)", pair.label, 100.0 * wc.size),
                    t: tp,
                    y: yp,
                },
            ]
        })
        .collect()
}
