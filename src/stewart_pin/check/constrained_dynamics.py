"""The independent check: the robot's dynamics from Pinocchio's constrained tree.

This module shares none of the paper's algebra (it imports neither ``legs``, ``closure``
nor ``kinematics``). The robot is the 24-dof tree of
:func:`stewart_pin.models.pinocchio_models.build_tree`
(six 3-dof legs, the platform as a free-flyer) closed by six 3D point constraints
``c_i(q) = 0`` (origin of leg frame 3i == P_i on the platform). Only the leg joint
*positions* come from the project's inverse geometry; every velocity, acceleration and
dynamic term comes from Pinocchio:

- velocities: the 18 leg rates solve ``Jc v = 0`` given the platform's 6, with ``Jc``
  (18 x 24) from ``pin.getConstraintsJacobian``;
- inverse dynamics: the 18 leg accelerations solve ``Jc qddot + drift = 0``, where the
  drift is the constraint acceleration with the leg accelerations set to zero (classical
  point accelerations from ``pin.forwardKinematics``); then ``pin.rnea`` gives
  ``tau = M qddot + b`` and ``[S^T, Jc^T] [Gamma; lambda] = tau`` (24 x 24) gives the six
  actuator forces and the 18 constraint multipliers;
- direct dynamics: ``pin.constraintDynamics`` with ``tau = S^T Gamma`` and
  ``pin.ProximalSettings(1e-14, 0, 1)`` (one proximal iteration with ``mu = 0``: the exact
  KKT solution).

Conventions (as the rest of the package): a pose is 0Tp (4x4, or ``pin.SE3``), a twist
``[v, w]`` (6,) is the velocity of O_p and the angular velocity, both in F0 [m/s, rad/s];
an acceleration is classical ``[dv/dt, dw/dt]`` in F0 [m/s^2, rad/s^2]; ``Gamma`` (6,) [N]
are the prismatic joint forces, positive when they extend the leg. Pinocchio's free-flyer
velocity is the local body twist ``[R^T v, R^T w]`` and its acceleration the time
derivative of that local twist, ``[R^T vdot - (R^T w) x (R^T v), R^T wdot]``; the
conversions live here and nowhere else.

Robots with general legs (any robot that is not the ideal 6-UPS form, among them every
robot with a per-body gravity compensation) go to
:class:`~stewart_pin.check.leg_chain_tree.GeneralTreeSolver`: their tree with the joint
terms, and the compensating forces ``-c_b m_b g`` at the bodies' centres of mass as
external forces.

Every function takes one state or a batch with a leading N axis (a Python loop over the
states: this is a reference, not a fast path). Stroke and U-joint limits are *not*
checked (the physics is defined outside them); leg singularities raise
:class:`SingularityError`.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_states
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_energy,
    reference_inverse_dynamics,
)
from stewart_pin.check.tolerances import DDM_TOLERANCE, IDM_TOLERANCE
from stewart_pin.description import RobotDescription
from stewart_pin.description.actuator_convention import actuator_convention_of
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.exceptions import (
    InputError,
    InputTypeError,
    NumericalError,
    SingularityError,
    WorkspaceError,
)
from stewart_pin.kinematics.geometry import inverse_geometry_batch
from stewart_pin.models.pinocchio_models import TreeModel
from stewart_pin.protocols import RobotLike

__all__ = [
    "RELATIVE_FLOOR",
    "TreeSolver",
    "ValidationReport",
    "constrained_forward_dynamics",
    "constrained_inverse_dynamics",
    "constraint_dynamics_call",
    "constraint_jacobian",
    "energy",
    "relative_error",
    "tree_solver",
    "tree_state",
    "validate",
]

#: Floor of the relative errors, as a fraction of the largest reference magnitude in the
#: batch: ``err_n = max_k |a_nk - b_nk| / max(max_k |b_nk|, RELATIVE_FLOOR * max |b|)``.
RELATIVE_FLOOR = 1e-6

#: Settings of ``pin.constraintDynamics``: absolute accuracy, ``mu = 0`` (no proximal
#: regularisation), one iteration: an exact KKT solve.
_PROXIMAL = (1e-14, 0.0, 1)


class TreeSolver:
    """Pinocchio data for one robot's tree, with ``initConstraintDynamics`` done once."""

    def __init__(self, tree: TreeModel) -> None:
        self.model = tree.model
        self.data = tree.model.createData()
        self.cmodels = pin.StdVec_RigidConstraintModel()
        self.cdatas = pin.StdVec_RigidConstraintData()
        for cm in tree.constraints:
            self.cmodels.append(cm)
            self.cdatas.append(cm.createData())
        pin.initConstraintDynamics(self.model, self.data, self.cmodels, self.cdatas)
        self.settings = pin.ProximalSettings(*_PROXIMAL)
        self.q_ff = np.asarray(tree.platform_q_index)
        self.v_ff = np.asarray(tree.platform_v_index)
        self.q_legs = np.asarray(tree.leg_q_index).ravel()
        self.v_legs = np.asarray(tree.leg_v_index).ravel()
        self.v_act = np.asarray(tree.actuated_v_index)
        self.nv = tree.model.nv


_SOLVERS: weakref.WeakKeyDictionary[Any, TreeSolver] = weakref.WeakKeyDictionary()


def tree_solver(robot: RobotLike) -> TreeSolver:
    if not hasattr(robot, "tree") or not hasattr(robot, "description"):
        raise InputTypeError(
            f"expected a StewartRobot (with .tree and .description), got {type(robot).__name__}"
        )
    try:
        return _SOLVERS[robot]
    except KeyError:
        pass
    solver = TreeSolver(robot.tree)
    _SOLVERS[robot] = solver
    return solver


# ---------------------------------------------------------------------------- inputs
def _unbatch(x: np.ndarray, batched: bool) -> np.ndarray:
    return x if batched else x[0]


# ---------------------------------------------------------------------------- one state
@contextmanager
def _at_state(n: int) -> Iterator[None]:
    """State ``n`` of a batch: a :class:`NumericalError` raised inside names it, and
    overflow warnings are silenced (the outputs are checked instead)."""
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            yield
    except NumericalError as e:
        if e.index is not None:
            raise
        raise NumericalError(e.output, n) from e


def _constraint_jacobian(s: TreeSolver, q: np.ndarray) -> np.ndarray:
    """``Jc`` (18, 24): rows 3i..3i+2 are ``R_c1^T (J_1 - J_2)`` of loop i (LOCAL frame
    of the leg-side point), from ``pin.getConstraintsJacobian``.

    ``getConstraintsJacobian`` reads the constraint datas' placements, which only
    ``cm.calc`` updates: without the ``calc`` calls it returns a stale, plausible-looking
    Jacobian.
    """
    pin.computeJointJacobians(s.model, s.data, q)
    for cm, cd in zip(s.cmodels, s.cdatas, strict=True):
        cm.calc(s.model, s.data, cd)
    return pin.getConstraintsJacobian(s.model, s.data, s.cmodels, s.cdatas)


def _solve(A: np.ndarray, b: np.ndarray, what: str) -> np.ndarray:
    """``A^-1 b``; a non-finite ``b`` (finite inputs that overflowed) raises
    :class:`NumericalError`, a singular ``A`` :class:`SingularityError`."""
    if not np.isfinite(b).all():
        raise NumericalError(f"the right-hand side solved by {what} (reference)", None)
    try:
        x = np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularityError(f"{what} is singular (a singular configuration)") from e
    if not np.all(np.isfinite(x)):
        raise SingularityError(f"{what} gave non-finite values (a singular configuration)")
    return x


def _state(
    s: TreeSolver, desc: RobotDescription, T: np.ndarray, twist: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Tree ``q`` (25,), ``v`` (24,), ``Jc`` (18, 24) and ``R = 0Rp`` for one state."""
    desc.ideal_stroke("the 6-UPS tree state")  # general legs: the GeneralTreeSolver's
    R = T[:3, :3]
    q = np.empty(s.model.nq)
    q[s.q_ff] = pin.SE3ToXYZQUAT(pin.SE3(R, T[:3, 3]))
    q[s.q_legs] = inverse_geometry_batch(desc, T[None], check_limits=False)[0].ravel()
    Jc = _constraint_jacobian(s, q)
    v = np.zeros(s.nv)
    v[s.v_ff] = np.concatenate([R.T @ twist[:3], R.T @ twist[3:]])
    rhs = -Jc[:, s.v_ff] @ v[s.v_ff]
    v[s.v_legs] = _solve(Jc[:, s.v_legs], rhs, "the legs' constraint Jacobian")
    return q, v, Jc, R


def _loop_accelerations(s: TreeSolver) -> np.ndarray:
    """Constraint accelerations ``R_c1^T (a_1 - a_2)`` of the six loops, (18,), from the
    classical accelerations in F0 of both points (after
    ``pin.forwardKinematics(model, data, q, v, a)`` and the constraints' ``calc``).

    A point at placement ``M`` on joint ``j`` has the classical acceleration
    ``R_0j R_M (a_lin + w x v_lin)`` of the spatial velocity and acceleration brought to
    it; ``data.a`` alone lacks the ``w x v`` term.
    """
    n = len(s.cmodels)
    lin, ang, acc = np.empty((3, 2 * n, 3))
    rot = np.empty((2 * n, 3, 3))
    k = 0
    for cm in s.cmodels:
        for joint, M in ((cm.joint1_id, cm.joint1_placement), (cm.joint2_id, cm.joint2_placement)):
            vc = M.actInv(s.data.v[joint])
            lin[k], ang[k] = vc.linear, vc.angular
            acc[k] = M.actInv(s.data.a[joint]).linear
            rot[k] = s.data.oMi[joint].rotation @ M.rotation
            k += 1
    a0 = np.einsum("kij,kj->ki", rot, acc + np.cross(ang, lin))
    R_c1 = rot[0::2]
    return np.einsum("kji,kj->ki", R_c1, a0[0::2] - a0[1::2]).ravel()


def _local_platform_acceleration(
    R: np.ndarray, twist: np.ndarray, accel: np.ndarray
) -> np.ndarray:
    """Free-flyer acceleration ``d/dt [R^T v, R^T w]`` from the classical one in F0."""
    v_loc, w_loc = R.T @ twist[:3], R.T @ twist[3:]
    return np.concatenate([R.T @ accel[:3] - np.cross(w_loc, v_loc), R.T @ accel[3:]])


def _classical_platform_acceleration(
    R: np.ndarray, v_ff: np.ndarray, a_ff: np.ndarray
) -> np.ndarray:
    """Classical ``[vdot, wdot]`` in F0 from the free-flyer velocity and acceleration."""
    v_loc, w_loc = v_ff[:3], v_ff[3:]
    return np.concatenate([R @ (a_ff[:3] + np.cross(w_loc, v_loc)), R @ a_ff[3:]])


def _inverse_one(
    s: TreeSolver, desc: RobotDescription, T: np.ndarray, twist: np.ndarray, accel: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    q, v, Jc, R = _state(s, desc, T, twist)
    a = np.zeros(s.nv)
    a[s.v_ff] = _local_platform_acceleration(R, twist, accel)
    # Constraint acceleration with the legs' accelerations at zero: the drift plus the
    # platform's share, ``R_c1^T (a_1 - a_2)`` per loop (classical point accelerations).
    pin.forwardKinematics(s.model, s.data, q, v, a)
    residual = _loop_accelerations(s)
    a[s.v_legs] = _solve(Jc[:, s.v_legs], -residual, "the legs' constraint Jacobian")
    tau = pin.rnea(s.model, s.data, q, v, a)
    # tau = S^T Gamma + Jc^T lambda, 24 equations in 6 + 18 unknowns.
    K = np.zeros((s.nv, s.nv))
    K[s.v_act, np.arange(6)] = 1.0
    K[:, 6:] = Jc.T
    x = _solve(K, tau, "[S^T, Jc^T] (the parallel Jacobian)")
    gamma, lam = x[:6], x[6:].reshape(-1, 3)
    # lambda_i acts on the leg side in frame c1: the leg's force on the platform is its
    # opposite, in F0.
    forces = -np.einsum("kij,kj->ki", np.array([cd.oMc1.rotation for cd in s.cdatas]), lam)
    return gamma, forces


def _forward_one(
    s: TreeSolver, desc: RobotDescription, T: np.ndarray, twist: np.ndarray, gamma: np.ndarray
) -> np.ndarray:
    q, v, _, R = _state(s, desc, T, twist)
    tau = np.zeros(s.nv)
    tau[s.v_act] = gamma
    ddq = pin.constraintDynamics(s.model, s.data, q, v, tau, s.cmodels, s.cdatas, s.settings)
    ddq = np.array(ddq)
    if not np.all(np.isfinite(ddq)):
        if not np.isfinite(pin.rnea(s.model, s.data, q, v, np.zeros(s.nv))).all():
            raise NumericalError("the tree's bias force vector (reference)", None)
        raise SingularityError(
            "pin.constraintDynamics returned non-finite accelerations: a singular "
            "configuration, or a singular tree mass matrix (massless leg links; use "
            "constrained_inverse_dynamics, which needs no mass matrix)"
        )
    return _classical_platform_acceleration(R, v[s.v_ff], ddq[s.v_ff])


# ---------------------------------------------------------------------------- public API
def tree_state(robot: RobotLike, pose: Any, twist: Any) -> tuple[np.ndarray, np.ndarray]:
    """The full tree configuration and velocity of a platform state.

    The platform's free-flyer coordinates come from the pose and twist; the leg joint
    values from :func:`stewart_pin.kinematics.geometry.inverse_geometry` (default U-joint
    branch, no stroke check; general legs: ``robot.inverse_geometry``, each leg on its
    branch, the loop closure checked); the 18 leg rates solve the constraint velocity
    equation ``Jc v = 0``.

    Args:
        robot: the robot (its ``tree`` is used).
        pose: 0Tp, shape (4, 4) or (N, 4, 4) (``pin.SE3`` accepted).
        twist: ``[v, w]`` of O_p in F0, shape (6,) or (N, 6) [m/s, rad/s].

    Returns:
        ``(q, v)``: shapes (25,) and (24,) (or (N, 25), (N, 24)) in the tree's order;
        ``q`` holds the free-flyer's ``[p, quaternion xyzw]`` at ``robot.tree.platform_q_index``,
        ``v`` its local body twist ``[R^T v, R^T w]`` at ``platform_v_index``, and the
        prismatic rates ``qdot_3i`` [m/s] at ``actuated_v_index``.

    Raises:
        InputError: bad shapes or values. SingularityError: a leg singularity.
    """
    s = tree_solver(robot)  # a robot with a tree (TypeError otherwise)
    batched, T, V = check_states(pose, (twist, "twist"))
    if not robot.description.is_ideal_ups:  # the same layout: both trees' builder
        g = _general_solver(robot)
        q_legs = np.asarray(robot.inverse_geometry(T, check_limits=False), dtype=float)
        qs = np.empty((len(T), g.model.nq))
        vs = np.empty((len(T), g.nv))
        for n in range(len(T)):
            with _at_state(n):
                qs[n], vs[n] = g.state(T[n], V[n], q_legs[n])[:2]
        return _unbatch(qs, batched), _unbatch(vs, batched)
    qs = np.empty((len(T), s.model.nq))
    vs = np.empty((len(T), s.nv))
    for n in range(len(T)):
        with _at_state(n):
            qs[n], vs[n] = _state(s, robot.description, T[n], V[n])[:2]
    return _unbatch(qs, batched), _unbatch(vs, batched)


def constraint_dynamics_call(
    robot: RobotLike, pose: np.ndarray, twist: np.ndarray, gamma: np.ndarray
) -> Callable[[], object]:
    """One raw ``pin.constraintDynamics`` call on the robot's closed-loop tree at a platform
    state (pose (4, 4), twist (6,), actuator efforts (6,) [N or N m]), ready to time: the
    yardstick ``stewart-pin bench`` divides every row by. Leg rates from the loop
    constraints (:func:`tree_state`); general legs: the 24-dof tree of
    :func:`stewart_pin.models.leg_chains.build_general_tree` (``model.armature`` set, the
    joint terms in ``tau``; a solver of its own, not the cached reference's); chain legs:
    :class:`~stewart_pin.check.chain_legs_tree.ChainTreeSolver` (3D / 6D loops)."""
    if robot.description.has_chain_legs:  # chain legs: their tree with 3D / 6D loops
        chain = ChainTreeSolver(robot.description)
        q_all = np.asarray(robot.inverse_geometry(pose, check_limits=False), dtype=float)
        legs = robot.description.chain_legs or ()
        q_legs = [q_all[k, : len(leg.joints)] for k, leg in enumerate(legs)]
        q, v, _ = chain.state(pose, twist, q_legs, np.zeros(6))  # idle joints: at rest
        tau = -chain.joint_torques(q, v)
        tau[chain.v_act] += gamma
        args = (chain.model, chain.data, q, v, tau, chain.cmodels, chain.cdatas)
        return partial(pin.constraintDynamics, *args, chain.settings)
    if not robot.description.is_ideal_ups:  # general legs: their tree with joint terms
        general = GeneralTreeSolver(general_from_description(robot.description))
        q, v, _ = general.state(pose, twist, robot.inverse_geometry(pose, check_limits=False))
        tau = -general.joint_torques(q, v)
        if general.compensated:  # the bodies' gravity compensation, as joint torques
            tau += general.compensation_torques(q)
        tau[general.v_act] += gamma
        args = (general.model, general.data, q, v, tau, general.cmodels, general.cdatas)
        return partial(pin.constraintDynamics, *args, general.settings)
    solver = tree_solver(robot)
    q, v = tree_state(robot, pose, twist)
    tau = np.zeros(solver.nv)
    tau[solver.v_act] = gamma
    args = (solver.model, solver.data, q, v, tau, solver.cmodels, solver.cdatas)
    return partial(pin.constraintDynamics, *args, solver.settings)


def constraint_jacobian(robot: RobotLike, q: Any) -> np.ndarray:
    """The loop-closure Jacobian ``Jc`` (18, 24) at a tree configuration ``q`` (25,).

    Rows ``3i..3i+2`` give the relative velocity of loop i's two points (leg tip minus
    platform point P_i) in the frame of the leg-side point: ``Jc = R_c1^T (J_1 - J_2)``
    with ``J_1, J_2`` the world-aligned point Jacobians [m/rad, dimensionless].
    """
    s = tree_solver(robot)
    q = np.asarray(q, dtype=float)
    if q.shape != (s.model.nq,) or not np.all(np.isfinite(q)):
        raise InputError(f"q must be a finite array of shape ({s.model.nq},), got {q.shape}")
    return _constraint_jacobian(s, q).copy()


def constrained_inverse_dynamics(
    robot: RobotLike, pose: Any, twist: Any, accel: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Actuator forces and loop-closure forces from the constrained tree.

    Solves ``M qddot + b = S^T Gamma + Jc^T lambda`` with ``Jc qddot + drift = 0``, the
    platform's part of ``qddot`` given by ``accel``.

    Args:
        robot: the robot.
        pose: 0Tp, shape (4, 4) or (N, 4, 4).
        twist: ``[v, w]`` in F0, shape (6,) or (N, 6) [m/s, rad/s].
        accel: classical ``[dv/dt, dw/dt]`` of O_p in F0, shape (6,) or (N, 6)
            [m/s^2, rad/s^2].

    Returns:
        ``(gamma, forces)``: ``gamma`` shape (6,) (or (N, 6)) the prismatic joint forces
        [N], positive extending; ``forces`` shape (6, 3) (or (N, 6, 3)) the force of leg i
        on the platform at P_i, in F0 [N] (``f_i`` of eq. 23).

    Raises:
        InputError: bad shapes or values.
        SingularityError: a leg singularity, or ``[S^T, Jc^T]`` singular (parallel
            singularity).
    """
    s = tree_solver(robot)  # a robot with a tree (TypeError otherwise)
    batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
    gammas = np.empty((len(T), 6))
    forces = np.empty((len(T), 6, 3))
    if not robot.description.is_ideal_ups:  # general legs: their tree with joint terms
        g = _general_solver(robot)
        q_legs = np.asarray(robot.inverse_geometry(T, check_limits=False), dtype=float)
        for n in range(len(T)):
            with _at_state(n):
                gammas[n], forces[n], _ = g.inverse_with_forces_one(T[n], V[n], A[n], q_legs[n])
        return _unbatch(gammas, batched), _unbatch(forces, batched)
    for n in range(len(T)):
        with _at_state(n):
            gammas[n], forces[n] = _inverse_one(s, robot.description, T[n], V[n], A[n])
    return _unbatch(gammas, batched), _unbatch(forces, batched)


def reference_actuator_efforts(robot: RobotLike, pose: Any, twist: Any, accel: Any) -> np.ndarray:
    """The actuated joints' efforts from the constrained tree, for any leg architecture:
    :func:`constrained_inverse_dynamics`'s ``gamma`` for the ideal 6-UPS, the KKT solve
    of :class:`~stewart_pin.check.leg_chain_tree.GeneralTreeSolver` for general legs (with
    the leg joint positions from the robot's inverse geometry: see
    :func:`_general_reference`).

    Returns:
        shape (6,) or (N, 6) [N or N m], in the order of the legs.
    """
    if robot.description.is_ideal_ups:
        return constrained_inverse_dynamics(robot, pose, twist, accel)[0]
    batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
    q_legs = np.asarray(robot.inverse_geometry(T, check_limits=False), dtype=float)
    return _unbatch(reference_inverse_dynamics(_general_solver(robot), T, V, A, q_legs), batched)


def constrained_forward_dynamics(
    robot: RobotLike, pose: Any, twist: Any, gamma: Any
) -> np.ndarray:
    """The platform's acceleration under actuator forces, from ``pin.constraintDynamics``.

    Args:
        robot: the robot.
        pose: 0Tp, shape (4, 4) or (N, 4, 4).
        twist: ``[v, w]`` in F0, shape (6,) or (N, 6) [m/s, rad/s].
        gamma: actuator efforts, shape (6,) or (N, 6): prismatic joint forces [N],
            positive extending (general legs: each actuated joint's effort [N or N m]).

    Returns:
        The classical acceleration ``[dv/dt, dw/dt]`` of O_p in F0, shape (6,) or (N, 6)
        [m/s^2, rad/s^2].

    Raises:
        InputError: bad shapes or values. SingularityError: a singular configuration.
    """
    if not robot.description.is_ideal_ups:
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        solver = _general_solver(robot)
        q_legs = np.asarray(robot.inverse_geometry(T, check_limits=False), dtype=float)
        return _unbatch(reference_direct_dynamics(solver, T, V, G, q_legs), batched)
    s = tree_solver(robot)
    batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
    out = np.empty((len(T), 6))
    for n in range(len(T)):
        with _at_state(n):
            out[n] = _forward_one(s, robot.description, T[n], V[n], G[n])
    return _unbatch(out, batched)


def energy(robot: RobotLike, pose: Any, twist: Any) -> tuple[Any, Any]:
    """Kinetic and potential energy of the whole robot (legs and platform) [J].

    From ``pin.computeKineticEnergy`` / ``pin.computePotentialEnergy`` on the tree at
    :func:`tree_state`; the potential is ``-sum_j m_j g . c_j`` with the description's
    gravity ``g`` and the centres of mass ``c_j`` in F0 (zero at the origin of F0).

    Args:
        robot: the robot.
        pose: 0Tp, shape (4, 4) or (N, 4, 4).
        twist: ``[v, w]`` in F0, shape (6,) or (N, 6) [m/s, rad/s].

    Returns:
        ``(kinetic, potential)``: floats, or arrays of shape (N,) for a batch [J].
    """
    s = tree_solver(robot)  # a robot with a tree (TypeError otherwise)
    batched, T, V = check_states(pose, (twist, "twist"))
    if not robot.description.is_ideal_ups:  # general legs: armatures and springs included
        q_legs = np.asarray(robot.inverse_geometry(T, check_limits=False), dtype=float)
        kinetic, potential, _ = reference_energy(_general_solver(robot), T, V, q_legs)
        if batched:
            return kinetic, potential
        return float(kinetic[0]), float(potential[0])
    out = np.empty((len(T), 2))
    for n in range(len(T)):
        with _at_state(n):
            q, v = _state(s, robot.description, T[n], V[n])[:2]
            out[n, 0] = pin.computeKineticEnergy(s.model, s.data, q, v)
            out[n, 1] = pin.computePotentialEnergy(s.model, s.data, q)
            if not np.isfinite(out[n]).all():
                raise NumericalError("the energy (reference)", n)
    if batched:
        return out[:, 0], out[:, 1]
    return float(out[0, 0]), float(out[0, 1])


# ---------------------------------------------------------------------------- the check
def relative_error(a: Any, b: Any, floor: float = RELATIVE_FLOOR) -> float:
    """Largest per-state relative error of ``a`` against the reference ``b``, shape (N, k).

    ``max_n max_k |a_nk - b_nk| / max(max_k |b_nk|, floor * max |b|)``: each state is
    scaled by its own magnitude, floored at ``floor`` times the batch's largest, so that a
    state with a near-zero reference doesn't blow up the ratio.
    """
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.atleast_2d(np.asarray(b, dtype=float))
    if a.shape != b.shape:
        raise InputError(f"cannot compare shapes {a.shape} and {b.shape}")
    scale = np.abs(b).max(axis=1, initial=0.0)  # k = 0 (a payload without joints): 0
    denominator = np.maximum(scale, floor * scale.max(initial=0.0))
    denominator[denominator == 0.0] = 1.0
    return float((np.abs(a - b).max(axis=1, initial=0.0) / denominator).max(initial=0.0))


@dataclass(frozen=True)
class ValidationReport:
    """The paper's models against the constrained tree, over random states.

    Attributes:
        robot: the robot's name.
        n_states: number of random states compared.
        idm_error: largest relative error of ``robot.inverse_dynamics`` against
            :func:`constrained_inverse_dynamics` (Gamma).
        ddm_error: largest relative error of ``robot.direct_dynamics`` against
            :func:`constrained_forward_dynamics`, both under the reference Gamma.
        round_trip_error: largest relative error of ``DDM(IDM(x, V, Vdot))`` against
            ``Vdot`` (the paper's models alone).
        reference_error: the same round trip through the constrained tree alone (the
            reference's own consistency).
        floor: the relative-error floor used (see :func:`relative_error`).
    """

    robot: str
    n_states: int
    idm_error: float
    ddm_error: float
    round_trip_error: float
    reference_error: float
    floor: float = RELATIVE_FLOOR

    def passed(self, tol_idm: float = IDM_TOLERANCE, tol_ddm: float = DDM_TOLERANCE) -> bool:
        """Whether the inverse model is within ``tol_idm`` and the direct model, the round
        trip and the reference's own round trip within ``tol_ddm`` (relative)."""
        return bool(
            self.idm_error <= tol_idm
            and self.ddm_error <= tol_ddm
            and self.round_trip_error <= tol_ddm
            and self.reference_error <= tol_ddm
        )

    def summary(self, tol_idm: float = IDM_TOLERANCE, tol_ddm: float = DDM_TOLERANCE) -> str:
        """The errors and one verdict, at the tolerances given (``str(report)``: the
        defaults)."""
        return (
            f"validation of '{self.robot}' against Pinocchio's constrained tree, "
            f"{self.n_states} random states (relative errors, floor {self.floor:g}):\n"
            f"  inverse dynamics  Gamma         {self.idm_error:.3e}\n"
            f"  direct dynamics   Vdot          {self.ddm_error:.3e}\n"
            f"  round trip        DDM(IDM)      {self.round_trip_error:.3e}\n"
            f"  reference         FD(ID) tree   {self.reference_error:.3e}\n"
            + verdict_line(self.passed(tol_idm, tol_ddm), tol_idm, tol_ddm)
        )

    def __str__(self) -> str:
        return self.summary()


def verdict_line(passed: bool, tol_idm: float, tol_ddm: float) -> str:
    """``"  PASSED at the default tolerances (IDM 1e-09, DDM 1e-08)"`` or ``FAILED``, the
    tolerances named as given (a validation report's last line, once)."""
    default = (tol_idm, tol_ddm) == (IDM_TOLERANCE, DDM_TOLERANCE)
    return (
        f"  {'PASSED' if passed else 'FAILED'} at the {'default ' if default else ''}"
        f"tolerances (IDM {tol_idm:g}, DDM {tol_ddm:g})"
    )


def _integer(value: Any, name: str, least: int) -> int:
    """``value`` as an int >= ``least`` (integral floats accepted), else InputError."""
    ok = not isinstance(value, (bool, str, bytes))
    try:
        x = int(value) if ok and value == int(value) else None
    except (TypeError, ValueError, OverflowError):
        x = None
    if x is None or x < least:
        raise InputError(f"{name} must be an integer >= {least}, got {value!r}")
    return x


_GENERAL_SOLVERS: weakref.WeakKeyDictionary[Any, GeneralTreeSolver] = weakref.WeakKeyDictionary()


def _general_solver(robot: RobotLike) -> GeneralTreeSolver:
    """The (cached, per robot) constrained tree of a robot with general legs."""
    try:
        return _GENERAL_SOLVERS[robot]
    except KeyError:
        solver = GeneralTreeSolver(general_from_description(robot.description))
        _GENERAL_SOLVERS[robot] = solver
        return solver


def _general_reference(
    robot: RobotLike, poses: np.ndarray, twists: np.ndarray, accels: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The reference Gamma and Vdot of a robot with general legs: Pinocchio's constrained
    tree with ``model.armature`` and the joint torques
    (:class:`stewart_pin.check.leg_chain_tree.GeneralTreeSolver`).

    The leg joint *positions* come from the robot's own inverse geometry
    (``robot.inverse_geometry``, through :mod:`stewart_pin.kinematics.leg_chains`): that
    part is not independent, but the solver checks with Pinocchio's forward kinematics
    that they close the six loops (within
    :data:`stewart_pin.check.leg_chain_tree.CLOSURE_TOLERANCE`); every rate, acceleration
    and dynamic term is the tree's own.
    """
    solver = _general_solver(robot)
    q_legs = np.asarray(robot.inverse_geometry(poses, check_limits=False), dtype=float)
    gamma_ref = reference_inverse_dynamics(solver, poses, twists, accels, q_legs)
    accel_ref = reference_direct_dynamics(solver, poses, twists, gamma_ref, q_legs)
    return gamma_ref, accel_ref


def _chain_reference(
    robot: RobotLike, poses: np.ndarray, twists: np.ndarray, accels: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The reference Gamma and Vdot of a robot with chain legs: Pinocchio's tree with its
    3D (ball) and 6D (weld) loop constraints
    (:class:`stewart_pin.check.chain_legs_tree.ChainTreeSolver`), fed the robot's own leg
    joint positions (checked to close the loops), everything else the tree's own."""
    legs = robot.description.chain_legs or ()
    solver = ChainTreeSolver(robot.description)
    q = np.asarray(robot.inverse_geometry(poses, check_limits=False), dtype=float)
    gamma_ref, accel_ref = np.empty((len(poses), 6)), np.empty((len(poses), 6))
    for n in range(len(poses)):
        q_legs = [q[n, k, : len(leg.joints)] for k, leg in enumerate(legs)]
        gamma_ref[n] = solver.inverse_one(poses[n], twists[n], accels[n], q_legs)
        accel_ref[n] = solver.forward_one(poses[n], twists[n], gamma_ref[n], q_legs)
    return gamma_ref, accel_ref


def validate(
    robot: RobotLike,
    n_states: int = 200,
    seed: int | None = 0,
    translation_range: float | None = None,
    rotation_range: float = 0.25,
) -> ValidationReport:
    """Compare the paper's inverse and direct models with the constrained tree.

    Draws ``n_states`` states with ``robot.sample_states`` (seeded; for a
    :class:`~stewart_pin.StewartRobot`, :func:`stewart_pin.kinematics.workspace.sample_states`),
    computes the reference Gamma with :func:`constrained_inverse_dynamics` (general legs:
    :class:`~stewart_pin.check.leg_chain_tree.GeneralTreeSolver`, the tree with the joint
    dynamics, fed the robot's own leg joint positions, whose loop closure it checks; see
    :func:`_general_reference`), then compares
    ``robot.inverse_dynamics(poses, twists, accels)`` with it, ``robot.direct_dynamics``
    under the reference Gamma with :func:`constrained_forward_dynamics`, and the round
    trip ``robot.direct_dynamics(robot.inverse_dynamics(...))`` with the drawn
    accelerations. Errors are relative (see :func:`relative_error`).

    Args:
        robot: the robot; it must provide ``inverse_dynamics`` and ``direct_dynamics``
            taking batches and returning (N, 6).
        n_states: number of random states (>= 1).
        seed: seed of the random generator.
        translation_range: half-side [m] of the cube, along F0's axes, in which the
            platform's origin is drawn around the home pose (default 15 % of the
            mid-stroke); give a smaller one for a robot with a small workspace.
        rotation_range: each component of the rotation vector (in F0) applied to the
            home orientation is drawn in ``[-rotation_range, rotation_range]`` [rad].

    Raises:
        InputError: a bad ``n_states`` or range. WorkspaceError: too few of the drawn
            poses are reachable (the message says to narrow the ranges).
    """
    n_states = _integer(n_states, "n_states", 1)
    seed = None if seed is None else _integer(seed, "seed", 0)
    for method in ("inverse_dynamics", "direct_dynamics"):
        if not callable(getattr(robot, method, None)):
            raise InputTypeError(f"{type(robot).__name__} has no method '{method}' to validate")
    rng = np.random.default_rng(seed)
    try:  # the robot draws in its own workspace (its singularity threshold)
        poses, twists, accels = robot.sample_states(
            n_states, rng, translation=translation_range, rotation=rotation_range
        )
    except WorkspaceError as e:
        raise WorkspaceError(
            f"{e} (validate: translation_range, rotation_range; stewart-pin validate: "
            "--translation, --rotation)"
        ) from e
    if robot.description.is_ideal_ups:
        gamma_ref, _ = constrained_inverse_dynamics(robot, poses, twists, accels)
        accel_ref = constrained_forward_dynamics(robot, poses, twists, gamma_ref)
    elif robot.description.chain_legs is not None:
        gamma_ref, accel_ref = _chain_reference(robot, poses, twists, accels)
    else:
        gamma_ref, accel_ref = _general_reference(robot, poses, twists, accels)
    # the references are the description's efforts: in the robot's actuator convention
    # (an imported robot's file's) through the description's record of it
    gamma_ref = actuator_convention_of(robot).efforts_from_description(gamma_ref)
    gamma = np.asarray(robot.inverse_dynamics(poses, twists, accels), dtype=float)
    accel = np.asarray(robot.direct_dynamics(poses, twists, gamma_ref), dtype=float)
    round_trip = np.asarray(robot.direct_dynamics(poses, twists, gamma), dtype=float)
    return ValidationReport(
        robot=str(robot.description.name),
        n_states=n_states,
        idm_error=relative_error(gamma, gamma_ref),
        ddm_error=relative_error(accel, accel_ref),
        round_trip_error=relative_error(round_trip, accels),
        reference_error=relative_error(accel_ref, accels),
    )
