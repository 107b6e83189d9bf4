"""URDF in: a URDF read with yourdfpy, and its loop closures, as the neutral tree of
:mod:`stewart_pin.importers.tree`.

URDF holds a tree; a hexapod's loops come from elsewhere (:func:`read_urdf`):

- the project's own sidecar ``<stem>.closures.json`` (``docs/closures.md``): the point
  closures, the actuated joints, gravity, the joint terms URDF cannot hold (armature,
  springs, transmissions, true limits) and the home configuration;
- onshape-to-robot's and placo's frame pairs: fixed frames (links) ``closing_<k>_1`` on
  the leg and ``closing_<k>_2`` on the platform, whose origins coincide;
- pairs ``(name1, name2)`` of links or frames given by the caller.

Joints: ``revolute``, ``continuous`` (a revolute joint without limits), ``prismatic``,
``fixed`` (the child is lumped into its parent), ``floating`` (the platform's free
joint). ``planar`` and ``mimic`` joints are refused. ``<dynamics damping friction>`` are
the viscous and Coulomb coefficients; ``<transmission>`` elements (their order) name the
actuated joints and their ``mechanicalReduction`` the gear. Visual and collision geometry
is never read (no mesh file is opened). F0 is the root link's frame.

The XML is parsed first by lxml without entity resolution or network access; a file it
cannot parse is refused (yourdfpy alone would try to "recover" it).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, decode_utf8
from stewart_pin._extras import require
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.exceptions import (
    FileFormatError,
    InputError,
    JointDynamicsError,
    ModelImportError,
)
from stewart_pin.formats._urdf_checks import check_urdf_numbers, urdf_cycle
from stewart_pin.formats.urdf import (
    CLOSURE_FORMAT,
    GRAVCOMP_KEY,
    JOINT_TERMS_KEY,
    non_finite_number,
    parse_closures,
)
from stewart_pin.importers.tree import (
    FREE,
    KinematicModel,
    TreeActuator,
    TreeBody,
    TreeClosure,
    TreeJoint,
    shown,
)

#: onshape-to-robot's closing frames: ``closing_<k>_1`` (leg side), ``closing_<k>_2``.
CLOSING_FRAME = re.compile(r"closing_(.+)_([12])")


@dataclass
class UrdfRead:
    """What :func:`read_urdf` gives :func:`~stewart_pin.importers.build.build`."""

    model: KinematicModel
    actuated: list[str] | None
    joint_terms: Callable[[str], JointDynamics | None]
    limits: Callable[[str], tuple[float, float] | None]
    sidecar: Path | None = None
    terms: dict[str, JointDynamics] = field(default_factory=dict)
    platform: str | None = None
    home_pose: np.ndarray | None = None


def _yourdfpy() -> Any:
    """The ``yourdfpy`` module, or :class:`MissingDependencyError` with the install hint."""
    (yourdfpy,) = require("reading URDF", "import", "yourdfpy")
    return yourdfpy


def _strict_parse(path: Path) -> Any:
    """The file's root element; refuses a file that is not well-formed XML, or whose
    ``<inertia>`` / ``<mass>`` miss attributes (yourdfpy would default them to 1 kg m^2 /
    0 kg)."""
    (etree,) = require("reading URDF", "import", "lxml.etree")

    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)
    try:
        root = etree.parse(str(path), parser).getroot()
    except (etree.XMLSyntaxError, OSError) as e:
        raise FileFormatError(f"{path} is not well-formed XML: {e}") from e
    if root.tag != "robot":
        raise FileFormatError(f"{path}: the root element is <{root.tag}>, not <robot> (a URDF)")
    bad = non_finite_number(root)  # named first: the strict check's message is about format
    if bad is not None:
        raise ModelImportError(f"{path}: {bad}: every number of a URDF must be finite")
    check_urdf_numbers(root, str(path), FileFormatError)  # yourdfpy's float() is lenient
    cycle = urdf_cycle(root)  # the tree walk below would not end
    if cycle is not None:
        raise ModelImportError(
            f"{path}: {cycle.message} (loop closures go in the sidecar, docs/closures.md)",
            (cycle.parent, cycle.child),
            (cycle.joint,),
        )
    for el in root.iter("inertia"):
        missing = [k for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz") if el.get(k) is None]
        if missing:
            raise FileFormatError(
                f"{path} line {el.sourceline}: <inertia> misses {', '.join(missing)}"
            )
    for el in root.iter("mass"):
        if el.get("value") is None:
            raise FileFormatError(f"{path} line {el.sourceline}: <mass> has no value")
    return root


def _transmissions(root: Any, path: Path) -> list[TreeActuator]:
    """The ``<transmission>`` elements in order: the first joint each drives and its
    ``mechanicalReduction`` (under ``<actuator>``, or under ``<joint>`` in the older
    format; 1 without one). yourdfpy 0.0.x does not read them."""
    out: list[TreeActuator] = []
    for n, t in enumerate(root.findall("transmission")):
        joint = t.find("joint")
        if joint is None or not joint.get("name"):
            raise FileFormatError(
                f"{path} line {t.sourceline}: <transmission> without a <joint name=...>"
            )
        reduction = t.find("actuator/mechanicalReduction")
        if reduction is None:
            reduction = joint.find("mechanicalReduction")
        gear = 1.0
        if reduction is not None:
            try:
                gear = float((reduction.text or "").strip())
            except ValueError as e:
                raise FileFormatError(
                    f"{path} line {reduction.sourceline}: mechanicalReduction "
                    f"{shown(reduction.text or '')} is not a number"
                ) from e
        name = t.get("name") or f"transmission{n + 1}"
        out.append(TreeActuator(str(name), str(joint.get("name")), gear))
    return out


def _khalil(inertial: Any) -> np.ndarray:
    """Khalil parameters (10,) in the link frame from a yourdfpy ``Inertial``."""
    if inertial is None:
        return np.zeros(10)
    T = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
    mass = float(inertial.mass or 0.0)
    I = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, float)
    R, c = T[:3, :3], T[:3, 3]
    I_c = R @ I @ R.T
    I_O = I_c + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *(mass * c), mass]
    )


def _load_sidecar(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(decode_utf8(path.read_bytes(), path))
    except (OSError, ValueError, RecursionError) as e:
        raise FileFormatError(f"cannot read loop closures {path}: {e}") from e
    if not isinstance(data, dict):
        raise FileFormatError(f"{path}: a closure sidecar is a JSON object")
    return data


def _sidecar_terms(data: dict[str, Any], source: str) -> dict[str, dict[str, Any]]:
    terms = data.get(JOINT_TERMS_KEY)
    if terms is None:
        return {}
    if not isinstance(terms, dict):
        raise FileFormatError(f"{source}: '{JOINT_TERMS_KEY}' must be an object")
    return terms


def _dynamics(entry: Any, name: str, source: str, armature: float | None) -> JointDynamics:
    """A joint's :class:`JointDynamics` from its sidecar entry (``own_armature`` the
    joint's own armature; else the total less the reflected rotor inertia)."""
    if not isinstance(entry, dict):
        raise FileFormatError(f"{source}: joint terms of {shown(name)} must be an object")

    def num(key: str, default: float | None = 0.0) -> Any:
        value = entry.get(key, default)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FileFormatError(f"{source}: {key} of {shown(name)} must be a number")
        return float(value)

    try:
        dyn = JointDynamics(
            viscous=num("viscous"),
            coulomb=num("coulomb"),
            stiffness=num("stiffness"),
            rest_position=num("rest_position"),
            damping=num("damping"),
            gear_ratio=num("gear_ratio", None),
            screw_lead=num("screw_lead", None),
            rotor_inertia=num("rotor_inertia"),
        )
        own = num("own_armature", None)
        if own is None:
            own = num("armature") - dyn.transmission_ratio**2 * dyn.rotor_inertia
        if armature is not None:
            own = armature
        return JointDynamics(**{**dyn.__dict__, "armature": own})
    except JointDynamicsError as e:
        raise FileFormatError(f"{source}: joint terms of {shown(name)}: {e}") from e


def _limits(entry: Any, name: str, source: str) -> tuple[float, float] | None:
    """A joint's true limits from its sidecar entry (``lower`` and ``upper``, each a
    number or ``null`` for unbounded), or None when it gives neither;
    :class:`FileFormatError` for one alone, a value that is not a number (a boolean, a
    string, NaN) or a lower limit above the upper one."""
    if not isinstance(entry, dict) or ("lower" not in entry and "upper" not in entry):
        return None
    if "lower" not in entry or "upper" not in entry:
        given, missing = ("lower", "upper") if "lower" in entry else ("upper", "lower")
        raise FileFormatError(
            f"{source}: joint terms of {shown(name)} give a {given} limit without an "
            f"{missing} one (give both, null for unbounded)"
        )
    out = []
    for key, unbounded in (("lower", -math.inf), ("upper", math.inf)):
        value = entry[key]
        if value is None:
            out.append(unbounded)
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
            raise FileFormatError(
                f"{source}: the {key} limit of {shown(name)} must be a number or null "
                f"(unbounded), got {json.dumps(value)[:60]}"
            )
        else:
            out.append(float(value))
    if not out[0] <= out[1]:
        raise FileFormatError(
            f"{source}: the limits of {shown(name)} are reversed: lower {out[0]!r} > upper "
            f"{out[1]!r}"
        )
    return out[0], out[1]


#: Keys of a version-2 sidecar (``docs/closures.md``); any other is refused.
SIDECAR_KEYS = (
    "format",
    "version",
    "urdf",
    "description",
    "closures",
    "actuated_joints",
    "gravity",
    "platform",
    "home_pose",
    "home_joint_positions",
    JOINT_TERMS_KEY,
    GRAVCOMP_KEY,
)
#: Keys of a version-2 closure, by type.
CLOSURE_KEYS = {
    "point": ("name", "type", "link1", "point1", "link2", "point2"),
    "weld": ("name", "type", "link1", "frame1", "link2", "frame2"),
}


@dataclass(frozen=True)
class SidecarClosure:
    """A closure of a version-2 sidecar: ``"point"`` (``point1`` in ``link1`` coincides
    with ``point2`` in ``link2`` [m]) or ``"weld"`` (frame ``frame1`` of ``link1`` held on
    frame ``frame2`` of ``link2``: each a 4x4 pose in its link's frame, or ``None`` for
    the link's ``<inertial>`` frame, resolved by the reader)."""

    name: str
    kind: str
    link1: str
    link2: str
    point1: np.ndarray
    point2: np.ndarray
    frame1: np.ndarray | None
    frame2: np.ndarray | None


def _rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF's ``rpy`` (fixed-axis roll, pitch, yaw) as a rotation matrix."""
    r, p, y = (float(v) for v in rpy)

    def rot(axis: int, a: float) -> np.ndarray:
        c, s_ = math.cos(a), math.sin(a)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        R = np.eye(3)
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s_, s_, c
        return R

    return rot(2, y) @ rot(1, p) @ rot(0, r)


def parse_sidecar_v2(data: dict[str, Any], source: str) -> list[SidecarClosure]:
    """Validate a version-2 sidecar (``docs/closures.md``) strictly: every key known,
    every value of its type, numbers finite; returns its closures.
    :class:`FileFormatError` naming the key (and the closure) otherwise."""
    unknown = [str(k) for k in data if k not in SIDECAR_KEYS]
    if unknown:
        raise FileFormatError(
            f"{source}: unknown key(s) {', '.join(map(repr, unknown))} (a version-2 sidecar "
            f"has {', '.join(SIDECAR_KEYS)})"
        )
    for key in ("urdf", "description", "platform"):
        if key in data and not isinstance(data[key], str):
            raise FileFormatError(f"{source}: '{key}' must be a string, got {data[key]!r:.60}")
    items = data.get("closures")
    if not isinstance(items, list) or not items:
        raise FileFormatError(f"{source}: 'closures' must be a non-empty list")
    out: list[SidecarClosure] = []
    seen: set[str] = set()
    for n, c in enumerate(items, start=1):
        where = f"{source}: closure {n}"
        if not isinstance(c, dict):
            raise FileFormatError(f"{where} must be an object, got {c!r:.60}")
        kind = c.get("type")
        if kind not in CLOSURE_KEYS:
            raise FileFormatError(f"{where}: 'type' must be 'point' or 'weld', got {kind!r:.60}")
        name = c.get("name", f"closure{n}")
        if not isinstance(name, str):
            raise FileFormatError(f"{where}: 'name' must be a string, got {name!r:.60}")
        where = f"{source}: closure {n} ({shown(name)})"
        if name in seen:
            raise FileFormatError(f"{where}: two closures have that name")
        seen.add(name)
        keys = CLOSURE_KEYS[kind]
        unknown = [str(k) for k in c if k not in keys]
        if unknown:
            raise FileFormatError(
                f"{where}: unknown key(s) {', '.join(map(repr, unknown))} (a {kind} closure "
                f"has {', '.join(keys)})"
            )
        for key in ("link1", "link2"):
            if not isinstance(c.get(key), str):
                raise FileFormatError(
                    f"{where}: '{key}' must be a link name (a string), got {c.get(key)!r:.60}"
                )
        points: list[np.ndarray] = []
        frames: list[np.ndarray | None] = []
        for key in ("point1", "point2") if kind == "point" else ():
            if key not in c:
                raise FileFormatError(f"{where}: '{key}' is missing (3 numbers [m])")
            points.append(_vector(c[key], 3, f"{where}: '{key}'"))
        for key in ("frame1", "frame2") if kind == "weld" else ():
            frames.append(_frame(c.get(key, {}), f"{where}: '{key}'"))
        out.append(
            SidecarClosure(
                name,
                kind,
                c["link1"],
                c["link2"],
                points[0] if points else np.zeros(3),
                points[1] if points else np.zeros(3),
                frames[0] if frames else np.eye(4),
                frames[1] if frames else np.eye(4),
            )
        )
    return out


def _vector(value: Any, n: int, what: str) -> np.ndarray:
    """``n`` finite numbers (a JSON list), else :class:`FileFormatError` naming ``what``."""
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
    ):
        raise FileFormatError(f"{what} must be {n} finite numbers, got {json.dumps(value)[:60]}")
    return np.array(value, dtype=float)


def _frame(value: Any, what: str) -> np.ndarray | None:
    """A weld frame: ``{"xyz": [3], "rpy": [3]}`` (each optional, default zeros) as a 4x4
    pose, or ``"inertial"`` (``None``: the link's ``<inertial>`` origin)."""
    if value == "inertial":
        return None
    if not isinstance(value, dict):
        raise FileFormatError(
            f'{what} must be {{"xyz": [x, y, z], "rpy": [r, p, y]}} or "inertial", got '
            f"{json.dumps(value)[:60]}"
        )
    unknown = [str(k) for k in value if k not in ("xyz", "rpy")]
    if unknown:
        raise FileFormatError(f"{what}: unknown key(s) {', '.join(map(repr, unknown))} (xyz, rpy)")
    T = np.eye(4)
    T[:3, 3] = _vector(value.get("xyz", [0, 0, 0]), 3, f"{what} 'xyz'")
    T[:3, :3] = _rpy_matrix(_vector(value.get("rpy", [0, 0, 0]), 3, f"{what} 'rpy'"))
    return T


#: The keys of a version-1 ``"frame"`` closure (the project's URDF writer of chain legs).
FRAME_CLOSURE_KEYS = {"name", "type", "link1", "frame1", "link2", "frame2"}


def _frame_closure(
    item: dict[str, Any], source: str, body_of: Callable[[str, str], int]
) -> TreeClosure:
    """A version-1 sidecar's ``"frame"`` closure (``frame1`` in ``link1`` coincides with
    ``frame2`` in ``link2``, each ``{"xyz", "rpy"}``) as a weld of the tree."""
    name = item.get("name")
    where = f"{source}: closure {shown(str(name))}"
    if not isinstance(name, str) or set(item) != FRAME_CLOSURE_KEYS:
        raise FileFormatError(
            f"{where}: a frame closure has the keys {', '.join(sorted(FRAME_CLOSURE_KEYS))}"
        )
    F1 = _frame(item["frame1"], f"{where} 'frame1'")
    F2 = _frame(item["frame2"], f"{where} 'frame2'")
    if F1 is None or F2 is None:
        raise FileFormatError(f'{where}: a version-1 frame is {{"xyz", "rpy"}}')
    b1, b2 = body_of(str(item["link1"]), where), body_of(str(item["link2"]), where)
    return TreeClosure(name, "weld", b1, b2, T_1_2=F1 @ np.linalg.inv(F2), frame2=F2)


def read_urdf(
    path: str | Path, closures: Any = None, armature: dict[str, float] | None = None
) -> UrdfRead:
    """The neutral tree of a URDF and its closures (module docstring); see
    :func:`stewart_pin.importers.import_urdf` for the arguments."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"no URDF file {path}")
    root_element = _strict_parse(path)
    yourdfpy = _yourdfpy()
    try:
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as e:  # yourdfpy raises its own errors and ValueError
        raise FileFormatError(f"yourdfpy cannot read {path}: {e}") from e
    robot = urdf.robot
    links = {link.name: link for link in robot.links}
    joints = list(robot.joints)
    children = {j.child for j in joints}
    roots = [n for n in links if n not in children]
    if len(roots) != 1:
        raise ModelImportError(
            f"{path}: a URDF is a tree with one root link, found {len(roots)} "
            f"({', '.join(shown(r) for r in roots)})",
            tuple(roots),
        )
    names = [j.name for j in joints]
    if len(set(names)) != len(names):
        raise ModelImportError(f"{path}: two joints have one name", (), tuple(names))

    # the sidecar, when there is one
    sidecar: Path | None = None
    data: dict[str, Any] = {}
    pairs: list[tuple[str, str]] | None = None
    from_dict = isinstance(closures, dict)
    if from_dict:  # the sidecar's content
        data = closures
    elif isinstance(closures, (str, Path)):
        sidecar = Path(closures)
    elif closures is None:
        candidate = path.with_name(path.name.removesuffix(".urdf") + ".closures.json")
        sidecar = candidate if candidate.is_file() else None
    else:
        try:
            pairs = [(str(a), str(b)) for a, b in closures]
        except (TypeError, ValueError) as e:
            raise InputError(
                "closures must be a sidecar path or a list of pairs (name1, name2) of links "
                f"or frames, got {closures!r}"
            ) from e
    if sidecar is not None:
        data = _load_sidecar(sidecar)

    # bodies at the zero configuration (every joint 0; a floating platform at its origin)
    bodies = [TreeBody(roots[0], -1, None, np.eye(4), _khalil(links[roots[0]].inertial))]
    index = {roots[0]: 0}
    by_parent: dict[str, list[Any]] = {}
    for j in joints:
        by_parent.setdefault(j.parent, []).append(j)
    queue = [roots[0]]
    while queue:
        parent = queue.pop(0)
        for j in by_parent.get(parent, []):
            if j.child not in links:
                raise ModelImportError(
                    f"{path}: joint {shown(j.name)} names no link {shown(j.child)}"
                )
            if j.mimic is not None:
                raise ModelImportError(
                    f"joint {shown(j.name)} mimics {shown(j.mimic.joint)}: stewart-pin reads "
                    "independent joints",
                    (),
                    (j.name,),
                )
            origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
            pose = bodies[index[parent]].pose @ origin
            J: TreeJoint | None
            if j.type == "fixed":
                J = None
            elif j.type == "floating":
                J = TreeJoint(j.name, FREE)
            elif j.type in ("revolute", "continuous", "prismatic"):
                axis = np.array([1.0, 0.0, 0.0] if j.axis is None else j.axis, dtype=float)
                if not np.linalg.norm(axis) > 0:
                    raise ModelImportError(f"joint {shown(j.name)} has a zero axis", (), (j.name,))
                J = TreeJoint(
                    j.name,
                    "prismatic" if j.type == "prismatic" else "revolute",
                    pose[:3, 3].copy(),
                    pose[:3, :3] @ axis / np.linalg.norm(axis),
                )
                if j.type != "continuous" and j.limit is not None:
                    lo, hi = j.limit.lower, j.limit.upper
                    J.lower = -math.inf if lo is None else float(lo)
                    J.upper = math.inf if hi is None else float(hi)
                if j.dynamics is not None:
                    J.damping = float(j.dynamics.damping or 0.0)
                    J.coulomb = float(j.dynamics.friction or 0.0)
            else:
                raise ModelImportError(
                    f"joint {shown(j.name)} is {shown(str(j.type))}: stewart-pin reads revolute, "
                    "continuous, prismatic, fixed and floating joints",
                    (),
                    (j.name,),
                )
            bodies.append(
                TreeBody(j.child, index[parent], J, pose, _khalil(links[j.child].inertial))
            )
            index[j.child] = len(bodies) - 1
            queue.append(j.child)

    # closures
    tree_closures: list[TreeClosure] = []
    source = (
        str(sidecar) if sidecar is not None else "the closures given" if from_dict else str(path)
    )

    def body_of(link: str, what: str) -> int:
        if link not in index:
            raise ModelImportError(
                f"{what} names no link or frame {shown(link)} of {path}", (link,)
            )
        return index[link]

    version = data.get("version") if (sidecar is not None or from_dict) else None
    if (sidecar is not None or from_dict) and version == 2:
        if data.get("format") != CLOSURE_FORMAT:
            raise FileFormatError(f"{source}: not a '{CLOSURE_FORMAT}' document ('format')")
        for sc in parse_sidecar_v2(data, source):
            where = f"closure {shown(sc.name)}"
            b1, b2 = body_of(sc.link1, where), body_of(sc.link2, where)
            if sc.kind == "point":
                tree_closures.append(TreeClosure(sc.name, "point", b1, b2, sc.point1, sc.point2))
                continue
            F1 = sc.frame1 if sc.frame1 is not None else _inertial_origin(links[sc.link1])
            F2 = sc.frame2 if sc.frame2 is not None else _inertial_origin(links[sc.link2])
            tree_closures.append(
                TreeClosure(sc.name, "weld", b1, b2, T_1_2=F1 @ np.linalg.inv(F2), frame2=F2)
            )
    elif sidecar is not None or from_dict:
        items = data.get("closures") if isinstance(data, dict) else None
        welds = [
            w
            for w in (items if isinstance(items, list) else [])
            if isinstance(w, dict) and w.get("type") == "frame"
        ]
        for w in welds:  # the project's own weld closures (chain legs: frame1 == frame2)
            tree_closures.append(_frame_closure(w, source, body_of))
        if welds:
            data = {**data, "closures": [w for w in items if w not in welds]}  # type: ignore[union-attr]
        for c in parse_closures(data, source) if not welds or data["closures"] else []:
            tree_closures.append(
                TreeClosure(
                    c.name,
                    "point",
                    body_of(c.link1, f"closure {shown(c.name)}"),
                    body_of(c.link2, f"closure {shown(c.name)}"),
                    c.point1,
                    c.point2,
                )
            )
    elif pairs is not None:
        for a, b in pairs:
            tree_closures.append(
                TreeClosure(f"{a} = {b}", "point", body_of(a, "closures"), body_of(b, "closures"))
            )
    else:
        found: dict[str, dict[str, str]] = {}
        for name in links:
            match = CLOSING_FRAME.fullmatch(name)
            if match:
                found.setdefault(match.group(1), {})[match.group(2)] = name
        for key, pair in sorted(found.items()):
            if set(pair) != {"1", "2"}:
                raise ModelImportError(
                    f"closing frame {shown(next(iter(pair.values())))} has no partner "
                    f"(closing_{key}_1 and closing_{key}_2 come in pairs)",
                    tuple(pair.values()),
                )
            tree_closures.append(
                TreeClosure(
                    f"closing_{key}",
                    "point",
                    body_of(pair["1"], "closing"),
                    body_of(pair["2"], "closing"),
                )
            )

    # actuated joints: argument (caller), sidecar, transmissions
    actuators = _transmissions(root_element, path)
    actuated: list[str] | None = None
    if "actuated_joints" in data:
        names_ = data["actuated_joints"]
        if not isinstance(names_, list) or not all(isinstance(n, str) for n in names_):
            raise FileFormatError(f"{source}: 'actuated_joints' must be a list of joint names")
        actuated = list(names_)
    elif not actuators:
        actuated = None

    # gravity
    gravity = np.array([0.0, 0.0, -9.81])
    if "gravity" in data:
        try:
            gravity = check_array(data["gravity"], (3,), "gravity")
        except InputError as e:
            raise FileFormatError(f"{source}: 'gravity' must be 3 finite numbers: {e}") from e

    # per-body gravity compensation (URDF has none: the sidecar's "gravcomp")
    _sidecar_gravcomp(data, bodies, source, path.name)

    # the reference configuration
    values: dict[str, float] = {}
    free: dict[str, np.ndarray] = {}
    home_pose: np.ndarray | None = None
    reference = "the zero configuration"
    if "home_pose" in data:
        try:
            T = check_array(data["home_pose"], (4, 4), "home_pose")
        except InputError as e:
            raise FileFormatError(f"{source}: 'home_pose' must be a 4x4 pose: {e}") from e
        if version == 2 and not (
            np.abs(T[:3, :3].T @ T[:3, :3] - np.eye(3)).max() <= 1e-9
            and np.linalg.det(T[:3, :3]) > 0.0
            and np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0])
        ):
            raise FileFormatError(
                f"{source}: 'home_pose' must be a rigid transform (a rotation, bottom row 0 0 0 1)"
            )
        home_pose = T
        for tree_body in bodies:
            if tree_body.joint is not None and tree_body.joint.kind == FREE:
                free[tree_body.joint.name] = T
        reference = "the sidecar's home configuration"
    positions = data.get("home_joint_positions", {})
    if not isinstance(positions, dict):
        raise FileFormatError(f"{source}: 'home_joint_positions' must be an object")
    if version == 2:
        strangers = [str(k) for k in positions if k not in {j.name for j in joints}]
        if strangers:
            raise FileFormatError(
                f"{source}: 'home_joint_positions' names no joint "
                f"{', '.join(shown(n) for n in strangers)} of {path.name}"
            )
        if positions:
            reference = "the sidecar's home configuration"
    for key, value in positions.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise FileFormatError(f"{source}: home position of {shown(str(key))} must be a number")
        values[str(key)] = float(value)

    # joint terms the sidecar holds (and armature given by the caller)
    terms_data = _sidecar_terms(data, source)
    terms: dict[str, JointDynamics] = {}
    for jname, entry in terms_data.items():
        terms[str(jname)] = _dynamics(entry, str(jname), source, (armature or {}).get(str(jname)))
    limits = {str(n): lim for n, e in terms_data.items() if (lim := _limits(e, str(n), source))}
    joint_names = {j.name for j in joints}
    unknown_terms = [str(n) for n in terms_data if str(n) not in joint_names]
    if unknown_terms:
        raise ModelImportError(
            f"{source}: joint terms for {', '.join(shown(n) for n in unknown_terms)}: no "
            f"such joint in {path.name} (check the names)",
            (),
            tuple(unknown_terms),
        )
    if armature:
        unknown = [n for n in armature if n not in {j.name for j in joints}]
        if unknown:
            raise ModelImportError(
                f"armature given for {', '.join(shown(n) for n in unknown)}: no such joint",
                (),
                tuple(unknown),
            )

    model = KinematicModel(
        name=str(robot.name or ""),
        format="urdf",
        file=path.name,
        bodies=bodies,
        closures=tree_closures,
        actuators=actuators,
        gravity=gravity,
        reference=reference,
        values=values,
        balls={},
        free=free,
        notes=[],
        base_name=roots[0],
    )
    return UrdfRead(
        model,
        actuated,
        lambda n: terms.get(n),
        lambda n: limits.get(n),
        sidecar,
        terms,
        data.get("platform") if version == 2 else None,
        home_pose if not free else None,  # a floating platform is placed by it
    )


def _sidecar_gravcomp(
    data: dict[str, Any], bodies: list[TreeBody], source: str, urdf: str
) -> None:
    """Set ``TreeBody.gravcomp`` from the sidecar's ``gravcomp`` (link name -> the
    fraction of its weight removed, a number in [0, 1]); :class:`FileFormatError` for a
    bad value, :class:`ModelImportError` for a link the URDF does not have."""
    entry = data.get(GRAVCOMP_KEY)
    if entry is None:
        return
    if not isinstance(entry, dict):
        raise FileFormatError(f"{source}: '{GRAVCOMP_KEY}' must be an object (link -> factor)")
    by_name = {b.name: b for b in bodies[1:] if not b.virtual}
    for name, c in entry.items():
        if (
            isinstance(c, bool)
            or not isinstance(c, (int, float))
            or not (math.isfinite(c) and 0.0 <= c <= 1.0)
        ):
            raise FileFormatError(
                f"{source}: gravity compensation of {shown(str(name))} must be a number in "
                f"[0, 1] (the fraction of its weight removed), got {c!r:.60}"
            )
        if str(name) not in by_name:
            raise ModelImportError(
                f"{source}: gravity compensation for {shown(str(name))}: no such moving link "
                f"in {urdf} (check the names)",
                (str(name),),
            )
        by_name[str(name)].gravcomp = float(c)


def _inertial_origin(link: Any) -> np.ndarray:
    """A link's ``<inertial><origin>`` (4x4 in its frame; identity when it has none)."""
    inertial = getattr(link, "inertial", None)
    origin = None if inertial is None else inertial.origin
    return np.eye(4) if origin is None else np.asarray(origin, dtype=float)


def closing_pairs(names: Sequence[str]) -> list[tuple[str, str]]:
    """The ``(closing_<k>_1, closing_<k>_2)`` pairs among link names, sorted by k."""
    found: dict[str, dict[str, str]] = {}
    for name in names:
        match = CLOSING_FRAME.fullmatch(name)
        if match:
            found.setdefault(match.group(1), {})[match.group(2)] = name
    return [(p["1"], p["2"]) for _, p in sorted(found.items()) if set(p) == {"1", "2"}]


__all__ = ["CLOSING_FRAME", "UrdfRead", "closing_pairs", "read_urdf"]
