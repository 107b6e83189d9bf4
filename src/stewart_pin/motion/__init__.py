"""Motion of the platform: reference trajectories (minimum jerk, washout, sinusoids,
Fourier series) with exact twists and classical accelerations, the SE(3) integrators of
the direct model (RK4, Dormand-Prince), and computed-torque control. :mod:`.payload`:
a payload's joint trajectories, computed torque with the coupled model, and the
simulation of a hexapod whose payload runs its own trajectory.

The simulator and the controller take any robot with the dynamics of
:class:`stewart_pin.robot.StewartRobot` (a protocol, :mod:`stewart_pin._typing`).
"""

from .control import ComputedTorqueController, pose_error, tracking_errors
from .simulation import SimulationResult, simulate
from .trajectories import (
    CoordinateMotion,
    FourierTrajectory,
    Trajectory,
    minimum_jerk,
    standard_motion,
    washout,
)

__all__ = [
    "ComputedTorqueController",
    "CoordinateMotion",
    "FourierTrajectory",
    "SimulationResult",
    "Trajectory",
    "minimum_jerk",
    "pose_error",
    "simulate",
    "standard_motion",
    "tracking_errors",
    "washout",
]
