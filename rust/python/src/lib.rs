//! pyo3 bindings of tribodyn-core: the `tribodyn._core` extension module.
//!
//! This layer only converts types: it borrows NumPy arrays without copying
//! (`as_slice` fails with a ValueError on a non-contiguous array; the Python
//! wrappers make inputs contiguous float64 first) and releases the GIL
//! around every kernel. The window kernels take one frozen [`PyWindowSpec`]
//! (`WindowSpec`: what every window of an analysis shares, checked and
//! converted once when it is made). Every exception this module raises is
//! built in one place, from a [`Fault`] (`From<Fault> for PyErr`): kernel
//! errors, bad arguments, memory, descriptors, text rows; a NaN or inf in
//! a window is named there in the recording's terms when the spec says how.
//! The messages of kernel and text-row errors are the core's own
//! (`KernelError::named`, `ParseError::named`): this layer words none of them.
//! Validation of user-facing options lives in the Python layer; the kernels
//! re-check everything that could otherwise panic. The file readers'
//! bindings (`Extents`, the TDMS index, the text scan and parse) are in
//! `files.rs`.

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn, PyReadwriteArray2,
    PyReadwriteArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyMemoryError, PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tribodyn_core::io::mapped;
use tribodyn_core::io::text;

mod files;
mod ranges;
use files::{PyExtents, PyTextDialect, PyTextScan};
use tribodyn_core::numerics::bootstrap;
use tribodyn_core::numerics::correlation::{self, Method};
use tribodyn_core::numerics::extended;
use tribodyn_core::numerics::iir;
use tribodyn_core::numerics::lagprofile;
use tribodyn_core::numerics::order;
use tribodyn_core::numerics::peaks;
use tribodyn_core::numerics::regression::{self, LinFit, Moments};
use tribodyn_core::numerics::sums;
use tribodyn_core::numerics::windows::{self, Deadband, WindowOptions};
use tribodyn_core::parallel;

/// Values per window of the column "ext".
const EXT_WIDTH: usize = extended::BLOCKS * extended::PRODUCTS;
use tribodyn_core::error::Naming;
use tribodyn_core::KernelError;

pyo3::create_exception!(
    _core,
    NonFiniteError,
    PyValueError,
    "A sample that must be finite is NaN or inf: the message, and attributes channel, sample, window."
);

/// Everything the binding raises: the one place an exception is built
/// (`From<Fault> for PyErr`); no other code of this module makes one.
enum Fault {
    /// A kernel's refusal: `ValueError`, a NaN or inf `NonFiniteError`
    /// in the kernel's words (channel `fy`, `fy_raw`, `aux`, ...).
    Kernel(KernelError),
    /// A window kernel's refusal, a NaN or inf in the recording's terms
    /// (see [`Naming`]).
    Window(KernelError, Naming),
    /// A malformed argument: `ValueError`.
    Arg(String),
    /// An argument of the wrong kind (an unknown option): `TypeError`.
    Type(String),
    /// Memory the results need and cannot have: `MemoryError`, never an abort.
    Memory(String),
    /// A file descriptor that cannot be used: `OSError`.
    Os(String),
    /// A text row that cannot be read: `ValueError`, in the core's words
    /// (`ParseError::named`), the columns asked for named by these labels.
    Parse(text::ParseError, Vec<String>),
}

impl From<KernelError> for Fault {
    fn from(e: KernelError) -> Self {
        Fault::Kernel(e)
    }
}

impl From<Fault> for PyErr {
    fn from(f: Fault) -> PyErr {
        match f {
            Fault::Kernel(e) => kernel_error(e, None),
            Fault::Window(e, naming) => kernel_error(e, Some(&naming)),
            Fault::Arg(msg) => PyValueError::new_err(msg),
            Fault::Type(msg) => PyTypeError::new_err(msg),
            Fault::Memory(msg) => PyMemoryError::new_err(msg),
            Fault::Os(msg) => PyOSError::new_err(msg),
            Fault::Parse(text::ParseError::Io(e), _) => kernel_error(e, None),
            Fault::Parse(e, labels) => PyValueError::new_err(e.named(&labels).to_string()),
        }
    }
}

/// A kernel error as a Python exception, in the core's words
/// (`KernelError::named`): `NonFiniteError` (its message the one arg;
/// attributes `channel`, `sample`, `window`: with `naming`, the channel is
/// the recording's role and the message gives the time) or `ValueError`.
fn kernel_error(e: KernelError, naming: Option<&Naming>) -> PyErr {
    let msg = e.named(naming).to_string();
    let KernelError::NonFinite { channel, sample, window } = e else { return PyValueError::new_err(msg) };
    let channel = naming.map_or(channel, |n| n.role(channel)).to_owned();
    Python::attach(|py| {
        let err = NonFiniteError::new_err(msg);
        let value = err.value(py);
        let set = value
            .setattr("channel", channel)
            .and_then(|()| value.setattr("sample", sample))
            .and_then(|()| value.setattr("window", window));
        match set {
            Ok(()) => err,
            Err(e) => e,
        }
    })
}

/// A kernel error as a Python exception (through [`Fault`]).
fn to_py(e: KernelError) -> PyErr {
    Fault::Kernel(e).into()
}

/// A `ValueError` (through [`Fault`]).
fn bad(msg: impl Into<String>) -> PyErr {
    Fault::Arg(msg.into()).into()
}

/// A `MemoryError` (through [`Fault`]).
fn no_memory(msg: impl Into<String>) -> PyErr {
    Fault::Memory(msg.into()).into()
}

/// An `OSError` (through [`Fault`]).
fn os_error(msg: impl Into<String>) -> PyErr {
    Fault::Os(msg.into()).into()
}

/// The thread count of one call: `threads` if given (1 ..= 4 x cores),
/// else the default ([`parallel::set_default_threads`]).
fn threads_of(threads: Option<i64>) -> PyResult<usize> {
    match threads {
        None => Ok(parallel::default_threads()),
        Some(t) => {
            let n = usize::try_from(t)
                .map_err(|_| bad(format!("threads must be in [1, {}], got {t}", parallel::max_threads())))?;
            parallel::check_threads(n).map_err(to_py)
        }
    }
}

/// `as_slice` also accepts Fortran order, which a kernel reading rows of a
/// (channels, n) array would silently mistake for C order: refuse it.
fn c_order(c_contiguous: bool, name: &str) -> PyResult<()> {
    if c_contiguous {
        Ok(())
    } else {
        Err(bad(format!("{name} must be a C-contiguous float64 array")))
    }
}

fn slice_err(name: &str) -> impl Fn(numpy::AsSliceError) -> PyErr + '_ {
    move |_| bad(format!("{name} must be a C-contiguous, aligned float64 array"))
}

fn method_of(name: &str) -> PyResult<Method> {
    match name {
        "direct" => Ok(Method::Direct),
        "fft" => Ok(Method::Fft),
        "auto" => Ok(Method::Auto),
        other => Err(bad(format!("method must be 'direct', 'fft' or 'auto', got {other:?}"))),
    }
}

/// Eq. (1) for lags -max_lag..=max_lag.
#[pyfunction]
#[pyo3(signature = (x, y, max_lag, method, *, threads=None))]
fn xcorr<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    max_lag: usize,
    method: &str,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let method = method_of(method)?;
    let threads = threads_of(threads)?;
    let (xs, ys) = (x.as_slice().map_err(slice_err("x"))?, y.as_slice().map_err(slice_err("y"))?);
    let c = if correlation::uses_threads(xs.len(), max_lag) {
        py.detach(|| parallel::run_with(threads, || correlation::xcorr(xs, ys, max_lag, method))).map_err(to_py)?
    } else {
        // One window: entering the pool would cost more than the work.
        correlation::xcorr(xs, ys, max_lag, method)
    }
    .map_err(to_py)?;
    Ok(PyArray1::from_vec(py, c))
}

/// The algorithm "auto" picks for (n, max_lag): "direct" or "fft".
#[pyfunction]
fn xcorr_auto_method(n: usize, max_lag: usize) -> &'static str {
    match correlation::auto_method(n, max_lag) {
        Method::Direct => "direct",
        _ => "fft",
    }
}

/// The values of ranks `ks` (0-based, ascending order) of a 1-D C-contiguous float64 array (with `centre`:
/// of its absolute deviations from it), exactly; None when it holds NaN (tribodyn._order).
#[pyfunction]
#[pyo3(signature = (x, ks, *, centre=None, threads=None))]
fn select_ranks<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    ks: Vec<usize>,
    centre: Option<f64>,
    threads: Option<i64>,
) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
    let threads = threads_of(threads)?;
    let xs = x.as_slice().map_err(slice_err("x"))?;
    let got = py
        .detach(|| parallel::run_with(threads, || order::select_ranks(xs, &ks, centre)))
        .map_err(to_py)?
        .map_err(to_py)?;
    Ok(got.map(|v| PyArray1::from_vec(py, v)))
}

/// Whether `windows_stats_file` reads each window alone, its gaps skipped: windows of `length` samples every
/// `step` at least `MAPPED_ALONE_GAP` apart (tribodyn.pipeline.routes sizes its blocks by it).
#[pyfunction]
fn mapped_windows_alone(step: usize, length: usize) -> bool {
    mapped::windows_alone(step, length)
}

/// Two 2-D float64 arrays.
type Pair2<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// The lag profile's lagged sums (tribodyn.pipeline.instrument.lag_profile, docs/method.md 3b): of each row of
/// `y` and `z` ((windows, n) float64, C order), divided by `scale` and centred, A(L) = sum_t z_t z_(t-L) and
/// C(L) = sum_t y_t z_(t-L) for L = 0..max_lag, by FFT: two (windows, max_lag + 1) arrays (A, C).
#[pyfunction]
#[pyo3(signature = (y, z, max_lag, scale, *, threads=None))]
fn lagged_sums<'py>(
    py: Python<'py>,
    y: PyReadonlyArray2<'py, f64>,
    z: PyReadonlyArray2<'py, f64>,
    max_lag: usize,
    scale: f64,
    threads: Option<i64>,
) -> PyResult<Pair2<'py>> {
    let threads = threads_of(threads)?;
    c_order(y.is_c_contiguous(), "y")?;
    c_order(z.is_c_contiguous(), "z")?;
    if y.shape() != z.shape() {
        return Err(bad(format!("y and z must have one shape, got {:?} and {:?}", y.shape(), z.shape())));
    }
    let (k, n) = (y.shape()[0], y.shape()[1]);
    let (ys, zs) = (y.as_slice().map_err(slice_err("y"))?, z.as_slice().map_err(slice_err("z"))?);
    let (a, c) = py
        .detach(|| parallel::run_with(threads, || lagprofile::lagged_sums(ys, zs, n, max_lag, scale)))
        .map_err(to_py)?
        .map_err(to_py)?;
    let shape = [k, max_lag + 1];
    let a = PyArray1::from_vec(py, a).reshape(shape)?;
    let c = PyArray1::from_vec(py, c).reshape(shape)?;
    Ok((a, c))
}

/// NumPy's histogram of `x` over the uniform `edges` (np.linspace), bit for bit (tribodyn.tribometer._otsu).
#[pyfunction]
fn histogram_uniform<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    edges: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let xs = x.as_slice().map_err(slice_err("x"))?;
    let es = edges.as_slice().map_err(slice_err("edges"))?;
    let counts = py.detach(|| order::histogram_uniform(xs, es)).map_err(to_py)?;
    Ok(PyArray1::from_vec(py, counts))
}

/// The local maxima of a 1-D float64 array whose prominence within `wlen` samples is at least `prominence`:
/// `scipy.signal.find_peaks(x, prominence=prominence, wlen=wlen)[0]`, index for index (tribodyn.kernels.peaks).
#[pyfunction]
#[pyo3(signature = (x, *, prominence, wlen))]
fn find_peaks<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    prominence: f64,
    wlen: usize,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let xs = x.as_slice().map_err(slice_err("x"))?;
    let at = py.detach(|| peaks::find_peaks(xs, prominence, wlen));
    Ok(PyArray1::from_vec(py, at.into_iter().map(|i| i as i64).collect()))
}

/// The fz-noise part of a resample: (var, pos, dnoise, used), see `tribodyn.results.NoiseResample`.
type NoiseArgs<'py> = (PyReadonlyArray1<'py, f64>, PyReadonlyArray1<'py, i64>, PyReadonlyArray1<'py, f64>, f64);

/// Median, mean, p05 and p95 of every moving-block resample (rows of `starts`, blocks of `ell` windows),
/// as `tribodyn.results._resample_stats` computes them with NumPy, bit for bit: a (4, rows) array.
#[pyfunction]
#[pyo3(signature = (v, starts, ell, *, noise=None, threads=None))]
fn resample_stats<'py>(
    py: Python<'py>,
    v: PyReadonlyArray1<'py, f64>,
    starts: PyReadonlyArray2<'py, i64>,
    ell: usize,
    noise: Option<NoiseArgs<'py>>,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let threads = threads_of(threads)?;
    c_order(starts.is_c_contiguous(), "starts")?;
    let (rows, per_row) = (starts.shape()[0], starts.shape()[1]);
    let ss = starts.as_slice().map_err(|_| bad("starts must be a C-contiguous int64 array"))?;
    let vs = v.as_slice().map_err(slice_err("v"))?;
    let parts = match &noise {
        Some((var, pos, dn, used)) => Some((
            var.as_slice().map_err(slice_err("var"))?,
            pos.as_slice().map_err(|_| bad("pos must be a C-contiguous int64 array"))?,
            dn.as_slice().map_err(slice_err("dnoise"))?,
            *used,
        )),
        None => None,
    };
    let mut out = vec![0.0; 4 * rows];
    py.detach(|| {
        let nz = parts.map(|(var, pos, dnoise, used)| bootstrap::Noise { var, pos, dnoise, used });
        parallel::run_with(threads, || bootstrap::resample_stats(vs, ss, per_row, ell, nz.as_ref(), &mut out))
            .and_then(|r| r)
    })
    .map_err(to_py)?;
    Ok(PyArray1::from_vec(py, out))
}

/// Two float64 arrays.
type Pair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// Per row of a (rows, width) float64 C-order matrix, ignoring NaN: the median and the percentiles of the
/// quantile fractions `qs`, bit for bit NumPy's nanmedian / nanpercentile (tribodyn._order.row_quantiles).
#[pyfunction]
#[pyo3(signature = (x, qs, *, threads=None))]
fn row_quantiles<'py>(
    py: Python<'py>,
    x: PyReadonlyArray2<'py, f64>,
    qs: Vec<f64>,
    threads: Option<i64>,
) -> PyResult<Pair<'py>> {
    let threads = threads_of(threads)?;
    c_order(x.is_c_contiguous(), "x")?;
    let (rows, width) = (x.shape()[0], x.shape()[1]);
    let xs = x.as_slice().map_err(slice_err("x"))?;
    let mut med = vec![0.0; rows];
    let mut out = vec![0.0; rows * qs.len()];
    py.detach(|| {
        parallel::run_with(threads, || order::row_quantiles(xs, width, &qs, &mut med, &mut out)).and_then(|r| r)
    })
    .map_err(to_py)?;
    Ok((PyArray1::from_vec(py, med), PyArray1::from_vec(py, out)))
}

/// Pearson's r, C(0) of Eq. (1).
#[pyfunction]
fn pearson(py: Python<'_>, x: PyReadonlyArray1<'_, f64>, y: PyReadonlyArray1<'_, f64>) -> PyResult<f64> {
    let (xs, ys) = (x.as_slice().map_err(slice_err("x"))?, y.as_slice().map_err(slice_err("y"))?);
    py.detach(|| correlation::pearson(xs, ys)).map_err(to_py)
}

fn sections(sos: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<iir::Section>> {
    let a = sos.as_array();
    if a.ncols() != 6 {
        return Err(bad(format!("sos must have shape (n_sections, 6), got {:?}", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| [r[0], r[1], r[2], r[3], r[4], r[5]]).collect())
}

/// Filters `data` (channels, n) in place with `sos`, carrying `state`
/// (channels, n_sections, 2) in place.
#[pyfunction]
#[pyo3(signature = (sos, data, state, *, threads=None))]
fn sosfilt_inplace(
    py: Python<'_>,
    sos: PyReadonlyArray2<'_, f64>,
    mut data: PyReadwriteArray2<'_, f64>,
    mut state: PyReadwriteArray3<'_, f64>,
    threads: Option<i64>,
) -> PyResult<()> {
    let threads = threads_of(threads)?;
    let secs = sections(&sos)?;
    let channels = data.as_array().nrows();
    let st_shape = state.as_array().shape().to_vec();
    if st_shape != [channels, secs.len(), 2] {
        return Err(bad(format!("state must have shape ({channels}, {}, 2), got {st_shape:?}", secs.len())));
    }
    c_order(data.is_c_contiguous(), "data")?;
    c_order(state.is_c_contiguous(), "state")?;
    let d = data.as_slice_mut().map_err(slice_err("data"))?;
    let s = state.as_slice_mut().map_err(slice_err("state"))?;
    // (channels * n_sections * 2) floats viewed as pairs.
    let mut pairs: Vec<[f64; 2]> = s.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let n = d.len() / channels.max(1);
    if iir::uses_threads(n, channels, threads) {
        py.detach(|| parallel::run_with(threads, || iir::sosfilt_inplace(&secs, d, channels, &mut pairs)))
            .map_err(to_py)?
    } else {
        iir::sosfilt_inplace(&secs, d, channels, &mut pairs)
    }
    .map_err(to_py)?;
    for (dst, p) in s.chunks_exact_mut(2).zip(&pairs) {
        dst.copy_from_slice(p);
    }
    Ok(())
}

/// Filters `x` (channels, n) into `out` (same shape) with `sos`, carrying
/// `state` (channels, n_sections, 2) in place. Returns whether every sample
/// of `x` was finite (a NaN or inf leaves the state non-finite; only then
/// is `x` scanned), so the caller's input check costs no extra pass.
#[pyfunction]
#[pyo3(signature = (sos, x, out, state, *, threads=None))]
fn sosfilt_into(
    py: Python<'_>,
    sos: PyReadonlyArray2<'_, f64>,
    x: PyReadonlyArray2<'_, f64>,
    mut out: PyReadwriteArray2<'_, f64>,
    mut state: PyReadwriteArray3<'_, f64>,
    threads: Option<i64>,
) -> PyResult<bool> {
    let threads = threads_of(threads)?;
    let secs = sections(&sos)?;
    let channels = x.as_array().nrows();
    if out.as_array().shape() != x.as_array().shape() {
        return Err(bad(format!(
            "out must have the shape of x {:?}, got {:?}",
            x.as_array().shape(),
            out.as_array().shape()
        )));
    }
    let st_shape = state.as_array().shape().to_vec();
    if st_shape != [channels, secs.len(), 2] {
        return Err(bad(format!("state must have shape ({channels}, {}, 2), got {st_shape:?}", secs.len())));
    }
    c_order(x.is_c_contiguous(), "x")?;
    c_order(out.is_c_contiguous(), "out")?;
    c_order(state.is_c_contiguous(), "state")?;
    let src = x.as_slice().map_err(slice_err("x"))?;
    let d = out.as_slice_mut().map_err(slice_err("out"))?;
    let s = state.as_slice_mut().map_err(slice_err("state"))?;
    let mut pairs: Vec<[f64; 2]> = s.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let n = src.len() / channels.max(1);
    let finite = if iir::uses_threads(n, channels, threads) {
        py.detach(|| parallel::run_with(threads, || iir::sosfilt_into(&secs, src, d, channels, &mut pairs)))
            .map_err(to_py)?
    } else {
        iir::sosfilt_into(&secs, src, d, channels, &mut pairs)
    }
    .map_err(to_py)?;
    for (dst, p) in s.chunks_exact_mut(2).zip(&pairs) {
        dst.copy_from_slice(p);
    }
    Ok(finite)
}

/// Whether every value of a C-contiguous float64 array is finite (no NaN or
/// inf), without the temporary mask of `np.isfinite(a).all()`.
#[pyfunction]
#[pyo3(signature = (a, *, threads=None))]
fn all_finite(py: Python<'_>, a: PyReadonlyArrayDyn<'_, f64>, threads: Option<i64>) -> PyResult<bool> {
    let threads = threads_of(threads)?;
    let s = a.as_slice().map_err(slice_err("a"))?;
    if s.len() < (1 << 20) {
        return Ok(sums::all_finite(s));
    }
    py.detach(|| parallel::run_with(threads, || sums::par_all_finite(s))).map_err(to_py)
}

fn fit_tuple(f: LinFit) -> (f64, f64, f64, f64, f64, f64, u64, bool) {
    (f.slope, f.intercept, f.r, f.slope_stderr, f.intercept_stderr, f.resid_std, f.n, f.degenerate)
}

/// Mergeable centred moments of (x, y) (docs/method.md 3).
#[pyclass(name = "Moments", module = "tribodyn._core", from_py_object)]
#[derive(Clone, Default)]
struct PyMoments {
    inner: Moments,
}

#[pymethods]
impl PyMoments {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Adds the samples of one chunk.
    #[pyo3(signature = (x, y, *, threads=None))]
    fn update(
        &mut self,
        py: Python<'_>,
        x: PyReadonlyArray1<'_, f64>,
        y: PyReadonlyArray1<'_, f64>,
        threads: Option<i64>,
    ) -> PyResult<()> {
        let threads = threads_of(threads)?;
        let (xs, ys) = (x.as_slice().map_err(slice_err("x"))?, y.as_slice().map_err(slice_err("y"))?);
        let m = if regression::uses_threads(xs.len()) {
            py.detach(|| parallel::run_with(threads, || Moments::of(xs, ys))).map_err(to_py)?
        } else {
            Moments::of(xs, ys)
        }
        .map_err(to_py)?;
        self.inner = self.inner.merge(&m);
        Ok(())
    }

    /// The moments of the union of both sample sets (a new object).
    fn merge(&self, other: &PyMoments) -> PyMoments {
        PyMoments { inner: self.inner.merge(&other.inner) }
    }

    /// (slope, intercept, r, slope_stderr, intercept_stderr, resid_std, n, degenerate).
    fn fit(&self) -> (f64, f64, f64, f64, f64, f64, u64, bool) {
        fit_tuple(self.inner.fit())
    }

    /// (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo).
    fn state(&self) -> StateTuple {
        let m = &self.inner;
        (m.n, m.mean_x, m.mean_y, m.sxx, m.syy, m.sxy, m.sse, m.mean_x_lo, m.mean_y_lo)
    }

    /// Rebuilds moments from `state()` (for pickling and transport): the
    /// tuple (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo),
    /// or its first seven (the low parts then 0.0).
    #[staticmethod]
    fn from_state(state: &Bound<'_, PyAny>) -> PyResult<PyMoments> {
        type Seven = (u64, f64, f64, f64, f64, f64, f64);
        let (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo) = match state.extract::<StateTuple>() {
            Ok(full) => full,
            Err(_) => {
                let (n, mx, my, sxx, syy, sxy, sse) = state.extract::<Seven>().map_err(|_| {
                    let want = "(n, mean_x, mean_y, sxx, syy, sxy, sse[, mean_x_lo, mean_y_lo])";
                    Fault::Type(format!("state must be a tuple {want}, got {state:?}"))
                })?;
                (n, mx, my, sxx, syy, sxy, sse, 0.0, 0.0)
            }
        };
        Ok(PyMoments { inner: Moments { n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo } })
    }
}

/// (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo)
type StateTuple = (u64, f64, f64, f64, f64, f64, f64, f64, f64);

/// (slope, intercept, r, slope_stderr, intercept_stderr, resid_std, n, degenerate)
type FitTuple = (f64, f64, f64, f64, f64, f64, u64, bool);

/// One-shot least squares of y on x.
#[pyfunction]
#[pyo3(signature = (x, y, *, threads=None))]
fn linfit(
    py: Python<'_>,
    x: PyReadonlyArray1<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    threads: Option<i64>,
) -> PyResult<FitTuple> {
    let threads = threads_of(threads)?;
    let (xs, ys) = (x.as_slice().map_err(slice_err("x"))?, y.as_slice().map_err(slice_err("y"))?);
    let f = if regression::uses_threads(xs.len()) {
        py.detach(|| parallel::run_with(threads, || regression::linfit(xs, ys))).map_err(to_py)?
    } else {
        // One window: entering the pool would cost more than the work.
        regression::linfit(xs, ys)
    }
    .map_err(to_py)?;
    Ok(fit_tuple(f))
}

fn opt_slice<'a>(a: &'a Option<PyReadonlyArray1<'_, f64>>, name: &str) -> PyResult<Option<&'a [f64]>> {
    a.as_ref().map(|v| v.as_slice().map_err(slice_err(name))).transpose()
}

/// The settings every window call of one analysis shares, validated and
/// converted once: window length, deadband, fz bins, the columns asked
/// for, the options beyond the paper, the high-pass of raw forces, the
/// thread count and how a NaN or inf is named. Frozen; `replace` makes a
/// variant (another length, auxiliary role or thread count).
#[pyclass(name = "WindowSpec", module = "tribodyn._core", frozen)]
#[derive(Clone)]
struct PyWindowSpec {
    opt: WindowOptions,
    names: Vec<String>,
    cols: Vec<Column>,
    threads: usize,
    /// Second-order sections and their steady state for a unit input.
    highpass: Option<(Vec<iir::Section>, Vec<[f64; 2]>)>,
    naming: Option<Naming>,
}

/// The option names of `WindowSpec(options=...)`.
const OPTION_NAMES: &str = "lag, lags, lines, segments, delay, classical";

/// One entry of `WindowSpec(options=...)`, its conversion error naming it.
fn option<'py, T: FromPyObjectOwned<'py>>(key: &str, v: &Bound<'py, PyAny>, what: &str) -> PyResult<T> {
    v.extract::<T>().map_err(|_| bad(format!("the kernel option {key:?} must be {what}, got {v:?}")))
}

/// The options beyond the paper from `WindowSpec(options=...)` (see [`ext_options`]).
fn ext_of(columns: &[String], options: Option<&Bound<'_, PyDict>>) -> PyResult<extended::ExtOptions> {
    let (mut lag, mut lines, mut segments, mut delay, mut classical) = (0, None::<Vec<f64>>, 4, 0.0, None);
    let mut lags = None::<Vec<usize>>;
    for (k, v) in options.into_iter().flat_map(|d| d.iter()) {
        let key: String =
            k.extract().map_err(|_| Fault::Type(format!("a kernel option's name must be a str, got {k:?}")))?;
        match key.as_str() {
            "lag" => lag = option(&key, &v, "a sample count >= 0")?,
            "lags" => lags = option(&key, &v, "a list of sample counts >= 1 or None")?,
            "lines" => lines = option(&key, &v, "a list of frequencies (cycles per sample) or None")?,
            "segments" => segments = option(&key, &v, "a count >= 0")?,
            "delay" => delay = option(&key, &v, "a number of samples")?,
            "classical" => classical = option(&key, &v, "(min_fn, tare_fy, tare_fz) or None")?,
            other => {
                return Err(
                    Fault::Type(format!("unknown kernel option {other:?}; the options are {OPTION_NAMES}")).into()
                )
            }
        }
    }
    let mut ext = ext_options(columns, lag, lines.as_deref(), segments, delay, classical)?;
    if columns.iter().any(|c| c == "lag_sums") {
        let lags = lags.unwrap_or_default();
        if lags.is_empty() || lags.len() > extended::MAX_EXTRA_LAGS {
            return Err(bad(format!(
                "the column 'lag_sums' needs 1 to {} extra lags, got {}",
                extended::MAX_EXTRA_LAGS,
                lags.len()
            )));
        }
        ext.extra_lags[..lags.len()].copy_from_slice(&lags);
        ext.n_extra = lags.len();
        ext.check().map_err(to_py)?;
    }
    Ok(ext)
}

/// (sos, zi) of `WindowSpec(highpass=...)`: `zi` one row per section.
fn highpass_of(
    sos: &PyReadonlyArray2<'_, f64>,
    zi: &PyReadonlyArray2<'_, f64>,
) -> PyResult<(Vec<iir::Section>, Vec<[f64; 2]>)> {
    let secs = sections(sos)?;
    let zs = zi.as_array();
    if zs.shape() != [secs.len(), 2] {
        return Err(bad(format!("zi must have shape ({}, 2), got {:?}", secs.len(), zs.shape())));
    }
    let zi: Vec<[f64; 2]> = zs.rows().into_iter().map(|r| [r[0], r[1]]).collect();
    Ok((secs, zi))
}

fn naming_of(aux: String, fs: Option<f64>) -> PyResult<Naming> {
    if fs.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
        return Err(bad(format!("fs must be finite and > 0, got {}", fs.unwrap_or_default())));
    }
    Ok(Naming { aux, fs })
}

#[pymethods]
impl PyWindowSpec {
    /// `deadband` is (kind, value): "force" (N) or "sigma" (a multiple of
    /// the window's std of fz). `options`: a dict of lag, lags, lines,
    /// segments, delay, classical (see `windows_stats`). `highpass`: (sos, zi) of the
    /// raw forces' filter (`windows_stats_file` only). `naming`: (the
    /// auxiliary channel's role, fs): a NaN or inf is then named by role
    /// and time. Every argument is checked here: a bad one is a
    /// `ValueError` (an unknown option a `TypeError`).
    #[new]
    #[pyo3(signature = (length, deadband, n_bins, columns, *, options=None, highpass=None, threads=None, naming=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        length: usize,
        deadband: (String, f64),
        n_bins: usize,
        columns: Vec<String>,
        options: Option<&Bound<'_, PyDict>>,
        highpass: Option<(PyReadonlyArray2<'_, f64>, PyReadonlyArray2<'_, f64>)>,
        threads: Option<i64>,
        naming: Option<(String, f64)>,
    ) -> PyResult<Self> {
        if length == 0 {
            return Err(bad("the window length must be at least 1 sample"));
        }
        if n_bins == 0 || n_bins > windows::MAX_BINS {
            return Err(bad(format!("n_bins must be in [1, {}], got {n_bins}", windows::MAX_BINS)));
        }
        let deadband = parse_deadband(&deadband.0, deadband.1)?;
        let cols = columns_of(&columns)?;
        let ext = ext_of(&columns, options)?;
        let highpass = highpass.as_ref().map(|(sos, zi)| highpass_of(sos, zi)).transpose()?;
        let naming = naming.map(|(aux, fs)| naming_of(aux, Some(fs))).transpose()?;
        Ok(PyWindowSpec {
            opt: WindowOptions { len: length, orientation: 1.0, deadband, n_bins, ext },
            names: columns,
            cols,
            threads: threads_of(threads)?,
            highpass,
            naming,
        })
    }

    /// The same spec with another window `length`, auxiliary role `aux`
    /// (how a NaN or inf in it is named) or thread count (a new object).
    #[pyo3(signature = (*, length=None, aux=None, threads=None))]
    fn replace(&self, length: Option<usize>, aux: Option<String>, threads: Option<i64>) -> PyResult<Self> {
        let mut out = self.clone();
        if let Some(len) = length {
            if len == 0 {
                return Err(bad("the window length must be at least 1 sample"));
            }
            out.opt.len = len;
        }
        if let Some(aux) = aux {
            out.naming = Some(naming_of(aux, self.naming.as_ref().and_then(|n| n.fs))?);
        }
        if threads.is_some() {
            out.threads = threads_of(threads)?;
        }
        Ok(out)
    }

    /// Samples per window.
    #[getter]
    fn length(&self) -> usize {
        self.opt.len
    }

    /// (kind, value): ("force", N) or ("sigma", k).
    #[getter]
    fn deadband(&self) -> (&'static str, f64) {
        match self.opt.deadband {
            Deadband::Force(v) => ("force", v),
            Deadband::Sigma(v) => ("sigma", v),
        }
    }

    /// Equal-width fz bins per window.
    #[getter]
    fn n_bins(&self) -> usize {
        self.opt.n_bins
    }

    /// The columns asked for, in order.
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.names.clone()
    }

    /// Threads of a call.
    #[getter]
    fn threads(&self) -> usize {
        self.threads
    }

    /// Whether the spec carries a high-pass for raw forces.
    #[getter]
    fn raw(&self) -> bool {
        self.highpass.is_some()
    }

    fn __repr__(&self) -> String {
        let (kind, value) = self.deadband();
        let naming = match &self.naming {
            Some(n) => format!(", naming=({:?}, {:?})", n.aux, n.fs),
            None => String::new(),
        };
        format!(
            "WindowSpec(length={}, deadband=({kind:?}, {value:?}), n_bins={}, columns={:?}, threads={}, raw={}{naming})",
            self.opt.len,
            self.opt.n_bins,
            self.names,
            self.threads,
            if self.highpass.is_some() { "True" } else { "False" },
        )
    }
}

impl PyWindowSpec {
    /// A kernel error of a window call, named as the spec says.
    fn fault(&self, e: KernelError) -> PyErr {
        match &self.naming {
            Some(n) => Fault::Window(e, n.clone()).into(),
            None => Fault::Kernel(e).into(),
        }
    }
}

/// Per-window statistics (docs/method.md 3-6) of the windows of
/// `spec.length` samples starting at `starts`: a dict of the spec's
/// columns, in that order, one row per window (see [`column`] for the
/// names). `raw` = (fy, fz before the high-pass) defines `mu_classic`. A
/// non-finite sample in a window raises `NonFiniteError`, its sample
/// counted from `offset` (the caller's index of sample 0 of the arrays).
/// `spec.threads == 1` keeps the work on the calling thread.
#[pyfunction]
#[pyo3(signature = (spec, fx, fy, fz, aux, starts, *, raw=None, offset=0))]
#[allow(clippy::too_many_arguments)]
fn windows_stats<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyWindowSpec>,
    fx: Option<PyReadonlyArray1<'py, f64>>,
    fy: PyReadonlyArray1<'py, f64>,
    fz: PyReadonlyArray1<'py, f64>,
    aux: Option<PyReadonlyArray1<'py, f64>>,
    starts: PyReadonlyArray1<'py, i64>,
    raw: Option<(PyReadonlyArray1<'py, f64>, PyReadonlyArray1<'py, f64>)>,
    offset: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = spec.get();
    let starts: Vec<usize> = starts
        .as_slice()
        .map_err(slice_err("starts"))?
        .iter()
        .map(|&s| usize::try_from(s).map_err(|_| bad(format!("window start {s} is negative"))))
        .collect::<PyResult<_>>()?;
    let (fxs, auxs) = (opt_slice(&fx, "fx")?, opt_slice(&aux, "aux")?);
    let (fys, fzs) = (fy.as_slice().map_err(slice_err("fy"))?, fz.as_slice().map_err(slice_err("fz"))?);
    let raw = match &raw {
        Some((y, z)) => Some((y.as_slice().map_err(slice_err("fy_raw"))?, z.as_slice().map_err(slice_err("fz_raw"))?)),
        None => None,
    };
    let ch = windows::Channels { fx: fxs, fy: fys, fz: fzs, aux: auxs, raw };
    let (opt, threads) = (&spec.opt, spec.threads);
    // A few windows cost less than entering the pool.
    let stats = if starts.len() < 8 || threads == 1 {
        py.detach(|| windows::windows_stats_serial(&ch, &starts, opt))
    } else {
        py.detach(|| parallel::run_with(threads, || windows::windows_stats(&ch, &starts, opt))).map_err(to_py)?
    }
    .map_err(|e| spec.fault(e.shifted(offset)))?;
    let mut out = Columns::new(spec.cols.clone(), stats.len(), opt.n_bins, opt.ext.spec_len(), opt.ext.lag_sums_len())?;
    out.set(0, &stats);
    drop(stats);
    out.into_dict(py, &spec.names)
}

/// One per-window column the kernel can deliver.
#[derive(Clone, Copy)]
enum Column {
    /// A float per window, from the window's statistics and its fit.
    F(fn(&windows::WindowStats, &LinFit) -> f64),
    /// A count per window.
    I(fn(&windows::WindowStats) -> u64),
    /// Samples per fz bin (windows x n_bins, int64).
    BinCount,
    /// COF per fz bin (windows x n_bins).
    BinCof,
    /// Block sums for the estimators (windows x BLOCKS x PRODUCTS).
    Ext,
    /// Cross-spectra at the lines (windows x n_lines x 4).
    Spec,
    /// The instrument's sums at the extra lags (windows x n_extra x 2).
    LagSums,
}

/// The options of the statistics beyond the paper: block sums when the
/// column "ext" is asked for (instrument lag `lag`), line spectra when
/// "spec" is (at `lines`, cycles per sample), and the fz delay correction.
fn ext_options(
    columns: &[String],
    lag: usize,
    lines: Option<&[f64]>,
    segments: usize,
    delay: f64,
    classical: Option<(f64, f64, f64)>,
) -> PyResult<extended::ExtOptions> {
    let mut ext =
        extended::ExtOptions { sums: columns.iter().any(|c| c == "ext"), lag, segments, delay, ..Default::default() };
    if columns.iter().any(|c| c == "spec") {
        let lines = lines.unwrap_or(&[]);
        if lines.is_empty() || lines.len() > extended::MAX_LINES {
            return Err(bad(format!(
                "the column 'spec' needs 1 to {} line frequencies, got {}",
                extended::MAX_LINES,
                lines.len()
            )));
        }
        ext.lines[..lines.len()].copy_from_slice(lines);
        ext.n_lines = lines.len();
    }
    let wants_classical =
        columns.iter().any(|c| matches!(c.as_str(), "mu_classical" | "mu_classical_median" | "fz_mean" | "fz_std"));
    if wants_classical {
        let (min_fn, tare_y, tare_z) =
            classical.ok_or_else(|| bad("the classical COF columns need classical=(min_fn, tare_fy, tare_fz)"))?;
        ext.classical = Some(extended::Classical { min_fn, tare_y, tare_z });
    }
    ext.check().map_err(to_py)?;
    Ok(ext)
}

/// The kernel's vocabulary: the column called `name` (orientation +1;
/// docs/method.md 3-5). Which of them a table holds, in which order, with
/// which unit and meaning, is declared once in Python (`tribodyn.columns`).
fn column(name: &str) -> Option<Column> {
    use Column::{BinCof, BinCount, F, I};
    Some(match name {
        "slope" => F(|_, f| f.slope),
        "intercept" => F(|_, f| f.intercept),
        "r" => F(|_, f| f.r),
        "slope_stderr" => F(|_, f| f.slope_stderr),
        "intercept_stderr" => F(|_, f| f.intercept_stderr),
        "resid_std" => F(|_, f| f.resid_std),
        "sse" => F(|w, _| w.moments.sse),
        "mean_z" => F(|w, _| w.moments.mean_x),
        "mean_y" => F(|w, _| w.moments.mean_y),
        "szz" => F(|w, _| w.moments.sxx),
        "syy" => F(|w, _| w.moments.syy),
        "syz" => F(|w, _| w.moments.sxy),
        "c_xy" => F(|w, _| w.c_xy),
        "c_xz" => F(|w, _| w.c_xz),
        "c_yz" => F(|w, _| w.c_yz),
        "deadband" => F(|w, _| w.deadband),
        "mu_a" => F(|w, _| w.mu_a),
        "mu_b" => F(|w, _| w.mu_b),
        "fz_min" => F(|w, _| w.fz_min),
        "fz_max" => F(|w, _| w.fz_max),
        "aux_mean" => F(|w, _| w.aux_mean),
        "mu_classic" => F(|w, _| w.mu_classic),
        "n" => I(|w| w.moments.n),
        "n_a" => I(|w| w.n_a),
        "n_b" => I(|w| w.n_b),
        "out_of_range" => I(|w| u64::from(w.out_of_range)),
        "bin_count" => BinCount,
        "bin_cof" => BinCof,
        "mu_classical" => F(|w, _| w.classical[0]),
        "mu_classical_median" => F(|w, _| w.classical[1]),
        "fz_mean" => F(|w, _| w.classical[2]),
        "fz_std" => F(|w, _| w.classical[3]),
        "ext" => Column::Ext,
        "spec" => Column::Spec,
        "lag_sums" => Column::LagSums,
        _ => return None,
    })
}

const COLUMN_NAMES: &str = "slope, intercept, r, slope_stderr, intercept_stderr, resid_std, sse, mean_z, mean_y, \
szz, syy, syz, c_xy, c_xz, c_yz, deadband, mu_a, mu_b, fz_min, fz_max, aux_mean, mu_classic, n, n_a, n_b, \
out_of_range, bin_count, bin_cof, mu_classical, mu_classical_median, fz_mean, fz_std, ext, spec, lag_sums";

fn columns_of(names: &[String]) -> PyResult<Vec<Column>> {
    names
        .iter()
        .map(|n| column(n).ok_or_else(|| bad(format!("unknown kernel column {n:?}; the kernel has {COLUMN_NAMES}"))))
        .collect()
}

/// One column's values, allocated once at its final size.
enum Buf {
    F(Vec<f64>),
    I(Vec<i64>),
}

/// The per-window statistics as the columns asked for (one row per
/// window), each allocated once at its final size: rows are written as the
/// kernel delivers its windows, so their per-window vectors are freed (and
/// their memory reused) block after block. Fresh memory is costly on its
/// first touch, so the peak of it matters.
struct Columns {
    rows: usize,
    n_bins: usize,
    spec: usize,
    /// Values per window of the column "lag_sums".
    lag_w: usize,
    cols: Vec<(Column, Buf)>,
}

/// A vector of `len` zeros, or a `MemoryError` (never an abort) when it
/// cannot be had.
fn zeros<T: Clone + Default>(len: usize, what: &str) -> PyResult<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| {
        no_memory(format!("the per-window table needs {len} values for {what}, more memory than there is"))
    })?;
    v.resize(len, T::default());
    Ok(v)
}

impl Columns {
    fn new(cols: Vec<Column>, rows: usize, n_bins: usize, spec: usize, lag_w: usize) -> PyResult<Self> {
        let overflow = |what: &str| no_memory(format!("{rows} windows x {what} overflow"));
        let bins = rows.checked_mul(n_bins).ok_or_else(|| overflow("bins"))?;
        let ext_len = rows.checked_mul(EXT_WIDTH).ok_or_else(|| overflow("block sums"))?;
        let spec_len = rows.checked_mul(spec).ok_or_else(|| overflow("line spectra"))?;
        let lag_len = rows.checked_mul(lag_w).ok_or_else(|| overflow("lag sums"))?;
        let cols = cols
            .into_iter()
            .map(|c| {
                let buf = match c {
                    Column::F(_) => Buf::F(zeros(rows, "a column")?),
                    Column::I(_) => Buf::I(zeros(rows, "a column")?),
                    Column::BinCount => Buf::I(zeros(bins, "bin_count")?),
                    Column::BinCof => Buf::F(zeros(bins, "bin_cof")?),
                    Column::Ext => Buf::F(zeros(ext_len, "ext")?),
                    Column::Spec => Buf::F(zeros(spec_len, "spec")?),
                    Column::LagSums => Buf::F(zeros(lag_len, "lag_sums")?),
                };
                Ok((c, buf))
            })
            .collect::<PyResult<_>>()?;
        Ok(Columns { rows, n_bins, spec, lag_w, cols })
    }

    /// Rows `first..` from consecutive windows.
    fn set(&mut self, first: usize, stats: &[windows::WindowStats]) {
        let nb = self.n_bins;
        for (k, w) in stats.iter().enumerate() {
            let row = first + k;
            let fit: LinFit = w.moments.fit();
            for (c, buf) in self.cols.iter_mut() {
                match (c, buf) {
                    (Column::F(get), Buf::F(v)) => v[row] = get(w, &fit),
                    (Column::I(get), Buf::I(v)) => v[row] = get(w) as i64,
                    (Column::BinCount, Buf::I(v)) => {
                        for (dst, &c) in v[row * nb..(row + 1) * nb].iter_mut().zip(&w.bin_count) {
                            *dst = c as i64;
                        }
                    }
                    (Column::BinCof, Buf::F(v)) => v[row * nb..(row + 1) * nb].copy_from_slice(&w.bin_cof),
                    (Column::Ext, Buf::F(v)) => v[row * EXT_WIDTH..(row + 1) * EXT_WIDTH].copy_from_slice(&w.ext_sums),
                    (Column::Spec, Buf::F(v)) => v[row * self.spec..(row + 1) * self.spec].copy_from_slice(&w.spec),
                    (Column::LagSums, Buf::F(v)) => {
                        v[row * self.lag_w..(row + 1) * self.lag_w].copy_from_slice(&w.lag_sums)
                    }
                    _ => unreachable!("each column's buffer is made for its kind in Columns::new"),
                }
            }
        }
    }

    fn into_dict<'py>(self, py: Python<'py>, names: &[String]) -> PyResult<Bound<'py, PyDict>> {
        let out = PyDict::new(py);
        let shape = [self.rows, self.n_bins];
        for (name, (c, buf)) in names.iter().zip(self.cols) {
            let bins = matches!(c, Column::BinCount | Column::BinCof);
            match (c, buf) {
                (Column::Ext, Buf::F(v)) => {
                    out.set_item(
                        name,
                        PyArray1::from_vec(py, v).reshape([self.rows, extended::BLOCKS, extended::PRODUCTS])?,
                    )?;
                    continue;
                }
                (Column::Spec, Buf::F(v)) => {
                    out.set_item(name, PyArray1::from_vec(py, v).reshape([self.rows, self.spec / 4, 4])?)?;
                    continue;
                }
                (Column::LagSums, Buf::F(v)) => {
                    out.set_item(name, PyArray1::from_vec(py, v).reshape([self.rows, self.lag_w / 2, 2])?)?;
                    continue;
                }
                (_, buf) => match buf {
                    Buf::F(v) if bins => out.set_item(name, PyArray1::from_vec(py, v).reshape(shape)?)?,
                    Buf::I(v) if bins => out.set_item(name, PyArray1::from_vec(py, v).reshape(shape)?)?,
                    Buf::F(v) => out.set_item(name, PyArray1::from_vec(py, v))?,
                    Buf::I(v) => out.set_item(name, PyArray1::from_vec(py, v))?,
                },
            }
        }
        Ok(out)
    }
}

/// A new handle on the open file descriptor `fd` (which stays the caller's).
#[cfg(unix)]
fn dup_fd(fd: i32) -> PyResult<std::fs::File> {
    use std::os::fd::BorrowedFd;
    if fd < 0 {
        return Err(bad(format!("fd must be an open file descriptor, got {fd}")));
    }
    // SAFETY: the descriptor is only borrowed for the duplication below; an
    // fd that is not open makes it fail with EBADF.
    let borrowed = unsafe { BorrowedFd::borrow_raw(fd) };
    borrowed.try_clone_to_owned().map(std::fs::File::from).map_err(|e| os_error(format!("file descriptor {fd}: {e}")))
}

#[cfg(not(unix))]
fn dup_fd(_fd: i32) -> PyResult<std::fs::File> {
    Err(os_error("reading a file descriptor directly needs a Unix system"))
}

fn parse_deadband(kind: &str, value: f64) -> PyResult<Deadband> {
    match kind {
        "force" => Ok(Deadband::Force(value)),
        "sigma" => Ok(Deadband::Sigma(value)),
        other => Err(bad(format!("the deadband kind must be 'force' or 'sigma', got {other:?}"))),
    }
}

/// Per-window statistics of windows k0..k1 (`windows` = (k0, k1, step):
/// window k = samples [k * step, k * step + spec.length)) of channels
/// stored in the open file `fd` (a file descriptor, duplicated for the
/// call and left open) as contiguous little-endian f64 runs starting at the
/// byte offsets `(fx, fy, fz, aux)` (fx, aux may be None), `n` samples
/// each, or as `Extents` (any numeric type, segments, interleaved rows,
/// scaling). The samples are read with `pread`, `block` windows per task,
/// on `spec.threads` threads; the spec's columns, with the same results as
/// `windows_stats` on those samples. A file that shrinks meanwhile is a
/// `ValueError` (a short read), never a crash.
///
/// With the spec's `highpass` (sos and zi, its steady state for a unit
/// input, one row per section) the force channels are raw: they are
/// high-passed from sample `origin` on (state carried, each channel started
/// at `zi * x[origin]`) and the classical COF of the raw forces is added
/// (`mu_classic`); the windows must not overlap (step >= length).
#[pyfunction]
#[pyo3(signature = (spec, fd, offsets, n, windows, *, block=512, origin=0))]
#[allow(clippy::too_many_arguments)]
fn windows_stats_file<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyWindowSpec>,
    fd: i32,
    offsets: Offsets<'py>,
    n: usize,
    windows: (usize, usize, usize),
    block: usize,
    origin: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = spec.get();
    let (k0, k1, step) = windows;
    let file = dup_fd(fd)?;
    let layout = mapped::FileLayout {
        fx: offsets.0.as_ref().map(source_of).transpose()?,
        fy: source_of(&offsets.1)?,
        fz: source_of(&offsets.2)?,
        aux: offsets.3.as_ref().map(source_of).transpose()?,
        n,
    };
    let grid = mapped::Grid { k0, k1, step, block };
    let (opt, threads) = (&spec.opt, spec.threads);
    // Checked before the columns are allocated ((k1 - k0) x n_bins of them).
    mapped::check(&file, &layout, &grid, opt).map_err(to_py)?;
    let cols = std::sync::Mutex::new(Columns::new(
        spec.cols.clone(),
        k1.saturating_sub(k0),
        opt.n_bins,
        opt.ext.spec_len(),
        opt.ext.lag_sums_len(),
    )?);
    // Each block's rows go into the columns as soon as it is done.
    let sink = |first: usize, stats: Vec<windows::WindowStats>| {
        cols.lock().unwrap_or_else(|e| e.into_inner()).set(first, &stats);
    };
    py.detach(|| match &spec.highpass {
        // Its own threads (the caller and scoped helpers), no pool to wake.
        None => mapped::windows_stats_mapped_each(&file, &layout, &grid, opt, threads, &sink),
        Some((sos, zi)) => {
            let hp = mapped::HighPass { sos, zi, origin };
            parallel::run_with(threads, || {
                mapped::windows_stats_mapped_highpass_each(&file, &layout, &grid, opt, &hp, &sink)
            })
            .and_then(|r| r)
        }
    })
    .map_err(|e| spec.fault(e))?;
    cols.into_inner().unwrap_or_else(|e| e.into_inner()).into_dict(py, &spec.names)
}

/// `(fx, fy, fz, aux)` of `windows_stats_file`, each as [`source_of`] takes it.
type Offsets<'py> = (Option<Bound<'py, PyAny>>, Bound<'py, PyAny>, Bound<'py, PyAny>, Option<Bound<'py, PyAny>>);

/// A channel of `windows_stats_file`: a `PyExtents`, else a byte offset
/// (contiguous little-endian f64; a negative one is an OverflowError).
fn source_of(ob: &Bound<'_, PyAny>) -> PyResult<mapped::Source> {
    if let Ok(e) = ob.extract::<PyRef<'_, PyExtents>>() {
        return Ok(mapped::Source::Extents(e.inner.clone()));
    }
    Ok(mapped::Source::F64(ob.extract::<u64>()?))
}

/// Sets the thread count of calls that name none (0 = all cores; at most
/// `max_threads()`).
#[pyfunction]
fn set_threads(n: i64) -> PyResult<()> {
    let n =
        usize::try_from(n).map_err(|_| bad(format!("threads must be in [0, {}], got {n}", parallel::max_threads())))?;
    parallel::set_default_threads(n).map_err(to_py)
}

/// The thread count of calls that name none.
#[pyfunction]
fn get_threads() -> usize {
    parallel::default_threads()
}

/// The largest thread count a call may ask for (4 x the cores).
#[pyfunction]
fn max_threads() -> usize {
    parallel::max_threads()
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(xcorr, m)?)?;
    m.add_function(wrap_pyfunction!(xcorr_auto_method, m)?)?;
    m.add_function(wrap_pyfunction!(pearson, m)?)?;
    m.add_function(wrap_pyfunction!(row_quantiles, m)?)?;
    m.add_function(wrap_pyfunction!(lagged_sums, m)?)?;
    m.add_function(wrap_pyfunction!(mapped_windows_alone, m)?)?;
    m.add_function(wrap_pyfunction!(resample_stats, m)?)?;
    m.add_function(wrap_pyfunction!(select_ranks, m)?)?;
    m.add_function(wrap_pyfunction!(histogram_uniform, m)?)?;
    m.add_function(wrap_pyfunction!(find_peaks, m)?)?;
    m.add_function(wrap_pyfunction!(sosfilt_inplace, m)?)?;
    m.add_function(wrap_pyfunction!(sosfilt_into, m)?)?;
    m.add_function(wrap_pyfunction!(all_finite, m)?)?;
    m.add_function(wrap_pyfunction!(linfit, m)?)?;
    m.add_function(wrap_pyfunction!(windows_stats, m)?)?;
    m.add_function(wrap_pyfunction!(windows_stats_file, m)?)?;
    m.add_function(wrap_pyfunction!(files::tdms_index, m)?)?;
    m.add_function(wrap_pyfunction!(ranges::pread_ranges, m)?)?;
    m.add_function(wrap_pyfunction!(ranges::extents_read_ranges, m)?)?;
    m.add_class::<PyExtents>()?;
    m.add_class::<PyWindowSpec>()?;
    m.add_class::<PyTextDialect>()?;
    m.add_class::<PyTextScan>()?;
    m.add_class::<files::PyFileDigest>()?;
    m.add_function(wrap_pyfunction!(files::text_scan, m)?)?;
    m.add_function(wrap_pyfunction!(files::text_parse, m)?)?;
    m.add_function(wrap_pyfunction!(set_threads, m)?)?;
    m.add_function(wrap_pyfunction!(get_threads, m)?)?;
    m.add_function(wrap_pyfunction!(max_threads, m)?)?;
    m.add("NonFiniteError", m.py().get_type::<NonFiniteError>())?;
    m.add("FORCE_LIMIT", windows::FORCE_LIMIT)?;
    m.add("MAPPED_ALONE_GAP", mapped::ALONE_GAP)?;
    m.add_class::<PyMoments>()?;
    Ok(())
}
