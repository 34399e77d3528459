//! skyloop's blackbox decoder against orangebox 0.5.0 (tests/fixtures/blackbox/orangebox.json, made by
//! tools/gen_blackbox.py): the same frames, field for field, as integers; and no panic on damaged input.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

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
            // No motor value wraps (blackbox-log 0.4.3 gave 4294967253 in btfl_all.bbl session 35,
            // whose frames there are pinned in the fixture): DShot values are 0..=2047.
            for (j, name) in names.iter().enumerate().filter(|(_, n)| n.starts_with("motor[")) {
                assert!(
                    (0..d.main.len()).all(|k| (0..=2047).contains(&d.main.row(k)[j])),
                    "{file} session {index} {name}"
                );
            }
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

/// A hand-encoded Betaflight 3.x session: "P interval:1/2" (every other iteration logged), motor[0]
/// predicted from minthrottle (predictor 4), the others from motor[0]; then a log-end event.
#[test]
fn betaflight_3_session_decodes() {
    let mut b = Vec::new();
    b.extend_from_slice(b"H Product:Blackbox flight data recorder by Nicholas Sherlock\n");
    b.extend_from_slice(b"H Data version:2\nH I interval:32\nH P interval:1/2\nH minthrottle:1070\n");
    b.extend_from_slice(b"H Firmware type:Cleanflight\nH Firmware revision:Betaflight 3.5.7 (1c1e4d2) OMNIBUSF4\n");
    b.extend_from_slice(b"H Field I name:loopIteration,time,motor[0],motor[1],gyroADC[0]\n");
    b.extend_from_slice(b"H Field I signed:0,0,0,0,1\nH Field I predictor:0,0,4,5,0\nH Field I encoding:1,1,1,0,0\n");
    b.extend_from_slice(b"H Field P predictor:6,2,3,3,1\nH Field P encoding:9,0,0,0,0\n");
    // I: iteration 0, time 1000 µs, motor[0] = 1070 + 30, motor[1] = motor[0] + 50, gyro -3.
    b.extend_from_slice(&[b'I', 0, 0xE8, 0x07, 30, 100, 5]);
    // P: iteration 0 + 1 + 1 skipped = 2; time 2·1000 − 1000 + 250; motors +1, −2; gyro −3 + 4.
    b.extend_from_slice(&[b'P', 0xF4, 0x03, 2, 3, 8]);
    // P: iteration 4; time 2·1250 − 1000 + 0 = 1500; motor[0] avg(1101, 1100) + 0 = 1100.
    b.extend_from_slice(&[b'P', 0, 0, 0, 0]);
    b.extend_from_slice(&[b'E', 0xFF]);
    b.extend_from_slice(b"End of log\0");
    let raw = blackbox::decode_session(&b, 1, "bf35.bbl").unwrap();
    let m = &raw.decoded.main;
    assert_eq!(m.len(), 3);
    assert_eq!(m.row(0), &[0, 1000, 1100, 1150, -3]);
    assert_eq!(m.row(1), &[2, 1250, 1101, 1148, 1]);
    assert_eq!(m.row(2), &[4, 1500, 1100, 1149, 1]);
    assert_eq!(raw.decoded.stats.end, End::LogEnd);
    assert_eq!(raw.header.firmware, blackbox::header::Firmware::Betaflight(3, 5));
    let log = blackbox::read_bytes(&b, "bf35.bbl", None).unwrap();
    assert_eq!(log.groups[0].time_s, vec![0.0, 250e-6, 500e-6]);
    // Damage after the I-frame: the P-frames that follow cannot be trusted and are counted, not kept.
    let mut bad = b.clone();
    let p = bad.windows(2).position(|w| w == [b'P', 0xF4]).unwrap();
    bad.insert(p + 6, 0x55); // a stray byte after the first P-frame: that frame is not trusted
    let raw = blackbox::decode_session(&bad, 1, "bf35.bbl").unwrap();
    assert_eq!(raw.decoded.main.len(), 1);
    let st = raw.decoded.stats;
    assert!(st.corrupt == 1 && st.unanchored == 1 && st.end == End::LogEnd, "{st:?}");
}

/// Damage in the middle of a real log (bytes dropped, as a logging device that overflows does, or
/// overwritten): every frame decoded from the damaged file is at an iteration of the clean file, and
/// equal to it, except where the damage kept the frame's shape (the format has no checksum, so a
/// changed value inside a well-formed frame cannot be seen): such differences stay within the
/// I-intervals the damage touches, the next I-frame ends them. Decoding picks up again at the next I-frame.
#[test]
fn damage_is_dropped_not_trusted() {
    let clean_bytes = std::fs::read(data("LOG00037.BFL")).unwrap();
    let clean = blackbox::decode_session(&clean_bytes, 1, "clean").unwrap().decoded;
    let by_iteration: std::collections::HashMap<i64, usize> =
        (0..clean.main.len()).map(|k| (clean.main.row(k)[0], k)).collect();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut silent = 0;
    let cases = 90;
    for case in 0..cases {
        let mut b = clean_bytes.clone();
        let at = 20_000 + (next() as usize) % (b.len() - 40_000);
        let n = 1 + (next() as usize) % 300;
        match case % 3 {
            0 => {
                b.drain(at..at + n);
            }
            1 => b[at..at + n].iter_mut().for_each(|x| *x = next() as u8),
            _ => b[at..at + n].iter_mut().for_each(|x| *x = 0),
        }
        let d = blackbox::decode_session(&b, 1, "damaged").unwrap().decoded;
        let mut kept = 0;
        let mut differing_intervals = std::collections::BTreeSet::new();
        for k in 0..d.main.len() {
            let it = d.main.row(k)[0];
            let Some(&c) = by_iteration.get(&it) else {
                panic!(
                    "case {case}: frame at iteration {it} is not in the clean log ({:?})",
                    d.stats
                );
            };
            if d.main.row(k) != clean.main.row(c) {
                // The frame the damage is in, and the P-frames predicted from it up to the next I-frame.
                differing_intervals.insert(it / 256);
            }
            kept += 1;
        }
        // Damage of up to 300 bytes touches at most two adjacent I-intervals (~1 kB each here).
        let span = match (differing_intervals.first(), differing_intervals.last()) {
            (Some(a), Some(b)) => b - a + 1,
            _ => 0,
        };
        assert!(
            span <= 2,
            "case {case}: values differ in I-intervals {differing_intervals:?}"
        );
        silent += usize::from(!differing_intervals.is_empty());
        // At most what lies between two I-frames (32 frames) around the damage is lost.
        assert!(
            kept + 2 * 32 + n / 8 >= clean.main.len(),
            "case {case}: kept {kept} of {}",
            clean.main.len()
        );
    }
    println!("{silent} of {cases} damaged copies changed values inside well-formed frames");
}

/// Hostile input cannot make the decoder hold more than a small multiple of the file's size: here
/// 2-byte P-frames of 302 fields each (300 of them encoded as nothing) would decode to ~150 values per
/// input byte; decoding stops at the budget (8 values per byte) and says so.
#[test]
fn decoded_values_are_bounded_by_the_input_size() {
    let n = 300;
    let mut b = Vec::new();
    b.extend_from_slice(
        b"H Product:Blackbox flight data recorder by Nicholas Sherlock\nH I interval:256\nH P interval:1\n",
    );
    let names: Vec<String> = (0..n).map(|i| format!("f{i}")).collect();
    b.extend_from_slice(format!("H Field I name:loopIteration,time,{}\n", names.join(",")).as_bytes());
    let list = |first: &str, rest: &str| format!("{first},{}", vec![rest; n].join(","));
    b.extend_from_slice(format!("H Field I predictor:{}\n", list("0,0", "0")).as_bytes());
    b.extend_from_slice(format!("H Field I encoding:{}\n", list("1,1", "9")).as_bytes());
    b.extend_from_slice(format!("H Field P predictor:{}\n", list("6,1", "1")).as_bytes());
    b.extend_from_slice(format!("H Field P encoding:{}\n", list("9,0", "9")).as_bytes());
    let data_start = b.len();
    b.extend_from_slice(&[b'I', 0, 1]);
    for _ in 0..200_000 {
        b.extend_from_slice(&[b'P', 2]); // time +1 µs
    }
    let raw = blackbox::decode_session(&b, 1, "hostile.bbl").unwrap();
    let d = &raw.decoded;
    assert_eq!(d.stats.end, End::Budget);
    assert!(
        d.main.values.len() <= 8 * (b.len() - data_start) + (n + 2),
        "{}",
        d.main.values.len()
    );
    assert!(d.main.len() > 1000);
    let log = blackbox::read_bytes(&b, "hostile.bbl", None).unwrap();
    assert!(
        log.notes
            .iter()
            .any(|n| n.contains("more values than the file's size allows")),
        "{:?}",
        log.notes
    );
}
