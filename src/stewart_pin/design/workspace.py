"""Workspaces: the constant-orientation, orientation and dexterous workspaces of a robot.

Each is estimated on a jittered grid (stratified Monte Carlo): the box is cut into cells,
one uniformly drawn state per cell is tested (:func:`~stewart_pin.design.feasibility.feasible`),
and the set kept is the 6-connected component of feasible cells that holds the start (the
home position, or the home orientation): the platform above the base, never the mirror
assembly below it. The volume is the count times the cell volume; its one standard error
is the collapsed-strata estimate over pairs of cells along x, ``v sqrt(sum (y_a - y_b)^2)``
(``y`` the cell's 0/1 indicator, ``v`` the cell volume), which slightly overstates it.

Boundary points are found by bisection along rays from the start to a tolerance of
1e-9 of the box size: each lies on a limit (stroke, joint range, or the singularity
measure bound) within that tolerance.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar
from stewart_pin._extras import require
from stewart_pin.design.feasibility import (
    check_directions,
    check_distance,
    check_rotations,
    condition_bound,
    mask,
)
from stewart_pin.exceptions import EmptyWorkspaceError, InputError

#: Cells along the longest side of the box (default).
RESOLUTION = 40
#: Rays for the default box and :meth:`Workspace.boundary`: the 26 grid directions.
_DIRECTIONS = np.array(
    [
        (i, j, k)
        for i in (-1, 0, 1)
        for j in (-1, 0, 1)
        for k in (-1, 0, 1)
        if (i, j, k) != (0, 0, 0)
    ],
    dtype=float,
)
_DIRECTIONS /= np.linalg.norm(_DIRECTIONS, axis=1)[:, None]


@dataclass(frozen=True)
class Workspace:
    """A workspace estimated on a jittered grid (see the module docstring).

    Attributes:
        kind: ``"position"`` (constant orientation: coordinates x, y, z of O_p in F0 [m]),
            ``"orientation"`` (roll, pitch, yaw [rad] of ``R_rpy R_home`` at a position) or
            ``"dexterous"`` (positions [m] feasible at every orientation of a set).
        lower, upper: the box (3,) [m or rad].
        shape: cells per axis (3,).
        points: the drawn state of every cell, (nx, ny, nz, 3) [m or rad].
        feasible: every limit satisfied at the cell's state, (nx, ny, nz) bool.
        inside: the cells of the component holding the start, (nx, ny, nz) bool.
        volume: the component's volume [m^3 or rad^3]; volume_error: one standard error.
        start: the start point (3,) [m or rad].
        touches_box: a cell of the component on the box's faces (the box may cut it).
    """

    kind: str
    lower: np.ndarray
    upper: np.ndarray
    shape: tuple[int, int, int]
    points: np.ndarray
    feasible: np.ndarray
    inside: np.ndarray
    volume: float
    volume_error: float
    start: np.ndarray
    touches_box: bool
    _test: Callable[[np.ndarray], np.ndarray] = field(repr=False, compare=False)

    @property
    def cell(self) -> np.ndarray:
        """The cell's sides (3,) [m or rad]."""
        return (self.upper - self.lower) / np.array(self.shape)

    @property
    def inside_points(self) -> np.ndarray:
        """The states of the component's cells, (M, 3)."""
        return self.points[self.inside]

    def slice(self, axis: int = 2, value: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The component on the grid layer nearest ``value`` along ``axis`` (0, 1, 2;
        default the start's): ``(mask (n_a, n_b), extent (4,))`` with the other two axes
        in order and ``extent = [a_min, a_max, b_min, b_max]`` (for ``imshow``)."""
        if axis not in (0, 1, 2):
            raise InputError(f"axis must be 0, 1 or 2, got {axis!r}")
        v = self.start[axis] if value is None else check_scalar(value, "value")
        k = int(np.clip((v - self.lower[axis]) // self.cell[axis], 0, self.shape[axis] - 1))
        mask = np.take(self.inside, k, axis=axis)
        a, b = (i for i in range(3) if i != axis)
        extent = np.array([self.lower[a], self.upper[a], self.lower[b], self.upper[b]])
        return mask, extent

    def boundary(self, directions: Any = None, tol: float | None = None) -> np.ndarray:
        """Points (K, 3) on the boundary, one per direction (K, 3) (default the 26 grid
        directions) along the ray from the start: the last feasible point before the first
        infeasible one of a march at a quarter cell, refined by bisection to ``tol``
        (default 1e-9 of the box's diagonal). A ray that leaves the box feasible ends at
        the box's face."""
        d = check_directions(_DIRECTIONS if directions is None else directions)
        size = float(np.linalg.norm(self.upper - self.lower))
        tol = 1e-9 * size if tol is None else check_scalar(tol, "tol", positive=True)
        return _ray_boundary(self._test, self.start, d, self.lower, self.upper, tol)

    def plot_slice(self, axis: int = 2, value: float | None = None, ax: Any = None) -> Any:
        """The slice of :meth:`slice` as an image on a Matplotlib axes (created when
        ``ax`` is None); returns the axes (needs ``pip install "stewart-pin[viz]"``)."""
        (plt,) = require("the workspace slice plot", "viz", "matplotlib.pyplot")

        mask, extent = self.slice(axis, value)
        if ax is None:
            ax = plt.figure().add_subplot()
        ax.imshow(mask.T, origin="lower", extent=tuple(extent), aspect="equal", cmap="Blues")
        names = ("x", "y", "z") if self.kind != "orientation" else ("roll", "pitch", "yaw")
        a, b = (names[i] for i in range(3) if i != axis)
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.set_title(f"{self.kind} workspace, {names[axis]} slice")
        return ax


# ---------------------------------------------------------------------------- core
def _box(lower: Any, upper: Any) -> tuple[np.ndarray, np.ndarray]:
    lo = np.asarray(lower, dtype=float).reshape(-1)
    hi = np.asarray(upper, dtype=float).reshape(-1)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(np.r_[lo, hi])):
        raise InputError("the box must be two finite 3-vectors (lower, upper)")
    if not np.all(hi > lo):
        raise InputError(f"the box must have upper > lower on every axis, got {lo} .. {hi}")
    return lo, hi


def _shape(lo: np.ndarray, hi: np.ndarray, resolution: int) -> tuple[int, int, int]:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)):
        raise InputError(f"resolution must be an integer >= 2, got {resolution!r}")
    if resolution < 2:
        raise InputError(f"resolution must be an integer >= 2, got {resolution!r}")
    side = (hi - lo).max() / resolution
    n = np.maximum(2, np.ceil((hi - lo) / side - 1e-9)).astype(int)
    n[0] += n[0] % 2  # pairs of cells along x for the standard error
    return int(n[0]), int(n[1]), int(n[2])


def _march_limit(
    test: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    d: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    step: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per ray: the largest t inside the box ``t_box``, and a bracket ``(a, b)`` with
    ``start + a d`` feasible and ``start + b d`` infeasible (``b = inf`` if none found)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t_hi = np.where(d > 0, (hi - start) / d, np.where(d < 0, (lo - start) / d, np.inf))
    t_box = t_hi.min(axis=1)
    n = int(np.ceil(t_box.max() / step)) + 1
    ts = np.linspace(0.0, 1.0, n)[None, :] * t_box[:, None]  # (K, n)
    pts = start + ts[..., None] * d[:, None, :]
    ok = test(pts.reshape(-1, 3)).reshape(ts.shape)
    first_bad = np.where(~ok.all(axis=1), np.argmin(ok, axis=1), n)
    k = np.arange(len(d))
    a = np.where(first_bad > 0, ts[k, np.maximum(first_bad - 1, 0)], 0.0)
    b = np.where(first_bad < n, ts[k, np.minimum(first_bad, n - 1)], np.inf)
    return t_box, a, b


def _ray_boundary(
    test: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    d: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    tol: float,
) -> np.ndarray:
    step = float((hi - lo).max()) / (4 * RESOLUTION)
    t_box, a, b = _march_limit(test, start, d, lo, hi, step)
    open_ = np.isfinite(b)
    while np.any(open_ & (b - a > tol)):
        m = 0.5 * (a + b)
        ok = test(start + m[:, None] * d)
        a = np.where(open_ & ok, m, a)
        b = np.where(open_ & ~ok, m, b)
    t = np.where(open_, a, t_box)
    return start + t[:, None] * d


def _grid(
    kind: str,
    test: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    resolution: int,
    rng: np.random.Generator | int | None,
) -> Workspace:
    shape = _shape(lo, hi, resolution)
    cell = (hi - lo) / np.array(shape)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    idx = np.stack(np.meshgrid(*(np.arange(n) for n in shape), indexing="ij"), axis=-1)
    points = lo + (idx + gen.uniform(0.0, 1.0, idx.shape)) * cell
    ok = test(points.reshape(-1, 3)).reshape(shape)
    inside = _component(ok, points, start, kind)
    y = inside.astype(float)
    v = float(np.prod(cell))
    se = v * float(np.sqrt(np.sum((y[0::2] - y[1::2]) ** 2)))
    return Workspace(
        kind,
        lo,
        hi,
        shape,
        points,
        ok,
        inside,
        v * int(inside.sum()),
        se,
        start,
        bool(_faces(inside).any()),
        test,
    )


def _faces(inside: np.ndarray) -> np.ndarray:
    """Which faces of the box the component touches: (3, 2) bool, [axis, lower/upper]."""
    return np.array(
        [[np.take(inside, e, axis=a).any() for e in (0, -1)] for a in range(3)], dtype=bool
    )


def _grown_grid(
    kind: str,
    test: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    box: tuple[np.ndarray, np.ndarray],
    limit: tuple[np.ndarray, np.ndarray],
    resolution: int,
    rng: np.random.Generator | int | None,
) -> Workspace:
    """:func:`_grid` on the default box, widened by a quarter of its span on each face the
    component touches (within ``limit``), at most four times."""
    lo, hi = box
    for _ in range(4):
        ws = _grid(kind, test, start, lo, hi, resolution, rng)
        touch = _faces(ws.inside)
        grow = 0.25 * (hi - lo)
        new_lo = np.where(touch[:, 0], np.maximum(lo - grow, limit[0]), lo)
        new_hi = np.where(touch[:, 1], np.minimum(hi + grow, limit[1]), hi)
        if np.array_equal(new_lo, lo) and np.array_equal(new_hi, hi):
            return ws
        lo, hi = new_lo, new_hi
    return _grid(kind, test, start, lo, hi, resolution, rng)


def _component(ok: np.ndarray, points: np.ndarray, start: np.ndarray, kind: str) -> np.ndarray:
    """The 6-connected component of ``ok`` holding the feasible cell nearest ``start``
    (:class:`EmptyWorkspaceError` when no cell is feasible)."""
    from scipy import ndimage

    if not ok.any():
        raise EmptyWorkspaceError(
            f"the {kind} workspace is empty: no state of the box satisfies every limit; "
            "check the orientation set, the box and the singularity bound"
        )
    labels, _ = ndimage.label(ok)
    cand = np.argwhere(ok)
    dist = np.linalg.norm(points[ok] - start, axis=1)
    i, j, k = cand[int(np.argmin(dist))]
    return np.asarray(labels == labels[i, j, k])


def _poses(positions: np.ndarray, R: np.ndarray) -> np.ndarray:
    T = np.zeros((positions.shape[0], 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = positions
    T[:, 3, 3] = 1.0
    return T


def _positions(
    kind: str,
    test: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    reach: float,
    box: Sequence[Any] | None,
    resolution: int,
    rng: np.random.Generator | int | None,
) -> Workspace:
    """A position workspace on ``box``; by default on a box around the rays' extents from
    ``start`` (within ``reach`` [m] of it), padded by a quarter on every side and widened
    where the component touches it."""
    if box is not None:
        if isinstance(box, (str, bytes)) or len(box) != 2:
            raise InputError(f"box must be (lower (3,), upper (3,)), got {box!r}")
        return _grid(kind, test, start, *_box(*box), resolution, rng)
    limit = (start - reach, start + reach)
    pts = _ray_boundary(test, start, _DIRECTIONS, *limit, 1e-6 * reach)
    a, b = pts.min(axis=0), pts.max(axis=0)
    pad = 0.25 * (b - a) + 1e-3 * reach
    lo, hi = np.maximum(a - pad, limit[0]), np.minimum(b + pad, limit[1])
    return _grown_grid(kind, test, start, (lo, hi), limit, resolution, rng)


def _reach(robot: Any) -> float:
    """An upper bound of the distance of O_p from the home position [m] (legs' reach)."""
    desc = robot.description
    home = desc.home_pose
    P = desc.platform_points @ home[:3, :3].T + home[:3, 3]
    return float(2.0 * np.linalg.norm(P - desc.base_points, axis=1).max() + desc.size)


def _start_check(test: Callable[[np.ndarray], np.ndarray], start: np.ndarray, what: str) -> None:
    if not bool(test(start[None])[0]):
        raise EmptyWorkspaceError(
            f"{what} is not feasible (a limit or the singularity bound is violated there): "
            "the workspace connected to it is empty; choose a reachable orientation set"
        )


# ---------------------------------------------------------------------------- public
def workspace(
    robot: Any,
    orientation: Any = None,
    *,
    box: Sequence[Any] | None = None,
    resolution: int = RESOLUTION,
    max_condition: float | None = None,
    min_leg_distance: float | None = None,
    rng: np.random.Generator | int | None = 0,
) -> Workspace:
    """The constant-orientation workspace: positions of O_p in F0 [m] where the platform,
    at rotation ``orientation`` (3x3, default the home pose's), satisfies every limit, the
    component connected to the home position.

    Args:
        robot: a :class:`~stewart_pin.robot.StewartRobot` (any architecture).
        orientation: 0Rp (3, 3).
        box: ``(lower (3,), upper (3,))`` [m]; default the rays' extents from the home
            position padded by a quarter, widened (up to four times) on the faces the
            component touches; ``touches_box`` says whether it still does.
        resolution: cells along the box's longest side (the cells are about cubic).
        max_condition: the singularity measure bound (default ``robot.max_condition``).
        min_leg_distance: with it, no two legs closer than this [m] (leg-leg
            interference, :func:`~stewart_pin.design.feasibility.leg_distance`); the other
            workspaces take it too.
        rng: the jitter's generator or seed (default 0: reproducible).

    Raises:
        EmptyWorkspaceError: the home position infeasible at ``orientation``.
    """
    home = robot.home_pose
    R = home[:3, :3] if orientation is None else check_rotations(orientation)[0]
    bound = condition_bound(robot, max_condition)
    gap = check_distance(min_leg_distance)

    def test(p: np.ndarray) -> np.ndarray:
        return mask(robot, _poses(p, R), bound, gap)

    start = home[:3, 3].copy()
    _start_check(test, start, "the home position at this orientation")
    return _positions("position", test, start, _reach(robot), box, resolution, rng)


def orientation_workspace(
    robot: Any,
    position: Any = None,
    *,
    max_angle: float = 0.6,
    resolution: int = 24,
    max_condition: float | None = None,
    min_leg_distance: float | None = None,
    rng: np.random.Generator | int | None = 0,
) -> Workspace:
    """The orientation workspace at ``position`` (3,) [m] of O_p in F0 (default the home
    position): the roll, pitch, yaw [rad] (``R = Rz(yaw) Ry(pitch) Rx(roll) R_home``,
    applied in F0) within ``max_angle`` [rad] of the home orientation where every limit
    holds, the component connected to the home orientation; ``volume`` in rad^3.

    Raises:
        EmptyWorkspaceError: the home orientation infeasible at ``position``.
    """
    from pinocchio import rpy

    home = robot.home_pose
    p = home[:3, 3] if position is None else np.asarray(position, dtype=float).reshape(3)
    a = check_scalar(max_angle, "max_angle", positive=True)
    bound = condition_bound(robot, max_condition)
    gap = check_distance(min_leg_distance)

    def test(rpys: np.ndarray) -> np.ndarray:
        R = np.array([rpy.rpyToMatrix(*r) for r in rpys]) @ home[:3, :3]
        return mask(robot, _poses(np.broadcast_to(p, rpys.shape), R), bound, gap)

    start = np.zeros(3)
    _start_check(test, start, "the home orientation at this position")
    lo, hi = -np.full(3, a), np.full(3, a)
    return _grid("orientation", test, start, lo, hi, resolution, rng)


def dexterous_workspace(
    robot: Any,
    orientations: Any,
    *,
    box: Sequence[Any] | None = None,
    resolution: int = RESOLUTION,
    max_condition: float | None = None,
    min_leg_distance: float | None = None,
    rng: np.random.Generator | int | None = 0,
) -> Workspace:
    """The dexterous workspace: positions of O_p [m] where the platform reaches every
    rotation 0Rp of ``orientations`` (K, 3, 3), connected to the home position.

    Raises:
        EmptyWorkspaceError: the home position misses an orientation of the set (an
            unreachable orientation set).
    """
    home = robot.home_pose
    Rs = check_rotations(orientations)
    bound = condition_bound(robot, max_condition)
    gap = check_distance(min_leg_distance)

    def test(p: np.ndarray) -> np.ndarray:
        n, k = p.shape[0], Rs.shape[0]
        T = _poses(np.repeat(p, k, axis=0), np.tile(Rs, (n, 1, 1)))
        return np.asarray(mask(robot, T, bound, gap).reshape(n, k).all(axis=1))

    start = home[:3, 3].copy()
    _start_check(test, start, "the home position at some orientation of the set")
    return _positions("dexterous", test, start, _reach(robot), box, resolution, rng)
