"""Deprecated: the URDF writer of every leg architecture is :mod:`stewart_pin.formats.urdf`.

This module was the general-leg twin of :mod:`stewart_pin.formats.urdf` (issue 19 merged
them). Its names keep working and warn (``DeprecationWarning``) naming their new place:
``general_urdf_string`` and ``write_general_urdf`` (re-exported by
:mod:`stewart_pin.formats`) when called, the others when read from this module.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from stewart_pin.formats import urdf
from stewart_pin.formats._deprecated import moved_names, warn_moved

#: Old name -> (the object it now is, the name to use instead).
_MOVED: dict[str, tuple[Any, str]] = {
    "JOINT_TERMS_KEY": (urdf.JOINT_TERMS_KEY, "stewart_pin.formats.urdf.JOINT_TERMS_KEY"),
    "URDF_UNBOUNDED": (urdf.URDF_UNBOUNDED, "stewart_pin.formats.urdf.URDF_UNBOUNDED"),
    "GeneralVisualSizes": (urdf.LegVisualSizes, "stewart_pin.formats.urdf.LegVisualSizes"),
    "general_closures_dict": (
        urdf.leg_chains_closures_dict,
        "stewart_pin.formats.urdf.leg_chains_closures_dict",
    ),
    "is_general": (urdf.is_general, "stewart_pin.formats.urdf.is_general"),
    "joint_terms": (urdf.joint_terms, "stewart_pin.formats.urdf.joint_terms"),
    "leg_joint_values": (urdf.leg_joint_values, "stewart_pin.formats.urdf.leg_joint_values"),
    "parse_joint_terms": (urdf.parse_joint_terms, "stewart_pin.formats.urdf.parse_joint_terms"),
    "read_actuated_joints": (
        urdf.read_actuated_joints,
        "stewart_pin.formats.urdf.read_actuated_joints",
    ),
    "read_joint_terms": (urdf.read_joint_terms, "stewart_pin.formats.urdf.read_joint_terms"),
}


__getattr__ = moved_names(__name__, _MOVED)


def general_urdf_string(desc: Any) -> str:
    """Deprecated: :func:`stewart_pin.formats.urdf_string` (the same document for a robot
    with general legs), :func:`stewart_pin.formats.urdf.leg_chains_urdf_string`."""
    warn_moved(
        "stewart_pin.formats.general_urdf.general_urdf_string",
        "stewart_pin.formats.urdf_string (stewart_pin.formats.urdf.leg_chains_urdf_string: "
        "the joint-chain form of any robot with legs)",
    )
    return urdf.leg_chains_urdf_string(desc)


def write_general_urdf(desc: Any, path: str | Path) -> tuple[Path, Path]:
    """Deprecated: :func:`stewart_pin.formats.write_urdf` (the same files for a robot with
    general legs)."""
    warn_moved(
        "stewart_pin.formats.general_urdf.write_general_urdf", "stewart_pin.formats.write_urdf"
    )
    return urdf.write_with_sidecar(
        path,
        lambda: urdf.leg_chains_urdf_string(desc),
        lambda n: urdf.leg_chains_closures_dict(desc, n),
    )


__all__ = ["general_urdf_string", "write_general_urdf"]
