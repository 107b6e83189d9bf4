"""Payloads: a robot (or any articulated machine) bolted to the platform.

A :class:`Payload` is a Pinocchio model with a **fixed base** (no free-flyer: its base
link is rigidly attached) and its mounting placement ``T_p_b``, the pose of the payload's
base frame ``Fb`` (its ``universe`` frame) in the platform frame ``Fp`` (4x4). Its joint
configuration ``q`` is Pinocchio's (``model.nq`` values; a continuous joint has two,
``cos`` and ``sin``), its rates and accelerations ``model.nv`` values.

Sources (:func:`load_payload`):

- a ``pin.Model`` with a fixed base (:meth:`Payload.from_model`);
- a URDF file (:meth:`Payload.from_urdf`), loaded with a fixed base: the root link is the
  part bolted to the platform, the links welded to it are part of that rigid base;
- a robot of **example-robot-data** by its name (``ur5``, ``panda``, ``so101``...:
  :meth:`Payload.from_example_robot_data`, :func:`example_robot_names`). Its files are
  located through the installed distribution's own file list
  (``importlib.metadata``): the URDFs under ``share/example-robot-data/robots/`` (the
  wheel's ``cmeel.prefix/...``), and, when the ``example_robot_data`` Python module is
  importable (conda, robotpkg), its loader's table of names. No path is hard-coded. The
  package is optional: ``pip install "stewart-pin[payload]"``.

:func:`floating_payload_model` is the payload on a free-flyer (the platform's motion as
its base motion: :mod:`stewart_pin.dynamics.payload` runs Pinocchio's RNEA and CRBA on
it); :func:`attach_payload` appends it to another model's frame (the independent check
appends it to the platform of the closed-loop tree, :mod:`stewart_pin.check.payload`).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.metadata
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, check_batch, check_pose, check_scalar
from stewart_pin.exceptions import (
    InputError,
    MissingDependencyError,
    PayloadError,
    PayloadMeshError,
    UnknownPayloadError,
)
from stewart_pin.formats._urdf_checks import check_urdf_numbers, urdf_cycle
from stewart_pin.formats.urdf import non_finite_number

__all__ = [
    "DISTRIBUTION",
    "INSTALL_HINT",
    "MOUNT_FRAME",
    "AttachedModel",
    "Payload",
    "attach_payload",
    "example_robot_names",
    "example_robot_urdf",
    "floating_payload_model",
    "load_payload",
]

#: The distribution holding the robot files, and the hint given when it is missing.
DISTRIBUTION = "example-robot-data"
INSTALL_HINT = 'pip install "stewart-pin[payload]"'
#: Where example-robot-data's robot folders live inside its installation prefix.
_ROBOTS_SUBPATH = ("share", "example-robot-data", "robots")
#: Name of the frame the payload is appended to (on the free-flyer or the platform).
MOUNT_FRAME = "payload_mount"
#: Prefix of the payload's joint and frame names in a combined model.
PREFIX = "payload/"
#: Name of the free-flyer joint carrying the payload in :func:`floating_payload_model`.
BASE_JOINT = "payload_base_joint"
#: Joint kinds that make a floating base (a payload is bolted to the platform).
_FLOATING = ("JointModelFreeFlyer", "JointModelPlanar")
#: Half-range [rad or m] used for a joint without finite limits when drawing random
#: configurations.
UNBOUNDED_RANGE = np.pi


# ---------------------------------------------------------------------------- the library
@dataclass(frozen=True)
class _Library:
    """example-robot-data as installed: each robot name's URDF, every URDF by its path
    under ``robots/`` (lower case), and the folders holding ``example-robot-data/`` (the
    root of its ``package://`` URIs)."""

    urdfs: dict[str, Path]
    files: dict[str, Path]
    package_dirs: tuple[Path, ...]


def _name_from_file(relative: str) -> str:
    """A robot's name from its URDF path under ``robots/``, as example-robot-data's loader
    names them: ``ur5_robot.urdf`` -> ``ur5``, ``ur5_joint_limited_robot.urdf`` ->
    ``ur5_limited``, ``panda.urdf`` -> ``panda``."""
    stem = PurePosixPath(relative).stem.lower()
    if stem.endswith("_joint_limited_robot"):
        return stem.removesuffix("_joint_limited_robot") + "_limited"
    return stem.removesuffix("_robot")


def _from_distribution() -> dict[str, Path] | None:
    """The distribution's URDFs under ``share/example-robot-data/robots/``, keyed by their
    path relative to that folder (``None`` when the distribution is not installed)."""
    try:
        dist = importlib.metadata.distribution(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return None
    found: dict[str, Path] = {}
    n = len(_ROBOTS_SUBPATH)
    for f in dist.files or ():
        parts = PurePosixPath(str(f)).parts
        if not parts or not parts[-1].lower().endswith(".urdf"):
            continue
        for k in range(len(parts) - n):
            if parts[k : k + n] == _ROBOTS_SUBPATH:
                found["/".join(parts[k + n :])] = Path(str(dist.locate_file(f)))
                break
    return found


def _from_module() -> tuple[dict[str, str], dict[str, Path]] | None:
    """With the ``example_robot_data`` module (conda, robotpkg): its loader's names and
    their URDFs' relative paths, and the files it locates; ``None`` without it."""
    try:
        loader = importlib.import_module("example_robot_data.robots_loader")
    except Exception:  # not installed, or a broken install: the file list still serves
        return None
    names: dict[str, str] = {}
    files: dict[str, Path] = {}
    for name, cls in getattr(loader, "ROBOTS", {}).items():
        urdf = getattr(cls, "urdf_filename", "")
        if not urdf:
            continue  # SDF robots
        rel = f"{cls.path}/{getattr(cls, 'urdf_subpath', 'robots')}/{urdf}"
        names[str(name).lower()] = rel
        try:
            files[rel] = Path(loader.getModelPath(rel)) / rel
        except Exception:  # the loader cannot find it: the distribution's list may
            continue
    return names, files


@functools.cache
def _library() -> _Library:
    """example-robot-data's robots, or :class:`MissingDependencyError`."""
    files = _from_distribution()
    module = _from_module()
    if files is None and module is None:
        raise MissingDependencyError(
            f"robots by name come from the optional package {DISTRIBUTION}, which is not "
            f"installed: {INSTALL_HINT} (or give a URDF file or a pin.Model)",
            DISTRIBUTION,
            "payload",
        )
    files = dict(files or {})
    aliases: dict[str, str] = {}
    if module is not None:
        aliases, module_files = module
        for rel, path in module_files.items():
            files.setdefault(rel, path)
    urdfs: dict[str, Path] = {}
    by_name: dict[str, list[str]] = {}
    for rel in files:
        by_name.setdefault(_name_from_file(rel), []).append(rel)
    for name, rels in by_name.items():
        if len(rels) == 1:
            urdfs[name] = files[rels[0]]
            continue
        # Two files give one name: `<name>_robot.urdf` keeps it (the loader's convention;
        # the other, e.g. ur3.urdf beside ur3_robot.urdf, is reached by its path under
        # robots/); the same file name in two folders is qualified by the folder
        # (anymal_b_simple_anymal).
        stems = [PurePosixPath(rel).stem.lower() for rel in rels]
        robot = [rel for rel, stem in zip(rels, stems, strict=True) if stem != name]
        if len(robot) == 1 and len(set(stems)) == len(stems):
            urdfs[name] = files[robot[0]]
            continue
        for rel in rels:
            folder = PurePosixPath(rel).parts[0].removesuffix("_description")
            urdfs[f"{folder}_{_name_from_file(rel)}".lower()] = files[rel]
    for name, rel in aliases.items():  # the loader's own names win
        if rel in files:
            urdfs[name] = files[rel]
    dirs = []
    for rel, path in files.items():
        # <dir>/example-robot-data/robots/<rel>: package:// URIs resolve from <dir>
        depth = len(PurePosixPath(rel).parts) + 2
        root = path.parents[depth - 1] if len(path.parents) >= depth else path.parent
        if root not in dirs:
            dirs.append(root)
    return _Library(
        urdfs=dict(sorted(urdfs.items())),
        files={rel.lower(): path for rel, path in files.items()},
        package_dirs=tuple(dirs),
    )


def example_robot_names() -> tuple[str, ...]:
    """The robot names example-robot-data provides, sorted (``ur5``, ``panda``, ...).

    Raises:
        MissingDependencyError: example-robot-data is not installed (the message says
            ``pip install "stewart-pin[payload]"``).
    """
    return tuple(_library().urdfs)


def example_robot_urdf(name: str) -> Path:
    """The URDF file of example-robot-data's robot ``name`` (case-insensitive), found in
    the installed package; a path relative to its ``robots/`` folder works too
    (``ur_description/urdf/ur5_robot.urdf``).

    Raises:
        UnknownPayloadError: no such robot (the message lists the available names).
        MissingDependencyError: example-robot-data is not installed.
    """
    lib = _library()
    if not isinstance(name, str):
        raise InputError(f"a robot name must be a string, got {type(name).__name__}")
    key = name.strip().lower()
    if key in lib.urdfs:
        return lib.urdfs[key]
    if key in lib.files:
        return lib.files[key]
    available = tuple(lib.urdfs)
    raise UnknownPayloadError(
        f"example-robot-data has no robot '{name}': give one of {', '.join(available)} "
        "(or a URDF file, or a pin.Model)",
        name,
        available,
    )


#: The SRDF group states taken as a payload's reference posture, in this order of preference
#: (else the first the file has).
REFERENCE_STATES = ("default", "ready", "arm_up", "home")


def _srdf_reference(model: pin.Model, urdf: Path) -> np.ndarray | None:
    """The reference posture of example-robot-data's SRDF beside ``urdf``
    (``<robot>_description/srdf/<stem>.srdf``), ``None`` without one (or without a
    group state of every joint within its limits)."""
    srdf = urdf.parent.parent / "srdf" / f"{urdf.stem}.srdf"
    if not srdf.is_file():
        return None
    copy = pin.Model(model)
    try:
        pin.loadReferenceConfigurations(copy, str(srdf), False)
    except (RuntimeError, ValueError):
        return None
    states = {
        entry.key(): np.array(entry.data(), dtype=float) for entry in copy.referenceConfigurations
    }
    for name in (*REFERENCE_STATES, *states):
        q = states.get(name)
        if q is not None and q.shape == (model.nq,):
            lo, hi = model.lowerPositionLimit, model.upperPositionLimit
            if np.all((q >= lo - 1e-12) & (q <= hi + 1e-12)):
                return q
    return None


# ---------------------------------------------------------------------------- the payload
def _check_fixed_base(model: pin.Model, name: str) -> None:
    for jid in range(1, model.njoints):
        kind = model.joints[jid].shortname()
        if kind in _FLOATING:
            raise PayloadError(
                f"payload '{name}': joint '{model.names[jid]}' is a {kind}: a payload is "
                "bolted to the platform and needs a fixed base (load the URDF without a "
                "free-flyer, or lock that joint with pin.buildReducedModel)"
            )


@dataclass(frozen=True, eq=False)
class Payload:
    """A fixed-base Pinocchio model mounted on the platform.

    Attributes:
        name: the payload's name (a robot name, a file stem, or ``model.name``).
        model: the Pinocchio model, fixed base (a copy: the payload owns it). Its
            ``universe`` frame is the mount frame ``Fb``; ``model.armature`` counts in the
            dynamics; its ``gravity`` does not (the hexapod's is used).
        placement: ``T_p_b`` (4, 4), the pose of ``Fb`` in the platform frame ``Fp``.
        urdf: the URDF file it came from (its visual geometry), or ``None``.
        package_dirs: folders resolving the URDF's ``package://`` URIs.
        visual_scale: the length scale applied by :meth:`scaled` (drawing the meshes).
        reference: the robot's own reference posture (nq,), e.g. the ``default`` group
            state of example-robot-data's SRDF, or ``None``: :meth:`home_configuration`.
    """

    name: str
    model: pin.Model
    placement: np.ndarray = field(default_factory=lambda: np.eye(4))
    urdf: Path | None = None
    package_dirs: tuple[Path, ...] = ()
    visual_scale: float = 1.0
    reference: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.model, pin.Model):
            raise PayloadError(
                f"a payload's model must be a pin.Model, got {type(self.model).__name__}"
            )
        _check_fixed_base(self.model, self.name)
        object.__setattr__(self, "model", pin.Model(self.model))
        T = check_pose(self.placement, "payload placement")
        T.flags.writeable = False
        object.__setattr__(self, "placement", T)
        if self.reference is not None:
            q = check_array(self.reference, (self.nq,), "payload reference posture")
            lo, hi = self.model.lowerPositionLimit, self.model.upperPositionLimit
            if np.any((q < lo - 1e-12) | (q > hi + 1e-12)):
                raise PayloadError(
                    f"payload '{self.name}': the reference posture {q} leaves the joint limits"
                )
            q.flags.writeable = False
            object.__setattr__(self, "reference", q)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_model(
        cls, model: pin.Model, placement: Any = None, name: str | None = None
    ) -> Payload:
        """A payload from a fixed-base ``pin.Model`` (copied), at ``placement`` ``T_p_b``
        (default identity: ``Fb`` on ``Fp``)."""
        if not isinstance(model, pin.Model):
            raise PayloadError(f"expected a pin.Model, got {type(model).__name__}")
        return cls(name or model.name or "payload", model, _placement(placement))

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        placement: Any = None,
        name: str | None = None,
        package_dirs: tuple[str | Path, ...] = (),
    ) -> Payload:
        """A payload from a URDF file, loaded with a fixed base (its root link bolted to
        the platform at ``placement``); ``package_dirs`` resolve ``package://`` URIs of
        its meshes (drawing only)."""
        path = Path(path)
        if not path.is_file():
            raise PayloadError(f"payload URDF {path} is not a file")
        _check_urdf_root(path)
        try:
            model = pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError) as e:
            raise PayloadError(f"Pinocchio cannot load the payload URDF {path}: {e}") from e
        dirs = tuple(Path(d) for d in package_dirs) or (path.parent,)
        return cls(name or path.stem, model, _placement(placement), path, dirs)

    @classmethod
    def from_example_robot_data(cls, name: str, placement: Any = None) -> Payload:
        """example-robot-data's robot ``name`` (see :func:`example_robot_names`), with a
        fixed base, at ``placement``.

        Raises:
            UnknownPayloadError: an unknown name (the message lists the available ones).
            MissingDependencyError: example-robot-data is not installed.
        """
        path = example_robot_urdf(name)
        p = cls.from_urdf(path, placement, name.strip().lower(), _library().package_dirs)
        reference = _srdf_reference(p.model, path)
        return p if reference is None else dataclasses.replace(p, reference=reference)

    # ------------------------------------------------------------------ properties
    @property
    def nq(self) -> int:
        """Size of the joint configuration ``q``."""
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        """Number of joint rates (and torques)."""
        return int(self.model.nv)

    @property
    def mass(self) -> float:
        """Total mass [kg] (the welded base links included)."""
        return float(sum(inertia.mass for inertia in self.model.inertias))

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The moving joints' names, in Pinocchio's order."""
        return tuple(self.model.names[1:])

    def __repr__(self) -> str:
        return f"Payload('{self.name}', nq={self.nq}, nv={self.nv}, mass={self.mass:.4g} kg)"

    # ------------------------------------------------------------------ variants
    def with_placement(self, placement: Any) -> Payload:
        """The same payload mounted at ``placement`` ``T_p_b`` (4, 4)."""
        return dataclasses.replace(self, placement=_placement(placement))

    def scaled(self, length: float = 1.0, mass: float = 1.0) -> Payload:
        """The payload scaled geometrically: every length by ``length`` (joint and frame
        placements, centres of mass, prismatic joint limits), every mass by ``mass``,
        inertia tensors by ``mass * length**2``, the armature of revolute joints by
        ``mass * length**2`` and of prismatic ones by ``mass``. A small arm made to fit a
        hexapod: ``Payload.from_example_robot_data("so101").scaled(2.0, 8.0)``."""
        s = check_scalar(length, "length", positive=True)
        m = check_scalar(mass, "mass", positive=True)
        model = pin.Model(self.model)
        for j in range(model.njoints):
            M = model.jointPlacements[j]
            model.jointPlacements[j] = pin.SE3(M.rotation, M.translation * s)
            inertia = model.inertias[j]
            model.inertias[j] = pin.Inertia(
                inertia.mass * m, inertia.lever * s, inertia.inertia * (m * s * s)
            )
        for k in range(len(model.frames)):
            frame = model.frames[k]
            frame.placement = pin.SE3(frame.placement.rotation, frame.placement.translation * s)
            model.frames[k] = frame
        lower, upper = np.array(model.lowerPositionLimit), np.array(model.upperPositionLimit)
        velocity, armature = np.array(model.velocityLimit), np.array(model.armature)
        for j in range(1, model.njoints):
            joint = model.joints[j]
            qs = slice(joint.idx_q, joint.idx_q + joint.nq)
            vs = slice(joint.idx_v, joint.idx_v + joint.nv)
            if _is_prismatic(joint):
                lower[qs] *= s
                upper[qs] *= s
                velocity[vs] *= s
                armature[vs] *= m
            else:
                armature[vs] *= m * s * s
        model.lowerPositionLimit, model.upperPositionLimit = lower, upper
        model.velocityLimit, model.armature = velocity, armature
        name = f"{self.name}-x{s:g}" if s != 1.0 or m != 1.0 else self.name
        reference = None
        if self.reference is not None:  # a slide's position scales with the lengths
            reference = self.reference.copy()
            for j in range(1, model.njoints):
                joint = model.joints[j]
                if _is_prismatic(joint):
                    reference[joint.idx_q : joint.idx_q + joint.nq] *= s
        return Payload(
            name,
            model,
            self.placement,
            self.urdf,
            self.package_dirs,
            self.visual_scale * s,
            reference,
        )

    # ------------------------------------------------------------------ configurations
    def home_configuration(self) -> np.ndarray:
        """The home posture, (nq,): the robot's own :attr:`reference` posture where it has
        one (example-robot-data's SRDF ``default`` state: the Panda's ready pose, its arm
        clear of the platform, where the middle of the ranges folded it down), else the
        middle of each joint's range: a joint with finite limits (within ``+-2 pi``) at
        the middle of them, any other at Pinocchio's neutral value (a continuous joint at
        angle 0)."""
        if self.reference is not None:
            return self.reference.copy()
        q = np.array(pin.neutral(self.model), dtype=float)
        lo = np.array(self.model.lowerPositionLimit, dtype=float)
        hi = np.array(self.model.upperPositionLimit, dtype=float)
        for k, _ in self._joint_slices():
            ok = np.isfinite(lo[k]) & np.isfinite(hi[k]) & (lo[k] <= hi[k])
            ok &= (np.abs(lo[k]) <= 2 * np.pi + 1e-9) & (np.abs(hi[k]) <= 2 * np.pi + 1e-9)
            q[k] = np.where(ok, 0.5 * (lo[k] + hi[k]), q[k])
        return q

    def room(self, q: Any = None) -> np.ndarray:
        """How far each degree of freedom can move either way from ``q`` (default the home
        posture) within its limits, (nv,) [rad or m]: the distance to the nearer limit,
        at most :meth:`half_ranges` (so, at the middle of the ranges, the half-ranges)."""
        q = self.home_configuration() if q is None else check_array(q, (self.nq,), "q")
        room = self.half_ranges()
        lo = np.asarray(self.model.lowerPositionLimit, dtype=float)
        hi = np.asarray(self.model.upperPositionLimit, dtype=float)
        for qs, vs in self._joint_slices():
            with np.errstate(invalid="ignore"):
                near = np.minimum(q[qs] - lo[qs], hi[qs] - q[qs])
            room[vs] = np.where(
                np.isfinite(near), np.minimum(room[vs], np.maximum(near, 0.0)), room[vs]
            )
        return room

    def half_ranges(self) -> np.ndarray:
        """Each degree of freedom's half-range (nv,) [rad or m]: half the distance between
        its joint's limits, at most pi; pi for a joint without finite limits (or a
        continuous one)."""
        half = np.full(self.nv, np.pi)
        lo = np.asarray(self.model.lowerPositionLimit, dtype=float)
        hi = np.asarray(self.model.upperPositionLimit, dtype=float)
        for qs, vs in self._joint_slices():
            width = 0.5 * (hi[qs] - lo[qs])
            ok = np.isfinite(width) & (width >= 0)
            half[vs] = np.where(ok, np.minimum(np.where(ok, width, 0.0), np.pi), np.pi)
        return half

    def _joint_slices(self) -> Iterator[tuple[slice, slice]]:
        """``(q slice, v slice)`` of each joint with as many positions as rates (not a
        continuous joint's ``(cos, sin)``, nor a spherical joint's quaternion)."""
        for j in range(1, self.model.njoints):
            joint = self.model.joints[j]
            if joint.nq == joint.nv:
                yield (
                    slice(joint.idx_q, joint.idx_q + joint.nq),
                    slice(joint.idx_v, joint.idx_v + joint.nv),
                )

    def random_configurations(
        self, n: int, rng: np.random.Generator | int | None = None
    ) -> np.ndarray:
        """``n`` configurations (n, nq) drawn uniformly within the joint limits (a joint
        without finite limits within ``+-UNBOUNDED_RANGE``)."""
        rng = np.random.default_rng(rng)
        lo, hi = self._limits()
        q = rng.uniform(lo, hi, size=(n, self.nq))
        for j in range(1, self.model.njoints):
            joint = self.model.joints[j]
            if joint.nq == 2 and joint.nv == 1:  # continuous joint: (cos, sin)
                angle = rng.uniform(-np.pi, np.pi, size=n)
                q[:, joint.idx_q] = np.cos(angle)
                q[:, joint.idx_q + 1] = np.sin(angle)
            elif joint.nq != joint.nv:  # other Lie groups: Pinocchio's own draw
                for k in range(n):
                    qk = pin.randomConfiguration(self.model, lo, hi)
                    q[k, joint.idx_q : joint.idx_q + joint.nq] = qk[
                        joint.idx_q : joint.idx_q + joint.nq
                    ]
        return q

    def _limits(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array(self.model.lowerPositionLimit, dtype=float)
        hi = np.array(self.model.upperPositionLimit, dtype=float)
        bad = ~(np.isfinite(lo) & np.isfinite(hi) & (lo <= hi)) | (np.abs(lo) > 1e6)
        bad |= np.abs(hi) > 1e6
        lo[bad], hi[bad] = -UNBOUNDED_RANGE, UNBOUNDED_RANGE
        return lo, hi

    def check_configurations(self, q: Any, name: str = "payload q") -> tuple[np.ndarray, bool]:
        """``q`` (nq,) or (N, nq) as a batch (N, nq) and whether it was one; continuous
        joints' ``(cos, sin)`` pairs must have unit norm (to 1e-9)."""
        arr, batched = check_batch(q, (self.nq,), name)
        for j in range(1, self.model.njoints):
            joint = self.model.joints[j]
            if joint.nq == 2 and joint.nv == 1:
                norm = np.hypot(arr[:, joint.idx_q], arr[:, joint.idx_q + 1])
                if np.any(np.abs(norm - 1.0) > 1e-9):
                    raise PayloadError(
                        f"{name}: continuous joint '{self.model.names[j]}' takes (cos, sin) "
                        f"of its angle, of unit norm; got norm {norm.max():.6g}"
                    )
        return arr, batched

    def check_rates(self, value: Any, name: str, n: int, batched: bool) -> np.ndarray:
        """Joint rates, accelerations or torques (nv,) or (N, nv), as a batch (N, nv)
        matching ``n`` states given as a batch (``batched``) or one."""
        arr, b = check_batch(value, (self.nv,), name)
        if b != batched or arr.shape[0] != n:
            want = f"a batch ({n}, {self.nv})" if batched else f"one vector ({self.nv},)"
            raise InputError(f"{name} must be {want} to match the states, got {np.shape(value)}")
        return arr

    # ------------------------------------------------------------------ drawing
    def visual_model(self) -> pin.GeometryModel | None:
        """The URDF's visual geometry on :attr:`model` (meshes scaled by
        :attr:`visual_scale`), or ``None`` without a URDF or when its meshes cannot be
        loaded (the viewer then draws simple shapes).

        Raises:
            PayloadMeshError: a mesh whose real path (symbolic links resolved) is not
                under the URDF's folder or one of :attr:`package_dirs`
                (:meth:`check_mesh_paths`).
        """
        if self.urdf is None:
            return None
        try:
            geom = pin.buildGeomFromUrdf(
                self.model,
                str(self.urdf),
                pin.GeometryType.VISUAL,
                package_dirs=[str(d) for d in self.package_dirs],
            )
        except (RuntimeError, ValueError, OSError):
            return None
        self.check_mesh_paths(geom)
        s = self.visual_scale
        if s != 1.0:
            for g in geom.geometryObjects:
                g.meshScale = np.asarray(g.meshScale) * s
                g.placement = pin.SE3(g.placement.rotation, g.placement.translation * s)
        return geom

    def mesh_folders(self) -> tuple[str, ...]:
        """The real paths of the folders a mesh of the URDF may lie under: the URDF's own
        folder and :attr:`package_dirs` (empty without a URDF)."""
        if self.urdf is None:
            return ()
        folders = [self.urdf.parent, *self.package_dirs]
        return tuple(dict.fromkeys(os.path.realpath(f) for f in folders))

    def check_mesh_paths(self, geom: pin.GeometryModel) -> None:
        """Refuse a mesh of ``geom`` whose real path lies outside :meth:`mesh_folders`
        (:class:`PayloadMeshError`, naming the mesh): an absolute path, ``../``,
        ``file://`` or a symbolic link leading out of the URDF's folders. Primitives
        (boxes, cylinders, spheres) have no file."""
        allowed = self.mesh_folders()
        for obj in geom.geometryObjects:
            if type(obj.geometry).__name__ in _PRIMITIVES or not obj.meshPath:
                continue
            mesh = str(obj.meshPath)
            real = os.path.realpath(mesh)  # a relative path (a relative URDF path): from "."
            inside = any(os.path.commonpath([real, folder]) == folder for folder in allowed)
            if not inside:
                raise PayloadMeshError(
                    f"payload '{self.name}': the mesh of {obj.name!r} is {mesh!r}, whose real "
                    f"path {real!r} is outside the URDF's folder and its package directories "
                    f"({', '.join(allowed)}); only meshes shipped under them are drawn: move "
                    "the mesh there (a copy, not a symbolic link), or draw simple shapes "
                    "(--payload-shapes, meshes=False)",
                    mesh,
                    real,
                    allowed,
                )


#: coal's primitive shapes: drawn from their parameters, no file read.
_PRIMITIVES = frozenset(
    ("Box", "Sphere", "Cylinder", "Capsule", "Cone", "Ellipsoid", "Plane", "Halfspace")
)


def _check_urdf_root(path: Path) -> None:
    """A file that is not well-formed XML with a ``<robot>`` root, with a number
    Pinocchio's URDF parser cannot read (``mass="1,5"``, ``"1.5kg"``: it prints a line
    on stderr and loads a massless link), or whose joints close a cycle (it drops the
    links of a cycle the root does not reach, mass and all) is refused here, in one
    message naming the element or joint (:mod:`stewart_pin.formats._urdf_checks`)."""
    from xml.etree import ElementTree

    try:
        root = ElementTree.parse(path).getroot()  # no external entities, no network
    except (ElementTree.ParseError, OSError, ValueError) as e:
        raise PayloadError(f"payload URDF {path} is not well-formed XML: {e}") from e
    if root.tag != "robot":
        raise PayloadError(
            f"payload URDF {path}: the root element is <{root.tag}>, not <robot> (a URDF)"
        )
    bad = non_finite_number(root)
    if bad is not None:  # Pinocchio would load it and fail later in its own words
        raise PayloadError(f"payload URDF {path}: {bad}: every number must be finite")
    check_urdf_numbers(root, f"payload URDF {path}", PayloadError)
    for link in root.findall("link"):  # urdfdom drops an incomplete <inertial>: massless
        for inertial in link.findall("inertial"):
            mass, inertia = inertial.find("mass"), inertial.find("inertia")
            missing = [] if mass is not None and mass.get("value") is not None else ["mass"]
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            missing += [k for k in keys if inertia is None or inertia.get(k) is None]
            if missing:
                raise PayloadError(
                    f"payload URDF {path}: the <inertial> of link {link.get('name')!r} misses "
                    f"{', '.join(missing)}: give <mass value=...> and <inertia> with ixx, ixy, "
                    "ixz, iyy, iyz and izz (Pinocchio would load the link without it)"
                )
    cycle = urdf_cycle(root)  # urdfdom drops the links of a cycle the root does not reach
    if cycle is not None:
        raise PayloadError(f"payload URDF {path}: {cycle.message}")


def _is_prismatic(joint: Any) -> bool:
    kind = joint.shortname()
    return bool(kind.startswith("JointModelP") and not kind.startswith("JointModelPlanar"))


def _placement(placement: Any) -> np.ndarray:
    if placement is None:
        return np.eye(4)
    if isinstance(placement, pin.SE3):
        return np.array(placement.homogeneous)
    return check_pose(placement, "payload placement")


def load_payload(source: Any, placement: Any = None) -> Payload:
    """A :class:`Payload` from ``source``: a :class:`Payload` (re-mounted at
    ``placement`` when given), a ``pin.Model``, a URDF path (``.urdf``), or a robot name
    of example-robot-data; ``placement`` is ``T_p_b`` (4, 4) or ``pin.SE3``, default
    identity.

    Raises:
        UnknownPayloadError: a name that is neither a file nor a robot (the message lists
            the robots). MissingDependencyError: a robot name without example-robot-data
            installed. PayloadError: a floating base, or a URDF Pinocchio cannot load.
    """
    if isinstance(source, Payload):
        return source if placement is None else source.with_placement(placement)
    if isinstance(source, pin.Model):
        return Payload.from_model(source, placement)
    if isinstance(source, (str, Path)):
        path = Path(source)
        if path.suffix.lower() == ".urdf" or path.is_file():
            return Payload.from_urdf(path, placement)
        return Payload.from_example_robot_data(str(source), placement)
    raise InputError(
        "a payload is a robot name, a URDF path, a pin.Model or a Payload; got "
        f"{type(source).__name__}"
    )


# ---------------------------------------------------------------------------- composition
def _index_map(source: pin.Model, combined: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    """For every q and v coordinate of ``source``, its index in ``combined`` (joints
    matched by name): ``(q_map (source.nq,), v_map (source.nv,))``."""
    q_map = np.empty(source.nq, dtype=int)
    v_map = np.empty(source.nv, dtype=int)
    for j in range(1, source.njoints):
        name = source.names[j]
        if not combined.existJointName(name):
            raise PayloadError(f"joint '{name}' is missing after appending the payload")
        js, jc = source.joints[j], combined.joints[combined.getJointId(name)]
        if (js.nq, js.nv) != (jc.nq, jc.nv):
            raise PayloadError(f"joint '{name}' changed kind after appending the payload")
        q_map[js.idx_q : js.idx_q + js.nq] = np.arange(jc.idx_q, jc.idx_q + jc.nq)
        v_map[js.idx_v : js.idx_v + js.nv] = np.arange(jc.idx_v, jc.idx_v + jc.nv)
    return q_map, v_map


@dataclass(frozen=True)
class AttachedModel:
    """A host model with a payload appended (:func:`attach_payload`).

    Attributes:
        model: the combined model (host, then payload, in Pinocchio's depth-first order).
        q_index, v_index: the payload's coordinates in it, (payload.nq,), (payload.nv,).
        host_q, host_v: each host coordinate's index in it, (host.nq,), (host.nv,).
        host_joints: each host joint id's id in it, (host.njoints,).
    """

    model: pin.Model
    q_index: np.ndarray
    v_index: np.ndarray
    host_q: np.ndarray
    host_v: np.ndarray
    host_joints: np.ndarray


def _prefixed(model: pin.Model, prefix: str) -> pin.Model:
    """A copy of ``model`` whose joint and frame names (but ``universe``) start with
    ``prefix`` (no clash with the host's names)."""
    out = pin.Model(model)
    if not prefix:
        return out
    for j in range(1, out.njoints):
        out.names[j] = prefix + out.names[j]
    for k in range(1, len(out.frames)):
        frame = out.frames[k]
        frame.name = prefix + frame.name
        out.frames[k] = frame
    return out


def attach_payload(
    model: pin.Model, joint: int, payload: Payload, mount: Any = None, prefix: str = PREFIX
) -> AttachedModel:
    """``model`` with ``payload`` appended (``pin.appendModel``) to joint ``joint`` at
    ``mount`` (the pose, in that joint's frame, of the frame carrying ``T_p_b``; default
    identity), its base bolted to that joint's body (the payload's welded links join
    that body). The payload's joint and frame names get ``prefix``. The host's joints may
    be renumbered (Pinocchio orders joints depth first): :class:`AttachedModel` maps them.
    ``model.armature`` is kept and the payload's appended; gravity is ``model``'s.
    """
    host = pin.Model(model)
    M = pin.SE3.Identity() if mount is None else pin.SE3(np.asarray(mount, dtype=float))
    fid = host.addFrame(pin.Frame(MOUNT_FRAME, joint, M, pin.FrameType.OP_FRAME))
    guest = _prefixed(payload.model, prefix)
    try:
        combined = pin.appendModel(host, guest, fid, pin.SE3(payload.placement))
    except (RuntimeError, ValueError) as e:
        raise PayloadError(f"cannot append payload '{payload.name}': {e}") from e
    q_idx, v_idx = _index_map(guest, combined)
    host_q, host_v = _index_map(model, combined)
    host_joints = np.array(
        [0] + [combined.getJointId(model.names[j]) for j in range(1, model.njoints)]
    )
    armature = np.zeros(combined.nv)
    armature[host_v] = np.asarray(model.armature)
    armature[v_idx] = np.asarray(payload.model.armature)
    combined.armature = armature
    combined.gravity = pin.Motion(model.gravity)
    return AttachedModel(combined, q_idx, v_idx, host_q, host_v, host_joints)


def floating_payload_model(
    payload: Payload, gravity: Any
) -> tuple[pin.Model, np.ndarray, np.ndarray]:
    """The payload on a free-flyer whose frame is ``Fb``: the platform's motion (through
    ``T_p_b``) is its base motion. Pinocchio's RNEA on it gives, in its first six rows,
    the wrench the platform applies to the payload (in ``Fb``, about ``Fb``'s origin:
    Pinocchio's free-flyer convention) and in the others the payload's joint torques.

    Args:
        payload: the payload. gravity: (3,) in F0 [m/s^2].

    Returns:
        ``(model, q_index, v_index)``: ``model.nq = 7 + payload.nq`` (free-flyer first,
        ``[p, quaternion xyzw]``), and the payload's coordinates in it.
    """
    g = check_array(gravity, (3,), "gravity")
    host = pin.Model()
    host.name = f"{payload.name}-floating"
    host.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), BASE_JOINT)
    host.gravity = pin.Motion(g, np.zeros(3))
    attached = attach_payload(host, 1, payload.with_placement(np.eye(4)))
    return attached.model, attached.q_index, attached.v_index
