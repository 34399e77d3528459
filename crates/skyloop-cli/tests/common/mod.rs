//! Shared by the CLI test files: running the built `skyloop` binary.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::process::Command;

/// Runs `skyloop` with `args`: (exit code, stdout, stderr); −1 when killed by a signal.
pub fn skyloop(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .output()
        .expect("run skyloop");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
