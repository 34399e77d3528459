//! Maximum-length pseudo-random binary sequences from a Fibonacci linear-feedback shift register.

use super::{check_rate, Signal};
use crate::error::{invalid, Result};

/// Feedback taps (1-based register positions) of primitive polynomials giving period 2ⁿ − 1, for
/// register lengths n = 2..=20 (the table of Xilinx application note XAPP052; maximality is checked
/// by the unit test `every_order_has_maximal_period`).
const TAPS: [&[u32]; 19] = [
    &[2, 1],
    &[3, 2],
    &[4, 3],
    &[5, 3],
    &[6, 5],
    &[7, 6],
    &[8, 6, 5, 4],
    &[9, 5],
    &[10, 7],
    &[11, 9],
    &[12, 6, 4, 1],
    &[13, 4, 3, 1],
    &[14, 5, 3, 1],
    &[15, 14],
    &[16, 15, 13, 4],
    &[17, 14],
    &[18, 11],
    &[19, 6, 2, 1],
    &[20, 17],
];

/// A PRBS's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct PrbsSpec {
    /// Register length n (2..=20); one period has 2ⁿ − 1 bits.
    pub order: u32,
    /// Samples per bit (≥ 1): the bit rate is `rate_hz / samples_per_bit`, which sets the bandwidth.
    pub samples_per_bit: usize,
    /// Number of periods to generate (≥ 1).
    pub periods: usize,
    /// Output level is ±amplitude.
    pub amplitude: f64,
}

/// One period of the ±1 maximum-length sequence of register length `order`.
pub fn mls(order: u32) -> Result<Vec<f64>> {
    if !(2..=20).contains(&order) {
        return Err(invalid(format!("PRBS order must be within 2..=20, got {order}")));
    }
    let taps = TAPS[(order - 2) as usize];
    let n = order;
    let period = (1usize << n) - 1;
    let mut reg: u32 = 1;
    let mut out = Vec::with_capacity(period);
    for _ in 0..period {
        out.push(if reg & 1 == 1 { 1.0 } else { -1.0 });
        let bit = taps.iter().fold(0u32, |acc, &t| acc ^ ((reg >> (n - t)) & 1));
        reg = (reg >> 1) | (bit << (n - 1));
    }
    Ok(out)
}

/// Samples the PRBS at `rate_hz`: each bit held for `samples_per_bit` samples.
pub fn prbs(spec: &PrbsSpec, rate_hz: f64) -> Result<Signal> {
    check_rate(rate_hz)?;
    if spec.samples_per_bit == 0 || spec.periods == 0 {
        return Err(invalid("PRBS needs at least one sample per bit and one period"));
    }
    if !spec.amplitude.is_finite() {
        return Err(invalid("PRBS amplitude must be finite"));
    }
    let seq = mls(spec.order)?;
    let total = (seq.len() as f64) * (spec.samples_per_bit as f64) * (spec.periods as f64);
    if total > super::MAX_SIGNAL_SAMPLES {
        return Err(invalid(format!(
            "PRBS of {total:.3e} samples (order {}, {} samples per bit, {} periods) is above the limit of {:e}",
            spec.order,
            spec.samples_per_bit,
            spec.periods,
            super::MAX_SIGNAL_SAMPLES
        )));
    }
    let total = total as usize;
    let mut values = Vec::with_capacity(total);
    for _ in 0..spec.periods {
        for &b in &seq {
            values.extend(std::iter::repeat_n(b * spec.amplitude, spec.samples_per_bit));
        }
    }
    Ok(Signal { rate_hz, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A maximal LFSR visits all 2ⁿ − 1 nonzero states before repeating.
    #[test]
    fn every_order_has_maximal_period() {
        for n in 2..=20u32 {
            let taps = TAPS[(n - 2) as usize];
            let mut reg: u32 = 1;
            let mut steps = 0usize;
            loop {
                let bit = taps.iter().fold(0u32, |acc, &t| acc ^ ((reg >> (n - t)) & 1));
                reg = (reg >> 1) | (bit << (n - 1));
                steps += 1;
                if reg == 1 {
                    break;
                }
                assert!(steps < (1usize << n), "order {n} is not maximal");
            }
            assert_eq!(steps, (1usize << n) - 1, "order {n}");
        }
    }

    /// An m-sequence has one more +1 than −1 and a two-valued periodic autocorrelation (N, −1).
    #[test]
    fn mls_balance_and_autocorrelation() {
        let s = mls(7).unwrap();
        let n = s.len();
        assert_eq!(s.iter().sum::<f64>(), 1.0);
        for lag in 0..n {
            let r: f64 = (0..n).map(|i| s[i] * s[(i + lag) % n]).sum();
            assert_eq!(r, if lag == 0 { n as f64 } else { -1.0 });
        }
    }

    #[test]
    fn prbs_hold_and_errors() {
        let sig = prbs(
            &PrbsSpec {
                order: 5,
                samples_per_bit: 3,
                periods: 2,
                amplitude: 0.5,
            },
            100.0,
        )
        .unwrap();
        assert_eq!(sig.values.len(), 31 * 3 * 2);
        assert!(sig.values.iter().all(|v| v.abs() == 0.5));
        assert_eq!(sig.values[0], sig.values[2]);
        assert!(prbs(
            &PrbsSpec {
                order: 1,
                samples_per_bit: 1,
                periods: 1,
                amplitude: 1.0
            },
            100.0
        )
        .is_err());
        assert!(prbs(
            &PrbsSpec {
                order: 5,
                samples_per_bit: 0,
                periods: 1,
                amplitude: 1.0
            },
            100.0
        )
        .is_err());
    }
}
