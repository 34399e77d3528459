//! One estimate from several records of one experiment (the airborne segments of a flight): the
//! spectra are estimated within each record and averaged, weighted by the record's length, so no
//! periodogram or correlation spans the gap between two records. Joining the records into one
//! instead puts a step (or, tapered, a ramp) at every joint, whose broadband power biases every
//! spectrum, and it gives the joined record a frequency resolution that no record has.

use super::spafdr::{Dft, MIN_WIDTH_BINS};
use super::welch::{default_nfft, Windows};
use super::{limits, prepare, spa, Cross, Frf, IoData, Method, Options, Prepared};
use crate::error::{invalid, Result, SysidError};

/// A record contributes to a SPAFDR point only where the smoothing window spans at least this many
/// of its own DFT bins: a shorter record cannot resolve the window, and would blur it.
const MIN_RECORD_BINS: f64 = 3.0;

/// Length of the cosine ramps that taper each record for SPAFDR, s: the taper's own leakage falls off
/// fast above 1/TAPER_S (2 Hz), and it down-weights only a second of each record.
pub const TAPER_S: f64 = 0.5;

/// Welch segment length for several records: the power of two the one-record default would choose
/// for all the samples together, shortened until records at least that long hold three quarters of
/// the samples (so that short records are not all dropped).
pub fn default_nfft_records(lengths: &[usize]) -> usize {
    let total: usize = lengths.iter().sum();
    let mut nfft = default_nfft(total);
    while nfft > 16 {
        let held: usize = lengths.iter().filter(|&&n| n >= nfft).sum();
        if 4 * held >= 3 * total {
            break;
        }
        nfft /= 2;
    }
    nfft
}

/// The frequency response of several records sampled every `dt_s` (all the same) with the chosen
/// method, the records' spectra averaged with weights proportional to their lengths:
/// - Welch: the windows of every record at least `nfft` long (default [`default_nfft_records`]);
///   ν is the sum of the records' equivalent averages;
/// - SPAFDR: each record tapered at both ends (cosine ramps of `TAPER_S`, at most a tenth of the
///   record each): an untapered record's periodogram leaks the power of the jump between its last
///   and first sample (a flight's rates wander by hundreds of deg/s) as a 1/f² floor that buries a
///   pilot's weak high-frequency setpoint. Its periodograms are then smoothed with the same Hann
///   kernel of full width
///   max(`resolution`·f, 6 bins of the longest record), a record taking part where the kernel spans
///   at least 3 of its own bins; ν = (Σw)²/Σw² over the taps of all records;
/// - SPA: the correlation functions of the records pooled (Σ_records Σ_t over ΣN), lag window M
///   (default min(ΣN/10, 30)) from records longer than M;
/// - ETFE: the records joined end to end (a raw ETFE has one DFT grid, which records of different
///   lengths do not share).
///
/// One record is [`estimate`](super::estimate) itself, but for SPAFDR, whose records are tapered here.
///
/// # Errors
/// No record, records with different sample intervals, no record long enough for the method, and
/// everything [`estimate`](super::estimate) refuses.
pub fn estimate_records(records: &[IoData], o: &Options) -> Result<Frf> {
    let Some(first) = records.first() else {
        return Err(invalid("no record to estimate from"));
    };
    if records.len() == 1 && o.method != Method::Spafdr {
        return super::estimate(first, o);
    }
    let dt = first.dt_s;
    if let Some(d) = records.iter().find(|d| d.dt_s != dt) {
        return Err(invalid(format!(
            "records sampled at different intervals ({} s and {} s) cannot be averaged",
            dt, d.dt_s
        )));
    }
    let closed = first.r.is_some();
    if records.iter().any(|d| d.r.is_some() != closed) {
        return Err(invalid("some records have an excitation and some do not"));
    }
    let disturbed = first.dist.is_some();
    if records.iter().any(|d| d.dist.is_some() != disturbed) {
        return Err(invalid("some records have a measured disturbance and some do not"));
    }
    if disturbed && !o.method.conditions_on_disturbance() {
        return Err(super::no_conditioning(o.method));
    }
    let lengths: Vec<usize> = records.iter().map(|d| d.u.len()).collect();
    let longest = lengths.iter().copied().max().unwrap_or(0);
    let too_short = |what: String| {
        SysidError::NotEnoughData(format!(
            "no record is long enough for {what} (longest {longest} samples of {} records)",
            records.len()
        ))
    };
    match o.method {
        Method::Welch => {
            let nfft = o.nfft.unwrap_or_else(|| default_nfft_records(&lengths));
            if nfft < 8 {
                return Err(invalid(format!("Welch segment length {nfft} must be at least 8")));
            }
            let mut w = Windows::new(nfft, o)?;
            let mut used = 0;
            for d in records.iter().filter(|d| d.u.len() >= nfft) {
                w.add(&prepare(d, o.detrend, 16)?)?;
                used += 1;
            }
            if used == 0 {
                return Err(too_short(format!("Welch segments of {nfft} samples")));
            }
            w.finish(o, dt, closed)
        }
        Method::Spafdr => spafdr_records(records, o, dt, longest, closed),
        Method::Spa => {
            let total: usize = lengths.iter().sum();
            let m = o.lag_window.unwrap_or((total / 10).min(30));
            if m < 2 {
                return Err(invalid(format!("lag window {m} must be at least 2")));
            }
            let mut pooled: Option<spa::Correlations> = None;
            let mut n_used = 0usize;
            for d in records.iter().filter(|d| d.u.len() > m.max(16)) {
                let p = prepare(d, o.detrend, 16)?;
                let n = p.u.len() as f64;
                let (a, b, c, cl) = spa::correlations(&p, m)?;
                let scale = |v: Vec<f64>| v.into_iter().map(|x| x * n).collect::<Vec<f64>>();
                let add = |acc: &mut Vec<f64>, v: Vec<f64>| acc.iter_mut().zip(v).for_each(|(a, v)| *a += v);
                let (a, b, c) = (scale(a), scale(b), scale(c));
                let cl = cl.map(|(x, y, z)| (scale(x), scale(y), scale(z)));
                match &mut pooled {
                    None => pooled = Some((a, b, c, cl)),
                    Some((pa, pb, pc, pcl)) => {
                        add(pa, a);
                        add(pb, b);
                        add(pc, c);
                        if let (Some((px, py, pz)), Some((x, y, z))) = (pcl.as_mut(), cl) {
                            add(px, x);
                            add(py, y);
                            add(pz, z);
                        }
                    }
                }
                n_used += p.u.len();
            }
            let Some((a, b, c, cl)) = pooled else {
                return Err(too_short(format!("a lag window of {m}")));
            };
            let s = 1.0 / n_used as f64;
            let norm = |v: Vec<f64>| v.into_iter().map(|x| x * s).collect::<Vec<f64>>();
            let cl = cl.map(|(x, y, z)| (norm(x), norm(y), norm(z)));
            spa::from_correlations(o, dt, n_used, m, (norm(a), norm(b), norm(c), cl))
        }
        Method::Etfe => {
            let u = joined(records, |d| d.u);
            let y = joined(records, |d| d.y);
            let r = closed.then(|| joined(records, |d| d.r.unwrap_or(&[])));
            super::estimate(
                &IoData {
                    u: &u,
                    y: &y,
                    r: r.as_deref(),
                    dist: None,
                    dt_s: dt,
                },
                o,
            )
        }
    }
}

/// One channel of the records end to end, each record's mean removed (so the joints carry no step
/// of the mean).
fn joined<'a>(records: &[IoData<'a>], f: impl Fn(&IoData<'a>) -> &'a [f64]) -> Vec<f64> {
    records
        .iter()
        .flat_map(|d| {
            let x = f(d);
            let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
            x.iter().map(move |v| v - mean)
        })
        .collect()
}

fn spafdr_records(records: &[IoData], o: &Options, dt: f64, longest: usize, closed: bool) -> Result<Frf> {
    if !(o.resolution.is_finite() && o.resolution > 0.0) {
        return Err(invalid(format!(
            "relative resolution must be positive, got {}",
            o.resolution
        )));
    }
    if o.n_freq < 2 {
        return Err(invalid("SPAFDR needs at least 2 output frequencies"));
    }
    let prepared: Vec<Prepared> = records
        .iter()
        .filter(|d| d.u.len() >= 32)
        .map(|d| prepare(d, o.detrend, 32))
        .collect::<Result<_>>()?;
    if prepared.is_empty() {
        return Err(SysidError::NotEnoughData(format!(
            "no record has the 32 samples SPAFDR needs (longest {longest})"
        )));
    }
    let dfts: Vec<(Dft, f64)> = prepared
        .iter()
        .map(|p| {
            let n = p.u.len();
            let m = ((TAPER_S / dt).round() as usize).min(n / 10);
            let w: Vec<f64> = (0..n)
                .map(|i| {
                    let k = i.min(n - 1 - i);
                    if k < m {
                        0.5 * (1.0 - (std::f64::consts::PI * (k as f64 + 0.5) / m as f64).cos())
                    } else {
                        1.0
                    }
                })
                .collect();
            let tap = |x: &[f64]| x.iter().zip(&w).map(|(x, w)| x * w).collect::<Vec<f64>>();
            let r = p.r.as_deref().map(tap);
            let dist = p.dist.as_deref().map(tap);
            let energy: f64 = w.iter().map(|w| w * w).sum();
            Ok((
                Dft::new(&tap(&p.u), &tap(&p.y), r.as_deref(), dist.as_deref(), p.dt)?,
                energy,
            ))
        })
        .collect::<Result<_>>()?;
    let df_min = 1.0 / (longest as f64 * dt);
    let (lo, hi) = limits(o, 2.0 * MIN_WIDTH_BINS * df_min, dt)?;
    let lo = lo.max(df_min);
    if hi <= lo {
        return Err(invalid(format!(
            "frequency range ends at {hi} Hz, below the resolution {df_min} Hz of the longest record"
        )));
    }
    let ratio = (hi / lo).powf(1.0 / (o.n_freq - 1) as f64);
    let width = |f: f64| (o.resolution * f).max(MIN_WIDTH_BINS * df_min);
    let mut points = Vec::new();
    let mut widths = Vec::new();
    for i in 0..o.n_freq {
        let f = lo * ratio.powi(i as i32);
        let b = width(f);
        let mut c = Cross::default();
        let (mut sw, mut sw2) = (0.0, 0.0);
        for (dft, n) in &dfts {
            if b < MIN_RECORD_BINS * dft.df {
                continue;
            }
            if let Some((ci, s1, s2)) = dft.smooth_sums(f, b) {
                // |X_k|²/Σw² (w the taper) estimates the same spectrum whatever the record's length,
                // so each tap weighs the same and a record's weight grows with its bins under the
                // kernel, ∝ its length.
                let k = 1.0 / n;
                c.add_scaled(k, &ci);
                sw += k * s1;
                sw2 += k * k * s2;
            }
        }
        if sw > 0.0 {
            points.push((f, c, sw * sw / sw2));
            widths.push((f, b));
        }
    }
    let mut frf = Frf::from_cross(points, closed)?;
    frf.bandwidth_hz = frf
        .freq_hz
        .iter()
        .map(|f| widths.iter().find(|(g, _)| g == f).map_or(0.0, |(_, b)| *b))
        .collect();
    Ok(frf)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records cut from one long record estimate what the long record does; a step between two records
    /// of different means, which joining would turn into broadband power, leaves them unchanged.
    #[test]
    fn records_agree_with_one_record_and_ignore_offsets() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let n = 60_000;
        let u: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let mut y = vec![0.0; n];
        for k in 1..n {
            y[k] = 0.9 * y[k - 1] + 0.1 * u[k - 1] + 0.01 * rnd();
        }
        // A first-order lag at 1 ms: G(e^{jω}) = 0.1 e^{−jω}/(1 − 0.9 e^{−jω}).
        let g = |f: f64| {
            let z = num_complex::Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * f * 0.001);
            0.1 * z / (1.0 - 0.9 * z)
        };
        let cuts = [0..9000, 9000..21_000, 21_000..26_000, 26_000..60_000];
        let (uo, yo): (Vec<Vec<f64>>, Vec<Vec<f64>>) = cuts
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let off = 50.0 * i as f64;
                (
                    u[r.clone()].iter().map(|v| v + off).collect(),
                    y[r.clone()].iter().map(|v| v - off).collect(),
                )
            })
            .unzip();
        let recs: Vec<IoData> = uo
            .iter()
            .zip(&yo)
            .map(|(u, y)| IoData {
                u,
                y,
                r: None,
                dist: None,
                dt_s: 0.001,
            })
            .collect();
        for method in [Method::Welch, Method::Spafdr, Method::Spa] {
            let o = Options {
                method,
                fmin_hz: Some(2.0),
                fmax_hz: Some(100.0),
                nfft: Some(2048),
                lag_window: Some(60),
                ..Options::default()
            };
            let frf = estimate_records(&recs, &o).unwrap();
            assert!(frf.freq_hz.len() > 10);
            // SPA's lag window of 60 samples smooths over about 33 Hz, which biases it near the
            // lag's corner: it is compared with SPA of the whole uncut record, which shares the bias.
            let whole = super::super::estimate(
                &IoData {
                    u: &u,
                    y: &y,
                    r: None,
                    dist: None,
                    dt_s: 0.001,
                },
                &o,
            )
            .unwrap();
            for (i, (f, gh)) in frf.freq_hz.iter().zip(&frf.response).enumerate() {
                let want = if method == Method::Spa {
                    whole.response[i]
                } else {
                    g(*f)
                };
                let e = (gh / want - 1.0).norm();
                assert!(e < 0.06, "{method:?} at {f} Hz: {gh} vs {want}");
            }
        }
        assert_eq!(default_nfft_records(&[9000, 12_000, 5000, 34_000]), 8192);
        assert_eq!(default_nfft_records(&[1000; 10]), 512);
    }
}
