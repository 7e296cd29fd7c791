"""The native text body reader (Rust ``text_scan``/``text_parse``) against the Python reader it replaces.

Every generated file is opened twice, natively and with the Python parser
(``_use_native = False``, the reference), and must give the same recording:
samples bit for bit (NaN included), segments, rate, warnings, metadata, and
the same error, worded the same, for a file either refuses. Files are
generated from seeds with the quirks real exports have (decimal commas,
blank and comment lines, empty fields, exponents, long mantissas, NaN/inf,
CRLF, trailing separators, footers, repeated column rows, time restarts and
gaps, cut last rows, text in a number column) and random edits on top.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import pytest
from tribodyn.io import RecordingError, open_recording
from tribodyn.io.delimited import DelimitedRecording
from tribodyn.io.lvm import LvmRecording


def _open(path: Path, native: bool, **kw: Any) -> Tuple[str, Any]:
    """("ok", recording facts) or ("error", message) for one way of reading."""
    saved = (DelimitedRecording._use_native, LvmRecording._use_native)
    DelimitedRecording._use_native = LvmRecording._use_native = native
    try:
        with open_recording(str(path), **kw) as rec:
            facts: Dict[str, Any] = {
                "n": rec.n_samples,
                "fs": rec.fs,
                "segments": rec.segments,
                "warnings": list(rec.warnings),
                "metadata": rec.metadata,
                "names": rec.channel_names,
                "random_access": rec.random_access,
            }
            data = rec.read(rec.channel_names)
            facts["data"] = {k: v.tobytes() for k, v in data.items()}
            if rec.n_samples > 10:
                a, b = rec.n_samples // 3, rec.n_samples // 3 + 7
                part = next(rec.chunks(b - a, rec.channel_names, start=a, stop=b))
                facts["part"] = {k: v.tobytes() for k, v in part.items()}
            return "ok", facts
    except RecordingError as exc:
        return "error", str(exc)
    finally:
        DelimitedRecording._use_native, LvmRecording._use_native = saved


def _same(path: Path, **kw: Any) -> Tuple[str, Any]:
    py = _open(path, False, **kw)
    rs = _open(path, True, **kw)
    if py[0] == "ok" and rs[0] == "ok":
        assert rs[1]["random_access"] or rs[1]["n"] == 0
        py[1].pop("random_access"), rs[1].pop("random_access")
    assert rs == py, f"{path.name}: native {rs[0]} vs python {py[0]}"
    return rs


_NUMBER_STYLES = ("plain", "exp", "long", "plus", "spaced")


def _fmt(v: float, style: str, decimal: str) -> str:
    if not np.isfinite(v):
        s = ("nan", "NaN", "inf", "-Infinity")[len(style) % 4]
    elif style == "exp":
        s = f"{v:.6e}"
    elif style == "long":
        s = f"{v:.22f}"
    elif style == "plus":
        s = f"{v:+.5f}"
    elif style == "spaced":
        s = f"  {v:.4f} "
    else:
        s = repr(round(v, 6))
    return s.replace(".", decimal) if decimal == "," else s


def _table(rng: np.random.Generator, *, delim: Optional[str], decimal: str, rows: int, quirks: bool) -> str:
    quirky = quirks
    sep = delim if delim is not None else "  "
    names = ["time", "fx", "fy", "fz", "i"]
    lines: List[str] = []
    if quirks and rng.random() < 0.5:
        lines.append("# exported by a rig")
    lines.append(sep.join(names))
    if rng.random() < 0.5:
        lines.append(sep.join(["s", "N", "N", "N", "A"]))
    t = 0.0
    head_rows = min(500, rows // 4)  # a clean head (the sniffer's part), quirks in the body
    for r in range(rows):
        quirks = quirky and r >= head_rows
        t += 0.001
        if quirks and rng.random() < 0.002:
            t -= 0.5 if rng.random() < 0.5 else -0.2  # restart / gap
        vals = rng.normal(size=4) * 10.0 ** float(rng.integers(-3, 3))
        style = str(rng.choice(_NUMBER_STYLES)) if quirks and rng.random() < 0.3 else "plain"
        fields = [repr(round(t, 3)).replace(".", decimal) if decimal == "," else repr(round(t, 3))]
        for v in vals:
            if quirks and rng.random() < 0.003:
                v = float("nan") if rng.random() < 0.5 else float("inf")
            fields.append(_fmt(float(v), style, decimal))
        if quirks and delim is not None and rng.random() < 0.003:
            fields[int(rng.integers(1, 5))] = ""
        line = sep.join(fields)
        if quirks and delim is not None and rng.random() < 0.01:
            line += delim  # trailing separator: an empty extra field
        lines.append(line)
        if quirks and rng.random() < 0.003:
            lines.append("" if rng.random() < 0.5 else "# pause")
    if quirky and rng.random() < 0.3:
        lines.append("Test completed")
    eol = "\r\n" if quirky and rng.random() < 0.3 else "\n"
    return eol.join(lines) + eol


def _mutate(text: bytes, rng: np.random.Generator) -> bytes:
    b = bytearray(text)
    for _ in range(int(rng.integers(1, 4))):
        kind = rng.integers(0, 5)
        at = int(rng.integers(len(b) // 4, len(b)))
        if kind == 0:
            del b[at:]  # cut
        elif kind == 1:
            b[at:at] = b"x"  # text in a number
        elif kind == 2:
            b[at:at] = b"\n"  # split a row
        elif kind == 3 and at < len(b):
            del b[at]  # lose a byte (maybe a separator or a line end)
        else:
            b[at:at] = b"1e400,"
    return bytes(b)


DIALECTS = [(",", "."), (";", ","), ("\t", "."), ("\t", ","), (None, "."), ("|", ".")]


@pytest.mark.fast
@pytest.mark.parametrize("k", range(len(DIALECTS)))
def test_native_equals_python_on_clean_and_quirky_tables(tmp_path: Path, k: int) -> None:
    delim, decimal = DIALECTS[k]
    rng = np.random.default_rng(1000 + k)
    for j, quirks in enumerate((False, True, True)):
        p = tmp_path / f"t{k}_{j}.csv"
        p.write_text(_table(rng, delim=delim, decimal=decimal, rows=3000, quirks=quirks))
        # quirky files name their layout (the subject is the body, not the sniffer's guess)
        kw = {"delimiter": delim or "whitespace", "decimal": decimal} if quirks else {}
        kind, facts = _same(p, **kw)
        assert kind == "ok", facts
        assert facts["n"] >= 2500  # the sniffer may take a quirky first stretch for header lines


def test_native_equals_python_on_damaged_files(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    kinds = {"ok": 0, "error": 0}
    for j in range(60):
        delim, decimal = DIALECTS[j % len(DIALECTS)]
        text = _table(rng, delim=delim, decimal=decimal, rows=400, quirks=j % 2 == 0).encode()
        p = tmp_path / f"m{j}.csv"
        p.write_bytes(_mutate(text, rng))
        kind, _ = _same(p)
        kinds[kind] += 1
    assert kinds["ok"] and kinds["error"], kinds  # both outcomes were exercised


@pytest.mark.fast
def test_native_errors_name_the_line(tmp_path: Path) -> None:
    p = tmp_path / "bad.csv"
    rows = [f"{i / 1000:.3f},{i},{i},{i}" for i in range(5000)]
    rows[3210] = "3.210,1,abc,3"
    p.write_text("time,fx,fy,fz\n" + "\n".join(rows) + "\n")
    with open_recording(str(p)) as rec:
        with pytest.raises(RecordingError, match=r"line 3212: 'abc' in channel 'fy' is not a number"):
            rec.read()
    kind, msg = _same(p)  # both readers open it and fail at reading, with the same words
    assert kind == "error" and "line 3212" in msg


@pytest.mark.fast
def test_native_errors_quote_odd_bytes_and_names_as_python(tmp_path: Path) -> None:
    """The native reader words a bad field as Python's repr of its latin-1 text (quotes, escapes,
    bytes that are not printable, the first 40 characters) and the channel by repr of its name."""
    p = tmp_path / "odd.csv"
    field = b"a'b\\\xad\x7f\x85z\xe9" + b"9" * 45
    rows = [f"{i / 1000:.3f},{i},{i},{i}".encode() for i in range(3000)]
    rows[2500] = b"2.500,1," + field + b",3"
    p.write_bytes(b'time,fx,fy "q",fz\n' + b"\n".join(rows) + b"\n")
    kind, msg = _same(p)  # both readers fail at reading, with the same words
    quoted = repr(field.decode("latin-1")[:40])
    assert kind == "error" and f"line 2502: {quoted} in channel " in msg, msg


@pytest.mark.fast
def test_native_lvm_equals_python(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    for j, decimal in enumerate((".", ",", ".")):
        n = 4000
        x = rng.normal(size=(n, 3))
        head = (
            "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\n"
            f"Decimal_Separator\t{decimal}\nMulti_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\n"
            "Operator\tx\nDate\t2026/11/22\nTime\t10:00:00\n***End_of_Header***\t\n\n"
            "Channels\t3\t\t\t\nSamples\t4000\t4000\t4000\t\nDate\t2026/11/22\t2026/11/22\t2026/11/22\t\n"
            "Time\t10:00:00\t10:00:00\t10:00:00\t\nY_Unit_Label\tN\tN\tN\t\nX_Dimension\tTime\tTime\tTime\t\n"
            "X0\t0\t0\t0\t\nDelta_X\t0.001\t0.001\t0.001\t\n***End_of_Header***\t\t\t\t\n"
            "X_Value\tfy\tfz\tfx\tComment\n"
        )
        body = []
        for r in range(n):
            vals = [f"{r / 1000:.3f}"] + [f"{v:.6f}" for v in x[r]]
            body.append("\t".join(vals).replace(".", decimal) if decimal == "," else "\t".join(vals))
        p = tmp_path / f"r{j}.lvm"
        text = head + "\n".join(body) + "\n"
        if j == 2:
            text = text[: len(text) - 9]  # a cut last row: refused, the same way
        p.write_text(text)
        kind, facts = _same(p)
        assert kind == ("error" if j == 2 else "ok"), facts


def test_thread_count_does_not_change_the_result(tmp_path: Path) -> None:
    from tribodyn.kernels import threads

    rng = np.random.default_rng(5)
    p = tmp_path / "big.csv"
    p.write_text(_table(rng, delim=",", decimal=".", rows=120_000, quirks=True))
    seen = []
    old = threads.get_threads()
    try:
        for n in (1, 2, 3):
            threads.set_threads(n)
            seen.append(_open(p, True))
    finally:
        threads.set_threads(old)
    assert seen[0][0] == "ok"
    assert seen[0] == seen[1] == seen[2]
    py = _open(p, False)
    assert seen[0][1].pop("random_access") and not py[1].pop("random_access")
    assert seen[0] == py


@pytest.mark.fast
def test_native_is_what_a_plain_file_gets(tmp_path: Path) -> None:
    p = tmp_path / "plain.csv"
    p.write_text("time,fx,fy,fz\n" + "".join(f"{i / 1000:.3f},1,2,3\n" for i in range(100)))
    with open_recording(str(p)) as rec:
        assert rec.random_access and rec._checkpoints is not None  # type: ignore[attr-defined]
    # a separator of two characters is read by the Python parser
    q = tmp_path / "two.csv"
    q.write_text("time::fx::fy\n" + "".join(f"{i / 1000:.3f}::1::2\n" for i in range(100)))
    with open_recording(str(q), delimiter="::") as rec:
        assert not rec.random_access and rec.n_samples == 100
    os.unlink(q)


@pytest.mark.fast
@pytest.mark.parametrize(
    "content, kw",
    [
        # a line of tabs only is blank to Python's bytes.strip(): skipped, never a row (fuzz, kind A)
        (b"t\tx\n0\t1\n0.001\t2\n\t\n0.002\t3\n", {"delimiter": "\t"}),
        (b"t\tx\ty\n0\t1\t1\n0.001\t2\t2\n\t\t\t\n0.002\t3\t3\n", {"delimiter": "\t"}),
        (b"t\tx\n0\t1\n0.001\t2\n \t \r\n0.002\t3\n0.003\t4\n", {"delimiter": "\t"}),
        (
            b"LabVIEW Measurement\n***End_of_Header***\nDelta_X\t1\n***End_of_Header***\nX_Value\ta\tb\tComment\n"
            b"0\t1\t2\n1\t3\t4\n\t\t\n2\t5\t6\n",
            {},
        ),
        # a short row holding a non-number: the width is reported first, as Python does (kind B)
        (
            b"LabVIEW Measurement\n***End_of_Header***\nDelta_X\t1\n***End_of_Header***\nX_Value\ta\tb\tComment\n"
            b"0\t1\t2\n1\t3x4\n2\t5\t6\n",
            {},
        ),
        # a number of more than 400 characters is still a number (kind C)
        (b"t,a\n0,1\n0.001," + b"1" * 401 + b"\n0.002,3\n", {}),
        (b"t;a\n0;1\n0,001;0," + b"0" * 500 + b"15\n0,002;3\n", {"delimiter": ";", "decimal": ","}),
    ],
)
def test_fuzz_findings(tmp_path: Path, content: bytes, kw: Dict[str, Any]) -> None:
    p = tmp_path / ("f.lvm" if content.startswith(b"LabVIEW") else "f.csv")
    p.write_bytes(content)
    _same(p, **kw)
