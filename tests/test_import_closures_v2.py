"""URDF loop closures of every kind: the sidecar's version 2 (issue 21, item 2).

Files: onshape-to-robot style URDFs (``cad_models.cad_urdf``) with their loops given by a
version-2 sidecar (a file or the same content as a dict): point closures between the
closing frames; or each leg ending in a rod end (three hinges through one point with
massless links between them, then a rod-end link with mass) welded to the platform at
the rod end's ``<inertial>`` frame (PyBullet's ``createConstraint`` convention).

Independent reference: Pinocchio's own parser of the URDF with the closures as hard
constraints (3 rows per point, 6 per weld: the two frames' velocities in
LOCAL_WORLD_ALIGNED, their classical accelerations for the drift), an exact KKT solve
(``test_import_urdf.PinReference``, extended here by the weld rows).
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from cad_models import cad_urdf
from helpers import rel_error
from scipy.spatial.transform import Rotation
from test_import_mjcf import states
from test_import_urdf import ARMATURE, PinReference, check_against_pinocchio, pairs_of

from stewart_pin import (
    FileFormatError,
    ModelImportError,
    StewartRobot,
)
from stewart_pin.description.leg_chain_presets import random_hexapod
from stewart_pin.importers import import_urdf

pytest.importorskip("yourdfpy")
pytestmark = pytest.mark.filterwarnings("ignore::stewart_pin.ModelImportWarning")

RANGES = (0.02, 0.05)


def _robot():
    return random_hexapod("ups", 1)


def _write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def point_sidecar(**extra) -> dict:
    """A version-2 sidecar closing the six loops at the closing frames."""
    closures = [
        {"name": f"loop{k}", "type": "point", "link1": a, "point1": [0, 0, 0], "link2": b,
         "point2": [0.0, 0.0, 0.0]}
        for k, (a, b) in enumerate(pairs_of(), start=1)
    ]  # fmt: skip
    return {"format": "stewart-pin/closures", "version": 2, "closures": closures, **extra}


@pytest.mark.parametrize("as_dict", [True, False])
def test_point_closures_of_a_version_2_sidecar_match_pinocchio_kkt(tmp_path, as_dict):
    """Point closures, ``platform``, by file or as a dict: the file's dynamics (KKT)."""
    path = _write(tmp_path, cad_urdf(_robot(), "floating", seed=1))
    data = point_sidecar(platform="platform", urdf="robot.urdf", description="six balls")
    if as_dict:
        closures = data
    else:
        closures = tmp_path / "loops.json"
        closures.write_text(json.dumps(data))
    robot = StewartRobot.from_urdf(path, closures=closures, armature=ARMATURE)
    assert robot.description.source.platform == "platform"
    check_against_pinocchio(path, robot, RANGES, pairs_of())


# --- welds at the rod ends' centre-of-mass frames ---------------------------------------------


def rod_end_urdf(text: str) -> tuple[str, list[np.ndarray]]:
    """``text`` (a floating-platform ``cad_urdf``) with each closing frame ``closing_k_1``
    carrying three hinges (x, y, z) through its origin, massless links between them, and a
    rod end ``rod_k`` (80 g, a rotated ``<inertial>`` frame); returns the text and each rod
    end's inertial frame in its link (4x4)."""
    root = ET.fromstring(text)
    frames = []
    for k in range(1, 7):
        parent = f"closing_{k}_1"
        for axis, child in (
            ("1 0 0", f"rod_{k}_a"),
            ("0 1 0", f"rod_{k}_b"),
            ("0 0 1", f"rod_{k}"),
        ):
            ET.SubElement(root, "link", name=child)
            joint = ET.SubElement(root, "joint", name=f"{child}_hinge", type="continuous")
            ET.SubElement(joint, "parent", link=parent)
            ET.SubElement(joint, "child", link=child)
            ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")
            ET.SubElement(joint, "axis", xyz=axis)
            parent = child
        link = root.find(f"link[@name='rod_{k}']")
        inertial = ET.SubElement(link, "inertial")
        xyz, rpy = np.array([0.004, -0.002, 0.003]) * k, np.array([0.3, -0.2, 0.1 * k])
        ET.SubElement(inertial, "origin", xyz=" ".join(map(str, xyz)), rpy=" ".join(map(str, rpy)))
        ET.SubElement(inertial, "mass", value="0.08")
        ET.SubElement(inertial, "inertia", ixx="2e-5", ixy="0", ixz="0", iyy="3e-5", iyz="0",
                      izz="4e-5")  # fmt: skip
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = Rotation.from_euler("xyz", rpy).as_matrix(), xyz
        frames.append(T)
    return ET.tostring(root, encoding="unicode"), frames


def weld_sidecar(path, inertial_frames) -> dict:
    """Welds of each rod end's inertial frame (``"inertial"``) to the platform, at the
    pose that frame has at the file's zero configuration (its home: the hinges at 0),
    computed by Pinocchio."""
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    Tp = data.oMf[model.getFrameId("platform")].homogeneous
    closures = []
    for k, F in enumerate(inertial_frames, start=1):
        T = np.linalg.inv(Tp) @ data.oMf[model.getFrameId(f"rod_{k}")].homogeneous @ F
        frame2 = {
            "xyz": T[:3, 3].tolist(),
            "rpy": Rotation.from_matrix(T[:3, :3]).as_euler("xyz").tolist(),
        }
        closures.append({"name": f"weld{k}", "type": "weld", "link1": f"rod_{k}",
                         "frame1": "inertial", "link2": "platform", "frame2": frame2})  # fmt: skip
    return {"format": "stewart-pin/closures", "version": 2, "closures": closures,
            "platform": "platform"}  # fmt: skip


class WeldReference(PinReference):
    """:class:`PinReference` with weld closures: 6 rows each, frame ``a`` (the rod end's
    inertial frame) held on frame ``b`` (in the platform)."""

    def __init__(self, path, welds, armature):
        super().__init__(path, [], armature)
        self.welds = []
        for name, link_a, F_a, link_b, F_b in welds:
            ids = []
            for suffix, link, F in (("a", link_a, F_a), ("b", link_b, F_b)):
                parent = self.model.frames[self.model.getFrameId(link)]
                frame = pin.Frame(
                    f"{name}_{suffix}",
                    parent.parentJoint,
                    self.model.getFrameId(link),
                    parent.placement * pin.SE3(F),
                    pin.FrameType.OP_FRAME,
                )
                ids.append(self.model.addFrame(frame))
            self.welds.append(tuple(ids))
        self.data = self.model.createData()

    def _rows(self, q):
        m, d = self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        J = [pin.getFrameJacobian(m, d, a, frame) - pin.getFrameJacobian(m, d, b, frame)
             for a, b in self.welds]  # fmt: skip
        return np.vstack(J), pin.getFrameJacobian(m, d, self.platform, frame)

    def _loop_residuals(self):
        d, r = self.data, []
        for a, b in self.welds:
            Ma, Mb = d.oMf[a], d.oMf[b]
            r += [Ma.translation - Mb.translation, pin.log3(Ma.rotation @ Mb.rotation.T)]
        return np.concatenate(r)

    def _bias(self, q, v):
        m, d = self.model, self.data
        c = pin.rnea(m, d, q, v, np.zeros(m.nv)) + m.damping * v
        c += m.friction * np.sign(v) * (np.abs(v) > 1e-12)
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        pin.updateFramePlacements(m, d)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        acc = lambda f: pin.getFrameClassicalAcceleration(m, d, f, frame)  # noqa: E731
        drift = np.concatenate(
            [np.r_[acc(a).linear - acc(b).linear, acc(a).angular - acc(b).angular]
             for a, b in self.welds]
        )  # fmt: skip
        a_p = acc(self.platform)
        return c, drift, np.r_[a_p.linear, a_p.angular]


def test_welds_at_the_rod_ends_inertial_frames_match_pinocchio_kkt(tmp_path):
    """Rod ends on three hinges, welded to the platform at their ``<inertial>`` frames
    (``"inertial"``): the hinges are the spherical joint, each rod end part of the
    platform; the file's dynamics to 1e-10 (a weld could not be described before)."""
    text, frames = rod_end_urdf(cad_urdf(_robot(), "floating", seed=1))
    path = _write(tmp_path, text)
    sidecar = weld_sidecar(path, frames)
    robot = StewartRobot.from_urdf(path, closures=sidecar, armature=ARMATURE)
    assert robot.description.architecture == "custom"  # the file's rounding: no exact U-P-S
    welds = []
    for c in sidecar["closures"]:
        F2 = np.eye(4)
        F2[:3, :3] = Rotation.from_euler("xyz", c["frame2"]["rpy"]).as_matrix()
        F2[:3, 3] = c["frame2"]["xyz"]
        welds.append((c["name"], c["link1"], frames[int(c["name"][4:]) - 1], "platform", F2))
    ref = WeldReference(path, welds, ARMATURE)
    for T, V, A in states(robot, RANGES, 3, seed=3):
        q, v = ref.closed_state(T, V)
        gamma_ref = ref.kkt(q, v, A=A)
        gamma = robot.inverse_dynamics(T, V, A, motor=True)
        assert rel_error(gamma, gamma_ref) < 1e-10, f"IDM {rel_error(gamma, gamma_ref):.2e}"
    report = str(import_urdf(path, closures=sidecar, armature=ARMATURE).report)
    assert "hinges 'rod_1_a_hinge', 'rod_1_b_hinge', 'rod_1_hinge'" in report


def test_a_weld_where_the_leg_needs_a_spherical_joint_is_refused(tmp_path):
    """Legs of three joints closed by welds at the closing frames (no spherical joint
    left) are read as chain legs and refused for their mobility: a weld's six constraints
    leave the platform three freedoms short, named with the weld and the joints."""
    path = _write(tmp_path, cad_urdf(_robot(), "floating", seed=1))
    data = point_sidecar()
    for c in data["closures"]:
        c.update(type="weld", frame1={"xyz": [0, 0, 0]}, frame2={"rpy": [0, 0, 0]})
        del c["point1"], c["point2"]
    with pytest.raises(ModelImportError, match="leaves the platform 3 freedom") as e:
        import_urdf(path, closures=data)
    assert "weld 'loop" in str(e.value) and len(e.value.joints) == 3


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda d: d.update(extra=1), "unknown key\\(s\\) 'extra'"),
        (lambda d: d["closures"][2].update(radius=1), "closure 3 \\('loop3'\\): unknown key"),
        (lambda d: d["closures"][0].update(type="ball"), "'type' must be 'point' or 'weld'"),
        (lambda d: d["closures"][0].update(point1=[0, 0, math.nan]), "'point1' must be 3 finite"),
        (lambda d: d["closures"][0].update(point2=[0, 0]), "'point2' must be 3 finite"),
        (lambda d: d["closures"][1].update(link1=3), "'link1' must be a link name"),
        (lambda d: d.update(platform=["platform"]), "'platform' must be a string"),
        (lambda d: d.update(closures=[]), "'closures' must be a non-empty list"),
        (lambda d: d["closures"][0].update(type="weld"), "closure 1 \\('loop1'\\): unknown key"),
        (lambda d: d.update(home_joint_positions={"nope": 0.1}), "names no joint 'nope'"),
        (lambda d: d.update(home_pose=np.diag([1.0, 2.0, 1.0, 1.0]).tolist()), "rigid transform"),
    ],
)  # fmt: skip
def test_version_2_sidecars_are_checked_strictly(tmp_path, change, match):
    """Unknown keys, wrong types, NaN: a FileFormatError naming the key and closure."""
    path = _write(tmp_path, cad_urdf(_robot(), "floating", seed=1))
    data = point_sidecar()
    change(data)
    with pytest.raises(FileFormatError, match=match):
        import_urdf(path, closures=data)
    sidecar = tmp_path / "robot.closures.json"  # the same from the file beside the URDF
    sidecar.write_text(json.dumps(data))
    with pytest.raises(FileFormatError, match=match):
        import_urdf(path)


def test_weld_frames_are_checked(tmp_path):
    path = _write(tmp_path, cad_urdf(_robot(), "floating", seed=1))
    data = point_sidecar()
    c = data["closures"][0]
    del c["point1"], c["point2"]
    c.update(type="weld", frame1={"xyz": [0, 0, 0], "rpy": [0, math.inf, 0]}, frame2="inertial")
    with pytest.raises(FileFormatError, match="'frame1' 'rpy' must be 3 finite numbers"):
        import_urdf(path, closures=data)
    c.update(frame1={"xyz": [0, 0, 0], "quat": [1, 0, 0, 0]})
    with pytest.raises(FileFormatError, match="'frame1': unknown key\\(s\\) 'quat'"):
        import_urdf(path, closures=data)


def test_home_pose_of_a_platform_hanging_in_the_tree_is_checked(tmp_path):
    """A platform hanging from leg 1 (three hinges): ``home_joint_positions`` place it,
    ``home_pose`` must agree (else a ModelImportError with the distance)."""
    path = _write(tmp_path, cad_urdf(_robot(), "tree-hinges", seed=1))
    data = point_sidecar()
    data["closures"] = data["closures"][1:]
    home = StewartRobot.from_urdf(path, closures=data).home_pose
    data["home_pose"] = home.tolist()
    assert np.allclose(StewartRobot.from_urdf(path, closures=data).home_pose, home, atol=1e-12)
    data["home_pose"][2][3] += 0.05
    with pytest.raises(ModelImportError, match=r"home_pose is 0.05 m and [0-9.e-]+ rad from"):
        import_urdf(path, closures=data)
