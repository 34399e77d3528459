//! Nonlinear closed-loop runs of the example scenarios.

use skyloop_sim::{simulate, Scenario};

fn example(name: &str) -> Scenario {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/");
    let text = std::fs::read_to_string(format!("{path}{name}")).expect("example exists");
    Scenario::from_toml(&text).expect("example parses")
}

#[test]
fn quadrotor_ssi_tracks_roll_step_and_rejects_gust() {
    let scn = example("quadrotor-ssi.toml");
    let (trace, m) = simulate(&scn).expect("runs");
    assert!(!m.crashed);
    let at = |t: f64| trace.iter().find(|s| s.t >= t).expect("sample");
    // before the gust (t = 6 s) the 0.2 rad step has settled (dominant pole ≈ −1.04 s⁻¹ ⇒ ~5 s)
    assert!((at(5.9).euler[0] - 0.2).abs() < 0.01, "{}", at(5.9).euler[0]);
    // the SSI integral removes the constant gust torque: back on 0.2 rad at the end
    assert!((trace.last().expect("last").euler[0] - 0.2).abs() < 0.01);
    println!("{m:?}");
}
