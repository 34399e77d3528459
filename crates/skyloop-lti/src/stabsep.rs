//! Additive stable/unstable decomposition G = Gs + Gu by an ordered real Schur form of A and one
//! Sylvester equation that decouples the two diagonal blocks (the method of Safonov, Jonckheere,
//! Verma and Limebeer, also behind SLICOT AB09MD's treatment of unstable systems).

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::{c64, Mat};
use skyloop_linalg::schur::{real_schur, reorder_schur, Schur};
use skyloop_linalg::sylvester::{solve_quasi_triangular, Kind};

/// Relative margin that keeps poles on (or within rounding of) the stability boundary in the
/// unstable part: an exact integrator computed as −1e−17 must not be "reduced".
const BOUNDARY_MARGIN: f64 = 1.5e-8;

/// True for a pole that belongs to the stable part: Re λ < −margin·max(1, |λ|) in continuous time,
/// |λ| < 1 − margin in discrete time.
pub fn is_stable_pole(lambda: c64, dt: f64) -> bool {
    if dt > 0.0 {
        lambda.norm() < 1.0 - BOUNDARY_MARGIN
    } else {
        lambda.re < -BOUNDARY_MARGIN * lambda.norm().max(1.0)
    }
}

/// Splits a model into G = Gs + Gu with all poles of Gs stable and all of Gu on or beyond the
/// stability boundary; Gs keeps D, Gu has D = 0, both keep the model's delays and sample time.
pub fn stabsep(sys: &StateSpace) -> Result<(StateSpace, StateSpace)> {
    sys.validate()?;
    let s = real_schur(sys.a.as_ref())?;
    split(sys, s)
}

fn split(sys: &StateSpace, mut s: Schur) -> Result<(StateSpace, StateSpace)> {
    let n = sys.nx();
    let dt = sys.dt;
    let ns = reorder_schur(&mut s, |l| is_stable_pole(l, dt))?;
    let nu = n - ns;
    // With A = Q·[T11 T12; 0 T22]·Qᵀ, the similarity [I X; 0 I] with T11·X − X·T22 = −T12
    // makes the state matrix block diagonal; λ(T11) and λ(T22) are disjoint by construction.
    let t11 = s.t.get(..ns, ..ns);
    let t22neg = Mat::from_fn(nu, nu, |i, j| -s.t[(ns + i, ns + j)]);
    let t12neg = Mat::from_fn(ns, nu, |i, j| -s.t[(i, ns + j)]);
    let x = solve_quasi_triangular(t11, t22neg.as_ref(), t12neg.as_ref(), Kind::Continuous)
        .map_err(|e| LtiError::Numerical(format!("cannot decouple the stable and unstable parts: {e}")))?;
    let qb = s.q.transpose() * &sys.b;
    let cq = &sys.c * &s.q;
    let (ny, nuu) = (sys.ny(), sys.nu());
    let b2 = qb.get(ns.., ..).to_owned();
    let bs = qb.get(..ns, ..) - &x * &b2;
    let c1 = cq.get(.., ..ns).to_owned();
    let cu = &c1 * &x + cq.get(.., ns..);
    let stable = StateSpace::new(t11.to_owned(), bs, c1, sys.d.clone(), dt)?
        .with_delays(sys.input_delay.clone(), sys.output_delay.clone())?;
    let unstable = StateSpace::new(s.t.get(ns.., ns..).to_owned(), b2, cu, Mat::zeros(ny, nuu), dt)?
        .with_delays(sys.input_delay.clone(), sys.output_delay.clone())?;
    Ok((stable, unstable))
}

/// The stable part, the unstable part and the real Schur form of the stable part's A, computing
/// the Schur form of A only once (a stable model is returned unchanged with an empty Gu).
pub(crate) fn split_with_schur(sys: &StateSpace) -> Result<(StateSpace, StateSpace, Schur)> {
    sys.validate()?;
    let s = real_schur(sys.a.as_ref())?;
    if s.eigenvalues().iter().all(|&l| is_stable_pole(l, sys.dt)) {
        let empty = StateSpace::new(
            Mat::zeros(0, 0),
            Mat::zeros(0, sys.nu()),
            Mat::zeros(sys.ny(), 0),
            Mat::zeros(sys.ny(), sys.nu()),
            sys.dt,
        )?
        .with_delays(sys.input_delay.clone(), sys.output_delay.clone())?;
        return Ok((sys.clone(), empty, s));
    }
    let (gs, gu) = split(sys, s)?;
    let n = gs.nx();
    // The stable part's A is the leading block of an ordered Schur form: its own Schur form.
    let ss = Schur {
        t: gs.a.clone(),
        q: Mat::identity(n, n),
    };
    Ok((gs, gu, ss))
}

/// The parallel connection Gs + Gu of two models with the same inputs, outputs, sample time and
/// delays (block-diagonal state matrix), used to put a reduced stable part back together with the
/// unstable part it was split from.
pub(crate) fn add_parts(gs: &StateSpace, gu: &StateSpace) -> Result<StateSpace> {
    let (n1, n2) = (gs.nx(), gu.nx());
    let n = n1 + n2;
    let a = Mat::from_fn(n, n, |i, j| match (i < n1, j < n1) {
        (true, true) => gs.a[(i, j)],
        (false, false) => gu.a[(i - n1, j - n1)],
        _ => 0.0,
    });
    let b = Mat::from_fn(n, gs.nu(), |i, j| if i < n1 { gs.b[(i, j)] } else { gu.b[(i - n1, j)] });
    let c = Mat::from_fn(gs.ny(), n, |i, j| if j < n1 { gs.c[(i, j)] } else { gu.c[(i, j - n1)] });
    let d = &gs.d + &gu.d;
    StateSpace::new(a, b, c, d, gs.dt)?.with_delays(gs.input_delay.clone(), gs.output_delay.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::freqresp::freqresp;
    use faer::linalg::solvers::DenseSolveCore;

    #[test]
    fn parts_add_up_and_separate_the_poles() {
        // Poles −1, −2 ± 1j, 0.5 and an integrator mixed by a non-orthogonal similarity.
        let a0 = [
            [-1.0, 0.3, 0.0, 0.2, 0.1],
            [0.0, -2.0, 1.0, 0.0, 0.4],
            [0.0, -1.0, -2.0, 0.3, 0.0],
            [0.0, 0.0, 0.0, 0.5, 1.0],
            [0.0, 0.0, 0.0, 0.0, 0.0],
        ];
        let t = Mat::from_fn(5, 5, |i, j| {
            if i == j {
                2.0
            } else {
                ((i * 3 + j * 7) % 5) as f64 * 0.2 - 0.4
            }
        });
        let ti = t.as_ref().partial_piv_lu().inverse();
        let a = &ti * Mat::from_fn(5, 5, |i, j| a0[i][j]) * &t;
        let b = Mat::from_fn(5, 2, |i, j| ((i + 2 * j) % 3) as f64 - 0.7);
        let c = Mat::from_fn(1, 5, |_, j| 1.0 - 0.3 * j as f64);
        let sys = StateSpace::new(a, b, c, Mat::from_fn(1, 2, |_, j| j as f64), 0.0).unwrap();
        let (gs, gu) = stabsep(&sys).unwrap();
        assert_eq!((gs.nx(), gu.nx()), (3, 2));
        let sum = add_parts(&gs, &gu).unwrap();
        let w = [0.01, 0.3, 1.0, 7.0, 100.0];
        let (g0, g1) = (freqresp(&sys, &w).unwrap(), freqresp(&sum, &w).unwrap());
        for (x, y) in g0.iter().zip(&g1) {
            assert!((x - y).norm_l2() <= 1e-10 * x.norm_l2());
        }
        let ev = real_schur(gs.a.as_ref()).unwrap().eigenvalues();
        assert!(ev.iter().all(|&l| l.re < -0.5));
    }
}
