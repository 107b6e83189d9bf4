"""Compiled closed-form models of general legs (issue 14, item 2): the generated IDM and DDM
of every architecture and joint model (:mod:`stewart_pin.codegen.leg_chain_symbolic`) against
the reference path (Pinocchio's RNEA and CRBA on the leg chains, joint terms, the closure
layer: ``backend="pinocchio"``), which shares no algebra with them; the same errors as the
reference; the 6-UPS hand-derived path kept; operation counts per architecture. No timing
assertions.

Tolerances (relative to the largest value of the batch, :func:`helpers.rel_error`):

- IDM: :data:`TOL` = 1e-12.
- DDM: the acceleration put back through the *reference* IDM gives the forces to
  :data:`TOL` (the backward error: the compiled acceleration satisfies the reference's
  equations of motion), and the acceleration itself agrees to :data:`DDM_TOL`. The
  forward figure is looser because the direct model subtracts nearly equal forces
  (those that hold the robot up and the bias): the reference's own round trip
  ``DDM(IDM(a))`` comes back to ``a`` only to about 1e-12 on the ``rus`` preset
  (measured 1.1e-12), and the two paths round differently.
- Custom legs: the reference solves each leg's inverse geometry by Newton's method until
  the tip is within 1e-13 m (``LEG_TOLERANCE``), which leaves up to about 1e-11 in the
  forces at some states; the compiled model iterates on to the round-off. They are
  compared with the reference's Newton tolerance tightened to 1e-15 m (and at the default
  tolerance, to 1e-10).
"""

from __future__ import annotations

import math
import shutil
import warnings
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.cli import main
from stewart_pin.codegen import CompiledDynamics, cost_dict, count_operations, generate_models
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.compiled import THREAD_MIN_STATES, build_library, c_source
from stewart_pin.codegen.leg_chain_symbolic import NEWTON_ITERATIONS, build_general_models
from stewart_pin.codegen.opcount import architecture_dict, architecture_table, cost_table
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.description.leg_chain_presets import random_hexapod
from stewart_pin.exceptions import (
    InputError,
    LegJointLimitError,
    LegReachError,
    NumericalError,
    SingularityError,
    StewartPinError,
)
from stewart_pin.kinematics import leg_chains

TOL = 1e-12
DDM_TOL = 1e-10
#: Every architecture with every joint term (``random-<kind>-0``), and the named presets.
RANDOM = tuple(f"random-{k}-0" for k in ("ups", "ups-offset", "rus", "pus", "custom"))
PRESETS = ("ups-offset", "rus", "pus")
ROBOTS = RANDOM + PRESETS


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)


_BACKENDS: dict[str, CompiledDynamics] = {}


def backend_of(name: str) -> CompiledDynamics:
    if name not in _BACKENDS:
        _BACKENDS[name] = CompiledDynamics(get_robot(name))
        assert _BACKENDS[name].kind == "compiled", _BACKENDS[name].reason
    return _BACKENDS[name]


@pytest.fixture
def tight_newton(monkeypatch):
    """The reference's Newton tolerance on a custom leg's tip tightened from 1e-13 m to
    1e-15 m (see the module docstring)."""
    tol, iterations, index = leg_chains.solve_leg.__defaults__
    assert tol == leg_chains.LEG_TOLERANCE
    monkeypatch.setattr(leg_chains.solve_leg, "__defaults__", (1e-15, iterations, index))


def _states(name: str, n: int = 60, seed: int = 5):
    robot = get_robot(name)
    P, V, A = robot.sample_states(n, seed)
    return robot, P, V, A


# ---------------------------------------------------------------------------- agreement
@pytest.mark.parametrize("name", ROBOTS)
def test_compiled_general_idm_and_ddm_equal_the_reference(name, tight_newton):
    backend = backend_of(name)
    robot, P, V, A = _states(name)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    acc_ref = robot.direct_dynamics(P, V, G, backend="pinocchio")
    acc = backend.direct_dynamics(P, V, G)
    back = robot.inverse_dynamics(P, V, acc, backend="pinocchio")
    assert rel_error(back, G) < TOL  # backward error of the compiled DDM
    assert rel_error(acc, acc_ref) < DDM_TOL
    for k in range(3):  # one state at a time, (6,) results, through the C entry
        g = backend.inverse_dynamics(P[k], V[k], A[k])
        assert g.shape == (6,) and rel_error(g, G[k]) < TOL
        a = backend.direct_dynamics(P[k], V[k], G[k])
        assert a.shape == (6,) and rel_error(a, acc_ref[k]) < DDM_TOL
    # A batch of one, lists and SE3 take their own paths.
    assert rel_error(backend.inverse_dynamics(P[:1], V[:1], A[:1]), G[:1]) < TOL
    assert rel_error(backend.inverse_dynamics(P[0].tolist(), list(V[0]), A[0]), G[0]) < TOL
    se3 = pin.SE3(P[1][:3, :3], P[1][:3, 3])
    assert rel_error(backend.inverse_dynamics(se3, V[1], A[1]), G[1]) < TOL


def test_custom_legs_at_the_references_own_newton_tolerance():
    """Without tightening: the reference stops within 1e-13 m of the tip (module
    docstring), the compiled Newton iterates to the round-off."""
    backend = backend_of("random-custom-0")
    robot, P, V, A = _states("random-custom-0", 200)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < 1e-10


def test_the_robot_facade_serves_general_legs_compiled():
    """``backend="compiled"`` on general legs (it used to be refused), with ``motor``: the
    motor side through each actuated joint's gear or screw."""
    robot, P, V, A = _states("random-rus-0", 20)
    ref = robot.inverse_dynamics(P, V, A, backend="pinocchio", motor=True)
    assert rel_error(robot.inverse_dynamics(P, V, A, backend="compiled", motor=True), ref) < TOL
    joint = robot.inverse_dynamics(P, V, A, backend="compiled")
    assert not np.allclose(joint, ref)  # the transmissions make a difference here
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    acc = robot.direct_dynamics(P, V, G, backend="compiled")
    assert rel_error(acc, robot.direct_dynamics(P, V, G, backend="pinocchio")) < DDM_TOL


def test_general_path_takes_the_ideal_6ups_as_ups_legs():
    """The generic models handle ``ups`` legs: on the paper's ideal 6-UPS robot they equal
    its hand-derived closed forms (which the compiled backend keeps for that robot)."""
    robot, P, V, A = _states("simulator", 40)
    general, _ = build_general_models(robot.description)
    hand = generate_models(robot.description, parameters="numeric")
    args = (P.reshape(-1, 16).T, V.T, A.T)
    g_general = np.array(general.idm(*args, np.zeros(0))).T
    g_hand = np.array(hand.idm(*args, hand.constants.parameter_values)).T
    assert rel_error(g_general, g_hand) < TOL
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(g_general, G) < TOL
    a = np.array(general.ddm(P.reshape(-1, 16).T, V.T, G.T, np.zeros(0))).T
    assert rel_error(a, robot.direct_dynamics(P, V, G, backend="pinocchio")) < DDM_TOL
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the VM's warning
        assert CompiledDynamics(robot, compiler=False).general is False  # the hand path


def test_symbolic_models_have_the_shared_signature():
    """Derivatives are built from ``idm(pose, twist, accel, base_parameters)`` and
    ``ddm(pose, twist, gamma, base_parameters)`` whatever the legs."""
    for name in ("rus", "simulator"):
        m = generate_models(get_robot(name).description)
        assert m.idm.name_in() == ["pose", "twist", "accel", "base_parameters"]
        assert m.ddm.name_in() == ["pose", "twist", "gamma", "base_parameters"]
        assert m.idm.name_out() == ["gamma"] and m.ddm.name_out() == ["accel"]
    m = generate_models(get_robot("rus").description)
    assert m.idm.size1_in(3) == 0 and m.parameters == "numeric"
    with pytest.raises(InputError, match="baked in"):
        generate_models(get_robot("rus").description, parameters="essential")


def test_springs_take_the_joint_value_inside_limits_past_pi():
    """A revolute joint whose limits lie past pi ([q + 2 pi - 1.2, q + 2 pi + 1.2]): the
    reference takes its value modulo 2 pi into them, and so does the spring term of the
    compiled model."""
    base = random_hexapod("rus", 3)
    q_home = leg_chains.inverse_geometry(base, base.home_pose)
    legs = []
    for k, leg in enumerate(base.legs):
        j2 = leg.joints[1]
        lo = float(q_home[k, 1]) + 2 * math.pi - 1.2
        dyn = replace(j2.dynamics, stiffness=5.0, rest_position=float(q_home[k, 1]) + 2 * math.pi)
        j2 = replace(j2, lower=lo, upper=lo + 2.4, dynamics=dyn)
        joints = (leg.joints[0], j2, leg.joints[2])
        legs.append(leg.replace(joints=joints))
    robot = StewartRobot(base.replace(legs=tuple(legs)).to_description())
    P, V, A = robot.sample_states(30, 2)
    q = robot.inverse_geometry(P)[:, :, 1]
    assert np.all(q > math.pi)  # the values the reference reports are past pi
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(robot.inverse_dynamics(P, V, A, backend="compiled"), G) < TOL


def test_threaded_general_batch_equals_one_thread():
    robot, P, V, A = _states("pus", 2 * THREAD_MIN_STATES + 7, 9)
    one = CompiledDynamics(robot, threads=1).inverse_dynamics(P, V, A)
    two = CompiledDynamics(robot, threads=2).inverse_dynamics(P, V, A)
    np.testing.assert_array_equal(one, two)
    assert rel_error(two, robot.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL


def test_vm_fallback_general(monkeypatch):
    """Without a compiler the same models run in CasADi's VM: same results, same errors."""
    robot, P, V, A = _states("rus", 30)
    with pytest.warns(RuntimeWarning, match="virtual machine"):
        monkeypatch.setattr(compiled_module, "_WARNED", set())
        vm = CompiledDynamics(robot, compiler=False)
    assert vm.kind == "vm" and vm.general
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(vm.inverse_dynamics(P, V, A), G) < TOL
    acc = robot.direct_dynamics(P, V, G, backend="pinocchio")
    assert rel_error(vm.direct_dynamics(P, V, G), acc) < DDM_TOL
    far = P[:4].copy()
    far[2, :3, 3] += 1.0  # out of reach
    _same_error(lambda: vm.inverse_dynamics(far, V[:4], A[:4]), robot, far, V[:4], A[:4])


def test_base_values_are_refused_for_general_legs():
    backend = backend_of("pus")
    _, P, V, A = _states("pus", 3)
    assert backend.parameter_names == () and backend.base_values.shape == (0,)
    with pytest.raises(InputError, match="general legs"):
        backend.inverse_dynamics(P, V, A, base_values=np.zeros(0))


# ---------------------------------------------------------------------------- guards
def _same_error(call, robot, P, V, X, which="idm"):
    """``call()`` raises what the reference raises: the same type and message."""
    ref = robot.inverse_dynamics if which == "idm" else robot.direct_dynamics
    with pytest.raises(StewartPinError) as expected:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref(P, V, X, backend="pinocchio")
    with pytest.raises(type(expected.value)) as got:
        call()
    assert str(got.value) == str(expected.value)
    return got.value


def _bad_batch(name: str, k: int, edit):
    """10 valid states with state ``k`` edited by ``edit(T, V, A) -> (T, V, A)``."""
    robot, P, V, A = _states(name, 10, 1)
    P, V, A = P.copy(), V.copy(), A.copy()
    P[k], V[k], A[k] = edit(P[k].copy(), V[k].copy(), A[k].copy())
    return robot, P, V, A


def _reach(T, V, A):
    T[:3, 3] += [0.0, 0.0, 1.0]
    return T, V, A


def _nan(T, V, A):
    V[2] = np.nan
    return T, V, A


def _overflow(T, V, A):
    return T, V * 1e160, A


@pytest.mark.parametrize("name", ("rus", "pus", "random-custom-0", "ups-offset"))
@pytest.mark.parametrize(
    "edit, error",
    [(_reach, StewartPinError), (_nan, InputError), (_overflow, NumericalError)],
)
def test_guard_raises_the_references_error(name, edit, error):
    """Out of reach, a non-finite input, an overflowing result, at state 7 of a batch:
    the compiled model raises the reference's error, state index included, batch and
    single state, IDM and DDM."""
    backend = backend_of(name)
    robot, P, V, A = _bad_batch(name, 7, edit)
    e = _same_error(lambda: backend.inverse_dynamics(P, V, A), robot, P, V, A)
    assert isinstance(e, error)
    G = np.tile(robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6)), (10, 1))
    _same_error(lambda: backend.direct_dynamics(P, V, G), robot, P, V, G, "ddm")
    _same_error(lambda: backend.inverse_dynamics(P[7], V[7], A[7]), robot, P[7], V[7], A[7])


def _sweep(name: str, poses) -> set[type]:
    """The compiled IDM along a sweep of poses: the reference's values where it accepts
    a pose, its error (type and message) where it refuses one; returns the errors seen."""
    robot, backend, zero = get_robot(name), backend_of(name), np.zeros(6)
    seen: set[type] = set()
    for T in poses:
        try:
            g_ref = robot.inverse_dynamics(T, zero, zero, backend="pinocchio")
        except StewartPinError as e:
            seen.add(type(e))
            _same_error(lambda T=T: backend.inverse_dynamics(T, zero, zero), robot, T, zero, zero)
            continue
        assert rel_error(backend.inverse_dynamics(T, zero, zero), g_ref) < 1e-10
    return seen


def _moved(robot, dz: float = 0.0, pitch: float = 0.0):
    T = robot.home_pose
    T[2, 3] += dz
    T[:3, :3] = pin.exp3(np.array([0.0, pitch, 0.0])) @ T[:3, :3]
    return T


def test_reach_and_serial_singularity_of_a_rus_leg():
    """Raising the ``rus`` preset's platform aligns a crank with its rod (a serial
    singularity from 19 mm, then out of reach); pitching it takes a leg out of reach (at
    0.235 rad): both paths refuse alike, and agree up to there."""
    robot = get_robot("rus")
    up = _sweep("rus", [_moved(robot, dz=dz) for dz in np.linspace(0.0, 0.03, 61)])
    assert up == {SingularityError, LegReachError}
    tilt = _sweep("rus", [_moved(robot, pitch=a) for a in np.linspace(0.0, 0.3, 61)])
    assert tilt == {LegReachError}


def test_joint_limits_are_the_references():
    """The ``rus`` preset's cranks are limited to [-pi/2, pi/2]: lowering the platform
    by 48 mm drives crank 1 through its limit; the compiled model refuses exactly as the
    reference (LegJointLimitError), and agrees just inside."""
    robot = get_robot("rus")
    down = _sweep("rus", [_moved(robot, dz=-dz) for dz in np.linspace(0.0, 0.06, 121)])
    assert down == {LegJointLimitError}


def test_flagged_states_take_the_reference_values():
    """States the guard flags (a slack not positive) but the reference accepts get the
    reference's values; flagged only by the cheap singularity bound, the exact measure
    decides and the compiled values stay."""
    backend = backend_of("pus")
    robot, P, V, A = _states("pus", 20)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    out = np.zeros((20, 6))
    flags = np.full(20, compiled_module._GEOMETRY, dtype=np.int32)
    flags[::2] = 0
    backend._resolve("idm", flags, (P, V, A, "accel"), P, V, A, out)
    np.testing.assert_array_equal(out[1::2], G[1::2])  # the reference's own numbers
    assert not out[::2].any()  # the unflagged states are left alone
    cond = leg_chains.condition_number_batch(robot.general, robot.inverse_jacobian(P))
    strict = StewartRobot(robot.description, max_condition=float(cond.max()) * 1.0001)
    assert rel_error(CompiledDynamics(strict).inverse_dynamics(P, V, A), G) < TOL
    tighter = StewartRobot(robot.description, max_condition=float(cond.max()) * 0.9999)
    _same_error(lambda: CompiledDynamics(tighter).inverse_dynamics(P, V, A), tighter, P, V, A)


# ---------------------------------------------------------------------------- cache, source
def test_general_source_holds_no_text_of_the_description(tmp_path):
    """The robot's name shapes nothing in a general robot's C source either."""
    desc = get_robot("pus").description
    evil = desc.replace()
    object.__setattr__(evil, "name", 'x */ int sp_evil; /* "; rm -rf ~')
    source = c_source(evil)
    assert source == c_source(desc)
    assert "sp_evil" not in source and "rm -rf" not in source


def test_general_library_in_another_geometrys_folder_is_rebuilt(tmp_path):
    """The cache's integrity rules hold for general robots: a library replaced by another
    robot's is rebuilt (with a warning), never loaded."""
    # Built (or found) in the session's cache, pus's folder copied into a cache of its
    # own: a file this process has mapped is never tampered with.
    pus, _ = build_library(get_robot("pus").description)
    b, _ = build_library(get_robot("rus").description)
    shutil.copytree(pus.parent, tmp_path / pus.parent.name)
    a = tmp_path / pus.parent.name / pus.name
    assert a.read_bytes() != b.read_bytes()
    a.write_bytes(b.read_bytes())
    with pytest.warns(RuntimeWarning, match="does not match its manifest"):
        again = CompiledDynamics(get_robot("pus"), cache_dir=tmp_path)
    assert again.compiled_now
    robot, P, V, A = _states("pus", 5)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert rel_error(again.inverse_dynamics(P, V, A), G) < TOL


def test_custom_newton_steps_are_calls_in_the_source():
    """A custom leg's Newton steps are calls of one step function in the C source (a
    shorter source and build), written out for the operation counts."""
    desc = get_robot("random-custom-0").description
    source = c_source(desc)
    flat, _ = build_general_models(desc, inline_newton=True)
    called = generate_models(desc)
    assert count_operations(called.idm).trig < count_operations(flat.idm).trig
    assert count_operations(flat.idm).trig >= 6 * 2 * NEWTON_ITERATIONS  # sin, cos per step
    assert len(source) < 2 * len(c_source(get_robot("random-pus-0").description))


# ---------------------------------------------------------------------------- counts
def test_operation_counts_of_each_architecture(capsys):
    """``stewart-pin cost`` takes general legs; the architectures' table beside Table IV;
    the 6-UPS closed forms keep their counts (the general ups path costs more)."""
    d = cost_dict(get_robot("rus"))
    for model in ("IDM", "DDM"):
        for key in ("numeric", "quaternion", "critical_path", "critical_path_7"):
            c = d[model][key]
            assert all(isinstance(v, int) and v >= 0 for v in c.values())
            assert c["mul"] > 0 and c["add"] > 0
        assert d[model]["critical_path"]["total"] < d[model]["numeric"]["total"]
        assert d[model]["numeric"]["trig"] == 0  # the rus preset has no spring
    assert d["IDM"]["numeric"]["total"] < d["DDM"]["numeric"]["total"]
    text = cost_table(get_robot("pus"))
    assert "Table IV" in text and "critical path" in text and "2078" in text
    archs = architecture_dict()
    hand = archs["6-UPS, the paper's closed forms"]["IDM"]["numeric"]["total"]
    assert hand == cost_dict(get_robot("simulator"))["IDM"]["numeric"]["total"]
    assert archs["6-UPS as general ups legs"]["IDM"]["numeric"]["total"] > hand
    assert archs["6-UPS, every joint term"]["DDM"]["numeric"]["trig"] > 0  # springs: atan2
    assert "6-RUS" in architecture_table()
    assert main(["cost", "--preset", "rus"]) == 0
    assert "IDM, parameter values baked in" in capsys.readouterr().out
    assert main(["cost", "--architectures"]) == 0
    out = capsys.readouterr().out
    assert "6-PUS" in out and "custom legs" in out and "Table IV" in out


def test_joint_terms_change_the_compiled_model():
    """Each joint term reaches the compiled model (a model without it differs)."""
    base = get_robot("random-pus-0")
    _, P, V, A = _states("random-pus-0", 10)
    G = backend_of("random-pus-0").inverse_dynamics(P, V, A)
    legs = tuple(leg.with_dynamics([JointDynamics()] * 3) for leg in base.description.legs)
    bare = StewartRobot(base.description.replace(legs=legs))
    G0 = bare.inverse_dynamics(P, V, A, backend="compiled")
    assert rel_error(G0, bare.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL
    assert rel_error(G0, G) > 1e-3


@pytest.mark.parametrize("name", ["pus", "desktop"])
def test_compiled_path_refuses_booleans_and_strings_like_the_reference(name):
    """A boolean or a string inside a list is refused with the reference's message (the
    compiled path used to take ``True`` as 1.0)."""
    robot = get_robot(name)
    T, V, A = (x[0] for x in robot.sample_states(1, 3))
    for twist in ([*V[:5], True], [*V[:5], "0.5"]):
        with pytest.raises(InputError) as ref:
            robot.inverse_dynamics(T, twist, A, backend="pinocchio")
        with pytest.raises(InputError) as got:
            robot.inverse_dynamics(T, twist, A, backend="compiled")
        assert str(got.value) == str(ref.value)


@pytest.mark.parametrize("name", ["pus", "simulator"])
def test_gravity_past_1e154_is_compiled_in(name):
    """A gravity of 1e160 m/s^2: its norm's sum of squares overflows (past ~1.3e154), and the
    constants' snapping used to take every component as zero (general legs: forces 4 %
    off, silently) or as NaN (6-UPS: a NumericalError where the reference has a value).
    The compiled IDM equals the reference, and so does the DDM of zero forces (a free
    fall, accelerations of the order of gravity: no cancellation between the two)."""
    base = get_robot(name)
    robot = StewartRobot(base.description.replace(gravity=np.array([0.0, 0.3, -1.0]) * 1e160))
    backend = CompiledDynamics(robot)
    assert backend.kind == "compiled", backend.reason
    P, V, A = robot.sample_states(10, 3)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert np.abs(G).max() > 1e155  # gravity dominates
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    zero = np.zeros((10, 6))
    acc = robot.direct_dynamics(P, V, zero, backend="pinocchio")
    assert rel_error(backend.direct_dynamics(P, V, zero), acc) < DDM_TOL
