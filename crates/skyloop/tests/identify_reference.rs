//! `identify LOG --axis roll` on a real acro flight against an independent instrumental-variable
//! identification (tools/gen_iv_reference.py: orangebox decoding, scipy Welch spectra per airborne
//! segment, G = S_yr/S_ur, scipy least squares), committed as tests/fixtures/iv_reference.json.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use skyloop::identify::{identify, Identification, IdentifyRequest};
use skyloop_fixtures::{cases, f64s};

fn log(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata/logs")
        .join(name)
}

fn reference(axis: &str) -> serde_json::Value {
    cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/iv_reference.json")
        .into_iter()
        .find(|c| c["axis"] == axis && c["file"] == "btfl_all.bbl")
        .unwrap()
}

fn params(id: &Identification) -> (f64, f64, f64) {
    let p = &id.fit.as_ref().unwrap().1.params;
    (p["K"], p["tau"], p["Td"])
}

/// The reference's recipe spelled in skyloop's flags: Welch with its window length, its band, its
/// (un)weighting. What differs is only the implementation: the decoder (ours against orangebox, equal
/// to the integer), the time grid (skyloop resamples the 500 Hz frames onto an exact 2 ms grid, which
/// moves a segment's ends by at most a sample) and the optimizer. The segments, FRF and parameters
/// must then agree closely: within a sample (2 ms, plus rounding) on the segments' ends, 1 % on the FRF's median point and 2 % plus
/// twice its random error on every point (interpolating the frames' jittered timestamps, ±60 µs, onto the
/// grid changes the data by about 1 % at 30 Hz, which a point of low coherence amplifies), and 3 % on
/// K, τ and Td.
#[test]
fn same_recipe_gives_the_reference_fit() {
    let r = reference("roll");
    let band = f64s(&r["band_hz"]);
    let id = identify(&IdentifyRequest {
        data: log("btfl_all.bbl"),
        axis: Some("roll".into()),
        method: "welch".into(),
        nfft: Some(r["nperseg"].as_u64().unwrap() as usize),
        fmin_hz: Some(band[0]),
        fmax_hz: Some(band[1]),
        weighting: "none".into(),
        ..Default::default()
    })
    .unwrap();
    assert_eq!(id.input, r["input"].as_str().unwrap());
    let segs = r["segments_clock_s"].as_array().unwrap();
    assert_eq!(id.segments.len(), segs.len(), "{:?}", id.segments);
    for (s, want) in id.segments.iter().zip(segs) {
        let w = f64s(want);
        let (a, b) = (s.from_s + id.clock_origin_s, s.to_s + id.clock_origin_s);
        assert!(
            (a - w[0]).abs() < 2.5e-3 && (b - w[1]).abs() < 2.5e-3,
            "{a} {b} vs {w:?}"
        );
    }
    let (f, re, im) = (f64s(&r["frf"]["freq_hz"]), f64s(&r["frf"]["re"]), f64s(&r["frf"]["im"]));
    let (coh, nu) = (f64s(&r["frf"]["coherence"]), r["dof"].as_f64().unwrap());
    let mut diffs = Vec::new();
    for (i, f) in f.iter().enumerate() {
        let k = id
            .frf
            .freq_hz
            .iter()
            .position(|g| (g - f).abs() < 1e-3 * f)
            .unwrap_or_else(|| panic!("no point at {f} Hz"));
        let want = num_complex::Complex64::new(re[i], im[i]);
        let d = (id.frf.response[k] - want).norm() / want.norm();
        // A point's own random error (Bendat & Piersol 9.90) bounds how much a sample more or less
        // at a segment's end may move it.
        let c = coh[i].clamp(1e-6, 1.0);
        let eps = ((1.0 - c) / (2.0 * nu * c)).sqrt();
        assert!(
            d < 0.02 + 2.0 * eps,
            "{f} Hz: {} vs {want} (random error {eps})",
            id.frf.response[k]
        );
        diffs.push(d);
    }
    diffs.sort_by(f64::total_cmp);
    assert!(
        diffs[diffs.len() / 2] < 0.01,
        "median FRF difference {}",
        diffs[diffs.len() / 2]
    );
    let (k, tau, td) = params(&id);
    let want = &r["fit"]["none"];
    for (name, got) in [("K", k), ("tau", tau), ("Td", td)] {
        let w = want[name].as_f64().unwrap();
        assert!((got / w - 1.0).abs() < 0.03, "{name}: {got} vs reference {w}");
    }
}

/// The pilot's bare command (SPAFDR, its own band, inverse-variance weights, jackknife errors)
/// against the reference's weighted fit: a different estimator and band of the same data, so they
/// agree within the reported errors (twice the reported standard error, which already includes the
/// jackknife's spread), and the fit is one a reviewer accepts: no parameter on a bound, each known to
/// better than 30 %, and more of the FRF's variation explained than its mean does on the fitted
/// points and on held-out blocks. (Measured when this was written: K 126.5 ± 12.6 against the
/// reference's 146.0, τ 8.8 ± 1.0 ms against 10.2, Td 3.43 ± 0.15 ms against 3.48; fit 41 % over
/// 2.1 .. 72 Hz, held-out 14 %. A complex fit percentage is dominated by the low-frequency
/// points where |G| is largest and the pilot's inputs scatter most; the reference's Welch fit over
/// 2 .. 50 Hz scores 55 %.)
#[test]
fn the_pilots_command_agrees_with_the_reference() {
    let r = reference("roll");
    let id = identify(&IdentifyRequest {
        data: log("btfl_all.bbl"),
        axis: Some("roll".into()),
        ..Default::default()
    })
    .unwrap();
    let fit = &id.fit.as_ref().unwrap().1;
    let want = &r["fit"]["inverse_variance"];
    for name in ["K", "tau", "Td"] {
        let (got, se, w) = (fit.params[name], fit.stderr[name], want[name].as_f64().unwrap());
        assert!(se.is_finite() && se < 0.3 * got, "{name}: {got} ± {se}");
        assert!((got - w).abs() <= 2.0 * se, "{name}: {got} ± {se} vs reference {w}");
    }
    assert!(fit.fit_percent > 30.0, "fit {}", fit.fit_percent);
    assert!(fit.converged && fit.at_bounds.is_empty(), "{fit:?}");
    let v = id.validation.as_ref().unwrap();
    assert!(v.fit_percent > 5.0, "held-out fit {}", v.fit_percent);
    let (lo, hi) = id.fit_band_hz.unwrap();
    assert!(lo >= 2.0 && hi > 4.0 * lo, "band {lo} .. {hi}");
}

/// The two halves of the flight (log time before and after 73 s, about 65 airborne seconds each)
/// identified separately agree within three of their combined reported errors, as the issue asks.
/// Measured when this was written: K 117.8 ± 15.5 and 159.6 ± 26.0, τ 8.3 ± 1.3 and 11.4 ± 1.6 ms,
/// Td 3.60 ± 0.32 and 3.14 ± 0.17 ms: differences of 1.4, 1.5 and 1.3 combined errors.
#[test]
fn two_halves_of_the_flight_agree() {
    let half = |from: Option<f64>, to: Option<f64>| {
        identify(&IdentifyRequest {
            data: log("btfl_all.bbl"),
            axis: Some("roll".into()),
            from,
            to,
            // Each half's own held-out quarter validates near 0 % (−3 % after 73 s): the
            // parameters' agreement between halves is what is tested here.
            allow_poor_fit: true,
            ..Default::default()
        })
        .unwrap()
        .fit
        .unwrap()
        .1
    };
    let (a, b) = (half(None, Some(73.0)), half(Some(73.0), None));
    for k in ["K", "tau", "Td"] {
        let d = (a.params[k] - b.params[k]).abs();
        let s = a.stderr[k].hypot(b.stderr[k]);
        assert!(
            d <= 3.0 * s,
            "{k}: {} ± {} vs {} ± {}",
            a.params[k],
            a.stderr[k],
            b.params[k],
            b.stderr[k]
        );
        // The errors are not inflated into meaninglessness either.
        assert!(
            a.stderr[k] < 0.3 * a.params[k] && b.stderr[k] < 0.3 * b.params[k],
            "{k}"
        );
    }
}
