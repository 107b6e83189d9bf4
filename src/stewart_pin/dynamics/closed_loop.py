"""The paper's closure layer: Cartesian projection of the legs, the platform's
Newton-Euler equations, and the inverse and direct dynamic models (eq. 20-38).

The closure kernel (:func:`closure_inverse_dynamics`, :func:`closure_cartesian_dynamics`,
:func:`closure_direct_dynamics`) sees only "a leg with three joints, one actuated": each
leg's Jacobian inverse ``J_i^-1`` (3x3, ``qdot_i = J_i^-1 v_Pi``), its ``L_i`` (O_p to P_i
in F0), its own ``H_i`` or ``(A_i, h_i)`` (joint terms included) and drift
``Jdot_i qdot_i``, with ``Jp^-1`` and the platform's terms. The ideal 6-UPS path below and
the general legs (:mod:`stewart_pin.dynamics.leg_chain_dynamics`) both call it.

All functions take validated batches: poses (N, 4, 4), twists (N, 6), classical
accelerations (N, 6), forces (N, 6); every 6-vector is ``[linear, angular]`` in F0, and
every wrench is about O_p (the origin of Fp).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from stewart_pin._checks import cholesky_failures, in_batch
from stewart_pin._so3 import cross, skew
from stewart_pin._typing import Accels, FloatArray, Forces, Poses, Twists
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import inertia_tensor
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.exceptions import NumericalError, SingularityError
from stewart_pin.kinematics.geometry import leg_vectors
from stewart_pin.kinematics.jacobians import (
    LegState,
    check_singularity,
    inverse_jacobian_from_vectors,
    leg_state,
)

#: The outputs of the inverse and direct dynamic models as their NumericalError names them
#: (the compiled backend raises the same).
IDM_OUTPUT = "inverse dynamics Gamma"
DDM_OUTPUT = "direct dynamics acceleration"


def check_finite(value: FloatArray, output: str) -> FloatArray:
    """``value`` (a batch, leading axis N) when every entry is finite, else
    :class:`NumericalError` naming ``output`` and the first non-finite state.

    The cheap ``np.isfinite(value).all()`` is all a finite result pays.
    """
    if np.isfinite(value).all():
        return value
    value = np.asarray(value)
    if value.ndim == 0:
        raise NumericalError(output, 0, 1, 1)
    bad = ~np.isfinite(value.reshape(value.shape[0], -1)).all(axis=1)
    raise NumericalError(output, int(np.argmax(bad)), int(bad.sum()), int(bad.size))


@dataclass(frozen=True)
class PlatformTerms:
    """The platform's Newton-Euler terms (eq. 24-29), in F0 about O_p.

    Attributes:
        inertia: ``Ip`` (N, 6, 6), the spatial inertia ``[[M I3, -MS^], [MS^, I]]``.
        bias: (N, 6), ``[w x (w x MS); w x (I w)] - [M g; MS x g]``.
    """

    inertia: FloatArray
    bias: FloatArray


#: The platform's inertia tensor in Fp and ``M I3``, per description (computed once: the
#: descriptions are immutable).
_PLATFORM: weakref.WeakKeyDictionary[Any, tuple[FloatArray, FloatArray]] = (
    weakref.WeakKeyDictionary()
)


def _platform_constants(desc: RobotDescription) -> tuple[FloatArray, FloatArray]:
    """``(I (3, 3) about O_p in Fp, M I3)`` of ``desc``'s platform, cached per description."""
    try:
        return _PLATFORM[desc]
    except KeyError:
        pass
    except TypeError:  # neither hashable nor weakly referenceable: no cache
        p = desc.platform_inertia
        return inertia_tensor(p), p[9] * np.eye(3)
    p = desc.platform_inertia
    consts = (inertia_tensor(p), p[9] * np.eye(3))
    for c in consts:
        c.flags.writeable = False
    _PLATFORM[desc] = consts
    return consts


def platform_gravity(desc: RobotDescription) -> FloatArray:
    """The gravity (3,) in F0 [m/s^2] acting on the platform: ``(1 - c) g`` with ``c`` its
    gravity compensation (``platform_gravcomp``, the fraction of its weight removed)."""
    return (1.0 - desc.platform_gravcomp) * np.asarray(desc.gravity)


def platform_terms(desc: RobotDescription, poses: Poses, twists: Twists) -> PlatformTerms:
    """Rotate the platform's parameters into F0 and form ``Ip`` and its bias (eq. 24-29),
    gravity as :func:`platform_gravity` (its weight less its compensation)."""
    R = poses[:, :3, :3]
    p = desc.platform_inertia
    mass = p[9]
    I_p, mass_eye = _platform_constants(desc)
    MS = R @ p[6:9]  # (N, 3)
    I0 = R @ I_p @ np.swapaxes(R, 1, 2)
    S = skew(MS)
    Ip = np.empty((R.shape[0], 6, 6))
    Ip[:, :3, :3] = mass_eye
    Ip[:, :3, 3:] = -S
    Ip[:, 3:, :3] = S
    Ip[:, 3:, 3:] = I0
    w, g = twists[:, 3:], platform_gravity(desc)
    bias = np.empty((R.shape[0], 6))
    bias[:, :3] = cross(w, cross(w, MS)) - mass * g
    bias[:, 3:] = cross(w, np.einsum("nij,nj->ni", I0, w)) - cross(MS, g)
    return PlatformTerms(Ip, bias)


def platform_energy(
    desc: RobotDescription, poses: Poses, twists: Twists
) -> tuple[FloatArray, FloatArray]:
    """Kinetic and potential energy of the platform, each (N,) [J]:
    ``1/2 (M v.v + w.I w) + v.(w x MS)`` and ``-g.(M p + MS)`` (zero at F0's origin; ``g``
    as :func:`platform_gravity`)."""
    p = desc.platform_inertia
    R, pos = poses[:, :3, :3], poses[:, :3, 3]
    MS = R @ p[6:9]
    I0 = R @ inertia_tensor(p) @ np.swapaxes(R, 1, 2)
    v, w = twists[:, :3], twists[:, 3:]
    kinetic = 0.5 * (p[9] * np.einsum("ni,ni->n", v, v) + np.einsum("ni,nij,nj->n", w, I0, w))
    kinetic += np.einsum("ni,ni->n", v, cross(w, MS))
    g = platform_gravity(desc)
    potential = -(p[9] * pos @ g + MS @ g)
    return kinetic, potential


def _wrench_at_origin(force: FloatArray, L: FloatArray) -> FloatArray:
    """``sum_i [f_i; L_i x f_i]``: forces (N, 6, 3) at P_i as one wrench (N, 6) about O_p."""
    return np.concatenate([force.sum(axis=1), cross(L, force).sum(axis=1)], axis=-1)


def _transpose_solve(J_inv: FloatArray, wrench: FloatArray) -> FloatArray:
    """``Jp^T wrench = (Jp^-1)^-T wrench`` for batches."""
    x = np.linalg.solve(np.swapaxes(J_inv, 1, 2), wrench[..., None])[..., 0]
    return np.asarray(x, dtype=np.float64)  # float64 for the type checker


# ---------------------------------------------------------------------------- closure kernel
def closure_inverse_dynamics(
    J_inv: FloatArray,
    leg_J_inv: FloatArray,
    L: FloatArray,
    H: FloatArray,
    plat: PlatformTerms,
    accels: Accels,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``Gamma = Jp^T (F_p + sum_i [I3; L_i^] J_i^-T H_i)`` (eq. 22-24, 31-32).

    Args:
        J_inv: ``Jp^-1`` (N, 6, 6). leg_J_inv: each leg's ``J_i^-1`` (N, 6, 3, 3).
        L: (N, 6, 3) O_p to P_i in F0 [m]. H: (N, 6, 3) each leg's own inverse dynamics
        (joint terms included). plat: the platform's terms. accels: (N, 6) classical.

    Returns:
        ``(gamma (N, 6), H_x (N, 6, 3), F_p (N, 6), F_leg (N, 6))``; :class:`NumericalError`
        when Gamma is not finite.
    """
    H_x = np.einsum("nkji,nkj->nki", leg_J_inv, H)  # J_i^-T H_i
    F_p = np.einsum("nij,nj->ni", plat.inertia, accels) + plat.bias
    F_leg = _wrench_at_origin(H_x, L)
    gamma = check_finite(_transpose_solve(J_inv, F_p + F_leg), IDM_OUTPUT)
    return gamma, H_x, F_p, F_leg


def closure_cartesian_dynamics(
    leg_J_inv: FloatArray,
    A: FloatArray,
    h: FloatArray,
    L: FloatArray,
    drift: FloatArray,
    twists: Twists,
    plat: PlatformTerms,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``A_robot = Ip + sum G_i^T A_xi G_i`` and
    ``h_robot = bias + sum G_i^T (A_xi (w x (w x L_i) - Jdot_i qdot_i) + J_i^-T h_i)``
    (eq. 33-37), ``A_xi = J_i^-T A_i J_i^-1``, ``G_i = [I3, -L_i^]``.

    Args:
        leg_J_inv: (N, 6, 3, 3) ``J_i^-1``. A: (N, 6, 3, 3) and h: (N, 6, 3), each leg's
        mass matrix and bias (joint terms included). L: (N, 6, 3). drift: (N, 6, 3)
        ``Jdot_i qdot_i`` (the tip acceleration at zero joint acceleration) in F0.
        twists: (N, 6). plat: the platform's terms.

    Returns:
        ``(A_robot (N, 6, 6) symmetrised, h_robot (N, 6), A_x (N, 6, 3, 3), h_x (N, 6, 3))``.
    """
    A_x = np.einsum("nkji,nkjl,nklm->nkim", leg_J_inv, A, leg_J_inv)
    h_x = np.einsum("nkji,nkj->nki", leg_J_inv, h)
    w = twists[:, None, 3:]
    # Centripetal acceleration of P_i on the platform minus the leg drift (eq. 34).
    c = cross(w, cross(w, L)) - drift
    t = np.einsum("nkij,nkj->nki", A_x, c) + h_x
    Lh = skew(L)  # (N, 6, 3, 3)
    AL = A_x @ Lh
    blocks = np.zeros((*L.shape[:2], 6, 6))
    blocks[..., :3, :3] = A_x
    blocks[..., :3, 3:] = -AL
    blocks[..., 3:, :3] = Lh @ A_x
    blocks[..., 3:, 3:] = -Lh @ AL
    A_robot = plat.inertia + blocks.sum(axis=1)
    h_robot = plat.bias + _wrench_at_origin(t, L)
    return 0.5 * (A_robot + np.swapaxes(A_robot, 1, 2)), h_robot, A_x, h_x


def closure_direct_dynamics(
    A_robot: FloatArray, h_robot: FloatArray, J_inv: FloatArray, gammas: Forces
) -> FloatArray:
    """``Vdot_p = A_robot^-1 (Jp^-T Gamma - h_robot)`` (eq. 35) by Cholesky, (N, 6).

    Raises :class:`NumericalError` when ``A_robot`` or the acceleration is not finite,
    :class:`SingularityError` when ``A_robot`` is not positive definite."""
    check_finite(A_robot, "direct dynamics A_robot")
    rhs = np.einsum("nji,nj->ni", J_inv, gammas) - h_robot
    try:
        chol = np.linalg.cholesky(A_robot)
    except np.linalg.LinAlgError as e:
        raise in_batch(SingularityError.not_positive_definite(), cholesky_failures(A_robot)) from e
    y = np.linalg.solve(chol, rhs[..., None])
    accel = np.linalg.solve(np.swapaxes(chol, 1, 2), y)[..., 0]
    return check_finite(accel, DDM_OUTPUT)


@dataclass(frozen=True)
class InverseDynamicsResult:
    """The inverse dynamic model with its intermediate terms (batches).

    Attributes:
        gamma: (N, 6) actuator forces Gamma_3i [N] (eq. 31).
        leg_forces: (N, 6, 3) the force f_i of leg i on the platform at P_i, in F0 (eq. 23).
        platform_share: (N, 6) ``Jp^T F_p``, the part of Gamma that moves the platform.
        leg_shares: (N, 6, 6) ``Jp^T [I3; L_i^] H_xi``, leg i's part of Gamma in
            ``leg_shares[:, i]``; ``gamma = platform_share + leg_shares.sum(axis=1)``.
        H: (N, 6, 3) each leg's own inverse dynamics ``H_i`` (eq. 20).
        H_x: (N, 6, 3) its Cartesian form ``J_3i^-T H_i`` at P_i (eq. 22).
        F_p, F_leg: (N, 6) the platform and leg wrenches about O_p (eq. 24, 32).
        J_inv: (N, 6, 6) ``Jp^-1``.
        legs: the leg kinematic state used.

    ``leg_forces``, ``platform_share`` and ``leg_shares`` are computed on first access, so
    that the plain model (``gamma`` only) does not pay for them.
    """

    gamma: FloatArray
    H: FloatArray
    H_x: FloatArray
    F_p: FloatArray
    F_leg: FloatArray
    J_inv: FloatArray
    legs: LegState

    @cached_property
    def leg_forces(self) -> FloatArray:
        return -self.H_x + self.legs.frames.a * self.gamma[..., None]

    @cached_property
    def platform_share(self) -> FloatArray:
        return _transpose_solve(self.J_inv, self.F_p)

    @cached_property
    def leg_shares(self) -> FloatArray:
        per_leg = np.concatenate([self.H_x, cross(self.legs.L, self.H_x)], axis=-1)
        J_T = np.swapaxes(self.J_inv, 1, 2)[:, None]
        return np.linalg.solve(J_T, per_leg[..., None])[..., 0]


def inverse_dynamics(
    desc: RobotDescription,
    legs_dyn: LegDynamics,
    poses: Poses,
    twists: Twists,
    accels: Accels,
    max_condition: float,
) -> InverseDynamicsResult:
    """``Gamma = Jp^T (F_p + F_leg)`` (eq. 31) with every intermediate term.

    Raises :class:`NumericalError` when Gamma is not finite (finite inputs that overflow),
    :class:`SingularityError` past ``max_condition`` (decided as
    :func:`~stewart_pin.kinematics.jacobians.check_condition` does, by its cheap bound
    :func:`~stewart_pin.kinematics.jacobians.check_singularity` where that suffices).

    The leg vectors ``B_i P_i``, ``L_i`` are computed once and shared by the inverse
    geometry, the leg kinematics and Jp^-1."""
    vectors = leg_vectors(desc, poses)
    legs = leg_state(desc, poses, twists, accels, vectors=vectors)
    J_inv = inverse_jacobian_from_vectors(*vectors, lengths=legs.q[..., 2])
    check_singularity(J_inv, max_condition, desc)
    assert legs.qddot is not None  # accels given
    H = legs_dyn.inverse_dynamics(legs.q, legs.qdot, legs.qddot)
    plat = platform_terms(desc, poses, twists)
    gamma, H_x, F_p, F_leg = closure_inverse_dynamics(J_inv, legs.J_inv, legs.L, H, plat, accels)
    return InverseDynamicsResult(gamma, H, H_x, F_p, F_leg, J_inv, legs)


@dataclass(frozen=True)
class CartesianDynamics:
    """``A_robot Vdot_p + h_robot = Jp^-T Gamma`` (eq. 35-37) at a batch of states.

    Attributes:
        A_robot: (N, 6, 6) symmetric positive definite inertia of platform + legs.
        h_robot: (N, 6) Coriolis, centrifugal and gravity wrench about O_p.
        J_inv: (N, 6, 6) ``Jp^-1``.
        A_x: (N, 6, 3, 3) each leg's Cartesian inertia at P_i, ``J_3i^-T A_i J_3i^-1``.
        h_x: (N, 6, 3) each leg's Cartesian bias ``J_3i^-T h_i``.
    """

    A_robot: FloatArray
    h_robot: FloatArray
    J_inv: FloatArray
    A_x: FloatArray
    h_x: FloatArray


def cartesian_dynamics(
    desc: RobotDescription,
    legs_dyn: LegDynamics,
    poses: Poses,
    twists: Twists,
    max_condition: float,
) -> CartesianDynamics:
    """``A_robot`` and ``h_robot`` (eq. 36-37); the leg vectors computed once, the
    singularity decided as in :func:`inverse_dynamics`."""
    vectors = leg_vectors(desc, poses)
    legs = leg_state(desc, poses, twists, vectors=vectors)
    J_inv = inverse_jacobian_from_vectors(*vectors, lengths=legs.q[..., 2])
    check_singularity(J_inv, max_condition, desc)
    A, h = legs_dyn.mass_and_bias(legs.q, legs.qdot)
    plat = platform_terms(desc, poses, twists)
    A_robot, h_robot, A_x, h_x = closure_cartesian_dynamics(
        legs.J_inv, A, h, legs.L, legs.drift, twists, plat
    )
    return CartesianDynamics(A_robot, h_robot, J_inv, A_x, h_x)


def direct_dynamics(
    desc: RobotDescription,
    legs_dyn: LegDynamics,
    poses: Poses,
    twists: Twists,
    gammas: Forces,
    max_condition: float,
) -> tuple[FloatArray, CartesianDynamics]:
    """``Vdot_p = A_robot^-1 (Jp^-T Gamma - h_robot)`` (eq. 35) by Cholesky, classical, F0.

    Raises :class:`NumericalError` when ``A_robot`` or the acceleration is not finite."""
    cd = cartesian_dynamics(desc, legs_dyn, poses, twists, max_condition)
    accel = closure_direct_dynamics(cd.A_robot, cd.h_robot, cd.J_inv, gammas)
    return accel, cd
