//! `skyloop._skyloop`: the compiled half of the Python package. Every function converts numpy in,
//! calls one `skyloop` library function with the GIL released and panics caught, and converts out;
//! no numerics live here. Units follow the library: rad/s, s, dB, degrees, as the names say.

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{Complex64, IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use pyo3::IntoPyObjectExt;
use skyloop::lti::{c64, Mat, StateSpace};
use std::f64::consts::TAU;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

create_exception!(
    _skyloop,
    SkyloopError,
    PyException,
    "Base class of every error skyloop raises; the message is the Rust error's."
);
create_exception!(
    _skyloop,
    LinalgError,
    SkyloopError,
    "Dense numerics failed (Schur, Riccati, Lyapunov, ...)."
);
create_exception!(
    _skyloop,
    ModelError,
    SkyloopError,
    "A model or classical analysis failed: bad dimensions, parse error, unsupported delay, ..."
);
create_exception!(
    _skyloop,
    RobustError,
    SkyloopError,
    "Robust synthesis or analysis failed: infeasible γ, unstabilizable modes, ..."
);
create_exception!(
    _skyloop,
    SysidError,
    SkyloopError,
    "Identification or log reading failed."
);
create_exception!(
    _skyloop,
    SimError,
    SkyloopError,
    "Nonlinear simulation failed (invalid vehicle, controller or scenario)."
);
create_exception!(
    _skyloop,
    InputError,
    SkyloopError,
    "An argument outside what the function accepts; the message names it."
);
create_exception!(
    _skyloop,
    FileError,
    SkyloopError,
    "A file that could not be read or written."
);
create_exception!(
    _skyloop,
    InternalError,
    SkyloopError,
    "A panic inside skyloop, caught at the boundary (a bug: please report it)."
);

/// The Python exception for a library error, by its cause.
fn py_err(e: skyloop::Error) -> PyErr {
    use skyloop::Error as E;
    let msg = e.to_string();
    match e {
        E::Linalg(_) => LinalgError::new_err(msg),
        E::Lti(_) => ModelError::new_err(msg),
        E::Robust(_) => RobustError::new_err(msg),
        E::Sysid(_) => SysidError::new_err(msg),
        E::Sim(_) => SimError::new_err(msg),
        E::Spec(_) | E::Input(_) => InputError::new_err(msg),
        E::Io { .. } => FileError::new_err(msg),
        _ => SkyloopError::new_err(msg),
    }
}

fn input_err(msg: impl Into<String>) -> PyErr {
    InputError::new_err(msg.into())
}

/// Runs `f` without the GIL and with panics caught, so a bug in skyloop is a Python exception,
/// never a crash across the FFI.
fn guarded<T: Send, E: Into<skyloop::Error> + Send>(
    py: Python<'_>,
    f: impl FnOnce() -> Result<T, E> + Send,
) -> PyResult<T> {
    match py.allow_threads(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(py_err(e.into())),
        Err(p) => {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(InternalError::new_err(format!("internal error in skyloop: {what}")))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Conversions

fn mat_from(a: &PyReadonlyArray2<'_, f64>) -> Mat<f64> {
    let v = a.as_array();
    Mat::from_fn(v.nrows(), v.ncols(), |i, j| v[[i, j]])
}

fn mat_to<'py>(py: Python<'py>, m: &Mat<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

fn cvec_to<'py>(py: Python<'py>, v: &[c64]) -> Bound<'py, PyArray1<Complex64>> {
    Array1::from_iter(v.iter().map(|z| Complex64::new(z.re, z.im))).into_pyarray(py)
}

fn vec_to<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(v.to_vec()).into_pyarray(py)
}

/// `[a][b][k]` nested vectors as a 3-D array.
fn cube_to<'py>(py: Python<'py>, v: &[Vec<Vec<f64>>]) -> Bound<'py, PyArray3<f64>> {
    let (n0, n1) = (v.len(), v.first().map_or(0, |r| r.len()));
    let n2 = v.first().and_then(|r| r.first()).map_or(0, |x| x.len());
    Array3::from_shape_fn((n0, n1, n2), |(i, j, k)| v[i][j][k]).into_pyarray(py)
}

/// A JSON value (the CLI's shapes, built by the library) as plain Python objects.
fn json_to_py(py: Python<'_>, v: &serde_json::Value) -> PyResult<PyObject> {
    use serde_json::Value as V;
    Ok(match v {
        V::Null => py.None(),
        V::Bool(b) => (*b).into_py_any(py)?,
        V::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_py_any(py)?,
            (None, Some(u)) => u.into_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_py_any(py)?,
        },
        V::String(s) => s.into_py_any(py)?,
        V::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(json_to_py(py, x)?)?;
            }
            l.into_any().unbind()
        }
        V::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any().unbind()
        }
    })
}

fn ser_to_py(py: Python<'_>, v: &impl serde::Serialize) -> PyResult<PyObject> {
    let j = serde_json::to_value(v).map_err(|e| SkyloopError::new_err(format!("cannot encode result: {e}")))?;
    json_to_py(py, &j)
}

fn hz(w: f64) -> f64 {
    w / TAU
}

// ---------------------------------------------------------------------------------------------
// Models

/// A linear time-invariant model in state-space form, with exact input and output delays.
///
/// Continuous time when ``dt == 0``, else discrete with sample period ``dt`` seconds. Build one with
/// :func:`skyloop.ss` or :func:`skyloop.tf`. ``a * b`` is the series connection (``b`` first, then
/// ``a``, as python-control), ``a + b`` / ``a - b`` the parallel sum / difference, ``a / b`` and
/// ``a ** n`` through the inverse; numbers, 2-D arrays (``np.eye(2) * G`` is a series connection:
/// ``__array_priority__``), :class:`skyloop.TransferFunction` and python-control models combine with
/// it. ``G(x)`` is the response at the complex point x (or an array of them), ``G[i, j]`` a
/// subsystem; python-control's methods ``poles() zeros() dcgain() freqresp(w) bode(w) step(t)
/// feedback(K) minreal() c2d(dt) sample(dt) hinf_norm() h2_norm()`` and ``margins()`` are here.
/// Models pickle (through their LTI JSON), so they travel to Dask or Ray workers.
///
/// >>> import skyloop as sk
/// >>> G = sk.ss([[-1.0]], [[1.0]], [[2.0]], [[0.0]])
/// >>> G.dcgain(), complex(G(1j))
/// (2.0, (1-1j))
/// >>> sk.feedback(G).poles()
/// array([-3.+0.j])
#[pyclass(name = "StateSpace", module = "skyloop", frozen)]
#[derive(Clone)]
pub struct PyStateSpace {
    inner: StateSpace,
}

fn wrap(inner: StateSpace) -> PyStateSpace {
    PyStateSpace { inner }
}

/// `other` as a model next to `me`: a StateSpace, a number k (k·I of size `n`) or a 2-D array (a gain).
fn as_model(other: &Bound<'_, PyAny>, n: usize, dt: f64) -> PyResult<Option<StateSpace>> {
    if let Ok(s) = other.downcast::<PyStateSpace>() {
        return Ok(Some(s.get().inner.clone()));
    }
    if let Ok(k) = other.extract::<f64>() {
        let d = Mat::from_fn(n, n, |i, j| if i == j { k } else { 0.0 });
        return StateSpace::gain(d, dt).map(Some).map_err(|e| py_err(e.into()));
    }
    if let Ok(a) = other.extract::<PyReadonlyArray2<'_, f64>>() {
        return StateSpace::gain(mat_from(&a), dt)
            .map(Some)
            .map_err(|e| py_err(e.into()));
    }
    Ok(None)
}

/// −sys, as the series connection with the gain −I.
fn negated(s: &StateSpace) -> Result<StateSpace, skyloop::lti::LtiError> {
    let minus = StateSpace::gain(
        Mat::from_fn(s.ny(), s.ny(), |i, j| if i == j { -1.0 } else { 0.0 }),
        s.dt,
    )?;
    skyloop::lti::interconnect::series(s, &minus)
}

#[pymethods]
impl PyStateSpace {
    /// State matrix A (nx × nx), a copy.
    #[getter(A)]
    fn a<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat_to(py, &self.inner.a)
    }
    /// Input matrix B (nx × nu), a copy.
    #[getter(B)]
    fn b<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat_to(py, &self.inner.b)
    }
    /// Output matrix C (ny × nx), a copy.
    #[getter(C)]
    fn c<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat_to(py, &self.inner.c)
    }
    /// Feedthrough matrix D (ny × nu), a copy.
    #[getter(D)]
    fn d<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat_to(py, &self.inner.d)
    }
    /// Sample period, s (0 for continuous time).
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.dt
    }
    /// Delay on each input, s (length nu).
    #[getter]
    fn input_delay<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec_to(py, &self.inner.input_delay)
    }
    /// Delay on each output, s (length ny).
    #[getter]
    fn output_delay<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec_to(py, &self.inner.output_delay)
    }
    /// Number of states.
    #[getter]
    fn nstates(&self) -> usize {
        self.inner.nx()
    }
    /// Number of inputs.
    #[getter]
    fn ninputs(&self) -> usize {
        self.inner.nu()
    }
    /// Number of outputs.
    #[getter]
    fn noutputs(&self) -> usize {
        self.inner.ny()
    }
    /// True when any input or output delay is non-zero.
    fn has_delay(&self) -> bool {
        self.inner.has_delay()
    }
    /// True for continuous time (dt == 0).
    fn isctime(&self) -> bool {
        self.inner.is_continuous()
    }
    /// The model with every delay replaced by its order-``n`` Padé approximant (MATLAB ``pade``), n in 1..=20.
    fn pade(&self, py: Python<'_>, n: usize) -> PyResult<PyStateSpace> {
        let s = &self.inner;
        guarded(py, || s.try_pade(n)).map(wrap)
    }
    /// The model as LTI JSON text (the CLI's model file format).
    fn to_json(&self) -> String {
        skyloop::lti::json::to_json_string(&self.inner)
    }
    /// The model as a ``control.StateSpace`` (python-control must be installed). python-control has
    /// no delays: a model with delays raises InputError unless ``pade`` gives the Padé order to
    /// replace them with.
    #[pyo3(signature = (pade=None))]
    fn to_control(&self, py: Python<'_>, pade: Option<usize>) -> PyResult<PyObject> {
        let s = match (self.inner.has_delay(), pade) {
            (false, _) => self.inner.clone(),
            (true, Some(n)) => {
                let s = &self.inner;
                guarded(py, || s.try_pade(n))?
            }
            (true, None) => {
                return Err(input_err(
                    "python-control models have no delays: call to_control(pade=N) to replace them by order-N Padé approximants",
                ))
            }
        };
        let control = py.import("control")?;
        let dt: PyObject = if s.dt == 0.0 {
            0.into_py_any(py)?
        } else {
            s.dt.into_py_any(py)?
        };
        Ok(control
            .call_method1(
                "ss",
                (
                    mat_to(py, &s.a),
                    mat_to(py, &s.b),
                    mat_to(py, &s.c),
                    mat_to(py, &s.d),
                    dt,
                ),
            )?
            .unbind())
    }
    fn __repr__(&self) -> String {
        let s = &self.inner;
        let time = if s.dt == 0.0 {
            "continuous".to_string()
        } else {
            format!("dt={} s", s.dt)
        };
        let delays = if s.has_delay() {
            format!(
                ", input_delay={:?} s, output_delay={:?} s",
                s.input_delay, s.output_delay
            )
        } else {
            String::new()
        };
        format!(
            "<skyloop.StateSpace: {} states, {} outputs, {} inputs, {time}{delays}>",
            s.nx(),
            s.ny(),
            s.nu()
        )
    }
    fn __reduce__(&self, py: Python<'_>) -> PyResult<(PyObject, (String,))> {
        let f = py.import("skyloop._skyloop")?.getattr("_from_json")?.unbind();
        Ok((f, (self.to_json(),)))
    }
    fn __mul__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.nu(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::series(&o, s))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("mul", slf, other)),
        }
    }
    fn __rmul__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.ny(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::series(s, &o))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("rmul", slf, other)),
        }
    }
    fn __add__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.ny(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::parallel(s, &o))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("add", slf, other)),
        }
    }
    fn __radd__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.ny(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::parallel(&o, s))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("radd", slf, other)),
        }
    }
    fn __sub__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.ny(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::parallel(s, &negated(&o)?))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("sub", slf, other)),
        }
    }
    fn __rsub__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        let s = &slf.get().inner;
        match as_model(other, s.ny(), s.dt)? {
            Some(o) => guarded(py, || skyloop::lti::interconnect::parallel(&o, &negated(s)?))
                .map(wrap)?
                .into_py_any(py),
            None => py_model_call(py, "_ss_binop", ("rsub", slf, other)),
        }
    }
    fn __truediv__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        py_model_call(py, "_ss_binop", ("truediv", slf, other))
    }
    fn __rtruediv__(slf: &Bound<'_, Self>, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        py_model_call(py, "_ss_binop", ("rtruediv", slf, other))
    }
    fn __pow__(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        other: &Bound<'_, PyAny>,
        _modulo: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyObject> {
        py_model_call(py, "_ss_binop", ("pow", slf, other))
    }
    /// ``G(x)``: the response at the complex point x (s or z), or at each point of an array.
    #[pyo3(signature = (x, squeeze=None))]
    fn __call__(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        x: &Bound<'_, PyAny>,
        squeeze: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyObject> {
        py_model_call(py, "_ss_call", (slf, x, squeeze))
    }
    /// ``G[i, j]``: the channels (ints or slices) as a model, delays included.
    fn __getitem__(slf: &Bound<'_, Self>, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<PyObject> {
        py_model_call(py, "_ss_getitem", (slf, key))
    }
    /// The methods written in Python (poles, zeros, dcgain, freqresp, bode, step, feedback, minreal,
    /// c2d, hinf_norm, h2_norm, ...), looked up in ``skyloop._model``.
    fn __getattr__(slf: &Bound<'_, Self>, py: Python<'_>, name: &str) -> PyResult<PyObject> {
        py_model_call(py, "_ss_getattr", (slf, name))
    }
    /// numpy defers to the model's reflected operators (``np.eye(2) * G`` is a series connection).
    #[classattr]
    fn __array_priority__() -> f64 {
        100.0
    }
    fn __neg__(&self, py: Python<'_>) -> PyResult<PyStateSpace> {
        let s = &self.inner;
        guarded(py, || negated(s)).map(wrap)
    }
}

/// Rebuilds a model from its LTI JSON text (used by pickle).
#[pyfunction]
fn _from_json(py: Python<'_>, text: String) -> PyResult<PyStateSpace> {
    guarded(py, || skyloop::lti::json::from_json_str(&text)).map(wrap)
}

/// A state-space model from float64 matrices A (nx×nx), B (nx×nu), C (ny×nx), D (ny×nu); dt in s
/// (0: continuous); delays in s per input / output.
#[pyfunction]
#[pyo3(signature = (a, b, c, d, dt=0.0, input_delay=None, output_delay=None))]
#[allow(clippy::too_many_arguments)]
fn _ss(
    py: Python<'_>,
    a: PyReadonlyArray2<'_, f64>,
    b: PyReadonlyArray2<'_, f64>,
    c: PyReadonlyArray2<'_, f64>,
    d: PyReadonlyArray2<'_, f64>,
    dt: f64,
    input_delay: Option<Vec<f64>>,
    output_delay: Option<Vec<f64>>,
) -> PyResult<PyStateSpace> {
    let (a, b, c, d) = (mat_from(&a), mat_from(&b), mat_from(&c), mat_from(&d));
    guarded(py, move || {
        let mut s = StateSpace::new(a, b, c, d, dt)?;
        if let Some(v) = input_delay {
            s.input_delay = v;
        }
        if let Some(v) = output_delay {
            s.output_delay = v;
        }
        s.validate()?;
        Ok::<_, skyloop::lti::LtiError>(s)
    })
    .map(wrap)
}

/// A model from a transfer-function expression (skyloop's expression language), e.g.
/// ``"0.0887*exp(-0.032*s)/(0.0256*s+1)"``: numbers, ``s``, ``+ - * /``, integer ``^``, parentheses,
/// ``exp(-T*s)`` for an exact delay of T seconds; or a path to an LTI JSON file.
#[pyfunction]
fn tf(py: Python<'_>, expr: String) -> PyResult<PyStateSpace> {
    if std::path::Path::new(&expr).is_file() {
        return guarded(py, || skyloop::model::load_model(&expr)).map(wrap);
    }
    guarded(py, || skyloop::lti::expr::parse_model(&expr)).map(wrap)
}

fn sys_of(s: &Bound<'_, PyAny>) -> PyResult<StateSpace> {
    if let Ok(m) = s.downcast::<PyStateSpace>() {
        return Ok(m.get().inner.clone());
    }
    // Anything else (a skyloop.TransferFunction, a python-control model, an expression) goes through
    // the Python layer's conversion, which raises a clear error for what it cannot take.
    let conv = s.py().import("skyloop._model")?.getattr("_to_ss")?.call1((s,))?;
    match conv.downcast::<PyStateSpace>() {
        Ok(m) => Ok(m.get().inner.clone()),
        Err(_) => Err(input_err(format!(
            "expected a skyloop model, got {}",
            s.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))),
    }
}

/// Calls ``skyloop._model.<name>(*args)``: the Python layer's half of a StateSpace method.
fn py_model_call<'py>(py: Python<'py>, name: &str, args: impl pyo3::call::PyCallArgs<'py>) -> PyResult<PyObject> {
    Ok(py.import("skyloop._model")?.getattr(name)?.call1(args)?.unbind())
}

/// Feedback connection of ``sys1`` with ``sys2`` in the return path; ``sign=-1`` (default) for
/// negative feedback: y = sys1·(u + sign·sys2·y). ``sys2`` may be a number (a gain).
#[pyfunction]
#[pyo3(signature = (sys1, sys2=None, sign=-1.0))]
fn feedback(
    py: Python<'_>,
    sys1: &Bound<'_, PyAny>,
    sys2: Option<&Bound<'_, PyAny>>,
    sign: f64,
) -> PyResult<PyStateSpace> {
    let g1 = sys_of(sys1)?;
    let g2 = match sys2 {
        None => StateSpace::gain(Mat::identity(g1.nu(), g1.ny()), g1.dt).map_err(|e| py_err(e.into()))?,
        Some(o) => as_model(o, g1.ny().min(g1.nu()), g1.dt)?
            .ok_or_else(|| input_err("sys2 must be a StateSpace, a number or a 2-D array"))?,
    };
    guarded(py, || skyloop::lti::interconnect::feedback(&g1, &g2, sign)).map(wrap)
}

/// Lower linear fractional transformation lft(P, K): K (u = K·y) closes the last K.noutputs inputs
/// and K.ninputs outputs of P (MATLAB ``lft(P, K)``).
#[pyfunction]
#[allow(non_snake_case)]
fn lft(py: Python<'_>, P: &Bound<'_, PyAny>, K: &Bound<'_, PyAny>) -> PyResult<PyStateSpace> {
    let (p, k) = (sys_of(P)?, sys_of(K)?);
    guarded(py, move || skyloop::lti::interconnect::lft_lower(&p, &k)).map(wrap)
}

/// The channels ``outputs`` × ``inputs`` (index lists) of a model, delays included (python-control
/// ``sys[outputs, inputs]``).
#[pyfunction]
fn subsystem(sys: &Bound<'_, PyAny>, outputs: Vec<usize>, inputs: Vec<usize>) -> PyResult<PyStateSpace> {
    let s = sys_of(sys)?;
    if let Some(&i) = outputs.iter().find(|&&i| i >= s.ny()) {
        return Err(input_err(format!(
            "output {i} out of range: the model has {} outputs",
            s.ny()
        )));
    }
    if let Some(&j) = inputs.iter().find(|&&j| j >= s.nu()) {
        return Err(input_err(format!(
            "input {j} out of range: the model has {} inputs",
            s.nu()
        )));
    }
    let n = s.nx();
    Ok(wrap(StateSpace {
        a: s.a.clone(),
        b: Mat::from_fn(n, inputs.len(), |i, j| s.b[(i, inputs[j])]),
        c: Mat::from_fn(outputs.len(), n, |i, j| s.c[(outputs[i], j)]),
        d: Mat::from_fn(outputs.len(), inputs.len(), |i, j| s.d[(outputs[i], inputs[j])]),
        dt: s.dt,
        input_delay: inputs.iter().map(|&j| s.input_delay[j]).collect(),
        output_delay: outputs.iter().map(|&i| s.output_delay[i]).collect(),
    }))
}

/// The ducted-fan paper's plants (skyloop's reproduction, default design): dict {g (generalized
/// plant: inputs [v n_unc | w n_w | u ncon], outputs [z n_unc | e n_e | y nmeas]), g_nom (nominal
/// plant for the H∞ design, eq. (11)), n_unc, n_w, n_e, nmeas, ncon}.
#[pyfunction]
fn ducted_fan_plants(py: Python<'_>) -> PyResult<PyObject> {
    use skyloop::papers::ducted_fan::plant;
    let p = guarded(py, || {
        plant::build(skyloop::sim::presets::ducted_fan_pross(), &plant::Design::default())
    })?;
    let d = PyDict::new(py);
    d.set_item("nmeas", p.g.ny() - p.n_unc - p.n_e)?;
    d.set_item("ncon", p.g.nu() - p.n_unc - p.n_w)?;
    d.set_item("n_unc", p.n_unc)?;
    d.set_item("n_w", p.n_w)?;
    d.set_item("n_e", p.n_e)?;
    d.set_item("g", wrap(p.g))?;
    d.set_item("g_nom", wrap(p.g_nom))?;
    d.into_py_any(py)
}

/// Reproduces a paper ("bicopter", "quadrotor-ssi", "ducted-fan"; ``quick`` for the shorter
/// ducted-fan run), writing figures and report.html into ``out``: list of claims {name, paper,
/// ours, reproduced, ...} as in the reproduction's report.
#[pyfunction]
#[pyo3(signature = (name, out, quick=false))]
fn reproduce(py: Python<'_>, name: String, out: PathBuf, quick: bool) -> PyResult<PyObject> {
    let r = guarded(py, move || skyloop::papers::reproduce(&name, &out, quick))?;
    ser_to_py(py, &r.claims)
}

// ---------------------------------------------------------------------------------------------
// Analysis

/// Frequency response at ``omega`` (rad/s): complex array [nfreq, ny, nu], exact with delays.
#[pyfunction]
fn _freqresp<'py>(
    py: Python<'py>,
    sys: &Bound<'py, PyAny>,
    omega: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray3<Complex64>>> {
    let s = sys_of(sys)?;
    let w = omega.as_slice().map_err(|e| input_err(e.to_string()))?.to_vec();
    let (ny, nu) = (s.ny(), s.nu());
    let out = guarded(py, move || {
        // The flat response is already [frequency][output][input], row-major.
        let g = skyloop::lti::freqresp::freqresp_flat(&s, &w)?;
        let flat: Vec<Complex64> = g.iter().map(|z| Complex64::new(z.re, z.im)).collect();
        Array3::from_shape_vec((w.len(), ny, nu), flat)
            .map_err(|e| skyloop::lti::LtiError::Numerical(format!("frequency response shape: {e}")))
    })?;
    Ok(out.into_pyarray(py))
}

/// Bode data: dict with ``w_rad_s``, ``freq_hz`` (arrays [nfreq]), ``mag_db`` and unwrapped
/// ``phase_deg`` (arrays [ny, nu, nfreq]); ``omega`` in rad/s (default: a grid over the dynamics).
#[pyfunction]
#[pyo3(signature = (sys, omega=None))]
fn _bode(py: Python<'_>, sys: &Bound<'_, PyAny>, omega: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<PyObject> {
    let s = sys_of(sys)?;
    let w = match &omega {
        Some(o) => Some(o.as_slice().map_err(|e| input_err(e.to_string()))?.to_vec()),
        None => None,
    };
    let b = guarded(py, move || skyloop::lti::freqresp::bode(&s, w.as_deref()))?;
    let d = PyDict::new(py);
    d.set_item("w_rad_s", vec_to(py, &b.w_rad_s))?;
    d.set_item("freq_hz", vec_to(py, &b.freq_hz))?;
    d.set_item("mag_db", cube_to(py, &b.mag_db))?;
    d.set_item("phase_deg", cube_to(py, &b.phase_deg))?;
    Ok(d.into_any().unbind())
}

fn fin(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// Classic, delay and disk margins of a SISO loop L = P·C (closed as u = −y), exact with delays:
/// the CLI's ``margins --json`` dict (gain_margin_db, gain_margin_freq_hz, phase_margin_deg,
/// phase_margin_freq_hz, delay_margin_s, disk_margin{alpha, gain_db, phase_deg, freq_hz},
/// closed_loop_stable, unit_gain_band_hz, all_gain_margins, all_phase_margins); None where infinite.
#[pyfunction]
fn margins(py: Python<'_>, sys: &Bound<'_, PyAny>) -> PyResult<PyObject> {
    let s = sys_of(sys)?;
    let v = guarded(py, move || skyloop::json_out::margins_json(&s))?;
    json_to_py(py, &v)
}

/// Every gain and phase crossing of a SISO loop L: dict with ``gain_margins`` [{gm_db, w_rad_s}],
/// ``phase_margins`` [{pm_deg, w_rad_s, delay_margin_s}], ``delay_margin_s``, ``stable`` (closed
/// loop), ``w_range_rad_s`` (searched band) and ``unit_gain_band_rad_s`` (None unless |L| = 1 on a band).
#[pyfunction]
fn allmargin(py: Python<'_>, sys: &Bound<'_, PyAny>) -> PyResult<PyObject> {
    let s = sys_of(sys)?;
    let all = guarded(py, move || skyloop::lti::margins::allmargin(&s))?;
    let v = serde_json::json!({
        "gain_margins": all.gain_margins.iter()
            .map(|g| serde_json::json!({"gm_db": fin(g.gm_db), "w_rad_s": g.w_rad_s}))
            .collect::<Vec<_>>(),
        "phase_margins": all.phase_margins.iter()
            .map(|p| serde_json::json!({"pm_deg": p.pm_deg, "w_rad_s": p.w_rad_s, "delay_margin_s": fin(p.delay_margin_s)}))
            .collect::<Vec<_>>(),
        "delay_margin_s": fin(all.delay_margin_s),
        "stable": all.stable,
        "w_range_rad_s": [all.w_range_rad_s.0, all.w_range_rad_s.1],
        "unit_gain_band_rad_s": all.unit_gain_band_rad_s.map(|(a, b)| [a, b]),
    });
    json_to_py(py, &v)
}

/// Symmetric disk margin of a SISO loop L: dict with ``alpha``, ``gain_db`` [low, high], ``phase_deg``
/// (±), ``w_rad_s`` (where it is attained); None where infinite.
#[pyfunction]
fn diskmargin(py: Python<'_>, sys: &Bound<'_, PyAny>) -> PyResult<PyObject> {
    let s = sys_of(sys)?;
    let dm = guarded(py, move || skyloop::lti::margins::diskmargin(&s))?;
    json_to_py(
        py,
        &serde_json::json!({
            "alpha": fin(dm.alpha),
            "gain_db": [fin(dm.gain_db[0]), fin(dm.gain_db[1])],
            "phase_deg": fin(dm.phase_deg),
            "w_rad_s": fin(dm.w_rad_s),
        }),
    )
}

/// H∞ norm and the frequency (rad/s) of its peak: ``(norm, w_peak)``; ``(inf, nan)`` for an unstable model.
#[pyfunction]
fn hinf_norm(py: Python<'_>, sys: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    let s = sys_of(sys)?;
    guarded(py, move || skyloop::lti::norms::hinf_norm(&s))
}

/// H2 norm (inf for an unstable or, in continuous time, non-strictly-proper model).
#[pyfunction]
fn h2_norm(py: Python<'_>, sys: &Bound<'_, PyAny>) -> PyResult<f64> {
    let s = sys_of(sys)?;
    guarded(py, move || skyloop::lti::norms::h2_norm(&s))
}

/// Poles (eigenvalues of A), complex array; rad/s in continuous time.
#[pyfunction]
fn poles<'py>(py: Python<'py>, sys: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
    let s = sys_of(sys)?;
    let p = guarded(py, move || skyloop::lti::poles_zeros::poles(&s))?;
    Ok(cvec_to(py, &p))
}

/// Transmission zeros, complex array.
#[pyfunction]
fn zeros<'py>(py: Python<'py>, sys: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
    let s = sys_of(sys)?;
    let z = guarded(py, move || skyloop::lti::poles_zeros::zeros(&s))?;
    Ok(cvec_to(py, &z))
}

/// Steady-state gain, array [ny, nu].
#[pyfunction]
fn dcgain<'py>(py: Python<'py>, sys: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let s = sys_of(sys)?;
    let g = guarded(py, move || skyloop::lti::poles_zeros::dcgain(&s))?;
    Ok(mat_to(py, &g))
}

/// Unit-step response: dict with ``t_s`` (array [nt], s) and ``y`` (array [ny, nu, nt]); ``t`` uniform
/// from 0 (default: from the slowest pole), delays exact.
#[pyfunction]
#[pyo3(signature = (sys, t=None))]
fn _step(py: Python<'_>, sys: &Bound<'_, PyAny>, t: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<PyObject> {
    let s = sys_of(sys)?;
    let t = match &t {
        Some(o) => Some(o.as_slice().map_err(|e| input_err(e.to_string()))?.to_vec()),
        None => None,
    };
    let r = guarded(py, move || skyloop::lti::timeresp::step(&s, t.as_deref()))?;
    let d = PyDict::new(py);
    d.set_item("t_s", vec_to(py, &r.t_s))?;
    d.set_item("y", cube_to(py, &r.y))?;
    Ok(d.into_any().unbind())
}

/// Discretizes with sample period ``dt`` (s) by ``method``: ``zoh``, ``foh``, ``tustin`` (``bilinear``;
/// with ``prewarp`` in rad/s) or ``matched``.
#[pyfunction]
#[pyo3(signature = (sys, dt, method="zoh", prewarp=None))]
fn c2d(py: Python<'_>, sys: &Bound<'_, PyAny>, dt: f64, method: &str, prewarp: Option<f64>) -> PyResult<PyStateSpace> {
    use skyloop::lti::discretize::Method;
    let s = sys_of(sys)?;
    let mut m: Method = method
        .parse()
        .map_err(|e: skyloop::lti::LtiError| input_err(e.to_string()))?;
    if let Some(w) = prewarp {
        match &mut m {
            Method::Tustin { prewarp_rad_s } => *prewarp_rad_s = Some(w),
            _ => return Err(input_err("prewarp applies to the tustin method only")),
        }
    }
    guarded(py, move || skyloop::lti::discretize::c2d(&s, dt, m)).map(wrap)
}

/// Balanced reduction to ``order`` states, unstable part kept exactly: ``method`` ``truncate``
/// (``balanced``, SLICOT AB09AD) or ``matchdc`` (``spa``, singular perturbation keeping the DC gain).
#[pyfunction]
#[pyo3(signature = (sys, order, method="truncate"))]
fn balred(py: Python<'_>, sys: &Bound<'_, PyAny>, order: usize, method: &str) -> PyResult<PyStateSpace> {
    let s = sys_of(sys)?;
    let m: skyloop::lti::reduce::Method = method
        .parse()
        .map_err(|e: skyloop::lti::LtiError| input_err(e.to_string()))?;
    guarded(py, move || skyloop::lti::reduce::balred(&s, order, m)).map(|r| wrap(r.sys))
}

/// Hankel singular values of the stable part, descending.
#[pyfunction]
fn hsvd<'py>(py: Python<'py>, sys: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let s = sys_of(sys)?;
    let h = guarded(py, move || skyloop::lti::reduce::hsvd(&s))?;
    Ok(vec_to(py, &h))
}

/// Minimal realization: removes uncontrollable and unobservable states (``tol`` relative; default automatic).
#[pyfunction]
#[pyo3(signature = (sys, tol=None))]
fn minreal(py: Python<'_>, sys: &Bound<'_, PyAny>, tol: Option<f64>) -> PyResult<PyStateSpace> {
    let s = sys_of(sys)?;
    guarded(py, move || skyloop::lti::minreal::minreal(&s, tol)).map(wrap)
}

// ---------------------------------------------------------------------------------------------
// Synthesis

fn hinf_opts(gamma_min: f64, gamma_max: Option<f64>, tol: f64) -> skyloop::robust::hinfsyn::HinfOptions {
    skyloop::robust::hinfsyn::HinfOptions {
        gamma_range: (gamma_min, gamma_max.unwrap_or(f64::INFINITY)),
        rel_tol: tol,
    }
}

/// H∞ output-feedback synthesis (MATLAB conventions: the last ``nmeas`` outputs of P are y, the
/// last ``ncon`` inputs are u, u = K·y): ``(K, gamma)``, γ the verified closed-loop H∞ norm bound.
/// ``full=True`` returns the dict {controller, gamma, gamma_lower, closed_loop_norm, closed_loop}.
#[pyfunction]
#[pyo3(signature = (P, nmeas, ncon, gamma_min=0.0, gamma_max=None, tol=1e-4, full=false))]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn hinfsyn(
    py: Python<'_>,
    P: &Bound<'_, PyAny>,
    nmeas: usize,
    ncon: usize,
    gamma_min: f64,
    gamma_max: Option<f64>,
    tol: f64,
    full: bool,
) -> PyResult<PyObject> {
    let p = sys_of(P)?;
    let o = hinf_opts(gamma_min, gamma_max, tol);
    let sol = guarded(py, move || skyloop::robust::hinfsyn::hinfsyn_with(&p, nmeas, ncon, &o))?;
    if full {
        let d = PyDict::new(py);
        d.set_item("controller", wrap(sol.controller))?;
        d.set_item("gamma", sol.gamma)?;
        d.set_item("gamma_lower", sol.gamma_lower)?;
        d.set_item("closed_loop_norm", sol.closed_loop_norm)?;
        d.set_item("closed_loop", wrap(sol.closed_loop))?;
        return d.into_py_any(py);
    }
    (wrap(sol.controller), sol.gamma).into_py_any(py)
}

fn opt_sys(s: Option<&Bound<'_, PyAny>>) -> PyResult<Option<StateSpace>> {
    s.map(sys_of).transpose()
}

/// Glover–McFarlane H∞ loop shaping of P with weights W1 (input side) and W2 (output side), shaped
/// plant W2·P·W1; delays replaced by order-``pade`` Padé approximants; the controller is built for
/// γ = factor·γ_min. Dict {controller (C for u = C·(r − y)), k_inf, shaped_plant, gamma_min, gamma}.
#[pyfunction]
#[pyo3(signature = (P, W1=None, W2=None, factor=1.1, pade=3))]
#[allow(non_snake_case)]
fn ncfsyn(
    py: Python<'_>,
    P: &Bound<'_, PyAny>,
    W1: Option<&Bound<'_, PyAny>>,
    W2: Option<&Bound<'_, PyAny>>,
    factor: f64,
    pade: usize,
) -> PyResult<PyObject> {
    let (p, w1, w2) = (sys_of(P)?, opt_sys(W1)?, opt_sys(W2)?);
    let o = skyloop::robust::ncfsyn::NcfOptions {
        factor,
        pade_order: pade,
    };
    let sol = guarded(py, move || {
        skyloop::robust::ncfsyn::ncfsyn(&p, w1.as_ref(), w2.as_ref(), &o)
    })?;
    let d = PyDict::new(py);
    d.set_item("controller", wrap(sol.controller))?;
    d.set_item("k_inf", wrap(sol.k_inf))?;
    d.set_item("shaped_plant", wrap(sol.shaped_plant))?;
    d.set_item("gamma_min", sol.gamma_min)?;
    d.set_item("gamma", sol.gamma)?;
    d.into_py_any(py)
}

/// Mixed-sensitivity H∞ synthesis of G with weights W1 (on S), W2 (on KS), W3 (on T), python-control
/// order: ``(K, CL, gamma)`` with u = K·y (y = −e) and CL the weighted closed loop.
#[pyfunction]
#[pyo3(signature = (G, W1=None, W2=None, W3=None, gamma_max=None, tol=1e-4))]
#[allow(non_snake_case)]
fn mixsyn(
    py: Python<'_>,
    G: &Bound<'_, PyAny>,
    W1: Option<&Bound<'_, PyAny>>,
    W2: Option<&Bound<'_, PyAny>>,
    W3: Option<&Bound<'_, PyAny>>,
    gamma_max: Option<f64>,
    tol: f64,
) -> PyResult<(PyStateSpace, PyStateSpace, f64)> {
    let (g, w1, w2, w3) = (sys_of(G)?, opt_sys(W1)?, opt_sys(W2)?, opt_sys(W3)?);
    let o = hinf_opts(0.0, gamma_max, tol);
    let sol = guarded(py, move || {
        skyloop::robust::mixsyn::mixsyn(&g, w1.as_ref(), w2.as_ref(), w3.as_ref(), &o)
    })?;
    Ok((wrap(sol.controller), wrap(sol.closed_loop), sol.gamma))
}

/// Fixed-order H∞ synthesis by nonsmooth optimization (MATLAB conventions, as :func:`hinfsyn`: the
/// last ``nmeas`` outputs of P are y, the last ``ncon`` inputs are u, u = K·y), a controller of
/// ``order`` states (0..=50; P's order is hinfsyn's full-order problem) from ``starts`` random starts
/// (1..=1000, run in parallel; start k uses ``seed`` + k). Dict as ``skyloop hinfstruct --json``:
/// {gamma (‖lft(P, K)‖∞ re-verified), controller (StateSpace K), stabilized_starts of starts_run
/// (the requested starts plus added_starts central-controller ones)}.
#[pyfunction]
#[pyo3(signature = (P, nmeas, ncon, order, starts=8, seed=1))]
#[allow(non_snake_case)]
fn _hinfstruct(
    py: Python<'_>,
    P: &Bound<'_, PyAny>,
    nmeas: usize,
    ncon: usize,
    order: usize,
    starts: usize,
    seed: u64,
) -> PyResult<PyObject> {
    use skyloop::robust::structured::hinfstruct::{hinfstruct, HinfstructOptions};
    let p = sys_of(P)?;
    let o = HinfstructOptions {
        starts,
        seed,
        ..Default::default()
    };
    let sol = guarded(py, move || hinfstruct(&p, nmeas, ncon, order, &o))?;
    let d = PyDict::new(py);
    d.set_item("gamma", sol.gamma)?;
    d.set_item("controller", wrap(sol.controller))?;
    d.set_item("stabilized_starts", sol.stabilized_starts)?;
    d.set_item("starts_run", sol.starts_run)?;
    d.set_item("added_starts", sol.added_starts)?;
    d.into_py_any(py)
}

/// Firmware gains tuned against margin goals (``skyloop tune --plant``): the rate-loop ``plant`` in
/// the firmware's units, ``firmware`` betaflight / px4 / generic, the other arguments the CLI's
/// flags (``d_filter_tau`` in s). Dict as ``tune --json`` {gains, feedback_controller,
/// discrete_controller, margins {disk_alpha, gain_margin_db (dB), phase_margin_deg (deg),
/// crossover_hz (Hz), ms, mt, stable}, goals [{goal, value, met, active}], cli, defaults, notes},
/// the controllers as StateSpace objects, plus ``loop_plant`` (the plant the margins were checked
/// with, the firmware's sample-and-hold delay included). ``out``: also write the CLI's files there.
#[pyfunction]
#[pyo3(signature = (plant, firmware, goals=Vec::new(), structure="pid", d_filter_tau=None,
    maximize="integral_gain", axis="roll", starts=8, out=None, keep_feedforward=false))]
#[allow(clippy::too_many_arguments)]
fn _tune(
    py: Python<'_>,
    plant: &Bound<'_, PyAny>,
    firmware: &str,
    goals: Vec<String>,
    structure: &str,
    d_filter_tau: Option<f64>,
    maximize: &str,
    axis: &str,
    starts: usize,
    out: Option<PathBuf>,
    keep_feedforward: bool,
) -> PyResult<PyObject> {
    use skyloop::tune::{report::write_outputs, tune, Firmware, GenericStructure, Maximize, TuneRequest};
    let p = sys_of(plant)?;
    // The same parsers as the CLI, so a bad name raises the CLI's message.
    let mut req = TuneRequest::new(p, Firmware::parse(firmware).map_err(py_err)?);
    req.structure = GenericStructure::parse(structure).map_err(py_err)?;
    req.d_filter_tau_s = d_filter_tau;
    req.goals = goals;
    req.maximize = Maximize::parse(maximize).map_err(py_err)?;
    req.axis = skyloop::firmware::Axis::parse(axis).map_err(py_err)?;
    req.starts = starts;
    req.tune_feedforward = !keep_feedforward;
    let o = guarded(py, move || {
        let o = tune(&req)?;
        if let Some(dir) = &out {
            write_outputs(&o, dir)?;
        }
        Ok::<_, skyloop::Error>(o)
    })?;
    let d = json_to_py(py, &o.to_json())?;
    let dict = d.bind(py);
    dict.set_item("feedback_controller", wrap(o.feedback_controller))?;
    dict.set_item("discrete_controller", o.discrete_controller.map(wrap))?;
    dict.set_item("loop_plant", wrap(o.loop_plant))?;
    Ok(d)
}

fn blocks_of(text: &str) -> PyResult<skyloop::robust::uncertainty::BlockStructure> {
    skyloop::robust::uncertainty::BlockStructure::parse(text).map_err(|e| input_err(format!("blocks: {e}")))
}

/// Structured singular value bounds of M against ``blocks`` (e.g. ``"c1x1,f2x2,r1,c3r"``: cMxN/fMxN
/// full complex, cNr repeated complex scalar, rN repeated real). M a StateSpace with ``omega`` (rad/s,
/// increasing; default a 200-point grid over its dynamics): dict {upper, lower, w_rad_s, freq_hz
/// (arrays), peak {upper, lower, w_rad_s, freq_hz, margin_lower, margin_upper, margin_freq_hz}}.
/// M a complex 2-D array: dict {upper, lower, delta} for that one matrix.
#[pyfunction]
#[pyo3(signature = (M, blocks, omega=None))]
#[allow(non_snake_case)]
fn _mu(
    py: Python<'_>,
    M: &Bound<'_, PyAny>,
    blocks: &str,
    omega: Option<PyReadonlyArray1<'_, f64>>,
) -> PyResult<PyObject> {
    use skyloop::robust::mu::{mu, mu_system, robust_stability, MuOptions};
    let bs = blocks_of(blocks)?;
    if let Ok(a) = M.extract::<PyReadonlyArray2<'_, Complex64>>() {
        let v = a.as_array();
        let m = Mat::<c64>::from_fn(v.nrows(), v.ncols(), |i, j| c64::new(v[[i, j]].re, v[[i, j]].im));
        let b = guarded(py, move || mu(m.as_ref(), &bs))?;
        let d = PyDict::new(py);
        d.set_item("upper", b.upper)?;
        d.set_item("lower", b.lower)?;
        let del = Array2::from_shape_fn((b.delta.nrows(), b.delta.ncols()), |(i, j)| {
            Complex64::new(b.delta[(i, j)].re, b.delta[(i, j)].im)
        });
        d.set_item("delta", del.into_pyarray(py))?;
        return d.into_py_any(py);
    }
    let s = sys_of(M)?;
    let w = match &omega {
        Some(o) => Some(o.as_slice().map_err(|e| input_err(e.to_string()))?.to_vec()),
        None => None,
    };
    let (w, sw, rs) = guarded(py, move || {
        let w = match w {
            Some(w) => w,
            None => skyloop::lti::freqresp::default_grid(&s, 200)?,
        };
        let sw = mu_system(&s, &w, &bs, &MuOptions::default())?;
        let rs = robust_stability(&sw);
        Ok::<_, skyloop::Error>((w, sw, rs))
    })?;
    let d = PyDict::new(py);
    d.set_item("upper", vec_to(py, &sw.upper))?;
    d.set_item("lower", vec_to(py, &sw.lower))?;
    d.set_item("w_rad_s", vec_to(py, &w))?;
    d.set_item("freq_hz", vec_to(py, &w.iter().map(|&x| hz(x)).collect::<Vec<_>>()))?;
    let peak = serde_json::json!({
        "upper": sw.peak.upper,
        "lower": sw.peak.lower,
        "w_rad_s": sw.peak.w_rad_s,
        "freq_hz": hz(sw.peak.w_rad_s),
        "margin_lower": rs.lower,
        "margin_upper": fin(rs.upper),
        "margin_freq_hz": hz(rs.w_rad_s),
    });
    d.set_item("peak", json_to_py(py, &peak)?)?;
    d.into_py_any(py)
}

/// μ-synthesis by DK-iteration: P with the uncertainty channels first, then performance, then the
/// last ``nmeas`` outputs / ``ncon`` inputs for y / u; ``blocks`` the uncertainty structure (the
/// performance block is added). Dict {controller, mu_peak, best, stop_reason, iterations [{gamma,
/// mu_peak, mu_peak_w_rad_s, mu_lower_peak, mu_rs_peak, controller_order, scaled_plant_order}]}.
#[pyfunction]
#[pyo3(signature = (P, blocks, nmeas, ncon, omega=None, max_iter=6, d_order=2, tol=1e-2, reduce_order=None))]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn _musyn(
    py: Python<'_>,
    P: &Bound<'_, PyAny>,
    blocks: &str,
    nmeas: usize,
    ncon: usize,
    omega: Option<Vec<f64>>,
    max_iter: usize,
    d_order: usize,
    tol: f64,
    reduce_order: Option<usize>,
) -> PyResult<PyObject> {
    let p = sys_of(P)?;
    let bs = blocks_of(blocks)?;
    let o = skyloop::robust::musyn::MusynOptions {
        max_iter,
        d_order,
        w_rad_s: omega.unwrap_or_default(),
        tol,
        reduce_order,
        ..Default::default()
    };
    let sol = guarded(py, move || skyloop::robust::musyn::musyn(&p, &bs, nmeas, ncon, &o))?;
    musyn_dict(py, sol)
}

fn musyn_dict(py: Python<'_>, sol: skyloop::robust::musyn::MusynSolution) -> PyResult<PyObject> {
    let v = skyloop::synthesis::musyn_summary(&sol, false);
    let d = json_to_py(py, &v)?;
    d.bind(py).set_item("controller", wrap(sol.controller))?;
    Ok(d)
}

/// μ-synthesis of a musyn spec file (TOML, as ``skyloop musyn SPEC``): the same dict as :func:`musyn`.
#[pyfunction]
fn musyn_spec(py: Python<'_>, path: PathBuf) -> PyResult<PyObject> {
    let sol = guarded(py, move || {
        let spec = skyloop::spec::musyn::MusynSpec::from_file(&path)?;
        skyloop::synthesis::musyn_from_spec(&spec)
    })?;
    musyn_dict(py, sol)
}

// ---------------------------------------------------------------------------------------------
// Identification and logs

/// Frequency response (and optional parametric fits) of a flight log; the arguments are those of
/// ``skyloop identify`` (frequencies in Hz, times in s; ``axis`` roll/pitch/yaw for the firmware's
/// rate-loop preset, else ``input`` and ``output`` columns; ``blocks`` of the jackknife, default
/// the CLI's; ``disturbance`` a measured disturbance channel conditioned out of the spectra, or
/// ``"none"``, default the preset's throttle where it helps). Dict as ``identify --json``: {frf {freq_hz, mag, phase_deg, coherence, ...},
/// fit {...} with ``model``, tf {...} with ``tf``, notes, ...}.
#[pyfunction]
#[pyo3(signature = (data, input=None, output=None, axis=None, excitation=None, method="spafdr", fmin_hz=None, fmax_hz=None,
    start_s=None, end_s=None, where_=None, rate_hz=None, session=None, n_freq=100, nfft=None, window="hann",
    overlap=0.5, lag_window=None, resolution=0.15, model=None, init=None, bounds=None, error="log",
    weighting="inverse-variance", tf=None, delay_s=None, max_delay_s=0.1, blocks=None, allow_poor_fit=false,
    disturbance=None))]
#[allow(clippy::too_many_arguments)]
fn identify(
    py: Python<'_>,
    data: PathBuf,
    input: Option<String>,
    output: Option<String>,
    axis: Option<String>,
    excitation: Option<String>,
    method: &str,
    fmin_hz: Option<f64>,
    fmax_hz: Option<f64>,
    start_s: Option<f64>,
    end_s: Option<f64>,
    where_: Option<String>,
    rate_hz: Option<f64>,
    session: Option<usize>,
    n_freq: usize,
    nfft: Option<usize>,
    window: &str,
    overlap: f64,
    lag_window: Option<usize>,
    resolution: f64,
    model: Option<String>,
    init: Option<String>,
    bounds: Option<String>,
    error: &str,
    weighting: &str,
    tf: Option<String>,
    delay_s: Option<f64>,
    max_delay_s: f64,
    blocks: Option<usize>,
    allow_poor_fit: bool,
    disturbance: Option<String>,
) -> PyResult<PyObject> {
    let defaults = skyloop::identify::IdentifyRequest::default();
    let req = skyloop::identify::IdentifyRequest {
        data,
        axis,
        input,
        output,
        excitation,
        method: method.into(),
        fmin_hz,
        fmax_hz,
        from: start_s,
        to: end_s,
        condition: where_,
        rate: rate_hz,
        session,
        n_freq,
        nfft,
        window: window.into(),
        overlap,
        lag_window,
        resolution,
        model,
        init,
        bounds,
        error: error.into(),
        weighting: weighting.into(),
        tf,
        delay_s,
        max_delay_s,
        blocks: blocks.unwrap_or(defaults.blocks),
        allow_poor_fit,
        disturbance,
    };
    let (v, notes) = guarded(py, move || {
        skyloop::identify::identify(&req).map(|id| (id.to_json(), id.notes))
    })?;
    let d = json_to_py(py, &v)?;
    if d.bind(py)
        .downcast::<PyDict>()
        .is_ok_and(|d| !d.contains("notes").unwrap_or(true))
    {
        d.bind(py).set_item("notes", notes)?;
    }
    Ok(d)
}

/// Reads a flight log (PX4 ULog, Betaflight/INAV blackbox, or CSV): dict of float64 arrays, one per
/// channel under its full name (as ``identify`` accepts it), and each group's sample times in s
/// under ``"<group>.time_s"``. Units as logged (blackbox gyro deg/s, acceleration g, voltage V).
#[pyfunction]
#[pyo3(signature = (path, session=None))]
fn read_log(py: Python<'_>, path: PathBuf, session: Option<usize>) -> PyResult<PyObject> {
    use skyloop::sysid::logs::{Log, OpenOptions};
    let log = guarded(py, move || {
        Log::open(
            &path,
            &OpenOptions {
                session,
                ..Default::default()
            },
        )
    })?;
    let d = PyDict::new(py);
    let names = log.field_names();
    let mut k = 0;
    for g in &log.groups {
        d.set_item(format!("{}.time_s", g.name), vec_to(py, &g.time_s))?;
        for c in &g.channels {
            d.set_item(&names[k], vec_to(py, &c.values))?;
            k += 1;
        }
    }
    d.into_py_any(py)
}

// ---------------------------------------------------------------------------------------------
// Simulation

fn scenario_of(text: &str) -> PyResult<skyloop::sim::Scenario> {
    skyloop::sim::Scenario::from_toml(text).map_err(|e| InputError::new_err(format!("scenario: {e}")))
}

/// One nonlinear 6-DOF run of a scenario (TOML text): dict {metrics {max_abs_error, rms_error,
/// settling_time_s, saturated_fraction, crashed}, trajectory {t_s [n], pos_m [n,3] (NED), euler_rad
/// [n,3], rates_rad_s [n,3], reference [n,3], tracked [n,3], rate_sp_rad_s [n,3], torque_n_m [n,3],
/// u [n, nu], saturated [n]}}.
#[pyfunction]
fn _simulate(py: Python<'_>, scenario: &str) -> PyResult<PyObject> {
    let scn = scenario_of(scenario)?;
    let (trace, m, nu) = guarded(py, move || {
        let (trace, m) = skyloop::sim::simulate(&scn)?;
        let nu = scn.vehicle.resolve().and_then(|v| v.build())?.nu();
        Ok::<_, skyloop::sim::SimError>((trace, m, nu))
    })?;
    let n = trace.len();
    let v3 = |f: &dyn Fn(&skyloop::sim::Sample) -> [f64; 3]| {
        Array2::from_shape_fn((n, 3), |(k, i)| f(&trace[k])[i]).into_pyarray(py)
    };
    let t = PyDict::new(py);
    t.set_item("t_s", Array1::from_iter(trace.iter().map(|s| s.t)).into_pyarray(py))?;
    t.set_item("pos_m", v3(&|s| s.pos))?;
    t.set_item("euler_rad", v3(&|s| s.euler))?;
    t.set_item("rates_rad_s", v3(&|s| s.rates))?;
    t.set_item("reference", v3(&|s| s.reference))?;
    t.set_item("tracked", v3(&|s| s.tracked))?;
    t.set_item("rate_sp_rad_s", v3(&|s| s.rate_sp))?;
    t.set_item("torque_n_m", v3(&|s| s.torque))?;
    t.set_item(
        "u",
        Array2::from_shape_fn((n, nu), |(k, i)| trace[k].u[i]).into_pyarray(py),
    )?;
    t.set_item(
        "saturated",
        Array1::from_iter(trace.iter().map(|s| s.saturated)).into_pyarray(py),
    )?;
    let d = PyDict::new(py);
    d.set_item("metrics", ser_to_py(py, &m)?)?;
    d.set_item("trajectory", t)?;
    d.into_py_any(py)
}

/// Runs ``seeds`` (indices of the scenario's ``[monte_carlo]`` study; run i uses noise seed
/// monte_carlo.seed + i; default: all its runs) on ``threads`` threads (default: all cores).
/// Dict {seeds [..], runs [{max_abs_error, rms_error, settling_time_s, saturated_fraction, crashed}],
/// summary {runs, crashed, unsettled, max_abs_error {mean, std, min, p95, max}, ...}}.
#[pyfunction]
#[pyo3(signature = (scenario, seeds=None, threads=None))]
fn _montecarlo(
    py: Python<'_>,
    scenario: &str,
    seeds: Option<Vec<usize>>,
    threads: Option<usize>,
) -> PyResult<PyObject> {
    let scn = scenario_of(scenario)?;
    let seeds = match seeds {
        Some(s) => s,
        None => (0..scn.monte_carlo.as_ref().map_or(0, |m| m.runs)).collect(),
    };
    let s2 = seeds.clone();
    let (runs, summary) = guarded(py, move || {
        skyloop::simulation::monte_carlo_runs(&scn, &s2, threads, &|_, _| {})
    })?;
    let d = PyDict::new(py);
    d.set_item("seeds", seeds)?;
    d.set_item("runs", ser_to_py(py, &runs)?)?;
    d.set_item("summary", ser_to_py(py, &summary)?)?;
    d.into_py_any(py)
}

fn field<'py>(d: &Bound<'py, PyDict>, k: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(k)?
        .ok_or_else(|| input_err(format!("runs: a run without '{k}'")))
}

/// Summary statistics of Monte Carlo runs (a list of run-metrics dicts, as in
/// ``montecarlo(...)["runs"]``): the ``summary`` dict of :func:`montecarlo`.
#[pyfunction]
fn _summarize(py: Python<'_>, runs: Vec<Bound<'_, PyDict>>) -> PyResult<PyObject> {
    let mut all = Vec::with_capacity(runs.len());
    for d in &runs {
        all.push(skyloop::sim::Metrics {
            max_abs_error: field(d, "max_abs_error")?.extract()?,
            rms_error: field(d, "rms_error")?.extract()?,
            settling_time_s: field(d, "settling_time_s")?.extract()?,
            saturated_fraction: field(d, "saturated_fraction")?.extract()?,
            crashed: field(d, "crashed")?.extract()?,
        });
    }
    let s = guarded(py, move || {
        Ok::<_, skyloop::Error>(skyloop::sim::montecarlo::summarize(&all))
    })?;
    ser_to_py(py, &s)
}

/// The number of runs of a scenario's ``[monte_carlo]`` study (TOML text), None without one.
#[pyfunction]
fn _study_runs(scenario: &str) -> PyResult<Option<usize>> {
    Ok(scenario_of(scenario)?.monte_carlo.map(|m| m.runs))
}

/// Triggers a panic inside a guarded call (tests that a panic becomes InternalError, not a crash).
#[pyfunction]
fn _panic_for_test(py: Python<'_>) -> PyResult<()> {
    guarded(py, || -> Result<(), skyloop::Error> { panic!("deliberate test panic") })
}

#[pymodule]
fn _skyloop(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SkyloopError", py.get_type::<SkyloopError>())?;
    m.add("LinalgError", py.get_type::<LinalgError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("RobustError", py.get_type::<RobustError>())?;
    m.add("SysidError", py.get_type::<SysidError>())?;
    m.add("SimError", py.get_type::<SimError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add_class::<PyStateSpace>()?;
    m.add_function(wrap_pyfunction!(_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(_ss, m)?)?;
    m.add_function(wrap_pyfunction!(tf, m)?)?;
    m.add_function(wrap_pyfunction!(feedback, m)?)?;
    m.add_function(wrap_pyfunction!(lft, m)?)?;
    m.add_function(wrap_pyfunction!(subsystem, m)?)?;
    m.add_function(wrap_pyfunction!(ducted_fan_plants, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce, m)?)?;
    m.add_function(wrap_pyfunction!(_freqresp, m)?)?;
    m.add_function(wrap_pyfunction!(_bode, m)?)?;
    m.add_function(wrap_pyfunction!(margins, m)?)?;
    m.add_function(wrap_pyfunction!(allmargin, m)?)?;
    m.add_function(wrap_pyfunction!(diskmargin, m)?)?;
    m.add_function(wrap_pyfunction!(hinf_norm, m)?)?;
    m.add_function(wrap_pyfunction!(h2_norm, m)?)?;
    m.add_function(wrap_pyfunction!(poles, m)?)?;
    m.add_function(wrap_pyfunction!(zeros, m)?)?;
    m.add_function(wrap_pyfunction!(dcgain, m)?)?;
    m.add_function(wrap_pyfunction!(_step, m)?)?;
    m.add_function(wrap_pyfunction!(c2d, m)?)?;
    m.add_function(wrap_pyfunction!(balred, m)?)?;
    m.add_function(wrap_pyfunction!(hsvd, m)?)?;
    m.add_function(wrap_pyfunction!(minreal, m)?)?;
    m.add_function(wrap_pyfunction!(hinfsyn, m)?)?;
    m.add_function(wrap_pyfunction!(ncfsyn, m)?)?;
    m.add_function(wrap_pyfunction!(mixsyn, m)?)?;
    m.add_function(wrap_pyfunction!(_hinfstruct, m)?)?;
    m.add_function(wrap_pyfunction!(_tune, m)?)?;
    m.add_function(wrap_pyfunction!(_mu, m)?)?;
    m.add_function(wrap_pyfunction!(_musyn, m)?)?;
    m.add_function(wrap_pyfunction!(musyn_spec, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(read_log, m)?)?;
    m.add_function(wrap_pyfunction!(_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(_montecarlo, m)?)?;
    m.add_function(wrap_pyfunction!(_summarize, m)?)?;
    m.add_function(wrap_pyfunction!(_study_runs, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    Ok(())
}
