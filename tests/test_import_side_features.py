"""Side features of MJCF files modelled, not refused (issue 21, item 5).

- an actuator on a site or a body (a disturbance input): ignored, a report line; the
  efforts those of the file with it at zero;
- gravity compensation (``gravcomp``) the same on every moving body: gravity scaled;
  routed to actuators: refused (on some bodies only: tests/test_gravity_compensation.py);
- mesh files missing: visual ones named in a line; a body whose inertia MuJoCo computes
  from a missing mesh takes its inertia from ``inertials=``.

Independent reference: MuJoCo's own model of the file (or of the same file with its mesh
present / the disturbance actuator removed) in an exact KKT solve (``helpers.mujoco_kkt``).
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pinocchio as pin
import pytest
from helpers import mujoco_closed_state, mujoco_kkt, rel_error

from stewart_pin import InputError, ModelImportError, ModelImportWarning, StewartRobot
from stewart_pin.description.presets import preset
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import import_mjcf

mujoco = pytest.importorskip("mujoco")


def _import(xml, **options) -> StewartRobot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        return StewartRobot.from_mjcf(xml, **options)


def _check(
    reference_xml: str, robot: StewartRobot, n: int = 3, backend: str | None = None, ddm=False
) -> None:
    """The robot's IDM (``ddm``: and DDM) against the KKT solve on MuJoCo's model of
    ``reference_xml``, on ``backend`` (default: the robot's)."""
    kw = {} if backend is None else {"backend": backend}
    m = mujoco.MjModel.from_xml_string(reference_xml)
    data = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    for _ in range(n):
        T = robot.home_pose
        T[:3, 3] += rng.uniform(-0.003, 0.003, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-0.02, 0.02, 3)) @ T[:3, :3]
        V, A = rng.normal(size=6) * 0.1, rng.normal(size=6)
        mujoco_closed_state(m, data, "platform", T, V, guess=m.key_qpos[0])
        gamma_mj = mujoco_kkt(m, data, "platform", A=A)
        gamma = robot.inverse_dynamics(T, V, A, **kw)
        assert rel_error(gamma, gamma_mj) < 1e-10, f"IDM {rel_error(gamma, gamma_mj):.2e}"
        if ddm:
            A_mj = mujoco_kkt(m, data, "platform", gamma=gamma_mj)
            A_got = robot.direct_dynamics(T, V, gamma_mj, **kw)
            assert rel_error(A_got, A_mj) < 1e-10, f"DDM {rel_error(A_got, A_mj):.2e}"


def test_actuators_on_sites_and_bodies_are_ignored_with_a_line():
    """A ``<general site=...>`` and a ``<motor body=...>`` (disturbances): the import
    used to refuse the model; now they are named in the report and left at zero."""
    xml = mjcf_string(preset("rus"))
    extra = (
        '    <general name="push" site="platform_p1" gear="0 0 1 0 0 0" />\n'
        '    <general name="wind" body="platform" gear="1 0 0 0 0 0" />\n'
        "  </actuator>"
    )
    with_site = xml.replace("  </actuator>", extra)
    result = import_mjcf(with_site)
    text = str(result.report)
    assert "actuator 'push' drives the site 'platform_p1'" in text
    assert "actuator 'wind' drives the body 'platform'" in text
    _check(xml, _import(with_site))  # MuJoCo's file without them: the same efforts


@pytest.mark.parametrize("c", [1.0, 0.4])
def test_uniform_gravity_compensation_scales_gravity(c):
    """``gravcomp`` c on every moving body: MuJoCo's dynamics of that file (its passive
    forces cancel c of each weight) equal the robot's with gravity times 1 - c."""
    xml = mjcf_string(preset("rus"))
    comp = re.sub(r'<body name="(leg\d_link\d|platform)"', rf'<body name="\1" gravcomp="{c}"', xml)
    assert comp.count("gravcomp") == 19
    robot = _import(comp)
    assert np.allclose(robot.description.gravity, (1 - c) * np.array([0, 0, -9.81]), atol=1e-15)
    assert "gravity scaled by" in str(import_mjcf(comp).report)
    _check(comp, robot)


def test_gravity_compensation_routed_to_actuators_is_refused():
    """(On some bodies only it is modelled: tests/test_gravity_compensation.py.)"""
    xml = mjcf_string(preset("rus"))
    all_ = re.sub(r'<body name="(leg\d_link\d|platform)"', r'<body name="\1" gravcomp="1"', xml)
    routed = all_.replace('name="leg1_q1"', 'name="leg1_q1" actuatorgravcomp="true"')
    with pytest.raises(ModelImportError, match="routed to the actuators of 'leg1_q1'"):
        import_mjcf(routed)


CUBE_OBJ = """v -0.5 -0.5 -0.05\nv 0.5 -0.5 -0.05\nv 0.5 0.5 -0.05\nv -0.5 0.5 -0.05
v -0.5 -0.5 0.05\nv 0.5 -0.5 0.05\nv 0.5 0.5 0.05\nv -0.5 0.5 0.05
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7
f 4 1 5\nf 4 5 8
"""


def _mesh_files(tmp_path, present: bool):
    """The rus preset with its platform's inertia from a mesh (``plate.obj``, a 1 x 1 x
    0.1 m plate of density 500) and a visual mesh (``logo.obj``) on link 1 of leg 1; the
    files written in ``tmp_path`` when ``present``."""
    xml = mjcf_string(preset("rus")).replace('inertiafromgeom="false"', 'inertiafromgeom="auto"')
    xml = xml.replace(
        "<worldbody>",
        '<asset><mesh name="plate" file="plate.obj"/><mesh name="logo" file="logo.obj"/>'
        "</asset>\n  <worldbody>",
    )
    xml = re.sub(
        r'(<body name="platform"[^>]*>\s*<freejoint[^>]*>\s*)<inertial[^>]*/>',
        r'\1<geom type="mesh" mesh="plate" density="500" contype="1" pos="0 0 0.02" />',
        xml,
    )
    xml = xml.replace(
        '<joint name="leg1_q1"', '<geom type="mesh" mesh="logo" />\n        <joint name="leg1_q1"'
    )
    assert 'mesh="plate"' in xml and 'mesh="logo"' in xml
    if present:
        (tmp_path / "plate.obj").write_text(CUBE_OBJ)
        (tmp_path / "logo.obj").write_text(CUBE_OBJ)
    path = tmp_path / "robot.xml"
    path.write_text(xml)
    return path


def test_missing_meshes_are_named_and_inertias_can_be_given(tmp_path):
    """Mesh files absent: the visual one is named in a line; the platform's inertia came
    from the other, so the import names it, its body and ``inertials=``; given there (the
    values MuJoCo computes from the file when it is present), the robot's dynamics are
    MuJoCo's of the complete file."""
    full_dir, bare_dir = tmp_path / "full", tmp_path / "bare"
    full_dir.mkdir()
    bare_dir.mkdir()
    full = _mesh_files(full_dir, present=True)
    bare = _mesh_files(bare_dir, present=False)
    with pytest.raises(
        ModelImportError, match=r"'plate.obj' missing beside .*'platform'.*inertials="
    ):
        import_mjcf(bare)
    m = mujoco.MjModel.from_xml_path(str(full))
    b = m.body("platform").id
    q = m.body_iquat[b]
    R = pin.Quaternion(q[0], q[1], q[2], q[3]).toRotationMatrix()
    I = R @ np.diag(m.body_inertia[b]) @ R.T
    given = {
        "platform": {
            "mass": float(m.body_mass[b]),
            "pos": m.body_ipos[b].tolist(),
            "inertia": [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]],
        }
    }
    result = import_mjcf(bare, inertials=given)
    text = str(result.report)
    assert "'logo.obj' missing: visual only" in text
    assert "the inertia of body 'platform' given by inertials=" in text
    _check(
        full.read_text().replace('file="', f'file="{full_dir}/'), _import(bare, inertials=given)
    )
    with pytest.raises(InputError, match="not a body whose inertia comes from a missing mesh"):
        import_mjcf(bare, inertials={**given, "leg1_link1": given["platform"]})
    with pytest.raises(InputError, match="exactly the keys"):
        import_mjcf(bare, inertials={"platform": {"mass": 1.0}})
