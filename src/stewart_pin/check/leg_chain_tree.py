"""The independent check for general-leg robots: Pinocchio's constrained tree.

Shares no algebra with :mod:`stewart_pin.dynamics.leg_chain_dynamics` or
:mod:`stewart_pin.kinematics.leg_chains` (it imports neither): the robot is the 24-dof
tree of :func:`stewart_pin.models.leg_chains.build_general_tree` (six chains, the
platform as a free-flyer, ``model.armature`` for the armatures) closed by six 3D point
constraints. The leg joint *positions* are an input (any inverse geometry may give them):
they are checked here, by Pinocchio's forward kinematics, to close the six loops within
:data:`CLOSURE_TOLERANCE`. Everything else comes from Pinocchio:

- leg rates: ``Jc v = 0`` given the platform's free-flyer velocity;
- inverse dynamics: the leg accelerations from ``Jc qddot + drift = 0`` (classical point
  accelerations), ``tau = rnea(q, v, a) + tau_joint`` with the joint terms
  ``tau_joint = (Fv + D) qdot + Fc sign(qdot) + K (q - q0)`` (this module's own code),
  then ``[S^T, Jc^T] [Gamma; lambda] = tau``;
- direct dynamics: ``pin.constraintDynamics`` with ``tau = S^T Gamma - tau_joint`` and
  ``pin.ProximalSettings(1e-14, 0, 1)`` (an exact KKT solve);
- regressor: ``pin.computeJointTorqueRegressor`` on the tree and the joint-term columns,
  each column mapped to the actuated efforts by the same KKT solve;
- energy: ``pin.computeKineticEnergy`` (checked against ``1/2 v^T M v`` with the
  armature), ``pin.computePotentialEnergy`` and the springs;
- per-body gravity compensation (``leg_gravcomp``, ``platform_gravcomp``: the fraction
  ``c_b`` of body b's weight removed): external forces ``f_b = -c_b m_b g`` at each body's
  centre of mass on the tree (this module's own code, from the tree's inertias): ``fext``
  of ``pin.rnea`` in the inverse model, ``J^T fext`` added to the torques of
  ``pin.constraintDynamics`` in the direct one, their potential ``c_b m_b g . c_b`` added to
  the energy; the regressor refuses such a robot.

Conventions as :mod:`stewart_pin.check.constrained_dynamics`: pose 0Tp (N, 4, 4), twist
``[v, w]`` of O_p in F0, classical acceleration in F0; ``Gamma`` (N, 6) the actuated
joints' efforts (joint side). A Python loop over states: a reference, not a fast path.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.exceptions import InputError, SingularityError
from stewart_pin.models.leg_chains import build_general_tree, leg_joint_name
from stewart_pin.models.pinocchio_models import TreeModel

#: Khalil's order ``XX XY XZ YY YZ ZZ MX MY MZ M`` -> Pinocchio's ``m mx my mz Ixx Ixy Iyy
#: Ixz Iyz Izz`` (written out here so that the check shares no conversion table).
_KHALIL_TO_PIN = np.array([9, 6, 7, 8, 0, 1, 3, 2, 4, 5])
#: Largest loop-closure error [m] accepted for the given leg joint positions.
CLOSURE_TOLERANCE = 1e-9


class GeneralTreeSolver:
    """Pinocchio data for one general robot's tree, constraints initialised once."""

    def __init__(self, robot: GeneralHexapod, tree: TreeModel | None = None) -> None:
        self.robot = robot
        self.tree = build_general_tree(robot) if tree is None else tree
        self.model = self.tree.model
        self.data = self.model.createData()
        self.cmodels = pin.StdVec_RigidConstraintModel()
        self.cdatas = pin.StdVec_RigidConstraintData()
        for cm in self.tree.constraints:
            self.cmodels.append(cm)
            self.cdatas.append(cm.createData())
        pin.initConstraintDynamics(self.model, self.data, self.cmodels, self.cdatas)
        self.settings = pin.ProximalSettings(1e-14, 0.0, 1)
        self.q_ff = self.tree.platform_q_index
        self.v_ff = self.tree.platform_v_index
        self.q_legs = self.tree.leg_q_index.ravel()
        self.v_legs = self.tree.leg_v_index.ravel()
        self.v_act = self.tree.actuated_v_index
        self.nv = self.model.nv
        dyn = [[j.dynamics for j in leg.joints] for leg in robot.legs]
        self.viscous = np.array([[d.viscous + d.damping for d in row] for row in dyn]).ravel()
        self.coulomb = np.array([[d.coulomb for d in row] for row in dyn]).ravel()
        self.stiffness = np.array([[d.stiffness for d in row] for row in dyn]).ravel()
        self.rest = np.array([[d.rest_position for d in row] for row in dyn]).ravel()
        # (joint id, compensation) of each body whose weight is partly compensated
        compensated = [(self.tree.platform_joint, float(robot.platform_gravcomp))] + [
            (self.model.getJointId(leg_joint_name(i + 1, j + 1)), float(robot.leg_gravcomp[i, j]))
            for i in range(6)
            for j in range(3)
        ]
        self.compensated = [(jid, c) for jid, c in compensated if c != 0.0]

    # ------------------------------------------------------------------ pieces
    def compensation_forces(self) -> list[pin.Force]:
        """The forces ``-c_b m_b g`` at the bodies' centres of mass (F0), each as a
        ``pin.Force`` in its joint's frame (``fext`` of ``pin.rnea``; one per joint), at the
        placements in ``data`` (after ``pin.forwardKinematics``)."""
        return compensation_forces(self.model, self.data, self.compensated)

    def compensation_torques(self, q: np.ndarray) -> np.ndarray:
        """``J^T fext`` (nv,): the compensating forces as joint torques (the difference of
        ``pin.rnea`` at rest without and with them)."""
        return compensation_torques(self.model, self.data, self.compensated, q)

    def joint_torques(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Friction, spring and damper torques on the tree's joints (nv,)."""
        ql, vl = q[self.q_legs], v[self.v_legs]
        tau = np.zeros(self.nv)
        tau[self.v_legs] = (
            self.viscous * vl + self.coulomb * coulomb_sign(vl) + self.stiffness * (ql - self.rest)
        )
        return tau

    def constraint_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``Jc`` (18, 24) (``calc`` on each constraint first: see pinocchio-4.1-notes)."""
        pin.computeJointJacobians(self.model, self.data, q)
        for cm, cd in zip(self.cmodels, self.cdatas, strict=True):
            cm.calc(self.model, self.data, cd)
        return pin.getConstraintsJacobian(self.model, self.data, self.cmodels, self.cdatas)

    def loop_accelerations(self) -> np.ndarray:
        """``R_c1^T (a_1 - a_2)`` of the six loops (18,), classical point accelerations
        (after ``pin.forwardKinematics(model, data, q, v, a)``)."""
        out = np.empty((len(self.cmodels), 3))
        for k, cm in enumerate(self.cmodels):
            acc = []
            for joint, M in (
                (cm.joint1_id, cm.joint1_placement),
                (cm.joint2_id, cm.joint2_placement),
            ):
                vc = M.actInv(self.data.v[joint])
                ac = M.actInv(self.data.a[joint])
                R = self.data.oMi[joint].rotation @ M.rotation
                acc.append((R, R @ (ac.linear + np.cross(vc.angular, vc.linear))))
            (R1, a1), (_, a2) = acc
            out[k] = R1.T @ (a1 - a2)
        return out.ravel()

    def state(
        self, T: np.ndarray, twist: np.ndarray, q_legs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tree ``q``, ``v`` and ``Jc`` for one platform state and leg positions (6, 3)."""
        R = T[:3, :3]
        q = np.empty(self.model.nq)
        q[self.q_ff] = pin.SE3ToXYZQUAT(pin.SE3(R, T[:3, 3]))
        q[self.q_legs] = np.asarray(q_legs, float).ravel()
        pin.forwardKinematics(self.model, self.data, q)
        gap = largest_loop_gap(self.data, self.cmodels)
        if not gap <= CLOSURE_TOLERANCE:
            raise InputError(
                f"the leg joint positions do not close the loops (largest gap {gap:.3g} m > "
                f"{CLOSURE_TOLERANCE:g} m): give the inverse geometry of the pose"
            )
        Jc = self.constraint_jacobian(q)
        v = np.zeros(self.nv)
        v[self.v_ff] = np.concatenate([R.T @ twist[:3], R.T @ twist[3:]])
        v[self.v_legs] = solve(Jc[:, self.v_legs], -Jc[:, self.v_ff] @ v[self.v_ff], "Jc legs")
        return q, v, Jc

    # ------------------------------------------------------------------ one state
    def motion(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Tree ``q``, ``v``, ``a`` (leg accelerations from ``Jc a + drift = 0``) and the
        KKT matrix ``[S^T, Jc^T]`` (nv, nv) of one platform state."""
        q, v, Jc = self.state(T, twist, q_legs)
        R = T[:3, :3]
        a = np.zeros(self.nv)
        v_loc, w_loc = R.T @ twist[:3], R.T @ twist[3:]
        a[self.v_ff] = np.concatenate([R.T @ accel[:3] - np.cross(w_loc, v_loc), R.T @ accel[3:]])
        pin.forwardKinematics(self.model, self.data, q, v, a)
        residual = self.loop_accelerations()
        a[self.v_legs] = solve(Jc[:, self.v_legs], -residual, "Jc legs")
        K = np.zeros((self.nv, self.nv))
        K[self.v_act, np.arange(6)] = 1.0
        K[:, 6:] = Jc.T
        return q, v, a, K

    def inverse_one(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        return self.inverse_with_forces_one(T, twist, accel, q_legs)[::2]

    def inverse_with_forces_one(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Gamma`` (6,), the force of each leg on the platform at ``P_i`` in F0 (6, 3)
        [N] (the loop multipliers, which act on the leg side in the contact frame c1:
        their opposite, rotated to F0) and the tree's accelerations (nv,)."""
        q, v, a, K = self.motion(T, twist, accel, q_legs)
        if self.compensated:
            fext = self.compensation_forces()
            tau = pin.rnea(self.model, self.data, q, v, a, fext)
        else:
            tau = pin.rnea(self.model, self.data, q, v, a)
        tau = tau + self.joint_torques(q, v)
        x = solve(K, tau, "[S^T, Jc^T]")
        lam = x[6:].reshape(-1, 3)
        rotations = np.array([cd.oMc1.rotation for cd in self.cdatas])
        return x[:6], -np.einsum("kij,kj->ki", rotations, lam), a

    def regressor_one(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: np.ndarray
    ) -> np.ndarray:
        """The regressor (6, 280) of one state from the tree: the tree's joint torques per
        standard parameter (``pin.computeJointTorqueRegressor`` for the 19 bodies, the
        joint terms ``[qddot, qdot, sign(qdot), q, 1]`` on each leg joint), each mapped to
        the actuated efforts by the KKT solve ``[S^T, Jc^T] [Gamma; lambda] = tau``.

        Columns: leg i link j (10, Khalil's order, in its frame about its origin; leg-major),
        the platform's 10 (in Fp about O_p), then per leg joint ``IA FV FC K OF``.
        """
        if self.compensated:
            raise InputError(
                "the tree's regressor has no per-body gravity compensation (its gravity "
                "columns would need each body's weight scaled): not for such a robot"
            )
        q, v, a, K = self.motion(T, twist, accel, q_legs)
        Y = pin.computeJointTorqueRegressor(self.model, self.data, q, v, a)
        tau = np.zeros((self.nv, 280))
        khalil = np.argsort(_KHALIL_TO_PIN)  # Pinocchio's order -> Khalil's
        for i in range(6):
            for j in range(3):
                jid = self.model.getJointId(leg_joint_name(i + 1, j + 1))
                tau[:, 30 * i + 10 * j : 30 * i + 10 * j + 10] = Y[:, 10 * (jid - 1) + khalil]
        ff = self.tree.platform_joint
        tau[:, 180:190] = Y[:, 10 * (ff - 1) + khalil]
        ql, vl, al = q[self.q_legs], v[self.v_legs], a[self.v_legs]
        for k, (row, qk, vk, ak) in enumerate(zip(self.v_legs, ql, vl, al, strict=True)):
            tau[row, 190 + 5 * k : 195 + 5 * k] = [ak, vk, coulomb_sign(np.array(vk)), qk, 1.0]
        x = solve(K, tau, "[S^T, Jc^T]")
        return np.asarray(x[:6])

    def forward_one(
        self, T: np.ndarray, twist: np.ndarray, gamma: np.ndarray, q_legs: np.ndarray
    ) -> np.ndarray:
        q, v, _ = self.state(T, twist, q_legs)
        tau = -self.joint_torques(q, v)
        if self.compensated:
            tau += self.compensation_torques(q)
        tau[self.v_act] += gamma
        ddq = np.array(
            pin.constraintDynamics(
                self.model, self.data, q, v, tau, self.cmodels, self.cdatas, self.settings
            )
        )
        if not np.all(np.isfinite(ddq)):
            raise SingularityError("pin.constraintDynamics: non-finite accelerations")
        R = T[:3, :3]
        vl, wl = v[self.v_ff][:3], v[self.v_ff][3:]
        af = ddq[self.v_ff]
        return np.concatenate([R @ (af[:3] + np.cross(wl, vl)), R @ af[3:]])

    def energy_one(
        self, T: np.ndarray, twist: np.ndarray, q_legs: np.ndarray
    ) -> tuple[float, float]:
        q, v, _ = self.state(T, twist, q_legs)
        kinetic = pin.computeKineticEnergy(self.model, self.data, q, v)
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        kinetic_m = 0.5 * v @ M @ v  # with model.armature
        if not abs(kinetic - kinetic_m) <= 1e-9 * max(abs(kinetic_m), 1e-300):
            kinetic = kinetic_m  # computeKineticEnergy without the armature: use M's
        potential = pin.computePotentialEnergy(self.model, self.data, q)
        potential += compensation_potential(self.model, self.data, self.compensated)
        ql = q[self.q_legs]
        potential += 0.5 * float(self.stiffness @ (ql - self.rest) ** 2)
        return float(kinetic), float(potential)

    def dissipated_one(self, T: np.ndarray, twist: np.ndarray, q_legs: np.ndarray) -> float:
        _, v, _ = self.state(T, twist, q_legs)
        vl = v[self.v_legs]
        return float(self.viscous @ vl**2 + self.coulomb @ np.abs(vl))


def compensation_forces(
    model: pin.Model, data: pin.Data, compensated: list[tuple[int, float]]
) -> list[pin.Force]:
    """The forces ``-c_b m_b g`` at the centres of mass of the bodies ``compensated``
    (``(joint id, c_b)``, one body per joint, F0), each as a ``pin.Force`` in its joint's
    frame (``fext`` of ``pin.rnea``; one per joint), at the placements in ``data`` (after
    ``pin.forwardKinematics``)."""
    g = np.array(model.gravity.linear)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for jid, c in compensated:
        body = model.inertias[jid]
        f = data.oMi[jid].rotation.T @ (-c * body.mass * g)
        fext[jid] = pin.Force(f, np.cross(body.lever, f))
    return fext


def compensation_torques(
    model: pin.Model, data: pin.Data, compensated: list[tuple[int, float]], q: np.ndarray
) -> np.ndarray:
    """``J^T fext`` (nv,): :func:`compensation_forces` at ``q`` as joint torques (the
    difference of ``pin.rnea`` at rest without and with them)."""
    zero = np.zeros(model.nv)
    pin.forwardKinematics(model, data, q)
    fext = compensation_forces(model, data, compensated)
    without = pin.rnea(model, data, q, zero, zero)
    return np.asarray(without - pin.rnea(model, data, q, zero, zero, fext))


def compensation_potential(
    model: pin.Model, data: pin.Data, compensated: list[tuple[int, float]]
) -> float:
    """The potential of the compensating forces, ``sum c_b m_b (g dot com_b)`` [J], at the
    placements in ``data``."""
    g = np.array(model.gravity.linear)
    out = 0.0
    for jid, c in compensated:
        body = model.inertias[jid]
        out += c * body.mass * float(g @ data.oMi[jid].act(body.lever))
    return out


def largest_loop_gap(data: pin.Data, cmodels: Any) -> float:
    """The largest distance [m] between the two contact frames of the loop closures
    ``cmodels`` at the placements in ``data`` (after ``pin.forwardKinematics``)."""
    gap = 0.0
    for cm in cmodels:
        p1 = (data.oMi[cm.joint1_id] * cm.joint1_placement).translation
        p2 = (data.oMi[cm.joint2_id] * cm.joint2_placement).translation
        gap = max(gap, float(np.linalg.norm(p1 - p2)))
    return gap


def solve(A: np.ndarray, b: np.ndarray, what: str) -> np.ndarray:
    try:
        x = np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularityError(
            f"{what} is singular (a singular configuration)", np.inf, 0.0
        ) from e
    if not np.all(np.isfinite(x)):
        raise SingularityError(f"{what} gave non-finite values", np.inf, 0.0)
    return x


def _batch(*arrays: Any) -> tuple[np.ndarray, ...]:
    out = tuple(np.asarray(a, dtype=float) for a in arrays)
    n = out[0].shape[0]
    if any(a.shape[0] != n for a in out):
        raise InputError("every argument must have the same leading batch size")
    return out


def reference_inverse_dynamics(
    solver: GeneralTreeSolver, poses: Any, twists: Any, accels: Any, q_legs: Any
) -> np.ndarray:
    """The actuated efforts (N, 6) from the constrained tree (KKT solve); ``q_legs``
    (N, 6, 3) the leg joint positions of each pose."""
    T, V, A, Q = _batch(poses, twists, accels, q_legs)
    return np.array([solver.inverse_one(*x)[0] for x in zip(T, V, A, Q, strict=True)])


def reference_regressor(
    solver: GeneralTreeSolver, poses: Any, twists: Any, accels: Any, q_legs: Any
) -> np.ndarray:
    """The regressor (N, 6, 280) from the constrained tree
    (:meth:`GeneralTreeSolver.regressor_one`)."""
    T, V, A, Q = _batch(poses, twists, accels, q_legs)
    return np.array([solver.regressor_one(*x) for x in zip(T, V, A, Q, strict=True)])


def reference_direct_dynamics(
    solver: GeneralTreeSolver, poses: Any, twists: Any, gammas: Any, q_legs: Any
) -> np.ndarray:
    """The platform's classical acceleration (N, 6) from ``pin.constraintDynamics``."""
    T, V, G, Q = _batch(poses, twists, gammas, q_legs)
    return np.array([solver.forward_one(*x) for x in zip(T, V, G, Q, strict=True)])


def reference_energy(
    solver: GeneralTreeSolver, poses: Any, twists: Any, q_legs: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kinetic and potential energy (N,) and the dissipated power (N,) from the tree."""
    T, V, Q = _batch(poses, twists, q_legs)
    e = np.array([solver.energy_one(*x) for x in zip(T, V, Q, strict=True)])
    p = np.array([solver.dissipated_one(*x) for x in zip(T, V, Q, strict=True)])
    return e[:, 0], e[:, 1], p


__all__ = [
    "CLOSURE_TOLERANCE",
    "GeneralTreeSolver",
    "largest_loop_gap",
    "reference_direct_dynamics",
    "reference_energy",
    "reference_inverse_dynamics",
    "reference_regressor",
]
