"""The neutral kinematic tree the MJCF and URDF readers produce (:class:`KinematicModel`).

Bodies with at most one joint each (a file body with several joints becomes a chain of
massless bodies: MuJoCo's sequential joint motion), every pose and axis given in F0 (the
file's world) at the **zero configuration** (every hinge and slide at 0, every ball at the
identity, each free body at its reference pose), inertias as Khalil's ten parameters in
each body's own frame about its origin; loop closures (points, welds); actuators;
gravity; the joint values of the **reference configuration** (the assembled state: MJCF
``qpos0`` or a keyframe, URDF zero or the sidecar's home).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stewart_pin.description.leg_architecture import (
    PRISMATIC,
    REVOLUTE,
)
from stewart_pin.exceptions import (
    ModelImportError,
)

#: Joint kinds of the neutral tree.
BALL, FREE = "ball", "free"


# ------------------------------------------------------------------------------ the tree
@dataclass
class TreeJoint:
    """A joint of the neutral tree, in F0 at the zero configuration.

    Attributes:
        name: as in the file.
        kind: ``"revolute"``, ``"prismatic"``, ``"ball"`` or ``"free"``.
        anchor: (3,) a point of the axis (the ball's centre) [m].
        axis: (3,) unit axis (revolute, prismatic); zeros otherwise.
        lower, upper: limits [rad or m] (infinite: none).
        armature, damping, coulomb, stiffness, rest: the joint terms (SI units; MuJoCo's
            ``armature``, ``damping``, ``frictionloss``, ``stiffness``, ``springref``; URDF's
            ``damping`` and ``friction``).
        limited: a ball joint's cone limit (ignored, reported).
    """

    name: str
    kind: str
    anchor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    lower: float = -math.inf
    upper: float = math.inf
    armature: float = 0.0
    damping: float = 0.0
    coulomb: float = 0.0
    stiffness: float = 0.0
    rest: float = 0.0
    limited: bool = False

    @property
    def one_dof(self) -> bool:
        return self.kind in (REVOLUTE, PRISMATIC)

    @property
    def has_terms(self) -> bool:
        return any(
            getattr(self, k) != 0.0 for k in ("armature", "damping", "coulomb", "stiffness")
        )

    def motion(self, value: Any, R_zero: np.ndarray | None = None) -> np.ndarray:
        """The 4x4 motion in F0 of this joint at ``value`` from the zero configuration:
        a rotation about the axis line (revolute), a translation (prismatic), or for a
        ball the rotation ``value`` (3, 3) given in the body's zero frame ``R_zero``."""
        M = np.eye(4)
        if self.kind == REVOLUTE:
            M[:3, :3] = _axis_angle(self.axis, float(value))
            M[:3, 3] = self.anchor - M[:3, :3] @ self.anchor
        elif self.kind == PRISMATIC:
            M[:3, 3] = self.axis * float(value)
        elif self.kind == BALL:
            assert R_zero is not None
            M[:3, :3] = R_zero @ np.asarray(value, dtype=float) @ R_zero.T
            M[:3, 3] = self.anchor - M[:3, :3] @ self.anchor
        else:  # free joints are placed directly (KinematicModel.poses)
            raise ModelImportError(f"joint {shown(self.name)}: a {self.kind} joint has no motion")
        return M


@dataclass
class TreeBody:
    """A body of the neutral tree.

    Attributes:
        name: the file's body name (a massless body between two joints of one file body
            has that body's name, and ``virtual`` set).
        parent: the parent body's index (-1 for the world, body 0).
        joint: the joint between parent and this body, or ``None`` (fixed to the parent).
        pose: (4, 4) the body's frame in F0 at the zero configuration.
        inertia: (10,) Khalil's parameters in the body frame about its origin.
        virtual: a massless body the reader inserted (not in the file).
        gravcomp: the fraction of its weight compensated (MJCF ``gravcomp``; 1 for a
            body without gravity, SDF ``<gravity>false</gravity>``); the import scales
            gravity when every moving body has the same, else gives each link its own.
    """

    name: str
    parent: int
    joint: TreeJoint | None
    pose: np.ndarray
    inertia: np.ndarray = field(default_factory=lambda: np.zeros(10))
    virtual: bool = False
    gravcomp: float = 0.0


@dataclass
class TreeClosure:
    """A loop closure: ``point1`` in ``body1`` coincides with ``point2`` in ``body2``
    (``"point"``, MJCF ``connect``, URDF frame pairs), or ``body2`` is held at ``T_1_2``
    in ``body1`` (``"weld"``; ``frame2``: the file's weld frame in ``body2``, e.g. an MJCF
    site or a sidecar's ``frame2``, so at ``T_1_2 frame2`` in ``body1``: where a chain leg
    is attached)."""

    name: str
    kind: str
    body1: int
    body2: int
    point1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    point2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    T_1_2: np.ndarray = field(default_factory=lambda: np.eye(4))
    frame2: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class TreeActuator:
    """An actuator on a joint (``gear``: joint effort per actuator effort)."""

    name: str
    joint: str
    gear: float = 1.0


@dataclass
class KinematicModel:
    """What a reader produces (module docstring).

    Attributes:
        name: the model's own name. format: ``"mjcf"`` / ``"urdf"``. file: the file name.
        bodies: body 0 is the world (F0).
        closures, actuators: as read.
        gravity: (3,) in F0 [m/s^2].
        reference: the name of the reference configuration.
        values: 1-dof joint values at the reference [rad or m], by joint name.
        balls: ball rotations (3, 3) at the reference, in each body's zero frame, by name.
        free: free bodies' poses (4, 4) in F0 at the reference, by joint name.
        notes: what the reader ignored or corrected (reported).
        base_name: the name of body 0 in the file.
    """

    name: str
    format: str
    file: str
    bodies: list[TreeBody]
    closures: list[TreeClosure]
    actuators: list[TreeActuator]
    gravity: np.ndarray
    reference: str
    values: dict[str, float]
    balls: dict[str, np.ndarray]
    free: dict[str, np.ndarray]
    notes: list[str] = field(default_factory=list)
    base_name: str = "world"

    def poses(
        self,
        values: dict[str, float] | None = None,
        balls: dict[str, np.ndarray] | None = None,
        free: dict[str, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Every body's pose (n, 4, 4) in F0 at the given joint values (default the
        reference; a joint not given is at zero)."""
        values = self.values if values is None else values
        balls = self.balls if balls is None else balls
        free = self.free if free is None else free
        out = np.empty((len(self.bodies), 4, 4))
        out[0] = self.bodies[0].pose
        for b, body in enumerate(self.bodies[1:], start=1):
            parent = out[body.parent] @ np.linalg.inv(self.bodies[body.parent].pose)
            J = body.joint
            if J is None:
                out[b] = parent @ body.pose
            elif J.kind == FREE:
                out[b] = free.get(J.name, body.pose)
            elif J.kind == BALL:
                M = J.motion(balls.get(J.name, np.eye(3)), body.pose[:3, :3])
                out[b] = parent @ M @ body.pose
            else:
                out[b] = parent @ J.motion(values.get(J.name, 0.0)) @ body.pose
        return out

    def body_label(self, b: int) -> str:
        return "world" if b == 0 else self.bodies[b].name


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def shown(name: str) -> str:
    """A name from a file as shown in a message: quoted, control characters escaped,
    at most 80 characters."""
    text = name if len(name) <= 80 else name[:77] + "..."
    return repr(text)


def shown_list(items: Sequence[str]) -> str:
    """Names from a file, each :func:`shown`, comma-separated."""
    return ", ".join(shown(n) for n in items)


__all__ = [
    "BALL",
    "FREE",
    "KinematicModel",
    "TreeActuator",
    "TreeBody",
    "TreeClosure",
    "TreeJoint",
    "shown",
    "shown_list",
]
