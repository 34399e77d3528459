//! Mixed-sensitivity design: `augw` builds the S/KS/T weighted generalized plant (MATLAB's augw),
//! `mixsyn` solves it with [`crate::hinfsyn`].
//!
//! With e = r − G·u the closed loop is z = [W1·S; W2·K·S; W3·T]·r for u = K·e, so K is a
//! negative-feedback controller in the skyloop convention (u = C·(r − y), C = K).

use crate::error::Result;
use crate::error::RobustError;
use crate::hinfsyn::{hinfsyn_with, HinfOptions, HinfSolution};
use skyloop_lti::{Mat, StateSpace};

/// Augmented plant P = [W1, −W1·G; 0, W2; 0, W3·G; I, −G] with inputs [w; u] and outputs
/// [z1; z2; z3; e]; a missing weight drops its output block. Weights must be proper and delay free.
pub fn augw(
    g: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    w3: Option<&StateSpace>,
) -> Result<StateSpace> {
    g.validate()?;
    if g.has_delay() {
        return Err(RobustError::Unsupported(
            "augw needs a rational plant: replace the delays by Padé approximants first".into(),
        ));
    }
    let (ny, nu) = (g.ny(), g.nu());
    // An absent weight is a gain with no outputs but the right number of inputs, so every block
    // product below keeps consistent shapes.
    let absent = [
        StateSpace::gain(Mat::zeros(0, ny), g.dt)?,
        StateSpace::gain(Mat::zeros(0, nu), g.dt)?,
        StateSpace::gain(Mat::zeros(0, ny), g.dt)?,
    ];
    let mut ws = Vec::new();
    for (k, (w, name, nin)) in [(w1, "W1", ny), (w2, "W2", nu), (w3, "W3", ny)].into_iter().enumerate() {
        let w = match w {
            Some(w) => {
                w.validate()?;
                if w.nu() != nin {
                    return Err(RobustError::Dimension(format!(
                        "{name} must have {nin} inputs, has {}",
                        w.nu()
                    )));
                }
                if w.dt != g.dt {
                    return Err(RobustError::InvalidArgument(format!(
                        "{name} has sample time {} but the plant has {}",
                        w.dt, g.dt
                    )));
                }
                if w.has_delay() {
                    return Err(RobustError::Unsupported(format!(
                        "{name} has a delay; weights must be rational"
                    )));
                }
                w
            }
            None => &absent[k],
        };
        ws.push(w);
    }
    if ws.iter().all(|w| w.ny() == 0) {
        return Err(RobustError::InvalidArgument("augw needs at least one weight".into()));
    }
    let (w1, w2, w3) = (ws[0], ws[1], ws[2]);
    let (ng, n1, n2, n3) = (g.nx(), w1.nx(), w2.nx(), w3.nx());
    let (o1, o2, o3) = (w1.ny(), w2.ny(), w3.ny());
    let n = ng + n1 + n2 + n3;
    let (i1, i2, i3) = (ng, ng + n1, ng + n1 + n2);
    let nout = o1 + o2 + o3 + ny;
    let nin = ny + nu;
    let mut a = Mat::<f64>::zeros(n, n);
    let mut b = Mat::<f64>::zeros(n, nin);
    let mut c = Mat::<f64>::zeros(nout, n);
    let mut d = Mat::<f64>::zeros(nout, nin);
    let w1_b = w1.b.as_ref();
    let w3_b = w3.b.as_ref();

    // Plant states: ẋg = Ag xg + Bg u.
    a.get_mut(..ng, ..ng).copy_from(&g.a);
    b.get_mut(..ng, ny..).copy_from(&g.b);
    // W1 is driven by e = w − Cg xg − Dg u.
    a.get_mut(i1..i2, i1..i2).copy_from(&w1.a);
    a.get_mut(i1..i2, ..ng).copy_from(-(w1_b * &g.c));
    b.get_mut(i1..i2, ..ny).copy_from(w1_b);
    b.get_mut(i1..i2, ny..).copy_from(-(w1_b * &g.d));
    // W2 is driven by u.
    a.get_mut(i2..i3, i2..i3).copy_from(&w2.a);
    b.get_mut(i2..i3, ny..).copy_from(&w2.b);
    // W3 is driven by G·u = Cg xg + Dg u.
    a.get_mut(i3.., i3..).copy_from(&w3.a);
    a.get_mut(i3.., ..ng).copy_from(w3_b * &g.c);
    b.get_mut(i3.., ny..).copy_from(w3_b * &g.d);

    // z1 = C1 x1 + D1 e.
    c.get_mut(..o1, i1..i2).copy_from(&w1.c);
    c.get_mut(..o1, ..ng).copy_from(-(&w1.d * &g.c));
    d.get_mut(..o1, ..ny).copy_from(&w1.d);
    d.get_mut(..o1, ny..).copy_from(-(&w1.d * &g.d));
    // z2 = C2 x2 + D2 u.
    c.get_mut(o1..o1 + o2, i2..i3).copy_from(&w2.c);
    d.get_mut(o1..o1 + o2, ny..).copy_from(&w2.d);
    // z3 = C3 x3 + D3 (Cg xg + Dg u).
    let r3 = o1 + o2..o1 + o2 + o3;
    c.get_mut(r3.clone(), i3..).copy_from(&w3.c);
    c.get_mut(r3.clone(), ..ng).copy_from(&w3.d * &g.c);
    d.get_mut(r3, ny..).copy_from(&w3.d * &g.d);
    // e = w − Cg xg − Dg u.
    let re = o1 + o2 + o3..nout;
    c.get_mut(re.clone(), ..ng).copy_from(-&g.c);
    d.get_mut(re.clone(), ..ny).copy_from(Mat::<f64>::identity(ny, ny));
    d.get_mut(re, ny..).copy_from(-&g.d);
    Ok(StateSpace::new(a, b, c, d, g.dt)?)
}

/// Mixed-sensitivity H∞ design: K minimizing ‖[W1·S; W2·K·S; W3·T]‖∞, for u = K·(r − y).
///
/// # Errors
/// Weights of the wrong size, or the H∞ synthesis of the augmented plant failing (see `hinfsyn`).
///
/// # Examples
/// ```
/// use skyloop_lti::expr::parse_model;
/// use skyloop_robust::{hinfsyn::HinfOptions, mixsyn::mixsyn};
/// // S-weight with integral action and a bounded control effort on a first-order plant.
/// let g = parse_model("10/(s+1)")?;
/// let ws = parse_model("(0.5*s+2)/(s+0.02)")?;
/// let wks = parse_model("0.1")?;
/// let sol = mixsyn(&g, Some(&ws), Some(&wks), None, &HinfOptions::default())?;
/// assert!(sol.gamma.is_finite() && sol.gamma > 0.0);
/// // The verified closed loop meets the γ it reports.
/// assert!(sol.closed_loop_norm <= sol.gamma * (1.0 + 1e-6));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn mixsyn(
    g: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    w3: Option<&StateSpace>,
    opts: &HinfOptions,
) -> Result<HinfSolution> {
    let p = augw(g, w1, w2, w3)?;
    hinfsyn_with(&p, g.ny(), g.nu(), opts)
}
