//! The new builders render, their SVG carries the values and labels an engineer reads, and no
//! tick label is written with float noise or a trailing ".0".
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use num_complex::Complex64;
use skyloop_plot::bode::{bode_figure, bode_mimo_figure, BodeData, BodeMarks, IoNames};
use skyloop_plot::nichols::{nichols_figure, DEFAULT_M_DB};
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::pzmap::{pzmap_figure, rlocus_figure, PoleZeroData, RootLocusData};
use skyloop_plot::traces::{step_figure, StepInfo, Trace};
use skyloop_plot::{Figure, Report};

/// A delayed integrating loop 20 e^(−0.03 s)/(s (0.05 s + 1)) over 0.01–1000 Hz.
fn delayed_loop() -> (Vec<f64>, Vec<Complex64>) {
    let f: Vec<f64> = (0..800).map(|i| 10f64.powf(-2.0 + 5.0 * i as f64 / 799.0)).collect();
    let l = f
        .iter()
        .map(|f| {
            let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
            20.0 * (-0.03 * s).exp() / (s * (0.05 * s + 1.0))
        })
        .collect();
    (f, l)
}

fn bode_data(label: &str, f: &[f64], h: &[Complex64]) -> BodeData {
    let mut phase: Vec<f64> = Vec::new();
    for z in h {
        let mut p = z.arg().to_degrees();
        if let Some(q) = phase.last() {
            p += 360.0 * ((q - p) / 360.0).round();
        }
        phase.push(p);
    }
    BodeData {
        label: label.into(),
        freq_hz: f.to_vec(),
        mag_db: h.iter().map(|z| 20.0 * z.norm().log10()).collect(),
        phase_deg: phase,
    }
}

/// Text content of every `<text>` element of an SVG.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            t.split_once('>')
                .and_then(|(_, rest)| rest.split_once("</text>"))
                .map(|(s, _)| s.trim().to_string())
        })
        .collect()
}

fn assert_clean_ticks(fig: &Figure) -> Vec<String> {
    let svg = fig.to_svg_string().expect("svg");
    let t = texts(&svg);
    for s in &t {
        assert!(!s.ends_with(".0"), "tick label with a trailing .0: {s:?}");
        assert!(!s.contains("0000000"), "float noise in a label: {s:?}");
    }
    t
}

#[test]
fn delayed_bode_windows_the_phase_and_labels_decades() {
    let (f, l) = delayed_loop();
    let d = bode_data("L", &f, &l);
    let fig = bode_figure(
        "L",
        &[d],
        &BodeMarks {
            crossover_hz: Some(2.9),
            gain_margin: None,
            phase_margin: Some((40.0, 2.9)),
            ..BodeMarks::default()
        },
    );
    let (lo, hi) = fig.panels[1].y_range.expect("phase window");
    assert!(hi - lo <= 720.0 + 90.0, "{lo}..{hi}");
    let t = assert_clean_ticks(&fig);
    for label in ["0.01", "0.1", "1", "10", "100", "1k", "-180", "PM 40.0° at 2.9 Hz"] {
        assert!(t.iter().any(|s| s == label), "missing {label:?} in {t:?}");
    }
}

#[test]
fn nyquist_nichols_pzmap_rlocus_step_and_mimo_render() {
    let (f, l) = delayed_loop();
    let ny = NyquistData {
        label: "L".into(),
        re: l.iter().map(|z| z.re).collect(),
        im: l.iter().map(|z| z.im).collect(),
    };
    let t = assert_clean_ticks(&nyquist_figure("N", &[ny], Some(3.0)));
    assert!(t.iter().any(|s| s == "−1") && t.iter().any(|s| s == "|L| = 1"));

    let d = bode_data("L", &f, &l);
    let t = assert_clean_ticks(&nichols_figure("N", std::slice::from_ref(&d), &DEFAULT_M_DB));
    assert!(t.iter().any(|s| s == "6 dB"), "{t:?}");

    let pz = PoleZeroData {
        label: String::new(),
        poles: vec![Complex64::new(-1.0, 3.0), Complex64::new(-1.0, -3.0)],
        zeros: vec![Complex64::new(2.0, 0.0)],
    };
    let t = assert_clean_ticks(&pzmap_figure("P", std::slice::from_ref(&pz), false));
    assert!(t.iter().any(|s| s == "poles") && t.iter().any(|s| s == "zeros"));
    assert_clean_ticks(&pzmap_figure("P", &[pz], true));

    let gains: Vec<f64> = (0..50).map(|i| i as f64 * 0.2).collect();
    let poles = gains
        .iter()
        .map(|k| {
            let d = Complex64::new(1.0 - k, 0.0).sqrt();
            vec![Complex64::new(-1.0, 0.0) + d, Complex64::new(-1.0, 0.0) - d]
        })
        .collect();
    let rl = RootLocusData {
        gains,
        poles,
        open_loop_poles: vec![Complex64::new(0.0, 0.0), Complex64::new(-2.0, 0.0)],
        open_loop_zeros: vec![],
    };
    let t = assert_clean_ticks(&rlocus_figure("R", &rl, false));
    assert!(t.iter().any(|s| s == "open-loop poles"));

    let tt: Vec<f64> = (0..200).map(|i| i as f64 * 0.02).collect();
    let y: Vec<f64> = tt.iter().map(|t| 1.0 - (-2.0 * t).exp()).collect();
    let info = StepInfo {
        rise_time_s: Some(1.0986),
        settling_time_s: Some(1.956),
        ..StepInfo::new(1.0)
    };
    let t = assert_clean_ticks(&step_figure(
        "S",
        &[Trace {
            label: "y".into(),
            t: tt,
            y,
        }],
        &[info],
    ));
    assert!(t.iter().any(|s| s == "rise time 1.1 s"), "{t:?}");
    assert!(t.iter().any(|s| s == "settling time 1.96 s (2 %)"), "{t:?}");

    let sys = vec![vec![d.clone(), d.clone()], vec![d.clone(), d]];
    let fig = bode_mimo_figure("G", &[sys], &IoNames::default());
    let t = assert_clean_ticks(&fig);
    for title in ["from u1 to y1", "from u2 to y1", "from u1 to y2", "from u2 to y2"] {
        assert!(t.iter().any(|s| s == title), "missing {title}");
    }
    assert_eq!(fig.size().0, 960);
}

#[test]
fn colours_can_be_renumbered_for_a_whole_figure() {
    let (f, l) = delayed_loop();
    let d = bode_data("K final", &f, &l);
    let fig = bode_figure("L", &[d], &BodeMarks::default()).remap_colors(&[3]);
    // Magnitude and phase of the one system both in palette colour 3.
    assert_eq!(fig.panels[0].series[0].color, Some(3));
    assert_eq!(fig.panels[1].series[0].color, Some(3));
}

#[test]
fn interactive_report_is_self_contained() {
    let (f, l) = delayed_loop();
    let mut r = Report::new("R");
    r.section("S").interactive_figure(
        bode_figure("L", &[bode_data("L", &f, &l)], &BodeMarks::default()),
        "Bode",
    );
    let html = r.to_html().expect("html");
    assert!(html.contains("<svg"), "the static SVG is kept");
    assert!(html.contains("class=\"skl-int\"") && html.contains("type=\"application/json\""));
    assert!(html.contains("function Plot("));
    // (The SVG namespace is a name, not a request.)
    assert!(
        !html.contains("src=\"http") && !html.contains("https://") && !html.contains("fetch("),
        "no network"
    );
    assert_eq!(html.matches("function Plot(").count(), 1);
}
