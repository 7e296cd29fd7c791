"""The report's figures, declared: one entry per figure, walked by :func:`build_named_figures`.

Each entry (:class:`FigureEntry`) names the figure's file, says when it applies (from the
:class:`~tribodyn.Results` and what the report was given: :class:`FigureInputs`), builds its caption and draws it
(a function of :mod:`tribodyn.app.figures`, which imports Matplotlib: it is imported only when a figure is drawn).
:data:`RECORDING_FIGURES` are the recording's figures, in their order; :data:`WINDOW_FIGURES` the paper's
diagnostics of one example window (Figs. 2-9), one set per window given. The order of the two groups is one rule
(issue 34 point 9): the window diagnostics lead when the dynamic method gives the headline; an export's report
(classical, per-stroke or instrument headline) opens with its COF against time (and its strokes, cycles and
loops), and they follow.

A new figure: its function in ``app/figures.py`` and one entry here (docs/architecture.md, "Where a change goes").
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Callable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..results._cache import cached
from . import _labels

if TYPE_CHECKING:  # Matplotlib is imported where a figure is drawn
    from matplotlib.figure import Figure

__all__ = [
    "FigureInputs",
    "FigureEntry",
    "Window",
    "WindowFigure",
    "RECORDING_FIGURES",
    "WINDOW_FIGURES",
    "build_named_figures",
    "finite_any",
    "range_or_none",
]

#: (file name without ".png", caption, Figure).
NamedFigure = Tuple[str, str, "Figure"]


def _figs() -> Any:
    """:mod:`tribodyn.app.figures`, imported on first use (it imports Matplotlib)."""
    from . import figures

    return figures


def finite_any(results: Any, column: str) -> bool:
    """Whether ``column`` of the per-window table has a finite value."""
    table = getattr(results, "table", results)
    return column in table and bool(np.isfinite(np.asarray(table[column], dtype=float)).any())


def range_or_none(results: Any, opr: Any, by: str) -> Any:
    """``opr``, else the operating range against ``by`` with the defaults when its column has data and one is found."""
    if opr is not None:
        return opr
    column = {"temperature": "T", "current_density": "J"}.get(by, by)
    if not finite_any(results, column):
        return None
    try:
        from ..analyses.ranges import operating_range

        return operating_range(results, by=by)
    except ValueError:
        return None


@dataclasses.dataclass(frozen=True)
class FigureInputs:
    """What a figure may read: the analysis and what the report was given (:func:`build_named_figures`).

    What several entries read is computed once, on first use (the operating ranges, what the
    COF-against-time figures show).
    """

    results: Any
    opr_temperature: Any = None
    opr_current: Any = None
    opr_speed: Any = None
    examples: Sequence[Mapping[str, Any]] = ()
    temperature_log: Any = None
    loops: Sequence[Mapping[str, Any]] = ()
    time_figure: bool = True
    #: Where the running-in ends (a :meth:`tribodyn.SteadyState.to_dict`), shaded on the COF against time.
    steady_state: Optional[Mapping[str, Any]] = None

    @cached
    def dynamic_first(self) -> bool:
        """Whether the window diagnostics lead: the dynamic method gives the headline (issue 34 point 9)."""
        head = getattr(self.results, "headline", None)
        return head is None or head.method == "dynamic"

    def has(self, column: str) -> bool:
        """Whether ``column`` of the per-window table has data."""
        return finite_any(self.results, column)

    @cached
    def what(self) -> str:
        """What the COF-against-time figures show, for their captions."""
        return _time_what(self.results, getattr(self.results, "headline", None))

    @cached
    def opr_t(self) -> Any:
        return range_or_none(self.results, self.opr_temperature, "temperature")

    @cached
    def opr_j(self) -> Any:
        return range_or_none(self.results, self.opr_current, "current_density")

    @cached
    def opr_v(self) -> Any:
        return range_or_none(self.results, self.opr_speed, "speed")

    @property
    def strokes(self) -> Optional[Mapping[str, Any]]:
        return getattr(self.results, "strokes", None)

    def has_strokes(self) -> bool:
        """A reciprocating test's per-stroke table with strokes."""
        return self.strokes is not None and bool(len(self.strokes.get("mu", ())))

    def has_energy(self) -> bool:
        """A cycle with an energy (a reciprocating test with a position channel)."""
        cycles = getattr(self.results, "cycles", None)
        return cycles is not None and bool(np.isfinite(np.asarray(cycles["energy"], dtype=float)).any())


@dataclasses.dataclass(frozen=True)
class FigureEntry:
    """One figure of the recording: its file name, when it applies, its caption and its drawing."""

    name: str
    when: Callable[[FigureInputs], bool]
    caption: Callable[[FigureInputs], str]
    draw: Callable[[FigureInputs], "Figure"]


# -- captions --------------------------------------------------------------------------------------------------


def _time_what(results: Any, head: Any) -> str:
    """What the COF-against-time figures show, for their captions."""
    n = len(getattr(results, "table", results)["time"])
    if head is not None and head.method != "dynamic":  # the figure shows the classical COF (docs/method.md 6e)
        return (f"{n} windows: the classical COF of each and the instrument's where the file has it; black line "
                f"and grey band: the headline ({head.method} COF, {head.statistic}) and its 95 % interval")  # fmt: skip
    ok = int(np.sum(np.asarray(getattr(results, "table", results).get("ok", np.ones(n)), dtype=bool)))
    many = ok > _figs().BAND_FROM
    return (f"{n} windows, {ok} passed the quality gate"
            + ("; line and shaded band: running median and 5-95 % of the gated windows" if many else "")
            + "; failed windows as grey ticks in the strip at the top, with their commonest reasons")  # fmt: skip


def opr_caption(opr: Any) -> str:
    """An operating range in words, for the caption of its figure (docs/method.md 7)."""
    if opr is None:
        return "No operating range (no quality-gated window with this covariate)."
    unit = _labels.unit_text(opr.unit)
    if getattr(opr, "method", "binned") == "segmented":
        return _segmented_caption(opr, unit)
    fmt = _labels.fmt_value
    parts = []
    if opr.optimum is not None:
        parts.append(
            f"Optimum (shaded): {fmt(opr.optimum[0])}–{fmt(opr.optimum[1])} {unit}, binned COF within "
            f"{100 * opr.tol:g} % of its minimum {fmt(opr.mu_min)}"
        )
    if opr.onset is not None:
        parts.append(f"COF reaches {1 + opr.rise:g} × the minimum at {fmt(opr.onset)} {unit} (dashed red line)")
    return ("; ".join(parts) + ".") if parts else "No optimum found."


def _ci(ci: Any) -> str:
    return "" if ci is None else f" [{_labels.fmt_value(ci[0])}, {_labels.fmt_value(ci[1])}]"


def _segmented_caption(opr: Any, unit: str) -> str:
    """The segmented fit in words: verdict, breakpoints and intervals, exclusions (docs/method.md 7)."""
    fmt = _labels.fmt_value
    expl = _labels.units_in_text(opr.explanation)
    parts = [f"Bathtub fit (line) with its 95 % bootstrap band; verdict: {opr.verdict}. {expl}"]
    for name, f in opr.fits.items():
        if f.verdict in ("too few windows", "covariate constant"):
            parts.append(f"{name} ({f.n_windows} windows): {f.verdict}.")
            continue
        bits = []
        if f.lower is not None:
            bits.append(f"lower breakpoint {fmt(f.lower)}{_ci(f.lower_ci)} {unit}")
        if f.upper is not None:
            bits.append(f"upper breakpoint {fmt(f.upper)}{_ci(f.upper_ci)} {unit}")
        bits.append(f"minimum COF {fmt(f.mu_min)}{_ci(f.mu_min_ci)}")
        if f.onset is not None:
            bits.append(f"COF {1 + opr.rise:g} × the minimum at {fmt(f.onset)}{_ci(f.onset_ci)} {unit}")
        parts.append(f"{name} ({f.n_windows} windows, {f.verdict}): " + ", ".join(bits) + ".")
    h = opr.hysteresis
    if h is not None and h.upper is not None:
        parts.append(f"Hysteresis of the upper edge (heating − cooling): {fmt(h.upper)}{_ci(h.upper_ci)} {unit}.")
    if opr.instability is not None:
        parts.append(f"Contact loss from {fmt(opr.instability)} {unit} (onset between{_ci(opr.instability_ci)}).")
    if opr.excluded:
        parts.append("Left out of the fit: " + ", ".join(f"{v} ({k})" for k, v in opr.excluded.items()) + ".")
    return " ".join(parts)


def _strokes_caption(d: FigureInputs) -> str:
    strokes = d.strokes or {}
    fraction = getattr(d.results, "params", {}).get("stroke_fraction", 0.5)
    instrument = np.isfinite(np.asarray(strokes.get("mu_instrument", [np.nan]), dtype=float)).any()
    marks = "; open markers: the instrument's COF column" if instrument else ""
    return (
        f"Reciprocating test: per-stroke classical COF (mean |fy|/|fz| over the central {fraction:g} of each "
        f"stroke) against cycle number, one marker per sliding direction ({len(strokes['mu'])} strokes)"
        f"{marks}; docs/method.md 6c."
    )


_LOOPS = (
    "Friction loops: the friction force against the position over the first, a middle and the last whole cycle; "
    "the area inside a loop is the energy friction dissipates in that cycle (docs/method.md 6c)."
)
_ENERGY = (
    "Energy dissipated per cycle (the friction loop's area, sum of F_y dx) and the energy COF, energy / "
    "(mean F_n x sliding distance), against cycle number (docs/method.md 6c)."
)
_STRIBECK = (
    "Stribeck curve: COF of each window against its mean sliding speed (log axis), the bathtub fit on log "
    "speed and the regimes its walls stand for (docs/method.md 7a). "
)


#: The recording's figures, in the report's order: (file name, when, caption, drawing). A new figure is one entry.
RECORDING_FIGURES: Tuple[FigureEntry, ...] = (
    FigureEntry(
        "fig10_cof_temperature_vs_time",
        lambda d: d.has("T"),
        lambda d: (
            "COF (mu_r by regression, mu_a and mu_b per normal-force sign) and commutator temperature "
            f"against time ({d.what}); cf. paper Fig. 10."
        ),
        lambda d: _figs().cof_and_temperature_vs_time(
            d.results, temperature_log=d.temperature_log, steady_state=d.steady_state
        ),
    ),
    FigureEntry(
        "fig11_cof_vs_temperature",
        lambda d: d.has("T"),
        lambda d: (
            "COF against temperature, heating and cooling branches apart (hysteresis) with binned medians. "
            f"{opr_caption(d.opr_t)} Cf. paper Fig. 11."
        ),
        lambda d: _figs().cof_vs_temperature(d.results, d.opr_t),
    ),
    FigureEntry(
        "fig12_cof_current_density_vs_time",
        lambda d: d.has("J"),
        lambda d: f"COF and current density J against time ({d.what}); cf. paper Fig. 12.",
        lambda d: _figs().cof_and_current_density_vs_time(d.results, steady_state=d.steady_state),
    ),
    FigureEntry(
        "sec4-2_cof_vs_current_density",
        lambda d: d.has("J"),
        lambda d: f"COF against current density with binned medians. {opr_caption(d.opr_j)} Cf. paper Sec. 4.2.",
        lambda d: _figs().cof_vs_current_density(d.results, d.opr_j),
    ),
    FigureEntry(
        "stribeck_curve",
        lambda d: d.has("speed"),
        lambda d: _STRIBECK + opr_caption(d.opr_v),
        lambda d: _figs().stribeck_curve(d.results, d.opr_v),
    ),
    FigureEntry(
        "cof_vs_time",
        lambda d: d.time_figure and not (d.has("T") or d.has("J")),
        lambda d: f"COF against time ({d.what}); no temperature or current density was given.",
        lambda d: _figs().cof_vs_time(d.results, steady_state=d.steady_state),
    ),
    FigureEntry(
        "strokes_cof_vs_cycle",
        FigureInputs.has_strokes,
        _strokes_caption,
        lambda d: _figs().strokes_vs_cycle(d.results),
    ),
    FigureEntry(
        "friction_loops",
        lambda d: d.has_energy() and bool(d.loops),
        lambda d: _LOOPS,
        lambda d: _figs().friction_loops(d.loops),
    ),
    FigureEntry(
        "energy_vs_cycle", FigureInputs.has_energy, lambda d: _ENERGY, lambda d: _figs().energy_vs_cycle(d.results)
    ),
)


# -- one example window's diagnostics (paper Figs. 2-9) --------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Window:
    """One example window, ready for its figures: its forces, its fit and correlation functions, its words.

    ``example`` (a dict): ``fx`` (may be None), ``fy``, ``fz`` (arrays, N), ``fs`` (Hz), optional ``result``
    (alias ``cof``: its :class:`~tribodyn.CofResult`, fitted here with ``identify(..., max_lag=fs/2)`` when
    absent; the correlation functions are computed if it has none), ``t0`` (s), ``label`` (e.g.
    "representative gated window"), ``tag`` (for the file names) and ``gate_text`` (the analysis's own verdict
    on the window).
    """

    fx: Any
    fy: Any
    fz: Any
    fs: float
    t0: float
    fit: Any
    corr: Any  # the correlation functions by pair ("xy", "xz", "yz"), {} when none
    label: str
    tag: str
    span: str
    gate: str

    @staticmethod
    def of(example: Mapping[str, Any]) -> "Window":
        from ..kernels.correlation import xcorr
        from ..pipeline.identify import identify

        fx, fy, fz = example.get("fx"), example["fy"], example["fz"]
        fs = float(example["fs"])
        t0 = float(example.get("t0", 0.0) or 0.0)
        res = example.get("result", example.get("cof"))
        n = len(np.asarray(fz))
        lag = max(0, min(n - 1, round(0.5 * fs)))
        if res is None:
            res = identify(fy, fz, fx=fx, fs=fs, max_lag=lag, method="paper")  # the figures' own fit, as before
        corr = res.correlations
        if corr is None and n >= 2:
            corr = {"yz": xcorr(fy, fz, max_lag=lag, fs=fs, check_finite=False)}
            if fx is not None:
                corr["xy"] = xcorr(fx, fy, max_lag=lag, fs=fs, check_finite=False)
                corr["xz"] = xcorr(fx, fz, max_lag=lag, fs=fs, check_finite=False)
        gate = "passed" if res.ok else "failed (" + "; ".join(res.reasons) + ")"
        window_gate = example.get("gate_text")  # the analysis's own verdict on this window
        return Window(
            fx,
            fy,
            fz,
            fs,
            t0,
            res,
            corr or {},
            str(example.get("label") or "example window"),
            str(example.get("tag") or "example"),
            f"{n / fs:g} s at {fs:g} Hz from t = {t0:g} s",
            str(window_gate) if window_gate else gate,
        )


@dataclasses.dataclass(frozen=True)
class WindowFigure:
    """One diagnostic of an example window: its file name's stem (``<stem>_<tag>``), its caption and drawing."""

    stem: str
    caption: Callable[[Window], str]
    draw: Callable[[Window], "Figure"]


_v = _labels.fmt_value

#: The diagnostics of each example window, in their order (paper Figs. 2-9).
WINDOW_FIGURES: Tuple[WindowFigure, ...] = (
    WindowFigure(
        "fig02_forces",
        lambda w: f"Dynamic forces of the {w.label} ({w.span}); cf. paper Fig. 2.",
        lambda w: _figs().forces_vs_time(w.fx, w.fy, w.fz, w.fs, t0=w.t0),
    ),
    WindowFigure(
        "fig03-05_correlations",
        lambda w: (
            f"Correlation functions C_xy, C_xz, C_yz of the {w.label} against the time shift, Eq. (1); "
            f"C_yz(0) = {_v(w.fit.c_yz)}, quality gate {w.gate}; cf. paper Figs. 3-5."
        ),
        lambda w: _figs().correlation_functions(w.corr),
    ),
    WindowFigure(
        "fig06-08_phase_plots",
        lambda w: (
            f"Force phase plots of the {w.label} with the regression of F_y,d on F_z,d (mu_r = {_v(w.fit.mu_r)}, "
            f"orientation s = {w.fit.orientation:+d}); cf. paper Figs. 6-8."
        ),
        lambda w: _figs().phase_plots(w.fx, w.fy, w.fz, fit=w.fit),
    ),
    WindowFigure(
        "fig09_cof_vs_normal_force",
        lambda w: (
            f"COF per F_z,d bin of the {w.label}, deadband {_v(w.fit.deadband)} N shaded; mu_r = {_v(w.fit.mu_r)}, "
            f"mu_a = {_v(w.fit.mu_a)}, mu_b = {_v(w.fit.mu_b)}; cf. paper Fig. 9."
        ),
        lambda w: _figs().cof_vs_normal_force(w.fit),
    ),
)


def build_named_figures(
    results: Any,
    *,
    opr_temperature: Any = None,
    opr_current: Any = None,
    examples: Sequence[Mapping[str, Any]] = (),
    temperature_log: Any = None,
    loops: Sequence[Mapping[str, Any]] = (),
    opr_speed: Any = None,
    time_figure: bool = True,
    steady_state: Optional[Mapping[str, Any]] = None,
) -> List[NamedFigure]:
    """(file name, caption, Figure) of every figure that applies, walking :data:`WINDOW_FIGURES` (once per example
    window) and :data:`RECORDING_FIGURES`; the window diagnostics first when the headline is the dynamic COF, else
    after the recording's figures (issue 34 point 9).

    ``time_figure=False`` leaves out ``cof_vs_time`` (the report's interactive view shows it). ``loops`` (a
    reciprocating test with a position channel: ``x``, ``fy``, ``label`` and ``energy`` of whole cycles) add the
    friction-loop figure; ``opr_temperature``, ``opr_current``, ``opr_speed``: the operating ranges (computed
    with the defaults when not given and the column has data); ``temperature_log``: the readings, drawn on the
    Fig. 10 analogue; ``steady_state`` (:meth:`tribodyn.SteadyState.to_dict`, docs/method.md 6h): the running-in
    shaded on the COF against time. Matplotlib is imported only when a figure is drawn.
    """
    d = FigureInputs(results, opr_temperature, opr_current, opr_speed, tuple(examples), temperature_log,
                     tuple(loops), time_figure, steady_state)  # fmt: skip
    diagnostics = [named for ex in d.examples for named in window_figures(Window.of(ex))]
    own = [(e.name, e.caption(d), e.draw(d)) for e in RECORDING_FIGURES if e.when(d)]
    return diagnostics + own if d.dynamic_first else own + diagnostics


def window_figures(w: Window) -> List[NamedFigure]:
    """(file name, caption, Figure) of :data:`WINDOW_FIGURES` for one example window."""
    return [(f"{f.stem}_{w.tag}", f.caption(w), f.draw(w)) for f in WINDOW_FIGURES]
