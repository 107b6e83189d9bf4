"""Per-state feasibility without exceptions: which poses satisfy every limit of a robot.

:func:`feasible` returns a boolean mask (N,) where the library's checked calls would raise
at the first offending state. A pose is feasible when every actuator is inside its stroke
or range, every passive joint inside its limits, no leg is at (or too near) a serial
singularity, and the singularity measure (:meth:`StewartRobot.condition_number`) is at
most the bound (default the robot's ``max_condition``).

The ideal 6-UPS is decided in closed form on the whole batch (the computations of
:func:`stewart_pin.kinematics.geometry.inverse_geometry_batch`, without raising); general
legs through the checked batch calls on chunks, a chunk that raises being split until the
offending states are isolated (slower: workspaces of general legs want fewer states).
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from stewart_pin._checks import check_poses, check_rotation, check_scalar
from stewart_pin.exceptions import InputError, StewartPinError
from stewart_pin.kinematics import geometry, jacobians, leg_chains

#: States per chunk of the closed-form mask (bounds the temporary arrays: ~100 MB).
CHUNK = 100_000
#: Below this size a chunk of general-leg states that raises is checked state by state.
_SPLIT_FLOOR = 16


def condition_bound(robot: Any, max_condition: float | None) -> float:
    """The singularity measure bound: ``max_condition`` checked (a number >= 1), or the
    robot's ``max_condition`` when None."""
    value = robot.max_condition if max_condition is None else max_condition
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 1.0):
        raise InputError(f"max_condition must be a number >= 1, got {value!r}")
    return float(value)


def check_distance(value: float | None) -> float | None:
    """``min_leg_distance`` checked: None, or a finite number >= 0 [m]."""
    if value is None:
        return None
    return check_scalar(value, "min_leg_distance", nonnegative=True, unit="m")


def feasible(
    robot: Any,
    poses: Any,
    max_condition: float | None = None,
    min_leg_distance: float | None = None,
) -> np.ndarray:
    """Boolean mask (N,) of the poses 0Tp (N, 4, 4) (or one pose -> shape (1,)) that satisfy
    every limit of ``robot`` (a :class:`~stewart_pin.robot.StewartRobot`) and whose
    singularity measure is at most ``max_condition`` (default ``robot.max_condition``);
    with ``min_leg_distance`` [m], also no two legs closer than that
    (:func:`leg_distance`: leg-leg interference)."""
    T = check_poses(poses)[0]
    return mask(robot, T, condition_bound(robot, max_condition), check_distance(min_leg_distance))


def mask(
    robot: Any, T: np.ndarray, bound: float, min_leg_distance: float | None = None
) -> np.ndarray:
    """:func:`feasible` on poses (N, 4, 4) already valid (rotations orthonormal: the
    studies build them) and checked bounds."""
    out = np.zeros(T.shape[0], dtype=bool)
    for start in range(0, T.shape[0], CHUNK):
        chunk = T[start : start + CHUNK]
        if robot.is_ideal_ups:
            ok = _ups_mask(robot.description, chunk, bound)
        else:
            ok = _general_mask(robot, chunk, bound)
        if min_leg_distance is not None and np.any(ok):
            ok[ok] = _leg_distance(robot, chunk[ok]) >= min_leg_distance
        out[start : start + CHUNK] = ok
    return out


# ---------------------------------------------------------------------------- interference
def segment_distance(p1: Any, q1: Any, p2: Any, q2: Any) -> np.ndarray:
    """The distance between the segments ``[p1, q1]`` and ``[p2, q2]`` (..., 3) [m], (...):
    the closest points' parameters clamped to the segments (Ericson, Real-Time Collision
    Detection, 5.1.9), degenerate segments (points) included."""
    p1, q1, p2, q2 = (np.asarray(v, dtype=float) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    tiny = 1e-30
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = a * e - b * b
        s = np.where(
            denom > tiny * np.maximum(a * e, tiny), np.clip((b * f - c * e) / denom, 0, 1), 0.0
        )
        t = np.where(e > tiny, (b * s + f) / e, 0.0)
        s_lo = np.where(a > tiny, np.clip(-c / a, 0, 1), 0.0)  # t clamped to 0
        s_hi = np.where(a > tiny, np.clip((b - c) / a, 0, 1), 0.0)  # t clamped to 1
        s = np.where(t < 0, s_lo, np.where(t > 1, s_hi, s))
        t = np.clip(t, 0, 1)
        # a point (e = 0) against a segment: t = 0, s the projection
        s = np.where(e > tiny, s, s_lo)
    gap = p1 + d1 * s[..., None] - (p2 + d2 * t[..., None])
    return np.asarray(np.linalg.norm(gap, axis=-1))


def _polylines(robot: Any, T: np.ndarray) -> np.ndarray:
    """Each leg as a polyline in F0, (N, 6, M, 3): B_i, P_i for the ideal 6-UPS; the three
    joint frames' origins and P_i for general legs (poses inside the legs' reach)."""
    if robot.is_ideal_ups:
        desc = robot.description
        P = np.swapaxes(T[:, :3, :3] @ desc.platform_points.T, 1, 2) + T[:, None, :3, 3]
        B = np.broadcast_to(desc.base_points, P.shape)
        return np.stack([B, P], axis=2)
    q = leg_chains.inverse_geometry_batch(robot.general, T, check_limits=False)
    frames = leg_chains.leg_forward(robot.general, q)
    return np.concatenate([frames.origins, frames.P[:, :, None]], axis=2)


def _leg_distance(robot: Any, T: np.ndarray) -> np.ndarray:
    lines = _polylines(robot, T)
    m = lines.shape[2] - 1
    best = np.full(T.shape[0], np.inf)
    for i, j in itertools.combinations(range(6), 2):
        for u in range(m):
            for v in range(m):
                d = segment_distance(
                    lines[:, i, u], lines[:, i, u + 1], lines[:, j, v], lines[:, j, v + 1]
                )
                best = np.minimum(best, d)
    return best


def leg_distance(robot: Any, poses: Any) -> np.ndarray:
    """The smallest distance between two legs (N,) [m] at poses (N, 4, 4) (one pose ->
    (1,)): each leg a polyline through its joints (the ideal 6-UPS: the segment
    ``B_i P_i``; general legs: through the joint frames' origins (modified DH: on each
    joint's axis; a slide's frame moves with it) to ``P_i``), the legs' thickness not
    counted (compare with a clearance plus the diameters). Legs sharing a joint centre (a
    6-3 platform) are at distance 0. General legs must reach the poses
    (:class:`~stewart_pin.exceptions.LegReachError` otherwise)."""
    return _leg_distance(robot, check_poses(poses)[0])


def _ups_mask(desc: Any, T: np.ndarray, bound: float) -> np.ndarray:
    """The ideal 6-UPS: stroke, U-joint limits, leg singularities, then the measure."""
    # B_i P_i = R P_i + p - B_i (N, 6, 3), as geometry.leg_vectors, by matmul (faster)
    d = np.swapaxes(T[:, :3, :3] @ desc.platform_points.T, 1, 2)
    d += T[:, None, :3, 3] - desc.base_points
    q3 = np.sqrt(np.einsum("nki,nki->nk", d, d))
    lo, hi = desc.ideal_stroke("the 6-UPS feasibility mask")
    ok = np.all((q3 >= lo) & (q3 <= hi), axis=1)
    min_length = geometry.LEG_MIN_LENGTH_RATIO * geometry.characteristic_length(desc)
    ok &= np.all(q3 >= min_length, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        # u_k = R1_k^T d_k / q3_k, as rows: d_k^T R1_k
        u = (d[:, :, None, :] @ desc.leg_base_rotations[None])[:, :, 0, :] / q3[..., None]
    sin_q2 = np.hypot(u[..., 0], u[..., 1])
    ok &= np.all(sin_q2 >= geometry.LEG_SINGULARITY_SIN, axis=1)
    if desc.u_joint_limits is not None:
        lim = desc.u_joint_limits
        q1 = np.arctan2(u[..., 1], u[..., 0])
        q2 = np.arctan2(sin_q2, -u[..., 2])
        for j, q in enumerate((q1, q2)):
            ok &= np.all((q >= lim[:, j, 0]) & (q <= lim[:, j, 1]), axis=1)
    if np.any(ok):
        c = jacobians.condition_number_batch(desc, T[ok])
        ok[ok] = c <= bound
    return ok


def _general_ok(robot: Any, T: np.ndarray, bound: float) -> bool:
    """Whether every state of ``T`` passes the checked calls of the general legs."""
    try:
        leg_chains.inverse_geometry_batch(robot.general, T, check_limits=True)
        J_inv = leg_chains.inverse_jacobian_batch(robot.general, T)
        leg_chains.check_parallel(robot.general, J_inv, bound)
    except StewartPinError:
        return False
    return True


def _general_mask(robot: Any, T: np.ndarray, bound: float) -> np.ndarray:
    """General legs: the batch decided at once by
    :func:`~stewart_pin.kinematics.leg_chains.admissible_poses` (the decision of the checked
    calls, state by state); where a closed form meets a floating-point fault, checked calls
    on halves of the batch until each chunk passes or is a single state."""
    n = T.shape[0]
    if n == 0:
        return np.zeros(0, dtype=bool)
    try:
        return leg_chains.admissible_poses(robot.general, T, bound)
    except FloatingPointError:
        return _split_mask(robot, T, bound)


def _split_mask(robot: Any, T: np.ndarray, bound: float) -> np.ndarray:
    """Checked calls on halves of the batch until each chunk passes or is a single state
    (states far from the limits cost one batched call per chunk)."""
    n = T.shape[0]
    if n == 0:
        return np.zeros(0, dtype=bool)
    with np.errstate(all="ignore"):
        if _general_ok(robot, T, bound):
            return np.ones(n, dtype=bool)
    if n == 1:
        return np.zeros(1, dtype=bool)
    if n <= _SPLIT_FLOOR:
        return np.array([_general_ok(robot, T[i : i + 1], bound) for i in range(n)])
    half = n // 2
    return np.concatenate(
        [_split_mask(robot, T[:half], bound), _split_mask(robot, T[half:], bound)]
    )


def check_rotations(orientations: Any) -> np.ndarray:
    """Rotation matrices (K, 3, 3), each checked; a single (3, 3) gives K = 1."""
    try:
        R = np.asarray(orientations, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"orientations must be rotation matrices, got {orientations!r}") from None
    if R.shape == (3, 3):
        R = R[None]
    if R.ndim != 3 or R.shape[1:] != (3, 3) or R.shape[0] == 0:
        raise InputError(f"orientations must be (3, 3) or (K, 3, 3), got shape {R.shape}")
    return np.array([check_rotation(r, f"orientation {k}") for k, r in enumerate(R)])
