"""The dynamic regressor ``W``: ``Gamma = W chi`` for the standard parameters ``chi``.

**The ideal 6-UPS robot** (``desc.legs is None``): 190 standard parameters, Khalil's order
``XX XY XZ YY YZ ZZ MX MY MZ M`` inside each block of 10: leg 1 link 1, leg 1 link 2, ...,
leg 6 link 3, platform. :data:`STANDARD_NAMES` names them (``XX2_3`` is XX of link 2 of
leg 3, ``MZ_P`` the platform's MZ). Built the way the inverse dynamic model is (eq. 31),
from Pinocchio's regressors: ``H_i = Y_i chi_i`` (``pin.computeJointTorqueRegressor`` on
the legs) and the platform's ``F_p = Y_p chi_p`` (``pin.bodyRegressor``), so
``W = Jp^T [[I3; L_i^] J_3i^-T Y_i ..., Y_p]``.

**General legs** (``desc.legs`` set: ``ups``, ``ups-offset``, ``rus``, ``pus``, ``custom``,
mixed): 280 standard parameters (:func:`standard_parameter_names`), in this order:

- the 18 leg links x 10 (the same names, each link about the origin of its own MDH frame
  ``ji``, in that frame), then the platform's 10 (in Fp about O_p): indices 0..189 as for
  the ideal robot;
- then per joint (leg 1 joint 1, leg 1 joint 2, ..., leg 6 joint 3) five joint terms,
  each the coefficient of one column of the joint's effort (joint side, [N m] revolute,
  [N] prismatic)::

      IA{j}_{i}  armature              x qddot_j        [kg m^2 or kg]
      FV{j}_{i}  viscous friction      x qdot_j         [N m s/rad or N s/m]
      FC{j}_{i}  Coulomb friction      x sign(qdot_j)   [N m or N]
      K{j}_{i}   stiffness             x q_j            [N m/rad or N/m]
      OF{j}_{i}  offset (constant)     x 1              [N m or N]

  with ``sign`` the model's own (:func:`~stewart_pin.description.leg_architecture.coulomb_sign`:
  0 within :data:`~stewart_pin.description.leg_architecture.COULOMB_DEAD_BAND` of rest).

Every term of a joint's :class:`~stewart_pin.description.leg_architecture.JointDynamics`
is linear in these, so ``Gamma = W chi`` holds exactly, with no known remainder:

- ``IA = armature + ratio^2 rotor_inertia`` (the rotor's inertia reflected through the
  gear or screw: :attr:`JointDynamics.total_armature`);
- ``FV = viscous + damping`` (the damper acts as viscous friction);
- ``FC = coulomb``;
- ``K = stiffness`` and ``OF = -stiffness rest_position``: the spring
  ``K (q - q0) = K q + OF``.

Passive joints carry their terms too: they act on the actuators through the closure
(``Jp^T [I3; L_i^] J_i^-T``), like the links' inertia. ``W`` gives the *joint-side*
efforts of the actuated joints (what :meth:`StewartRobot.inverse_dynamics` returns by
default); the motor side divides row i by the actuated joint's transmission ratio, a
known constant and not a parameter (:func:`actuator_ratios`; the rotor's own inertia is
already in IA, reflected to the joint side).

The general ``W`` is built as the inverse dynamic model of
:mod:`stewart_pin.dynamics.leg_chain_dynamics` is: ``H_i = Y_i chi_i`` from
``pin.computeJointTorqueRegressor`` on the six chains (each body's frame is its MDH link
frame, so the only conversion is Pinocchio's parameter order to Khalil's), plus the joint
term columns, projected by the closure ``Jp^T [I3; L_i^] J_i^-T``, and the platform's
Newton-Euler regressor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from stewart_pin._checks import check_array
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._so3 import cross
from stewart_pin._typing import Accels, FloatArray, JointValues, Poses, Twists
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import KHALIL_NAMES, PIN_TO_KHALIL
from stewart_pin.description.leg_architecture import JointDynamics, coulomb_sign
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.dynamics.chain_leg_dynamics import chain_parameters
from stewart_pin.dynamics.closed_loop import check_finite
from stewart_pin.dynamics.leg_chain_dynamics import GeneralLegDynamics
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.exceptions import JointDynamicsError
from stewart_pin.formats.urdf import leg_joint
from stewart_pin.kinematics import leg_chains
from stewart_pin.kinematics.jacobians import check_condition, inverse_jacobian_batch, leg_state
from stewart_pin.models.leg_chains import leg_joint_name

N_STANDARD = 190

#: Names of the 190 standard parameters of the ideal 6-UPS robot, in the regressor's
#: column order (also the first 190 of a general robot's).
STANDARD_NAMES: tuple[str, ...] = tuple(
    [f"{p}{j}_{i}" for i in range(1, 7) for j in (1, 2, 3) for p in KHALIL_NAMES]
    + [f"{p}_P" for p in KHALIL_NAMES]
)

#: The five joint terms of each joint of a general robot, in their column order: armature,
#: viscous friction, Coulomb friction, stiffness, offset (constant effort).
JOINT_TERM_NAMES = ("IA", "FV", "FC", "K", "OF")
#: Joint terms per joint.
N_JOINT_TERMS = len(JOINT_TERM_NAMES)
#: Standard parameters of a robot with general legs: 190 inertial + 18 joints x 5 terms.
N_STANDARD_GENERAL = N_STANDARD + 18 * N_JOINT_TERMS
#: Index of the first joint term of a general robot: that of joint j (0-based) of leg i
#: (0-based), term t, is ``JOINT_TERMS_START + 15 i + 5 j + t``.
JOINT_TERMS_START = N_STANDARD

#: Names of the 280 standard parameters of a robot with general legs.
GENERAL_STANDARD_NAMES: tuple[str, ...] = STANDARD_NAMES + tuple(
    f"{t}{j}_{i}" for i in range(1, 7) for j in (1, 2, 3) for t in JOINT_TERM_NAMES
)


def _chain_offsets(desc: RobotDescription) -> tuple[list[list[int]], int, list[list[int]]]:
    """Where each chain leg link's 10 parameters start, the platform's, and where each
    joint's ``IA`` is (:func:`~.chain_leg_dynamics.chain_parameters`' order)."""
    legs = desc.chain_legs or ()
    links, k = [], 0
    for leg in legs:
        links.append([k + 10 * j for j in range(leg.n_joints)])
        k += 10 * leg.n_joints
    platform, k = k, k + 10
    joints = []
    for leg in legs:
        joints.append([k + N_JOINT_TERMS * j for j in range(leg.n_joints)])
        k += N_JOINT_TERMS * leg.n_joints
    return links, platform, joints


def _chain_parameter_groups(desc: RobotDescription) -> ParameterGroups:
    links, platform, terms = _chain_offsets(desc)
    bodies = [
        BodyParameters(f"leg {i + 1} link {j + 1}", slice(k, k + 10))
        for i, row in enumerate(links)
        for j, k in enumerate(row)
    ]
    bodies.append(BodyParameters("platform", slice(platform, platform + 10)))
    joints = [
        JointParameters(
            f"leg {i + 1} joint {j + 1}",
            i + 1,
            j + 1,
            joint.kind,
            k,
            k + 1,
            k + 2,
            k + 3,
            k + 4,
            leg.actuated == j + 1,
        )
        for i, (leg, row) in enumerate(zip(desc.chain_legs or (), terms, strict=True))
        for j, (joint, k) in enumerate(zip(leg.joints, row, strict=True))
    ]
    return ParameterGroups(tuple(bodies), tuple(joints), standard_parameter_names(desc))


def _chain_with_standard_parameters(desc: RobotDescription, chi: FloatArray) -> RobotDescription:
    links, platform, terms = _chain_offsets(desc)
    legs = []
    for i, (leg, rows, starts) in enumerate(zip(desc.chain_legs or (), links, terms, strict=True)):
        joints = tuple(
            replace(
                joint,
                dynamics=_joint_dynamics_from_terms(
                    joint.dynamics, chi[k : k + N_JOINT_TERMS], f"leg {i + 1} joint {j + 1}"
                ),
            )
            for j, (joint, k) in enumerate(zip(leg.joints, starts, strict=True))
        )
        inertia = np.array([chi[k : k + 10] for k in rows])
        legs.append(leg.replace(joints=joints, inertia=inertia))
    return desc.replace(chain_legs=tuple(legs), platform_inertia=chi[platform : platform + 10])


def standard_parameter_names(desc: RobotDescription) -> tuple[str, ...]:
    """The names of ``desc``'s standard parameters, in the regressor's column order: the
    190 of :data:`STANDARD_NAMES` for the ideal 6-UPS robot, the 280 of
    :data:`GENERAL_STANDARD_NAMES` (the same 190, then ``IA FV FC K OF`` per joint) for
    general legs (module docstring); chain legs: :func:`~.chain_leg_dynamics.chain_parameters`."""
    if desc.chain_legs is not None:
        return chain_parameters(desc)[1]
    return STANDARD_NAMES if desc.legs is None else GENERAL_STANDARD_NAMES


def joint_index(leg: int, joint: int, term: str) -> int:
    """The standard index of joint term ``term`` (one of :data:`JOINT_TERM_NAMES`) of
    joint ``joint`` (1..3) of leg ``leg`` (1..6) of a general robot."""
    return JOINT_TERMS_START + 15 * (leg - 1) + 5 * (joint - 1) + JOINT_TERM_NAMES.index(term)


def joint_terms(dynamics: JointDynamics) -> FloatArray:
    """``[IA, FV, FC, K, OF]`` of one joint's dynamics (module docstring):
    ``[armature + ratio^2 rotor_inertia, viscous + damping, coulomb, stiffness,
    -stiffness rest_position]``."""
    return np.array(
        [
            dynamics.total_armature,
            dynamics.viscous + dynamics.damping,
            dynamics.coulomb,
            dynamics.stiffness,
            -dynamics.stiffness * dynamics.rest_position,
        ]
    )


def standard_parameters(desc: RobotDescription) -> FloatArray:
    """The standard parameters ``chi`` of a description, in the regressor's order: (190,)
    for the ideal 6-UPS robot, (280,) for general legs (with the joint terms of
    :func:`joint_terms`); chain legs: :func:`~.chain_leg_dynamics.chain_parameters`."""
    if desc.chain_legs is not None:
        return chain_parameters(desc)[0]
    chi = np.concatenate([desc.leg_inertia.reshape(-1), desc.platform_inertia])
    if desc.legs is None:
        return chi
    terms = [joint_terms(joint.dynamics) for leg in desc.legs for joint in leg.joints]
    return np.concatenate([chi, np.concatenate(terms)])


def _joint_dynamics_from_terms(
    dynamics: JointDynamics, terms: FloatArray, where: str
) -> JointDynamics:
    """``dynamics`` with its five terms set to ``terms`` (``[IA, FV, FC, K, OF]``), keeping
    what the terms cannot tell apart as far as possible (see
    :func:`with_standard_parameters`)."""
    ia, fv, fc, k, of = (float(x) for x in terms)
    reflected = dynamics.transmission_ratio**2 * dynamics.rotor_inertia
    if ia >= reflected:
        armature, rotor = ia - reflected, dynamics.rotor_inertia
    else:  # the rotor alone would be more than IA: the rotor takes it all
        armature, rotor = 0.0, dynamics.rotor_inertia * (ia / reflected) if reflected else 0.0
    viscous, damping = (
        (fv - dynamics.damping, dynamics.damping)
        if fv >= dynamics.damping
        else (
            0.0,
            fv,
        )
    )
    if k != 0.0:
        rest = -of / k
    elif of == 0.0:
        rest = dynamics.rest_position
    else:
        raise JointDynamicsError(
            f"{where}: an offset (constant effort) OF = {of:.9g} with a zero stiffness K "
            "cannot be written as joint dynamics (a joint's constant effort is its spring's "
            "-K q0); give K > 0 or OF = 0",
            "offset",
            of,
        )
    try:
        return replace(
            dynamics,
            armature=armature,
            rotor_inertia=rotor,
            viscous=viscous,
            damping=damping,
            coulomb=fc,
            stiffness=k,
            rest_position=rest,
        )
    except JointDynamicsError as e:
        raise JointDynamicsError(f"{where}: {e}", e.field, e.value) from e


def with_standard_parameters(desc: RobotDescription, chi: FloatArray) -> RobotDescription:
    """A copy of ``desc`` with its standard parameters replaced by ``chi`` (validated).

    ``chi``: (190,) for the ideal 6-UPS robot, (280,) for general legs
    (:func:`standard_parameter_names`). The inertial parameters are replaced as they are.
    The joint terms map back onto each joint's
    :class:`~stewart_pin.description.leg_architecture.JointDynamics` as far as that is
    invertible; what they cannot tell apart keeps the description's split:

    - IA: ``armature = IA - ratio^2 rotor_inertia`` (the transmission and the rotor kept);
      when IA is below the reflected rotor inertia, ``armature = 0`` and the rotor
      inertia is scaled down to ``IA / ratio^2``;
    - FV: ``viscous = FV - damping`` (damping kept); when FV is below the damping,
      ``viscous = 0``, ``damping = FV``;
    - FC: ``coulomb``; K: ``stiffness``;
    - OF: ``rest_position = -OF / K`` when ``K != 0``; with ``K = 0`` an offset has no
      place in the joint dynamics (:class:`JointDynamicsError`), and ``OF = 0`` keeps the
      rest position (which then acts on nothing).

    Negative terms (a negative IA, FV, FC or K) are refused by the joint dynamics
    (:class:`JointDynamicsError` naming the joint), non-physical inertial parameters by
    the description (:class:`~stewart_pin.exceptions.InertiaError`). So
    ``standard_parameters(with_standard_parameters(desc, chi)) == chi`` up to round-off.
    """
    n = len(standard_parameter_names(desc))
    chi = check_array(chi, (n,), "standard parameters chi")
    if desc.chain_legs is not None:
        return _chain_with_standard_parameters(desc, chi)
    changes: dict[str, object] = {
        "leg_inertia": chi[:180].reshape(6, 3, 10),
        "platform_inertia": chi[180:190],
    }
    if desc.legs is not None:
        legs = []
        for i, leg in enumerate(desc.legs):
            dyns = []
            for j, joint in enumerate(leg.joints):
                start = joint_index(i + 1, j + 1, "IA")
                terms = chi[start : start + N_JOINT_TERMS]
                where = f"leg {i + 1} joint {j + 1}"
                dyns.append(_joint_dynamics_from_terms(joint.dynamics, terms, where))
            legs.append(leg.with_dynamics(dyns))
        changes["legs"] = tuple(legs)
    return desc.replace(**changes)


# ---------------------------------------------------------------------------- groups
@dataclass(frozen=True)
class BodyParameters:
    """A body's 10 inertial parameters in the standard vector.

    Attributes:
        name: ``"leg i link j"`` or ``"platform"``. index: the slice of its 10 parameters
        (Khalil's order, about the origin of its own frame: MDH frame ji, or Fp).
    """

    name: str
    index: slice


@dataclass(frozen=True)
class JointParameters:
    """A joint's five terms in the standard vector (general legs).

    Attributes:
        name: ``"leg i joint j"``. leg, joint: 1-based. kind: ``"revolute"`` or
        ``"prismatic"``. armature, viscous, coulomb, stiffness, offset: the indices of
        IA, FV, FC, K, OF. actuated: whether the joint is its leg's actuated one.
    """

    name: str
    leg: int
    joint: int
    kind: str
    armature: int
    viscous: int
    coulomb: int
    stiffness: int
    offset: int
    actuated: bool

    @property
    def index(self) -> slice:
        """The slice of the five terms ``IA FV FC K OF``."""
        return slice(self.armature, self.offset + 1)

    @property
    def nonnegative(self) -> tuple[int, int, int, int]:
        """The indices of the terms a real joint has non-negative (IA, FV, FC, K); the
        offset OF takes either sign."""
        return (self.armature, self.viscous, self.coulomb, self.stiffness)


@dataclass(frozen=True)
class ParameterGroups:
    """Which standard parameters belong to which body and joint.

    Attributes:
        bodies: the 19 bodies (18 leg links, leg-major, then the platform), each with the
            slice of its 10 inertial parameters: each block is one rigid body's, so its
            pseudo-inertia must be positive semi-definite.
        joints: the 18 joints' terms (empty for the ideal 6-UPS robot, which has none).
        names: the standard parameter names (:func:`standard_parameter_names`).
    """

    bodies: tuple[BodyParameters, ...]
    joints: tuple[JointParameters, ...]
    names: tuple[str, ...]

    @property
    def n(self) -> int:
        """The number of standard parameters."""
        return len(self.names)

    @property
    def nonnegative(self) -> np.ndarray:
        """The indices of every joint term that must be non-negative (IA, FV, FC, K)."""
        return np.array([k for jp in self.joints for k in jp.nonnegative], dtype=int)


def parameter_groups(desc: RobotDescription) -> ParameterGroups:
    """The bodies' and joints' parameter indices of ``desc``'s standard vector."""
    if desc.chain_legs is not None:
        return _chain_parameter_groups(desc)
    bodies = [
        BodyParameters(f"leg {i + 1} link {j + 1}", slice(30 * i + 10 * j, 30 * i + 10 * j + 10))
        for i in range(6)
        for j in range(3)
    ]
    bodies.append(BodyParameters("platform", slice(180, 190)))
    joints = []
    if desc.legs is not None:
        for i, leg in enumerate(desc.legs):
            for j, joint in enumerate(leg.joints):
                k = joint_index(i + 1, j + 1, "IA")
                joints.append(
                    JointParameters(
                        f"leg {i + 1} joint {j + 1}",
                        i + 1,
                        j + 1,
                        joint.kind,
                        k,
                        k + 1,
                        k + 2,
                        k + 3,
                        k + 4,
                        leg.actuated == j + 1,
                    )
                )
    return ParameterGroups(tuple(bodies), tuple(joints), standard_parameter_names(desc))


def actuator_ratios(desc: RobotDescription) -> FloatArray:
    """(6,) the actuated joints' transmission ratios (motor rate per joint rate; 1 without
    a transmission, and for the ideal 6-UPS robot): the motor-side regressor is
    ``W / ratio[:, None]`` (row i divided by actuator i's ratio)."""
    if desc.chain_legs is not None:
        legs_any: tuple[Any, ...] = desc.chain_legs
        return np.array(
            [leg.joints[leg.actuated - 1].dynamics.transmission_ratio for leg in legs_any]
        )
    if desc.legs is None:
        return np.ones(6)
    return np.array(
        [leg.joints[leg.actuated - 1].dynamics.transmission_ratio for leg in desc.legs]
    )


# ---------------------------------------------------------------------------- 6-UPS
def _leg_columns(legs: LegDynamics) -> FloatArray:
    """(6, 3, 10) columns of each leg body in Pinocchio's joint-torque regressor, permuted
    to Khalil's order."""
    return _chain_columns(legs.model, leg_joint)


def _chain_columns(model: pin.Model, name: Callable[[int, int], str]) -> np.ndarray:
    """(6, 3, 10) columns of joint ``name(i, j)``'s body (1-based i, j) in Pinocchio's
    joint-torque regressor of ``model``, in Khalil's order (one body per joint)."""
    cols = np.empty((6, 3, 10), dtype=int)
    for i in range(6):
        for j in range(3):
            jid = model.getJointId(name(i + 1, j + 1))
            cols[i, j] = 10 * (jid - 1) + PIN_TO_KHALIL
    return cols


def _regressors(
    legs: LegDynamics,
    cols: np.ndarray,
    q: JointValues,
    qd: JointValues,
    qdd: JointValues,
    gravcomp: FloatArray | None = None,
) -> FloatArray:
    """``Y_i`` (N, 6, 3, 30) with ``H_i = Y_i chi_i`` (links 1..3, Khalil order), columns
    ``cols`` (6, 3, 10) of the model's joint-torque regressor. ``gravcomp`` (6, 3): each
    link's gravity compensation ``c``, its columns' gravity part (the regressor at rest)
    scaled by ``1 - c`` (its weight ``(1 - c) m g``; the efforts stay linear in the same
    parameters)."""
    cols = cols.reshape(6, 30)
    rows = legs.blocks  # (6, 3) velocity index of each leg joint
    out = np.empty((*q.shape, 30))
    m, d = legs.model, legs.data
    scale = None
    if gravcomp is not None and np.any(gravcomp):
        scale = np.repeat(np.asarray(gravcomp, dtype=float), 10, axis=1)[:, None, :]
        zero = np.zeros(m.nv)
    for n in range(q.shape[0]):
        qn = legs.pack(q[n])
        Y = pin.computeJointTorqueRegressor(m, d, qn, legs.pack(qd[n]), legs.pack(qdd[n]))
        out[n] = Y[rows[:, :, None], cols[:, None, :]]
        if scale is not None:
            Yg = pin.computeJointTorqueRegressor(m, d, qn, zero, zero)
            out[n] -= scale * Yg[rows[:, :, None], cols[:, None, :]]
    return out


def leg_regressors(
    legs: LegDynamics, q: JointValues, qd: JointValues, qdd: JointValues
) -> FloatArray:
    """``Y_i`` with ``H_i = Y_i chi_i``: shape (N, 6, 3, 30), Khalil order, links 1..3."""
    return _regressors(legs, _leg_columns(legs), q, qd, qdd)


def platform_regressor(
    desc: RobotDescription | GeneralHexapod, poses: Poses, twists: Twists, accels: Accels
) -> FloatArray:
    """``Y_p`` with ``F_p = Y_p chi_p`` (eq. 24): shape (N, 6, 10), wrench in F0 about O_p
    (gravity less the platform's compensation, ``(1 - c_p) g``)."""
    out = np.empty((poses.shape[0], 6, 10))
    g = (1.0 - desc.platform_gravcomp) * np.asarray(desc.gravity)
    for n in range(poses.shape[0]):
        R = poses[n, :3, :3]
        w_b = R.T @ twists[n, 3:]
        v_b = R.T @ twists[n, :3]
        # Body spatial acceleration (Featherstone) with gravity as a fictitious acceleration.
        a_lin = R.T @ (accels[n, :3] - g) - np.cross(w_b, v_b)
        Y = pin.bodyRegressor(pin.Motion(v_b, w_b), pin.Motion(a_lin, R.T @ accels[n, 3:]))
        out[n, :3] = R @ Y[:3, PIN_TO_KHALIL]
        out[n, 3:] = R @ Y[3:, PIN_TO_KHALIL]
    return out


def _project(J_inv: FloatArray, leg_J_inv: FloatArray, L: FloatArray, Y: FloatArray) -> FloatArray:
    """``[I3; L_i^] J_i^-T Y_i`` (N, 6, 6, c): each leg's columns (N, 6, 3, c) as wrenches
    on the platform about O_p, in F0 (eq. 22-23)."""
    Yx = np.einsum("nkji,nkjc->nkic", leg_J_inv, Y)  # J_i^-T Y_i at P_i, (N, 6, 3, c)
    c = Y.shape[-1]
    L = L[..., None, :]  # (N, 6, 1, 3)
    moment = cross(np.broadcast_to(L, (*Yx.shape[:2], c, 3)), np.swapaxes(Yx, -1, -2))
    return np.concatenate([Yx, np.swapaxes(moment, -1, -2)], axis=-2)


def regressor_batch(
    desc: RobotDescription,
    legs: LegDynamics,
    poses: Poses,
    twists: Twists,
    accels: Accels,
    max_condition: float,
) -> FloatArray:
    """``W`` for validated batches: shape (N, 6, 190); :class:`NumericalError` when not
    finite."""
    state = leg_state(desc, poses, twists, accels)
    J_inv = inverse_jacobian_batch(desc, poses)
    check_condition(J_inv, max_condition, desc)
    assert state.qddot is not None  # accels given
    Y = leg_regressors(legs, state.q, state.qdot, state.qddot)  # (N, 6, 3, 30)
    wrench = _project(J_inv, state.J_inv, state.L, Y)  # (N, 6, 6, 30)
    N = poses.shape[0]
    F = np.empty((N, 6, N_STANDARD))
    F[:, :, :180] = np.moveaxis(wrench, 1, 2).reshape(N, 6, 180)
    F[:, :, 180:] = platform_regressor(desc, poses, twists, accels)
    W = np.asarray(np.linalg.solve(np.swapaxes(J_inv, 1, 2), F), dtype=np.float64)
    return check_finite(W, "regressor W")


# ---------------------------------------------------------------------------- general legs
def joint_term_columns(q: JointValues, qd: JointValues, qdd: JointValues) -> FloatArray:
    """(N, 6, 3, 15): each leg's joint efforts per joint term, columns ``IA FV FC K OF``
    of joint 1, then joint 2, then joint 3: joint j's row holds
    ``[qddot_j, qdot_j, sign(qdot_j), q_j, 1]`` (``sign`` with the model's dead band) in
    its own five columns, zeros elsewhere."""
    out = np.zeros((*q.shape, 3 * N_JOINT_TERMS))
    for j in range(3):
        c = N_JOINT_TERMS * j
        out[..., j, c] = qdd[..., j]
        out[..., j, c + 1] = qd[..., j]
        out[..., j, c + 2] = coulomb_sign(qd[..., j])
        out[..., j, c + 3] = q[..., j]
        out[..., j, c + 4] = 1.0
    return out


def general_regressor_batch(
    robot: GeneralHexapod,
    legs_dyn: GeneralLegDynamics,
    poses: Poses,
    twists: Twists,
    accels: Accels,
    max_condition: float = leg_chains.MAX_CONDITION,
    check_limits: bool = False,
) -> FloatArray:
    """``W`` of a robot with general legs for validated batches: shape (N, 6, 280), columns
    in :data:`GENERAL_STANDARD_NAMES` order, joint-side efforts;
    :class:`NumericalError` when not finite, :class:`SingularityError` past
    ``max_condition``, :class:`LegJointLimitError` outside a joint's limits with
    ``check_limits``.

    ``W = Jp^T [[I3; L_i^] J_i^-T [Y_i, Y_joint,i] ..., Y_p]`` with ``Y_i`` from
    ``pin.computeJointTorqueRegressor`` on the six chains (``legs_dyn.model``; it leaves
    out ``model.armature``, which is the IA columns here; a link's gravity part scaled by
    ``1 - c`` for its gravity compensation ``c``) and ``Y_joint,i`` of
    :func:`joint_term_columns`.
    """
    legs = leg_chains.leg_state(robot, poses, twists, accels, check_limits)
    J_inv = leg_chains.inverse_jacobian_from_legs(robot, legs.J_inv, legs.L)
    leg_chains.check_parallel(robot, J_inv, max_condition)
    cols = _chain_columns(legs_dyn.model, leg_joint_name)
    Y = _regressors(legs_dyn, cols, legs.q, legs.qdot, legs.qddot, robot.leg_gravcomp)
    Yj = joint_term_columns(legs.q, legs.qdot, legs.qddot)  # (N, 6, 3, 15)
    wrench = _project(J_inv, legs.J_inv, legs.L, np.concatenate([Y, Yj], axis=-1))
    N = poses.shape[0]
    F = np.empty((N, 6, N_STANDARD_GENERAL))
    links = np.moveaxis(wrench[..., :30], 1, 2).reshape(N, 6, 180)
    F[:, :, :180] = links
    F[:, :, 180:190] = platform_regressor(robot, poses, twists, accels)
    F[:, :, 190:] = np.moveaxis(wrench[..., 30:], 1, 2).reshape(N, 6, 90)
    W = np.asarray(np.linalg.solve(np.swapaxes(J_inv, 1, 2), F), dtype=np.float64)
    return check_finite(W, "regressor W")


__all__ = [
    "GENERAL_STANDARD_NAMES",
    "JOINT_TERM_NAMES",
    "N_STANDARD",
    "N_STANDARD_GENERAL",
    "STANDARD_NAMES",
    "BodyParameters",
    "JointParameters",
    "ParameterGroups",
    "actuator_ratios",
    "general_regressor_batch",
    "joint_index",
    "joint_term_columns",
    "joint_terms",
    "leg_regressors",
    "parameter_groups",
    "platform_regressor",
    "regressor_batch",
    "standard_parameter_names",
    "standard_parameters",
    "with_standard_parameters",
]
