# ruff: noqa: E501 (lines of XML kept whole, as they appear in the files written)
"""Hexapod SDF files written the way Gazebo users write them, for ``test_import_sdf.py``.

- :func:`gazebo_sdf`: a robot of the project (its description) as a Gazebo model: the
  base fixed to ``world``, each leg's two intersecting hinges written as one
  ``universal`` joint (the cross between them massless), the other joint a ``revolute``
  or ``prismatic`` one, and the **platform the child of six ``ball`` joints** (how SDF
  closes loops), one per leg's last link; every link frame at an odd place, joint
  frames turned about their axis, the file's poses the home configuration (every joint at
  zero there: joint zeros are not the description's), SDFormat 1.4 (poses in the model
  frame, axes in the model frame) or 1.9 (poses ``relative_to`` links and ``<frame>``
  elements, axes ``expressed_in`` frames or in the joint frame, angles in degrees).
- :func:`urdf_to_sdf`: an onshape-to-robot style URDF (``cad_models.cad_urdf``: closing
  frames, fixed extra links, ``<dynamics>``) rewritten as SDF, its closing frame pairs as
  ball joints whose child is the platform, in versions 1.4, 1.6 and 1.9, the model placed
  in a ``<world>`` at a pose: the URDF is the reference (Pinocchio's URDF parser and a KKT
  solve), independent of the SDF reader.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
from cad_models import _frames
from scipy.spatial.transform import Rotation

from stewart_pin import StewartRobot
from stewart_pin.description.inertia import transform_khalil, urdf_inertial_from_khalil


def n(x: float) -> str:
    return repr(float(x))


def v(xs) -> str:
    return " ".join(n(x) for x in np.asarray(xs, dtype=float).ravel())


def rpy_of(R: np.ndarray) -> np.ndarray:
    """Fixed-axis roll, pitch, yaw (SDFormat's and URDF's ``Rz(y) Ry(p) Rx(r)``)."""
    return Rotation.from_matrix(R).as_euler("xyz")


def pose(T: np.ndarray, relative_to: str = "", degrees: bool = False) -> str:
    attrs = f' relative_to="{relative_to}"' if relative_to else ""
    angles = rpy_of(T[:3, :3])
    if degrees:
        attrs += ' degrees="true"'
        angles = np.degrees(angles)
    return f"<pose{attrs}>{v(T[:3, 3])} {v(angles)}</pose>"


def random_pose(rng: np.random.Generator, scale: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
    T[:3, 3] = rng.uniform(-scale, scale, 3)
    return T


def about_z(rng: np.random.Generator) -> np.ndarray:
    c = rng.uniform(-math.pi, math.pi)
    T = np.eye(4)
    T[:2, :2] = [[math.cos(c), -math.sin(c)], [math.sin(c), math.cos(c)]]
    return T


def inertial(params: np.ndarray, T_link_frame: np.ndarray, rng, extra: str = "") -> str:
    """``<inertial>`` of Khalil parameters given in a frame at ``T_link_frame`` in the
    link, its inertial frame turned at random."""
    p = transform_khalil(params, T_link_frame[:3, :3], T_link_frame[:3, 3])
    m, c, I_c = urdf_inertial_from_khalil(p)
    Ri = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
    I = Ri.T @ I_c @ Ri
    Ti = np.eye(4)
    Ti[:3, :3], Ti[:3, 3] = Ri, c
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    vals = (I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2])
    tensor = "".join(f"<{k}>{n(x)}</{k}>" for k, x in zip(keys, vals, strict=True))
    return f"<inertial>{pose(Ti, extra)}<mass>{n(m)}</mass><inertia>{tensor}</inertia></inertial>"


def gazebo_sdf(
    desc,
    version: str = "1.9",
    seed: int = 0,
    gravity_off: tuple[str, ...] = (),
    base: str = "world",
    ball_dynamics: bool = False,
) -> str:
    """``desc`` (a description whose legs have two intersecting hinges with a massless
    link between them: a U-joint) as a Gazebo user's SDF (module docstring); the platform
    link's frame is the description's Fp, the file's poses its home configuration.

    ``base``: ``"world"`` (a fixed joint to the world), ``"static"`` (``<static>``) or
    ``"none"`` (neither). ``gravity_off``: links written with ``<gravity>false``."""
    rng = np.random.default_rng(seed)
    robot = StewartRobot(desc)
    g = robot.general
    F, q_home = _frames(g)
    T_home = np.asarray(g.home_pose)
    new = version != "1.4"
    out = [f'<?xml version="1.0"?>\n<sdf version="{version}">\n<world name="lab">\n']
    gravity = v(desc.gravity)
    out.append(
        f"<gravity>{gravity}</gravity>\n"
        if new
        else f"<physics type='ode'><gravity>{gravity}</gravity></physics>\n"
    )
    out.append(
        '<include><uri>model://ground_plane</uri></include>\n<model name="gazebo_hexapod">\n'
    )
    if base == "static":
        out.append("<static>true</static>\n")

    def gravity_tag(name: str) -> str:
        return "<gravity>false</gravity>" if name in gravity_off else ""

    out.append(
        f'<link name="base">{pose(np.eye(4))}<inertial><mass>5</mass><inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.2</izz></inertia></inertial></link>\n'
    )
    if base == "world":
        out.append(
            '<joint name="anchor" type="fixed"><parent>world</parent><child>base</child></joint>\n'
        )
    if new:  # a frame on the platform, for poses relative to it
        Tf = T_home @ random_pose(rng, 0.1 * g.size)
        out.append(
            f'<frame name="platform_mark" attached_to="base">{pose(Tf, "__model__")}</frame>\n'
        )
    Wp = T_home
    if new:
        out.append(
            f'<link name="platform">{pose(np.linalg.inv(Tf) @ Wp, "platform_mark", degrees=True)}'
        )
    else:
        out.append(f'<link name="platform">{pose(Wp)}')
    out.append(
        f"{inertial(desc.platform_inertia, np.eye(4), rng)}{gravity_tag('platform')}</link>\n"
    )
    P = g.platform_points @ T_home[:3, :3].T + T_home[:3, 3]
    for k, leg in enumerate(g.legs):
        kinds = [j.kind for j in leg.joints]
        # the U-joint: the two hinges whose axes meet (massless link between them)
        u = (
            0
            if kinds[:2] == ["revolute", "revolute"] and abs(math.sin(leg.joints[1].alpha)) > 0.5
            else 1
        )
        assert np.allclose(F[k, u][:3, 3], F[k, u + 1][:3, 3]), "the U axes must meet"
        assert not np.any(desc.leg_inertia[k, u]), "the U cross must be massless"
        prev, W_prev = "base", np.eye(4)
        for j in range(3):
            if j == u:
                continue  # the cross, inside the universal joint
            W = F[k, j] @ random_pose(rng, 0.2 * g.size)
            name = f"leg{k + 1}_link{j + 1}"
            if new and j > 0:
                out.append(f'<link name="{name}">{pose(np.linalg.inv(W_prev) @ W, prev)}')
            else:
                out.append(f'<link name="{name}">{pose(W)}')
            out.append(
                f"{inertial(desc.leg_inertia[k, j], np.linalg.inv(W) @ F[k, j], rng)}{gravity_tag(name)}</link>\n"
            )
            J = F[k, j - 1 if j == u + 1 else j] @ about_z(
                rng
            )  # the joint frame: z along the (first) axis
            axes = [F[k, u][:3, 2], F[k, u + 1][:3, 2]] if j == u + 1 else [F[k, j][:3, 2]]
            kind = (
                "universal"
                if j == u + 1
                else ("revolute" if kinds[j] == "revolute" else "prismatic")
            )
            jname = f"leg{k + 1}_u" if j == u + 1 else f"leg{k + 1}_q{j + 1}"
            lo, hi = leg.joints[j].lower - q_home[k, j], leg.joints[j].upper - q_home[k, j]
            out.append(
                f'<joint name="{jname}" type="{kind}"><parent>{prev}</parent><child>{name}</child>'
            )
            out.append(pose(np.linalg.inv(W) @ J))
            for a, (tag, axis) in enumerate(zip(("axis", "axis2"), axes, strict=False)):
                if version == "1.4":
                    xyz = f"<xyz>{v(axis)}</xyz>"  # the model frame
                elif (k + a) % 3 == 0:
                    xyz = f'<xyz expressed_in="__model__">{v(axis)}</xyz>'
                elif (k + a) % 3 == 1:
                    xyz = f'<xyz expressed_in="{prev}">{v(np.linalg.inv(W_prev)[:3, :3] @ axis)}</xyz>'
                else:
                    xyz = f"<xyz>{v(J[:3, :3].T @ axis)}</xyz>"  # the joint frame
                limit = ""
                if kind != "universal" and math.isfinite(lo) and math.isfinite(hi):
                    limit = f"<limit><lower>{n(lo)}</lower><upper>{n(hi)}</upper><effort>100</effort></limit>"
                terms = leg.joints[u + a if kind == "universal" else j].dynamics
                dyn = ""
                if terms.viscous or terms.coulomb:
                    dyn = f"<dynamics><damping>{n(terms.viscous)}</damping><friction>{n(terms.coulomb)}</friction></dynamics>"
                out.append(f"<{tag}>{xyz}{limit}{dyn}</{tag}>")
            out.append("</joint>\n")
            prev, W_prev = name, W
        B = np.eye(4)
        B[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
        B[:3, 3] = P[k]
        dyn = "<axis><dynamics><damping>0.5</damping></dynamics></axis>" if ball_dynamics else ""
        if new and k % 2:
            ball_pose = pose(np.linalg.inv(Tf) @ B, "platform_mark")
        else:
            ball_pose = pose(np.linalg.inv(Wp) @ B)  # in the child (platform) frame
        out.append(
            f'<joint name="leg{k + 1}_ball" type="ball"><parent>{prev}</parent><child>platform</child>{ball_pose}{dyn}</joint>\n'
        )
    out.append("</model>\n</world>\n</sdf>\n")
    return "".join(out)


# ---------------------------------------------------------------------------- URDF -> SDF
def _origin(el) -> np.ndarray:
    T = np.eye(4)
    o = el.find("origin")
    if o is not None:
        T[:3, 3] = [float(x) for x in o.get("xyz", "0 0 0").split()]
        T[:3, :3] = Rotation.from_euler(
            "xyz", [float(x) for x in o.get("rpy", "0 0 0").split()]
        ).as_matrix()
    return T


#: The model's pose in the world of :func:`urdf_to_sdf` (a turn about z: gravity stays).
MODEL_POSE = np.array(
    [[0.0, -1.0, 0.0, 0.05], [1.0, 0.0, 0.0, -0.02], [0.0, 0.0, 1.0, 0.01], [0, 0, 0, 1.0]]
)


def closed_urdf(urdf: str) -> str:
    """``urdf`` with each ``closing_<k>_2`` frame moved onto ``closing_<k>_1`` (17 digits):
    the loops closed exactly at the zero configuration (``cad_urdf`` rounds the joints'
    ``rpy`` to 1e-9 rad), so that one ball joint can stand for the pair."""
    root = ET.fromstring(urdf)
    W = _world_poses(root.findall("joint"))
    for j in root.findall("joint"):
        child = j.find("child").get("link")
        if child.startswith("closing_") and child.endswith("_2"):
            target = W[child[:-1] + "1"][:3, 3]
            parent = W[j.find("parent").get("link")]
            xyz = np.linalg.inv(parent)[:3, :3] @ target + np.linalg.inv(parent)[:3, 3]
            j.find("origin").set("xyz", v(xyz))
    return ET.tostring(root, encoding="unicode")


def _world_poses(joints) -> dict[str, np.ndarray]:
    W = {"world": np.eye(4)}
    pending = list(joints)
    while pending:
        for j in list(pending):
            parent = j.find("parent").get("link")
            if parent in W:
                W[j.find("child").get("link")] = W[parent] @ _origin(j)
                pending.remove(j)
    return W


def urdf_to_sdf(urdf: str, version: str, seed: int = 0) -> str:
    """The robot of a ``cad_urdf`` file (floating platform, ``closing_<k>_1`` /
    ``closing_<k>_2`` pairs) as SDF ``version`` (module docstring); F0 = the URDF's root
    link frame = the SDF world; the model at :data:`MODEL_POSE` in it."""
    rng = np.random.default_rng(seed)
    root = ET.fromstring(urdf)
    joints = root.findall("joint")
    W = _world_poses(joints)
    M = MODEL_POSE
    Mi = np.linalg.inv(M)
    new = version >= "1.7" or version.startswith("1.1")
    out = [f'<?xml version="1.0"?>\n<sdf version="{version}">\n<world name="w">\n']
    g = "0 0 -9.81"
    out.append(
        f"<physics type='ode'><gravity>{g}</gravity></physics>\n"
        if version == "1.4"
        else f"<gravity>{g}</gravity>\n"
    )
    out.append(f'<model name="from_urdf">{pose(M)}\n')
    parent_of = {j.find("child").get("link"): j.find("parent").get("link") for j in joints}
    for link in root.findall("link"):
        name = link.get("name")
        if name == "world" or name.startswith("closing_"):
            continue
        T = Mi @ W[name]
        p = parent_of.get(name, "world")
        if new and p not in ("world",) and not p.startswith("closing_"):
            body = pose(np.linalg.inv(W[p]) @ W[name], p, degrees=bool(rng.integers(2)))
        else:
            body = pose(T)
        ine = link.find("inertial")
        text = ""
        if ine is not None:
            Ti = _origin(ine)
            I = ine.find("inertia")
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            tensor = "".join(f"<{k}>{I.get(k)}</{k}>" for k in keys)
            text = f"<inertial>{pose(Ti)}<mass>{ine.find('mass').get('value')}</mass><inertia>{tensor}</inertia></inertial>"
        out.append(f'<link name="{name}">{body}{text}</link>\n')
    for j in joints:
        kind, name = j.get("type"), j.get("name")
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        if kind == "floating" or child.startswith("closing_"):
            continue
        text = (
            f'<joint name="{name}" type="{kind}"><parent>{parent}</parent><child>{child}</child>'
        )
        if kind in ("revolute", "prismatic"):
            axis = np.array([float(x) for x in j.find("axis").get("xyz").split()])
            R = W[child][:3, :3]  # the URDF joint frame is the child link's
            Jf = np.eye(4)
            Jf[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            text += pose(Jf)  # the joint frame, turned in the child link
            if version == "1.4":
                xyz = f"<xyz>{v(Mi[:3, :3] @ R @ axis)}</xyz>"
            elif version in ("1.5", "1.6"):
                if rng.integers(2):
                    xyz = f"<xyz>{v(Mi[:3, :3] @ R @ axis)}</xyz><use_parent_model_frame>true</use_parent_model_frame>"
                else:
                    xyz = f"<xyz>{v(Jf[:3, :3].T @ axis)}</xyz>"
            else:
                xyz = (
                    f'<xyz expressed_in="{child}">{v(axis)}</xyz>'
                    if rng.integers(2)
                    else f"<xyz>{v(Jf[:3, :3].T @ axis)}</xyz>"
                )
            lim = j.find("limit")
            dyn = j.find("dynamics")
            text += (
                f"<axis>{xyz}<limit><lower>{lim.get('lower')}</lower><upper>{lim.get('upper')}</upper></limit>"
                f"<dynamics><damping>{dyn.get('damping')}</damping><friction>{dyn.get('friction')}</friction></dynamics></axis>"
            )
        out.append(text + "</joint>\n")
    # the closing frame pairs: ball joints whose child is the platform
    for link in root.findall("link"):
        name = link.get("name")
        if name.startswith("closing_") and name.endswith("_1"):
            k = name.split("_")[1]
            other = f"closing_{k}_2"
            B = np.eye(4)
            B[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            B[:3, 3] = W[other][:3, 3]
            rel = np.linalg.inv(W[parent_of[other]]) @ B
            out.append(
                f'<joint name="ball_{k}" type="ball"><parent>{parent_of[name]}</parent>'
                f"<child>{parent_of[other]}</child>{pose(rel)}</joint>\n"
            )
    out.append("</model>\n</world>\n</sdf>\n")
    return "".join(out)
