//! Printing a list of poles or zeros: `{"re":[..],"im":[..]}` or a table.

use crate::output;
use skyloop::lti::c64;

/// Prints roots as JSON or as a table with natural frequency and damping.
pub fn print_roots(what: &str, roots: &[c64], dt: f64, json: bool) -> skyloop::Result<()> {
    if json {
        let v = serde_json::json!({
            "re": roots.iter().map(|z| z.re).collect::<Vec<_>>(),
            "im": roots.iter().map(|z| z.im).collect::<Vec<_>>(),
        });
        return output::print_json(&v);
    }
    if roots.is_empty() {
        println!("no finite {what}");
        return Ok(());
    }
    println!("{:>16} {:>16} {:>14} {:>10}", "re", "im", "freq_hz", "damping");
    for z in roots {
        // Natural frequency and damping of the continuous-time equivalent (z = e^{s·dt} when discrete).
        let s = if dt > 0.0 { z.ln() / dt } else { *z };
        let wn = s.norm();
        let zeta = if wn > 0.0 { -s.re / wn } else { f64::NAN };
        // Bounded width (skyloop::lti::display::Num): a pole at 1e300 prints as 1e300, not 301 digits.
        let hz = skyloop::lti::display::Num(wn / (2.0 * std::f64::consts::PI)).to_string();
        println!("{:>16.8e} {:>16.8e} {:>14} {:>10.4}", z.re, z.im, hz, zeta);
    }
    Ok(())
}
