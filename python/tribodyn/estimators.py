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

__all__ = [
    "BLOCKS",
    "PRODUCTS",
    "ESTIMATORS",
    "T975",
    "Slopes",
    "slopes",
    "pooled_noise",
    "quadratic",
    "line_stats",
    "line_frequencies",
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


def _p(E: np.ndarray, name: str) -> np.ndarray:
    return E[..., _I[name]]


def block_sizes(n: np.ndarray) -> np.ndarray:
    """Samples per block, (windows, BLOCKS): block k is [k n // B, (k + 1) n // B)."""
    n = np.asarray(n, dtype=np.int64)[:, None]
    k = np.arange(BLOCKS + 1, dtype=np.int64)[None, :]
    edges = k * n // BLOCKS
    return np.diff(edges, axis=1).astype(float)


def _bm_se(U: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Batch-means standard error sqrt(B / (B - 1) sum_k U_k^2) / |D| (docs/method.md 3d)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(BLOCKS / (BLOCKS - 1) * np.sum(U * U, axis=1)) / np.abs(D)


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


def pooled_noise(E: np.ndarray, n: np.ndarray) -> Tuple[float, float]:
    """sigma_z^2 of the noise on fz measured from the recording, and its standard error (docs/method.md 3c).

    Per window (S_zz - S_zy / b_iv) / n: the part of fz's variance the
    instrument does not share with fy; the median over windows (robust to
    windows where the instrument is weak), clipped at 0. Its standard error
    is that of a median, sqrt(pi / 2) * 1.4826 MAD / sqrt(windows).
    """
    T = E.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        b_iv = _p(T, "wy") / _p(T, "wz")
        s2 = (_p(T, "zz") - _p(T, "zy") / b_iv) / np.asarray(n, dtype=float)
    s2 = s2[np.isfinite(s2)]
    if s2.size == 0:
        return float("nan"), float("nan")
    med = float(np.median(s2))
    mad = float(np.median(np.abs(s2 - med)))
    se = np.sqrt(np.pi / 2) * 1.4826 * mad / np.sqrt(s2.size)
    return max(med, 0.0), float(se)


def slopes(
    E: np.ndarray,
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
    E = np.asarray(E, dtype=float)
    T = E.sum(axis=1)
    nk = block_sizes(n)
    nf = np.asarray(n, dtype=float)
    szz, szy, syy, swz, swy, sww = (_p(T, k) for k in ("zz", "zy", "yy", "wz", "wy", "ww"))
    with np.errstate(invalid="ignore", divide="ignore"):
        b_ols = szy / szz
        u_ols = _p(E, "zy") - b_ols[:, None] * _p(E, "zz")
        b_iv = swy / swz
        u_iv = _p(E, "wy") - b_iv[:, None] * _p(E, "wz")
        r_inst = swz / np.sqrt(sww * szz)
        se_ols, se_iv = _bm_se(u_ols, szz), _bm_se(u_iv, swz)
        phi = u_iv / swz[:, None] - u_ols / szz[:, None]
        t = (b_iv - b_ols) / np.sqrt(BLOCKS / (BLOCKS - 1) * np.sum(phi * phi, axis=1))
    from scipy import stats  # lazy: scipy.stats is slow to import

    p = 2.0 * stats.t.sf(np.abs(t), BLOCKS - 1)
    noise_z = float("nan")
    if estimator == "ols":
        b, se = b_ols, se_ols
    elif estimator == "iv":
        b, se = b_iv, se_iv
    elif estimator == "corrected":
        if noise is not None:
            s2, s2_se = float(noise[1]) ** 2, 0.0
        else:
            s2, s2_se = pooled if pooled is not None else pooled_noise(E, n)
        noise_z = s2
        with np.errstate(invalid="ignore", divide="ignore"):
            D = szz - nf * s2
            D = np.where(D > 0, D, np.nan)
            b = szy / D
            u = _p(E, "zy") - b[:, None] * (_p(E, "zz") - nk * s2)
            se = np.sqrt(_bm_se(u, D) ** 2 + (b * nf / D) ** 2 * (s2_se if np.isfinite(s2_se) else 0.0) ** 2)
    else:
        if noise is None:
            raise ValueError("estimator='deming' needs noise=(sigma_y, sigma_z) or a quiet record (docs/method.md 3c)")
        b, se = _deming(E, nk, float(noise[0]) ** 2 / float(noise[1]) ** 2)
    return Slopes(
        ols=b_ols, ols_se=se_ols, iv=b_iv, iv_se=se_iv, slope=b, se=se, attenuation_p=p, noise_z=noise_z,
        instrument_r=r_inst,
    )  # fmt: skip


def _deming_slope(szz: np.ndarray, syy: np.ndarray, szy: np.ndarray, delta: float) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        d = syy - delta * szz
        return (d + np.sqrt(d * d + 4.0 * delta * szy * szy)) / (2.0 * szy)


def _deming(E: np.ndarray, nk: np.ndarray, delta: float) -> Tuple[np.ndarray, np.ndarray]:
    """Deming slope and its delete-one-block jackknife standard error (docs/method.md 3c)."""
    T = E.sum(axis=1)
    b = _deming_slope(_p(T, "zz"), _p(T, "yy"), _p(T, "zy"), delta)
    reps = []
    for k in range(BLOCKS):
        R = T - E[:, k, :]
        m = nk.sum(axis=1) - nk[:, k]
        with np.errstate(invalid="ignore", divide="ignore"):
            cz, cy = _p(R, "z") / m, _p(R, "y") / m
        szz = _p(R, "zz") - m * cz * cz
        syy = _p(R, "yy") - m * cy * cy
        szy = _p(R, "zy") - m * cz * cy
        reps.append(_deming_slope(szz, syy, szy, delta))
    J = np.stack(reps, axis=1)
    se = np.sqrt((BLOCKS - 1) / BLOCKS * np.sum((J - J.mean(axis=1, keepdims=True)) ** 2, axis=1))
    return b, se


def quadratic(E: np.ndarray, n: np.ndarray, instrumented: bool) -> Tuple[np.ndarray, np.ndarray]:
    """d mu / d Fn per window and its batch-means standard error (orientation +1; docs/method.md 3e).

    Fits fy = c + a1 z + a2 (z^2 - mean z^2) per window; a2 is d mu / d Fn
    when mu = mu0 (1 + beta (Fn - Fn0)). With ``instrumented`` the
    instruments are w and w^2 - mean w^2 (w the lagged fz), which keeps a2
    unbiased when fz carries noise.
    """
    E = np.asarray(E, dtype=float)
    T = E.sum(axis=1)
    nk = block_sizes(n)
    nf = np.asarray(n, dtype=float)
    g = _p  # shorthand
    m2 = g(T, "zz") / nf
    y_b, z_b = g(E, "y"), g(E, "z")
    if instrumented:
        mw2 = g(T, "ww") / nf
        w_b = g(E, "w")
        H = np.empty((len(nf), 2, 2))
        H[:, 0, 0], H[:, 0, 1] = g(T, "wz"), g(T, "wzz")
        H[:, 1, 0], H[:, 1, 1] = g(T, "wwz"), g(T, "wwzz") - nf * m2 * mw2
        v = np.stack([g(T, "wy"), g(T, "wwy")], axis=1)
        # Block sums of instrument x (y, z, q), q = z^2 - m2, r = w^2 - mw2.
        hy = np.stack([g(E, "wy"), g(E, "wwy") - mw2[:, None] * y_b], axis=2)
        hz = np.stack([g(E, "wz"), g(E, "wwz") - mw2[:, None] * z_b], axis=2)
        hq = np.stack(
            [
                g(E, "wzz") - m2[:, None] * w_b,
                g(E, "wwzz") - m2[:, None] * g(E, "ww") - mw2[:, None] * g(E, "zz") + (m2 * mw2)[:, None] * nk,
            ],
            axis=2,
        )
    else:
        H = np.empty((len(nf), 2, 2))
        H[:, 0, 0], H[:, 0, 1] = g(T, "zz"), g(T, "zzz")
        H[:, 1, 0], H[:, 1, 1] = g(T, "zzz"), g(T, "zzzz") - nf * m2 * m2
        v = np.stack([g(T, "zy"), g(T, "zzy")], axis=1)
        hy = np.stack([g(E, "zy"), g(E, "zzy") - m2[:, None] * y_b], axis=2)
        hz = np.stack([g(E, "zz"), g(E, "zzz") - m2[:, None] * z_b], axis=2)
        hq = np.stack(
            [g(E, "zzz") - m2[:, None] * z_b, g(E, "zzzz") - 2 * m2[:, None] * g(E, "zz") + (m2 * m2)[:, None] * nk],
            axis=2,
        )
    a2 = np.full(len(nf), np.nan)
    se = np.full(len(nf), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
        ok = np.isfinite(det) & (det != 0) & np.isfinite(v).all(axis=1)
        if not ok.any():
            return a2, se
        Hi = np.linalg.inv(H[ok])
        a = np.einsum("kij,kj->ki", Hi, v[ok])
        G = hy[ok] - a[:, 0, None, None] * hz[ok] - a[:, 1, None, None] * hq[ok]  # (k, B, 2) block scores
        S = BLOCKS / (BLOCKS - 1) * np.einsum("kbi,kbj->kij", G, G)
        V = np.einsum("kij,kjl,kml->kim", Hi, S, Hi)
    a2[ok] = a[:, 1]
    se[ok] = np.sqrt(np.maximum(V[:, 1, 1], 0.0))
    return a2, se


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
