//! Linear-model manipulations for analysing the simulated vehicles: virtual inputs through the
//! allocation, residualization of fast actuator states, and the SSI-PI attitude loop of eq. (32).

use crate::error::{Result, SimError};
use crate::linearize::Linearization;
use crate::rigid::{Input, State};
use crate::vehicle::Vehicle;
use faer::Mat;
use skyloop_lti::StateSpace;

/// Replaces the actuator inputs by [thrust_n, mx_n_m, my_n_m, mz_n_m] through the vehicle's allocation,
/// linearized by central differences at the trim point. Input delays become the largest actuator delay
/// feeding each virtual input.
pub fn virtual_inputs(v: &Vehicle, x0: &State, trim_thrust_n: f64, lin: &Linearization) -> Result<Linearization> {
    let nu = v.nu();
    let mut du = Mat::<f64>::zeros(nu, 4);
    let alloc = |k: usize, h: f64| -> Input {
        let mut w = [trim_thrust_n, 0.0, 0.0, 0.0];
        w[k] += h;
        let mut u = [0.0; crate::rigid::MAXU];
        v.allocate(x0, w[0], [w[1], w[2], w[3]], &mut u);
        u
    };
    for k in 0..4 {
        let h = 1e-6 * if k == 0 { trim_thrust_n.abs().max(1.0) } else { 1.0 };
        let (up, um) = (alloc(k, h), alloc(k, -h));
        for i in 0..nu {
            du[(i, k)] = (up[i] - um[i]) / (2.0 * h);
        }
    }
    let ss = &lin.ss;
    let b = &ss.b * &du;
    let d = &ss.d * &du;
    let mut delays = vec![0.0; 4];
    for (k, dl) in delays.iter_mut().enumerate() {
        for i in 0..nu {
            if du[(i, k)].abs() > 1e-12 {
                *dl = f64::max(*dl, ss.input_delay.get(i).copied().unwrap_or(0.0));
            }
        }
    }
    let out = StateSpace::new(ss.a.clone(), b, ss.c.clone(), d, 0.0)?.with_delays(delays, ss.output_delay.clone())?;
    Ok(Linearization {
        ss: out,
        states: lin.states.clone(),
        inputs: vec!["thrust_n".into(), "mx_n_m".into(), "my_n_m".into(), "mz_n_m".into()],
        outputs: lin.outputs.clone(),
    })
}

/// Singular-perturbation reduction: the named (fast) states are set to their quasi-steady values,
/// A₁₁ − A₁₂A₂₂⁻¹A₂₁ etc. Outputs that are the removed states are dropped as well.
pub fn residualize(lin: &Linearization, fast: &[&str]) -> Result<Linearization> {
    let ss = &lin.ss;
    let n = ss.nx();
    let mut f_idx = Vec::new();
    for name in fast {
        let i = lin
            .states
            .iter()
            .position(|s| s == name)
            .ok_or_else(|| SimError::Param(format!("no state '{name}' to residualize")))?;
        f_idx.push(i);
    }
    let s_idx: Vec<usize> = (0..n).filter(|i| !f_idx.contains(i)).collect();
    let pick = |m: &Mat<f64>, r: &[usize], c: &[usize]| Mat::<f64>::from_fn(r.len(), c.len(), |i, j| m[(r[i], c[j])]);
    let all_u: Vec<usize> = (0..ss.nu()).collect();
    let a11 = pick(&ss.a, &s_idx, &s_idx);
    let a12 = pick(&ss.a, &s_idx, &f_idx);
    let a21 = pick(&ss.a, &f_idx, &s_idx);
    let a22 = pick(&ss.a, &f_idx, &f_idx);
    let b1 = pick(&ss.b, &s_idx, &all_u);
    let b2 = pick(&ss.b, &f_idx, &all_u);
    let lu = a22.partial_piv_lu();
    let x21 = faer::linalg::solvers::Solve::solve(&lu, &a21);
    let x2b = faer::linalg::solvers::Solve::solve(&lu, &b2);
    if x21
        .col_iter()
        .flat_map(|c| c.iter().copied().collect::<Vec<_>>())
        .any(|v: f64| !v.is_finite())
    {
        return Err(SimError::Param("fast states are singular (A22 not invertible)".into()));
    }
    let keep_y: Vec<usize> = (0..ss.ny())
        .filter(|&i| !fast.contains(&lin.outputs[i].as_str()))
        .collect();
    let c1 = pick(&ss.c, &keep_y, &s_idx);
    let c2 = pick(&ss.c, &keep_y, &f_idx);
    let d = pick(&ss.d, &keep_y, &all_u);
    let a = &a11 - &a12 * &x21;
    let b = &b1 - &a12 * &x2b;
    let c = &c1 - &c2 * &x21;
    let dd = &d - &c2 * &x2b;
    let out = StateSpace::new(a, b, c, dd, 0.0)?.with_delays(ss.input_delay.clone(), vec![0.0; keep_y.len()])?;
    Ok(Linearization {
        ss: out,
        states: s_idx.iter().map(|&i| lin.states[i].clone()).collect(),
        inputs: lin.inputs.clone(),
        outputs: keep_y.iter().map(|&i| lin.outputs[i].clone()).collect(),
    })
}

/// SSI-PI parameters for closing one attitude axis: u = Kp·e + Ki·Kp·∫e − Ki·Jm·ω, e = k·(θr − θ) − ω.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsiLoop {
    /// Kp (N·m per rad/s).
    pub kp: f64,
    /// Ki (1/s).
    pub ki: f64,
    /// Jm (kg·m²).
    pub jm: f64,
    /// Attitude P gain k (1/s); the paper's eq. (32) has k = 1.
    pub k_att: f64,
}

/// Closes the SSI-PI attitude loop around one axis of a linear model with a moment input.
/// Returns the closed loop with inputs [θr, disturbance torque T] and outputs [θ, ω]; its last
/// state is the controller integral ∫e.
pub fn ssi_closed_loop(lin: &Linearization, angle: &str, rate: &str, moment: &str, c: SsiLoop) -> Result<StateSpace> {
    let ss = &lin.ss;
    let (ia, ir, im) = (lin.output(angle)?, lin.output(rate)?, lin.input(moment)?);
    for (i, name) in [(ia, angle), (ir, rate)] {
        if (0..ss.nu()).any(|j| ss.d[(i, j)].abs() > 1e-12) {
            return Err(SimError::Param(format!(
                "output {name} has a feedthrough; close the loop on states"
            )));
        }
    }
    let n = ss.nx();
    let mut a = Mat::<f64>::zeros(n + 1, n + 1);
    let mut b = Mat::<f64>::zeros(n + 1, 2);
    let mut cc = Mat::<f64>::zeros(2, n + 1);
    // e = k·θr − (k·Cθ + Cω)·x; u = Kp·e + Ki·Kp·z − Ki·Jm·Cω·x + T.
    for j in 0..n {
        let ce = -(c.k_att * ss.c[(ia, j)] + ss.c[(ir, j)]);
        let cu = c.kp * ce - c.ki * c.jm * ss.c[(ir, j)];
        for i in 0..n {
            a[(i, j)] = ss.a[(i, j)] + ss.b[(i, im)] * cu;
        }
        a[(n, j)] = ce;
        cc[(0, j)] = ss.c[(ia, j)];
        cc[(1, j)] = ss.c[(ir, j)];
    }
    for i in 0..n {
        a[(i, n)] = ss.b[(i, im)] * c.ki * c.kp;
        b[(i, 0)] = ss.b[(i, im)] * c.kp * c.k_att;
        b[(i, 1)] = ss.b[(i, im)];
    }
    b[(n, 0)] = c.k_att;
    Ok(StateSpace::new(a, b, cc, Mat::zeros(2, 2), 0.0)?)
}

/// Coefficients of eq. (32)'s characteristic polynomial, s³ + a2·s² + a1·s + a0 (descending, monic):
/// a2 = (Jm·Ki + Kp)/J, a1 = Kp·(Ki + 1)/J, a0 = Kp·Ki/J.
pub fn eq32_charpoly(j: f64, c: SsiLoop) -> [f64; 4] {
    [1.0, (c.jm * c.ki + c.kp) / j, c.kp * (c.ki + 1.0) / j, c.kp * c.ki / j]
}

/// Routh condition (35): the loop is stable iff Jm > J/(Ki + 1) − Kp/Ki (for Kp, Ki, J > 0).
pub fn routh_eq35(j: f64, c: SsiLoop) -> bool {
    c.jm > j / (c.ki + 1.0) - c.kp / c.ki
}

/// Keeps only the named states, inputs and outputs. Fails if a dropped state drives a kept state or
/// output (then truncation would change the dynamics).
pub fn subsystem(lin: &Linearization, states: &[&str], inputs: &[&str], outputs: &[&str]) -> Result<Linearization> {
    let ss = &lin.ss;
    let find = |names: &[String], n: &str, what: &str| {
        names
            .iter()
            .position(|s| s == n)
            .ok_or_else(|| SimError::Param(format!("no {what} '{n}'")))
    };
    let xs: Vec<usize> = states
        .iter()
        .map(|n| find(&lin.states, n, "state"))
        .collect::<Result<_>>()?;
    let us: Vec<usize> = inputs
        .iter()
        .map(|n| find(&lin.inputs, n, "input"))
        .collect::<Result<_>>()?;
    let ys: Vec<usize> = outputs
        .iter()
        .map(|n| find(&lin.outputs, n, "output"))
        .collect::<Result<_>>()?;
    let scale = ss.a.norm_max().max(1.0);
    for j in (0..ss.nx()).filter(|j| !xs.contains(j)) {
        let leak = xs
            .iter()
            .map(|&i| ss.a[(i, j)].abs())
            .chain(ys.iter().map(|&i| ss.c[(i, j)].abs()))
            .fold(0.0, f64::max);
        if leak > 1e-9 * scale {
            return Err(SimError::Param(format!(
                "dropped state '{}' drives the kept ones ({leak:e})",
                lin.states[j]
            )));
        }
    }
    let pick = |m: &Mat<f64>, r: &[usize], c: &[usize]| Mat::<f64>::from_fn(r.len(), c.len(), |i, j| m[(r[i], c[j])]);
    let out = StateSpace::new(
        pick(&ss.a, &xs, &xs),
        pick(&ss.b, &xs, &us),
        pick(&ss.c, &ys, &xs),
        pick(&ss.d, &ys, &us),
        0.0,
    )?
    .with_delays(
        us.iter()
            .map(|&i| ss.input_delay.get(i).copied().unwrap_or(0.0))
            .collect(),
        vec![0.0; ys.len()],
    )?;
    Ok(Linearization {
        ss: out,
        states: states.iter().map(|s| s.to_string()).collect(),
        inputs: inputs.iter().map(|s| s.to_string()).collect(),
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
    })
}

/// Splits a linearization into its actuators and the rigid body they drive, so that uncertainty or
/// filters can be inserted between them: `actuators` has the vehicle inputs and the `drive` states
/// (e.g. flap angles, propeller speed) as outputs; `body` has the `drive` signals as inputs and the
/// remaining states. `series(actuators, body)` reproduces the original model's outputs that do not
/// read actuator states. Fails if an actuator state depends on a body state, a body state is driven
/// directly by an input, or an actuator state other than `drive` feeds the body.
pub fn actuator_split(
    lin: &Linearization,
    actuator_states: &[&str],
    drive: &[&str],
) -> Result<(Linearization, Linearization)> {
    let ss = &lin.ss;
    let find = |n: &str| {
        lin.states
            .iter()
            .position(|s| s == n)
            .ok_or_else(|| SimError::Param(format!("no state '{n}'")))
    };
    let act: Vec<usize> = actuator_states.iter().map(|n| find(n)).collect::<Result<_>>()?;
    let drv: Vec<usize> = drive.iter().map(|n| find(n)).collect::<Result<_>>()?;
    if let Some(n) = drive.iter().zip(&drv).find(|(_, i)| !act.contains(i)) {
        return Err(SimError::Param(format!(
            "drive state '{}' is not an actuator state",
            n.0
        )));
    }
    let body: Vec<usize> = (0..ss.nx()).filter(|i| !act.contains(i)).collect();
    let tol = 1e-9 * ss.a.norm_max().max(ss.b.norm_max()).max(1.0);
    for &i in &act {
        if let Some(&j) = body.iter().find(|&&j| ss.a[(i, j)].abs() > tol) {
            return Err(SimError::Param(format!(
                "actuator state '{}' depends on body state '{}'",
                lin.states[i], lin.states[j]
            )));
        }
    }
    for &i in &body {
        if (0..ss.nu()).any(|k| ss.b[(i, k)].abs() > tol) {
            return Err(SimError::Param(format!(
                "body state '{}' is driven directly by an input",
                lin.states[i]
            )));
        }
        if let Some(&j) = act.iter().find(|&&j| !drv.contains(&j) && ss.a[(i, j)].abs() > tol) {
            return Err(SimError::Param(format!(
                "actuator state '{}' feeds the body but is not a drive signal",
                lin.states[j]
            )));
        }
    }
    // Body outputs are those that read no actuator state and have no feedthrough.
    let ys: Vec<usize> = (0..ss.ny())
        .filter(|&i| act.iter().all(|&j| ss.c[(i, j)].abs() <= tol) && (0..ss.nu()).all(|k| ss.d[(i, k)].abs() <= tol))
        .collect();
    let pick = |m: &Mat<f64>, r: &[usize], c: &[usize]| Mat::<f64>::from_fn(r.len(), c.len(), |i, j| m[(r[i], c[j])]);
    let all_u: Vec<usize> = (0..ss.nu()).collect();
    let a_act = pick(&ss.a, &act, &act);
    let c_act = Mat::<f64>::from_fn(drv.len(), act.len(), |i, j| f64::from(u8::from(drv[i] == act[j])));
    let actuators = StateSpace::new(
        a_act,
        pick(&ss.b, &act, &all_u),
        c_act,
        Mat::zeros(drv.len(), ss.nu()),
        0.0,
    )?
    .with_delays(ss.input_delay.clone(), vec![0.0; drv.len()])?;
    let body_ss = StateSpace::new(
        pick(&ss.a, &body, &body),
        pick(&ss.a, &body, &drv),
        pick(&ss.c, &ys, &body),
        Mat::zeros(ys.len(), drv.len()),
        0.0,
    )?;
    let names = |idx: &[usize], from: &[String]| idx.iter().map(|&i| from[i].clone()).collect::<Vec<_>>();
    Ok((
        Linearization {
            ss: actuators,
            states: names(&act, &lin.states),
            inputs: lin.inputs.clone(),
            outputs: names(&drv, &lin.states),
        },
        Linearization {
            ss: body_ss,
            states: names(&body, &lin.states),
            inputs: names(&drv, &lin.states),
            outputs: names(&ys, &lin.outputs),
        },
    ))
}

/// Eigenvalues of A (the poles of a state-space model), sorted by real part.
pub fn eigenvalues(a: &Mat<f64>) -> Result<Vec<num_complex::Complex<f64>>> {
    let mut e = a
        .eigenvalues()
        .map_err(|e| SimError::Param(format!("eigenvalues failed: {e:?}")))?;
    e.sort_by(|x, y| x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im)));
    Ok(e)
}

/// The quadrotor's roll axis at hover as [roll_rad, p_rad_s] driven by mx_n_m: the linearization
/// with virtual inputs and the motor states residualized (motors at steady state, as eq. (24) assumes).
pub fn quad_roll_axis(v: &Vehicle) -> Result<Linearization> {
    let (x0, u0) = v.trim_hover(10.0, 0.0);
    let lin = crate::linearize::linearize(v, &x0, &u0)?;
    let lv = virtual_inputs(v, &x0, v.body().mass_kg * crate::rigid::G, &lin)?;
    let (aux, _) = v.names();
    let fast: Vec<&str> = aux.iter().map(|s| s.as_str()).collect();
    let r = residualize(&lv, &fast)?;
    subsystem(&r, &["roll_rad", "p_rad_s"], &["mx_n_m"], &["roll_rad", "p_rad_s"])
}
