"""Reading measured force recordings: :func:`open_recording`.

One entry point opens any supported file and returns a
:class:`~tribodyn.io.base.Recording` that streams fixed-size chunks of the
channels, scaled to SI and keyed by role (``fy`` friction force, ``fz``
normal force, ``fx``, ``i``, ``u``, ``cof``...)::

    from tribodyn.io import open_recording

    with open_recording("test.tdms", channels={"fy": "Ft", "fz": "Fn"}) as rec:
        for chunk in rec.chunks(65536):
            process(chunk["fy"], chunk["fz"])

Formats (``format=`` or auto-detection, by extension and then content):

=============  ========================================  ===============================
format         files                                     module
=============  ========================================  ===============================
``tdms``       NI TDMS (incl. DAQmx raw, scaled)         :mod:`tribodyn.io.tdms`
``lvm``        LabVIEW Measurement text files            :mod:`tribodyn.io.lvm`
``hdf5``       HDF5, 1-D datasets                        :mod:`tribodyn.io.hdf5`
``npy``        NumPy array, memory-mapped                :mod:`tribodyn.io.numpy_files`
``npz``        NumPy archive, one member per channel     :mod:`tribodyn.io.numpy_files`
``delimited``  CSV/TSV/... text                          :mod:`tribodyn.io.delimited`
``cetr``       CETR UMT csv export (multi-step)          :mod:`tribodyn.io.delimited`
``compend``    COMPEND pin-on-disc tsv export            :mod:`tribodyn.io.delimited`
=============  ========================================  ===============================

Detection: the content's signature decides for binary formats (TDMS
``TDSm``, HDF5, ``\\x93NUMPY``, zip); a file with the extension of a binary
format but not its signature is reported as corrupt. Text starting with
``LabVIEW Measurement`` is LVM; other text is delimited (CETR and COMPEND
recognised by their first lines).
"""

from __future__ import annotations

import numbers
import os
import stat
from typing import Any, Mapping, Optional, Tuple, Union

from .base import ChannelInfo, Recording, RecordingError, RecordingProtocol
from .writers import atomic_write, save_hdf5, save_npy, save_npz, save_recording, save_tdms, sha256_file

__all__ = [
    "FORMATS",
    "ChannelInfo",
    "Recording",
    "RecordingError",
    "RecordingProtocol",
    "atomic_write",
    "detect_format",
    "open_recording",
    "save_hdf5",
    "save_npy",
    "save_npz",
    "save_recording",
    "save_tdms",
    "sha256_file",
]

#: Accepted values of ``format`` (besides ``"auto"``) and aliases.
FORMATS = ("tdms", "lvm", "hdf5", "npy", "npz", "delimited", "cetr", "compend")
_ALIASES = {
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
}
_BINARY = {"tdms", "hdf5", "npy", "npz"}
_HDF5_SIG = b"\x89HDF\r\n\x1a\n"


def _sniff(head: bytes) -> Optional[str]:
    """Format from the first bytes, or None for unrecognised content."""
    if head.startswith(b"TDSm"):
        return "tdms"
    if any(head[o : o + 8] == _HDF5_SIG for o in (0, 512, 1024, 2048)):
        return "hdf5"
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return "npz"
    text = head.lstrip(b"\xef\xbb\xbf")
    if text.startswith(b"LabVIEW Measurement"):
        return "lvm"
    from ._text import sniff_encoding  # UTF-8/16 (BOM or NUL pattern), CP932, CP1252; None: binary

    return "delimited" if sniff_encoding(head) is not None else None


def detect_format(path: Union[str, "os.PathLike[str]"]) -> str:
    """Format name of a file (see the module docstring for the rules).

    Raises
    ------
    RecordingError
        Missing or empty file, content contradicting a binary extension, or
        unrecognised content.
    """
    p = os.fspath(path)
    head = _read_head(p)
    by_ext = _EXT.get(os.path.splitext(p)[1].lower())
    by_content = _sniff(head)
    if by_ext in _BINARY and by_content != by_ext:
        raise RecordingError(
            f"{p}: not a valid {by_ext} file (its first bytes are not a {by_ext} signature: corrupt or mislabelled)"
        )
    if by_content is None:
        raise RecordingError(
            f"{p}: unknown format (binary content of no supported kind); supported: " + ", ".join(FORMATS)
        )
    if by_ext == "lvm" and by_content != "lvm":
        raise RecordingError(f"{p}: not a LabVIEW Measurement file (no 'LabVIEW Measurement' line)")
    return by_content


def _read_head(p: str) -> bytes:
    if not os.path.exists(p):
        raise RecordingError(f"{p}: no such file")
    if os.path.isdir(p):
        raise RecordingError(f"{p}: is a directory, not a recording file")
    try:
        if not stat.S_ISREG(os.stat(p).st_mode):  # a FIFO would block, /dev/zero never end
            raise RecordingError(f"{p}: not a regular file")
        with open(p, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if not head:
        raise RecordingError(f"{p}: empty file")
    return head


def open_recording(
    path: Union[str, "os.PathLike[str]"],
    *,
    format: str = "auto",
    channels: Optional[Mapping[str, Optional[str]]] = None,
    fs: Optional[float] = None,
    scale: Optional[Mapping[str, float]] = None,
    **options: Any,
) -> Recording:
    """Opens a recording file.

    Parameters
    ----------
    path : str or PathLike
        The file.
    format : str
        ``"auto"`` (default) or one of :data:`FORMATS` (aliases ``csv``,
        ``tsv``, ``txt`` -> delimited, ``pod`` -> compend, ``h5`` -> hdf5).
    channels : mapping, optional
        Role -> file channel name (roles ``fx``, ``fy``, ``fz``, ``i``,
        ``u``, ``cof`` or any other name). Merged over the format's default
        map; map a role to None to drop a default.
    fs : float, optional
        Sampling rate in Hz; required when the file has none (npy, text
        without time column), overrides the file's otherwise.
    scale : mapping, optional
        Role or channel -> factor to SI, replacing any automatic conversion
        (e.g. ``{"fy": 9.80665e-3}`` for gram-force).
    **options
        ``units`` (role/channel -> unit string, for display), and per
        format: ``group`` (tdms, hdf5), ``layout``, ``names``,
        ``time_channel`` (npy/npz), ``delimiter``, ``decimal``,
        ``encoding``, ``time_column`` (text), ``encoding`` (lvm).

    Returns
    -------
    Recording
        Open recording; use as a context manager or call ``close()``.

    Raises
    ------
    RecordingError
        Missing file, unknown format, unmapped/missing channel, truncated or
        corrupt file, sampling rate unknown, unequal channel lengths.
    TypeError
        An argument of the wrong type (named), or an option the format does
        not take.
    """
    if not isinstance(path, (str, bytes, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    _check_mapping(channels, "channels", (str, type(None)), "a channel name (or None)")
    _check_mapping(scale, "scale", (numbers.Real,), "a number")
    _check_mapping(options.get("units"), "units", (str,), "a unit string")
    p = os.fsdecode(os.fspath(path))
    fmt = _ALIASES.get(format, format)
    if fmt == "auto":
        fmt = detect_format(p)
    elif fmt not in FORMATS:
        raise RecordingError(f"unknown format {format!r}; use 'auto' or one of {', '.join(FORMATS)}")
    else:
        _read_head(p)  # missing / empty / directory checks
    cls, vendor = _backend(fmt)
    kwargs = dict(options)
    if vendor is not None:
        kwargs["vendor"] = vendor
    # The friction channel among several tangential ones is chosen by evidence (docs/method.md 6f).
    from .roles import choose_roles

    rec: Optional[Recording] = None
    try:
        rec = cls(p, channels=channels, fs=fs, scale=scale, **kwargs)
        rec.role_choice = choose_roles(rec, channels)
        return rec
    except BaseException as exc:
        if rec is not None:
            rec.close()
        if isinstance(exc, TypeError) and "unexpected keyword argument" in str(exc):
            raise TypeError(f"open_recording: option not accepted for format {fmt!r}: {exc}") from None
        if isinstance(exc, (OSError, EOFError, UnicodeError)):
            raise RecordingError(f"{p}: cannot read as {fmt}: {exc}") from None
        raise


def _check_mapping(value: Any, name: str, kinds: Tuple[type, ...], what: str) -> None:
    """A mapping role/channel -> value of one of ``kinds`` (or None), else a ``TypeError`` naming ``name``."""
    if value is None:
        return
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{name} must be a mapping role/channel -> {what}, e.g. {{'fy': 'Ft'}}, got {type(value).__name__}"
        )
    for key, v in value.items():
        if not isinstance(key, str):
            raise TypeError(f"{name} keys must be role or channel names (str), got {key!r}")
        if isinstance(v, bool) or not isinstance(v, kinds):
            raise TypeError(f"{name}[{key!r}] must be {what}, got {type(v).__name__} {v!r}")


def _backend(fmt: str) -> Any:
    if fmt == "tdms":
        from .tdms import TdmsRecording

        return TdmsRecording, None
    if fmt == "lvm":
        from .lvm import LvmRecording

        return LvmRecording, None
    if fmt == "hdf5":
        from .hdf5 import Hdf5Recording

        return Hdf5Recording, None
    if fmt == "npy":
        from .numpy_files import NpyRecording

        return NpyRecording, None
    if fmt == "npz":
        from .numpy_files import NpzRecording

        return NpzRecording, None
    from .delimited import DelimitedRecording

    return DelimitedRecording, (None if fmt == "delimited" else fmt)
