"""``cached``: a value computed on first use and kept on the instance, with no lock (issue 38 audit).

``functools.cached_property`` before Python 3.12 holds one lock per property for *every* instance while it
computes: the bootstraps of two Results in two threads run one after the other, and a child made by ``fork``
while another thread computes one (``multiprocessing`` on Linux) waits forever for the first such value of any
Results (the lock is copied held, its owner is not). ``cached`` holds none: two threads asking for the same
value of one instance at once may both compute it (a pure function of the instance, so the same value); the
first stored is the one both get.
"""

from __future__ import annotations

from typing import Any, Callable, Generic, Optional, TypeVar, overload

__all__ = ["cached"]

_T = TypeVar("_T")


class cached(Generic[_T]):  # noqa: N801 - used as a decorator, like functools.cached_property
    """A property computed once per instance (on first use) and kept in its ``__dict__``; no lock."""

    def __init__(self, func: Callable[[Any], _T]) -> None:
        self.func = func
        self.attrname: Optional[str] = None
        self.__doc__ = func.__doc__
        self.__module__ = func.__module__

    def __set_name__(self, owner: type, name: str) -> None:
        self.attrname = name

    @overload
    def __get__(self, instance: None, owner: Optional[type] = None) -> "cached[_T]": ...

    @overload
    def __get__(self, instance: object, owner: Optional[type] = None) -> _T: ...

    def __get__(self, instance: Optional[object], owner: Optional[type] = None) -> Any:
        if instance is None:
            return self
        name = self.attrname
        if name is None:
            raise TypeError("cached used without __set_name__ (assign it in a class body)")
        store = instance.__dict__
        try:
            return store[name]
        except KeyError:
            pass
        # setdefault: of two threads that computed it at once, both return the value stored first
        return store.setdefault(name, self.func(instance))
