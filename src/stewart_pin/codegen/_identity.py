"""What a compiled library is made from, as the text its cache key hashes
(:func:`library_identity`), found without generating its C source (issue 24): the
description's canonical serialisation and :func:`generator_version`, the version of the
code that writes the C, derived automatically from the generator's source files so that a
code change can never reuse a stale library.

What shapes a library's C source is the description (every number baked in: geometry,
inertia, joint terms, gravity, limits, the leg architectures), the generator's code and
constants (this package's modules below ``cli``, ``apps``, ``viz``, ``planning``,
``check`` and the facades, which the layering contract forbids the generator to import),
and CasADi (its code generator). The compiler and its flags are added by
:func:`.compiled.cache_key`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin.codegen.leg_chain_symbolic import GENERAL_GENERATOR_VERSION
from stewart_pin.codegen.symbolic import GENERATOR_VERSION

__all__ = ["generator_version", "library_identity", "source_digest"]

#: The generator's source files: every module of the package but those of the layers above
#: ``codegen`` (``pyproject.toml``'s layering contract: the generator cannot import them).
_NOT_GENERATOR = ("cli", "apps", "viz", "planning", "check", "robot.py", "payload_robot.py")
_GENERATOR_VERSION: list[str] = []


def source_digest(package: Path) -> str:
    """The SHA-256 of the generator's source files under ``package`` (the folder of
    ``stewart_pin``): every ``*.py`` file but those of :data:`_NOT_GENERATOR`, each with its
    relative path, in sorted order."""
    h = hashlib.sha256()
    files = sorted(
        f.relative_to(package).as_posix()
        for f in package.rglob("*.py")
        if f.relative_to(package).parts[0] not in _NOT_GENERATOR
    )
    for name in files:
        for data in (name.encode(), (package / name).read_bytes()):
            h.update(len(data).to_bytes(8, "little"))
            h.update(data)
    return h.hexdigest()


def _casadi_identity() -> str:
    """CasADi's version as its installed metadata names it (the folder name of its
    ``*.dist-info``), with the path, size and time of its ``__init__.py``: found without
    importing it."""
    spec = importlib.util.find_spec("casadi")
    if spec is None or spec.origin is None:
        return "no casadi"
    origin = Path(spec.origin)
    site = origin.parent.parent
    try:
        infos = sorted(n for n in os.listdir(site) if n.lower().startswith("casadi-"))
        st = origin.stat()
    except OSError as e:
        return f"{origin}: {e.strerror}"
    return f"{origin} {st.st_size} {st.st_mtime_ns} {' '.join(infos)}"


def generator_version() -> str:
    """The version of the code that writes a library's C source: the generators' own
    version numbers, CasADi's identity and the digest of the generator's source files
    (:func:`source_digest`), so that a change of any of them can never reuse a stale
    library. Computed once per process (a few milliseconds)."""
    if not _GENERATOR_VERSION:
        package = Path(__file__).resolve().parent.parent
        _GENERATOR_VERSION.append(
            f"{GENERATOR_VERSION} {GENERAL_GENERATOR_VERSION}\n{_casadi_identity()}\n"
            f"{source_digest(package)}"
        )
    return _GENERATOR_VERSION[0]


def _canonical(x: Any, unknown: list[str]) -> Any:
    """``x`` as plain JSON data, exactly (floats by their shortest repr, arrays with their
    dtype and shape, dataclasses field by field under their class name); anything else (a
    function, say) is named in ``unknown``."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        fields = {f.name: _canonical(getattr(x, f.name), unknown) for f in dataclasses.fields(x)}
        return {type(x).__qualname__: fields}
    if isinstance(x, np.ndarray) and x.dtype.kind in "biuf":
        return [str(x.dtype), list(x.shape), x.tolist()]
    if isinstance(x, (list, tuple)):
        return [_canonical(v, unknown) for v in x]
    if isinstance(x, dict):
        return [[_canonical(k, unknown), _canonical(v, unknown)] for k, v in x.items()]
    if isinstance(x, np.generic) and x.dtype.kind in "biuf":
        return x.item()
    if x is None or isinstance(x, (bool, int, float, str)):
        return x
    unknown.append(type(x).__name__)
    return None


def library_identity(desc: Any, what: str) -> str | None:
    """What the library ``what`` (``"models"``, ``"derivatives"``) of ``desc`` is made from,
    as text for :func:`.compiled.cache_key`: the description's every field but its name (the
    numbers baked into the C; :func:`_canonical`) and :func:`generator_version`. None when
    the description cannot be serialised so (then the source itself is the key)."""
    if not dataclasses.is_dataclass(desc) or isinstance(desc, type):
        return None
    unknown: list[str] = []
    fields = {
        f.name: _canonical(getattr(desc, f.name), unknown)
        for f in dataclasses.fields(desc)
        if f.name != "name"
    }
    if unknown:
        return None
    text = json.dumps(fields, sort_keys=True, allow_nan=True)
    return f"stewart-pin library {what}\n{generator_version()}\n{type(desc).__qualname__}\n{text}"
