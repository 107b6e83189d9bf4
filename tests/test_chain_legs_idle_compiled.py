"""The compiled models of robots whose legs have idle freedoms (6-RSS: each rod's spin about
its ball-to-ball line, ``rss_robot``; :mod:`stewart_pin.codegen.idle_compiled`) against
independent references: Pinocchio's constrained tree with the spins as tree joints
(:class:`~stewart_pin.check.chain_legs_tree.ChainTreeSolver`: the exact KKT solve with the
spin accelerations as unknowns, ``pin.constraintDynamics``) and central differences of
the reference path; the guard (a state the unrolled Newton has not solved, a state out of
reach) and the idle input's checks.

One compile (the asymmetric rods, module-scoped); the symmetric rods run the same
generated models in CasADi's virtual machine (nothing compiled)."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from conftest import use_compile_cache

from stewart_pin import StewartRobot
from stewart_pin._so3 import so3_exp
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen import idle_compiled
from stewart_pin.codegen.idle_compiled import CompiledIdleDerivatives, CompiledIdleDynamics
from stewart_pin.description.chain_leg_presets import rss_robot, welded_ups
from stewart_pin.dynamics.chain_leg_dynamics import ChainDynamics
from stewart_pin.exceptions import InputError, LegReachError, NumericalError
from stewart_pin.kinematics import chain_legs

#: Relative agreement with the constrained tree. The tree is evaluated at the legs'
#: configuration of the reference path (the compiled Newton's agrees with it to ~1e-14
#: rad; this desktop robot's direct model amplifies such differences to ~2e-11 at worst
#: over 60 sampled states: see test_chain_legs.py's 6-RSS direct-model test).
TOL = 1e-10


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache: Path) -> Iterator[Path]:
    yield from use_compile_cache(shared_compile_cache)


@pytest.fixture(scope="module")
def asymmetric() -> tuple[StewartRobot, CompiledIdleDynamics]:
    robot = StewartRobot(rss_robot(symmetric=False))
    return robot, idle_compiled.idle_backend(robot)  # the one compile of this module


@pytest.fixture(scope="module", params=["asymmetric-compiled", "symmetric-vm"])
def models(
    request: pytest.FixtureRequest, asymmetric: tuple[StewartRobot, CompiledIdleDynamics]
) -> tuple[StewartRobot, CompiledIdleDynamics]:
    if request.param == "asymmetric-compiled":
        assert asymmetric[1].kind == "compiled"
        return asymmetric
    robot = StewartRobot(rss_robot(symmetric=True))
    with warnings.catch_warnings():  # the VM's one warning per reason and process
        warnings.simplefilter("ignore", RuntimeWarning)
        fast = CompiledIdleDynamics(robot, compiler=False)
    assert fast.kind == "vm"
    return robot, fast


def _idle(robot: StewartRobot, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    spin = chain_legs.idle_home(robot.description) + rng.uniform(-0.6, 0.6, (n, 6))
    return spin, rng.uniform(-5.0, 5.0, (n, 6))


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_compiled_inverse_dynamics_and_spin_accelerations_match_the_tree(
    models: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    robot, fast = models
    T, V, A = robot.sample_states(4, rng=7)
    spin, rate = _idle(robot, 4, 1)
    gamma, sigma = fast.inverse_dynamics(T, V, A, (spin, rate))
    legs = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate)).legs
    tree = ChainTreeSolver(robot.description)
    for n in range(4):
        ref, ref_sigma = tree.inverse_idle_one(T[n], V[n], A[n], [s.q[n] for s in legs], rate[n])
        assert _rel(gamma[n], ref) <= TOL
        assert _rel(sigma[n], ref_sigma) <= TOL
        assert np.abs(ref_sigma).max() > 1.0  # the spins accelerate: a real check


def test_compiled_direct_dynamics_and_spin_accelerations_match_constraint_dynamics(
    models: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    robot, fast = models
    T, V, A = robot.sample_states(4, rng=8)
    spin, rate = _idle(robot, 4, 2)
    gammas = fast.inverse_dynamics(T, V, A, (spin, rate))[0]
    gammas = gammas * np.random.default_rng(0).uniform(0.5, 1.5, gammas.shape)
    acc, sigma = fast.direct_dynamics(T, V, gammas, (spin, rate))
    legs = robot.chain_dynamics.cartesian_dynamics(T, V, idle=(spin, rate)).legs
    tree = ChainTreeSolver(robot.description)
    for n in range(4):
        q = [s.q[n] for s in legs]
        ref, ref_sigma = tree.forward_idle_one(T[n], V[n], gammas[n], q, rate[n])
        assert _rel(acc[n], ref) <= TOL
        assert _rel(sigma[n], ref_sigma) <= TOL


def test_batches_equal_single_states_and_the_facade_serves_every_backend(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    robot, fast = asymmetric
    T, V, A = robot.sample_states(5, rng=9)
    spin, rate = _idle(robot, 5, 3)
    gamma, sigma = fast.inverse_dynamics(T, V, A, (spin, rate))
    acc, acc_sigma = fast.direct_dynamics(T, V, gamma, (spin, rate))
    for n in range(5):  # the same C on one state: the same numbers
        g1, s1 = fast.inverse_dynamics(T[n], V[n], A[n], (spin[n], rate[n]))
        a1, t1 = fast.direct_dynamics(T[n], V[n], gamma[n], (spin[n], rate[n]))
        assert np.array_equal(g1, gamma[n]) and np.array_equal(s1, sigma[n])
        assert np.array_equal(a1, acc[n]) and np.array_equal(t1, acc_sigma[n])
    assert _rel(acc, A) <= TOL  # the direct model inverts the inverse one
    ref = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    for backend in ("pinocchio", "compiled"):
        g, s = robot.inverse_dynamics_idle(T, V, A, (spin, rate), backend=backend)
        assert _rel(g, ref.gamma) <= TOL and _rel(s, ref.idle_accel) <= TOL
        assert np.array_equal(
            robot.inverse_dynamics(T[0], V[0], A[0], backend=backend, idle=(spin[0], rate[0])),
            robot.inverse_dynamics_idle(T[0], V[0], A[0], (spin[0], rate[0]), backend)[0],
        )
        a, t = robot.direct_dynamics_idle(T, V, g, (spin, rate), backend=backend)
        assert _rel(a, A) <= TOL and _rel(t, ref.idle_accel) <= TOL
        d = robot.direct_dynamics(T, V, g, backend=backend, idle=(spin, rate))
        assert np.array_equal(d, a)


def test_auto_takes_the_compiled_idle_models(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics], monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = StewartRobot(rss_robot(symmetric=False))  # a fresh robot: auto decides anew
    monkeypatch.setenv(compiled_module.BACKEND_ENV, "auto")
    fast = idle_compiled.auto_idle_backend(robot)
    assert fast is not None and fast.kind == "compiled"
    monkeypatch.setenv(compiled_module.BACKEND_ENV, "pinocchio")
    assert idle_compiled.auto_idle_backend(StewartRobot(rss_robot(symmetric=False))) is None


def test_a_flagged_state_is_computed_by_the_reference(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """A threshold between the state's singularity measure cond(S) and the C guard's bound
    ``||S||_F ||S^-1||_F``: the guard flags the state (COND), the reference path, whose
    exact measure accepts it, computes it; in a batch too. (The unrolled Newton's own
    flag, a residual above its slack, is met by no sampled 6-RSS state with 12 steps.)"""
    robot, fast = asymmetric
    T, V, A = robot.sample_states(3, rng=5)
    spin, rate = _idle(robot, 3, 6)
    J = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate)).J_inv
    S = J.copy()
    S[:, :, 3:] /= chain_legs.robot_size(robot.description)
    cond = np.linalg.cond(S)
    k = int(np.argmax(cond))  # the others stay under the threshold
    bound = np.linalg.norm(S[k]) * np.linalg.norm(np.linalg.inv(S[k]))
    assert bound > 1.01 * cond[k]
    inp = idle_compiled._inputs(fast._reference, T, V, A, "accel", (spin, rate))
    out, sig, flags = np.empty((3, 6)), np.empty((3, 6)), np.zeros(3, np.int32)
    saved = robot.max_condition
    try:
        robot.max_condition = 0.5 * (cond[k] + bound)
        fast._call_batch("idm", inp, robot.max_condition, out, sig, flags)
        assert flags[k] & 4  # COND
        gamma, sigma = fast.inverse_dynamics(T, V, A, (spin, rate))
        g1, s1 = fast.inverse_dynamics(T[k], V[k], A[k], (spin[k], rate[k]))
        ref = ChainDynamics(robot.description, robot.max_condition, check_limits=True)
        r = ref.inverse_dynamics(T[k], V[k], A[k], details=True, idle=(spin[k], rate[k]))
    finally:
        robot.max_condition = saved
    # the reference's numbers (its leg solutions from another start: 1e-12, not bitwise)
    assert _rel(g1, r.gamma[0]) <= 1e-12 and _rel(s1, r.idle_accel[0]) <= 1e-12
    assert _rel(gamma[k], g1) <= 1e-12 and _rel(sigma[k], s1) <= 1e-12


def test_out_of_reach_raises_the_reference_error(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    robot, _ = asymmetric
    T, V, A = robot.sample_states(3, rng=4)
    spin, rate = _idle(robot, 3, 4)
    far = T.copy()
    far[1, 2, 3] += 0.15  # 15 cm up: past the 3 cm cranks and 10 cm rods
    for backend in ("pinocchio", "compiled"):
        with pytest.raises(LegReachError, match="pose 1"):
            robot.inverse_dynamics_idle(far, V, A, (spin, rate), backend=backend)
        with pytest.raises(LegReachError):
            robot.direct_dynamics_idle(far[1], V[1], A[1], (spin[1], rate[1]), backend=backend)


def test_bad_idle_input_is_an_input_error(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    robot, _ = asymmetric
    H, zero = robot.description.home_pose, np.zeros(6)
    spin = chain_legs.idle_home(robot.description)
    for backend in ("compiled", "pinocchio"):
        with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
            robot.inverse_dynamics(H, zero, zero, backend=backend)
        with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
            robot.direct_dynamics(H, zero, zero, backend=backend)
        with pytest.raises(InputError, match="idle values"):
            robot.inverse_dynamics_idle(H, zero, zero, (spin[:5], zero), backend=backend)
        with pytest.raises(InputError, match="idle rates must be finite"):
            robot.inverse_dynamics_idle(H, zero, zero, (spin, np.full(6, np.nan)), backend)
        with pytest.raises(InputError, match="idle must be"):
            robot.direct_dynamics_idle(H, zero, zero, spin, backend=backend)
    with pytest.raises(InputError, match="idle freedoms"):
        robot.inverse_dynamics_derivatives(H, zero, zero)
    welded = StewartRobot(welded_ups(seed=1, joint_terms=False))
    with pytest.raises(InputError, match="has no idle joints"):
        welded.inverse_dynamics(welded.description.home_pose, zero, zero, idle=(zero, zero))


def _central(f, T, V, X, idle, h=1e-6):  # type: ignore[no-untyped-def]
    """Central differences of ``f(T, V, X, (s, sd)) -> (6,), (6,)`` stacked (12,): in the
    pose chart ``[dp, dtheta]``, the twist, X, the idle values and rates."""
    s, sd = idle

    def g(*a):  # type: ignore[no-untyped-def]
        return np.concatenate(f(*a))

    out = [np.zeros((12, 6)) for _ in range(5)]
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        P = [T.copy(), T.copy()]
        for P_s, sign in zip(P, (1.0, -1.0), strict=True):
            P_s[:3, 3] += sign * e[:3]
            P_s[:3, :3] = so3_exp((sign * e[3:])[None])[0] @ T[:3, :3]
        out[0][:, j] = (g(P[0], V, X, idle) - g(P[1], V, X, idle)) / (2 * h)
        out[1][:, j] = (g(T, V + e, X, idle) - g(T, V - e, X, idle)) / (2 * h)
        out[2][:, j] = (g(T, V, X + e, idle) - g(T, V, X - e, idle)) / (2 * h)
        out[3][:, j] = (g(T, V, X, (s + e, sd)) - g(T, V, X, (s - e, sd))) / (2 * h)
        out[4][:, j] = (g(T, V, X, (s, sd + e)) - g(T, V, X, (s, sd - e))) / (2 * h)
    return out


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_exact_derivatives_match_central_differences(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """The Jacobians (CasADi's, in the VM: the compiled library's functions) of the
    efforts, platform acceleration and spin accelerations in the pose, twist, third
    argument and the spin angles and rates, against central differences (h = 1e-6) of
    the reference path, to 1e-6 relative (their truncation and rounding)."""
    robot, fast = asymmetric
    T, V, A = (x[0] for x in robot.sample_states(1, rng=8))
    s, sd = (x[0] for x in _idle(robot, 1, 5))
    exact = CompiledIdleDerivatives(robot, fast, compiler=False)

    def ref_idm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.inverse_dynamics_idle(T, V, X, idle, backend="pinocchio")

    def ref_ddm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.direct_dynamics_idle(T, V, X, idle, backend="pinocchio")

    d = exact.inverse_dynamics_derivatives(T, V, A, (s, sd))
    fd = _central(ref_idm, T, V, A, (s, sd))
    for x, y in zip((d.pose, d.twist, d.accel, d.idle_values, d.idle_rates), fd, strict=True):
        for rows in (slice(0, 6), slice(6, 12)):  # efforts, spin accelerations
            assert np.abs(x[rows] - y[rows]).max() <= 1e-6 * np.abs(y[rows]).max()
    g = exact.direct_dynamics_derivatives(T, V, d.gamma, (s, sd))
    fd = _central(ref_ddm, T, V, d.gamma, (s, sd))
    for x, y in zip((g.pose, g.twist, g.gamma, g.idle_values, g.idle_rates), fd, strict=True):
        for rows in (slice(0, 6), slice(6, 12)):
            assert np.abs(x[rows] - y[rows]).max() <= 1e-6 * np.abs(y[rows]).max()


def test_simulate_idle_runs_on_the_compiled_direct_model(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    from stewart_pin.motion.idle_simulation import simulate_idle

    robot, _ = asymmetric
    s0 = chain_legs.idle_home(robot.description)
    v0 = np.linspace(-3.0, 3.0, 6)
    runs = [
        simulate_idle(robot, 0.01, idle=(s0, v0), dt=0.002, backend=b)
        for b in ("compiled", "pinocchio")
    ]
    assert len(runs[0].t) == 6
    for a, b in zip((runs[0].poses, runs[0].idle_v), (runs[1].poses, runs[1].idle_v), strict=True):
        assert np.abs(a - b).max() <= 1e-9 * max(np.abs(b).max(), 1.0)


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_the_generated_models_match_mujocos_kkt_with_spinning_rods() -> None:
    """MuJoCo's model of the same 6-RSS (the spins as hinges; Coulomb off: MuJoCo's
    frictionloss is no ``Fc sign(qdot)``) in an exact KKT solve
    (``tests/test_chain_legs_mjcf.py``) against the generated idle models (in the VM:
    the compiled library's functions, nothing compiled), efforts and spin accelerations."""
    pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")
    import mujoco
    from test_chain_legs_mjcf import mujoco_kkt_inverse_dynamics, without_coulomb

    robot = StewartRobot(without_coulomb(rss_robot(symmetric=False)))
    fast = CompiledIdleDynamics(robot, compiler=False)
    assert fast.kind == "vm"
    m = mujoco.MjModel.from_xml_string(robot.mjcf())
    data = mujoco.MjData(m)
    T, V, A = robot.sample_states(3, rng=6)
    spin, rate = _idle(robot, 3, 7)
    gamma, sigma = fast.inverse_dynamics(T, V, A, (spin, rate))
    for n in range(3):
        ref, ref_sigma = mujoco_kkt_inverse_dynamics(
            m, data, robot, T[n], V[n], A[n], (spin[n], rate[n])
        )
        assert _rel(gamma[n], ref) <= TOL
        assert _rel(sigma[n], ref_sigma) <= TOL


# ---------------------------------------------------------------------------- first use
def _small_jacobian(model, name):  # type: ignore[no-untyped-def]
    """A stand-in of ``_jacobian_function`` with its signature and output size (a few
    thousand instructions: compiled in a fraction of a second), to check the libraries'
    orchestration and C wiring: ``M @ sin(z)``, z = [pose, twist, x, idle] (40,)."""
    import casadi as cs

    x = [cs.SX.sym(model.name_in(k), model.size1_in(k)) for k in range(5)]
    z = cs.vertcat(x[0], x[1], x[2], x[4])
    out = cs.mtimes(cs.DM(_STUB_M), cs.sin(z))
    return cs.Function(name, x, [out], [model.name_in(k) for k in range(5)], ["d"])


_STUB_M = np.random.default_rng(3).normal(size=(12 * 30, 40))


def _stub_blocks(T, V, X, idle):  # type: ignore[no-untyped-def]
    """The stand-in's five (N, 12, 6) blocks, by NumPy."""
    z = np.concatenate([T.reshape(len(T), 16), V, X, idle[0], idle[1]], axis=1)
    J = (np.sin(z) @ _STUB_M.T).reshape(len(T), 12, 30)
    return [J[:, :, 6 * k : 6 * k + 6] for k in range(5)]


def test_idle_derivative_libraries_one_per_model_background_then_cached(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capfd: pytest.CaptureFixture[str],
) -> None:
    """The first use of :class:`CompiledIdleDerivatives` is :class:`CompiledDerivatives`'
    (the Jacobian function replaced by a small stand-in, the real one being a 45 s
    compile): past the background threshold (lowered to 0) the inverse model's library
    compiles in a thread, announced on stderr, while the VM answers; the direct model's
    is sought on its first call only (threshold raised: compiled at once); a new backend
    loads both from the cache without generating anything. Every answer (VM, library,
    batch of 3 split over the C loop's pointers, one state) equals NumPy's evaluation of
    the stand-in to 1e-12 relative."""
    from stewart_pin.codegen import derivatives

    if compiled_module.find_compiler() is None:
        pytest.skip("no C compiler on this machine")
    robot, fast = asymmetric
    monkeypatch.setattr(idle_compiled, "_jacobian_function", _small_jacobian)
    monkeypatch.setattr(derivatives, "BACKGROUND_INSTRUCTIONS", 0)
    T, V, A = robot.sample_states(3, rng=11)
    idle = _idle(robot, 3, 12)
    want = _stub_blocks(T, V, A, idle)

    def same(d, want, n=None):  # type: ignore[no-untyped-def]
        third = d.accel if d.accel.shape[-2:] == (12, 6) else d.gamma  # the Jacobian
        got = (d.pose, d.twist, third, d.idle_values, d.idle_rates)
        for g, w in zip(got, want, strict=True):
            w = w if n is None else w[n]
            assert g.shape == w.shape
            assert np.abs(g - w).max() <= 1e-12 * np.abs(w).max()

    exact = CompiledIdleDerivatives(robot, fast, cache_dir=tmp_path)
    assert exact.reason == "compiling in the background" and exact.kinds == {"idm": "vm"}
    first = exact.inverse_dynamics_derivatives(T, V, A, idle)
    same(first, want)
    assert exact.wait(120)
    assert exact.kind == "compiled" and exact.compiled_now and exact.library is not None
    assert "ddm" not in exact.kinds  # the direct model's library not sought yet
    err = capfd.readouterr().err
    assert "exact derivatives with idle freedoms of robot" in err and "in the background" in err
    again = exact.inverse_dynamics_derivatives(T, V, A, idle)
    same(again, want)
    one = exact.inverse_dynamics_derivatives(T[1], V[1], A[1], (idle[0][1], idle[1][1]))
    same(one, want, 1)

    monkeypatch.setattr(derivatives, "BACKGROUND_INSTRUCTIONS", 10**9)  # compiled at once
    gamma = fast.inverse_dynamics(T, V, A, idle)[0]
    want_d = _stub_blocks(T, V, gamma, idle)
    d = exact.direct_dynamics_derivatives(T, V, gamma, idle)
    assert exact.kinds == {"idm": "compiled", "ddm": "compiled"}
    assert "the direct model's exact derivatives" in capfd.readouterr().err
    same(d, want_d)

    def forbidden(*args):  # type: ignore[no-untyped-def]
        raise AssertionError("the Jacobian function was generated")

    monkeypatch.setattr(idle_compiled, "_jacobian_function", forbidden)
    cached = CompiledIdleDerivatives(robot, fast, cache_dir=tmp_path)
    assert cached.kind == "compiled" and not cached.compiled_now
    same(cached.inverse_dynamics_derivatives(T, V, A, idle), want)
    d = cached.direct_dynamics_derivatives(T, V, gamma, idle)
    assert cached.kinds["ddm"] == "compiled" and not capfd.readouterr().err
    same(d, want_d)


def test_idle_derivatives_first_use_answers_from_the_vm_announced(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
    tmp_path: Path,
    capfd: pytest.CaptureFixture[str],
) -> None:
    """The real Jacobians (63 000 instructions for the inverse model: past the background
    threshold) on first use: the constructor compiles nothing in the foreground, the
    build is announced on stderr and the first call answers from CasADi's VM. A stub
    compiler that fails at once stands in for the 45 s compile: the build fails in its
    thread (one warning), :meth:`wait` returns, and the VM keeps answering. The answer's
    acceleration and idle-rate Jacobians equal central differences (h = 1e-6) of the
    reference path to 1e-6 relative (test_exact_derivatives_match_central_differences
    checks every block)."""
    robot, fast = asymmetric
    stub = tmp_path / "failing-cc"
    stub.write_text("#!/bin/sh\nexit 1\n")
    stub.chmod(0o755)
    exact = CompiledIdleDerivatives(robot, fast, compiler=str(stub), cache_dir=tmp_path / "c")
    assert exact.reason == "compiling in the background"
    T, V, A = (x[0] for x in robot.sample_states(1, rng=13))
    s, sd = (x[0] for x in _idle(robot, 1, 14))
    with pytest.warns(RuntimeWarning, match="idle derivatives unavailable"):
        d = exact.inverse_dynamics_derivatives(T, V, A, (s, sd))
        assert exact.wait(60)
    assert exact.kind == "vm" and exact.kinds == {"idm": "vm"}
    err = capfd.readouterr().err
    assert "exact derivatives with idle freedoms of robot" in err and "in the background" in err

    def ref_idm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.inverse_dynamics_idle(T, V, X, idle, backend="pinocchio")

    fd = _central(ref_idm, T, V, A, (s, sd))
    for x, y in zip((d.accel, d.idle_rates), (fd[2], fd[4]), strict=True):
        for rows in (slice(0, 6), slice(6, 12)):
            assert np.abs(x[rows] - y[rows]).max() <= 1e-6 * np.abs(y[rows]).max()
    again = exact.inverse_dynamics_derivatives(T, V, A, (s, sd))
    assert np.array_equal(again.pose, d.pose)


def test_outputs_that_overflow_are_numerical_errors_without_warnings(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """Finite inputs whose results overflow (a 1e160 twist: its squares overflow in the
    legs' kinematics): NumericalError on every backend and entry, and no RuntimeWarning
    escapes (the reference path's overflow is checked, as ``quiet_overflow`` does for the
    robots without idle joints)."""
    robot, _ = asymmetric
    H, zero = robot.description.home_pose, np.zeros(6)
    idle = (chain_legs.idle_home(robot.description), zero)
    huge = np.full(6, 1e160)
    for backend in ("pinocchio", "compiled"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no RuntimeWarning escapes either
            with pytest.raises(NumericalError, match="Gamma is not finite"):
                robot.inverse_dynamics_idle(H, huge, zero, idle, backend=backend)
            with pytest.raises(NumericalError, match="acceleration is not finite"):
                robot.direct_dynamics_idle(H, huge, zero, idle, backend=backend)
            with pytest.raises(NumericalError, match="Gamma is not finite"):
                robot.inverse_dynamics(H, huge, zero, backend=backend, idle=idle)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NumericalError, match="Gamma is not finite"):
            robot.inverse_dynamics(H, huge, zero, details=True, idle=idle)


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_facade_derivatives_speak_the_robots_actuator_convention(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """``robot.*_dynamics_derivatives(..., idle=)`` of a robot whose actuator convention
    flips three actuators (as an imported file's axes would): the efforts' rows and the
    ``gamma`` columns in the robot's convention, against central differences (h = 1e-6,
    1e-6 relative: their truncation and rounding) of the facade's reference path in that
    convention (``backend="pinocchio"``), plus the differences' rounding (1e-9 of the
    values' scale: eps |f| / h is 1e-10 of it). The derivatives run in the VM (the compiled
    library's functions) to keep the test free of a compile."""
    from dataclasses import replace as dc_replace

    base, fast = asymmetric
    robot = StewartRobot(base.description)
    signs = np.array([1.0, -1.0, 1.0, -1.0, -1.0, 1.0])
    robot._set_convention(dc_replace(robot.actuator_convention, name="file", signs=signs))
    assert robot._actuators is not None
    idle_compiled._DERIVATIVES[robot] = CompiledIdleDerivatives(robot, fast, compiler=False)
    T, V, A = (x[0] for x in robot.sample_states(1, rng=3))
    s, sd = (x[0] for x in _idle(robot, 1, 8))

    def ref_idm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.inverse_dynamics_idle(T, V, X, idle, backend="pinocchio")

    def ref_ddm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.direct_dynamics_idle(T, V, X, idle, backend="pinocchio")

    d = robot.inverse_dynamics_derivatives(T, V, A, idle=(s, sd))
    assert isinstance(d, idle_compiled.IdleInverseDerivatives)
    gamma, _ = ref_idm(T, V, A, (s, sd))
    assert _rel(d.gamma, gamma) <= TOL
    fd = _central(ref_idm, T, V, A, (s, sd))
    noise = 1e-9 * np.abs(gamma).max()
    for x, y in zip((d.pose, d.twist, d.accel, d.idle_values, d.idle_rates), fd, strict=True):
        assert np.abs(x[:6] - y[:6]).max() <= 1e-6 * np.abs(y[:6]).max() + noise
    g = robot.direct_dynamics_derivatives(T, V, gamma, idle=(s, sd))
    assert isinstance(g, idle_compiled.IdleDirectDerivatives)
    assert _rel(g.accel, A) <= TOL
    fd = _central(ref_ddm, T, V, gamma, (s, sd))
    noise = 1e-9 * np.abs(A).max()
    for x, y in zip((g.pose, g.twist, g.gamma, g.idle_values, g.idle_rates), fd, strict=True):
        assert np.abs(x[:6] - y[:6]).max() <= 1e-6 * np.abs(y[:6]).max() + noise


def _edge(
    robot: StewartRobot, fast: CompiledIdleDynamics
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(T, spin, zero)``: just past the last pose along a direction from home that the
    12 unrolled Newton steps solve (found by bisection on the compiled guard's flag; a leg
    near full stretch, where Newton converges slowly), the spins and a zero (1, 6)."""
    H = robot.description.home_pose
    size = chain_legs.robot_size(robot.description)
    rng = np.random.default_rng(5)
    d = rng.normal(size=6)
    d[3:] *= 1.5
    spin = chain_legs.idle_home(robot.description) + rng.uniform(-2.0, 2.0, 6)
    idle = (spin[None], np.zeros((1, 6)))
    zero = np.zeros((1, 6))

    def pose(s: float) -> np.ndarray:
        T = H.copy()
        T[:3, 3] += s * d[:3] * size
        T[:3, :3] = so3_exp((s * d[3:])[None])[0] @ H[:3, :3]
        return T

    def flag(s: float) -> int:
        inp = idle_compiled._inputs(fast._reference, pose(s)[None], zero, zero, "accel", idle)
        out, sig, f = np.empty((1, 6)), np.empty((1, 6)), np.zeros(1, np.int32)
        fast._call_batch("idm", inp, robot.max_condition, out, sig, f)
        return int(f[0])

    lo, hi = 0.0, 1.0
    while flag(hi) == 0:
        hi *= 2.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if flag(mid) == 0 else (lo, mid)
    assert flag(hi * (1.0 + 1e-9)) == 2  # GEOMETRY only
    return pose(hi * (1.0 + 1e-9)), spin, zero


def test_a_state_the_unrolled_newton_does_not_solve_is_computed_by_the_reference(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """Along a direction from home, just past the last pose the 12 unrolled Newton steps
    solve (a leg near full stretch: Newton converges slowly there), the guard flags the
    state (GEOMETRY: the leg's residual above its slack) although the reference's
    continuation solves it; the compiled models then return the reference's numbers
    (1e-12: its leg solutions from another start), not the unrolled Newton's (which
    differ from them by ~1e-9 there)."""
    robot, fast = asymmetric
    T, spin, zero = _edge(robot, fast)
    models = idle_compiled.idle_models(robot.description)
    lay = models.layout
    args = (T.reshape(16), zero[0], zero[0], np.zeros(0), np.concatenate([spin, zero[0]]))
    aux = np.array(models.idm_guarded(*args)[1]).ravel()
    slacks = aux[lay.idm_slack : lay.idm_slack + lay.n_slack].reshape(6, -1)
    assert np.any(slacks[:, 0] <= 0.0)  # a leg's Newton residual, not a limit
    flat = np.array(models.flat_idm(*args)).ravel()
    ref = robot.inverse_dynamics_idle(T, zero[0], zero[0], (spin, zero[0]), backend="pinocchio")
    got = robot.inverse_dynamics_idle(T, zero[0], zero[0], (spin, zero[0]), backend="compiled")
    assert _rel(got[0], ref[0]) <= 1e-12 and _rel(got[1], ref[1]) <= 1e-12
    assert _rel(flat[:6], ref[0]) > 1e-11  # what the guard kept out


@pytest.mark.filterwarnings("ignore:stewart-pin compiled:RuntimeWarning")  # the VM, on purpose
def test_exact_derivatives_refuse_a_state_the_unrolled_newton_does_not_solve(
    asymmetric: tuple[StewartRobot, CompiledIdleDynamics],
) -> None:
    """At :func:`_edge`'s state (a leg's Newton residual slack negative after the 12
    unrolled steps; its values come from the reference) the Jacobians of the unrolled
    model are not the converged solution's: the derivative calls raise NumericalError
    naming the state (batch semantics: the whole call raises), found with the compiled
    value guard (the Jacobians in the VM); an ordinary state alone still matches central
    differences of the reference path (1e-6 relative)."""
    robot, fast = asymmetric
    T, spin, zero = _edge(robot, fast)
    exact = CompiledIdleDerivatives(robot, fast, compiler=False)
    T0, V0, A0 = (x[0] for x in robot.sample_states(1, rng=8))
    s0, sd0 = (x[0] for x in _idle(robot, 1, 5))
    Ts, Vs, As = np.stack([T0, T]), np.stack([V0, zero[0]]), np.stack([A0, zero[0]])
    idle = (np.stack([s0, spin]), np.stack([sd0, zero[0]]))
    with pytest.raises(NumericalError, match=r"did not converge at state 1 \(leg"):
        exact.inverse_dynamics_derivatives(Ts, Vs, As, idle)
    with pytest.raises(NumericalError, match=r"did not converge at state 0 \(leg") as err:
        exact.inverse_dynamics_derivatives(T, zero[0], zero[0], (spin, zero[0]))
    assert err.value.index == 0
    G = robot.inverse_dynamics_idle(Ts, Vs, As, idle, backend="pinocchio")[0]
    with pytest.raises(NumericalError, match="did not converge at state 1"):
        exact.direct_dynamics_derivatives(Ts, Vs, G, idle)

    def ref_idm(T, V, X, idle):  # type: ignore[no-untyped-def]
        return robot.inverse_dynamics_idle(T, V, X, idle, backend="pinocchio")

    d = exact.inverse_dynamics_derivatives(T0, V0, A0, (s0, sd0))
    fd = _central(ref_idm, T0, V0, A0, (s0, sd0))
    for x, y in zip((d.pose, d.twist, d.accel, d.idle_values, d.idle_rates), fd, strict=True):
        for rows in (slice(0, 6), slice(6, 12)):
            assert np.abs(x[rows] - y[rows]).max() <= 1e-6 * np.abs(y[rows]).max()
