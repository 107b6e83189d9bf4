"""Inverse and forward geometry (stewart_pin.kinematics.geometry), checked with Pinocchio's forward
kinematics of the generated models."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from helpers import (
    frame_position,
    leg_lengths_by_hand,
    points_in_base,
    tip_frame,
    tree_configuration,
)

from stewart_pin import (
    ConvergenceError,
    InputError,
    JointLimitError,
    SingularityError,
    StewartRobot,
    StrokeLimitError,
    WorkspaceError,
    leg_base_rotation_from_axis,
)

TIP_TOLERANCE = 1e-12  # [m]


@pytest.fixture(scope="module", params=["simulator", "paper", "random-0", "random-1"])
def robot_and_poses(request) -> tuple[StewartRobot, np.ndarray]:
    from conftest import get_robot

    robot = get_robot(request.param)
    return robot, robot.sample_poses(8, np.random.default_rng(7))


def scale(robot: StewartRobot) -> float:
    """A length scale for relative tolerances [m]."""
    return max(1.0, float(robot.description.stroke[1]))


# ---------------------------------------------------------------------- against Pinocchio
def test_leg_models_put_the_tip_at_P_i(robot_and_poses):
    robot, poses = robot_and_poses
    desc = robot.description
    for T in poses:
        q = robot.inverse_geometry(T)
        P = points_in_base(desc, T)
        for i, model in enumerate(robot.leg_models):
            tip = frame_position(model, q[i], tip_frame(i))
            np.testing.assert_allclose(tip, P[i], rtol=0, atol=TIP_TOLERANCE * scale(robot))


def test_tree_puts_every_tip_at_P_i_and_the_platform_at_the_pose(robot_and_poses):
    robot, poses = robot_and_poses
    model = robot.tree.model
    data = model.createData()
    for T in poses:
        q = tree_configuration(model, T, robot.inverse_geometry(T))
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        platform = data.oMf[model.getFrameId("platform")]
        np.testing.assert_allclose(platform.homogeneous, T, rtol=0, atol=1e-14 * scale(robot))
        for i in range(6):
            P_i = platform.act(robot.description.platform_points[i])  # by Pinocchio
            tip = data.oMf[model.getFrameId(tip_frame(i))].translation
            np.testing.assert_allclose(tip, P_i, rtol=0, atol=TIP_TOLERANCE * scale(robot))


def test_tip_frame_z_axis_runs_along_the_leg(robot_and_poses):
    robot, poses = robot_and_poses
    desc = robot.description
    model = robot.leg_models[2]
    data = model.createData()
    for T in poses:
        q = robot.inverse_geometry(T)
        pin.framesForwardKinematics(model, data, q[2])
        z3 = data.oMf[model.getFrameId(tip_frame(2))].rotation[:, 2]
        d = points_in_base(desc, T)[2] - desc.base_points[2]
        np.testing.assert_allclose(z3, d / np.linalg.norm(d), rtol=0, atol=1e-13)
        assert q[2, 2] == pytest.approx(np.linalg.norm(d), rel=1e-14)


def test_second_u_joint_branch_reaches_the_same_point(robot_and_poses):
    robot, poses = robot_and_poses
    for T in poses[:3]:
        q = robot.inverse_geometry(T)
        for i, model in enumerate(robot.leg_models):
            other = np.array([q[i, 0] + np.pi, -q[i, 1], q[i, 2]])
            np.testing.assert_allclose(
                frame_position(model, other, tip_frame(i)),
                frame_position(model, q[i], tip_frame(i)),
                rtol=0,
                atol=TIP_TOLERANCE * scale(robot),
            )


def test_default_branch_ranges(robot_and_poses):
    robot, poses = robot_and_poses
    q = robot.inverse_geometry(poses)
    assert np.all((q[..., 1] > 0) & (q[..., 1] < np.pi))
    assert np.all((q[..., 0] > -np.pi) & (q[..., 0] <= np.pi))


def test_leg_lengths_are_the_distances(robot_and_poses):
    robot, poses = robot_and_poses
    expected = np.array([leg_lengths_by_hand(robot.description, T) for T in poses])
    np.testing.assert_allclose(robot.leg_lengths(poses), expected, rtol=1e-14)
    np.testing.assert_allclose(robot.inverse_geometry(poses)[..., 2], expected, rtol=1e-14)


# ---------------------------------------------------------------------- forward geometry
def test_forward_geometry_inverts_inverse_geometry(robot_and_poses):
    robot, poses = robot_and_poses
    for T in poses:
        lengths = leg_lengths_by_hand(robot.description, T)
        back = robot.forward_geometry(lengths)
        np.testing.assert_allclose(back, T, rtol=0, atol=1e-10)
        np.testing.assert_allclose(
            leg_lengths_by_hand(robot.description, back), lengths, rtol=0, atol=1e-12
        )


def test_forward_geometry_from_an_explicit_guess(paper):
    T = paper.sample_poses(1, np.random.default_rng(3))[0]
    guess = T.copy()
    guess[:3, 3] += 0.01  # [m]
    back = paper.forward_geometry(leg_lengths_by_hand(paper.description, T), guess=guess)
    np.testing.assert_allclose(back, T, rtol=0, atol=1e-10)


def test_forward_geometry_convergence_error(desktop):
    T = desktop.home_pose
    guess = T.copy()
    guess[:3, 3] += [0.02, -0.01, 0.03]  # [m], far for a 10 cm robot
    guess[:3, :3] = pin.exp3(np.array([0.3, -0.2, 0.4])) @ guess[:3, :3]
    lengths = leg_lengths_by_hand(desktop.description, T)
    with pytest.raises(ConvergenceError, match="did not converge in 1 iterations") as info:
        desktop.forward_geometry(lengths, guess=guess, max_iterations=1)
    assert info.value.iterations == 1
    assert info.value.residual > 1e-12
    assert isinstance(info.value, RuntimeError)


def test_forward_geometry_rejects_lengths_outside_the_stroke(desktop):
    lengths = leg_lengths_by_hand(desktop.description, desktop.home_pose)
    lengths[4] = 1.0  # [m]
    with pytest.raises(StrokeLimitError, match="leg 5 length 1 m") as info:
        desktop.forward_geometry(lengths)
    assert info.value.leg == 5


# ---------------------------------------------------------------------- errors
def test_stroke_limit_error(simulator):
    T = simulator.home_pose
    T[2, 3] += 1.0  # one metre up: beyond the 2.8 m stroke
    lengths = leg_lengths_by_hand(simulator.description, T)
    with pytest.raises(StrokeLimitError, match=r"leg 1 length .* outside its stroke") as info:
        simulator.inverse_geometry(T)
    e = info.value
    assert isinstance(e, WorkspaceError)
    assert e.leg == 1
    assert e.value == pytest.approx(lengths[0], rel=1e-14)
    assert (e.lower, e.upper) == (2.0, 2.8)
    assert e.value > e.upper
    # no limit checks on request
    q = simulator.inverse_geometry(T, check_limits=False)
    np.testing.assert_allclose(q[:, 2], lengths, rtol=1e-14)


def test_stroke_limit_error_below(simulator):
    T = simulator.home_pose
    T[2, 3] -= 0.8  # [m]
    with pytest.raises(StrokeLimitError, match="outside its stroke") as info:
        simulator.inverse_geometry(T)
    assert info.value.value < info.value.lower


def test_joint_limit_error(paper):
    # At the paper robot's home pose every q2i is pi/2 (axes perpendicular to the legs), so
    # q2 limits of [0.1, 1.2] rad exclude it and leg 1 is the first offender.
    limits = [[-np.pi, np.pi], [0.1, 1.2]]
    robot = StewartRobot(paper.description.replace(u_joint_limits=limits))
    with pytest.raises(JointLimitError, match=r"leg 1 U-joint angle q21 = ") as info:
        robot.inverse_geometry(robot.home_pose)
    e = info.value
    assert (e.leg, e.joint, e.lower, e.upper) == (1, 2, 0.1, 1.2)
    assert e.value == pytest.approx(np.pi / 2, abs=1e-9)
    # the same robot without limits reaches the pose
    paper.inverse_geometry(paper.home_pose)


def test_joint_limit_error_on_q1(random_robot):
    robot = random_robot(1)
    q = robot.inverse_geometry(robot.home_pose)
    limits = np.tile([[-np.pi, np.pi], [0.0, np.pi]], (6, 1, 1))
    limits[3, 0] = (q[3, 0] + 0.1, q[3, 0] + 0.5)  # leg 4's q1 sits below its range
    limited = StewartRobot(robot.description.replace(u_joint_limits=limits))
    with pytest.raises(JointLimitError, match="leg 4 U-joint angle q14") as info:
        limited.inverse_geometry(robot.home_pose)
    assert (info.value.leg, info.value.joint) == (4, 1)
    assert info.value.value < info.value.lower


def test_singularity_error_when_a_leg_lies_along_its_first_axis(desktop):
    desc = desktop.description
    T = desc.home_pose
    d = points_in_base(desc, T)[2] - desc.base_points[2]  # leg 3 at home
    rotations = np.array(desc.leg_base_rotations)
    rotations[2] = leg_base_rotation_from_axis(d, [1.0, 0.0, 0.0])
    robot = StewartRobot(desc.replace(leg_base_rotations=rotations))
    with pytest.raises(SingularityError, match="leg 3 lies along its first U-joint axis") as info:
        robot.inverse_geometry(T)
    assert info.value.leg == 3
    assert info.value.value < info.value.threshold


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda T: T * np.where(np.arange(4) == 0, np.nan, 1.0), "non-finite"),
        (lambda T: np.diag([1.1, 1.0, 1.0, 1.0]) @ T, "not a rotation"),
        (lambda T: np.diag([1.0, 1.0, -1.0, 1.0]) @ T, "reflection"),
        (lambda T: T + np.eye(4)[3] * 0.5, r"last row .*must be \[0, 0, 0, 1\]"),
        (lambda T: T[:3], r"must have shape \(4, 4\)"),
        (lambda T: T.ravel(), r"must have shape \(4, 4\)"),
        (lambda T: [[T]], r"must have shape \(4, 4\)"),
        (lambda T: "home", "numeric array"),
    ],
)
def test_bad_pose_raises_input_error(desktop, make, message):
    with pytest.raises(InputError, match=message):
        desktop.inverse_geometry(make(desktop.home_pose))


def test_bad_pose_in_a_batch_raises_input_error(desktop):
    poses = np.stack([desktop.home_pose] * 3)
    poses[1, :3, :3] *= 1.01
    with pytest.raises(InputError, match=r"pose\[1\] rotation block is not a rotation"):
        desktop.inverse_geometry(poses)


def test_bad_lengths_raise_input_error(desktop):
    with pytest.raises(InputError, match=r"lengths must have shape \(6,\)"):
        desktop.forward_geometry(np.ones(5))
    with pytest.raises(InputError, match="non-finite"):
        desktop.forward_geometry([0.15] * 5 + [np.nan])


# ---------------------------------------------------------------------- input forms
def test_se3_pose_is_accepted(random_robot):
    robot = random_robot(2)
    T = robot.sample_poses(1, np.random.default_rng(0))[0]
    M = pin.SE3(T[:3, :3], T[:3, 3])
    np.testing.assert_array_equal(robot.inverse_geometry(M), robot.inverse_geometry(T))
    both = robot.inverse_geometry([M, M])
    assert both.shape == (2, 6, 3)
    np.testing.assert_array_equal(both[1], robot.inverse_geometry(T))


def test_batch_equals_per_pose(robot_and_poses):
    robot, poses = robot_and_poses
    batch = robot.inverse_geometry(poses)
    assert batch.shape == (len(poses), 6, 3)
    for n, T in enumerate(poses):
        np.testing.assert_array_equal(batch[n], robot.inverse_geometry(T))
    lengths = robot.leg_lengths(poses)
    assert lengths.shape == (len(poses), 6)
    np.testing.assert_array_equal(lengths[3], robot.leg_lengths(poses[3]))


def test_a_batch_reports_the_first_bad_pose(simulator):
    poses = np.stack([simulator.home_pose] * 4)
    poses[2, 2, 3] += 1.0  # [m]
    with pytest.raises(StrokeLimitError):
        simulator.inverse_geometry(poses)


def test_singularity_error_for_a_zero_length_leg(desktop):
    """B_1 and P_1 coincide: q1, q2 are undefined even without stroke checks."""
    d = desktop.description
    T = np.eye(4)
    T[:3, 3] = d.base_points[0] - d.platform_points[0]
    with pytest.raises(SingularityError, match="leg 1 has zero length") as e:
        desktop.inverse_geometry(T, check_limits=False)
    assert e.value.leg == 1
