"""What a robot is: the first room of the data flow.

A :class:`RobotDescription` holds the geometry (base points B_i in F0, platform points
P_i in Fp, each leg's base frame), the strokes and joint limits, the 6 x 3 x 10 + 10
inertial parameters in Khalil's order, gravity and the home pose, validated on
construction and read from / written to TOML or JSON. Presets and the random robot
generator build descriptions; :mod:`.inertia` converts inertial parameters between
Khalil's, Pinocchio's and URDF's conventions and checks them for physical consistency.

Nothing here knows Pinocchio models, kinematics or dynamics: every other room reads a
description.

Modules: :mod:`.robot_description` (``RobotDescription``, the file format),
:mod:`.inertia`, :mod:`.presets`.
"""

from .inertia import KHALIL_NAMES, check_physical, inertia_tensor, random_physical_khalil
from .presets import PRESETS, preset, random_robot
from .robot_description import (
    NAME_RULE,
    OPTIONAL_KEYS,
    REQUIRED_KEYS,
    RobotDescription,
    check_robot_name,
    leg_base_rotation_from_axis,
    leg_frame_from_mdh,
)

__all__ = [
    "KHALIL_NAMES",
    "NAME_RULE",
    "OPTIONAL_KEYS",
    "PRESETS",
    "REQUIRED_KEYS",
    "RobotDescription",
    "check_physical",
    "check_robot_name",
    "inertia_tensor",
    "leg_base_rotation_from_axis",
    "leg_frame_from_mdh",
    "preset",
    "random_physical_khalil",
    "random_robot",
]
