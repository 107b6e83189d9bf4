"""The independent check: inverse and direct dynamics of the full closed-loop tree by
Pinocchio's constrained dynamics (``pin.constraintDynamics`` and a KKT solve of the
loop-closure Jacobians), compared with the paper's models.

Shares no algebra with :mod:`stewart_pin.dynamics`, :mod:`stewart_pin.codegen` or the
Jacobians of :mod:`stewart_pin.kinematics`: a check that reused the code it checks would
prove nothing (the layering contract in ``pyproject.toml`` enforces it).
:mod:`.leg_chain_tree` is the same check for general legs: the constrained tree with the
armatures and the joint torques (friction, springs, dampers). :mod:`.payload` checks a
hexapod carrying a payload against the whole tree (the payload appended to the platform).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported on first use
    from .constrained_dynamics import (
        ValidationReport,
        constrained_forward_dynamics,
        constrained_inverse_dynamics,
        validate,
    )

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "ValidationReport": ".constrained_dynamics",
        "constrained_forward_dynamics": ".constrained_dynamics",
        "constrained_inverse_dynamics": ".constrained_dynamics",
        "validate": ".constrained_dynamics",
    },
)

__all__ = [
    "ValidationReport",
    "constrained_forward_dynamics",
    "constrained_inverse_dynamics",
    "validate",
]
