//! Every sample flight log is read or refused with a clear message; channels have sane content;
//! truncated, corrupt and foreign files give errors (or notes) instead of panics.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::{Path, PathBuf};

use skyloop_sysid::logs::{blackbox, Log, LogFormat, OpenOptions};

fn data(name: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/logs")).join(name)
}

fn open(name: &str) -> Log {
    Log::open(&data(name), &OpenOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn temp_with(name: &str, bytes: &[u8]) -> PathBuf {
    let p = std::env::temp_dir().join(format!("skyloop-sysid-{}-{name}", std::process::id()));
    std::fs::write(&p, bytes).unwrap();
    p
}

const ALL: [&str; 11] = [
    "sample.ulg",
    "sample_log_small.ulg",
    "sample_px4_events.ulg",
    "sample_logging_tagged_and_default_params.ulg",
    "sample_appended_multiple.ulg",
    "6ba1abc7-b433-4029-b8f5-3b2bb12d3b6c.ulg",
    "esc_status_log.ulg",
    "ulog-rs_sample-small.ulg",
    "btfl_001.bbl",
    "LOG00037.BFL",
    "btfl_all.bbl",
];

#[test]
fn every_sample_log_reads() {
    for name in ALL {
        let log = open(name);
        let info = log.info();
        assert!(!info.is_empty(), "{name}");
        // Every sample holds more than 5 s of data (sample_log_small.ulg the least: 7.4 s, from the
        // first to the last live data message; the old 10 s bound held only because stale time
        // stamps, a lone 'mission' message at 1194 s, stretched it); none a day.
        assert!(
            log.duration_s() > 5.0 && log.duration_s() < 86400.0,
            "{name}: {}",
            log.duration_s()
        );
        let expect = if name.ends_with(".ulg") {
            LogFormat::Ulog
        } else {
            LogFormat::Blackbox
        };
        assert_eq!(log.format, expect);
        for g in &info {
            assert!(
                g.samples > 0 && g.fields.iter().all(|f| log.channel(f).is_ok()),
                "{name} {}",
                g.name
            );
        }
    }
}

#[test]
fn px4_channels() {
    // SITL hover log (SOURCES.md): angular velocity is logged per axis in rad/s.
    let log = open("sample_px4_events.ulg");
    let (t, p) = log.channel("vehicle_angular_velocity.xyz[0]").unwrap();
    assert_eq!(t.len(), p.len());
    assert!(t.windows(2).all(|w| w[1] >= w[0]));
    assert!(p.iter().all(|x| x.abs() < 20.0));
    // Multi-instance topics get [k] after the topic name.
    let log = open("esc_status_log.ulg");
    assert!(log.channel("actuator_outputs[1].output[0]").is_ok());
    assert!(log.channel("esc_status.esc[5].esc_rpm").is_ok());
    let e = log.channel("vehicle_angular_velocity.xyz[7]").unwrap_err().to_string();
    assert!(
        e.contains("vehicle_angular_velocity.xyz[7]") && e.contains("esc_status_log.ulg"),
        "{e}"
    );
}

#[test]
fn betaflight_channels_and_sessions() {
    // LOG00037.BFL: Betaflight 4.2.0 at 1 kHz (SOURCES.md).
    let log = open("LOG00037.BFL");
    let info = log.info();
    assert!((info[0].rate_hz - 1000.0).abs() < 1.0, "{}", info[0].rate_hz);
    for f in [
        "gyroADC[0]",
        "setpoint[0]",
        "axisP[0]",
        "axisI[0]",
        "axisD[0]",
        "axisF[0]",
        "rcCommand[3]",
    ] {
        assert!(log.channel(f).is_ok(), "{f}");
    }
    let (_, sum) = log.series("axisP[0]+axisI[0]+axisD[0]+axisF[0]").unwrap();
    let (_, p) = log.channel("axisP[0]").unwrap();
    assert_eq!(sum.len(), p.len());
    // loopIteration counts loop iterations: 8 per frame at "P interval:8" (blackbox-log counted 1).
    let (_, it) = log.channel("loopIteration").unwrap();
    assert_eq!(&it[..3], &[0.0, 8.0, 16.0]);
    // GPS frames: position in degrees, time predicted from the main frames' (from 0.000124 s on).
    let (t, lat) = log.channel("GPS_coord[0]").unwrap();
    assert_eq!((t.len(), lat[0]), (86, 50.397491));
    assert!((t[0] - 0.000124).abs() < 1e-9, "{}", t[0]);
    let e = log.series("gyroADC[7]").unwrap_err().to_string();
    assert!(e.contains("gyroADC[7]") && e.contains("similar: gyroADC[0]"), "{e}");

    // btfl_all.bbl: 44 sessions; the 4th is a ~145 s acro flight with roll rates of hundreds of deg/s.
    let bytes = std::fs::read(data("btfl_all.bbl")).unwrap();
    let s = blackbox::sessions(&bytes, "btfl_all.bbl");
    assert_eq!(s.len(), 44);
    assert!(s.iter().any(|s| s.error.is_some()));
    let best = s.iter().max_by_key(|s| s.main_frames).unwrap();
    assert_eq!(best.index, 4);
    assert!((best.duration_s - 145.0).abs() < 5.0, "{}", best.duration_s);
    let log = open("btfl_all.bbl");
    let (_, roll) = log.channel("gyroADC[0]").unwrap();
    let peak = roll.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(peak > 200.0 && peak < 2000.0, "{peak}");
    let opts = OpenOptions {
        session: Some(99),
        ..Default::default()
    };
    let e = Log::open(&data("btfl_all.bbl"), &opts).unwrap_err().to_string();
    assert!(e.contains("no session 99") && e.contains("44 sessions"), "{e}");
}

#[test]
fn truncated_and_corrupt_files() {
    // A ULog cut in its data section keeps the prefix and says so.
    let bytes = std::fs::read(data("sample_log_small.ulg")).unwrap();
    let p = temp_with("cut.ulg", &bytes[..bytes.len() * 2 / 5 + 3]);
    let log = Log::open(&p, &OpenOptions::default()).unwrap();
    assert!(
        log.notes
            .iter()
            .any(|n| n.contains("truncated") || n.contains("corrupt")),
        "{:?}",
        log.notes
    );
    // Cut inside the header: refused.
    let p = temp_with("head.ulg", &bytes[..40]);
    let e = Log::open(&p, &OpenOptions::default()).unwrap_err().to_string();
    assert!(e.contains("head.ulg") && e.contains("before any data message"), "{e}");
    let p = temp_with("short.ulg", b"ULog\x01\x12\x35garbage");
    let e = Log::open(&p, &OpenOptions::default()).unwrap_err().to_string();
    assert!(e.contains("short.ulg: not a readable ULog file: 14 bytes"), "{e}");
    // Garbage in the middle of the data: read or refused, never a panic.
    let mut bad = bytes.clone();
    for (i, b) in bad.iter_mut().enumerate().skip(bytes.len() / 2).take(5000) {
        *b = (i * 7919 % 251) as u8;
    }
    let p = temp_with("garbage.ulg", &bad);
    if let Ok(log) = Log::open(&p, &OpenOptions::default()) {
        assert!(!log.notes.is_empty());
    }

    // A blackbox file cut in its headers is refused; cut in the data, it keeps what decodes.
    let bytes = std::fs::read(data("LOG00037.BFL")).unwrap();
    let p = temp_with("head.bfl", &bytes[..300]);
    let e = Log::open(&p, &OpenOptions::default()).unwrap_err().to_string();
    assert!(e.contains("head.bfl"), "{e}");
    let p = temp_with("cut.bfl", &bytes[..bytes.len() / 3]);
    let log = Log::open(&p, &OpenOptions::default()).unwrap();
    assert!(
        log.duration_s() > 2.0 && log.duration_s() < 10.0,
        "{}",
        log.duration_s()
    );

    // Neither format, not text.
    let p = temp_with("noise.bin", &[0u8, 159, 146, 150, 1, 2, 3, 255]);
    let e = Log::open(&p, &OpenOptions::default()).unwrap_err().to_string();
    assert!(e.contains("not a ULog, blackbox, DataFlash or CSV"), "{e}");
    let e = Log::open(Path::new("/nonexistent/x.ulg"), &OpenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot read /nonexistent/x.ulg"), "{e}");
}

#[test]
fn resampled_flight_segment() {
    let log = open("LOG00037.BFL");
    let u = log
        .uniform(
            &["axisP[0]+axisI[0]+axisD[0]+axisF[0]", "gyroADC[0]"],
            None,
            Some(2.0),
            Some(12.0),
        )
        .unwrap();
    // One steadily logged group: the frames as logged, at their mean rate. orangebox's timestamps put
    // 9854 frames (8 loop iterations each) between 2 and 12 s, 1.0148 ms apart on average although
    // the median interval is 1 ms: the loop ran below its nominal 8 kHz.
    assert!((u.rate_hz() - 985.4).abs() < 0.5, "{}", u.rate_hz());
    assert!((u.len() as f64 - 9854.0).abs() <= 1.0, "{}", u.len());
    assert!(log.uniform(&["gyroADC[0]"], None, Some(100.0), Some(200.0)).is_err());
}

/// A never-ending device is refused before it is read: /dev/urandom used to be read until the
/// memory cap (31 s), and /dev/zero, whose zeros pass as text, until the 4 GiB log cap (12 s).
#[cfg(unix)]
#[test]
fn an_endless_device_is_refused_at_once() {
    for dev in ["/dev/urandom", "/dev/zero"] {
        let p = Path::new(dev);
        if !p.exists() {
            continue;
        }
        let t = std::time::Instant::now();
        let e = Log::open(p, &OpenOptions::default()).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{dev}: {e}");
        assert!(
            t.elapsed().as_secs_f64() < 5.0,
            "{dev}: refused only after {:?}",
            t.elapsed()
        );
    }
}

/// A binary file that is no log is refused from its first bytes, not read to its end.
#[test]
fn a_binary_file_that_is_no_log_is_refused() {
    let p = std::env::temp_dir().join(format!("skyloop-binary-{}.bin", std::process::id()));
    std::fs::write(
        &p,
        (0..200_000u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let e = Log::open(&p, &OpenOptions::default()).unwrap_err().to_string();
    let _ = std::fs::remove_file(&p);
    assert!(e.contains("not a ULog, blackbox, DataFlash or CSV file"), "{e}");
}
