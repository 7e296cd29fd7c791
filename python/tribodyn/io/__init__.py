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
``steps``      multi-step export (a header block a step)  :mod:`tribodyn.io.steps`
``mat``        MATLAB MAT-file v4, v5/v7, v7.3 (HDF5)    :mod:`tribodyn.io.matlab`
``spreadsheet``  Excel .xlsx/.xlsm/.xls, OpenDocument .ods  :mod:`tribodyn.io.spreadsheet`
=============  ========================================  ===============================

Detection: the content's signature decides for binary formats (TDMS
``TDSm``, a MAT-file's ``MATLAB 5.0``/``MATLAB 7.3`` header, HDF5,
``\\x93NUMPY``, a zip's members: ``.npy`` members for npz, ``xl/workbook.xml``
for an Excel workbook, an OpenDocument spreadsheet's ``mimetype``; an OLE2
file for ``.xls``); a file with the extension of a binary format but other
content is refused with the format its content has ("an Excel workbook", "a
zip archive", "text"...). Text starting with ``LabVIEW Measurement`` is LVM;
text with a ``Step N ... started at`` line is a multi-step export; other text
is delimited (CETR and COMPEND recognised by their first lines). A version 4
MAT-file has no signature: binary content under ``.mat`` is read as one.

Other packages add formats through the entry-point group ``tribodyn.readers``
(:mod:`tribodyn.io.plugins`): a file of an extension tribodyn does not know
whose content no built-in signature recognises, or that is plain text, is
offered to them (``.csv``, ``.txt``... stay delimited text unless
``format=`` names the plugin's format).
"""

from __future__ import annotations

import contextlib
import numbers
import os
import stat
from typing import Any, Mapping, Optional, Tuple, Union

from .base import APPENDING, ChannelInfo, Recording, RecordingError, RecordingProtocol
from .constant import with_load
from .units import check_role_units
from .detect import _ALIASES, _BINARY, _EXT, FORMATS, _sniff, _zip_kind, reader_class
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
    "reader_takes",
    "save_hdf5",
    "save_npy",
    "save_npz",
    "save_recording",
    "save_tdms",
    "sha256_file",
]


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
    ext = os.path.splitext(p)[1].lower()
    by_ext = _EXT.get(ext)
    by_content, what = _zip_kind(p, _sniff(head))
    if by_ext == "mat" and by_content is None and what.startswith("binary"):
        return "mat"  # a version 4 MAT-file has no signature: scipy.io tells whether it is one
    if by_ext in _BINARY and by_content != by_ext:
        shown = ext if by_ext in ("mat", "spreadsheet") else by_ext
        raise RecordingError(
            f"{p}: not a valid {shown} file: its content is {what} (corrupt or mislabelled)"
            + (f"; read it with --format {by_content}" if by_content is not None and by_content != "delimited" else "")
        )
    if by_ext is None and by_content in (None, "delimited"):
        from .plugins import find_plugin, plugin_errors

        plugin = find_plugin(p, head)  # formats added by other packages (entry points tribodyn.readers)
        if plugin is not None:
            return plugin
        if by_content is None:
            unused = "".join(f"; {e}" for e in plugin_errors().values())
            raise RecordingError(f"{p}: unknown format ({what}); supported: {', '.join(_all_formats())}{unused}")
    if by_content is None:
        raise RecordingError(f"{p}: unknown format ({what}); supported: " + ", ".join(_all_formats()))
    if by_ext == "lvm" and by_content != "lvm":
        raise RecordingError(f"{p}: not a LabVIEW Measurement file (no 'LabVIEW Measurement' line)")
    return by_content


def reader_takes(path: Union[str, "os.PathLike[str]"]) -> bool:
    """Whether a reader takes ``path`` as a recording: by its extension (tribodyn's own or a reader plugin's),
    else by a binary signature a reader recognises (an HDF5 file named ``.bin``) or a plugin's ``sniff``.

    A folder's expansion (:func:`tribodyn.pipeline.distributed.expand_paths`) skips the files it refuses: text or
    binary content of another extension (``README.md``, ``photo.png``, ``notes.docx``), empty or not (an empty
    ``notes.md`` has no content a reader could take), and the owner file Excel or Word writes beside a workbook
    open in it (``~$run1.xlsx``, whatever its extension). A file it cannot read (unreadable; empty, of a reader's
    extension) is taken: its reader says what is wrong.
    """
    p = os.fspath(path)
    if os.path.basename(p).startswith("~$"):  # Office's owner file of an open workbook (~$run1.xlsx): a user's name
        return False
    if os.path.splitext(p)[1].lower() in _EXT:
        return True
    from .plugins import find_plugin, plugins

    low = p.lower()
    if any(low.endswith(e.lower()) for cls in plugins().values() for e in getattr(cls, "extensions", ())):
        return True
    try:
        head = _read_head(p)
    except RecordingError:
        with contextlib.suppress(OSError):  # (an empty regular file of another extension: nothing to take)
            st = os.stat(p)
            if stat.S_ISREG(st.st_mode) and st.st_size == 0:
                return False
        return True
    kind = _zip_kind(p, _sniff(head))[0]
    return kind not in (None, "delimited", "steps") or find_plugin(p, head) is not None


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
    load: Optional[float] = None,
    **options: Any,
) -> Recording:
    """Opens a recording file.

    Parameters
    ----------
    path : str or PathLike
        The file.
    format : str
        ``"auto"`` (default), one of :data:`FORMATS` or of a reader plugin
        (:mod:`tribodyn.io.plugins`) (aliases ``csv``,
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
    load : float, optional
        A known constant normal force (N) for a file without a load
        channel: the role ``fz`` is then that constant
        (:class:`tribodyn.io.constant.ConstantLoad`; docs/method.md 6a).
        A file whose ``fz`` is mapped is refused.
    **options
        ``units`` (role/channel -> unit string, for display), and per
        format: ``group`` (tdms, hdf5), ``layout``, ``names``,
        ``time_channel`` (npy/npz), ``delimiter``, ``decimal``,
        ``encoding``, ``time_column`` (text), ``encoding`` (lvm),
        ``sheet`` (spreadsheet: a sheet's name; ignored with a warning for
        other formats, so a job of several files can name it), ``time_column`` and
        ``resample`` (text, spreadsheet, mat, steps); ``appending=True``: the
        file is still being written (``tribodyn watch``, docs/method.md 11):
        its samples at opening are read, and it may grow meanwhile (it must
        not shrink or be replaced).

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
    elif fmt not in _all_formats():
        from .plugins import plugin_errors

        why = "".join(f"; {e}" for e in plugin_errors().values() if repr(fmt) in e or fmt in e.split("'"))
        raise RecordingError(f"unknown format {format!r}; use 'auto' or one of {', '.join(_all_formats())}{why}")
    else:
        _read_head(p)  # missing / empty / directory checks
    cls, vendor = _backend(fmt)
    kwargs = dict(options)
    appending = bool(kwargs.pop("appending", False))
    # a sheet names a spreadsheet's table: a job of several files gives it to the spreadsheets among them
    ignored = [f"sheet={kwargs.pop('sheet')!r} ignored: a {fmt} file has no sheets"] if (
        "sheet" in kwargs and fmt != "spreadsheet") else []  # fmt: skip
    if vendor is not None:
        kwargs["vendor"] = vendor
    # The friction channel among several tangential ones is chosen by evidence (docs/method.md 6f).
    from .roles import choose_roles

    rec: Optional[Recording] = None
    try:
        token = APPENDING.set(appending)
        try:
            rec = cls(p, channels=channels, fs=fs, scale=scale, **kwargs)
        finally:
            APPENDING.reset(token)
        rec.role_choice = choose_roles(rec, channels)
        rec = with_load(rec, load)
        rec.warnings.extend(w for w in [*ignored, *check_role_units(rec.channels)[1]] if w not in rec.warnings)
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


def _all_formats() -> Tuple[str, ...]:
    """tribodyn's formats and those of the reader plugins installed (:mod:`tribodyn.io.plugins`)."""
    from .plugins import plugins

    return FORMATS + tuple(sorted(plugins()))


def _backend(fmt: str) -> Any:
    """(Recording class, vendor variant) of a format: a built-in one's row of :data:`~tribodyn.io.detect.READERS`,
    else a reader plugin's."""
    if fmt not in FORMATS:
        from .plugins import plugins

        return plugins()[fmt], None
    return reader_class(fmt)
