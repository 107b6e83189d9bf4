"""Lazy public names of a package (PEP 562): a package's ``__init__`` lists which module
holds each of its public names, and each is imported on first use, so that importing the
package (``import stewart_pin``, the ``stewart-pin`` command) does not import Pinocchio,
CasADi or SciPy until a name that needs them is used.

Usage, in a package's ``__init__.py`` (with the same imports under ``if TYPE_CHECKING:``
for type checkers)::

    __getattr__, __dir__ = lazy_names(__name__, {"name": ".module", ...})

A name must not be that of one of the package's own submodules (importing the submodule
would set the package's attribute to the module): such a name is imported eagerly.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(
    package: str, names: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` for its lazy ``names``
    (public name -> the module holding it, absolute or relative to ``package``). A name is
    imported on first use and then kept in the package's namespace."""
    table = dict(names)

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *table})

    return __getattr__, __dir__
