"""The independent check of a hexapod carrying a payload: Pinocchio's constrained dynamics
of the WHOLE tree (six legs, the platform as a free-flyer, the payload appended to the
platform's body with ``pin.appendModel``) closed by the six loop constraints.

Shares no algebra with :mod:`stewart_pin.dynamics` (neither the closure projection nor
the payload's free-flyer RNEA of :mod:`stewart_pin.dynamics.payload`). The tree is the
robot's own closed-loop tree (6-UPS: from the generated URDF,
:func:`~stewart_pin.models.pinocchio_models.build_tree`; general legs:
:func:`~stewart_pin.models.leg_chains.build_general_tree` with ``model.armature`` and the
joint terms of :class:`~stewart_pin.check.leg_chain_tree.GeneralTreeSolver`), with the
payload's model appended at ``T_p_b`` on the platform's joint
(:func:`~stewart_pin.models.payload.attach_payload`). The leg joint *positions* come
from the robot's inverse geometry (checked to close the loops); everything else from
Pinocchio on that tree:

- leg rates from ``Jc v = 0`` (the payload's columns of ``Jc`` are zero: no loop passes
  through it), the payload's rates given;
- inverse dynamics: leg accelerations from ``Jc a + drift = 0`` (classical point
  accelerations), ``tau = rnea(q, v, a) + tau_joint``; the tree's rows solve
  ``[S^T, Jc^T] [Gamma; lambda] = tau``, the payload's rows are its joint torques;
- direct dynamics, torque-driven: ``pin.constraintDynamics`` with
  ``tau = S^T Gamma - tau_joint`` on the tree and the payload's torques on its joints
  (``ProximalSettings(1e-14, 0, 1)``: an exact KKT solve);
- direct dynamics, prescribed joint motion: the KKT system of the same equations with the
  payload's accelerations moved to the right-hand side, ``M`` from ``pin.crba``, ``b``
  from ``pin.nonLinearEffects``, ``Jc`` and the drift as above (NumPy solve).

Conventions as :mod:`stewart_pin.check.constrained_dynamics`. A Python loop over states:
a reference, not a fast path.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_scalar
from stewart_pin.check.constrained_dynamics import (
    DDM_TOLERANCE,
    IDM_TOLERANCE,
    RELATIVE_FLOOR,
    relative_error,
    verdict_line,
)
from stewart_pin.check.leg_chain_tree import (
    CLOSURE_TOLERANCE,
    GeneralTreeSolver,
    largest_loop_gap,
)
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.exceptions import InputError, InputTypeError, SingularityError, WorkspaceError
from stewart_pin.models.payload import Payload, attach_payload
from stewart_pin.models.pinocchio_models import TreeModel
from stewart_pin.protocols import PayloadRobotLike, RobotLike

__all__ = [
    "PayloadTreeSolver",
    "PayloadValidationReport",
    "validate_payload",
]


def _solve(A: np.ndarray, b: np.ndarray, what: str) -> np.ndarray:
    try:
        x = np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularityError(f"{what} is singular (a singular configuration)") from e
    if not np.all(np.isfinite(x)):
        raise SingularityError(f"{what} gave non-finite values (a singular configuration)")
    return np.asarray(x, dtype=float)


class PayloadTreeSolver:
    """The closed-loop tree of ``robot`` with ``payload`` appended to its platform, and
    Pinocchio's constrained dynamics on it.

    Args:
        robot: the hexapod (its ``description``, ``tree`` for the ideal 6-UPS, and
            ``inverse_geometry`` for the leg joint positions).
        payload: the payload and its placement ``T_p_b``.
    """

    def __init__(self, robot: RobotLike, payload: Payload) -> None:
        if not isinstance(payload, Payload):
            raise InputTypeError(f"expected a Payload, got {type(payload).__name__}")
        self.robot, self.payload = robot, payload
        desc = robot.description
        general = general_from_description(desc)
        tree = robot.tree  # every robot's closed-loop tree (models.leg_chains)
        attached = attach_payload(tree.model, tree.platform_joint, payload)
        model, self.q_p, self.v_p = attached.model, attached.q_index, attached.v_index
        model.gravity = pin.Motion(np.asarray(desc.gravity, float), np.zeros(3))
        joints = attached.host_joints
        constraints = []
        for cm in tree.constraints:
            new = pin.RigidConstraintModel(
                cm.type,
                model,
                int(joints[cm.joint1_id]),
                cm.joint1_placement,
                int(joints[cm.joint2_id]),
                cm.joint2_placement,
                cm.reference_frame,
            )
            new.name = cm.name
            constraints.append(new)
        hq, hv = attached.host_q, attached.host_v
        whole = TreeModel(
            model=model,
            constraints=constraints,
            platform_joint=int(joints[tree.platform_joint]),
            leg_q_index=hq[tree.leg_q_index],
            leg_v_index=hv[tree.leg_v_index],
            platform_q_index=hq[tree.platform_q_index],
            platform_v_index=hv[tree.platform_v_index],
            actuated=tree.actuated,
        )
        #: The tree's loop constraints, joint terms and loop accelerations (its
        #: ``constraint_jacobian``, ``loop_accelerations`` and ``joint_torques`` work on
        #: the whole tree: the payload's joints carry no joint terms).
        self.tree = GeneralTreeSolver(general, whole)
        self.model, self.data = model, self.tree.data
        self.nv = model.nv
        self.rows = np.setdiff1d(np.arange(self.nv), self.v_p)  # the hexapod's dofs
        # [S^T, Jc^T] restricted to the hexapod's rows: S^T's columns
        self.S_T = np.zeros((len(self.rows), 6))
        for k, idx in enumerate(self.tree.v_act):
            self.S_T[np.searchsorted(self.rows, idx), k] = 1.0

    # ------------------------------------------------------------------ one state
    def state(
        self, T: np.ndarray, twist: np.ndarray, q_legs: np.ndarray, q: np.ndarray, qd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The whole tree's ``x`` (nq), ``v`` (nv) and ``Jc`` (18, nv) at one state."""
        s = self.tree
        R = T[:3, :3]
        x = np.array(pin.neutral(self.model))
        x[s.q_ff] = pin.SE3ToXYZQUAT(pin.SE3(R, T[:3, 3]))
        x[s.q_legs] = np.asarray(q_legs, float).ravel()
        x[self.q_p] = q
        pin.forwardKinematics(self.model, self.data, x)
        gap = largest_loop_gap(self.data, s.cmodels)
        if not gap <= CLOSURE_TOLERANCE:
            raise InputError(
                f"the leg joint positions do not close the loops (largest gap {gap:.3g} m)"
            )
        Jc = s.constraint_jacobian(x)
        if np.abs(Jc[:, self.v_p]).max(initial=0.0) > 0.0:
            raise InputError("a loop constraint acts on the payload's joints")
        v = np.zeros(self.nv)
        v[s.v_ff] = np.concatenate([R.T @ twist[:3], R.T @ twist[3:]])
        v[self.v_p] = qd
        rhs = -Jc[:, s.v_ff] @ v[s.v_ff]
        v[s.v_legs] = _solve(Jc[:, s.v_legs], rhs, "the legs' constraint Jacobian")
        return x, v, Jc

    def _classical(self, T: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        R = T[:3, :3]
        s = self.tree
        vl, wl, af = v[s.v_ff][:3], v[s.v_ff][3:], a[s.v_ff]
        return np.concatenate([R @ (af[:3] + np.cross(wl, vl)), R @ af[3:]])

    def inverse_one(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        accel: np.ndarray,
        q_legs: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray,
        qdd: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(Gamma (6,), tau (nv_payload,))`` at one state."""
        s = self.tree
        x, v, Jc = self.state(T, twist, q_legs, q, qd)
        R = T[:3, :3]
        a = np.zeros(self.nv)
        v_loc, w_loc = R.T @ twist[:3], R.T @ twist[3:]
        a[s.v_ff] = np.concatenate([R.T @ accel[:3] - np.cross(w_loc, v_loc), R.T @ accel[3:]])
        a[self.v_p] = qdd
        pin.forwardKinematics(self.model, self.data, x, v, a)
        residual = s.loop_accelerations()
        a[s.v_legs] = _solve(Jc[:, s.v_legs], -residual, "the legs' constraint Jacobian")
        tau = pin.rnea(self.model, self.data, x, v, a) + s.joint_torques(x, v)
        K = np.concatenate([self.S_T, Jc[:, self.rows].T], axis=1)
        sol = _solve(K, tau[self.rows], "[S^T, Jc^T] (the parallel Jacobian)")
        return sol[:6], np.asarray(tau[self.v_p], dtype=float)

    def forward_one(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        gamma: np.ndarray,
        q_legs: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray,
        tau_p: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(A (6,) classical in F0, qdd (nv_payload,))`` from ``pin.constraintDynamics``
        under the actuator efforts and the payload's joint torques."""
        s = self.tree
        x, v, _ = self.state(T, twist, q_legs, q, qd)
        tau = -s.joint_torques(x, v)
        tau[s.v_act] += gamma
        tau[self.v_p] += tau_p
        ddq = np.array(
            pin.constraintDynamics(
                self.model, self.data, x, v, tau, s.cmodels, s.cdatas, s.settings
            )
        )
        if not np.all(np.isfinite(ddq)):
            raise SingularityError("pin.constraintDynamics: non-finite accelerations")
        return self._classical(T, v, ddq), ddq[self.v_p]

    def prescribed_one(
        self,
        T: np.ndarray,
        twist: np.ndarray,
        gamma: np.ndarray,
        q_legs: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray,
        qdd: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(A (6,), tau (nv_payload,))`` with the payload's joint accelerations
        prescribed: the KKT system ``M_rr z - Jc_r^T lambda = S^T Gamma - tau_joint - b_r
        - M_rp qdd``, ``Jc_r z = -drift`` on the hexapod's dofs ``r``, then
        ``tau = M_pr z + M_pp qdd + b_p``."""
        s = self.tree
        x, v, Jc = self.state(T, twist, q_legs, q, qd)
        M = np.array(pin.crba(self.model, self.data, x))
        M = np.triu(M) + np.triu(M, 1).T
        b = np.array(pin.nonLinearEffects(self.model, self.data, x, v))
        pin.forwardKinematics(self.model, self.data, x, v, np.zeros(self.nv))
        drift = s.loop_accelerations()
        r, p = self.rows, self.v_p
        tau_joint = s.joint_torques(x, v)
        nr, nc = len(r), Jc.shape[0]
        K = np.zeros((nr + nc, nr + nc))
        K[:nr, :nr] = M[np.ix_(r, r)]
        K[:nr, nr:] = -Jc[:, r].T
        K[nr:, :nr] = Jc[:, r]
        rhs = np.concatenate(
            [self.S_T @ gamma - tau_joint[r] - b[r] - M[np.ix_(r, p)] @ qdd, -drift]
        )
        z = _solve(K, rhs, "the KKT matrix")[:nr]
        a = np.zeros(self.nv)
        a[r], a[p] = z, qdd
        tau = M[p] @ a + b[p]
        return self._classical(T, v, a), tau


# ---------------------------------------------------------------------------- batches
def _legs(robot: RobotLike, poses: np.ndarray) -> np.ndarray:
    return np.asarray(robot.inverse_geometry(poses, check_limits=False), dtype=float)


def _each_state(
    one: Callable[..., tuple[np.ndarray, np.ndarray]],
    solver: PayloadTreeSolver,
    poses: Any,
    *columns: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """``one(T, twist, x, q_legs, q, qd, y)`` state by state over a batch ``(poses,
    twists, x, q, qd, y)``, the leg joint positions from the robot's inverse geometry:
    its two outputs stacked, ``(N, 6)`` and ``(N, nv)``."""
    T = np.asarray(poses, float)
    twists, x, q, qd, y = columns
    L = _legs(solver.robot, T)
    out = [one(*state) for state in zip(T, twists, x, L, q, qd, y, strict=True)]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out]).reshape(len(T), -1)


def reference_inverse_dynamics(
    solver: PayloadTreeSolver, poses: Any, twists: Any, accels: Any, q: Any, qd: Any, qdd: Any
) -> tuple[np.ndarray, np.ndarray]:
    """``(Gamma (N, 6), tau (N, nv))`` from the whole constrained tree (batches)."""
    return _each_state(solver.inverse_one, solver, poses, twists, accels, q, qd, qdd)


def reference_direct_dynamics(
    solver: PayloadTreeSolver, poses: Any, twists: Any, gammas: Any, q: Any, qd: Any, tau: Any
) -> tuple[np.ndarray, np.ndarray]:
    """``(A (N, 6), qdd (N, nv))`` from ``pin.constraintDynamics`` on the whole tree."""
    return _each_state(solver.forward_one, solver, poses, twists, gammas, q, qd, tau)


def reference_prescribed_dynamics(
    solver: PayloadTreeSolver, poses: Any, twists: Any, gammas: Any, q: Any, qd: Any, qdd: Any
) -> tuple[np.ndarray, np.ndarray]:
    """``(A (N, 6), tau (N, nv))`` with the payload's joint accelerations prescribed."""
    return _each_state(solver.prescribed_one, solver, poses, twists, gammas, q, qd, qdd)


# ---------------------------------------------------------------------------- the check
def _count(value: Any, name: str, least: int) -> int:
    """``value`` as an int >= ``least`` (integral floats accepted), else InputError."""
    n = int(check_scalar(value, name, integer=True))
    if n < least:
        raise InputError(f"{name} must be an integer >= {least}, got {value!r}")
    return n


@dataclass(frozen=True)
class PayloadValidationReport:
    """The coupled models of a hexapod and its payload against the whole constrained tree,
    over random states (relative errors, :func:`relative_error`).

    Attributes:
        robot: ``"<hexapod>+<payload>"``. n_states: states compared.
        idm_error: the actuator efforts Gamma of the inverse model.
        torque_error: the payload's joint torques of the inverse model.
        ddm_error: the torque-driven direct model (platform acceleration and payload joint
            accelerations, the larger) under the reference Gamma and torques, against
            ``pin.constraintDynamics``.
        prescribed_error: the direct model with the payload's joint accelerations
            prescribed (platform acceleration and the torques it takes) against the
            tree's KKT solve.
        round_trip_error: both direct models after the inverse one, against the drawn
            accelerations (the models alone).
        reference_error: the same round trips through the tree alone.
    """

    robot: str
    n_states: int
    idm_error: float
    torque_error: float
    ddm_error: float
    prescribed_error: float
    round_trip_error: float
    reference_error: float
    floor: float = RELATIVE_FLOOR

    def passed(self, tol_idm: float = IDM_TOLERANCE, tol_ddm: float = DDM_TOLERANCE) -> bool:
        """Inverse model (Gamma and torques) within ``tol_idm``; direct models, round
        trips and the reference's own within ``tol_ddm``."""
        return bool(
            max(self.idm_error, self.torque_error) <= tol_idm
            and max(
                self.ddm_error,
                self.prescribed_error,
                self.round_trip_error,
                self.reference_error,
            )
            <= tol_ddm
        )

    def summary(self, tol_idm: float = IDM_TOLERANCE, tol_ddm: float = DDM_TOLERANCE) -> str:
        """The errors and one verdict, at the tolerances given (``str(report)``: the
        defaults)."""
        return (
            f"validation of '{self.robot}' (hexapod and payload) against Pinocchio's "
            f"constrained dynamics of the whole tree, {self.n_states} random states "
            f"(relative errors, floor {self.floor:g}):\n"
            f"  inverse dynamics  Gamma            {self.idm_error:.3e}\n"
            f"  inverse dynamics  payload torques  {self.torque_error:.3e}\n"
            f"  direct dynamics   torque-driven    {self.ddm_error:.3e}\n"
            f"  direct dynamics   prescribed qdd   {self.prescribed_error:.3e}\n"
            f"  round trip        DDM(IDM)         {self.round_trip_error:.3e}\n"
            f"  reference         FD(ID) tree      {self.reference_error:.3e}\n"
            + verdict_line(self.passed(tol_idm, tol_ddm), tol_idm, tol_ddm)
        )

    def __str__(self) -> str:
        return self.summary()


def validate_payload(
    robot: PayloadRobotLike,
    n_states: int = 50,
    seed: int | None = 0,
    translation_range: float | None = None,
    rotation_range: float = 0.25,
) -> PayloadValidationReport:
    """Compare a :class:`~stewart_pin.payload_robot.PayloadRobot`'s coupled models with
    the whole constrained tree (:class:`PayloadTreeSolver`) on ``n_states`` random states
    (``robot.sample_states``: the hexapod's workspace, the payload within its joint
    limits).

    Raises:
        InputError: a bad ``n_states``. WorkspaceError: too few reachable poses.
    """
    n_states = _count(n_states, "n_states", 1)
    seed = None if seed is None else _count(seed, "seed", 0)
    rng = np.random.default_rng(seed)
    try:
        P, V, A, q, qd, qdd = robot.sample_states(
            n_states, rng, translation=translation_range, rotation=rotation_range
        )
    except WorkspaceError as e:
        raise WorkspaceError(
            f"{e} (validate: translation_range, rotation_range; stewart-pin validate: "
            "--translation, --rotation)"
        ) from e
    solver = PayloadTreeSolver(robot.robot, robot.payload)
    gamma_ref, tau_ref = reference_inverse_dynamics(solver, P, V, A, q, qd, qdd)
    accel_ref, qdd_ref = reference_direct_dynamics(solver, P, V, gamma_ref, q, qd, tau_ref)
    accel_pres_ref, tau_pres_ref = reference_prescribed_dynamics(
        solver, P, V, gamma_ref, q, qd, qdd
    )
    gamma, tau = robot.inverse_dynamics(P, V, A, q, qd, qdd)
    ddm = robot.direct_dynamics(P, V, gamma_ref, q, qd, tau=tau_ref)
    pres = robot.direct_dynamics(P, V, gamma_ref, q, qd, qdd)
    trip = robot.direct_dynamics(P, V, gamma, q, qd, tau=tau)
    trip_pres = robot.direct_dynamics(P, V, gamma, q, qd, qdd)
    return PayloadValidationReport(
        robot=str(robot.name),
        n_states=n_states,
        idm_error=relative_error(gamma, gamma_ref),
        torque_error=relative_error(tau, tau_ref),
        ddm_error=max(relative_error(ddm.accel, accel_ref), relative_error(ddm.qdd, qdd_ref)),
        prescribed_error=max(
            relative_error(pres.accel, accel_pres_ref), relative_error(pres.tau, tau_pres_ref)
        ),
        round_trip_error=max(
            relative_error(trip.accel, A),
            relative_error(trip.qdd, qdd),
            relative_error(trip_pres.accel, A),
        ),
        reference_error=max(
            relative_error(accel_ref, A),
            relative_error(qdd_ref, qdd),
            relative_error(accel_pres_ref, A),
            relative_error(tau_pres_ref, tau_ref),
        ),
    )
