"""The optional extras (``pyproject.toml``) and the one check that a feature's packages are
installed, made before the work that needs them.

:func:`require` imports the modules a feature needs and raises
:class:`~stewart_pin.exceptions.MissingDependencyError` naming the extra that brings them,
with a quoted install hint (``pip install "stewart-pin[viz]"``): one line on the command
line, exit code 2, instead of a traceback after a long run.
"""

from __future__ import annotations

import importlib
from typing import Any

from stewart_pin.exceptions import MissingDependencyError

__all__ = ["install_hint", "require"]

#: The distribution (``pip`` name) of each optional module stewart-pin imports.
DISTRIBUTIONS = {"example_robot_data": "example-robot-data"}


def install_hint(extra: str) -> str:
    """``pip install "stewart-pin[<extra>]"`` (quoted: a shell must not glob the brackets)."""
    return f'pip install "stewart-pin[{extra}]"'


def require(feature: str, extra: str, *modules: str) -> list[Any]:
    """Import ``modules`` (e.g. ``"matplotlib"``) for ``feature`` (e.g. ``"the figures"``),
    returning them, or raise :class:`MissingDependencyError` naming the first missing one
    and the install hint of ``extra`` (e.g. ``"viz"``)."""
    loaded = []
    for name in modules:
        try:
            loaded.append(importlib.import_module(name))
        except ImportError as e:
            package = DISTRIBUTIONS.get(name.split(".")[0], name.split(".")[0])
            raise MissingDependencyError(
                f"{package}, needed for {feature}, is not installed: {install_hint(extra)}",
                package,
                extra,
            ) from e
    return loaded
