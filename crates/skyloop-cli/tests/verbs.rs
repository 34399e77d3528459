//! MATLAB's verbs on the command line: loops from a plant and a controller, series / parallel /
//! feedback / loopsens, lsim / impulse / d2c, augw → hinfsyn → margins, and the exit-0 defects of
//! the first-hour session, each checked on a second code path.
#![allow(clippy::unwrap_used)]

mod common;
use common::skyloop;
use serde_json::Value;

fn json(args: &[&str]) -> Value {
    let (code, out, err) = skyloop(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

fn tmp(name: &str) -> String {
    std::env::temp_dir()
        .join(format!("skyloop-verbs-{}-{name}", std::process::id()))
        .to_string_lossy()
        .into_owned()
}

/// margin(P*C) from --plant/--controller equals the margins of the product written out.
#[test]
fn margins_of_plant_and_controller_equal_those_of_the_product() {
    let a = json(&[
        "margins",
        "--plant",
        "10/(s*(s+1))",
        "--controller",
        "(s+2)/(s+20)",
        "--json",
    ]);
    let b = json(&["margins", "10*(s+2)/(s*(s+1)*(s+20))", "--json"]);
    for k in ["gain_margin_db", "phase_margin_deg", "delay_margin_s"] {
        if a[k].is_null() && b[k].is_null() {
            continue;
        }
        let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
        assert!((x - y).abs() < 1e-6 * y.abs().max(1.0), "{k}: {x} vs {y}\n{a}");
    }
}

/// A controller written to a file by `ncfsyn --out` enters an expression as `@C.json`: the margins
/// of `@P.json*@C.json` (and of a plant expression times the file) equal those of
/// `--plant P --controller C`.
#[test]
fn expressions_name_model_files() {
    let dir = tmp("at-files");
    std::fs::create_dir_all(&dir).unwrap();
    let c = format!("{dir}/C.json");
    let p = format!("{dir}/P.json");
    let plant = "0.09*exp(-0.03*s)/(s*(0.03*s+1))";
    let (code, _, err) = skyloop(&["ncfsyn", plant, "--w1", "20*(s+2)/s", "--out", &c]);
    assert_eq!(code, 0, "{err}");
    let pj = json(&["show", plant, "--json"]);
    std::fs::write(&p, pj.to_string()).unwrap();
    let a = json(&["margins", "--plant", plant, "--controller", &c, "--json"]);
    for expr in [format!("@{p}*@{c}"), format!("{plant}*@{c}")] {
        let b = json(&["margins", &expr, "--json"]);
        for k in ["gain_margin_db", "phase_margin_deg", "delay_margin_s"] {
            let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
            assert!((x - y).abs() < 1e-6 * y.abs().max(1.0), "{expr} {k}: {x} vs {y}");
        }
    }
    let (code, _, err) = skyloop(&["margins", &format!("{dir}/nothere.json")]);
    assert_eq!(code, 2);
    assert!(err.contains("@"), "{err}");
}

/// loopsens's S peak is the H∞ norm of 1/(1 + L) written out; with a negligible loop delay the
/// frequency-response path gives the same peaks as the state-space path.
#[test]
fn loopsens_peaks_match_the_closed_forms_and_both_paths() {
    let v = json(&["loopsens", "10/(s*(s+1))", "(s+2)/(s+20)", "--json"]);
    assert_eq!(v["stable"], true);
    let peak = |v: &Value, n: &str| {
        v["sensitivities"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == n)
            .unwrap()["peak"]
            .as_f64()
            .unwrap()
    };
    let s_direct = json(&["norm", "s*(s+1)*(s+20)/(s*(s+1)*(s+20)+10*(s+2))", "--json"]);
    let hinf = s_direct["hinf"].as_f64().unwrap();
    assert!(
        (peak(&v, "S") - hinf).abs() < 1e-6 * hinf,
        "{} vs {hinf}",
        peak(&v, "S")
    );
    let d = json(&["loopsens", "10*exp(-1e-9*s)/(s*(s+1))", "(s+2)/(s+20)", "--json"]);
    for n in ["S", "T", "CS", "PS"] {
        assert!(
            (peak(&v, n) - peak(&d, n)).abs() < 2e-3 * peak(&v, n),
            "{n}: {} vs {}",
            peak(&v, n),
            peak(&d, n)
        );
    }
    let (code, _, err) = skyloop(&["loopsens", "1/(s+1)", "[1]"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn series_parallel_feedback() {
    let show = |args: &[&str]| {
        let (code, out, err) = skyloop(args);
        assert_eq!(code, 0, "{err}");
        out.lines().last().unwrap().to_string()
    };
    assert_eq!(show(&["feedback", "1/s", "1"]), "1/(s+1)");
    assert_eq!(show(&["feedback", "1/s", "1", "--sign", "1"]), "1/(s-1)");
    assert_eq!(show(&["series", "1/(s+1)", "2*exp(-0.1*s)"]), "2*exp(-0.1*s)/(s+1)");
    assert_eq!(show(&["parallel", "1/(s+1)", "1/(s+2)"]), "2*(s+1.5)/((s+1)*(s+2))");
    let (code, _, err) = skyloop(&["feedback", "1/s", "1", "--sign", "0.5"]);
    assert!(code == 2 && err.contains("--sign"), "{err}");
}

/// lsim of a step equals 1 − e^(−t); impulse of 2e^(−0.25 s)/(s+1) is 2e^(−(t−0.25)) after the
/// delay; d2c undoes c2d (zoh).
#[test]
fn lsim_impulse_and_d2c() {
    let v = json(&[
        "lsim", "1/(s+1)", "--input", "step", "--dt", "0.01", "--tfinal", "5", "--json",
    ]);
    let y = v["y"].as_array().unwrap();
    assert!((y[300][0].as_f64().unwrap() - (1.0 - (-3.0f64).exp())).abs() < 1e-9);
    let csv = tmp("u.csv");
    std::fs::write(&csv, "time_s,u\n0,1\n0.5,1\n1.0,0\n1.5,0\n").unwrap();
    let v = json(&["lsim", "1/(s+1)", "--input", &csv, "--json"]);
    let y1 = v["y"][2][0].as_f64().unwrap();
    assert!((y1 - (1.0 - (-1.0f64).exp())).abs() < 1e-9, "{y1}");
    let v = json(&["impulse", "2*exp(-0.25*s)/(s+1)", "--tfinal", "3", "--json"]);
    let t: Vec<f64> = v["t_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (k, tk) in t.iter().enumerate().step_by(37) {
        let want = if *tk > 0.25 + 1e-9 {
            2.0 * (-(tk - 0.25)).exp()
        } else {
            0.0
        };
        assert!((v["y"][k][0].as_f64().unwrap() - want).abs() < 1e-6, "t {tk}");
    }
    let d = tmp("d.json");
    let (code, out, _) = skyloop(&["c2d", "(s+3)/((s+1)*(s+5))", "--dt", "0.05", "--json"]);
    assert_eq!(code, 0);
    std::fs::write(&d, out).unwrap();
    let back = json(&["d2c", &d, "--json"]);
    let bp = tmp("back.json");
    std::fs::write(&bp, back.to_string()).unwrap();
    let (a, b) = (
        json(&["freqresp", &bp, "--hz", "0.3", "--json"]),
        json(&["freqresp", "(s+3)/((s+1)*(s+5))", "--hz", "0.3", "--json"]),
    );
    let (x, y) = (freq_value(&a), freq_value(&b));
    assert!((x.0 - y.0).abs() < 1e-8 && (x.1 - y.1).abs() < 1e-8, "{x:?} vs {y:?}");
    let (code, _, err) = skyloop(&["d2c", "1/(s+1)"]);
    assert!(code == 2 && err.contains("continuous"), "{err}");
    // A fast discrete pole, z = 1e-100 at dt = 0.01: the continuous pole is ln(1e-100)/0.01 =
    // −23026 rad/s (the matrix logarithm's unscaled square roots gave −6793 for any z ≤ 1e-100);
    // a pole at z = −0.5 has no ZOH preimage and is named.
    let fast = tmp("fast.json");
    std::fs::write(&fast, r#"{"a":[[1e-100]],"b":[[1]],"c":[[1]],"d":[[0]],"dt":0.01}"#).unwrap();
    let back = json(&["d2c", &fast, "--json"]);
    let pole = back["a"][0][0].as_f64().unwrap();
    assert!((pole - 1e-100f64.ln() / 0.01).abs() < 1e-9 * pole.abs(), "{pole}");
    std::fs::write(&fast, r#"{"a":[[-0.5]],"b":[[1]],"c":[[1]],"d":[[0]],"dt":0.01}"#).unwrap();
    let (code, _, err) = skyloop(&["d2c", &fast]);
    assert!(code == 2 && err.contains("z = -0.5") && err.contains("tustin"), "{err}");
    // A signal the grid cannot carry is refused, not aliased: 60 Hz sampled at 100 Hz would be a
    // 40 Hz input; a pulse shorter than one step would be one sample or none.
    let (code, _, err) = skyloop(&["lsim", "1/(s+1)", "--input", "sin:60", "--dt", "0.01", "--tfinal", "1"]);
    assert!(code == 2 && err.contains("Nyquist frequency 50 Hz"), "{err}");
    let (code, _, err) = skyloop(&[
        "lsim",
        "1/(s+1)",
        "--input",
        "pulse:0.001",
        "--dt",
        "0.01",
        "--tfinal",
        "1",
    ]);
    assert!(code == 2 && err.contains("shorter than one step"), "{err}");
    // A model file that never ends (a device) is refused by name, not read forever.
    let (code, _, err) = skyloop(&["margins", "@\"/dev/urandom\""]);
    assert!(code == 2 && err.contains("not a regular file"), "{err}");
    for verb in ["design", "simulate"] {
        let (code, _, err) = skyloop(&[verb, "/dev/urandom"]);
        assert!(code == 2 && err.contains("not a regular file"), "{verb}: {err}");
    }
    // Logs likewise (/dev/zero passed as text and was read to the 4 GiB cap), and a log tune's
    // --starts is held to its range as a model tune's is (0 and 65 ran before).
    let log = format!("{}/../../testdata/logs/LOG00037.BFL", env!("CARGO_MANIFEST_DIR"));
    let (code, _, err) = skyloop(&["log", "compare", &log, "/dev/zero"]);
    assert!(code == 2 && err.contains("not a regular file"), "{err}");
    for starts in ["0", "65"] {
        let (code, _, err) = skyloop(&["tune", &log, "--starts", starts]);
        assert!(
            code == 2 && err.contains("--starts must be in 1..=64"),
            "{starts}: {err}"
        );
    }
    // A huge response is printed in exponent form, not as 300 digits.
    let csv = tmp("huge.csv");
    std::fs::write(&csv, "time_s,u\n0,1\n0.1,1e308\n0.2,1e308\n").unwrap();
    let (code, out, err) = skyloop(&["lsim", "1/(s+1)", "--input", &csv]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("largest |y| = 9.5") && out.contains("e306") && out.len() < 200,
        "{out}"
    );
}

/// The one response value of `freqresp --json` (`re[output][input][k]`).
fn freq_value(v: &Value) -> (f64, f64) {
    (v["re"][0][0][0].as_f64().unwrap(), v["im"][0][0][0].as_f64().unwrap())
}

/// augw → hinfsyn → margins: the mixed-sensitivity controller stabilizes the plant, γ < 1.
#[test]
fn augw_then_hinfsyn_then_margins() {
    let plant = tmp("aug.json");
    let k = tmp("K.json");
    let g = "200/((10*s+1)*(0.05*s+1)^2)";
    let (code, out, err) = skyloop(&[
        "augw",
        g,
        "--w1",
        "(s/2+6.28)/(s+6.28e-3)",
        "--w2",
        "0.1",
        "--w3",
        "(s+6.28)/(0.01*s+62.8)",
        "--out",
        &plant,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("nmeas = 1, ncon = 1"), "{out}");
    let h = json(&["hinfsyn", &plant, "--nmeas", "1", "--ncon", "1", "--out", &k, "--json"]);
    assert!(h["gamma"].as_f64().unwrap() < 1.0, "{h}");
    let m = json(&["margins", "--plant", g, "--controller", &k, "--json"]);
    assert_eq!(m["closed_loop_stable"], true, "{m}");
    assert!(m["phase_margin_deg"].as_f64().unwrap() > 30.0, "{m}");
}

/// The exit-0 defects: a 1e9 s window still reports 1/(s+1)'s 2.2 s rise; an unstable loop lists
/// no per-crossover delay margin; a negative number after an option reaches its range check.
#[test]
fn first_hour_defects_stay_fixed() {
    let v = json(&["step", "1/(s+1)", "--tfinal", "1e9", "--json"]);
    let rise = v["models"][0]["info"][0][0]["rise_time_s"].as_f64().unwrap();
    assert!((rise - 9f64.ln()).abs() < 1e-3, "{rise}");
    let (code, out, _) = skyloop(&["margins", "20/(s*(s+1)*(0.1*s+1))"]);
    assert_eq!(code, 0);
    assert!(out.contains("UNSTABLE") && !out.contains("delay margin 1.4"), "{out}");
    let (code, _, err) = skyloop(&["c2d", "1/(s+1)", "--dt", "-0.01"]);
    assert_eq!(code, 2);
    assert!(err.contains("-0.01") && !err.contains("unexpected argument"), "{err}");
}

/// A flash dump's empty sessions are summarized, not listed one per line; a poorly validating
/// identification says so.
#[test]
fn log_info_summarizes_and_identify_warns() {
    let log = format!("{}/../../testdata/logs/btfl_all.bbl", env!("CARGO_MANIFEST_DIR"));
    let (code, out, err) = skyloop(&["log", "info", &log]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        out.lines()
            .filter(|l| l.trim_start().starts_with("not decodable"))
            .count(),
        1,
        "{out}"
    );
    assert!(out.contains("37 session(s): 2–3, 5–11"), "{out}");
    let (code, out, err) = skyloop(&["identify", &log, "--axis", "roll"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("held-out validation is poor") || err.contains("held-out validation is poor"),
        "{out}{err}"
    );
}

/// (s−1)/((s−0.5)(s−2)) has its real RHP zero between its two real RHP poles: every stabilizing
/// controller is unstable (parity interlacing), so hinfstruct's must be flagged.
#[test]
fn hinfstruct_flags_an_unstable_controller() {
    let plant = tmp("pi.json");
    let (code, _, err) = skyloop(&[
        "augw",
        "(s-1)/((s-0.5)*(s-2))",
        "--w1",
        "0.1/(s+0.01)",
        "--w2",
        "0.1",
        "--out",
        &plant,
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = skyloop(&[
        "hinfstruct",
        &plant,
        "--nmeas",
        "1",
        "--ncon",
        "1",
        "--order",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(
        v["warnings"][0]
            .as_str()
            .unwrap()
            .contains("controller itself is unstable"),
        "{v}"
    );
    assert!(err.contains("warning: the controller itself is unstable"), "{err}");
}

/// tune does not advise an option it does not have.
#[test]
fn tune_refusal_names_options_tune_has() {
    let log = format!("{}/../../testdata/logs/LOG00037.BFL", env!("CARGO_MANIFEST_DIR"));
    let (code, _, err) = skyloop(&["tune", &log, "--firmware", "betaflight", "--axis", "roll"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        !err.contains("or --allow-poor-fit to fit anyway")
            && err.contains("skyloop identify LOG --axis roll --allow-poor-fit"),
        "{err}"
    );
}

/// Sizes a user sets are refused up front, naming the option and its bound.
#[test]
fn sizes_are_bounded_up_front() {
    let (code, _, err) = skyloop(&[
        "hinfstruct",
        &format!("{}/../../examples/augw-plant.json", env!("CARGO_MANIFEST_DIR")),
        "--nmeas",
        "1",
        "--ncon",
        "1",
        "--order",
        "50",
        "--starts",
        "1000",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("minutes") && err.contains("1000 starts"), "{err}");
    let log = format!("{}/../../testdata/logs/btfl_all.bbl", env!("CARGO_MANIFEST_DIR"));
    let (code, _, err) = skyloop(&["identify", &log, "--axis", "roll", "--n-freq", "1000000"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--n-freq 1000000") && err.contains("20000"), "{err}");
}
