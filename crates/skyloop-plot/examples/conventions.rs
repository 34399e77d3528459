//! Renders every plot kind for a delayed loop and writes an HTML report with interactive figures.
//!
//! The plant is P(s) = 0.0887·e^(−0.032 s)/(0.0256 s + 1) · (42² − s²)/s · 2.221e5/(s² + 666.4 s +
//! 2.221e5) and the controller a PI, C(s) = 0.05 (s + 2)/s; responses are computed here with plain
//! complex arithmetic, as any caller of this data-only crate would.
//!
//! `cargo run -p skyloop-plot --example conventions -- /tmp/plots` (default directory: the system
//! temporary directory).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::f64::consts::PI;
use std::path::PathBuf;

use num_complex::Complex64 as C;
use skyloop_plot::bode::{bode_figure, bode_mimo_figure, BodeData, BodeMarks, IoNames};
use skyloop_plot::nichols::{nichols_figure, DEFAULT_M_DB};
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::pzmap::{pzmap_figure, rlocus_figure, PoleZeroData, RootLocusData};
use skyloop_plot::sigma::{sigma_figure, SigmaData};
use skyloop_plot::traces::{step_figure, Trace};
use skyloop_plot::Report;

fn plant(s: C) -> C {
    0.0887 * (-0.032 * s).exp() / (0.0256 * s + 1.0) * (42.0 * 42.0 - s * s) / s * 2.221e5
        / (s * s + 666.4 * s + 2.221e5)
}

fn controller(s: C) -> C {
    0.05 * (s + 2.0) / s
}

/// Log-spaced frequencies, Hz.
fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 10f64.powf(lo + (hi - lo) * i as f64 / (n - 1) as f64))
        .collect()
}

/// Bode data with the phase unwrapped along the grid.
fn bode(label: &str, f: &[f64], h: &dyn Fn(C) -> C) -> BodeData {
    let mut phase = Vec::with_capacity(f.len());
    let mut prev: Option<f64> = None;
    let mut mag = Vec::with_capacity(f.len());
    for &fi in f {
        let z = h(C::new(0.0, 2.0 * PI * fi));
        mag.push(20.0 * z.norm().log10());
        let mut p = z.arg().to_degrees();
        if let Some(q) = prev {
            p += 360.0 * ((q - p) / 360.0).round();
        }
        prev = Some(p);
        phase.push(p);
    }
    BodeData {
        label: label.into(),
        freq_hz: f.to_vec(),
        mag_db: mag,
        phase_deg: phase,
    }
}

/// Linear interpolation of the first crossing of `level` in `y` over `x` (log x).
fn crossing(x: &[f64], y: &[f64], level: f64) -> Option<(usize, f64)> {
    (1..x.len()).find_map(|i| {
        let (a, b) = (y[i - 1] - level, y[i] - level);
        (a.signum() != b.signum()).then(|| {
            let t = a / (a - b);
            (i, 10f64.powf(x[i - 1].log10() + t * (x[i].log10() - x[i - 1].log10())))
        })
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("skyloop-plot-conventions"));
    std::fs::create_dir_all(&dir)?;
    let f = grid(-2.0, 3.0, 1500);
    let loop_tf = |s: C| plant(s) * controller(s);
    let l = bode("L = P·C", &f, &loop_tf);
    let p = bode("P", &f, &plant);
    // Margins read off the grid.
    let (_, wc) = crossing(&f, &l.mag_db, 0.0).ok_or("no crossover")?;
    let pm = 180.0 + interp(&f, &l.phase_deg, wc);
    let (_, w180) = crossing(&f, &l.phase_deg, -180.0).ok_or("no phase crossover")?;
    let gm = -interp(&f, &l.mag_db, w180);
    let marks = BodeMarks {
        crossover_hz: Some(wc),
        gain_margin: Some((gm, w180)),
        phase_margin: Some((pm, wc)),
        ..BodeMarks::default()
    };
    let mut report = Report::new("skyloop-plot conventions: a delayed loop");
    let bode_fig = bode_figure("Loop transfer L = P·C (delay 32 ms)", &[l.clone(), p.clone()], &marks);
    bode_fig.save(&dir.join("bode.svg"))?;

    // A 2×2 plant: the delayed channel and scaled/filtered copies.
    let g = |i: usize, j: usize| {
        move |s: C| match (i, j) {
            (0, 0) => plant(s),
            (0, 1) => 0.3 * plant(s) / (0.1 * s + 1.0),
            (1, 0) => 2.0 / (s + 3.0),
            _ => 10.0 / ((s + 1.0) * (0.05 * s + 1.0)),
        }
    };
    let sys: Vec<Vec<BodeData>> = (0..2)
        .map(|i| (0..2).map(|j| bode("G", &f, &g(i, j))).collect())
        .collect();
    let scaled: Vec<Vec<BodeData>> = (0..2)
        .map(|i| {
            (0..2)
                .map(|j| bode("G with 2 ms more delay", &f, &|s: C| g(i, j)(s) * (-0.002 * s).exp()))
                .collect()
        })
        .collect();
    let names = IoNames {
        inputs: vec!["thrust".into(), "tilt".into()],
        outputs: vec!["roll".into(), "pitch".into()],
    };
    let mimo = bode_mimo_figure("MIMO plant G", &[sys, scaled], &names);
    mimo.save(&dir.join("bode_mimo.svg"))?;

    let ny = NyquistData {
        label: "L".into(),
        re: f.iter().map(|fi| loop_tf(C::new(0.0, 2.0 * PI * fi)).re).collect(),
        im: f.iter().map(|fi| loop_tf(C::new(0.0, 2.0 * PI * fi)).im).collect(),
    };
    let nyq = nyquist_figure("Nyquist of L", std::slice::from_ref(&ny), Some(2.5));
    nyq.save(&dir.join("nyquist.svg"))?;
    nyquist_figure("Nyquist of L (automatic view)", &[ny], None).save(&dir.join("nyquist_auto.svg"))?;

    let nic = nichols_figure("Nichols chart of L", std::slice::from_ref(&l), &DEFAULT_M_DB);
    nic.save(&dir.join("nichols.svg"))?;

    // Singular values of the 2×2 plant (closed form for 2×2).
    let sv: Vec<Vec<f64>> = f
        .iter()
        .map(|fi| {
            let s = C::new(0.0, 2.0 * PI * fi);
            let m = [[g(0, 0)(s), g(0, 1)(s)], [g(1, 0)(s), g(1, 1)(s)]];
            let fro: f64 = m.iter().flatten().map(|z| z.norm_sqr()).sum();
            let det = (m[0][0] * m[1][1] - m[0][1] * m[1][0]).norm();
            let disc = (fro * fro - 4.0 * det * det).max(0.0).sqrt();
            let s1 = ((fro + disc) / 2.0).sqrt();
            let s2 = ((fro - disc).max(0.0) / 2.0).sqrt();
            vec![20.0 * s1.log10(), 20.0 * s2.log10()]
        })
        .collect();
    let sig = sigma_figure(
        "Singular values of G",
        &[SigmaData {
            label: "G".into(),
            freq_hz: f.clone(),
            sv_db: sv,
        }],
    );
    sig.save(&dir.join("sigma.svg"))?;

    // Poles and zeros of the rational part of P.
    let wd = (2.221e5f64 - 333.2f64 * 333.2).sqrt();
    let pz = PoleZeroData {
        label: "P".into(),
        poles: vec![
            C::new(0.0, 0.0),
            C::new(-1.0 / 0.0256, 0.0),
            C::new(-333.2, wd),
            C::new(-333.2, -wd),
        ],
        zeros: vec![C::new(42.0, 0.0), C::new(-42.0, 0.0)],
    };
    let pzf = pzmap_figure("Poles and zeros of P (rational part)", &[pz], false);
    pzf.save(&dir.join("pzmap.svg"))?;
    // The same poles sampled at 1 kHz (z = e^(sT)): the boundary is the unit circle.
    let ts = 1e-3;
    let zd = PoleZeroData {
        label: "P at 1 kHz".into(),
        poles: [
            C::new(0.0, 0.0),
            C::new(-1.0 / 0.0256, 0.0),
            C::new(-333.2, wd),
            C::new(-333.2, -wd),
        ]
        .iter()
        .map(|p| (p * ts).exp())
        .collect(),
        zeros: vec![C::new(42.0 * ts, 0.0).exp(), C::new(-42.0 * ts, 0.0).exp()],
    };
    pzmap_figure("Discrete poles and zeros", &[zd], true).save(&dir.join("pzmap_discrete.svg"))?;

    // Root locus of k/(s(s+2)(s+5)): roots of s³ + 7s² + 10s + k.
    let gains: Vec<f64> = (0..400).map(|i| 10f64.powf(-2.0 + 4.0 * i as f64 / 399.0)).collect();
    let poles: Vec<Vec<C>> = gains.iter().map(|k| roots(&[1.0, 7.0, 10.0, *k])).collect();
    let rl = rlocus_figure(
        "Root locus of k/(s(s+2)(s+5))",
        &RootLocusData {
            gains,
            poles,
            open_loop_poles: vec![C::new(0.0, 0.0), C::new(-2.0, 0.0), C::new(-5.0, 0.0)],
            open_loop_zeros: vec![],
        },
        false,
    );
    rl.save(&dir.join("rlocus.svg"))?;

    // Step of ωn²/(s² + 2ζωn s + ωn²) with its characteristics computed from the trace.
    let (z, wn) = (0.35f64, 6.0f64);
    let wdd = wn * (1.0 - z * z).sqrt();
    let t: Vec<f64> = (0..=600).map(|i| i as f64 * 0.005).collect();
    let y: Vec<f64> = t
        .iter()
        .map(|t| 1.0 - (-z * wn * t).exp() * ((wdd * t).cos() + z / (1.0 - z * z).sqrt() * (wdd * t).sin()))
        .collect();
    let info = skyloop_lti::timeresp::stepinfo(&t, &y, Some(1.0));
    let step = step_figure(
        "Step response with its characteristics",
        &[Trace {
            label: "y (ζ = 0.35, ωn = 6 rad/s)".into(),
            t,
            y,
        }],
        &[info],
    );
    step.save(&dir.join("step.svg"))?;

    // Curves through every corner: the legend has to go outside, on the right.
    let tt: Vec<f64> = (0..=500).map(|i| i as f64 * 0.01).collect();
    let crowded = skyloop_plot::traces::traces_figure(
        "Three oscillations filling the axes",
        &[skyloop_plot::traces::TracePanel {
            y_label: "signal [V]".into(),
            traces: (0..3)
                .map(|k| Trace {
                    label: format!("channel {} (noisy)", k + 1),
                    t: tt.clone(),
                    y: tt.iter().map(|t| (2.0 * PI * (1.0 + k as f64) * t).sin()).collect(),
                })
                .collect(),
            references: vec![],
        }],
    );
    crowded.save(&dir.join("legend_outside.svg"))?;

    report
        .section("Loop")
        .text(format!("PM {pm:.1}° at {wc:.3} Hz, GM {gm:.2} dB at {w180:.3} Hz."))
        .interactive_figure(bode_fig, "Bode plot of L and P")
        .interactive_figure(nyq, "Nyquist plot of L")
        .interactive_figure(nic, "Nichols chart")
        .figure(step, "Step response");
    report
        .section("MIMO")
        .interactive_figure(mimo, "MIMO Bode grid")
        .figure(sig, "Singular values")
        .figure(pzf, "Pole-zero map")
        .figure(rl, "Root locus");
    report.save(&dir.join("report.html"))?;
    println!("wrote plots and report.html to {}", dir.display());
    Ok(())
}

/// `y(x)` at `at` by linear interpolation in log x.
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    for i in 1..x.len() {
        if x[i - 1] <= at && at <= x[i] {
            let t = (at.log10() - x[i - 1].log10()) / (x[i].log10() - x[i - 1].log10());
            return y[i - 1] + t * (y[i] - y[i - 1]);
        }
    }
    f64::NAN
}

/// Roots of a monic-or-not polynomial (coefficients from the highest power) by Durand–Kerner.
fn roots(c: &[f64]) -> Vec<C> {
    let n = c.len() - 1;
    let a: Vec<C> = c.iter().map(|v| C::new(v / c[0], 0.0)).collect();
    let mut z: Vec<C> = (0..n).map(|k| C::new(0.4, 0.9).powu(k as u32)).collect();
    for _ in 0..500 {
        for i in 0..n {
            let p = a.iter().fold(C::new(0.0, 0.0), |acc, ak| acc * z[i] + ak);
            let d = (0..n)
                .filter(|j| *j != i)
                .fold(C::new(1.0, 0.0), |acc, j| acc * (z[i] - z[j]));
            z[i] -= p / d;
        }
    }
    z
}
