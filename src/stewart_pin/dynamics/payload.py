"""A payload moving on the platform: its reaction on the platform from Pinocchio's RNEA,
and the coupled inverse and direct models of hexapod and payload.

The payload (:class:`~stewart_pin.models.payload.Payload`, its base frame ``Fb`` at
``T_p_b`` in ``Fp``) runs on a free-flyer whose motion is the platform's
(:func:`~stewart_pin.models.payload.floating_payload_model`). With the platform's pose
``(R, p)``, twist ``V = [v, w]`` and **classical** acceleration ``A = [vdot, wdot]`` (all
in F0, about O_p, as everywhere in the library), the free-flyer's velocity and
acceleration (Pinocchio's: the body twist of ``Fb`` in ``Fb`` and its time derivative)
are

    nu_b = Ad_bp [R^T v; R^T w],      a_b = X A + c,
    X = Ad_bp diag(R^T, R^T),         c = Ad_bp [-(R^T w) x (R^T v); 0],

``Ad_bp`` the (constant) motion transform from ``Fp`` to ``Fb`` (``T_b_p = T_p_b^-1``);
``c`` is the classical-to-spatial term of ``docs/conventions.md``, carried to ``Fb``.
Pinocchio's RNEA on the floating payload, ``tau = rnea([T_0_b, q], [nu_b, qd],
[a_b, qdd])``, gives the wrench the platform applies to the payload's base, ``tau_f``
(its first six rows, in ``Fb``), and the payload's joint torques ``tau_j`` (the others).
By virtual power the same wrench in F0 about O_p is ``W = X^T tau_f``: the payload's
reaction on the platform is ``-W``.

- **Inverse model**: the hexapod must also supply ``W``, so
  ``Gamma = Jp^T (F_p + F_leg + W) = Gamma_hexapod + Jp^T W`` (eq. 31 with the payload's
  wrench added to the platform's): the hexapod's own model (either leg path, either
  backend) plus the payload's share.
- **Direct models**: with ``M = [[M_ff, M_fj], [M_jf, M_jj]]`` the floating payload's
  mass matrix (CRBA) and ``b = rnea(q, v, [c, 0])`` its bias at zero platform and joint
  accelerations, the payload adds ``X^T M_ff X`` to the platform's inertia and couples
  through ``X^T M_fj``:

      | A_robot + X^T M_ff X   X^T M_fj | | A   |   | Jp^-T Gamma - h_robot - X^T b_f |
      | M_jf X                 M_jj     | | qdd | = | tau_j - b_j                     |

  the **coupled mass matrix** of platform and payload (symmetric positive definite, size
  6 + nv) with ``A_robot, h_robot`` the hexapod's (eq. 36-37). Given the joint torques
  ``tau_j`` it is solved for ``(A, qdd)``; given the joint motion (``qdd`` prescribed), its
  first row alone gives ``A`` (the platform's inertia ``A_robot + X^T M_ff X``) and its
  second row the torques that realise the motion.

Batches throughout: poses (N, 4, 4), twists and accelerations (N, 6), payload
configurations (N, nq), rates, accelerations and torques (N, nv).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from stewart_pin._checks import cholesky_failures, in_batch
from stewart_pin._so3 import cross
from stewart_pin._typing import FloatArray
from stewart_pin.dynamics.closed_loop import check_finite
from stewart_pin.exceptions import SingularityError
from stewart_pin.models.payload import Payload, floating_payload_model

__all__ = [
    "CoupledTerms",
    "PayloadAcceleration",
    "PayloadDynamics",
    "PayloadEfforts",
    "PayloadInverseDynamics",
    "coupled_direct_dynamics",
    "coupled_mass_matrix",
    "prescribed_direct_dynamics",
]


class PayloadEfforts(NamedTuple):
    """The coupled inverse model's outputs: ``gamma`` (6,) or (N, 6) the hexapod's
    actuator efforts [N, or N m for revolute actuated joints], ``tau`` (nv,) or (N, nv)
    the payload's joint torques [N m or N]."""

    gamma: FloatArray
    tau: FloatArray


class PayloadAcceleration(NamedTuple):
    """The coupled direct model's outputs: ``accel`` (6,) or (N, 6) the platform's
    classical acceleration in F0, ``qdd`` (nv,) or (N, nv) the payload's joint
    accelerations, ``tau`` the payload's joint torques (given, or those realising a
    prescribed ``qdd``)."""

    accel: FloatArray
    qdd: FloatArray
    tau: FloatArray


@dataclass(frozen=True)
class PayloadInverseDynamics:
    """The coupled inverse model with its parts (batches).

    Attributes:
        gamma: (N, 6) the actuator efforts, ``hexapod_gamma + payload_gamma``.
        tau: (N, nv) the payload's joint torques.
        wrench: (N, 6) ``W``, the wrench ``[f, m]`` the platform applies to the payload's
            base, in F0 about O_p (the payload's reaction on the platform is ``-W``).
        hexapod_gamma: (N, 6) the hexapod's own efforts (platform and legs, no payload).
        payload_gamma: (N, 6) ``Jp^T W``, the payload's share of the efforts.
    """

    gamma: FloatArray
    tau: FloatArray
    wrench: FloatArray
    hexapod_gamma: FloatArray
    payload_gamma: FloatArray


@dataclass(frozen=True)
class CoupledTerms:
    """The payload's blocks of the coupled model at a batch of states, in the platform's
    coordinates (classical acceleration in F0, wrenches about O_p in F0).

    Attributes:
        M_ff: (N, 6, 6) ``X^T M_ff X``, the payload's inertia added to the platform's.
        M_fj: (N, 6, nv) ``X^T M_fj``, the coupling with the payload's joints.
        M_jj: (N, nv, nv) the payload's joint-space mass matrix (armature included).
        b_f: (N, 6) ``X^T b_f``, the wrench the platform applies to the payload at zero
            platform and joint accelerations (gravity, Coriolis, centrifugal).
        b_j: (N, nv) the joint torques at zero platform and joint accelerations.
    """

    M_ff: FloatArray
    M_fj: FloatArray
    M_jj: FloatArray
    b_f: FloatArray
    b_j: FloatArray


class PayloadDynamics:
    """Pinocchio's RNEA and CRBA on the payload, with the platform's motion as its base
    motion (:mod:`stewart_pin.dynamics.payload`).

    Args:
        payload: the payload and its placement ``T_p_b``.
        gravity: (3,) in F0 [m/s^2] (the hexapod's).
    """

    def __init__(self, payload: Payload, gravity: FloatArray) -> None:
        self.payload = payload
        self.model, self.q_index, self.v_index = floating_payload_model(payload, gravity)
        self.data = self.model.createData()
        self.nv = payload.nv
        self.T_p_b = np.asarray(payload.placement)
        #: ``Ad_bp`` (6, 6): a motion in Fp (about O_p) to the same motion in Fb.
        self.Ad_bp = np.asarray(pin.SE3(self.T_p_b).inverse().action)

    # ------------------------------------------------------------------ base motion
    def base_motion(
        self, poses: FloatArray, twists: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(T_0_b (N, 4, 4), nu_b (N, 6), X (N, 6, 6), c (N, 6))``: the pose of Fb, its
        free-flyer velocity, and ``a_b = X A + c``."""
        R = poses[:, :3, :3]
        Rt = np.swapaxes(R, 1, 2)
        v_loc = np.einsum("nij,nj->ni", Rt, twists[:, :3])
        w_loc = np.einsum("nij,nj->ni", Rt, twists[:, 3:])
        nu_b = np.concatenate([v_loc, w_loc], axis=1) @ self.Ad_bp.T
        X = np.zeros((len(R), 6, 6))
        X[:, :, :3] = self.Ad_bp[:, :3] @ Rt
        X[:, :, 3:] = self.Ad_bp[:, 3:] @ Rt
        c = -cross(w_loc, v_loc) @ self.Ad_bp[:, :3].T
        T_0_b = poses @ self.T_p_b
        return T_0_b, nu_b, X, c

    def _configuration(self, T_0_b: FloatArray, q: FloatArray) -> FloatArray:
        x = np.empty(self.model.nq)
        x[:7] = pin.SE3ToXYZQUAT(pin.SE3(T_0_b[:3, :3], T_0_b[:3, 3]))
        x[self.q_index] = q
        return x

    def _vector(self, base: FloatArray, joints: FloatArray) -> FloatArray:
        x = np.empty(self.model.nv)
        x[:6] = base
        x[self.v_index] = joints
        return x

    # ------------------------------------------------------------------ models
    def inverse(
        self,
        poses: FloatArray,
        twists: FloatArray,
        accels: FloatArray,
        q: FloatArray,
        qd: FloatArray,
        qdd: FloatArray,
    ) -> tuple[FloatArray, FloatArray]:
        """``(W (N, 6), tau (N, nv))``: the wrench the platform applies to the payload
        (F0, about O_p) and the payload's joint torques, from one RNEA per state."""
        T_0_b, nu_b, X, c = self.base_motion(poses, twists)
        a_b = np.einsum("nij,nj->ni", X, accels) + c
        n = len(poses)
        W = np.empty((n, 6))
        tau = np.empty((n, self.nv))
        for k in range(n):
            out = pin.rnea(
                self.model,
                self.data,
                self._configuration(T_0_b[k], q[k]),
                self._vector(nu_b[k], qd[k]),
                self._vector(a_b[k], qdd[k]),
            )
            W[k] = X[k].T @ out[:6]
            tau[k] = out[self.v_index]
        return check_finite(W, "payload wrench"), check_finite(tau, "payload joint torques")

    def coupled_terms(
        self, poses: FloatArray, twists: FloatArray, q: FloatArray, qd: FloatArray
    ) -> CoupledTerms:
        """The payload's blocks of the coupled mass matrix and bias (CRBA and one RNEA at
        zero platform and joint accelerations per state)."""
        T_0_b, nu_b, X, c = self.base_motion(poses, twists)
        n, nv = len(poses), self.nv
        M_ff, M_fj = np.empty((n, 6, 6)), np.empty((n, 6, nv))
        M_jj, b_f, b_j = np.empty((n, nv, nv)), np.empty((n, 6)), np.empty((n, nv))
        vi = self.v_index
        zero = np.zeros(nv)
        for k in range(n):
            x = self._configuration(T_0_b[k], q[k])
            M = np.array(pin.crba(self.model, self.data, x))
            M = np.triu(M) + np.triu(M, 1).T
            Xk = X[k]
            M_ff[k] = Xk.T @ M[:6, :6] @ Xk
            M_fj[k] = Xk.T @ M[:6][:, vi]
            M_jj[k] = M[np.ix_(vi, vi)]
            b = pin.rnea(
                self.model, self.data, x, self._vector(nu_b[k], qd[k]), self._vector(c[k], zero)
            )
            b_f[k] = Xk.T @ b[:6]
            b_j[k] = b[vi]
        check_finite(M_ff, "payload mass matrix")
        check_finite(b_f, "payload bias")
        return CoupledTerms(M_ff, M_fj, M_jj, b_f, check_finite(b_j, "payload bias"))


# ---------------------------------------------------------------------------- direct models
def _cholesky_solve(K: FloatArray, rhs: FloatArray, what: str) -> FloatArray:
    """``K^-1 rhs`` for symmetric positive definite batches, by Cholesky."""
    check_finite(K, what)
    try:
        chol = np.linalg.cholesky(K)
    except np.linalg.LinAlgError as e:
        raise in_batch(SingularityError.not_positive_definite(), cholesky_failures(K)) from e
    y = np.linalg.solve(chol, rhs[..., None])
    return np.asarray(np.linalg.solve(np.swapaxes(chol, 1, 2), y)[..., 0], dtype=np.float64)


def prescribed_direct_dynamics(
    A_robot: FloatArray,
    h_robot: FloatArray,
    J_inv: FloatArray,
    gammas: FloatArray,
    terms: CoupledTerms,
    qdd: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The platform's classical acceleration (N, 6) under the actuator efforts ``gammas``
    while the payload's joints follow ``qdd`` (N, nv), and the joint torques (N, nv) that
    make them do so:

        (A_robot + X^T M_ff X) A = Jp^-T Gamma - h_robot - X^T M_fj qdd - X^T b_f,
        tau_j = M_jf X A + M_jj qdd + b_j.
    """
    K = 0.5 * (A_robot + terms.M_ff + np.swapaxes(A_robot + terms.M_ff, 1, 2))
    rhs = (
        np.einsum("nji,nj->ni", J_inv, gammas)
        - h_robot
        - np.einsum("nij,nj->ni", terms.M_fj, qdd)
        - terms.b_f
    )
    accel = check_finite(_cholesky_solve(K, rhs, "coupled platform inertia"), "payload DDM")
    tau = (
        np.einsum("nji,nj->ni", terms.M_fj, accel)
        + np.einsum("nij,nj->ni", terms.M_jj, qdd)
        + terms.b_j
    )
    return accel, check_finite(tau, "payload joint torques")


def coupled_mass_matrix(A_robot: FloatArray, terms: CoupledTerms) -> FloatArray:
    """The coupled mass matrix (N, 6 + nv, 6 + nv) of platform (classical acceleration in
    F0) and payload joints: ``[[A_robot + X^T M_ff X, X^T M_fj], [M_jf X, M_jj]]``."""
    n, nv = A_robot.shape[0], terms.M_jj.shape[1]
    K = np.empty((n, 6 + nv, 6 + nv))
    K[:, :6, :6] = A_robot + terms.M_ff
    K[:, :6, 6:] = terms.M_fj
    K[:, 6:, :6] = np.swapaxes(terms.M_fj, 1, 2)
    K[:, 6:, 6:] = terms.M_jj
    return 0.5 * (K + np.swapaxes(K, 1, 2))


def coupled_direct_dynamics(
    A_robot: FloatArray,
    h_robot: FloatArray,
    J_inv: FloatArray,
    gammas: FloatArray,
    terms: CoupledTerms,
    tau: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """``(A (N, 6), qdd (N, nv))`` under the actuator efforts ``gammas`` and the payload's
    joint torques ``tau``: the coupled mass matrix (:func:`coupled_mass_matrix`) solved by
    Cholesky."""
    K = coupled_mass_matrix(A_robot, terms)
    rhs = np.concatenate(
        [np.einsum("nji,nj->ni", J_inv, gammas) - h_robot - terms.b_f, tau - terms.b_j], axis=1
    )
    x = check_finite(_cholesky_solve(K, rhs, "coupled mass matrix"), "payload DDM")
    return x[:, :6], x[:, 6:]
