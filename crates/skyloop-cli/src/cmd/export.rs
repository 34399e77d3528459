//! `skyloop export CONTROLLER --dt T --c FILE.h`: a self-contained C header (coefficients + step
//! function with output limits and Hanus anti-windup) for PX4/Betaflight-style firmware.

use skyloop::export::c_header::controller_header;
use std::path::PathBuf;

/// Arguments of `skyloop export`.
#[derive(clap::Args)]
pub struct Args {
    /// Controller: LTI JSON file or transfer-function expression (continuous → Tustin at --dt).
    controller: String,
    /// Sample time of the flight-controller loop (s).
    #[arg(long)]
    dt: f64,
    /// Output C header path.
    #[arg(long = "c")]
    c_file: PathBuf,
    /// C identifier prefix.
    #[arg(long, default_value = "skyloop_ctrl")]
    name: String,
    /// Use double instead of float.
    #[arg(long)]
    double: bool,
    /// Lower output limit (one value for all outputs).
    #[arg(long, default_value_t = -1e30, allow_hyphen_values = true)]
    u_min: f64,
    /// Upper output limit.
    #[arg(long, default_value_t = 1e30, allow_hyphen_values = true)]
    u_max: f64,
}

/// Discretizes and writes the header.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.controller)?;
    let ty = if a.double { "double" } else { "float" };
    let (text, d) = controller_header(&sys, a.dt, &a.name, ty, a.u_min, a.u_max, &a.controller)?;
    let limited = a.u_min.is_finite() || a.u_max.is_finite();
    if let Some(w) = skyloop::export::c_header::anti_windup_warning(&d).filter(|_| limited) {
        eprintln!("warning: {w}");
    }
    std::fs::write(&a.c_file, text).map_err(|e| skyloop::Error::write(&a.c_file, e))?;
    println!("wrote {} ({} states, dt = {} s)", a.c_file.display(), d.nx(), d.dt);
    Ok(())
}
