"""Drawing robots with general three-joint legs (``general-legs.md``) in meshcat: the links
of each leg's chain placed from its joint frames, without a URDF.

For each leg i (``k = 1..6``), at the joint values of the inverse geometry
(:func:`~stewart_pin.kinematics.leg_chains.inverse_geometry_batch`, limits not checked)
and the joint frames of :func:`~stewart_pin.kinematics.leg_chains.leg_forward` (O_j the
origin and z_j the axis of frame ji in F0), the scene holds, under
``/meshcat/stewart_pin/legs/leg<k>/``:

- ``axis`` (revolute joint 1, fixed): a short dark cylinder along z_1 at O_1, the motor
  shaft;
- ``crank``: a red box from O_1 (on the crank axis) to O_2 (the universal joint), its
  depth along z_1, when joint 2's placement has a translation or joint 2 is prismatic
  (absent for 6-UPS; the short common normal of ``ups-offset``; on a slide, an arm);
- ``rail`` (prismatic joint 1, fixed): a purple box along the rail axis over the joint's
  range (its limits, widened to the drawn values; without limits, the drawn values'
  range plus a margin);
- ``slide`` (prismatic joint 1): a green box at O_1, oriented with frame 1i;
- ``ujoint``: a dark sphere at O_2;
- ``link2`` (when joint 3 can move O_3 off O_2 and the tip is off frame 3i's origin):
  a silver cylinder O_2 -> O_3;
- ``rod``: a blue cylinder from the last joint centre (O_3, or O_2 when P_i = O_3 as for
  6-UPS) to P_i;
- ``tip``: a dark sphere at P_i;

and ``base`` (a grey disc under the base points, fixed) and ``platform`` (an orange disc
through the P_i, moving with 0Tp) under ``/meshcat/stewart_pin/``.

A segment (crank, rail, link2, rod) is a node whose transform has its origin at the
segment's start and its y axis along the segment (three.js cylinders lie along y), scaled
along y by the segment's length [m]; its shape (child ``shape``) is a unit-length box or
cylinder from y = 0 to y = 1. So the segment's end is ``position + R (0, scale_y, 0)``.
In an animation, each moving node has a ``position``, ``quaternion`` and (segments)
``scale`` track.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin.architectures import reference_path
from stewart_pin.description import RobotDescription
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.formats.urdf import VisualSizes, plate_visual
from stewart_pin.kinematics.leg_chains import LegFrames, inverse_geometry_batch, leg_forward

#: Colours (RGB in [0, 1]).
CRANK_RED = (0.85, 0.18, 0.18)
RAIL_PURPLE = (0.50, 0.25, 0.75)
SLIDE_GREEN = (0.20, 0.65, 0.30)
ROD_BLUE = (0.20, 0.40, 0.80)
JOINT_DARK = (0.15, 0.15, 0.15)
LINK_SILVER = (0.80, 0.80, 0.82)
BASE_GREY = (0.35, 0.35, 0.38)
PLATFORM_ORANGE = (0.95, 0.55, 0.15)
#: Below this length [m] a segment is not drawn (coincident joint centres).
MIN_SEGMENT = 1e-9
#: Three.js cylinders lie along y; URDF / Pinocchio ones along z: ``R @ Rx(pi/2)``.
_Y_TO_Z = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def general_robot(robot: Any) -> GeneralHexapod | None:
    """The leg chains the viewer draws for ``robot``, or ``None`` when it draws the
    robot's URDF tree with its visuals.

    ``robot`` may be a :class:`GeneralHexapod` (drawn as chains), a
    :class:`RobotDescription` or a robot holding one as ``description`` (its
    architecture's path says which: :attr:`stewart_pin.architectures.LegChainPath.urdf_visuals`,
    the ideal 6-UPS's tree), or a description-like object with ``legs`` (the duck-typed
    attributes of :class:`GeneralHexapod`; without ``legs``, or with a URDF tree (``tree``
    and ``urdf``) and only plain ``ups`` legs, the URDF tree is drawn).
    """
    desc = getattr(robot, "description", robot)
    if isinstance(desc, GeneralHexapod):
        return desc
    if isinstance(desc, RobotDescription):  # its architecture's path says how it is drawn
        return None if reference_path(desc).urdf_visuals else general_from_description(desc)
    legs = getattr(desc, "legs", None)  # a description-like object: duck-typed
    if legs is None or (
        hasattr(robot, "tree")
        and hasattr(robot, "urdf")
        and all(getattr(leg, "name", None) == "ups" for leg in legs)
    ):
        return None
    return GeneralHexapod(
        base_points=desc.base_points,
        leg_base_rotations=desc.leg_base_rotations,
        platform_points=desc.platform_points,
        legs=tuple(legs),
        leg_inertia=desc.leg_inertia,
        platform_inertia=desc.platform_inertia,
        gravity=desc.gravity,
        home_pose=desc.home_pose,
        name=str(getattr(desc, "name", "general")),
    )


@dataclass(frozen=True)
class Shape:
    """One drawn object: ``node`` under the root, ``kind`` (``box``, ``cylinder``,
    ``sphere``), ``size`` (box: (width, depth) across a segment or (x, y, z) for a solid
    box; cylinder, sphere: (radius,); the plates: (radius, thickness)), ``colour``,
    ``segment`` (unit length along y, scaled per frame), ``moving``."""

    node: str
    kind: str
    size: tuple[float, ...]
    colour: tuple[float, float, float]
    segment: bool
    moving: bool


@dataclass(frozen=True)
class Placements:
    """Node placements over K frames: ``matrices`` node -> (K, 4, 4) rigid transforms in
    the robot's frame F0, ``lengths`` node -> (K,) segment lengths [m] (the y scale)."""

    matrices: dict[str, np.ndarray]
    lengths: dict[str, np.ndarray]

    def scaled(self, node: str, k: int) -> np.ndarray:
        """Node ``node``'s transform at frame ``k``, with its segment scale applied."""
        M = self.matrices[node][k].copy()
        if node in self.lengths:
            M[:3, 1] *= self.lengths[node][k]
        return M


def _segments(
    start: np.ndarray, end: np.ndarray, hint: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rigid transforms (K, 4, 4) with origin ``start`` and y along ``end - start``, z the
    component of ``hint`` normal to it (another normal when ``hint`` is parallel), and the
    lengths (K,)."""
    v = end - start
    L = np.linalg.norm(v, axis=-1)
    y = np.where(L[:, None] > MIN_SEGMENT, v / np.maximum(L, MIN_SEGMENT)[:, None], [0, 0, 1.0])
    hint = np.broadcast_to(hint, y.shape)
    z = hint - np.sum(hint * y, axis=-1, keepdims=True) * y
    bad = np.linalg.norm(z, axis=-1) < 1e-6
    if np.any(bad):
        other = np.where(np.abs(y[bad, 0:1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        z[bad] = other - np.sum(other * y[bad], axis=-1, keepdims=True) * y[bad]
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    M = np.tile(np.eye(4), (len(v), 1, 1))
    M[:, :3, 0], M[:, :3, 1], M[:, :3, 2], M[:, :3, 3] = np.cross(y, z), y, z, start
    return M, L


def _offset(joint: Any) -> bool:
    """Whether a joint's frame origin can leave the previous frame's origin (a prismatic
    joint, or a placement with a translation)."""
    return not joint.revolute or bool(np.linalg.norm(joint.placement()[:3, 3]) > MIN_SEGMENT)


def _translations(p: np.ndarray) -> np.ndarray:
    M = np.tile(np.eye(4), (len(p), 1, 1))
    M[:, :3, 3] = p
    return M


class LegScene:
    """The meshcat scene of a :class:`GeneralHexapod` (module docstring).

    Args:
        robot: the robot.
        poses: (K, 4, 4) poses 0Tp the scene will draw (they set the rails' drawn range
            when the prismatic joints have no limits; default the home pose).
    """

    def __init__(self, robot: GeneralHexapod, poses: np.ndarray | None = None):
        self.robot = robot
        s = float(robot.size)
        self.sizes = VisualSizes(0.06 * s, 0.045 * s, 0.03 * s, 0.0, 0.0, 0.04 * s)
        T = np.asarray(robot.home_pose)[None] if poses is None else np.asarray(poses, float)
        q = self.joint_values(T)
        frames = leg_forward(robot, q)
        # Which segments a leg has follows from its structure, not from the drawn poses.
        self._rod_from_o3 = [bool(np.linalg.norm(leg.tip) > MIN_SEGMENT) for leg in robot.legs]
        self._crank = [_offset(leg.joints[1]) for leg in robot.legs]
        self._link2 = [
            self._rod_from_o3[i] and _offset(leg.joints[2]) for i, leg in enumerate(robot.legs)
        ]
        self._static = self._static_placements(q, frames)
        self.shapes = self._shapes()

    # ------------------------------------------------------------------ geometry
    def joint_values(self, poses: np.ndarray) -> np.ndarray:
        """Joint values (K, 6, 3) [rad or m] of the poses (inverse geometry, each leg on
        its branch, limits not checked: the viewer draws any pose the legs reach)."""
        return inverse_geometry_batch(self.robot, poses, check_limits=False)

    def _static_placements(self, q: np.ndarray, frames: LegFrames) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        s, vs = float(self.robot.size), self.sizes
        self.rail_range: dict[int, tuple[float, float]] = {}
        for i, leg in enumerate(self.robot.legs):
            j1 = leg.joints[0]
            T1 = frames.T[0, i, 0]
            if j1.revolute:
                # the shaft, centred on O_1 along z_1 (y of the cylinder)
                out[f"legs/leg{i + 1}/axis"] = T1 @ _rot4(_Y_TO_Z)
            else:
                # the rail frame: frame 1i with the slide's travel r1 + q1 taken back
                rail = T1.copy()
                rail[:3, 3] -= (j1.r + q[0, i, 0]) * T1[:3, 2]
                lo_q, hi_q = float(q[:, i, 0].min()), float(q[:, i, 0].max())
                lo = j1.lower if math.isfinite(j1.lower) else lo_q - 0.5 * s
                hi = j1.upper if math.isfinite(j1.upper) else hi_q + 0.5 * s
                lo, hi = min(lo, lo_q), max(hi, hi_q)
                lo, hi = lo - vs.joint_radius, hi + vs.joint_radius
                self.rail_range[i] = (lo, hi)
                start = rail[:3, 3] + (j1.r + lo) * rail[:3, 2]
                end = rail[:3, 3] + (j1.r + hi) * rail[:3, 2]
                M, L = _segments(start[None], end[None], rail[:3, 0])
                out[f"legs/leg{i + 1}/rail"] = M[0] @ np.diag([1.0, L[0], 1.0, 1.0])
        xyz, rpy, _, _ = plate_visual(self.robot.base_points, vs, -1.0)
        out["base"] = _pose4(pin.rpy.rpyToMatrix(rpy) @ _Y_TO_Z, xyz)
        return out

    def _shapes(self) -> list[Shape]:
        vs = self.sizes
        jr, w = vs.joint_radius, vs.cylinder_radius
        shapes = []
        for i, leg in enumerate(self.robot.legs):
            n = f"legs/leg{i + 1}"
            if leg.joints[0].revolute:
                shapes.append(
                    Shape(f"{n}/axis", "cylinder", (0.8 * jr, 3.0 * jr), JOINT_DARK, False, False)
                )
            else:
                shapes.append(Shape(f"{n}/rail", "box", (w, w), RAIL_PURPLE, True, False))
                shapes.append(
                    Shape(
                        f"{n}/slide", "box", (2.4 * w, 2.4 * w, 3.0 * w), SLIDE_GREEN, False, True
                    )
                )
            if self._crank[i]:  # the crank; on a slide, an arm to an offset U joint
                shapes.append(Shape(f"{n}/crank", "box", (1.6 * w, w), CRANK_RED, True, True))
            shapes.append(Shape(f"{n}/ujoint", "sphere", (jr,), JOINT_DARK, False, True))
            if self._link2[i]:
                shapes.append(
                    Shape(f"{n}/link2", "cylinder", (vs.rod_radius,), LINK_SILVER, True, True)
                )
            shapes.append(Shape(f"{n}/rod", "cylinder", (vs.rod_radius,), ROD_BLUE, True, True))
            shapes.append(Shape(f"{n}/tip", "sphere", (jr,), JOINT_DARK, False, True))
        base = plate_visual(self.robot.base_points, vs, -1.0)
        plate = plate_visual(self.robot.platform_points, vs, 1.0)
        shapes.append(Shape("base", "cylinder", (base[2], base[3]), BASE_GREY, False, False))
        shapes.append(
            Shape("platform", "cylinder", (plate[2], plate[3]), PLATFORM_ORANGE, False, True)
        )
        return shapes

    def placements(self, poses: np.ndarray) -> Placements:
        """The moving nodes' placements at poses (K, 4, 4) 0Tp."""
        T = np.asarray(poses, float)
        frames = leg_forward(self.robot, self.joint_values(T))
        O, Z, P = frames.origins, frames.axes, frames.P
        mats: dict[str, np.ndarray] = {}
        lengths: dict[str, np.ndarray] = {}
        for i, leg in enumerate(self.robot.legs):
            n = f"legs/leg{i + 1}"
            if not leg.joints[0].revolute:
                mats[f"{n}/slide"] = frames.T[:, i, 0]
            if self._crank[i]:
                mats[f"{n}/crank"], lengths[f"{n}/crank"] = _segments(
                    O[:, i, 0], O[:, i, 1], Z[:, i, 0]
                )
            mats[f"{n}/ujoint"] = _translations(O[:, i, 1])
            start = O[:, i, 2] if self._rod_from_o3[i] else O[:, i, 1]
            if self._link2[i]:
                mats[f"{n}/link2"], lengths[f"{n}/link2"] = _segments(
                    O[:, i, 1], O[:, i, 2], Z[:, i, 2]
                )
            mats[f"{n}/rod"], lengths[f"{n}/rod"] = _segments(start, P[:, i], Z[:, i, 2])
            mats[f"{n}/tip"] = _translations(P[:, i])
        xyz, rpy, _, _ = plate_visual(self.robot.platform_points, self.sizes, 1.0)
        mats["platform"] = T @ _pose4(pin.rpy.rpyToMatrix(rpy) @ _Y_TO_Z, xyz)
        return Placements(mats, lengths)

    def extent_points(self, poses: np.ndarray) -> np.ndarray:
        """Points (M, 3) the drawing spans at ``poses``: B_i, the joint centres, the P_i,
        the rail ends [m]."""
        frames = leg_forward(self.robot, self.joint_values(np.asarray(poses, float)))
        pts = [self.robot.base_points, frames.origins.reshape(-1, 3), frames.P.reshape(-1, 3)]
        for node, M in self._static.items():
            if node.endswith("/rail"):
                pts.append(np.array([M[:3, 3], M[:3, 3] + M[:3, 1]]))
        return np.concatenate(pts)

    # ------------------------------------------------------------------ meshcat
    def load(self, visualizer: Any, root: str) -> None:
        """Create every object under ``root`` and place the fixed ones."""
        import meshcat.geometry as g

        for shape in self.shapes:
            material = g.MeshLambertMaterial(color=_hex(shape.colour))
            node = visualizer[f"{root}/{shape.node}"]
            if shape.kind == "sphere":
                geometry: Any = g.Sphere(shape.size[0])
            elif shape.segment:
                if shape.kind == "box":
                    geometry = g.Box([shape.size[0], 1.0, shape.size[1]])
                else:
                    geometry = g.Cylinder(1.0, shape.size[0])
                node["shape"].set_object(geometry, material)
                node["shape"].set_transform(_pose4(np.eye(3), [0.0, 0.5, 0.0]))
                continue
            elif shape.kind == "box":
                geometry = g.Box(list(shape.size))
            else:
                geometry = g.Cylinder(shape.size[1], shape.size[0])
            node.set_object(geometry, material)
        for name, M in self._static.items():
            visualizer[f"{root}/{name}"].set_transform(M)

    def moving_nodes(self) -> Iterator[str]:
        return (s.node for s in self.shapes if s.moving)

    def display(self, visualizer: Any, root: str, pose: np.ndarray) -> None:
        """Place the moving objects at one pose 0Tp."""
        placed = self.placements(np.asarray(pose, float)[None])
        for node in placed.matrices:
            visualizer[f"{root}/{node}"].set_transform(placed.scaled(node, 0))

    def animate(
        self,
        animation: Any,
        visualizer: Any,
        root: str,
        poses: np.ndarray,
        times: np.ndarray,
        fps: float,
    ) -> None:
        """Keyframes (``t * fps``) of every moving node at poses (K, 4, 4), times (K,) [s]."""
        placed = self.placements(poses)
        for k, tk in enumerate(times):
            with animation.at_frame(visualizer, float(tk) * fps) as frame:
                for node, M in placed.matrices.items():
                    frame[f"{root}/{node}"].set_transform(M[k])
                    if node in placed.lengths:
                        length = float(placed.lengths[node][k])
                        frame[f"{root}/{node}"].set_property(
                            "scale", "vector3", [1.0, length, 1.0]
                        )


def _rot4(R: np.ndarray) -> np.ndarray:
    return _pose4(R, np.zeros(3))


def _pose4(R: np.ndarray, p: Any) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, p
    return M


def _hex(rgb: tuple[float, float, float]) -> int:
    r, g, b = (round(255 * c) for c in rgb)
    return (r << 16) | (g << 8) | b
