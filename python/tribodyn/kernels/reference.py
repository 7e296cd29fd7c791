"""Pure-NumPy reference of every kernel: the maths in the fewest lines.

Same names and signatures as the fast path (``xcorr``, ``pearson``,
``HighPass``, ``highpass``, ``linfit``, ``LinFitAccumulator``). Written for
clarity, not speed: it is the baseline of the parity tests and the
benchmarks. Input checks are shared with the fast path, so both refuse the
same inputs with the same messages. The recursion of the high-pass filter
cannot be expressed in NumPy, so it uses ``scipy.signal.sosfilt``.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Dict, Optional, Tuple

import numpy as np
from scipy import signal as _signal

from ..columns import TABLE
from ._validate import as_channels, check_fs
from .correlation import XcorrResult, _max_lag, _prepare
from .filters import Init, _check_sos, butter_highpass
from .regression import LinFit, _pair, _result

__all__ = ["xcorr", "pearson", "HighPass", "highpass", "linfit", "LinFitAccumulator", "mean"]


def mean(x: np.ndarray) -> float:
    """Two-pass mean: exact for a constant input (docs/method.md 1, 3)."""
    m0 = x.sum() / x.size
    return float(m0 + (x - m0).sum() / x.size)


# -- Eq. (1) ------------------------------------------------------------------


def xcorr(
    x: Any,
    y: Any,
    *,
    max_lag: Optional[int] = None,
    fs: Optional[float] = None,
    method: str = "direct",
    check_finite: bool = True,
) -> XcorrResult:
    """Eq. (1) by its definition: one overlap dot product per lag."""
    xa, ya = _prepare(x, y, check_finite)
    n = xa.size
    lag = _max_lag(max_lag, n)
    xc, yc = xa - mean(xa), ya - mean(ya)
    lags = np.arange(-lag, lag + 1, dtype=np.int64)
    c = np.empty(lags.size)
    for k, j in enumerate(lags):
        # Overlap of x_i and y_{i+j}: i in [max(0, -j), min(n, n - j)).
        a = xc[max(0, -j) : min(n, n - j)]
        b = yc[max(0, j) : min(n, n + j)]
        den = np.sqrt(np.dot(a, a) * np.dot(b, b))
        c[k] = np.clip(np.dot(a, b) / den, -1.0, 1.0) if den > 0 else np.nan
    tau = None if fs is None else lags / check_fs(fs)
    return XcorrResult(lags=lags, c=c, tau=tau, method="direct")


def pearson(x: Any, y: Any, *, check_finite: bool = True) -> float:
    """C(0): Pearson's r, NaN for a constant input."""
    xa, ya = _prepare(x, y, check_finite)
    xc, yc = xa - mean(xa), ya - mean(ya)
    den = np.sqrt(np.dot(xc, xc) * np.dot(yc, yc))
    return float(np.clip(np.dot(xc, yc) / den, -1.0, 1.0)) if den > 0 else float("nan")


# -- High-pass (docs/method.md 2) ----------------------------------------------------


class HighPass:
    """Streaming SOS filter on top of ``scipy.signal.sosfilt`` with carried ``zi``."""

    def __init__(
        self,
        fs: float,
        *,
        cutoff: float = 0.1,
        order: int = 1,
        sos: Optional[Any] = None,
        channels: int = 1,
        init: Init = "steady",
    ) -> None:
        self.sos = butter_highpass(fs, cutoff=cutoff, order=order) if sos is None else _check_sos(sos)
        self.channels = channels
        self.init = init
        self.reset()

    def reset(self) -> None:
        self.state = np.zeros((self.channels, self.sos.shape[0], 2))
        self._started = self.init == "zero"

    def process(self, chunk: Any, *, check_finite: bool = True) -> np.ndarray:
        x = np.atleast_2d(as_channels(chunk, "chunk", check_finite=check_finite))
        if x.shape[0] != self.channels:  # same refusals as the fast path
            got = "1-D" if np.ndim(chunk) == 1 else f"{x.shape[0]} channels"
            raise ValueError(
                f"chunk must have shape ({self.channels}, m) for a {self.channels}-channel filter (channels), got {got}"
            )
        if x.shape[1] == 0:
            return np.asarray(chunk, dtype=float).copy()
        if not self._started:
            self.state = _signal.sosfilt_zi(self.sos)[None, :, :] * x[:, 0, None, None]
            self._started = True
        # scipy's zi is (n_sections, channels, 2) for axis=-1 on (channels, m).
        y, zf = _signal.sosfilt(self.sos, x, axis=-1, zi=np.moveaxis(self.state, 0, 1))
        self.state = np.moveaxis(zf, 1, 0)
        out: np.ndarray = y[0] if np.ndim(chunk) == 1 else y
        return out


def highpass(
    x: Any,
    fs: float,
    *,
    cutoff: float = 0.1,
    order: int = 1,
    axis: int = -1,
    init: Init = "steady",
    sos: Optional[Any] = None,
    check_finite: bool = True,
) -> np.ndarray:
    """One-shot ``scipy.signal.sosfilt`` along ``axis``, other axes as channels."""
    moved = np.moveaxis(np.asarray(x, dtype=float), axis, -1)
    # Not reshape(-1, m): with m = 0 the -1 would be ambiguous.
    flat = moved.reshape(int(np.prod(moved.shape[:-1])), moved.shape[-1])
    hp = HighPass(fs, cutoff=cutoff, order=order, sos=sos, channels=flat.shape[0], init=init)
    return np.moveaxis(hp.process(flat, check_finite=check_finite).reshape(moved.shape), -1, axis)


# -- Eqs. (6)-(8) ---------------------------------------------------------------


def _two_sum(a: float, b: float) -> Tuple[Any, ...]:
    """a + b = s + e exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _mean_pair(x: np.ndarray) -> Tuple[Any, ...]:
    """The two-pass mean as a double-double (hi, lo)."""
    m0 = float(x.sum() / x.size)
    return _two_sum(m0, float((x - m0).sum() / x.size))


def _fit(m: Tuple[Any, ...]) -> Tuple[Any, ...]:
    """The LinFit fields from the moments (n, mean_x, mean_y, S_xx, S_yy, S_xy, SSE, mean_x_lo, mean_y_lo)."""
    n, mx, my, sxx, syy, sxy, sse, mx_lo, my_lo = m
    if n < 3 or not sxx > 0:
        nan = float("nan")
        return (nan, nan, nan, nan, nan, nan, n, True)
    slope = sxy / sxx
    den = np.sqrt(sxx * syy)
    r = float(np.clip(sxy / den, -1, 1)) if den > 0 else float("nan")
    var = sse / (n - 2)
    se = np.sqrt(var / sxx)
    # mean_y - slope * mean_x exactly, then rounded once: the intercept is a
    # small difference of large numbers when the means are far from zero.
    intercept = float(Fraction(my) + Fraction(my_lo) - Fraction(slope) * (Fraction(mx) + Fraction(mx_lo)))
    return (slope, intercept, r, se, se * np.sqrt(sxx / n + mx * mx), np.sqrt(var), n, False)


def _moments(x: np.ndarray, y: np.ndarray) -> Tuple[Any, ...]:
    """(n, mean_x, mean_y, S_xx, S_yy, S_xy, SSE, mean_x_lo, mean_y_lo) by centred passes."""
    n = x.size
    if n == 0:
        return (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    (mx, mx_lo), (my, my_lo) = _mean_pair(x), _mean_pair(y)
    dx, dy = x - mx, y - my
    sxx, syy, sxy = dx @ dx, dy @ dy, dx @ dy
    if sxx > 0:
        e = dy - (sxy / sxx) * dx
        sse = max(e @ e - e.sum() ** 2 / n, 0.0)
    else:
        sse = syy
    return (n, mx, my, sxx, syy, sxy, sse, mx_lo, my_lo)


def linfit(x: Any, y: Any, *, check_finite: bool = True) -> LinFit:
    """OLS of y on x from centred sums; SSE from the residuals themselves."""
    xa, ya = _pair(x, y, check_finite, 1)
    return _result(_fit(_moments(xa, ya)))


class LinFitAccumulator:
    """Chan et al. pairwise merge of centred moments, in plain Python.

    The means are kept as double-doubles (hi, lo), so merging never rounds
    them (docs/method.md 3: any split gives the one-shot result).
    """

    def __init__(self) -> None:
        self.m: Tuple[Any, ...] = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @staticmethod
    def _merge(a: Tuple[Any, ...], b: Tuple[Any, ...]) -> Tuple[Any, ...]:
        na, mxa, mya, sxxa, syya, sxya, ssea, mxa_lo, mya_lo = a
        nb, mxb, myb, sxxb, syyb, sxyb, sseb, mxb_lo, myb_lo = b
        if nb == 0:
            return a
        if na == 0:
            return b
        n = na + nb
        w = na * nb / n
        hx, ex = _two_sum(mxb, -mxa)
        hy, ey = _two_sum(myb, -mya)
        dx, dy = hx + (ex + (mxb_lo - mxa_lo)), hy + (ey + (myb_lo - mya_lo))
        sxx = sxxa + sxxb + dx * dx * w
        ba = sxya / sxxa if sxxa > 0 else 0.0
        bb = sxyb / sxxb if sxxb > 0 else 0.0
        # SSE of the union = SSE_a + SSE_b + the non-negative "between" term.
        if sxx > 0:
            between = (
                sxxa * sxxb * (ba - bb) ** 2 + sxxa * w * (ba * dx - dy) ** 2 + sxxb * w * (bb * dx - dy) ** 2
            ) / sxx
        else:
            between = dy * dy * w
        mx, ex = _two_sum(mxa, dx * (nb / n))
        mx, mx_lo = _two_sum(mx, ex + mxa_lo)
        my, ey = _two_sum(mya, dy * (nb / n))
        my, my_lo = _two_sum(my, ey + mya_lo)
        return (
            n,
            mx,
            my,
            sxx,
            syya + syyb + dy * dy * w,
            sxya + sxyb + dx * dy * w,
            ssea + sseb + between,
            mx_lo,
            my_lo,
        )

    def update(self, x: Any, y: Any, *, check_finite: bool = True) -> "LinFitAccumulator":
        xa, ya = _pair(x, y, check_finite, 0)
        self.m = self._merge(self.m, _moments(xa, ya))
        return self

    def merge(self, other: "LinFitAccumulator") -> "LinFitAccumulator":
        out = LinFitAccumulator()
        out.m = self._merge(self.m, other.m)
        return out

    def result(self) -> LinFit:
        return _result(_fit(self.m))


# -- The long-recording pipeline, tiled windows (docs/method.md 3-6) -------------------

__all__ += ["analyze_tiled", "TILED_COLUMNS"]

#: The columns of the per-window table (``tribodyn.columns.TABLE``) that
#: :func:`analyze_tiled` computes, in the table's order.
TILED_COLUMNS = tuple(
    c.name
    for c in TABLE
    if c.name
    in {
        "time", "mu_r", "f_y0", "r", "mu_r_stderr", "mu_a", "mu_b", "force_dependence", "c_xy", "c_xz", "c_yz",
        "i", "J", "n", "deadband", "mu_classic",
    }
)  # fmt: skip


def _row_mean(a: np.ndarray) -> np.ndarray:
    """Two-pass mean of every row (exact for a constant row)."""
    m0 = a.sum(axis=1) / a.shape[1]
    out: np.ndarray = m0 + (a - m0[:, None]).sum(axis=1) / a.shape[1]
    return out


def _rows_pearson(sab: np.ndarray, saa: np.ndarray, sbb: np.ndarray) -> np.ndarray:
    den = np.sqrt(saa * sbb)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.clip(sab / den, -1.0, 1.0), np.nan)


def _tile_stats(
    fx: Optional[np.ndarray],
    fy: np.ndarray,
    fz: np.ndarray,
    aux: Optional[np.ndarray],
    raw: Optional[Tuple[Any, ...]],
    *,
    dead: Tuple[Any, ...],
    nb: int,
) -> Dict[str, Any]:
    """Statistics of the rows of (windows, W) arrays, orientation +1."""
    n_w, w = fz.shape
    mz, my = _row_mean(fz), _row_mean(fy)
    dz, dy = fz - mz[:, None], fy - my[:, None]
    szz, syy, syz = (dz * dz).sum(axis=1), (dy * dy).sum(axis=1), (dy * dz).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        # Eqs. 6-8; the residual sum of squares from the residuals themselves.
        b = np.where(szz > 0, syz / szz, 0.0)
        e = dy - b[:, None] * dz
        sse = np.where(szz > 0, np.maximum((e * e).sum(axis=1) - e.sum(axis=1) ** 2 / w, 0.0), syy)
        ok = (w >= 3) & (szz > 0)
        slope = np.where(ok, syz / szz, np.nan)
        se = np.where(ok, np.sqrt(sse / (w - 2) / szz), np.nan)
    out = {
        "slope": slope,
        "intercept": my - slope * mz,
        "slope_stderr": se,
        "c_yz": _rows_pearson(syz, szz, syy),
        "n": np.full(n_w, w, dtype=np.int64),
        "mean_z": mz,
        "mean_y": my,
        "syz": syz,
    }
    out["r"] = np.where(ok, out["c_yz"], np.nan)
    if fx is not None and w >= 2:
        dx = fx - _row_mean(fx)[:, None]
        sxx = (dx * dx).sum(axis=1)
        out["c_xy"] = _rows_pearson((dx * dy).sum(axis=1), sxx, syy)
        out["c_xz"] = _rows_pearson((dx * dz).sum(axis=1), sxx, szz)
    else:
        out["c_xy"] = out["c_xz"] = np.full(n_w, np.nan)
    # Deadband and bins (docs/method.md 4): bin floor((fz - lo) * n_bins / span),
    # the top edge in the last bin.
    kind, value = dead
    d = np.full(n_w, value) if kind == "force" else value * np.sqrt(szz / (w - 1)) if w >= 2 else np.full(n_w, np.nan)
    lo, hi = fz.min(axis=1), fz.max(axis=1)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(span > 0, nb / span, 0.0)
        mu = fy / fz
    keep = (np.abs(fz) >= d[:, None]) & (fz != 0)
    k = np.minimum((fz - lo[:, None]) * scale[:, None], nb - 1).astype(np.int64)
    slot = (k + nb * np.arange(n_w)[:, None])[keep]
    counts = np.bincount(slot, minlength=n_w * nb).reshape(n_w, nb)
    sums = np.bincount(slot, weights=mu[keep], minlength=n_w * nb).reshape(n_w, nb)
    neg, pos = keep & (fz < 0), keep & (fz > 0)
    out["n_a"], out["n_b"] = neg.sum(axis=1), pos.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["bin_cof"] = np.where(counts > 0, sums / counts, np.nan)
        out["mu_a"] = np.where(neg, mu, 0.0).sum(axis=1) / out["n_a"]
        out["mu_b"] = np.where(pos, mu, 0.0).sum(axis=1) / out["n_b"]
    out.update(bin_count=counts, deadband=d, fz_min=lo, fz_max=hi)
    out["aux_mean"] = aux.mean(axis=1) if aux is not None else np.full(n_w, np.nan)
    if raw is not None:
        ay, az = np.abs(raw[0]), np.abs(raw[1])
        nz = az > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            out["mu_classic"] = np.where(nz, ay / np.where(nz, az, 1.0), 0.0).sum(axis=1) / nz.sum(axis=1)
    else:
        out["mu_classic"] = np.full(n_w, np.nan)
    return out


def analyze_tiled(
    channels: Any,
    *,
    fs: float,
    window: float = 2.0,
    deadband: Any = 0.35,
    n_bins: int = 16,
    highpass: Optional[float] = None,
    area_mm2: Optional[float] = None,
    orientation: Any = "auto",
    block: int = 256,
) -> Dict[str, Any]:
    """``tribodyn.analyze`` with hop == window, vectorised over windows.

    Each block of ``block`` consecutive windows is a (windows, W) view of
    the channels; every per-window quantity is a centred sum along rows, the
    bins one ``np.bincount`` over (window, bin) slots. With ``highpass`` the
    forces are filtered first by ``scipy.signal.sosfilt`` (first-order
    Butterworth, "steady" start, state carried from block to block).

    Parameters
    ----------
    channels : mapping
        Role -> 1-D array: ``fy``, ``fz``, optionally ``fx`` and ``i``
        (current, A). Memory-mapped arrays are read a block at a time.
    fs, window, deadband, n_bins, highpass, area_mm2, orientation
        As for :func:`tribodyn.analyze` (``deadband`` a force in N or
        ``"0.7sigma"``).
    block : int
        Windows per vectorised step (memory is O(block * W)).

    Returns
    -------
    dict of str -> ndarray
        The columns of ``analyze``'s table it covers: ``time``, ``mu_r``,
        ``f_y0``, ``r``, ``mu_r_stderr``, ``mu_a``, ``mu_b``,
        ``force_dependence``, ``c_xy``, ``c_xz``, ``c_yz``, ``i``, ``J``,
        ``n``, ``deadband``, ``mu_classic``; and per window ``bin_count``
        (int64) and ``bin_cof`` (windows, n_bins), ``fz_min``, ``fz_max``;
        ``orientation`` (0-d int).
    """
    from .deadband import parse_deadband

    fs_v = check_fs(fs)
    w = int(round(float(window) * fs_v))
    db = parse_deadband(deadband)
    nb = int(n_bins)
    if w < 3 or nb < 1:
        raise ValueError("a window needs at least 3 samples and n_bins >= 1")
    roles = [r for r in ("fx", "fy", "fz") if r in channels]
    n = len(channels["fz"])
    n_win = n // w
    if n_win == 0:
        raise ValueError("the recording is shorter than one window")
    hp = HighPass(fs_v, cutoff=highpass, channels=len(roles)) if highpass is not None else None
    parts = []
    for k0 in range(0, n_win, block):
        k1 = min(n_win, k0 + block)
        a, b = k0 * w, k1 * w
        ch = {r: np.asarray(channels[r][a:b], dtype=float) for r in roles}
        raw = None
        if hp is not None:
            # The filter also runs over the samples between blocks: none here
            # (tiling), except the tail after the last window, never used.
            filtered = hp.process(np.stack([ch[r] for r in roles]))
            raw = (ch["fy"].reshape(-1, w), ch["fz"].reshape(-1, w))
            ch = {r: filtered[j] for j, r in enumerate(roles)}
        aux = np.asarray(channels["i"][a:b], dtype=float).reshape(-1, w) if "i" in channels else None
        rows = {r: v.reshape(-1, w) for r, v in ch.items()}
        parts.append(_tile_stats(rows.get("fx"), rows["fy"], rows["fz"], aux, raw, dead=(db.kind, db.value), nb=nb))
    st = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    if orientation == "auto":
        # docs/method.md 0: the sign of the whole-recording slope, from the
        # windows' moments merged (within + between windows).
        nw = st["n"].astype(float)
        mz, my = np.average(st["mean_z"], weights=nw), np.average(st["mean_y"], weights=nw)
        total = st["syz"].sum() + (nw * (st["mean_z"] - mz) * (st["mean_y"] - my)).sum()
        s = -1 if total < 0 else 1
    else:
        s = int(orientation)
    time = np.arange(n_win) * w / fs_v + 0.5 * w / fs_v
    mu_r = s * st["slope"]
    mu_a, mu_b = s * st["mu_a"], s * st["mu_b"]
    with np.errstate(invalid="ignore", divide="ignore"):
        force_dependence = (mu_b - mu_a) / mu_r
    i = st["aux_mean"]
    columns = {
        "time": time,
        "mu_r": mu_r,
        "f_y0": st["intercept"],
        "r": st["r"],
        "mu_r_stderr": st["slope_stderr"],
        "mu_a": mu_a,
        "mu_b": mu_b,
        "force_dependence": force_dependence,
        "c_xy": st["c_xy"],
        "c_xz": st["c_xz"],
        "c_yz": st["c_yz"],
        "i": i,
        "J": i / area_mm2 if area_mm2 is not None else np.full(n_win, np.nan),
        "n": st["n"],
        "deadband": st["deadband"],
        "mu_classic": st["mu_classic"],
    }
    out = {c: columns[c] for c in TILED_COLUMNS}  # the table's names and order
    out.update(bin_count=st["bin_count"], bin_cof=s * st["bin_cof"], fz_min=st["fz_min"], fz_max=st["fz_max"])
    out["orientation"] = np.array(s)
    return out


# -- Per-window statistics, any window starts (docs/method.md 3-5) ----------------------

__all__ += ["window_stats"]


def _pearson_from(sab: float, saa: float, sbb: float) -> float:
    den = np.sqrt(saa * sbb)
    return float(np.clip(sab / den, -1.0, 1.0)) if den > 0 else float("nan")


#: The keys of :func:`window_stats`'s dict, in its order.
_WS_FIT_KEYS = ("slope", "intercept", "r", "slope_stderr", "intercept_stderr", "resid_std")
_WS_KEYS: Tuple[str, ...] = (
    _WS_FIT_KEYS
    + ("sse", "mean_z", "mean_y", "szz", "syy", "syz", "c_xy", "c_xz", "c_yz")
    + ("deadband", "mu_a", "mu_b", "n_a", "n_b", "fz_min", "fz_max", "bin_count", "bin_cof", "aux_mean")
    + ("mu_classic", "n", "out_of_range")
)


def window_stats(
    fx: Optional[np.ndarray],
    fy: np.ndarray,
    fz: np.ndarray,
    aux: Optional[np.ndarray],
    starts: Any,
    *,
    length: int,
    deadband: Any,
    n_bins: int,
    raw: Optional[Tuple[Any, ...]] = None,
) -> Dict[str, Any]:
    """``tribodyn.kernels.window_stats.compute`` one window at a time (docs/method.md 3-5).

    Window k is samples ``[starts[k], starts[k] + length)``; windows may be in
    any order, overlap or tile. Orientation +1. Same keys as the kernel's dict:
    the regression of fy on fz (Eqs. 6-8) from two-pass centred sums, NaN when
    degenerate (fewer than 3 samples or S_zz = 0); Pearson C_xy, C_xz, C_yz
    (NaN for a constant channel; C_xy, C_xz NaN without fx); the deadband d
    (a force, or k * std(fz) with n - 1); the fz bins
    floor((fz - min) * (n_bins / (max - min))), the maximum in the last bin,
    every sample in bin 0 when max = min; bin counts and per-bin mean of
    fy/fz over the samples with |fz| >= d and fz != 0; mu_a (those with
    fz < 0), mu_b (fz > 0); the mean of ``aux``; and with ``raw`` = (fy_raw,
    fz_raw) the classical COF mean(|fy_raw| / |fz_raw|) over fz_raw != 0.
    A window with a force beyond ``_core.FORCE_LIMIT`` in magnitude (fy, fz,
    fx, raw) or whose second-moment sums overflow is out of range: every
    statistic NaN, counts 0, ``out_of_range`` 1 (docs/method.md 4).
    """
    from .deadband import parse_deadband

    db = parse_deadband(deadband)
    nb = int(n_bins)
    n = int(length)
    cols: Dict[str, Any] = {key: [] for key in _WS_KEYS}
    forces = [a for a in (fx, fy, fz, *(raw or ())) if a is not None]
    for s in np.asarray(starts, dtype=np.int64):
        w = slice(int(s), int(s) + n)
        row = _ws_window(fx, fy, fz, aux, raw, w=w, n=n, db=db, nb=nb, forces=forces)
        for key in _WS_KEYS:
            cols[key].append(row[key])
    return _ws_arrays(cols, m=len(np.asarray(starts)), nb=nb)


def _ws_window(
    fx: Optional[np.ndarray],
    fy: np.ndarray,
    fz: np.ndarray,
    aux: Optional[np.ndarray],
    raw: Optional[Tuple[Any, ...]],
    *,
    w: slice,
    n: int,
    db: Any,
    nb: int,
    forces: Any,
) -> Dict[str, Any]:
    """:func:`window_stats`'s statistics of the one window ``w``."""
    from .._core import FORCE_LIMIT

    y, z = np.asarray(fy[w], dtype=float), np.asarray(fz[w], dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        # Eqs. 6-8 from centred sums.
        mz, my = mean(z), mean(y)
        dz, dy = z - mz, y - my
        szz, syy, syz = float(dz @ dz), float(dy @ dy), float(dy @ dz)
        sxx = float(np.sum(np.square(np.asarray(fx[w], dtype=float) - mean(fx[w])))) if fx is not None else 0.0
    peak = max((float(np.abs(np.asarray(a[w], dtype=float)).max()) for a in forces), default=0.0) if n else 0.0
    aux_mean = mean(np.asarray(aux[w], dtype=float)) if aux is not None and n > 0 else float("nan")
    if peak > FORCE_LIMIT or not all(np.isfinite(v) for v in (szz, syy, syz, sxx)):
        return _ws_out_of_range(n, db=db, nb=nb, aux_mean=aux_mean)
    if szz > 0:
        e = dy - (syz / szz) * dz
        sse = max(float(e @ e - e.sum() ** 2 / n), 0.0)
    else:
        sse = syy
    row = _ws_fit(n, mz, my, szz, syy, syz=syz, sse=sse)
    row.update(sse=sse, mean_z=mz, mean_y=my, szz=szz, syy=syy, syz=syz)
    # Pearson at lag 0 (docs/method.md 5).
    row["c_yz"] = _pearson_from(syz, szz, syy)
    if fx is not None and n >= 2:
        x = np.asarray(fx[w], dtype=float)
        dx = x - mean(x)
        sxx = float(dx @ dx)
        row["c_xy"] = _pearson_from(float(dx @ dy), sxx, syy)
        row["c_xz"] = _pearson_from(float(dx @ dz), sxx, szz)
    else:
        row["c_xy"] = row["c_xz"] = float("nan")
    # Deadband and bins (docs/method.md 4).
    if db.kind == "force":
        d = db.value
    else:
        d = db.value * np.sqrt(szz / (n - 1)) if n >= 2 else float("nan")
    row.update(_ws_bins(y, z, d=d, n=n, nb=nb))
    row["aux_mean"] = aux_mean
    row["mu_classic"] = _ws_classic(raw, w) if raw is not None else float("nan")
    row["n"] = n
    row["out_of_range"] = 0
    return row


def _ws_out_of_range(n: int, *, db: Any, nb: int, aux_mean: float) -> Dict[str, Any]:
    """:func:`window_stats`'s row of a window out of range: every statistic NaN, counts 0."""
    nan = float("nan")
    row: Dict[str, Any] = dict.fromkeys(_WS_KEYS, nan)
    row["bin_count"], row["bin_cof"] = np.zeros(nb, dtype=np.int64), np.full(nb, nan)
    row["n_a"] = row["n_b"] = 0
    row["deadband"] = db.value if db.kind == "force" else nan
    row["aux_mean"] = aux_mean
    row["n"], row["out_of_range"] = n, 1
    return row


def _ws_fit(n: int, mz: float, my: float, szz: float, syy: float, *, syz: float, sse: float) -> Dict[str, Any]:
    """The regression of fy on fz (Eqs. 6-8) from the window's centred sums, NaN when degenerate."""
    if not (n >= 3 and szz > 0):
        return dict.fromkeys(_WS_FIT_KEYS, float("nan"))
    slope = syz / szz
    resid_var = sse / (n - 2)
    slope_se = np.sqrt(resid_var / szz)
    return {
        "slope": slope,
        "intercept": my - slope * mz,
        "r": _pearson_from(syz, szz, syy),
        "slope_stderr": slope_se,
        "intercept_stderr": slope_se * np.sqrt(szz / n + mz * mz),
        "resid_std": np.sqrt(resid_var),
    }


def _ws_bins(y: np.ndarray, z: np.ndarray, *, d: float, n: int, nb: int) -> Dict[str, Any]:
    """The deadband, fz bins, mu_a and mu_b of one window (docs/method.md 4)."""
    nan = float("nan")
    keep = (np.abs(z) >= d) & (z != 0)  # a NaN d keeps nothing
    lo, hi = float(z.min()), float(z.max())
    span = hi - lo
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # n_bins / span first, as the kernel does: (z - lo) * nb / span
        # rounds differently and moves some samples on an edge to a neighbour.
        t = (z - lo) * (nb / span) if span > 0 else np.zeros(n)
        ratio = y / z
    # A tiny span can make nb / span infinite: (lo - lo) * inf is NaN, bin 0.
    t = np.where(t >= 0, t, 0.0)
    k = np.minimum(np.floor(t), nb - 1).astype(np.int64)
    counts = np.zeros(nb, dtype=np.int64)
    cof = np.full(nb, nan)
    for j in range(nb):
        in_bin = keep & (k == j)
        counts[j] = in_bin.sum()
        if counts[j]:
            cof[j] = ratio[in_bin].mean()
    neg, pos = keep & (z < 0), keep & (z > 0)
    return {
        "deadband": d,
        "mu_a": ratio[neg].mean() if neg.any() else nan,
        "mu_b": ratio[pos].mean() if pos.any() else nan,
        "n_a": int(neg.sum()),
        "n_b": int(pos.sum()),
        "fz_min": lo,
        "fz_max": hi,
        "bin_count": counts,
        "bin_cof": cof,
    }


def _ws_classic(raw: Tuple[Any, ...], w: slice) -> float:
    """The classical COF mean(|fy_raw| / |fz_raw|) of one window over fz_raw != 0."""
    ay, az = np.abs(np.asarray(raw[0][w], dtype=float)), np.abs(np.asarray(raw[1][w], dtype=float))
    nz = az > 0
    return float((ay[nz] / az[nz]).mean()) if nz.any() else float("nan")


def _ws_arrays(cols: Dict[str, Any], *, m: int, nb: int) -> Dict[str, Any]:
    """:func:`window_stats`'s per-window lists as arrays (the bins as (m, n_bins))."""
    out = {}
    for key, values in cols.items():
        if key == "bin_count":
            out[key] = np.array(values, dtype=np.int64).reshape(m, nb)
        elif key == "bin_cof":
            out[key] = np.array(values, dtype=float).reshape(m, nb)
        elif key in ("n", "n_a", "n_b", "out_of_range"):
            out[key] = np.array(values, dtype=np.int64)
        else:
            out[key] = np.array(values, dtype=float)
    return out


def block_sums(fy: Any, fz: Any, lag: int, blocks: int = 5) -> np.ndarray:
    """NumPy reference of the kernel's column ``"ext"`` for one window (docs/method.md 3a-3d).

    Returns (blocks, 16): per block k = [k n // B, (k + 1) n // B), the sums
    of z, y, w, zz, zy, yy, wz, wy, ww, zzz, zzy, zzzz, wzz, wwz, wwy, wwzz
    with z, y the centred forces and w the instrument (fz lagged by ``lag``
    samples, fz led by ``lag`` for the first ``lag`` samples), centred; the
    instrument's sums are NaN unless n > 2 lag.
    """
    fy = np.asarray(fy, dtype=np.float64)
    fz = np.asarray(fz, dtype=np.float64)
    n = fz.size
    z = fz - fz.mean()
    y = fy - fy.mean()
    has_w = lag >= 1 and n > 2 * lag
    if has_w:
        w = np.concatenate([fz[lag : 2 * lag], fz[: n - lag]])
        w = w - w.mean()
    else:
        w = np.zeros(n)
    terms = np.stack(
        [
            z,
            y,
            w,
            z * z,
            z * y,
            y * y,
            w * z,
            w * y,
            w * w,
            z**3,
            z * z * y,
            z**4,
            w * z * z,
            w * w * z,
            w * w * y,
            w * w * z * z,
        ]  # fmt: skip
    )
    edges = np.arange(blocks + 1) * n // blocks
    out = np.stack([terms[:, a:b].sum(axis=1) for a, b in zip(edges[:-1], edges[1:])])
    if not has_w:
        out[:, [2, 6, 7, 8, 12, 13, 14, 15]] = np.nan
    return out


def line_spectra(fy: Any, fz: Any, lines: Any, segments: int = 4) -> np.ndarray:
    """NumPy reference of the kernel's column ``"spec"`` for one window (docs/method.md 3e).

    Returns (lines, 4): Re S_yz, Im S_yz, S_zz, S_yy with S_yz the mean over
    ``segments`` consecutive segments of m = n // segments samples of
    Y conj(Z), Y and Z the DFTs at each line (cycles per sample) of the
    segment, centred and multiplied by the Hann window 0.5 - 0.5 cos(2 pi t / m).
    """
    fy = np.asarray(fy, dtype=np.float64)
    fz = np.asarray(fz, dtype=np.float64)
    m = fz.size // segments
    t = np.arange(m)
    h = 0.5 - 0.5 * np.cos(2 * np.pi * t / m)
    out = np.zeros((len(lines), 4))
    for j, f in enumerate(lines):
        e = np.exp(-2j * np.pi * f * t)
        for k in range(segments):
            ys, zs = fy[k * m : (k + 1) * m], fz[k * m : (k + 1) * m]
            Y = np.sum(h * (ys - ys.mean()) * e)
            Z = np.sum(h * (zs - zs.mean()) * e)
            c = Y * np.conj(Z)
            out[j] += (c.real, c.imag, abs(Z) ** 2, abs(Y) ** 2)
    return out / segments


def classical_windows(fy: np.ndarray, fz: np.ndarray, rel: np.ndarray, length: int, spec: Any
                      ) -> Dict[str, np.ndarray]:  # fmt: skip
    """NumPy reference of the kernel's classical COF per window starting at ``rel`` (docs/method.md 6a).

    Mean and median of |fy - tare_fy| / |fz - tare_fz| over |fz - tare_fz| >=
    min_fn, and the mean and standard deviation of fz - tare_fz.
    """
    k = len(rel)
    mean = np.full(k, np.nan)
    median = np.full(k, np.nan)
    zm = np.full(k, np.nan)
    zs = np.full(k, np.nan)
    for j, s in enumerate(rel):
        zr = fz[s : s + length] - spec.tare_fz
        y = np.abs(fy[s : s + length] - spec.tare_fy)
        z = np.abs(zr)
        zm[j] = float(np.mean(zr))
        zs[j] = float(np.std(zr))
        keep = (z >= spec.min_fn) & (z > 0) & np.isfinite(y) & np.isfinite(z)
        if keep.any():
            r = y[keep] / z[keep]
            mean[j] = float(r.mean())
            median[j] = float(np.median(r))
    return {"mu_classical": mean, "mu_classical_median": median, "fz_mean": zm, "fz_std": zs}
