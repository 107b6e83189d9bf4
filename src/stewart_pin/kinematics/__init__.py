"""Platform state -> leg states: geometry and kinematics of the closed loop.

:mod:`.geometry` holds the inverse geometry (leg vectors, lengths and joint values from a
pose 0Tp, with the stroke and joint-limit checks); :mod:`.forward_geometry` the forward
geometry (Newton on SE(3) from the actuator lengths, using the Jacobian); :mod:`.jacobians`
the first and second order: Jp^-1 (eq. 13), each leg's J_3i and its drift, the unit-free
singularity measure and its check; :mod:`.workspace` samples reachable poses and states.
:mod:`.leg_chains` is the same for any three-joint leg (closed-form inverse geometry of
the named legs, a Newton solver for others, J_i, Jp^-1 rows ``e_ai^T J_i^-1 G_i``, serial
and parallel singularities); one private SE(3) Newton serves both forward geometries.

Reads a :class:`~stewart_pin.description.RobotDescription`; knows no Pinocchio model
and no dynamics.
"""

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names

from .forward_geometry import forward_geometry
from .geometry import inverse_geometry, inverse_geometry_batch, leg_lengths
from .jacobians import (
    MAX_CONDITION,
    LegState,
    condition_number,
    inverse_jacobian,
    inverse_jacobian_batch,
    jacobian,
    leg_state,
)

if TYPE_CHECKING:
    from .workspace import sample_poses, sample_states

# the sampling (Pinocchio's exponential) on first use: the geometry imports light
__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "sample_poses": "stewart_pin.kinematics.workspace",
        "sample_states": "stewart_pin.kinematics.workspace",
    },
)

__all__ = [
    "MAX_CONDITION",
    "LegState",
    "condition_number",
    "forward_geometry",
    "inverse_geometry",
    "inverse_geometry_batch",
    "inverse_jacobian",
    "inverse_jacobian_batch",
    "jacobian",
    "leg_lengths",
    "leg_state",
    "sample_poses",
    "sample_states",
]
