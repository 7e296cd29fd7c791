"""The validated settings of one analysis: :class:`Plan` (docs/method.md 3-6).

:func:`make_plan` checks every option of :func:`tribodyn.analyze` once and
returns a frozen :class:`Plan`; every route of the pipeline (and the
finishing step) takes the plan, never loose settings. Nothing in a plan
changes while a recording is read.

An option valid on its own names its rule in its declaration
(``tribodyn.options.Option.check``, a key of :data:`CHECKS`), which
``make_plan`` applies from ``OPTIONS``; the others are checked together
with the options they depend on, as :data:`JOINT` says.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Callable, Dict, Mapping, Optional, Tuple, Union

import numpy as np

from ..columns import kernel_columns
from ..kernels._validate import check_bins, check_fs, check_gate, check_int, positive
from ..kernels.deadband import Deadband, parse_deadband
from ..kernels.threads import resolve_threads
from ..kernels.uncertainty import Inputs, parse_inputs
from ..options import TARE_MODES
from .covariates import TimeLog, as_log, constant_or_log

if TYPE_CHECKING:
    from ..options import Option

__all__ = [
    "CHECKS",
    "JOINT",
    "RECORDED",
    "PLAN_FIELDS",
    "Covariates",
    "Findings",
    "Plan",
    "make_plan",
    "check_options",
    "check_orientation",
    "check_covariate_logs",
    "checked",
]


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
    logs : tuple of (name, (t_s, values))
        Other covariate logs by name (``analyze(covariates=...)``), each
        interpolated at the window centres into the table: ``speed`` (m/s)
        into the declared column, any other name into a column of its own
        after the declared ones (docs/method.md 7a).
    """

    temperature: Optional[TimeLog] = None
    current: Optional[TimeLog] = None
    voltage: Optional[TimeLog] = None
    shunt_ohm: Optional[float] = None
    area_mm2: Optional[float] = None
    logs: Tuple[Tuple[str, TimeLog], ...] = ()


#: Names a covariate log may not take: the options that have their own meaning (docs/method.md 7a).
_OWN_OPTION = {"temperature": "temperature=", "current": "current=", "voltage": "voltage="}
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def check_covariate_logs(covariates: Any) -> Tuple[Tuple[str, TimeLog], ...]:
    """``analyze(covariates=...)`` checked: a mapping of name -> (t_s, values) log or constant (docs/method.md 7a).

    A name is an identifier that is not a column of the table (``speed``
    excepted: its log fills that column) nor ``temperature``, ``current`` or
    ``voltage`` (their options interpolate, branch and check their logs).
    """
    from ..columns import UNITS

    if covariates is None:
        return ()
    if not isinstance(covariates, Mapping):
        raise TypeError(f"covariates must be a mapping of name -> (t_s, values), got {type(covariates).__name__}")
    out = []
    for name, log in covariates.items():
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"covariates: a name must be an identifier (letters, digits, _), got {name!r}")
        if name in _OWN_OPTION:
            raise ValueError(f"covariates: give the {name} log as {_OWN_OPTION[name]} (it has its own treatment)")
        if name in UNITS and name != "speed":
            raise ValueError(f"covariates: {name!r} is a column of the table; name the log otherwise")
        found = constant_or_log(log, f"covariates[{name!r}]")
        if found is None:
            raise ValueError(f"covariates[{name!r}] is None: give a (t_s, values) log or a number")
        out.append((name, found))
    return tuple(out)


@dataclass(frozen=True)
class Plan:
    """Every setting of one analysis, checked once (docs/architecture.md; the options: :mod:`tribodyn.options`).

    Made by :func:`make_plan` (``td.make_plan(fs=1000, window=2, ...)``),
    with the options of :func:`tribodyn.analyze`, and frozen: nothing in a
    plan changes while a recording is read. ``analyze(source, plan)`` runs
    it on a source recorded at ``plan.fs``; what the pre-pass and the
    alignment find in the data goes in :class:`Findings`, never into the plan.

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
    gate : float or "ci"
        |C_yz(0)| threshold, or the gate on the interval's width.
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
    chunk, chunk_samples : float or None, int or None
        Seconds, and samples, per chunk read (None: the route's default).
    start, stop : int, int or None
        Sample range of a recording analysed.
    progress : bool
    motion : {"auto", "unidirectional", "reciprocating"}
    min_fn : float or None
        Classical COF: least |fz| in contact, N (None: from the data).
    tare : float, mapping or None
        Classical COF: seconds without contact at the start, or offsets.
    stroke_fraction : float
        Central part of each stroke of a reciprocating test.
    window_note : str
        What was chosen from the rate for window and hop ('' when nothing).
    stick_slip : bool
        Also find the stick-slip events in the same reading (docs/method.md 6g).
    uncertainty : uncertainty.Inputs or None
        What is known of the instrument: the headline's budget (docs/method.md 6i).
    """

    fs: float
    window: float
    hop: float
    length: int
    step: int
    deadband: Deadband
    n_bins: int
    gate: Union[float, str]
    orientation: Union[int, str]
    highpass: Optional[float]
    max_lag: Optional[int]
    rpm: Optional[float]
    n_lamellas: Optional[int]
    covariates: Covariates
    threads: int
    chunk: Optional[float]
    start: int
    stop: Optional[int]
    progress: bool
    #: "paper" or "" (docs/method.md 3a): the paper's preset fixes estimator, gate and alignment.
    method: str = ""
    #: Slope estimator (docs/method.md 3a-3c): "corrected", "iv", "ols" or "deming".
    estimator: str = "ols"
    #: Largest expected half-width of the 95 % interval, relative to the recording's COF, for gate "ci".
    max_rel_ci: float = 0.1
    #: "auto" (estimate and correct the fz delay) or None.
    align: Optional[str] = None
    #: Instrument lag, s (docs/method.md 3b): the one given, one revolution with ``rpm``, else a tenth of the
    #: window; with ``iv_lag_from_data`` the fallback when the data name none (``Findings.iv_lag_samples``).
    iv_lag: Optional[float] = None
    #: ``iv_lag`` in samples (the kernel's lag); 0 with ``method="paper"``.
    iv_lag_samples: int = 0
    #: True when neither ``iv_lag`` nor ``rpm`` was given: the lag is chosen from the data (docs/method.md 3b).
    iv_lag_from_data: bool = False
    #: Line frequencies (cycles per sample) and the index of f0, f_l among them.
    lines: Tuple[float, ...] = ()
    line_index: Tuple[Tuple[str, int], ...] = ()
    #: (sigma_y, sigma_z) of the measurement noise, N, or None.
    noise: Optional[Tuple[float, float]] = None
    #: "auto", "unidirectional" or "reciprocating" (docs/method.md 6c).
    motion: str = "auto"
    #: Classical COF: least |fz| in contact, N; None: from the data (docs/method.md 6a).
    min_fn: Optional[float] = None
    #: Classical COF: seconds without contact at the start, or offsets {"fy": N, "fz": N}; None: from the data.
    tare: Any = None
    #: Central part of each stroke used for its COF (docs/method.md 6c).
    stroke_fraction: float = 0.5
    #: What was chosen from the rate for window and hop (docs/method.md 6b), '' when nothing was.
    window_note: str = ""
    #: Also find the stick-slip events, in the analysis' own reading (docs/method.md 6g).
    stick_slip: bool = False
    #: ``chunk`` in samples (None: the route's default).
    chunk_samples: Optional[int] = None
    #: What is known of the instrument, for the headline's uncertainty budget (docs/method.md 6i), or None.
    uncertainty: Optional["Inputs"] = None
    #: Whether ``threads`` was asked for (False: the default count of the process that made the plan), so that a
    #: task on a Dask worker takes its share of its host instead (docs/method.md 9); not recorded in ``params``.
    threads_asked: bool = True

    @property
    def paper(self) -> bool:
        """True for the paper's preset (``method="paper"``): its statistics only, exactly as before."""
        return self.method == "paper"

    def kernel_options(self, found: "Findings") -> Dict[str, Any]:
        """The options of the statistics beyond the paper for ``_core.windows_stats`` (docs/method.md 3a-3e)."""
        out: Dict[str, Any] = {}
        if found.classical is not None:
            c = found.classical
            out["classical"] = (float(c.min_fn), float(c.tare_fy), float(c.tare_fz))
        if self.paper:
            return out
        out.update(lag=self.lag(found), lines=list(self.lines) or None, segments=LINE_SEGMENTS, delay=found.delay)
        if self.extra_lags(found):
            out["lags"] = list(self.extra_lags(found))
        return out

    def extra_lags(self, found: "Findings") -> Tuple[int, ...]:
        """The other admissible lags whose instrument sums the kernel adds per window (column ``lag_sums``;
        docs/method.md 3d): ``found.iv_lag_others`` when mu_r rests on the lag chosen from the data (the IV
        estimator, or "corrected" with the fz noise measured), else none (nothing to pay)."""
        uses = self.estimator == "iv" or (self.estimator == "corrected" and self.noise is None)
        if self.paper or not self.iv_lag_from_data or not found.iv_lag_samples or not uses:
            return ()
        return tuple(int(k) for k in found.iv_lag_others)

    def lag(self, found: "Findings") -> int:
        """The instrument lag of the analysis (samples): the data's choice when the plan leaves it to them."""
        return int(found.iv_lag_samples) if self.iv_lag_from_data and found.iv_lag_samples else self.iv_lag_samples

    @property
    def raw(self) -> bool:
        """True when the forces are raw (DC-coupled) and high-passed first."""
        return self.highpass is not None

    def kernel_columns(self, found: "Findings") -> Tuple[str, ...]:
        """The statistics asked of the kernel per window (``tribodyn.columns``)."""
        extra: Tuple[str, ...] = () if self.paper else ("szz", "syy", "ext") + (("spec",) if self.lines else ())
        extra += ("lag_sums",) if self.extra_lags(found) else ()
        if found.classical is not None:
            extra += ("mu_classical", "mu_classical_median", "fz_mean", "fz_std")
        return kernel_columns(self.raw) + extra

    def params(self) -> Dict[str, Any]:
        """The settings for provenance (``Results.params``, ``summary.json``).

        Each field under its own name and as it is, but those :data:`RECORDED`
        records otherwise (in samples, as text, the logs' lengths) or not at
        all: ``motion`` and ``min_fn`` are recorded as the pre-pass resolved
        them (``Results.params["motion"]``, ``["min_fn"]``; docs/method.md 6a,
        6c). A new field is recorded as it is, with nothing to add here.
        """
        out: Dict[str, Any] = {}
        for f in dataclasses.fields(self):
            if f.name not in RECORDED:
                out[f.name] = getattr(self, f.name)
                continue
            how = RECORDED[f.name]
            if how is not None:
                out.update(how(self))
        return out


def _covariate_params(plan: Plan) -> Dict[str, Any]:
    """``Plan.covariates`` for provenance: the constants, and each log's number of points."""
    cov = plan.covariates

    def points(log: Optional[TimeLog]) -> Optional[int]:
        return None if log is None else int(log[0].size)

    return dict(area_mm2=cov.area_mm2, shunt_ohm=cov.shunt_ohm, temperature_log_points=points(cov.temperature),
                covariate_logs={k: int(v[0].size) for k, v in cov.logs} or None,
                current_log_points=points(cov.current), voltage_log_points=points(cov.voltage))  # fmt: skip


#: How :meth:`Plan.params` records the fields it does not record as they are, under their own names: a function
#: of the plan giving the entries, or None for a field not recorded there (the line frequencies, and what the
#: pre-pass or the window's choice records itself: ``motion``, ``min_fn``, ``window_note``).
RECORDED: Mapping[str, Optional[Callable[[Plan], Dict[str, Any]]]] = MappingProxyType({
    "length": lambda p: {"window_samples": p.length},
    "step": lambda p: {"hop_samples": p.step},
    "deadband": lambda p: {"deadband": str(p.deadband)},
    "covariates": _covariate_params,
    "chunk": lambda p: {"chunk_samples": p.chunk_samples},
    "method": lambda p: {"method": p.method or None},
    "max_rel_ci": lambda p: {"max_rel_ci": p.max_rel_ci if p.gate == "ci" else None},
    "iv_lag": lambda p: {"iv_lag_samples": None if p.paper else p.iv_lag_samples},
    "tare": lambda p: {"tare": dict(p.tare) if isinstance(p.tare, Mapping) else p.tare},
    "uncertainty": lambda p: {"uncertainty": None if p.uncertainty is None else p.uncertainty.to_dict()},
    **dict.fromkeys(("iv_lag_from_data", "lines", "line_index", "motion", "min_fn", "window_note", "chunk_samples",
                     "iv_lag_samples", "threads_asked")),
})  # fmt: skip

#: The fields of a :class:`Plan`.
PLAN_FIELDS = frozenset(f.name for f in dataclasses.fields(Plan))
#: The options checked by their own rule (``Option.check``) that a :class:`Plan` holds otherwise than as checked.
_CONVERTED = frozenset({"covariates"})


def make_plan(*, fs: Any, **options: Any) -> Plan:
    """Checks the options of :func:`tribodyn.analyze` into a :class:`Plan` (``td.make_plan``).

    ``fs`` is the sampling rate in Hz; ``options`` are any of
    :data:`tribodyn.options.OPTIONS` of kind "plan" or "log" (defaults:
    theirs). Not given, window and hop are chosen from the rate
    (docs/method.md 6b; ``Plan.window_note`` says what was chosen).

    Raises
    ------
    ValueError, TypeError
        An unknown option, or the first bad one, named.
    """
    from ..options import OPTIONS

    known = {o.name: o for o in OPTIONS if o.kind != "source"}
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise TypeError(f"unknown option(s) {', '.join(map(repr, unknown))}; the options are {', '.join(known)}")
    o = {name: options.get(name, opt.default) for name, opt in known.items()}
    return _make_plan(fs, o)


def check_options(**options: Any) -> None:
    """The options of :func:`tribodyn.analyze` checked as far as :func:`make_plan` checks them without a
    recording's rate, with its messages: each option by its own rule (``Option.check``), ``window`` and ``hop``
    finite and > 0, ``n_bins`` at least 1, and the statistical options (``gate``, ``max_rel_ci``, ``iv_lag``,
    ``estimator``, ``method``, ``noise``, ...) as :func:`check_statistics` checks them at any rate. None (a
    default) and names that are no option pass.

    For many recordings (:func:`tribodyn.analyze_many`, ``tribodyn analyze``), once before any is read: an
    option bad for every recording is one error, not one failure per recording.
    """
    from ..options import OPTIONS

    rules = {o.name: o for o in OPTIONS if o.check}
    for name, value in options.items():
        if value is None:
            continue
        if name in rules:
            checked(rules[name], value)
        elif name in ("window", "hop"):
            positive(value, name)
        elif name == "n_bins":
            check_int(value, name, minimum=1)
    stats = {name: options[name] for name in _STATISTICS if options.get(name) is not None}
    if stats:  # (at a stand-in rate: what they refuse there they refuse at a recording's; gate=2 failed each one)
        check_statistics(_ANY_FS, _ANY_LENGTH, **stats)


#: The stand-in rate (Hz) and window (samples) at which :func:`check_options` checks the statistical options: only
#: the instrument lag and the rig's lines depend on them, and neither refuses a value at this rate that a
#: recording's rate (up to a MHz) takes.
_ANY_FS = 1.0e6
_ANY_LENGTH = 1000


def _make_plan(fs: Any, o: Dict[str, Any]) -> Plan:
    """:func:`make_plan` with every option present (``o``)."""
    from ..options import OPTIONS, option
    from .prepass import auto_window

    fs_v = checked(option("fs"), fs)
    window, hop, window_note = auto_window(fs_v, o["window"], o["hop"])
    w_s = positive(window, "window")
    h_s = positive(hop, "hop")
    length = int(round(w_s * fs_v))
    step = int(round(h_s * fs_v))
    if length < 3:
        raise ValueError(f"window = {window} s is under 3 samples at fs = {fs_v:g} Hz")
    if step < 1:
        raise ValueError(f"hop = {hop} s is under one sample at fs = {fs_v:g} Hz")
    if o["voltage"] is not None and o["shunt_ohm"] is None:
        raise ValueError("voltage needs shunt_ohm (i = u / R)")
    # Each option valid on its own, by the rule it declares (in the order of OPTIONS); then those checked jointly.
    c = {opt.name: checked(opt, o[opt.name]) for opt in OPTIONS if opt.check and opt.name in o}
    cov = Covariates(temperature=c["temperature"], current=c["current"], voltage=c["voltage"],
                     shunt_ohm=c["shunt_ohm"], area_mm2=c["area_mm2"], logs=c["covariates"])  # fmt: skip
    if c["stop"] is not None and c["stop"] < c["start"]:
        raise ValueError(f"stop must satisfy start <= stop, got start={c['start']}, stop={c['stop']}")
    stats = check_statistics(
        fs_v, length, method=o["method"], estimator=o["estimator"], gate=o["gate"], max_rel_ci=o["max_rel_ci"],
        align=o["align"], iv_lag=o["iv_lag"], noise=o["noise"], rpm=o["rpm"], n_lamellas=o["n_lamellas"],
    )  # fmt: skip
    chunk = c["chunk"]
    # an option checked by its own rule that is a field of the plan goes into it as checked
    as_checked = {name: value for name, value in c.items() if name in PLAN_FIELDS and name not in _CONVERTED}
    return Plan(
        fs=fs_v,
        window=w_s,
        hop=h_s,
        length=length,
        step=step,
        n_bins=check_bins(o["n_bins"], length),
        covariates=cov,
        chunk_samples=None if chunk is None else max(1, int(round(chunk * fs_v))),
        window_note=window_note,
        threads_asked=o["threads"] is not None,
        **stats,
        **as_checked,
    )


# -- each option's own check (tribodyn.options.Option.check) -----------------------------------------------------


def checked(opt: "Option", value: Any) -> Any:
    """``value`` checked (and converted) by the rule ``opt`` declares (``opt.check``, a key of :data:`CHECKS`)."""
    return CHECKS[opt.check](value, opt)


def _positive_or_none(value: Any, opt: "Option") -> Optional[float]:
    return None if value is None else positive(value, opt.name)


def _count(value: Any, opt: "Option") -> int:
    return check_int(value, opt.name, minimum=0)


def _count_or_none(value: Any, opt: "Option") -> Optional[int]:
    return None if value is None else check_int(value, opt.name, minimum=0)


def _choice(value: Any, opt: "Option") -> Any:
    """One of ``opt.choices``; None is the default."""
    value = opt.default if value is None else value
    if value not in opt.choices:
        *first, last = map(repr, opt.choices)
        raise ValueError(f"{opt.name} must be {', '.join(first)} or {last}, got {value!r}")
    return value


def _min_fn(value: Any, opt: "Option") -> Optional[float]:
    """A force in N, finite and >= 0, or None (docs/method.md 6a)."""
    if value is None:
        return None
    try:
        fn = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{opt.name} must be a force in N, got {value!r}") from None
    if not (np.isfinite(fn) and fn >= 0) or isinstance(value, bool):
        raise ValueError(f"{opt.name} must be finite and >= 0, got {value!r}")
    return fn


_TARE_TYPES = "tare must be 'auto', 'start', 'none', seconds (a number) or a mapping {'fy': N, 'fz': N} of offsets"


def _tare(tare: Any, opt: "Option") -> Any:
    """Seconds >= 0 without contact at the start, a read-only mapping of offsets {"fy": N, "fz": N}, a mode
    ("start", "none"; "auto" is None), or None."""
    if tare is None:
        return None
    if isinstance(tare, str):
        mode = tare.strip().lower()
        if mode not in TARE_MODES:
            raise ValueError(f"tare must be one of {', '.join(TARE_MODES)}, seconds or fy=N,fz=N offsets, got {tare!r}")
        return None if mode == "auto" else mode
    if isinstance(tare, Mapping):
        bad = [
            k
            for k, v in tare.items()
            if k not in ("fy", "fz") or isinstance(v, bool) or not isinstance(v, (int, float))
        ]
        if bad:
            raise TypeError(_TARE_TYPES)
        return MappingProxyType({str(k): float(v) for k, v in tare.items()})
    if isinstance(tare, bool) or not isinstance(tare, (int, float)):
        raise TypeError(_TARE_TYPES)
    if not (np.isfinite(tare) and tare >= 0):
        raise ValueError(f"tare must be seconds >= 0, got {tare!r}")
    return float(tare)


def _fraction(value: Any, opt: "Option") -> float:
    """A number in (0, 1]; None is the default (docs/method.md 6c)."""
    try:
        frac = float(opt.default if value is None else value)
    except (TypeError, ValueError):
        raise TypeError(f"{opt.name} must be a number in (0, 1], got {value!r}") from None
    if not (0 < frac <= 1):
        raise ValueError(f"{opt.name} must be in (0, 1], got {value!r}")
    return frac


#: The rules an option may declare as its own check (``Option.check``): each takes the value and the option
#: and returns the value checked and converted, or raises the TypeError or ValueError that names the option.
CHECKS: Mapping[str, Callable[[Any, "Option"], Any]] = MappingProxyType({
    "sampling rate": lambda v, o: check_fs(v),
    "number > 0 or None": _positive_or_none,
    "integer >= 0": _count,
    "integer >= 0 or None": _count_or_none,
    "truth value": lambda v, o: bool(v),
    "choice": _choice,
    "orientation": lambda v, o: check_orientation(v),
    "deadband": lambda v, o: parse_deadband(v),
    "threads": lambda v, o: resolve_threads(v),
    "log or None": lambda v, o: None if v is None else as_log(v, o.name),
    "constant or log": lambda v, o: constant_or_log(v, o.name),
    "covariate logs": lambda v, o: check_covariate_logs(v),
    "force >= 0 or None": _min_fn,
    "tare": _tare,
    "fraction": _fraction,
    "uncertainty inputs": lambda v, o: parse_inputs(v),
})  # fmt: skip

_STATISTICS = ("method", "estimator", "gate", "max_rel_ci", "align", "iv_lag", "noise", "rpm", "n_lamellas")
#: The options without a rule of their own (``Option.check`` is ""), and where they are checked with the
#: options they depend on.
JOINT: Mapping[str, str] = MappingProxyType({
    "window": "make_plan: with hop and fs (tribometer.auto_window; at least 3 samples)",
    "hop": "make_plan: with window and fs (at least one sample)",
    "n_bins": "make_plan: against the window's length in samples (_validate.check_bins)",
    **dict.fromkeys(_STATISTICS, "check_statistics: the paper's preset (method='paper') fixes, refuses or ignores "
                                 "them; the instrument lag and the rig's lines need fs and rpm"),
    "channels": "where the source is opened (open_recording, a DataFrame's columns); make_plan does not take it",
    "load": "where the source is opened (io.constant.check_load: a finite force > 0 N, and no fz beside it)",
})  # fmt: skip


@dataclass(frozen=True)
class Findings:
    """What one analysis finds in the data before the windows: kept apart from its :class:`Plan`.

    Attributes
    ----------
    classical : ClassicalSpec or None
        The classical COF's contact threshold and tare offsets the pre-pass
        resolved (``tribodyn.pipeline.prepass.ClassicalSpec``; docs/method.md 6a), or None.
    delay : float
        Samples by which fz is advanced in every window (``align="auto"``'s
        measurement, docs/method.md 3e); 0 otherwise.
    iv_lag_samples : int or None
        The instrument lag chosen from the data (samples; docs/method.md 3b:
        the shortest lag past the noise's correlation time at which the
        instrument is strong), used when the plan leaves the lag to the data
        (``Plan.iv_lag_from_data``); None when none was found or looked for.
    iv_lag_shifts : tuple of float
        The IV slope's moves at the other lags that choice could not tell
        apart over the lag profile's windows (``pipeline.instrument.ChosenLag.shifts``; for information: the
        headline pools the moves over all the analysed windows, docs/method.md 3d).
    iv_lag_others : tuple of int
        The other admissible lags (at most ``pipeline.instrument.EXTRA_LAGS``; ``ChosenLag.others``) at which
        the kernel adds each window's instrument sums (``Plan.extra_lags``; docs/method.md 3d).
    """

    classical: Optional[Any] = None
    delay: float = 0.0
    iv_lag_samples: Optional[int] = None
    iv_lag_shifts: Tuple[float, ...] = ()
    iv_lag_others: Tuple[int, ...] = ()


#: Segments averaged per window for the line cross-spectra (docs/method.md 3e).
LINE_SEGMENTS = 4
#: Default largest expected relative half-width of the 95 % interval (gate "ci"; docs/method.md 5).
MAX_REL_CI = 0.1


def check_statistics(
    fs: float,
    length: int,
    *,
    method: Any = None,
    estimator: Any = None,
    gate: Any = None,
    max_rel_ci: Any = None,
    align: Any = None,
    iv_lag: Any = None,
    noise: Any = None,
    rpm: Any = None,
    n_lamellas: Any = None,
) -> Dict[str, Any]:
    """The statistical options checked, defaults resolved (docs/method.md 3a-5).

    ``method="paper"`` is the paper's preset: OLS, |C_yz(0)| >= 0.85, no
    alignment, exactly the tables of tribodyn 0.2; an option that
    contradicts it is an error. Otherwise the defaults are the corrected
    estimator, the gate on the interval width and no alignment.
    """
    from ..kernels.estimators import ESTIMATORS, line_frequencies

    if method not in (None, "paper"):
        raise ValueError(f"method must be None or 'paper', got {method!r}")
    # every value checked whatever the preset (the paper's records the rig data it does not use)
    rev = None if rpm is None else positive(rpm, "rpm")
    nl = None if n_lamellas is None else check_int(n_lamellas, "n_lamellas", minimum=1)
    rel = MAX_REL_CI if max_rel_ci is None else positive(max_rel_ci, "max_rel_ci")
    lag_s = None if iv_lag is None else positive(iv_lag, "iv_lag")
    sig = _noise(noise)
    if method == "paper":
        for name, value, allowed in (("estimator", estimator, (None, "ols")), ("align", align, (None,))):
            if value not in allowed:
                raise ValueError(f"method='paper' uses estimator='ols' and align=None; got {name}={value!r}")
        if gate == "ci":
            raise ValueError("method='paper' uses the |C_yz| gate (a number such as 0.85), not gate='ci'")
        return dict(method="paper", estimator="ols", gate=check_gate(0.85 if gate is None else gate), rpm=rev,
                    n_lamellas=nl)  # fmt: skip
    est = "corrected" if estimator is None else estimator
    if est not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {', '.join(map(repr, ESTIMATORS))}, got {estimator!r}")
    g: Union[float, str] = "ci" if gate is None or gate == "ci" else check_gate(gate)
    if align not in (None, "auto"):
        raise ValueError(f"align must be None or 'auto', got {align!r}")
    if lag_s is None:
        # One revolution when the speed is known (the run-out repeats, the
        # noise does not); else chosen from the data (Findings.iv_lag_samples), failing
        # which a tenth of the window, at least 10 samples.
        lag = int(round(60.0 * fs / rev)) if rev is not None else max(10, length // 10)
    else:
        lag = max(1, int(round(lag_s * fs)))
    if est == "deming" and sig is None:
        raise ValueError("estimator='deming' needs noise=(sigma_y, sigma_z) in N (docs/method.md 3c)")
    lines, index = line_frequencies(fs, rev, nl)
    if align == "auto" and not lines:
        raise ValueError("align='auto' needs rpm= (and n_lamellas=): the delay is measured at the rig's lines")
    return dict(
        method="", estimator=est, gate=g, max_rel_ci=rel, align=align, iv_lag=lag / fs, iv_lag_samples=lag, lines=lines,
        line_index=tuple(index.items()), noise=sig, iv_lag_from_data=iv_lag is None and rev is None, rpm=rev,
        n_lamellas=nl,
    )  # fmt: skip


def _noise(noise: Any) -> Optional[Tuple[float, float]]:
    """``noise=(sigma_y, sigma_z)`` checked (docs/method.md 3c), or None."""
    if noise is None:
        return None
    try:
        sy, sz = (float(v) for v in noise)
    except (TypeError, ValueError):
        raise TypeError(f"noise must be (sigma_y, sigma_z) in N, got {noise!r}") from None
    if not (sy >= 0 and sz > 0 and np.isfinite(sy) and np.isfinite(sz)):
        raise ValueError(f"noise must be (sigma_y >= 0, sigma_z > 0) in N, got {noise!r}")
    return sy, sz
