//! The file readers' bindings: `Extents` (where a channel's samples lie
//! in a file), the TDMS index, and the text body's scan and parse with
//! their options (`TextDialect`, `TextScan`).

use crate::{bad, dup_fd, threads_of, to_py, zeros, Fault};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tribodyn_core::io::{mapped, text};

/// Where a channel's samples lie in a file: runs of one numeric type and
/// byte order (TDMS segments, interleaved rows, DAQmx raw integers, HDF5
/// chunks), with scaling. Read with `pread` (any number of threads).
#[pyclass(name = "Extents", module = "tribodyn._core", frozen)]
pub(crate) struct PyExtents {
    pub(crate) inner: std::sync::Arc<mapped::Extents>,
}

#[pymethods]
impl PyExtents {
    /// Extents of `dtype` (NumPy's name: "f8", "i2", ...) stored
    /// contiguously: `parts` is a list of (sample count, byte offset).
    #[staticmethod]
    fn contiguous(dtype: &str, big_endian: bool, parts: Vec<(u64, u64)>) -> PyResult<Self> {
        let num = mapped::Num::from_name(dtype).ok_or_else(|| bad(format!("unknown numeric type {dtype:?}")))?;
        let w = num.width();
        let mut start = 0u64;
        let mut out = Vec::with_capacity(parts.len());
        for (count, offset) in parts {
            let end = count.checked_mul(w).and_then(|b| b.checked_add(offset));
            let end = end.ok_or_else(|| bad("extent overflows"))?;
            out.push(mapped::Extent { start, ..mapped::Extent::single(count, offset, w, (offset, end)) });
            start = start.checked_add(count).ok_or_else(|| bad("extent counts overflow"))?;
        }
        let ext = mapped::Extents { num, big_endian, parts: out, ops: Vec::new() };
        ext.check(u64::MAX).map_err(to_py)?;
        Ok(PyExtents { inner: std::sync::Arc::new(ext) })
    }

    /// The same samples scaled by `ops` after these' own, in order: each
    /// ("linear", [slope, intercept]) or ("poly", [c0, c1, ...]).
    fn scaled(&self, ops: Vec<(String, Vec<f64>)>) -> PyResult<Self> {
        let mut ext = (*self.inner).clone();
        for (kind, v) in ops {
            ext.ops.push(match (kind.as_str(), v.as_slice()) {
                ("linear", &[slope, intercept]) => mapped::Op::Linear { slope, intercept },
                ("poly", c) => mapped::Op::Poly(c.to_vec()),
                _ => return Err(bad(format!("unknown scaling {kind:?} with {} values", v.len()))),
            });
        }
        Ok(PyExtents { inner: std::sync::Arc::new(ext) })
    }

    /// Samples [start, stop) as float64 (scaled), read from the open file `fd`.
    fn read<'py>(&self, py: Python<'py>, fd: i32, start: u64, stop: u64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let file = dup_fd(fd)?;
        let inner = self.inner.clone();
        let out = py
            .detach(move || {
                let mut out = Vec::new();
                let mut cache = mapped::ByteCache::default();
                inner.read(&file, start, stop, &mut out, &mut cache).map(|_| out)
            })
            .map_err(to_py)?;
        Ok(PyArray1::from_vec(py, out))
    }

    /// Samples of the channel.
    #[getter]
    fn n(&self) -> u64 {
        self.inner.len()
    }

    /// NumPy's name of the stored type ("f8", "i2", ...).
    #[getter]
    fn dtype(&self) -> &'static str {
        self.inner.num.name()
    }

    /// Whether the samples are stored big-endian.
    #[getter]
    fn big_endian(&self) -> bool {
        self.inner.big_endian
    }

    /// Runs of samples (one per segment or chunk; consecutive ones, and
    /// equal ones at a fixed distance, merged).
    #[getter]
    fn runs(&self) -> usize {
        self.inner.parts.len()
    }

    /// Whether scaling is applied.
    #[getter]
    fn is_scaled(&self) -> bool {
        !self.inner.ops.is_empty()
    }

    /// One past the last byte read.
    #[getter]
    fn end(&self) -> u64 {
        self.inner.end()
    }
}

/// The segment index of the TDMS file open as `fd` (see `tribodyn.io.tdms`),
/// its metadata read from the `.tdms_index` open as `index_fd` if given
/// (and it matches the data file): a dict with "segments", "warnings" (npTDMS's log, as it would say it),
/// "fallback" (why the file is not read natively, or None) and "objects":
/// a list of (path, properties [(name, type code, value bytes, big-endian)],
/// data type code or None, values, {scale key: Extents} (-1 for the
/// channel's own samples, else a DAQmx scale id), why not native or None).
/// A damaged file is a ValueError naming the segment.
#[pyfunction]
#[pyo3(signature = (fd, index_fd=None))]
pub(crate) fn tdms_index<'py>(py: Python<'py>, fd: i32, index_fd: Option<i32>) -> PyResult<Bound<'py, PyDict>> {
    use pyo3::types::{PyBytes, PyList};
    let file = dup_fd(fd)?;
    let index = index_fd.map(dup_fd).transpose()?;
    let idx = py.detach(|| tribodyn_core::io::tdms::read_index(&file, index.as_ref())).map_err(to_py)?;
    let d = PyDict::new(py);
    d.set_item("segments", idx.segments)?;
    d.set_item("warnings", idx.warnings)?;
    d.set_item("fallback", idx.fallback)?;
    let objs = PyList::empty(py);
    for o in idx.objects {
        let props = PyList::empty(py);
        for (name, code, value, big) in o.properties {
            props.append((name, code, PyBytes::new(py, &value), big))?;
        }
        let runs = PyDict::new(py);
        for (k, ext) in o.runs {
            ext.check(u64::MAX).map_err(to_py)?; // built consistent; checked before any read trusts it
            runs.set_item(k, PyExtents { inner: std::sync::Arc::new(ext) })?;
        }
        objs.append((o.path, props, o.code, o.n, runs, o.unsupported))?;
    }
    d.set_item("objects", objs)?;
    Ok(d)
}

/// How a text file's fields are separated and which lines are skipped
/// (the rules of `text_scan` and `text_parse`), checked when it is made.
#[pyclass(name = "TextDialect", module = "tribodyn._core", frozen)]
#[derive(Clone)]
pub(crate) struct PyTextDialect {
    pub(crate) inner: text::Dialect,
}

#[pymethods]
impl PyTextDialect {
    /// `delimiter`: one ASCII character, or None for runs of whitespace;
    /// `decimal`: "." or ","; `comment`: ASCII text that starts a skipped
    /// line, or None; `skip_blank`: blank lines are skipped (else they end
    /// a run). A bad argument is a `ValueError`.
    #[new]
    #[pyo3(signature = (delimiter, decimal, comment=None, skip_blank=true))]
    fn new(delimiter: Option<&str>, decimal: &str, comment: Option<&str>, skip_blank: bool) -> PyResult<Self> {
        let delim = match delimiter {
            None => None,
            Some(d) if d.len() == 1 && d.is_ascii() => Some(d.as_bytes()[0]),
            Some(d) => return Err(bad(format!("delimiter must be one ASCII character or None, got {d:?}"))),
        };
        let decimal = match decimal {
            "." => b'.',
            "," => b',',
            d => return Err(bad(format!("decimal must be '.' or ',', got {d:?}"))),
        };
        let comment = match comment {
            Some(c) if c.is_empty() || !c.is_ascii() => {
                return Err(bad(format!("comment must be ASCII text or None, got {c:?}")))
            }
            c => c.map(|c| c.as_bytes().to_vec()),
        };
        Ok(PyTextDialect { inner: text::Dialect { delim, decimal, comment, skip_blank } })
    }

    fn __repr__(&self) -> String {
        let d = &self.inner;
        let py_str = |b: &[u8]| format!("'{}'", b.escape_ascii());
        format!(
            "TextDialect(delimiter={}, decimal={}, comment={}, skip_blank={})",
            d.delim.map_or("None".into(), |c| py_str(&[c])),
            py_str(&[d.decimal]),
            d.comment.as_deref().map_or("None".into(), py_str),
            if d.skip_blank { "True" } else { "False" },
        )
    }
}

/// What makes a line a data row of `text_scan`, and what the scan records.
#[pyclass(name = "TextScan", module = "tribodyn._core", frozen)]
pub(crate) struct PyTextScan {
    pub(crate) inner: text::ScanSpec,
}

#[pymethods]
impl PyTextScan {
    /// `dialect`: the file's `TextDialect`; `nf`: the fields a row has (more
    /// are allowed when blank; None: any); `probe`: a field that must be a
    /// number or empty; `time`: the time column, whose restarts and gaps (a
    /// step above `gap`; NaN: restarts only) are reported, `t_prev` the
    /// time of the row before the run (NaN: none); `keep_times`: time
    /// values kept from the run's first row.
    #[new]
    #[pyo3(signature = (dialect, *, nf, probe, time=None, gap=f64::NAN, t_prev=f64::NAN, keep_times=0))]
    fn new(
        dialect: &PyTextDialect,
        nf: Option<usize>,
        probe: usize,
        time: Option<usize>,
        gap: f64,
        t_prev: f64,
        keep_times: usize,
    ) -> Self {
        let dialect = dialect.inner.clone();
        PyTextScan { inner: text::ScanSpec { dialect, nf, probe, time, gap, t_prev, keep_times } }
    }
}

/// Follows the run of data rows from byte `start` of the text file open as
/// `fd` by the rules of `scan` (see `tribodyn.io._text.native_scan`): a dict with "rows", "lines",
/// "end", "times" (float64), "breaks" [(row, line, offset, prev, now)],
/// "t_prev", "checkpoints" [(row, offset, line)] (about one a MiB), "marks" (more
/// such entries, about one per 64 KiB, see `Checkpoints`) and "last" ((line, offset) or None);
/// lines are counted from the run's first (0).
#[pyfunction]
#[pyo3(signature = (fd, start, scan, *, threads=None))]
pub(crate) fn text_scan<'py>(
    py: Python<'py>,
    fd: i32,
    start: u64,
    scan: &PyTextScan,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = threads_of(threads)?;
    let file = dup_fd(fd)?;
    let spec = &scan.inner;
    let run = py.detach(|| text::scan(&file, start, spec, threads)).map_err(to_py)?;
    let d = PyDict::new(py);
    d.set_item("rows", run.rows)?;
    d.set_item("lines", run.lines)?;
    d.set_item("end", run.end)?;
    d.set_item("times", PyArray1::from_vec(py, run.times))?;
    let breaks: Vec<(u64, u64, u64, f64, f64)> =
        run.breaks.iter().map(|b| (b.row, b.line, b.offset, b.prev, b.now)).collect();
    d.set_item("breaks", breaks)?;
    d.set_item("t_prev", run.t_prev)?;
    d.set_item("checkpoints", run.checkpoints)?;
    d.set_item("marks", run.marks)?;
    d.set_item("last", run.last)?;
    Ok(d)
}

/// Parses the rows of `pieces` [(offset, line, skip, rows)] of the text
/// file open as `fd` by the rules of `dialect` into one float64 array per
/// entry of `usecols`. A row that cannot be read raises ValueError in the
/// reader's words ("line 7: 'x' in channel 'fy' is not a number (corrupt
/// file?)"), each column asked for named by its entry of `names` (by its
/// index without one).
#[pyfunction]
#[pyo3(signature = (fd, pieces, usecols, dialect, *, names=None, threads=None))]
pub(crate) fn text_parse<'py>(
    py: Python<'py>,
    fd: i32,
    pieces: Vec<(u64, u64, u64, u64)>,
    usecols: Vec<usize>,
    dialect: &PyTextDialect,
    names: Option<Vec<Bound<'py, PyAny>>>,
    threads: Option<i64>,
) -> PyResult<Vec<Bound<'py, PyArray1<f64>>>> {
    let threads = threads_of(threads)?;
    let file = dup_fd(fd)?;
    let pieces: Vec<text::Piece> =
        pieces.into_iter().map(|(offset, line, skip, rows)| text::Piece { offset, line, skip, rows }).collect();
    let total: u64 = pieces.iter().map(|p| p.rows).sum();
    let total = usize::try_from(total).map_err(|_| bad("too many rows"))?;
    let mut outs: Vec<Vec<f64>> = Vec::with_capacity(usecols.len());
    for _ in &usecols {
        outs.push(zeros(total, "rows")?);
    }
    let d = &dialect.inner;
    let res = py.detach(|| {
        let mut cols: Vec<&mut [f64]> = outs.iter_mut().map(|v| v.as_mut_slice()).collect();
        text::parse(&file, &pieces, d, &usecols, &mut cols, threads)
    });
    if let Err(e) = res {
        // a message quotes each name as Python's repr does
        let labels = names.iter().flatten().map(|n| Ok(n.repr()?.to_string())).collect::<PyResult<Vec<String>>>()?;
        return Err(Fault::Parse(e, labels).into());
    }
    Ok(outs.into_iter().map(|v| PyArray1::from_vec(py, v)).collect())
}

/// The SHA-256 of a file, hashed in steps (`advance`) that run without the GIL, so that a thread hashing
/// an input is never held back by a thread that holds the GIL (`tribodyn.app.outputs.Digests`).
#[pyclass(name = "FileDigest", module = "tribodyn._core")]
pub(crate) struct PyFileDigest {
    inner: tribodyn_core::io::digest::FileDigest,
}

#[pymethods]
impl PyFileDigest {
    /// Opens ``path`` (an OSError when it cannot be opened).
    #[new]
    fn new(path: std::path::PathBuf) -> PyResult<Self> {
        Ok(PyFileDigest { inner: tribodyn_core::io::digest::FileDigest::open(&path)? })
    }

    /// Hashes up to ``max_bytes`` more bytes of the file without the GIL; True once the file's end was
    /// reached (an OSError when a read fails).
    fn advance(&mut self, py: Python<'_>, max_bytes: u64) -> PyResult<bool> {
        let inner = &mut self.inner;
        Ok(py.detach(|| inner.advance(max_bytes))?)
    }

    /// Bytes hashed so far.
    #[getter]
    fn bytes(&self) -> u64 {
        self.inner.bytes()
    }

    /// The lowercase hex SHA-256 of the bytes hashed so far (the file's once ``advance`` returned True).
    fn hexdigest(&self) -> String {
        self.inner.hex()
    }
}
