"""Importing models whatever their joints' zeros and directions (issue 21, item 3).

Files: the project's presets written by its MJCF writer, then edited the way hand-written
and CAD models are (``convention_models.rezeroed``): hinges at zero at home and the slide
at zero at the home length (no ``ref``), ``ref`` offsets (``qpos0`` away from home), axes
and slides pointing the other way, ``springref``, full-turn hinge ranges.

Independent reference: MuJoCo's own model of each edited file, in an exact KKT solve
(``helpers.mujoco_kkt``) at states put together by MuJoCo's constraint residuals
(``helpers.mujoco_closed_state``); the file's joint values are MuJoCo's ``qpos``. The
imported robot must be the named architecture with its closed forms, its inverse
dynamics equal to the KKT solve to 1e-10 relative, its actuator positions and efforts
(in the file's convention, ``description.source``) MuJoCo's.
"""

from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from convention_models import rezeroed
from helpers import mujoco_closed_state, mujoco_kkt, rel_error
from test_import_mjcf import states

from stewart_pin import (
    DescriptionError,
    ModelImportWarning,
    RobotDescription,
    StewartRobot,
)
from stewart_pin.description.presets import preset
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import import_mjcf

mujoco = pytest.importorskip("mujoco")

#: preset -> (architecture, workspace ranges around home: translation [m], rotation [rad])
PRESETS = {
    "simulator": ("ups", (0.05, 0.05)),
    "ups-offset": ("ups-offset", (0.01, 0.05)),
    "rus": ("rus", (0.003, 0.03)),
    "pus": ("pus", (0.01, 0.05)),
}
LEG_JOINTS = [f"leg{i}_q{j}" for i in range(1, 7) for j in (1, 2, 3)]


def _xml(name: str) -> str:
    return mjcf_string(preset(name))


def _edits(kind: str) -> dict:
    """``rezeroed`` options of each kind of file."""
    if kind == "baked":  # zero at home everywhere, no keyframe: qpos0 is home
        return {"mode": dict.fromkeys(LEG_JOINTS, "baked"), "drop_keyframe": True}
    if kind == "ref":  # ref offsets: qpos0 away from home, a home keyframe
        return {"mode": dict.fromkeys(LEG_JOINTS, "ref")}
    if kind == "flipped":  # zero at home and every axis the other way
        return {"mode": dict.fromkeys(LEG_JOINTS, "baked"), "flip": set(LEG_JOINTS)}
    # mixed: legs in turn baked / ref / as written, every other joint flipped
    mode = {n: ("baked", "ref", "")[int(n[3]) % 3] for n in LEG_JOINTS}
    return {
        "mode": {n: m for n, m in mode.items() if m},
        "flip": {n for k, n in enumerate(LEG_JOINTS) if k % 2},
    }


def _actuated(robot: StewartRobot) -> tuple[list[int], np.ndarray]:
    legs = robot.general.legs
    actuated = [leg.actuated for leg in legs]
    revolute = np.array([leg.joints[leg.actuated - 1].revolute for leg in legs])
    return actuated, revolute


def check_against_mujoco(xml: str, robot: StewartRobot, ranges, n: int = 3) -> None:
    """IDM of the imported robot (efforts in the file's joint directions) against the
    KKT solve on MuJoCo's model of the file; every leg joint's value and the actuator
    positions, in the file's convention, against MuJoCo's ``qpos``."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    source = robot.description.source
    actuated, revolute = _actuated(robot)
    rev3 = np.array([[j.revolute for j in leg.joints] for leg in robot.general.legs])
    for T, V, A in states(robot, ranges, n, seed=7):
        home = m.key_qpos[0] if m.nkey else m.qpos0  # the assembled state: a good start
        mujoco_closed_state(m, data, source.platform, T, V, guess=home)
        q_file = source.file_joint_values(robot.inverse_geometry(T, check_limits=False), rev3)
        for i, leg in enumerate(source.legs):
            for j, name in enumerate(leg.joints):
                got = data.qpos[m.joint(name).qposadr[0]]
                diff = math.remainder(got - q_file[i, j], 2 * math.pi) if rev3[i, j] else (
                    got - q_file[i, j]
                )  # fmt: skip
                assert abs(diff) < 1e-9, (name, got, q_file[i, j])
        positions = robot.actuator_positions(T)  # the file's convention
        qpos = np.array([data.qpos[m.joint(leg.joints[a - 1]).qposadr[0]]
                         for leg, a in zip(source.legs, actuated, strict=True)])  # fmt: skip
        wrapped = np.where(revolute, np.remainder(positions - qpos + math.pi, 2 * math.pi)
                           - math.pi, positions - qpos)  # fmt: skip
        assert np.abs(wrapped).max() < 1e-9
        gamma_mj = mujoco_kkt(m, data, source.platform, A=A)
        gamma = robot.inverse_dynamics(T, V, A, motor=True)  # along the file's axes
        assert rel_error(gamma, gamma_mj) < 1e-10, f"IDM {rel_error(gamma, gamma_mj):.2e}"


def _import(xml: str, **options) -> StewartRobot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        return StewartRobot.from_mjcf(xml, **options)


@pytest.mark.parametrize("kind", ["baked", "ref", "flipped", "mixed"])
@pytest.mark.parametrize("name", list(PRESETS))
def test_any_joint_zero_and_direction_is_the_named_architecture(name, kind):
    """The presets with their joints zeroed at home (no ``ref``), with ``ref`` offsets,
    with every axis and slide the other way, and a mix per leg: the same named
    architecture (6-UPS: the ideal form), the file's dynamics to 1e-10 (they were
    ``custom``, solved by Newton's method)."""
    xml = rezeroed(_xml(name), **_edits(kind))
    assert xml != _xml(name)
    robot = _import(xml)
    arch, ranges = PRESETS[name]
    assert robot.description.architecture == arch
    assert robot.is_ideal_ups == (name == "simulator")
    check_against_mujoco(xml, robot, ranges)


def test_an_inverted_slide_with_a_spring_is_a_ups_leg_in_the_files_convention():
    """A U-P-S leg whose slide points from the platform to the U joint, zeroed away from
    home, with a spring (``stiffness``, ``springref``): a ``ups`` leg (the closed form's
    slide is the distance to P_i, positive: the slide turned round and its value
    negated), the spring's rest position moved with it; MuJoCo's dynamics of the file to
    1e-10 (the inverted slide used to be read as a ``ups`` leg of negative length: the
    closed form then put the leg on the other side of its U joint)."""
    xml = _xml("simulator")
    xml = re.sub(r'(<joint name="leg\d_q3" type="slide")', r'\1 stiffness="800" springref="2.3"',
                 xml)  # fmt: skip
    edited = rezeroed(
        xml, {n: "ref" for n in LEG_JOINTS if n.endswith("q3")}, flip=set(LEG_JOINTS)
    )
    robot = _import(edited)
    assert robot.description.architecture == "ups"
    assert not robot.is_ideal_ups  # the springs
    for leg, src in zip(robot.description.legs, robot.description.source.legs, strict=True):
        slide = leg.joints[2]
        assert src.signs[2] == -1.0
        # the spring's rest at 2.3 m of leg length, as the writer's file had it
        assert slide.dynamics.rest_position == pytest.approx(2.3, abs=1e-12)
        assert slide.lower == pytest.approx(2.0, abs=1e-12)
        assert slide.upper == pytest.approx(2.8, abs=1e-12)
    check_against_mujoco(edited, robot, PRESETS["simulator"][1])
    assert "joint values read from the file's" in str(import_mjcf(edited).report)


def test_a_full_turn_range_limits_nothing_and_angles_are_given_in_it():
    """RUS cranks with the range ``0 .. 2 pi`` (a CAD export's "no limit"), the file's
    zero at home: poses with cranks at negative angles from home are reachable, and the
    crank angles are given in ``[0, 2 pi)``, MuJoCo's modulo 2 pi."""
    cranks = {f"leg{i}_q1" for i in range(1, 7)}
    xml = rezeroed(_xml("rus"), dict.fromkeys(cranks, "baked"), full_turn=cranks)
    assert 'range="0 6.28' in xml
    robot = _import(xml)
    assert robot.description.architecture == "rus"
    source = robot.description.source
    for T, _, _ in states(robot, (0.003, 0.03), 6, seed=2):
        positions = robot.actuator_positions(T, check_limits=True)  # the file's convention
        assert np.all((positions >= 0.0) & (positions < 2 * math.pi))
    assert {src.wraps[0] for src in source.legs} == {0.0}
    check_against_mujoco(xml, robot, (0.003, 0.03))


def test_the_files_convention_survives_toml_and_json(tmp_path):
    """The signs, offsets and wraps are part of ``source``: written and read back with
    the description (TOML, dict), refused when not numbers."""
    xml = rezeroed(_xml("simulator"), **_edits("mixed"))
    desc = import_mjcf(xml).description
    assert not all(leg.identity for leg in desc.source.legs)
    back = RobotDescription.read(desc.write(tmp_path / "r.toml"))
    assert back.source == desc.source
    assert RobotDescription.from_dict(desc.to_dict()).source == desc.source
    bad = desc.to_dict()
    bad["source"]["legs"][0]["signs"] = [1, 2, 1]
    with pytest.raises(DescriptionError, match="signs must list three"):
        RobotDescription.from_dict(bad)


def test_a_urdf_with_turned_axes_is_the_ideal_6_ups(tmp_path):
    """The desktop preset's URDF (the project's writer) with every slide and second U-joint
    hinge turned round (``<axis xyz="0 0 -1"/>``, limits and home positions negated, in a
    version-2 sidecar given as a dict): the ideal 6-UPS, its efforts along the file's
    axes equal to the KKT on Pinocchio's own parse of the file (1e-10)."""
    pytest.importorskip("yourdfpy")
    from test_import_urdf import PinReference

    from stewart_pin.formats.urdf import closures_dict, urdf_string

    desc = preset("desktop")
    root = ET.fromstring(urdf_string(desc))
    flipped = {f"leg{i}_q{j}" for i in range(1, 7) for j in (2, 3)}
    for joint in root.iter("joint"):
        if joint.get("name") in flipped:
            joint.find("axis").set("xyz", "0 0 -1")
            limit = joint.find("limit")
            lo, hi = float(limit.get("lower")), float(limit.get("upper"))
            limit.set("lower", repr(-hi))
            limit.set("upper", repr(-lo))
    path = tmp_path / "flipped.urdf"
    path.write_text(ET.tostring(root, encoding="unicode"))
    sidecar = closures_dict(desc, path.name)
    sidecar["version"] = 2
    sidecar["home_joint_positions"] = {
        k: -v if k in flipped else v for k, v in sidecar["home_joint_positions"].items()
    }
    robot = StewartRobot.from_urdf(path, closures=sidecar)
    assert robot.is_ideal_ups
    assert {src.signs[2] for src in robot.description.source.legs} == {-1.0}

    class Reference(PinReference):
        def __init__(self):
            super().__init__(path, [], {})
            self.pairs = []
            for k, c in enumerate(sidecar["closures"]):
                ids = []
                for link, point in ((c["link1"], c["point1"]), (c["link2"], c["point2"])):
                    parent = self.model.frames[self.model.getFrameId(link)]
                    frame = pin.Frame(
                        f"loop{k}_{link}",
                        parent.parentJoint,
                        self.model.getFrameId(link),
                        parent.placement * pin.SE3(np.eye(3), np.array(point)),
                        pin.FrameType.OP_FRAME,
                    )
                    ids.append(self.model.addFrame(frame))
                self.pairs.append(tuple(ids))
            self.data = self.model.createData()
            self.S = np.zeros((6, self.model.nv))  # the slides, joint side, leg order
            for i, name in enumerate(sidecar["actuated_joints"]):
                self.S[i, self.model.joints[self.model.getJointId(name)].idx_v] = 1.0

        def closed_state(self, T, V):  # from the legs' home assembly, to round-off here
            q0 = pin.neutral(self.model)
            for name, value in sidecar["home_joint_positions"].items():
                q0[self.model.joints[self.model.getJointId(name)].idx_q] = value
            return super().closed_state(T, V, q0, tol=1e-13)

    ref = Reference()
    for T, V, A in states(robot, (0.005, 0.05), 3, seed=5):
        q, v = ref.closed_state(T, V)
        gamma_ref = ref.kkt(q, v, A=A)  # the sidecar's order: legs 1..6
        gamma = robot.inverse_dynamics(T, V, A)  # along the file's axes
        assert rel_error(gamma, gamma_ref) < 1e-10, f"IDM {rel_error(gamma, gamma_ref):.2e}"
