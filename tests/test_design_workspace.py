"""Design studies, workspaces (issue 22 items 1): the volume against a dense Monte-Carlo
count written here, boundary points on a limit, named errors for empty workspaces."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot

from stewart_pin import EmptyWorkspaceError, InputError, StewartPinError, StewartRobot, design


def _own_feasible(robot, positions, R, bound):
    """Independent of stewart_pin.design: leg lengths |R p_i + t - b_i| in the stroke (the
    desktop preset has no U-joint limits), and the singularity measure under ``bound``."""
    desc = robot.description
    P = np.einsum("ij,kj->ki", R, desc.platform_points)  # (6, 3)
    legs = positions[:, None, :] + P[None] - desc.base_points[None]
    q = np.linalg.norm(legs, axis=-1)
    lo, hi = desc.stroke
    ok = np.all((q >= lo) & (q <= hi), axis=1)
    T = np.tile(np.eye(4), (int(ok.sum()), 1, 1))
    T[:, :3, :3] = R
    T[:, :3, 3] = positions[ok]
    ok[ok] = np.asarray(robot.condition_number(T)) <= bound
    return ok


@pytest.fixture(scope="module")
def desktop_ws():
    robot = get_robot("desktop")
    R = pin.rpy.rpyToMatrix(0.05, -0.03, 0.1) @ robot.home_pose[:3, :3]
    return robot, R, design.workspace(robot, orientation=R, resolution=36, rng=1)


def test_volume_matches_a_dense_monte_carlo_count(desktop_ws):
    robot, R, ws = desktop_ws
    assert robot.description.u_joint_limits is None
    assert not ws.touches_box
    rng = np.random.default_rng(7)
    n = 400_000
    pts = rng.uniform(ws.lower, ws.upper, (n, 3))
    ok = _own_feasible(robot, pts, R, robot.max_condition)
    ok &= pts[:, 2] > 0  # the platform above the base (the mirror assembly excluded)
    box = float(np.prod(ws.upper - ws.lower))
    p = ok.mean()
    v_mc, se_mc = box * p, box * np.sqrt(p * (1 - p) / n)
    assert ws.volume > 0 and 0 < ws.volume_error < 0.05 * ws.volume
    assert abs(ws.volume - v_mc) <= 3.0 * np.hypot(ws.volume_error, se_mc), (
        ws.volume,
        ws.volume_error,
        v_mc,
        se_mc,
    )


def test_boundary_points_lie_on_a_limit(desktop_ws):
    robot, R, ws = desktop_ws
    b = ws.boundary()
    desc = robot.description
    P = np.einsum("ij,kj->ki", R, desc.platform_points)
    q = np.linalg.norm(b[:, None, :] + P[None] - desc.base_points[None], axis=-1)
    lo, hi = desc.stroke
    T = np.tile(np.eye(4), (len(b), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, b
    c = np.asarray(robot.condition_number(T))
    # distance to the nearest limit: a stroke end [m], or the measure bound (relative)
    stroke_gap = np.minimum(np.abs(q - lo), np.abs(q - hi)).min(axis=1)
    cond_gap = np.abs(c - robot.max_condition) / robot.max_condition
    assert np.all(np.minimum(stroke_gap, cond_gap) <= 1e-6), (stroke_gap, cond_gap)
    # and inside: every stroke satisfied to the tolerance
    assert np.all((q >= lo - 1e-9) & (q <= hi + 1e-9))


def test_slice_and_orientation_and_dexterous_workspaces(desktop_ws):
    robot, _, ws = desktop_ws
    mask, extent = ws.slice(2)
    assert mask.shape == (ws.shape[0], ws.shape[1]) and mask.any() and extent[1] > extent[0]
    ow = design.orientation_workspace(robot, max_angle=0.5, resolution=12)
    assert 0 < ow.volume <= 1.0**3 + 1e-12
    Rs = np.array([pin.rpy.rpyToMatrix(0, 0, a) @ robot.home_pose[:3, :3] for a in (-0.1, 0.1)])
    dw = design.dexterous_workspace(robot, Rs, resolution=20)
    w0 = design.workspace(robot, resolution=20)
    assert 0 < dw.volume < w0.volume


def test_empty_workspaces_are_named_errors():
    robot = get_robot("desktop")
    flipped = pin.rpy.rpyToMatrix(np.pi, 0, 0) @ robot.home_pose[:3, :3]
    with pytest.raises(EmptyWorkspaceError, match="home position"):
        design.workspace(robot, orientation=flipped)
    with pytest.raises(EmptyWorkspaceError):
        design.dexterous_workspace(robot, [robot.home_pose[:3, :3], flipped])
    far = robot.home_pose[:3, 3] + [0, 0, 10.0]
    with pytest.raises(EmptyWorkspaceError):
        design.workspace(robot, box=(far - 0.01, far + 0.01))
    with pytest.raises(InputError):
        design.workspace(robot, resolution=1)


def test_feasible_mask_agrees_with_the_checked_calls():
    """The mask is True exactly where inverse geometry with limits and the measure pass."""
    robot = get_robot("desktop")
    rng = np.random.default_rng(3)
    T = np.tile(robot.home_pose, (300, 1, 1))
    T[:, :3, 3] += rng.uniform(-0.06, 0.06, (300, 3))
    mask = design.feasible(robot, T)
    for k in range(300):
        try:
            robot.inverse_geometry(T[k])
            ok = robot.condition_number(T[k]) <= robot.max_condition
        except StewartPinError:
            ok = False
        assert mask[k] == ok, k
    assert 0 < mask.sum() < 300


def test_general_legs_mask_and_workspace():
    """A 6-RUS: the mask agrees with the checked calls (inverse geometry with the joint
    limits, the parallel singularity), and its workspace is a finite non-empty volume."""
    robot = StewartRobot.from_preset("rus")
    rng = np.random.default_rng(4)
    T = np.tile(robot.home_pose, (60, 1, 1))
    T[:, :3, 3] += rng.uniform(-0.05, 0.05, (60, 3))
    mask = design.feasible(robot, T)
    for k in range(60):
        try:
            robot.inverse_geometry(T[k])
            robot.jacobian(T[k])
            ok = True
        except StewartPinError:
            ok = False
        assert mask[k] == ok, k
    assert 0 < mask.sum() < 60
    ws = design.workspace(robot, resolution=8)
    assert ws.volume > 0 and np.isfinite(ws.volume_error)


def test_segment_distance_against_a_dense_grid():
    rng = np.random.default_rng(11)
    P = rng.normal(size=(40, 4, 3))
    P[0, 1] = P[0, 0]  # a point against a segment
    P[1, 3] = P[1, 2]
    P[2, 1], P[2, 3] = P[2, 0], P[2, 2]  # two points
    P[3, 2:] = P[3, :2] + [0.3, 0.0, 0.0]  # parallel segments
    d = design.segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
    s = np.linspace(0, 1, 401)
    for k in range(40):
        a = P[k, 0] + s[:, None] * (P[k, 1] - P[k, 0])
        b = P[k, 2] + s[:, None] * (P[k, 3] - P[k, 2])
        brute = np.linalg.norm(a[:, None] - b[None], axis=-1).min()
        assert d[k] <= brute + 1e-12
        assert brute - d[k] <= 2e-2 * np.abs(P[k]).max()  # the grid's resolution


def test_leg_interference_shrinks_the_workspace():
    robot = get_robot("desktop")
    home = robot.home_pose
    d0 = design.leg_distance(robot, home)[0]
    desc = robot.description
    P = desc.platform_points @ home[:3, :3].T + home[:3, 3]
    own = min(
        design.segment_distance(desc.base_points[i], P[i], desc.base_points[j], P[j])
        for i in range(6)
        for j in range(i + 1, 6)
    )
    assert d0 == pytest.approx(own)
    w = design.workspace(robot, resolution=16)
    # the legs come closest (at their base ends) at some positions: a clearance between
    # that and the home pose's removes those
    lowest = design.leg_distance(robot, _poses_at(w.inside_points, home)).min()
    assert lowest < d0
    gap = 0.5 * (lowest + d0)
    w_gap = design.workspace(robot, resolution=16, min_leg_distance=gap)
    assert 0 < w_gap.volume < w.volume
    assert np.all(design.leg_distance(robot, _poses_at(w_gap.inside_points, home)) >= gap)
    assert not design.feasible(robot, home, min_leg_distance=1.01 * d0)[0]


def _poses_at(points, home):
    T = np.tile(home, (len(points), 1, 1))
    T[:, :3, 3] = points
    return T


def test_orientation_workspace_volume_matches_a_monte_carlo_count():
    """Roll, pitch, yaw (R = Rz Ry Rx R_home) at the home position: the volume [rad^3]
    against a uniform count with the feasibility written here; the set is connected to
    the home orientation, and the box small enough that it is all of it."""
    robot = get_robot("desktop")
    ow = design.orientation_workspace(robot, max_angle=0.35, resolution=20, rng=2)
    rng = np.random.default_rng(8)
    n = 60_000
    rpy = rng.uniform(-0.35, 0.35, (n, 3))
    home = robot.home_pose
    ok = np.zeros(n, dtype=bool)
    for k in range(0, n, 5000):
        R = np.array([pin.rpy.rpyToMatrix(*r) for r in rpy[k : k + 5000]]) @ home[:3, :3]
        desc = robot.description
        P = np.einsum("nij,kj->nki", R, desc.platform_points) + home[:3, 3]
        q = np.linalg.norm(P - desc.base_points, axis=-1)
        lo, hi = desc.stroke
        good = np.all((q >= lo) & (q <= hi), axis=1)
        T = np.tile(home, (int(good.sum()), 1, 1))
        T[:, :3, :3] = R[good]
        good[good] = np.asarray(robot.condition_number(T)) <= robot.max_condition
        ok[k : k + 5000] = good
    box = 0.7**3
    p = ok.mean()
    v_mc, se_mc = box * p, box * np.sqrt(p * (1 - p) / n)
    assert ow.feasible.sum() == ow.inside.sum()  # one component in this box
    assert abs(ow.volume - v_mc) <= 3.0 * np.hypot(ow.volume_error, se_mc), (ow.volume, v_mc)
