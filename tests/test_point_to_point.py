"""Minimum-effort point-to-point motions (issue 14, item 6).

Independent references: the open-loop simulation of the optimised forces with the
project's simulator on the *reference* direct model (Pinocchio's leg dynamics and the
closure layer, not the generated code the NLP used), and the reference inverse model at
the nodes. Tolerances: 1e-6 m / rad against the simulation with the transcription's step
(the same RK4 order, a different SO(3) integration: ~1e-9 measured), 1e-5 m / rad with a
step twenty times finer (the transcription's own error, ~2e-7 measured).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot

from stewart_pin import StewartRobot
from stewart_pin.exceptions import ConvergenceError, InputError
from stewart_pin.planning import OptimalMotion, optimal_point_to_point

#: Limits for the simulator preset below the unconstrained optimum's peaks (about
#: 5730 N and 0.49 m/s on this motion), so that both are active.
MAX_EFFORT = 5200.0  # [N]
MAX_SPEED = 0.45  # [m/s]


def _goal(robot: StewartRobot) -> np.ndarray:
    T = robot.home_pose
    T[:3, 3] += [0.15, -0.1, 0.1]
    T[:3, :3] = pin.exp3(np.array([0.1, 0.15, -0.2])) @ T[:3, :3]
    return T


@pytest.fixture(scope="module")
def limited() -> tuple[StewartRobot, OptimalMotion]:
    robot = get_robot("simulator")
    motion = optimal_point_to_point(
        robot, robot.home_pose, _goal(robot), 1.0, max_effort=MAX_EFFORT, max_speed=MAX_SPEED
    )
    return robot, motion


def test_optimal_motion_converges_and_reaches_the_goal_at_rest(limited):
    robot, m = limited
    assert m.status == "Solve_Succeeded" and m.iterations > 0
    assert m.t.shape == (31,) and m.gammas.shape == (30, 6) and m.poses.shape == (31, 4, 4)
    np.testing.assert_allclose(m.poses[0], robot.home_pose, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.poses[-1], _goal(robot), rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.twists[[0, -1]], 0.0, rtol=0, atol=1e-8)


def test_optimal_motion_satisfies_the_limits_and_uses_them(limited):
    _, m = limited
    assert np.abs(m.gammas).max() <= MAX_EFFORT  # bounds honoured exactly (no relaxation)
    assert np.abs(m.gammas).max() >= MAX_EFFORT * (1 - 1e-6)  # the limit is active
    assert np.abs(m.actuator_speeds).max() <= MAX_SPEED * (1 + 1e-8)
    assert np.abs(m.actuator_speeds).max() >= MAX_SPEED * (1 - 1e-6)
    lo, hi = m.length_bounds
    assert m.leg_lengths.min() >= lo - 1e-9 and m.leg_lengths.max() <= hi + 1e-9


def test_optimal_motion_forces_are_the_reference_inverse_dynamics(limited):
    """At each node, the reference IDM of the NLP's state and acceleration gives back the
    force held from that node."""
    robot, m = limited
    gamma = robot.inverse_dynamics(m.poses[:-1], m.twists[:-1], m.accels[:-1], backend="pinocchio")
    assert np.abs(gamma - m.gammas).max() < 1e-9 * MAX_EFFORT


def test_open_loop_simulation_tracks_the_optimised_motion(limited):
    robot, m = limited
    dp, dr = m.deviation(m.simulate(robot))
    assert dp < 1e-6 and dr < 1e-6
    dp, dr = m.deviation(m.simulate(robot, substeps=20))
    assert dp < 1e-5 and dr < 1e-5
    assert m.forces(0.0).tolist() == m.gammas[0].tolist()
    assert m.forces(m.control_period * 3).tolist() == m.gammas[3].tolist()  # held from t_3
    assert m.forces(m.duration).tolist() == m.gammas[-1].tolist()


def test_limits_cost_effort(limited):
    """Without the limits the optimum costs no more, and goes past them."""
    robot, m = limited
    free = optimal_point_to_point(robot, robot.home_pose, _goal(robot), 1.0)
    assert free.cost <= m.cost * (1 + 1e-9)
    assert (
        np.abs(free.gammas).max() > MAX_EFFORT and np.abs(free.actuator_speeds).max() > MAX_SPEED
    )


def test_impossible_limits_raise_convergence_error():
    robot = get_robot("simulator")
    with pytest.raises(ConvergenceError, match="IPOPT found no optimal motion") as e:
        optimal_point_to_point(
            robot, robot.home_pose, _goal(robot), 1.0, max_effort=100.0, max_iterations=30
        )
    assert e.value.iterations is not None and e.value.iterations > 0


def test_bad_arguments_raise_input_errors():
    robot = get_robot("simulator")
    T0, T1 = robot.home_pose, _goal(robot)
    with pytest.raises(InputError, match="duration"):
        optimal_point_to_point(robot, T0, T1, -1.0)
    with pytest.raises(InputError, match="intervals"):
        optimal_point_to_point(robot, T0, T1, 1.0, intervals=1)
    with pytest.raises(InputError, match="max_effort"):
        optimal_point_to_point(robot, T0, T1, 1.0, max_effort=[1.0, 2.0])
    with pytest.raises(InputError, match="max_speed"):
        optimal_point_to_point(robot, T0, T1, 1.0, max_speed=-1.0)
    with pytest.raises(InputError, match="hessian"):
        optimal_point_to_point(robot, T0, T1, 1.0, hessian="bfgs")
    lo, hi = robot.description.stroke
    with pytest.raises(InputError, match="margin"):
        optimal_point_to_point(robot, T0, T1, 1.0, margin=0.5 * (hi - lo))
    with pytest.raises(InputError, match="goal_pose has leg lengths"):
        optimal_point_to_point(robot, T0, T1, 1.0, margin=0.2 * (hi - lo))
    for bad in (True, "fast", [1.0, "x", 1, 1, 1, 1], 1j):
        with pytest.raises(InputError, match="max_effort"):
            optimal_point_to_point(robot, T0, T1, 1.0, max_effort=bad)
    for bad in (0, -1, 2.5, "many", True):
        with pytest.raises(InputError, match="max_iterations"):
            optimal_point_to_point(robot, T0, T1, 1.0, max_iterations=bad)
    with pytest.raises(InputError, match="substeps"):
        optimal_point_to_point(robot, T0, T1, 1.0, substeps=1.5)


def test_bad_replay_arguments_raise_input_errors(limited):
    robot, m = limited
    for bad in (0, 1.7, "x", True):
        with pytest.raises(InputError, match="substeps"):
            m.simulate(robot, substeps=bad)
    with pytest.raises(InputError, match="t must be finite"):
        m.forces(float("nan"))


#: Each general architecture, and the Hessian its NLP converges with in a few iterations
#: (CasADi's exact second derivatives for the crank of the 6-RUS; L-BFGS for the rest:
#: through a custom leg's Newton steps the exact Hessian is slower than it pays).
GENERAL_PLANS = (
    ("pus", "limited-memory"),
    ("ups-offset", "limited-memory"),
    ("rus", "exact"),
    ("random-custom-0", "limited-memory"),
)


def _small_goal(robot: StewartRobot) -> np.ndarray:
    T = robot.home_pose
    s = robot.description.stroke_mid
    T[:3, 3] += 0.03 * s * np.array([1.0, -0.6, 0.6])
    T[:3, :3] = pin.exp3(0.03 * np.array([0.6, 0.8, -1.0])) @ T[:3, :3]
    return T


@pytest.mark.parametrize(("name", "hessian"), GENERAL_PLANS)
def test_optimal_motion_on_every_leg_architecture(name, hessian):
    """The planner on general legs (issue 19): the joint limits of every leg instead of
    the shared stroke. References: the reference inverse model (Pinocchio's leg dynamics
    and the closure layer) at every node gives back the force held there (the NLP used
    the generated DDM); the reference inverse geometry's actuated joints lie within
    each leg's limits less the margin; the open-loop simulation on the reference direct
    model reaches the goal at rest."""
    robot = StewartRobot.from_preset(name)
    goal = _small_goal(robot)
    m = optimal_point_to_point(
        robot, robot.home_pose, goal, 1.0, intervals=6, hessian=hessian, coulomb_smoothing=0.0
    )  # the exact model (Coulomb's sign): this coarse transcription converges with it
    assert m.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    np.testing.assert_allclose(m.poses[-1], goal, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.twists[[0, -1]], 0.0, rtol=0, atol=1e-8)
    # the DDM the NLP used against the reference IDM, node by node (held forces)
    held = np.vstack([m.gammas, m.gammas[-1:]])
    gamma_ref = robot.inverse_dynamics(m.poses, m.twists, m.accels, backend="pinocchio")
    np.testing.assert_allclose(gamma_ref, held, rtol=1e-8, atol=1e-8 * np.abs(held).max())
    # the limits of every leg, with the reference inverse geometry
    q_a = robot.actuator_positions(m.poses, check_limits=True)
    np.testing.assert_allclose(m.actuator_positions, q_a, rtol=0, atol=1e-9)
    lo, hi = m.actuator_bounds[:, 0], m.actuator_bounds[:, 1]
    legs = robot.general.legs
    limits = np.array([leg.limits[leg.actuated - 1] for leg in legs])
    finite = np.isfinite(limits[:, 0])
    np.testing.assert_allclose(
        lo[finite], limits[finite, 0] + 0.01 * (limits[finite, 1] - limits[finite, 0])
    )
    assert (q_a >= lo - 1e-9).all() and (q_a <= hi + 1e-9).all()
    # the open loop on the reference direct model
    dp, dr = m.deviation(m.simulate(robot))
    assert dp < 1e-5 and dr < 1e-4


def test_a_margin_past_half_a_crank_range_is_refused():
    robot = get_robot("simulator")  # the 6-UPS: half the stroke, 0.4 m
    with pytest.raises(InputError, match="margin must be in"):
        optimal_point_to_point(robot, robot.home_pose, robot.home_pose, 1.0, margin=0.5)
    rus = StewartRobot.from_preset("rus")  # cranks in [-pi/2, pi/2]: half is pi/2 rad
    with pytest.raises(InputError, match=r"margin must be in \[0, 1.5708\)"):
        optimal_point_to_point(rus, rus.home_pose, rus.home_pose, 1.0, margin=1.6)


#: The friction robots and transcriptions: the 6-PUS on 20 intervals with CasADi's exact
#: Hessian (L-BFGS also converges there, in ~190 iterations against ~20: the suite's time).
FINE_TRANSCRIPTIONS = (
    ("pus", 10, "limited-memory"),
    ("pus", 20, "exact"),
    ("ups-offset", 10, "limited-memory"),
    ("ups-offset", 20, "limited-memory"),
)


@pytest.mark.parametrize(("name", "intervals", "hessian"), FINE_TRANSCRIPTIONS)
def test_friction_robots_converge_on_fine_transcriptions(name, intervals, hessian):
    """Coulomb friction made IPOPT stop on 10 and 20 intervals (its sign jumps where a
    joint starts from rest); the NLP now optimises on tanh(qd / eps), eps = 1e-2 m/s or
    rad/s, and reports the exact efforts of the motion it found. References at every node
    (the motion's states and accelerations): the reference inverse model (Pinocchio's leg
    dynamics and the closure layer, Coulomb's exact sign) and Pinocchio's constrained
    dynamics on the closed-loop tree (the independent check's KKT solve); at rest (the
    ends) both signs are 0, so the exact efforts are the held forces there."""
    from stewart_pin.check.constrained_dynamics import reference_actuator_efforts

    robot = StewartRobot.from_preset(name)
    goal = _small_goal(robot)
    m = optimal_point_to_point(
        robot, robot.home_pose, goal, 1.0, intervals=intervals, hessian=hessian
    )
    assert m.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    assert m.coulomb_smoothing == 1e-2
    np.testing.assert_allclose(m.poses[-1], goal, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.twists[[0, -1]], 0.0, rtol=0, atol=1e-8)
    held = np.vstack([m.gammas, m.gammas[-1:]])
    scale = np.abs(held).max()
    assert m.exact_efforts.shape == (intervals + 1, 6)
    gamma_ref = robot.inverse_dynamics(m.poses, m.twists, m.accels, backend="pinocchio")
    np.testing.assert_allclose(m.exact_efforts, gamma_ref, rtol=0, atol=1e-9 * scale)
    kkt = reference_actuator_efforts(robot, m.poses, m.twists, m.accels)
    np.testing.assert_allclose(m.exact_efforts, kkt, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(m.exact_efforts[0], held[0], rtol=0, atol=1e-9 * scale)
    # elsewhere the smooth sign differs from the exact one: the efforts differ (by at most
    # the Coulomb forces mapped to the actuators), not the motion
    assert np.abs(m.exact_efforts - held).max() > 1e-6 * scale


def test_optimal_motion_on_chain_legs():
    """The planner on chain legs (welded six-joint legs, Coulomb friction on every joint):
    the NLP on the chain generator's smooth models. References at the nodes: the reference
    inverse model (Pinocchio's chain-leg dynamics and the closure layer, Coulomb's exact
    sign) and the independent constrained tree (check/chain_legs_tree.py); at rest (the
    start) both signs are 0, so there the held force is exact; elsewhere the smooth sign
    moves the efforts by the Coulomb forces mapped to the actuators (a few per mille of the
    largest effort here, 1.5e-4 measured on two intervals), not more. Two intervals (the
    fewest): one moving node, 11 IPOPT iterations (four intervals took ~100)."""
    from stewart_pin.check.chain_legs_tree import ChainTreeSolver
    from stewart_pin.description.chain_leg_presets import welded_ups
    from stewart_pin.kinematics import chain_legs

    robot = StewartRobot(welded_ups(seed=1))
    goal = robot.home_pose
    goal[2, 3] += 0.005  # 5 mm up
    m = optimal_point_to_point(robot, robot.home_pose, goal, 0.5, intervals=2, tol=1e-6)
    assert m.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    np.testing.assert_allclose(m.poses[-1], goal, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.twists[[0, -1]], 0.0, rtol=0, atol=1e-8)
    held = np.vstack([m.gammas, m.gammas[-1:]])
    scale = np.abs(m.exact_efforts).max()
    gamma_ref = robot.inverse_dynamics(m.poses, m.twists, m.accels, backend="pinocchio")
    np.testing.assert_allclose(m.exact_efforts, gamma_ref, rtol=0, atol=1e-9 * scale)
    tree = ChainTreeSolver(robot.description)
    for T, V, A, gamma in zip(m.poses, m.twists, m.accels, m.exact_efforts, strict=True):
        q = [x[0] for x in chain_legs.inverse_geometry(robot.description, T[None], False)]
        np.testing.assert_allclose(gamma, tree.inverse_one(T, V, A, q), rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(m.exact_efforts[0], held[0], rtol=0, atol=1e-9 * scale)
    gap = np.abs(m.exact_efforts - held).max()
    assert 1e-6 * scale < gap < 2e-2 * scale
