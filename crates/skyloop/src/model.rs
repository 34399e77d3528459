//! Models named on a command line or in a spec: a path to an LTI JSON file, or a transfer-function
//! expression.

use crate::error::{Error, Result};
use skyloop_lti::StateSpace;
use std::path::Path;

/// Loads MODEL: an LTI JSON file when `arg` names an existing file, else a transfer-function
/// expression such as `"0.0887*exp(-0.032*s)/(0.0256*s+1)"`, which may name model files as
/// `@C.json` (paths relative to the working directory; see [`skyloop_lti::expr`]): the loop of a
/// plant and a controller file is `"@P.json*@C.json"`, MATLAB's `P*C`.
///
/// # Errors
/// An unreadable file, invalid LTI JSON, a `.json` name that does not exist, or an expression that
/// does not parse ([`Error::Lti`] with the column).
///
/// # Examples
/// ```
/// let g = skyloop::model::load_model("1/(s+1)")?;
/// assert_eq!((g.nx(), g.nu(), g.ny()), (1, 1, 1));
/// assert!(skyloop::model::load_model("missing.json").is_err());
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn load_model(arg: &str) -> Result<StateSpace> {
    let path = Path::new(arg);
    if path.is_file() {
        let text = skyloop_lti::json::read_text_file(path).map_err(|e| Error::Input(format!("{arg}: {e}")))?;
        return skyloop_lti::json::from_json_str(&text).map_err(|e| Error::Input(format!("{arg}: {e}")));
    }
    if arg.ends_with(".json") && !arg.contains('@') {
        return Err(Error::Input(format!(
            "no such file: {arg} (inside an expression, write a model file as @{arg})"
        )));
    }
    skyloop_lti::expr::parse_model(arg)
        .map_err(|e| Error::Input(format!("'{}' is not a file; as an expression: {e}", abbreviate(arg))))
}

/// Loads MODEL as [`load_model`] does, except that with a sample time `dt_s` an expression is a
/// discrete transfer function in `z` (delays as `z^-k`), as `show` prints discrete models.
///
/// # Errors
/// As [`load_model`]; an expression in `s` or with `exp(...)` when `dt_s` is given.
///
/// # Examples
/// ```
/// let g = skyloop::model::load_model_dt("0.0128309*z^-8/(z-0.855345)", Some(0.004))?;
/// assert_eq!(g.dt, 0.004);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn load_model_dt(arg: &str, dt_s: Option<f64>) -> Result<StateSpace> {
    match dt_s {
        Some(dt) if !Path::new(arg).is_file() && !arg.ends_with(".json") => skyloop_lti::expr::parse_discrete(arg, dt)
            .map_err(|e| {
                Error::Input(format!(
                    "'{}' as a discrete expression (--dt {dt}): {e}",
                    abbreviate(arg)
                ))
            }),
        _ => load_model(arg),
    }
}

/// `arg` as quoted in a message: long inputs (a generated expression can be megabytes) keep their
/// first and last 40 characters, since the parse error names the column.
fn abbreviate(arg: &str) -> String {
    let chars: Vec<char> = arg.chars().collect();
    if chars.len() <= 100 {
        return arg.to_string();
    }
    let head: String = chars[..40].iter().collect();
    let tail: String = chars[chars.len() - 40..].iter().collect();
    format!("{head}…{tail} ({} characters)", chars.len())
}

/// Loads a model named relative to `base` (a spec file's directory) when such a file exists, else
/// as [`load_model`] does.
pub fn load_model_in(base: &Path, name: &str) -> Result<StateSpace> {
    let rel = base.join(name);
    if rel.is_file() {
        load_model(&rel.to_string_lossy())
    } else {
        load_model(name)
    }
}

/// Format of a written-out model entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// Gain, zeros and poles as real first- and second-order factors: `2*(s+3)/(s*(s^2+2*s+5))`.
    Zpk,
    /// Numerator and denominator polynomials: `(2*s+6)/(s^3+2*s^2+5*s)`.
    Tf,
}

/// Every entry (output i, input j) of `sys` written as a transfer-function expression in the
/// language [`load_model`] reads, with its delay as `exp(-T*s)` (continuous time) or `z` in place of
/// `s` for a discrete model; numbers have 6 significant digits.
///
/// # Errors
/// A model whose entries' zeros or poles cannot be computed.
///
/// # Examples
/// ```
/// use skyloop::model::{expressions, load_model, Form};
/// let g = load_model("2*exp(-0.1*s)*(s+3)/(s*(s^2+2*s+5))")?;
/// let e = expressions(&g, Form::Zpk)?;
/// assert_eq!(e[0][0], "2*exp(-0.1*s)*(s+3)/(s*(s^2+2*s+5))");
/// // The text reads back as the same model.
/// let back = load_model(&e[0][0])?;
/// assert_eq!(back.nx(), 3);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn expressions(sys: &StateSpace, form: Form) -> Result<Vec<Vec<String>>> {
    let mut out = Vec::with_capacity(sys.ny());
    for i in 0..sys.ny() {
        let mut row = Vec::with_capacity(sys.nu());
        for j in 0..sys.nu() {
            let (z, p, k) = skyloop_lti::convert::ss_entry_zpk(sys, i, j)?;
            let delay =
                sys.output_delay.get(i).copied().unwrap_or(0.0) + sys.input_delay.get(j).copied().unwrap_or(0.0);
            row.push(entry_text(&z, &p, k, delay, sys.dt, form));
        }
        out.push(row);
    }
    Ok(out)
}

/// A number with 6 significant digits, without trailing zeros or a needless exponent.
fn g6(x: f64) -> String {
    g_sig(x, 6)
}

/// A number as a model's text writes it: 6 significant digits in s; 10 in z, where factors near
/// z = 1 are ill-conditioned (a 50 ms sample time puts poles at 0.9048 and 0.9608).
fn gv(x: f64, var: &str) -> String {
    g_sig(x, if var == "z" { 10 } else { 6 })
}

/// A number with `sig` significant digits, without trailing zeros or a needless exponent.
fn g_sig(x: f64, sig: i32) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let e = x.abs().log10().floor() as i32;
    if !(-4..sig).contains(&e) {
        let s = format!("{x:.prec$e}", prec = (sig - 1) as usize);
        let (m, ex) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{ex}");
    }
    let decimals = (sig - 1 - e).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The real factors of a root list with conjugate pairs: the real roots (ascending) and, per pair
/// a ± jb, the coefficients [c1, c0] of s² + c1·s + c0 (ascending in c0). A root is real when its
/// imaginary part is within 1e-7 of its modulus (at least 1): a repeated real root comes back from
/// the eigenvalue solver split by about √ε into a pair, which is not a resonance.
pub fn real_factors(roots: &[skyloop_lti::c64]) -> (Vec<f64>, Vec<[f64; 2]>) {
    let mut reals = Vec::new();
    let mut quads = Vec::new();
    for r in roots {
        if r.im.abs() <= 1e-7 * r.norm().max(1.0) {
            reals.push(r.re);
        } else if r.im > 0.0 {
            quads.push([-2.0 * r.re, r.norm_sqr()]);
        }
    }
    reals.sort_by(|a, b| a.total_cmp(b));
    quads.sort_by(|a, b| a[1].total_cmp(&b[1]));
    (reals, quads)
}

/// Real factors of a root list as text: `s`, `(s+a)`, `(s^2+b*s+c)`, in ascending order of size.
fn factors(roots: &[skyloop_lti::c64], var: &str) -> Vec<String> {
    let (reals, quads) = real_factors(roots);
    let mut f: Vec<(f64, String)> = Vec::new();
    for r in reals {
        let a = -r;
        let t = if a.abs() < 1e-12 {
            var.to_string()
        } else if a > 0.0 {
            format!("({var}+{})", gv(a, var))
        } else {
            format!("({var}-{})", gv(-a, var))
        };
        f.push((r.abs(), t));
    }
    for [b, c] in quads {
        let bt = if b.abs() < 1e-12 * c.sqrt() {
            String::new()
        } else if b > 0.0 {
            format!("+{}*{var}", gv(b, var))
        } else {
            format!("-{}*{var}", gv(-b, var))
        };
        f.push((c.sqrt(), format!("({var}^2{bt}+{})", gv(c, var))));
    }
    f.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Equal factors once with a power: s^3, (z-0.5)^2.
    let mut out: Vec<(String, usize)> = Vec::new();
    for (_, t) in f {
        match out.last_mut() {
            Some((last, n)) if *last == t => *n += 1,
            _ => out.push((t, 1)),
        }
    }
    out.into_iter()
        .map(|(t, n)| if n == 1 { t } else { format!("{t}^{n}") })
        .collect()
}

/// The coefficients of Π(s − r), highest power first (real for conjugate-closed root lists).
fn poly_text(roots: &[skyloop_lti::c64], k: f64, var: &str) -> String {
    let p = skyloop_lti::poly::Poly::from_roots(roots).scale(k);
    let n = p.degree();
    // Roundoff of the roots (a repeated root at 0 comes back as ±1e-8) leaves coefficients at
    // 1e-17 of the others: they are zeros.
    let big = (0..=n).map(|d| p.coeff_of_power(d).abs()).fold(0.0, f64::max);
    let mut terms = Vec::new();
    for d in (0..=n).rev() {
        let c = p.coeff_of_power(d);
        let c = if c.abs() < 1e-12 * big { 0.0 } else { c };
        if c == 0.0 && n > 0 {
            continue;
        }
        let mag = if (c.abs() - 1.0).abs() < 1e-12 && d > 0 {
            String::new()
        } else {
            gv(c.abs(), var)
        };
        let pow = match d {
            0 => String::new(),
            1 => var.to_string(),
            _ => format!("{var}^{d}"),
        };
        let body = match (mag.is_empty(), pow.is_empty()) {
            (true, _) => pow,
            (false, true) => mag,
            (false, false) => format!("{mag}*{pow}"),
        };
        let sign = if c < 0.0 { "-" } else { "+" };
        terms.push(if terms.is_empty() && sign == "+" {
            body
        } else {
            format!("{sign}{body}")
        });
    }
    if terms.is_empty() {
        "0".into()
    } else {
        terms.concat()
    }
}

/// One entry as text; `dt` 0 for continuous time (delay `exp(-T*s)`), else the sample time (delay
/// `z^-k`, k = T/dt samples: c2d keeps whole samples as delay and puts the fraction in the states).
fn entry_text(z: &[skyloop_lti::c64], p: &[skyloop_lti::c64], k: f64, delay_s: f64, dt: f64, form: Form) -> String {
    if k == 0.0 {
        return "0".into();
    }
    let var = if dt > 0.0 { "z" } else { "s" };
    let delay = match (delay_s > 0.0, dt > 0.0) {
        (false, _) => String::new(),
        (true, true) => format!("z^-{}", (delay_s / dt).round()),
        (true, false) => format!("exp(-{}*s)", g6(delay_s)),
    };
    match form {
        Form::Zpk => {
            let mut num: Vec<String> = Vec::new();
            if gv(k, var) != "1" || (z.is_empty() && delay.is_empty()) {
                num.push(gv(k, var));
            }
            if !delay.is_empty() {
                num.push(delay);
            }
            num.extend(factors(z, var));
            let den = factors(p, var);
            let n = num.join("*");
            match den.len() {
                0 => n,
                1 => format!("{n}/{}", den[0]),
                _ => format!("{n}/({})", den.join("*")),
            }
        }
        Form::Tf => {
            let num = poly_text(z, k, var);
            let num = if z.is_empty() { num } else { format!("({num})") };
            let num = if delay.is_empty() {
                num
            } else {
                format!("{delay}*{num}")
            };
            if p.is_empty() {
                num
            } else {
                format!("{num}/({})", poly_text(p, 1.0, var))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::discretize::{c2d, Method};

    fn response(g: &StateSpace, w: f64) -> skyloop_lti::c64 {
        let z = if g.is_continuous() {
            skyloop_lti::c64::new(0.0, w)
        } else {
            skyloop_lti::c64::new(0.0, w * g.dt).exp()
        };
        let delay = g.input_delay[0] + g.output_delay[0];
        skyloop_lti::freqresp::evalfr(
            &StateSpace {
                input_delay: vec![0.0],
                output_delay: vec![0.0],
                ..g.clone()
            },
            z,
        )
        .unwrap()[(0, 0)]
            * skyloop_lti::c64::new(0.0, -w * delay).exp()
    }

    /// Discrete models print as z transfer functions with z^-k delays, and both forms read back
    /// (with their sample time) as the same model (10 significant digits in z: with 6, a pole at
    /// 0.904837 near z = 1 moved the response by 1e-4).
    #[test]
    fn discrete_models_round_trip_through_text() {
        for (expr, dt) in [
            ("0.0887*exp(-0.032*s)/(0.0256*s+1)", 0.004),
            ("0.0887*exp(-0.032*s)/(0.0256*s+1)", 0.01),
            ("2*(s+3)/(s*(s^2+2*s+5))", 0.05),
            ("(s+1)^2/((s+2)^2*(s+5))", 0.02),
        ] {
            let d = c2d(&load_model(expr).unwrap(), dt, Method::Zoh).unwrap();
            for form in [Form::Zpk, Form::Tf] {
                let text = &expressions(&d, form).unwrap()[0][0];
                assert!(!text.contains('s') && !text.contains("exp"), "{text}");
                let back = load_model_dt(text, Some(dt)).unwrap();
                assert_eq!(back.dt, dt);
                for w in [0.3, 3.0, 30.0] {
                    let (a, b) = (response(&d, w), response(&back, w));
                    assert!(
                        (a - b).norm() < 1e-6 * a.norm().max(1e-3),
                        "{expr} {form:?} at {w}: {text}: {a} vs {b}"
                    );
                }
            }
        }
        assert!(load_model_dt("1/(s-0.5)", Some(0.1)).is_err());
        assert!(load_model_dt("exp(-0.1*z)/(z-0.5)", Some(0.1)).is_err());
        assert!(load_model_dt("1/(z-0.5)", Some(-1.0)).is_err());
    }
}
