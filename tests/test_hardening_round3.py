"""Hardening, round 3 (issue 25, items 1-5 and 10): the importers, payloads and outputs.

Independent references:
- special files (FIFO, device node, symbolic link) given as outputs: ``os.lstat`` of the
  destination after the attempt (still the special file, the link's target unchanged);
- ``-o -``: the CSV on standard output against the constrained dynamics of Pinocchio's
  closed-loop tree (``constrained_inverse_dynamics``), the TOML against the description
  the importer gives;
- a URDF whose joints close a cycle: the import returns (in a child process with a time
  limit: a hang is a failure, not a frozen test run) with the joint's name.
"""

from __future__ import annotations

import io
import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from stewart_pin import InputError, ModelImportError, StewartRobot
from stewart_pin._io import atomic_open, write_text_atomic
from stewart_pin.cli import main

SRC = Path(__file__).resolve().parents[1] / "src"
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")


# ---------------------------------------------------------------------- item 2: special files
def _special_files(tmp_path: Path) -> dict[str, Path]:
    """A FIFO, a symbolic link to a regular file, and (as root) a character device."""
    out = {}
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    out["FIFO"] = fifo
    target = tmp_path / "target.csv"
    target.write_text("keep\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    out["symbolic link"] = link
    if os.geteuid() == 0:
        device = tmp_path / "null.csv"
        os.mknod(device, stat.S_IFCHR | 0o600, os.makedev(1, 3))  # a /dev/null node
        out["character device"] = device
    return out


def _kind(path: Path) -> int:
    return stat.S_IFMT(os.lstat(path).st_mode)


def test_atomic_writer_refuses_special_files_and_leaves_them(tmp_path):
    files = _special_files(tmp_path)
    before = {name: _kind(path) for name, path in files.items()}
    for name, path in files.items():
        with pytest.raises(InputError, match=name.split()[-1]):
            write_text_atomic(path, "t,x\n0,1\n")
        with pytest.raises(InputError, match=str(path.name)):
            with atomic_open(path, "wb") as handle:
                handle.write(b"data")
        assert _kind(path) == before[name], f"the {name} was replaced"
    assert (tmp_path / "target.csv").read_text() == "keep\n"  # through the link: untouched
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")) == []
    # a regular file is still replaced, atomically
    regular = tmp_path / "regular.csv"
    regular.write_text("old\n")
    write_text_atomic(regular, "new\n")
    assert regular.read_text() == "new\n"


def test_cli_refuses_special_outputs_in_one_line(tmp_path, capsys):
    files = _special_files(tmp_path)
    for name, path in files.items():
        capsys.readouterr()
        code = main(["simulate", "--duration", "0.002", "--no-progress", "-o", str(path)])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and name in err, err
        assert stat.S_ISREG(os.lstat(path).st_mode) is False
    assert (tmp_path / "target.csv").read_text() == "keep\n"


def test_idm_writes_the_forces_csv_to_stdout(tmp_path, capsysbinary):
    from stewart_pin.check.constrained_dynamics import constrained_inverse_dynamics
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, state_table, write_csv
    from stewart_pin.motion.trajectories import standard_motion

    robot = StewartRobot.from_preset("desktop")
    tr = standard_motion(robot, "washout").sample(np.linspace(0, 4.0, 12))
    traj = write_csv(
        tmp_path / "traj.csv", STATE_COLUMNS, state_table(tr.times, tr.poses, tr.twists, tr.accels)
    )
    assert main(["idm", "--preset", "desktop", "--trajectory", str(traj), "-o", "-"]) == 0
    captured = capsysbinary.readouterr()
    lines = captured.out.decode().splitlines()
    assert lines[0] == "t,gamma1,gamma2,gamma3,gamma4,gamma5,gamma6"
    table = np.loadtxt(io.StringIO("\n".join(lines[1:])), delimiter=",")
    ref, _ = constrained_inverse_dynamics(robot, tr.poses, tr.twists, tr.accels)
    np.testing.assert_array_equal(table[:, 0], tr.times)
    np.testing.assert_allclose(table[:, 1:], ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    assert b"peak |Gamma_i|" in captured.err  # the summary on stderr, not in the table
    assert not (tmp_path / "-").exists() and not Path("-").exists()


def test_simulate_and_import_write_to_stdout(tmp_path, capsysbinary, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = ["simulate", "--duration", "0.003", "--no-progress", "--backend", "pinocchio"]
    assert main([*args, "-o", "-"]) == 0
    captured = capsysbinary.readouterr()
    assert captured.out.startswith(b"t,x,y,z,") and b"simulated" in captured.err
    assert main([*args, "-o", "file.csv"]) == 0  # the same run written to a file
    assert captured.out == (tmp_path / "file.csv").read_bytes()
    (tmp_path / "file.csv").unlink()
    capsysbinary.readouterr()
    # import -o -: the TOML of the imported description
    path = tmp_path / "robot.urdf"
    StewartRobot.from_preset("desktop").write_urdf(path)
    assert main(["import", str(path), "-o", "-"]) == 0
    captured = capsysbinary.readouterr()
    toml = tmp_path / "got.toml"
    toml.write_bytes(captured.out)
    got = StewartRobot.from_file(toml).description
    from stewart_pin.importers import import_urdf

    want = import_urdf(path).description
    np.testing.assert_allclose(got.base_points, want.base_points, rtol=0, atol=1e-15)
    assert got.platform_inertia == pytest.approx(want.platform_inertia, rel=1e-15)
    assert b"wrote -" in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["robot.urdf", "robot.closures.json", "got.toml"]
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["animate", "-o", "-"],
        ["urdf", "-o", "-"],
        ["demo", "-o", "-"],
        ["identify", "-o", "-"],
        ["simulate", "--payload", "x.urdf", "-o", "-"],
    ],
)
def test_file_outputs_refuse_stdout_in_one_line(argv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "standard output" in err, err
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- item 3: joint cycles
_LINK = (
    '<link name="{}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" '
    'iyz="0" izz="1"/></inertial></link>'
)
_JOINT = (
    '<joint name="{}" type="revolute"><parent link="{}"/><child link="{}"/><axis xyz="0 0 1"/>'
    '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
)


def _urdf(links: list[str], joints: list[tuple[str, str, str]]) -> str:
    body = [_LINK.format(n) for n in links] + [_JOINT.format(*j) for j in joints]
    return '<robot name="cyc">' + "".join(body) + "</robot>"


def _import_in_child(path: Path, entry: str, timeout: float = 60.0) -> str:
    """The importer's error message, run in a child process killed after ``timeout`` [s]
    (a hang fails the test) with at most 2 GB of memory."""
    code = textwrap.dedent(
        f"""
        import resource, sys
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
        from stewart_pin import StewartRobot, ModelImportError
        from stewart_pin.cli import main
        path = {str(path)!r}
        try:
            if {entry!r} == "from_urdf":
                StewartRobot.from_urdf(path)
            else:
                sys.exit(main([{entry!r}, path] if {entry!r} == "import" else
                              [{entry!r}, "--model", path]))
        except ModelImportError as e:
            print("ModelImportError:", e, "joints:", e.joints)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    try:
        run = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=env,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"importing {path.name} ({entry}) did not return within {timeout} s")
    return run.stdout + run.stderr + f"exit {run.returncode}"


def test_a_urdf_joint_cycle_is_refused_naming_the_joint(tmp_path):
    cyc = tmp_path / "cycle.urdf"  # base -> a -> b -> a
    cyc.write_text(
        _urdf(["base", "a", "b"], [("j1", "base", "a"), ("j2", "a", "b"), ("j3", "b", "a")])
    )
    out = _import_in_child(cyc, "from_urdf")
    assert "ModelImportError:" in out and "'j3'" in out and "('j3',)" in out, out
    out = _import_in_child(cyc, "import")
    assert "error:" in out and "'j3' closes a cycle" in out and "exit 2" in out, out
    assert "Traceback" not in out
    out = _import_in_child(cyc, "ik")  # --model
    assert "'j3' closes a cycle" in out and "exit 2" in out, out


def test_a_urdf_cycle_apart_from_the_root_is_refused(tmp_path):
    """Links c, d hang from nothing but each other: no second root, no path from the root."""
    path = tmp_path / "island.urdf"
    path.write_text(
        _urdf(["base", "a", "c", "d"], [("j1", "base", "a"), ("k1", "c", "d"), ("k2", "d", "c")])
    )
    with pytest.raises(ModelImportError, match="'k1' is not reached from the root") as info:
        StewartRobot.from_urdf(path)
    assert info.value.joints == ("k1",)


def test_a_payload_urdf_cycle_is_refused_not_dropped(tmp_path):
    """Pinocchio's parser loads the tree from the root and drops links c, d (50 kg) of a
    cycle no path from the root enters."""
    from stewart_pin import PayloadError
    from stewart_pin.models.payload import Payload

    path = tmp_path / "island.urdf"
    text = _urdf(
        ["base", "a", "c", "d"], [("j1", "base", "a"), ("k1", "c", "d"), ("k2", "d", "c")]
    )
    path.write_text(text.replace('<mass value="1"/>', '<mass value="50"/>', 3))
    with pytest.raises(PayloadError, match="joint 'k1' is not reached from the root link 'base'"):
        Payload.from_urdf(path)
    path.write_text(
        _urdf(["base", "a", "b"], [("j1", "base", "a"), ("j2", "a", "b"), ("j3", "b", "a")])
    )
    with pytest.raises(PayloadError, match="joint 'j3' closes a cycle"):
        Payload.from_urdf(path)


# ---------------------------------------------------------------------- item 1: mesh paths
_STL = (
    "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.1 0 0\n"
    "vertex 0 0.1 0\nendloop\nendfacet\nendsolid t\n"
)


def _arm(mesh: str, mass: str = "1.5", inertia: str = "0.01") -> str:
    """A one-joint payload URDF whose base link is drawn with ``mesh``."""
    return (
        '<robot name="arm"><link name="base"><inertial><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
        f'<visual><geometry><mesh filename="{mesh}"/></geometry></visual></link>'
        f'<link name="l1"><inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="{inertia}" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
        "</link>"
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<origin xyz="0 0 0.05" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint></robot>'
    )


@pytest.fixture()
def mesh_tree(tmp_path):
    """``arm/meshes/box.stl`` (shipped), ``secret/secret.stl`` (outside), and a symbolic
    link ``arm/meshes/link.stl`` to the outside file."""
    (tmp_path / "arm" / "meshes").mkdir(parents=True)
    (tmp_path / "secret").mkdir()
    (tmp_path / "arm" / "meshes" / "box.stl").write_text(_STL)
    (tmp_path / "secret" / "secret.stl").write_text(_STL)
    (tmp_path / "arm" / "meshes" / "link.stl").symlink_to(tmp_path / "secret" / "secret.stl")
    return tmp_path


def test_payload_meshes_outside_the_urdf_folder_are_refused(mesh_tree, monkeypatch):
    pytest.importorskip("meshcat")
    from stewart_pin import PayloadMeshError
    from stewart_pin.models.payload import Payload
    from stewart_pin.viz.payload_scene import PayloadScene

    urdf = mesh_tree / "arm" / "arm.urdf"
    urdf.write_text(_arm("meshes/box.stl"))
    scene = PayloadScene(Payload.from_urdf(urdf))
    assert scene.meshes  # the shipped mesh is drawn
    monkeypatch.chdir(mesh_tree)  # a relative URDF path: Pinocchio's mesh path is relative
    assert PayloadScene(Payload.from_urdf(Path("arm") / "arm.urdf")).meshes
    secret = mesh_tree / "secret" / "secret.stl"
    for mesh in (str(secret), "../secret/secret.stl", f"file://{secret}", "meshes/link.stl"):
        urdf.write_text(_arm(mesh))
        payload = Payload.from_urdf(urdf)
        with pytest.raises(PayloadMeshError, match="outside the URDF's folder") as info:
            PayloadScene(payload)
        assert info.value.real == str(secret.resolve()), mesh
        assert PayloadScene(payload, meshes=False).meshes is False  # shapes read no file


def test_the_payload_demo_refuses_a_mesh_from_outside_before_its_run(mesh_tree):
    pytest.importorskip("meshcat")
    from stewart_pin import PayloadMeshError
    from stewart_pin.apps.payload_demo import run_payload_demo

    urdf = mesh_tree / "arm" / "arm.urdf"
    urdf.write_text(_arm("meshes/link.stl"))
    with pytest.raises(PayloadMeshError, match=r"link\.stl"):
        run_payload_demo("simulator", urdf, mesh_tree / "demo")
    assert list((mesh_tree / "demo").iterdir()) == []  # nothing computed, nothing written


def test_animate_refuses_a_payload_mesh_from_outside_in_one_line(mesh_tree, capsys):
    pytest.importorskip("meshcat")
    urdf = mesh_tree / "arm" / "arm.urdf"
    urdf.write_text(_arm("../secret/secret.stl"))
    out = mesh_tree / "a.html"
    argv = ["animate", "--duration", "0.1", "--fps", "5", "--payload", str(urdf), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "secret.stl" in err and "outside" in err, err
    assert not out.exists()


# ---------------------------------------------------------------------- item 5: strict numbers
@pytest.mark.parametrize(
    ("mass", "inertia", "shown"),
    [
        ("1,5", "0.01", "<mass value='1,5'> of link 'l1'"),
        ("1.5kg", "0.01", "<mass value='1.5kg'> of link 'l1'"),
        ("1.5", "0,01", "<inertia ixx='0,01'> of link 'l1'"),
        ("1_5", "0.01", "<mass value='1_5'>"),
        (" 1.5", "0.01", "<mass value=' 1.5'>"),
        ("1.5", "\u0661", "<inertia ixx="),  # an Arabic-Indic digit
    ],
)
def test_payload_numbers_are_parsed_strictly(mass, inertia, shown, tmp_path, capsys):
    from stewart_pin import PayloadError
    from stewart_pin.models.payload import Payload

    good = tmp_path / "good.urdf"
    good.write_text(_arm("meshes/none.stl"))
    assert Payload.from_urdf(good).mass == pytest.approx(2.5, rel=1e-15)  # 1 + 1.5 [kg]
    bad = tmp_path / "bad.urdf"
    bad.write_text(_arm("meshes/none.stl", mass, inertia))
    with pytest.raises(PayloadError, match="is not a number") as info:
        Payload.from_urdf(bad)
    assert shown in str(info.value)
    argv = ["simulate", "--duration", "0.002", "--no-progress", "--payload", str(bad)]
    assert main([*argv, "-o", str(tmp_path / "s.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and shown in err, err
    assert not (tmp_path / "s.npz").exists()


@pytest.mark.parametrize(
    ("old", "new", "missing"),
    [
        ('<mass value="1.5"/>', "<mass/>", "misses mass"),
        ('<inertia ixx="0.01" ', "<inertia ", "misses ixx"),
        (
            '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
            "<joint",
            "</inertial></link><joint",
            "misses ixx, ixy, ixz, iyy, iyz, izz",
        ),
    ],
)
def test_an_incomplete_payload_inertial_is_refused(old, new, missing, tmp_path):
    """Pinocchio's parser prints a line and loads link l1 without its inertial."""
    from stewart_pin import PayloadError
    from stewart_pin.models.payload import Payload

    text = _arm("meshes/none.stl")
    at = text.index('<link name="l1">')
    bad = text[:at] + text[at:].replace(old, new, 1)
    assert bad != text
    path = tmp_path / "bad.urdf"
    path.write_text(bad)
    with pytest.raises(PayloadError, match=f"<inertial> of link 'l1' {missing}"):
        Payload.from_urdf(path)


def test_importer_numbers_are_parsed_strictly(tmp_path):
    """yourdfpy reads numbers with float(): '1_000', 'infinity' and a non-breaking space
    would pass."""
    from stewart_pin import FileFormatError, ModelImportError

    source = tmp_path / "robot.urdf"
    _, sidecar = StewartRobot.from_preset("desktop").write_urdf(source)
    text = source.read_text()
    (tmp_path / "bad.closures.json").write_bytes(sidecar.read_bytes())
    path = tmp_path / "bad.urdf"
    for old, new in (('value="', 'value="1_0'), ('xyz="', 'xyz="\u00a0')):
        path.write_text(text.replace(old, new, 1))
        with pytest.raises(FileFormatError, match=r"is not (a number|3 numbers)"):
            StewartRobot.from_urdf(path)
    path.write_text(text.replace('rpy="', 'rpy="inf ', 1))  # named as non-finite first
    with pytest.raises(ModelImportError, match=r"rpy='inf .*must be finite"):
        StewartRobot.from_urdf(path)


# ---------------------------------------------------------------------- item 4: stray loops
def _with_connect(text: str, element: str) -> str:
    return text.replace("</equality>", element + "</equality>", 1)


@pytest.mark.parametrize(
    ("element", "name", "bodies"),
    [
        # a crank pinned to the world: the file's leg 1 cannot turn, an import would
        ('<connect name="pin" body1="leg1_b1" body2="world" anchor="0 0 0"/>', "pin", "world"),
        # two legs coupled at their middle bodies
        (
            '<connect name="couple" body1="leg1_b2" body2="leg2_b2" anchor="0 0 0"/>',
            "couple",
            "leg2_b2",
        ),
    ],
)
def test_an_mjcf_loop_away_from_the_platform_is_refused(element, name, bodies, tmp_path):
    pytest.importorskip("mujoco")
    from cad_models import cad_mjcf

    from stewart_pin.description.leg_chain_presets import rus_preset
    from stewart_pin.importers import import_mjcf

    text = cad_mjcf(rus_preset(), "connect-site", seed=3)
    good = tmp_path / "good.xml"
    good.write_text(text)
    import_mjcf(good)  # the file as written imports
    bad = tmp_path / "bad.xml"
    bad.write_text(_with_connect(text, element))
    with pytest.raises(
        ModelImportError, match=f"loop closure '{name}'.*away from the platform"
    ) as info:
        import_mjcf(bad)
    assert info.value.joints == (name,) and bodies in info.value.bodies


def test_a_seventh_sidecar_closure_is_refused(tmp_path):
    import json

    pytest.importorskip("yourdfpy")
    path = tmp_path / "robot.urdf"
    _, sidecar = StewartRobot.from_preset("desktop").write_urdf(path)
    data = json.loads(sidecar.read_text())
    StewartRobot.from_urdf(path)  # the file as written imports
    # a seventh closure: leg 1's and leg 2's last links pinned together
    data["closures"].append(
        {
            "name": "extra",
            "type": "point",
            "link1": "leg1_link3",
            "point1": [0.0, 0.0, 0.0],
            "link2": "leg2_link3",
            "point2": [0.0, 0.0, 0.0],
        }
    )
    sidecar.write_text(json.dumps(data))
    with pytest.raises(ModelImportError, match="'extra'") as info:
        StewartRobot.from_urdf(path)
    assert "extra" in info.value.joints


# ---------------------------------------------------------------------- item 10: a fixed tool
_TOOL = """<robot name="tool">
 <link name="flange"><inertial><origin xyz="0.01 0 0.02" rpy="0 0 0"/><mass value="2"/>
  <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
 <link name="tip"><inertial><origin xyz="0 0.05 0.1" rpy="0.1 0 0"/><mass value="1"/>
  <inertia ixx="0.01" ixy="0.001" ixz="0" iyy="0.012" iyz="0" izz="0.011"/></inertial></link>
 <joint name="weld" type="fixed"><parent link="flange"/><child link="tip"/>
  <origin xyz="0 0 0.2" rpy="0 0.3 0"/></joint>
</robot>"""


def _rot(axis: int, angle: float) -> np.ndarray:
    """The rotation by ``angle`` [rad] about x, y or z (``axis`` 0, 1, 2)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3  # (y, z), (z, x), (x, y): right-handed
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _pose(xyz, rpy) -> np.ndarray:
    """URDF's origin: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    T = np.eye(4)
    T[:3, :3] = _rot(2, rpy[2]) @ _rot(1, rpy[1]) @ _rot(0, rpy[0])
    T[:3, 3] = xyz
    return T


def _khalil_about_origin(T_p_c: np.ndarray, mass: float, I_c: np.ndarray) -> np.ndarray:
    """Khalil's 10 parameters in Fp about O_p of a body whose centre-of-mass frame is
    ``T_p_c`` (inertia ``I_c`` about the centre of mass, in that frame)."""
    R, c = T_p_c[:3, :3], T_p_c[:3, 3]
    I = R @ I_c @ R.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2], *(mass * c), mass])


def test_a_payload_without_joints_is_the_platform_with_its_inertia(tmp_path, capsys):
    """A fixed tool: the coupled models against Pinocchio's constrained tree of the
    hexapod whose platform carries the tool's inertia, lumped by hand from the URDF's
    numbers (independent of the payload code)."""
    from stewart_pin.check.constrained_dynamics import (
        constrained_forward_dynamics,
        constrained_inverse_dynamics,
    )

    path = tmp_path / "tool.urdf"
    path.write_text(_TOOL)
    robot = StewartRobot.from_preset("simulator")
    T_p_b = _pose([0.05, -0.02, 0.1], [0.2, -0.1, 0.4])
    carrier = robot.with_payload(str(path), T_p_b)
    assert (carrier.nq, carrier.nv) == (0, 0)
    flange = _khalil_about_origin(
        T_p_b @ _pose([0.01, 0, 0.02], [0, 0, 0]), 2.0, np.diag([0.02, 0.03, 0.04])
    )
    I_tip = np.array([[0.01, 0.001, 0.0], [0.001, 0.012, 0.0], [0.0, 0.0, 0.011]])
    T_p_tip = T_p_b @ _pose([0, 0, 0.2], [0, 0.3, 0]) @ _pose([0, 0.05, 0.1], [0.1, 0, 0])
    tip = _khalil_about_origin(T_p_tip, 1.0, I_tip)
    desc = robot.description
    lumped = StewartRobot(desc.replace(platform_inertia=desc.platform_inertia + flange + tip))

    T, V, A = robot.sample_states(6, rng=3)
    empty = np.zeros((6, 0))
    gamma, tau = carrier.inverse_dynamics(T, V, A, empty, empty, empty)
    ref, _ = constrained_inverse_dynamics(lumped, T, V, A)
    assert tau.shape == (6, 0)
    np.testing.assert_allclose(gamma, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    accel = carrier.direct_dynamics(T, V, ref, empty, empty, tau=empty).accel
    ref_accel = constrained_forward_dynamics(lumped, T, V, ref)
    np.testing.assert_allclose(accel, ref_accel, rtol=1e-8, atol=1e-8 * np.abs(ref_accel).max())
    np.testing.assert_allclose(ref_accel, A, rtol=1e-8, atol=1e-8 * np.abs(A).max())

    # drawn: the mount at 0Tp T_p_b
    pytest.importorskip("meshcat")
    from stewart_pin.viz.payload_scene import PayloadScene

    M = PayloadScene(carrier.payload, meshes=False).placements(T, empty)
    np.testing.assert_allclose(M[0], T @ T_p_b, rtol=0, atol=1e-12)

    # the command line: validate passes, simulate runs
    assert main(["validate", "--payload", str(path), "--states", "4"]) == 0
    assert "PASSED" in capsys.readouterr().out
    sim = ["simulate", "--payload", str(path), "--duration", "0.004", "--no-progress"]
    assert main([*sim, "-o", str(tmp_path / "s.npz")]) == 0
    assert (tmp_path / "s.npz").is_file() and (tmp_path / "s.payload.npz").is_file()
