"""Stick-slip of a recording, the public function (docs/method.md 6g).

The search itself (its events, noise floor and verdict) is :mod:`tribodyn.pipeline.stickslip`, which the
analysis also runs in its own reading (``analyze(stick_slip=True)``); this module adds the analysis of
a source not yet analysed.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional

from ..pipeline.analyze import analyze
from ..pipeline.stickslip import DROP_SAMPLES, K_SIGMA, StickSlip, find_stick_slip

__all__ = ["StickSlip", "stick_slip"]


def stick_slip(
    source: Any,
    res: Any = None,
    *,
    fs: Optional[float] = None,
    k: float = K_SIGMA,
    drop_samples: int = DROP_SAMPLES,
    fraction: Optional[float] = None,
    open_options: Optional[Mapping[str, Any]] = None,
) -> StickSlip:
    """Stick-slip events of a recording: rises of the friction force while the contact sticks, each ended by
    a drop as it slips, within a sample or over many (docs/method.md 6g).

    Parameters
    ----------
    source : mapping, list of acquisitions, Recording or path
        The data given to :func:`tribodyn.analyze` (fy and fz are read again, in blocks).
    res : Results, optional
        Its analysis (tare, ``min_fn``, strokes); None: ``tribodyn.analyze(source, fs=fs)`` first. An
        analysis made with ``stick_slip=True`` holds the result already (``res.stick_slip``, found in the
        analysis' own reading): with the default ``k``, ``drop_samples`` and ``fraction`` it is returned
        as it is, nothing read.
    fs : float, optional
        Sampling rate, only when ``res`` is None and the source does not carry it.
    k : float
        A drop counts when it exceeds k noise SDs (default 5).
    drop_samples : int
        The gap (samples) of the drop statistic whose spread gives the
        coloured noise (default 3). A drop itself may take up to 0.2 of the
        stick before it and 0.25 s, or lie within one sample interval.
    fraction : float, optional
        Reciprocating: the central part of each stroke searched (default the analysis' ``stroke_fraction``).
    open_options : mapping, optional
        ``open_recording`` options for a path.

    Returns
    -------
    StickSlip
        ``present`` with at least 3 events whose sticks fill 5 % of the time searched; ``verdict`` is its
        one line. Forces without their static
        level (high-passed) are not assessed (``events`` 0, NaN amounts, the verdict says why).
    """
    if res is None:
        res = analyze(source, fs=fs)
    return find_stick_slip(source, res, k=k, drop_samples=drop_samples, fraction=fraction, open_options=open_options)
