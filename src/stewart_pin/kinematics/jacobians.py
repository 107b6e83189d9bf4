"""Kinematic models (paper section III): Jp^-1, the leg Jacobians, first and second order.

Conventions: a twist is ``V_p = [v, w]`` (6,) — the velocity of O_p and the angular
velocity of the platform, both in F0; an acceleration is classical ``[dv/dt, dw/dt]``
(the acceleration of the point O_p, not the spatial one). Batches carry a leading N axis.

Leg i in F0 (frame 1i at q1i = 0 has orientation ``R1_i``)::

    a_i   = R1_i [cos q1 sin q2, sin q1 sin q2, -cos q2]    (unit vector z3i along the leg)
    P_i   = B_i + q3i a_i
    J_3i  = [q3i da/dq1, q3i da/dq2, a_i]                   (3x3, columns orthogonal)

so ``J_3i^-1`` has rows ``(da/dq1)^T / (q3 sin^2 q2)``, ``(da/dq2)^T / q3``, ``a_i^T`` —
the frame-3i form of the paper (eq. 15-17) rotated into F0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._checks import check_batch, check_poses, in_batch
from stewart_pin._so3 import cross
from stewart_pin._typing import Accels, ArrayLike, FloatArray, JointValues, Poses, Twists
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import InputError, SingularityError
from stewart_pin.kinematics.geometry import (
    characteristic_length,
    inverse_geometry_batch,
    leg_vectors,
)

#: Default threshold on the singularity measure (:func:`condition_number`, the condition
#: number of Jp^-1 with its angular columns divided by the characteristic length) past
#: which a pose is declared singular (``SingularityError``); a robot can set its own.
#: Near a parallel singularity the models lose accuracy like measure * eps: the IDM's
#: Gamma = Jp^T F, and the DDM given forces that nearly cancel through Jp^-T (e.g. those of
#: the IDM): the two backends agree to 1.6e-10 at 1e4, 8e-10 at 1e5 and only 9e-9 at 1e6
#: (worst of the sweeps of ``tests/test_singularities.py``, run as a script with
#: ``--beyond``). Workspace poses of the presets measure below 10.
MAX_CONDITION = 1e4


@dataclass(frozen=True)
class LegFrames:
    """Leg directions and their derivatives in F0, each shape (N, 6, 3).

    ``a`` is the unit vector of the leg, ``a1 = da/dq1``, ``a2 = da/dq2``; ``y3`` the y axis
    of frame 3i (its x axis is ``a2``, z axis ``a``).
    """

    a: FloatArray
    a1: FloatArray
    a2: FloatArray
    y3: FloatArray
    sin_q2: FloatArray
    cos_q2: FloatArray


def leg_frames(desc: RobotDescription, q: JointValues) -> LegFrames:
    """Leg directions and derivatives from leg joint values (N, 6, 3).

    The four vectors are written in frame 1i into one (N, 6, 4, 3) array and rotated into
    F0 by one ``einsum`` (a few numpy calls whatever N: one state costs little more than
    the Python overhead)."""
    c1, s1 = np.cos(q[..., 0]), np.sin(q[..., 0])
    c2, s2 = np.cos(q[..., 1]), np.sin(q[..., 1])
    u = np.empty((*q.shape[:-1], 4, 3))
    u[..., 0, 0], u[..., 0, 1], u[..., 0, 2] = c1 * s2, s1 * s2, -c2  # a
    u[..., 1, 0], u[..., 1, 1], u[..., 1, 2] = -s1 * s2, c1 * s2, 0.0  # a1 = da/dq1
    u[..., 2, 0], u[..., 2, 1], u[..., 2, 2] = c1 * c2, s1 * c2, s2  # a2 = da/dq2
    u[..., 3, 0], u[..., 3, 1], u[..., 3, 2] = s1, -c1, 0.0  # y3
    f0 = np.einsum("kij,nkmj->mnki", desc.leg_base_rotations, u)
    return LegFrames(a=f0[0], a1=f0[1], a2=f0[2], y3=f0[3], sin_q2=s2, cos_q2=c2)


def leg_jacobians(desc: RobotDescription, q: JointValues) -> FloatArray:
    """``J_3i`` in F0: velocity of the leg tip P_i from ``qdot_i``, shape (N, 6, 3, 3)."""
    f = leg_frames(desc, q)
    q3 = q[..., 2, None]
    return np.stack([q3 * f.a1, q3 * f.a2, f.a], axis=-1)


def leg_inverse_jacobians(desc: RobotDescription, q: JointValues) -> FloatArray:
    """``J_3i^-1`` in F0 (eq. 16-17): shape (N, 6, 3, 3). Singular when sin q2i or q3i is 0."""
    return _leg_inverse_jacobians(leg_frames(desc, q), q)


def _leg_inverse_jacobians(f: LegFrames, q: JointValues) -> FloatArray:
    q3 = q[..., 2, None]
    return np.stack([f.a1 / (q3 * f.sin_q2[..., None] ** 2), f.a2 / q3, f.a], axis=-2)


def leg_drift(desc: RobotDescription, q: JointValues, qdot: JointValues) -> FloatArray:
    """``Jdot_3i qdot_i`` in F0: the classical acceleration of P_i at ``qddot_i = 0``,
    shape (N, 6, 3) [m/s^2]."""
    return _leg_drift(leg_frames(desc, q), q, qdot)


def _leg_drift(f: LegFrames, q: JointValues, qd: JointValues) -> FloatArray:
    d1, d2, d3 = (qd[..., j, None] for j in range(3))
    q3 = q[..., 2, None]
    # Second derivatives of a, from a = R1 [c1 s2, s1 s2, -c2]:
    #   a11 = -sin q2 * (sin q2 a + cos q2 a2)   (minus the component of a normal to z1)
    #   a12 = -cos q2 * y3                        (since a1 = -sin q2 y3)
    #   a22 = -a
    s2, c2 = f.sin_q2[..., None], f.cos_q2[..., None]
    a11 = -s2 * (s2 * f.a + c2 * f.a2)
    a12 = -c2 * f.y3
    return 2.0 * d3 * (f.a1 * d1 + f.a2 * d2) + q3 * (
        a11 * d1**2 + 2.0 * a12 * d1 * d2 - f.a * d2**2
    )


def inverse_jacobian_batch(desc: RobotDescription, poses: Poses) -> FloatArray:
    """``Jp^-1`` (eq. 13) for validated poses (N, 4, 4): rows ``[a_i^T, (L_i x a_i)^T]``."""
    return inverse_jacobian_from_vectors(*leg_vectors(desc, poses))


def inverse_jacobian_from_vectors(
    d: FloatArray, L: FloatArray, lengths: FloatArray | None = None
) -> FloatArray:
    """``Jp^-1`` (N, 6, 6) from the leg vectors ``B_i P_i`` and ``L_i`` (N, 6, 3) of
    :func:`~stewart_pin.kinematics.geometry.leg_vectors` (eq. 13); ``lengths`` (N, 6), when
    given, must be ``|B_i P_i|`` as the inverse geometry computed them (``q3i``)."""
    norm = np.linalg.norm(d, axis=-1) if lengths is None else lengths
    a = d / norm[..., None]
    return np.concatenate([a, cross(L, a)], axis=-1)


def inverse_jacobian(desc: RobotDescription, pose: ArrayLike) -> FloatArray:
    """``Jp^-1``: actuator velocities ``qdot_a = Jp^-1 V_p`` [m/s] from the twist; (6, 6)
    for one pose, (N, 6, 6) for a batch. Its transpose maps leg forces to the platform
    wrench about O_p in F0."""
    T, batched = check_poses(pose)
    J = inverse_jacobian_batch(desc, T)
    return J if batched else J[0]


def scaled_inverse_jacobian(J_inv: FloatArray, length: float) -> FloatArray:
    """``Jp^-1 diag(1, 1, 1, 1/l, 1/l, 1/l)``: Jp^-1 (..., 6, 6) acting on the twist
    ``[v, w l]`` (the angular velocity times the characteristic length ``l`` [m],
    :func:`stewart_pin.kinematics.geometry.characteristic_length`), so that every entry is
    dimensionless. Its condition number is the singularity measure."""
    S = J_inv.copy()
    S[..., 3:] /= length
    return S


def condition_number_batch(desc: RobotDescription, poses: Poses) -> FloatArray:
    """The singularity measure (:func:`condition_number`) of validated poses (N, 4, 4): (N,)."""
    J = scaled_inverse_jacobian(inverse_jacobian_batch(desc, poses), characteristic_length(desc))
    return np.linalg.cond(J)


def condition_number(desc: RobotDescription, pose: ArrayLike) -> FloatArray | float:
    """The singularity measure: the 2-norm condition number of Jp^-1 with its angular
    columns divided by the robot's characteristic length (its platform radius,
    :func:`stewart_pin.kinematics.geometry.characteristic_length`), 1 when isotropic, infinite at a
    parallel singularity.

    The scaling makes it unit-free: a robot and its copy scaled by any factor have the same
    measure at corresponding poses (plain cond(Jp^-1) mixes columns in m/m and m/rad, and
    refused micro-scale robots). ``max_condition`` thresholds refer to this measure.
    """
    T, batched = check_poses(pose)
    c = condition_number_batch(desc, T)
    return c if batched else float(c[0])


def check_condition(J_inv: FloatArray, max_condition: float, desc: RobotDescription) -> FloatArray:
    """Raise :class:`SingularityError` where the singularity measure (:func:`condition_number`)
    of ``J_inv`` (N, 6, 6), Jp^-1 of ``desc`` at N poses, exceeds ``max_condition``.
    Returns the measures (N,)."""
    length = characteristic_length(desc)
    c = np.linalg.cond(scaled_inverse_jacobian(J_inv, length))
    bad = ~(c <= max_condition)
    if np.any(bad):
        n = int(np.argmax(bad))  # the first failing state
        raise in_batch(
            SingularityError(
                f"the platform is at or near a parallel singularity: cond(Jp^-1) = "
                f"{c[n]:.3g} > {max_condition:g} (angular columns scaled by the platform radius "
                f"{length:.3g} m); move away from it (a higher max_condition costs accuracy)",
                float(c[n]),
                max_condition,
            ),
            bad,
        )
    return c


def check_singularity(J_inv: FloatArray, max_condition: float, desc: RobotDescription) -> None:
    """The decision of :func:`check_condition` (raise :class:`SingularityError` where the
    singularity measure of ``J_inv`` (N, 6, 6) exceeds ``max_condition``), mostly without
    its SVD.

    With ``S`` the scaled Jp^-1 (:func:`scaled_inverse_jacobian`), the measure is
    ``cond_2(S) = ||S||_2 ||S^-1||_2 <= ||S||_F ||S^-1||_F``: when that cheap bound (one
    LU inverse per state) is at most ``max_condition`` at every state, every state is
    accepted, as the exact measure would; otherwise (a bound above the threshold, a
    singular or non-finite ``S``) :func:`check_condition` computes the exact SVD measure
    of the whole batch and decides. The accept/refuse decision, and the error raised,
    are therefore those of :func:`check_condition`; the bound is at most ``sqrt(6)`` times
    the measure, so it only falls back within that factor of the threshold.
    """
    S = scaled_inverse_jacobian(J_inv, characteristic_length(desc))
    try:
        with np.errstate(all="ignore"):
            S_inv = np.linalg.inv(S)
            bound = np.sqrt(np.einsum("nij,nij->n", S, S) * np.einsum("nij,nij->n", S_inv, S_inv))
        if bool(np.all(bound <= max_condition)):
            return
    except np.linalg.LinAlgError:
        pass
    check_condition(J_inv, max_condition, desc)


def jacobian(
    desc: RobotDescription, pose: ArrayLike, max_condition: float = MAX_CONDITION
) -> FloatArray:
    """``Jp = (Jp^-1)^-1``: platform twist from actuator velocities; (6, 6) or (N, 6, 6).

    Raises :class:`SingularityError` past ``max_condition``.
    """
    T, batched = check_poses(pose)
    J_inv = inverse_jacobian_batch(desc, T)
    check_condition(J_inv, max_condition, desc)
    J = np.asarray(np.linalg.inv(J_inv), dtype=np.float64)  # float64 for the type checker
    return J if batched else J[0]


@dataclass(frozen=True)
class LegState:
    """Leg joint positions, velocities, accelerations (N, 6, 3), with the quantities the
    dynamics needs: frames, Jacobians (N, 6, 3, 3), the drift ``Jdot qdot`` (N, 6, 3) and
    ``L_i`` (N, 6, 3), all in F0."""

    q: JointValues
    qdot: JointValues
    qddot: JointValues | None
    frames: LegFrames
    J_inv: FloatArray
    drift: FloatArray
    L: FloatArray


def leg_state(
    desc: RobotDescription,
    poses: Poses,
    twists: Twists,
    accels: Accels | None = None,
    check_limits: bool = True,
    vectors: tuple[FloatArray, FloatArray] | None = None,
) -> LegState:
    """First and second order inverse kinematics of the legs (eq. 14-19), validated inputs.

    ``vectors``: the poses' ``(B_i P_i, L_i)`` when the caller has them already
    (:func:`~stewart_pin.kinematics.geometry.leg_vectors`), so that they are computed once.

    ``qdot_i = J_3i^-1 (v + w x L_i)``;
    ``qddot_i = J_3i^-1 (vdot + wdot x L_i + w x (w x L_i) - Jdot_3i qdot_i)``.
    """
    d, L = leg_vectors(desc, poses) if vectors is None else vectors
    q = inverse_geometry_batch(desc, poses, check_limits, vectors=d)
    f = leg_frames(desc, q)
    J_inv = _leg_inverse_jacobians(f, q)
    v, w = twists[:, None, :3], twists[:, None, 3:]
    w_L = cross(w, L)
    V_P = v + w_L
    qdot = np.einsum("nkij,nkj->nki", J_inv, V_P)
    drift = _leg_drift(f, q, qdot)
    qddot = None
    if accels is not None:
        vd, wd = accels[:, None, :3], accels[:, None, 3:]
        Vdot_P = vd + cross(wd, L) + cross(w, w_L)
        qddot = np.einsum("nkij,nkj->nki", J_inv, Vdot_P - drift)
    return LegState(q, qdot, qddot, f, J_inv, drift, L)


def leg_kinematics(
    desc: RobotDescription, pose: ArrayLike, twist: Any, accel: Any | None = None
) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """``(q, qdot, qddot)`` of the legs, each (6, 3) for one state or (N, 6, 3) for a batch.

    Args:
        pose: 0Tp, (4, 4) / ``pin.SE3`` or (N, 4, 4).
        twist: ``[v, w]`` of O_p in F0, (6,) or (N, 6) [m/s, rad/s].
        accel: classical ``[dv/dt, dw/dt]`` in F0, (6,) or (N, 6) [m/s^2, rad/s^2]; ``None``
            skips qddot.
    """
    T, batched = check_poses(pose)
    V, _ = check_batch(twist, (6,), "twist")
    A = None if accel is None else check_batch(accel, (6,), "accel")[0]
    for name, arr in (("twist", V), ("accel", A)):
        if arr is not None and arr.shape[0] != T.shape[0]:
            raise InputError(f"{name} has {arr.shape[0]} states but pose has {T.shape[0]}")
    s = leg_state(desc, T, V, A)
    out = (s.q, s.qdot, s.qddot)
    if batched:
        return out
    return tuple(None if x is None else x[0] for x in out)  # type: ignore[return-value]
