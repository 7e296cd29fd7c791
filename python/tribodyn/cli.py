"""The ``tribodyn`` command line.

Sub-commands: ``demo`` (simulate the paper's tests, analyse, report),
``analyze`` (your recordings), ``info`` (what a file holds) and ``simulate``
(write a simulated recording). User errors print one line and exit with
status 2 (no traceback unless ``--debug``); a bug exits with status 1 and a
traceback. When several recordings are analysed and some fail, the others
are written, the failures are listed in ``summary.json`` and on stderr, and
the status is 3.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

__all__ = ["main"]

EXIT_USER_ERROR = 2
#: Some recordings of a multi-file analysis failed (the others were written).
EXIT_SOME_FAILED = 3


class UserError(Exception):
    """A problem with the user's input or options: one line, no traceback."""


def _kv(text: str, what: str, convert=str) -> Dict[str, Any]:
    out: Dict[str, Any] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        if "=" not in part:
            raise UserError(f"--{what} takes ROLE=VALUE pairs separated by commas, got {part!r}")
        k, v = part.split("=", 1)
        try:
            out[k.strip()] = convert(v.strip())
        except ValueError:
            raise UserError(f"--{what}: {v.strip()!r} is not a number") from None
    return out


def _orientation(text: str) -> Any:
    if text == "auto":
        return "auto"
    if text in ("1", "+1", "-1"):
        return int(text)
    raise argparse.ArgumentTypeError("orientation must be auto, +1 or -1")


def _deadband(text: str) -> Any:
    try:
        return float(text)
    except ValueError:
        return text


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--quiet", "-q", action="store_true", help="no progress bar or summary")
    common.add_argument("--debug", action="store_true", help="show tracebacks of errors")

    p = argparse.ArgumentParser(prog="tribodyn", description="Coefficient of friction from measured dynamic forces.")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    d = sub.add_parser("demo", parents=[common], help="simulate the paper's two tests, analyse them, write a report")
    d.add_argument("--out", default="tribodyn-demo", help="output directory (default: ./tribodyn-demo)")
    d.add_argument("--seed", type=int, default=0, help="simulation seed")

    a = sub.add_parser("analyze", aliases=["analyse"], parents=[common], help="analyse recording files")
    a.add_argument(
        "files",
        nargs="+",
        metavar="FILE",
        help="recordings (TDMS, LVM, HDF5, NPY/NPZ, CSV/TSV), directories or glob patterns",
    )
    a.add_argument("--out", required=True, help="output directory")
    a.add_argument("--config", help="TOML file with any of these options (command-line options win)")
    a.add_argument("--format", help="file format (default: from the extension and content)")
    a.add_argument("--map", help="channel map ROLE=CHANNEL,... (roles fx, fy, fz, i, u, cof)")
    a.add_argument("--scale", help="unit factors to SI, ROLE=FACTOR,... (e.g. fz=0.00980665 for gram-force)")
    a.add_argument("--fs", type=float, help="sampling rate in Hz (when the file has none)")
    a.add_argument("--window", type=float, help="window length in s (default 2)")
    a.add_argument("--hop", type=float, help="window start spacing in s (default 10; = window tiles)")
    a.add_argument("--highpass", type=float, help="high-pass raw DC-coupled forces at HZ first (e.g. 0.1)")
    a.add_argument("--temperature", help="temperature log file: two columns, time in s and degC")
    a.add_argument("--area", type=float, help="contact area in mm^2 (for the current density)")
    a.add_argument("--shunt", type=float, help="shunt resistance in ohm (current = u / R)")
    a.add_argument("--rpm", type=float, help="rotating speed")
    a.add_argument("--lamellas", type=int, help="number of commutator lamellas")
    a.add_argument("--orientation", type=_orientation, help="auto (default), +1 or -1")
    a.add_argument("--deadband", type=_deadband, help="deadband in N (default 0.35) or e.g. 0.7sigma")
    a.add_argument("--bins", type=int, help="normal-force bins (default 16)")
    a.add_argument("--gate", type=float, help="quality gate on |C_yz(0)| (default 0.85)")
    a.add_argument("--max-lag", type=int, help="per-window channel-skew check up to this lag (samples)")
    a.add_argument("--chunk", type=float, help="seconds read per chunk (memory bound; default 60)")
    a.add_argument("--threads", type=int, help="kernel threads (default: all cores or TRIBODYN_THREADS)")
    a.add_argument("--scheduler", help="run on Dask: a scheduler ADDRESS (tcp://host:8786) or 'local'")
    a.add_argument("--workers", type=int, default=2, help="worker processes for --scheduler local (default 2)")
    a.add_argument("--split", type=float, help="cut each recording into ranges of S seconds, one task each")

    i = sub.add_parser("info", parents=[common], help="channels, units, fs, duration and size of a file")
    i.add_argument("file", metavar="FILE")
    i.add_argument("--format", help="file format (default: detected)")
    i.add_argument("--fs", type=float, help="sampling rate in Hz (when the file has none)")

    s = sub.add_parser("simulate", parents=[common], help="write a simulated recording (npz, h5 or tdms)")
    s.add_argument("scenario", choices=["temperature", "current_density"], help="which test of the paper")
    s.add_argument("--out", required=True, help="output file: .npz, .h5/.hdf5 or .tdms")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--raw", action="store_true", help="DC-coupled forces (no amplifier high-pass)")
    s.add_argument("--skew", type=int, default=0, help="delay fz by this many samples")
    s.add_argument("--force-dependence", type=float, default=0.0, help="beta of mu = mu0 (1 + beta (N - N0)/N0)")
    return p


_CONFIG_KEYS = {
    "format",
    "map",
    "scale",
    "fs",
    "window",
    "hop",
    "highpass",
    "temperature",
    "area",
    "shunt",
    "rpm",
    "lamellas",
    "orientation",
    "deadband",
    "bins",
    "gate",
    "max_lag",
    "chunk",
    "threads",
}


def _load_config(path: str) -> Dict[str, Any]:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python < 3.11
        import tomli as tomllib
    p = Path(path)
    if not p.is_file():
        raise UserError(f"config file not found: {p}")
    try:
        with open(p, "rb") as f:
            cfg = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"config file {p.name} is not valid TOML: {exc}") from None
    cfg = {k.replace("-", "_"): v for k, v in cfg.items()}
    unknown = set(cfg) - _CONFIG_KEYS
    if unknown:
        raise UserError(f"config file {p.name}: unknown option(s) {', '.join(sorted(unknown))}")
    return cfg


def _analysis_options(ns: argparse.Namespace) -> tuple:
    cfg = _load_config(ns.config) if ns.config else {}
    get = lambda key: getattr(ns, key) if getattr(ns, key, None) is not None else cfg.get(key)  # noqa: E731
    channels = cfg.get("map") or {}
    if isinstance(channels, str):
        channels = _kv(channels, "map")
    if ns.map:
        channels = {**channels, **_kv(ns.map, "map")}
    scale = cfg.get("scale") or {}
    if isinstance(scale, str):
        scale = _kv(scale, "scale", float)
    if ns.scale:
        scale = {**scale, **_kv(ns.scale, "scale", float)}
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
    opts: Dict[str, Any] = {}
    for key, name in (
        ("window", "window"),
        ("hop", "hop"),
        ("highpass", "highpass"),
        ("area", "area_mm2"),
        ("shunt", "shunt_ohm"),
        ("rpm", "rpm"),
        ("lamellas", "n_lamellas"),
        ("orientation", "orientation"),
        ("deadband", "deadband"),
        ("bins", "n_bins"),
        ("gate", "gate"),
        ("max_lag", "max_lag"),
        ("chunk", "chunk"),
        ("threads", "threads"),
    ):
        v = get(key)
        if v is not None:
            opts[name] = v
    if get("temperature"):
        from .jobs import read_log

        opts["temperature"] = read_log(get("temperature"))
    return open_opts, opts


def _progress_wanted(ns: argparse.Namespace) -> bool:
    return not ns.quiet and sys.stderr.isatty()


def _print_demo(summary: Dict[str, Any], out: str) -> None:
    for key, label in (("temperature_test", "temperature test"), ("current_density_test", "current-density test")):
        s = summary[key]
        mu = s["mu_r"]
        rng = s["operating_range"] or {}
        line = (
            f"{label}: {s['gated']}/{s['windows']} windows pass the gate; "
            f"COF {mu['p05']:.3f}..{mu['p95']:.3f} (median {mu['median']:.3f})"
        )
        if rng.get("optimum"):
            lo, hi = rng["optimum"]
            line += f"; optimum {lo:g}..{hi:g} {rng['unit']} (COF {rng['mu_min']:.3f})"
        if rng.get("onset") is not None:
            line += f"; steep rise from {rng['onset']:.2f} {rng['unit']}"
        print(line)
    print(f"outputs in {out}/ (report.html, summary.json, *_windows.csv, figures/)")


def _print_analysis(summary: Dict[str, Any], out: str) -> None:
    for name, s in summary["recordings"].items():
        mu = s["mu_r"]
        text = f"{name}: {s['gated']}/{s['windows']} windows pass the gate"
        if mu.get("n"):
            text += f"; COF median {mu['median']:.4f} (p05 {mu['p05']:.4f}, p95 {mu['p95']:.4f})"
        print(text)
    print(f"outputs in {out}/")


def _run(ns: argparse.Namespace) -> int:
    if ns.command == "demo":
        from .jobs import run_demo

        summary = run_demo(ns.out, seed=ns.seed, progress=_progress_wanted(ns))
        if not ns.quiet:
            _print_demo(summary, ns.out)
        return 0
    if ns.command in ("analyze", "analyse"):
        from .jobs import run_analysis

        open_opts, opts = _analysis_options(ns)
        client = None
        if ns.scheduler:
            from .distributed import connect

            if ns.workers < 1:
                raise UserError("--workers must be at least 1")
            try:
                client = connect(ns.scheduler, ns.workers)
            except ImportError as exc:
                raise UserError(str(exc)) from None
            except OSError as exc:
                raise UserError(f"cannot reach the Dask scheduler {ns.scheduler}: {exc}") from None
        try:
            summary = run_analysis(
                ns.files,
                ns.out,
                open_options=open_opts,
                analyze_options=opts,
                progress=_progress_wanted(ns),
                client=client,
                split=ns.split,
            )
        finally:
            if client is not None:
                cluster = getattr(client, "cluster", None)
                client.close()
                if ns.scheduler == "local" and cluster is not None:
                    cluster.close()
        if not ns.quiet:
            _print_analysis(summary, ns.out)
        for name, f in summary.get("failures", {}).items():
            print(f"tribodyn: warning: {name} failed: {f['error']}", file=sys.stderr)
        return EXIT_SOME_FAILED if summary.get("failures") else 0
    if ns.command == "info":
        from .io import open_recording

        kw: Dict[str, Any] = {}
        if ns.format:
            kw["format"] = ns.format
        if ns.fs:
            kw["fs"] = ns.fs
        with open_recording(ns.file, **kw) as rec:
            info = rec.info()
        _print_info(info)
        return 0
    if ns.command == "simulate":
        from . import simulate
        from .io.writers import save_recording

        sim = simulate.scenario(
            ns.scenario, seed=ns.seed, raw=ns.raw, skew=ns.skew, force_dependence=ns.force_dependence
        )
        save_recording(ns.out, sim.channels, sim.fs, units={k: ("A" if k == "i" else "N") for k in sim.channels})
        if not ns.quiet:
            print(f"wrote {ns.out}: {sim.duration:g} s at {sim.fs:g} Hz, channels {', '.join(sim.channels)}")
        return 0
    raise UserError("no command given (try: tribodyn demo)")


def _print_info(info: Dict[str, Any]) -> None:
    for key, val in info.items():
        if key == "channels":
            print("channels:")
            for ch in val:
                if isinstance(ch, dict):
                    role = f"  [{ch.get('role')}]" if ch.get("role") else ""
                    print(f"  {ch.get('name')} ({ch.get('unit') or '-'}){role}")
                else:
                    print(f"  {ch}")
        else:
            print(f"{key}: {val}")


def _user_errors() -> tuple:
    errs: List[type] = [
        UserError,
        ValueError,
        TypeError,
        FileNotFoundError,
        PermissionError,
        IsADirectoryError,
        NotADirectoryError,
    ]
    try:
        from .io import RecordingError

        errs.append(RecordingError)
    except ImportError:  # pragma: no cover
        pass
    return tuple(errs)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``tribodyn`` console script; returns the exit status."""
    parser = _parser()
    ns = parser.parse_args(argv)
    if ns.version:
        from . import __version__

        print(f"tribodyn {__version__}")
        return 0
    if ns.command is None:
        parser.print_help()
        return EXIT_USER_ERROR
    try:
        return _run(ns)
    except KeyboardInterrupt:
        print("tribodyn: interrupted (no partial outputs were kept)", file=sys.stderr)
        return 130
    except _user_errors() as exc:
        if getattr(ns, "debug", False):
            raise
        print(f"tribodyn: error: {_cli_words(str(exc))}", file=sys.stderr)
        return EXIT_USER_ERROR


def _cli_words(msg: str) -> str:
    """A library message in the CLI's terms (its options instead of Python keywords)."""
    return msg.replace("pass fs=... (Hz)", "give --fs HZ").replace("; pass fs=", "; give --fs HZ")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
