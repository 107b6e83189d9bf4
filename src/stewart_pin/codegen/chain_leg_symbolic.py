"""Symbolic models of robots with chain legs (CasADi SX): any serial chain of n 1-dof
joints closed by a ball (c = 3) or a weld (c = 6), ``n = c``; legs with an idle joint
(``n = c + 1``, an R-S-S rod's spin) in :func:`build_idle_models`, the idle state an input
(:mod:`.idle_compiled` compiles them).

The same models as :mod:`.leg_chain_symbolic` (IDM and DDM, their guarded variants with
``aux`` in :class:`~.leg_chain_symbolic.AuxLayout`, the closures of :mod:`._sx_common`)
for the legs of :mod:`stewart_pin.kinematics.chain_legs` and
:class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`, every number of the
robot baked in. Per leg i, in its frame 0i (``[R_i, B_i]`` in F0):

- inverse geometry: :data:`NEWTON_ITERATIONS` Newton steps on the chain from the leg's
  configuration at the home pose
  (:func:`~stewart_pin.kinematics.chain_legs.home_configuration`), each step ``J dq = e``
  (``e`` the attachment's position error and, for a weld, the rotation error
  ``vex(asym(R_target R_tip^T))``, equal to the reference's ``log`` to second order at the
  solution) solved by an LU with static pivots (chosen at the home configuration), capped
  as the reference caps it (:data:`~stewart_pin.kinematics.chain_legs.MAX_STEP`), a
  revolute joint carried as ``cos``, ``sin`` of ``theta + q`` and turned by the Cayley
  rotation of ``dq`` (no trigonometric call). Each step is one function called, never
  inlined, in the compiled source (the batch loop calls its vector copy,
  :mod:`._simd`). The final residual is reported to the guard: a state
  where the fixed count has not converged is decided by the reference path;
- ``J_i`` (c x n, columns ``[z_j x (P - O_j); z_j]`` or ``[z_j; 0]``) inverted by the
  same static-pivot LU (its largest multiplier reported to the guard); ``qdot = J_i^-1
  G_i V``, the drift ``Jdot_i qdot_i`` (the reference's :func:`chain_drift`),
  ``qddot = J_i^-1 (G_i Vdot + d_i - drift)``;
- Newton-Euler on the chain in the link frames (gravity as the base's acceleration),
  plus ``Ia qddot + (Fv + D) qdot + Fc sign(qdot) + K (q - q0)`` per joint;
- IDM: the actuated joint's effort to its actuator, the rest through ``Jp^T``; DDM:
  ``A_x = J_i^-T M_i J_i^-1`` (c x c) mapped by ``G_i``, ``L D L^T`` closure.

Slacks (positive inside): the Newton residual under :data:`RESIDUAL_TOLERANCE`, the leg
LU's growth under :data:`LEG_GROWTH_LIMIT`, the joint limits with margins.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin.codegen._sx_common import (
    Mat,
    ModelConstants,
    Scalar,
    SymbolicModels,
    Vec,
    column,
    ddm_legs_closure,
    ddm_platform,
    function,
    idm_platform,
    idm_shared,
    lu_solve,
    mat3,
    pivot_order,
    pose_from_input,
    pose_size,
    split,
)
from stewart_pin.codegen.leg_chain_symbolic import (
    AuxLayout,
    JointConst,
    JointState,
    actuators_of,
    add,
    assemble_models,
    cross,
    dot,
    idm_closure_and_aux,
    joint_constants,
    joint_terms,
    leg_block,
    limit_slacks,
    lin_comb,
    mass_matrix,
    minus,
    mul,
    newton_euler,
    plus,
    prismatic,
    revolute,
    scaled,
    snap,
    sub,
)
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import UnsupportedArchitectureError
from stewart_pin.kinematics import chain_legs as kin

#: The chain-leg generator's version (in the cache manifest).
CHAIN_GENERATOR_VERSION = "1"
#: Newton steps unrolled per leg from its home configuration (the reference's Newton
#: from home needs at most 7 on the welded and mixed robots' sampled states; more: the
#: guard flags the state).
NEWTON_ITERATIONS = 7
#: The idle models' Newton steps per leg (an R-S-S crank swings further from home than
#: the welded legs' joints: of 10 000 states of ``sample_states`` on the 6-RSS, 7 steps
#: leave 14 % to the reference path, 9 steps 0.2 % (each costs milliseconds there), 12
#: none).
IDLE_NEWTON_ITERATIONS = 12
#: The residual the guard accepts after the last step: position over the robot's size,
#: rotation [rad] (the reference's own tolerance is 1e-13; one more quadratic step).
RESIDUAL_TOLERANCE = 1e-11
#: Largest static-pivot multiplier of a leg's LU trusted (else the reference decides).
LEG_GROWTH_LIMIT = 64.0


@dataclass(frozen=True)
class _ChainConst:
    """One chain leg's numbers (snapped)."""

    index: int
    R: tuple[tuple[float, ...], ...]  # R_i, frame 0i in F0
    B: tuple[float, ...]
    pL: tuple[float, ...]  # P_i in Fp
    pR: tuple[tuple[float, ...], ...]  # the platform attachment's orientation in Fp (weld)
    joints: tuple[JointConst, ...]
    tip: tuple[float, ...]
    tip_R: tuple[tuple[float, ...], ...]
    constraints: int
    actuated: int  # 0-based
    home: tuple[float, ...]  # joint values at the home pose
    caps: tuple[float, ...]  # Newton's step caps
    pivots: tuple[tuple[int, int], ...]  # the leg LU's static pivots
    gravity: tuple[float, ...]  # g in frame 0i
    size: float
    inline_newton: bool = True
    idle: int = -1  # the idle joint (0-based), -1 without one
    iterations: int = NEWTON_ITERATIONS

    @property
    def free(self) -> tuple[int, ...]:
        """The joints Newton moves (all but the idle joint)."""
        return tuple(j for j in range(len(self.joints)) if j != self.idle)


def chain_constants(
    desc: RobotDescription,
    k: int,
    inline_newton: bool = True,
    coulomb_smoothing: float = 0.0,
    idle: bool = False,
) -> _ChainConst:
    """Leg k's :class:`_ChainConst` (a leg with an idle joint:
    :class:`UnsupportedArchitectureError` unless ``idle``, for the models taking the idle
    state); ``coulomb_smoothing`` > 0
    [m/s or rad/s, each joint's rate]: its joints' Coulomb signs smoothed as
    ``tanh(qd / eps)``."""
    leg = kin.chain_legs_of(desc)[k]
    if leg.idle_joint is not None and not idle:
        raise UnsupportedArchitectureError(
            f"robot '{desc.name}': leg {k + 1} has an idle joint ({leg.idle_joint}): the "
            "compiled models do not take idle freedoms yet; use backend='pinocchio'",
            "backend",
            desc.architecture,
        )
    size = kin.robot_size(desc)
    scale = max(size, float(np.abs(desc.base_points).max()), 1e-300)
    home = kin.home_configuration(desc)[k]
    frames = kin.chain_frames(leg, kin.leg_base_pose(desc, k), home[None])
    R = desc.leg_base_rotations[k]
    J_home = R.T @ kin.chain_jacobian(leg, frames)[0][:3] if leg.constraints == 3 else None
    if J_home is None:
        J6 = kin.chain_jacobian(leg, frames)[0]
        J_home = np.vstack([R.T @ J6[:3], R.T @ J6[3:]])
    idle_index = -1 if leg.idle_joint is None else leg.idle_joint - 1
    free = [j for j in range(leg.n_joints) if j != idle_index]
    J_home = J_home[:, free]  # Newton and J_i^-1 move the joints but the idle one
    nonzero = np.abs(J_home) > 1e-12 * max(np.abs(J_home).max(), 1e-300)
    g = desc.gravity
    gscale = max(math.hypot(*(float(x) for x in g)), 1e-300)
    return _ChainConst(
        index=k,
        R=tuple(tuple(snap(x) for x in row) for row in R),
        B=tuple(snap(x, scale) for x in desc.base_points[k]),
        pL=tuple(snap(x, scale) for x in desc.platform_points[k]),
        pR=tuple(tuple(snap(x) for x in row) for row in leg.platform_rotation),
        joints=tuple(
            joint_constants(j, leg.inertia[m], scale, leg.gravcomp[m], coulomb_smoothing)
            for m, j in enumerate(leg.joints)
        ),
        tip=tuple(snap(x, scale) for x in leg.tip),
        tip_R=tuple(tuple(snap(x) for x in row) for row in leg.tip_rotation),
        constraints=leg.constraints,
        actuated=leg.actuated - 1,
        home=tuple(float(x) for x in home),
        caps=tuple(kin.MAX_STEP if leg.joints[j].revolute else kin.MAX_STEP * size for j in free),
        pivots=tuple(pivot_order(J_home, nonzero)),
        gravity=tuple(snap(x, gscale) for x in R.T @ g),
        size=size,
        inline_newton=inline_newton,
        idle=idle_index,
        iterations=IDLE_NEWTON_ITERATIONS if idle else NEWTON_ITERATIONS,
    )


# ---------------------------------------------------------------------------- algebra
def _matvec(M: Sequence[Sequence[Scalar]], v: Sequence[Scalar]) -> list[Scalar]:
    return [lin_comb(*zip(row, v, strict=True)) for row in M]


def _matTvec(M: Sequence[Sequence[Scalar]], v: Sequence[Scalar]) -> list[Scalar]:
    return [lin_comb(*((M[i][j], v[i]) for i in range(len(M)))) for j in range(len(M[0]))]


def _rot(R: Sequence[Sequence[Scalar]], u: Vec) -> Vec:
    return [lin_comb((R[i][0], u[0]), (R[i][1], u[1]), (R[i][2], u[2])) for i in range(3)]


def _rotT(R: Sequence[Sequence[Scalar]], u: Vec) -> Vec:
    return [lin_comb((R[0][i], u[0]), (R[1][i], u[1]), (R[2][i], u[2])) for i in range(3)]


def _matmul3(A: Sequence[Sequence[Scalar]], B: Sequence[Sequence[Scalar]]) -> Mat:
    return [
        [lin_comb(*((A[i][m], B[m][j]) for m in range(3))) for j in range(3)] for i in range(3)
    ]


def _to_frame(lc: _ChainConst, u: Vec) -> Vec:
    """An F0 vector in frame 0i."""
    return _rotT(lc.R, u)


def _from_frame(lc: _ChainConst, u: Vec) -> Vec:
    return _rot(lc.R, u)


def _lu_inverse(
    J: list[list[Scalar]], pivots: Sequence[tuple[int, int]]
) -> tuple[list[list[Scalar]], Scalar]:
    """``J^-1`` (rows) by the static-pivot LU of :mod:`._sx_common` (the factorisation is
    shared by the n solves once common sub-expressions are eliminated) and the largest
    multiplier."""
    n = len(J)
    cols = []
    growth: Scalar = 0.0
    for m in range(n):
        x, mults, _ = lu_solve(J, [1.0 if i == m else 0.0 for i in range(n)], pivots)
        cols.append(x)
        if m == 0:
            for mult in mults:
                growth = cs.fmax(growth, cs.fabs(mult))
    return [[cols[m][i] for m in range(n)] for i in range(n)], growth


# ---------------------------------------------------------------------------- the chain
@dataclass
class _Frames:
    z: list[Vec]
    O: list[Vec]
    P: Vec
    R_tip: Mat | None  # weld: the attachment frame's orientation in frame 0i


def _frames(lc: _ChainConst, joints: Sequence[JointState]) -> _Frames:
    """Axes and origins of the joint frames in frame 0i, forward from the base."""
    R: Mat = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    origin: Vec = [0.0, 0.0, 0.0]
    z, O = [], []
    unit = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
    for J in joints:
        origin = add(origin, _rot(R, J.origin()))
        cols = [_rot(R, J.to_parent(list(e))) for e in unit]
        R = [[cols[c][r] for c in range(3)] for r in range(3)]
        z.append([R[0][2], R[1][2], R[2][2]])
        O.append(origin)
    P = add(origin, _rot(R, list(lc.tip)))
    R_tip = _matmul3(R, lc.tip_R) if lc.constraints == 6 else None
    return _Frames(z, O, P, R_tip)


def _jacobian(lc: _ChainConst, joints: Sequence[JointState], f: _Frames) -> list[list[Scalar]]:
    """``J_i`` (c x n) in frame 0i, by rows."""
    cols = []
    for j, J in enumerate(joints):
        if J.k.revolute:
            cols.append([*cross(f.z[j], sub(f.P, f.O[j])), *f.z[j]])
        else:
            cols.append([*f.z[j], 0.0, 0.0, 0.0])
    return [[cols[j][i] for j in range(len(joints))] for i in range(lc.constraints)]


def _residual(lc: _ChainConst, f: _Frames, P0: Vec, Rt0: Mat | None) -> list[Scalar]:
    e = sub(P0, f.P)
    if lc.constraints == 3:
        return e
    assert Rt0 is not None and f.R_tip is not None
    # M = R_target R_tip^T; vex((M - M^T) / 2)
    M = [
        [lin_comb(*((Rt0[i][m], f.R_tip[j][m]) for m in range(3))) for j in range(3)]
        for i in range(3)
    ]
    r = [
        mul(0.5, minus(M[2][1], M[1][2])),
        mul(0.5, minus(M[0][2], M[2][0])),
        mul(0.5, minus(M[1][0], M[0][1])),
    ]
    return [*e, *r]


def _joints_from(lc: _ChainConst, state: Sequence[Scalar]) -> list[JointState]:
    """Joint states from Newton's state: ``(cos, sin)`` of ``theta + q`` per revolute
    joint, ``q`` per prismatic one."""
    out, i = [], 0
    for k in lc.joints:
        if k.revolute:
            out.append(revolute(k, state[i], state[i + 1]))
            i += 2
        else:
            out.append(prismatic(k, state[i]))
            i += 1
    return out


def _home_state(lc: _ChainConst, idle_q: Scalar | None = None) -> list[Scalar]:
    """Newton's start: the home configuration, the idle joint (if any) at ``idle_q``."""
    out: list[Scalar] = []
    for j, (k, q) in enumerate(zip(lc.joints, lc.home, strict=True)):
        if j == lc.idle and idle_q is not None:
            out += [cs.cos(k.theta + idle_q), cs.sin(k.theta + idle_q)] if k.revolute else [idle_q]
        else:
            out += [math.cos(k.theta + q), math.sin(k.theta + q)] if k.revolute else [q]
    return out


def _free_columns(lc: _ChainConst, J: list[list[Scalar]]) -> list[list[Scalar]]:
    """``J`` (c x n) without the idle joint's column (c x c)."""
    if lc.idle < 0:
        return J
    return [[row[j] for j in lc.free] for row in J]


def _newton_step(
    lc: _ChainConst, state: Sequence[Scalar], P0: Vec, Rt0: Mat | None
) -> list[Scalar]:
    """One capped Newton step ``J dq = e`` (the reference's), revolute joints turned by
    the Cayley rotation of ``dq``; an idle joint kept (the reference's Newton too)."""
    joints = _joints_from(lc, state)
    f = _frames(lc, joints)
    e = _residual(lc, f, P0, Rt0)
    dq_free, _, _ = lu_solve(_free_columns(lc, _jacobian(lc, joints, f)), e, lc.pivots)
    scale: Scalar = 1.0
    for d, cap in zip(dq_free, lc.caps, strict=True):
        scale = cs.fmax(scale, cs.fabs(d) * (1.0 / cap))
    inv = 1.0 / scale
    dq: list[Scalar | None] = [None] * len(lc.joints)
    for j, d in zip(lc.free, dq_free, strict=True):
        dq[j] = d
    out: list[Scalar] = []
    i = 0
    for k, d in zip(lc.joints, dq, strict=True):
        if d is None:  # the idle joint: its value is given
            out += [state[i], state[i + 1]] if k.revolute else [state[i]]
            i += 2 if k.revolute else 1
            continue
        d = d * inv
        if k.revolute:
            t = 0.5 * d
            den = 1.0 / (1.0 + t * t)
            cd, sd = (1.0 - t * t) * den, 2.0 * t * den
            c, s = state[i], state[i + 1]
            out += [c * cd - s * sd, s * cd + c * sd]
            i += 2
        else:
            out.append(state[i] + d)
            i += 1
    return out


@functools.lru_cache(maxsize=64)
def _newton_step_function(lc: _ChainConst) -> cs.Function:
    """One Newton step of leg ``lc`` as a function called (never inlined) by the models."""
    n_state = len(_home_state(lc))
    state, P, Rt = cs.SX.sym("state", n_state), cs.SX.sym("P", 3), cs.SX.sym("R", 9)
    Rt0 = mat3(split(Rt)) if lc.constraints == 6 else None
    step = _newton_step(lc, split(state), split(P), Rt0)
    return cs.Function(
        f"chain_newton_leg{lc.index + 1}",
        [state, P, Rt],
        [column(step)],
        ["state", "P", "R"],
        ["state_next"],
        {"never_inline": True},
    )


@dataclass
class _ChainKinematics:
    joints: list[JointState]
    frames: _Frames
    L: Vec  # O_p -> P_i in F0
    inv: list[list[Scalar]]  # J_i^-1 (n x c) in frame 0i
    qd: list[Scalar]
    row: list[Scalar]  # row i of Jp^-1 (F0)
    slacks: list[Scalar]
    #: the idle motion per unit idle rate (n,) (``J_i null = 0``, 1 at the idle joint)
    null: list[Scalar] | None = None


def chain_kinematics(
    lc: _ChainConst,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    idle: tuple[Scalar, Scalar] | None = None,
) -> _ChainKinematics:
    """Inverse geometry (Newton), ``J_i^-1``, the slacks, ``qdot`` and the ``Jp^-1`` row;
    a leg with an idle joint (``lc.idle``) takes its value and rate ``idle`` (the
    reference's :func:`~stewart_pin.kinematics.chain_legs.leg_states`: Newton with the
    idle joint kept, ``J_i^-1`` the first c columns of ``[J_i; e_idle^T]^-1`` and
    ``qdot = J_i^-1 G_i V + null * idle_rate``)."""
    if lc.idle >= 0 and idle is None:
        raise UnsupportedArchitectureError(
            f"leg {lc.index + 1} has an idle joint: its models take the idle state",
            "backend",
            "chain",
        )
    L = _rot(R, list(lc.pL))
    P0 = _to_frame(lc, [plus(minus(p[i], lc.B[i]), L[i]) for i in range(3)])
    Rt0 = None
    if lc.constraints == 6:  # R_i^T R R_p
        Rt0 = _matmul3([list(r) for r in zip(*lc.R, strict=True)], _matmul3(R, lc.pR))
    state: list[Scalar] = _home_state(lc, None if idle is None or lc.idle < 0 else idle[0])
    if lc.inline_newton:
        for _ in range(lc.iterations):
            state = _newton_step(lc, state, P0, Rt0)
    else:  # the first step inline (from the constant home configuration: its kinematics
        # and LU fold into numbers), the others calls of one step function
        state = _newton_step(lc, state, P0, Rt0)
        step = _newton_step_function(lc)
        Rflat = column([x for r in Rt0 for x in r] if Rt0 is not None else [0.0] * 9)
        for _ in range(lc.iterations - 1):
            state = split(step(column(state), column(P0), Rflat))
    joints = _joints_from(lc, state)
    f = _frames(lc, joints)
    e = _residual(lc, f, P0, Rt0)
    tol = RESIDUAL_TOLERANCE
    slacks: list[Scalar] = [
        (tol * lc.size) ** 2 - dot(e[:3], e[:3]),
    ]
    if lc.constraints == 6:
        slacks.append(tol * tol - dot(e[3:], e[3:]))
    J = _jacobian(lc, joints, f)
    inv, growth = _lu_inverse(_free_columns(lc, J), lc.pivots)
    slacks.append(LEG_GROWTH_LIMIT - growth)
    slacks += limit_slacks(lc.size, joints)
    tw = _platform_twist(lc, L, v, w)
    null: list[Scalar] | None = None
    if lc.idle >= 0 and idle is not None:
        # [J; e_idle^T]^-1: the free joints' rows J_free^-1 (first c columns) and
        # -J_free^-1 J[:, idle] (last column, the null motion); the idle row e_last
        c = lc.constraints
        col = [J[i][lc.idle] for i in range(c)]
        null_free = [mul(-1.0, x) for x in _matvec(inv, col)]
        rows: list[list[Scalar]] = [[0.0] * c for _ in lc.joints]
        null = [0.0] * len(lc.joints)
        null[lc.idle] = 1.0
        for i, j in enumerate(lc.free):
            rows[j] = inv[i]
            null[j] = null_free[i]
        inv = rows
    qd = _matvec(inv, tw)
    if null is not None and idle is not None:
        qd = [plus(x, mul(nj, idle[1])) for x, nj in zip(qd, null, strict=True)]
    a = inv[lc.actuated]
    m = _from_frame(lc, a[:3])
    row = [*m, *cross(L, m)]
    if lc.constraints == 6:
        row = [*m, *add(row[3:], _from_frame(lc, a[3:]))]
    return _ChainKinematics(joints, f, L, inv, qd, row, slacks, null)


def _platform_twist(lc: _ChainConst, L: Vec, v: Vec, w: Vec) -> list[Scalar]:
    """``G_i V`` in frame 0i (c,)."""
    vP = _to_frame(lc, add(v, cross(w, L)))
    return vP if lc.constraints == 3 else [*vP, *_to_frame(lc, w)]


def _drift(lc: _ChainConst, kin_: _ChainKinematics) -> list[Scalar]:
    """``Jdot_i qdot_i`` (c,) in frame 0i (the reference's :func:`chain_drift`)."""
    joints, f, qd = kin_.joints, kin_.frames, kin_.qd
    z, o, P = f.z, f.O, f.P

    def lin_col(k: int, point: Vec) -> Vec:
        return cross(z[k], sub(point, o[k])) if joints[k].k.revolute else z[k]

    n = len(joints)
    v_P: Vec = [0.0, 0.0, 0.0]
    for k in range(n):
        v_P = add(v_P, scaled(lin_col(k, P), qd[k]))
    lin: Vec = [0.0, 0.0, 0.0]
    ang: Vec = [0.0, 0.0, 0.0]
    w: Vec = [0.0, 0.0, 0.0]
    for j in range(n):
        wz = cross(w, z[j])
        if joints[j].k.revolute:
            v_o: Vec = [0.0, 0.0, 0.0]
            for k in range(j):
                v_o = add(v_o, scaled(lin_col(k, o[j]), qd[k]))
            term = add(cross(wz, sub(P, o[j])), cross(z[j], sub(v_P, v_o)))
            lin = add(lin, scaled(term, qd[j]))
            ang = add(ang, scaled(wz, qd[j]))
            w = add(w, scaled(z[j], qd[j]))
        else:
            lin = add(lin, scaled(wz, qd[j]))
    return lin if lc.constraints == 3 else [*lin, *ang]


# ---------------------------------------------------------------------------- dynamics
def _wrench(lc: _ChainConst, L: Vec, fc: Sequence[Scalar]) -> list[Scalar]:
    """``G_i^T`` of a frame-0i (c,) force (and moment) at P_i: the wrench about O_p in F0."""
    f = _from_frame(lc, list(fc[:3]))
    moment = cross(L, f)
    if lc.constraints == 6:
        moment = add(moment, _from_frame(lc, list(fc[3:])))
    return [*f, *moment]


def _idle_inertia(joints: Sequence[JointState], null: Sequence[Scalar]) -> list[Scalar]:
    """``M_i null`` (n,): the chain's efforts of the joint accelerations ``null`` without
    velocity or gravity, armature included (one Newton-Euler pass)."""
    n = len(joints)
    Mn = newton_euler(joints, [0.0] * n, list(null), [0.0, 0.0, 0.0])
    return [
        plus(t, mul(J.k.armature, x)) if J.k.armature else t
        for t, J, x in zip(Mn, joints, null, strict=True)
    ]


def _idm_leg(
    lc: _ChainConst,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    vd: Vec,
    wd: Vec,
    K: Mat,
    idle: tuple[Scalar, Scalar] | None = None,
) -> dict[str, Any]:
    ck = chain_kinematics(lc, p, R, v, w, idle)
    A_P = add(vd, [dot(K[i], ck.L) for i in range(3)])
    acc = _to_frame(lc, A_P)
    if lc.constraints == 6:
        acc = [*acc, *_to_frame(lc, wd)]
    drift = _drift(lc, ck)
    qdd = _matvec(ck.inv, [minus(a, d) for a, d in zip(acc, drift, strict=True)])
    g = lc.gravity
    tau = newton_euler(ck.joints, ck.qd, qdd, [-g[0], -g[1], -g[2]], list(g))
    terms = joint_terms(ck.joints, ck.qd, qdd)
    H = [plus(t, u) for t, u in zip(tau, terms, strict=True)]
    sigma: Scalar = 0.0
    if ck.null is not None:
        # the idle acceleration: null^T H = 0 with qdd + null sigma (the reference's)
        Mn = _idle_inertia(ck.joints, ck.null)
        sigma = mul(-1.0, _dot_n(ck.null, H)) / _dot_n(ck.null, Mn)
        H = [plus(h, mul(sigma, m)) for h, m in zip(H, Mn, strict=True)]
    a = lc.actuated
    Hp = [0.0 if j == a else H[j] for j in range(len(H))]
    return {
        "row": ck.row,
        "wrench": _wrench(lc, ck.L, _matTvec(ck.inv, Hp)),
        "Hz": [H[a]],
        "slack": ck.slacks,
        "residual": 2 if lc.constraints == 6 else 1,  # chain_kinematics: the first slacks
        "sigma": [sigma],
    }


_UPPER6 = [(i, j) for i in range(6) for j in range(i, 6)]


def _weld_block(A: list[list[Scalar]], L: Vec) -> list[Scalar]:
    """The upper triangle (21) of ``G^T A G``, ``G = [[I3, -L^], [0, I3]]`` (A 6x6, F0)."""
    nL = [mul(-1.0, x) for x in L]
    G: list[list[Scalar]] = [[0.0] * 6 for _ in range(6)]
    Lh = [[0.0, nL[2], L[1]], [L[2], 0.0, nL[0]], [nL[1], L[0], 0.0]]
    for i in range(3):
        G[i][i] = G[3 + i][3 + i] = 1.0
        for j in range(3):
            G[i][3 + j] = mul(-1.0, Lh[i][j])
    AG = [[lin_comb(*((A[i][m], G[m][j]) for m in range(6))) for j in range(6)] for i in range(6)]
    return [lin_comb(*((G[m][i], AG[m][j]) for m in range(6))) for i, j in _UPPER6]


def _ddm_leg(
    lc: _ChainConst,
    p: Vec,
    R: Mat,
    v: Vec,
    w: Vec,
    gamma_k: Scalar,
    idle: tuple[Scalar, Scalar] | None = None,
) -> dict[str, Any]:
    ck = chain_kinematics(lc, p, R, v, w, idle)
    joints = ck.joints
    n = len(joints)
    g = lc.gravity
    zero = [0.0] * n
    h = newton_euler(joints, ck.qd, zero, [-g[0], -g[1], -g[2]], list(g))
    terms = joint_terms(joints, ck.qd, zero)
    h = [plus(a, b) for a, b in zip(h, terms, strict=True)]
    c = lc.constraints
    # B = J_i^-1 blockdiag(R_i^T) (n x c, F0): column i of B^T...; d_i - drift in F0
    drift0 = _drift(lc, ck)
    dr = _from_frame(lc, drift0[:3])
    if c == 6:
        dr = [*dr, *_from_frame(lc, drift0[3:])]
    cw = cross(w, cross(w, ck.L))
    cvec = [minus(cw[i], dr[i]) for i in range(3)]
    if c == 6:
        cvec += [mul(-1.0, x) for x in dr[3:]]
    Bm = []
    for row in ck.inv:
        b = _from_frame(lc, row[:3])
        Bm.append(b if c == 3 else [*b, *_from_frame(lc, row[3:])])
    Mq = mass_matrix(joints)
    sigma_of = None
    if ck.null is not None:
        # the idle acceleration sigma = -(null^T M (K Vdot + k) + null^T h) / m eliminated
        # (the reference's cartesian_batch): M -> M - Mn Mn^T / m, h -> h - Mn null^T h / m
        Mn = [_dot_n(r, ck.null) for r in Mq]
        m_inv = 1.0 / _dot_n(ck.null, Mn)
        nh = _dot_n(ck.null, h)
        u = _matTvec(Bm, Mn)  # B^T Mn (c,), F0: null^T M B x = u . x
        L = ck.L

        def sigma_of(acc: Sequence[Scalar]) -> Scalar:
            """The idle acceleration at the platform's classical acceleration ``acc``."""
            GA = add(list(acc[:3]), cross(list(acc[3:]), L))
            if c == 6:
                GA = [*GA, *acc[3:]]
            x = [plus(gi, ci) for gi, ci in zip(GA, cvec, strict=True)]
            return mul(-1.0, plus(_dot_n(u, x), nh)) * m_inv

        Mq = [[minus(Mq[i][j], mul(Mn[i], Mn[j]) * m_inv) for j in range(n)] for i in range(n)]
        h = [minus(h[i], mul(Mn[i], nh) * m_inv) for i in range(n)]
    MB = [
        [lin_comb(*((Mq[i][m], Bm[m][j]) for m in range(n))) for j in range(c)] for i in range(n)
    ]
    A0: list[list[Scalar]] = [[0.0] * c for _ in range(c)]
    for i in range(c):
        for j in range(i, c):
            A0[i][j] = A0[j][i] = lin_comb(*((Bm[m][i], MB[m][j]) for m in range(n)))
    a = lc.actuated
    rhs = [(gamma_k if j == a else 0.0) - h[j] for j in range(n)]
    Btr = _matTvec(Bm, rhs)
    f = [minus(Btr[i], _dot_n(A0[i], cvec)) for i in range(c)]
    moment = cross(ck.L, f[:3])
    if c == 6:
        moment = add(moment, f[3:])
    block = leg_block(A0, ck.L) if c == 3 else _weld_block(A0, ck.L)
    return {
        "row": ck.row,
        "block": block,
        "wrench": [*f[:3], *moment],
        "slack": ck.slacks,
        "sigma_of": sigma_of,
    }


def _dot_n(a: Sequence[Scalar], b: Sequence[Scalar]) -> Scalar:
    return lin_comb(*zip(a, b, strict=True))


# ---------------------------------------------------------------------------- assembly
def _idm_leg_stage(lc: _ChainConst, p: Vec, R: Mat, t: list, a: list, K: Mat) -> dict:
    return _idm_leg(lc, p, R, t[:3], t[3:], a[:3], a[3:], K)


def _ddm_leg_stage(lc: _ChainConst, p: Vec, R: Mat, t: list, gamma_k: Scalar) -> dict:
    return _ddm_leg(lc, p, R, t[:3], t[3:], gamma_k)


def build_chain_models(
    desc: RobotDescription,
    pose: str = "matrix",
    prefix: str = "stewart_",
    stages: bool = False,
    inline_newton: bool = False,
    coulomb_smoothing: float = 0.0,
) -> tuple[SymbolicModels, AuxLayout]:
    """The IDM and DDM of a robot with chain legs as :class:`SymbolicModels`
    (``parameters="numeric"``, an empty ``base_parameters`` input) with the layout of their
    ``aux``; ``stages``, ``inline_newton`` and ``coulomb_smoothing`` (``eps`` [m/s or
    rad/s] > 0: every joint's ``Fc sign(qd)`` as ``Fc tanh(qd / eps)``, the planner's
    smooth model) as :func:`~.leg_chain_symbolic.build_general_models`."""
    legs = [chain_constants(desc, k, inline_newton, coulomb_smoothing) for k in range(6)]
    states = kin.leg_states(desc, desc.home_pose[None], np.zeros((1, 6)))
    home_rows = kin.inverse_jacobian(desc, states)[0]
    return assemble_models(
        desc,
        legs,
        home_rows,
        kin.robot_size(desc),
        pose,
        prefix,
        stages,
        _idm_leg_stage,
        _ddm_leg_stage,
    )


#: The idle state input of the idle models: the six idle joints' values then rates (12,)
#: [rad or m, /s] (entries of legs without an idle joint ignored).
IDLE_INPUT = 12


@dataclass(frozen=True)
class IdleModels:
    """The models of a robot whose legs have idle joints (R-S-S spins), the idle state an
    input (``idle`` (12,): the idle joints' values then rates, legs without one ignored).

    Attributes:
        idm: ``(pose, twist, accel, base_parameters, idle) -> (gamma, idle_accel)``.
        ddm: ``(pose, twist, gamma, base_parameters, idle) -> (accel, idle_accel)``.
        idm_guarded, ddm_guarded: the same with ``aux`` between the two outputs (the
            layout of :class:`~.leg_chain_symbolic.AuxLayout`): what gets compiled.
        flat_idm, flat_ddm: one output (12,) ``[gamma | accel, idle_accel]`` (what the
            exact derivatives differentiate).
        layout: the ``aux`` layout. pivots: the IDM closure's static pivots.
    """

    idm: cs.Function
    ddm: cs.Function
    idm_guarded: cs.Function
    ddm_guarded: cs.Function
    flat_idm: cs.Function
    flat_ddm: cs.Function
    layout: AuxLayout
    pivots: tuple[tuple[int, int], ...]
    constants: ModelConstants


def build_idle_models(
    desc: RobotDescription, prefix: str = "stewart_idle_", inline_newton: bool = False
) -> IdleModels:
    """The IDM and DDM of a robot with chain legs some of which have an idle joint, the
    idle joints' values and rates an input (:class:`IdleModels`): each leg as
    :func:`build_chain_models`'s, with the reference's idle equations
    (:class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`): the IDM's idle
    acceleration from ``null^T H_i = 0``, the DDM's eliminated (``M - Mn Mn^T / m``) and
    recovered from the platform's acceleration. ``inline_newton``: the Newton steps
    written out (the operation counts) rather than calls of one step function."""
    legs = [chain_constants(desc, k, inline_newton=inline_newton, idle=True) for k in range(6)]
    states = kin.leg_states(
        desc,
        desc.home_pose[None],
        np.zeros((1, 6)),
        idle=kin.IdleState(kin.idle_home(desc)[None], np.zeros((1, 6))),
    )
    home_rows = kin.inverse_jacobian(desc, states)[0]
    gravity = np.asarray(desc.gravity, dtype=float)
    g_platform = (1.0 - desc.platform_gravcomp) * gravity
    Pp = [float(x) for x in desc.platform_inertia]
    x_pose = cs.SX.sym("pose", pose_size("matrix"))
    x_twist, x_accel, x_gamma = (cs.SX.sym(n, 6) for n in ("twist", "accel", "gamma"))
    x_chi = cs.SX.sym("base_parameters", 0)
    x_idle = cs.SX.sym("idle", IDLE_INPUT)
    p, R = pose_from_input(x_pose, "matrix")
    tw, ac, gm, idle = split(x_twist), split(x_accel), split(x_gamma), split(x_idle)
    w, wd = tw[3:], ac[3:]

    def idle_of(lc: _ChainConst) -> tuple[Scalar, Scalar] | None:
        return (idle[lc.index], idle[6 + lc.index]) if lc.idle >= 0 else None

    # ---- IDM
    K, vdg = idm_shared(tw, ac, g_platform)
    ilegs = [_idm_leg(lc, p, R, tw[:3], w, ac[:3], wd, K, idle_of(lc)) for lc in legs]
    F_p = idm_platform(R, w, wd, vdg, K, Pp)
    inv_l = 1.0 / kin.robot_size(desc)
    gamma, idm_aux, layout, pivots = idm_closure_and_aux(ilegs, F_p, home_rows, inv_l)
    idm_sigma = [lg["sigma"][0] for lg in ilegs]

    # ---- DDM
    dlegs = [_ddm_leg(lc, p, R, tw[:3], w, gm[lc.index], idle_of(lc)) for lc in legs]
    Ip, hp = ddm_platform(R, w, Pp, g_platform)
    accel, D = ddm_legs_closure(dlegs, Ip, hp)
    ddm_sigma: list[Scalar] = [
        0.0 if lg["sigma_of"] is None else lg["sigma_of"](accel) for lg in dlegs
    ]
    dslacks = [s for lg in dlegs for s in lg["slack"]]
    ddm_aux = [*[x for lg in dlegs for x in lg["row"]], *D, *dslacks]

    idm_in = [("pose", x_pose), ("twist", x_twist), ("accel", x_accel)]
    ddm_in = [("pose", x_pose), ("twist", x_twist), ("gamma", x_gamma)]
    tail = [("base_parameters", x_chi), ("idle", x_idle)]
    idm_in, ddm_in = idm_in + tail, ddm_in + tail
    sig = ("idle_accel", idm_sigma)
    dsig = ("idle_accel", ddm_sigma)
    return IdleModels(
        idm=function(f"{prefix}idm", idm_in, [("gamma", gamma), sig]),
        ddm=function(f"{prefix}ddm", ddm_in, [("accel", accel), dsig]),
        idm_guarded=function(
            f"{prefix}idm_guarded", idm_in, [("gamma", gamma), ("aux", idm_aux), sig]
        ),
        ddm_guarded=function(
            f"{prefix}ddm_guarded", ddm_in, [("accel", accel), ("aux", ddm_aux), dsig]
        ),
        flat_idm=function(f"{prefix}idm_flat", idm_in, [("out", [*gamma, *idm_sigma])]),
        flat_ddm=function(f"{prefix}ddm_flat", ddm_in, [("out", [*accel, *ddm_sigma])]),
        layout=layout,
        pivots=pivots,
        constants=ModelConstants(
            base_points=np.array(desc.base_points),
            platform_points=np.array(desc.platform_points),
            leg_base_rotations=np.array(desc.leg_base_rotations),
            gravity=gravity.copy(),
            parameter_names=(),
            parameter_values=np.zeros(0),
        ),
    )


def chain_actuator_function(desc: RobotDescription) -> cs.Function:
    """``actuators(pose, twist) -> (q_a, qdot_a)``: the six actuated joint values [m or
    rad, a revolute one in (-pi, pi] taken into its limits] and rates from the generated
    leg code (pose 0Tp row-major (16), twist ``[v, w]`` in F0)."""

    def actuated(k: int, p: Vec, R: Mat, tw: list) -> tuple[Scalar, Scalar]:
        lc = chain_constants(desc, k, inline_newton=False)
        ck = chain_kinematics(lc, p, R, tw[:3], tw[3:])
        return ck.joints[lc.actuated].value(), ck.qd[lc.actuated]

    return actuators_of(actuated)


__all__ = [
    "CHAIN_GENERATOR_VERSION",
    "IDLE_INPUT",
    "LEG_GROWTH_LIMIT",
    "NEWTON_ITERATIONS",
    "RESIDUAL_TOLERANCE",
    "IdleModels",
    "build_chain_models",
    "build_idle_models",
    "chain_actuator_function",
    "chain_constants",
    "chain_kinematics",
]
