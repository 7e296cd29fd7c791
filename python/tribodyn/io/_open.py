"""Shared steps of the reader constructors: open the file, then set up or close.

A reader opens its file handle first (a failure is reported as a
:class:`~tribodyn.io.base.RecordingError` naming the file) and then reads
the metadata through that handle; if that fails in any way the handle is
released before the error propagates, so a failed constructor leaks nothing.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Callable, Iterator, Tuple, Type, TypeVar, Union

from .base import Recording, RecordingError

__all__ = ["closing_on_error", "open_or_raise"]

_T = TypeVar("_T")

_Errors = Union[Type[BaseException], Tuple[Type[BaseException], ...]]


def open_or_raise(opener: Callable[[], _T], path: str, what: str, errors: _Errors) -> _T:
    """Returns ``opener()``; ``errors`` raised by it become a :class:`RecordingError`.

    The message is ``"{path}: {what}: {exc}"``; the original exception is not
    chained (``from None``).
    """
    try:
        return opener()
    except errors as exc:
        raise RecordingError(f"{path}: {what}: {exc}") from None


@contextmanager
def closing_on_error(rec: Recording) -> Iterator[None]:
    """Calls ``rec._close()`` when the block raises anything, then re-raises."""
    try:
        yield
    except BaseException:
        rec._close()
        raise
