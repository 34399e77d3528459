//! Writing columns of samples as CSV with a header line.

use std::io::Write;

use crate::error::{invalid, Result, SysidError};

/// Writes `columns` (all of the same length) under `header` to `out`, one row per sample.
pub fn write_csv<W: Write>(out: &mut W, header: &[&str], columns: &[&[f64]]) -> Result<()> {
    if header.len() != columns.len() || columns.is_empty() {
        return Err(invalid("CSV needs one header name per column and at least one column"));
    }
    let n = columns[0].len();
    if columns.iter().any(|c| c.len() != n) {
        return Err(invalid("CSV columns differ in length"));
    }
    let io = |e: std::io::Error| SysidError::Io(format!("cannot write CSV: {e}"));
    let mut w = std::io::BufWriter::new(out);
    writeln!(w, "{}", header.join(",")).map_err(io)?;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        for (j, c) in columns.iter().enumerate() {
            if j > 0 {
                line.push(',');
            }
            line.push_str(&format!("{}", c[i]));
        }
        writeln!(w, "{line}").map_err(io)?;
    }
    w.flush().map_err(io)?;
    Ok(())
}
