"""Model files in: a hexapod from its MJCF, URDF or SDF, as a
:class:`~stewart_pin.description.RobotDescription` (``docs/importing.md``).

- :func:`import_mjcf`, :func:`import_urdf`, :func:`import_sdf`, :func:`import_model` (by
  the file's suffix; :func:`model_format` names the format, or refuses a file in a format
  not read in one line saying how to convert it): the description and an
  :class:`~.topology.ImportReport` of what was recognised, lumped, corrected and
  ignored. ``StewartRobot.from_mjcf`` / ``from_urdf`` / ``from_sdf`` wrap them.
- :mod:`.tree`: the neutral kinematic tree both readers produce; :mod:`.topology`: the
  recognition of the base, the platform and six legs in it; :mod:`.build`: the
  description built from them and the import report; :mod:`.chains`: legs that are not
  three 1-dof joints and an ideal spherical joint, read exactly as chain legs (any 1-dof
  joints closed by a ball or a weld; ``approximate_legs=True`` keeps the old ball
  approximation instead).
- :mod:`.canonical`: the canonical modified-DH form of a leg chosen from its joint axes,
  and :func:`~.canonical.canonical_description` (any description in that form).
- :mod:`.mjcf` (through MuJoCo) and :mod:`.urdf` (through yourdfpy; loop closures from the
  project's sidecar, onshape-to-robot's ``closing_<k>_1`` / ``closing_<k>_2`` frames or
  pairs of names); :mod:`.sdf` (Gazebo's SDFormat 1.4 to 1.11, the project's own strict
  reader).

MuJoCo, yourdfpy and lxml are optional (``pip install "stewart-pin[import]"``), imported
when a file is read.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar
from stewart_pin._so3 import so3_log as _so3_log
from stewart_pin.description.chain_leg import CLOSURES
from stewart_pin.exceptions import FileFormatError, InputError, ModelImportError
from stewart_pin.importers.build import (
    CLOSURE_TOLERANCE,
    SPIN_TOLERANCE,
    ImportReport,
    ImportResult,
    build,
)
from stewart_pin.importers.canonical import canonical_description
from stewart_pin.importers.chains import ChainRecognition, build_chains, recognise_chains
from stewart_pin.importers.topology import Recognition, recognise
from stewart_pin.importers.tree import KinematicModel, shown_list

__all__ = [
    "CLOSURE_TOLERANCE",
    "SPIN_TOLERANCE",
    "ImportReport",
    "ImportResult",
    "canonical_description",
    "import_mjcf",
    "import_model",
    "import_sdf",
    "import_urdf",
    "model_format",
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
    approximate_legs: bool = False,
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
        approximate_legs: a leg that is not exactly three 1-dof joints and an ideal
            spherical joint is read as it is, a chain leg (default); ``True`` takes three
            hinges that nearly meet as an ideal ball instead (masses between them and their
            joint terms dropped, axes snapped: reported, with their effect on the efforts
            by ``stewart-pin import``).
    """
    from stewart_pin.importers.mjcf import read_mjcf

    if isinstance(source, Path) or (
        isinstance(source, str) and not source.lstrip().startswith("<")
    ):
        model_format(source, "mjcf")
    if keyframe is not None and (
        isinstance(keyframe, bool) or not isinstance(keyframe, (str, int))
    ):
        raise InputError(f"keyframe must be a keyframe's name or index, got {keyframe!r}")
    closure_tolerance, spin_tolerance = _check_options(
        platform, name, closure_tolerance, spin_tolerance
    )
    model = read_mjcf(source, keyframe, inertials)
    rec = _recognise(model, platform, approximate_legs)
    return _build(
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
    approximate_legs: bool = False,
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
        platform, name, closure_tolerance, spin_tolerance, rod_spin, approximate_legs: as
            :func:`import_mjcf`.
    """
    from stewart_pin.importers.urdf import read_urdf

    closure_tolerance, spin_tolerance = _check_options(
        platform, name, closure_tolerance, spin_tolerance
    )
    _check_actuated(actuated)
    model_format(path, "urdf")
    if armature is not None:
        if not isinstance(armature, Mapping) or not all(isinstance(k, str) for k in armature):
            raise InputError(
                "armature must be a dict of joint name to armature [kg m^2 or kg], got "
                f"{armature!r}"
            )
        for joint, value in armature.items():  # named here, not as the sidecar's
            check_scalar(value, f"armature of joint '{joint}'", nonnegative=True)
    read = read_urdf(path, closures, armature)
    rec = _recognise(
        read.model, platform if platform is not None else read.platform, approximate_legs
    )
    result = _build(
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


def import_sdf(
    path: str | Path,
    actuated: Sequence[str] | None = None,
    *,
    platform: str | None = None,
    name: str | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    spin_tolerance: float = SPIN_TOLERANCE,
    rod_spin: str = "error",
    approximate_legs: bool = False,
) -> ImportResult:
    """A hexapod from a Gazebo SDF file (SDFormat 1.4 to 1.11; ``docs/importing.md``).

    Args:
        path: the ``.sdf`` (or ``.world``) file: one ``<model>``, or a ``<world>`` with it.
        actuated: the actuated joints in leg order. SDF has no actuators: by default each
            leg's one revolute or prismatic joint (a universal joint's hinges are passive),
            legs in the order of those joints in the file; a leg with several needs this.
        platform, name, closure_tolerance, spin_tolerance, rod_spin, approximate_legs: as
            :func:`import_mjcf`.
    """
    from stewart_pin.importers.sdf import default_actuated, read_sdf

    closure_tolerance, spin_tolerance = _check_options(
        platform, name, closure_tolerance, spin_tolerance
    )
    _check_actuated(actuated)
    model_format(path, "sdf")
    read = read_sdf(path)
    rec = _recognise(read.model, platform, approximate_legs)
    if actuated is None:
        if isinstance(rec, ChainRecognition):
            legs = [[J.name for J in leg.joints] for leg in rec.legs]
        else:
            legs = [[e.joint.name for e in leg.edges if not e.spherical] for leg in rec.legs]
        actuated = default_actuated(read, legs)
    return _build(
        read.model,
        rec,
        actuated=actuated,
        name=name,
        closure_tolerance=closure_tolerance,
        spin_tolerance=spin_tolerance,
        rod_spin=rod_spin,
    )


def _recognise(
    model: KinematicModel, platform: str | None, approximate_legs: bool
) -> Recognition | ChainRecognition:
    """The three-joint recognition (:func:`~.topology.recognise`: today's legs, exactly
    as before), or, when it does not fit, the legs as chain legs
    (:func:`~.chains.recognise_chains`: any 1-dof joints closed by a ball or a weld, read
    exactly); ``approximate_legs``: the three-joint recognition only, nearly spherical
    hinge triples taken as ideal balls (reported with their effect). The three-joint
    recognition's error is raised when neither fits."""
    if not isinstance(approximate_legs, bool):
        raise InputError(f"approximate_legs must be True or False, got {approximate_legs!r}")
    if approximate_legs:
        return recognise(model, platform, approximate=True)
    notes = list(model.notes)
    try:
        return recognise(model, platform)
    except ModelImportError as err:
        model.notes[:] = notes
        chains = recognise_chains(model, platform)
        if chains is None:
            model.notes[:] = notes
            raise err from None
        for leg in chains.legs:
            n, c = len(leg.joints), CLOSURES[leg.closure]
            if n == c or (leg.closure == "ball" and n == c + 1):
                continue
            if leg.closure == "ball" or "a weld where a ball should be" in str(err):
                raise err from None
            names = tuple(J.name for J in leg.joints)
            raise ModelImportError(
                f"the leg of joints {shown_list(names)} closed by the {leg.label} (a weld: 6 "
                f"constraints) has {n} joints: "
                + (
                    f"it leaves the platform {c - n} freedom(s) short of six; close it by a "
                    "ball (a point closure) at its spherical joint, or give it six joints"
                    if n < c
                    else f"{n - c} freedom(s) too many: the actuators would not hold the platform"
                ),
                (),
                names,
            ) from None
        chains.fallback = err
        return chains


def _build(
    model: KinematicModel, rec: Recognition | ChainRecognition, **options: Any
) -> ImportResult:
    """:func:`~.build.build` for three-joint legs, :func:`~.chains.build_chains` for chain
    legs (the options only three-joint legs have left out)."""
    if isinstance(rec, ChainRecognition):
        for key in ("spin_tolerance", "rod_spin"):
            options.pop(key, None)
        return build_chains(model, rec, **options)
    return build(model, rec, **options)


def _check_actuated(actuated: Any) -> None:
    """:class:`InputError` unless ``actuated`` is None or a list of joint names."""
    if actuated is not None and (
        isinstance(actuated, str)
        or not isinstance(actuated, Sequence)
        or not all(isinstance(joint, str) for joint in actuated)
    ):
        raise InputError(f"actuated must be a list of joint names in leg order, got {actuated!r}")


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


#: The suffixes of the formats read (lower case).
READ_SUFFIXES = {".urdf": "urdf", ".xml": "mjcf", ".mjcf": "mjcf", ".sdf": "sdf", ".world": "sdf"}
_USD = (
    "a USD stage (have the robot written as a URDF or an MJCF, e.g. by Isaac Sim's URDF "
    "exporter, then import that)"
)
_MESH = "a mesh, geometry only (no joints, no masses): give the model file that uses it"
#: Formats not read, by suffix: what the file is, and how to make it one that is.
NOT_READ = {
    ".xacro": "a xacro template (expand it to a URDF first with xacrodoc, `pip install xacrodoc`: "
    "`xacrodoc FILE.urdf.xacro -o robot.urdf`; then import the .urdf)",
    ".erb": "an ERB template (Gazebo's Ruby templates: render it first, `erb FILE.sdf.erb > "
    "robot.sdf`, then import the .sdf)",
    ".wbt": "a Webots world (have Webots write the robot as a URDF: Export URDF in the "
    "robot's context menu, or wb_robot_get_urdf(); its loops then go in the sidecar, "
    "docs/closures.md)",
    ".proto": "a Webots PROTO (put it in a world and have Webots write the robot as a URDF)",
    ".slx": "a Simulink / Simscape Multibody model (Simscape writes no URDF: describe the "
    "robot as a URDF, an MJCF or an SDF, e.g. from the CAD it came from)",
    ".ssc": "a Simscape language file (describe the robot as a URDF, an MJCF or an SDF)",
    ".usd": _USD,
    ".usda": _USD,
    ".usdc": _USD,
    ".usdz": _USD,
    ".dae": _MESH,
    ".stl": _MESH,
    ".obj": _MESH,
}
_READ = "URDF (.urdf), MJCF (.xml, .mjcf) and SDF (.sdf, .world)"
_NAMES = {"urdf": "a URDF", "mjcf": "an MJCF model", "sdf": "an SDF file"}


def model_format(path: str | Path, expected: str | None = None) -> str:
    """The format of a model file by its suffix: ``"urdf"``, ``"mjcf"`` (``.xml``,
    ``.mjcf``) or ``"sdf"`` (``.sdf``, ``.world``).

    :class:`FileFormatError` in one line for a format not read (naming it and how to
    convert or expand it: :data:`NOT_READ`), and without ``expected`` (the format chosen
    by its suffix) for an unknown suffix. With ``expected`` (the importer the caller chose)
    any other suffix is taken as that format, except one of another format read
    (``.urdf``, ``.sdf``, ``.world``; ``.xml`` may be any of them), refused naming the
    right importer."""
    suffix = Path(path).suffix.lower()
    if suffix in NOT_READ:
        raise FileFormatError(f"{path} is {NOT_READ[suffix]}; stewart-pin reads {_READ}")
    kind = READ_SUFFIXES.get(suffix)
    if expected is not None:
        if kind is not None and kind != expected and suffix != ".xml":
            raise FileFormatError(
                f"{path} is {_NAMES[kind]} (by its suffix): read it with from_{kind} / "
                f"import_{kind}, not from_{expected}"
            )
        return expected
    if kind is None:
        raise FileFormatError(
            f"{path}: the suffix {suffix or '(none)'!r} is no model format stewart-pin reads: "
            f"it reads {_READ} (rename the file if it is one of them)"
        )
    return kind


def import_model(path: str | Path, **options: Any) -> ImportResult:
    """:func:`import_urdf`, :func:`import_mjcf` or :func:`import_sdf` by the file's suffix
    (:func:`model_format`)."""
    kind = model_format(path)
    if kind == "urdf":
        return import_urdf(path, **options)
    if kind == "sdf":
        return import_sdf(path, **options)
    return import_mjcf(path, **options)
