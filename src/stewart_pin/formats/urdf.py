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
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, decode_utf8
from stewart_pin._io import write_text_atomic
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

    A robot with general legs (``legs`` and not ``is_ideal_ups``) gets
    :func:`stewart_pin.formats.general_urdf.general_urdf_string`.

    The robot name goes into the ``name`` attribute only, escaped by ElementTree (and
    refused by :class:`InputError` if XML cannot hold it); the comments are fixed text.
    """
    from stewart_pin.formats import general_urdf

    if general_urdf.is_general(desc):
        return general_urdf.general_urdf_string(desc)
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
    :func:`stewart_pin.formats.general_urdf.general_closures_dict`."""
    from stewart_pin.formats import general_urdf

    if general_urdf.is_general(desc):
        return general_urdf.general_closures_dict(desc, urdf_name)
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
    from stewart_pin.formats import general_urdf

    T = np.asarray(desc.home_pose, dtype=float)
    if general_urdf.is_general(desc):
        q = general_urdf.leg_joint_values(desc, T)
    else:
        from stewart_pin.kinematics.geometry import inverse_geometry

        q = np.asarray(inverse_geometry(desc, T, check_limits=False))
    positions = {leg_joint(i + 1, j + 1): float(q[i, j]) for i in range(6) for j in range(3)}
    return {"home_pose": T.tolist(), "home_joint_positions": positions}


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
