//! `skyloop signal`, `skyloop log info` and `skyloop identify` on generated data and real flight logs.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skyloop-cli-sysid-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn log_path(name: &str) -> String {
    format!("{}/../../testdata/logs/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn skyloop(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .output()
        .expect("run skyloop")
}

fn ok_json(args: &[&str]) -> serde_json::Value {
    let out = skyloop(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn fails_with(args: &[&str], needle: &str) {
    let out = skyloop(args);
    assert_eq!(out.status.code(), Some(2), "{args:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(needle), "{args:?}: {err}");
}

#[test]
fn signal_writes_csv() {
    let p = tmp("chirp.csv");
    let ps = p.to_str().unwrap();
    let out = skyloop(&[
        "signal",
        "chirp",
        "--f0-hz",
        "0.8",
        "--f1-hz",
        "20",
        "--duration-s",
        "10",
        "--fade-s",
        "0.5",
        "--rate",
        "250",
        "--out",
        ps,
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(text.lines().next(), Some("time_s,value"));
    assert_eq!(text.lines().count(), 2501);
    let p2 = tmp("prbs.csv");
    let out = skyloop(&[
        "signal",
        "prbs",
        "--order",
        "7",
        "--rate",
        "100",
        "--out",
        p2.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert_eq!(std::fs::read_to_string(&p2).unwrap().lines().count(), 128);
    let p3 = tmp("ms.csv");
    let out = skyloop(&[
        "signal",
        "multisine",
        "--fmin-hz",
        "1",
        "--fmax-hz",
        "20",
        "--period-s",
        "5",
        "--rate",
        "100",
        "--out",
        p3.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    fails_with(
        &[
            "signal",
            "chirp",
            "--f0-hz",
            "1",
            "--f1-hz",
            "80",
            "--duration-s",
            "5",
            "--rate",
            "100",
            "--out",
            ps,
        ],
        "Nyquist",
    );
    fails_with(
        &["signal", "prbs", "--order", "40", "--rate", "100", "--out", ps],
        "order",
    );
}

#[test]
fn log_info_lists_fields_and_refuses_garbage() {
    let v = ok_json(&["log", "info", &log_path("LOG00037.BFL"), "--json"]);
    assert_eq!(v["format"], "blackbox");
    let fields: Vec<String> = v["groups"][0]["fields"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect();
    assert!(fields.contains(&"gyroADC[0]".to_string()));
    assert!((v["groups"][0]["rate_hz"].as_f64().unwrap() - 1000.0).abs() < 1.0);
    let v = ok_json(&["log", "info", &log_path("sample_px4_events.ulg"), "--json"]);
    assert_eq!(v["format"], "ulog");
    let out = skyloop(&["log", "info", &log_path("btfl_all.bbl")]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("not decodable") && text.contains("gyroADC[0]"), "{text}");
    let bad = tmp("garbage.ulg");
    std::fs::write(&bad, b"ULog\x01\x12\x35garbage").unwrap();
    fails_with(&["log", "info", bad.to_str().unwrap()], "garbage.ulg");
    fails_with(&["log", "info", "/nonexistent.ulg"], "cannot read");
}

/// y is K/(τs+1) with K = 2, τ = 0.05 s driven by a held chirp, discretized exactly (ZOH) at 1 kHz.
fn first_order_csv() -> PathBuf {
    let (dt, k, tau): (f64, f64, f64) = (0.001, 2.0, 0.05);
    let a = (-dt / tau).exp();
    let n = 20_000;
    let mut s = String::from("time_s,u,y\n");
    let mut y = 0.0;
    for i in 0..n {
        let t = i as f64 * dt;
        // Exponential chirp 0.5 → 50 Hz over 20 s (phase 2π·f0·L·(e^(t/L) − 1), L = T/ln(f1/f0)).
        let l = 20.0 / (100.0f64).ln();
        let u = (2.0 * std::f64::consts::PI * 0.5 * l * ((t / l).exp() - 1.0)).sin();
        s.push_str(&format!("{t},{u},{y}\n"));
        y = a * y + k * (1.0 - a) * u;
    }
    let p = tmp("first_order.csv");
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn identify_fits_a_model_to_csv_data() {
    let p = first_order_csv();
    let ps = p.to_str().unwrap();
    let svg = tmp("frf.svg");
    let v = ok_json(&[
        "identify",
        ps,
        "--input",
        "u",
        "--output",
        "y",
        "--fmin-hz",
        "0.5",
        "--fmax-hz",
        "40",
        "--model",
        "K/(tau*s+1)*(1-exp(-0.001*s))/(0.001*s)",
        "--init",
        "K=1,tau=0.1",
        "--bounds",
        "K=0:10,tau=0.001:",
        "--plot",
        svg.to_str().unwrap(),
        "--json",
    ]);
    let f = v["frf"]["freq_hz"].as_array().unwrap();
    assert_eq!(f.len(), 100);
    for k in ["mag", "phase_deg", "coherence"] {
        assert_eq!(v["frf"][k].as_array().unwrap().len(), f.len(), "{k}");
    }
    let k = v["fit"]["params"]["K"].as_f64().unwrap();
    let tau = v["fit"]["params"]["tau"].as_f64().unwrap();
    assert!((k - 2.0).abs() < 0.01 && (tau - 0.05).abs() < 0.0005, "{k} {tau}");
    assert!(v["fit"]["stderr"]["K"].as_f64().is_some());
    assert!(v["fit"]["fit_percent"].as_f64().unwrap() > 99.0);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    // Rational fit of one pole, no delay.
    let v = ok_json(&[
        "identify",
        ps,
        "--input",
        "u",
        "--output",
        "y",
        "--method",
        "welch",
        "--fmax-hz",
        "20",
        "--tf",
        "0/1",
        "--delay-s",
        "0.0005",
        "--json",
    ]);
    let den = v["tf"]["den"].as_array().unwrap();
    assert!((den[1].as_f64().unwrap() - 20.0).abs() < 0.5, "{den:?}");
    fails_with(
        &["identify", ps, "--input", "u", "--output", "gyro", "--json"],
        "no field 'gyro'",
    );
    fails_with(
        &[
            "identify",
            ps,
            "--input",
            "u",
            "--output",
            "y",
            "--model",
            "K/(tau*s+1)",
        ],
        "--init",
    );
    fails_with(
        &[
            "identify",
            ps,
            "--input",
            "u",
            "--output",
            "y",
            "--model",
            "K/(tau*s+1",
            "--init",
            "K=1,tau=1",
        ],
        "column",
    );
    fails_with(
        &["identify", ps, "--input", "u", "--output", "y", "--method", "magic"],
        "unknown method",
    );
}

#[test]
fn identify_betaflight_rate_loop() {
    // btfl_all.bbl session 4: the ~130 s acro flight (SOURCES.md); roll PID sum → gyro roll.
    let v = ok_json(&[
        "identify",
        &log_path("btfl_all.bbl"),
        "--input",
        "axisP[0]+axisI[0]+axisD[0]+axisF[0]",
        "--output",
        "gyroADC[0]",
        "--from",
        "10",
        "--to",
        "140",
        "--fmin-hz",
        "1",
        "--fmax-hz",
        "100",
        "--json",
    ]);
    let coh: Vec<f64> = v["frf"]["coherence"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_f64().unwrap())
        .collect();
    let f: Vec<f64> = v["frf"]["freq_hz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_f64().unwrap())
        .collect();
    assert!(coh.iter().all(|c| (0.0..=1.0).contains(c)));
    // Stick inputs and turbulence make the PID sum explain the gyro between 3 and 60 Hz (below, the
    // I-term's response to disturbances dominates; above, motor noise).
    let band: Vec<f64> = f
        .iter()
        .zip(&coh)
        .filter(|(f, _)| **f > 3.0 && **f < 60.0)
        .map(|(_, c)| *c)
        .collect();
    let mean = band.iter().sum::<f64>() / band.len() as f64;
    assert!(mean > 0.5, "mean coherence {mean}");
    // Segment selection by a condition (throttle above idle), and the closed-loop form with the
    // pilot's setpoint as the excitation.
    let v = ok_json(&[
        "identify",
        &log_path("btfl_all.bbl"),
        "--input",
        "axisP[0]+axisI[0]+axisD[0]+axisF[0]",
        "--output",
        "gyroADC[0]",
        "--excitation",
        "setpoint[0]",
        "--where",
        "rcCommand[3]>1100",
        "--method",
        "welch",
        "--json",
    ]);
    assert!(!v["frf"]["freq_hz"].as_array().unwrap().is_empty());
    fails_with(
        &[
            "identify",
            &log_path("btfl_all.bbl"),
            "--input",
            "axisP[0]",
            "--output",
            "gyroADC[0]",
            "--where",
            "rcCommand[3]>5000",
        ],
        "never holds",
    );
}
