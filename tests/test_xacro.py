"""The xacro version of the URDF renders, with xacrodoc, to the URDF the writer makes."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin.description.presets import preset
from stewart_pin.formats.urdf import urdf_string
from stewart_pin.formats.xacro import write_xacro_args, xacro_args, yaml_string

xacrodoc = pytest.importorskip("xacrodoc", reason="xacrodoc (test extra) renders the xacro")
yaml = pytest.importorskip("yaml", reason="PyYAML (a dependency of xacro) reads the args")

XACRO = Path(__file__).resolve().parent.parent / "models" / "urdf" / "stewart.urdf.xacro"
ROBOTS = ["simulator", "desktop", "paper", "random-0", "random-7", "limited"]


def make(name: str):
    """A preset, or "limited": a random robot with U-joint limits [rad] of its own."""
    if name != "limited":
        return preset(name)
    rng = np.random.default_rng(4)
    lower = rng.uniform(-1.0, 0.0, (6, 2))
    return preset("random-4").replace(u_joint_limits=np.stack([lower, lower + 2.5], axis=-1))


def render(args_path: Path) -> str:
    doc = xacrodoc.XacroDoc.from_file(XACRO, subargs={"args_file": str(args_path.resolve())})
    return doc.to_urdf_string()


@pytest.fixture(scope="module", params=ROBOTS)
def rendered(request, tmp_path_factory):
    """``(description, args file, rendered URDF text)`` for each robot."""
    desc = make(request.param)
    args_path = write_xacro_args(desc, tmp_path_factory.mktemp("xacro") / "robot.xacro.yaml")
    return desc, args_path, render(args_path)


def canonical(element: ET.Element):
    """Tag, attributes and children (comments and layout dropped)."""
    return element.tag, dict(element.attrib), [canonical(c) for c in element]


def test_args_file_reads_back_exactly(rendered):
    desc, args_path, _ = rendered
    assert yaml.safe_load(args_path.read_text()) == xacro_args(desc)


@pytest.mark.parametrize("x", [1e-05, -2.5e-17, 1e16, 1.5e300, -0.0, 0.1 + 0.2, np.pi, 7.0])
def test_yaml_floats_are_floats(x):
    # PyYAML (YAML 1.1) reads "1e-05" as a string: the writer must add the dot.
    back = yaml.safe_load(yaml_string({"x": float(x), "v": [float(x), 1.0]}))
    assert isinstance(back["x"], float) and back == {"x": x, "v": [x, 1.0]}
    assert np.copysign(1.0, back["x"]) == np.copysign(1.0, x)


def test_rendered_xml_equals_writer_output(rendered):
    # Same elements, order and attribute strings: the numbers are the very same reprs.
    desc, _, text = rendered
    assert canonical(ET.fromstring(text)) == canonical(ET.fromstring(urdf_string(desc)))


def assert_models_agree(a: pin.Model, b: pin.Model, name: str, fields: tuple[str, ...]) -> None:
    """Two Pinocchio models of the same robot, joint by joint, to 1e-12: names, joint
    types, parents, placements, inertias, and the per-joint ``fields`` (limits, damping)."""
    assert a.name == b.name == name
    assert list(a.names) == list(b.names)
    assert (a.nq, a.nv, a.njoints) == (b.nq, b.nv, b.njoints) == (25, 24, 20)
    for j in range(1, a.njoints):
        joint = a.names[j]
        assert a.joints[j].shortname() == b.joints[j].shortname(), joint
        assert a.parents[j] == b.parents[j], joint
        assert np.allclose(
            a.jointPlacements[j].homogeneous, b.jointPlacements[j].homogeneous, rtol=0, atol=1e-12
        ), joint
        Ia, Ib = a.inertias[j], b.inertias[j]
        assert Ia.mass == pytest.approx(Ib.mass, rel=1e-12, abs=0.0), joint
        assert np.allclose(Ia.lever, Ib.lever, rtol=0, atol=1e-12), joint
        assert np.allclose(Ia.inertia, Ib.inertia, rtol=1e-12, atol=1e-15), joint
    for field in fields:
        assert np.allclose(getattr(a, field), getattr(b, field), rtol=1e-12, atol=0), field


def test_pinocchio_models_agree(rendered):
    desc, _, text = rendered
    a, b = pin.buildModelFromXML(text), pin.buildModelFromXML(urdf_string(desc))
    assert_models_agree(
        a,
        b,
        desc.name,
        ("lowerPositionLimit", "upperPositionLimit", "effortLimit", "velocityLimit"),
    )
    assert [f.name for f in a.frames] == [f.name for f in b.frames]


def test_yourdfpy_loads_rendered(rendered, tmp_path):
    yourdfpy = pytest.importorskip("yourdfpy")
    _, _, text = rendered
    path = tmp_path / "rendered.urdf"
    path.write_text(text)
    robot = yourdfpy.URDF.load(str(path), load_meshes=False)
    assert robot.validate()
    assert len(robot.robot.links) == 20
    assert sorted(robot.actuated_joint_names) == sorted(
        [f"leg{i}_q{j}" for i in range(1, 7) for j in (1, 2, 3)] + ["platform_joint"]
    )


def test_args_file_is_required():
    from xacro import XacroException  # xacrodoc's dependency

    with pytest.raises(XacroException, match="needs args_file"):
        xacrodoc.XacroDoc.from_file(XACRO)


# ------------------------------------------------------------------------- general legs
GENERAL_XACRO = XACRO.with_name("stewart_general.urdf.xacro")
GENERAL_ROBOTS = ["rus", "pus", "ups-offset", "custom-3"]


def make_general(name: str):
    """A general preset through the facade, or "custom-<seed>": a random custom-leg robot
    with every joint term non-zero (limits, damping, Coulomb friction)."""
    if name.startswith("custom-"):
        from stewart_pin.description.leg_chain_presets import random_hexapod

        return random_hexapod("custom", int(name.removeprefix("custom-")), joint_terms=True)
    from stewart_pin import StewartRobot

    return StewartRobot.from_preset(name).description


@pytest.fixture(scope="module", params=GENERAL_ROBOTS)
def rendered_general(request, tmp_path_factory):
    """``(description, args file, rendered URDF text)`` for each general robot."""
    desc = make_general(request.param)
    args_path = write_xacro_args(desc, tmp_path_factory.mktemp("xacro") / "robot.xacro.yaml")
    doc = xacrodoc.XacroDoc.from_file(
        GENERAL_XACRO, subargs={"args_file": str(args_path.resolve())}
    )
    return desc, args_path, doc.to_urdf_string()


def test_general_args_file_reads_back_exactly(rendered_general):
    desc, args_path, _ = rendered_general
    assert yaml.safe_load(args_path.read_text()) == xacro_args(desc)
    assert "stewart_general.urdf.xacro" in args_path.read_text().splitlines()[0]


def test_general_rendered_xml_equals_writer_output(rendered_general):
    # Same elements (visuals included), order and attribute strings.
    desc, _, text = rendered_general
    assert canonical(ET.fromstring(text)) == canonical(ET.fromstring(urdf_string(desc)))


def _joint_elements(text: str) -> dict[str, ET.Element]:
    return {j.get("name"): j for j in ET.fromstring(text).iter("joint")}


def test_general_joints_carry_the_description(rendered_general):
    # Independent of the writers: origins from the MDH parameters, limits and dynamics
    # from the legs' joints, to 1e-12.
    from stewart_pin.description.leg_architecture import mdh_transform

    desc, _, text = rendered_general
    joints = _joint_elements(text)
    for k, leg in enumerate(desc.legs):
        for j, joint in enumerate(leg.joints):
            el = joints[f"leg{k + 1}_q{j + 1}"]
            assert el.get("type") == joint.kind
            origin = el.find("origin")
            T = np.eye(4)
            T[:3, :3] = pin.rpy.rpyToMatrix(np.array(origin.get("rpy").split(), float))
            T[:3, 3] = np.array(origin.get("xyz").split(), float)
            expected = mdh_transform(joint.alpha, joint.d, joint.theta, joint.r)
            if j == 0:
                T0 = np.eye(4)
                T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
                expected = T0 @ expected
            assert np.allclose(T, expected, rtol=0, atol=1e-12)
            assert el.find("axis").get("xyz") == "0 0 1"
            limit = el.find("limit")
            for side, value in (("lower", joint.lower), ("upper", joint.upper)):
                written = float(limit.get(side))
                assert written == value if np.isfinite(value) else abs(written) == 1e9
            dyn = el.find("dynamics")
            d = joint.dynamics
            assert float(dyn.get("damping")) == pytest.approx(d.viscous + d.damping, abs=1e-12)
            assert float(dyn.get("friction")) == pytest.approx(d.coulomb, abs=1e-12)


def test_general_pinocchio_models_agree(rendered_general):
    desc, _, text = rendered_general
    a, b = pin.buildModelFromXML(text), pin.buildModelFromXML(urdf_string(desc))
    assert_models_agree(
        a, b, desc.name, ("lowerPositionLimit", "upperPositionLimit", "damping", "friction")
    )


def test_general_inertials_are_the_descriptions(rendered_general):
    # Pinocchio's inertia of each leg link == the description's Khalil parameters
    # (first moments m*c and inertia about the link origin), to 1e-12.
    desc, _, text = rendered_general
    model = pin.buildModelFromXML(text)
    for k in range(6):
        for j in range(3):
            I = model.inertias[model.getJointId(f"leg{k + 1}_q{j + 1}")]
            XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = np.asarray(desc.leg_inertia[k][j], float)
            J = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
            assert I.mass == pytest.approx(M, abs=1e-12)
            assert np.allclose(I.mass * I.lever, [MX, MY, MZ], rtol=0, atol=1e-12)
            c = I.lever
            about_origin = I.inertia + I.mass * (c @ c * np.eye(3) - np.outer(c, c))
            assert np.allclose(about_origin, J, rtol=0, atol=1e-12)


def test_general_source_refuses_ups_arguments(tmp_path):
    from xacro import XacroException

    args_path = write_xacro_args(preset("desktop"), tmp_path / "ups.xacro.yaml")
    with pytest.raises(XacroException, match="general legs"):
        xacrodoc.XacroDoc.from_file(GENERAL_XACRO, subargs={"args_file": str(args_path.resolve())})


# ------------------------------------------------------------------------- chain legs
CHAIN_XACRO = XACRO.with_name("stewart_chain.urdf.xacro")


def make_chain(name: str):
    """The welded 6-UPS (six joints, welds) or the mixed robot (ball and weld legs)."""
    from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups

    return welded_ups() if name == "welded-ups" else mixed_chain_robot(seed=2)


@pytest.fixture(scope="module", params=["welded-ups", "mixed-chain"])
def rendered_chain(request, tmp_path_factory):
    """``(description, args file, rendered URDF text)`` for each robot with chain legs."""
    desc = make_chain(request.param)
    args_path = write_xacro_args(desc, tmp_path_factory.mktemp("xacro") / "robot.xacro.yaml")
    doc = xacrodoc.XacroDoc.from_file(CHAIN_XACRO, subargs={"args_file": str(args_path.resolve())})
    return desc, args_path, doc.to_urdf_string()


def test_chain_args_file_reads_back_exactly(rendered_chain):
    desc, args_path, _ = rendered_chain
    assert yaml.safe_load(args_path.read_text()) == xacro_args(desc)
    assert "stewart_chain.urdf.xacro" in args_path.read_text().splitlines()[0]


def test_chain_rendered_xml_equals_writer_output(rendered_chain):
    # Same elements, order and attribute strings as the URDF writer's chain-leg tree.
    desc, _, text = rendered_chain
    assert canonical(ET.fromstring(text)) == canonical(ET.fromstring(urdf_string(desc)))


def test_chain_rendered_tree_closes_the_loops_at_home(rendered_chain):
    """Pinocchio's model of the rendered URDF, independently of the writer: at the legs'
    home joint values (the reference kinematics' Newton) each leg's attachment frame (last
    link, ``tip``, ``tip_rotation``) is the platform's at the home pose (P_i; a weld's
    orientation too) to 1e-12, and every link's inertia is the description's Khalil
    parameters (first moments, inertia about the link origin) to 1e-12."""
    from stewart_pin.kinematics import chain_legs

    desc, _, text = rendered_chain
    model = pin.buildModelFromXML(text)
    data = model.createData()
    q = pin.neutral(model)
    home = chain_legs.home_configuration(desc)
    for k, leg in enumerate(desc.chain_legs):
        for j in range(len(leg.joints)):
            q[model.joints[model.getJointId(f"leg{k + 1}_q{j + 1}")].idx_q] = home[k][j]
    pin.forwardKinematics(model, data, q)
    H = desc.home_pose
    for k, leg in enumerate(desc.chain_legs):
        n = len(leg.joints)
        oMn = data.oMi[model.getJointId(f"leg{k + 1}_q{n}")]
        tip = oMn.rotation @ leg.tip + oMn.translation
        P = H[:3, :3] @ desc.platform_points[k] + H[:3, 3]
        assert np.allclose(tip, P, rtol=0, atol=1e-12)
        if leg.closure == "weld":
            R = oMn.rotation @ leg.tip_rotation
            assert np.allclose(R, H[:3, :3] @ leg.platform_rotation, rtol=0, atol=1e-12)
        for j in range(n):
            I = model.inertias[model.getJointId(f"leg{k + 1}_q{j + 1}")]
            XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = np.asarray(leg.inertia[j], float)
            J = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
            assert I.mass == pytest.approx(M, abs=1e-12)
            assert np.allclose(I.mass * I.lever, [MX, MY, MZ], rtol=0, atol=1e-12)
            c = I.lever
            about_origin = I.inertia + I.mass * (c @ c * np.eye(3) - np.outer(c, c))
            assert np.allclose(about_origin, J, rtol=0, atol=1e-12)


def test_general_source_refuses_chain_arguments(tmp_path):
    from xacro import XacroException

    args_path = write_xacro_args(make_chain("mixed-chain"), tmp_path / "chain.xacro.yaml")
    with pytest.raises(XacroException, match="chain legs: stewart_chain"):
        xacrodoc.XacroDoc.from_file(GENERAL_XACRO, subargs={"args_file": str(args_path.resolve())})
    with pytest.raises(XacroException, match="robot with chain legs"):
        args_path = write_xacro_args(preset("desktop"), tmp_path / "ups.xacro.yaml")
        xacrodoc.XacroDoc.from_file(CHAIN_XACRO, subargs={"args_file": str(args_path.resolve())})
