"""MJCF of a robot with general three-joint legs (duck-typed as in
:mod:`stewart_pin.formats.general_urdf`).

The same bodies, frames, names and inertials as the general URDF, and what URDF cannot
hold:

- each leg joint is a ``hinge`` (revolute) or ``slide`` (prismatic) about ``z`` of its MDH
  frame, the body placed by the MDH placement (``pos``, ``quat``), with its dynamics:
  ``armature`` = the joint-side armature (rotor inertia reflected through the
  transmission), ``damping`` = viscous + damper coefficients, ``frictionloss`` = the
  Coulomb coefficient (MuJoCo's dry friction is a constraint solved with the others, not
  a smooth ``Fc sign(qdot)`` term: a slipping joint feels ``Fc``, a still one up to
  ``Fc``), ``stiffness`` and ``springref`` = the spring and its rest position, ``range``
  = the limits when both are finite (MuJoCo has no one-sided range: a half-bounded joint
  is written unlimited);
- sites ``leg{i}_tip`` (P_i in frame 3i: the leg's ``tip``) and ``platform_p{i}``, the six
  loops ``<equality><connect>`` with :data:`~stewart_pin.formats.mjcf.LOOP_SOLREF` and
  :data:`~stewart_pin.formats.mjcf.LOOP_SOLIMP`;
- a ``<motor>`` ``leg{i}_motor`` (gear 1: the joint-side effort, N or N m) on each leg's
  actuated joint, in leg order; the transmission ratio and rotor inertia are not
  MuJoCo's (the motor-side effort is the joint-side one divided by the ratio; the rotor
  inertia is in ``armature``);
- ``<option gravity>`` and a ``home`` keyframe (the inverse geometry of the home pose).

MuJoCo's ``qpos`` is the 18 leg joints (leg 1 first, q1i, q2i, q3i) then the platform's
``[p, quat (w, x, y, z)]``; its free-joint velocity ``[v in F0, w in Fp]``.

Bodies MuJoCo refuses are handled as :func:`stewart_pin.formats.mjcf.mujoco_inertials` does
for 6-UPS (:func:`general_mujoco_inertials`): a massless link 1 or 2 gets no body (its
joint goes to the next body, with ``pos`` and ``axis`` such that MuJoCo's sequential
joint motion is the chain's: exact; its visuals are not drawn), a light rod takes a point
mass at P_i (its ``tip``) from the platform (exact), what remains gets MuJoCo's smallest
moments and mass. ``pinocchio_layout=True`` nests the platform, at the identity, in
``base_link`` for Pinocchio's parser and writes the bodies as described.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._io import write_text_atomic
from stewart_pin.formats._xml import MJCF_RGBA, mjcf_body, mjcf_geom, mjcf_inertial, num, vec
from stewart_pin.formats.general_urdf import (
    GeneralVisualSizes,
    joint_placement,
    leg_joint_values,
    next_point,
    robot_size,
    travel,
)
from stewart_pin.formats.mjcf import (
    MujocoInertials,
    closed_loop_mjcf,
    leg_tip_site,
    mujoco_inertials,
    quaternion_wxyz,
)
from stewart_pin.formats.urdf import leg_joint, leg_link


def general_mujoco_inertials(desc: Any) -> MujocoInertials:
    """:func:`stewart_pin.formats.mjcf.mujoco_inertials` for general legs: the rods'
    point masses go to and from P_i, the leg's ``tip`` in frame 3i; the length scale is
    :func:`~stewart_pin.formats.general_urdf.robot_size`."""
    tips = np.array([np.asarray(lg.tip, dtype=float) for lg in desc.legs])
    return mujoco_inertials(desc, tips, robot_size(desc))


def _joint(body: ET.Element, name: str, joint: Any, X: np.ndarray) -> None:
    """A hinge or slide about ``z`` of the joint frame ``X`` (4x4, in the body frame)."""
    attrs = {"name": name, "type": "hinge" if joint.revolute else "slide"}
    if np.any(X[:3, 3] != 0.0):
        attrs["pos"] = vec(X[:3, 3])
    attrs["axis"] = vec(X[:3, 2]) if np.any(X[:3, :3] != np.eye(3)) else "0 0 1"
    if math.isfinite(joint.lower) and math.isfinite(joint.upper):
        attrs["range"] = vec((joint.lower, joint.upper))
    d = joint.dynamics
    terms = {
        "armature": d.total_armature,
        "damping": d.viscous + d.damping,
        "frictionloss": d.coulomb,
        "stiffness": d.stiffness,
    }
    for key, value in terms.items():
        if value != 0.0:
            attrs[key] = num(value)
    if d.stiffness != 0.0:
        attrs["springref"] = num(d.rest_position)
    ET.SubElement(body, "joint", attrs)


def _fromto(body: ET.Element, a: np.ndarray, b: np.ndarray, radius: float, rgba: str) -> None:
    if float(np.linalg.norm(b - a)) <= 1e-9:
        return
    ET.SubElement(
        body,
        "geom",
        type="cylinder",
        fromto=vec(np.r_[a, b]),
        size=num(radius),
        rgba=MJCF_RGBA[rgba],
    )


def _chain(transforms: list[np.ndarray]) -> np.ndarray:
    """The product of 4x4 transforms in order (identity for none)."""
    T = np.eye(4)
    for X in transforms:
        T = T @ X
    return T


def _leg(
    base: ET.Element,
    desc: Any,
    k: int,
    vs: GeneralVisualSizes,
    inertia: np.ndarray,
    has_body: np.ndarray,
    q_home: np.ndarray,
) -> None:
    """Leg k's (0-based) bodies; a link without a body passes its joint to the next body."""
    i = k + 1
    leg = desc.legs[k]
    parent, carried = base, []
    parent_has_body = True
    for j in range(3):
        carried.append(j)
        if not has_body[j]:
            continue
        placements = [joint_placement(desc, k, n) for n in carried]
        T = _chain(placements)
        body = mjcf_body(parent, leg_link(i, j + 1), T[:3, 3], T[:3, :3])
        for m, n in enumerate(carried):
            after = placements[m + 1 :]
            X = np.linalg.inv(_chain(after))
            _joint(body, leg_joint(i, n + 1), leg.joints[n], X)
        mjcf_inertial(body, inertia[j])
        # visuals of this link (those of merged massless links are not drawn)
        _fromto(
            body,
            np.zeros(3),
            next_point(desc, k, j),
            vs.bar_radius,
            "rod" if j == 2 else "cylinder",
        )
        joint = leg.joints[j]
        if joint.revolute:
            h = vs.joint_radius
            _fromto(body, np.array([0, 0, -h]), np.array([0, 0, h]), 0.8 * h, "joint")
        else:
            c = vs.carriage / 2
            mjcf_geom(body, "box", "joint", (c, c, c))
            if len(carried) == 1 and parent_has_body:
                lo, hi = travel(desc, k, j, q_home)
                Tj = joint_placement(desc, k, j)
                z = Tj[:3, 2]
                _fromto(parent, Tj[:3, 3] + lo * z, Tj[:3, 3] + hi * z, vs.rail_radius, "cylinder")
        if j == 2:
            tip = np.asarray(leg.tip, dtype=float)
            mjcf_geom(body, "sphere", "joint", (vs.joint_radius,), tip)
            ET.SubElement(body, "site", name=leg_tip_site(i), pos=vec(tip))
        parent, carried, parent_has_body = body, [], True


def general_mujoco_qpos(desc: Any, pose: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` (25,) at a platform pose 0Tp: the 18 leg joints from the inverse
    geometry (each leg's branch, limits unchecked), then ``[p [m], quat (w, x, y, z)]``."""
    T = np.asarray(pose, dtype=float)
    q_legs = leg_joint_values(desc, T)
    return np.concatenate([q_legs.ravel(), T[:3, 3], quaternion_wxyz(T[:3, :3])])


def general_mjcf_string(desc: Any, pinocchio_layout: bool = False) -> str:
    """The MJCF of a general-leg robot (module docstring); ``pinocchio_layout`` as for
    :func:`stewart_pin.formats.mjcf.mjcf_string`."""
    vs = GeneralVisualSizes.for_robot(desc)
    q_home = leg_joint_values(desc)

    def write_leg(base: ET.Element, k: int, inertia: np.ndarray, has_body: np.ndarray) -> None:
        _leg(base, desc, k, vs, inertia, has_body, q_home)

    layout = "Pinocchio's parser (MuJoCo refuses it)" if pinocchio_layout else "MuJoCo"
    return closed_loop_mjcf(
        desc,
        None if pinocchio_layout else general_mujoco_inertials(desc),
        vs.plate(),
        write_leg,
        [leg_joint(i, leg.actuated) for i, leg in enumerate(desc.legs, start=1)],
        lambda: general_mujoco_qpos(desc, desc.home_pose),
        f"General legs. Layout for {layout}: see stewart_pin/formats/general_mjcf.py. "
        "SI units, angles in rad.",
    )


def write_general_mjcf(desc: Any, path: str | Path, pinocchio_layout: bool = False) -> Path:
    """Write :func:`general_mjcf_string` to ``path`` (atomically); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, general_mjcf_string(desc, pinocchio_layout))
    return path


__all__ = [
    "general_mjcf_string",
    "general_mujoco_inertials",
    "general_mujoco_qpos",
    "write_general_mjcf",
]
