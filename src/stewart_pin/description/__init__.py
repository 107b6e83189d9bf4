"""What a robot is: the first room of the data flow.

A :class:`RobotDescription` holds the geometry (base points B_i in F0, platform points
P_i in Fp, each leg's base frame), the strokes and joint limits, the 6 x 3 x 10 + 10
inertial parameters in Khalil's order, gravity and the home pose, validated on
construction and read from / written to TOML or JSON. Presets and the random robot
generator build descriptions; :mod:`.inertia` converts inertial parameters between
Khalil's, Pinocchio's and URDF's conventions and checks them for physical consistency.

Nothing here knows Pinocchio models, kinematics or dynamics: every other room reads a
description.

A leg is any chain of three 1-dof joints ending in a spherical joint on the platform:
:mod:`.leg_architecture` holds the joints (modified-DH placement, limits, armature,
friction, springs, transmissions), the legs and their builders (``ups``, ``ups_offset``,
``rus``, ``pus``); ``RobotDescription.legs`` is ``None`` for the paper's ideal 6-UPS.

Modules: :mod:`.robot_description` (``RobotDescription``, the file format),
:mod:`.leg_architecture`, :mod:`.leg_io` (the ``[[legs]]`` file section), :mod:`.inertia`,
:mod:`.presets` (6-UPS presets, and the names of the general ones),
:mod:`.leg_chain_presets` (``ups-offset``, ``rus``, ``pus``, random general robots),
:mod:`.leg_chain_hexapod` (the resolved view of a robot's legs), :mod:`.symmetric_hexapod`
(the builder of symmetric 6-6 and 6-3 hexapods).
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
from .symmetric_hexapod import symmetric_hexapod

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
    "symmetric_hexapod",
]
