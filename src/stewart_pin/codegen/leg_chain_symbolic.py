"""Symbolic closed-form models of robots with general three-joint legs (CasADi SX).

The same models as :mod:`.symbolic` (the inverse, IDM, and the direct, DDM, dynamic
models as straight-line CasADi ``SX`` code, with their guarded variants and stages) for any
robot whose legs are :class:`~stewart_pin.description.leg_architecture.LegArchitecture`
chains (``ups``, ``ups-offset``, ``rus``, ``pus``, ``custom``, mixed), every
:class:`~stewart_pin.description.leg_architecture.JointDynamics` term included. Nothing is
hand-derived per architecture except the inverse geometry: the leg dynamics are a generic
Newton-Euler on the chain's modified-DH joint placements (Khalil's recursive algorithm in
the link frames), and every number of the robot (placements, inertial parameters, joint
terms, gravity) enters as a constant, so that the zeros, ones and products of constants
of a particular robot fold away (``alpha = pi/2`` gives ``cos alpha = 0`` exactly: values
within :data:`SNAP` of 0 or +-1 are snapped).

Per leg i, in its frame 0i (``[R_i, B_i]`` in F0):

- inverse geometry without a trigonometric call where a closed form exists (each revolute
  joint carries ``cos`` and ``sin`` of ``theta_j + q_j``, ratios of square roots):
  ``ups`` / ``ups-offset`` (the leg's line through the second U axis), ``rus`` (the crank
  equation ``A cos + B sin = K``: ``cos phi = (A K + b B S) / R^2``, ``S = sqrt(R^2 - K^2)``),
  ``pus`` (a quadratic along the rail), then the universal joint (the same identity);
  ``custom`` legs run :data:`NEWTON_ITERATIONS` Newton steps from the leg's ``guess``
  (the reference's iteration, unrolled: calls of one step function, never inlined, in
  the compiled source) and report the final residual to the guard. The
  joint value ``q_j`` itself (``atan2``) is computed only where a spring needs it, taken
  into the joint's limits as :func:`~stewart_pin.description.leg_architecture.wrap_into_limits`
  does;
- ``J_i`` (columns ``z_j x (P_i - O_j)`` or ``z_j``) and its inverse by the adjugate;
  ``qdot = J_i^-1 V_Pi``, the drift ``Jdot_i qdot_i`` (the reference's recursion),
  ``qddot = J_i^-1 (A_Pi - drift)``;
- Newton-Euler in the link frames with the base acceleration ``-g`` (gravity), nothing at
  the tip (a link with a gravity compensation ``c``, ``leg_gravcomp``: ``c M g`` and
  ``c MS x g`` added to its terms, its weight ``(1 - c) m g``; the platform's gravity
  ``(1 - c_p) g``), plus ``Ia qddot + (Fv + D) qdot + Fc sign(qdot) + K (q - q0)`` on each joint
  (``sign`` zero within :data:`~stewart_pin.description.leg_architecture.COULOMB_DEAD_BAND`);
- IDM: the actuated joint's effort goes straight to its actuator, the rest through
  ``Jp^T`` (``Gamma = H_a + Jp^T (F_p + sum_i G_i^T J_i^-T H_i,passive)``, the static-pivot
  LU of :mod:`.symbolic`);
- DDM: ``A_xi = J_i^-T M_i J_i^-1`` (``M_i`` from unit joint accelerations, armature on
  its diagonal), ``h`` from the same leg code at zero platform acceleration, the closure
  by ``L D L^T`` (:mod:`.symbolic`).

The guarded variants return ``aux``: ``Jp^-1``, the IDM's closure by-products or the DDM's
pivots as in :mod:`.symbolic` (:class:`AuxLayout`), then the *slacks*: numbers that
are positive when a state is safely inside every geometric condition of the reference
(reach, serial singularity bound ``2 |det S| / ||S||_F^2`` of the scaled leg Jacobian,
levers, joint limits with margins, the Newton residual). A state with a slack not
positive is decided by the reference path (see :mod:`.compiled`).

The parameters are the robot's numbers: the ``base_parameters`` input is empty (length 0)
so that the functions have the signature of :class:`~stewart_pin.codegen.symbolic.SymbolicModels`
(``idm(pose, twist, accel, base_parameters)``, ``ddm(pose, twist, gamma, base_parameters)``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin.codegen._sx_common import (
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
    model_functions,
    pivot_order,
    pose_from_input,
    pose_size,
    split,
    stage_function,
)
from stewart_pin.description import RobotDescription
from stewart_pin.description.leg_architecture import COULOMB_DEAD_BAND, Joint, LegArchitecture
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics import leg_chains
from stewart_pin.kinematics.geometry import LEG_MIN_LENGTH_RATIO
from stewart_pin.kinematics.leg_chains import LEG_SINGULARITY, LEG_TOLERANCE

#: The general generator's version (in the cache manifest).
GENERAL_GENERATOR_VERSION = "1"
#: Constants within this (relative) distance of 0 or +-1 are snapped to it: cos(pi/2) =
#: 6e-17 becomes an exact 0 (a few ulps only, far below the models' accuracy).
SNAP = 4.0 * float(np.finfo(float).eps)
#: Newton steps unrolled for a ``custom`` leg (from its ``guess``; the reference needs at
#: most 9 on the random custom robots' sampled states; more: the guard flags the state).
NEWTON_ITERATIONS = 12
#: Relative margins of the guard (a flagged state is decided by the reference path).
_MARGIN_SERIAL = 1e-6
_MARGIN_LIMIT = 1e-9
_MARGIN_REVOLUTE_LIMIT = 1e-9


@dataclass(frozen=True)
class AuxLayout:
    """Where the guarded variants put their by-products (offsets in ``aux``, per state).

    The defaults are the general models': ``jinv``: ``Jp^-1`` row-major (36), then for the
    IDM ``idm_f`` (6: the wrench ``Jp^T`` maps), ``idm_hz`` (6: the actuated joints' own
    efforts), ``growth``, ``det``, ``fro2`` (as :mod:`.symbolic`); for the DDM ``ddm_d``
    (6: the ``L D L^T`` pivots). Then ``n_slack`` slacks from ``idm_slack`` /
    ``ddm_slack``; ``residual``: those of them (offsets from the first) that are a leg's
    Newton residual after the unrolled steps from home, each with its leg (1..6)
    (:func:`residual_slacks`). (:data:`stewart_pin.codegen.compiled.UPS_AUX_LAYOUT` is
    the paper's 6-UPS models', whose leg checks read ``q3^2`` and ``rho^2`` instead of
    slacks.)"""

    jinv: int = 0
    idm_f: int = 36
    idm_hz: int = 42
    growth: int = 48
    det: int = 49
    fro2: int = 50
    idm_slack: int = 51
    ddm_d: int = 36
    ddm_slack: int = 42
    n_slack: int = 0
    residual: tuple[tuple[int, int], ...] = ()

    @property
    def idm_size(self) -> int:
        return self.idm_slack + self.n_slack

    @property
    def ddm_size(self) -> int:
        return self.ddm_slack + self.n_slack


# ---------------------------------------------------------------------------- arithmetic
# Scalars are Python floats (constants of the robot) or 1x1 casadi.SX. These helpers fold
# what they can in Python before building an SX node (CasADi would fold 0 * x, 1 * x, x + 0
# too, but building the node first costs tens of microseconds each: a robot's models
# generate several times faster this way; the expressions are the same).
def mul(a: Scalar, b: Scalar) -> Scalar:
    if isinstance(a, (int, float)):
        if a == 0.0:
            return 0.0
        if isinstance(b, (int, float)):
            return float(a * b)
        if a == 1.0:
            return b
        if a == -1.0:
            return -b
    elif isinstance(b, (int, float)):
        if b == 0.0:
            return 0.0
        if b == 1.0:
            return a
        if b == -1.0:
            return -a
    return a * b


def plus(a: Scalar, b: Scalar) -> Scalar:
    if isinstance(a, (int, float)):
        if a == 0.0:
            return b
        if isinstance(b, (int, float)):
            return float(a + b)
    if isinstance(b, (int, float)) and b == 0.0:
        return a
    return a + b


def minus(a: Scalar, b: Scalar) -> Scalar:
    if isinstance(b, (int, float)):
        if b == 0.0:
            return a
        if isinstance(a, (int, float)):
            return float(a - b)
    if isinstance(a, (int, float)) and a == 0.0:
        return -b
    return a - b


def dot(a: Vec, b: Vec) -> Scalar:
    return plus(plus(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))


def cross(a: Vec, b: Vec) -> Vec:
    return [
        minus(mul(a[1], b[2]), mul(a[2], b[1])),
        minus(mul(a[2], b[0]), mul(a[0], b[2])),
        minus(mul(a[0], b[1]), mul(a[1], b[0])),
    ]


def add(a: Vec, b: Vec) -> Vec:
    return [plus(a[0], b[0]), plus(a[1], b[1]), plus(a[2], b[2])]


def sub(a: Vec, b: Vec) -> Vec:
    return [minus(a[0], b[0]), minus(a[1], b[1]), minus(a[2], b[2])]


def scaled(a: Vec, s: Scalar) -> Vec:
    return [mul(a[0], s), mul(a[1], s), mul(a[2], s)]


def lin_comb(*terms: tuple[Scalar, Scalar]) -> Scalar:
    """``sum a * b`` over the pairs, folding constants."""
    out: Scalar = 0.0
    for a, b in terms:
        out = plus(out, mul(a, b))
    return out


# ---------------------------------------------------------------------------- constants
def snap(x: float, scale: float = 1.0) -> float:
    x = float(x)
    if abs(x) <= SNAP * scale:
        return 0.0
    if abs(abs(x) - scale) <= SNAP * scale:
        return math.copysign(scale, x)
    return x + 0.0


@dataclass(frozen=True)
class JointConst:
    """One joint's numbers: placement, limits, joint terms, its link's inertia."""

    revolute: bool
    ca: float
    sa: float
    d: float
    theta: float
    ct: float
    st: float
    r: float
    lower: float
    upper: float
    armature: float
    viscous: float
    coulomb: float
    stiffness: float
    rest: float
    inertia: tuple[float, ...]  # XX XY XZ YY YZ ZZ MX MY MZ M, frame j about O_j
    gravcomp: float = 0.0  # the fraction of the link's weight removed
    #: > 0: Coulomb's sign smoothed as tanh(qd / coulomb_smoothing) [m/s or rad/s]
    coulomb_smoothing: float = 0.0


@dataclass(frozen=True)
class LegConst:
    """One leg's numbers (snapped)."""

    index: int
    name: str
    R: tuple[tuple[float, ...], ...]  # R_i, frame 0i in F0
    B: tuple[float, ...]
    pL: tuple[float, ...]  # P_i in Fp
    joints: tuple[JointConst, ...]
    tip: tuple[float, ...]
    branch: int
    guess: tuple[float, ...]
    actuated: int  # 0-based
    gravity: tuple[float, ...]  # g in frame 0i
    radius: float  # the platform radius of the lever check
    inline_newton: bool = True  # custom legs: Newton's steps inline, or calls of one step


def joint_constants(
    jt: Joint,
    inertia: np.ndarray,
    size: float,
    gravcomp: float = 0.0,
    coulomb_smoothing: float = 0.0,
) -> JointConst:
    """A joint's numbers (snapped; ``size`` [m] the lengths' scale), ``inertia`` (10,) its
    link's Khalil parameters, ``gravcomp`` the fraction of its link's weight removed,
    ``coulomb_smoothing`` > 0 [m/s or rad/s]: its Coulomb sign smoothed."""
    dyn = jt.dynamics
    return JointConst(
        revolute=jt.revolute,
        ca=snap(math.cos(jt.alpha)),
        sa=snap(math.sin(jt.alpha)),
        d=snap(jt.d, size),
        theta=jt.theta,
        ct=snap(math.cos(jt.theta)),
        st=snap(math.sin(jt.theta)),
        r=snap(jt.r, size),
        lower=jt.lower,
        upper=jt.upper,
        armature=dyn.total_armature,
        viscous=dyn.viscous + dyn.damping,
        coulomb=dyn.coulomb,
        stiffness=dyn.stiffness,
        rest=dyn.rest_position,
        inertia=tuple(float(x) for x in inertia),
        gravcomp=float(gravcomp),
        coulomb_smoothing=float(coulomb_smoothing),
    )


def leg_constants(
    robot: GeneralHexapod, k: int, inline_newton: bool = True, coulomb_smoothing: float = 0.0
) -> LegConst:
    """Leg ``k``'s numbers; ``coulomb_smoothing`` > 0 [m/s or rad/s, each joint's rate
    unit]: its joints' Coulomb sign smoothed (:func:`build_general_models`)."""
    leg: LegArchitecture = robot.legs[k]
    size = max(robot.size, float(np.abs(robot.base_points).max()), 1e-300)
    joints = [
        joint_constants(
            jt, robot.leg_inertia[k, j], size, robot.leg_gravcomp[k, j], coulomb_smoothing
        )
        for j, jt in enumerate(leg.joints)
    ]
    R = robot.leg_base_rotations[k]
    g = robot.gravity
    g0 = R.T @ g
    # hypot, not the norm's sum of squares: |g| past ~1e154 overflowed that to inf, which
    # snapped every component to 0 (a robot without gravity, silently)
    gscale = max(math.hypot(*(float(x) for x in g)), 1e-300)
    return LegConst(
        index=k,
        name=leg.name,
        R=tuple(tuple(snap(x) for x in row) for row in R),
        B=tuple(snap(x, size) for x in robot.base_points[k]),
        pL=tuple(snap(x, size) for x in robot.platform_points[k]),
        joints=tuple(joints),
        tip=tuple(snap(x, size) for x in leg.tip),
        branch=leg.branch,
        guess=tuple(float(x) for x in leg.guess),
        actuated=leg.actuated - 1,
        gravity=tuple(snap(x, gscale) for x in g0),
        radius=robot.size,
        inline_newton=inline_newton,
    )


# ---------------------------------------------------------------------------- joints
@dataclass
class JointState:
    """A joint at a state: ``c``, ``s`` = cos, sin of ``theta + q`` (constants for a
    prismatic joint), ``rr`` = ``r + q`` (prismatic) or ``r``, and ``q`` when known
    directly (prismatic joints, Newton's iterate), else computed on demand."""

    k: JointConst
    c: Scalar
    s: Scalar
    rr: Scalar
    q: Scalar | None = None

    def origin(self) -> Vec:
        """The origin of this joint's frame in the previous frame."""
        k = self.k
        return [k.d, mul(-k.sa, self.rr), mul(k.ca, self.rr)]

    def axis(self) -> Vec:
        """This joint's axis z_j in the previous frame."""
        return [0.0, -self.k.sa, self.k.ca]

    def to_parent(self, u: Vec) -> Vec:
        """``Rx(alpha) Rz(phi) u``: a vector of this joint's frame in the previous one."""
        c, s, ca, sa = self.c, self.s, self.k.ca, self.k.sa
        t0 = minus(mul(c, u[0]), mul(s, u[1]))
        t1 = plus(mul(s, u[0]), mul(c, u[1]))
        return [t0, minus(mul(ca, t1), mul(sa, u[2])), plus(mul(sa, t1), mul(ca, u[2]))]

    def to_child(self, u: Vec) -> Vec:
        """``Rz(phi)^T Rx(alpha)^T u``: a vector of the previous frame in this joint's."""
        c, s, ca, sa = self.c, self.s, self.k.ca, self.k.sa
        t1 = plus(mul(ca, u[1]), mul(sa, u[2]))
        t2 = minus(mul(ca, u[2]), mul(sa, u[1]))
        return [plus(mul(c, u[0]), mul(s, t1)), minus(mul(c, t1), mul(s, u[0])), t2]

    def value(self) -> Scalar:
        """The joint value the reference reports: for a revolute joint the closed form's
        ``(-pi, pi]`` value (or Newton's), taken into the joint's limits modulo 2 pi."""
        k = self.k
        if not k.revolute:
            assert self.q is not None
            return self.q
        raw = self.q
        if raw is None:
            raw = cs.atan2(self.s * k.ct - self.c * k.st, self.c * k.ct + self.s * k.st)
        return _wrap_into_limits(raw, k.lower, k.upper)


def _wrap_into_limits(q: Scalar, lower: float, upper: float) -> Scalar:
    """:func:`~stewart_pin.description.leg_architecture.wrap_into_limits` for one revolute
    joint value, symbolically (the limits are numbers)."""
    if not (math.isfinite(lower) or math.isfinite(upper)):
        return q
    two_pi = 2.0 * math.pi

    def mod(x: Scalar) -> Scalar:  # numpy's mod: the sign of the divisor
        m = cs.fmod(x, two_pi)
        return cs.if_else(m < 0, m + two_pi, m)

    rep = lower + mod(q - lower) if math.isfinite(lower) else upper - mod(upper - q)
    if math.isfinite(lower) and math.isfinite(upper):
        below = rep - two_pi
        rep = cs.if_else(cs.logic_and(rep > upper, lower - below < rep - upper), below, rep)
    outside = q < lower if not math.isfinite(upper) else q > upper
    if math.isfinite(lower) and math.isfinite(upper):
        outside = cs.logic_or(q < lower, q > upper)
    return cs.if_else(outside, rep, q)


def revolute(k: JointConst, c: Scalar, s: Scalar, q: Scalar | None = None) -> JointState:
    return JointState(k, c, s, k.r, q)


def prismatic(k: JointConst, q: Scalar) -> JointState:
    return JointState(k, k.ct, k.st, plus(k.r, q), q)


def _shift(c: Scalar, s: Scalar, ct: float, st: float) -> tuple[Scalar, Scalar]:
    """cos, sin of ``a - t`` from those of ``a`` and ``t``."""
    return plus(mul(c, ct), mul(s, st)), minus(mul(s, ct), mul(c, st))


# ---------------------------------------------------------------------------- geometry
@dataclass
class _LegGeometry:
    joints: list[JointState]
    P: Vec  # P_i in frame 0i
    slacks: list[Scalar]


def _pre_joint1(lc: LegConst, P0: Vec) -> Vec:
    """``(Rx(alpha1) Tx(d1))^-1 P``."""
    j1 = lc.joints[0]
    x, y, z = P0[0] - j1.d, P0[1], P0[2]
    return [x, j1.ca * y + j1.sa * z, j1.ca * z - j1.sa * y]


def _solve_u(lc: LegConst, w: Vec, slacks: list[Scalar]) -> tuple[JointState, JointState]:
    """The universal joint (joints 2, 3, intersecting axes) pointing ``tip`` at ``w``
    (frame 1 rotated by ``Rx(alpha2)``; the reference's ``_solve_u``):
    ``psi3 = atan2(b, a) - acos(k / hypot(a, b))``, ``psi2 = atan2(w_y, w_x) - atan2(v_y, v_x)``,
    as cosines and sines."""
    j2, j3 = lc.joints[1], lc.joints[2]
    t = lc.tip
    sa, ca = j3.sa, j3.ca
    a, b = sa * t[1], sa * t[0]
    kk = w[2] - ca * t[2]
    rad2 = a * a + b * b
    disc = rad2 - kk * kk
    slacks.append(disc)  # |k| < hypot(a, b): the rod reaches
    S = cs.sqrt(cs.fmax(disc, 0.0))
    c3 = (a * kk + b * S) / rad2
    s3 = (b * kk - a * S) / rad2
    vx = c3 * t[0] - s3 * t[1]
    vy = ca * (s3 * t[0] + c3 * t[1]) - sa * t[2]
    inv = 1.0 / cs.sqrt((w[0] * w[0] + w[1] * w[1]) * (vx * vx + vy * vy))
    c2 = (w[0] * vx + w[1] * vy) * inv
    s2 = (w[1] * vx - w[0] * vy) * inv
    return revolute(j2, c2, s2), revolute(j3, c3, s3)


def _inverse_geometry(lc: LegConst, P0: Vec) -> _LegGeometry:
    """The closed-form inverse geometry of a named leg, or Newton's for a custom one."""
    if lc.name == "custom":
        return _newton(lc, P0)
    j1 = lc.joints[0]
    # a number, or a lane input of the legs-as-lanes models (:mod:`.lanes`)
    b = lc.branch if isinstance(lc.branch, cs.SX) else float(lc.branch)
    slacks: list[Scalar] = []
    p = _pre_joint1(lc, P0)
    if lc.name in ("ups", "ups-offset"):
        j2 = lc.joints[1]
        pz = p[2] - j1.r
        h2 = p[0] * p[0] + p[1] * p[1]
        ih = 1.0 / cs.sqrt(h2)
        c1, s1 = b * p[0] * ih, b * p[1] * ih
        rho = b * h2 * ih - j2.d
        q3 = cs.sqrt(rho * rho + pz * pz)
        c2, s2 = -pz / q3, rho / q3
        J1 = revolute(j1, c1, s1)
        J2 = revolute(j2, c2, s2)  # theta2 = 0: the angle is q2 = atan2(rho, -p_z)
        J3 = prismatic(lc.joints[2], q3)
        return _LegGeometry([J1, J2, J3], P0, slacks)
    j2 = lc.joints[1]
    cvec = [j2.d, -(j2.sa * j2.r), j2.ca * j2.r]  # the U-joint centre in frame 1
    tip = lc.tip
    ell2 = tip[0] * tip[0] + tip[1] * tip[1] + tip[2] * tip[2]
    if lc.name == "rus":
        px, py, pz = p[0], p[1], p[2] - j1.r
        A = px * cvec[0] + py * cvec[1]
        Bq = py * cvec[0] - px * cvec[1]
        K = 0.5 * (px * px + py * py + pz * pz + dot(cvec, cvec) - ell2) - pz * cvec[2]
        R2 = A * A + Bq * Bq
        disc = R2 - K * K
        slacks.append(disc)  # |K| < R: the crank equation has a solution
        S = cs.sqrt(cs.fmax(disc, 0.0))
        c1 = (A * K + b * Bq * S) / R2
        s1 = (Bq * K - b * A * S) / R2
        J1 = revolute(j1, c1, s1)
        local = [c1 * px + s1 * py, c1 * py - s1 * px, pz]
        e = sub(local, cvec)
    elif lc.name == "pus":
        ct, st = j1.ct, j1.st
        Rc = [ct * cvec[0] - st * cvec[1], st * cvec[0] + ct * cvec[1], cvec[2] + j1.r]
        ev = sub(p, Rc)
        disc = ell2 - ev[0] * ev[0] - ev[1] * ev[1]
        slacks.append(disc)  # the rod reaches from the rail
        q1 = ev[2] - b * cs.sqrt(cs.fmax(disc, 0.0))
        J1 = prismatic(j1, q1)
        rel = [ev[0], ev[1], ev[2] - q1]
        e = [ct * rel[0] + st * rel[1], ct * rel[1] - st * rel[0], rel[2]]
    else:  # pragma: no cover - the architecture names are checked by LegArchitecture
        raise InputError(f"no closed-form inverse geometry for a '{lc.name}' leg")
    ca2, sa2 = j2.ca, j2.sa
    w = [e[0], ca2 * e[1] + sa2 * e[2], ca2 * e[2] - sa2 * e[1]]  # Rx(alpha2)^T e
    J2, J3 = _solve_u(lc, w, slacks)
    return _LegGeometry([J1, J2, J3], P0, slacks)


def _joints_at(lc: LegConst, q: Sequence[Scalar]) -> list[JointState]:
    out = []
    for k, qj in zip(lc.joints, q, strict=True):
        if k.revolute:
            out.append(revolute(k, cs.cos(k.theta + qj), cs.sin(k.theta + qj), qj))
        else:
            out.append(prismatic(k, qj))
    return out


def _newton(lc: LegConst, P0: Vec) -> _LegGeometry:
    """:data:`NEWTON_ITERATIONS` steps of the reference's Newton method
    (:func:`~stewart_pin.kinematics.leg_chains.solve_leg`) from the leg's ``guess``; the
    slack ``tol^2 - |P - P(q)|^2`` flags a state that has not converged."""
    q: list[Scalar] = list(lc.guess)
    if lc.inline_newton:
        for _ in range(NEWTON_ITERATIONS):
            q = _newton_step(lc, q, P0)
    else:  # calls of one step function: a C source NEWTON_ITERATIONS times shorter
        step = _newton_step_function(lc)
        P = column(P0)
        for _ in range(NEWTON_ITERATIONS):
            q = split(step(column(q), P))
    joints = _joints_at(lc, q)
    _, _, tip = _chain(joints, lc.tip)
    err = sub(P0, tip)
    tol = LEG_TOLERANCE * (1.0 - 1e-6)
    return _LegGeometry(joints, tip, [tol * tol - dot(err, err)])


def _newton_step(lc: LegConst, q: Sequence[Scalar], P0: Vec) -> list[Scalar]:
    """``q + J(q)^-1 (P - P(q))``."""
    joints = _joints_at(lc, q)
    z, O, tip = _chain(joints, lc.tip)
    err = sub(P0, tip)
    cols = [_column_of(J, z[j], O[j], tip) for j, J in enumerate(joints)]
    inv_rows, _ = _inverse3(cols)
    return [plus(q[j], dot(inv_rows[j], err)) for j in range(3)]


@functools.lru_cache(maxsize=64)
def _newton_step_function(lc: LegConst) -> cs.Function:
    """One Newton step of leg ``lc`` as a function called (never inlined) by the models."""
    q, P = cs.SX.sym("q", 3), cs.SX.sym("P", 3)
    step = _newton_step(lc, split(q), split(P))
    return cs.Function(
        f"newton_leg{lc.index + 1}",
        [q, P],
        [column(step)],
        ["q", "P"],
        ["q_next"],
        {"never_inline": True},
    )


# ---------------------------------------------------------------------------- kinematics
def _chain(joints: Sequence[JointState], tip: Sequence[float]) -> tuple[list, list, Vec]:
    """Axes ``z_j`` and origins ``O_j`` of the three joint frames in frame 0i, and the tip
    position by forward kinematics."""
    z, O = [], []
    origin: Vec = [0.0, 0.0, 0.0]
    for j, J in enumerate(joints):
        zj, pj = J.axis(), J.origin()
        for m in reversed(range(j)):
            zj, pj = joints[m].to_parent(zj), joints[m].to_parent(pj)
        origin = add(origin, pj)
        z.append(zj)
        O.append(origin)
    t = list(tip)
    for m in reversed(range(3)):
        t = joints[m].to_parent(t)
    return z, O, add(O[2], t)


def _column_of(J: JointState, z: Vec, O: Vec, P: Vec) -> Vec:
    return cross(z, sub(P, O)) if J.k.revolute else z


def _inverse3(cols: Sequence[Vec]) -> tuple[list[Vec], Scalar]:
    """Rows of the inverse of the matrix with columns ``cols`` (adjugate / det), and det."""
    r0, r1, r2 = cross(cols[1], cols[2]), cross(cols[2], cols[0]), cross(cols[0], cols[1])
    det = dot(cols[0], r0)
    inv = 1.0 / det
    return [scaled(r0, inv), scaled(r1, inv), scaled(r2, inv)], det


def _matvec_rows(rows: Sequence[Vec], v: Vec) -> Vec:
    return [dot(r, v) for r in rows]


def _rows_T_vec(rows: Sequence[Vec], v: Vec) -> Vec:
    """``M^T v`` for M given by its rows."""
    return [lin_comb((rows[0][i], v[0]), (rows[1][i], v[1]), (rows[2][i], v[2])) for i in range(3)]


def _drift(joints: Sequence[JointState], z: list, O: list, P: Vec, qd: Vec) -> Vec:
    """``Jdot_i qdot_i`` in frame 0i (the reference's :func:`leg_drift`)."""
    zero: Vec = [0.0, 0.0, 0.0]
    w, wd, acc, prev = zero, zero, zero, zero
    for j, J in enumerate(joints):
        r = sub(O[j], prev)
        acc = add(acc, add(cross(wd, r), cross(w, cross(w, r))))
        if J.k.revolute:
            wd = add(wd, scaled(cross(w, z[j]), qd[j]))
            w = add(w, scaled(z[j], qd[j]))
        else:
            acc = add(acc, scaled(cross(w, z[j]), 2.0 * qd[j]))
        prev = O[j]
    r = sub(P, prev)
    return add(acc, add(cross(wd, r), cross(w, cross(w, r))))


# ---------------------------------------------------------------------------- dynamics
def newton_euler(
    joints: Sequence[JointState],
    qd: Sequence[Scalar],
    qdd: Sequence[Scalar],
    base_acc: Vec,
    gravity: Vec | None = None,
) -> list[Scalar]:
    """Joint efforts of the chain (Khalil's recursive Newton-Euler in the link frames):
    ``qd``, ``qdd`` the joint rates and accelerations, ``base_acc`` the acceleration of
    frame 0i's origin in frame 0i (``-g`` for gravity); nothing acts at the tip.
    ``gravity``: ``g`` in frame 0i when ``base_acc`` holds it and some link has a gravity
    compensation ``c`` (its weight ``(1 - c) m g``): the force ``-c m g`` at its centre of
    mass, i.e. ``c M g`` and ``c MS x g`` (in its frame) added to its Newton-Euler terms."""
    zero: Vec = [0.0, 0.0, 0.0]
    w, wd, vd = zero, zero, list(base_acc)
    g: Vec | None = None
    if gravity is not None and any(J.k.gravcomp for J in joints):
        g = list(gravity)
    forces = []
    for j, J in enumerate(joints):
        p = J.origin()
        vd_par = add(vd, add(cross(wd, p), cross(w, cross(w, p))))
        vd, w_in, wd = J.to_child(vd_par), J.to_child(w), J.to_child(wd)
        if g is not None:
            g = J.to_child(g)
        if J.k.revolute:
            wd = [
                plus(wd[0], mul(qd[j], w_in[1])),
                minus(wd[1], mul(qd[j], w_in[0])),
                plus(wd[2], qdd[j]),
            ]
            w = [w_in[0], w_in[1], plus(w_in[2], qd[j])]
        else:
            two = mul(2.0, qd[j])
            vd = [
                plus(vd[0], mul(two, w_in[1])),
                minus(vd[1], mul(two, w_in[0])),
                plus(vd[2], qdd[j]),
            ]
            w = w_in
        XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = J.k.inertia
        MS: Vec = [MX, MY, MZ]
        inertia = [[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]]
        F = add(add(scaled(vd, M), cross(wd, MS)), cross(w, cross(w, MS)))
        Iw = [dot(row, w) for row in inertia]
        N = add(add([dot(row, wd) for row in inertia], cross(w, Iw)), cross(MS, vd))
        c = J.k.gravcomp
        if g is not None and c:
            F = add(F, scaled(g, c * M))
            N = add(N, cross([c * x for x in MS], g))
        forces.append((F, N))
    f, n = forces[-1]
    tau: list[Scalar] = [0.0] * len(joints)
    tau[-1] = n[2] if joints[-1].k.revolute else f[2]
    for j in reversed(range(len(joints) - 1)):
        child = joints[j + 1]
        fc, nc = child.to_parent(f), child.to_parent(n)
        F, N = forces[j]
        f = add(F, fc)
        n = add(add(N, nc), cross(child.origin(), fc))
        tau[j] = n[2] if joints[j].k.revolute else f[2]
    return tau


def joint_terms(
    joints: Sequence[JointState], qd: Sequence[Scalar], qdd: Sequence[Scalar]
) -> list[Scalar]:
    """``Ia qdd + (Fv + D) qd + Fc sign(qd) + K (q - q0)`` per joint (zero terms fold; a
    coefficient may be a symbol: the legs-as-lanes models of :mod:`.lanes`)."""
    out: list[Scalar] = []
    for j, J in enumerate(joints):
        k = J.k
        t: Scalar = 0.0
        if not is_zero(k.armature):
            t = plus(t, mul(k.armature, qdd[j]))
        if not is_zero(k.viscous):
            t = plus(t, mul(k.viscous, qd[j]))
        if not is_zero(k.coulomb) and not isinstance(qd[j], (int, float)):
            if k.coulomb_smoothing > 0.0:  # the planner's smooth model
                sign = cs.tanh(qd[j] / k.coulomb_smoothing)
            else:
                sign = cs.if_else(cs.fabs(qd[j]) > COULOMB_DEAD_BAND, cs.sign(qd[j]), 0.0)
            t = plus(t, mul(k.coulomb, sign))
        if not is_zero(k.stiffness):
            t = plus(t, mul(k.stiffness, minus(J.value(), k.rest)))
        out.append(t)
    return out


def mass_matrix(joints: Sequence[JointState]) -> list[list[Scalar]]:
    """The chain's n x n joint-space inertia (armature on the diagonal), column m from the
    efforts of a unit ``qdd_m`` without velocity or gravity."""
    n = len(joints)
    M: list[list[Scalar]] = [[0.0] * n for _ in range(n)]
    zero = [0.0] * n
    for m in range(n):
        e = [1.0 if i == m else 0.0 for i in range(n)]
        tau = newton_euler(joints, zero, e, [0.0, 0.0, 0.0])
        for i in range(m + 1):
            M[i][m] = M[m][i] = tau[i]
        M[m][m] = plus(M[m][m], joints[m].k.armature)
    return M


# ---------------------------------------------------------------------------- one leg
def _rotate(R: Sequence[Sequence[float]], u: Vec) -> Vec:
    return [lin_comb((R[i][0], u[0]), (R[i][1], u[1]), (R[i][2], u[2])) for i in range(3)]


def _rotate_T(R: Sequence[Sequence[float]], u: Vec) -> Vec:
    return [lin_comb((R[0][i], u[0]), (R[1][i], u[1]), (R[2][i], u[2])) for i in range(3)]


@dataclass
class _LegKinematics:
    geo: _LegGeometry
    L: Vec  # O_p -> P_i in F0
    inv_rows: list[Vec]  # J_i^-1 in frame 0i, by rows
    z: list
    O: list
    qd: Vec
    row: list[Scalar]  # row i of Jp^-1 (F0)
    slacks: list[Scalar]


def leg_kinematics(lc: LegConst, p: Vec, R: Mat, v: Vec, w: Vec) -> _LegKinematics:
    """Inverse geometry, ``J_i^-1``, the guard's slacks, ``qdot`` and the Jp^-1 row."""
    L = _rotate(R, list(lc.pL))
    P0 = _rotate_T(lc.R, [plus(minus(p[i], lc.B[i]), L[i]) for i in range(3)])
    geo = _inverse_geometry(lc, P0)
    joints = geo.joints
    z, O, _ = _chain(joints, lc.tip)
    P = geo.P
    cols = [_column_of(J, z[j], O[j], P) for j, J in enumerate(joints)]
    inv_rows, det = _inverse3(cols)
    slacks = list(geo.slacks) + _serial_slacks(lc, joints, cols, O, P, det)
    slacks += limit_slacks(lc.radius, joints)
    V0 = _rotate_T(lc.R, add(v, cross(w, L)))
    qd = _matvec_rows(inv_rows, V0)
    m = _rotate(lc.R, inv_rows[lc.actuated])
    return _LegKinematics(geo, L, inv_rows, z, O, qd, [*m, *cross(L, m)], slacks)


def _serial_slacks(
    lc: LegConst, joints: Sequence[JointState], cols: list, O: list, P: Vec, det: Scalar
) -> list[Scalar]:
    """The reference's serial-singularity refusals as slacks: each revolute lever
    ``l_j = |P_i - O_j|`` longer than ``LEG_MIN_LENGTH_RATIO`` of the platform radius, and
    the lower bound ``|det S| / sqrt(c2) <= sigma_min(S)`` of the scaled leg Jacobian
    ``S = J_i diag(1 / l)`` (``l_j = 1`` for a prismatic joint) above ``LEG_SINGULARITY``,
    where ``c2 = sum_{i<j} |s_i x s_j|^2 >= (sigma_1 sigma_2)^2`` is the sum of the 2x2
    principal minors of ``S^T S``; squared, with the denominators cleared:
    ``det(J)^2 > tau^2 sum_k |c_i x c_j|^2 l_k^2`` (``(i, j, k)`` a cyclic order; the cross
    products are the adjugate's rows)."""
    out: list[Scalar] = []
    lever2: list[Scalar] = []
    for j, J in enumerate(joints):
        if J.k.revolute:
            r = sub(P, O[j])
            l2 = dot(r, r)
            lever2.append(l2)
            out.append(l2 - (LEG_MIN_LENGTH_RATIO * lc.radius) ** 2 * (1.0 + _MARGIN_SERIAL))
        else:
            lever2.append(1.0)
    minors: Scalar = 0.0
    for k in range(3):
        adj = cross(cols[(k + 1) % 3], cols[(k + 2) % 3])
        minors = plus(minors, mul(dot(adj, adj), lever2[k]))
    tau = LEG_SINGULARITY * (1.0 + _MARGIN_SERIAL)
    out.append(det * det - tau * tau * minors)
    return out


def limit_slacks(radius: float, joints: Sequence[JointState]) -> list[Scalar]:
    """Joint limits with margins (``radius`` [m] the prismatic margins' scale): prismatic
    values against their limits, revolute angles
    by ``cos(q - mid) > cos(half range)`` (the reference takes a revolute value modulo
    2 pi into its limits: only a range shorter than 2 pi can refuse one)."""
    out: list[Scalar] = []
    for J in joints:
        k = J.k
        lo, hi = k.lower, k.upper
        if not k.revolute:
            assert J.q is not None
            scale = max(radius, *(abs(x) for x in (lo, hi) if math.isfinite(x)), 1e-300)
            if math.isfinite(lo):
                out.append(J.q - lo - _MARGIN_LIMIT * scale)
            if math.isfinite(hi):
                out.append(hi - J.q - _MARGIN_LIMIT * scale)
        elif math.isfinite(lo) and math.isfinite(hi) and hi - lo < 2.0 * math.pi:
            mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
            beta = k.theta + mid
            cq, _ = _shift(J.c, J.s, math.cos(beta), math.sin(beta))
            out.append(cq - math.cos(half) - _MARGIN_REVOLUTE_LIMIT)
    return out


def _leg_torques(lc: LegConst, kin: _LegKinematics, A_P: Vec) -> tuple[list[Scalar], Vec]:
    """The leg's joint efforts ``H_i`` (joint terms included) with the tip accelerating at
    ``A_P`` (F0, classical); also ``qddot``."""
    joints = kin.geo.joints
    A0 = _rotate_T(lc.R, A_P)
    drift = _drift(joints, kin.z, kin.O, kin.geo.P, kin.qd)
    qdd = _matvec_rows(kin.inv_rows, sub(A0, drift))
    g = lc.gravity
    tau = newton_euler(joints, kin.qd, qdd, [-g[0], -g[1], -g[2]], list(g))
    terms = joint_terms(joints, kin.qd, qdd)
    return [tau[j] + terms[j] for j in range(3)], qdd


def idm_leg_outputs(
    lc: LegConst, p: Vec, R: Mat, v: Vec, w: Vec, vd: Vec, K: Mat
) -> dict[str, Any]:
    kin = leg_kinematics(lc, p, R, v, w)
    A_P = add(vd, [dot(K[i], kin.L) for i in range(3)])
    H, _ = _leg_torques(lc, kin, A_P)
    a = lc.actuated
    Hp = [0.0 if j == a else H[j] for j in range(3)]
    f = _rotate(lc.R, _rows_T_vec(kin.inv_rows, Hp))
    return {
        "row": kin.row,
        "wrench": [*f, *cross(kin.L, f)],
        "Hz": [H[a]],
        "slack": kin.slacks,
        "residual": 1 if lc.name == "custom" else 0,  # _newton's slack: the first
    }


_UPPER6 = [(i, j) for i in range(6) for j in range(i, 6)]


def leg_block(A0: Mat, L: Vec) -> list[Scalar]:
    """The upper triangle (21) of ``G^T A_x G``, ``G = [I3, -L^]``."""
    nL = [mul(-1.0, x) for x in L]
    Lh = [[0.0, nL[2], L[1]], [L[2], 0.0, nL[0]], [nL[1], L[0], 0.0]]
    TR = [
        [mul(-1.0, lin_comb(*((A0[i][m], Lh[m][j]) for m in range(3)))) for j in range(3)]
        for i in range(3)
    ]
    block: list[list[Scalar]] = [[0.0] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(3):
            block[i][j] = A0[i][j]
            block[i][3 + j] = TR[i][j]
    for i in range(3):
        for j in range(i, 3):
            block[3 + i][3 + j] = lin_comb(*((Lh[i][m], TR[m][j]) for m in range(3)))
    return [block[i][j] for i, j in _UPPER6]


def ddm_leg_outputs(
    lc: LegConst, p: Vec, R: Mat, v: Vec, w: Vec, gamma_k: Scalar
) -> dict[str, list[Scalar]]:
    kin = leg_kinematics(lc, p, R, v, w)
    joints = kin.geo.joints
    # The leg's share of h_robot (general-legs.md): G^T (A_x (w x (w x L) - Jdot qdot) +
    # J^-T h), h the nonlinear effects (gravity, velocity, joint terms) at zero qddot.
    g = lc.gravity
    zero3: Vec = [0.0, 0.0, 0.0]
    h = newton_euler(joints, kin.qd, zero3, [-g[0], -g[1], -g[2]], list(g))
    terms = joint_terms(joints, kin.qd, zero3)
    h = [plus(h[j], terms[j]) for j in range(3)]
    drift = _rotate(lc.R, _drift(joints, kin.z, kin.O, kin.geo.P, kin.qd))
    c = sub(cross(w, cross(w, kin.L)), drift)
    Mq = mass_matrix(joints)
    # B = J_i^-1 R_i^T (J^-1 in F0); A_x = B^T M B.
    Bm = [_rotate(lc.R, row) for row in kin.inv_rows]  # rows of B
    MB = [
        [lin_comb(*((Mq[i][m], Bm[m][c]) for m in range(3))) for c in range(3)] for i in range(3)
    ]
    A0: Mat = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            A0[i][j] = A0[j][i] = lin_comb(*((Bm[m][i], MB[m][j]) for m in range(3)))
    a = lc.actuated
    rhs = [(gamma_k if j == a else 0.0) - h[j] for j in range(3)]
    f = sub(_rotate(lc.R, _rows_T_vec(kin.inv_rows, rhs)), [dot(row, c) for row in A0])
    return {
        "row": kin.row,
        "block": leg_block(A0, kin.L),
        "wrench": [*f, *cross(kin.L, f)],
        "slack": kin.slacks,
    }


# ---------------------------------------------------------------------------- assembly
def _idm_leg_stage(lc: LegConst, p: Vec, R: Mat, t: list, a: list, K: Mat) -> dict:
    return idm_leg_outputs(lc, p, R, t[:3], t[3:], a[:3], K)


def _ddm_leg_stage(lc: LegConst, p: Vec, R: Mat, t: list, gamma_k: Scalar) -> dict:
    return ddm_leg_outputs(lc, p, R, t[:3], t[3:], gamma_k)


#: Entries of a leg's outputs that describe them rather than being outputs: how many of
#: its slacks are Newton residuals (``"residual"``), the idle models' spin terms
#: (``"sigma"``, ``"sigma_of"``, read by the chain legs' idle generator).
LEG_METADATA = ("residual", "sigma", "sigma_of")


def leg_stage_outputs(outputs: dict[str, Any]) -> dict[str, Any]:
    """A leg's outputs as a stage function's (lists of scalars): without
    :data:`LEG_METADATA`."""
    return {k: v for k, v in outputs.items() if k not in LEG_METADATA}


def _stages(
    legs: Sequence[Any],
    pose: str,
    Pp: list[float],
    gravity: np.ndarray,
    pivots: Sequence[tuple[int, int]],
    idm_leg: Callable[..., dict] = _idm_leg_stage,
    ddm_leg: Callable[..., dict] = _ddm_leg_stage,
) -> tuple[Stages, Stages]:
    """The IDM and DDM split for parallel evaluation (fresh symbols at each interface; for
    the operation counts): the shared prelude, six legs, the platform, the closure.
    ``idm_leg(lc, p, R, twist, accel, K)`` and ``ddm_leg(lc, p, R, twist, gamma_k)`` give a
    leg's outputs (``legs``: their constants, each with its ``index``; the chain legs'
    generator passes its own)."""
    npose = pose_size(pose)

    def pose_of(ps: Sequence[Scalar]) -> tuple[Vec, Mat]:
        return pose_from_input(column(ps), pose)

    idm_closure_stage, ddm_closure_stage = closure_stages(pivots)
    idm_stages = Stages(
        shared=idm_shared_stage(gravity),
        legs=tuple(
            stage_function(
                f"idm_leg{lc.index + 1}",
                [("pose", npose), ("twist", 6), ("accel", 6), ("K", 9)],
                lambda ps, t, a, Kf, lc=lc: leg_stage_outputs(
                    idm_leg(lc, *pose_of(ps), t, a, mat3(Kf))
                ),
            )
            for lc in legs
        ),
        platform=stage_function(
            "idm_platform",
            [("pose", npose), ("twist", 6), ("accel", 6), ("K", 9), ("vdg", 3)],
            lambda ps, t, a, Kf, vg: {
                "F_p": idm_platform(pose_of(ps)[1], t[3:], a[3:], vg, mat3(Kf), Pp)
            },
        ),
        closure=idm_closure_stage,
    )
    ddm_stages = Stages(
        shared=None,
        legs=tuple(
            stage_function(
                f"ddm_leg{lc.index + 1}",
                [("pose", npose), ("twist", 6), ("gamma", 1)],
                lambda ps, t, gk, lc=lc: leg_stage_outputs(ddm_leg(lc, *pose_of(ps), t, gk[0])),
            )
            for lc in legs
        ),
        platform=stage_function(
            "ddm_platform",
            [("pose", npose), ("twist", 6)],
            lambda ps, t: dict(
                zip(("Ip", "hp"), ddm_platform(pose_of(ps)[1], t[3:], Pp, gravity), strict=True)
            ),
        ),
        closure=ddm_closure_stage,
    )
    return idm_stages, ddm_stages


def aux_layout(models: SymbolicModels) -> AuxLayout:
    """The :class:`AuxLayout` of general-leg models (their number of slacks and the Newton
    residuals among them)."""
    return AuxLayout(
        n_slack=models.idm_guarded.size1_out(1) - AuxLayout().idm_slack,
        residual=models.residual_slacks,
    )


def residual_slacks(legs: Sequence[dict[str, Any]]) -> tuple[tuple[int, int], ...]:
    """The Newton residuals among the slacks of the IDM's six legs (``legs`` in leg order,
    each with its ``"slack"`` list and, first in it, ``"residual"`` of them): their offsets
    from the first slack, each with its leg (1..6)."""
    out: list[tuple[int, int]] = []
    at = 0
    for k, lg in enumerate(legs):
        out += [(at + j, k + 1) for j in range(lg.get("residual", 0))]
        at += len(lg["slack"])
    return tuple(out)


def general_robot(desc: RobotDescription | GeneralHexapod) -> GeneralHexapod:
    """The :class:`GeneralHexapod` of a description (or the robot itself)."""
    return desc if isinstance(desc, GeneralHexapod) else general_from_description(desc)


def build_general_models(
    desc: RobotDescription | GeneralHexapod,
    pose: str = "matrix",
    prefix: str = "stewart_",
    stages: bool = False,
    inline_newton: bool = False,
    coulomb_smoothing: float = 0.0,
) -> tuple[SymbolicModels, AuxLayout]:
    """The IDM and DDM of a robot with general legs (or an ideal 6-UPS robot taken as
    ``ups`` legs), as :class:`SymbolicModels` (``parameters="numeric"``, an empty
    ``base_parameters`` input), with the layout of their ``aux`` output. ``stages``: also
    split them for the operation counts (:attr:`SymbolicModels.idm_stages`; ``None``
    without: they take as long again to generate). ``inline_newton``: a custom leg's
    Newton steps written out (for the operation counts) rather than called.
    ``coulomb_smoothing`` > 0 (``eps`` [m/s for a prismatic joint, rad/s for a revolute
    one]): every joint's Coulomb term ``Fc sign(qd)`` becomes ``Fc tanh(qd / eps)``, a
    smooth model for optimisers (:mod:`stewart_pin.planning.point_to_point`); 0: the
    exact model."""
    robot = general_robot(desc)
    legs = [leg_constants(robot, k, inline_newton, coulomb_smoothing) for k in range(6)]
    home_rows = leg_chains.inverse_jacobian_batch(robot, robot.home_pose[None])[0]
    return assemble_models(robot, legs, home_rows, robot.size, pose, prefix, stages)


def idm_closure_and_aux(
    ilegs: Sequence[dict[str, Any]],
    F_p: list[Scalar],
    home_rows: np.ndarray,
    inv_l: float,
    pivots: Sequence[tuple[int, int]] | None = None,
) -> tuple[list[Scalar], list[Scalar], AuxLayout, tuple[tuple[int, int], ...]]:
    """The IDM's closure from the six legs' outputs (``row``, ``wrench``, ``Hz``,
    ``slack``, in leg order) and the platform's wrench ``F_p``, with the static pivots of
    ``home_rows`` (6, 6) ``Jp^-1`` at home: ``(gamma, aux, layout, pivots)``, ``aux`` the
    guard's inputs of :class:`AuxLayout` (``Jp^-1`` row-major, ``F``, ``Hz``, the pivot
    growth, det and squared Frobenius norm of ``Jp^-1`` scaled by ``inv_l`` = 1 / the
    singularity measure's length [1/m], the legs' slacks). Shared by the three-joint and the
    chain-leg generators (the idle models too). ``pivots``: given (the legs-as-lanes
    closure of :mod:`.lanes`, whose rows are inputs: the robot's models' pivots), else
    chosen from ``home_rows`` and the rows' structural zeros."""
    rows = [lg["row"] for lg in ilegs]
    if pivots is None:
        nonzero = np.array([[not is_zero(rows[i][c]) for i in range(6)] for c in range(6)])
        pivots = pivot_order(home_rows.T, nonzero)
    pivots = tuple(pivots)
    Hz = [lg["Hz"][0] for lg in ilegs]
    gamma, growth, F, det = idm_closure(rows, [lg["wrench"] for lg in ilegs], Hz, F_p, pivots)
    fro2: Scalar = 0.0
    for r in rows:
        for j in range(3):
            fro2 = fro2 + r[j] * r[j] + r[3 + j] * r[3 + j] * (inv_l * inv_l)
    det = det * inv_l**3
    slacks = [s for lg in ilegs for s in lg["slack"]]
    layout = AuxLayout(n_slack=len(slacks), residual=residual_slacks(ilegs))
    aux = [*[x for r in rows for x in r], *F, *Hz, growth, det, fro2, *slacks]
    return gamma, aux, layout, pivots


def assemble_models(
    robot: Any,
    legs: Sequence[Any],
    home_rows: np.ndarray,
    size: float,
    pose: str,
    prefix: str,
    stages: bool,
    idm_leg: Callable[..., dict] = _idm_leg_stage,
    ddm_leg: Callable[..., dict] = _ddm_leg_stage,
) -> tuple[SymbolicModels, AuxLayout]:
    """The models from six legs' outputs: ``idm_leg(lc, p, R, twist, accel, K)`` (``row``,
    ``wrench``, ``Hz``, ``slack``) and ``ddm_leg(lc, p, R, twist, gamma_k)`` (``row``,
    ``block``, ``wrench``, ``slack``) of each of ``legs``, the platform's Newton-Euler and
    the closures; ``robot`` gives the geometry, platform inertia and gravity,
    ``home_rows`` (6, 6) ``Jp^-1`` at the home pose (the static pivots), ``size`` [m] the
    singularity measure's length (shared by the three-joint and the chain-leg generators)."""
    Pp = [float(x) for x in robot.platform_inertia]
    gravity = np.asarray(robot.gravity, dtype=float)
    # the platform's weight less its gravity compensation (the legs' in leg_constants)
    g_platform = (1.0 - robot.platform_gravcomp) * gravity
    npose = pose_size(pose)
    x_pose = cs.SX.sym("pose", npose)
    x_twist = cs.SX.sym("twist", 6)
    x_accel = cs.SX.sym("accel", 6)
    x_gamma = cs.SX.sym("gamma", 6)
    x_chi = cs.SX.sym("base_parameters", 0)
    p, R = pose_from_input(x_pose, pose)
    tw, ac, gm = split(x_twist), split(x_accel), split(x_gamma)
    w, wd = tw[3:], ac[3:]
    inv_l = 1.0 / size

    # ---- IDM
    K, vdg = idm_shared(tw, ac, g_platform)
    ilegs = [idm_leg(lc, p, R, tw, ac, K) for lc in legs]
    F_p = idm_platform(R, w, wd, vdg, K, Pp)
    gamma, idm_aux, layout, pivots = idm_closure_and_aux(ilegs, F_p, home_rows, inv_l)

    # ---- DDM
    dlegs = [ddm_leg(lc, p, R, tw, gm[k]) for k, lc in enumerate(legs)]
    Ip, hp = ddm_platform(R, w, Pp, g_platform)
    accel, D = ddm_legs_closure(dlegs, Ip, hp)
    dslacks = [s for lg in dlegs for s in lg["slack"]]
    assert len(dslacks) == layout.n_slack  # the same leg code: the same slacks
    djinv = [x for lg in dlegs for x in lg["row"]]
    inputs = {
        "pose": x_pose,
        "twist": x_twist,
        "accel": x_accel,
        "gamma": x_gamma,
        "base_parameters": x_chi,
    }
    idm, ddm, idm_guarded, ddm_guarded = model_functions(
        prefix, inputs, gamma, idm_aux, accel, [*djinv, *D, *dslacks]
    )

    idm_stages, ddm_stages = (
        _stages(legs, pose, Pp, g_platform, pivots, idm_leg, ddm_leg) if stages else (None, None)
    )
    constants = ModelConstants(
        base_points=np.array(robot.base_points),
        platform_points=np.array(robot.platform_points),
        leg_base_rotations=np.array(robot.leg_base_rotations),
        gravity=gravity.copy(),
        parameter_names=(),
        parameter_values=np.zeros(0),
    )
    models = SymbolicModels(
        idm,
        ddm,
        idm_guarded,
        ddm_guarded,
        idm_stages,
        ddm_stages,
        pose,
        "numeric",
        constants,
        pivots,
        layout.residual,
    )
    return models, layout


def actuator_function(desc: RobotDescription | GeneralHexapod) -> cs.Function:
    """``actuators(pose, twist) -> (q_a, qdot_a)``: the six actuated joint values (6,)
    [m or rad, as the reference reports them: a revolute one taken into its limits] and
    their rates (6,) [m/s or rad/s] at a platform state (pose 0Tp row-major (16), twist
    ``[v, w]`` in F0), from the generated models' leg code (the closed forms; a custom
    leg's Newton steps called). An SX function: its derivatives are CasADi's."""
    robot = general_robot(desc)

    def actuated(k: int, p: Vec, R: Mat, tw: list) -> tuple[Scalar, Scalar]:
        lc = leg_constants(robot, k, inline_newton=False)
        kin = leg_kinematics(lc, p, R, tw[:3], tw[3:])
        return kin.geo.joints[lc.actuated].value(), kin.qd[lc.actuated]

    return actuators_of(actuated)


def actuators_of(actuated: Callable[[int, Vec, Mat, list], tuple[Scalar, Scalar]]) -> cs.Function:
    """``actuators(pose, twist) -> (q_a, qdot_a)`` from ``actuated(k, p, R, twist)``, leg
    k's actuated joint value and rate (pose 0Tp row-major (16), twist ``[v, w]`` in F0)."""
    x_pose = cs.SX.sym("pose", pose_size("matrix"))
    x_twist = cs.SX.sym("twist", 6)
    p, R = pose_from_input(x_pose, "matrix")
    tw = split(x_twist)
    q_a, qd_a = zip(*(actuated(k, p, R, tw) for k in range(6)), strict=True)
    return cs.Function(
        "actuators",
        [x_pose, x_twist],
        [cs.vertcat(*q_a), cs.vertcat(*qd_a)],
        ["pose", "twist"],
        ["q_a", "qdot_a"],
    )


__all__ = [
    "GENERAL_GENERATOR_VERSION",
    "NEWTON_ITERATIONS",
    "AuxLayout",
    "actuator_function",
    "actuators_of",
    "assemble_models",
    "aux_layout",
    "build_general_models",
    "general_robot",
    "joint_constants",
]
