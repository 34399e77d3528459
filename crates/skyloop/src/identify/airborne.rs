//! The airborne segments of a log: where every one of the firmware's tests holds
//! ([`AirborneCriteria`], from `crate::firmware`), trimmed by the margins around take-off, landing,
//! saturation and a log that ends in flight.

use std::ops::Range;

use crate::error::{Error, Result};
use crate::firmware::AirborneCriteria;
use skyloop_sysid::logs::uniform::sorted;
use skyloop_sysid::logs::{segments_where, Log, Span};
use skyloop_sysid::SysidError;

/// The exclusion reason of NaN samples in a tested channel (PX4: a stopped motor).
const NAN_REASON: &str = "no value (NaN, e.g. a stopped motor)";

/// The airborne segments and what was excluded.
#[derive(Debug, Clone, PartialEq)]
pub struct Airborne {
    /// The usable segments, in time order.
    pub segments: Vec<Span>,
    /// Seconds of the searched span excluded by each reason (a sample failing several tests counts
    /// for each), in the order of the criteria.
    pub excluded_s: Vec<(&'static str, f64)>,
    /// The searched span, s.
    pub searched: Span,
    /// The searched span cut into stretches, each used or not and why, in time order (adjacent
    /// unused stretches merged, their reasons listed by the time each excluded).
    pub timeline: Vec<SegmentVerdict>,
}

/// One stretch of a searched span: whether the identification used it, and why (not).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentVerdict {
    /// Start, log seconds.
    pub start_s: f64,
    /// End, log seconds.
    pub end_s: f64,
    /// Part of an airborne segment the estimate used.
    pub used: bool,
    /// What held there ("airborne: every test holds") or what excluded it ("motor saturation",
    /// "margin around a take-off, landing or limit", "the log ends in flight", ...).
    pub reason: String,
}

impl SegmentVerdict {
    /// The stretches worth a line each: every used one, then the longest unused ones up to `max`
    /// lines in all, in time order (a flight with saturation blips has hundreds of short ones).
    pub fn headline(timeline: &[SegmentVerdict], max: usize) -> Vec<&SegmentVerdict> {
        let mut shown: Vec<&SegmentVerdict> = timeline.iter().filter(|s| s.used).collect();
        let mut unused: Vec<&SegmentVerdict> = timeline.iter().filter(|s| !s.used).collect();
        unused.sort_by(|a, b| (b.end_s - b.start_s).total_cmp(&(a.end_s - a.start_s)));
        shown.extend(unused.into_iter().take(max.saturating_sub(shown.len())));
        shown.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        shown
    }

    /// Seconds used and seconds in all of a timeline.
    pub fn used_of_total_s(timeline: &[SegmentVerdict]) -> (f64, f64) {
        let len = |s: &&SegmentVerdict| s.end_s - s.start_s;
        (
            timeline.iter().filter(|s| s.used).map(|s| len(&s)).sum(),
            timeline.iter().map(|s| len(&s)).sum(),
        )
    }
}

/// The reason of a used stretch.
pub const USED_REASON: &str = "airborne: every test holds";
/// The reason of the trimmed ends of a run where every test holds.
const MARGIN_REASON: &str = "margin around a take-off, landing or limit";
/// The reason of the crash tail.
const CRASH_REASON: &str = "the log ends in flight (a crash or power loss): its last moments are not flight";
/// The reason of a run too short to keep.
const SHORT_REASON: &str = "airborne, but shorter than the shortest segment kept";

/// Finds the airborne segments of `log` within [from_s, to_s] on the time base of channel `base` (the
/// identification's output channel; other channels are held at their last sample, so a slow flag
/// such as PX4's 1 Hz `landed` applies until it changes).
///
/// # Errors
/// A base channel the log lacks, or no segment of at least `min_len_s` (the message says how much
/// each reason excluded).
pub fn airborne_segments(
    log: &Log,
    base: &str,
    c: &AirborneCriteria,
    from_s: Option<f64>,
    to_s: Option<f64>,
) -> Result<Airborne> {
    let (t_all, _) = log.series(base)?;
    let lo = from_s.unwrap_or(f64::NEG_INFINITY);
    let hi = to_s.unwrap_or(f64::INFINITY);
    let t: Vec<f64> = t_all.iter().copied().filter(|&x| x >= lo && x <= hi).collect();
    if t.len() < 2 {
        return Err(Error::from(SysidError::NotEnoughData(format!(
            "{}: '{base}' has fewer than 2 samples in the selected span",
            log.source
        ))));
    }
    let (t_first, t_last) = (t[0], t[t.len() - 1]);
    let log_end = t_all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut ok = vec![true; t.len()];
    // The first test each sample fails (an index into `excluded`), for the timeline.
    let mut why: Vec<Option<usize>> = vec![None; t.len()];
    let mut excluded: Vec<(&'static str, f64)> = Vec::new();
    let dt = (t_last - t_first) / (t.len() - 1) as f64;
    for l in &c.limits {
        let (tc, vc) = log.channel(&l.channel)?;
        let (tc, vc) = sorted(tc, vc);
        // PX4 logs NaN for the outputs a frame does not use (motors 7–12 of a hexarotor) and for
        // stopped motors: a channel that is NaN throughout is not tested, and NaN samples of a
        // used one are excluded under their own reason, not taken for saturation.
        if vc.iter().all(|v| v.is_nan()) {
            continue;
        }
        let held = hold_last(&tc, &vc, &t);
        let (mut bad, mut nan) = (0usize, 0usize);
        let idx_of =
            |excluded: &mut Vec<(&'static str, f64)>, r: &'static str| match excluded.iter().position(|(e, _)| *e == r)
            {
                Some(i) => i,
                None => {
                    excluded.push((r, 0.0));
                    excluded.len() - 1
                }
            };
        // In the order of the criteria: the test's own reason before its NaN samples'.
        idx_of(&mut excluded, l.reason);
        for (k, v) in held.iter().enumerate() {
            let reason = if v.is_nan() {
                nan += 1;
                NAN_REASON
            } else if !(*v > l.lo && *v < l.hi) {
                bad += 1;
                l.reason
            } else {
                continue;
            };
            ok[k] = false;
            if why[k].is_none() {
                why[k] = Some(idx_of(&mut excluded, reason));
            }
        }
        for (reason, count) in [(l.reason, bad), (NAN_REASON, nan)] {
            if reason == NAN_REASON && count == 0 {
                continue;
            }
            match excluded.iter_mut().find(|(r, _)| *r == reason) {
                Some(e) => e.1 = e.1.max(count as f64 * dt),
                None => excluded.push((reason, count as f64 * dt)),
            }
        }
    }
    let mut segments = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    for r in runs(&ok) {
        let (r0, r1) = (t[r.start], t[r.end - 1]);
        let mut a = r0 + c.margin_s;
        let mut b = r1 - c.margin_s;
        // The run reaches the last sample of the log: it stopped in flight.
        let crashed = r.end == t.len() && log_end - t_last <= 1.5 * dt;
        if crashed {
            b -= c.crash_tail_s;
        }
        a = a.max(t_first);
        b = b.min(t_last);
        if b - a >= c.min_len_s {
            segments.push(Span { from_s: a, to_s: b });
            pieces.push(Piece::unused(r0, a, MARGIN_REASON));
            pieces.push(Piece {
                start_s: a,
                end_s: b,
                used: true,
                reasons: vec![(USED_REASON, b - a)],
            });
            pieces.push(Piece::unused(b, (b + c.margin_s).min(r1), MARGIN_REASON));
            if crashed {
                pieces.push(Piece::unused((b + c.margin_s).min(r1), r1, CRASH_REASON));
            }
        } else {
            pieces.push(Piece::unused(r0, r1, SHORT_REASON));
        }
    }
    pieces.extend(excluded_pieces(&t, dt, &why, &excluded));
    let timeline = merge_pieces(pieces, dt);
    let searched = Span {
        from_s: t_first,
        to_s: t_last,
    };
    if segments.is_empty() {
        return Err(Error::from(no_segment_error(log, c, (t_first, t_last), &excluded)));
    }
    Ok(Airborne {
        segments,
        excluded_s: excluded,
        searched,
        timeline,
    })
}

/// Adds `s` seconds to `name`'s entry of `reasons` (a new entry at the end if it has none).
fn tally(reasons: &mut Vec<(&'static str, f64)>, name: &'static str, s: f64) {
    match reasons.iter_mut().find(|(n, _)| *n == name) {
        Some(e) => e.1 += s,
        None => reasons.push((name, s)),
    }
}

/// A stretch of the timeline before adjacent unused ones are merged: the seconds each reason holds.
struct Piece {
    start_s: f64,
    end_s: f64,
    used: bool,
    reasons: Vec<(&'static str, f64)>,
}

impl Piece {
    fn unused(start_s: f64, end_s: f64, reason: &'static str) -> Piece {
        Piece {
            start_s,
            end_s,
            used: false,
            reasons: vec![(reason, (end_s - start_s).max(0.0))],
        }
    }
}

/// The runs of samples some test excluded, each with the seconds each reason excluded in it.
fn excluded_pieces(t: &[f64], dt: f64, why: &[Option<usize>], excluded: &[(&'static str, f64)]) -> Vec<Piece> {
    let bad: Vec<bool> = why.iter().map(Option::is_some).collect();
    runs(&bad)
        .into_iter()
        .map(|r| {
            let mut reasons: Vec<(&'static str, f64)> = Vec::new();
            for w in why[r.clone()].iter().flatten() {
                tally(&mut reasons, excluded[*w].0, dt);
            }
            Piece {
                start_s: t[r.start],
                end_s: t[r.end - 1],
                used: false,
                reasons,
            }
        })
        .collect()
}

/// The pieces in time order, empty ones dropped, adjacent unused ones (within a sample or two)
/// merged with their reasons listed by the time each held, longest first.
fn merge_pieces(mut pieces: Vec<Piece>, dt: f64) -> Vec<SegmentVerdict> {
    pieces.retain(|p| p.end_s > p.start_s || (!p.used && p.end_s == p.start_s && !p.reasons.is_empty()));
    pieces.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
    let mut merged: Vec<Piece> = Vec::new();
    for p in pieces {
        match merged.last_mut() {
            Some(m) if !m.used && !p.used && p.start_s - m.end_s <= 2.5 * dt => {
                m.end_s = m.end_s.max(p.end_s);
                for (n, s) in p.reasons {
                    tally(&mut m.reasons, n, s);
                }
            }
            _ => merged.push(p),
        }
    }
    merged
        .into_iter()
        .map(|mut p| {
            p.reasons.sort_by(|a, b| b.1.total_cmp(&a.1));
            SegmentVerdict {
                start_s: p.start_s,
                end_s: p.end_s,
                used: p.used,
                reason: p.reasons.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
            }
        })
        .collect()
}

/// The refusal of a span without an airborne segment: how much each reason excluded, and, when one
/// reason held for the whole span (motors idle or saturated, throttle at idle, landed), that there
/// was no flight to identify and the vehicle must fly.
fn no_segment_error(log: &Log, c: &AirborneCriteria, span: (f64, f64), excluded: &[(&'static str, f64)]) -> SysidError {
    let (t_first, t_last) = span;
    let why: Vec<String> = excluded
        .iter()
        .filter(|(_, s)| *s > 0.0)
        .map(|(r, s)| format!("{r} {s:.1} s"))
        .collect();
    let whole: Vec<&str> = excluded
        .iter()
        .filter(|(_, s)| *s >= 0.99 * (t_last - t_first) && t_last > t_first)
        .map(|(r, _)| *r)
        .collect();
    let advice = if whole.is_empty() {
        String::new()
    } else {
        format!(
            "; {} for the whole log, so it holds no flight (a test stand, or a vehicle that never took off?): fly and log again",
            whole.join(" and ")
        )
    };
    SysidError::NotEnoughData(format!(
        "{}: no airborne segment of {} s or more between {:.2} s and {:.2} s (excluded: {}){advice}",
        log.source,
        c.min_len_s,
        t_first,
        t_last,
        if why.is_empty() {
            "nothing; the span is too short".to_string()
        } else {
            why.join(", ")
        }
    ))
}

/// Maximal runs of `true`.
fn runs(mask: &[bool]) -> Vec<Range<usize>> {
    segments_where(mask, 1)
}

/// The value of (t, v) (t increasing) last sampled at or before each time of `at`; the first value
/// before the first sample.
pub(crate) fn hold_last(t: &[f64], v: &[f64], at: &[f64]) -> Vec<f64> {
    at.iter()
        .map(|&x| {
            let k = t.partition_point(|&s| s <= x);
            v[k.saturating_sub(1).min(v.len().saturating_sub(1))]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::firmware::{Axis, Firmware, FirmwareTuning};
    use skyloop_sysid::logs::{Channel, Group, LogFormat};

    fn log(format: LogFormat, channels: Vec<(&str, Vec<f64>)>, dt: f64) -> Log {
        let n = channels[0].1.len();
        Log {
            source: "test".into(),
            format,
            groups: vec![Group {
                name: "main".into(),
                prefix: None,
                time_s: (0..n).map(|i| i as f64 * dt).collect(),
                channels: channels
                    .into_iter()
                    .map(|(name, values)| Channel {
                        name: name.into(),
                        values,
                    })
                    .collect(),
            }],
            notes: vec![],
            settings: vec![("motorOutput".into(), "158,2047".into())],
            clock_origin_s: 0.0,
        }
    }

    /// A 20 s synthetic Betaflight session at 100 Hz: idle until 2 s, flying with a motor pinned at its
    /// maximum from 8 to 9 s and the gyro saturated from 12 to 12.5 s, log ending in flight (crash).
    #[test]
    fn segments_exclude_idle_saturation_and_crash_tail() {
        let n = 2000;
        let t = |i: usize| i as f64 * 0.01;
        let thr: Vec<f64> = (0..n).map(|i| if t(i) < 2.0 { 1000.0 } else { 1400.0 }).collect();
        let m0: Vec<f64> = (0..n)
            .map(|i| if (8.0..9.0).contains(&t(i)) { 2047.0 } else { 900.0 })
            .collect();
        let g0: Vec<f64> = (0..n)
            .map(|i| if (12.0..12.5).contains(&t(i)) { 1999.0 } else { 100.0 })
            .collect();
        let l = log(
            LogFormat::Blackbox,
            vec![
                ("rcCommand[3]", thr),
                ("motor[0]", m0),
                ("gyroADC[0]", g0),
                ("axisP[0]", vec![0.0; n]),
                ("setpoint[0]", vec![0.0; n]),
            ],
            0.01,
        );
        let c = crate::firmware::airborne_criteria(&l).unwrap();
        let a = airborne_segments(&l, "gyroADC[0]", &c, None, None).unwrap();
        let got: Vec<(f64, f64)> = a.segments.iter().map(|s| (s.from_s, s.to_s)).collect();
        let want = [(2.2, 7.79), (9.2, 11.79), (12.7, 19.99 - 0.2 - 1.0)];
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (g, w) in got.iter().zip(want) {
            assert!((g.0 - w.0).abs() < 1e-9 && (g.1 - w.1).abs() < 1e-9, "{got:?}");
        }
        let idle = a.excluded_s.iter().find(|(r, _)| *r == "idle throttle").unwrap().1;
        assert!((idle - 2.0).abs() < 0.02, "{idle}");
        // The timeline: the used stretches are the segments, the others alternate with them and
        // name what excluded them, and together they cover the span without overlap.
        let tl = &a.timeline;
        let used: Vec<(f64, f64)> = tl.iter().filter(|s| s.used).map(|s| (s.start_s, s.end_s)).collect();
        assert_eq!(used, got, "{tl:?}");
        assert!(
            tl.windows(2)
                .all(|w| w[0].used != w[1].used && w[1].start_s >= w[0].end_s - 1e-9),
            "{tl:?}"
        );
        assert!(
            (tl[0].start_s - 0.0).abs() < 1e-9 && (tl[tl.len() - 1].end_s - 19.99).abs() < 1e-9,
            "{tl:?}"
        );
        let covered: f64 = tl.iter().map(|s| s.end_s - s.start_s).sum();
        assert!((covered - 19.99).abs() < 0.05, "{covered} {tl:?}");
        let at = |x: f64| tl.iter().find(|s| s.start_s <= x && x <= s.end_s).unwrap();
        assert!(at(1.0).reason.starts_with("idle throttle"), "{tl:?}");
        assert!(at(8.5).reason.starts_with("motor saturation"), "{tl:?}");
        assert!(at(12.2).reason.starts_with("gyro saturation"), "{tl:?}");
        assert!(at(19.5).reason.contains("the log ends in flight"), "{tl:?}");
        // A span with no flight names what excluded it.
        let e = airborne_segments(&l, "gyroADC[0]", &c, Some(0.0), Some(1.9))
            .unwrap_err()
            .to_string();
        assert!(e.contains("idle throttle"), "{e}");
        // Channels: the PID sum of the terms logged, setpoint as instrument.
        let ch = crate::firmware::rate_loop_channels(&l, Axis::Roll).unwrap();
        assert_eq!(ch.input, "axisP[0]");
        assert_eq!(ch.instrument, "setpoint[0]");
        assert_eq!(ch.gain_unit(), "deg/s² per PID unit");
        assert!(crate::firmware::rate_loop_channels(&l, Axis::Pitch).is_err());
    }
    /// A 5 s PX4 log at 100 Hz whose four motors sit at `motor` throughout (a test stand).
    fn stand(motor: f64) -> Log {
        let n = 500;
        let mut channels = vec![Channel {
            name: "vehicle_angular_velocity.xyz[0]".into(),
            values: vec![0.1; n],
        }];
        for k in 0..4 {
            channels.push(Channel {
                name: format!("actuator_motors.control[{k}]"),
                values: vec![motor; n],
            });
        }
        Log {
            source: "stand.ulg".into(),
            format: LogFormat::Ulog,
            groups: vec![Group {
                name: "all".into(),
                prefix: None,
                time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
                channels,
            }],
            notes: vec![],
            settings: vec![],
            clock_origin_s: 0.0,
        }
    }

    #[test]
    fn motors_idle_or_saturated_throughout_are_refused_by_name_with_the_advice_to_fly() {
        for (m, reason) in [(0.0, "motors at idle"), (1.0, "motor saturation")] {
            let l = stand(m);
            let c = crate::firmware::airborne_criteria(&l).unwrap();
            let e = airborne_segments(&l, "vehicle_angular_velocity.xyz[0]", &c, None, None)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("{reason} for the whole log")) && e.contains("fly"),
                "{e}"
            );
            let other = if m == 0.0 { "motor saturation" } else { "motors at idle" };
            assert!(!e.contains(other), "{e}");
        }
    }
    /// A 10 s synthetic INAV session at 100 Hz whose header's `motorOutput` is not the scale
    /// `motor[k]` is logged in (as on INAV 9 with DShot): read as Betaflight, every sample would be
    /// "motor saturation"; read as INAV, only the motor pinned at its largest logged value is.
    fn inav_log(settings: Vec<(&str, &str)>) -> Log {
        let n = 1000;
        let t = |i: usize| i as f64 * 0.01;
        let m0: Vec<f64> = (0..n)
            .map(|i| {
                if (5.0..5.5).contains(&t(i)) {
                    1850.0
                } else {
                    1300.0 + 100.0 * (t(i)).sin()
                }
            })
            .collect();
        let channels = vec![
            ("rcCommand[3]", vec![1400.0; n]),
            ("motor[0]", m0),
            // One low sample sets the logged span's floor (1100) away from the sine's trough.
            (
                "motor[1]",
                (0..n).map(|i| if i == 0 { 1100.0 } else { 1350.0 }).collect(),
            ),
            ("gyroADC[0]", vec![10.0; n]),
            ("axisP[0]", vec![0.0; n]),
            ("axisI[0]", vec![0.0; n]),
            ("axisD[0]", vec![0.0; n]),
            ("axisRate[0]", vec![0.0; n]),
            ("rcCommand[0]", vec![0.0; n]),
        ];
        Log {
            source: "inav".into(),
            format: LogFormat::Blackbox,
            groups: vec![Group {
                name: "main".into(),
                prefix: None,
                time_s: (0..n).map(t).collect(),
                channels: channels
                    .into_iter()
                    .map(|(name, values)| Channel {
                        name: name.into(),
                        values,
                    })
                    .collect(),
            }],
            notes: vec![],
            settings: settings
                .into_iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            clock_origin_s: 0.0,
        }
    }

    #[test]
    fn inav_is_recognised_and_its_motor_range_gives_no_false_saturation() {
        let l = inav_log(vec![
            ("Firmware type", "Cleanflight"),
            ("Firmware revision", "INAV 9.0.1 (d44f2cf6) IFLIGHT_BLITZ_F722"),
            ("motorOutput", "48,1000"),
            ("minthrottle", "1000"),
            ("maxthrottle", "2000"),
        ]);
        assert_eq!(Firmware::of_log(&l), Some(Firmware::Inav));
        assert_eq!(Firmware::Inav.display_name(), "INAV");
        let ch = crate::firmware::rate_loop_channels(&l, Axis::Roll).unwrap();
        assert_eq!(ch.input, "axisP[0]+axisI[0]+axisD[0]");
        assert_eq!(ch.instrument, "axisRate[0]");
        assert_eq!(ch.output, "gyroADC[0]");
        let (_, range) = crate::firmware::inav::flight::throttle_and_motor_range(&l);
        assert_eq!(range, (1100.0, 1850.0));
        let c = crate::firmware::airborne_criteria(&l).unwrap();
        let a = airborne_segments(&l, "gyroADC[0]", &c, None, None).unwrap();
        let sat = a.excluded_s.iter().find(|(r, _)| *r == "motor saturation").unwrap().1;
        assert!((sat - 0.5).abs() < 0.05, "{sat}");
        assert_eq!(a.segments.len(), 2, "{:?}", a.segments);
        // The same data read as Betaflight (no INAV in the header) is saturated throughout.
        let mut bf = l.clone();
        bf.settings.retain(|(k, _)| !k.starts_with("Firmware"));
        assert_eq!(Firmware::of_log(&bf), Some(Firmware::Betaflight));
        let c = crate::firmware::airborne_criteria(&bf).unwrap();
        assert!(airborne_segments(&bf, "gyroADC[0]", &c, None, None).is_err());
        // `Firmware type:INAV` alone also names INAV; a header range that holds the motors is used.
        let l2 = inav_log(vec![("Firmware type", "INAV"), ("motorOutput", "1000,2000")]);
        assert_eq!(Firmware::of_log(&l2), Some(Firmware::Inav));
        assert_eq!(
            crate::firmware::inav::flight::throttle_and_motor_range(&l2).1,
            (1000.0, 2000.0)
        );
    }

    #[test]
    fn inav_header_is_read_with_inav_keys() {
        let l = inav_log(vec![
            ("Firmware revision", "INAV 9.0.1 (d44f2cf6) IFLIGHT_BLITZ_F722"),
            ("rollPID", "44,75,25,60"),
            ("pitchPID", "46,80,26,60"),
            ("yawPID", "35,80,0,60"),
            ("gyro_main_lpf_hz", "110"),
            ("gyro_main_lpf_type", "PT1"),
            ("dterm_lpf_hz", "110"),
            ("dterm_lpf_type", "3"),
            ("yaw_lpf_hz", "30"),
            ("looptime", "1022"),
            ("motorOutput", "48,1000"),
        ]);
        let Some(FirmwareTuning::Inav(t)) = FirmwareTuning::from_log(&l) else {
            panic!("not read as INAV")
        };
        assert_eq!(t.version_major, Some(9));
        assert_eq!(
            (t.pid[0].p, t.pid[0].i, t.pid[0].d, t.pid[0].cd),
            (44.0, 75.0, 25.0, Some(60.0))
        );
        assert_eq!(t.pid.len(), 3);
        let g = t.gyro_lowpass.as_ref().unwrap();
        assert_eq!((g.kind.as_str(), g.cutoff_hz), ("PT1", 110.0));
        let d = t.dterm_lowpass.as_ref().unwrap();
        assert_eq!((d.kind.as_str(), d.cutoff_hz), ("PT3", 110.0));
        assert!((t.pid_rate_hz.unwrap() - 978.47).abs() < 0.01);
        assert_eq!(t.motor_output, Some((48.0, 1000.0)));
        assert_eq!(t.yaw_lpf_hz, Some(30.0));
    }
}
