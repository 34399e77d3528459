//! The figures of models that the plotting commands draw (`bode`, `sigma`, `nichols`, `nyquist`,
//! `pzmap`, `rlocus`, `step`): each function computes the responses of labelled models and builds
//! the [`Figure`](skyloop_plot::figure::Figure), so the CLI only parses and saves, and a library user gets the same pictures.
//!
//! Frequencies are chosen in rad/s and shown in Hz, gains in dB, phases in degrees, times in s.

mod frequency;
mod roots;
mod step;

pub use frequency::{bode, frequency_grid, nichols, nyquist, sigma};
pub use roots::{pzmap, rlocus, root_locus_data};
pub use step::{step, StepRun};

use crate::error::Result;
use skyloop_lti::StateSpace;

/// A model with the name it has in legends (the expression the user typed, or `--label`).
#[derive(Debug, Clone)]
pub struct Labeled {
    /// Legend text.
    pub label: String,
    /// The model.
    pub sys: StateSpace,
}

/// Refuses a model above `max` states for `what`, naming the order, the bound and the way out
/// (the cost of these computations grows as the cube of the order, and past the bound a run takes
/// minutes).
///
/// # Errors
/// When `sys` has more than `max` states.
pub fn check_order(sys: &StateSpace, label: &str, what: &str, max: usize) -> Result<()> {
    if sys.nx() > max {
        return Err(format!(
            "{label}: order {} is above the {max} states {what} handles in reasonable time; reduce it first (skyloop reduce MODEL --order K)",
            sys.nx()
        )
        .into());
    }
    Ok(())
}

/// Largest loop order `step --closed-loop` simulates.
pub const MAX_CLOSED_LOOP_ORDER: usize = 150;
/// Largest loop order a root locus traces.
pub const MAX_RLOCUS_ORDER: usize = 80;

impl Labeled {
    /// Pairs a model with its legend text.
    pub fn new(label: impl Into<String>, sys: StateSpace) -> Self {
        Labeled {
            label: label.into(),
            sys,
        }
    }

    /// Checks the model is SISO, naming the figure that needs it.
    pub(crate) fn siso(&self, what: &str) -> Result<()> {
        if self.sys.ny() != 1 || self.sys.nu() != 1 {
            return Err(format!(
                "{}: {what} needs a SISO loop transfer, got {}×{} (outputs × inputs)",
                self.label,
                self.sys.ny(),
                self.sys.nu()
            )
            .into());
        }
        Ok(())
    }
}

/// Channel suffix for the curves of a MIMO model (empty for SISO): `[out i ← in j]`, 1-based.
pub fn channel(sys: &StateSpace, i: usize, j: usize) -> String {
    if sys.ny() * sys.nu() > 1 {
        format!(" [out {} ← in {}]", i + 1, j + 1)
    } else {
        String::new()
    }
}

/// A legend label for a model argument: the text itself, its middle elided when long (products of
/// models often share a long prefix, so both ends are kept).
pub fn short_label(arg: &str) -> String {
    let chars: Vec<char> = arg.chars().collect();
    if chars.len() > 48 {
        let head: String = chars[..22].iter().collect();
        let tail: String = chars[chars.len() - 22..].iter().collect();
        format!("{head}…{tail}")
    } else {
        arg.to_string()
    }
}

/// Writes a figure; the format follows the extension: `.svg` or `.png` (static), or `.html` (a
/// self-contained page with the interactive figure, zoom and hover values, above its static SVG).
pub fn save(fig: &skyloop_plot::figure::Figure, path: &std::path::Path) -> Result<()> {
    let html = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("html") || e.eq_ignore_ascii_case("htm"));
    if html {
        let mut r = skyloop_plot::report::Report::new(fig.title.clone());
        r.section("").interactive_figure(
            fig.clone(),
            "wheel: zoom (shift: x only, alt: y only) · drag: pan · double-click: reset",
        );
        r.save(path)?;
    } else {
        fig.save(path)?;
    }
    Ok(())
}
