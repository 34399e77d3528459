//! The ULog reader's time origin, duration and per-topic sample counts against pyulog 1.3.0
//! (tests/fixtures/ulog/pyulog.json, made by tools/gen_ulog.py with the same data-span rule).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::Path;

use serde_json::Value;
use skyloop_sysid::logs::{Log, OpenOptions};

#[test]
fn durations_and_topics_match_pyulog() {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/ulog/pyulog.json");
    let fx: Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    let mut report = Vec::new();
    for (file, f) in fx["files"].as_object().unwrap() {
        let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/logs")).join(file);
        let log = Log::open(&path, &OpenOptions::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
        let start = f["span_start_us"].as_i64().unwrap();
        let want = f["duration_s"].as_f64().unwrap();
        assert!(
            (log.duration_s() - want).abs() < 1e-9,
            "{file}: {} s, pyulog-based {want} s",
            log.duration_s()
        );
        let mut stale = 0;
        for t in f["topics"].as_array().unwrap() {
            let (name, multi) = (t["name"].as_str().unwrap(), t["multi_id"].as_u64().unwrap());
            let group = if multi == 0 {
                name.to_string()
            } else {
                format!("{name}[{multi}]")
            };
            let kept = t["kept"].as_u64().unwrap() as usize;
            stale += t["messages"].as_u64().unwrap() as usize - kept;
            let g = log.groups.iter().find(|g| g.name == group);
            if kept == 0 {
                assert!(g.is_none(), "{file} {group}: only stale messages, yet listed");
                continue;
            }
            let g = g.unwrap_or_else(|| panic!("{file}: no group {group}"));
            assert_eq!(g.time_s.len(), kept, "{file} {group}");
            let first = (t["kept_first_us"].as_i64().unwrap() - start) as f64 * 1e-6;
            let last = (t["kept_last_us"].as_i64().unwrap() - start) as f64 * 1e-6;
            assert!(
                (g.time_s[0] - first).abs() < 1e-9 && (g.time_s[kept - 1] - last).abs() < 1e-9,
                "{file} {group}"
            );
        }
        if stale > 0 {
            assert!(
                log.notes
                    .iter()
                    .any(|n| n.starts_with(&format!("{stale} messages with stale"))),
                "{file}: {:?}",
                log.notes
            );
        }
        report.push(format!(
            "{file}: {:.3} s (pyulog header-to-last {:.3} s), {} topics, {stale} stale messages",
            log.duration_s(),
            f["pyulog_duration_s"].as_f64().unwrap(),
            log.groups.len()
        ));
    }
    println!("{}", report.join("\n"));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 64, ..Default::default() })]

    /// Truncated and bit-flipped ULogs give an error or a log with notes, and px4-ulog never panics
    /// on them (a caught panic would surface as "the ULog parser failed on corrupt data", and its
    /// message would reach stderr): the record guard cuts the file before any record it would.
    #[test]
    fn damaged_ulogs_never_reach_a_panic(
        cut in 20usize..500_000,
        flips in proptest::collection::vec((0usize..60_000, 0u8..8), 1..30),
        which in 0usize..3,
    ) {
        let name = ["sample_log_small.ulg", "sample_appended_multiple.ulg", "esc_status_log.ulg"][which];
        let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/logs")).join(name);
        let mut b = std::fs::read(path).unwrap();
        b.truncate(cut.max(20));
        for (at, bit) in flips {
            let i = at % b.len();
            b[i] ^= 1 << bit;
        }
        match skyloop_sysid::logs::ulog::read_bytes(&b, name) {
            Ok(log) => {
                for g in &log.groups {
                    proptest::prop_assert!(g.channels.iter().all(|c| c.values.len() == g.time_s.len()));
                }
            }
            Err(e) => proptest::prop_assert!(!e.to_string().contains("failed on corrupt"), "{}", e),
        }
    }
}
