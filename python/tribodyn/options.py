"""The options of :func:`tribodyn.analyze`, declared once (docs/architecture.md, "Where a change goes").

Each :class:`Option` carries its default, unit, command-line flag, ``--config``
key, the docs/method.md section that defines it and a one-line meaning.
From this table come the defaults :func:`tribodyn.pipeline.plan.make_plan` applies,
the command line's flags and ``--config`` keys (``tribodyn.app.cli``), the
report's units and the README's option list; ``analyze``'s signature and
docstring, ``Plan``'s fields and ``Results.params`` are checked against it
(``tests/test_options.py``). Each option names its check (``check``): a rule
of :data:`tribodyn.pipeline.plan.CHECKS` that :func:`tribodyn.pipeline.plan.make_plan` applies
to its value alone, or "" for the few whose validity depends on other
options, which ``make_plan`` checks together (:data:`tribodyn.pipeline.plan.JOINT`
says where). A new option is one entry here, its rule (or its joint check)
and its use.

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

from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple

__all__ = ["Option", "OPTIONS", "TARE_MODES", "option", "defaults", "plan_options"]


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


_NUMBER, _INTEGER, _TEXT = "a number", "an integer", "a string"


#: The tare's modes by name (docs/method.md 6a): "auto" is the default (None); ``tare=`` also takes seconds and
#: offsets.
TARE_MODES = ("auto", "start", "none")


def _opt(*, name: str, default: Any, kind: str, unit: str, section: str, doc: str, flag: Optional[str] = None,
         cli_type: str = "", choices: Tuple[str, ...] = (), config_type: str = "",
         config: Optional[str] = None, check: str = "") -> Option:  # fmt: skip
    config = config or (flag[2:].replace("-", "_") if flag else None)
    if not config_type:
        config_type = {"float": _NUMBER, "int": _INTEGER, "text": _TEXT, "choice": _TEXT}.get(cli_type, "")
    return Option(name, default, kind, unit, section, doc, flag, config, cli_type, choices, config_type, check)


# fmt: off
#: Every option of :func:`tribodyn.analyze`, in the order of its signature.
OPTIONS: Tuple[Option, ...] = (
    _opt(name="fs", default=None, kind="source", unit="Hz", section="6", doc="sampling rate (default: the recording's)",
         flag="--fs", cli_type="float", check="sampling rate"),
    _opt(name="window", default=None, kind="plan", unit="s", section="6b",
         doc="window length (default 2 s; slow recordings: from the rate)", flag="--window", cli_type="float"),
    _opt(name="hop", default=None, kind="plan", unit="s", section="6b",
         doc="window start spacing (default 10 s; = window tiles)", flag="--hop", cli_type="float"),
    _opt(name="highpass", default=None, kind="plan", unit="Hz", section="2",
         doc="high-pass raw DC-coupled forces first (None: dynamic forces)", flag="--highpass", cli_type="float",
         check="number > 0 or None"),
    _opt(name="orientation", default="auto", kind="plan", unit="", section="0",
         doc="s in mu = s * slope: +1, -1 or auto (once per recording)", flag="--orientation", cli_type="orientation",
         config_type='"auto", 1 or -1', check="orientation"),
    _opt(name="temperature", default=None, kind="log", unit="degC", section="6",
         doc="temperature log (t_s, T), interpolated at window centres", flag="--temperature", cli_type="log",
         config_type="a string", check="log or None"),
    _opt(name="current", default=None, kind="log", unit="A", section="6",
         doc="current log (t_s, i) or constant, when the source has no i channel", check="constant or log"),
    _opt(name="voltage", default=None, kind="log", unit="V", section="6",
         doc="shunt voltage log (t_s, u) or constant (needs shunt_ohm)", check="constant or log"),
    _opt(name="shunt_ohm", default=None, kind="plan", unit="ohm", section="6", doc="shunt resistance R: i = u / R",
         flag="--shunt", cli_type="float", check="number > 0 or None"),
    _opt(name="area_mm2", default=None, kind="plan", unit="mm^2", section="7", doc="contact area: J = i / area",
         flag="--area", cli_type="float", check="number > 0 or None"),
    _opt(name="covariates", default=None, kind="log", unit="", section="7a",
         doc="other logs by name (speed: the Stribeck curve)", flag="--covariate", cli_type="covariate",
         config_type='a table of name = "log file"', config="covariates", check="covariate logs"),
    _opt(name="chunk", default=None, kind="plan", unit="s", section="9",
         doc="seconds read per chunk (memory bound; never changes a result)", flag="--chunk", cli_type="float",
         check="number > 0 or None"),
    _opt(name="progress", default=False, kind="plan", unit="", section="9", doc="a progress bar on stderr",
         check="truth value"),
    _opt(name="deadband", default=0.35, kind="plan", unit="N", section="4",
         doc="|fz| below it is left out of the bins and mu_a, mu_b: a force (default 0.35) or e.g. 0.7sigma",
         flag="--deadband", cli_type="deadband",
         config_type='a number (N) or a string such as "0.7sigma"', check="deadband"),
    _opt(name="n_bins", default=16, kind="plan", unit="", section="4",
         doc="normal-force bins (default 16; at most 1024, about 4 samples each)", flag="--bins", cli_type="int"),
    _opt(name="gate", default=None, kind="plan", unit="", section="5",
         doc="quality gate: ci (default) or a |C_yz(0)| threshold (paper 0.85)", flag="--gate", cli_type="gate",
         config_type='a number (|C_yz| threshold) or "ci"'),
    _opt(name="max_lag", default=None, kind="plan", unit="samples", section="3e",
         doc="per-window channel-skew check up to this lag", flag="--max-lag", cli_type="int",
         check="integer >= 0 or None"),
    _opt(name="rpm", default=None, kind="plan", unit="1/min", section="3e",
         doc="rotating speed: the instrument lag and the rig's lines", flag="--rpm", cli_type="float"),
    _opt(name="n_lamellas", default=None, kind="plan", unit="", section="3e",
         doc="commutator lamellas: the lamella line f_l", flag="--lamellas", cli_type="int"),
    _opt(name="threads", default=None, kind="plan", unit="", section="9",
         doc="kernel threads of this call (default: every core)", flag="--threads", cli_type="int", check="threads"),
    _opt(name="start", default=0, kind="plan", unit="samples", section="9",
         doc="first sample of the source within the recording", check="integer >= 0"),
    _opt(name="stop", default=None, kind="plan", unit="samples", section="9",
         doc="a recording's sample where reading ends (exclusive)", check="integer >= 0 or None"),
    _opt(name="estimator", default=None, kind="plan", unit="", section="3a",
         doc="slope estimator: corrected (default), iv, ols or deming", flag="--estimator", cli_type="choice",
         choices=("corrected", "iv", "ols", "deming")),
    _opt(name="method", default=None, kind="plan", unit="", section="3a",
         doc="paper: the paper's method exactly (OLS, |C_yz| >= 0.85)", flag="--method", cli_type="choice",
         choices=("paper",)),
    _opt(name="max_rel_ci", default=None, kind="plan", unit="", section="5",
         doc="gate ci: largest expected relative half-width (default 0.1)", flag="--max-rel-ci", cli_type="float"),
    _opt(name="align", default=None, kind="plan", unit="", section="3e",
         doc="auto: measure the fz delay at the rig's lines and correct it", flag="--align", cli_type="choice",
         choices=("auto",)),
    _opt(name="iv_lag", default=None, kind="plan", unit="s", section="3b",
         doc="instrument lag (default one revolution with rpm)", flag="--iv-lag", cli_type="float"),
    _opt(name="noise", default=None, kind="plan", unit="N", section="3c",
         doc="(sigma_y, sigma_z): measurement noise (deming needs it)", flag="--noise", cli_type="pair",
         config_type="a list of two numbers [sigma_y, sigma_z] in N"),
    _opt(name="motion", default="auto", kind="plan", unit="", section="6c",
         doc="auto, unidirectional or reciprocating (per-stroke table)", flag="--motion", cli_type="choice",
         choices=("auto", "unidirectional", "reciprocating"), check="choice"),
    _opt(name="min_fn", default=None, kind="plan", unit="N", section="6a",
         doc="classical COF: least |fz| in contact (default from the data)", flag="--min-fn", cli_type="float",
         check="force >= 0 or None"),
    _opt(name="tare", default=None, kind="plan", unit="s or N", section="6a",
         doc="classical COF: auto (unloaded samples, before the first contact when there are some), start (only "
             "before the first contact), none (fy not tared: a drag stays in the friction), seconds without contact "
             "at the start, or offsets fy=N,fz=N", flag="--tare", cli_type="tare",
         config_type="auto, start, none, a number of seconds or a table of offsets", check="tare"),
    _opt(name="stroke_fraction", default=0.5, kind="plan", unit="", section="6c",
         doc="reciprocating: central part of each stroke", flag="--stroke-fraction", cli_type="float",
         check="fraction"),
    _opt(name="stick_slip", default=False, kind="plan", unit="", section="6g",
         doc="also find stick-slip events, in the same reading (Results.stick_slip)", check="truth value"),
    _opt(name="uncertainty", default=None, kind="plan", unit="", section="6i",
         doc="instrument budget: fy_rel, fz_rel, fy_abs, fz_abs, misalignment_deg, crosstalk (standard uncertainties)",
         flag="--uncertainty", cli_type="uncertainty",
         config_type="a table of key = standard uncertainty or {u, distribution, dof}", check="uncertainty inputs"),
    _opt(name="load", default=None, kind="source", unit="N", section="6a",
         doc="a constant normal force for a file without a load channel (fz)", flag="--load", cli_type="float"),
    _opt(name="channels", default=None, kind="source", unit="", section="6f",
         doc="role -> column of a DataFrame, or channel of a file", flag="--map", cli_type="map",
         config_type='a table of role = "channel" (or a string "fy=Ft,fz=Fn")', config="map"),
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
