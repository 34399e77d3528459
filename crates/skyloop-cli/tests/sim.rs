//! CLI: simulate, reproduce, export.

use std::process::Command;

fn skyloop() -> Command {
    Command::new(env!("CARGO_BIN_EXE_skyloop"))
}

fn example(name: &str) -> String {
    format!("{}/../../examples/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("skyloop-cli-sim-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn simulate_writes_csv_metrics_and_json() {
    let out = tmp("sim");
    let o = skyloop()
        .args(["simulate", &example("quadrotor-ssi.toml"), "--json", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    for k in [
        "max_abs_error",
        "rms_error",
        "settling_time_s",
        "saturated_fraction",
        "crashed",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["crashed"], false);
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).expect("csv");
    assert!(csv.starts_with("t_s,x_m,"));
    assert!(csv.lines().count() > 1000);
    assert!(out.join("metrics.json").is_file());
    assert!(out.join("trajectory.svg").is_file());
}

#[test]
fn simulate_bad_input_exits_2() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let cases = [
        ("missing.toml", None),
        ("garbage.toml", Some("this is = = not toml")),
        (
            "unknown_preset.toml",
            Some(
                &*std::fs::read_to_string(example("quadrotor-ssi.toml"))
                    .expect("ex")
                    .replace("quadrotor-ssi\"", "nope\""),
            ),
        ),
        (
            "bad_rate.toml",
            Some(
                &*std::fs::read_to_string(example("quadrotor-ssi.toml"))
                    .expect("ex")
                    .replace("rate_hz = 500.0", "rate_hz = 300.0"),
            ),
        ),
        (
            "neg_mass.toml",
            Some(
                &*std::fs::read_to_string(example("quadrotor-ssi.toml"))
                    .expect("ex")
                    .replace(
                        "preset = \"quadrotor-ssi\"",
                        "preset = \"quadrotor-ssi\"\nmass_kg = -1.0",
                    ),
            ),
        ),
    ];
    for (name, text) in cases {
        let p = dir.join(name);
        if let Some(t) = text {
            std::fs::write(&p, t).expect("write");
        }
        let o = skyloop()
            .arg("simulate")
            .arg(&p)
            .arg("--out")
            .arg(dir.join("o"))
            .output()
            .expect("runs");
        assert_eq!(
            o.status.code(),
            Some(2),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(String::from_utf8_lossy(&o.stderr).starts_with("error: "), "{name}");
    }
}

#[test]
fn reproduce_quadrotor_ssi_passes_and_unknown_name_fails() {
    let out = tmp("repro");
    let o = skyloop()
        .args(["reproduce", "quadrotor-ssi", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}\n{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("all claims reproduced"));
    assert!(out.join("fig6_8_roll.svg").is_file());
    let o = skyloop().args(["reproduce", "no-such-paper"]).output().expect("runs");
    assert_eq!(o.status.code(), Some(2));
}
