"""URDF and closure sidecar of a robot with general three-joint legs.

For any robot carrying six :class:`~stewart_pin.description.leg_architecture.LegArchitecture`
(duck-typed: ``base_points``, ``leg_base_rotations``, ``platform_points``, ``legs``,
``leg_inertia``, ``platform_inertia``, ``gravity``, ``home_pose``, ``name``: a
``GeneralHexapod``, or a ``RobotDescription`` carrying legs), :func:`general_urdf_string`
writes the tree with the same names as the 6-UPS URDF (:mod:`stewart_pin.formats.urdf`):

- ``base_link`` (frame F0); per leg i the links ``leg{i}_link1..3`` joined by
  ``leg{i}_q1..3``, each ``revolute`` or ``prismatic`` as the leg's joint j, axis ``z``,
  origin the MDH placement ``Rx(alpha) Tx(d) Rz(theta) Tz(r)`` from the previous link
  (for joint 1 preceded by ``[R_i, B_i]``). Every link frame is the MDH joint frame, so
  the inertials are the description's Khalil parameters converted exactly (centre of mass
  and inertia about it, frame never rotated);
- ``<limit>``: the joint's limits; URDF has no unbounded revolute joint of one
  coordinate (``continuous`` is a 2-coordinate joint in Pinocchio) and refuses ``inf``, so
  an unbounded side is written as ``-+``:data:`URDF_UNBOUNDED` (the sidecar keeps
  ``null``);
- ``<dynamics damping friction>``: ``damping`` = viscous + damper coefficients, ``friction``
  = the Coulomb coefficient (URDF's friction is Coulomb's);
- ``platform`` on the ``floating`` joint ``platform_joint``;
- visuals: a bar from each link's origin to the next joint's origin (crank, offsets) or to
  P_i (rod), a rail on the parent of each prismatic joint along its travel, a carriage box
  on each slide, a sphere at each spherical joint, the base and platform discs.

The sidecar (:func:`general_closures_dict`, ``docs/closures.md``) names the six closures
``leg{i}_link3`` at ``tip`` == ``platform`` at ``P_i``, the actuated joints in leg order,
gravity, and under ``"joint_terms"`` every leg joint's terms, those URDF cannot hold
(armature, stiffness, rest position, transmission, true limits) with the others.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import decode_utf8
from stewart_pin.exceptions import FileFormatError
from stewart_pin.formats._xml import Visual, num, urdf_inertial, urdf_origin, urdf_visual
from stewart_pin.formats.urdf import (
    BASE_LINK,
    CLOSURE_FORMAT,
    PLATFORM_LINK,
    URDF_EFFORT,
    URDF_VELOCITY,
    VisualSizes,
    add_platform,
    home_configuration,
    leg_joint,
    leg_link,
    robot_with_base,
    write_with_sidecar,
)

#: The bound written for an unbounded side of a joint's limits [rad or m].
URDF_UNBOUNDED = 1.0e9
#: Key of the joint terms in the sidecar.
JOINT_TERMS_KEY = "joint_terms"


def is_general(desc: Any) -> bool:
    """True for a robot the general-leg writers handle: it carries ``legs`` and is not
    flagged ``is_ideal_ups`` (a 6-UPS ``RobotDescription`` keeps today's files)."""
    return getattr(desc, "legs", None) is not None and not getattr(desc, "is_ideal_ups", False)


def robot_size(desc: Any) -> float:
    """A length scale [m]: the mean distance of the platform points to their centroid."""
    P = np.asarray(desc.platform_points, float)
    r = float(np.linalg.norm(P - P.mean(0), axis=1).mean())
    return r if r > 0 else float(np.linalg.norm(np.asarray(desc.base_points).std(0)))


@dataclass(frozen=True)
class GeneralVisualSizes:
    """Sizes of the simple visuals of general legs [m], scaled on the robot."""

    joint_radius: float
    bar_radius: float
    rail_radius: float
    carriage: float
    plate_thickness: float

    @classmethod
    def for_robot(cls, desc: Any) -> GeneralVisualSizes:
        s = robot_size(desc)
        return cls(0.04 * s, 0.015 * s, 0.025 * s, 0.06 * s, 0.04 * s)

    def plate(self) -> VisualSizes:
        """The sizes :func:`plate_visual` reads (joint radius, plate thickness)."""
        return VisualSizes(self.joint_radius, 0.0, 0.0, 0.0, 0.0, self.plate_thickness)


def leg_joint_values(desc: Any, pose: Any = None) -> np.ndarray:
    """The legs' joint values (6, 3) at ``pose`` (default the home pose), limits unchecked."""
    from stewart_pin.kinematics.leg_chains import inverse_geometry

    T = np.asarray(desc.home_pose if pose is None else pose, dtype=float)
    return np.asarray(inverse_geometry(desc, T, check_limits=False))


def joint_placement(desc: Any, k: int, j: int) -> np.ndarray:
    """Frame j of leg k (0-based) in its parent link's frame at zero joint value (4x4):
    the MDH placement, preceded by ``[R_i, B_i]`` for the first joint."""
    T = np.asarray(desc.legs[k].joints[j].placement(), dtype=float)
    if j == 0:
        T0 = np.eye(4)
        T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
        T = T0 @ T
    return T


def next_point(desc: Any, k: int, j: int) -> np.ndarray:
    """In link j's frame (0-based j): the origin of the next joint at zero value, or P_i
    (the leg's tip) for the last link [m]."""
    leg = desc.legs[k]
    if j == 2:
        return np.asarray(leg.tip, dtype=float)
    return np.asarray(leg.joints[j + 1].placement()[:3, 3], dtype=float)


def travel(desc: Any, k: int, j: int, q_home: np.ndarray) -> tuple[float, float]:
    """The drawn travel of joint j of leg k [m or rad]: its limits (an unbounded side
    replaced by the home value -+ half the robot's size), stretched to include 0 (the
    joint's origin: a U-P-S cylinder starts at its U-joint)."""
    joint = desc.legs[k].joints[j]
    half = 0.5 * robot_size(desc)
    lo = joint.lower if math.isfinite(joint.lower) else q_home[k, j] - half
    hi = joint.upper if math.isfinite(joint.upper) else q_home[k, j] + half
    return min(float(lo), 0.0), max(float(hi), 0.0)


def _segment_rpy(v: np.ndarray) -> np.ndarray:
    """rpy of a frame whose z is along ``v``."""
    z = v / np.linalg.norm(v)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.asarray(pin.rpy.matrixToRpy(np.column_stack([x, np.cross(z, x), z])))


def _bar(a: np.ndarray, b: np.ndarray, radius: float, material: str) -> list[Visual]:
    """The cylinder from ``a`` to ``b`` [m] (none when they coincide)."""
    v = b - a
    length = float(np.linalg.norm(v))
    if length <= 1e-9:
        return []
    size = {"radius": radius, "length": length}
    return [Visual("cylinder", material, (a + b) / 2, _segment_rpy(v), size)]


def leg_visuals(
    desc: Any, k: int, vs: GeneralVisualSizes, q_home: np.ndarray
) -> tuple[list[Visual], list[list[Visual]]]:
    """The visuals of leg k (0-based), in the order written: ``(on_base, links)`` with
    ``on_base`` the rail of a prismatic first joint (on ``base_link``) and ``links`` the
    visuals of links 1..3 in their frames: each link's bar to the next joint (crank,
    offsets) or to P_i (rod); a revolute joint's hinge (a short dark cylinder along its
    axis); a prismatic joint's carriage (a box) on its link and its rail along the drawn
    :func:`travel` on the parent; the sphere at P_i on link 3. Shared by the URDF and the
    xacro arguments (:func:`stewart_pin.formats.xacro.general_xacro_args`)."""
    leg = desc.legs[k]
    on_base: list[Visual] = []
    links: list[list[Visual]] = [[], [], []]
    for j, joint in enumerate(leg.joints):
        material = "rod_silver" if j == 2 else "cylinder_blue"
        links[j] += _bar(np.zeros(3), next_point(desc, k, j), vs.bar_radius, material)
        if joint.revolute:
            size = {"radius": vs.joint_radius * 0.8, "length": vs.joint_radius * 2.0}
            links[j].append(Visual("cylinder", "joint_dark", size=size))
        else:
            c = vs.carriage
            links[j].append(Visual("box", "joint_dark", size={"size": (c, c, c)}))
            lo, hi = travel(desc, k, j, q_home)
            T = joint_placement(desc, k, j)
            z = T[:3, 2]
            rail = _bar(T[:3, 3] + lo * z, T[:3, 3] + hi * z, vs.rail_radius, "cylinder_blue")
            (on_base if j == 0 else links[j - 1]).extend(rail)
    tip = np.asarray(leg.tip, dtype=float)
    links[2].append(Visual("sphere", "joint_dark", tip, size={"radius": vs.joint_radius}))
    return on_base, links


def limit_values(lower: float, upper: float) -> tuple[float, float]:
    return (
        lower if math.isfinite(lower) else -URDF_UNBOUNDED,
        upper if math.isfinite(upper) else URDF_UNBOUNDED,
    )


def general_urdf_string(desc: Any) -> str:
    """The URDF of the tree of a robot with general legs (see the module docstring).

    The robot name goes into the ``name`` attribute only, escaped by ElementTree (and
    refused by :class:`~stewart_pin.exceptions.InputError` if XML cannot hold it).
    """
    vs = GeneralVisualSizes.for_robot(desc)
    q_home = leg_joint_values(desc)
    robot, base = robot_with_base(desc.name, np.asarray(desc.base_points), vs.plate())

    for i in range(1, 7):
        k = i - 1
        leg = desc.legs[k]
        parents = [BASE_LINK] + [leg_link(i, j) for j in (1, 2)]
        links = [ET.SubElement(robot, "link", name=leg_link(i, j)) for j in (1, 2, 3)]
        on_base, visuals = leg_visuals(desc, k, vs, q_home)
        for j, link in enumerate(links):
            urdf_inertial(link, np.asarray(desc.leg_inertia[k][j], dtype=float))
        for visual in on_base:
            urdf_visual(base, visual)
        for link, link_visuals in zip(links, visuals, strict=True):
            for visual in link_visuals:
                urdf_visual(link, visual)
        for j, joint in enumerate(leg.joints):
            T = joint_placement(desc, k, j)
            el = ET.SubElement(robot, "joint", name=leg_joint(i, j + 1), type=str(joint.kind))
            ET.SubElement(el, "parent", link=parents[j])
            ET.SubElement(el, "child", link=leg_link(i, j + 1))
            urdf_origin(el, T[:3, 3], pin.rpy.matrixToRpy(T[:3, :3]))
            ET.SubElement(el, "axis", xyz="0 0 1")
            lo_w, hi_w = limit_values(joint.lower, joint.upper)
            ET.SubElement(
                el,
                "limit",
                lower=num(lo_w),
                upper=num(hi_w),
                effort=num(URDF_EFFORT),
                velocity=num(URDF_VELOCITY),
            )
            dyn = joint.dynamics
            ET.SubElement(
                el,
                "dynamics",
                damping=num(dyn.viscous + dyn.damping),
                friction=num(dyn.coulomb),
            )

    add_platform(robot, desc.platform_inertia, np.asarray(desc.platform_points), vs.plate())
    ET.indent(robot)
    text = ET.tostring(robot, encoding="unicode")
    return (
        '<?xml version="1.0"?>\n'
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        "<!-- General legs. Loop closures and the joint terms URDF cannot hold: the "
        ".closures.json file of the same name beside this one. -->\n" + text + "\n"
    )


def _bound(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def joint_terms(desc: Any) -> dict[str, dict[str, Any]]:
    """The sidecar's ``joint_terms``: for each joint ``leg{i}_q{j}``, its kind, whether it
    is actuated, its true limits (``null``: unbounded) and its dynamics (SI units; see
    :class:`~stewart_pin.description.leg_architecture.JointDynamics`); ``armature`` is
    the joint-side total (rotor inertia reflected), the others as described."""
    out: dict[str, dict[str, Any]] = {}
    for i, leg in enumerate(desc.legs, start=1):
        for j, joint in enumerate(leg.joints, start=1):
            d = joint.dynamics
            out[leg_joint(i, j)] = {
                "kind": str(joint.kind),
                "actuated": j == leg.actuated,
                "lower": _bound(joint.lower),
                "upper": _bound(joint.upper),
                "armature": float(d.total_armature),
                "viscous": float(d.viscous),
                "damping": float(d.damping),
                "coulomb": float(d.coulomb),
                "stiffness": float(d.stiffness),
                "rest_position": float(d.rest_position),
                "gear_ratio": d.gear_ratio,
                "screw_lead": d.screw_lead,
                "rotor_inertia": float(d.rotor_inertia),
                "own_armature": float(d.armature),
            }
    return out


def general_closures_dict(desc: Any, urdf_name: str | None = None) -> dict[str, Any]:
    """The sidecar of a general-leg robot as a dict (format of ``docs/closures.md``)."""
    return {
        "format": CLOSURE_FORMAT,
        "version": 1,
        "urdf": urdf_name or f"{desc.name}.urdf",
        "description": (
            "Point constraints closing the six loops: point1 in link1 coincides with point2 "
            "in link2 (spherical joints). Coordinates in each link's frame [m]. joint_terms: "
            "each leg joint's limits and dynamics, SI units (armature joint-side)."
        ),
        "closures": [
            {
                "name": f"loop{i}",
                "type": "point",
                "link1": leg_link(i, 3),
                "point1": np.asarray(leg.tip, dtype=float).tolist(),
                "link2": PLATFORM_LINK,
                "point2": np.asarray(desc.platform_points[i - 1], dtype=float).tolist(),
            }
            for i, leg in enumerate(desc.legs, start=1)
        ],
        "actuated_joints": [leg_joint(i, leg.actuated) for i, leg in enumerate(desc.legs, 1)],
        "gravity": np.asarray(desc.gravity, dtype=float).tolist(),
        "architectures": [str(leg.name) for leg in desc.legs],
        JOINT_TERMS_KEY: joint_terms(desc),
        **home_configuration(desc),
    }


_TERM_KEYS = ("armature", "viscous", "damping", "coulomb", "stiffness", "rest_position")


def parse_joint_terms(data: Any, source: str = "closures") -> dict[str, dict[str, float]]:
    """The ``joint_terms`` of a sidecar dict: joint name -> the six numbers of
    ``_TERM_KEYS`` (empty for a sidecar without the key: a 6-UPS robot without terms);
    :class:`FileFormatError` on a malformed entry."""
    terms = data.get(JOINT_TERMS_KEY) if isinstance(data, dict) else None
    if terms is None:
        return {}
    if not isinstance(terms, dict):
        raise FileFormatError(f"{source}: '{JOINT_TERMS_KEY}' must be an object")
    out: dict[str, dict[str, float]] = {}
    for name, entry in terms.items():
        if not isinstance(entry, dict):
            raise FileFormatError(f"{source}: joint terms of {name!r} must be an object")
        missing = [key for key in _TERM_KEYS if key not in entry]
        if missing:
            raise FileFormatError(
                f"{source}: joint terms of {name!r} miss {', '.join(map(repr, missing))}"
            )
        for key in _TERM_KEYS:  # JSON numbers only: not true/false, not "1.5"
            value = entry[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise FileFormatError(
                    f"{source}: {key} of joint {name!r} must be a number, got {value!r}"
                )
        values = {key: float(entry[key]) for key in _TERM_KEYS}
        if not all(math.isfinite(v) for v in values.values()):
            raise FileFormatError(f"{source}: joint terms of {name!r} must be finite")
        out[str(name)] = values
    return out


def read_joint_terms(path: str | Path) -> dict[str, dict[str, float]]:
    """:func:`parse_joint_terms` of a sidecar file."""
    path = Path(path)
    try:
        data = json.loads(decode_utf8(path.read_bytes(), path))
    except (OSError, ValueError, RecursionError) as e:
        raise FileFormatError(f"cannot read joint terms from {path}: {e}") from e
    return parse_joint_terms(data, str(path))


def read_actuated_joints(path: str | Path) -> list[str]:
    """The sidecar's ``actuated_joints`` (joint names); :class:`FileFormatError` if absent
    or not a list of strings."""
    path = Path(path)
    try:
        data = json.loads(decode_utf8(path.read_bytes(), path))
    except (OSError, ValueError, RecursionError) as e:
        raise FileFormatError(f"cannot read actuated joints from {path}: {e}") from e
    names = data.get("actuated_joints") if isinstance(data, dict) else None
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise FileFormatError(f"{path}: 'actuated_joints' must be a list of joint names")
    return names


def write_general_urdf(desc: Any, path: str | Path) -> tuple[Path, Path]:
    """Write the URDF of a general-leg robot and its sidecar beside it (atomically);
    returns both paths."""
    return write_with_sidecar(
        path, lambda: general_urdf_string(desc), lambda n: general_closures_dict(desc, n)
    )


__all__ = [
    "JOINT_TERMS_KEY",
    "URDF_UNBOUNDED",
    "GeneralVisualSizes",
    "general_closures_dict",
    "general_urdf_string",
    "is_general",
    "joint_terms",
    "leg_joint_values",
    "parse_joint_terms",
    "read_actuated_joints",
    "read_joint_terms",
    "write_general_urdf",
]
