"""The import report's approximations and their effect on the efforts (issue 21, item 6).

Independent references: MuJoCo's own model of the file in an exact KKT solve
(``helpers.mujoco_kkt``) at the file's reference configuration, at rest, for the
accelerations :data:`ACCELERATIONS`; against it, the file-physics model of
``stewart_pin.check.import_effects`` (Pinocchio on the file's tree) to 1e-10, and the
effect the report states.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from helpers import mujoco_kkt, rel_error

from stewart_pin import ModelImportWarning, StewartRobot
from stewart_pin.check.import_effects import (
    ACCELERATIONS,
    FileTree,
    effect_on_efforts,
    import_effects,
)
from stewart_pin.description.presets import preset
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import import_mjcf

mujoco = pytest.importorskip("mujoco")


def _mujoco_at_reference(xml: str, actuated) -> np.ndarray:
    """MuJoCo's efforts (7, 6) of the file's actuators at its home keyframe, at rest."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    data.qpos[:] = m.key_qpos[0]
    data.qvel[:] = 0.0
    out = np.array([mujoco_kkt(m, data, "platform", A=A) for A in ACCELERATIONS])
    order = [m.actuator(f"leg{i}_motor").trnid[0] for i in range(1, 7)]
    by_joint = {m.joint(int(j)).name: out[:, k] for k, j in enumerate(order)}
    return np.array([by_joint[name] for name in actuated]).T


@pytest.mark.parametrize("name", ["rus", "simulator", "pus"])
def test_the_file_tree_is_mujocos_physics(name):
    """FileTree (Pinocchio on the tree the reader gives) at rest at home equals MuJoCo's
    KKT solve of the same file for the seven accelerations."""
    xml = mjcf_string(preset(name))
    result = import_mjcf(xml)
    source = result.description.source
    actuated = [leg.joints[2 if name == "simulator" else 0] for leg in source.legs]
    got = FileTree(result.model).inverse_dynamics_at_rest("platform", actuated, ACCELERATIONS)
    assert rel_error(got, _mujoco_at_reference(xml, actuated)) < 1e-10


def test_approximations_are_listed_with_their_effect_on_idm_at_home():
    """An RUS file whose crank and first U-joint axes are 5e-5 rad from parallel: the
    report lists "axes made parallel" (and the loops closed from the residual that
    opens) with the effect on the efforts at home; that effect is the difference between
    the robot's efforts and MuJoCo's KKT on the file (1e-9 absolute)."""
    xml = mjcf_string(preset("rus"))
    tilted = xml.replace(
        '<joint name="leg1_q2" type="hinge" axis="0 0 1"',
        '<joint name="leg1_q2" type="hinge" axis="5e-05 0 1"',
    )
    assert tilted != xml
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        result = import_mjcf(tilted)
    report = result.report
    assert any("axes made parallel in 1 leg(s)" in a for a in report.approximations)
    robot = StewartRobot(result.description)
    (line,) = import_effects(result, robot)
    assert line in str(report) and line.endswith("% on IDM at home")
    percent = float(line.rsplit(": ", 1)[1].split(" %")[0])
    source = result.description.source
    actuated = [leg.joints[0] for leg in source.legs]
    reference = _mujoco_at_reference(tilted, actuated)
    home = np.broadcast_to(robot.home_pose, (7, 4, 4))
    ours = robot.inverse_dynamics(home, np.zeros((7, 6)), ACCELERATIONS)
    expected = np.abs(ours - reference).max() / np.abs(reference).max()
    assert 1e-7 < expected < 1e-2
    assert percent == float(f"{100 * expected:.3g}")  # the line's three digits
    assert effect_on_efforts(result, robot) == pytest.approx(expected, abs=1e-9)
    assert import_effects(import_mjcf(xml), StewartRobot.from_mjcf(xml)) == []  # exact: none


def test_the_import_command_prints_the_effect(tmp_path, capsys):
    """``stewart-pin import`` prints the approximations and their effect."""
    from stewart_pin.cli import main

    xml = mjcf_string(preset("rus")).replace(
        '<joint name="leg1_q2" type="hinge" axis="0 0 1"',
        '<joint name="leg1_q2" type="hinge" axis="5e-05 0 1"',
    )
    path = tmp_path / "tilted.xml"
    path.write_text(xml)
    assert main(["import", str(path)]) == 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "approximation: axes made parallel in 1 leg(s)" in text
    assert "% on IDM at home" in text
