//! Smallest thread CPU time of N calls of `hinf_norm` on an LTI JSON model, printed as JSON with
//! the norm, for `bench/compare.py` (which times SLICOT AB13DD on the same model the same way).
//! Run: `cargo run --release -p skyloop-lti --example time_hinf_norm -- MODEL.json [repeats]`.

/// Seconds of CPU time consumed by this thread (wall time where that clock is unavailable).
#[allow(unsafe_code)] // one libc call; std has no per-thread CPU clock
fn now() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: clock_gettime only writes the timespec it is given.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    use std::sync::OnceLock;
    static T0: OnceLock<std::time::Instant> = OnceLock::new();
    T0.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: time_hinf_norm MODEL.json [repeats]")?;
    let repeats: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(50);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
    let sys = skyloop_lti::json::from_json_str(&text).map_err(|e| e.to_string())?;
    let mut best = f64::INFINITY;
    let mut norm = f64::NAN;
    for _ in 0..repeats {
        let t = now();
        norm = skyloop_lti::norms::hinf_norm(&sys).map_err(|e| e.to_string())?.0;
        best = best.min(now() - t);
    }
    println!("{{\"seconds\": {best:e}, \"norm\": {norm:e}}}");
    Ok(())
}
