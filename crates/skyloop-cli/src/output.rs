//! Printing results: exactly one JSON object on stdout with --json, readable tables otherwise.

use skyloop::lti::Mat;

/// Prints one JSON value on stdout, serialized straight into a buffered stdout (no intermediate
/// string or `Value` tree: a 10,000-frequency response prints in about a millisecond).
pub fn print_json<T: serde::Serialize>(v: &T) -> skyloop::Result<()> {
    use std::io::Write;
    let mut out = std::io::BufWriter::with_capacity(1 << 16, std::io::stdout().lock());
    let written = serde_json::to_writer(&mut out, v).map_err(std::io::Error::from);
    match written.and_then(|_| writeln!(out)).and_then(|_| out.flush()) {
        // A reader that stopped early (`| head`) is not an error of ours.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(skyloop::Error::Failed(format!("cannot write to stdout: {e}"))),
        Ok(()) => Ok(()),
    }
}

/// With `--bench N`, runs `f` N times and prints the fastest wall time on stderr as
/// `bench_seconds T` (for `bench/compare.py`: start-up and printing are not timed).
pub fn bench<T, E>(n: Option<usize>, mut f: impl FnMut() -> Result<T, E>) -> Result<(), E> {
    let Some(n) = n else { return Ok(()) };
    let mut best = f64::INFINITY;
    for _ in 0..n.max(1) {
        let t = std::time::Instant::now();
        std::hint::black_box(f()?);
        best = best.min(t.elapsed().as_secs_f64());
    }
    eprintln!("bench_seconds {best:e}");
    Ok(())
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
