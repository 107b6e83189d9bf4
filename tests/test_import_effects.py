"""The import report's approximations and their effect on the efforts (issue 21, item 6).

Independent references: MuJoCo's own model of the file in an exact KKT solve
(``helpers.mujoco_kkt``) at the file's reference configuration, at rest, for the
accelerations :data:`ACCELERATIONS`; against it, the file-physics model of
``stewart_pin.check.import_effects`` (Pinocchio on the file's tree) to 1e-10, and the
effect the report states.
"""

from __future__ import annotations

import dataclasses
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from cad_models import LOOPS, cad_mjcf, cad_urdf
from helpers import mujoco_kkt, rel_error
from test_import_urdf import PinReference, pairs_of

from stewart_pin import ModelImportWarning, StewartRobot
from stewart_pin.check.import_effects import (
    ACCELERATIONS,
    FileTree,
    effect_on_efforts,
    import_effects,
)
from stewart_pin.description.leg_chain_presets import pus_preset, random_hexapod
from stewart_pin.description.presets import preset
from stewart_pin.exceptions import InputError
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import import_mjcf, import_urdf

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


@pytest.mark.parametrize("loops", LOOPS)
def test_the_file_tree_of_cad_files_is_mujocos_physics(loops):
    """FileTree on CAD-like MJCF files in every loop convention (odd frames, welds, balls,
    hinges, the platform in the tree) equals MuJoCo's KKT at the file's reference
    configuration (joint side: MuJoCo's actuator forces times their gears)."""
    xml = cad_mjcf(pus_preset(), loops, seed=3)
    result = import_mjcf(xml)
    platform = result.description.source.platform
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
    data.qpos[:] = m.key_qpos[key] if key >= 0 else m.qpos0
    names = [m.joint(int(m.actuator_trnid[u, 0])).name for u in range(m.nu)]
    gears = m.actuator_gear[:, 0]
    reference = np.array([mujoco_kkt(m, data, platform, A=A) for A in ACCELERATIONS]) * gears
    got = FileTree(result.model).inverse_dynamics_at_rest(platform, names, ACCELERATIONS)
    assert rel_error(got, reference) < 1e-10


def test_the_file_tree_of_a_urdf_is_pinocchios_physics(tmp_path):
    """FileTree on an onshape-style URDF (its bodies read breadth first) equals the KKT
    on Pinocchio's own parse of the file at its zero configuration (motor side: joint
    efforts over the transmissions' reductions). It used to add the joints breadth
    first, which Pinocchio's CRBA does not take (a subtree's velocities must be
    contiguous): 1 % off."""
    path = tmp_path / "robot.urdf"
    path.write_text(cad_urdf(random_hexapod("ups", 1), "floating", seed=1))
    result = import_urdf(path)
    root = ET.parse(path).getroot()
    names = [t.find("joint").get("name") for t in root.findall("transmission")]
    reductions = [float(t.find("actuator/mechanicalReduction").text)
                  for t in root.findall("transmission")]  # fmt: skip
    ref = PinReference(path, pairs_of(), {})
    q0, v0 = pin.neutral(ref.model), np.zeros(ref.model.nv)
    reference = np.array([ref.kkt(q0, v0, A=A) for A in ACCELERATIONS])
    got = FileTree(result.model).inverse_dynamics_at_rest("platform", names, ACCELERATIONS)
    assert rel_error(got / np.array(reductions), reference) < 1e-10


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


def test_effect_on_efforts_refuses_a_result_without_the_files_record():
    """An import result whose description lost its source (the file's record of its joints)
    is refused with the project's error naming it, not an assertion."""
    result = import_mjcf(mjcf_string(preset("rus")))
    bare = dataclasses.replace(result, description=result.description.replace(source=None))
    with pytest.raises(InputError, match="carries no source"):
        effect_on_efforts(bare, StewartRobot(bare.description))


def test_the_file_tree_removes_the_compensated_weights():
    """The rus MJCF with ``gravcomp`` on some bodies (MuJoCo's passive force), imported
    exactly: the file tree's efforts equal MuJoCo's KKT on the file and the effect on the
    efforts is round-off (it charged every body its full weight: 0.389)."""
    from test_gravity_compensation import _mjcf_with_gravcomp

    xml = _mjcf_with_gravcomp()
    result = import_mjcf(xml)
    actuated = [leg.joints[0] for leg in result.description.source.legs]
    got = FileTree(result.model).inverse_dynamics_at_rest("platform", actuated, ACCELERATIONS)
    assert rel_error(got, _mujoco_at_reference(xml, actuated)) < 1e-10
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        robot = StewartRobot(result.description)
    assert effect_on_efforts(result, robot) < 1e-10
