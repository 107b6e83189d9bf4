"""Recognition of a six-legged platform in a neutral kinematic tree
(:mod:`stewart_pin.importers.tree`): :func:`recognise`.

1. Bodies fixed to their parent (no joint) and bodies joined by a weld form one rigid
   link; its inertia is the exact sum of its bodies' (lumped). The link holding the world
   is the base.
2. Three hinges through one point with massless bodies between them (within
   :data:`MASSLESS` of the robot's mass scale) are a spherical joint, as is a ``ball``.
3. The platform is the link with six spherical connections (ball joints, three-hinge
   spherical joints, point closures); walking from each one back to the base gives a leg:
   three 1-dof joints then the spherical joint, or a rod between two spherical joints
   (R-S-S, P-S-S: a 1-dof joint, a spherical joint, the rod; S-P-S: a spherical joint at
   the base, a slide along the rod), which :mod:`stewart_pin.importers.build` replaces by
   the equivalent universal-joint leg.
4. Everything else that moves is an error naming its bodies; a model whose legs are not
   three joints and a spherical joint is then read by :mod:`stewart_pin.importers.chains`
   (chain legs, exactly).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from stewart_pin.description.leg_architecture import (
    REVOLUTE,
)
from stewart_pin.exceptions import (
    ModelImportError,
    ModelImportWarning,
)
from stewart_pin.importers.canonical import (
    transform_inertia,
)
from stewart_pin.importers.tree import (
    BALL,
    FREE,
    KinematicModel,
    TreeClosure,
    TreeJoint,
    shown,
    shown_list,
)

#: A body is massless when its mass is at most this fraction of the robot's total mass
#: and its inertia at most this fraction of that mass times the size squared (MuJoCo
#: refuses exactly massless moving bodies; files give them 1e-9 kg or so): its inertia is
#: dropped (reported).
MASSLESS = 1e-9
#: Three hinge axes meet in one point when each passes within this fraction of the size of
#: the point nearest to all three.
INTERSECTION_TOLERANCE = 1e-9
#: With ``approximate_legs``: three hinges whose axes pass within this fraction of the
#: size of one point are taken as a spherical joint at that point, whatever the mass of
#: the bodies between them (dropped) and their joint terms (dropped): the old
#: approximation of a spin + U-joint top by an ideal ball (reported with its effect).
APPROXIMATE_INTERSECTION = 1e-2


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
            return "hinges " + shown_list([h.name for h in self.hinges])
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
    approximated: list[str] = field(default_factory=list)


def union_links(model: KinematicModel) -> tuple[list[Link], list[int]]:
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


def length_scale(model: KinematicModel) -> float:
    """A length scale of the model [m]: the spread of the body origins and joint anchors
    at the reference configuration."""
    poses = model.poses()
    points = [T[:3, 3] for T in poses]
    P = np.array(points)
    s = float(np.linalg.norm(P - P.mean(0), axis=1).mean()) if len(P) > 1 else 0.0
    return s if s > 0 else 1.0


def recognise(
    model: KinematicModel, platform: str | None = None, approximate: bool = False
) -> Recognition:
    """Find the base, the platform and the six legs (module docstring); raises
    :class:`ModelImportError` naming the bodies and joints that do not fit. With
    ``approximate`` three hinges that nearly meet (:data:`APPROXIMATE_INTERSECTION`) with
    massive bodies between them or joint terms are taken as an ideal spherical joint
    (their masses and terms dropped, the miss reported in ``approximated``)."""
    links, link_of = union_links(model)
    ground = link_of[0]
    forced: int | None = None
    if platform is not None:  # the body whose frame is Fp: its link's frame
        matches = [b for b, body in enumerate(model.bodies) if body.name == platform]
        if not matches:
            raise ModelImportError(
                f"no body named {shown(platform)} (the platform asked for)", (platform,)
            )
        forced = link_of[matches[-1]]
        links[forced] = reroot(links[forced], matches[-1])
    scale = length_scale(model)
    moving = [lk for i, lk in enumerate(links) if i != ground]
    mass = float(sum(lk.inertia[9] for lk in moving)) or 1.0
    dropped: list[str] = []
    approximated: list[str] = []
    ref_poses = model.poses() if approximate else np.zeros((0, 4, 4))

    def massless(link: Link) -> bool:
        if approximate:
            return True
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
            e.centre_child = frame_in_link(links[ch], model, b, J.anchor)
            e.centre_parent = frame_in_link(links[pa], model, body.parent, J.anchor)
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
        tolerance = APPROXIMATE_INTERSECTION if approximate else INTERSECTION_TOLERANCE
        lines: tuple[TreeJoint, ...] = hinges
        if approximate:  # at the reference configuration (at zero they may be aligned)
            lines = tuple(_line_at(model, ref_poses, e.body) for e in (e1, e2, e3))
        centre = _meeting_point(lines, tolerance)
        if centre is None or _coplanar(lines):
            continue
        centre_child = centre_parent = centre
        if approximate:
            miss = _miss(lines)
            b3, b0 = e3.body, model.bodies[e1.body].parent
            back = [model.bodies[b].pose @ np.linalg.inv(ref_poses[b]) for b in (b3, b0)]
            centre_child = back[0][:3, :3] @ centre + back[0][:3, 3]
            centre_parent = back[1][:3, :3] @ centre + back[1][:3, 3]
            terms = [h.name for h in hinges if h.has_terms]
            mass = sum(float(links[i].inertia[9]) for i in (e1.child, e2.child))
            approximated.append(
                f"hinges {shown_list([h.name for h in hinges])} taken as an ideal spherical "
                f"joint (axes missing each other by up to {miss:.3g} m, {mass:.3g} kg between "
                "them dropped"
                + (f", joint terms of {shown_list(terms)} dropped" if terms else "")
                + ")"
            )
        for h in hinges:
            if h.has_terms and not approximate:
                raise ModelImportError(
                    f"hinges {shown_list([x.name for x in hinges])} make a spherical joint, but "
                    f"{shown(h.name)} carries joint terms (armature, damping, friction or a "
                    "spring): stewart-pin's spherical joints are ideal; remove them",
                    tuple(link_names(e1.child) + link_names(e2.child)),
                    tuple(h.name for h in hinges),
                )
        for inner in (e1.child, e2.child):
            if np.any(links[inner].inertia != 0.0):
                dropped.append(
                    f"{shown_list(link_names(inner))}: mass {links[inner].inertia[9]:.3g} kg "
                    "(a massless body of a three-hinge spherical joint)"
                )
        sph = Edge(e1.parent, e3.child, e3.joint, e3.body, hinges, (e1.child, e2.child))
        sph.centre_child = frame_in_link(links[e3.child], model, e3.body, centre_child)
        sph.centre_parent = frame_in_link(
            links[e1.parent], model, model.bodies[e1.body].parent, centre_parent
        )
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
                f"the link of {shown_list(link_names(best[0]))} has {best[1]}"
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
        platform_body(model, links, P, connections, edges)
    if P == ground:
        raise ModelImportError(
            f"the platform {shown(platform or '')} is fixed to the base", (platform or "",)
        )
    at_platform = [cn for cn in connections if P in (cn.a, cn.b)]
    if len(at_platform) != 6:
        raise ModelImportError(
            f"not six legs: the platform {shown_list(link_names(P))} has {len(at_platform)} "
            "spherical joints to legs, stewart-pin needs six",
            tuple(link_names(P)),
        )
    for cn in connections:
        stray = cn.closure
        if stray is not None and P not in (cn.a, cn.b):  # a loop no leg closes
            ends = (model.body_label(stray.body1), model.body_label(stray.body2))
            raise ModelImportError(
                f"loop closure {shown(stray.name)} joins {shown(ends[0])} and {shown(ends[1])}, "
                f"away from the platform {shown_list(link_names(P))}: stewart-pin models the "
                "six loops that close the legs at the platform; another loop (a body pinned "
                "to the base, two legs coupled) would be dropped and the robot would move "
                "where the file's cannot; remove it",
                ends,
                (stray.name,),
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
                f"the platform {shown_list(link_names(P))} is joined to body "
                f"{shown(model.body_label(model.bodies[e.body].parent))} by the "
                f"{e.joint.kind} joint {shown(e.joint.name)}, not by a spherical joint"
                + (
                    f" (through the weld(s) {shown_list(welds)}: a closure must be a point, a "
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
                    f"a leg hangs from the platform {shown_list(link_names(P))}: stewart-pin "
                    "reads each leg from the base up; write the tree from the base",
                    tuple(link_names(P)),
                )
            if not tree:
                raise ModelImportError(
                    f"body {shown_list(link_names(cur))} has no joint to the base: it is not part "
                    "of a leg",
                    tuple(link_names(cur)),
                )
            if len(tree) > 1:
                raise ModelImportError(
                    f"bodies {shown_list(link_names(cur))} are joined to the rest by "
                    f"{len(tree)} joints ({shown_list([e.joint.name for e in tree])}): a leg is a "
                    "serial chain",
                    tuple(link_names(cur)),
                    tuple(e.joint.name for e in tree),
                )
            e = tree[0]
            if e.joint.kind == FREE:
                raise ModelImportError(
                    f"a floating base: the legs start from {shown_list(link_names(cur))}, which "
                    f"has the free joint {shown(e.joint.name)}; weld that body to the world "
                    "(remove its free joint) so the base is fixed",
                    tuple(link_names(cur)),
                    (e.joint.name,),
                )
            if cur in seen:
                raise ModelImportError(
                    f"legs {seen[cur] + 1} and {k + 1} share the bodies "
                    f"{shown_list(link_names(cur))}: each leg is its own chain",
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
            f"extra moving bodies {shown_list(names)} (joints {shown_list(joints)}): stewart-pin "
            "models the platform, six legs and bodies fixed to them; remove these bodies, "
            "or fix them to the platform or a leg (no joint)",
            tuple(names),
            tuple(joints),
        )
    return Recognition(links, link_of, ground, P, legs, scale, mass, dropped, approximated)


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
                f"{shown(e.joint.name)}) is welded to the platform by {shown_list(names)}: a "
                "closure must be a point (a connect), or the weld of a rod end that carries a "
                "ball joint (or three hinges); a weld where a ball should be",
                (model.body_label(body),),
                (e.joint.name, *names),
            )


#: Two bodies of the platform's rigid group within this fraction of each other's mass
#: could both be meant as the platform: a warning names them.
PLATFORM_MASS_MARGIN = 0.1


def platform_body(
    model: KinematicModel,
    links: list[Link],
    P: int,
    connections: list[Connection],
    edges: list[Edge],
) -> None:
    """Give the platform link ``P``, when it hangs in the tree (no free joint), the frame
    of its heaviest body (the platform the user means, not a joint part such as a rod end
    through which it hangs from a leg), the points already found in its frame moved with
    it; a note and a :class:`ModelImportWarning` when the two heaviest are within
    :data:`PLATFORM_MASS_MARGIN` of each other's mass (``platform=`` chooses). A floating
    platform keeps the frame of the body with the free joint."""
    link = links[P]
    root_joint = model.bodies[link.root].joint
    if root_joint is not None and root_joint.kind == FREE:
        return  # a floating platform: the body the file moves (its free joint) is Fp
    bodies = [b for b in link.bodies if not model.bodies[b].virtual and b != 0]
    if not bodies:
        return
    by_mass = sorted(bodies, key=lambda b: (-model.bodies[b].inertia[9], b))
    heaviest = by_mass[0]
    mass = float(model.bodies[heaviest].inertia[9])
    if len(by_mass) > 1:
        second = by_mass[1]
        other = float(model.bodies[second].inertia[9])
        if mass > 0.0 and other >= (1.0 - PLATFORM_MASS_MARGIN) * mass:
            names = (model.body_label(heaviest), model.body_label(second))
            message = (
                f"the platform's rigid group has two bodies of similar mass, "
                f"{shown(names[0])} ({mass:.4g} kg) and {shown(names[1])} ({other:.4g} kg): "
                f"Fp is the frame of {shown(names[0])}, the heavier; poses are in that frame "
                "(choose another with platform=... / --platform)"
            )
            model.notes.append(message)
            warnings.warn(
                ModelImportWarning(message, short=f"platform frame: {shown(names[0])}"),
                stacklevel=4,
            )
    if heaviest == link.root:
        return
    new = reroot(link, heaviest)
    T = new.rel[link.root]  # the old link frame in the new one

    def moved(p: np.ndarray) -> np.ndarray:
        return T[:3, :3] @ p + T[:3, 3]

    for cn in connections:
        if cn.a == P:
            cn.point_a = moved(cn.point_a)
        if cn.b == P:
            cn.point_b = moved(cn.point_b)
    for e in edges:
        if e.child == P:
            e.centre_child = moved(e.centre_child)
        if e.parent == P:
            e.centre_parent = moved(e.centre_parent)
    links[P] = new
    model.notes.append(
        f"platform frame Fp: body {shown(model.body_label(heaviest))}, the heaviest of the "
        f"platform's rigid group ({mass:.4g} kg; not {shown(model.body_label(link.root))}, "
        "through which it is jointed)"
    )


def reroot(link: Link, root: int) -> Link:
    """The link with its frame moved to body ``root``'s (the platform asked for)."""
    T = np.linalg.inv(link.rel[root])
    rel = {b: T @ R for b, R in link.rel.items()}
    inertia = transform_inertia(link.inertia, T)
    return Link(root, link.bodies, rel, inertia)


def frame_in_link(link: Link, model: KinematicModel, body: int, point: np.ndarray) -> np.ndarray:
    """``point`` (F0, zero configuration, a point of ``body``) in the link's frame."""
    T = link.rel[body] @ np.linalg.inv(model.bodies[body].pose)
    return T[:3, :3] @ point + T[:3, 3]


def _line_at(model: KinematicModel, poses: np.ndarray, body: int) -> TreeJoint:
    """The hinge of ``body`` with its line (anchor, axis) in F0 at the configuration of
    ``poses`` (the bodies' poses there)."""
    J = model.bodies[body].joint
    assert J is not None
    parent = model.bodies[body].parent
    M = poses[parent] @ np.linalg.inv(model.bodies[parent].pose)
    return TreeJoint(J.name, J.kind, M[:3, :3] @ J.anchor + M[:3, 3], M[:3, :3] @ J.axis)


def _miss(hinges: Sequence[TreeJoint]) -> float:
    """The largest distance [m] between two of the three lines (0 when they meet)."""
    out = 0.0
    for a, b in ((0, 1), (0, 2), (1, 2)):
        ha, hb = hinges[a], hinges[b]
        n = np.cross(ha.axis, hb.axis)
        w = hb.anchor - ha.anchor
        if np.linalg.norm(n) > 1e-12:
            d = abs(float(w @ n)) / float(np.linalg.norm(n))
        else:
            d = float(np.linalg.norm(w - (w @ ha.axis) * ha.axis))
        out = max(out, d)
    return out


def _meeting_point(
    hinges: Sequence[TreeJoint], tolerance: float = INTERSECTION_TOLERANCE
) -> np.ndarray | None:
    """The point nearest to the three lines, if each passes within ``tolerance``
    (:data:`INTERSECTION_TOLERANCE`) of the lines' spread; else ``None``."""
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
        if np.linalg.norm(v - (v @ h.axis) * h.axis) > tolerance * max(spread, 1.0):
            return None
    return c


def _coplanar(hinges: Sequence[TreeJoint]) -> bool:
    return abs(float(np.linalg.det(np.array([h.axis for h in hinges])))) < 1e-6


__all__ = [
    "APPROXIMATE_INTERSECTION",
    "INTERSECTION_TOLERANCE",
    "MASSLESS",
    "PLATFORM_MASS_MARGIN",
    "Connection",
    "Edge",
    "LegChain",
    "Link",
    "Recognition",
    "recognise",
]
