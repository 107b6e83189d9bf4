"""MJCF writer: the closed-loop robot for MuJoCo.

The same bodies, frames and inertials as the URDF (:mod:`stewart_pin.formats.urdf`), plus what URDF
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
- ``gravcomp`` on the bodies whose weight is partly removed (the description's
  ``platform_gravcomp``, ``leg_gravcomp``; MuJoCo applies it as a passive force; Pinocchio's
  parser ignores it).

MuJoCo's ``qpos`` is the 18 leg joints (leg 1 first, ``q1i, q2i, q3i``) then the platform
``[p, quat (w, x, y, z)]`` in F0; its free-joint velocity is ``[v in F0, w in Fp]``. MuJoCo's
loops are soft constraints; each ``connect`` carries the stiffest parameters MuJoCo allows
(:data:`LOOP_SOLREF`, :data:`LOOP_SOLIMP`), with which ``mj_forward`` at a consistent state
gives the platform acceleration to about 1e-4 of the larger of it and gravity (against the
exact model; figures in ``docs/closures.md``), where MuJoCo's defaults are 10 % off or
worse. Geoms are visual only (``contype = conaffinity = 0``).

MuJoCo refuses moving bodies without mass or with a vanishing principal moment, which a
description allows (a massless U-joint cross, a point mass, a thin rod): the MuJoCo layout
writes such bodies through :func:`mujoco_inertials`: a massless link 1 or 2 has no body
(its joints go to the next link's body), a light rod takes a point mass at P_i from the
platform (both exact), and what remains gets the smallest principal moments and mass MuJoCo
takes (1e-9 of the robot's scale; an :class:`~stewart_pin.exceptions.ApproximationWarning`
when that is not negligible).

Pinocchio's MJCF parser (``pin.buildModelAndConstraintsFromMJCF``, Pinocchio 4.1) reads
only the first top-level body of ``<worldbody>`` and ignores ``<option gravity>``, while
MuJoCo accepts a free joint only in a top-level body: no one layout suits both. The default
layout is MuJoCo's; Pinocchio refuses it (it builds the base and legs only, 18 dof, and
then finds the 25-value keyframe too long). ``pinocchio_layout=True`` nests the platform,
at the identity, in ``base_link``: Pinocchio reads the whole closed-loop robot, six point
anchors and the keyframe (it converts the quaternion to its (x, y, z, w)); MuJoCo refuses
that file. Either way, set ``model.gravity`` in Pinocchio yourself.

One writer for every leg architecture: a robot with general legs
(:func:`~stewart_pin.formats.urdf.is_general`, duck-typed as there) gets the same bodies,
frames, names and inertials as its URDF, and what URDF cannot hold:

- each leg joint is a ``hinge`` (revolute) or ``slide`` (prismatic) about ``z`` of its MDH
  frame, the body placed by the MDH placement (``pos``, ``quat``), with its dynamics:
  ``armature`` = the joint-side armature (rotor inertia reflected through the
  transmission), ``damping`` = viscous + damper coefficients, ``frictionloss`` = the
  Coulomb coefficient (MuJoCo's dry friction is a constraint solved with the others, not
  a smooth ``Fc sign(qdot)`` term: a slipping joint feels ``Fc``, a still one up to
  ``Fc``), ``stiffness`` and ``springref`` = the spring and its rest position, ``range``
  = the limits when both are finite (MuJoCo has no one-sided range: a half-bounded joint
  is written unlimited);
- the site ``leg{i}_tip`` at P_i in frame 3i (the leg's ``tip``);
- a ``<motor>`` ``leg{i}_motor`` (gear 1: the joint-side effort, N or N m) on each leg's
  actuated joint, in leg order; the transmission ratio and rotor inertia are not
  MuJoCo's (the motor-side effort is the joint-side one divided by the ratio; the rotor
  inertia is in ``armature``);
- the ``home`` keyframe from each leg's branch of the inverse geometry.

Bodies MuJoCo refuses are handled by :func:`mujoco_inertials` as for the 6-UPS, the rods'
point masses at each leg's ``tip``; a link without a body passes its joint to the next
body with ``pos`` and ``axis`` such that MuJoCo's sequential joint motion is the chain's
(exact; its visuals are not drawn).
"""

from __future__ import annotations

import functools
import math
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._io import write_text_atomic
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._safe import check_xml_text
from stewart_pin._so3 import quaternion_wxyz_from_rotation
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import (
    inertia_tensor,
    khalil_from_tensor,
    khalil_from_urdf_inertial,
    urdf_inertial_from_khalil,
)
from stewart_pin.exceptions import ApproximationWarning, UnsupportedArchitectureError
from stewart_pin.formats._xml import MJCF_RGBA, mjcf_body, mjcf_geom, mjcf_inertial, num, vec
from stewart_pin.formats.urdf import (
    BASE_LINK,
    PLATFORM_JOINT,
    PLATFORM_LINK,
    LegVisualSizes,
    VisualSizes,
    is_general,
    joint_limits,
    joint_placement,
    leg_joint,
    leg_joint_values,
    leg_link,
    next_point,
    plate_visual,
    robot_size,
    travel,
)
from stewart_pin.kinematics import chain_legs
from stewart_pin.kinematics.geometry import inverse_geometry

__all__ = [
    "LOOP_SOLIMP",
    "LOOP_SOLREF",
    "MujocoInertials",
    "chain_legs_mjcf_string",
    "chain_legs_mujoco_qpos",
    "leg_chains_mjcf_string",
    "leg_chains_mujoco_qpos",
    "leg_tip_site",
    "mjcf_string",
    "mujoco_inertials",
    "mujoco_qpos",
    "platform_site",
    "quaternion_wxyz",
    "write_mjcf",
]


@functools.cache
def _r_x90() -> np.ndarray:
    """``Rx(pi / 2)`` (Pinocchio's ``rpyToMatrix``; on first use: importing stays light)."""
    return np.asarray(pin.rpy.rpyToMatrix(np.pi / 2, 0.0, 0.0))


#: ``solref`` of the six loop constraints: a time constant far below any step, which
#: MuJoCo (flag ``refsafe``, on by default) raises to two steps (4 ms at its default 2 ms
#: step): the stiffest drift correction the step allows; critically damped.
LOOP_SOLREF = (0.0002, 1.0)
#: ``solimp`` of the loop constraints: impedance 0.9999 (MuJoCo's maximum) at any violation,
#: so the regulariser is 1e-4 of the constraint's approximate inverse inertia.
LOOP_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)

# MuJoCo refuses a moving body whose fullinertia has an eigenvalue below 1e-14 kg m^2 or
# whose mass or principal moments are below 1e-15 (mjEPS, mjMINVAL), and principal moments
# with I1 + I2 < I3; the bounds below keep a margin from those.
_MJ_MIN_INERTIA = 1e-13  # [kg m^2]
_MJ_MIN_MASS = 1e-14  # [kg]
_TRIANGLE_MARGIN = 1e-9
#: A raised principal moment or mass: this fraction of the robot's total mass (times its
#: size squared for a moment), at least the bounds above.
_FLOOR = 1e-9
#: Raised values above this fraction of the robot's scale are warned about.
_DOUBTFUL = 1e-6
#: A rod (link 3) lighter than this fraction of the platform's mass per leg gets a point
#: mass at P_i from the platform (exact), or MuJoCo's soft loops lose accuracy.
_LIGHT_ROD = 0.01


@dataclass(frozen=True)
class MujocoInertials:
    """The bodies and inertials of the MuJoCo layout (:func:`mujoco_inertials`).

    Attributes:
        leg: (6, 3, 10) Khalil parameters of each leg link about the origin of its own
            frame (zeros for a link without a body).
        has_body: (6, 3) bool; ``False``: a massless link 1 or 2 written without a body,
            its joint carried by the next link's body.
        platform: (10,) Khalil parameters of the platform in Fp.
        exact: notes on the changes that leave the closed-loop dynamics as they are.
        approximate: notes on the changes that alter them (principal moments or masses
            raised to what MuJoCo takes).
        doubtful: the approximate changes that may exceed the accuracy stated in
            ``docs/closures.md``: a bound above 1e-6 of the robot's mass (times its size
            squared), or a mass given to a rod or the platform (whose masses set MuJoCo's
            loop regularisation); :func:`mjcf_string` issues them as an
            :class:`ApproximationWarning`.
    """

    leg: np.ndarray
    has_body: np.ndarray
    platform: np.ndarray
    exact: tuple[str, ...]
    approximate: tuple[str, ...]
    doubtful: tuple[str, ...]


def _pseudo_inertia(params: np.ndarray) -> np.ndarray:
    """The 4x4 pseudo-inertia ``[[sum m x x^T, m c], [m c^T, m]]`` (about the frame origin)."""
    I_O = inertia_tensor(params)
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_O) * np.eye(3) - I_O
    J[:3, 3] = J[3, :3] = params[6:9]
    J[3, 3] = params[9]
    return J


def _khalil_from_pseudo(J: np.ndarray) -> np.ndarray:
    J = 0.5 * (J + J.T)
    return khalil_from_tensor(np.trace(J[:3, :3]) * np.eye(3) - J[:3, :3], J[:3, 3], J[3, 3])


def _point_mass_capacity(params: np.ndarray, points: np.ndarray) -> float:
    """The largest mass ``mu`` [kg] that can be taken from the body at each of ``points``
    ((k, 3), in its frame) leaving a physical body: ``J - mu sum q q^T >= 0`` with
    ``q = [p, 1]``; 0 unless the pseudo-inertia J is positive definite."""
    try:
        L = np.linalg.cholesky(_pseudo_inertia(params))
    except np.linalg.LinAlgError:
        return 0.0
    Y = np.linalg.solve(L, np.c_[points, np.ones(len(points))].T)
    return float(1.0 / np.linalg.eigvalsh(Y @ Y.T)[-1])


def _bounded(params: np.ndarray, min_inertia: float, min_mass: float) -> np.ndarray:
    """The parameters with the principal moments about the centre of mass raised to at
    least ``min_inertia`` and to the triangle inequality with a margin, and the mass to at
    least ``min_mass`` (same centre of mass); unchanged if MuJoCo takes them as they are."""
    mass, com, I_c = urdf_inertial_from_khalil(params)
    moments, axes = np.linalg.eigh(I_c)
    raised = np.maximum(moments, min_inertia)
    short = raised[2] * (1.0 + _TRIANGLE_MARGIN) - raised[0] - raised[1]
    if short > 0.0:
        raised[:2] += short / 2
    if mass >= min_mass and np.array_equal(raised, moments):
        return params
    return khalil_from_urdf_inertial(max(mass, min_mass), com, axes @ np.diag(raised) @ axes.T)


def _point_mass(params: np.ndarray, point: np.ndarray, mu: float) -> np.ndarray:
    """The parameters with a point mass ``mu`` [kg] added at ``point`` (in the body frame;
    ``mu`` < 0: taken). At the frame origin only the mass changes (written as such)."""
    if not np.any(point):
        out = params.copy()
        out[9] += mu
        return out
    q = np.r_[point, 1.0]
    return _khalil_from_pseudo(_pseudo_inertia(params) + mu * np.outer(q, q))


def mujoco_inertials(
    desc: Any, tips: np.ndarray | None = None, size: float | None = None
) -> MujocoInertials:
    """The inertials written in the MuJoCo layout, which refuses moving bodies without mass
    or with a vanishing principal moment (massless links, point masses, thin rods, flat
    plates at the triangle inequality). Bodies MuJoCo takes are written as described;
    the others are changed, in this order:

    1. a massless link 1 or 2 gets no body: its joints go to the next link's body (exact);
    2. a rod (link 3) lighter than 1/100 of the platform's mass per leg gets a point mass at
       P_i taken from the platform (exact: the rod's tip is P_i; at most half of what
       leaves the platform physical); a massless platform likewise takes point masses at
       P_i from the rods;
    3. what remains (a massless rod or platform with no donor, a point mass, a thin rod, a
       flat plate) gets its principal moments raised to 1e-9 of the robot's mass times its
       size squared and to the triangle inequality, and its mass to 1e-9 of the robot's,
       at least MuJoCo's bounds (an approximation, reported in ``approximate``; in
       ``doubtful`` too when MuJoCo's bounds exceed 1e-6 of the robot's scale, a tiny
       robot, or when a rod or the platform must be given mass).

    Args:
        desc: the robot (``leg_inertia`` (6, 3, 10) in the link frames, ``platform_inertia``
            (10,) in Fp, ``platform_points`` (6, 3) in Fp, and ``size`` unless given).
        tips: (6, 3) P_i in frame 3i of each rod [m], where a rod's point mass goes; default
            each leg's ``tip`` for general legs (:func:`~stewart_pin.formats.urdf.is_general`),
            the origin of frame 3i for the 6-UPS.
        size: the robot's length scale [m]; default
            :func:`~stewart_pin.formats.urdf.robot_size` for general legs, ``desc.size``
            for the 6-UPS.
    """
    default_tips, default_size = _form(desc).inertial_defaults(desc)
    tips = default_tips if tips is None else tips
    size = default_size if size is None else size
    leg = np.array(desc.leg_inertia, dtype=float)
    platform = np.array(desc.platform_inertia, dtype=float)
    P = np.asarray(desc.platform_points, dtype=float)
    rod_tips = np.zeros((6, 3)) if tips is None else np.asarray(tips, dtype=float)
    exact: list[str] = []
    # a point mass moved between a rod and the platform takes the gravity compensation of
    # the body it goes to: not exact when theirs differ
    gc_platform = float(getattr(desc, "platform_gravcomp", 0.0))
    gc_rods = np.asarray(getattr(desc, "leg_gravcomp", np.zeros((6, 3))), dtype=float)[:, 2]
    moved: list[str] = []

    has_body = np.ones((6, 3), dtype=bool)
    has_body[:, :2] = leg[:, :2, 9] != 0.0
    for k, j in zip(*np.nonzero(~has_body), strict=True):
        exact.append(f"leg {k + 1} link {j + 1} is massless: its joint is on the next link")

    light = leg[:, 2, 9] < _LIGHT_ROD * platform[9] / 6
    if light.any():
        points = P[light]
        mu = 0.5 * _point_mass_capacity(platform, points)
        if mu > 0.0:
            q = np.c_[points, np.ones(len(points))]
            platform = _khalil_from_pseudo(_pseudo_inertia(platform) - mu * q.T @ q)
            for k in np.nonzero(light)[0]:
                leg[k, 2] = _point_mass(leg[k, 2], rod_tips[k], mu)
            legs = ", ".join(str(k + 1) for k in np.nonzero(light)[0])
            exact.append(f"the rods of legs {legs} carry {mu:.6g} kg at P_i from the platform")
            moved += [
                f"rod {k + 1}: {mu:.6g} kg from the platform, its gravity compensation "
                f"{gc_platform:g} -> {gc_rods[k]:g}"
                for k in np.nonzero(light)[0]
                if gc_rods[k] != gc_platform
            ]
    m_total = platform[9] + leg[has_body, 9].sum()
    min_mass = max(_FLOOR * m_total, _MJ_MIN_MASS)
    if platform[9] < min_mass:
        J = _pseudo_inertia(platform)
        for k in range(6):
            mu = 0.5 * _point_mass_capacity(leg[k, 2], rod_tips[k][None, :])
            if mu > 0.0:
                leg[k, 2] = _point_mass(leg[k, 2], rod_tips[k], -mu)
                q = np.r_[P[k], 1.0]
                J += mu * np.outer(q, q)
                exact.append(f"the platform carries {mu:.6g} kg at P_{k + 1} from rod {k + 1}")
                if gc_rods[k] != gc_platform:
                    moved.append(
                        f"platform: {mu:.6g} kg from rod {k + 1}, its gravity compensation "
                        f"{gc_rods[k]:g} -> {gc_platform:g}"
                    )
        platform = _khalil_from_pseudo(J)

    scale = float(desc.size if size is None else size)
    min_inertia = max(_FLOOR * m_total * scale**2, _MJ_MIN_INERTIA)
    # MuJoCo's absolute bounds above a millionth of the robot's own scale (a tiny robot).
    too_small = min_inertia > _DOUBTFUL * m_total * scale**2 or min_mass > _DOUBTFUL * m_total
    approximate: list[str] = list(moved)
    doubtful: list[str] = list(moved)
    bodies = [
        (f"leg {k + 1} link {j + 1}", leg[k, j])
        for k, j in zip(*np.nonzero(has_body), strict=True)
    ]
    for name, params in [*bodies, ("platform", platform)]:
        bounded = _bounded(params, min_inertia, min_mass)
        if bounded is params:
            continue
        note = (
            f"{name}: mass {params[9]:.6g} -> {bounded[9]:.6g} kg, principal moments "
            f"{_moments(params)} -> {_moments(bounded)} kg m^2"
        )
        approximate.append(note)
        in_loop = name == "platform" or name.endswith("link 3")
        if too_small or (in_loop and bounded[9] != params[9]):
            doubtful.append(note)
        params[:] = bounded
    return MujocoInertials(
        leg, has_body, platform, tuple(exact), tuple(approximate), tuple(doubtful)
    )


def _moments(params: np.ndarray) -> str:
    moments = np.linalg.eigvalsh(urdf_inertial_from_khalil(params)[2])
    return "[" + ", ".join(f"{x:.3g}" for x in moments) + "]"


def leg_tip_site(i: int) -> str:
    """Name of the site at the origin of frame 3i of leg i (1..6)."""
    return f"leg{i}_tip"


def platform_site(i: int) -> str:
    """Name of the site at P_i (1..6) on the platform."""
    return f"platform_p{i}"


#: MuJoCo's ``(w, x, y, z)`` unit quaternion of a rotation matrix, with ``w >= 0``.
quaternion_wxyz = quaternion_wxyz_from_rotation


def plate_geom(
    body: ET.Element, points: np.ndarray, vs: VisualSizes, sign: float, rgba: str
) -> None:
    """The disc of :func:`stewart_pin.formats.urdf.plate_visual` as a cylinder geom."""
    xyz, rpy, radius, length = plate_visual(points, vs, sign)
    mjcf_geom(body, "cylinder", rgba, (radius, length / 2), xyz, pin.rpy.rpyToMatrix(rpy))


def _joint(body: ET.Element, name: str, kind: str, limits: np.ndarray, axis: Any = None) -> None:
    axis = "0 0 1" if axis is None else vec(axis)
    ET.SubElement(body, "joint", name=name, type=kind, axis=axis, range=vec(limits))


def _leg(
    base: ET.Element,
    desc: RobotDescription,
    i: int,
    vs: VisualSizes,
    lim: np.ndarray,
    inertia: np.ndarray,
    has_body: np.ndarray,
) -> None:
    """Leg i's bodies. A link without a body (``has_body`` False) passes its joint on to
    the next body, whose frame at zero joint values is then the product ``X`` of the fixed
    rotations before each joint it carries (``leg_base_rotations`` before q1 at B_i,
    ``R_X90`` before q2 and q3), and joint n's axis there is ``S_n^T z``, with ``S_n`` the
    product of the fixed rotations after it (MuJoCo turns a body's joints in order, each
    about its axis in the frame the previous ones left; all pass through B_i, the slide
    last)."""
    k = i - 1
    kinds = ("hinge", "hinge", "slide")
    parent, carried = base, []
    for j in range(3):
        carried.append(j)
        if not has_body[j]:
            continue
        fixed = [desc.leg_base_rotations[k] if n == 0 else _r_x90() for n in carried]
        pos = desc.base_points[k] if carried[0] == 0 else None
        X = np.linalg.multi_dot([np.eye(3), *fixed])
        body = mjcf_body(parent, leg_link(i, j + 1), pos, fixed[0] if len(fixed) == 1 else X)
        for m, n in enumerate(carried):
            after = fixed[m + 1 :]
            axis = None if not after else np.linalg.multi_dot([np.eye(3), *after]).T[:, 2]
            _joint(body, leg_joint(i, n + 1), kinds[n], lim[k, n], axis)
        mjcf_inertial(body, inertia[j])
        if 0 in carried and j < 2:  # the U-joint sphere at B_i (not on the sliding rod)
            mjcf_geom(body, "sphere", "joint", (vs.joint_radius,))
        if j == 1:
            # The cylinder body runs along -y2 (the leg direction in frame 2i) from B_i.
            size = (vs.cylinder_radius, vs.body_length / 2)
            mjcf_geom(
                body, "cylinder", "cylinder", size, (0.0, -vs.body_length / 2, 0.0), _r_x90()
            )
        if j == 2:
            size = (vs.rod_radius, vs.rod_length / 2)
            mjcf_geom(body, "cylinder", "rod", size, (0.0, 0.0, -vs.rod_length / 2))
            mjcf_geom(body, "sphere", "joint", (vs.joint_radius,))
            ET.SubElement(body, "site", name=leg_tip_site(i), pos="0.0 0.0 0.0")
        parent, carried = body, []


def mujoco_qpos(desc: RobotDescription, pose: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` (25,) at a platform pose 0Tp (4x4): the 18 leg joints (leg 1
    first, ``q1i, q2i, q3i`` of the default U-joint branch, limits unchecked), then the
    platform's ``[p [m], quat (w, x, y, z)]``. General legs: each leg's branch."""
    return _form(desc).qpos(desc, pose)


def _ideal_ups_mujoco_qpos(desc: RobotDescription, pose: Any) -> np.ndarray:
    """The ideal 6-UPS's ``qpos`` (:func:`mujoco_qpos`): its closed-form inverse geometry."""
    T = np.asarray(pose, dtype=float)
    q_legs = inverse_geometry(desc, T, check_limits=False)
    return np.concatenate([q_legs.ravel(), T[:3, 3], quaternion_wxyz(T[:3, :3])])


def mjcf_string(desc: RobotDescription, pinocchio_layout: bool = False) -> str:
    """The MJCF of the closed-loop robot (see the module docstring).

    Args:
        desc: the robot description.
        pinocchio_layout: nest the platform in ``base_link`` (at the identity) so that
            Pinocchio's parser reads it; MuJoCo refuses such a file.

    A robot with general legs (:func:`~stewart_pin.formats.urdf.is_general`) gets its
    legs' joint chains (module docstring).

    The robot name goes into the ``model`` attribute only, escaped by ElementTree (and
    refused by :class:`InputError` if XML cannot hold it); the comments are fixed text.
    """
    return _form(desc).mjcf(desc, pinocchio_layout)


def _ideal_ups_mjcf_string(desc: RobotDescription, pinocchio_layout: bool) -> str:
    """The ideal 6-UPS's MJCF (:func:`mjcf_string`): the paper's joints and frames."""
    vs = VisualSizes.for_robot(desc)
    lim = joint_limits(desc)

    def write_leg(base: ET.Element, k: int, inertia: np.ndarray, has_body: np.ndarray) -> None:
        _leg(base, desc, k + 1, vs, lim, inertia, has_body)

    return closed_loop_mjcf(
        desc,
        None if pinocchio_layout else mujoco_inertials(desc),
        vs,
        write_leg,
        [leg_joint(i, 3) for i in range(1, 7)],
        lambda: mujoco_qpos(desc, desc.home_pose),
        "Layout for "
        + ("Pinocchio's parser (MuJoCo refuses it)" if pinocchio_layout else "MuJoCo")
        + ": see stewart_pin/mjcf.py. SI units, angles in rad.",
    )


def closed_loop_mjcf(
    desc: Any,
    inertials: MujocoInertials | None,
    plate_sizes: VisualSizes,
    write_leg: Callable[[ET.Element, int, np.ndarray, np.ndarray], None],
    motor_joints: Sequence[str],
    home_qpos: Callable[[], np.ndarray],
    comment: str,
) -> str:
    """The MJCF document shared by the 6-UPS and general-leg writers: ``<compiler>``,
    ``<option gravity>``, the static ``base_link`` (null inertial, base disc) carrying the
    legs that ``write_leg(base, k, inertia (3, 10), has_body (3,))`` writes for k = 0..5,
    the ``platform`` with its free joint, inertial, disc and sites ``platform_p{i}``, the
    six ``connect`` loops, a motor on each of ``motor_joints`` and the ``home`` keyframe
    (``home_qpos()``), after a fixed header and the ``comment`` line (fixed text).

    ``inertials``: the MuJoCo layout's bodies (:func:`mujoco_inertials`), whose doubtful
    changes are warned about (:class:`ApproximationWarning`); ``None``: Pinocchio's
    layout (the platform nested, at the identity, in ``base_link``; the bodies as
    described).
    """
    if inertials is None:  # Pinocchio takes massless bodies: the description as it is
        leg_inertia = np.asarray(desc.leg_inertia, dtype=float)
        has_body = np.ones((6, 3), dtype=bool)
        platform_inertia = np.asarray(desc.platform_inertia, dtype=float)
    else:
        leg_inertia, has_body = inertials.leg, inertials.has_body
        platform_inertia = inertials.platform
        if inertials.doubtful:
            warnings.warn(
                f"robot {desc.name!r}: MuJoCo cannot hold some bodies as described, and the "
                f"MJCF changes them enough to exceed the accuracy stated in docs/closures.md: "
                f"{'; '.join(inertials.doubtful)}",
                ApproximationWarning,
                stacklevel=3,
            )
    root = ET.Element("mujoco", model=check_xml_text(desc.name, "robot name"))
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    ET.SubElement(root, "option", gravity=vec(desc.gravity))
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0")
    world = ET.SubElement(root, "worldbody")

    base = mjcf_body(world, BASE_LINK)
    # A static body; the explicit (null) inertial is for Pinocchio's parser, which
    # otherwise looks for geoms to compute one from.
    ET.SubElement(base, "inertial", pos="0.0 0.0 0.0", mass="0.0", diaginertia="0.0 0.0 0.0")
    plate_geom(base, np.asarray(desc.base_points, dtype=float), plate_sizes, -1.0, "base")
    for k in range(6):
        write_leg(base, k, leg_inertia[k], has_body[k])

    if inertials is None:
        platform = mjcf_body(base, PLATFORM_LINK)
    else:
        T = np.asarray(desc.home_pose, dtype=float)
        platform = mjcf_body(world, PLATFORM_LINK, T[:3, 3], T[:3, :3])
    ET.SubElement(platform, "freejoint", name=PLATFORM_JOINT)
    mjcf_inertial(platform, platform_inertia)
    gravcomp(platform, getattr(desc, "platform_gravcomp", 0.0))
    points = np.asarray(desc.platform_points, dtype=float)
    plate_geom(platform, points, plate_sizes, 1.0, "platform")
    for i in range(1, 7):
        ET.SubElement(platform, "site", name=platform_site(i), pos=vec(points[i - 1]))

    equality = ET.SubElement(root, "equality")
    for i in range(1, 7):
        ET.SubElement(
            equality,
            "connect",
            name=f"loop{i}",
            site1=leg_tip_site(i),
            site2=platform_site(i),
            solref=vec(LOOP_SOLREF),
            solimp=vec(LOOP_SOLIMP),
        )
    actuator = ET.SubElement(root, "actuator")
    for i, joint in enumerate(motor_joints, start=1):
        ET.SubElement(actuator, "motor", name=f"leg{i}_motor", joint=joint)
    keyframe = ET.SubElement(root, "keyframe")
    ET.SubElement(keyframe, "key", name="home", qpos=vec(home_qpos()))

    ET.indent(root)
    return (
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        f"<!-- {comment} -->\n" + ET.tostring(root, encoding="unicode") + "\n"
    )


def _chain_joint(body: ET.Element, name: str, joint: Any, X: np.ndarray) -> None:
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


def gravcomp(body: ET.Element, c: float) -> None:
    """MuJoCo's ``gravcomp`` of ``body``: the fraction ``c`` of its weight removed (the
    description's ``platform_gravcomp`` / ``leg_gravcomp``; written only when not 0)."""
    if c:
        body.set("gravcomp", repr(float(c)))


def _chain_leg(
    base: ET.Element,
    desc: Any,
    k: int,
    vs: LegVisualSizes,
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
            _chain_joint(body, leg_joint(i, n + 1), leg.joints[n], X)
        mjcf_inertial(body, inertia[j])
        gravcomp(body, desc.leg_gravcomp[k, j])
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


def leg_chains_mujoco_qpos(desc: Any, pose: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` (25,) of :func:`leg_chains_mjcf_string` at a platform pose 0Tp:
    the 18 leg joints from the inverse geometry (each leg's branch, limits unchecked), then
    ``[p [m], quat (w, x, y, z)]``."""
    T = np.asarray(pose, dtype=float)
    q_legs = leg_joint_values(desc, T)
    return np.concatenate([q_legs.ravel(), T[:3, 3], quaternion_wxyz(T[:3, :3])])


def leg_chains_mjcf_string(desc: Any, pinocchio_layout: bool = False) -> str:
    """The MJCF of a robot's legs' joint chains (module docstring): what :func:`mjcf_string`
    writes for general legs; ``pinocchio_layout`` as there."""
    vs = LegVisualSizes.for_robot(desc)
    q_home = leg_joint_values(desc)

    def write_leg(base: ET.Element, k: int, inertia: np.ndarray, has_body: np.ndarray) -> None:
        _chain_leg(base, desc, k, vs, inertia, has_body, q_home)

    layout = "Pinocchio's parser (MuJoCo refuses it)" if pinocchio_layout else "MuJoCo"
    return closed_loop_mjcf(
        desc,
        None if pinocchio_layout else mujoco_inertials(desc),
        vs.plate(),
        write_leg,
        [leg_joint(i, leg.actuated) for i, leg in enumerate(desc.legs, start=1)],
        lambda: leg_chains_mujoco_qpos(desc, desc.home_pose),
        f"General legs. Layout for {layout}: see stewart_pin/formats/mjcf.py. "
        "SI units, angles in rad.",
    )


def chain_legs_mujoco_qpos(desc: Any, pose: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` of :func:`chain_legs_mjcf_string` at a platform pose 0Tp: every
    leg's joints (leg by leg, from the inverse geometry, limits unchecked), then ``[p [m],
    quat (w, x, y, z)]``."""
    T = np.asarray(pose, dtype=float)
    qs = chain_legs.inverse_geometry(desc, T[None], check_limits=False)
    return np.concatenate([*(q[0] for q in qs), T[:3, 3], quaternion_wxyz(T[:3, :3])])


def chain_legs_mjcf_string(desc: Any, pinocchio_layout: bool = False) -> str:
    """The MJCF of a robot with chain legs (``desc.chain_legs``): each leg's links as nested
    bodies (body j at joint j's frame at q = 0, the hinge or slide about its z, the joint
    terms as :func:`mjcf_string` writes them, link j's inertial), sites ``leg{i}_tip`` (the
    ball centre or the attachment frame) and ``platform_p{i}`` (``P_i``, with the platform
    attachment's orientation for a weld), the loops as ``<connect>`` (ball) or ``<weld>``
    (weld: the two sites' frames coincide) equalities, a motor on each actuated joint and
    the ``home`` keyframe, ``gravcomp`` on the bodies whose weight is partly removed (each
    leg's ``gravcomp``, ``platform_gravcomp``). Only MuJoCo's layout (``pinocchio_layout``
    refused)."""
    if pinocchio_layout:
        raise UnsupportedArchitectureError(
            "the Pinocchio layout of the MJCF is not written for chain legs (Pinocchio's "
            "MJCF parser reads no <weld>); write MuJoCo's layout",
            "pinocchio_layout",
            "chain",
        )
    legs = desc.chain_legs
    root = ET.Element("mujoco", model=check_xml_text(desc.name, "robot name"))
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    ET.SubElement(root, "option", gravity=vec(desc.gravity))
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0")
    world = ET.SubElement(root, "worldbody")
    base = mjcf_body(world, BASE_LINK)
    ET.SubElement(base, "inertial", pos="0.0 0.0 0.0", mass="0.0", diaginertia="0.0 0.0 0.0")
    radius = 0.02 * robot_size(desc)
    for k, leg in enumerate(legs):
        parent = base
        for j, joint in enumerate(leg.joints):
            X = joint.placement()
            if j == 0:
                T0 = np.eye(4)
                T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
                X = T0 @ X
            body = mjcf_body(parent, leg_link(k + 1, j + 1), X[:3, 3], X[:3, :3])
            _chain_joint(body, leg_joint(k + 1, j + 1), joint, np.eye(4))
            mjcf_inertial(body, leg.inertia[j])
            gravcomp(body, leg.gravcomp[j])
            mjcf_geom(body, "sphere", "joint", (radius,))
            parent = body
        site = {"name": leg_tip_site(k + 1), "pos": vec(leg.tip)}
        if leg.closure == "weld":
            site["quat"] = vec(quaternion_wxyz(leg.tip_rotation))
        ET.SubElement(parent, "site", site)
    T = np.asarray(desc.home_pose, dtype=float)
    platform = mjcf_body(world, PLATFORM_LINK, T[:3, 3], T[:3, :3])
    ET.SubElement(platform, "freejoint", name=PLATFORM_JOINT)
    mjcf_inertial(platform, desc.platform_inertia)
    gravcomp(platform, desc.platform_gravcomp)
    for k, leg in enumerate(legs):
        site = {"name": platform_site(k + 1), "pos": vec(desc.platform_points[k])}
        if leg.closure == "weld":
            site["quat"] = vec(quaternion_wxyz(leg.platform_rotation))
        ET.SubElement(platform, "site", site)
    equality = ET.SubElement(root, "equality")
    for k, leg in enumerate(legs):
        ET.SubElement(
            equality,
            "weld" if leg.closure == "weld" else "connect",
            name=f"loop{k + 1}",
            site1=leg_tip_site(k + 1),
            site2=platform_site(k + 1),
            solref=vec(LOOP_SOLREF),
            solimp=vec(LOOP_SOLIMP),
        )
    actuator = ET.SubElement(root, "actuator")
    for k, leg in enumerate(legs):
        ET.SubElement(
            actuator, "motor", name=f"leg{k + 1}_motor", joint=leg_joint(k + 1, leg.actuated)
        )
    keyframe = ET.SubElement(root, "keyframe")
    ET.SubElement(keyframe, "key", name="home", qpos=vec(chain_legs_mujoco_qpos(desc, T)))
    ET.indent(root)
    return (
        "<!-- Generated by stewart-pin from the robot description; do not edit by hand. -->\n"
        "<!-- Chain legs: ball loops as <connect>, welds as <weld> between the sites "
        "leg<i>_tip and platform_p<i>. SI units, angles in rad. -->\n"
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


@dataclass(frozen=True)
class _MjcfForm:
    """How one kind of robot is written (each takes its description): the MJCF text (and
    ``pinocchio_layout``), MuJoCo's ``qpos`` (25,) at a pose."""

    mjcf: Callable[[Any, bool], str]
    qpos: Callable[[Any, Any], np.ndarray]
    #: :func:`mujoco_inertials`'s defaults ``(tips, size)`` (``None``: its own).
    inertial_defaults: Callable[[Any], tuple[np.ndarray | None, float | None]]


def _no_inertial_defaults(desc: Any) -> tuple[np.ndarray | None, float | None]:
    """The 6-UPS: the rods' point masses at the origin of frame 3i, ``desc.size``."""
    return None, None


def _leg_chains_inertial_defaults(desc: Any) -> tuple[np.ndarray | None, float | None]:
    """Leg chains: each leg's ``tip``, :func:`~stewart_pin.formats.urdf.robot_size`."""
    return np.array([np.asarray(lg.tip, dtype=float) for lg in desc.legs]), robot_size(desc)


#: The ideal 6-UPS (today's files, byte for byte) and every robot carrying leg chains.
_IDEAL_UPS = _MjcfForm(_ideal_ups_mjcf_string, _ideal_ups_mujoco_qpos, _no_inertial_defaults)
_LEG_CHAINS = _MjcfForm(
    leg_chains_mjcf_string, leg_chains_mujoco_qpos, _leg_chains_inertial_defaults
)
_CHAIN_LEGS = _MjcfForm(chain_legs_mjcf_string, chain_legs_mujoco_qpos, _no_inertial_defaults)


def _form(desc: Any) -> _MjcfForm:
    """The writers of ``desc``'s kind (:func:`~stewart_pin.formats.urdf.is_general`): the
    one place the MJCF's choice is made (``mujoco_inertials``' defaults included)."""
    if getattr(desc, "chain_legs", None) is not None:
        return _CHAIN_LEGS
    return _LEG_CHAINS if is_general(desc) else _IDEAL_UPS
