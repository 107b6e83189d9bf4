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

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

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
    """

    bodies: tuple[str, ...]
    joints: tuple[str, ...]
    actuator: str
    spherical: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "bodies", _names(self.bodies, "leg bodies", 3))
        object.__setattr__(self, "joints", _names(self.joints, "leg joints", 3))
        _name(self.actuator, "leg actuator")
        _name(self.spherical, "leg spherical joint")

    def to_dict(self) -> dict[str, Any]:
        return {
            "bodies": list(self.bodies),
            "joints": list(self.joints),
            "actuator": self.actuator,
            "spherical": self.spherical,
        }


#: Keys of the ``source`` table.
SOURCE_KEYS = ("format", "file", "model", "reference", "base", "platform", "lumped", "legs")
#: Keys of a ``[[source.legs]]`` table.
LEG_SOURCE_KEYS = ("bodies", "joints", "actuator", "spherical")


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
    return LegSource(**_table(value, LEG_SOURCE_KEYS, "model source leg"))


def _table(value: Any, keys: tuple[str, ...], what: str) -> dict[str, Any]:
    """``value``'s entries of ``keys``, exactly those (else :class:`DescriptionError`)."""
    if not isinstance(value, dict):
        raise DescriptionError(
            f"{what} must be a table ({', '.join(keys)}), got {type(value).__name__}"
        )
    missing = [k for k in keys if k not in value]
    unknown = [k for k in value if k not in keys]
    if missing or unknown:
        raise DescriptionError(
            f"{what} keys: missing {missing}, unknown {unknown}; expected {list(keys)}"
        )
    return {k: value[k] for k in keys}


def source_toml(source: dict[str, Any]) -> str:
    """The ``[source]`` table and its ``[[source.legs]]`` of :meth:`ModelSource.to_dict`."""

    def value(x: Any) -> str:
        if isinstance(x, str):
            return toml_string(x)
        return "[" + ", ".join(value(v) for v in x) + "]"

    out = ["\n# where the robot was imported from (names as in the file: data only)\n[source]\n"]
    out.extend(f"{k} = {value(v)}\n" for k, v in source.items() if k != "legs")
    for leg in source["legs"]:
        out.append("[[source.legs]]\n")
        out.extend(f"{k} = {value(v)}\n" for k, v in leg.items())
    return "".join(out)


__all__ = [
    "LEG_SOURCE_KEYS",
    "MAX_NAME_LENGTH",
    "SOURCE_KEYS",
    "LegSource",
    "ModelSource",
    "leg_source_from_dict",
    "source_toml",
    "toml_string",
]
