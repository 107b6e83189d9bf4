"""Pinocchio models of general-leg robots, built with the ``pin.Model`` API (no URDF).

Every joint is Pinocchio's ``JointModelRZ`` (revolute) or ``JointModelPZ`` (prismatic):
in the MDH frames the joint axis is z, and ``Rz(theta + q) Tz(r) = Rz(theta) Tz(r) Rz(q)``,
``Rz(theta) Tz(r + q) = Rz(theta) Tz(r) Tz(q)``, so the joint placement is the constant
``Rx(alpha) Tx(d) Rz(theta) Tz(r)`` (for joint 1 preceded by ``[R_i, B_i]``). Each link's
body is its Khalil parameters in its own frame (converted once, by
:func:`stewart_pin.description.inertia.pin_inertia_from_khalil`). ``model.armature`` holds
each joint's armature (rotor inertia reflected through its transmission): Pinocchio's
``rnea``, ``crba`` and ``constraintDynamics`` include it.

- :func:`build_leg_chain` : one leg, 3 dof, joints ``leg{i}_q{j}``, tip frame ``leg{i}_tip``.
- :func:`build_leg_chains` : the six legs side by side on a fixed base (18 dof).
- :func:`build_general_tree` : six legs and the platform as a free-flyer (24 dof) with
  six ``RigidConstraintModel`` CONTACT_3D (LOCAL): leg i's tip == P_i on the platform.

Which models a robot gets is chosen once per architecture, by its path
(:mod:`stewart_pin.architectures`: ``closed_loop_tree``, ``leg_models``, ``legs_model``):
the paper's ideal 6-UPS keeps the models parsed from its URDF (:mod:`.pinocchio_models`:
the paper's joint names and frames), every other robot gets its chains built here.
"""

from __future__ import annotations

import importlib
import warnings
from typing import Any

import numpy as np

from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin.description.inertia import pin_inertia_from_khalil
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.models.pinocchio_models import (
    TreeModel,
)

PLATFORM_JOINT = "platform_joint"


def leg_joint_name(i: int, j: int) -> str:
    """Joint j (1..3) of leg i (1..6)."""
    return f"leg{i}_q{j}"


def _add_leg(model: pin.Model, robot: GeneralHexapod, k: int) -> list[int]:
    leg = robot.legs[k]
    T0 = pin.SE3(robot.leg_base_poses[k])
    parent, ids = 0, []
    for j, joint in enumerate(leg.joints):
        placement = pin.SE3(joint.placement())
        if j == 0:
            placement = T0 * placement
        jm = pin.JointModelRZ() if joint.revolute else pin.JointModelPZ()
        jid = model.addJoint(parent, jm, placement, leg_joint_name(k + 1, j + 1))
        model.appendBodyToJoint(
            jid, pin_inertia_from_khalil(robot.leg_inertia[k, j]), pin.SE3.Identity()
        )
        model.addFrame(
            pin.Frame(f"leg{k + 1}_link{j + 1}", jid, pin.SE3.Identity(), pin.FrameType.BODY)
        )
        ids.append(jid)
        parent = jid
    model.addFrame(
        pin.Frame(
            f"leg{k + 1}_tip",
            parent,
            pin.SE3(np.eye(3), np.asarray(leg.tip)),
            pin.FrameType.OP_FRAME,
        )
    )
    return ids


def _finish(model: pin.Model, robot: GeneralHexapod, legs: list[int]) -> None:
    model.gravity.linear = np.asarray(robot.gravity, dtype=float)
    armature = np.zeros(model.nv)
    for k in legs:
        for j, joint in enumerate(robot.legs[k].joints):
            jid = model.getJointId(leg_joint_name(k + 1, j + 1))
            armature[model.idx_vs[jid]] = joint.dynamics.total_armature
    model.armature = armature


def build_leg_chain(robot: GeneralHexapod, leg: int) -> pin.Model:
    """The 3-dof model of leg ``leg`` (0-based), joints q1..q3 in that order."""
    model = pin.Model()
    model.name = f"{robot.name}-leg{leg + 1}"
    _add_leg(model, robot, leg)
    _finish(model, robot, [leg])
    return model


def build_leg_chains(robot: GeneralHexapod) -> tuple[pin.Model, np.ndarray]:
    """The six legs on a fixed base (18 dof) and the (6, 3) velocity index of q_ji."""
    model = pin.Model()
    model.name = f"{robot.name}-legs"
    index = np.empty((6, 3), dtype=int)
    for k in range(6):
        ids = _add_leg(model, robot, k)
        index[k] = [model.idx_vs[jid] for jid in ids]
    _finish(model, robot, list(range(6)))
    return model, index


def build_general_tree(robot: GeneralHexapod) -> TreeModel:
    """The 24-dof tree with its six loop closures and ``model.armature``: the same
    :class:`~stewart_pin.models.pinocchio_models.TreeModel` as the 6-UPS tree's, with each
    leg's actuated joint in ``actuated`` (0-based), the loops closed at the legs' tips
    (``RigidConstraintModel`` CONTACT_3D in LOCAL, joint1 the leg's last joint)."""
    model = pin.Model()
    model.name = robot.name
    ff = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), PLATFORM_JOINT)
    model.appendBodyToJoint(
        ff, pin_inertia_from_khalil(robot.platform_inertia), pin.SE3.Identity()
    )
    model.addFrame(pin.Frame("platform", ff, pin.SE3.Identity(), pin.FrameType.BODY))
    leg_ids = [_add_leg(model, robot, k) for k in range(6)]
    _finish(model, robot, list(range(6)))
    constraints = []
    for k, ids in enumerate(leg_ids):
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_3D,
            model,
            ids[-1],
            pin.SE3(np.eye(3), np.asarray(robot.legs[k].tip)),
            ff,
            pin.SE3(np.eye(3), np.asarray(robot.platform_points[k])),
            pin.ReferenceFrame.LOCAL,
        )
        cm.name = f"loop{k + 1}"
        constraints.append(cm)
    q_idx = np.array([[model.idx_qs[j] for j in ids] for ids in leg_ids])
    v_idx = np.array([[model.idx_vs[j] for j in ids] for ids in leg_ids])
    return TreeModel(
        model=model,
        constraints=constraints,
        platform_joint=ff,
        leg_q_index=q_idx,
        leg_v_index=v_idx,
        platform_q_index=np.arange(model.idx_qs[ff], model.idx_qs[ff] + 7),
        platform_v_index=np.arange(model.idx_vs[ff], model.idx_vs[ff] + 6),
        actuated=robot.actuated,
    )


#: Where the models of any robot are chosen now (issue 19: once per architecture, in
#: :mod:`stewart_pin.architectures`): the names this module held until then.
_MOVED = ("closed_loop_tree", "leg_models", "legs_model")


def __getattr__(name: str) -> Any:
    """``closed_loop_tree``, ``leg_models`` and ``legs_model`` (deprecated here): the
    functions of :mod:`stewart_pin.architectures`, after a ``DeprecationWarning`` naming
    them (the architecture's path chooses the models)."""
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"{__name__}.{name} is deprecated: use stewart_pin.architectures.{name} (each "
        "architecture's path chooses its Pinocchio models)",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(importlib.import_module("stewart_pin.architectures"), name)


__all__ = [
    "PLATFORM_JOINT",
    "build_general_tree",
    "build_leg_chain",
    "build_leg_chains",
    "leg_joint_name",
]
