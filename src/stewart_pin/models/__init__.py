"""Pinocchio models built from a description's URDF: the 24-dof closed-loop tree with its
six 3D loop closures (``RigidConstraintModel``), each 3-dof leg, and the 18-dof set of
the six legs used by the leg dynamics.

Both the dynamics (each leg's H_i, A_i, h_i) and the independent check (the constrained
tree) stand on these models. :mod:`.leg_chains` builds the same for general legs with the
Pinocchio API (each chain, the 18-dof set, the tree with ``model.armature``).
:mod:`.payload` loads a payload (a fixed-base model: a ``pin.Model``, a URDF, a robot of
example-robot-data) and appends it to a model's body.
"""

from .pinocchio_models import (
    TreeModel,
    build_leg_models,
    build_legs_model,
    build_tree,
    load_tree,
)

__all__ = [
    "TreeModel",
    "build_leg_models",
    "build_legs_model",
    "build_tree",
    "load_tree",
]
