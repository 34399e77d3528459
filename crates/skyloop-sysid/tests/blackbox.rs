//! skyloop's blackbox decoder against orangebox 0.5.0 (tests/fixtures/blackbox/orangebox.json, made by
//! tools/gen_blackbox.py): the same frames, field for field, as integers; and no panic on damaged input.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use serde_json::Value;
use skyloop_sysid::logs::blackbox::{self, decode::End};

fn data(name: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/logs")).join(name)
}

fn fixture() -> Value {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/blackbox/orangebox.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn ints(v: &Value) -> Vec<i64> {
    v.as_array().unwrap().iter().map(|x| x.as_i64().unwrap()).collect()
}

#[test]
fn every_session_matches_orangebox() {
    let fx = fixture();
    let mut report = Vec::new();
    for (file, f) in fx["files"].as_object().unwrap() {
        let bytes = std::fs::read(data(file)).unwrap();
        let sessions = f["sessions"].as_array().unwrap();
        assert_eq!(blackbox::session_count(&bytes), sessions.len(), "{file}");
        for s in sessions {
            let index = s["index"].as_u64().unwrap() as usize;
            let raw = blackbox::decode_session(&bytes, index, file).unwrap_or_else(|e| panic!("{e}"));
            let d = &raw.decoded;
            let Some(expected) = s["frames"].as_u64().map(|n| n as usize) else {
                // orangebox cannot split out this session (it holds no frames, only a disarm and a
                // log-end event); neither do we find any.
                assert_eq!(d.main.len(), 0, "{file} session {index}");
                report.push(format!("{file} #{index}: 0 frames (orangebox: {})", s["error"]));
                continue;
            };
            let names: Vec<&str> = raw.header.defs.intra.iter().map(|f| f.name.as_str()).collect();
            let fx_names: Vec<&str> = s["fields"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_str().unwrap())
                .collect();
            assert_eq!(names, fx_names, "{file} session {index}");
            if expected == 0 {
                assert_eq!(d.main.len(), 0, "{file} session {index}");
                continue;
            }
            // orangebox starts at its first I-frame (see tools/gen_blackbox.py); so do we here.
            let first = s["first_iteration"].as_i64().unwrap();
            let k0 = (0..d.main.len())
                .find(|&k| d.main_is_intra[k] && d.main.row(k)[0] == first)
                .unwrap_or_else(|| panic!("{file} session {index}: no I-frame at iteration {first}"));
            let ours = d.main.len() - k0;
            // orangebox drops a session's last frame when no log-end event follows it.
            let extra = usize::from(s["ended_by"] != "log end" && d.stats.end != End::LogEnd);
            assert!(
                ours == expected || ours == expected + extra,
                "{file} session {index}: {ours} frames from iteration {first}, orangebox {expected}"
            );
            let mut max_dev = 0i64;
            for (j, name) in names.iter().enumerate() {
                let sum: i64 = (k0..k0 + expected).map(|k| d.main.row(k)[j]).sum();
                let want = s["sums"][name].as_i64().unwrap();
                max_dev = max_dev.max((sum - want).abs());
                assert_eq!(sum, want, "{file} session {index}: sum of {name}");
            }
            let cols: Vec<usize> = s["selected_fields"]
                .as_array()
                .unwrap()
                .iter()
                .map(|n| names.iter().position(|x| *x == n.as_str().unwrap()).unwrap())
                .collect();
            let selected = s["selected"].as_array().unwrap();
            for row in selected {
                let r = row.as_array().unwrap();
                let k = k0 + r[0].as_u64().unwrap() as usize;
                assert_eq!(d.main_is_intra[k], r[1] == "I", "{file} session {index} frame {k}");
                let want = ints(&Value::Array(r[2..].to_vec()));
                let got: Vec<i64> = cols.iter().map(|&c| d.main.row(k)[c]).collect();
                for (g, w) in got.iter().zip(&want) {
                    max_dev = max_dev.max((g - w).abs());
                }
                assert_eq!(
                    got, want,
                    "{file} session {index} frame {k} ({:?})",
                    s["selected_fields"]
                );
            }
            assert_eq!(max_dev, 0);
            report.push(format!(
                "{file} #{index}: {} main frames ({k0} before orangebox's first I-frame), {} checked in full, max deviation {max_dev}; stats {:?}",
                d.main.len(),
                selected.len(),
                d.stats
            ));
        }
    }
    println!("{}", report.join("\n"));
}

#[test]
fn loop_iteration_follows_the_logging_rate() {
    // LOG00037.BFL: "P interval:8" — one main frame every 8 loop iterations, an I-frame every 256.
    let bytes = std::fs::read(data("LOG00037.BFL")).unwrap();
    let raw = blackbox::decode_session(&bytes, 1, "LOG00037.BFL").unwrap();
    let m = &raw.decoded.main;
    assert!(m.len() > 16000);
    let steps: Vec<i64> = (1..m.len()).map(|k| m.row(k)[0] - m.row(k - 1)[0]).collect();
    assert!(
        steps.iter().all(|&s| s == 8),
        "{:?}",
        steps.iter().filter(|&&s| s != 8).take(5).collect::<Vec<_>>()
    );
    for k in 0..m.len() {
        assert_eq!(raw.decoded.main_is_intra[k], m.row(k)[0] % 256 == 0, "frame {k}");
    }
    assert_eq!(raw.decoded.stats.end, End::LogEnd);
    assert_eq!(raw.decoded.stats.corrupt, 0);
    // Motors stay within DShot's 0..2047: no 32-bit wrap anywhere.
    let names: Vec<&str> = raw.header.defs.intra.iter().map(|f| f.name.as_str()).collect();
    for i in 0..4 {
        let c = names.iter().position(|n| *n == format!("motor[{i}]")).unwrap();
        let (lo, hi) = (0..m.len()).fold((i64::MAX, i64::MIN), |(a, b), k| {
            (a.min(m.row(k)[c]), b.max(m.row(k)[c]))
        });
        assert!(lo >= 0 && hi <= 2047, "motor[{i}] in {lo}..={hi}");
    }
}

fn mangle(bytes: &[u8], cut: usize, flips: &[(usize, u8)]) -> Vec<u8> {
    let mut b = bytes[..cut.min(bytes.len())].to_vec();
    for &(at, bit) in flips {
        if !b.is_empty() {
            let i = at % b.len();
            b[i] ^= 1 << (bit % 8);
        }
    }
    b
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Truncated and bit-flipped logs give an error or a log, never a panic; frames keep their shape.
    #[test]
    fn damaged_logs_never_panic(
        cut in 0usize..60_000,
        flips in proptest::collection::vec((0usize..60_000, 0u8..8), 0..40),
        which in 0usize..3,
    ) {
        let name = ["LOG00037.BFL", "btfl_001.bbl", "btfl_all.bbl"][which];
        let full = std::fs::read(data(name)).unwrap();
        // btfl_all.bbl: start inside session 4, the flight.
        let start = if which == 2 { 18432 } else { 0 };
        let bytes = mangle(&full[start..], cut, &flips);
        let _ = blackbox::sessions(&bytes, name);
        if let Ok(log) = blackbox::read_bytes(&bytes, name, None) {
            for g in &log.groups {
                prop_assert!(g.channels.iter().all(|c| c.values.len() == g.time_s.len()));
                prop_assert!(g.time_s.iter().all(|t| t.is_finite()));
            }
        }
    }
}
