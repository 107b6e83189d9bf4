"""MJCF writer: the closed-loop robot for MuJoCo.

The same bodies, frames and inertials as the URDF (:mod:`stewart_pin.urdf`), plus what URDF
cannot hold:

- ``worldbody``: the static ``base_link`` body carrying the six leg chains ``leg{i}_link1..3``
  (``hinge`` ``leg{i}_q1``, ``hinge`` ``leg{i}_q2``, ``slide`` ``leg{i}_q3``; each body frame
  is the leg's MDH frame, so ``<inertial pos mass fullinertia>`` is the description's
  centre of mass and inertia about it), and the ``platform`` body with a
  ``<freejoint name="platform_joint"/>``, placed at the home pose.
- Sites ``leg{i}_tip`` (origin of frame 3i) and ``platform_p{i}`` (``P_i`` in Fp), and the
  six loops as ``<equality><connect site1="leg{i}_tip" site2="platform_p{i}"/>``.
- ``<option gravity>``, a ``<motor>`` on each prismatic joint (``leg{i}_motor``, force [N]),
  and a keyframe ``home``: the inverse geometry of the home pose.

MuJoCo's ``qpos`` is the 18 leg joints (leg 1 first, ``q1i, q2i, q3i``) then the platform
``[p, quat (w, x, y, z)]`` in F0; its free-joint velocity is ``[v in F0, w in Fp]``. The
loops are soft constraints (MuJoCo's default ``solref``/``solimp``): a simulation holds them
only approximately. Geoms are visual only (``contype = conaffinity = 0``).

Pinocchio's MJCF parser (``pin.buildModelAndConstraintsFromMJCF``, Pinocchio 4.1) reads
only the first top-level body of ``<worldbody>`` and ignores ``<option gravity>``, while
MuJoCo accepts a free joint only in a top-level body: no one layout suits both. The default
layout is MuJoCo's; Pinocchio refuses it (it builds the base and legs only, 18 dof, and
then finds the 25-value keyframe too long). ``pinocchio_layout=True`` nests the platform,
at the identity, in ``base_link``: Pinocchio reads the whole closed-loop robot, six point
anchors and the keyframe (it converts the quaternion to its (x, y, z, w)); MuJoCo refuses
that file. Either way, set ``model.gravity`` in Pinocchio yourself.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ._io import write_text_atomic
from ._safe import check_xml_text
from .description import RobotDescription
from .geometry import inverse_geometry
from .inertia import urdf_inertial_from_khalil
from .urdf import (
    BASE_LINK,
    PLATFORM_JOINT,
    PLATFORM_LINK,
    VisualSizes,
    joint_limits,
    leg_joint,
    leg_link,
    plate_visual,
)

__all__ = [
    "leg_tip_site",
    "mjcf_string",
    "mujoco_qpos",
    "platform_site",
    "quaternion_wxyz",
    "write_mjcf",
]

#: Colours of the visual geoms (those of the URDF's materials).
_RGBA = {
    "base": "0.35 0.35 0.38 1",
    "cylinder": "0.20 0.40 0.80 1",
    "rod": "0.80 0.80 0.82 1",
    "joint": "0.15 0.15 0.15 1",
    "platform": "0.95 0.55 0.15 1",
}
_R_X90 = pin.rpy.rpyToMatrix(np.pi / 2, 0.0, 0.0)


def leg_tip_site(i: int) -> str:
    """Name of the site at the origin of frame 3i of leg i (1..6)."""
    return f"leg{i}_tip"


def platform_site(i: int) -> str:
    """Name of the site at P_i (1..6) on the platform."""
    return f"platform_p{i}"


def _num(x: float) -> str:
    return repr(float(x))


def _vec(v: Any) -> str:
    return " ".join(_num(x) for x in np.asarray(v, dtype=float).ravel())


def quaternion_wxyz(R: Any) -> np.ndarray:
    """MuJoCo's ``(w, x, y, z)`` unit quaternion of a rotation matrix, with ``w >= 0``."""
    x, y, z, w = pin.Quaternion(np.asarray(R, dtype=float)).normalized().coeffs()
    q = np.array([w, x, y, z])
    return -q if w < 0 else q


def _body(parent: ET.Element, name: str, pos: Any = None, R: Any = None) -> ET.Element:
    attrs = {"name": name}
    if pos is not None:
        attrs["pos"] = _vec(pos)
    if R is not None:
        attrs["quat"] = _vec(quaternion_wxyz(R))
    return ET.SubElement(parent, "body", attrs)


def _inertial(body: ET.Element, params: np.ndarray) -> None:
    mass, com, I = urdf_inertial_from_khalil(params)
    # MuJoCo's order: Ixx Iyy Izz Ixy Ixz Iyz, about the centre of mass.
    full = (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    ET.SubElement(body, "inertial", pos=_vec(com), mass=_num(mass), fullinertia=_vec(full))


def _geom(body: ET.Element, kind: str, rgba: str, size: Any, pos: Any = None, R: Any = None):
    attrs = {"type": kind, "size": _vec(size)}
    if pos is not None:
        attrs["pos"] = _vec(pos)
    if R is not None:
        attrs["quat"] = _vec(quaternion_wxyz(R))
    attrs["rgba"] = _RGBA[rgba]
    ET.SubElement(body, "geom", attrs)


def _plate(body: ET.Element, points: np.ndarray, vs: VisualSizes, sign: float, rgba: str):
    xyz, rpy, radius, length = plate_visual(points, vs, sign)
    _geom(body, "cylinder", rgba, (radius, length / 2), xyz, pin.rpy.rpyToMatrix(rpy))


def _joint(body: ET.Element, name: str, kind: str, limits: np.ndarray) -> None:
    ET.SubElement(body, "joint", name=name, type=kind, axis="0 0 1", range=_vec(limits))


def _leg(base: ET.Element, desc: RobotDescription, i: int, vs: VisualSizes, lim: np.ndarray):
    k = i - 1
    inertia = desc.leg_inertia[k]
    link1 = _body(base, leg_link(i, 1), desc.base_points[k], desc.leg_base_rotations[k])
    _joint(link1, leg_joint(i, 1), "hinge", lim[k, 0])
    _inertial(link1, inertia[0])
    _geom(link1, "sphere", "joint", (vs.joint_radius,))
    link2 = _body(link1, leg_link(i, 2), R=_R_X90)
    _joint(link2, leg_joint(i, 2), "hinge", lim[k, 1])
    _inertial(link2, inertia[1])
    # The cylinder body runs along -y2 (the leg direction in frame 2i) from B_i.
    size = (vs.cylinder_radius, vs.body_length / 2)
    _geom(link2, "cylinder", "cylinder", size, (0.0, -vs.body_length / 2, 0.0), _R_X90)
    link3 = _body(link2, leg_link(i, 3), R=_R_X90)
    _joint(link3, leg_joint(i, 3), "slide", lim[k, 2])
    _inertial(link3, inertia[2])
    size = (vs.rod_radius, vs.rod_length / 2)
    _geom(link3, "cylinder", "rod", size, (0.0, 0.0, -vs.rod_length / 2))
    _geom(link3, "sphere", "joint", (vs.joint_radius,))
    ET.SubElement(link3, "site", name=leg_tip_site(i), pos="0.0 0.0 0.0")


def mujoco_qpos(desc: RobotDescription, pose: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` (25,) at a platform pose 0Tp (4x4): the 18 leg joints (leg 1
    first, ``q1i, q2i, q3i`` of the default U-joint branch, limits unchecked), then the
    platform's ``[p [m], quat (w, x, y, z)]``."""
    T = np.asarray(pose, dtype=float)
    q_legs = inverse_geometry(desc, T, check_limits=False)
    return np.concatenate([q_legs.ravel(), T[:3, 3], quaternion_wxyz(T[:3, :3])])


def mjcf_string(desc: RobotDescription, pinocchio_layout: bool = False) -> str:
    """The MJCF of the closed-loop robot (see the module docstring).

    Args:
        desc: the robot description.
        pinocchio_layout: nest the platform in ``base_link`` (at the identity) so that
            Pinocchio's parser reads it; MuJoCo refuses such a file.

    The robot name goes into the ``model`` attribute only, escaped by ElementTree (and
    refused by :class:`InputError` if XML cannot hold it); the comments are fixed text.
    """
    vs = VisualSizes.for_robot(desc)
    lim = joint_limits(desc)
    root = ET.Element("mujoco", model=check_xml_text(desc.name, "robot name"))
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    ET.SubElement(root, "option", gravity=_vec(desc.gravity))
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0")
    world = ET.SubElement(root, "worldbody")

    base = _body(world, BASE_LINK)
    # A static body; the explicit (null) inertial is for Pinocchio's parser, which
    # otherwise looks for geoms to compute one from.
    ET.SubElement(base, "inertial", pos="0.0 0.0 0.0", mass="0.0", diaginertia="0.0 0.0 0.0")
    _plate(base, desc.base_points, vs, -1.0, "base")
    for i in range(1, 7):
        _leg(base, desc, i, vs, lim)

    if pinocchio_layout:
        platform = _body(base, PLATFORM_LINK)
    else:
        T = desc.home_pose
        platform = _body(world, PLATFORM_LINK, T[:3, 3], T[:3, :3])
    ET.SubElement(platform, "freejoint", name=PLATFORM_JOINT)
    _inertial(platform, desc.platform_inertia)
    _plate(platform, desc.platform_points, vs, 1.0, "platform")
    for i in range(1, 7):
        ET.SubElement(
            platform, "site", name=platform_site(i), pos=_vec(desc.platform_points[i - 1])
        )

    equality = ET.SubElement(root, "equality")
    for i in range(1, 7):
        ET.SubElement(
            equality, "connect", name=f"loop{i}", site1=leg_tip_site(i), site2=platform_site(i)
        )
    actuator = ET.SubElement(root, "actuator")
    for i in range(1, 7):
        ET.SubElement(actuator, "motor", name=f"leg{i}_motor", joint=leg_joint(i, 3))
    keyframe = ET.SubElement(root, "keyframe")
    ET.SubElement(keyframe, "key", name="home", qpos=_vec(mujoco_qpos(desc, desc.home_pose)))

    ET.indent(root)
    layout = "Pinocchio's parser (MuJoCo refuses it)" if pinocchio_layout else "MuJoCo"
    return (
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        f"<!-- Layout for {layout}: see stewart_pin/mjcf.py. SI units, angles in rad. -->\n"
        + ET.tostring(root, encoding="unicode")
        + "\n"
    )


def write_mjcf(desc: RobotDescription, path: str | Path, pinocchio_layout: bool = False) -> Path:
    """Write :func:`mjcf_string` to ``path`` (atomically: a temporary file in the folder,
    then renamed); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, mjcf_string(desc, pinocchio_layout))
    return path
