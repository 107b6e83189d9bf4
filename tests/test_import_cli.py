"""``stewart-pin import MODEL`` and ``--model FILE`` on the robot commands.

The printed report is checked against the file (its joints, actuators, lumped bodies),
and the description written is read back and compared with the library's import of the
same file; the commands given ``--model`` answer as with the robot imported by the
library (the inverse geometry printed equals ``robot.inverse_geometry`` of that robot).
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from cad_models import cad_mjcf, cad_urdf

from stewart_pin import ModelImportWarning, RobotDescription, StewartRobot
from stewart_pin.cli import main
from stewart_pin.description.leg_chain_presets import pus_preset
from stewart_pin.description.presets import preset
from stewart_pin.formats.mjcf import write_mjcf

pytest.importorskip("mujoco")
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")


@pytest.fixture(scope="module")
def cad_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cad") / "hexaglide.xml"
    path.write_text(cad_mjcf(pus_preset(), "weld-ball", seed=3))
    return path


def test_import_prints_what_it_recognised_and_writes_the_description(cad_file, tmp_path, capsys):
    out = tmp_path / "robot.toml"
    assert main(["import", str(cad_file), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "MJCF model 'cad-weld-ball'" in text and "platform 'platform' (Fp)" in text
    assert text.count("\nleg ") == 6
    assert "'leg1_j1' (P*)" in text  # the actuated slide, starred
    assert "spherical: ball joint 'ball" in text
    assert "joint terms: q1: armature 0.0021, viscous 0.037, coulomb 0.011" in text
    lumped = next(
        line for line in text.splitlines() if line.startswith("lumped into the platform")
    )
    assert "'rod1_end'" in lumped and "'camera'" in lumped  # welded rod ends, fixed camera
    assert "loop residuals [m]" in text
    assert "warning: model 'cad-weld-ball'" not in text  # exact loops: nothing to warn
    assert f"wrote {out}" in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        expected = StewartRobot.from_mjcf(cad_file).description
    back = RobotDescription.read(out)
    assert back.source == expected.source
    np.testing.assert_array_equal(back.leg_inertia, expected.leg_inertia)
    np.testing.assert_array_equal(back.home_pose, expected.home_pose)


def test_import_prints_the_warnings(tmp_path, capsys):
    path = tmp_path / "rounded.xml"
    path.write_text(cad_mjcf(pus_preset(), "connect-site", seed=3))
    assert main(["import", str(path)]) == 0
    text = capsys.readouterr().out
    assert "warning: model 'cad-connect-site': the loops close at the reference" in text


def test_import_urdf_with_pairs_and_actuated_joints(tmp_path, capsys):
    path = tmp_path / "r.urdf"
    path.write_text(cad_urdf(pus_preset(), seed=2, closing="tip", transmissions=False))
    pairs = [f"tip_{k}=socket_{k}" for k in range(1, 7)]
    actuated = [f"leg{k}_q1" for k in range(1, 7)]
    argv = ["import", str(path), "--closure-pairs", *pairs, "--actuated", *actuated]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "URDF model 'onshape-floating'" in text and "closure 'tip_6 = socket_6'" in text


def test_robot_commands_take_a_model(cad_file, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        robot = StewartRobot.from_mjcf(cad_file)
    assert main(["ik", "--model", str(cad_file)]) == 0
    text = capsys.readouterr().out
    q = robot.inverse_geometry(robot.home_pose)
    rows = [
        line.split()
        for line in text.splitlines()
        if line[:3].strip() in "123456" and line[:3].strip()
    ]
    got = np.array([[float(x.rstrip("*")) for x in row[1:4]] for row in rows[:6]])
    np.testing.assert_allclose(got, q, atol=1e-6)


def test_model_from_our_own_writer(tmp_path, capsys):
    path = write_mjcf(preset("desktop"), tmp_path / "desktop.xml")
    assert main(["validate", "--model", str(path), "--states", "10"]) == 0
    assert "PASSED" in capsys.readouterr().out


def test_import_errors_are_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.xml"
    bad.write_text(
        "<mujoco><worldbody><body name='a'><joint/><geom size='1'/></body></worldbody></mujoco>"
    )
    assert main(["import", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stewart-pin import: error: not six legs") and err.count("\n") == 1
    assert main(["ik", "--model", str(tmp_path / "none.xml")]) == 2
    assert "no MJCF file" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["ik", "--model", str(bad), "--preset", "desktop"])
    assert info.value.code == 2
    out = tmp_path / "x.txt"
    assert main(["import", str(bad), "-o", str(out)]) == 2
    assert "must end in .toml or .json" in capsys.readouterr().err


def test_import_options_of_the_other_format_are_refused(cad_file, tmp_path, capsys):
    """``--keyframe`` is MJCF's, ``--closures`` / ``--closure-pairs`` are URDF's,
    ``--actuated`` URDF's and SDF's: given for another kind of file they would be ignored
    silently."""
    for extra, formats in (
        (["--actuated", *[f"leg{k}_j1" for k in range(1, 7)]], "URDF and SDF"),
        (["--closures", "x.json"], "URDF"),
    ):
        assert main(["import", str(cad_file), *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{extra[0]} only applies to {formats} files" in err
    urdf = tmp_path / "r.urdf"
    urdf.write_text(cad_urdf(pus_preset(), seed=2))
    assert main(["import", str(urdf), "--keyframe", "home"]) == 2
    assert "--keyframe only applies to MJCF files" in capsys.readouterr().err


def test_robot_commands_print_the_import_warnings_in_one_line(tmp_path, capsys):
    """``--model`` on a file with rounded loops: the ModelImportWarning is one short line
    on stderr, not a Python warning with a source line, and once per process (it repeated
    on every ``--model`` command); ``stewart-pin import`` prints it whole."""
    path = tmp_path / "rounded.xml"
    path.write_text(cad_mjcf(pus_preset(), "connect-site", seed=3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # none escapes as a Python warning
        assert main(["ik", "--model", str(path)]) == 0
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.fullmatch(
        r"stewart-pin ik: note: model 'cad-connect-site': loops closed from a residual of "
        r"\S+ m \(`stewart-pin import` says more\)",
        lines[0],
    )
    assert main(["ik", "--model", str(path)]) == 0
    assert capsys.readouterr().err == ""  # said once
    assert main(["import", str(path)]) == 0
    assert "warning: model 'cad-connect-site': the loops close at the reference" in (
        capsys.readouterr().out
    )
