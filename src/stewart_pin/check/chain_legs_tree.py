"""The independent check for robots with chain legs: Pinocchio's constrained tree with 3D
(ball) and 6D (weld) loop constraints.

Shares no algebra with :mod:`stewart_pin.dynamics.chain_leg_dynamics` or
:mod:`stewart_pin.kinematics.chain_legs` (it imports neither): the tree (the platform a
free-flyer, each leg's chain from its MDH placements and inertias converted here, not by
``Joint.placement`` or ``pin_inertia_from_khalil``, ``model.armature``) and its loop
constraints (``pin.RigidConstraintModel``: ``CONTACT_3D`` between the ball centre on the
last link and ``P_i`` on the platform; ``CONTACT_6D`` between the leg's attachment frame
and the platform's) are built here. The leg joint positions are an input (any inverse
geometry may give them), checked to close the loops within :data:`CLOSURE_TOLERANCE`.

- leg rates: ``Jc v = 0`` given the platform's free-flyer velocity;
- inverse dynamics: the leg accelerations from the loops' classical point accelerations
  and angular accelerations being equal on both sides, ``tau = rnea(q, v, a) +
  tau_joint`` (``tau_joint = (Fv + D) qdot + Fc sign(qdot) + K (q - q0)``), then the exact
  KKT solve ``[S^T, Jc^T] [Gamma; lambda] = tau``;
- direct dynamics: ``pin.constraintDynamics`` with ``tau = S^T Gamma - tau_joint`` and
  ``pin.ProximalSettings(1e-14, 0, 1)`` (an exact KKT solve);
- energy: ``1/2 v^T M v`` (CRBA, armature included), ``pin.computePotentialEnergy`` and
  the springs;
- per-body gravity compensation (``platform_gravcomp``, each chain leg's ``gravcomp``: the
  fraction ``c_b`` of body b's weight removed): external forces ``f_b = -c_b m_b g`` at
  each body's centre of mass on the tree, from the tree's own inertias
  (:func:`~stewart_pin.check.leg_chain_tree.compensation_forces`): ``fext`` of ``pin.rnea``
  in the inverse model, ``J^T fext`` added to the torques of ``pin.constraintDynamics`` in
  the direct one, their potential ``c_b m_b g . c_b`` added to the energy; the regressor
  refuses such a robot.

Conventions: pose 0Tp (4, 4), twist ``[v, w]`` of O_p in F0, classical acceleration in
F0, ``Gamma`` (6,) the actuated joints' efforts (joint side). A Python loop over states.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin.check.leg_chain_tree import (
    compensation_forces,
    compensation_potential,
    compensation_torques,
    solve,
)
from stewart_pin.description import RobotDescription
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.exceptions import InputError, SingularityError

#: Khalil's order ``XX XY XZ YY YZ ZZ MX MY MZ M`` -> Pinocchio's ``m mx my mz Ixx Ixy Iyy
#: Ixz Iyz Izz`` (written out here so that the check shares no conversion table).
_KHALIL_TO_PIN = np.array([9, 6, 7, 8, 0, 1, 3, 2, 4, 5])
#: Largest loop-closure error [m, rad] accepted for the given leg joint positions.
CLOSURE_TOLERANCE = 1e-9


def _placement(alpha: float, d: float, theta: float, r: float) -> pin.SE3:
    """Frame j in frame j-1 at q = 0 (modified DH, Khalil): ``Rx(alpha) Tx(d) Rz(theta)
    Tz(r)``, written out here (not ``Joint.placement``)."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    Rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    I3, o = np.eye(3), np.zeros(3)
    return (
        pin.SE3(Rx, o)
        * pin.SE3(I3, np.array([d, 0.0, 0.0]))
        * pin.SE3(Rz, o)
        * pin.SE3(I3, np.array([0.0, 0.0, r]))
    )


def _inertia(params: np.ndarray) -> pin.Inertia:
    """A body's inertia from Khalil's 10 parameters about its frame origin (converted
    here: :data:`_KHALIL_TO_PIN`); a massless body keeps its rotational inertia."""
    p = np.asarray(params, dtype=float)
    if p[9] == 0.0:
        I_O = np.array([[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]])
        return pin.Inertia(0.0, np.zeros(3), I_O)
    return pin.Inertia.FromDynamicParameters(p[_KHALIL_TO_PIN])


class ChainTreeSolver:
    """Pinocchio's tree of a chain-leg robot with its 3D / 6D loop constraints."""

    def __init__(self, desc: RobotDescription) -> None:
        if desc.chain_legs is None:
            raise InputError("ChainTreeSolver takes a description with chain_legs")
        self.desc = desc
        legs = desc.chain_legs
        model = pin.Model()
        model.gravity = pin.Motion(np.asarray(desc.gravity, float), np.zeros(3))
        ff = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform")
        model.appendBodyToJoint(ff, _inertia(desc.platform_inertia), pin.SE3.Identity())
        last, act, armature = [], [], []
        self.leg_joints: list[list[int]] = []
        for k, leg in enumerate(legs):
            parent = 0
            ids = []
            for j, joint in enumerate(leg.joints):
                M = _placement(joint.alpha, joint.d, joint.theta, joint.r)
                if j == 0:
                    M = pin.SE3(desc.leg_base_rotations[k], desc.base_points[k]) * M
                jm = pin.JointModelRZ() if joint.revolute else pin.JointModelPZ()
                parent = model.addJoint(parent, jm, M, f"l{k + 1}j{j + 1}")
                model.appendBodyToJoint(parent, _inertia(leg.inertia[j]), pin.SE3.Identity())
                ids.append(parent)
                armature.append(joint.dynamics.total_armature)
            last.append(parent)
            act.append(ids[leg.actuated - 1])
            self.leg_joints.append(ids)
        arm = np.zeros(model.nv)
        flat = [jid for ids in self.leg_joints for jid in ids]
        for jid, a in zip(flat, armature, strict=True):
            arm[model.idx_vs[jid]] = a
        model.armature = arm
        self.model, self.data = model, model.createData()
        self.cmodels = pin.StdVec_RigidConstraintModel()
        for k, leg in enumerate(legs):
            c1 = pin.SE3(leg.tip_rotation if leg.closure == "weld" else np.eye(3), leg.tip)
            c2 = pin.SE3(
                leg.platform_rotation if leg.closure == "weld" else np.eye(3),
                desc.platform_points[k],
            )
            kind = (
                pin.ContactType.CONTACT_6D if leg.closure == "weld" else pin.ContactType.CONTACT_3D
            )
            self.cmodels.append(
                pin.RigidConstraintModel(
                    kind, model, last[k], c1, ff, c2, pin.ReferenceFrame.LOCAL
                )
            )
        self.cdatas = pin.StdVec_RigidConstraintData()
        for cm in self.cmodels:
            self.cdatas.append(cm.createData())
        pin.initConstraintDynamics(self.model, self.data, self.cmodels, self.cdatas)
        self.settings = pin.ProximalSettings(1e-14, 0.0, 1)
        self.q_legs = np.array([model.idx_qs[j] for j in flat])
        self.v_legs = np.array([model.idx_vs[j] for j in flat])
        self.v_act = np.array([model.idx_vs[j] for j in act])
        #: the idle joints (a leg's ``idle_joint``): their velocity indices and legs
        idle = [(k, leg.idle_joint) for k, leg in enumerate(legs) if leg.idle_joint is not None]
        self.idle_legs = [k for k, _ in idle]
        self.v_idle = np.array(
            [model.idx_vs[self.leg_joints[k][j - 1]] for k, j in idle], dtype=np.int64
        ).reshape(-1)
        # rows picking the idle joints' velocities among the legs' (v_legs order)
        self.E_idle = (self.v_idle[:, None] == self.v_legs[None, :]).astype(float)
        self.nv = model.nv
        dyn = [j.dynamics for leg in legs for j in leg.joints]
        self.viscous = np.array([d.viscous + d.damping for d in dyn])
        self.coulomb = np.array([d.coulomb for d in dyn])
        self.stiffness = np.array([d.stiffness for d in dyn])
        self.rest = np.array([d.rest_position for d in dyn])
        # (joint id, compensation) of each body whose weight is partly compensated
        compensated = [(ff, float(desc.platform_gravcomp))] + [
            (jid, float(c))
            for ids, leg in zip(self.leg_joints, legs, strict=True)
            for jid, c in zip(ids, leg.gravcomp, strict=True)
        ]
        self.compensated = [(jid, c) for jid, c in compensated if c != 0.0]

    # ------------------------------------------------------------------ pieces
    def joint_torques(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        ql, vl = q[self.q_legs], v[self.v_legs]
        tau = np.zeros(self.nv)
        tau[self.v_legs] = (
            self.viscous * vl + self.coulomb * coulomb_sign(vl) + self.stiffness * (ql - self.rest)
        )
        return tau

    def _frames(self, cm: Any) -> list[tuple[pin.SE3, int, pin.SE3]]:
        return [
            (self.data.oMi[j] * M, j, M)
            for j, M in ((cm.joint1_id, cm.joint1_placement), (cm.joint2_id, cm.joint2_placement))
        ]

    def gap(self) -> float:
        """The largest loop error [m or rad] (after forward kinematics)."""
        out = 0.0
        for cm in self.cmodels:
            (A, _, _), (B, _, _) = self._frames(cm)
            out = max(out, float(np.linalg.norm(A.translation - B.translation)))
            if cm.type == pin.ContactType.CONTACT_6D:
                out = max(out, float(np.linalg.norm(pin.log3(A.rotation.T @ B.rotation))))
        return out

    def constraint_jacobian(self, q: np.ndarray) -> np.ndarray:
        pin.computeJointJacobians(self.model, self.data, q)
        for cm, cd in zip(self.cmodels, self.cdatas, strict=True):
            cm.calc(self.model, self.data, cd)
        return pin.getConstraintsJacobian(self.model, self.data, self.cmodels, self.cdatas)

    def loop_accelerations(self) -> np.ndarray:
        """Per loop ``R_c1^T (a_1 - a_2)`` (classical point accelerations) and for a weld
        ``R_c1^T (dw_1 - dw_2)``, stacked as the constraints' rows."""
        out = []
        for cm in self.cmodels:
            acc = []
            for oM, joint, M in self._frames(cm):
                vc = M.actInv(self.data.v[joint])
                ac = M.actInv(self.data.a[joint])
                R = oM.rotation
                acc.append((R, R @ (ac.linear + np.cross(vc.angular, vc.linear)), R @ ac.angular))
            (R1, a1, dw1), (_, a2, dw2) = acc
            out.append(R1.T @ (a1 - a2))
            if cm.type == pin.ContactType.CONTACT_6D:
                out.append(R1.T @ (dw1 - dw2))
        return np.concatenate(out)

    def _legs_solve(self, Jc: np.ndarray, rhs: np.ndarray, idle: np.ndarray) -> np.ndarray:
        """The legs' velocities (or accelerations) from ``Jc_legs x = rhs`` and the idle
        joints' values ``idle`` (one per idle leg)."""
        A = np.vstack([Jc[:, self.v_legs], self.E_idle])
        return solve(A, np.concatenate([rhs, idle]), "Jc legs")

    def state(
        self, T: np.ndarray, twist: np.ndarray, q_legs: Any, idle_rates: Any = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tree ``q``, ``v`` and ``Jc``; ``q_legs`` the legs' joint values (a list of (n_i,)
        or one flat array); ``idle_rates`` (6,) the idle joints' rates (legs with one)."""
        R = T[:3, :3]
        q = np.empty(self.model.nq)
        q[:7] = pin.SE3ToXYZQUAT(pin.SE3(R, T[:3, 3]))
        q[self.q_legs] = np.concatenate([np.ravel(x) for x in q_legs])
        pin.forwardKinematics(self.model, self.data, q)
        gap = self.gap()
        if not gap <= CLOSURE_TOLERANCE:
            raise InputError(
                f"the leg joint positions do not close the loops (largest gap {gap:.3g} > "
                f"{CLOSURE_TOLERANCE:g}): give the inverse geometry of the pose"
            )
        Jc = self.constraint_jacobian(q)
        v = np.zeros(self.nv)
        v[:6] = np.concatenate([R.T @ twist[:3], R.T @ twist[3:]])
        v[self.v_legs] = self._legs_solve(Jc, -Jc[:, :6] @ v[:6], self._idle(idle_rates))
        return q, v, Jc

    def _idle(self, values: Any) -> np.ndarray:
        if not self.idle_legs:
            return np.zeros(0)
        if values is None:
            raise InputError("this robot has idle joints: give their rates (6,)")
        return np.asarray(values, dtype=float)[self.idle_legs]

    def _accelerations(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        accel: np.ndarray,
        q: np.ndarray,
        v: np.ndarray,
        Jc: np.ndarray,
    ) -> np.ndarray:
        """The tree's accelerations (nv,): the free-flyer's from the platform's classical
        acceleration, the legs' from the loops (idle joints at zero acceleration)."""
        R = T[:3, :3]
        a = np.zeros(self.nv)
        v_loc, w_loc = R.T @ twist[:3], R.T @ twist[3:]
        a[:6] = np.concatenate([R.T @ accel[:3] - np.cross(w_loc, v_loc), R.T @ accel[3:]])
        pin.forwardKinematics(self.model, self.data, q, v, a)
        idle = np.zeros(len(self.idle_legs))
        a[self.v_legs] = self._legs_solve(Jc, -self.loop_accelerations(), idle)
        return a

    # ------------------------------------------------------------------ one state
    def inverse_one(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: Any
    ) -> np.ndarray:
        """``Gamma`` (6,) by the exact KKT solve."""
        return self.inverse_idle_one(T, twist, accel, q_legs)[0]

    def inverse_idle_one(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        accel: np.ndarray,
        q_legs: Any,
        idle_rates: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``Gamma`` (6,) and the idle joints' accelerations (6,) (0 for legs without one)
        by the exact KKT solve; the idle accelerations are unknowns beside Gamma and the
        loop forces: ``[S^T, Jc^T, -M N] [Gamma; lambda; sigma] = tau(a0)`` with the leg
        accelerations ``a0 + N sigma``."""
        q, v, Jc = self.state(T, twist, q_legs, idle_rates)
        n_idle = len(self.idle_legs)
        a = self._accelerations(T, twist, accel, q, v, Jc)
        fext = compensation_forces(self.model, self.data, self.compensated)
        tau = pin.rnea(self.model, self.data, q, v, a, fext) + self.joint_torques(q, v)
        N = np.zeros((self.nv, n_idle))
        for i in range(n_idle):
            N[self.v_legs, i] = self._legs_solve(Jc, np.zeros(Jc.shape[0]), np.eye(n_idle)[i])
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        K = np.zeros((self.nv, self.nv))
        K[self.v_act, np.arange(6)] = 1.0
        K[:, 6 : 6 + Jc.shape[0]] = Jc.T
        K[:, 6 + Jc.shape[0] :] = -M @ N
        x = solve(K, tau, "[S^T, Jc^T, -M N]")
        sigma = np.zeros(6)
        sigma[self.idle_legs] = x[6 + Jc.shape[0] :]
        return x[:6], sigma

    def regressor_one(
        self, T: np.ndarray, twist: np.ndarray, accel: np.ndarray, q_legs: Any
    ) -> np.ndarray:
        """The regressor (6, n_p) of one state from the tree (robots without idle joints):
        ``pin.computeJointTorqueRegressor`` for every body (Khalil's order, leg-major, then
        the platform's 10) and the joint terms ``[qddot, qdot, sign(qdot), q, 1]`` of each
        leg joint, each column mapped to the actuated efforts by the KKT solve
        ``[S^T, Jc^T] [Gamma; lambda] = tau``."""
        if self.idle_legs:
            raise InputError("a robot with idle joints has no regressor")
        if self.compensated:
            raise InputError(
                "the tree's regressor has no per-body gravity compensation (its gravity "
                "columns would need each body's weight scaled): not for such a robot"
            )
        q, v, Jc = self.state(T, twist, q_legs)
        a = self._accelerations(T, twist, accel, q, v, Jc)
        Y = pin.computeJointTorqueRegressor(self.model, self.data, q, v, a)
        khalil = np.argsort(_KHALIL_TO_PIN)
        flat = [jid for ids in self.leg_joints for jid in ids]
        n_links = len(flat)
        tau = np.zeros((self.nv, 10 * n_links + 10 + 5 * n_links))
        for c, jid in enumerate(flat):
            tau[:, 10 * c : 10 * c + 10] = Y[:, 10 * (jid - 1) + khalil]
        tau[:, 10 * n_links : 10 * n_links + 10] = Y[:, khalil]  # the free-flyer: joint 1
        ql, vl, al = q[self.q_legs], v[self.v_legs], a[self.v_legs]
        base = 10 * n_links + 10
        for c, (row, qc, vc, ac) in enumerate(zip(self.v_legs, ql, vl, al, strict=True)):
            sign = float(coulomb_sign(np.array(vc)))
            tau[row, base + 5 * c : base + 5 * c + 5] = [ac, vc, sign, qc, 1.0]
        K = np.zeros((self.nv, self.nv))
        K[self.v_act, np.arange(6)] = 1.0
        K[:, 6:] = Jc.T
        return np.asarray(solve(K, tau, "[S^T, Jc^T]")[:6])

    def forward_one(
        self, T: np.ndarray, twist: np.ndarray, gamma: np.ndarray, q_legs: Any
    ) -> np.ndarray:
        """The platform's classical acceleration (6,) from ``pin.constraintDynamics``."""
        return self.forward_idle_one(T, twist, gamma, q_legs)[0]

    def forward_idle_one(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        gamma: np.ndarray,
        q_legs: Any,
        idle_rates: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The platform's classical acceleration (6,) and the idle joints' accelerations
        (6,) (0 for legs without one) from ``pin.constraintDynamics``."""
        q, v, _ = self.state(T, twist, q_legs, idle_rates)
        tau = -self.joint_torques(q, v)
        if self.compensated:
            tau += compensation_torques(self.model, self.data, self.compensated, q)
        tau[self.v_act] += gamma
        ddq = np.array(
            pin.constraintDynamics(
                self.model, self.data, q, v, tau, self.cmodels, self.cdatas, self.settings
            )
        )
        if not np.all(np.isfinite(ddq)):
            raise SingularityError("pin.constraintDynamics: non-finite accelerations")
        R = T[:3, :3]
        vl, wl = v[:3], v[3:6]
        sigma = np.zeros(6)
        sigma[self.idle_legs] = ddq[self.v_idle]
        return np.concatenate([R @ (ddq[:3] + np.cross(wl, vl)), R @ ddq[3:6]]), sigma

    def energy_one(
        self, T: np.ndarray, twist: np.ndarray, q_legs: Any, idle_rates: Any = None
    ) -> tuple[float, float]:
        q, v, _ = self.state(T, twist, q_legs, idle_rates)
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        potential = pin.computePotentialEnergy(self.model, self.data, q)
        potential += compensation_potential(self.model, self.data, self.compensated)
        ql = q[self.q_legs]
        potential += 0.5 * float(self.stiffness @ (ql - self.rest) ** 2)
        return float(0.5 * v @ M @ v), float(potential)


__all__ = ["CLOSURE_TOLERANCE", "ChainTreeSolver"]
