"""The options of :func:`tribodyn.analyze`, declared once (docs/architecture.md, "Where a change goes").

Each :class:`Option` carries its default, unit, command-line flag, ``--config``
key, the docs/method.md section that defines it and a one-line meaning.
From this table come the defaults :func:`tribodyn.pipeline.plan.make_plan` applies,
the command line's flags and ``--config`` keys (``tribodyn.app.cli``), the
report's units, the README's option list and the entries of ``analyze``'s
docstring (:func:`parameters_doc`); ``analyze``'s signature and ``Plan``'s
fields (typed, written by hand) and ``Results.params`` are checked against
it (``tests/test_options.py``). Each option names its check (``check``): a rule
of :data:`tribodyn.pipeline.plan.CHECKS` that :func:`tribodyn.pipeline.plan.make_plan` applies
to its value alone, or "" for the few whose validity depends on other
options, which ``make_plan`` checks together (:data:`tribodyn.pipeline.plan.JOINT`
says where). A new option is one entry here (its rule, or its joint check),
its keyword in ``analyze``'s signature and its ``Plan`` field, and its use.

Kinds:

``"plan"``
    A setting of the analysis: a field of :class:`tribodyn.Plan`.
``"log"``
    A covariate log or constant (temperature, current, voltage, other
    logs): checked into ``Plan.covariates``.
``"source"``
    How the source is read (``fs``, ``channels``): used to open a file or
    map a DataFrame, not a setting of the analysis.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple

__all__ = [
    "Option",
    "OPTIONS",
    "TARE_MODES",
    "option",
    "defaults",
    "plan_options",
    "doc_type",
    "parameters_doc",
    "markdown_table",
]


@dataclass(frozen=True)
class Option:
    """One option of :func:`tribodyn.analyze`.

    Attributes
    ----------
    name : str
        The keyword of ``analyze`` (and the field of ``Plan`` for kind "plan").
    default : object
        The keyword's default (None: chosen from the data or the other
        options, as ``doc`` says).
    kind : {"plan", "log", "source"}
        See the module's docstring.
    unit : str
        SI unit of a number ("" for none).
    section : str
        The section of docs/method.md that defines it.
    doc : str
        One line: what it is and its default.
    flag : str or None
        The command line's flag (``tribodyn analyze``), None when it has none.
    config : str or None
        The ``--config`` key (the flag without dashes), None when it has none.
    cli_type : str
        How the command line parses it: "float", "int", "text", "choice",
        or a parser of ``tribodyn.app.cli`` ("orientation", "deadband", "gate",
        "pair", "tare", "log"), or "" (set by the command line itself).
    choices : tuple of str
        The values a "choice" takes.
    config_type : str
        What a ``--config`` value must be, in words.
    check : str
        The rule of :data:`tribodyn.pipeline.plan.CHECKS` that checks (and converts)
        the value on its own; "" when :func:`tribodyn.pipeline.plan.make_plan` checks
        it together with other options (:data:`tribodyn.pipeline.plan.JOINT`).
    doc_type : str
        Its type in ``analyze``'s docstring ("" : from ``cli_type``, ``choices``
        and the default, :func:`doc_type`).
    detail : str
        Its entry in ``analyze``'s docstring, one paragraph ("": ``doc`` as a
        sentence); :func:`parameters_doc` writes the entries.
    """

    name: str
    default: Any
    kind: str
    unit: str
    section: str
    doc: str
    flag: Optional[str] = None
    config: Optional[str] = None
    cli_type: str = ""
    choices: Tuple[str, ...] = ()
    config_type: str = ""
    check: str = ""
    doc_type: str = ""
    detail: str = ""


_NUMBER, _INTEGER, _TEXT = "a number", "an integer", "a string"


#: The tare's modes by name (docs/method.md 6a): "auto" is the default (None); ``tare=`` also takes seconds and
#: offsets.
TARE_MODES = ("auto", "start", "none")


def _opt(*, name: str, default: Any, kind: str, unit: str, section: str, doc: str, flag: Optional[str] = None,
         cli_type: str = "", choices: Tuple[str, ...] = (), config_type: str = "",
         config: Optional[str] = None, check: str = "", doc_type: str = "", detail: str = "") -> Option:  # fmt: skip
    config = config or (flag[2:].replace("-", "_") if flag else None)
    if not config_type:
        config_type = {"float": _NUMBER, "int": _INTEGER, "text": _TEXT, "choice": _TEXT}.get(cli_type, "")
    return Option(name, default, kind, unit, section, doc, flag, config, cli_type, choices, config_type, check,
                  doc_type, detail)  # fmt: skip


# fmt: off
#: Every option of :func:`tribodyn.analyze`, in the order of its signature.
OPTIONS: Tuple[Option, ...] = (
    _opt(name="fs", default=None, kind="source", unit="Hz", section="6", doc="sampling rate (default: the recording's)",
         flag="--fs", cli_type="float", check="sampling rate",
         detail="Sampling rate in Hz (taken from a recording when omitted)."),
    _opt(name="window", default=None, kind="plan", unit="s", section="6b",
         doc="window length (default 2 s; slow recordings: from the rate)", flag="--window", cli_type="float",
         detail=("Window length in s (paper 2). Only complete windows count. Not given: 2 s, except for slow "
                 'recordings (docs/method.md 6b): a window of at least 100 samples; ``params["window_note"]`` says'
                 " what was chosen.")),
    _opt(name="hop", default=None, kind="plan", unit="s", section="6b",
         doc="window start spacing (default 10 s; = window tiles)", flag="--hop", cli_type="float",
         detail=("Start-to-start spacing of the windows in s (paper 10; ``hop == window`` tiles the recording). "
                 "Not given: 10 s, except below 100 Hz (docs/method.md 6b): hop = window; "
                 '``params["window_note"]`` says what was chosen.')),
    _opt(name="highpass", default=None, kind="plan", unit="Hz", section="2",
         doc="high-pass raw DC-coupled forces first (None: dynamic forces)", flag="--highpass", cli_type="float",
         check="number > 0 or None",
         detail=("Cut-off in Hz of a first-order Butterworth high-pass applied to raw, DC-coupled force channels "
                 'first (streaming, state carried, "steady" start). None for dynamic forces as delivered by the '
                 "paper's charge amplifier. With it, the table's ``mu_classical`` is the classical COF "
                 "mean(|fy|/|fz|) of the raw forces.")),
    _opt(name="orientation", default="auto", kind="plan", unit="", section="0",
         doc="s in mu = s * slope: +1, -1 or auto (once per recording)", flag="--orientation", cli_type="orientation",
         config_type='"auto", 1 or -1', check="orientation",
         doc_type='{+1, -1, "auto"}',
         detail=('s in mu = s * slope; "auto" fixes it ONCE for the recording, as the sign of the least-squares '
                 "slope of fy on fz over all windows (docs/method.md 0), never per window.")),
    _opt(name="temperature", default=None, kind="log", unit="degC", section="6",
         doc="temperature log (t_s, T), interpolated at window centres", flag="--temperature", cli_type="log",
         config_type="a string", check="log or None",
         doc_type="(t_s, T_degC), optional",
         detail=("Intermittent temperature log, interpolated linearly at each window centre (NaN outside the log);"
                 " ``branch`` is the sign of dT/dt.")),
    _opt(name="current", default=None, kind="log", unit="A", section="6",
         doc="current log (t_s, i) or constant, when the source has no i channel", check="constant or log",
         doc_type="(t_s, i_A) or float, optional",
         detail="Current log or constant, when the source has no ``i`` channel."),
    _opt(name="voltage", default=None, kind="log", unit="V", section="6",
         doc="shunt voltage log (t_s, u) or constant (needs shunt_ohm)", check="constant or log",
         doc_type="(t_s, u_V) or float, optional",
         detail=("Shunt voltage log or constant (needs ``shunt_ohm``); a ``u`` channel in the source is used "
                 "likewise.")),
    _opt(name="shunt_ohm", default=None, kind="plan", unit="ohm", section="6", doc="shunt resistance R: i = u / R",
         flag="--shunt", cli_type="float", check="number > 0 or None",
         detail="Shunt resistance R: i = u / R."),
    _opt(name="area_mm2", default=None, kind="plan", unit="mm^2", section="7", doc="contact area: J = i / area",
         flag="--area", cli_type="float", check="number > 0 or None",
         detail="Contact area; J = i / area_mm2 in A/mm^2."),
    _opt(name="covariates", default=None, kind="log", unit="", section="7a",
         doc="other logs by name (speed: the Stribeck curve)", flag="--covariate", cli_type="covariate",
         config_type='a table of name = "log file"', config="covariates", check="covariate logs",
         doc_type="mapping of str -> (t_s, values) or float, optional",
         detail=("Other logs, interpolated linearly at each window centre (NaN outside the log; absolute times "
                 'aligned as ``temperature``\'s): ``{"speed": (t, v)}`` fills the ``speed`` column (m/s, its '
                 "magnitude; it replaces the mean |v| of a velocity channel ``v``), any other name a column of "
                 "that name after the declared ones (docs/method.md 7a). Each may be the covariate of "
                 ":func:`tribodyn.operating_range` (``by=NAME``).")),
    _opt(name="chunk", default=None, kind="plan", unit="s", section="9",
         doc="seconds read per chunk (memory bound; never changes a result)", flag="--chunk", cli_type="float",
         check="number > 0 or None",
         detail=("Seconds per chunk when reading a mapping or a recording (default 131072 samples, about 2 min at "
                 "1 kHz, for a recording; a mapping is taken whole). For a channels-first float64 ``.npy`` the "
                 "kernel reads the file itself, in blocks of at most this many seconds (default 2^15 samples) per "
                 "thread. Never changes a result.")),
    _opt(name="progress", default=False, kind="plan", unit="", section="9", doc="a progress bar on stderr",
         check="truth value",
         detail="Show a progress bar on stderr."),
    _opt(name="deadband", default=0.35, kind="plan", unit="N", section="4",
         doc="|fz| below it is left out of the bins and mu_a, mu_b: a force (default 0.35) or e.g. 0.7sigma",
         flag="--deadband", cli_type="deadband",
         config_type='a number (N) or a string such as "0.7sigma"', check="deadband",
         doc_type="float or str",
         detail=("|fz| below it is left out of the bins and of mu_a, mu_b, per window: a force in N (paper 0.35) "
                 'or ``"0.7sigma"`` (k times the std of fz), as for :func:`tribodyn.identify`.')),
    _opt(name="n_bins", default=16, kind="plan", unit="", section="4",
         doc="normal-force bins (default 16; at most 1024, about 4 samples each)", flag="--bins", cli_type="int",
         detail=("Equal-width fz bins per window over [min fz, max fz] (default 16; at most max(16, n // 4) and "
                 "1024, docs/method.md 4).")),
    _opt(name="gate", default=None, kind="plan", unit="", section="5",
         doc="quality gate: ci (default) or a |C_yz(0)| threshold (paper 0.85)", flag="--gate", cli_type="gate",
         config_type='a number (|C_yz| threshold) or "ci"',
         doc_type='float or "ci", optional',
         detail=('Quality gate (docs/method.md 5): "ci" (default) keeps a window when its expected 95 % half-width'
                 " (its white-noise standard error times the recording's batch-means ratio) is at most "
                 "+-``max_rel_ci`` of the recording's median COF; a number g is the paper's |C_yz(0)| >= g (0.85 "
                 'with ``method="paper"``). With either, a window whose slope has the sign opposite to the '
                 "recording's orientation fails.")),
    _opt(name="max_lag", default=None, kind="plan", unit="samples", section="3e",
         doc="per-window channel-skew check up to this lag", flag="--max-lag", cli_type="int",
         check="integer >= 0 or None",
         detail=("Adds the lag of max |C_yz(j)| per window, for lags up to ``max_lag`` samples (costly: one "
                 "correlation function per window); a non-zero lag fails the gate.")),
    _opt(name="rpm", default=None, kind="plan", unit="1/min", section="3e",
         doc="rotating speed: the instrument lag and the rig's lines", flag="--rpm", cli_type="float",
         detail=("Rotating speed (rig data): the instrument lag (one revolution) and the line frequencies f0 = "
                 "rpm/60, 2 f0, 3 f0 of the columns ``skew``, ``h1_f0``.")),
    _opt(name="n_lamellas", default=None, kind="plan", unit="", section="3e",
         doc="commutator lamellas: the lamella line f_l", flag="--lamellas", cli_type="int",
         detail=("Commutator lamellas (rig data, with ``rpm``): the lamella lines f_l = n_lamellas f0 and 2 f_l of"
                 " the columns ``h1_fl``, ``coherence_fl``.")),
    _opt(name="threads", default=None, kind="plan", unit="", section="9",
         doc="kernel threads of this call (default: every core; a Dask task: its host's share)", flag="--threads",
         cli_type="int", check="threads",
         detail=("Kernel threads for this call only, 1 to 4 x the CPU count (default: the ``TRIBODYN_THREADS`` "
                 "environment variable, else :func:`tribodyn.get_threads`, every core unless "
                 ":func:`tribodyn.set_threads` changed it; a task of ``analyze_many`` on a Dask cluster: its share "
                 "of its host's cores, docs/method.md 9). Results do not depend on it, and concurrent calls do "
                 "not change each other's count.")),
    _opt(name="start", default=0, kind="plan", unit="samples", section="9",
         doc="first sample of the source within the recording", check="integer >= 0",
         detail=("Sample index, within the whole recording, of the source's first sample (default 0). Windows stay"
                 " on the recording's grid (starting at multiples of ``hop``), so consecutive ranges of a long "
                 "recording analysed separately give exactly the windows of one pass (see "
                 ":func:`tribodyn.analyze_many`), except with ``highpass``: the filter starts afresh at ``start``, "
                 "so the range's first windows differ. A recording source is read from ``start`` on.")),
    _opt(name="stop", default=None, kind="plan", unit="samples", section="9",
         doc="a recording's sample where reading ends (exclusive)", check="integer >= 0 or None",
         doc_type="int, optional",
         detail=("For a recording source: the sample index (exclusive) where reading ends (default: the end). "
                 "``start``/``stop`` analyse one range of a long recording straight from the file, with the "
                 "windows that lie wholly inside it.")),
    _opt(name="estimator", default=None, kind="plan", unit="", section="3a",
         doc="slope estimator: corrected (default), iv, ols or deming", flag="--estimator", cli_type="choice",
         choices=("corrected", "iv", "ols", "deming"),
         detail=('The slope estimator (docs/method.md 3a-3c). Default "corrected": least squares corrected for the'
                 " noise on fz, whose variance is measured from the recording with instruments (or taken from "
                 "``noise``); unbiased under noise on fz and as precise as OLS without it (measured: "
                 'docs/method.md 3f). "ols" is the paper\'s Eq. 8, "iv" instrumental variables (fz lagged by '
                 '``iv_lag``), "deming" needs ``noise``.')),
    _opt(name="method", default=None, kind="plan", unit="", section="3a",
         doc="paper: the paper's method exactly (OLS, |C_yz| >= 0.85)", flag="--method", cli_type="choice",
         choices=("paper",),
         detail=('"paper": the paper\'s method exactly (OLS, |C_yz(0)| >= 0.85, OLS standard errors, no alignment),'
                 " the tables of tribodyn 0.2.")),
    _opt(name="max_rel_ci", default=None, kind="plan", unit="", section="5",
         doc="gate ci: largest expected relative half-width (default 0.1)", flag="--max-rel-ci", cli_type="float",
         detail=("Largest expected half-width of the 95 % interval, relative to the recording's median COF, for "
                 'gate "ci" (default 0.1).')),
    _opt(name="align", default=None, kind="plan", unit="", section="3e",
         doc="auto: measure the fz delay at the rig's lines and correct it", flag="--align", cli_type="choice",
         choices=("auto",),
         detail=('"auto": measure the delay of fz behind fy from the cross-spectral phase at the rig\'s lines '
                 "(needs ``rpm``), and when it exceeds 0.05 samples analyse again with fz advanced by it (a "
                 'fractional-delay filter, docs/method.md 3e); ``params["delay_samples"]`` holds it. None leaves '
                 "the data untouched (a measurable delay is then warned of).")),
    _opt(name="iv_lag", default=None, kind="plan", unit="s", section="3b",
         doc="instrument lag (default one revolution with rpm)", flag="--iv-lag", cli_type="float",
         detail=("Instrument lag in s (default one revolution, 60 / rpm, when ``rpm`` is given; else a tenth of "
                 "the window, at least 10 samples).")),
    _opt(name="noise", default=None, kind="plan", unit="N", section="3c",
         doc="(sigma_y, sigma_z): measurement noise (deming needs it)", flag="--noise", cli_type="pair",
         config_type="a list of two numbers [sigma_y, sigma_z] in N",
         doc_type="(sigma_y, sigma_z), optional",
         detail=("Standard deviations (N) of the measurement noise on fy and fz, e.g. the standard deviations of a"
                 ' record taken with the rig at rest (docs/method.md 3c); needed by "deming".')),
    _opt(name="motion", default="auto", kind="plan", unit="", section="6c",
         doc="auto, unidirectional or reciprocating (per-stroke table)", flag="--motion", cli_type="choice",
         choices=("auto", "unidirectional", "reciprocating"), check="choice",
         detail=('"reciprocating" adds the per-stroke table ``Results.strokes`` (strokes from the sign changes of '
                 'the ``v`` role, of d``x``/dt, else of fy; docs/method.md 6c); "auto" detects it from fy\'s sign '
                 "changes.")),
    _opt(name="min_fn", default=None, kind="plan", unit="N", section="6a",
         doc="classical COF: least |fz| in contact (default from the data)", flag="--min-fn", cli_type="float",
         check="force >= 0 or None",
         detail=("Classical COF: samples with |fz| below it (N) are left out (default 5 % of the recording's "
                 "median |fz|; docs/method.md 6a).")),
    _opt(name="tare", default=None, kind="plan", unit="s or N", section="6a",
         doc="classical COF: auto (unloaded samples, before the first contact when there are some), start (only "
             "before the first contact), none (fy not tared: a drag stays in the friction), seconds without contact "
             "at the start, or offsets fy=N,fz=N", flag="--tare", cli_type="tare",
         config_type="auto, start, none, a number of seconds or a table of offsets", check="tare",
         doc_type="str, float or mapping, optional",
         detail=('Classical COF (docs/method.md 6a): "auto" (None: the unloaded samples, those before the first '
                 'contact when there are some), "start" (only those before the first contact), "none" (fy not '
                 "tared: a drag stays in the friction), seconds at the start without contact (their mean fy and fz"
                 ' are subtracted), or explicit offsets ``{"fy": N, "fz": N}``.')),
    _opt(name="stroke_fraction", default=0.5, kind="plan", unit="", section="6c",
         doc="reciprocating: central part of each stroke", flag="--stroke-fraction", cli_type="float",
         check="fraction",
         detail="Central part of each stroke used for its COF (default 0.5)."),
    _opt(name="stick_slip", default=False, kind="plan", unit="", section="6g",
         doc="also find stick-slip events, in the same reading (Results.stick_slip)", check="truth value",
         detail=("Also find the stick-slip events (docs/method.md 6g) in the same reading of the source: "
                 "``Results.stick_slip`` holds what :func:`tribodyn.stick_slip` would find reading it again, bit "
                 "for bit. Default False (``Results.stick_slip`` None); the command line sets it.")),
    _opt(name="uncertainty", default=None, kind="plan", unit="", section="6i",
         doc="instrument budget: fy_rel, fz_rel, fy_abs, fz_abs, misalignment_deg, crosstalk (standard uncertainties)",
         flag="--uncertainty", cli_type="uncertainty",
         config_type="a table of key = standard uncertainty or {u, distribution, dof}", check="uncertainty inputs",
         doc_type="mapping, optional",
         detail=("What is known of the instrument (docs/method.md 6i): standard uncertainties of ``fy_rel``, "
                 "``fz_rel`` (calibration, relative), ``fy_abs``, ``fz_abs`` (offsets, N), ``misalignment_deg`` "
                 'and ``crosstalk``, each a number (normal) or ``{"u": ..., "distribution": "normal" | '
                 '"rectangular" | "triangular", "dof": ...}``, and a known ``misalignment_bias_deg`` (corrected). '
                 "The headline then carries ``Headline.uncertainty``: the combined uncertainty of the instrument "
                 "and the statistics by Monte Carlo (JCGM 101) with its budget. Default None: the headline's "
                 "interval is statistical only.")),
    _opt(name="load", default=None, kind="source", unit="N", section="6a",
         doc="a constant normal force for a file without a load channel (fz)", flag="--load", cli_type="float",
         detail=("A known constant normal force (N) for a source without a load channel (a pin-on-disc export "
                 "whose load is a test parameter): it becomes the channel ``fz``, so the headline is the classical"
                 " COF mean |fy| / load over the samples in contact and the instrument's COF column is checked "
                 "against it (docs/method.md 6a). A source that has fz is refused (map it away with "
                 '``channels={"fz": None}``).')),
    _opt(name="channels", default=None, kind="source", unit="", section="6f",
         doc="role -> column of a DataFrame, or channel of a file", flag="--map", cli_type="map",
         config_type='a table of role = "channel" (or a string "fy=Ft,fz=Fn")', config="map",
         doc_type="mapping, optional",
         detail=("For a DataFrame source: role -> column; for a path: role -> channel, as ``open_recording``'s "
                 "``channels=``.")),
)
# fmt: on

_BY_NAME: Dict[str, Option] = {o.name: o for o in OPTIONS}


def option(name: str) -> Option:
    """The option called ``name`` (a ``KeyError`` names the known ones otherwise)."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"no option {name!r}; the options are {', '.join(_BY_NAME)}") from None


def defaults() -> Dict[str, Any]:
    """Every option's default, by name."""
    return {o.name: o.default for o in OPTIONS}


def plan_options() -> Tuple[str, ...]:
    """The names of the options a :class:`tribodyn.Plan` holds (kinds "plan" and "log")."""
    return tuple(o.name for o in OPTIONS if o.kind != "source")


def markdown_table() -> str:
    """The README's option table (``README.md``, "Options"), generated from :data:`OPTIONS`.

    ``tests/test_options.py`` checks that the README holds exactly this;
    regenerate it with ``python -c "import tribodyn.options as o; print(o.markdown_table())"``.
    """
    rows = [
        "| option | command line / `--config` key | default | unit | meaning | docs/method.md |",
        "|---|---|---|---|---|---|",
    ]
    for o in OPTIONS:
        flag = f"`{o.flag}` / `{o.config}`" if o.flag else "(Python only)"
        default = f"`{o.default!r}`".replace("'", '"')
        doc = o.doc.replace("|", "\\|")
        rows.append(f"| `{o.name}` | {flag} | {default} | {o.unit or ''} | {doc} | {o.section} |")
    return "\n".join(rows)


def doc_type(o: Option) -> str:
    """The option's type in ``analyze``'s docstring: its ``doc_type``, else from its choices, ``cli_type`` or
    default (", optional" when the default is None)."""
    if o.doc_type:
        return o.doc_type
    if o.choices:
        base = "{" + ", ".join(f'"{c}"' for c in o.choices) + "}"
    elif o.cli_type in ("float", "int"):
        base = o.cli_type
    elif o.default is not None:
        base = type(o.default).__name__
    else:
        base = "object"
    return f"{base}, optional" if o.default is None else base


def parameters_doc(indent: str = "    ", width: int = 76) -> str:
    """The entries of every option in the "Parameters" section of ``analyze``'s docstring (numpydoc), in the
    order of :data:`OPTIONS`: ``name : type`` and its ``detail`` (else ``doc`` as a sentence), wrapped."""
    out = []
    for o in OPTIONS:
        text = o.detail or (o.doc[:1].upper() + o.doc[1:] + ".")
        body = textwrap.fill(text, width=width, initial_indent=2 * indent, subsequent_indent=2 * indent,
                             break_long_words=False, break_on_hyphens=False)  # fmt: skip
        out.append(f"{indent}{o.name} : {doc_type(o)}\n{body}")
    return "\n".join(out) + "\n"
