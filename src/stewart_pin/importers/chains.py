"""Legs read as they are written: chain legs
(:class:`~stewart_pin.description.chain_leg.ChainLeg`) for every leg that is not exactly
three 1-dof joints and an ideal spherical joint
(``docs/importing.md``, "Chain legs").

:func:`recognise_chains` finds the platform as the link with six closures (a ball joint to
it, a point closure, a weld closure, or a 1-dof joint whose child is the platform: a leg
whose last link *is* the platform, a weld at that body's frame) and walks each leg from
the platform back to the base through 1-dof joints only; :func:`build_chains` places each
leg's joints exactly (modified DH, frames chosen from the joint lines at the file's zero
configuration: :func:`mdh_frames`), with its links' ten inertial parameters, its joint
terms and limits, the file's joint values (no sign, no offset), its closure (ball: the
point; weld: the two frames) and its links' gravity compensation (``ChainLeg.gravcomp``,
the one each link's bodies share: different factors in one link refused; the platform's
into ``platform_gravcomp``; the same on every moving body is gravity scaled).
Nothing is approximated: no link is made massless, no axis is snapped; the joint values of
the description are the file's.

A ball leg of four joints has an idle freedom (an R-S-S rod's spin about its ball-to-ball
line): the joint whose motion does not move the ball centre at the reference configuration
is its coordinate (``idle_joint``); without one the leg is refused, naming it.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from typing import Any

import numpy as np

from stewart_pin.description.chain_leg import ChainLeg
from stewart_pin.description.leg_architecture import (
    REVOLUTE,
    Joint,
    JointDynamics,
)
from stewart_pin.description.robot_description import RobotDescription, check_robot_name
from stewart_pin.exceptions import (
    ArchitectureError,
    DescriptionError,
    LoopClosureError,
    ModelImportError,
    ModelImportWarning,
)
from stewart_pin.importers.build import (
    CLOSURE_TOLERANCE,
    EXACT_CLOSURE,
    ImportReport,
    ImportResult,
    LegReport,
    LinkPoses,
    assign_actuators,
    compensated_gravity,
    joint_dynamics,
    link_gravcomp,
    robot_name,
)
from stewart_pin.importers.canonical import transform_inertia
from stewart_pin.importers.topology import (
    Link,
    frame_in_link,
    length_scale,
    platform_body,
    reroot,
    union_links,
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

#: Two joint lines with ``|z_j x z_{j+1}|`` at or below this are parallel (their common
#: normal is chosen through the previous frame's origin); exact lines only: nothing is
#: snapped.
PARALLEL = 1e-12
#: A joint of a four-joint ball leg is its idle freedom's coordinate when its motion
#: moves the ball centre by at most this fraction of the robot's size per unit rate: the
#: axis passes the ball centre within it (files round their numbers to 6-9 digits; the
#: three-joint path's ``PARALLEL_TOLERANCE``). Only the choice of the coordinate: the leg
#: stays exact (the residual is reported).
IDLE_TOLERANCE = 1e-4
#: Two joint lines whose common normal's feet lie more than this times the robot's size
#: from the lines' anchors are taken as parallel (reported when they are not exactly).
FAR = 1e3
#: Largest distance [fraction of the size] and angle [rad] between the frames rebuilt from
#: a leg's modified-DH parameters and the file's joint lines (round-off is ~1e-15).
MDH_MATCH = 1e-9


@dataclass
class ChainLegRead:
    """One leg found by :func:`recognise_chains`.

    Attributes:
        joints: the file joints from the base (1-dof).
        children: the link each joint moves (the last may be the platform: ``into_platform``).
        closure: ``"ball"`` or ``"weld"``.
        tip: (4, 4) the closing frame (a ball: its centre) in F0 at the zero configuration.
        at_platform: (4, 4) the same frame in the platform link's frame.
        label: how the closure is written, e.g. ``"weld 'loop3'"``.
        into_platform: the last joint moves the platform itself (its link's mass is the
            platform's).
        tip_link: the link holding the leg's side of the closure; ``tip_body``/``tip_rel``:
            its body and the frame in that body (residual at the reference).
    """

    joints: list[TreeJoint]
    children: list[int]
    closure: str
    tip: np.ndarray
    at_platform: np.ndarray
    label: str
    into_platform: bool = False
    tip_link: int = -1
    tip_in_link: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class ChainRecognition:
    """What :func:`recognise_chains` found: the links (welds that close legs kept as
    closures), the base and platform links, the six legs, the scale [m]."""

    links: list[Link]
    link_of: list[int]
    ground: int
    platform: int
    legs: list[ChainLegRead]
    scale: float
    fallback: ModelImportError | None = None


def _frame(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def recognise_chains(
    model: KinematicModel, platform: str | None = None
) -> ChainRecognition | None:
    """The platform and six chain legs (module docstring), or ``None`` when the model is no
    six-legged platform of 1-dof chains closed by balls or welds (the caller then raises
    the error of the three-joint recognition)."""
    world = {0}
    fixed = [b for b, body in enumerate(model.bodies) if b and body.joint is None]
    # the world's rigid group through fixed bodies: welds to it lump (a base welded down)
    grew = True
    while grew:
        grew = False
        for b in fixed:
            if b not in world and model.bodies[b].parent in world:
                world.add(b)
                grew = True
    lumped = [c for c in model.closures if c.kind == "weld" and ({c.body1, c.body2} & world)]
    kept = [c for c in model.closures if c not in lumped]
    links, link_of = union_links(dc_replace(model, closures=lumped))
    ground = link_of[0]
    edges: list[tuple[int, int, TreeJoint, int]] = []  # parent link, child link, joint, body
    for b, body in enumerate(model.bodies[1:], start=1):
        if body.joint is not None and link_of[body.parent] != link_of[b]:
            edges.append((link_of[body.parent], link_of[b], body.joint, b))
    into: dict[int, list[tuple[int, int, TreeJoint, int]]] = {}
    for e in edges:
        into.setdefault(e[1], []).append(e)

    # closures at each link: (link, other link, kind, label, item)
    ends: list[tuple[int, int, str, str, Any]] = []
    for c in kept:
        a, b = link_of[c.body1], link_of[c.body2]
        if a == b:
            return None
        kind = "ball" if c.kind == "point" else "weld"
        label = f"{'closure' if kind == 'ball' else 'weld'} {shown(c.name)}"
        ends += [(a, b, kind, label, c), (b, a, kind, label, c)]
    for e in edges:
        if e[2].kind == BALL:
            label = f"ball joint {shown(e[2].name)}"
            ends += [(e[1], e[0], "ball", label, e), (e[0], e[1], "ball", label, e)]
    if platform is not None:
        matches = [b for b, body in enumerate(model.bodies) if body.name == platform]
        if not matches:
            return None
        P = link_of[matches[-1]]
        links[P] = reroot(links[P], matches[-1])
    else:
        count: dict[int, int] = {}
        for lk, _, _, _, _ in ends:
            if lk != ground:
                count[lk] = count.get(lk, 0) + 1
        for _, ch, J, _ in edges:  # a leg whose last joint moves the platform
            if J.one_dof:
                count[ch] = count.get(ch, 0) + 1
        six = [i for i, n in count.items() if n == 6]
        if len(six) != 1:
            return None
        P = six[0]
        platform_body(model, links, P, [], [])
    if P == ground:
        return None
    for c in kept:
        if P not in (link_of[c.body1], link_of[c.body2]):
            ends_ = (model.body_label(c.body1), model.body_label(c.body2))
            raise ModelImportError(
                f"loop closure {shown(c.name)} joins {shown(ends_[0])} and {shown(ends_[1])}, "
                f"away from the platform {shown(model.body_label(links[P].root))}: "
                "stewart-pin models the six loops that close the legs at the platform; "
                "another loop (a body pinned to the base, two legs coupled) would be dropped "
                "and the robot would move where the file's cannot; remove it",
                ends_,
                (c.name,),
            )
    zero = np.array([b.pose for b in model.bodies])

    def link_zero(i: int) -> np.ndarray:
        lk = links[i]
        return zero[lk.root] @ np.linalg.inv(lk.rel[lk.root])

    def in_link(i: int, body: int, T: np.ndarray) -> np.ndarray:
        """A frame ``T`` of ``body`` (in that body's frame) in link i's frame."""
        return links[i].rel[body] @ T

    starts: list[tuple[int, str, np.ndarray, np.ndarray, str, TreeJoint | None, int]] = []
    for lk, other, kind, label, item in ends:
        if lk != P:
            continue
        if isinstance(item, TreeClosure):
            c = item
            mine, theirs = (c.body1, c.body2) if link_of[c.body1] == P else (c.body2, c.body1)
            if kind == "ball":
                pt_mine = c.point1 if mine == c.body1 else c.point2
                pt_theirs = c.point2 if mine == c.body1 else c.point1
                at_p = in_link(P, mine, _frame(np.eye(3), pt_mine))
                at_x = in_link(other, theirs, _frame(np.eye(3), pt_theirs))
            else:  # the frame: body2's, held at T_1_2 in body1
                F1, F2 = c.T_1_2 @ c.frame2, c.frame2
                at_p = in_link(P, mine, F1 if mine == c.body1 else F2)
                at_x = in_link(other, theirs, F1 if theirs == c.body1 else F2)
            starts.append((other, kind, at_x, at_p, label, None, -1))
        else:
            pa, ch, J, b = item
            if ch == P:  # the platform hangs from this leg by a ball joint
                at_p = _frame(np.eye(3), frame_in_link(links[P], model, b, J.anchor))
                at_x = _frame(
                    np.eye(3), frame_in_link(links[pa], model, model.bodies[b].parent, J.anchor)
                )
            else:  # a ball joint moves a leg link from the platform: no leg from the base
                return None
            starts.append((other, kind, at_x, at_p, label, None, -1))
    for pa, _, J, b in into.get(P, []):
        if J.one_dof:  # the leg's last joint moves the platform: a weld at that body
            at_p = links[P].rel[b]
            starts.append((pa, "weld", np.eye(4), at_p, f"{J.kind} joint {shown(J.name)}", J, b))
        elif J.kind != BALL and J.kind != FREE:
            return None
    if len(starts) != 6:
        return None

    legs: list[ChainLegRead] = []
    seen: set[int] = set()
    for X, kind, at_x, at_p, label, last, jbody in starts:
        joints: list[TreeJoint] = []
        children: list[int] = []
        if last is not None:
            joints.append(last)
            children.append(P)
            tip = zero[jbody]
        else:
            tip = link_zero(X) @ at_x
        cur = X
        while cur != ground:
            tree = into.get(cur, [])
            if len(tree) != 1 or not tree[0][2].one_dof or cur in seen or cur == P:
                return None
            seen.add(cur)
            joints.insert(0, tree[0][2])
            children.insert(0, cur)
            cur = tree[0][0]
        if not joints:
            return None
        legs.append(
            ChainLegRead(joints, children, kind, tip, at_p, label, last is not None, X, at_x)
        )
    # anything else that moves
    used = {i for leg in legs for i in leg.children} | {ground, P}
    if any(i not in used for i in range(len(links))):
        return None
    return ChainRecognition(links, link_of, ground, P, legs, length_scale(model))


def mdh_frames(
    kinds: Sequence[str],
    anchors: Any,
    axes: Any,
    size: float = 1.0,
    nearly: list[int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Frames 1..n (n, 4, 4) in F0 and the modified-DH parameters (n, 4) ``alpha, d,
    theta, r`` of a chain of n 1-dof joints given by a point and the unit axis of each
    line (F0, zero configuration), joint 1's all zero (frame 0 is frame 1 at q1 = 0).

    ``x_j`` is the common normal of lines j and j+1 (``z_j x z_{j+1}``), ``o_j`` its foot
    on line j; for parallel lines (:data:`PARALLEL`) ``o_j`` is where the previous normal
    meets line j (joint 1: its anchor) and ``x_j`` points from it to line j+1; the last
    frame's ``x_n`` is ``x_{n-1}`` made normal to ``z_n``. Lines whose common normal's feet
    lie more than :data:`FAR` times ``size`` [m] from the anchors are taken as parallel: the
    1-based indices j of those not exactly parallel are appended to ``nearly`` (the frames
    rebuilt from the parameters then miss the file's lines: :func:`mdh_mismatch`)."""
    nearly = [] if nearly is None else nearly
    n = len(kinds)
    a = np.array(anchors, dtype=float).reshape(n, 3)
    z = np.array([np.asarray(v, float) / np.linalg.norm(v) for v in axes]).reshape(n, 3)
    o = np.zeros((n, 3))
    x = np.zeros((n, 3))
    p = a[0].copy()  # where the previous normal meets line j
    for j in range(n):
        if j == n - 1:
            o[j] = p
            prev = x[j - 1] if j else np.array([1.0, 0.0, 0.0])
            v = prev - (prev @ z[j]) * z[j]
            if np.linalg.norm(v) < 1e-6:
                v = np.cross(z[j], [1.0, 0.0, 0.0] if abs(z[j][0]) < 0.9 else [0.0, 1.0, 0.0])
            x[j] = v / np.linalg.norm(v)
            break
        c = np.cross(z[j], z[j + 1])
        # the feet of the common normal: ((a_{j+1} - a_j) x z) . c / |c|^2, well conditioned
        # (``1 - (z_j . z_{j+1})^2`` would cancel for nearly parallel lines)
        den = float(c @ c)
        w = a[j + 1] - a[j]
        s = float(np.cross(w, z[j + 1]) @ c) / den if den > PARALLEL**2 else math.inf
        t = float(np.cross(w, z[j]) @ c) / den if den > PARALLEL**2 else math.inf
        if max(abs(s), abs(t)) <= FAR * size:
            o[j] = a[j] + s * z[j]
            p = a[j + 1] + t * z[j + 1]
            x[j] = c / math.sqrt(den)
        else:  # parallel, or so nearly that the common normal lies FAR away: as parallel
            if den > PARALLEL**2:
                nearly.append(j + 1)
            o[j] = p
            foot = a[j + 1] + ((o[j] - a[j + 1]) @ z[j + 1]) * z[j + 1]
            v = foot - o[j]
            v = v - (v @ z[j]) * z[j]  # normal to z_j (lines nearly parallel)
            if np.linalg.norm(v) < 1e-12 * (1.0 + np.linalg.norm(o[j])):
                prev = x[j - 1] if j else np.array([1.0, 0.0, 0.0])
                v = prev - (prev @ z[j]) * z[j]
                if np.linalg.norm(v) < 1e-6:
                    v = np.cross(z[j], [1.0, 0.0, 0.0] if abs(z[j][0]) < 0.9 else [0.0, 1.0, 0.0])
            x[j] = v / np.linalg.norm(v)
            p = foot
    frames = np.empty((n, 4, 4))
    for j in range(n):
        frames[j] = _frame(np.column_stack([x[j], np.cross(z[j], x[j]), z[j]]), o[j])
    params = np.zeros((n, 4))
    for j in range(1, n):
        T = np.linalg.inv(frames[j - 1]) @ frames[j]
        R, t = T[:3, :3], T[:3, 3]
        alpha = math.atan2(-R[1, 2], R[2, 2])
        theta = math.atan2(-R[0, 1], R[0, 0])
        r = -t[1] * math.sin(alpha) + t[2] * math.cos(alpha)
        params[j] = (alpha, t[0], theta, r)
    return frames, params


def mdh_mismatch(
    frame0: np.ndarray, joints: Sequence[Joint], anchors: Any, axes: Any
) -> np.ndarray:
    """(n, 2) the distance [m] of each frame rebuilt from ``frame0`` (F0, (4, 4)) and the
    joints' parameters at q = 0 from the file's joint line (its anchor and axis, F0), and
    the angle [rad] between their axes."""
    out = np.zeros((len(joints), 2))
    T = frame0.copy()
    for j, jt in enumerate(joints):
        if j:
            T = T @ jt.transform(0.0)
        z = np.asarray(axes[j], float) / np.linalg.norm(axes[j])
        out[j, 0] = np.linalg.norm(np.cross(T[:3, 3] - np.asarray(anchors[j], float), z))
        out[j, 1] = math.atan2(float(np.linalg.norm(np.cross(T[:3, 2], z))), float(T[:3, 2] @ z))
    return out


def build_chains(
    model: KinematicModel,
    rec: ChainRecognition,
    *,
    actuated: Sequence[str] | None = None,
    armature: dict[str, float] | None = None,
    name: str | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    joint_terms: Callable[[str], JointDynamics | None] | None = None,
    limits: Callable[[str], tuple[float, float] | None] | None = None,
) -> ImportResult:
    """The description of a robot with chain legs (module docstring); the arguments are
    :func:`~stewart_pin.importers.build.build`'s."""
    links, P = rec.links, rec.platform
    poses = LinkPoses(model, links)
    link_zero, link_ref, link_names = poses.zero, poses.ref, poses.names

    leg_of = {J.name: k for k, leg in enumerate(rec.legs) for J in leg.joints}
    order, act_of = assign_actuators(
        model,
        actuated,
        leg_of,
        set(),
        [[J.name for J in leg.joints] for leg in rec.legs],
        lambda k: [n for li in rec.legs[k].children[-1:] if li != P for n in link_names(li)],
    )

    T_home = link_ref(P)
    # per-body gravity compensation: one fraction on every moving body scales gravity;
    # else each link's (its bodies' shared one: link_gravcomp) and the platform's
    gravity, uniform = compensated_gravity(model, rec)  # type: ignore[arg-type]
    platform_gravcomp = 0.0 if uniform else link_gravcomp(model, links, P)
    chain_legs: list[ChainLeg] = []
    base_pts, base_rot, plat_pts = np.zeros((6, 3)), np.zeros((6, 3, 3)), np.zeros((6, 3))
    reports: list[LegReport] = []
    residuals = np.zeros(6)
    angles = np.zeros(6)
    near: list[str] = []  # nearly parallel joint lines taken as parallel
    for n_out, k in enumerate(order):
        leg = rec.legs[k]
        n = len(leg.joints)
        kinds = [J.kind for J in leg.joints]
        anchors = [J.anchor for J in leg.joints]
        axes = [J.axis for J in leg.joints]
        nearly: list[int] = []
        frames, params = mdh_frames(kinds, anchors, axes, rec.scale, nearly)
        a_act = act_of[k]
        act_index = [J.name for J in leg.joints].index(a_act.joint) + 1
        joints: list[Joint] = []
        dyns: list[JointDynamics] = []
        for j, J in enumerate(leg.joints):
            dyn = joint_dynamics(
                J, a_act.gear if j + 1 == act_index else 1.0, armature, joint_terms
            )
            lo, hi = J.lower, J.upper
            if limits is not None and (lim := limits(J.name)) is not None:
                lo, hi = lim
            try:
                alpha, d, theta, r = (float(v) for v in params[j])
                joints.append(Joint(J.kind, alpha, d, theta, r, lo, hi, dyn))
            except ArchitectureError as err:
                raise ModelImportError(f"joint {shown(J.name)}: {err}", (), (J.name,)) from err
            dyns.append(dyn)
        miss = mdh_mismatch(frames[0], joints, anchors, axes)
        worst = float(max(miss[:, 0].max() / rec.scale, miss[:, 1].max()))
        names = tuple(J.name for J in leg.joints)
        if worst > MDH_MATCH:
            pairs = ", ".join(f"{shown(names[j - 1])}-{shown(names[j])}" for j in nearly)
            if not nearly:
                raise ModelImportError(
                    f"the leg of joints {shown_list(names)}: its joint frames rebuilt from "
                    f"the modified-DH parameters miss the file's joint lines by "
                    f"{miss[:, 0].max():.3g} m, {miss[:, 1].max():.3g} rad",
                    (),
                    names,
                )
            warnings.warn(
                ModelImportWarning(
                    f"leg through {shown_list(names)}: the joint lines {pairs} are so nearly "
                    f"parallel that their common normal lies over {FAR:g} times the robot's "
                    "size away; taken as parallel, the frames miss the file's lines by "
                    f"{miss[:, 0].max():.3g} m, {miss[:, 1].max():.3g} rad",
                    short=f"nearly parallel joint lines {pairs} taken as parallel",
                ),
                stacklevel=3,
            )
            near.append(
                f"nearly parallel joint lines {pairs} taken as parallel (the frames move by "
                f"{miss[:, 0].max():.2g} m, {miss[:, 1].max():.2g} rad)"
            )
        inertia = np.zeros((n, 10))
        for j, li in enumerate(leg.children):
            if li == P:
                continue  # the platform's own mass
            params_f0 = transform_inertia(links[li].inertia, link_zero(li))
            inertia[j] = transform_inertia(params_f0, np.linalg.inv(frames[j]))
        gravcomp = np.zeros(n)
        if not uniform:
            for j, li in enumerate(leg.children):
                gravcomp[j] = 0.0 if li == P else link_gravcomp(model, links, li)
        tip = np.linalg.inv(frames[-1]) @ leg.tip
        q_ref = np.array([model.values.get(J.name, 0.0) for J in leg.joints])
        chain = ChainLeg(
            tuple(joints),
            act_index,
            leg.closure,
            inertia,
            tip[:3, 3],
            tip[:3, :3],
            leg.at_platform[:3, :3],
            guess=q_ref,
            gravcomp=gravcomp,
        )
        if leg.closure == "ball" and n == 4:
            idle, miss_idle = _idle_joint(chain, frames[0], rec.scale, leg, rec.fallback)
            chain = chain.replace(idle_joint=idle)
            if miss_idle > EXACT_CLOSURE * rec.scale:
                model.notes.append(
                    f"idle joint {shown(leg.joints[idle - 1].name)}: its axis passes the ball "
                    f"centre within {miss_idle:.3g} m (the file's rounding; the leg is exact)"
                )
        chain_legs.append(chain)
        base_pts[n_out], base_rot[n_out] = frames[0][:3, 3], frames[0][:3, :3]
        plat_pts[n_out] = leg.at_platform[:3, 3]
        # the loop at the reference configuration
        T_leg = frames[0].copy()
        for jt, q in zip(joints, q_ref, strict=True):
            T_leg = T_leg @ jt.transform(q)
        T_leg = T_leg @ chain.attachment()
        T_plat = T_home @ leg.at_platform
        residuals[n_out] = float(np.linalg.norm(T_leg[:3, 3] - T_plat[:3, 3]))
        if leg.closure == "weld":
            R = T_leg[:3, :3].T @ T_plat[:3, :3]
            s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
            angles[n_out] = math.atan2(s, 0.5 * (np.trace(R) - 1.0))
        reports.append(
            LegReport(
                f"chain of {n} joints closed by a {leg.closure}",
                tuple(kinds),
                names,
                tuple(", ".join(link_names(li)) if li != P else "" for li in leg.children),
                act_index,
                a_act.name,
                a_act.gear,
                leg.label,
                float(residuals[n_out]),
                0.0,
                0.0,
                tuple(dyns),
                "chain",
            )
        )
    size = float(np.linalg.norm(plat_pts - plat_pts.mean(0), axis=1).mean()) or rec.scale
    tol = closure_tolerance * size
    if np.any(residuals > tol) or np.any(angles > closure_tolerance):
        bad = [
            f"leg {i + 1}: {r:.3g} m" + (f", {t:.3g} rad" if t else "")
            for i, (r, t) in enumerate(zip(residuals, angles, strict=True))
        ]
        raise LoopClosureError(
            f"the loops do not close at the reference configuration ({model.reference}): "
            f"{'; '.join(bad)} (tolerance {tol:.3g} m = {closure_tolerance:g} of the platform's "
            "size, and that in rad for a weld); give the assembled configuration (a keyframe, "
            "or fix the file), or raise closure_tolerance",
            tuple(residuals),
            tol,
        )
    approximations = list(near)
    if np.any(residuals > EXACT_CLOSURE * size) or np.any(angles > EXACT_CLOSURE):
        warnings.warn(
            ModelImportWarning(
                f"model {shown(model.name)}: the loops close at the reference configuration "
                f"({model.reference}) only to {residuals.max():.3g} m, {angles.max():.3g} rad: "
                "each leg is re-solved at the platform's reference pose",
                short=f"model {shown(model.name)}: loops closed from a residual of "
                f"{residuals.max():.3g} m",
            ),
            stacklevel=3,
        )
        approximations.append(f"loops closed from a residual of {residuals.max():.2g} m")
    lumped = {
        "the platform": [n for n in link_names(P) if n != model.body_label(links[P].root)],
        "the base": [n for n in link_names(rec.ground) if n != model.body_label(0)],
    }
    compensated = [("the platform", platform_gravcomp)] + [
        (f"leg {i + 1} link {j + 1}", float(c))
        for i, chain in enumerate(chain_legs)
        for j, c in enumerate(chain.gravcomp)
    ]
    if any(c for _, c in compensated):
        model.notes.append(
            "gravity compensation of some bodies (gravcomp, or no gravity); "
            + ", ".join(f"{body}: {c:g}" for body, c in compensated if c)
            + " (the fractions of their weights removed: platform_gravcomp, each chain "
            "leg's gravcomp)"
        )
    robot = robot_name(model.name) if name is None else check_robot_name(name)
    notes = list(model.notes)
    notes.append(
        "legs read as chain legs (exact joints, massive links, joint terms, ball or weld "
        "closures; joint values as in the file): "
        + ", ".join(
            f"leg {i + 1}: {len(c.joints)} joints, {c.closure}" for i, c in enumerate(chain_legs)
        )
    )
    try:
        desc = RobotDescription(
            base_points=base_pts,
            platform_points=plat_pts,
            leg_base_rotations=base_rot,
            stroke=None,
            leg_inertia=np.zeros((6, 3, 10)),
            platform_inertia=links[P].inertia.copy(),
            gravity=gravity,
            name=robot,
            home_pose=T_home,
            chain_legs=tuple(chain_legs),
            platform_gravcomp=platform_gravcomp,
        )
    except DescriptionError as err:
        raise ModelImportError(f"the robot read from the file is not valid: {err}") from err
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
        False,
        "chain",
        approximations,
    )
    return ImportResult(desc, report, model)


def _idle_joint(
    chain: ChainLeg,
    base: np.ndarray,
    scale: float,
    leg: ChainLegRead,
    fallback: ModelImportError | None = None,
) -> tuple[int, float]:
    """The joint of a four-joint ball leg whose motion leaves the ball centre in place at
    the reference configuration (the idle freedom's coordinate; :data:`IDLE_TOLERANCE`)
    and the distance [m] of its axis from the ball centre, else :class:`ModelImportError`
    naming the leg's joints."""
    T = base.copy()
    frames = []
    for jt, q in zip(chain.joints, chain.guess, strict=True):
        T = T @ jt.transform(q)
        frames.append(T)
    tip = T[:3, :3] @ chain.tip + T[:3, 3]
    found, miss = [], []
    for j, F in enumerate(frames):
        if j + 1 == chain.actuated:
            continue
        z = F[:3, 2]
        col = np.cross(z, tip - F[:3, 3]) if chain.joints[j].kind == REVOLUTE else z
        if np.linalg.norm(col) <= IDLE_TOLERANCE * scale:
            found.append(j + 1)
            miss.append(float(np.linalg.norm(col)))
    if len(found) == 1:
        return found[0], miss[0]
    names = [J.name for J in leg.joints]
    reason = (
        f"the leg of joints {shown_list(names)} closed by a ball ({leg.label}) has four "
        "joints: one freedom more than its ball's three constraints, and "
        + (
            "no joint's motion leaves the ball centre in place (an idle spin about a line "
            "through the ball, as an R-S-S rod's): the actuators would not hold the platform"
            if not found
            else f"{len(found)} joints leave the ball centre in place"
        )
    )
    if fallback is not None:  # the three-joint recognition's error, with the reason
        raise ModelImportError(
            f"{fallback}; read as a chain leg: {reason}",
            fallback.bodies,
            (*fallback.joints, *(n for n in names if n not in fallback.joints)),
        )
    raise ModelImportError(reason, (), tuple(names))


__all__ = [
    "FAR",
    "IDLE_TOLERANCE",
    "MDH_MATCH",
    "PARALLEL",
    "ChainLegRead",
    "ChainRecognition",
    "build_chains",
    "mdh_frames",
    "mdh_mismatch",
    "recognise_chains",
]
