"""Where an imported robot came from: :class:`ModelSource`, the optional ``source`` of a
:class:`~stewart_pin.description.robot_description.RobotDescription`.

An importer (:mod:`stewart_pin.importers`) records the file's format and, with the names
the file gives them, the base and platform bodies, the bodies lumped into others, and for
each leg (in leg order) the bodies of its three links, its three joints, its actuator
and the spherical joint that closes it. The names are data only: they are never used to
build code, markup or paths, and they are written to TOML with every character a TOML
basic string cannot hold escaped (:func:`toml_string`).

A joint that is not a joint of the file (the universal joint that replaces the first
spherical joint of an R-S-S, P-S-S or S-P-S rod) is named after the file's joint with a
suffix, e.g. ``"ball3 (U axis 1)"``; a link without a body of its own (the cross of
such a universal joint, the massless bodies of three hinges) has the name ``""``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._safe import toml_quoted as toml_string
from stewart_pin.exceptions import DescriptionError

#: The longest name kept [characters]; longer names are refused (a file could hold
#: anything: a name that long is not a name).
MAX_NAME_LENGTH = 1000


def _names(value: Any, what: str, count: int | None = None) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise DescriptionError(f"model source: {what} must be a list of strings, got {value!r}")
    out = tuple(value)
    if count is not None and len(out) != count:
        raise DescriptionError(f"model source: {what} must list {count} names, got {len(out)}")
    for name in out:
        _name(name, what)
    return out


def _name(value: Any, what: str) -> str:
    if not isinstance(value, str):
        raise DescriptionError(f"model source: {what} must be a string, got {value!r}")
    if len(value) > MAX_NAME_LENGTH:
        raise DescriptionError(
            f"model source: a name in {what} has {len(value)} characters (at most "
            f"{MAX_NAME_LENGTH})"
        )
    return value


@dataclass(frozen=True)
class LegSource:
    """Where one leg came from (names as in the file).

    Attributes:
        bodies: the file bodies of links 1, 2, 3 (``""``: a link with no body of its own).
        joints: the file joints of joints 1, 2, 3 (see the module docstring for joints
            that replace a spherical joint).
        actuator: the actuator (MJCF ``<actuator>``, URDF ``<transmission>`` or the name
            of the actuated joint when given by argument).
        spherical: how the leg's spherical joint is written, e.g. ``"ball joint 'b3'"``,
            ``"connect 'loop3'"``, ``"hinges 'h1', 'h2', 'h3'"``.
        signs, offsets: the file's joint convention (``docs/importing.md``): joint j's
            value in the description is ``signs[j] q_file + offsets[j]`` [rad or m]
            (``signs`` +1 or -1: the file's axis along or against the description's;
            ``offsets``: the description's value at the file's zero). Default: the
            file's own values (1, 0).
        wraps: a revolute joint's file value is given in ``[wraps[j], wraps[j] + 2 pi)``
            [rad] (from the lower end of the file's full-turn range, else from -pi);
            unused for prismatic joints.
    """

    bodies: tuple[str, ...]
    joints: tuple[str, ...]
    actuator: str
    spherical: str
    signs: tuple[float, ...] = (1.0, 1.0, 1.0)
    offsets: tuple[float, ...] = (0.0, 0.0, 0.0)
    wraps: tuple[float, ...] = (-math.pi, -math.pi, -math.pi)

    def __post_init__(self) -> None:
        object.__setattr__(self, "bodies", _names(self.bodies, "leg bodies", 3))
        object.__setattr__(self, "joints", _names(self.joints, "leg joints", 3))
        _name(self.actuator, "leg actuator")
        _name(self.spherical, "leg spherical joint")
        for key in ("signs", "offsets", "wraps"):
            value = getattr(self, key)
            if isinstance(value, (str, dict)) or not isinstance(value, Sequence):
                raise DescriptionError(f"model source: leg {key} must list three numbers")
            ok = len(value) == 3 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value
            )
            if not ok or (key == "signs" and any(v not in (1, -1) for v in value)):
                what = "+1 or -1" if key == "signs" else "finite numbers"
                raise DescriptionError(
                    f"model source: leg {key} must list three {what}, got {list(value)!r}"
                )
            object.__setattr__(self, key, tuple(float(v) for v in value))

    @property
    def identity(self) -> bool:
        """The description's joint values are the file's (no sign, no offset)."""
        return self.signs == (1.0, 1.0, 1.0) and self.offsets == (0.0, 0.0, 0.0)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "bodies": list(self.bodies),
            "joints": list(self.joints),
            "actuator": self.actuator,
            "spherical": self.spherical,
        }
        if not self.identity or self.wraps != (-math.pi,) * 3:
            out.update(signs=list(self.signs), offsets=list(self.offsets), wraps=list(self.wraps))
        return out


#: Keys of the ``source`` table.
SOURCE_KEYS = ("format", "file", "model", "reference", "base", "platform", "lumped", "legs")
#: Keys of a ``[[source.legs]]`` table.
LEG_SOURCE_KEYS = ("bodies", "joints", "actuator", "spherical")
#: Optional keys of a ``[[source.legs]]`` table (the file's joint convention).
LEG_SOURCE_OPTIONAL = ("signs", "offsets", "wraps")


@dataclass(frozen=True)
class ModelSource:
    """Where an imported robot came from (names as in the file).

    Attributes:
        format: ``"mjcf"`` or ``"urdf"``.
        file: the file's name (no folder), ``""`` for a model given as text or object.
        model: the model's own name (MJCF ``model``, URDF ``robot name``).
        reference: the configuration read as the robot's assembled state, e.g.
            ``"keyframe 'home'"``, ``"qpos0"``, ``"zero configuration"``.
        base: the base body (``"world"``, or the URDF root link).
        platform: the platform body: Fp is its frame.
        lumped: the bodies lumped into the platform, a leg link or the base.
        legs: six :class:`LegSource`, in leg order.
    """

    format: str
    file: str
    model: str
    reference: str
    base: str
    platform: str
    lumped: tuple[str, ...]
    legs: tuple[LegSource, ...]

    def __post_init__(self) -> None:
        for key in ("format", "file", "model", "reference", "base", "platform"):
            _name(getattr(self, key), key)
        object.__setattr__(self, "lumped", _names(self.lumped, "lumped"))
        legs = self.legs
        if isinstance(legs, (str, dict)) or not isinstance(legs, Sequence) or len(legs) != 6:
            raise DescriptionError("model source: legs must list six leg sources")
        object.__setattr__(
            self,
            "legs",
            tuple(
                leg if isinstance(leg, LegSource) else leg_source_from_dict(leg) for leg in legs
            ),
        )

    def file_joint_values(self, q: Any, revolute: Any = None) -> np.ndarray:
        """Joint values (..., 6, 3) of the description [rad or m] in the file's own
        convention (:class:`LegSource` ``signs``, ``offsets``); ``revolute`` (6, 3) bool:
        those joints' values taken into ``[wraps, wraps + 2 pi)``."""
        q = np.asarray(q, dtype=float)
        s = np.array([leg.signs for leg in self.legs])
        o = np.array([leg.offsets for leg in self.legs])
        out = s * (q - o)
        if revolute is not None:
            w = np.array([leg.wraps for leg in self.legs])
            out = np.where(revolute, w + np.mod(out - w, 2.0 * math.pi), out)
        return out

    def file_efforts(self, gamma: Any, actuated: Any) -> np.ndarray:
        """Actuated joints' efforts (..., 6) [N or N m] of the description along the
        file's joint directions; ``actuated`` (6,): each leg's actuated joint (1..3)."""
        s = np.array([leg.signs[int(a) - 1] for leg, a in zip(self.legs, actuated, strict=True)])
        return s * np.asarray(gamma, dtype=float)

    def file_actuator_positions(self, positions: Any, actuated: Any, revolute: Any) -> np.ndarray:
        """Actuated joint values (..., 6) of the description in the file's convention;
        ``actuated`` (6,) 1..3, ``revolute`` (6,) bool."""
        pos = np.asarray(positions, dtype=float)
        idx = [int(a) - 1 for a in actuated]
        s = np.array([leg.signs[j] for leg, j in zip(self.legs, idx, strict=True)])
        o = np.array([leg.offsets[j] for leg, j in zip(self.legs, idx, strict=True)])
        w = np.array([leg.wraps[j] for leg, j in zip(self.legs, idx, strict=True)])
        out = s * (pos - o)
        return np.where(revolute, w + np.mod(out - w, 2.0 * math.pi), out)

    def description_actuator_positions(self, positions: Any, actuated: Any) -> np.ndarray:
        """The inverse of :meth:`file_actuator_positions` (file values -> description's,
        e.g. for ``forward_geometry``)."""
        pos = np.asarray(positions, dtype=float)
        idx = [int(a) - 1 for a in actuated]
        s = np.array([leg.signs[j] for leg, j in zip(self.legs, idx, strict=True)])
        o = np.array([leg.offsets[j] for leg, j in zip(self.legs, idx, strict=True)])
        return s * pos + o

    def to_dict(self) -> dict[str, Any]:
        """Plain values (JSON / TOML-ready)."""
        return {
            "format": self.format,
            "file": self.file,
            "model": self.model,
            "reference": self.reference,
            "base": self.base,
            "platform": self.platform,
            "lumped": list(self.lumped),
            "legs": [leg.to_dict() for leg in self.legs],
        }

    @classmethod
    def from_value(cls, value: Any) -> ModelSource:
        """A :class:`ModelSource` from itself or from its :meth:`to_dict` form."""
        if isinstance(value, ModelSource):
            return value
        return cls(**_table(value, SOURCE_KEYS, "model source"))


def leg_source_from_dict(value: Any) -> LegSource:
    return LegSource(**_table(value, LEG_SOURCE_KEYS, "model source leg", LEG_SOURCE_OPTIONAL))


def _table(
    value: Any, keys: tuple[str, ...], what: str, optional: tuple[str, ...] = ()
) -> dict[str, Any]:
    """``value``'s entries of ``keys`` (all) and ``optional`` (those given), no other
    (else :class:`DescriptionError`)."""
    if not isinstance(value, dict):
        raise DescriptionError(
            f"{what} must be a table ({', '.join(keys)}), got {type(value).__name__}"
        )
    missing = [k for k in keys if k not in value]
    unknown = [k for k in value if k not in keys + optional]
    if missing or unknown:
        raise DescriptionError(
            f"{what} keys: missing {missing}, unknown {unknown}; expected {list(keys)}"
            + (f" and optionally {list(optional)}" if optional else "")
        )
    return {k: value[k] for k in keys + optional if k in value}


def source_toml(source: dict[str, Any]) -> str:
    """The ``[source]`` table and its ``[[source.legs]]`` of :meth:`ModelSource.to_dict`."""

    def value(x: Any) -> str:
        if isinstance(x, str):
            return toml_string(x)
        if isinstance(x, float):
            return repr(x)  # finite (LegSource)
        return "[" + ", ".join(value(v) for v in x) + "]"

    out = ["\n# where the robot was imported from (names as in the file: data only)\n[source]\n"]
    out.extend(f"{k} = {value(v)}\n" for k, v in source.items() if k != "legs")
    for leg in source["legs"]:
        out.append("[[source.legs]]\n")
        out.extend(f"{k} = {value(v)}\n" for k, v in leg.items())
    return "".join(out)


__all__ = [
    "LEG_SOURCE_KEYS",
    "LEG_SOURCE_OPTIONAL",
    "MAX_NAME_LENGTH",
    "SOURCE_KEYS",
    "LegSource",
    "ModelSource",
    "leg_source_from_dict",
    "source_toml",
    "toml_string",
]
