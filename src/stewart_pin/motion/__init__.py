"""Motion of the platform: reference trajectories (minimum jerk, washout, sinusoids,
Fourier series) with exact twists and classical accelerations, the SE(3) integrators of
the direct model (RK4, Dormand-Prince; the RK4 also in C around the compiled model,
:mod:`stewart_pin.codegen.simulator`), forces as data (:class:`ForceTable`), and
computed-torque control. :mod:`.payload`:
a payload's joint trajectories, computed torque with the coupled model, and the
simulation of a hexapod whose payload runs its own trajectory.

The simulator and the controller take any robot with the dynamics of
:class:`stewart_pin.robot.StewartRobot` (a protocol, :mod:`stewart_pin._typing`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported on first use
    from .control import ComputedTorqueController, pose_error, tracking_errors
    from .force_tables import ForceTable
    from .simulation import SimulationResult, simulate
    from .trajectories import (
        CoordinateMotion,
        FourierTrajectory,
        Trajectory,
        minimum_jerk,
        standard_motion,
        washout,
    )

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "ComputedTorqueController": ".control",
        "pose_error": ".control",
        "tracking_errors": ".control",
        "ForceTable": ".force_tables",
        "SimulationResult": ".simulation",
        "simulate": ".simulation",
        "CoordinateMotion": ".trajectories",
        "FourierTrajectory": ".trajectories",
        "Trajectory": ".trajectories",
        "minimum_jerk": ".trajectories",
        "standard_motion": ".trajectories",
        "washout": ".trajectories",
    },
)

__all__ = [
    "ComputedTorqueController",
    "CoordinateMotion",
    "ForceTable",
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
