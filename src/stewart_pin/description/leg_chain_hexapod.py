"""A Gough-Stewart robot with general three-joint legs: :class:`GeneralHexapod`.

The robot places each leg's frame 0i (``B_i`` and ``R_i`` in F0, today's 6-UPS
convention ``0T1i = [R_i, B_i] Rz(q1i)`` for the ``ups`` legs), holds the six
:class:`~stewart_pin.description.leg_architecture.LegArchitecture`, the 18 + 1 bodies'
inertial parameters (Khalil's order, each link in its own MDH frame), gravity and a
reachable home pose. :func:`general_from_description` turns any
:class:`~stewart_pin.description.robot_description.RobotDescription` into the same robot
(the resolved view the general-leg kinematics and dynamics read), and
:meth:`GeneralHexapod.to_description` goes back.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, project_rotation
from stewart_pin.description.inertia import check_physical, check_physical_bodies, leg_link_name
from stewart_pin.description.leg_architecture import LegArchitecture
from stewart_pin.description.robot_description import RobotDescription
from stewart_pin.exceptions import (
    ArchitectureError,
    DescriptionError,
    GravityCompensationError,
    InputError,
)


@dataclass(frozen=True, eq=False)
class GeneralHexapod:
    """A Gough-Stewart robot with general three-joint legs.

    Attributes:
        base_points: (6, 3) B_i, origin of leg frame 0i in F0 [m].
        leg_base_rotations: (6, 3, 3) orientation of frame 0i in F0.
        platform_points: (6, 3) P_i in Fp [m].
        legs: six :class:`LegArchitecture`.
        leg_inertia: (6, 3, 10) Khalil's parameters of link j of leg i in frame ji.
        platform_inertia: (10,) the platform's, in Fp about O_p.
        gravity: (3,) in F0 [m/s^2].
        home_pose: (4, 4) 0Tp, a reachable pose (forward geometry's default guess).
        name: the robot's name.
        leg_gravcomp: (6, 3) the fraction of each link's weight removed (per-body gravity
            compensation, in [0, 1]: that link's weight is ``(1 - c) m g``).
        platform_gravcomp: the same for the platform.
    """

    base_points: np.ndarray
    leg_base_rotations: np.ndarray
    platform_points: np.ndarray
    legs: tuple[LegArchitecture, ...]
    leg_inertia: np.ndarray
    platform_inertia: np.ndarray
    gravity: np.ndarray
    home_pose: np.ndarray
    name: str = "general"
    leg_gravcomp: np.ndarray = field(default_factory=lambda: np.zeros((6, 3)))
    platform_gravcomp: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "platform_gravcomp", float(self.platform_gravcomp))
        shapes = {
            "base_points": (6, 3),
            "leg_base_rotations": (6, 3, 3),
            "platform_points": (6, 3),
            "leg_inertia": (6, 3, 10),
            "platform_inertia": (10,),
            "gravity": (3,),
            "home_pose": (4, 4),
            "leg_gravcomp": (6, 3),
        }
        for key, shape in shapes.items():
            try:
                value = check_array(getattr(self, key), shape, key)
            except InputError as e:
                raise DescriptionError(f"general hexapod '{self.name}': {e}") from e
            if key == "leg_base_rotations":
                value = np.array(
                    [project_rotation(R, f"leg_base_rotations[{i}]") for i, R in enumerate(value)]
                )
            if key == "home_pose":
                value = value.copy()
                value[:3, :3] = project_rotation(value[:3, :3], "home_pose rotation block")
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        legs = tuple(self.legs) if isinstance(self.legs, Sequence) else ()
        if len(legs) != 6 or not all(isinstance(leg, LegArchitecture) for leg in legs):
            raise ArchitectureError(
                "a general hexapod needs six LegArchitecture legs", "legs", self.legs
            )
        object.__setattr__(self, "legs", legs)
        check_physical_bodies(self.leg_inertia, leg_link_name)
        check_physical(self.platform_inertia, "platform")
        for body, c in [
            ("platform", self.platform_gravcomp),
            *(
                (f"leg {i + 1} link {j + 1}", self.leg_gravcomp[i, j])
                for i in range(6)
                for j in range(3)
            ),
        ]:
            if not 0.0 <= c <= 1.0:  # NaN too
                raise GravityCompensationError(
                    f"general hexapod '{self.name}': gravity compensation of the {body} must be "
                    f"in [0, 1] (the fraction of its weight removed), got {c!r}",
                    body,
                    c,
                )

    # ------------------------------------------------------------------ derived data
    @property
    def has_gravcomp(self) -> bool:
        """Whether some body's weight is compensated."""
        return self.platform_gravcomp != 0.0 or bool(np.any(self.leg_gravcomp))

    @property
    def actuated(self) -> np.ndarray:
        """The actuated joint of each leg, 0-based, shape (6,)."""
        return np.array([leg.actuated - 1 for leg in self.legs])

    @property
    def leg_base_poses(self) -> np.ndarray:
        """(6, 4, 4) the poses of the leg frames 0i in F0."""
        T = np.tile(np.eye(4), (6, 1, 1))
        T[:, :3, :3], T[:, :3, 3] = self.leg_base_rotations, self.base_points
        return T

    @property
    def joint_legs(self) -> tuple[LegArchitecture, ...]:
        """The six legs as chains of joints (:attr:`RobotDescription.joint_legs`)."""
        return self.legs

    @property
    def architecture(self) -> str:
        """The legs' common architecture name, or ``"mixed"``."""
        names = {leg.name for leg in self.legs}
        return names.pop() if len(names) == 1 else "mixed"

    @property
    def size(self) -> float:
        """A length scale: the mean platform-point distance to their centroid [m]."""
        P = self.platform_points
        r = float(np.linalg.norm(P - P.mean(0), axis=1).mean())
        return r if r > 0 else float(np.linalg.norm(self.base_points.std(0)))

    def replace(self, **changes: Any) -> GeneralHexapod:
        return replace(self, **changes)

    def to_description(self) -> RobotDescription:
        """The same robot as a :class:`RobotDescription` with explicit ``legs``."""
        return RobotDescription(
            base_points=self.base_points,
            platform_points=self.platform_points,
            leg_base_rotations=self.leg_base_rotations,
            stroke=None,
            leg_inertia=self.leg_inertia,
            platform_inertia=self.platform_inertia,
            gravity=self.gravity,
            name=self.name,
            home_pose=self.home_pose,
            legs=self.legs,
            platform_gravcomp=self.platform_gravcomp,
            leg_gravcomp=self.leg_gravcomp,
        )

    def with_joint_dynamics(self, dynamics: Any) -> GeneralHexapod:
        """A copy with every joint's dynamics set: ``dynamics[i][j]`` for joint j of leg i."""
        legs = tuple(leg.with_dynamics(d) for leg, d in zip(self.legs, dynamics, strict=True))
        return self.replace(legs=legs)


def general_from_description(desc: RobotDescription) -> GeneralHexapod:
    """The :class:`GeneralHexapod` view of any :class:`RobotDescription`: its ``legs``, or
    for the ideal 6-UPS robot :func:`ups` legs with its stroke and U-joint limits and no
    joint dynamics (:attr:`RobotDescription.leg_architectures`): the same robot."""
    return GeneralHexapod(
        base_points=desc.base_points,
        leg_base_rotations=desc.leg_base_rotations,
        platform_points=desc.platform_points,
        legs=desc.leg_architectures,
        leg_inertia=desc.leg_inertia,
        platform_inertia=desc.platform_inertia,
        gravity=desc.gravity,
        home_pose=desc.home_pose,
        name=desc.name,
        leg_gravcomp=desc.leg_gravcomp,
        platform_gravcomp=desc.platform_gravcomp,
    )


__all__ = ["GeneralHexapod", "general_from_description"]
