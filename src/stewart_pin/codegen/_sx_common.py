"""The pieces of the symbolic models (CasADi SX) shared by every leg architecture's
generator: 3-vector and 3x3 algebra on SX scalars, the pose input, the platform's
Newton-Euler, the closure of the IDM (static-pivot LU of ``Jp^-T``) and of the DDM
(``L D L^T``), the stages and the :class:`SymbolicModels` container.

:mod:`.symbolic` (the paper's 6-UPS, hand-derived) and :mod:`.leg_chain_symbolic` (general
three-joint legs) both build on this module, which imports neither: the generators depend
on it, never the reverse.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin._so3 import rotation_rows_from_quaternion_xyzw
from stewart_pin.exceptions import InputError

#: Threshold of the static pivoting: a pivot is at least this fraction of the largest
#: entry of its column at the home pose (so every multiplier is <= 1 / this there).
PIVOT_THRESHOLD = 0.5


Scalar = Any  # a float or a 1x1 casadi.SX
Vec = list  # three Scalars
Mat = list[list[Scalar]]  # a 3x3 (or 6x6) matrix of Scalars, row-major


# ---------------------------------------------------------------------------- constants
@dataclass(frozen=True)
class ModelConstants:
    """The numbers baked into the generated code (snapped, see
    :data:`~stewart_pin.codegen.symbolic.SNAP_TOLERANCE`).

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


def vcross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def vadd(a: Vec, b: Vec) -> Vec:
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def vsub(a: Vec, b: Vec) -> Vec:
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def vscale(a: Vec, s: Scalar) -> Vec:
    return [a[0] * s, a[1] * s, a[2] * s]


def matvec(M: Sequence[Sequence[Scalar]], v: Vec) -> Vec:
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


def idm_platform(R: Mat, w: Vec, wd: Vec, vdg: Vec, K: Mat, Pp: Sequence[Scalar]) -> list[Scalar]:
    """``F_p`` (eq. 24) in F0 about O_p, with the grouped platform parameters."""
    M, MS = Pp[9], list(Pp[6:9])
    MS0 = matvec(R, MS)
    F = vadd(vscale(vdg, M), matvec(K, MS0))
    I = _inertia(Pp)
    wp, wdp = _matTvec(R, w), _matTvec(R, wd)
    Np = vadd(matvec(I, wdp), vcross(wp, matvec(I, wp)))
    N = vadd(matvec(R, Np), vcross(MS0, vdg))
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


def lu_solve(
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
    x, mults, diag = lu_solve(JT, F, pivots)
    gamma = [Hz[i] + x[i] for i in range(6)]
    growth: Scalar = 0.0
    for m in mults:
        growth = cs.fmax(growth, cs.fabs(m))
    det = diag[0]
    for d in diag[1:]:
        det = det * d
    return gamma, growth, F, det


UPPER6 = [(i, j) for i in range(6) for j in range(i, 6)]


def ddm_platform(
    R: Mat, w: Vec, Pp: Sequence[Scalar], gravity: np.ndarray
) -> tuple[list[Scalar], list[Scalar]]:
    """``Ip`` (upper triangle, 21) and ``h_p`` (eq. 24-29 at zero acceleration), F0."""
    M, MS = Pp[9], list(Pp[6:9])
    g = [float(x) for x in gravity]
    MS0 = matvec(R, MS)
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
    hF = vsub(vcross(w, vcross(w, MS0)), vscale(g, M))
    hN = vsub(vcross(w, matvec(I0, w)), vcross(MS0, g))
    return [Ip[i][j] for i, j in UPPER6], [*hF, *hN]


def ldlt_solve(A: list[list[Scalar]], b: list[Scalar]) -> tuple[list[Scalar], list[Scalar]]:
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
    for m, (i, j) in enumerate(UPPER6):
        A[i][j] = A[j][i] = Au[m]
    rhs = [-h for h in hp]
    for wr in wrenches:
        rhs = [rhs[j] + wr[j] for j in range(6)]
    return ldlt_solve(A, rhs)


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
            :func:`stewart_pin.codegen.leg_chain_symbolic.build_general_models`).
        pose: ``"matrix"`` (input ``pose`` = 0Tp row-major, 16) or ``"quaternion"``
            (``[x, y, z, qx, qy, qz, qw]``).
        parameters: ``"base"`` (88 symbolic base parameters), ``"essential"`` (only the
            paper's 52 essential ones symbolic, the others zero) or ``"numeric"`` (all
            values baked in; always for general legs, whose ``base_parameters`` input is
            empty).
        constants: the numbers baked in. pivots: the static LU pivots of the IDM.
        residual_slacks: the slacks (offsets from the first slack of ``aux``) that are a
            leg's Newton residual after the unrolled steps from home, each with its leg
            (1..6); empty for legs in closed form.

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
    residual_slacks: tuple[tuple[int, int], ...] = ()


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


def _flat_shared(KV: tuple[Mat, Vec]) -> tuple[list[Scalar], Vec]:
    K, vdg = KV
    return [x for r in K for x in r], vdg


def mat3(flat: Sequence[Scalar]) -> list[list[Scalar]]:
    return [list(flat[3 * i : 3 * i + 3]) for i in range(3)]
