"""MJCF in: a MuJoCo model read through MuJoCo itself, as the neutral tree of
:mod:`stewart_pin.importers.tree`.

MuJoCo's compiler resolves what the file says: defaults and classes, ``fullinertia``,
``quat`` / ``euler`` / ``axisangle`` / ``xyaxes`` / ``zaxis`` orientations and the
compiler's ``angle`` unit, ``inertiafromgeom`` (inertias computed from geoms and meshes),
``ref`` and ``springref``; the reader takes the compiled model (``mujoco.MjModel``):

- bodies, their joints (``hinge``, ``slide``, ``ball``, ``free``; several joints in one
  body become a chain of massless bodies, MuJoCo's sequential joint motion), poses and
  axes from ``mj_kinematics`` at the zero configuration (hinges and slides at 0, balls at
  the identity, free bodies where ``qpos0`` puts them), inertias from ``body_mass``,
  ``body_ipos``, ``body_iquat``, ``body_inertia``;
- the joint terms ``dof_armature``, ``dof_damping``, ``dof_frictionloss``,
  ``jnt_stiffness`` and ``qpos_spring`` (``springref``), ranges when ``jnt_limited``;
- equality constraints ``connect`` (site or body/anchor form) and ``weld`` (active at
  ``qpos0``); any other kind is refused;
- actuators on joints (``motor``, ``position``, ``velocity``, ``general``...): the joint
  and ``gear[0]`` (the joint's effort per actuator effort); one on a site or a body (a
  disturbance input) is ignored with a note, one on a tendon is refused;
- each body's ``gravcomp`` (the same on every moving body: gravity scaled; else each
  link's own, the description's ``platform_gravcomp`` / ``leg_gravcomp``;
  ``actuatorgravcomp`` refused);
- ``<option gravity>``; the reference configuration: a keyframe (by name or index;
  default the one named ``home``, else ``qpos0``).

Geoms matter only through the inertias MuJoCo computes from them: the reader compiles
with ``discardvisual`` (geoms with ``contype = conaffinity = 0`` and their meshes dropped
before they are loaded, their inertia kept as an explicit one) and drops the mesh geoms
of bodies whose inertia is explicit, so a visual mesh file missing beside the model does
not stop the import (a note names it); a body whose inertia MuJoCo would compute from a
missing mesh takes it from ``inertials=`` (:func:`load_model`). Contacts, tendons without
springs, sensors and the like play no part in the rigid-body dynamics imported.
"""

from __future__ import annotations

import contextlib
import xml.parsers.expat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._extras import require
from stewart_pin.exceptions import FileFormatError, ModelImportError
from stewart_pin.importers.tree import (
    BALL,
    FREE,
    KinematicModel,
    TreeActuator,
    TreeBody,
    TreeClosure,
    TreeJoint,
    shown,
)


def _mujoco() -> Any:
    """The ``mujoco`` module, or :class:`MissingDependencyError` with the install hint."""
    (mujoco,) = require("reading MJCF", "import", "mujoco")
    return mujoco


def _khalil(mass: float, com: np.ndarray, R: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """Khalil parameters (10,) about the body origin from MuJoCo's mass, centre of mass,
    principal axes and principal moments (body frame)."""
    I_c = R @ np.diag(moments) @ R.T
    I_O = I_c + mass * (com @ com * np.eye(3) - np.outer(com, com))
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *(mass * com), mass]
    )


def _quat_matrix(q: Any) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(pos: Any, R: Any) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, pos
    return T


def load_model(source: Any, inertials: dict[str, Any] | None = None) -> tuple[Any, str, list[str]]:
    """``(mujoco.MjModel, file name, notes)`` of a path, an XML string or a compiled model.

    Mesh files missing beside the model: a visual mesh is dropped (a note names it); a
    body whose inertia MuJoCo computes from a missing mesh needs its inertia given in
    ``inertials`` (body name -> ``{"mass": m [kg], "pos": centre of mass (3,) in the
    body frame [m], "inertia": [ixx, iyy, izz, ixy, ixz, iyz] about it in body axes
    [kg m^2]}``): its geoms are then not used for its inertia (a note says so); else
    :class:`ModelImportError` naming the files, the bodies and the option.

    A path (``str`` or ``os.PathLike`` naming an existing file, or a ``str`` not starting
    with ``<``) is read with its includes and assets relative to its folder; a string
    starting with ``<`` is the XML itself (assets relative to the working folder).
    :class:`FileFormatError` with MuJoCo's message when MuJoCo refuses the model;
    :class:`ModelImportError` for a NaN or infinite number written in the file (naming the
    element, the attribute and the value) and for any warning MuJoCo gives while reading
    it (MuJoCo's warnings are captured: nothing is printed or written to
    ``MUJOCO_LOG.TXT``).
    """
    mujoco = _mujoco()
    if isinstance(source, mujoco.MjModel):
        return source, "", []
    text: str | None = None
    path: Path | None = None
    if isinstance(source, str) and source.lstrip().startswith("<"):
        text = source
    elif isinstance(source, (str, Path)) or hasattr(source, "__fspath__"):
        path = Path(source)
        if not path.is_file():
            raise FileFormatError(f"no MJCF file {path}")
    else:
        raise FileFormatError(
            f"from_mjcf takes a path, an XML string or a mujoco.MjModel, got "
            f"{type(source).__name__}"
        )
    where = str(path) if path is not None else "the MJCF text"
    _check_finite_text(text, path)
    with mujoco_warnings() as said:
        try:
            spec = (
                mujoco.MjSpec.from_string(text)
                if text is not None
                else mujoco.MjSpec.from_file(str(path))
            )
        except Exception as e:  # MuJoCo raises ValueError with its own message
            raise FileFormatError(f"MuJoCo cannot read {where}: {e}") from e
        absent = _absent_meshes(spec, path)
        _drop_visuals(mujoco, spec)
        notes = _missing_meshes(mujoco, spec, absent, inertials or {}, where)
        try:
            model = spec.compile()
        except Exception as e:
            raise FileFormatError(f"MuJoCo cannot compile {where}: {e}") from e
    if said:
        raise ModelImportError(
            f"MuJoCo warns about {where}: {said[0]} (stewart-pin does not import a model "
            "MuJoCo warns about: fix the file)"
        )
    return model, "" if path is None else path.name, notes


def _absent_meshes(spec: Any, path: Path | None) -> dict[str, str]:
    """Mesh asset name -> its file, for the mesh files that are not where MuJoCo looks
    (``meshdir``, relative to the model's folder; the working folder for XML text)."""
    folder = path.parent if path is not None else Path()
    meshdir = Path(spec.meshdir or "")
    out = {}
    for mesh in spec.meshes:
        if not mesh.file:
            continue
        file = Path(mesh.file)
        where = file if file.is_absolute() else folder / meshdir / file
        if not where.is_file():
            out[mesh.name] = mesh.file
    return out


#: Keys of an ``inertials=`` entry.
INERTIAL_KEYS = ("mass", "pos", "inertia")


def _missing_meshes(
    mujoco: Any, spec: Any, absent: dict[str, str], inertials: dict[str, Any], where: str
) -> list[str]:
    """Deal with the mesh files missing (:func:`load_model`): the notes, or
    :class:`ModelImportError`."""
    from stewart_pin._checks import check_array, check_scalar
    from stewart_pin.exceptions import InputError

    if not isinstance(inertials, dict) or not all(isinstance(k, str) for k in inertials):
        raise InputError(f"inertials must be a dict of body name to inertia, got {inertials!r}")
    mesh = mujoco.mjtGeom.mjGEOM_MESH
    affected: dict[str, list[str]] = {}
    for body in spec.bodies:
        for geom in body.geoms:
            if geom.type == mesh and geom.meshname in absent:
                affected.setdefault(body.name, []).append(absent[geom.meshname])
    notes = []
    used = {f for files in affected.values() for f in files}
    visual = sorted(set(absent.values()) - used)
    if visual:
        notes.append(
            f"mesh file(s) {', '.join(shown(f) for f in visual)} missing: visual only, not needed"
        )
    unknown = [b for b in inertials if b not in affected]
    if unknown:
        raise InputError(
            f"inertials given for {', '.join(shown(b) for b in unknown)}: not a body whose "
            f"inertia comes from a missing mesh file (those: "
            f"{', '.join(shown(b) for b in affected) or 'none'})"
        )
    lacking = [b for b in affected if b not in inertials]
    if lacking:
        files = sorted({f for b in lacking for f in affected[b]})
        raise ModelImportError(
            f"mesh file(s) {', '.join(shown(f) for f in files)} missing beside {where}: MuJoCo "
            f"computes the inertia of {', '.join(shown(b) for b in lacking)} from them; put "
            "the files back, or give each body's inertia with inertials={body: {'mass': m, "
            "'pos': [x, y, z], 'inertia': [ixx, iyy, izz, ixy, ixz, iyz]}} (centre of mass "
            "and inertia about it, in the body frame; SI)",
            tuple(lacking),
        )
    explicit_elsewhere = any(
        body.explicitinertial and body.name not in affected for body in spec.bodies
    )
    for bname in affected:
        entry = inertials[bname]
        what = f"inertials[{bname!r}]"
        if not isinstance(entry, dict) or sorted(entry) != sorted(INERTIAL_KEYS):
            raise InputError(f"{what} must be a dict with exactly the keys {INERTIAL_KEYS}")
        body = spec.body(bname)
        for geom in list(body.geoms):
            spec.delete(geom)  # the body's inertia is the one given
        body.mass = check_scalar(entry["mass"], f"{what}['mass']", positive=True)
        body.ipos = check_array(entry["pos"], (3,), f"{what}['pos']")
        body.fullinertia = check_array(entry["inertia"], (6,), f"{what}['inertia']")
        body.explicitinertial = True
    if (
        affected
        and spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    ):
        if explicit_elsewhere:
            raise ModelImportError(
                'inertials= cannot be used with <compiler inertiafromgeom="true"> when other '
                "bodies have an <inertial> (MuJoCo would then read theirs too)"
            )
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO
    for asset in list(spec.meshes):
        if asset.name in absent:
            spec.delete(asset)
    notes.extend(
        f"mesh file(s) {', '.join(shown(f) for f in sorted(set(files)))} missing: the inertia "
        f"of body {shown(b)} given by inertials= ({inertials[b]['mass']!r} kg)"
        for b, files in affected.items()
    )
    return notes


def _gravity_routed(m: Any, name: Any) -> None:
    """:class:`ModelImportError` for gravity compensation routed to actuators
    (``actuatorgravcomp``): the actuators' forces would then include it."""
    routed = [name("mjOBJ_JOINT", j) for j in range(m.njnt) if m.jnt_actgravcomp[j]]
    if routed and np.any(m.body_gravcomp != 0.0):
        raise ModelImportError(
            f"gravity compensation (gravcomp) is routed to the actuators of "
            f"{', '.join(shown(j) for j in routed)} (actuatorgravcomp): the actuator forces "
            "would include it; stewart-pin's efforts do not: remove actuatorgravcomp",
            (),
            tuple(routed),
        )


@contextlib.contextmanager
def mujoco_warnings() -> Iterator[list[str]]:
    """MuJoCo's warnings (``mju_warning``) collected into the list yielded, instead of
    printed and appended to ``MUJOCO_LOG.TXT`` in the working folder; the previous handler
    is put back afterwards (the handler is process-wide)."""
    mujoco = _mujoco()
    said: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: said.append(str(message).strip()))
    try:
        yield said
    finally:
        mujoco.set_mju_user_warning(previous)


#: MJCF attributes that hold names, files or keywords, never numbers: the scan for
#: non-finite numbers skips them (a body may be named "nan").
_TEXT_ATTRIBUTES = frozenset(
    """name class childclass file prefix model joint joint1 joint2 body body1 body2 site
    site1 site2 tendon tendon1 tendon2 target mesh material texture hfield geom geom1 geom2
    objname refname objtype reftype actuator cranksite slidersite jointinparent refsite
    camera light flex skin meshdir texturedir assetdir content_type plugin instance key
    type mode""".split()
)
#: MJCF elements whose attributes are text (``<custom><text data>``, plugin settings).
_TEXT_ELEMENTS = frozenset({"text", "config"})
_NON_FINITE = frozenset({"nan", "inf", "infinity"})
#: Files an MJCF's ``<include>`` chain may name before the scan stops following them.
_MAX_INCLUDES = 64


def _check_finite_text(text: str | None, path: Path | None) -> None:
    """:class:`ModelImportError` for the first NaN or infinity written in an attribute of
    the MJCF ``text`` (or the file ``path``, and the files it includes): MuJoCo reads
    ``nan`` with a warning naming nothing, and ``inf`` silently."""
    queue: list[tuple[str | None, Path | None]] = [(text, path)]
    seen: set[Path] = set()
    root: Path | None = None
    while queue and len(seen) <= _MAX_INCLUDES:
        text, path = queue.pop(0)
        if text is None and path is not None:
            try:
                text = path.read_text(encoding="utf-8", errors="replace")
            except OSError:
                continue  # MuJoCo says what is wrong with it
        if text is None:
            continue
        found, includes = _scan_attributes(text)
        if found is not None:
            element, tag, name, key, value, line = found
            where = "the MJCF text" if path is None else str(path)
            raise ModelImportError(
                f"{where}, line {line}: {element} has {key}={shown(value)}: every number "
                "of a model file must be finite (no NaN or infinity)",
                (name,) if tag == "body" and name else (),
                (name,) if tag != "body" and name else (),
            )
        if path is not None:
            seen.add(path.resolve())
            root = root or path.parent  # MuJoCo reads includes from the main file's folder
            for file in includes:
                child = root / file
                if child.is_file() and child.resolve() not in seen:
                    queue.append((None, child))


_Found = tuple[str, str, str, str, str, int]


def _scan_attributes(text: str) -> tuple[_Found | None, list[str]]:
    """The first attribute of an MJCF ``text`` holding ``nan`` or ``inf`` (``(the element
    as shown: its tag and name, or the nearest named element it is in; its tag; its name;
    the attribute; the value; the line)``, or None) and the files its ``<include>`` name."""
    found: list[_Found] = []
    includes: list[str] = []
    names: list[str] = []  # the element names along the current path ("" when unnamed)
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        names.append(attrs.get("name", ""))
        if tag == "include" and "file" in attrs:
            includes.append(attrs["file"])
        if tag in _TEXT_ELEMENTS:
            return
        for key, value in attrs.items():
            if found or key in _TEXT_ATTRIBUTES:
                continue
            if any(t.lower().lstrip("+-") in _NON_FINITE for t in value.split()):
                own = names[-1]
                owner = next((n for n in reversed(names[:-1]) if n), "")
                label = f"<{tag}> {shown(own)}" if own else f"<{tag}>"
                if not own and owner:
                    label += f" in {shown(owner)}"
                found.append((label, tag, own, key, value, parser.CurrentLineNumber))

    def end(tag: str) -> None:
        names.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    with contextlib.suppress(xml.parsers.expat.ExpatError):  # MuJoCo says what is wrong
        parser.Parse(text, True)
    return (found[0] if found else None), includes


def _drop_visuals(mujoco: Any, spec: Any) -> None:
    """``discardvisual``, and the mesh geoms that add nothing to the dynamics (unless
    something refers to them): in bodies whose inertia is explicit, with a zero mass or
    density, or outside the compiler's ``inertiagrouprange``; so that their mesh files are
    never opened."""
    spec.compiler.discardvisual = True
    mode = spec.compiler.inertiafromgeom
    if mode == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE:
        explicit_counts = False
    else:
        explicit_counts = True
    never = mode == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    low, high = (int(x) for x in spec.compiler.inertiagrouprange)
    referred: set[str] = set()
    for pair in spec.pairs:
        referred.update({pair.geomname1, pair.geomname2})
    for sensor in spec.sensors:
        referred.update({sensor.objname, sensor.refname})
    mesh = mujoco.mjtGeom.mjGEOM_MESH
    for body in spec.bodies:
        for geom in list(body.geoms):
            if geom.type != mesh or (geom.name and geom.name in referred):
                continue
            no_mass = geom.mass == 0 or (geom.mass < 0 and geom.density == 0)
            if (
                never
                or (explicit_counts and body.explicitinertial)
                or no_mass
                or not low <= int(geom.group) <= high
            ):
                spec.delete(geom)
    used = {geom.meshname for geom in spec.geoms if geom.type == mesh}
    for asset in list(spec.meshes):
        if asset.name not in used:
            spec.delete(asset)


def read_mjcf(
    source: Any,
    keyframe: str | int | None = None,
    inertials: dict[str, Any] | None = None,
) -> KinematicModel:
    """The neutral tree of an MJCF model (module docstring).

    Args:
        source: a path, an XML string or a ``mujoco.MjModel``.
        keyframe: the reference configuration: a keyframe's name or index; default the
            keyframe named ``home`` if there is one, else ``qpos0``.
        inertials: body name -> its inertia (:func:`load_model`), for bodies whose
            inertia MuJoCo would compute from a mesh file that is missing.
    """
    mujoco = _mujoco()
    m, file_name, load_notes = load_model(source, inertials)
    _check_finite_model(mujoco, m)
    off = _disabled(mujoco, m)
    data = mujoco.MjData(m)

    def name(obj: str, i: int) -> str:
        return mujoco.mj_id2name(m, getattr(mujoco.mjtObj, obj), i) or f"{obj[6:].lower()}{i}"

    # the zero configuration
    q_zero = np.array(m.qpos0, dtype=float)
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    ball = int(mujoco.mjtJoint.mjJNT_BALL)
    for j in range(m.njnt):
        if int(m.jnt_type[j]) in (hinge, slide):
            q_zero[m.jnt_qposadr[j]] = 0.0
    data.qpos[:] = q_zero
    mujoco.mj_kinematics(m, data)
    xpos, xmat = data.xpos.copy(), data.xmat.copy().reshape(-1, 3, 3)
    xanchor, xaxis = data.xanchor.copy(), data.xaxis.copy()

    # the reference configuration
    if keyframe is None:
        key: int | None = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
        key = None if key is None or key < 0 else key
    elif isinstance(keyframe, int) and not isinstance(keyframe, bool):
        if not 0 <= keyframe < m.nkey:
            raise ModelImportError(f"keyframe {keyframe}: the model has {m.nkey} keyframe(s)")
        key = keyframe
    else:
        key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, str(keyframe))
        if key < 0:
            raise ModelImportError(f"no keyframe named {shown(str(keyframe))} in the model")
    if key is None:
        q_ref, reference = np.array(m.qpos0, dtype=float), "qpos0"
    else:
        q_ref = np.array(m.key_qpos[key], dtype=float)
        reference = f"keyframe {shown(name('mjOBJ_KEY', key))}"

    bodies = [TreeBody("world", -1, None, np.eye(4))]
    index = {0: 0}
    values: dict[str, float] = {}
    balls: dict[str, np.ndarray] = {}
    frees: dict[str, np.ndarray] = {}
    notes: list[str] = list(load_notes)
    seen: set[str] = set()
    notes.extend(
        f'<option><flag {flag}="disable"/>: imported {what}'
        for flag, what in _FLAGS_HONOURED.items()
        if flag in off
    )
    if "gravity" not in off:  # without gravity, gravcomp does nothing
        _gravity_routed(m, name)
    for b in range(1, m.nbody):
        bname = name("mjOBJ_BODY", b)
        pose = _pose(xpos[b], xmat[b])
        R_i = _quat_matrix(m.body_iquat[b])
        inertia = _khalil(
            float(m.body_mass[b]), np.array(m.body_ipos[b]), R_i, np.array(m.body_inertia[b])
        )
        parent = index[int(m.body_parentid[b])]
        jids = range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])
        gravcomp = 0.0 if "gravity" in off else float(m.body_gravcomp[b])
        if m.body_jntnum[b] == 0:
            bodies.append(TreeBody(bname, parent, None, pose, inertia, gravcomp=gravcomp))
            index[b] = len(bodies) - 1
            continue
        for n, j in enumerate(jids):
            jname = name("mjOBJ_JOINT", j)
            if jname in seen:
                raise ModelImportError(f"two joints named {shown(jname)}", (), (jname,))
            seen.add(jname)
            kind = int(m.jnt_type[j])
            dof = m.jnt_dofadr[j]
            qadr = m.jnt_qposadr[j]
            if kind in (hinge, slide):
                J = TreeJoint(
                    jname,
                    "revolute" if kind == hinge else "prismatic",
                    np.array(xanchor[j]),
                    np.array(xaxis[j]) / np.linalg.norm(xaxis[j]),
                    armature=float(m.dof_armature[dof]),
                    damping=0.0 if "damper" in off else float(m.dof_damping[dof]),
                    coulomb=0.0 if "frictionloss" in off else float(m.dof_frictionloss[dof]),
                    stiffness=0.0 if "spring" in off else float(m.jnt_stiffness[j]),
                    rest=float(m.qpos_spring[qadr]),
                )
                if m.jnt_limited[j] and "limit" not in off:
                    J.lower, J.upper = float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])
                values[jname] = float(q_ref[qadr])
            elif kind == ball:
                terms = (
                    float(np.abs(m.dof_armature[dof : dof + 3]).max())
                    + ("damper" not in off) * float(np.abs(m.dof_damping[dof : dof + 3]).max())
                    + ("frictionloss" not in off)
                    * float(np.abs(m.dof_frictionloss[dof : dof + 3]).max())
                    + ("spring" not in off) * float(m.jnt_stiffness[j])
                )
                limited = bool(m.jnt_limited[j]) and "limit" not in off
                J = TreeJoint(jname, BALL, np.array(xanchor[j]), limited=limited)
                J.damping = terms  # only its being non-zero matters (refused)
                balls[jname] = _quat_matrix(q_ref[qadr : qadr + 4])
            else:
                J = TreeJoint(jname, FREE)
                T = _pose(q_ref[qadr : qadr + 3], _quat_matrix(q_ref[qadr + 3 : qadr + 7]))
                frees[jname] = T
            last = n == m.body_jntnum[b] - 1
            bodies.append(
                TreeBody(
                    bname,
                    parent,
                    J,
                    pose,
                    inertia if last else np.zeros(10),
                    virtual=not last,
                    gravcomp=gravcomp if last else 0.0,
                )
            )
            parent = len(bodies) - 1
        index[b] = len(bodies) - 1

    closures: list[TreeClosure] = []
    connect, weld = int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)
    site_obj = int(mujoco.mjtObj.mjOBJ_SITE)
    for e in range(m.neq):
        ename = name("mjOBJ_EQUALITY", e)
        if not m.eq_active0[e]:
            notes.append(f"the inactive equality constraint {shown(ename)} is ignored")
            continue
        kind = int(m.eq_type[e])
        if kind not in (connect, weld):
            raise ModelImportError(
                f"equality constraint {shown(ename)} is a "
                f"{mujoco.mjtEq(kind).name.removeprefix('mjEQ_').lower()}: stewart-pin reads "
                "connect (a spherical joint) and weld (a rigid attachment) only",
                (),
                (ename,),
            )
        data_e = np.array(m.eq_data[e], dtype=float)
        if int(m.eq_objtype[e]) == site_obj:
            s1, s2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
            b1, b2 = int(m.site_bodyid[s1]), int(m.site_bodyid[s2])
            p1, p2 = np.array(m.site_pos[s1]), np.array(m.site_pos[s2])
            R1, R2 = _quat_matrix(m.site_quat[s1]), _quat_matrix(m.site_quat[s2])
        else:
            b1, b2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
            p1, p2 = data_e[0:3], data_e[3:6]
            R1 = R2 = np.eye(3)
        if kind == connect:
            closures.append(TreeClosure(ename, "point", index[b1], index[b2], p1, p2))
        else:
            if int(m.eq_objtype[e]) == site_obj:
                T_1_2 = _pose(p1, R1) @ np.linalg.inv(_pose(p2, R2))
                F2 = _pose(p2, R2)
            else:
                R = _quat_matrix(data_e[6:10])
                T_1_2 = _pose(data_e[3:6] - R @ data_e[0:3], R)
                F2 = _pose(data_e[0:3], np.eye(3))
            closures.append(
                TreeClosure(ename, "weld", index[b1], index[b2], T_1_2=T_1_2, frame2=F2)
            )

    actuators: list[TreeActuator] = []
    joint_trn = int(mujoco.mjtTrn.mjTRN_JOINT)
    for a in range(m.nu):
        aname = name("mjOBJ_ACTUATOR", a)
        trn = int(m.actuator_trntype[a])
        if trn in (int(mujoco.mjtTrn.mjTRN_SITE), int(mujoco.mjtTrn.mjTRN_BODY)):
            target = name("mjOBJ_SITE" if trn == int(mujoco.mjtTrn.mjTRN_SITE) else "mjOBJ_BODY",
                          int(m.actuator_trnid[a, 0]))  # fmt: skip
            notes.append(
                f"actuator {shown(aname)} drives the {mujoco.mjtTrn(trn).name[6:].lower()} "
                f"{shown(target)}, not a joint (a disturbance input): ignored (the efforts "
                "computed are those with it at zero)"
            )
            continue
        if trn != joint_trn:
            raise ModelImportError(
                f"actuator {shown(aname)} does not act on a joint (transmission "
                f"{mujoco.mjtTrn(int(m.actuator_trntype[a])).name}): stewart-pin reads "
                "actuators on the legs' joints",
                (),
                (aname,),
            )
        jname = name("mjOBJ_JOINT", int(m.actuator_trnid[a, 0]))
        actuators.append(TreeActuator(aname, jname, float(m.actuator_gear[a, 0])))

    for t in range(m.ntendon):
        spring = m.tendon_stiffness[t] != 0.0 and "spring" not in off
        if spring or (m.tendon_damping[t] != 0.0 and "damper" not in off):
            tname = name("mjOBJ_TENDON", t)
            raise ModelImportError(
                f"tendon {shown(tname)} has a spring or a damper: stewart-pin's dynamics "
                "have no tendons; remove it",
                (),
                (tname,),
            )
    if m.opt.density != 0.0 or m.opt.viscosity != 0.0:
        notes.append("the fluid forces (option density, viscosity) are ignored")
    model = KinematicModel(
        name=_model_name(m),
        format="mjcf",
        file=file_name,
        bodies=bodies,
        closures=closures,
        actuators=actuators,
        gravity=(np.zeros(3) if "gravity" in off else np.array(m.opt.gravity, dtype=float)),
        reference=reference,
        values=values,
        balls=balls,
        free=frees,
        notes=notes,
        base_name="world",
    )
    # the neutral tree's kinematics at the reference configuration against MuJoCo's
    data.qpos[:] = q_ref
    mujoco.mj_kinematics(m, data)
    poses = model.poses()
    for b in range(1, m.nbody):
        T = poses[index[b]]
        err = float(np.abs(T[:3, 3] - data.xpos[b]).max()) + float(
            np.abs(T[:3, :3] - data.xmat[b].reshape(3, 3)).max()
        )
        if not err <= 1e-9 * (1.0 + float(np.abs(data.xpos[b]).max())):
            raise ModelImportError(
                f"MJCF reader: body {shown(name('mjOBJ_BODY', b))} is placed {err:.3g} away "
                "from MuJoCo's own kinematics at the reference configuration (an internal "
                "inconsistency of stewart-pin's reader: please report it with the file)",
                (name("mjOBJ_BODY", b),),
            )
    return model


#: MuJoCo's ``<option><flag ... ="disable"/>`` switches that the import honours, and how.
_FLAGS_HONOURED = {
    "gravity": "with zero gravity",
    "damper": "without the joints' damping",
    "spring": "without the joints' springs",
    "frictionloss": "without the joints' Coulomb friction (frictionloss)",
    "limit": "without joint limits",
}
#: The switches the import refuses (the file's robot then is not the one imported).
_FLAGS_REFUSED = {
    "constraint": "MuJoCo then ignores every constraint, the loop closures among them "
    "(the file's robot is open chains)",
    "equality": "MuJoCo then ignores the equality constraints that close the loops (the "
    "file's robot is open chains)",
    "actuation": "MuJoCo then applies no actuator force (the file's legs are not driven)",
}


def _disabled(mujoco: Any, m: Any) -> set[str]:
    """The names of the ``<option><flag>`` switches that change the dynamics and are
    disabled in ``m`` (:data:`_FLAGS_HONOURED`); :class:`ModelImportError` for one the
    import cannot honour (:data:`_FLAGS_REFUSED`)."""
    bits = int(m.opt.disableflags)

    def off(flag: str) -> bool:
        return bool(bits & int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag.upper()}")))

    for flag, why in _FLAGS_REFUSED.items():
        if off(flag):
            raise ModelImportError(
                f'the model disables {flag} (<option><flag {flag}="disable"/>): {why}; '
                "stewart-pin cannot import that model: remove the flag"
            )
    return {flag for flag in _FLAGS_HONOURED if off(flag)}


#: The compiled model's numbers the reader uses, by the kind of element they belong to.
_FINITE_FIELDS = {
    "body": ("body_pos", "body_quat", "body_mass", "body_ipos", "body_iquat", "body_inertia"),
    "joint": ("jnt_pos", "jnt_axis", "jnt_range", "jnt_stiffness"),
    "dof": ("dof_armature", "dof_damping", "dof_frictionloss"),
    "site": ("site_pos", "site_quat"),
    "equality": ("eq_data",),
    "actuator": ("actuator_gear",),
    "key": ("key_qpos",),
    "qpos": ("qpos0", "qpos_spring"),
}


def _check_finite_model(mujoco: Any, m: Any) -> None:
    """:class:`ModelImportError` naming the element and the value of the first non-finite
    number among those the reader uses (a compiled model given as such, or a number the
    compiler made non-finite)."""
    objects = {"body": "mjOBJ_BODY", "joint": "mjOBJ_JOINT", "site": "mjOBJ_SITE"}
    objects.update(equality="mjOBJ_EQUALITY", actuator="mjOBJ_ACTUATOR", key="mjOBJ_KEY")
    g = np.array(m.opt.gravity, dtype=float)
    if not np.all(np.isfinite(g)):
        raise ModelImportError(f"<option> gravity is {g.tolist()}: it must be finite")
    for kind, fields in _FINITE_FIELDS.items():
        for field in fields:
            values = np.asarray(getattr(m, field), dtype=float)
            if values.size == 0:
                continue
            bad = np.flatnonzero(~np.all(np.isfinite(values.reshape(len(values), -1)), axis=1))
            if bad.size == 0:
                continue
            i = int(bad[0])
            if kind == "dof":
                kind, i = "joint", int(m.dof_jntid[i])
            elif kind == "qpos":
                kind, i = "joint", int(np.flatnonzero(np.asarray(m.jnt_qposadr) <= i)[-1])
            name = mujoco.mj_id2name(m, getattr(mujoco.mjtObj, objects[kind]), i) or f"#{i}"
            raise ModelImportError(
                f"{kind} {shown(name)}: {field} is {values[int(bad[0])].tolist()}: every "
                "number of a model must be finite (no NaN or infinity)",
                (name,) if kind == "body" else (),
                (name,) if kind != "body" else (),
            )


def _model_name(m: Any) -> str:
    """The model's ``model`` attribute (the first name of MuJoCo's name buffer)."""
    raw = m.names if isinstance(m.names, bytes) else bytes(m.names)
    end = raw.find(b"\0")
    return raw[: end if end >= 0 else len(raw)].decode("utf-8", "replace")


__all__ = ["load_model", "read_mjcf"]
