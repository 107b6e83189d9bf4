"""The canonical modified-DH form of a leg, chosen from its joint axes alone.

The modified-DH parameters of a chain are not unique: frame 0i (``R_i``, ``B_i``) is free,
and so is where each frame sits on its axis when two axes are parallel, where a prismatic
joint's line runs (only its direction moves the leg), and how frame 3i is turned about
its axis. An importer sees joint axes, not frames, so it places them by these rules (all
at the zero configuration, every joint value 0, in F0; ``z_j`` is joint j's axis with the
file's positive direction, so joint values mean what they mean in the file):

0. Two consecutive axes within :data:`PARALLEL_TOLERANCE` of parallel are made parallel
   (the second turned onto the first).
1. A prismatic joint's line is placed through a point of the next line: joint 3's
   through the spherical-joint centre P_i (the tip at q = 0), joint 2's through the point
   ``c_3`` of line 3 nearest P_i, joint 1's through origin ``o_2``.
2. Frames 1i, 2i: ``x_j`` is the common normal of lines j and j+1,
   ``x_j = (z_j x z_{j+1}) / |z_j x z_{j+1}|`` (so ``alpha_{j+1}`` is in (0, pi)), and the
   origin ``o_j`` is its foot on line j; frame j+1's origin on line j+1 is the other foot
   for j + 1 = 3 (``r_3 = 0``). Parallel lines (``|z_j x z_{j+1}| <=``
   :data:`PARALLEL_TOLERANCE`): ``o_{j+1}`` is fixed first (``o_3 = c_3``), ``o_j`` is its
   projection on line j (``r_{j+1} = 0``), ``x_j`` points from line j to line j+1
   (``d_{j+1} > 0``, ``alpha_{j+1}`` 0 or pi). Two joints on one line are refused.
3. Frame 3i: ``x_3`` points from ``o_3`` to P_i across axis 3 (P_i's component along
   ``x_3`` is positive, along ``y_3`` zero); when P_i is on axis 3 (a prismatic joint 3),
   ``x_3 = x_2`` (``theta_3 = 0``).
4. Frame 0i is frame 1i at q1 = 0: joint 1 has ``alpha_1 = d_1 = theta_1 = r_1 = 0``,
   ``R_i = [x_1, z_1 x x_1, z_1]`` and ``B_i = o_1``.

Parameters within :data:`SNAP` of 0, ±pi/2 or pi (angles, rad) or of 0 (lengths, relative
to the robot's size) are set to those values, so the structure checks of the named
architectures (``ups``: ``theta_2 = r_2 = 0``...) see exact zeros.

The paper's 6-UPS leg, the builders ``ups``, ``ups_offset``, ``rus`` and ``pus`` (with
``rail_tilt = 0``) are canonical: so are the presets ``simulator``, ``desktop``, ``paper``,
``random-<seed>``, ``ups-offset``, ``rus``, ``pus``, ``random-ups-<seed>`` and
``random-ups-offset-<seed>``. The random ``rus``, ``pus`` and ``custom`` robots perturb
joint 1 (and the offsets of joint 2) away from it: :func:`canonical_description` gives the
same robot in canonical form (same joint values, limits, joint dynamics and closed-loop
dynamics; each link's ten inertial parameters re-expressed in its new frame).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from stewart_pin.description.leg_architecture import (
    PRISMATIC,
    Joint,
    LegArchitecture,
    mdh_transform,
)
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.description.robot_description import RobotDescription
from stewart_pin.exceptions import ArchitectureError

#: ``|z_j x z_{j+1}|`` (the sine of their angle) at or below which two joint axes are made
#: parallel: the frames of the modified-DH form of two axes at an angle ``delta`` lie about
#: ``1 / delta`` times the robot's size away, where a link's inertia about its frame origin
#: keeps ``~1e-16 / delta^2`` of its relative precision; axes a file means to be parallel
#: and rounds (``delta`` ~1e-6) are made parallel instead, which moves the robot by
#: ``delta`` (reported by the importer).
PARALLEL_TOLERANCE = 1e-4
#: Angles [rad] within this of 0, ±pi/2, pi, and lengths within this times the robot's
#: size of 0, are set to those values.
SNAP = 1e-12
#: Largest mismatch [relative to the size] between the frames rebuilt from the parameters
#: and the axes they come from (a self-check: round-off is ~1e-15).
SELF_CHECK = 1e-9


@dataclass(frozen=True)
class CanonicalChain:
    """A leg in canonical form (module docstring).

    Attributes:
        base: (4, 4) frame 0i in F0 (``[R_i, B_i]``).
        params: (3, 4) ``alpha, d, theta, r`` of joints 1..3 [rad, m, rad, m].
        tip: (3,) P_i in frame 3i [m].
        frames: (3, 4, 4) frames 1i..3i in F0 at the zero configuration, rebuilt from
            ``base`` and ``params`` (the frames the link inertias are expressed in).
        snapped: the largest angle [rad] by which an axis was turned to make it parallel
            to its neighbour (0 when none was).
    """

    base: np.ndarray
    params: np.ndarray
    tip: np.ndarray
    frames: np.ndarray
    snapped: float = 0.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _feet(a1: np.ndarray, z1: np.ndarray, a2: np.ndarray, z2: np.ndarray) -> tuple[Any, Any]:
    """The feet on lines 1 and 2 of their common normal (non-parallel lines)."""
    w = a1 - a2
    b = z1 @ z2
    d, e = z1 @ w, z2 @ w
    den = 1.0 - b * b
    s = (b * e - d) / den
    t = (e - b * d) / den
    return a1 + s * z1, a2 + t * z2


def _project(point: np.ndarray, a: np.ndarray, z: np.ndarray) -> np.ndarray:
    return a + ((point - a) @ z) * z


def _snap_angle(x: float) -> float:
    for target in (0.0, math.pi / 2, -math.pi / 2, math.pi, -math.pi):
        if abs(x - target) <= SNAP:
            return math.pi if target == -math.pi else target
    return x


def _snap_length(x: float, scale: float) -> float:
    return 0.0 if abs(x) <= SNAP * scale else x


def canonical_chain(
    kinds: Sequence[str],
    anchors: Any,
    axes: Any,
    tip_point: Any,
    scale: float,
    names: Sequence[str] = ("joint 1", "joint 2", "joint 3"),
) -> CanonicalChain:
    """The canonical modified-DH form (module docstring) of a chain of three 1-dof joints.

    Args:
        kinds: ``"revolute"`` / ``"prismatic"`` of joints 1..3.
        anchors: (3, 3) a point of each joint's line in F0 at the zero configuration [m]
            (any point for a prismatic joint).
        axes: (3, 3) each joint's axis in F0 at the zero configuration (any length > 0).
        tip_point: (3,) the spherical-joint centre P_i in F0 at the zero configuration [m].
        scale: the robot's length scale [m] (tolerances).
        names: the joints' names, for the messages.

    Raises:
        ArchitectureError: two joints on one line (a redundant chain).
    """
    a = np.array(anchors, dtype=float)
    z = np.array([_unit(np.asarray(v, dtype=float)) for v in axes])
    P = np.asarray(tip_point, dtype=float)
    prismatic = [k == PRISMATIC for k in kinds]
    # nearly parallel axes (rounded numbers) are made parallel: 0. rule of the docstring
    snapped = 0.0
    for j in (0, 1):
        if np.linalg.norm(np.cross(z[j], z[j + 1])) <= PARALLEL_TOLERANCE:
            target = z[j] if z[j] @ z[j + 1] > 0 else -z[j]
            snapped = max(snapped, float(np.linalg.norm(z[j + 1] - target)))
            z[j + 1] = target

    # 1. prismatic lines through the next line's point
    if prismatic[2]:
        a[2] = P
    c3 = _project(P, a[2], z[2])
    if prismatic[1]:
        a[1] = c3
    o = np.zeros((3, 3))
    x = np.full((3, 3), np.nan)  # nan: not chosen yet (coaxial joints, below)

    def coincident(j: int) -> ArchitectureError:
        return ArchitectureError(
            f"{names[j]} and {names[j + 1]} move along or about one line: the leg has a "
            "redundant joint (a chain of three independent 1-dof joints is needed)",
            "joints",
            (names[j], names[j + 1]),
        )

    def parallel(j: int) -> None:
        """Lines j, j+1 parallel, o[j+1] placed: o[j] its projection on line j."""
        o[j] = _project(o[j + 1], a[j], z[j])
        gap = o[j + 1] - o[j]
        if np.linalg.norm(gap) > SNAP * scale:
            x[j] = _unit(gap)
        elif prismatic[j] == prismatic[j + 1]:
            raise coincident(j)
        # else a slide along a hinge's axis (a cylindrical pair): x[j] = x[j+1], below

    # 2. frames 2 and 3's origin (pair 2-3), then frame 1 (pair 1-2)
    n23 = np.cross(z[1], z[2])
    if np.linalg.norm(n23) > PARALLEL_TOLERANCE:
        x[1] = _unit(n23)
        o[1], o[2] = _feet(a[1], z[1], a[2], z[2])
    else:
        o[2] = c3
        parallel(1)
    if prismatic[0]:
        a[0] = o[1]
    n12 = np.cross(z[0], z[1])
    if np.linalg.norm(n12) > PARALLEL_TOLERANCE:
        x[0] = _unit(n12)
        o[0], _ = _feet(a[0], z[0], a[1], z[1])
    else:
        parallel(0)

    # 3. frame 3's x axis
    v = P - o[2]
    v_perp = v - (v @ z[2]) * z[2]
    if np.linalg.norm(v_perp) > SNAP * scale:
        x[2] = _unit(v_perp)
    elif not np.isnan(x[1, 0]):
        x[2] = x[1]
    else:
        raise ArchitectureError(
            f"the spherical-joint centre lies on the common axis of {names[1]} and "
            f"{names[2]}: the leg cannot move it across that axis",
            "tip",
            tuple(P),
        )
    if np.isnan(x[1, 0]):
        x[1] = x[2]
    if np.isnan(x[0, 0]):
        x[0] = x[1]

    R = [np.column_stack([x[j], np.cross(z[j], x[j]), z[j]]) for j in range(3)]
    base = np.eye(4)
    base[:3, :3], base[:3, 3] = R[0], o[0]

    params = np.zeros((3, 4))
    for j in (1, 2):
        zp, xp, zj, xj = z[j - 1], x[j - 1], z[j], x[j]
        alpha = math.atan2(float(np.cross(zp, zj) @ xp), float(zp @ zj))
        delta = o[j] - o[j - 1]
        d = float(delta @ xp)
        r = float((delta - d * xp) @ zj)
        theta = math.atan2(float(np.cross(xp, xj) @ zj), float(xp @ xj))
        params[j] = (_snap_angle(alpha), _snap_length(d, scale), _snap_angle(theta), 0.0)
        params[j, 3] = _snap_length(r, scale)
    tip = np.array([_snap_length(float(c), scale) for c in R[2].T @ (P - o[2])])

    frames = np.empty((3, 4, 4))
    T = base
    for j in range(3):
        T = T @ mdh_transform(*params[j])
        frames[j] = T
    # self-check: the rebuilt frames carry the given axes, and the tip is P
    err = max(
        float(np.abs(frames[j, :3, 2] - z[j]).max()) * scale
        + float(np.abs(np.cross(frames[j, :3, 3] - a[j], z[j])).max())
        for j in range(3)
    )
    err = max(err, float(np.abs(frames[2, :3, :3] @ tip + frames[2, :3, 3] - P).max()))
    if not err <= SELF_CHECK * scale:
        raise ArchitectureError(
            f"canonical modified-DH form of {', '.join(names)}: the frames rebuilt from the "
            f"parameters miss the joint axes by {err:.3g} m (more than {SELF_CHECK:g} of the "
            f"size {scale:.3g} m): nearly parallel axes whose common normal lies far away",
            "joints",
            tuple(names),
        )
    return CanonicalChain(base, params, tip, frames, snapped)


# ------------------------------------------------------------------------------ inertia
def pseudo_inertia(params: np.ndarray) -> np.ndarray:
    """The 4x4 pseudo-inertia ``[[sum m x x^T, m c], [m c^T, m]]`` of Khalil parameters
    (10,) about the frame origin (linear in them; defined for massless bodies)."""
    p = np.asarray(params, dtype=float)
    I_O = np.array([[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_O) * np.eye(3) - I_O
    J[:3, 3] = J[3, :3] = p[6:9]
    J[3, 3] = p[9]
    return J


def khalil_from_pseudo(J: np.ndarray) -> np.ndarray:
    """Khalil parameters (10,) of a 4x4 pseudo-inertia."""
    J = 0.5 * (J + J.T)
    I_O = np.trace(J[:3, :3]) * np.eye(3) - J[:3, :3]
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *J[:3, 3], J[3, 3]]
    )


def transform_inertia(params: Any, T_b_a: Any) -> np.ndarray:
    """Khalil parameters (10,) given in frame a, re-expressed in frame b, ``T_b_a`` the
    pose of a in b (4x4): exact (``J_b = T J_a T^T`` on the pseudo-inertia)."""
    T = np.asarray(T_b_a, dtype=float)
    return khalil_from_pseudo(T @ pseudo_inertia(params) @ T.T)


# ------------------------------------------------------------------------------ legs
def classify(
    joints: tuple[Joint, ...], actuated: int, tip: np.ndarray, guess: np.ndarray
) -> LegArchitecture:
    """The leg with the first architecture name whose structure it has: ``ups`` (R, R, P
    with intersecting U-joint axes), ``ups-offset``, ``rus``, ``pus``, else ``custom``
    (branch +1; set it with ``LegArchitecture.branch_at``)."""
    for name in ("ups", "ups-offset", "rus", "pus"):
        try:
            return LegArchitecture(joints, actuated, tip, 1, name, guess)
        except ArchitectureError:
            continue
    return LegArchitecture(joints, actuated, tip, 1, "custom", guess)


def leg_zero_frames(desc: Any, k: int) -> np.ndarray:
    """Frames 1i..3i of leg k (0-based) in F0 at the zero configuration, (3, 4, 4)."""
    leg = desc.legs[k]
    T0 = np.eye(4)
    T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
    return np.array(leg.transforms(np.zeros(3), T0))


def canonical_description(desc: RobotDescription) -> RobotDescription:
    """The same robot with every leg in canonical form (module docstring): the joints'
    kinds, values, limits and dynamics, the actuated joints, P_i, the platform and the
    home pose unchanged; ``R_i``, ``B_i``, the MDH parameters, the tips and each link's
    ten inertial parameters (re-expressed in its canonical frame) in canonical form; the
    architecture names by structure (:func:`classify`), each leg's branch that of its home
    configuration, its ``guess`` kept. The architecture says whether its legs need the
    rewrite (:meth:`RobotDescription.canonical`: the paper's ideal 6-UPS is canonical as
    written and is returned as it is). ``source`` is kept."""
    return desc.canonical(_canonical_chains)


def _canonical_chains(desc: RobotDescription) -> RobotDescription:
    """:func:`canonical_description`'s rewrite of a robot's leg chains."""
    from stewart_pin.kinematics.leg_chains import inverse_geometry

    g = general_from_description(desc)
    q_home = np.asarray(inverse_geometry(g, desc.home_pose, check_limits=False))
    scale = g.size
    legs, rotations, points = [], [], []
    inertia = np.array(desc.leg_inertia)
    for k, leg in enumerate(g.legs):
        frames = leg_zero_frames(g, k)
        tip_point = frames[2, :3, :3] @ leg.tip + frames[2, :3, 3]
        chain = canonical_chain(leg.kinds, frames[:, :3, 3], frames[:, :3, 2], tip_point, scale)
        joints = tuple(
            replace(j, alpha=p[0], d=p[1], theta=p[2], r=p[3])
            for j, p in zip(leg.joints, chain.params, strict=True)
        )
        new = classify(joints, leg.actuated, chain.tip, leg.guess)
        legs.append(new.replace(branch=new.branch_at(q_home[k])))
        rotations.append(chain.base[:3, :3])
        points.append(chain.base[:3, 3])
        for j in range(3):
            T_new_old = np.linalg.inv(chain.frames[j]) @ frames[j]
            inertia[k, j] = transform_inertia(desc.leg_inertia[k, j], T_new_old)
    return desc.replace(
        legs=tuple(legs),
        leg_base_rotations=np.array(rotations),
        base_points=np.array(points),
        leg_inertia=inertia,
    )


__all__ = [
    "PARALLEL_TOLERANCE",
    "SNAP",
    "CanonicalChain",
    "canonical_chain",
    "canonical_description",
    "classify",
    "khalil_from_pseudo",
    "leg_zero_frames",
    "pseudo_inertia",
    "transform_inertia",
]
