//! `skyloop augw P [--w1 W1] [--w2 W2] [--w3 W3] --out plant.json`: the generalized plant of the
//! S/KS/T mixed-sensitivity problem (MATLAB augw) as LTI JSON for `hinfsyn`, with its nmeas and
//! ncon printed (thin: load, call skyloop::robust::mixsyn::augw, write).

use skyloop::model::load_model;

/// Arguments of `skyloop augw`.
#[derive(clap::Args)]
pub struct Args {
    /// The plant G (rational: replace delays with `skyloop pade` first).
    #[arg(allow_hyphen_values = true)]
    plant: String,
    /// Weight on the sensitivity S (performance), e.g. "(s/2+6.28)/(s+6.28e-3)".
    #[arg(long, allow_hyphen_values = true)]
    w1: Option<String>,
    /// Weight on K·S (control effort).
    #[arg(long, allow_hyphen_values = true)]
    w2: Option<String>,
    /// Weight on T (robustness, noise).
    #[arg(long, allow_hyphen_values = true)]
    w3: Option<String>,
    /// Write the generalized plant as LTI JSON here.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Builds the plant and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    if a.w1.is_none() && a.w2.is_none() && a.w3.is_none() {
        return Err("augw needs at least one of --w1, --w2, --w3".into());
    }
    let g = load_model(&a.plant)?;
    let load = |w: &Option<String>| w.as_deref().map(load_model).transpose();
    let (w1, w2, w3) = (load(&a.w1)?, load(&a.w2)?, load(&a.w3)?);
    let p = skyloop::robust::mixsyn::augw(&g, w1.as_ref(), w2.as_ref(), w3.as_ref())?;
    let text = serde_json::to_string_pretty(&skyloop::lti::json::LtiJson::from_ss(&p))
        .map_err(|e| skyloop::Error::Input(e.to_string()))?;
    std::fs::write(&a.out, text + "\n").map_err(|e| skyloop::Error::write(&a.out, e))?;
    let (nmeas, ncon) = (g.ny(), g.nu());
    println!(
        "generalized plant: {} states, {} outputs (z: {}, y: {nmeas}), {} inputs (w: {}, u: {ncon})",
        p.nx(),
        p.ny(),
        p.ny() - nmeas,
        p.nu(),
        p.nu() - ncon
    );
    println!("nmeas = {nmeas}, ncon = {ncon}");
    println!(
        "next: skyloop hinfsyn {} --nmeas {nmeas} --ncon {ncon} --out K.json",
        a.out.display()
    );
    Ok(())
}
