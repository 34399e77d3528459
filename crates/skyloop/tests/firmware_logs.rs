//! How `skyloop::firmware` reads real and synthetic logs: which firmware wrote them, what their
//! headers tune, and where the aircraft was airborne.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use std::path::PathBuf;

use skyloop::firmware::{airborne_criteria, FirmwareTuning};
use skyloop::identify::airborne_segments;
use skyloop_sysid::logs::{Log, OpenOptions};

fn open(name: &str) -> Log {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata/logs")
        .join(name);
    Log::open(&p, &OpenOptions::default()).unwrap()
}

/// A real PX4 1.14 hexarotor flight (SOURCES.md): PX4 logs NaN for the six unused outputs of
/// `actuator_motors`, which once counted as "motor saturation" over the whole log and left no
/// airborne segment. The segment found lies inside the airborne time pyulog shows (4.8–15.6 s
/// after the logger's start, 0.65 s later than the data span's start), and NaN is never blamed on
/// saturation.
#[test]
fn px4_unused_motor_outputs_are_not_saturation() {
    let log = open("ulog-rs_sample-small.ulg");
    let (_, m6) = log.channel("actuator_motors.control[6]").unwrap();
    assert!(
        m6.iter().all(|v| v.is_nan()),
        "output 7 of a hexarotor is NaN in PX4 logs"
    );
    let c = airborne_criteria(&log).unwrap();
    let a = airborne_segments(&log, "vehicle_angular_velocity.xyz[0]", &c, None, None).unwrap();
    assert!(!a.segments.is_empty());
    let span = a.searched.to_s - a.searched.from_s;
    for (reason, s) in &a.excluded_s {
        assert!(*s < 0.6 * span, "{reason}: {s} s of {span} s excluded");
    }
    for seg in &a.segments {
        assert!(seg.from_s >= 4.8 + 0.6 && seg.to_s <= 15.6 + 0.7, "{seg:?}");
        assert!(seg.to_s - seg.from_s >= 2.0, "{seg:?}");
    }
}

/// The ArduCopter header of the synthetic DataFlash log (tools/gen_dataflash.py): banner, frame,
/// rate PIDs (a missing parameter stays missing, not zero), the gyro filter and the logging rates.
#[test]
fn ardupilot_header_is_read_from_parm_and_msg() {
    let log = open("synthetic_arducopter.bin");
    let Some(FirmwareTuning::ArduPilot(t)) = FirmwareTuning::from_log(&log) else {
        panic!("no ArduPilot tuning")
    };
    assert_eq!(
        (t.vehicle.as_deref(), t.version.as_deref(), t.frame.as_deref()),
        (Some("ArduCopter"), Some("4.3.7"), Some("QUAD/X"))
    );
    assert!((t.rate[0].p.unwrap() - 0.135).abs() < 1e-6, "{:?}", t.rate[0].p);
    assert!((t.rate[2].p.unwrap() - 0.18).abs() < 1e-6, "{:?}", t.rate[2].p);
    assert_eq!(t.rate[1].i, None, "ATC_RAT_PIT_I is not in the log");
    assert_eq!(t.gyro_filter_hz, Some(20.0));
    assert_eq!(t.loop_rate_hz, Some(400.0));
    assert!(t
        .harmonic_notch
        .iter()
        .any(|n| n.name == "INS_HNTCH_FREQ" && n.value == 80.0));
    let rate = t.log_rates_hz.iter().find(|n| n.name == "RATE").unwrap();
    assert!((rate.value - 400.0).abs() < 1e-6, "{rate:?}");
}
