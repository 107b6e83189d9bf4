"""Exact derivatives of the inverse and direct models (issue 14, item 5).

Independent references:

- central finite differences of the reference path (``backend="pinocchio"``: Pinocchio's
  RNEA on the legs and the closure layer, no generated code), the pose moved on SO(3) as
  the chart says (``p + dp``, ``exp(dtheta^) R`` with ``pin.exp3``);
- Pinocchio's derivatives of the constrained tree, ``pin.computeConstraintDynamicsDerivatives``
  mapped to the platform state by :mod:`stewart_pin.check.dynamics_derivatives` (no code
  shared with codegen), whose mapping is itself checked here against finite differences of
  ``pin.constraintDynamics`` (:func:`constrained_forward_dynamics`);
- the time derivative of Gamma along an analytic motion (central differences in time).

Tolerance 1e-6 relative per state (the largest entry error over the largest entry of the
reference matrix), as the issue asks; central differences with the steps below are
accurate to about 1e-9 here, the Pinocchio comparison to about 1e-13.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache

from stewart_pin import StewartRobot
from stewart_pin.check.constrained_dynamics import (
    constrained_forward_dynamics,
    constrained_inverse_dynamics,
)
from stewart_pin.check.dynamics_derivatives import (
    constrained_direct_dynamics_derivatives,
    constrained_inverse_dynamics_derivatives,
)
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen import derivatives as derivatives_module
from stewart_pin.codegen.derivatives import CompiledDerivatives
from stewart_pin.exceptions import (
    CompilationError,
    InputError,
    NumericalError,
    SingularityError,
    StewartPinError,
    StrokeLimitError,
)

TOL = 1e-6  # relative, per state (the tolerance)
N_STATES = 4
#: Robots checked in CasADi's VM (the same functions as the compiled library, which is
#: built once, for the simulator, to keep the suite fast).
VM_ROBOTS = ("paper", "random-1")


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    """The session's shared cache folder (the same robots compile once for the suite)."""
    yield from use_compile_cache(shared_compile_cache)


def _vm(robot: StewartRobot) -> CompiledDerivatives:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return CompiledDerivatives(robot, compiler=False)


def _backend(name: str) -> tuple[StewartRobot, object]:
    """The robot and what computes its derivatives: the facade (compiled) for the
    simulator, the VM backend for the others."""
    robot = get_robot(name)
    if name == "simulator":
        return robot, robot
    return robot, _vm(robot)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest per-state relative error of matrices (or vectors) ``a`` against ``b``."""
    a, b = np.asarray(a), np.asarray(b)
    n = a.shape[0] if a.ndim == 3 else 1
    a, b = a.reshape(n, -1), b.reshape(n, -1)
    return float((np.abs(a - b).max(axis=1) / np.abs(b).max(axis=1)).max())


def _moved(T: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """0Tp moved by ``delta = [dp, dtheta]`` in F0: ``p + dp``, ``exp(dtheta^) R``."""
    M = T.copy()
    M[:3, 3] += delta[:3]
    M[:3, :3] = pin.exp3(delta[3:]) @ T[:3, :3]
    return M


def _central_differences(f, T, V, X, h_pose: float, h_twist: float, h_x: float):
    """Central differences of ``f(poses, twists, xs) -> (N, 6)`` at one state, with respect
    to the pose chart, the twist and the third argument: three (6, 6) matrices."""
    poses, twists, xs = [], [], []
    for which, h in ((0, h_pose), (1, h_twist), (2, h_x)):
        for k in range(6):
            for sign in (1.0, -1.0):
                e = np.zeros(6)
                e[k] = sign * h
                poses.append(_moved(T, e) if which == 0 else T)
                twists.append(V + e if which == 1 else V)
                xs.append(X + e if which == 2 else X)
    y = np.asarray(f(np.array(poses), np.array(twists), np.array(xs))).reshape(3, 6, 2, 6)
    return [(y[w, :, 0] - y[w, :, 1]).T / (2 * h) for w, h in enumerate((h_pose, h_twist, h_x))]


def _reference(method):
    """A robot method on the reference path (Pinocchio legs and the closure layer)."""
    return lambda *args: method(*args, backend="pinocchio")


def _steps(robot: StewartRobot) -> tuple[float, float]:
    size = robot.description.size
    return 1e-5 * size, 1e-4  # pose [m, rad scaled alike], twist [m/s, rad/s]


# ---------------------------------------------------------------------------- finite differences
@pytest.mark.parametrize("name", ("simulator", *VM_ROBOTS))
def test_inverse_dynamics_derivatives_equal_central_differences(name):
    robot, backend = _backend(name)
    P, V, A = robot.sample_states(N_STATES, 11)
    d = backend.inverse_dynamics_derivatives(P, V, A)
    assert d.pose.shape == d.twist.shape == d.accel.shape == (N_STATES, 6, 6)
    assert _rel(d.gamma, robot.inverse_dynamics(P, V, A, backend="pinocchio")) < 1e-10
    h_pose, h_twist = _steps(robot)
    for n in range(N_STATES):
        fd = _central_differences(robot.inverse_dynamics, P[n], V[n], A[n], h_pose, h_twist, 1.0)
        for got, ref in zip((d.pose[n], d.twist[n], d.accel[n]), fd, strict=True):
            assert _rel(got, ref) < TOL


@pytest.mark.parametrize("name", ("simulator", *VM_ROBOTS))
def test_direct_dynamics_derivatives_equal_central_differences(name):
    robot, backend = _backend(name)
    P, V, A = robot.sample_states(N_STATES, 12)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    d = backend.direct_dynamics_derivatives(P, V, G)
    assert _rel(d.accel, A) < 1e-8
    h_pose, h_twist = _steps(robot)
    h_gamma = 1e-3 * float(np.abs(G).max())  # Vdot is affine in Gamma: any step
    for n in range(N_STATES):
        fd = _central_differences(
            _reference(robot.direct_dynamics), P[n], V[n], G[n], h_pose, h_twist, h_gamma
        )
        for got, ref in zip((d.pose[n], d.twist[n], d.gamma[n]), fd, strict=True):
            assert _rel(got, ref) < TOL


# ---------------------------------------------------------------------------- Pinocchio
@pytest.mark.parametrize("name", ("simulator", *VM_ROBOTS))
def test_derivatives_equal_pinocchio_constrained_tree(name):
    robot, backend = _backend(name)
    P, V, A = robot.sample_states(N_STATES, 13)
    d = backend.inverse_dynamics_derivatives(P, V, A)
    gamma, d_pose, d_twist, d_accel = constrained_inverse_dynamics_derivatives(robot, P, V, A)
    assert _rel(d.gamma, gamma) < 1e-9
    assert _rel(d.pose, d_pose) < TOL
    assert _rel(d.twist, d_twist) < TOL
    assert _rel(d.accel, d_accel) < TOL
    dd = backend.direct_dynamics_derivatives(P, V, gamma)
    accel, d_pose, d_twist, d_gamma = constrained_direct_dynamics_derivatives(robot, P, V, gamma)
    assert _rel(dd.accel, accel) < 1e-8
    assert _rel(dd.pose, d_pose) < TOL
    assert _rel(dd.twist, d_twist) < TOL
    assert _rel(dd.gamma, d_gamma) < TOL


@pytest.mark.parametrize("name", ("simulator", "random-2"))
def test_pinocchio_mapping_equals_central_differences_of_the_tree(name):
    """The check's mapping of ``computeConstraintDynamicsDerivatives`` (with its padded
    tree) against central differences of ``pin.constraintDynamics`` itself."""
    robot = get_robot(name)
    P, V, A = robot.sample_states(2, 14)
    G = constrained_inverse_dynamics(robot, P, V, A)[0]
    accel, d_pose, d_twist, d_gamma = constrained_direct_dynamics_derivatives(robot, P, V, G)
    assert _rel(accel, A) < 1e-9
    h_pose, h_twist = _steps(robot)

    def tree(poses, twists, gammas):
        return constrained_forward_dynamics(robot, poses, twists, gammas)

    for n in range(2):
        fd = _central_differences(tree, P[n], V[n], G[n], h_pose, h_twist, 1.0)
        for got, ref in zip((d_pose[n], d_twist[n], d_gamma[n]), fd, strict=True):
            assert _rel(got, ref) < TOL


# ---------------------------------------------------------------------------- along a motion
def _motion(robot: StewartRobot, t: float):
    """An analytic motion: pose, twist ``[v, w]`` (F0) and classical acceleration at ``t``
    [s]. ``R = exp(a(t) u^) exp(b(t) k^) R0``: ``w = a' u + b' R_a k``,
    ``dw/dt = a'' u + b'' R_a k + a' b' u x (R_a k)``."""
    T0 = robot.home_pose
    amp = 0.05 * robot.description.size
    c = np.array([1.0, 0.7, 1.3])
    p = T0[:3, 3] + amp * np.sin(c * t + np.array([0.1, 0.5, 0.9]))
    v = amp * c * np.cos(c * t + np.array([0.1, 0.5, 0.9]))
    vd = -amp * c**2 * np.sin(c * t + np.array([0.1, 0.5, 0.9]))
    u = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    k = np.array([0.0, -0.6, 0.8])
    a, ad, add = 0.1 * np.sin(1.1 * t), 0.11 * np.cos(1.1 * t), -0.121 * np.sin(1.1 * t)
    b, bd, bdd = 0.08 * np.cos(0.9 * t), -0.072 * np.sin(0.9 * t), -0.0648 * np.cos(0.9 * t)
    Ra, Rb = pin.exp3(a * u), pin.exp3(b * k)
    T = np.eye(4)
    T[:3, :3] = Ra @ Rb @ T0[:3, :3]
    T[:3, 3] = p
    Rak = Ra @ k
    w = ad * u + bd * Rak
    wd = add * u + bdd * Rak + ad * bd * np.cross(u, Rak)
    return T, np.concatenate([v, w]), np.concatenate([vd, wd])


def test_gamma_rate_along_a_motion_is_the_chain_rule():
    """``dGamma/dt = D.pose @ V + D.twist @ Vdot + D.accel @ jerk`` and
    ``jerk = DDM.pose @ V + DDM.twist @ Vdot + DDM.gamma @ dGamma/dt`` on a motion, the
    time derivatives by central differences in time."""
    robot = get_robot("simulator")
    h = 1e-4  # [s]
    for t in (0.3, 1.7, 4.2):
        T, V, Vd = _motion(robot, t)
        T1, V1, A1 = _motion(robot, t + h)
        T0, V0, A0 = _motion(robot, t - h)
        assert np.allclose((V1 - V0) / (2 * h), Vd, rtol=0, atol=1e-7)  # the motion itself
        jerk = (A1 - A0) / (2 * h)
        idm = _reference(robot.inverse_dynamics)
        gamma_rate = (idm(T1, V1, A1) - idm(T0, V0, A0)) / (2 * h)
        d = robot.inverse_dynamics_derivatives(T, V, Vd)
        chain = d.pose @ V + d.twist @ Vd + d.accel @ jerk
        assert np.abs(chain - gamma_rate).max() < TOL * np.abs(gamma_rate).max()
        dd = robot.direct_dynamics_derivatives(T, V, d.gamma)
        jerk_chain = dd.pose @ V + dd.twist @ Vd + dd.gamma @ gamma_rate
        assert np.abs(jerk_chain - jerk).max() < TOL * np.abs(jerk).max()


# ---------------------------------------------------------------------------- calls and errors
def test_single_state_threads_and_vm_agree():
    robot = get_robot("simulator")
    n = 2 * derivatives_module.THREAD_MIN_STATES + 5
    P, V, A = robot.sample_states(n, 15)
    one = CompiledDerivatives(robot, threads=1)
    two = CompiledDerivatives(robot, threads=2)
    assert one.kind == two.kind == "compiled" and not two.compiled_now  # found in the cache
    d1, d2 = one.inverse_dynamics_derivatives(P, V, A), two.inverse_dynamics_derivatives(P, V, A)
    for x in ("gamma", "pose", "twist", "accel"):
        np.testing.assert_array_equal(getattr(d1, x), getattr(d2, x))
    single = robot.inverse_dynamics_derivatives(P[7], V[7], A[7])
    assert single.pose.shape == (6, 6) and single.gamma.shape == (6,)
    np.testing.assert_array_equal(single.pose, d2.pose[7])
    se3 = robot.inverse_dynamics_derivatives(pin.SE3(P[7]), list(V[7]), A[7].astype(np.float32))
    assert _rel(se3.pose, d2.pose[7]) < 1e-6  # float32 accel: rounded input
    vm = _vm(robot)
    dv = vm.direct_dynamics_derivatives(P[:5], V[:5], d2.gamma[:5])
    dc = two.direct_dynamics_derivatives(P[:5], V[:5], d2.gamma[:5])
    for x in ("accel", "pose", "twist", "gamma"):
        assert _rel(getattr(dv, x), getattr(dc, x)) < 1e-12


def test_derivatives_raise_the_value_models_errors():
    robot = get_robot("simulator")
    P, V, A = robot.sample_states(3, 16)
    P = P.copy()
    P[2, 2, 3] += 10.0  # legs far too long
    with pytest.raises(StrokeLimitError) as ref:
        robot.inverse_dynamics(P, V, A, backend="pinocchio")
    with pytest.raises(StrokeLimitError) as got:
        robot.inverse_dynamics_derivatives(P, V, A)
    assert str(got.value) == str(ref.value)
    with pytest.raises(InputError, match="twist"):
        robot.direct_dynamics_derivatives(P[0], V[0, :5], A[0])
    bad = V[0].copy()
    bad[1] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        robot.inverse_dynamics_derivatives(P[0], bad, A[0])


def test_derivatives_raise_at_a_singularity():
    robot = get_robot("simulator")
    tight = StewartRobot(robot.description, max_condition=1.0001)  # every pose "singular"
    P, V, A = robot.sample_states(1, 17)
    with pytest.raises(SingularityError):
        tight.inverse_dynamics_derivatives(P[0], V[0], A[0])
    with pytest.raises(SingularityError):
        tight.direct_dynamics_derivatives(P[0], V[0], A[0])


def test_non_finite_derivative_raises_numerical_error():
    """The C loop's flag: a state whose Jacobians are not finite (here a NaN slipped past
    the value model, which the public methods never let through) names its index."""
    robot = get_robot("simulator")
    backend = derivatives_module.derivatives_backend(robot)
    P, V, A = robot.sample_states(3, 18)
    V = V.copy()
    V[1, 4] = np.inf
    with pytest.raises(NumericalError, match="state 1") as e:
        backend._run("idm", P, V, A, "accel", None)
    assert e.value.index == 1 and e.value.n_bad == 1


# ---------------------------------------------------------------------------- general legs
#: Robots with general legs: ``rus`` through its compiled library (one build, in the
#: session's shared cache), the others in CasADi's VM (the same functions, no compile).
GENERAL_ROBOTS = ("rus", "pus", "ups-offset", "random-custom-0")


@pytest.fixture(scope="module")
def general_backends(shared_compile_cache) -> dict[str, object]:
    """The robots' derivative backends; ``rus``'s is the facade's own (built in the shared
    cache, where the value library may already be)."""
    backends: dict[str, object] = {}
    for name in GENERAL_ROBOTS:
        robot = get_robot(name)
        if name == "rus":
            with pytest.MonkeyPatch.context() as mp:
                mp.setenv(compiled_module.CACHE_ENV, str(shared_compile_cache))
                backends[name] = derivatives_module.derivatives_backend(robot)
            assert backends[name].kind == "compiled"
        else:
            backends[name] = _vm(robot)
    return backends


def _check_general(robot, d, P, V, X, which: str) -> None:
    """Each state's three Jacobians (``d`` of the states ``P, V, X``, (N, ...) arrays)
    against central differences of the reference path."""
    method = robot.inverse_dynamics if which == "idm" else robot.direct_dynamics
    h_pose, h_twist = _steps(robot)
    # a quarter of the pose step: the truncation error (2e-7 at the full step on rus and
    # random-custom-0, shrinking as h^2) well under the tolerance
    h_pose *= 0.25
    h_x = 1.0 if which == "idm" else 1e-3 * float(np.abs(X).max())  # affine: any step
    third = "accel" if which == "idm" else "gamma"
    blocks = [np.reshape(getattr(d, k), (-1, 6, 6)) for k in ("pose", "twist", third)]
    for n in range(P.shape[0]):
        fd = _central_differences(_reference(method), P[n], V[n], X[n], h_pose, h_twist, h_x)
        for got, ref in zip((b[n] for b in blocks), fd, strict=True):
            assert _rel(got, ref) < TOL


@pytest.mark.parametrize("name", GENERAL_ROBOTS)
def test_general_legs_inverse_dynamics_derivatives_equal_central_differences(
    name, general_backends
):
    robot, backend = get_robot(name), general_backends[name]
    P, V, A = robot.sample_states(3, 31)
    d = backend.inverse_dynamics_derivatives(P, V, A)  # a batch
    assert d.pose.shape == d.twist.shape == d.accel.shape == (3, 6, 6)
    assert _rel(d.gamma, robot.inverse_dynamics(P, V, A, backend="pinocchio")) < 1e-9
    _check_general(robot, d, P, V, A, "idm")
    one = backend.inverse_dynamics_derivatives(P[1], V[1], A[1])  # a single state
    assert one.pose.shape == (6, 6)
    _check_general(robot, one, P[1:2], V[1:2], A[1:2], "idm")


@pytest.mark.parametrize("name", GENERAL_ROBOTS)
def test_general_legs_direct_dynamics_derivatives_equal_central_differences(
    name, general_backends
):
    robot, backend = get_robot(name), general_backends[name]
    P, V, A = robot.sample_states(3, 32)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    d = backend.direct_dynamics_derivatives(P, V, G)
    assert d.pose.shape == d.twist.shape == d.gamma.shape == (3, 6, 6)
    assert _rel(d.accel, A) < 1e-8
    _check_general(robot, d, P, V, G, "ddm")
    one = backend.direct_dynamics_derivatives(P[2], V[2], G[2])
    assert one.gamma.shape == (6, 6)
    _check_general(robot, one, P[2:3], V[2:3], G[2:3], "ddm")


def test_general_legs_derivatives_keep_the_guards(general_backends):
    """The value model is evaluated first: a state out of reach raises the reference's
    error, and general legs take no ``base_values`` (their parameters are built in)."""
    robot, backend = get_robot("rus"), general_backends["rus"]
    P, V, A = robot.sample_states(1, 33)
    far = P[0].copy()
    far[2, 3] += 10.0 * robot.description.size
    with pytest.raises(StewartPinError) as ref:
        robot.inverse_dynamics(far, V[0], A[0], backend="pinocchio")
    with pytest.raises(type(ref.value)):
        backend.inverse_dynamics_derivatives(far, V[0], A[0])
    with pytest.raises(InputError, match="base_values"):
        backend.inverse_dynamics_derivatives(P[0], V[0], A[0], base_values=np.zeros(0))


def test_facade_derivatives_of_general_legs(general_backends):
    """``robot.inverse_dynamics_derivatives`` / ``direct_dynamics_derivatives`` no longer
    refuse general legs: the facade (compiled) gives what the VM gives."""
    robot = get_robot("rus")
    P, V, A = robot.sample_states(2, 34)
    d = robot.inverse_dynamics_derivatives(P, V, A)
    vm = _vm(robot)
    ref = vm.inverse_dynamics_derivatives(P, V, A)
    for x in ("gamma", "pose", "twist", "accel"):
        assert _rel(getattr(d, x), getattr(ref, x)) < 1e-12
    e = robot.direct_dynamics_derivatives(P[0], V[0], d.gamma[0])
    e_ref = vm.direct_dynamics_derivatives(P[0], V[0], d.gamma[0])
    for x in ("accel", "pose", "twist", "gamma"):
        assert _rel(getattr(e, x), getattr(e_ref, x)) < 1e-12


def test_derivative_library_follows_the_cache_rules(tmp_path, monkeypatch):
    """The derivative library goes through the value library's cache: a second
    construction loads it (no compilation), and a replaced library is detected by its
    manifest and rebuilt (the rebuild made to fail here: the VM takes over, with warnings;
    a real rebuild is :mod:`tests.test_codegen_cache`'s business)."""
    robot = get_robot("simulator")
    built = derivatives_module.derivatives_backend(robot)
    assert built.kind == "compiled" and built.library is not None
    folder = built.library.parent
    meta = json.loads((folder / "manifest.json").read_text())
    assert meta["key"] == folder.name
    assert "sp_idm_derivatives_batch" in (folder / "stewart_models.c").read_text()
    root = tmp_path / "cache"
    root.mkdir(mode=0o700)
    shutil.copytree(folder, root / folder.name)
    hit = CompiledDerivatives(robot, cache_dir=root)
    assert hit.kind == "compiled" and not hit.compiled_now
    assert hit.library == root / folder.name / built.library.name
    # replaced, not overwritten in place: this process has the library mapped, and
    # truncating a mapped file kills the process with SIGBUS when its pages are touched
    replacement = hit.library.with_name(hit.library.name + ".new")
    replacement.write_bytes(b"not a library")
    replacement.replace(hit.library)

    def failing_build(*args, **kwargs):
        raise CompilationError("no rebuild in this test")

    monkeypatch.setattr(compiled_module, "_build", failing_build)
    monkeypatch.setattr(derivatives_module, "_WARNED", set())
    with pytest.warns(RuntimeWarning) as record:
        vm = CompiledDerivatives(robot, cache_dir=root)
    messages = " | ".join(str(w.message) for w in record)
    assert "does not match its manifest" in messages
    assert "no rebuild in this test" in messages
    assert vm.kind == "vm"
    P, V, A = robot.sample_states(2, 20)
    ref = built.inverse_dynamics_derivatives(P, V, A)
    assert _rel(vm.inverse_dynamics_derivatives(P, V, A).pose, ref.pose) < 1e-12


def test_derivatives_take_base_values_checked():
    """``base_values`` reach the derivatives (single state and batch): Gamma is linear in
    the base parameters, so twice the robot's values give twice its Jacobians (an
    independent property of the model, not its code); a wrong size is an InputError."""
    robot = get_robot("simulator")
    backend = derivatives_module.derivatives_backend(robot)
    chi = np.asarray(compiled_module.compiled_backend(robot).base_values)
    P, V, A = robot.sample_states(3, 21)
    ref = backend.inverse_dynamics_derivatives(P, V, A)
    doubled = backend.inverse_dynamics_derivatives(P, V, A, base_values=2.0 * chi)
    one = backend.inverse_dynamics_derivatives(P[1], V[1], A[1], base_values=2.0 * chi)
    for x in ("gamma", "pose", "twist", "accel"):
        assert _rel(getattr(doubled, x), 2.0 * getattr(ref, x)) < 1e-13
        assert _rel(getattr(one, x), 2.0 * getattr(ref, x)[1]) < 1e-13
    with pytest.raises(InputError, match="base_values"):
        backend.inverse_dynamics_derivatives(P, V, A, base_values=chi[:10])
    with pytest.raises(InputError, match="base_values"):
        backend.direct_dynamics_derivatives(P[0], V[0], ref.gamma[0], base_values=np.nan * chi)


def test_first_build_is_announced_and_a_second_process_reuses_it(tmp_path, capsys):
    """The first use compiles the derivative library (quick flags) and says so in one line
    on stderr with its expected duration; a new process finds it in the cache (nothing
    compiled, nothing announced) and gives the same derivatives."""
    robot = get_robot("simulator")
    root = tmp_path / "cache"
    built = CompiledDerivatives(robot, cache_dir=root)
    err = capsys.readouterr().err
    assert built.kind == "compiled" and built.compiled_now
    lines = [ln for ln in err.splitlines() if "the exact derivatives of robot" in ln]
    assert len(lines) == 1 and lines[0].startswith("stewart-pin: compiling")
    assert re.search(r"about \d+ s", lines[0])
    meta = json.loads((built.library.parent / "manifest.json").read_text())
    assert meta["cflags"] == list(compiled_module.QUICK_CFLAGS)
    P, V, A = robot.sample_states(2, 40)
    ref = built.inverse_dynamics_derivatives(P, V, A)
    program = (
        "import sys, numpy as np\n"
        "from stewart_pin import StewartRobot\n"
        "from stewart_pin.codegen.derivatives import CompiledDerivatives\n"
        "robot = StewartRobot.from_preset('simulator')\n"
        "d = CompiledDerivatives(robot, cache_dir=sys.argv[1])\n"
        "P, V, A = robot.sample_states(2, 40)\n"
        "np.save(sys.argv[2], d.inverse_dynamics_derivatives(P, V, A).pose)\n"
        "print(d.kind, d.compiled_now, d.library)\n"
    )
    out = tmp_path / "pose.npy"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run(
        [sys.executable, "-c", program, str(root), str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["compiled", "False", str(built.library)], run.stderr
    assert "compiling" not in run.stderr
    np.testing.assert_array_equal(np.load(out), ref.pose)
