"""Inverse and direct dynamics of robots with general three-joint legs, through the
paper's closure layer (``general-legs.md``; eq. 20-38 with ``a_i`` replaced by the
actuated row of ``J_i^-1 G_i``).

Each leg's own dynamics come from Pinocchio on the 18-dof model of the six chains
(:func:`stewart_pin.models.leg_chains.build_leg_chains`), with the joint terms:

    H_i = A_i qddot_i + h_i,   A_i = CRBA (with the armature, ``model.armature``),
    h_i = nonlinear effects + (Fv + D) qdot + Fc sign(qdot) + K (q - q0) - g_c(q_i),

``g_c`` the joint efforts of the links' gravity compensation (``leg_gravcomp``: link b's
weight is ``(1 - c_b) m_b g``, the force ``-c_b m_b g`` at its centre of mass removed):
Pinocchio's generalized gravity of the same chains with each link's mass and first moments
scaled by ``c_b`` (gravity is linear in them); the platform's weight is scaled likewise
(:func:`~stewart_pin.dynamics.closed_loop.platform_gravity`).

``sign(0) = 0``: at zero joint velocity the Coulomb term is zero (no stiction), in the
inverse and in the direct model (the direct model is explicit in the velocity); rates
within :data:`~stewart_pin.description.leg_architecture.COULOMB_DEAD_BAND` count as zero.

- IDM: ``Gamma = Jp^T (F_p + sum_i [I3; L_i^] J_i^-T H_i)``, the actuated joints' efforts
  on the joint side [N or N m]; with a transmission, ``Gamma / ratio`` on the motor side.
- DDM: ``A_robot Vdot + h_robot = Jp^-T Gamma``,
  ``A_robot = Ip + sum G_i^T A_xi G_i``, ``A_xi = J_i^-T A_i J_i^-1``,
  ``h_robot = platform bias + sum G_i^T (A_xi (w x (w x L_i) - Jdot_i qdot_i) + J_i^-T h_i)``,
  solved by Cholesky.
- Power: ``Gamma . qdot_a = dE/dt + sum (Fv + D) qdot^2 + Fc |qdot|`` with ``E`` the
  kinetic energy (armature included), gravity's potential and the springs'.

Batches throughout: poses (N, 4, 4), twists and classical accelerations (N, 6) in F0.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._checks import check_poses, check_states
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin.description.leg_architecture import JointDynamics, coulomb_sign
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.dynamics.closed_loop import (
    closure_cartesian_dynamics,
    closure_direct_dynamics,
    closure_inverse_dynamics,
    platform_energy,
    platform_terms,
)
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.kinematics.leg_chains import (
    MAX_CONDITION,
    LegKinematics,
    check_parallel,
    inverse_jacobian_from_legs,
    leg_state,
)
from stewart_pin.models.leg_chains import build_leg_chains, leg_joint_name


# ---------------------------------------------------------------------------- joint terms
@dataclass(frozen=True)
class JointTermArrays:
    """The joint dynamics of the 18 joints as (6, 3) arrays."""

    armature: np.ndarray
    viscous: np.ndarray  # viscous friction + damper
    coulomb: np.ndarray
    stiffness: np.ndarray
    rest: np.ndarray
    ratio: np.ndarray  # transmission ratio (1 without)

    @classmethod
    def of(cls, robot: GeneralHexapod) -> JointTermArrays:
        def get(f: Callable[[JointDynamics], float]) -> np.ndarray:
            return np.array([[f(j.dynamics) for j in leg.joints] for leg in robot.legs])

        return cls(
            armature=get(lambda d: d.total_armature),
            viscous=get(lambda d: d.viscous + d.damping),
            coulomb=get(lambda d: d.coulomb),
            stiffness=get(lambda d: d.stiffness),
            rest=get(lambda d: d.rest_position),
            ratio=get(lambda d: d.transmission_ratio),
        )

    def efforts(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """Friction, spring and damper efforts (N, 6, 3), armature excluded;
        ``sign(0) = 0``."""
        return (
            self.viscous * qdot
            + self.coulomb * coulomb_sign(qdot)
            + self.stiffness * (q - self.rest)
        )

    def dissipated_power(self, qdot: np.ndarray) -> np.ndarray:
        """``sum (Fv + D) qdot^2 + Fc |qdot|`` over the 18 joints, (N,) [W]."""
        return np.einsum("kj,nkj->n", self.viscous, qdot**2) + np.einsum(
            "kj,nkj->n", self.coulomb, np.abs(qdot)
        )

    def spring_energy(self, q: np.ndarray) -> np.ndarray:
        """``sum 1/2 K (q - q0)^2``, (N,) [J]."""
        return 0.5 * np.einsum("kj,nkj->n", self.stiffness, (q - self.rest) ** 2)


class GeneralLegDynamics(LegDynamics):
    """Pinocchio's RNEA / CRBA / nonlinear effects on the six chains plus the joint terms,
    for batches (N, 6, 3): :class:`~stewart_pin.dynamics.leg_dynamics.LegDynamics`'s loops
    on the general chains (:func:`~stewart_pin.models.leg_chains.build_leg_chains`)."""

    def __init__(self, robot: GeneralHexapod) -> None:
        self.robot = robot
        self._attach(*build_leg_chains(robot))
        self.terms = JointTermArrays.of(robot)
        self.compensated = _compensated_model(self.model, robot)
        self._compensated_data = (
            None if self.compensated is None else self.compensated.createData()
        )

    def compensation_efforts(self, q: np.ndarray) -> np.ndarray:
        """``g_c`` (N, 6, 3) [N m or N]: the joint efforts of the links' gravity
        compensation (module docstring), zeros when no link has one."""
        if self.compensated is None:
            return np.zeros(q.shape)
        m, d = self.compensated, self._compensated_data
        out = np.empty(q.shape)
        for n in range(q.shape[0]):
            out[n] = self._unpack(pin.computeGeneralizedGravity(m, d, self.pack(q[n])))
        return out

    def inverse_dynamics(self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        """``H_i`` (N, 6, 3) [N m or N]: RNEA (armature included) plus the joint terms,
        less the gravity compensation."""
        H = super().inverse_dynamics(q, qdot, qddot) + self.terms.efforts(q, qdot)
        return H - self.compensation_efforts(q) if self.compensated is not None else H

    def mass_and_bias(self, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(A_i (N, 6, 3, 3), h_i (N, 6, 3))``: CRBA with the armature, and the nonlinear
        effects plus the joint terms, less the gravity compensation."""
        A, h = super().mass_and_bias(q, qdot)
        h = h + self.terms.efforts(q, qdot)
        return A, h - self.compensation_efforts(q) if self.compensated is not None else h

    def energy(self, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic (armature included: Pinocchio >= 4.1 counts ``model.armature``) and
        potential (gravity less its compensation, and springs) energy of the six legs, each
        (N,) [J]; gravity's potential is zero at the origin of F0."""
        kinetic, potential = super().energy(q, qdot)
        potential = potential + self.terms.spring_energy(q)
        if self.compensated is not None:
            m, d = self.compensated, self._compensated_data
            for n in range(q.shape[0]):
                potential[n] -= pin.computePotentialEnergy(m, d, self.pack(q[n]))
        return kinetic, potential


def _compensated_model(model: pin.Model, robot: GeneralHexapod) -> pin.Model | None:
    """A copy of the six chains ``model`` whose link b has its mass and first moments
    scaled by its gravity compensation ``c_b`` (``robot.leg_gravcomp``): its generalized
    gravity is the joint efforts of the forces ``c_b m_b g`` at the centres of mass, and
    its potential energy theirs. ``None`` when no link has a compensation."""
    if not np.any(robot.leg_gravcomp):
        return None
    out = pin.Model(model)
    for k in range(6):
        for j in range(3):
            jid = out.getJointId(leg_joint_name(k + 1, j + 1))
            c = float(robot.leg_gravcomp[k, j])
            I = out.inertias[jid]
            out.inertias[jid] = pin.Inertia(c * I.mass, I.lever, c * I.inertia)
    return out


# ---------------------------------------------------------------------------- closure layer
# The paper's closure layer itself is shared with the 6-UPS path:
# :func:`~stewart_pin.dynamics.closed_loop.closure_inverse_dynamics` and its siblings.
@dataclass(frozen=True)
class GeneralInverseDynamics:
    """The inverse model with its intermediate terms (batches).

    Attributes:
        gamma: (N, 6) actuated joint efforts, joint side [N or N m].
        motor: (N, 6) the same on the motor side, ``gamma / ratio`` (``gamma`` where a
            joint has no transmission) [N m or N].
        H: (N, 6, 3) each leg's ``H_i`` (joint terms included). H_x: (N, 6, 3)
            ``J_i^-T H_i`` at P_i in F0. F_p: (N, 6) the platform's wrench about O_p.
        J_inv: (N, 6, 6) ``Jp^-1``. legs: the :class:`LegKinematics` used.
        joint_efforts: (N, 6, 3) the actuators' effort on every joint, joint side:
            ``gamma`` on the actuated joint, 0 on the two passive ones [N or N m].
    """

    gamma: np.ndarray
    motor: np.ndarray
    H: np.ndarray
    H_x: np.ndarray
    F_p: np.ndarray
    J_inv: np.ndarray
    legs: LegKinematics
    joint_efforts: np.ndarray


def inverse_dynamics_batch(
    robot: GeneralHexapod,
    legs_dyn: GeneralLegDynamics,
    poses: np.ndarray,
    twists: np.ndarray,
    accels: np.ndarray,
    max_condition: float = MAX_CONDITION,
    check_limits: bool = False,
) -> GeneralInverseDynamics:
    """``Gamma = Jp^T (F_p + sum_i [I3; L_i^] J_i^-T H_i)`` for validated batches
    (``check_limits``: :class:`LegJointLimitError` outside a joint's limits)."""
    legs = leg_state(robot, poses, twists, accels, check_limits)
    J_inv = inverse_jacobian_from_legs(robot, legs.J_inv, legs.L)
    check_parallel(robot, J_inv, max_condition)
    H = legs_dyn.inverse_dynamics(legs.q, legs.qdot, legs.qddot)
    plat = platform_terms(robot, poses, twists)  # type: ignore[arg-type] # duck-typed
    gamma, H_x, F_p, _ = closure_inverse_dynamics(J_inv, legs.J_inv, legs.L, H, plat, accels)
    ratio = legs_dyn.terms.ratio[np.arange(6), robot.actuated]
    efforts = np.zeros(H.shape)
    efforts[:, np.arange(6), robot.actuated] = gamma
    return GeneralInverseDynamics(gamma, gamma / ratio, H, H_x, F_p, J_inv, legs, efforts)


@dataclass(frozen=True)
class GeneralCartesianDynamics:
    """``A_robot Vdot + h_robot = Jp^-T Gamma`` at a batch of states.

    Attributes: A_robot (N, 6, 6), h_robot (N, 6), J_inv (N, 6, 6), A_x (N, 6, 3, 3),
    h_x (N, 6, 3), legs (the :class:`LegKinematics`, ``qddot`` zero).
    """

    A_robot: np.ndarray
    h_robot: np.ndarray
    J_inv: np.ndarray
    A_x: np.ndarray
    h_x: np.ndarray
    legs: LegKinematics


def cartesian_dynamics_batch(
    robot: GeneralHexapod,
    legs_dyn: GeneralLegDynamics,
    poses: np.ndarray,
    twists: np.ndarray,
    max_condition: float = MAX_CONDITION,
    check_limits: bool = False,
) -> GeneralCartesianDynamics:
    """``A_robot`` and ``h_robot`` (general-legs.md, DDM) for validated batches."""
    legs = leg_state(robot, poses, twists, None, check_limits)
    J_inv = inverse_jacobian_from_legs(robot, legs.J_inv, legs.L)
    check_parallel(robot, J_inv, max_condition)
    A, h = legs_dyn.mass_and_bias(legs.q, legs.qdot)
    plat = platform_terms(robot, poses, twists)  # type: ignore[arg-type] # duck-typed
    A_robot, h_robot, A_x, h_x = closure_cartesian_dynamics(
        legs.J_inv, A, h, legs.L, legs.drift, twists, plat
    )
    return GeneralCartesianDynamics(A_robot, h_robot, J_inv, A_x, h_x, legs)


def direct_dynamics_batch(
    robot: GeneralHexapod,
    legs_dyn: GeneralLegDynamics,
    poses: np.ndarray,
    twists: np.ndarray,
    gammas: np.ndarray,
    max_condition: float = MAX_CONDITION,
    check_limits: bool = False,
) -> np.ndarray:
    """``Vdot = A_robot^-1 (Jp^-T Gamma - h_robot)`` (N, 6), classical in F0, by Cholesky;
    ``gammas`` (N, 6) joint-side actuated efforts."""
    cd = cartesian_dynamics_batch(robot, legs_dyn, poses, twists, max_condition, check_limits)
    return closure_direct_dynamics(cd.A_robot, cd.h_robot, cd.J_inv, gammas)


# ---------------------------------------------------------------------------- the model
class GeneralDynamics:
    """The dynamic models of a :class:`GeneralHexapod`, for one state or a batch.

    Args:
        robot: the robot. max_condition: the parallel singularity threshold.
        check_limits: refuse states with a joint outside its limits
            (:class:`LegJointLimitError`) in the inverse, direct and cartesian models
            (:class:`~stewart_pin.StewartRobot` sets it, as its 6-UPS path checks the
            stroke); energy and power are defined outside the limits too.
    """

    def __init__(
        self,
        robot: GeneralHexapod,
        max_condition: float = MAX_CONDITION,
        check_limits: bool = False,
    ) -> None:
        self.robot = robot
        self.max_condition = max_condition
        self.check_limits = check_limits
        self.legs = GeneralLegDynamics(robot)

    def inverse_dynamics(
        self, pose: Any, twist: Any, accel: Any, details: bool = False, motor: bool = False
    ) -> Any:
        """Actuated joint efforts (6,) or (N, 6) [N or N m], joint side (``motor``: motor
        side); ``details`` returns the :class:`GeneralInverseDynamics` (batched)."""
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        r = inverse_dynamics_batch(
            self.robot, self.legs, T, V, A, self.max_condition, self.check_limits
        )
        if details:
            return r
        out = r.motor if motor else r.gamma
        return out if batched else out[0]

    def direct_dynamics(self, pose: Any, twist: Any, gamma: Any) -> np.ndarray:
        """The classical acceleration of the platform (6,) or (N, 6) under the joint-side
        actuated efforts ``gamma`` (6,) or (N, 6)."""
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        out = direct_dynamics_batch(
            self.robot, self.legs, T, V, G, self.max_condition, self.check_limits
        )
        return out if batched else out[0]

    def cartesian_dynamics(self, pose: Any, twist: Any) -> GeneralCartesianDynamics:
        """``A_robot``, ``h_robot`` and their parts (batched, N = 1 for one state)."""
        _, T, V = check_states(pose, (twist, "twist"))
        return cartesian_dynamics_batch(
            self.robot, self.legs, T, V, self.max_condition, self.check_limits
        )

    def gravity_compensation(self, pose: Any) -> np.ndarray:
        """The actuated efforts holding the platform still (gravity and springs)."""
        T, batched = check_poses(pose)
        zero = np.zeros((T.shape[0], 6))
        g = inverse_dynamics_batch(
            self.robot, self.legs, T, zero, zero, self.max_condition, self.check_limits
        )
        return g.gamma if batched else g.gamma[0]

    def energy(self, pose: Any, twist: Any) -> tuple[Any, Any]:
        """Kinetic (armature included) and potential (gravity, springs) energy [J] of the
        whole robot: floats, or (N,) arrays for a batch."""
        batched, T, V = check_states(pose, (twist, "twist"))
        legs = leg_state(self.robot, T, V)
        k_legs, u_legs = self.legs.energy(legs.q, legs.qdot)
        k_p, u_p = platform_energy(self.robot, T, V)  # type: ignore[arg-type]
        k, u = k_legs + k_p, u_legs + u_p
        return (k, u) if batched else (float(k[0]), float(u[0]))

    def dissipated_power(self, pose: Any, twist: Any) -> Any:
        """Power lost in friction and dampers [W], float or (N,)."""
        batched, T, V = check_states(pose, (twist, "twist"))
        legs = leg_state(self.robot, T, V)
        p = self.legs.terms.dissipated_power(legs.qdot)
        return p if batched else float(p[0])

    def actuator_rates(self, pose: Any, twist: Any) -> np.ndarray:
        """``qdot_a`` (6,) or (N, 6), the actuated joints' rates."""
        batched, T, V = check_states(pose, (twist, "twist"))
        legs = leg_state(self.robot, T, V)
        qa = legs.qdot[:, np.arange(6), self.robot.actuated]
        return qa if batched else qa[0]


__all__ = [
    "GeneralCartesianDynamics",
    "GeneralDynamics",
    "GeneralInverseDynamics",
    "GeneralLegDynamics",
    "JointTermArrays",
    "cartesian_dynamics_batch",
    "direct_dynamics_batch",
    "inverse_dynamics_batch",
]
