"""The ``stewart-pin`` command (stewart_pin.cli)."""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from helpers import leg_lengths_by_hand

from stewart_pin import StewartRobot, preset
from stewart_pin.cli import build_parser, main
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.models.pinocchio_models import load_tree


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


def test_ik_prints_one_table_for_every_architecture(capsys):
    """``ik`` on a 6-RUS (issue 19: one table for every robot, the actuated joint named in
    the header): the printed actuated column (the cranks, q1) taken back through the
    forward geometry gives the pose printed (a round trip, to the 6 printed places)."""
    assert main(["ik", "--preset", "rus"]) == 0
    out = capsys.readouterr().out
    assert "rus legs" in out and "actuated: q1" in out
    rows = leg_rows(out)
    assert rows.shape == (6, 4)
    robot = StewartRobot.from_preset("rus")
    T = robot.forward_geometry(rows[:, 1])
    np.testing.assert_allclose(T, robot.home_pose, rtol=0, atol=1e-4)
    np.testing.assert_allclose(robot.inverse_geometry(T)[:, 1:], rows[:, 2:], atol=1e-4)


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
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv, state_table, write_csv
    from stewart_pin.motion.trajectories import standard_motion

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
    from stewart_pin.check.constrained_dynamics import constrained_inverse_dynamics

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


def test_validate_gives_one_verdict_at_the_tolerances_given(capsys):
    """It printed PASSED twice, and PASSED (at the defaults) then FAILED with a tolerance
    no double reaches: one verdict, naming the tolerances it used."""
    assert main(["validate", "--preset", "desktop", "--states", "5"]) == 0
    out = capsys.readouterr().out
    assert out.count("PASSED") == 1 and "FAILED" not in out
    assert "PASSED at the default tolerances (IDM 1e-09, DDM 1e-08)" in out
    assert main(["validate", "--preset", "desktop", "--states", "5", "--tol-idm", "1e-20"]) == 1
    out = capsys.readouterr().out
    assert out.count("FAILED") == 1 and "PASSED" not in out
    assert "FAILED at the tolerances (IDM 1e-20, DDM 1e-08)" in out


def test_simulate_tracks_and_writes_the_result(tmp_path, capsys):
    from stewart_pin.motion.simulation import SimulationResult

    out = tmp_path / "run.csv"
    args = ["simulate", "--preset", "desktop", "--motion", "minimum-jerk", "--duration", "0.2"]
    assert main([*args, "-o", str(out), "--no-progress"]) == 0
    res = SimulationResult.load(out)
    assert res.t[-1] == pytest.approx(0.2) and len(res.t) == 201
    text = capsys.readouterr().out
    error_mm = float(text.split("tracking error: max ")[1].split(" mm")[0])
    assert error_mm < 0.01


def test_simulate_a_washout_for_the_duration_asked(tmp_path, capsys):
    from stewart_pin.motion.simulation import SimulationResult

    out = tmp_path / "run.npz"
    args = ["simulate", "--preset", "desktop", "--motion", "washout", "--duration", "0.3"]
    assert main([*args, "--backend", "pinocchio", "-o", str(out), "--no-progress"]) == 0
    res = SimulationResult.load(out)
    assert res.t[-1] == 0.3 and len(res.t) == 301  # it ran the 4.5 s cue
    assert "simulated 0.3 s" in capsys.readouterr().out


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
    args += ["--architectures", "simulator"]
    assert main([*args, "--json", str(path)]) == 0
    out = capsys.readouterr().out
    data = json.loads(path.read_text())
    rows = data["median_us_per_state"]
    assert "pin.constraintDynamics (raw call)" in rows and "IDM single" in rows
    assert all(t > 0 for t in rows.values())
    assert data["machine"]["cpus"] >= 1
    # every figure of issue 24 in the one run: each section printed with its aim, and in
    # the JSON with finite positive medians and ratios (no timing asserted)
    from stewart_pin.apps.bench_sections import AIMS

    sections = data["sections"]
    assert set(sections) == set(AIMS)
    for name, entry in sections.items():
        assert f"{name}: aim {AIMS[name]}" in out
        medians, ratios = entry["median"], entry["ratio_to_pin_constraintDynamics"]
        assert medians and set(ratios) == set(medians)
        assert all(np.isfinite(v) and v > 0 for v in [*medians.values(), *ratios.values()])
    first = sections["derivatives first use"]["median"]
    assert "desktop: first inverse_dynamics_derivatives call" in first
    assert "import stewart_pin" in sections["start-up"]["median"]
    from stewart_pin.apps.bench_sections import SAMPLING_PRESETS

    sampled = {k.split(":")[0] for k in sections["sampling"]["median"]}
    assert sampled == set(SAMPLING_PRESETS) and {"rus", "welded-ups"} <= sampled
    assert "payload robot, inverse, compiled, one state" in sections["payload"]["median"]
    assert any(k.startswith("IDM batch 50, per state") for k in sections["batches"]["median"])
    # the suite builds quick (conftest.py): the run says its figures are not the default's
    quick = compiled_module.model_cflags() == compiled_module.QUICK_CFLAGS
    assert ("models built without optimisation ($STEWART_PIN_BUILD=quick)" in out) == quick
    sim = data["simulation"]["desktop"]
    assert all(np.isfinite(v) and v > 0 for v in sim["median_us_per_step"].values())
    assert "simulation: aim" in out


@pytest.mark.skipif(not os.path.exists("/proc/self/maps"), reason="Linux's process maps")
def test_bench_fills_its_fresh_caches_by_copying_the_users_libraries(tmp_path):
    """The start-up and first-use figures time processes on a fresh cache that holds the
    robot's value models: copied from the caller's cache (the session's here), not built
    again; a new process on the copy loads it without compiling (FIRST_CALL asserts it)."""
    from stewart_pin.apps.bench_sections import FIRST_CALL, environment, seed_cache

    first = FIRST_CALL.format(preset="desktop")
    fresh = tmp_path / "fresh"
    fill = first.replace("and not backend.compiled_now", "")
    assert seed_cache(str(fresh), fill) == 1
    (folder,) = fresh.iterdir()
    assert (folder / "manifest.json").is_file() and (folder / "libstewart_models.so").is_file()
    assert fresh.stat().st_mode & 0o777 == 0o700
    run = subprocess.run(
        [sys.executable, "-c", first], env=environment(str(fresh)), capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr[-2000:]
    # a script that fails on the user's cache copies nothing (the timed processes build)
    assert seed_cache(str(tmp_path / "other"), "raise SystemExit(3)") == 0
    assert not any((tmp_path / "other").iterdir())


def test_bench_prints_progress_then_one_table(capsys, monkeypatch):
    """``bench`` printed a raw dict header and nothing until the end: a progress line per
    stage (stderr), a readable machine line and one table (the timings stubbed: the
    output is under test, not the machine)."""
    from stewart_pin.apps import bench

    def arch(name, repeats, batches):
        rows = {"pin.constraintDynamics (raw call)": 10.0, "IDM single": 2.0}
        return {
            "architecture": name,
            "backend": "compiled (c)",
            "threads": 2,
            "median_us_per_state": rows,
            "ratio_to_pin_constraintDynamics": {k: t / 10.0 for k, t in rows.items()},
        }

    monkeypatch.setattr(bench, "median_us", lambda fn, repeats, per=1: 4.0)
    monkeypatch.setattr(bench, "architecture_rows", arch)
    monkeypatch.setattr(bench, "compiled_rows", lambda *a: ({"compiled IDM single (c)": 1.0}, {}))
    monkeypatch.setattr(bench, "mujoco_rows", lambda *a: {})
    from stewart_pin.apps import bench_simulation

    sim_rows = {"C RK4, forces as data": 3.0, "MuJoCo RK4 step (mj_step)": 60.0}
    monkeypatch.setattr(
        bench_simulation,
        "simulation_rows",
        lambda name, repeats, quick=False: {
            "median_us_per_step": sim_rows,
            "ratio_to_mujoco_rk4_step": {k: t / 60.0 for k, t in sim_rows.items()},
            "ratio_to_pin_constraintDynamics": {k: t / 10.0 for k, t in sim_rows.items()},
        },
    )
    from stewart_pin.apps import bench_sections

    monkeypatch.setattr(bench_sections, "bench_sections", lambda *a: {})
    monkeypatch.setattr(
        bench,
        "cost_dict",
        lambda robot: {
            m: dict.fromkeys(("base", "essential", "critical_path"), 1) for m in ("IDM", "DDM")
        },
    )
    args = ["bench", "--preset", "desktop", "--architectures", "rus,pus", "--batch", "5"]
    assert main([*args, "--repeats", "1", "--quick"]) == 0
    out, err = capsys.readouterr()
    stages = [line for line in err.splitlines() if line.startswith("bench: [")]
    assert len(stages) == 6 and stages[0].startswith("bench: [1/11] 'rus'")
    lines = out.splitlines()
    assert "{" not in lines[0] and "CPUs" in lines[0] and "Python" in lines[0]
    assert lines[1].split() == [
        "robot",
        "backend",
        "timing",
        "[us/state]",
        "/",
        "pin.constraintDynamics",
    ]
    end = lines.index("")  # then the simulator's table
    rows = [line.split() for line in lines[2:end]]
    assert [r[0] for r in rows] == ["rus"] * 2 + ["pus"] * 2 + ["desktop"] * 9
    assert rows[1][-2:] == ["2.000", "0.200"] and rows[-1][-2:] == ["1.000", "0.250"]
    assert lines[end + 1].startswith("simulation: aim")
    sim = [line.split() for line in lines[end + 3 :]]
    assert sim[0][-3:] == ["3.00", "0.050", "0.300"] and len(sim) == 2
    assert main([*args, "--repeats", "1", "--quick", "--no-progress"]) == 0
    assert capsys.readouterr().err == ""


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


def test_demo_writes_the_whole_workflow(tmp_path, capsys, monkeypatch):
    # the user's default (the suite's is the reference path): the compiled models and the
    # C simulator, the robot's library shared with the bench tests above
    monkeypatch.setenv("STEWART_PIN_BACKEND", "auto")
    from stewart_pin.motion.simulation import SimulationResult

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


# ---------------------------------------------------------------------------- item 13
#: (command, option, bad value): every numeric option of every command.
BAD_NUMBERS = [
    ("validate", "--states", "0"),
    ("validate", "--states", "-3"),
    ("validate", "--states", "1.5"),
    ("validate", "--seed", "-1"),
    ("validate", "--seed", "x"),
    ("validate", "--tol-idm", "nan"),
    ("validate", "--tol-idm", "-1e-9"),
    ("validate", "--tol-ddm", "inf"),
    ("validate", "--translation", "nan"),
    ("validate", "--translation", "-0.01"),
    ("validate", "--rotation", "inf"),
    ("validate", "--rotation", "-0.1"),
    ("base-params", "--states", "0"),
    ("base-params", "--seed", "-1"),
    ("base-params", "--threshold", "nan"),
    ("base-params", "--threshold", "0"),
    ("identify", "--seed", "-1"),
    ("identify", "--samples", "0"),
    ("identify", "--duration", "nan"),
    ("identify", "--duration", "0"),
    ("identify", "--harmonics", "0"),
    ("identify", "--frequency", "0"),
    ("identify", "--frequency", "inf"),
    ("identify", "--evaluations", "-1"),
    ("identify", "--noise", "-1"),
    ("identify", "--noise", "nan"),
    ("identify", "--max-relative-std", "0"),
    ("identify", "--max-relative-std", "nan"),
    ("identify", "--cutoff", "0"),
    ("identify", "--cutoff", "nan"),
    ("identify", "--decimation", "0"),
    ("simulate", "--duration", "nan"),
    ("simulate", "--duration", "0"),
    ("simulate", "--duration", "inf"),
    ("simulate", "--dt", "0"),
    ("simulate", "--dt", "nan"),
    ("simulate", "--control-period", "0"),
    ("simulate", "--control-period", "nan"),
    ("simulate", "--control-period", "-1e-3"),
    ("simulate", "--model-error", "nan"),
    ("simulate", "--model-error", "inf"),
    ("animate", "--duration", "nan"),
    ("animate", "--fps", "0"),
    ("animate", "--fps", "nan"),
    ("view", "--duration", "nan"),
    ("view", "--duration", "-1"),
    ("bench", "--batch", "0"),
    ("bench", "--repeats", "0"),
    ("ik", "--pose", "nan"),
    ("ik", "--pose", "inf"),
    # payloads (docs/payloads.md)
    ("validate", "--payload-placement", "nan"),
    *(
        (command, option, value)
        for command in ("simulate", "animate", "view")
        for option, value in (
            ("--payload-placement", "inf"),
            ("--payload-fraction", "0"),
            ("--payload-fraction", "1.5"),
            ("--payload-period", "nan"),
        )
    ),
    ("import", "--closure-tolerance", "0"),
    ("import", "--closure-tolerance", "nan"),
    ("export-c", "--samples", "0"),
    ("workspace", "--orientation", "nan"),
    ("workspace", "--resolution", "0"),
    ("workspace", "--max-condition", "0"),
    ("workspace", "--seed", "-1"),
    ("workspace", "--max-angle", "0"),
    ("workspace", "--min-leg-distance", "-1"),
    ("size", "--translation", "-1"),
    ("size", "--rotation", "nan"),
    ("size", "--speed", "-1"),
    ("size", "--angular-speed", "inf"),
    ("size", "--accel", "-1"),
    ("size", "--angular-accel", "nan"),
    ("size", "--samples", "0"),
    ("size", "--seed", "-1"),
    ("size", "--effort-limit", "0"),
    ("sweep", "--resolution", "0"),
    ("sweep", "--samples", "0"),
    ("sweep", "--seed", "-1"),
    ("sweep", "--workers", "0"),
    ("sweep", "--timeout", "0"),
]


@pytest.mark.parametrize(
    "command, option, value", BAD_NUMBERS, ids=[" ".join(c) for c in BAD_NUMBERS]
)
def test_bad_number_argument_exits_2_with_one_line(command, option, value, capsys):
    if option in ("--pose", "--payload-placement"):
        argv = [command, option, value, "0", "0", "0", "0", "0"]
    elif option == "--orientation":  # three numbers
        argv = [command, option, value, "0", "0"]
    else:
        argv = [command, f"{option}={value}"]  # '--tol-idm -1e-9' would read as an option
    with pytest.raises(SystemExit) as e:  # refused while parsing: before any work
        main(argv)
    assert e.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert captured.err.startswith(f"stewart-pin {command}: error: argument {option}")
    assert repr(value) in captured.err


def _parsers():
    import argparse

    from stewart_pin.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


def test_every_numeric_option_has_a_checked_type_and_a_test():
    from stewart_pin.cli import _common

    checked = {
        _common.positive_int,
        _common.non_negative_int,
        _common.finite_float,
        _common.positive_finite_float,
        _common.non_negative_finite_float,
        _common.fraction_of_one,
    }
    tested = {(command, option) for command, option, _ in BAD_NUMBERS}
    n_checked = 0
    for command, parser in _parsers().items():
        for action in parser._actions:
            assert action.type not in (int, float), (command, action.option_strings)
            # the sizes bounded by memory (issue 25, item 16) check as positive_int /
            # positive_finite_float first
            if action.type in checked or getattr(action.type, "within_memory", False):
                n_checked += 1
                assert (command, action.option_strings[-1]) in tested
    assert n_checked == len(tested)


def test_checked_number_types_accept_good_values():
    from stewart_pin.cli import _common

    assert _common.positive_int("3") == 3 and _common.non_negative_int("0") == 0
    assert _common.finite_float("-2.5") == -2.5 and _common.finite_float("1e3") == 1000.0
    assert _common.positive_finite_float("1e-300") == 1e-300
    assert _common.non_negative_finite_float("0") == 0.0
    assert _common.fraction_of_one("1") == 1.0 and _common.fraction_of_one("1e-9") == 1e-9


def test_output_suffix_and_folder_are_checked_before_the_run(tmp_path, capsys, monkeypatch):
    import stewart_pin.apps.bench
    import stewart_pin.motion.simulation

    def never(*args, **kwargs):
        raise AssertionError("the long run started before the output was checked")

    monkeypatch.setattr(stewart_pin.motion.simulation, "simulate", never)
    monkeypatch.setattr(stewart_pin.apps.bench, "report", never)
    blocker = tmp_path / "file"
    blocker.write_text("")
    cases = [
        (["simulate", "-o", str(tmp_path / "out.xyz")], "must end in .npz or .csv"),
        (["simulate", "-o", str(blocker / "x.npz")], "cannot create the folder"),
        (["simulate", "-o", str(tmp_path)], "must end in"),
        (["simulate", "--plots", str(blocker)], "is a file"),
        (["animate", "-o", str(tmp_path / "a.txt")], "must end in .html or .htm"),
        (["bench", "--quick", "--json", str(tmp_path / "b.txt")], "must end in .json"),
        (["idm", "--trajectory", "t.csv", "-o", str(tmp_path / "f.txt")], "must end in .csv"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, (argv, err)
    assert list(tmp_path.iterdir()) == [blocker]  # nothing written


def test_output_equal_to_an_input_is_refused(tmp_path, capsys):
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, write_csv

    traj = write_csv(tmp_path / "traj.csv", STATE_COLUMNS, np.zeros((2, len(STATE_COLUMNS))))
    log = tmp_path / "log.csv"
    log.write_text("anything\n")
    measurements = tmp_path / "r_measurements.csv"
    measurements.write_text("validation log\n")
    robot_file = preset("desktop").write(tmp_path / "robot.toml")
    before = traj.read_bytes(), log.read_bytes(), robot_file.read_bytes()
    same = str(tmp_path / "sub" / ".." / "traj.csv")  # another spelling of the same file
    cases = [
        ["idm", "--trajectory", str(traj), "-o", str(traj)],
        ["idm", "--trajectory", str(traj), "-o", same],
        ["identify", "--csv", str(log), "-o", str(log)],
        ["identify", "--csv", str(traj), "--validation-csv", str(log), "-o", str(log)],
        ["identify", "--description", str(robot_file), "--csv", str(log), "-o", str(robot_file)],
        # The simulated measurements (r_measurements.csv beside the report r.txt) would
        # be written over the validation log.
        ["identify", "--validation-csv", str(measurements), "-o", str(tmp_path / "r.txt")],
    ]
    for argv in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "is the input file" in err, (argv, err)
    assert (traj.read_bytes(), log.read_bytes(), robot_file.read_bytes()) == before
    assert measurements.read_text() == "validation log\n"


# ---------------------------------------------------------------------------- item 5
def test_idm_overflowing_state_exits_2_and_writes_nothing(tmp_path, capsys):
    from stewart_pin import StewartRobot
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, state_table, write_csv
    from stewart_pin.kinematics.workspace import sample_states

    robot = StewartRobot.from_preset("desktop")
    poses, twists, accels = sample_states(robot.description, 5, 2)
    twists[3, :3] = 1e160  # finite, but its square overflows
    table = state_table(np.arange(5) * 0.01, poses, twists, accels)
    traj = write_csv(tmp_path / "traj.csv", STATE_COLUMNS, table)
    out = tmp_path / "forces.csv"
    assert main(["idm", "--preset", "desktop", "--trajectory", str(traj), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "inverse dynamics Gamma is not finite at state 3" in err
    assert not out.exists()


# ---------------------------------------------------------------------------- item 17
def test_validate_takes_the_sampling_range(tmp_path, capsys):
    from stewart_pin import StewartRobot, random_robot

    desc = random_robot(1)
    lengths = StewartRobot(desc).leg_lengths(desc.home_pose)
    tiny = desc.replace(stroke=[lengths.min() - 2e-3, lengths.max() + 2e-3], name="tiny")
    path = tiny.write(tmp_path / "tiny.toml")
    args = ["validate", "--description", str(path), "--states", "8"]
    assert main(args) == 2  # the default range leaves the 4 mm stroke
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--translation, --rotation" in err
    assert main([*args, "--translation", "5e-4", "--rotation", "5e-4"]) == 0
    assert "PASSED" in capsys.readouterr().out


def test_version_prints_the_package_version(capsys):
    import stewart_pin

    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"stewart-pin {stewart_pin.__version__}"


def test_python_dash_m_runs_the_command():
    """``python -m stewart_pin.cli`` is the command (exit codes and one-line errors)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import stewart_pin

    env = {**os.environ, "PYTHONPATH": str(Path(stewart_pin.__file__).parents[1])}
    run = [sys.executable, "-m", "stewart_pin.cli"]
    ok = subprocess.run([*run, "--version"], capture_output=True, text=True, env=env)
    assert ok.returncode == 0 and ok.stdout.strip() == f"stewart-pin {stewart_pin.__version__}"
    bad = subprocess.run(
        [*run, "ik", "--preset", "no-such"], capture_output=True, text=True, env=env
    )
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1, bad.stderr


def subcommand_parsers() -> dict[str, argparse.ArgumentParser]:
    """Every subcommand's parser, by name."""
    (sub,) = (a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def test_every_help_shows_the_defaults():
    parsers = subcommand_parsers()
    assert {"urdf", "ik", "idm", "validate", "simulate", "identify", "demo"} <= set(parsers)
    for name, parser in parsers.items():
        text = " ".join(parser.format_help().split())  # unwrapped
        for action in parser._actions:
            has_value = action.option_strings and action.nargs != 0
            if has_value and action.default not in (None, argparse.SUPPRESS):
                shown = f"(default: {action.default})"
                assert shown in text, f"stewart-pin {name} --help: {action.dest} {shown}"


def test_every_preset_option_names_every_preset():
    """`demo --help` listed only the ideal 6-UPS presets, though the demo runs the others
    (`bench --preset` is 6-UPS-only, and says so)."""
    from stewart_pin.description.presets import PRESET_NAMES

    parsers = subcommand_parsers()
    assert "demo" in parsers
    for name, parser in parsers.items():
        for action in parser._actions if name != "bench" else ():
            if "--preset" in action.option_strings:
                text = " ".join(parser.format_help().split())
                for preset_name in (*PRESET_NAMES, "random-<seed>", "random-<kind>-<seed>"):
                    assert preset_name in text, f"stewart-pin {name} --help: {preset_name}"


# ---------------------------------------------------------------------- missing extras
def _without(monkeypatch: pytest.MonkeyPatch, *modules: str) -> None:
    """Make ``import <module>`` fail as if the package were not installed (a ``None`` in
    ``sys.modules`` halts the import with an ImportError)."""
    import sys

    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)


_NO_MATPLOTLIB = ("matplotlib", "matplotlib.figure", "matplotlib.pyplot")
_NO_MESHCAT = ("meshcat", "meshcat.animation", "meshcat.geometry")


@pytest.mark.parametrize(
    ("command", "missing", "package", "extra"),
    [
        (["demo", "--preset", "desktop", "-o", "out"], _NO_MATPLOTLIB, "matplotlib", "viz"),
        (["demo", "--preset", "desktop", "-o", "out"], _NO_MESHCAT, "meshcat", "viz"),
        (["animate", "--preset", "desktop", "--duration", "0.2"], _NO_MESHCAT, "meshcat", "viz"),
        (
            [
                "simulate",
                "--preset",
                "desktop",
                "--duration",
                "0.05",
                "--no-progress",
                "--plots",
                "p",
            ],
            _NO_MATPLOTLIB,
            "matplotlib",
            "viz",
        ),
        (["import", "MODEL", "-o", "out.toml"], ("mujoco",), "mujoco", "import"),
        (["ik", "--model", "MODEL"], ("mujoco",), "mujoco", "import"),
    ],
)
def test_a_missing_extra_is_one_line_before_the_work(
    tmp_path, capsys, monkeypatch, command, missing, package, extra
):
    """Without the extra a command needs: one line naming the package and the quoted
    install hint, exit 2, and nothing done (these used to run for a minute, then end in a
    traceback)."""
    from stewart_pin.formats.mjcf import write_mjcf

    model = write_mjcf(preset("desktop"), tmp_path / "desktop.xml")
    monkeypatch.chdir(tmp_path)
    command = [str(model) if a == "MODEL" else a for a in command]
    _without(monkeypatch, *missing)
    before = set(tmp_path.iterdir())
    assert main(command) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{package}, needed for" in err and f'pip install "stewart-pin[{extra}]"' in err
    assert set(tmp_path.iterdir()) == before  # nothing written


# ---------------------------------------------------------------------- pipes
@pytest.mark.parametrize(
    "command", [["ik", "--preset", "desktop"], ["base-params", "--preset", "desktop"]]
)
def test_a_reader_that_stops_early_ends_the_command_quietly(command):
    """``stewart-pin ... | head``: the reader closes the pipe before the command writes.
    Nothing on stderr (it printed "error: [Errno 32] Broken pipe" and exited 2), exit code
    141 (128 + SIGPIPE, as a shell reports for a Unix tool ended by the closed pipe)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import stewart_pin
    from stewart_pin.cli import EXIT_BROKEN_PIPE

    env = {**os.environ, "PYTHONPATH": str(Path(stewart_pin.__file__).parents[1])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "stewart_pin.cli", *command],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == EXIT_BROKEN_PIPE and EXIT_BROKEN_PIPE == 141
    assert err == ""


def test_no_progress_is_the_one_name_and_quiet_a_deprecated_alias(tmp_path, capsys):
    """``--quiet`` (simulate) and ``--no-progress`` (identify) meant the same thing: one
    name everywhere, the old one kept with a warning and out of the help."""
    parsers = subcommand_parsers()
    for name in ("simulate", "identify"):
        assert "--no-progress" in parsers[name].format_help()
        assert "--quiet" not in parsers[name].format_help()
    args = ["simulate", "--preset", "desktop", "--duration", "0.01", "--backend", "pinocchio"]
    assert main([*args, "--quiet", "-o", str(tmp_path / "a.npz")]) == 0
    err = capsys.readouterr().err
    assert err == "stewart-pin simulate: warning: --quiet is deprecated, use --no-progress\n"
    assert main([*args, "--no-progress", "-o", str(tmp_path / "b.npz")]) == 0
    assert capsys.readouterr().err == ""
