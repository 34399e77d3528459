//! Transfer-function expressions such as `0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s`.
//!
//! Grammar (recursive descent, usual precedence, `^` binds tighter than unary minus):
//! ```text
//! sum     := product (('+' | '-') product)*
//! product := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary ('^' ['-'] integer)?
//! primary := number | 's' | parameter | 'exp' '(' sum ')' | '(' sum ')'
//! ```
//! Numbers accept `1`, `1.5`, `.5`, `1e-3`; parameters are identifiers other than `s` and `exp`.

use crate::convert::tf_to_ss;
use crate::error::{LtiError, Result};
use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::{rat_add, TransferFunction};
use faer::c64;
use std::collections::HashMap;

/// A parsed transfer-function expression in the Laplace variable `s`.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A real constant.
    Num(f64),
    /// The Laplace variable.
    S,
    /// A named parameter (value supplied at evaluation).
    Param(String),
    /// Unary minus.
    Neg(Box<Expr>),
    /// Sum.
    Add(Box<Expr>, Box<Expr>),
    /// Difference.
    Sub(Box<Expr>, Box<Expr>),
    /// Product.
    Mul(Box<Expr>, Box<Expr>),
    /// Quotient.
    Div(Box<Expr>, Box<Expr>),
    /// Integer power.
    Pow(Box<Expr>, i32),
    /// Exponential; `exp(-T*s)` is a delay of T seconds.
    Exp(Box<Expr>),
}

/// Parses an expression; errors carry the 1-based column and what was expected.
pub fn parse(text: &str) -> Result<Expr> {
    let toks = lex(text)?;
    let mut p = Parser { toks, pos: 0 };
    let e = p.sum()?;
    match p.peek() {
        Tok::End => Ok(e),
        t => Err(p.err(format!(
            "expected an operator or the end of the expression, found {}",
            t.describe()
        ))),
    }
}

/// Parses a numeric expression (no parameters) into a state-space model with its exact delay.
pub fn parse_model(text: &str) -> Result<StateSpace> {
    let e = parse(text)?;
    let params = e.params();
    if !params.is_empty() {
        return Err(LtiError::InvalidArgument(format!(
            "the expression has parameters without values: {}",
            params.join(", ")
        )));
    }
    tf_to_ss(&e.to_tf(&HashMap::new())?)
}

impl Expr {
    /// Names of the parameters in the expression, sorted and without repeats.
    pub fn params(&self) -> Vec<String> {
        let mut v = Vec::new();
        self.collect_params(&mut v);
        v.sort();
        v.dedup();
        v
    }

    fn collect_params(&self, v: &mut Vec<String>) {
        match self {
            Expr::Num(_) | Expr::S => {}
            Expr::Param(n) => v.push(n.clone()),
            Expr::Neg(a) | Expr::Pow(a, _) | Expr::Exp(a) => a.collect_params(v),
            Expr::Add(a, b) | Expr::Sub(a, b) | Expr::Mul(a, b) | Expr::Div(a, b) => {
                a.collect_params(v);
                b.collect_params(v);
            }
        }
    }

    /// Value at the complex point `s` (rad/s), exact including delays; every parameter needs a value.
    pub fn eval(&self, s: c64, params: &HashMap<String, f64>) -> Result<c64> {
        Ok(match self {
            Expr::Num(x) => c64::new(*x, 0.0),
            Expr::S => s,
            Expr::Param(n) => c64::new(param_value(n, params)?, 0.0),
            Expr::Neg(a) => -a.eval(s, params)?,
            Expr::Add(a, b) => a.eval(s, params)? + b.eval(s, params)?,
            Expr::Sub(a, b) => a.eval(s, params)? - b.eval(s, params)?,
            Expr::Mul(a, b) => a.eval(s, params)? * b.eval(s, params)?,
            Expr::Div(a, b) => a.eval(s, params)? / b.eval(s, params)?,
            Expr::Pow(a, k) => a.eval(s, params)?.powi(*k),
            Expr::Exp(a) => a.eval(s, params)?.exp(),
        })
    }

    /// The SISO transfer function with all delay factors collected into one exact input delay.
    ///
    /// Fails when a sum mixes different delays, an `exp` argument is not `c − T·s`, or the net delay
    /// is negative (a prediction).
    pub fn to_tf(&self, params: &HashMap<String, f64>) -> Result<TransferFunction> {
        let r = self.rational(params)?;
        if r.delay < 0.0 {
            return Err(LtiError::Unsupported(format!(
                "the net delay is negative ({} s): the model would be a prediction",
                r.delay
            )));
        }
        let mut tf = TransferFunction::siso(r.num, r.den, 0.0)?;
        tf.input_delay[0] = r.delay;
        Ok(tf)
    }

    fn rational(&self, params: &HashMap<String, f64>) -> Result<Rat> {
        Ok(match self {
            Expr::Num(x) => Rat::constant(*x),
            Expr::S => Rat {
                num: Poly::s(),
                den: Poly::one(),
                delay: 0.0,
            },
            Expr::Param(n) => Rat::constant(param_value(n, params)?),
            Expr::Neg(a) => {
                let r = a.rational(params)?;
                Rat { num: -&r.num, ..r }
            }
            Expr::Add(a, b) => a.rational(params)?.add(&b.rational(params)?)?,
            Expr::Sub(a, b) => {
                let rb = b.rational(params)?;
                a.rational(params)?.add(&Rat { num: -&rb.num, ..rb })?
            }
            Expr::Mul(a, b) => a.rational(params)?.mul(&b.rational(params)?),
            Expr::Div(a, b) => a.rational(params)?.mul(&b.rational(params)?.inv()?),
            Expr::Pow(a, k) => {
                let r = a.rational(params)?;
                let base = if *k < 0 { r.inv()? } else { r };
                let n = k.unsigned_abs();
                Rat {
                    num: base.num.powi(n),
                    den: base.den.powi(n),
                    delay: base.delay * n as f64,
                }
            }
            Expr::Exp(a) => {
                let r = a.rational(params)?;
                if r.delay != 0.0 || r.den.degree() != 0 || r.num.degree() > 1 {
                    return Err(LtiError::Unsupported(
                        "exp(...) must have an argument of the form c - T*s (a delay of T seconds)".into(),
                    ));
                }
                let d = r.den.leading();
                let slope = r.num.coeff_of_power(1) / d;
                let offset = r.num.coeff_of_power(0) / d;
                Rat {
                    num: Poly::constant(offset.exp()),
                    den: Poly::one(),
                    delay: -slope,
                }
            }
        })
    }
}

fn param_value(name: &str, params: &HashMap<String, f64>) -> Result<f64> {
    params
        .get(name)
        .copied()
        .ok_or_else(|| LtiError::InvalidArgument(format!("parameter '{name}' has no value")))
}

/// A rational function times `e^(−delay·s)`, the value of a sub-expression.
struct Rat {
    num: Poly,
    den: Poly,
    delay: f64,
}

impl Rat {
    fn constant(x: f64) -> Rat {
        Rat {
            num: Poly::constant(x),
            den: Poly::one(),
            delay: 0.0,
        }
    }

    fn add(&self, o: &Rat) -> Result<Rat> {
        let delay = if self.num.is_zero() {
            o.delay
        } else if o.num.is_zero() || (self.delay - o.delay).abs() <= 1e-12 * self.delay.abs().max(o.delay.abs()) {
            self.delay
        } else {
            return Err(LtiError::Unsupported(format!(
                "cannot add terms with different delays ({} s and {} s): the sum is not one delayed rational model",
                self.delay, o.delay
            )));
        };
        let (num, den) = rat_add(&self.num, &self.den, &o.num, &o.den);
        Ok(Rat { num, den, delay })
    }

    fn mul(&self, o: &Rat) -> Rat {
        Rat {
            num: &self.num * &o.num,
            den: &self.den * &o.den,
            delay: self.delay + o.delay,
        }
    }

    fn inv(&self) -> Result<Rat> {
        if self.num.is_zero() {
            return Err(LtiError::InvalidArgument("division by zero".into()));
        }
        Ok(Rat {
            num: self.den.clone(),
            den: self.num.clone(),
            delay: -self.delay,
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
    End,
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Num(x) => format!("the number {x}"),
            Tok::Ident(n) => format!("'{n}'"),
            Tok::Op(c) => format!("'{c}'"),
            Tok::End => "the end of the expression".into(),
        }
    }
}

/// Splits the text into tokens with their 1-based columns.
fn lex(text: &str) -> Result<Vec<(Tok, usize)>> {
    let ch: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < ch.len() {
        let c = ch[i];
        let col = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && ch.get(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            let start = i;
            while i < ch.len() && ch[i].is_ascii_digit() {
                i += 1;
            }
            if i < ch.len() && ch[i] == '.' {
                i += 1;
                while i < ch.len() && ch[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < ch.len() && (ch[i] == 'e' || ch[i] == 'E') {
                let mut j = i + 1;
                if j < ch.len() && (ch[j] == '+' || ch[j] == '-') {
                    j += 1;
                }
                if j < ch.len() && ch[j].is_ascii_digit() {
                    while j < ch.len() && ch[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let s: String = ch[start..i].iter().collect();
            let v: f64 = s.parse().map_err(|_| LtiError::Parse {
                column: col,
                message: format!("'{s}' is not a number"),
            })?;
            if !v.is_finite() {
                return Err(LtiError::Parse {
                    column: col,
                    message: format!("'{s}' is not a finite number"),
                });
            }
            out.push((Tok::Num(v), col));
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < ch.len() && (ch[i].is_alphanumeric() || ch[i] == '_') {
                i += 1;
            }
            out.push((Tok::Ident(ch[start..i].iter().collect()), col));
        } else if "+-*/^()".contains(c) {
            out.push((Tok::Op(c), col));
            i += 1;
        } else {
            return Err(LtiError::Parse {
                column: col,
                message: format!("unexpected character '{c}'"),
            });
        }
    }
    out.push((Tok::End, ch.len() + 1));
    Ok(out)
}

struct Parser {
    toks: Vec<(Tok, usize)>,
    pos: usize,
}

impl Parser {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }

    fn col(&self) -> usize {
        self.toks[self.pos].1
    }

    fn bump(&mut self) -> Tok {
        let t = self.toks[self.pos].0.clone();
        if t != Tok::End {
            self.pos += 1;
        }
        t
    }

    fn err(&self, message: String) -> LtiError {
        LtiError::Parse {
            column: self.col(),
            message,
        }
    }

    fn sum(&mut self) -> Result<Expr> {
        let mut e = self.product()?;
        loop {
            match self.peek() {
                Tok::Op('+') => {
                    self.bump();
                    e = Expr::Add(Box::new(e), Box::new(self.product()?));
                }
                Tok::Op('-') => {
                    self.bump();
                    e = Expr::Sub(Box::new(e), Box::new(self.product()?));
                }
                _ => return Ok(e),
            }
        }
    }

    fn product(&mut self) -> Result<Expr> {
        let mut e = self.unary()?;
        loop {
            match self.peek() {
                Tok::Op('*') => {
                    self.bump();
                    e = Expr::Mul(Box::new(e), Box::new(self.unary()?));
                }
                Tok::Op('/') => {
                    self.bump();
                    e = Expr::Div(Box::new(e), Box::new(self.unary()?));
                }
                _ => return Ok(e),
            }
        }
    }

    fn unary(&mut self) -> Result<Expr> {
        match self.peek() {
            Tok::Op('-') => {
                self.bump();
                Ok(Expr::Neg(Box::new(self.unary()?)))
            }
            Tok::Op('+') => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Expr> {
        let base = self.primary()?;
        if self.peek() != &Tok::Op('^') {
            return Ok(base);
        }
        self.bump();
        let neg = if self.peek() == &Tok::Op('-') {
            self.bump();
            true
        } else {
            false
        };
        match self.peek().clone() {
            Tok::Num(x) if x.fract() == 0.0 && x.abs() <= 1000.0 => {
                self.bump();
                let k = x as i32;
                Ok(Expr::Pow(Box::new(base), if neg { -k } else { k }))
            }
            t => Err(self.err(format!(
                "expected an integer exponent (at most 1000) after '^', found {}",
                t.describe()
            ))),
        }
    }

    fn primary(&mut self) -> Result<Expr> {
        let col = self.col();
        match self.bump() {
            Tok::Num(x) => Ok(Expr::Num(x)),
            Tok::Ident(n) if n == "s" => Ok(Expr::S),
            Tok::Ident(n) if n == "exp" => {
                if self.peek() != &Tok::Op('(') {
                    return Err(self.err(format!("expected '(' after 'exp', found {}", self.peek().describe())));
                }
                self.bump();
                let arg = self.sum()?;
                self.close(col)?;
                Ok(Expr::Exp(Box::new(arg)))
            }
            Tok::Ident(n) => {
                if self.peek() == &Tok::Op('(') {
                    return Err(LtiError::Parse {
                        column: col,
                        message: format!("unknown function '{n}' (only exp is known)"),
                    });
                }
                Ok(Expr::Param(n))
            }
            Tok::Op('(') => {
                let e = self.sum()?;
                self.close(col)?;
                Ok(e)
            }
            t => {
                self.pos -= usize::from(t != Tok::End);
                Err(self.err(format!(
                    "expected a number, 's', a parameter, 'exp(' or '(', found {}",
                    t.describe()
                )))
            }
        }
    }

    fn close(&mut self, open_col: usize) -> Result<()> {
        if self.peek() == &Tok::Op(')') {
            self.bump();
            Ok(())
        } else {
            Err(self.err(format!(
                "expected ')' to close the '(' at column {open_col}, found {}",
                self.peek().describe()
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BICOPTER: &str = "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)";

    /// Eq. (8) of the bicopter paper evaluated factor by factor, independently of the parser.
    fn bicopter_direct(s: c64) -> c64 {
        let one = c64::new(1.0, 0.0);
        0.0887 * (-0.032 * s).exp() / (0.0256 * s + one) * (one * 42.0 * 42.0 - s * s) / s * 2.221e5
            / (s * s + 666.4 * s + 2.221e5)
    }

    #[test]
    fn bicopter_eval_tf_and_model_agree() {
        let e = parse(BICOPTER).unwrap();
        assert!(e.params().is_empty());
        let tf = e.to_tf(&HashMap::new()).unwrap();
        assert_eq!(tf.input_delay, vec![0.032]);
        assert_eq!(tf.den[0][0].degree(), 4);
        assert_eq!(tf.num[0][0].degree(), 2);
        let sys = parse_model(BICOPTER).unwrap();
        assert_eq!(sys.nx(), 4);
        assert_eq!(sys.input_delay, vec![0.032]);
        for w in [0.1, 1.0, 9.2, 42.0, 300.0] {
            let s = c64::new(0.0, w);
            let want = bicopter_direct(s);
            let got = e.eval(s, &HashMap::new()).unwrap();
            assert!((got - want).norm() < 1e-13 * want.norm(), "eval at {w}");
            let got = tf.eval(s)[(0, 0)];
            assert!((got - want).norm() < 1e-12 * want.norm(), "tf at {w}");
            // C (sI − A)^-1 B + D with the delay, via a complex solve.
            let n = sys.nx();
            let m = faer::Mat::<c64>::from_fn(n, n, |i, j| {
                let a = c64::new(-sys.a[(i, j)], 0.0);
                if i == j {
                    a + s
                } else {
                    a
                }
            });
            let b = faer::Mat::<c64>::from_fn(n, 1, |i, _| c64::new(sys.b[(i, 0)], 0.0));
            use faer::linalg::solvers::Solve;
            let x = m.partial_piv_lu().solve(&b);
            let mut g = c64::new(sys.d[(0, 0)], 0.0);
            for i in 0..n {
                g += sys.c[(0, i)] * x[(i, 0)];
            }
            g *= (-s * 0.032).exp();
            assert!((g - want).norm() < 1e-10 * want.norm(), "ss at {w}: {g} vs {want}");
        }
    }

    #[test]
    fn numbers_and_precedence() {
        let p = HashMap::new();
        let v = |t: &str| parse(t).unwrap().eval(c64::new(2.0, 0.0), &p).unwrap().re;
        assert_eq!(v("1e-3"), 1e-3);
        assert_eq!(v(".5*s"), 1.0);
        assert_eq!(v("-s^2"), -4.0);
        assert_eq!(v("2*3+4"), 10.0);
        assert_eq!(v("2*(3+4)"), 14.0);
        assert_eq!(v("8/2/2"), 2.0);
        assert_eq!(v("s^-1"), 0.5);
        assert_eq!(v("1.5E+1 - -1"), 16.0);
    }

    #[test]
    fn parameters_eval_and_list() {
        let e = parse("K*exp(-Td*s)/(tau*s+1) + 0*K").unwrap();
        assert_eq!(e.params(), vec!["K", "Td", "tau"]);
        let p: HashMap<String, f64> = [("K".into(), 2.0), ("Td".into(), 0.1), ("tau".into(), 0.5)].into();
        let s = c64::new(0.0, 3.0);
        let want = 2.0 * (-0.1 * s).exp() / (0.5 * s + 1.0);
        assert!((e.eval(s, &p).unwrap() - want).norm() < 1e-15);
        let tf = e.to_tf(&p).unwrap();
        assert!((tf.input_delay[0] - 0.1).abs() < 1e-15);
        assert!(e.eval(s, &HashMap::new()).is_err());
        assert!(parse_model("K/(s+1)").is_err());
    }

    fn parse_col(t: &str) -> usize {
        match parse(t) {
            Err(LtiError::Parse { column, .. }) => column,
            other => panic!("expected a parse error for {t:?}, got {other:?}"),
        }
    }

    #[test]
    fn errors_name_the_column() {
        assert_eq!(parse_col("1/(s+1"), 7);
        assert_eq!(parse_col("1/(s+*1)"), 6);
        assert_eq!(parse_col("2s"), 2);
        assert_eq!(parse_col("s^1.5"), 3);
        assert_eq!(parse_col("s # 1"), 3);
        assert_eq!(parse_col("sin(s)"), 1);
        assert_eq!(parse_col(""), 1);
        assert_eq!(parse_col("exp -s"), 5);
        let msg = parse("1/(s+").unwrap_err().to_string();
        assert!(msg.contains("column 6") && msg.contains("expected"), "{msg}");
    }

    #[test]
    fn delay_rules() {
        let m = HashMap::new();
        assert!(parse("exp(-s)+1").unwrap().to_tf(&m).is_err());
        assert!(parse("exp(s)").unwrap().to_tf(&m).is_err());
        assert!(parse("exp(-s^2)").unwrap().to_tf(&m).is_err());
        assert!(parse("1/(s-s)").unwrap().to_tf(&m).is_err());
        // Same delay on both terms is one delayed rational model; exp(+0.1 s)·exp(−0.3 s) is net 0.2 s.
        let tf = parse("exp(-0.2*s)/(s+1) + exp(-0.2*s)").unwrap().to_tf(&m).unwrap();
        assert_eq!(tf.input_delay, vec![0.2]);
        let tf = parse("exp(0.1*s)*exp(-0.3*s)").unwrap().to_tf(&m).unwrap();
        assert!((tf.input_delay[0] - 0.2).abs() < 1e-15);
        assert!(parse_model("s").is_err());
    }
}
