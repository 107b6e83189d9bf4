"""Lazy public names of a package (PEP 562): a package's ``__init__`` lists which module
holds each of its public names, and each is imported on first use, so that importing the
package (``import stewart_pin``, the ``stewart-pin`` command) does not import Pinocchio,
CasADi or SciPy until a name that needs them is used.

Usage, in a package's ``__init__.py`` (with the same imports under ``if TYPE_CHECKING:``
for type checkers)::

    __getattr__, __dir__ = lazy_names(__name__, {"name": ".module", ...})

A name must not be that of one of the package's own submodules (importing the submodule
would set the package's attribute to the module): such a name is imported eagerly.

:func:`lazy_module` is the same for a whole third-party module a module uses only inside
its functions; :data:`casadi` and :data:`pinocchio` are CasADi and Pinocchio so, for the
code generator and the modules a robot's construction imports (a robot whose compiled
library is cached answers without importing either)::

    from stewart_pin._lazy import casadi as cs
    from stewart_pin._lazy import pinocchio as pin
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

__all__ = ["casadi", "lazy_module", "lazy_names", "pinocchio"]


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


class _LazyModule(types.ModuleType):
    """A stand-in for a module, imported on the first attribute read. Every read is the
    module's attribute at that moment (nothing is copied: a name the module rebinds later,
    or a test replaces, is what the stand-in gives)."""

    def __getattr__(self, attr: str) -> Any:  # every name: the stand-in holds none
        if attr.startswith("__") and attr.endswith("__") and attr != "__version__":
            raise AttributeError(attr)  # copy, pickle and the like probing the stand-in
        module = sys.modules.get(self.__name__)
        if module is None:
            module = importlib.import_module(self.__name__)
        return getattr(module, attr)


def lazy_module(name: str) -> Any:
    """The module ``name`` (absolute), imported on the first read of one of its attributes
    (the module docstring's example); nothing is imported before."""
    return _LazyModule(name)


if TYPE_CHECKING:
    import casadi as casadi
    import pinocchio as pinocchio
else:
    #: CasADi and Pinocchio, imported on first use (type checkers see the modules
    #: themselves): a robot whose compiled library is cached answers without either.
    casadi = lazy_module("casadi")
    pinocchio = lazy_module("pinocchio")
