"""Checks of a URDF read from a file, before a lenient parser sees it (private module,
public names): strict numbers and a tree.

URDF parsers read numbers leniently, each its own way: urdfdom (Pinocchio) reports
``mass="1,5"`` on stderr and goes on with a massless link; Python's ``float`` takes
``1_000``, ``infinity``, Arabic-Indic digits and a non-breaking space. Before a file is
handed to either, :func:`check_urdf_numbers` reads every numeric attribute of the URDF's
links, joints and materials (origins, inertials, axes, limits, dynamics, geometry,
colours) with one strict rule: decimal numbers in ASCII (``1.5``, ``-2e-3``, ``.5``),
finite, separated by ASCII spaces (a single number without spaces around it: urdfdom
refuses ``" 1.5 "``), as many as the attribute holds; any other text is
refused, the message naming the element, its link or joint, the attribute and the value.

URDF parsers also trust the file to be a tree: the importer walked a joint cycle forever,
urdfdom drops links in a cycle that no path from the root enters (with their mass).
:func:`urdf_cycle` finds the joint that closes a cycle.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

__all__ = ["URDF_NUMBERS", "UrdfCycle", "check_urdf_numbers", "strict_numbers", "urdf_cycle"]

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


@dataclass(frozen=True)
class UrdfCycle:
    """A joint that makes a URDF's links other than a tree: ``joint`` (its name), its
    ``parent`` and ``child`` links, and ``message``, what is wrong (to follow the file's
    name)."""

    joint: str
    parent: str
    child: str
    message: str


def urdf_cycle(root: Any) -> UrdfCycle | None:
    """The first joint of ``root`` (a ``<robot>`` element) that closes a cycle: one whose
    child link already has a parent joint, or, when each link has at most one parent,
    the first joint no path from the root link reaches (its links form a cycle); ``None``
    for a tree. Joints naming links that do not exist, and several roots, are left to the
    readers' own messages."""
    links = {str(el.get("name")) for el in root.findall("link")}
    parent_of: dict[str, str] = {}
    children: dict[str, list[str]] = {}
    joints: list[tuple[str, str, str]] = []
    for el in root.findall("joint"):
        ends = [el.find(tag) for tag in ("parent", "child")]
        names = [str(e.get("link")) if e is not None else "" for e in ends]
        parent, child = names
        if parent not in links or child not in links:
            continue
        name = str(el.get("name", ""))
        if child in parent_of:
            return UrdfCycle(
                name,
                parent,
                child,
                f"joint {_shown(name)} closes a cycle: its child link {_shown(child)} already "
                f"has the parent joint {_shown(parent_of[child])}; a URDF is a tree",
            )
        parent_of[child] = name
        children.setdefault(parent, []).append(child)
        joints.append((name, parent, child))
    roots = [n for n in links if n not in parent_of]
    if len(roots) > 1:
        return None
    reached = set(roots)
    stack = list(roots)
    while stack:
        for child in children.get(stack.pop(), []):
            if child not in reached:
                reached.add(child)
                stack.append(child)
    for name, parent, child in joints:
        if parent not in reached:
            start = f"the root link {_shown(roots[0])}" if roots else "any root link"
            return UrdfCycle(
                name,
                parent,
                child,
                f"joint {_shown(name)} is not reached from {start}: its links form a cycle "
                "(each has a parent joint); a URDF is one tree",
            )
    return None
