"""Hardening of the log and CSV readers and the command line (issue 25, items 13-18 and
the physical fit's credibility of item 20).

References are independent of the code under test: hand-written file texts (numbers as
CSV tools write them, and the spellings Python's ``float`` also accepts), the sizes of
the machine (``os.sysconf``), signals sent to a child process, and an effort log whose
sign was flipped (a fit no physical robot can make).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stewart_pin.exceptions import FileFormatError, LogError, LogValueError
from stewart_pin.formats.csv_tables import MAX_LINE_LENGTH, STATE_COLUMNS, read_csv
from stewart_pin.parameters.logs import MAX_MAGNITUDE, read_log

HEADER = "t,l1,l2,l3,l4,l5,l6,gamma1,gamma2,gamma3,gamma4,gamma5,gamma6\n"


def _log_text(n: int = 12, field: str | None = None, row: int = 5, column: int = 8) -> str:
    """A plain log of ``n`` samples at 100 Hz (positions 0.5 m, efforts 10 N plus a ramp);
    ``field`` replaces column ``column`` of sample ``row`` (line ``row + 2``)."""
    lines = [HEADER]
    for k in range(n):
        values = [repr(k / 100.0)] + ["0.5"] * 6 + [repr(10.0 + 0.1 * k + j) for j in range(6)]
        if field is not None and k == row:
            values[column] = field
        lines.append(",".join(values) + "\n")
    return "".join(lines)


# ====================================================================== item 13: numbers

ACCEPTED = ["12.5", " 12.5 ", "+12.5", "1.25e1", "1.25E+01", "125e-1", ".125e2", "0012.50"]
REFUSED = {
    "digit separator": "1_2.5",
    "Arabic-Indic digits": "\u0661\u0662.\u0665",
    "non-breaking space": "\u00a012.5",
    "tab": "\t12.5",
    "full-width digits": "\uff11\uff12",
    "hex": "0x12",
}


@pytest.mark.parametrize("text", ACCEPTED)
def test_log_reads_numbers_as_csv_tools_write_them(tmp_path, text):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field=text), encoding="utf-8")
    assert read_log(path).efforts[5, 1] == 12.5


@pytest.mark.parametrize("case", list(REFUSED))
def test_log_refuses_what_python_float_alone_would_take(tmp_path, case):
    text = _log_text(field=REFUSED[case])
    path = tmp_path / "log.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(LogValueError, match=r"log\.csv, line 7: column 'gamma2': .* is not a num"):
        read_log(path)


@pytest.mark.parametrize("case", list(REFUSED))
def test_trajectory_csv_refuses_what_python_float_alone_would_take(tmp_path, case):
    value = REFUSED[case]
    row = ["0.0", "0", "0", "1", "0", "0", "0", "1"] + ["0"] * 12
    good = tmp_path / "good.csv"
    good.write_text(",".join(STATE_COLUMNS) + "\n" + ",".join(row) + "\n", encoding="utf-8")
    assert read_csv(good, STATE_COLUMNS)[0, 3] == 1.0
    row[3] = value
    path = tmp_path / "traj.csv"
    path.write_text(",".join(STATE_COLUMNS) + "\n" + ",".join(row) + "\n", encoding="utf-8")
    with pytest.raises(FileFormatError, match=r"traj\.csv, line 2, column 'z': .* is not a num"):
        read_csv(path, STATE_COLUMNS)


def test_nan_in_a_log_is_read_as_a_number_and_refused_as_non_finite(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field="NaN"), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 7: column 'gamma2': non-finite value nan"):
        read_log(path)


# ====================================================================== item 14: magnitudes


@pytest.mark.parametrize("value", ["1e308", "-1e200", "1.0000001e9"])
def test_log_effort_beyond_the_bound_names_its_value_and_line(tmp_path, value):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field=value), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 7: column 'gamma2': effort .* beyond 1e\+09"):
        read_log(path)
    assert MAX_MAGNITUDE == 1e9
    path.write_text(_log_text(field="1e9"), encoding="utf-8")  # the bound itself: accepted
    assert read_log(path, clip_run=0).efforts[5, 1] == 1e9


def test_log_position_beyond_the_bound_names_its_value_and_line(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field="-3e15", row=9, column=4), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 11: column 'l4': position -3e\+15") as info:
        read_log(path)
    assert info.value.line == 11 and info.value.value == -3e15


def test_cli_identify_log_with_a_huge_effort_is_one_line_exit_2(tmp_path, capsys):
    from stewart_pin.cli import main

    path = tmp_path / "log.csv"
    path.write_text(_log_text(n=40, field="1e308", row=30), encoding="utf-8")
    code = main(["identify", "--preset", "random-2", "--log", str(path), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "line 32" in err and "1e+308" in err


# ====================================================================== item 15: lines


@pytest.mark.parametrize("reader", ["log", "table"])
def test_a_file_without_line_breaks_is_refused_at_line_1(tmp_path, reader):
    path = tmp_path / "long.csv"
    path.write_bytes(b"1" * (4 * MAX_LINE_LENGTH))
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=rf"line 1: a line longer than {MAX_LINE_LENGTH}"):
        read(path)


@pytest.mark.parametrize("reader", ["log", "table"])
def test_a_binary_file_is_refused_at_its_first_nul(tmp_path, reader):
    path = tmp_path / "bin.csv"
    path.write_bytes(HEADER.encode() + b"0,1\x00\x00,2\n" + b"\x00" * 100)
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=r"line 2: a NUL byte: a binary file"):
        read(path)


@pytest.mark.parametrize("reader", ["log", "table"])
def test_dev_zero_is_refused_not_read_forever(reader):
    from pathlib import Path

    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=r"/dev/zero, line 1: a line longer"):
        read(Path("/dev/zero"))


def test_the_bound_leaves_long_comment_and_data_lines_alone(tmp_path):
    path = tmp_path / "log.csv"
    text = _log_text()
    path.write_text("#" + "x" * (MAX_LINE_LENGTH - 2) + "\n" + text, encoding="utf-8")
    assert len(read_log(path)) == 12
    assert isinstance(LogError("x"), FileFormatError) and math.isfinite(MAX_MAGNITUDE)
    np.testing.assert_array_equal(read_log(path).positions, 0.5)


# ====================================================================== item 18: Ctrl-C


def test_keyboard_interrupt_in_forces_keeps_the_states_so_far():
    from stewart_pin import SimulationInterrupted, StewartPinError, StewartRobot, simulate

    robot = StewartRobot.from_preset("simulator")

    def forces(t, T, V):
        if t > 0.0105:
            raise KeyboardInterrupt
        return np.zeros(6)

    with pytest.raises(SimulationInterrupted) as info:
        simulate(robot, 1.0, forces=forces, dt=1e-3)
    e = info.value
    assert isinstance(e, KeyboardInterrupt) and not isinstance(e, (Exception, StewartPinError))
    # the accepted states: t = 0, 1 ms, ..., 10 ms (the 11 ms step was being tried)
    np.testing.assert_allclose(e.result.t, np.arange(11) * 1e-3, rtol=0, atol=1e-15)
    assert e.time == pytest.approx(0.010, abs=1e-15)


def test_cli_simulate_interrupted_saves_the_partial_file_exit_130(tmp_path, capsys, monkeypatch):
    from contextlib import contextmanager

    from stewart_pin.cli import main, motion_cmds
    from stewart_pin.motion.simulation import SimulationResult

    @contextmanager
    def bar(total, unit, enabled=True):
        class Bar:
            def to(self, t):  # Ctrl-C once 20 ms are simulated
                if t >= 0.02 - 1e-12:
                    raise KeyboardInterrupt

        yield Bar()

    monkeypatch.setattr(motion_cmds, "progress_bar", bar)
    out = tmp_path / "run.csv"
    code = main(["simulate", "--motion", "free", "--duration", "5", "-o", str(out)])
    err = capsys.readouterr().err.strip()
    partial = tmp_path / "run.partial.csv"
    assert code == 130 and "\n" not in err, err
    assert err.startswith("stewart-pin simulate: simulation interrupted at t = 0.02 s")
    assert str(partial) in err
    assert not out.exists()
    saved = SimulationResult.load(partial)
    np.testing.assert_allclose(saved.t, np.arange(21) * 1e-3, rtol=0, atol=1e-12)


def test_cli_simulate_sigint_in_a_child_process_exit_130(tmp_path):
    """A real SIGINT to ``stewart-pin simulate`` once its progress bar shows: one line on
    stderr, exit code 130, the states so far saved beside the output."""
    import os
    import re
    import select
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "run.npz"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    argv = [sys.executable, "-m", "stewart_pin.cli", "simulate", "--motion", "sinusoid"]
    child = subprocess.Popen(
        [*argv, "--duration", "1000", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    try:
        seen = b""
        deadline = time.monotonic() + 120
        moving = re.compile(rb"\| *(?!0/)[0-9.e+-]+/1e\+03 s")  # the bar past 0 s
        while moving.search(seen) is None and time.monotonic() < deadline:
            ready, _, _ = select.select([child.stderr], [], [], 1.0)
            if ready:
                seen += os.read(child.stderr.fileno(), 4096)
            assert child.poll() is None, seen
        assert moving.search(seen) is not None, seen
        child.send_signal(signal.SIGINT)
        _, rest = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    lines = [x for x in (seen + rest).decode().replace("\r", "\n").splitlines() if x.strip()]
    assert child.returncode == 130, lines
    assert lines[-1].startswith("stewart-pin simulate: simulation interrupted at t = ")
    assert "Traceback" not in "\n".join(lines)
    from stewart_pin.motion.simulation import SimulationResult

    saved = SimulationResult.load(tmp_path / "run.partial.npz")
    assert len(saved.t) >= 2 and str(tmp_path / "run.partial.npz") in lines[-1]


def test_ctrl_c_during_the_planner_is_a_keyboard_interrupt(monkeypatch):
    """SIGINT while IPOPT iterates: CasADi catches it and returns a failed status; the
    planner raises KeyboardInterrupt, not a ConvergenceError with a false message."""
    import os
    import signal
    import threading

    from stewart_pin import StewartRobot
    from stewart_pin.planning import point_to_point

    nlpsol = point_to_point.cs.nlpsol

    def slow_nlpsol(*args, **kwargs):
        solver = nlpsol(*args, **kwargs)

        class Interrupted:
            def __call__(self, **kw):
                timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
                timer.start()
                try:
                    return solver(**kw)
                finally:
                    timer.cancel()

            def stats(self):
                return solver.stats()

        return Interrupted()

    monkeypatch.setattr(point_to_point.cs, "nlpsol", slow_nlpsol)
    robot = StewartRobot.from_preset("simulator")
    goal = robot.home_pose
    goal[:3, 3] += [0.15, -0.1, 0.1]
    with pytest.raises(KeyboardInterrupt):
        # many intervals and a tight tolerance: IPOPT iterates for seconds
        point_to_point.optimal_point_to_point(
            robot, robot.home_pose, goal, 1.0, intervals=200, tol=1e-14, max_iterations=3000
        )


# ====================================================================== item 16: sizes

HUGE = "100000000000"  # 1e11: petabytes at any of the measured costs per unit


@pytest.mark.parametrize(
    "argv",
    [
        ["validate", "--states", HUGE],
        ["base-params", "--states", HUGE],
        ["identify", "--samples", HUGE],
        ["bench", "--batch", HUGE],
        ["animate", "--duration", "1e9"],
        ["view", "--duration", "1e9"],
    ],
)
def test_cli_sizes_beyond_the_machine_memory_are_one_line_exit_2(argv, capsys):
    from stewart_pin.cli import main

    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err.strip()
    assert info.value.code == 2 and "\n" not in err
    assert "GB of memory" in err and "more than this machine's" in err and "give at most" in err


def test_the_memory_bound_is_the_machine_memory_over_the_cost_per_unit(monkeypatch):
    import argparse

    from stewart_pin import _argtypes

    monkeypatch.setattr(_argtypes, "physical_memory", lambda: 10**9)  # a 1 GB machine
    states = _argtypes.count_within_memory(10_000, "state")
    assert states("100000") == 100_000  # exactly 1 GB
    with pytest.raises(argparse.ArgumentTypeError, match=r"give at most 100000$"):
        states("100001")
    with pytest.raises(argparse.ArgumentTypeError, match="an integer >= 1"):
        states("0")
    seconds = _argtypes.duration_within_memory(700_000)
    assert seconds("1428.5") == 1428.5
    with pytest.raises(argparse.ArgumentTypeError, match=r"give at most 1428$"):
        seconds("1429")
    monkeypatch.setattr(_argtypes, "physical_memory", lambda: None)  # unknown: no bound
    assert states(HUGE) == 10**11


def test_decimation_beyond_the_log_length_is_refused_at_once(tmp_path, capsys):
    """--decimation 100000 on a 2000-sample log: refused with the largest factor that
    fits, instead of designing a 1.6-million-tap filter."""
    from stewart_pin import StewartRobot
    from stewart_pin.cli import main
    from stewart_pin.exceptions import InputError
    from stewart_pin.parameters.logs import ActuatorLog, write_log
    from stewart_pin.parameters.state_estimation import FIR_HALF, design_filters

    robot = StewartRobot.from_preset("random-2")
    t = np.arange(2000) / 200.0
    T = np.tile(robot.home_pose, (len(t), 1, 1))
    T[:, 2, 3] += 0.01 * np.sin(2 * np.pi * 0.5 * t)
    log = ActuatorLog(t, robot.actuator_positions(T), np.sin(t)[:, None] * np.ones(6))
    d = design_filters(log)
    usable = len(log) - 2 * d.edge
    longest = (usable - 1) // (2 * FIR_HALF)
    assert design_filters(log, decimation=longest).decimation == longest
    with pytest.raises(InputError, match=rf"decimation factor of {longest} or less"):
        design_filters(log, decimation=longest + 1)
    path = write_log(tmp_path / "log.csv", log)
    argv = ["identify", "--preset", "random-2", "--log", str(path), "--no-progress"]
    code = main([*argv, "--decimation", "100000"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and f"{longest} or less" in err


# ====================================================================== item 20: physical fit


@pytest.fixture(scope="module")
def negated_log():
    """A noisy log of the 6-UPS preset random-2 on an exciting trajectory, its efforts
    negated: least squares fits it as well as the true log (with negative masses), but no
    robot with positive masses makes these efforts."""
    from stewart_pin import StewartRobot
    from stewart_pin.parameters.identification import exciting_trajectory
    from stewart_pin.parameters.logs import ActuatorLog

    robot = StewartRobot.from_preset("random-2")
    traj, _ = exciting_trajectory(
        robot, base_frequency=0.5, n_harmonics=3, seed=1, optimise=False, n_samples=10
    )
    t = np.arange(1600) / 200.0
    s = traj.fourier.sample(t)
    gamma = robot.inverse_dynamics(s.poses, s.twists, s.accels)
    gamma = gamma + np.random.default_rng(1).normal(size=gamma.shape) * 0.5
    positions = robot.actuator_positions(s.poses)
    return robot, ActuatorLog(t, positions, gamma), ActuatorLog(t, positions, -gamma)


def test_physical_fit_of_negated_efforts_is_refused(negated_log):
    from stewart_pin.exceptions import IdentificationError, PhysicalFitError
    from stewart_pin.parameters.base import base_parameters
    from stewart_pin.parameters.identification import identify_log
    from stewart_pin.parameters.physical import (
        MAX_FIT_LOSS,
        MAX_SIGNAL_LOSS,
        physically_consistent,
    )

    robot, good, negated = negated_log
    base = base_parameters(robot)
    ok = physically_consistent(robot, identify_log(robot, good, base))
    assert ok.fit_loss < MAX_FIT_LOSS  # the true log: credible
    ident = identify_log(robot, negated, base)
    # least squares fits the negated efforts as well: the negated parameters
    np.testing.assert_allclose(
        ident.result.estimate, -identify_log(robot, good, base).result.estimate, rtol=1e-9
    )
    with pytest.raises(PhysicalFitError, match="no physically consistent robot") as info:
        physically_consistent(robot, ident)
    e = info.value
    assert isinstance(e, IdentificationError)
    assert e.fit_loss > MAX_FIT_LOSS and e.signal_loss > MAX_SIGNAL_LOSS


def test_cli_identify_physical_of_negated_efforts_writes_nothing(tmp_path, capsys, negated_log):
    from stewart_pin.cli import main
    from stewart_pin.parameters.logs import write_log

    _, _, negated = negated_log
    path = write_log(tmp_path / "neg.csv", negated)
    out = tmp_path / "id.toml"
    argv = ["identify", "--preset", "random-2", "--log", str(path), "--no-progress"]
    code = main([*argv, "--physical", "--write-description", str(out)])
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert code == 2 and "\n" not in err and "no physically consistent robot" in err
    assert "base parameters" in captured.out  # the least-squares report is still shown
    assert not out.exists()


# ====================================================================== item 17: memory


def test_log_memory_is_thirteen_floats_and_a_line_number_per_sample(tmp_path):
    """tracemalloc (numpy's allocations included): the log keeps 13 floats and the line
    number per sample (112 bytes) and reads with a peak of at most 1.25 times that (the
    arrays grow by a quarter in place) plus small temporaries; it was 340 bytes."""
    import tracemalloc

    n = 30_000
    path = tmp_path / "log.csv"
    t = np.arange(n) / 1000.0
    rows = np.column_stack([t, 0.5 + 0.01 * np.sin(t[:, None] + np.arange(6))])
    rows = np.column_stack([rows, 100.0 * np.cos(t[:, None] + np.arange(6))])
    path.write_text(HEADER + "".join(",".join(map(repr, r)) + "\n" for r in rows.tolist()))
    tracemalloc.start()
    try:
        log = read_log(path, clip_run=0)
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(log) == n
    assert kept / n < 112 + 2  # the arrays, plus a few objects
    assert peak / n < 1.25 * 112 + 16
    np.testing.assert_array_equal(log.efforts, rows[:, 7:13])  # read exactly
    assert not log.efforts.flags.writeable


@pytest.mark.parametrize("value", ["1e308", "-1e200"])
def test_measurement_csv_effort_beyond_the_bound_names_its_line(tmp_path, value, capsys):
    """identify --csv (the measurement CSV): the same bound, instead of an SVD traceback
    (1e308) or a misleading "lost rank" (1e200)."""
    from stewart_pin.cli import main
    from stewart_pin.parameters.identification import CSV_COLUMNS, read_measurements_csv

    row = ["0", "0", "0", "1", "0", "0", "0", "1"] + ["0"] * 12 + ["10"] * 6
    lines = [",".join(CSV_COLUMNS)]
    for k in range(20):
        r = list(row)
        r[0] = repr(k / 100.0)
        lines.append(",".join(r))
    good = tmp_path / "m.csv"
    good.write_text("\n".join(lines) + "\n")
    assert len(read_measurements_csv(good)) == 20
    r = lines[8].split(",")
    r[CSV_COLUMNS.index("gamma5")] = value
    lines[8] = ",".join(r)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        FileFormatError, match=r"bad\.csv, line 9, column 'gamma5': .* beyond 1e\+09"
    ):
        read_measurements_csv(path)
    code = main(["identify", "--preset", "simulator", "--csv", str(path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "line 9" in err


def test_old_mac_line_breaks_and_utf8_errors_keep_their_line_numbers(tmp_path):
    """Line breaks ``\\r`` (split as before), and a byte that is not UTF-8 on line 4."""
    text = _log_text(n=1200)  # over 64 kB with "\\r" line breaks: not one long line
    path = tmp_path / "mac.csv"
    path.write_bytes(text.replace("\n", "\r").encode())
    assert len(text) > MAX_LINE_LENGTH and len(read_log(path)) == 1200
    lines = text.encode().split(b"\n")
    lines[3] = lines[3].replace(b"0.5", b"0.\xe95", 1)
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(LogError, match=r"mac\.csv, line 4: not UTF-8 text \(byte 0xe9"):
        read_log(path)
    with pytest.raises(FileFormatError, match=r"mac\.csv, line 4: not UTF-8 text"):
        read_csv(path, STATE_COLUMNS)
