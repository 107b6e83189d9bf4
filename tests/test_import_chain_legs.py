# ruff: noqa: E501 (lines of XML kept whole, as they appear in the files written)
"""Published-style model files whose legs are not three 1-dof joints and an ideal ball load
as chain legs, exactly (``docs/importing.md``, "Legs of any joints: chain legs").

Each file is written the way its community writes it, from a robot with chain legs
(:func:`~stewart_pin.description.chain_leg_presets.welded_ups`: U-joint, slide, spin hinge
and an upper U-joint whose axes miss each other by 0.5 mm, links of 15-90 g, welded to the
platform), and the imported robot is compared with a reference built from the file alone,
never with the project's dynamics:

(a) MJCF as a model collection writes it (site welds, ``springdamper``, ``ref`` offsets,
    a ``home`` keyframe): IDM and DDM against the exact KKT solve on MuJoCo's own model
    (``helpers.mujoco_kkt``);
(b) a Fusion/Onshape-style URDF, the platform hanging from one leg in the tree, the other
    loops welds at the links' centre-of-mass frames (sidecar version 2, ``"inertial"``):
    against Pinocchio's constrained dynamics (``pin.constraintDynamics``) with
    ``CONTACT_6D`` constraints built from ``pin.buildModelFromUrdf``;
(c) SDFormat 1.9 whose loops are fixed joints to the platform: against the same
    Pinocchio reference on the URDF of the same robot.
"""

from __future__ import annotations

import json
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from helpers import (
    mujoco_closed_state,
    mujoco_kkt,
    rel_error,
    urdf_weights,
    weight_removal_torques,
)
from scipy.spatial.transform import Rotation

from stewart_pin import ModelImportError, StewartRobot
from stewart_pin.description.chain_leg_presets import welded_ups
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.exceptions import InputError, ModelImportWarning
from stewart_pin.importers import import_mjcf, import_sdf, import_urdf

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")

#: Relative agreement asked of every comparison.
TOLERANCE = 1e-10
#: The slides' ``ref`` in the community MJCF [m].
SLIDE_REF = 0.6


def _source() -> StewartRobot:
    return StewartRobot(welded_ups(seed=4))


def _states(robot: StewartRobot, n: int = 3, seed: int = 5):
    T, V, A = robot.sample_states(n, rng=seed)
    return T, V, A


# --- (a) MJCF as a model collection writes it -------------------------------------------------


def community_mjcf() -> str:
    """The MJCF of :func:`_source` rewritten by hand the community's way: no generator
    comments, the slides zeroed elsewhere (``ref``: the keyframe, springs and ranges
    shifted with it, the same physical robot), the spin hinges' spring and damper given
    as ``springdamper`` (MuJoCo computes them), the loops site welds, a ``home``
    keyframe; the rest as written (axes missing by 0.5 mm, links of 15-90 g)."""
    xml = _source().mjcf()
    xml = re.sub(r"<!--.*?-->\n", "", xml)
    for k in range(1, 7):

        def slide(m: re.Match[str]) -> str:
            tag = m.group(0)
            lo, hi = (float(x) for x in re.search(r'range="([^"]+)"', tag).group(1).split())
            tag = re.sub(r'range="[^"]+"', f'range="{lo + SLIDE_REF!r} {hi + SLIDE_REF!r}"', tag)
            rest = float(re.search(r'springref="([^"]+)"', tag).group(1))
            tag = re.sub(r'springref="[^"]+"', f'springref="{rest + SLIDE_REF!r}"', tag)
            return tag.replace('type="slide"', f'type="slide" ref="{SLIDE_REF!r}"')

        xml = re.sub(rf'<joint name="leg{k}_q3"[^>]*/>', slide, xml)

        def spin(m: re.Match[str]) -> str:
            tag = re.sub(r' (stiffness|damping)="[^"]+"', "", m.group(0))
            return tag.replace("/>", 'springdamper="0.4 0.7" />')

        xml = re.sub(rf'<joint name="leg{k}_q4"[^>]*/>', spin, xml)

    def key(m: re.Match[str]) -> str:
        q = [float(x) for x in m.group(1).split()]
        for k in range(6):
            q[6 * k + 2] += SLIDE_REF
        return f'qpos="{" ".join(repr(x) for x in q)}"'

    xml = re.sub(r'qpos="([^"]+)"', key, xml)
    assert xml.count(f' ref="{SLIDE_REF!r}"') == 6 and xml.count("springdamper") == 6
    return xml


def body_welds(xml: str) -> str:
    """``xml`` with its site welds written in the body form: ``anchor`` (the platform
    point, in the platform) and ``relpose`` (that point in the leg's last body, and the
    platform's orientation in it) from MuJoCo's own state at the ``home`` keyframe."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    for k in range(1, 7):
        b1, b2 = m.body(f"leg{k}_link6").id, m.body("platform").id
        anchor = m.site_pos[m.site(f"platform_p{k}").id]
        R1, R2 = d.xmat[b1].reshape(3, 3), d.xmat[b2].reshape(3, 3)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, (R1.T @ R2).ravel())
        pos = R1.T @ (R2 @ anchor + d.xpos[b2] - d.xpos[b1])
        text = lambda xs: " ".join(repr(float(x)) for x in xs)  # noqa: E731
        xml = xml.replace(
            f'<weld name="loop{k}" site1="leg{k}_tip" site2="platform_p{k}"',
            f'<weld name="loop{k}" body1="leg{k}_link6" body2="platform" '
            f'anchor="{text(anchor)}" relpose="{text([*pos, *quat])}"',
        )
    assert "site1=" not in xml
    return xml


def in_range(m, data) -> None:
    """Hinges whose range spans a full turn (the spin's ``0 2pi``) taken into their range:
    MuJoCo's state of the file with every joint within its limits (Gauss-Newton may end a
    turn away; a spring on such a hinge would then pull by ``2 pi k``)."""
    for j in range(m.njnt):
        lo, hi = m.jnt_range[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE and hi - lo >= 2 * np.pi - 1e-9:
            a = m.jnt_qposadr[j]
            data.qpos[a] = lo + np.remainder(data.qpos[a] - lo, 2 * np.pi)


@pytest.mark.parametrize("form", ["site", "body"])
def test_community_mjcf_loads_as_chain_legs_matching_mujoco_kkt(form: str) -> None:
    """Site welds, and the same welds in the body form (``anchor``, ``relpose``)."""
    xml = community_mjcf() if form == "site" else body_welds(community_mjcf())
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelImportWarning)  # nothing approximated
        result = import_mjcf(xml)
    desc = result.description
    assert desc.chain_legs is not None and result.report.approximations == []
    assert [leg.n_joints for leg in desc.chain_legs] == [6] * 6
    assert {leg.closure for leg in desc.chain_legs} == {"weld"}
    # every link massive, as in the file (15-90 g at the spin and upper U-joint)
    masses = np.array([leg.inertia[:, 9] for leg in desc.chain_legs])
    assert masses.min() >= 0.015 and np.all(masses[:, 3:] <= 0.09)
    robot = StewartRobot(desc)
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    assert m.jnt_stiffness[m.joint("leg1_q4").id] > 0.0  # springdamper compiled
    mujoco.mj_resetDataKeyframe(m, data, m.key("home").id)
    guess = data.qpos.copy()
    T, V, A = _states(robot, 6)
    gamma = robot.inverse_dynamics(T, V, A)
    for n in range(len(T)):
        mujoco_closed_state(m, data, "platform", T[n], V[n], guess=guess)
        in_range(m, data)
        # the leg joints where the robot's inverse geometry puts them (the file's values)
        q = np.concatenate(robot.inverse_geometry(T[n]))
        legs = [m.joint(f"leg{k}_q{j}").qposadr[0] for k in range(1, 7) for j in range(1, 7)]
        assert np.abs(np.remainder(data.qpos[legs] - q + np.pi, 2 * np.pi) - np.pi).max() < 1e-9
        gamma_mj = mujoco_kkt(m, data, "platform", A=A[n])
        assert rel_error(gamma[n], gamma_mj) < TOLERANCE, (
            f"IDM {rel_error(gamma[n], gamma_mj):.2e}"
        )
        A_mj = mujoco_kkt(m, data, "platform", gamma=gamma_mj)
        A_robot = robot.direct_dynamics(T[n], V[n], gamma_mj)
        assert rel_error(A_robot, A_mj) < TOLERANCE, f"DDM {rel_error(A_robot, A_mj):.2e}"


def test_the_ball_approximation_is_an_explicit_option_reported_with_its_effect() -> None:
    """``approximate_legs=True``: the spin + U-joint tops taken as ideal balls (their links
    and joint terms dropped), reported, and its effect on the efforts measured against the
    file's physics; it is an approximation: MuJoCo's efforts differ."""
    from stewart_pin.check.import_effects import effect_on_efforts, import_effects

    xml = community_mjcf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        result = import_mjcf(xml, approximate_legs=True)
    desc = result.description
    assert desc.chain_legs is None and len(desc.legs or ()) == 6
    text = " ".join(result.report.approximations)
    assert "taken as an ideal spherical joint" in text and "leg1_q4" in text
    assert "missing each other by up to 0.0005 m" in text
    robot = StewartRobot(desc)
    (line,) = import_effects(result, robot)
    effect = float(re.search(r": ([0-9.e+-]+) % on IDM at home", line).group(1))
    assert effect > 0.01  # percent
    # the same measure of the default import: the file's physics, exactly
    exact = import_mjcf(xml)
    assert effect_on_efforts(exact, StewartRobot(exact.description)) < 1e-12
    assert line in str(result.report)
    with pytest.raises(InputError, match="approximate_legs must be True or False"):
        import_mjcf(xml, approximate_legs="yes")


# --- Pinocchio's constrained dynamics with 6D loop constraints, from a URDF --------------------


class Pin6D:
    """A URDF in Pinocchio (``pin.buildModelFromUrdf``), its welds as ``CONTACT_6D``
    :class:`pin.RigidConstraintModel` (``welds``: ``(link1, F1, link2, F2)``, the frames in
    each link), the actuated joints, URDF damping and friction (the project's dead band),
    the platform frame. IDM by linearity of ``pin.constraintDynamics`` in the torques."""

    def __init__(
        self, path, welds, actuated, platform="platform", home=None, terms=None, weightless=()
    ):
        m = self.model = pin.buildModelFromUrdf(str(path))
        # links without gravity (SDF <gravity>false</gravity>): the forces -m g at their
        # centres of mass, as external forces (joint, mass, centre of mass in the joint)
        self.weightless = urdf_weights(m, path, weightless)
        self.springs = []  # (idx_q, idx_v, stiffness, rest) from the sidecar's joint terms
        for name, t in (terms or {}).items():
            j = m.joints[m.getJointId(name)]
            m.armature[j.idx_v] = t["armature"]
            lo, hi = t["lower"], t["upper"]
            turn = lo is not None and hi is not None and hi - lo >= 2 * np.pi - 1e-9
            # a full-turn hinge's angle taken into its range (a spring pulls from there)
            self.springs.append((j.idx_q, j.idx_v, t["stiffness"], t["rest_position"],
                                 lo if turn else None))  # fmt: skip
        self.constraints = pin.StdVec_RigidConstraintModel()
        self.frames = []
        for l1, F1, l2, F2 in welds:
            ends = []
            for link, F in ((l1, F1), (l2, F2)):
                f = m.frames[m.getFrameId(link)]
                ends.append((f.parentJoint, f.placement * pin.SE3(F)))
            (j1, P1), (j2, P2) = ends
            self.constraints.append(
                pin.RigidConstraintModel(
                    pin.ContactType.CONTACT_6D, m, j1, P1, j2, P2, pin.ReferenceFrame.LOCAL
                )
            )
            self.frames.append(ends)
        self.data = m.createData()
        self.cdata = pin.StdVec_RigidConstraintData()
        for c in self.constraints:
            self.cdata.append(c.createData())
        pin.initConstraintDynamics(m, self.data, self.constraints, self.cdata)
        self.settings = pin.ProximalSettings(1e-14, 0.0, 1)
        self.platform = m.getFrameId(platform)
        self.S = np.zeros((6, m.nv))
        for u, name in enumerate(actuated):
            self.S[u, m.joints[m.getJointId(name)].idx_v] = 1.0
        self.q = pin.neutral(m) if home is None else home

    def _pose(self, joint, P):
        return self.data.oMi[joint] * P

    def _rows(self, q):
        m, d = self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        rows, res = [], []
        for (j1, P1), (j2, P2) in self.frames:
            M1, M2 = self._pose(j1, P1), self._pose(j2, P2)
            J = []
            for j, M in ((j1, M1), (j2, M2)):
                Jj = pin.getJointJacobian(m, d, j, pin.ReferenceFrame.WORLD)
                J.append(pin.SE3(np.eye(3), -M.translation).action @ Jj)  # at M's origin
            rows.append(np.r_[J[0][:3] - J[1][:3], J[0][3:] - J[1][3:]])
            res.append(
                np.r_[M1.translation - M2.translation, pin.log3(M1.rotation @ M2.rotation.T)]
            )
        Jp = pin.getFrameJacobian(m, d, self.platform, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return np.vstack(rows), np.concatenate(res), Jp

    def closed_state(self, T, V):
        """q, v: the welds closed, the platform at T with the twist V (F0), by
        Gauss-Newton from the last state (the file's home at first)."""
        m, d = self.model, self.data
        q = self.q
        for _ in range(80):
            J, r, Jp = self._rows(q)
            M = d.oMf[self.platform]
            r = np.r_[r, M.translation - T[:3, 3], pin.log3(M.rotation @ T[:3, :3].T)]
            if np.abs(r).max() < 1e-14:
                break
            q = pin.integrate(m, q, -np.linalg.lstsq(np.r_[J, Jp], r, rcond=None)[0])
        else:
            raise AssertionError(f"no closed state: {np.abs(r).max():.3g}")
        J, _, Jp = self._rows(q)
        v = np.linalg.lstsq(np.r_[J, Jp], np.r_[np.zeros(len(J)), V], rcond=None)[0]
        return q, v

    def direct(self, q, v, gamma):
        """The platform's classical acceleration ``[a of its origin, dw/dt]`` (F0)."""
        m, d = self.model, self.data
        tau = self.S.T @ gamma - m.damping * v - m.friction * coulomb_sign(v)
        for iq, iv, k, rest, lo in self.springs:
            angle = q[iq] if lo is None else lo + np.remainder(q[iq] - lo, 2 * np.pi)
            tau[iv] -= k * (angle - rest)
        if self.weightless:  # J^T f of the compensating forces
            tau += weight_removal_torques(m, d, q, self.weightless)
        ddq = pin.constraintDynamics(m, d, q, v, tau, self.constraints, self.cdata, self.settings)
        pin.forwardKinematics(m, d, q, v, ddq)
        pin.updateFramePlacements(m, d)
        a = pin.getFrameClassicalAcceleration(
            m, d, self.platform, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        return np.r_[a.linear, a.angular]

    def inverse(self, q, v, A):
        """The actuator efforts giving the platform the acceleration ``A``: the direct
        model is affine in them."""
        a0 = self.direct(q, v, np.zeros(6))
        G = np.column_stack([self.direct(q, v, e) - a0 for e in np.eye(6)])
        return np.linalg.solve(G, A - a0)


def _check_against(robot: StewartRobot, ref: Pin6D) -> None:
    T, V, A = _states(robot)
    gamma = robot.inverse_dynamics(T, V, A)
    for n in range(len(T)):
        q, v = ref.closed_state(T[n], V[n])
        ref.q = q
        gamma_ref = ref.inverse(q, v, A[n])
        assert rel_error(gamma[n], gamma_ref) < TOLERANCE, (
            f"IDM {rel_error(gamma[n], gamma_ref):.2e}"
        )
        A_ref = ref.direct(q, v, gamma_ref)
        A_robot = robot.direct_dynamics(T[n], V[n], gamma_ref)
        assert rel_error(A_robot, A_ref) < TOLERANCE, f"DDM {rel_error(A_robot, A_ref):.2e}"


def _urdf_parts(tmp_path):
    """The source robot's URDF (floating platform) and sidecar (version 1: its weld
    frames, home joint positions and pose), and Pinocchio's model of it at home."""
    src = _source()
    path, side = src.write_urdf(tmp_path / "source.urdf")
    data = json.loads(side.read_text())
    m = pin.buildModelFromUrdf(str(path))
    d = m.createData()
    q = pin.neutral(m)
    for name, value in data["home_joint_positions"].items():
        q[m.joints[m.getJointId(name)].idx_q] = value
    Tp = np.array(data["home_pose"])
    j = m.joints[m.getJointId("platform_joint")]
    q[j.idx_q : j.idx_q + 7] = pin.SE3ToXYZQUAT(pin.SE3(Tp))
    pin.framesForwardKinematics(m, d, q)
    world = {f.name: d.oMf[i].homogeneous for i, f in enumerate(m.frames)}
    return src, path.read_text(), data, world


def _frame_of(spec) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", spec["rpy"]).as_matrix()
    T[:3, 3] = spec["xyz"]
    return T


def _xyz_rpy(T) -> str:
    rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz")
    return f'xyz="{" ".join(repr(float(x)) for x in T[:3, 3])}" rpy="{" ".join(repr(float(x)) for x in rpy)}"'


def _inertial_origin(urdf: str, link: str) -> np.ndarray:
    el = ET.fromstring(urdf).find(f"link[@name='{link}']/inertial/origin")
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", [float(x) for x in el.get("rpy").split()]).as_matrix()
    T[:3, 3] = [float(x) for x in el.get("xyz").split()]
    return T


# --- (b) a Fusion/Onshape-style URDF, welds at centre-of-mass frames ---------------------------


def test_cad_urdf_with_welds_at_com_frames_matches_pinocchio_6d_constraints(tmp_path) -> None:
    """The platform is the child of leg 1's last link by a fixed joint (a CAD export's
    tree); legs 2-6 end at small mounts fixed to the platform whose ``<inertial>`` origin
    is where the leg's last link has its own at home: the sidecar welds the two
    ``"inertial"`` frames (PyBullet's ``createConstraint`` convention)."""
    _, urdf, data, world = _urdf_parts(tmp_path)
    urdf = re.sub(r"<!--.*?-->\n", "", urdf)
    Tp = world["platform"]
    leg1 = world["leg1_link6"]
    # the platform hangs from leg 1: a fixed joint where it is at home
    floating = re.search(r'<joint name="platform_joint" type="floating">.*?</joint>', urdf, re.S)
    hang = (
        '<joint name="platform_mount" type="fixed"><parent link="leg1_link6" />'
        f'<child link="platform" /><origin {_xyz_rpy(np.linalg.inv(leg1) @ Tp)} /></joint>'
    )
    mounts = []
    welds = []
    for k in range(2, 7):
        F = world[f"leg{k}_link6"] @ _inertial_origin(urdf, f"leg{k}_link6")
        C = np.linalg.inv(Tp) @ F  # the mount's inertial frame in the platform
        mounts.append(
            f'<link name="mount_{k}"><inertial><origin {_xyz_rpy(C)} /><mass value="0.01" />'
            '<inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6" /></inertial>'
            f'</link><joint name="mount_{k}_fixed" type="fixed"><parent link="platform" />'
            f'<child link="mount_{k}" /><origin xyz="0 0 0" rpy="0 0 0" /></joint>'
        )
        welds.append({"name": f"weld_{k}", "type": "weld", "link1": f"leg{k}_link6",
                      "frame1": "inertial", "link2": f"mount_{k}", "frame2": "inertial"})  # fmt: skip
    urdf = urdf.replace(floating.group(0), hang + "".join(mounts))
    path = tmp_path / "cad.urdf"
    path.write_text(urdf)
    sidecar = {
        "format": "stewart-pin/closures",
        "version": 2,
        "closures": welds,
        "platform": "platform",
        "actuated_joints": data["actuated_joints"],
        "home_joint_positions": data["home_joint_positions"],
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)  # the xyz/rpy's round-off
        result = import_urdf(path, closures=sidecar)
    desc = result.description
    assert [leg.closure for leg in desc.chain_legs] == ["weld"] * 6
    assert result.report.platform == "platform"
    assert "'leg1_q6'" in str(result.report)  # leg 1 closed in the tree
    robot = StewartRobot(desc)
    # a home a micro-radian off: the loops closed from that residual, reported with its
    # effect against the file's own physics (Pinocchio's model of the file's tree)
    from stewart_pin.check.import_effects import import_effects

    off = dict(
        data["home_joint_positions"], leg2_q1=data["home_joint_positions"]["leg2_q1"] + 1e-6
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        moved = import_urdf(path, closures=dict(sidecar, home_joint_positions=off))
    assert moved.report.approximations[0].startswith("loops closed from a residual")
    (line,) = import_effects(moved, StewartRobot(moved.description))
    effect = float(re.search(r": ([0-9.e+-]+) % on IDM at home", line).group(1))
    assert 0.0 < effect < 1e-2
    ref_welds = [(f"leg{k}_link6", _inertial_origin(urdf, f"leg{k}_link6"),
                  f"mount_{k}", _inertial_origin(urdf, f"mount_{k}")) for k in range(2, 7)]  # fmt: skip
    ref = Pin6D(path, ref_welds, data["actuated_joints"])
    q = pin.neutral(ref.model)
    for name, value in data["home_joint_positions"].items():
        q[ref.model.joints[ref.model.getJointId(name)].idx_q] = value
    ref.q = q
    _check_against(robot, ref)


# --- (c) SDFormat 1.9, loops closed by fixed joints --------------------------------------------


def _sdf_of_welded_ups(tmp_path, weightless=()):
    """The SDF 1.9 of :func:`_urdf_parts`'s robot as Gazebo users write it (the test
    below), the links ``weightless`` with ``<gravity>false</gravity>``; returns its path,
    the sidecar's data and the welds for :class:`Pin6D`."""
    src, urdf, data, world = _urdf_parts(tmp_path)
    root = ET.fromstring(urdf)
    out = ['<?xml version="1.0"?>\n<sdf version="1.9"><world name="lab">']
    out.append('<gravity>0 0 -9.81</gravity><model name="hexapod">')  # Pinocchio's
    out.append('<link name="base_link"><pose>0 0 0 0 0 0</pose></link>')
    out.append(
        '<joint name="anchor" type="fixed"><parent>world</parent><child>base_link</child></joint>'
    )
    parent_of = {j.find("child").get("link"): j for j in root.findall("joint")}

    def pose(T, rel=""):
        rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz")
        attr = f' relative_to="{rel}"' if rel else ""
        return f"<pose{attr}>{' '.join(repr(float(x)) for x in [*T[:3, 3], *rpy])}</pose>"

    for link in root.findall("link"):
        name = link.get("name")
        if name == "base_link":
            continue
        j = parent_of[name]
        p = j.find("parent").get("link")
        rel = np.linalg.inv(world[p]) @ world[name] if name != "platform" else world[name]
        ine = link.find("inertial")
        o = ine.find("origin")
        I = ine.find("inertia")
        tensor = "".join(
            f"<{k}>{I.get(k)}</{k}>" for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        )
        out.append(
            f'<link name="{name}">{pose(rel, p if name != "platform" else "")}<inertial>'
            f"<pose>{o.get('xyz')} {o.get('rpy')}</pose><mass>{ine.find('mass').get('value')}</mass>"
            f"<inertia>{tensor}</inertia></inertial>"
            + ("<gravity>false</gravity>" if name in weightless else "")
            + "</link>"
        )
    for j in root.findall("joint"):
        if j.get("type") == "floating":
            continue
        axis = j.find("axis").get("xyz")
        dyn = j.find("dynamics")
        out.append(
            f'<joint name="{j.get("name")}" type="{j.get("type")}"><parent>{j.find("parent").get("link")}'
            f"</parent><child>{j.find('child').get('link')}</child><axis><xyz>{axis}</xyz>"
            "<limit><lower>-1e16</lower><upper>1e16</upper></limit>"
            f"<dynamics><damping>{dyn.get('damping')}</damping><friction>{dyn.get('friction')}"
            "</friction></dynamics></axis></joint>"
        )
    welds = []
    for k, c in enumerate(data["closures"], start=1):
        F2 = _frame_of(c["frame2"])  # the weld frame in the platform
        out.append(
            f'<joint name="weld_{k}" type="fixed"><parent>{c["link1"]}</parent>'
            f"<child>platform</child>{pose(F2)}</joint>"
        )
        welds.append((c["link1"], _frame_of(c["frame1"]), "platform", F2))
    out.append("</model></world></sdf>\n")
    path = tmp_path / "hexapod.sdf"
    path.write_text("".join(out))
    return path, data, welds, src


def test_sdf_with_fixed_joint_closures_matches_pinocchio_6d_constraints(tmp_path) -> None:
    """SDF 1.9 as Gazebo users write it: every link posed ``relative_to`` its parent at the
    assembled home (every joint 0 there), joint axes in the joint frame, the platform the
    child of six fixed joints placed at the legs' weld frames (its only joints: loops).
    Reference: Pinocchio on the source URDF with the same six welds (6D constraints)."""
    path, data, welds, src = _sdf_of_welded_ups(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        result = import_sdf(path, actuated=data["actuated_joints"])
    desc = result.description
    assert [leg.closure for leg in desc.chain_legs] == ["weld"] * 6
    assert [leg.n_joints for leg in desc.chain_legs] == [6] * 6
    robot = StewartRobot(desc)
    _check_against(robot, _source_reference(tmp_path, data, welds))
    assert src.description.name == "welded-ups-4"


def _source_reference(tmp_path, data, welds, weightless=()) -> Pin6D:
    """The reference of the SDF tests: the source URDF in Pinocchio with its welds, at its
    home (zeros elsewhere: the efforts do not depend on them); ``weightless``: links whose
    weights the compensating forces remove."""
    ref = Pin6D(tmp_path / "source.urdf", welds, data["actuated_joints"], weightless=weightless)
    q = pin.neutral(ref.model)
    for name, value in data["home_joint_positions"].items():
        q[ref.model.joints[ref.model.getJointId(name)].idx_q] = value
    j = ref.model.joints[ref.model.getJointId("platform_joint")]
    q[j.idx_q : j.idx_q + 7] = pin.SE3ToXYZQUAT(pin.SE3(np.array(data["home_pose"])))
    ref.q = q
    return ref


def test_sdf_links_without_gravity_in_chain_legs_match_pinocchio_with_compensating_forces(
    tmp_path,
) -> None:
    """The same SDF with ``<gravity>false</gravity>`` on the platform and two leg links
    (one a slide's, one a leg's last): compensation 1 on those links of the chain legs and
    the platform, against Pinocchio with the forces ``-m g`` at their centres of mass.
    (Leg 1's last link is the platform's parent in the SDF tree, fixed to it: one link with
    it, so it shares the platform's factor; a different one is refused, by name.)"""
    weightless = ("platform", "leg1_link6", "leg2_link3", "leg5_link6")
    path, data, welds, _ = _sdf_of_welded_ups(tmp_path, weightless)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        result = import_sdf(path, actuated=data["actuated_joints"])
    desc = result.description
    assert desc.platform_gravcomp == 1.0
    got = [
        bodies
        for leg, report in zip(desc.chain_legs, result.report.legs, strict=True)
        for c, bodies in zip(leg.gravcomp, report.bodies, strict=True)
        if c
    ]
    assert sorted(got) == ["leg2_link3", "leg5_link6"]
    assert sum(int(np.count_nonzero(leg.gravcomp == 1.0)) for leg in desc.chain_legs) == 2
    robot = StewartRobot(desc)
    _check_against(robot, _source_reference(tmp_path, data, welds, weightless))
    # leg 1's last link without the platform's factor: one link, two factors, refused
    path, *_ = _sdf_of_welded_ups(tmp_path, weightless[1:])
    with pytest.raises(ModelImportError, match=r"'leg1_link6', 'platform'.*different gravity"):
        import_sdf(path, actuated=data["actuated_joints"])
    # the compensation matters: the reference with every weight differs
    T, V, A = _states(robot)
    full = _source_reference(tmp_path, data, welds)
    q, v = full.closed_state(T[0], V[0])
    assert rel_error(robot.inverse_dynamics(T[0], V[0], A[0]), full.inverse(q, v, A[0])) > 1e-3


def test_the_projects_own_urdf_of_chain_legs_loads_with_its_frame_closures(tmp_path) -> None:
    """The URDF writer's file of a robot with welded legs (its version-1 sidecar's
    ``"frame"`` closures, joint terms, home) imports as chain legs, against Pinocchio's 6D
    constrained dynamics of the URDF with the sidecar's welds, armatures and springs."""
    _, _, data, _ = _urdf_parts(tmp_path)
    robot = StewartRobot.from_urdf(tmp_path / "source.urdf")
    assert [leg.closure for leg in robot.description.chain_legs] == ["weld"] * 6
    welds = [
        (c["link1"], _frame_of(c["frame1"]), c["link2"], _frame_of(c["frame2"]))
        for c in data["closures"]
    ]
    ref = Pin6D(
        tmp_path / "source.urdf", welds, data["actuated_joints"], terms=data["joint_terms"]
    )
    ref.model.gravity.linear = np.array(data["gravity"])  # the sidecar's
    q = pin.neutral(ref.model)
    for name, value in data["home_joint_positions"].items():
        q[ref.model.joints[ref.model.getJointId(name)].idx_q] = value
    j = ref.model.joints[ref.model.getJointId("platform_joint")]
    q[j.idx_q : j.idx_q + 7] = pin.SE3ToXYZQUAT(pin.SE3(np.array(data["home_pose"])))
    ref.q = q
    _check_against(robot, ref)


# --- legs that still do not fit ----------------------------------------------------------------


def test_a_three_joint_leg_welded_to_the_platform_names_its_missing_freedoms() -> None:
    xml = community_mjcf()
    # leg 2's spin and upper U-joint removed: a U-P leg welded to the platform
    for j in (4, 5, 6):
        xml = re.sub(rf'<joint name="leg2_q{j}"[^>]*/>', "", xml)
    xml = re.sub(r"<keyframe>.*</keyframe>", "", xml, flags=re.S)
    with pytest.raises(ModelImportError, match="leaves the platform 3 freedom") as info:
        import_mjcf(xml)
    assert info.value.joints == ("leg2_q1", "leg2_q2", "leg2_q3")


# --- R-S-S rods spinning freely: the idle joint -------------------------------------------------


def test_rss_rods_spinning_freely_get_their_idle_joint_and_match_mujoco_kkt() -> None:
    """6-RSS whose rods' inertia is not symmetric about their ball-to-ball line, written
    with four hinges and a ``connect`` per leg: each leg's spin hinge (the joint that
    leaves the ball centre in place) becomes its ``idle_joint``, exactly (no rod spin
    removed); Gamma and the spin accelerations match MuJoCo's KKT solve for the same spin
    state (``test_chain_legs_mjcf``'s, which takes no Coulomb friction)."""
    from test_chain_legs_mjcf import mujoco_kkt_inverse_dynamics, without_coulomb

    from stewart_pin.description.chain_leg_presets import rss_robot

    xml = StewartRobot(without_coulomb(rss_robot(False))).mjcf()
    result = import_mjcf(xml)
    legs = result.description.chain_legs
    assert [leg.idle_joint for leg in legs] == [4] * 6 and result.report.approximations == []
    robot = StewartRobot(result.description)
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    T, V, A = robot.sample_states(2, rng=6)
    rng = np.random.default_rng(1)
    spin, rate = rng.uniform(-1.0, 1.0, (2, 6)), rng.uniform(-5.0, 5.0, (2, 6))
    res = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    for n in range(2):
        got, sigma = mujoco_kkt_inverse_dynamics(
            m, data, robot, T[n], V[n], A[n], (spin[n], rate[n])
        )
        assert rel_error(res.gamma[n], got) < TOLERANCE
        assert rel_error(res.idle_accel[n], sigma) < TOLERANCE


def test_cli_import_reads_chain_legs_and_approximates_only_when_asked(tmp_path, capsys) -> None:
    from stewart_pin.cli import main

    path = tmp_path / "hexapod.xml"
    path.write_text(community_mjcf())
    assert main(["import", str(path)]) == 0
    out = capsys.readouterr().out
    assert "chain legs" in out and "chain of 6 joints closed by a weld" in out
    assert "approximation:" not in out and "effect:" not in out
    assert main(["import", str(path), "--approximate-legs"]) == 0
    out = capsys.readouterr().out
    assert "approximation: " in out and "taken as an ideal spherical joint" in out
    assert re.search(r"effect: .* [0-9.e+-]+ % on IDM at home", out)


def test_a_loop_away_from_the_platform_of_chain_legs_is_refused() -> None:
    """A connect pinning a leg's first body to the world: not dropped, refused by name."""
    xml = community_mjcf().replace(
        "<equality>",
        '<equality>\n    <connect name="pin" body1="leg1_link1" body2="world" anchor="0 0 0"/>',
    )
    with pytest.raises(ModelImportError, match=r"loop closure 'pin'.*away from the platform") as e:
        import_mjcf(xml)
    assert e.value.joints == ("pin",) and "world" in e.value.bodies


def test_a_mixed_robot_of_ball_and_welded_legs_matches_mujoco_kkt() -> None:
    """Legs 1, 3, 5 three joints closed by ``<connect>``, legs 2, 4, 6 six joints welded:
    one robot of chain legs, each leg with its own closure, against MuJoCo's KKT."""
    from stewart_pin.description.chain_leg_presets import mixed_chain_robot

    xml = StewartRobot(mixed_chain_robot(seed=4)).mjcf()
    result = import_mjcf(xml)
    legs = result.description.chain_legs
    assert [leg.closure for leg in legs] == ["ball", "weld"] * 3
    assert [leg.n_joints for leg in legs] == [3, 6] * 3
    robot = StewartRobot(result.description)
    matches_mujoco_kkt(xml, robot, *_states(robot, 3, seed=7))


def matches_mujoco_kkt(xml: str, robot: StewartRobot, T, V, A) -> np.ndarray:
    """IDM and DDM of ``robot`` at the states ``T, V, A`` against MuJoCo's exact KKT solve
    on ``xml`` (each state closed by MuJoCo's own constraints, from the ``home``
    keyframe); returns MuJoCo's efforts (N, 6)."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, data, m.key("home").id)
    guess = data.qpos.copy()
    gamma = robot.inverse_dynamics(T, V, A)
    out = np.empty_like(gamma)
    for n in range(len(T)):
        mujoco_closed_state(m, data, "platform", T[n], V[n], guess=guess)
        in_range(m, data)
        out[n] = gamma_mj = mujoco_kkt(m, data, "platform", A=A[n])
        assert rel_error(gamma[n], gamma_mj) < TOLERANCE, (
            f"IDM {rel_error(gamma[n], gamma_mj):.2e}"
        )
        A_mj = mujoco_kkt(m, data, "platform", gamma=gamma_mj)
        A_robot = robot.direct_dynamics(T[n], V[n], gamma_mj)
        assert rel_error(A_robot, A_mj) < TOLERANCE, f"DDM {rel_error(A_robot, A_mj):.2e}"
    return out


#: Community MJCF bodies given a gravcomp (the platform, a slide's link, a spin link, a
#: last link), different factors.
GRAVCOMP = {
    "platform": 0.6,
    "leg1_link1": 1.0,
    "leg2_link4": 0.35,
    "leg5_link3": 0.8,
    "leg6_link6": 0.5,
}


def _with_gravcomp(xml: str, bodies: dict[str, float]) -> str:
    for body, c in bodies.items():
        xml, n = re.subn(rf'(<body name="{body}"[^>]*?)>', rf'\1 gravcomp="{c}">', xml, count=1)
        assert n == 1, body
    return xml


def test_chain_legs_with_gravity_compensation_on_some_bodies_match_mujoco_kkt() -> None:
    """``gravcomp`` on some bodies of the community MJCF (MuJoCo applies it as a passive
    force): each link's factor read into its chain leg's ``gravcomp``, the platform's into
    ``platform_gravcomp``, IDM and DDM against MuJoCo's exact KKT."""
    xml = _with_gravcomp(community_mjcf(), GRAVCOMP)
    result = import_mjcf(xml)
    desc = result.description
    assert desc.platform_gravcomp == GRAVCOMP["platform"]
    got = {}
    for leg, source in zip(desc.chain_legs, result.report.legs, strict=True):
        for c, bodies in zip(leg.gravcomp, source.bodies, strict=True):
            if c:
                got[bodies] = float(c)
    assert got == {k: v for k, v in GRAVCOMP.items() if k != "platform"}
    assert "gravity compensation of some bodies" in str(result.report)
    robot = StewartRobot(desc)
    T, V, A = _states(robot, 3, seed=9)
    gamma_mj = matches_mujoco_kkt(xml, robot, T, V, A)
    without = StewartRobot(import_mjcf(community_mjcf()).description).inverse_dynamics(T, V, A)
    assert rel_error(without, gamma_mj) > 1e-3  # the compensation matters


def test_chain_leg_bodies_of_one_link_with_different_compensations_are_refused() -> None:
    """A body fixed in a chain leg's link with another compensation than the link's: one
    factor per link is exact only when its bodies share it, so the import refuses by name."""
    extra = (
        '<body name="sensor" gravcomp="1">'
        '<inertial pos="0 0 0.01" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/></body>'
    )
    xml = re.sub(r'(<body name="leg2_link4"[^>]*>)', r"\1" + extra, community_mjcf(), count=1)
    with pytest.raises(ModelImportError, match=r"'leg2_link4', 'sensor'.*different gravity comp"):
        import_mjcf(xml)
