"""Singularity-free regions: the largest sphere and cube around a pose in which the
singularity measure stays under a bound, over a set of orientations; the measure's map
on slices.

The measure is :meth:`StewartRobot.condition_number` (the unit-free condition number of
Jp^-1); it is taken as infinite where a general leg cannot reach (the region ends
there). Limits other than the measure (strokes, joint ranges) do not bound these regions:
they are :func:`~stewart_pin.design.workspace.workspace`'s.

The sphere's radius is the distance from the centre to the nearest point where the
measure reaches the bound: found along rays (a Fibonacci set of directions, a march then
a bisection to ``tol``), the nearest crossing then refined by Nelder-Mead over the ray's
direction. The cube's half-side is the smallest infinity norm of the crossings found
(a sampled estimate).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._checks import check_pose, check_scalar
from stewart_pin.design.feasibility import check_rotations, condition_bound
from stewart_pin.exceptions import InputError, SingularityError, StewartPinError


def measure(robot: Any, poses: np.ndarray) -> np.ndarray:
    """The singularity measure (N,) at poses (N, 4, 4), ``inf`` where it cannot be
    computed (a general leg that cannot reach, or at a serial singularity)."""
    T = np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    return _measure(robot, T)


def _measure(robot: Any, T: np.ndarray) -> np.ndarray:
    """:func:`measure` by the robot's own batched call, the batch halved where it raises
    until the offending states are isolated (``inf``)."""
    try:
        with np.errstate(all="ignore"):
            c = np.asarray(robot.condition_number(T), dtype=float).reshape(-1)
        return np.where(np.isfinite(c), c, np.inf)
    except StewartPinError:
        if T.shape[0] == 1:
            return np.array([np.inf])
    half = T.shape[0] // 2
    return np.concatenate([_measure(robot, T[:half]), _measure(robot, T[half:])])


@dataclass(frozen=True)
class SingularityFreeRegion:
    """The largest sphere and cube around ``center`` (3,) [m] free of the measure's bound.

    Attributes:
        radius: the sphere's radius [m]; ``touch``: the nearest point (3,) where the
            measure reaches the bound, at rotation ``touch_orientation`` (3, 3);
            ``half_side``: the cube's half-side [m] (axes of F0); ``bounded``: a
            crossing found within ``reach`` (else ``radius == reach``).
    """

    center: np.ndarray
    radius: float
    half_side: float
    touch: np.ndarray
    touch_orientation: np.ndarray
    bound: float
    bounded: bool


def _fibonacci(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z**2)
    phi = np.pi * (1.0 + 5**0.5) * k
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _crossings(
    robot: Any,
    center: np.ndarray,
    R: np.ndarray,
    d: np.ndarray,
    reach: float,
    bound: float,
    steps: int,
    tol: float,
) -> np.ndarray:
    """Distance (K,) along each direction d (K, 3) to the first point where the measure
    exceeds ``bound`` at rotation R (``inf`` where none within ``reach``)."""

    def bad(p: np.ndarray) -> np.ndarray:
        T = np.tile(np.eye(4), (p.shape[0], 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R, p
        return np.asarray(~(measure(robot, T) <= bound))

    ts = np.linspace(0.0, reach, steps + 1)
    pts = center + ts[None, :, None] * d[:, None, :]
    over = bad(pts.reshape(-1, 3)).reshape(len(d), -1)
    hit = over.any(axis=1)
    first = np.argmax(over, axis=1)
    a = ts[np.maximum(first - 1, 0)]
    b = ts[first]
    while np.any(hit & (b - a > tol)):
        m = 0.5 * (a + b)
        o = bad(center + m[:, None] * d)
        a = np.where(hit & ~o, m, a)
        b = np.where(hit & o, m, b)
    return np.where(hit, b, np.inf)


def singularity_free_region(
    robot: Any,
    pose: Any = None,
    orientations: Any = None,
    *,
    max_condition: float | None = None,
    reach: float | None = None,
    directions: int = 400,
    steps: int = 200,
    tol: float = 1e-9,
) -> SingularityFreeRegion:
    """The largest sphere (and cube) around the position of ``pose`` (default home) in
    which the measure stays at most ``max_condition`` (default ``robot.max_condition``)
    at every rotation of ``orientations`` (K, 3, 3) (default the pose's own).

    Args:
        reach: the largest radius searched [m] (default the robot's mid-stroke, or its
            size for general legs).
        directions: rays (a Fibonacci set); steps: march points per ray; tol: the
            bisection's tolerance [m].

    Raises:
        SingularityError: the measure at the centre already exceeds the bound.
    """
    from scipy.optimize import minimize

    T0 = robot.home_pose if pose is None else check_pose(pose)
    center = T0[:3, 3].copy()
    Rs = check_rotations(T0[:3, :3] if orientations is None else orientations)
    bound = condition_bound(robot, max_condition)
    desc = robot.description
    if reach is None:
        reach = float(desc.stroke_mid if desc.stroke is not None else desc.size)
    reach = check_scalar(reach, "reach", positive=True, unit="m")
    if isinstance(directions, bool) or not isinstance(directions, int) or directions < 6:
        raise InputError(f"directions must be an integer >= 6, got {directions!r}")
    steps = int(check_scalar(steps, "steps", positive=True, integer=True))
    tol = check_scalar(tol, "tol", positive=True, unit="m")
    T = np.tile(np.eye(4), (len(Rs), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = Rs, center
    c0 = measure(robot, T)
    if not np.all(c0 <= bound):
        worst = int(np.argmax(~(c0 <= bound)))
        raise SingularityError(
            f"the singularity measure at the centre is {c0[worst]:.6g} > {bound:g} "
            f"(orientation {worst}): no singularity-free region around it",
            float(c0[worst]),
            bound,
            leg=None,
        )
    d = np.vstack([_fibonacci(directions), np.eye(3), -np.eye(3)])
    per = np.array([_crossings(robot, center, R, d, reach, bound, steps, tol) for R in Rs])
    finite = np.isfinite(per)
    pts = center + np.where(finite, per, 0.0)[..., None] * d[None]  # (K, D, 3)
    if not finite.any():
        # no crossing within the searched sphere: the cube inscribed in it (its corners
        # at ``reach``, the largest distance probed)
        return SingularityFreeRegion(
            center, reach, reach / np.sqrt(3.0), center, Rs[0], bound, False
        )
    k, j = (int(i) for i in np.unravel_index(int(np.argmin(per)), per.shape))
    half_side = float(np.min(np.abs(pts[finite] - center).max(axis=-1)))

    def dist(angles: np.ndarray) -> float:
        th, ph = angles
        u = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        r = _crossings(robot, center, Rs[k], u[None], reach, bound, steps, tol)[0]
        return float(min(r, reach))

    u0 = d[j]
    x0 = np.array([np.arccos(np.clip(u0[2], -1, 1)), np.arctan2(u0[1], u0[0])])
    step = np.pi / np.sqrt(directions)
    res = minimize(
        dist,
        x0,
        method="Nelder-Mead",
        options={
            "xatol": 1e-7,
            "fatol": tol,
            "initial_simplex": [x0, x0 + np.array([step, 0.0]), x0 + np.array([0.0, step])],
        },
    )
    radius = float(per[k, j])
    touch = pts[k, j]
    if res.fun < radius:
        th, ph = res.x
        u = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        radius = float(res.fun)
        touch = center + radius * u
    return SingularityFreeRegion(center, radius, half_side, touch, Rs[k], bound, True)


def singularity_map(
    robot: Any,
    orientation: Any = None,
    *,
    axis: int = 2,
    value: float | None = None,
    half_width: float | None = None,
    resolution: int = 60,
) -> tuple[np.ndarray, np.ndarray]:
    """The singularity measure on a slice of positions at rotation ``orientation`` (default
    the home orientation): the plane ``x_axis = value`` (default the home position's)
    over a square of half-width ``half_width`` [m] (default the mid-stroke) around the
    home position. Returns ``(measure (n, n), extent (4,))``, the other two axes in order,
    ``inf`` where it cannot be computed."""
    if axis not in (0, 1, 2):
        raise InputError(f"axis must be 0, 1 or 2, got {axis!r}")
    home = robot.home_pose
    R = home[:3, :3] if orientation is None else check_rotations(orientation)[0]
    desc = robot.description
    h = half_width
    if h is None:
        h = float(desc.stroke_mid if desc.stroke is not None else desc.size)
    h = check_scalar(h, "half_width", positive=True, unit="m")
    n = int(check_scalar(resolution, "resolution", positive=True, integer=True))
    a, b = (i for i in range(3) if i != axis)
    c = home[:3, 3]
    ua = np.linspace(c[a] - h, c[a] + h, n)
    ub = np.linspace(c[b] - h, c[b] + h, n)
    A, B = np.meshgrid(ua, ub, indexing="ij")
    p = np.tile(c, (n * n, 1))
    if value is not None:
        p[:, axis] = check_scalar(value, "value")
    p[:, a], p[:, b] = A.ravel(), B.ravel()
    T = np.tile(np.eye(4), (n * n, 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, p
    return measure(robot, T).reshape(n, n), np.array([ua[0], ua[-1], ub[0], ub[-1]])
