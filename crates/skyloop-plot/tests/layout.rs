//! No legend hides a label and no two value labels hide each other, in one representative figure of
//! every kind, judged from the boxes the renderer placed ([`skyloop_plot::layout`]).
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use num_complex::Complex64;
use skyloop_plot::bode::{
    bode_figure, bode_figure_marked, bode_mimo_figure, BodeData, BodeMarks, BodeOptions, IoNames,
};
use skyloop_plot::frf::{frf_figure, FrfEstimate};
use skyloop_plot::heatmap::{Heatmap, Overlay};
use skyloop_plot::hsv::hsv_figure;
use skyloop_plot::layout::{BoxKind, Layout};
use skyloop_plot::mu::{mu_figure, MuCurve};
use skyloop_plot::nichols::{nichols_figure, DEFAULT_M_DB};
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::pzmap::{pzmap_figure, rlocus_figure, PoleZeroData, RootLocusData};
use skyloop_plot::sigma::{sigma_figure_with_targets, SigmaData, SigmaTarget};
use skyloop_plot::traces::{step_figure, traces_figure, Trace, TracePanel};

/// `n` frequencies from 10^lo to 10^hi Hz, evenly spaced in log.
fn freqs(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 10f64.powf(lo + (hi - lo) * i as f64 / (n - 1) as f64))
        .collect()
}

/// Bode data of `l(jω)` at `f` Hz, the phase unwrapped.
fn bode_of(label: &str, f: &[f64], l: impl Fn(f64) -> Complex64) -> BodeData {
    let v: Vec<Complex64> = f.iter().map(|f| l(2.0 * std::f64::consts::PI * f)).collect();
    let mut phase: Vec<f64> = Vec::with_capacity(v.len());
    for z in &v {
        let p = z.arg().to_degrees();
        let p = match phase.last() {
            Some(q) => p + 360.0 * ((q - p) / 360.0).round(),
            None => p,
        };
        phase.push(p);
    }
    BodeData {
        label: label.into(),
        freq_hz: f.to_vec(),
        mag_db: v.iter().map(|z| 20.0 * z.norm().log10()).collect(),
        phase_deg: phase,
    }
}

/// The loop shape, k·e^(−0.02s)/(s(0.03s+1)) (100 in the issue: unstable; 30: crossover
/// 3.8 Hz, gain margin 5.3 dB at 5.9 Hz).
fn delayed_loop(k: f64, w: f64) -> Complex64 {
    let s = Complex64::new(0.0, w);
    k * (-0.02 * s).exp() / (s * (0.03 * s + 1.0))
}

/// The margins of `d` read off its grid (crossover and phase crossover by linear interpolation).
fn marks_of(d: &BodeData) -> BodeMarks {
    let cross = |v: &[f64], level: f64| {
        let k = v.windows(2).position(|w| (w[0] - level) * (w[1] - level) <= 0.0)?;
        let t = (level - v[k]) / (v[k + 1] - v[k]);
        Some((k, d.freq_hz[k] + t * (d.freq_hz[k + 1] - d.freq_hz[k])))
    };
    let (kc, fc) = cross(&d.mag_db, 0.0).unwrap();
    let (kg, fg) = cross(&d.phase_deg, -180.0).unwrap();
    BodeMarks {
        crossover_hz: Some(fc),
        gain_margin: Some((-d.mag_db[kg], fg)),
        phase_margin: Some((180.0 + d.phase_deg[kc], fc)),
        ..BodeMarks::default()
    }
}

/// The unit step response of ωn²/(s² + 2ζωn s + ωn²) times `gain`, over `t_end` s.
fn second_order_step(zeta: f64, wn: f64, gain: f64, t_end: f64) -> Trace {
    let t: Vec<f64> = (0..=(t_end / 0.01) as usize).map(|k| k as f64 * 0.01).collect();
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let y = t
        .iter()
        .map(|t| {
            let e = (-zeta * wn * t).exp();
            gain * (1.0 - e * ((wd * t).cos() + zeta * wn / wd * (wd * t).sin()))
        })
        .collect();
    Trace {
        label: "y for r = 1 (final controller)".into(),
        t,
        y,
    }
}

fn every_figure() -> Vec<(&'static str, Layout)> {
    let f = freqs(-2.0, 2.5, 400);
    let l = bode_of("L", &f, |w| delayed_loop(100.0, w));
    let lag = bode_of("lag", &f, |w| 1.0 / Complex64::new(1.0, w / 3.0));
    let mut out: Vec<(&'static str, Layout)> = Vec::new();
    let mut add = |name, fig: skyloop_plot::Figure| out.push((name, fig.layout().unwrap()));

    add(
        "bode --margins",
        bode_figure("Bode", std::slice::from_ref(&l), &marks_of(&l)),
    );
    // The margins in the right third, where a legend goes first.
    let tight = bode_of("L", &freqs(-1.0, 1.3, 300), |w| delayed_loop(30.0, w));
    add(
        "bode --margins, tight grid",
        bode_figure("Bode", std::slice::from_ref(&tight), &marks_of(&tight)),
    );
    // As the design report draws its loop: two controllers, the final one's margins marked.
    let ft = freqs(-1.0, 1.0, 300);
    let full = bode_of("L with full controller", &ft, |w| delayed_loop(32.0, w));
    let reduced = bode_of("L with reduced controller", &ft, |w| delayed_loop(30.0, w));
    add(
        "design loop",
        bode_figure("Loop transfer L = P·C", &[full, reduced.clone()], &marks_of(&reduced)),
    );
    let l2 = bode_of("L, retuned", &f, |w| delayed_loop(60.0, w));
    add(
        "bode, two tunes marked",
        bode_figure_marked(
            "Loop transfer, flown and proposed",
            &[l.clone(), l2.clone()],
            &[marks_of(&l), marks_of(&l2)],
            &BodeOptions::default(),
        ),
    );
    let grid = vec![vec![lag.clone(), l.clone()], vec![l2.clone(), lag.clone()]];
    add("bode mimo", bode_mimo_figure("MIMO", &[grid], &IoNames::default()));

    let w: Vec<f64> = f.iter().map(|f| 2.0 * std::f64::consts::PI * f).collect();
    let nyq = NyquistData {
        label: "L".into(),
        re: w.iter().map(|w| delayed_loop(30.0, *w).re).collect(),
        im: w.iter().map(|w| delayed_loop(30.0, *w).im).collect(),
    };
    add("nyquist", nyquist_figure("Nyquist", &[nyq], None));
    add(
        "nichols",
        nichols_figure("Nichols", std::slice::from_ref(&l), &DEFAULT_M_DB),
    );

    let sv = SigmaData {
        label: "G".into(),
        freq_hz: f.clone(),
        sv_db: lag.mag_db.iter().map(|m| vec![*m, m - 12.0]).collect(),
    };
    let target = SigmaTarget {
        label: "target".into(),
        freq_hz: f.clone(),
        mag_db: f.iter().map(|f| -20.0 * f.log10()).collect(),
    };
    add("sigma", sigma_figure_with_targets("Singular values", &[sv], &[target]));

    let c = |re: f64, im: f64| Complex64::new(re, im);
    let pz = PoleZeroData {
        label: "G".into(),
        poles: vec![c(-1.0, 2.0), c(-1.0, -2.0), c(-5.0, 0.0)],
        zeros: vec![c(-3.0, 0.0)],
    };
    add("pzmap", pzmap_figure("Poles and zeros", &[pz], false));
    let gains: Vec<f64> = (0..60).map(|k| 0.1 * k as f64).collect();
    let poles = gains
        .iter()
        .map(|k| {
            // s² + 2s + 2 + k(s + 3) = 0.
            let (b, cc) = (2.0 + k, 2.0 + 3.0 * k);
            let d = Complex64::new(b * b - 4.0 * cc, 0.0).sqrt();
            vec![(-b + d) / 2.0, (-b - d) / 2.0]
        })
        .collect();
    let rl = RootLocusData {
        gains,
        poles,
        open_loop_poles: vec![c(-1.0, 1.0), c(-1.0, -1.0)],
        open_loop_zeros: vec![c(-3.0, 0.0)],
    };
    add("rlocus", rlocus_figure("Root locus", &rl, false));

    // As the design report draws it: the window 1.5× the settling time, so the settling time's
    // note sits in the upper right, where the legend goes first.
    let long = second_order_step(0.7, 4.0, 1.0, 10.0);
    let ts = skyloop_lti::timeresp::stepinfo(&long.t, &long.y, Some(1.0))
        .settling_time_s
        .unwrap();
    let step = second_order_step(0.7, 4.0, 1.0, 1.5 * ts);
    let info = skyloop_lti::timeresp::stepinfo(&step.t, &step.y, Some(1.0));
    add(
        "design step",
        step_figure("Closed-loop step response", std::slice::from_ref(&step), &[info]),
    );
    for zeta in [0.3, 0.5, 0.6, 0.8, 0.9, 1.0] {
        let long = second_order_step(zeta, 4.0, 1.0, 20.0);
        let ts = skyloop_lti::timeresp::stepinfo(&long.t, &long.y, Some(1.0))
            .settling_time_s
            .unwrap();
        let st = second_order_step(zeta, 4.0, 1.0, 1.5 * ts);
        let info = skyloop_lti::timeresp::stepinfo(&st.t, &st.y, Some(1.0));
        add(
            "design step, other damping",
            step_figure("Closed-loop step response", &[st], &[info]),
        );
    }
    // The design report's shape: a non-minimum-phase closed loop (undershoot) with a slow tail
    // from a nearly cancelled pole, on 1.5× its settling time.
    let t_nmp = skyloop_lti::expr::parse_model("(1-0.08*s)*(0.53*s+1)/((0.05*s+1)^2*(0.5*s+1))").unwrap();
    let long = skyloop_lti::timeresp::step(&t_nmp, None).unwrap();
    let ts = skyloop_lti::timeresp::stepinfo(&long.t_s, &long.y[0][0], Some(1.0))
        .settling_time_s
        .unwrap();
    let grid: Vec<f64> = (0..=500).map(|k| 1.5 * ts * k as f64 / 500.0).collect();
    let nmp = Trace {
        label: "y for r = 1 (final controller)".into(),
        y: skyloop_lti::timeresp::step(&t_nmp, Some(&grid)).unwrap().y[0][0].clone(),
        t: grid,
    };
    let info = skyloop_lti::timeresp::stepinfo(&nmp.t, &nmp.y, Some(1.0));
    add(
        "design step, non-minimum phase",
        step_figure("Closed-loop step response T = PC/(1+PC)", &[nmp], &[info]),
    );
    // Two traces whose notes crowd the same upper region (either one the slower).
    for (z1, z2) in [(0.7, 0.45), (0.45, 0.7)] {
        let long = second_order_step(z1, 4.0, 1.0, 20.0);
        let ts = skyloop_lti::timeresp::stepinfo(&long.t, &long.y, Some(1.0))
            .settling_time_s
            .unwrap();
        let first = second_order_step(z1, 4.0, 1.0, 1.5 * ts);
        let mut other = second_order_step(z2, 6.0, 1.0, 1.5 * ts);
        other.label = "retuned".into();
        let infos: Vec<_> = [&first, &other]
            .iter()
            .map(|t| skyloop_lti::timeresp::stepinfo(&t.t, &t.y, Some(1.0)))
            .collect();
        add("step, two traces", step_figure("Step", &[first, other], &infos));
    }
    let tp = TracePanel {
        y_label: "rate [deg/s]".into(),
        traces: vec![step.clone()],
        references: vec![(1.0, "setpoint".into())],
    };
    add("traces", traces_figure("Traces", &[tp]));

    let mu = MuCurve {
        label: "RS".into(),
        freq_hz: f.clone(),
        upper: lag.mag_db.iter().map(|m| 1.3 * 10f64.powf(m / 20.0)).collect(),
        lower: lag.mag_db.iter().map(|m| 1.2 * 10f64.powf(m / 20.0)).collect(),
    };
    add("mu", mu_figure("μ", &[mu]));
    let est = FrfEstimate {
        freq_hz: f.clone(),
        mag_db: lag.mag_db.clone(),
        phase_deg: lag.phase_deg.clone(),
        mag_band_db: (
            lag.mag_db.iter().map(|m| m - 1.0).collect(),
            lag.mag_db.iter().map(|m| m + 1.0).collect(),
        ),
        phase_band_deg: (
            lag.phase_deg.iter().map(|m| m - 5.0).collect(),
            lag.phase_deg.iter().map(|m| m + 5.0).collect(),
        ),
        coherence: f.iter().map(|f| 1.0 / (1.0 + 0.01 * f)).collect(),
        fit_band_hz: Some((0.1, 20.0)),
    };
    add("frf", frf_figure("Measured response", &est, std::slice::from_ref(&lag)));
    add(
        "hsv",
        hsv_figure("Hankel singular values", &[3.0, 1.0, 0.2, 0.01, 1e-4], Some(2)).unwrap(),
    );

    let x: Vec<f64> = (0..20).map(|i| 2.5 + 5.0 * i as f64).collect();
    let y: Vec<f64> = (0..100).map(|j| 4.0 * j as f64).collect();
    let z = x
        .iter()
        .map(|t| {
            y.iter()
                .map(|f| -60.0 + 30.0 * (-((f - 3.0 * t) / 20.0).powi(2)).exp())
                .collect()
        })
        .collect();
    let heat = Heatmap {
        title: "gyro roll".into(),
        x_label: "throttle [%]".into(),
        y_label: "frequency [Hz]".into(),
        colorbar_label: "PSD [dB]".into(),
        x,
        y,
        z,
        overlays: (1..=3)
            .map(|h| Overlay {
                label: format!("motor ×{h}"),
                points: vec![(10.0, 30.0 * h as f64), (90.0, 120.0 * h as f64)],
            })
            .collect(),
        y_max: None,
        z_range: None,
    };
    out.push(("heatmap", heat.layout().unwrap()));
    out
}

#[test]
fn no_legend_hides_a_label_and_no_labels_overlap_in_any_figure() {
    let figures = every_figure();
    // The boxes are there to judge: the margins' labels and the legends were recorded.
    let (_, bode) = &figures[0];
    assert_eq!(bode.of(BoxKind::Legend).count(), 1);
    assert!(bode.of(BoxKind::Label).any(|b| b.text.starts_with("GM ")));
    assert!(bode.of(BoxKind::Label).any(|b| b.text.starts_with("PM ")));
    let (_, step) = &figures.iter().find(|(n, _)| *n == "design step").unwrap();
    assert!(step.of(BoxKind::Label).any(|b| b.text.starts_with("settling time")));
    assert_eq!(step.of(BoxKind::Legend).count(), 1);
    let (_, heat) = figures.last().unwrap();
    assert_eq!(heat.of(BoxKind::Label).count(), 3);

    let report: Vec<String> = figures
        .iter()
        .filter(|(_, l)| !l.collisions().is_empty())
        .map(|(name, l)| format!("{name}:\n{}", l.describe_collisions()))
        .collect();
    assert!(report.is_empty(), "{}", report.join("\n"));
}
