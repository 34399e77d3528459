//! Negligible feedthrough: a D entry left at rounding level by a computation (singular
//! perturbation's D + C₂A₂₂⁻¹B₂ of a strictly proper model, say) is not dynamics, but it puts a
//! transmission zero where no zero is, at |CB|/|D| rad/s (3.4·10⁸ rad/s for the bicopter's reduced
//! controller), and it makes a strictly proper controller look biproper in its zpk form.

use crate::error::Result;
use crate::freqresp::{dynamics_range, freqresp, logspace};
use crate::ss::StateSpace;

/// A model with its negligible feedthrough entries set to zero, and what was dropped.
#[derive(Clone, Debug)]
pub struct Trimmed {
    /// The model, D entries found negligible set to 0 (everything else unchanged).
    pub sys: StateSpace,
    /// Each dropped entry: (output, input, the value dropped, its largest share of the response on
    /// the grid: max over ω of |D_ij| / |G_ij(jω) − D_ij|).
    pub dropped: Vec<(usize, usize, f64, f64)>,
    /// The top of the frequency grid the test used, rad/s.
    pub up_to_rad_s: f64,
}

/// Sets to zero each feedthrough entry D_ij of a continuous model that changes the response by at
/// most `rel` (relative) at every frequency from two decades below the slowest to two decades
/// above the fastest dynamics (400 log-spaced points): |D_ij| ≤ rel·|G_ij(jω) − D_ij|. A discrete
/// model, a model without states, or an entry that matters anywhere on the grid is kept as it is.
///
/// # Errors
/// A model whose frequency response cannot be evaluated.
///
/// ```
/// use skyloop_lti::{feedthrough::drop_negligible_feedthrough, expr::parse_model};
/// // 24/(s + 50) with a stray feedthrough of 1e-9 (a zero at 2.4e10 rad/s).
/// let g = parse_model("24/(s+50) + 1e-9").unwrap();
/// let t = drop_negligible_feedthrough(&g, 1e-4).unwrap();
/// assert_eq!(t.sys.d[(0, 0)], 0.0);
/// assert_eq!(t.dropped.len(), 1);
/// // A real feedthrough stays.
/// let h = parse_model("24/(s+50) + 0.1").unwrap();
/// assert!(drop_negligible_feedthrough(&h, 1e-4).unwrap().dropped.is_empty());
/// ```
pub fn drop_negligible_feedthrough(sys: &StateSpace, rel: f64) -> Result<Trimmed> {
    let mut out = Trimmed {
        sys: sys.clone(),
        dropped: Vec::new(),
        up_to_rad_s: 0.0,
    };
    let any = (0..sys.ny()).any(|i| (0..sys.nu()).any(|j| sys.d[(i, j)] != 0.0));
    if !sys.is_continuous() || sys.nx() == 0 || !any {
        return Ok(out);
    }
    let (lo, hi) = dynamics_range(sys)?;
    out.up_to_rad_s = 100.0 * hi;
    let grid = logspace((lo / 100.0).log10(), out.up_to_rad_s.log10(), 400);
    let resp = freqresp(sys, &grid)?;
    for i in 0..sys.ny() {
        for j in 0..sys.nu() {
            let d = sys.d[(i, j)];
            if d == 0.0 {
                continue;
            }
            let share = resp
                .iter()
                .map(|g| d.abs() / (g[(i, j)] - d).norm())
                .fold(0.0, f64::max);
            if share <= rel {
                out.sys.d[(i, j)] = 0.0;
                out.dropped.push((i, j, d, share));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;
    use crate::poles_zeros::zeros;

    #[test]
    fn a_stray_feedthrough_and_its_zero_at_infinity_go() {
        // Strictly proper with an integrator (as a controller), plus 7e-8.
        let g = parse_model("24*(s+54)*(s+0.25)/(s*(s^2+24*s+8544)) - 7e-8").unwrap();
        assert_eq!(zeros(&g).unwrap().len(), 3, "the stray D adds a zero");
        let t = drop_negligible_feedthrough(&g, 1e-4).unwrap();
        assert_eq!(t.dropped.len(), 1);
        assert!((t.dropped[0].2 + 7e-8).abs() < 1e-20);
        assert!(t.dropped[0].3 < 1e-4);
        assert_eq!(zeros(&t.sys).unwrap().len(), 2, "the zero at |CB|/|D| is gone");
    }

    #[test]
    fn a_feedthrough_that_matters_somewhere_stays() {
        // 1e-3 is small at low frequency but dominates above 24e3 rad/s, inside the grid.
        let g = parse_model("24/(s+50) + 1e-3").unwrap();
        assert!(drop_negligible_feedthrough(&g, 1e-4).unwrap().dropped.is_empty());
        // A discrete model is never trimmed.
        let z = crate::expr::parse_discrete("0.1/(z-0.9) + 1e-12", 0.01).unwrap();
        assert!(drop_negligible_feedthrough(&z, 1e-4).unwrap().dropped.is_empty());
    }
}
