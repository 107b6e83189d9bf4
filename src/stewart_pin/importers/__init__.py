"""Model files in: a hexapod from its MJCF or URDF, as a
:class:`~stewart_pin.description.RobotDescription` (``docs/importing.md``).

- :func:`import_mjcf`, :func:`import_urdf`, :func:`import_model` (by the file's suffix):
  the description and an :class:`~.topology.ImportReport` of what was recognised, lumped,
  corrected and ignored. ``StewartRobot.from_mjcf`` / ``from_urdf`` wrap them.
- :mod:`.tree`: the neutral kinematic tree both readers produce; :mod:`.topology`: the
  recognition of the base, the platform and six legs in it; :mod:`.build`: the
  description built from them and the import report.
- :mod:`.canonical`: the canonical modified-DH form of a leg chosen from its joint axes,
  and :func:`~.canonical.canonical_description` (any description in that form).
- :mod:`.mjcf` (through MuJoCo) and :mod:`.urdf` (through yourdfpy; loop closures from the
  project's sidecar, onshape-to-robot's ``closing_<k>_1`` / ``closing_<k>_2`` frames or
  pairs of names).

MuJoCo and yourdfpy are optional (``pip install "stewart-pin[import]"``), imported when a
file is read.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar
from stewart_pin._so3 import so3_log as _so3_log
from stewart_pin.exceptions import InputError, ModelImportError
from stewart_pin.importers.build import (
    CLOSURE_TOLERANCE,
    SPIN_TOLERANCE,
    ImportReport,
    ImportResult,
    build,
)
from stewart_pin.importers.canonical import canonical_description
from stewart_pin.importers.topology import recognise

__all__ = [
    "CLOSURE_TOLERANCE",
    "SPIN_TOLERANCE",
    "ImportReport",
    "ImportResult",
    "canonical_description",
    "import_mjcf",
    "import_model",
    "import_urdf",
]


def import_mjcf(
    source: Any,
    *,
    keyframe: str | int | None = None,
    platform: str | None = None,
    name: str | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    spin_tolerance: float = SPIN_TOLERANCE,
    rod_spin: str = "error",
    inertials: dict[str, Any] | None = None,
) -> ImportResult:
    """A hexapod from an MJCF model (``docs/importing.md``).

    Args:
        source: a path, the XML text, or a compiled ``mujoco.MjModel``.
        keyframe: the reference (assembled) configuration: a keyframe's name or index;
            default the keyframe ``home`` if any, else ``qpos0``.
        platform: the name of the body whose frame is Fp (default: found from the
            topology, the body carrying the platform's free joint or most attachments).
        name: the robot's name (default the model's, made valid).
        closure_tolerance: the largest loop residual at the reference configuration,
            relative to the platform's size (past it :class:`LoopClosureError`).
        spin_tolerance, rod_spin: the largest asymmetry of an S-S rod about its axis, and
            ``"error"`` (:class:`RodSpinError`) or ``"warn"`` past it.
        inertials: body name -> ``{"mass", "pos", "inertia"}`` for bodies whose inertia
            MuJoCo computes from a mesh file that is missing
            (:func:`~stewart_pin.importers.mjcf.load_model`).
    """
    from stewart_pin.importers.mjcf import read_mjcf

    if keyframe is not None and (
        isinstance(keyframe, bool) or not isinstance(keyframe, (str, int))
    ):
        raise InputError(f"keyframe must be a keyframe's name or index, got {keyframe!r}")
    closure_tolerance, spin_tolerance = _check_options(
        platform, name, closure_tolerance, spin_tolerance
    )
    model = read_mjcf(source, keyframe, inertials)
    rec = recognise(model, platform)
    return build(
        model,
        rec,
        name=name,
        closure_tolerance=closure_tolerance,
        spin_tolerance=spin_tolerance,
        rod_spin=rod_spin,
    )


def import_urdf(
    path: str | Path,
    closures: Any = None,
    actuated: Sequence[str] | None = None,
    armature: dict[str, float] | None = None,
    *,
    platform: str | None = None,
    name: str | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    spin_tolerance: float = SPIN_TOLERANCE,
    rod_spin: str = "error",
) -> ImportResult:
    """A hexapod from a URDF (``docs/importing.md``).

    Args:
        path: the URDF file.
        closures: the loop closures: a sidecar file (``docs/closures.md``), a list of
            pairs ``(name1, name2)`` of links or fixed frames whose origins coincide, or
            ``None``: the sidecar ``<stem>.closures.json`` beside the URDF if there is
            one, else the frame pairs ``closing_<k>_1`` / ``closing_<k>_2``.
        actuated: the actuated joints in leg order (default the sidecar's, else the
            ``<transmission>`` elements in their order).
        armature: joint name -> armature [kg m^2 or kg] (URDF cannot say it; the
            project's sidecar can).
        platform, name, closure_tolerance, spin_tolerance, rod_spin: as
            :func:`import_mjcf`.
    """
    from stewart_pin.importers.urdf import read_urdf

    closure_tolerance, spin_tolerance = _check_options(
        platform, name, closure_tolerance, spin_tolerance
    )
    if actuated is not None and (
        isinstance(actuated, str)
        or not isinstance(actuated, Sequence)
        or not all(isinstance(joint, str) for joint in actuated)
    ):
        raise InputError(f"actuated must be a list of joint names in leg order, got {actuated!r}")
    if armature is not None:
        if not isinstance(armature, Mapping) or not all(isinstance(k, str) for k in armature):
            raise InputError(
                "armature must be a dict of joint name to armature [kg m^2 or kg], got "
                f"{armature!r}"
            )
        for joint, value in armature.items():  # named here, not as the sidecar's
            check_scalar(value, f"armature of joint '{joint}'", nonnegative=True)
    read = read_urdf(path, closures, armature)
    rec = recognise(read.model, platform if platform is not None else read.platform)
    result = build(
        read.model,
        rec,
        actuated=actuated if actuated is not None else read.actuated,
        armature=armature,
        name=name,
        closure_tolerance=closure_tolerance,
        spin_tolerance=spin_tolerance,
        rod_spin=rod_spin,
        joint_terms=read.joint_terms,
        limits=read.limits,
    )
    if read.home_pose is not None:  # the platform hangs in the tree: its pose a check
        _check_home_pose(result, read.home_pose, closure_tolerance)
    return result


def _check_home_pose(result: ImportResult, home: np.ndarray, tolerance: float) -> None:
    """The sidecar's ``home_pose`` of a platform that hangs in the tree against the pose
    its home joint positions give: :class:`ModelImportError` past ``tolerance`` times the
    platform's size (position) or ``tolerance`` rad."""
    desc = result.description
    T = desc.home_pose
    size = float(
        np.linalg.norm(desc.platform_points - desc.platform_points.mean(0), axis=1).mean()
    )
    dp = float(np.linalg.norm(T[:3, 3] - home[:3, 3]))
    angle = float(np.linalg.norm(_so3_log((home[:3, :3].T @ T[:3, :3])[None])))
    if dp > tolerance * size or angle > tolerance:
        raise ModelImportError(
            f"the sidecar's home_pose is {dp:.3g} m and {angle:.3g} rad from the pose of the "
            f"platform {result.report.platform!r} at its home joint positions (the platform "
            "hangs in the tree: home_joint_positions place it); give matching values",
            (result.report.platform,),
        )


def _check_options(
    platform: Any, name: Any, closure_tolerance: Any, spin_tolerance: Any
) -> tuple[float, float]:
    """The options both readers share, checked before the file is read: the two
    tolerances as positive finite numbers."""
    for value, what in ((platform, "platform"), (name, "name")):
        if value is not None and not isinstance(value, str):
            raise InputError(f"{what} must be a name (a string), got {value!r}")
    return (
        check_scalar(closure_tolerance, "closure_tolerance", positive=True),
        check_scalar(spin_tolerance, "spin_tolerance", positive=True),
    )


def import_model(path: str | Path, **options: Any) -> ImportResult:
    """:func:`import_urdf` for a ``.urdf`` file, :func:`import_mjcf` for any other (MJCF:
    ``.xml``, ``.mjcf``)."""
    if Path(path).suffix.lower() == ".urdf":
        return import_urdf(path, **options)
    return import_mjcf(path, **options)
