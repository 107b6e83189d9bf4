"""The dynamic regressor of robots with general legs, joint terms included (issue 13, item 1).

References: the inverse dynamic model (``robot.inverse_dynamics``: Pinocchio's RNEA on the
chains with ``model.armature``, the joint terms, the closure layer) for ``W chi``;
finite differences of that model in each standard parameter, through
``with_standard_parameters``, for each column; and the independent constrained tree
(``check.leg_chain_tree.reference_regressor``: Pinocchio's joint-torque regressor on the
24-dof tree, each column mapped to the actuators by the KKT solve) for every entry.
"""

from __future__ import annotations

import numpy as np
import pytest

from stewart_pin import StewartRobot
from stewart_pin.check.leg_chain_tree import GeneralTreeSolver, reference_regressor
from stewart_pin.description.leg_architecture import COULOMB_DEAD_BAND
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.dynamics.regressor import (
    GENERAL_STANDARD_NAMES,
    JOINT_TERM_NAMES,
    STANDARD_NAMES,
    actuator_ratios,
    joint_index,
    parameter_groups,
    standard_parameter_names,
    standard_parameters,
    with_standard_parameters,
)
from stewart_pin.exceptions import JointDynamicsError

#: Random robots of every architecture, every joint term non-zero (armature, viscous and
#: Coulomb friction, spring with a rest position, damper; gear or screw on the actuated
#: joints), and the general presets.
RANDOM = ("random-ups-1", "random-ups-offset-2", "random-rus-3", "random-pus-4", "random-custom-5")
PRESETS = ("ups-offset", "rus", "pus")

_ROBOTS: dict[str, StewartRobot] = {}


def robot_named(name: str) -> StewartRobot:
    if name not in _ROBOTS:
        _ROBOTS[name] = StewartRobot.from_preset(name)
    return _ROBOTS[name]


def mixed_robot() -> StewartRobot:
    """A robot whose legs 4-6 are ``custom`` (Newton's inverse geometry) and 1-3 ``pus``:
    the same chains as ``random-pus-4``, so the same dynamics, architecture ``mixed``."""
    desc = robot_named("random-pus-4").description
    legs = [leg if k < 3 else leg.replace(name="custom") for k, leg in enumerate(desc.legs)]
    return StewartRobot(desc.replace(legs=tuple(legs)))


def test_standard_names_of_general_legs_add_five_joint_terms_per_joint():
    desc = robot_named("random-rus-3").description
    names = standard_parameter_names(desc)
    assert names == GENERAL_STANDARD_NAMES and len(names) == 280 == len(set(names))
    assert names[:190] == STANDARD_NAMES  # the links and the platform as for 6-UPS
    assert names[190:195] == ("IA1_1", "FV1_1", "FC1_1", "K1_1", "OF1_1")
    assert names[195] == "IA2_1" and names[205] == "IA1_2" and names[-1] == "OF3_6"
    assert names[joint_index(4, 2, "FC")] == "FC2_4"
    assert standard_parameter_names(robot_named("rus").description) == names
    assert len(standard_parameter_names(StewartRobot.from_preset("simulator").description)) == 190


def test_standard_parameters_hold_every_joint_term():
    """IA = armature + ratio^2 rotor, FV = viscous + damping, FC, K, OF = -K q0."""
    desc = robot_named("random-pus-4").description
    chi = standard_parameters(desc)
    assert chi.shape == (280,)
    np.testing.assert_array_equal(chi[:180], desc.leg_inertia.reshape(-1))
    np.testing.assert_array_equal(chi[180:190], desc.platform_inertia)
    d = desc.legs[2].joints[0].dynamics  # leg 3's actuated slide, with a ball screw
    assert d.screw_lead is not None and d.rotor_inertia > 0
    ratio = 2 * np.pi / d.screw_lead
    v = dict(zip(GENERAL_STANDARD_NAMES, chi, strict=True))
    assert v["IA1_3"] == pytest.approx(d.armature + ratio**2 * d.rotor_inertia, rel=1e-15)
    assert v["FV1_3"] == pytest.approx(d.viscous + d.damping, rel=1e-15)
    assert v["FC1_3"] == d.coulomb and v["K1_3"] == d.stiffness
    assert v["OF1_3"] == pytest.approx(-d.stiffness * d.rest_position, rel=1e-15)
    assert all(chi[190:][k] != 0 for k in range(90))  # every joint term non-zero here


@pytest.mark.parametrize("name", RANDOM + PRESETS)
def test_regressor_times_standard_parameters_is_inverse_dynamics(name):
    """``W chi`` equals the inverse dynamic model to 1e-12 relative, one state and batches."""
    robot = robot_named(name)
    poses, twists, accels = robot.sample_states(40, 11)
    W = robot.regressor(poses, twists, accels)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    assert W.shape == (40, 6, 280)
    chi = standard_parameters(robot.description)
    assert np.abs(W @ chi - gamma).max() <= 1e-12 * np.abs(gamma).max()
    single = robot.regressor(poses[3], twists[3], accels[3])
    assert single.shape == (6, 280)
    np.testing.assert_allclose(single, W[3], rtol=0, atol=1e-14 * np.abs(W[3]).max())


def test_regressor_of_a_mixed_robot():
    robot = mixed_robot()
    assert robot.architecture == "mixed"
    poses, twists, accels = robot.sample_states(20, 4)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    W = robot.regressor(poses, twists, accels)
    chi = standard_parameters(robot.description)
    assert np.abs(W @ chi - gamma).max() <= 1e-12 * np.abs(gamma).max()


def _column_errors(W: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per column: max |W - reference| over the column's largest entry (floor: 1e-300)."""
    diff = np.abs(W - reference).reshape(-1, W.shape[-1]).max(axis=0)
    scale = np.abs(reference).reshape(-1, W.shape[-1]).max(axis=0)
    return diff / np.maximum(scale, 1e-300)


def _physical_steps(p: np.ndarray) -> np.ndarray:
    """Steps (10,) for a body's parameters ``p`` (Khalil's order) that keep it physical:
    a tenth of its slack (the smallest principal moment about the centre of mass, and the
    triangle inequality's ``I1 + I2 - I3``) on a tensor entry, that slack over the lever
    arm on a first moment (moving the centre of mass), and over the arm squared on the
    mass."""
    mass, com = p[9], p[6:9] / p[9]
    I_O = np.array([[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]])
    I_c = I_O - mass * (com @ com * np.eye(3) - np.outer(com, com))
    e = np.linalg.eigvalsh(I_c)
    slack = min(e[0], e[0] + e[1] - e[2])
    arm = max(float(np.linalg.norm(com)), np.sqrt(np.trace(I_c) / mass))
    return np.array([0.1 * slack] * 6 + [0.05 * slack / arm] * 3 + [0.05 * slack / arm**2])


@pytest.mark.parametrize("name", RANDOM)
def test_regressor_columns_are_finite_differences_of_inverse_dynamics(name):
    """Column k is ``d Gamma / d chi_k``, through ``with_standard_parameters``: the model is
    linear in chi, so a one-sided difference is exact but for round-off. Steps: a tenth
    of each joint term; for a body's parameters, a step that keeps the body physical
    (:func:`_physical_steps`). Bound per column: 1e-8 of the column's largest entry plus
    the round-off of two evaluations, 1e-13 of Gamma's largest entry over the step."""
    robot = robot_named(name)
    desc = robot.description
    poses, twists, accels = robot.sample_states(4, 5)
    W = robot.regressor(poses, twists, accels)
    chi = standard_parameters(desc)

    def gamma(c: np.ndarray) -> np.ndarray:
        model = GeneralDynamics(general_from_description(with_standard_parameters(desc, c)))
        return model.inverse_dynamics(poses, twists, accels)

    g0 = gamma(chi)
    steps = np.empty(280)
    for body in parameter_groups(desc).bodies:
        steps[body.index] = _physical_steps(chi[body.index])
    steps[190:] = 0.1 * np.abs(chi[190:])
    assert np.all(steps > 0)
    error = np.empty(280)
    for k in range(280):
        c = chi.copy()
        c[k] += steps[k]
        fd = (gamma(c) - g0) / steps[k]
        error[k] = np.abs(fd - W[..., k]).max() / (
            1e-8 * np.abs(W[..., k]).max() + 1e-13 * np.abs(g0).max() / steps[k]
        )
    worst = int(np.argmax(error))
    assert error.max() < 1.0, GENERAL_STANDARD_NAMES[worst]


@pytest.mark.parametrize("name", [*RANDOM, *PRESETS])
def test_regressor_matches_the_constrained_tree(name):
    """Every column against the independent tree's, within 1e-10 of the column's size."""
    robot = robot_named(name)
    poses, twists, accels = robot.sample_states(4, 3)
    W = robot.regressor(poses, twists, accels)
    solver = GeneralTreeSolver(robot.general)
    reference = reference_regressor(solver, poses, twists, accels, robot.inverse_geometry(poses))
    errors = _column_errors(W, reference)
    worst = int(np.argmax(errors))
    assert errors.max() < 1e-10, GENERAL_STANDARD_NAMES[worst]


def test_joint_term_columns_at_rest_and_the_dead_band():
    """At rest (zero twist and acceleration) the armature, viscous and Coulomb columns are
    zero: Coulomb is ``sign(0) = 0`` (rates within the dead band count as zero); the
    stiffness column is ``q`` and the offset's the constant effort, projected."""
    robot = robot_named("random-rus-3")
    T = robot.home_pose
    zero = np.zeros(6)
    W = robot.regressor(T, zero, zero)
    for term in ("IA", "FV", "FC"):
        cols = [joint_index(i, j, term) for i in range(1, 7) for j in (1, 2, 3)]
        assert not W[:, cols].any()
    # A joint term of one joint acts like an effort on that joint alone: OF of leg 2's
    # joint 3 (passive) gives Jp^T [I3; L^] J_2^-T e_3 (the inverse dynamics with only
    # that constant effort is the same projection).
    for term in ("K", "OF"):
        cols = [joint_index(i, j, term) for i in range(1, 7) for j in (1, 2, 3)]
        assert np.all(np.abs(W[:, cols]).max(axis=0) > 0)
    q = robot.inverse_geometry(T)
    np.testing.assert_allclose(
        W[:, joint_index(2, 3, "K")], q[1, 2] * W[:, joint_index(2, 3, "OF")], rtol=1e-14, atol=0
    )


def test_coulomb_column_uses_the_dead_band_of_the_model():
    """A twist whose leg 1 joint 2 rate is zero in exact arithmetic (round-off, within
    COULOMB_DEAD_BAND): that joint's Coulomb column is zero (``sign(0) = 0``), as in the
    inverse dynamics, and ``W chi`` still equals the model; the other joints move."""
    robot = robot_named("random-rus-3")
    T = robot.home_pose
    basis = np.array([robot.leg_kinematics(T, e)[1][0, 1] for e in np.eye(6)])  # d qdot / d V
    twist = np.array([0.01, -0.02, 0.015, 0.3, -0.2, 0.1])
    twist -= (basis @ twist) / (basis @ basis) * basis
    qdot = robot.leg_kinematics(T, twist)[1]
    assert 0 < abs(qdot[0, 1]) <= COULOMB_DEAD_BAND or qdot[0, 1] == 0.0
    assert np.abs(qdot).max() > 1e-3
    accel = np.array([0.1, 0.2, -0.1, 1.0, 0.5, -0.3])
    W = robot.regressor(T, twist, accel)
    assert not W[:, joint_index(1, 2, "FC")].any()
    assert np.all(np.abs(W[:, joint_index(1, 3, "FC")]) > 0)
    gamma = robot.inverse_dynamics(T, twist, accel)
    chi = standard_parameters(robot.description)
    assert np.abs(W @ chi - gamma).max() <= 1e-12 * np.abs(gamma).max()


def test_motor_side_regressor_divides_by_the_transmission_ratio():
    robot = robot_named("random-pus-4")
    ratios = actuator_ratios(robot.description)
    assert np.all(ratios > 1)  # screws on every actuated slide
    poses, twists, accels = robot.sample_states(10, 2)
    W = robot.regressor(poses, twists, accels) / ratios[:, None]
    motor = robot.inverse_dynamics(poses, twists, accels, motor=True)
    chi = standard_parameters(robot.description)
    assert np.abs(W @ chi - motor).max() <= 1e-12 * np.abs(motor).max()
    np.testing.assert_array_equal(
        actuator_ratios(StewartRobot.from_preset("paper").description), 1
    )


@pytest.mark.parametrize("name", ["random-ups-offset-2", "random-pus-4", "rus"])
def test_with_standard_parameters_round_trip(name):
    desc = robot_named(name).description
    chi = standard_parameters(desc)
    again = standard_parameters(with_standard_parameters(desc, chi))
    np.testing.assert_allclose(again, chi, rtol=1e-14, atol=0)
    # Other joint terms: each maps back onto the joint dynamics.
    rng = np.random.default_rng(0)
    other = chi.copy()
    other[190:] *= rng.uniform(0.5, 2.0, 90)
    other[[joint_index(i, 1, "OF") for i in range(1, 7)]] *= -1  # either sign
    back = with_standard_parameters(desc, other)
    np.testing.assert_allclose(standard_parameters(back), other, rtol=1e-13, atol=0)


def test_with_standard_parameters_keeps_what_the_terms_cannot_tell_apart():
    """IA below the reflected rotor inertia: the rotor is scaled down, armature 0; FV below
    the damping: damping = FV, viscous 0; K = 0 with OF = 0 keeps the rest position."""
    desc = robot_named("random-pus-4").description
    d = desc.legs[0].joints[0].dynamics
    reflected = d.transmission_ratio**2 * d.rotor_inertia
    chi = standard_parameters(desc)
    chi[joint_index(1, 1, "IA")] = 0.5 * reflected
    chi[joint_index(1, 1, "FV")] = 0.5 * d.damping
    chi[joint_index(1, 1, "K")] = 0.0
    chi[joint_index(1, 1, "OF")] = 0.0
    new = with_standard_parameters(desc, chi).legs[0].joints[0].dynamics
    assert new.armature == 0 and new.rotor_inertia == pytest.approx(0.5 * d.rotor_inertia)
    assert new.screw_lead == d.screw_lead
    assert new.viscous == 0 and new.damping == pytest.approx(0.5 * d.damping)
    assert new.stiffness == 0 and new.rest_position == d.rest_position


def test_bad_standard_parameters_are_named_errors():
    desc = robot_named("random-rus-3").description
    chi = standard_parameters(desc)
    bad = chi.copy()
    bad[joint_index(2, 3, "K")] = 0.0  # OF stays non-zero: no spring to hold it
    with pytest.raises(JointDynamicsError, match=r"leg 2 joint 3: an offset .* zero stiffness"):
        with_standard_parameters(desc, bad)
    bad = chi.copy()
    bad[joint_index(5, 1, "FC")] = -1.0
    with pytest.raises(JointDynamicsError, match=r"leg 5 joint 1: .*coulomb .* negative"):
        with_standard_parameters(desc, bad)
    from stewart_pin.exceptions import InputError

    with pytest.raises(InputError, match="shape"):
        with_standard_parameters(desc, chi[:190])


def test_parameter_groups_name_each_body_and_joint():
    desc = robot_named("random-pus-4").description
    groups = parameter_groups(desc)
    names = GENERAL_STANDARD_NAMES
    assert groups.n == 280 and len(groups.bodies) == 19 and len(groups.joints) == 18
    covered = np.concatenate(
        [np.arange(280)[b.index] for b in groups.bodies]
        + [np.arange(280)[jp.index] for jp in groups.joints]
    )
    np.testing.assert_array_equal(np.sort(covered), np.arange(280))  # a partition
    body = groups.bodies[7]  # leg 3 link 2
    assert body.name == "leg 3 link 2"
    assert [names[k] for k in range(280)[body.index]] == [
        f"{p}2_3" for p in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
    ]
    assert groups.bodies[-1].name == "platform" and names[groups.bodies[-1].index][-1] == "M_P"
    jp = groups.joints[6]  # leg 3 joint 1: the actuated slide
    assert (jp.name, jp.leg, jp.joint, jp.kind, jp.actuated) == (
        "leg 3 joint 1",
        3,
        1,
        "prismatic",
        True,
    )
    assert [names[k] for k in range(280)[jp.index]] == [f"{t}1_3" for t in JOINT_TERM_NAMES]
    assert [names[k] for k in jp.nonnegative] == ["IA1_3", "FV1_3", "FC1_3", "K1_3"]
    assert len(groups.nonnegative) == 72
    ideal = parameter_groups(StewartRobot.from_preset("paper").description)
    assert ideal.n == 190 and ideal.joints == () and len(ideal.bodies) == 19
