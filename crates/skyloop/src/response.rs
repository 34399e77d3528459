//! Frequency grids named by a user and frequency responses in skyloop's JSON layout.

use std::f64::consts::PI;

use skyloop_lti::{c64, StateSpace};

use crate::{Error, Result};

/// The most frequencies one grid may hold: a million points already take seconds to print, so a
/// larger request is a typo rather than a plot.
pub const MAX_GRID_POINTS: usize = 1_000_000;

/// `n` log-spaced frequencies from `lo_hz` to `hi_hz` (both in Hz, ends included).
///
/// # Errors
/// [`Error::Input`] naming `what` (the option the numbers came from) unless
/// `0 < lo_hz < hi_hz`, both finite, and `2 <= n <= MAX_GRID_POINTS`.
///
/// # Examples
/// ```
/// let f = skyloop::response::logspace_hz(0.1, 10.0, 3, "--logspace-hz").unwrap();
/// assert!((f[1] - 1.0).abs() < 1e-12);
/// assert!(skyloop::response::logspace_hz(10.0, 1.0, 3, "--logspace-hz").is_err());
/// ```
pub fn logspace_hz(lo_hz: f64, hi_hz: f64, n: usize, what: &str) -> Result<Vec<f64>> {
    if !(lo_hz.is_finite() && hi_hz.is_finite() && lo_hz > 0.0 && hi_hz > lo_hz) || n < 2 {
        return Err(Error::Input(format!(
            "{what} needs LO,HI,N with 0 < LO < HI (Hz, finite) and an integer N >= 2; got {lo_hz},{hi_hz},{n}"
        )));
    }
    if n > MAX_GRID_POINTS {
        return Err(Error::Input(format!(
            "{what}: N = {n} exceeds the limit of {MAX_GRID_POINTS} points"
        )));
    }
    let w = skyloop_lti::freqresp::try_logspace(lo_hz.log10(), hi_hz.log10(), n)?;
    Ok(w)
}

/// Parses `LO,HI,N` (Hz, Hz, count) as [`logspace_hz`] takes it; `what` names the option.
///
/// # Errors
/// [`Error::Input`] when the text is not three numbers or [`logspace_hz`] refuses them.
pub fn parse_logspace_hz(values: &[f64], what: &str) -> Result<Vec<f64>> {
    match values {
        [lo, hi, n] if n.fract() == 0.0 && *n >= 0.0 => logspace_hz(*lo, *hi, n.min(usize::MAX as f64) as usize, what),
        _ => Err(Error::Input(format!(
            "{what} needs LO,HI,N with 0 < LO < HI (Hz) and an integer N >= 2"
        ))),
    }
}

/// Checks user-given frequencies (Hz): every one finite and `>= 0`.
///
/// # Errors
/// [`Error::Input`] naming `what` and the first offending value.
pub fn check_frequencies_hz(freq_hz: &[f64], what: &str) -> Result<()> {
    match freq_hz.iter().find(|&&x| !(x.is_finite() && x >= 0.0)) {
        Some(x) => Err(Error::Input(format!(
            "{what}: frequencies must be finite and >= 0 Hz, got {x}"
        ))),
        None => Ok(()),
    }
}

/// `n` log-spaced frequencies (Hz) spanning the model's dynamics two decades either side (up to
/// the Nyquist frequency of a discrete model).
///
/// # Errors
/// When the model's dynamics put the grid beyond the floating-point range.
pub fn default_grid_hz(sys: &StateSpace, n: usize) -> Result<Vec<f64>> {
    Ok(skyloop_lti::freqresp::default_grid(sys, n)?
        .into_iter()
        .map(|w| w / (2.0 * PI))
        .collect())
}

/// A frequency response in skyloop's JSON layout,
/// `{"freq_hz":[..],"re":[[[..]]],"im":[[[..]]]}` indexed `[frequency][output][input]`,
/// serialized straight from the flat response (no nested copies, no allocation per frequency).
#[derive(serde::Serialize)]
pub struct ResponseJson<'a> {
    /// Frequencies, Hz.
    pub freq_hz: &'a [f64],
    /// Real parts.
    pub re: Part<'a>,
    /// Imaginary parts.
    pub im: Part<'a>,
}

impl<'a> ResponseJson<'a> {
    /// The JSON view of the flat response `g` of an `ny`×`nu` model: the values of frequency `k`
    /// of `freq_hz`, row-major, at `k·ny·nu ..` (as `skyloop_lti::freqresp::freqresp_flat` gives).
    pub fn new(freq_hz: &'a [f64], g: &'a [c64], ny: usize, nu: usize) -> Self {
        let nfreq = freq_hz.len();
        let view = |f: fn(&c64) -> f64| Part { g, nfreq, ny, nu, f };
        ResponseJson {
            freq_hz,
            re: view(|z| z.re),
            im: view(|z| z.im),
        }
    }
}

/// One part (real or imaginary) of a flat response, serialized as `[frequency][output][input]`.
#[derive(Clone, Copy)]
pub struct Part<'a> {
    g: &'a [c64],
    nfreq: usize,
    ny: usize,
    nu: usize,
    f: fn(&c64) -> f64,
}

/// `[output][input]` of one frequency, or `[input]` of one row when `nu` is its only dimension.
struct Rows<'a> {
    part: Part<'a>,
    values: &'a [c64],
    by_row: bool,
}

impl serde::Serialize for Rows<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let nu = self.part.nu;
        if self.by_row {
            let mut rows = s.serialize_seq(Some(self.part.ny))?;
            for i in 0..self.part.ny {
                let row = &self.values[i * nu..(i + 1) * nu];
                rows.serialize_element(&Rows {
                    part: self.part,
                    values: row,
                    by_row: false,
                })?;
            }
            rows.end()
        } else {
            let mut cols = s.serialize_seq(Some(self.values.len()))?;
            for z in self.values {
                cols.serialize_element(&(self.part.f)(z))?;
            }
            cols.end()
        }
    }
}

impl serde::Serialize for Part<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let per = self.ny * self.nu;
        let mut freqs = s.serialize_seq(Some(self.nfreq))?;
        for k in 0..self.nfreq {
            freqs.serialize_element(&Rows {
                part: *self,
                values: &self.g[k * per..(k + 1) * per],
                by_row: true,
            })?;
        }
        freqs.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `re[k][i][j]` and `im[k][i][j]` of a 2×3 response are the flat values at `k·6 + i·3 + j`.
    #[test]
    fn response_json_is_indexed_frequency_output_input() {
        let g: Vec<c64> = (0..12).map(|v| c64::new(v as f64, -(v as f64) / 2.0)).collect();
        let text = serde_json::to_string(&ResponseJson::new(&[1.0, 2.0], &g, 2, 3)).unwrap_or_default();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        for k in 0..2 {
            for i in 0..2 {
                for j in 0..3 {
                    let idx = (k * 6 + i * 3 + j) as f64;
                    assert_eq!(v["re"][k][i][j].as_f64(), Some(idx), "{text}");
                    assert_eq!(v["im"][k][i][j].as_f64(), Some(-idx / 2.0), "{text}");
                }
            }
        }
        assert_eq!(v["freq_hz"], serde_json::json!([1.0, 2.0]));
        assert_eq!(v["re"].as_array().map(Vec::len), Some(2));
    }
}
