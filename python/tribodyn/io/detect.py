"""Content detection of :mod:`tribodyn.io` (a leaf module: the readers and the plugins import it, it
imports no reader): the formats, their extensions and aliases, the signatures, and what a file's content
is in words for messages (:func:`describe_content`). The rules are in :mod:`tribodyn.io`'s docstring."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Optional, Tuple

__all__ = [
    "FORMATS",
    "READERS",
    "Reader",
    "MAT73_HEADER",
    "STEP_LINE",
    "describe_content",
    "is_mat73",
    "reader_class",
    "sniff_mat",
    "sniff_steps",
]


@dataclass(frozen=True)
class Reader:
    """One built-in format: a row of :data:`READERS`, the registry of tribodyn's readers (docs/architecture.md).

    A new reader is its module under ``io/`` plus one row here (a package of its own adds one through the
    ``tribodyn.readers`` entry points instead: :mod:`tribodyn.io.plugins`).

    Attributes
    ----------
    format : str
        The value of ``format=`` / ``--format``.
    target : str
        ``"module:Class"`` of its :class:`~tribodyn.io.base.Recording` under ``tribodyn.io``, imported on first use.
    extensions : tuple of str
        File extensions (lower case, with the dot) that select it.
    aliases : tuple of str
        Other names ``format=`` takes for it.
    content : str
        What a file of this content is called in messages ("" for a variant sharing another's content).
    binary : bool
        A binary format: a file of its extension whose content is another is refused, naming the content.
    vendor : str or None
        The vendor variant the target reads (its ``vendor=`` keyword), None for none.
    """

    format: str
    target: str
    extensions: Tuple[str, ...] = ()
    aliases: Tuple[str, ...] = ()
    content: str = ""
    binary: bool = False
    vendor: Optional[str] = None


#: The readers, in the order of ``FORMATS``. Content signatures are looked at by :func:`_sniff`.
READERS: Tuple[Reader, ...] = (
    Reader("tdms", "tdms:TdmsRecording", (".tdms",), content="a TDMS file", binary=True),
    Reader("lvm", "lvm:LvmRecording", (".lvm",), content="a LabVIEW Measurement text file"),
    Reader("hdf5", "hdf5:Hdf5Recording", (".h5", ".hdf5", ".hdf", ".he5"), ("h5",), "an HDF5 file", True),
    Reader("npy", "numpy_files:NpyRecording", (".npy",), content="a NumPy .npy array", binary=True),
    Reader("npz", "numpy_files:NpzRecording", (".npz",), content="a NumPy .npz archive", binary=True),
    Reader("delimited", "delimited:DelimitedRecording", (".csv", ".tsv", ".txt", ".dat", ".asc", ".tab"),
           ("csv", "tsv", "text", "txt"), "text"),
    Reader("cetr", "delimited:DelimitedRecording", vendor="cetr"),
    Reader("compend", "delimited:DelimitedRecording", aliases=("pod",), vendor="compend"),
    Reader("steps", "steps:StepsRecording", content="a multi-step text export"),
    Reader("mat", "matlab:MatRecording", (".mat",), ("matlab",), "a MATLAB MAT-file", True),
    Reader("spreadsheet", "spreadsheet:SpreadsheetRecording", (".xlsx", ".xlsm", ".xls", ".ods"),
           ("xlsx", "xlsm", "xls", "ods", "excel"), "a spreadsheet", True),
)  # fmt: skip

#: Accepted values of ``format`` (besides ``"auto"``) and aliases, from :data:`READERS`.
FORMATS = tuple(r.format for r in READERS)
_ALIASES = {a: r.format for r in READERS for a in r.aliases}
_EXT = {e: r.format for r in READERS for e in r.extensions}
_BINARY = {r.format for r in READERS if r.binary}
_HDF5_SIG = b"\x89HDF\r\n\x1a\n"
_OLE2_SIG = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"

#: What each kind of content is, for messages (a zip's and an OLE2 file's are decided by :func:`_zip_kind`).
_CONTENT_NAMES = {r.format: r.content for r in READERS if r.content}


def reader_class(fmt: str) -> Tuple[Any, Optional[str]]:
    """(the Recording class of built-in format ``fmt``, its vendor variant or None), imported on first use."""
    import importlib

    row = next(r for r in READERS if r.format == fmt)
    module, cls = row.target.split(":")
    return getattr(importlib.import_module(f"{__package__}.{module}"), cls), row.vendor


def _sniff(head: bytes) -> Optional[str]:
    """Format from the first bytes (``zip`` and ``ole2`` for containers :func:`_zip_kind` looks into), or None
    for unrecognised content."""
    if head.startswith(b"TDSm"):
        return "tdms"
    if is_mat73(head) or sniff_mat(head):
        return "mat"
    if any(head[o : o + 8] == _HDF5_SIG for o in (0, 512, 1024, 2048)):
        return "hdf5"
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return "zip"
    if head.startswith(_OLE2_SIG):
        return "ole2"
    text = head.lstrip(b"\xef\xbb\xbf")
    if text.startswith(b"LabVIEW Measurement"):
        return "lvm"
    from ._text import sniff_encoding  # UTF-8/16 (BOM or NUL pattern), CP932, CP1252; None: binary

    if sniff_encoding(head) is None:
        return None
    return "steps" if sniff_steps(text) else "delimited"


def _zip_kind(p: str, kind: Optional[str]) -> Tuple[Optional[str], str]:
    """(format, what the content is) of a sniffed kind: a zip is an npz, an Excel workbook, an OpenDocument
    spreadsheet or another zip archive (format None); an OLE2 file is taken for an Excel 97-2003 workbook."""
    if kind == "ole2":
        return "spreadsheet", "an OLE2 compound file (an Excel 97-2003 workbook?)"
    if kind != "zip":
        return kind, _CONTENT_NAMES.get(kind or "", "binary content of no supported kind")
    import zipfile

    try:
        with zipfile.ZipFile(p) as z:
            names = z.namelist()[:100_000]
            mimetype = z.read("mimetype")[:100] if "mimetype" in names else b""
    except (zipfile.BadZipFile, OSError, EOFError, KeyError, NotImplementedError, RuntimeError, ValueError):
        return "npz", "a zip archive (unreadable)"  # the npz reader says what is wrong
    if "xl/workbook.xml" in names or "xl/workbook.bin" in names:
        return "spreadsheet", "an Excel workbook"
    if mimetype.startswith(b"application/vnd.oasis.opendocument.spreadsheet"):
        return "spreadsheet", "an OpenDocument spreadsheet"
    if mimetype.startswith(b"application/vnd.oasis.opendocument"):
        return None, "an OpenDocument document (not a spreadsheet)"
    if "word/document.xml" in names:
        return None, "a Word document"
    if "ppt/presentation.xml" in names:
        return None, "a PowerPoint presentation"
    if any(n.endswith(".npy") for n in names) or not names:
        return "npz", _CONTENT_NAMES["npz"]
    return None, "a zip archive (no .npy member)"


def describe_content(path: str) -> str:
    """What a file's content is, for messages ("an Excel workbook", "text", "a MATLAB MAT-file"...)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return "unreadable"
    return _zip_kind(path, _sniff(head))[1] if head else "empty"


#: The text a version 7.3 MAT-file starts with (its HDF5 data follow at byte 512).
MAT73_HEADER = b"MATLAB 7.3 MAT-file"
#: A line opening a step: ``Step 3 started at ...`` (any words between the number and "started at").
STEP_LINE = re.compile(r"^\s*step\s+(\d+)\b(.*?)\bstarted\s+at\b(.*)$", re.IGNORECASE)


def is_mat73(head: bytes) -> bool:
    """True when the first bytes are a MATLAB 7.3 header (the file is HDF5 from byte 512)."""
    return head.startswith(MAT73_HEADER)


def sniff_steps(head: bytes) -> bool:
    """True when a line of the first bytes opens a step (``Step N ... started at``)."""
    text = head.decode("latin-1")
    return any(STEP_LINE.match(ln) for ln in text.splitlines()[:200])


def sniff_mat(head: bytes) -> bool:
    """True when the first bytes are a MAT-file 5/7 header (116 bytes of text starting with ``MATLAB``)."""
    return head.startswith(b"MATLAB 5.0 MAT-file") or (head.startswith(b"MATLAB") and head[124:126] == b"\x00\x01")
