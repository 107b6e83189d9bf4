"""stewart-pin: closed-loop dynamics of Gough-Stewart hexapods (6-UPS, 6-RUS, 6-PUS,
custom legs) on Pinocchio.

The models of Khalil & Guegan, "Inverse and direct dynamic modeling of Gough-Stewart
robots": geometry, kinematics, inverse and direct dynamics, cross-checked against
Pinocchio's constrained dynamics on the full closed-loop model.

Importing the package is cheap: the exceptions come with it, every other public name is
imported on first use (PEP 562 module ``__getattr__``), so ``import stewart_pin`` and the
``stewart-pin`` command start without Pinocchio, CasADi or SciPy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names
from stewart_pin.exceptions import (
    ApproximationWarning,
    ArchitectureError,
    BaseParameterWarning,
    CompilationError,
    ConvergenceError,
    DescriptionError,
    EmptyWorkspaceError,
    ExportError,
    FileFormatError,
    GravityCompensationError,
    IdentificationError,
    InertiaError,
    InputError,
    InputTypeError,
    JointDynamicsError,
    JointLimitError,
    LegJointLimitError,
    LegMobilityError,
    LegReachError,
    LogError,
    LogGapError,
    LogLimitError,
    LogSaturationError,
    LogTimeError,
    LogValueError,
    LoopClosureError,
    MissingDependencyError,
    ModelImportError,
    ModelImportWarning,
    NumericalError,
    PayloadError,
    PayloadMeshError,
    PhysicalFitError,
    RobotNameError,
    RodSpinError,
    SchedulerError,
    SimulationError,
    SimulationInterrupted,
    SingularityError,
    StewartPinError,
    StewartPinWarning,
    StrokeLimitError,
    UnknownPayloadError,
    UnsafeCacheError,
    UnsupportedArchitectureError,
    ViewerError,
    WorkspaceError,
)

if TYPE_CHECKING:  # what mypy and editors see; at run time :func:`__getattr__` imports them
    from stewart_pin.check.constrained_dynamics import validate
    from stewart_pin.description.presets import PRESETS, preset, random_robot
    from stewart_pin.description.robot_description import (
        RobotDescription,
        leg_base_rotation_from_axis,
        leg_frame_from_mdh,
    )
    from stewart_pin.description.symmetric_hexapod import symmetric_hexapod
    from stewart_pin.motion.simulation import simulate
    from stewart_pin.parameters.base import base_parameters, essential_parameters
    from stewart_pin.payload_robot import PayloadRobot
    from stewart_pin.robot import StewartRobot

__version__ = "0.1.0"

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "validate": "stewart_pin.check.constrained_dynamics",
        "PRESETS": "stewart_pin.description.presets",
        "preset": "stewart_pin.description.presets",
        "random_robot": "stewart_pin.description.presets",
        "RobotDescription": "stewart_pin.description.robot_description",
        "leg_base_rotation_from_axis": "stewart_pin.description.robot_description",
        "leg_frame_from_mdh": "stewart_pin.description.robot_description",
        "symmetric_hexapod": "stewart_pin.description.symmetric_hexapod",
        "simulate": "stewart_pin.motion.simulation",
        "base_parameters": "stewart_pin.parameters.base",
        "essential_parameters": "stewart_pin.parameters.base",
        "PayloadRobot": "stewart_pin.payload_robot",
        "StewartRobot": "stewart_pin.robot",
    },
)

__all__ = [
    "PRESETS",
    "ApproximationWarning",
    "ArchitectureError",
    "BaseParameterWarning",
    "CompilationError",
    "ConvergenceError",
    "DescriptionError",
    "EmptyWorkspaceError",
    "ExportError",
    "FileFormatError",
    "GravityCompensationError",
    "IdentificationError",
    "InertiaError",
    "InputError",
    "InputTypeError",
    "JointDynamicsError",
    "JointLimitError",
    "LegJointLimitError",
    "LegMobilityError",
    "LegReachError",
    "LogError",
    "LogGapError",
    "LogLimitError",
    "LogSaturationError",
    "LogTimeError",
    "LogValueError",
    "LoopClosureError",
    "MissingDependencyError",
    "ModelImportError",
    "ModelImportWarning",
    "NumericalError",
    "PayloadError",
    "PayloadMeshError",
    "PayloadRobot",
    "PhysicalFitError",
    "RobotDescription",
    "RobotNameError",
    "RodSpinError",
    "SchedulerError",
    "SimulationError",
    "SimulationInterrupted",
    "SingularityError",
    "StewartPinError",
    "StewartPinWarning",
    "StewartRobot",
    "StrokeLimitError",
    "UnknownPayloadError",
    "UnsafeCacheError",
    "UnsupportedArchitectureError",
    "ViewerError",
    "WorkspaceError",
    "__version__",
    "base_parameters",
    "essential_parameters",
    "leg_base_rotation_from_axis",
    "leg_frame_from_mdh",
    "preset",
    "random_robot",
    "simulate",
    "symmetric_hexapod",
    "validate",
]
