"""The test record: what was tested, how, and how the COF was computed (docs/method.md 10c).

The fields are declared once in :data:`FIELDS`, in the order of ASTM G115's
reporting guidance as tribodyn reads it: the tribosystem (materials,
counterpart), the conditions (load, speed, stroke, distance, temperature,
humidity, lubricant, duration), who ran the test (operator); further keys
are kept after them, in the order given. :func:`parse_meta` checks them
(``--meta key=value``, the config's ``[meta]`` table); :func:`summary_meta`
is the ``"meta"`` block of a recording in ``summary.json`` (with how the
headline was computed), :func:`metadata` the ``metadata.json`` a data
repository can index, and :func:`record_html` the report's "Test record".
"""

from __future__ import annotations

import difflib
import html
import math
import re
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

__all__ = ["FIELDS", "Field", "Meta", "metadata", "parse_meta", "record_html", "summary_meta"]

#: Version of the ``metadata.json`` layout.
METADATA_SCHEMA = "tribodyn-test-record/1"


@dataclass(frozen=True)
class Field:
    """A field of the test record: its key, its SI unit ("" for text), its meaning and unit factors."""

    key: str
    unit: str
    meaning: str
    #: Units accepted after a number -> factor to ``unit`` (an offset for kelvin: see :func:`_number`).
    units: Tuple[Tuple[str, float], ...] = ()
    low: float = -math.inf
    high: float = math.inf


_LENGTH = (("m", 1.0), ("km", 1e3), ("cm", 1e-2), ("mm", 1e-3), ("um", 1e-6), ("µm", 1e-6))

#: The record's fields, in the order of ASTM G115's reporting guidance (docs/method.md 10c).
FIELDS: Tuple[Field, ...] = (
    Field("materials", "", "specimen material(s) and condition (e.g. 'AISI 52100 steel, Ra 0.05 um')"),
    Field("counterpart", "", "counterface: material and geometry (e.g. 'alumina ball, 6 mm')"),
    Field("load", "N", "normal load", (("N", 1.0), ("kN", 1e3), ("mN", 1e-3)), low=0.0),
    Field("speed", "m/s", "sliding speed", (("m/s", 1.0), ("mm/s", 1e-3), ("cm/s", 1e-2)), low=0.0),
    Field("stroke", "m", "stroke length (reciprocating) or track radius", _LENGTH, low=0.0),
    Field("distance", "m", "sliding distance", _LENGTH, low=0.0),
    Field("temperature", "°C", "temperature", (("°C", 1.0), ("degC", 1.0), ("C", 1.0), ("K", 1.0)), low=-273.15),
    Field("humidity", "%", "relative humidity", (("%", 1.0), ("%RH", 1.0)), low=0.0, high=100.0),
    Field("lubricant", "", "lubricant, or 'dry'"),
    Field("duration", "s", "test duration", (("s", 1.0), ("ms", 1e-3), ("min", 60.0), ("h", 3600.0)), low=0.0),
    Field("operator", "", "who ran the test"),
)
_BY_KEY = {f.key: f for f in FIELDS}
_KEY = re.compile(r"^[A-Za-z][A-Za-z0-9_.\-]*$")
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")

Value = Union[str, int, float]


@dataclass(frozen=True)
class Entry:
    """One field as given, and its value in the field's SI unit (None for text or a text-only value)."""

    key: str
    given: Value
    value: Optional[float]
    unit: str


@dataclass(frozen=True)
class Meta:
    """The test record's fields, checked (:func:`parse_meta`), standard fields first in :data:`FIELDS` order."""

    entries: Tuple[Entry, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.entries)

    def given(self) -> Dict[str, Value]:
        """Key -> value as given, in record order."""
        return {e.key: e.given for e in self.entries}


def _number(field: Field, given: Value, where: str) -> Optional[float]:
    """The value of a unit field in its SI unit; None for a text that does not start with a number."""
    if isinstance(given, bool):
        raise ValueError(f"{where}: {field.key} must be a number or text, got {given!r}")
    if isinstance(given, (int, float)):
        x, unit = float(given), ""
    else:
        m = _NUMBER.match(given)
        if m is None:
            return None  # e.g. "ambient": kept as text
        x, unit = float(m.group(1)), m.group(2)
    if not math.isfinite(x):
        raise ValueError(f"{where}: {field.key} must be finite, got {given!r}")
    if unit:
        factors = dict(field.units)
        if unit not in factors:
            known = ", ".join(u for u, _ in field.units)
            raise ValueError(f"{where}: {field.key} {given!r}: unknown unit {unit!r} (use {known}; a bare number "
                             f"is in {field.unit})")  # fmt: skip
        x = x - 273.15 if unit == "K" else x * factors[unit]
    if not field.low <= x <= field.high:
        rng = f">= {field.low:g}" if math.isinf(field.high) else f"within {field.low:g} to {field.high:g}"
        raise ValueError(f"{where}: {field.key} must be {rng} {field.unit}, got {given!r}")
    return x


def parse_meta(pairs: Union[Mapping[str, Any], Sequence[Tuple[str, Any]]], where: str = "meta") -> Meta:
    """Checks the test record's fields (docs/method.md 10c).

    Known keys (case-insensitive) are those of :data:`FIELDS`; a number in
    a unit field may carry a unit (``"10 N"``, ``"5 mm"``, ``"300 K"``) and
    is also kept in the field's SI unit; other keys are kept as given.

    Raises
    ------
    ValueError
        A key given twice, the reserved key ``result``, a key that is not a name or looks like a
        misspelt field, an empty value, a table or list as a value, a unit
        the field does not take, a number out of range (a negative load, a
        humidity over 100 %...).
    """
    items = list(pairs.items()) if isinstance(pairs, Mapping) else list(pairs)
    seen: Dict[str, Entry] = {}
    for raw_key, given in items:
        key = str(raw_key).strip()
        if not _KEY.match(key):
            raise ValueError(f"{where}: {raw_key!r} is not a field name (letters, digits, _ . -)")
        low = key.lower()
        if low in _BY_KEY:
            key = low
        else:
            # a typo: close in spelling and in length ("materail", "humidty"); "temperature_note" is a key of its own
            near = [
                k for k in difflib.get_close_matches(low, list(_BY_KEY), n=1, cutoff=0.8) if abs(len(k) - len(low)) <= 2
            ]
            if near:
                raise ValueError(f"{where}: {raw_key!r} is not a field: did you mean {near[0]}? (further keys are "
                                 "allowed, but not ones that look like a misspelt field)")  # fmt: skip
        if key == "result":
            raise ValueError(f"{where}: 'result' is reserved (the record's COF and how it was computed)")
        if key in seen:
            raise ValueError(f"{where}: {key} is given twice")
        if isinstance(given, bool) or not isinstance(given, (str, int, float)):
            raise ValueError(f"{where}: {key} must be text or a number, got {given!r}")
        if isinstance(given, str):
            given = given.strip()
            if not given:
                raise ValueError(f"{where}: {key} is empty (give {key}=VALUE)")
        field = _BY_KEY.get(key)
        value: Optional[float] = None
        unit = ""
        if field is not None and field.unit:
            value, unit = _number(field, given, where), field.unit
        elif isinstance(given, float) and not math.isfinite(given):
            raise ValueError(f"{where}: {key} must be finite, got {given!r}")
        seen[key] = Entry(key=key, given=given, value=value, unit=unit)
    order = [f.key for f in FIELDS if f.key in seen] + [k for k in seen if k not in _BY_KEY]
    return Meta(entries=tuple(seen[k] for k in order))


def merge(base: Meta, top: Meta) -> Meta:
    """``base`` with the fields of ``top`` put over it (the command line over the config), in record order."""
    entries = {e.key: e for e in base.entries}
    entries.update({e.key: e for e in top.entries})
    order = [f.key for f in FIELDS if f.key in entries] + [k for k in entries if k not in _BY_KEY]
    return Meta(entries=tuple(entries[k] for k in order))


def _how(head: Mapping[str, Any]) -> Dict[str, Any]:
    return {
        "cof": head.get("value"),
        "low": head.get("low"),
        "high": head.get("high"),
        "method": head.get("method"),
        "statistic": head.get("statistic"),
        "n": head.get("n"),
        "how_computed": head.get("estimate"),
        "interval": head.get("interval"),
    }


def summary_meta(meta: Meta, headline: Mapping[str, Any]) -> Dict[str, Any]:
    """The ``"meta"`` block of a recording in summary.json: the fields as given, then the COF and how computed."""
    return {**meta.given(), "result": _how(headline)}


def metadata(meta: Meta, inputs: Sequence[Mapping[str, Any]], headlines: Mapping[str, Mapping[str, Any]],
             version: str) -> Dict[str, Any]:  # fmt: skip
    """``metadata.json``: the record's fields with units, the inputs' SHA-256, the software and each headline."""
    fields: Dict[str, Any] = {}
    for e in meta.entries:
        f = _BY_KEY.get(e.key)
        item: Dict[str, Any] = {"given": e.given}
        if e.unit:
            item.update(value=e.value, unit=e.unit)
        if f is not None:
            item["meaning"] = f.meaning
        fields[e.key] = item
    return {
        "schema": METADATA_SCHEMA,
        "software": {"name": "tribodyn", "version": version},
        "standard_fields": [f.key for f in FIELDS],
        "fields": fields,
        "inputs": [{"file": i.get("file"), "bytes": i.get("bytes"), "sha256": i.get("sha256")} for i in inputs],
        "results": [{"recording": name, **_how(h), "text": h.get("text")} for name, h in headlines.items()],
    }


def record_html(meta: Meta, headlines: Mapping[str, Mapping[str, Any]]) -> str:
    """The report's "Test record" section: the fields in record order, then each headline and how it was computed."""
    esc = html.escape
    rows: List[str] = []
    given = {e.key: e for e in meta.entries}
    for key in [f.key for f in FIELDS] + [k for k in given if k not in _BY_KEY]:
        e = given.get(key)
        if e is None:
            text = '<span class="note">not given</span>'
        else:
            text = esc(str(e.given))
            m = _NUMBER.match(str(e.given))
            if e.value is not None and m is not None and not m.group(2):  # a bare number: in the field's unit
                text += f" {esc(e.unit)}"
            elif e.value is not None and m is not None and float(m.group(1)) != e.value:  # converted
                text += f" ({e.value:g} {esc(e.unit)})"
        rows.append(f'<tr><td class="key">{esc(key)}</td><td class="text">{text}</td></tr>')
    for name, h in headlines.items():
        prefix = f"{name}: " if len(headlines) > 1 else ""
        cof = esc(str(h.get("text", "")))
        rows.append(f'<tr><td class="key">{esc(prefix)}COF</td><td class="text">{cof}</td></tr>')
        how = f"{h.get('estimate') or ''}; interval: {h.get('interval') or ''}"
        rows.append(f'<tr><td class="key">{esc(prefix)}how computed</td><td class="text">{esc(how)}</td></tr>')
    hint = ""
    if not meta:
        hint = ('<p class="note">No test record given: pass --meta KEY=VALUE (repeatable) or a [meta] table in the '
                "--config file (materials, counterpart, load, speed, stroke, distance, temperature, humidity, "
                "lubricant, duration, operator).</p>")  # fmt: skip
    return hint + "<table>" + "".join(rows) + "</table>"
