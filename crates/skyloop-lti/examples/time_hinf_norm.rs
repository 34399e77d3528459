//! Smallest thread CPU time of N calls of `hinf_norm` on an LTI JSON model, printed as JSON with
//! the norm, for `bench/compare.py` (which times SLICOT AB13DD on the same model the same way).
//! Run: `cargo run --release -p skyloop-lti --example time_hinf_norm -- MODEL.json [repeats]`.

use skyloop_fixtures::thread_cpu_seconds as now;

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
