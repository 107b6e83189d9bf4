"""Modules kept at their former path (the ``general_*`` twins renamed by issue 19): each
name read from the old module warns, with a ``DeprecationWarning`` naming its new
place, and is the same object as before."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from types import ModuleType
from typing import Any

__all__ = ["moved_module"]


def moved_module(old: str, new: ModuleType) -> Callable[[str], Any]:
    """The module-level ``__getattr__`` of the deprecated module ``old`` (its dotted name)
    whose names now live in ``new``: returns ``new``'s attribute after a
    ``DeprecationWarning`` naming it (pointing at the importer), ``AttributeError`` for a
    name ``new`` does not have."""

    def __getattr__(name: str) -> Any:
        if name.startswith("__") or not hasattr(new, name):
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        warnings.warn(
            f"{old} is deprecated: use {new.__name__}.{name} (the module was renamed after "
            "what it holds; every leg architecture goes through it)",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(new, name)

    return __getattr__
