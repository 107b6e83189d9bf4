"""The ``stewart-pin`` command (stewart_pin.cli)."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from helpers import leg_lengths_by_hand

from stewart_pin import preset
from stewart_pin.cli import main
from stewart_pin.models import load_tree


def leg_rows(text: str) -> np.ndarray:
    """The ``leg q1 q2 q3`` table printed by ``ik``: rows (leg, q1, q2, q3)."""
    rows = []
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[0].isdigit():
            rows.append([float(x) for x in parts])
    return np.array(rows)


def test_urdf_writes_files_pinocchio_loads(tmp_path, capsys):
    out = tmp_path / "sub" / "x.urdf"
    assert main(["urdf", "--preset", "desktop", "-o", str(out)]) == 0
    sidecar = tmp_path / "sub" / "x.closures.json"
    assert out.exists() and sidecar.exists()
    assert str(out) in capsys.readouterr().out
    model = pin.buildModelFromUrdf(str(out))
    assert (model.nq, model.nv) == (25, 24)  # the floating platform joint is a free-flyer
    tree = load_tree(out)
    assert (tree.model.nq, tree.model.nv, len(tree.constraints)) == (25, 24, 6)


def test_urdf_from_a_description_file(tmp_path):
    desc = preset("paper")
    path = desc.write(tmp_path / "paper.toml")
    out = tmp_path / "p.urdf"
    assert main(["urdf", "--description", str(path), "-o", str(out)]) == 0
    assert 'robot name="paper"' in out.read_text()


def test_ik_prints_six_legs(capsys):
    assert main(["ik", "--preset", "desktop"]) == 0
    out = capsys.readouterr().out
    rows = leg_rows(out)
    assert rows.shape == (6, 4)
    np.testing.assert_array_equal(rows[:, 0], np.arange(1, 7))
    desc = preset("desktop")
    expected = leg_lengths_by_hand(desc, desc.home_pose)
    np.testing.assert_allclose(rows[:, 3], expected, rtol=0, atol=1e-6)  # printed to 6 places
    assert "Jp^-1" in out


def test_ik_with_a_pose_offset(capsys):
    offset = [0.01, -0.02, 0.05, 0.05, -0.03, 0.1]  # [m, m, m, rad, rad, rad]
    assert main(["ik", "--preset", "simulator", "--pose", *map(str, offset)]) == 0
    desc = preset("simulator")
    T = desc.home_pose.copy()
    T[:3, 3] += offset[:3]
    T[:3, :3] = pin.rpy.rpyToMatrix(*offset[3:]) @ T[:3, :3]
    rows = leg_rows(capsys.readouterr().out)
    np.testing.assert_allclose(rows[:, 3], leg_lengths_by_hand(desc, T), rtol=0, atol=1e-6)


def test_unknown_preset_exits_2_with_one_line(capsys):
    assert main(["ik", "--preset", "nonexistent"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("stewart-pin ik: error: unknown preset 'nonexistent'")


def test_unreachable_pose_exits_2(capsys):
    assert main(["ik", "--preset", "desktop", "--pose", "0", "0", "1", "0", "0", "0"]) == 2
    assert "outside its stroke" in capsys.readouterr().err


def test_missing_description_file_exits_2(tmp_path, capsys):
    assert main(["urdf", "--description", str(tmp_path / "none.toml")]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1


def test_debug_shows_the_exception():
    from stewart_pin import DescriptionError

    with pytest.raises(DescriptionError, match="unknown preset"):
        main(["--debug", "ik", "--preset", "nonexistent"])


def test_bad_arguments_exit_2():
    with pytest.raises(SystemExit) as info:
        main(["ik", "--pose", "1", "2"])
    assert info.value.code == 2


def test_idm_reads_a_trajectory_and_writes_forces(tmp_path, capsys):
    from stewart_pin import StewartRobot
    from stewart_pin.tables import STATE_COLUMNS, read_csv, state_table, write_csv
    from stewart_pin.trajectories import standard_motion

    robot = StewartRobot.from_preset("desktop")
    tr = standard_motion(robot, "washout").sample(np.linspace(0, 4.0, 30))
    traj = write_csv(
        tmp_path / "traj.csv", STATE_COLUMNS, state_table(tr.times, tr.poses, tr.twists, tr.accels)
    )
    out = tmp_path / "forces.csv"
    assert main(["idm", "--preset", "desktop", "--trajectory", str(traj), "-o", str(out)]) == 0
    rows = read_csv(out, ("t", *(f"gamma{i}" for i in range(1, 7))))
    np.testing.assert_array_equal(rows[:, 0], tr.times)
    # Against the constrained dynamics of Pinocchio's closed-loop tree (independent).
    from stewart_pin.validation import constrained_inverse_dynamics

    ref, _ = constrained_inverse_dynamics(robot, tr.poses, tr.twists, tr.accels)
    np.testing.assert_allclose(rows[:, 1:], ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_idm_bad_file_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,1\n")
    assert main(["idm", "--preset", "desktop", "--trajectory", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing columns" in err


def test_validate_passes_and_reports(capsys):
    assert main(["validate", "--preset", "desktop", "--states", "20"]) == 0
    out = capsys.readouterr().out
    assert "PASSED" in out and "inverse dynamics" in out


def test_simulate_tracks_and_writes_the_result(tmp_path, capsys):
    from stewart_pin.simulation import SimulationResult

    out = tmp_path / "run.csv"
    args = ["simulate", "--preset", "desktop", "--motion", "minimum-jerk", "--duration", "0.2"]
    assert main([*args, "-o", str(out), "--quiet"]) == 0
    res = SimulationResult.load(out)
    assert res.t[-1] == pytest.approx(0.2) and len(res.t) == 201
    text = capsys.readouterr().out
    error_mm = float(text.split("tracking error: max ")[1].split(" mm")[0])
    assert error_mm < 0.01


def test_bad_arguments_exit_2_with_one_line(capsys):
    with pytest.raises(SystemExit) as e:
        main(["simulate", "--motion", "loop-the-loop"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "invalid choice" in err


def test_cost_prints_counts_beside_table_iv(capsys):
    assert main(["cost", "--preset", "paper"]) == 0
    out = capsys.readouterr().out
    assert "IDM, 52 essential parameters" in out and "2078" in out and "2943" in out


def test_bench_writes_json(tmp_path, capsys):
    import json

    path = tmp_path / "bench.json"
    args = ["bench", "--preset", "desktop", "--batch", "50", "--repeats", "3", "--quick"]
    assert main([*args, "--json", str(path)]) == 0
    data = json.loads(path.read_text())
    rows = data["median_us_per_state"]
    assert "pin.constraintDynamics (raw call)" in rows and "IDM single" in rows
    assert all(t > 0 for t in rows.values())
    assert data["machine"]["cpus"] >= 1


def test_animate_writes_a_standalone_page(tmp_path, capsys):
    out = tmp_path / "a.html"
    args = ["animate", "--preset", "desktop", "--motion", "minimum-jerk", "--duration", "1"]
    assert main([*args, "-o", str(out)]) == 0
    html = out.read_text()
    assert "<html" in html.lower() and "animation" in html.lower()
    # Nothing fetched at view time (the page holds an XML namespace URL, which is no fetch).
    assert not re.search(r"""(src|href)\s*=\s*["']https?://""", html)
    assert 'fetch("http' not in html


def test_view_starts_a_local_server(capsys):
    assert main(["view", "--preset", "desktop", "--no-wait"]) == 0
    assert "http://127.0.0.1:" in capsys.readouterr().out


def test_demo_writes_the_whole_workflow(tmp_path, capsys):
    from stewart_pin.simulation import SimulationResult

    out = tmp_path / "demo"
    assert main(["demo", "--preset", "desktop", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    for name in (
        "desktop.urdf",
        "desktop.closures.json",
        "trajectory.csv",
        "forces.csv",
        "simulation.npz",
        "validation.png",
        "plots/forces.png",
        "animation.html",
    ):
        assert (out / name).is_file(), name
        assert str(out / name) in text
    res = SimulationResult.load(out / "simulation.npz")
    assert res.t[-1] == pytest.approx(4.0)
    assert "file://" in text
