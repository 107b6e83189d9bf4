"""The compiled simulator's direct model with the six legs as vector lanes
(:mod:`stewart_pin.codegen.lanes`): the same results and flags as the robot library's
``sp_ddm_aux`` (which the single-state and batch calls share with the Python loop) and as
the reference path, on sampled states and on states the guard flags; where it applies and
where the robot library's entry stays; the C loop on it equals the Python loop. No timing
assertions (scripts/bench_simulation.py measures)."""

from __future__ import annotations

import ctypes
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache
from helpers import rel_error

from stewart_pin.codegen import lanes
from stewart_pin.codegen.compiled import model_layout, singularity_length
from stewart_pin.codegen.simulator import _DDM_AUX, _address
from stewart_pin.codegen.symbolic import LEG_PARAMETERS
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.description.leg_chain_presets import GENERAL_PRESETS, random_hexapod
from stewart_pin.motion import simulation
from stewart_pin.motion.simulation import prepare_run
from stewart_pin.parameters.base import grouped_parameters

#: Named presets and asymmetric robots (every joint term non-zero, legs that differ in
#: their joints' numbers too); the paper's 6-UPS models (:mod:`stewart_pin.codegen.symbolic`)
#: on three presets and a random robot (no zero in its geometry).
ROBOTS = (
    "rus",
    "pus",
    "ups-offset",
    "random-rus-0",
    "random-pus-0",
    "random-ups-offset-0",  # the robot of test_general_codegen.py: one build for both
    "simulator",
    "desktop",
    "paper",
    "random-0",
)


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)


def _avx2_fma() -> bool:
    """Whether this processor has AVX2 and FMA (Linux's /proc/cpuinfo; False elsewhere)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    flags = next((ln.split(":", 1)[1].split() for ln in text.splitlines() if "flags" in ln), [])
    return "avx2" in flags and "fma" in flags


needs_lanes = pytest.mark.skipif(not _avx2_fma(), reason="the lanes need AVX2 and FMA")


def _entries(robot):
    """The run's direct-model entry (the lanes where they apply) and the library's."""
    run = prepare_run(robot, 0.01, backend="compiled", integrator="compiled")
    lib = run.fast._models._lib
    return run, run.fast.sim.ddm, lib.sp_ddm_aux, _address(lib, "sp_ddm_aux")


def _call(fn, T, V, g, run, chi=None, max_cond=None):
    """One ``sp_ddm_aux``-like call (``chi``: the run's base parameters, or these;
    ``max_cond``: the run's threshold, or this): (flag, accel, aux, det)."""
    aux, out, det = np.empty(run.fast.sim.naux), np.empty(6), ctypes.c_double()
    flag = fn(
        *(ctypes.c_void_p(np.ascontiguousarray(a).ctypes.data) for a in (T, V, g)),
        ctypes.c_void_p(run.fast.sim.chi if chi is None else chi.ctypes.data),
        ctypes.c_double(run.fast.sim.max_cond if max_cond is None else max_cond),
        ctypes.c_void_p(out.ctypes.data),
        ctypes.c_void_p(aux.ctypes.data),
        ctypes.byref(det),
    )
    return flag, out, aux, det.value


def _close(got: np.ndarray, ref: np.ndarray, tol: float = 1e-13) -> None:
    """Each value within ``tol`` of the reference, relative to max(|reference|, 1)."""
    err = np.abs(got - ref) / np.maximum(np.abs(ref), 1.0)
    assert err.max() <= tol, (err.max(), got, ref)


def _near_home(robot, n: int, seed: int, spread: float, odd: bool = False):
    """``n`` states about home (pose offsets of ``spread`` in the stroke and radians,
    twists of 0.1, forces within 5 % of the hover); ``odd``: every other state's offsets
    0.02 instead, and every tenth with a pose that is no rotation, a non-finite twist or
    force."""
    rng = np.random.default_rng(seed)
    g0 = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6), backend="pinocchio")
    out = []
    for i in range(n):
        T = robot.home_pose.copy()
        d = (spread if i % 2 or not odd else 0.02) * rng.standard_normal(6)
        T[:3, :3] = pin.exp3(d[3:]) @ T[:3, :3]
        T[:3, 3] += robot.description.stroke_mid * d[:3]
        tw = 0.1 * rng.standard_normal(6)
        g = g0 * (1.0 + 0.05 * rng.standard_normal(6))
        if odd and i % 10 == 3:
            T[0, 0] += 1e-5
        if odd and i % 10 == 7:
            tw[2] = np.nan
        if odd and i % 10 == 9:
            g[4] = np.inf
        out.append((T, tw, g))
    return out


@needs_lanes
@pytest.mark.parametrize("name", ROBOTS)
def test_the_lanes_equal_the_library_and_the_reference(name):
    """The lanes against ``sp_ddm_aux`` (the robot library's AVX2+FMA copy of the flat
    model, the C loop's entry without the lanes) and the single-state compiled model (the
    batch call, no FMA), state by state:

    - 100 states about home: the same flag (0); the acceleration within 1e-13 of both
      (relative to max(|a|, 1), as tests/test_compiled_simulation.py bounds the copy),
      the by-products (``Jp^-1``, the ``L D L^T`` pivots, the slacks) and the
      determinant of the cheap condition check within 1e-13 of ``sp_ddm_aux``'s;
    - 300 sampled states (``sample_states``, the forces the reference's IDM of a sampled
      acceleration): the same flags; the by-products but the pivots (the leg code's:
      ``Jp^-1``, the slacks or the 6-UPS ``q^2``, ``rho^2``) within 1e-13;
      the acceleration's backward error (the
      reference IDM of it against the forces) under 1e-12, as the compiled model's in
      tests/test_general_codegen.py (a forward bound would be the state's condition
      number times the rounding: up to 4e-10 between ``sp_ddm_aux`` and the batch call
      already at some sampled states of random-pus-0, and as much on the pivots);
    - 200 states from well inside to beyond the workspace, every tenth with a pose that
      is no rotation or a non-finite input: the same flag, flagged or not, and the INPUT
      flag (beyond a first flag the generated values are meaningless and FMA may change
      which further flags they raise, as for ``sp_ddm_aux``'s own copy)."""
    robot = get_robot(name)
    run, entry, aux_fn, aux_address = _entries(robot)
    assert entry != aux_address  # the lanes run
    lanes_fn = _DDM_AUX(entry)
    near = _near_home(robot, 100, 7, 0.02)
    T, tw, g = (np.array(x) for x in zip(*near, strict=True))
    batch = robot.direct_dynamics(T, tw, g, backend="compiled")
    for k in range(len(near)):
        f1, a1, x1, d1 = _call(aux_fn, T[k], tw[k], g[k], run)
        f2, a2, x2, d2 = _call(lanes_fn, T[k], tw[k], g[k], run)
        assert f1 == 0 and f2 == 0
        _close(a2, a1)
        _close(a2, batch[k])
        _close(x2, x1)
        _close(np.array([d2]), np.array([d1]))

    P, V, A = robot.sample_states(300, 5)
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    d = model_layout(robot.description).ddm_d  # the L D L^T pivots: aux[d : d + 6]
    legs = np.r_[0:d, d + 6 : run.fast.sim.naux]
    ok, acc = [], []
    for k in range(300):
        f1, _, x1, _ = _call(aux_fn, P[k], V[k], G[k], run)
        f2, a2, x2, _ = _call(lanes_fn, P[k], V[k], G[k], run)
        assert (f1 == 0) == (f2 == 0) and f1 & 1 == f2 & 1, (f1, f2)
        if f1 == 0:
            _close(x2[legs], x1[legs])
            ok.append(k)
            acc.append(a2)
    assert len(ok) >= 150, len(ok)
    back = robot.inverse_dynamics(P[ok], V[ok], np.array(acc), backend="pinocchio")
    assert rel_error(back, G[ok]) < 1e-12

    flags = set()
    for T1, tw1, g1 in _near_home(robot, 200, 11, 0.4, odd=True):
        f1, *_ = _call(aux_fn, T1, tw1, g1, run)
        f2, *_ = _call(lanes_fn, T1, tw1, g1, run)
        assert (f1 == 0) == (f2 == 0) and f1 & 1 == f2 & 1, (f1, f2)
        flags.add(int(f1))
    assert 0 in flags and any(f & 1 for f in flags) and len(flags) >= 3, flags


def _idm(address_or_fn, T, V, A, run, chi, max_cond=None):
    """One ``sp_idm_sim``-like call (``max_cond``: the run's threshold, or this): (flag,
    gamma)."""
    gamma, flags = np.empty(6), np.zeros(1, np.int32)
    address_or_fn(
        ctypes.c_longlong(1),
        *(ctypes.c_void_p(np.ascontiguousarray(a).ctypes.data) for a in (T, V, A)),
        ctypes.c_void_p(chi),
        ctypes.c_double(run.fast.sim.max_cond if max_cond is None else max_cond),
        ctypes.c_void_p(gamma.ctypes.data),
        ctypes.c_void_p(flags.ctypes.data),
    )
    return int(flags[0]), gamma


_IDM_SIM = ctypes.CFUNCTYPE(
    ctypes.c_int,
    ctypes.c_longlong,
    *[ctypes.c_void_p] * 4,
    ctypes.c_double,
    *[ctypes.c_void_p] * 2,
)


@needs_lanes
@pytest.mark.parametrize("name", ROBOTS)
def test_the_inverse_lanes_equal_the_library_and_the_reference(name):
    """The computed-torque controller's inverse model on the lanes (``sp_idm_lanes``)
    against the robot library's ``sp_idm_sim`` (its AVX2+FMA copy) and the batch call:
    about home the same flag (0) and forces within 1e-13 (relative to max(|G|, 1)); at
    300 sampled states the same flags and forces within 1e-12 of the reference path's
    (tests/test_general_codegen.py's bound for the compiled inverse model); at 200
    states from well inside to beyond the workspace (non-finite inputs among them) the
    same flag, flagged or not, and the INPUT flag."""
    robot = get_robot(name)
    run = prepare_run(robot, 0.01, backend="compiled", integrator="compiled")
    models = run.fast._models
    ddm, idm = lanes.lanes_entries(models)
    assert ddm != 0 and idm != 0
    lanes_fn, lib_fn = _IDM_SIM(idm), models._lib.sp_idm_sim
    chi = run.fast.sim.chi
    rng = np.random.default_rng(3)
    near = _near_home(robot, 100, 7, 0.02)
    T, tw, _ = (np.array(x) for x in zip(*near, strict=True))
    A = 0.5 * rng.standard_normal((100, 6))
    batch = robot.inverse_dynamics(T, tw, A, backend="compiled")
    for k in range(100):
        f1, g1 = _idm(lib_fn, T[k], tw[k], A[k], run, chi)
        f2, g2 = _idm(lanes_fn, T[k], tw[k], A[k], run, chi)
        assert f1 == 0 and f2 == 0
        _close(g2, g1)
        _close(g2, batch[k])
    P, V, A = robot.sample_states(300, 5)
    ok, got = [], []
    for k in range(300):
        f1, _ = _idm(lib_fn, P[k], V[k], A[k], run, chi)
        f2, g2 = _idm(lanes_fn, P[k], V[k], A[k], run, chi)
        assert (f1 == 0) == (f2 == 0) and f1 & 1 == f2 & 1, (f1, f2)
        if f1 == 0:
            ok.append(k)
            got.append(g2)
    assert len(ok) >= 150, len(ok)
    ref = robot.inverse_dynamics(P[ok], V[ok], A[ok], backend="pinocchio")
    assert rel_error(np.array(got), ref) < 1e-12
    flags = set()
    for T1, tw1, g1 in _near_home(robot, 200, 11, 0.4, odd=True):
        acc = 0.5 * rng.standard_normal(6)
        if not np.all(np.isfinite(g1)):
            acc[1] = np.inf
        f1, _ = _idm(lib_fn, T1, tw1, acc, run, chi)
        f2, _ = _idm(lanes_fn, T1, tw1, acc, run, chi)
        assert (f1 == 0) == (f2 == 0) and f1 & 1 == f2 & 1, (f1, f2)
        flags.add(f1)
    assert 0 in flags and any(f & 1 for f in flags) and len(flags) >= 3, flags


@needs_lanes
@pytest.mark.parametrize("name", ROBOTS)
def test_the_direct_lanes_at_the_controllers_state_flag_as_the_library(name):
    """The direct model on the lanes called at the state of the lanes' inverse model's last
    call (the computed-torque controller's in the C loop: the same pose and twist, the
    forces it returned), where its guard takes the inputs' validity and the condition
    bound's determinant and norm from that call (sign by the static pivot order's parity:
    -1 on random-rus-0, random-pus-0, paper, random-0): at 200 sampled states, the
    inverse model at a threshold that flags none of them, the direct model at the run's
    ``max_condition`` (at least 150 states pass) and at the quartiles of the thresholds
    at which the guard's bounds of cond S (NumPy's) pass the passing states (the direct
    model's own threshold decides; at each, 20 states flagged COND and 20 passed): the
    flags of the robot library's ``sp_ddm_aux`` at the same state and threshold; where
    the state passes with the cheap check's determinant (at the run's threshold, 150
    states at least), the sign of NumPy's ``det Jp^-1`` (the by-products'), the sign the
    C loop compares with the step's start. The inverse model's own flags there: the
    library's ``sp_idm_sim``'s."""
    robot = get_robot(name)
    run, entry, aux_fn, _ = _entries(robot)
    models = run.fast._models
    lanes_fn = _DDM_AUX(entry)
    ilanes, ilib = _IDM_SIM(lanes.lanes_entries(models)[1]), models._lib.sp_idm_sim
    chi = run.fast.sim.chi
    jinv = model_layout(robot.description).jinv
    scale = np.r_[np.ones(3), np.full(3, 1.0 / singularity_length(robot.description))]
    P, V, A = robot.sample_states(200, 9)
    states, passing = [], []
    for k in range(200):
        fi, gamma = _idm(ilanes, P[k], V[k], A[k], run, chi, max_cond=1e12)
        fl, _ = _idm(ilib, P[k], V[k], A[k], run, chi, max_cond=1e12)
        assert fi == fl, (k, fi, fl)
        f, _, x, _ = _call(aux_fn, P[k], V[k], gamma, run)
        if f == 0:  # the threshold below which the guard flags it (its two bounds of cond S)
            S = x[jinv : jinv + 36].reshape(6, 6).T * scale[:, None]
            fro2 = np.sum(S * S)
            bound = 2.0 / abs(np.linalg.det(S)) * (fro2 / 6.0) ** 3
            passing.append(min(2.0 * bound, np.sqrt(fro2 * np.sum(np.linalg.inv(S) ** 2))))
            states.append((k, gamma))
    assert len(states) >= 150, len(states)
    thresholds = (run.fast.sim.max_cond, *np.quantile(passing, [0.25, 0.5, 0.75]))
    flags: dict[float, list[int]] = {c: [] for c in thresholds}
    signed = dict.fromkeys(thresholds, 0)
    for k, gamma in states:
        for c in thresholds:
            _idm(ilanes, P[k], V[k], A[k], run, chi, max_cond=1e12)  # the state to reuse
            f1, _, x1, d1 = _call(lanes_fn, P[k], V[k], gamma, run, max_cond=c)
            f2, *_ = _call(aux_fn, P[k], V[k], gamma, run, max_cond=c)
            assert f1 == f2, (k, c, f1, f2)
            flags[c].append(f1)
            if f1 == 0 and d1 != 0.0:  # 0.0: the cheap check did not decide (an LU does)
                ref = np.linalg.det(x1[jinv : jinv + 36].reshape(6, 6))
                assert np.sign(d1) == np.sign(ref), (k, d1, ref)
                signed[c] += 1
    for c in thresholds[1:]:
        assert min(flags[c].count(0), flags[c].count(4)) >= 20, (c, flags[c])
    assert flags[thresholds[0]].count(0) == len(states) and signed[thresholds[0]] >= 150


def _asymmetric_limits(robot):
    """``robot`` (general legs) with another lower limit on leg 2's first joint that has
    one."""
    legs = list(robot.legs)
    joints = list(legs[1].joints)
    m = next(m for m, j in enumerate(joints) if np.isfinite(j.lower))
    joints[m] = replace(joints[m], lower=joints[m].lower - 0.01)
    legs[1] = replace(legs[1], joints=tuple(joints))
    return replace(robot, legs=tuple(legs))


def test_the_lanes_apply_where_the_legs_differ_in_numbers_only():
    """The lanes take every number of a leg that enters its code by arithmetic alone:
    the named presets and the asymmetric random robots have lane models, with the
    legs' numbers as rows (six, one per leg), as has a preset whose one leg has a joint
    term the others do not (a lane number, zero in five lanes); a ``custom`` leg
    (Newton's steps, a called function of the leg's numbers) or a joint limit (a branch
    of the generator, a threshold of the guard) that differs between legs leaves the
    robot on the library's direct model."""
    for name in ("rus", "pus", "ups-offset", "random-rus-0"):
        m = lanes.lane_models(get_robot(name).description)
        assert m is not None and m.prm.shape[0] == 6 and m.prm.shape[1] >= 8, name
        assert not np.all(m.prm == m.prm[0]), name  # legs do differ
    assert lanes.lane_models(get_robot("random-custom-0").description) is None
    assert lanes.lane_models(random_hexapod("pus", 0)) is not None
    assert lanes.lane_models(_asymmetric_limits(GENERAL_PRESETS["pus"]())) is None
    rus = GENERAL_PRESETS["rus"]()
    legs = list(rus.legs)
    j = legs[0].joints[1]
    assert j.dynamics.coulomb == 0.0
    legs[0] = replace(
        legs[0],
        joints=(
            legs[0].joints[0],
            replace(j, dynamics=JointDynamics(coulomb=0.1)),
            legs[0].joints[2],
        ),
    )
    m0, m1 = lanes.lane_models(rus), lanes.lane_models(replace(rus, legs=tuple(legs)))
    assert m0 is not None and m1 is not None and m1.prm.shape[1] == m0.prm.shape[1] + 1


@needs_lanes
def test_the_library_entry_stays_where_the_lanes_do_not_apply():
    """``custom`` legs: the C loop calls ``sp_ddm_aux``."""
    _, entry, _, aux_address = _entries(get_robot("random-custom-0"))
    assert entry == aux_address


def test_the_6ups_lanes_take_the_legs_placements_and_base_parameters():
    """The paper's 6-UPS on the lanes: the numbers that differ between the legs (``P_i``,
    ``B_i``, the first U-joint's axis; x and y only on the paper's presets, whose z are
    all zero, all nine on a random robot) are lane numbers, gravity (one vector) is baked,
    and each leg reads its own 13 base parameters from ``chi`` (their names' indices)."""
    for name, n_prm in (("simulator", 6), ("paper", 6), ("random-0", 9)):
        desc = get_robot(name).description
        m = lanes.lane_models(desc)
        assert m is not None and m.prm.shape == (6, n_prm), (name, m.prm.shape)
        names = grouped_parameters(desc).names
        assert m.chi_index.shape == (6, 13)
        for k in range(6):
            got = [names[i] for i in m.chi_index[k]]
            assert got == [f"{q}_{k + 1}" for q in LEG_PARAMETERS], got


@needs_lanes
@pytest.mark.parametrize("name", ("simulator", "random-0"))
def test_the_6ups_lanes_read_the_base_parameters_at_run_time(name):
    """Base parameters other than the robot's, each leg's its own (every value scaled by
    a random factor in [0.8, 1.2]): the lanes' direct and inverse models equal the robot
    library's ``sp_ddm_aux`` and ``sp_idm_sim`` with the same ``chi`` (same flags, 1e-13),
    and differ from their results with the robot's parameters (the values are read)."""
    robot = get_robot(name)
    run, entry, aux_fn, _ = _entries(robot)
    models = run.fast._models
    lanes_fn, ilanes_fn = _DDM_AUX(entry), _IDM_SIM(lanes.lanes_entries(models)[1])
    rng = np.random.default_rng(5)
    chi = models.base_values * rng.uniform(0.8, 1.2, models.base_values.size)
    same = 0
    for T, tw, g in _near_home(robot, 50, 13, 0.02):
        f1, a1, x1, _ = _call(aux_fn, T, tw, g, run, chi)
        f2, a2, x2, _ = _call(lanes_fn, T, tw, g, run, chi)
        _, a0, _, _ = _call(lanes_fn, T, tw, g, run)
        assert f1 == f2, (f1, f2)
        if f1 == 0:
            same += 1
            _close(a2, a1)
            _close(x2, x1)
            assert np.abs(a2 - a0).max() > 1e-6 * max(1.0, np.abs(a0).max())
        acc = 0.5 * rng.standard_normal(6)
        f1, g1 = _idm(models._lib.sp_idm_sim, T, tw, acc, run, chi.ctypes.data)
        f2, g2 = _idm(ilanes_fn, T, tw, acc, run, chi.ctypes.data)
        _, g0 = _idm(ilanes_fn, T, tw, acc, run, run.fast.sim.chi)
        assert f1 == f2 == 0, (f1, f2)
        _close(g2, g1)
        assert np.abs(g2 - g0).max() > 1e-6 * max(1.0, np.abs(g0).max())
    assert same >= 40, same


@needs_lanes
@pytest.mark.parametrize("name", ("pus", "random-rus-0", "simulator", "random-0"))
def test_the_c_loop_on_the_lanes_equals_the_python_loop(name):
    """RK4 at 1 ms for 0.1 s under constant forces about the hover: the C loop on the
    lanes gives the Python loop's trajectory to 1e-10 (relative to max(|x|, 1))."""
    robot = get_robot(name)
    g = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6), backend="pinocchio")
    kwargs = {"forces": g * 1.001, "twist": [0.01, -0.02, 0.01, 0.05, 0.02, -0.03], "dt": 1e-3}
    ref = prepare_run(robot, 0.1, backend="compiled", integrator="python", **kwargs).go()
    run = prepare_run(robot, 0.1, backend="compiled", integrator="compiled", **kwargs)
    assert run.fast is not None and run.fast.sim.ddm != _address(
        run.fast._models._lib, "sp_ddm_aux"
    )
    got = run.go()
    assert any(isinstance(r, simulation._Block) for r in run.rows)  # the C loop ran
    np.testing.assert_array_equal(got.t, ref.t)
    assert got.t.size == 101
    for field in ("poses", "twists", "accels", "gammas"):
        x, y = getattr(got, field), getattr(ref, field)
        assert np.abs(x - y).max() <= 1e-10 * max(1.0, float(np.abs(y).max())), field
