"""SO(3) and 3-vector helpers, batched: the one home of the project's rotation maths.

- :func:`cross`, :func:`skew`: ``a x b`` and the skew matrix (faster than ``np.cross`` on
  small arrays);
- :func:`so3_exp`, :func:`so3_log`, the left Jacobian :func:`so3_left_jacobian`, its time
  derivative :func:`so3_left_jacobian_rate` and its inverse :func:`so3_left_jacobian_inverse`
  (``w = J_l(r) r'`` is the angular velocity in F0 of ``exp(r) R0``);
- quaternion conversions, the component order in each name: ``xyzw`` (scalar last,
  Pinocchio's ``coeffs()`` and the CSV tables) or ``wxyz`` (scalar first, MuJoCo and
  ``pin.Quaternion(w, x, y, z)``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

_PINOCCHIO: list[Any] = []


def _pin() -> Any:
    """Pinocchio, imported on first use (importing this module, hence the descriptions and
    the CSV tables, stays cheap: ``import stewart_pin``, the command's ``--help``)."""
    if not _PINOCCHIO:
        import pinocchio

        _PINOCCHIO.append(pinocchio)
    return _PINOCCHIO[0]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis, broadcasting the leading ones."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    # (np.broadcast_shapes costs more than the arithmetic on one state: skip it when it can.)
    out = np.empty(a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def skew(v: np.ndarray) -> np.ndarray:
    """The 3x3 (or batch (..., 3, 3)) skew matrix ``v^`` with ``v^ x = v x x``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros((*v.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


# ---------------------------------------------------------------- exponential, Jacobians
#: Below this rotation angle [rad] the SO(3) coefficient functions use Taylor series.
_SERIES_ANGLE = 0.1


def _series(theta2: np.ndarray, coefs: list[float]) -> np.ndarray:
    out = np.zeros_like(theta2)
    for c in reversed(coefs):
        out = out * theta2 + c
    return out


def so3_coefficients(r: np.ndarray) -> tuple[np.ndarray, ...]:
    """``sin t / t, a, b, a'/t, b'/t`` at ``t = |r|`` for rotation vectors r (N, 3)."""
    t = np.linalg.norm(r, axis=-1)
    t2 = t * t
    small = t < _SERIES_ANGLE
    ts = np.where(small, 1.0, t)  # avoids 0/0 in the branch np.where discards
    sinc = np.sinc(t / np.pi)
    a = np.where(
        small, _series(t2, [1 / 2, -1 / 24, 1 / 720, -1 / 40320]), (1 - np.cos(ts)) / ts**2
    )
    b = np.where(
        small,
        _series(t2, [1 / 6, -1 / 120, 1 / 5040, -1 / 362880]),
        (ts - np.sin(ts)) / ts**3,
    )
    da = np.where(
        small,
        _series(t2, [-1 / 12, 1 / 180, -1 / 6720, 1 / 453600]),
        (ts * np.sin(ts) - 2 * (1 - np.cos(ts))) / ts**4,
    )
    db = np.where(
        small,
        _series(t2, [-1 / 60, 1 / 1260, -1 / 60480, 1 / 4989600]),
        ((1 - np.cos(ts)) * ts - 3 * (ts - np.sin(ts))) / ts**5,
    )
    return sinc, a, b, da, db


def so3_exp(r: np.ndarray, coefs: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """Rotation matrices ``exp([r]x)`` (Rodrigues) of rotation vectors r (N, 3) [rad]."""
    sinc, a, _, _, _ = coefs or so3_coefficients(r)
    K = skew(r)
    return np.eye(3) + sinc[:, None, None] * K + a[:, None, None] * (K @ K)


def so3_left_jacobian(r: np.ndarray, coefs: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """``J_l(r)`` (N, 3, 3): ``w = J_l(r) r'`` is the angular velocity in F0 of ``exp(r) R0``."""
    _, a, b, _, _ = coefs or so3_coefficients(r)
    K = skew(r)
    return np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)


def so3_left_jacobian_rate(
    r: np.ndarray, rd: np.ndarray, coefs: tuple[np.ndarray, ...] | None = None
) -> np.ndarray:
    """``(dJ_l/dt) r'`` (N, 3) (module docstring)."""
    _, _, b, da, db = coefs or so3_coefficients(r)
    rdr = np.einsum("ni,ni->n", r, rd)
    r_x_rd = cross(r, rd)
    return (
        (rdr * da)[:, None] * r_x_rd
        + (rdr * db)[:, None] * cross(r, r_x_rd)
        + b[:, None] * cross(rd, r_x_rd)
    )


def so3_left_jacobian_inverse(xi: np.ndarray) -> np.ndarray:
    """``J_l(xi)^-1`` (3, 3) of one rotation vector xi (3,): ``dxi/dt = J_l^-1 w`` for
    ``R = exp(xi^) R_0``, w in F0."""
    # J_l(xi) = J_r(-xi) = J_r(xi)^T, and pin.Jlog3(exp3(xi)) = J_r(xi)^-1.
    pin = _pin()
    return pin.Jlog3(pin.exp3(xi)).T


#: Past this rotation angle [rad] :func:`so3_log` takes the axis from the symmetric part
#: of R (the antisymmetric part ``sin t a^`` vanishes at pi).
_LOG_SYMMETRIC_ANGLE = 2.0


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (N, 3) [rad], angles in [0, pi], of rotation matrices R (N, 3, 3)
    (``pin.log3``, vectorised over the batch).

    With ``v = vee(R - R^T) / 2 = sin t a`` and ``c = (tr R - 1) / 2 = cos t``:
    ``t = atan2(|v|, c)`` and ``r = t v / |v|`` (``r = v`` at ``|v| = 0``, t = 0); past
    :data:`_LOG_SYMMETRIC_ANGLE` the axis comes from ``(R + R^T) / 2 - c I = (1 - c) a a^T``
    (its largest diagonal entry's column), signed along v."""
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    v = 0.5 * np.stack(
        [R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=-1
    )
    c = 0.5 * (R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2] - 1.0)
    s = np.sqrt(np.einsum("ni,ni->n", v, v))
    t = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = v * np.where(s > 0.0, t / np.where(s > 0.0, s, 1.0), 1.0)[:, None]
    wide = np.flatnonzero(t > _LOG_SYMMETRIC_ANGLE)
    if wide.size:
        Rw, cw = R[wide], c[wide]
        B = 0.5 * (Rw + np.swapaxes(Rw, 1, 2)) - cw[:, None, None] * np.eye(3)
        k = np.argmax(np.diagonal(B, axis1=1, axis2=2), axis=1)
        col = B[np.arange(wide.size), :, k]  # (1 - c) a_k a
        axis = col / np.linalg.norm(col, axis=1)[:, None]
        sign = np.where(np.einsum("ni,ni->n", axis, v[wide]) < 0.0, -1.0, 1.0)
        out[wide] = (sign * t[wide])[:, None] * axis
    return out


# ------------------------------------------------------------------------- quaternions
def quaternions_xyzw_from_rotations(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``[x, y, z, w]`` (N, 4) with ``w >= 0`` of rotation matrices (N, 3, 3)."""
    quaternion = _pin().Quaternion
    q = np.array([quaternion(r).normalized().coeffs() for r in R]).reshape(-1, 4)
    return q * np.where(q[:, 3:] < 0, -1.0, 1.0)


def rotation_rows_from_quaternion_xyzw(x: Any, y: Any, z: Any, w: Any) -> list[list[Any]]:
    """The rotation matrix of a unit quaternion ``(x, y, z, w)`` as three rows of three
    entries, in 9 multiplications and 15 additions; the components may be floats, arrays
    (entrywise) or CasADi symbols (the generated code uses this same expression)."""
    x2, y2, z2 = x + x, y + y, z + z
    xx, yy, zz = x * x2, y * y2, z * z2
    xy, xz, yz = x * y2, x * z2, y * z2
    wx, wy, wz = w * x2, w * y2, w * z2
    return [
        [1.0 - (yy + zz), xy - wz, xz + wy],
        [xy + wz, 1.0 - (xx + zz), yz - wx],
        [xz - wy, yz + wx, 1.0 - (xx + yy)],
    ]


def rotations_from_quaternions_xyzw(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of unit quaternions ``[x, y, z, w]`` (N, 4)."""
    rows = rotation_rows_from_quaternion_xyzw(*np.asarray(q, dtype=float).T)
    return np.stack([np.stack(row, -1) for row in rows], -2)


def quaternion_wxyz_from_rotation(R: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` (4,) with ``w >= 0`` of one rotation matrix (3, 3)."""
    x, y, z, w = quaternions_xyzw_from_rotations(np.asarray(R, dtype=float)[None])[0]
    return np.array([w, x, y, z])


def rotation_from_quaternion_wxyz(q: np.ndarray) -> np.ndarray:
    """The rotation matrix (3, 3) of a quaternion ``(w, x, y, z)`` (4,), normalised first."""
    return _pin().Quaternion(*(q / np.linalg.norm(q))).toRotationMatrix()
