"""A neutral kinematic tree (what the MJCF and URDF readers produce) and the recognition of
a six-legged platform in it, mapped onto :class:`~stewart_pin.description.RobotDescription`.

The tree (:class:`KinematicModel`): bodies with at most one joint each (a file body with
several joints becomes a chain of massless bodies, MuJoCo's sequential joint motion),
every pose and axis given in F0 (the file's world) at the **zero configuration** (every
hinge and slide at 0, every ball at the identity, each free body at its reference pose),
inertias as Khalil's ten parameters in each body's own frame; loop closures (points,
welds); actuators; gravity; the joint values of the **reference configuration** (the
assembled state: MJCF ``qpos0`` or a keyframe, URDF zero or the sidecar's home).

Recognition (:func:`recognise`):

1. Bodies fixed to their parent (no joint) and bodies joined by a weld form one rigid
   link; its inertia is the exact sum of its bodies' (lumped). The link holding the world
   is the base.
2. Three hinges through one point with massless bodies between them (within
   :data:`MASSLESS` of the robot's mass scale) are a spherical joint, as is a ``ball``.
3. The platform is the link with six spherical connections (ball joints, three-hinge
   spherical joints, point closures); walking from each one back to the base gives a leg.
   A leg is three 1-dof joints then the spherical joint, or a rod between two spherical
   joints: R-S-S, P-S-S (a 1-dof joint, a spherical joint, the rod) or S-P-S (a
   spherical joint at the base, a slide along the rod), each replaced by the equivalent
   universal-joint leg (the rod's spin about its axis removed: exact when the rod's
   inertia is symmetric about that axis, :data:`SPIN_TOLERANCE`).
4. Everything else that moves is an error naming its bodies.

:func:`build` then places every leg in the canonical modified-DH form
(:mod:`stewart_pin.importers.canonical`), re-expresses each link's inertia in its frame,
reads the actuated joints and the joint terms, checks the loops at the reference
configuration and writes the description, with the ideal 6-UPS form when it fits.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stewart_pin.description.leg_architecture import (
    PRISMATIC,
    REVOLUTE,
    Joint,
    JointDynamics,
    LegArchitecture,
)
from stewart_pin.description.model_source import LegSource, ModelSource
from stewart_pin.description.robot_description import (
    NAME_PATTERN,
    RobotDescription,
    check_robot_name,
)
from stewart_pin.exceptions import (
    ArchitectureError,
    DescriptionError,
    JointDynamicsError,
    LoopClosureError,
    ModelImportError,
    ModelImportWarning,
    RobotNameError,
    RodSpinError,
)
from stewart_pin.importers.canonical import (
    canonical_chain,
    classify,
    transform_inertia,
)

#: Joint kinds of the neutral tree.
BALL, FREE = "ball", "free"
#: A body is massless when its mass is at most this fraction of the robot's total mass
#: and its inertia at most this fraction of that mass times the size squared (MuJoCo
#: refuses exactly massless moving bodies; files give them 1e-9 kg or so): its inertia is
#: dropped (reported).
MASSLESS = 1e-9
#: Three hinge axes meet in one point when each passes within this fraction of the size of
#: the point nearest to all three.
INTERSECTION_TOLERANCE = 1e-9
#: Axes made parallel by more than this angle [rad] are reported (below: round-off).
PARALLEL_NOTICE = 1e-12
#: Loop residuals at or below this fraction of the size are round-off: no warning.
EXACT_CLOSURE = 1e-9
#: Default largest loop residual accepted, as a fraction of the platform's size (the mean
#: distance of the P_i to their centroid): CAD exports round their numbers; past it the
#: import fails with :class:`LoopClosureError`.
CLOSURE_TOLERANCE = 1e-2
#: Default largest asymmetry of an S-S rod about its axis (relative; see
#: :func:`rod_asymmetry`) for which its spin is removed without a word.
SPIN_TOLERANCE = 1e-6
#: A slide between two spherical joints (S-P-S) must run along the line through their
#: centres to within this angle [rad].
AXIS_TOLERANCE = 1e-9


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
    """

    name: str
    parent: int
    joint: TreeJoint | None
    pose: np.ndarray
    inertia: np.ndarray = field(default_factory=lambda: np.zeros(10))
    virtual: bool = False


@dataclass
class TreeClosure:
    """A loop closure: ``point1`` in ``body1`` coincides with ``point2`` in ``body2``
    (``"point"``, MJCF ``connect``, URDF frame pairs), or ``body2`` is held at ``T_1_2``
    in ``body1`` (``"weld"``)."""

    name: str
    kind: str
    body1: int
    body2: int
    point1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    point2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    T_1_2: np.ndarray = field(default_factory=lambda: np.eye(4))


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


def _names(items: Sequence[str]) -> str:
    return ", ".join(shown(n) for n in items)


# ------------------------------------------------------------------------------ links
@dataclass
class Link:
    """A rigid link: bodies fixed together (no joint, or welded).

    Attributes:
        root: the body whose frame is the link's frame.
        bodies: its bodies; ``rel[b]``: pose of body b in the link frame (4, 4).
        inertia: (10,) the lumped inertia in the link frame.
    """

    root: int
    bodies: list[int]
    rel: dict[int, np.ndarray]
    inertia: np.ndarray


@dataclass
class Edge:
    """A joint of the tree seen between links (``parent`` -> ``child`` link indices), or
    a spherical joint made of three hinges (``hinges``: the three joints)."""

    parent: int
    child: int
    joint: TreeJoint
    body: int  # the body the joint moves
    hinges: tuple[TreeJoint, ...] = ()
    inner: tuple[int, ...] = ()  # links between the hinges (massless)
    centre_parent: np.ndarray = field(default_factory=lambda: np.zeros(3))
    centre_child: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def spherical(self) -> bool:
        return self.joint.kind == BALL or bool(self.hinges)

    @property
    def label(self) -> str:
        if self.hinges:
            return "hinges " + _names([h.name for h in self.hinges])
        kind = "ball joint" if self.joint.kind == BALL else self.joint.kind
        return f"{kind} {shown(self.joint.name)}"


@dataclass
class Connection:
    """A spherical joint between two links: a tree edge or a point closure. ``a`` and
    ``b`` the links, ``point_a`` / ``point_b`` its centre in each link's frame."""

    a: int
    b: int
    point_a: np.ndarray
    point_b: np.ndarray
    label: str
    edge: Edge | None = None
    closure: TreeClosure | None = None


@dataclass
class LegChain:
    """One recognised leg: its edges from the base, its spherical connection at the
    platform, and its shape (``"3R"``-like ``"JJJ"``, ``"JS"`` R-S-S / P-S-S, ``"SJ"``
    S-P-S)."""

    edges: list[Edge]
    connection: Connection
    shape: str
    links: list[int]  # the links after each edge


@dataclass
class Recognition:
    """What :func:`recognise` found."""

    links: list[Link]
    link_of: list[int]
    ground: int
    platform: int
    legs: list[LegChain]
    scale: float
    mass: float
    dropped: list[str]


def _links(model: KinematicModel) -> tuple[list[Link], list[int]]:
    """Union the bodies fixed to their parents and the welded ones into links."""
    n = len(model.bodies)
    parent = list(range(n))

    def find(b: int) -> int:
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        return b

    rigid: dict[int, list[tuple[int, np.ndarray]]] = {b: [] for b in range(n)}
    for b, body in enumerate(model.bodies[1:], start=1):
        if body.joint is None:
            T = np.linalg.inv(model.bodies[body.parent].pose) @ body.pose
            rigid[body.parent].append((b, T))
            rigid[b].append((body.parent, np.linalg.inv(T)))
            parent[find(b)] = find(body.parent)
    for c in model.closures:
        if c.kind == "weld":
            rigid[c.body1].append((c.body2, c.T_1_2))
            rigid[c.body2].append((c.body1, np.linalg.inv(c.T_1_2)))
            parent[find(c.body2)] = find(c.body1)
    groups: dict[int, list[int]] = {}
    for b in range(n):
        groups.setdefault(find(b), []).append(b)

    def root_of(members: list[int]) -> int:
        if 0 in members:
            return 0
        free = [b for b in members if (j := model.bodies[b].joint) is not None and j.kind == FREE]
        if free:
            return free[0]
        jointed = [b for b in members if model.bodies[b].joint is not None]
        if len(jointed) <= 1:
            return jointed[0] if jointed else members[0]
        # several bodies with joints welded together: the one most bodies are fixed to
        # (the platform, with the rod ends welded to it), then the heaviest
        return max(jointed, key=lambda b: (len(rigid[b]), model.bodies[b].inertia[9], -b))

    links: list[Link] = []
    link_of = [0] * n
    for members in sorted(groups.values(), key=lambda m: m[0]):
        root = root_of(members)
        rel = {root: np.eye(4)}
        stack = [root]
        while stack:
            b = stack.pop()
            for other, T_rel in rigid[b]:
                if other not in rel:
                    rel[other] = rel[b] @ T_rel
                    stack.append(other)
        inertia = np.zeros(10)
        for b in members:
            inertia += transform_inertia(model.bodies[b].inertia, rel[b])
        for b in members:
            link_of[b] = len(links)
        links.append(Link(root, sorted(members), rel, inertia))
    return links, link_of


def _scale(model: KinematicModel) -> float:
    """A length scale of the model [m]: the spread of the body origins and joint anchors
    at the reference configuration."""
    poses = model.poses()
    points = [T[:3, 3] for T in poses]
    P = np.array(points)
    s = float(np.linalg.norm(P - P.mean(0), axis=1).mean()) if len(P) > 1 else 0.0
    return s if s > 0 else 1.0


def recognise(model: KinematicModel, platform: str | None = None) -> Recognition:
    """Find the base, the platform and the six legs (module docstring); raises
    :class:`ModelImportError` naming the bodies and joints that do not fit."""
    links, link_of = _links(model)
    ground = link_of[0]
    forced: int | None = None
    if platform is not None:  # the body whose frame is Fp: its link's frame
        matches = [b for b, body in enumerate(model.bodies) if body.name == platform]
        if not matches:
            raise ModelImportError(
                f"no body named {shown(platform)} (the platform asked for)", (platform,)
            )
        forced = link_of[matches[-1]]
        links[forced] = _reroot(links[forced], matches[-1])
    scale = _scale(model)
    moving = [lk for i, lk in enumerate(links) if i != ground]
    mass = float(sum(lk.inertia[9] for lk in moving)) or 1.0
    dropped: list[str] = []

    def massless(link: Link) -> bool:
        p = link.inertia
        moments = max(abs(p[0]), abs(p[3]), abs(p[5]))
        return p[9] <= MASSLESS * mass and moments <= MASSLESS * mass * scale**2

    def link_names(i: int) -> list[str]:
        return [model.body_label(b) for b in links[i].bodies if not model.bodies[b].virtual]

    # edges between links
    edges: list[Edge] = []
    for b, body in enumerate(model.bodies[1:], start=1):
        J = body.joint
        if J is None:
            continue
        pa, ch = link_of[body.parent], link_of[b]
        if pa == ch and J.kind == FREE:
            model.notes.append(
                f"the free joint {shown(J.name)} of body {shown(body.name)} is held by a weld"
            )
            continue
        if pa == ch:
            raise ModelImportError(
                f"joint {shown(J.name)} moves body {shown(body.name)} against a body it is "
                "welded to: a weld across a joint locks it; remove the weld or the joint",
                (body.name,),
                (J.name,),
            )
        e = Edge(pa, ch, J, b)
        if J.kind == BALL:
            e.centre_child = _in_link(links[ch], model, b, J.anchor)
            e.centre_parent = _in_link(links[pa], model, body.parent, J.anchor)
        edges.append(e)
    free_edges = [e for e in edges if e.joint.kind == FREE]
    for e in free_edges:
        if e.parent != ground:
            raise ModelImportError(
                f"body {shown(model.bodies[e.body].name)} has a free joint "
                f"{shown(e.joint.name)} inside the tree (its parent moves): stewart-pin "
                "reads a free joint only on the platform, a child of the base",
                (model.bodies[e.body].name,),
                (e.joint.name,),
            )

    # three hinges through one point with massless links between: a spherical joint
    incoming: dict[int, list[Edge]] = {}
    outgoing: dict[int, list[Edge]] = {}
    for e in edges:
        incoming.setdefault(e.child, []).append(e)
        outgoing.setdefault(e.parent, []).append(e)
    point_links = {c.body1 for c in model.closures if c.kind == "point"} | {
        c.body2 for c in model.closures if c.kind == "point"
    }
    point_links = {link_of[b] for b in point_links}
    used: set[int] = set()

    def plain(i: int) -> bool:
        return (
            i != ground
            and massless(links[i])
            and len(incoming.get(i, [])) == 1
            and len(outgoing.get(i, [])) == 1
            and i not in point_links
        )

    merged: list[Edge] = []
    for e1 in edges:
        if id(e1) in used or e1.joint.kind != REVOLUTE or not plain(e1.child):
            continue
        e2 = outgoing[e1.child][0]
        if e2.joint.kind != REVOLUTE or not plain(e2.child):
            continue
        e3 = outgoing[e2.child][0]
        if e3.joint.kind != REVOLUTE:
            continue
        hinges = (e1.joint, e2.joint, e3.joint)
        centre = _meeting_point(hinges)
        if centre is None or _coplanar(hinges):
            continue
        for h in hinges:
            if h.has_terms:
                raise ModelImportError(
                    f"hinges {_names([x.name for x in hinges])} make a spherical joint, but "
                    f"{shown(h.name)} carries joint terms (armature, damping, friction or a "
                    "spring): stewart-pin's spherical joints are ideal; remove them",
                    tuple(link_names(e1.child) + link_names(e2.child)),
                    tuple(h.name for h in hinges),
                )
        for inner in (e1.child, e2.child):
            if np.any(links[inner].inertia != 0.0):
                dropped.append(
                    f"{_names(link_names(inner))}: mass {links[inner].inertia[9]:.3g} kg "
                    "(a massless body of a three-hinge spherical joint)"
                )
        sph = Edge(e1.parent, e3.child, e3.joint, e3.body, hinges, (e1.child, e2.child))
        sph.centre_child = _in_link(links[e3.child], model, e3.body, centre)
        sph.centre_parent = _in_link(links[e1.parent], model, model.bodies[e1.body].parent, centre)
        used.update({id(e1), id(e2), id(e3)})
        merged.append(sph)
        for h in hinges:
            if math.isfinite(h.lower) or math.isfinite(h.upper):
                model.notes.append(
                    f"the limits of hinge {shown(h.name)} of a spherical joint are ignored"
                )
    edges = [e for e in edges if id(e) not in used] + merged
    for e in edges:
        if e.joint.kind == BALL and e.joint.has_terms:
            raise ModelImportError(
                f"ball joint {shown(e.joint.name)} carries joint terms (armature, damping, "
                "friction or a spring): stewart-pin's spherical joints are ideal; remove them",
                tuple(link_names(e.child)),
                (e.joint.name,),
            )
        if e.joint.kind == BALL and e.joint.limited:
            model.notes.append(f"the cone limit of ball joint {shown(e.joint.name)} is ignored")

    # spherical connections
    connections: list[Connection] = []
    for e in edges:
        if e.spherical:
            connections.append(
                Connection(e.parent, e.child, e.centre_parent, e.centre_child, e.label, edge=e)
            )
    for c in model.closures:
        if c.kind != "point":
            continue
        a, b = link_of[c.body1], link_of[c.body2]
        if a == b:
            raise ModelImportError(
                f"loop closure {shown(c.name)} joins two bodies of one rigid link "
                f"({shown(model.body_label(c.body1))}, {shown(model.body_label(c.body2))})",
                (model.body_label(c.body1), model.body_label(c.body2)),
                (c.name,),
            )
        pa = links[a].rel[c.body1][:3, :3] @ c.point1 + links[a].rel[c.body1][:3, 3]
        pb = links[b].rel[c.body2][:3, :3] @ c.point2 + links[b].rel[c.body2][:3, 3]
        connections.append(Connection(a, b, pa, pb, f"closure {shown(c.name)}", closure=c))

    # the platform
    count: dict[int, int] = {}
    for cn in connections:
        for i in (cn.a, cn.b):
            if i != ground:
                count[i] = count.get(i, 0) + 1
    if forced is not None:
        P = forced
    else:
        six = [i for i, n in count.items() if n == 6]
        if len(six) != 1:
            best = max(count.items(), key=lambda kv: kv[1], default=(None, 0))
            if best[0] is not None:
                _weld_where_a_ball_should_be(model, links, link_of, edges, best[0])
            where = (
                f"the link of {_names(link_names(best[0]))} has {best[1]}"
                if best[0] is not None
                else "none has any"
            )
            raise ModelImportError(
                f"not six legs: stewart-pin looks for the platform as the one body with six "
                f"spherical joints to legs (ball joints, three hinges through one point, or "
                f"point closures); {where}"
                + (f", and {len(six)} links have six" if len(six) > 1 else ""),
                tuple(link_names(best[0])) if best[0] is not None else (),
            )
        P = six[0]
    if P == ground:
        raise ModelImportError(
            f"the platform {shown(platform or '')} is fixed to the base", (platform or "",)
        )
    at_platform = [cn for cn in connections if P in (cn.a, cn.b)]
    if len(at_platform) != 6:
        raise ModelImportError(
            f"not six legs: the platform {_names(link_names(P))} has {len(at_platform)} "
            "spherical joints to legs, stewart-pin needs six",
            tuple(link_names(P)),
        )

    # edges into each link (the tree's parent side, spherical closures excluded)
    into: dict[int, list[Edge]] = {}
    for e in edges:
        into.setdefault(e.child, []).append(e)
    for e in into.get(P, []):
        if not e.spherical and e.joint.one_dof:
            welds = [
                c.name
                for c in model.closures
                if c.kind == "weld" and P in (link_of[c.body1], link_of[c.body2])
            ]
            raise ModelImportError(
                f"the platform {_names(link_names(P))} is joined to body "
                f"{shown(model.body_label(model.bodies[e.body].parent))} by the "
                f"{e.joint.kind} joint {shown(e.joint.name)}, not by a spherical joint"
                + (
                    f" (through the weld(s) {_names(welds)}: a closure must be a point, a "
                    "connect, or the weld of a rod end that carries a ball joint; a weld "
                    "where a ball should be)"
                    if welds
                    else ""
                ),
                tuple(link_names(P)),
                (e.joint.name, *welds),
            )

    legs: list[LegChain] = []
    seen: dict[int, int] = {}
    for k, cn in enumerate(at_platform):
        X = cn.b if cn.a == P else cn.a
        chain: list[Edge] = []
        cur = X
        guard = 0
        while cur != ground:
            guard += 1
            tree = into.get(cur, [])
            if cur == P:
                raise ModelImportError(
                    f"a leg hangs from the platform {_names(link_names(P))}: stewart-pin reads "
                    "each leg from the base up; write the tree from the base",
                    tuple(link_names(P)),
                )
            if not tree:
                raise ModelImportError(
                    f"body {_names(link_names(cur))} has no joint to the base: it is not part "
                    "of a leg",
                    tuple(link_names(cur)),
                )
            if len(tree) > 1:
                raise ModelImportError(
                    f"bodies {_names(link_names(cur))} are joined to the rest by "
                    f"{len(tree)} joints ({_names([e.joint.name for e in tree])}): a leg is a "
                    "serial chain",
                    tuple(link_names(cur)),
                    tuple(e.joint.name for e in tree),
                )
            e = tree[0]
            if e.joint.kind == FREE:
                raise ModelImportError(
                    f"a floating base: the legs start from {_names(link_names(cur))}, which "
                    f"has the free joint {shown(e.joint.name)}; weld that body to the world "
                    "(remove its free joint) so the base is fixed",
                    tuple(link_names(cur)),
                    (e.joint.name,),
                )
            if cur in seen:
                raise ModelImportError(
                    f"legs {seen[cur] + 1} and {k + 1} share the bodies "
                    f"{_names(link_names(cur))}: each leg is its own chain",
                    tuple(link_names(cur)),
                )
            seen[cur] = k
            chain.insert(0, e)
            cur = e.parent
            if guard > len(links):
                break  # pragma: no cover (a tree has no cycle)
        shape = "".join("S" if e.spherical else "J" for e in chain)
        joints_desc = ", ".join(f"{e.label}" for e in chain)
        if shape not in ("JJJ", "JS", "SJ"):
            n1 = shape.count("J")
            raise ModelImportError(
                f"leg ending at the platform through {cn.label}: from the base it has "
                f"{n1} one-dof joint(s) and {shape.count('S')} spherical joint(s) "
                f"({joints_desc or 'none'}); stewart-pin reads three 1-dof joints (hinges, "
                "slides) then the spherical joint, or a rod between two spherical joints "
                "(R-S-S, P-S-S, S-P-S)",
                tuple(n for e in chain for n in link_names(e.child)),
                tuple(e.joint.name for e in chain),
            )
        legs.append(LegChain(chain, cn, shape, [e.child for e in chain]))

    # anything else that moves
    in_legs = {i for leg in legs for i in leg.links} | {
        i for leg in legs for e in leg.edges for i in e.inner
    }
    extra = [i for i in range(len(links)) if i not in in_legs and i not in (ground, P)]
    # the inner links of merged hinge joints at the platform
    for cn in at_platform:
        if cn.edge is not None:
            extra = [i for i in extra if i not in cn.edge.inner]
    if extra:
        names = [n for i in extra for n in link_names(i)]
        joints = [
            model.bodies[b].joint.name  # type: ignore[union-attr]
            for i in extra
            for b in links[i].bodies
            if model.bodies[b].joint is not None
        ]
        raise ModelImportError(
            f"extra moving bodies {_names(names)} (joints {_names(joints)}): stewart-pin "
            "models the platform, six legs and bodies fixed to them; remove these bodies, "
            "or fix them to the platform or a leg (no joint)",
            tuple(names),
            tuple(joints),
        )
    return Recognition(links, link_of, ground, P, legs, scale, mass, dropped)


def _weld_where_a_ball_should_be(
    model: KinematicModel, links: list[Link], link_of: list[int], edges: list[Edge], P: int
) -> None:
    """Raise the error of a weld that joins a body moved by a 1-dof joint to the link
    ``P`` (the platform's): a leg closed rigidly where a spherical joint should be."""
    for e in edges:
        if e.child != P or e.spherical or not e.joint.one_dof:
            continue
        body = e.body
        welds = [
            c
            for c in model.closures
            if c.kind == "weld" and link_of[c.body1] == P and link_of[c.body2] == P
        ]
        if welds:
            names = tuple(c.name for c in welds)
            raise ModelImportError(
                f"body {shown(model.body_label(body))} (moved by the {e.joint.kind} joint "
                f"{shown(e.joint.name)}) is welded to the platform by {_names(names)}: a "
                "closure must be a point (a connect), or the weld of a rod end that carries a "
                "ball joint (or three hinges); a weld where a ball should be",
                (model.body_label(body),),
                (e.joint.name, *names),
            )


def _reroot(link: Link, root: int) -> Link:
    """The link with its frame moved to body ``root``'s (the platform asked for)."""
    T = np.linalg.inv(link.rel[root])
    rel = {b: T @ R for b, R in link.rel.items()}
    inertia = transform_inertia(link.inertia, T)
    return Link(root, link.bodies, rel, inertia)


def _in_link(link: Link, model: KinematicModel, body: int, point: np.ndarray) -> np.ndarray:
    """``point`` (F0, zero configuration, a point of ``body``) in the link's frame."""
    T = link.rel[body] @ np.linalg.inv(model.bodies[body].pose)
    return T[:3, :3] @ point + T[:3, 3]


def _meeting_point(hinges: Sequence[TreeJoint]) -> np.ndarray | None:
    """The point nearest to the three lines, if each passes within
    :data:`INTERSECTION_TOLERANCE` of the lines' spread; else ``None``."""
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for h in hinges:
        Pm = np.eye(3) - np.outer(h.axis, h.axis)
        A += Pm
        b += Pm @ h.anchor
    try:
        c = np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return None
    spread = max(float(np.linalg.norm(h.anchor - c)) for h in hinges) + 1e-3
    for h in hinges:
        v = c - h.anchor
        if np.linalg.norm(v - (v @ h.axis) * h.axis) > INTERSECTION_TOLERANCE * max(spread, 1.0):
            return None
    return c


def _coplanar(hinges: Sequence[TreeJoint]) -> bool:
    return abs(float(np.linalg.det(np.array([h.axis for h in hinges])))) < 1e-6


# ------------------------------------------------------------------------------ build
@dataclass
class LegReport:
    """One leg as imported (names as in the file)."""

    shape: str
    kinds: tuple[str, str, str]
    joints: tuple[str, str, str]
    bodies: tuple[str, str, str]
    actuated: int
    actuator: str
    gear: float
    spherical: str
    residual: float
    spin_inertia: float
    spin_asymmetry: float
    dynamics: tuple[JointDynamics, ...]
    architecture: str


@dataclass
class ImportReport:
    """What an import recognised, corrected and ignored (``str()`` prints it)."""

    format: str
    file: str
    model: str
    reference: str
    platform: str
    base: str
    legs: list[LegReport]
    lumped: dict[str, list[str]]
    notes: list[str]
    closure_tolerance: float
    ideal: bool
    architecture: str

    @property
    def residuals(self) -> np.ndarray:
        """Loop residuals at the reference configuration, leg order (6,) [m]."""
        return np.array([leg.residual for leg in self.legs])

    def __str__(self) -> str:
        kind = "ideal 6-UPS" if self.ideal else f"{self.architecture} legs"
        lines = [
            f"{self.format.upper()} model {shown(self.model)}"
            + (f" ({shown(self.file)})" if self.file else "")
            + f": {kind}, platform {shown(self.platform)} (Fp), base {shown(self.base)} (F0)",
            f"reference configuration: {self.reference}; loop residuals [m] (tolerance "
            f"{self.closure_tolerance:.3g} m): " + " ".join(f"{r:.2e}" for r in self.residuals),
        ]
        for i, leg in enumerate(self.legs, start=1):
            joints = ", ".join(
                f"{shown(n)} ({k[0].upper()}{'*' if j + 1 == leg.actuated else ''})"
                for j, (n, k) in enumerate(zip(leg.joints, leg.kinds, strict=True))
            )
            gear = f", gear {leg.gear:g}" if leg.gear != 1.0 else ""
            lines.append(
                f"leg {i} ({leg.architecture}, {leg.shape}): {joints}; actuator "
                f"{shown(leg.actuator)}{gear}; spherical: {leg.spherical}"
            )
            terms = []
            for j, d in enumerate(leg.dynamics, start=1):
                parts = [
                    f"{k} {getattr(d, k):.4g}"
                    for k in ("armature", "viscous", "coulomb", "stiffness", "damping")
                    if getattr(d, k) != 0.0
                ]
                if d.stiffness:
                    parts.append(f"rest {d.rest_position:.4g}")
                if parts:
                    terms.append(f"q{j}: " + ", ".join(parts))
            if terms:
                lines.append("    joint terms: " + "; ".join(terms))
            if leg.spin_inertia or leg.spin_asymmetry:
                lines.append(
                    f"    rod spin removed: {leg.spin_inertia:.4g} kg m^2 about its axis "
                    f"(asymmetry {leg.spin_asymmetry:.2e})"
                )
        for where, names in self.lumped.items():
            if names:
                lines.append(f"lumped into {where}: {_names(names)}")
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)


@dataclass
class ImportResult:
    """The imported description and its report."""

    description: RobotDescription
    report: ImportReport


def robot_name(name: str) -> str:
    """A valid robot name from a model's name: kept when valid, else its characters
    outside ``A-Z a-z 0-9 _ . -`` replaced by ``_`` (``"imported"`` when nothing is left)."""
    try:
        return check_robot_name(name)
    except RobotNameError:
        pass
    text = "".join(c if c.isascii() and (c.isalnum() or c in "_.-") else "_" for c in name)
    while ".." in text or "--" in text:
        text = text.replace("..", "_").replace("--", "_")
    text = text.lstrip("_.-")[:64]
    return text if text and NAME_PATTERN.fullmatch(text) else "imported"


def rod_asymmetry(params: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> tuple[float, float]:
    """``(spin inertia, asymmetry)`` of a body (Khalil parameters in some frame) about the
    line through ``origin`` along the unit ``axis`` (same frame).

    The spin inertia is the moment about the line [kg m^2]; the asymmetry is
    ``max(|Ixx - Iyy|, 2 |Ixy|, 2 |Ixz|, 2 |Iyz|) / max(Ixx, Iyy)`` of the tensor about
    ``origin`` in axes whose z is the line, plus ``M |c_perp| / (M L)`` with ``c_perp``
    the centre of mass's distance from the line and L the scale ``sqrt(max(Ixx, Iyy) /
    M)``: 0 exactly when the body's inertia is symmetric about the line (then removing
    its spin is exact)."""
    T = _line_frame(origin, axis)
    p = transform_inertia(params, np.linalg.inv(T))
    Ixx, Ixy, Ixz, Iyy, Iyz, Izz = p[:6]
    m = p[9]
    big = max(Ixx, Iyy)
    if m <= 0.0 or big <= 0.0:
        return float(Izz), 0.0
    asym = max(abs(Ixx - Iyy), 2 * abs(Ixy), 2 * abs(Ixz), 2 * abs(Iyz)) / big
    L = math.sqrt(big / m)
    offset = math.hypot(p[6], p[7]) / (m * L)
    return float(Izz), float(max(asym, offset))


def _line_frame(origin: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A frame (4x4) at ``origin`` whose z is the unit ``axis``."""
    z = axis / np.linalg.norm(axis)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = origin
    return T


def remove_spin(params: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The body (Khalil parameters) without its spin about the line through ``origin``
    along ``axis``: in axes along the line, about a point of it, the tensor made
    symmetric about the line (``XX = YY`` their mean, products 0, first moments across the
    line 0: nothing changes for a symmetric body) and the moment about the line ``ZZ``
    set to 0, i.e. ``I - I_a a a^T``."""
    T = _line_frame(origin, axis)
    p = transform_inertia(params, np.linalg.inv(T))
    t = 0.5 * (p[0] + p[3])
    q = np.array([t, 0.0, 0.0, t, 0.0, 0.0, 0.0, 0.0, p[8], p[9]])
    return transform_inertia(q, T)


def build(
    model: KinematicModel,
    rec: Recognition,
    *,
    actuated: Sequence[str] | None = None,
    armature: dict[str, float] | None = None,
    name: str | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    spin_tolerance: float = SPIN_TOLERANCE,
    rod_spin: str = "error",
    joint_terms: Callable[[str], JointDynamics | None] | None = None,
    limits: Callable[[str], tuple[float, float] | None] | None = None,
) -> ImportResult:
    """The description of a recognised model (module docstring).

    Args:
        actuated: the actuated joints' names in leg order (default the model's actuators,
            in their order).
        armature: joint name -> armature [kg m^2 or kg] to add (URDF cannot say it).
        name: the robot's name (default the model's, made valid by :func:`robot_name`).
        closure_tolerance: the largest loop residual accepted, relative to the platform's
            size (:data:`CLOSURE_TOLERANCE`).
        spin_tolerance, rod_spin: see :data:`SPIN_TOLERANCE`; ``rod_spin`` is ``"error"``
            (raise :class:`RodSpinError` past the tolerance) or ``"warn"``.
        joint_terms: joint name -> its full :class:`JointDynamics` when the reader knows
            more than the tree (the project's own URDF sidecar), else ``None``.
        limits: joint name -> its true limits when the reader knows them, else ``None``.
    """
    if rod_spin not in ("error", "warn"):
        raise ModelImportError(f"rod_spin must be 'error' or 'warn', got {rod_spin!r}")
    links, P = rec.links, rec.platform
    bodies = model.bodies
    ref_poses = model.poses()
    zero = np.array([b.pose for b in bodies])

    def link_zero(i: int) -> np.ndarray:
        lk = links[i]
        return zero[lk.root] @ np.linalg.inv(lk.rel[lk.root])

    def link_ref(i: int) -> np.ndarray:
        lk = links[i]
        return ref_poses[lk.root] @ np.linalg.inv(lk.rel[lk.root])

    def link_names(i: int) -> list[str]:
        return [model.body_label(b) for b in links[i].bodies if not bodies[b].virtual]

    # actuators -> (leg, joint name)
    leg_of_joint: dict[str, int] = {}
    for k, leg in enumerate(rec.legs):
        for e in leg.edges:
            if not e.spherical:
                leg_of_joint[e.joint.name] = k
    spherical_joints = {
        h.name: k
        for k, leg in enumerate(rec.legs)
        for e in [*leg.edges, *([leg.connection.edge] if leg.connection.edge else [])]
        if e.spherical
        for h in (e.hinges or (e.joint,))
    }
    if actuated is not None:
        acts = [TreeActuator(str(n), str(n)) for n in actuated]
        gears = {a.joint: a.gear for a in model.actuators}
        for a in acts:
            a.gear = gears.get(a.joint, 1.0)
            a.name = next((x.name for x in model.actuators if x.joint == a.joint), a.name)
    else:
        acts = list(model.actuators)
    all_joints = {b.joint.name for b in bodies if b.joint is not None}
    order: list[int] = []
    act_of_leg: dict[int, TreeActuator] = {}
    for a in acts:
        if a.joint in spherical_joints:
            raise ModelImportError(
                f"actuator {shown(a.name)} drives {shown(a.joint)}, a joint of the spherical "
                f"joint of leg {spherical_joints[a.joint] + 1} (a passive joint): actuate "
                "one of the leg's three 1-dof joints",
                (),
                (a.name, a.joint),
            )
        if a.joint not in leg_of_joint:
            what = "no joint of the model" if a.joint not in all_joints else "not a leg joint"
            raise ModelImportError(
                f"actuator {shown(a.name)} drives {shown(a.joint)}, {what}: actuate one 1-dof "
                "joint of each leg",
                (),
                (a.name, a.joint),
            )
        k = leg_of_joint[a.joint]
        if k in act_of_leg:
            if act_of_leg[k].joint != a.joint:
                raise ModelImportError(
                    f"leg through {shown(act_of_leg[k].joint)} has two actuated joints "
                    f"({shown(act_of_leg[k].joint)} by {shown(act_of_leg[k].name)}, "
                    f"{shown(a.joint)} by {shown(a.name)}): stewart-pin actuates one joint "
                    "per leg",
                    (),
                    (act_of_leg[k].joint, a.joint),
                )
            model.notes.append(
                f"actuator {shown(a.name)} drives the same joint as "
                f"{shown(act_of_leg[k].name)}: the leg's efforts are those of its joint"
            )
            continue
        if not a.gear > 0 or not math.isfinite(a.gear):
            raise ModelImportError(
                f"actuator {shown(a.name)} has gear {a.gear:g}: stewart-pin's efforts are "
                "along each joint's positive direction, through a positive ratio",
                (),
                (a.name,),
            )
        act_of_leg[k] = a
        order.append(k)
    missing = [k for k in range(6) if k not in act_of_leg]
    if missing:
        idle = [
            n
            for k in missing
            for e in rec.legs[k].edges
            for n in ([e.joint.name] if not e.spherical else [])
        ]
        raise ModelImportError(
            f"{len(missing)} leg(s) without an actuator (joints {_names(idle)}): each leg "
            "needs one actuated 1-dof joint"
            + (
                " (give them with actuated=[...] or <transmission>)"
                if model.format == "urdf"
                else ""
            ),
            tuple(n for k in missing for n in link_names(rec.legs[k].links[-1])),
            tuple(idle),
        )

    # platform
    plat = links[P]
    platform_inertia = plat.inertia.copy()
    T_home = link_ref(P)
    size_points = []
    legs_out: list[LegArchitecture] = []
    leg_inertia = np.zeros((6, 3, 10))
    base_rot = np.zeros((6, 3, 3))
    base_pts = np.zeros((6, 3))
    plat_pts = np.zeros((6, 3))
    reports: list[LegReport] = []
    sources: list[LegSource] = []
    residual_points: list[tuple[np.ndarray, np.ndarray]] = []
    for k in order:
        leg = rec.legs[k]
        cn = leg.connection
        X = cn.b if cn.a == P else cn.a
        tip_in_X = cn.point_a if cn.a == X else cn.point_b
        p_in_P = cn.point_b if cn.a == X else cn.point_a
        plat_pts[len(reports)] = p_in_P
        size_points.append(p_in_P)
        tip_zero = link_zero(X)[:3, :3] @ tip_in_X + link_zero(X)[:3, 3]
        # the loop at the reference configuration: both sides of the spherical joint
        side_leg = link_ref(X)[:3, :3] @ tip_in_X + link_ref(X)[:3, 3]
        side_plat = T_home[:3, :3] @ p_in_P + T_home[:3, 3]
        residual_points.append((side_leg, side_plat))

        # the three joints (lines at zero) and their links
        kinds: list[str] = []
        anchors: list[np.ndarray] = []
        axes: list[np.ndarray] = []
        names: list[str] = []
        link_bodies: list[str] = []
        link_params: list[np.ndarray] = []  # in F0 at zero configuration (T = identity)
        refs: list[float | None] = []
        file_joints: list[TreeJoint | None] = []
        spin_I = asym = 0.0
        if leg.shape == "JJJ":
            for e in leg.edges:
                kinds.append(e.joint.kind)
                anchors.append(e.joint.anchor)
                axes.append(e.joint.axis)
                names.append(e.joint.name)
                file_joints.append(e.joint)
                link_bodies.append(", ".join(link_names(e.child)))
                link_params.append(transform_inertia(links[e.child].inertia, link_zero(e.child)))
                refs.append(model.values.get(e.joint.name, 0.0))
        else:
            spin_I, asym = 0.0, 0.0
            if leg.shape == "JS":
                e1, s1 = leg.edges
                C = link_zero(s1.parent)[:3, :3] @ s1.centre_parent + link_zero(s1.parent)[:3, 3]
            else:
                s1, e1 = leg.edges
                C = link_zero(s1.parent)[:3, :3] @ s1.centre_parent + link_zero(s1.parent)[:3, 3]
            d = tip_zero - C
            if np.linalg.norm(d) <= 1e-9 * rec.scale:
                raise ModelImportError(
                    f"the two spherical joints of a rod ({s1.label}, {cn.label}) have one centre",
                    tuple(link_names(s1.child)),
                )
            d = d / np.linalg.norm(d)
            rod_links = [s1.child] if leg.shape == "JS" else [s1.child, e1.child]
            if leg.shape == "SJ":
                if (
                    e1.joint.kind != PRISMATIC
                    or np.linalg.norm(np.cross(e1.joint.axis, d)) > AXIS_TOLERANCE
                ):
                    raise ModelImportError(
                        f"leg through {s1.label} and {e1.label}: between two spherical joints "
                        "stewart-pin reads a slide along the line through their centres "
                        "(S-P-S)",
                        tuple(link_names(e1.child)),
                        (e1.joint.name,),
                    )
            removed = []
            for li in rod_links:
                params0 = transform_inertia(links[li].inertia, link_zero(li))
                s_I, s_a = rod_asymmetry(params0, C, d)
                spin_I += s_I
                asym = max(asym, s_a)
                removed.append(remove_spin(params0, C, d))
            if asym > spin_tolerance:
                rod_names = [n for li in rod_links for n in link_names(li)]
                message = (
                    f"leg through {s1.label}: the rod {_names(rod_names)} "
                    f"between two spherical joints is not symmetric about its axis (asymmetry "
                    f"{asym:.3g} > {spin_tolerance:g}): the equivalent universal-joint leg "
                    "(spin removed) is not exact"
                )
                if rod_spin == "error":
                    raise RodSpinError(
                        message + "; pass rod_spin='warn' to import it anyway (its inertia made "
                        "symmetric)",
                        asym,
                        spin_tolerance,
                        tuple(n for li in rod_links for n in link_names(li)),
                    )
                warnings.warn(
                    message + "; its inertia is made symmetric", ModelImportWarning, stacklevel=3
                )
            if leg.shape == "JS":
                z1 = e1.joint.axis
                if e1.joint.kind == REVOLUTE:
                    u1 = z1 - (z1 @ d) * d
                else:
                    u1 = np.cross(z1, d)
                if np.linalg.norm(u1) < 1e-6:
                    u1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
                u1 = u1 / np.linalg.norm(u1)
                u2 = np.cross(d, u1)
                kinds = [e1.joint.kind, REVOLUTE, REVOLUTE]
                anchors = [e1.joint.anchor, C, C]
                axes = [e1.joint.axis, u1, u2]
                base_name = s1.joint.name if not s1.hinges else s1.hinges[0].name
                names = [e1.joint.name, f"{base_name} (U axis 1)", f"{base_name} (U axis 2)"]
                file_joints = [e1.joint, None, None]
                link_bodies = [
                    ", ".join(link_names(e1.child)),
                    "",
                    ", ".join(link_names(s1.child)),
                ]
                link_params = [
                    transform_inertia(links[e1.child].inertia, link_zero(e1.child)),
                    np.zeros(10),
                    removed[0],
                ]
                refs = [model.values.get(e1.joint.name, 0.0), None, None]
            else:
                z_up = np.array([0.0, 0.0, 1.0])
                u1 = np.cross(z_up, d)
                if np.linalg.norm(u1) < 1e-6:
                    u1 = np.cross([1.0, 0.0, 0.0], d)
                u1 /= np.linalg.norm(u1)
                u2 = np.cross(d, u1)
                kinds = [REVOLUTE, REVOLUTE, PRISMATIC]
                anchors = [C, C, e1.joint.anchor]
                axes = [u1, u2, e1.joint.axis]
                base_name = s1.joint.name if not s1.hinges else s1.hinges[0].name
                names = [f"{base_name} (U axis 1)", f"{base_name} (U axis 2)", e1.joint.name]
                file_joints = [None, None, e1.joint]
                link_bodies = [
                    "",
                    ", ".join(link_names(s1.child)),
                    ", ".join(link_names(e1.child)),
                ]
                link_params = [np.zeros(10), removed[0], removed[1]]
                refs = [None, None, model.values.get(e1.joint.name, 0.0)]

        try:
            chain = canonical_chain(kinds, anchors, axes, tip_zero, rec.scale, names)
        except ArchitectureError as err:
            raise ModelImportError(str(err), tuple(link_bodies), tuple(names)) from err
        if chain.snapped > PARALLEL_NOTICE:
            warnings.warn(
                f"leg through {_names(names)}: two joint axes {chain.snapped:.2g} rad from "
                "parallel are made parallel (the file's rounding, as read; the robot turns "
                "by that angle; see docs/importing.md)",
                ModelImportWarning,
                stacklevel=3,
            )
            model.notes.append(
                f"axes of {_names(names)} made parallel (turned by {chain.snapped:.2g} rad)"
            )
        joints: list[Joint] = []
        dyns: list[JointDynamics] = []
        a_act = act_of_leg[k]
        actuated_index = names.index(a_act.joint) + 1 if a_act.joint in names else 0
        if actuated_index == 0:
            raise ModelImportError(
                f"actuator {shown(a_act.name)} drives {shown(a_act.joint)}, not one of the "
                f"leg's joints {_names(names)}",
                (),
                (a_act.name,),
            )
        for j in range(3):
            J = file_joints[j]
            lo, hi = (-math.inf, math.inf) if J is None else (J.lower, J.upper)
            if J is not None and limits is not None and (lim := limits(J.name)) is not None:
                lo, hi = lim
            dyn = JointDynamics()
            if J is not None:
                full = joint_terms(J.name) if joint_terms is not None else None
                if full is not None:
                    dyn = full
                else:
                    gear = a_act.gear if j + 1 == actuated_index else 1.0
                    extra = (armature or {}).get(J.name, 0.0)
                    try:
                        dyn = JointDynamics(
                            armature=J.armature + float(extra),
                            viscous=J.damping,
                            coulomb=J.coulomb,
                            stiffness=J.stiffness,
                            rest_position=J.rest if J.stiffness else 0.0,
                            gear_ratio=gear if gear != 1.0 else None,
                        )
                    except JointDynamicsError as err:
                        raise ModelImportError(
                            f"joint {shown(J.name)}: {err}", (), (J.name,)
                        ) from err
            dyns.append(dyn)
            try:
                alpha, d_j, theta, r_j = (float(v) for v in chain.params[j])
                joints.append(Joint(kinds[j], alpha, d_j, theta, r_j, lo, hi, dyn))
            except ArchitectureError as err:
                raise ModelImportError(f"joint {shown(names[j])}: {err}", (), (names[j],)) from err
        # link inertias in the canonical frames
        for j in range(3):
            leg_inertia[len(reports), j] = transform_inertia(
                link_params[j], np.linalg.inv(chain.frames[j])
            )
        # reference joint values (the U angles of an S-S leg solved from the rod)
        q_ref = _reference_values(
            joints,
            actuated_index,
            chain,
            refs,
            side_leg if leg.shape == "JJJ" else side_plat,
            T_home,
            p_in_P,
        )
        arch = classify(tuple(joints), actuated_index, chain.tip, q_ref)
        arch = arch.replace(branch=arch.branch_at(q_ref))
        legs_out.append(arch)
        base_rot[len(reports)] = chain.base[:3, :3]
        base_pts[len(reports)] = chain.base[:3, 3]
        spherical = cn.label
        if cn.edge is not None and cn.edge.child == P and cn.edge.joint.kind == BALL:
            b_rod_end = bodies[cn.edge.body]
            if links[P].root != cn.edge.body:
                spherical += f" in rod end {shown(b_rod_end.name)}"
        reports.append(
            LegReport(
                {
                    "JJJ": "three 1-dof joints",
                    "JS": "R-S-S" if kinds[0] == REVOLUTE else "P-S-S",
                    "SJ": "S-P-S",
                }[leg.shape],
                (kinds[0], kinds[1], kinds[2]),
                (names[0], names[1], names[2]),
                (link_bodies[0], link_bodies[1], link_bodies[2]),
                actuated_index,
                a_act.name,
                a_act.gear,
                spherical,
                0.0,
                spin_I,
                asym if leg.shape != "JJJ" else 0.0,
                tuple(dyns),
                arch.name,
            )
        )
        sources.append(
            LegSource(
                (link_bodies[0], link_bodies[1], link_bodies[2]),
                (names[0], names[1], names[2]),
                a_act.name,
                spherical,
            )
        )

    # loop residuals at the reference configuration
    Pp = np.array(size_points)
    size = float(np.linalg.norm(Pp - Pp.mean(0), axis=1).mean()) or rec.scale
    tol = closure_tolerance * size
    residuals = np.array([float(np.linalg.norm(a - b)) for a, b in residual_points])
    for rep, r in zip(reports, residuals, strict=True):
        rep.residual = float(r)
    if np.any(residuals > tol):
        bad = [f"leg {i + 1}: {r:.3g} m" for i, r in enumerate(residuals)]
        raise LoopClosureError(
            f"the loops do not close at the reference configuration ({model.reference}): "
            f"{'; '.join(bad)} (tolerance {tol:.3g} m = {closure_tolerance:g} of the platform's "
            "size); give the assembled configuration (a keyframe, or fix the file), or raise "
            "closure_tolerance",
            tuple(residuals),
            tol,
        )
    if np.any(residuals > EXACT_CLOSURE * size):
        warnings.warn(
            f"model {shown(model.name)}: the loops close at the reference configuration "
            f"({model.reference}) only to {residuals.max():.3g} m (per leg: "
            f"{', '.join(f'{r:.2e}' for r in residuals)}; tolerance {tol:.3g} m): the robot is "
            "assembled at the platform's reference pose, each leg re-solved",
            ModelImportWarning,
            stacklevel=3,
        )

    lumped = {
        "the platform": [n for n in link_names(P) if n != model.body_label(links[P].root)],
        "the base": [n for n in link_names(rec.ground) if n != model.body_label(0)],
    }
    for k in order:
        for li in rec.legs[k].links:
            fixed = [n for n in link_names(li) if n != model.body_label(links[li].root)]
            if fixed:
                lumped.setdefault("leg links", []).extend(fixed)
    notes = list(model.notes) + [f"dropped {x}" for x in rec.dropped]

    robot = robot_name(model.name) if name is None else check_robot_name(name)
    source = ModelSource(
        model.format,
        model.file,
        model.name,
        model.reference,
        model.base_name,
        model.body_label(links[P].root),
        tuple(n for names_ in lumped.values() for n in names_),
        tuple(sources),
    )
    try:
        desc, ideal = _description(
            robot,
            base_pts,
            base_rot,
            plat_pts,
            legs_out,
            leg_inertia,
            platform_inertia,
            model.gravity,
            T_home,
            source,
        )
    except DescriptionError as err:
        where = getattr(err, "body", "")
        match = re.fullmatch(r"leg (\d) link (\d)", where)
        names_ = [sources[int(match[1]) - 1].bodies[int(match[2]) - 1]] if match else []
        if where == "platform":
            names_ = [source.platform]
        raise ModelImportError(
            f"the robot read from the file is not valid: {err}"
            + (f" (the file's body {_names(names_)})" if names_ else ""),
            tuple(names_),
        ) from err
    architectures = {leg.name for leg in legs_out}
    report = ImportReport(
        model.format,
        model.file,
        model.name,
        model.reference,
        model.body_label(links[P].root),
        model.base_name,
        reports,
        lumped,
        notes,
        tol,
        ideal,
        architectures.pop() if len(architectures) == 1 else "mixed",
    )
    return ImportResult(desc, report)


def _reference_values(
    joints: list[Joint],
    actuated: int,
    chain: Any,
    refs: list[float | None],
    target: np.ndarray,
    T_home: np.ndarray,
    p_in_P: np.ndarray,
) -> np.ndarray:
    """The leg's joint values at the reference configuration: the file's values, the
    unknown ones (an S-S leg's universal joint) solved by Gauss-Newton so that the tip
    reaches ``target`` (F0) with the known ones fixed."""
    q = np.array([0.0 if r is None else float(r) for r in refs])
    free = [j for j, r in enumerate(refs) if r is None]
    if not free:
        return q
    leg = LegArchitecture(tuple(joints), actuated, chain.tip, 1, "custom")
    for _ in range(50):
        err = leg.tip_position(q, chain.base) - target
        if np.linalg.norm(err) < 1e-15:
            break
        J = np.empty((3, len(free)))
        h = 1e-7
        for c, j in enumerate(free):
            dq = q.copy()
            dq[j] += h
            J[:, c] = (leg.tip_position(dq, chain.base) - leg.tip_position(q, chain.base)) / h
        step = np.linalg.lstsq(J, -err, rcond=None)[0]
        q[free] += step
        if np.linalg.norm(step) < 1e-14:
            break
    q[free] = (q[free] + math.pi) % (2 * math.pi) - math.pi
    return q


def _description(
    name: str,
    base_points: np.ndarray,
    rotations: np.ndarray,
    platform_points: np.ndarray,
    legs: list[LegArchitecture],
    leg_inertia: np.ndarray,
    platform_inertia: np.ndarray,
    gravity: np.ndarray,
    home: np.ndarray,
    source: ModelSource,
) -> tuple[RobotDescription, bool]:
    """The description: the paper's ideal 6-UPS form when every leg is an ideal ``ups``
    leg on its +1 branch with one stroke and finite U-joint limits; general legs else."""
    ideal = all(
        leg.name == "ups"
        and leg.branch == 1
        and all(j.dynamics == JointDynamics() for j in leg.joints)
        for leg in legs
    )
    if ideal:
        stroke = np.array([[leg.joints[2].lower, leg.joints[2].upper] for leg in legs])
        u = np.array([[[j.lower, j.upper] for j in leg.joints[:2]] for leg in legs])
        ideal = (
            bool(np.all(stroke == stroke[0]))
            and bool(np.all(np.isfinite(stroke)))
            and 0.0 < stroke[0, 0] < stroke[0, 1]
            and bool(np.all(np.isfinite(u)))
        )
    if ideal:
        default = np.array([[-math.pi, math.pi], [0.0, math.pi]])
        u_limits = None if bool(np.all(u == default)) else u
        desc = RobotDescription(
            base_points=base_points,
            platform_points=platform_points,
            leg_base_rotations=rotations,
            stroke=stroke[0],
            leg_inertia=leg_inertia,
            platform_inertia=platform_inertia,
            gravity=gravity,
            u_joint_limits=u_limits,
            name=name,
            home_pose=home,
            source=source,
        )
        return desc, True
    desc = RobotDescription(
        base_points=base_points,
        platform_points=platform_points,
        leg_base_rotations=rotations,
        stroke=None,
        leg_inertia=leg_inertia,
        platform_inertia=platform_inertia,
        gravity=gravity,
        name=name,
        home_pose=home,
        legs=tuple(legs),
        source=source,
    )
    return desc, False


__all__ = [
    "BALL",
    "CLOSURE_TOLERANCE",
    "EXACT_CLOSURE",
    "FREE",
    "MASSLESS",
    "SPIN_TOLERANCE",
    "ImportReport",
    "ImportResult",
    "KinematicModel",
    "LegReport",
    "Recognition",
    "TreeActuator",
    "TreeBody",
    "TreeClosure",
    "TreeJoint",
    "build",
    "recognise",
    "robot_name",
]
