"""Time integration on SE(3): checked by physics (energy), by replaying the inverse
model's forces (the commanded motion must come back), and by the workspace guards."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot
from stewart_pin.simulation import SimulationError, SimulationResult, simulate


@pytest.fixture(scope="module")
def desktop() -> StewartRobot:
    return StewartRobot.from_preset("desktop")


def reference(robot: StewartRobot, t: float):
    """A multi-axis sinusoid: exact pose, twist and classical acceleration."""
    T0 = robot.home_pose
    s = robot.description.stroke_mid
    amp, om = np.array([0.06, -0.05, 0.04]) * s, np.array([3.0, 2.0, 4.0])
    p = T0[:3, 3] + amp * np.sin(om * t)
    v = amp * om * np.cos(om * t)
    a = -amp * om**2 * np.sin(om * t)
    n = np.array([0.4, -0.3, 0.866])
    n /= np.linalg.norm(n)
    th, thd, thdd = 0.08 * np.sin(2.5 * t), 0.2 * np.cos(2.5 * t), -0.5 * np.sin(2.5 * t)
    T = np.eye(4)
    T[:3, :3] = pin.exp3(th * n) @ T0[:3, :3]
    T[:3, 3] = p
    return T, np.concatenate([v, thd * n]), np.concatenate([a, thdd * n])


@pytest.mark.parametrize(("name", "rtol"), [("simulator", 1e-9)])
def test_inverse_model_forces_replay_the_commanded_motion(name, rtol):
    """Open loop: Gamma(t) from the inverse model along a 2 s trajectory, fed to the
    direct model through the adaptive integrator, reproduces the trajectory.

    The open-loop plant is unstable (nothing corrects a deviation), so the global error
    grows from the local tolerance: 3e-9 m for the simulator at rtol 1e-9; the small,
    fast desktop robot needs rtol 1e-12 (2e-8 m, 10 s of run time; 2e-6 m at rtol 1e-10)."""
    robot = StewartRobot.from_preset(name)

    def forces(t, T, V):
        return robot.inverse_dynamics(*reference(robot, t))

    T0, V0, _ = reference(robot, 0.0)
    res = simulate(robot, 2.0, T0, V0, forces, method="adaptive", rtol=rtol, atol=rtol * 1e-2)
    assert res.t[-1] == pytest.approx(2.0, abs=1e-12)
    # Pose error in metres: the largest displacement of the six platform points P_i.
    P = robot.description.platform_points
    errors = [
        np.abs((P @ T[:3, :3].T + T[:3, 3]) - (P @ Tr[:3, :3].T + Tr[:3, 3])).max()
        for T, Tr in ((T, reference(robot, t)[0]) for t, T in zip(res.t, res.poses, strict=True))
    ]
    assert max(errors) < 1e-6  # [m]


def _energy_drift(robot, **kwargs) -> float:
    # Thrown upwards and tumbling, it flies for 0.12 s before a leg reaches its stroke end.
    twist = np.array([0.05, -0.04, 0.4, 0.3, -0.2, 0.4])
    res = simulate(robot, 0.12, twist=twist, **kwargs)
    E = robot.energy(res.poses, res.twists)
    return float(np.abs(E - E[0]).max())


def test_energy_is_conserved_in_free_motion(desktop):
    """Gamma = 0 under gravity: the total energy is constant to the integrator's error,
    which falls as dt^4 for RK4, and stays within the adaptive method's tolerance."""
    scale = abs(desktop.energy(desktop.home_pose, np.zeros(6)))
    coarse = _energy_drift(desktop, method="rk4", dt=4e-3)
    fine = _energy_drift(desktop, method="rk4", dt=2e-3)
    assert fine < 1e-8 * scale
    assert coarse / fine > 10.0  # order 4: ideally 16
    adaptive = _energy_drift(desktop, method="adaptive", rtol=1e-10, atol=1e-12)
    assert adaptive < 1e-8 * scale


def test_rotation_stays_on_so3(desktop):
    res = simulate(desktop, 0.06, twist=[0, 0, 0, 1.0, -0.5, 0.8], dt=2e-3)
    R = res.poses[:, :3, :3]
    assert np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max() < 1e-13


def test_leaving_the_stroke_stops_with_the_partial_result(desktop):
    """Unpowered, the platform falls until a leg reaches its shortest length."""
    with pytest.raises(SimulationError, match=r"stopped at t = .* leg \d length") as e:
        simulate(desktop, 2.0, dt=2e-3)
    partial = e.value.result
    assert 0 < e.value.time < 2.0 and len(partial.t) > 2
    assert partial.lengths.min() >= desktop.description.stroke[0]
    # Falling from rest: the platform has gone down.
    assert partial.poses[-1, 2, 3] < partial.poses[0, 2, 3]


def test_zero_order_hold(desktop):
    calls = []

    def forces(t, T, V):
        calls.append(t)
        return desktop.gravity_compensation(T)

    res = simulate(desktop, 0.05, forces=forces, dt=1e-3, control_period=1e-2)
    held = res.gammas
    # Forces change only at the 10 ms samples.
    changes = np.flatnonzero(np.abs(np.diff(held, axis=0)).max(axis=1) > 0) + 1
    assert set(np.round(res.t[changes], 9)) <= {0.01, 0.02, 0.03, 0.04, 0.05}
    with pytest.raises(Exception, match="whole multiple"):
        simulate(desktop, 0.05, dt=3e-3, control_period=1e-2)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_save_and_load(desktop, tmp_path, suffix):
    res = simulate(desktop, 0.02, twist=[0.01, 0, 0, 0, 0, 0.1], dt=5e-3)
    back = SimulationResult.load(res.save(tmp_path / f"run{suffix}"))
    for name in ("t", "poses", "twists", "accels", "gammas", "lengths"):
        np.testing.assert_allclose(getattr(back, name), getattr(res, name), rtol=1e-15, atol=1e-15)
