"""Names kept at their former place (the ``general_*`` twins merged by issue 19): each
warns, with a ``DeprecationWarning`` naming its new place, and works as before."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any


def warn_moved(old: str, new: str) -> None:
    """Warn that ``old`` (a dotted name) is deprecated, naming ``new``; the warning points
    at the caller of the function that calls this one."""
    warnings.warn(
        f"{old} is deprecated: use {new} (one writer for every leg architecture)",
        DeprecationWarning,
        stacklevel=3,
    )


def moved_names(module: str, moved: dict[str, tuple[Any, str]]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` for ``module`` (its dotted name) that returns
    ``moved[name][0]`` after :func:`warn_moved` naming ``moved[name][1]``, and raises
    ``AttributeError`` for any other name."""

    def __getattr__(name: str) -> Any:
        if name in moved:
            value, new = moved[name]
            warn_moved(f"{module}.{name}", new)
            return value
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__
