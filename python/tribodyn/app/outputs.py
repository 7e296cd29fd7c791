"""Output files of an analysis: per-window tables (CSV, Parquet), the JSON
summary, figures and the report, written all-or-nothing as one folder.

:class:`OutputSet` writes every file into a staging folder beside the
output folder (``<out>.tribodyn-staging-<pid>-<random>``) and, once the
whole set is written, swaps the folders with two renames: the previous
``<out>`` is renamed aside (``<out>.tribodyn-old-<pid>-<random>``), the
staging folder is renamed to ``<out>``, and the old one is removed. So
``<out>`` holds either the previous set or the complete new one, never a
mix, and never files of an earlier run beside the new ones; a set that
fails into a new ``<out>`` removes the folders it created (``<out>`` and
missing parents): nothing is left where there was nothing. SIGINT and
SIGTERM are held back during the two renames. A run that was killed
(SIGKILL, power loss) leaves its staging or aside folder behind; the next
run into the same ``<out>`` recognises them by name (and a dead process
id), puts a complete previous set back if ``<out>`` is missing, and removes
the rest.

Every set holds a marker file :data:`MARKER` listing its files. A non-empty
``<out>`` holding anything that is not part of a previous set (no marker, or
a file, folder or link the marker does not list) is refused with
:class:`OutputError` unless ``overwrite=True``. Symbolic links are never
followed: a symlinked ``<out>`` is refused, links inside it are foreign
entries (and removed, not followed, when replaced).
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import re
import secrets
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path
from types import TracebackType
from typing import Any, Dict, Iterable, Iterator, List, Optional, Set, Tuple, Type, Union

import numpy as np

from .. import _core
from ..io.writers import DIGEST_STEP, _fsync_dir, sha256_file
from ..results import Results
from ..errors import OutputError

__all__ = [
    "MARKER",
    "OutputError",
    "OutputSet",
    "publish",
    "write_table_csv",
    "write_table_parquet",
    "write_json",
    "sha256_file",
    "fill_digests",
    "Digests",
    "jsonable",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Marker file written into every output set: JSON with the set's file list.
MARKER = ".tribodyn-output"
_STAGING = "tribodyn-staging"
_ASIDE = "tribodyn-old"
#: Files a desktop's file browser drops into folders it shows; not foreign.
_DESKTOP_FILES = frozenset({".DS_Store", "Thumbs.db", "desktop.ini"})


def _work_prefix(target: Path) -> str:
    # Room for the suffix within the usual 255-byte limit of a file name.
    return target.name[:160]


def _work_pattern(target: Path) -> "re.Pattern[str]":
    return re.compile(re.escape(_work_prefix(target)) + rf"\.({_STAGING}|{_ASIDE})-(\d+)-[A-Za-z0-9_]+$")


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` may still be running (then its staging folder is not stale)."""
    if pid == os.getpid():
        return True
    if os.name != "posix":  # no harmless liveness probe (os.kill(pid, 0) would signal it on Windows)
        return False
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):
        return False
    except OSError:  # EPERM: alive, another user's
        return True
    return True


def _read_marker(folder: Path) -> Optional[Set[str]]:
    """The files a set's marker lists, or None (no marker, a link, unreadable)."""
    p = folder / MARKER
    try:
        if not stat.S_ISREG(os.lstat(p).st_mode):
            return None
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # RecursionError: a marker nested thousands deep
        return None
    files = data.get("files") if isinstance(data, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return set(files)


def _entries(folder: Path) -> Iterator[os.DirEntry[str]]:
    """Every entry below ``folder``, depth first, never following a symbolic link."""
    with os.scandir(folder) as it:
        entries = sorted(it, key=lambda e: e.name)
    for e in entries:
        yield e
        if e.is_dir(follow_symlinks=False):
            yield from _entries(Path(e.path))


def _foreign_entry(folder: Path) -> Optional[str]:
    """The first entry of ``folder`` that is not part of a previous output set, or None."""
    listed = _read_marker(folder)
    files: Set[str] = set() if listed is None else listed | {MARKER}
    dirs: Set[str] = set()
    for f in files:
        dirs.update(p.as_posix() for p in Path(f).parents if p.parts)
    for e in _entries(folder):
        rel = Path(e.path).relative_to(folder).as_posix()
        if e.is_file(follow_symlinks=False) and (e.name in _DESKTOP_FILES or rel in files):
            continue
        if e.is_dir(follow_symlinks=False) and rel in dirs:
            continue
        if e.is_symlink():
            return f"the symbolic link {rel!r}"
        return repr(rel)
    return None


def _complete(folder: Path) -> bool:
    """True when ``folder`` holds a marker and every file it lists."""
    listed = _read_marker(folder)
    return listed is not None and all((folder / f).is_file() for f in listed)


def _within(inner: PathLike, outer: Path) -> bool:
    """Whether ``inner`` is ``outer`` or lies inside it (both resolved)."""
    a, b = os.path.realpath(inner), os.path.realpath(outer)
    try:
        return os.path.commonpath([a, b]) == b
    except ValueError:  # different drives
        return False


#: Threads that flush a set's files at once (:func:`_sync_tree`).
_SYNC_THREADS = 16


def _sync_entry(e: "os.DirEntry[str]") -> None:
    if e.is_file(follow_symlinks=False):
        with open(e.path, "rb+") as fh:
            os.fsync(fh.fileno())
    elif e.is_dir(follow_symlinks=False):
        _fsync_dir(Path(e.path))


def _sync_tree(folder: Path) -> None:
    """Flushes every file (and folder) of the set to disk before it is published, many at once: each
    ``fsync`` waits for the disk outside the GIL, and the file system commits those in flight together (a
    folder of 8 exports' 54 files: 0.16-0.31 s one after the other, 0.03 s from 16 threads on this machine's
    ext4; issue 38 point 3). What a flush raises is raised here, before anything is published."""
    entries = list(_entries(folder))
    if entries:
        from ..kernels.threads import thread_pool

        with thread_pool(min(_SYNC_THREADS, len(entries)), "tribodyn-fsync") as pool:
            for _ in pool.map(_sync_entry, entries):  # (raises the first failure, once all are done)
                pass
    _fsync_dir(folder)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Holds SIGINT and SIGTERM back (main thread only) and re-raises them at the end."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: List[int] = []
    saved: Dict[int, Any] = {}
    for name in ("SIGINT", "SIGTERM"):
        sig = getattr(signal, name, None)
        if sig is None or signal.getsignal(sig) is None:
            continue
        try:
            saved[sig] = signal.signal(sig, lambda num, frame: got.append(num))
        except (ValueError, OSError):  # pragma: no cover
            pass
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(got):
            signal.raise_signal(sig)


def publish(stage: PathLike, target: PathLike, *, durable: bool = True) -> None:
    """Replaces folder ``target`` (if any) by folder ``stage``, in the same parent folder.

    Two renames: ``target`` to an aside name, ``stage`` to ``target``; then
    the aside folder is removed. If the second rename fails, the first is
    undone. SIGINT/SIGTERM wait until both renames are done; after a hard
    kill in between, ``target`` is missing and the aside folder holds the
    previous set, which the next :class:`OutputSet` into ``target`` puts
    back. ``durable``: the parent folder flushed to disk after the swap.
    """
    stage, target = Path(stage), Path(target)
    aside: Optional[Path] = None
    swapped = False
    try:
        with _signals_held():  # a held-back signal is raised on leaving, after the swap
            if os.path.lexists(target):
                if os.path.islink(target) or not target.is_dir():
                    raise OutputError(f"output folder {target} is not a folder (or is a symbolic link)")
                aside = target.parent / f"{_work_prefix(target)}.{_ASIDE}-{os.getpid()}-{secrets.token_hex(4)}"
                os.rename(target, aside)
            try:
                os.rename(stage, target)
                swapped = True
            except BaseException:
                if aside is not None:
                    try:
                        os.rename(aside, target)
                    except OSError:  # left for the next run to put back
                        pass
                raise
    finally:
        if swapped:
            if durable:
                _fsync_dir(target.parent)
            if aside is not None:
                shutil.rmtree(aside, ignore_errors=True)


class OutputSet:
    """Collects output files in a staging folder, then publishes them together as ``directory``.

    Parameters
    ----------
    directory : str or PathLike
        The output folder. It may be missing, empty, or hold a previous
        output set (its marker lists every file in it); anything else is
        refused unless ``overwrite``.
    overwrite : bool
        Replace the folder even when it holds other files.
    protect : iterable of paths
        Files that must not lie in the folder (the inputs): refused even
        with ``overwrite``.
    durable : bool
        Flush the files and folders to disk before and after the swap
        (default). A set replaced again within seconds (the live outputs of
        ``tribodyn watch``) skips it: readers still see the old set or the
        new one, never a mix; after a power cut the folder may hold an
        older set.

    Raises
    ------
    OutputError
        When the folder cannot take the set (checked here, before the
        work, and again on entering the with-block): it is a file, a
        symbolic link, a filesystem root, a mount point, the current
        folder (or holds it), the home folder (or holds it), holds a
        protected file, or holds foreign files and not ``overwrite``.

    Examples
    --------
    >>> with OutputSet("out") as out:
    ...     write_table_csv(results, out.path("windows.csv"))
    ...     write_json(summary, out.path("summary.json"))
    >>> # out/ now holds windows.csv, summary.json and the marker, and nothing else;
    >>> # after a failure it holds what it held before.
    """

    def __init__(self, directory: PathLike, *, overwrite: bool = False, protect: Iterable[PathLike] = (),
                 durable: bool = True) -> None:  # fmt: skip
        text = os.fspath(directory)
        if not text.strip():
            raise OutputError("the output folder name is empty")
        self.directory = Path(text)
        self.target = Path(os.path.abspath(text))
        self.overwrite = overwrite
        self.protect = [os.fspath(p) for p in protect]
        self.durable = durable
        self._stage: Optional[Path] = None
        self._made: List[Path] = []  # folders __enter__ created (the target and missing parents), outermost first
        self.written: List[Path] = []
        self.check()

    def check(self) -> None:
        """Raises :class:`OutputError` unless the set may replace the folder (changes nothing)."""
        t, shown = self.target, self.directory
        if t.parent == t:
            raise OutputError(f"output folder {shown} is a filesystem root: give a folder inside it")
        if os.path.islink(t):
            raise OutputError(f"output folder {shown} is a symbolic link: give the folder it points to")
        if not os.path.lexists(t):
            up = t.parent
            while not os.path.lexists(up) and up.parent != up:
                up = up.parent
            if not up.is_dir():
                raise OutputError(f"output folder {shown}: {up} is a file, not a folder")
            return
        if not t.is_dir():
            raise OutputError(f"output folder {shown} exists and is a file, not a folder")
        if os.path.ismount(t):
            raise OutputError(f"output folder {shown} is a mount point: give a folder inside it")
        for what, p in (("current folder", os.getcwd()), ("home folder", os.path.expanduser("~"))):
            if _within(p, t):
                raise OutputError(f"output folder {shown} is or holds the {what}: give a folder of its own")
        for p in self.protect:
            if _within(p, t):
                raise OutputError(f"output folder {shown} holds the input {p}: give another folder")
        if not self.overwrite:
            foreign = _foreign_entry(t)
            if foreign is not None:
                raise OutputError(
                    f"output folder {shown} holds {foreign}, which is not part of a previous tribodyn output "
                    f"set: give another folder, or pass overwrite=True to replace everything in it"
                )

    def _recover(self) -> None:
        """Puts back a previous set a killed run left aside (if ``directory`` is missing), removes the rest."""
        parent, pattern = self.target.parent, _work_pattern(self.target)
        stale: List[Path] = []
        with os.scandir(parent) as it:
            for e in it:
                m = pattern.match(e.name)
                if m and e.is_dir(follow_symlinks=False) and not _pid_alive(int(m.group(2))):
                    stale.append(Path(e.path))
        if not os.path.lexists(self.target):
            old = [p for p in stale if f".{_ASIDE}-" in p.name and _complete(p)]
            if old:
                newest = max(old, key=lambda p: os.lstat(p / MARKER).st_mtime)
                os.rename(newest, self.target)
                stale.remove(newest)
        for p in stale:
            shutil.rmtree(p, ignore_errors=True)

    def __enter__(self) -> "OutputSet":
        parent = self.target.parent
        self._made = [p for p in (*reversed(self.target.parents), self.target) if not os.path.lexists(p)]
        try:
            parent.mkdir(parents=True, exist_ok=True)
            self._recover()
            self.check()
            # The folder exists (empty if new) while the job runs, as a place holder.
            self.target.mkdir(exist_ok=True)
            self._stage = Path(
                tempfile.mkdtemp(prefix=f"{_work_prefix(self.target)}.{_STAGING}-{os.getpid()}-", dir=parent)
            )
        except BaseException:
            self._remove_made()
            raise
        return self

    def _remove_made(self) -> None:
        """Removes the folders :meth:`__enter__` created, innermost first, as long as they are empty: a set that
        failed leaves nothing where there was nothing."""
        made, self._made = self._made, []
        for p in reversed(made):
            try:
                os.rmdir(p)
            except OSError:  # not empty (another run's, or something put there meanwhile) or already gone
                break

    def path(self, name: str) -> Path:
        """Where to write output ``name`` (a relative path, sub-folders allowed)."""
        if self._stage is None:
            raise RuntimeError("OutputSet.path() outside its with-block")
        rel = Path(name)
        if not rel.parts or rel.is_absolute() or ".." in rel.parts or rel.as_posix() == MARKER:
            raise ValueError(f"output name {name!r} must be a relative path inside the set (not {MARKER})")
        p = self._stage / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def __exit__(
        self, et: Optional[Type[BaseException]], ev: Optional[BaseException], tb: Optional[TracebackType]
    ) -> None:
        stage, self._stage = self._stage, None
        if stage is None:
            return
        published = False
        try:
            if et is None:
                files = sorted(
                    Path(e.path).relative_to(stage).as_posix()
                    for e in _entries(stage)
                    if e.is_file(follow_symlinks=False)
                )
                _write_marker(stage, files)
                if self.durable:
                    _sync_tree(stage)
                publish(stage, self.target, durable=self.durable)
                published = True
                self.written = [self.target / f for f in files]
        finally:
            if os.path.lexists(stage):
                shutil.rmtree(stage, ignore_errors=True)
            if published:
                self._made = []
            else:
                self._remove_made()


def _write_marker(stage: Path, files: List[str]) -> None:
    from .._version import version

    __version__ = version()

    data = {"tribodyn_output": 1, "tribodyn_version": __version__, "files": files}
    (stage / MARKER).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


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

    Text cells are made safe for spreadsheets (CSV formula injection, as the
    OWASP advises): a text cell (a recording name, a reason, a header)
    starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return is
    written with a leading single quote (``'=1+2``), so Excel, LibreOffice
    and the like show it as text instead of evaluating it. Numbers, also
    negative ones in numeric columns, are written unchanged.
    """
    cols = _columns(results, extra)
    names = list(cols)
    header = [_safe_text(str(n)) for n in names]
    cells = [_column_cells(cols[c]) for c in names]
    with open(path, "w", newline="", encoding="utf-8") as f:
        if len(names) < 2:  # (csv quotes a row of one empty field: its own writer)
            w = csv.writer(f)
            w.writerow(header)
            w.writerows(zip(*cells))
            return
        # The text csv.writer (the excel dialect) writes, built a line at a time by str.join: numbers never need
        # quoting, text cells are quoted as csv quotes them (_csv_text); ~10x faster than writerows (issue 38).
        quoted = [c if _numeric(cols[n]) else list(map(_csv_text, c)) for n, c in zip(names, cells)]
        lines = [",".join(map(_csv_text, header)), *map(",".join, zip(*quoted))]
        f.write("\r\n".join(lines))
        f.write("\r\n")


def _column_cells(v: np.ndarray) -> List[str]:
    """:func:`_cell` of every value of a column, converted once per column (a numeric column's values
    through ``tolist``, which gives the Python bools, floats and ints ``_cell`` formats)."""
    v = np.asarray(v)
    if v.dtype == np.bool_:
        return ["true" if x else "false" for x in v.tolist()]
    if np.issubdtype(v.dtype, np.floating):
        return [repr(x) if math.isfinite(x) else "" for x in v.tolist()]
    if np.issubdtype(v.dtype, np.integer):
        return [str(x) for x in v.tolist()]
    return [_cell(x) for x in v]


def _numeric(v: np.ndarray) -> bool:
    """Whether :func:`_column_cells` writes ``v`` as numbers or true/false (no cell of it is ever quoted)."""
    kind = np.asarray(v).dtype.kind
    return kind in "bfiu"


#: Characters that make csv.writer (the excel dialect, QUOTE_MINIMAL) quote a field.
_CSV_QUOTED = re.compile('[,"\r\n]')


def _csv_text(s: str) -> str:
    """A field as csv.writer's excel dialect writes it in a row of two fields or more: quoted (its quotes doubled)
    when it holds a comma, a quote, a carriage return or a line feed, else as it is."""
    return '"' + s.replace('"', '""') + '"' if _CSV_QUOTED.search(s) else s


#: First characters that make a spreadsheet read a cell as a formula.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _safe_text(s: str) -> str:
    """A text cell a spreadsheet shows as text: a leading quote before a formula character."""
    return "'" + s if s.startswith(_FORMULA_START) else s


def _cell(v: Any) -> str:
    if isinstance(v, (np.bool_, bool)):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)):
        return "" if not np.isfinite(v) else repr(float(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return _safe_text(str(v))


def write_table_parquet(results: Results, path: PathLike, *, extra: Optional[Dict[str, Any]] = None) -> bool:
    """Per-window table as Parquet. Returns True (it used to return False without pyarrow, now a dependency).

    Raises
    ------
    ImportError
        pyarrow cannot be imported (an install that skipped tribodyn's dependencies).
    """
    pa, pq = pyarrow_modules()
    from ..columns import UNITS

    cols = _columns(results, extra)
    arrays = [arrow_array(pa, v) for v in cols.values()]
    # Each field carries its unit (metadata b"unit"; tribodyn.columns.UNITS; "1" dimensionless, "" a label), set in
    # the schema the table is built with (``Table.cast`` to it would import pyarrow.compute: ~0.1 s a process).
    schema = pa.schema([pa.field(n, a.type).with_metadata({"unit": UNITS.get(n, "")}) for n, a in zip(cols, arrays)])
    pq.write_table(pa.Table.from_arrays(arrays, schema=schema), str(path))
    return True


def arrow_array(pa: Any, v: np.ndarray) -> Any:
    """The Arrow array ``pa.array`` makes of a NumPy column (object columns as text), built from its buffers.

    ``pa.array`` imports pandas (about 0.4 s) to ask whether its argument is a pandas object; the
    buffers give the same array (same type, values and no nulls, NaN kept as a value) without it.
    """
    v = np.asarray(v)
    if v.dtype == object:
        v = v.astype(str)
    n = len(v)
    if v.dtype.kind == "U":
        data = [str(x).encode("utf-8") for x in v.tolist()]
        offsets = np.zeros(n + 1, dtype=np.int64)
        np.cumsum([len(d) for d in data], out=offsets[1:])
        if offsets[-1] >= 2**31:
            return pa.array(v)
        return pa.Array.from_buffers(pa.string(), n, [None, pa.py_buffer(offsets.astype(np.int32)),
                                                      pa.py_buffer(b"".join(data))])  # fmt: skip
    if v.dtype == np.bool_:
        return pa.Array.from_buffers(pa.bool_(), n, [None, pa.py_buffer(np.packbits(v, bitorder="little"))])
    if v.dtype.kind in "fiu" and v.dtype.isnative:
        return pa.Array.from_buffers(pa.from_numpy_dtype(v.dtype), n, [None, pa.py_buffer(np.ascontiguousarray(v))])
    return pa.array(v)


def pyarrow_modules() -> Tuple[Any, Any]:
    """``(pyarrow, pyarrow.parquet)``; an ImportError saying what to install when pyarrow is missing."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise ImportError(f"writing Parquet needs pyarrow>=10, a dependency of tribodyn: pip install pyarrow ({exc})"
                          ) from None  # fmt: skip
    return pa, pq


def input_provenance(paths: Iterable[PathLike], digests: Optional["Digests"] = None, *, later: bool = False
                     ) -> List[Dict[str, Any]]:  # fmt: skip
    """Name, size and SHA-256 of each input file (``digests``: computed beforehand, e.g. during the analysis).

    ``later``: the digests are left None, for :func:`fill_digests` to fill when they are written (the outputs
    are drawn while the hashing thread finishes).
    """
    out = []
    for p in paths:
        p = Path(p)
        digest = None if later else digests.get(p) if digests is not None else sha256_file(p)
        out.append({"file": p.name, "path": str(p.resolve()), "bytes": p.stat().st_size, "sha256": digest})
    return out


def fill_digests(inputs: Iterable[Dict[str, Any]], digests: Optional["Digests"]) -> None:
    """Sets the SHA-256 that :func:`input_provenance` left None (``later``), waiting for ``digests``."""
    for entry in inputs:
        if entry.get("sha256") is None and entry.get("path"):
            entry["sha256"] = digests.get(entry["path"]) if digests is not None else sha256_file(entry["path"])


class Digests:
    """SHA-256 of files computed in a background thread started at once (issue 25).

    Each step of ``_core.FileDigest`` (:data:`~tribodyn.io.writers.DIGEST_STEP` bytes, read and hashed
    natively) runs without the GIL, so the digests of the inputs overlap the analysis and the figures'
    drawing, which holds the GIL (``hashlib`` took the GIL back after each 1 MiB block and waited for it
    behind the drawing: a 1.15 GB input took 4-10 s beside a busy Python thread instead of 1.2 s; issue 38
    point 3). :meth:`get` waits for a file's digest (computing it here if the thread did not); :meth:`cancel`
    stops the thread at its next step.
    """

    def __init__(self, paths: Iterable[PathLike]) -> None:
        self._paths = [Path(p) for p in paths]
        self._done: Dict[str, Union[str, BaseException]] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="tribodyn-sha256", daemon=True)
        self._thread.start()

    @staticmethod
    def _key(p: PathLike) -> str:
        return os.path.realpath(os.fspath(p))

    def _run(self) -> None:
        for p in self._paths:
            try:
                digest = _core.FileDigest(os.fspath(p))
                while not digest.advance(DIGEST_STEP):
                    if self._stop.is_set():
                        return
                if self._stop.is_set():
                    return
                self._done[self._key(p)] = str(digest.hexdigest())
            except BaseException as exc:  # noqa: BLE001 - get() computes it again and raises there
                self._done[self._key(p)] = exc

    def get(self, path: PathLike) -> str:
        """The hex SHA-256 of ``path`` (waits for the thread)."""
        self._thread.join()
        got = self._done.get(self._key(path))
        return got if isinstance(got, str) else sha256_file(path)

    def cancel(self) -> None:
        self._stop.set()
