//! Property test of the CLI entry points: random argument lists for the quick commands (random
//! models, flags and hostile values) end with status 0 or 2 within a time limit, never a panic, a
//! signal or a Debug dump on stderr.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use proptest::prelude::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const COMMANDS: &[&str] = &[
    "freqresp", "margins", "norm", "poles", "zeros", "c2d", "pade", "show", "reduce", "minreal", "mu",
];
const MODELS: &[&str] = &[
    "1/(s+1)",
    "exp(-0.02*s)*100/(s*(0.03*s+1))",
    "(s-1)/(s+1)",
    "1/(s+1)^30",
    "1e300/(s+1e-300)",
    "s^3/(s+1)",
    "1/(s^2+1)",
    "1/s",
    "((s+1)",
    "",
    "nan/(s+1)",
    "exp(-1e9*s)/(s+1)",
    "1/(s+1e-300)",
];
const FLAGS: &[&str] = &[
    "--json",
    "--hz",
    "--logspace-hz",
    "--dt",
    "--method",
    "--order",
    "--blocks",
    "--form",
    "--prewarp-hz",
];
const VALUES: &[&str] = &[
    "1",
    "0",
    "-1",
    "nan",
    "inf",
    "1e300",
    "1e-320",
    "0.1,1,100",
    "1,0.1,10",
    "1e-3,1e3,1e12",
    "zoh",
    "tustin",
    "balanced",
    "spa",
    "c1x1",
    "r1,c1x1",
    "f2x2",
    "tf",
    "zpk",
    "20",
    "99999999999",
    "",
];

fn arg() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => prop::sample::select(FLAGS).prop_map(str::to_string),
        4 => prop::sample::select(VALUES).prop_map(str::to_string),
        1 => prop::sample::select(MODELS).prop_map(str::to_string),
    ]
}

/// Runs the binary with a 30 s limit: (status, stderr); status −1 when killed by a signal.
fn run(args: &[String]) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run skyloop");
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            let mut err = String::new();
            use std::io::Read;
            child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
            return (Some(status.code().unwrap_or(-1)), err);
        }
        if Instant::now() > deadline {
            child.kill().ok();
            child.wait().ok();
            return (None, String::new());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 150, ..ProptestConfig::default() })]

    #[test]
    fn random_arguments_end_with_0_or_2(
        cmd in prop::sample::select(COMMANDS),
        model in prop::sample::select(MODELS),
        rest in prop::collection::vec(arg(), 0..6),
    ) {
        let mut args = vec![cmd.to_string(), model.to_string()];
        args.extend(rest);
        let (status, err) = run(&args);
        prop_assert!(status.is_some(), "{args:?} did not finish in 30 s");
        let status = status.unwrap();
        prop_assert!(status == 0 || status == 2, "{args:?}: status {status}: {err}");
        prop_assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "{args:?}: {err}");
        prop_assert!(!err.contains(" { ") , "{args:?}: a Debug dump: {err}");
        if status == 2 {
            prop_assert!(err.starts_with("error"), "{args:?}: {err}");
        }
    }
}
