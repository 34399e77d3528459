//! Models named on a command line or in a spec: a path to an LTI JSON file, or a transfer-function
//! expression.

use crate::error::{Error, Result};
use skyloop_lti::StateSpace;
use std::path::Path;

/// Loads MODEL: an LTI JSON file when `arg` names an existing file, else a transfer-function
/// expression such as `"0.0887*exp(-0.032*s)/(0.0256*s+1)"`.
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
        let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
        return skyloop_lti::json::from_json_str(&text).map_err(|e| Error::Input(format!("{arg}: {e}")));
    }
    if arg.ends_with(".json") {
        return Err(Error::Input(format!("no such file: {arg}")));
    }
    skyloop_lti::expr::parse_model(arg)
        .map_err(|e| Error::Input(format!("'{}' is not a file; as an expression: {e}", abbreviate(arg))))
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
    let var = if sys.is_continuous() { "s" } else { "z" };
    let mut out = Vec::with_capacity(sys.ny());
    for i in 0..sys.ny() {
        let mut row = Vec::with_capacity(sys.nu());
        for j in 0..sys.nu() {
            let (z, p, k) = skyloop_lti::convert::ss_entry_zpk(sys, i, j)?;
            let delay =
                sys.output_delay.get(i).copied().unwrap_or(0.0) + sys.input_delay.get(j).copied().unwrap_or(0.0);
            row.push(entry_text(&z, &p, k, delay, var, form));
        }
        out.push(row);
    }
    Ok(out)
}

/// A number with 6 significant digits, without trailing zeros or a needless exponent.
fn g6(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let e = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&e) {
        let s = format!("{x:.5e}");
        let (m, ex) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{ex}");
    }
    let decimals = (5 - e).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The real factors of a root list with conjugate pairs: the real roots (ascending) and, per pair
/// a ± jb, the coefficients [c1, c0] of s² + c1·s + c0 (ascending in c0). A root is real when its
/// imaginary part is within 1e-9 of its modulus (at least 1).
pub fn real_factors(roots: &[skyloop_lti::c64]) -> (Vec<f64>, Vec<[f64; 2]>) {
    let mut reals = Vec::new();
    let mut quads = Vec::new();
    for r in roots {
        if r.im.abs() <= 1e-9 * r.norm().max(1.0) {
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
            format!("({var}+{})", g6(a))
        } else {
            format!("({var}-{})", g6(-a))
        };
        f.push((r.abs(), t));
    }
    for [b, c] in quads {
        let bt = if b.abs() < 1e-12 * c.sqrt() {
            String::new()
        } else if b > 0.0 {
            format!("+{}*{var}", g6(b))
        } else {
            format!("-{}*{var}", g6(-b))
        };
        f.push((c.sqrt(), format!("({var}^2{bt}+{})", g6(c))));
    }
    f.sort_by(|a, b| a.0.total_cmp(&b.0));
    f.into_iter().map(|(_, t)| t).collect()
}

/// The coefficients of Π(s − r), highest power first (real for conjugate-closed root lists).
fn poly_text(roots: &[skyloop_lti::c64], k: f64, var: &str) -> String {
    let p = skyloop_lti::poly::Poly::from_roots(roots).scale(k);
    let n = p.degree();
    let mut terms = Vec::new();
    for d in (0..=n).rev() {
        let c = p.coeff_of_power(d);
        if c == 0.0 && n > 0 {
            continue;
        }
        let mag = if (c.abs() - 1.0).abs() < 1e-12 && d > 0 {
            String::new()
        } else {
            g6(c.abs())
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

fn entry_text(z: &[skyloop_lti::c64], p: &[skyloop_lti::c64], k: f64, delay_s: f64, var: &str, form: Form) -> String {
    if k == 0.0 {
        return "0".into();
    }
    let delay = if delay_s > 0.0 {
        format!("exp(-{}*s)", g6(delay_s))
    } else {
        String::new()
    };
    match form {
        Form::Zpk => {
            let mut num: Vec<String> = Vec::new();
            if k != 1.0 || (z.is_empty() && delay.is_empty()) {
                num.push(g6(k));
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
