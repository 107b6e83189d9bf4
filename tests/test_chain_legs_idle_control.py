"""Computed-torque control of a robot whose legs have idle freedoms (the asymmetric 6-RSS,
``rss_robot(symmetric=False)``: each rod spins freely about its ball-to-ball line and its
inertia couples that spin), simulated by
:func:`~stewart_pin.motion.idle_simulation.simulate_idle` with the spin state passed to the
controller.

The controller's efforts are checked against an independent reference: the exact KKT
inverse dynamics of Pinocchio's constrained tree with the spins as tree joints
(:class:`~stewart_pin.check.chain_legs_tree.ChainTreeSolver`) at the commanded
acceleration and the simulated spin state. One compile (the asymmetric rods' idle-state
models, shared with test_chain_legs_idle_compiled.py through the session's cache)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import use_compile_cache

from stewart_pin import StewartRobot
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg_presets import rss_robot, welded_ups
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics import chain_legs
from stewart_pin.motion.control import ComputedTorqueController, tracking_errors
from stewart_pin.motion.idle_simulation import IdleSimulationResult, simulate_idle, takes_idle
from stewart_pin.motion.trajectories import Sinusoids

#: Relative agreement of the controller's efforts with the constrained tree's KKT solve
#: (as test_chain_legs_idle_compiled.py).
TOL = 1e-10
#: Tracking bounds over 0.2 s with the exact model and the measured spin state. The
#: closed loop is then ``e'' + Kd e' + Kp e = 0`` from zero error: what remains is RK4's
#: truncation (measured 8.0e-11 m and 6.5e-10 rad). The same controller with the spin
#: state frozen at home (at rest) misses by 1.3e-6 m and 1.1e-5 rad (the rods spin by
#: 0.3 rad under gravity in 0.2 s), above these bounds by 100 times.
POS_BOUND, ROT_BOUND = 1e-8, 1e-7  # [m], [rad]
DURATION, DT = 0.2, 1e-3  # [s]


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache: Path) -> Iterator[Path]:
    yield from use_compile_cache(shared_compile_cache)


@pytest.fixture(scope="module")
def robot() -> StewartRobot:
    return StewartRobot(rss_robot(symmetric=False))


@pytest.fixture(scope="module")
def reference(robot: StewartRobot) -> Sinusoids:
    """A small six-axis sinusoid about home (3-4 mm, 0.02-0.04 rad, 2-3 Hz)."""
    return Sinusoids(
        robot.description.home_pose,
        amplitudes=[0.003, 0.002, 0.004, 0.03, 0.02, 0.04],
        frequencies=[2.0, 2.5, 3.0, 2.0, 3.0, 2.5],
        phases=[0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
        duration=1.0,
    )


@pytest.fixture(scope="module")
def controller(robot: StewartRobot, reference: Sinusoids) -> ComputedTorqueController:
    return ComputedTorqueController(robot, reference, backend="compiled")


def _track(
    robot: StewartRobot, reference: Sinusoids, forces: Any
) -> tuple[IdleSimulationResult, float, float]:
    T0, V0, _ = reference(0.0)
    s0 = chain_legs.idle_home(robot.description)
    res = simulate_idle(
        robot, DURATION, T0, V0, idle=(s0, np.zeros(6)), forces=forces, dt=DT, backend="compiled"
    )
    e_p, e_r = (
        np.linalg.norm(e, axis=1).max() for e in tracking_errors(reference, res.t, res.poses)
    )
    return res, float(e_p), float(e_r)


@pytest.fixture(scope="module")
def exact_run(
    robot: StewartRobot, reference: Sinusoids, controller: ComputedTorqueController
) -> tuple[IdleSimulationResult, float, float]:
    return _track(robot, reference, controller)  # four arguments: the spin state passed


def test_computed_torque_with_the_spin_state_tracks_and_without_it_does_not(
    robot: StewartRobot,
    reference: Sinusoids,
    controller: ComputedTorqueController,
    exact_run: tuple[IdleSimulationResult, float, float],
) -> None:
    res, e_p, e_r = exact_run
    assert len(res.t) == round(DURATION / DT) + 1
    s0 = chain_legs.idle_home(robot.description)
    assert np.abs(res.idle_q[-1] - s0).max() > 0.1  # [rad]: the rods do spin
    assert e_p <= POS_BOUND and e_r <= ROT_BOUND
    # the spin state ignored (frozen at home, at rest; a three-argument force function)
    zero = np.zeros(6)
    _, f_p, f_r = _track(robot, reference, lambda t, T, V: controller(t, T, V, (s0, zero)))
    assert f_p > 10 * POS_BOUND and f_r > 10 * ROT_BOUND


def test_the_controllers_efforts_are_the_constrained_trees_kkt_inverse_dynamics(
    robot: StewartRobot,
    controller: ComputedTorqueController,
    exact_run: tuple[IdleSimulationResult, float, float],
) -> None:
    res = exact_run[0]
    tree = ChainTreeSolver(robot.description)
    s0, zero = chain_legs.idle_home(robot.description), np.zeros(6)
    for k in (50, 120, 200):  # states the simulation reached (the spins away from home)
        t, T, V, q_idle, v_idle = (
            res.t[k],
            res.poses[k],
            res.twists[k],
            res.idle_q[k],
            res.idle_v[k],
        )
        A_cmd = controller.command(t, T, V)
        q_legs = [
            x[0]
            for x in chain_legs.inverse_geometry(robot.description, T[None], False, q_idle[None])
        ]
        ref, _ = tree.inverse_idle_one(T, V, A_cmd, q_legs, v_idle)
        for backend in ("compiled", "pinocchio"):
            ctl = ComputedTorqueController(robot, controller.reference, backend=backend)
            gamma = ctl(t, T, V, (q_idle, v_idle))
            assert np.abs(gamma - ref).max() <= TOL * np.abs(ref).max()
        # what the simulation applied at that sample: the same efforts
        assert np.abs(res.gammas[k] - ref).max() <= TOL * np.abs(ref).max()
        # the home spin state gives other efforts: the check can fail
        wrong = controller(t, T, V, (s0, zero))
        assert np.abs(wrong - ref).max() > 1e3 * TOL * np.abs(ref).max()


def test_simulate_idle_passes_the_spin_state_to_four_argument_functions_only(
    robot: StewartRobot,
) -> None:
    s0 = chain_legs.idle_home(robot.description)
    v0 = np.linspace(-3.0, 3.0, 6)
    g0 = robot.inverse_dynamics(
        robot.description.home_pose, np.zeros(6), np.zeros(6), idle=(s0, v0), backend="compiled"
    )
    seen: list[tuple[float, Any]] = []

    def four(t: float, T: np.ndarray, V: np.ndarray, idle: Any) -> np.ndarray:
        seen.append((t, idle))
        return g0 * (1.0 + 0.2 * math.sin(40 * t))

    def three(t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        return g0 * (1.0 + 0.2 * math.sin(40 * t))

    run4, run3 = (
        simulate_idle(robot, 0.01, idle=(s0, v0), forces=f, dt=DT, backend="compiled")
        for f in (four, three)
    )
    assert len(seen) == 4 * 10 + 1  # four RK4 stages a step, the last sample's one
    # each step's first stage sees the sample's spin state
    firsts = [seen[4 * k][1] for k in range(11)]
    assert np.array_equal(np.array([f[0] for f in firsts]), run4.idle_q)
    assert np.array_equal(np.array([f[1] for f in firsts]), run4.idle_v)
    assert np.array_equal(run4.idle_q, run3.idle_q) and np.array_equal(run4.poses, run3.poses)
    assert np.abs(run4.idle_v[-1] - v0).max() > 1e-3  # the spin rates changed: a real state
    # the rule: a signature binding four positional arguments
    assert (
        takes_idle(four)
        and takes_idle(lambda *a: 0)
        and takes_idle(ComputedTorqueController(robot, lambda t: (None, None, None)))
    )
    assert not takes_idle(three) and not takes_idle(lambda t, T, V, *, idle: 0)


def test_a_robot_without_idle_joints_passes_none_to_four_argument_functions() -> None:
    robot = StewartRobot(welded_ups(seed=1))  # chain legs welded, no idle joint
    seen: list[Any] = []

    def four(t: float, T: np.ndarray, V: np.ndarray, idle: Any) -> np.ndarray:
        seen.append(idle)
        return np.zeros(6)

    simulate_idle(robot, 0.002, forces=four, dt=DT, backend="pinocchio")
    assert seen == [None] * 9  # two RK4 steps and the last sample


def test_bad_idle_states_to_the_controller_raise_input_errors(
    robot: StewartRobot, controller: ComputedTorqueController
) -> None:
    H, zero = robot.description.home_pose, np.zeros(6)
    with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
        controller(0.0, H, zero)  # this robot's state includes the spins
    bad = [
        zero,
        (zero,),
        (zero, zero, zero),
        (np.zeros(5), zero),
        (zero, np.full(6, np.nan)),
        ("ab", zero),
        "ab",
    ]
    for idle in bad:
        with pytest.raises(InputError, match="idle"):
            controller(0.0, H, zero, idle)
    plain = StewartRobot.from_preset("simulator")  # no idle joints: refuses a spin state
    ct = ComputedTorqueController(
        plain, lambda t: (plain.home_pose, zero, zero), backend="pinocchio"
    )
    assert np.all(np.isfinite(ct(0.0, plain.home_pose, zero)))
    with pytest.raises(InputError, match="no idle joints"):
        ct(0.0, plain.home_pose, zero, (zero, zero))
