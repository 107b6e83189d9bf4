"""The platform frame of an imported model (issue 21, item 4).

A platform hanging from leg 1 in the tree: leg 1's slide carries a light rod-end body
(84 g) with a ball joint, the heavy platform fixed to it (a child body without a joint,
or a ``weld``), the other legs closed by ``connect``. Fp must be the platform body's
frame (the heaviest of the rigid group), named in the report, overridable with
``platform=``; poses in and out in that frame.

Independent reference: MuJoCo's own model of the file in an exact KKT solve
(``helpers.mujoco_kkt``) with the motion prescribed to the ``platform`` body's frame.
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from helpers import mujoco_closed_state, mujoco_kkt, rel_error
from scipy.spatial.transform import Rotation

from stewart_pin import ModelImportWarning, StewartRobot
from stewart_pin.description.presets import preset
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import import_mjcf

mujoco = pytest.importorskip("mujoco")


def _vec(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def hanging_platform(rod_end_mass: float = 0.084, weld: bool = False) -> str:
    """The simulator preset with its platform hanging from leg 1 through a rod end
    (module docstring): the rod end's frame turned at an odd angle, its origin at the
    ball's centre; the home keyframe puts every body where the writer's home has it."""
    xml = mjcf_string(preset("simulator"))
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    mujoco.mj_kinematics(m, d)
    R3 = d.xmat[m.body("leg1_link3").id].reshape(3, 3)
    Rp = d.xmat[m.body("platform").id].reshape(3, 3)
    turn = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()  # rod-end frame vs platform
    root = ET.fromstring(xml)
    world = root.find("worldbody")
    platform = world.find("body[@name='platform']")
    world.remove(platform)
    platform.remove(platform.find("freejoint"))
    p1 = np.array(
        [float(x) for x in platform.find("site[@name='platform_p1']").get("pos").split()]
    )
    link3 = next(b for b in root.iter("body") if b.get("name") == "leg1_link3")
    rod_end = ET.SubElement(
        link3,
        "body",
        name="rod_end",
        quat=_vec(Rotation.from_matrix(R3.T @ Rp @ turn).as_quat(scalar_first=True)),
    )
    ET.SubElement(rod_end, "joint", name="rod_end_ball", type="ball")
    ET.SubElement(
        rod_end,
        "inertial",
        pos="0.01 0 0.02",
        mass=repr(rod_end_mass),
        diaginertia="2e-5 3e-5 4e-5",
    )
    platform.set("pos", _vec(turn.T @ -p1))
    platform.set("quat", _vec(Rotation.from_matrix(turn.T).as_quat(scalar_first=True)))
    if weld:  # the platform its own body, welded to the rod end where it sits at home
        platform.set("pos", _vec(d.xpos[m.body("platform").id]))
        platform.set("quat", _vec(Rotation.from_matrix(Rp).as_quat(scalar_first=True)))
        ET.SubElement(platform, "freejoint", name="platform_joint")
        world.append(platform)
        ET.SubElement(root.find("equality"), "weld", name="rod_weld", body1="rod_end",
                      body2="platform")  # fmt: skip
    else:
        rod_end.append(platform)
    equality = root.find("equality")
    equality.remove(equality.find("connect[@name='loop1']"))
    if weld:  # the rod end's pose in the platform's frame at home (relpose: the
        # platform's origin in the rod end, then the rotation, quaternion w x y z)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = turn.T, turn.T @ -p1
        weld_el = equality.find("weld[@name='rod_weld']")
        weld_el.set("relpose", _vec([*T[:3, 3], *Rotation.from_matrix(T[:3, :3]).as_quat(
            scalar_first=True)]))  # fmt: skip
    key = root.find("keyframe/key")
    key.set("qpos", "0")
    text = ET.tostring(root, encoding="unicode")
    new_m = mujoco.MjModel.from_xml_string(re.sub(r'<key name="home" qpos="0" />', "", text))
    q = np.array(new_m.qpos0)
    for j in range(new_m.njnt):
        name = new_m.joint(j).name
        adr = new_m.jnt_qposadr[j]
        if name == "rod_end_ball":
            q[adr : adr + 4] = (1.0, 0.0, 0.0, 0.0)
        else:
            old = m.jnt_qposadr[m.joint(name).id]
            size = 7 if name == "platform_joint" else 1
            q[adr : adr + size] = m.key_qpos[0][old : old + size]
    key.set("qpos", _vec(q))
    return ET.tostring(root, encoding="unicode")


def _import(xml: str, **options) -> StewartRobot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        return StewartRobot.from_mjcf(xml, **options)


def _check_against_mujoco(xml: str, robot: StewartRobot, body: str) -> None:
    """Poses, twists and accelerations of ``body``'s frame given to the robot; its IDM
    against the KKT solve on MuJoCo's model of the file with ``body`` so moved."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    for _ in range(3):
        T = robot.home_pose
        T[:3, 3] += rng.uniform(-0.05, 0.05, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-0.05, 0.05, 3)) @ T[:3, :3]
        V, A = rng.normal(size=6) * 0.2, rng.normal(size=6)
        mujoco_closed_state(m, data, body, T, V, guess=m.key_qpos[0])
        gamma_mj = mujoco_kkt(m, data, body, A=A)
        gamma = robot.inverse_dynamics(T, V, A)
        assert rel_error(gamma, gamma_mj) < 1e-10, f"IDM {rel_error(gamma, gamma_mj):.2e}"


@pytest.mark.parametrize("weld", [False, True])
def test_platform_hanging_from_a_leg_is_the_heaviest_body(weld):
    """Fp is the 1200 kg platform's frame, not the 84 g rod end's through which it hangs
    (the rod end was Fp: poses meant for the platform gave efforts 13-45 % wrong); the
    report names it; the home pose is the platform's in MuJoCo; the dynamics are the
    file's with the platform so moved."""
    xml = hanging_platform(weld=weld)
    result = import_mjcf(xml)
    assert result.report.platform == "platform"
    assert result.description.source.platform == "platform"
    assert "platform 'platform' (Fp)" in str(result.report)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = m.key_qpos[0]
    mujoco.mj_kinematics(m, d)
    b = m.body("platform").id
    home = result.description.home_pose
    assert np.abs(home[:3, 3] - d.xpos[b]).max() < 1e-12
    assert np.abs(home[:3, :3] - d.xmat[b].reshape(3, 3)).max() < 1e-12
    robot = _import(xml)
    assert robot.is_ideal_ups
    _check_against_mujoco(xml, robot, "platform")


def test_platform_option_chooses_the_body():
    """``platform="rod_end"``: Fp is the rod end's frame, poses in it, the dynamics the
    file's with the rod end so moved."""
    xml = hanging_platform()
    robot = _import(xml, platform="rod_end")
    assert robot.description.source.platform == "rod_end"
    _check_against_mujoco(xml, robot, "rod_end")


def test_two_bodies_of_similar_mass_are_warned_about():
    """A rod end within 10 % of the platform's mass: a warning naming both, and the
    report line; the heavier is Fp."""
    xml = hanging_platform(rod_end_mass=1150.0)
    with pytest.warns(ModelImportWarning, match=r"similar mass, 'platform' \(1200 kg\)"):
        result = import_mjcf(xml)
    assert result.report.platform == "platform"
    assert re.search(r"note: the platform's rigid group has two bodies", str(result.report))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelImportWarning)
        import_mjcf(hanging_platform(rod_end_mass=1000.0))  # 17 % lighter: no warning


def test_a_floating_platform_keeps_the_body_with_the_free_joint():
    """A free platform carrying a heavier body fixed to it (a payload): Fp stays the
    body the file moves (its free joint), no warning."""
    xml = mjcf_string(preset("simulator")).replace(
        '<site name="platform_p1"',
        '<body name="payload" pos="0 0 0.3"><inertial pos="0 0 0" mass="5000" '
        'diaginertia="10 10 10" /></body>\n      <site name="platform_p1"',
        1,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelImportWarning)
        result = import_mjcf(xml)
    assert result.report.platform == "platform"
    assert "payload" in str(result.report)  # lumped into the platform
