"""The ``tribodyn`` command line.

Sub-commands: ``demo`` (simulate the paper's tests, analyse, report),
``analyze`` (your recordings), ``compare`` (replicate tests: the outputs of
``analyze``), ``info`` (what a file holds) and ``simulate`` (write a
simulated recording). User errors (bad options, config values,
paths, unreadable inputs, an unusable output folder, a full disk or a
read-only file system) print one line on stderr and exit with status 2 (no
traceback unless ``--debug``); a bug exits with status 1 and a traceback.
When several recordings are analysed and some fail, the others are written,
the failures are listed in ``summary.json`` and on stderr, and the status is
3. Warnings are lines starting with ``tribodyn: warning:``.

``--out`` is written as one unit (:class:`tribodyn.app.outputs.OutputSet`): it
then holds the new set and nothing else, or, after a failure or an
interruption, what it held before. A non-empty folder that does not hold a
previous tribodyn output set is refused unless ``--overwrite``.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import stat
import sys
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Type

__all__ = ["main"]

EXIT_USER_ERROR = 2
#: Some recordings of a multi-file analysis failed (the others were written).
EXIT_SOME_FAILED = 3
#: stdout's reader went away (``tribodyn analyze ... | head -1``): the status of a process a closed pipe stops
#: (128 + SIGPIPE), with no message; the outputs were published before the summary was printed.
EXIT_PIPE_CLOSED = 141


#: Roles --map may name (tribodyn.io.base.KNOWN_ROLES and the stroke roles x position, v velocity of
#: docs/method.md 6c, kept here so the CLI starts fast).
ROLES = ("fx", "fy", "fz", "i", "u", "cof", "x", "v")

#: Unknown roles that are common names of a valid one (for the error message).
_ROLE_GUESSES = {
    "fn": "fz",
    "n": "fz",
    "load": "fz",
    "ft": "fy",
    "ff": "fy",
    "mu": "cof",
    "current": "i",
    "voltage": "u",
}

#: How the analysis says a recording has no fy/fz channel (tribodyn.analyze).
_MISSING_CHANNELS = "lacks the required channel(s)"


class UserError(Exception):
    """A problem with the user's input or options: one line, no traceback."""


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line usage error (status 2) instead of the usage block."""

    def error(self, message: str) -> Any:
        self.exit(EXIT_USER_ERROR, f"tribodyn: error: {message} (see {self.prog} --help)\n")


def _kv(text: str, what: str, convert: Callable[[str], Any] = str) -> Dict[str, Any]:
    out: Dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        if "=" not in part:
            raise UserError(f"--{what} takes ROLE=VALUE pairs separated by commas, got {part!r}")
        k, v = part.split("=", 1)
        if not k.strip():
            raise UserError(f"--{what}: {part!r} names no role")
        try:
            out[k.strip()] = convert(v.strip())
        except ValueError:
            raise UserError(f"--{what}: {v.strip()!r} is not a number") from None
    return out


def _role_map(pairs: Mapping[Any, Any], where: str) -> Dict[str, str]:
    """Role -> channel, roles checked against ROLES (case-insensitive), channel names kept as given."""
    out: Dict[str, str] = {}
    for key, name in pairs.items():
        role = str(key).strip().lower()
        if role not in ROLES:
            guess = f" (did you mean {_ROLE_GUESSES[role]}?)" if role in _ROLE_GUESSES else ""
            raise UserError(f"{where}: unknown role {str(key).strip()!r}; valid roles: {', '.join(ROLES)}{guess}")
        if not isinstance(name, str):
            raise UserError(f"{where}: the channel of role {role} must be a name (text), got {name!r}")
        if not name.strip():
            raise UserError(f"{where}: role {role} needs a channel name ({role}=CHANNEL)")
        out[role] = name.strip()
    return out


def _covariate_name(name: str, where: str) -> str:
    """A covariate log's name, checked (an identifier; not temperature, current or voltage: their own options)."""
    name = name.strip()
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise UserError(f"{where}: a covariate name must be letters, digits and _, got {name!r}")
    if name == "temperature":
        raise UserError(f"{where}: give the temperature log with --temperature FILE (it gets branches and checks)")
    if name in ("current", "voltage"):
        role = {"current": "i", "voltage": "u"}[name]
        raise UserError(f"{where}: the {name} comes from a channel (--map {role}=CHANNEL), not from a covariate log")
    return name


def _covariate_option(text: str) -> Tuple[str, str]:
    """--covariate NAME=FILE as (name, file)."""
    name, sep, path = text.partition("=")
    if not sep or not path.strip():
        raise UserError(f"--covariate takes NAME=FILE (e.g. speed=speed.csv), got {text!r}")
    return _covariate_name(name, "--covariate"), path.strip()


def _orientation(text: str) -> Any:
    if text == "auto":
        return "auto"
    if text in ("1", "+1", "-1"):
        return int(text)
    raise argparse.ArgumentTypeError("orientation must be auto, +1 or -1")


def _gate(text: str) -> Any:
    if text == "ci":
        return "ci"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("gate must be ci or a number in [0, 1]") from None


def _pair(text: str) -> Any:
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError("noise must be SY,SZ: two numbers in N, e.g. 0.01,0.005") from None
    return (a, b)


def _tare(text: str) -> Any:
    from ..options import TARE_MODES

    if text.strip().lower() in TARE_MODES:
        return text.strip().lower()
    try:
        return float(text)
    except ValueError:
        pass
    try:
        return {k: float(v) for k, v in _kv(text, "tare", float).items()}
    except UserError as exc:
        raise argparse.ArgumentTypeError(
            f"tare must be auto, start, none, seconds or fy=N,fz=N offsets ({exc})"
        ) from None


def _deadband(text: str) -> Any:
    try:
        return float(text)
    except ValueError:
        return text


def _add_analysis_options(a: argparse.ArgumentParser) -> None:
    """The flags of ``analyze``'s options, from their one declaration (:data:`tribodyn.options.OPTIONS`).

    The channel map (``--map``), the logs read from files (``--temperature``,
    ``--covariate``) are added by :func:`_parser` itself: their values are
    files or lists, not the option's value.
    """
    from ..options import OPTIONS

    parse: Dict[str, Callable[[str], Any]] = {
        "float": float, "int": int, "text": str, "orientation": _orientation, "deadband": _deadband, "gate": _gate,
        "pair": _pair, "tare": _tare,
    }  # fmt: skip
    for o in OPTIONS:
        if o.flag is None or o.cli_type in ("map", "log", "covariate", "uncertainty"):
            continue
        unit = f" [{o.unit}]" if o.unit else ""
        text = f"{o.doc}{unit}; docs/method.md {o.section}".replace("%", "%%")
        if o.cli_type == "choice":
            a.add_argument(o.flag, choices=list(o.choices), help=text)
        else:
            a.add_argument(o.flag, type=parse[o.cli_type], help=text)


def _add_reading_options(a: argparse.ArgumentParser) -> None:
    """How a file is read, the same flags for ``analyze`` and ``info`` (``--fs`` and ``--load`` are options of
    :data:`tribodyn.options.OPTIONS`, added with the analysis's; ``info`` adds them itself)."""
    a.add_argument("--format", help="file format (default: from the extension and content)")
    a.add_argument(
        "--map",
        action="append",
        help="channel map ROLE=CHANNEL,... (roles fx, fy, fz, i, u, cof, x position, v velocity; any case); "
        "may be repeated",
    )
    a.add_argument(
        "--scale",
        action="append",
        help="unit factors to SI, ROLE=FACTOR,... (e.g. fz=0.00980665 for gram-force; replaces the reader's "
        "own conversion); may be repeated",
    )
    a.add_argument("--time-column", help="text files: the column holding time (gives fs; restarts split segments)")
    a.add_argument("--encoding", help="text files: the encoding (default: detected; e.g. cp932, utf-16, latin-1)")
    a.add_argument("--resample", type=float, help="text files with irregular time: interpolate linearly at HZ")
    a.add_argument("--sheet", help=_SHEET_HELP)


def _open_options(ns: argparse.Namespace, cfg: Mapping[str, Any]) -> Dict[str, Any]:
    """The keywords of ``open_recording`` from the reading flags (``--config`` values where a flag is not
    given): one builder for ``analyze`` and ``info``, so that ``info`` shows what ``analyze`` reads."""

    def get(key: str) -> Any:
        return getattr(ns, key) if getattr(ns, key, None) is not None else cfg.get(key)

    channels: Dict[str, str] = dict(cfg.get("map") or {})
    for text in getattr(ns, "map", None) or ():  # repeated --map options add up; a later role wins
        channels.update(_role_map(_kv(text, "map"), "--map"))
    scale: Dict[str, float] = dict(cfg.get("scale") or {})
    for text in getattr(ns, "scale", None) or ():
        scale.update(_kv(text, "scale", float))
    open_opts: Dict[str, Any] = {}
    if get("format"):
        open_opts["format"] = get("format")
    if channels:
        open_opts["channels"] = channels
    if scale:
        open_opts["scale"] = scale
    fs = get("fs")
    if fs is not None:
        open_opts["fs"] = float(fs)
    for key in ("time_column", "encoding", "resample", "sheet", "load"):
        if get(key) is not None:
            open_opts[key] = get(key)
    return open_opts


def _add_budget_options(a: argparse.ArgumentParser) -> None:
    """``--uncertainty KEY=VALUE`` (repeated) and ``--calibration FILE``: the budget (docs/method.md 6i)."""
    a.add_argument(
        "--uncertainty",
        action="append",
        dest="uncertainty_items",
        metavar="KEY=VALUE",
        help="the instrument's budget (docs/method.md 6i): KEY is fy_rel, fz_rel, fy_abs, fz_abs, misalignment_deg, "
        "crosstalk (VALUE: standard uncertainty U, U:DISTRIBUTION or U:normal:DOF) or misalignment_bias_deg "
        "(degrees, corrected); may be repeated; wins over --calibration and [uncertainty] in --config",
    )
    a.add_argument(
        "--calibration",
        metavar="FILE",
        help='TOML file of the instrument\'s uncertainties (the --uncertainty keys; instrument = "name")',
    )


def _parser() -> argparse.ArgumentParser:
    # Global options go before or after the sub-command: the sub-commands' copies
    # default to SUPPRESS so they never overwrite a value given before it.
    common = _Parser(add_help=False)
    common.add_argument("--quiet", "-q", action="store_true", default=argparse.SUPPRESS, help=_QUIET_HELP)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG_HELP)

    p = _Parser(prog="tribodyn", description="Coefficient of friction from measured dynamic forces.")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    p.add_argument("--quiet", "-q", action="store_true", default=False, help=_QUIET_HELP)
    p.add_argument("--debug", action="store_true", default=False, help=_DEBUG_HELP)
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    d = sub.add_parser("demo", parents=[common], help="simulate the paper's two tests, analyse them, write a report")
    d.add_argument("--out", default="tribodyn-demo", help="output directory (default: ./tribodyn-demo)")
    d.add_argument("--seed", type=int, default=0, help="simulation seed")
    d.add_argument("--overwrite", action="store_true", help=_OVERWRITE_HELP)

    _add_analyze_command(
        sub.add_parser("analyze", aliases=["analyse"], parents=[common], help="analyse recording files")
    )
    _add_compare_command(
        sub.add_parser("compare", parents=[common], help="compare replicate tests (output folders of analyze)")
    )

    _add_watch_command(
        sub.add_parser(
            "watch",
            parents=[common],
            help="follow a recording being written: its COF as it grows, trip rules, a live page",
        )  # fmt: skip
    )

    i = sub.add_parser("info", parents=[common], help="channels, units, fs, duration and size of files")
    i.add_argument("files", nargs="+", metavar="FILE", help="recordings, directories or glob patterns")
    i.add_argument("--json", action="store_true", help="print one JSON document (a list, one object per file)")
    _add_reading_options(i)  # the same reading flags as analyze: info shows what analyze reads
    i.add_argument("--fs", type=float, help="sampling rate in Hz (when the file has none)")
    i.add_argument("--load", type=float, help="a constant normal force [N] for a file without a load channel (as "
                   "analyze's --load: fz is then that constant); docs/method.md 6a")  # fmt: skip

    s = sub.add_parser("simulate", parents=[common], help="write a simulated recording (npz, h5 or tdms)")
    s.add_argument("scenario", choices=["temperature", "current_density"], help="which test of the paper")
    s.add_argument("--out", required=True, help="output file: .npz, .h5/.hdf5 or .tdms")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--raw", action="store_true", help="DC-coupled forces (no amplifier high-pass)")
    s.add_argument("--skew", type=int, default=0, help="delay fz by this many samples")
    s.add_argument("--force-dependence", type=float, default=0.0, help="beta of mu = mu0 (1 + beta (N - N0)/N0)")
    return p


def _add_analyze_command(a: argparse.ArgumentParser) -> None:
    """The arguments of ``analyze``: the files, the output, how to read them, the analysis's options, the logs,
    the budget, where to run and what more to report."""
    a.add_argument(
        "files",
        nargs="+",
        metavar="FILE",
        help="recordings (TDMS, LVM, HDF5, NPY/NPZ, CSV/TSV, MAT, XLSX/XLS/ODS), directories (their files no "
        "reader takes, such as README.md, skipped) or glob patterns",
    )
    a.add_argument("--out", required=True, help="output directory (replaced as a whole by the new outputs)")
    a.add_argument("--overwrite", action="store_true", help=_OVERWRITE_HELP)
    a.add_argument("--config", help="TOML file with any of these options (command-line options win)")
    _add_reading_options(a)
    _add_analysis_options(a)
    a.add_argument("--temperature", help="temperature log file: two columns, time in s and degC")
    a.add_argument(
        "--covariate",
        action="append",
        metavar="NAME=FILE",
        help="another log file (two columns: time in s, value) interpolated at each window into the column NAME, "
        "e.g. speed=speed.csv (m/s: the Stribeck curve); may be repeated",
    )
    _add_budget_options(a)
    a.add_argument("--scheduler", help="run on Dask: a scheduler ADDRESS (tcp://host:8786) or 'local'")
    a.add_argument("--workers", type=int, default=None, help="worker processes for --scheduler local (default 2)")
    a.add_argument("--split", type=float, help="cut each recording into ranges of S seconds, one task each")
    a.add_argument(
        "--steady-state",
        action="store_true",
        help="also where the running-in ends and the steady-state COF (docs/method.md 6h)",
    )
    a.add_argument(
        "--figures",
        choices=("auto", "all", "none"),
        default="auto",
        help="PNG figures: auto (default) every figure when the headline is the dynamic COF, else neither the "
        "window diagnostics (Figs. 2-9) nor the COF against time (the report's interactive view shows it); all: "
        "every figure; none: no PNG, the quickest report (its interactive views stay)",
    )
    a.add_argument(
        "--meta",
        action="append",
        metavar="KEY=VALUE",
        help="test record field (materials, counterpart, load, speed, stroke, distance, temperature, humidity, "
        "lubricant, duration, operator, or your own key); may be repeated (docs/method.md 10c)",
    )


def _add_watch_command(w: argparse.ArgumentParser) -> None:
    """The arguments of ``watch`` (docs/method.md 11): the file, the output, the update and trip flags, and
    analyze's reading and analysis flags."""
    w.add_argument("file", metavar="FILE", help="the recording being written (CSV/TSV/LVM, TDMS, HDF5, ...)")
    w.add_argument("--out", required=True, help="output directory (replaced at each update; a second watch of it "
                   "is refused)")  # fmt: skip
    w.add_argument("--overwrite", action="store_true", help=_OVERWRITE_HELP)
    w.add_argument("--config", help="TOML file with any of these options (command-line options win)")
    w.add_argument("--interval", type=float, default=2.0, help="seconds between updates (default 2)")
    w.add_argument(
        "--until-idle",
        type=float,
        metavar="S",
        help="stop when the file has not grown for S seconds (default: run until interrupted)",
    )
    w.add_argument("--trip", action="append", metavar="RULE",
                   help="stop with status 3 when RULE holds: cof>X, cof<X, fn<X (each optionally 'for S s'), "
                   "stick-slip, contact-loss, 'no-data for S s'; may be repeated (docs/method.md 11)")  # fmt: skip
    w.add_argument("--on-trip", metavar="CMD", help="shell command run when a rule trips (environment: "
                   "TRIBODYN_TRIP_RULE, TRIBODYN_TRIP_TIME, TRIBODYN_TRIP_VALUE, TRIBODYN_OUT)")  # fmt: skip
    _add_reading_options(w)
    _add_analysis_options(w)
    w.add_argument("--temperature", help="temperature log file: two columns, time in s and degC")
    w.add_argument("--covariate", action="append", metavar="NAME=FILE", help="another log file (as analyze's)")
    _add_budget_options(w)
    w.add_argument("--meta", action="append", metavar="KEY=VALUE", help="test record field (as analyze's)")


def _add_compare_command(c: argparse.ArgumentParser) -> None:
    """The arguments of ``compare``: the output folders, the output, the names and groups of the tests."""
    c.add_argument("folders", nargs="+", metavar="OUT_DIR", help="output folders of tribodyn analyze (or summary.json)")
    c.add_argument("--out", required=True, help="output directory (replaced as a whole by the new outputs)")
    c.add_argument("--labels", help="test names, comma-separated: one per test (recording) or one per OUT_DIR")
    c.add_argument(
        "--groups",
        help="groups (laboratories, days), comma-separated, one per test or per OUT_DIR: adds the ISO 5725 "
        "repeatability and reproducibility",
    )
    c.add_argument(
        "--allow-mixed",
        action="store_true",
        help="compare headlines of different methods (a dynamic median and a classical mean differ)",
    )
    c.add_argument("--overwrite", action="store_true", help=_OVERWRITE_HELP)


_SHEET_HELP = "spreadsheets: the sheet to read, by name (default: the first sheet holding a numeric table)"
_QUIET_HELP = "no progress bar or summary (before or after the command)"
_DEBUG_HELP = "show tracebacks of errors (before or after the command)"
_OVERWRITE_HELP = "replace --out even when it holds files that are not a previous tribodyn output set"

# Config keys: what each must be (checked like the command-line options).
_NUMBER, _INTEGER, _TEXT = "a number", "an integer", "a string"


def _config_keys() -> Dict[str, str]:
    """Every ``--config`` key and what its value must be: the reading options, then the analysis's (one declaration)."""
    from ..options import OPTIONS

    keys = {
        "format": _TEXT,
        "scale": 'a table of role = number (or a string "fz=0.00980665")',
        "time_column": _TEXT,
        "encoding": _TEXT,
        "resample": _NUMBER,
        "sheet": _TEXT,
        "meta": "a table of field = text or number (the test record, docs/method.md 10c)",
    }
    keys.update({o.config: o.config_type for o in OPTIONS if o.config is not None})
    return keys


_CONFIG_KEYS: Dict[str, str] = _config_keys()


def _toml_type(v: Any) -> str:
    for t, name in ((bool, "a boolean"), (int, "an integer"), (float, "a float"), (str, "a string")):
        if isinstance(v, t):
            return name
    if isinstance(v, list):
        return "an array"
    if isinstance(v, dict):
        return "a table"
    return f"a TOML {type(v).__name__}"


def _config_value(key: str, shown: str, v: Any, where: str) -> Any:
    """The config value ``v`` of ``key`` checked and converted like the option, or UserError."""
    expected = _CONFIG_KEYS[key]
    is_int = isinstance(v, int) and not isinstance(v, bool)
    if expected in (_NUMBER, _INTEGER, _TEXT):
        out = _plain_config_value(expected, v, is_int)
    elif key in ("orientation", "gate", "noise", "tare", "deadband"):
        out = _option_config_value(key, v, is_int)
    else:
        out = _table_config_value(key, v, where)
    if out is _BAD:
        raise UserError(f"{where}: {shown} must be {expected}, got {v!r} ({_toml_type(v)})")
    return out


#: What a config value's converter returns for a value of the wrong type.
_BAD: Any = object()


def _plain_config_value(expected: str, v: Any, is_int: bool) -> Any:
    """A number (as float), an integer or a string, or :data:`_BAD`."""
    if expected == _NUMBER:
        return float(v) if is_int or isinstance(v, float) else _BAD
    if expected == _INTEGER:
        return v if is_int else _BAD
    return v if isinstance(v, str) else _BAD


def _option_config_value(key: str, v: Any, is_int: bool) -> Any:
    """The value of one of the options whose value is more than a number or a string, converted, or :data:`_BAD`."""
    from ..options import TARE_MODES

    if key == "orientation":
        if v == "auto" or (is_int and v in (1, -1)):
            return v
        if isinstance(v, str) and v in ("1", "+1", "-1"):
            return int(v)
        return _BAD
    if key == "gate":
        if v == "ci":
            return v
        return float(v) if is_int or isinstance(v, float) else _BAD
    if key == "noise":
        if (
            isinstance(v, list)
            and len(v) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
        ):
            return (float(v[0]), float(v[1]))
        return _BAD
    if key == "tare":
        if is_int or isinstance(v, float):
            return float(v)
        if isinstance(v, dict) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v.values()):
            return {str(k): float(x) for k, x in v.items()}
        if isinstance(v, str) and v.strip().lower() in TARE_MODES:
            return v.strip().lower()
        return _BAD
    # deadband
    if is_int or isinstance(v, float):
        return float(v)
    return _deadband(v) if isinstance(v, str) else _BAD


def _table_config_value(key: str, v: Any, where: str) -> Any:
    """A table (covariates, uncertainty, meta, map, scale) checked and converted, UserError, or :data:`_BAD`."""
    if key == "covariates":
        if not (isinstance(v, dict) and all(isinstance(x, str) for x in v.values())):
            return _BAD
        return {_covariate_name(str(k), f"{where}: covariates"): path for k, path in v.items()}
    if key == "uncertainty":
        return _uncertainty(v, f"{where}: [uncertainty]") if isinstance(v, dict) else _BAD
    if key == "meta":
        if not isinstance(v, dict):
            return _BAD
        from .record import parse_meta

        try:
            return parse_meta(v, f"{where}: [meta]")
        except ValueError as exc:
            raise UserError(str(exc)) from None
    if key == "map":
        if isinstance(v, str):
            return _role_map(_kv(v, "map"), f"{where}: map")
        if isinstance(v, dict):
            return _role_map(v, f"{where}: map")
        return _BAD
    # scale
    if isinstance(v, str):
        return _kv(v, "scale", float)
    if not isinstance(v, dict):
        return _BAD
    for k, f in v.items():
        if isinstance(f, bool) or not isinstance(f, (int, float)):
            raise UserError(f"{where}: scale.{k} must be a number, got {f!r} ({_toml_type(f)})")
    return {k: float(f) for k, f in v.items()}


def _uncertainty(v: Dict[str, Any], where: str) -> Dict[str, Any]:
    """An uncertainty table checked like ``analyze(uncertainty=...)`` (docs/method.md 6i), or UserError."""
    from ..kernels.uncertainty import parse_inputs

    try:
        parse_inputs(v)
    except (TypeError, ValueError) as exc:
        raise UserError(f"{where}: {exc}") from None
    return dict(v)


def _budget_options(ns: argparse.Namespace, cfg: Dict[str, Any]) -> Dict[str, Any]:
    """The instrument's budget: --calibration FILE, then [uncertainty] in --config, then --uncertainty (each wins)."""
    from ..kernels.uncertainty import parse_item

    out: Dict[str, Any] = {}
    path = getattr(ns, "calibration", None)
    if path:
        out.update(_uncertainty(_read_toml(path, "calibration file"), f"calibration file {Path(path).name}"))
    out.update(cfg.get("uncertainty") or {})
    for text in getattr(ns, "uncertainty_items", None) or ():
        try:
            key, value = parse_item(text)
        except ValueError as exc:
            raise UserError(str(exc)) from None
        out[key] = value
    return _uncertainty(out, "--uncertainty") if out else out


def _read_toml(path: str, what: str) -> Dict[str, Any]:
    """A TOML file as a dict, or UserError naming ``what``."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python < 3.11
        try:
            import tomli as tomllib
        except ImportError:
            raise UserError(f"{what} needs the tomli package on Python < 3.11 (pip install tomli)") from None
    p = Path(path)
    if not p.is_file():
        raise UserError(f"{what} not found: {p}")
    try:
        with open(p, "rb") as f:
            return dict(tomllib.load(f))
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{what} {p.name} is not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise UserError(f"{what} {p.name} is not valid TOML: not UTF-8 text") from None


def _load_config(path: str) -> Dict[str, Any]:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python < 3.11
        try:
            import tomli as tomllib
        except ImportError:
            raise UserError("--config needs the tomli package on Python < 3.11 (pip install tomli)") from None
    p = Path(path)
    if not p.is_file():
        raise UserError(f"config file not found: {p}")
    try:
        with open(p, "rb") as f:
            raw = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"config file {p.name} is not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise UserError(f"config file {p.name} is not valid TOML: not UTF-8 text") from None
    except RecursionError:  # issue 34: arrays or tables nested hundreds deep
        raise UserError(f"config file {p.name}: values nested too deeply (no option takes nested values)") from None
    unknown = sorted(k for k in raw if k.replace("-", "_") not in _CONFIG_KEYS)
    if unknown:
        raise UserError(f"config file {p.name}: unknown option(s) {', '.join(unknown)}")
    return {
        k.replace("-", "_"): _config_value(k.replace("-", "_"), k, v, f"config file {p.name}") for k, v in raw.items()
    }


def _analysis_options(ns: argparse.Namespace) -> Tuple[Dict[str, Any], Dict[str, Any], List[Any]]:
    from ..options import OPTIONS

    cfg = _load_config(ns.config) if ns.config else {}

    def get(key: str) -> Any:
        return getattr(ns, key) if getattr(ns, key, None) is not None else cfg.get(key)

    open_opts = _open_options(ns, cfg)
    opts: Dict[str, Any] = {}
    for o in OPTIONS:  # the analysis's options by flag or config key (one declaration: tribodyn.options)
        if o.kind == "plan" and o.config is not None:
            v = get(o.config)
            if v is not None:
                opts[o.name] = v
    rpm, lamellas = opts.get("rpm"), opts.get("n_lamellas")
    if rpm is not None and not (math.isfinite(rpm) and rpm > 0):
        raise UserError(f"--rpm must be a finite number > 0, got {rpm!r}")
    if lamellas is not None and lamellas < 1:
        raise UserError(f"--lamellas must be at least 1, got {lamellas!r}")
    if cfg.get("meta") or ns.meta:
        from .record import Meta, merge, parse_meta

        pairs = [tuple(t.split("=", 1)) if "=" in t else (t, None) for t in ns.meta or ()]
        bad = [k for k, v in pairs if v is None]
        if bad:
            raise UserError(f"--meta takes KEY=VALUE, got {bad[0]!r}")
        try:
            opts["meta"] = merge(cfg.get("meta") or Meta(), parse_meta(pairs, "--meta"))
        except ValueError as exc:
            raise UserError(str(exc)) from None
    budget = _budget_options(ns, cfg)
    if budget:
        opts["uncertainty"] = budget
    logs: Dict[str, str] = dict(cfg.get("covariates") or {})
    for text in ns.covariate or ():  # repeated --covariate options add up; a later name wins
        name, path = _covariate_option(text)
        logs[name] = path
    protect = [p for p in (ns.config, getattr(ns, "calibration", None), get("temperature"), *logs.values()) if p]
    if get("temperature") or logs:
        from .jobs import read_log

        if get("temperature"):
            opts["temperature"] = read_log(get("temperature"))
            opts["temperature_file"] = str(get("temperature"))  # named in the report's inputs (not an analysis option)
        if logs:  # docs/method.md 7a
            opts["covariates"] = {name: read_log(path) for name, path in logs.items()}
            opts["covariate_files"] = dict(logs)  # named in the report's inputs (not an analysis option)
    return open_opts, opts, protect


def _check_present(paths: Sequence[str]) -> None:
    """Refuses inputs that do not exist (a typo among several: one line, before any recording is read; it was a
    failed recording, status 3, after the others' analysis), naming each."""
    missing = [p for p in paths if not os.path.exists(p)]
    others = " (nothing analysed)" if len(missing) < len(paths) else ""
    if len(missing) == 1:
        raise UserError(f"{missing[0]}: no such file{others}")
    if missing:
        raise UserError(f"no such files: {', '.join(missing)}{others}")


def _check_regular(paths: Sequence[str]) -> None:
    """Refuses inputs that are not regular files (a pipe would block the reader forever)."""
    for p in paths:
        try:
            mode = os.stat(p).st_mode
        except OSError:
            continue  # the reader says what is wrong
        if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
            raise UserError(f"{p}: not a regular file (a pipe, socket or device?)")


def _warn_converted(files: Sequence[str], open_opts: Dict[str, Any]) -> None:
    """Warns when --scale targets a channel the reader converts to SI itself (the factor replaces that)."""
    from ..io import open_recording

    plain = {k: v for k, v in open_opts.items() if k != "scale"}
    for f in files:
        try:
            with open_recording(f, **plain) as rec:
                infos = list(rec.channels)
                roles = dict(rec.roles)
        except Exception:  # the analysis reports what is wrong with the file
            continue
        for key, factor in open_opts["scale"].items():
            name = roles.get(key, key)
            info = next((c for c in infos if c.name == name), None)
            info = info or next((c for c in infos if c.name.lower() == str(name).lower()), None)
            if info is None or (info.scale == 1.0 and "convert" not in info.note.lower()):
                continue
            how = info.note or f"x{info.scale:g}"
            print(
                f"tribodyn: warning: {Path(f).name}: --scale {key}={factor:g} replaces the reader's own conversion "
                f"of channel {info.name!r} ({how}); the factor must take the file's raw values "
                f"({info.raw_unit or 'no unit'}) to SI, it is not applied on top",
                file=sys.stderr,
            )


def _channels_hint(message: str, files: Sequence[str], open_opts: Dict[str, Any]) -> str:
    """A 'lacks the required channel(s)' message with the file's channels and the --map option."""
    if _MISSING_CHANNELS not in message:
        return message
    path = files[0] if len(files) == 1 else None
    for f in files:
        if message.startswith(f"{Path(f).name}:"):
            path = f
    if path is None:
        return f"{message}; map channels with --map ROLE=CHANNEL"
    from ..io import open_recording
    from ..io.roles import missing_roles

    try:
        with open_recording(path, **open_opts) as rec:
            missing, mapped, shown = missing_roles(dict(rec.roles), list(rec.channel_names))
    except Exception:
        return f"{message}; map channels with --map ROLE=CHANNEL"
    missing = missing or ["fy", "fz"]
    example = ",".join(f"{r}=CHANNEL" for r in missing)
    return (
        f"{Path(path).name} {_MISSING_CHANNELS} {', '.join(missing)} (mapped: {mapped}); "
        f"its channels: {shown}; map them with --map ROLE=CHANNEL, e.g. --map {example}"
        + ("; or, for a test whose load is a constant, give it with --load N" if missing == ["fz"] else "")
    )


def _progress_wanted(ns: argparse.Namespace) -> bool:
    """A progress bar only for a person watching: stderr is a terminal and no --quiet."""
    return not ns.quiet and sys.stderr.isatty()


def _print_breakpoints(rng: Dict[str, Any], s: Dict[str, Any]) -> None:
    """The verdict and the breakpoints with their 95 % intervals next to the simulator's truth (docs/method.md 7)."""
    if not rng.get("verdict"):
        return
    from ._labels import fmt_interval, fmt_number, fmt_range, unit_text

    print(f"  verdict: {rng['verdict']}")
    unit = unit_text(rng["unit"])
    sim, bath = s.get("simulated_optimum") or {}, s.get("simulated_breakpoints") or {}
    fits = {"all": rng, **{k[4:]: v for k, v in rng.items() if k.startswith("fit_")}}
    for name, f in fits.items():
        if not f or not f.get("optimum") or not f.get("optimum_ci"):
            continue
        (lo, hi), (lci, hci) = f["optimum"], f["optimum_ci"]

        def iv(ci: Any) -> str:
            return fmt_interval(ci) or "[-]"

        line = f"  {name}: breakpoints {fmt_number(lo)} {iv(lci)} and {fmt_number(hi)} {iv(hci)} {unit}"
        truth = sim.get(rng["by"] if name == "all" else f"{rng['by']}_{name}")
        if truth:
            line += f"; simulated flat bottom {fmt_range(truth[0], truth[1], unit)}"
        b = bath.get(name)
        if b and b.get("lower") is not None and b.get("upper") is not None:
            line += f" (straight-wall fit of it: {fmt_range(b['lower'], b['upper'], unit)})"
        print(line)


def _print_demo(summary: Dict[str, Any], out: str) -> None:
    from ._labels import fmt_number, fmt_range, unit_text

    for key, label in (("temperature_test", "temperature test"), ("current_density_test", "current-density test")):
        s = summary[key]
        mu = s["mu_r"]
        rng = s["operating_range"] or {}
        print(f"{label}: {(s.get('headline') or {}).get('text', 'no headline')}")
        line = f"  {s['gated']}/{s['windows']} windows pass the gate"
        if mu.get("n"):
            line += f"; 90 % of them between {mu['p05']:.3f} and {mu['p95']:.3f}"
        unit = unit_text(rng.get("unit"))
        if rng.get("optimum"):
            lo, hi = rng["optimum"]
            line += f"; optimum {fmt_range(lo, hi, unit, ci=rng.get('optimum_ci'))} (COF {rng['mu_min']:.3f})"
        if rng.get("onset") is not None:
            line += f"; steep rise from {fmt_number(rng['onset'])} {unit}"
        print(line)
        _print_breakpoints(rng, s)
    print(f"outputs in {out}/ (report.html, summary.json, *_windows.csv, figures/)")


def _tribometer_lines(s: Dict[str, Any]) -> List[str]:
    """The instrument's COF beside the headline, the strokes, the contact rule, the role map and the window."""
    out: List[str] = []
    ins, st = s.get("instrument_comparison") or {}, s.get("strokes") or {}
    parts = []
    if ins.get("mean") is not None:
        diff = ins.get("difference")
        d = f", {100 * diff:+.2f} % from the headline" if isinstance(diff, float) and math.isfinite(diff) else ""
        parts.append(f"instrument COF mean {ins['mean']:.4f} over {ins.get('over', 'the same samples')}{d}")
    for d in ("forward", "backward"):
        if (st.get(d) or {}).get("n"):
            parts.append(f"{d} strokes COF mean {st[d]['mean']:.4f} ({st[d]['n']} strokes)")
    if parts:
        out.append("; ".join(parts))
    slip = s.get("stick_slip") or {}
    if slip.get("present"):  # docs/method.md 6g: said only when present
        out.append(str(slip["verdict"]))
    contact = s.get("contact") or {}
    if contact.get("rule"):
        out.append(f"contact: {contact['rule']}")
    roles = s.get("roles") or {}
    source = s.get("roles_source")
    if roles and source in ("automatic", "partly given"):
        # The friction channel with its evidence when it was chosen among several (docs/method.md 6f).
        ev = s.get("roles_evidence") or {}
        shown = [
            f"{r} <- {ev['text']}" if r == "fy" and ev.get("text") and ev.get("rule") != "names" else f"{r} <- {n}"
            for r, n in roles.items()
        ]
        out.append(f"roles: {', '.join(shown)} ({source}; --map ROLE=CHANNEL to change)")
    if s.get("window_note"):
        out.append(str(s["window_note"]))
    return out


def _print_analysis(summary: Dict[str, Any], out: str) -> None:
    from ..results import verdict_text
    from ._labels import units_in_text

    for name, s in summary["recordings"].items():
        head = s.get("headline") or {}
        print(f"{name}: {head.get('text', 'no headline')}")
        if s.get("steady_state"):
            print(f"  {s['steady_state']['text']}")
        print(f"  {s['gated']}/{s['windows']} windows pass the dynamic method's gate")
        verdict = verdict_text(s.get("verdict"))
        if verdict:
            print(f"  verdict: {units_in_text(verdict)}")
        for line in _tribometer_lines(s):
            print(f"  {line}")
        for key in ("operating_range_temperature", "operating_range_current_density", "operating_range_speed"):
            rng = s.get(key) or {}
            if rng.get("optimum"):
                from ._labels import fmt_range

                lo, hi = rng["optimum"]
                where = fmt_range(lo, hi, rng["unit"], ci=rng.get("optimum_ci"))
                line = f"  optimum {rng['by'].replace('_', ' ')}: {where}"
                if rng.get("mu_min") is not None:
                    line += f" (COF {rng['mu_min']:.3f})"
                if rng.get("verdict"):
                    line += f"; {rng['verdict']}"
                print(line)
    if not summary["recordings"]:  # every recording failed: no report, summary.json lists the errors (status 3)
        print(f"no recording analysed: {out}/summary.json lists each failure")
        return
    print(f"outputs in {out}/ (open report.html)")


def _run(ns: argparse.Namespace) -> int:
    if ns.command == "demo":
        from .jobs import run_demo

        summary = run_demo(ns.out, seed=ns.seed, progress=_progress_wanted(ns), overwrite=ns.overwrite)
        if not ns.quiet:
            _print_demo(summary, ns.out)
        return 0
    if ns.command in ("analyze", "analyse"):
        return _run_analyze(ns)
    if ns.command == "compare":
        from .compare_job import cli_compare

        return cli_compare(ns)
    if ns.command == "info":
        return _run_info(ns)
    if ns.command == "watch":
        return _run_watch(ns)
    if ns.command == "simulate":
        return _run_simulate(ns)
    raise UserError("no command given (try: tribodyn demo)")


def _run_analyze(ns: argparse.Namespace) -> int:
    """``analyze``: the files' analysis into --out, the summary printed, each reader's warning and failure on
    stderr; the status is 3 when a file failed."""
    from ..pipeline.distributed import expand_paths
    from .jobs import check_distinct_names, run_analysis
    from .outputs import OutputSet

    from ..pipeline.plan import check_options

    open_opts, opts, protect = _analysis_options(ns)
    meta = opts.pop("meta", None)
    # an option bad for every file: one line before any is read (one failure per file); --fs too (a reader's option)
    check_options(**opts, **({} if "fs" in opts else {"fs": open_opts.get("fs")}))
    files = expand_paths(ns.files)  # (a folder's files no reader takes skipped: summary["skipped"] names them)
    _check_present(files)
    _check_regular(files)
    check_distinct_names(files)  # (before a Dask cluster is started)
    OutputSet(ns.out, overwrite=ns.overwrite, protect=[*files, *protect])  # refuse a bad --out before the work
    if open_opts.get("scale"):
        _warn_converted(files, open_opts)
    if ns.workers is not None and ns.scheduler != "local":  # (it was ignored without a word)
        raise UserError("--workers sets the worker processes of --scheduler local; give --scheduler local too"
                        if ns.scheduler is None else "--workers applies to --scheduler local only: a cluster at an "
                        "address has its own workers")  # fmt: skip
    client = _dask_client(ns) if ns.scheduler is not None else None
    try:
        summary = run_analysis(
            ns.files,
            ns.out,
            open_options=open_opts,
            analyze_options=opts,
            progress=_progress_wanted(ns),
            client=client,
            split=ns.split,
            overwrite=ns.overwrite,
            protect=protect,
            meta=meta,
            steady_state=ns.steady_state,
            figures=ns.figures,
        )
    except ValueError as exc:
        if _MISSING_CHANNELS in str(exc):
            raise UserError(_channels_hint(str(exc), files, open_opts)) from exc
        raise
    finally:
        if client is not None:
            from ..pipeline.distributed import close_quietly, silence_dask_logs

            interrupted = isinstance(sys.exc_info()[1], KeyboardInterrupt)
            if interrupted:  # (closing a client while it gathers logs each pending wait's AllExit with a traceback)
                silence_dask_logs()
            cluster = getattr(client, "cluster", None) if ns.scheduler == "local" else None
            # (Dask's shutdown logged a worker's heartbeat CommClosedError at ERROR at times)
            close_quietly(client, cluster, workers=not interrupted)
    if not ns.quiet:
        _print_analysis(summary, ns.out)
    _print_problems(summary, files, open_opts)
    return EXIT_SOME_FAILED if summary.get("failures") else 0


def _run_watch(ns: argparse.Namespace) -> int:
    """``watch``: a recording being written, its COF at each update, the analysis of the complete file at the end;
    status 3 when a trip rule ended it (docs/method.md 11)."""
    from .watch_job import run_watch

    open_opts, opts, protect = _analysis_options(ns)
    _check_regular([ns.file])
    return run_watch(ns, open_opts, opts, protect)


def _dask_client(ns: argparse.Namespace) -> Any:
    """The Dask client of ``--scheduler`` (with ``--workers`` for 'local'), or UserError."""
    from ..pipeline.distributed import connect

    ns.workers = 2 if ns.workers is None else ns.workers
    if ns.workers < 1:
        raise UserError("--workers must be at least 1")
    if not ns.scheduler.strip():  # (an empty address once ran serially, saying nothing)
        raise UserError("--scheduler needs an ADDRESS (tcp://host:8786) or 'local'")
    try:
        return connect(ns.scheduler, ns.workers)
    except ImportError as exc:
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"cannot reach the Dask scheduler {ns.scheduler}: {exc}") from None
    except ValueError as exc:  # Dask's address parsing ("missing port number in address 'x'")
        raise UserError(f"--scheduler {ns.scheduler}: {exc}; give an ADDRESS (tcp://host:8786) or 'local'") from None


def _print_problems(summary: Dict[str, Any], files: Sequence[str], open_opts: Dict[str, Any]) -> None:
    """The readers' warnings, once each (they are also in summary.json and the report), each failed file, and the
    folders' files no reader takes, skipped (one line), on stderr."""
    if summary.get("skipped"):
        from ..pipeline.distributed import skipped_text

        print(f"tribodyn: warning: {skipped_text(summary['skipped'])}", file=sys.stderr)
    for name, s in summary.get("recordings", {}).items():
        for w in dict.fromkeys(s.get("warnings") or ()):
            print(f"tribodyn: warning: {name}: {w}", file=sys.stderr)
    from .jobs import recording_labels

    names = recording_labels(files)  # (the failures' keys)
    for name, f in summary.get("failures", {}).items():
        err, paths = f["error"], [p for p in files if names.get(Path(p)) == name][:1]
        if _MISSING_CHANNELS in err:
            err = _channels_hint(err, paths, open_opts)
        print(f"tribodyn: warning: {name} failed: {_cli_words(_unnamed(err, name, paths))}", file=sys.stderr)


def _unnamed(err: str, name: str, paths: Sequence[str]) -> str:
    """A failure's error without the file's name at its start (after its kind, "RecordingError: "), which the line
    says once before it ("runA/x.csv failed: ..."): its label ``name`` or its file name ("run.npz lacks ..." said
    the name twice). A path that says more than the label (its folders: "m/b/t.tdms: truncated ..." of the label
    "t.tdms") is kept: it tells where the file is."""
    kind, sep, rest = err.partition(": ")
    head, text = (f"{kind}: ", rest) if sep and kind.isidentifier() and kind[:1].isupper() else ("", err)
    spelled = {name, *(Path(p).name for p in paths)}
    for said in sorted(spelled, key=len, reverse=True):
        for after in (": ", " "):
            if text.startswith(said + after) and len(text) > len(said + after):
                return head + text[len(said + after) :]
    return err


def _run_simulate(ns: argparse.Namespace) -> int:
    """``simulate``: one of the paper's simulated tests written as a recording file."""
    from .. import simulate
    from ..io.writers import save_recording

    _check_recording_target(ns.out)
    sim = simulate.scenario(ns.scenario, seed=ns.seed, raw=ns.raw, skew=ns.skew, force_dependence=ns.force_dependence)
    save_recording(ns.out, sim.channels, sim.fs, units={k: ("A" if k == "i" else "N") for k in sim.channels})
    if not ns.quiet:
        print(f"wrote {ns.out}: {sim.duration:g} s at {sim.fs:g} Hz, channels {', '.join(sim.channels)}")
    return 0


def _check_recording_target(path: str) -> None:
    """Refuses a simulate --out the writer would refuse, before the (long) simulation."""
    if os.path.isdir(path):
        raise UserError(f"{path} is a folder: give a file name (.npz, .h5/.hdf5 or .tdms)")
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".npz", ".h5", ".hdf5", ".hdf", ".tdms"):
        raise UserError(f"cannot write recordings as {ext!r}: use .npz, .h5/.hdf5 or .tdms")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise UserError(f"{path}: the folder {folder} does not exist")


def _run_info(ns: argparse.Namespace) -> int:
    """``info``: every file's format, size, fs, duration and channels; text or one JSON list.

    A file that cannot be read is reported (``"error"`` in JSON, a line on
    stderr) and the others are still shown; the status is then 3 (2 if none
    could be read).
    """
    import json

    from ..io import open_recording
    from ..pipeline.distributed import expand_paths

    kw = _open_options(ns, {})
    skipped: List[str] = []
    files = expand_paths(ns.files, skipped)
    if skipped:
        from ..pipeline.distributed import skipped_text

        print(f"tribodyn: warning: {skipped_text(skipped)}", file=sys.stderr)
    _check_regular(files)
    from .jobs import recording_labels

    names = recording_labels(files)  # (runA/data.tdms, runB/data.tdms: each header named as analyze names it)
    infos: List[Dict[str, Any]] = []
    failed = 0
    for f in files:
        try:
            infos.append(_jsonable(_file_info(open_recording, f, kw)))
        except _user_errors() as exc:
            if len(files) == 1 and not ns.json:
                raise
            failed += 1
            infos.append({"path": str(f), "error": _one_line(_cli_words(_error_text(exc)))})
            if not ns.json:
                print(f"tribodyn: error: {names[Path(f)]}: {infos[-1]['error']}", file=sys.stderr)
    if ns.json:
        print(json.dumps(infos, indent=2, ensure_ascii=False, allow_nan=False))
    else:
        for k, info in enumerate(i for i in infos if "error" not in i):
            if k:
                print()
            _print_info(info, names.get(Path(str(info.get("path")))))
    if failed:
        return EXIT_USER_ERROR if failed == len(files) else EXIT_SOME_FAILED
    return 0


def _file_info(open_recording: Any, path: str, kw: Dict[str, Any]) -> Dict[str, Any]:
    """``Recording.info()``; a file that does not carry its sampling rate is still described (fs unknown)."""
    from ..io.units import check_role_units

    try:
        with open_recording(path, **kw) as rec:
            # what analyze refuses of this map (docs/method.md 6f): said here too, so info shows what analyze reads
            return {**rec.info(), "analyze_refuses": check_role_units(rec.channels)[0]}
    except Exception as exc:
        if "fs" in kw or "sampling rate unknown" not in str(exc):
            raise
    # Open it once more with a stand-in rate (1 Hz) to list its channels; report no rate and no duration.
    with open_recording(path, **{**kw, "fs": 1.0}) as rec:
        info = dict(rec.info())
    info.update(fs=None, duration=None, fs_source="not in the file")
    return info


def _jsonable(v: Any) -> Any:
    """Plain JSON values: NaN/inf as None, NumPy scalars and arrays as numbers and lists, others as text."""
    if isinstance(v, Mapping):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if hasattr(v, "tolist"):
        return _jsonable(v.tolist())
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if v is None or isinstance(v, (bool, int, str)):
        return v
    return str(v)


def _size_text(n: Any) -> str:
    if not isinstance(n, int):
        return "unknown"
    for unit, f in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= f:
            return f"{n / f:.1f} {unit} ({n:,} bytes)"
    return f"{n} bytes"


def _duration_text(d: Any) -> str:
    if not isinstance(d, (int, float)):
        return "unknown"
    if d >= 3600:
        return f"{d:g} s ({d / 3600:.2f} h)"
    if d >= 60:
        return f"{d:g} s ({d / 60:.1f} min)"
    return f"{d:g} s"


def _print_info(info: Dict[str, Any], name: Optional[str] = None) -> None:
    """One file's info as aligned text under ``name`` (default its file name): the essentials, the channels as a
    table, metadata and warnings."""
    name = name or Path(str(info.get("path", "?"))).name
    print(name)
    print("=" * len(name))
    fs = info.get("fs")
    fs_text = f"{fs:g} Hz" if isinstance(fs, (int, float)) else "unknown (give --fs HZ)"
    if info.get("fs_source"):
        fs_text += f" ({info['fs_source']})"
    rows = [
        ("format", info.get("format")),
        ("size", _size_text(info.get("size_bytes"))),
        ("sampling rate", fs_text),
        ("samples", f"{info['n_samples']:,}" if isinstance(info.get("n_samples"), int) else "unknown"),
        ("duration", _duration_text(info.get("duration"))),
        ("segments", info.get("segments")),
    ]
    for key, val in rows:
        if val is not None:
            print(f"  {key + ':':<15}{val}")
    chans = [c for c in info.get("channels") or () if isinstance(c, Mapping)]
    if chans:
        print(f"  channels ({len(chans)}):")
        w = max(len(str(c.get("name"))) for c in chans)
        for c in chans:
            unit = c.get("unit") or "-"
            role = f"role {c['role']}" if c.get("role") else ""
            note = c.get("note") or ""
            print(f"    {str(c.get('name')):<{w}}  {unit:<8} {role:<8} {note}".rstrip())
    ev = info.get("roles_evidence") or {}
    if ev.get("text") and ev.get("rule") != "names":
        print(f"  friction:      fy <- {ev['text']}")
    meta = info.get("metadata") or {}
    if meta:
        print(f"  metadata ({len(meta)}):")
        for k, v in list(meta.items())[:40]:
            text = " ".join(str(v).split())
            print(f"    {k}: {text[:100] + '...' if len(text) > 100 else text}")
        if len(meta) > 40:
            print(f"    ... and {len(meta) - 40} more (--json shows all)")
    for wtext in info.get("warnings") or ():
        print(f"  warning: {wtext}")
    for etext in info.get("analyze_refuses") or ():
        print(f"  analyze refuses: {etext}")


def _user_errors() -> Tuple[Type[BaseException], ...]:
    errs: List[Type[BaseException]] = [
        UserError,
        ValueError,
        TypeError,
        OverflowError,
        # Missing or unusable paths, permissions, a full disk (ENOSPC), a
        # read-only file system (EROFS), a busy folder...: the user's to fix.
        OSError,
    ]
    try:
        from ..io import RecordingError

        errs.append(RecordingError)
    except ImportError:  # pragma: no cover
        pass
    return tuple(errs)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``tribodyn`` console script; returns the exit status."""
    parser = _parser()
    try:
        ns = parser.parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (one line, see _Parser.error)
        return exc.code if isinstance(exc.code, int) else EXIT_USER_ERROR
    if ns.version:
        from .._version import version

        __version__ = version()

        print(f"tribodyn {__version__}")
        return 0
    if ns.command is None:
        parser.print_help()
        return EXIT_USER_ERROR
    broken = _extension_missing()
    if broken:
        print(f"tribodyn: error: {broken}", file=sys.stderr)
        return EXIT_USER_ERROR
    try:
        return _run(ns)
    except BrokenPipeError:  # stdout's reader left (``| head``): nothing more to say, nothing half-written
        _stdout_gone()
        return EXIT_PIPE_CLOSED
    except KeyboardInterrupt:
        print(
            "tribodyn: interrupted (the output folder holds what it held before, or the whole new set)", file=sys.stderr
        )
        return 130
    except _user_errors() as exc:
        if getattr(ns, "debug", False):
            raise
        print(f"tribodyn: error: {_one_line(_cli_words(_error_text(exc)))}", file=sys.stderr)
        return EXIT_USER_ERROR


def _stdout_gone() -> None:
    """Points stdout at the null device, so that the interpreter's last flush of it raises nothing."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # (no file descriptor: a replaced sys.stdout)
        pass


def _extension_missing() -> str:
    """Why the compiled extension ``tribodyn._core`` cannot be loaded, in one line, or "" (``import tribodyn``
    loads it on first use, so a broken install shows here, not in a traceback of the command)."""
    try:
        from .. import _core  # noqa: F401 - loaded to check it loads
    except ImportError as exc:
        return (f"tribodyn's compiled extension (tribodyn._core) cannot be loaded ({_one_line(str(exc))}): "
                f"reinstall tribodyn for this Python ({sys.version.split()[0]}, {sys.executable})")  # fmt: skip
    return ""


# The staging/aside folders of tribodyn.app.outputs: errors name the output folder instead.
_WORK_DIR = re.compile(r"\.tribodyn-(?:staging|old)-\d+-[A-Za-z0-9_]+")


def _error_text(exc: BaseException) -> str:
    """The message of an error; an OSError as 'PATH: reason' (naming --out, not its staging folder)."""
    if isinstance(exc, OSError) and exc.strerror:
        names = [_WORK_DIR.sub("", str(n)) for n in (exc.filename, exc.filename2) if n is not None]
        if len(names) == 2:
            return f"cannot move {names[0]} to {names[1]}: {exc.strerror}"
        return f"{names[0]}: {exc.strerror}" if names else exc.strerror
    return str(exc) or type(exc).__name__


def _one_line(msg: str) -> str:
    return " ".join(msg.split()) if "\n" in msg or "\r" in msg else msg


def _cli_words(msg: str) -> str:
    """A library message in the CLI's terms (its options instead of Python keywords)."""
    msg = msg.replace("pass fs=... (Hz)", "give --fs HZ").replace("; pass fs=", "; give --fs HZ")
    msg = msg.replace("pass allow_mixed=True", "pass --allow-mixed")
    msg = msg.replace(  # (several files, --split or --scheduler: the command never named analyze_many)
        "analyze_many does not align (align='auto' reads a recording twice): use analyze per file",
        "--align auto reads a recording twice: give it one file at a time, without --split or --scheduler",
    )
    return msg.replace("pass overwrite=True", "pass --overwrite")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
