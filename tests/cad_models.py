# ruff: noqa: E501 (lines of XML kept whole, as they appear in the files written)
"""Hexapod MJCF files written the way CAD exports and hand-written models look, for the
import tests: body frames at odd angles to the joint axes, numbers rounded to a few
digits, orientations as ``euler`` (degrees), ``axisangle``, ``xyaxes`` and ``quat``,
joint terms from classes and defaults, inertias as ``fullinertia`` or computed by MuJoCo
from geoms (``inertiafromgeom``), extra bodies fixed to the base, a leg and the platform,
hinge ``ref`` values, actuators of several kinds in shuffled order.

The geometry comes from a robot of the project (a preset or a random general robot) at its
home pose: every body is placed there (the file's zero configuration is the assembled
one), each link's inertia is that robot's. Rounding opens the loops by ~1e-5 m: the file
is its own robot, and the tests compare the import with MuJoCo's model of the same file,
never with the robot the geometry came from.

Conventions (``loops``):

- ``connect-site``: a free platform, six ``<connect site1 site2>``;
- ``connect-body``: a free platform, six ``<connect body1 body2 anchor>``;
- ``weld-ball``: a free platform; each rod carries a rod-end body with a ``ball`` joint,
  welded to the platform;
- ``weld-hinges``: the same with three hinges in the rod-end body for the ball;
- ``weld-hinge-bodies``: three hinges with (nearly) massless bodies between them;
- ``tree-ball``: the platform inside the tree, hanging from leg 1 through a ``ball``, the
  other legs closed by connects;
- ``tree-hinges``: the same through three hinges on the platform body.

S-S legs (:func:`ss_mjcf`): ``rss`` (crank, ball at its tip, rod, connect), ``pss``
(slide, ball, rod, connect), ``sps`` (ball at the base, cylinder, slide along the leg,
piston, connect); rods symmetric about their axis unless ``asymmetric``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from stewart_pin.description.inertia import transform_khalil, urdf_inertial_from_khalil
from stewart_pin.kinematics.leg_chains import inverse_geometry

LOOPS = (
    "connect-site",
    "connect-body",
    "weld-ball",
    "weld-hinges",
    "weld-hinge-bodies",
    "tree-ball",
    "tree-hinges",
)


class Writer:
    """Text of the bodies, rounded."""

    def __init__(self, rng: np.random.Generator, digits: int = 5):
        self.rng = rng
        self.digits = digits
        self.style = 0

    def n(self, x: float) -> str:
        v = round(float(x), self.digits)
        return "0" if v == 0 else f"{v:.{self.digits}f}".rstrip("0").rstrip(".")

    def v(self, xs) -> str:
        return " ".join(self.n(x) for x in xs)

    def g(self, x: float, sig: int = 6) -> str:
        return f"{float(x):.{sig}g}"

    def orientation(self, R: np.ndarray) -> str:
        """One of MuJoCo's orientation forms, in turn."""
        self.style += 1
        rot = Rotation.from_matrix(R)
        k = self.style % 4
        if k == 0:
            q = rot.as_quat(scalar_first=True)
            return f'quat="{" ".join(f"{x:.6f}" for x in q)}"'
        if k == 1:
            e = rot.as_euler("XYZ", degrees=True)  # MuJoCo's default eulerseq "xyz"
            return f'euler="{" ".join(f"{x:.4f}" for x in e)}"'
        if k == 2:
            rv = rot.as_rotvec()
            angle = float(np.linalg.norm(rv))
            axis = rv / angle if angle > 0 else np.array([0.0, 0.0, 1.0])
            return f'axisangle="{" ".join(f"{x:.6f}" for x in axis)} {math.degrees(angle):.4f}"'
        return f'xyaxes="{" ".join(f"{x:.6f}" for x in np.r_[R[:, 0], R[:, 1]])}"'

    def odd(self, scale: float) -> np.ndarray:
        """A random offset: the body frame away from the joint frame."""
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=int(self.rng.integers(1 << 30))).as_matrix()
        T[:3, 3] = self.rng.uniform(-scale, scale, 3)
        return T

    def aligned(self, scale: float) -> np.ndarray:
        """A random offset turning about z only."""
        T = np.eye(4)
        c = self.rng.uniform(-math.pi, math.pi)
        T[:2, :2] = [[math.cos(c), -math.sin(c)], [math.sin(c), math.cos(c)]]
        T[:3, 3] = self.rng.uniform(-scale, scale, 3)
        return T

    def inertial(self, params: np.ndarray, T_body_frame: np.ndarray) -> str:
        """``<inertial>`` of Khalil parameters given in a frame placed at ``T_body_frame``
        in the body."""
        p = transform_khalil(params, T_body_frame[:3, :3], T_body_frame[:3, 3])
        m, c, I = urdf_inertial_from_khalil(p)
        full = (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
        return (
            f'<inertial pos="{self.v(c)}" mass="{self.g(m)}" '
            f'fullinertia="{" ".join(self.g(x, 7) for x in full)}"/>'
        )


def _frames(robot, pose=None):
    """Frames 1i..3i of every leg in F0 at the home configuration, (6, 3, 4, 4), and the
    legs' home joint values."""
    T = robot.home_pose if pose is None else pose
    q = inverse_geometry(robot, T, check_limits=False)
    out = np.empty((6, 3, 4, 4))
    for k, leg in enumerate(robot.legs):
        T0 = np.eye(4)
        T0[:3, :3], T0[:3, 3] = robot.leg_base_rotations[k], robot.base_points[k]
        out[k] = leg.transforms(q[k], T0)
    return out, q


def _rel(W_parent: np.ndarray, W: np.ndarray) -> np.ndarray:
    return np.linalg.inv(W_parent) @ W


HEADER = """<mujoco model="{name}">
  <compiler angle="degree" autolimits="true"/>
  <option gravity="{gravity}"/>
  <default>
    <geom contype="0" conaffinity="0" density="800"/>
    <joint damping="{passive_damping}"/>
    <default class="actuated">
      <joint armature="{armature}" damping="{damping}" frictionloss="{friction}"/>
    </default>
    <default class="passive">
      <joint stiffness="{stiffness}" springref="{springref}"/>
    </default>
  </default>
  <worldbody>
    <body name="floor_plate" pos="0 0 -0.01">
      <geom type="box" size="0.3 0.3 0.005" density="2700"/>
    </body>
"""


def _joint_attrs(
    w: Writer,
    kind: str,
    W_body: np.ndarray,
    frame: np.ndarray,
    name: str,
    cls: str,
    extra: str = "",
) -> str:
    """A hinge or slide about z of ``frame`` (F0), written in the body at ``W_body``."""
    T = np.linalg.inv(W_body) @ frame
    jt = "hinge" if kind == "revolute" else "slide"
    return (
        f'<joint name="{name}" class="{cls}" type="{jt}" pos="{w.v(T[:3, 3])}" '
        f'axis="{w.v(T[:3, 2])}"{extra}/>'
    )


def cad_mjcf(
    robot,
    loops: str,
    seed: int = 0,
    digits: int = 5,
    terms: bool = True,
    gravity=(0.0, 0.0, -9.81),
    reference_keyframe: bool = False,
) -> str:
    """A CAD-like MJCF of ``robot`` (a ``GeneralHexapod``) with the loop convention
    ``loops`` (module docstring)."""
    assert loops in LOOPS
    rng = np.random.default_rng(seed)
    w = Writer(rng, digits)
    F, _ = _frames(robot)
    s = max(robot.size, 0.02)
    order = rng.permutation(6)
    text = [
        HEADER.format(
            name=f"cad-{loops}",
            gravity=w.v(gravity),
            passive_damping="0.0013" if terms else "0",
            armature="0.0021" if terms else "0",
            damping="0.037" if terms else "0",
            friction="0.011" if terms else "0",
            stiffness="0.21" if terms else "0",
            springref="3" if terms else "0",
        )
    ]
    base = np.eye(4)
    base[:3, 3] = (0.0, 0.0, 0.0)
    text.append(f'    <body name="base" {w.orientation(np.eye(3))}>\n')
    text.append('      <geom type="cylinder" size="0.12 0.004" density="2000"/>\n')
    T_home = np.asarray(robot.home_pose)
    Wp = T_home @ w.odd(0.2 * s)
    rods: list[np.ndarray] = []
    tips: list[np.ndarray] = []
    for k in range(6):
        leg = robot.legs[k]
        W_prev = base
        indent = "      "
        closes = []
        parallel = [abs(math.sin(leg.joints[n].alpha)) < 1e-12 for n in (1, 2)]
        for j in range(3):
            frame = F[k, j]
            if (j < 2 and parallel[j]) or (j > 0 and parallel[j - 1]):
                # a body on one of two parallel axes: its z along the axis, so that the
                # rounded file keeps them parallel (as a CAD export placing joint frames)
                W = frame @ w.aligned(0.3 * s)
            else:
                W = frame @ w.odd(0.3 * s)
            rel = _rel(W_prev, W)
            name = f"leg{k + 1}_b{j + 1}"
            text.append(
                f'{indent}<body name="{name}" pos="{w.v(rel[:3, 3])}" {w.orientation(rel[:3, :3])}>\n'
            )
            indent += "  "
            cls = "actuated" if j + 1 == leg.actuated else "passive"
            extra = ""
            if j + 1 == leg.actuated and leg.joints[j].revolute:
                extra = ' range="-70 70"' + (' ref="7"' if k % 2 == 0 else "")
            elif j + 1 == leg.actuated:
                extra = ' range="-0.08 0.08"'
            text.append(
                indent
                + _joint_attrs(w, leg.joints[j].kind, W, frame, f"leg{k + 1}_j{j + 1}", cls, extra)
                + "\n"
            )
            # the link's inertia (Khalil, in its MDH frame) in the body
            T_body_frame = np.linalg.inv(W) @ frame
            if j == 0 and k == 1:
                # an extra body fixed to link 1 (a motor housing), lumped
                text.append(
                    f'{indent}<geom type="box" size="0.01 0.006 0.004" pos="{w.v(T_body_frame[:3, 3])}"/>\n'
                )
            text.append(indent + w.inertial(robot.leg_inertia[k, j], T_body_frame) + "\n")
            if j == 0:
                text.append(
                    f'{indent}<body name="leg{k + 1}_housing" pos="{w.v(w.rng.uniform(-0.01, 0.01, 3))}">\n'
                )
                text.append(f'{indent}  <geom type="sphere" size="0.006" density="1500"/>\n')
                text.append(f"{indent}</body>\n")
            W_prev = W
            closes.append("</body>")
        rods.append(W_prev)
        tip = F[k, 2][:3, :3] @ leg.tip + F[k, 2][:3, 3]
        tips.append(tip)
        tip_in_rod = np.linalg.inv(W_prev) @ np.r_[tip, 1.0]
        if loops == "connect-site" or (loops.startswith("tree") and k != 0):
            text.append(f'{indent}<site name="rod{k + 1}_tip" pos="{w.v(tip_in_rod[:3])}"/>\n')
        elif loops.startswith("weld"):
            We = np.eye(4)
            We[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            We[:3, 3] = tip
            rel = _rel(W_prev, We)
            text.append(
                f'{indent}<body name="rod{k + 1}_end" pos="{w.v(rel[:3, 3])}" {w.orientation(rel[:3, :3])}>\n'
            )
            if loops == "weld-ball":
                text.append(f'{indent}  <joint name="ball{k + 1}" type="ball" damping="0"/>\n')
                text.append(f'{indent}  <geom type="sphere" size="0.004" density="7800"/>\n')
            elif loops == "weld-hinges":
                A = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
                for h in range(3):
                    text.append(
                        f'{indent}  <joint name="s{k + 1}_{"xyz"[h]}" type="hinge" axis="{w.v(A[:, h])}" damping="0"/>\n'
                    )
                text.append(f'{indent}  <geom type="sphere" size="0.004" density="7800"/>\n')
            else:  # weld-hinge-bodies
                A = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
                text.append(
                    f'{indent}  <inertial pos="0 0 0" mass="1e-12" diaginertia="1e-14 1e-14 1e-14"/>\n'
                )
                text.append(
                    f'{indent}  <joint name="s{k + 1}_x" type="hinge" axis="{w.v(A[:, 0])}" damping="0"/>\n'
                )
                text.append(f'{indent}  <body name="rod{k + 1}_cross">\n')
                text.append(
                    f'{indent}    <inertial pos="0 0 0" mass="1e-12" diaginertia="1e-14 1e-14 1e-14"/>\n'
                )
                text.append(
                    f'{indent}    <joint name="s{k + 1}_y" type="hinge" axis="{w.v(A[:, 1])}" damping="0"/>\n'
                )
                text.append(f'{indent}    <body name="rod{k + 1}_socket">\n')
                text.append(
                    f'{indent}      <joint name="s{k + 1}_z" type="hinge" axis="{w.v(A[:, 2])}" damping="0"/>\n'
                )
                text.append(f'{indent}      <geom type="sphere" size="0.004" density="7800"/>\n')
                text.append(f"{indent}    </body>\n{indent}  </body>\n")
            text.append(f"{indent}</body>\n")
        if loops.startswith("tree") and k == 0:
            rel = _rel(W_prev, Wp)
            tip_in_p = np.linalg.inv(Wp) @ np.r_[tip, 1.0]
            text.append(
                f'{indent}<body name="platform" pos="{w.v(rel[:3, 3])}" {w.orientation(rel[:3, :3])}>\n'
            )
            if loops == "tree-ball":
                text.append(
                    f'{indent}  <joint name="ball1" type="ball" pos="{w.v(tip_in_p[:3])}" damping="0"/>\n'
                )
            else:
                A = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
                for h in range(3):
                    text.append(
                        f'{indent}  <joint name="s1_{"xyz"[h]}" type="hinge" pos="{w.v(tip_in_p[:3])}" axis="{w.v(A[:, h])}" damping="0"/>\n'
                    )
            text.extend(_platform_contents(w, robot, Wp, indent + "  ", loops, tips_later=True))
            text.append(f"{indent}</body>\n")
        for c in reversed(closes):
            indent = indent[:-2]
            text.append(f"{indent}{c}\n")
    text.append("    </body>\n")
    if not loops.startswith("tree"):
        text.append(
            f'    <body name="platform" pos="{w.v(Wp[:3, 3])}" {w.orientation(Wp[:3, :3])}>\n'
        )
        text.append('      <freejoint name="platform_free"/>\n')
        text.extend(_platform_contents(w, robot, Wp, "      ", loops))
        text.append("    </body>\n")
    text.append("  </worldbody>\n  <equality>\n")
    for k in range(6):
        if loops == "connect-site" or (loops.startswith("tree") and k != 0):
            text.append(
                f'    <connect name="loop{k + 1}" site1="rod{k + 1}_tip" site2="plate_p{k + 1}"/>\n'
            )
        elif loops == "connect-body":
            tip_in_rod = np.linalg.inv(rods[k]) @ np.r_[tips[k], 1.0]
            text.append(
                f'    <connect name="loop{k + 1}" body1="leg{k + 1}_b3" body2="platform" anchor="{w.v(tip_in_rod[:3])}"/>\n'
            )
        elif loops.startswith("weld"):
            end = f"rod{k + 1}_socket" if loops == "weld-hinge-bodies" else f"rod{k + 1}_end"
            text.append(f'    <weld name="loop{k + 1}" body1="platform" body2="{end}"/>\n')
    text.append("  </equality>\n  <actuator>\n")
    kinds = ("motor", "position", "general", "motor", "velocity", "motor")
    for n, k in enumerate(order):
        leg = robot.legs[k]
        joint = f"leg{k + 1}_j{leg.actuated}"
        gear = ("", ' gear="50"', "", ' gear="2.5"', ' gear="120"', "")[n]
        extra = {"position": ' kp="3"', "velocity": ' kv="0.5"', "general": ' gainprm="1"'}.get(
            kinds[n], ""
        )
        text.append(f'    <{kinds[n]} name="act{n + 1}" joint="{joint}"{gear}{extra}/>\n')
    text.append("  </actuator>\n</mujoco>\n")
    return "".join(text)


def _platform_contents(
    w: Writer, robot, Wp: np.ndarray, indent: str, loops: str, tips_later: bool = False
) -> list[str]:
    T_home = np.asarray(robot.home_pose)
    T_body_Fp = np.linalg.inv(Wp) @ T_home
    out = [indent + w.inertial(robot.platform_inertia, T_body_Fp) + "\n"]
    out.append(
        f'{indent}<body name="camera" pos="{w.v(w.rng.uniform(-0.02, 0.02, 3))}" {w.orientation(np.eye(3))}>\n'
    )
    out.append(f'{indent}  <geom type="box" size="0.015 0.01 0.008" density="1200"/>\n')
    out.append(f"{indent}</body>\n")
    P = robot.platform_points @ T_home[:3, :3].T + T_home[:3, 3]
    for k in range(6):
        p = np.linalg.inv(Wp) @ np.r_[P[k], 1.0]
        out.append(f'{indent}<site name="plate_p{k + 1}" pos="{w.v(p[:3])}"/>\n')
    return out


# ------------------------------------------------------------------------------ S-S legs
def _symmetric_rod(
    w: Writer, mass: float, radius: float, length: float, start: float, asymmetric: bool
) -> str:
    """A solid cylinder along z from ``start`` (body frame on the axis)."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    off = 0.004 if asymmetric else 0.0  # a centre of mass off the axis
    return (
        f'<inertial pos="{w.n(off)} 0 {w.n(start + length / 2)}" mass="{w.g(mass)}" '
        f'diaginertia="{w.g(transverse)} {w.g(transverse)} {w.g(axial)}"/>'
    )


def _frame_z(z: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    z = z / np.linalg.norm(z)
    a = rng.normal(size=3)
    x = a - (a @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def ss_mjcf(
    robot,
    kind: str,
    seed: int = 0,
    digits: int = 5,
    asymmetric: bool = False,
    connect: bool = True,
) -> str:
    """A CAD-like MJCF of legs with a rod between two spherical joints: ``rss`` (from a
    ``rus`` robot: crank, ball at the crank tip, rod), ``pss`` (from a ``pus`` robot: slide,
    ball, rod), ``sps`` (from a ``ups`` robot: ball at B_i, cylinder, slide, piston). The
    platform is free, closed by connects (``connect``) or held in the tree by leg 1's ball
    (``connect=False``)."""
    rng = np.random.default_rng(seed)
    w = Writer(rng, digits)
    F, _ = _frames(robot)
    s = max(robot.size, 0.02)
    T_home = np.asarray(robot.home_pose)
    P = robot.platform_points @ T_home[:3, :3].T + T_home[:3, 3]
    Wp = T_home @ w.odd(0.2 * s)
    text = [
        HEADER.format(
            name=f"cad-{kind}",
            gravity="0 0 -9.81",
            passive_damping="0",
            armature="0.0031",
            damping="0.041",
            friction="0.013",
            stiffness="0",
            springref="0",
        )
    ]
    text.append('    <body name="base">\n')
    for k in range(6):
        leg = robot.legs[k]
        i = k + 1
        ind = "      "
        if kind in ("rss", "pss"):
            frame = F[k, 0]
            W1 = frame @ w.odd(0.3 * s)
            text.append(
                f'{ind}<body name="leg{i}_b1" pos="{w.v(W1[:3, 3])}" {w.orientation(W1[:3, :3])}>\n'
            )
            text.append(
                ind
                + "  "
                + _joint_attrs(w, leg.joints[0].kind, W1, frame, f"leg{i}_j1", "actuated")
                + "\n"
            )
            T_body_frame = np.linalg.inv(W1) @ frame
            text.append(ind + "  " + w.inertial(robot.leg_inertia[k, 0], T_body_frame) + "\n")
            C = F[k, 2][:3, 3]  # the U-joint centre: origin of frames 2 and 3
            Wr = np.eye(4)
            Wr[:3, :3] = _frame_z(P[k] - C, rng)
            Wr[:3, 3] = C
            rel = _rel(W1, Wr)
            L = float(np.linalg.norm(P[k] - C))
            text.append(
                f'{ind}  <body name="leg{i}_rod" pos="{w.v(rel[:3, 3])}" {w.orientation(rel[:3, :3])}>\n'
            )
            text.append(f'{ind}    <joint name="ball{i}" type="ball" damping="0"/>\n')
            text.append(
                f"{ind}    {_symmetric_rod(w, 0.02, 0.003, L, 0.0, asymmetric and k == 2)}\n"
            )
            if connect or k != 0:
                text.append(f'{ind}    <site name="rod{i}_tip" pos="0 0 {w.n(L)}"/>\n')
            else:
                text.extend(_tree_platform(w, robot, Wr, Wp, L, ind + "    "))
            text.append(f"{ind}  </body>\n{ind}</body>\n")
        else:  # sps: ball at B_i (the U centre), cylinder, slide along the leg, piston
            B = F[k, 0][:3, 3]
            Wc = np.eye(4)
            Wc[:3, :3] = _frame_z(P[k] - B, rng)
            Wc[:3, 3] = B
            L = float(np.linalg.norm(P[k] - B))
            text.append(
                f'{ind}<body name="leg{i}_cylinder" pos="{w.v(B)}" {w.orientation(Wc[:3, :3])}>\n'
            )
            text.append(f'{ind}  <joint name="ball{i}" type="ball" damping="0"/>\n')
            text.append(
                f"{ind}  {_symmetric_rod(w, 1.5, 0.03, 0.5 * L, 0.0, asymmetric and k == 2)}\n"
            )
            text.append(f'{ind}  <body name="leg{i}_piston">\n')
            text.append(
                f'{ind}    <joint name="leg{i}_j3" class="actuated" type="slide" axis="0 0 1" range="-0.1 0.1"/>\n'
            )
            text.append(f"{ind}    {_symmetric_rod(w, 0.8, 0.015, 0.6 * L, 0.4 * L, False)}\n")
            if connect or k != 0:
                text.append(f'{ind}    <site name="rod{i}_tip" pos="0 0 {w.n(L)}"/>\n')
            else:
                text.extend(_tree_platform(w, robot, Wc, Wp, L, ind + "    "))
            text.append(f"{ind}  </body>\n{ind}</body>\n")
    text.append("    </body>\n")
    if connect:
        text.append(
            f'    <body name="platform" pos="{w.v(Wp[:3, 3])}" {w.orientation(Wp[:3, :3])}>\n'
        )
        text.append("      <freejoint/>\n")
        text.extend(_platform_contents(w, robot, Wp, "      ", "ss"))
        text.append("    </body>\n")
    text.append("  </worldbody>\n  <equality>\n")
    for k in range(0 if connect else 1, 6):
        text.append(
            f'    <connect name="loop{k + 1}" site1="rod{k + 1}_tip" site2="plate_p{k + 1}"/>\n'
        )
    text.append("  </equality>\n  <actuator>\n")
    for k in range(6):
        joint = f"leg{k + 1}_j1" if kind != "sps" else f"leg{k + 1}_j3"
        text.append(f'    <motor name="m{k + 1}" joint="{joint}"/>\n')
    text.append("  </actuator>\n</mujoco>\n")
    return "".join(text)


def _tree_platform(w, robot, W_rod, Wp, L, ind):
    """The platform inside leg 1's rod: a socket body at the rod's tip (on its axis) with
    the ball joint, the platform fixed to it (import with ``platform="platform"``)."""
    W_socket = W_rod @ np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, L], [0, 0, 0, 1.0]])
    rel = _rel(W_socket, Wp)
    out = [f'{ind}<body name="socket1" pos="0 0 {w.n(L)}">\n']
    out.append(f'{ind}  <joint name="ball_p1" type="ball" damping="0"/>\n')
    out.append(f'{ind}  <geom type="sphere" size="0.004" density="7800"/>\n')
    out.append(
        f'{ind}  <body name="platform" pos="{w.v(rel[:3, 3])}" {w.orientation(rel[:3, :3])}>\n'
    )
    out.extend(_platform_contents(w, robot, Wp, ind + "    ", "ss"))
    out.append(f"{ind}  </body>\n{ind}</body>\n")
    return out


# ------------------------------------------------------------------------------ URDF
def _leg_base(robot, k: int) -> np.ndarray:
    T0 = np.eye(4)
    T0[:3, :3], T0[:3, 3] = robot.leg_base_rotations[k], robot.base_points[k]
    return T0


def _rpy(R: np.ndarray) -> np.ndarray:
    return Rotation.from_matrix(R).as_euler("xyz")  # URDF: fixed-axis roll, pitch, yaw


def cad_urdf(
    robot,
    style: str = "floating",
    seed: int = 0,
    digits: int = 6,
    closing: str = "closing",
    transmissions: bool = True,
) -> str:
    """A URDF of ``robot`` (a ``GeneralHexapod``) as onshape-to-robot writes one: link frames
    at odd places (each joint's frame is its child link's, axis given in it), rounded
    numbers, inertials with a rotated ``<inertial>`` frame, fixed extra links (a housing on
    each link 1, a camera on the platform), ``<dynamics damping friction>``, and the loops
    as fixed frames ``closing_<k>_1`` (on the leg) / ``closing_<k>_2`` (on the platform)
    (``closing`` renames them: ``"tip"`` gives ``tip_<k>`` / ``socket_<k>``).

    ``style``: ``"floating"`` (the platform on a floating joint, six closing pairs; its
    ``<origin>`` the home pose) or ``"tree-hinges"`` (the platform hanging from leg 1
    through three revolute joints with massless links between them, five closing pairs).
    ``transmissions``: one ``<transmission>`` per leg (shuffled order, reductions)."""
    rng = np.random.default_rng(seed)
    w = Writer(rng, digits)
    F, _ = _frames(robot)
    s = max(robot.size, 0.02)
    T_home = np.asarray(robot.home_pose)
    P = robot.platform_points @ T_home[:3, :3].T + T_home[:3, 3]
    Wp = T_home @ w.odd(0.2 * s)
    if style == "tree-hinges":  # URDF: a joint's axis runs through its child's origin
        Wp[:3, 3] = robot.legs[0].tip_position(_frames(robot)[1][0], _leg_base(robot, 0))
    out = [f'<?xml version="1.0"?>\n<robot name="onshape-{style}">\n']
    out.append('  <link name="world"/>\n  <joint name="world_fix" type="fixed">\n'
               '    <parent link="world"/><child link="base_link"/>\n'
               '    <origin xyz="0 0 0.002" rpy="0 0 0"/>\n  </joint>\n')  # fmt: skip
    base = np.eye(4)
    base[2, 3] = 0.002
    out.append('  <link name="base_link">\n    <inertial><origin xyz="0 0 0"/><mass value="3"/>'
               '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.2"/></inertial>\n'
               '    <visual><geometry><mesh filename="package://robot/base.stl"/></geometry>'
               '</visual>\n  </link>\n')  # fmt: skip

    def inertial(params: np.ndarray, T_link_frame: np.ndarray) -> str:
        p = transform_khalil(params, T_link_frame[:3, :3], T_link_frame[:3, 3])
        m, c, I_c = urdf_inertial_from_khalil(p)
        Ri = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
        I = Ri.T @ I_c @ Ri  # the tensor in a rotated inertial frame
        return (
            f'<inertial><origin xyz="{w.v(c)}" rpy="{" ".join(f"{x:.9f}" for x in _rpy(Ri))}"/>'
            f'<mass value="{w.g(m, 9)}"/><inertia ixx="{w.g(I[0, 0], 9)}" ixy="{w.g(I[0, 1], 9)}" '
            f'ixz="{w.g(I[0, 2], 9)}" iyy="{w.g(I[1, 1], 9)}" iyz="{w.g(I[1, 2], 9)}" '
            f'izz="{w.g(I[2, 2], 9)}"/></inertial>'
        )

    def joint(name, kind, parent, child, T_parent, T_child, axis_frame, dyn=True):
        rel = np.linalg.inv(T_parent) @ T_child
        axis = (np.linalg.inv(T_child) @ axis_frame)[:3, 2]
        limit = (
            '<limit lower="-1" upper="1" effort="100" velocity="10"/>' if kind != "fixed" else ""
        )
        dynamics = (
            '<dynamics damping="0.0125" friction="0.0075"/>' if dyn and kind != "fixed" else ""
        )
        ax = f'<axis xyz="{w.v(axis)}"/>' if kind != "fixed" else ""
        return (
            f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/><child link="{child}"/>\n'
            f'    <origin xyz="{w.v(rel[:3, 3])}" rpy="{" ".join(f"{x:.9f}" for x in _rpy(rel[:3, :3]))}"/>'
            f"\n    {ax}{limit}{dynamics}\n  </joint>\n"
        )

    def frame_link(name, parent, T_parent, point):
        T = np.eye(4)
        T[:3, 3] = point
        return f'  <link name="{name}"/>\n' + joint(
            f"{name}_frame", "fixed", parent, name, T_parent, T, T
        )

    ends = (
        ("closing_{k}_1", "closing_{k}_2") if closing == "closing" else ("tip_{k}", "socket_{k}")
    )
    for k in range(6):
        leg = robot.legs[k]
        parent, W_prev = "base_link", base
        parallel = [abs(math.sin(leg.joints[n].alpha)) < 1e-12 for n in (1, 2)]
        for j in range(3):
            aligned = (j < 2 and parallel[j]) or (j > 0 and parallel[j - 1])
            offset = w.aligned(0.3 * s) if aligned else w.odd(0.3 * s)
            # URDF: the joint's axis runs through its child's origin (moved along it only)
            offset[:3, 3] = [0.0, 0.0, offset[2, 3]]
            W = F[k, j] @ offset
            name = f"leg{k + 1}_link{j + 1}"
            out.append(
                f'  <link name="{name}">\n    {inertial(robot.leg_inertia[k, j], np.linalg.inv(W) @ F[k, j])}\n  </link>\n'
            )
            out.append(joint(f"leg{k + 1}_q{j + 1}", "revolute" if leg.joints[j].revolute else "prismatic",
                             parent, name, W_prev, W, F[k, j]))  # fmt: skip
            if j == 0:
                out.append(f'  <link name="leg{k + 1}_housing">\n    <inertial><origin xyz="0 0 0"/>'
                           '<mass value="0.01"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" '
                           'iyz="0" izz="1e-6"/></inertial>\n  </link>\n')  # fmt: skip
                H = W.copy()
                H[:3, 3] += rng.uniform(-0.01, 0.01, 3)
                out.append(
                    joint(f"leg{k + 1}_housing_fix", "fixed", name, f"leg{k + 1}_housing", W, H, H)
                )
            parent, W_prev = name, W
        tip = F[k, 2][:3, :3] @ leg.tip + F[k, 2][:3, 3]
        if style == "tree-hinges" and k == 0:
            A = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            prev, Tprev = parent, W_prev
            for h in range(2):
                Th = np.eye(4)
                Th[:3, :3], Th[:3, 3] = A, tip
                Th = (
                    Th @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]])
                    if h
                    else Th
                )
                hn = f"ball1_link{h + 1}"
                out.append(f'  <link name="{hn}"/>\n')
                axis_frame = np.eye(4)
                axis_frame[:3, :3] = _frame_z(A[:, h], rng)
                axis_frame[:3, 3] = tip
                out.append(
                    joint(
                        f"ball1_{'xyz'[h]}", "revolute", prev, hn, Tprev, Th, axis_frame, dyn=False
                    ).replace('<limit lower="-1" upper="1"', '<limit lower="-3" upper="3"')
                )
                prev, Tprev = hn, Th
            axis_frame = np.eye(4)
            axis_frame[:3, :3] = _frame_z(A[:, 2], rng)
            axis_frame[:3, 3] = tip
            out.append(
                joint(
                    "ball1_z", "revolute", prev, "platform", Tprev, Wp, axis_frame, dyn=False
                ).replace('<limit lower="-1" upper="1"', '<limit lower="-3" upper="3"')
            )
        else:
            out.append(frame_link(ends[0].format(k=k + 1), parent, W_prev, tip))
    out.append(
        f'  <link name="platform">\n    {inertial(robot.platform_inertia, np.linalg.inv(Wp) @ T_home)}\n  </link>\n'
    )
    if style == "floating":
        out.append(
            joint("platform_free", "floating", "world", "platform", np.eye(4), Wp, Wp, dyn=False)
        )
    out.append('  <link name="camera">\n    <inertial><origin xyz="0.001 0 0.01"/><mass value="0.2"/>'
               '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="2e-4" iyz="0" izz="1e-4"/></inertial>\n'
               '  </link>\n')  # fmt: skip
    C = Wp.copy()
    C[:3, 3] += rng.uniform(-0.02, 0.02, 3)
    out.append(joint("camera_fix", "fixed", "platform", "camera", Wp, C, C))
    for k in range(6):
        if style == "tree-hinges" and k == 0:
            continue
        out.append(frame_link(ends[1].format(k=k + 1), "platform", Wp, P[k]))
    if transmissions:
        for n, k in enumerate(rng.permutation(6)):
            leg = robot.legs[k]
            reduction = (1, 20, 1, 3.5, 1, 80)[n]
            out.append(
                f'  <transmission name="tr{n + 1}"><type>transmission_interface/SimpleTransmission'
                f'</type><joint name="leg{k + 1}_q{leg.actuated}"><hardwareInterface>'
                f'EffortJointInterface</hardwareInterface></joint><actuator name="motor{n + 1}">'
                f"<mechanicalReduction>{reduction}</mechanicalReduction></actuator>"
                "</transmission>\n"
            )
    out.append("</robot>\n")
    return "".join(out)
