"""Time integration on SE(3): checked by physics (energy), by replaying the inverse
model's forces (the commanded motion must come back), by analytic free fall, and by the
workspace and singularity guards."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from helpers import leg_lengths_by_hand

from stewart_pin import StewartRobot, exceptions
from stewart_pin.cli import main
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.exceptions import (
    ConvergenceError,
    InputError,
    JointLimitError,
    SingularityError,
    StewartPinError,
    StrokeLimitError,
)
from stewart_pin.motion import simulation
from stewart_pin.motion.simulation import SimulationError, SimulationResult, simulate


@pytest.fixture(scope="module")
def desktop() -> StewartRobot:
    return StewartRobot.from_preset("desktop")


def reference(robot: StewartRobot, t: float):
    """A multi-axis sinusoid: exact pose, twist and classical acceleration."""
    T0 = robot.home_pose
    s = robot.description.stroke_mid
    amp, om = np.array([0.06, -0.05, 0.04]) * s, np.array([3.0, 2.0, 4.0])
    p = T0[:3, 3] + amp * np.sin(om * t)
    v = amp * om * np.cos(om * t)
    a = -amp * om**2 * np.sin(om * t)
    n = np.array([0.4, -0.3, 0.866])
    n /= np.linalg.norm(n)
    th, thd, thdd = 0.08 * np.sin(2.5 * t), 0.2 * np.cos(2.5 * t), -0.5 * np.sin(2.5 * t)
    T = np.eye(4)
    T[:3, :3] = pin.exp3(th * n) @ T0[:3, :3]
    T[:3, 3] = p
    return T, np.concatenate([v, thd * n]), np.concatenate([a, thdd * n])


@pytest.mark.parametrize(("name", "rtol"), [("simulator", 1e-9)])
def test_inverse_model_forces_replay_the_commanded_motion(name, rtol):
    """Open loop: Gamma(t) from the inverse model along a 2 s trajectory, fed to the
    direct model through the adaptive integrator, reproduces the trajectory.

    The open-loop plant is unstable (nothing corrects a deviation), so the global error
    grows from the local tolerance: 3e-9 m for the simulator at rtol 1e-9; the small,
    fast desktop robot needs rtol 1e-12 (2e-8 m, 10 s of run time; 2e-6 m at rtol 1e-10)."""
    robot = StewartRobot.from_preset(name)

    def forces(t, T, V):
        return robot.inverse_dynamics(*reference(robot, t))

    T0, V0, _ = reference(robot, 0.0)
    res = simulate(robot, 2.0, T0, V0, forces, method="adaptive", rtol=rtol, atol=rtol * 1e-2)
    assert res.t[-1] == pytest.approx(2.0, abs=1e-12)
    # Pose error in metres: the largest displacement of the six platform points P_i.
    P = robot.description.platform_points
    errors = [
        np.abs((P @ T[:3, :3].T + T[:3, 3]) - (P @ Tr[:3, :3].T + Tr[:3, 3])).max()
        for T, Tr in ((T, reference(robot, t)[0]) for t, T in zip(res.t, res.poses, strict=True))
    ]
    assert max(errors) < 1e-6  # [m]


def _energy_drift(robot, **kwargs) -> float:
    # Thrown upwards and tumbling, it flies for 0.12 s before a leg reaches its stroke end.
    twist = np.array([0.05, -0.04, 0.4, 0.3, -0.2, 0.4])
    res = simulate(robot, 0.12, twist=twist, **kwargs)
    E = robot.energy(res.poses, res.twists)
    return float(np.abs(E - E[0]).max())


def test_energy_is_conserved_in_free_motion(desktop):
    """Gamma = 0 under gravity: the total energy is constant to the integrator's error,
    which falls as dt^4 for RK4, and stays within the adaptive method's tolerance."""
    scale = abs(desktop.energy(desktop.home_pose, np.zeros(6)))
    coarse = _energy_drift(desktop, method="rk4", dt=4e-3)
    fine = _energy_drift(desktop, method="rk4", dt=2e-3)
    assert fine < 1e-8 * scale
    assert coarse / fine > 10.0  # order 4: ideally 16
    adaptive = _energy_drift(desktop, method="adaptive", rtol=1e-10, atol=1e-12)
    assert adaptive < 1e-8 * scale


def test_rotation_stays_on_so3(desktop):
    res = simulate(desktop, 0.06, twist=[0, 0, 0, 1.0, -0.5, 0.8], dt=2e-3)
    R = res.poses[:, :3, :3]
    assert np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max() < 1e-13


def test_leaving_the_stroke_stops_with_the_partial_result(desktop):
    """Unpowered, the platform falls until a leg reaches its shortest length."""
    with pytest.raises(SimulationError, match=r"stopped at t = .* leg \d length") as e:
        simulate(desktop, 2.0, dt=2e-3)
    partial = e.value.result
    assert 0 < e.value.time < 2.0 and len(partial.t) > 2
    assert partial.lengths.min() >= desktop.description.stroke[0]
    # Falling from rest: the platform has gone down.
    assert partial.poses[-1, 2, 3] < partial.poses[0, 2, 3]


def test_zero_order_hold(desktop):
    calls = []

    def forces(t, T, V):
        calls.append(t)
        return desktop.gravity_compensation(T)

    res = simulate(desktop, 0.05, forces=forces, dt=1e-3, control_period=1e-2)
    held = res.gammas
    # Forces change only at the 10 ms samples.
    changes = np.flatnonzero(np.abs(np.diff(held, axis=0)).max(axis=1) > 0) + 1
    assert set(np.round(res.t[changes], 9)) <= {0.01, 0.02, 0.03, 0.04, 0.05}
    with pytest.raises(InputError, match="whole multiple"):
        simulate(desktop, 0.05, dt=3e-3, control_period=1e-2)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_save_and_load(desktop, tmp_path, suffix):
    res = simulate(desktop, 0.02, twist=[0.01, 0, 0, 0, 0, 0.1], dt=5e-3)
    back = SimulationResult.load(res.save(tmp_path / f"run{suffix}"))
    for name in ("t", "poses", "twists", "accels", "gammas", "lengths"):
        np.testing.assert_allclose(getattr(back, name), getattr(res, name), rtol=1e-15, atol=1e-15)


# ---------------------------------------------------------------------- stops and events
def _stopped(robot: StewartRobot, duration: float, **kwargs) -> SimulationError:
    with pytest.raises(SimulationError) as e:
        simulate(robot, duration, **kwargs)
    return e.value


def _quoted(message: str, what: str) -> float:
    """The number a stop message gives for ``what`` (``length`` [m] or ``= `` [rad])."""
    return float(re.search(rf"{what} ([-0-9.e+]+) (?:m|rad) reached", message).group(1))


def _free_fall_reference(robot: StewartRobot) -> float:
    """Massless legs: the platform falls freely from rest at the home pose, p(t) = p0 +
    g t^2 / 2 with R constant. The time [s] the first leg reaches the lower stroke end,
    from |d_i - h e_z| = l_min (d_i = B_i P_i at home, h the drop)."""
    desc = robot.description
    T0, lo, g = robot.home_pose, desc.stroke[0], -desc.gravity[2]
    d = desc.platform_points @ T0[:3, :3].T + T0[:3, 3] - desc.base_points
    drop = d[:, 2] - np.sqrt(d[:, 2] ** 2 - (d**2).sum(axis=1) + lo**2)
    return float(np.sqrt(2 * drop.min() / g))


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
def test_free_fall_of_a_massless_leg_robot_stops_at_the_analytic_stroke_time(method):
    """Massless legs pass no force: the platform falls at g, and both integrators stop at
    the analytic instant a leg reaches its shortest length. Located to 1e-6 of the longest
    stroke length (2.8 um; the leg shortens at ~2.4 m/s, so within 1.2 us before the
    analytic time); the pose stays on the free-fall parabola (RK4 and Dormand-Prince are
    exact on a constant acceleration: 1e-12 m)."""
    d = StewartRobot.from_preset("simulator").to_dict()
    d["leg_inertia"] = np.zeros((6, 3, 10)).tolist()
    robot = StewartRobot.from_dict(d)
    desc, T0 = robot.description, robot.home_pose
    t_ref = _free_fall_reference(robot)
    err = _stopped(robot, 1.0, method=method)
    res = err.result
    assert isinstance(err.__cause__, StrokeLimitError)
    assert err.time == res.t[-1]
    assert t_ref - 2e-6 < err.time <= t_ref + 1e-12
    last = leg_lengths_by_hand(desc, res.poses[-1])
    assert 0.0 <= last.min() - desc.stroke[0] <= 1e-6 * desc.stroke[1]
    # The message quotes the located (accepted) length, not a rejected trial's.
    assert _quoted(str(err), "length") == pytest.approx(last.min(), abs=1e-8)
    # Accepted states only: every reported length inside the stroke.
    assert res.lengths.min() >= desc.stroke[0]
    g = desc.gravity
    expected = T0[:3, 3] + 0.5 * np.outer(res.t**2, g)
    np.testing.assert_allclose(res.poses[:, :3, 3], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        res.poses[:, :3, :3], np.broadcast_to(T0[:3, :3], (len(res.t), 3, 3)), atol=1e-13
    )


def test_both_integrators_stop_a_free_fall_at_the_same_located_stroke_end(simulator):
    """The simulator preset falling from rest (legs with mass): RK4 and the adaptive method
    stop at the same instant (the leg reaches the stroke end at ~2.4 m/s: 2.8 um is ~1 us),
    the shortest leg at the lower stroke limit. A trial stage leaving the stroke shrinks the
    step instead of stopping the adaptive run early (it used to stop at 0.257 s with the
    shortest leg at 2.117 m, quoting a rejected state's 1.993 m)."""
    desc = simulator.description
    stops = {m: _stopped(simulator, 2.0, method=m) for m in ("rk4", "adaptive")}
    for err in stops.values():
        shortest = leg_lengths_by_hand(desc, err.result.poses[-1]).min()
        assert 0.0 <= shortest - desc.stroke[0] <= 1e-6 * desc.stroke[1]
        assert _quoted(str(err), "length") == pytest.approx(shortest, abs=1e-8)
        assert err.result.lengths.min() >= desc.stroke[0]
    assert stops["rk4"].time == pytest.approx(stops["adaptive"].time, abs=3e-6)
    assert stops["rk4"].time == pytest.approx(0.30668, abs=1e-4)


def test_a_u_joint_limit_is_located_by_both_integrators():
    """The desktop robot with |q1i| <= 0.05 rad falls until a first U-joint angle reaches
    0.05 rad (before any stroke end): located to 1e-6 rad, at the same time by both."""
    d = StewartRobot.from_preset("desktop").to_dict()
    d["u_joint_limits"] = [[-0.05, 0.05], [0.1, np.pi - 0.1]]
    robot = StewartRobot.from_dict(d)
    stops = {m: _stopped(robot, 1.0, method=m, dt=2e-3) for m in ("rk4", "adaptive")}
    for err in stops.values():
        assert isinstance(err.__cause__, JointLimitError)
        assert re.search(r"U-joint angle q1\d = .* reached its upper limit", str(err))
        q1 = robot.inverse_geometry(err.result.poses[-1], check_limits=False)[:, 0]
        assert 0.0 <= 0.05 - q1.max() <= 1e-6
        assert _quoted(str(err), "=") == pytest.approx(q1.max(), abs=1e-8)
    assert stops["rk4"].time == pytest.approx(stops["adaptive"].time, abs=1e-5)


def _spinning_robot(max_condition: float) -> StewartRobot:
    """The simulator's geometry with a stroke wide enough to twist it by 90 degrees about
    z, where det Jp^-1 changes sign (a parallel singularity), and no gravity."""
    d = StewartRobot.from_preset("simulator").to_dict()
    d["stroke"], d["gravity"] = [1.5, 4.5], [0.0, 0.0, 0.0]
    return StewartRobot.from_dict(d, max_condition=max_condition)


def _advance(T: np.ndarray, V: np.ndarray, dt: float) -> np.ndarray:
    """The pose ``dt`` [s] further along the twist V (first order)."""
    out = T.copy()
    out[:3, :3] = pin.exp3(V[3:] * dt) @ T[:3, :3]
    out[:3, 3] += V[:3] * dt
    return out


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
@pytest.mark.parametrize("max_condition", [1e6, 1e16])
def test_stepping_over_a_parallel_singularity_stops_with_a_singularity_error(
    method, max_condition
):
    """A platform spinning freely about z from a 1.45 rad twist reaches the singular twist
    (~1.575 rad) after ~0.06 s. A step jumps over the thin region where cond(Jp^-1) passes
    its threshold (the run used to complete, det Jp^-1 changing sign between two states);
    now every stage's sign of det Jp^-1 is watched: the run stops just before the crossing,
    every reported state on the starting side. With the threshold at 1e16 only the sign
    change can catch it."""
    robot = _spinning_robot(max_condition)
    T0 = robot.home_pose
    T0[:3, :3] = pin.exp3(np.array([0.0, 0.0, 1.45])) @ T0[:3, :3]
    V0 = np.array([0, 0, 0, 0, 0, 2.0])
    err = _stopped(robot, 0.2, pose=T0, twist=V0, method=method)
    assert isinstance(err.__cause__, SingularityError)
    assert "parallel singularity" in str(err)
    assert ("det Jp^-1 changes sign" in str(err)) == (max_condition == 1e16)
    res = err.result
    assert 0.03 < err.time < 0.1 and err.time == res.t[-1]
    signs = np.sign(np.linalg.det(robot.inverse_jacobian(res.poses)))
    assert np.all(signs == signs[0])
    # The crossing is right ahead: 1e-4 s further along the last twist the sign differs.
    ahead = _advance(res.poses[-1], res.twists[-1], 1e-4)
    assert np.sign(np.linalg.det(robot.inverse_jacobian(ahead))) == -signs[0]
    assert robot.condition_number(res.poses[-1]) <= max_condition


# ---------------------------------------------------------------------- callbacks
def test_a_raising_controller_keeps_the_partial_result(desktop):
    """A controller that raises stops the run with SimulationError chaining its exception
    (not the raw exception), and the accepted states so far are kept: they are the same
    states as a clean run over that time."""
    failure = RuntimeError("controller lost")

    def forces(t, T, V):
        if t > 0.0105:
            raise failure
        return desktop.gravity_compensation(T)

    err = _stopped(desktop, 0.05, forces=forces, dt=1e-3)
    assert err.__cause__ is failure
    assert "forces(t, pose, twist) raised RuntimeError" in str(err)
    assert simulation.SimulationError is exceptions.SimulationError
    assert isinstance(err, StewartPinError)
    res = err.result
    assert res.t[-1] == pytest.approx(0.010, abs=1e-12) and err.time == res.t[-1]
    clean = simulate(desktop, res.t[-1], forces=forces, dt=1e-3)
    np.testing.assert_array_equal(res.poses, clean.poses)
    np.testing.assert_array_equal(res.gammas, clean.gammas)


def test_a_raising_progress_callback_keeps_the_partial_result(desktop):
    calls = []

    def progress(t):
        calls.append(t)
        if len(calls) == 3:
            raise KeyError("progress bar closed")

    for method in ("rk4", "adaptive"):
        calls.clear()
        err = _stopped(desktop, 0.05, method=method, dt=1e-3, progress=progress)
        assert isinstance(err.__cause__, KeyError)
        assert "progress(t) raised KeyError" in str(err)
        assert len(err.result.t) == 4 and err.result.t[-1] == calls[-1]  # t = 0 and 3 steps


def test_cli_simulate_saves_the_partial_result_beside_the_output(tmp_path, capsys, desktop):
    """``stewart-pin simulate`` of a run that stops: exit 2, one line naming the partial
    result ``<stem>.partial<suffix>``, which holds the accepted states up to the stop."""
    for suffix in (".npz", ".csv"):
        out = tmp_path / f"run{suffix}"
        args = ["simulate", "--preset", "desktop", "--motion", "free", "--duration", "2"]
        code = main(
            [*args, "--backend", "pinocchio", "--dt", "2e-3", "-o", str(out), "--no-progress"]
        )
        assert code == 2
        err = capsys.readouterr().err
        partial = tmp_path / f"run.partial{suffix}"
        assert err.count("\n") == 1 and str(partial) in err and "stopped at t =" in err
        assert not out.exists()
        res = SimulationResult.load(partial)
        assert 0.05 < res.t[-1] < 0.2 and res.lengths.min() >= desktop.description.stroke[0]
        assert res.lengths[-1].min() - desktop.description.stroke[0] <= 1e-6 * 0.19


# ---------------------------------------------------------------------- bounds
def _trap(t):
    raise AssertionError("simulate started a run it should have refused")


@pytest.mark.parametrize(
    "kwargs",
    [
        {"duration": np.inf},
        {"duration": np.nan},
        {"duration": -1.0},
        {"duration": 0.0},
        {"duration": "2"},
        {"duration": True},
        {"dt": 1e-300},
        {"dt": 0.0},
        {"dt": np.inf},
        {"dt": 1e-13},
        {"duration": 1e6, "dt": 1e-3},
        {"method": "adaptive", "dt": 1e-300},
        {"method": "adaptive", "control_period": 1e-300},
        {"control_period": np.nan},
        {"rtol": -1e-9, "method": "adaptive"},
        {"atol": np.nan, "method": "adaptive"},
        {"output_dt": 0.0},
    ],
)
def test_unbounded_durations_and_steps_are_refused_up_front(desktop, kwargs):
    """Infinite or NaN durations and steps, a dt of 1e-300 (these ran forever), more than
    MAX_STEPS steps, and non-positive tolerances: InputError before the first step."""
    kwargs = {"duration": 0.01, **kwargs}
    with pytest.raises(InputError):
        simulate(desktop, kwargs.pop("duration"), progress=_trap, **kwargs)


def test_cli_refuses_a_vanishing_step_in_one_line(tmp_path, capsys):
    out = tmp_path / "run.npz"
    assert main(["simulate", "--dt", "1e-300", "--no-progress", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "dt = 1e-300 s is below the smallest step" in err
    assert not out.exists() and not (tmp_path / "run.partial.npz").exists()


def test_step_count_bound(desktop, monkeypatch):
    """With MAX_STEPS at 5: rk4 beyond it is refused up front; the adaptive method stops
    after 5 accepted steps with the partial result."""
    monkeypatch.setattr(simulation, "MAX_STEPS", 5)
    with pytest.raises(InputError, match=r"more than the bound 5e\+00"):
        simulate(desktop, 0.01, dt=1e-3)
    err = _stopped(desktop, 0.01, method="adaptive", dt=1e-5)
    assert "5 accepted steps" in str(err) and len(err.result.t) == 6


def test_the_adaptive_step_stops_at_its_minimum(desktop):
    """Forces that no step resolves (fresh noise at every call): the error control shrinks
    the step to MIN_STEP, then the run stops with the accepted states so far."""
    rng = np.random.default_rng(0)

    def noisy(t, T, V):
        base = desktop.gravity_compensation(T)
        return base if t < 2e-3 else base + rng.normal(0.0, 100.0, 6)

    err = _stopped(desktop, 0.01, forces=noisy, method="adaptive")
    assert "adaptive step fell below" in str(err)
    assert isinstance(err.__cause__, ConvergenceError) and err.__cause__.residual > 1.0
    assert 0 < err.time < 2e-3 + 1e-12 and err.result.t[-1] == err.time


def test_zero_order_hold_samples_accepted_states_only(desktop):
    """With a control period, the controller sees the accepted state at the start of each
    period, never a trial stage (RK4 used to sample its fourth stage, the adaptive method
    whichever stage came first): every call is at a period start, with exactly the pose
    reported there; both integrators then agree on the motion."""
    runs = {}
    for method in ("rk4", "adaptive"):
        calls = []

        def forces(t, T, V, calls=calls):
            calls.append((t, T.copy()))
            return desktop.gravity_compensation(T) * 1.02 - 0.5 * V

        res = simulate(
            desktop,
            0.05,
            forces=forces,
            method=method,
            dt=1e-3,
            control_period=0.01,
            rtol=1e-11,
            atol=1e-13,
        )
        times = np.array([t for t, _ in calls])
        np.testing.assert_allclose(times, 0.01 * np.arange(len(times)), rtol=0, atol=1e-15)
        for t, T in calls:
            k = int(np.argmin(np.abs(res.t - t)))
            assert res.t[k] == pytest.approx(t, abs=1e-15)
            np.testing.assert_array_equal(T, res.poses[k])
        runs[method] = res
    end = {m: r.poses[-1][:3, 3] for m, r in runs.items()}
    np.testing.assert_allclose(end["rk4"], end["adaptive"], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------- time grid
def _at_rest(t, T, V, gamma):
    """A direct model that holds the platform still (zero acceleration): the time grid
    alone is under test, at no cost."""
    return np.zeros(6)


@pytest.mark.parametrize(
    ("kwargs", "step"),
    [
        ({"dt": 1e-3}, 1e-3),
        ({"dt": 1e-3, "control_period": 5e-3}, 1e-3),
        ({"dt": 1e-3, "output_dt": 5e-3}, 5e-3),
        ({"method": "adaptive", "dt": 1e-3, "output_dt": 1e-3}, 1e-3),
        ({"method": "adaptive", "control_period": 1e-3, "output_dt": 1e-3}, 1e-3),
    ],
)
def test_one_sample_per_grid_time(desktop, kwargs, step):
    """Past t = 1 s the rk4 grid was built by accumulation: every step split in two, 2.2e-16
    s apart (2497 samples for 2 s at 1e-3 s instead of 2001). The samples are the grid
    ``k * step`` exactly, bit for bit, one per grid time, for either integrator."""
    res = simulate(desktop, 2.0, dynamics=_at_rest, **kwargs)
    grid = np.arange(round(2.0 / step) + 1) * step
    assert len(res.t) == len(grid)
    np.testing.assert_array_equal(res.t, grid)


def test_cli_simulate_output_reads_as_an_identification_log(
    tmp_path, capsys, shared_compile_cache
):
    """The documented path ``simulate -o run.csv`` then ``identify --log run.csv``: the
    split grid steps past t = 1 s made the log fail with "irregular sampling". A 1.5 s run
    (past 1 s; the short log asks for a wider state filter and no decimation). The Python
    integrator (whose grid it was) on the compiled direct model: the reference path's
    6000 calls on the cranks took 12 s of the suite."""
    log = tmp_path / "run.csv"
    args = ["--preset", "rus", "--backend", "compiled", "--integrator", "python"]
    args += ["--duration", "1.5", "--no-progress"]
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(compiled_module.CACHE_ENV, str(shared_compile_cache))
        assert main(["simulate", *args, "-o", str(log)]) == 0
    t = np.loadtxt(log, delimiter=",", comments="#", skiprows=1, usecols=0)
    np.testing.assert_array_equal(t, np.arange(1501) * 1e-3)
    # the cranks' torques [N m] through angles [rad] (the torques were labelled N)
    assert re.search(r"peak \|Gamma\| \S+ N m; .* rad$", capsys.readouterr().out, re.M)
    ident = ["--cutoff", "50", "--decimation", "1", "--no-progress"]
    assert main(["identify", "--preset", "rus", "--log", str(log), *ident]) == 0
    out, err = capsys.readouterr()
    assert "irregular" not in err
    assert "noise std (from the residuals) [N m]:" in out and "[N]" not in out
