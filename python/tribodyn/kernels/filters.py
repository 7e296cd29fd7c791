"""Streaming high-pass filter (docs/method.md section 2).

The design is a Butterworth high-pass as second-order sections, identical to
``scipy.signal.butter(order, cutoff, "highpass", fs=fs, output="sos")``
(default order 1, like the charge amplifier's RC stage, at 0.1 Hz). The
filtering is the transposed-direct-form-II recurrence of
``scipy.signal.sosfilt``, run by the Rust kernel with several channels in
lockstep. Processing a signal in chunks of any sizes, carrying the state,
gives bitwise the same output as one call on the whole signal.
"""

from __future__ import annotations

from typing import Any, Literal, Optional

import numpy as np

from .. import _core
from ._compat import positional_options
from ._validate import as_channels, check_fs, check_int, finite_error, positive
from .threads import resolve_threads

__all__ = ["HighPass", "highpass", "butter_highpass"]

Init = Literal["steady", "zero"]


#: Highest Butterworth order :func:`butter_highpass` designs (the paper's
#: amplifier is order 1; beyond a few dozen the design is numerically void).
MAX_ORDER = 32
#: Most channels one :class:`HighPass` filters together.
MAX_CHANNELS = 4096


def butter_highpass(fs: float, *, cutoff: float = 0.1, order: int = 1) -> np.ndarray:
    """Butterworth high-pass as SOS, exactly ``scipy.signal.butter(..., output="sos")``.

    Raises ``ValueError`` for fs <= 0, cutoff outside (0, fs/2) or order < 1.
    """
    fs_v = check_fs(fs)
    fc = positive(cutoff, "cutoff")
    if not fc < fs_v / 2:
        raise ValueError(f"cutoff must be in (0, fs/2) = (0, {fs_v / 2:g}) Hz, got {cutoff!r}")
    n = check_int(order, "order", minimum=1)
    if n > MAX_ORDER:
        raise ValueError(f"order must be in [1, {MAX_ORDER}], got {n}")
    from scipy import signal as _signal  # lazy: scipy.signal takes ~0.5 s to import

    return np.ascontiguousarray(_signal.butter(n, fc, "highpass", fs=fs_v, output="sos"), dtype=np.float64)


def _check_sos(sos: Any) -> np.ndarray:
    # A complex array would otherwise lose its imaginary part with only a warning.
    if np.asarray(sos).dtype.kind == "c":
        raise TypeError("sos must be a real (n_sections, 6) array, got complex")
    try:
        s = np.array(sos, dtype=np.float64, order="C", ndmin=2)
    except (TypeError, ValueError):
        raise TypeError("sos must be a real (n_sections, 6) array") from None
    if s.ndim != 2 or s.shape[1] != 6 or s.shape[0] < 1:
        raise ValueError(f"sos must have shape (n_sections, 6), got {s.shape}")
    if s.shape[0] > MAX_ORDER:
        raise ValueError(f"sos may have at most {MAX_ORDER} sections, got {s.shape[0]}")
    if not np.isfinite(s).all():
        raise ValueError("sos contains NaN or inf")
    if not np.all(s[:, 3] == 1.0):
        raise ValueError("sos must have a0 = 1 in every section (column 3), as scipy.signal.sosfilt requires")
    return s


def _precheck(x: np.ndarray, check_finite: bool) -> None:
    """Reports a NaN/inf before a shape error, as the other entry points do."""
    if check_finite:
        as_channels(x, "chunk", check_finite=True)


class HighPass:
    """A streaming SOS high-pass filter for one or more channels.

    Parameters
    ----------
    fs : float
        Sampling rate in Hz.
    cutoff : float
        Cut-off frequency in Hz, in (0, fs/2). Default 0.1 Hz (the paper's
        charge amplifier).
    order : int
        Butterworth order (default 1, an RC stage).
    sos : array_like (n_sections, 6), optional
        Any other SOS filter instead of the Butterworth design (a0 = 1).
    channels : int
        Number of channels filtered together.
    init : {"steady", "zero"}
        "steady" (default) starts each channel in the steady state for a
        constant input equal to its first sample (``sosfilt_zi(sos) * x[0]``),
        removing the start-up transient of a DC-coupled signal; "zero" starts
        at rest.
    threads : int, optional
        Kernel threads for this filter's calls (default: the process
        default, see :func:`tribodyn.set_threads`); never changes the output.

    Examples
    --------
    >>> hp = HighPass(1000.0, channels=3)
    >>> for chunk in chunks:            # (3, m) arrays
    ...     out = hp.process(chunk)     # same as one call on the whole signal
    """

    def __init__(
        self,
        fs: float,
        *,
        cutoff: float = 0.1,
        order: int = 1,
        sos: Optional[Any] = None,
        channels: int = 1,
        init: Init = "steady",
        threads: Optional[int] = None,
    ) -> None:
        self.fs = check_fs(fs)
        self.threads = None if threads is None else resolve_threads(threads)
        self.sos = butter_highpass(self.fs, cutoff=cutoff, order=order) if sos is None else _check_sos(sos)
        self.channels = check_int(channels, "channels", minimum=1)
        if self.channels > MAX_CHANNELS:
            raise ValueError(f"channels must be in [1, {MAX_CHANNELS}], got {self.channels}")
        if init not in ("steady", "zero"):
            raise ValueError(f"init must be 'steady' or 'zero', got {init!r}")
        self.init: Init = init
        # The steady state only exists without a pole at z = 1; "zero" needs none.
        self._zi = np.zeros((self.n_sections, 2))
        if init == "steady":
            try:
                from scipy import signal as _signal

                self._zi = np.ascontiguousarray(_signal.sosfilt_zi(self.sos), dtype=np.float64)
            except np.linalg.LinAlgError:
                raise ValueError("sos has a pole at z = 1: no steady state exists (use init='zero')") from None
        self.reset()

    @property
    def n_sections(self) -> int:
        return int(self.sos.shape[0])

    @property
    def steady_state(self) -> np.ndarray:
        """Per-section state for a constant unit input, shape (n_sections, 2) (zeros with ``init="zero"``).

        A channel starts in ``steady_state * x[0]`` (a copy).
        """
        return self._zi.copy()

    @property
    def state(self) -> np.ndarray:
        """Filter state, shape (channels, n_sections, 2) (a copy).

        With ``init="steady"``, before the first non-empty chunk the state is
        not yet fixed and reads as zeros; setting it fixes it.
        """
        return self._state.copy()

    @state.setter
    def state(self, value: Any) -> None:
        s = np.array(value, dtype=np.float64, order="C")
        want = (self.channels, self.n_sections, 2)
        if s.shape != want:
            raise ValueError(f"state must have shape {want}, got {s.shape}")
        if not np.isfinite(s).all():
            raise ValueError("state contains NaN or inf")
        self._state = s
        self._started = True

    def reset(self) -> None:
        """Back to the initial state (the next chunk starts a new signal)."""
        self._state = np.zeros((self.channels, self.n_sections, 2))
        self._started = self.init == "zero"

    def process(self, chunk: Any, *, check_finite: bool = True) -> np.ndarray:
        """Filters the next chunk and returns it (a new float64 array).

        ``chunk`` is 1-D for a one-channel filter, or (channels, m). Chunks of
        any length (0 included) may follow each other.
        """
        # The kernel checks finiteness while it copies the input (no extra
        # pass over a long record); shape errors still see the check first.
        x = as_channels(chunk, "chunk", check_finite=False)
        one_d = x.ndim == 1
        if one_d:
            if self.channels != 1:
                _precheck(x, check_finite)
                raise ValueError(
                    f"chunk must have shape ({self.channels}, m) for a {self.channels}-channel filter, got 1-D"
                )
            x = x[np.newaxis, :]
        elif x.shape[0] != self.channels:
            _precheck(x, check_finite)
            raise ValueError(f"chunk has {x.shape[0]} channels, the filter {self.channels}")
        if x.shape[1] == 0:
            y = x.copy()
        else:
            # A new state, committed only if the chunk is accepted.
            if self._started:
                state = self._state.copy()
            else:
                state = np.ascontiguousarray(self._zi[np.newaxis, :, :] * x[:, 0, np.newaxis, np.newaxis])
            y = np.empty_like(x)
            finite = _core.sosfilt_into(self.sos, x, y, state, threads=self.threads)
            if check_finite and not finite:
                raise ValueError(finite_error("chunk"))
            self._state = state
            self._started = True
        return y[0] if one_d else y


def highpass(
    x: Any,
    *args: Any,
    fs: Optional[float] = None,
    cutoff: float = 0.1,
    order: int = 1,
    axis: int = -1,
    init: Init = "steady",
    sos: Optional[Any] = None,
    check_finite: bool = True,
) -> np.ndarray:
    """One-shot high-pass of ``x`` along ``axis`` (docs/method.md 2).

    Every other axis is an independent channel. Same design, recurrence and
    initial state as :class:`HighPass`; equal to
    ``scipy.signal.sosfilt(sos, x, axis=axis, zi=...)`` to rounding (in fact
    bitwise, as the arithmetic is the same).

    ``fs`` is keyword-only; ``highpass(x, fs)`` still works with a
    DeprecationWarning.
    """
    if args:
        fs = positional_options("highpass", args, ("fs",), {"fs": fs})["fs"]
    if fs is None:
        raise TypeError("highpass() missing required keyword argument 'fs' (sampling rate, Hz)")
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"x must hold real numbers, got dtype {a.dtype}")
    if a.ndim < 1:
        raise ValueError("x must have at least one dimension")
    try:
        moved = np.moveaxis(a, axis, -1)
    except (ValueError, IndexError) as exc:  # numpy's AxisError is both
        raise ValueError(f"axis {axis} is out of range for x of shape {a.shape}") from exc
    # Not reshape(-1, m): with m = 0 the -1 would be ambiguous.
    flat = moved.reshape(int(np.prod(moved.shape[:-1])), moved.shape[-1])
    hp = HighPass(fs, cutoff=cutoff, order=order, sos=sos, channels=max(flat.shape[0], 1), init=init)
    if flat.shape[0] == 0:
        return np.zeros(a.shape)
    y = hp.process(flat, check_finite=check_finite)
    return np.moveaxis(y.reshape(moved.shape), -1, axis)
