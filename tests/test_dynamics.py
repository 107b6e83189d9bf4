"""The paper's inverse and direct dynamic models (closure.py through StewartRobot).

References, all independent of the closure layer's algebra:
- the round trip DDM(IDM(x)) == x, and A_robot symmetric positive definite;
- the energy theorem: actuator power Gamma . qdot_a equals dE/dt of the total energy,
  computed from Pinocchio's leg energies and the platform's rigid-body energy;
- energy conservation along a trajectory of the direct model with Gamma = 0;
- massless legs: Gamma equals the platform's Newton-Euler wrench computed with
  Pinocchio's spatial algebra (pin.Inertia, pin.Motion), mapped by Jp^T;
- Pinocchio's 3-dof leg models for H_i, A_i, h_i.
The comparison with Pinocchio's constrained dynamics on the closed-loop tree lives in
test_validation.py.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from helpers import rel_error

from stewart_pin import (
    InputError,
    SingularityError,
    StewartRobot,
    StrokeLimitError,
    random_robot,
)
from stewart_pin.kinematics.workspace import sample_states

ROBOTS = ["simulator", "desktop", "paper", "random-1", "random-7"]


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request) -> StewartRobot:
    return StewartRobot.from_preset(request.param)


def test_round_trip_direct_of_inverse(robot):
    poses, twists, accels = sample_states(robot.description, 200, 11)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    back = robot.direct_dynamics(poses, twists, gamma)
    # Exact algebra on both sides: round-off only.
    assert rel_error(back, accels) < 1e-10


def test_single_state_equals_batch(robot):
    poses, twists, accels = sample_states(robot.description, 3, 5)
    batch = robot.inverse_dynamics(poses, twists, accels)
    for n in range(3):
        single = robot.inverse_dynamics(poses[n], twists[n], accels[n])
        assert single.shape == (6,)
        np.testing.assert_allclose(single, batch[n], rtol=0, atol=1e-12 * np.abs(batch).max())
        se3 = robot.inverse_dynamics(pin.SE3(poses[n]), twists[n], accels[n])
        np.testing.assert_allclose(se3, single, rtol=1e-14, atol=0)


def test_A_robot_symmetric_positive_definite(robot):
    poses, twists, _ = sample_states(robot.description, 100, 3)
    cd = robot.cartesian_dynamics(poses, twists)
    A = cd.A_robot
    assert np.abs(A - np.swapaxes(A, 1, 2)).max() <= 1e-12 * np.abs(A).max()
    assert np.linalg.eigvalsh(A).min() > 0


def test_details_are_consistent(robot):
    poses, twists, accels = sample_states(robot.description, 20, 4)
    res = robot.inverse_dynamics(poses, twists, accels, details=True)
    total = res.platform_share + res.leg_shares.sum(axis=1)
    assert rel_error(total, res.gamma) < 1e-12
    # The leg forces on the platform balance its Newton-Euler equations (eq. 30):
    # sum_i [f_i; L_i x f_i] = F_p.
    L = res.legs.L
    wrench = np.concatenate(
        [res.leg_forces.sum(axis=1), np.cross(L, res.leg_forces).sum(axis=1)], axis=-1
    )
    assert rel_error(wrench, res.F_p) < 1e-10


def _trajectory(robot: StewartRobot, t: float):
    """A smooth analytic motion: polynomial position, rotation about a fixed axis.

    Returns the pose, twist [v, w] and classical acceleration, exactly.
    """
    T0 = robot.home_pose
    s = robot.description.stroke_mid
    c1, c2 = np.array([0.3, -0.2, 0.25]) * s, np.array([-0.4, 0.3, 0.2]) * s
    p = T0[:3, 3] + c1 * t + c2 * t**2
    v = c1 + 2 * c2 * t
    a = 2 * c2
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    th, thd, thdd = 0.6 * t - 0.5 * t**2, 0.6 - t, -1.0
    T = np.eye(4)
    T[:3, :3] = pin.exp3(th * axis) @ T0[:3, :3]
    T[:3, 3] = p
    return T, np.concatenate([v, thd * axis]), np.concatenate([a, thdd * axis])


def test_power_equals_energy_rate(robot):
    """Energy theorem along an arbitrary motion: Gamma . qdot_a = dE/dt."""
    h = 1e-4
    for t in (0.05, 0.2, 0.35):
        T, V, A = _trajectory(robot, t)
        gamma = robot.inverse_dynamics(T, V, A)
        power = gamma @ (robot.inverse_jacobian(T) @ V)
        E_plus = robot.energy(*_trajectory(robot, t + h)[:2])
        E_minus = robot.energy(*_trajectory(robot, t - h)[:2])
        E_rate = (E_plus - E_minus) / (2 * h)
        # Central difference: O(h^2) truncation, relative to the gravity power scale.
        scale = np.abs(gamma).max() * np.abs(robot.inverse_jacobian(T) @ V).max()
        assert abs(power - E_rate) < 1e-6 * scale


def _rk4_step(robot: StewartRobot, x: np.ndarray, dt: float) -> np.ndarray:
    """One RK4 step of the free motion (Gamma = 0) on x = [p, quaternion xyzw, v, w].

    The quaternion obeys qdot = 1/2 [w, 0] * q (w in F0) and is renormalised after the step.
    """

    def f(x):
        quat = pin.Quaternion(x[6], *x[3:6]).normalized()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = quat.toRotationMatrix(), x[:3]
        acc = robot.direct_dynamics(T, x[7:13], np.zeros(6))
        w = x[10:13]
        qv, qw = x[3:6], x[6]
        dq_v = 0.5 * (qw * w + np.cross(w, qv))
        dq_w = -0.5 * w @ qv
        return np.concatenate([x[7:10], dq_v, [dq_w], acc])

    k1 = f(x)
    k2 = f(x + 0.5 * dt * k1)
    k3 = f(x + 0.5 * dt * k2)
    k4 = f(x + dt * k3)
    out = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    out[3:7] /= np.linalg.norm(out[3:7])
    return out


def _energy_drift(robot: StewartRobot, dt: float, duration: float) -> float:
    T0 = robot.home_pose
    quat = pin.Quaternion(T0[:3, :3])
    s = robot.description.stroke_mid
    x = np.concatenate([T0[:3, 3], quat.coeffs(), [0.05 * s, -0.03 * s, 0.0, 0.2, -0.1, 0.3]])

    def energy(x):
        T = np.eye(4)
        T[:3, :3] = pin.Quaternion(x[6], *x[3:6]).toRotationMatrix()
        T[:3, 3] = x[:3]
        return robot.energy(T, x[7:13])

    E0 = energy(x)
    drift = 0.0
    for _ in range(round(duration / dt)):
        x = _rk4_step(robot, x, dt)
        drift = max(drift, abs(energy(x) - E0))
    return drift


@pytest.mark.parametrize("name", ["desktop", "random-3"])
def test_energy_conserved_without_actuation(name):
    """Free motion under gravity (Gamma = 0): the energy drift is the integrator's, and it
    falls as dt^4 (RK4)."""
    robot = StewartRobot.from_preset(name)
    coarse = _energy_drift(robot, 2e-3, 0.06)
    fine = _energy_drift(robot, 1e-3, 0.06)
    scale = robot.description.platform_inertia[9] * 9.81 * robot.description.stroke_mid
    assert fine < 1e-9 * scale
    assert coarse / fine > 8.0  # fourth order: ideally 16


def test_massless_legs_reduce_to_platform_newton_euler():
    base = random_robot(4)
    robot = StewartRobot(base.replace(leg_inertia=np.zeros((6, 3, 10))))
    poses, twists, accels = sample_states(robot.description, 30, 8)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    platform = pin.Inertia.FromDynamicParameters(
        base.platform_inertia[[9, 6, 7, 8, 0, 1, 3, 2, 4, 5]]
    )
    g = base.gravity
    for T, V, A, G in zip(poses, twists, accels, gamma, strict=True):
        R = T[:3, :3]
        # Body-frame (Fp) spatial velocity and spatial acceleration of the platform.
        v_b = pin.Motion(R.T @ V[:3], R.T @ V[3:])
        a_b = pin.Motion(R.T @ A[:3] - np.cross(R.T @ V[3:], R.T @ V[:3]), R.T @ A[3:])
        f_b = platform * a_b + v_b.cross(platform * v_b)  # Featherstone, in Fp about O_p
        f_b -= platform * pin.Motion(R.T @ g, np.zeros(3))  # gravity as a body force
        wrench = np.concatenate([R @ f_b.linear, R @ f_b.angular])  # F0 axes, about O_p
        expected = np.linalg.solve(robot.inverse_jacobian(T).T, wrench)
        assert rel_error(G, expected) < 1e-10


def test_leg_terms_match_each_three_dof_model():
    robot = StewartRobot(random_robot(2))
    poses, twists, accels = sample_states(robot.description, 5, 2)
    q, qd, qdd = robot.leg_kinematics(poses, twists, accels)
    H = robot.leg_dynamics.inverse_dynamics(q, qd, qdd)
    A, h = robot.leg_dynamics.mass_and_bias(q, qd)
    for i, model in enumerate(robot.leg_models):
        data = model.createData()
        for n in range(5):
            tau = pin.rnea(model, data, q[n, i], qd[n, i], qdd[n, i])
            np.testing.assert_allclose(H[n, i], tau, rtol=1e-12, atol=1e-12 * np.abs(tau).max())
            M = pin.crba(model, data, q[n, i])
            np.testing.assert_allclose(A[n, i], M, rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(A[n, i] @ qdd[n, i] + h[n, i], tau, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("name", ["paper", "random-5"])
def test_gravity_compensation_is_the_potential_gradient(name):
    """Virtual work: the static forces satisfy Jp^-T Gamma = dU/dX, the gradient of the
    total potential energy along the six twist directions (central differences)."""
    robot = StewartRobot.from_preset(name)
    T = robot.sample_poses(1, 4)[0]
    static = robot.gravity_compensation(T)
    h, grad = 1e-6, np.empty(6)
    for k in range(6):
        dX = np.zeros(6)
        dX[k] = h
        U = []
        for sign in (1, -1):
            Tk = T.copy()
            Tk[:3, 3] += sign * dX[:3]
            Tk[:3, :3] = pin.exp3(sign * dX[3:]) @ T[:3, :3]
            U.append(robot.energy(Tk, np.zeros(6)))
        grad[k] = (U[0] - U[1]) / (2 * h)
    wrench = robot.inverse_jacobian(T).T @ static
    assert rel_error(wrench, grad) < 1e-7
    # Holding still: the direct model under these forces gives no acceleration.
    acc = robot.direct_dynamics(T, np.zeros(6), static)
    assert np.abs(acc).max() < 1e-10 * np.abs(robot.description.gravity).max()


class TestBadInput:
    robot = StewartRobot.from_preset("desktop")

    def test_nan(self):
        with pytest.raises(InputError, match="non-finite"):
            self.robot.inverse_dynamics(self.robot.home_pose, [0, 0, np.nan, 0, 0, 0], np.zeros(6))

    def test_wrong_shapes(self):
        with pytest.raises(InputError, match="shape"):
            self.robot.inverse_dynamics(self.robot.home_pose, np.zeros(5), np.zeros(6))
        with pytest.raises(InputError, match="twist"):
            self.robot.direct_dynamics(self.robot.home_pose, np.zeros((2, 6)), np.zeros(6))
        with pytest.raises(InputError, match="4, 4"):
            self.robot.inverse_dynamics(np.eye(3), np.zeros(6), np.zeros(6))

    def test_pose_outside_workspace(self):
        T = self.robot.home_pose
        T[2, 3] += 0.2  # 20 cm up: legs far beyond the 19 cm stroke end
        with pytest.raises(StrokeLimitError, match=r"leg \d length 0\.\d+ m is outside") as e:
            self.robot.inverse_dynamics(T, np.zeros(6), np.zeros(6))
        assert e.value.value > e.value.upper

    def test_singular_configuration(self):
        strict = StewartRobot(self.robot.description, max_condition=1.5)
        with pytest.raises(SingularityError, match=r"cond\(Jp\^-1\) = [\d.]+ > 1.5"):
            strict.direct_dynamics(self.robot.home_pose, np.zeros(6), np.zeros(6))


def test_compiled_backend_agrees_with_the_pinocchio_path(tmp_path, monkeypatch):
    monkeypatch.setenv("STEWART_PIN_CACHE", str(tmp_path))
    robot = StewartRobot.from_preset("random-2")
    poses, twists, accels = sample_states(robot.description, 50, 6)
    ref = robot.inverse_dynamics(poses, twists, accels)
    fast = robot.inverse_dynamics(poses, twists, accels, backend="compiled")
    assert rel_error(fast, ref) < 1e-10
    acc = robot.direct_dynamics(poses, twists, ref, backend="compiled")
    assert rel_error(acc, accels) < 1e-10
    single = robot.direct_dynamics(poses[0], twists[0], ref[0], backend="compiled")
    assert single.shape == (6,)
    with pytest.raises(InputError, match="unknown backend 'fast'"):
        robot.inverse_dynamics(poses, twists, accels, backend="fast")
    with pytest.raises(InputError, match="details=True needs backend='pinocchio'"):
        robot.inverse_dynamics(poses, twists, accels, details=True, backend="compiled")


# ---------------------------------------------------------------------------- item 5
# Finite inputs whose results overflow double precision: a named NumericalError, never NaN.
BAD_STATE = 2  # the overflowing state of the batch of four


@pytest.fixture(scope="module")
def overflow_case():
    robot = StewartRobot.from_preset("simulator")
    poses, twists, accels = sample_states(robot.description, 4, 17)
    gammas = robot.inverse_dynamics(poses, twists, accels)
    return robot, poses, twists, accels, gammas


def _overflowing(values: np.ndarray, magnitude: float) -> np.ndarray:
    """A copy with state BAD_STATE set to ``magnitude`` (finite)."""
    out = values.copy()
    out[BAD_STATE] = magnitude
    return out


def _no_runtime_warning(record) -> None:
    leaked = [w for w in record if issubclass(w.category, RuntimeWarning)]
    assert not leaked, [str(w.message) for w in leaked]


@pytest.mark.parametrize("backend", ["pinocchio", "compiled"])
@pytest.mark.parametrize("batched", [True, False], ids=["batch", "single"])
@pytest.mark.parametrize(
    "model, field, magnitude, output",
    [
        ("inverse", "twist", 1e160, "inverse dynamics Gamma"),
        ("inverse", "accel", 1e308, "inverse dynamics Gamma"),
        ("direct", "twist", 1e160, "direct dynamics acceleration"),
        ("direct", "gamma", 1e308, "direct dynamics acceleration"),
    ],
)
def test_finite_input_that_overflows_raises_numerical_error_not_nan(
    overflow_case, backend, batched, model, field, magnitude, output
):
    import warnings

    from stewart_pin import NumericalError, StewartPinError

    robot, poses, twists, accels, gammas = overflow_case
    twist, third = twists.copy(), (accels if model == "inverse" else gammas).copy()
    (twist if field == "twist" else third)[BAD_STATE] = magnitude  # finite
    args = (poses, twist, third)
    if not batched:
        args = tuple(a[BAD_STATE] for a in args)
    f = robot.inverse_dynamics if model == "inverse" else robot.direct_dynamics
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        with pytest.raises(NumericalError) as info:
            f(*args, backend=backend)
    _no_runtime_warning(record)
    e = info.value
    assert isinstance(e, StewartPinError) and isinstance(e, ArithmeticError)
    index = BAD_STATE if batched else 0
    assert (e.output, e.index) == (output, index)
    # Both backends: the same type and the same message, naming the output and the state.
    assert str(e).startswith(f"{output} is not finite at state {index}")
    if backend == "pinocchio":
        assert e.n_bad == 1 and e.n_states == (4 if batched else 1)


def test_every_dynamic_output_is_checked_for_overflow(overflow_case):
    """cartesian_dynamics, regressor, energy, details=True and the gravity compensation."""
    import warnings

    from stewart_pin import NumericalError

    robot, poses, twists, accels, _ = overflow_case
    fast = _overflowing(twists, 1e160)
    calls = {
        "cartesian dynamics h_robot": lambda: robot.cartesian_dynamics(poses, fast),
        "regressor W": lambda: robot.regressor(poses, fast, accels),
        "energy": lambda: robot.energy(poses, fast),
        "inverse dynamics Gamma": lambda: robot.inverse_dynamics(
            poses, fast, accels, details=True
        ),
    }
    for output, call in calls.items():
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            with pytest.raises(NumericalError, match=f"at state {BAD_STATE}") as info:
                call()
        _no_runtime_warning(record)
        assert info.value.output == output and info.value.index == BAD_STATE
    with pytest.raises(NumericalError) as info:
        robot.energy(poses[BAD_STATE], fast[BAD_STATE])
    assert info.value.index == 0
    # A robot whose weight overflows (platform 1.2e303 kg under 1e10 m/s^2): the static
    # model, whose only inputs are poses, overflows too.
    desc = robot.description
    heavy = StewartRobot(
        desc.replace(platform_inertia=desc.platform_inertia * 1e300, gravity=[0, 0, -1e10])
    )
    with pytest.raises(NumericalError, match="gravity compensation Gamma is not finite"):
        heavy.gravity_compensation(poses)
    # The same calls on the physical states are finite (the check costs them nothing).
    assert np.isfinite(robot.regressor(poses, twists, accels)).all()
    assert np.isfinite(robot.energy(poses, twists)).all()
