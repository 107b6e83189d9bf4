"""The independent check of the derivatives: Pinocchio's constrained-dynamics derivatives
mapped to the platform state.

``pin.computeConstraintDynamicsDerivatives`` differentiates the joint accelerations of the
24-dof closed-loop tree of :mod:`.constrained_dynamics` (free-flyer platform, six 3-dof
legs, six 3D loop closures) with respect to the tree's ``q`` (tangent), ``v`` and
``tau``. This module maps them to the platform state, with nothing from the paper's
algebra or the generated code (only the leg joint *positions* come from the project's
inverse geometry, as in :mod:`.constrained_dynamics`):

- the pose perturbation ``delta = [dp, dtheta]`` in F0 (``p + dp``, ``R <- exp(dtheta^) R``)
  is the free-flyer tangent ``[R^T dp, R^T dtheta]`` (Pinocchio integrates
  ``M exp6(xi)``), and the legs follow on the constraint manifold: ``Jc dq = 0``;
- the tree velocity at fixed platform twist moves with the pose: its free-flyer part
  ``[R^T v, R^T w]`` turns with R (``d(R^T u)/dtheta = R^T u^``), and its leg part keeps
  ``Jc(q) v = 0``, so ``Jc dv = -d(Jc v)/dq dq``; the constraint velocity is
  ``R_c1^T (nu_1 - nu_2)`` with ``nu_1 = nu_2`` on the manifold, so ``d(Jc v)/dq`` is
  ``R_c1^T (d nu_1/dq - d nu_2/dq)``, the point velocities' derivatives from
  ``pin.getPointVelocityDerivatives`` (LOCAL_WORLD_ALIGNED);
- the platform's classical acceleration is ``[R (a_lin + w_l x v_l), R a_ang]`` from the
  free-flyer's local velocity ``[v_l, w_l]`` and acceleration ``[a_lin, a_ang]``; its
  derivatives collect the chain rule through ``ddq``, ``v_ff`` and R.

The inverse model's derivatives follow from the direct model's by the implicit function
theorem at ``Gamma = IDM(x, V, Vdot)`` (the tree's own, :func:`constrained_inverse_dynamics`):
``dGamma/dVdot = (dVdot/dGamma)^-1``, ``dGamma/dV = -(dVdot/dGamma)^-1 dVdot/dV``, likewise
for the pose.

A Pinocchio 4.1 defect, worked around here: ``computeConstraintDynamicsDerivatives``
returns a wrong first column of ``ddq_dq`` (velocity index 0) on this closed-loop tree (off
by as much as ten times the column's size, against central finite differences of
``pin.constraintDynamics`` on ``pin.integrate``; every other column agrees to 1e-9). The
derivatives are therefore taken on a copy of the tree with one more joint in front: a
revolute joint on the universe carrying a unit inertia on its axis, in no constraint, at
rest (its dynamics is decoupled from the robot's), whose row and column are dropped.
``tests/test_derivatives.py`` checks the whole mapping against finite differences of
:func:`~.constrained_dynamics.constrained_forward_dynamics`.

Ideal 6-UPS robots only (general legs carry joint friction and springs that Pinocchio's
derivatives do not see: their check is finite differences).
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_states
from stewart_pin.check.constrained_dynamics import (
    TreeSolver,
    constrained_inverse_dynamics,
    constraint_jacobian,
    tree_solver,
    tree_state,
)
from stewart_pin.exceptions import NumericalError, SingularityError
from stewart_pin.protocols import RobotLike

__all__ = [
    "constrained_direct_dynamics_derivatives",
    "constrained_inverse_dynamics_derivatives",
    "tree_derivatives_call",
]


class _PaddedTree:
    """The tree of a :class:`TreeSolver` with a decoupled revolute joint in front (velocity
    index 0; see the module docstring), its constraints and data."""

    def __init__(self, s: TreeSolver) -> None:
        m0 = s.model
        model = pin.Model()
        model.gravity = m0.gravity
        pad = model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "derivative_pad")
        model.appendBodyToJoint(pad, pin.Inertia(1.0, np.zeros(3), np.eye(3)), pin.SE3.Identity())
        for i in range(1, m0.njoints):
            parent = m0.parents[i]
            j = model.addJoint(
                parent + 1 if parent > 0 else 0, m0.joints[i], m0.jointPlacements[i], m0.names[i]
            )
            model.appendBodyToJoint(j, m0.inertias[i], pin.SE3.Identity())
        self.model, self.data = model, model.createData()
        self.cmodels = pin.StdVec_RigidConstraintModel()
        self.cdatas = pin.StdVec_RigidConstraintData()
        for cm in s.cmodels:
            c = pin.RigidConstraintModel(
                cm.type,
                model,
                cm.joint1_id + 1,
                cm.joint1_placement,
                cm.joint2_id + 1,
                cm.joint2_placement,
                cm.reference_frame,
            )
            self.cmodels.append(c)
            self.cdatas.append(c.createData())
        pin.initConstraintDynamics(model, self.data, self.cmodels, self.cdatas)
        self.settings = s.settings

    def derivatives(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``ddq, ddq_dq, ddq_dv, ddq_dtau`` of the robot's tree (the pad dropped)."""
        z = np.zeros(1)
        q, v, tau = np.concatenate([z, q]), np.concatenate([z, v]), np.concatenate([z, tau])
        m, d, cms, cds = self.model, self.data, self.cmodels, self.cdatas
        ddq = np.array(pin.constraintDynamics(m, d, q, v, tau, cms, cds, self.settings))
        dd = pin.computeConstraintDynamicsDerivatives(m, d, cms, cds, self.settings)[:3]
        return ddq[1:], *(np.array(x)[1:, 1:] for x in dd)  # type: ignore[return-value]


_PADDED: weakref.WeakKeyDictionary[Any, _PaddedTree] = weakref.WeakKeyDictionary()


def _padded(robot: RobotLike, s: TreeSolver) -> _PaddedTree:
    try:
        return _PADDED[robot]
    except KeyError:
        padded = _PaddedTree(s)
        _PADDED[robot] = padded
        return padded


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``A^-1 b`` for the legs' constraint Jacobian; singular: a leg singularity."""
    try:
        x = np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularityError("the legs' constraint Jacobian is singular") from e
    if not np.all(np.isfinite(x)):
        raise SingularityError("the legs' constraint Jacobian gave non-finite values")
    return x


def _hat(u: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])


def _blocks(R: np.ndarray) -> np.ndarray:
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    return B


def _constraint_velocity_dq(s: TreeSolver, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d(Jc(q) v)/dq`` (18, 24) at a state whose loops close in velocity (see the module
    docstring)."""
    pin.computeForwardKinematicsDerivatives(s.model, s.data, q, v, np.zeros(s.nv))
    rows = []
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for cm, cd in zip(s.cmodels, s.cdatas, strict=True):
        d1 = pin.getPointVelocityDerivatives(
            s.model, s.data, cm.joint1_id, cm.joint1_placement, world
        )[0]
        d2 = pin.getPointVelocityDerivatives(
            s.model, s.data, cm.joint2_id, cm.joint2_placement, world
        )[0]
        rows.append(cd.oMc1.rotation.T @ (d1 - d2))
    return np.vstack(rows)


def _direct_one(
    robot: RobotLike,
    s: TreeSolver,
    padded: _PaddedTree,
    T: np.ndarray,
    twist: np.ndarray,
    gamma: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    q, v = tree_state(robot, T, twist)
    Jc = constraint_jacobian(robot, q)  # (also brings the constraint datas to q)
    R = T[:3, :3]
    ff, legs = s.v_ff, s.v_legs
    tau = np.zeros(s.nv)
    tau[s.v_act] = gamma
    ddq, ddq_dq, ddq_dv, ddq_dtau = padded.derivatives(q, v, tau)
    Jl, Jf = Jc[:, legs], Jc[:, ff]
    P = _blocks(R.T)  # platform twist (or delta) in F0 -> free-flyer velocity (tangent)
    # tangents of q and v: the legs follow the platform on the constraint manifold
    dq = np.zeros((s.nv, 6))
    dq[ff] = P
    dq[legs] = _solve(Jl, -Jf @ P)
    dv_twist = dq.copy()  # the same linear map takes the twist to v
    v_l, w_l = v[ff][:3], v[ff][3:]
    dv = np.zeros((s.nv, 6))
    dv[ff[:3], 3:] = R.T @ _hat(twist[:3])
    dv[ff[3:], 3:] = R.T @ _hat(twist[3:])
    Cq = _constraint_velocity_dq(s, q, v)
    dv[legs] = _solve(Jl, -(Cq @ dq + Jf @ dv[ff]))
    # platform classical acceleration [R (a_lin + w_l x v_l), R a_ang]
    B = _blocks(R)
    a = ddq[ff]
    dC_dvff = np.zeros((6, 6))
    dC_dvff[:3, :3] = R @ _hat(w_l)
    dC_dvff[:3, 3:] = -R @ _hat(v_l)
    accel = np.concatenate([R @ (a[:3] + np.cross(w_l, v_l)), R @ a[3:]])
    d_gamma = B @ ddq_dtau[ff][:, s.v_act]
    d_twist = B @ (ddq_dv[ff] @ dv_twist) + dC_dvff @ P
    d_pose = B @ (ddq_dq[ff] @ dq + ddq_dv[ff] @ dv) + dC_dvff @ dv[ff]
    d_pose[:3, 3:] -= _hat(accel[:3])  # the explicit R of R u: d(exp(t^) R u)/dt = -(R u)^
    d_pose[3:, 3:] -= _hat(accel[3:])
    return accel, d_pose, d_twist, d_gamma


def constrained_direct_dynamics_derivatives(
    robot: RobotLike, pose: Any, twist: Any, gamma: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The direct model's derivatives from Pinocchio's constrained tree (6-UPS).

    Args:
        robot: the robot (its ``tree``).
        pose: 0Tp, shape (4, 4) or (N, 4, 4). twist: ``[v, w]`` in F0, (6,) or (N, 6)
            [m/s, rad/s]. gamma: actuator forces, (6,) or (N, 6) [N].

    Returns:
        ``(accel, d_pose, d_twist, d_gamma)``: the classical acceleration ``[dv/dt, dw/dt]``
        in F0 (6,) and its derivatives (6, 6) with respect to ``delta = [dp, dtheta]`` (see
        the module docstring), the twist and Gamma (a leading N axis for a batch).

    Raises:
        InputError: bad shapes or values. SingularityError: a singular configuration.
        NumericalError: a non-finite derivative.
    """
    s = tree_solver(robot)
    padded = _padded(robot, s)
    batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
    outs = [np.empty((len(T), 6)), *(np.empty((len(T), 6, 6)) for _ in range(3))]
    for n in range(len(T)):
        one = _direct_one(robot, s, padded, T[n], V[n], G[n])
        for out, x in zip(outs, one, strict=True):
            out[n] = x
    for out in outs:
        if not np.isfinite(out).all():
            raise NumericalError("the constrained dynamics derivatives (reference)", None)
    return tuple(x if batched else x[0] for x in outs)  # type: ignore[return-value]


def constrained_inverse_dynamics_derivatives(
    robot: RobotLike, pose: Any, twist: Any, accel: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The inverse model's derivatives from Pinocchio's constrained tree (6-UPS), by the
    implicit function theorem on :func:`constrained_direct_dynamics_derivatives` at
    ``Gamma`` from :func:`constrained_inverse_dynamics`.

    Returns:
        ``(gamma, d_pose, d_twist, d_accel)``: Gamma (6,) [N] and its derivatives (6, 6)
        with respect to ``delta``, the twist and the classical acceleration (a leading N
        axis for a batch).
    """
    batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
    gamma = constrained_inverse_dynamics(robot, T, V, A)[0]
    _, dp, dt, dg = constrained_direct_dynamics_derivatives(robot, T, V, gamma)
    d_accel = np.linalg.inv(dg)
    d_pose = -d_accel @ dp
    d_twist = -d_accel @ dt
    outs = (gamma, d_pose, d_twist, d_accel)
    return tuple(x if batched else x[0] for x in outs)  # type: ignore[return-value]


def tree_derivatives_call(
    robot: RobotLike, pose: np.ndarray, twist: np.ndarray, gamma: np.ndarray
) -> Any:
    """One raw ``pin.constraintDynamics`` followed by
    ``pin.computeConstraintDynamicsDerivatives`` (which needs it) on the closed-loop tree at
    a platform state, q, v and tau prepared beforehand: the benchmark's yardstick for the
    derivatives (a function of no arguments)."""
    s = tree_solver(robot)
    q, v = tree_state(robot, pose, twist)
    tau = np.zeros(s.nv)
    tau[s.v_act] = gamma
    model, data, cms, cds, settings = s.model, s.data, s.cmodels, s.cdatas, s.settings

    def call() -> Any:
        pin.constraintDynamics(model, data, q, v, tau, cms, cds, settings)
        return pin.computeConstraintDynamicsDerivatives(model, data, cms, cds, settings)

    return call
