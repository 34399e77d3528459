//! Nonlinear closed-loop runs of the example scenarios.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

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

#[test]
fn bicopter_hinf_holds_roll_step_with_pendulum() {
    let scn = example("bicopter-hinf.toml");
    let (trace, m) = simulate(&scn).expect("runs");
    assert!(!m.crashed);
    let late: Vec<f64> = trace.iter().filter(|s| s.t >= 4.0).map(|s| s.euler[0]).collect();
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    // the 0.1 rad step is held on average while the 0.5 Hz pendulum rocks the vehicle
    assert!((mean - 0.1).abs() < 0.02, "mean roll {mean}");
    assert!(m.max_abs_error < 0.25, "{m:?}");
}

#[test]
fn allocation_signs_match_the_models() {
    use skyloop_sim::rigid::{External, AUX, MAXS, RATE};
    for name in skyloop_sim::presets::NAMES {
        let v = skyloop_sim::presets::vehicle(name).expect("p").build().expect("v");
        let (x0, _) = v.trim_hover(5.0, 0.0);
        for axis in 0..3 {
            let mut tq = [0.0; 3];
            tq[axis] = 0.002;
            let mut u = [0.0; skyloop_sim::rigid::MAXU];
            v.allocate(&x0, v.body().mass_kg * skyloop_sim::rigid::G, tq, &mut u);
            // actuators at their commanded steady state
            let mut x = x0;
            match &v {
                skyloop_sim::Vehicle::DuctedFan(_) => {
                    x[AUX..AUX + 4].copy_from_slice(&u[..4]);
                }
                skyloop_sim::Vehicle::Bicopter(b) => {
                    x[AUX] = b.p.servo_gain * u[2];
                    x[AUX + 1] = b.p.servo_gain * u[3];
                    x[AUX + 2] = u[0];
                    x[AUX + 3] = u[1];
                }
                skyloop_sim::Vehicle::Quadrotor(q) => {
                    for i in 0..4 {
                        x[AUX + i] = q.p.km_rad_s * (u[i] - q.p.delta_star);
                    }
                }
            }
            let mut dx = [0.0; MAXS];
            v.derivative(&x, &u, &External::default(), &mut dx);
            let j = v.inertia()[axis];
            let mom = if matches!(v, skyloop_sim::Vehicle::Bicopter(_)) && axis == 0 {
                dx[RATE]
            } else {
                dx[RATE + axis] * j
            };
            assert!((mom - 0.002).abs() < 2e-4, "{name} axis {axis}: torque {mom}");
        }
    }
}
