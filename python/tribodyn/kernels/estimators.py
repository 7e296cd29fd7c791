"""Slope estimators, robust standard errors, force dependence and line spectra (docs/method.md 3a-3e).

The Rust kernel delivers, per window, the sums of products of the centred
forces z = fz - mean, y = fy - mean and of the instrument w (fz lagged by
``lag`` samples, centred) in :data:`BLOCKS` consecutive blocks of the window
(``_core`` column ``"ext"``, shape ``(windows, BLOCKS, PRODUCTS)``), and the
cross-spectra of fy and fz at the line frequencies (column ``"spec"``).
Everything here is closed-form arithmetic on those sums, vectorised over
windows; all slopes are for orientation +1 (the caller multiplies by s).

Estimators (docs/method.md 3a-3c):

- ``"ols"``: the paper's Eq. (8), b = S_zy / S_zz;
- ``"iv"``: instrumental variables, b = S_wy / S_wz;
- ``"corrected"``: errors-in-variables correction of OLS, b = S_zy /
  (S_zz - n sigma_z^2), with the variance sigma_z^2 of the noise on fz given
  or measured from the recording (median over windows of
  (S_zz - S_zy / b_iv) / n);
- ``"deming"``: Deming regression with the ratio delta = sigma_y^2 / sigma_z^2
  of the noise variances.

Standard errors are batch means over the blocks (docs/method.md 3d): with
U_k the block sums of the estimating equation's terms,
var(b) = B / (B - 1) sum_k U_k^2 / D^2, and the 95 % interval uses Student's
t with B - 1 degrees of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from .quantiles import Z975

#: Below this median |r| of instrument and fz the instrument is weak (docs/method.md 3b).
WEAK_INSTRUMENT = 0.3

__all__ = [
    "BLOCKS",
    "PRODUCTS",
    "ESTIMATORS",
    "T975",
    "Slopes",
    "slopes",
    "pooled_noise",
    "reverse_slope",
    "window_noise",
    "gate_precision",
    "quadratic",
    "line_stats",
    "line_frequencies",
    "Sums",
]

#: Blocks per window of the batch-means standard errors (``_core``'s extended.BLOCKS).
BLOCKS = 5
#: Sums per block, in the kernel's order.
PRODUCTS = ("z", "y", "w", "zz", "zy", "yy", "wz", "wy", "ww", "zzz", "zzy", "zzzz", "wzz", "wwz", "wwy", "wwzz")
_I = {name: k for k, name in enumerate(PRODUCTS)}
#: The estimators of ``analyze(estimator=...)``.
ESTIMATORS = ("corrected", "iv", "ols", "deming")
#: Student's t quantile 0.975 with BLOCKS - 1 = 4 degrees of freedom (scipy.stats.t.ppf(0.975, 4)).
T975 = 2.7764451051977987
#: Median of chi^2 with BLOCKS - 1 = 4 degrees of freedom (scipy.stats.chi2.ppf(0.5, 4)): a batch-means
#: variance over 5 blocks is var(b) chi^2_4 / 4 (docs/method.md 5).
CHI2_4_MEDIAN = 3.3566939800333224


def student4_cdf(t: np.ndarray) -> np.ndarray:
    """Student's t distribution function with 4 degrees of freedom, in closed form (docs/method.md 3b).

    F(t) = 1/2 + (3/8) (t / sqrt(1 + t^2/4)) (1 - t^2 / (12 (1 + t^2/4))); equal to
    ``scipy.special.stdtr(4, t)`` within 1e-15 (tested), without importing SciPy in every analysis.
    """
    if BLOCKS - 1 != 4:  # pragma: no cover - the closed form is for 4 degrees of freedom
        raise AssertionError("student4_cdf needs BLOCKS = 5")
    t = np.asarray(t, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        u = 1.0 + 0.25 * t * t
        f = 0.5 + 0.375 * (t / np.sqrt(u)) * (1.0 - t * t / (12.0 * u))
    return np.where(np.isinf(t), np.where(t > 0, 1.0, 0.0), f)


class Sums:
    """The block sums of many windows laid out for the arithmetic: ``blocks[p]`` is product p's
    (windows, BLOCKS) array (contiguous), ``total[p]`` its (windows,) sum over the blocks."""

    def __init__(self, E: np.ndarray) -> None:
        E = np.asarray(E, dtype=float)
        if E.ndim != 3 or E.shape[1:] != (BLOCKS, len(PRODUCTS)):
            raise ValueError(f"block sums must have shape (windows, {BLOCKS}, {len(PRODUCTS)}), got {E.shape}")
        self.E = E
        self.blocks = np.ascontiguousarray(E.transpose(2, 0, 1))
        # blocks.sum(axis=2) bit for bit (NumPy adds the few blocks in order onto 0.0), without its slow
        # reduction over a short last axis
        total = 0.0 + self.blocks[:, :, 0]
        for k in range(1, BLOCKS):
            total += self.blocks[:, :, k]
        self.total = total

    def __len__(self) -> int:
        return int(self.E.shape[0])


def _sums(E: "np.ndarray | Sums") -> Sums:
    return E if isinstance(E, Sums) else Sums(E)


def _p(S: Sums, name: str, total: bool = False) -> np.ndarray:
    out: np.ndarray = S.total[_I[name]] if total else S.blocks[_I[name]]
    return out


def block_sizes(n: np.ndarray) -> np.ndarray:
    """Samples per block, (windows, BLOCKS): block k is [k n // B, (k + 1) n // B)."""
    n = np.asarray(n, dtype=np.int64)[:, None]
    k = np.arange(BLOCKS + 1, dtype=np.int64)[None, :]
    edges = k * n // BLOCKS
    return np.diff(edges, axis=1).astype(float)


def _bm_se(U: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Batch-means standard error sqrt(B / (B - 1) sum_k U_k^2) / |D| (docs/method.md 3d)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        se: np.ndarray = np.sqrt(BLOCKS / (BLOCKS - 1) * np.sum(U * U, axis=1)) / np.abs(D)
    return se


@dataclass(frozen=True)
class Slopes:
    """Per-window slopes of fy on fz (orientation +1) and their batch-means standard errors.

    Attributes
    ----------
    ols, ols_se, iv, iv_se : ndarray
        Least squares and instrumental variables.
    slope, se : ndarray
        The chosen estimator's.
    attenuation_p : ndarray
        p-value of the test that OLS and IV agree (a Hausman test on the
        batch means of their difference; small: OLS attenuated, docs/method.md 3b).
    noise_z : float
        sigma_z^2 (N^2) used by ``"corrected"`` (NaN otherwise).
    instrument_r : ndarray
        Pearson r of the instrument and fz per window (its strength).
    dnoise : ndarray
        d b / d sigma_z^2 = b n / D (1/N^2) for ``"corrected"`` with the noise
        measured from the recording (one estimate, whose error moves every
        window together; ``summary()`` draws it anew, docs/method.md 3d);
        0 otherwise.
    se_white : ndarray
        The chosen estimator's standard error if the residuals were white:
        s_e sqrt(S_hh) / |D| with s_e^2 = (S_yy - S_zy^2 / S_zz) / (n - 2)
        (n - 2 degrees of freedom, so nearly free of sampling noise; the
        precision the gate judges, docs/method.md 5).
    """

    ols: np.ndarray
    ols_se: np.ndarray
    iv: np.ndarray
    iv_se: np.ndarray
    slope: np.ndarray
    se: np.ndarray
    attenuation_p: np.ndarray
    noise_z: float
    instrument_r: np.ndarray
    se_white: np.ndarray
    dnoise: np.ndarray


def window_noise(E: "np.ndarray | Sums", n: np.ndarray) -> np.ndarray:
    """Each window's measurement of sigma_z^2, (S_zz - S_zy / b_iv) / n (N^2; docs/method.md 3c).

    The part of fz's variance the instrument does not share with fy; NaN
    where the instrument gives no slope.
    """
    S = _sums(E)
    with np.errstate(invalid="ignore", divide="ignore"):
        b_iv = _p(S, "wy", True) / _p(S, "wz", True)
        s2: np.ndarray = (_p(S, "zz", True) - _p(S, "zy", True) / b_iv) / np.asarray(n, dtype=float)
    return np.where(np.isfinite(s2), s2, np.nan)


def pooled_noise(E: "np.ndarray | Sums", n: np.ndarray) -> Tuple[float, float]:
    """sigma_z^2 of the noise on fz measured from the recording, and its standard error (docs/method.md 3c).

    The median over windows of :func:`window_noise` (robust to windows
    where the instrument is weak), clipped at 0. Its standard error is that
    of a median, sqrt(pi / 2) * 1.4826 MAD / sqrt(windows).
    """
    s2 = window_noise(E, n)
    s2 = s2[np.isfinite(s2)]
    if s2.size == 0:
        return float("nan"), float("nan")
    med = float(np.median(s2))
    mad = float(np.median(np.abs(s2 - med)))
    se = np.sqrt(np.pi / 2) * 1.4826 * mad / np.sqrt(s2.size)
    return max(med, 0.0), float(se)


def slopes(
    E: "np.ndarray | Sums",
    n: np.ndarray,
    estimator: str,
    *,
    noise: Optional[Tuple[float, float]] = None,
    pooled: Optional[Tuple[float, float]] = None,
) -> Slopes:
    """The slopes of every window from its block sums ``E`` (windows, BLOCKS, PRODUCTS).

    Parameters
    ----------
    n : ndarray
        Samples per window.
    estimator : {"corrected", "iv", "ols", "deming"}
    noise : (sigma_y, sigma_z) in N, optional
        Standard deviations of the noise on fy and fz; ``"deming"`` needs
        both, ``"corrected"`` uses sigma_z instead of measuring it.
    pooled : (sigma_z^2, its standard error), optional
        For ``"corrected"`` without ``noise``: the recording's measurement
        (default: :func:`pooled_noise` of these windows).
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {', '.join(map(repr, ESTIMATORS))}, got {estimator!r}")
    S = _sums(E)
    nk = block_sizes(n)
    nf = np.asarray(n, dtype=float)
    szz, szy, syy, swz, swy, sww = (_p(S, k, True) for k in ("zz", "zy", "yy", "wz", "wy", "ww"))
    with np.errstate(invalid="ignore", divide="ignore"):
        s_e2 = np.maximum(syy - szy * szy / szz, 0.0) / (nf - 2.0)  # OLS residual variance, docs/method.md 5
        b_ols = szy / szz
        u_ols = _p(S, "zy") - b_ols[:, None] * _p(S, "zz")
        b_iv = swy / swz
        u_iv = _p(S, "wy") - b_iv[:, None] * _p(S, "wz")
        r_inst = swz / np.sqrt(sww * szz)
        se_ols, se_iv = _bm_se(u_ols, szz), _bm_se(u_iv, swz)
        phi = u_iv / swz[:, None] - u_ols / szz[:, None]
        t = (b_iv - b_ols) / np.sqrt(BLOCKS / (BLOCKS - 1) * np.sum(phi * phi, axis=1))
    p = 2.0 * student4_cdf(-np.abs(t))  # two-sided Student t, B - 1 = 4 degrees of freedom
    noise_z = float("nan")
    with np.errstate(invalid="ignore", divide="ignore"):
        se_w = np.sqrt(s_e2 / szz)
    dnoise = np.zeros(len(nf))
    if estimator == "ols":
        b, se = b_ols, se_ols
    elif estimator == "iv":
        b, se = b_iv, se_iv
        with np.errstate(invalid="ignore", divide="ignore"):
            se_w = np.sqrt(s_e2 * sww) / np.abs(swz)
    elif estimator == "corrected":
        if noise is not None:
            s2, s2_se = float(noise[1]) ** 2, 0.0
        else:
            s2, s2_se = pooled if pooled is not None else pooled_noise(S, n)
        noise_z = s2
        with np.errstate(invalid="ignore", divide="ignore"):
            D = szz - nf * s2
            D = np.where(D > 0, D, np.nan)
            b = szy / D
            u = _p(S, "zy") - b[:, None] * (_p(S, "zz") - nk * s2)
            s2_se = s2_se if np.isfinite(s2_se) else 0.0
            se = np.sqrt(_bm_se(u, D) ** 2 + (b * nf / D) ** 2 * s2_se**2)
            se_w = np.sqrt(s_e2 * szz) / D
            if noise is None and s2_se > 0:  # measured here (a weak instrument's fallback passes (0, 0))
                dnoise = b * nf / D
    else:
        if noise is None:
            raise ValueError("estimator='deming' needs noise=(sigma_y, sigma_z) or a quiet record (docs/method.md 3c)")
        b, se = _deming(S, nk, float(noise[0]) ** 2 / float(noise[1]) ** 2)
    return Slopes(
        ols=b_ols, ols_se=se_ols, iv=b_iv, iv_se=se_iv, slope=b, se=se, attenuation_p=p, noise_z=noise_z,
        instrument_r=r_inst, se_white=se_w, dnoise=dnoise,
    )  # fmt: skip


def reverse_slope(E: "np.ndarray | Sums") -> Tuple[np.ndarray, np.ndarray]:
    """The reverse regression's slope S_yy / S_zy per window (orientation +1) and its batch-means standard error.

    fz regressed on fy, inverted: with noise on fy and fz independent of the
    contact force, |OLS| <= |b| <= |S_yy / S_zy| (the classical bounds of
    errors in variables; Frisch 1934, Fuller 1987, Sec. 1.1.3): the upper
    end of the interval when least squares is a lower bound (docs/method.md 3d).
    Estimating equation sum_t y_t (y_t - b z_t) = 0, so U_k = S_yy,k - b S_zy,k, D = S_zy.
    """
    S = _sums(E)
    syy, szy = _p(S, "yy", True), _p(S, "zy", True)
    with np.errstate(invalid="ignore", divide="ignore"):
        b = syy / szy
        u = _p(S, "yy") - b[:, None] * _p(S, "zy")
    return b, _bm_se(u, szy)


def gate_precision(mu: np.ndarray, se: np.ndarray, se_white: np.ndarray) -> Tuple[np.ndarray, float, float]:
    """The relative half-width the "ci" gate judges, per window, and what it is made of (docs/method.md 5).

    rel = Z975 R se_white / |mu_ref|: the window's white-noise standard
    error ``se_white`` (:class:`Slopes`), scaled by the recording's ratio R
    of batch-means to white-noise standard errors (R^2 = median over
    windows of (se / se_white)^2, divided by median(chi^2_4) / 4 = 0.839,
    the median of a batch-means variance over its expectation), against the
    recording's robust COF mu_ref = median of the finite ``mu``. Neither
    the window's own slope nor the sampling noise of its 4-degree-of-freedom
    ``se`` enters, so passing does not select windows whose error is
    positive or whose interval is too short. Returns (rel, R, mu_ref); rel
    is NaN where it cannot be formed (the window then fails the gate).
    """
    mu = np.asarray(mu, dtype=float)
    se_w = np.asarray(se_white, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        q2 = (np.asarray(se, dtype=float) / se_w) ** 2
    q2 = q2[np.isfinite(q2)]
    fin = mu[np.isfinite(mu)]
    scale = float(np.sqrt(np.median(q2) * 4.0 / CHI2_4_MEDIAN)) if q2.size else float("nan")
    ref = float(np.median(fin)) if fin.size else float("nan")
    with np.errstate(invalid="ignore", divide="ignore"):
        rel: np.ndarray = Z975 * scale * se_w / abs(ref)
    return np.where(np.isfinite(rel), rel, np.nan), scale, ref


def _deming_slope(szz: np.ndarray, syy: np.ndarray, szy: np.ndarray, delta: float) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        d = syy - delta * szz
        b: np.ndarray = (d + np.sqrt(d * d + 4.0 * delta * szy * szy)) / (2.0 * szy)
    return b


def _deming(S: Sums, nk: np.ndarray, delta: float) -> Tuple[np.ndarray, np.ndarray]:
    """Deming slope and its delete-one-block jackknife standard error (docs/method.md 3c)."""
    T = S.total
    b = _deming_slope(T[_I["zz"]], T[_I["yy"]], T[_I["zy"]], delta)
    reps = []
    for k in range(BLOCKS):
        R = T - S.blocks[:, :, k]
        m = nk.sum(axis=1) - nk[:, k]
        with np.errstate(invalid="ignore", divide="ignore"):
            cz, cy = R[_I["z"]] / m, R[_I["y"]] / m
        szz = R[_I["zz"]] - m * cz * cz
        syy = R[_I["yy"]] - m * cy * cy
        szy = R[_I["zy"]] - m * cz * cy
        reps.append(_deming_slope(szz, syy, szy, delta))
    J = np.stack(reps, axis=1)
    se = np.sqrt((BLOCKS - 1) / BLOCKS * np.sum((J - J.mean(axis=1, keepdims=True)) ** 2, axis=1))
    return b, se


def quadratic(E: "np.ndarray | Sums", n: np.ndarray, instrumented: bool) -> Tuple[np.ndarray, np.ndarray]:
    """d mu / d Fn per window and its batch-means standard error (orientation +1; docs/method.md 3e).

    Fits fy = c + a1 z + a2 (z^2 - mean z^2) per window; a2 is d mu / d Fn
    when mu = mu0 (1 + beta (Fn - Fn0)). With ``instrumented`` the
    instruments are w and w^2 - mean w^2 (w the lagged fz), which keeps a2
    unbiased when fz carries noise. a = H^-1 v with H the instruments'
    cross-products with (z, q), q = z^2 - mean z^2; the block scores
    g_k = h_k y - H_k a give var(a) = H^-1 (B / (B - 1) sum_k g_k g_k^T) H^-T.
    """
    S = _sums(E)
    nk = block_sizes(n)
    nf = np.asarray(n, dtype=float)

    def t(name: str) -> np.ndarray:
        return _p(S, name, True)

    def b(name: str) -> np.ndarray:
        return _p(S, name)

    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        m2 = t("zz") / nf
        y_b, z_b = b("y"), b("z")
        if instrumented:
            mw2 = t("ww") / nf
            h00, h01, h10, h11 = t("wz"), t("wzz"), t("wwz"), t("wwzz") - nf * m2 * mw2
            v0, v1 = t("wy"), t("wwy")
            # Block sums of instrument x (y, z, q), q = z^2 - m2, r = w^2 - mw2.
            hy0, hy1 = b("wy"), b("wwy") - mw2[:, None] * y_b
            hz0, hz1 = b("wz"), b("wwz") - mw2[:, None] * z_b
            hq0 = b("wzz") - m2[:, None] * b("w")
            hq1 = b("wwzz") - m2[:, None] * b("ww") - mw2[:, None] * b("zz") + (m2 * mw2)[:, None] * nk
        else:
            h00, h01, h10, h11 = t("zz"), t("zzz"), t("zzz"), t("zzzz") - nf * m2 * m2
            v0, v1 = t("zy"), t("zzy")
            hy0, hy1 = b("zy"), b("zzy") - m2[:, None] * y_b
            hz0, hz1 = b("zz"), b("zzz") - m2[:, None] * z_b
            hq0 = b("zzz") - m2[:, None] * z_b
            hq1 = b("zzzz") - 2 * m2[:, None] * b("zz") + (m2 * m2)[:, None] * nk
        det = h00 * h11 - h01 * h10
        det = np.where(det != 0, det, np.nan)
        a1 = (h11 * v0 - h01 * v1) / det
        a2 = (h00 * v1 - h10 * v0) / det
        g0 = hy0 - a1[:, None] * hz0 - a2[:, None] * hq0
        g1 = hy1 - a1[:, None] * hz1 - a2[:, None] * hq1
        c = BLOCKS / (BLOCKS - 1)
        s00, s01, s11 = c * np.sum(g0 * g0, axis=1), c * np.sum(g0 * g1, axis=1), c * np.sum(g1 * g1, axis=1)
        r0, r1 = -h10 / det, h00 / det  # row 2 of H^-1
        var = r0 * r0 * s00 + 2 * r0 * r1 * s01 + r1 * r1 * s11
        se = np.sqrt(np.maximum(var, 0.0))
    return a2, np.where(np.isfinite(a2), se, np.nan)


def line_frequencies(
    fs: float, rpm: Optional[float], n_lamellas: Optional[int]
) -> Tuple[Tuple[float, ...], Dict[str, int]]:
    """Line frequencies (cycles per sample) of the rig and the index of f0 and f_l among them (docs/method.md 3e).

    f0 = rpm / 60 and its 2nd and 3rd harmonics, f_l = n_lamellas f0 and
    2 f_l, those below 0.45 fs, in increasing order. Empty without rpm.
    """
    if rpm is None:
        return (), {}
    f0 = float(rpm) / 60.0
    cand = [("f0", f0), ("2f0", 2 * f0), ("3f0", 3 * f0)]
    if n_lamellas is not None:
        fl = int(n_lamellas) * f0
        cand += [("fl", fl), ("2fl", 2 * fl)]
    seen: Dict[float, str] = {}
    for name, f in cand:
        if 0 < f < 0.45 * fs and f not in seen:
            seen[f] = name
    order = sorted(seen)
    return tuple(f / fs for f in order), {seen[f]: k for k, f in enumerate(order)}


def line_stats(spec: np.ndarray, lines: Sequence[float], s: int) -> Dict[str, np.ndarray]:
    """H1, coherence and the fz delay per window from the line cross-spectra (docs/method.md 3e).

    ``spec`` is (windows, lines, 4): Re S_yz, Im S_yz, S_zz, S_yy. Returns
    ``h1`` (windows, lines) = s Re(S_yz / S_zz), ``coherence``
    |S_yz|^2 / (S_zz S_yy) and ``skew`` (samples by which fz lags fy): the
    slope through 0 of the phase of s S_yz against 2 pi f, unwrapped line
    by line from the lowest frequency, weighted by gamma^2 / (1 - gamma^2).
    """
    spec = np.asarray(spec, dtype=float)
    syz = s * (spec[..., 0] + 1j * spec[..., 1])
    szz, syy = spec[..., 2], spec[..., 3]
    with np.errstate(invalid="ignore", divide="ignore"):
        h1 = (syz / szz).real
        coh = np.abs(syz) ** 2 / (szz * syy)
    omega = 2 * np.pi * np.asarray(lines, dtype=float)
    phase = np.angle(syz)
    w = np.clip(coh / np.maximum(1.0 - coh, 1e-9), 0.0, 1e9)
    w = np.where(np.isfinite(w), w, 0.0)
    tau = phase[:, 0] / omega[0] if len(omega) else np.full(len(spec), np.nan)
    num = w[:, 0] * omega[0] * phase[:, 0] if len(omega) else 0.0
    den = w[:, 0] * omega[0] ** 2 if len(omega) else 1.0
    for j in range(1, len(omega)):
        ph = phase[:, j] + 2 * np.pi * np.round((omega[j] * tau - phase[:, j]) / (2 * np.pi))
        num = num + w[:, j] * omega[j] * ph
        den = den + w[:, j] * omega[j] ** 2
        with np.errstate(invalid="ignore", divide="ignore"):
            tau = np.where(den > 0, num / den, tau)
    return {"h1": h1, "coherence": coh, "skew": tau}
