"""Shared helpers of the text readers (LVM and delimited): number parsing,
block parsing of data lines, and sequential reading of a file's data rows.

Lines are read as bytes and decoded as latin-1 (numbers are ASCII, and
latin-1 never fails), so byte offsets found by a scan pass can be used to
seek straight to a data block later.
"""

from __future__ import annotations

import codecs
import itertools
import os
import re
import warnings
from typing import IO, Any, Dict, Iterator, List, Mapping, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from .base import Recording, RecordingError, roles_by_name

#: Lines parsed at once by the text readers (a block of lines costs far more
#: memory than its numbers, so text blocks are smaller than binary ones).
TEXT_BLOCK_ROWS = 8192

__all__ = [
    "TEXT_BLOCK_ROWS",
    "Checkpoints",
    "TextRecording",
    "check_encoding",
    "decode_header",
    "default_roles",
    "duplicate_warnings",
    "dropped_row_warning",
    "incomplete_row_error",
    "is_number",
    "iter_data_lines",
    "native_dialect",
    "native_parse",
    "native_scan",
    "parse_rows",
    "row_defects",
    "split_fields",
    "to_float",
]


def check_encoding(encoding: object) -> str:
    """``encoding`` when it names a text encoding Python knows; raises :class:`RecordingError` otherwise."""
    if not isinstance(encoding, str):
        raise RecordingError(f"encoding must be a string such as 'utf-8', got {encoding!r} (encoding=)")
    try:
        codecs.lookup(encoding)
    except LookupError:
        raise RecordingError(f"unknown encoding {encoding!r} (encoding=)") from None
    try:
        b"0".decode(encoding)
    except LookupError:  # 'base64', 'rot13'...: codecs, but not text encodings
        raise RecordingError(f"{encoding!r} is not a text encoding (encoding=)") from None
    except UnicodeError:  # a text encoding that wants more than one byte
        pass
    return encoding


def row_defects(nfields: int, expected: int, terminated: bool) -> str:
    """What is wrong with a last row, for messages: missing fields and/or line end ('' when nothing)."""
    out = []
    if nfields < expected:
        out.append(f"{nfields} fields, expected {expected}")
    if not terminated:
        out.append("no line end")
    return " and ".join(out)


def dropped_row_warning(lineno: int, defects: str) -> str:
    """Warning for a last row dropped because it may have been cut off (see :func:`row_defects`)."""
    return f"last row (line {lineno}) has {defects}: dropped as possibly cut off"


def incomplete_row_error(path: str, lineno: int, defects: str) -> RecordingError:
    """Error for a last row that is refused because it may have been cut off (see :func:`row_defects`)."""
    return RecordingError(f"{path}: last row (line {lineno}) has {defects}: incomplete row, file truncated or corrupt")


def _and(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _duplicated(names: Sequence[str]) -> Dict[str, List[int]]:
    """Names met more than once -> their indices."""
    where: Dict[str, List[int]] = {}
    for k, n in enumerate(names):
        where.setdefault(n, []).append(k)
    return {n: ks for n, ks in where.items() if len(ks) > 1}


def default_roles(names: Sequence[str], unique: Sequence[str]) -> Dict[str, str]:
    """Default role map of a text file's columns: :func:`~tribodyn.io.base.roles_by_name` of the names
    as written in the file (``names``), as the unique channel names the reader gave them (``unique``).

    A role is never mapped to a column whose name appears more than once in the file (see
    :func:`duplicate_warnings`).
    """
    return {role: unique[names.index(n)] for role, n in roles_by_name(names).items()}


def duplicate_warnings(
    names: Sequence[str], unique: Sequence[str], columns: Sequence[int], roles: Mapping[str, str]
) -> List[str]:
    """One warning per channel name appearing more than once in a file's column row.

    Parameters
    ----------
    names : sequence of str
        Channel names as written in the file.
    unique : sequence of str
        The distinct names the reader gave them (``'fy [N]'``, ``'fy [N].1'``...).
    columns : sequence of int
        1-based column of each channel in the file.
    roles : mapping
        The recording's role map, to say what happened to a role such a name would have had.
    """
    out = []
    for name, ks in _duplicated(names).items():
        given = [unique[k] for k in ks]
        msg = (
            f"channel name {name!r} appears in columns {_and([str(columns[k]) for k in ks])}: "
            f"read as {_and([repr(g) for g in given])}"
        )
        for role in roles_by_name([name]):
            mapped = roles.get(role)
            if mapped is None:
                msg += f"; role {role!r} left unmapped (ambiguous): map one with channels="
            elif mapped in given:
                msg += f"; role {role!r} mapped to {mapped!r} (column {columns[ks[given.index(mapped)]]})"
        out.append(msg)
    return out


def to_float(s: str, decimal: str = ".") -> float:
    """Parses one field; ``decimal=','`` accepts a decimal comma. Raises ValueError."""
    s = s.strip()
    if decimal != ".":
        s = s.replace(decimal, ".")
    if "_" in s:  # float() accepts 1_000; a data file should not
        raise ValueError(s)
    return float(s)


def is_number(s: str, decimal: str = ".") -> bool:
    """True when ``s`` parses as a number (see :func:`to_float`)."""
    try:
        to_float(s, decimal)
    except ValueError:
        return False
    return True


def split_fields(line: str, delimiter: Optional[str]) -> List[str]:
    """Splits a line (without its end-of-line); ``delimiter=None`` splits on whitespace runs."""
    if delimiter is None:
        return line.split()
    return line.split(delimiter)


def decode_header(raw: bytes, encoding: str) -> str:
    """Decodes a header line with ``encoding``, falling back to latin-1."""
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def parse_rows(
    lines: Sequence[str],
    linenos: Sequence[int],
    delimiter: Optional[str],
    decimal: str,
    *,
    usecols: Sequence[int],
    colnames: Sequence[str],
    path: str,
) -> np.ndarray:
    """Parses data lines into a ``(len(lines), len(usecols))`` float64 array.

    Empty fields become NaN. A field that is not a number, or a line with
    too few fields, raises :class:`RecordingError` naming the line.

    Parameters
    ----------
    lines : sequence of str
        Data lines (end-of-line characters allowed).
    linenos : sequence of int
        1-based line numbers of ``lines`` in the file (for messages).
    delimiter : str or None
        Field separator; None for whitespace runs.
    decimal : str
        ``'.'`` or ``','``.
    usecols : sequence of int
        Field indices to keep.
    colnames : sequence of str
        Channel names of ``usecols`` (for messages).
    path : str
        File (for messages).
    """
    ncol = len(usecols)
    if not lines:
        return np.empty((0, ncol))
    if decimal == "," and delimiter != ",":
        fast_lines: Sequence[str] = [ln.replace(",", ".") for ln in lines]
    else:
        fast_lines = lines
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            a = np.loadtxt(
                fast_lines,
                delimiter=delimiter,
                usecols=list(usecols),
                dtype=np.float64,
                ndmin=2,
                comments=None,
                encoding=None,
            )
        if a.shape == (len(lines), ncol):
            return a
    except ValueError:
        pass
    # slow path: exact per-line checks, NaN for empty fields, precise errors
    out = np.empty((len(lines), ncol))
    need = max(usecols) + 1 if ncol else 0
    for r, (ln, no) in enumerate(zip(lines, linenos)):
        f = split_fields(ln.rstrip("\r\n"), delimiter)
        if len(f) < need:
            raise RecordingError(
                f"{path}: line {no} has {len(f)} fields, expected at least {need} (truncated or corrupt file)"
            )
        for c, (i, name) in enumerate(zip(usecols, colnames)):
            s = f[i].strip()
            if not s:
                out[r, c] = np.nan
                continue
            try:
                out[r, c] = to_float(s, decimal)
            except ValueError:
                raise RecordingError(
                    f"{path}: line {no}: {s[:40]!r} in channel {name!r} is not a number (corrupt file?)"
                ) from None
    return out


def iter_data_lines(
    fh: IO[bytes],
    offset: int,
    first_lineno: int,
    n_rows: int,
    *,
    block: int,
    path: str,
    comment: Optional[bytes] = None,
) -> Iterator[Tuple[List[str], List[int]]]:
    """Yields the data lines of one block of a text file, ``block`` lines at a time.

    Starts at byte ``offset`` (line number ``first_lineno``), skips blank lines
    (and lines starting with ``comment``), and stops after ``n_rows`` data
    lines. Raises :class:`RecordingError` if the file ends first.
    """
    fh.seek(offset)
    lineno = first_lineno - 1
    left = n_rows
    while left > 0:
        lines: List[str] = []
        nos: List[int] = []
        want = min(block, left)
        # read a few more than needed only if blank lines intervene
        while len(lines) < want:
            got_any = False
            for raw in itertools.islice(fh, want - len(lines)):
                got_any = True
                lineno += 1
                s = raw.strip()
                if not s or (comment is not None and s.startswith(comment)):
                    continue
                lines.append(raw.decode("latin-1"))
                nos.append(lineno)
            if not got_any:
                raise RecordingError(
                    f"{path}: file ended after line {lineno}, {left - len(lines)} data rows "
                    "short (file changed or truncated since it was opened?)"
                )
        left -= len(lines)
        yield lines, nos


# -- encodings -------------------------------------------------------------------------

#: Byte-order marks and the encoding each announces (longest first).
_BOMS: Tuple[Tuple[bytes, str], ...] = (
    (b"\xef\xbb\xbf", "utf-8-sig"),
    (b"\xff\xfe", "utf-16"),
    (b"\xfe\xff", "utf-16"),
)


def _decodes(head: bytes, encoding: str) -> Optional[str]:
    """``head`` decoded with ``encoding``, allowing a character cut at the end of the probe; None if it fails."""
    for cut in range(4):
        try:
            return head[: len(head) - cut].decode(encoding)
        except UnicodeDecodeError:
            continue
    return None


def sniff_encoding(head: bytes) -> Optional[str]:
    """The text encoding of a file from its first bytes, or None for binary content.

    The documented detection, in order:

    1. a byte-order mark: UTF-8 (``utf-8-sig``) or UTF-16 (either byte order);
    2. NUL bytes at every other position of mostly ASCII text: UTF-16 LE or
       BE without a mark (any other NUL byte: binary, None);
    3. valid UTF-8: ``utf-8``;
    4. valid CP932 (Shift-JIS, as Japanese instruments such as Kyowa's
       write) holding at least one Japanese character: ``cp932``;
    5. valid Windows-1252: ``cp1252`` (Latin-1 text);
    6. otherwise None (binary).

    ``encoding=`` of the readers overrides it.
    """
    for bom, enc in _BOMS:
        if head.startswith(bom):
            return enc
    if b"\x00" in head:
        probe = head[: 2 * (min(len(head), 512) // 2)]
        if len(probe) >= 4:
            even, odd = probe[0::2], probe[1::2]
            if odd.count(0) >= 0.9 * len(odd) and even.count(0) == 0:
                return "utf-16-le"
            if even.count(0) >= 0.9 * len(even) and odd.count(0) == 0:
                return "utf-16-be"
        return None
    if _decodes(head, "utf-8") is not None:
        return "utf-8"
    text = _decodes(head, "cp932")
    if text is not None and any(
        "\u3000" <= c <= "\u9fff" or "\uff00" <= c <= "\uffef" for c in text
    ):  # kana, kanji, full-width forms
        return "cp932"
    if _decodes(head, "cp1252") is not None:
        return "cp1252"
    return None


def is_wide(encoding: str) -> bool:
    """True for encodings whose ASCII characters are not single bytes (UTF-16, UTF-32)."""
    try:
        return len("0".encode(encoding)) > 1 or codecs.lookup(encoding).name.startswith(("utf-16", "utf-32"))
    except LookupError:
        return False


# -- sampling rates written in a header ------------------------------------------------


def norm_words(text: str) -> str:
    """``text`` lower case, accents removed, ``_ - . ' ’`` as spaces, spaces collapsed: how header keys
    and column names are compared (``"Fréquence d'échantillonnage"`` -> ``"frequence d echantillonnage"``)."""
    import unicodedata

    t = unicodedata.normalize("NFKD", text.strip().strip("\"'").strip().lower())
    t = "".join(c for c in t if not unicodedata.combining(c))
    t = re.sub(r"[_\-.'\u2019`]+", " ", t)
    return re.sub(r"\s+", " ", t).strip()


#: Header keys that give a rate (Hz), compared after :func:`norm_words` without a unit. English first,
#: then German, French, Spanish, Italian, Portuguese, Dutch, Swedish, Polish, Czech, Russian, Japanese,
#: Chinese and Korean.
RATE_KEYS = (
    "sampling rate", "sampling frequency", "sample rate", "sampling freq", "scan rate", "sample frequency",
    "data rate", "acquisition rate", "acquisition frequency", "sampling speed", "samples per second",
    "fs", "sr", "rate",
    "abtastrate", "abtastfrequenz", "samplerate", "samplingrate", "messrate", "messfrequenz", "aufnahmerate",
    "aufzeichnungsrate", "erfassungsrate", "datenrate", "abtastung",
    "frequence d echantillonnage", "taux d echantillonnage", "frequence d acquisition", "cadence d echantillonnage",
    "cadence d acquisition", "frequence echantillonnage",
    "frecuencia de muestreo", "tasa de muestreo", "velocidad de muestreo", "frecuencia de adquisicion",
    "frequenza di campionamento", "tasso di campionamento", "frequenza campionamento",
    "taxa de amostragem", "frequencia de amostragem",
    "bemonsteringsfrequentie", "samplefrequentie", "samplingsfrekvens", "samplingshastighet",
    "czestotliwosc probkowania", "vzorkovaci frekvence",
    "частота дискретизации", "частота выборки", "частота опроса",
    "サンプリング周波数", "サンプリングレート", "サンプリング速度", "采样频率", "采样率", "采样速率",
    "샘플링 주파수", "샘플링 속도",
)  # fmt: skip
#: Header keys that give a sampling step (s unless a unit says otherwise), compared as :data:`RATE_KEYS`.
STEP_KEYS = (
    "delta x", "interval", "sample interval", "sampling interval", "dt", "wf increment", "time step",
    "sampling period", "sample period", "increment", "time interval",
    "abtastintervall", "abtastzeit", "abtastperiode", "messintervall", "zeitschritt", "schrittweite",
    "periode d echantillonnage", "pas d echantillonnage", "intervalle d echantillonnage", "pas de temps",
    "periodo de muestreo", "intervalo de muestreo", "paso de tiempo",
    "periodo di campionamento", "intervallo di campionamento", "passo di campionamento",
    "periodo de amostragem", "intervalo de amostragem",
    "bemonsteringsinterval", "samplingsintervall", "okres probkowania",
    "шаг дискретизации", "период дискретизации",
    "サンプリング間隔", "サンプリング周期", "采样间隔", "采样周期", "샘플링 간격",
)  # fmt: skip
_RATE_UNITS = {"hz": 1.0, "khz": 1e3, "mhz": 1e6, "s/s": 1.0, "sps": 1.0, "1/s": 1.0, "/s": 1.0, "ks/s": 1e3}
_STEP_UNITS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9, "min": 60.0}
#: Words of a key whose value in Hz is some other frequency than the sampling rate (filters, the motion).
_NOT_RATE_WORDS = re.compile(
    r"filter|cut ?off|pass|grenz|eck|band|corner|nyquist|motor|drive|antrieb|rotat|dreh|speed|velocit|geschw|"
    r"stroke|hub|osc|oszill|schwing|excit|anreg|vibra|resonan|mains|netz|line|puls|carrier|modul|trigger|display|"
    r"anzeige|update|refresh|bildwiederhol|frame|course|recip|cycle|zyklus|period"
)
#: A key that is only the word "frequency" (in any of these languages): on a tribometer that is usually the
#: stroke or rotation frequency, never read as the sampling rate.
_BARE_FREQUENCY = {"frequency", "freq", "f", "frequenz", "frequence", "frecuencia", "frequenza", "frequencia",
                   "frequentie", "frekvens", "czestotliwosc", "частота", "周波数", "频率", "주파수"}  # fmt: skip
_RATE_SET = frozenset(RATE_KEYS)
_STEP_SET = frozenset(STEP_KEYS)
_KNOWN_NOSPACE = {k.replace(" ", ""): ("rate" if k in _RATE_SET else "step") for k in STEP_KEYS + RATE_KEYS}
_NUMBER = r"[-+]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][-+]?\d+)?"
_KEY_UNIT = re.compile(r"^(.*?)\s*[\[(]([^\[\]()]{1,8})[\])]\s*$")
_UNIT_WORDS = "|".join(re.escape(u) for u in sorted(set(_RATE_UNITS) | set(_STEP_UNITS), key=len, reverse=True))
_KEY_TRAILING_UNIT = re.compile(r"^(.*?\S)\s*(?:/|,|\bin\b|\s)\s*(" + _UNIT_WORDS + r")\s*$", re.IGNORECASE)


class HeaderRate(NamedTuple):
    """A sampling rate read from a header: ``hz``, the ``key`` as written and ``how`` it was recognised:
    ``'key'`` (a known rate or step key), ``'fuzzy'`` (a misspelling of one) or ``'unit'`` (another key
    whose value is in Hz or S/s)."""

    hz: float
    key: str
    how: str


def _key_unit(key: str) -> Tuple[str, Optional[str]]:
    """(key without its unit, the unit) from ``'Sampling rate [kHz]'``, ``'Abtastrate/Hz'``, ``'Rate in kHz'``."""
    m = _KEY_UNIT.match(key)
    if m:
        return m.group(1), m.group(2).strip()
    m = _KEY_TRAILING_UNIT.match(key.strip().rstrip(":=").strip())
    if m:
        return m.group(1), m.group(2)
    return key, None


def _norm_key(key: str) -> str:
    return norm_words(re.sub(r"\s*[:=]+\s*$", "", key.strip()))


def _key_kind(k: str) -> Optional[Tuple[str, str]]:
    """("rate" or "step", "key" or "fuzzy") for a normalized key, or None."""
    import difflib

    if k in _RATE_SET:
        return "rate", "key"
    if k in _STEP_SET:
        return "step", "key"
    ns = k.replace(" ", "")
    if ns in _KNOWN_NOSPACE:  # "SamplingRate", "Sample-Rate"
        return _KNOWN_NOSPACE[ns], "key"
    if len(ns) < 6:
        return None
    best, kind = 0.0, None
    for cand, knd in _KNOWN_NOSPACE.items():
        if len(cand) < 5:
            continue
        r = difflib.SequenceMatcher(None, ns, cand).ratio()
        if r > best:
            best, kind = r, knd
    return (kind, "fuzzy") if kind is not None and best >= 0.85 else None


def _value_number(value: str) -> Optional[Tuple[float, str]]:
    """(the first number of a header value, the unit written after it, lower case) or None."""
    m = re.match(r"^\s*\"?(" + _NUMBER + r")\s*([A-Za-zµμ/]+(?:/s)?)?", str(value))
    if not m:
        return None
    try:
        x = float(m.group(1).replace(",", "."))
    except ValueError:
        return None
    if not (x > 0) or x == float("inf"):
        return None
    return x, (m.group(2) or "").strip().lower()


def header_rate(pairs: Mapping[str, str]) -> Optional[HeaderRate]:
    """The sampling rate a header states, from its ``key -> value`` pairs, or None.

    In order of trust, the first key found of:

    1. a known key (:data:`RATE_KEYS`: ``Sampling rate``, ``fs``, ``Abtastrate``, ``Fréquence
       d'échantillonnage``...; :data:`STEP_KEYS`: ``Delta_X``, ``Interval``, ``dt``, ``Abtastintervall``...),
       compared without case, accents, quotes, ``_``/``-``/``.``, spaces or a unit (``[kHz]``, ``(Hz)``,
       ``/Hz``, ``in Hz``);
    2. a misspelling of one (``difflib`` ratio >= 0.85 to the closest known key, spaces ignored:
       ``Sampling fequency``, ``Samplig rate``);
    3. any other key whose value is in Hz, kHz, MHz or S/s (``Messrate [Hz]: 500``, ``Erfassung: 2 kHz``),
       unless its words name another frequency (filter, cut-off, motor, rotation, stroke, oscillation...)
       or it is the bare word "frequency" (on a tribometer, the motion's); when several such keys disagree,
       none is used.

    The value's first number is taken; a unit after it (``100 Hz``, ``2 ms``) or in the key is understood
    (a rate in Hz unless written otherwise, a step in s). A rate key with a time unit, or a step key with
    a rate unit, is skipped.
    """
    fuzzy: Optional[HeaderRate] = None
    by_unit: List[HeaderRate] = []
    for key, value in pairs.items():
        base, key_unit = _key_unit(str(key))
        k = _norm_key(base)
        if not k or len(k) > 40:
            continue
        num = _value_number(str(value))
        if num is None:
            continue
        x, u = num
        u = u or (key_unit or "").strip().lower()
        found = _key_kind(k)
        if found is None:
            f = _RATE_UNITS.get(u)
            if f is not None and k not in _BARE_FREQUENCY and not _NOT_RATE_WORDS.search(k):
                by_unit.append(HeaderRate(float(f"{x * f:.12g}"), str(key), "unit"))
            continue
        kind, how = found
        if kind == "rate":
            f = _RATE_UNITS.get(u, 1.0 if not u else None) if u not in _STEP_UNITS else None
            if f is None:
                continue
            hit = HeaderRate(float(f"{x * f:.12g}"), str(key), how)
        else:
            f = _STEP_UNITS.get(u, 1.0 if not u else None)
            if f is None:
                continue
            hit = HeaderRate(float(f"{1.0 / (x * f):.12g}"), str(key), how)
        if how == "key":
            return hit
        if fuzzy is None:
            fuzzy = hit
    if fuzzy is not None:
        return fuzzy
    if by_unit and all(abs(h.hz - by_unit[0].hz) <= 1e-9 * by_unit[0].hz for h in by_unit):
        return by_unit[0]
    return None


def unit_likeness(fields: Sequence[str]) -> float:
    """Share of the non-empty fields that read as units (``N``, ``[N]``, ``(mm/s)``, ``g``, ``-``)."""
    from .units import is_known_unit

    vals = [f.strip().strip("\"'").strip() for f in fields]
    vals = [v for v in vals if v]
    if not vals:
        return 0.0
    hits = 0
    for v in vals:
        inner = v[1:-1].strip() if len(v) >= 2 and v[0] in "[(" and v[-1] in "])" else v
        if inner in ("-", "1", "%") or is_known_unit(inner) or (v != inner and len(inner) <= 8):
            hits += 1
    return hits / len(vals)


# -- the native body reader (Rust, tribodyn._core.text_scan / text_parse) ---------------------


def native_dialect(delimiter: Optional[str], decimal: str, comment: Optional[str], skip_blank: bool = True
                   ) -> Optional[Dict[str, Any]]:  # fmt: skip
    """The keyword arguments of the native scan and parse for this layout, or None when it has none.

    The native reader handles a one-character ASCII separator or whitespace
    runs, a decimal point or comma and an ASCII comment prefix; anything else
    (a longer separator given by the user) is read by the Python parser.
    """
    if delimiter is not None and not (len(delimiter) == 1 and delimiter.isascii()):
        return None
    if decimal not in (".", ","):
        return None
    if comment is not None and not (comment and comment.isascii()):
        return None
    return {"delimiter": delimiter, "decimal": decimal, "comment": comment, "skip_blank": skip_blank}


def native_scan(
    fd: int,
    start: int,
    dialect: Mapping[str, Any],
    *,
    nf: Optional[int],
    probe: int,
    time: Optional[int] = None,
    gap: float = float("nan"),
    t_prev: float = float("nan"),
    keep_times: int = 0,
) -> Dict[str, Any]:
    """The run of data rows from byte ``start`` (see ``tribodyn._core.text_scan``)."""
    from .. import _core
    from ..kernels.threads import read_threads

    try:
        scan = _core.TextScan(
            _core.TextDialect(**dialect), nf=nf, probe=probe, time=time, gap=gap, t_prev=t_prev, keep_times=keep_times
        )
        out: Dict[str, Any] = _core.text_scan(fd, start, scan, threads=read_threads())
    except ValueError as exc:
        raise RecordingError(str(exc)) from None
    return out


class Checkpoints:
    """Where a parse of a text file's data rows may start: sorted (sample, byte offset, line) entries.

    The rows from one entry to the next are consecutive data rows (blank and
    comment lines may sit between them, the parse skips them the same way),
    so any range of samples is read from the entry at or before its start.
    """

    def __init__(
        self, entries: Sequence[Tuple[int, int, int]], n: int, marks: Sequence[Tuple[int, int, int]] = ()
    ) -> None:
        m = np.array(sorted(marks), dtype=np.int64).reshape(-1, 3)
        self.mark_sample, self.mark_offset, self.mark_line = m[:, 0], m[:, 1], m[:, 2]
        a = np.array(sorted(entries), dtype=np.int64).reshape(-1, 3)
        keep = np.ones(len(a), dtype=bool)
        keep[1:] = a[1:, 0] != a[:-1, 0]  # one entry per sample (the first)
        a = a[keep & (a[:, 0] < n)] if len(a) else a
        self.sample, self.offset, self.line = a[:, 0], a[:, 1], a[:, 2]
        self.limit = np.append(self.sample[1:], n)
        self.n = n

    def extended(
        self, entries: Sequence[Tuple[int, int, int]], n: int, marks: Sequence[Tuple[int, int, int]] = ()
    ) -> "Checkpoints":
        """These checkpoints and those of rows after them (a followed file's new rows: every sample of
        ``entries`` at or after :attr:`n`), for ``n`` samples; only the new entries are sorted."""
        new = Checkpoints(entries, n, marks)
        if len(new.sample) and new.sample[0] < self.n:
            raise ValueError("the new checkpoints must follow the old ones")
        out = Checkpoints((), n)
        out.sample, out.offset, out.line = (np.concatenate([a, b]) for a, b in (
            (self.sample, new.sample), (self.offset, new.offset), (self.line, new.line)))  # fmt: skip
        out.mark_sample, out.mark_offset, out.mark_line = (np.concatenate([a, b]) for a, b in (
            (self.mark_sample, new.mark_sample), (self.mark_offset, new.mark_offset),
            (self.mark_line, new.mark_line)))  # fmt: skip
        out.limit = np.append(out.sample[1:], n)
        return out

    def pieces(self, start: int, stop: int) -> List[Tuple[int, int, int, int]]:
        """(offset, line, rows to skip, rows) covering samples ``start:stop`` in order.

        The first piece starts from the last mark (one about every 64 KiB of a native run, see
        ``tribodyn._core.text_scan``) at or before ``start`` when one lies after the entry
        before ``start``, so few rows are skipped; every other piece from an entry.
        """
        out: List[Tuple[int, int, int, int]] = []
        if stop <= start:
            return out
        j = int(np.searchsorted(self.sample, start, side="right")) - 1
        while j < len(self.sample) and self.sample[j] < stop:
            s, off, line = int(self.sample[j]), int(self.offset[j]), int(self.line[j])
            if not out:
                i = int(np.searchsorted(self.mark_sample, start, side="right")) - 1
                if i >= 0 and s <= self.mark_sample[i] and self.mark_offset[i] > off:
                    # between this entry and the next: the rows from the mark on are consecutive
                    s, off, line = int(self.mark_sample[i]), int(self.mark_offset[i]), int(self.mark_line[i])
            a, b = max(start, s), min(stop, int(self.limit[j]))
            if b > a:
                out.append((off, line, a - s, b - a))
            j += 1
        return out


def native_parse(
    path: str,
    pieces: Sequence[Tuple[int, int, int, int]],
    usecols: Sequence[int],
    colnames: Sequence[str],
    dialect: Mapping[str, Any],
) -> List[np.ndarray]:
    """The rows of ``pieces`` as one new float64 array per column of ``usecols``, parsed natively.

    Errors are those of :func:`parse_rows` and :func:`iter_data_lines`, worded the same (by the
    native reader: ``tribodyn._core.text_parse``; the path is put before them here).
    """
    from .. import _core
    from ..kernels.threads import read_threads

    fd = os.open(path, os.O_RDONLY | getattr(os, "O_BINARY", 0))
    try:
        a: List[np.ndarray] = _core.text_parse(
            fd, list(pieces), list(usecols), _core.TextDialect(**dialect), names=list(colnames), threads=read_threads()
        )
        return a
    except ValueError as exc:
        raise RecordingError(f"{path}: {exc}") from None
    finally:
        os.close(fd)


class TextRecording(Recording):
    """What the text readers (delimited, LVM) share: reading any samples natively from the scan's checkpoints.

    A reader sets :attr:`_checkpoints` and :attr:`_parse_dialect` after its
    scan when the layout is read natively (then it is :attr:`random_access`),
    and leaves them None otherwise (its own sequential Python parser).
    """

    # Each read opens its own file handle.
    thread_safe = True
    #: Whether the numeric body is scanned and parsed natively (Rust) when the layout allows it; the
    #: Python parser (the reference of the differential tests) otherwise.
    _use_native = True
    _owned_reads = True  # every array read is new (the native parse's; the Python parser's are copied)
    _checkpoints: Optional[Checkpoints] = None
    _parse_dialect: Optional[Dict[str, Any]] = None
    _usecols: List[int]

    def _text_path(self) -> str:
        """The file the byte offsets refer to."""
        return self.path

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        return self._read_ranges(names, [(start, stop)])

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        assert self._checkpoints is not None and self._parse_dialect is not None, "random access is native only"
        self.check_unchanged()
        column = dict(zip(self._names, self._usecols))
        pieces = [p for a, b in ranges for p in self._checkpoints.pieces(a, b)]
        cols = native_parse(self._text_path(), pieces, [column[n] for n in names], list(names), self._parse_dialect)
        return dict(zip(names, cols))
