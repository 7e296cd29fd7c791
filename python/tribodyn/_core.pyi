"""Typed stub of ``tribodyn._core``, the pyo3 extension built from
``rust/python/src/lib.rs``; docstrings mirror its ``///`` comments.

The binding only converts types: array arguments must already be
C-contiguous float64 (the Python wrappers ensure it; anything else raises
``ValueError``, a wrong dtype ``TypeError``), every error is
built in one place (kernel errors ``ValueError``, a NaN or inf in a window
its subclass ``NonFiniteError``), the window kernels take one frozen
``WindowSpec`` checked once,
and the GIL is released around the kernels. ``threads=`` applies to one
call (1 .. ``max_threads()``); None means ``get_threads()``. Check for drift
with ``python -m mypy.stubtest tribodyn._core``.
"""

import os
from typing import Any, final

import numpy as np
from numpy.typing import NDArray
from typing_extensions import TypeAlias

__all__ = [
    "FORCE_LIMIT",
    "MAPPED_ALONE_GAP",
    "Extents",
    "FileDigest",
    "Moments",
    "NonFiniteError",
    "TextDialect",
    "TextScan",
    "WindowSpec",
    "all_finite",
    "get_threads",
    "max_threads",
    "linfit",
    "pearson",
    "row_quantiles",
    "lagged_sums",
    "mapped_windows_alone",
    "resample_stats",
    "select_ranks",
    "histogram_uniform",
    "find_peaks",
    "set_threads",
    "tdms_index",
    "pread_ranges",
    "extents_read_ranges",
    "text_parse",
    "text_scan",
    "sosfilt_inplace",
    "sosfilt_into",
    "windows_stats",
    "windows_stats_file",
    "xcorr",
    "xcorr_auto_method",
]

_F64: TypeAlias = NDArray[np.float64]

#: Largest |force| (N) of a window ``windows_stats`` analyses (docs/method.md 4):
#: beyond it, or when its sums overflow, the window is out of range.
FORCE_LIMIT: float
#: ``windows_stats_file`` reads each window alone (the gaps skipped) when the windows are at least this many
#: samples apart (step >= length + MAPPED_ALONE_GAP); else each block's whole span.
MAPPED_ALONE_GAP: int

# (slope, intercept, r, slope_stderr, intercept_stderr, resid_std, n, degenerate)
_FitTuple: TypeAlias = tuple[float, float, float, float, float, float, int, bool]
# (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo)
_StateTuple: TypeAlias = tuple[int, float, float, float, float, float, float, float, float]

class NonFiniteError(ValueError):
    """A sample that must be finite is NaN or inf: the message, and attributes channel, sample, window."""

    #: The kernel's channel ("fy", "fy_raw", "aux", ...), or with a spec's naming the recording's role.
    channel: str
    #: The window's first sample (``window``), or the sample itself; None when not known.
    sample: int | None
    #: Whether ``sample`` starts the window that holds the NaN or inf.
    window: bool

def xcorr(x: _F64, y: _F64, max_lag: int, method: str, *, threads: int | None = None) -> _F64:
    """Eq. (1) for lags -max_lag..=max_lag.

    ``method`` is "direct", "fft" or "auto". Returns C(j) in lag order.
    """

def xcorr_auto_method(n: int, max_lag: int) -> str:
    """The algorithm "auto" picks for (n, max_lag): "direct" or "fft"."""

def row_quantiles(x: _F64, qs: list[float], *, threads: int | None = None) -> tuple[_F64, _F64]:
    """Per row, ignoring NaN: the median and the quantiles qs (fractions), NumPy's values bit for bit."""

def lagged_sums(y: _F64, z: _F64, max_lag: int, scale: float, *, threads: int | None = None) -> tuple[_F64, _F64]:
    """(A, C), (windows, max_lag + 1): per row of y and z (C order), divided by scale and centred,
    A(L) = sum_t z_t z_(t-L) and C(L) = sum_t y_t z_(t-L), by FFT (the instrument's lag profile)."""

def mapped_windows_alone(step: int, length: int) -> bool:
    """Whether ``windows_stats_file`` reads each window alone (step >= length + MAPPED_ALONE_GAP)."""

def select_ranks(x: _F64, ks: list[int], *, centre: float | None = None, threads: int | None = None) -> _F64 | None:
    """The values of ranks ks (0-based, ascending) of a 1-D array (with centre: of |x - centre|), exactly;
    None when it holds NaN."""

def histogram_uniform(x: _F64, edges: _F64) -> NDArray[np.int64]:
    """NumPy's histogram of x over uniform edges (np.linspace), bit for bit."""

def find_peaks(x: _F64, *, prominence: float, wlen: int) -> NDArray[np.int64]:
    """scipy.signal.find_peaks(x, prominence=prominence, wlen=wlen)[0], index for index."""

def resample_stats(
    v: _F64,
    starts: NDArray[np.int64],
    ell: int,
    *,
    noise: tuple[_F64, NDArray[np.int64], _F64, float] | None = None,
    threads: int | None = None,
) -> _F64:
    """Median, mean, p05 and p95 of every moving-block resample, NumPy's values bit for bit: (4 x rows)."""

def pearson(x: _F64, y: _F64) -> float:
    """Pearson's r, C(0) of Eq. (1)."""

def sosfilt_inplace(sos: _F64, data: _F64, state: _F64, *, threads: int | None = None) -> None:
    """Filters `data` (channels, n) in place with `sos`, carrying `state`
    (channels, n_sections, 2) in place."""

def sosfilt_into(sos: _F64, x: _F64, out: _F64, state: _F64, *, threads: int | None = None) -> bool:
    """Filters `x` (channels, n) into `out` (same shape) with `sos`, carrying
    `state` (channels, n_sections, 2) in place. Returns whether every sample
    of `x` was finite (a NaN or inf leaves the state non-finite; only then
    is `x` scanned), so the caller's input check costs no extra pass."""

def all_finite(a: _F64, *, threads: int | None = None) -> bool:
    """Whether every value of a C-contiguous float64 array is finite (no NaN or
    inf), without the temporary mask of `np.isfinite(a).all()`."""

def linfit(x: _F64, y: _F64, *, threads: int | None = None) -> _FitTuple:
    """One-shot least squares of y on x.

    Returns (slope, intercept, r, slope_stderr, intercept_stderr, resid_std,
    n, degenerate).
    """

@final  # a pyo3 class: not subclassable at runtime
class WindowSpec:
    """The settings every window call of one analysis shares, validated and
    converted once: window length, deadband, fz bins, the columns asked
    for, the options beyond the paper, the high-pass of raw forces, the
    thread count and how a NaN or inf is named. Frozen; `replace` makes a
    variant (another length, auxiliary role or thread count)."""

    def __new__(
        cls,
        length: int,
        deadband: tuple[str, float],
        n_bins: int,
        columns: list[str],
        *,
        options: dict[str, Any] | None = None,
        highpass: tuple[_F64, _F64] | None = None,
        threads: int | None = None,
        naming: tuple[str, float] | None = None,
    ) -> WindowSpec:
        """`deadband` is (kind, value): "force" (N) or "sigma" (a multiple of
        the window's std of fz). `options`: a dict of lag, lags, lines,
        segments, delay, classical (see `windows_stats`). `highpass`: (sos, zi) of the
        raw forces' filter (`windows_stats_file` only). `naming`: (the
        auxiliary channel's role, fs): a NaN or inf is then named by role
        and time. Every argument is checked here: a bad one is a
        `ValueError` (an unknown option a `TypeError`)."""
    def replace(self, *, length: int | None = None, aux: str | None = None, threads: int | None = None) -> WindowSpec:
        """The same spec with another window `length`, auxiliary role `aux`
        (how a NaN or inf in it is named) or thread count (a new object)."""
    @property
    def length(self) -> int:
        """Samples per window."""
    @property
    def deadband(self) -> tuple[str, float]:
        """(kind, value): ("force", N) or ("sigma", k)."""
    @property
    def n_bins(self) -> int:
        """Equal-width fz bins per window."""
    @property
    def columns(self) -> list[str]:
        """The columns asked for, in order."""
    @property
    def threads(self) -> int:
        """Threads of a call."""
    @property
    def raw(self) -> bool:
        """Whether the spec carries a high-pass for raw forces."""

def windows_stats(
    spec: WindowSpec,
    fx: _F64 | None,
    fy: _F64,
    fz: _F64,
    aux: _F64 | None,
    starts: NDArray[np.int64],
    *,
    raw: tuple[_F64, _F64] | None = None,
    offset: int = 0,
) -> dict[str, NDArray[np.float64] | NDArray[np.int64]]:
    """Per-window statistics (docs/method.md 3-6) of the windows of
    `spec.length` samples starting at `starts`: a dict of the spec's
    columns, in that order, one row per window. `raw` = (fy, fz before the
    high-pass) defines `mu_classic`. A non-finite sample in a window raises
    `NonFiniteError`, its sample counted from `offset` (the caller's index
    of sample 0 of the arrays). `spec.threads == 1` keeps the work on the
    calling thread.

    Column names: slope, intercept, r, slope_stderr, intercept_stderr,
    resid_std, sse, mean_z, mean_y, szz, syy, syz, c_xy, c_xz, c_yz,
    deadband, mu_a, mu_b, fz_min, fz_max, aux_mean, mu_classic (float64,
    shape (windows,)), n, n_a, n_b, out_of_range (int64), bin_count (int64)
    and bin_cof (float64) of shape (windows, n_bins); ``tribodyn.columns``
    declares which a table uses. ``out_of_range`` is 1 for a window with a
    force beyond ``FORCE_LIMIT`` in magnitude (fy, fz, fx or the raw
    forces) or whose sums overflow: every statistic of it NaN, its counts 0
    (docs/method.md 4).

    Beyond the paper (docs/method.md 3a-3e), from the spec's options:
    ``ext`` (float64, (windows, 5, 16)), the block sums of the estimators
    with the instrument fz lagged by ``lag`` samples
    (``tribodyn.kernels.estimators.PRODUCTS``); ``spec`` (float64, (windows,
    len(lines), 4)), the cross-spectra at ``lines`` (cycles per sample)
    averaged over ``segments``; ``lag_sums`` (float64, (windows,
    len(lags), 2)), [S_wz, S_wy] over the window with the instrument fz
    lagged by each of ``lags`` (1 to 8 lags of at least 1 sample; w built
    as for ``ext``; NaN for a lag with n <= 2 lag); ``delay`` advances fz by that many samples
    in every window first (a fractional-delay filter; the windows lose 16
    samples at each end). ``classical`` = (min_fn, tare_fy, tare_fz) gives
    the columns ``mu_classical``, ``mu_classical_median``, ``fz_mean``,
    ``fz_std`` of the raw forces (docs/method.md 6a).

    With the spec's ``naming`` a NaN or inf is named in the recording's
    terms: "fy contains NaN or inf in the window starting at sample 5000
    (t = 5 s)"; its ``channel`` is then the role.
    """

def set_threads(n: int) -> None:
    """Sets the thread count of calls that name none (0 = all cores; at most
    `max_threads()`)."""

def get_threads() -> int:
    """The thread count of calls that name none."""

def max_threads() -> int:
    """The largest thread count a call may ask for (4 x the cores)."""

@final  # a pyo3 class: not subclassable at runtime
class Moments:
    """Mergeable centred moments of (x, y) (docs/method.md 3)."""

    def __new__(cls) -> Moments: ...
    def update(self, x: _F64, y: _F64, *, threads: int | None = None) -> None:
        """Adds the samples of one chunk."""

    def merge(self, other: Moments) -> Moments:
        """The moments of the union of both sample sets (a new object)."""

    def fit(self) -> _FitTuple:
        """(slope, intercept, r, slope_stderr, intercept_stderr, resid_std, n, degenerate)."""

    def state(self) -> _StateTuple:
        """(n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo)."""

    @staticmethod
    def from_state(state: _StateTuple | tuple[int, float, float, float, float, float, float]) -> Moments:
        """Rebuilds moments from `state()` (for pickling and transport): the
        tuple (n, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo),
        or its first seven (the low parts then 0.0)."""

def windows_stats_file(
    spec: WindowSpec,
    fd: int,
    offsets: tuple[int | Extents | None, int | Extents, int | Extents, int | Extents | None],
    n: int,
    windows: tuple[int, int, int],
    *,
    block: int = 512,
    origin: int = 0,
) -> dict[str, NDArray[np.float64] | NDArray[np.int64]]:
    """Per-window statistics of windows k0..k1 (`windows` = (k0, k1, step):
    window k = samples [k * step, k * step + spec.length)) of channels
    stored in the open file `fd` (a file descriptor, duplicated for the
    call and left open) as contiguous little-endian f64 runs starting at the
    byte offsets `(fx, fy, fz, aux)` (fx, aux may be None), `n` samples
    each, or as `Extents` (any numeric type, segments, interleaved rows,
    scaling). The samples are read with `pread`, `block` windows per task,
    on `spec.threads` threads; the spec's columns, with the same results as
    `windows_stats` on those samples. A file that shrinks meanwhile is a
    `ValueError` (a short read), never a crash.

    With the spec's `highpass` (sos and zi, its steady state for a unit
    input, one row per section) the force channels are raw: they are
    high-passed from sample `origin` on (state carried, each channel started
    at `zi * x[origin]`) and the classical COF of the raw forces is added
    (`mu_classic`); the windows must not overlap (step >= length)."""

@final
class Extents:
    """Where a channel's samples lie in a file: runs of one numeric type and
    byte order (TDMS segments, interleaved rows, DAQmx raw integers, HDF5
    chunks), with scaling. Read with `pread` (any number of threads)."""

    @staticmethod
    def contiguous(dtype: str, big_endian: bool, parts: list[tuple[int, int]]) -> Extents:
        """Extents of `dtype` (NumPy's name: "f8", "i2", ...) stored
        contiguously: `parts` is a list of (sample count, byte offset)."""
    def scaled(self, ops: list[tuple[str, list[float]]]) -> Extents:
        """The same samples scaled by `ops` after these' own, in order: each
        ("linear", [slope, intercept]) or ("poly", [c0, c1, ...])."""
    def read(self, fd: int, start: int, stop: int) -> NDArray[np.float64]:
        """Samples [start, stop) as float64 (scaled), read from the open file `fd`."""
    @property
    def n(self) -> int:
        """Samples of the channel."""
    @property
    def dtype(self) -> str:
        """NumPy's name of the stored type ("f8", "i2", ...)."""
    @property
    def big_endian(self) -> bool:
        """Whether the samples are stored big-endian."""
    @property
    def runs(self) -> int:
        """Runs of samples (one per segment or chunk; consecutive ones, and
        equal ones at a fixed distance, merged)."""
    @property
    def is_scaled(self) -> bool:
        """Whether scaling is applied."""
    @property
    def end(self) -> int:
        """One past the last byte read."""

def pread_ranges(
    fd: int,
    out: NDArray[np.uint8],
    offsets: NDArray[np.int64],
    lengths: NDArray[np.int64],
    *,
    threads: int | None = None,
) -> None:
    """Fills `out` (a C-contiguous uint8 array) with byte ranges of the open file `fd`: range k is
    lengths[k] bytes from byte offsets[k], after range k - 1 (pread without the GIL, threads for large
    reads); a range past the end of the file is a ValueError, a failed read an OSError."""

def extents_read_ranges(extents: Extents, fd: int, ranges: list[tuple[int, int]]) -> _F64:
    """Samples [a, b) of every (a, b) in ranges of the channel `extents` describes, concatenated as
    float64 (what Extents.read gives for each range), in one call from the open file `fd`, only each
    range's bytes read; a range it cannot read is a ValueError starting "a:b: "."""

def tdms_index(fd: int, index_fd: int | None = None) -> dict[str, Any]:
    """The segment index of the TDMS file open as `fd` (see `tribodyn.io.tdms`),
    its metadata read from the `.tdms_index` open as `index_fd` if given
    (and it matches the data file): a dict with "segments", "warnings" (npTDMS's log, as it would say it),
    "fallback" (why the file is not read natively, or None) and "objects":
    a list of (path, properties [(name, type code, value bytes, big-endian)],
    data type code or None, values, {scale key: Extents} (-1 for the
    channel's own samples, else a DAQmx scale id), why not native or None).
    A damaged file is a ValueError naming the segment."""

@final
class TextDialect:
    """How a text file's fields are separated and which lines are skipped
    (the rules of `text_scan` and `text_parse`), checked when it is made."""

    def __new__(
        cls, delimiter: str | None, decimal: str, comment: str | None = None, skip_blank: bool = True
    ) -> TextDialect:
        """`delimiter`: one ASCII character, or None for runs of whitespace;
        `decimal`: "." or ","; `comment`: ASCII text that starts a skipped
        line, or None; `skip_blank`: blank lines are skipped (else they end
        a run). A bad argument is a `ValueError`."""

@final
class FileDigest:
    """The SHA-256 of a file, hashed in steps (`advance`) that run without the GIL."""

    def __new__(cls, path: str | os.PathLike[str]) -> FileDigest: ...
    def advance(self, max_bytes: int) -> bool:
        """Hashes up to ``max_bytes`` more bytes of the file without the GIL; True once the file's end was
        reached (an OSError when a read fails)."""

    @property
    def bytes(self) -> int:
        """Bytes hashed so far."""

    def hexdigest(self) -> str:
        """The lowercase hex SHA-256 of the bytes hashed so far (the file's once ``advance`` returned True)."""

@final
class TextScan:
    """What makes a line a data row of `text_scan`, and what the scan records."""

    def __new__(
        cls,
        dialect: TextDialect,
        *,
        nf: int | None,
        probe: int,
        time: int | None = None,
        gap: float = ...,
        t_prev: float = ...,
        keep_times: int = 0,
    ) -> TextScan:
        """`dialect`: the file's `TextDialect`; `nf`: the fields a row has (more
        are allowed when blank; None: any); `probe`: a field that must be a
        number or empty; `time`: the time column, whose restarts and gaps (a
        step above `gap`; NaN: restarts only) are reported, `t_prev` the
        time of the row before the run (NaN: none); `keep_times`: time
        values kept from the run's first row."""

def text_scan(fd: int, start: int, scan: TextScan, *, threads: int | None = None) -> dict[str, Any]:
    """Follows the run of data rows from byte `start` of the text file open as
    `fd` by the rules of `scan` (see `tribodyn.io._text.native_scan`): a dict with "rows", "lines",
    "end", "times" (float64), "breaks" [(row, line, offset, prev, now)],
    "t_prev", "checkpoints" [(row, offset, line)] (about one a MiB), "marks" (more
    such entries, about one per 64 KiB, see `Checkpoints`) and "last" ((line, offset) or None);
    lines are counted from the run's first (0)."""

def text_parse(
    fd: int,
    pieces: list[tuple[int, int, int, int]],
    usecols: list[int],
    dialect: TextDialect,
    *,
    names: list[str] | None = None,
    threads: int | None = None,
) -> list[NDArray[np.float64]]:
    """Parses the rows of `pieces` [(offset, line, skip, rows)] of the text
    file open as `fd` by the rules of `dialect` into one float64 array per
    entry of `usecols`. A row that cannot be read raises ValueError in the
    reader's words ("line 7: 'x' in channel 'fy' is not a number (corrupt
    file?)"), each column asked for named by its entry of `names` (by its
    index without one)."""
