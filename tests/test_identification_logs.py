"""Identification from actuator logs (issue 13, items 2-6): the log format and its named
errors, state estimation, the chunked least squares, physically consistent parameters,
exciting trajectories within actuator limits, and ``stewart-pin identify --log``.

References are independent of the code under test: closed-form derivatives of Fourier
trajectories (the states a log's positions come from), the robot's inverse dynamic model
(the efforts), ``numpy.linalg.lstsq`` / SVD on the whole stacked matrix (the chunked QR),
``numpy.convolve`` on the whole signal (the chunked FIR decimation), Monte-Carlo
statistics of filtered white noise (the noise correlation factor), the description's own
physical check (realisability) and the true parameters' base projection.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stewart_pin import (
    InertiaError,
    LogError,
    LogGapError,
    LogLimitError,
    LogSaturationError,
    LogTimeError,
    LogValueError,
    RobotDescription,
    StewartRobot,
    preset,
)
from stewart_pin.cli import main
from stewart_pin.description.inertia import check_physical
from stewart_pin.dynamics.regressor import parameter_groups, standard_parameters
from stewart_pin.motion.trajectories import FourierTrajectory
from stewart_pin.parameters.base import base_parameters
from stewart_pin.parameters.identification import (
    ActuatorLimits,
    Measurements,
    actuator_peaks,
    base_without,
    exciting_trajectory,
    identify,
    identify_log,
    log_equations,
    simulate_measurements,
)
from stewart_pin.parameters.least_squares import StackedLeastSquares
from stewart_pin.parameters.logs import ActuatorLog, hold_shift, read_log, write_log
from stewart_pin.parameters.physical import physically_consistent, pseudo_inertia
from stewart_pin.parameters.state_estimation import (
    PolyphaseDecimator,
    decimation_centres,
    design_filters,
    estimate_states,
    excitation_bandwidth,
    fir_decimate,
    noise_correlation,
    track_poses,
)

#: Encoder resolutions of the lab experiment: 1 um (slides), 2^-16 rad (cranks).
UM, RAD16 = 1e-6, 2.0**-16


def fourier(robot: StewartRobot, seed: int, scale: float = 0.1, f: float = 1.0, n: int = 3):
    """A smooth platform motion about home: translations ``scale`` x the robot's size,
    rotations ``scale`` rad, ``n`` harmonics of ``f`` Hz."""
    rng = np.random.default_rng(seed)
    amp = np.array([scale * robot.description.size] * 3 + [scale] * 3)[:, None]
    return FourierTrajectory(
        robot.home_pose,
        f,
        np.zeros(6),
        rng.uniform(-1, 1, (6, n)) * amp / n,
        rng.uniform(-1, 1, (6, n)) * amp / n,
    )


def exact_log(robot: StewartRobot, motion, rate: float, duration: float, noise=0.0, seed=0):
    """The log of ``motion`` sampled at ``rate`` [Hz]: exact actuator positions and the
    inverse dynamic model's efforts (plus Gaussian noise of std ``noise``), with the
    exact states for reference."""
    t = np.arange(round(duration * rate)) / rate
    s = motion.sample(t)
    gamma = robot.inverse_dynamics(s.poses, s.twists, s.accels)
    gamma = gamma + np.random.default_rng(seed).normal(size=gamma.shape) * noise
    return ActuatorLog(t, robot.actuator_positions(s.poses), gamma), s


@pytest.fixture(scope="module")
def ideal() -> StewartRobot:
    return StewartRobot.from_preset("random-2")


@pytest.fixture(scope="module")
def rus() -> StewartRobot:
    return StewartRobot.from_preset("rus")


# ====================================================================== item 2: the log


def test_log_round_trip_is_exact_with_tracker_and_hold(tmp_path, ideal):
    log, s = exact_log(ideal, fourier(ideal, 0), 100.0, 0.5)
    log = ActuatorLog(log.times, log.positions, log.efforts, s.poses, effort_hold=True)
    path = write_log(tmp_path / "log.csv", log)
    back = read_log(path, ideal)
    for name in ("times", "positions", "efforts"):
        np.testing.assert_array_equal(getattr(back, name), getattr(log, name))
    # The pose goes through a quaternion: a few 1e-16.
    np.testing.assert_allclose(back.tracker_poses, s.poses, rtol=0, atol=1e-15)
    assert back.effort_hold and back.line(0) == 3  # directive line, header, first sample


def test_simulation_csv_reads_as_a_log(tmp_path, ideal):
    """``stewart-pin simulate``'s CSV (states, forces, lengths) is a log with a tracker."""
    from stewart_pin import simulate

    result = simulate(ideal, 0.05, dt=1e-3)
    path = result.save(tmp_path / "run.csv")
    log = read_log(path, ideal, clip_run=0)
    np.testing.assert_array_equal(log.positions, result.lengths)
    np.testing.assert_array_equal(log.efforts, result.gammas)
    np.testing.assert_allclose(log.tracker_poses, result.poses, rtol=0, atol=1e-15)


HEADER = "t,l1,l2,l3,l4,l5,l6,gamma1,gamma2,gamma3,gamma4,gamma5,gamma6\n"


def _rows(robot: StewartRobot, n: int = 30, rate: float = 100.0) -> list[list[float]]:
    log, _ = exact_log(robot, fourier(robot, 1), rate, n / rate)
    return [[t, *q, *g] for t, q, g in zip(log.times, log.positions, log.efforts, strict=True)]


def _write(path, rows, header=HEADER, end="\n") -> None:
    text = header + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    path.write_text(text[:-1] + end if end != "\n" else text)


BAD_LOGS = {
    # name: (how to spoil row 10 (0-based, line 12), error, extra read_log arguments)
    "gap": (lambda rows: [r for k, r in enumerate(rows) if k not in (10, 11)], LogGapError),
    "time goes back": (
        lambda rows: [*rows[:10], [rows[8][0], *rows[10][1:]], *rows[11:]],
        LogTimeError,
    ),
    "irregular step": (
        lambda rows: [*rows[:10], [rows[9][0] + 0.001, *rows[10][1:]], *rows[11:]],
        LogTimeError,
    ),
    "position outside the stroke": (
        lambda rows: [*rows[:10], [*rows[10][:3], 9.0, *rows[10][4:]], *rows[11:]],
        LogLimitError,
    ),
    "non-finite effort": (
        lambda rows: [*rows[:10], [*rows[10][:8], math.nan, *rows[10][9:]], *rows[11:]],
        LogValueError,
    ),
}


@pytest.mark.parametrize("case", list(BAD_LOGS))
def test_bad_log_raises_a_named_error_with_its_line(tmp_path, ideal, case):
    spoil, error = BAD_LOGS[case]
    path = tmp_path / "bad.csv"
    _write(path, spoil(_rows(ideal)))
    with pytest.raises(error, match=r"bad\.csv, line 12: ") as info:
        read_log(path, ideal)
    assert info.value.line == 12 and isinstance(info.value, LogError)


def test_saturated_efforts_raise_with_their_line(tmp_path, ideal):
    rows = _rows(ideal)
    limit = 1.5 * max(abs(r[8]) for r in rows)
    rows[20][8] = limit  # line 22: gamma2 at its limit
    path = tmp_path / "sat.csv"
    _write(path, rows)
    with pytest.raises(LogSaturationError, match=r"line 22: actuator 2 effort .* at its limit"):
        read_log(path, ideal, effort_limits=limit)
    # The description's own limits apply too.
    robot = StewartRobot(ideal.description.replace(effort_limits=limit))
    with pytest.raises(LogSaturationError) as info:
        read_log(path, robot)
    assert info.value.line == 22 and info.value.column == "gamma2"
    # A clipped drive: gamma5 stuck at its extreme over 12 samples (lines 12-23).
    rows = _rows(ideal)
    top = max(r[11] for r in rows) + 1.0
    for r in rows[10:22]:
        r[11] = top
    _write(path, rows)
    with pytest.raises(LogSaturationError, match=r"line 12: .* 12 consecutive samples"):
        read_log(path, ideal)
    assert read_log(path, ideal, clip_run=0).efforts[15, 4] == top


def test_rus_crank_outside_its_limits_is_named(tmp_path, rus):
    rows = _rows(rus)
    rows[5][3] = 2.0  # line 7: crank 3 at 2 rad, its limits are [-pi/2, pi/2]
    path = tmp_path / "rus.csv"
    _write(path, rows)
    with pytest.raises(LogLimitError, match=r"line 7: actuator 3 position l3 = 2.0 rad"):
        read_log(path, rus)


@pytest.mark.parametrize(
    "text, match",
    [
        ("t,l1,l2\n0,1,2\n", r"line 1: missing columns"),
        (HEADER + "0,1,2\n", r"line 2: 3 fields, expected 13"),
        (HEADER + "0" + ",1" * 6 + ",x" + ",1" * 5 + "\n", r"line 2: column 'gamma1': 'x'"),
        (HEADER + "0" + ",1" * 12, r"line 2: no line break after the last line"),
        (HEADER.replace("gamma6", "gamma6,x,y,z") + "0" + ",1" * 15 + "\n", "tracker columns"),
    ],
)
def test_malformed_log_text_is_refused_with_its_line(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(LogError, match=match):
        read_log(path)


def test_forward_geometry_failure_names_the_line(ideal):
    """Positions no pose has (one leg at the top of its stroke, the others at the bottom)
    from sample 10 on: the continuation stops there with the line (sample + 2)."""
    lo, hi = ideal.description.stroke
    q = np.tile(ideal.actuator_positions(ideal.home_pose), (20, 1))
    q[10:, 0], q[10:, 1:] = hi, lo
    with pytest.raises(LogError, match=r"line 12: the forward geometry of the actuator"):
        track_poses(ideal, q, ideal.home_pose)
    t = np.arange(400) / 200.0
    q = np.tile(ideal.actuator_positions(ideal.home_pose), (400, 1))
    q[200:, 0], q[200:, 1:] = hi - 2e-3, lo + 2e-3
    efforts = np.random.default_rng(0).normal(size=(400, 6))
    log = ActuatorLog(t, q + 1e-3 * np.sin(2 * np.pi * t)[:, None], efforts)
    with pytest.raises(LogError, match=r"line \d+: the forward geometry"):
        estimate_states(ideal, log)


# ====================================================================== item 2: the states


@pytest.mark.parametrize("name", ["random-2", "rus"])
def test_states_from_positions_match_the_exact_motion(name, ideal, rus):
    """Exact positions of a Fourier motion at 500 Hz: poses to 1e-9 m, twists and
    classical accelerations to 1e-5 of their largest values (the filter's gain at the
    third harmonic and fourth-order differences: a few 1e-8 inside, the filter's start-up
    transient at the first used samples: 3e-6); with 1 um / 2^-16 rad encoders, the
    quantisation noise through the filter: 1e-3 / 1e-2 of the largest."""
    robot = ideal if name == "random-2" else rus
    motion = fourier(robot, 3)
    log, s = exact_log(robot, motion, 500.0, 3.0)
    design = design_filters(log)
    # Three harmonics of 1 Hz (the crank angles of RUS legs carry a fourth).
    assert 3.0 <= design.bandwidth <= 4.5
    est = estimate_states(robot, log, design)
    k = est.index
    np.testing.assert_allclose(est.poses, s.poses[k], rtol=0, atol=1e-9)
    for got, exact in ((est.twists, s.twists[k]), (est.accels, s.accels[k])):
        np.testing.assert_allclose(got, exact, rtol=0, atol=1e-5 * np.abs(exact).max())
        if name == "random-2":  # three harmonics exactly (crank angles carry more)
            middle = slice(len(k) // 4, 3 * len(k) // 4)
            assert np.abs(got - exact)[middle].max() <= 1e-7 * np.abs(exact).max()
    res = UM if name == "random-2" else RAD16
    q = np.round(log.positions / res) * res
    noisy = estimate_states(robot, ActuatorLog(log.times, q, log.efforts), design)
    tol = 1e-3 if name == "random-2" else 1e-2
    for got, exact in ((noisy.twists, s.twists[k]), (noisy.accels, s.accels[k])):
        assert np.sqrt(np.mean((got - exact) ** 2)) <= tol * np.abs(exact).max()


def test_excitation_bandwidth_of_known_sinusoids():
    t = np.arange(20000) / 1000.0  # 20 s at 1 kHz
    q = np.column_stack(
        [
            np.sin(2 * np.pi * 0.5 * t) + 0.1 * np.sin(2 * np.pi * f * t)
            for f in (2.0, 4.0, 6.0, 3.0, 1.0, 5.0)
        ]
    )
    # 99.9 % of the power: the second sinusoid (1 % of it) is inside the band.
    assert excitation_bandwidth(q, 1e-3) == pytest.approx(6.0, abs=0.1)


def test_noise_correlation_matches_filtered_white_noise():
    """kappa of the FIR decimation: the variance of means of blocks of decimated white
    noise (the long-run variance) over its variance, from 2e6 samples; the standard
    error of that ratio is about 2 %."""
    log = ActuatorLog(np.arange(3000) / 500.0, np.zeros((3000, 6)), np.zeros((3000, 6)))
    rng = np.random.default_rng(0)
    log = ActuatorLog(
        log.times,
        rng.normal(size=(3000, 6)) * 1e-3 + np.sin(2 * np.pi * 2 * log.times)[:, None],
        log.efforts,
    )
    design = design_filters(log)
    assert design.decimation > 1
    e = rng.normal(size=2_000_000)
    y = np.convolve(e, design.taps, mode="valid")[:: design.decimation]
    blocks = y[: len(y) // 200 * 200].reshape(-1, 200).mean(axis=1)
    ratio = 200 * blocks.var() / y.var()
    assert ratio == pytest.approx(design.kappa, rel=0.08)
    assert noise_correlation(np.ones(1), 1) == 1.0


def test_chunked_fir_decimation_equals_the_whole_signal(ideal):
    log, _ = exact_log(ideal, fourier(ideal, 4), 400.0, 2.0)
    design = design_filters(log)
    centres = decimation_centres(design, len(log))
    x = np.random.default_rng(1).normal(size=(len(log), 3, 2))
    whole = np.stack(
        [np.convolve(x[:, a, b], design.taps, mode="same") for a in range(3) for b in range(2)],
        axis=-1,
    ).reshape(len(log), 3, 2)[centres]
    parts = []
    for m in range(0, len(centres), 7):
        c = centres[m : m + 7]
        start = int(c[0]) - design.half
        parts.append(fir_decimate(x[start : int(c[-1]) + design.half + 1], design.taps, c, start))
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-14)
    # Streamed in batches of random sizes, each sample once (identify_log's way).
    fir = PolyphaseDecimator(design.taps, centres)
    got, a = [], 0
    for size in np.random.default_rng(2).integers(1, 300, size=10_000):
        if a >= len(log):
            break
        idx, (y,) = fir.push(a, x[a : a + size])
        got.append((idx, y))
        a += size
    idx = np.concatenate([i for i, _ in got])
    np.testing.assert_array_equal(idx, np.arange(len(centres)))
    np.testing.assert_allclose(np.concatenate([y for _, y in got]), whole, rtol=0, atol=1e-14)


def test_hold_shift_delays_by_half_a_sample():
    """A held sinusoid (each value the signal at the middle of its step) shifted back by
    half a sample is the sinusoid at the time stamps, to 1e-4 up to a fifth of the rate."""
    h = hold_shift()
    for f in (0.01, 0.05, 0.1, 0.2):  # [cycles per sample]
        k = np.arange(200)
        held = np.sin(2 * np.pi * f * (k + 0.5))
        j = np.arange(-len(h) // 2 + 1, len(h) // 2 + 1)
        shifted = [np.dot(h, held[m - j]) for m in range(40, 160)]
        np.testing.assert_allclose(shifted, np.sin(2 * np.pi * f * k[40:160]), atol=2e-4)


# ====================================================================== item 3: chunks


def test_incremental_qr_equals_the_stacked_least_squares():
    """Chunks of random sizes give the estimate, residuals and covariance of the SVD of
    the whole stacked matrix (badly scaled columns: condition number ~1e6)."""
    rng = np.random.default_rng(5)
    n, nb = 400, 12
    W = rng.normal(size=(n, 6, nb)) * np.logspace(-3, 3, nb)
    x = rng.normal(size=nb)
    y = W @ x + rng.normal(size=(n, 6)) * 0.01
    acc = StackedLeastSquares(nb)
    k = 0
    for size in rng.integers(1, 60, size=100):
        acc.add(W[k : k + size], y[k : k + size])
        k += size
        if k >= n:
            break
    assert acc.n_samples == n
    sol = acc.solve(weighted=False)
    A, b = W.reshape(-1, nb), y.reshape(-1)
    ref = np.linalg.lstsq(A, b, rcond=None)[0]
    # eps cond(W) ~ 1e-10 relative to the estimate's norm
    np.testing.assert_allclose(sol.estimate, ref, rtol=0, atol=1e-9 * np.linalg.norm(ref))
    r = b - A @ ref
    s2 = r @ r / (6 * n - nb)
    np.testing.assert_allclose(sol.covariance, s2 * np.linalg.inv(A.T @ A), rtol=1e-8)
    np.testing.assert_allclose(sol.residual_rms, np.sqrt(np.mean(r.reshape(n, 6) ** 2, 0)))
    assert sol.weighted_residual(ref + 1e-3) == pytest.approx(
        np.sum((b - A @ (ref + 1e-3)) ** 2), rel=1e-9
    )


def test_identify_log_does_not_depend_on_the_chunk_size(ideal):
    log, _ = exact_log(ideal, fourier(ideal, 5, f=0.5, n=4), 200.0, 8.0, noise=1.0)
    base = base_parameters(ideal)
    a = identify_log(ideal, log, base, chunk=300).result
    b = identify_log(ideal, log, base, chunk=5000).result
    # The poses solved from other warm starts differ by ~1e-13: the estimates by a
    # millionth of their standard deviations at most.
    assert np.all(np.abs(a.estimate - b.estimate) <= 1e-6 * a.std)
    np.testing.assert_allclose(a.std, b.std, rtol=1e-6)


# ====================================================================== item 4: physical


def test_physically_consistent_estimate_on_noise_free_data_is_the_base_projection():
    """Exact measurements of the RUS preset (friction, armature): least squares gives the
    true base parameters to 1e-9; the physically consistent estimate, started from
    another robot's parameters as prior, has the same base values to 1e-9 and passes
    the description's physical check."""
    robot = StewartRobot.from_preset("rus")
    base = base_without(base_parameters(robot), ["K", "OF", "FV@passive", "FC@passive"])
    states = robot.sample_states(60, 3)
    m = Measurements(np.arange(60) * 0.01, *states, robot.inverse_dynamics(*states))
    result = identify(robot, m, base)
    big = np.abs(base.values).max()
    np.testing.assert_allclose(result.estimate, base.values, rtol=0, atol=1e-9 * big)
    prior = preset("random-rus-1")
    est = physically_consistent(robot, result, prior=prior)
    np.testing.assert_allclose(est.base_values, base.values, rtol=0, atol=1e-9 * big)
    # Not merely the truth again: the null space came from the prior.
    assert np.abs(est.standard - standard_parameters(robot.description)).max() > 1e-3
    groups = parameter_groups(robot.description)
    for body in groups.bodies:
        check_physical(est.standard[body.index], body.name)
        assert np.linalg.eigvalsh(pseudo_inertia(est.standard[body.index]))[0] > 0
    assert np.all(est.standard[groups.nonnegative] >= 0)
    assert isinstance(est.description, RobotDescription)


def test_pseudo_inertia_is_psd_exactly_for_realisable_bodies():
    rng = np.random.default_rng(2)
    from stewart_pin.description.inertia import random_physical_khalil

    for _ in range(20):
        p = random_physical_khalil(rng, 1.3, 0.2, 0.1)
        assert np.linalg.eigvalsh(pseudo_inertia(p))[0] > 0
        bad = p.copy()
        bad[0] = p[3] + p[5] + 0.01  # XX > YY + ZZ breaks the triangle inequality
        assert np.linalg.eigvalsh(pseudo_inertia(bad))[0] < 0
        with pytest.raises(InertiaError):
            check_physical(bad, "body")


# ====================================================================== item 5: excitation


def test_exciting_trajectory_respects_actuator_limits(rus):
    """Limits at 90 % (efforts: gravity's share stays) and 60 % (velocities,
    accelerations) of a random draw's peaks: the optimised trajectory stays within
    95 % of them (the margin) at 300 samples of a period, by the inverse dynamic model
    and the kinematics (independent of the penalty's own evaluation), and is better
    conditioned than a draw shrunk onto the same limits."""
    base = base_without(base_parameters(rus), ["K", "OF", "FV@passive", "FC@passive"])
    draw, _cond_draw = exciting_trajectory(
        rus, base=base, base_frequency=1.0, n_harmonics=2, optimise=False, n_samples=300
    )
    peaks = actuator_peaks(rus, draw)
    limits = ActuatorLimits(
        0.9 * peaks["effort"], 0.6 * peaks["velocity"], 0.6 * peaks["acceleration"]
    )
    traj, cond = exciting_trajectory(
        rus,
        base=base,
        base_frequency=1.0,
        n_harmonics=2,
        limits=limits,
        max_evaluations=40,
        n_candidates=3,
        n_samples=300,
        n_grid=20,
    )
    got = actuator_peaks(rus, traj)
    for key in ("effort", "velocity", "acceleration"):
        assert np.all(got[key] <= 0.95 * getattr(limits, key) * (1 + 1e-9)), key
    shrunk, cond_shrunk = exciting_trajectory(
        rus,
        base=base,
        base_frequency=1.0,
        n_harmonics=2,
        limits=limits,
        optimise=False,
        n_samples=300,
        n_candidates=3,
    )
    peaks_shrunk = actuator_peaks(rus, shrunk)
    for key in ("effort", "velocity", "acceleration"):
        assert np.all(peaks_shrunk[key] <= 0.95 * getattr(limits, key) * (1 + 1e-9)), key
    assert cond < cond_shrunk  # the optimiser improves on the draw under the same limits
    # From the description: the same limits by its keys.
    desc = rus.description.replace(
        effort_limits=limits.effort,
        velocity_limits=limits.velocity,
        acceleration_limits=limits.acceleration,
    )
    assert ActuatorLimits.of(StewartRobot(desc)).effort.tolist() == limits.effort.tolist()


# ====================================================================== item 6: CLI


def test_cli_identify_log_writes_the_physical_robot(tmp_path, capsys, ideal):
    traj, _ = exciting_trajectory(
        ideal, base_frequency=0.5, n_harmonics=3, seed=1, optimise=False, n_samples=10
    )
    log, _ = exact_log(ideal, traj.fourier, 200.0, 8.0, noise=0.5, seed=1)
    path = write_log(tmp_path / "log.csv", log)
    val, _ = exact_log(ideal, fourier(ideal, 6, f=0.5), 200.0, 4.0, noise=0.5, seed=2)
    vpath = write_log(tmp_path / "val.csv", val)
    desc = ideal.description.write(tmp_path / "robot.toml")
    out = tmp_path / "out"
    code = main(
        [
            "identify",
            "--description",
            str(desc),
            "--log",
            str(path),
            "--validation-log",
            str(vpath),
            "--physical",
            "--write-description",
            str(out / "id.toml"),
            "--write-urdf",
            str(out / "id.urdf"),
            "--write-mjcf",
            str(out / "id.xml"),
            "--no-progress",
            "-o",
            str(out / "report.txt"),
        ]
    )
    text = capsys.readouterr().out
    assert code == 0, text
    assert "88 base parameters" in text and "physically consistent" in text
    assert "% (least squares)" in text and "% (physically consistent)" in text
    identified = RobotDescription.read(out / "id.toml")  # validated on reading
    robot = StewartRobot(identified)
    assert (out / "id.urdf").exists() and (out / "id.xml").exists()
    mujoco = pytest.importorskip("mujoco")
    mujoco.MjModel.from_xml_path(str(out / "id.xml"))
    # The identified robot predicts the validation efforts (noise 0.5 N) to ~1 %.
    s = fourier(ideal, 6, f=0.5).sample(val.times)
    pred = robot.inverse_dynamics(s.poses, s.twists, s.accels)
    exact = ideal.inverse_dynamics(s.poses, s.twists, s.accels)
    assert np.linalg.norm(pred - exact) <= 0.05 * np.linalg.norm(exact)


def test_cli_identify_bad_log_is_one_line_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text(HEADER + "0" + ",1" * 12 + "\n" + "0" + ",1" * 12 + "\n")
    code = main(["identify", "--preset", "random-2", "--log", str(path), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "line 3" in err and "does not increase" in err
    code = main(
        [
            "identify",
            "--preset",
            "random-2",
            "--log",
            str(path),
            "--write-urdf",
            str(tmp_path / "x.urdf"),
        ]
    )
    assert code == 2 and "--physical" in capsys.readouterr().err


def test_log_equations_hold_the_true_parameters_on_exact_data(ideal):
    """Exact positions and inverse-dynamics efforts: the decimated equations hold the true
    base parameters to 1e-6 of the efforts (filters and differences only)."""
    log, _ = exact_log(ideal, fourier(ideal, 7, f=0.5, n=4), 500.0, 6.0)
    base = base_parameters(ideal)
    design = design_filters(log)
    r = np.concatenate(
        [g - W @ base.values for _, W, g, _ in log_equations(ideal, log, base, design)]
    )
    assert np.sqrt(np.mean(r**2)) <= 1e-6 * np.sqrt(np.mean(log.efforts**2))


def test_simulated_measurements_still_identify(ideal):
    """The measurement CSV path (states given) is unchanged by the chunked solver."""
    traj, _ = exciting_trajectory(ideal, n_samples=60, seed=2, optimise=False)
    result = identify(ideal, simulate_measurements(ideal, traj))
    big = np.abs(result.base.values).max()
    np.testing.assert_allclose(result.estimate, result.base.values, rtol=0, atol=1e-8 * big)
