"""Kinematic models (stewart_pin.kinematics.jacobians): Jp^-1, leg Jacobians, first and second
order.

References: central finite differences on SE(3) of independently computed leg lengths,
Pinocchio's forward kinematics, frame Jacobians and classical frame accelerations of the
generated leg models, and a platform trajectory whose twist and acceleration are derived
analytically here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot
from helpers import frame_position, leg_lengths_by_hand, tip_frame

from stewart_pin import InputError, SingularityError, StewartRobot
from stewart_pin.kinematics.jacobians import leg_drift, leg_inverse_jacobians
from stewart_pin.kinematics.workspace import sample_states

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@pytest.fixture(scope="module", params=["simulator", "paper", "random-0", "random-2"])
def robot(request) -> StewartRobot:
    return get_robot(request.param)


def perturbed(T: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """The pose moved by a small twist [v, w] of O_p in F0: p += v, R <- exp3(w) R."""
    out = T.copy()
    out[:3, 3] += twist[:3]
    out[:3, :3] = pin.exp3(twist[3:]) @ T[:3, :3]
    return out


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi], for differences of q1 near the branch cut."""
    return np.angle(np.exp(1j * angle))


# ---------------------------------------------------------------------- a smooth trajectory
@dataclass
class Trajectory:
    """T(t) with R(t) = exp3(th1(t) n1) exp3(th2(t) n2) R0 and a cubic p(t): its twist
    [v, w] of O_p in F0 and classical acceleration [dv/dt, dw/dt], derived by hand:

        w    = th1' n1 + th2' R1 n2                      (R1 = exp3(th1 n1))
        dw/dt = th1'' n1 + th2'' R1 n2 + th2' th1' n1 x (R1 n2)
    """

    T0: np.ndarray
    n1: np.ndarray
    n2: np.ndarray
    th1: np.ndarray  # cubic coefficients [c1, c2, c3] of th1(t) = c1 t + c2 t^2 + c3 t^3
    th2: np.ndarray
    p: np.ndarray  # (3, 3): rows c1, c2, c3 of p(t) - p0

    @staticmethod
    def random(T0: np.ndarray, size: float, rng: np.random.Generator) -> Trajectory:
        n1, n2 = rng.normal(size=3), rng.normal(size=3)
        return Trajectory(
            T0,
            n1 / np.linalg.norm(n1),
            n2 / np.linalg.norm(n2),
            rng.uniform(-0.3, 0.3, 3),
            rng.uniform(-0.3, 0.3, 3),
            rng.uniform(-0.05, 0.05, (3, 3)) * size,
        )

    @staticmethod
    def _poly(c: np.ndarray, t: float) -> tuple:
        value = c[0] * t + c[1] * t**2 + c[2] * t**3
        rate = c[0] + 2 * c[1] * t + 3 * c[2] * t**2
        accel = 2 * c[1] + 6 * c[2] * t
        return value, rate, accel

    def pose(self, t: float) -> np.ndarray:
        a, _, _ = self._poly(self.th1, t)
        b, _, _ = self._poly(self.th2, t)
        T = self.T0.copy()
        T[:3, :3] = pin.exp3(a * self.n1) @ pin.exp3(b * self.n2) @ self.T0[:3, :3]
        T[:3, 3] += self._poly(self.p, t)[0]
        return T

    def twist(self, t: float) -> np.ndarray:
        a, ad, _ = self._poly(self.th1, t)
        _, bd, _ = self._poly(self.th2, t)
        m = pin.exp3(a * self.n1) @ self.n2
        return np.concatenate([self._poly(self.p, t)[1], ad * self.n1 + bd * m])

    def accel(self, t: float) -> np.ndarray:
        a, ad, add = self._poly(self.th1, t)
        _, bd, bdd = self._poly(self.th2, t)
        m = pin.exp3(a * self.n1) @ self.n2
        wdot = add * self.n1 + bdd * m + bd * ad * np.cross(self.n1, m)
        return np.concatenate([self._poly(self.p, t)[2], wdot])


@pytest.fixture(scope="module")
def trajectories(robot) -> list[Trajectory]:
    rng = np.random.default_rng(11)
    size = robot.description.stroke_mid
    # Start well inside the workspace, so that the whole path stays in the stroke.
    poses = robot.sample_poses(3, rng, translation=0.05 * size, rotation=0.1)
    return [Trajectory.random(T, size, rng) for T in poses]


def test_trajectory_twist_and_accel_match_finite_differences(robot, trajectories):
    """The hand derivation of the reference trajectory, checked once by differences."""
    h = 1e-5  # [s]
    for traj in trajectories:
        for t in (-0.2, 0.0, 0.25):
            Tm, Tp = traj.pose(t - h), traj.pose(t + h)
            v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
            w = pin.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
            np.testing.assert_allclose(np.r_[v, w], traj.twist(t), rtol=0, atol=1e-8)
            acc = (traj.twist(t + h) - traj.twist(t - h)) / (2 * h)
            np.testing.assert_allclose(acc, traj.accel(t), rtol=0, atol=1e-8)


# ---------------------------------------------------------------------- Jp^-1
def test_inverse_jacobian_matches_finite_differences_of_leg_lengths(robot):
    desc, h = robot.description, 1e-6  # step along the twist [m, rad]
    for T in robot.sample_poses(5, np.random.default_rng(1)):
        J_inv = robot.inverse_jacobian(T)
        fd = np.empty((6, 6))
        for k in range(6):
            e = np.eye(6)[k] * h
            fd[:, k] = (
                leg_lengths_by_hand(desc, perturbed(T, e))
                - leg_lengths_by_hand(desc, perturbed(T, -e))
            ) / (2 * h)
        np.testing.assert_allclose(J_inv, fd, rtol=0, atol=1e-8)


def test_inverse_jacobian_rows_are_unit_leg_directions(robot):
    # The linear block of row i is the unit vector along the leg (eq. 13).
    for T in robot.sample_poses(3, np.random.default_rng(2)):
        np.testing.assert_allclose(
            np.linalg.norm(robot.inverse_jacobian(T)[:, :3], axis=1), 1.0, rtol=1e-14
        )


def test_jacobian_inverts_inverse_jacobian(robot):
    poses = robot.sample_poses(4, np.random.default_rng(3))
    J, J_inv = robot.jacobian(poses), robot.inverse_jacobian(poses)
    assert J.shape == J_inv.shape == (4, 6, 6)
    for n in range(4):
        np.testing.assert_allclose(J[n] @ J_inv[n], np.eye(6), rtol=0, atol=1e-10)
        np.testing.assert_array_equal(J[n], robot.jacobian(poses[n]))
        np.testing.assert_array_equal(J_inv[n], robot.inverse_jacobian(poses[n]))


def test_condition_number(robot):
    poses = robot.sample_poses(4, np.random.default_rng(4))
    c = robot.condition_number(poses)
    assert c.shape == (4,)
    assert np.all(c >= 1.0)
    # The measure is unit-free: Jp^-1's angular columns divided by the platform radius.
    P = robot.description.platform_points
    radius = np.linalg.norm(P - P.mean(axis=0), axis=1).mean()
    scale = np.diag([1.0, 1.0, 1.0, 1.0 / radius, 1.0 / radius, 1.0 / radius])
    s = np.linalg.svd(robot.inverse_jacobian(poses[0]) @ scale, compute_uv=False)
    assert robot.condition_number(poses[0]) == pytest.approx(s[0] / s[-1], rel=1e-12)


def test_singularity_error_past_max_condition(paper):
    strict = StewartRobot(paper.description, max_condition=1.0)
    with pytest.raises(SingularityError, match=r"cond\(Jp\^-1\) = .* > 1") as info:
        strict.jacobian(paper.home_pose)
    assert info.value.threshold == 1.0
    assert info.value.value == pytest.approx(paper.condition_number(paper.home_pose), rel=1e-12)
    assert info.value.leg is None


@pytest.mark.parametrize("name", ["simulator", "desktop"])
def test_fichter_singularity(name):
    # Fichter (1986): a symmetric 6-6 hexapod whose platform turns by +/- 90 degrees about
    # the vertical axis from its central orientation is singular, at any height.
    robot = get_robot(name)
    for sign in (1.0, -1.0):
        T = robot.home_pose
        T[:3, :3] = pin.exp3(np.array([0.0, 0.0, sign * np.pi / 2])) @ T[:3, :3]
        assert robot.condition_number(T) > 1e12
        with pytest.raises(SingularityError, match="parallel singularity"):
            robot.jacobian(T)


def test_sample_poses_respect_max_condition(paper):
    robot = StewartRobot(paper.description, max_condition=20.0)
    assert np.all(robot.condition_number(robot.sample_poses(20, 0, rotation=0.4)) <= 20.0)


# ---------------------------------------------------------------------- leg Jacobians
def test_leg_jacobians_match_pinocchio(robot):
    h = 1e-6  # [rad, m]
    for T in robot.sample_poses(3, np.random.default_rng(5)):
        q, J = robot.inverse_geometry(T), robot.leg_jacobians(T)
        for i, model in enumerate(robot.leg_models):
            data, fid = model.createData(), model.getFrameId(tip_frame(i))
            J_pin = pin.computeFrameJacobian(model, data, q[i], fid, LWA)[:3]
            np.testing.assert_allclose(J[i], J_pin, rtol=0, atol=1e-12)
            fd = np.column_stack(
                [
                    (
                        frame_position(model, q[i] + h * e, tip_frame(i))
                        - frame_position(model, q[i] - h * e, tip_frame(i))
                    )
                    / (2 * h)
                    for e in np.eye(3)
                ]
            )
            np.testing.assert_allclose(J[i], fd, rtol=0, atol=1e-8)


def test_leg_inverse_jacobians_invert_pinocchio_jacobians(robot):
    T = robot.sample_poses(1, np.random.default_rng(6))[0]
    q = robot.inverse_geometry(T)
    J_inv = leg_inverse_jacobians(robot.description, q[None])[0]
    for i, model in enumerate(robot.leg_models):
        data, fid = model.createData(), model.getFrameId(tip_frame(i))
        J_pin = pin.computeFrameJacobian(model, data, q[i], fid, LWA)[:3]
        np.testing.assert_allclose(J_inv[i] @ J_pin, np.eye(3), rtol=0, atol=1e-10)


# ---------------------------------------------------------------------- first and second order
def test_qdot_matches_finite_differences_of_inverse_geometry(robot, trajectories):
    h = 1e-5  # [s]
    for traj in trajectories:
        for t in (-0.2, 0.0, 0.25):
            _, qdot, _ = robot.leg_kinematics(traj.pose(t), traj.twist(t))
            qm, qp = (
                robot.inverse_geometry(traj.pose(t - h)),
                robot.inverse_geometry(traj.pose(t + h)),
            )
            fd = (qp - qm) / (2 * h)
            fd[:, :2] = wrap(qp[:, :2] - qm[:, :2]) / (2 * h)
            np.testing.assert_allclose(qdot, fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))


def test_qddot_matches_finite_differences_of_qdot(robot, trajectories):
    h = 1e-5  # [s]
    for traj in trajectories:
        for t in (-0.2, 0.0, 0.25):
            _, _, qddot = robot.leg_kinematics(traj.pose(t), traj.twist(t), traj.accel(t))
            _, qd_m, _ = robot.leg_kinematics(traj.pose(t - h), traj.twist(t - h))
            _, qd_p, _ = robot.leg_kinematics(traj.pose(t + h), traj.twist(t + h))
            fd = (qd_p - qd_m) / (2 * h)
            np.testing.assert_allclose(qddot, fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))


@pytest.fixture(scope="module")
def states(robot):
    return sample_states(robot.description, 6, np.random.default_rng(8))


def point_motion(T: np.ndarray, pP: np.ndarray, V: np.ndarray, A: np.ndarray) -> tuple:
    """Velocity and classical acceleration of the platform point pP (in Fp), in F0 (eq. 5-7)."""
    L = T[:3, :3] @ pP
    v, w, vd, wd = V[:3], V[3:], A[:3], A[3:]
    return v + np.cross(w, L), vd + np.cross(wd, L) + np.cross(w, np.cross(w, L))


def test_leg_kinematics_match_pinocchio_velocity_and_classical_acceleration(robot, states):
    desc = robot.description
    poses, twists, accels = states
    q, qdot, qddot = robot.leg_kinematics(poses, twists, accels)
    for n in range(len(poses)):
        for i, model in enumerate(robot.leg_models):
            data, fid = model.createData(), model.getFrameId(tip_frame(i))
            pin.forwardKinematics(model, data, q[n, i], qdot[n, i], qddot[n, i])
            pin.updateFramePlacements(model, data)
            V_P, A_P = point_motion(poses[n], desc.platform_points[i], twists[n], accels[n])
            vel = pin.getFrameVelocity(model, data, fid, LWA).linear
            acc = pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear
            np.testing.assert_allclose(vel, V_P, rtol=0, atol=1e-10 * np.abs(V_P).max())
            np.testing.assert_allclose(acc, A_P, rtol=0, atol=1e-10 * np.abs(A_P).max())


def test_leg_drift_is_the_classical_tip_acceleration_at_zero_qddot(robot, states):
    poses, twists, _ = states
    q, qdot, _ = robot.leg_kinematics(poses, twists)
    drift = leg_drift(robot.description, q, qdot)
    assert drift.shape == (len(poses), 6, 3)
    for n in range(len(poses)):
        for i, model in enumerate(robot.leg_models):
            data, fid = model.createData(), model.getFrameId(tip_frame(i))
            pin.forwardKinematics(model, data, q[n, i], qdot[n, i], np.zeros(3))
            pin.updateFramePlacements(model, data)
            acc = pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear
            np.testing.assert_allclose(drift[n, i], acc, rtol=0, atol=1e-10 * np.abs(acc).max())


def test_leg_kinematics_single_state_and_batch_agree(robot, states):
    poses, twists, accels = states
    batch = robot.leg_kinematics(poses, twists, accels)
    one = robot.leg_kinematics(poses[2], twists[2], accels[2])
    for b, o in zip(batch, one, strict=True):
        assert o.shape == (6, 3)
        np.testing.assert_array_equal(b[2], o)
    _, qdot, qddot = robot.leg_kinematics(poses[2], twists[2])
    assert qddot is None
    np.testing.assert_array_equal(qdot, one[1])


def test_leg_kinematics_input_errors(desktop):
    T = desktop.home_pose
    with pytest.raises(InputError, match=r"twist must have shape \(6,\)"):
        desktop.leg_kinematics(T, np.zeros(5))
    with pytest.raises(InputError, match="twist holds a non-finite"):
        desktop.leg_kinematics(T, [0, 0, np.nan, 0, 0, 0])
    with pytest.raises(InputError, match="twist has 2 states but pose has 1"):
        desktop.leg_kinematics(T, np.zeros((2, 6)))
    with pytest.raises(InputError, match="accel has 1 states but pose has 3"):
        desktop.leg_kinematics(np.stack([T] * 3), np.zeros((3, 6)), np.zeros(6))


def test_cheap_singularity_bound_keeps_the_exact_decision(robot: StewartRobot) -> None:
    """check_singularity (Frobenius bound, SVD only past it) accepts and refuses exactly
    where the SVD condition number of the scaled Jp^-1 (numpy's, computed here) says: at
    thresholds just above and just below each state's measure, and far above it."""
    from stewart_pin.kinematics.geometry import characteristic_length
    from stewart_pin.kinematics.jacobians import check_singularity

    desc = robot.description
    poses, _, _ = sample_states(desc, 20, 11)
    for T in poses:
        J = robot.inverse_jacobian(T)[None]
        S = J.copy()
        S[..., 3:] /= characteristic_length(desc)
        c = float(np.linalg.cond(S[0]))
        check_singularity(J, 1e6 * c, desc)  # the bound suffices
        check_singularity(J, c * (1 + 1e-9), desc)  # the bound exceeds it: exact decides
        with pytest.raises(SingularityError):
            check_singularity(J, c * (1 - 1e-9), desc)
    # Exactly singular (two equal rows): refused, with the exact measure's error.
    J = robot.inverse_jacobian(poses[0])[None].copy()
    J[0, 1] = J[0, 0]
    with pytest.raises(SingularityError):
        check_singularity(J, 1e12, desc)
