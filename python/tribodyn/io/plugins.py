"""Reader plugins: formats added by other packages through the entry-point group ``tribodyn.readers``.

A package adds a format by declaring, in its ``pyproject.toml``::

    [project.entry-points."tribodyn.readers"]
    acme = "acme_tribo:AcmeRecording"

The object named is a :class:`~tribodyn.io.base.Recording` subclass (most simply a
:class:`~tribodyn.io.tables.TableRecording` that reads its columns and calls ``open_table``) with

``format`` (str)
    The format's name: ``open_recording(path, format="acme")``, ``--format acme``. It may not be one
    of tribodyn's own (:data:`tribodyn.io.FORMATS`).
``extensions`` (tuple of str, optional)
    File name endings it reads (``(".acme",)``), matched without case.
``sniff(head: bytes) -> bool`` (static or class method, optional)
    True when the first 4096 bytes of a file are of this format.

and a constructor ``(path, *, channels=None, fs=None, scale=None, units=None, **options)`` as the
readers of :mod:`tribodyn.io` take. Detection (:func:`tribodyn.io.detect_format`): the signatures of
tribodyn's own binary formats and tribodyn's own extensions come first; a file of another extension
whose content none of them recognises, or that is plain text, is offered to the plugins' ``sniff``,
then matched by the plugins' extensions (so ``.csv``, ``.txt``... stay delimited text, and the plugins
are looked for only when such a file comes: about 30 ms, once a process, to list the entry points). Whatever a
plugin's reader returns goes through the same role map, unit conversion, checks, analysis and
outputs as a built-in format's. A plugin that cannot be loaded (an import error, a wrong object) is
not used; the error is said when its format is asked for, and in ``tribodyn info``'s unknown-format
message.
"""

from __future__ import annotations

import sys
from typing import Any, Dict, List, Optional, Tuple

__all__ = ["GROUP", "PluginError", "find_plugin", "plugin_errors", "plugins", "reload"]

#: The entry-point group of reader plugins.
GROUP = "tribodyn.readers"

_cache: Optional[Tuple[Dict[str, Any], Dict[str, str]]] = None


class PluginError(RuntimeError):
    """A reader plugin that cannot be used (the message names the entry point and why)."""


def _entry_points() -> List[Any]:
    from importlib import metadata

    if sys.version_info >= (3, 10):
        return list(metadata.entry_points(group=GROUP))
    return list(metadata.entry_points().get(GROUP, ()))  # pragma: no cover - Python 3.9


def _check(ep: Any, obj: Any, builtin: Tuple[str, ...]) -> str:
    """The format name of a loaded plugin object, or a PluginError saying what is wrong with it."""
    from .base import Recording

    where = f"reader plugin {ep.name!r} ({ep.value})"
    if not (isinstance(obj, type) and issubclass(obj, Recording)):
        raise PluginError(f"{where} is not a tribodyn.io.Recording subclass")
    fmt = getattr(obj, "format", None)
    if not isinstance(fmt, str) or not fmt or fmt == "?":
        raise PluginError(f"{where} has no format name (a class attribute 'format')")
    if fmt in builtin or fmt == "auto":
        raise PluginError(f"{where}: format {fmt!r} is one of tribodyn's own")
    ext = getattr(obj, "extensions", ())
    if not (isinstance(ext, tuple) and all(isinstance(e, str) and e.startswith(".") for e in ext)):
        raise PluginError(f"{where}: 'extensions' must be a tuple of endings such as ('.acme',)")
    sniff = getattr(obj, "sniff", None)
    if sniff is not None and not callable(sniff):
        raise PluginError(f"{where}: 'sniff' must be callable (head bytes -> bool)")
    return fmt


def _load() -> Tuple[Dict[str, Any], Dict[str, str]]:
    from .detect import FORMATS

    found: Dict[str, Any] = {}
    errors: Dict[str, str] = {}
    try:
        eps = _entry_points()
    except Exception as exc:  # noqa: BLE001 - broken distribution metadata must not break tribodyn
        return {}, {"?": f"reader plugins cannot be listed: {exc}"}
    for ep in eps:
        try:
            obj = ep.load()
            fmt = _check(ep, obj, FORMATS)
        except Exception as exc:  # noqa: BLE001 - a plugin's import may raise anything
            errors[ep.name] = (
                str(exc)
                if isinstance(exc, PluginError)
                else (f"reader plugin {ep.name!r} ({ep.value}) cannot be loaded: {type(exc).__name__}: {exc}")
            )
            continue
        if fmt in found:
            errors[ep.name] = f"reader plugin {ep.name!r}: format {fmt!r} is already given by another plugin"
            continue
        found[fmt] = obj
    return found, errors


def plugins() -> Dict[str, Any]:
    """Format name -> reader class of every usable plugin (loaded once; :func:`reload` after installing one)."""
    global _cache
    if _cache is None:
        _cache = _load()
    return dict(_cache[0])


def plugin_errors() -> Dict[str, str]:
    """Entry-point name -> why that plugin is not used."""
    plugins()
    assert _cache is not None
    return dict(_cache[1])


def reload() -> None:
    """Forgets the plugins found, so the next use looks for them again."""
    global _cache
    _cache = None


def find_plugin(path: str, head: bytes) -> Optional[str]:
    """The format of the first plugin whose ``sniff`` takes ``head``, else whose extension ``path`` has."""
    found = plugins()
    for fmt, cls in found.items():
        sniff = getattr(cls, "sniff", None)
        if sniff is not None:
            try:
                if sniff(head):
                    return fmt
            except Exception:  # noqa: BLE001 - a plugin's faulty sniff is not a match
                continue
    low = path.lower()
    for fmt, cls in found.items():
        if any(low.endswith(e.lower()) for e in getattr(cls, "extensions", ())):
            return fmt
    return None
