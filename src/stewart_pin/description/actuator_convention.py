"""The actuators' convention at a robot's boundary: :class:`ActuatorConvention`.

A robot imported from a model file speaks that file's joint convention for its six
actuators (``docs/conventions.md``, "Actuator convention"): an actuator position is the
file's joint value (its zero and direction), an effort acts along the file's joint axis.
The description holds the named architecture's own convention (the closed forms'), and
its ``source`` (:class:`~stewart_pin.description.model_source.ModelSource`) the mapping:
for actuator i, with ``s_i`` = +1 or -1 and ``o_i`` the description's value at the
file's zero,

- position: ``q_file = s_i (q_description - o_i)`` (a revolute joint's taken into
  ``[wrap_i, wrap_i + 2 pi)``), and back ``q_description = s_i q_file + o_i``;
- rate, acceleration, effort: ``x_file = s_i x_description`` (the power
  ``Gamma . qdot`` is the same in both; the motor side, ``Gamma / ratio`` with a ratio
  > 0, takes the same sign).

This one object converts every actuator quantity of
:class:`~stewart_pin.robot.StewartRobot` (positions, limits, rates, Jacobians' rows,
efforts in and out, regressor rows, derivatives), at the facade's boundary where the
motor side is applied; a description without a source, or a source that keeps the
file's values (signs +1, offsets 0, no wrap), is the identity and converts nothing, as
does a robot whose legs are not three-joint legs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin.description.robot_description import RobotDescription
from stewart_pin.exceptions import InputError, StewartPinError

#: The conventions a robot can speak: its source file's, or its description's.
CONVENTIONS = ("file", "description")


@dataclass(frozen=True, eq=False)
class ActuatorConvention:
    """The mapping between the description's actuator values and the robot's (module
    docstring).

    Attributes:
        name: ``"file"`` (the source file's joint convention) or ``"description"``.
        signs: (6,) +1 or -1: actuator i's file axis along (+1) or against the
            description's.
        offsets: (6,) the description's value at the file's zero [m or rad].
        wraps: (6,) a revolute actuator's file value is given in ``[wrap, wrap + 2 pi)``
            [rad] (unused for a prismatic one).
        revolute: (6,) bool, the revolute actuators.
        file: the source file's name (``""`` without one).
    """

    name: str
    signs: np.ndarray
    offsets: np.ndarray
    wraps: np.ndarray
    revolute: np.ndarray
    file: str = ""

    @classmethod
    def of(cls, description: RobotDescription, convention: str = "file") -> ActuatorConvention:
        """The convention of a robot built from ``description``: ``"file"`` (the source's
        mapping; the identity without a source) or ``"description"`` (the identity)."""
        if convention not in CONVENTIONS:
            raise InputError(
                f"convention must be one of {CONVENTIONS}, got {convention!r}: 'file' reports "
                "actuator positions and efforts in the imported file's joint convention, "
                "'description' in the named architecture's"
            )
        signs, offsets, wraps = np.ones(6), np.zeros(6), np.full(6, -math.pi)
        try:
            legs = description.leg_architectures
        except StewartPinError:  # legs that are not three-joint legs: their own values
            return cls(convention, signs, offsets, wraps, np.zeros(6, dtype=bool))
        index = [leg.actuated - 1 for leg in legs]
        revolute = np.array([leg.joints[j].revolute for leg, j in zip(legs, index, strict=True)])
        source = description.source
        if convention == "file" and source is not None:
            for i, (leg, j) in enumerate(zip(source.legs, index, strict=True)):
                signs[i], offsets[i], wraps[i] = leg.signs[j], leg.offsets[j], leg.wraps[j]
        file = source.file if source is not None and convention == "file" else ""
        return cls(convention, signs, offsets, wraps, revolute, file)

    def __post_init__(self) -> None:
        for key in ("signs", "offsets", "wraps", "revolute"):
            value = np.array(getattr(self, key))
            value.setflags(write=False)
            object.__setattr__(self, key, value)

    @property
    def identity(self) -> bool:
        """The robot's actuator values are the description's (no sign, offset or wrap)."""
        return bool(
            np.all(self.signs == 1.0)
            and np.all(self.offsets == 0.0)
            and np.all(self.wraps[self.revolute] == -math.pi)
        )

    # ------------------------------------------------------------------ positions
    def positions_from_description(self, q: Any) -> np.ndarray:
        """Actuator positions (..., 6) of the description -> the robot's [m or rad]."""
        out = self.signs * (np.asarray(q, dtype=float) - self.offsets)
        if not np.any(self.revolute):
            return out
        w = self.wraps
        return np.where(self.revolute, w + np.mod(out - w, 2.0 * math.pi), out)

    def positions_to_description(self, q: Any) -> np.ndarray:
        """Actuator positions (..., 6) of the robot -> the description's [m or rad]."""
        return self.signs * np.asarray(q, dtype=float) + self.offsets

    def limits_from_description(self, limits: Any) -> np.ndarray:
        """Actuator limits (6, 2) ``[lower, upper]`` of the description -> the robot's
        (a flipped axis swaps the ends; not wrapped) [m or rad]."""
        lim = np.asarray(limits, dtype=float)
        ends = self.signs[:, None] * (lim - self.offsets[:, None])
        return np.sort(ends, axis=1)

    # ------------------------------------------------------------------ rates and efforts
    def rates_from_description(self, qdot: Any) -> np.ndarray:
        """Actuator rates or accelerations (..., 6) of the description -> the robot's
        [m/s or rad/s, m/s^2 or rad/s^2] (and back: the same map)."""
        return self.signs * np.asarray(qdot, dtype=float)

    def efforts_from_description(self, gamma: Any) -> np.ndarray:
        """Efforts (..., 6) of the description -> the robot's [N or N m]."""
        return self.signs * np.asarray(gamma, dtype=float)

    def efforts_to_description(self, gamma: Any) -> np.ndarray:
        """Efforts (..., 6) of the robot (joint side) -> the description's [N or N m]."""
        return self.signs * np.asarray(gamma, dtype=float)

    def rows(self, matrix: Any) -> np.ndarray:
        """``matrix`` (..., 6, n) with row i multiplied by ``signs[i]``: a map to
        actuator values (``Jp^-1``, the regressor, the IDM's Jacobians) in the robot's
        convention from the description's."""
        return self.signs[:, None] * np.asarray(matrix, dtype=float)

    def columns(self, matrix: Any) -> np.ndarray:
        """``matrix`` (..., n, 6) with column i multiplied by ``signs[i]``: a map from
        actuator values (``Jp``, ``dVdot/dGamma``) in the robot's convention."""
        return np.asarray(matrix, dtype=float) * self.signs

    # ------------------------------------------------------------------ the accessor
    def to_dict(self) -> dict[str, Any]:
        """Plain values: ``convention``, ``file`` and per actuator ``signs``, ``offsets``
        [m or rad], ``wraps`` [rad] (revolute actuators), ``revolute``."""
        return {
            "convention": self.name,
            "file": self.file,
            "signs": self.signs.tolist(),
            "offsets": self.offsets.tolist(),
            "wraps": [
                float(w) if r else None for w, r in zip(self.wraps, self.revolute, strict=True)
            ],
            "revolute": self.revolute.tolist(),
        }

    def __str__(self) -> str:
        if self.identity:
            return "actuator convention: the description's joint values (no file mapping)"
        lines = [f"actuator convention: {self.name}'s; q_robot = s (q_description - o)"]
        for i in range(6):
            unit = "rad" if self.revolute[i] else "m"
            wrap = (
                f", in [{self.wraps[i]:.6g}, {self.wraps[i] + 2 * math.pi:.6g}) rad"
                if self.revolute[i]
                else ""
            )
            lines.append(
                f"  actuator {i + 1}: s = {self.signs[i]:+.0f}, o = {self.offsets[i]:.9g} {unit}"
                + wrap
            )
        return "\n".join(lines)


def actuator_convention_of(robot: Any) -> ActuatorConvention:
    """The convention ``robot`` speaks (``robot.actuator_convention``; a robot-like
    object without one speaks its description's)."""
    convention = getattr(robot, "actuator_convention", None)
    if isinstance(convention, ActuatorConvention):
        return convention
    return ActuatorConvention.of(robot.description, "description")


__all__ = ["CONVENTIONS", "ActuatorConvention", "actuator_convention_of"]
