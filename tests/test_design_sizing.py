"""Design studies, actuator sizing (issue 22 item 3): speeds against finite differences
of the actuator positions, the optimiser's worst case at least as bad as dense sampling,
the dynamic capability against a bisection on the inverse dynamics."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache

from stewart_pin import EmptyWorkspaceError, InputError, design
from stewart_pin.design import sizing


def _trajectory(robot, t):
    """A smooth motion of the platform around home: poses (N,4,4), twists, accels."""
    home = robot.home_pose
    T = np.tile(home, (len(t), 1, 1))
    T[:, 0, 3] += 0.01 * np.sin(3 * t)
    T[:, 2, 3] += 0.005 * np.sin(2 * t)
    T[:, :3, :3] = (
        np.array([pin.exp3(np.array([0, 0, 0.05 * np.sin(t_)])) for t_ in t]) @ home[:3, :3]
    )
    V = np.zeros((len(t), 6))
    V[:, 0], V[:, 2], V[:, 5] = 0.03 * np.cos(3 * t), 0.01 * np.cos(2 * t), 0.05 * np.cos(t)
    A = np.zeros((len(t), 6))
    A[:, 0], A[:, 2], A[:, 5] = -0.09 * np.sin(3 * t), -0.02 * np.sin(2 * t), -0.05 * np.sin(t)
    return T, V, A


def test_loads_speeds_match_finite_differences_and_the_table(tmp_path):
    robot = get_robot("desktop")
    t = np.linspace(0, 2, 41)
    loads = design.actuator_loads(robot, *_trajectory(robot, t))
    h = 1e-6
    qp = robot.actuator_positions(_trajectory(robot, t + h)[0])
    qm = robot.actuator_positions(_trajectory(robot, t - h)[0])
    np.testing.assert_allclose(loads.speeds, (qp - qm) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(loads.powers, loads.efforts * loads.speeds)
    rows = loads.table()
    assert [r["actuator"] for r in rows] == [1, 2, 3, 4, 5, 6]
    for i, r in enumerate(rows):
        g = loads.efforts[:, i]
        assert r["peak_effort"] == pytest.approx(np.abs(g).max())
        assert r["rms_effort"] == pytest.approx(np.sqrt(np.mean(g**2)))
    paths = sizing.write_report(tmp_path, loads=loads)
    assert json.loads((tmp_path / "report.json").read_text())["loads"][0]["actuator"] == 1
    assert (tmp_path / "loads.csv").read_text().startswith("actuator,peak_effort")
    assert len(paths) == 2
    pytest.importorskip("matplotlib")
    paths = sizing.write_report(tmp_path / "h", loads=loads, html=True)
    page = (tmp_path / "h" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 1 and page.count("<tr>") == 7


def test_worst_case_at_least_as_bad_as_dense_sampling():
    robot = get_robot("desktop")
    box = design.StateBox(
        translation=0.01, rotation=0.05, speed=0.1, angular_speed=0.5, accel=2.0,
        angular_accel=5.0,
    )  # fmt: skip
    worst = design.worst_case(robot, box, samples=200, actuators=[1, 4], rng=0)
    dense = box.sample(robot, 20_000, rng=99)
    g = np.asarray(robot.inverse_dynamics(*box.states(robot, dense)))
    for w in worst:
        k = w.actuator - 1
        assert abs(w.effort) >= np.abs(g[:, k]).max(), (w.actuator, w.effort)
        assert abs(w.effort) >= w.sampled
        # the state is in the box and feasible, and the effort is that state's
        assert design.feasible(robot, w.pose[None])[0]
        assert np.all(np.abs(w.accel[:3]) <= 2.0 + 1e-12)
        g_w = robot.inverse_dynamics(w.pose, w.twist, w.accel)[k]
        assert g_w == pytest.approx(w.effort, rel=1e-12)


def test_dynamic_capability_against_a_bisection():
    robot = get_robot("desktop")
    home = robot.home_pose
    g0 = robot.inverse_dynamics(home, np.zeros(6), np.zeros(6))
    lim = 3.0 * np.abs(g0).max() * np.ones(6)
    dirs = np.array([[1, 0, 0], [0, 0, 1], [0, 0, -1], [1, 1, 0.5]], float)
    cap = design.dynamic_capability(robot, lim, directions=dirs)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]

    def ok(s, d):
        a = np.concatenate([s * d, np.zeros(3)])
        return np.all(np.abs(robot.inverse_dynamics(home, np.zeros(6), a)) <= lim)

    for d, s in zip(dirs, cap.accel, strict=True):
        lo, hi = 0.0, 1.0
        while ok(hi, d):
            hi *= 2
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if ok(mid, d) else (lo, mid)
        assert s == pytest.approx(lo, rel=1e-6)
    free = design.dynamic_capability(robot, lim, directions=dirs, free_rotation=True)
    assert np.all(free.accel >= cap.accel - 1e-9)
    with pytest.raises(InputError, match="effort limits"):
        design.dynamic_capability(robot)
    with pytest.raises(InputError, match="cannot hold"):
        design.dynamic_capability(robot, 0.5 * np.abs(g0).max())


@pytest.mark.parametrize("name", ["desktop", "rus"])
@pytest.mark.parametrize("kind", ["force", "moment"])
def test_wrench_capability_by_virtual_work_and_bisection(name, kind):
    """The efforts of the largest wrench, less those holding the robot at rest, do the
    virtual work of the wrench on every small displacement: checked with central
    differences of the actuator positions (inverse geometry, not the Jacobian); and a
    bisection on the efforts finds the same largest magnitude."""
    robot = get_robot(name)
    home = robot.home_pose
    g0 = robot.inverse_dynamics(home, np.zeros(6), np.zeros(6), backend="pinocchio")
    lim = 2.0 * np.abs(g0).max() * np.ones(6)
    dirs = np.array([[1, 0, 0], [0, 0, 1], [0, 0, -1], [1, -1, 0.5]], float)
    cap = design.wrench_capability(robot, lim, directions=dirs, kind=kind, backend="pinocchio")
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    assert np.all(cap.magnitude > 0)
    rng = np.random.default_rng(3)
    h = 1e-6
    # the efforts beyond g0 for a unit wrench along each direction, from the result
    for d, s in zip(dirs, cap.magnitude, strict=True):
        w = np.concatenate([d, np.zeros(3)] if kind == "force" else [np.zeros(3), d])
        K = np.linalg.inv(robot.inverse_jacobian(home).T)
        extra = K @ (s * w)
        assert np.max(np.abs(g0 + extra) / lim) == pytest.approx(1.0, rel=1e-9)
        for _ in range(3):  # virtual work with finite differences of the inverse geometry
            delta = rng.normal(size=6)
            q = []
            for sign in (1.0, -1.0):
                T = home.copy()
                T[:3, 3] += sign * h * delta[:3]
                T[:3, :3] = pin.exp3(sign * h * delta[3:]) @ home[:3, :3]
                q.append(robot.actuator_positions(T))
            dq = (q[0] - q[1]) / (2 * h)
            assert extra @ dq == pytest.approx(s * w @ delta, rel=1e-6, abs=1e-9 * s)
        lo, hi = 0.0, 2.0 * s + 1.0  # bisection on |g0 + K w t| <= lim
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if np.all(np.abs(g0 + K @ (mid * w)) <= lim) else (lo, mid)
        assert s == pytest.approx(lo, rel=1e-9)
    with pytest.raises(InputError, match="kind"):
        design.wrench_capability(robot, lim, kind="torque")
    with pytest.raises(InputError, match="cannot hold"):
        design.wrench_capability(robot, 0.5 * np.abs(g0).max(), backend="pinocchio")


def test_an_infeasible_state_box_is_a_named_error():
    robot = get_robot("desktop")
    box = design.StateBox(translation=1.0)
    with pytest.raises(EmptyWorkspaceError, match="feasible"):
        # displacements up to 1 m: about one draw in 10^4 is in the desktop's reach
        box.sample(robot, 2000, rng=0)
    with pytest.raises(InputError):
        _ = design.StateBox(translation=-1.0).half_widths


@pytest.fixture
def compile_cache(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)


def test_exact_gradient_matches_differences_and_worst_case(compile_cache):
    """The chain rule of the exact Jacobians (rotation chart exp(w) R_home) against
    central differences of the inverse dynamics, at a state away from home."""
    robot = get_robot("desktop")
    box = design.StateBox(0.01, 0.05, 0.1, 0.5, 2.0, 5.0)
    x = box.sample(robot, 1, rng=3)[0]
    for k in (0, 3):
        f, g = sizing._exact_value_and_gradient(robot, box, x, k, 1.0, 1e9)
        fd = np.empty(18)
        h = 1e-6
        for j in range(18):
            e = np.zeros(18)
            e[j] = h
            up = robot.inverse_dynamics(*box.states(robot, x + e))[0, k]
            dn = robot.inverse_dynamics(*box.states(robot, x - e))[0, k]
            fd[j] = -(up - dn) / (2 * h)
        assert f == pytest.approx(-robot.inverse_dynamics(*box.states(robot, x))[0, k])
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    worst = design.worst_case(robot, box, samples=100, actuators=[2], gradient="exact")
    dense = box.sample(robot, 5000, rng=99)
    g_dense = np.asarray(robot.inverse_dynamics(*box.states(robot, dense)))[:, 1]
    assert abs(worst[0].effort) >= np.abs(g_dense).max()


def test_bad_sample_counts_and_directions_are_named_errors():
    """``StateBox.sample(n=-1)`` returned one state; NaN directions failed inside scipy."""
    robot = get_robot("desktop")
    box = design.StateBox(translation=0.01, rotation=0.05)
    for n in (-1, 1.5, True):
        with pytest.raises(InputError, match="n"):
            box.sample(robot, n)
    for dirs in ([[np.nan, 0.0, 0.0]], [[np.inf, 1.0, 0.0]], "x", [[0.0, 0.0, 0.0]]):
        with pytest.raises(InputError, match="directions"):
            design.dynamic_capability(robot, 100.0, directions=dirs)
        with pytest.raises(InputError, match="directions"):
            design.wrench_capability(robot, 100.0, directions=dirs)
