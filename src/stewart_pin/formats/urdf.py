"""URDF writer and the loop-closure sidecar.

The URDF holds the tree: ``base_link``; for each leg i (1..6) the links ``leg{i}_link1..3``
joined by ``leg{i}_q1`` (revolute, at B_i, about the first U-joint axis), ``leg{i}_q2``
(revolute) and ``leg{i}_q3`` (prismatic along the leg, actuated, limits = stroke); and the
``platform`` link, child of ``base_link`` through the ``floating`` joint ``platform_joint``.
Every link frame is the MDH frame of the paper, so the inertials are the description's
Khalil parameters converted exactly (centre of mass and inertia about it).

URDF cannot hold loops: the six closures (origin of frame 3i == P_i on the platform) go in
a JSON sidecar, ``<name>.closures.json``, documented in ``docs/closures.md``::

    {"format": "stewart-pin/closures", "version": 1, "urdf": "<name>.urdf",
     "closures": [{"name": "loop1", "type": "point",
                   "link1": "leg1_link3", "point1": [0, 0, 0],
                   "link2": "platform",   "point2": [x, y, z]}, ...],
     "actuated_joints": ["leg1_q3", ...]}

One writer for every leg architecture: :func:`urdf_string` and :func:`closures_dict`
write the files above for the ideal 6-UPS (a ``RobotDescription`` without legs, or
flagged ``is_ideal_ups``: today's files, byte for byte) and, for any robot carrying six
:class:`~stewart_pin.description.leg_architecture.LegArchitecture` (:func:`is_general`;
duck-typed: ``base_points``, ``leg_base_rotations``, ``platform_points``, ``legs``,
``leg_inertia``, ``platform_inertia``, ``gravity``, ``home_pose``, ``name``: a
``GeneralHexapod``, or a ``RobotDescription`` carrying legs), the tree of its legs' joint
chains with the same names:

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

Their sidecar (``docs/closures.md``) names the six closures ``leg{i}_link3`` at ``tip`` ==
``platform`` at ``P_i``, the actuated joints in leg order, gravity, and under
``"joint_terms"`` every leg joint's terms, those URDF cannot hold (armature, stiffness,
rest position, transmission, true limits) with the others (:func:`parse_joint_terms`,
:func:`read_joint_terms`); and under ``"gravcomp"`` (only when some body has one) each
link's gravity compensation, which URDF cannot hold either (:func:`gravcomp_entry`).
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, decode_utf8
from stewart_pin._io import write_text_atomic
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._safe import check_xml_text
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import FileFormatError, InputError
from stewart_pin.formats._xml import Visual, num, urdf_inertial, urdf_origin, urdf_visual

BASE_LINK = "base_link"
PLATFORM_LINK = "platform"
PLATFORM_JOINT = "platform_joint"
CLOSURE_FORMAT = "stewart-pin/closures"

#: Placeholder actuator limits written into the URDF (the description has none) [N, m/s].
URDF_EFFORT, URDF_VELOCITY = 1.0e6, 10.0


def leg_link(i: int, j: int) -> str:
    """Name of link j (1..3) of leg i (1..6)."""
    return f"leg{i}_link{j}"


def leg_joint(i: int, j: int) -> str:
    """Name of joint q_ji (j = 1..3) of leg i (1..6)."""
    return f"leg{i}_q{j}"


def _joint(
    robot: ET.Element,
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz: Any = (0, 0, 0),
    rpy: Any = (0, 0, 0),
    limits: Any = None,
) -> ET.Element:
    el = ET.SubElement(robot, "joint", name=name, type=kind)
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=child)
    urdf_origin(el, xyz, rpy)
    if kind != "floating":
        ET.SubElement(el, "axis", xyz="0 0 1")
    if limits is not None:
        ET.SubElement(
            el,
            "limit",
            lower=num(limits[0]),
            upper=num(limits[1]),
            effort=num(URDF_EFFORT),
            velocity=num(URDF_VELOCITY),
        )
    return el


def _plane_rpy(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and rpy of a disc through the best-fit plane of ``points``."""
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre)[2][2]
    normal = normal if normal[2] >= 0 else -normal
    x = np.cross([0.0, 1.0, 0.0], normal)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0.0, 0.0])
    R = np.column_stack([x, np.cross(normal, x), normal])
    return centre, pin.rpy.matrixToRpy(R)


def plate_visual(
    points: np.ndarray, vs: VisualSizes, sign: float
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """``(xyz, rpy, radius, length)`` of the disc drawn through ``points`` [m, rad].

    The disc lies on the points' best-fit plane, moved along its normal by ``sign`` (-1
    below, for the base; +1 above, for the platform) so that the joint spheres rest on it.
    """
    centre, rpy = _plane_rpy(points)
    radius = np.linalg.norm(points - centre, axis=1).max() + 2 * vs.joint_radius
    R = pin.rpy.rpyToMatrix(rpy)
    xyz = centre + sign * R[:, 2] * (vs.plate_thickness / 2 + vs.joint_radius)
    return xyz, rpy, float(radius), vs.plate_thickness


def plate_disc(points: np.ndarray, vs: VisualSizes, sign: float, material: str) -> Visual:
    """The disc of :func:`plate_visual` as a cylinder :class:`Visual`."""
    xyz, rpy, radius, length = plate_visual(np.asarray(points, dtype=float), vs, sign)
    return Visual("cylinder", material, xyz, rpy, {"radius": radius, "length": length})


#: The URDF materials (name, rgba).
MATERIALS = (
    ("base_grey", "0.35 0.35 0.38 1"),
    ("cylinder_blue", "0.20 0.40 0.80 1"),
    ("rod_silver", "0.80 0.80 0.82 1"),
    ("joint_dark", "0.15 0.15 0.15 1"),
    ("platform_orange", "0.95 0.55 0.15 1"),
)


def robot_with_base(
    name: str, base_points: np.ndarray, vs: VisualSizes
) -> tuple[ET.Element, ET.Element]:
    """The ``<robot>`` element (``name`` checked by :func:`check_xml_text`) with the
    :data:`MATERIALS`, and its ``base_link`` drawn as the base disc (returned second)."""
    robot = ET.Element("robot", name=check_xml_text(name, "robot name"))
    for material, rgba in MATERIALS:
        ET.SubElement(ET.SubElement(robot, "material", name=material), "color", rgba=rgba)
    base = ET.SubElement(robot, "link", name=BASE_LINK)
    urdf_visual(base, plate_disc(base_points, vs, -1.0, "base_grey"))
    return robot, base


def add_platform(
    robot: ET.Element, params: np.ndarray, points: np.ndarray, vs: VisualSizes
) -> None:
    """The ``platform`` link (Khalil parameters ``params`` in Fp, the platform disc through
    ``points``) and its floating joint to ``base_link``."""
    platform = ET.SubElement(robot, "link", name=PLATFORM_LINK)
    urdf_inertial(platform, np.asarray(params, dtype=float))
    urdf_visual(platform, plate_disc(points, vs, 1.0, "platform_orange"))
    _joint(robot, PLATFORM_JOINT, "floating", BASE_LINK, PLATFORM_LINK)


def joint_limits(desc: RobotDescription) -> np.ndarray:
    """Limits written for q1i, q2i [rad] and q3i [m]: shape (6, 3, 2) ``[lower, upper]``.

    Without ``desc.u_joint_limits``: q1i in [-pi, pi], q2i in [0, pi].
    """
    lim = np.empty((6, 3, 2))
    if desc.u_joint_limits is not None:
        lim[:, :2] = desc.u_joint_limits
    else:
        lim[:, 0], lim[:, 1] = (-np.pi, np.pi), (0.0, np.pi)
    lim[:, 2] = desc.ideal_stroke("the 6-UPS joint limits")
    return lim


@dataclass(frozen=True)
class VisualSizes:
    """Sizes of the simple visuals [m], scaled on the robot."""

    joint_radius: float
    cylinder_radius: float
    rod_radius: float
    body_length: float
    rod_length: float
    plate_thickness: float

    @classmethod
    def for_robot(cls, desc: RobotDescription) -> VisualSizes:
        s = desc.size
        lo, hi = (float(x) for x in desc.ideal_stroke("the 6-UPS URDF"))
        # Cylinder and rod overlap over the whole stroke (together longer than the longest
        # leg) and the rod never pokes out below B_i (shorter than the shortest leg).
        length = min(0.55 * hi, 0.95 * lo)
        return cls(0.05 * s, 0.035 * s, 0.02 * s, 0.55 * hi, length, 0.04 * s)


def urdf_string(desc: RobotDescription) -> str:
    """The URDF of the six-leg tree plus the platform (see the module docstring).

    A robot with general legs (:func:`is_general`) gets the tree of its legs' joint chains
    (module docstring).

    The robot name goes into the ``name`` attribute only, escaped by ElementTree (and
    refused by :class:`InputError` if XML cannot hold it); the comments are fixed text.
    """
    return _form(desc).urdf(desc)


def _ideal_ups_urdf_string(desc: RobotDescription) -> str:
    """The ideal 6-UPS's URDF (:func:`urdf_string`): the paper's joints and frames."""
    vs = VisualSizes.for_robot(desc)
    robot, _ = robot_with_base(desc.name, desc.base_points, vs)

    lim = joint_limits(desc)
    for i in range(1, 7):
        k = i - 1
        links = [ET.SubElement(robot, "link", name=leg_link(i, j)) for j in (1, 2, 3)]
        for link, params in zip(links, desc.leg_inertia[k], strict=True):
            urdf_inertial(link, params)
        urdf_visual(links[0], Visual("sphere", "joint_dark", size={"radius": vs.joint_radius}))
        # The cylinder body runs along -y2 (the leg direction in frame 2i) from B_i.
        body = {"radius": vs.cylinder_radius, "length": vs.body_length}
        body_xyz = (0.0, -vs.body_length / 2, 0.0)
        urdf_visual(
            links[1], Visual("cylinder", "cylinder_blue", body_xyz, (np.pi / 2, 0.0, 0.0), body)
        )
        rod = {"radius": vs.rod_radius, "length": vs.rod_length}
        rod_xyz = (0.0, 0.0, -vs.rod_length / 2)
        urdf_visual(links[2], Visual("cylinder", "rod_silver", rod_xyz, size=rod))
        urdf_visual(links[2], Visual("sphere", "joint_dark", size={"radius": vs.joint_radius}))
        R1 = desc.leg_base_rotations[k]
        _joint(
            robot,
            leg_joint(i, 1),
            "revolute",
            BASE_LINK,
            leg_link(i, 1),
            desc.base_points[k],
            pin.rpy.matrixToRpy(R1),
            lim[k, 0],
        )
        _joint(
            robot,
            leg_joint(i, 2),
            "revolute",
            leg_link(i, 1),
            leg_link(i, 2),
            rpy=(np.pi / 2, 0, 0),
            limits=lim[k, 1],
        )
        _joint(
            robot,
            leg_joint(i, 3),
            "prismatic",
            leg_link(i, 2),
            leg_link(i, 3),
            rpy=(np.pi / 2, 0, 0),
            limits=lim[k, 2],
        )

    add_platform(robot, desc.platform_inertia, desc.platform_points, vs)
    ET.indent(robot)
    return (
        '<?xml version="1.0"?>\n'
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        "<!-- Loop closures (not expressible in URDF): the .closures.json file of the same "
        "name beside this one. -->\n" + ET.tostring(robot, encoding="unicode") + "\n"
    )


def closures_dict(desc: RobotDescription, urdf_name: str | None = None) -> dict[str, Any]:
    """The loop-closure sidecar as a dict (see the module docstring); for general legs
    (:func:`is_general`) with their joint terms."""
    return _form(desc).closures(desc, urdf_name)


def _ideal_ups_closures_dict(desc: RobotDescription, urdf_name: str | None) -> dict[str, Any]:
    """The ideal 6-UPS's sidecar (:func:`closures_dict`): six points, the actuated slides."""
    return {
        "format": CLOSURE_FORMAT,
        "version": 1,
        "urdf": urdf_name or f"{desc.name}.urdf",
        "description": (
            "Point constraints closing the six loops: the origin of point1 in link1 coincides "
            "with point2 in link2 (spherical joints). Coordinates in each link's frame [m]."
        ),
        "closures": [
            {
                "name": f"loop{i}",
                "type": "point",
                "link1": leg_link(i, 3),
                "point1": [0.0, 0.0, 0.0],
                "link2": PLATFORM_LINK,
                "point2": desc.platform_points[i - 1].tolist(),
            }
            for i in range(1, 7)
        ],
        "actuated_joints": [leg_joint(i, 3) for i in range(1, 7)],
        "gravity": desc.gravity.tolist(),
        **home_configuration(desc),
    }


def home_configuration(desc: Any) -> dict[str, Any]:
    """The sidecar's ``home_pose`` (0Tp, 4x4) and ``home_joint_positions`` (leg joint name
    -> value [rad or m] at that pose, each leg's branch): the assembled configuration an
    importer reads back (``stewart_pin.importers``); URDF has no place for it."""
    T = np.asarray(desc.home_pose, dtype=float)
    q = _form(desc).joint_values(desc, T)
    positions = {leg_joint(i + 1, j + 1): float(q[i, j]) for i in range(6) for j in range(3)}
    return {"home_pose": T.tolist(), "home_joint_positions": positions}


def _ideal_ups_joint_values(desc: RobotDescription, pose: Any) -> np.ndarray:
    """The ideal 6-UPS's leg joint values (6, 3) at ``pose`` (its closed-form inverse
    geometry, limits unchecked)."""
    from stewart_pin.kinematics.geometry import inverse_geometry

    return np.asarray(inverse_geometry(desc, pose, check_limits=False))


@dataclass(frozen=True)
class Closure:
    """One point closure read from a sidecar: ``point1`` in ``link1`` == ``point2`` in
    ``link2`` [m]."""

    name: str
    link1: str
    point1: np.ndarray
    link2: str
    point2: np.ndarray


def read_closures(path: str | Path) -> list[Closure]:
    """Read and validate a closure sidecar; raises :class:`FileFormatError` on any defect."""
    return read_sidecar(path)[0]


def read_sidecar(path: str | Path) -> tuple[list[Closure], np.ndarray | None]:
    """The closures of a sidecar and the gravity it records (``None`` when absent) [m/s^2]."""
    path = Path(path)
    try:
        data = json.loads(decode_utf8(path.read_bytes(), path))
    except (OSError, ValueError) as e:  # JSONDecodeError, huge integers
        raise FileFormatError(f"cannot read loop closures {path}: {e}") from e
    except RecursionError:
        raise FileFormatError(f"cannot read loop closures {path}: nested too deeply") from None
    closures = parse_closures(data, str(path))
    if "gravity" not in data:
        return closures, None
    try:
        g = check_array(data["gravity"], (3,), "gravity")
    except InputError as e:
        raise FileFormatError(f"{path}: 'gravity' must be 3 finite numbers [m/s^2]: {e}") from e
    return closures, g


def parse_closures(data: Any, source: str = "closures") -> list[Closure]:
    """Validate a closure dict (the sidecar's content)."""
    if not isinstance(data, dict) or data.get("format") != CLOSURE_FORMAT:
        raise FileFormatError(f"{source}: not a '{CLOSURE_FORMAT}' document")
    if data.get("version") != 1:
        raise FileFormatError(f"{source}: unsupported version {data.get('version')!r}")
    items = data.get("closures")
    if not isinstance(items, list) or not items:
        raise FileFormatError(f"{source}: 'closures' must be a non-empty list")
    out = []
    for n, c in enumerate(items):
        try:
            if c["type"] != "point":
                raise FileFormatError(f"{source}: closure {n} has type {c['type']!r}, not 'point'")
            try:
                p1 = check_array(c["point1"], (3,), "point1")
                p2 = check_array(c["point2"], (3,), "point2")
            except InputError as e:
                raise FileFormatError(
                    f"{source}: closure {n} points must be 3 finite numbers: {e}"
                ) from e
            out.append(Closure(str(c["name"]), str(c["link1"]), p1, str(c["link2"]), p2))
        except (KeyError, TypeError, ValueError) as e:
            raise FileFormatError(f"{source}: closure {n} is malformed: {e!r}") from e
    return out


def write_urdf(desc: RobotDescription, path: str | Path) -> tuple[Path, Path]:
    """Write ``path`` (the URDF) and its closure sidecar beside it; returns both paths.

    Each file is written atomically (a temporary file in the folder, then renamed): an
    error leaves the previous file in place, never a truncated one.
    """
    return write_with_sidecar(path, lambda: urdf_string(desc), lambda n: closures_dict(desc, n))


def write_with_sidecar(
    path: str | Path, urdf: Callable[[], str], closures: Callable[[str], dict[str, Any]]
) -> tuple[Path, Path]:
    """Write ``urdf()`` to ``path`` and ``closures(file name)`` as JSON to the sidecar
    ``<stem>.closures.json`` beside it, each atomically, both computed before either is
    written; returns both paths."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = urdf()
    sidecar = path.with_name(path.name.removesuffix(".urdf") + ".closures.json")
    sidecar_text = json.dumps(closures(path.name), indent=2) + "\n"
    write_text_atomic(path, text)
    write_text_atomic(sidecar, sidecar_text)
    return path, sidecar


#: The URDF attributes that hold numbers (``<origin xyz rpy>``, ``<mass value>``,
#: ``<inertia ixx...>``, ``<limit>``, ``<dynamics>``, ``<safety_controller>``, ``<mimic>``,
#: ``<calibration>``, geometry sizes, colours).
URDF_NUMBER_ATTRIBUTES = frozenset(
    """xyz rpy value ixx ixy ixz iyy iyz izz lower upper effort velocity damping friction
    soft_lower_limit soft_upper_limit k_position k_velocity multiplier offset rising falling
    radius length size scale rgba""".split()
)


def non_finite_number(root: Any) -> str | None:
    """Where a parsed URDF (the ``<robot>`` element of ElementTree or lxml) writes a NaN or
    an infinity (``nan``, ``inf``, ``1e999``) in a number: ``"<tag> of link 'name' (line
    n) has attr='value'"``, or None. Text that is not a number is left to the parser."""
    for top in root:
        if not isinstance(top.tag, str):  # lxml comments and processing instructions
            continue
        owner = f"{top.tag} {top.get('name', '')!r}"
        for el in top.iter():
            if not isinstance(el.tag, str):
                continue
            texts = [(k, v) for k, v in el.attrib.items() if k in URDF_NUMBER_ATTRIBUTES]
            if el.tag == "mechanicalReduction":
                texts.append(("text", el.text or ""))
            for key, value in texts:
                for token in value.split():
                    try:
                        x = float(token)
                    except ValueError:
                        continue
                    if x != x or x in (float("inf"), float("-inf")):
                        line = getattr(el, "sourceline", None)
                        where = f" (line {line})" if line else ""
                        inside = f"<{el.tag}> of {owner}" if el is not top else f"{owner}"
                        what = f"{key}={value!r}" if key != "text" else f"{value.strip()!r}"
                        return f"{inside}{where} has {what}"
    return None


#: The bound written for an unbounded side of a joint's limits [rad or m].
URDF_UNBOUNDED = 1.0e9
#: Key of the joint terms in the sidecar.
JOINT_TERMS_KEY = "joint_terms"


def is_general(desc: Any) -> bool:
    """True for a robot written from its legs' joint chains: it carries ``legs`` and is not
    flagged ``is_ideal_ups`` (a 6-UPS ``RobotDescription`` keeps today's files)."""
    return getattr(desc, "legs", None) is not None and not getattr(desc, "is_ideal_ups", False)


def robot_size(desc: Any) -> float:
    """A length scale [m]: the mean distance of the platform points to their centroid."""
    P = np.asarray(desc.platform_points, float)
    r = float(np.linalg.norm(P - P.mean(0), axis=1).mean())
    return r if r > 0 else float(np.linalg.norm(np.asarray(desc.base_points).std(0)))


@dataclass(frozen=True)
class LegVisualSizes:
    """Sizes of the simple visuals of general legs [m], scaled on the robot."""

    joint_radius: float
    bar_radius: float
    rail_radius: float
    carriage: float
    plate_thickness: float

    @classmethod
    def for_robot(cls, desc: Any) -> LegVisualSizes:
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
    desc: Any, k: int, vs: LegVisualSizes, q_home: np.ndarray
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


def _chain_joint(
    robot: ET.Element, name: str, joint: Any, parent: str, child: str, T: np.ndarray
) -> None:
    """A leg joint: placed at ``T`` (4x4) in its parent link, about z, its limits, damping
    (viscous + damper) and friction (Coulomb)."""
    el = ET.SubElement(robot, "joint", name=name, type=str(joint.kind))
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=child)
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
        el, "dynamics", damping=num(dyn.viscous + dyn.damping), friction=num(dyn.coulomb)
    )


def leg_chains_urdf_string(desc: Any) -> str:
    """The URDF of the tree of a robot's legs' joint chains (see the module docstring):
    what :func:`urdf_string` writes for general legs (:func:`is_general`); it takes any
    robot carrying ``legs``.

    The robot name goes into the ``name`` attribute only, escaped by ElementTree (and
    refused by :class:`~stewart_pin.exceptions.InputError` if XML cannot hold it).
    """
    vs = LegVisualSizes.for_robot(desc)
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
            _chain_joint(robot, leg_joint(i, j + 1), joint, parents[j], leg_link(i, j + 1), T)

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
    legs = desc.joint_legs  # chain legs: n joints each
    for i, leg in enumerate(legs, start=1):
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


def leg_chains_closures_dict(desc: Any, urdf_name: str | None = None) -> dict[str, Any]:
    """The sidecar of the tree :func:`leg_chains_urdf_string` writes, as a dict (format of
    ``docs/closures.md``): what :func:`closures_dict` gives for general legs."""
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
        **gravcomp_entry(desc),
    }


#: Key of the per-body gravity compensation in the sidecar (URDF has no such field).
GRAVCOMP_KEY = "gravcomp"


def gravcomp_entry(desc: Any) -> dict[str, dict[str, float]]:
    """The sidecar's ``gravcomp``: link name -> the fraction of its weight removed, for
    the links (``platform``, ``leg{i}_link{j}``; chain legs: each leg's ``gravcomp``)
    whose factor is not 0; ``{}`` (no key)
    when no body has one, so that such files are unchanged."""
    platform = float(getattr(desc, "platform_gravcomp", 0.0))
    chain = getattr(desc, "chain_legs", None)
    if chain is not None:  # each chain leg's links (n_i factors)
        legs: Any = [leg.gravcomp for leg in chain]
    else:
        legs = np.asarray(getattr(desc, "leg_gravcomp", np.zeros((6, 3))), dtype=float)
    out = {PLATFORM_LINK: platform} if platform else {}
    for i, row in enumerate(legs, start=1):
        for j, c in enumerate(row, start=1):
            if c:
                out[leg_link(i, j)] = float(c)
    return {GRAVCOMP_KEY: out} if out else {}


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


@dataclass(frozen=True)
class _UrdfForm:
    """How one kind of robot is written (each takes its description): the URDF text, the
    sidecar dict (and the URDF's file name), the leg joint values (6, 3) at a pose."""

    urdf: Callable[[Any], str]
    closures: Callable[[Any, str | None], dict[str, Any]]
    joint_values: Callable[[Any, Any], np.ndarray]


#: The ideal 6-UPS (today's files, byte for byte) and every robot carrying leg chains.
_IDEAL_UPS = _UrdfForm(_ideal_ups_urdf_string, _ideal_ups_closures_dict, _ideal_ups_joint_values)
_LEG_CHAINS = _UrdfForm(leg_chains_urdf_string, leg_chains_closures_dict, leg_joint_values)


def chain_legs_urdf_string(desc: Any) -> str:
    """The URDF of the tree of a robot with chain legs (``desc.chain_legs``): links
    ``leg<i>_link<j>`` (their inertials; no visuals but the plates), joints ``leg<i>_q<j>``
    placed by their MDH transforms (revolute or prismatic about z, limits, damping and
    friction), the platform on its floating joint; the loops and the joint terms URDF
    cannot hold in the sidecar (:func:`chain_legs_closures_dict`)."""
    vs = LegVisualSizes.for_robot(desc).plate()
    robot, _ = robot_with_base(desc.name, np.asarray(desc.base_points), vs)
    for i, leg in enumerate(desc.chain_legs, start=1):
        for j, joint in enumerate(leg.joints, start=1):
            link = ET.SubElement(robot, "link", name=leg_link(i, j))
            urdf_inertial(link, np.asarray(leg.inertia[j - 1], dtype=float))
            T = joint.placement()
            if j == 1:
                T0 = np.eye(4)
                T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[i - 1], desc.base_points[i - 1]
                T = T0 @ T
            parent = BASE_LINK if j == 1 else leg_link(i, j - 1)
            _chain_joint(robot, leg_joint(i, j), joint, parent, leg_link(i, j), T)
    add_platform(robot, desc.platform_inertia, np.asarray(desc.platform_points), vs)
    ET.indent(robot)
    return (
        '<?xml version="1.0"?>\n'
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        "<!-- Chain legs. Loop closures (points for balls, frames for welds) and the joint "
        "terms URDF cannot hold: the .closures.json file of the same name beside this "
        "one. -->\n" + ET.tostring(robot, encoding="unicode") + "\n"
    )


def chain_legs_closures_dict(desc: Any, urdf_name: str | None = None) -> dict[str, Any]:
    """The sidecar of :func:`chain_legs_urdf_string`: a ``"point"`` closure per ball leg
    (``point1`` in the leg's last link, ``point2`` in the platform), a ``"frame"`` closure
    per welded leg (``frame1`` / ``frame2``: ``xyz`` [m] and ``rpy`` [rad] of the two
    frames that coincide, in the last link and in the platform), the actuated joints,
    gravity, the joint terms, the home configuration and the links' gravity compensation
    (:func:`gravcomp_entry`)."""
    closures = []
    for i, leg in enumerate(desc.chain_legs, start=1):
        c: dict[str, Any] = {
            "name": f"loop{i}",
            "type": "point" if leg.closure == "ball" else "frame",
        }
        c["link1"], c["link2"] = leg_link(i, leg.n_joints), PLATFORM_LINK
        P = np.asarray(desc.platform_points[i - 1], dtype=float)
        if leg.closure == "ball":
            c["point1"], c["point2"] = leg.tip.tolist(), P.tolist()
        else:
            for key, xyz, R in (
                ("frame1", leg.tip, leg.tip_rotation),
                ("frame2", P, leg.platform_rotation),
            ):
                c[key] = {"xyz": np.asarray(xyz).tolist(), "rpy": pin.rpy.matrixToRpy(R).tolist()}
        closures.append(c)
    legs = desc.chain_legs
    return {
        "format": CLOSURE_FORMAT,
        "version": 1,
        "urdf": urdf_name or f"{desc.name}.urdf",
        "description": (
            "Constraints closing the six loops: a point closure makes point1 in link1 "
            "coincide with point2 in link2 (a ball); a frame closure makes frame1 in link1 "
            "coincide with frame2 in link2 (a weld; xyz [m], rpy [rad] in each link's "
            "frame). joint_terms: each leg joint's limits and dynamics, SI units."
        ),
        "closures": closures,
        "actuated_joints": [leg_joint(i, leg.actuated) for i, leg in enumerate(legs, 1)],
        "gravity": np.asarray(desc.gravity, dtype=float).tolist(),
        "architectures": ["chain"] * 6,
        JOINT_TERMS_KEY: joint_terms(desc),
        **_chain_home_configuration(desc),
        **gravcomp_entry(desc),
    }


def _chain_home_configuration(desc: Any) -> dict[str, Any]:
    """:func:`home_configuration` for chain legs (n_i joints each)."""
    from stewart_pin.kinematics import chain_legs

    T = np.asarray(desc.home_pose, dtype=float)
    qs = chain_legs.inverse_geometry(desc, T[None], check_limits=False)
    positions = {
        leg_joint(i + 1, j + 1): float(q[0, j])
        for i, q in enumerate(qs)
        for j in range(q.shape[1])
    }
    return {"home_pose": T.tolist(), "home_joint_positions": positions}


def _chain_joint_values(desc: Any, pose: Any) -> np.ndarray:
    from stewart_pin.kinematics import chain_legs

    T = np.asarray(pose, dtype=float)
    return chain_legs.padded(chain_legs.inverse_geometry(desc, T[None], False))[0]


_CHAIN_LEGS = _UrdfForm(chain_legs_urdf_string, chain_legs_closures_dict, _chain_joint_values)


def _form(desc: Any) -> _UrdfForm:
    """The writers of ``desc``'s kind (:func:`is_general`): the one place the URDF's choice
    is made (chain legs: ``desc.chain_legs``)."""
    if getattr(desc, "chain_legs", None) is not None:
        return _CHAIN_LEGS
    return _LEG_CHAINS if is_general(desc) else _IDEAL_UPS
