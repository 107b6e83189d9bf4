"""Kinematics of chain legs (:class:`~stewart_pin.description.chain_leg.ChainLeg`): any
serial chain of n 1-dof joints closed by a ball (c = 3) or a weld (c = 6), ``n = c``
(Khalil & Ibrahim 2007; ``docs/legs.md``, "Chain legs and welds").

Conventions: pose 0Tp (N, 4, 4); twist ``V = [v, w]`` of O_p in F0 [m/s, rad/s];
classical acceleration ``[dv/dt, dw/dt]`` in F0. Leg i's attachment on the platform is
``P_i`` (``L_i = 0Rp P_i`` in F0 from O_p), with the orientation ``0Rp R_pi`` for a weld.
Its Jacobian ``J_i`` (c, n) maps the joint rates to the attachment's velocity ``v_P`` (ball)
or twist ``[v_P, w]`` (weld) in F0; ``G_i = [I3, -L_i^]`` (ball) or
``[[I3, -L_i^], [0, I3]]`` (weld) maps the platform's twist to the same, so

- ``qdot_i = J_i^-1 G_i V``;
- ``qddot_i = J_i^-1 (G_i Vdot + d_i - Jdot_i qdot_i)``, ``d_i = w x (w x L_i)`` (ball;
  ``[w x (w x L_i), 0]`` weld), ``Jdot_i qdot_i`` the attachment's classical acceleration
  at zero joint acceleration;
- the actuated joint's rate ``e_a^T J_i^-1 G_i V``: row i of ``Jp^-1``.

Inverse geometry: a guarded Newton on the leg's chain (3D point residual, or 6D: point and
rotation vector ``log(R_target R^T)`` in F0), continued from the leg's configuration at the
home pose (found from its ``guess``) along the straight path from the home pose to the
target (position linearly, orientation along the geodesic): the configuration reached is
on the assembly branch of the home pose. Revolute joints are then taken modulo 2 pi into
their limits (a full-turn range limits nothing). Legs of the same joints are solved as
one batch, numpy over the states (on (3, N) arrays), Newton stepping only the states
not yet converged.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_pose, in_batch
from stewart_pin._so3 import cross, skew, so3_exp, so3_log
from stewart_pin.description import RobotDescription
from stewart_pin.description.chain_leg import ChainLeg, full_turn
from stewart_pin.description.leg_architecture import wrap_into_limits
from stewart_pin.exceptions import (
    LegJointLimitError,
    LegMobilityError,
    LegReachError,
    SingularityError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics._se3_newton import newton_se3
from stewart_pin.kinematics.leg_chains import (
    FORWARD_MAX_ITERATIONS,
    FORWARD_TOLERANCE,
    check_condition,
    scaled_condition_number,
)

#: Newton's convergence: the attachment's position error under ``NEWTON_TOLERANCE``
#: times the robot's size [m] and its orientation error under ``NEWTON_TOLERANCE`` [rad].
NEWTON_TOLERANCE = 1e-13
NEWTON_MAX_ITERATIONS = 40
#: Largest Newton step: revolute joints [rad]; prismatic joints, times the size [m].
MAX_STEP = 0.3
#: Continuation from the home pose: sub-steps of at most this fraction of the size [m]
#: and this angle [rad].
CONTINUATION_TRANSLATION = 0.25
CONTINUATION_ROTATION = 0.25
#: Newton's tolerance at the continuation's intermediate poses.
CONTINUATION_TOLERANCE = 1e-6
#: States per block of Newton's batch (its temporaries stay in the cache).
NEWTON_BLOCK = 100000
#: Singular values of a leg's Jacobian under this fraction of its largest: rank-deficient.
RANK_TOLERANCE = 1e-9


def chain_legs_of(desc: RobotDescription) -> tuple[ChainLeg, ...]:
    """The description's chain legs.

    Raises:
        UnsupportedArchitectureError: the robot has no chain legs (its legs are three-joint
            ball legs: the general and 6-UPS models take them)."""
    if desc.chain_legs is None:
        raise UnsupportedArchitectureError(
            f"robot '{desc.name}' has no chain legs (description.chain_legs): the chain-leg "
            f"models and the idle simulation take chain legs only; its {desc.architecture} "
            "legs take the robot's inverse and direct models and simulation",
            "chain_legs",
            desc.architecture,
        )
    return desc.chain_legs


def idle_legs(desc: RobotDescription) -> list[int]:
    """The legs (0-based) whose chain has an idle joint (``ChainLeg.idle_joint``); empty
    for a robot without chain legs."""
    if desc.chain_legs is None:
        return []
    return [k for k, leg in enumerate(desc.chain_legs) if leg.idle_joint is not None]


def robot_size(desc: RobotDescription) -> float:
    """The length scale [m]: the mean platform-point distance to their centroid."""
    P = desc.platform_points
    r = float(np.linalg.norm(P - P.mean(0), axis=1).mean())
    return r if r > 0 else desc.size


# ---------------------------------------------------------------------------- one chain
@dataclass(frozen=True)
class ChainFrames:
    """One leg's frames at a batch of joint values.

    Attributes:
        origins, axes: (N, n, 3) origin and z axis of each joint frame in F0.
        tip: (N, 4, 4) the attachment frame in F0.
    """

    origins: np.ndarray
    axes: np.ndarray
    tip: np.ndarray


def _frames_soa(
    leg: ChainLeg, T0: np.ndarray, q: np.ndarray, A: np.ndarray | None = None
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """:func:`chain_frames`'s arithmetic on (3, N) arrays (one row per component, so that
    numpy's loops run over the N states): each joint's origin and z axis, and the tip
    (4, 3, N) (its x, y, z axes and origin). ``T0`` (4, 4) or one per state (4, 4, N);
    ``A`` the attachment (4, 4) or (4, 4, N) (default ``leg.attachment()``)."""
    N = q.shape[0]
    # (3, 1) until the first joint variable: broadcast over the states after
    x, y, z = (T0[:3, k, None] if T0.ndim == 2 else T0[:3, k] for k in range(3))
    o = T0[:3, 3, None] if T0.ndim == 2 else T0[:3, 3]
    origins, axes = [], []
    for j, joint in enumerate(leg.joints):
        ca, sa = math.cos(joint.alpha), math.sin(joint.alpha)
        if joint.d != 0.0:
            o = o + joint.d * x
        if sa != 0.0 or ca != 1.0:
            y, z = ca * y + sa * z, ca * z - sa * y
        ct: Any
        st: Any
        r: Any
        if joint.revolute:
            theta = joint.theta + q[:, j]
            ct, st, r = np.cos(theta), np.sin(theta), joint.r
        else:
            ct, st = math.cos(joint.theta), math.sin(joint.theta)
            r = joint.r + q[:, j]
        x, y = ct * x + st * y, ct * y - st * x
        o = o + r * z
        origins.append(np.broadcast_to(o, (3, N)))
        axes.append(np.broadcast_to(z, (3, N)))
    A = leg.attachment() if A is None else A
    tip = np.empty((4, 3, N))
    for k in range(3):
        tip[k] = A[0, k] * x + A[1, k] * y + A[2, k] * z
    tip[3] = o + A[0, 3] * x + A[1, 3] * y + A[2, 3] * z
    return origins, axes, tip


def _tip_matrix(tip: np.ndarray) -> np.ndarray:
    """The tip (4, 3, N) of :func:`_frames_soa` as frames (N, 4, 4)."""
    out = np.zeros((tip.shape[2], 4, 4))
    out[:, :3, :] = np.moveaxis(tip, 2, 0).swapaxes(1, 2)
    out[:, 3, 3] = 1.0
    return out


def chain_frames(leg: ChainLeg, T0: np.ndarray, q: np.ndarray) -> ChainFrames:
    """Frames of ``leg`` (frame 0 at ``T0`` (4, 4) in F0) at joint values q (N, n).

    Each joint's ``Rx(alpha) Tx(d) Rz(theta) Tz(r)`` is applied to the frame's axes and
    origin, (3, N) arrays each: ``y, z`` turned by alpha about x, ``O += d x``, ``x, y``
    turned by theta about z, ``O += r z``."""
    origins, axes, tip = _frames_soa(leg, T0, q)
    shape = (q.shape[0], q.shape[1], 3)
    O = np.stack(origins, axis=2).transpose(1, 2, 0) if origins else np.empty(shape)
    Z = np.stack(axes, axis=2).transpose(1, 2, 0) if axes else np.empty(shape)
    return ChainFrames(np.ascontiguousarray(O), np.ascontiguousarray(Z), _tip_matrix(tip))


def _newton_jacobian(
    leg: ChainLeg,
    origins: list[np.ndarray],
    axes: list[np.ndarray],
    P: np.ndarray,
    free: np.ndarray,
) -> np.ndarray:
    """:func:`chain_jacobian`'s free columns (N, c, n_free) from :func:`_frames_soa`'s
    frames (the attachment point P (3, N)), with the same arithmetic."""
    c = leg.constraints
    cols = [j for j in range(leg.n_joints) if free[j]]
    out = np.zeros((c, len(cols), P.shape[1]))
    for m, j in enumerate(cols):
        z = axes[j]
        if leg.revolute[j]:
            d = P - origins[j]
            out[0, m] = z[1] * d[2] - z[2] * d[1]
            out[1, m] = z[2] * d[0] - z[0] * d[2]
            out[2, m] = z[0] * d[1] - z[1] * d[0]
            if c == 6:
                out[3:, m] = z
        else:
            out[:3, m] = z
    return out.transpose(2, 0, 1)


def chain_jacobian(leg: ChainLeg, frames: ChainFrames) -> np.ndarray:
    """``J_i`` (N, c, n): the attachment's velocity (ball) or twist ``[v_P, w]`` (weld) in
    F0 per joint rate."""
    P = frames.tip[:, None, :3, 3]
    z = frames.axes
    rev = leg.revolute
    J = np.zeros((z.shape[0], 6, z.shape[1]))
    J[:, :3] = np.swapaxes(np.where(rev[:, None], cross(z, P - frames.origins), z), 1, 2)
    J[:, 3:] = np.swapaxes(np.where(rev[:, None], z, 0.0), 1, 2)
    return J[:, : leg.constraints]


def chain_drift(leg: ChainLeg, frames: ChainFrames, qdot: np.ndarray) -> np.ndarray:
    """``Jdot_i qdot_i`` (N, c): the attachment's classical acceleration (ball: of its
    point; weld: ``[a_P, dw/dt]``) in F0 at zero joint acceleration."""
    z, o = frames.axes, frames.origins
    P = frames.tip[:, :3, 3]
    rev = leg.revolute
    N, n = qdot.shape

    def lin_col(k: int, point: np.ndarray) -> np.ndarray:
        return cross(z[:, k], point - o[:, k]) if rev[k] else z[:, k]

    v_P = sum((lin_col(k, P) * qdot[:, k, None] for k in range(n)), np.zeros((N, 3)))
    out = np.zeros((N, 6))
    w = np.zeros((N, 3))  # angular velocity of link j-1
    for j in range(n):
        wz = cross(w, z[:, j])
        if rev[j]:
            v_o = sum((lin_col(k, o[:, j]) * qdot[:, k, None] for k in range(j)), np.zeros((N, 3)))
            lin = cross(wz, P - o[:, j]) + cross(z[:, j], v_P - v_o)
            out[:, :3] += lin * qdot[:, j, None]
            out[:, 3:] += wz * qdot[:, j, None]
            w = w + z[:, j] * qdot[:, j, None]
        else:
            out[:, :3] += wz * qdot[:, j, None]
    return out[:, : leg.constraints]


def platform_map(leg: ChainLeg, L: np.ndarray) -> np.ndarray:
    """``G_i`` (N, c, 6) from L_i (N, 3)."""
    G = np.zeros((L.shape[0], 6, 6))
    G[:, :3, :3] = np.eye(3)
    G[:, :3, 3:] = -skew(L)
    G[:, 3:, 3:] = np.eye(3)
    return G[:, : leg.constraints]


def attachment_targets(desc: RobotDescription, k: int, T: np.ndarray) -> np.ndarray:
    """Leg k's platform attachment frame in F0 (N, 4, 4) at poses T (N, 4, 4)."""
    leg = chain_legs_of(desc)[k]
    A = np.eye(4)
    A[:3, :3], A[:3, 3] = leg.platform_rotation, desc.platform_points[k]
    return T @ A


def _residual(leg: ChainLeg, tip: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(N, c): ``target - tip`` position, and for a weld ``log(R_target R_tip^T)``."""
    e = target[:, :3, 3] - tip[:, :3, 3]
    if leg.constraints == 3:
        return e
    rot = so3_log(target[:, :3, :3] @ np.swapaxes(tip[:, :3, :3], 1, 2))
    return np.concatenate([e, rot], axis=1)


def leg_base_pose(desc: RobotDescription, k: int) -> np.ndarray:
    T0 = np.eye(4)
    T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
    return T0


def _norm3(v: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(v, axis=1)`` of v (N, 3), the same sums in the same order (faster
    than a reduction over the short axis)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def newton(
    desc: RobotDescription,
    k: int,
    target: np.ndarray,
    q: np.ndarray,
    tol: float = NEWTON_TOLERANCE,
) -> tuple[np.ndarray, np.ndarray]:
    """Guarded Newton on leg k's chain toward ``target`` (N, 4, 4) from q (N, n), an idle
    joint kept at its value, to ``tol`` (relative position, rad); returns ``(q, converged
    (N,) bool)``."""
    leg = chain_legs_of(desc)[k]
    return _newton(leg, leg_base_pose(desc, k), None, robot_size(desc), target, q, tol)


def _newton(
    leg: ChainLeg,
    T0: np.ndarray,
    A: np.ndarray | None,
    size: float,
    target: np.ndarray,
    q: np.ndarray,
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`newton` on ``leg``'s joints with frame 0 at ``T0`` (4, 4) or one per state
    (4, 4, N), the attachment ``A`` (4, 4, N) per state (``None``: the leg's): several
    legs of the same joints solved as one batch."""
    per_state = T0.ndim == 3
    if q.shape[0] > NEWTON_BLOCK:  # each state's arithmetic is its own
        parts = [
            _newton(
                leg,
                T0[:, :, i : i + NEWTON_BLOCK] if per_state else T0,
                None if A is None else A[:, :, i : i + NEWTON_BLOCK],
                size,
                target[i : i + NEWTON_BLOCK],
                q[i : i + NEWTON_BLOCK],
                tol,
            )
            for i in range(0, q.shape[0], NEWTON_BLOCK)
        ]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    free = np.array([j + 1 != leg.idle_joint for j in range(leg.n_joints)])
    step_cap = np.where(leg.revolute, MAX_STEP, MAX_STEP * size)[free]
    q = q.copy()
    done = np.zeros(q.shape[0], bool)
    # Only the states not yet converged are evaluated and stepped (the others keep their
    # q, so their residual would stay under tol): each state's arithmetic is that of the
    # whole batch's, row by row. The not-converged states' q, base poses, attachments
    # and targets are kept compact, ``active`` their rows.
    active = np.arange(q.shape[0])
    qa, Ta = q, target
    T0a = T0
    Aa = A
    for _ in range(NEWTON_MAX_ITERATIONS):
        origins, axes, tip = _frames_soa(leg, T0a, qa, Aa)
        if leg.constraints == 3:
            e = Ta[:, :3, 3] - tip[3].T
        else:
            e = _residual(leg, _tip_matrix(tip), Ta)
        err = _norm3(e[:, :3]) / size
        if leg.constraints == 6:
            err = np.maximum(err, _norm3(e[:, 3:]))
        converged = err <= tol
        if np.all(converged):
            done[active] = True
            q[active] = qa
            return q, done
        if np.any(converged):
            done[active[converged]] = True
            q[active[converged]] = qa[converged]
            keep = ~converged
            active, qa, e, Ta = active[keep], qa[keep], e[keep], Ta[keep]
            if per_state:
                T0a = T0a[:, :, keep]
            if Aa is not None:
                Aa = Aa[:, :, keep]
            origins = [o[:, keep] for o in origins]
            axes = [z[:, keep] for z in axes]
            tip = tip[:, :, keep]
        J = _newton_jacobian(leg, origins, axes, tip[3], free)
        with np.errstate(all="ignore"):
            try:
                dq = np.linalg.solve(J, e[..., None])[..., 0]
            except np.linalg.LinAlgError:
                dq = np.einsum("nij,nj->ni", np.linalg.pinv(J), e)
        dq = np.where(np.isfinite(dq), dq, 0.0)
        scale = np.max(np.abs(dq) / step_cap, axis=1)
        dq = dq / np.maximum(scale, 1.0)[:, None]
        step = np.zeros_like(qa)
        step[:, free] = dq
        qa = qa + step
    q[active] = qa
    return q, done


_HOME: weakref.WeakKeyDictionary[RobotDescription, list[np.ndarray]] = weakref.WeakKeyDictionary()


def home_configuration(desc: RobotDescription) -> list[np.ndarray]:
    """Each leg's joint values (n,) at the home pose, Newton from its ``guess``
    (:class:`LegReachError` when a leg does not reach it; cached per description)."""
    if desc in _HOME:
        return _HOME[desc]
    out = []
    T = desc.home_pose[None]
    for k, leg in enumerate(chain_legs_of(desc)):
        q, ok = newton(desc, k, attachment_targets(desc, k, T), leg.guess[None])
        if not ok[0]:
            raise LegReachError(
                f"leg {k + 1}: Newton from the leg's guess {leg.guess.tolist()} does not "
                "reach its platform attachment at the home pose: give a guess closer to "
                "the home configuration",
                k + 1,
                float("nan"),
            )
        out.append(q[0])
    _HOME[desc] = out
    return out


def check_mobility_at_home(desc: RobotDescription) -> None:
    """Each leg's Jacobian at the home pose has full rank c; a leg's idle joint moves its
    idle freedom, which leaves the actuated joint still (:class:`LegMobilityError` naming
    the leg and the freedoms it lacks)."""
    for k, (leg, q) in enumerate(zip(chain_legs_of(desc), home_configuration(desc), strict=True)):
        J = chain_jacobian(leg, chain_frames(leg, leg_base_pose(desc, k), q[None]))[0]
        s = np.linalg.svd(J, compute_uv=False)
        rank = int(np.sum(s > RANK_TOLERANCE * s[0])) if s[0] > 0 else 0
        if rank < leg.constraints:
            raise LegMobilityError(
                f"leg {k + 1}: its {leg.n_joints} joints with its {leg.closure} closure "
                f"move the attachment in {rank} directions only at the home pose (rank of "
                f"J_{k + 1} {rank} < {leg.constraints}): the platform misses "
                f"{leg.constraints - rank} freedom(s) there (parallel axes, a joint along "
                "its own link...)",
                k + 1,
                missing=leg.constraints - rank,
                rank=rank,
            )
        if leg.idle_joint is not None:
            _check_idle(leg, leg.idle_joint, J, k)


def _check_idle(leg: ChainLeg, idle: int, J: np.ndarray, k: int) -> None:
    """The idle joint (1-based) parametrises the idle motion (``[J; e_idle^T]`` regular)
    and that motion leaves the actuated joint still."""
    n = leg.n_joints
    Jsq = np.vstack([J, np.eye(n)[idle - 1]])
    s = np.linalg.svd(Jsq, compute_uv=False)
    if not s[-1] > RANK_TOLERANCE * s[0]:
        raise LegMobilityError(
            f"leg {k + 1}: joint {idle} (idle_joint) does not move the leg's idle "
            "freedom at the home pose: name a joint that does (for an R-S-S rod, its spin)",
            k + 1,
        )
    null = np.linalg.solve(Jsq, np.eye(n)[-1])
    if abs(null[leg.actuated - 1]) > 1e-9 * np.abs(null).max():
        raise LegMobilityError(
            f"leg {k + 1}: the idle freedom moves the actuated joint {leg.actuated}: the "
            "actuators would not hold the platform",
            k + 1,
            extra=1,
        )


def _interpolate(T_from: np.ndarray, T_to: np.ndarray, s: float) -> np.ndarray:
    """Poses (N, 4, 4) a fraction s along the straight path from T_from (4, 4)."""
    out = np.tile(np.eye(4), (T_to.shape[0], 1, 1))
    out[:, :3, 3] = T_from[:3, 3] + s * (T_to[:, :3, 3] - T_from[:3, 3])
    r = so3_log(T_to[:, :3, :3] @ T_from[:3, :3].T)
    out[:, :3, :3] = so3_exp(s * r) @ T_from[:3, :3]
    return out


def check_limits_of(desc: RobotDescription, k: int, q: np.ndarray) -> np.ndarray:
    """Leg k's joint values (N, n) with revolute ones taken modulo 2 pi into their limits
    (full turns limit nothing); :class:`LegJointLimitError` when one is outside."""
    leg = chain_legs_of(desc)[k]
    lim = leg.limits
    rev = leg.revolute
    lower = np.where(rev & full_turn(lim[:, 0], lim[:, 1]), -np.inf, lim[:, 0])
    upper = np.where(rev & full_turn(lim[:, 0], lim[:, 1]), np.inf, lim[:, 1])
    q = wrap_into_limits(q, rev, lim[:, 0], lim[:, 1])
    bad = (q < lower) | (q > upper)
    if np.any(bad):
        n, j = np.argwhere(bad)[0]
        raise in_batch(
            LegJointLimitError(
                k + 1, int(j + 1), float(q[n, j]), float(lim[j, 0]), float(lim[j, 1])
            ),
            bad.any(axis=1),
        )
    return q


def _continuation_steps(
    desc: RobotDescription, H: np.ndarray, T: np.ndarray, idle_step: np.ndarray
) -> np.ndarray:
    """(N,) int: each pose's sub-steps of the continuation from pose H (4, 4) to the poses
    T (N, 4, 4), the idle joints moving by ``idle_step`` (N,) [rad or m] (1 where not
    finite)."""
    dp = np.linalg.norm(T[:, :3, 3] - H[:3, 3], axis=1) / robot_size(desc)
    da = np.linalg.norm(so3_log(T[:, :3, :3] @ H[:3, :3].T), axis=1)
    da = np.maximum(da, idle_step)
    worst = np.maximum(dp / CONTINUATION_TRANSLATION, da / CONTINUATION_ROTATION)
    worst = np.where(np.isfinite(worst), worst, 1.0)
    return np.maximum(np.ceil(worst), 1).astype(int)


def idle_home(desc: RobotDescription) -> np.ndarray:
    """(6,) the idle joints' values at the home pose (0 for a leg without one)."""
    out = np.zeros(6)
    for k, (leg, q) in enumerate(zip(chain_legs_of(desc), home_configuration(desc), strict=True)):
        if leg.idle_joint is not None:
            out[k] = q[leg.idle_joint - 1]
    return out


def solve_legs(
    desc: RobotDescription, T: np.ndarray, idle_q: np.ndarray | None = None
) -> tuple[list[np.ndarray], np.ndarray]:
    """Each leg's joint values (N, n_i) at poses T (N, 4, 4) by the continuation from the
    home configuration (or from the last configuration solved, :data:`_LAST`, when that
    is fewer steps away for the batch: a trajectory's, a simulation's), each pose in its
    own number of sub-steps (:func:`_continuation_steps`), revolute ones in (-pi, pi], and
    ``reached`` (N, 6) bool; the idle joints at ``idle_q`` (N, 6) (``None``: their home
    values), reached along the same continuation."""
    out, reached, _ = _solve_legs(desc, T, idle_q, False)
    return out, reached


def _solve_legs(
    desc: RobotDescription, T: np.ndarray, idle_q: np.ndarray | None, prune: bool
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """:func:`solve_legs`, and ``alive`` (N,) bool: every leg reached, inside its limits.

    The legs of the same joints (:func:`_leg_groups`) are solved as one batch. With
    ``prune``, a pose whose attachment lies outside a leg's reach within its limits
    (:func:`_reach`) is solved for no leg, and a pose that one group of legs does not
    reach or puts outside its limits is not solved for the next groups (its values NaN,
    ``reached`` False, ``alive`` False; the last pose is solved for every leg: it
    decides :data:`_LAST`). Each pose and leg solved has the arithmetic of one leg's
    Newton alone (:func:`newton`)."""
    legs = chain_legs_of(desc)
    H, start, q_start = desc.home_pose, idle_home(desc), home_configuration(desc)
    N = T.shape[0]
    idle_q = np.broadcast_to(start, (N, 6)) if idle_q is None else idle_q
    has_idle = np.array([leg.idle_joint is not None for leg in legs])

    def steps_from(H: np.ndarray, start: np.ndarray) -> np.ndarray:
        change = np.abs(np.where(has_idle, idle_q - start, 0.0)).max(axis=1)
        return _continuation_steps(desc, H, T, change)

    steps = steps_from(H, start)
    last = _LAST.get(desc)
    if last is not None and steps.max() > 1:
        steps_last = steps_from(last[0], last[1])
        if steps_last.max() < steps.max():
            H, start, q_start, steps = last[0], last[1], last[2], steps_last
    # Each pose's own number of sub-steps (its result does not depend on the other poses
    # of the batch); the poses of the same number are solved as one batch, their
    # continuation's poses shared by the legs.
    counts = {int(c): np.flatnonzero(steps == c) for c in np.unique(steps)}
    paths = {
        c: [_interpolate(H, T[idx], s / c) for s in range(1, c)] + [T[idx]]
        for c, idx in counts.items()
    }
    out = [np.full((N, leg.n_joints), np.nan) for leg in legs]
    reached = np.zeros((N, 6), bool)
    alive = np.ones(N, bool)
    size = robot_size(desc)
    if prune:  # outside a leg's reach: rejected before any Newton
        for k, leg in enumerate(legs):
            lo, hi = _reach(leg, size)
            P = attachment_targets(desc, k, T)[:, :3, 3]
            dist = np.linalg.norm(P - desc.base_points[k], axis=1)
            alive &= (dist >= lo) & (dist <= hi)
        alive[-1] = True
    for group in _leg_groups(legs):
        leg, idle = legs[group[0]], legs[group[0]].idle_joint
        for c, idx in counts.items():
            sel = np.flatnonzero(alive[idx])  # the alive poses of count c, within idx
            rows, M = idx[sel], sel.size
            if M == 0:
                continue
            q = np.concatenate([np.broadcast_to(q_start[k], (M, leg.n_joints)) for k in group])
            T0 = np.repeat(np.stack([leg_base_pose(desc, k) for k in group], axis=2), M, axis=2)
            A = np.repeat(np.stack([legs[k].attachment() for k in group], axis=2), M, axis=2)
            for s in range(1, c + 1):
                Ts = paths[c][s - 1] if M == idx.size else paths[c][s - 1][sel]
                if idle is not None:
                    q[:, idle - 1] = np.concatenate(
                        [start[k] + s / c * (idle_q[rows, k] - start[k]) for k in group]
                    )
                # the intermediate poses only guide the branch: a loose tolerance
                tol = NEWTON_TOLERANCE if s == c else CONTINUATION_TOLERANCE
                target = np.concatenate([attachment_targets(desc, k, Ts) for k in group])
                q, ok = _newton(leg, T0, A, size, target, q, tol)
            q = np.where(leg.revolute, np.mod(q + math.pi, 2 * math.pi) - math.pi, q)
            good = np.ones(M, bool)
            for m, k in enumerate(group):
                qk, okk = q[m * M : (m + 1) * M], ok[m * M : (m + 1) * M]
                out[k][rows] = qk
                reached[rows, k] = okk
                if prune:
                    good &= okk & _inside(legs[k], qk)
            if prune:
                alive[rows[~good & (rows != N - 1)]] = False
    if np.all(reached[-1]):
        _LAST[desc] = (T[-1].copy(), np.array(idle_q[-1]), [q[-1].copy() for q in out])
    alive &= reached.all(axis=1)
    for leg, q in zip(legs, out, strict=True):
        alive[alive] = _inside(leg, q[alive])
    return out, reached, alive


def _leg_groups(legs: tuple[ChainLeg, ...]) -> list[list[int]]:
    """The legs (0-based) grouped by their joints (MDH parameters and kinds), idle joint
    and closure, in order of first appearance: each group is solved as one batch."""
    groups: dict[tuple[Any, ...], list[int]] = {}
    for k, leg in enumerate(legs):
        key = (
            tuple((j.alpha, j.d, j.theta, j.r, j.revolute) for j in leg.joints),
            leg.idle_joint,
            leg.constraints,
        )
        groups.setdefault(key, []).append(k)
    return list(groups.values())


def _inside(leg: ChainLeg, q: np.ndarray) -> np.ndarray:
    """(M,) bool: the joint values q (M, n), revolute ones taken modulo 2 pi, are inside
    the leg's limits (a full turn limits nothing)."""
    lim = leg.limits
    turn = leg.revolute & full_turn(lim[:, 0], lim[:, 1])
    qw = wrap_into_limits(q, leg.revolute, lim[:, 0], lim[:, 1])
    return np.all(turn | ((qw >= lim[:, 0]) & (qw <= lim[:, 1])), axis=1)


def _reach(leg: ChainLeg, size: float) -> tuple[float, float]:
    """``(lo, hi)`` [m]: bounds on the distance from the leg's frame 0 origin to its
    attachment over joint values inside the limits (revolute joints: any angle), widened
    by ``1e-9 (hi + size)``.

    The attachment is frame 0's origin plus the segments ``d_j x`` and ``(r_j + q_j) z``
    of each joint and the attachment's offset, of lengths within ``[l_min, l_max]``
    each: the distance lies within ``[max(l_min) - (sum(l_max) - l_max of that one),
    sum(l_max)]`` (a pose Newton reaches inside the limits, to its tolerance, is inside
    the bounds)."""
    segments = [(float(np.linalg.norm(leg.attachment()[:3, 3])),) * 2]
    for joint in leg.joints:
        segments.append((abs(joint.d), abs(joint.d)))
        if joint.revolute:
            segments.append((abs(joint.r), abs(joint.r)))
        else:
            a, b = joint.r + joint.lower, joint.r + joint.upper
            low = 0.0 if a <= 0.0 <= b else min(abs(a), abs(b))
            segments.append((low, max(abs(a), abs(b))))
    hi = sum(s[1] for s in segments)
    lo = max(s[0] - (hi - s[1]) for s in segments)
    margin = 1e-9 * (hi + size) if math.isfinite(hi) else 0.0
    return lo - margin, hi + margin


#: The last state solved per description: ``(pose (4, 4), idle values (6,), the legs'
#: joint values)``, a start for the next :func:`solve_legs` near it.
_LAST: weakref.WeakKeyDictionary[
    RobotDescription, tuple[np.ndarray, np.ndarray, list[np.ndarray]]
] = weakref.WeakKeyDictionary()


def inverse_geometry(
    desc: RobotDescription, T: np.ndarray, check_limits: bool, idle_q: np.ndarray | None = None
) -> list[np.ndarray]:
    """Each leg's joint values (N, n_i) at poses T (N, 4, 4), on the home pose's assembly
    branch (module docstring), idle joints at ``idle_q`` (N, 6) (default their home
    values); :class:`LegReachError` where Newton does not converge,
    :class:`LegJointLimitError` (``check_limits``) outside a joint's limits."""
    qs, reached = solve_legs(desc, T, idle_q)
    out = []
    for k, q in enumerate(qs):
        ok = reached[:, k]
        if not np.all(ok):
            n = int(np.argmin(ok))
            raise in_batch(
                LegReachError(
                    f"leg {k + 1} does not reach its platform attachment at pose {n} (Newton "
                    "on the leg's chain from the home configuration did not converge): the "
                    "pose is outside the leg's reach or past a leg singularity",
                    k + 1,
                    float("nan"),
                ),
                ~ok,
            )
        if check_limits:
            q = check_limits_of(desc, k, q)
        else:
            lim = chain_legs_of(desc)[k].limits
            q = wrap_into_limits(q, chain_legs_of(desc)[k].revolute, lim[:, 0], lim[:, 1])
        out.append(q)
    return out


def padded(qs: list[np.ndarray]) -> np.ndarray:
    """Per-leg arrays (N, n_i) as one (N, 6, max n_i), zero past a leg's last joint."""
    width = max(q.shape[1] for q in qs)
    out = np.zeros((qs[0].shape[0], 6, width))
    for k, q in enumerate(qs):
        out[:, k, : q.shape[1]] = q
    return out


def admissible_poses(desc: RobotDescription, T: np.ndarray, max_condition: float) -> np.ndarray:
    """(N,) bool: every leg reaches its attachment inside its joint limits, no leg
    Jacobian is singular, and ``Jp^-1``'s condition number is within ``max_condition``.

    A pose that one leg rejects is not solved for the next legs (:func:`_solve_legs`).
    The rank test ``s_min > RANK_TOLERANCE s_max`` on each leg's (square) Jacobian is
    decided by the bound ``s_min / s_max >= 1 / (|J|_F |J^-1|_F)`` where that bound
    passes twice the tolerance, by the singular values elsewhere."""
    legs = chain_legs_of(desc)
    qs, _, ok = _solve_legs(desc, T, None, True)
    rows = np.zeros((T.shape[0], 6, 6))
    for k, (leg, q) in enumerate(zip(legs, qs, strict=True)):
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            break
        J = _square(leg, chain_jacobian(leg, chain_frames(leg, leg_base_pose(desc, k), q[idx])))
        with np.errstate(all="ignore"):
            try:
                J_inv = np.linalg.inv(J)
            except np.linalg.LinAlgError:  # an exactly singular one: the singular values
                J_inv = np.full(J.shape, np.nan)
            bound = 1.0 / (np.linalg.norm(J, axis=(1, 2)) * np.linalg.norm(J_inv, axis=(1, 2)))
            clear = bound > 2.0 * RANK_TOLERANCE
            unclear = np.flatnonzero(~clear)
            if unclear.size:
                s = np.linalg.svd(J[unclear], compute_uv=False)
                regular = s[:, -1] > RANK_TOLERANCE * s[:, 0]
                clear[unclear] = regular
                fine = unclear[regular]
                if fine.size:
                    J_inv[fine] = np.linalg.inv(J[fine])
            ok[idx] = clear
            G = platform_map(leg, T[idx, :3, :3] @ desc.platform_points[k])
            rows[idx, k] = (J_inv[:, :, : leg.constraints] @ G)[:, leg.actuated - 1]
    if np.any(ok):
        ok[ok] = condition_number(desc, rows[ok]) <= max_condition
    return ok


def forward_geometry(
    desc: RobotDescription,
    actuated: Any,
    guess: Any = None,
    tol: float = FORWARD_TOLERANCE,
    max_iterations: int = FORWARD_MAX_ITERATIONS,
) -> np.ndarray:
    """The pose 0Tp (4, 4) whose actuated joint values are ``actuated`` (6,) [m or rad]:
    Newton on SE(3) from ``guess`` (default the home pose), ``Jp^-1 dV = actuated -
    q_a(T)``, ``p += dv``, ``R <- exp(dw) R``.

    Raises:
        ConvergenceError, SingularityError, LegReachError: as
        :func:`stewart_pin.kinematics.leg_chains.forward_geometry`.
    """
    target = check_array(actuated, (6,), "actuated")
    T = check_pose(desc.home_pose if guess is None else guess, "guess").copy()
    legs = chain_legs_of(desc)
    act = [leg.actuated - 1 for leg in legs]
    revolute = np.array([leg.revolute[a] for leg, a in zip(legs, act, strict=True)])

    def evaluate(T: np.ndarray) -> tuple[np.ndarray, Callable[[], np.ndarray]]:
        states = leg_states(desc, T[None], np.zeros((1, 6)))
        q_a = np.array([s.q[0, a] for s, a in zip(states, act, strict=True)])
        error = target - q_a
        error = np.where(revolute, np.mod(error + math.pi, 2 * math.pi) - math.pi, error)
        return error, lambda: inverse_jacobian(desc, states)[0]

    return newton_se3(T, evaluate, tol, max_iterations, "actuated joint error")


# ---------------------------------------------------------------------------- the legs' state
@dataclass(frozen=True)
class ChainLegState:
    """One leg's state at a batch of platform states.

    Attributes:
        q, qdot, qddot: (N, n) joint values, rates, accelerations [rad or m, /s, /s^2]
            (qddot zero without a platform acceleration).
        J: (N, c, n). J_inv: (N, n, c) ``J_i^-1``; for a leg with an idle joint the
            first c columns of ``[J_i; e_idle^T]^-1`` (the joint motion with the idle joint
            still). G: (N, c, 6). L: (N, 3) O_p to P_i in F0.
        drift: (N, c) ``Jdot_i qdot_i``. platform_drift: (N, c) ``d_i``.
        frames: the leg's :class:`ChainFrames`.
        null: (N, n) the idle motion per unit idle rate (last column of
            ``[J_i; e_idle^T]^-1``: ``J_i null = 0``), or ``None`` without an idle joint.
    """

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    J: np.ndarray
    J_inv: np.ndarray
    G: np.ndarray
    L: np.ndarray
    drift: np.ndarray
    platform_drift: np.ndarray
    frames: ChainFrames
    null: np.ndarray | None = None

    @property
    def KG(self) -> np.ndarray:
        """``J_i^-1 G_i`` (N, n, 6)."""
        return self.J_inv @ self.G


def _square(leg: ChainLeg, J: np.ndarray) -> np.ndarray:
    """``J`` (N, c, n), with the row ``e_idle^T`` below for a leg with an idle joint:
    (N, n, n)."""
    if leg.idle_joint is None:
        return J
    row = np.broadcast_to(np.eye(leg.n_joints)[leg.idle_joint - 1], (J.shape[0], 1, J.shape[2]))
    return np.concatenate([J, row], axis=1)


def _inv(J: np.ndarray, k: int) -> np.ndarray:
    try:
        J_inv = np.linalg.inv(J)
    except np.linalg.LinAlgError:
        J_inv = np.full(J.shape, np.nan)
    bad = ~np.all(np.isfinite(J_inv), axis=(1, 2))
    if np.any(bad):
        raise in_batch(
            SingularityError(
                f"leg {k + 1}: its Jacobian J_{k + 1} is singular (a serial singularity of "
                "the leg's chain)",
                float("inf"),
                None,
                leg=k + 1,
            ),
            bad,
        )
    return J_inv


@dataclass(frozen=True)
class IdleState:
    """The idle joints' state (one per leg; ignored for a leg without an idle joint).

    Attributes:
        q, qdot: (N, 6) values and rates [rad or m, /s]. qddot: (N, 6) accelerations, or
        ``None`` (zero; the inverse model computes them).
    """

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray | None = None


def leg_states(
    desc: RobotDescription,
    T: np.ndarray,
    V: np.ndarray,
    A: np.ndarray | None = None,
    check_limits: bool = False,
    idle: IdleState | None = None,
) -> list[ChainLegState]:
    """The six legs' :class:`ChainLegState` at poses T (N, 4, 4), twists V (N, 6) and
    classical accelerations A (N, 6) (``None``: qddot zero); the idle joints' values,
    rates and accelerations from ``idle`` (``None``: home values, at rest)."""
    q_all = inverse_geometry(desc, T, check_limits, None if idle is None else idle.q)
    w = V[:, 3:]
    out = []
    for k, (leg, q) in enumerate(zip(chain_legs_of(desc), q_all, strict=True)):
        frames = chain_frames(leg, leg_base_pose(desc, k), q)
        J = chain_jacobian(leg, frames)
        square = _inv(_square(leg, J), k)
        J_inv = square[:, :, : leg.constraints]
        null = None if leg.idle_joint is None else square[:, :, -1]
        L = T[:, :3, :3] @ desc.platform_points[k]
        G = platform_map(leg, L)
        qdot = np.einsum("nij,nj->ni", J_inv @ G, V)
        if null is not None and idle is not None:
            qdot = qdot + null * idle.qdot[:, k, None]
        drift = chain_drift(leg, frames, qdot)
        d = np.zeros((T.shape[0], leg.constraints))
        d[:, :3] = cross(w, cross(w, L))
        if A is None:
            qddot = np.zeros_like(qdot)
        else:
            rhs = np.einsum("nij,nj->ni", G, A) + d - drift
            qddot = np.einsum("nij,nj->ni", J_inv, rhs)
            if null is not None and idle is not None and idle.qddot is not None:
                qddot = qddot + null * idle.qddot[:, k, None]
        out.append(ChainLegState(q, qdot, qddot, J, J_inv, G, L, drift, d, frames, null))
    return out


def inverse_jacobian(desc: RobotDescription, states: list[ChainLegState]) -> np.ndarray:
    """``Jp^-1`` (N, 6, 6): row i is ``e_a^T J_i^-1 G_i``."""
    legs = chain_legs_of(desc)
    return np.stack([s.KG[:, leg.actuated - 1] for leg, s in zip(legs, states, strict=True)], 1)


def condition_number(desc: RobotDescription, J_inv: np.ndarray) -> np.ndarray:
    """Unit-free condition number of ``Jp^-1`` (N,): angular columns over the size."""
    return scaled_condition_number(J_inv, robot_size(desc))


def check_parallel(desc: RobotDescription, J_inv: np.ndarray, max_condition: float) -> None:
    """:class:`SingularityError` (``leg=None``) at a parallel singularity."""
    check_condition(condition_number(desc, J_inv), max_condition)


__all__ = [
    "NEWTON_TOLERANCE",
    "ChainFrames",
    "ChainLegState",
    "IdleState",
    "admissible_poses",
    "attachment_targets",
    "chain_drift",
    "chain_frames",
    "chain_jacobian",
    "check_mobility_at_home",
    "check_parallel",
    "condition_number",
    "forward_geometry",
    "home_configuration",
    "idle_home",
    "idle_legs",
    "inverse_geometry",
    "inverse_jacobian",
    "leg_states",
    "newton",
    "padded",
    "platform_map",
    "solve_legs",
]
