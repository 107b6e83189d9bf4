"""Inverse geometric model (paper section II); the forward one is in :mod:`.forward_geometry`.

Every function works on batches: poses ``(N, 4, 4)`` give leg values ``(N, 6, 3)``.

Inverse geometry of leg i. With ``u = R1_i^T (P_i - B_i) / q3i`` (the leg direction in
frame 1i at q1i = 0), the MDH chain gives ``u = [cos q1 sin q2, sin q1 sin q2, -cos q2]``,
so ``q2i = atan2(hypot(u_x, u_y), -u_z)``, ``q1i = atan2(u_y, u_x)``, ``q3i = |B_i P_i|``.
The U-joint has a second solution ``(q1i + pi, -q2i)`` reaching the same direction; it
differs physically when the links' inertia is not symmetric about the leg. The default
branch, used throughout, has ``q2i`` in ``(0, pi)`` and ``q1i`` in ``(-pi, pi]``.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from stewart_pin._checks import check_poses, in_batch
from stewart_pin._typing import ArrayLike, FloatArray, JointValues, Poses
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import (
    JointLimitError,
    SingularityError,
    StrokeLimitError,
)

#: A leg is singular (first U-joint axis along the leg) when ``sin q2i`` falls below this.
#: Near that singularity the leg's Cartesian inertia and velocity terms grow like
#: ``1 / sin^2 q2`` and ``1 / sin^3 q2``, and the direct dynamic model loses accuracy
#: fast: the two backends agree to 1e-11 at 0.02, 2e-10 at 0.01, 1e-9 at 6e-3, 2e-8 at
#: 3e-3 and 7e-3 at 1e-4 (worst of the sweeps of ``tests/test_singularities.py``, run as a
#: script with ``--beyond``).
LEG_SINGULARITY_SIN = 2e-2
#: A leg shorter than this fraction of the robot's characteristic length
#: (:func:`characteristic_length`, the platform radius) is singular: B_i and P_i nearly
#: coincide and its joint rates grow like ``1 / q3``; the backends agree to 2e-12 at 5 %,
#: 6e-11 at 2 %, 2e-9 at 1 % and 1e-5 at 0.1 % (same sweeps).
LEG_MIN_LENGTH_RATIO = 5e-2


#: Per-robot constants computed once: descriptions are immutable (read-only arrays).
_LENGTHS: weakref.WeakKeyDictionary[Any, float] = weakref.WeakKeyDictionary()


def characteristic_length(desc: RobotDescription) -> float:
    """The robot's characteristic length [m]: its platform radius, the mean distance of the
    platform attachment points P_i from their centroid (independent of where Fp is placed;
    the base radius :attr:`RobotDescription.size` if the P_i coincide).

    It makes the singularity measures unit-free: the angular columns of Jp^-1 are divided
    by it (:func:`stewart_pin.kinematics.jacobians.condition_number`) and the shortest leg is a
    fraction of it (:data:`LEG_MIN_LENGTH_RATIO`). Computed once per description (they are
    immutable) when the description can be weakly referenced and hashed.
    """
    try:
        return _LENGTHS[desc]
    except KeyError:
        length = _characteristic_length(desc)
        _LENGTHS[desc] = length
        return length
    except TypeError:  # not hashable or not weakly referenceable: compute each time
        return _characteristic_length(desc)


def _characteristic_length(desc: RobotDescription) -> float:
    P = desc.platform_points
    radius = float(np.linalg.norm(P - P.mean(axis=0), axis=1).mean())
    return radius if radius > 0.0 else max(float(desc.size), np.finfo(float).tiny)


def platform_points_in_base(desc: RobotDescription, poses: Poses) -> FloatArray:
    """``P_i`` in F0 for a batch of poses: shape (N, 6, 3) [m]."""
    R, p = poses[:, :3, :3], poses[:, :3, 3]
    return np.einsum("nij,kj->nki", R, desc.platform_points) + p[:, None, :]


def leg_vectors(desc: RobotDescription, poses: Poses) -> tuple[FloatArray, FloatArray]:
    """``(B_i P_i, L_i = O_p P_i)`` in F0, each shape (N, 6, 3) [m]."""
    R = poses[:, :3, :3]
    L = np.einsum("nij,kj->nki", R, desc.platform_points)
    return L + poses[:, None, :3, 3] - desc.base_points, L


def leg_lengths(desc: RobotDescription, poses: ArrayLike) -> FloatArray:
    """Leg lengths ``q3i = |B_i P_i|`` [m], shape (6,) or (N, 6)."""
    T, batched = check_poses(poses)
    lengths = np.linalg.norm(leg_vectors(desc, T)[0], axis=-1)
    return lengths if batched else lengths[0]


def inverse_geometry_batch(
    desc: RobotDescription,
    poses: Poses,
    check_limits: bool = True,
    vectors: FloatArray | None = None,
) -> FloatArray:
    """The 18 leg joint values for validated poses ``(N, 4, 4)``: shape (N, 6, 3).

    ``vectors``: the poses' ``B_i P_i`` (N, 6, 3) when the caller has them already
    (:func:`leg_vectors`), so that they are not computed again.

    Raises:
        StrokeLimitError: a leg length outside the stroke (when ``check_limits``).
        JointLimitError: a U-joint angle outside ``desc.u_joint_limits`` (when set).
        SingularityError: a leg along its first U-joint axis (``sin q2i`` below
            :data:`LEG_SINGULARITY_SIN`) or nearly zero-length (:data:`LEG_MIN_LENGTH_RATIO`).
    """
    d = leg_vectors(desc, poses)[0] if vectors is None else vectors
    q3 = np.linalg.norm(d, axis=-1)
    min_length = LEG_MIN_LENGTH_RATIO * characteristic_length(desc)
    short = ~(q3 >= min_length)
    if np.any(short):
        n, k = np.argwhere(short)[0]  # the first failing state (its first leg)
        raise in_batch(
            SingularityError(
                f"leg {k + 1} has zero length or nearly ({q3[n, k]:.3g} m < {min_length:.3g} m, "
                f"{LEG_MIN_LENGTH_RATIO:g} of the platform radius): its U-joint angles are "
                "ill-defined there",
                float(q3[n, k]),
                min_length,
                leg=int(k + 1),
            ),
            short,
        )
    u = np.einsum("kji,nkj->nki", desc.leg_base_rotations, d) / q3[..., None]
    q = np.empty(d.shape)
    q[..., 0] = np.arctan2(u[..., 1], u[..., 0])
    sin_q2 = np.hypot(u[..., 0], u[..., 1])
    # atan2, not arccos(-u_z): arccos loses the relative accuracy eps / sin^2 q2 near 0, pi.
    q[..., 1] = np.arctan2(sin_q2, -u[..., 2])
    q[..., 2] = q3
    along = ~(sin_q2 >= LEG_SINGULARITY_SIN)
    if np.any(along):
        n, k = np.argwhere(along)[0]  # the first failing state (its first leg)
        raise in_batch(
            SingularityError(
                f"leg {k + 1} lies along its first U-joint axis or too close to it "
                f"(sin q2{k + 1} = {sin_q2[n, k]:.3g} < {LEG_SINGULARITY_SIN:g}): its Jacobian "
                "is singular or too ill-conditioned there for an accurate model",
                float(sin_q2[n, k]),
                LEG_SINGULARITY_SIN,
                leg=int(k + 1),
            ),
            along,
        )
    if check_limits:
        check_leg_limits(desc, q)
    return q


def check_leg_limits(desc: RobotDescription, q: JointValues) -> None:
    """Raise :class:`StrokeLimitError` / :class:`JointLimitError` for leg values (N, 6, 3),
    naming the first failing state's first failing leg, and how many states fail."""
    lo, hi = desc.ideal_stroke("the 6-UPS leg limit check")
    bad = (q[..., 2] < lo) | (q[..., 2] > hi)
    if np.any(bad):
        n, k = np.argwhere(bad)[0]
        raise in_batch(StrokeLimitError(int(k + 1), float(q[n, k, 2]), float(lo), float(hi)), bad)
    if desc.u_joint_limits is not None:
        lim = desc.u_joint_limits
        for j in range(2):
            bad = (q[..., j] < lim[:, j, 0]) | (q[..., j] > lim[:, j, 1])
            if np.any(bad):
                n, k = np.argwhere(bad)[0]
                raise in_batch(
                    JointLimitError(
                        int(k + 1),
                        j + 1,
                        float(q[n, k, j]),
                        float(lim[k, j, 0]),
                        float(lim[k, j, 1]),
                    ),
                    bad,
                )


def inverse_geometry(
    desc: RobotDescription, pose: ArrayLike, check_limits: bool = True
) -> FloatArray:
    """Leg joint values for one pose (4x4 or ``pin.SE3``) -> (6, 3), or a batch -> (N, 6, 3).

    Columns ``q1i, q2i`` [rad] (default U-joint branch) and ``q3i`` [m].
    """
    T, batched = check_poses(pose)
    q = inverse_geometry_batch(desc, T, check_limits)
    return q if batched else q[0]


def admissible_poses(desc: RobotDescription, poses: Poses) -> np.ndarray:
    """(N,) bool: the validated poses (N, 4, 4) that :func:`inverse_geometry_batch` (with
    ``check_limits``) accepts, decided for the whole batch at once: its length and
    serial-singularity tests (the same arithmetic), then its limits on the values of the
    poses that pass them."""
    d = leg_vectors(desc, poses)[0]
    q3 = np.linalg.norm(d, axis=-1)
    ok = np.all(q3 >= LEG_MIN_LENGTH_RATIO * characteristic_length(desc), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):  # a zero-length leg: refused above
        u = np.einsum("kji,nkj->nki", desc.leg_base_rotations, d) / q3[..., None]
    ok &= np.all(np.hypot(u[..., 0], u[..., 1]) >= LEG_SINGULARITY_SIN, axis=1)
    fine = np.flatnonzero(ok)
    q = inverse_geometry_batch(desc, poses[fine], check_limits=False, vectors=d[fine])
    ok[fine] = ~_outside_leg_limits(desc, q)
    return ok


def _outside_leg_limits(desc: RobotDescription, q: JointValues) -> np.ndarray:
    """(N,) bool: leg values (N, 6, 3) outside the stroke or the U-joint limits (the
    tests of :func:`check_leg_limits`)."""
    lo, hi = desc.ideal_stroke("the 6-UPS leg limit check")
    bad = np.any((q[..., 2] < lo) | (q[..., 2] > hi), axis=1)
    if desc.u_joint_limits is not None:
        lim = desc.u_joint_limits
        for j in range(2):
            bad |= np.any((q[..., j] < lim[:, j, 0]) | (q[..., j] > lim[:, j, 1]), axis=1)
    return bad
