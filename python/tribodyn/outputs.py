"""Output files of an analysis: per-window tables (CSV, Parquet), the JSON
summary, figures and the report, written all-or-nothing.

:class:`OutputSet` stages every file in a hidden directory beside the
targets and moves them into place only when the whole set was written; on
any failure (or an interruption) the staging directory is removed, so no
partial or half-written output is ever left behind. Each move is an atomic
``os.replace``.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from types import TracebackType
from typing import Any, Dict, Iterable, List, Optional, Type, Union

import numpy as np

from .io.writers import sha256_file
from .results import Results

__all__ = ["OutputSet", "write_table_csv", "write_table_parquet", "write_json", "sha256_file", "jsonable"]

PathLike = Union[str, "os.PathLike[str]"]


class OutputSet:
    """Collects output files in a staging directory, then publishes them together.

    Examples
    --------
    >>> with OutputSet("out") as out:
    ...     write_table_csv(results, out.path("windows.csv"))
    ...     write_json(summary, out.path("summary.json"))
    >>> # out/windows.csv and out/summary.json now exist, or neither does.
    """

    def __init__(self, directory: PathLike) -> None:
        self.directory = Path(directory)
        self._stage: Optional[Path] = None
        self.written: List[Path] = []

    def __enter__(self) -> "OutputSet":
        self.directory.mkdir(parents=True, exist_ok=True)
        self._stage = Path(tempfile.mkdtemp(prefix=".tribodyn-partial-", dir=self.directory))
        return self

    def path(self, name: str) -> Path:
        """Where to write output ``name`` (a relative path, sub-folders allowed)."""
        if self._stage is None:
            raise RuntimeError("OutputSet.path() outside its with-block")
        p = self._stage / name
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def __exit__(
        self, et: Optional[Type[BaseException]], ev: Optional[BaseException], tb: Optional[TracebackType]
    ) -> None:
        stage, self._stage = self._stage, None
        if stage is None:
            return
        try:
            if et is None:
                for src in sorted(p for p in stage.rglob("*") if p.is_file()):
                    dst = self.directory / src.relative_to(stage)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(src, dst)
                    self.written.append(dst)
        finally:
            shutil.rmtree(stage, ignore_errors=True)


def jsonable(x: Any) -> Any:
    """Converts numpy scalars/arrays, tuples and NaN to plain JSON values (NaN -> null)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return [jsonable(v) for v in x.tolist()]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if isinstance(x, Path):
        return str(x)
    return x


def write_json(obj: Any, path: PathLike) -> None:
    """Writes ``obj`` as indented JSON (NaN as null)."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(jsonable(obj), f, indent=2, sort_keys=False)
        f.write("\n")


def _columns(results: Results, extra: Optional[Dict[str, Any]] = None) -> Dict[str, np.ndarray]:
    cols: Dict[str, np.ndarray] = {}
    n = len(results)
    for k, v in (extra or {}).items():
        cols[k] = np.asarray(v) if np.ndim(v) else np.full(n, v)
    cols.update(results.table)
    return cols


def write_table_csv(results: Results, path: PathLike, *, extra: Optional[Dict[str, Any]] = None) -> None:
    """Per-window table as CSV, one row per window (columns: ``WINDOW_COLUMNS``).

    ``extra`` adds leading columns (e.g. ``recording``). Floats are written
    with 17 significant digits (round-trip exact); NaN as an empty field.
    """
    cols = _columns(results, extra)
    names = list(cols)
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(names)
        for row in zip(*(cols[c] for c in names)):
            w.writerow([_cell(v) for v in row])


def _cell(v: Any) -> str:
    if isinstance(v, (float, np.floating)):
        return "" if not np.isfinite(v) else repr(float(v))
    if isinstance(v, (np.bool_, bool)):
        return "true" if v else "false"
    return str(v)


def write_table_parquet(results: Results, path: PathLike, *, extra: Optional[Dict[str, Any]] = None) -> bool:
    """Per-window table as Parquet (needs pyarrow). Returns False if pyarrow is missing."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return False
    cols = _columns(results, extra)
    table = pa.table({k: (v.astype(str) if v.dtype == object else v) for k, v in cols.items()})
    pq.write_table(table, str(path))
    return True


def input_provenance(paths: Iterable[PathLike]) -> List[Dict[str, Any]]:
    """Name, size and SHA-256 of each input file."""
    out = []
    for p in paths:
        p = Path(p)
        out.append({"file": p.name, "path": str(p.resolve()), "bytes": p.stat().st_size, "sha256": sha256_file(p)})
    return out
