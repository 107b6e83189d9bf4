"""Symbolic generation of the closed-form models (paper section VII) with CasADi SX.

The inverse (IDM, eq. 13-32) and direct (DDM, eq. 33-38) dynamic models of one robot are
written as straight-line CasADi ``SX`` expressions. The geometry (``B_i``, ``P_i``, ``R1_i``,
gravity) enters as numbers, so that the zeros and ones of a particular frame placement
propagate (SX folds ``x*0``, ``x*1``, ``x+0``, ``-(-x)``...); the 88 base inertial parameters
enter as a symbolic input, so that identified values can be plugged in at run time.

This is the paper's "customised symbolic technique": nothing is generic here. Each leg is
written in its own modified-DH frames, exploiting ``alpha = pi/2``, ``d = 0``, and the
base-parameter grouping (links 1 and 2 turn about the fixed point ``B_i``, link 3's tensor
is grouped into link 2, ``M3i`` into the platform), as follows (frame ``3i`` coordinates,
``x3 = da/dq2``, ``y3``, ``z3 = a``, ``q3 = |B_i P_i|``, ``rho = q3 sin q2``,
``dz = (P_i - B_i) . z1i = -q3 cos q2``):

- leg kinematics from the velocity ``V`` and acceleration ``A`` of ``P_i`` (eq. 14-19)::

      w   = [-V_y / q3, V_x / q3, e w_x],   e = dz / rho  (= -cot q2)
      wd_x = w_z w_y - (A_y + 2 V_z w_x) / q3
      wd_y = (A_x - 2 V_z w_y) / q3 - w_z w_x
      wd_z = e wd_x + w_x w_y (q3 / rho)^2,   qdd1 = (wd_x + e w_x w_y) q3 / rho

- Newton-Euler (eq. 20) about ``B_i`` for links 1-2 and about ``P_i`` for link 3, with the
  13 base parameters of the leg: ``F3 = wd x MS3 + w x (w x MS3)``,
  ``N3 = MS3 x (A - g)``, ``N2 = I2 wd + w x I2 w - MS2 x g`` (frame 2, ``YY2 = MZ2 = M2 =
  0`` after grouping), ``tau3 = F3_z``, ``tau2 = (N2 + N3 + q3 z3 x F3) . z2``, ``tau1 =
  ZZ1R qdd1 + (MS1 x -g) . z1 + (...) . z1``;
- the Cartesian force at ``P_i`` (eq. 22, ``J_3i^-T`` in frame 3i is a permutation and two
  scalings): ``H_x = [tau2 / q3, -tau1 / rho, tau3]``.

The closure (eq. 31) uses ``Gamma = H_z + Jp^T (F_p + sum_i [H_perp; L_i x H_perp])``: the
component of ``H_x`` along the leg goes straight to its actuator. ``Jp^T`` is applied by an
LU factorisation of ``Jp^-T`` with a *static* pivot order (threshold partial pivoting with
a sparsity criterion at the home pose); the runtime variants return the largest
multiplier so that a caller can detect pivot growth (see :mod:`.compiled`). The DDM
(eq. 33-38) assembles ``A_robot`` from each leg's Cartesian inertia at ``P_i`` (the unit
acceleration columns of the same leg code, with velocity and gravity zero), ``h_robot``
from the same leg code at zero platform acceleration, and solves by a symbolic ``L D L^T``.

Every model comes as one flat function (``SymbolicModels.idm`` / ``ddm``, common
sub-expressions eliminated with :func:`casadi.cse`) and as its stages
(``SymbolicModels.idm_stages``): a shared prelude, six independent leg functions and the
platform (which could run on seven processors), then the closure.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

import casadi as cs
import numpy as np

from stewart_pin._so3 import rotation_rows_from_quaternion_xyzw
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics.geometry import characteristic_length
from stewart_pin.kinematics.jacobians import inverse_jacobian_batch
from stewart_pin.parameters.base import PAPER_ESSENTIAL_PER_LEG, grouped_parameters

#: The generator's version (recorded in the cache manifest; the cache key is a hash of the
#: generated source itself).
GENERATOR_VERSION = "2"

#: Geometry constants within this (relative) distance of 0 or +-1 are snapped to it, so
#: that a frame placement like the paper's propagates exact zeros and ones.
SNAP_TOLERANCE = 1e-12

#: Threshold of the static pivoting: a pivot is at least this fraction of the largest
#: entry of its column at the home pose (so every multiplier is <= 1 / this there).
PIVOT_THRESHOLD = 0.5

#: The 13 base parameters of each leg, in the order of ``grouped_parameters``.
LEG_PARAMETERS = (
    "ZZ1R",
    "MX1",
    "MY1R",
    "XX2R",
    "XY2R",
    "XZ2R",
    "YZ2R",
    "ZZ2R",
    "MX2",
    "MY2",
    "MX3",
    "MY3",
    "MZ3",
)
#: The 10 grouped platform parameters.
PLATFORM_PARAMETERS = tuple(
    f"{p}_RP" for p in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
)

#: Layout of the auxiliary output of the runtime ("guarded") variants, per state.
AUX_Q3SQ = slice(0, 6)  # squared leg lengths q3i^2 [m^2]
AUX_RHO2 = slice(6, 12)  # (q3i sin q2i)^2 [m^2] (P_i's squared distance to the axis z1i)
AUX_JINV = slice(12, 48)  # Jp^-1, row-major (row i = [a_i, L_i x a_i])
#: IDM only: the wrench F (6) that Jp^T maps, H_z (6), the largest multiplier of the
#: static-pivot LU of Jp^-T, then ``+-det(S)`` and ``||S||_F^2`` of ``S = Jp^-1 diag(1, 1, 1,
#: 1/l, 1/l, 1/l)`` (``l`` the characteristic length: the singularity measure is cond(S)).
AUX_IDM_F = slice(48, 54)
AUX_IDM_HZ = slice(54, 60)
AUX_IDM_GROWTH = 60
AUX_IDM_DET = 61
AUX_IDM_FRO2 = 62
AUX_IDM_SIZE = 63
#: DDM only: the pivots D of A_robot = L D L^T.
AUX_DDM_D = slice(48, 54)
AUX_DDM_SIZE = 54

Scalar = Any  # a float or a 1x1 casadi.SX
Vec = list  # three Scalars
Mat = list[list[Scalar]]  # a 3x3 (or 6x6) matrix of Scalars, row-major


# ---------------------------------------------------------------------------- constants
@dataclass(frozen=True)
class ModelConstants:
    """The numbers baked into the generated code (snapped, see :data:`SNAP_TOLERANCE`).

    Attributes:
        base_points: (6, 3) B_i in F0 [m]. platform_points: (6, 3) P_i in Fp [m].
        leg_base_rotations: (6, 3, 3) R1_i. gravity: (3,) in F0 [m/s^2].
        parameter_names: the 88 base parameter names. parameter_values: their values.
    """

    base_points: np.ndarray
    platform_points: np.ndarray
    leg_base_rotations: np.ndarray
    gravity: np.ndarray
    parameter_names: tuple[str, ...]
    parameter_values: np.ndarray


def _snap(x: np.ndarray, scale: float) -> np.ndarray:
    x = np.array(x, dtype=float)
    x[np.abs(x) <= SNAP_TOLERANCE * scale] = 0.0
    unit = np.abs(np.abs(x) - scale) <= SNAP_TOLERANCE * scale
    x[unit] = np.sign(x[unit]) * scale
    return x + 0.0  # no -0.0


def model_constants(desc: RobotDescription) -> ModelConstants:
    """The snapped geometry and the base parameters of ``desc``."""
    size = max(desc.size, float(np.abs(desc.base_points).max()), 1e-300)
    bp = grouped_parameters(desc)
    g = desc.gravity
    return ModelConstants(
        base_points=_snap(desc.base_points, size),
        platform_points=_snap(desc.platform_points, size),
        leg_base_rotations=_snap(desc.leg_base_rotations, 1.0),
        gravity=_snap(g, max(math.hypot(*(float(x) for x in g)), 1e-300)),  # hypot: no overflow
        parameter_names=bp.names,
        parameter_values=np.array(bp.values),
    )


# ---------------------------------------------------------------------------- 3-vectors
def _dot(a: Vec, b: Vec) -> Scalar:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _add(a: Vec, b: Vec) -> Vec:
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def _sub(a: Vec, b: Vec) -> Vec:
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _scale(a: Vec, s: Scalar) -> Vec:
    return [a[0] * s, a[1] * s, a[2] * s]


def _matvec(M: Sequence[Sequence[Scalar]], v: Vec) -> Vec:
    return [M[i][0] * v[0] + M[i][1] * v[1] + M[i][2] * v[2] for i in range(3)]


def _matTvec(M: Sequence[Sequence[Scalar]], v: Vec) -> Vec:
    return [M[0][j] * v[0] + M[1][j] * v[1] + M[2][j] * v[2] for j in range(3)]


def is_zero(x: Scalar) -> bool:
    if isinstance(x, cs.SX):
        return bool(x.is_zero())
    return x == 0.0


def split(x: cs.SX) -> list:
    return [x[k] for k in range(x.numel())]


# ---------------------------------------------------------------------------- the pose
def column(xs: Sequence[Scalar]) -> cs.SX:
    """The column SX of ``xs`` (casadi's stubs type ``vertcat`` as returning ``Sparsity``)."""
    return cast(cs.SX, cs.vertcat(*xs))


def pose_from_input(pose: cs.SX, rotation: str) -> tuple[Vec, list[list[Scalar]]]:
    """``(p, R)`` from the pose input: ``"matrix"`` is the 4x4 0Tp in row-major order (16),
    ``"quaternion"`` is ``[x, y, z, qx, qy, qz, qw]`` (7, unit quaternion, Pinocchio's
    order), whose rotation costs 9 multiplications and 15 additions."""
    if rotation == "matrix":
        return [pose[3], pose[7], pose[11]], [
            [pose[4 * i + j] for j in range(3)] for i in range(3)
        ]
    if rotation == "quaternion":
        R = rotation_rows_from_quaternion_xyzw(pose[3], pose[4], pose[5], pose[6])
        return [pose[0], pose[1], pose[2]], R
    raise InputError(f"rotation must be 'matrix' or 'quaternion', got {rotation!r}")


def pose_size(rotation: str) -> int:
    """Length of the pose input vector: 16 (row-major 4x4) or 7 (position, quaternion)."""
    return {"matrix": 16, "quaternion": 7}[rotation]


# ---------------------------------------------------------------------------- one leg
@dataclass
class _LegGeometry:
    L: Vec  # O_p -> P_i in F0
    a: Vec  # z3 (leg direction) in F0
    x3: Vec
    y3: Vec
    q3sq: Scalar  # q3^2
    rho2: Scalar  # rho^2 = (q3 sin q2)^2
    iq3: Scalar  # 1 / q3
    irho: Scalar  # 1 / rho
    is2sq: Scalar  # (q3 / rho)^2 = 1 / sin^2 q2
    dz: Scalar  # (P_i - B_i) . z1 = -q3 cos q2


def _leg_geometry(c: ModelConstants, k: int, p: Vec, R: list[list[Scalar]]) -> _LegGeometry:
    """Inverse geometry of leg k (eq. 1-4) without trigonometry: ``q3``, ``rho``, the frame
    3k axes in F0 and ``L_k``."""
    pL = [float(x) for x in c.platform_points[k]]
    B = [float(x) for x in c.base_points[k]]
    z1 = [float(x) for x in c.leg_base_rotations[k][:, 2]]
    L = _matvec(R, pL)
    d = [(p[i] - B[i]) + L[i] for i in range(3)]
    q3sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    dz = _dot(d, z1)
    # rho^2 = |d x z1|^2, not q3^2 - dz^2: the difference loses the relative accuracy
    # eps / sin^2 q2 near a leg singularity (2e-6 at sin q2 = 1e-5), the cross product none.
    n = _cross(d, z1)
    rho2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    # 1/sqrt first: SX folds a product by a reciprocal 1/x into a division.
    inv_rho2 = 1.0 / rho2
    iq3, irho = cs.sqrt(1.0 / q3sq), cs.sqrt(inv_rho2)
    a = _scale(d, iq3)
    y3 = _scale(n, irho)
    x3 = _cross(y3, a)
    return _LegGeometry(L, a, x3, y3, q3sq, rho2, iq3, irho, q3sq * inv_rho2, dz)


def _to_frame3(g: _LegGeometry, u: Vec) -> Vec:
    return [_dot(g.x3, u), _dot(g.y3, u), _dot(g.a, u)]


def _leg_dynamics(
    g: _LegGeometry, V: Vec, A_xy: Sequence[Scalar], A_g: Vec, grav: Vec, P: dict[str, Scalar]
) -> Vec:
    """``H_x`` of one leg in frame 3 (eq. 20-22) with its 13 base parameters ``P``.

    ``V``: velocity of P_i in frame 3; ``A_xy``: the x, y components of its acceleration;
    ``A_g``: acceleration minus gravity, frame 3; ``grav``: gravity in frame 3.
    """
    iq3, irho, dz = g.iq3, g.irho, g.dz
    wx = -(V[1] * iq3)
    wy = V[0] * iq3
    e = dz * irho
    wz = e * wx
    Vz2 = V[2] + V[2]
    wdx = wz * wy - (A_xy[1] + Vz2 * wx) * iq3
    wdy = (A_xy[0] - Vz2 * wy) * iq3 - wz * wx
    t = wx * wy
    wdz = e * wdx + t * g.is2sq
    w, wd = [wx, wy, wz], [wdx, wdy, wdz]
    # Link 3 about P_i (M3 is grouped into the platform, its tensor into link 2).
    MS3 = [P["MX3"], P["MY3"], P["MZ3"]]
    F3 = _add(_cross(wd, MS3), _cross(w, _cross(w, MS3)))
    N3 = _cross(MS3, A_g)
    # Link 2 about B_i, in frame 2 = Rx(pi/2) frame 3: (x, y, z)_2 = (x, -z, y)_3.
    w2, wd2, g2 = [wx, -wz, wy], [wdx, -wdz, wdy], [grav[0], -grav[2], grav[1]]
    XX, XY, XZ, YZ, ZZ = P["XX2R"], P["XY2R"], P["XZ2R"], P["YZ2R"], P["ZZ2R"]
    I2 = [[XX, XY, XZ], [XY, 0.0, YZ], [XZ, YZ, ZZ]]
    Iw = _matvec(I2, w2)
    N2 = _sub(_add(_matvec(I2, wd2), _cross(w2, Iw)), _cross([P["MX2"], P["MY2"], 0.0], g2))
    # Moment about B_i of links 2-3, back in frame 3: n2 = N2 + N3 + q3 z3 x F3. Joint
    # torques tau2 = n2 . z2 (z2 = y3) and tau1 = (N1 + n2) . z1, with z1 = (s2, 0, -c2)_3,
    # x1 = s2 a + c2 x3 for link 1's gravity (ZZ1R, MX1, MY1R about B_i), and
    # qdd1 = (wd_x + e w_x w_y) q3 / rho. Then H_x = [tau2 / q3, -tau1 / rho, tau3], with
    # the factors q3 and rho distributed to save products.
    MY1 = P["MY1R"]
    Hx = (N2[2] + N3[1]) * iq3 + F3[0]
    Hy = F3[1] - (
        P["ZZ1R"] * (wdx + e * t) * (g.is2sq * iq3)
        + P["MX1"] * grav[1] * irho
        + iq3 * (N2[0] + N3[0] + MY1 * grav[2] + e * (N3[2] - N2[1] - MY1 * grav[0]))
    )
    return [Hx, Hy, F3[2]]


# ---------------------------------------------------------------------------- stages
def _leg_parameters(chi: Sequence[Scalar], names: Sequence[str], k: int) -> dict[str, Scalar]:
    index = {n: j for j, n in enumerate(names)}
    return {p: chi[index[f"{p}_{k + 1}"]] for p in LEG_PARAMETERS}


def _platform_parameters(chi: Sequence[Scalar], names: Sequence[str]) -> list[Scalar]:
    index = {n: j for j, n in enumerate(names)}
    return [chi[index[p]] for p in PLATFORM_PARAMETERS]


def _inertia(P: Sequence[Scalar]) -> list[list[Scalar]]:
    XX, XY, XZ, YY, YZ, ZZ = P[:6]
    return [[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]]


def idm_shared(
    twist: Sequence[Scalar], accel: Sequence[Scalar], gravity: np.ndarray
) -> tuple[Mat, Vec]:
    """``K = wd^ + w^ w^`` (so that ``A_Pi = vd + K L_i``) and ``vd - g``."""
    w, wd = list(twist[3:6]), list(accel[3:6])
    wxx, wyy, wzz = w[0] * w[0], w[1] * w[1], w[2] * w[2]
    wxy, wxz, wyz = w[0] * w[1], w[0] * w[2], w[1] * w[2]
    K = [
        [-(wyy + wzz), wxy - wd[2], wxz + wd[1]],
        [wxy + wd[2], -(wxx + wzz), wyz - wd[0]],
        [wxz - wd[1], wyz + wd[0], -(wxx + wyy)],
    ]
    vdg = [accel[i] - float(gravity[i]) for i in range(3)]
    return K, vdg


def _idm_leg(
    c: ModelConstants,
    k: int,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    K: Mat,
    vdg: Vec,
    P: dict[str, Scalar],
) -> dict[str, list[Scalar]]:
    g = _leg_geometry(c, k, p, R)
    V = _add(v, _cross(w, g.L))
    Ag = _add(vdg, _matvec(K, g.L))  # acceleration of P_k minus gravity, F0
    grav = _to_frame3(g, [float(x) for x in c.gravity])
    A3g = _to_frame3(g, Ag)
    H = _leg_dynamics(g, _to_frame3(g, V), [A3g[0] + grav[0], A3g[1] + grav[1]], A3g, grav, P)
    Hp = _add(_scale(g.x3, H[0]), _scale(g.y3, H[1]))  # the part of H_x normal to the leg
    row = [*g.a, *_cross(g.L, g.a)]
    return {
        "row": row,
        "wrench": [*Hp, *_cross(g.L, Hp)],
        "Hz": [H[2]],
        "q3sq": [g.q3sq],
        "rho2": [g.rho2],
    }


def idm_platform(R: Mat, w: Vec, wd: Vec, vdg: Vec, K: Mat, Pp: Sequence[Scalar]) -> list[Scalar]:
    """``F_p`` (eq. 24) in F0 about O_p, with the grouped platform parameters."""
    M, MS = Pp[9], list(Pp[6:9])
    MS0 = _matvec(R, MS)
    F = _add(_scale(vdg, M), _matvec(K, MS0))
    I = _inertia(Pp)
    wp, wdp = _matTvec(R, w), _matTvec(R, wd)
    Np = _add(_matvec(I, wdp), _cross(wp, _matvec(I, wp)))
    N = _add(_matvec(R, Np), _cross(MS0, vdg))
    return [*F, *N]


def pivot_order(A: np.ndarray, nonzero: np.ndarray) -> list[tuple[int, int]]:
    """Static pivots ``(row, col)``: threshold partial pivoting (:data:`PIVOT_THRESHOLD`)
    on the numeric matrix ``A``, the Markowitz count of the structure ``nonzero`` breaking
    the choice among admissible pivots."""
    A, S = A.astype(float).copy(), nonzero.astype(bool).copy()
    rows, cols = list(range(A.shape[0])), list(range(A.shape[1]))
    pivots = []
    while rows:
        best = None
        for j in cols:
            colmax = max(abs(A[i, j]) for i in rows)
            for i in rows:
                if not S[i, j] or abs(A[i, j]) < PIVOT_THRESHOLD * colmax or colmax == 0:
                    continue
                cost = (sum(S[i, jj] for jj in cols) - 1) * (sum(S[ii, j] for ii in rows) - 1)
                key = (cost, -abs(A[i, j]) / colmax, j, i)
                if best is None or key < best[0]:
                    best = (key, i, j)
        if best is None:  # numerically singular at home: plain partial pivoting
            j = cols[0]
            i = max(rows, key=lambda r: abs(A[r, j]))
        else:
            _, i, j = best
        pivots.append((i, j))
        rows.remove(i)
        cols.remove(j)
        for r in rows:
            if S[r, j]:
                l = A[r, j] / A[i, j] if A[i, j] != 0 else 0.0
                for cc in cols:
                    A[r, cc] -= l * A[i, cc]
                    S[r, cc] = S[r, cc] or S[i, cc]
    return pivots


def _lu_solve(
    A: list[list[Scalar]], b: list[Scalar], pivots: Sequence[tuple[int, int]]
) -> tuple[list[Scalar], list[Scalar], list[Scalar]]:
    """Solve ``A x = b`` by LU with the static ``pivots``; returns x, the multipliers and
    the pivots."""
    n = len(b)
    rows, cols = [r for r, _ in pivots], [c for _, c in pivots]
    U = [[A[r][c] for c in cols] for r in rows]
    y = [b[r] for r in rows]
    inv, mults = [], []
    for k in range(n):
        inv.append(1.0 / U[k][k])
        for i in range(k + 1, n):
            if is_zero(U[i][k]):
                continue
            l = U[i][k] * inv[k]
            mults.append(l)
            for j in range(k + 1, n):
                U[i][j] = U[i][j] - l * U[k][j]
            y[i] = y[i] - l * y[k]
    x: list[Scalar] = [0.0] * n
    for k in reversed(range(n)):
        s = y[k]
        for j in range(k + 1, n):
            s = s - U[k][j] * x[j]
        x[k] = s * inv[k]
    out: list[Scalar] = [0.0] * n
    for k in range(n):
        out[cols[k]] = x[k]
    return out, mults, [U[k][k] for k in range(n)]


def idm_closure(
    rows: Sequence[Sequence[Scalar]],
    wrenches: Sequence[Sequence[Scalar]],
    Hz: Sequence[Scalar],
    F_p: Sequence[Scalar],
    pivots: Sequence[tuple[int, int]],
) -> tuple[list[Scalar], Scalar, list[Scalar], Scalar]:
    """``Gamma = H_z + Jp^T (F_p + sum wrench_i)`` (eq. 31)."""
    F = list(F_p)
    for wr in wrenches:
        F = [F[j] + wr[j] for j in range(6)]
    JT = [[rows[i][c] for i in range(6)] for c in range(6)]  # Jp^-T: column i = row i
    x, mults, diag = _lu_solve(JT, F, pivots)
    gamma = [Hz[i] + x[i] for i in range(6)]
    growth: Scalar = 0.0
    for m in mults:
        growth = cs.fmax(growth, cs.fabs(m))
    det = diag[0]
    for d in diag[1:]:
        det = det * d
    return gamma, growth, F, det


_UPPER6 = [(i, j) for i in range(6) for j in range(i, 6)]


def _ddm_leg(
    c: ModelConstants,
    k: int,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    gamma_k: Scalar,
    P: dict[str, Scalar],
) -> dict[str, list[Scalar]]:
    g = _leg_geometry(c, k, p, R)
    wL = _cross(w, g.L)
    V3 = _to_frame3(g, _add(v, wL))
    grav = _to_frame3(g, [float(x) for x in c.gravity])
    A3 = _to_frame3(g, _cross(w, wL))  # acceleration of P_k at zero platform acceleration
    b = _leg_dynamics(g, V3, A3[:2], _sub(A3, grav), grav, P)
    # Cartesian inertia at P_k in frame 3 (symmetric, only the upper triangle is used).
    zero = [0.0, 0.0, 0.0]
    cols = []
    for j in range(3):
        e = [0.0, 0.0, 0.0]
        e[j] = 1.0
        cols.append(_leg_dynamics(g, zero, e[:2], e, zero, P))
    A3x = [[cols[max(i, j)][min(i, j)] for j in range(3)] for i in range(3)]
    r = [g.x3, g.y3, g.a]  # columns of 0R3
    Bm = [[sum(r[m][i] * A3x[m][j] for m in range(3)) for j in range(3)] for i in range(3)]
    A0 = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            A0[i][j] = A0[j][i] = Bm[i][0] * r[0][j] + Bm[i][1] * r[1][j] + Bm[i][2] * r[2][j]
    L = g.L
    Lh = [[0.0, -L[2], L[1]], [L[2], 0.0, -L[0]], [-L[1], L[0], 0.0]]
    TR = [[-(sum(A0[i][m] * Lh[m][j] for m in range(3))) for j in range(3)] for i in range(3)]
    block = [[None] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(3):
            block[i][j] = A0[i][j]
            block[i][3 + j] = TR[i][j]
    for i in range(3):
        for j in range(i, 3):
            block[3 + i][3 + j] = sum(Lh[i][m] * TR[m][j] for m in range(3))
    f = _sub(_scale(g.a, gamma_k - b[2]), _add(_scale(g.x3, b[0]), _scale(g.y3, b[1])))
    return {
        "row": [*g.a, *_cross(g.L, g.a)],
        "block": [block[i][j] for i, j in _UPPER6],
        "wrench": [*f, *_cross(L, f)],
        "q3sq": [g.q3sq],
        "rho2": [g.rho2],
    }


def ddm_platform(
    R: Mat, w: Vec, Pp: Sequence[Scalar], gravity: np.ndarray
) -> tuple[list[Scalar], list[Scalar]]:
    """``Ip`` (upper triangle, 21) and ``h_p`` (eq. 24-29 at zero acceleration), F0."""
    M, MS = Pp[9], list(Pp[6:9])
    g = [float(x) for x in gravity]
    MS0 = _matvec(R, MS)
    I = _inertia(Pp)
    RI = [[sum(R[i][m] * I[m][j] for m in range(3)) for j in range(3)] for i in range(3)]
    I0: Mat = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            I0[i][j] = I0[j][i] = RI[i][0] * R[j][0] + RI[i][1] * R[j][1] + RI[i][2] * R[j][2]
    S = [[0.0, -MS0[2], MS0[1]], [MS0[2], 0.0, -MS0[0]], [-MS0[1], MS0[0], 0.0]]
    Ip: Mat = [[None] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(3):
            Ip[i][j] = M if i == j else 0.0
            Ip[i][3 + j] = -S[i][j]
            Ip[3 + i][3 + j] = I0[i][j]
    hF = _sub(_cross(w, _cross(w, MS0)), _scale(g, M))
    hN = _sub(_cross(w, _matvec(I0, w)), _cross(MS0, g))
    return [Ip[i][j] for i, j in _UPPER6], [*hF, *hN]


def _ldlt_solve(A: list[list[Scalar]], b: list[Scalar]) -> tuple[list[Scalar], list[Scalar]]:
    """Solve ``A x = b`` for a symmetric positive definite A (upper triangle read) by
    ``L D L^T``; returns x and D."""
    n = len(b)
    L = [[0.0] * n for _ in range(n)]
    W = [[0.0] * n for _ in range(n)]  # W[i][k] = L[i][k] D[k]
    D, invD = [0.0] * n, [0.0] * n
    for j in range(n):
        d = A[j][j]
        for k in range(j):
            d = d - W[j][k] * L[j][k]
        D[j], invD[j] = d, 1.0 / d
        for i in range(j + 1, n):
            s = A[j][i]
            for k in range(j):
                s = s - W[i][k] * L[j][k]
            W[i][j], L[i][j] = s, s * invD[j]
    y = list(b)
    for i in range(n):
        for k in range(i):
            y[i] = y[i] - L[i][k] * y[k]
    x: list[Scalar] = [0.0] * n
    for i in reversed(range(n)):
        s = y[i] * invD[i]
        for k in range(i + 1, n):
            s = s - L[k][i] * x[k]
        x[i] = s
    return x, D


def ddm_closure(
    rows: Sequence[Sequence[Scalar]],
    blocks: Sequence[Sequence[Scalar]],
    wrenches: Sequence[Sequence[Scalar]],
    Ip: Sequence[Scalar],
    hp: Sequence[Scalar],
) -> tuple[list[Scalar], list[Scalar]]:
    """``A_robot Vdot = Jp^-T Gamma - h_robot`` (eq. 35-37) by ``L D L^T``."""
    Au = list(Ip)
    for bl in blocks:
        Au = [Au[m] + bl[m] for m in range(21)]
    A = [[0.0] * 6 for _ in range(6)]
    for m, (i, j) in enumerate(_UPPER6):
        A[i][j] = A[j][i] = Au[m]
    rhs = [-h for h in hp]
    for wr in wrenches:
        rhs = [rhs[j] + wr[j] for j in range(6)]
    return _ldlt_solve(A, rhs)


# ---------------------------------------------------------------------------- assembly
@dataclass(frozen=True)
class Stages:
    """A model split for parallel evaluation: ``shared`` (serial prelude, or none), six ``legs``
    and the ``platform`` (independent of one another: seven processors), then
    ``closure`` (serial). Each is a CasADi SX function with common sub-expressions
    eliminated."""

    shared: cs.Function | None
    legs: tuple[cs.Function, ...]
    platform: cs.Function
    closure: cs.Function


@dataclass(frozen=True)
class SymbolicModels:
    """The generated models of one robot.

    Attributes:
        idm: ``(pose, twist, accel, base_parameters) -> gamma``, the inverse dynamic model.
        ddm: ``(pose, twist, gamma, base_parameters) -> accel``, the direct dynamic model.
        idm_guarded, ddm_guarded: the same with a second output ``aux`` (the by-products
            used to validate a state, layout ``AUX_*``); this is what gets compiled.
        idm_stages, ddm_stages: the models split for parallel evaluation (``None`` for
            the general-leg models unless asked for:
            :func:`stewart_pin.codegen.general_symbolic.build_general_models`).
        pose: ``"matrix"`` (input ``pose`` = 0Tp row-major, 16) or ``"quaternion"``
            (``[x, y, z, qx, qy, qz, qw]``).
        parameters: ``"base"`` (88 symbolic base parameters), ``"essential"`` (only the
            paper's 52 essential ones symbolic, the others zero) or ``"numeric"`` (all
            values baked in; always for general legs, whose ``base_parameters`` input is
            empty).
        constants: the numbers baked in. pivots: the static LU pivots of the IDM.

    Inputs ``twist`` = ``[v, w]`` of O_p in F0 [m/s, rad/s], ``accel`` classical
    ``[dv/dt, dw/dt]`` in F0, ``gamma`` the actuator forces [N], ``base_parameters`` (88,)
    in the order of ``constants.parameter_names``.
    """

    idm: cs.Function
    ddm: cs.Function
    idm_guarded: cs.Function
    ddm_guarded: cs.Function
    idm_stages: Stages | None
    ddm_stages: Stages | None
    pose: str
    parameters: str
    constants: ModelConstants
    pivots: tuple[tuple[int, int], ...]


def _chi_values(c: ModelConstants, chi: cs.SX, parameters: str) -> list[Scalar]:
    entries = split(chi)
    if parameters == "base":
        return entries
    if parameters == "numeric":
        return [float(x) for x in c.parameter_values]
    if parameters == "essential":
        keep = {f"{p}_{i}" for i in range(1, 7) for p in PAPER_ESSENTIAL_PER_LEG}
        keep |= set(PLATFORM_PARAMETERS)
        return [x if n in keep else 0.0 for x, n in zip(entries, c.parameter_names, strict=True)]
    raise InputError(f"parameters must be 'base', 'essential' or 'numeric', got {parameters!r}")


def function(
    name: str, inputs: list[tuple[str, cs.SX]], outputs: list[tuple[str, list[Scalar]]]
) -> cs.Function:
    outs = [
        cs.vertcat(*[cs.SX(x) if not isinstance(x, cs.SX) else x for x in o]) for _, o in outputs
    ]
    outs = cs.cse(outs)
    return cs.Function(
        name, [s for _, s in inputs], outs, [n for n, _ in inputs], [n for n, _ in outputs]
    )


def stage_function(
    name: str,
    inputs: list[tuple[str, int]],
    body: Callable[..., dict[str, list]],
) -> cs.Function:
    syms = [(n, cs.SX.sym(n, size)) for n, size in inputs]
    outs = body(*[split(s) for _, s in syms])
    return function(name, syms, list(outs.items()))


def closure_stages(pivots: Sequence[tuple[int, int]]) -> tuple[cs.Function, cs.Function]:
    """The ``idm_closure`` and ``ddm_closure`` stage functions (fresh symbols at each
    interface), shared by the 6-UPS and the general-leg models."""
    idm = stage_function(
        "idm_closure",
        [("rows", 36), ("wrenches", 36), ("Hz", 6), ("F_p", 6)],
        lambda r, wr, hz, fp: {
            "gamma": idm_closure(
                [r[6 * i : 6 * i + 6] for i in range(6)],
                [wr[6 * i : 6 * i + 6] for i in range(6)],
                hz,
                fp,
                pivots,
            )[0]
        },
    )
    ddm = stage_function(
        "ddm_closure",
        [("rows", 36), ("blocks", 126), ("wrenches", 36), ("Ip", 21), ("hp", 6)],
        lambda r, bl, wr, ip, h: {
            "accel": ddm_closure(
                [r[6 * i : 6 * i + 6] for i in range(6)],
                [bl[21 * i : 21 * i + 21] for i in range(6)],
                [wr[6 * i : 6 * i + 6] for i in range(6)],
                ip,
                h,
            )[0]
        },
    )
    return idm, ddm


def idm_shared_stage(gravity: np.ndarray) -> cs.Function:
    """The ``idm_shared`` stage function (``K`` flattened row-major, ``vdg``)."""
    return stage_function(
        "idm_shared",
        [("twist", 6), ("accel", 6)],
        lambda t, a: dict(zip(("K", "vdg"), _flat_shared(idm_shared(t, a, gravity)), strict=True)),
    )


def ddm_legs_closure(
    dlegs: Sequence[dict[str, list[Scalar]]], Ip: Sequence[Scalar], hp: Sequence[Scalar]
) -> tuple[list[Scalar], list[Scalar]]:
    """:func:`ddm_closure` of the six legs' ``row``, ``block`` and ``wrench`` outputs."""
    return ddm_closure(
        [lg["row"] for lg in dlegs],
        [lg["block"] for lg in dlegs],
        [lg["wrench"] for lg in dlegs],
        Ip,
        hp,
    )


def model_functions(
    prefix: str,
    inputs: dict[str, cs.SX],
    gamma: list[Scalar],
    idm_aux: list[Scalar],
    accel: list[Scalar],
    ddm_aux: list[Scalar],
) -> tuple[cs.Function, cs.Function, cs.Function, cs.Function]:
    """The four casadi functions ``idm``, ``ddm``, ``idm_guarded``, ``ddm_guarded`` (in that
    order) from their outputs; ``inputs`` maps ``pose``, ``twist``, ``accel``, ``gamma``,
    ``base_parameters`` to their symbols."""
    idm_in = [(n, inputs[n]) for n in ("pose", "twist", "accel", "base_parameters")]
    ddm_in = [(n, inputs[n]) for n in ("pose", "twist", "gamma", "base_parameters")]
    idm = function(f"{prefix}idm", idm_in, [("gamma", gamma)])
    ddm = function(f"{prefix}ddm", ddm_in, [("accel", accel)])
    idm_guarded = function(f"{prefix}idm_guarded", idm_in, [("gamma", gamma), ("aux", idm_aux)])
    ddm_guarded = function(f"{prefix}ddm_guarded", ddm_in, [("accel", accel), ("aux", ddm_aux)])
    return idm, ddm, idm_guarded, ddm_guarded


def _build(desc: RobotDescription, pose: str, parameters: str, prefix: str) -> SymbolicModels:
    c = model_constants(desc)
    names = c.parameter_names
    npose = pose_size(pose)
    x_pose = cs.SX.sym("pose", npose)
    x_twist = cs.SX.sym("twist", 6)
    x_accel = cs.SX.sym("accel", 6)
    x_gamma = cs.SX.sym("gamma", 6)
    x_chi = cs.SX.sym("base_parameters", len(names))
    chi = _chi_values(c, x_chi, parameters)
    Ps = [_leg_parameters(chi, names, k) for k in range(6)]
    Pp = _platform_parameters(chi, names)

    p, R = pose_from_input(x_pose, pose)
    tw, ac, gm = split(x_twist), split(x_accel), split(x_gamma)
    v, w, wd = tw[:3], tw[3:], ac[3:]

    # ---- IDM, flat
    K, vdg = idm_shared(tw, ac, c.gravity)
    legs = [_idm_leg(c, k, p, R, v, w, K, vdg, Ps[k]) for k in range(6)]
    F_p = idm_platform(R, w, wd, vdg, K, Pp)
    rows = [lg["row"] for lg in legs]
    home_rows = inverse_jacobian_batch(desc, desc.home_pose[None])[0]
    nonzero = np.array([[not is_zero(rows[i][cc]) for i in range(6)] for cc in range(6)])
    pivots = tuple(pivot_order(home_rows.T, nonzero))
    gamma, growth, F, det = idm_closure(
        rows, [lg["wrench"] for lg in legs], [lg["Hz"][0] for lg in legs], F_p, pivots
    )
    q3 = [lg["q3sq"][0] for lg in legs]
    rho = [lg["rho2"][0] for lg in legs]
    jinv = [x for r in rows for x in r]
    # The condition bound's inputs for the singularity measure (Jp^-1 with its angular
    # columns divided by the characteristic length l): ||.||_F^2 and det = det(Jp^-1) / l^3.
    inv_l = 1.0 / characteristic_length(desc)
    fro2_lin, fro2_ang = 0.0, 0.0
    for r in rows:
        for j in range(3):
            fro2_lin = fro2_lin + r[j] * r[j]
            fro2_ang = fro2_ang + r[3 + j] * r[3 + j]
    fro2 = fro2_lin + fro2_ang * (inv_l * inv_l)
    det = det * inv_l**3
    idm_aux = [*q3, *rho, *jinv, *F, *[lg["Hz"][0] for lg in legs], growth, det, fro2]

    # ---- DDM, flat
    dlegs = [_ddm_leg(c, k, p, R, v, w, gm[k], Ps[k]) for k in range(6)]
    Ip, hp = ddm_platform(R, w, Pp, c.gravity)
    accel, D = ddm_legs_closure(dlegs, Ip, hp)
    dq3 = [lg["q3sq"][0] for lg in dlegs]
    drho = [lg["rho2"][0] for lg in dlegs]
    djinv = [x for lg in dlegs for x in lg["row"]]
    inputs = {
        "pose": x_pose,
        "twist": x_twist,
        "accel": x_accel,
        "gamma": x_gamma,
        "base_parameters": x_chi,
    }
    idm, ddm, idm_guarded, ddm_guarded = model_functions(
        prefix, inputs, gamma, idm_aux, accel, [*dq3, *drho, *djinv, *D]
    )

    # ---- stages (fresh symbols at each interface)
    def chi_of(s: Sequence[Scalar]) -> list[Scalar]:
        return _chi_values(c, column(s), parameters)

    def leg_params(s: Sequence[Scalar], k: int) -> dict[str, Scalar]:
        return _leg_parameters(chi_of(s), names, k)

    idm_closure_stage, ddm_closure_stage = closure_stages(pivots)
    idm_stages = Stages(
        shared=idm_shared_stage(c.gravity),
        legs=tuple(
            stage_function(
                f"idm_leg{k + 1}",
                [("pose", npose), ("twist", 6), ("K", 9), ("vdg", 3), ("base_parameters", 88)],
                lambda ps, t, Kf, vg, s, k=k: _idm_leg(
                    c,
                    k,
                    *pose_from_input(column(ps), pose),
                    t[:3],
                    t[3:],
                    mat3(Kf),
                    vg,
                    leg_params(s, k),
                ),
            )
            for k in range(6)
        ),
        platform=stage_function(
            "idm_platform",
            [
                ("pose", npose),
                ("twist", 6),
                ("accel", 6),
                ("K", 9),
                ("vdg", 3),
                ("base_parameters", 88),
            ],
            lambda ps, t, a, Kf, vg, s: {
                "F_p": idm_platform(
                    pose_from_input(column(ps), pose)[1],
                    t[3:],
                    a[3:],
                    vg,
                    mat3(Kf),
                    _platform_parameters(chi_of(s), names),
                )
            },
        ),
        closure=idm_closure_stage,
    )
    ddm_stages = Stages(
        shared=None,
        legs=tuple(
            stage_function(
                f"ddm_leg{k + 1}",
                [("pose", npose), ("twist", 6), ("gamma", 1), ("base_parameters", 88)],
                lambda ps, t, gk, s, k=k: _ddm_leg(
                    c,
                    k,
                    *pose_from_input(column(ps), pose),
                    t[:3],
                    t[3:],
                    gk[0],
                    leg_params(s, k),
                ),
            )
            for k in range(6)
        ),
        platform=stage_function(
            "ddm_platform",
            [("pose", npose), ("twist", 6), ("base_parameters", 88)],
            lambda ps, t, s: dict(
                zip(
                    ("Ip", "hp"),
                    ddm_platform(
                        pose_from_input(column(ps), pose)[1],
                        t[3:],
                        _platform_parameters(chi_of(s), names),
                        c.gravity,
                    ),
                    strict=True,
                )
            ),
        ),
        closure=ddm_closure_stage,
    )
    return SymbolicModels(
        idm, ddm, idm_guarded, ddm_guarded, idm_stages, ddm_stages, pose, parameters, c, pivots
    )


def _flat_shared(KV: tuple[Mat, Vec]) -> tuple[list[Scalar], Vec]:
    K, vdg = KV
    return [x for r in K for x in r], vdg


def mat3(flat: Sequence[Scalar]) -> list[list[Scalar]]:
    return [list(flat[3 * i : 3 * i + 3]) for i in range(3)]


_CACHE: dict[tuple[str, str, str], SymbolicModels] = {}
_CACHE_SIZE = 16


def description_key(desc: RobotDescription) -> str:
    """A canonical text of a description (its dictionary form as sorted JSON)."""
    return json.dumps(desc.to_dict(), sort_keys=True)


def generate_models(
    desc: RobotDescription, pose: str = "matrix", parameters: str = "base"
) -> SymbolicModels:
    """Generate the symbolic IDM and DDM of a robot (cached per description).

    A robot with general legs (``desc.legs`` set) gets the generic models of
    :mod:`stewart_pin.codegen.general_symbolic`: every number of the robot baked in, an
    empty ``base_parameters`` input (``parameters`` ``"base"`` or ``"numeric"``), no
    stages.

    Args:
        desc: the robot description; its geometry is baked in as numbers.
        pose: ``"matrix"`` (the pose input is 0Tp row-major, 16 numbers) or
            ``"quaternion"`` (``[x, y, z, qx, qy, qz, qw]``).
        parameters: ``"base"`` (the 88 base parameters are a symbolic input),
            ``"essential"`` (the paper's 52 essential parameters symbolic, the other 36
            zero, as in the paper's operation counts) or ``"numeric"`` (every value baked
            in: zeros of a symmetric robot propagate too).
    """
    if not desc.is_ideal_ups:
        if parameters not in ("base", "numeric"):
            raise InputError(
                f"robot '{desc.name}' has general legs: its models have every parameter value "
                f"baked in (parameters 'base' or 'numeric'), got {parameters!r}"
            )
        parameters = "numeric"
    key = (description_key(desc), pose, parameters)
    if key not in _CACHE:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        if desc.is_ideal_ups:
            _CACHE[key] = _build(desc, pose, parameters, "stewart_")
        else:
            from stewart_pin.codegen.general_symbolic import build_general_models

            _CACHE[key] = build_general_models(desc, pose)[0]
    return _CACHE[key]
