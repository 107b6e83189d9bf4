"""The inverse and direct dynamic models of Khalil & Guegan.

:mod:`.leg_dynamics` gets each leg's H_i (RNEA), A_i (CRBA) and h_i from Pinocchio;
:mod:`.closed_loop` is the paper's projection: leg forces to the platform (eq. 20-23),
the platform's Newton-Euler (eq. 24), the inverse model Gamma = Jp^T (F_p + F_leg) and
the direct model with A_robot, h_robot (eq. 36-38); :mod:`.regressor` gives the regressor W
with Gamma = W chi (6 x 190 for the ideal 6-UPS robot; 6 x 280 for general legs, whose
joint terms are standard parameters too). :mod:`.leg_chain_dynamics` gives any three-joint
leg's H_i with its joint terms (armature, friction, springs, dampers) to the same closure kernel.
:mod:`.payload` adds a payload moving on the platform (its reaction from Pinocchio's RNEA
with the platform's motion as its base motion; the coupled mass matrix).

Stands on :mod:`stewart_pin.kinematics` and :mod:`stewart_pin.models`; knows no
simulator, screen or command line.
"""

from .closed_loop import (
    CartesianDynamics,
    InverseDynamicsResult,
    cartesian_dynamics,
    direct_dynamics,
    inverse_dynamics,
)
from .leg_dynamics import LegDynamics
from .regressor import (
    N_STANDARD,
    parameter_groups,
    regressor_batch,
    standard_parameter_names,
    standard_parameters,
    with_standard_parameters,
)

__all__ = [
    "N_STANDARD",
    "CartesianDynamics",
    "InverseDynamicsResult",
    "LegDynamics",
    "cartesian_dynamics",
    "direct_dynamics",
    "inverse_dynamics",
    "parameter_groups",
    "regressor_batch",
    "standard_parameter_names",
    "standard_parameters",
    "with_standard_parameters",
]
