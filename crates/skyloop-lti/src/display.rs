//! Bounded-width text for numbers, roots and models, so that a pole at 1e300 prints as `1e300`
//! rather than as 301 digits (Rust's `{}` for f64 never switches to an exponent).
//!
//! Numbers print with at most 10 significant digits: plainly when 1e-4 ≤ |x| < 1e6, with an
//! exponent otherwise; the longest output of [`Num`] is 17 characters (`-1.234567891e-300`).

use crate::poly::Poly;
use crate::zpk::Zpk;
use faer::c64;
use std::fmt;

/// A real number in bounded-width text (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let text = if x == 0.0 {
            "0".to_string()
        } else if x.is_nan() {
            "NaN".to_string()
        } else if x.is_infinite() {
            if x > 0.0 { "inf" } else { "-inf" }.to_string()
        } else if (1e-4..1e6).contains(&x.abs()) {
            let mag = x.abs().log10().floor() as i32;
            let prec = (9 - mag).clamp(0, 13) as usize;
            trim_zeros(&format!("{x:.prec$}"))
        } else {
            let s = format!("{x:.9e}");
            match s.split_once('e') {
                Some((m, e)) => format!("{}e{e}", trim_zeros(m)),
                None => s,
            }
        };
        f.pad(&text)
    }
}

fn trim_zeros(s: &str) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s.to_string()
    }
}

/// A complex number as `re+imj` / `re-imj` in bounded width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Complex(pub c64);

impl fmt::Display for Complex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let z = self.0;
        let text = if z.im == 0.0 {
            Num(z.re).to_string()
        } else if z.im < 0.0 {
            format!("{}-{}j", Num(z.re), Num(-z.im))
        } else {
            format!("{}+{}j", Num(z.re), Num(z.im))
        };
        f.pad(&text)
    }
}

/// Poles or zeros as a table: real part, imaginary part, natural frequency (Hz) and damping of the
/// continuous-time equivalent (s = ln z / dt for discrete models, `dt` in seconds).
#[derive(Debug, Clone, Copy)]
pub struct RootTable<'a> {
    /// The roots (s-plane, or z-plane when `dt > 0`).
    pub roots: &'a [c64],
    /// Sample period in seconds; 0 for continuous time.
    pub dt: f64,
}

impl fmt::Display for RootTable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{:>17} {:>17} {:>17} {:>17}", "re", "im", "freq_hz", "damping")?;
        for z in self.roots {
            let s = if self.dt > 0.0 { z.ln() / self.dt } else { *z };
            let wn = s.norm();
            let zeta = if wn > 0.0 { -s.re / wn } else { f64::NAN };
            writeln!(
                f,
                "{:>17} {:>17} {:>17} {:>17}",
                Num(z.re),
                Num(z.im),
                Num(wn / (2.0 * std::f64::consts::PI)),
                Num(zeta)
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for Poly {
    /// Descending powers of s, e.g. `s^2 + 666.4*s + 2.221e5`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.degree();
        let mut first = true;
        for (i, &c) in self.coeffs.iter().enumerate() {
            let k = n - i;
            if c == 0.0 && n != 0 {
                continue;
            }
            let (sign, a) = if c < 0.0 { ("-", -c) } else { ("+", c) };
            if first {
                if sign == "-" {
                    write!(f, "-")?;
                }
            } else {
                write!(f, " {sign} ")?;
            }
            first = false;
            let power = match k {
                0 => String::new(),
                1 => "s".into(),
                _ => format!("s^{k}"),
            };
            match (k, a == 1.0) {
                (0, _) => write!(f, "{}", Num(a))?,
                (_, true) => write!(f, "{power}")?,
                _ => write!(f, "{}*{power}", Num(a))?,
            }
        }
        Ok(())
    }
}

impl fmt::Display for Zpk {
    /// Each entry as `k * (s - z1)*(s - z2) / ((s - p1)*...)`, one line per (output, input).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let var = if self.dt > 0.0 { "z" } else { "s" };
        let factors = |r: &[c64]| -> String {
            if r.is_empty() {
                return "1".into();
            }
            r.iter()
                .map(|x| format!("({var} - ({}))", Complex(*x)))
                .collect::<Vec<_>>()
                .join("*")
        };
        for (i, row) in self.k.iter().enumerate() {
            for (j, &k) in row.iter().enumerate() {
                writeln!(
                    f,
                    "[{i},{j}]: {} * {} / ({})",
                    Num(k),
                    factors(&self.z[i][j]),
                    factors(&self.p[i][j])
                )?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_stay_short() {
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(-1.5).to_string(), "-1.5");
        assert_eq!(Num(0.1 + 0.2).to_string(), "0.3");
        assert_eq!(Num(2.221e5).to_string(), "222100");
        assert_eq!(Num(1.0 / 3.0).to_string(), "0.3333333333");
        assert_eq!(Num(f64::MIN_POSITIVE).to_string(), "2.225073859e-308");
        for x in [
            1e300,
            -1.234567891234e-300,
            123456.789,
            9.99999e5,
            1e-4,
            f64::MAX,
            -f64::MIN_POSITIVE,
        ] {
            assert!(Num(x).to_string().len() <= 17, "{x}: {}", Num(x));
        }
        assert_eq!(format!("{:>8}", Num(2.0)), "       2");
        let z = Complex(c64::new(-1e300, 2.0));
        assert_eq!(z.to_string(), "-1e300+2j");
        let table = RootTable {
            roots: &[c64::new(-1e300, 0.0)],
            dt: 0.0,
        }
        .to_string();
        assert!(table.lines().all(|l| l.len() < 80), "{table}");
        assert_eq!(
            Poly::new(vec![1.0, 666.4, 2.221e5]).to_string(),
            "s^2 + 666.4*s + 222100"
        );
        assert_eq!(Poly::new(vec![-2.0, 0.0, -1.0]).to_string(), "-2*s^2 - 1");
    }
}
