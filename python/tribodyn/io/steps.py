"""Multi-step text exports (``format='steps'``): a test run as a sequence of steps, each written as its
own block, as traction and ball-on-disc machines export them.

Layout (detected by a line ``Step N ... started at ...`` in the first 4 kB)::

    Test name<TAB>...              <- header lines (kept in metadata['header'])
    Step 1 started at 09:12:03 on 02/05/2024
    Step type<TAB>Mapper           <- the step's own lines (optional)
    Rolling Speed (mm/s)<TAB>...   <- the step's column row (units in the names or in a units row below)
    0.5<TAB>...                    <- the step's data rows
    Step 2 started at ...
    ...
    All steps completed            <- footer (any non-data text)

Each step has its own column row and may have other columns than the others. The *test* steps are
joined in file order into one recording; a step named as a mapper (``mapper`` in its ``Step`` line
or its own lines: a map of traction or film against speed between the test steps) is kept apart:
its data are in :attr:`StepsRecording.other_steps` under its name (``'step 2 (mapper)'``) and listed
in ``metadata['steps']``, never mixed into the joined channels. Joined are the columns every test
step has (the others are listed in a warning). The time column (``Time``, or the step's own clock
``Step Time``) is made continuous where it restarts in each step: a step that starts at or before
the previous step's last time is shifted to start one median step after it (the shift is in
``metadata['steps']``). Each step is a separate acquisition (windowed apart), and a ``step``
channel holds each sample's step number. Delimiter: tab, ``;`` or ``,``; decimal comma recognised.

Default roles, by name when exactly one joined column matches: ``fy`` a traction or friction force,
``fz`` the ball, pin or normal load, ``cof`` the traction or friction coefficient.
"""

from __future__ import annotations

import re
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .base import RecordingError, roles_by_name
from .detect import STEP_LINE, sniff_steps
from .tables import TableRecording, find_time_column
from .units import is_known_unit, normalize_unit

__all__ = ["StepsRecording", "sniff_steps"]

#: Words of a step's lines that make it a non-test step (kept apart).
_NON_TEST = re.compile(r"\bmapper\b|\b3d\s*map\b|\bspacer\s+layer\b", re.IGNORECASE)
#: Largest export read (bytes): these files are small; a larger one is not this layout.
_MAX_BYTES = 1 << 30


def _split(line: str, delim: str) -> List[str]:
    return [f.strip() for f in line.rstrip("\r\n").split(delim)]


def _num(s: str, comma: bool) -> Optional[float]:
    """A field as a number (a decimal comma taken when ``comma``), None when it is not one."""
    s = s.strip()
    if not s:
        return None
    try:
        return float(s)
    except ValueError:
        pass
    if comma and s.count(",") == 1 and "." not in s:
        try:
            return float(s.replace(",", "."))
        except ValueError:
            return None
    return None


def _is_data(fields: Sequence[str], comma: bool) -> bool:
    filled = [f for f in fields if f]
    nums = sum(1 for f in filled if _num(f, comma) is not None)
    return nums >= 1 and nums * 2 >= len(filled)


class _Step:
    def __init__(self, number: int, line: str) -> None:
        self.number = number
        self.line = line.strip()
        self.lines: List[str] = []
        self.names: List[str] = []
        self.units: Dict[str, Optional[str]] = {}
        self.rows: List[List[str]] = []
        self.values: Dict[str, np.ndarray] = {}

    @property
    def kind(self) -> str:
        text = " ".join([self.line, *self.lines])
        m = _NON_TEST.search(text)
        return m.group(0).lower() if m else "test"


class StepsRecording(TableRecording):
    """A multi-step export (see the module docstring)."""

    format = "steps"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        time_column: Optional[str] = None,
        time_channel: Optional[str] = None,
        resample: Optional[float] = None,
        encoding: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        #: Non-test steps (mappers), kept apart: name -> column -> values.
        self.other_steps: Dict[str, Dict[str, np.ndarray]] = {}
        header, steps, footer = self._parse(encoding)
        self.metadata["header"] = header[:50]
        if footer:
            self.metadata["footer"] = footer[:10]
        tests = [s for s in steps if s.kind == "test" and s.rows]
        info: List[Dict[str, Any]] = []
        for s in steps:
            entry: Dict[str, Any] = {"step": s.number, "kind": s.kind, "rows": len(s.rows), "line": s.line}
            if s.kind != "test" and s.rows:
                name = f"step {s.number} ({s.kind})"
                self.other_steps[name] = s.values
                entry["kept apart as"] = name
            info.append(entry)
        self.metadata["steps"] = info
        if not tests:
            listed = ", ".join("step {}: {}, {} rows".format(d["step"], d["kind"], d["rows"]) for d in info)
            raise RecordingError(f"{self.path}: no test step with data rows among {len(steps)} step(s) ({listed})")
        common = [n for n in tests[0].names if all(n in s.names for s in tests[1:])]
        partial = sorted({n for s in tests for n in s.names} - set(common))
        if partial:
            self.warnings.append(
                f"column(s) {', '.join(map(repr, partial))} are not in every test step: not read "
                f"(the {len(common)} columns all test steps have are joined)"
            )
        apart = [d for d in info if d["kind"] != "test"]
        if apart:
            self.warnings.append(
                "non-test step(s) kept apart, not analysed: "
                + ", ".join(f"step {d['step']} ({d['kind']}, {d['rows']} rows)" for d in apart)
            )
        per_step = [s.values for s in tests]
        cols = {n: np.concatenate([c[n] for c in per_step]) for n in common}
        units_of = {n: tests[0].units.get(n) for n in common}
        bounds: List[Tuple[int, int]] = []
        pos = 0
        for s in tests:
            bounds.append((pos, pos + len(s.rows)))
            pos += len(s.rows)
        tname = time_column or time_channel
        if tname is None:
            tname = find_time_column(common)
        if tname is not None:
            from .base import resolve_name

            tname = resolve_name(self.path, common, tname, "time_column")
            shifts = _continuous(cols[tname], bounds)
            for (k, sh), s in zip(enumerate(shifts), tests):
                if sh:
                    entry = next(d for d in info if d["step"] == s.number and d["kind"] == "test")
                    entry["time shifted by"] = sh
        step_name = "step" if "step" not in cols else "step number"
        cols[step_name] = np.concatenate([np.full(len(s.rows), float(s.number)) for s in tests])
        units_of[step_name] = None
        self.open_table(
            cols,
            units_of,
            channels=channels,
            fs=fs,
            scale=scale,
            given_units=units,
            time_column=tname,
            resample=resample,
            segments=bounds,
            default_roles=roles_by_name(common),  # the vocabulary (io/base.py ROLE_NAMES)
        )

    def _parse(self, encoding: Optional[str]) -> Tuple[List[str], List[_Step], List[str]]:
        import os

        size = os.path.getsize(self.path)
        if size > _MAX_BYTES:
            raise RecordingError(f"{self.path}: {size} bytes: too large for a multi-step export")
        with open(self.path, "rb") as fh:
            raw = fh.read()
        enc = encoding or ("utf-8-sig" if raw.startswith(b"\xef\xbb\xbf") else "utf-8")
        try:
            text = raw.decode(enc)
        except UnicodeDecodeError:
            text = raw.decode("cp1252", errors="replace") if encoding is None else raw.decode(enc, errors="strict")
        except LookupError:
            raise RecordingError(f"unknown encoding {encoding!r}") from None
        lines = text.splitlines()
        header: List[str] = []
        steps: List[_Step] = []
        footer: List[str] = []
        delim: Optional[str] = None
        cur: Optional[_Step] = None
        pending: List[str] = []  # non-data lines of the current step before its data
        for lineno, line in enumerate(lines, 1):
            m = STEP_LINE.match(line)
            if m:
                if cur is not None and not cur.rows:
                    cur.lines = pending
                cur = _Step(int(m.group(1)), line)
                steps.append(cur)
                pending = []
                footer = []
                continue
            if cur is None:
                if line.strip():
                    header.append(line.strip())
                continue
            if not line.strip():
                continue
            if delim is None:
                delim = "\t" if "\t" in line else (";" if ";" in line else ",")
            fields = _split(line, delim)
            if _is_data(fields, delim != ",") and (cur.rows or pending):
                if not cur.rows:
                    self._column_row(cur, pending, lineno, delim)
                if len(fields) < len(cur.names):
                    raise RecordingError(
                        f"{self.path}: line {lineno}: {len(fields)} fields, step {cur.number}'s column row "
                        f"has {len(cur.names)}"
                    )
                cur.rows.append(fields[: len(cur.names)])
            elif cur.rows:
                footer.append(line.strip())  # text after a step's data: the footer, or notes before the next step
            else:
                pending.append(line)
        if cur is not None and not cur.rows:
            cur.lines = pending
        if not steps:
            raise RecordingError(f"{self.path}: no 'Step N started at' line: not a multi-step export")
        self._comma = delim != ","
        for st in steps:
            if st.rows:
                st.values = _columns(st, self._comma)
        return header, steps, footer

    def _column_row(self, step: _Step, pending: List[str], lineno: int, delim: str) -> None:
        """The step's column row (and units row) from the non-data lines above its first data row."""
        rows = [_split(ln, delim) for ln in pending]
        if len(rows) >= 2 and _units_row(rows[-1]):
            names, units = rows[-2], [normalize_unit(u) for u in rows[-1]]
            step.lines = pending[:-2]
        else:
            names, units = rows[-1], [None] * len(rows[-1])
            step.lines = pending[:-1]
        if len([n for n in names if n]) < 2:
            raise RecordingError(f"{self.path}: line {lineno}: step {step.number}'s data have no column row above")
        from .delimited import _unit_from_name

        clean: List[str] = []
        for k, n in enumerate(names):
            n = " ".join(n.split()) or f"column {k + 1}"
            base = n
            j = 1
            while n in clean:
                n = f"{base}.{j}"
                j += 1
            clean.append(n)
        step.names = clean
        step.units = {n: (units[k] if k < len(units) and units[k] else _unit_from_name(n)) for k, n in enumerate(clean)}


def _units_row(fields: Sequence[str]) -> bool:
    toks = [normalize_unit(f) for f in fields if f.strip()]
    return bool(toks) and all(t is None or t in ("-", "%") or is_known_unit(t) for t in toks)


def _columns(step: _Step, comma: bool) -> Dict[str, np.ndarray]:
    """The step's numeric columns (a text column, e.g. a clock time, is left out)."""
    out: Dict[str, np.ndarray] = {}
    for j, name in enumerate(step.names):
        vals = [_num(r[j], comma) for r in step.rows]
        if all(v is not None for v in vals):
            out[name] = np.asarray(vals, dtype=np.float64)
    step.names = [n for n in step.names if n in out]
    return out


def _continuous(t: np.ndarray, bounds: Sequence[Tuple[int, int]]) -> List[float]:
    """Shifts each step's time (in place) to follow the previous step's; returns the shifts."""
    shifts = [0.0]
    steps = [np.diff(t[a:b]) for a, b in bounds if b - a > 1]
    d = np.concatenate(steps) if steps else np.zeros(0)
    d = d[np.isfinite(d) & (d > 0)]
    dt = float(np.median(d)) if d.size else 1.0
    for (pa, pb), (a, b) in zip(bounds[:-1], bounds[1:]):
        last = t[pb - 1]
        if b > a and t[a] <= last:
            sh = float(last + dt - t[a])
            t[a:b] += sh
            shifts.append(sh)
        else:
            shifts.append(0.0)
    return shifts
