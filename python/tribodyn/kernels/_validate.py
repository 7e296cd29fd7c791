"""Input checks shared by every entry point.

Each function converts a user argument to what the kernels need (C-contiguous
float64) or raises a ``TypeError``/``ValueError`` whose message names the
argument. Nothing here copies an array that is already contiguous float64.
"""

from __future__ import annotations

import numbers
from typing import Any, Tuple, Union

import numpy as np

from .. import _core

__all__ = [
    "Orientation",
    "resolve_orientation",
    "check_gate",
    "as_signal",
    "check_1d",
    "as_channels",
    "positive",
    "check_fs",
    "check_int",
    "check_bins",
    "MAX_BINS",
    "MIN_BIN_SAMPLES",
]


def _as_float_array(x: Any, name: str) -> np.ndarray:
    try:
        a = np.asarray(x)
    except Exception as exc:  # ragged lists and the like
        raise TypeError(f"{name} must be array-like of numbers: {exc}") from None
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {a.dtype}")
    # Not np.ascontiguousarray: it turns a scalar into shape (1,), which would
    # slip past the callers' ndim checks. A valid but unaligned float64 array
    # (a view at an odd byte offset of a buffer) is copied: the kernels read
    # aligned f64 only.
    out = np.asarray(a, dtype=np.float64, order="C")
    return out if out.flags.aligned else out.copy()


def _check_finite(a: np.ndarray, name: str) -> None:
    # The Rust check reads the array once, in parallel when long, instead of
    # building the boolean mask of np.isfinite (which costs as much as a
    # kernel for a multi-hour record).
    ok = _core.all_finite(a) if a.dtype == np.float64 and a.flags.c_contiguous else np.isfinite(a).all()
    if not ok:
        raise ValueError(finite_error(name))


def finite_error(name: str) -> str:
    """The message of the ValueError for a NaN or inf in argument ``name``."""
    return f"{name} contains NaN or inf (pass check_finite=False to allow)"


def check_1d(shape: Tuple[int, ...], name: str) -> None:
    """Raises the ``ValueError`` of an argument ``name`` of ``shape`` that is not 1-D."""
    if len(shape) != 1:
        raise ValueError(f"{name} must be 1-D, got {len(shape)}-D with shape {shape}")


def as_signal(x: Any, name: str, *, min_len: int = 1, check_finite: bool = True) -> np.ndarray:
    """Returns ``x`` as a 1-D C-contiguous float64 array of at least ``min_len`` samples."""
    a = _as_float_array(x, name)
    check_1d(a.shape, name)
    if a.size < min_len:
        raise ValueError(f"{name} needs at least {min_len} samples, got {a.size}")
    if check_finite:
        _check_finite(a, name)
    return a


def as_channels(x: Any, name: str, *, check_finite: bool = True) -> np.ndarray:
    """Returns ``x`` as a 1-D or 2-D (channels, samples) C-contiguous float64 array."""
    a = _as_float_array(x, name)
    if a.ndim not in (1, 2):
        raise ValueError(f"{name} must be 1-D or 2-D (channels, samples), got shape {a.shape}")
    if check_finite:
        _check_finite(a, name)
    return a


def same_length(**arrays: np.ndarray) -> int:
    """Checks that all arrays have equal length; returns it."""
    lengths = {k: len(v) for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{k} has {n}" for k, n in lengths.items())
        raise ValueError(f"inputs must have equal lengths: {listed}")
    return next(iter(lengths.values()), 0)


def positive(value: Any, name: str) -> float:
    """A finite number > 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def check_fs(fs: Any) -> float:
    """The sampling rate in Hz: finite and > 0."""
    return positive(fs, "fs")


def check_int(value: Any, name: str, *, minimum: int) -> int:
    """An integer >= ``minimum`` (bools refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    v = int(value)
    if v < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {v}")
    return v


#: Most fz bins of a window (docs/method.md 4): Fig. 9 reads a COF per bin,
#: and the table holds windows x n_bins counts and COFs (16 bytes each).
MAX_BINS = 1024
#: Fewest samples a bin holds on average (docs/method.md 4): a bin's COF is a
#: mean of s fy / fz over its samples.
MIN_BIN_SAMPLES = 4
#: The paper's bin count (Fig. 9), allowed on any window.
DEFAULT_BINS = 16


def check_bins(value: Any, samples: int, name: str = "n_bins") -> int:
    """The fz bins of a window of ``samples`` samples (docs/method.md 4), checked before anything is allocated.

    At most ``max(DEFAULT_BINS, samples // MIN_BIN_SAMPLES)`` (about 4 samples
    per bin on average, or the paper's 16) and never more than
    :data:`MAX_BINS`; more bins leave most of them empty and cost memory and
    time per window for nothing.
    """
    nb = check_int(value, name, minimum=1)
    limit = min(MAX_BINS, max(DEFAULT_BINS, samples // MIN_BIN_SAMPLES))
    if nb > limit:
        raise ValueError(
            f"{name} must be at most {limit} for a window of {samples} samples (max({DEFAULT_BINS}, samples // "
            f"{MIN_BIN_SAMPLES}), at most {MAX_BINS}; docs/method.md 4), got {nb}"
        )
    return nb


Orientation = Union[int, str]


def resolve_orientation(orientation: Orientation, slope: float) -> int:
    """s in {+1, -1}: as given, or for "auto" the sign of ``slope`` (docs/method.md 0).

    "auto" with an undefined or zero slope gives +1.
    """
    if isinstance(orientation, str):
        if orientation != "auto":
            raise ValueError(f"orientation must be +1, -1 or 'auto', got {orientation!r}")
        return -1 if slope < 0 else 1
    if orientation in (1, -1) and not isinstance(orientation, bool):
        return int(orientation)
    raise ValueError(f"orientation must be +1, -1 or 'auto', got {orientation!r}")


def check_gate(gate: Any) -> float:
    """The paper's |C_yz(0)| threshold, in [0, 1] (docs/method.md 5)."""
    g = float(gate)
    if not 0 <= g <= 1:
        raise ValueError(f"gate must be in [0, 1], got {gate!r}")
    return g
