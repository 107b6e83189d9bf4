"""The generated models (stewart_pin.codegen): symbolic, compiled and VM paths against the
reference path (Pinocchio leg dynamics + closure layer), operation counts, the cache, the
fallback, and the errors. No timing assertions."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.codegen import (
    CompiledDynamics,
    compiled_backend,
    cost_dict,
    cost_table,
    count_operations,
    generate_models,
)
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.symbolic import AUX_IDM_GROWTH
from stewart_pin.dynamics.regressor import with_standard_parameters
from stewart_pin.exceptions import (
    InputError,
    JointLimitError,
    SingularityError,
    StrokeLimitError,
)
from stewart_pin.kinematics.workspace import sample_states
from stewart_pin.parameters.base import analytic_base_parameters

ROBOTS = ("simulator", "paper", "random-1")
TOL = 1e-10  # relative to the largest value of the batch


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    """The session's shared cache folder (the same robots compile once for the suite)."""
    yield from use_compile_cache(shared_compile_cache)


@pytest.fixture(scope="module")
def states() -> dict[str, tuple[np.ndarray, ...]]:
    """200 random states per robot with the reference IDM."""
    out = {}
    for name in ROBOTS:
        robot = get_robot(name)
        P, V, A = sample_states(robot.description, 200, 11)
        out[name] = (P, V, A, robot.inverse_dynamics(P, V, A))
    return out


@pytest.fixture(scope="module")
def backends(cache_dir) -> dict[str, CompiledDynamics]:
    return {name: CompiledDynamics(get_robot(name)) for name in ROBOTS}


# ------------------------------------------------------------------ agreement
@pytest.mark.parametrize("name", ROBOTS)
def test_compiled_matches_reference(name, backends, states):
    backend, robot = backends[name], get_robot(name)
    assert backend.kind == "compiled", backend.reason
    P, V, A, G = states[name]
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    acc_ref = robot.direct_dynamics(P, V, G)
    assert rel_error(backend.direct_dynamics(P, V, G), acc_ref) < TOL
    assert rel_error(backend.direct_dynamics(P, V, G), A) < 1e-9  # DDM(IDM(x)) == x
    for k in range(3):  # one state at a time, (6,) results
        g = backend.inverse_dynamics(P[k], V[k], A[k])
        assert g.shape == (6,)
        assert rel_error(g, G[k]) < TOL
        a = backend.direct_dynamics(P[k], V[k], G[k])
        assert a.shape == (6,)
        assert rel_error(a, acc_ref[k]) < TOL
    # Lists, float32 and non-contiguous inputs take the general path.
    g = backend.inverse_dynamics(P[0].tolist(), list(V[0]), tuple(A[0]))
    assert rel_error(g, G[0]) < TOL
    g = backend.inverse_dynamics(np.asfortranarray(P[:5]), V[:5, ::1], A[:5])
    assert rel_error(g, G[:5]) < TOL
    g = backend.inverse_dynamics(P[:1], V[:1], A[:1])  # a batch of one
    assert g.shape == (1, 6)
    assert rel_error(g, G[:1]) < TOL
    se3 = [pin.SE3(T[:3, :3], T[:3, 3]) for T in P[:3]]
    assert rel_error(backend.inverse_dynamics(se3[0], V[0], A[0]), G[0]) < TOL
    assert rel_error(backend.inverse_dynamics(se3, V[:3], A[:3]), G[:3]) < TOL


def test_joint_limits_are_checked(states, cache_dir):
    """The guard checks the U-joint angles (issue 19): a robot with limits raises the
    reference's JointLimitError, and computes within them. (Its library is its own: the cache
    key is the description, limits included, not the generated source, issue 24.)"""
    desc = get_robot("random-1").description
    P, V, A, G = (x[:10] for x in states["random-1"])
    q = get_robot("random-1").inverse_geometry(P)
    lo, hi = q[..., :2].min(axis=0), q[..., :2].max(axis=0)
    wide = StewartRobot(desc.replace(u_joint_limits=np.stack([lo - 0.1, hi + 0.1], -1)))
    backend = compiled_backend(wide)
    assert backend.kind == "compiled"
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    narrow = StewartRobot(
        wide.description.replace(u_joint_limits=np.stack([lo + 1e-3, hi + 0.1], -1))
    )
    backend = CompiledDynamics(narrow)
    _same_error(
        lambda: backend.inverse_dynamics(P, V, A),
        lambda: narrow.inverse_dynamics(P, V, A),
        JointLimitError,
    )


@pytest.mark.parametrize("name", ROBOTS)
def test_vm_fallback_without_compiler(name, states, monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setattr(compiled_module.shutil, "which", lambda _: None)
    monkeypatch.setattr(compiled_module, "_WARNED", set())
    with pytest.warns(RuntimeWarning, match="no C compiler"):
        backend = CompiledDynamics(get_robot(name))
    assert backend.kind == "vm"
    assert "no C compiler" in backend.reason
    P, V, A, G = (x[:40] for x in states[name])
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    assert rel_error(backend.inverse_dynamics(P[0], V[0], A[0]), G[0]) < TOL
    acc = get_robot(name).direct_dynamics(P, V, G)
    assert rel_error(backend.direct_dynamics(P, V, G), acc) < TOL
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # warned once only
        CompiledDynamics(get_robot(name))


def test_failed_compilation_falls_back(tmp_path, monkeypatch, states):
    monkeypatch.setattr(compiled_module, "_WARNED", set())
    with pytest.warns(RuntimeWarning, match="failed"):
        backend = CompiledDynamics(get_robot("paper"), cache_dir=tmp_path, compiler="false")
    assert backend.kind == "vm"
    P, V, A, G = (x[:5] for x in states["paper"])
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL


def test_cache_is_reused(backends, cache_dir):
    first = backends["paper"]
    assert first.library is not None and first.library.parent.parent == cache_dir
    mtime = os.path.getmtime(first.library)
    second = CompiledDynamics(get_robot("paper"))
    assert second.kind == "compiled"
    assert not second.compiled_now
    assert second.library == first.library
    assert os.path.getmtime(second.library) == mtime
    # Another robot object with the same description shares the library.
    twin = StewartRobot(get_robot("paper").description)
    assert compiled_backend(twin).library == first.library
    assert compiled_backend(twin) is compiled_backend(twin)


def test_base_values_are_an_input(backends, states):
    """Identified (here: other) base parameters need no recompilation."""
    robot = get_robot("random-1")
    desc = robot.description
    rng = np.random.default_rng(5)
    other = desc.replace(
        leg_inertia=desc.leg_inertia * rng.uniform(0.8, 1.2, (6, 3, 1)),
        platform_inertia=desc.platform_inertia * 1.1,
    )
    chi = np.concatenate([other.leg_inertia.ravel(), other.platform_inertia])
    assert with_standard_parameters(desc, chi).leg_inertia.shape == (6, 3, 10)
    values = analytic_base_parameters(other).values
    P, V, A, _ = states["random-1"]
    ref = StewartRobot(other).inverse_dynamics(P[:20], V[:20], A[:20])
    backend = backends["random-1"]
    assert (
        rel_error(backend.inverse_dynamics(P[:20], V[:20], A[:20], base_values=values), ref) < TOL
    )
    assert rel_error(backend.inverse_dynamics(P[0], V[0], A[0], base_values=values), ref[0]) < TOL
    acc = backend.direct_dynamics(P[:20], V[:20], ref, base_values=values)
    assert rel_error(acc, A[:20]) < 1e-9
    with pytest.raises(InputError, match="base_values"):
        backend.inverse_dynamics(P[0], V[0], A[0], base_values=values[:10])


def test_static_pivot_growth_is_solved_again(backends):
    """A pose far from home where the generated LU's static pivots grow (multiplier > 16):
    the C guard solves that state again with partial pivoting."""
    robot = get_robot("random-1")
    T = np.eye(4)
    T[:3] = [
        [0.9460648375552638, -0.21880346741504367, 0.2389275325044944, -0.17080838391682096],
        [0.30078291099534227, 0.8672190873441238, -0.39681317392343834, 0.16633685487777328],
        [-0.12037841830951412, 0.4472763096713025, 0.8862578288580141, 0.6149335671891982],
    ]
    m = generate_models(robot.description)
    V, A = np.array([0.1, -0.2, 0.05, 0.3, -0.1, 0.2]), np.array([1.0, 0.5, -2.0, 1.0, 2.0, -1])
    _, aux = m.idm_guarded(T.reshape(16), V, A, m.constants.parameter_values)
    assert float(aux[AUX_IDM_GROWTH]) > compiled_module.GROWTH_LIMIT
    ref = robot.inverse_dynamics(T, V, A)
    assert rel_error(backends["random-1"].inverse_dynamics(T, V, A), ref) < TOL


def test_stream(backends, states):
    P, V, A, G = states["simulator"]
    chunks = ((P[s : s + 64], V[s : s + 64], A[s : s + 64]) for s in range(0, 200, 64))
    out = np.concatenate(list(backends["simulator"].inverse_dynamics_stream(chunks)))
    assert rel_error(out, G) < TOL
    accs = backends["simulator"].direct_dynamics_stream([(P, V, G)])
    assert rel_error(next(iter(accs)), A) < 1e-9


# ------------------------------------------------------------------ errors
def _same_error(call_a, call_b, error):
    with pytest.raises(error) as a:
        call_a()
    with pytest.raises(error) as b:
        call_b()
    assert str(a.value) == str(b.value)


@pytest.mark.parametrize("kind", ["compiled", "vm"])
def test_bad_inputs_raise_like_the_reference(kind, backends, states, monkeypatch):
    monkeypatch.setattr(compiled_module, "_WARNED", set())
    robot = get_robot("simulator")
    if kind == "compiled":
        backend = backends["simulator"]
    else:
        with pytest.warns(RuntimeWarning):
            backend = CompiledDynamics(robot, compiler=False)
    P, V, A, G = (x[:10].copy() for x in states["simulator"])
    cases = []
    bad = P.copy()
    bad[3, 0, 1] = np.nan
    cases.append((bad, V, A, InputError))
    cases.append((bad[3], V[3], A[3], InputError))
    bad = P.copy()
    bad[2, :3, :3] *= 1.001  # not orthonormal
    cases.append((bad, V, A, InputError))
    bad = P.copy()
    bad[4, 3, 3] = 2.0  # last row
    cases.append((bad, V, A, InputError))
    badV = V.copy()
    badV[5, 2] = np.inf
    cases.append((P, badV, A, InputError))
    cases.append((P, V[:9], A, InputError))  # batch sizes differ
    cases.append((P[0], V, A[0], InputError))  # one pose, a batch of twists
    cases.append((P[0], V[0, :5], A[0], InputError))
    cases.append((P[0], "twist", A[0], InputError))
    far = P.copy()
    far[6, 2, 3] += 5.0  # beyond the stroke
    cases.append((far, V, A, StrokeLimitError))
    cases.append((far[6], V[6], A[6], StrokeLimitError))
    cases.append((far[6:7], V[6:7], A[6:7], StrokeLimitError))  # a batch of one
    cases.append((bad[4:5], V[4:5], A[4:5], InputError))
    for pose, twist, x, error in cases:
        _same_error(
            lambda pose=pose, twist=twist, x=x: backend.inverse_dynamics(pose, twist, x),
            lambda pose=pose, twist=twist, x=x: robot.inverse_dynamics(pose, twist, x),
            error,
        )
        if twist is V and x is A and pose.ndim == 3:
            _same_error(
                lambda pose=pose: backend.direct_dynamics(pose, V, G),
                lambda pose=pose: robot.direct_dynamics(pose, V, G),
                error,
            )


def test_singular_poses_raise(states):
    """A robot whose threshold declares every pose singular (cond(Jp^-1) >= 1)."""
    desc = get_robot("paper").description
    strict = StewartRobot(desc, max_condition=1.0)
    backend = compiled_backend(strict)
    assert backend.kind == "compiled"
    P, V, A, G = (x[:4] for x in states["paper"])
    _same_error(
        lambda: backend.inverse_dynamics(P, V, A),
        lambda: strict.inverse_dynamics(P, V, A),
        SingularityError,
    )
    _same_error(
        lambda: backend.direct_dynamics(P[1], V[1], G[1]),
        lambda: strict.direct_dynamics(P[1], V[1], G[1]),
        SingularityError,
    )
    # The guard's bound flags states the exact check then accepts: no error.
    loose = StewartRobot(desc, max_condition=float(np.max(strict.condition_number(P))) * 1.5)
    assert rel_error(compiled_backend(loose).inverse_dynamics(P, V, A), G) < TOL


# ------------------------------------------------------------------ symbolic variants
def test_variants_and_stages(states):
    robot = get_robot("paper")
    P, V, A, G = (x[:20] for x in states["paper"])
    n = len(P)
    base = generate_models(robot.description)
    chi = base.constants.parameter_values
    # Quaternion pose input [x, y, z, qx, qy, qz, qw].
    q = np.array([np.r_[T[:3, 3], pin.Quaternion(T[:3, :3]).coeffs()] for T in P])
    quat = generate_models(robot.description, pose="quaternion")
    assert rel_error(np.array(quat.idm(q.T, V.T, A.T, chi)).T, G) < TOL
    # Values baked in.
    num = generate_models(robot.description, parameters="numeric")
    assert rel_error(np.array(num.idm(P.reshape(n, 16).T, V.T, A.T, 0 * chi)).T, G) < TOL
    # Essential parameters: the base model with the other 36 set to zero.
    ess = generate_models(robot.description, parameters="essential")
    kept = np.array([float(not ess_name_zero(nm)) for nm in base.constants.parameter_names])
    g_ess = np.array(ess.idm(P.reshape(n, 16).T, V.T, A.T, chi)).T
    g_base = np.array(base.idm(P.reshape(n, 16).T, V.T, A.T, chi * kept)).T
    assert rel_error(g_ess, g_base) < TOL
    # The stages composed give the flat models.
    s = base.idm_stages
    K, vdg = s.shared(V.T, A.T)
    legs = [f(P.reshape(n, 16).T, V.T, K, vdg, chi) for f in s.legs]
    rows = np.vstack([np.array(lg[0]) for lg in legs])
    wrenches = np.vstack([np.array(lg[1]) for lg in legs])
    Hz = np.vstack([np.array(lg[2]) for lg in legs])
    F_p = s.platform(P.reshape(n, 16).T, V.T, A.T, K, vdg, chi)
    assert rel_error(np.array(s.closure(rows, wrenches, Hz, F_p)).T, G) < TOL
    d = base.ddm_stages
    dlegs = [f(P.reshape(n, 16).T, V.T, G[None, :, k], chi) for k, f in enumerate(d.legs)]
    parts = [np.vstack([np.array(lg[j]) for lg in dlegs]) for j in range(3)]
    Ip, hp = d.platform(P.reshape(n, 16).T, V.T, chi)
    assert rel_error(np.array(d.closure(*parts, Ip, hp)).T, A) < 1e-9


def ess_name_zero(name: str) -> bool:
    from stewart_pin.parameters.base import PAPER_ESSENTIAL_PER_LEG

    if name.endswith("_RP"):
        return False
    return name.rsplit("_", 1)[0] not in PAPER_ESSENTIAL_PER_LEG


# ------------------------------------------------------------------ operation counts
def test_operation_counts():
    d = cost_dict(get_robot("paper"))
    for model in ("IDM", "DDM"):
        for key in ("base", "essential", "quaternion", "numeric", "critical_path"):
            c = d[model][key]
            assert all(isinstance(v, int) and v >= 0 for v in c.values())
            assert c["mul"] > 0 and c["add"] > 0 and c["trig"] == 0
        assert d[model]["critical_path"]["total"] < d[model]["base"]["total"]
    # The paper's frame placement and its essential parameters: at or below Table IV.
    assert d["IDM"]["essential"]["total"] <= 2078
    assert d["DDM"]["essential"]["total"] <= 2943
    text = cost_table(get_robot("paper"))
    assert "Table IV" in text and "critical path" in text and "2078" in text
    m = generate_models(get_robot("paper").description)
    assert count_operations(m.idm).total == d["IDM"]["base"]["total"]
