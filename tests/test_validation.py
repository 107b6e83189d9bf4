"""Tests of the independent check (``stewart_pin.check.constrained_dynamics``).

Every reference here is computed without the module under test: finite differences of
Pinocchio's forward kinematics, analytic statics of a platform on six two-force members,
the energy theorem (conservation, power balance), Newton's law for the platform.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import (
    InputError,
    SingularityError,
    StewartRobot,
    random_robot,
)
from stewart_pin.check import constrained_dynamics as val
from stewart_pin.kinematics import workspace
from stewart_pin.kinematics.geometry import inverse_geometry
from stewart_pin.kinematics.workspace import sample_poses, sample_states

ROBOTS = ("simulator", "desktop", "random-1")


def _robot(name: str) -> StewartRobot:
    if name == "random-1":
        return StewartRobot(random_robot(1))
    return StewartRobot.from_preset(name)


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request) -> StewartRobot:
    return _robot(request.param)


@pytest.fixture(scope="module")
def random1() -> StewartRobot:
    return _robot("random-1")


@pytest.fixture(scope="module")
def massless(random1) -> StewartRobot:
    desc = random1.description
    return StewartRobot(desc.replace(leg_inertia=np.zeros((6, 3, 10)), name="massless-legs"))


def _loop_points(model: pin.Model, data: pin.Data, cms, q: np.ndarray) -> np.ndarray:
    """Both points of every loop in F0, (6, 2, 3), from forward kinematics alone."""
    pin.forwardKinematics(model, data, q)
    return np.array(
        [
            [
                (data.oMi[cm.joint1_id] * cm.joint1_placement).translation,
                (data.oMi[cm.joint2_id] * cm.joint2_placement).translation,
            ]
            for cm in cms
        ]
    )


def _pose_along(T: np.ndarray, phi: np.ndarray, dp: np.ndarray) -> np.ndarray:
    out = T.copy()
    out[:3, :3] = pin.exp3(phi) @ T[:3, :3]
    out[:3, 3] = T[:3, 3] + dp
    return out


# ---------------------------------------------------------------------------- kinematics
def test_constraint_jacobian_matches_finite_differences(robot):
    """Jc = R_c1^T d(p1 - p2)/dq, against central differences on the tree's manifold."""
    tree = robot.tree
    model, data = tree.model, tree.model.createData()
    poses, twists, _ = sample_states(robot.description, 3, 11)
    h = 1e-6
    for T, V in zip(poses, twists, strict=True):
        q, _ = val.tree_state(robot, T, V)
        points = _loop_points(model, data, tree.constraints, q)
        # The tree is closed at q: both points of each loop coincide.
        assert np.abs(points[:, 0] - points[:, 1]).max() < 1e-12 * robot.description.size
        R_c1 = [(data.oMi[cm.joint1_id] * cm.joint1_placement).rotation for cm in tree.constraints]
        J_fd = np.empty((18, model.nv))
        for k in range(model.nv):
            e = np.zeros(model.nv)
            e[k] = h
            plus = _loop_points(model, data, tree.constraints, pin.integrate(model, q, e))
            minus = _loop_points(model, data, tree.constraints, pin.integrate(model, q, -e))
            d = (plus[:, 0] - plus[:, 1] - minus[:, 0] + minus[:, 1]) / (2 * h)
            J_fd[:, k] = np.concatenate([R.T @ di for R, di in zip(R_c1, d, strict=True)])
        Jc = val.constraint_jacobian(robot, q)
        assert Jc.shape == (18, 24)
        # Central differences: truncation ~h^2, round-off ~eps/h ~ 1e-10 relative.
        np.testing.assert_allclose(Jc, J_fd, rtol=0, atol=1e-8 * np.abs(J_fd).max())


def test_tree_state_matches_inverse_geometry_differences(robot):
    """Leg rates from Jc v = 0 equal the time derivative of the inverse geometry along
    the motion p(s) = p + v s, R(s) = exp(w s) R (central differences)."""
    tree = robot.tree
    poses, twists, _ = sample_states(robot.description, 4, 5)
    q, v = val.tree_state(robot, poses, twists)
    assert q.shape == (4, 25) and v.shape == (4, 24)
    h = 1e-6
    for n, (T, V) in enumerate(zip(poses, twists, strict=True)):
        plus = inverse_geometry(robot.description, _pose_along(T, V[3:] * h, V[:3] * h), False)
        minus = inverse_geometry(robot.description, _pose_along(T, -V[3:] * h, -V[:3] * h), False)
        qdot_fd = (plus - minus) / (2 * h)
        np.testing.assert_allclose(
            v[n][tree.leg_v_index], qdot_fd, rtol=0, atol=1e-7 * np.abs(qdot_fd).max()
        )
        np.testing.assert_allclose(q[n][tree.leg_q_index], inverse_geometry(robot.description, T))
        R = T[:3, :3]
        np.testing.assert_allclose(v[n][tree.platform_v_index], np.r_[R.T @ V[:3], R.T @ V[3:]])
        placement = pin.XYZQUATToSE3(q[n][tree.platform_q_index])
        np.testing.assert_allclose(placement.homogeneous, T, atol=1e-14)
    q1, v1 = val.tree_state(robot, poses[0], twists[0])
    assert q1.shape == (25,) and v1.shape == (24,)
    np.testing.assert_array_equal(v1, v[0])


# ---------------------------------------------------------------------------- statics
def test_static_massless_legs_balance_the_platform_weight(massless):
    """Analytic statics: six two-force members along a_i hold the platform's weight."""
    desc = massless.description
    m = desc.platform_inertia[9]
    weight = m * desc.gravity
    for T in sample_poses(desc, 5, 2):
        gamma, forces = val.constrained_inverse_dynamics(massless, T, np.zeros(6), np.zeros(6))
        R, p = T[:3, :3], T[:3, 3]
        L = desc.platform_points @ R.T
        a = L + p - desc.base_points
        a /= np.linalg.norm(a, axis=1)[:, None]
        c = R @ desc.platform_inertia[6:9] / m
        scale = np.linalg.norm(weight) * (1.0 + np.linalg.norm(L, axis=1).max())
        np.testing.assert_allclose(a.T @ gamma, -weight, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(
            np.cross(L, a).T @ gamma, -np.cross(c, weight), rtol=0, atol=1e-12 * scale
        )
        # A massless leg transmits a force along itself only: f_i = a_i Gamma_i.
        np.testing.assert_allclose(forces, a * gamma[:, None], rtol=0, atol=1e-12 * scale)


def test_forward_dynamics_with_massless_legs_is_refused(massless):
    """Pinocchio's constrained forward dynamics factors the tree's mass matrix: with
    massless leg links it is singular and the answer non-finite."""
    T = massless.home_pose
    with pytest.raises(SingularityError, match="massless"):
        val.constrained_forward_dynamics(massless, T, np.zeros(6), np.ones(6))


# ---------------------------------------------------------------------------- dynamics
def test_forward_after_inverse_returns_the_acceleration(robot):
    poses, twists, accels = sample_states(robot.description, 20, 1)
    gamma, forces = val.constrained_inverse_dynamics(robot, poses, twists, accels)
    assert gamma.shape == (20, 6) and forces.shape == (20, 6, 3)
    back = val.constrained_forward_dynamics(robot, poses, twists, gamma)
    assert back.shape == (20, 6)
    assert val.relative_error(back, accels) < 1e-9
    g1, f1 = val.constrained_inverse_dynamics(robot, poses[0], twists[0], accels[0])
    assert g1.shape == (6,) and f1.shape == (6, 3)
    np.testing.assert_allclose(g1, gamma[0], rtol=1e-13, atol=0)
    a1 = val.constrained_forward_dynamics(robot, poses[0], twists[0], g1)
    np.testing.assert_allclose(a1, back[0], rtol=1e-12, atol=1e-12)


def test_leg_forces_drive_the_platform(robot):
    """Newton's law for the platform alone: m a_G = sum f_i + m g, with a_G the classical
    acceleration of its centre of mass (textbook rigid-body kinematics)."""
    desc = robot.description
    m = desc.platform_inertia[9]
    poses, twists, accels = sample_states(desc, 5, 8)
    _, forces = val.constrained_inverse_dynamics(robot, poses, twists, accels)
    for T, V, A, f in zip(poses, twists, accels, forces, strict=True):
        c = T[:3, :3] @ desc.platform_inertia[6:9] / m
        w = V[3:]
        a_G = A[:3] + np.cross(A[3:], c) + np.cross(w, np.cross(w, c))
        scale = np.abs(f).sum() + m * np.linalg.norm(desc.gravity)
        np.testing.assert_allclose(m * a_G, f.sum(axis=0) + m * desc.gravity, atol=1e-11 * scale)


def _path_state(T, V, A, s):
    """Pose and twist at time s on p(s) = p + v s + A_v s^2/2, R(s) = exp(phi(s)) R with
    phi(s) = w s + A_w s^2/2: its twist at s = 0 is V and its acceleration A."""
    phi, phidot = V[3:] * s + A[3:] * s**2 / 2, V[3:] + A[3:] * s
    T_s = _pose_along(T, phi, V[:3] * s + A[:3] * s**2 / 2)
    # Angular velocity of exp(phi) R in F0: the left Jacobian, Jl(phi) = Jr(phi)^T.
    w = pin.Jexp3(phi).T @ phidot
    return T_s, np.r_[V[:3] + A[:3] * s, w]


def test_inverse_dynamics_power_balance(robot):
    """dE/dt = Gamma . qdot_a at each state (ideal joints: constraint forces do no
    work), with dE/dt by central differences of Pinocchio's energies along a path
    through the state with the given acceleration."""
    tree = robot.tree
    poses, twists, accels = sample_states(robot.description, 5, 3)
    gamma, _ = val.constrained_inverse_dynamics(robot, poses, twists, accels)
    _, v = val.tree_state(robot, poses, twists)
    h = 1e-5
    for n in range(5):
        E = []
        for s in (h, -h):
            T_s, V_s = _path_state(poses[n], twists[n], accels[n], s)
            E.append(sum(val.energy(robot, T_s, V_s)))
        dE = (E[0] - E[1]) / (2 * h)
        power = gamma[n] @ v[n][tree.actuated_v_index]
        scale = np.abs(gamma[n] * v[n][tree.actuated_v_index]).sum()
        # Central differences: O(h^2) truncation plus ~eps |E| / h round-off.
        assert abs(dE - power) < 1e-8 * scale, (dE, power)


def _rk4_trajectory(robot, T0, V0, gamma, dt, steps):
    """Integrate the platform under constant actuator forces with classical RK4 on
    (phi, p, v, w), R = exp(phi) R_k restarted at each step, pose/twist as the state."""
    poses, twists = [T0.copy()], [V0.copy()]

    def f(R_k, y):
        phi, p, lin, w = y[:3], y[3:6], y[6:9], y[9:]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = pin.exp3(phi) @ R_k, p
        acc = val.constrained_forward_dynamics(robot, T, np.r_[lin, w], gamma)
        # phidot = Jl(phi)^-1 w, Jl = Jr^T.
        return np.r_[np.linalg.solve(pin.Jexp3(phi).T, w), lin, acc]

    T, V = T0.copy(), V0.copy()
    for _ in range(steps):
        R_k = T[:3, :3]
        y = np.r_[np.zeros(3), T[:3, 3], V]
        k1 = f(R_k, y)
        k2 = f(R_k, y + dt / 2 * k1)
        k3 = f(R_k, y + dt / 2 * k2)
        k4 = f(R_k, y + dt * k3)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = pin.exp3(y[:3]) @ R_k, y[3:6]
        V = y[6:]
        poses.append(T)
        twists.append(V.copy())
    return np.array(poses), np.array(twists)


def test_energy_is_conserved_without_actuation(random1):
    """Gamma = 0: kinetic + potential energy stays constant along the motion.

    RK4, dt = 1 ms over 0.1 s: the drift of the total scales as dt^4 (2e-14 of the
    energies here, 2e-10 at dt = 10 ms); dropping the w x v term of the free-flyer
    conversion makes it 2e-5."""
    robot = random1
    rng = np.random.default_rng(4)
    T0 = robot.home_pose
    V0 = np.r_[rng.uniform(-0.2, 0.2, 3), rng.uniform(-0.5, 0.5, 3)]
    poses, twists = _rk4_trajectory(robot, T0, V0, np.zeros(6), 1e-3, 100)
    kinetic, potential = val.energy(robot, poses, twists)
    total = kinetic + potential
    exchanged = np.ptp(kinetic)  # energy really moves between the two forms
    assert exchanged > 0.1 * kinetic.max()
    assert np.ptp(total) < 1e-12 * (np.abs(kinetic).max() + np.abs(potential).max())


def test_power_balance_along_an_actuated_trajectory(random1):
    """dE/dt (central differences of the energy along an RK4 trajectory, dt = 1 ms,
    60 ms) equals the actuators' power Gamma . qdot_a."""
    robot = random1
    tree = robot.tree
    T0 = robot.home_pose
    hold, _ = val.constrained_inverse_dynamics(robot, T0, np.zeros(6), np.zeros(6))
    gamma = hold * np.array([1.3, 0.8, 1.1, 0.9, 1.2, 0.7])
    dt = 1e-3
    poses, twists = _rk4_trajectory(robot, T0, np.zeros(6), gamma, dt, 60)
    E = np.sum(val.energy(robot, poses, twists), axis=0)
    # Five-point central differences: truncation O(dt^4), ~1e-9 of the power here (the
    # three-point stencil's O(dt^2) error is ~3e-5).
    dE = (-E[4:] + 8 * E[3:-1] - 8 * E[1:-3] + E[:-4]) / (12 * dt)
    _, v = val.tree_state(robot, poses[2:-2], twists[2:-2])
    power = v[:, tree.actuated_v_index] @ gamma
    assert np.abs(power).max() > 1.0  # the actuators do real work
    assert np.abs(dE - power).max() < 1e-8 * np.abs(power).max()


# ---------------------------------------------------------------------------- inputs
def test_bad_inputs_raise(random1):
    T = random1.home_pose
    z = np.zeros(6)
    with pytest.raises(InputError, match="twist"):
        val.tree_state(random1, T, np.zeros(5))
    with pytest.raises(InputError, match="accel"):
        val.constrained_inverse_dynamics(random1, T, z, np.full(6, np.nan))
    with pytest.raises(InputError, match="gamma"):
        val.constrained_forward_dynamics(random1, T, z, np.zeros((2, 6)))
    with pytest.raises(InputError, match="states"):
        val.constrained_inverse_dynamics(random1, T[None], z[None], np.zeros((2, 6)))
    with pytest.raises(InputError, match="pose"):
        val.energy(random1, np.eye(3), z)
    with pytest.raises(InputError, match="shape"):
        val.constraint_jacobian(random1, np.zeros(24))
    with pytest.raises(InputError, match="n_states"):
        val.validate(random1, n_states=0)
    with pytest.raises(TypeError, match="StewartRobot"):
        val.tree_state(object(), T, z)


def test_relative_error_uses_the_floor():
    b = np.array([[1.0, -2.0], [0.0, 0.0]])
    a = b + np.array([[0.02, 0.0], [1e-9, 0.0]])
    assert val.relative_error(a, b) == pytest.approx(max(0.01, 1e-9 / (2.0 * 1e-6)))
    assert val.relative_error(b, b) == 0.0
    with pytest.raises(InputError):
        val.relative_error(a, b[:1])


# ---------------------------------------------------------------------------- validate
class _ReferenceRobot(StewartRobot):
    """A robot whose 'paper models' are the reference itself, optionally perturbed."""

    def __init__(self, description, error: float = 0.0):
        super().__init__(description)
        self.error = error

    def inverse_dynamics(self, poses, twists, accels):
        gamma, _ = val.constrained_inverse_dynamics(self, poses, twists, accels)
        return gamma * (1 + self.error)

    def direct_dynamics(self, poses, twists, gammas):
        return val.constrained_forward_dynamics(self, poses, twists, gammas) * (1 + self.error)


def test_validate_report_machinery(random1):
    exact = val.validate(_ReferenceRobot(random1.description), n_states=10, seed=1)
    assert exact.n_states == 10 and exact.robot == "random-1"
    assert exact.idm_error == 0.0 and exact.ddm_error == 0.0
    assert exact.round_trip_error < 1e-9 and exact.reference_error < 1e-9
    assert exact.passed()
    assert "PASSED" in str(exact) and "10 random states" in str(exact)
    off = val.validate(_ReferenceRobot(random1.description, error=1e-6), n_states=10, seed=1)
    assert off.idm_error == pytest.approx(1e-6, rel=1e-6)
    assert not off.passed() and off.passed(tol_idm=1e-5, tol_ddm=1e-5)
    assert "FAILED" in str(off)


class _NoModels:
    """Has a description and a tree, but no dynamic models to validate."""

    def __init__(self, robot):
        self.description, self.tree = robot.description, robot.tree


def test_validate_needs_the_models(random1):
    with pytest.raises(TypeError, match="inverse_dynamics"):
        val.validate(_NoModels(random1), n_states=1)


@pytest.mark.parametrize("name", ROBOTS)
def test_paper_models_agree_with_the_constrained_tree(name):
    report = val.validate(_robot(name), n_states=30, seed=0)
    assert report.passed(), str(report)


# ---------------------------------------------------------------------------- item 17
@pytest.fixture(scope="module")
def tiny_stroke(random1) -> StewartRobot:
    """random-1 with a stroke just 2 mm wider than its home leg lengths on each side."""
    desc = random1.description
    lengths = random1.leg_lengths(desc.home_pose)
    stroke = [lengths.min() - 2e-3, lengths.max() + 2e-3]
    return StewartRobot(desc.replace(stroke=stroke, name="tiny-stroke"))


#: A sampling range that keeps every leg of ``tiny_stroke`` inside its stroke [m, rad].
SMALL_RANGE = {"translation_range": 5e-4, "rotation_range": 5e-4}


class _WrongModel(StewartRobot):
    """The tree (the reference) of one description, the paper's models of another."""

    def __init__(self, description, model_description):
        super().__init__(description)
        self._model = StewartRobot(model_description)

    def inverse_dynamics(self, poses, twists, accels):
        return self._model.inverse_dynamics(poses, twists, accels)

    def direct_dynamics(self, poses, twists, gammas):
        return self._model.direct_dynamics(poses, twists, gammas)


def test_validate_takes_the_sampling_range_for_a_small_workspace(tiny_stroke):
    from stewart_pin import WorkspaceError

    with pytest.raises(WorkspaceError, match="translation_range, rotation_range"):
        val.validate(tiny_stroke, n_states=10)  # the default range leaves the stroke
    report = val.validate(tiny_stroke, n_states=10, seed=3, **SMALL_RANGE)
    assert report.passed(), str(report)
    assert report.n_states == 10 and report.robot == "tiny-stroke"


def test_validate_with_a_small_range_still_catches_a_wrong_model(tiny_stroke):
    desc = tiny_stroke.description
    heavier = desc.platform_inertia * 1.01  # platform mass and moments 1 % off
    wrong = _WrongModel(desc, desc.replace(platform_inertia=heavier))
    report = val.validate(wrong, n_states=10, seed=3, **SMALL_RANGE)
    assert not report.passed()
    assert report.idm_error > 1e-4 and report.ddm_error > 1e-4
    off = val.validate(_ReferenceRobot(desc, error=1e-6), n_states=10, seed=3, **SMALL_RANGE)
    assert off.idm_error == pytest.approx(1e-6, rel=1e-6) and not off.passed()


def test_validate_samples_inside_the_given_range(tiny_stroke, monkeypatch):
    """The states compared are drawn within the range: |dp_k| <= translation_range and the
    rotation from the home orientation at most sqrt(3) rotation_range (a rotation vector
    with every component in [-r, r])."""
    drawn = []

    def recording(*args, **kwargs):
        states = sample_states(*args, **kwargs)
        drawn.append(states[0])
        return states

    # validate draws through the robot (RobotLike.sample_states), which samples here
    monkeypatch.setattr(workspace, "sample_states", recording)
    val.validate(tiny_stroke, n_states=20, seed=4, translation_range=3e-4, rotation_range=2e-4)
    (poses,) = drawn
    home = tiny_stroke.home_pose
    assert np.abs(poses[:, :3, 3] - home[:3, 3]).max() <= 3e-4
    angles = [np.linalg.norm(pin.log3(T[:3, :3] @ home[:3, :3].T)) for T in poses]
    assert max(angles) <= np.sqrt(3) * 2e-4 * (1 + 1e-9)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"translation_range": float("nan")},
        {"translation_range": -1e-3},
        {"rotation_range": float("inf")},
        {"rotation_range": -0.1},
        {"rotation_range": "0.1"},
        {"n_states": 0},
        {"n_states": 2.5},
        {"seed": -1},
    ],
)
def test_validate_refuses_bad_ranges_and_counts(random1, kwargs):
    with pytest.raises(InputError):
        val.validate(random1, **{"n_states": 2, **kwargs})


# ---------------------------------------------------------------------------- item 5
def test_reference_overflow_is_a_numerical_error_not_a_singularity(random1):
    """The constrained tree's own checks name an overflow (twist 1e160 m/s, finite) as one,
    at its state, instead of a singular configuration or a NaN energy."""
    import warnings

    from stewart_pin import NumericalError

    poses, twists, accels = sample_states(random1.description, 3, 5)
    fast = twists.copy()
    fast[1, :3] = 1e160
    calls = [
        lambda: val.constrained_inverse_dynamics(random1, poses, fast, accels),
        lambda: val.constrained_forward_dynamics(random1, poses, fast, np.zeros((3, 6))),
        lambda: val.energy(random1, poses, fast),
    ]
    for call in calls:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            with pytest.raises(NumericalError, match="at state 1") as info:
                call()
        assert info.value.index == 1
