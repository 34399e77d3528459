//! Every plot kind renders to SVG and PNG with its data in it, and bad input is refused.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::PathBuf;

use skyloop_plot::bode::{plot_bode, BodeData, BodeMarks};
use skyloop_plot::frf::{plot_frf, FrfEstimate};
use skyloop_plot::hsv::plot_hsv;
use skyloop_plot::mu::{plot_mu, MuCurve};
use skyloop_plot::nyquist::{plot_nyquist, NyquistData};
use skyloop_plot::sigma::{plot_sigma, SigmaData};
use skyloop_plot::traces::{plot_step, plot_traces, Trace, TracePanel};
use skyloop_plot::PlotError;

fn out(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skyloop-plot-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn svg_text(path: &PathBuf) -> String {
    let s = std::fs::read_to_string(path).expect("svg written");
    assert!(s.starts_with("<svg"), "not an SVG: {}", &s[..s.len().min(80)]);
    s
}

/// First-order lag 1/(s/(2π) + 1) in Bode form, a known closed form.
fn lag() -> BodeData {
    let f: Vec<f64> = (0..200).map(|i| 10f64.powf(-2.0 + 4.0 * i as f64 / 199.0)).collect();
    let mag_db = f.iter().map(|f| -10.0 * (1.0 + f * f).log10()).collect();
    let phase_deg = f.iter().map(|f| -f.atan().to_degrees()).collect();
    BodeData {
        label: "lag".into(),
        freq_hz: f,
        mag_db,
        phase_deg,
    }
}

#[test]
fn bode_svg_has_legend_and_margin_labels() {
    let p = out("bode.svg");
    let marks = BodeMarks {
        crossover_hz: Some(1.47),
        gain_margin: Some((7.25, 4.0)),
        phase_margin: Some((65.8, 1.47)),
        ..BodeMarks::default()
    };
    let mut second = lag();
    second.label = "second system".into();
    plot_bode(&p, "Bode", &[lag(), second], &marks).expect("bode");
    let s = svg_text(&p);
    assert!(s.contains("second system"));
    assert!(s.contains("PM 65.8"));
    assert!(s.contains("GM 7.25 dB"));
    assert!(s.contains("magnitude [dB]"));
}

#[test]
fn bode_png_is_a_png() {
    let p = out("bode.png");
    plot_bode(&p, "Bode", &[lag()], &BodeMarks::default()).expect("bode png");
    let bytes = std::fs::read(&p).expect("png written");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(bytes.len() > 5000);
}

#[test]
fn nyquist_step_sigma_hsv_mu_frf_render() {
    let l = lag();
    let (re, im): (Vec<f64>, Vec<f64>) = l
        .mag_db
        .iter()
        .zip(&l.phase_deg)
        .map(|(m, p)| {
            let a = 10f64.powf(m / 20.0);
            (a * p.to_radians().cos(), a * p.to_radians().sin())
        })
        .unzip();
    let p = out("nyq.svg");
    plot_nyquist(
        &p,
        "Nyquist",
        &[NyquistData {
            label: "L".into(),
            re,
            im,
        }],
        Some(2.0),
    )
    .expect("nyquist");
    assert!(svg_text(&p).contains("-1"));

    let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.05).collect();
    let y: Vec<f64> = t.iter().map(|t| 1.0 - (-t).exp()).collect();
    let p = out("step.svg");
    plot_step(
        &p,
        "Step",
        &[Trace {
            label: "y".into(),
            t: t.clone(),
            y: y.clone(),
        }],
    )
    .expect("step");
    assert!(svg_text(&p).contains("time [s]"));

    let p = out("traces.png");
    let panels = vec![
        TracePanel {
            y_label: "roll [rad]".into(),
            traces: vec![Trace {
                label: "roll".into(),
                t: t.clone(),
                y,
            }],
            references: vec![(0.05, "bound".into())],
        },
        TracePanel {
            y_label: "u".into(),
            traces: vec![Trace {
                label: "u".into(),
                t: t.clone(),
                y: t.clone(),
            }],
            references: vec![],
        },
    ];
    plot_traces(&p, "Traces", &panels).expect("traces");

    let p = out("sigma.svg");
    let sv = l.mag_db.iter().map(|m| vec![*m, m - 10.0]).collect();
    plot_sigma(
        &p,
        "sigma",
        &[SigmaData {
            label: "G".into(),
            freq_hz: l.freq_hz.clone(),
            sv_db: sv,
        }],
    )
    .expect("sigma");
    svg_text(&p);

    let p = out("hsv.svg");
    plot_hsv(&p, "HSV", &[3.0, 1.0, 0.3, 1e-3, 1e-6], Some(3)).expect("hsv");
    let s = svg_text(&p);
    assert!(s.contains("discarded") && s.contains("order 3"));

    let p = out("mu.svg");
    let up: Vec<f64> = l.mag_db.iter().map(|m| 10f64.powf(m / 20.0)).collect();
    let lo: Vec<f64> = up.iter().map(|u| 0.9 * u).collect();
    plot_mu(
        &p,
        "mu",
        &[MuCurve {
            label: "RS".into(),
            freq_hz: l.freq_hz.clone(),
            upper: up,
            lower: lo,
        }],
    )
    .expect("mu");
    assert!(svg_text(&p).contains("RS upper"));

    let p = out("frf.svg");
    let est = FrfEstimate {
        freq_hz: l.freq_hz.clone(),
        mag_db: l.mag_db.clone(),
        phase_deg: l.phase_deg.clone(),
        mag_band_db: (
            l.mag_db.iter().map(|m| m - 1.0).collect(),
            l.mag_db.iter().map(|m| m + 1.0).collect(),
        ),
        phase_band_deg: (vec![], vec![]),
        coherence: vec![0.9; l.freq_hz.len()],
        fit_band_hz: Some((1.0, 10.0)),
    };
    plot_frf(&p, "FRF", &est, std::slice::from_ref(&l)).expect("frf");
    let s = svg_text(&p);
    assert!(s.contains("coherence") && s.contains("measured"));
    assert!(s.contains("fit band 1.000 to 10.000 Hz"), "the fit band is labelled");
}

#[test]
fn bad_input_is_refused() {
    let l = lag();
    match plot_bode(&out("bode.jpg"), "x", std::slice::from_ref(&l), &BodeMarks::default()) {
        Err(PlotError::Format(_)) => {}
        other => panic!("expected a format error, got {other:?}"),
    }
    let mut short = l.clone();
    short.mag_db.pop();
    assert!(matches!(
        plot_bode(&out("b.svg"), "x", &[short], &BodeMarks::default()),
        Err(PlotError::Data(_))
    ));
    let nan = BodeData {
        label: "nan".into(),
        freq_hz: vec![f64::NAN; 3],
        mag_db: vec![1.0; 3],
        phase_deg: vec![0.0; 3],
    };
    assert!(matches!(
        plot_bode(&out("c.svg"), "x", &[nan], &BodeMarks::default()),
        Err(PlotError::Data(_))
    ));
    assert!(matches!(
        plot_hsv(&out("h.svg"), "x", &[], None),
        Err(PlotError::Data(_))
    ));
    let missing_dir = std::env::temp_dir().join("skyloop-no-such-dir/x/y.png");
    assert!(matches!(
        plot_bode(&missing_dir, "x", &[l], &BodeMarks::default()),
        Err(PlotError::Draw { .. })
    ));
}

#[test]
fn html_report_inlines_figures_and_escapes_text() {
    use skyloop_plot::bode::bode_figure;
    use skyloop_plot::Report;
    let mut r = Report::new("Design <bicopter>");
    r.section("Margins")
        .text("PM & GM of L = P·C")
        .key_values(&[("phase margin [deg]", "65.8".into())])
        .figure(bode_figure("L", &[lag()], &BodeMarks::default()), "loop transfer");
    let p = out("report.html");
    r.save(&p).expect("report");
    let html = std::fs::read_to_string(&p).expect("html");
    assert!(html.contains("Design &lt;bicopter&gt;"));
    assert!(html.contains("PM &amp; GM"));
    assert!(html.contains("<svg") && html.contains("loop transfer") && html.contains("<td>65.8</td>"));
}
