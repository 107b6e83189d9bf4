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

The leg code takes the numbers of one leg (:class:`LegNumbers`: Python floats here, SX
symbols in the legs-as-lanes models of :mod:`.lanes`, which run it for four legs at a
time in the compiled simulator) and the closures' by-products are assembled by
:func:`idm_legs_closure` and :func:`ddm_closure_and_aux` for both.

The pieces shared with the general-leg generator (:mod:`.leg_chain_symbolic`): the SX
algebra, the platform, both closures, the stages and :class:`SymbolicModels`, live in
:mod:`._sx_common`, below both generators.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin._lazy import lazy_names
from stewart_pin.codegen._sx_common import (
    UPPER6,
    Mat,
    ModelConstants,
    Scalar,
    Stages,
    SymbolicModels,
    Vec,
    closure_stages,
    column,
    ddm_legs_closure,
    ddm_platform,
    idm_closure,
    idm_platform,
    idm_shared,
    idm_shared_stage,
    is_zero,
    mat3,
    matvec,
    model_functions,
    pivot_order,
    pose_from_input,
    pose_size,
    split,
    stage_function,
    vadd,
    vcross,
    vscale,
    vsub,
)
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


@dataclass(frozen=True)
class LegNumbers:
    """The numbers of one leg that its code reads: ``pL`` the platform point ``P_k`` in
    the platform frame [m], ``B`` the base point ``B_k`` [m], ``z1`` the axis of its first
    U-joint (frame 1k's ``z``) and ``gravity`` [m/s^2], in F0, 3 each. Python floats (the
    robot's snapped constants, :func:`leg_numbers`: its zeros and ones fold) or SX
    symbols (the legs-as-lanes models of :mod:`.lanes`, one leg's code for all six)."""

    pL: Vec
    B: Vec
    z1: Vec
    gravity: Vec


def leg_numbers(c: ModelConstants, k: int) -> LegNumbers:
    """The numbers of leg ``k`` (0-5) of the constants ``c`` (:func:`model_constants`)."""
    return LegNumbers(
        pL=[float(x) for x in c.platform_points[k]],
        B=[float(x) for x in c.base_points[k]],
        z1=[float(x) for x in c.leg_base_rotations[k][:, 2]],
        gravity=[float(x) for x in c.gravity],
    )


def leg_geometry(c: ModelConstants, k: int, p: Vec, R: list[list[Scalar]]) -> _LegGeometry:
    """Inverse geometry of leg k (eq. 1-4) without trigonometry: ``q3``, ``rho``, the frame
    3k axes in F0 and ``L_k``."""
    return leg_geometry_of(leg_numbers(c, k), p, R)


def leg_geometry_of(leg: LegNumbers, p: Vec, R: list[list[Scalar]]) -> _LegGeometry:
    """:func:`leg_geometry` of the leg of numbers ``leg``."""
    pL, B, z1 = leg.pL, leg.B, leg.z1
    L = matvec(R, pL)
    d = [(p[i] - B[i]) + L[i] for i in range(3)]
    q3sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    dz = _dot(d, z1)
    # rho^2 = |d x z1|^2, not q3^2 - dz^2: the difference loses the relative accuracy
    # eps / sin^2 q2 near a leg singularity (2e-6 at sin q2 = 1e-5), the cross product none.
    n = vcross(d, z1)
    rho2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    # 1/sqrt first: SX folds a product by a reciprocal 1/x into a division.
    inv_rho2 = 1.0 / rho2
    iq3, irho = cs.sqrt(1.0 / q3sq), cs.sqrt(inv_rho2)
    a = vscale(d, iq3)
    y3 = vscale(n, irho)
    x3 = vcross(y3, a)
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
    F3 = vadd(vcross(wd, MS3), vcross(w, vcross(w, MS3)))
    N3 = vcross(MS3, A_g)
    # Link 2 about B_i, in frame 2 = Rx(pi/2) frame 3: (x, y, z)_2 = (x, -z, y)_3.
    w2, wd2, g2 = [wx, -wz, wy], [wdx, -wdz, wdy], [grav[0], -grav[2], grav[1]]
    XX, XY, XZ, YZ, ZZ = P["XX2R"], P["XY2R"], P["XZ2R"], P["YZ2R"], P["ZZ2R"]
    I2 = [[XX, XY, XZ], [XY, 0.0, YZ], [XZ, YZ, ZZ]]
    Iw = matvec(I2, w2)
    N2 = vsub(vadd(matvec(I2, wd2), vcross(w2, Iw)), vcross([P["MX2"], P["MY2"], 0.0], g2))
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


def platform_parameters(chi: Sequence[Scalar], names: Sequence[str]) -> list[Scalar]:
    """The 10 grouped platform parameters (:data:`PLATFORM_PARAMETERS`) of the base
    parameters ``chi`` named ``names``."""
    index = {n: j for j, n in enumerate(names)}
    return [chi[index[p]] for p in PLATFORM_PARAMETERS]


def idm_leg_outputs(
    n: LegNumbers,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    K: Mat,
    vdg: Vec,
    P: dict[str, Scalar],
) -> dict[str, list[Scalar]]:
    """One leg's share of the IDM (the leg of numbers ``n``, base parameters ``P``):
    ``row`` (its row of ``Jp^-1``), ``wrench`` (6, the part of ``H_x`` normal to the leg
    and its moment about ``O_p``, F0), ``Hz``, ``q3sq``, ``rho2`` (1 each)."""
    g = leg_geometry_of(n, p, R)
    V = vadd(v, vcross(w, g.L))
    Ag = vadd(vdg, matvec(K, g.L))  # acceleration of P_k minus gravity, F0
    grav = _to_frame3(g, list(n.gravity))
    A3g = _to_frame3(g, Ag)
    H = _leg_dynamics(g, _to_frame3(g, V), [A3g[0] + grav[0], A3g[1] + grav[1]], A3g, grav, P)
    Hp = vadd(vscale(g.x3, H[0]), vscale(g.y3, H[1]))  # the part of H_x normal to the leg
    row = [*g.a, *vcross(g.L, g.a)]
    return {
        "row": row,
        "wrench": [*Hp, *vcross(g.L, Hp)],
        "Hz": [H[2]],
        "q3sq": [g.q3sq],
        "rho2": [g.rho2],
    }


def ddm_leg_outputs(
    n: LegNumbers,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    gamma_k: Scalar,
    P: dict[str, Scalar],
) -> dict[str, list[Scalar]]:
    """One leg's share of the DDM (the leg of numbers ``n``, base parameters ``P``, its
    actuator force ``gamma_k``): ``row`` (6), ``block`` (21, the upper triangle of its 6x6
    share of ``A_robot``), ``wrench`` (6, F0), ``q3sq``, ``rho2`` (1 each)."""
    g = leg_geometry_of(n, p, R)
    wL = vcross(w, g.L)
    V3 = _to_frame3(g, vadd(v, wL))
    grav = _to_frame3(g, list(n.gravity))
    A3 = _to_frame3(g, vcross(w, wL))  # acceleration of P_k at zero platform acceleration
    b = _leg_dynamics(g, V3, A3[:2], vsub(A3, grav), grav, P)
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
    f = vsub(vscale(g.a, gamma_k - b[2]), vadd(vscale(g.x3, b[0]), vscale(g.y3, b[1])))
    return {
        "row": [*g.a, *vcross(g.L, g.a)],
        "block": [block[i][j] for i, j in UPPER6],
        "wrench": [*f, *vcross(L, f)],
        "q3sq": [g.q3sq],
        "rho2": [g.rho2],
    }


def static_pivots(desc: RobotDescription, rows: Sequence[Sequence[Scalar]]) -> tuple:
    """The static pivot order of the IDM's LU of ``Jp^-T`` (threshold partial pivoting at
    the home pose with the structural zeros of the legs' ``rows``, as built from the
    robot's numbers)."""
    home_rows = inverse_jacobian_batch(desc, desc.home_pose[None])[0]
    nonzero = np.array([[not is_zero(rows[i][cc]) for i in range(6)] for cc in range(6)])
    return tuple(pivot_order(home_rows.T, nonzero))


def idm_legs_closure(
    legs: Sequence[dict[str, list[Scalar]]],
    F_p: Sequence[Scalar],
    pivots: Sequence[tuple[int, int]],
    inv_l: float,
) -> tuple[list[Scalar], list[Scalar]]:
    """The IDM's closure (eq. 31) from the six legs' outputs (:func:`idm_leg_outputs`) and
    the platform's wrench ``F_p``: ``(gamma, aux)``, ``aux`` the guarded variant's
    by-products (``AUX_*``: ``q3^2``, ``rho^2``, ``Jp^-1``, ``F``, ``H_z``, the pivot growth,
    ``det`` and ``||.||_F^2`` of ``S``), ``inv_l`` = 1 / the characteristic length [1/m]."""
    rows = [lg["row"] for lg in legs]
    Hz = [lg["Hz"][0] for lg in legs]
    gamma, growth, F, det = idm_closure(rows, [lg["wrench"] for lg in legs], Hz, F_p, pivots)
    q3 = [lg["q3sq"][0] for lg in legs]
    rho = [lg["rho2"][0] for lg in legs]
    jinv = [x for r in rows for x in r]
    # The condition bound's inputs for the singularity measure (Jp^-1 with its angular
    # columns divided by the characteristic length l): ||.||_F^2 and det = det(Jp^-1) / l^3.
    fro2_lin: Scalar = 0.0
    fro2_ang: Scalar = 0.0
    for r in rows:
        for j in range(3):
            fro2_lin = fro2_lin + r[j] * r[j]
            fro2_ang = fro2_ang + r[3 + j] * r[3 + j]
    fro2 = fro2_lin + fro2_ang * (inv_l * inv_l)
    det = det * inv_l**3
    return gamma, [*q3, *rho, *jinv, *F, *Hz, growth, det, fro2]


def ddm_closure_and_aux(
    dlegs: Sequence[dict[str, list[Scalar]]], Ip: Sequence[Scalar], hp: Sequence[Scalar]
) -> tuple[list[Scalar], list[Scalar]]:
    """The DDM's closure (eq. 33-38) from the six legs' outputs (:func:`ddm_leg_outputs`)
    and the platform's ``Ip``, ``h_p``: ``(accel, aux)``, ``aux`` the guarded variant's
    by-products (``q3^2``, ``rho^2``, ``Jp^-1``, the pivots ``D``: ``AUX_DDM_*``)."""
    accel, D = ddm_legs_closure(dlegs, Ip, hp)
    dq3 = [lg["q3sq"][0] for lg in dlegs]
    drho = [lg["rho2"][0] for lg in dlegs]
    djinv = [x for lg in dlegs for x in lg["row"]]
    return accel, [*dq3, *drho, *djinv, *D]


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


def build(desc: RobotDescription, pose: str, parameters: str, prefix: str) -> SymbolicModels:
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
    Pp = platform_parameters(chi, names)
    numbers = [leg_numbers(c, k) for k in range(6)]  # each leg's numbers, once

    p, R = pose_from_input(x_pose, pose)
    tw, ac, gm = split(x_twist), split(x_accel), split(x_gamma)
    v, w, wd = tw[:3], tw[3:], ac[3:]

    # ---- IDM, flat
    K, vdg = idm_shared(tw, ac, c.gravity)
    legs = [idm_leg_outputs(numbers[k], p, R, v, w, K, vdg, Ps[k]) for k in range(6)]
    F_p = idm_platform(R, w, wd, vdg, K, Pp)
    pivots = static_pivots(desc, [lg["row"] for lg in legs])
    gamma, idm_aux = idm_legs_closure(legs, F_p, pivots, 1.0 / characteristic_length(desc))

    # ---- DDM, flat
    dlegs = [ddm_leg_outputs(numbers[k], p, R, v, w, gm[k], Ps[k]) for k in range(6)]
    Ip, hp = ddm_platform(R, w, Pp, c.gravity)
    accel, ddm_aux = ddm_closure_and_aux(dlegs, Ip, hp)
    inputs = {
        "pose": x_pose,
        "twist": x_twist,
        "accel": x_accel,
        "gamma": x_gamma,
        "base_parameters": x_chi,
    }
    idm, ddm, idm_guarded, ddm_guarded = model_functions(
        prefix, inputs, gamma, idm_aux, accel, ddm_aux
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
                lambda ps, t, Kf, vg, s, k=k: idm_leg_outputs(
                    numbers[k],
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
                    platform_parameters(chi_of(s), names),
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
                lambda ps, t, gk, s, k=k: ddm_leg_outputs(
                    numbers[k],
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
                        platform_parameters(chi_of(s), names),
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


def description_key(desc: RobotDescription) -> str:
    """A canonical text of a description (its dictionary form as sorted JSON)."""
    return json.dumps(desc.to_dict(), sort_keys=True)


#: ``generate_models`` (the models of any robot, the choice of generator made once per
#: architecture) lives in :mod:`._architecture`, above this generator and the leg chains';
#: it stays importable from here.
if TYPE_CHECKING:
    from stewart_pin.codegen._architecture import generate_models as generate_models
__getattr__, __dir__ = lazy_names(
    __name__, {"generate_models": "stewart_pin.codegen._architecture"}
)
