"""stewart-pin: closed-loop dynamics of Gough-Stewart (6-UPS) hexapods on Pinocchio.

The models of Khalil & Guegan, "Inverse and direct dynamic modeling of Gough-Stewart
robots": geometry, kinematics, inverse and direct dynamics, cross-checked against
Pinocchio's constrained dynamics on the full closed-loop model.
"""

from stewart_pin.check.constrained_dynamics import validate
from stewart_pin.description.presets import PRESETS, preset, random_robot
from stewart_pin.description.robot_description import (
    RobotDescription,
    leg_base_rotation_from_axis,
    leg_frame_from_mdh,
)
from stewart_pin.description.symmetric_hexapod import symmetric_hexapod
from stewart_pin.exceptions import (
    ApproximationWarning,
    ArchitectureError,
    BaseParameterWarning,
    CompilationError,
    ConvergenceError,
    DescriptionError,
    FileFormatError,
    IdentificationError,
    InertiaError,
    InputError,
    InputTypeError,
    JointDynamicsError,
    JointLimitError,
    LegJointLimitError,
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
    RobotNameError,
    RodSpinError,
    SimulationError,
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
from stewart_pin.motion.simulation import simulate
from stewart_pin.parameters.base import base_parameters, essential_parameters
from stewart_pin.payload_robot import PayloadRobot
from stewart_pin.robot import StewartRobot

__version__ = "0.1.0"

__all__ = [
    "PRESETS",
    "ApproximationWarning",
    "ArchitectureError",
    "BaseParameterWarning",
    "CompilationError",
    "ConvergenceError",
    "DescriptionError",
    "FileFormatError",
    "IdentificationError",
    "InertiaError",
    "InputError",
    "InputTypeError",
    "JointDynamicsError",
    "JointLimitError",
    "LegJointLimitError",
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
    "PayloadRobot",
    "RobotDescription",
    "RobotNameError",
    "RodSpinError",
    "SimulationError",
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
