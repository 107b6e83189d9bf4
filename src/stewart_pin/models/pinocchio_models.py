"""Pinocchio models built from the generated URDF and closure sidecar.

- :func:`build_tree` : the 24-dof tree (platform free-flyer + 18 leg joints) with the six
  3D loop-closure constraints (``pin.RigidConstraintModel`` CONTACT_3D, LOCAL).
- :func:`build_leg_models` : the 3-dof model of each leg.
- :func:`build_legs_model` : the six legs side by side, fixed base, 18 dof: one RNEA /
  CRBA call on it is the six legs' RNEA / CRBA (the chains share no body).

The tree's free-flyer velocity is the platform's body twist in Fp (``[R^T v, R^T w]``),
Pinocchio's convention; :mod:`stewart_pin.check.constrained_dynamics` converts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from stewart_pin._checks import decode_utf8
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import FileFormatError
from stewart_pin.formats.urdf import (
    PLATFORM_JOINT,
    Closure,
    closures_dict,
    leg_joint,
    parse_closures,
    read_actuated_joints,
    read_joint_terms,
    read_sidecar,
    urdf_string,
)


def _model_from_urdf_text(text: str, gravity: np.ndarray) -> pin.Model:
    try:
        model = pin.buildModelFromXML(text)
    except (RuntimeError, ValueError) as e:
        raise FileFormatError(f"Pinocchio cannot parse the URDF: {e}") from e
    model.gravity.linear = np.asarray(gravity, dtype=float)
    return model


@dataclass
class TreeModel:
    """The closed-loop robot as Pinocchio sees it.

    Attributes:
        model: the 24-dof tree (nq = 25: free-flyer position + quaternion, 18 leg joints).
        constraints: the six 3D point constraints (leg tip frame 3i == P_i on the platform).
        platform_joint: joint id of the free-flyer.
        leg_q_index, leg_v_index: (6, 3) indices of q_ji in ``q`` and ``v``.
        platform_v_index: the 6 velocity indices of the free-flyer.
    """

    model: pin.Model
    constraints: list[pin.RigidConstraintModel]
    platform_joint: int
    leg_q_index: np.ndarray
    leg_v_index: np.ndarray
    platform_q_index: np.ndarray = field(default_factory=lambda: np.arange(7))
    platform_v_index: np.ndarray = field(default_factory=lambda: np.arange(6))
    actuated: np.ndarray | None = None

    @property
    def actuated_v_index(self) -> np.ndarray:
        """Velocity indices of the six actuated joints: q3i (6-UPS), or the joint of each
        leg that ``actuated`` (6,) (0-based, from the sidecar of general legs) names."""
        if self.actuated is None:
            return self.leg_v_index[:, 2]
        return self.leg_v_index[np.arange(6), self.actuated]


def _leg_indices(model: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    q_idx = np.empty((6, 3), dtype=int)
    v_idx = np.empty((6, 3), dtype=int)
    for i in range(6):
        for j in range(3):
            name = leg_joint(i + 1, j + 1)
            if not model.existJointName(name):
                raise FileFormatError(f"the URDF has no joint '{name}'")
            jid = model.getJointId(name)
            q_idx[i, j], v_idx[i, j] = model.idx_qs[jid], model.idx_vs[jid]
    return q_idx, v_idx


def tree_from_files(
    urdf_text: str,
    closures: list[Closure],
    gravity: np.ndarray,
    joint_terms: dict[str, dict[str, float]] | None = None,
    actuated_joints: list[str] | None = None,
) -> TreeModel:
    """Build the closed-loop model from URDF text and parsed closures.

    ``joint_terms`` (the sidecar's, general legs): ``model.armature`` of each named joint
    is set to its ``armature``. ``actuated_joints``: the actuated joint of each leg
    (default ``leg{i}_q3``).
    """
    model = _model_from_urdf_text(urdf_text, gravity)
    if not model.existJointName(PLATFORM_JOINT):
        raise FileFormatError(f"the URDF has no floating joint '{PLATFORM_JOINT}'")
    ff = model.getJointId(PLATFORM_JOINT)
    if model.joints[ff].nv != 6 or model.nv != 24:
        raise FileFormatError(
            f"expected a free-flyer '{PLATFORM_JOINT}' and 24 velocity coordinates, got "
            f"nv = {model.nv}"
        )
    constraints = []
    for c in closures:
        frames = []
        for link, point in ((c.link1, c.point1), (c.link2, c.point2)):
            if not model.existBodyName(link):
                raise FileFormatError(f"closure '{c.name}' names an unknown link '{link}'")
            frame = model.frames[model.getBodyId(link)]
            frames.append((frame.parentJoint, frame.placement * pin.SE3(np.eye(3), point)))
        (j1, M1), (j2, M2) = frames
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_3D, model, j1, M1, j2, M2, pin.ReferenceFrame.LOCAL
        )
        cm.name = c.name
        constraints.append(cm)
    q_idx, v_idx = _leg_indices(model)
    if joint_terms:
        armature = np.array(model.armature, dtype=float)
        for name, terms in joint_terms.items():
            if not model.existJointName(name):
                raise FileFormatError(f"the joint terms name an unknown joint '{name}'")
            armature[model.idx_vs[model.getJointId(name)]] = terms["armature"]
        model.armature = armature
    actuated = None
    if actuated_joints is not None:
        actuated = np.empty(6, dtype=int)
        for i in range(6):
            found = [j for j in range(3) if leg_joint(i + 1, j + 1) in actuated_joints]
            if len(found) != 1:
                raise FileFormatError(f"expected one actuated joint in leg {i + 1}")
            actuated[i] = found[0]
    return TreeModel(
        model=model,
        constraints=constraints,
        platform_joint=ff,
        leg_q_index=q_idx,
        leg_v_index=v_idx,
        platform_q_index=np.arange(model.idx_qs[ff], model.idx_qs[ff] + 7),
        platform_v_index=np.arange(model.idx_vs[ff], model.idx_vs[ff] + 6),
        actuated=actuated,
    )


def build_tree(desc: RobotDescription) -> TreeModel:
    """The 24-dof tree with six 3D loop closures, from the generated URDF and sidecar."""
    return tree_from_files(urdf_string(desc), parse_closures(closures_dict(desc)), desc.gravity)


def load_tree(urdf_path: str | Path, gravity: np.ndarray | None = None) -> TreeModel:
    """The closed-loop model from files on disk (``X.urdf`` and ``X.closures.json``).

    Gravity: ``gravity`` when given, else the sidecar's ``gravity``, else [0, 0, -9.81].
    A sidecar with ``joint_terms`` (general legs) sets ``model.armature`` and the actuated
    joints (its ``actuated_joints``).
    """
    urdf_path = Path(urdf_path)
    sidecar = urdf_path.with_name(urdf_path.name.removesuffix(".urdf") + ".closures.json")
    closures, recorded = read_sidecar(sidecar)
    terms = read_joint_terms(sidecar)
    actuated = read_actuated_joints(sidecar) if terms else None
    if gravity is not None:
        g = np.asarray(gravity, float)
    elif recorded is not None:
        g = recorded
    else:
        g = np.array([0.0, 0.0, -9.81])
    try:
        text = decode_utf8(urdf_path.read_bytes(), urdf_path)
    except OSError as e:
        raise FileFormatError(f"cannot read {urdf_path}: {e}") from e
    return tree_from_files(text, closures, g, terms, actuated)


def _reduced(model: pin.Model, keep_legs: list[int]) -> pin.Model:
    """Lock the free-flyer and every leg not in ``keep_legs`` (0-based)."""
    locked = [model.getJointId(PLATFORM_JOINT)]
    for i in range(6):
        if i not in keep_legs:
            locked += [model.getJointId(leg_joint(i + 1, j)) for j in (1, 2, 3)]
    q_ref = pin.neutral(model)
    reduced = pin.buildReducedModel(model, locked, q_ref)
    reduced.gravity = model.gravity
    return reduced


def build_leg_models(desc: RobotDescription) -> list[pin.Model]:
    """The six 3-dof leg models, from one parse of the URDF: model ``i`` (0-based) has the
    joints ``q1i, q2i, q3i`` in that order, and its tip frame ``leg{i}_link3`` has its
    origin at P_i when q = inverse geometry."""
    tree = _model_from_urdf_text(urdf_string(desc), desc.gravity)
    return [_reduced(tree, [leg]) for leg in range(6)]


def build_legs_model(desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
    """The six legs on a fixed base (18 dof) and the (6, 3) velocity index of q_ji."""
    tree = _model_from_urdf_text(urdf_string(desc), desc.gravity)
    legs = _reduced(tree, list(range(6)))
    return legs, _leg_indices(legs)[1]
