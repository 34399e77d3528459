//! CSV logs: a header line, then one row of numbers per sample; one column is time in seconds.

use super::{Channel, Group, Log, LogFormat};
use crate::error::{Result, SysidError};

/// Parses CSV text (delimiter `,`, `;` or tab, detected from the header).
pub fn read_str(text: &str, source: &str, time_column: Option<&str>) -> Result<Log> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let (_, header) = lines
        .next()
        .ok_or_else(|| SysidError::Log(format!("{source}: empty CSV file")))?;
    let delim = [',', ';', '\t']
        .into_iter()
        .max_by_key(|d| header.matches(*d).count())
        .unwrap_or(',');
    let names: Vec<String> = header
        .split(delim)
        .map(|s| s.trim().trim_matches('"').to_string())
        .collect();
    if names.iter().any(|n| n.is_empty()) {
        return Err(SysidError::Log(format!(
            "{source}: the CSV header has an empty column name: '{header}'"
        )));
    }
    let tcol = match time_column {
        Some(tc) => names
            .iter()
            .position(|n| n == tc)
            .ok_or_else(|| SysidError::MissingField {
                name: tc.to_string(),
                source_name: source.to_string(),
                hint: format!("; columns: {}", names.join(", ")),
            })?,
        None => ["time_s", "time", "t"]
            .iter()
            .find_map(|c| names.iter().position(|n| n == c))
            .unwrap_or(0),
    };
    if names.len() < 2 {
        return Err(SysidError::Log(format!(
            "{source}: CSV needs a time column and at least one data column"
        )));
    }
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for (lineno, line) in lines {
        let fields: Vec<&str> = line.split(delim).collect();
        if fields.len() != names.len() {
            return Err(SysidError::Log(format!(
                "{source}: line {} has {} fields, the header has {}",
                lineno + 1,
                fields.len(),
                names.len()
            )));
        }
        for (j, f) in fields.iter().enumerate() {
            let v: f64 = f.trim().parse().map_err(|_| {
                SysidError::Log(format!(
                    "{source}: line {}, column '{}': '{}' is not a number",
                    lineno + 1,
                    names[j],
                    f.trim()
                ))
            })?;
            cols[j].push(v);
        }
    }
    let time_s = std::mem::take(&mut cols[tcol]);
    if time_s.is_empty() {
        return Err(SysidError::Log(format!("{source}: CSV has a header but no data rows")));
    }
    if let Some(i) = time_s.windows(2).position(|w| !(w[1] > w[0])) {
        return Err(SysidError::Log(format!(
            "{source}: time column '{}' is not increasing at data row {} ({} then {})",
            names[tcol],
            i + 2,
            time_s[i],
            time_s[i + 1]
        )));
    }
    let channels = names
        .iter()
        .zip(cols)
        .enumerate()
        .filter(|(j, _)| *j != tcol)
        .map(|(_, (n, values))| Channel {
            name: n.clone(),
            values,
        })
        .collect();
    Ok(Log {
        source: source.to_string(),
        format: LogFormat::Csv,
        groups: vec![Group {
            name: "csv".into(),
            prefix: None,
            time_s,
            channels,
        }],
        notes: Vec::new(),
        settings: Vec::new(),
        clock_origin_s: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_refuses() {
        let log = read_str("time_s,u,y\n0,1,2\n0.01,3,4\n", "x.csv", None).unwrap();
        let (t, y) = log.channel("y").unwrap();
        assert_eq!(t, &[0.0, 0.01]);
        assert_eq!(y, &[2.0, 4.0]);
        let e = read_str("time_s,u\n0,1\n0.1,abc\n", "x.csv", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("'u'") && e.contains("abc"), "{e}");
        let e = read_str("time_s,u\n0,1\n0.1\n", "x.csv", None).unwrap_err().to_string();
        assert!(e.contains("line 3 has 1 fields"), "{e}");
        let e = read_str("t;u\n0;1\n0;2\n", "x.csv", None).unwrap_err().to_string();
        assert!(e.contains("not increasing"), "{e}");
        let e = log.channel("gyro").unwrap_err().to_string();
        assert!(e.contains("no field 'gyro' in x.csv"), "{e}");
        assert!(read_str("", "x.csv", None).is_err());
        assert!(read_str("a,b\n", "x.csv", Some("zz")).is_err());
    }
}
