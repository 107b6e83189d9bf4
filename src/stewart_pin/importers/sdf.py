"""SDF in: a Gazebo SDFormat model (versions 1.4 to 1.11) read by a strict reader of the
project's own, as the neutral tree of :mod:`stewart_pin.importers.tree`.

No maintained SDFormat library installs from the package index (libsdformat's Python
bindings come with Gazebo's Debian packages only), so the file is read here, with lxml
(no entity resolution, no network), every number strictly (ASCII decimal, finite):

- one ``<model>``, at the top of the file or the one ``<model>`` of a ``<world>`` (a world
  holding several: the one with joints; other models and ``<include>`` of a world are not
  the robot, reported); the model's ``<pose>`` places it in the world, F0;
- ``<link>``: ``<pose>`` (``relative_to`` a link, joint or ``<frame>`` from 1.7; the model
  frame before), ``<inertial>`` (``<mass>``, ``<pose>`` and ``<inertia>`` ``ixx``..``izz``
  about the centre of mass in the inertial frame), ``<gravity>`` (false: the link's
  weight removed, its gravity compensation 1);
- ``<frame>`` (``attached_to``, ``<pose relative_to>``): for poses, and as a joint's parent
  or child (the link it is attached to);
- ``<joint>`` ``revolute``, ``continuous``, ``prismatic``, ``universal`` (two hinges, the
  first about ``<axis>`` carried by the parent, the second about ``<axis2>`` by the child),
  ``ball``, ``fixed``: ``<parent>``, ``<child>`` (a link, a frame, or ``world`` as the
  parent), ``<pose>`` (in the child link's frame unless ``relative_to``), ``<axis><xyz>``
  in the frame the version says (:func:`_axis_frame`: 1.4 the model frame; 1.5, 1.6 the
  joint frame unless ``<use_parent_model_frame>``; 1.7 on the joint frame unless
  ``expressed_in``), ``<limit><lower><upper>`` (``|x| >= 1e16``: unbounded, SDFormat's
  default), ``<dynamics>`` ``<damping>`` (viscous), ``<friction>`` (Coulomb),
  ``<spring_stiffness>``, ``<spring_reference>``; ``<dynamics>`` under a ball joint is
  ignored (Gazebo applies none), reported.

The file's poses are the reference configuration (every joint at zero). SDF writes a loop
as several joints with one child (the platform, the child of its six ball joints): a link
that is the child of several joints hangs from its one hinge, slide or universal joint if
it has one, else from its first fixed joint, else floats (a free body); its other joints
are the loop closures (a ball: a point; a fixed joint: a weld). A link that is nobody's
child floats, except the base: jointed to ``world``, or the canonical link of a
``<static>`` model, or else (neither: Gazebo would let it fall) fixed at its pose with a
report line. SDF has no actuators: :func:`default_actuated` picks them.

Refused, naming the element, its line and the file: ``<include>`` (expand it first),
nested models, joint types ``revolute2``, ``screw``, ``gearbox``, a moving link without
``<inertial>`` (SDFormat's default is 1 kg with a unit inertia), an ``<inertial>`` without
its ``<mass>`` or the diagonal of its ``<inertia>`` (same defaults), ``<inertial
auto="true">`` (computed from collisions), two links, joints or frames of one name, a
NaN, an infinity or text where a number goes, a pose graph that loops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._extras import require
from stewart_pin.description.leg_architecture import PRISMATIC, REVOLUTE
from stewart_pin.exceptions import FileFormatError, ModelImportError
from stewart_pin.formats._urdf_checks import strict_numbers
from stewart_pin.importers.tree import (
    BALL,
    FREE,
    KinematicModel,
    TreeBody,
    TreeClosure,
    TreeJoint,
    shown,
    shown_list,
)

#: The SDFormat versions read.
SDF_VERSIONS = ("1.4", "1.5", "1.6", "1.7", "1.8", "1.9", "1.10", "1.11")
#: SDFormat's default limits (``1e16``): a bound at least this large is no bound.
SDF_UNBOUNDED = 1e16
#: SDFormat's default gravity (a ``<world>`` without ``<gravity>``, a lone ``<model>``).
SDF_GRAVITY = (0.0, 0.0, -9.8)
#: The joint types read, and those refused with why.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "universal", "ball", "fixed")
_REFUSED_TYPES = {
    "revolute2": "two hinges on two links' axes (write it as two revolute joints)",
    "screw": "a coupled rotation and translation stewart-pin's legs do not have",
    "gearbox": "a coupling of two joints stewart-pin's legs do not have",
    "planar": "a 3-dof joint stewart-pin's legs do not have",
    "free": "not an SDFormat joint (a link that no joint holds floats)",
}
#: The hint shown when a file holds what the reader does not expand.
EXPAND_HINT = "expand it first (`gz sdf -p FILE > expanded.sdf`)"
_MODEL = "__model__"


@dataclass
class SdfRead:
    """What :func:`read_sdf` gives the import.

    Attributes:
        model: the neutral tree.
        one_dof: the file's 1-dof joints (revolute, continuous, prismatic; not the hinges
            of a universal joint) by name, with their order in the file.
        gravity_off: the links with ``<gravity>false</gravity>`` (their bodies' ``gravcomp``
            set to 1: their weights removed).
    """

    model: KinematicModel
    one_dof: dict[str, int] = field(default_factory=dict)
    gravity_off: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------ XML
def _parse(path: Path) -> Any:
    """The ``<sdf>`` root of a file: well-formed XML, no entities resolved, no network."""
    (etree,) = require("reading SDF", "import", "lxml.etree")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False)
    try:
        root = etree.parse(str(path), parser).getroot()
    except (etree.XMLSyntaxError, OSError) as e:
        raise FileFormatError(f"{path} is not well-formed XML: {e}") from e
    if root.tag != "sdf":
        raise FileFormatError(f"{path}: the root element is <{root.tag}>, not <sdf> (SDFormat)")
    return root


def _children(el: Any, tag: str) -> list[Any]:
    return [c for c in el if isinstance(c.tag, str) and c.tag == tag]


class _Reader:
    """The state of one file's reading: its path and version, for the messages."""

    def __init__(self, path: Path, version: tuple[int, int]):
        self.path, self.version = path, version

    # -------------------------------------------------------------------- messages
    def where(self, el: Any) -> str:
        return f"{self.path} line {el.sourceline}"

    def error(self, el: Any, message: str, cls: type[FileFormatError] = FileFormatError) -> Any:
        return cls(f"{self.where(el)}: {message}")

    # -------------------------------------------------------------------- values
    def numbers(self, el: Any, counts: Sequence[int], what: str) -> list[float]:
        text = el.text or ""
        values = strict_numbers(text)
        if values is None or len(values) not in counts:
            expected = " or ".join(str(c) for c in counts)
            raise self.error(
                el,
                f"{what} is {shown(text.strip())}: {expected} finite decimal number(s) "
                "expected (no NaN or infinity)",
                ModelImportError,
            )
        return values

    def number(self, parent: Any, tag: str, what: str, default: float | None) -> float:
        found = _children(parent, tag)
        if not found:
            if default is None:
                raise self.error(parent, f"{what} has no <{tag}>")
            return default
        return self.numbers(found[0], (1,), f"<{tag}> of {what}")[0]

    def boolean(self, el: Any, what: str) -> bool:
        text = (el.text or "").strip().lower()
        if text in ("true", "1"):
            return True
        if text in ("false", "0"):
            return False
        raise self.error(el, f"{what} is {shown(text)}: true or false expected")

    def flag(self, parent: Any, tag: str, what: str, default: bool) -> bool:
        found = _children(parent, tag)
        return self.boolean(found[0], f"<{tag}> of {what}") if found else default

    def pose(self, el: Any, owner: str) -> tuple[np.ndarray, str]:
        """``(the 4x4 pose, relative_to)`` of ``el``'s ``<pose>`` (identity, "" without
        one): ``x y z roll pitch yaw`` (fixed axes, URDF's convention) [m, rad], from 1.9
        ``degrees="true"`` and ``rotation_format="quat_xyzw"`` (``x y z qx qy qz qw``)."""
        found = _children(el, "pose")
        if not found:
            return np.eye(4), ""
        p = found[0]
        if len(found) > 1:
            raise self.error(found[1], f"{owner} has two <pose> elements")
        frame = p.get("frame")
        if frame:
            raise self.error(
                p,
                f'<pose frame="{frame}"> of {owner}: the frame attribute of SDFormat 1.5/1.6 '
                "is not read (its meaning was never settled); write the pose in the model "
                'frame, or use SDFormat 1.7+ relative_to="..."',
                ModelImportError,
            )
        relative_to = p.get("relative_to", "")
        if relative_to and self.version < (1, 7):
            raise self.error(p, f"<pose relative_to> of {owner}: SDFormat 1.7 or later")
        quat = p.get("rotation_format", "euler_rpy")
        if quat not in ("euler_rpy", "quat_xyzw"):
            raise self.error(p, f"<pose> of {owner}: rotation_format {shown(quat)} is not read")
        degrees_text = p.get("degrees", "false").strip().lower()
        if degrees_text not in ("true", "false", "1", "0"):
            raise self.error(p, f"<pose> of {owner}: degrees={shown(degrees_text)}")
        degrees = degrees_text in ("true", "1")
        if not (p.text or "").strip():  # <pose relative_to="f"/>: at f
            return np.eye(4), relative_to
        v = self.numbers(p, (7,) if quat == "quat_xyzw" else (6,), f"<pose> of {owner}")
        T = np.eye(4)
        T[:3, 3] = v[:3]
        if quat == "quat_xyzw":
            q = np.array(v[3:7])
            if not np.linalg.norm(q) > 0:
                raise self.error(p, f"<pose> of {owner}: a zero quaternion", ModelImportError)
            x, y, z, w = q / np.linalg.norm(q)
            T[:3, :3] = [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        else:
            r, pi_, y_ = (math.radians(a) if degrees else a for a in v[3:6])
            T[:3, :3] = _rpy(r, pi_, y_)
        return T, relative_to


def _rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (SDFormat's and URDF's fixed-axis angles)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _version(root: Any, path: Path) -> tuple[int, int]:
    text = (root.get("version") or "").strip()
    if text not in SDF_VERSIONS:
        raise FileFormatError(
            f"{path}: SDFormat version {shown(text) if text else '(none given)'}: stewart-pin "
            f"reads versions {SDF_VERSIONS[0]} to {SDF_VERSIONS[-1]} (convert an older file "
            "with `gz sdf -p FILE > converted.sdf`)"
        )
    major, minor = text.split(".")
    return int(major), int(minor)


def _find_model(root: Any, reader: _Reader, notes: list[str]) -> tuple[Any, np.ndarray, Any]:
    """``(the <model> element, its pose in the world, the <world> element or None)``."""
    path = reader.path
    worlds = _children(root, "world")
    models = _children(root, "model")
    for inc in _children(root, "include"):
        raise reader.error(
            inc,
            f"<include> of {shown(_include_uri(inc))}: stewart-pin does not fetch included "
            f"models; {EXPAND_HINT}",
            ModelImportError,
        )
    if len(worlds) + len(models) != 1:
        raise FileFormatError(
            f"{path}: an SDF file with one <model> (or one <world>) is read, found "
            f"{len(models)} model(s) and {len(worlds)} world(s)"
        )
    if models:
        return models[0], np.eye(4), None
    world = worlds[0]
    models = _children(world, "model")
    includes = _children(world, "include")
    if not models:
        if includes:
            raise reader.error(
                includes[0],
                f"the world's robot is an <include> of {shown(_include_uri(includes[0]))}: "
                f"stewart-pin does not fetch included models; {EXPAND_HINT}",
                ModelImportError,
            )
        raise reader.error(world, "the <world> holds no <model>", ModelImportError)
    chosen = models
    if len(models) > 1:
        chosen = [m for m in models if next(m.iter("joint"), None) is not None]
        if len(chosen) != 1:
            names = [str(m.get("name", "")) for m in (chosen or models)]
            raise reader.error(
                world,
                f"the <world> holds several models with joints ({shown_list(names)}): "
                "stewart-pin reads one robot; keep it alone in the file",
                ModelImportError,
            )
    others = [str(m.get("name", "")) for m in models if m is not chosen[0]]
    others += [_include_uri(i) for i in includes]
    if others:
        notes.append(f"the world's other models ignored: {shown_list(others)}")
    if _children(world, "joint"):
        raise reader.error(
            _children(world, "joint")[0],
            "a <joint> of the <world>: stewart-pin reads the joints of the robot's <model>",
            ModelImportError,
        )
    model = chosen[0]
    T, relative_to = reader.pose(model, f"model {shown(str(model.get('name', '')))}")
    if relative_to not in ("", "world"):
        raise reader.error(model, f"the model's pose is relative to {shown(relative_to)}")
    return model, T, world


def _include_uri(inc: Any) -> str:
    uri = _children(inc, "uri")
    return (uri[0].text or "").strip() if uri else ""


def _gravity(world: Any, reader: _Reader) -> np.ndarray:
    if world is None:
        return np.array(SDF_GRAVITY)
    found = _children(world, "gravity")
    if not found:
        found = [g for p in _children(world, "physics") for g in _children(p, "gravity")]
    if not found:
        return np.array(SDF_GRAVITY)
    return np.array(reader.numbers(found[0], (3,), "<gravity> of the world"))


# ------------------------------------------------------------------------------ reading
@dataclass
class _Joint:
    el: Any
    name: str
    kind: str
    parent: str  # a link name or "world"
    child: str
    order: int
    child_frame: str  # as written (a link or a frame): the joint pose's default frame


def read_sdf(path: str | Path) -> SdfRead:
    """The neutral tree of an SDF file (module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"no SDF file {path}")
    root = _parse(path)
    reader = _Reader(path, (1, 0))
    reader.version = _version(root, path)
    notes: list[str] = []
    model_el, T_model, world = _find_model(root, reader, notes)
    model_name = str(model_el.get("name", ""))

    for tag in ("include", "model"):
        for el in model_el.iter(tag):
            if el is model_el:
                continue
            if tag == "include":
                raise reader.error(
                    el,
                    f"<include> of {shown(_include_uri(el))} in model {shown(model_name)}: "
                    f"stewart-pin does not fetch included models; {EXPAND_HINT}",
                    ModelImportError,
                )
            raise reader.error(
                el,
                f"nested model {shown(str(el.get('name', '')))}: write its links and joints "
                f"in model {shown(model_name)} itself",
                ModelImportError,
            )

    # names: links, joints and frames share one name space
    links = _children(model_el, "link")
    joint_els = _children(model_el, "joint")
    frames = _children(model_el, "frame")
    if not links:
        raise reader.error(model_el, f"model {shown(model_name)} has no <link>", ModelImportError)
    kinds: dict[str, tuple[str, Any]] = {}
    for kind, els in (("link", links), ("joint", joint_els), ("frame", frames)):
        for el in els:
            name = el.get("name")
            if not name:
                raise reader.error(el, f"a <{kind}> without a name")
            if name in kinds or name in ("world", _MODEL):
                first = kinds.get(name, ("reserved name", None))[0]
                raise reader.error(
                    el,
                    f"two elements named {shown(name)} in model {shown(model_name)} (a "
                    f"{first} and a {kind}): every link, joint and frame needs its own name",
                    ModelImportError,
                )
            kinds[name] = (kind, el)
    canonical = model_el.get("canonical_link") or str(links[0].get("name"))
    if kinds.get(canonical, ("",))[0] != "link":
        raise reader.error(model_el, f"canonical_link {shown(canonical)} names no link")

    # the joints' ends
    joints: list[_Joint] = []
    for n, el in enumerate(joint_els):
        name = str(el.get("name"))
        kind = (el.get("type") or "").strip()
        if kind in _REFUSED_TYPES:
            raise reader.error(
                el,
                f"joint {shown(name)} is a {kind} joint: {_REFUSED_TYPES[kind]}; stewart-pin "
                f"reads {', '.join(JOINT_TYPES)} joints",
                ModelImportError,
            )
        if kind not in JOINT_TYPES:
            raise reader.error(
                el,
                f"joint {shown(name)} has type {shown(kind)}: stewart-pin reads "
                f"{', '.join(JOINT_TYPES)} joints",
                ModelImportError,
            )
        ends = []
        for tag in ("parent", "child"):
            found = _children(el, tag)
            if len(found) != 1 or not (found[0].text or "").strip():
                raise reader.error(el, f"joint {shown(name)} needs one <{tag}>")
            ends.append((found[0].text or "").strip())
        parent = _link_of(ends[0], kinds, canonical, reader, el, name, "parent")
        child = _link_of(ends[1], kinds, canonical, reader, el, name, "child")
        if child == "world":
            raise reader.error(el, f"joint {shown(name)} has the world as its child")
        if parent == child:
            raise reader.error(
                el, f"joint {shown(name)} joins link {shown(child)} to itself", ModelImportError
            )
        joints.append(_Joint(el, name, kind, parent, child, n, ends[1]))

    # poses at the zero configuration, in the world (F0)
    poses: dict[str, np.ndarray] = {}
    visiting: list[str] = []

    def world_pose(name: str, el: Any) -> np.ndarray:
        if name == _MODEL:
            return T_model
        if name in poses:
            return poses[name]
        if name not in kinds:
            raise reader.error(
                el, f"pose relative to {shown(name)}: no link, joint or frame of that name"
            )
        if name in visiting:
            loop = [*visiting[visiting.index(name) :], name]
            raise reader.error(
                kinds[name][1],
                f"the poses are relative to each other in a loop: {' -> '.join(loop)}",
                ModelImportError,
            )
        visiting.append(name)
        kind, element = kinds[name]
        T, relative_to = reader.pose(element, f"{kind} {shown(name)}")
        if not relative_to:
            if kind == "joint":
                relative_to = next(j.child_frame for j in joints if j.name == name)
            elif kind == "frame":
                relative_to = element.get("attached_to") or _MODEL
            else:
                relative_to = _MODEL
        if relative_to == "world":
            raise reader.error(element, f"{kind} {shown(name)}: a pose relative to the world")
        poses[name] = world_pose(relative_to, element) @ T
        visiting.pop()
        return poses[name]

    for name in kinds:
        world_pose(name, model_el)

    # inertias (Khalil's parameters in each link's frame) and per-link gravity
    inertia: dict[str, np.ndarray | None] = {}
    gravity_off: list[str] = []
    for el in links:
        name = str(el.get("name"))
        inertia[name] = _inertial(el, name, poses, world_pose, reader)
        if not reader.flag(el, "gravity", f"link {shown(name)}", True):
            gravity_off.append(name)

    # the spanning tree: each link's joint from its parent; the others close loops
    by_child: dict[str, list[_Joint]] = {}
    for j in joints:
        by_child.setdefault(j.child, []).append(j)
    tree_joint: dict[str, _Joint] = {}
    closing: list[_Joint] = []
    for el in links:
        name = str(el.get("name"))
        incoming = by_child.get(name, [])
        if not incoming:
            continue
        moving = [j for j in incoming if j.kind not in ("ball", "fixed")]
        if len(moving) > 1:
            raise reader.error(
                moving[1].el,
                f"link {shown(name)} is the child of the joints "
                f"{shown_list([j.name for j in moving])}: a loop may close through ball or "
                "fixed joints only (a point or a weld); make the link the child of one hinge, "
                "slide or universal joint",
                ModelImportError,
            )
        if moving:
            tree_joint[name] = moving[0]
        elif len(incoming) == 1 or any(j.kind == "fixed" for j in incoming):
            tree_joint[name] = next((j for j in incoming if j.kind == "fixed"), incoming[0])
        closing.extend(j for j in incoming if tree_joint.get(name) is not j)

    static = reader.flag(model_el, "static", f"model {shown(model_name)}", False)
    to_world = any(j.parent == "world" for j in joints)
    roots = [str(el.get("name")) for el in links if str(el.get("name")) not in tree_joint]
    base: str | None = None
    if not to_world and roots:
        # the canonical link, unless it is the child of joints (a platform closing loops)
        alone = [r for r in roots if r not in by_child] or roots
        base = canonical if canonical in alone else alone[0]
        if not static:
            notes.append(
                f"the base link {shown(base)} is neither <static> nor jointed to the world: "
                "fixed at its pose (Gazebo would let the model fall)"
            )

    # bodies, parents first
    children: dict[str, list[str]] = {}
    for child, j in tree_joint.items():
        children.setdefault(j.parent, []).append(child)
    bodies = [TreeBody("world", -1, None, np.eye(4))]
    index = {"world": 0}
    fixed_to_world = {"world"}
    one_dof: dict[str, int] = {}
    queue = ["world", *roots]
    order: list[str] = []
    while queue:
        name = queue.pop(0)
        if name != "world":
            order.append(name)
        queue.extend(children.get(name, []))
    for name in order:
        T = poses[name]
        params = inertia[name]
        tj = tree_joint.get(name)
        if tj is not None:
            up = index[tj.parent]
            tree_joints = _tree_joints(tj, poses, T_model, reader)
        else:
            up = 0
            tree_joints = [] if name == base else [TreeJoint(f"{name} (free)", FREE)]
        if not tree_joints and (tj is None or tj.parent in fixed_to_world):
            fixed_to_world.add(name)
        if params is None:
            if name not in fixed_to_world:
                el = kinds[name][1]
                raise reader.error(
                    el,
                    f"link {shown(name)} has no <inertial>: SDFormat's default is 1 kg with a "
                    "unit inertia, which no part of a hexapod has; write its <inertial>",
                    ModelImportError,
                )
            params = np.zeros(10)
        gravcomp = 1.0 if name in gravity_off else 0.0  # <gravity>false</gravity>
        for k, J in enumerate(tree_joints):
            last = k == len(tree_joints) - 1
            bodies.append(
                TreeBody(
                    name,
                    up,
                    J,
                    T,
                    params if last else np.zeros(10),
                    virtual=not last,
                    gravcomp=gravcomp if last else 0.0,
                )
            )
            up = len(bodies) - 1
        if not tree_joints:
            bodies.append(TreeBody(name, up, None, T, params, gravcomp=gravcomp))
        index[name] = len(bodies) - 1
        if tj is not None and tj.kind in ("revolute", "continuous", "prismatic"):
            one_dof[tj.name] = tj.order
    unreached = [el for el in links if str(el.get("name")) not in order]
    if unreached:
        name = str(unreached[0].get("name"))
        j = tree_joint[name]
        raise reader.error(
            j.el,
            f"joint {shown(j.name)}: link {shown(name)} is not reached from the base or the "
            "world (its joints form a cycle of parents and children)",
            ModelImportError,
        )

    # loop closures
    closures: list[TreeClosure] = []
    for j in sorted(closing, key=lambda x: x.order):
        b1, b2 = index[j.parent], index[j.child]
        W1, W2 = bodies[b1].pose, bodies[b2].pose
        if j.kind == "ball":
            anchor = poses[j.name][:3, 3]
            p1 = np.linalg.inv(W1)[:3, :3] @ anchor + np.linalg.inv(W1)[:3, 3]
            p2 = np.linalg.inv(W2)[:3, :3] @ anchor + np.linalg.inv(W2)[:3, 3]
            closures.append(TreeClosure(j.name, "point", b1, b2, p1, p2))
            _ball_terms(j, reader, notes)
        else:
            F2 = np.linalg.inv(W2) @ poses[j.name]  # the joint's frame in the child
            closures.append(
                TreeClosure(j.name, "weld", b1, b2, T_1_2=np.linalg.inv(W1) @ W2, frame2=F2)
            )
    for j in joints:
        if j.kind == "ball" and j not in closing:
            _ball_terms(j, reader, notes)
    if gravity_off:
        notes.append(
            f"links with <gravity>false</gravity>: {shown_list(gravity_off)}: their weights "
            "removed (gravity compensation 1)"
        )
    tree = KinematicModel(
        name=model_name,
        format="sdf",
        file=path.name,
        bodies=bodies,
        closures=closures,
        actuators=[],
        gravity=_gravity(world, reader),
        reference="the file's poses",
        values={},
        balls={},
        free={},
        notes=notes,
        base_name=base or "world",
    )
    return SdfRead(tree, one_dof, gravity_off)


def _link_of(
    name: str,
    kinds: dict[str, tuple[str, Any]],
    canonical: str,
    reader: _Reader,
    el: Any,
    joint: str,
    end: str,
) -> str:
    """The link a joint's ``<parent>`` / ``<child>`` names: a link, ``world`` (a parent),
    or a frame (from 1.8: the link it is attached to)."""
    if name == "world":
        return name
    if "::" in name:
        raise reader.error(
            el,
            f"joint {shown(joint)}: {end} {shown(name)} is in another model (scoped names "
            "are not read)",
            ModelImportError,
        )
    seen = []
    while True:
        kind, element = kinds.get(name, ("", None))
        if kind == "link":
            return name
        if kind == "frame":
            seen.append(name)
            name = element.get("attached_to") or canonical
        elif kind == "joint":
            seen.append(name)
            found = _children(element, "child")
            name = (found[0].text or "").strip() if found else ""
        else:
            raise reader.error(el, f"joint {shown(joint)}: {end} {shown(name)} is no link")
        if name in seen:
            raise reader.error(el, f"joint {shown(joint)}: frames attached in a loop")


def _inertial(
    el: Any, name: str, poses: dict[str, np.ndarray], world_pose: Any, reader: _Reader
) -> np.ndarray | None:
    """Khalil's parameters (10,) of a link in its frame, or None without ``<inertial>``."""
    found = _children(el, "inertial")
    if not found:
        return None
    inertial = found[0]
    owner = f"the <inertial> of link {shown(name)}"
    if (inertial.get("auto") or "").strip().lower() in ("true", "1"):
        raise reader.error(
            inertial,
            f'{owner} is auto="true" (computed from the collisions): write its mass and inertia',
            ModelImportError,
        )
    mass = reader.number(inertial, "mass", owner, None)
    T, relative_to = reader.pose(inertial, owner)
    if relative_to:
        T = np.linalg.inv(poses[name]) @ world_pose(relative_to, inertial) @ T
    tensor = _children(inertial, "inertia")
    if not tensor:
        raise reader.error(inertial, f"{owner} has no <inertia>")
    values = {}
    for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
        default = None if key in ("ixx", "iyy", "izz") else 0.0
        owner = f"the <inertia> of link {shown(name)}"
        values[key] = reader.number(tensor[0], key, owner, default)
    I = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    R, c = T[:3, :3], T[:3, 3]
    I_c = R @ I @ R.T
    I_O = I_c + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *(mass * c), mass]
    )


def _axis_frame(j: _Joint, axis: Any, poses: dict[str, np.ndarray], T_model: np.ndarray,
                reader: _Reader) -> np.ndarray:  # fmt: skip
    """The rotation (3, 3) of the frame an ``<axis>``'s ``<xyz>`` is written in, in F0.

    1.4: the model frame (the 1.4 -> 1.5 conversion adds ``use_parent_model_frame``);
    1.5, 1.6: the joint frame, the model frame with ``<use_parent_model_frame>true``;
    1.7 on: the joint frame, or the frame ``expressed_in`` names (``__model__``...)."""
    xyz = _children(axis, "xyz")
    upmf = _children(axis, "use_parent_model_frame")
    if reader.version >= (1, 7):
        if upmf:
            raise reader.error(
                upmf[0],
                f"joint {shown(j.name)}: <use_parent_model_frame> is SDFormat 1.5/1.6; from "
                '1.7 write <xyz expressed_in="__model__">',
                ModelImportError,
            )
        frame = xyz[0].get("expressed_in", "") if xyz else ""
        if frame:
            return _pose_of(frame, poses, T_model, reader, axis, j.name)[:3, :3]
        return poses[j.name][:3, :3]
    parent_model = reader.version == (1, 4)
    if upmf:
        parent_model = reader.boolean(upmf[0], f"<use_parent_model_frame> of {shown(j.name)}")
    return T_model[:3, :3] if parent_model else poses[j.name][:3, :3]


def _pose_of(
    frame: str, poses: dict[str, np.ndarray], T_model: np.ndarray, reader: _Reader, el: Any,
    joint: str,
) -> np.ndarray:  # fmt: skip
    if frame == _MODEL:
        return T_model
    if frame not in poses:
        raise reader.error(el, f"joint {shown(joint)}: expressed_in {shown(frame)} names no frame")
    return poses[frame]


def _tree_joints(
    j: _Joint, poses: dict[str, np.ndarray], T_model: np.ndarray, reader: _Reader
) -> list[TreeJoint]:
    """The neutral tree's joints of an SDF joint (two for a universal joint, none for a
    fixed one), in F0 at the zero configuration."""
    if j.kind == "fixed":
        return []
    anchor = poses[j.name][:3, 3].copy()
    if j.kind == "ball":
        return [TreeJoint(j.name, BALL, anchor)]
    out = []
    tags = ("axis", "axis2") if j.kind == "universal" else ("axis",)
    for n, tag in enumerate(tags):
        found = _children(j.el, tag)
        R = poses[j.name][:3, :3]
        xyz = np.array([0.0, 0.0, 1.0])  # SDFormat's default, <axis2> too
        limit: Any = None
        dynamics: Any = None
        if found:
            axis = found[0]
            R = _axis_frame(j, axis, poses, T_model, reader)
            el = _children(axis, "xyz")
            if el:
                what = f"<{tag}><xyz> of joint {shown(j.name)}"
                xyz = np.array(reader.numbers(el[0], (3,), what))
            limit = next(iter(_children(axis, "limit")), None)
            dynamics = next(iter(_children(axis, "dynamics")), None)
        if not np.linalg.norm(xyz) > 0:
            raise reader.error(
                found[0] if found else j.el, f"joint {shown(j.name)} has a zero axis",
                ModelImportError,
            )  # fmt: skip
        name = j.name if n == 0 else f"{j.name}::axis2"
        kind = PRISMATIC if j.kind == "prismatic" else REVOLUTE
        J = TreeJoint(name, kind, anchor, R @ xyz / np.linalg.norm(xyz))
        what = f"joint {shown(j.name)}"
        if limit is not None and j.kind != "continuous":
            lo = reader.number(limit, "lower", f"the <limit> of {what}", -SDF_UNBOUNDED)
            hi = reader.number(limit, "upper", f"the <limit> of {what}", SDF_UNBOUNDED)
            J.lower = -math.inf if lo <= -SDF_UNBOUNDED else lo
            J.upper = math.inf if hi >= SDF_UNBOUNDED else hi
            if not J.lower <= J.upper:
                raise reader.error(
                    limit, f"the limits of {what} are reversed: {lo!r} > {hi!r}", ModelImportError
                )
        if dynamics is not None:
            owner = f"the <dynamics> of {what}"
            J.damping = reader.number(dynamics, "damping", owner, 0.0)
            J.coulomb = reader.number(dynamics, "friction", owner, 0.0)
            J.stiffness = reader.number(dynamics, "spring_stiffness", owner, 0.0)
            J.rest = reader.number(dynamics, "spring_reference", owner, 0.0)
        out.append(J)
    return out


def _ball_terms(j: _Joint, reader: _Reader, notes: list[str]) -> None:
    """A report line for ``<dynamics>`` under a ball joint (Gazebo applies none)."""
    for axis in _children(j.el, "axis"):
        for dyn in _children(axis, "dynamics"):
            values = [
                reader.number(dyn, tag, f"the <dynamics> of joint {shown(j.name)}", 0.0)
                for tag in ("damping", "friction", "spring_stiffness")
            ]
            if any(v != 0.0 for v in values):
                notes.append(
                    f"the <dynamics> of ball joint {shown(j.name)} ignored (Gazebo applies "
                    "none to a ball joint)"
                )


def default_actuated(read: SdfRead, legs: Sequence[Sequence[str]]) -> list[str]:
    """The actuated joints, one per leg in the file's order, when the file says which:
    each leg (its joints' names, from the base) whose only 1-dof joint (a revolute,
    continuous or prismatic joint of the file; a universal joint is two passive hinges) is
    one hinge or slide has it actuated; otherwise :class:`ModelImportError` asking for
    ``actuated=``."""
    chosen: list[str] = []
    unclear: list[str] = []
    for names in legs:
        own = [n for n in names if n in read.one_dof]
        if len(own) == 1:
            chosen.append(own[0])
        else:
            unclear.append(f"({shown_list(names)}: {len(own)} 1-dof joints)")
    if unclear:
        raise ModelImportError(
            f"SDF has no actuators, and {len(unclear)} leg(s) do not have exactly one "
            f"revolute or prismatic joint to actuate {' '.join(unclear)}: name the actuated "
            "joints, one per leg in leg order, with actuated=[...] (--actuated)",
            (),
            tuple(n for names in legs for n in names),
        )
    return sorted(chosen, key=lambda n: read.one_dof[n])


__all__ = [
    "SDF_GRAVITY",
    "SDF_UNBOUNDED",
    "SDF_VERSIONS",
    "SdfRead",
    "default_actuated",
    "read_sdf",
]
