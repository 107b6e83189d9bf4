"""Deprecated: the MJCF writer of every leg architecture is :mod:`stewart_pin.formats.mjcf`.

This module was the general-leg twin of :mod:`stewart_pin.formats.mjcf` (issue 19 merged
them). Its names keep working and warn (``DeprecationWarning``) naming their new place:
``general_mjcf_string`` and ``write_general_mjcf`` (re-exported by
:mod:`stewart_pin.formats`) when called, the others when read from this module.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from stewart_pin._io import write_text_atomic
from stewart_pin.formats import mjcf
from stewart_pin.formats._deprecated import moved_names, warn_moved

#: Old name -> (the object it now is, the name to use instead).
_MOVED: dict[str, tuple[Any, str]] = {
    "general_mujoco_inertials": (
        mjcf.mujoco_inertials,
        "stewart_pin.formats.mjcf.mujoco_inertials",
    ),
    "general_mujoco_qpos": (
        mjcf.leg_chains_mujoco_qpos,
        "stewart_pin.formats.mjcf.leg_chains_mujoco_qpos",
    ),
}


__getattr__ = moved_names(__name__, _MOVED)


def general_mjcf_string(desc: Any, pinocchio_layout: bool = False) -> str:
    """Deprecated: :func:`stewart_pin.formats.mjcf_string` (the same document for a robot
    with general legs), :func:`stewart_pin.formats.mjcf.leg_chains_mjcf_string`."""
    warn_moved(
        "stewart_pin.formats.general_mjcf.general_mjcf_string",
        "stewart_pin.formats.mjcf_string (stewart_pin.formats.mjcf.leg_chains_mjcf_string: "
        "the joint-chain form of any robot with legs)",
    )
    return mjcf.leg_chains_mjcf_string(desc, pinocchio_layout)


def write_general_mjcf(desc: Any, path: str | Path, pinocchio_layout: bool = False) -> Path:
    """Deprecated: :func:`stewart_pin.formats.write_mjcf` (the same file for a robot with
    general legs)."""
    warn_moved(
        "stewart_pin.formats.general_mjcf.write_general_mjcf", "stewart_pin.formats.write_mjcf"
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, mjcf.leg_chains_mjcf_string(desc, pinocchio_layout))
    return path


__all__ = ["general_mjcf_string", "write_general_mjcf"]
