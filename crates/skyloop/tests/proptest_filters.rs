//! Property tests of the `--filters` grammar (`FilterChain::with_changes`): any text built from the
//! grammar's own characters is either a chain or an error that names `--filters` (never a panic),
//! every accepted chain's response is finite, and a cutoff written plainly or in exponent form
//! (`1.5e2`) is read as that frequency, a `MIN-MAX` pair as a throttle-following range.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use proptest::prelude::*;
use skyloop::firmware::filters::{FilterChain, OperatingPoint, Path, Shape, StageKind};

const LOOP_HZ: f64 = 8000.0;

/// A flown chain: a PT1 gyro lowpass at 200 Hz and a PT1 D-term lowpass at 150 Hz.
fn flown() -> FilterChain {
    let empty = FilterChain {
        loop_hz: LOOP_HZ,
        stages: Vec::new(),
    };
    empty.with_changes("gyro_lpf1=pt1:200,dterm_lpf1=pt1:150").unwrap().0
}

const LOWPASS_STAGES: [&str; 4] = ["gyro_lpf1", "gyro_lpf2", "dterm_lpf1", "dterm_lpf2"];
const SHAPES: [(&str, Shape); 4] = [
    ("pt1", Shape::Pt1),
    ("pt2", Shape::Pt2),
    ("pt3", Shape::Pt3),
    ("biquad", Shape::Biquad),
];

/// A frequency as a user may write it: plain, with decimals, or in exponent form.
fn written(hz: f64, form: u8) -> String {
    match form % 4 {
        0 => format!("{}", hz.round()),
        1 => format!("{hz:.3}"),
        2 => format!("{hz:e}"),
        // A negative exponent: its sign is not a range dash.
        _ => format!("{}e-3", (hz * 1000.0).round()),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn grammar_text_never_panics(spec in "[a-z0-9_=,:/@.xhqe -]{0,60}") {
        match flown().with_changes(&spec) {
            Ok((chain, _)) => {
                let op = OperatingPoint { peaks_hz: vec![150.0, 300.0], ..Default::default() };
                for path in [Path::Gyro, Path::Dterm] {
                    let h = chain.response(path, &[0.0, 50.0, 500.0, 3999.0], &op).unwrap();
                    prop_assert!(h.iter().all(|v| v.re.is_finite() && v.im.is_finite()), "{spec}: {h:?}");
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("--filters"), "{spec}: {e}"),
        }
    }

    #[test]
    fn a_written_cutoff_is_that_frequency(stage in 0usize..4, shape in 0usize..4, hz in 1.0f64..3999.0, form in 0u8..4) {
        let text = written(hz, form);
        let want: f64 = text.parse().unwrap();
        prop_assume!((1.0..LOOP_HZ / 2.0).contains(&want));
        let spec = format!("{}={}:{text}", LOWPASS_STAGES[stage], SHAPES[shape].0);
        let (chain, _) = flown().with_changes(&spec).unwrap();
        let got = chain.stages.iter().find(|s| s.name == LOWPASS_STAGES[stage]).unwrap();
        prop_assert_eq!(&got.kind, &StageKind::Lowpass { shape: SHAPES[shape].1, hz: want });
    }

    #[test]
    fn a_written_range_follows_the_throttle(lo in 1.0f64..1000.0, span in 1.0f64..2000.0, form in 0u8..4) {
        let (a, b) = (written(lo, form), written(lo + span, form));
        let (wa, wb): (f64, f64) = (a.parse().unwrap(), b.parse().unwrap());
        prop_assume!(wa >= 1.0 && wa < wb && wb < LOOP_HZ / 2.0);
        let (chain, _) = flown().with_changes(&format!("dterm_lpf1=pt2:{a}-{b}")).unwrap();
        let got = chain.stages.iter().find(|s| s.name == "dterm_lpf1").unwrap();
        let ok = matches!(got.kind, StageKind::DynamicLowpass { shape: Shape::Pt2, min_hz, max_hz, .. }
            if min_hz == wa && max_hz == wb);
        prop_assert!(ok, "{a}-{b}: {:?}", got.kind);
    }
}
