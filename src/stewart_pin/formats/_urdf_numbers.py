"""Strict numbers in a URDF read from a file (private module, public name).

URDF parsers read numbers leniently, each its own way: urdfdom (Pinocchio) reports
``mass="1,5"`` on stderr and goes on with a massless link; Python's ``float`` takes
``1_000``, ``infinity``, Arabic-Indic digits and a non-breaking space. Before a file is
handed to either, :func:`check_urdf_numbers` reads every numeric attribute of the URDF's
links, joints and materials (origins, inertials, axes, limits, dynamics, geometry,
colours) with one strict rule: decimal numbers in ASCII (``1.5``, ``-2e-3``, ``.5``),
finite, separated by ASCII spaces (a single number without spaces around it: urdfdom
refuses ``" 1.5 "``), as many as the attribute holds; any other text is
refused, the message naming the element, its link or joint, the attribute and the value.
"""

from __future__ import annotations

import math
import re
from typing import Any

__all__ = ["URDF_NUMBERS", "check_urdf_numbers", "strict_numbers"]

#: The numeric attributes of a URDF's elements and how many numbers each holds.
URDF_NUMBERS: dict[str, dict[str, tuple[int, ...]]] = {
    "origin": {"xyz": (3,), "rpy": (3,)},
    "mass": {"value": (1,)},
    "inertia": {k: (1,) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "axis": {"xyz": (3,)},
    "limit": {"lower": (1,), "upper": (1,), "effort": (1,), "velocity": (1,)},
    "dynamics": {"damping": (1,), "friction": (1,)},
    "safety_controller": {
        k: (1,) for k in ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity")
    },
    "calibration": {"rising": (1,), "falling": (1,)},
    "mimic": {"multiplier": (1,), "offset": (1,)},
    "box": {"size": (3,)},
    "cylinder": {"radius": (1,), "length": (1,)},
    "capsule": {"radius": (1,), "length": (1,)},
    "sphere": {"radius": (1,)},
    "mesh": {"scale": (1, 3)},
    "color": {"rgba": (4,)},
}
#: The elements of ``<robot>`` whose descendants are checked (not ``<gazebo>`` extensions).
_CHECKED_PARENTS = ("link", "joint", "material")
#: One decimal number, ASCII digits only (no ``_``, no ``nan``/``inf``, no hexadecimal).
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_SPACES = re.compile(r"[ \t\r\n]+")


def strict_numbers(text: str) -> list[float] | None:
    """The numbers of ``text`` (ASCII decimal numbers separated by ASCII whitespace), or
    ``None`` when any field is something else or is not finite (``1e999``)."""
    fields = [f for f in _SPACES.split(text.strip(" \t\r\n")) if f]
    if not fields or not all(_NUMBER.fullmatch(f) for f in fields):
        return None
    values = [float(f) for f in fields]
    return values if all(math.isfinite(v) for v in values) else None


def _shown(text: str) -> str:
    return repr(text if len(text) <= 60 else text[:57] + "...")


def check_urdf_numbers(root: Any, source: str, error: type[Exception]) -> None:
    """Refuse (``error(message)``) a numeric attribute of ``root`` (the ``<robot>``
    element, from ``xml.etree`` or lxml) that is not :func:`strict_numbers` of the
    expected count (:data:`URDF_NUMBERS`).

    Args:
        root: the parsed ``<robot>`` element. source: the file, as shown in the message.
        error: the exception class raised (the caller's: ``PayloadError``,
            ``FileFormatError``).
    """
    for parent in root:
        if parent.tag not in _CHECKED_PARENTS:
            continue
        owner = f"{parent.tag} {_shown(str(parent.get('name', '')))}"
        for el in parent.iter():
            for attr, counts in URDF_NUMBERS.get(str(el.tag), {}).items():
                text = el.get(attr)
                if text is None:
                    continue
                values = strict_numbers(text)
                if counts == (1,) and not _NUMBER.fullmatch(text):
                    values = None  # urdfdom reads one number without surrounding spaces
                if values is not None and len(values) in counts:
                    continue
                line = getattr(el, "sourceline", None)
                where = f" line {line}" if line else ""
                want = " or ".join(str(c) for c in counts)
                plural = "a number" if counts == (1,) else f"{want} numbers"
                raise error(
                    f"{source}{where}: <{el.tag} {attr}={_shown(text)}> of {owner} is not "
                    f"{plural}: write finite decimal numbers with a point, separated by "
                    "spaces (1.5, -2e-3; not 1,5, 1.5kg, nan or inf)"
                )
