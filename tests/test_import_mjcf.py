"""Importing hexapods from MJCF (``StewartRobot.from_mjcf``, ``stewart_pin.importers``).

Independent references:
- MuJoCo's own model of the same file, in an exact KKT solve (``helpers.mujoco_kkt``): the
  mass matrix ``mj_fullM`` (armature included), ``qfrc_bias``, ``qfrc_passive`` (damping,
  springs), Coulomb friction ``frictionloss * sign(qvel)`` added by hand with the project's
  dead band, every ``connect`` and ``weld`` as a hard constraint (``mj_jac`` /
  ``mj_jacDot`` rows, checked against MuJoCo's ``efc_J``), the actuators' joint
  transmissions and gears; the states are put together by MuJoCo's own constraint
  residuals (``helpers.mujoco_closed_state``), never by the importer. The imported
  robot's inverse and direct dynamics equal it to 1e-9 relative, for 6-UPS, 6-RUS, 6-PUS
  and R-S-S / P-S-S / S-P-S legs written in every loop convention (``cad_models``: odd body
  frames, rounded numbers, classes and defaults, extra fixed bodies, ``ref``, gears).
- ``stewart_pin.validate`` (Pinocchio's constrained tree) on imported robots.
- Round trips ``from_mjcf(write_mjcf(robot))`` against the robot's description (its
  canonical form, and what MJCF can hold of its joint terms): to 1e-12.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from cad_models import LOOPS, cad_mjcf, ss_mjcf
from helpers import mujoco_closed_state, mujoco_kkt, rel_error

import stewart_pin
from stewart_pin import (
    LoopClosureError,
    ModelImportError,
    ModelImportWarning,
    RobotDescription,
    RodSpinError,
    StewartRobot,
)
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.description.leg_chain_presets import pus_preset, random_hexapod, rus_preset
from stewart_pin.description.presets import preset
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.formats.mjcf import mjcf_string
from stewart_pin.importers import canonical_description, import_mjcf

mujoco = pytest.importorskip("mujoco")
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")

#: Presets written by stewart-pin's MJCF writer and read back.
ROUND_TRIP = [
    "simulator",
    "desktop",
    "paper",
    "random-3",
    "ups-offset",
    "rus",
    "pus",
    "random-ups-0",
    "random-ups-offset-1",
    "random-rus-0",
    "random-pus-1",
    "random-custom-0",
]
#: Presets already in the canonical modified-DH form (docs/importing.md).
CANONICAL = ROUND_TRIP[:9]
#: Robots the CAD-like files are drawn from, and their workspace ranges around home
#: (translation [m], rotation [rad]).
SOURCES = {"rus": rus_preset, "pus": pus_preset, "ups": lambda: random_hexapod("ups", 1)}
RANGES = {"rus": (0.003, 0.03), "pus": (0.01, 0.05), "ups": (0.02, 0.05)}
_ROBOTS: dict[str, object] = {}


def source(name: str):
    if name not in _ROBOTS:
        _ROBOTS[name] = SOURCES[name]()
    return _ROBOTS[name]


def flat(value, prefix=""):
    """A nested dict / list as ``{path: leaf}``."""
    out = {}
    if isinstance(value, dict):
        for k, v in value.items():
            out.update(flat(v, f"{prefix}/{k}"))
    elif isinstance(value, list) and value and isinstance(value[0], dict):
        for i, v in enumerate(value):
            out.update(flat(v, f"{prefix}[{i}]"))
    else:
        out[prefix] = value
    return out


def differences(a: RobotDescription, b: RobotDescription, tol: float = 1e-12) -> list[str]:
    """Where two descriptions differ (``source`` left out): keys, names, and numbers by more
    than ``tol`` times the largest magnitude of the array (at least 1)."""
    da = {k: v for k, v in flat(a.to_dict()).items() if not k.startswith("/source")}
    db = {k: v for k, v in flat(b.to_dict()).items() if not k.startswith("/source")}
    out = [f"{k}: only in one" for k in sorted(set(da) ^ set(db))]
    for k in sorted(set(da) & set(db)):
        x, y = da[k], db[k]
        if isinstance(x, str) or isinstance(y, str) or isinstance(x, bool):
            if x != y:
                out.append(f"{k}: {x!r} != {y!r}")
            continue
        x, y = np.asarray(x, float), np.asarray(y, float)
        if x.shape != y.shape:
            out.append(f"{k}: shapes {x.shape} != {y.shape}")
        elif not np.abs(x - y).max() <= tol * max(1.0, np.abs(x).max()):
            out.append(f"{k}: {np.abs(x - y).max():.3g}")
    return out


def mujoco_view(desc: RobotDescription) -> RobotDescription:
    """What MJCF holds of a description's joint terms (docs/importing.md): MuJoCo's one
    ``armature`` (the joint-side total, rotor reflected), one ``damping`` (viscous +
    damper), ``frictionloss`` (Coulomb), ``stiffness`` with ``springref``; no transmission
    (the writer's motors have gear 1); limits only when both sides are finite."""
    if desc.legs is None:
        return desc
    legs = []
    for leg in desc.legs:
        joints = []
        for j in leg.joints:
            d = j.dynamics
            dyn = JointDynamics(
                armature=d.total_armature,
                viscous=d.viscous + d.damping,
                coulomb=d.coulomb,
                stiffness=d.stiffness,
                rest_position=d.rest_position if d.stiffness else 0.0,
            )
            bounded = math.isfinite(j.lower) and math.isfinite(j.upper)
            lo, hi = (j.lower, j.upper) if bounded else (-math.inf, math.inf)
            joints.append(replace(j, dynamics=dyn, lower=lo, upper=hi))
        legs.append(leg.replace(joints=tuple(joints)))
    return desc.replace(legs=tuple(legs))


def states(robot: StewartRobot, ranges, n: int, seed: int):
    """``n`` random reachable states around home: ``(T, V, A)`` each."""
    tr, rot = ranges
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        T = robot.home_pose
        T[:3, 3] += rng.uniform(-tr, tr, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-rot, rot, 3)) @ T[:3, :3]
        try:
            robot.inverse_geometry(T)
        except stewart_pin.WorkspaceError:
            continue
        V = np.r_[rng.normal(size=3) * tr * 5, rng.normal(size=3) * rot * 5]
        A = np.r_[rng.normal(size=3) * tr * 30, rng.normal(size=3) * rot * 30]
        out.append((T, V, A))
    return out


def imported(xml: str, **options) -> StewartRobot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        return StewartRobot.from_mjcf(xml, **options)


def check_against_mujoco(xml: str, robot: StewartRobot, ranges, n=3, no_spin=()):
    """IDM and DDM of the imported robot against the KKT solve on MuJoCo's model of the
    same file; the file's leg joints where the robot's inverse geometry puts them."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    ratio = np.array([leg.joints[leg.actuated - 1].dynamics.transmission_ratio
                      for leg in robot.general.legs])  # fmt: skip
    for T, V, A in states(robot, ranges, n, seed=5):
        mujoco_closed_state(m, data, robot.description.source.platform, T, V, no_spin=no_spin)
        q = robot.inverse_geometry(T)
        for i, leg in enumerate(robot.description.source.legs):
            for j, name in enumerate(leg.joints):
                if name.endswith(")"):  # a universal joint replacing a ball: not in the file
                    continue
                jnt = m.joint(name)
                got = data.qpos[jnt.qposadr[0]]
                assert abs(math.remainder(got - q[i, j], 2 * math.pi)) < 1e-9, (name, got, q[i, j])
        gamma_mj = mujoco_kkt(m, data, robot.description.source.platform, A=A)
        gamma = robot.inverse_dynamics(T, V, A, motor=True)
        assert rel_error(gamma, gamma_mj) < 1e-9, f"IDM {rel_error(gamma, gamma_mj):.2e}"
        A_mj = mujoco_kkt(m, data, robot.description.source.platform, gamma=gamma_mj)
        A_robot = robot.direct_dynamics(T, V, gamma * ratio)
        assert rel_error(A_robot, A_mj) < 1e-9, f"DDM {rel_error(A_robot, A_mj):.2e}"


# --- 1. conventions: the imported dynamics are MuJoCo's -------------------------------------


@pytest.mark.parametrize("loops", LOOPS)
@pytest.mark.parametrize("arch", list(SOURCES))
def test_cad_files_match_mujoco_kkt_in_every_loop_convention(arch, loops):
    xml = cad_mjcf(source(arch), loops, seed=3)
    robot = imported(xml)
    assert not robot.is_ideal_ups
    check_against_mujoco(xml, robot, RANGES[arch])


SS = {"rss": ("rus", (0.003, 0.03)), "pss": ("pus", (0.01, 0.05))}


def _ss_source(kind: str):
    if kind == "sps":
        return StewartRobot.from_preset("desktop").general, (0.005, 0.05)
    name, ranges = SS[kind]
    return source(name), ranges


@pytest.mark.parametrize("connect", [True, False], ids=["connects", "platform-in-tree"])
@pytest.mark.parametrize("kind", ["rss", "pss", "sps"])
def test_rods_between_two_spherical_joints_match_mujoco_kkt(kind, connect):
    """R-S-S, P-S-S, S-P-S legs: the equivalent universal-joint legs give MuJoCo's forces
    (the rods symmetric about their axes, not spinning about them)."""
    robot_src, ranges = _ss_source(kind)
    xml = ss_mjcf(robot_src, kind, seed=2, connect=connect)
    result = import_mjcf(xml, platform="platform") if not connect else None
    robot = imported(xml, platform="platform")
    rods = [f"leg{i}_rod" if kind != "sps" else f"leg{i}_cylinder" for i in range(1, 7)]
    if kind == "sps":
        rods += [f"leg{i}_piston" for i in range(1, 7)]
    check_against_mujoco(xml, robot, ranges, no_spin=[(r, (0, 0, 1)) for r in rods])
    shape = {"rss": "R-S-S", "pss": "P-S-S", "sps": "S-P-S"}[kind]
    report = (result or import_mjcf(xml)).report
    assert all(leg.shape == shape for leg in report.legs)


def test_removed_rod_spin_is_reported():
    """The spin inertia removed is the rod's moment about its axis, as the file gives it
    (a solid cylinder: m r^2 / 2 in ``diaginertia``)."""
    xml = ss_mjcf(source("rus"), "rss", seed=2)
    report = import_mjcf(xml).report
    m = mujoco.MjModel.from_xml_string(xml)
    axial = m.body_inertia[m.body("leg1_rod").id][2]
    for leg in report.legs:
        assert leg.spin_inertia == pytest.approx(axial, rel=1e-12)
        assert leg.spin_asymmetry < 1e-12
    assert "rod spin removed" in str(report)


def test_asymmetric_rod_is_refused_or_warned():
    xml = ss_mjcf(source("rus"), "rss", seed=2, asymmetric=True)
    with pytest.raises(RodSpinError, match="not symmetric about its axis") as info:
        import_mjcf(xml)
    assert info.value.asymmetry > 0.05 and info.value.bodies == ("leg3_rod",)
    with pytest.warns(ModelImportWarning, match="made symmetric"):
        result = import_mjcf(xml, rod_spin="warn")
    assert result.report.legs[2].spin_asymmetry > 0.05


@pytest.mark.parametrize("arch", ["rus", "ups"])
def test_imported_robots_pass_validate(arch):
    xml = cad_mjcf(source(arch), "weld-ball", seed=4)
    robot = imported(xml)
    tr, rot = RANGES[arch]
    report = stewart_pin.validate(robot, n_states=8, translation_range=tr, rotation_range=rot)
    assert report.passed, report


def test_ss_robot_passes_validate():
    xml = ss_mjcf(source("pus"), "pss", seed=2)
    robot = imported(xml)
    report = stewart_pin.validate(robot, n_states=8, translation_range=0.01, rotation_range=0.05)
    assert report.passed, report


# --- what is read: actuators, joint terms, lumped bodies, frames ----------------------------


def test_legs_are_numbered_in_actuator_order_with_their_gears():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    result = import_mjcf(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    for u, leg in enumerate(result.report.legs):
        joint = m.joint(m.actuator_trnid[u, 0]).name
        assert leg.joints[leg.actuated - 1] == joint
        assert leg.actuator == m.actuator(u).name
        gear = m.actuator_gear[u, 0]
        dyn = result.description.legs[u].joints[leg.actuated - 1].dynamics
        assert dyn.transmission_ratio == gear
        assert (dyn.gear_ratio is None) == (gear == 1.0)


def test_joint_terms_come_from_classes_and_defaults():
    xml = cad_mjcf(source("rus"), "connect-site", seed=3)
    desc = import_mjcf(xml).description
    m = mujoco.MjModel.from_xml_string(xml)
    for leg, src in zip(desc.legs, desc.source.legs, strict=True):
        for joint, name in zip(leg.joints, src.joints, strict=True):
            jnt = m.joint(name)
            d = joint.dynamics
            assert d.armature == m.dof_armature[jnt.dofadr[0]]
            assert d.viscous == m.dof_damping[jnt.dofadr[0]]
            assert d.coulomb == m.dof_frictionloss[jnt.dofadr[0]]
            assert d.stiffness == m.jnt_stiffness[jnt.id]
            if d.stiffness:
                assert d.rest_position == m.qpos_spring[jnt.qposadr[0]]
            if m.jnt_limited[jnt.id]:
                assert (joint.lower, joint.upper) == tuple(m.jnt_range[jnt.id])
            else:
                assert (joint.lower, joint.upper) == (-math.inf, math.inf)
    # the actuated joints are the "actuated" class: armature 0.0021
    assert {leg.joints[leg.actuated - 1].dynamics.armature for leg in desc.legs} == {0.0021}


def test_fixed_bodies_are_lumped_exactly():
    """The camera on the platform, the housings on the cranks and the floor plate are
    lumped; the platform's mass is MuJoCo's subtree mass (geoms' densities included)."""
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    result = import_mjcf(xml)
    lumped = result.report.lumped
    assert lumped["the platform"] == ["camera"]
    assert set(lumped["the base"]) == {"floor_plate", "base"}
    assert set(lumped["leg links"]) == {f"leg{i}_housing" for i in range(1, 7)}
    m = mujoco.MjModel.from_xml_string(xml)
    subtree = m.body_subtreemass[m.body("platform").id]
    assert result.description.platform_inertia[9] == pytest.approx(subtree, rel=1e-14)


def test_frames_are_the_files():
    """F0 is the world and Fp the platform body: the home pose is the platform body's pose at
    the reference configuration and P_i are the sites' positions in it."""
    xml = cad_mjcf(source("ups"), "connect-site", seed=3)
    desc = imported(xml).description
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    mujoco.mj_kinematics(m, data)
    b = m.body("platform").id
    np.testing.assert_allclose(desc.home_pose[:3, 3], data.xpos[b], rtol=0, atol=1e-15)
    np.testing.assert_allclose(desc.home_pose[:3, :3], data.xmat[b].reshape(3, 3), atol=1e-15)
    for i, leg in enumerate(desc.source.legs):  # leg order: the actuators'
        loop = leg.spherical.removeprefix("closure ").strip("'")
        site = m.site(m.eq(loop).obj2id[0])
        np.testing.assert_array_equal(desc.platform_points[i], site.pos)
    assert np.array_equal(desc.gravity, m.opt.gravity)


def test_source_records_names_and_survives_toml(tmp_path):
    xml = cad_mjcf(source("rus"), "weld-ball", seed=3)
    desc = imported(xml).description
    src = desc.source
    assert (src.format, src.model, src.platform, src.base) == (
        "mjcf",
        "cad-weld-ball",
        "platform",
        "world",
    )
    assert src.reference == "qpos0"
    assert src.legs[0].spherical.startswith("ball joint")
    path = desc.write(tmp_path / "r.toml")
    back = RobotDescription.read(path)
    assert back.source == src
    assert differences(back, desc, 0.0) == []


def test_names_from_the_file_are_data(tmp_path):
    """A body named with quotes, a backslash, a newline and non-ASCII text reaches the
    description and its TOML as data, escaped, and comes back the same; the robot's name is
    made valid."""
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    odd = 'pl"at\\form\n]] = "x" é\U0001f600'
    escaped = odd.replace("&", "&amp;").replace('"', "&quot;").replace("\n", "&#10;")
    xml = xml.replace('name="platform"', f'name="{escaped}"')
    xml = xml.replace('<mujoco model="cad-connect-site">', '<mujoco model="../../etc/x y">')
    desc = imported(xml).description
    assert desc.source.platform == odd
    assert desc.name == "etc_x_y"
    path = desc.write(tmp_path / "odd.toml")
    assert RobotDescription.read(path).source.platform == odd
    assert [p.name for p in tmp_path.iterdir()] == ["odd.toml"]


def test_reference_keyframe_and_ref():
    """A keyframe is the reference when named (or ``home``); a hinge's ``ref`` makes its
    value at the file's placement non-zero (checked in the KKT tests, joint by joint)."""
    d = preset("pus")
    xml = mjcf_string(d)
    assert import_mjcf(xml).report.reference == "keyframe 'home'"
    assert import_mjcf(xml, keyframe=0).report.reference == "keyframe 'home'"
    with pytest.raises(ModelImportError, match="no keyframe named 'nope'"):
        import_mjcf(xml, keyframe="nope")
    with pytest.raises(ModelImportError, match="1 keyframe"):
        import_mjcf(xml, keyframe=3)
    m = mujoco.MjModel.from_xml_string(cad_mjcf(source("rus"), "connect-site", seed=3))
    assert m.qpos0[m.joint("leg1_j1").qposadr[0]] == pytest.approx(math.radians(7))


# --- 4. tolerance to real files ----------------------------------------------------------


def test_rounded_files_are_assembled_with_a_warning():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    with pytest.warns(ModelImportWarning, match="close at the reference configuration") as w:
        result = import_mjcf(xml)
    residuals = result.report.residuals
    assert 1e-7 < residuals.max() < 1e-4
    assert "assembled" in str(w[0].message)
    # exact files: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        import_mjcf(mjcf_string(preset("pus")))


def test_loops_that_do_not_close_are_refused_with_the_residuals():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    m = mujoco.MjModel.from_xml_string(xml)
    site = m.site("plate_p4")
    moved = site.pos + np.array([0.02, 0.0, 0.0])
    old = " ".join(f"{x:.5f}".rstrip("0").rstrip(".") for x in site.pos)
    assert f'name="plate_p4" pos="{old}"' in xml
    bad = xml.replace(
        f'name="plate_p4" pos="{old}"', f'name="plate_p4" pos="{moved[0]} {moved[1]} {moved[2]}"'
    )
    with pytest.raises(LoopClosureError, match=r"leg .: 0.02 m") as info:
        import_mjcf(bad)
    r = np.array(info.value.residuals)
    assert r.shape == (6,) and np.sum(r > 0.01) == 1 and info.value.tolerance < 0.01
    robot = imported(bad, closure_tolerance=0.5)  # accepted when asked: assembled at home
    assert robot.inverse_geometry(robot.home_pose).shape == (6, 3)


def test_nearly_parallel_axes_are_made_parallel_with_a_warning():
    xml = cad_mjcf(source("rus"), "connect-site", seed=3)
    m = mujoco.MjModel.from_xml_string(xml)
    axis = m.joint("leg2_j2").axis
    text = " ".join(f"{x:.5f}".rstrip("0").rstrip(".") if x else "0" for x in axis)
    assert text in xml
    tilted = axis + np.array([2e-6, -1e-6, 0.0])
    bad = xml.replace(text, " ".join(repr(float(x)) for x in tilted), 1)
    with pytest.warns(ModelImportWarning, match="made parallel"):
        import_mjcf(bad)


def test_visual_meshes_are_ignored_and_mesh_inertias_are_mujocos(tmp_path):
    """A visual mesh whose file is missing does not stop the import; a mesh that gives a
    body its inertia is read by MuJoCo, and its mass is the compiled one."""
    cube = "\n".join(
        [f"v {x} {y} {z}" for x in (-0.01, 0.01) for y in (-0.01, 0.01) for z in (-0.01, 0.01)]
        + ["f 1 3 4 2", "f 5 6 8 7", "f 1 2 6 5", "f 3 7 8 4", "f 1 5 7 3", "f 2 4 8 6"]
    )
    (tmp_path / "cube.obj").write_text(cube)
    xml = cad_mjcf(source("pus"), "connect-body", seed=3)
    xml = xml.replace(
        "  <worldbody>",
        '  <asset>\n    <mesh name="cube" file="cube.obj"/>\n    <mesh name="shell" '
        'file="missing_visual.stl"/>\n  </asset>\n  <worldbody>',
    )
    xml = xml.replace(
        '<geom type="box" size="0.015 0.01 0.008" density="1200"/>',
        '<geom type="mesh" mesh="cube" density="5000"/>\n'
        '<geom type="mesh" mesh="shell" mass="0"/>',
    )
    path = tmp_path / "robot.xml"
    path.write_text(xml)
    robot = imported(str(path))
    # MuJoCo's own model, the visual mesh taken out (it has no file)
    m = mujoco.MjModel.from_xml_string(
        xml.replace('<mesh name="shell" file="missing_visual.stl"/>', "")
        .replace('<geom type="mesh" mesh="shell" mass="0"/>', "")
        .replace('file="cube.obj"', f'file="{tmp_path / "cube.obj"}"')
    )
    # MuJoCo's mesh volume (float32 vertices) of the 2 cm cube of density 5000
    assert m.body_mass[m.body("camera").id] == pytest.approx(5000 * 0.02**3, rel=1e-6)
    subtree = m.body_subtreemass[m.body("platform").id]
    assert robot.description.platform_inertia[9] == pytest.approx(subtree, rel=1e-14)


# --- 5. round trips -------------------------------------------------------------------------


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_mjcf_round_trip_gives_the_canonical_description(name):
    """``from_mjcf(write_mjcf(d))`` equals ``canonical_description(d)`` with the joint
    terms MJCF holds, to 1e-12 (names, kinds, limits, joint terms, branches, guesses, every
    number); for the canonical presets that is ``d`` itself."""
    d = preset(name)
    back = import_mjcf(mjcf_string(d)).description
    assert back.is_ideal_ups == d.is_ideal_ups
    expected = canonical_description(mujoco_view(d))
    assert differences(back, expected) == []
    if name in CANONICAL:
        assert differences(back, mujoco_view(d)) == []


@pytest.mark.parametrize("name", CANONICAL)
def test_canonical_presets_are_their_own_canonical_form(name):
    d = preset(name)
    assert differences(canonical_description(d), d) == []


@pytest.mark.parametrize("name", ["random-rus-0", "random-pus-1", "random-custom-0"])
def test_canonical_form_keeps_the_dynamics(name):
    """The canonical form of a robot that is not in it (other frames 0i, MDH parameters,
    link inertias) has the same inverse and direct dynamics to 1e-12."""
    d = preset(name)
    c = canonical_description(d)
    assert differences(c, d) != []
    robot, other = StewartRobot(d), StewartRobot(c)
    ranges = {"random-rus-0": (0.003, 0.03)}.get(name, (0.01, 0.05))
    for T, V, A in states(robot, ranges, 5, seed=1):
        g = robot.inverse_dynamics(T, V, A)
        assert rel_error(other.inverse_dynamics(T, V, A), g) < 1e-12
        assert rel_error(other.direct_dynamics(T, V, g), robot.direct_dynamics(T, V, g)) < 1e-12
        assert np.allclose(other.inverse_geometry(T), robot.inverse_geometry(T), atol=1e-12)


@pytest.mark.parametrize("name", ["rus", "random-rus-0"])
def test_round_trip_dynamics_are_the_mujoco_view(name):
    d = preset(name)
    back = import_mjcf(mjcf_string(d)).description
    ref = GeneralDynamics(StewartRobot(mujoco_view(d)).general)
    got = GeneralDynamics(StewartRobot(back).general)
    for T, V, A in states(StewartRobot(d), (0.003, 0.03), 3, seed=2):
        g = ref.inverse_dynamics(T[None], V[None], A[None])
        assert rel_error(got.inverse_dynamics(T[None], V[None], A[None]), g) < 1e-12


def test_compiled_model_and_path_are_accepted(tmp_path):
    d = preset("desktop")
    m = mujoco.MjModel.from_xml_string(mjcf_string(d))
    assert differences(import_mjcf(m).description, d) == []
    path = tmp_path / "desktop.xml"
    path.write_text(mjcf_string(d))
    result = import_mjcf(path)
    assert result.report.file == "desktop.xml" and result.description.source.file == "desktop.xml"


# --- 7. what does not fit -------------------------------------------------------------------


def test_not_six_legs():
    spec = mujoco.MjSpec.from_string(cad_mjcf(source("pus"), "connect-site", seed=3))
    spec.delete(spec.body("leg6_b1"))  # MuJoCo drops the loop and the motor on it too
    for element in [*spec.equalities, *spec.actuators]:
        if element.name in ("loop6",) or getattr(element, "target", "") == "leg6_j1":
            spec.delete(element)
    with pytest.raises(ModelImportError, match=r"not six legs.*has 5"):
        import_mjcf(spec.compile())


def test_chain_of_two_or_four_joints_names_its_joints():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    two = xml.replace('<joint name="leg2_j2"', '<joint name="leg2_j2" type="hinge"').split("\n")
    two = "\n".join(line for line in two if '<joint name="leg2_j2"' not in line)
    with pytest.raises(ModelImportError, match=r"2 one-dof joint\(s\).*'leg2_j1'") as info:
        import_mjcf(two)
    assert "leg2_j3" in info.value.joints
    four = xml.replace(
        '<joint name="leg3_j2"',
        '<joint name="leg3_extra" type="hinge" axis="1 0 0"/><joint name="leg3_j2"',
    )
    with pytest.raises(ModelImportError, match=r"4 one-dof joint\(s\)") as info:
        import_mjcf(four)
    assert "leg3_extra" in info.value.joints


def test_weld_where_a_ball_should_be():
    xml = cad_mjcf(source("pus"), "weld-ball", seed=3)
    no_ball = xml.replace('<joint name="ball4" type="ball" damping="0"/>', "")
    with pytest.raises(ModelImportError, match="a weld where a ball should be") as info:
        import_mjcf(no_ball)
    assert "loop4" in info.value.joints


def test_actuator_on_a_passive_joint_or_none_on_a_leg():
    xml = cad_mjcf(source("pus"), "weld-hinges", seed=3)
    m = mujoco.MjModel.from_xml_string(xml)
    first = m.actuator(0)
    joint = m.joint(first.trnid[0]).name
    on_sphere = xml.replace(f'joint="{joint}"', 'joint="s2_y"', 1)
    with pytest.raises(ModelImportError, match="passive joint") as info:
        import_mjcf(on_sphere)
    assert "s2_y" in info.value.joints
    none = "\n".join(line for line in xml.split("\n") if f'joint="{joint}"' not in line)
    with pytest.raises(ModelImportError, match="without an actuator") as info:
        import_mjcf(none)
    assert joint in info.value.joints
    two = xml.replace(
        "  </actuator>", f'    <motor name="extra" joint="{joint[:-1]}2"/>\n  </actuator>'
    )
    with pytest.raises(ModelImportError, match="two actuated joints"):
        import_mjcf(two)


def test_floating_base_is_refused():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    plate = '<geom type="cylinder" size="0.12 0.004" density="2000"/>'
    floating = xml.replace(plate, '<freejoint name="base_free"/>' + plate)
    with pytest.raises(ModelImportError, match="a floating base") as info:
        import_mjcf(floating)
    assert info.value.joints == ("base_free",)
    # welded to the world, the same free body is a fixed base
    welded = floating.replace("  <equality>\n", '  <equality>\n    <weld body1="base"/>\n')
    imported(welded)


def test_extra_moving_bodies_are_named():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    extra = xml.replace(
        '<body name="camera"',
        '<body name="gimbal"><joint name="pan" type="hinge"/><geom size="0.01"/></body>\n'
        '<body name="camera"',
        1,
    )
    with pytest.raises(ModelImportError, match="extra moving bodies 'gimbal'") as info:
        import_mjcf(extra)
    assert info.value.joints == ("pan",)


def test_unsupported_elements_are_refused():
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    with pytest.raises(ModelImportError, match="gravity compensation"):
        import_mjcf(xml.replace('<body name="camera"', '<body name="camera" gravcomp="1"', 1))
    joint_eq = xml.replace(
        "  </equality>", '    <joint joint1="leg1_j2" joint2="leg2_j2"/>\n  </equality>'
    )
    with pytest.raises(ModelImportError, match="is a joint: stewart-pin reads connect"):
        import_mjcf(joint_eq)
    ball = cad_mjcf(source("pus"), "weld-ball", seed=3).replace(
        '<joint name="ball2" type="ball" damping="0"/>',
        '<joint name="ball2" type="ball" damping="0.1"/>',
    )
    with pytest.raises(ModelImportError, match="ball joint 'ball2' carries joint terms"):
        import_mjcf(ball)
    with pytest.raises(stewart_pin.FileFormatError, match="MuJoCo cannot read"):
        import_mjcf("<mujoco><worldbody><body></mujoco>")


def test_docs_example_servo_head():
    """docs/importing.md's worked example: the file shipped in the model files
    (models/examples/), the report and forces it prints, and the dynamics against MuJoCo's
    model of the file."""
    from stewart_pin.formats import model_files

    path = model_files() / "examples" / "servo_head.xml"
    result = import_mjcf(path)
    text = str(result.report)
    assert "MJCF model 'servo-head' ('servo_head.xml'): rus legs" in text
    assert "leg 1 (rus, R-S-S): 'servo1' (R*), 'ball1 (U axis 1)' (R)" in text
    robot = StewartRobot(result.description)
    T = robot.home_pose
    gamma = robot.inverse_dynamics(
        T, np.array([0.01, 0, 0, 0, 0, 0.2]), np.array([0, 0, 0.5, 0, 0.3, 0])
    )
    np.testing.assert_allclose(
        gamma, [-0.0801, 0.1268, -0.0932, 0.1352, -0.0905, 0.1411], atol=6e-5
    )
    xml = path.read_text()
    rods = [(f"rod{i}", (0, 0, 1)) for i in range(1, 7)]
    check_against_mujoco(xml, robot, (0.003, 0.03), no_spin=rods)


def test_source_survives_json(tmp_path):
    desc = imported(cad_mjcf(source("ups"), "tree-ball", seed=3)).description
    back = RobotDescription.read(desc.write(tmp_path / "r.json"))
    assert back.source == desc.source
    assert sum(leg.spherical.startswith("ball joint") for leg in back.source.legs) == 1
    with pytest.raises(stewart_pin.DescriptionError, match="model source keys"):
        RobotDescription.from_dict({**desc.to_dict(), "source": {"format": "mjcf"}})
    d = desc.to_dict()
    leg = {**d["source"]["legs"][0], "extra": 1}
    bad_leg = {**d["source"], "legs": [leg, *d["source"]["legs"][1:]]}
    with pytest.raises(stewart_pin.DescriptionError, match=r"model source leg keys.*\['extra'\]"):
        RobotDescription.from_dict({**d, "source": bad_leg})
    not_table = {**d["source"], "legs": ["leg", *d["source"]["legs"][1:]]}
    with pytest.raises(stewart_pin.DescriptionError, match="model source leg must be a table"):
        RobotDescription.from_dict({**d, "source": not_table})
    with pytest.raises(stewart_pin.DescriptionError, match="model source must be a table"):
        RobotDescription.from_dict({**d, "source": ["mjcf"]})


# --- 8. option flags, MuJoCo's warnings, non-finite numbers (issue 25) ----------------------


def _with_flags(xml: str, **flags: str) -> str:
    """``xml`` with ``<option><flag name="value" .../></option>``."""
    flag = " ".join(f'{k}="{v}"' for k, v in flags.items())
    option = re.search(r"<option([^>]*)/>", xml)
    assert option is not None
    return xml.replace(option.group(0), f"<option{option.group(1)}><flag {flag}/></option>")


def test_option_flags_gravity_damper_spring_are_mujocos():
    """``<flag gravity|damper|spring="disable">``: MuJoCo's own model of the file then has
    no gravity (``qfrc_bias``) and no damping or springs (``qfrc_passive``); the imported
    robot's dynamics equal the KKT solve on that model (they used to keep all three)."""
    xml = _with_flags(
        cad_mjcf(source("pus"), "connect-site", seed=3),
        gravity="disable",
        damper="disable",
        spring="disable",
    )
    robot = imported(xml)
    assert not robot.description.gravity.any()
    dyn = [j.dynamics for leg in robot.description.legs for j in leg.joints]
    assert not any(d.viscous or d.damping or d.stiffness for d in dyn)
    assert any(d.armature for d in dyn)  # not switched off by any flag
    check_against_mujoco(xml, robot, RANGES["pus"])


def test_option_flags_frictionloss_and_limit_drop_those_terms():
    """``<flag frictionloss="disable" limit="disable">``: MuJoCo then has no joint friction
    and no joint limits: the imported joints have no Coulomb term and no limits, the rest
    as without the flags; the report says so."""
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    plain = import_mjcf(xml).description
    flagged = import_mjcf(_with_flags(xml, frictionloss="disable", limit="disable"))
    assert any(j.dynamics.coulomb for leg in plain.legs for j in leg.joints)
    assert any(math.isfinite(j.lower) for leg in plain.legs for j in leg.joints)
    for leg_a, leg_b in zip(plain.legs, flagged.description.legs, strict=True):
        for a, b in zip(leg_a.joints, leg_b.joints, strict=True):
            assert b.dynamics.coulomb == 0.0
            assert (b.lower, b.upper) == (-math.inf, math.inf)
            assert b.dynamics.viscous == a.dynamics.viscous
    text = str(flagged.report)
    assert 'frictionloss="disable"' in text and 'limit="disable"' in text


@pytest.mark.parametrize("flag", ["equality", "constraint", "actuation"])
def test_option_flags_that_change_the_robot_are_refused(flag):
    """Without its equality constraints (or every constraint) the file's robot is open
    chains; without actuation its legs are not driven: refused, the flag named."""
    xml = _with_flags(cad_mjcf(source("pus"), "connect-site", seed=3), **{flag: "disable"})
    with pytest.raises(ModelImportError, match=rf'<flag {flag}="disable"/>'):
        import_mjcf(xml)


@pytest.mark.parametrize(
    "old, new, element, value",
    [
        ('range="-0.08 0.08"', 'range="nan 0.08"', "<joint> 'leg1_j1'", "range='nan 0.08'"),
        ('range="-0.08 0.08"', 'range="-inf 0.08"', "<joint> 'leg1_j1'", "range='-inf 0.08'"),
        ('<body name="leg1_b1" pos="0.43059', '<body name="leg1_b1" pos="NaN', "<body> 'leg1_b1'",
         "pos='NaN"),
        ('density="2000"', 'density="-Inf"', "<geom> in 'base'", "density='-Inf'"),
    ],
)  # fmt: skip
def test_non_finite_numbers_are_named_and_no_log_is_written(
    tmp_path, monkeypatch, old, new, element, value
):
    """A NaN or an infinity written in the file: a ModelImportError naming the element, the
    attribute and the value (a NaN range imported as an unlimited joint, an infinite one
    silently, a NaN position was called an internal inconsistency); MuJoCo's warning is
    captured, no MUJOCO_LOG.TXT is left in the working folder."""
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    assert old in xml
    path = tmp_path / "model.xml"
    path.write_text(xml.replace(old, new, 1))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelImportError, match=r"model\.xml, line \d+: ") as info:
        import_mjcf(path)
    assert element in str(info.value) and value in str(info.value)
    assert "finite" in str(info.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.xml"]


def test_mujoco_warnings_are_errors_and_not_logged(tmp_path, monkeypatch, capfd):
    """Past stewart-pin's own scan (switched off here), MuJoCo's warning about the NaN is
    an error, and MuJoCo writes neither to stderr nor to MUJOCO_LOG.TXT; the handler
    installed before is put back."""
    from stewart_pin.importers import mjcf as mjcf_module

    monkeypatch.setattr(mjcf_module, "_check_finite_text", lambda text, path: None)
    monkeypatch.chdir(tmp_path)
    xml = cad_mjcf(source("pus"), "connect-site", seed=3).replace(
        'range="-0.08 0.08"', 'range="nan 0.08"', 1
    )
    before = mujoco.get_mju_user_warning()
    with pytest.raises(ModelImportError, match=r"MuJoCo warns about the MJCF text: .*NaN"):
        import_mjcf(xml)
    assert mujoco.get_mju_user_warning() is before
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert "NaN" not in capfd.readouterr().err


def test_non_finite_numbers_of_a_compiled_model_are_named():
    """A compiled model given as such: its non-finite numbers are named by element."""
    m = mujoco.MjModel.from_xml_string(cad_mjcf(source("pus"), "connect-site", seed=3))
    m.jnt_range[m.joint("leg2_j1").id, 1] = math.inf
    with pytest.raises(ModelImportError, match=r"joint 'leg2_j1': jnt_range is \[-0.08, inf\]"):
        import_mjcf(m)
    m.jnt_range[m.joint("leg2_j1").id, 1] = 0.08
    m.body_mass[m.body("leg3_b1").id] = math.nan
    with pytest.raises(ModelImportError, match=r"body 'leg3_b1': body_mass is nan") as info:
        import_mjcf(m)
    assert info.value.bodies == ("leg3_b1",)


def test_non_finite_number_in_an_included_file_is_named(tmp_path, monkeypatch):
    """An ``<include>``d file is scanned as well (MuJoCo reads it from the main file's
    folder): the error names that file."""
    xml = cad_mjcf(source("pus"), "connect-site", seed=3)
    start, end = xml.index("  <actuator>"), xml.index("</actuator>") + len("</actuator>")
    part = xml[start:end].replace('gear="50"', 'gear="nan"')
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "actuators.xml").write_text(f"<mujoco>\n{part}\n</mujoco>\n")
    main = tmp_path / "model.xml"
    main.write_text(xml[:start] + '  <include file="parts/actuators.xml"/>' + xml[end:])
    monkeypatch.chdir(tmp_path)
    with pytest.raises(
        ModelImportError, match=r"actuators\.xml, line 4: <position> 'act2' has gear='nan'"
    ):
        import_mjcf(main)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    (tmp_path / "parts" / "actuators.xml").write_text(
        f"<mujoco>\n{part}\n</mujoco>\n".replace('gear="nan"', 'gear="50"')
    )
    assert import_mjcf(main).description.legs
