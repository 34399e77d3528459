//! CLI: simulate, reproduce, export.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

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

const HINF_EQ12: &str = "24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+26240)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+70410))";

/// The exported header, compiled with the system C compiler, reproduces scipy's Tustin discretization
/// of the bicopter's H∞ controller eq. (12) at 250 Hz (fixture from tools/gen_control.py).
#[test]
fn export_c_header_matches_scipy_dlsim() {
    let dir = tmp("export");
    std::fs::create_dir_all(&dir).expect("dir");
    let h = dir.join("hinf.h");
    let o = skyloop()
        .args([
            "export", HINF_EQ12, "--dt", "0.004", "--double", "--name", "hinf", "--c",
        ])
        .arg(&h)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&h).expect("header");
    assert!(text.contains("#define HINF_NX 5") && text.contains("hinf_step"));
    let fx: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!(
            "{}/../skyloop-control/tests/fixtures/control/control.json",
            env!("CARGO_MANIFEST_DIR")
        ))
        .expect("fixture"),
    )
    .expect("json");
    let input: Vec<f64> = fx["hinf_bicopter"]["input"]
        .as_array()
        .expect("in")
        .iter()
        .map(|v| v.as_f64().expect("f"))
        .collect();
    let want: Vec<f64> = fx["hinf_bicopter"]["output"]
        .as_array()
        .expect("out")
        .iter()
        .map(|v| v.as_f64().expect("f"))
        .collect();
    let cc = ["cc", "gcc"]
        .into_iter()
        .find(|c| Command::new(c).arg("--version").output().is_ok());
    let Some(cc) = cc else {
        eprintln!("no C compiler: header not compiled (text checks only)");
        return;
    };
    let main = dir.join("main.c");
    let data: Vec<String> = input.iter().map(|v| format!("{v:.17e}")).collect();
    std::fs::write(
        &main,
        format!(
            "#include <stdio.h>\n#include \"hinf.h\"\nstatic const double in[] = {{{}}};\nint main(void) {{\n  hinf_state_t s; hinf_reset(&s);\n  for (unsigned i = 0; i < sizeof in / sizeof in[0]; ++i) {{ double u[1]; hinf_step(&s, &in[i], u); printf(\"%.17e\\n\", u[0]); }}\n  return 0;\n}}\n",
            data.join(",")
        ),
    )
    .expect("main.c");
    let exe = dir.join("hinf_test");
    let o = Command::new(cc)
        .arg("-std=c99")
        .arg("-Wall")
        .arg("-Werror")
        .arg("-o")
        .arg(&exe)
        .arg(&main)
        .output()
        .expect("cc");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = Command::new(&exe).output().expect("run");
    let got: Vec<f64> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| l.parse().expect("num"))
        .collect();
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = got.iter().zip(&want).fold(0.0f64, |m, (g, w)| m.max((g - w).abs())) / scale;
    assert!(err < 1e-8, "C header vs scipy dlsim: {err:e}");
}

#[test]
fn export_bad_input_exits_2() {
    let dir = tmp("export-bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let h = dir.join("x.h");
    for args in [
        vec!["export", "1/(s+1)", "--dt", "0", "--c"],
        vec!["export", "1/(s+1)", "--dt", "0.01", "--name", "9bad", "--c"],
        vec!["export", "exp(-0.1*s)/(s+1)", "--dt", "0.01", "--c"],
        vec!["export", "1/(s+", "--dt", "0.01", "--c"],
    ] {
        let o = skyloop().args(&args).arg(&h).output().expect("runs");
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

#[test]
fn reproduce_bad_invocations_exit_2() {
    let o = skyloop().args(["reproduce", "ducted-fans"]).output().expect("runs");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("ducted-fan"));
    // An output directory that cannot be created.
    let o = skyloop()
        .args(["reproduce", "ducted-fan", "--quick", "--out", "/proc/skyloop-no/such"])
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot create"));
}

#[test]
fn monte_carlo_seed_ranges_write_csv_that_splits_a_campaign() {
    let dir = tmp("mc-seeds");
    std::fs::create_dir_all(&dir).expect("dir");
    let text = std::fs::read_to_string(example("quadrotor-ssi.toml")).expect("example");
    let short = text
        .lines()
        .map(|l| {
            if l.starts_with("duration_s") {
                "duration_s = 1.5"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let spec = dir.join("mc.toml");
    std::fs::write(&spec, short).expect("spec");
    let run = |seeds: &str, out: &str| {
        let path = dir.join(out);
        let o = skyloop()
            .arg("simulate")
            .arg(&spec)
            .args(["--monte-carlo", "--json", "--seeds", seeds, "--out"])
            .arg(&path)
            .output()
            .expect("runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("summary JSON");
        (std::fs::read_to_string(&path).expect("csv"), v)
    };
    let (whole, summary) = run("0..4", "whole.csv");
    let (tail, _) = run("2..4", "tail.csv");
    let lines: Vec<&str> = whole.lines().collect();
    assert_eq!(
        lines[0],
        "run,seed,max_abs_error,rms_error,settling_time_s,saturated_fraction,crashed"
    );
    assert_eq!(lines.len(), 5);
    assert_eq!(summary["runs"], 4);
    assert!(lines[1].starts_with("0,") && lines[4].starts_with("3,"));
    // The runs 2..4 of the campaign are the same flights however the campaign is split.
    assert_eq!(tail.lines().skip(1).collect::<Vec<_>>(), lines[3..].to_vec());
    // Different seeds fly differently (the noise and parameters are per run).
    assert_ne!(lines[1].split(',').nth(3), lines[2].split(',').nth(3));
    // The same campaign as Parquet: a complete file (magic at both ends) with the same summary;
    // its contents are checked by skyloop's own test against the Parquet reader, and by pyarrow.
    let pq = dir.join("whole.parquet");
    let o = skyloop()
        .arg("simulate")
        .arg(&spec)
        .args(["--monte-carlo", "--json", "--seeds", "0..4", "--out"])
        .arg(&pq)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("summary JSON");
    assert_eq!(v, summary);
    let bytes = std::fs::read(&pq).expect("parquet");
    assert!(bytes.len() > 8 && bytes.starts_with(b"PAR1") && bytes.ends_with(b"PAR1"));
    let bad = skyloop()
        .arg("simulate")
        .arg(&spec)
        .args(["--monte-carlo", "--seeds", "5..2", "--out"])
        .arg(dir.join("bad.csv"))
        .output()
        .expect("runs");
    assert_eq!(bad.status.code(), Some(2));
}

/// A relative mass or inertia spread above 1 is refused with the option and its range named (the
/// campaign's `mass_sd = 1e9` was accepted).
#[test]
fn monte_carlo_spreads_are_bounded() {
    let src = std::fs::read_to_string(format!(
        "{}/../../examples/quadrotor-ssi.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let dir = std::env::temp_dir().join(format!("skyloop-mc-sd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("s.toml");
    std::fs::write(
        &path,
        src.replace("mass_sd = 0.05", "mass_sd = 1e9")
            .replace("runs = 100", "runs = 2"),
    )
    .unwrap();
    let out = skyloop()
        .args([
            "simulate",
            path.to_str().unwrap(),
            "--monte-carlo",
            "--out",
            dir.join("o.csv").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("monte_carlo.mass_sd") && err.contains("0..=1"), "{err}");
}

/// `monte_carlo.runs` beyond the bound is refused on every output path with the key and its range
/// named, exit 2 (issue 46: with `--out FILE.csv` the run indices were listed before any check, and
/// `runs = 1000000000000` aborted on an 8 TB allocation).
#[test]
fn monte_carlo_runs_are_bounded_on_every_path() {
    let src = std::fs::read_to_string(example("quadrotor-ssi.toml")).unwrap();
    let dir = tmp("mc-runs");
    std::fs::create_dir_all(&dir).unwrap();
    for runs in ["1000000000000", "0"] {
        let path = dir.join(format!("r{runs}.toml"));
        std::fs::write(&path, src.replace("runs = 100", &format!("runs = {runs}"))).unwrap();
        for out in ["o.csv", "o.parquet", "dir"] {
            let o = skyloop()
                .args(["simulate", path.to_str().unwrap(), "--monte-carlo", "--json", "--out"])
                .arg(dir.join(out))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "runs = {runs}, --out {out}: {err}");
            assert!(err.contains("monte_carlo.runs") && err.contains("1..=1000000"), "{err}");
        }
    }
}

/// A long run states its cost up front and reports progress on stderr (a line every 10 % when
/// stderr is not a terminal); one beyond the step bound is refused before it starts.
#[test]
fn long_simulations_state_their_cost_and_progress() {
    let dir = tmp("long");
    std::fs::create_dir_all(&dir).expect("dir");
    let text = std::fs::read_to_string(example("bicopter-hinf.toml")).expect("example");
    let scn = dir.join("long.toml");
    std::fs::write(
        &scn,
        text.replacen("duration_s = 8.0", "duration_s = 1100.0", 1)
            .replacen("log_hz = 250.0", "log_hz = 50.0", 1),
    )
    .expect("write");
    let run = || {
        skyloop()
            .arg("simulate")
            .arg(&scn)
            .arg("--out")
            .arg(dir.join("out"))
            .output()
            .expect("runs")
    };
    let o = run();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("M physics steps") && err.contains("simulated 50 %") && err.contains("simulated 100 %"),
        "{err}"
    );
    std::fs::write(&scn, text.replacen("duration_s = 8.0", "duration_s = 360000.0", 1)).expect("write");
    let o = run();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sim.duration_s × sim.physics_hz"));
}
