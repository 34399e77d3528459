//! The page's requests on the host: the same JSON as the library's CLI objects, errors for bad
//! input, and the live re-analysis agreeing with the tune it comes from.

use serde_json::json;
use skyloop_web::api;

fn log(name: &str) -> (Vec<u8>, String) {
    let path = format!("{}/../../testdata/logs/{name}", env!("CARGO_MANIFEST_DIR"));
    (std::fs::read(&path).expect("testdata log"), path)
}

#[test]
fn log_info_is_the_cli_object() {
    let (bytes, path) = log("btfl_all.bbl");
    let v = api::log_info(&bytes, &path, None).unwrap();
    let from_file = skyloop::sysid::logs::Log::open(std::path::Path::new(&path), &Default::default()).unwrap();
    assert_eq!(v, skyloop::flightlog::info_json(&path, &from_file, Some(&bytes)));
    assert_eq!(v["format"], "blackbox");
    assert_eq!(v["sessions"].as_array().map(Vec::len), Some(44));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let e = api::log_info(&[0xff, 0xfe, 0, 1, 2], "junk.bin", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a ULog, blackbox, DataFlash or CSV file"), "{e}");
    assert!(api::log_info(&[], "empty.bbl", None)
        .unwrap_err()
        .to_string()
        .contains("empty"));
    assert!(api::tune_log(b"time,x\n0,1\n", "a.csv", &json!({}), None).is_err());
    assert!(api::margins("1/(s+").is_err());
    assert!(api::ncfsyn(&json!({"plant": "1/(s+1)", "w1": "s^"})).is_err());
}

#[test]
fn live_retune_at_the_proposal_is_the_proposal() {
    let (bytes, path) = log("pid-analyzer_example_smooth_tune.BBL");
    let (v, live) = api::tune_log(&bytes, &path, &json!({"axis": "roll"}), None).unwrap();
    let live = live.expect("a Betaflight log with flown gains");
    let g = live.gains(&v["proposed"]["gains"]).unwrap();
    let r = live.evaluate(&g, true).unwrap();
    for k in [
        "disk_alpha",
        "gain_margin_db",
        "phase_margin_deg",
        "crossover_hz",
        "ms",
        "mt",
    ] {
        assert_eq!(r["margins"][k], v["proposed"]["margins"][k], "{k}");
        assert_eq!(r["worst_margins"][k], v["proposed"]["worst_margins"][k], "{k}");
    }
    assert_eq!(
        r["loop"]["freq_hz"].as_array().map(Vec::len),
        Some(skyloop::tune::live::GRID_POINTS)
    );
    // A lower P: a different loop, still analysed.
    let mut knobs = v["live"]["flown"]["gains"].clone();
    knobs["p"] = json!(7);
    let r2 = live.evaluate(&live.gains(&knobs).unwrap(), false).unwrap();
    assert!(r2["margins"]["crossover_hz"].as_f64() < r["margins"]["crossover_hz"].as_f64());
    assert!(r2["worst_margins"].is_null());
    assert!(live.gains(&json!({"p": -1})).is_err());
    assert!(live.gains(&json!({"dterm_hz": [100, 100, 100, 100]})).is_err());
}

#[test]
fn ncfsyn_of_the_bicopter_paper() {
    // The bicopter paper's W1, W2 and 3rd-order Padé: γ_min = 1.748 (Sec. IV).
    let v = api::ncfsyn(&json!({
        "plant": "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)",
        "w1": "0.03511*(s+0.3419)/s",
        "w2": "307.5*(s+3.816)/((s+11.35)*(s+103.4))",
        "pade": 3,
    }))
    .unwrap();
    assert!(
        (v["gamma_min"].as_f64().unwrap() - 1.748).abs() < 5e-3,
        "{}",
        v["gamma_min"]
    );
    let b = v["analysis"]["b_pc"].as_f64().unwrap();
    assert!(b > 0.0 && b < 1.0, "{b}");
    let h = api::c_header(&v["controller"].to_string(), 0.002, "ctrl").unwrap();
    assert!(h.contains("ctrl"));
}
