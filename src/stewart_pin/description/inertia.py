"""Inertial parameters: Khalil's 10 standard parameters and their conversions.

Khalil's order, about the origin of the body's own frame (not its centre of mass)::

    XX XY XZ YY YZ ZZ MX MY MZ M

``XX..ZZ`` are the inertia tensor at the frame origin [kg m^2], ``MX MY MZ`` the first
moments ``M * c`` [kg m], ``M`` the mass [kg]. This module is the only place that converts
them to Pinocchio's order (``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz``, same origin)
and to URDF's ``<inertial>`` (centre of mass and the tensor about it).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from stewart_pin._checks import check_array, check_scalar
from stewart_pin._so3 import rotation_from_quaternion_wxyz, skew
from stewart_pin.exceptions import InertiaError, InputError

if TYPE_CHECKING:  # imported where used: reading a description needs no Pinocchio
    import pinocchio as pin

#: Names of the 10 standard parameters, in Khalil's order.
KHALIL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")

#: ``pin_params = khalil_params[KHALIL_TO_PIN]``.
KHALIL_TO_PIN = np.array([9, 6, 7, 8, 0, 1, 3, 2, 4, 5])
#: ``khalil_params = pin_params[PIN_TO_KHALIL]``.
PIN_TO_KHALIL = np.argsort(KHALIL_TO_PIN)

#: Relative tolerance of the physical-consistency checks of :func:`check_physical`, as a
#: fraction of the body's inertia scale ``S = ||I_O||_F + M |c|^2`` [kg m^2] (the tensor
#: about the frame origin and the parallel-axis term, i.e. mass times a squared length).
#: The inertia about the centre of mass is computed as ``I_O - M (|c|^2 I - c c^T)``,
#: whose round-off is a few ``eps * S`` (~1e-15 S) whatever the mass or the offset: a
#: point mass or a thin rod (a zero principal moment, or ``I1 + I2 = I3``) lands a
#: round-off away on either side of the bounds, and 1e-10 S accepts it with a wide margin
#: while any violation larger than 1e-10 S is refused.
PHYSICAL_TOLERANCE = 1e-10


#: The Khalil parameters ``XX, XY, XZ, YY, YZ, ZZ`` (indices 0-5) at their places in the
#: symmetric 3x3 tensor.
_TENSOR_ENTRIES = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])


def inertia_tensor(params: np.ndarray) -> np.ndarray:
    """The 3x3 (or batch) inertia tensor about the frame origin [kg m^2] from Khalil params."""
    return np.asarray(params, dtype=float)[..., _TENSOR_ENTRIES]


def khalil_from_tensor(I_O: np.ndarray, ms: np.ndarray, mass: float) -> np.ndarray:
    """Khalil's 10 parameters from the tensor about the origin, first moments and mass."""
    I_O = np.asarray(I_O, dtype=float)
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *ms, mass], dtype=float
    )


def pin_inertia_from_khalil(params: Any) -> pin.Inertia:
    """A ``pin.Inertia`` from Khalil's 10 parameters (both about the frame origin).

    A massless body (mass 0, so first moments 0 for a physical body) gives
    ``pin.Inertia.Zero()`` plus its rotational inertia, without dividing by the mass
    (``FromDynamicParameters`` would return NaN for the centre of mass).
    """
    import pinocchio as pin

    p = check_array(params, (10,), "inertial parameters")
    if p[9] == 0.0:
        I_O = inertia_tensor(p)
        return pin.Inertia(0.0, np.zeros(3), 0.5 * (I_O + I_O.T))
    return pin.Inertia.FromDynamicParameters(p[KHALIL_TO_PIN])


def khalil_from_pin_inertia(inertia: pin.Inertia) -> np.ndarray:
    """Khalil's 10 parameters from a ``pin.Inertia``."""
    return np.asarray(inertia.toDynamicParameters(), dtype=float)[PIN_TO_KHALIL]


def urdf_inertial_from_khalil(params: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """URDF's ``<inertial>``: ``(mass [kg], com [m] (3,), inertia about the com (3, 3))``.

    A massless body (all ten parameters zero) gives ``(0, 0, 0)``.
    """
    p = check_array(params, (10,), "inertial parameters")
    mass, ms, I_O = p[9], p[6:9], inertia_tensor(p)
    if mass == 0.0:
        return 0.0, np.zeros(3), I_O.copy()
    com = ms / mass
    I_c = I_O - mass * (com @ com * np.eye(3) - np.outer(com, com))
    return float(mass), com, 0.5 * (I_c + I_c.T)


def khalil_from_urdf_inertial(mass: float, com: Any, I_c: Any) -> np.ndarray:
    """Khalil's 10 parameters from URDF's mass, centre of mass and inertia about it."""
    com = check_array(com, (3,), "centre of mass")
    I_c = check_array(I_c, (3, 3), "inertia about the centre of mass")
    I_O = I_c + mass * (com @ com * np.eye(3) - np.outer(com, com))
    return khalil_from_tensor(I_O, mass * com, mass)


#: Keys of a body's URDF-style inertial table (:func:`khalil_from_inertial_table`):
#: ``mass`` [kg], ``com`` (3,) [m], ``rpy`` (3,) [rad] and the six entries of the inertia
#: tensor about the centre of mass [kg m^2].
INERTIAL_TABLE_KEYS = ("mass", "com", "rpy", "ixx", "iyy", "izz", "ixy", "ixz", "iyz")


def khalil_from_inertial_table(table: Any, body: str) -> np.ndarray:
    """Khalil's 10 parameters of a body from its URDF-style inertial table.

    The table holds what a URDF ``<inertial>`` does, in the body's own frame (a leg
    link's MDH frame, ``Fp`` for the platform): ``mass`` [kg] (required), ``com`` the
    centre of mass in that frame [m] (URDF's ``<origin xyz>``, default zeros), ``rpy``
    the orientation of the inertia's axes in that frame [rad] (URDF's ``<origin rpy>``:
    ``R = Rz(yaw) Ry(pitch) Rx(roll)``, default zeros), and the tensor about the centre
    of mass in those axes: ``ixx``, ``iyy``, ``izz`` (required), ``ixy``, ``ixz``,
    ``iyz`` (default 0) [kg m^2]. The conversion, exact: ``I_c = R I R^T`` in the body's
    axes, then the parallel-axis theorem ``I_O = I_c + m (|c|^2 I3 - c c^T)``,
    ``MS = m c`` (:func:`khalil_from_urdf_inertial`).

    Raises:
        InertiaError: not a table, unknown or missing keys, Khalil's names mixed in
            (both forms at once), a value that is not a finite real number, a negative
            mass, or an inertia about the centre of mass that is not positive
            semi-definite or violates the triangle inequality (to
            :data:`PHYSICAL_TOLERANCE` of its norm); the message names ``body``.
    """
    if not isinstance(table, dict):
        raise InertiaError(
            f"{body}: an inertial table (mass, com, rpy, ixx, iyy, izz, ixy, ixz, iyz) was "
            f"expected, got {type(table).__name__}",
            body,
        )
    khalil = [k for k in table if k in KHALIL_NAMES]
    if khalil:
        raise InertiaError(
            f"{body}: give the inertia in one form: Khalil's ten parameters (XX XY XZ YY YZ "
            f"ZZ MX MY MZ M, a list) or the URDF-style table, not both (found {khalil} in "
            "the table)",
            body,
        )
    unknown = [k for k in table if k not in INERTIAL_TABLE_KEYS]
    missing = [k for k in ("mass", "ixx", "iyy", "izz") if k not in table]
    if unknown or missing:
        raise InertiaError(
            f"{body}: inertial table keys: missing {missing}, unknown {unknown}; expected "
            f"{list(INERTIAL_TABLE_KEYS)} (com, rpy and the products of inertia optional)",
            body,
        )
    try:
        mass = check_scalar(table["mass"], f"{body} mass", unit="kg")
        com = check_array(table.get("com", (0.0, 0.0, 0.0)), (3,), f"{body} com")
        rpy = check_array(table.get("rpy", (0.0, 0.0, 0.0)), (3,), f"{body} rpy")
        i = {k: check_scalar(table.get(k, 0.0), f"{body} {k}") for k in INERTIAL_TABLE_KEYS[3:]}
    except InputError as e:
        raise InertiaError(str(e), body) from e
    if mass < 0:
        raise InertiaError(f"{body}: negative mass {mass:.9g} kg", body)
    I_axes = np.array(
        [
            [i["ixx"], i["ixy"], i["ixz"]],
            [i["ixy"], i["iyy"], i["iyz"]],
            [i["ixz"], i["iyz"], i["izz"]],
        ]
    )
    margin = PHYSICAL_TOLERANCE * max(float(np.linalg.norm(I_axes)), np.finfo(float).tiny)
    _check_principal_moments(I_axes, margin, body, "ixy, ixz, iyz")
    import pinocchio as pin

    R = pin.rpy.rpyToMatrix(*rpy)
    I_c = R @ I_axes @ R.T
    return khalil_from_urdf_inertial(mass, com, 0.5 * (I_c + I_c.T))


def transform_khalil(params: Any, R_a_b: Any, p_a_b: Any) -> np.ndarray:
    """Re-express a body's parameters given in frame b (about O_b) in frame a (about O_a).

    Args:
        params: shape (10,), Khalil's parameters in frame b.
        R_a_b: shape (3, 3), orientation of frame b in frame a.
        p_a_b: shape (3,), position of O_b in frame a [m].
    """
    p = check_array(params, (10,), "inertial parameters")
    R, t = np.asarray(R_a_b, float), np.asarray(p_a_b, float)
    mass, ms_b, I_b = p[9], p[6:9], inertia_tensor(p)
    ms_a = R @ ms_b + mass * t
    # Parallel axis theorem via the first moments, valid for any mass (0 included):
    # I_Oa = R I_Ob R^T - m t^ t^ - t^ (R ms)^ - (R ms)^ t^ .
    Rms, T = R @ ms_b, skew(t)
    I_a = R @ I_b @ R.T - mass * T @ T - T @ skew(Rms) - skew(Rms) @ T
    return khalil_from_tensor(0.5 * (I_a + I_a.T), ms_a, mass)


def inertia_scale(params: Any) -> float:
    """The inertia scale ``S = ||I_O||_F + M |c|^2`` [kg m^2] of Khalil parameters: the
    magnitude of the terms whose difference is the inertia about the centre of mass (so
    its round-off is a few ``eps * S``). 0 for a massless body or a point mass at O."""
    p = np.asarray(params, dtype=float)
    mass, ms = p[9], p[6:9]
    # Parameters near the float range (~1e154 and up) overflow to an infinite scale: the
    # check then accepts, and the dynamics that overflow too raise NumericalError.
    with np.errstate(over="ignore"):
        offset = float(ms @ ms / mass) if mass > 0 else 0.0  # M |c|^2 = |M c|^2 / M
        return float(np.linalg.norm(inertia_tensor(p))) + offset


def check_physical(params: Any, body: str, tol: float = PHYSICAL_TOLERANCE) -> np.ndarray:
    """Return the parameters as float64, or raise :class:`InertiaError` if non-physical.

    A body is physical when its mass is non-negative, a massless body has no first moment
    or inertia, and its inertia about the centre of mass is positive semi-definite with
    principal moments satisfying the triangle inequality ``I1 + I2 >= I3``, each within
    ``tol`` times the body's :func:`inertia_scale` ``S = ||I_O||_F + M |c|^2`` (see
    :data:`PHYSICAL_TOLERANCE`: scale-aware, so a point mass or a thin rod passes whatever
    its mass and position, and a violation larger than ``tol * S`` fails).
    """
    tol = check_scalar(tol, "tol", nonnegative=True)
    try:
        p = check_array(params, (10,), f"inertial parameters of {body}")
    except InputError as e:
        raise InertiaError(str(e), body) from e
    mass = p[9]
    if mass < 0:
        raise InertiaError(f"{body}: negative mass M = {mass:.9g} kg", body)
    if mass == 0.0:
        if np.any(p != 0.0):
            raise InertiaError(
                f"{body}: a massless body must have zero first moments and inertia, got {p}", body
            )
        return p
    _, _, I_c = urdf_inertial_from_khalil(p)
    margin = tol * max(inertia_scale(p), np.finfo(float).tiny)
    _check_principal_moments(I_c, margin, body, "XY, XZ, YZ and the first moments")
    return p


def leg_link_name(k: int) -> str:
    """The name of body ``k`` of the legs' links (6, 3) flattened: ``leg i link j``."""
    return f"leg {k // 3 + 1} link {k % 3 + 1}"


def check_physical_bodies(
    params: np.ndarray, bodies: Callable[[int], str], tol: float = PHYSICAL_TOLERANCE
) -> None:
    """:func:`check_physical` on each of the bodies ``params`` (n, 10) (finite float64),
    ``bodies(k)`` naming body k: the error of the first non-physical body.

    The rules are evaluated for all bodies at once with the same arithmetic; only when
    one of them is not accepted are the bodies checked one by one, in their order, to
    raise that body's error (a description's 19 bodies: ~10x sooner than one by one)."""
    p = np.asarray(params, dtype=float).reshape(-1, 10)
    mass = p[:, 9]
    massive = mass > 0
    fine = bool(np.all(mass >= 0) and np.all(massive | np.all(p == 0.0, axis=1)))
    if fine and np.any(massive):
        with np.errstate(all="ignore"):  # an overflow: decided body by body below
            q = p[massive]
            m, c = q[:, 9], q[:, 6:9] / q[:, 9:10]
            I_O = inertia_tensor(q)
            shift = np.einsum("ki,ki->k", c, c)[:, None, None] * np.eye(3)
            I_c = I_O - m[:, None, None] * (shift - c[:, :, None] * c[:, None, :])
            I_c = 0.5 * (I_c + np.swapaxes(I_c, 1, 2))
            offset = np.einsum("ki,ki->k", q[:, 6:9], q[:, 6:9]) / m
            scale = np.linalg.norm(I_O, axis=(1, 2)) + offset
            margin = tol * np.maximum(scale, np.finfo(float).tiny)
        fine = bool(np.all(np.isfinite(I_c)) and np.all(np.isfinite(margin)))
        if fine:
            eig = np.linalg.eigvalsh(I_c)
            fine = bool(
                np.all(eig[:, 0] >= -margin)
                and np.all(eig[:, 0] + eig[:, 1] >= eig[:, 2] - margin)
            )
    if not fine:
        for k in range(len(p)):
            check_physical(p[k], bodies(k), tol)


def _check_principal_moments(I_c: np.ndarray, margin: float, body: str, signs: str) -> None:
    """:class:`InertiaError` unless the inertia about the centre of mass ``I_c`` (3, 3)
    [kg m^2] is positive semi-definite with principal moments satisfying the triangle
    inequality, each to ``margin`` [kg m^2]; ``signs`` names the terms to check."""
    eig = np.linalg.eigvalsh(I_c)
    if eig[0] < -margin:
        raise InertiaError(
            f"{body}: inertia about the centre of mass is not positive semi-definite "
            f"(principal moments {eig} kg m^2, tolerance {margin:.3g}); check the sign of "
            f"{signs}",
            body,
        )
    if eig[0] + eig[1] < eig[2] - margin:
        raise InertiaError(
            f"{body}: principal moments {eig} kg m^2 violate the triangle inequality "
            f"I1 + I2 >= I3 (by {eig[2] - eig[0] - eig[1]:.3g} > tolerance {margin:.3g})",
            body,
        )


def random_physical_khalil(
    rng: np.random.Generator, mass: float, size: float, com_offset: float
) -> np.ndarray:
    """Random physically consistent parameters with a full tensor and an offset centre of mass.

    Args:
        mass: the body's mass [kg].
        size: a typical half-dimension of the body [m] (sets the inertia magnitude).
        com_offset: the largest coordinate of the centre of mass in the body frame [m].
    """
    # A random box-like density: principal moments of a solid with random half-axes,
    # which satisfy the triangle inequality by construction.
    half = size * rng.uniform(0.3, 1.0, 3)
    principal = (
        mass
        / 5.0
        * np.array(
            [half[1] ** 2 + half[2] ** 2, half[0] ** 2 + half[2] ** 2, half[0] ** 2 + half[1] ** 2]
        )
    )
    q = rng.normal(size=4)
    R = rotation_from_quaternion_wxyz(q)
    I_c = R @ np.diag(principal) @ R.T
    com = rng.uniform(-com_offset, com_offset, 3)
    return khalil_from_urdf_inertial(mass, com, I_c)
