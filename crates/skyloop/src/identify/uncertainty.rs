//! Honest uncertainty from the data themselves: a delete-one-block jackknife over the record
//! (Efron & Tibshirani, An Introduction to the Bootstrap, ch. 11) gives an empirical spread that
//! includes what the model-based error leaves out (drift between parts of a flight, nonlinearity,
//! errors of the model's form), and a held-out validation predicts blocks the fit did not see.

use std::collections::BTreeMap;

use serde::Serialize;

/// Standard errors of the fitted parameters, by source.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Uncertainty {
    /// From the fit's Jacobian and the FRF's own variance (correlated residuals accounted for).
    pub model_stderr: BTreeMap<String, f64>,
    /// Delete-one-block jackknife: √((m−1)/m · Σ(θ₋ᵢ − θ̄)²) over the m blocks whose refit succeeded.
    pub jackknife_stderr: BTreeMap<String, f64>,
    /// Blocks the record was split into.
    pub blocks: usize,
    /// Blocks whose leave-one-out refit succeeded (the jackknife's m).
    pub blocks_used: usize,
}

/// A fit to part of the data judged on the rest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// Blocks fitted (0-based, in time order over the segments).
    pub train_blocks: Vec<usize>,
    /// Blocks predicted.
    pub test_blocks: Vec<usize>,
    /// Fit percentage of the training fit on its own FRF.
    pub train_fit_percent: f64,
    /// Fit percentage of the training fit's model on the held-out blocks' FRF, percent.
    pub fit_percent: f64,
    /// RMS log error |ln(G_model/G_heldout)| over the held-out FRF's fitted band (dimensionless; 0.1
    /// is about 0.9 dB or 5.7°).
    pub frf_residual: f64,
    /// The training model's share of the held-out FRF's variation in log magnitude and phase, each
    /// point weighted by its inverse variance as in the fit, percent (what the refusal judges: the
    /// unweighted `fit_percent` is dominated by the largest, lowest-frequency points, where the
    /// pilot's loop biases the instrument most).
    pub weighted_fit_percent: f64,
}

/// Delete-one jackknife standard error of each parameter over leave-one-out estimates.
pub(crate) fn jackknife(estimates: &[BTreeMap<String, f64>]) -> BTreeMap<String, f64> {
    let m = estimates.len() as f64;
    let mut out = BTreeMap::new();
    let Some(first) = estimates.first() else { return out };
    for k in first.keys() {
        let v: Vec<f64> = estimates.iter().filter_map(|e| e.get(k).copied()).collect();
        let mean = v.iter().sum::<f64>() / m;
        let ss: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
        out.insert(k.clone(), ((m - 1.0) / m * ss).sqrt());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The jackknife of a sample mean is the usual standard error of the mean, s/√n.
    #[test]
    fn jackknife_of_a_mean_is_its_standard_error() {
        let x = [1.0, 4.0, 2.0, 8.0, 5.0, 7.0];
        let n = x.len() as f64;
        let loo: Vec<BTreeMap<String, f64>> = (0..x.len())
            .map(|i| {
                let m = x
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, v)| v)
                    .sum::<f64>()
                    / (n - 1.0);
                BTreeMap::from([("m".to_string(), m)])
            })
            .collect();
        let mean = x.iter().sum::<f64>() / n;
        let s = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!((jackknife(&loo)["m"] - s / n.sqrt()).abs() < 1e-12);
    }
}
