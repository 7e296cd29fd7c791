"""The validated settings of one analysis: :class:`Plan` (docs/method.md 3-6).

:func:`make_plan` checks every option of :func:`tribodyn.analyze` once and
returns a frozen :class:`Plan`; every route of the pipeline (and the
finishing step) takes the plan, never loose settings. Nothing in a plan
changes while a recording is read.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple, Union

from ._validate import check_fs, check_int, positive
from .columns import kernel_columns
from .covariates import TimeLog, as_log, constant_or_log
from .deadband import Deadband, DeadbandSpec, parse_deadband
from .identify import Orientation, check_gate
from .threads import resolve_threads

__all__ = ["Covariates", "Plan", "make_plan", "check_orientation"]


def check_orientation(orientation: Any) -> Union[int, str]:
    """+1, -1 or "auto" (docs/method.md 0); anything else is a ``ValueError``."""
    if isinstance(orientation, str):
        if orientation == "auto":
            return orientation
    elif not isinstance(orientation, bool) and orientation in (1, -1):
        return int(orientation)
    raise ValueError(f"orientation must be +1, -1 or 'auto', got {orientation!r}")


@dataclass(frozen=True)
class Covariates:
    """Where each window's temperature and current come from (docs/method.md 6).

    Attributes
    ----------
    temperature : (t_s, T_degC) or None
        Intermittent temperature log.
    current, voltage : (t_s, values) or None
        Current (A) or shunt voltage (V) logs; a constant is a flat log.
    shunt_ohm : float or None
        Shunt resistance R (i = u / R), needed with a voltage.
    area_mm2 : float or None
        Contact area: J = i / area_mm2 in A/mm^2.
    """

    temperature: Optional[TimeLog] = None
    current: Optional[TimeLog] = None
    voltage: Optional[TimeLog] = None
    shunt_ohm: Optional[float] = None
    area_mm2: Optional[float] = None


@dataclass(frozen=True)
class Plan:
    """Every setting of one analysis, checked (see :func:`tribodyn.analyze` for their meaning).

    Attributes
    ----------
    fs : float
        Sampling rate, Hz.
    window, hop : float
        Window length and start-to-start spacing, s.
    length, step : int
        The same in samples (window k is samples [k * step, k * step + length)).
    deadband : Deadband
    n_bins : int
    gate : float
        |C_yz(0)| threshold.
    orientation : +1, -1 or "auto"
    highpass : float or None
        Cut-off of the high-pass for raw forces, Hz.
    max_lag : int or None
        Per-window skew from the correlation function up to this lag.
    rpm, n_lamellas
        Rig data, recorded.
    covariates : Covariates
    threads : int
        Kernel threads of this call.
    chunk : int or None
        Samples per chunk read (None: the route's default).
    start, stop : int, int or None
        Sample range of a recording analysed.
    progress : bool
    """

    fs: float
    window: float
    hop: float
    length: int
    step: int
    deadband: Deadband
    n_bins: int
    gate: float
    orientation: Union[int, str]
    highpass: Optional[float]
    max_lag: Optional[int]
    rpm: Optional[float]
    n_lamellas: Optional[int]
    covariates: Covariates
    threads: int
    chunk: Optional[int]
    start: int
    stop: Optional[int]
    progress: bool

    @property
    def raw(self) -> bool:
        """True when the forces are raw (DC-coupled) and high-passed first."""
        return self.highpass is not None

    @property
    def kernel_columns(self) -> Tuple[str, ...]:
        """The statistics asked of the kernel per window (``tribodyn.columns``)."""
        return kernel_columns(self.raw)

    def params(self) -> Dict[str, Any]:
        """The settings for provenance (``Results.params``, ``summary.json``)."""
        cov = self.covariates
        return dict(
            fs=self.fs,
            window=self.window,
            hop=self.hop,
            window_samples=self.length,
            hop_samples=self.step,
            highpass=self.highpass,
            orientation=self.orientation,
            deadband=str(self.deadband),
            n_bins=self.n_bins,
            gate=self.gate,
            max_lag=self.max_lag,
            rpm=self.rpm,
            n_lamellas=self.n_lamellas,
            area_mm2=cov.area_mm2,
            shunt_ohm=cov.shunt_ohm,
            chunk_samples=self.chunk,
            temperature_log_points=None if cov.temperature is None else int(cov.temperature[0].size),
        )


def make_plan(
    *,
    fs: Any,
    window: Any = 2.0,
    hop: Any = 10.0,
    highpass: Any = None,
    orientation: Orientation = "auto",
    temperature: Any = None,
    current: Any = None,
    voltage: Any = None,
    shunt_ohm: Any = None,
    area_mm2: Any = None,
    chunk: Any = None,
    progress: bool = False,
    deadband: DeadbandSpec = 0.35,
    n_bins: Any = 16,
    gate: Any = 0.85,
    max_lag: Any = None,
    rpm: Any = None,
    n_lamellas: Any = None,
    threads: Any = None,
    start: Any = 0,
    stop: Any = None,
) -> Plan:
    """Checks the options of :func:`tribodyn.analyze` into a :class:`Plan`.

    Raises
    ------
    ValueError, TypeError
        The first bad option, named.
    """
    fs_v = check_fs(fs)
    w_s = positive(window, "window")
    h_s = positive(hop, "hop")
    length = int(round(w_s * fs_v))
    step = int(round(h_s * fs_v))
    if length < 3:
        raise ValueError(f"window = {window} s is under 3 samples at fs = {fs_v:g} Hz")
    if step < 1:
        raise ValueError(f"hop = {hop} s is under one sample at fs = {fs_v:g} Hz")
    if voltage is not None or shunt_ohm is not None:
        if shunt_ohm is None:
            raise ValueError("voltage needs shunt_ohm (i = u / R)")
        shunt: Optional[float] = positive(shunt_ohm, "shunt_ohm")
    else:
        shunt = None
    cov = Covariates(
        temperature=None if temperature is None else as_log(temperature, "temperature"),
        current=constant_or_log(current, "current"),
        voltage=constant_or_log(voltage, "voltage"),
        shunt_ohm=shunt,
        area_mm2=None if area_mm2 is None else positive(area_mm2, "area_mm2"),
    )
    origin = check_int(start, "start", minimum=0)
    end = None if stop is None else check_int(stop, "stop", minimum=0)
    if end is not None and end < origin:
        raise ValueError(f"stop must satisfy start <= stop, got start={origin}, stop={end}")
    return Plan(
        fs=fs_v,
        window=w_s,
        hop=h_s,
        length=length,
        step=step,
        deadband=parse_deadband(deadband),
        n_bins=check_int(n_bins, "n_bins", minimum=1),
        gate=check_gate(gate),
        orientation=check_orientation(orientation),
        highpass=None if highpass is None else positive(highpass, "highpass"),
        max_lag=None if max_lag is None else check_int(max_lag, "max_lag", minimum=0),
        rpm=rpm,
        n_lamellas=n_lamellas,
        covariates=cov,
        threads=resolve_threads(threads),
        chunk=None if chunk is None else max(1, int(round(positive(chunk, "chunk") * fs_v))),
        start=origin,
        stop=end,
        progress=bool(progress),
    )
