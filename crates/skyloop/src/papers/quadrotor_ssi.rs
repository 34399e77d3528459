//! Tai, Phang & Hoo (2018), SSI-PI for the multirotor inner loop ("Steady-State Integral PI controller for the inner loop of multirotors"):
//! eq. (32) characteristic polynomial, eq. (33) poles for Jm = J, Routh condition (35), and the
//! nonlinear step responses with Jm = J and Jm = 0.5·J under a gust (Fig. 6–8), against a plain PI.

use super::Reproduction;
use crate::error::Result;
use skyloop_plot::traces::{plot_traces, Trace, TracePanel};
use skyloop_sim::cascade::RateLaw;
use skyloop_sim::linear_models::{self, SsiLoop};
use skyloop_sim::linearize::Linearization;
use skyloop_sim::{disturbance::DisturbanceSpec, Sample, Scenario};
use std::path::{Path, PathBuf};

const SCENARIO: &str = include_str!("../../../../examples/quadrotor-ssi.toml");

/// Polynomial coefficients (descending, monic) from roots.
fn poly_from_roots(r: &[num_complex::Complex64]) -> Vec<f64> {
    let mut c = vec![num_complex::Complex64::new(1.0, 0.0)];
    for z in r {
        let mut n = vec![num_complex::Complex64::new(0.0, 0.0); c.len() + 1];
        for (i, ci) in c.iter().enumerate() {
            n[i] += ci;
            n[i + 1] -= ci * z;
        }
        c = n;
    }
    c.iter().map(|z| z.re).collect()
}

fn with_law(base: &Scenario, law: impl Fn(usize) -> RateLaw) -> Scenario {
    let mut s = base.clone();
    for i in 0..3 {
        s.controller.rate[i] = law(i);
    }
    s
}

fn roll_err(trace: &[Sample], from: f64) -> f64 {
    trace
        .iter()
        .filter(|s| s.t >= from)
        .fold(0.0, |m, s| m.max((s.reference[0] - s.euler[0]).abs()))
}

fn overshoot(trace: &[Sample], t0: f64, t1: f64, target: f64) -> f64 {
    trace
        .iter()
        .filter(|s| s.t >= t0 && s.t < t1)
        .fold(0.0f64, |m, s| m.max(s.euler[0] - target))
        / target
}

/// One nonlinear run of Fig. 6–8: its label, trace, largest roll error under the gust (rad), final
/// roll error (rad) and whether it crashed.
struct GustRun {
    label: String,
    trace: Vec<Sample>,
    gust_err_rad: f64,
    final_err_rad: f64,
    crashed: bool,
}

/// Runs the reproduction, writing traces and plots to `out`.
pub fn run(out: &Path) -> Result<Reproduction> {
    let scn = Scenario::from_toml(SCENARIO).map_err(|e| format!("embedded scenario: {e}"))?;
    let RateLaw::SsiPi { kp, ki, .. } = scn.controller.rate[0].clone() else {
        return Err("embedded scenario must use ssi_pi on roll".into());
    };
    let vehicle = scn.vehicle.resolve().and_then(|v| v.build())?;
    let j = vehicle.inertia()[0];
    let mut rep = Reproduction::new("quadrotor-ssi");
    rep.note(format!(
        "SSI-PI quadrotor (Tai, Phang & Hoo 2018): J = {j} kg·m², Kp = {kp}, Ki = {ki}, attitude gain 1"
    ));

    rep.note("\nLinear: roll axis of the linearized quadrotor (motors residualized), SSI-PI loop closed");
    let roll = linear_models::quad_roll_axis(&vehicle)?;
    for frac in [1.0, 0.5] {
        linear_loop_checks(&mut rep, &roll, j, kp, ki, frac)?;
    }
    routh_sweep(&mut rep, &roll, j, kp, ki)?;

    let results = gust_runs(&mut rep, &scn, vehicle.nu(), out)?;
    gust_checks(&mut rep, &results);
    rate_step_check(&mut rep, &scn)?;

    let path = roll_figure(out, &results)?;
    rep.note(format!(
        "\nwrote {} and per-run CSV/SVG in {}",
        path.display(),
        out.display()
    ));
    rep.artifact(&path);
    super::write_report(
        &mut rep,
        "SSI-PI quadrotor (Tai, Phang & Hoo 2018): claims reproduced",
        out,
    )?;
    Ok(rep)
}

/// The linearized roll axis `roll` with the SSI-PI loop closed (Kp in N·m per rad/s, Ki in 1/s,
/// Jm = `frac`·J with J = `j` kg·m², attitude gain 1): its characteristic polynomial against
/// eq. (32), its poles against eq. (33)'s factorization when Jm = J, and its stability against the
/// Routh condition (35).
fn linear_loop_checks(rep: &mut Reproduction, roll: &Linearization, j: f64, kp: f64, ki: f64, frac: f64) -> Result<()> {
    let c = SsiLoop {
        kp,
        ki,
        jm: frac * j,
        k_att: 1.0,
    };
    let cl = linear_models::ssi_closed_loop(roll, "roll_rad", "p_rad_s", "mx_n_m", c)?;
    let poles = linear_models::eigenvalues(&cl.a)?;
    let got = poly_from_roots(&poles);
    let want = linear_models::eq32_charpoly(j, c);
    let rel = got
        .iter()
        .zip(want.iter())
        .map(|(g, w)| (g - w).abs() / w.abs())
        .fold(0.0, f64::max);
    rep.note(format!(
        "  Jm = {frac}·J: closed-loop char. poly {:?}",
        got.iter().map(|v| format!("{v:.6}")).collect::<Vec<_>>()
    ));
    rep.note(format!(
        "               eq. (32)               {:?}",
        want.iter().map(|v| format!("{v:.6}")).collect::<Vec<_>>()
    ));
    rep.check(
        rel < 1e-6,
        format!("eq. (32) coefficients match (Jm = {frac}·J), max rel. error {rel:.1e}"),
    );
    let pstr: Vec<String> = poles.iter().map(|p| format!("{:.4}{:+.4}j", p.re, p.im)).collect();
    rep.note(format!("               poles {}", pstr.join(", ")));
    if frac == 1.0 {
        eq33_check(rep, &poles, kp / j, ki);
    }
    let max_re = poles.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.re));
    let routh = linear_models::routh_eq35(j, c);
    rep.check(
        routh == (max_re < 0.0),
        format!("Routh (35) says stable = {routh}, eigenvalues: max Re = {max_re:.4}"),
    );
    Ok(())
}

/// Eq. (33) for Jm = J: the closed-loop `poles` are −Ki (`ki`, 1/s) and the roots of
/// s² + a·s + a with `a` = Kp/J; notes the roots and checks the largest distance to them.
fn eq33_check(rep: &mut Reproduction, poles: &[num_complex::Complex64], a: f64, ki: f64) {
    let disc = a * a - 4.0 * a;
    let r = if disc >= 0.0 {
        vec![(-a - disc.sqrt()) / 2.0, (-a + disc.sqrt()) / 2.0, -ki]
    } else {
        vec![-ki]
    };
    let worst = r
        .iter()
        .map(|z| {
            poles
                .iter()
                .map(|p| (p - num_complex::Complex64::new(*z, 0.0)).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    rep.note(format!(
        "               eq. (33) roots: −Ki = {}, s² + (Kp/J)s + Kp/J → {:?}",
        -ki,
        &r[..r.len().min(2)]
    ));
    rep.check(
        worst < 1e-6 * ki,
        format!("poles equal eq. (33)'s factorization (max distance {worst:.1e})"),
    );
}

/// The Routh condition (35) swept across its boundary (Jm from −J to 2J, four (Kp, Ki) pairs): it
/// must agree with the eigenvalues wherever the loop is not marginal.
fn routh_sweep(rep: &mut Reproduction, roll: &Linearization, j: f64, kp: f64, ki: f64) -> Result<()> {
    let mut agree = 0;
    let mut total = 0;
    for frac in [-1.0, -0.5, -0.1, 0.0, 0.01, 0.1, 0.5, 1.0, 2.0] {
        for (kp2, ki2) in [(kp, ki), (0.001, 0.5), (0.0005, 2.0), (0.002, 50.0)] {
            let c = SsiLoop {
                kp: kp2,
                ki: ki2,
                jm: frac * j,
                k_att: 1.0,
            };
            let cl = linear_models::ssi_closed_loop(roll, "roll_rad", "p_rad_s", "mx_n_m", c)?;
            let max_re = linear_models::eigenvalues(&cl.a)?
                .iter()
                .fold(f64::NEG_INFINITY, |m, p| m.max(p.re));
            if max_re.abs() > 1e-9 {
                total += 1;
                agree += (linear_models::routh_eq35(j, c) == (max_re < 0.0)) as usize;
            }
        }
    }
    rep.check(
        agree == total,
        format!("Routh (35) agrees with eigenvalues on {agree}/{total} (Kp, Ki, Jm) cases"),
    );
    Ok(())
}

/// The nonlinear 6-DOF runs of Fig. 6–8 (roll step 0.2 rad at 1 s, then the scenario's torque
/// gust): SSI-PI with Jm = J and 0.5·J and the plain PI, each tabulated and written as CSV/SVG
/// (`nu` motor channels) into `out`.
fn gust_runs(rep: &mut Reproduction, scn: &Scenario, nu: usize, out: &Path) -> Result<Vec<GustRun>> {
    rep.note("\nNonlinear 6-DOF simulation (RK4 1 kHz, motors, gyro noise): roll step 0.2 rad at 1 s, gust torque");
    let t_gust = scn
        .disturbance
        .iter()
        .find_map(|d| match d {
            DisturbanceSpec::TorqueGust { t_on_s, .. } => Some(*t_on_s),
            _ => None,
        })
        .ok_or("embedded scenario has no torque_gust")?;
    let runs = [
        (
            "ssi_jm_1.0",
            "SSI-PI, Jm = J (Fig. 6)",
            with_law(scn, |i| ssi(scn, i, 1.0)),
        ),
        (
            "ssi_jm_0.5",
            "SSI-PI, Jm = 0.5·J (Fig. 7)",
            with_law(scn, |i| ssi(scn, i, 0.5)),
        ),
        ("pi", "PI (same Kp, Ki·Kp)", with_law(scn, |i| pi(scn, i))),
    ];
    let mut results = Vec::new();
    rep.note(format!(
        "  {:<28} {:>12} {:>14} {:>14} {:>9}",
        "controller", "overshoot %", "gust err rad", "final err rad", "crashed"
    ));
    for (stem, label, s) in &runs {
        let (trace, m) = skyloop_sim::simulate(s)?;
        let os = 100.0 * overshoot(&trace, 1.0, t_gust, 0.2);
        let ge = roll_err(&trace, t_gust);
        let fe = trace
            .last()
            .map_or(f64::INFINITY, |s| (s.reference[0] - s.euler[0]).abs());
        rep.note(format!(
            "  {label:<28} {os:>12.2} {ge:>14.5} {fe:>14.5} {:>9}",
            m.crashed
        ));
        crate::simulation::write_run(out, stem, label, &trace, nu)?;
        rep.artifact(&out.join(format!("{stem}.csv")));
        results.push(GustRun {
            label: label.to_string(),
            trace,
            gust_err_rad: ge,
            final_err_rad: fe,
            crashed: m.crashed,
        });
    }
    Ok(results)
}

/// The paper's claims on the gust runs (SSI-PI Jm = J, Jm = 0.5·J, PI): no crash, the gust error
/// bounded by 0.05 rad, the constant disturbance eliminated, and Jm = 0.5·J no better than Jm = J.
fn gust_checks(rep: &mut Reproduction, results: &[GustRun]) {
    let (ideal, half) = (&results[0], &results[1]);
    rep.check(
        !ideal.crashed && !half.crashed,
        "no crash with Jm = J or Jm = 0.5·J".into(),
    );
    rep.check(
        ideal.gust_err_rad < 0.05,
        format!(
            "Jm = J: angle error under the gust bounded by 0.05 rad ({:.4})",
            ideal.gust_err_rad
        ),
    );
    rep.check(
        half.gust_err_rad < 0.05,
        format!(
            "Jm = 0.5·J: angle error under the gust bounded by 0.05 rad ({:.4})",
            half.gust_err_rad
        ),
    );
    rep.check(
        ideal.final_err_rad < 0.005 && half.final_err_rad < 0.005,
        "constant disturbance eliminated: final error < 0.005 rad".into(),
    );
    rep.check(
        half.gust_err_rad >= ideal.gust_err_rad,
        "Jm = 0.5·J is not as good as the ideal case (larger gust error)".into(),
    );
}

/// The rate loop alone: a 1 rad/s roll-rate step (rate mode, no gust, 2 s) with SSI-PI (Jm = J)
/// and with the PI; notes each overshoot (%) and checks that SSI-PI's is the smaller.
fn rate_step_check(rep: &mut Reproduction, scn: &Scenario) -> Result<()> {
    // The attitude loop's slow pole (≈ −1 s⁻¹) hides the inner loops' difference; compare the rate loop:
    // SSI-PI (Jm = J) has the real poles −Ki, −Kp/J, the PI the pair of J·s² + Kp·s + Kp·Ki.
    rep.note("\n  rate loop, 1 rad/s roll-rate step (rate mode, no gust):");
    let mut rate_os = Vec::new();
    for (label, law) in [("SSI-PI, Jm = J", 0usize), ("PI", 1usize)] {
        let mut s = if law == 0 {
            with_law(scn, |i| ssi(scn, i, 1.0))
        } else {
            with_law(scn, |i| pi(scn, i))
        };
        s.controller.mode = skyloop_sim::cascade::Mode::Rate;
        s.disturbance.clear();
        s.sim.duration_s = 2.0;
        let step = |t_s: f64, p: f64| skyloop_sim::scenario::RefStep {
            t_s,
            attitude_rad: None,
            position_m: None,
            rate_rad_s: Some([p, 0.0, 0.0]),
        };
        s.reference = vec![step(0.0, 0.0), step(0.5, 1.0), step(0.9, 0.0)];
        let (trace, _) = skyloop_sim::simulate(&s)?;
        let os = trace
            .iter()
            .filter(|x| x.t >= 0.5 && x.t < 0.9)
            .fold(0.0f64, |m, x| m.max(x.rates[0] - 1.0));
        rep.note(format!("    {label:<16} overshoot {:.2} %", 100.0 * os));
        rate_os.push(os);
    }
    rep.check(
        rate_os[0] < rate_os[1],
        format!(
            "SSI-PI rate step overshoots less than PI ({:.2} % vs {:.2} %)",
            100.0 * rate_os[0],
            100.0 * rate_os[1]
        ),
    );
    Ok(())
}

/// Fig. 6–8: roll (rad) of every gust run beside the reference, and their roll errors (rad) with
/// the 0.05 rad bound, written as `fig6_8_roll.svg` in `out`; returns its path.
fn roll_figure(out: &Path, results: &[GustRun]) -> Result<PathBuf> {
    let ideal = &results[0];
    let t: Vec<f64> = ideal.trace.iter().map(|s| s.t).collect();
    let err = |r: &GustRun| Trace {
        label: r.label.clone(),
        t: r.trace.iter().map(|s| s.t).collect(),
        y: r.trace.iter().map(|s| s.reference[0] - s.euler[0]).collect(),
    };
    let fig8 = TracePanel {
        y_label: "roll error [rad]".into(),
        traces: results.iter().map(err).collect(),
        references: vec![(0.05, "0.05 rad bound".into()), (-0.05, "".into())],
    };
    let step = TracePanel {
        y_label: "roll [rad]".into(),
        traces: std::iter::once(Trace {
            label: "reference".into(),
            t: t.clone(),
            y: ideal.trace.iter().map(|s| s.reference[0]).collect(),
        })
        .chain(results.iter().map(|r| Trace {
            label: r.label.clone(),
            t: r.trace.iter().map(|s| s.t).collect(),
            y: r.trace.iter().map(|s| s.euler[0]).collect(),
        }))
        .collect(),
        references: vec![],
    };
    let path = out.join("fig6_8_roll.svg");
    plot_traces(&path, "SSI-PI quadrotor: roll step and gust", &[step, fig8]).map_err(|e| format!("plot: {e}"))?;
    Ok(path)
}

fn ssi(scn: &Scenario, axis: usize, frac: f64) -> RateLaw {
    match scn.controller.rate[axis].clone() {
        RateLaw::SsiPi { kp, ki, .. } => RateLaw::SsiPi {
            kp,
            ki,
            jm_fraction: frac,
        },
        other => other,
    }
}

fn pi(scn: &Scenario, axis: usize) -> RateLaw {
    match scn.controller.rate[axis].clone() {
        RateLaw::SsiPi { kp, ki, .. } => RateLaw::Pid {
            kp,
            ki: ki * kp,
            kd: 0.0,
            tf_s: 0.0,
            i_limit_n_m: 1e9,
        },
        other => other,
    }
}
