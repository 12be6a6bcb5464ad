"""Registries of named kinds: classes registered under the names a configuration uses.

A registry is filled by the modules of its packages, each registering its classes with
:meth:`Registry.register` when imported; the first lookup imports every module of those
packages, so adding a kind is adding one module (as python-microscope names device classes
in its configuration). Unknown names are refused with the closest known one.
"""

from __future__ import annotations

import difflib
import importlib
import pkgutil
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from sassi_bench.errors import ConfigError, step_error

__all__ = ["Registry"]

T = TypeVar("T")


class Registry(Generic[T]):
    """Classes by name, registered by the modules of ``package``.

    Parameters
    ----------
    what
        What the names name (``"light kind"``), for errors.
    *packages
        The dotted packages whose modules register the kinds.

    Examples
    --------
    >>> shapes = Registry("shape", "sassi_bench._shared")
    >>> @shapes.register("square")
    ... class Square:
    ...     pass
    >>> shapes["square"].__name__, "square" in shapes
    ('Square', True)
    >>> shapes["sqare"]
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: shape 'sqare': no such shape (did you mean 'square'?). ...
    """

    def __init__(self, what: str, *packages: str) -> None:
        self.what = what
        self.packages = packages
        self._classes: dict[str, type[T]] = {}
        self._loaded = False

    def register(self, *names: str) -> Callable[[type[T]], type[T]]:
        """Register a class under ``names`` (a decorator)."""

        def add(cls: type[T]) -> type[T]:
            for name in names:
                if name in self._classes and self._classes[name] is not cls:
                    raise ValueError(f"{self.what} {name!r} is registered twice")
                self._classes[name] = cls
            return cls

        return add

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for name in self.packages:
                package = importlib.import_module(name)
                for module in pkgutil.iter_modules(package.__path__):
                    importlib.import_module(f"{name}.{module.name}")

    def __getitem__(self, name: str) -> type[T]:
        self._load()
        if name not in self._classes:
            close = difflib.get_close_matches(str(name), list(self._classes), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ConfigError(
                step_error(
                    f"{self.what} {name!r}",
                    f"no such {self.what}{hint}",
                    f"use one of {', '.join(sorted(self._classes))}",
                )
            )
        return self._classes[name]

    def __contains__(self, name: object) -> bool:
        self._load()
        return name in self._classes

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(list(self._classes))

    def items(self) -> list[tuple[str, type[T]]]:
        """``(name, class)`` in the order the modules registered them."""
        self._load()
        return list(self._classes.items())
