"""Importing hexapods from URDF (``StewartRobot.from_urdf``, ``stewart_pin.importers``).

Independent references:
- Pinocchio's own URDF parser (``pin.buildModelFromUrdf``: it merges the fixed links and
  their inertias itself, reads ``<dynamics>``) with the loops as hard point constraints
  between the closing frames, in an exact KKT solve (``crba`` with ``model.armature`` set
  to the armatures given,
  ``rnea``, damping and Coulomb friction added by hand with the project's dead band, frame
  Jacobians and classical accelerations for the constraint drift; the transmissions'
  reductions read from the file's XML by the test): the imported robot's inverse and
  direct dynamics equal it to 1e-9 relative, for onshape-to-robot style files (odd link
  frames, rotated ``<inertial>`` frames, fixed extra links, the platform floating or
  hanging from a leg through three hinges).
- Round trips ``from_urdf(write_urdf(robot))`` against the robot's canonical description,
  joint terms and transmissions included (the project's sidecar holds them): to 1e-12.
"""

from __future__ import annotations

import json
import math
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from cad_models import cad_urdf
from helpers import rel_error
from test_import_mjcf import CANONICAL, ROUND_TRIP, differences, states

from stewart_pin import (
    FileFormatError,
    ModelImportError,
    ModelImportWarning,
    StewartRobot,
)
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.description.leg_chain_presets import pus_preset, random_hexapod, rus_preset
from stewart_pin.description.presets import preset
from stewart_pin.formats import model_files
from stewart_pin.formats.urdf import write_urdf
from stewart_pin.importers import canonical_description, import_urdf

pytest.importorskip("yourdfpy")
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")

SOURCES = {"rus": rus_preset, "pus": pus_preset, "ups": lambda: random_hexapod("ups", 1)}
RANGES = {"rus": (0.003, 0.03), "pus": (0.01, 0.05), "ups": (0.02, 0.05)}
ARMATURE = {"leg1_q1": 0.003, "leg2_q2": 0.0005, "leg4_q1": 0.002}


class PinReference:
    """The URDF in Pinocchio, with its loops (pairs of frame names) as hard constraints."""

    def __init__(self, path, pairs, armature, platform="platform"):
        self.model = pin.buildModelFromUrdf(str(path))
        self.data = self.model.createData()
        for name, value in armature.items():
            self.model.armature[self.model.joints[self.model.getJointId(name)].idx_v] = value
        self.pairs = [(self.model.getFrameId(a), self.model.getFrameId(b)) for a, b in pairs]
        self.platform = self.model.getFrameId(platform)
        root = ET.parse(path).getroot()
        self.S = np.zeros((len(root.findall("transmission")), self.model.nv))
        for u, t in enumerate(root.findall("transmission")):
            jid = self.model.getJointId(t.find("joint").get("name"))
            reduction = t.find("actuator/mechanicalReduction")
            self.S[u, self.model.joints[jid].idx_v] = float(reduction.text)

    def _rows(self, q):
        m, d = self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        J = [
            (pin.getFrameJacobian(m, d, a, frame) - pin.getFrameJacobian(m, d, b, frame))[:3]
            for a, b in self.pairs
        ]
        return np.vstack(J), pin.getFrameJacobian(m, d, self.platform, frame)

    def _loop_residuals(self):
        """The loops' residuals at the placements last computed (``_rows``)."""
        d = self.data
        return np.concatenate([d.oMf[a].translation - d.oMf[b].translation for a, b in self.pairs])

    def closed_state(self, T, V, q0=None, tol=1e-14):
        """q, v with the loops closed, the platform frame at T with twist V (F0), by
        Gauss-Newton from ``q0`` (default neutral) to residuals below ``tol``."""
        m, d = self.model, self.data
        q = pin.neutral(m) if q0 is None else q0
        for _ in range(80):
            J, Jp = self._rows(q)
            M = d.oMf[self.platform]
            r = np.r_[
                self._loop_residuals(),
                M.translation - T[:3, 3],
                pin.log3(M.rotation @ T[:3, :3].T),
            ]
            if np.abs(r).max() < tol:
                break
            q = pin.integrate(m, q, -np.linalg.lstsq(np.r_[J, Jp], r, rcond=None)[0])
        else:
            raise AssertionError(f"no closed state: {np.abs(r).max():.3g}")
        J, Jp = self._rows(q)
        v = np.linalg.lstsq(np.r_[J, Jp], np.r_[np.zeros(len(J)), V], rcond=None)[0]
        return q, v

    def _bias(self, q, v):
        m, d = self.model, self.data
        c = pin.rnea(m, d, q, v, np.zeros(m.nv)) + m.damping * v + m.friction * coulomb_sign(v)
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        pin.updateFramePlacements(m, d)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        acc = lambda f: pin.getFrameClassicalAcceleration(m, d, f, frame)  # noqa: E731
        drift = np.concatenate([acc(a).linear - acc(b).linear for a, b in self.pairs])
        a_p = acc(self.platform)
        return c, drift, np.r_[a_p.linear, a_p.angular]

    def kkt(self, q, v, A=None, gamma=None):
        m = self.model
        c, drift, plat = self._bias(q, v)
        M = pin.crba(m, self.data, q)  # model.armature on its diagonal (Pinocchio 3+)
        M = np.triu(M) + np.triu(M, 1).T
        J, Jp = self._rows(q)
        nv, nr, nu = m.nv, len(J), len(self.S)
        if A is not None:
            K = np.zeros((nv + nr + 6, nv + nu + nr))
            K[:nv, :nv], K[:nv, nv : nv + nu], K[:nv, nv + nu :] = M, -self.S.T, -J.T
            K[nv : nv + nr, :nv], K[nv + nr :, :nv] = J, Jp
            return np.linalg.solve(K, np.r_[-c, -drift, A - plat])[nv : nv + nu]
        K = np.zeros((nv + nr, nv + nr))
        K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = M, -J.T, J
        x = np.linalg.solve(K, np.r_[self.S.T @ gamma - c, -drift])
        return Jp @ x[:nv] + plat


def write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def pairs_of(closing="closing"):
    ends = (
        ("closing_{k}_1", "closing_{k}_2") if closing == "closing" else ("tip_{k}", "socket_{k}")
    )
    return [(ends[0].format(k=k), ends[1].format(k=k)) for k in range(1, 7)]


def check_against_pinocchio(path, robot, ranges, pairs):
    ref = PinReference(path, pairs, ARMATURE)
    ratio = np.array([leg.joints[leg.actuated - 1].dynamics.transmission_ratio
                      for leg in robot.general.legs])  # fmt: skip
    for T, V, A in states(robot, ranges, 3, seed=3):
        q, v = ref.closed_state(T, V)
        gamma_ref = ref.kkt(q, v, A=A)
        gamma = robot.inverse_dynamics(T, V, A, motor=True)
        assert rel_error(gamma, gamma_ref) < 1e-9, f"IDM {rel_error(gamma, gamma_ref):.2e}"
        A_ref = ref.kkt(q, v, gamma=gamma_ref)
        A_robot = robot.direct_dynamics(T, V, gamma * ratio)
        assert rel_error(A_robot, A_ref) < 1e-9, f"DDM {rel_error(A_robot, A_ref):.2e}"


# --- 2. conventions ---------------------------------------------------------------------------


@pytest.mark.parametrize("style", ["floating", "tree-hinges"])
@pytest.mark.parametrize("arch", list(SOURCES))
def test_onshape_style_urdf_matches_pinocchio_kkt(arch, style, tmp_path):
    """Closing frames, transmissions with reductions, ``<dynamics>``, armature by dict."""
    path = write(tmp_path, cad_urdf(SOURCES[arch](), style, seed=1))
    robot = StewartRobot.from_urdf(path, armature=ARMATURE)
    pairs = [p for p in pairs_of() if not (style == "tree-hinges" and p[0] == "closing_1_1")]
    check_against_pinocchio(path, robot, RANGES[arch], pairs)
    src = robot.description.source
    root = ET.parse(path).getroot()
    order = [t.find("joint").get("name") for t in root.findall("transmission")]
    assert [
        leg.joints[robot.general.legs[i].actuated - 1] for i, leg in enumerate(src.legs)
    ] == order


def test_closures_as_pairs_and_actuated_by_argument(tmp_path):
    path = write(tmp_path, cad_urdf(SOURCES["pus"](), seed=2, closing="tip", transmissions=False))
    with pytest.raises(ModelImportError, match="not six legs"):
        StewartRobot.from_urdf(path)  # no sidecar, no closing frames: no loops
    actuated = [f"leg{k}_q1" for k in (3, 1, 2, 6, 5, 4)]
    robot = StewartRobot.from_urdf(path, closures=pairs_of("tip"), actuated=actuated)
    assert [leg.joints[0] for leg in robot.description.source.legs] == actuated
    assert robot.description.source.legs[0].spherical == "closure 'tip_3 = socket_3'"
    with pytest.raises(ModelImportError, match="without an actuator"):
        StewartRobot.from_urdf(path, closures=pairs_of("tip"))


def test_dynamics_tags_and_armature_become_joint_terms(tmp_path):
    path = write(tmp_path, cad_urdf(SOURCES["rus"](), seed=1))
    desc = StewartRobot.from_urdf(path, armature=ARMATURE).description
    for leg, src in zip(desc.legs, desc.source.legs, strict=True):
        for joint, name in zip(leg.joints, src.joints, strict=True):
            d = joint.dynamics
            assert (d.viscous, d.coulomb) == (0.0125, 0.0075)
            assert d.armature == ARMATURE.get(name, 0.0)
            assert (joint.lower, joint.upper) == (-1.0, 1.0)
    with pytest.raises(ModelImportError, match="no such joint"):
        import_urdf(path, armature={"nope": 1.0})


def test_urdf_frames_are_the_files(tmp_path):
    """F0 is the root link's frame, Fp the platform link's: the home pose is the floating
    joint's origin and P_i the closing frames' origins on the platform."""
    text = cad_urdf(SOURCES["ups"](), seed=1)
    path = write(tmp_path, text)
    desc = StewartRobot.from_urdf(path).description
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    q = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q)
    Tp = data.oMf[model.getFrameId("platform")]
    np.testing.assert_allclose(desc.home_pose[:3, :3], Tp.rotation, atol=1e-14)
    np.testing.assert_allclose(desc.home_pose[:3, 3], Tp.translation, atol=1e-14)
    for i, leg in enumerate(desc.source.legs):
        k = leg.spherical.removeprefix("closure 'closing_").rstrip("'")
        socket = data.oMf[model.getFrameId(f"closing_{k}_2")]
        np.testing.assert_allclose(
            Tp.actInv(socket).translation, desc.platform_points[i], atol=1e-14
        )


# --- 5. round trips -------------------------------------------------------------------------


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_urdf_round_trip_gives_the_canonical_description(name, tmp_path):
    """``from_urdf(write_urdf(d))`` (the sidecar holds the joint terms, transmissions, true
    limits and the home configuration) equals ``canonical_description(d)`` to 1e-12; for
    the canonical presets, ``d`` itself."""
    d = preset(name)
    urdf, _ = write_urdf(d, tmp_path / f"{name}.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelImportWarning)  # exact: no warning
        back = import_urdf(urdf).description
    assert back.is_ideal_ups == d.is_ideal_ups
    assert differences(back, canonical_description(d)) == []
    if name in CANONICAL:
        assert differences(back, d) == []


def test_urdf_round_trip_keeps_the_dynamics(tmp_path):
    d = preset("random-pus-1")
    urdf, _ = write_urdf(d, tmp_path / "r.urdf")
    back, robot = StewartRobot.from_urdf(urdf), StewartRobot(d)
    for T, V, A in states(robot, (0.01, 0.05), 3, seed=4):
        g = robot.inverse_dynamics(T, V, A, motor=True)
        assert rel_error(back.inverse_dynamics(T, V, A, motor=True), g) < 1e-12


# --- errors ---------------------------------------------------------------------------------


def test_urdf_errors_name_what_does_not_fit(tmp_path):
    text = cad_urdf(SOURCES["pus"](), seed=1)
    with pytest.raises(FileFormatError, match="not well-formed XML"):
        import_urdf(write(tmp_path, text.replace("</robot>", ""), "a.urdf"))
    no_ixx = text.replace('<inertia ixx="0.1" ', "<inertia ", 1)
    with pytest.raises(FileFormatError, match="<inertia> misses ixx"):
        import_urdf(write(tmp_path, no_ixx, "b.urdf"))
    planar = text.replace(
        '<joint name="camera_fix" type="fixed">', '<joint name="camera_fix" type="planar">'
    )
    with pytest.raises(ModelImportError, match="'camera_fix' is 'planar'"):
        import_urdf(write(tmp_path, planar, "c.urdf"))
    mimic = text.replace(
        '<dynamics damping="0.0125" friction="0.0075"/>',
        '<dynamics damping="0.0125" friction="0.0075"/><mimic joint="leg2_q2"/>',
        1,
    )
    with pytest.raises(ModelImportError, match="mimics 'leg2_q2'"):
        import_urdf(write(tmp_path, mimic, "d.urdf"))
    lonely = text.replace('<link name="closing_3_2"/>', '<link name="closing_x_2"/>').replace(
        'child link="closing_3_2"', 'child link="closing_x_2"'
    )
    with pytest.raises(ModelImportError, match="has no partner"):
        import_urdf(write(tmp_path, lonely, "e.urdf"))
    with pytest.raises(ModelImportError, match="drives 'nope', no joint of the model"):
        import_urdf(write(tmp_path, text, "f.urdf"), actuated=["nope"] * 6)
    with pytest.raises(FileFormatError, match="no URDF file"):
        import_urdf(tmp_path / "missing.urdf")
    start = text.index('<link name="leg2_link2">')
    mass_at = text.index("<mass value=", start)
    end = text.index("/>", mass_at)
    massless = text[:mass_at] + '<mass value="0"' + text[end:]
    with pytest.raises(ModelImportError, match=r"(?s)massless body.*the file's body 'leg2_link2'"):
        import_urdf(write(tmp_path, massless, "g.urdf"))


def test_continuous_joints_are_unlimited_revolute_joints(tmp_path):
    text = cad_urdf(SOURCES["rus"](), seed=1)
    text = text.replace(
        '<joint name="leg2_q3" type="revolute">', '<joint name="leg2_q3" type="continuous">'
    )
    desc = StewartRobot.from_urdf(write(tmp_path, text)).description
    k = [leg.joints[2] for leg in desc.source.legs].index("leg2_q3")
    joint = desc.legs[k].joints[2]
    assert joint.kind == "revolute" and (joint.lower, joint.upper) == (-math.inf, math.inf)


def test_bad_import_options_are_input_errors(tmp_path):
    """Options are checked before the file is read: a tolerance that is NaN, negative or a
    boolean (a NaN tolerance let every loop through), a platform or name that is not a
    string, a string for ``actuated`` (read letter by letter), a list for ``armature``."""
    import stewart_pin
    from stewart_pin.importers import import_mjcf

    path = write(tmp_path, cad_urdf(SOURCES["pus"](), seed=1))
    xml = str(model_files() / "examples" / "servo_head.xml")
    for key in ("closure_tolerance", "spin_tolerance"):
        for bad in (float("nan"), -1.0, 0.0, True, "1e-3"):
            with pytest.raises(stewart_pin.InputError, match=key):
                import_urdf(path, **{key: bad})
            with pytest.raises(stewart_pin.InputError, match=key):
                import_mjcf(xml, **{key: bad})
    for key in ("platform", "name"):
        with pytest.raises(stewart_pin.InputError, match=key):
            import_mjcf(xml, **{key: 3})
    for bad in (True, 1.5, [0]):
        with pytest.raises(stewart_pin.InputError, match="keyframe"):
            import_mjcf(xml, keyframe=bad)
    with pytest.raises(stewart_pin.InputError, match="actuated must be a list"):
        import_urdf(path, actuated="leg1_q1")
    with pytest.raises(stewart_pin.InputError, match="armature must be a dict"):
        import_urdf(path, armature=[0.1] * 6)
    for bad in (float("nan"), -1.0, True, "x"):
        with pytest.raises(stewart_pin.InputError, match="armature of joint 'leg1_q1'"):
            import_urdf(path, armature={"leg1_q1": bad})


# --- the sidecar's joint terms, non-finite numbers (issue 25) -------------------------------


def _round_trip_files(tmp_path, name="r"):
    """``preset("rus")`` written as a URDF and its sidecar: (urdf text, sidecar dict)."""
    urdf, sidecar = write_urdf(preset("rus"), tmp_path / f"{name}.urdf")
    return urdf.read_text(), json.loads(sidecar.read_text())


def _import_with(tmp_path, text, data, name):
    folder = tmp_path / name
    folder.mkdir()
    (folder / "r.closures.json").write_text(json.dumps(data))
    return import_urdf(write(folder, text, "r.urdf"))


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("lower", "abc", r'lower limit of .leg1_q1. must be a number or null .*got "abc"'),
        ("lower", [1], r"lower limit of .leg1_q1. must be a number or null .*got \[1\]"),
        ("lower", True, r"lower limit of .leg1_q1. must be a number or null .*got true"),
        ("upper", False, r"upper limit of .leg1_q1. must be a number or null .*got false"),
        ("upper", math.nan, r"upper limit of .leg1_q1. must be a number or null .*got NaN"),
        ("lower", 2.0, r"limits of .leg1_q1. are reversed: lower 2.0 > upper"),
    ],
)
def test_sidecar_limits_of_the_wrong_type_are_named(tmp_path, key, value, match):
    """A sidecar limit that is a string or a list (a traceback), a boolean (taken as 1 or
    0), NaN, or limits reversed: a FileFormatError naming the joint and the value."""
    text, data = _round_trip_files(tmp_path)
    data["joint_terms"]["leg1_q1"][key] = value
    with pytest.raises(FileFormatError, match=match):
        _import_with(tmp_path, text, data, "bad")


def test_sidecar_limit_alone_and_terms_of_unknown_joints_are_refused(tmp_path):
    """One limit without the other was ignored, and so were the terms of a joint the URDF
    does not have (a misspelt name): both refused by name. A joint's terms with ``null``
    limits are unbounded."""
    text, data = _round_trip_files(tmp_path)
    lonely = json.loads(json.dumps(data))
    del lonely["joint_terms"]["leg1_q1"]["upper"]
    with pytest.raises(FileFormatError, match="'leg1_q1' give a lower limit without an upper"):
        _import_with(tmp_path, text, lonely, "lonely")
    misspelt = json.loads(json.dumps(data))
    misspelt["joint_terms"]["leg1_q11"] = misspelt["joint_terms"]["leg1_q1"]
    with pytest.raises(ModelImportError, match="joint terms for 'leg1_q11': no such joint") as e:
        _import_with(tmp_path, text, misspelt, "misspelt")
    assert e.value.joints == ("leg1_q11",)
    free = json.loads(json.dumps(data))
    free["joint_terms"]["leg1_q1"].update(lower=None, upper=None)
    desc = _import_with(tmp_path, text, free, "free").description
    k = [leg.joints[0] for leg in desc.source.legs].index("leg1_q1")
    assert (desc.legs[k].joints[0].lower, desc.legs[k].joints[0].upper) == (-math.inf, math.inf)


@pytest.mark.parametrize("value", [True, "0.1", None])
def test_sidecar_joint_terms_take_numbers_only(tmp_path, value):
    """The sidecar reader of the Pinocchio models (``parse_joint_terms``) took ``true`` as
    1 and ``"0.1"`` as 0.1: numbers only, the joint and the key named."""
    from stewart_pin.formats.urdf import parse_joint_terms

    _, data = _round_trip_files(tmp_path)
    assert (
        parse_joint_terms(data)["leg1_q1"]["viscous"] == data["joint_terms"]["leg1_q1"]["viscous"]
    )
    data["joint_terms"]["leg2_q3"]["viscous"] = value
    with pytest.raises(FileFormatError, match="viscous of joint 'leg2_q3' must be a number"):
        parse_joint_terms(data, "r.closures.json")


@pytest.mark.parametrize(
    "pattern, repl, named",
    [
        (r'(<joint name="leg2_q1".*?<origin xyz=")[^"]*"', r'\1nan 0 0"',
         "<origin> of joint 'leg2_q1' (line "),
        (r'(<mass value=")[^"]*"', r'\g<1>1e999"', "<mass> of link 'leg1_link1' (line "),
        (r'(<limit [^>]*upper=")[^"]*"', r'\1inf"', "<limit> of joint "),
    ],
)  # fmt: skip
def test_non_finite_numbers_of_a_urdf_are_named(tmp_path, capfd, pattern, repl, named):
    """``xyz="nan 0 0"`` was reported as a redundant joint, an infinite mass as an invalid
    description: a ModelImportError naming the element, its link or joint, the line and
    the value; one line on the command line, exit 2."""
    import re

    from stewart_pin.cli import main

    text, data = _round_trip_files(tmp_path)
    bad = re.sub(pattern, repl, text, count=1, flags=re.S)
    assert bad != text
    path = write(tmp_path, bad, "r.urdf")
    (tmp_path / "r.closures.json").write_text(json.dumps(data))
    with pytest.raises(ModelImportError, match="every number of a URDF must be finite") as e:
        import_urdf(path)
    assert named in str(e.value)
    capfd.readouterr()
    assert main(["import", str(path), "-o", str(tmp_path / "out.json")]) == 2
    err = capfd.readouterr().err
    assert len(err.strip().splitlines()) == 1 and named in err, err
