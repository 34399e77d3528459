//! `skyloop noise`: the noise picture of real logs, the flown chain's exactness against the logged
//! gyro, the what-if, and bad input.
#![allow(clippy::unwrap_used)]

mod common;
use common::skyloop;
use serde_json::Value;

fn log(name: &str) -> String {
    format!("{}/../../testdata/logs/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn json(args: &[&str]) -> Value {
    let (code, out, err) = skyloop(args);
    assert_eq!(code, 0, "{err}");
    serde_json::from_str(&out).unwrap()
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN))
        .collect()
}

/// Betaflight 3.1.5 logs the gyro between its lowpass and its notches (debug NOTCH): the flown
/// notch applied to it reproduces the logged gyro (measured 1.2 dB RMS over 8–275 Hz; the worst bin
/// is at the notch's edge), and the JSON carries the interface's keys.
#[test]
fn flown_chain_on_the_raw_gyro_reproduces_the_logged_gyro() {
    let v = json(&[
        "noise",
        &log("pid-analyzer_example_smooth_tune.BBL"),
        "--axis",
        "roll",
        "--json",
    ]);
    let a = &v["axes"][0];
    assert_eq!(a["axis"], "roll");
    let s = &a["spectra"];
    let f = nums(&s["freq_hz"]);
    for k in ["gyro", "gyro_raw", "gyro_predicted", "dterm", "motors"] {
        assert_eq!(nums(&s[k]).len(), f.len(), "{k}");
    }
    let val = &a["validation"];
    assert!(val["rms_db"].as_f64().unwrap() < 2.0, "{val}");
    assert!(val["mean_db"].as_f64().unwrap().abs() < 1.0, "{val}");
    assert!(val["band_hz"][1].as_f64().unwrap() > 200.0, "{val}");
    let chain = &a["gyro_chain"];
    for k in ["freq_hz", "gain_db", "phase_deg"] {
        assert!(nums(&chain[k]).len() > 100, "{k}");
    }
    // PT1 at 90 Hz plus the 220 Hz notch: about 1.8 ms of phase delay at 10 Hz (1/(2π·90) = 1.77 ms
    // from the PT1, a little from the notch).
    let d10 = chain["delay_ms_at"]["10"].as_f64().unwrap();
    assert!((1.7..2.6).contains(&d10), "{d10}");
    assert_eq!(v["raw_gyro"]["applied"][0], "gyro_lpf1");
    for p in a["peaks"].as_array().unwrap() {
        assert!(["motor harmonic", "frame resonance", "prop wash band"].contains(&p["kind"].as_str().unwrap()));
    }
}

/// Turning gyro lowpass 2 (PT1 300 Hz) off raises the what-if chain's gain at 300 Hz by that PT1's
/// attenuation (3 dB), and the predicted gyro above 200 Hz by about as much; below 20 Hz nothing
/// changes.
#[test]
fn what_if_changes_the_spectrum_by_the_filter_it_removes() {
    let v = json(&[
        "noise",
        &log("LOG00037.BFL"),
        "--axis",
        "pitch",
        "--filters",
        "gyro_lpf2=off",
        "--json",
    ]);
    let a = &v["axes"][0];
    assert_eq!(v["what_if"]["changes"][0], "gyro_lpf2: pt1 300 Hz → off");
    let (flown, what) = (&a["gyro_chain"], &a["what_if_chain"]);
    let f = nums(&flown["freq_hz"]);
    let k = f.iter().position(|x| *x >= 300.0).unwrap();
    let rise = nums(&what["gain_db"])[k] - nums(&flown["gain_db"])[k];
    assert!((2.5..4.0).contains(&rise), "{rise}");
    let s = &a["spectra"];
    let (sf, pred, wi) = (
        nums(&s["freq_hz"]),
        nums(&s["gyro_predicted"]),
        nums(&s["gyro_what_if"]),
    );
    for (i, fr) in sf.iter().enumerate() {
        let d = wi[i] - pred[i];
        if *fr < 20.0 {
            assert!(d.abs() < 0.1, "{fr} Hz: {d}");
        }
        if *fr > 250.0 && *fr < 450.0 {
            assert!(d > 1.0, "{fr} Hz: {d}");
        }
    }
}

#[test]
fn writes_the_report_and_figures() {
    let dir = std::env::temp_dir().join(format!("skyloop-noise-{}", std::process::id()));
    let (code, _, err) = skyloop(&[
        "noise",
        &log("btfl_001.bbl"),
        "--axis",
        "roll",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    for f in [
        "noise.json",
        "noise.txt",
        "report.html",
        "roll_spectra.png",
        "roll_throttle.png",
        "roll_time.png",
        "roll_chain.png",
    ] {
        assert!(std::fs::metadata(dir.join(f)).unwrap().len() > 1000, "{f}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("against throttle") && html.contains("dyn_notch"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_exits_2_naming_it() {
    let l = log("btfl_001.bbl");
    for (args, want) in [
        (vec!["noise", &l, "--filters", "gyro_lpf7=pt1:100"], "unknown stage"),
        (vec!["noise", &l, "--filters", "gyro_lpf1=pt1:9000"], "Nyquist"),
        (vec!["noise", &l, "--axis", "sideways"], "sideways"),
        (vec!["noise", "/nonexistent.bbl"], "nonexistent"),
    ] {
        let (code, _, err) = skyloop(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    let csv = std::env::temp_dir().join(format!("skyloop-noise-{}.csv", std::process::id()));
    std::fs::write(&csv, "time_s,x\n0,1\n0.1,2\n").unwrap();
    let (code, _, err) = skyloop(&["noise", csv.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("Betaflight, INAV or PX4"), "{err}");
    std::fs::remove_file(&csv).ok();
}

/// ArduPilot states its gyro chain in PARM messages: INS_GYRO_FILTER (a biquad) and a fixed
/// harmonic notch (INS_HNTCH_FREQ 80 Hz, BW 40 Hz: Q 2) at SCHED_LOOP_RATE; the chain's gain is
/// −3 dB at the lowpass cutoff and the notch removes its centre.
#[test]
fn ardupilot_gyro_chain_from_its_parameters() {
    let v = json(&["noise", &log("synthetic_arducopter.bin"), "--axis", "roll", "--json"]);
    assert_eq!(v["loop_rate_hz"].as_f64(), Some(400.0));
    let chain = v["flown_chain"].as_array().unwrap();
    let names: Vec<&str> = chain.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["gyro_lpf1", "gyro_notch1"]);
    assert_eq!(chain[0]["shape"], "biquad");
    assert_eq!(chain[0]["hz"].as_f64(), Some(20.0));
    assert!((chain[1]["q"].as_f64().unwrap() - 2.0).abs() < 1e-12);
    let g = &v["axes"][0]["gyro_chain"];
    let (f, db) = (nums(&g["freq_hz"]), nums(&g["gain_db"]));
    let at = |hz: f64| {
        let k = (0..f.len())
            .min_by(|&a, &b| (f[a] - hz).abs().total_cmp(&(f[b] - hz).abs()))
            .unwrap();
        (f[k], db[k])
    };
    let (f80, g80) = at(80.0);
    assert!((f80 - 80.0).abs() < 2.0 && g80 < -25.0, "{f80} Hz: {g80} dB");
    let (f1, g1) = at(1.0);
    assert!(f1 < 2.0 && g1.abs() < 0.1, "{f1} Hz: {g1} dB");
    let notes = v["notes"].as_array().unwrap();
    assert!(
        notes.iter().any(|n| n.as_str().unwrap().contains("full depth")),
        "{notes:?}"
    );
}
