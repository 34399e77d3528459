//! Transfer-function expressions such as `0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s`.
//!
//! Grammar (recursive descent, usual precedence, `^` binds tighter than unary minus):
//! ```text
//! sum     := product (('+' | '-') product)*
//! product := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary ('^' ['-'] integer)?
//! primary := number | 's' | parameter | 'exp' '(' sum ')' | '(' sum ')' | file
//! file    := '@' path-ending-in-.json | '@"' any-path '"'
//! ```
//! Numbers accept `1`, `1.5`, `.5`, `1e-3`; parameters are identifiers other than `s` and `exp`.
//! A file reference reads a continuous SISO model in LTI JSON (what `--out` writes) and stands for
//! it with its delays: `@C.json*(s+1)`, `@plant.json*@ctl/K.json`, `@"my model.txt"/s`. Unquoted,
//! the path runs to the first `.json` (so `@C.json/s` divides by s); quote any other path.
//! The parser accepts at most [`MAX_DEPTH`] nested parentheses, signs and `exp(...)` calls, and a
//! missing `*` is named with its fix (`2s` → "write 2*s").
//!
//! # From an expression to a state-space model
//!
//! [`parse_model`] / [`Expr::to_ss`] never multiply the expression out into one polynomial ratio
//! (whose coefficients lose the roots from about order 18: `1/(s+1)^25` was off by 23× at 1 rad/s).
//! The tree is realized bottom-up, each node as either
//!
//! * a **factored value** `k · Π nᵢ(s) / Π dⱼ(s) · e^(−T·s)`, kept as the list of factors the user
//!   wrote (`s`, `s+1`, `s^2+2*s+5`, ...): numbers, `s`, products, quotients and integer powers of
//!   factored values stay factored (a power repeats its factors), and a sum of polynomials is one
//!   polynomial factor of the degree written; or
//! * a **realized value**: a proper, delay-free SISO state-space model times `e^(−T·s)`.
//!
//! A factored value becomes a model when it must (it is added to something with dynamics, multiplied
//! with a realized value, or is the result): the roots of each factor (closed form up to degree 2,
//! the balanced companion matrix above) are grouped into real poles and complex pairs, roots shared by
//! numerator and denominator cancel (1e-10 relative), zeros are paired with the poles of nearest
//! magnitude into first- and second-order sections (a complex zero pair with a complex pole pair or
//! two real poles; real zeros left without a real pole, two at a time, with the complex pair nearest
//! their geometric mean, so no section's low-frequency gain comes out of a cancellation), and each section is realized small and balanced: `[p]` for a real pole, the
//! normal form `[σ ω; −ω σ]` for a pair, a triangular 2×2 for two real poles. Each section is scaled
//! to unit gain at its corner frequency and the total gain is spread evenly over the sections (in
//! logarithms, so gains of 1e±300 neither overflow nor end up in one section). Sections and realized
//! factors of a product are chained in series with the later model's states first, so A is block
//! upper triangular: the poles of a chain are the sections' own poles (a 60-fold pole stays exact
//! instead of scattering by ε^(1/60)), and the response is one quasi-triangular solve.
//!
//! `+`/`−` connect realized terms in parallel (block diagonal A). `/` inverts the divisor: a factored
//! divisor swaps its factors; a realized biproper divisor (A, B, C, D ≠ 0) is inverted exactly as
//! (A − BD⁻¹C, BD⁻¹, −D⁻¹C, D⁻¹) and the product is reduced by [`crate::minreal::minreal`] because
//! such a quotient usually cancels modes (`(1/(s+1))/(1 + 1/(s+1))`). The feedback forms
//! `G/(c + G·H)`, `G/(c − G·H)` and `G/(c ± G)` with proper, delay-free G and H are built by
//! [`crate::interconnect::feedback`], with the states of G and H once. What has no proper structural
//! form (a strictly proper divisor that is a sum, an improper term in a sum such as `s + 1/(s+1)`)
//! falls back, for that node only, to its exact rational form (the polynomial path of
//! [`Expr::to_tf`]), which is then realized like a user-written factor.
//!
//! Delays are collected exactly as in [`Expr::to_tf`]: products add them, a sum needs equal delays,
//! and the model carries the net delay as its input delay. Models of order above [`MAX_ORDER`] are
//! refused. [`Expr::to_tf`] keeps the polynomial form for those who ask for a transfer function.

use crate::error::{LtiError, Result};
use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::{rat_add, TransferFunction};
use faer::{c64, Mat};
use std::cell::Cell;
use std::collections::HashMap;

/// Most sub-expression visits one realization may take (see `Expr::realize`).
pub const MAX_REALIZE_VISITS: usize = 200_000;

/// Highest model order (states, or polynomial degree for [`Expr::to_tf`]) an expression may produce.
pub const MAX_ORDER: usize = 1000;

/// Deepest nesting of parentheses, signs and `exp(...)` the parser accepts (recursion bound).
pub const MAX_DEPTH: usize = 200;

/// Deepest expression tree the parser builds (a sum of n terms is n deep): evaluation and
/// realization recurse over the tree.
pub const MAX_TREE_DEPTH: usize = 1000;

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
    /// A model read from a file (`@C.json`): a continuous SISO state-space model with its delays.
    Model(Box<StateSpace>),
}

/// Parses an expression; errors carry the 1-based column and what was expected.
pub fn parse(text: &str) -> Result<Expr> {
    parse_in(text, "s")
}

/// Parses an expression in the variable `var` ("s", or "z" for a discrete model: `z` then plays the
/// role `s` plays in [`Expr`]).
fn parse_in(text: &str, var: &'static str) -> Result<Expr> {
    let toks = lex(text)?;
    let mut p = Parser {
        var,
        toks,
        pos: 0,
        depth: 0,
    };
    let (e, _) = p.sum()?;
    match p.peek() {
        Tok::End => Ok(e),
        t => {
            // Juxtaposition ("2s", "s(s+1)", ")(") is the usual slip: name the fix.
            let prev = p.pos.checked_sub(1).map(|i| p.toks[i].0.clone());
            let hint = match (&prev, t) {
                (Some(a), Tok::Ident(_) | Tok::Num(_) | Tok::Op('(') | Tok::File(_))
                    if matches!(a, Tok::Num(_) | Tok::Ident(_) | Tok::Op(')') | Tok::File(_)) =>
                {
                    format!(" (write {}*{} to multiply)", a.text(), t.text())
                }
                _ => String::new(),
            };
            Err(p.err(format!(
                "expected an operator or the end of the expression, found {}{hint}",
                t.describe()
            )))
        }
    }
}

/// Parses a numeric expression (no parameters) into a state-space model with its exact delay.
///
/// # Errors
/// A parse error with its column, an improper expression, or a parameter name where a number is needed.
///
/// # Examples
/// ```
/// let g = skyloop_lti::expr::parse_model("exp(-0.1*s)/(0.5*s+1)")?;
/// assert_eq!(g.nx(), 1);
/// assert_eq!(g.input_delay, vec![0.1]);
/// let e = skyloop_lti::expr::parse_model("1/(s+").expect_err("unfinished");
/// assert!(e.to_string().contains("column"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn parse_model(text: &str) -> Result<StateSpace> {
    let e = parse(text)?;
    let params = e.params();
    if !params.is_empty() {
        return Err(LtiError::InvalidArgument(format!(
            "the expression has parameters without values: {}",
            params.join(", ")
        )));
    }
    e.to_ss(&HashMap::new())
}

/// Parses a discrete transfer-function expression in `z` (delays as `z^-k`) into a model with
/// sample time `dt_s` seconds.
///
/// # Errors
/// A parse error with its column, an `s` or `exp(...)` in the text, an improper expression, or a
/// sample time that is not finite and positive.
///
/// # Examples
/// ```
/// let g = skyloop_lti::expr::parse_discrete("0.5*z^-2/(z-0.5)", 0.01)?;
/// assert_eq!((g.nx(), g.dt), (1, 0.01));
/// assert!((g.input_delay[0] - 0.02).abs() < 1e-15);
/// assert!(skyloop_lti::expr::parse_discrete("1/(s-0.5)", 0.01).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn parse_discrete(text: &str, dt_s: f64) -> Result<StateSpace> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "the sample time must be finite and > 0 s, got {dt_s}"
        )));
    }
    let e = parse_in(text, "z")?;
    let params = e.params();
    if !params.is_empty() {
        return Err(LtiError::InvalidArgument(format!(
            "the expression has parameters without values: {}",
            params.join(", ")
        )));
    }
    // A factor z^-k of the whole expression is a delay of k samples (as `show` prints one), not k
    // poles at the origin.
    let (e, k) = split_shift(e);
    // The rational function of z realized as one of s has the same matrices; only their meaning
    // (a shift instead of an integrator) changes with the sample time.
    let mut g = e.to_ss(&HashMap::new())?;
    g.dt = dt_s;
    if k > 0 {
        g.input_delay = vec![k as f64 * dt_s; g.nu()];
    }
    Ok(g)
}

/// The expression without its multiplicative factors z^-k (k > 0), and the sum of their k.
fn split_shift(e: Expr) -> (Expr, i32) {
    match e {
        Expr::Pow(b, k) if k < 0 && *b == Expr::S => (Expr::Num(1.0), -k),
        Expr::Mul(a, b) => {
            let ((a, ka), (b, kb)) = (split_shift(*a), split_shift(*b));
            (Expr::Mul(Box::new(a), Box::new(b)), ka + kb)
        }
        Expr::Div(a, b) => {
            let (a, ka) = split_shift(*a);
            (Expr::Div(Box::new(a), b), ka)
        }
        other => (other, 0),
    }
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
            Expr::Num(_) | Expr::S | Expr::Model(_) => {}
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
            Expr::Model(g) => model_at(g, s)?,
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
            Expr::Model(g) => {
                let tf = crate::convert::ss_to_tf(&without_delay(g))?;
                Rat {
                    num: tf.num[0][0].clone(),
                    den: tf.den[0][0].clone(),
                    delay: model_delay(g),
                }
            }
            Expr::Neg(a) => {
                let r = a.rational(params)?;
                Rat { num: -&r.num, ..r }
            }
            Expr::Add(a, b) => a.rational(params)?.add(&b.rational(params)?)?,
            Expr::Sub(a, b) => {
                let rb = b.rational(params)?;
                a.rational(params)?.add(&Rat { num: -&rb.num, ..rb })?
            }
            Expr::Mul(a, b) => a.rational(params)?.mul(&b.rational(params)?)?,
            Expr::Div(a, b) => a.rational(params)?.mul(&b.rational(params)?.inv()?)?,
            Expr::Pow(a, k) => {
                let r = a.rational(params)?;
                let base = if *k < 0 { r.inv()? } else { r };
                let n = k.unsigned_abs();
                check_order((base.num.degree().max(base.den.degree())).saturating_mul(n as usize))?;
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

/// The model without its delays (carried separately, as every realized value's delay is).
fn without_delay(g: &StateSpace) -> StateSpace {
    let mut r = g.clone();
    r.input_delay.iter_mut().for_each(|d| *d = 0.0);
    r.output_delay.iter_mut().for_each(|d| *d = 0.0);
    r
}

/// A SISO model's total delay, s.
fn model_delay(g: &StateSpace) -> f64 {
    g.input_delay.first().copied().unwrap_or(0.0) + g.output_delay.first().copied().unwrap_or(0.0)
}

/// G(s) with its delay.
fn model_at(g: &StateSpace, s: c64) -> Result<c64> {
    let ev = crate::freqresp::FreqEvaluator::new(&without_delay(g))?;
    let mut ws = ev.workspace();
    let mut out = [c64::new(0.0, 0.0)];
    ev.eval_into(s, &mut ws, &mut out)?;
    Ok(out[0] * (-s * model_delay(g)).exp())
}

/// Reads the model a file reference names: LTI JSON, continuous and SISO (an expression is a
/// scalar transfer function in s).
fn read_model_file(path: &str, column: usize) -> Result<StateSpace> {
    let bad = |message: String| LtiError::Parse { column, message };
    let text = crate::json::read_text_file(std::path::Path::new(path)).map_err(|e| bad(format!("@{path}: {e}")))?;
    let g = crate::json::from_json_str(&text).map_err(|e| bad(format!("@{path}: {e}")))?;
    if g.nu() != 1 || g.ny() != 1 {
        return Err(bad(format!(
            "@{path}: an expression takes SISO models; this one has {} outputs and {} inputs",
            g.ny(),
            g.nu()
        )));
    }
    if g.dt != 0.0 {
        return Err(bad(format!(
            "@{path}: a discrete model (dt = {} s) cannot enter an expression in s; convert it with `skyloop d2c` first",
            g.dt
        )));
    }
    Ok(g)
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

    fn mul(&self, o: &Rat) -> Result<Rat> {
        check_order((self.num.degree() + o.num.degree()).max(self.den.degree() + o.den.degree()))?;
        Ok(Rat {
            num: &self.num * &o.num,
            den: &self.den * &o.den,
            delay: self.delay + o.delay,
        })
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

// ---------------------------------------------------------------------------------------------
// Realization from the expression tree (see the module documentation).

/// A factored sub-expression `k · Π num / Π den · e^(−delay·s)`; every factor has degree ≥ 1.
#[derive(Debug, Clone)]
struct Fact {
    k: f64,
    num: Vec<Poly>,
    den: Vec<Poly>,
    delay: f64,
}

/// A realized sub-expression: a proper, delay-free SISO model times `e^(−delay·s)`.
#[derive(Debug, Clone)]
struct Sys {
    /// Boxed: keeps `Val` small, so the recursion over deep trees uses little stack.
    g: Box<StateSpace>,
    delay: f64,
}

#[derive(Debug, Clone)]
enum Val {
    F(Fact),
    S(Sys),
}

/// What a sub-expression could not be built as structurally (the caller expands that node instead).
enum Step {
    Done(Val),
    Expand,
}

impl Fact {
    fn constant(k: f64) -> Fact {
        Fact {
            k,
            num: Vec::new(),
            den: Vec::new(),
            delay: 0.0,
        }
    }

    /// `k·p` with constant polynomials folded into the gain.
    fn from_poly(p: Poly, k: f64, delay: f64) -> Fact {
        let mut f = Fact::constant(k);
        f.delay = delay;
        if p.degree() == 0 {
            f.k *= p.leading();
        } else {
            f.num.push(p);
        }
        f
    }

    fn deg(v: &[Poly]) -> usize {
        v.iter().map(Poly::degree).sum()
    }

    fn is_proper(&self) -> bool {
        self.k == 0.0 || Fact::deg(&self.num) <= Fact::deg(&self.den)
    }

    fn order(&self) -> usize {
        Fact::deg(&self.num).max(Fact::deg(&self.den))
    }

    fn inv(&self) -> Result<Fact> {
        if self.k == 0.0 {
            return Err(LtiError::InvalidArgument("division by zero".into()));
        }
        Ok(Fact {
            k: 1.0 / self.k,
            num: self.den.clone(),
            den: self.num.clone(),
            delay: -self.delay,
        })
    }

    /// The product of the numerator factors times k (only for polynomials, den empty).
    fn expand_num(&self) -> Poly {
        self.num.iter().fold(Poly::constant(self.k), |acc, p| &acc * p)
    }
}

fn check_order(n: usize) -> Result<()> {
    if n > MAX_ORDER {
        return Err(LtiError::InvalidArgument(format!(
            "the expression's model would have order {n}; at most {MAX_ORDER} is supported"
        )));
    }
    Ok(())
}

fn sys_order(v: &Val) -> usize {
    match v {
        Val::F(f) => f.order(),
        Val::S(s) => s.g.nx(),
    }
}

/// Delay of a sum of two terms: equal delays (to 1e-12), or the other's when one term is zero.
fn sum_delay(t1: f64, z1: bool, t2: f64, z2: bool) -> Result<f64> {
    if z1 {
        Ok(t2)
    } else if z2 || (t1 - t2).abs() <= 1e-12 * t1.abs().max(t2.abs()) {
        Ok(t1)
    } else {
        Err(LtiError::Unsupported(format!(
            "cannot add terms with different delays ({t1} s and {t2} s): the sum is not one delayed rational model"
        )))
    }
}

fn is_zero_val(v: &Val) -> bool {
    match v {
        Val::F(f) => f.k == 0.0,
        Val::S(s) => s.g.d[(0, 0)] == 0.0 && (0..s.g.nx()).all(|j| s.g.c[(0, j)] == 0.0),
    }
}

fn delay_of(v: &Val) -> f64 {
    match v {
        Val::F(f) => f.delay,
        Val::S(s) => s.delay,
    }
}

/// The realized form of a value, when it is proper.
fn to_sys(v: &Val) -> Result<Option<Sys>> {
    match v {
        Val::S(s) => Ok(Some(s.clone())),
        Val::F(f) if f.is_proper() => Ok(Some(Sys {
            g: Box::new(realize_fact(f)?),
            delay: f.delay,
        })),
        Val::F(_) => Ok(None),
    }
}

fn neg_val(v: Val) -> Val {
    match v {
        Val::F(mut f) => {
            f.k = -f.k;
            Val::F(f)
        }
        Val::S(mut s) => {
            s.g.c = -&s.g.c;
            s.g.d = -&s.g.d;
            Val::S(s)
        }
    }
}

fn add_val(a: &Val, b: &Val) -> Result<Step> {
    let delay = sum_delay(delay_of(a), is_zero_val(a), delay_of(b), is_zero_val(b))?;
    if is_zero_val(a) {
        return Ok(Step::Done(b.clone()));
    }
    if is_zero_val(b) {
        return Ok(Step::Done(a.clone()));
    }
    if let (Val::F(fa), Val::F(fb)) = (a, b) {
        if fa.den.is_empty() && fb.den.is_empty() {
            // A polynomial written as a sum (s^2 + 2*s + 5): one factor of the degree the user wrote.
            let p = &fa.expand_num() + &fb.expand_num();
            return Ok(Step::Done(Val::F(Fact::from_poly(p, 1.0, delay))));
        }
    }
    match (to_sys(a)?, to_sys(b)?) {
        (Some(sa), Some(sb)) => {
            let g = crate::interconnect::parallel(&sa.g, &sb.g)?;
            Ok(Step::Done(Val::S(Sys { g: Box::new(g), delay })))
        }
        // A proper plus an improper term has a polynomial part: expand this node.
        _ => Ok(Step::Expand),
    }
}

fn mul_val(a: &Val, b: &Val) -> Result<Step> {
    check_order(sys_order(a) + sys_order(b))?;
    if let (Val::F(fa), Val::F(fb)) = (a, b) {
        return Ok(Step::Done(Val::F(Fact {
            k: fa.k * fb.k,
            num: [fa.num.clone(), fb.num.clone()].concat(),
            den: [fa.den.clone(), fb.den.clone()].concat(),
            delay: fa.delay + fb.delay,
        })));
    }
    if is_zero_val(a) || is_zero_val(b) {
        return Ok(Step::Done(Val::F(Fact::constant(0.0))));
    }
    match (to_sys(a)?, to_sys(b)?) {
        (Some(sa), Some(sb)) => Ok(Step::Done(Val::S(Sys {
            g: Box::new(series_upper(&sa.g, &sb.g)?),
            delay: sa.delay + sb.delay,
        }))),
        _ => Ok(Step::Expand),
    }
}

/// The inverse of a value: factors swap for a factored form; a biproper realization
/// (A, B, C, D), D ≠ 0, inverts exactly to (A − B D⁻¹ C, B D⁻¹, −D⁻¹ C, D⁻¹).
fn inv_val(v: &Val) -> Result<Option<Val>> {
    match v {
        Val::F(f) => Ok(Some(Val::F(f.inv()?))),
        Val::S(s) => {
            let d = s.g.d[(0, 0)];
            if d == 0.0 {
                return Ok(None); // strictly proper: the inverse is improper
            }
            let g = &s.g;
            let a = &g.a - &g.b * &g.c * (1.0 / d);
            let b = &g.b * (1.0 / d);
            let c = &g.c * (-1.0 / d);
            let dd = Mat::from_fn(1, 1, |_, _| 1.0 / d);
            Ok(Some(Val::S(Sys {
                g: Box::new(StateSpace::new(a, b, c, dd, 0.0)?),
                delay: -s.delay,
            })))
        }
    }
}

/// Series connection u → g1 → g2 → y with the states of g2 first, so that A = [A2 B2·C1; 0 A1] is
/// block upper triangular: a chain of sections is then (quasi-)triangular and its poles are the
/// sections' poles, read off by the eigenvalue solver without mixing the sections.
fn series_upper(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    let (n1, n2) = (g1.nx(), g2.nx());
    let n = n1 + n2;
    let b2c1 = &g2.b * &g1.c;
    let d1 = g1.d[(0, 0)];
    let d2 = g2.d[(0, 0)];
    let a = Mat::from_fn(n, n, |i, j| match (i < n2, j < n2) {
        (true, true) => g2.a[(i, j)],
        (true, false) => b2c1[(i, j - n2)],
        (false, false) => g1.a[(i - n2, j - n2)],
        (false, true) => 0.0,
    });
    let b = Mat::from_fn(n, 1, |i, _| if i < n2 { g2.b[(i, 0)] * d1 } else { g1.b[(i - n2, 0)] });
    let c = Mat::from_fn(1, n, |_, j| if j < n2 { g2.c[(0, j)] } else { d2 * g1.c[(0, j - n2)] });
    StateSpace::new(a, b, c, Mat::from_fn(1, 1, |_, _| d1 * d2), 0.0)
}

/// A real root or a complex-conjugate pair (im > 0) of a factor.
#[derive(Debug, Clone, Copy)]
struct Root {
    re: f64,
    im: f64,
}

impl Root {
    fn mag(&self) -> f64 {
        self.re.hypot(self.im)
    }
    fn degree(&self) -> usize {
        if self.im > 0.0 {
            2
        } else {
            1
        }
    }
}

/// Roots of a factor as real roots and conjugate pairs, and its leading coefficient.
fn factor_roots(p: &Poly, out: &mut Vec<Root>) -> Result<f64> {
    let lead = p.leading();
    match p.degree() {
        0 => {}
        1 => out.push(Root {
            re: -p.coeffs[1] / lead,
            im: 0.0,
        }),
        2 => {
            // s² + b s + c with the cancellation-free quadratic formula.
            let (b, c) = (p.coeffs[1] / lead, p.coeffs[2] / lead);
            let disc = 0.25 * b * b - c;
            if !disc.is_finite() {
                for r in p.roots()? {
                    push_root(r, out);
                }
            } else if disc >= 0.0 {
                let q = -0.5 * b - disc.sqrt().copysign(b);
                if q == 0.0 {
                    out.push(Root { re: 0.0, im: 0.0 });
                    out.push(Root { re: 0.0, im: 0.0 });
                } else {
                    out.push(Root { re: q, im: 0.0 });
                    out.push(Root { re: c / q, im: 0.0 });
                }
            } else {
                out.push(Root {
                    re: -0.5 * b,
                    im: (-disc).sqrt(),
                });
            }
        }
        _ => {
            for r in p.roots()? {
                push_root(r, out);
            }
        }
    }
    Ok(lead)
}

/// Keeps real roots and the upper member of each conjugate pair.
fn push_root(r: c64, out: &mut Vec<Root>) {
    if r.im == 0.0 {
        out.push(Root { re: r.re, im: 0.0 });
    } else if r.im > 0.0 {
        out.push(Root { re: r.re, im: r.im });
    }
}

/// One section's denominator: a real pole, a complex pair, or two real poles.
#[derive(Debug, Clone, Copy)]
enum Den {
    Real(f64),
    Pair(f64, f64),
    Two(f64, f64),
}

impl Den {
    fn degree(&self) -> usize {
        match self {
            Den::Real(_) => 1,
            _ => 2,
        }
    }
    fn poly(&self) -> Poly {
        match *self {
            Den::Real(p) => Poly::new(vec![1.0, -p]),
            Den::Pair(s, w) => Poly::new(vec![1.0, -2.0 * s, s * s + w * w]),
            Den::Two(p1, p2) => Poly::new(vec![1.0, -(p1 + p2), p1 * p2]),
        }
    }
    fn mag(&self) -> f64 {
        match *self {
            Den::Real(p) => p.abs(),
            Den::Pair(s, w) => s.hypot(w),
            Den::Two(p1, p2) => (p1.abs() * p2.abs()).sqrt(),
        }
    }
}

fn root_poly(r: &Root) -> Poly {
    if r.im > 0.0 {
        Poly::new(vec![1.0, -2.0 * r.re, r.re * r.re + r.im * r.im])
    } else {
        Poly::new(vec![1.0, -r.re])
    }
}

/// Balanced realization (A, B, C, D) of the section n(s)/d(s), deg n ≤ deg d ≤ 2, d monic.
fn realize_section(num: &Poly, den: Den) -> Result<StateSpace> {
    let d = den.poly();
    let nn = |k: usize| num.coeff_of_power(k);
    let dd = if den.degree() == num.degree() {
        num.leading()
    } else {
        0.0
    };
    let one = |x: f64| Mat::from_fn(1, 1, |_, _| x);
    // r(s) = n(s) − dd·d(s), the strictly proper remainder.
    let r: Vec<f64> = (0..den.degree()).map(|k| nn(k) - dd * d.coeff_of_power(k)).collect();
    let (a, b, c) = match den {
        Den::Real(p) => {
            let res = r[0];
            let beta = res.abs().sqrt();
            if beta == 0.0 {
                return StateSpace::gain(one(dd), 0.0);
            }
            (one(p), one(beta), one(res / beta))
        }
        Den::Pair(s, w) => {
            // A = [σ ω; −ω σ] (normal), B = [β; 0]: C adj(sI − A) B = c1β(s − σ) − c2ωβ.
            let (r0, r1) = (r[0], r[1]);
            let q = (r0 + r1 * s) / w;
            let beta = r1.hypot(q).sqrt();
            if beta == 0.0 {
                return StateSpace::gain(one(dd), 0.0);
            }
            let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 0) | (1, 1) => s,
                (0, 1) => w,
                _ => -w,
            });
            let b = Mat::from_fn(2, 1, |i, _| if i == 0 { beta } else { 0.0 });
            let c = Mat::from_fn(1, 2, |_, j| if j == 0 { r1 / beta } else { -q / beta });
            (a, b, c)
        }
        Den::Two(p1, p2) => {
            // Triangular: x1' = p1 x1 + m u, x2' = p2 x2 + m x1 (states [x2, x1]); exact even when
            // p1 ≈ p2, unlike partial fractions.
            let (r0, r1) = (r[0], r[1]);
            let m = {
                let g = (p1.abs() * p2.abs()).sqrt();
                if g > 0.0 && g.is_finite() {
                    g
                } else if p1.abs().max(p2.abs()) > 0.0 {
                    p1.abs().max(p2.abs())
                } else {
                    1.0
                }
            };
            let c1 = r1 / m;
            let c2 = (r0 + r1 * p2) / (m * m);
            let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 0) => p2,
                (0, 1) => m,
                (1, 1) => p1,
                _ => 0.0,
            });
            let b = Mat::from_fn(2, 1, |i, _| if i == 1 { m } else { 0.0 });
            let c = Mat::from_fn(1, 2, |_, j| if j == 0 { c2 } else { c1 });
            (a, b, c)
        }
    };
    StateSpace::new(a, b, c, one(dd), 0.0)
}

/// A factored value's total gain, with every factor's leading coefficient folded in, and its roots.
struct FactRoots {
    /// Whether the total gain is negative.
    negative: bool,
    /// Natural logarithm of the total gain's magnitude.
    log_k: f64,
    /// The total gain as a plain product (may over- or underflow).
    k_lin: f64,
    /// Roots of the numerator factors.
    zeros: Vec<Root>,
    /// Roots of the denominator factors.
    poles: Vec<Root>,
}

/// Roots of every factor of `f` and the total gain (its `k` times the factors' leading coefficients).
fn fact_roots(f: &Fact) -> Result<FactRoots> {
    // The gain as sign and natural logarithm: the product of the factors' leading coefficients
    // may leave the floating-point range ((1e-200·s + 1)² has 1e-400) while the realization, whose
    // sections are each scaled near unit gain, does not.
    let mut negative = f.k < 0.0;
    let mut log_k = f.k.abs().ln();
    // The plain product too: exact where it stays in range (exp(ln 1000) is 999.9999999999998).
    let mut k_lin = f.k;
    let mut z = Vec::new();
    let mut p = Vec::new();
    for (q, sign) in f.num.iter().map(|q| (q, 1.0)).chain(f.den.iter().map(|q| (q, -1.0))) {
        let lead = factor_roots(q, if sign > 0.0 { &mut z } else { &mut p })?;
        negative ^= lead < 0.0;
        log_k += sign * lead.abs().ln();
        k_lin = if sign > 0.0 { k_lin * lead } else { k_lin / lead };
    }
    Ok(FactRoots {
        negative,
        log_k,
        k_lin,
        zeros: z,
        poles: p,
    })
}

/// The error for a total gain `e^log_k` outside the floating-point range.
fn gain_out_of_range(log_k: f64) -> LtiError {
    LtiError::InvalidArgument(format!(
        "the expression's gain e^{log_k:.4} is out of the floating-point range"
    ))
}

/// Removes from `p` the roots shared with `z`; returns the zeros left.
fn cancel_common_roots(z: Vec<Root>, p: &mut Vec<Root>) -> Vec<Root> {
    // Cancel roots shared by numerator and denominator (to 1e-10 relative, as tf_to_ss does).
    let mut zk = Vec::new();
    for r in z {
        let hit = p.iter().position(|q: &Root| {
            q.degree() == r.degree() && (q.re - r.re).hypot(q.im - r.im) <= 1e-10 * (1.0 + r.mag())
        });
        match hit {
            Some(i) => {
                p.remove(i);
            }
            None => zk.push(r),
        }
    }
    zk
}

/// Removes and returns the real pole whose magnitude is nearest `m` (rad/s).
fn take_nearest_real(reals: &mut Vec<f64>, m: f64) -> Option<f64> {
    let i = reals
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1.abs() - m).abs().total_cmp(&(b.1.abs() - m).abs()))
        .map(|(i, _)| i)?;
    Some(reals.remove(i))
}

/// Removes and returns the complex pole pair (σ, ω) whose magnitude is nearest `m` (rad/s).
fn take_nearest_pair(pairs: &mut Vec<(f64, f64)>, m: f64) -> Option<(f64, f64)> {
    let i = (0..pairs.len()).min_by(|&a, &b| {
        (pairs[a].0.hypot(pairs[a].1) - m)
            .abs()
            .total_cmp(&(pairs[b].0.hypot(pairs[b].1) - m).abs())
    })?;
    Some(pairs.remove(i))
}

/// The poles by increasing magnitude, split into real poles and complex pairs (σ, ω).
fn split_poles(mut p: Vec<Root>) -> (Vec<f64>, Vec<(f64, f64)>) {
    let mut reals: Vec<f64> = Vec::new();
    let mut pairs: Vec<(f64, f64)> = Vec::new();
    p.sort_by(|a, b| a.mag().total_cmp(&b.mag()));
    for r in &p {
        if r.im > 0.0 {
            pairs.push((r.re, r.im));
        } else {
            reals.push(r.re);
        }
    }
    (reals, pairs)
}

/// First- and second-order sections pairing the zeros `z` with the poles `p`; improper if a zero is left.
fn pair_sections(mut z: Vec<Root>, p: Vec<Root>) -> Result<Vec<(Poly, Den)>> {
    // Pair zeros with poles: complex zero pairs need a second-order denominator (a complex pole
    // pair, else two real poles); real zeros take a real pole, else share a second-order one.
    let mut sections: Vec<(Poly, Den)> = Vec::new();
    let (mut reals, mut pairs) = split_poles(p);
    z.sort_by_key(|r| std::cmp::Reverse(r.degree()));
    let mut pending_real_zero: Option<Root> = None;
    let mut open_quadratics: Vec<(Poly, Den)> = Vec::new();
    for r in z {
        if r.degree() == 2 {
            let den = if let Some((s, w)) = take_nearest_pair(&mut pairs, r.mag()) {
                Den::Pair(s, w)
            } else {
                match (
                    take_nearest_real(&mut reals, r.mag()),
                    take_nearest_real(&mut reals, r.mag()),
                ) {
                    (Some(p1), Some(p2)) => Den::Two(p1, p2),
                    _ => return Err(improper()),
                }
            };
            sections.push((root_poly(&r), den));
        } else if let Some(p1) = take_nearest_real(&mut reals, r.mag()) {
            sections.push((root_poly(&r), Den::Real(p1)));
        } else if let Some(prev) = pending_real_zero.take() {
            // Two real zeros left over for one complex pole pair: the pair nearest their geometric
            // mean, so the section's gain stays near 1 below its corner. Paired with a far pole
            // pair, D ≈ 1 and the low-frequency gain z₁z₂/ω² ≪ 1 came out of a cancellation,
            // and 15 such sections in a chain lost 5e-6 of the response at 0.1 Hz.
            let (s, w) = take_nearest_pair(&mut pairs, (prev.mag() * r.mag()).sqrt()).ok_or_else(improper)?;
            open_quadratics.push((&root_poly(&prev) * &root_poly(&r), Den::Pair(s, w)));
        } else {
            pending_real_zero = Some(r);
        }
    }
    if let Some(r) = pending_real_zero {
        let (s, w) = take_nearest_pair(&mut pairs, r.mag()).ok_or_else(improper)?;
        sections.push((root_poly(&r), Den::Pair(s, w)));
    }
    sections.extend(open_quadratics);
    for p1 in reals {
        sections.push((Poly::one(), Den::Real(p1)));
    }
    for (s, w) in pairs {
        sections.push((Poly::one(), Den::Pair(s, w)));
    }
    Ok(sections)
}

/// The static gain of a value with no sections left: the plain product where it is usable.
fn constant_gain(k_lin: f64, negative: bool, log_k: f64) -> Result<StateSpace> {
    let k = if k_lin.is_finite() && k_lin != 0.0 {
        k_lin
    } else if negative {
        -log_k.exp()
    } else {
        log_k.exp()
    };
    if !k.is_finite() || k == 0.0 {
        return Err(gain_out_of_range(log_k));
    }
    StateSpace::gain(Mat::from_fn(1, 1, |_, _| k), 0.0)
}

/// A section's gain magnitude at its corner frequency (else at 2× it, else at 1 rad/s); 1 if none is usable.
fn section_gain(num: &Poly, den: &Den) -> f64 {
    let w0 = if den.mag() > 0.0 && den.mag().is_finite() {
        den.mag()
    } else {
        1.0
    };
    let mut g = 0.0;
    for w in [w0, 2.0 * w0, 1.0] {
        let s = c64::new(0.0, w);
        let v = (num.eval(s) / den.poly().eval(s)).norm();
        if v > 0.0 && v.is_finite() {
            g = v;
            break;
        }
    }
    if g > 0.0 {
        g
    } else {
        1.0
    }
}

/// The sections realized and chained, with the total gain `±e^log_k` spread evenly over them.
fn realize_sections(sections: &[(Poly, Den)], mut log_k: f64, negative: bool) -> Result<StateSpace> {
    // Each section scaled to unit gain at its own corner frequency, the total gain spread evenly
    // (in logarithms, so 1e±300 gains neither overflow nor leave one section with all of it).
    let mut models = Vec::with_capacity(sections.len());
    for (num, den) in sections {
        let g = section_gain(num, den);
        log_k += g.ln();
        models.push((realize_section(num, *den)?, g));
    }
    let per = log_k / models.len() as f64;
    let mut scaled = Vec::with_capacity(models.len());
    for (i, (mut m, g)) in models.into_iter().enumerate() {
        let mut f = (per - g.ln()).exp();
        if i == 0 && negative {
            f = -f;
        }
        if !f.is_finite() || f == 0.0 {
            return Err(gain_out_of_range(log_k));
        }
        // Split the factor between B and C so both stay balanced.
        let h = f.abs().sqrt();
        m.b = &m.b * h;
        m.c = &m.c * (f / h);
        m.d = &m.d * f;
        scaled.push(m);
    }
    chain(&scaled)
}

/// The state-space model of a proper factored value: roots of every factor, common roots
/// cancelled, zeros paired with poles into first- and second-order sections, the gain spread evenly
/// over the sections, and the sections chained by [`series_upper`].
fn realize_fact(f: &Fact) -> Result<StateSpace> {
    if f.k == 0.0 {
        return StateSpace::gain(Mat::from_fn(1, 1, |_, _| 0.0), 0.0);
    }
    let FactRoots {
        negative,
        log_k,
        k_lin,
        zeros,
        mut poles,
    } = fact_roots(f)?;
    if !log_k.is_finite() {
        return Err(gain_out_of_range(log_k));
    }
    let zeros = cancel_common_roots(zeros, &mut poles);
    let sections = pair_sections(zeros, poles)?;
    if sections.is_empty() {
        return constant_gain(k_lin, negative, log_k);
    }
    realize_sections(&sections, log_k, negative)
}

/// The series connection u → m[0] → m[1] → … → y of SISO sections, assembled in one pass (O(n²)
/// entries, where pairwise connections would copy O(n²) per section), with the states of the last
/// section first so that A is block upper triangular as in [`series_upper`].
fn chain(models: &[StateSpace]) -> Result<StateSpace> {
    let n: usize = models.iter().map(StateSpace::nx).sum();
    // Natural order first (section 0's states first): section i sees u_i = w·x + dprod·u.
    let mut a = Mat::<f64>::zeros(n, n);
    let mut b = Mat::<f64>::zeros(n, 1);
    let mut w = vec![0.0; n];
    let mut dprod = 1.0;
    let mut offsets = Vec::with_capacity(models.len());
    let mut off = 0;
    for m in models {
        let ni = m.nx();
        offsets.push(off);
        for r in 0..ni {
            for c in 0..ni {
                a[(off + r, off + c)] = m.a[(r, c)];
            }
            let bi = m.b[(r, 0)];
            for (c, &wc) in w.iter().enumerate().take(off) {
                a[(off + r, c)] = bi * wc;
            }
            b[(off + r, 0)] = bi * dprod;
        }
        let di = m.d[(0, 0)];
        for wc in w.iter_mut().take(off) {
            *wc *= di;
        }
        for c in 0..ni {
            w[off + c] = m.c[(0, c)];
        }
        dprod *= di;
        off += ni;
    }
    // Reverse the order of the sections (not of the states within a section).
    let mut perm = Vec::with_capacity(n);
    for (m, &o) in models.iter().zip(&offsets).rev() {
        perm.extend(o..o + m.nx());
    }
    let ap = Mat::from_fn(n, n, |i, j| a[(perm[i], perm[j])]);
    let bp = Mat::from_fn(n, 1, |i, _| b[(perm[i], 0)]);
    let cp = Mat::from_fn(1, n, |_, j| w[perm[j]]);
    StateSpace::new(ap, bp, cp, Mat::from_fn(1, 1, |_, _| dprod), 0.0)
}

fn improper() -> LtiError {
    LtiError::Unsupported(
        "the transfer function is improper (numerator degree above denominator degree); it has no state-space form"
            .into(),
    )
}

impl Expr {
    /// The SISO state-space model of the expression with its exact delay, built from the
    /// expression tree without multiplying out polynomials (see the module documentation).
    pub fn to_ss(&self, params: &HashMap<String, f64>) -> Result<StateSpace> {
        let v = self.realize(params, &Cell::new(0))?;
        let delay = delay_of(&v);
        if delay < 0.0 {
            return Err(LtiError::Unsupported(format!(
                "the net delay is negative ({delay} s): the model would be a prediction"
            )));
        }
        let sys = to_sys(&v)?.ok_or_else(improper)?;
        sys.g.with_delays(vec![delay], vec![0.0])
    }

    /// Zeros, poles and gain with the net delay: from the roots of each factor as written when the
    /// expression is a product of factors (nothing multiplied out: the 25 poles of `1/(s+1)^25` are
    /// exactly −1), else from its realization ([`Zpk::from_ss`](crate::zpk::Zpk::from_ss)). Common
    /// factors are kept, as a zero-pole-gain form states them.
    pub fn to_zpk(&self, params: &HashMap<String, f64>) -> Result<crate::zpk::Zpk> {
        let v = self.realize(params, &Cell::new(0))?;
        let delay = delay_of(&v);
        if delay < 0.0 {
            return Err(LtiError::Unsupported(format!(
                "the net delay is negative ({delay} s): the model would be a prediction"
            )));
        }
        let mut out = match v {
            Val::F(f) => {
                let roots = |fs: &[Poly], k: &mut f64, inv: bool| -> Result<Vec<c64>> {
                    let mut r = Vec::new();
                    for q in fs {
                        let lead = factor_roots(q, &mut r)?;
                        *k = if inv { *k / lead } else { *k * lead };
                    }
                    Ok(r.iter()
                        .flat_map(|x| {
                            if x.im > 0.0 {
                                vec![c64::new(x.re, x.im), c64::new(x.re, -x.im)]
                            } else {
                                vec![c64::new(x.re, 0.0)]
                            }
                        })
                        .collect())
                };
                let mut k = f.k;
                if k == 0.0 {
                    crate::zpk::Zpk::siso(Vec::new(), Vec::new(), 0.0, 0.0)
                } else {
                    let z = roots(&f.num, &mut k, false)?;
                    let p = roots(&f.den, &mut k, true)?;
                    crate::zpk::Zpk::siso(z, p, k, 0.0)
                }
            }
            Val::S(s) => crate::zpk::Zpk::from_ss(&s.g)?,
        };
        out.input_delay = vec![delay];
        Ok(out)
    }

    /// `visits` counts realized nodes over the whole call: structurally equal sub-trees (G in
    /// `G/(1 + G·H)`) are realized more than once when no shortcut applies, which nested forms could
    /// turn exponential, so the count is bounded by [`MAX_REALIZE_VISITS`].
    fn realize(&self, params: &HashMap<String, f64>, visits: &Cell<usize>) -> Result<Val> {
        visits.set(visits.get() + 1);
        if visits.get() > MAX_REALIZE_VISITS {
            return Err(LtiError::InvalidArgument(format!(
                "the expression is too complex to realize (more than {MAX_REALIZE_VISITS} sub-expression visits)"
            )));
        }
        let step = match self {
            Expr::Num(x) => Step::Done(Val::F(Fact::constant(*x))),
            Expr::S => Step::Done(Val::F(Fact::from_poly(Poly::s(), 1.0, 0.0))),
            Expr::Param(n) => Step::Done(Val::F(Fact::constant(param_value(n, params)?))),
            Expr::Model(g) => Step::Done(Val::S(Sys {
                g: Box::new(without_delay(g)),
                delay: model_delay(g),
            })),
            Expr::Neg(a) => Step::Done(neg_val(a.realize(params, visits)?)),
            Expr::Add(a, b) => add_val(&a.realize(params, visits)?, &b.realize(params, visits)?)?,
            Expr::Sub(a, b) => add_val(&a.realize(params, visits)?, &neg_val(b.realize(params, visits)?))?,
            Expr::Mul(a, b) => mul_val(&a.realize(params, visits)?, &b.realize(params, visits)?)?,
            Expr::Div(a, b) => {
                let va = a.realize(params, visits)?;
                match self.feedback_form(&va, a, b, params, visits)? {
                    Some(v) => Step::Done(v),
                    None => {
                        match inv_val(&b.realize(params, visits)?)? {
                            Some(ib) => {
                                let step = mul_val(&va, &ib)?;
                                // A divisor realized as a sum was inverted: the product may carry
                                // modes that cancel (e.g. (1/(s+1)) / (1 + 1/(s+1))); remove them.
                                match (step, &ib) {
                                    (Step::Done(Val::S(s)), Val::S(_)) => Step::Done(Val::S(Sys {
                                        g: Box::new(crate::minreal::minreal(&s.g, None)?),
                                        delay: s.delay,
                                    })),
                                    (st, _) => st,
                                }
                            }
                            None => Step::Expand,
                        }
                    }
                }
            }
            Expr::Pow(a, k) => {
                let base = a.realize(params, visits)?;
                let base = if *k < 0 { inv_val(&base)? } else { Some(base) };
                match base {
                    None => Step::Expand,
                    Some(b) => {
                        let n = k.unsigned_abs() as usize;
                        check_order(sys_order(&b).saturating_mul(n))?;
                        let mut acc = Step::Done(Val::F(Fact::constant(1.0)));
                        for _ in 0..n {
                            acc = match acc {
                                Step::Done(v) => mul_val(&v, &b)?,
                                Step::Expand => Step::Expand,
                            };
                        }
                        acc
                    }
                }
            }
            Expr::Exp(_) => {
                let r = self.rational(params)?;
                let k = r.num.leading();
                if !k.is_finite() {
                    return Err(LtiError::InvalidArgument(format!(
                        "exp(...): the constant factor {k} is out of the floating-point range"
                    )));
                }
                Step::Done(Val::F(Fact {
                    k,
                    num: Vec::new(),
                    den: Vec::new(),
                    delay: r.delay,
                }))
            }
        };
        match step {
            Step::Done(v) => Ok(v),
            Step::Expand => {
                // Structure gave no proper realization of this node: fall back to its rational
                // (polynomial) form, which is exact but multiplies out this node's factors.
                let r = self.rational(params)?;
                if r.num.is_zero() {
                    return Ok(Val::F(Fact::constant(0.0)));
                }
                let mut f = Fact::from_poly(r.num, 1.0, r.delay);
                let fd = Fact::from_poly(r.den, 1.0, 0.0);
                f.k /= fd.k;
                f.den = fd.num;
                Ok(Val::F(f))
            }
        }
    }

    /// `G/(c + G·H)` and `G/(c − G·H)` (also `G/(c ± G)`) as a feedback interconnection, when G and
    /// H are proper and delay-free: the closed loop has the states of G and H once.
    fn feedback_form(
        &self,
        va: &Val,
        num: &Expr,
        den: &Expr,
        params: &HashMap<String, f64>,
        visits: &Cell<usize>,
    ) -> Result<Option<Val>> {
        let (c, x, sign) = match den {
            Expr::Add(l, r) => match (&**l, &**r) {
                (Expr::Num(c), x) | (x, Expr::Num(c)) => (*c, x, -1.0),
                _ => return Ok(None),
            },
            Expr::Sub(l, r) => match (&**l, &**r) {
                (Expr::Num(c), x) => (*c, x, 1.0),
                _ => return Ok(None),
            },
            _ => return Ok(None),
        };
        if c == 0.0 {
            return Ok(None);
        }
        let h: Option<Expr> = if x == num {
            Some(Expr::Num(1.0))
        } else if let Expr::Mul(p, q) = x {
            if &**p == num {
                Some((**q).clone())
            } else if &**q == num {
                Some((**p).clone())
            } else {
                None
            }
        } else {
            None
        };
        let Some(h) = h else { return Ok(None) };
        let (Some(g), Some(hs)) = (to_sys(va)?, to_sys(&h.realize(params, visits)?)?) else {
            return Ok(None);
        };
        if g.delay != 0.0 || hs.delay != 0.0 {
            return Ok(None);
        }
        // G/(c ± G·H) = (1/c)·G/(1 ± G·H/c).
        let mut hc = hs.g;
        hc.c = &hc.c * (1.0 / c);
        hc.d = &hc.d * (1.0 / c);
        let mut cl = match crate::interconnect::feedback(&g.g, &hc, sign) {
            Ok(cl) => cl,
            Err(_) => return Ok(None),
        };
        cl.c = &cl.c * (1.0 / c);
        cl.d = &cl.d * (1.0 / c);
        Ok(Some(Val::S(Sys {
            g: Box::new(cl),
            delay: 0.0,
        })))
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
    /// A file reference `@path` (the path without the `@` and quotes).
    File(String),
    End,
}

impl Tok {
    /// The token as written (for fix suggestions).
    fn text(&self) -> String {
        match self {
            Tok::Num(x) => format!("{x}"),
            Tok::Ident(n) => n.clone(),
            Tok::Op(c) => c.to_string(),
            Tok::File(p) => format!("@{p}"),
            Tok::End => String::new(),
        }
    }

    fn describe(&self) -> String {
        match self {
            Tok::Num(x) => format!("the number {x}"),
            Tok::Ident(n) => format!("'{n}'"),
            Tok::Op(c) => format!("'{c}'"),
            Tok::File(p) => format!("the file reference '@{p}'"),
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
        } else if c == '@' {
            let (path, next) = file_reference(&ch, i)?;
            out.push((Tok::File(path), col));
            i = next;
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

/// The path of the file reference whose `@` is at `at`, and the index after it: a quoted path
/// (`@"…"`), or the shortest run of non-space characters ending in `.json`.
fn file_reference(ch: &[char], at: usize) -> Result<(String, usize)> {
    let column = at + 1;
    if ch.get(at + 1) == Some(&'"') {
        let end = (at + 2..ch.len())
            .find(|&j| ch[j] == '"')
            .ok_or_else(|| LtiError::Parse {
                column,
                message: "the quoted file name after '@\"' has no closing '\"'".into(),
            })?;
        let path: String = ch[at + 2..end].iter().collect();
        if path.is_empty() {
            return Err(LtiError::Parse {
                column,
                message: "an empty file name after '@'".into(),
            });
        }
        return Ok((path, end + 1));
    }
    let mut j = at + 1;
    while j < ch.len() && !ch[j].is_whitespace() {
        j += 1;
        let tail: String = ch[at + 1..j].iter().collect();
        if tail.len() > 5 && tail.to_ascii_lowercase().ends_with(".json") {
            return Ok((tail, j));
        }
    }
    Err(LtiError::Parse {
        column,
        message: "after '@' a model file: a name ending in .json (@C.json) or a quoted path (@\"C model.txt\")".into(),
    })
}

struct Parser {
    /// The transfer function's variable: "s", or "z" for a discrete model.
    var: &'static str,
    toks: Vec<(Tok, usize)>,
    pos: usize,
    /// Current recursion depth (parentheses, signs, exp calls).
    depth: usize,
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

    /// Checks a new node's depth in the tree: deeper trees would overflow the recursive
    /// evaluation and realization (and even dropping the tree), so they are refused while parsing.
    fn node(&self, e: Expr, d: usize) -> Result<(Expr, usize)> {
        if d > MAX_TREE_DEPTH {
            return Err(self.err(format!(
                "the expression is too long: its tree would be deeper than {MAX_TREE_DEPTH} operations"
            )));
        }
        Ok((e, d))
    }

    fn sum(&mut self) -> Result<(Expr, usize)> {
        let (mut e, mut d) = self.product()?;
        loop {
            let op = match self.peek() {
                Tok::Op(c @ ('+' | '-')) => *c,
                _ => return Ok((e, d)),
            };
            self.bump();
            let (r, dr) = self.product()?;
            let dn = d.max(dr) + 1;
            let n = if op == '+' {
                Expr::Add(Box::new(e), Box::new(r))
            } else {
                Expr::Sub(Box::new(e), Box::new(r))
            };
            (e, d) = self.node(n, dn)?;
        }
    }

    fn product(&mut self) -> Result<(Expr, usize)> {
        let (mut e, mut d) = self.unary()?;
        loop {
            let op = match self.peek() {
                Tok::Op(c @ ('*' | '/')) => *c,
                _ => return Ok((e, d)),
            };
            self.bump();
            let (r, dr) = self.unary()?;
            let dn = d.max(dr) + 1;
            let n = if op == '*' {
                Expr::Mul(Box::new(e), Box::new(r))
            } else {
                Expr::Div(Box::new(e), Box::new(r))
            };
            (e, d) = self.node(n, dn)?;
        }
    }

    /// Enters one nesting level; errors past [`MAX_DEPTH`] instead of overflowing the stack.
    fn enter(&mut self) -> Result<()> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err(format!(
                "the expression nests deeper than {MAX_DEPTH} levels of parentheses, signs or exp(...)"
            )));
        }
        Ok(())
    }

    fn unary(&mut self) -> Result<(Expr, usize)> {
        self.enter()?;
        let e = match self.peek() {
            Tok::Op('-') => {
                self.bump();
                match self.unary() {
                    Ok((e, d)) => self.node(Expr::Neg(Box::new(e)), d + 1),
                    Err(e) => Err(e),
                }
            }
            Tok::Op('+') => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        };
        self.depth -= 1;
        e
    }

    fn power(&mut self) -> Result<(Expr, usize)> {
        let (base, d) = self.primary()?;
        if self.peek() != &Tok::Op('^') {
            return Ok((base, d));
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
                self.node(Expr::Pow(Box::new(base), if neg { -k } else { k }), d + 1)
            }
            t => Err(self.err(format!(
                "expected an integer exponent (at most 1000) after '^', found {}",
                t.describe()
            ))),
        }
    }

    fn primary(&mut self) -> Result<(Expr, usize)> {
        let col = self.col();
        match self.bump() {
            Tok::Num(x) => Ok((Expr::Num(x), 1)),
            Tok::Ident(n) if n == self.var => Ok((Expr::S, 1)),
            Tok::Ident(n) if n == "exp" && self.var == "z" => Err(LtiError::Parse {
                column: col,
                message: "a discrete model's delay is written z^-k (k samples), not exp(...)".into(),
            }),
            Tok::Ident(n) if n == "s" && self.var == "z" => Err(LtiError::Parse {
                column: col,
                message: "a discrete model (given a sample time) is written in z, not s".into(),
            }),
            Tok::Ident(n) if n == "exp" => {
                if self.peek() != &Tok::Op('(') {
                    return Err(self.err(format!("expected '(' after 'exp', found {}", self.peek().describe())));
                }
                self.bump();
                let (arg, d) = self.sum()?;
                self.close(col)?;
                self.node(Expr::Exp(Box::new(arg)), d + 1)
            }
            Tok::Ident(n) => {
                if self.peek() == &Tok::Op('(') {
                    return Err(LtiError::Parse {
                        column: col,
                        message: format!("unknown function '{n}' (only exp is known; write {n}*(...) to multiply)"),
                    });
                }
                Ok((Expr::Param(n), 1))
            }
            Tok::Op('(') => {
                let e = self.sum()?;
                self.close(col)?;
                Ok(e)
            }
            Tok::File(path) => {
                if self.var == "z" {
                    return Err(LtiError::Parse {
                        column: col,
                        message: "file references (@FILE) are read into expressions in s only".into(),
                    });
                }
                Ok((Expr::Model(Box::new(read_model_file(&path, col)?)), 1))
            }
            t => {
                self.pos -= usize::from(t != Tok::End);
                Err(self.err(format!(
                    "expected a number, 's', a parameter, 'exp(', '(' or @FILE, found {}",
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
    fn zpk_from_the_factors() {
        let m = HashMap::new();
        let z = parse("2/(s+1)^25").unwrap().to_zpk(&m).unwrap();
        assert_eq!(z.p[0][0].len(), 25);
        assert!(z.p[0][0].iter().all(|p| *p == c64::new(-1.0, 0.0)));
        assert_eq!(z.k[0][0], 2.0);
        let z = parse(BICOPTER).unwrap().to_zpk(&m).unwrap();
        assert_eq!((z.z[0][0].len(), z.p[0][0].len()), (2, 4));
        assert_eq!(z.input_delay, vec![0.032]);
        let s = c64::new(0.0, 9.2);
        let want = bicopter_direct(s) / (-0.032 * s).exp();
        let zp: c64 = z.z[0][0].iter().map(|r| s - r).product();
        let pp: c64 = z.p[0][0].iter().map(|r| s - r).product();
        let got = zp / pp * z.k[0][0];
        assert!((got - want).norm() < 1e-12 * want.norm(), "{got} vs {want}");
        // A sum goes through its realization.
        let z = parse("1/(s+1) + 1/(s+2)").unwrap().to_zpk(&m).unwrap();
        assert_eq!(z.p[0][0].len(), 2);
    }

    #[test]
    fn edges_of_the_grammar() {
        // Missing '*': the message names the fix.
        let msg = parse("2s").unwrap_err().to_string();
        assert!(msg.contains("write 2*s"), "{msg}");
        let msg = parse("s(s+1)").unwrap_err().to_string();
        assert!(msg.contains("write s*(s+1)") || msg.contains("write s*("), "{msg}");
        let msg = parse("(s+1)(s+2)").unwrap_err().to_string();
        assert!(msg.contains("write )*("), "{msg}");
        // A leading minus.
        let m = HashMap::new();
        let v = parse("-1/(s+1)").unwrap().eval(c64::new(0.0, 0.0), &m).unwrap();
        assert_eq!(v.re, -1.0);
        let g = parse_model("-2/(s+1)").unwrap();
        assert_eq!(g.nx(), 1);
        // Nesting: 11,000 parentheses is an error naming the limit, not a stack overflow.
        let deep = format!("{}s{}", "(".repeat(11_000), ")".repeat(11_000));
        let msg = parse(&deep).unwrap_err().to_string();
        assert!(msg.contains(&MAX_DEPTH.to_string()), "{msg}");
        let ok = format!("{}s{}", "(".repeat(150), ")".repeat(150));
        assert!(parse(&ok).is_ok());
        let signs = "-".repeat(5000) + "s";
        assert!(parse(&signs).is_err());
        // A very long sum is refused before its tree is too deep to walk (or drop).
        let long = vec!["1"; 20_000].join("+");
        let msg = parse(&long).unwrap_err().to_string();
        assert!(msg.contains("too long"), "{msg}");
        // The deepest accepted tree is walked without overflowing a test thread's 2 MB stack.
        let deepest = vec!["1"; MAX_TREE_DEPTH].join("+");
        assert_eq!(
            parse(&deepest).unwrap().eval(c64::new(0.0, 1.0), &m).unwrap().re,
            MAX_TREE_DEPTH as f64
        );
        assert_eq!(parse_model(&deepest).unwrap().d[(0, 0)], MAX_TREE_DEPTH as f64);
        let products = vec!["1/(s+2)"; MAX_TREE_DEPTH / 2 - 1].join("*");
        assert_eq!(parse_model(&products).unwrap().nx(), MAX_TREE_DEPTH / 2 - 1);
        let sum: String = (1..=500).map(|k| format!("1/(s+{k})")).collect::<Vec<_>>().join("+");
        assert_eq!(parse_model(&sum).unwrap().nx(), 500);
        // Orders beyond the bound are errors, also for the polynomial path.
        assert!(parse_model("1/((s+1)^1000)^1000").is_err());
        assert!(parse("((s+1)^1000)^1000").unwrap().to_tf(&m).is_err());
        assert!(parse_model("1/(s+1)^1000").is_ok());
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
