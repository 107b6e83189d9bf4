"""Importing hexapods from Gazebo SDF (``StewartRobot.from_sdf``, ``importers.sdf``), and
the one-line refusal of files in formats not read.

Independent references (neither shares the SDF reader):
- Pinocchio's own URDF parser with the loops as hard point constraints in an exact KKT
  solve (``test_import_urdf.PinReference``) on an onshape-to-robot style URDF; the SDF
  under test is that URDF rewritten (``sdf_models.urdf_to_sdf``: the closing frame pairs
  as ball joints whose child is the platform, the model at a pose in a world, axes in the
  frame each SDFormat version says): inverse and direct dynamics to 1e-10 relative.
- A robot of the project's presets written by the project's URDF writer and imported
  (``from_urdf(write_urdf(d))``), against the same robot written as a Gazebo user's SDF
  (``sdf_models.gazebo_sdf``: universal joints, the platform the child of six ball
  joints, poses ``relative_to`` links and frames, joint zeros at the home pose): 1e-10.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from cad_models import cad_urdf
from helpers import rel_error
from sdf_models import closed_urdf, gazebo_sdf, urdf_to_sdf
from test_import_mjcf import differences, states
from test_import_urdf import RANGES, SOURCES, PinReference, pairs_of

from stewart_pin import FileFormatError, ModelImportError, StewartRobot
from stewart_pin.cli import main
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.description.presets import preset
from stewart_pin.formats.urdf import write_urdf
from stewart_pin.importers import import_model, import_sdf

pytest.importorskip("lxml")
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")


def write(tmp_path, text, name="robot.sdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def actuated_of(urdf: str) -> list[str]:
    """The URDF's ``<transmission>`` joints, in order (the legs' order)."""
    return [t.find("joint").get("name") for t in ET.fromstring(urdf).findall("transmission")]


def check_dynamics(robot, reference, ranges, n=3, seed=3, ddm=1e-10):
    """``robot`` against ``reference(T, V, A) -> (gamma, gamma -> A)``: the inverse
    dynamics to 1e-10 relative, the direct dynamics to ``ddm``."""
    for T, V, A in states(robot, ranges, n, seed=seed):
        gamma_ref, A_of = reference(T, V, A)
        gamma = robot.inverse_dynamics(T, V, A)
        assert rel_error(gamma, gamma_ref) < 1e-10, f"IDM {rel_error(gamma, gamma_ref):.2e}"
        A_back, A_ref = robot.direct_dynamics(T, V, gamma_ref), A_of(gamma_ref)
        assert rel_error(A_back, A_ref) < ddm, f"DDM {rel_error(A_back, A_ref):.2e}"


# --- 1. against Pinocchio's KKT on the URDF the SDF was written from ---------------------------


@pytest.mark.parametrize("version", ["1.4", "1.6", "1.9"])
@pytest.mark.parametrize("arch", list(SOURCES))
def test_sdf_matches_pinocchio_kkt_on_the_same_robot(arch, version, tmp_path):
    """Onshape-style robot (odd link frames, rotated inertial frames, fixed extra links,
    ``<dynamics>`` damping and friction on every joint) as SDF ``version``: 1.4 poses and
    axes in the model frame, 1.6 axes in the joint frame or ``use_parent_model_frame``, 1.9
    poses ``relative_to`` the parent link, axes ``expressed_in`` the child link; the model
    at a pose in its world."""
    urdf = closed_urdf(cad_urdf(SOURCES[arch](), seed=1, digits=15))
    urdf_path = write(tmp_path, urdf, "robot.urdf")
    path = write(tmp_path, urdf_to_sdf(urdf, version, seed=2))
    robot = StewartRobot.from_sdf(path, actuated=actuated_of(urdf))
    ref = PinReference(urdf_path, pairs_of(), {})
    ref.S = (ref.S != 0).astype(float)  # SDF has no gears: the joints' efforts

    def reference(T, V, A):
        q, v = ref.closed_state(T, V)
        return ref.kkt(q, v, A=A), lambda gamma: ref.kkt(q, v, gamma=gamma)

    # the direct dynamics to 1e-9: on one 6-RUS state this reference's KKT solve is
    # 1.1e-10 away from the URDF import of the same file too (its conditioning)
    check_dynamics(robot, reference, RANGES[arch], ddm=1e-9)
    terms = robot.description.legs[0].joints[0].dynamics
    assert (terms.viscous, terms.coulomb) == (0.0125, 0.0075)


def test_one_model_in_every_version_imports_identically(tmp_path):
    """The same robot written 1.4 (axes in the model frame), 1.6 and 1.9 (axes in the joint
    frame, or in the frame named), and 1.10 / 1.11 (1.9's text): the same description."""
    urdf = closed_urdf(cad_urdf(SOURCES["rus"](), seed=4, digits=15))
    order = actuated_of(urdf)
    texts = {ver: urdf_to_sdf(urdf, ver, seed=5) for ver in ("1.4", "1.6", "1.9")}
    texts["1.11"] = texts["1.9"].replace('version="1.9"', 'version="1.11"')
    first = None
    for ver, text in texts.items():
        desc = import_sdf(write(tmp_path, text, f"v{ver}.sdf"), order).description
        first = first or desc
        assert differences(desc, first) == [], ver
    # the 1.6 file read with 1.4's rule (axes in the model frame): another robot
    wrong = texts["1.6"].replace('version="1.6"', 'version="1.4"')
    desc = import_sdf(write(tmp_path, wrong, "wrong.sdf"), order).description
    assert differences(desc, first) != []


# --- 2. a Gazebo user's SDF against the preset through the URDF writer -------------------------


def _u_cross_massless(name: str, link: int):
    """Preset ``name`` with its U-joint cross (leg link ``link``) massless and its joint
    terms those SDF holds (viscous and Coulomb friction: no rotor, no gear)."""
    d = preset(name)
    inertia = np.array(d.leg_inertia)
    inertia[:, link] = 0.0
    legs = d.legs
    if legs is not None:
        legs = tuple(
            dataclasses.replace(
                leg,
                joints=tuple(
                    dataclasses.replace(
                        j,
                        dynamics=JointDynamics(
                            viscous=j.dynamics.viscous + 0.01, coulomb=j.dynamics.coulomb
                        ),
                    )
                    for j in leg.joints
                ),
            )
            for leg in legs
        )
    return dataclasses.replace(d, leg_inertia=inertia, legs=legs)


@pytest.mark.parametrize("version", ["1.4", "1.9"])
@pytest.mark.parametrize(("name", "cross", "kind"), [("simulator", 0, "P"), ("rus", 1, "R")])
def test_gazebo_style_sdf_matches_the_urdf_round_trip(name, cross, kind, version, tmp_path):
    """6-UPS (universal joint, slide, ball at the platform) and 6-RUS (crank, universal,
    ball): the actuated joint is each leg's one revolute or prismatic joint, legs in file
    order; Fp is the platform link's frame; the dynamics are those of the preset written
    by the URDF writer and imported."""
    d = _u_cross_massless(name, cross)
    urdf, _ = write_urdf(d, tmp_path / "ref.urdf")
    ref = StewartRobot.from_urdf(urdf)
    result = import_sdf(write(tmp_path, gazebo_sdf(d, version, seed=7)))
    robot = StewartRobot(result.description)
    assert [leg.actuated for leg in result.report.legs] == [3 if kind == "P" else 1] * 6
    assert [leg.actuator for leg in result.report.legs] == [
        f"leg{k}_q{3 if kind == 'P' else 1}" for k in range(1, 7)
    ]
    np.testing.assert_allclose(robot.home_pose, d.home_pose, atol=1e-12)
    assert "the world's other models ignored: 'model://ground_plane'" in str(result.report)

    def reference(T, V, A):
        return ref.inverse_dynamics(T, V, A), lambda gamma: ref.direct_dynamics(T, V, gamma)

    check_dynamics(robot, reference, (0.01, 0.03) if name == "rus" else (0.05, 0.05))


def test_gravity_false_links_ball_dynamics_and_a_loose_base_are_reported(tmp_path):
    """(``<gravity>false</gravity>`` links against a reference:
    tests/test_gravity_compensation.py.)"""
    d = _u_cross_massless("simulator", 0)
    plain = import_sdf(write(tmp_path, gazebo_sdf(d, seed=3), "a.sdf"))
    text = gazebo_sdf(d, seed=3, gravity_off=("platform", "leg2_link3"), ball_dynamics=True)
    result = import_sdf(write(tmp_path, text, "b.sdf"))
    report = str(result.report)
    assert "<gravity>false</gravity>: 'leg2_link3', 'platform'" in report or (
        "<gravity>false</gravity>: 'platform', 'leg2_link3'" in report
    )
    assert "the <dynamics> of ball joint 'leg1_ball' ignored (Gazebo applies none" in report
    assert result.description.platform_gravcomp == 1.0
    assert result.description.leg_gravcomp[1].tolist() == [0.0, 0.0, 1.0]
    no_gravcomp = result.description.replace(platform_gravcomp=0.0, leg_gravcomp=None)
    assert differences(no_gravcomp, plain.description) == []
    text = gazebo_sdf(d, seed=3, ball_dynamics=True)
    result = import_sdf(write(tmp_path, text, "b2.sdf"))
    assert differences(result.description, plain.description) == []
    loose = import_sdf(write(tmp_path, gazebo_sdf(d, seed=3, base="none"), "c.sdf"))
    assert "the base link 'base' is neither <static> nor jointed to the world" in str(loose.report)
    assert differences(loose.description, plain.description) == []
    # the platform written first (the canonical link): still the base is the base
    first = gazebo_sdf(d, seed=3, base="none")
    base_link = first[first.index('<link name="base">') : first.index("</link>") + 7]
    first = first.replace(base_link, "").replace("</model>", base_link + "</model>")
    moved = import_sdf(write(tmp_path, first, "e.sdf"))
    assert "the base link 'base' is neither" in str(moved.report)
    assert differences(moved.description, plain.description) == []
    static = import_sdf(write(tmp_path, gazebo_sdf(d, seed=3, base="static"), "d.sdf"))
    assert "neither <static>" not in str(static.report)
    assert differences(static.description, plain.description) == []


def test_legs_with_several_one_dof_joints_need_actuated(tmp_path):
    urdf = cad_urdf(SOURCES["pus"](), seed=1)
    path = write(tmp_path, urdf_to_sdf(urdf, "1.9", seed=2))
    with pytest.raises(ModelImportError, match=r"SDF has no actuators.*actuated=\[\.\.\.\]"):
        import_sdf(path)
    with pytest.raises(ModelImportError, match="drives 'nope', no joint of the model"):
        import_sdf(path, ["nope"] * 6)


# --- 3. refusals --------------------------------------------------------------------------------


def _model(body: str, version: str = "1.9") -> str:
    return f'<sdf version="{version}"><model name="m">{body}</model></sdf>'


_LINK = (
    '<link name="{n}"><inertial><mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>1</izz>'
    "</inertia></inertial></link>"
)


@pytest.mark.parametrize(
    ("text", "error", "message"),
    [
        (
            _model(_LINK.format(n="a") + "<include><uri>model://leg</uri></include>"),
            ModelImportError,
            r"line 1: <include> of 'model://leg' in model 'm': stewart-pin does not fetch "
            r"included models; expand it first \(`gz sdf -p FILE > expanded.sdf`\)",
        ),
        (
            _model(
                _LINK.format(n="a")
                + _LINK.format(n="b")
                + '<joint name="s" type="screw"><parent>a</parent><child>b</child></joint>'
            ),
            ModelImportError,
            "joint 's' is a screw joint: a coupled rotation",
        ),
        (
            _model(
                _LINK.format(n="a")
                + _LINK.format(n="b")
                + '<joint name="g" type="gearbox"><parent>a</parent><child>b</child></joint>'
            ),
            ModelImportError,
            "joint 'g' is a gearbox joint",
        ),
        (
            _model(
                _LINK.format(n="a")
                + '<link name="b"/><joint name="h" type="revolute"><parent>a</parent>'
                "<child>b</child></joint>"
            ),
            ModelImportError,
            "link 'b' has no <inertial>: SDFormat's default is 1 kg",
        ),
        (
            _model('<link name="a"><pose>0 nan 0 0 0 0</pose></link>'),
            ModelImportError,
            r"<pose> of link 'a' is '0 nan 0 0 0 0': 6 finite decimal number\(s\) expected",
        ),
        (
            _model(_LINK.format(n="a").replace("<mass>1", "<mass>inf")),
            ModelImportError,
            "<mass> of the <inertial> of link 'a' is 'inf'",
        ),
        (
            _model(_LINK.format(n="a") + _LINK.format(n="a")),
            ModelImportError,
            "two elements named 'a' in model 'm' \\(a link and a link\\)",
        ),
        (
            _model(
                _LINK.format(n="a")
                + _LINK.format(n="b")
                + '<joint name="a" type="fixed"><parent>a</parent><child>b</child></joint>'
            ),
            ModelImportError,
            "two elements named 'a' in model 'm' \\(a link and a joint\\)",
        ),
        (
            _model(_LINK.format(n="a").replace("<ixx>1</ixx>", "")),
            FileFormatError,
            "the <inertia> of link 'a' has no <ixx>",
        ),
        (
            _model(_LINK.format(n="a").replace("<mass>1</mass>", "")),
            FileFormatError,
            "the <inertial> of link 'a' has no <mass>",
        ),
        (_model(_LINK.format(n="a"), "1.3"), FileFormatError, "SDFormat version '1.3'"),
        (
            _model(
                '<frame name="f" attached_to="a"><pose relative_to="g">0 0 0 0 0 0</pose>'
                '</frame><frame name="g" attached_to="a"><pose relative_to="f">0 0 0 0 0 0'
                "</pose></frame>" + _LINK.format(n="a")
            ),
            ModelImportError,
            "the poses are relative to each other in a loop: f -> g -> f",
        ),
        (
            _model(
                _LINK.format(n="a")
                + _LINK.format(n="b")
                + '<joint name="h" type="revolute"><parent>a</parent><child>b</child><axis>'
                "<xyz>1 0 0</xyz><use_parent_model_frame>true</use_parent_model_frame>"
                "</axis></joint>"
            ),
            ModelImportError,
            "<use_parent_model_frame> is SDFormat 1.5/1.6; from 1.7 write",
        ),
        ("<robot name='r'/>", FileFormatError, "the root element is <robot>, not <sdf>"),
        (
            '<sdf version="1.9"><world name="w"><include><uri>model://hexapod</uri>'
            "</include></world></sdf>",
            ModelImportError,
            "the world's robot is an <include> of 'model://hexapod'",
        ),
    ],
)
def test_refusals_name_the_element_and_the_file(text, error, message, tmp_path):
    path = write(tmp_path, text, "bad.sdf")
    with pytest.raises(error, match=message) as info:
        import_sdf(path)
    assert str(path) in str(info.value)


def test_two_hinges_closing_on_one_link_are_refused(tmp_path):
    d = _u_cross_massless("simulator", 0)
    text = gazebo_sdf(d, seed=1).replace(
        'name="leg2_ball" type="ball"', 'name="leg2_ball" type="revolute"'
    )
    text = text.replace('name="leg3_ball" type="ball"', 'name="leg3_ball" type="revolute"')
    with pytest.raises(ModelImportError, match="a loop may close through ball or fixed joints"):
        import_sdf(write(tmp_path, text))


# --- 4. formats not read; the command line ----------------------------------------------------


@pytest.mark.parametrize(
    ("suffix", "said"),
    [
        (".wbt", "a Webots world"),
        (".proto", "a Webots PROTO"),
        (".slx", "a Simulink / Simscape Multibody model"),
        (".ssc", "a Simscape language file"),
        (".erb", "an ERB template"),
        (".xacro", "a xacro template (expand it to a URDF first with xacrodoc"),
        (".usda", "a USD stage"),
        (".stl", "a mesh, geometry only"),
        (".dae", "a mesh, geometry only"),
        (".step", "the suffix '.step' is no model format stewart-pin reads"),
    ],
)
def test_formats_not_read_get_one_line(suffix, said, tmp_path, capsys):
    path = write(tmp_path, "<x/>", f"robot{suffix}")
    with pytest.raises(FileFormatError, match=re.escape(said)):
        import_model(path)
    for args in (["import", str(path)], ["ik", "--model", str(path)]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and said in err, err


def test_each_importer_names_the_right_one(tmp_path):
    sdf = write(tmp_path, "<sdf/>", "r.sdf")
    with pytest.raises(FileFormatError, match=r"is an SDF file .*read it with from_sdf"):
        StewartRobot.from_mjcf(sdf)
    with pytest.raises(FileFormatError, match=r"is an SDF file .*read it with from_sdf"):
        StewartRobot.from_urdf(sdf)
    urdf = write(tmp_path, "<robot/>", "r.urdf")
    with pytest.raises(FileFormatError, match=r"is a URDF .*read it with from_urdf"):
        StewartRobot.from_sdf(urdf)


def test_cli_imports_sdf_and_takes_it_as_model(tmp_path, capsys):
    d = _u_cross_massless("simulator", 0)
    path = write(tmp_path, gazebo_sdf(d, "1.9", seed=2))
    out = tmp_path / "robot.toml"
    assert main(["import", str(path), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("SDF model 'gazebo_hexapod' ('robot.sdf')") and out.is_file()
    assert main(["ik", "--model", str(path)]) == 0
    capsys.readouterr()
    assert main(["import", str(path), "--keyframe", "home"]) == 2
    assert "--keyframe only applies to MJCF files" in capsys.readouterr().err
    actuated = [f"leg{k}_q3" for k in (2, 1, 3, 4, 5, 6)]
    assert main(["import", str(path), "--actuated", *actuated]) == 0
    assert "leg 1 (" in capsys.readouterr().out
    back = StewartRobot.from_file(out)
    assert math.isclose(back.description.platform_inertia[9], d.platform_inertia[9])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        StewartRobot.from_sdf(path, name="gz")


# --- 5. SDF details ------------------------------------------------------------------------------


def test_frames_as_joint_ends_a_lone_model_and_several_models(tmp_path):
    """A ball joint's child written as a ``<frame>`` on the platform (SDFormat 1.8+), the
    model alone in the file (SDFormat's default gravity, -9.8 z), and a world with a second
    model without joints: the same robot."""
    d = _u_cross_massless("simulator", 0)
    text = gazebo_sdf(d, "1.9", seed=4)
    plain = import_sdf(write(tmp_path, text, "a.sdf")).description
    framed = text.replace(
        '<link name="platform">',
        '<frame name="top" attached_to="platform"/><link name="platform">',
    ).replace("<child>platform</child>", "<child>top</child>")
    assert framed.count("<child>top</child>") == 6
    assert differences(import_sdf(write(tmp_path, framed, "b.sdf")).description, plain) == []
    start, end = text.index("<model "), text.index("</model>") + len("</model>")
    lone = f'<sdf version="1.9">{text[start:end]}</sdf>'
    desc = import_sdf(write(tmp_path, lone, "c.sdf")).description
    np.testing.assert_array_equal(desc.gravity, [0.0, 0.0, -9.8])
    assert differences(desc, plain) == ["/gravity: 0.01"]
    crowded = text.replace(
        "<include><uri>model://ground_plane</uri></include>",
        '<model name="table"><static>true</static>' + _LINK.format(n="top") + "</model>",
    )
    result = import_sdf(write(tmp_path, crowded, "d.sdf"))
    assert "the world's other models ignored: 'table'" in str(result.report)
    assert differences(result.description, plain) == []


def test_pose_forms_are_the_same_rotation(tmp_path):
    """``x y z roll pitch yaw`` (fixed axes: ``Rz Ry Rx``), in degrees, and ``quat_xyzw``."""
    from scipy.spatial.transform import Rotation

    from stewart_pin.importers.sdf import read_sdf

    R = Rotation.from_euler("xyz", [0.3, -0.7, 1.9])
    x, y, z, w = (float(c) for c in R.as_quat())
    rpy = " ".join(repr(float(a)) for a in R.as_euler("xyz"))
    deg = " ".join(repr(float(a)) for a in R.as_euler("xyz", degrees=True))
    poses = [
        f"<pose>1 2 3 {rpy}</pose>",
        f'<pose degrees="true">1 2 3 {deg}</pose>',
        f'<pose rotation_format="quat_xyzw">1 2 3 {x!r} {y!r} {z!r} {w!r}</pose>',
    ]
    for pose in poses:
        body = _LINK.format(n="a").replace("<inertial>", pose + "<inertial>")
        model = read_sdf(write(tmp_path, _model(body), "p.sdf")).model
        T = model.bodies[1].pose
        np.testing.assert_allclose(T[:3, :3], R.as_matrix(), atol=1e-14)
        np.testing.assert_allclose(T[:3, 3], [1, 2, 3], atol=0)
