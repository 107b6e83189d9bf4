"""General three-joint legs (6-UPS, 6-UPS with offset U-joints, 6-RUS, 6-PUS).

Independent references:
- Pinocchio's constrained tree (:mod:`stewart_pin.check.leg_chain_tree`: KKT inverse
  dynamics, ``pin.constraintDynamics``), which shares no algebra with the closure layer;
- today's 6-UPS models (``StewartRobot``) for the ``ups`` builder;
- the power balance ``Gamma . qdot_a = dE/dt + dissipated power`` with ``dE/dt`` by
  central differences along an exact SE(3) trajectory, the energy from the tree;
- central finite differences for ``J_i``, ``Jdot_i qdot_i`` and ``Jp^-1`` (on SE(3));
- round trips: forward geometry after inverse geometry, ``DDM(IDM(Vdot)) = Vdot``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot
from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_energy,
    reference_inverse_dynamics,
)
from stewart_pin.description.leg_architecture import (
    Joint,
    JointDynamics,
    LegArchitecture,
    prismatic,
    revolute,
    rus,
    ups,
)
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.description.leg_chain_presets import GENERAL_PRESETS, random_hexapod
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.exceptions import (
    ArchitectureError,
    ConvergenceError,
    JointDynamicsError,
    LegJointLimitError,
    LegReachError,
    SingularityError,
    StewartPinError,
)
from stewart_pin.kinematics import leg_chains as lc

KINDS = ("ups", "ups-offset", "rus", "pus", "custom")
#: Workspace ranges per architecture (translation [m], rotation [rad]) around home.
RANGES = {
    "ups": (0.03, 0.1),
    "ups-offset": (0.03, 0.1),
    "rus": (0.003, 0.03),
    "pus": (0.02, 0.1),
    "custom": (0.02, 0.1),
}
_CACHE: dict[tuple[str, int], tuple[GeneralHexapod, GeneralDynamics, GeneralTreeSolver]] = {}


def _robot(kind: str, seed: int = 0):
    key = (kind, seed)
    if key not in _CACHE:
        h = random_hexapod(kind, seed)
        _CACHE[key] = (h, GeneralDynamics(h), GeneralTreeSolver(h))
    return _CACHE[key]


def _states(h: GeneralHexapod, n: int, seed: int, tr: float, rot: float):
    """Random poses around home, twists and classical accelerations of matching scales."""
    rng = np.random.default_rng(seed)
    T = np.array([h.home_pose] * n)
    for k in range(n):
        T[k, :3, 3] += rng.uniform(-tr, tr, 3)
        T[k, :3, :3] = pin.exp3(rng.uniform(-rot, rot, 3)) @ T[k, :3, :3]
    scale = np.r_[[tr] * 3, [rot] * 3]
    return T, 5 * scale * rng.normal(size=(n, 6)), 30 * scale * rng.normal(size=(n, 6))


def _rel(a, b) -> float:
    """Largest per-state relative error of ``a`` against the reference ``b`` (N, k)."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    return float((np.abs(a - b).max(axis=1) / np.abs(b).max(axis=1)).max())


def _left_jacobian(phi: np.ndarray) -> np.ndarray:
    """SO(3)'s left Jacobian: ``d/dt exp(phi) = (J_l(phi) phi_dot)^ exp(phi)``."""
    th = np.linalg.norm(phi)
    S = pin.skew(phi)
    if th < 1e-8:
        return np.eye(3) + 0.5 * S
    return np.eye(3) + (1 - math.cos(th)) / th**2 * S + (th - math.sin(th)) / th**3 * S @ S


# ---------------------------------------------------------------------------- dynamics
@pytest.mark.parametrize("kind", KINDS)
def test_dynamics_equal_constrained_tree(kind):
    """IDM and DDM equal the constrained tree to 1e-9 relative (every joint term on), and
    DDM(IDM(Vdot)) = Vdot."""
    h, g, solver = _robot(kind)
    assert all(not j.dynamics.is_zero for leg in h.legs for j in leg.joints)
    T, V, A = _states(h, 8, 1, *RANGES[kind])
    q = lc.inverse_geometry_batch(h, T)
    gamma = g.inverse_dynamics(T, V, A)
    gamma_ref = reference_inverse_dynamics(solver, T, V, A, q)
    # Measured ~1e-15 (IDM) and ~1e-12 (DDM, dominated by the tree's own KKT round-off).
    assert _rel(gamma, gamma_ref) < 1e-9
    accel_ref = reference_direct_dynamics(solver, T, V, gamma_ref, q)
    assert _rel(g.direct_dynamics(T, V, gamma_ref), accel_ref) < 1e-9
    assert _rel(g.direct_dynamics(T, V, gamma), A) < 1e-9
    assert _rel(accel_ref, A) < 1e-9  # the reference's own consistency


@pytest.mark.parametrize("kind", KINDS)
def test_power_balance(kind):
    """``Gamma . qdot_a = dE/dt + dissipated power`` along an exact SE(3) trajectory through
    the state, dE/dt by central differences of the tree's energy."""
    h, g, solver = _robot(kind)
    T0, V0, A0 = (x[0] for x in _states(h, 1, 2, *RANGES[kind]))
    R0, p0 = T0[:3, :3], T0[:3, 3]

    def state(t: float):
        phi = V0[3:] * t + 0.5 * A0[3:] * t**2
        T = np.eye(4)
        T[:3, :3] = pin.exp3(phi) @ R0
        T[:3, 3] = p0 + V0[:3] * t + 0.5 * A0[:3] * t**2
        w = _left_jacobian(phi) @ (V0[3:] + A0[3:] * t)
        return T, np.r_[V0[:3] + A0[:3] * t, w]

    def energy(t: float) -> float:
        T, V = state(t)
        q = lc.inverse_geometry_batch(h, T[None])
        k, u, _ = reference_energy(solver, T[None], V[None], q)
        return float(k[0] + u[0])

    dt = 1e-4
    dE = (energy(dt) - energy(-dt)) / (2 * dt)
    q = lc.inverse_geometry_batch(h, T0[None])
    _, _, lost = reference_energy(solver, T0[None], V0[None], q)
    power = g.inverse_dynamics(T0, V0, A0) @ g.actuator_rates(T0, V0)
    scale = abs(dE) + abs(lost[0]) + abs(power)
    # Central differences: O(dt^2) truncation ~1e-8 relative, round-off eps E / dt.
    assert abs(power - dE - lost[0]) < 1e-6 * scale
    assert g.dissipated_power(T0, V0) == pytest.approx(lost[0], rel=1e-12)
    # The closure layer's own energy equals the tree's.
    k_ref, u_ref, _ = reference_energy(solver, T0[None], V0[None], q)
    k, u = g.energy(T0, V0)
    assert k == pytest.approx(k_ref[0], rel=1e-12)
    assert u - u_ref[0] == pytest.approx(0.0, abs=1e-12 * (abs(u) + k))


def test_motor_side_and_gravity_compensation():
    """Motor-side efforts are the joint-side ones over the transmission ratio; gravity
    compensation holds the platform still (DDM of it at zero twist is zero)."""
    h, g, _ = _robot("rus")
    T = h.home_pose
    V, A = np.full(6, 0.1), np.full(6, 0.5)
    ratio = np.array([leg.joints[leg.actuated - 1].dynamics.transmission_ratio for leg in h.legs])
    assert np.all(ratio > 1)
    np.testing.assert_allclose(
        g.inverse_dynamics(T, V, A, motor=True) * ratio, g.inverse_dynamics(T, V, A), rtol=1e-14
    )
    gc = g.gravity_compensation(T)
    np.testing.assert_allclose(g.direct_dynamics(T, np.zeros(6), gc), 0.0, atol=1e-9)


def test_ups_builder_equals_todays_models():
    """The general path on ``ups`` legs equals today's 6-UPS models to 1e-12."""
    robot = StewartRobot.from_preset("random-1")
    h = general_from_description(robot.description)
    g = GeneralDynamics(h)
    T, V, A = _states(h, 6, 3, 0.03, 0.1)
    np.testing.assert_allclose(
        lc.inverse_geometry(h, T), robot.inverse_geometry(T), rtol=0, atol=1e-14
    )
    np.testing.assert_allclose(
        lc.inverse_jacobian(h, T), robot.inverse_jacobian(T), rtol=0, atol=1e-13
    )
    gamma = robot.inverse_dynamics(T, V, A)
    assert _rel(g.inverse_dynamics(T, V, A), gamma) < 1e-12
    assert _rel(g.direct_dynamics(T, V, gamma), robot.direct_dynamics(T, V, gamma)) < 1e-12


# ---------------------------------------------------------------------------- kinematics
@pytest.mark.parametrize("kind", KINDS)
def test_leg_jacobians_and_drift_by_finite_differences(kind):
    """``J_i`` and ``Jdot_i qdot_i`` against central differences of the chain's tip."""
    h, _, _ = _robot(kind)
    T, _, _ = _states(h, 3, 4, *RANGES[kind])
    q = lc.inverse_geometry_batch(h, T)
    qd = np.random.default_rng(5).normal(size=q.shape)
    frames = lc.leg_forward(h, q)
    e = 1e-6
    tip = lambda x: lc.leg_forward(h, x).P  # noqa: E731
    fd = (tip(q + e * qd) - tip(q - e * qd)) / (2 * e)
    J = lc.leg_jacobians(h, frames)
    # O(e^2) truncation on sizes ~1 m: 1e-9 absolute.
    np.testing.assert_allclose(np.einsum("nkij,nkj->nki", J, qd), fd, atol=1e-8)
    e = 1e-4
    fd2 = (tip(q + e * qd) - 2 * frames.P + tip(q - e * qd)) / e**2
    drift = lc.leg_drift(h, frames, qd)
    # second differences: round-off eps / e^2 ~ 1e-8 plus O(e^2) truncation.
    np.testing.assert_allclose(drift, fd2, atol=1e-6 * max(1.0, np.abs(drift).max()))


@pytest.mark.parametrize("kind", KINDS)
def test_inverse_jacobian_by_finite_differences_on_se3(kind):
    """``Jp^-1 V`` equals the central difference of the actuated joint values along
    ``T(t) = [exp(t w) R, p + t v]``."""
    h, _, _ = _robot(kind)
    T, V, _ = _states(h, 3, 6, *RANGES[kind])
    J_inv = lc.inverse_jacobian(h, T)
    e = 1e-6
    for n in range(len(T)):

        def moved(t: float, pose=T[n], twist=V[n]):
            M = pose.copy()
            M[:3, :3] = pin.exp3(t * twist[3:]) @ pose[:3, :3]
            M[:3, 3] += t * twist[:3]
            return lc.actuator_positions(h, M)

        fd = (moved(e) - moved(-e)) / (2 * e)
        np.testing.assert_allclose(J_inv[n] @ V[n], fd, atol=1e-8 * np.abs(fd).max())


@pytest.mark.parametrize("kind", KINDS)
def test_forward_geometry_inverts_inverse_geometry(kind):
    h, _, _ = _robot(kind)
    T, _, _ = _states(h, 3, 7, *RANGES[kind])
    for pose in T:
        qa = lc.actuator_positions(h, pose)
        found = lc.forward_geometry(h, qa)
        np.testing.assert_allclose(found, pose, atol=1e-10)


@pytest.mark.parametrize("kind", KINDS)
def test_branches(kind):
    """Each leg's inverse geometry lands on its documented branch (``branch_at``); the
    other branch reaches the same points with other joint values."""
    h, _, _ = _robot(kind)
    if kind == "custom":
        pytest.skip("custom legs have no branch: Newton's method follows its guess")
    T, _, _ = _states(h, 2, 10, *RANGES[kind])
    P = np.einsum("nij,kj->nki", T[:, :3, :3], h.platform_points) + T[:, None, :3, 3]
    q = lc.inverse_geometry(h, T)
    flipped = h.replace(legs=tuple(leg.replace(branch=-leg.branch) for leg in h.legs))
    q_other = lc.inverse_geometry(flipped, T)
    for robot, joints in ((h, q), (flipped, q_other)):
        np.testing.assert_allclose(lc.leg_forward(robot, joints).P, P, atol=1e-12)
        for n in range(len(T)):
            for k, leg in enumerate(robot.legs):
                assert leg.branch_at(joints[n, k]) == leg.branch
    assert np.abs(q - q_other).max() > 1e-3


def test_custom_legs_newton_equals_closed_form():
    """A robot whose legs are declared ``custom`` (Newton's method) gets the closed form's
    joint values and dynamics."""
    h, g, _ = _robot("rus")
    custom = h.replace(legs=tuple(leg.replace(name="custom") for leg in h.legs))
    T, V, A = _states(h, 3, 8, *RANGES["rus"])
    np.testing.assert_allclose(
        lc.inverse_geometry(custom, T), lc.inverse_geometry(h, T), atol=1e-11
    )
    assert (
        _rel(GeneralDynamics(custom).inverse_dynamics(T, V, A), g.inverse_dynamics(T, V, A)) < 1e-9
    )


def test_presets_reachable_and_regular():
    """The presets' home poses are reachable, far from both singularities, and their
    models agree with the tree."""
    for make in GENERAL_PRESETS.values():
        h = make()
        ks = lc.leg_state(h, h.home_pose[None], np.zeros((1, 6)))
        lc.check_joint_limits(h, ks.q)
        assert lc.serial_measure(h, ks.frames, ks.J).min() > 0.1
        J_inv = lc.inverse_jacobian_from_legs(h, ks.J_inv, ks.L)
        assert lc.condition_number_batch(h, J_inv)[0] < 10
        g, solver = GeneralDynamics(h), GeneralTreeSolver(h)
        T, V, A = _states(h, 2, 9, 0.005, 0.05)
        q = lc.inverse_geometry_batch(h, T)
        assert (
            _rel(g.inverse_dynamics(T, V, A), reference_inverse_dynamics(solver, T, V, A, q))
            < 1e-9
        )


# ---------------------------------------------------------------------------- bad input
def test_joint_dynamics_validation():
    dyn = JointDynamics(armature=0.1, gear_ratio=10.0, rotor_inertia=1e-4)
    assert dyn.total_armature == pytest.approx(0.1 + 100 * 1e-4)
    screw = JointDynamics(screw_lead=0.005, rotor_inertia=1e-5)
    assert screw.total_armature == pytest.approx((2 * math.pi / 0.005) ** 2 * 1e-5)
    assert screw.motor_effort(100.0) == pytest.approx(100.0 * 0.005 / (2 * math.pi))
    for bad in (
        {"armature": -1.0},
        {"coulomb": -0.1},
        {"viscous": -1},
        {"stiffness": -2.0},
        {"damping": -1e-3},
        {"gear_ratio": 0.0},
        {"screw_lead": -0.01},
        {"gear_ratio": 2.0, "screw_lead": 0.01},
        {"armature": float("nan")},
    ):
        with pytest.raises(JointDynamicsError):
            JointDynamics(**bad)
    assert issubclass(JointDynamicsError, StewartPinError)


def test_architecture_validation():
    with pytest.raises(ArchitectureError, match="three 1-dof joints"):
        LegArchitecture((revolute(), revolute()), 1)
    with pytest.raises(ArchitectureError, match="kind"):
        Joint("spherical")
    with pytest.raises(ArchitectureError, match="actuated"):
        LegArchitecture((revolute(), revolute(), prismatic()), 4)
    with pytest.raises(ArchitectureError, match="actuated"):
        LegArchitecture((revolute(), revolute(), prismatic()), 0)
    with pytest.raises(ArchitectureError, match="branch"):
        rus(0.03, 0.1, branch=0)
    with pytest.raises(ArchitectureError, match="'rus' leg needs"):
        LegArchitecture((revolute(), revolute(), prismatic()), 1, name="rus", tip=[0.1, 0, 0])
    with pytest.raises(ArchitectureError, match="limits"):
        revolute(lower=1.0, upper=-1.0)
    with pytest.raises(ArchitectureError, match="six"):
        h, _, _ = _robot("ups")
        h.replace(legs=h.legs[:5])
    assert ups().name == "ups"


def test_unreachable_limits_and_singularities():
    h, _, _ = _robot("rus")
    far = h.home_pose.copy()
    far[2, 3] += 0.2  # 20 cm above home: beyond crank + rod
    with pytest.raises(LegReachError) as info:
        lc.inverse_geometry(h, far)
    assert 1 <= info.value.leg <= 6
    hp, _, _ = _robot("pus")
    far = hp.home_pose.copy()
    far[0, 3] += 1.0
    with pytest.raises(LegReachError):
        lc.inverse_geometry(hp, far)
    # joint limits
    limited = h.replace(
        legs=tuple(
            leg.replace(
                joints=(
                    replace(leg.joints[0], lower=leg.guess[0] - 1e-3, upper=leg.guess[0] + 1e-3),
                    *leg.joints[1:],
                )
            )
            for leg in h.legs
        )
    )
    lc.inverse_geometry(limited, h.home_pose)
    moved = h.home_pose.copy()
    moved[2, 3] += 0.003
    with pytest.raises(LegJointLimitError):
        lc.inverse_geometry(limited, moved)
    lc.inverse_geometry(limited, moved, check_limits=False)
    # serial singularity: a rus leg with the rod continuing the crank (q2 = q3 = 0).
    leg = rus(0.03, 0.1)
    single = h.replace(legs=(leg,) * 6)
    frames = lc.leg_forward(single, np.zeros((1, 6, 3)))
    with pytest.raises(SingularityError) as info:
        lc.check_serial(single, frames, lc.leg_jacobians(single, frames))
    assert info.value.leg == 1
    # parallel singularity: a threshold below any pose's condition number.
    with pytest.raises(SingularityError) as info:
        GeneralDynamics(h, max_condition=1.0).inverse_dynamics(
            h.home_pose, np.zeros(6), np.zeros(6)
        )
    assert info.value.leg is None
    # Newton on an unreachable point
    with pytest.raises(ConvergenceError):
        lc.solve_leg(h.legs[0], np.eye(4), np.array([[1.0, 1.0, 1.0]]), np.zeros((1, 3)))


def test_reference_shares_no_algebra():
    """check/leg_chain_tree.py (the reference) imports nothing from ``stewart_pin.dynamics``
    nor ``stewart_pin.kinematics``: it does not reuse the closure algebra (eqs. of the
    paper), the leg Jacobians or the drift terms of the code under test.

    It is *not* fully independent: the reference and the code build their leg models with
    the same models/leg_chains.py helpers (MDH frames, inertias, joint dynamics), and the
    leg joint positions it is given come from the code's inverse geometry. The fully
    independent model is MuJoCo's, from the exported MJCF, in a KKT solve:
    tests/test_general_export.py::test_mujoco_kkt_inverse_dynamics.
    """
    import ast
    import inspect

    import stewart_pin.check.leg_chain_tree as ref

    tree = ast.parse(inspect.getsource(ref))
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
        elif isinstance(node, ast.Import):
            imported.update(alias.name for alias in node.names)
    forbidden = ("stewart_pin.dynamics", "stewart_pin.kinematics")
    assert not any(m.startswith(forbidden) for m in imported)


def test_serial_measure_is_sin_q2_for_ups():
    """For 6-UPS the serial measure is today's ``sin q2i``."""
    h, _, _ = _robot("ups")
    T, _, _ = _states(h, 3, 11, *RANGES["ups"])
    q = lc.inverse_geometry_batch(h, T)
    frames = lc.leg_forward(h, q)
    measure = lc.serial_measure(h, frames, lc.leg_jacobians(h, frames))
    np.testing.assert_allclose(measure, np.abs(np.sin(q[..., 1])), atol=1e-12)


def test_coulomb_is_zero_at_zero_velocity():
    """``sign(0) = 0``: at rest the Coulomb friction adds nothing (inverse and direct)."""
    h, g, _ = _robot("pus")
    no_coulomb = h.replace(
        legs=tuple(
            leg.with_dynamics([replace(j.dynamics, coulomb=0.0) for j in leg.joints])
            for leg in h.legs
        )
    )
    g0 = GeneralDynamics(no_coulomb)
    T, zero = h.home_pose, np.zeros(6)
    np.testing.assert_array_equal(g.gravity_compensation(T), g0.gravity_compensation(T))
    gamma = np.full(6, 3.0)
    np.testing.assert_array_equal(
        g.direct_dynamics(T, zero, gamma), g0.direct_dynamics(T, zero, gamma)
    )


def test_single_leg_model_matches_the_six_legs_model():
    """One leg's 3-dof model gives that leg's block of the 18-dof model (armature too)."""
    from stewart_pin.models.leg_chains import build_leg_chain

    h, g, _ = _robot("rus")
    rng = np.random.default_rng(12)
    q, v, a = (rng.normal(size=(1, 6, 3)) for _ in range(3))
    H = g.legs.inverse_dynamics(q, v, a) - g.legs.terms.efforts(q, v)
    for k in (0, 5):
        model = build_leg_chain(h, k)
        np.testing.assert_allclose(model.armature, h.legs[k].armature, rtol=0)
        tau = pin.rnea(model, model.createData(), q[0, k], v[0, k], a[0, k])
        np.testing.assert_allclose(tau, H[0, k], rtol=1e-12, atol=1e-15)


def test_a_vanishing_ups_leg_is_a_serial_singularity():
    """The normalised Jacobian measure of a UPS leg is |sin q2| whatever its length, so a
    leg shrinking to nothing needs its own rule: P_i within 5 % of the platform radius of
    a revolute joint's origin (today's 6-UPS rule) is refused. Reference: the leg length
    q3 itself, set in the test; a leg at 10 % of the radius passes."""
    from stewart_pin.description import preset
    from stewart_pin.description.leg_chain_hexapod import general_from_description
    from stewart_pin.kinematics.leg_chains import check_serial, leg_forward, leg_jacobians

    robot = general_from_description(preset("simulator"))
    P = np.asarray(robot.platform_points)
    radius = float(np.linalg.norm(P - P.mean(axis=0), axis=1).mean())
    q = np.tile([0.3, 1.2, 1.0], (1, 6, 1))  # sin q2 = 0.93: far from the U singularity
    q[0, 2, 2] = 0.10 * radius
    frames = leg_forward(robot, q)
    check_serial(robot, frames, leg_jacobians(robot, frames))  # 10 %: accepted
    q[0, 2, 2] = 0.04 * radius
    frames = leg_forward(robot, q)
    with pytest.raises(SingularityError, match=r"leg 3 .* vanishing leg") as info:
        check_serial(robot, frames, leg_jacobians(robot, frames))
    assert info.value.leg == 3 and info.value.value == pytest.approx(0.04, rel=1e-12)
