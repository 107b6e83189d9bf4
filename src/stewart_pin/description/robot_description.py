"""The robot description: geometry, strokes and the 190 standard inertial parameters.

Frames and points (SI units throughout):

- ``F0`` is the base frame, ``Fp`` the platform frame (origin ``O_p``).
- ``base_points[i]`` is ``B_i`` in ``F0``: the centre of leg i's universal joint.
- ``platform_points[i]`` is ``P_i`` in ``Fp``: the centre of leg i's spherical joint.
- ``leg_base_rotations[i]`` is the orientation in ``F0`` of leg frame ``1i`` at
  ``q1i = 0``; its z column is the first U-joint axis. The leg frames follow
  Khalil-Kleinfinger (modified DH): frame ``1i(q1) = R1_i Rz(q1)`` at ``B_i``,
  frame ``2i = 1i(q1) Rx(pi/2) Rz(q2)`` at ``B_i``, frame ``3i = 2i Rx(pi/2) Tz(q3)``,
  whose origin is ``P_i`` and whose z axis runs along the leg, ``q3i = |B_i P_i|``.
- ``leg_inertia[i, j]`` holds the 10 standard parameters of link ``j+1`` of leg ``i+1`` in
  Khalil's order ``XX XY XZ YY YZ ZZ MX MY MZ M``, in that link's frame, about its origin;
  ``platform_inertia`` likewise in ``Fp`` about ``O_p``.

Legs are numbered 1..6 in messages (as in the paper) and 0..5 as array indices.
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import (
    check_array,
    check_pose,
    decode_utf8,
    is_se3,
    nested_ndim,
    project_rotation,
)
from stewart_pin._io import write_text_atomic
from stewart_pin.description.chain_leg import ChainLeg, gravcomp_factor
from stewart_pin.description.chain_leg_io import chain_leg_to_dict, chain_legs_from_value
from stewart_pin.description.inertia import (
    check_physical,
    check_physical_bodies,
    khalil_from_inertial_table,
    leg_link_name,
)
from stewart_pin.description.leg_architecture import LegArchitecture, ups
from stewart_pin.description.leg_io import leg_to_dict, legs_from_value, legs_toml
from stewart_pin.description.model_source import ModelSource, source_toml
from stewart_pin.exceptions import (
    DescriptionError,
    FileFormatError,
    GravityCompensationError,
    InertiaError,
    InputError,
    RobotNameError,
    UnsupportedArchitectureError,
)

#: Keys of the dictionary form (``to_dict`` / ``from_dict``) that must be present.
REQUIRED_KEYS = (
    "base_points",
    "platform_points",
    "leg_base_rotations",
    "stroke",
    "leg_inertia",
    "platform_inertia",
    "gravity",
)
#: Optional keys: ``name`` (str), ``u_joint_limits`` ((2, 2) or (6, 2, 2) [rad]),
#: ``home_pose`` (4x4 0Tp: the workspace centre and forward geometry's default guess) and
#: ``legs`` (six leg tables, :mod:`stewart_pin.description.leg_io`; with ``legs``,
#: ``stroke`` and ``u_joint_limits`` are left out and ``home_pose`` is required) and
#: ``source`` (where an imported robot came from: :mod:`.model_source`).
OPTIONAL_KEYS = ("name", "u_joint_limits", "home_pose", "legs", "source")
#: Optional limits of the six actuated joints, each one positive number for all or six
#: (absent: unbounded): ``effort_limits`` [N or N m, joint side], ``velocity_limits``
#: [m/s or rad/s], ``acceleration_limits`` [m/s^2 or rad/s^2]. Exciting trajectories for
#: identification respect them and a log's efforts at the limit count as saturated.
ACTUATOR_LIMIT_KEYS = ("effort_limits", "velocity_limits", "acceleration_limits")
# (appended here, a line apart, so that other optional keys merge in above)
OPTIONAL_KEYS = (*OPTIONAL_KEYS, *ACTUATOR_LIMIT_KEYS)  # type: ignore[assignment]
#: Optional per-body gravity compensation, the fraction ``c`` of a body's weight removed
#: (MJCF ``gravcomp``; 1 for an SDF link with ``<gravity>false</gravity>``): each body's
#: weight is ``(1 - c) m g`` at its centre of mass. ``platform_gravcomp`` one number,
#: ``leg_gravcomp`` one list per leg with one factor per link (links 1, 2, 3; chain legs
#: carry theirs, each leg table's ``gravcomp``); each finite in [0, 1], 0 when left out
#: (and left out of the files when every factor is 0).
GRAVCOMP_KEYS = ("platform_gravcomp", "leg_gravcomp")
OPTIONAL_KEYS = (*OPTIONAL_KEYS, *GRAVCOMP_KEYS)  # type: ignore[assignment]

#: ``chain_legs``: six chain leg tables (:mod:`.chain_leg_io`; any 1-dof joints, ball or
#: weld closures); with them ``stroke`` and ``u_joint_limits`` are left out, ``leg_inertia``
#: may be (each leg carries its links') and ``home_pose`` is required.
OPTIONAL_KEYS = (*OPTIONAL_KEYS, "chain_legs")  # type: ignore[assignment]

#: URDF-style alternatives of the two inertia keys (``docs/description.md``): each body's
#: mass, centre of mass and inertia about it in the body's own frame
#: (:func:`~stewart_pin.description.inertia.khalil_from_inertial_table`):
#: ``platform_inertial`` one table, ``leg_inertial`` three tables (links 1, 2, 3 of every
#: leg) or six lists of three. Read by :meth:`RobotDescription.from_dict` (and so by
#: ``read``), which converts them to Khalil's parameters; ``to_dict`` and ``write`` give
#: Khalil's form.
INERTIAL_KEYS = {"leg_inertia": "leg_inertial", "platform_inertia": "platform_inertial"}

#: A robot name: 1 to 64 characters, ASCII letters, digits, ``_``, ``.`` and ``-``, starting
#: with a letter or a digit, with no ``..`` and no ``--`` in it. Such a name is a safe file
#: name (no folder, not hidden, not an option), and safe text in XML, YAML, JSON and HTML.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: The rule of :data:`NAME_PATTERN`, as the error messages and the docs state it.
NAME_RULE = (
    "1 to 64 characters among A-Z a-z 0-9 _ . -, starting with a letter or a digit, "
    "without '..' or '--'"
)

#: Relative distance (to the attachment circle's size) under which two attachment points
#: are one joint centre, shared by their legs (as in 3-3 and 6-3 designs).
POINT_TOLERANCE = 1e-9
#: Most legs that may meet at one joint centre: the lines of more than three legs
#: through one point are linearly dependent, so every pose of such a robot is singular.
MAX_LEGS_PER_POINT = 3


@dataclass(frozen=True, eq=False)
class RobotDescription:
    """A validated, immutable Gough-Stewart robot description (see the module docstring).

    Arrays are copied on construction and made read-only. ``name`` names the robot and
    the files written for it (``<name>.urdf``...): it follows :data:`NAME_RULE` (1 to 64
    characters among ``A-Z a-z 0-9 _ . -``, starting with a letter or a digit, without
    ``..`` or ``--``; :func:`check_robot_name`), else :class:`RobotNameError`.

    ``legs``: ``None`` (the default) is the paper's ideal 6-UPS robot, its legs built from
    ``stroke`` and ``u_joint_limits`` (:attr:`leg_architectures`); or six
    :class:`~stewart_pin.description.leg_architecture.LegArchitecture` (or leg tables of
    the file format) for general three-joint legs with joint dynamics. With ``legs``,
    the joint limits live in the legs: ``stroke`` and ``u_joint_limits`` must be ``None``
    (``desc.stroke`` is then ``None``; code paths that need the 6-UPS stroke refuse such
    a robot with :class:`~stewart_pin.exceptions.UnsupportedArchitectureError`), and
    ``home_pose`` must be given (its reachability and distance to singularities are
    checked by :class:`~stewart_pin.StewartRobot`, where the inverse geometry lives).
    Frame 0i of leg i is placed at ``base_points[i]`` with ``leg_base_rotations[i]``;
    ``leg_inertia[i, j]`` is link j+1 of leg i+1 in its own MDH frame.
    """

    base_points: np.ndarray
    platform_points: np.ndarray
    leg_base_rotations: np.ndarray
    stroke: np.ndarray | None
    leg_inertia: np.ndarray
    platform_inertia: np.ndarray
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    u_joint_limits: np.ndarray | None = None
    name: str = "stewart"
    # None (or a pin.SE3) is accepted at construction; __post_init__ stores the 4x4 (the
    # upright pose when None), so the attribute is always a pose.
    home_pose: np.ndarray = None  # type: ignore[assignment]
    # the actuated joints' limits (ACTUATOR_LIMIT_KEYS), (6,) each, or None
    effort_limits: np.ndarray | None = None
    velocity_limits: np.ndarray | None = None
    acceleration_limits: np.ndarray | None = None
    legs: tuple[LegArchitecture, ...] | None = None
    # where an imported robot came from (file names of its bodies and joints), or None
    source: ModelSource | None = None
    # six chain legs (any 1-dof joints, ball or weld closure, links' inertia in the legs;
    # docs/legs.md "Chain legs and welds"), or None
    chain_legs: tuple[ChainLeg, ...] | None = None
    # per-body gravity compensation (GRAVCOMP_KEYS): the platform's factor, and (6, 3) the
    # links' (None, or six lists, accepted at construction; stored as the (6, 3) array)
    platform_gravcomp: float = 0.0
    leg_gravcomp: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        check_robot_name(self.name)
        self._check_gravcomp()
        if self.source is not None:
            object.__setattr__(self, "source", ModelSource.from_value(self.source))
        if self.legs is not None:
            self._check_legs()
        if self.chain_legs is not None:
            self._check_chain_legs()

        def set_(key: str, value: np.ndarray) -> None:
            value = np.array(value, dtype=np.float64)
            value.flags.writeable = False
            object.__setattr__(self, key, value)

        shapes = {
            "base_points": (6, 3),
            "platform_points": (6, 3),
            "leg_base_rotations": (6, 3, 3),
            **({} if not self.is_ideal_ups else {"stroke": (2,)}),
            "leg_inertia": (6, 3, 10),
            "platform_inertia": (10,),
            "gravity": (3,),
        }
        key = ""
        try:
            for key, shape in shapes.items():
                set_(key, check_array(getattr(self, key), shape, key))
            if self.u_joint_limits is not None:
                key = "u_joint_limits"
                one = nested_ndim(self.u_joint_limits) == 2  # one (2, 2) for every leg
                try:
                    lim = check_array(self.u_joint_limits, (2, 2) if one else (6, 2, 2), key)
                except InputError as e:
                    raise InputError(f"{e} ((2, 2) for every leg, or (6, 2, 2))") from e
                set_(key, np.broadcast_to(lim, (6, 2, 2)))
            if self.home_pose is not None:
                key = "home_pose"
                pose: Any = self.home_pose
                if is_se3(pose):
                    pose = pose.homogeneous
                T = check_array(pose, (4, 4), key).copy()
                T[:3, :3] = project_rotation(T[:3, :3], "home_pose rotation block", stacklevel=4)
                set_(key, check_pose(T, key))
            for key in ACTUATOR_LIMIT_KEYS:
                if getattr(self, key) is not None:
                    set_(key, _actuator_limits(getattr(self, key), key))
        except InputError as e:
            raise _field_error(key, f"robot description '{self.name}': {e}") from e
        self._check_points()
        self._check_frames(set_)
        if self.stroke is not None:
            lo, hi = self.stroke
            if not 0.0 < lo < hi:
                raise _field_error(
                    "stroke", f"stroke must satisfy 0 < min < max, got [{lo:.9g}, {hi:.9g}] m"
                )
        if self.u_joint_limits is not None:
            bad = np.argwhere(self.u_joint_limits[..., 0] >= self.u_joint_limits[..., 1])
            if bad.size:
                i, j = bad[0]
                raise _field_error(
                    "u_joint_limits",
                    f"u_joint_limits of leg {i + 1}, q{j + 1}: lower "
                    f"{self.u_joint_limits[i, j, 0]:.9g} >= upper "
                    f"{self.u_joint_limits[i, j, 1]:.9g}",
                )
        if self.home_pose is None:
            set_("home_pose", _upright_home_pose(self))
        try:
            key = "leg_inertia"
            check_physical_bodies(self.leg_inertia, leg_link_name)
            key = "platform_inertia"
            check_physical(self.platform_inertia, "platform")
            key = "leg_inertia"
            if self.chain_legs is not None and np.any(self.leg_inertia != 0.0):
                raise InertiaError(
                    f"robot description '{self.name}': with chain_legs the links' inertia "
                    "is in each ChainLeg (inertia (n, 10)); leg_inertia must be zeros",
                    "legs",
                )
        except InertiaError as e:
            e.key = key  # type: ignore[attr-defined] # read() quotes the line of the key
            raise
        if self.chain_legs is not None and np.any(self.leg_gravcomp):
            raise _gravcomp_error(
                "leg_gravcomp",
                f"robot description '{self.name}': with chain_legs each link's gravity "
                "compensation is in its ChainLeg (gravcomp, one factor per link); "
                "leg_gravcomp must be left out",
                "leg_gravcomp",
            )
        if self.has_gravcomp and self.legs is None and self.chain_legs is None:
            # the ideal 6-UPS form has one gravity for every body: a robot whose bodies'
            # weights are compensated differently takes the same legs as general legs
            object.__setattr__(self, "legs", self.leg_architectures)
            object.__setattr__(self, "stroke", None)
            object.__setattr__(self, "u_joint_limits", None)

    # ------------------------------------------------------------------ validation
    def _check_gravcomp(self) -> None:
        """``platform_gravcomp`` a finite number in [0, 1]; ``leg_gravcomp`` ``None`` or
        six lists (one per leg) of one such number per link, stored as (6, 3)."""
        c = _gravcomp_factor(self.platform_gravcomp, "platform")
        object.__setattr__(self, "platform_gravcomp", c)
        n_links = 3  # every leg of this description is a chain of three links
        value = self.leg_gravcomp
        out = np.zeros((6, n_links))
        if value is not None:
            rows = value.tolist() if isinstance(value, np.ndarray) else value
            if not isinstance(rows, (list, tuple)) or len(rows) != 6:
                raise _gravcomp_error(
                    "leg_gravcomp",
                    f"leg_gravcomp must be six lists (one per leg) of {n_links} factors (one "
                    f"per link), got {_short(value)}",
                    value,
                )
            for i, row in enumerate(rows):
                if not isinstance(row, (list, tuple)) or len(row) != n_links:
                    raise _gravcomp_error(
                        "leg_gravcomp",
                        f"leg_gravcomp of leg {i + 1} must be {n_links} factors (one per link, "
                        f"links 1..{n_links}), got {_short(row)}",
                        row,
                    )
                for j, x in enumerate(row):
                    out[i, j] = _gravcomp_factor(x, f"leg {i + 1} link {j + 1}")
        out.flags.writeable = False
        object.__setattr__(self, "leg_gravcomp", out)

    @property
    def has_gravcomp(self) -> bool:
        """Whether some body's weight is compensated (a non-zero ``platform_gravcomp``,
        ``leg_gravcomp`` or a chain leg's ``gravcomp``)."""
        return (
            self.platform_gravcomp != 0.0
            or bool(np.any(self.leg_gravcomp))
            or any(np.any(leg.gravcomp) for leg in self.chain_legs or ())
        )

    def _check_legs(self) -> None:
        """Six legs (parsed from tables when needed); no shared stroke or U-joint limits
        beside them; an explicit home pose."""
        object.__setattr__(self, "legs", legs_from_value(self.legs))
        for key in ("stroke", "u_joint_limits"):
            if getattr(self, key) is not None:
                raise _field_error(
                    key,
                    f"robot description '{self.name}': {key} must be left out when legs are "
                    "given (each leg's joint limits are its lower / upper)",
                )
        if self.home_pose is None:
            raise _field_error(
                "home_pose",
                f"robot description '{self.name}': a robot with legs needs an explicit "
                "home_pose (a reachable pose: the workspace centre)",
            )

    def _check_chain_legs(self) -> None:
        """Six chain legs, each giving the platform six freedoms
        (:class:`~stewart_pin.exceptions.LegMobilityError`); no ``legs``, stroke or
        U-joint limits beside them; an explicit home pose."""
        object.__setattr__(self, "chain_legs", chain_legs_from_value(self.chain_legs))
        for key in ("legs", "stroke", "u_joint_limits"):
            if getattr(self, key) is not None:
                raise _field_error(
                    key,
                    f"robot description '{self.name}': {key} must be left out when "
                    "chain_legs are given (each leg's joints carry their limits)",
                )
        if self.home_pose is None:
            raise _field_error(
                "home_pose",
                f"robot description '{self.name}': a robot with chain legs needs an "
                "explicit home_pose (a reachable pose: the workspace centre)",
            )

    def _check_points(self) -> None:
        """Attachment points: legs may share a joint centre (3-3, 6-3 designs), but at most
        :data:`MAX_LEGS_PER_POINT` of them, no two legs may share both ends, and neither
        side's points may be collinear (each of these robots is singular in every pose)."""
        groups = []
        for points, which, letter in (
            (self.base_points, "base", "B"),
            (self.platform_points, "platform", "P"),
        ):
            key = f"{which}_points"
            centred = points - points.mean(axis=0)
            scale = max(np.linalg.norm(centred, axis=1).max(), np.finfo(float).tiny)
            distance = np.linalg.norm(points[:, None] - points[None], axis=-1)
            same = distance <= POINT_TOLERANCE * scale
            for a in range(6):
                shared = np.flatnonzero(same[a])
                if shared.size > MAX_LEGS_PER_POINT:
                    names = ", ".join(f"{letter}_{k + 1}" for k in shared)
                    raise _field_error(
                        key,
                        f"{shared.size} {which} attachment points ({names}) coincide at "
                        f"{points[a]}: at most {MAX_LEGS_PER_POINT} legs may share a joint "
                        "centre (the lines of more legs through one point are dependent, "
                        "so every pose would be singular)",
                    )
            sv = np.linalg.svd(centred, compute_uv=False)
            if sv[1] <= POINT_TOLERANCE * sv[0] or sv[0] == 0.0:
                raise _field_error(
                    key,
                    f"the six {which} attachment points {letter}_i are collinear: every pose "
                    "of such a robot is singular",
                )
            groups.append(same)
        both = groups[0] & groups[1]
        for a in range(6):
            for b in range(a + 1, 6):
                if both[a, b]:
                    raise _field_error(
                        "base_points",
                        f"legs {a + 1} and {b + 1} coincide: B_{a + 1} = B_{b + 1} "
                        f"({self.base_points[a]}) and P_{a + 1} = P_{b + 1} "
                        f"({self.platform_points[a]}); two legs may share one end, not both "
                        "(the robot would be singular in every pose)",
                    )

    def _check_frames(self, set_: Any) -> None:
        """Leg base rotations: kept when orthonormal to
        :data:`~stewart_pin._checks.ROTATION_TOLERANCE`, projected onto SO(3) with a
        :class:`~stewart_pin.exceptions.StewartPinWarning` up to ``max |R^T R - I| =``
        :data:`~stewart_pin._checks.ROTATION_PROJECTION_TOLERANCE`, else refused."""
        out = np.empty((6, 3, 3))
        for i, R in enumerate(self.leg_base_rotations):
            try:
                label = f"leg_base_rotations[{i}] (leg {i + 1})"
                out[i] = project_rotation(R, label, stacklevel=5)
            except InputError as e:
                raise _field_error("leg_base_rotations", str(e)) from e
        if not np.array_equal(out, self.leg_base_rotations):
            set_("leg_base_rotations", out)

    # ------------------------------------------------------------------ dict and files
    def to_dict(self) -> dict[str, Any]:
        """The description as plain Python lists (JSON/TOML-ready), with the public keys."""
        d: dict[str, Any] = {"name": self.name}
        for key in REQUIRED_KEYS:
            if getattr(self, key) is not None:
                d[key] = getattr(self, key).tolist()
        for key in ("u_joint_limits", "home_pose", *ACTUATOR_LIMIT_KEYS):
            if getattr(self, key) is not None:
                d[key] = getattr(self, key).tolist()
        if self.legs is not None:
            d["legs"] = [leg_to_dict(leg) for leg in self.legs]
        if self.chain_legs is not None:
            d.pop("leg_inertia")  # zeros: each chain leg carries its links'
            d["chain_legs"] = [chain_leg_to_dict(leg) for leg in self.chain_legs]
        if self.source is not None:
            d["source"] = self.source.to_dict()
        if self.has_gravcomp:  # left out when every body has its full weight
            d["platform_gravcomp"] = self.platform_gravcomp
            if self.chain_legs is None:  # chain legs: in each leg's table (gravcomp)
                d["leg_gravcomp"] = self.leg_gravcomp.tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RobotDescription:
        """Build from the dictionary form; raises :class:`DescriptionError` on bad keys."""
        if not isinstance(d, dict):
            raise DescriptionError(f"a robot description must be a dict, got {type(d).__name__}")
        chain = "chain_legs" in d
        required = [
            k
            for k in REQUIRED_KEYS
            if not (("legs" in d or chain) and k == "stroke")
            and not (chain and k == "leg_inertia")
        ]
        missing = [k for k in required if k not in d and INERTIAL_KEYS.get(k) not in d]
        known = REQUIRED_KEYS + OPTIONAL_KEYS + tuple(INERTIAL_KEYS.values())
        unknown = [k for k in d if k not in known]
        if missing or unknown:
            raise DescriptionError(
                f"robot description keys: missing {missing}, unknown {unknown}; expected "
                f"{list(REQUIRED_KEYS)} and optionally {list(OPTIONAL_KEYS)} (stroke is "
                "left out with legs; leg_inertial and platform_inertial may replace "
                "leg_inertia and platform_inertia)"
            )
        d = _inertia_from_tables(d)
        kwargs = {k: d[k] for k in REQUIRED_KEYS + OPTIONAL_KEYS if k in d}
        kwargs.setdefault("stroke", None)
        if chain:
            kwargs.setdefault("leg_inertia", np.zeros((6, 3, 10)))
        return cls(**kwargs)

    def replace(self, **changes: Any) -> RobotDescription:
        """A copy with some fields changed (validated again)."""
        d = {k: getattr(self, k) for k in (*REQUIRED_KEYS, *OPTIONAL_KEYS)}
        d.update(changes)
        return RobotDescription(**d)

    def write(self, path: str | Path) -> Path:
        """Write the description to ``path`` (``.toml`` or ``.json``, any case; SI units),
        atomically (a temporary file in the folder, then renamed)."""
        path = Path(path)
        d = self.to_dict()
        suffix = path.suffix.lower()
        if suffix == ".json":
            write_text_atomic(path, json.dumps(d, indent=2) + "\n")
        elif suffix == ".toml":
            legs = d.pop("legs", None)
            chain = d.pop("chain_legs", None)
            source = d.pop("source", None)
            header = FILE_HEADER if legs is None else GENERAL_FILE_HEADER
            text = (CHAIN_FILE_HEADER if chain is not None else header) + _toml(d)
            if legs is not None:
                text += LEGS_HEADER + legs_toml(legs)
            if chain is not None:
                text += CHAIN_LEGS_HEADER + legs_toml(chain, "chain_legs")
            if source is not None:
                text += source_toml(source)
            write_text_atomic(path, text)
        else:
            raise FileFormatError(f"unknown description file type '{path.suffix}' (.toml, .json)")
        return path

    @classmethod
    def read(cls, path: str | Path) -> RobotDescription:
        """Read a description written by :meth:`write` or by hand (``docs/description.md``).

        The file is UTF-8 text (a byte-order mark is allowed), ``.toml`` or ``.json`` (the
        suffix in any case).

        Raises:
            FileFormatError: the file cannot be read, is not UTF-8, is not valid TOML /
                JSON (the message gives the line), nests too deeply, repeats a key, or
                holds an invalid description (the message names the key and its line).
        """
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".toml", ".json"):
            raise FileFormatError(
                f"unknown description file type '{path.suffix}' of {path} (.toml, .json)"
            )
        try:
            data = path.read_bytes()
        except OSError as e:
            raise FileFormatError(f"cannot read robot description {path}: {e}") from e
        text = decode_utf8(data, path)
        try:
            if suffix == ".json":
                d = json.loads(text, object_pairs_hook=_no_repeated_keys)
            else:
                d = tomllib.loads(text)
        except RecursionError:
            raise FileFormatError(
                f"malformed robot description {path}: nested too deeply to read"
            ) from None
        except ValueError as e:  # JSONDecodeError, TOMLDecodeError, huge integers, keys
            raise FileFormatError(f"malformed robot description {path}: {e}") from e
        try:
            return cls.from_dict(d)
        except DescriptionError as e:
            line = _line_of_key(text, getattr(e, "key", ""), suffix)
            where = f"line {line}: " if line else ""
            raise FileFormatError(f"{path}: {where}{e}") from e

    # ------------------------------------------------------------------ derived data
    @property
    def leg_masses(self) -> np.ndarray:
        """Masses of the 18 leg links, shape (6, 3) [kg]."""
        return self.leg_inertia[:, :, 9]

    @property
    def stroke_mid(self) -> float:
        """Middle of the stroke [m] (6-UPS); for general legs, the mean distance
        ``|B_i P_i|`` at the home pose (the length scale sampling uses) [m]."""
        if self.stroke is None:
            T = self.home_pose
            P = self.platform_points @ T[:3, :3].T + T[:3, 3]
            return float(np.linalg.norm(P - self.base_points, axis=1).mean())
        return float(self.stroke.mean())

    def ideal_stroke(self, what: str) -> np.ndarray:
        """The shared stroke ``[min, max]`` [m] of the ideal 6-UPS robot, for the code of
        that architecture (its closed forms, the paper's tables; ``what`` names it):
        :class:`UnsupportedArchitectureError` for any other robot, which has no shared
        stroke (each leg carries its own joint limits, and the features take them)."""
        if self.stroke is None:
            raise UnsupportedArchitectureError(
                f"{what} belongs to the ideal 6-UPS architecture (R-R-P legs sharing one "
                f"stroke): robot '{self.name}' has {self.architecture} legs, whose joint "
                "limits are per leg",
                what,
                self.architecture,
            )
        return self.stroke

    @property
    def is_ideal_ups(self) -> bool:
        """Whether this is the paper's ideal 6-UPS robot (``legs`` is ``None``): the fast
        closed-form path, the compiled backend and the identification apply."""
        return self.legs is None and self.chain_legs is None

    @property
    def has_chain_legs(self) -> bool:
        """Whether the legs are :class:`~stewart_pin.description.chain_leg.ChainLeg`
        (``chain_legs``): the chain-leg path, no closed form, no compiled model yet."""
        return self.chain_legs is not None

    def canonical(
        self, rewrite: Callable[[RobotDescription], RobotDescription]
    ) -> RobotDescription:
        """This robot with its legs in canonical form: ``rewrite(self)`` (the rewrite of
        leg chains, :func:`stewart_pin.importers.canonical.canonical_description`), or for
        the ideal 6-UPS robot itself (its legs are the paper's MDH Table I frames: the
        canonical form, no chain to rewrite)."""
        return self if self.legs is None else rewrite(self)

    @property
    def joint_legs(self) -> tuple[Any, ...]:
        """The six legs as chains of 1-dof joints, whatever their kind: ``chain_legs``
        (:class:`~stewart_pin.description.chain_leg.ChainLeg`), else
        :attr:`leg_architectures` (three-joint ball legs, the ideal 6-UPS's included). Each
        has ``joints`` and ``actuated`` (1-based)."""
        return self.chain_legs if self.chain_legs is not None else self.leg_architectures

    @property
    def leg_architectures(self) -> tuple[LegArchitecture, ...]:
        """The six legs: ``legs``, or for the ideal 6-UPS robot :func:`ups` legs with its
        stroke and U-joint limits and no joint dynamics;
        :class:`UnsupportedArchitectureError` for chain legs (not three-joint ball legs:
        the features built on those take ``chain_legs`` or refuse the robot)."""
        if self.legs is not None:
            return self.legs
        if self.chain_legs is not None:
            raise UnsupportedArchitectureError(
                f"robot '{self.name}' has chain legs (any joints, ball or weld closures): "
                "this feature takes three-joint ball legs only; the inverse and direct "
                "models, kinematics, energy and simulation take chain legs",
                "legs",
                self.architecture,
            )
        assert self.stroke is not None
        lim = self.u_joint_limits
        return tuple(
            ups((float(self.stroke[0]), float(self.stroke[1])), None if lim is None else lim[i])
            for i in range(6)
        )

    @property
    def actuator_units(self) -> tuple[str, ...]:
        """The unit of each actuator's effort (6,), from its joint type: ``"N"`` for a
        prismatic actuated joint (6-UPS, PUS legs), ``"N m"`` for a revolute one (RUS
        cranks); joint side."""
        return tuple(leg.effort_unit for leg in self._legs_any)

    @property
    def _legs_any(self) -> tuple[LegArchitecture | ChainLeg, ...]:
        """The six legs, three-joint or chain."""
        return self.chain_legs if self.chain_legs is not None else self.leg_architectures

    @property
    def effort_unit(self) -> str:
        """The unit of the actuators' efforts for one label: ``"N"`` or ``"N m"`` when the
        six legs share it, ``"N or N m"`` for legs that mix them."""
        return _shared_unit(self.actuator_units)

    @property
    def position_unit(self) -> str:
        """The unit of the actuated joints' positions for one label: ``"m"`` or ``"rad"``
        when the six legs share it, ``"m or rad"`` for legs that mix them."""
        return _shared_unit(tuple(leg.position_unit for leg in self._legs_any))

    @property
    def actuator_position_name(self) -> str:
        """What the actuated joints' positions are called in messages: ``"leg lengths"``
        (the ideal 6-UPS), ``"actuated joint positions"`` (any other robot)."""
        return "leg lengths" if self.is_ideal_ups else "actuated joint positions"

    @property
    def position_label(self) -> str:
        """The axis label of the actuated joints' positions in figures: ``"leg length [m]"``
        (the ideal 6-UPS), ``"actuated joint [<unit>]"`` (any other robot)."""
        return "leg length [m]" if self.is_ideal_ups else f"actuated joint [{self.position_unit}]"

    @property
    def positions_title(self) -> str:
        """The title of a figure of the actuated joints' positions: ``"Leg lengths"`` (the
        ideal 6-UPS), ``"Actuator positions"`` (any other robot)."""
        return "Leg lengths" if self.is_ideal_ups else "Actuator positions"

    @property
    def limits_name(self) -> str:
        """What bounds the actuated joints, in messages: ``"stroke"`` (the ideal 6-UPS's
        shared one), ``"joint limits"`` (each leg's own)."""
        return "stroke" if self.is_ideal_ups else "joint limits"

    @property
    def legs_summary(self) -> str:
        """The legs in a few words: ``"stroke [lo hi] m"`` (the ideal 6-UPS), else
        ``"<architecture> legs"``."""
        return f"stroke {self.stroke} m" if self.is_ideal_ups else f"{self.architecture} legs"

    @property
    def architecture(self) -> str:
        """The legs' common architecture (``"ups"``, ``"ups-offset"``, ``"rus"``,
        ``"pus"``, ``"custom"``), or ``"mixed"``; ``"chain"`` for chain legs."""
        if self.chain_legs is not None:
            return "chain"
        if self.legs is None:
            return "ups"
        names = {leg.name for leg in self.legs}
        return names.pop() if len(names) == 1 else "mixed"

    @property
    def size(self) -> float:
        """A length scale of the robot: the mean base-point distance to their centroid [m]."""
        c = self.base_points - self.base_points.mean(axis=0)
        return float(np.linalg.norm(c, axis=1).mean())


def _shared_unit(units: tuple[str, ...]) -> str:
    """The unit the entries share, or the distinct ones joined by "or" (in first order)."""
    return " or ".join(dict.fromkeys(units))


def check_robot_name(name: Any) -> str:
    """``name`` if it is a valid robot name (:data:`NAME_RULE`), else
    :class:`RobotNameError` (a :class:`DescriptionError`) naming the rule."""
    if not isinstance(name, str) or not name:
        raise RobotNameError(
            f"robot name must be a non-empty string, got {name!r}; a name must have {NAME_RULE}",
            name,
        )
    if NAME_PATTERN.fullmatch(name) is None or ".." in name or "--" in name:
        shown = repr(name) if len(name) <= 80 else repr(name[:80]) + "..."
        raise RobotNameError(
            f"robot name {shown} is not allowed: a name must have {NAME_RULE} (it names "
            "files and is written into URDF, MJCF and YAML); rename the robot, e.g. "
            "'my_hexapod-2'",
            name,
        )
    return name


def _no_repeated_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object's dict, refusing a key given twice (which value would be meant?)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise FileFormatError(f"key {key!r} is given twice")
        out[key] = value
    return out


def _inertia_from_tables(d: dict[str, Any]) -> dict[str, Any]:
    """``d`` with its URDF-style inertial tables (:data:`INERTIAL_KEYS`) converted to
    Khalil's parameters; both forms of one key at once are refused."""
    out = dict(d)
    for key, alt in INERTIAL_KEYS.items():
        if alt not in out:
            continue
        if key in out:
            raise _field_error(
                alt,
                f"give {key} (Khalil's ten parameters, in the MDH frame about its origin) or "
                f"{alt} (URDF style: mass, centre of mass, inertia about it), not both",
            )
        value = out.pop(alt)
        try:
            if alt == "platform_inertial":
                out[key] = khalil_from_inertial_table(value, "platform")
                continue
            if (
                isinstance(value, list)
                and len(value) == 3
                and all(isinstance(t, dict) for t in value)
            ):
                value = [value] * 6  # the same three links on every leg
            if not (
                isinstance(value, list)
                and len(value) == 6
                and all(isinstance(leg, list) and len(leg) == 3 for leg in value)
            ):
                raise _field_error(
                    alt,
                    f"{alt} must be three inertial tables (links 1, 2, 3 of every leg) or six "
                    "lists of three (one per leg)",
                )
            out[key] = [
                [
                    khalil_from_inertial_table(table, f"leg {i + 1} link {j + 1}")
                    for j, table in enumerate(leg)
                ]
                for i, leg in enumerate(value)
            ]
        except InertiaError as e:
            e.key = alt  # type: ignore[attr-defined] # read() quotes the line of the key
            raise
    return out


def _actuator_limits(value: Any, key: str) -> np.ndarray:
    """One of :data:`ACTUATOR_LIMIT_KEYS`: a positive finite number, or six, as (6,)."""
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        value = [float(value)] * 6
    limits = check_array(value, (6,), key)
    if np.any(limits <= 0):
        raise InputError(
            f"{key} must be positive (one number for every actuator, or six), got "
            f"{limits.tolist()}; leave the key out for unbounded actuators"
        )
    return limits


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _gravcomp_error(body: str, message: str, value: Any) -> GravityCompensationError:
    """A :class:`GravityCompensationError` about ``body`` (``read`` quotes the line of
    its key)."""
    error = GravityCompensationError(message, body, value)
    error.key = "platform_gravcomp" if body == "platform" else "leg_gravcomp"  # type: ignore[attr-defined]
    return error


def _gravcomp_factor(value: Any, body: str) -> float:
    """A body's gravity compensation: a finite number in [0, 1] (the fraction of its
    weight removed), else :class:`GravityCompensationError` naming the body
    (:func:`~stewart_pin.description.chain_leg.gravcomp_factor`; ``read`` quotes the line
    of its key)."""
    try:
        return gravcomp_factor(value, body)
    except GravityCompensationError as e:
        raise _gravcomp_error(body, str(e), value) from None


def _field_error(key: str, message: str) -> DescriptionError:
    """A :class:`DescriptionError` about description key ``key`` (``read`` quotes its line)."""
    error = DescriptionError(message)
    error.key = key  # type: ignore[attr-defined]
    return error


def _line_of_key(text: str, key: str, suffix: str) -> int | None:
    """The line (1-based) where ``key`` is set in a TOML / JSON description, if found."""
    if not key:
        return None
    k = re.escape(key)
    pattern = (
        rf'"{k}"\s*:'
        if suffix == ".json"
        else rf'^[ \t]*(?:(?:{k}|"{k}"|\'{k}\')[ \t]*=|\[\[?[ \t]*{k}[ \t]*\]\]?)'
    )
    match = re.search(pattern, text, flags=re.MULTILINE)
    return text.count("\n", 0, match.start()) + 1 if match else None


FILE_HEADER = """\
# stewart-pin robot description (SI units: m, kg, kg m^2, m/s^2).
# base_points: B_i in F0 (6 x 3). platform_points: P_i in Fp (6 x 3).
# leg_base_rotations: orientation in F0 of leg frame 1i at q1i = 0 (6 x 3 x 3),
#   its z column the first U-joint axis.
# stroke: [min, max] leg length |B_i P_i|.
# leg_inertia: 6 legs x 3 links x 10 standard parameters, Khalil's order
#   XX XY XZ YY YZ ZZ MX MY MZ M, in each link's MDH frame about its origin.
# platform_inertia: the same 10 parameters of the platform, in Fp about its origin.
# gravity: in F0. Optional: u_joint_limits [[q1min, q1max], [q2min, q2max]] (rad),
#   home_pose: 0Tp (4 x 4), the workspace centre.
"""

#: The header of a robot with general legs: no stroke, no U-joint limits (the joint limits
#: live in the legs), a required home pose.
GENERAL_FILE_HEADER = """\
# stewart-pin robot description, general legs (SI units: m, kg, kg m^2, m/s^2; rad).
# base_points: B_i, origin of leg frame 0i, in F0 (6 x 3). platform_points: P_i in Fp
#   (6 x 3). leg_base_rotations: orientation in F0 of leg frame 0i (6 x 3 x 3), from which
#   joint 1's MDH transform starts.
# leg_inertia: 6 legs x 3 links x 10 standard parameters, Khalil's order
#   XX XY XZ YY YZ ZZ MX MY MZ M, in each link's MDH frame about its origin.
# platform_inertia: the same 10 parameters of the platform, in Fp about its origin.
# gravity: in F0. home_pose (required): 0Tp (4 x 4), a reachable pose, the workspace
#   centre. No stroke nor u_joint_limits: each joint's limits are in [[legs.joints]].
"""

#: The header of a robot with chain legs (no stroke, no leg_inertia: in the legs).
CHAIN_FILE_HEADER = """\
# stewart-pin robot description, chain legs (SI units: m, kg, kg m^2, m/s^2; rad).
# base_points: B_i, origin of leg frame 0i, in F0 (6 x 3). platform_points: P_i in Fp
#   (6 x 3), the ball centre or the weld's platform frame origin. leg_base_rotations:
#   orientation in F0 of leg frame 0i (6 x 3 x 3), from which joint 1's MDH transform starts.
# platform_inertia: Khalil's XX XY XZ YY YZ ZZ MX MY MZ M of the platform, in Fp about its
#   origin. gravity: in F0. home_pose (required): 0Tp (4 x 4), a reachable pose.
"""

#: What precedes the ``[[chain_legs]]`` tables.
CHAIN_LEGS_HEADER = """
# chain_legs: six chain leg tables (docs/legs.md, "Chain legs and welds"). Per leg:
#   actuated (1..n), closure ("ball" or "weld"), tip (in the last link's frame), inertia
#   (n x 10, each link in its MDH frame), optional tip_rotation, platform_rotation (weld),
#   guess, idle_joint, and n [[chain_legs.joints]] as [[legs.joints]].
"""

LEGS_HEADER = """
# legs: six leg tables (general three-joint legs; docs/description.md). Per leg:
#   architecture, actuated (1..3), tip (P_i in frame 3i), branch (+1 / -1), guess, and
#   three [[legs.joints]]: kind, MDH alpha d theta r, lower upper (omitted: none), and the
#   joint dynamics armature viscous coulomb stiffness rest_position damping rotor_inertia
#   (omitted: 0), gear_ratio or screw_lead (omitted: none).
"""


def _toml(d: dict[str, Any]) -> str:
    """TOML for the description's flat dict of strings and nested lists of floats, one
    innermost row per line (``tomllib`` reads it back exactly: floats as ``repr``)."""

    def value(x: Any, indent: int) -> str:
        if isinstance(x, str):
            return json.dumps(x)  # a JSON string is a valid TOML basic string
        if isinstance(x, float):
            return repr(x)
        if not isinstance(x[0], list):
            return "[" + ", ".join(repr(float(v)) for v in x) + "]"
        pad = " " * (indent + 4)
        rows = ",\n".join(pad + value(v, indent + 4) for v in x)
        return "[\n" + rows + ",\n" + " " * indent + "]"

    return "".join(f"{key} = {value(x, 0)}\n" for key, x in d.items())


def _upright_home_pose(desc: RobotDescription) -> np.ndarray:
    """The default home pose: Fp parallel to F0, O_p above the centroids, mean leg length at
    mid-stroke (found by bisection on the height along the base z axis)."""
    assert desc.stroke is not None  # only the ideal 6-UPS robot has a default home pose
    B, P = desc.base_points, desc.platform_points
    T = np.eye(4)
    T[:2, 3] = B.mean(axis=0)[:2] - P.mean(axis=0)[:2]
    z_lo = B[:, 2].mean() - P[:, 2].mean()
    z_hi = z_lo + 2.0 * desc.stroke[1] + np.linalg.norm(B - B.mean(0), axis=1).max()

    def mean_length(z: float) -> float:
        origin = np.array([T[0, 3], T[1, 3], z])
        return float(np.linalg.norm(origin + P - B, axis=1).mean())

    target = desc.stroke.mean()
    if mean_length(z_lo) > target:
        raise DescriptionError(
            "cannot place a default home pose: the legs are longer than mid-stroke even with "
            "the platform in the base plane; give home_pose explicitly"
        )
    for _ in range(200):
        z = 0.5 * (z_lo + z_hi)
        z_lo, z_hi = (z, z_hi) if mean_length(z) < target else (z_lo, z)
    T[2, 3] = 0.5 * (z_lo + z_hi)
    return T


def leg_base_rotation_from_axis(axis: Any, leg_direction: Any) -> np.ndarray:
    """Orientation of leg frame 1i at q1i = 0 from the first U-joint axis.

    ``z1 = axis``, ``x1`` is ``leg_direction`` made orthogonal to the axis, so that a leg
    along ``leg_direction`` sits at ``q1i = 0``, ``q2i = pi/2`` when the axis is
    perpendicular to it.

    Args:
        axis: shape (3,), first revolute axis in F0 (any length > 0).
        leg_direction: shape (3,), typically the leg's direction B_i -> P_i at home, in F0.
    """
    z = check_array(axis, (3,), "axis")
    x = check_array(leg_direction, (3,), "leg_direction")
    if np.linalg.norm(z) == 0:
        raise InputError("the U-joint axis must be non-zero")
    z = z / np.linalg.norm(z)
    x = x - (x @ z) * z
    if np.linalg.norm(x) < 1e-9 * max(1.0, float(np.linalg.norm(leg_direction))):
        raise InputError("leg_direction is parallel to the U-joint axis: that leg is singular")
    x = x / np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def leg_frame_from_mdh(
    gamma: float, b: float, alpha: float, d: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(B_i in F0, rotation of frame 1i at q1i = 0 in F0)`` from the paper's MDH parameters.

    Khalil-Kleinfinger: ``0T1i = Rz(gamma) Tz(b) Rx(alpha) Tx(d) Rz(q1i)``, with q1i = 0.
    Angles [rad], lengths [m].
    """
    cg, sg, ca, sa = np.cos(gamma), np.sin(gamma), np.cos(alpha), np.sin(alpha)
    Rz = np.array([[cg, -sg, 0.0], [sg, cg, 0.0], [0.0, 0.0, 1.0]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    R = Rz @ Rx
    B = np.array([0.0, 0.0, b]) + R @ np.array([d, 0.0, 0.0])
    return B, R
