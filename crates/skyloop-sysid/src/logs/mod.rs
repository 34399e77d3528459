//! Flight logs as named time series: CSV, PX4 ULog, Betaflight blackbox and ArduPilot DataFlash
//! readers, resampling onto
//! a uniform grid, detrending and segment selection.
//!
//! A log is a list of [`Group`]s; every group has one time vector shared by its channels (a ULog
//! topic instance, a blackbox frame kind, the rows of a CSV file). Channel names:
//! - CSV: the header names (`time_s` or the first column is time);
//! - ULog: `topic.field` (e.g. `vehicle_angular_velocity.xyz[0]`), and `topic[k].field` for
//!   instance k > 0 of a multi-instance topic;
//! - blackbox: Betaflight's field names (`gyroADC[0]` in deg/s, `setpoint[0]`, `axisP[0]`,
//!   `loopIteration` as the firmware's loop counter, ...); `time` is the group's time vector;
//! - DataFlash: `MESSAGE.Field` (e.g. `RATE.RDes`), and `MESSAGE[k].Field` for instance k > 0 of a
//!   message with an instance field (`IMU[1].GyrX`), see [`dataflash`].
//!
//! A column spec may also be a sum or difference of channels, such as
//! `axisP[0]+axisI[0]+axisD[0]+axisF[0]` (Betaflight's roll PID sum).

pub mod blackbox;
pub mod csv;
pub mod dataflash;
pub mod ulog;
pub mod uniform;

pub use uniform::{detrend, segments_where, Condition, Detrend, UniformData};

/// A stretch of a log, s (the log's own time axis).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Span {
    /// Start, s.
    pub from_s: f64,
    /// End, s.
    pub to_s: f64,
}

impl Span {
    /// to_s − from_s, s.
    pub fn len_s(&self) -> f64 {
        self.to_s - self.from_s
    }
}

use std::path::Path;

use crate::error::{Result, SysidError};

/// Which reader produced a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    /// Comma/semicolon/tab separated text with a header line.
    Csv,
    /// PX4 ULog.
    Ulog,
    /// Betaflight/INAV blackbox (one session of a possibly multi-session file).
    Blackbox,
    /// ArduPilot DataFlash (`.bin`).
    Dataflash,
}

/// Samples of several channels that share one time vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// Group name: ULog `topic` or `topic[k]`, blackbox `main`/`slow`/`gps`, DataFlash `MESSAGE` or
    /// `MESSAGE[k]`, CSV `csv`.
    pub name: String,
    /// When `Some(p)`, channels are addressed as `p.field`; when `None`, by bare field name.
    pub prefix: Option<String>,
    /// Sample times, s, from the log's time origin: the first main frame (blackbox), the start of the
    /// data span (ULog, see [`ulog`]); CSV times as in the file.
    pub time_s: Vec<f64>,
    /// The channels, each as long as `time_s`.
    pub channels: Vec<Channel>,
}

/// One named channel of a group.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Field name within its group.
    pub name: String,
    /// Values (units as logged, except blackbox gyro in deg/s, acceleration in g, voltage in V).
    pub values: Vec<f64>,
}

/// A decoded log.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    /// The file name (or a description) used in messages.
    pub source: String,
    /// The reader that produced it.
    pub format: LogFormat,
    /// All groups with at least one sample.
    pub groups: Vec<Group>,
    /// Warnings such as "log truncated after 12.3 s: data read up to there".
    pub notes: Vec<String>,
    /// The firmware's settings as the log records them, in file order (a later entry overrides an
    /// earlier one of the same name): blackbox `H name:value` header lines (value as written), ULog
    /// parameters (value as decimal text, the last value logged), DataFlash PARM messages plus
    /// `Firmware revision` and `Frame` from its MSG texts. Empty for CSV.
    pub settings: Vec<(String, String)>,
    /// The flight controller's clock at time 0 of [`Group::time_s`], s: a sample's time as the firmware
    /// logged it is `time_s + clock_origin_s` (0 for CSV, whose times are as in the file).
    pub clock_origin_s: f64,
}

/// Options for [`Log::open`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OpenOptions {
    /// Blackbox session (counted from 1) of a multi-session file; `None` picks the longest decodable one.
    pub session: Option<usize>,
    /// CSV time column; `None` uses `time_s`, `time`, `t` or else the first column.
    pub time_column: Option<String>,
}

/// Summary of one group for `log info`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GroupInfo {
    /// Group name.
    pub name: String,
    /// Full channel names (as accepted by [`Log::series`]).
    pub fields: Vec<String>,
    /// Number of samples.
    pub samples: usize,
    /// Median sample rate, Hz (0 for fewer than two samples).
    pub rate_hz: f64,
    /// First to last sample, s.
    pub duration_s: f64,
}

impl Log {
    /// Reads a log, choosing the reader from the file's first bytes (ULog magic, blackbox marker,
    /// DataFlash sync bytes 0xA3 0x95) or else treating it as CSV.
    pub fn open(path: &Path, opts: &OpenOptions) -> Result<Log> {
        let bytes = read_capped(path)?;
        Log::from_bytes(&bytes, &path.display().to_string(), opts)
    }

    /// Reads a log from its bytes (a file already in memory: a browser's dropped file), choosing the
    /// reader as [`Log::open`] does; `name` names it in messages.
    pub fn from_bytes(bytes: &[u8], name: &str, opts: &OpenOptions) -> Result<Log> {
        let name = name.to_string();
        if bytes.is_empty() {
            // Detection reads the first bytes; with none, the CSV reader's "empty CSV file" would
            // misname a truncated .ulg or .bbl download.
            return Err(SysidError::Log(format!("{name}: the file is empty (0 bytes)")));
        }
        match detect(bytes) {
            LogFormat::Ulog => ulog::read_bytes(bytes, &name),
            LogFormat::Blackbox => blackbox::read_bytes(bytes, &name, opts.session),
            LogFormat::Dataflash => dataflash::read_bytes(bytes, &name),
            LogFormat::Csv => {
                let text = std::str::from_utf8(bytes).map_err(|_| {
                    SysidError::Log(format!(
                        "{name}: not a ULog, blackbox, DataFlash or CSV file (binary content that is not UTF-8 text)"
                    ))
                })?;
                csv::read_str(text, &name, opts.time_column.as_deref())
            }
        }
    }

    /// Every channel's full name.
    pub fn field_names(&self) -> Vec<String> {
        self.groups
            .iter()
            .flat_map(|g| g.channels.iter().map(move |c| full_name(g, &c.name)))
            .collect()
    }

    /// The last value recorded for setting `name` (see [`Log::settings`]).
    pub fn setting(&self, name: &str) -> Option<&str> {
        self.settings
            .iter()
            .rev()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// Per-group summaries (fields, rate, duration).
    pub fn info(&self) -> Vec<GroupInfo> {
        self.groups
            .iter()
            .map(|g| GroupInfo {
                name: g.name.clone(),
                fields: g.channels.iter().map(|c| full_name(g, &c.name)).collect(),
                samples: g.time_s.len(),
                rate_hz: median_rate_hz(&g.time_s),
                duration_s: match (g.time_s.first(), g.time_s.last()) {
                    (Some(a), Some(b)) => b - a,
                    _ => 0.0,
                },
            })
            .collect()
    }

    /// First to last sample over all groups, s.
    pub fn duration_s(&self) -> f64 {
        let (lo, hi) = self
            .groups
            .iter()
            .flat_map(|g| g.time_s.first().into_iter().chain(g.time_s.last()))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| (a.min(t), b.max(t)));
        if hi >= lo {
            hi - lo
        } else {
            0.0
        }
    }

    /// The samples of one channel: (time_s, values). `name` is a full channel name.
    pub fn channel(&self, name: &str) -> Result<(&[f64], &[f64])> {
        for g in &self.groups {
            let field = match &g.prefix {
                Some(p) => match name.strip_prefix(p.as_str()).and_then(|r| r.strip_prefix('.')) {
                    Some(f) => f,
                    None => continue,
                },
                None => name,
            };
            if let Some(c) = g.channels.iter().find(|c| c.name == field) {
                return Ok((&g.time_s, &c.values));
            }
        }
        Err(self.missing(name))
    }

    /// A column spec (a channel, or channels joined by `+`/`-`) as one series on the time base of
    /// its first channel (the others interpolated onto it).
    pub fn series(&self, spec: &str) -> Result<(Vec<f64>, Vec<f64>)> {
        let spec = spec.trim();
        if let Ok((t, v)) = self.channel(spec) {
            return Ok((t.to_vec(), v.to_vec()));
        }
        let terms = split_terms(spec);
        if terms.len() < 2 {
            return Err(self.missing(spec));
        }
        let (t0, v0) = self.channel(&terms[0].1)?;
        let mut t = t0.to_vec();
        let mut v: Vec<f64> = v0.iter().map(|x| terms[0].0 * x).collect();
        for (sign, name) in &terms[1..] {
            let (ti, vi) = self.channel(name)?;
            let (ti, vi) = uniform::sorted(ti, vi);
            let interp = uniform::interp_linear(&ti, &vi, &t);
            for (a, b) in v.iter_mut().zip(interp) {
                *a += sign * b;
            }
        }
        // Keep only times where every term has data.
        let (lo, hi) = terms
            .iter()
            .try_fold((f64::NEG_INFINITY, f64::INFINITY), |(lo, hi), (_, n)| {
                let (ti, _) = self.channel(n)?;
                let (a, b) = uniform::span(ti);
                Ok::<_, SysidError>((lo.max(a), hi.min(b)))
            })?;
        let keep: Vec<usize> = (0..t.len()).filter(|&i| t[i] >= lo && t[i] <= hi).collect();
        t = keep.iter().map(|&i| t[i]).collect();
        v = keep.iter().map(|&i| v[i]).collect();
        Ok((t, v))
    }

    /// The named columns resampled onto one uniform grid over the time span they share, restricted to
    /// [from_s, to_s]; `rate_hz = None` uses the highest median rate of the columns, or, for columns
    /// of one group logged at a steady rate, the samples as logged (see `uniform::resample`).
    pub fn uniform(
        &self,
        specs: &[&str],
        rate_hz: Option<f64>,
        from_s: Option<f64>,
        to_s: Option<f64>,
    ) -> Result<UniformData> {
        let series = specs.iter().map(|s| self.series(s)).collect::<Result<Vec<_>>>()?;
        uniform::resample(specs, &series, rate_hz, from_s, to_s)
    }

    fn missing(&self, name: &str) -> SysidError {
        let all = self.field_names();
        let stem: String = name.split(['[', '.', '+']).next().unwrap_or(name).to_lowercase();
        let mut similar: Vec<&String> = all
            .iter()
            .filter(|f| !stem.is_empty() && f.to_lowercase().contains(&stem))
            .collect();
        similar.truncate(8);
        let hint = if !similar.is_empty() {
            format!(
                "; similar: {}",
                similar.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
            )
        } else if all.is_empty() {
            "; the log has no data channels".to_string()
        } else {
            format!("; it has {} fields (list them with `skyloop log info`)", all.len())
        };
        SysidError::MissingField {
            name: name.to_string(),
            source_name: self.source.clone(),
            hint,
        }
    }
}

fn full_name(g: &Group, field: &str) -> String {
    match &g.prefix {
        Some(p) => format!("{p}.{field}"),
        None => field.to_string(),
    }
}

/// Splits `a+b-c` into signed terms; returns a single term when there is no operator.
fn split_terms(spec: &str) -> Vec<(f64, String)> {
    let mut out = Vec::new();
    let mut sign = 1.0;
    let mut cur = String::new();
    for ch in spec.chars() {
        if ch == '+' || ch == '-' {
            if !cur.trim().is_empty() {
                out.push((sign, cur.trim().to_string()));
            }
            cur.clear();
            sign = if ch == '+' { 1.0 } else { -1.0 };
        } else {
            cur.push(ch);
        }
    }
    if !cur.trim().is_empty() {
        out.push((sign, cur.trim().to_string()));
    }
    out
}

/// Median sample rate of increasing times, Hz (0 for fewer than two distinct samples).
pub fn median_rate_hz(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return 0.0;
    }
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    1.0 / *m
}

/// Largest log file read, bytes (4 GiB): beyond it a file is no flight log this tool reads.
pub const MAX_LOG_BYTES: u64 = 4 << 30;

/// Reads a file for [`Log::open`]: the first 64 KiB decide the format; a file whose start is
/// neither a log's magic nor text is refused there, before the rest is read (a device such as
/// /dev/urandom never ends), and no file is read beyond [`MAX_LOG_BYTES`].
fn read_capped(path: &Path) -> Result<Vec<u8>> {
    use std::io::Read;
    let io = |e: std::io::Error| SysidError::Io(format!("cannot read {}: {e}", path.display()));
    let mut f = std::fs::File::open(path).map_err(io)?;
    // A device or a pipe is no log: /dev/zero reads as 4 GiB of "text" before the size cap
    // refuses it (12 s), and a FIFO may never end.
    skyloop_lti::json::require_regular_file(&f.metadata().map_err(io)?)
        .map_err(|why| SysidError::Log(format!("{}: {why}", path.display())))?;
    let mut bytes = Vec::new();
    (&mut f).take(64 << 10).read_to_end(&mut bytes).map_err(io)?;
    if detect(&bytes) == LogFormat::Csv {
        // A UTF-8 character cut at the 64 KiB boundary is still text.
        let text_start = match std::str::from_utf8(&bytes) {
            Ok(_) => true,
            Err(e) => e.error_len().is_none(),
        };
        if !text_start {
            return Err(SysidError::Log(format!(
                "{}: not a ULog, blackbox, DataFlash or CSV file (its first bytes are binary, not a log's magic or UTF-8 text)",
                path.display()
            )));
        }
    }
    f.take(MAX_LOG_BYTES).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 >= MAX_LOG_BYTES {
        return Err(SysidError::Log(format!(
            "{}: larger than {} GiB, the most a log may be",
            path.display(),
            MAX_LOG_BYTES >> 30
        )));
    }
    Ok(bytes)
}

/// Guesses the reader from a file's first bytes.
pub fn detect(bytes: &[u8]) -> LogFormat {
    if bytes.starts_with(b"ULog") {
        LogFormat::Ulog
    } else if bytes.starts_with(b"H Product:Blackbox")
        || bytes.windows(18).take(4096).any(|w| w == b"H Product:Blackbox")
    {
        LogFormat::Blackbox
    } else if dataflash::looks_like_dataflash(bytes) {
        LogFormat::Dataflash
    } else {
        LogFormat::Csv
    }
}

pub(crate) fn check_not_empty(log: &Log) -> Result<()> {
    if log.groups.iter().all(|g| g.time_s.is_empty()) {
        return Err(SysidError::Log(format!("{}: no data samples in the log", log.source)));
    }
    Ok(())
}
