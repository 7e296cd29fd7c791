"""A pandas DataFrame as a source of :func:`tribodyn.analyze`: roles by column, fs from its time."""

from __future__ import annotations

from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np


def from_dataframe(
    df: Any, channels: Optional[Mapping[str, str]], fs: Optional[float]
) -> Tuple[Dict[str, np.ndarray], Optional[float]]:
    """A pandas DataFrame as a mapping role -> array, and fs from its time column or index when not given.

    Columns are roles (``fy``, ``fz``...) or are mapped with ``channels``
    (role -> column). A column named ``time``/``t`` (s), a numeric index or
    a DatetimeIndex gives fs = 1 / median step.
    """
    cols = {str(c): c for c in df.columns}
    from .base import one_role_per_channel

    out: Dict[str, np.ndarray] = {}
    mapping = dict(channels or {})
    one_role_per_channel(mapping, "channels")
    for role, col in mapping.items():
        if col not in cols:
            raise ValueError(f"channels: no column {col!r} in the DataFrame (columns: {', '.join(cols)})")
        out[role] = np.asarray(df[cols[col]], dtype=float)
    for name, col in cols.items():
        if name in ("fx", "fy", "fz", "i", "u", "cof", "x", "v") and name not in out and name not in mapping.values():
            out[name] = np.asarray(df[col], dtype=float)
    if fs is None:
        t: Optional[np.ndarray] = None
        for name in ("time", "t", "Time", "time_s"):
            if name in cols:
                t = np.asarray(df[cols[name]], dtype=float)
                break
        if t is None:
            idx = df.index
            if hasattr(idx, "asi8") and str(getattr(idx, "dtype", "")).startswith("datetime64"):
                t = np.asarray(idx.asi8, dtype=float) * 1e-9
            elif np.issubdtype(np.asarray(idx).dtype, np.number) and not _is_range(idx):
                t = np.asarray(idx, dtype=float)
        if t is not None and t.size > 1:
            d = np.diff(t)
            d = d[np.isfinite(d) & (d > 0)]
            if d.size:
                fs = float(f"{1.0 / float(np.median(d)):.9g}")
    return out, fs


def _is_range(idx: Any) -> bool:
    return type(idx).__name__ == "RangeIndex"
