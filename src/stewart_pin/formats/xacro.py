"""The arguments file of the xacro version of the URDF.

``models/urdf/stewart.urdf.xacro`` builds the same URDF as
:func:`stewart_pin.formats.urdf.urdf_string`
(``models/urdf/stewart_leg.xacro`` holds the leg macro) from every number of one robot,
read from a YAML file with ``xacro.load_yaml``. This module writes that file::

    name: "simulator"
    effort: 1000000.0             # URDF placeholder limits [N], [m/s]
    velocity: 10.0
    visual: {joint_radius, cylinder_radius, rod_radius, body_length, rod_length}   # [m]
    base_visual: {xyz, rpy, radius, length}       # the base disc [m, rad]
    legs:                                         # six of them, leg 1 first
      - xyz: B_i in F0 [m]
        rpy: roll-pitch-yaw of frame 1i at q1i = 0 in F0 [rad]
        limits: [[q1 lower, upper], [q2 lower, upper], [q3 lower, upper]]   # [rad], [m]
        links: [{mass, com, inertia: {ixx, ixy, ixz, iyy, iyz, izz}}] * 3
    platform: {mass, com, inertia, visual: {xyz, rpy, radius, length}}

Masses [kg], centres of mass [m] in the link frame and inertias about the centre of mass
[kg m^2] are URDF's ``<inertial>``. Floats are written as their shortest exact repr (as the
URDF writer does), so the rendered URDF carries the very same numbers.

Render it with xacrodoc (``pip install xacrodoc``; the include uses
``$(find stewart_pin_models)``, which xacrodoc resolves by walking up to
``models/package.xml``)::

    xacrodoc models/urdf/stewart.urdf.xacro args_file:=$PWD/models/urdf/simulator.xacro.yaml

Relative ``args_file`` paths are resolved against the current directory by xacrodoc and
against the xacro file's directory by ROS's ``xacro``: pass an absolute path.

A robot with general legs (RUS, PUS, offset UPS, custom: see
:func:`stewart_pin.formats.urdf.is_general`) gets the arguments of
``models/urdf/stewart_general.urdf.xacro`` instead (:func:`general_xacro_args`), which
renders to the document :func:`stewart_pin.formats.urdf.urdf_string` writes for it; a
robot with chain legs (``desc.chain_legs``) those of ``models/urdf/stewart_chain.urdf.xacro``
(:func:`chain_xacro_args`: n joints per leg).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._io import write_text_atomic
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._safe import check_xml_text, yaml_quoted
from stewart_pin.description.inertia import urdf_inertial_from_khalil
from stewart_pin.exceptions import InputTypeError
from stewart_pin.formats._xml import Visual
from stewart_pin.formats.urdf import (
    URDF_EFFORT,
    URDF_VELOCITY,
    LegVisualSizes,
    VisualSizes,
    is_general,
    joint_limits,
    joint_placement,
    leg_joint_values,
    leg_visuals,
    limit_values,
    plate_disc,
    plate_visual,
)

__all__ = [
    "chain_xacro_args",
    "general_xacro_args",
    "write_xacro_args",
    "xacro_args",
    "yaml_string",
]


def _floats(v: Any) -> list[Any]:
    return np.asarray(v, dtype=float).tolist()


def _inertial(params: np.ndarray) -> dict[str, Any]:
    mass, com, I = urdf_inertial_from_khalil(params)
    names = (("ixx", 0, 0), ("ixy", 0, 1), ("ixz", 0, 2), ("iyy", 1, 1), ("iyz", 1, 2))
    inertia = {name: float(I[a, b]) for name, a, b in names}
    inertia["izz"] = float(I[2, 2])
    return {"mass": float(mass), "com": _floats(com), "inertia": inertia}


def _plate(points: np.ndarray, vs: VisualSizes, sign: float) -> dict[str, Any]:
    xyz, rpy, radius, length = plate_visual(points, vs, sign)
    return {"xyz": _floats(xyz), "rpy": _floats(rpy), "radius": radius, "length": length}


def xacro_args(desc: Any) -> dict[str, Any]:
    """Every number of the URDF of ``desc``, as the xacro arguments (see the module
    docstring): plain ``dict`` / ``list`` / ``float`` / ``str``.

    A robot with general legs gets :func:`general_xacro_args` (the arguments of
    ``models/urdf/stewart_general.urdf.xacro``), one with chain legs
    :func:`chain_xacro_args` (``models/urdf/stewart_chain.urdf.xacro``).
    """
    return _form(desc).args(desc)


def _ideal_ups_xacro_args(desc: Any) -> dict[str, Any]:
    """The ideal 6-UPS's arguments (:func:`xacro_args`, ``models/urdf/stewart.urdf.xacro``)."""
    vs = VisualSizes.for_robot(desc)
    lim = joint_limits(desc)
    legs = [
        {
            "xyz": _floats(desc.base_points[k]),
            "rpy": _floats(pin.rpy.matrixToRpy(desc.leg_base_rotations[k])),
            "limits": _floats(lim[k]),
            "links": [_inertial(params) for params in desc.leg_inertia[k]],
        }
        for k in range(6)
    ]
    platform = _inertial(desc.platform_inertia)
    platform["visual"] = _plate(desc.platform_points, vs, 1.0)
    return {
        "name": desc.name,
        "effort": float(URDF_EFFORT),
        "velocity": float(URDF_VELOCITY),
        "visual": {
            "joint_radius": vs.joint_radius,
            "cylinder_radius": vs.cylinder_radius,
            "rod_radius": vs.rod_radius,
            "body_length": vs.body_length,
            "rod_length": vs.rod_length,
        },
        "base_visual": _plate(desc.base_points, vs, -1.0),
        "legs": legs,
        "platform": platform,
    }


# ------------------------------------------------------------------------- general legs
def _visual(visual: Visual) -> dict[str, Any]:
    """A :class:`~stewart_pin.formats._xml.Visual` as the xacro ``visual`` mapping."""
    size = visual.size
    return {
        "shape": visual.shape,
        "material": visual.material,
        "xyz": _floats(visual.xyz),
        "rpy": _floats(visual.rpy),
        "size": {k: _floats(v) if isinstance(v, tuple) else float(v) for k, v in size.items()},
    }


def general_xacro_args(desc: Any) -> dict[str, Any]:
    """The arguments of ``models/urdf/stewart_general.urdf.xacro`` for a robot with general
    legs (duck-typed as :func:`stewart_pin.formats.urdf.is_general`)::

        name: "rus"
        effort: 1000000.0                   # URDF placeholder limits [N], [m/s]
        velocity: 10.0
        base_visuals: [visual, ...]         # the base disc, then rails of first joints
        legs:                               # six of them, leg 1 first
          - joints:                         # three, joint 1 first
              - {type: "revolute" | "prismatic",
                 xyz, rpy,                  # frame j in its parent's frame at zero value:
                                            # MDH Rx(alpha) Tx(d) Rz(theta) Tz(r), preceded
                                            # by [R_i, B_i] for joint 1 [m, rad]
                 limits: [lower, upper],    # [rad] or [m]; unbounded: -+1e9
                 damping, friction}         # viscous + damper, Coulomb [SI]
            links: [{mass, com, inertia, visuals: [visual, ...]}] * 3   # link frames
        platform: {mass, com, inertia, visuals: [visual]}

    with ``visual = {shape: "cylinder" | "sphere" | "box", material, xyz, rpy, size:
    {radius, length} | {radius} | {size: [x, y, z]}}``. Every number is the one
    :func:`~stewart_pin.formats.urdf.urdf_string` writes, so the rendered
    URDF is the same document. The terms URDF cannot hold (armature, stiffness, true
    limits, transmission) stay in the ``.closures.json`` sidecar.
    """
    vs = LegVisualSizes.for_robot(desc)
    q_home = leg_joint_values(desc)
    base_visuals = [_visual(plate_disc(desc.base_points, vs.plate(), -1.0, "base_grey"))]
    legs = []
    for k in range(6):
        leg = desc.legs[k]
        on_base, visuals = leg_visuals(desc, k, vs, q_home)
        base_visuals += [_visual(v) for v in on_base]
        links: list[dict[str, Any]] = []
        joints = []
        for j, joint in enumerate(leg.joints):
            link = _inertial(np.asarray(desc.leg_inertia[k][j], dtype=float))
            link["visuals"] = [_visual(v) for v in visuals[j]]
            links.append(link)
            T = joint_placement(desc, k, j)
            dyn = joint.dynamics
            joints.append(
                {
                    "type": str(joint.kind),
                    "xyz": _floats(T[:3, 3]),
                    "rpy": _floats(pin.rpy.matrixToRpy(T[:3, :3])),
                    "limits": _floats(limit_values(joint.lower, joint.upper)),
                    "damping": float(dyn.viscous + dyn.damping),
                    "friction": float(dyn.coulomb),
                }
            )
        legs.append({"joints": joints, "links": links})
    platform = _inertial(np.asarray(desc.platform_inertia, dtype=float))
    disc = plate_disc(desc.platform_points, vs.plate(), 1.0, "platform_orange")
    platform["visuals"] = [_visual(disc)]
    return {
        "name": check_xml_text(desc.name, "robot name"),
        "effort": float(URDF_EFFORT),
        "velocity": float(URDF_VELOCITY),
        "base_visuals": base_visuals,
        "legs": legs,
        "platform": platform,
    }


# ------------------------------------------------------------------------- chain legs
def chain_xacro_args(desc: Any) -> dict[str, Any]:
    """The arguments of ``models/urdf/stewart_chain.urdf.xacro`` for a robot with chain
    legs (``desc.chain_legs``)::

        name: "welded-ups-0"
        effort: 1000000.0                   # URDF placeholder limits [N], [m/s]
        velocity: 10.0
        closures: ["weld", ...]             # each leg's closure: "ball" or "weld"
        base_visuals: [visual]              # the base disc
        legs:                               # six of them, leg 1 first
          - joints:                         # n_i of them, joint 1 first
              - {type, xyz, rpy, limits, damping, friction}   # as general_xacro_args
            links: [{mass, com, inertia, visuals: []}] * n_i  # link frames
        platform: {mass, com, inertia, visuals: [visual]}

    Every number is the one :func:`~stewart_pin.formats.urdf.chain_legs_urdf_string`
    writes (each joint's MDH placement, preceded by ``[R_i, B_i]`` for joint 1), so the
    rendered URDF is the same document. The loop closures (points, frames) and the terms
    URDF cannot hold stay in the ``.closures.json`` sidecar.
    """
    vs = LegVisualSizes.for_robot(desc).plate()
    legs = []
    for k, leg in enumerate(desc.chain_legs):
        joints, links = [], []
        for j, joint in enumerate(leg.joints):
            link = _inertial(np.asarray(leg.inertia[j], dtype=float))
            link["visuals"] = []
            links.append(link)
            T = joint.placement()
            if j == 0:
                T0 = np.eye(4)
                T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
                T = T0 @ T
            dyn = joint.dynamics
            joints.append(
                {
                    "type": str(joint.kind),
                    "xyz": _floats(T[:3, 3]),
                    "rpy": _floats(pin.rpy.matrixToRpy(T[:3, :3])),
                    "limits": _floats(limit_values(joint.lower, joint.upper)),
                    "damping": float(dyn.viscous + dyn.damping),
                    "friction": float(dyn.coulomb),
                }
            )
        legs.append({"joints": joints, "links": links})
    platform = _inertial(np.asarray(desc.platform_inertia, dtype=float))
    platform["visuals"] = [_visual(plate_disc(desc.platform_points, vs, 1.0, "platform_orange"))]
    return {
        "name": check_xml_text(desc.name, "robot name"),
        "effort": float(URDF_EFFORT),
        "velocity": float(URDF_VELOCITY),
        "closures": [str(leg.closure) for leg in desc.chain_legs],
        "base_visuals": [_visual(plate_disc(desc.base_points, vs, -1.0, "base_grey"))],
        "legs": legs,
        "platform": platform,
    }


# ---------------------------------------------------------------------- a tiny YAML writer
def _scalar(x: Any) -> str:
    if isinstance(x, str):
        return yaml_quoted(x)
    if isinstance(x, bool) or not isinstance(x, float | int):
        raise InputTypeError(f"cannot write {x!r} as a YAML number")
    text = repr(float(x))
    # YAML 1.1 (PyYAML, hence xacro) reads "1e-05" as a string: a float needs a dot.
    if "e" in text and "." not in text:
        text = text.replace("e", ".0e", 1)
    return text


def _flow(x: Any) -> str:
    if isinstance(x, list):
        return "[" + ", ".join(_flow(v) for v in x) + "]"
    return _scalar(x)


def _is_flow(x: Any) -> bool:
    return not isinstance(x, dict | list) or (isinstance(x, list) and all(_is_flow(v) for v in x))


def _block(d: dict[str, Any], indent: int) -> list[str]:
    pad = " " * indent
    lines = []
    for key, value in d.items():
        if _is_flow(value):
            lines.append(f"{pad}{key}: {_flow(value)}")
        elif isinstance(value, dict):
            lines += [f"{pad}{key}:", *_block(value, indent + 2)]
        else:  # a list of mappings
            lines.append(f"{pad}{key}:")
            for item in value:
                item_lines = _block(item, indent + 4)
                item_lines[0] = f"{pad}  - {item_lines[0][indent + 4 :]}"
                lines += item_lines
    return lines


def yaml_string(args: dict[str, Any], header: str = "") -> str:
    """``args`` as block YAML (flow lists of numbers), floats written exactly, strings
    double-quoted with every non-printable or non-ASCII character escaped.

    ``header`` lines are written first, as comments (fixed text: no user text).
    """
    comments = [f"# {line}".rstrip() for line in header.splitlines()]
    return "\n".join([*comments, *_block(args, 0)]) + "\n"


def write_xacro_args(desc: Any, path: str | Path) -> Path:
    """Write :func:`xacro_args` of ``desc`` as YAML to ``path`` (atomically: a temporary
    file in the folder, then renamed); returns the path. The header names the xacro
    source to render: ``stewart.urdf.xacro`` (6-UPS), ``stewart_general.urdf.xacro``
    (general legs) or ``stewart_chain.urdf.xacro`` (chain legs)."""
    path = Path(path)
    source = _form(desc).source
    header = (
        f"xacro arguments of the robot named below, for models/urdf/{source}.\n"
        "Generated by stewart-pin from the robot description; do not edit by hand.\n"
        "SI units: m, rad, kg; inertia [kg m^2] about the centre of mass, in the link frame.\n"
        f"Render: xacrodoc {source} args_file:=<absolute path of this file>"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, yaml_string(xacro_args(desc), header))
    return path


@dataclass(frozen=True)
class _XacroForm:
    """How one kind of robot's xacro arguments are written: the arguments of its
    description, the xacro source (in ``models/urdf/``) they are for."""

    args: Callable[[Any], dict[str, Any]]
    source: str


#: The ideal 6-UPS, every robot carrying leg chains, robots with chain legs.
_IDEAL_UPS = _XacroForm(_ideal_ups_xacro_args, "stewart.urdf.xacro")
_LEG_CHAINS = _XacroForm(general_xacro_args, "stewart_general.urdf.xacro")
_CHAIN_LEGS = _XacroForm(chain_xacro_args, "stewart_chain.urdf.xacro")


def _form(desc: Any) -> _XacroForm:
    """The arguments of ``desc``'s kind (chain legs: ``desc.chain_legs``; else
    :func:`~stewart_pin.formats.urdf.is_general`): the one place the xacro's choice is
    made."""
    if getattr(desc, "chain_legs", None) is not None:
        return _CHAIN_LEGS
    return _LEG_CHAINS if is_general(desc) else _IDEAL_UPS
