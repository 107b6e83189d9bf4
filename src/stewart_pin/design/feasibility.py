"""Per-state feasibility without exceptions: which poses satisfy every limit of a robot.

:func:`feasible` returns a boolean mask (N,) where the library's checked calls would raise
at the first offending state. A pose is feasible when every actuator is inside its stroke
or range, every passive joint inside its limits, no leg is at (or too near) a serial
singularity, and the singularity measure (:meth:`StewartRobot.condition_number`) is at
most the bound (default the robot's ``max_condition``).

The decision is the robot's (:meth:`StewartRobot.admissible_poses`, chosen by its
architecture in :mod:`stewart_pin.architectures`): the ideal 6-UPS in closed form on the
whole batch, general legs through
:func:`stewart_pin.kinematics.leg_chains.admissible_poses`, both the decision of the
checked calls on each state alone.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from stewart_pin._checks import check_poses, check_rotation, check_scalar
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics import leg_chains

#: States per chunk of the closed-form mask (bounds the temporary arrays: ~100 MB).
CHUNK = 100_000


def condition_bound(robot: Any, max_condition: float | None) -> float:
    """The singularity measure bound: ``max_condition`` checked (a number >= 1), or the
    robot's ``max_condition`` when None."""
    value = robot.max_condition if max_condition is None else max_condition
    bound = check_scalar(value, "max_condition", positive=True)
    if bound < 1.0:
        raise InputError(f"max_condition must be a number >= 1, got {value!r}")
    return bound


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
        ok = robot.admissible_poses(chunk, bound)  # the robot's architecture decides
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
    """Each leg as a polyline in F0, (N, 6, M, 3): its joint frames' origins and P_i (the
    legs as chains, every architecture; poses inside the legs' reach)."""
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


def check_directions(directions: Any) -> np.ndarray:
    """``directions`` (K, 3) as unit vectors: finite, non-zero, else :class:`InputError`."""
    try:
        D = np.asarray(directions, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"directions must be (K, 3) numbers, got {directions!r}") from None
    if D.ndim != 2 or D.shape[1] != 3 or not np.all(np.isfinite(D)):
        raise InputError(f"directions must be a finite (K, 3) array, got shape {D.shape}")
    norms = np.linalg.norm(D, axis=1)
    if np.any(norms == 0):
        raise InputError("directions must be non-zero")
    return D / norms[:, None]


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
