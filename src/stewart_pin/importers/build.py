"""The description of a recognised platform (:func:`build`) and the import report.

Every leg is placed in the canonical modified-DH form
(:mod:`stewart_pin.importers.canonical`); a rod between two spherical joints becomes the
equivalent universal-joint leg, its spin about its axis removed (exact when the rod's
inertia is symmetric about that axis: :data:`SPIN_TOLERANCE`); each link's inertia is
re-expressed in its frame; the actuated joints (in the actuators' order) and the joint
terms are read; the loops are checked at the reference configuration
(:data:`CLOSURE_TOLERANCE`); the description takes the ideal 6-UPS form when it fits. Gravity
compensation (``TreeBody.gravcomp``): the same on every moving body is gravity scaled;
else each link's (the one its bodies share) goes to the description's
``platform_gravcomp`` and ``leg_gravcomp`` (general legs; chain legs:
:mod:`~stewart_pin.importers.chains`, each leg's ``gravcomp``).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
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
    StewartPinError,
)
from stewart_pin.importers.canonical import (
    SNAP,
    canonical_chain,
    classify,
    transform_inertia,
)
from stewart_pin.importers.topology import Link, Recognition
from stewart_pin.importers.tree import (
    BALL,
    KinematicModel,
    TreeActuator,
    TreeJoint,
    shown,
    shown_list,
)

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


# ------------------------------------------------------------------------------ build
@dataclass
class _LegForm:
    """One leg in the description's joint convention (``build``): the canonical chain of
    the signed axes, the joints (theta / r shifted by the offsets), their dynamics, the
    reference values, the architecture, ``signs`` / ``offsets`` (description value =
    ``sign q_file + offset``), P_i in frame 3i and frames 1i..3i at the file's zero."""

    chain: Any
    joints: list[Joint]
    dyns: list[JointDynamics]
    q_ref: np.ndarray
    arch: LegArchitecture
    signs: np.ndarray
    offsets: np.ndarray
    tip: np.ndarray
    frames: np.ndarray


@dataclass
class LegReport:
    """One leg as imported (names as in the file; three joints, or a chain leg's n)."""

    shape: str
    kinds: tuple[str, ...]
    joints: tuple[str, ...]
    bodies: tuple[str, ...]
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
    approximations: list[str] = field(default_factory=list)
    effects: list[str] = field(default_factory=list)

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
                lines.append(f"lumped into {where}: {shown_list(names)}")
        lines.extend(f"note: {n}" for n in self.notes)
        lines.extend(f"approximation: {a}" for a in self.approximations)
        lines.extend(f"effect: {e}" for e in self.effects)
        return "\n".join(lines)


@dataclass
class ImportResult:
    """The imported description and its report."""

    description: RobotDescription
    report: ImportReport
    model: KinematicModel | None = None


class LinkPoses:
    """Each link's frame (4x4, F0) at the file's zero configuration (:meth:`zero`) and at
    the reference configuration (:meth:`ref`), and its file bodies' names (:meth:`names`)."""

    def __init__(self, model: KinematicModel, links: Sequence[Link]) -> None:
        self.model, self.links = model, links
        self._zero = np.array([b.pose for b in model.bodies])
        self._ref = model.poses()

    def zero(self, i: int) -> np.ndarray:
        lk = self.links[i]
        return self._zero[lk.root] @ np.linalg.inv(lk.rel[lk.root])

    def ref(self, i: int) -> np.ndarray:
        lk = self.links[i]
        return self._ref[lk.root] @ np.linalg.inv(lk.rel[lk.root])

    def names(self, i: int) -> list[str]:
        bodies = self.model.bodies
        return [self.model.body_label(b) for b in self.links[i].bodies if not bodies[b].virtual]


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
    poses = LinkPoses(model, links)
    link_zero, link_ref, link_names = poses.zero, poses.ref, poses.names

    # actuators -> (leg, joint name)
    leg_of_joint: dict[str, int] = {}
    for k, leg in enumerate(rec.legs):
        for e in leg.edges:
            if not e.spherical:
                leg_of_joint[e.joint.name] = k
    spherical_joints = {
        h.name
        for leg in rec.legs
        for e in [*leg.edges, *([leg.connection.edge] if leg.connection.edge else [])]
        if e.spherical
        for h in (e.hinges or (e.joint,))
    }
    order, act_of_leg = assign_actuators(
        model,
        actuated,
        leg_of_joint,
        spherical_joints,
        [[e.joint.name for e in leg.edges if not e.spherical] for leg in rec.legs],
        lambda k: link_names(rec.legs[k].links[-1]),
    )

    # platform
    plat = links[P]
    platform_inertia = plat.inertia.copy()
    T_home = link_ref(P)
    size_points = []
    legs_out: list[LegArchitecture] = []
    leg_inertia = np.zeros((6, 3, 10))
    leg_gravcomp = np.zeros((6, 3))
    base_rot = np.zeros((6, 3, 3))
    base_pts = np.zeros((6, 3))
    plat_pts = np.zeros((6, 3))
    reports: list[LegReport] = []
    sources: list[LegSource] = []
    residual_points: list[tuple[np.ndarray, np.ndarray]] = []
    snapped: list[float] = []  # the angles by which legs' axes were made parallel [rad]
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
        link_ids: list[int | None] = []  # the link of each joint (None: a massless one)
        spin_I = asym = 0.0
        if leg.shape == "JJJ":
            for e in leg.edges:
                link_ids.append(e.child)
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
                    f"leg through {s1.label}: the rod {shown_list(rod_names)} "
                    f"between two spherical joints is not symmetric about its axis (asymmetry "
                    f"{asym:.3g} > {spin_tolerance:g}): the equivalent universal-joint leg "
                    "(spin removed) is not exact"
                )
                if rod_spin == "error":
                    raise RodSpinError(
                        message + "; pass rod_spin='warn' to import it anyway (its inertia made "
                        "symmetric), or write the rod's spherical joint as three hinges, the "
                        "last along the rod: the leg is then read exactly, a chain leg whose "
                        "spin is an idle joint (docs/importing.md)",
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
                link_ids = [e1.child, None, s1.child]
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
                link_ids = [None, s1.child, e1.child]
                link_bodies = [
                    "",
                    ", ".join(link_names(s1.child)),
                    ", ".join(link_names(e1.child)),
                ]
                link_params = [np.zeros(10), removed[0], removed[1]]
                refs = [None, None, model.values.get(e1.joint.name, 0.0)]

        a_act = act_of_leg[k]
        actuated_index = names.index(a_act.joint) + 1 if a_act.joint in names else 0
        if actuated_index == 0:
            raise ModelImportError(
                f"actuator {shown(a_act.name)} drives {shown(a_act.joint)}, not one of the "
                f"leg's joints {shown_list(names)}",
                (),
                (a_act.name,),
            )

        # the file's joint zeros and directions (docs/importing.md): the leg as the file
        # writes it; if that is no named architecture, its joints re-zeroed (theta_j,
        # r_j of joints 2, 3 zero) and a U-P-S slide pointed from the U joint to P_i; a
        # U-P-S leg on the other U-joint branch gets its first hinge turned the other way
        leg_in = _LegInput(
            kinds,
            anchors,
            axes,
            tip_zero,
            names,
            link_bodies,
            file_joints,
            refs,
            actuated_index,
            a_act.gear,
            rec.scale,
            armature,
            joint_terms,
            limits,
            side_leg if leg.shape == "JJJ" else side_plat,
        )
        form = _leg_form(leg_in, np.ones(3), False)
        if not _closed_form_fits(form, rec.scale):
            candidates: list[tuple[np.ndarray, bool]] = []
            if tuple(kinds) == (REVOLUTE, REVOLUTE, PRISMATIC):
                trial = np.ones(3)
                tip0 = form.chain.tip
                if file_joints[2] is not None and refs[2] is not None and not tip0[:2].any():
                    slide = form.chain.params[2, 3] + tip0[2] + float(refs[2])
                    trial[2] = -1.0 if slide < 0.0 else 1.0
                candidates.append((trial, True))
                if file_joints[0] is not None:
                    candidates.append((trial * np.array([-1.0, 1.0, 1.0]), True))
            else:  # the universal joint's closed form takes one of its two assemblies
                for flips in ((1.0, -1.0, 1.0), (1.0, 1.0, -1.0), (1.0, -1.0, -1.0)):
                    candidates.append((np.array(flips), False))
            fallback = None
            for trial, rezero in candidates:
                got = _leg_form(leg_in, trial, rezero)
                if _closed_form_fits(got, rec.scale):
                    form = got
                    break
                if fallback is None and _closed_form_fits(got, rec.scale, any_branch=True):
                    fallback = got
            else:
                if fallback is not None:
                    form = fallback
                elif _closed_form_fits(form, rec.scale, any_branch=True):
                    pass
                elif form.arch.name != "custom":  # the file's leg, solved by Newton's method
                    form.arch = LegArchitecture(
                        tuple(form.joints), actuated_index, form.tip, 1, "custom", form.q_ref
                    )
        chain, dyns, q_ref, arch = form.chain, form.dyns, form.q_ref, form.arch
        signs, offsets = form.signs, form.offsets
        if chain.snapped > PARALLEL_NOTICE:
            snapped.append(chain.snapped)
            warnings.warn(
                f"leg through {shown_list(names)}: two joint axes {chain.snapped:.2g} rad from "
                "parallel are made parallel (the file's rounding, as read; the robot turns "
                "by that angle; see docs/importing.md)",
                ModelImportWarning,
                stacklevel=3,
            )
            model.notes.append(
                f"axes of {shown_list(names)} made parallel (turned by {chain.snapped:.2g} rad)"
            )
        # link inertias in the canonical frames, their gravity compensation
        for j in range(3):
            leg_gravcomp[len(reports), j] = link_gravcomp(model, links, link_ids[j])
            leg_inertia[len(reports), j] = transform_inertia(
                link_params[j], np.linalg.inv(form.frames[j])
            )
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
                tuple(float(x) for x in signs),
                tuple(float(x) for x in offsets),
                _wraps(file_joints),
            )
        )
        if not sources[-1].identity:
            model.notes.append(
                f"leg {len(sources)}: joint values read from the file's as "
                + ", ".join(
                    f"{shown(names[j])} = {'-' if signs[j] < 0 else ''}q_file"
                    + (f" {'+-'[int(offsets[j] < 0)]} {abs(offsets[j]):.6g}" if offsets[j] else "")
                    for j in range(3)
                    if signs[j] < 0 or offsets[j]
                )
                + f" (named architecture {arch.name}; the robot's actuator positions and "
                "efforts are in the file's convention: robot.actuator_convention; every "
                "joint's: robot.description.source.file_joint_values)"
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
            ModelImportWarning(
                f"model {shown(model.name)}: the loops close at the reference configuration "
                f"({model.reference}) only to {residuals.max():.3g} m (per leg: "
                f"{', '.join(f'{r:.2e}' for r in residuals)}; tolerance {tol:.3g} m): the "
                "robot is assembled at the platform's reference pose, each leg re-solved",
                short=f"model {shown(model.name)}: loops closed from a residual of "
                f"{residuals.max():.3g} m",
            ),
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
    gravity, uniform = compensated_gravity(model, rec)
    platform_gravcomp = 0.0
    if uniform:
        leg_gravcomp[:] = 0.0
    else:
        platform_gravcomp = link_gravcomp(model, links, P)
        if platform_gravcomp or np.any(leg_gravcomp):
            model.notes.append(
                "gravity compensation of some bodies (gravcomp, or no gravity); "
                + ", ".join(
                    f"{name}: {c:g}"
                    for name, c in [
                        ("the platform", platform_gravcomp),
                        *(
                            (f"leg {i + 1} link {j + 1}", leg_gravcomp[i, j])
                            for i in range(6)
                            for j in range(3)
                        ),
                    ]
                    if c
                )
                + " (the fractions of their weights removed: platform_gravcomp, "
                "leg_gravcomp)"
            )
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
            gravity,
            T_home,
            source,
            platform_gravcomp,
            leg_gravcomp,
        )
    except DescriptionError as err:
        where = getattr(err, "body", "")
        match = re.fullmatch(r"leg (\d) link (\d)", where)
        names_ = [sources[int(match[1]) - 1].bodies[int(match[2]) - 1]] if match else []
        if where == "platform":
            names_ = [source.platform]
        raise ModelImportError(
            f"the robot read from the file is not valid: {err}"
            + (f" (the file's body {shown_list(names_)})" if names_ else ""),
            tuple(names_),
        ) from err
    architectures = {leg.name for leg in legs_out}
    approximations = []
    if rec.dropped:
        approximations.append(f"{len(rec.dropped)} nearly massless bodies taken as massless")
    approximations.extend(rec.approximated)
    if snapped:
        approximations.append(
            f"axes made parallel in {len(snapped)} leg(s) (turned by up to {max(snapped):.2g} rad)"
        )
    asymmetric = [rep.spin_asymmetry for rep in reports if rep.spin_asymmetry > spin_tolerance]
    if asymmetric:
        approximations.append(
            f"the spin of {len(asymmetric)} asymmetric rod(s) removed (asymmetry up to "
            f"{max(asymmetric):.2g})"
        )
    if np.any(residuals > EXACT_CLOSURE * size):
        approximations.append(f"loops closed from a residual of {residuals.max():.2g} m")
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
        approximations,
    )
    return ImportResult(desc, report, model)


def assign_actuators(
    model: KinematicModel,
    actuated: Sequence[str] | None,
    leg_of_joint: dict[str, int],
    spherical_joints: set[str],
    leg_joints: Sequence[Sequence[str]],
    leg_bodies: Callable[[int], list[str]],
) -> tuple[list[int], dict[int, TreeActuator]]:
    """The legs in actuator order and each leg's actuator: ``actuated`` (joint names in
    leg order) or the model's actuators; :class:`ModelImportError` for an actuator on a
    passive joint of ``spherical_joints`` or on no leg joint (``leg_of_joint``: joint name
    -> leg), two actuated joints on a leg, a non-positive gear, or a leg without one
    (named with its 1-dof joints ``leg_joints`` and ``leg_bodies(k)``)."""
    if actuated is not None:
        acts = [TreeActuator(str(n), str(n)) for n in actuated]
        gears = {a.joint: a.gear for a in model.actuators}
        for a in acts:
            a.gear = gears.get(a.joint, 1.0)
            a.name = next((x.name for x in model.actuators if x.joint == a.joint), a.name)
    else:
        acts = list(model.actuators)
    all_joints = {b.joint.name for b in model.bodies if b.joint is not None}
    order: list[int] = []
    act_of_leg: dict[int, TreeActuator] = {}
    for a in acts:
        if a.joint in spherical_joints:
            raise ModelImportError(
                f"actuator {shown(a.name)} drives {shown(a.joint)}, a hinge of a spherical "
                "joint (a passive joint): actuate one of the leg's three 1-dof joints",
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
        idle = [n for k in missing for n in leg_joints[k]]
        raise ModelImportError(
            f"{len(missing)} leg(s) without an actuator (joints {shown_list(idle)}): each leg "
            "needs one actuated 1-dof joint"
            + (
                " (give them with actuated=[...] or <transmission>)"
                if model.format == "urdf"
                else ""
            ),
            tuple(n for k in missing for n in leg_bodies(k)),
            tuple(idle),
        )

    return order, act_of_leg


@dataclass
class _LegInput:
    """What :func:`_leg_form` needs of a leg read from the file: the joints' kinds, a
    point and the axis of each line and P_i in F0 at the file's zero configuration, the
    names, the file's joints (``None``: a joint that replaces a spherical joint), their
    reference values, the actuated joint (1..3) and its gear, the robot's size [m], the
    reader's extra armature / joint terms / limits, and the tip's reference position
    (F0)."""

    kinds: list[str]
    anchors: list[np.ndarray]
    axes: list[np.ndarray]
    tip_zero: np.ndarray
    names: list[str]
    link_bodies: list[str]
    file_joints: list[TreeJoint | None]
    refs: list[float | None]
    actuated: int
    gear: float
    scale: float
    armature: dict[str, float] | None
    joint_terms: Callable[[str], JointDynamics | None] | None
    limits: Callable[[str], tuple[float, float] | None] | None
    target: np.ndarray


def _leg_form(leg: _LegInput, signs: np.ndarray, rezero: bool) -> _LegForm:
    """The leg with the file's joint j read as ``signs[j] q_file + offset_j``: offsets 0
    (the file's zeros), or with ``rezero`` those that zero theta_j / r_j of joints 2, 3
    (a slide's zero moved to P_i when P_i is on its line)."""
    kinds, names, file_joints, actuated_index = leg.kinds, leg.names, leg.file_joints, leg.actuated
    try:
        axes = [s * np.asarray(a) for s, a in zip(signs, leg.axes, strict=True)]
        chain = canonical_chain(kinds, leg.anchors, axes, leg.tip_zero, leg.scale, names)
    except ArchitectureError as err:
        raise ModelImportError(str(err), tuple(leg.link_bodies), tuple(names)) from err
    offsets = np.zeros(3)
    tip = chain.tip.copy()
    shift = 0.0  # frame 3i moved along a slide's line to P_i
    if rezero:
        for j in (1, 2):
            if file_joints[j] is not None:
                offsets[j] = chain.params[j, 2 if kinds[j] == REVOLUTE else 3]
        if kinds[2] == PRISMATIC and file_joints[2] is not None and not tip[:2].any():
            shift, tip[2] = tip[2], 0.0
            offsets[2] += shift
    joints_: list[Joint] = []
    dyns_: list[JointDynamics] = []
    for j in range(3):
        J = file_joints[j]
        s, o = float(signs[j]), float(offsets[j])
        lo, hi = (-math.inf, math.inf) if J is None else (J.lower, J.upper)
        if J is not None and leg.limits is not None and (lim := leg.limits(J.name)) is not None:
            lo, hi = lim
        lo, hi = sorted((s * lo + o, s * hi + o))
        dyn = JointDynamics()
        if J is not None:
            gear = leg.gear if j + 1 == actuated_index else 1.0
            dyn = joint_dynamics(J, gear, leg.armature, leg.joint_terms)
            if dyn.stiffness and (s, o) != (1.0, 0.0):
                dyn = replace(dyn, rest_position=s * dyn.rest_position + o)
        dyns_.append(dyn)
        alpha, d_j, theta, r_j = (float(v) for v in chain.params[j])
        if j > 0 and kinds[j] == REVOLUTE:
            theta -= o
        elif j > 0:
            r_j += (shift if j == 2 else 0.0) - o
        if j > 0 and abs(theta) <= SNAP:
            theta = 0.0
        if j > 0 and abs(r_j) <= SNAP * leg.scale:
            r_j = 0.0
        try:
            joints_.append(Joint(kinds[j], alpha, d_j, theta, r_j, lo, hi, dyn))
        except ArchitectureError as err:
            raise ModelImportError(f"joint {shown(names[j])}: {err}", (), (names[j],)) from err
    # the frames at the file's zero configuration (the links' inertias are given
    # in them): the joints at their offsets; frame 0i (joint 1 at 0) is the chain's
    frames = np.empty((3, 4, 4))
    T = chain.base
    for j in range(3):
        T = T @ joints_[j].transform(offsets[j] if j > 0 else 0.0)
        frames[j] = T
    refs_ = [
        None if r is None else s * r + o for r, s, o in zip(leg.refs, signs, offsets, strict=True)
    ]
    # reference joint values (the U angles of an S-S leg solved from the rod)
    q_ref_ = _reference_values(
        joints_,
        actuated_index,
        chain.base,
        tip,
        refs_,
        leg.target,
    )
    arch_ = classify(tuple(joints_), actuated_index, tip, q_ref_)
    if arch_.name in ("ups", "ups-offset") and q_ref_[2] + joints_[2].r <= 0.0:
        # the closed form's slide is the distance from the U joint to P_i (> 0):
        # a slide that points from P_i to the U joint is not that leg as it is
        arch_ = LegArchitecture(tuple(joints_), actuated_index, tip, 1, "custom", q_ref_)
    return _LegForm(chain, joints_, dyns_, q_ref_, arch_, signs, offsets, tip, frames)


def _closed_form_fits(form: _LegForm, scale: float, any_branch: bool = False) -> bool:
    """Whether the leg is a named architecture whose closed-form inverse geometry gives
    the file's reference joint values (mod 2 pi) from its reference tip position; unless
    ``any_branch``, a U-P-S leg also on the branch +1 (the ideal 6-UPS form)."""
    from stewart_pin.kinematics.leg_chains import leg_inverse_geometry

    arch = form.arch
    if arch.name == "custom":
        return False
    branch = arch.branch_at(form.q_ref)
    if arch.name in ("ups", "ups-offset") and branch < 0 and not any_branch:
        return False
    leg = arch.replace(branch=branch)
    try:
        q = leg_inverse_geometry(leg, leg.tip_position(form.q_ref))[0]
    except StewartPinError:
        return False
    diff = q - form.q_ref
    for j, joint in enumerate(leg.joints):
        if joint.revolute:
            diff[j] = math.remainder(float(diff[j]), 2.0 * math.pi)
        else:
            diff[j] /= scale
    return bool(np.abs(diff).max() <= 1e-9)


def compensated_gravity(model: KinematicModel, rec: Recognition) -> tuple[np.ndarray, bool]:
    """The model's gravity with the bodies' gravity compensation (``TreeBody.gravcomp``),
    and whether it is uniform: the same fraction c on every moving body with mass is
    gravity scaled by 1 - c (exact: every weight scaled; noted; the robot keeps its
    closed forms); else the model's gravity, the compensation per body
    (:func:`link_gravcomp`: the description's ``platform_gravcomp``, ``leg_gravcomp``)."""
    fixed = set(rec.links[rec.ground].bodies)
    moving = [
        b
        for b, body in enumerate(model.bodies)
        if b not in fixed and body.inertia[9] > 0.0 and not body.virtual
    ]
    values = {model.bodies[b].gravcomp for b in moving}
    if values <= {0.0}:
        return model.gravity, True
    if len(values) == 1:
        c = values.pop()
        model.notes.append(
            f"gravity compensation ({c:g} of every moving body's weight): imported as gravity "
            f"scaled by {1.0 - c:g}"
        )
        return (1.0 - c) * model.gravity, True
    return model.gravity, False


def link_gravcomp(model: KinematicModel, links: Sequence[Link], li: int | None) -> float:
    """The gravity compensation of link ``li`` (``None``: a massless link, 0): the one its
    bodies with mass share; :class:`ModelImportError` naming them when they differ (one
    factor per link is exact only when its bodies share it: the compensated weights of
    bodies compensated differently do not act at the link's centre of mass)."""
    if li is None:
        return 0.0
    massive = [
        b
        for b in links[li].bodies
        if model.bodies[b].inertia[9] > 0.0 and not model.bodies[b].virtual
    ]
    values = {model.bodies[b].gravcomp for b in massive}
    if len(values) > 1:
        names = [model.bodies[b].name for b in massive]
        raise ModelImportError(
            f"bodies {shown_list(names[:8])}{' ...' if len(names) > 8 else ''} are fixed "
            "together into one link but have different gravity compensations ("
            + ", ".join(f"{model.bodies[b].gravcomp:g}" for b in massive[:8])
            + "): stewart-pin gives each link one factor (exact when its bodies share it); "
            "give them the same gravcomp",
            tuple(names),
        )
    return values.pop() if values else 0.0


def _wraps(joints: Sequence[TreeJoint | None]) -> tuple[float, ...]:
    """Where each revolute file joint's value is given (``LegSource.wraps``): from the
    lower end of a range of a full turn or more (such a range limits nothing: the angle
    is taken modulo 2 pi into it), else from -pi."""
    out = []
    for J in joints:
        full = (
            J is not None
            and J.kind == REVOLUTE
            and math.isfinite(J.lower)
            and J.upper - J.lower >= 2.0 * math.pi * (1.0 - 1e-12)
        )
        out.append(float(J.lower) if full and J is not None else -math.pi)
    return tuple(out)


def _reference_values(
    joints: list[Joint],
    actuated: int,
    base: np.ndarray,
    tip: np.ndarray,
    refs: list[float | None],
    target: np.ndarray,
) -> np.ndarray:
    """The leg's joint values at the reference configuration: the file's values, the
    unknown ones (an S-S leg's universal joint) solved by Gauss-Newton so that the tip
    reaches ``target`` (F0) with the known ones fixed (frame 0i at ``base``, P_i at
    ``tip`` in frame 3i)."""
    q = np.array([0.0 if r is None else float(r) for r in refs])
    free = [j for j, r in enumerate(refs) if r is None]
    if not free:
        return q
    leg = LegArchitecture(tuple(joints), actuated, tip, 1, "custom")
    for _ in range(50):
        err = leg.tip_position(q, base) - target
        if np.linalg.norm(err) < 1e-15:
            break
        J = np.empty((3, len(free)))
        h = 1e-7
        for c, j in enumerate(free):
            dq = q.copy()
            dq[j] += h
            J[:, c] = (leg.tip_position(dq, base) - leg.tip_position(q, base)) / h
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
    platform_gravcomp: float = 0.0,
    leg_gravcomp: np.ndarray | None = None,
) -> tuple[RobotDescription, bool]:
    """The description: the paper's ideal 6-UPS form when every leg is an ideal ``ups``
    leg on its +1 branch with one stroke and finite U-joint limits and no body has its own
    gravity compensation; general legs else."""
    compensated = platform_gravcomp != 0.0 or (leg_gravcomp is not None and np.any(leg_gravcomp))
    ideal = not compensated and all(
        leg.name == "ups"
        and leg.branch == 1
        and all(j.dynamics == JointDynamics() for j in leg.joints)
        for leg in legs
    )
    if ideal:
        stroke = np.array([[leg.joints[2].lower, leg.joints[2].upper] for leg in legs])
        u = np.array([[[j.lower, j.upper] for j in leg.joints[:2]] for leg in legs])
        # strokes equal to round-off (a file's joint zeros moved to each leg's home
        # length): the first leg's
        ideal = (
            bool(np.all(np.abs(stroke - stroke[0]) <= 1e-12 * np.abs(stroke[0]).max()))
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
        platform_gravcomp=platform_gravcomp,
        leg_gravcomp=leg_gravcomp,  # type: ignore[arg-type] # None: zeros
    )
    return desc, False


def joint_dynamics(
    J: TreeJoint,
    gear: float,
    armature: dict[str, float] | None,
    joint_terms: Callable[[str], JointDynamics | None] | None,
) -> JointDynamics:
    """A file joint's :class:`JointDynamics`: the sidecar's full terms when it gives them
    (``joint_terms``), else the file's armature (plus ``armature[name]``), damping as
    viscous friction, Coulomb friction, spring about its rest position, the transmission
    ``gear`` (1: none); :class:`ModelImportError` naming the joint for a bad value."""
    full = joint_terms(J.name) if joint_terms is not None else None
    if full is not None:
        return full
    try:
        return JointDynamics(
            armature=J.armature + float((armature or {}).get(J.name, 0.0)),
            viscous=J.damping,
            coulomb=J.coulomb,
            stiffness=J.stiffness,
            rest_position=J.rest if J.stiffness else 0.0,
            gear_ratio=gear if gear != 1.0 else None,
        )
    except JointDynamicsError as err:
        raise ModelImportError(f"joint {shown(J.name)}: {err}", (), (J.name,)) from err


__all__ = [
    "AXIS_TOLERANCE",
    "CLOSURE_TOLERANCE",
    "EXACT_CLOSURE",
    "PARALLEL_NOTICE",
    "SPIN_TOLERANCE",
    "ImportReport",
    "ImportResult",
    "LegReport",
    "LinkPoses",
    "assign_actuators",
    "build",
    "joint_dynamics",
    "remove_spin",
    "robot_name",
    "rod_asymmetry",
]
