"""Packages whose public names load on first use (PEP 562).

``__getattr__, __dir__ = attach(__name__, {"name": ".module", ...})`` in a package's
``__init__``: ``package.name`` imports ``.module`` the first time it is read (and keeps
the value, so later reads skip the hook), so that importing the package, or one of its
modules, imports no more than that module needs. As ``lazy_loader.attach`` of the
scientific Python ecosystem, without the dependency.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Iterable, Mapping

__all__ = ["attach"]


def attach(package: str, exports: Mapping[str, str], submodules: Iterable[str] = ()
           ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``: ``exports`` maps a public
    name to the module that defines it (relative to ``package``); ``submodules`` are
    subpackages returned as attributes.

    A module of the package that is not imported yet is imported when read, as it would
    be if the package imported all its modules.

    >>> getattr_, dir_ = attach("roverimpact", {"partition": ".energy"})
    >>> getattr_("partition").__name__, "partition" in dir_()
    ('partition', True)
    >>> getattr_("impulse").__name__
    'roverimpact.impulse'
    """
    exports = dict(exports)
    submodules = frozenset(submodules)

    def __getattr__(name: str):
        if name in exports:
            value = getattr(importlib.import_module(exports[name], package), name)
            setattr(sys.modules[package], name, value)  # later reads skip this function
            return value
        if name in submodules or (not name.startswith("__") and importlib.util.find_spec(
                f"{package}.{name}") is not None):
            # a subpackage, or any module of the package not imported yet
            # (``roverimpact.studies.sweep`` after ``import roverimpact.studies``)
            return importlib.import_module(f".{name}", package)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *exports, *submodules})

    return __getattr__, __dir__
