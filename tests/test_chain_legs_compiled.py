"""The compiled models of robots with chain legs (:mod:`stewart_pin.codegen.chain_leg_symbolic`)
against independent references: Pinocchio's constrained tree with 3D and 6D loop
constraints (exact KKT solves, :mod:`stewart_pin.check.chain_legs_tree`) and central
differences; the guard (a state the unrolled Newton has not solved goes to the reference
path, whose errors it raises)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from conftest import use_compile_cache

from stewart_pin import StewartRobot
from stewart_pin._so3 import so3_exp
from stewart_pin.apps.bench import architecture_rows
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.chain_leg_symbolic import NEWTON_ITERATIONS, build_chain_models
from stewart_pin.codegen.derivatives import CompiledDerivatives
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups
from stewart_pin.exceptions import LegJointLimitError, NumericalError
from stewart_pin.kinematics import chain_legs

TOL = 1e-10  # relative agreement with the constrained tree


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache: Path) -> Iterator[Path]:
    yield from use_compile_cache(shared_compile_cache)


@pytest.fixture(scope="module", params=["welded", "mixed"])
def robot(request: pytest.FixtureRequest) -> StewartRobot:
    desc = welded_ups() if request.param == "welded" else mixed_chain_robot(seed=2)
    return StewartRobot(desc)


@pytest.fixture(scope="module")
def states(robot: StewartRobot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return robot.sample_states(4, rng=7)


def _q_legs(robot: StewartRobot, T: np.ndarray) -> list[np.ndarray]:
    return [q[0] for q in chain_legs.inverse_geometry(robot.description, T[None], False)]


def test_auto_takes_the_compiled_models(
    robot: StewartRobot, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(compiled_module.BACKEND_ENV, "auto")
    fast = compiled_module.auto_backend(robot)
    assert fast is not None and fast.kind == "compiled"


def test_compiled_inverse_dynamics_matches_the_constrained_tree(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, A = states
    tree = ChainTreeSolver(robot.description)
    for n in range(T.shape[0]):
        gamma = robot.inverse_dynamics(T[n], V[n], A[n], backend="compiled")
        ref = tree.inverse_one(T[n], V[n], A[n], _q_legs(robot, T[n]))
        assert np.abs(gamma - ref).max() <= TOL * np.abs(ref).max()


def test_compiled_direct_dynamics_matches_pinocchio_constraint_dynamics(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, _ = states
    tree = ChainTreeSolver(robot.description)
    g0 = robot.inverse_dynamics(T, V, np.zeros_like(V), backend="pinocchio")
    gammas = g0 + np.random.default_rng(3).normal(size=g0.shape) * np.abs(g0).mean() * 0.2
    for n in range(T.shape[0]):
        acc = robot.direct_dynamics(T[n], V[n], gammas[n], backend="compiled")
        ref = tree.forward_one(T[n], V[n], gammas[n], _q_legs(robot, T[n]))
        assert np.abs(acc - ref).max() <= TOL * np.abs(ref).max()


def test_a_batch_is_its_states_one_by_one(robot: StewartRobot) -> None:
    T, V, A = robot.sample_states(9, rng=4)
    gamma = robot.inverse_dynamics(T, V, A, backend="compiled")
    acc = robot.direct_dynamics(T, V, gamma, backend="compiled")
    for n in range(T.shape[0]):
        one = robot.inverse_dynamics(T[n], V[n], A[n], backend="compiled")
        assert np.abs(one - gamma[n]).max() <= 1e-13 * np.abs(gamma[n]).max()
        back = robot.direct_dynamics(T[n], V[n], gamma[n], backend="compiled")
        assert np.abs(back - acc[n]).max() <= 1e-13 * np.abs(acc[n]).max()
    assert np.abs(acc - A).max() <= TOL * np.abs(A).max()  # and they invert each other


def _far(robot: StewartRobot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A reachable pose the unrolled Newton from home does not solve: the reference's
    continuation does."""
    H = robot.description.home_pose.copy()
    size = chain_legs.robot_size(robot.description)
    T = H.copy()
    T[:3, 3] += np.array([1.05, -0.9, 0.45]) * size
    T[:3, :3] = so3_exp(np.array([[0.75, -0.9, 1.05]]))[0] @ H[:3, :3]
    rng = np.random.default_rng(5)
    return T, rng.normal(size=6) * 0.1, rng.normal(size=6)


def test_a_state_newton_has_not_solved_is_flagged_and_recomputed() -> None:
    robot = StewartRobot(welded_ups())
    T, V, A = _far(robot)
    models, layout = build_chain_models(robot.description)
    _, aux = models.idm_guarded(T.reshape(16), V, A, np.zeros(0))
    slacks = np.array(aux).ravel()[layout.idm_slack :]
    assert not np.all(slacks > 0.0), f"{NEWTON_ITERATIONS} steps solved it: not a test"
    ref = robot.inverse_dynamics(T, V, A, backend="pinocchio")
    gamma = robot.inverse_dynamics(T, V, A, backend="compiled")
    assert np.abs(gamma - ref).max() <= TOL * np.abs(ref).max()
    # in a batch beside a state the guard passes: only the flagged one is recomputed
    T0, V0, A0 = (x[0] for x in robot.sample_states(1, rng=2))
    Ts, Vs, As = np.stack([T0, T]), np.stack([V0, V]), np.stack([A0, A])
    batch = robot.inverse_dynamics(Ts, Vs, As, backend="compiled")
    refs = robot.inverse_dynamics(Ts, Vs, As, backend="pinocchio")
    assert np.abs(batch - refs).max() <= TOL * np.abs(refs).max()
    acc = robot.direct_dynamics(Ts, Vs, refs, backend="compiled")
    assert np.abs(acc - As).max() <= TOL * np.abs(As).max()


def test_a_pose_out_of_the_legs_limits_raises_the_reference_error() -> None:
    robot = StewartRobot(welded_ups())
    T = robot.description.home_pose.copy()
    T[2, 3] += 10.0 * chain_legs.robot_size(robot.description)
    zero = np.zeros(6)
    with pytest.raises(LegJointLimitError) as ref:
        robot.inverse_dynamics(T, zero, zero, backend="pinocchio")
    with pytest.raises(LegJointLimitError) as err:
        robot.inverse_dynamics(T, zero, zero, backend="compiled")
    assert str(err.value) == str(ref.value)
    with pytest.raises(LegJointLimitError):
        poses = np.stack([robot.description.home_pose, T])
        robot.direct_dynamics(poses, np.zeros((2, 6)), np.zeros((2, 6)), backend="compiled")


def test_the_bench_times_the_welded_robot_against_its_constrained_tree(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(compiled_module.BACKEND_ENV, "auto")
    row = architecture_rows("welded-ups", repeats=3, batches=(4,))
    assert row["architecture"] == "chain" and str(row["backend"]).startswith("compiled")
    ratios = row["ratio_to_pin_constraintDynamics"]
    assert set(ratios) >= {"IDM single", "DDM single", "IDM batch 4", "DDM batch 4"}
    assert all(np.isfinite(x) and x > 0 for x in ratios.values())


def _central(
    f: Callable[..., np.ndarray], T: np.ndarray, V: np.ndarray, X: np.ndarray, h: float = 1e-6
) -> tuple[np.ndarray, ...]:
    """Central differences of ``f(pose, twist, x)`` in ``delta = [dp, dtheta]`` (F0), the
    twist and ``x``: three (6, 6)."""
    out = tuple(np.zeros((6, 6)) for _ in range(3))
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        P = [T.copy(), T.copy()]
        for P_s, s in zip(P, (1.0, -1.0), strict=True):
            P_s[:3, 3] += s * e[:3]
            P_s[:3, :3] = so3_exp((s * e[3:])[None])[0] @ T[:3, :3]
        out[0][:, j] = (f(P[0], V, X) - f(P[1], V, X)) / (2 * h)
        out[1][:, j] = (f(T, V + e, X) - f(T, V - e, X)) / (2 * h)
        out[2][:, j] = (f(T, V, X + e) - f(T, V, X - e)) / (2 * h)
    return out


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_exact_derivatives_match_central_differences() -> None:
    robot = StewartRobot(welded_ups())
    T, V, A = (x[0] for x in robot.sample_states(1, rng=8))
    exact = CompiledDerivatives(robot, compiler=False)  # the VM: nothing to compile
    d = exact.inverse_dynamics_derivatives(T, V, A)
    fd = _central(partial(robot.inverse_dynamics, backend="pinocchio"), T, V, A)
    for x, y in zip((d.pose, d.twist, d.accel), fd, strict=True):
        assert np.abs(x - y).max() <= 1e-6 * np.abs(y).max()
    g = exact.direct_dynamics_derivatives(T, V, d.gamma)
    fd = _central(partial(robot.direct_dynamics, backend="pinocchio"), T, V, d.gamma)
    for x, y in zip((g.pose, g.twist, g.gamma), fd, strict=True):
        assert np.abs(x - y).max() <= 1e-6 * np.abs(y).max()


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_exact_derivatives_refuse_a_state_the_unrolled_newton_has_not_solved() -> None:
    """At a state the 7 unrolled Newton steps from home do not solve (the legs' residual
    slacks negative: its values come from the reference path), the Jacobians of the
    unrolled model are not the true ones (off by 4 times their size from central
    differences of the reference here; asserted: by more than 1e-3); the derivative call
    raises NumericalError naming the state (the whole batch call: one refused state
    refuses the call), and an ordinary state alone still matches central differences of
    the reference path (1e-6)."""
    robot = StewartRobot(welded_ups())
    T, V, A = _far(robot)
    T0, V0, A0 = (x[0] for x in robot.sample_states(1, rng=2))
    exact = CompiledDerivatives(robot, compiler=False)  # the VM: nothing to compile
    fd = _central(partial(robot.inverse_dynamics, backend="pinocchio"), T, V, A)
    unrolled = np.array(exact._flat("idm")(T.reshape(16), V, A, np.zeros(0))).reshape(3, 6, 6)
    assert np.abs(unrolled[0] - fd[0]).max() > 1e-3 * np.abs(fd[0]).max()  # what it refuses
    Ts, Vs, As = np.stack([T0, T]), np.stack([V0, V]), np.stack([A0, A])
    with pytest.raises(NumericalError, match=r"did not converge at state 1 .*1 of 2 states"):
        exact.inverse_dynamics_derivatives(Ts, Vs, As)
    with pytest.raises(NumericalError, match="did not converge at state 0") as err:
        exact.inverse_dynamics_derivatives(T, V, A)
    assert err.value.index == 0 and "unrolled model would be inexact" in str(err.value)
    G = robot.inverse_dynamics(Ts, Vs, As, backend="pinocchio")
    with pytest.raises(NumericalError, match="did not converge at state 1"):
        exact.direct_dynamics_derivatives(Ts, Vs, G)
    d = exact.inverse_dynamics_derivatives(T0, V0, A0)
    fd = _central(partial(robot.inverse_dynamics, backend="pinocchio"), T0, V0, A0)
    for x, y in zip((d.pose, d.twist, d.accel), fd, strict=True):
        assert np.abs(x - y).max() <= 1e-6 * np.abs(y).max()


def test_vector_batch_of_welded_legs_equals_the_scalar_path() -> None:
    """The chain legs' Newton steps are calls of one step function per leg: the batch loop
    runs them SP_WIDTH states at a time through the vector copies of the body and of the
    step functions (codegen/_simd.py; issue 20). Every state's result and flag equal those
    of the same C called on that state alone (the scalar path) to 1e-13, whichever lane it
    takes, with a state Newton has not solved (flagged: the guard's slack), states out of
    reach or not finite in other lanes and an uneven count (the last states scalar); the
    valid states equal the reference path."""
    robot = StewartRobot(welded_ups())
    n = 23
    P, V, A = (np.ascontiguousarray(a) for a in robot.sample_states(n, 8))
    backend = compiled_module.CompiledDynamics(robot, threads=1)
    source = (backend.library.parent / "stewart_models.c").read_text()
    assert "#define SP_VEC_IDM 1" in source and "#define SP_VEC_DDM 1" in source
    assert "sp_vf_" in source  # the step functions' vector copies
    G = np.ascontiguousarray(robot.inverse_dynamics(P, V, A, backend="pinocchio"))
    P[5], V[5], A[5] = _far(robot)  # lane 1 (of 4): Newton has not solved it
    G[5] = robot.inverse_dynamics(P[5], V[5], A[5], backend="pinocchio")
    P[6, 2, 3] += 10.0 * chain_legs.robot_size(robot.description)  # lane 2: out of reach
    V[11, 0] = np.nan  # lane 3: not finite
    A[16, 2] = G[16, 2] = np.inf  # lane 0: not finite
    valid = np.ones(n, dtype=bool)
    valid[[5, 6, 11, 16]] = False
    chi = np.ascontiguousarray(backend.base_values, dtype=np.float64)
    for which, X, ref in (("idm", A, G), ("ddm", G, A)):
        out, flags = np.empty((n, 6)), np.zeros(n, dtype=np.int32)
        backend._call_batch(which, n, P, V, X, chi, out, flags)
        assert np.all(flags[~valid] != 0) and not np.any(flags[valid])
        assert np.abs(out[valid] - ref[valid]).max() <= TOL * np.abs(ref[valid]).max()
        for k in range(n):
            one, flag = np.empty((1, 6)), np.zeros(1, dtype=np.int32)
            x = X[k : k + 1]
            backend._call_batch(which, 1, P[k : k + 1], V[k : k + 1], x, chi, one, flag)
            assert flag[0] == flags[k], (which, k)
            if valid[k] or k == 5:  # the unsolved state's (unused) values too
                assert np.max(np.abs(out[k] - one[0])) <= 1e-13 * np.max(np.abs(one[0]))
