"""The dynamic regressor ``W`` (6 x 190): ``Gamma = W chi`` for the 190 standard parameters.

Column order (Khalil's order ``XX XY XZ YY YZ ZZ MX MY MZ M`` inside each block of 10):
leg 1 link 1, leg 1 link 2, leg 1 link 3, leg 2 link 1, ..., leg 6 link 3, platform.
:func:`standard_parameters` gives the matching vector ``chi`` of a description and
:data:`STANDARD_NAMES` the names (``XX2_3`` is XX of link 2 of leg 3, ``MZ_P`` the
platform's MZ).

Built the way the inverse dynamic model is (eq. 31), from Pinocchio's regressors:
``H_i = Y_i chi_i`` (``pin.computeJointTorqueRegressor`` on the legs) and the platform's
``F_p = Y_p chi_p`` (``pin.bodyRegressor``), so ``W = Jp^T [[I3; L_i^] J_3i^-T Y_i ..., Y_p]``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from stewart_pin._so3 import cross
from stewart_pin._typing import Accels, FloatArray, JointValues, Poses, Twists
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import KHALIL_NAMES, PIN_TO_KHALIL
from stewart_pin.dynamics.closed_loop import check_finite
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.formats.urdf import leg_joint
from stewart_pin.kinematics.jacobians import check_condition, inverse_jacobian_batch, leg_state

N_STANDARD = 190

#: Names of the 190 standard parameters, in the regressor's column order.
STANDARD_NAMES: tuple[str, ...] = tuple(
    [f"{p}{j}_{i}" for i in range(1, 7) for j in (1, 2, 3) for p in KHALIL_NAMES]
    + [f"{p}_P" for p in KHALIL_NAMES]
)


def standard_parameters(desc: RobotDescription) -> FloatArray:
    """The 190 standard parameters ``chi`` of a description, in the regressor's order."""
    return np.concatenate([desc.leg_inertia.reshape(-1), desc.platform_inertia])


def with_standard_parameters(desc: RobotDescription, chi: FloatArray) -> RobotDescription:
    """A copy of ``desc`` with its 190 inertial parameters replaced by ``chi`` (validated)."""
    chi = np.asarray(chi, dtype=float)
    return desc.replace(leg_inertia=chi[:180].reshape(6, 3, 10), platform_inertia=chi[180:])


def _leg_columns(legs: LegDynamics) -> FloatArray:
    """(6, 3, 10) columns of each leg body in Pinocchio's joint-torque regressor, permuted
    to Khalil's order."""
    model = legs.model
    cols = np.empty((6, 3, 10), dtype=int)
    for i in range(6):
        for j in range(3):
            jid = model.getJointId(leg_joint(i + 1, j + 1))
            cols[i, j] = 10 * (jid - 1) + PIN_TO_KHALIL
    return cols


def leg_regressors(
    legs: LegDynamics, q: JointValues, qd: JointValues, qdd: JointValues
) -> FloatArray:
    """``Y_i`` with ``H_i = Y_i chi_i``: shape (N, 6, 3, 30), Khalil order, links 1..3."""
    cols = _leg_columns(legs).reshape(6, 30)
    rows = legs.blocks  # (6, 3) velocity index of each leg joint
    out = np.empty((*q.shape, 30))
    m, d = legs.model, legs.data
    for n in range(q.shape[0]):
        Y = pin.computeJointTorqueRegressor(
            m, d, legs.pack(q[n]), legs.pack(qd[n]), legs.pack(qdd[n])
        )
        out[n] = Y[rows[:, :, None], cols[:, None, :]]
    return out


def platform_regressor(
    desc: RobotDescription, poses: Poses, twists: Twists, accels: Accels
) -> FloatArray:
    """``Y_p`` with ``F_p = Y_p chi_p`` (eq. 24): shape (N, 6, 10), wrench in F0 about O_p."""
    out = np.empty((poses.shape[0], 6, 10))
    for n in range(poses.shape[0]):
        R = poses[n, :3, :3]
        w_b = R.T @ twists[n, 3:]
        v_b = R.T @ twists[n, :3]
        # Body spatial acceleration (Featherstone) with gravity as a fictitious acceleration.
        a_lin = R.T @ (accels[n, :3] - desc.gravity) - np.cross(w_b, v_b)
        Y = pin.bodyRegressor(pin.Motion(v_b, w_b), pin.Motion(a_lin, R.T @ accels[n, 3:]))
        out[n, :3] = R @ Y[:3, PIN_TO_KHALIL]
        out[n, 3:] = R @ Y[3:, PIN_TO_KHALIL]
    return out


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
    Yx = np.einsum("nkji,nkjc->nkic", state.J_inv, Y)  # J_3i^-T Y_i at P_i, (N, 6, 3, 30)
    L = state.L[..., None, :]  # (N, 6, 1, 3)
    moment = cross(np.broadcast_to(L, (*Yx.shape[:2], 30, 3)), np.swapaxes(Yx, -1, -2))
    wrench = np.concatenate([Yx, np.swapaxes(moment, -1, -2)], axis=-2)  # (N, 6, 6, 30)
    N = poses.shape[0]
    F = np.empty((N, 6, N_STANDARD))
    F[:, :, :180] = np.moveaxis(wrench, 1, 2).reshape(N, 6, 180)
    F[:, :, 180:] = platform_regressor(desc, poses, twists, accels)
    W = np.asarray(np.linalg.solve(np.swapaxes(J_inv, 1, 2), F), dtype=np.float64)
    return check_finite(W, "regressor W")
