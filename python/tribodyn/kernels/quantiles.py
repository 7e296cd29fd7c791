"""The quantiles every interval uses, defined once (docs/method.md 3d, 6e, 10a).

* :data:`Z975`: the normal quantile 0.975 (the paper's mu +- 1.96 se).
* :func:`t975`: Student's t quantile 0.975, tabulated from scipy for 1..40 degrees of freedom.
* :func:`t_quantile`: Student's t quantile at any level, exact for 1 and 2 degrees of freedom, else a
  Cornish-Fisher expansion (without importing scipy on the analysis path).
* :func:`t_ppf`, :func:`t_sf`, :func:`f_ppf`, :func:`f_sf`: Student's t and Fisher's F distributions, exact, the
  values ``scipy.stats`` gives (its own functions of ``scipy.special``, which imports in a third of the time);
  NumPy arrays or numbers.
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any

import numpy as np

__all__ = ["Z975", "t975", "t_quantile", "t_ppf", "t_sf", "f_ppf", "f_sf"]

#: Normal quantile 0.975 (scipy.stats.norm.ppf(0.975); NormalDist().inv_cdf(0.975) gives the same float).
Z975 = 1.959963984540054


def t_quantile(p: float, df: int) -> float:
    """Student's t quantile: exact for 1 and 2 degrees of freedom, else the Cornish-Fisher expansion in
    1/df to the 4th order (Abramowitz and Stegun 26.7.5; at p = 0.975 within 0.12 % at df = 3 and 1e-5
    at df >= 8; at p = 0.995 within 0.8 % at df = 3)."""
    if df == 1:
        return math.tan(math.pi * (p - 0.5))
    if df == 2:
        return (2.0 * p - 1.0) / math.sqrt(2.0 * p * (1.0 - p))
    z = NormalDist().inv_cdf(p)
    g1 = (z**3 + z) / 4
    g2 = (5 * z**5 + 16 * z**3 + 3 * z) / 96
    g3 = (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / 384
    g4 = (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / 92160
    return float(z + g1 / df + g2 / df**2 + g3 / df**3 + g4 / df**4)


#: Student's t quantile 0.975 for 1..40 degrees of freedom (scipy.stats.t.ppf(0.975, df); tested against it).
_T975 = (
    12.706205, 4.302653, 3.182446, 2.776445, 2.570582, 2.446912, 2.364624, 2.306004, 2.262157, 2.228139,
    2.200985, 2.178813, 2.160369, 2.144787, 2.13145, 2.119905, 2.109816, 2.100922, 2.093024, 2.085963,
    2.079614, 2.073873, 2.068658, 2.063899, 2.059539, 2.055529, 2.051831, 2.048407, 2.04523, 2.042272,
    2.039513, 2.036933, 2.034515, 2.032245, 2.030108, 2.028094, 2.026192, 2.024394, 2.022691, 2.021075,
)  # fmt: skip


def t975(df: int) -> float:
    """Student's t quantile 0.975 with ``df`` degrees of freedom (normal 1.96 beyond 40)."""
    if df < 1:
        return float("nan")
    return _T975[df - 1] if df <= len(_T975) else 1.959964 + 2.4 / df


def t_ppf(p: Any, df: Any) -> Any:
    """Student's t quantile at probability ``p`` with ``df`` degrees of freedom (``scipy.stats.t.ppf``)."""
    from scipy import special

    return special.stdtrit(df, p)


def t_sf(x: Any, df: Any) -> Any:
    """Student's t survival function P(T > x) with ``df`` degrees of freedom (``scipy.stats.t.sf``)."""
    from scipy import special

    return special.stdtr(df, np.negative(x))


def f_ppf(p: Any, dfn: Any, dfd: Any) -> Any:
    """Fisher's F quantile at probability ``p`` with (``dfn``, ``dfd``) degrees of freedom (``scipy.stats.f.ppf``)."""
    from scipy import special

    return special.fdtri(dfn, dfd, p)


def f_sf(x: Any, dfn: Any, dfd: Any) -> Any:
    """Fisher's F survival function P(F > x) with (``dfn``, ``dfd``) degrees of freedom (``scipy.stats.f.sf``)."""
    from scipy import special

    return special.fdtrc(dfn, dfd, x)
