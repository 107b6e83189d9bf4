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


def test_pinocchio_models_agree(rendered):
    desc, _, text = rendered
    a, b = pin.buildModelFromXML(text), pin.buildModelFromXML(urdf_string(desc))
    assert a.name == b.name == desc.name
    assert list(a.names) == list(b.names)
    assert (a.nq, a.nv, a.njoints) == (b.nq, b.nv, b.njoints) == (25, 24, 20)
    for j in range(1, a.njoints):
        name = a.names[j]
        assert a.joints[j].shortname() == b.joints[j].shortname(), name
        assert a.parents[j] == b.parents[j], name
        assert np.allclose(
            a.jointPlacements[j].homogeneous, b.jointPlacements[j].homogeneous, rtol=0, atol=1e-12
        ), name
        Ia, Ib = a.inertias[j], b.inertias[j]
        assert Ia.mass == pytest.approx(Ib.mass, rel=1e-12, abs=0.0), name
        assert np.allclose(Ia.lever, Ib.lever, rtol=0, atol=1e-12), name
        assert np.allclose(Ia.inertia, Ib.inertia, rtol=1e-12, atol=1e-15), name
    for limit in ("lowerPositionLimit", "upperPositionLimit", "effortLimit", "velocityLimit"):
        assert np.allclose(getattr(a, limit), getattr(b, limit), rtol=1e-12, atol=0), limit
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
