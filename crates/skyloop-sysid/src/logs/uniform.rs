//! Uniformly sampled data from irregular logs: linear resampling, detrending, segment selection.

use std::ops::Range;

use crate::error::{invalid, Result, SysidError};

/// Columns sampled on one uniform time grid t_i = t0_s + i·dt_s.
#[derive(Debug, Clone, PartialEq)]
pub struct UniformData {
    /// Column names (the specs they were made from).
    pub names: Vec<String>,
    /// Time of the first sample, s.
    pub t0_s: f64,
    /// Sample interval, s.
    pub dt_s: f64,
    /// The columns, all of the same length.
    pub columns: Vec<Vec<f64>>,
}

impl UniformData {
    /// The grid samples inside `span` (s, the log's clock): the first sample at or after its
    /// start to the last at or before its end, clamped to the grid (empty when none).
    pub fn range_of(&self, span: &super::Span) -> std::ops::Range<usize> {
        let lo = ((span.from_s - self.t0_s) / self.dt_s).ceil().max(0.0) as usize;
        let hi = (((span.to_s - self.t0_s) / self.dt_s).floor().max(0.0) as usize + 1).min(self.len());
        lo..hi.max(lo)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |c| c.len())
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        1.0 / self.dt_s
    }

    /// The samples `range` of every column.
    pub fn slice(&self, range: Range<usize>) -> Result<UniformData> {
        if range.start >= range.end || range.end > self.len() {
            return Err(invalid(format!(
                "segment {range:?} is outside the {} samples",
                self.len()
            )));
        }
        Ok(UniformData {
            names: self.names.clone(),
            t0_s: self.t0_s + range.start as f64 * self.dt_s,
            dt_s: self.dt_s,
            columns: self.columns.iter().map(|c| c[range.clone()].to_vec()).collect(),
        })
    }

    /// Every column's samples in `ranges`, joined end to end: each segment's own mean removed (separate
    /// flight segments sit at different trims) and its first and last `taper` samples faded in and out
    /// by a raised cosine, so that no segment starts or ends with a step. A step at a join would put
    /// broadband power into input, output and instrument alike that the plant did not make, and bias
    /// the estimate; the taper costs only the ramps' share of the data. Ranges outside the data are
    /// clipped; empty ones are skipped.
    pub fn segments_joined(&self, ranges: &[Range<usize>], taper: usize) -> Vec<Vec<f64>> {
        self.columns
            .iter()
            .map(|c| {
                let mut out = Vec::new();
                for r in ranges {
                    let r = r.start.min(c.len())..r.end.min(c.len());
                    if r.is_empty() {
                        continue;
                    }
                    let mut seg = c[r].to_vec();
                    detrend(&mut seg, Detrend::Mean);
                    let n = seg.len();
                    let m = taper.min(n / 2);
                    for i in 0..m {
                        let w = 0.5 * (1.0 - (std::f64::consts::PI * (i as f64 + 0.5) / m as f64).cos());
                        seg[i] *= w;
                        seg[n - 1 - i] *= w;
                    }
                    out.extend(seg);
                }
                out
            })
            .collect()
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Result<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
            .ok_or_else(|| invalid(format!("no column '{name}' among {}", self.names.join(", "))))
    }
}

/// Removing a trend before spectral estimation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Detrend {
    /// Leave the data as is.
    None,
    /// Subtract the mean.
    Mean,
    /// Subtract the least-squares straight line.
    Linear,
}

/// Removes the trend from `x` in place.
pub fn detrend(x: &mut [f64], how: Detrend) {
    let n = x.len();
    if n == 0 {
        return;
    }
    match how {
        Detrend::None => {}
        Detrend::Mean => {
            let m = x.iter().sum::<f64>() / n as f64;
            x.iter_mut().for_each(|v| *v -= m);
        }
        Detrend::Linear => {
            let tm = (n as f64 - 1.0) / 2.0;
            let xm = x.iter().sum::<f64>() / n as f64;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for (i, v) in x.iter().enumerate() {
                let d = i as f64 - tm;
                sxy += d * (v - xm);
                sxx += d * d;
            }
            let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
            for (i, v) in x.iter_mut().enumerate() {
                *v -= xm + slope * (i as f64 - tm);
            }
        }
    }
}

/// A threshold condition on a column, parsed from text like `rcCommand[3]>1100` or `throttle<=0.2`.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// Column spec.
    pub column: String,
    /// One of `>`, `>=`, `<`, `<=`.
    pub op: String,
    /// Threshold.
    pub value: f64,
}

impl Condition {
    /// Parses `COLUMN OP VALUE` with OP in `> >= < <=`.
    pub fn parse(text: &str) -> Result<Condition> {
        for op in [">=", "<=", ">", "<"] {
            if let Some(i) = text.find(op) {
                let column = text[..i].trim().to_string();
                let v = text[i + op.len()..].trim();
                let value: f64 = v
                    .parse()
                    .map_err(|_| invalid(format!("condition '{text}': '{v}' is not a number")))?;
                if column.is_empty() {
                    return Err(invalid(format!("condition '{text}' names no column")));
                }
                return Ok(Condition {
                    column,
                    op: op.to_string(),
                    value,
                });
            }
        }
        Err(invalid(format!(
            "condition '{text}' needs one of > >= < <= (e.g. 'rcCommand[3]>1100')"
        )))
    }

    /// Whether `x` satisfies the condition.
    pub fn holds(&self, x: f64) -> bool {
        match self.op.as_str() {
            ">" => x > self.value,
            ">=" => x >= self.value,
            "<" => x < self.value,
            _ => x <= self.value,
        }
    }
}

/// Maximal runs of `true` in `mask` that are at least `min_len` long.
pub fn segments_where(mask: &[bool], min_len: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, &m) in mask.iter().chain(std::iter::once(&false)).enumerate() {
        match (m, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if i - s >= min_len.max(1) {
                    out.push(s..i);
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

/// (first, last) of increasing times; (∞, −∞) when empty.
pub(crate) fn span(t: &[f64]) -> (f64, f64) {
    match (t.first(), t.last()) {
        (Some(&a), Some(&b)) => (a.min(b), a.max(b)),
        _ => (f64::INFINITY, f64::NEG_INFINITY),
    }
}

/// Sorts samples by time and drops repeated time stamps (keeping the first); borrowed when already
/// strictly increasing.
pub fn sorted<'a>(t: &'a [f64], v: &'a [f64]) -> (std::borrow::Cow<'a, [f64]>, std::borrow::Cow<'a, [f64]>) {
    if t.windows(2).all(|w| w[1] > w[0]) {
        return (t.into(), v.into());
    }
    let mut idx: Vec<usize> = (0..t.len()).filter(|&i| t[i].is_finite()).collect();
    idx.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
    idx.dedup_by(|b, a| t[*a] == t[*b]);
    (
        idx.iter().map(|&i| t[i]).collect::<Vec<_>>().into(),
        idx.iter().map(|&i| v[i]).collect::<Vec<_>>().into(),
    )
}

/// Linear interpolation of (t, v) (t strictly increasing) at times `at`, clamped at the ends.
pub(crate) fn interp_linear(t: &[f64], v: &[f64], at: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(at.len());
    if t.is_empty() {
        return vec![f64::NAN; at.len()];
    }
    let mut j = 0usize;
    for &x in at {
        if x <= t[0] {
            out.push(v[0]);
            continue;
        }
        if x >= t[t.len() - 1] {
            out.push(v[v.len() - 1]);
            continue;
        }
        // Times `at` are usually increasing: walk forward, restart with a binary search if not.
        if t[j] > x {
            j = t.partition_point(|&s| s <= x).saturating_sub(1);
        }
        while j + 1 < t.len() && t[j + 1] <= x {
            j += 1;
        }
        let (t0, t1) = (t[j], t[j + 1]);
        let w = (x - t0) / (t1 - t0);
        out.push(v[j] + w * (v[j + 1] - v[j]));
    }
    out
}

/// Largest deviation of a logged interval from the median for a series to count as steadily sampled.
const STEADY_JITTER: f64 = 0.25;

/// Series that share one time vector logged at a steady rate (every interval within 25 % of the
/// median), taken sample for sample over [lo, hi] with the mean interval: such a log (a blackbox's
/// main frames, one per N loop iterations) is sampled by the loop's clock, and its timestamps jitter
/// by the logging task's scheduling (−60 µs to +250 µs of 2 ms on btfl_all.bbl; a dropped frame
/// doubles an interval and is not steady). Interpolating by them would
/// resample exact samples at wrong times, an error that moves a flight's FRF by about 8 % at points
/// of low coherence. `None` when the series differ in time or are not steady.
fn steady_samples(names: &[&str], series: &[(Vec<f64>, Vec<f64>)], lo: f64, hi: f64) -> Option<UniformData> {
    let t = &series[0].0;
    if series.iter().any(|(s, _)| s != t) {
        return None;
    }
    let a = t.partition_point(|&x| x < lo);
    let b = t.partition_point(|&x| x <= hi);
    if b < a + 2 {
        return None;
    }
    let mut d: Vec<f64> = t[a..b].windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_by(f64::total_cmp);
    let med = d[d.len() / 2];
    if !(med > 0.0) || d[0] < (1.0 - STEADY_JITTER) * med || d[d.len() - 1] > (1.0 + STEADY_JITTER) * med {
        return None;
    }
    let columns: Vec<Vec<f64>> = series.iter().map(|(_, v)| v[a..b].to_vec()).collect();
    // Non-finite values: the interpolating path reports them with the column's name.
    if columns.iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return None;
    }
    Some(UniformData {
        names: names.iter().map(|s| s.to_string()).collect(),
        t0_s: t[a],
        dt_s: (t[b - 1] - t[a]) / (b - a - 1) as f64,
        columns,
    })
}

/// Most values (samples × columns) a uniform grid may hold: 2.5e8, 2 GiB of f64.
pub const MAX_GRID_VALUES: usize = 250_000_000;

/// Resamples several series onto one uniform grid (see [`crate::logs::Log::uniform`]); series of one
/// steadily logged group are taken sample for sample instead.
pub fn resample(
    names: &[&str],
    series: &[(Vec<f64>, Vec<f64>)],
    rate_hz: Option<f64>,
    from_s: Option<f64>,
    to_s: Option<f64>,
) -> Result<UniformData> {
    if series.is_empty() {
        return Err(invalid("no columns to resample"));
    }
    let mut lo = from_s.unwrap_or(f64::NEG_INFINITY);
    let mut hi = to_s.unwrap_or(f64::INFINITY);
    let mut rate = 0.0f64;
    for ((t, _), name) in series.iter().zip(names) {
        if t.len() < 2 {
            return Err(SysidError::NotEnoughData(format!(
                "column '{name}' has {} samples",
                t.len()
            )));
        }
        let (a, b) = span(t);
        lo = lo.max(a);
        hi = hi.min(b);
        rate = rate.max(super::median_rate_hz(t));
    }
    let rate = match rate_hz {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => return Err(invalid(format!("resampling rate must be positive, got {r}"))),
        None => rate,
    };
    if !(hi > lo) || rate <= 0.0 {
        return Err(SysidError::NotEnoughData(format!(
            "the columns {} share no time span within the requested range",
            names.join(", ")
        )));
    }
    if rate_hz.is_none() {
        if let Some(d) = steady_samples(names, series, lo, hi) {
            return Ok(d);
        }
    }
    let dt = 1.0 / rate;
    // The grid's size is checked before it is allocated: columns × samples × 8 bytes.
    let samples = (hi - lo) / dt + 1.0;
    if samples * series.len().max(1) as f64 > MAX_GRID_VALUES as f64 {
        return Err(invalid(format!(
            "resampling {} columns over {:.1} s at {rate} Hz needs {samples:.3e} samples each, more than the {MAX_GRID_VALUES} values in all (2 GiB) a uniform grid may hold: give a lower --rate (at most {:.0} Hz here)",
            series.len(),
            hi - lo,
            MAX_GRID_VALUES as f64 / series.len().max(1) as f64 / (hi - lo)
        )));
    }
    let n = ((hi - lo) / dt).floor() as usize + 1;
    if n < 2 {
        return Err(SysidError::NotEnoughData(format!(
            "only {n} samples between {lo} s and {hi} s"
        )));
    }
    let grid: Vec<f64> = (0..n).map(|i| lo + i as f64 * dt).collect();
    let columns = series
        .iter()
        .map(|(t, v)| {
            let (t, v) = sorted(t, v);
            interp_linear(&t, &v, &grid)
        })
        .collect::<Vec<_>>();
    for (c, name) in columns.iter().zip(names) {
        if c.iter().any(|v| !v.is_finite()) {
            return Err(SysidError::Log(format!(
                "column '{name}' holds non-finite values in the selected span"
            )));
        }
    }
    Ok(UniformData {
        names: names.iter().map(|s| s.to_string()).collect(),
        t0_s: lo,
        dt_s: dt,
        columns,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_linear_exact_on_lines() {
        // Irregular samples of 2t + 1 (and 3 − t) are resampled exactly by linear interpolation.
        let t1: Vec<f64> = vec![0.0, 0.013, 0.02, 0.041, 0.05, 0.07, 0.1];
        let v1: Vec<f64> = t1.iter().map(|t| 2.0 * t + 1.0).collect();
        let t2: Vec<f64> = (0..20).map(|i| 0.005 + i as f64 * 0.005).collect();
        let v2: Vec<f64> = t2.iter().map(|t| 3.0 - t).collect();
        let u = resample(&["a", "b"], &[(t1, v1), (t2, v2)], Some(100.0), None, None).unwrap();
        assert!((u.t0_s - 0.005).abs() < 1e-15);
        assert_eq!(u.len(), 10);
        for i in 0..u.len() {
            let t = u.t0_s + i as f64 * u.dt_s;
            assert!((u.columns[0][i] - (2.0 * t + 1.0)).abs() < 1e-12);
            assert!((u.columns[1][i] - (3.0 - t)).abs() < 1e-12);
        }
        assert!(resample(&["a"], &[(vec![0.0], vec![1.0])], None, None, None).is_err());
    }

    #[test]
    fn detrend_and_segments() {
        let mut x: Vec<f64> = (0..50).map(|i| 3.0 + 0.5 * i as f64).collect();
        detrend(&mut x, Detrend::Linear);
        assert!(x.iter().all(|v| v.abs() < 1e-12));
        let mask = [false, true, true, true, false, true, false, true, true];
        assert_eq!(segments_where(&mask, 2), vec![1..4, 7..9]);
        let c = Condition::parse("rcCommand[3] >= 1100").unwrap();
        assert_eq!(c.column, "rcCommand[3]");
        assert!(c.holds(1100.0) && !c.holds(1099.0));
        assert!(Condition::parse("x = 3").is_err());
        assert!(Condition::parse("x > abc").is_err());
    }
}
