//! Printing results: exactly one JSON object on stdout with --json, readable tables otherwise.

use skyloop::lti::Mat;

/// Prints one JSON value on stdout.
pub fn print_json<T: serde::Serialize>(v: &T) -> skyloop::Result<()> {
    use std::io::Write;
    let s = serde_json::to_string(v)?;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{s}").and_then(|_| out.flush()) {
        // A reader that stopped early (`| head`) is not an error of ours.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(skyloop::Error::Failed(format!("cannot write to stdout: {e}"))),
        Ok(()) => Ok(()),
    }
}

/// Formats a matrix as aligned rows.
pub fn matrix_table(m: &Mat<f64>) -> String {
    let mut s = String::new();
    for i in 0..m.nrows() {
        let row: Vec<String> = (0..m.ncols()).map(|j| format!("{:>12.6}", m[(i, j)])).collect();
        s.push_str(&format!("  {}\n", row.join(" ")));
    }
    s
}
