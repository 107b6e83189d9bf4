"""The compiled simulator (codegen/simulator.py): the C loop's trajectories equal the Python
loop's (same method, step and compiled direct model) to 1e-10, for forces as data, the
computed-torque controller and a Python function per control period; events stop both the
same way; energy and power balance hold (the reference path's energy, an independent
model)."""

from __future__ import annotations

import ctypes
import re

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache

from stewart_pin._so3 import so3_log
from stewart_pin.codegen import simulator
from stewart_pin.codegen.simulator import simulate_batch
from stewart_pin.exceptions import InputError
from stewart_pin.motion import simulation
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.force_tables import ForceTable
from stewart_pin.motion.simulation import SimulationError, prepare_run, simulate
from stewart_pin.motion.trajectories import (
    FourierTrajectory,
    MinimumJerkKnots,
    Sinusoids,
    minimum_jerk,
    standard_motion,
    states_at,
    washout,
)

TOL = 1e-10
ROBOTS = ("simulator", "rus")


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)


def _hover(robot) -> np.ndarray:
    """The forces holding the platform at rest at home (the reference path's IDM)."""
    return robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6), backend="pinocchio")


def _run(robot, duration, integrator, **kwargs):
    """``simulate`` through :func:`prepare_run`: the result and whether the C loop ran
    steps (rows it wrote)."""
    run = prepare_run(robot, duration, backend="compiled", integrator=integrator, **kwargs)
    result = run.go()
    return result, any(isinstance(r, simulation._Block) for r in run.rows)


def _assert_same(a, b) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    for name in ("poses", "twists", "accels", "gammas", "lengths"):
        x, y = getattr(a, name), getattr(b, name)
        scale = max(1.0, float(np.abs(x).max()))
        assert np.abs(x - y).max() <= TOL * scale, name


def _fourier(robot, rng) -> FourierTrajectory:
    """A 3-harmonic Fourier motion about home (a few mm and tenths of a degree at 2 Hz)."""
    scale = np.array([2e-3, 2e-3, 2e-3, 5e-3, 5e-3, 5e-3])[:, None]
    return FourierTrajectory(
        robot.home_pose,
        2.0,
        np.zeros(6),
        scale * rng.standard_normal((6, 3)),
        scale * rng.standard_normal((6, 3)),
    )


def _cases(robot):
    g = _hover(robot)
    rng = np.random.default_rng(3)
    times = np.linspace(0.0, 0.1, 6)
    values = g * (1.0 + 0.02 * rng.standard_normal((6, 6)))
    motion = standard_motion(robot, "sinusoid", 0.1)
    T0, V0, _ = motion(0.0)
    controller = ComputedTorqueController(robot, motion, backend="compiled")
    jerk = standard_motion(robot, "minimum-jerk", 0.1)
    fourier = _fourier(robot, rng)
    # A reference the C loop does not evaluate (a function): sampled before the run.
    sampled = ComputedTorqueController(robot, lambda t: motion(t), backend="compiled")
    return {
        "constant": {"forces": g * 1.001},
        "table-linear": {"forces": ForceTable(times, values, "linear")},
        "table-hold": {"forces": ForceTable(times, values, "hold"), "control_period": 2e-3},
        "ct": {"forces": controller, "pose": T0, "twist": V0},
        "ct-period": {"forces": controller, "pose": T0, "twist": V0, "control_period": 2e-3},
        "ct-minimum-jerk": {"forces": ComputedTorqueController(robot, jerk, backend="compiled")},
        "ct-fourier": {
            "forces": ComputedTorqueController(robot, fourier, backend="compiled"),
            "pose": fourier(0.0)[0],
            "twist": fourier(0.0)[1],
        },
        "ct-sampled": {"forces": sampled, "pose": T0, "twist": V0},
        "ct-sampled-period": {"forces": sampled, "pose": T0, "twist": V0, "control_period": 2e-3},
        "callback": {
            "forces": lambda t, T, V: g * (1.0 + 0.01 * np.sin(30 * t)),
            "control_period": 1e-3,
        },
    }


@pytest.mark.parametrize("name", ROBOTS)
def test_the_c_loop_equals_the_python_loop(name):
    robot = get_robot(name)
    for case, kwargs in _cases(robot).items():
        ref, ran_c = _run(robot, 0.1, "python", dt=1e-3, **kwargs)
        assert not ran_c
        got, ran_c = _run(robot, 0.1, "compiled", dt=1e-3, **kwargs)
        assert ran_c, case  # the C loop took the steps
        assert got.t.size == 101, case
        _assert_same(got, ref)


def test_the_adaptive_c_loop_follows_the_python_loop():
    """Dormand-Prince 5(4) in C: the same accepted steps as the Python loop. Where the
    error control alone sets the step (no control period pins it), a difference of a few
    ulps in a stage moves the next step by about 1e-9 of it (the error estimate is a
    difference of two solutions): times within 1e-8 s, the rows on the same trajectory to
    1e-10 (:func:`_assert_same_path`). The computed-torque controller without a control
    period: its reference evaluated in C at every stage time."""
    robot = get_robot("simulator")
    g = _hover(robot)
    motion = standard_motion(robot, "sinusoid", 0.2)
    T0, V0, _ = motion(0.0)
    controller = ComputedTorqueController(robot, motion, backend="compiled")
    fourier = _fourier(robot, np.random.default_rng(8))
    cases = {
        "rotating": {"forces": g * 1.001, "twist": [0.02, 0.0, 0.05, 0.1, 0.0, 0.1]},
        "ct-period": {"forces": controller, "pose": T0, "twist": V0, "control_period": 5e-3},
        # The reference evaluated in C at every stage time: no control period needed.
        "ct": {"forces": controller, "pose": T0, "twist": V0},
        "ct-fourier": {
            "forces": ComputedTorqueController(robot, fourier, backend="compiled"),
            "pose": fourier(0.0)[0],
            "twist": fourier(0.0)[1],
        },
        "ct-minimum-jerk": {
            "forces": ComputedTorqueController(
                robot, standard_motion(robot, "minimum-jerk", 0.2), backend="compiled"
            )
        },
        "callback": {
            "forces": lambda t, T, V: g * (1.0 + 0.01 * np.sin(20 * t)),
            "control_period": 0.01,
        },
    }
    for case, kwargs in cases.items():
        opts = {"method": "adaptive", "rtol": 1e-8, "atol": 1e-10, **kwargs}
        ref, _ = _run(robot, 0.2, "python", **opts)
        got, ran_c = _run(robot, 0.2, "compiled", **opts)
        assert ran_c, case
        assert got.t.shape == ref.t.shape and got.t.size >= 10, case
        assert np.abs(got.t - ref.t).max() < 1e-8, case
        smooth = "control_period" not in kwargs
        _assert_same_path(got, ref, smooth)
        if not smooth:  # the forces held over the periods, row by row
            y = ref.gammas
            assert np.abs(got.gammas - y).max() < 1e-9 * max(1.0, float(np.abs(y).max())), case


def _assert_same_path(got, ref, smooth: bool) -> None:
    """The rows of two adaptive runs lie on one trajectory to 1e-10: each row of ``got``
    equals ``ref``'s row moved by their time difference ``dt`` (under 1e-8 s: to first
    order, the derivative times ``dt``; the rates of the accelerations and forces from
    ``np.gradient``, only where they are ``smooth``, without a control period's jumps)."""
    dt = (got.t - ref.t)[:, None]
    R = np.einsum("nij,nkj->nik", got.poses[:, :3, :3], ref.poses[:, :3, :3])
    rows = {
        "positions": (got.poses[:, :3, 3] - ref.poses[:, :3, 3], ref.twists[:, :3]),
        "rotations": (so3_log(R), ref.twists[:, 3:]),
        "twists": (got.twists - ref.twists, ref.accels),
    }
    if smooth:
        for name in ("accels", "gammas"):
            y = getattr(ref, name)
            rows[name] = (getattr(got, name) - y, np.gradient(y, ref.t, axis=0))
    for name, (diff, rate) in rows.items():
        scale = max(1.0, float(np.abs(getattr(ref, name, ref.twists)).max()))
        assert np.abs(diff - rate * dt).max() <= TOL * scale, name


def _c_reference(motion, times):
    """``(T, V, A)`` of ``motion`` at ``times`` from the simulator library's ``sp_ref_eval``
    (the reference the C loop evaluates at its stage times)."""
    kind, n, data, pose = simulator._reference_data(motion)
    pose = np.ascontiguousarray(pose, dtype=np.float64)
    sim = simulator._Sim(
        ref_kind=kind, ref_pose=pose.ctypes.data, ref_n=n, ref_data=data.ctypes.data
    )
    lib = simulator.simulator_library()
    T, V, A = np.empty((times.size, 4, 4)), np.empty((times.size, 6)), np.empty((times.size, 6))
    for i, t in enumerate(times):
        out = (ctypes.c_void_p(x[i].ctypes.data) for x in (T, V, A))
        lib.sp_ref_eval(ctypes.byref(sim), ctypes.c_double(t), *out)
    return T, V, A


def test_the_c_reference_equals_states_at_to_1e_13():
    """The reference the C loop evaluates (Fourier series, sinusoids, minimum-jerk knots;
    rotations below and above the SO(3) series' angle) equals ``states_at`` (the Python
    evaluation) at random times, at knot times and outside the knots, to 1e-13 relative;
    a reference of another type is not evaluated in C."""
    rng = np.random.default_rng(11)
    T_ref = np.eye(4)
    T_ref[:3, :3] = pin.exp3(rng.standard_normal(3))
    T_ref[:3, 3] = rng.standard_normal(3)
    knots = (
        ((0.2, 1.0),),
        (),
        ((0.0, 0.5), (0.5, -1.0), (1.0, 2.0)),
        (),
        ((-0.3, 0.0), (0.4, 0.8), (0.9, 0.8), (2.0, -0.1)),
        ((0.3, 0.1), (0.9, 0.4)),
    )
    motions = {
        "fourier-wide": FourierTrajectory(
            T_ref, 0.7, *(0.4 * rng.standard_normal(s) for s in ((6,), (6, 5), (6, 5)))
        ),
        "fourier-small": FourierTrajectory(
            T_ref, 1.3, *(0.01 * rng.standard_normal(s) for s in ((6,), (6, 2), (6, 2)))
        ),
        "sinusoids-wide": Sinusoids(
            T_ref, rng.standard_normal(6), rng.uniform(0.1, 2.0, 6), rng.standard_normal(6)
        ),
        "sinusoids-small": Sinusoids(
            T_ref, 0.01 * rng.standard_normal(6), rng.uniform(0.1, 2, 6), rng.standard_normal(6)
        ),
        "minimum-jerk": minimum_jerk(T_ref, rng.standard_normal(6), 1.3, rng.standard_normal(6)),
        "knots": MinimumJerkKnots(T_ref, knots),
        "washout": washout(T_ref, 0.1, 0.2),
    }
    times = np.sort(np.r_[rng.uniform(-0.5, 4.0, 300), -0.3, 0.0, 0.2, 0.3, 0.4, 0.5, 0.9, 1.0])
    for name, motion in motions.items():
        want = states_at(motion, times)
        got = _c_reference(motion, times)
        angle = np.linalg.norm(motion.coordinates(times)[0][:, 3:], axis=1).max()
        assert angle < 0.1 if name.endswith("small") else angle > 0.1, name  # series or not
        for x, y in zip(got, want, strict=True):
            assert np.abs(x - y).max() <= 1e-13 * max(1.0, float(np.abs(y).max())), name
    assert np.abs(states_at(motions["fourier-wide"], times)[1][:, 3:]).max() > 1.0
    assert simulator._reference_data(lambda t: motions["knots"](t)) is None


#: output_dt values: multiples of dt = 1e-3 and not, one below dt, one past the run's end.
OUTPUT_DTS = (1e-2, 2.5e-3, 7.3e-3, 3e-4, 0.25)


def _output_grid(duration: float, output_dt: float) -> np.ndarray:
    """The documented sample times: ``k * output_dt`` up to the end, and ``duration``."""
    k = np.arange(int(np.floor(duration / output_dt - 1e-9)) + 1)
    t = k * output_dt
    return t if duration - t[-1] < 1e-12 else np.r_[t, duration]


@pytest.mark.parametrize("name", ROBOTS)
def test_output_dt_on_the_c_loop_equals_the_python_loop(name, monkeypatch):
    """``output_dt`` in C (rk4): the steps cut at the output times and the rows kept as
    the Python loop cuts and keeps them, for every kind of forces; the samples at
    ``k * output_dt`` exactly. Again with buffers of 16 rows (the steps per call bounded
    alike): most calls keep no row, the state and the output index go on across them."""
    from stewart_pin.codegen import simulator

    robot = get_robot(name)
    outs = OUTPUT_DTS if name == "simulator" else (1e-2, 7.3e-3)
    for case, kwargs in _cases(robot).items():
        for out in outs:
            ref, _ = _run(robot, 0.1, "python", dt=1e-3, output_dt=out, **kwargs)
            np.testing.assert_array_equal(ref.t, _output_grid(0.1, out))
            for chunk in (simulator.CHUNK_ROWS, 16):
                monkeypatch.setattr(simulator, "CHUNK_ROWS", chunk)
                run = prepare_run(
                    robot,
                    0.1,
                    backend="compiled",
                    integrator="compiled",
                    dt=1e-3,
                    output_dt=out,
                    **kwargs,
                )
                got = run.go()
                in_python = [r.t for r in run.rows if isinstance(r, simulation._State)]
                if case in ("constant", "table-linear", "table-hold"):
                    assert not in_python, (case, out, chunk)  # every step in C
                else:  # the callback's first forces; the continuous controller's cut steps
                    assert len(in_python) < got.t.size, (case, out, chunk)
                _assert_same(got, ref)


def test_output_dt_on_the_adaptive_c_loop_equals_the_python_loop():
    """``output_dt`` in C (adaptive): the trial steps cut at the output times (the next
    trial step grows from the cut one, as in the Python loop); the same rows at
    ``k * output_dt``, equal to 1e-10 (cases whose steps the error control does not set
    on a kink of the forces)."""
    robot = get_robot("simulator")
    g = _hover(robot)
    cases = _cases(robot)
    cases = {
        "rotating": {"forces": g * 1.001, "twist": [0.02, 0.0, 0.05, 0.1, 0.0, 0.1]},
        "table-hold": cases["table-hold"],
        "ct-period": cases["ct-period"],
        "callback": cases["callback"],
    }
    for case, kwargs in cases.items():
        for out in OUTPUT_DTS:
            opts = {"method": "adaptive", "rtol": 1e-8, "atol": 1e-10, "output_dt": out}
            ref, _ = _run(robot, 0.1, "python", **opts, **kwargs)
            got, ran_c = _run(robot, 0.1, "compiled", **opts, **kwargs)
            assert ran_c, (case, out)
            np.testing.assert_array_equal(ref.t, _output_grid(0.1, out))
            _assert_same(got, ref)


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
def test_output_dt_with_a_stroke_end_near_the_end(method):
    """A stroke end 4 ms before the run's end, between two output times: both loops stop
    alike (message, time, cause) with the same partial result (the output rows, then the
    last accepted state)."""
    robot = get_robot("simulator")
    opts = {"dt": 2e-3, "method": method, "rtol": 1e-8, "atol": 1e-10}
    with pytest.raises(SimulationError) as free:
        simulate(robot, 3.0, backend="compiled", integrator="python", **opts)
    end = free.value.time + 4e-3
    errors = []
    for integrator in ("python", "compiled"):
        run = prepare_run(
            robot, end, backend="compiled", integrator=integrator, output_dt=7e-3, **opts
        )
        with pytest.raises(SimulationError) as e:
            run.go()
        errors.append(e.value)
        ran_c = any(isinstance(r, simulation._Block) for r in run.rows)
        assert ran_c == (integrator == "compiled")
    a, b = errors
    assert str(a) == str(b) and a.time == b.time
    assert type(a.__cause__) is type(b.__cause__)
    _assert_same(a.result, b.result)
    assert b.result.t[-1] == b.time and b.result.t.size > 10
    np.testing.assert_array_equal(b.result.t[:-1], np.arange(b.result.t.size - 1) * 7e-3)


def test_the_computed_torque_controller_tracks_its_reference_in_c():
    """Closed loop on an exact model: the tracking error stays small (an independent
    check of the C law, against the reference motion itself)."""
    robot = get_robot("simulator")
    motion = standard_motion(robot, "sinusoid", 0.2)
    T0, V0, _ = motion(0.0)
    res, ran_c = _run(
        robot,
        0.2,
        "compiled",
        pose=T0,
        twist=V0,
        dt=1e-3,
        forces=ComputedTorqueController(robot, motion, backend="compiled"),
    )
    assert ran_c
    ref = motion.sample(res.t)
    assert np.abs(res.poses[:, :3, 3] - ref.poses[:, :3, 3]).max() < 1e-6


@pytest.mark.parametrize("name", ROBOTS)
def test_a_stroke_end_stops_both_loops_the_same_way(name):
    """Unpowered, the platform falls until a leg reaches its stroke end (or, for RUS
    legs, a joint its limit): same message, time, cause and partial result."""
    robot = get_robot(name)
    errors, blocks = [], []
    for integrator in ("python", "compiled"):
        run = prepare_run(robot, 3.0, dt=2e-3, backend="compiled", integrator=integrator)
        with pytest.raises(SimulationError) as e:
            run.go()
        errors.append(e.value)
        blocks.append(sum(len(r.times) for r in run.rows if isinstance(r, simulation._Block)))
    assert blocks[0] == 0 and blocks[1] > 10  # the C loop took the steps before the event
    a, b = errors
    assert str(a) == str(b) and a.time == b.time
    assert type(a.__cause__) is type(b.__cause__)
    _assert_same(a.result, b.result)
    assert b.result.t.size > 10


def test_energy_and_power_balance_on_the_c_loop():
    """Free motion (Gamma = 0): the reference path's energy is constant; driven by a
    force table: the actuators' work equals the energy gained (6-UPS, no friction)."""
    robot = get_robot("simulator")
    twist = np.array([0.02, -0.01, 0.05, 0.1, -0.05, 0.1])
    res, ran_c = _run(robot, 0.1, "compiled", twist=twist, dt=1e-3)
    assert ran_c
    E = robot.energy(res.poses, res.twists)
    scale = float(np.abs(E).max())
    assert np.abs(E - E[0]).max() < 1e-9 * scale
    g = _hover(robot)
    table = ForceTable(np.array([0.0, 0.1]), np.array([g * 0.98, g * 1.03]), "linear")
    res, ran_c = _run(robot, 0.1, "compiled", forces=table, dt=1e-3)
    assert ran_c
    E = robot.energy(res.poses, res.twists)
    dt = 1e-3
    # Five-point central differences of the energy: truncation O(dt^4).
    dE = (-E[4:] + 8 * E[3:-1] - 8 * E[1:-3] + E[:-4]) / (12 * dt)
    qd = np.einsum("nij,nj->ni", robot.inverse_jacobian(res.poses), res.twists)
    power = np.einsum("ni,ni->n", res.gammas, qd)[2:-2]
    assert np.abs(power).max() > 10.0  # the actuators do real work [W]
    assert np.abs(dE - power).max() < 1e-6 * np.abs(power).max()


def test_batch_runs_equal_single_runs():
    """Many initial states in one call (threads), one of them meeting its stroke end:
    each result is the single run's."""
    robot = get_robot("simulator")
    g = _hover(robot)
    rng = np.random.default_rng(5)
    twists = 0.05 * rng.standard_normal((4, 6))
    twists[3] = [0.0, 0.0, -5.0, 0.0, 0.0, 0.0]  # down fast: a stroke end within 0.1 s
    with pytest.raises(SimulationError, match="run 3: simulation stopped") as batch:
        simulate_batch(robot, 0.1, twists=twists, forces=g, dt=1e-3, backend="compiled", threads=2)
    with pytest.raises(SimulationError) as single:
        simulate(
            robot, 0.1, twist=twists[3], forces=g, dt=1e-3, backend="compiled", integrator="python"
        )
    assert str(batch.value) == f"run 3: {single.value}"
    _assert_same(batch.value.result, single.value.result)
    results = simulate_batch(
        robot,
        0.05,
        twists=twists[:3],
        forces=[g, g * 1.01, None],
        dt=1e-3,
        backend="compiled",
        threads=2,
    )
    for k, (f, res) in enumerate(zip([g, g * 1.01, None], results, strict=True)):
        ref = simulate(
            robot,
            0.05,
            twist=twists[k],
            forces=f,
            dt=1e-3,
            backend="compiled",
            integrator="python",
        )
        _assert_same(res, ref)


def test_batch_runs_under_computed_torque_at_every_stage_equal_python_runs():
    """The controller at every stage in a batch on two threads (each thread keeps its last
    reference evaluation; two controllers on different references, runs interleaved
    across the threads): each run equals the Python loop's."""
    robot = get_robot("simulator")
    motion = standard_motion(robot, "sinusoid", 0.05)
    fourier = _fourier(robot, np.random.default_rng(4))
    T0, V0, _ = motion(0.0)
    controllers = [
        ComputedTorqueController(robot, m, backend="compiled")
        for m in (motion, fourier, motion, fourier)
    ]
    twists = V0 + 1e-3 * np.random.default_rng(6).standard_normal((4, 6))
    opts = {"dt": 1e-3, "backend": "compiled"}
    for c in controllers[:2]:  # the C loop takes these runs (else: InputError)
        prepare_run(robot, 0.05, T0, V0, c, integrator="compiled", **opts)
    got = simulate_batch(robot, 0.05, [T0] * 4, twists, controllers, threads=2, **opts)
    for k, res in enumerate(got):
        ref = simulate(robot, 0.05, T0, twists[k], controllers[k], integrator="python", **opts)
        _assert_same(res, ref)


def test_force_table_values():
    """Held and interpolated values against NumPy's own interpolation."""
    times = np.array([0.0, 0.5, 2.0])
    values = np.arange(18.0).reshape(3, 6) ** 1.5
    linear, hold = ForceTable(times, values, "linear"), ForceTable(times, values)
    for t in (-1.0, 0.0, 0.2, 0.5, 1.3, 2.0, 5.0):
        expected = [np.interp(t, times, values[:, j]) for j in range(6)]
        np.testing.assert_allclose(linear(t), expected, rtol=1e-15)
        k = min(max(int(np.searchsorted(times, t, side="right")) - 1, 0), 2)
        np.testing.assert_array_equal(hold(t), values[k])
    with pytest.raises(InputError, match="interpolation"):
        ForceTable(times, values, "cubic")
    with pytest.raises(InputError, match="times"):
        ForceTable(times[::-1], values)


def test_force_tables_the_interpolation_would_overflow_are_refused():
    """Values beyond 1e150 (whose difference overflows: ``inf`` at mid-interval, where the
    exact value is 0) and times of infinite span (``inf`` weights) are refused, naming the
    bound; at the bound the interpolation is exact."""
    with pytest.raises(InputError, match=r"values\[0, 0\].*at most 1e\+150"):
        ForceTable([0.0, 1.0], [[-1e308] * 6, [1e308] * 6], "linear")
    with pytest.raises(InputError, match="span"):
        ForceTable([-1e308, 1e308], np.zeros((2, 6)), "linear")
    table = ForceTable([0.0, 1.0], [[-1e150] * 6, [1e150] * 6], "linear")
    np.testing.assert_array_equal(table(0.5), np.zeros(6))


def test_integrator_choice_is_checked():
    robot = get_robot("simulator")
    with pytest.raises(InputError, match="unknown integrator"):
        simulate(robot, 0.01, integrator="c")
    with pytest.raises(InputError, match=r"integrator='compiled'.*dynamics"):
        simulate(
            robot,
            0.01,
            dynamics=lambda t, T, V, g: np.zeros(6),
            backend="compiled",
            integrator="compiled",
        )
    with pytest.raises(InputError, match=r"integrator='compiled'.*not compiled"):
        simulate(robot, 0.01, backend="pinocchio", integrator="compiled")
    with pytest.raises(InputError, match=r"integrator='compiled'.*control_period"):
        simulate(
            robot,
            0.01,
            forces=lambda t, T, V: np.zeros(6),
            backend="compiled",
            integrator="compiled",
        )
    # The adaptive method with a controller whose reference C does not evaluate: its stage
    # times are not known before the run.
    motion = standard_motion(robot, "sinusoid", 0.01)
    ctl = ComputedTorqueController(robot, lambda t: motion(t), backend="compiled")
    with pytest.raises(InputError, match=r"integrator='compiled'.*control_period.*function"):
        simulate(
            robot, 0.01, forces=ctl, method="adaptive", backend="compiled", integrator="compiled"
        )


def test_cli_simulate_integrator(tmp_path, capsys):
    """``stewart-pin simulate --integrator``: the C loop's result file equals the Python
    loop's; a run it cannot take is one line and exit status 2."""
    from stewart_pin.cli import main

    args = ["simulate", "--preset", "simulator", "--motion", "sinusoid", "--duration", "0.1"]
    args += ["--backend", "compiled", "--no-progress"]
    for integrator in ("python", "compiled"):
        out = tmp_path / f"{integrator}.npz"
        assert main([*args, "--integrator", integrator, "-o", str(out)]) == 0
    _assert_same(
        simulation.SimulationResult.load(tmp_path / "compiled.npz"),
        simulation.SimulationResult.load(tmp_path / "python.npz"),
    )
    capsys.readouterr()
    bad = ["--integrator", "compiled", "--method", "adaptive", "--control-period", "3e-3"]
    assert main([*args, *bad, "--backend", "pinocchio", "-o", str(tmp_path / "x.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "integrator='compiled'" in err[0] and "not compiled" in err[0]


def test_runs_longer_than_one_output_chunk():
    """Over 4096 steps the C loop hands its rows over chunk by chunk (single runs and
    batches): every row kept, equal to the Python loop's (computed torque on a sinusoid,
    held over each step)."""
    from stewart_pin.codegen.simulator import CHUNK_ROWS

    robot = get_robot("simulator")
    duration = (CHUNK_ROWS + 200) * 1e-3
    motion = standard_motion(robot, "sinusoid", duration)
    T0, V0, _ = motion(0.0)
    ctl = ComputedTorqueController(robot, motion, backend="compiled")
    twists = np.array([V0, V0 + 1e-3])
    opts = {"forces": ctl, "control_period": 1e-3, "backend": "compiled"}
    ref = [simulate(robot, duration, T0, v, integrator="python", **opts) for v in twists]
    one, ran_c = _run(
        robot, duration, "compiled", pose=T0, twist=twists[0], forces=ctl, control_period=1e-3
    )
    assert ran_c and one.t.size == CHUNK_ROWS + 201
    _assert_same(one, ref[0])
    batch = simulate_batch(robot, duration, poses=[T0, T0], twists=twists, **opts)
    for got, want in zip(batch, ref, strict=True):
        _assert_same(got, want)


@pytest.mark.parametrize("max_condition", [1e6, 1e16])
def test_a_parallel_singularity_stops_both_loops_the_same_way(max_condition):
    """A platform spinning freely about z crosses a parallel singularity (det Jp^-1 changes
    sign). The C loop takes each stage's sign of det Jp^-1 from the determinant of the
    direct model's cheap condition check (max_condition 1e6), or from an LU of Jp^-1 when
    the threshold is too high for that determinant to decide (1e16: only the sign change
    stops the run): both stop as the Python loop does (the reference's Jp^-1 and
    ``np.linalg.det``), same message, time and partial result. (With the threshold at
    1e16 the last state lies where cond(Jp^-1) ~ 2e12: the value the message quotes
    amplifies the round-off between the two loops' states, so its digits are not
    compared.)"""
    d = get_robot("simulator").to_dict()
    d["stroke"], d["gravity"] = [1.5, 4.5], [0.0, 0.0, 0.0]
    robot = type(get_robot("simulator")).from_dict(d, max_condition=max_condition)
    T0 = robot.home_pose
    T0[:3, :3] = pin.exp3(np.array([0.0, 0.0, 1.45])) @ T0[:3, :3]
    V0 = np.array([0, 0, 0, 0, 0, 2.0])
    errors, blocks = [], []
    for integrator in ("python", "compiled"):
        run = prepare_run(robot, 0.2, T0, V0, dt=1e-3, backend="compiled", integrator=integrator)
        with pytest.raises(SimulationError) as e:
            run.go()
        errors.append(e.value)
        blocks.append(sum(len(r.times) for r in run.rows if isinstance(r, simulation._Block)))
    assert blocks[0] == 0 and blocks[1] > 10
    a, b = errors
    assert "parallel singularity" in str(b)
    assert ("det Jp^-1 changes sign" in str(b)) == (max_condition == 1e16)
    quoted = re.compile(r"cond\(Jp\^-1\) = [0-9.e+]+ here")
    assert quoted.sub("", str(a)) == quoted.sub("", str(b)) and a.time == b.time
    assert type(a.__cause__) is type(b.__cause__)
    _assert_same(a.result, b.result)


@pytest.mark.parametrize("name", ROBOTS)
def test_the_compiled_actuator_positions_and_sign_equal_the_reference(name):
    """The compiled loop's actuator positions (the library's generated ``sp_act_batch``:
    6-UPS leg lengths [m], RUS crank angles [rad]) equal the reference closed forms of
    ``robot.actuator_positions`` (NumPy) to 1e-12 at poses about home, and its sign of
    det Jp^-1 (the direct model's cheap condition check) equals the sign of
    ``np.linalg.det`` of the reference ``robot.inverse_jacobian``; above the threshold
    where that determinant decides, it leaves the sign to the reference (None)."""
    robot = get_robot(name)
    rng = np.random.default_rng(11)
    s = robot.description.stroke_mid
    poses = []
    for _ in range(20):
        T = robot.home_pose.copy()
        d = 0.02 * rng.standard_normal(6)
        T[:3, :3] = pin.exp3(d[3:]) @ T[:3, :3]
        T[:3, 3] += 0.5 * s * d[:3]
        poses.append(T)
    P = np.array(poses)
    run = prepare_run(robot, 0.01, backend="compiled", integrator="compiled")
    got = run.fast.actuator_positions(P)
    assert np.abs(got - robot.actuator_positions(P)).max() <= 1e-12
    ref_signs = np.sign(np.linalg.det(robot.inverse_jacobian(P)))
    assert [run.fast.det_sign(T) for T in P] == list(ref_signs)
    loose = type(robot)(robot.description, max_condition=1e9, convention="description")
    run = prepare_run(loose, 0.01, backend="compiled", integrator="compiled")
    assert run.fast.det_sign(P[0]) is None


def _close_1e13(got: np.ndarray, ref: np.ndarray) -> None:
    """Each output within 1e-13 of the reference, relative to max(|reference|, 1)."""
    err = np.abs(got - ref) / np.maximum(np.abs(ref), 1.0)
    assert err.max() <= 1e-13, (err.max(), got, ref)


@pytest.mark.parametrize("name", ROBOTS)
def test_the_simulators_models_equal_the_single_state_calls_to_1e_13(name):
    """The C loop's direct and inverse models (``sp_ddm_aux``, ``sp_idm_sim``: the AVX2+FMA
    copies of the generated code where the processor has both, contraction allowed) give
    the results of the single-state calls (the baseline copies, the Python loop's) to
    1e-13 relative per output (to the output's size, or to 1 for outputs under 1: the
    accelerations [m/s^2, rad/s^2] and forces [N, N m] at these states are of order 1 to
    1e3), at random states about home. Rounding once instead of twice moves a result by a
    few units in the last place; a wrong copy (another function, a lost term) moves it by
    far more."""
    import ctypes

    from stewart_pin.codegen.compiled import c_source

    robot = get_robot(name)
    source = c_source(robot.description)
    for copy in ("sp_ddm_avx2", "sp_idm_avx2"):
        assert f"SP_AVX2 static int {copy}(" in source and f"{copy}(arg, res" in source
    g0 = _hover(robot)
    rng = np.random.default_rng(7)
    run = prepare_run(robot, 0.01, backend="compiled", integrator="compiled")
    lib, chi = run.fast._models._lib, run.fast.sim.chi
    aux, out, det = np.empty(run.fast.sim.naux), np.empty(6), ctypes.c_double()
    for _ in range(50):
        T = robot.home_pose.copy()
        d = 0.02 * rng.standard_normal(6)
        T[:3, :3] = pin.exp3(d[3:]) @ T[:3, :3]
        T[:3, 3] += 0.5 * robot.description.stroke_mid * d[:3]
        V = 0.1 * rng.standard_normal(6)
        g = g0 * (1.0 + 0.05 * rng.standard_normal(6))
        flag = lib.sp_ddm_aux(
            *(ctypes.c_void_p(a.ctypes.data) for a in (T, V, g)),
            ctypes.c_void_p(chi),
            ctypes.c_double(robot.max_condition),
            ctypes.c_void_p(out.ctypes.data),
            ctypes.c_void_p(aux.ctypes.data),
            ctypes.byref(det),
        )
        assert flag == 0
        _close_1e13(out, robot.direct_dynamics(T, V, g, backend="compiled"))
        A, gamma, flags = 0.5 * rng.standard_normal(6), np.empty(6), np.zeros(1, np.int32)
        lib.sp_idm_sim(
            ctypes.c_longlong(1),
            *(ctypes.c_void_p(a.ctypes.data) for a in (T, V, A)),
            ctypes.c_void_p(chi),
            ctypes.c_double(robot.max_condition),
            ctypes.c_void_p(gamma.ctypes.data),
            ctypes.c_void_p(flags.ctypes.data),
        )
        assert flags[0] == 0
        _close_1e13(gamma, robot.inverse_dynamics(T, V, A, backend="compiled"))


@pytest.mark.parametrize("name", ROBOTS)
def test_the_simulators_guard_flags_states_as_the_batch_guard(name):
    """``sp_ddm_aux``'s guard (on AVX2+FMA processors its own copy: the input check
    without early exits, the cheap condition check summing ``||S||_F^2`` by columns)
    flags (or passes) every state the batch loop's scalar guard (``sp_ddm_batch``) does
    (the INPUT flag alike), at states
    from well inside to beyond the stroke ends and the condition threshold, with
    non-orthonormal rotations and non-finite inputs among them; where it passes, the sign
    of its determinant is that of ``np.linalg.det`` of the reference's ``Jp^-1``."""
    import ctypes

    robot = get_robot(name)
    g0 = _hover(robot)
    rng = np.random.default_rng(11)
    run = prepare_run(robot, 0.01, backend="compiled", integrator="compiled")
    lib, chi = run.fast._models._lib, run.fast.sim.chi
    aux, out, det = np.empty(run.fast.sim.naux), np.empty(6), ctypes.c_double()
    seen = set()
    for i in range(400):
        T = robot.home_pose.copy()
        d = (0.02 if i % 2 else 0.4) * rng.standard_normal(6)
        T[:3, :3] = pin.exp3(d[3:]) @ T[:3, :3]
        T[:3, 3] += robot.description.stroke_mid * d[:3]
        V = 0.1 * rng.standard_normal(6)
        g = g0 * (1.0 + 0.05 * rng.standard_normal(6))
        if i % 50 == 3:
            T[0, 0] += 1e-5  # not a rotation within the tolerance
        if i % 50 == 7:
            V[2] = np.nan
        if i % 50 == 9:
            g[4] = np.inf
        flag = lib.sp_ddm_aux(
            *(ctypes.c_void_p(a.ctypes.data) for a in (T, V, g)),
            ctypes.c_void_p(chi),
            ctypes.c_double(robot.max_condition),
            ctypes.c_void_p(out.ctypes.data),
            ctypes.c_void_p(aux.ctypes.data),
            ctypes.byref(det),
        )
        flags = np.zeros(1, np.int32)
        lib.sp_ddm_batch(
            ctypes.c_longlong(1),
            *(ctypes.c_void_p(a.ctypes.data) for a in (T, V, g)),
            ctypes.c_void_p(chi),
            ctypes.c_double(robot.max_condition),
            ctypes.c_void_p(np.empty(6).ctypes.data),
            ctypes.c_void_p(flags.ctypes.data),
        )
        # The C loop reads only whether a state is flagged; beyond a first flag (a leg
        # out of reach) the generated values are meaningless and FMA may change which
        # further flags they raise, so the INPUT flag and flagged or not are compared.
        assert (flag == 0) == (flags[0] == 0), (i, flag, flags[0])
        assert flag & 1 == flags[0] & 1, (i, flag, flags[0])
        seen.add(int(flag))
        if flag == 0 and det.value != 0.0:
            ref = np.linalg.det(robot.inverse_jacobian(T))
            assert np.sign(det.value) == np.sign(ref)
    assert 0 in seen and 1 in seen and len(seen) >= 3, seen  # accepted, INPUT and others
