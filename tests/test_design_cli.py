"""``stewart-pin workspace | size | sweep`` (issue 22): outputs and one-line errors."""

from __future__ import annotations

import json

import numpy as np

from stewart_pin.cli import main


def test_workspace_command_writes_cells_and_boundary(tmp_path, capsys):
    out, b = tmp_path / "ws.csv", tmp_path / "b.csv"
    rc = main(["workspace", "--preset", "desktop", "--resolution", "14", "-o", str(out),
               "--boundary", str(b)])  # fmt: skip
    assert rc == 0
    assert "m^3 +-" in capsys.readouterr().out
    cells = np.loadtxt(out, delimiter=",", skiprows=1)
    assert cells.ndim == 2 and cells.shape[1] == 3 and len(cells) > 10
    assert np.loadtxt(b, delimiter=",", skiprows=1).shape == (26, 3)


def test_workspace_command_other_kinds(tmp_path, capsys):
    out = tmp_path / "o.csv"
    rc = main(["workspace", "--preset", "desktop", "--kind", "orientation", "--max-angle",
               "0.3", "--resolution", "8", "-o", str(out)])  # fmt: skip
    assert rc == 0 and "orientation workspace volume" in capsys.readouterr().out
    assert out.read_text().startswith("roll,pitch,yaw\n")
    rc = main(["workspace", "--preset", "desktop", "--kind", "dexterous", "--max-angle",
               "0.05", "--resolution", "8", "-o", str(out)])  # fmt: skip
    assert rc == 0 and "dexterous workspace volume" in capsys.readouterr().out
    rc = main(["workspace", "--preset", "desktop", "--kind", "dexterous", "--max-angle",
               "3", "-o", str(out)])  # fmt: skip
    assert rc == 2 and "not feasible" in capsys.readouterr().err


def test_size_command_writes_the_report(tmp_path, capsys):
    rc = main(["size", "--preset", "desktop", "--samples", "50", "--no-optimise",
               "--effort-limit", "20", "--html", "-o", str(tmp_path / "r")])  # fmt: skip
    assert rc == 0
    assert (tmp_path / "r" / "report.html").read_text().count("data:image/png") == 2
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert set(report) == {"loads", "capability"}
    assert len(report["capability"]) == 6


def test_sweep_command_and_its_errors_in_one_line(tmp_path, capsys):
    out = tmp_path / "s.csv"
    rc = main(["sweep", "--home-height", "0.14,-1", "--samples", "20", "--resolution", "8",
               "--serial", "--quiet", "-o", str(out)])  # fmt: skip
    assert rc == 0
    lines = out.read_text().splitlines()
    assert len(lines) == 3 and "DescriptionError" in lines[2]
    capsys.readouterr()
    rc = main(["sweep", "--scheduler", "tcp://127.0.0.1:9", "--timeout", "1", "--quiet",
               "-o", str(out)])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and "cannot reach the Dask scheduler" in err and err.count("\n") == 1
    rc = main(["workspace", "--preset", "desktop", "--orientation", "3.14", "0", "0",
               "-o", str(tmp_path / "w.csv")])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and "not feasible" in err and err.count("\n") == 1


def test_size_along_a_trajectory(tmp_path, capsys):
    """The loads along a trajectory CSV: the peak efforts are those of the inverse
    dynamics at its states, the speeds the rates of the leg lengths (differences)."""
    from stewart_pin import StewartRobot
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, state_table, write_csv
    from stewart_pin.motion.trajectories import standard_motion

    robot = StewartRobot.from_preset("desktop")
    times = np.linspace(0, 4.0, 41)
    tr = standard_motion(robot, "washout").sample(times)
    traj = write_csv(
        tmp_path / "traj.csv", STATE_COLUMNS, state_table(tr.times, tr.poses, tr.twists, tr.accels)
    )
    rc = main(
        ["size", "--preset", "desktop", "--trajectory", str(traj), "-o", str(tmp_path / "r")]
    )
    assert rc == 0
    rows = json.loads((tmp_path / "r" / "report.json").read_text())["loads"]
    gamma = robot.inverse_dynamics(tr.poses, tr.twists, tr.accels)
    np.testing.assert_allclose([r["peak_effort"] for r in rows], np.abs(gamma).max(axis=0))
    motion, h = standard_motion(robot, "washout"), 1e-6
    qp = robot.actuator_positions(motion.sample(times + h).poses)
    qm = robot.actuator_positions(motion.sample(times - h).poses)
    rates = (qp - qm) / (2 * h)
    np.testing.assert_allclose(
        [r["peak_speed"] for r in rows], np.abs(rates).max(axis=0), rtol=1e-6
    )
