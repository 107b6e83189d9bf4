"""What the layers above the dynamics need from a robot: :class:`RobotLike`.

Simulation, trajectories, identification, base parameters, the independent check and
the code generator take a robot and call back into it. They take this protocol rather
than :class:`stewart_pin.robot.StewartRobot`, so that they import nothing above them (the
facade wires them all) and a test double or another robot class can stand in.
:class:`~stewart_pin.robot.StewartRobot` satisfies it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from stewart_pin._typing import ArrayLike, FloatArray, Forces, JointValues, Pose
from stewart_pin.description import RobotDescription

if TYPE_CHECKING:  # annotations only: the protocol imports no Pinocchio model
    from stewart_pin.models.payload import Payload
    from stewart_pin.models.pinocchio_models import TreeModel

__all__ = ["PayloadRobotLike", "RobotLike"]


class RobotLike(Protocol):
    """A robot: its description, its singularity threshold, and its models.

    Every method takes one state or a batch with a leading N axis and returns the same
    (see :class:`stewart_pin.robot.StewartRobot` for the conventions).
    """

    #: The validated robot description.
    description: RobotDescription
    #: The singularity measure past which a pose counts as singular.
    max_condition: float

    @property
    def home_pose(self) -> Pose:
        """The home pose 0Tp (4, 4)."""
        ...

    @property
    def tree(self) -> TreeModel:
        """The Pinocchio tree with its loop-closure constraints."""
        ...

    def inverse_geometry(self, pose: ArrayLike, check_limits: bool = True) -> JointValues:
        """Leg joint values (6, 3) or (N, 6, 3)."""
        ...

    def leg_lengths(self, pose: ArrayLike) -> FloatArray:
        """The actuated joint values, (6,) or (N, 6) (the 6-UPS's name: leg lengths [m])."""
        ...

    def actuator_positions(self, pose: ArrayLike, check_limits: bool = False) -> FloatArray:
        """The actuated joint values, (6,) or (N, 6) (leg lengths for 6-UPS)."""
        ...

    def inverse_jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp^-1`` (6, 6) or (N, 6, 6)."""
        ...

    def limit_margin(
        self, pose: ArrayLike, error: BaseException | None = None
    ) -> tuple[float, str]:
        """The smallest (unit-free) distance of a joint to its limits, and which."""
        ...

    def jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp`` (6, 6)."""
        ...

    def condition_number(self, pose: ArrayLike) -> float | FloatArray:
        """The singularity measure of ``pose``."""
        ...

    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        *,
        backend: str = ...,
        idle: Any = ...,
    ) -> Forces:
        """Actuator forces Gamma [N], (6,) or (N, 6); ``idle``: the idle joints'
        ``(values, rates)`` of a robot with idle freedoms."""
        ...

    def direct_dynamics(
        self, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike, *, backend: str = ...
    ) -> FloatArray:
        """Classical platform acceleration in F0, (6,) or (N, 6)."""
        ...

    def regressor(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike, idle: Any = None
    ) -> FloatArray:
        """The dynamic regressor ``W``, (6, n) or (N, 6, n): n = 190 standard parameters for
        the ideal 6-UPS robot, 280 for general legs (their joint terms included); ``idle``:
        the idle joints' ``(values, rates, accelerations)`` of a robot with idle freedoms."""
        ...

    def forward_geometry(self, lengths: ArrayLike, guess: ArrayLike = None) -> Pose:
        """The pose 0Tp (4, 4) with actuated joint values ``lengths`` (6,), Newton from
        ``guess``."""
        ...

    def leg_kinematics(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None = None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        """``(q, qdot, qddot)`` of the legs, each (6, 3) or (N, 6, 3)."""
        ...

    def sample_states(
        self,
        n: int,
        rng: np.random.Generator | int | None = None,
        translation: float | None = None,
        rotation: float = 0.25,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``n`` random reachable states ``(poses, twists, accels)``."""
        ...


class PayloadRobotLike(Protocol):
    """A hexapod carrying a payload (:class:`stewart_pin.payload_robot.PayloadRobot`):
    what the simulation, the independent check and the viewer need from it."""

    @property
    def robot(self) -> RobotLike:
        """The hexapod."""
        ...

    @property
    def payload(self) -> Payload:
        """The payload and its placement on the platform."""
        ...

    @property
    def name(self) -> str:
        """``"<hexapod>+<payload>"``."""
        ...

    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        qdd: ArrayLike,
        details: bool = False,
        backend: str = "auto",
    ) -> Any:
        """``PayloadEfforts(gamma, tau)``: actuator efforts and the payload's torques."""
        ...

    def direct_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        gamma: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        qdd: ArrayLike = None,
        *,
        tau: ArrayLike = None,
        backend: str = "auto",
    ) -> Any:
        """``PayloadAcceleration(accel, qdd, tau)``, prescribed ``qdd`` or given ``tau``."""
        ...

    def sample_states(
        self,
        n: int,
        rng: np.random.Generator | int | None = None,
        translation: float | None = None,
        rotation: float = 0.25,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(poses, twists, accels, q, qd, qdd)``: random states of both."""
        ...
