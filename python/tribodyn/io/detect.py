"""Content detection of :mod:`tribodyn.io` (a leaf module: the readers and the plugins import it, it
imports no reader): the formats, their extensions and aliases, the signatures, and what a file's content
is in words for messages (:func:`describe_content`). The rules are in :mod:`tribodyn.io`'s docstring."""

from __future__ import annotations

import re
from typing import Optional, Tuple

__all__ = ["FORMATS", "MAT73_HEADER", "STEP_LINE", "describe_content", "is_mat73", "sniff_mat", "sniff_steps"]

#: Accepted values of ``format`` (besides ``"auto"``) and aliases.
FORMATS = ("tdms", "lvm", "hdf5", "npy", "npz", "delimited", "cetr", "compend", "steps", "mat", "spreadsheet")
_ALIASES = {
    "matlab": "mat",
    "xlsx": "spreadsheet",
    "xlsm": "spreadsheet",
    "xls": "spreadsheet",
    "ods": "spreadsheet",
    "excel": "spreadsheet",
    "csv": "delimited",
    "tsv": "delimited",
    "text": "delimited",
    "txt": "delimited",
    "h5": "hdf5",
    "pod": "compend",
}

_EXT = {
    ".tdms": "tdms",
    ".lvm": "lvm",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
    ".he5": "hdf5",
    ".npy": "npy",
    ".npz": "npz",
    ".csv": "delimited",
    ".tsv": "delimited",
    ".txt": "delimited",
    ".dat": "delimited",
    ".asc": "delimited",
    ".tab": "delimited",
    ".mat": "mat",
    ".xlsx": "spreadsheet",
    ".xlsm": "spreadsheet",
    ".xls": "spreadsheet",
    ".ods": "spreadsheet",
}
_BINARY = {"tdms", "hdf5", "npy", "npz", "mat", "spreadsheet"}
_HDF5_SIG = b"\x89HDF\r\n\x1a\n"
_OLE2_SIG = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"

#: What each kind of content is, for messages (a zip's and an OLE2 file's are decided by :func:`_zip_kind`).
_CONTENT_NAMES = {
    "tdms": "a TDMS file",
    "hdf5": "an HDF5 file",
    "npy": "a NumPy .npy array",
    "npz": "a NumPy .npz archive",
    "mat": "a MATLAB MAT-file",
    "spreadsheet": "a spreadsheet",
    "lvm": "a LabVIEW Measurement text file",
    "delimited": "text",
    "steps": "a multi-step text export",
}


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
