"""Pinocchio models of robots with chain legs (``description.chain_legs``: any 1-dof
joints placed by MDH transforms, ball or weld closures), built with the ``pin.Model`` API.

Each joint is ``JointModelRZ`` (revolute) or ``JointModelPZ`` (prismatic) placed by
``Joint.placement`` (joint 1 preceded by the leg's base frame ``[R_0k, B_k]``), each link's
body its Khalil parameters (:func:`~stewart_pin.description.inertia.pin_inertia_from_khalil`),
``model.armature`` each joint's armature, the robot's gravity.

- :func:`build_chain_leg` : leg k alone, n_k dof, joints ``leg{k+1}_q{j}`` (the leg model of
  :class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`).
- :func:`build_chain_legs` : the six legs on a fixed base and the (6, max n) velocity
  index (``-1`` past a leg's last joint).
- :func:`build_chain_tree` : the six legs and the platform as a free-flyer with one
  ``RigidConstraintModel`` (LOCAL) per leg: ``CONTACT_3D`` between the ball centre on the
  last link and ``P_i`` on the platform (ball), ``CONTACT_6D`` between the leg's attachment
  frame ``(tip, tip_rotation)`` and the platform's ``(P_i, platform_rotation)`` (weld).
"""

from __future__ import annotations

import numpy as np

from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import pin_inertia_from_khalil
from stewart_pin.kinematics import chain_legs as kin
from stewart_pin.models.leg_chains import PLATFORM_JOINT, leg_joint_name
from stewart_pin.models.pinocchio_models import TreeModel

#: The index of a joint a leg does not have, in the (6, max n) indices.
NO_JOINT = -1


def _add_chain_leg(model: pin.Model, desc: RobotDescription, k: int) -> list[int]:
    """Leg k's joints on the universe (joint ids), with their bodies and armature."""
    leg = kin.chain_legs_of(desc)[k]
    parent, ids = 0, []
    for j, joint in enumerate(leg.joints):
        placement = pin.SE3(joint.placement())
        if j == 0:
            placement = pin.SE3(kin.leg_base_pose(desc, k)) * placement
        jm = pin.JointModelRZ() if joint.revolute else pin.JointModelPZ()
        parent = model.addJoint(parent, jm, placement, leg_joint_name(k + 1, j + 1))
        model.appendBodyToJoint(
            parent, pin_inertia_from_khalil(leg.inertia[j]), pin.SE3.Identity()
        )
        ids.append(parent)
    armature = np.array(model.armature, dtype=float)
    armature[[model.idx_vs[jid] for jid in ids]] = leg.armature
    model.armature = armature
    return ids


def _new_model(desc: RobotDescription, name: str) -> pin.Model:
    model = pin.Model()
    model.name = name
    model.gravity = pin.Motion(np.asarray(desc.gravity, float), np.zeros(3))
    return model


def build_chain_leg(desc: RobotDescription, k: int) -> pin.Model:
    """Leg k's (0-based) serial model: fixed base at frame 0k, n_k joints in order."""
    model = _new_model(desc, f"{desc.name}-leg{k + 1}")
    _add_chain_leg(model, desc, k)
    return model


def _index(model: pin.Model, legs: list[list[int]], table: str) -> np.ndarray:
    idx = getattr(model, table)
    out = np.full((6, max(len(ids) for ids in legs)), NO_JOINT, dtype=int)
    for k, ids in enumerate(legs):
        out[k, : len(ids)] = [idx[jid] for jid in ids]
    return out


def build_chain_legs(desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
    """The six legs on a fixed base (sum n_k dof) and the (6, max n) velocity index of
    joint j of leg k (:data:`NO_JOINT` past a leg's last joint)."""
    model = _new_model(desc, f"{desc.name}-legs")
    legs = [_add_chain_leg(model, desc, k) for k in range(6)]
    return model, _index(model, legs, "idx_vs")


def build_chain_tree(desc: RobotDescription) -> TreeModel:
    """The closed-loop tree (6 + sum n_k dof; module docstring): leg indices (6, max n)
    padded with :data:`NO_JOINT`, ``actuated`` each leg's actuated joint (0-based)."""
    legs_desc = kin.chain_legs_of(desc)
    model = _new_model(desc, desc.name)
    ff = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), PLATFORM_JOINT)
    model.appendBodyToJoint(ff, pin_inertia_from_khalil(desc.platform_inertia), pin.SE3.Identity())
    model.addFrame(pin.Frame("platform", ff, pin.SE3.Identity(), pin.FrameType.BODY))
    legs = [_add_chain_leg(model, desc, k) for k in range(6)]
    constraints = []
    for k, (leg, ids) in enumerate(zip(legs_desc, legs, strict=True)):
        weld = leg.closure == "weld"
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_6D if weld else pin.ContactType.CONTACT_3D,
            model,
            ids[-1],
            pin.SE3(leg.tip_rotation if weld else np.eye(3), np.asarray(leg.tip, float)),
            ff,
            pin.SE3(
                leg.platform_rotation if weld else np.eye(3),
                np.asarray(desc.platform_points[k], float),
            ),
            pin.ReferenceFrame.LOCAL,
        )
        cm.name = f"loop{k + 1}"
        constraints.append(cm)
    return TreeModel(
        model=model,
        constraints=constraints,
        platform_joint=ff,
        leg_q_index=_index(model, legs, "idx_qs"),
        leg_v_index=_index(model, legs, "idx_vs"),
        platform_q_index=np.arange(model.idx_qs[ff], model.idx_qs[ff] + 7),
        platform_v_index=np.arange(model.idx_vs[ff], model.idx_vs[ff] + 6),
        actuated=np.array([leg.actuated - 1 for leg in legs_desc]),
    )


__all__ = ["NO_JOINT", "build_chain_leg", "build_chain_legs", "build_chain_tree"]
