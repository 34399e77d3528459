//! Model reduction by balancing: Hankel singular values, balanced realization, balanced truncation
//! (square-root method) and singular perturbation approximation (Varga's balancing-free square-root
//! method, DC gain matched), with the additive error bound ‖G − Gr‖∞ ≤ 2·Σ discarded σ.
//!
//! Unstable models are split as G = Gs + Gu ([`crate::stabsep`]); Gu is kept exactly and only Gs
//! is reduced, as SLICOT AB09MD/AB09ND do.

mod sqrt;

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use crate::stabsep::{add_parts, split_with_schur};
use std::str::FromStr;

/// The reduction method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Balanced truncation, square-root method (SLICOT AB09AD, MATLAB balred 'Truncate').
    Balanced,
    /// Singular perturbation approximation, balancing-free square-root method (AB09BD/AB09ND,
    /// MATLAB balred 'MatchDC'); the reduced model has the DC gain of the original.
    Spa,
}

impl FromStr for Method {
    type Err = LtiError;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "balanced" | "truncate" | "bt" => Ok(Method::Balanced),
            "spa" | "matchdc" => Ok(Method::Spa),
            other => Err(LtiError::InvalidArgument(format!(
                "unknown reduction method '{other}' (expected balanced or spa)"
            ))),
        }
    }
}

/// A reduced model with what justifies it.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// The reduced model (unstable part kept exactly; same sample time and delays as the original).
    pub sys: StateSpace,
    /// Hankel singular values of the stable part of the original model, descending.
    pub hsv: Vec<f64>,
    /// 2·Σ of the discarded Hankel singular values: a bound on ‖G − Gr‖∞.
    pub error_bound: f64,
    /// Number of unstable (kept) states.
    pub n_unstable: usize,
}

/// Hankel singular values of the stable part of the model, descending (unstable poles, which have
/// no finite Hankel singular value, are left out as in SLICOT AB13AD).
pub fn hsvd(sys: &StateSpace) -> Result<Vec<f64>> {
    let (gs, _gu, schur) = split_with_schur(sys)?;
    Ok(sqrt::SquareRoot::new(&gs, &schur)?.hsv)
}

/// The balanced realization of a stable model (P = Q = diag(σ)), with its Hankel singular values;
/// states with σ ≤ n·ε·σ₁ (uncontrollable or unobservable to working precision) are removed.
pub fn balreal(sys: &StateSpace) -> Result<(StateSpace, Vec<f64>)> {
    let (gs, gu, schur) = split_with_schur(sys)?;
    if gu.nx() > 0 {
        return Err(LtiError::Unsupported(format!(
            "balreal needs a stable model; this one has {} unstable poles (use balred, which keeps them)",
            gu.nx()
        )));
    }
    let sr = sqrt::SquareRoot::new(&gs, &schur)?;
    let r = sr.minimal_order();
    Ok((sr.truncate(&gs, r)?, sr.hsv))
}

/// Reduces a model to `order` states: the unstable part is kept, the stable part is reduced by
/// `method`. An order above the minimal order of the stable part gives that minimal order.
///
/// # Errors
/// A discrete or delayed model, or Lyapunov equations that cannot be solved.
///
/// # Examples
/// ```
/// use skyloop_lti::reduce::{balred, Method};
/// // Two well-separated modes: truncating the fast one leaves the DC gain within the bound 2·σ₂.
/// let g = skyloop_lti::expr::parse_model("10/((s+1)*(s+100))")?;
/// let r = balred(&g, 1, Method::Balanced)?;
/// assert_eq!(r.sys.nx(), 1);
/// let dc = |s: &skyloop_lti::StateSpace| skyloop_lti::poles_zeros::dcgain(s).map(|m| m[(0, 0)]);
/// assert!((dc(&r.sys)? - dc(&g)?).abs() <= r.error_bound + 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn balred(sys: &StateSpace, order: usize, method: Method) -> Result<Reduced> {
    let (gs, gu, schur) = split_with_schur(sys)?;
    let nu = gu.nx();
    if order < nu {
        return Err(LtiError::InvalidArgument(format!(
            "order {order} is below the number of unstable poles ({nu}), which are always kept"
        )));
    }
    if order > sys.nx() {
        return Err(LtiError::InvalidArgument(format!(
            "order {order} exceeds the model order {}",
            sys.nx()
        )));
    }
    let sr = sqrt::SquareRoot::new(&gs, &schur)?;
    let r = (order - nu).min(sr.minimal_order());
    let reduced = match method {
        Method::Balanced => sr.truncate(&gs, r)?,
        Method::Spa => sr.singular_perturbation(&gs, r)?,
    };
    let error_bound = 2.0 * sr.hsv[r..].iter().sum::<f64>();
    let sys_r = if nu > 0 { add_parts(&reduced, &gu)? } else { reduced };
    Ok(Reduced {
        sys: sys_r,
        hsv: sr.hsv,
        error_bound,
        n_unstable: nu,
    })
}
