"""The coupled payload models compiled to C (issue 24): ``codegen.payload_symbolic`` (the
payload's Newton-Euler and composite-rigid-body algorithm generated over its Pinocchio
model, with the hexapod's closed form) and ``codegen.payload_compiled``.

Independent references: Pinocchio's constrained dynamics of the WHOLE tree (six legs,
platform, payload appended, six loop closures; ``stewart_pin.check.payload``: its KKT
inverse model, ``pin.constraintDynamics`` for the torque-driven direct model, the KKT
system with the joint accelerations given for the prescribed one), and Pinocchio's own
``rnea`` / ``crba`` on the payload on a free-flyer for the generated arm algebra.
Tolerance 1e-10 relative (observed: 1e-15 to 1e-13).

Every library of the module builds into the session's shared compile cache (a few
seconds each: the 6-UPS ``simulator`` carrying example-robot-data's Panda, and ``rus``
carrying a three-joint arm built here with an oblique revolute, a continuous and an
oblique prismatic joint).
"""

from __future__ import annotations

import warnings

import casadi as cs
import numpy as np
import pinocchio as pin
import pytest
from conftest import needs_example_robot_data, use_compile_cache

from stewart_pin import (
    InputError,
    JointLimitError,
    LegReachError,
    PayloadError,
    StewartRobot,
)
from stewart_pin.check import payload as check
from stewart_pin.check.constrained_dynamics import relative_error
from stewart_pin.codegen import payload_compiled
from stewart_pin.codegen._sx_common import split
from stewart_pin.codegen.payload_compiled import CompiledPayloadDynamics
from stewart_pin.codegen.payload_symbolic import arm_crba, arm_joints, arm_rnea, payload_identity
from stewart_pin.dynamics.payload import PayloadDynamics
from stewart_pin.models.payload import Payload
from stewart_pin.payload_robot import PayloadRobot

TOL = 1e-10
MOUNT = pin.SE3(pin.rpy.rpyToMatrix(0.2, -0.1, 0.4), np.array([0.05, -0.03, 0.02])).homogeneous

needs_erd = needs_example_robot_data()


@pytest.fixture(autouse=True)
def _cache(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)


def _inertia(rng: np.random.Generator, mass: float) -> pin.Inertia:
    A = rng.normal(size=(3, 3))
    return pin.Inertia(mass, rng.uniform(-0.05, 0.05, 3), A @ A.T * 1e-3 + np.eye(3) * 1e-3)


def three_joint_arm() -> pin.Model:
    """A fixed-base arm: an oblique revolute joint, a continuous one (``(cos, sin)``), an
    oblique prismatic one, a body welded to the base, and armatures."""
    rng = np.random.default_rng(11)
    model = pin.Model()
    model.name = "three-joint"
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    slide = np.array([0.6, 0.0, 0.8])
    place = [
        pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.01, 0.02, 0.05])),
        pin.SE3(pin.rpy.rpyToMatrix(np.pi / 2, 0.0, 0.0), np.array([0.0, 0.02, 0.25])),
        pin.SE3(pin.rpy.rpyToMatrix(0.0, -0.3, 0.0), np.array([0.2, 0.0, 0.0])),
    ]
    effort, vel = np.array([100.0]), np.array([10.0])
    j1 = model.addJoint(
        0, pin.JointModelRevoluteUnaligned(axis), place[0], "j1", effort, vel,
        np.array([-2.0]), np.array([2.0]),
    )  # fmt: skip
    j2 = model.addJoint(j1, pin.JointModelRUBY(), place[1], "j2")
    j3 = model.addJoint(
        j2, pin.JointModelPrismaticUnaligned(slide), place[2], "j3", effort, vel,
        np.array([-0.1]), np.array([0.15]),
    )  # fmt: skip
    model.appendBodyToJoint(0, _inertia(rng, 2.0), pin.SE3.Identity())
    for j, mass in ((j1, 3.0), (j2, 1.5), (j3, 0.7)):
        model.appendBodyToJoint(j, _inertia(rng, mass), pin.SE3.Identity())
    model.armature = np.array([0.02, 0.01, 0.3])
    return model


_ROBOTS: dict[str, PayloadRobot] = {}


def carrier(name: str) -> PayloadRobot:
    """``simulator+panda`` or ``rus+three``, shared by the module's tests."""
    if name not in _ROBOTS:
        hexapod, arm = name.split("+")
        source = three_joint_arm() if arm == "three" else arm
        _ROBOTS[name] = StewartRobot.from_preset(hexapod).with_payload(source, MOUNT)
    return _ROBOTS[name]


CARRIERS = [
    pytest.param("simulator+panda", marks=needs_erd),
    "rus+three",
]


# ---------------------------------------------------------------------------- the arm's algebra
@needs_erd
@pytest.mark.parametrize("arm", ("panda", "kinova"))
def test_generated_newton_euler_and_crba_equal_pinocchio_on_a_free_flyer(arm):
    """The payload's wrench and torques, coupled mass-matrix blocks and bias, generated,
    against Pinocchio's rnea and crba on the payload on a free-flyer (the Kinova has
    continuous joints; armatures set)."""
    payload = Payload.from_example_robot_data(arm, MOUNT)
    model = payload.model
    model.armature = np.linspace(0.01, 0.1, model.nv)
    payload = Payload.from_model(model, MOUNT)
    g = np.array([0.0, 0.0, -9.81])
    ref = PayloadDynamics(payload, g)
    joints, base = arm_joints(payload)
    R = cs.SX.sym("R", 3, 3)
    Rl = [[R[i, j] for j in range(3)] for i in range(3)]
    tw, ac = cs.SX.sym("tw", 6), cs.SX.sym("ac", 6)
    q, qd, qdd = (
        cs.SX.sym("q", payload.nq),
        cs.SX.sym("qd", payload.nv),
        cs.SX.sym("a", payload.nv),
    )
    W, tau = arm_rnea(joints, base, g, Rl, split(tw), split(ac), split(q), split(qd), split(qdd))
    b_f, b_j = arm_rnea(joints, base, g, Rl, split(tw), None, split(q), split(qd), None)
    Kff, Kfj, Mjj = arm_crba(joints, base, Rl, split(q))

    def mat(rows):
        return cs.vertcat(*[cs.horzcat(*r) for r in rows])

    outputs = [cs.vertcat(*W), cs.vertcat(*tau), mat(Kff), mat(Kfj), mat(Mjj)]
    outputs += [cs.vertcat(*b_f), cs.vertcat(*b_j)]
    f = cs.Function("f", [R, tw, ac, q, qd, qdd], outputs)
    rng = np.random.default_rng(2)
    n = 4
    T = np.array([pin.SE3.Random().homogeneous for _ in range(n)])
    V, A = rng.normal(size=(n, 6)), rng.normal(size=(n, 6))
    Q = payload.random_configurations(n, rng)
    Qd, Qdd = rng.normal(size=(n, payload.nv)), rng.normal(size=(n, payload.nv))
    W_ref, tau_ref = ref.inverse(T, V, A, Q, Qd, Qdd)
    terms = ref.coupled_terms(T, V, Q, Qd)
    for k in range(n):
        out = [np.array(x) for x in f(T[k, :3, :3], V[k], A[k], Q[k], Qd[k], Qdd[k])]
        refs = (W_ref[k], tau_ref[k], terms.M_ff[k], terms.M_fj[k], terms.M_jj[k])
        refs += (terms.b_f[k], terms.b_j[k])
        for got, want in zip(out, refs, strict=True):
            np.testing.assert_allclose(
                got.reshape(want.shape), want, rtol=0, atol=1e-12 * abs(want).max()
            )


# ---------------------------------------------------------------------------- the models
@pytest.mark.parametrize("name", CARRIERS)
def test_compiled_coupled_models_equal_the_whole_constrained_tree(name):
    robot = carrier(name)
    P, V, A, q, qd, qdd = robot.sample_states(10, 4)
    solver = check.PayloadTreeSolver(robot.robot, robot.payload)
    gamma_ref, tau_ref = check.reference_inverse_dynamics(solver, P, V, A, q, qd, qdd)
    out = robot.inverse_dynamics(P, V, A, q, qd, qdd, backend="compiled")
    assert relative_error(out.gamma, gamma_ref) < TOL
    assert relative_error(out.tau, tau_ref) < TOL
    # torque-driven: pin.constraintDynamics on the whole tree
    acc_ref, qdd_ref = check.reference_direct_dynamics(solver, P, V, gamma_ref, q, qd, tau_ref)
    out = robot.direct_dynamics(P, V, gamma_ref, q, qd, tau=tau_ref, backend="compiled")
    assert relative_error(out.accel, acc_ref) < TOL
    assert relative_error(out.qdd, qdd_ref) < TOL
    np.testing.assert_array_equal(out.tau, tau_ref)
    # prescribed joint motion
    acc_p, tau_p = check.reference_prescribed_dynamics(solver, P, V, gamma_ref, q, qd, qdd)
    out = robot.direct_dynamics(P, V, gamma_ref, q, qd, qdd, backend="compiled")
    assert relative_error(out.accel, acc_p) < TOL
    assert relative_error(out.tau, tau_p) < TOL
    np.testing.assert_array_equal(out.qdd, qdd)
    # one state in, one state out (the single-state entry), as the batch
    one = robot.inverse_dynamics(P[3], V[3], A[3], q[3], qd[3], qdd[3], backend="compiled")
    assert one.gamma.shape == (6,) and one.tau.shape == (robot.nv,)
    assert relative_error(one.gamma, gamma_ref[3]) < TOL
    assert relative_error(one.tau, tau_ref[3]) < TOL
    back = robot.direct_dynamics(
        P[3], V[3], one.gamma, q[3], qd[3], tau=one.tau, backend="compiled"
    )
    assert relative_error(back.accel, A[3]) < 1e-9 and relative_error(back.qdd, qdd[3]) < 1e-9
    pres = robot.direct_dynamics(P[3], V[3], gamma_ref[3], q[3], qd[3], qdd[3], backend="compiled")
    assert relative_error(pres.accel, acc_p[3]) < TOL
    assert relative_error(pres.tau, tau_p[3]) < TOL
    # lists are inputs too (the checked path)
    lst = robot.inverse_dynamics(
        P[3].tolist(), V[3].tolist(), A[3].tolist(), q[3].tolist(), qd[3].tolist(),
        qdd[3].tolist(), backend="compiled",
    )  # fmt: skip
    np.testing.assert_array_equal(lst.gamma, one.gamma)


@pytest.mark.parametrize("name", CARRIERS)
def test_a_large_batch_on_threads_equals_the_reference_path(name):
    robot = carrier(name)
    P, V, A, q, qd, qdd = robot.sample_states(1200, 9)
    fast = robot.inverse_dynamics(P, V, A, q, qd, qdd, backend="compiled")
    ref = robot.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio")
    assert relative_error(fast.gamma, ref.gamma) < TOL
    assert relative_error(fast.tau, ref.tau) < TOL
    fast_d = robot.direct_dynamics(P, V, ref.gamma, q, qd, tau=ref.tau, backend="compiled")
    assert relative_error(fast_d.accel, A) < 1e-9


# ---------------------------------------------------------------------------- errors
def _error(call):
    try:
        call()
    except Exception as e:
        return type(e), str(e)
    return None


def test_errors_are_the_reference_paths():
    robot = carrier("rus+three")
    P, V, A, q, qd, qdd = robot.sample_states(5, 1)
    far = P.copy()
    far[2, :3, 3] += [0.0, 0.0, 5.0]  # out of reach in state 2
    nan = V.copy()
    nan[1, 4] = np.nan
    bad_pair = q.copy()
    bad_pair[3, 1:3] = [0.9, 0.1]  # the continuous joint's (cos, sin), not of unit norm
    skew = P.copy()
    skew[4, 0, 1] += 1e-3  # not a rotation
    inf_qd = qd.copy()
    inf_qd[0, -1] = np.inf
    cases = [
        lambda b: robot.inverse_dynamics(skew, V, A, q, qd, qdd, backend=b),
        lambda b: robot.inverse_dynamics(P, V, A, q, inf_qd, qdd, backend=b),
        lambda b: robot.direct_dynamics(P, V, A, q, qd, tau=inf_qd, backend=b),
        lambda b: robot.inverse_dynamics(far, V, A, q, qd, qdd, backend=b),
        lambda b: robot.inverse_dynamics(P, nan, A, q, qd, qdd, backend=b),
        lambda b: robot.inverse_dynamics(P, V, A, bad_pair, qd, qdd, backend=b),
        lambda b: robot.direct_dynamics(far[2], V[2], A[2], q[2], qd[2], tau=qd[2], backend=b),
        lambda b: robot.direct_dynamics(P, V, A, q, qd[:2], qdd, backend=b),
        lambda b: robot.direct_dynamics(P, V, A, q, qd, backend=b),
    ]
    kinds = []
    for case in cases:
        ref = _error(lambda case=case: case("pinocchio"))
        assert ref is not None
        assert _error(lambda case=case: case("compiled")) == ref
        kinds.append(ref[0])
    assert kinds[:3] == [InputError] * 3  # the batches' native path: the C guard flags
    assert kinds[3] is LegReachError  # out of the leg's reach
    assert kinds[4:6] == [InputError, PayloadError]


def test_a_flagged_state_is_computed_by_the_reference_path():
    """States the C guard flags are decided by the reference path: an overflowing joint
    rate (finite input, non-finite result) raises the reference's error; with a
    ``max_condition`` below the robot's conditioning every state is flagged, and the
    results (or errors) are the reference's."""
    robot = carrier("rus+three")
    P, V, A, q, qd, qdd = robot.sample_states(3, 2)
    big = qd.copy()
    big[1, 0] = 1e200
    ref = _error(lambda: robot.inverse_dynamics(P, V, A, q, big, qdd, backend="pinocchio"))
    assert ref is not None
    assert _error(lambda: robot.inverse_dynamics(P, V, A, q, big, qdd, backend="compiled")) == ref
    fast = robot.robot.max_condition
    try:
        robot.robot.max_condition = 1.0001  # the guard's bound flags every state
        calls = (
            lambda b: robot.inverse_dynamics(P, V, A, q, qd, qdd, backend=b),
            lambda b: robot.direct_dynamics(P, V, A, q, qd, qdd, backend=b),
            lambda b: robot.direct_dynamics(P, V, A, q, qd, tau=qdd, backend=b),
        )
        for call in calls:
            try:
                ref = call("pinocchio")
            except Exception as e:
                assert _error(lambda call=call: call("compiled")) == (type(e), str(e))
                continue
            out = call("compiled")
            for got, want in zip(out, ref, strict=True):
                assert relative_error(got, want) < TOL
    finally:
        robot.robot.max_condition = fast


def test_u_joint_limits_are_checked_on_every_state():
    """A 6-UPS robot with U-joint limits: the guard checks the angles (issue 19) and the
    compiled model raises the reference's JointLimitError."""
    hexapod = StewartRobot.from_preset("simulator")
    P, V, A = hexapod.sample_states(6, 3)
    angles = hexapod.inverse_geometry(P)[..., :2]
    lo, hi = angles.min(axis=0), angles.max(axis=0)
    limits = np.stack([lo + 1e-3, hi + 0.1], -1)  # state argmin of each angle: beyond
    narrow = StewartRobot(hexapod.description.replace(u_joint_limits=limits))
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "hinge")
    model.appendBodyToJoint(j, pin.Inertia(1.0, np.array([0.1, 0.0, 0.0]), np.eye(3) * 0.01),
                            pin.SE3.Identity())  # fmt: skip
    robot = narrow.with_payload(model)
    q, qd = np.zeros((6, 1)), np.ones((6, 1))
    bad = int(np.argmin(angles[:, 0, 0]))
    for args in ((P, V, A, q, qd, qd), (P[bad], V[bad], A[bad], q[bad], qd[bad], qd[bad])):
        ref = _error(lambda args=args: robot.inverse_dynamics(*args, backend="pinocchio"))
        assert ref is not None and ref[0] is JointLimitError
        assert _error(lambda args=args: robot.inverse_dynamics(*args, backend="compiled")) == ref


def test_backends_auto_compiled_and_reference(monkeypatch):
    robot = carrier("rus+three")
    P, V, A, q, qd, qdd = robot.sample_states(2, 5)
    for bad in ("fast", ["compiled"]):
        with pytest.raises(InputError, match="unknown backend"):
            robot.inverse_dynamics(P, V, A, q, qd, qdd, backend=bad)
    with pytest.raises(InputError, match="details=True"):
        robot.inverse_dynamics(P, V, A, q, qd, qdd, details=True, backend="compiled")
    # the suite runs "auto" as the reference path ($STEWART_PIN_BACKEND=pinocchio)
    fresh = PayloadRobot(robot.robot, robot.payload)
    fresh.inverse_dynamics(P, V, A, q, qd, qdd)
    assert fresh.__dict__[payload_compiled.PAYLOAD_ATTR] == {"auto": None}
    robot.inverse_dynamics(P, V, A, q, qd, qdd, backend="compiled")  # built, or found
    monkeypatch.setenv("STEWART_PIN_BACKEND", "auto")
    fresh = PayloadRobot(robot.robot, robot.payload)
    out = fresh.inverse_dynamics(P, V, A, q, qd, qdd)
    backend = fresh.__dict__[payload_compiled.PAYLOAD_ATTR]["auto"]
    assert isinstance(backend, CompiledPayloadDynamics) and not backend.compiled_now  # cached
    ref = fresh.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio")
    assert relative_error(out.gamma, ref.gamma) < TOL
    # details take the reference path
    assert fresh.inverse_dynamics(P, V, A, q, qd, qdd, details=True).wrench.shape == (2, 6)


def test_a_joint_the_generator_does_not_take_is_refused_or_left_to_the_reference(monkeypatch):
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    model.appendBodyToJoint(j, pin.Inertia(1.0, np.array([0.0, 0.0, 0.1]), np.eye(3) * 0.01),
                            pin.SE3.Identity())  # fmt: skip
    robot = StewartRobot.from_preset("rus").with_payload(model, MOUNT)
    P, V, A, _, _, _ = robot.sample_states(2, 5)
    q = np.tile(pin.neutral(model), (2, 1))
    zero = np.zeros((2, 3))
    with pytest.raises(PayloadError, match="'ball' is a Spherical joint"):
        robot.inverse_dynamics(P, V, A, q, zero, zero, backend="compiled")
    monkeypatch.setenv("STEWART_PIN_BACKEND", "auto")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert payload_compiled.payload_backend(robot, "auto") is None  # the reference path
    assert any("Spherical" in str(w.message) for w in caught)


def test_the_cache_key_follows_the_payload():
    arm = carrier("rus+three").payload
    g = np.array([0.0, 0.0, -9.81])
    moved = arm.with_placement(np.eye(4))
    assert payload_identity(arm, g) != payload_identity(moved, g)
    assert payload_identity(arm, g) != payload_identity(arm, 2 * g)
    assert payload_identity(arm, g) == payload_identity(arm.with_placement(MOUNT), g)
