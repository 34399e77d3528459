//! The plotting subcommands write real files and refuse bad input with exit status 2.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skyloop-cli-plots-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

/// 1/(s+1) as LTI JSON, and a 2×2 static gain (a model Nyquist must refuse).
fn models() -> (PathBuf, PathBuf) {
    let siso = tmp("lag.json");
    std::fs::write(&siso, r#"{"a":[[-1.0]],"b":[[1.0]],"c":[[1.0]],"d":[[0.0]],"dt":0.0}"#).expect("write");
    let mimo = tmp("mimo.json");
    std::fs::write(&mimo, r#"{"a":[[-1.0,0.0],[0.0,-2.0]],"b":[[1.0,0.0],[0.0,1.0]],"c":[[1.0,0.0],[0.0,1.0]],"d":[[0.0,0.0],[0.0,0.0]],"dt":0.0}"#)
        .expect("write");
    (siso, mimo)
}

fn skyloop(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .output()
        .expect("run skyloop")
}

#[test]
fn bode_and_nyquist_write_svg_and_png() {
    let (siso, mimo) = models();
    let out = tmp("bode.svg");
    let r = skyloop(&[
        "bode",
        siso.to_str().unwrap_or_default(),
        mimo.to_str().unwrap_or_default(),
        "--out",
        out.to_str().unwrap_or_default(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let svg = std::fs::read_to_string(&out).expect("svg");
    // A MIMO model among them: MATLAB's input–output grid, one panel pair per channel.
    assert!(svg.starts_with("<svg") && svg.contains("from u2 to y2"), "no I/O grid");

    let out = tmp("nyq.png");
    let r = skyloop(&[
        "nyquist",
        siso.to_str().unwrap_or_default(),
        "--out",
        out.to_str().unwrap_or_default(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(&std::fs::read(&out).expect("png")[..4], b"\x89PNG");
}

#[test]
fn plotting_bad_input_exits_2() {
    let (siso, mimo) = models();
    let cases: Vec<Vec<String>> = vec![
        vec![
            "bode".into(),
            siso.display().to_string(),
            "--out".into(),
            tmp("x.jpg").display().to_string(),
        ],
        vec![
            "nyquist".into(),
            mimo.display().to_string(),
            "--out".into(),
            tmp("n.svg").display().to_string(),
        ],
        vec![
            "bode".into(),
            siso.display().to_string(),
            "--out".into(),
            tmp("b.svg").display().to_string(),
            "--hz-min".into(),
            "10".into(),
            "--hz-max".into(),
            "1".into(),
        ],
        vec![
            "bode".into(),
            "no_such_model.json".into(),
            "--out".into(),
            tmp("c.svg").display().to_string(),
        ],
    ];
    for c in cases {
        let args: Vec<&str> = c.iter().map(String::as_str).collect();
        let r = skyloop(&args);
        assert_eq!(
            r.status.code(),
            Some(2),
            "{c:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        assert!(String::from_utf8_lossy(&r.stderr).starts_with("error: "), "{c:?}");
    }
}

#[test]
fn bode_marks_the_bicopter_margins() {
    // P from eq. (8) and C from eq. (12) of the bicopter paper; the paper prints PM 65.8° at 1.47 Hz, GM 7.25 dB.
    let l = "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5) * \
             24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))";
    let out = tmp("bicopter_l.svg");
    let r = skyloop(&["bode", l, "--margins", "--out", out.to_str().unwrap_or_default()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let svg = std::fs::read_to_string(&out).expect("svg");
    assert!(svg.contains("PM 65.") && svg.contains("at 1.47"), "margins not marked");
    assert!(svg.contains("GM 7.2"), "gain margin not marked");
}

#[test]
fn closed_loop_step_of_a_lag_settles_at_one_half() {
    // L = 1/(s+1) closes to T = 1/(s+2): final value 1/2 (closed form).
    let out = tmp("step.svg");
    let r = skyloop(&[
        "step",
        "1/(s+1)",
        "--closed-loop",
        "--tfinal",
        "10",
        "--out",
        out.to_str().unwrap_or_default(),
        "--json",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    let y = v["models"][0]["y"][0][0].as_array().expect("y");
    let last = y[y.len() - 1].as_f64().expect("number");
    assert!((last - 0.5).abs() < 1e-6, "final value {last}");
    assert!(std::fs::read_to_string(&out).expect("svg").contains("time [s]"));
    let r = skyloop(&["step", "1/(s+1)"]);
    assert_eq!(r.status.code(), Some(2));
}

#[test]
fn norm_of_a_first_order_lag() {
    // 1/(s+1): H∞ = 1 at 0 Hz, H2 = sqrt(1/2) (closed forms).
    let r = skyloop(&["norm", "1/(s+1)", "--json"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    assert!((v["hinf"].as_f64().expect("hinf") - 1.0).abs() < 1e-8);
    assert!((v["h2"].as_f64().expect("h2") - 0.5f64.sqrt()).abs() < 1e-10);
    // D ≠ 0 in continuous time: H2 is infinite, printed as null.
    let r = skyloop(&["norm", "(s+2)/(s+1)", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    assert!(v["h2"].is_null());
    assert_eq!(skyloop(&["norm", "1/(s+"]).status.code(), Some(2));
}

#[test]
fn closed_loop_step_keeps_a_loop_delay_exact() {
    // L = 2·e^{−0.5 s}/(s+1): T(0) = 2/3, and nothing moves before the 0.5 s delay has passed.
    let r = skyloop(&[
        "step",
        "2*exp(-0.5*s)/(s+1)",
        "--closed-loop",
        "--tfinal",
        "20",
        "--json",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    let t: Vec<f64> = v["models"][0]["t_s"]
        .as_array()
        .expect("t")
        .iter()
        .map(|x| x.as_f64().expect("t"))
        .collect();
    let y: Vec<f64> = v["models"][0]["y"][0][0]
        .as_array()
        .expect("y")
        .iter()
        .map(|x| x.as_f64().expect("y"))
        .collect();
    for (tk, yk) in t.iter().zip(&y) {
        if *tk < 0.5 {
            assert!(yk.abs() < 1e-12, "y({tk}) = {yk} before the delay");
        }
    }
    assert!((y[y.len() - 1] - 2.0 / 3.0).abs() < 1e-3, "final {}", y[y.len() - 1]);
}

#[test]
fn show_forms_and_pade() {
    let r = skyloop(&["show", "2*exp(-0.1*s)*(s+3)/(s*(s^2+2*s+5))", "--form", "zpk"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = String::from_utf8_lossy(&r.stdout);
    assert!(text.contains("input delay [s]  = [0.1]"), "{text}");
    assert!(text.contains("2*exp(-0.1*s)*(s+3)/(s*(s^2+2*s+5))"), "{text}");
    let r = skyloop(&["show", "-1/(s+1)", "--form", "tf"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stdout).contains("-1/(s+1)"));
    assert_eq!(skyloop(&["show", "1/(s+1)", "--form", "abc"]).status.code(), Some(2));
    let r = skyloop(&["pade", "exp(-0.1*s)/(s+1)", "--order", "2", "--json"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    assert_eq!(v["a"].as_array().expect("a").len(), 3);
    let r = skyloop(&["pade", "exp(-0.1*s)/(s+1)", "--order", "0"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--order 0"));
}

#[test]
fn sigma_nichols_pzmap_rlocus_and_interactive_html() {
    let (siso, mimo) = models();
    let (siso, mimo) = (siso.to_str().unwrap_or_default(), mimo.to_str().unwrap_or_default());
    let cases: [(&str, &[&str], &str, &str); 5] = [
        ("sigma", &[mimo], "sigma.svg", "singular values [dB]"),
        (
            "nichols",
            &["10*exp(-0.01*s)/(s*(0.1*s+1))"],
            "nichols.svg",
            "open-loop phase [deg]",
        ),
        (
            "pzmap",
            &["(s+2)/((s+1)*(s^2+0.4*s+4))", siso],
            "pz.svg",
            "imaginary axis",
        ),
        ("rlocus", &["(s+2)/(s*(s+1)*(s+5))"], "rl.svg", "open-loop poles"),
        ("bode", &[siso], "bode.html", "skl-int"),
    ];
    for (cmd, models, file, needle) in cases {
        let out = tmp(file);
        let mut args = vec![cmd];
        args.extend_from_slice(models);
        args.extend(["--out", out.to_str().unwrap_or_default()]);
        let r = skyloop(&args);
        assert!(r.status.success(), "{cmd}: {}", String::from_utf8_lossy(&r.stderr));
        let text = std::fs::read_to_string(&out).expect("file");
        assert!(text.contains(needle), "{cmd}: no {needle:?} in {file}");
    }
    // Loop-only figures refuse a MIMO model; a delayed root locus asks for pade.
    let out = tmp("bad.svg");
    let o = out.to_str().unwrap_or_default();
    assert_eq!(skyloop(&["nichols", mimo, "--out", o]).status.code(), Some(2));
    let r = skyloop(&["rlocus", "exp(-0.1*s)/(s+1)", "--out", o]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("pade"));
    assert_eq!(
        skyloop(&["rlocus", "1/(s+1)", "--gains", "5,1", "--out", o])
            .status
            .code(),
        Some(2)
    );
}

#[test]
fn step_reports_stepinfo() {
    // L = 1/(s(s+1)) closes to T = 1/(s²+s+1): overshoot 16.30 % and peak at 3.628 s (closed forms).
    let r = skyloop(&["step", "1/(s*(s+1))", "--closed-loop", "--json", "--label", "T"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    let m = &v["models"][0];
    assert_eq!(m["label"], "T");
    let info = &m["info"][0][0];
    assert!(
        (info["overshoot_pct"].as_f64().expect("os") - 16.303).abs() < 0.05,
        "{info}"
    );
    assert!((info["final_value"].as_f64().expect("yf") - 1.0).abs() < 1e-9);
    assert!((info["peak"][1].as_f64().expect("tp") - 3.628).abs() < 0.05, "{info}");
    // A PI zero almost cancelling a slow pole: the window follows the fast settling (~0.16 s), not
    // seven time constants of the slow pole (70 s).
    let r = skyloop(&[
        "step",
        "50*(s+0.1001)/(s*(s+0.1)*(0.02*s+1))",
        "--closed-loop",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).expect("json");
    let t_end = v["models"][0]["t_s"]
        .as_array()
        .expect("t")
        .last()
        .and_then(|x| x.as_f64())
        .expect("t");
    assert!(t_end < 1.0, "window {t_end} s");
    let r = skyloop(&["step", "1/(s+1)", "--tfinal", "nan", "--json"]);
    assert_eq!(r.status.code(), Some(2));
}
