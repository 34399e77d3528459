//! The frequency-response estimate of an identification: the spectral options the request sets
//! (sizes checked before anything is allocated) and the estimate on any set of records, so that
//! the jackknife and the held-out validation refit parts of the data exactly as the whole.

use std::ops::Range;

use super::remarks::Remarks;
use super::request::IdentifyRequest;
use super::{MAX_ETFE_SAMPLES, MAX_N_FREQ};
use crate::error::{Error, Result};
use skyloop_sysid::logs::UniformData;
use skyloop_sysid::spectral::{default_nfft_records, estimate, estimate_records, Frf, IoData, Method, Options, Window};

/// Estimates FRFs of the selected channels on records of their grid.
pub(crate) struct Estimator<'a> {
    data: &'a UniformData,
    has_instrument: bool,
    /// A measured disturbance column follows the instrument (or the output without one).
    has_disturbance: bool,
    /// One span of a log the user chose keeps the single-record estimate.
    user_span: bool,
    opts: Options,
}

impl<'a> Estimator<'a> {
    /// The estimator of the request's method and options on `data` (input, output, then the
    /// instrument when `has_instrument`), for the `records` the whole estimate uses.
    ///
    /// # Errors
    /// A method or window that does not parse, `--n-freq` outside 2..=[`MAX_N_FREQ`], or an ETFE on
    /// more than [`MAX_ETFE_SAMPLES`] samples.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        a: &IdentifyRequest,
        data: &'a UniformData,
        records: &[Range<usize>],
        has_instrument: bool,
        has_disturbance: bool,
        user_span: bool,
        fmax_hz: Option<f64>,
        rm: &mut Remarks,
    ) -> Result<Self> {
        let method: Method = a.method.parse()?;
        let window: Window = a.window.parse()?;
        // Sizes a user sets are checked before anything is allocated or fitted on them.
        if !(2..=MAX_N_FREQ).contains(&a.n_freq) {
            return Err(Error::Input(format!(
                "--n-freq {} is outside 2..={MAX_N_FREQ}",
                a.n_freq
            )));
        }
        if method == Method::Etfe && data.len() > MAX_ETFE_SAMPLES {
            return Err(Error::Input(format!(
                "--method etfe on {} samples: the raw ratio of transforms has one point per sample pair, at most {MAX_ETFE_SAMPLES} samples are taken (use welch or spa, which average)",
                data.len()
            )));
        }
        let mut opts = Options {
            method,
            fmin_hz: a.fmin_hz,
            fmax_hz,
            nfft: a.nfft,
            window,
            overlap: a.overlap,
            lag_window: a.lag_window,
            n_freq: a.n_freq,
            resolution: a.resolution,
            ..Options::default()
        };
        // Every refit (jackknife, validation) uses the full data's Welch length, so that leaving out
        // a block changes the data, not the resolution.
        if method == Method::Welch && opts.nfft.is_none() && records.len() > 1 {
            opts.nfft = Some(default_nfft_records(
                &records.iter().map(|r| r.len()).collect::<Vec<_>>(),
            ));
        }
        if records.len() > 1 {
            rm.note(format!(
                "spectra estimated within each of the {} segments and averaged, weighted by length{}",
                records.len(),
                if method == Method::Etfe {
                    " (etfe: the segments joined, as a raw ETFE needs one DFT grid)"
                } else {
                    ""
                }
            ));
        }
        Ok(Self {
            data,
            has_instrument,
            has_disturbance,
            user_span,
            opts,
        })
    }

    /// The FRF estimated within each record and averaged, weighted by length.
    ///
    /// # Errors
    /// Records too short for the estimate's options.
    pub fn frf_of(&self, records: &[Range<usize>]) -> Result<Frf> {
        let c = &self.data.columns;
        let dist_col = 2 + usize::from(self.has_instrument);
        let io: Vec<IoData> = records
            .iter()
            .map(|r| IoData {
                u: &c[0][r.clone()],
                y: &c[1][r.clone()],
                r: if self.has_instrument {
                    Some(&c[2][r.clone()])
                } else {
                    None
                },
                dist: self.has_disturbance.then(|| &c[dist_col][r.clone()]),
                dt_s: self.data.dt_s,
            })
            .collect();
        // One span of a log the user chose keeps the single-record estimate (SPAFDR untapered, as
        // a bench record that starts and ends at rest wants); flight segments are always tapered.
        if io.len() == 1 && self.user_span {
            return Ok(estimate(&io[0], &self.opts)?);
        }
        Ok(estimate_records(&io, &self.opts)?)
    }
}
