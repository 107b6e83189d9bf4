"""Robot names never become paths outside the output folder, nor markup (issue 9, item 3).

Two layers: the description refuses a name outside the documented safe set
(``NAME_RULE``, :class:`RobotNameError`); and every writer escapes (or refuses) a name that
bypassed that check, so the files it writes parse back, with independent parsers
(ElementTree, PyYAML, json, Pinocchio's URDF parser, MuJoCo), to exactly that name.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import RobotDescription, StewartRobot, preset
from stewart_pin._safe import check_xml_text, file_in_folder, toml_quoted, yaml_quoted
from stewart_pin.cli import main
from stewart_pin.description.robot_description import NAME_RULE, check_robot_name
from stewart_pin.exceptions import DescriptionError, FileFormatError, InputError, RobotNameError
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.formats.robot_files import write_robot_files
from stewart_pin.formats.urdf import closures_dict, urdf_string, write_urdf
from stewart_pin.formats.xacro import xacro_args, yaml_string

GOOD_NAMES = ["simulator", "random-7", "a", "7", "A_b.c-1", "x" * 64, "my_hexapod-2", "v1.2"]
BAD_NAMES = [
    "../../x",  # a path out of the folder
    "..",
    "a/b",
    "a\\b",
    "x--y",  # "--" ends an XML comment
    "x--><tag/><!--",  # markup
    'a"b',
    "a<b",
    "a&b",
    "a..b",
    ".hidden",
    "-rf",
    "_x",
    "a b",
    "name\n",  # re.match with "$" would accept this one
    "tab\there",
    "nul\0",
    "caf\u00e9",
    "x" * 65,
    "",
    3,
    None,
]
#: Names that bypass the check (set after construction), to test the writers' escaping.
HOSTILE_NAMES = [
    "x--><tag/><!--",
    "a\"b&c<d>'e",
    "]]><![CDATA[x",
    "line\nbreak\ttab\rreturn",
    "../../x",
    "caf\u00e9 \u4e2d \U0001f600",
    "${1+1} $(arg x)",
    "  padded  ",
    "</script><script>alert(1)</script>",
]


def bypassed(name: str) -> RobotDescription:
    """A valid description whose name is then forced to ``name`` (as a bug or a subclass
    could do): the writers must still not let it through unescaped."""
    desc = preset("desktop")
    object.__setattr__(desc, "name", name)
    return desc


# ---------------------------------------------------------------------- the name rule
@pytest.mark.parametrize("name", GOOD_NAMES)
def test_names_in_the_safe_set_are_accepted(name):
    assert check_robot_name(name) == name
    assert preset("desktop").replace(name=name).name == name


@pytest.mark.parametrize("name", BAD_NAMES, ids=repr)
def test_names_outside_the_safe_set_are_refused_naming_the_rule(name):
    with pytest.raises(RobotNameError) as info:
        preset("desktop").replace(name=name)
    assert isinstance(info.value, DescriptionError) and isinstance(info.value, ValueError)
    assert NAME_RULE in str(info.value)
    assert info.value.value == name


def test_path_traversal_name_is_refused_in_a_description_file(tmp_path):
    good = preset("desktop").write(tmp_path / "good.toml")
    evil = tmp_path / "evil.toml"
    evil.write_text(good.read_text().replace('name = "desktop"', 'name = "../../x"'))
    with pytest.raises(FileFormatError, match=r"robot name '\.\./\.\./x' is not allowed") as info:
        RobotDescription.read(evil)
    assert isinstance(info.value.__cause__, RobotNameError)


def test_name_with_path_traversal_cannot_write_outside_the_folder(tmp_path, monkeypatch, capsys):
    # Old code: `stewart-pin urdf` wrote ../../x.urdf and its sidecar, exit 0.
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    good = preset("desktop").write(tmp_path / "good.toml")
    evil = work / "evil.toml"
    evil.write_text(good.read_text().replace('name = "desktop"', 'name = "../../x"'))
    monkeypatch.chdir(work)
    assert main(["urdf", "--description", "evil.toml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "robot name '../../x' is not allowed" in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "evil.toml", "good.toml"]


@pytest.mark.parametrize("name", ["x--y", "x--><tag/><!--"])
def test_name_with_comment_close_is_refused_by_the_cli(tmp_path, monkeypatch, capsys, name):
    # Old code: exit 0 and a URDF whose comment the name broke (malformed XML).
    good = preset("desktop").write(tmp_path / "good.toml")
    evil = tmp_path / "evil.toml"
    evil.write_text(good.read_text().replace('"desktop"', json.dumps(name)))
    monkeypatch.chdir(tmp_path)
    assert main(["urdf", "--description", "evil.toml"]) == 2
    assert "is not allowed: a name must have" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["evil.toml", "good.toml"]


def test_cli_default_urdf_path_stays_in_the_working_folder(tmp_path, monkeypatch, capsys):
    # Defence in depth: a robot whose name bypassed the check still cannot pick the path.
    import stewart_pin.cli.geometry_cmds as geometry_cmds

    monkeypatch.setattr(
        geometry_cmds, "robot_from_args", lambda args: StewartRobot(bypassed("../escaped"))
    )
    work = tmp_path / "w"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["urdf"]) == 2
    assert "would be written outside the folder" in capsys.readouterr().err
    assert [p.name for p in tmp_path.rglob("*")] == ["w"]


# ---------------------------------------------------------------------- defence in depth
def _comments(text: str) -> list[str]:
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    parser.feed(text)
    root = parser.close()
    return [el.text for el in root.iter() if el.tag is ET.Comment]


@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=repr)
def test_name_with_comment_close_cannot_inject_markup_in_urdf(name):
    text = urdf_string(bypassed(name))
    root = ET.fromstring(text)  # well-formed
    assert root.tag == "robot" and root.get("name") == name
    assert root.find(".//tag") is None and root.find(".//script") is None
    # The comments before the root are fixed text.
    head = text[: text.index("<robot")]
    assert name not in head and head.count("<!--") == head.count("-->") == 2
    assert all(name not in c for c in _comments(text))
    # Pinocchio's own URDF parser reads the same name.
    assert pin.buildModelFromXML(text).name == name


@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=repr)
def test_name_with_comment_close_cannot_inject_markup_in_mjcf(name):
    mujoco = pytest.importorskip("mujoco")
    text = mjcf_string(bypassed(name))
    head = text[: text.index("<mujoco")]
    assert name not in head and head.count("<!--") == head.count("-->") == 2
    root = ET.fromstring(text)
    assert root.tag == "mujoco" and root.get("model") == name
    assert root.find(".//tag") is None
    model = mujoco.MjModel.from_xml_string(text)
    assert (model.nq, model.neq) == (25, 6)


@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=repr)
def test_name_round_trips_through_the_xacro_yaml(name):
    yaml = pytest.importorskip("yaml")
    desc = bypassed(name)
    text = yaml_string(xacro_args(desc), "a header")
    assert name not in text.split("\nname:")[0]  # not in the comments
    assert yaml.safe_load(text) == xacro_args(desc)
    assert yaml.safe_load(text)["name"] == name


@pytest.mark.parametrize(
    "text", ["", "plain", 'q"q', "back\\slash", "\x00\x07\x1f\x7f\x85", "\u2028\u2029\ufeff"]
)
def test_yaml_quoted_is_exact_for_any_text(text):
    yaml = pytest.importorskip("yaml")
    quoted = yaml_quoted(text)
    assert quoted.isascii() and quoted.isprintable()
    assert yaml.safe_load(f"k: {quoted}\n") == {"k": text}


@pytest.mark.parametrize(
    "text",
    [
        "",
        "plain",
        'q"q',
        "back\\slash",
        "\x00\x07\x1f\x7f\x85",
        "\u2028\u2029\ufeff",
        "é\U0001f600",
    ],
)
def test_toml_quoted_is_exact_for_any_text(text):
    import tomllib

    quoted = toml_quoted(text)
    assert quoted.isascii() and quoted.isprintable()
    assert tomllib.loads(f"k = {quoted}\n") == {"k": text}
    # a lone surrogate, which no TOML string can hold, becomes U+FFFD
    assert tomllib.loads(f"k = {toml_quoted('a' + chr(0xD800))}\n") == {"k": "a\ufffd"}


def test_closures_json_round_trips_a_hostile_name():
    desc = bypassed('x--><tag/><!--"}')
    assert json.loads(json.dumps(closures_dict(desc)))["urdf"] == desc.name + ".urdf"


@pytest.mark.parametrize("name", ["nul\0", "bell\x07", "esc\x1b[31m", "lone\ud800"], ids=repr)
def test_text_xml_cannot_hold_is_refused_by_the_writers(name):
    desc = bypassed(name)
    with pytest.raises(InputError, match="which XML cannot represent"):
        urdf_string(desc)
    with pytest.raises(InputError, match="which XML cannot represent"):
        mjcf_string(desc)
    assert check_xml_text("tab\tnew\nline\r", "x") == "tab\tnew\nline\r"


@pytest.mark.parametrize("name", ["../../x", "../x", "sub/x", "/tmp/x", "a/../../x", "..\\x"])
def test_robot_files_stay_in_their_folder(tmp_path, name):
    out = tmp_path / "a" / "out"
    with pytest.raises(InputError, match="outside the folder"):
        write_robot_files(bypassed(name), out)
    assert [p for p in tmp_path.rglob("*") if p.is_file()] == []


@pytest.mark.parametrize("file_name", ["..", ".", "", "a/b", "nul\0"])
def test_file_in_folder_refuses_what_is_not_a_plain_file_name(tmp_path, file_name):
    with pytest.raises(InputError, match="not a plain file name"):
        file_in_folder(tmp_path, file_name)


def test_file_in_folder_resolves_symlinks(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "out" / "r.urdf").symlink_to(tmp_path / "elsewhere" / "r.urdf")
    with pytest.raises(InputError, match="resolves outside the folder"):
        file_in_folder(tmp_path / "out", "r.urdf")
    assert file_in_folder(tmp_path / "out", "s.urdf") == tmp_path / "out" / "s.urdf"


def test_written_urdf_round_trips_the_name_from_disk(tmp_path):
    name = "x--><tag/><!--"
    path, sidecar = write_urdf(bypassed(name), tmp_path / "r.urdf")
    assert ET.parse(path).getroot().get("name") == name
    assert json.loads(sidecar.read_text())["urdf"] == "r.urdf"


def test_html_export_holds_no_robot_name(tmp_path):
    pytest.importorskip("meshcat")
    from stewart_pin.viz.viewer import Viewer

    name = "</script><script>alert(1)</script><!--"
    robot = StewartRobot(bypassed(name))
    poses = np.array([robot.home_pose, robot.home_pose])
    page = Viewer(robot).export_html(tmp_path / "m.html", poses, [0.0, 1.0]).read_text()
    assert "alert(1)" not in page and "<!--" not in page


def test_docs_state_the_name_rule():
    docs = (Path(__file__).resolve().parents[1] / "docs" / "description.md").read_text()
    assert NAME_RULE in " ".join(docs.split())
    doc = " ".join(RobotDescription.__doc__.split())
    assert "starting with a letter or a digit, without ``..`` or ``--``" in doc
