"""``tribodyn compare``: replicate tests from the output folders of ``tribodyn analyze`` (docs/method.md 10).

:func:`read_tests` reads every recording's headline from each folder's
``summary.json``; :func:`run_compare` compares them (:func:`tribodyn.compare`)
and writes, all-or-nothing as one folder (:class:`tribodyn.app.outputs.OutputSet`),
``compare.json``, ``compare.csv`` (one row per test), ``compare.png`` (the
tests side by side with the mean and its band) and a self-contained
``report.html``.
"""

from __future__ import annotations

import csv
import html
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

from ..analyses.compare import Comparison, Precision, compare, headline_from_dict
from ..results import Headline
from .outputs import OutputSet, _safe_text, sha256_file, write_json

__all__ = ["SourceTest", "read_tests", "run_compare"]

#: Columns of compare.csv, in order.
CSV_COLUMNS = ("label", "group", "method", "statistic", "value", "low", "high", "se", "weight", "n",
               "fraction_used", "folder", "recording")  # fmt: skip


@dataclass(frozen=True)
class SourceTest:
    """One recording's headline as ``tribodyn analyze`` wrote it."""

    folder: str
    recording: str
    headline: Headline
    meta: Mapping[str, Any]


def _summary_path(folder: str) -> Path:
    p = Path(folder)
    if p.name == "summary.json" and p.is_file():
        return p
    if not p.exists():
        raise FileNotFoundError(f"{folder}: no such folder (give output folders of tribodyn analyze --out)")
    if not p.is_dir():
        raise ValueError(f"{folder} is a file: give an output folder of tribodyn analyze --out (or its summary.json)")
    s = p / "summary.json"
    if not s.is_file():
        raise ValueError(f"{folder} holds no summary.json: give an output folder of tribodyn analyze --out")
    return s


def _not_analyze_summary(path: Path, data: Any) -> str:
    """Why ``path`` (a summary.json without "recordings") is no output folder of tribodyn analyze, and what to give
    instead: one recording's sub-folder of an output of several (its ``headline`` alone; the folder above it holds
    the analysis' summary), or something else (the demo's output)."""
    if isinstance(data, dict) and isinstance(data.get("headline"), dict):
        above = path.parent.parent
        top = above / "summary.json"
        try:
            ours = isinstance(json.loads(top.read_text(encoding="utf-8")).get("recordings"), dict)
        except (OSError, ValueError, AttributeError, RecursionError):
            ours = False
        shown = above if str(above) not in ("", ".") else Path(os.path.abspath(above))  # (not "give .")
        instead = f"the output folder {shown}" if ours else "the output folder above it"
        return (
            f"{path.parent} is one recording's sub-folder of the output of tribodyn analyze with several recordings: "
            f"give {instead} instead (each of its recordings is one test)"
        )
    return (
        f'{path} is not the summary of tribodyn analyze (no "recordings"; the demo\'s output cannot be compared): '
        "analyse the recordings with tribodyn analyze FILES --out DIR"
    )


def read_tests(folders: Sequence[str]) -> Tuple[List[SourceTest], List[str], List[Path]]:
    """(tests, warnings, summary files) of the output folders, in order; each recording is one test.

    Raises
    ------
    ValueError
        A folder without a readable analysis summary, a recording without a
        headline, the same folder twice.
    FileNotFoundError
        A folder that does not exist.
    """
    tests: List[SourceTest] = []
    warnings: List[str] = []
    paths: List[Path] = []
    digests: Dict[str, str] = {}  # input SHA-256 -> the first test that read it
    for folder in folders:
        path = _summary_path(folder)
        real = path.resolve()
        if real in [p.resolve() for p in paths]:
            raise ValueError(f"{folder} is given twice")
        paths.append(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except UnicodeDecodeError:
            raise ValueError(f"{path} is not a tribodyn summary (not UTF-8 text)") from None
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path} is not valid JSON (line {exc.lineno}: {exc.msg})") from None
        except RecursionError:  # issue 34: a document nested thousands deep
            raise ValueError(f"{path} is not a tribodyn summary (JSON nested too deeply to read)") from None
        recs = data.get("recordings") if isinstance(data, dict) else None
        if not isinstance(recs, dict):
            raise ValueError(_not_analyze_summary(path, data))
        failures = data.get("failures")
        for name, f in (failures if isinstance(failures, dict) else {}).items():
            err = f.get("error") if isinstance(f, dict) else f
            warnings.append(f"{folder}: {name} failed in the analysis ({err}): not compared")
        if not recs:
            raise ValueError(f"{path}: no recording was analysed, nothing to compare")
        for name, rec in recs.items():
            head = rec.get("headline") if isinstance(rec, dict) else None
            if not isinstance(head, dict):
                raise ValueError(
                    f"{path}: recording {name} has no headline (written by an older tribodyn?): analyse it again"
                )
            try:
                h = headline_from_dict(head)
            except ValueError as exc:
                raise ValueError(f"{path}: recording {name}: {exc}") from None
            meta = rec.get("meta") if isinstance(rec.get("meta"), dict) else {}
            tests.append(SourceTest(folder=str(folder), recording=str(name), headline=h, meta=meta))
            listed = data.get("inputs") if isinstance(data.get("inputs"), list) else []
            sha = next((i.get("sha256") for i in listed if isinstance(i, dict) and i.get("file") == name
                        and i.get("sha256")), None)  # fmt: skip
            here = f"{folder}: {name}"
            if sha in digests:
                warnings.append(f"{here} is the same recording (SHA-256) as {digests[sha]}: one test counted twice")
            elif sha is not None:
                digests[sha] = here
    return tests, warnings, paths


def _default_labels(tests: Sequence[SourceTest]) -> List[str]:
    """The folder's name for a folder of one recording, else folder/recording; the path as given where names repeat."""
    count: Dict[str, int] = {}
    for t in tests:
        count[t.folder] = count.get(t.folder, 0) + 1

    def base(folder: str, full: bool) -> str:
        p = Path(folder)
        p = p.parent if p.name == "summary.json" else p
        return os.path.normpath(str(p)) if full else (p.resolve().name or str(p))

    for full in (False, True):
        labels = [base(t.folder, full) + ("" if count[t.folder] == 1 else f"/{t.recording}") for t in tests]
        if len(set(labels)) == len(labels):
            return labels
    return labels  # pragma: no cover - distinct folders give distinct normalised paths


def _per_test(values: Optional[Sequence[str]], tests: Sequence[SourceTest], folders: Sequence[str], what: str
              ) -> Optional[List[str]]:  # fmt: skip
    """One name per test; a list with one name per folder applies to each folder's recordings."""
    if values is None:
        return None
    if len(values) == len(tests):
        return list(values)
    if len(values) == len(folders):
        by_folder = dict(zip([str(f) for f in folders], values))
        return [by_folder[t.folder] for t in tests]
    raise ValueError(
        f"--{what}: {len(values)} given for {len(tests)} tests in {len(folders)} folders "
        "(give one per test, or one per folder)"
    )


def run_compare(
    folders: Sequence[str],
    out_dir: Any,
    *,
    labels: Optional[Sequence[str]] = None,
    groups: Optional[Sequence[str]] = None,
    allow_mixed: bool = False,
    overwrite: bool = False,
) -> Dict[str, Any]:
    """Compares the tests of ``folders`` (outputs of ``tribodyn analyze``) and writes ``out_dir`` (docs/method.md 10).

    ``labels`` and ``groups`` hold one name per test, or one per folder.
    Returns the content of ``compare.json``. ``out_dir`` is checked before
    the work and replaced as a whole (:class:`~tribodyn.app.outputs.OutputSet`);
    it may not hold an input's summary.json.
    """
    from .._version import version

    __version__ = version()

    if len(folders) < 1:
        raise ValueError("no output folder given")
    paths = [_summary_path(f) for f in folders]
    output = OutputSet(out_dir, overwrite=overwrite, protect=paths)
    tests, warnings, paths = read_tests(folders)
    lab = _per_test(labels, tests, folders, "labels") or _default_labels(tests)
    grp = _per_test(groups, tests, folders, "groups")
    cmp = compare([t.headline for t in tests], labels=lab, groups=grp, allow_mixed=allow_mixed)
    inputs = [{"folder": str(f), "summary": str(p.resolve()), "sha256": sha256_file(p)} for f, p in zip(folders, paths)]
    result: Dict[str, Any] = {
        "tribodyn_version": __version__,
        "inputs": inputs,
        "comparison": cmp.to_dict(),
        "warnings": warnings,
    }
    for row, t in zip(result["comparison"]["tests"], tests):
        row.update(folder=t.folder, recording=t.recording, meta=dict(t.meta))
    fig = cmp.figure()
    with output as out:
        write_json(result, out.path("compare.json"))
        _write_csv(cmp, tests, out.path("compare.csv"))
        from .figures import save_figure

        save_figure(fig, out.path("compare.png"))
        _write_report(cmp, tests, inputs, warnings, fig=fig, path=out.path("report.html"))
    return result


def _write_csv(cmp: Comparison, tests: Sequence[SourceTest], path: Path) -> None:
    """compare.csv: one row per test (columns :data:`CSV_COLUMNS`); floats round-trip exact, NaN empty."""

    def cell(v: Any) -> str:
        if isinstance(v, float):
            return repr(v) if math.isfinite(v) else ""
        return _safe_text("" if v is None else str(v))

    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(CSV_COLUMNS)
        for r, t in zip(cmp.replicates, tests):
            h = r.headline
            w.writerow([cell(v) for v in (r.label, r.group, h.method, h.statistic, float(h.value), float(h.low),
                                          float(h.high), r.se, r.weight, h.n, float(h.fraction_used), t.folder,
                                          t.recording)])  # fmt: skip


def _f(v: float, digits: int = 4) -> str:
    return f"{v:#.{digits}g}" if math.isfinite(v) else "&ndash;"


def _write_report(cmp: Comparison, tests: Sequence[SourceTest], inputs: Sequence[Mapping[str, Any]],
                  warnings: Sequence[str], *, fig: Any, path: Path) -> None:  # fmt: skip
    """A small self-contained report.html: the verdict, the figure, the tests, the precision, the inputs."""
    import datetime as dt

    from .._version import version

    __version__ = version()
    from .report import _CSS, _png_base64

    esc = html.escape
    png = _png_base64(fig, 110)
    stamp = dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")
    out: List[str] = [
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        f"<title>tribodyn: {cmp.k} tests compared</title>", f"<style>{_CSS}</style>", "</head>", "<body>",
        f"<h1>tribodyn: {cmp.k} tests compared</h1>",
        f'<p class="meta">tribodyn {esc(__version__)} &middot; {esc(stamp)}</p>',
        '<div class="verdict" id="verdict"><h2 style="margin-top:0">Verdict</h2>',
        f'<p class="headline">{esc(cmp.text)}.</p>',
    ]  # fmt: skip
    if cmp.notes:
        out.append("<ul>" + "".join(f"<li>{esc(n)}</li>" for n in cmp.notes) + "</ul>")
    out.append("</div>")
    if warnings:
        out.append('<h2 id="warnings">Warnings</h2><ul>' + "".join(f"<li>{esc(w)}</li>" for w in warnings) + "</ul>")
    cap = (
        "Each test's headline COF with its 95 % interval; grey band: the 95 % interval of the mean; dotted: "
        "the 95 % prediction for a further test [compare.png]"
    )
    out.append(
        f'<h2 id="figure">Tests side by side</h2><figure><img src="data:image/png;base64,{png}" alt="{esc(cap)}">'
        f"<figcaption><b>Figure 1.</b> {esc(cap)}</figcaption></figure>"
    )
    out.append(_tests_table(cmp, tests))
    out.append(_pooled_table(cmp))
    if cmp.precision is not None:
        out.append(_precision_section(cmp.precision))
    irow = "".join(
        f'<tr><td class="key">{esc(str(i["folder"]))}</td><td class="key">{esc(str(i["sha256"]))}</td></tr>'
        for i in inputs
    )
    out.append('<h2 id="inputs">Inputs</h2><table><tr><th class="key">output folder</th>'
               f'<th class="key">summary.json SHA-256</th></tr>{irow}</table>')  # fmt: skip
    out += ["</body>", "</html>", ""]
    path.write_text("\n".join(out), encoding="utf-8")


def _key_value_rows(pairs: Sequence[Tuple[str, str]]) -> str:
    """Table rows of (key, value): the key escaped, the value HTML as given."""
    return "".join(f'<tr><td class="key">{html.escape(k)}</td><td class="text">{v}</td></tr>' for k, v in pairs)


def _tests_table(cmp: Comparison, tests: Sequence[SourceTest]) -> str:
    """The report's "Tests": one row per test, its headline with interval, SE, weight and where it came from."""
    esc = html.escape
    rows = "".join(
        f'<tr><td class="key">{esc(r.label)}</td><td class="text">{esc(r.group or "")}</td>'
        f'<td class="text">{esc(r.headline.method)} {esc(r.headline.statistic)}</td><td>{_f(r.value)}</td>'
        f"<td>{_f(r.low)} to {_f(r.high)}</td><td>{_f(r.se, 3)}</td><td>{100 * r.weight:.1f} %</td>"
        f'<td>{r.headline.n}</td><td class="text">{esc(t.folder)}: {esc(t.recording)}</td></tr>'
        for r, t in zip(cmp.replicates, tests)
    )
    return (
        '<h2 id="tests">Tests</h2><table><tr><th class="key">test</th><th>group</th><th>headline</th><th>COF</th>'
        "<th>95 % interval</th><th>SE</th><th>weight</th><th>n</th><th>from</th></tr>" + rows + "</table>"
    )


def _pooled_table(cmp: Comparison) -> str:
    """The report's "Over the tests": the pooled mean, the scatter between the tests and the prediction."""
    pooled = [
        ("tests", str(cmp.k)),
        ("mean COF", f"{_f(cmp.mean)} (95 % interval {_f(cmp.low)} to {_f(cmp.high)})"),
        ("how", cmp.pooling),
        ("between-test SD beyond the tests' own uncertainty (tau)", _f(cmp.tau, 3)),
        ("SD of the tests' values", _f(cmp.sd, 3)),
        ("Cochran's Q, I²", f"{_f(cmp.q, 3)}, {100 * cmp.i2:.1f} %" if math.isfinite(cmp.i2) else "&ndash;"),
        ("95 % prediction for a further test", f"{_f(cmp.prediction_low)} to {_f(cmp.prediction_high)}"),
    ]
    return '<h2 id="pooled">Over the tests (docs/method.md 10a)</h2><table>' + _key_value_rows(pooled) + "</table>"


def _precision_section(p: Precision) -> str:
    """The report's ISO 5725-2 section: s_r, s_L, s_R with their limits and each group's h and k statistics."""
    esc = html.escape
    prow = "".join(
        f'<tr><td class="key">{esc(g)}</td><td>{n}</td><td>{_f(m)}</td><td>{_f(s, 3)}</td><td>{_f(h, 3)}</td>'
        f'<td>{_f(k, 3)}</td><td class="text">{esc(fl)}</td></tr>'
        for g, n, m, s, h, k, fl in zip(p.groups, p.counts, p.means, p.sds, p.h, p.k, p.flags)
    )
    lines = [
        ("general mean", f"{_f(p.mean)} (95 % interval {_f(p.low)} to {_f(p.high)})"),
        ("repeatability SD s_r, limit r = 2.8 s_r", f"{_f(p.s_r, 3)}, {_f(p.r, 3)}"),
        ("between-group SD s_L", _f(p.s_L, 3)),
        ("reproducibility SD s_R, limit R = 2.8 s_R", f"{_f(p.s_R, 3)}, {_f(p.R, 3)}"),
        ("h critical (1 %, 5 %)", f"{_f(p.h_critical[0], 3)}, {_f(p.h_critical[1], 3)}"),
        ("k critical (1 %, 5 %)", f"{_f(p.k_critical[0], 3)}, {_f(p.k_critical[1], 3)}"),
    ]
    return (
        '<h2 id="precision">Repeatability and reproducibility (ISO 5725-2, docs/method.md 10b)</h2><table>'
        + _key_value_rows(lines)
        + '</table><table><tr><th class="key">group</th><th>tests</th><th>mean</th><th>SD</th><th>h</th>'
        "<th>k</th><th>flag</th></tr>" + prow + "</table>"
    )


def _name_list(text: Optional[str], what: str) -> Optional[List[str]]:
    """``"a,b,c"`` -> ["a", "b", "c"]; an empty name is an error."""
    if text is None:
        return None
    names = [x.strip() for x in text.split(",")]
    if any(not x for x in names):
        raise ValueError(f"--{what} takes names separated by commas, got {text!r} (an empty name)")
    return names


def cli_compare(ns: Any) -> int:
    """``tribodyn compare``: run :func:`run_compare`, print the comparison (unless --quiet) and the warnings."""
    import sys

    result = run_compare(
        ns.folders,
        ns.out,
        labels=_name_list(ns.labels, "labels"),
        groups=_name_list(ns.groups, "groups"),
        allow_mixed=ns.allow_mixed,
        overwrite=ns.overwrite,
    )
    if not ns.quiet:
        cmp = result["comparison"]
        for t in cmp["tests"]:
            grp = f" [{t['group']}]" if t.get("group") else ""
            print(f"{t['label']}{grp}: {t['headline']['text']}")
        print(cmp["text"])
        for note in cmp["notes"]:
            print(f"  note: {note}")
        print(f"outputs in {ns.out}/ (compare.json, compare.csv, compare.png, report.html)")
    for w in result["warnings"]:
        print(f"tribodyn: warning: {w}", file=sys.stderr)
    return 0
