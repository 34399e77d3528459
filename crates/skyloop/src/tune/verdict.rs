//! The verdict of a log tune, in a pilot's words: a proposal and what it changes, "keep your tune",
//! or why the log cannot support a proposal and what to fly.

use crate::error::Error;
use crate::firmware::{excitation::what_to_fly, Axis};
use crate::tune::Firmware;
use serde_json::{json, Value};

/// Which of the three answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VerdictKind {
    /// New gains, better than the flown ones and verified.
    Propose,
    /// The flown tune is at the frontier of the model: no bounded change improves it.
    Keep,
    /// The model does not explain the flight (or the flight cannot be analysed): no proposal.
    Cannot,
}

impl VerdictKind {
    /// "propose", "keep" or "cannot".
    pub fn name(&self) -> &'static str {
        match self {
            VerdictKind::Propose => "propose",
            VerdictKind::Keep => "keep",
            VerdictKind::Cannot => "cannot",
        }
    }
}

/// The verdict with its one-line text.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Which answer.
    pub kind: VerdictKind,
    /// The line a pilot reads first.
    pub text: String,
}

impl Verdict {
    /// The verdict `cannot` on `axis`, for the reason `why`: "roll: the log cannot support a
    /// proposal: …".
    pub fn cannot(axis: Axis, why: &str) -> Verdict {
        Verdict {
            kind: VerdictKind::Cannot,
            text: format!("{}: the log cannot support a proposal: {why}", axis.name()),
        }
    }

    /// `{kind, text}`.
    pub fn to_json(&self) -> Value {
        json!({"kind": self.kind.name(), "text": self.text})
    }
}

/// An axis the log cannot support a proposal on: the verdict `cannot` with the measured reason, and
/// what to fly for the next log.
#[derive(Debug, Clone)]
pub struct Refusal {
    /// The axis.
    pub axis: Axis,
    /// Why, as the analysis measured it (the error's message).
    pub reason: String,
    /// The flight that would identify the axis: the stick sequence and the firmware's own
    /// excitation mode with its settings (None: the failure is not one more flying fixes, e.g. a
    /// numerical one).
    pub what_to_fly: Option<String>,
}

impl Refusal {
    /// The refusal of `axis` for `err`, with what to fly on `firmware` when the failure is the log's
    /// (an input the analysis refuses), not a numerical one.
    pub fn new(axis: Axis, firmware: Firmware, err: &Error) -> Self {
        let what_to_fly = matches!(err, Error::Input(_)).then(|| what_to_fly(firmware, axis));
        Refusal {
            axis,
            reason: err.to_string(),
            what_to_fly,
        }
    }

    /// The verdict line: "yaw: the log cannot support a proposal: …".
    pub fn verdict(&self) -> Verdict {
        Verdict::cannot(self.axis, &self.reason)
    }

    /// `{error, verdict: {kind: "cannot", text}, what_to_fly}` (`error` as before: the reason).
    pub fn to_json(&self) -> Value {
        json!({
            "error": self.reason,
            "verdict": self.verdict().to_json(),
            "what_to_fly": self.what_to_fly,
        })
    }
}

/// "+35 %" style relative change of `new` against `old`.
pub fn pct(new: f64, old: f64) -> String {
    if old == 0.0 || !old.is_finite() || !new.is_finite() {
        return "n/a".into();
    }
    format!("{:+.0} %", 100.0 * (new / old - 1.0))
}

/// What a balanced (skew 0) disk margin `alpha` means for the pilot: "±4.4 dB and ±28.1° at once"
/// for α = 0.5, computed from α ([`skyloop_lti::margins::DiskMargin::from_alpha`]); "any gain" from
/// α = 2 on.
pub fn disk_tolerance(alpha: f64) -> String {
    let d = skyloop_lti::margins::DiskMargin::from_alpha(alpha, f64::NAN);
    if d.gain_db[1].is_finite() {
        format!("±{:.1} dB and ±{:.1}° at once", d.gain_db[1], d.phase_deg)
    } else {
        format!("any gain and ±{:.1}° at once", d.phase_deg)
    }
}

/// The proposal's verdict line: crossover, robustness and noise against the flown tune.
pub fn proposal_text(axis: &str, xo: (f64, f64), alpha: (f64, f64), noise_ratio: f64) -> String {
    let robust = if (alpha.1 - alpha.0).abs() <= 0.02 * alpha.0.max(0.1) {
        format!("same robustness (disk α {:.2})", alpha.1)
    } else if alpha.1 > alpha.0 {
        format!(
            "more robust (disk α {:.2} → {:.2}: {})",
            alpha.0,
            alpha.1,
            disk_tolerance(alpha.1)
        )
    } else {
        format!("less robust (disk α {:.2} → {:.2}, above the floor)", alpha.0, alpha.1)
    };
    format!(
        "{axis}: proposal: {} crossover ({:.1} → {:.1} Hz), {robust}, {} motor noise",
        pct(xo.1, xo.0),
        xo.0,
        xo.1,
        pct(noise_ratio, 1.0)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_tolerance_is_computed_from_alpha() {
        assert_eq!(disk_tolerance(0.5), "±4.4 dB and ±28.1° at once");
        assert_eq!(disk_tolerance(1.0), "±9.5 dB and ±53.1° at once");
        assert_eq!(disk_tolerance(2.0), "any gain and ±90.0° at once");
        let t = proposal_text("roll", (20.0, 22.0), (0.3, 0.66), 1.0);
        assert!(t.contains("disk α 0.30 → 0.66: ±6.0 dB and ±36.5° at once"), "{t}");
    }
}
