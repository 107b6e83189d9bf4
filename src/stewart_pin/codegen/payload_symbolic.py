"""The coupled models of a hexapod carrying a payload, as CasADi SX functions (issue 24).

The payload (:class:`~stewart_pin.models.payload.Payload`: a fixed-base Pinocchio model
mounted at ``T_p_b`` in ``Fp``) gets a generic Newton-Euler written here over its
Pinocchio model: every number of it (joint placements, inertias, armatures, axes) baked
in, its joints revolute or prismatic about any axis (Pinocchio's ``RX``, ``RY``, ``RZ``,
``RevoluteUnaligned``, the unbounded ``RUBX``... taking ``(cos, sin)``, ``PX``, ``PY``,
``PZ``, ``PrismaticUnaligned``); any other joint raises :class:`PayloadError`. The base
is the platform frame ``Fp`` (the mount folded into the first placements and the welded
links' inertia), moving with the platform's pose ``(R, p)``, twist ``V = [v, w]`` (F0,
about O_p) and classical acceleration ``A`` (F0): its spatial velocity and acceleration in
``Fp`` (gravity ``g`` of F0 included as a base acceleration) are

    nu_p = [R^T v; R^T w],   a_p = [R^T (dv/dt - g) - (R^T w) x (R^T v); R^T dw/dt],

the conventions of :mod:`stewart_pin.dynamics.payload` (Pinocchio's free-flyer RNEA on the
payload, whose first six rows are the wrench the platform applies to the payload):

- :func:`arm_rnea`: the wrench ``W`` (F0, about O_p) the platform applies to the payload
  and its joint torques ``tau`` (armature included);
- :func:`arm_crba`: the payload's blocks of the coupled mass matrix in the platform's
  coordinates (classical acceleration in F0): ``K_ff = X^T M_ff X`` (its composite
  inertia at O_p, axes of F0), ``K_fj = X^T M_fj``, ``M_jj`` (composite-rigid-body
  algorithm, armature included).

:func:`payload_models` combines them with the hexapod's generated closed form
(:mod:`.symbolic` for the 6-UPS, :mod:`.leg_chain_symbolic` for general legs; the
hexapod's functions are called on the symbols, so their expressions are inlined):

- ``idm``: ``(pose, twist, accel, q, qd, qdd) -> ([Gamma; tau], aux)``, with
  ``Gamma = H_z + Jp^T (F + W)`` (the hexapod's closure with ``W`` added to the wrench it
  maps; ``aux``: the hexapod IDM's by-products, that wrench ``F + W`` in place of ``F``);
- ``ddm``: ``(pose, twist, gamma, q, qd, tau) -> ([A; qdd], aux)``, the coupled mass
  matrix ``[[A_robot + K_ff, K_fj], [K_fj^T, M_jj]]`` solved by ``L D L^T``;
- ``pddm``: ``(pose, twist, gamma, q, qd, qdd) -> ([A; tau], aux)`` (the joints' motion
  prescribed): ``(A_robot + K_ff) A = Jp^-T Gamma - h_robot - W(0, qdd)``, then
  ``tau = tau(0, qdd) + K_fj^T A``.

The DDMs' ``aux`` is the hexapod DDM's layout (:class:`~.leg_chain_symbolic.AuxLayout`)
with the first six ``L D L^T`` pivots in its ``D`` slot, followed by the others (``nv``
for ``ddm``, none for ``pddm``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as cs
import numpy as np
import pinocchio as pin

from stewart_pin.codegen._sx_common import (
    UPPER6,
    Mat,
    Scalar,
    Vec,
    function,
    idm_closure,
    ldlt_solve,
    pose_from_input,
    split,
)
from stewart_pin.codegen.leg_chain_symbolic import (
    AuxLayout,
    build_general_models,
    mul,
)
from stewart_pin.codegen.leg_chain_symbolic import (
    minus as _sub,  # the folding arithmetic of the general-leg generator
)
from stewart_pin.codegen.leg_chain_symbolic import (
    plus as _add,
)
from stewart_pin.codegen.symbolic import generate_models
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import PayloadError
from stewart_pin.models.payload import Payload

__all__ = [
    "PAYLOAD_GENERATOR_VERSION",
    "ArmJoint",
    "PayloadModels",
    "arm_crba",
    "arm_joints",
    "arm_rnea",
    "payload_identity",
    "payload_models",
]

#: The payload generator's version (its source is in the cache key's digest too).
PAYLOAD_GENERATOR_VERSION = "1"

#: Constants of the payload within this distance of 0 or +-1 (rotations, unit axes) are
#: snapped to it, so that the zeros and ones of a URDF's frames propagate.
SNAP = 1e-14

#: Pinocchio's joints taken here: kind (``"R"`` revolute, ``"U"`` unbounded revolute with
#: ``(cos, sin)``, ``"P"`` prismatic) and the axis (None: the joint's own ``axis``).
_JOINTS: dict[str, tuple[str, tuple[float, float, float] | None]] = {
    "JointModelRX": ("R", (1.0, 0.0, 0.0)),
    "JointModelRY": ("R", (0.0, 1.0, 0.0)),
    "JointModelRZ": ("R", (0.0, 0.0, 1.0)),
    "JointModelRevoluteUnaligned": ("R", None),
    "JointModelRUBX": ("U", (1.0, 0.0, 0.0)),
    "JointModelRUBY": ("U", (0.0, 1.0, 0.0)),
    "JointModelRUBZ": ("U", (0.0, 0.0, 1.0)),
    "JointModelRevoluteUnboundedUnaligned": ("U", None),
    "JointModelPX": ("P", (1.0, 0.0, 0.0)),
    "JointModelPY": ("P", (0.0, 1.0, 0.0)),
    "JointModelPZ": ("P", (0.0, 0.0, 1.0)),
    "JointModelPrismaticUnaligned": ("P", None),
}


def _snap(x: float) -> float:
    if abs(x) <= SNAP:
        return 0.0
    if abs(abs(x) - 1.0) <= SNAP:
        return math.copysign(1.0, x)
    return float(x) + 0.0


@dataclass(frozen=True)
class ArmJoint:
    """One joint of the payload, its numbers as baked in.

    Attributes:
        name: Pinocchio's joint name. kind: ``"R"``, ``"U"`` (revolute, configuration
            ``(cos, sin)``) or ``"P"``. parent: the index of the parent joint in the list
            (-1: the base, ``Fp``). axis: (3,) unit, in the joint's frame.
        rotation: (3, 3), translation: (3,) [m]: the joint's placement in its parent's
            frame (the base's: ``T_p_b`` folded in). idx_q, idx_v: its coordinates.
        mass [kg], first_moment (3,) [kg m] (``m c``) and inertia (3, 3) [kg m^2] about
            the joint frame's origin: its body. armature [kg m^2 or kg].
    """

    name: str
    kind: str
    parent: int
    axis: tuple[float, ...]
    rotation: tuple[tuple[float, ...], ...]
    translation: tuple[float, ...]
    idx_q: int
    idx_v: int
    mass: float
    first_moment: tuple[float, ...]
    inertia: tuple[tuple[float, ...], ...]
    armature: float


def _body(inertia: pin.Inertia, M: pin.SE3 | None = None) -> tuple[float, Vec, Mat]:
    """``(m, m c, I_O)`` of Pinocchio's inertia (carried by ``M`` when given)."""
    if M is not None:
        inertia = M.act(inertia)
    m = float(inertia.mass)
    c = np.asarray(inertia.lever, dtype=float)
    Ic = np.asarray(inertia.inertia, dtype=float)
    I_O = Ic + m * (float(c @ c) * np.eye(3) - np.outer(c, c))
    I_O = 0.5 * (I_O + I_O.T)
    return m, [float(x) for x in m * c], [[float(x) for x in row] for row in I_O]


def arm_joints(payload: Payload) -> tuple[tuple[ArmJoint, ...], tuple[float, Vec, Mat]]:
    """The payload's joints (Pinocchio's order: a parent before its children) with the
    mount folded into the base's children, and the base's body (the links welded to the
    payload's root, in ``Fp``).

    Raises:
        PayloadError: a joint that is neither revolute nor prismatic about one axis (a
            spherical, planar, free-flyer, helical, composite or mimic joint), named.
    """
    model = payload.model
    mount = pin.SE3(np.asarray(payload.placement, dtype=float))
    joints = []
    for j in range(1, model.njoints):
        jm = model.joints[j]
        kind_axis = _JOINTS.get(jm.shortname())
        if kind_axis is None or jm.nv != 1:
            raise PayloadError(
                f"payload '{payload.name}': joint '{model.names[j]}' is a "
                f"{jm.shortname().removeprefix('JointModel')} joint; the compiled payload "
                "models take revolute and prismatic joints about one axis (RX, RY, RZ, "
                "RevoluteUnaligned, RUBX/RUBY/RUBZ, RevoluteUnboundedUnaligned, PX, PY, PZ, "
                "PrismaticUnaligned): use backend='pinocchio' for this payload"
            )
        kind, fixed_axis = kind_axis
        if fixed_axis is None:
            u = np.asarray(jm.extract().axis, dtype=float).ravel()
            axis: tuple[float, ...] = tuple(float(x) for x in u / np.linalg.norm(u))
        else:
            axis = fixed_axis
        parent = int(model.parents[j])
        place = model.jointPlacements[j]
        if parent == 0:
            place = mount * place
        R = np.asarray(place.rotation, dtype=float)
        m, h, I_O = _body(model.inertias[j])
        joints.append(
            ArmJoint(
                name=str(model.names[j]),
                kind=kind,
                parent=parent - 1,
                axis=tuple(_snap(x) for x in axis),
                rotation=tuple(tuple(_snap(x) for x in row) for row in R),
                translation=tuple(float(x) + 0.0 for x in place.translation),
                idx_q=int(jm.idx_q),
                idx_v=int(jm.idx_v),
                mass=m,
                first_moment=tuple(h),
                inertia=tuple(tuple(r) for r in I_O),
                armature=float(np.asarray(model.armature)[jm.idx_v]),
            )
        )
    return tuple(joints), _body(model.inertias[0], mount)


def payload_identity(payload: Payload, gravity: Sequence[float]) -> str:
    """What the payload's generated code is made from, as text (for the cache key): its
    joints and bodies as :func:`arm_joints` bakes them, exactly (floats by their shortest
    repr), the gravity and :data:`PAYLOAD_GENERATOR_VERSION`."""
    joints, base = arm_joints(payload)
    data = {
        "version": PAYLOAD_GENERATOR_VERSION,
        "nq": payload.nq,
        "nv": payload.nv,
        "gravity": [float(x) for x in gravity],
        "base": base,
        "joints": [
            [
                *(j.kind, j.parent, j.axis, j.rotation, j.translation, j.idx_q, j.idx_v),
                *(j.mass, j.first_moment, j.inertia, j.armature),
            ]
            for j in joints
        ],
    }
    return json.dumps(data, sort_keys=True)


# ---------------------------------------------------------------------------- algebra
def _dot(a: Sequence[Scalar], b: Sequence[Scalar]) -> Scalar:
    s: Scalar = 0.0
    for x, y in zip(a, b, strict=True):
        s = _add(s, mul(x, y))
    return s


def _mv(M: Sequence[Sequence[Scalar]], v: Sequence[Scalar]) -> Vec:
    return [_dot(row, v) for row in M]


def _mtv(M: Sequence[Sequence[Scalar]], v: Sequence[Scalar]) -> Vec:
    return [_dot([M[0][j], M[1][j], M[2][j]], v) for j in range(3)]


def _cross(a: Sequence[Scalar], b: Sequence[Scalar]) -> Vec:
    return [
        _sub(mul(a[1], b[2]), mul(a[2], b[1])),
        _sub(mul(a[2], b[0]), mul(a[0], b[2])),
        _sub(mul(a[0], b[1]), mul(a[1], b[0])),
    ]


def _zero(x: Scalar) -> bool:
    return isinstance(x, float) and x == 0.0


def _vadd(a: Sequence[Scalar], b: Sequence[Scalar]) -> Vec:
    return [_add(x, y) for x, y in zip(a, b, strict=True)]


def _vsub(a: Sequence[Scalar], b: Sequence[Scalar]) -> Vec:
    return [_sub(x, y) for x, y in zip(a, b, strict=True)]


def _vscale(a: Sequence[Scalar], s: Scalar) -> Vec:
    return [mul(x, s) for x in a]


def _matmul(A: Sequence[Sequence[Scalar]], B: Sequence[Sequence[Scalar]]) -> Mat:
    return [[_dot(A[i], [B[0][j], B[1][j], B[2][j]]) for j in range(3)] for i in range(3)]


@dataclass
class _Link:
    """A joint's placement in its parent's frame at ``q``: ``(R, p)`` (child to parent)."""

    R: Mat
    p: Vec

    def act_inv_motion(self, m: tuple[Vec, Vec]) -> tuple[Vec, Vec]:
        """A motion ``[v; w]`` of the parent's frame in the child's."""
        v, w = m
        return _mtv(self.R, _vsub(v, _cross(self.p, w))), _mtv(self.R, w)

    def act_force(self, f: tuple[Vec, Vec]) -> tuple[Vec, Vec]:
        """A force ``[f; n]`` of the child's frame in the parent's."""
        Rf = _mv(self.R, f[0])
        return Rf, _vadd(_mv(self.R, f[1]), _cross(self.p, Rf))


def _rotation_about(u: Sequence[float], c: Scalar, s: Scalar) -> Mat:
    """Rodrigues, ``R_ij = u_i u_j + c (delta_ij - u_i u_j) + s [u]x_ij`` (``u`` unit,
    numbers): exact zeros and ones about a frame axis."""
    skew = [[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]]
    R: Mat = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            uu = float(u[i] * u[j])
            R[i][j] = _add(
                _add(uu, mul((1.0 if i == j else 0.0) - uu, c)), mul(float(skew[i][j]), s)
            )
    return R


def _links(joints: Sequence[ArmJoint], q: Sequence[Scalar]) -> list[_Link]:
    out = []
    for j in joints:
        R0 = [list(r) for r in j.rotation]
        p0 = list(j.translation)
        if j.kind == "P":
            d = q[j.idx_q]
            out.append(_Link(R0, _vadd(p0, _vscale(_mv(R0, j.axis), d))))
            continue
        if j.kind == "U":
            c, s = q[j.idx_q], q[j.idx_q + 1]
        else:
            c, s = cs.cos(q[j.idx_q]), cs.sin(q[j.idx_q])
        out.append(_Link(_matmul(R0, _rotation_about(j.axis, c, s)), p0))
    return out


def _subspace(j: ArmJoint) -> tuple[Vec, Vec]:
    u = list(j.axis)
    zero = [0.0, 0.0, 0.0]
    return (u, zero) if j.kind == "P" else (zero, u)


def _inertia_times(body: tuple[float, Vec, Mat], m: tuple[Vec, Vec]) -> tuple[Vec, Vec]:
    """``I [v; w] = [m v + w x h; I_O w + h x v]`` (``h = m c``, ``I_O`` about the frame's
    origin)."""
    mass, h, I_O = body
    v, w = m
    return _vadd(_vscale(v, mass), _cross(w, h)), _vadd(_mv(I_O, w), _cross(h, v))


def _motion_cross(a: tuple[Vec, Vec], b: tuple[Vec, Vec]) -> tuple[Vec, Vec]:
    """``a x b`` of two motions ``[v; w]``."""
    return _vadd(_cross(a[1], b[0]), _cross(a[0], b[1])), _cross(a[1], b[1])


def _force_cross(a: tuple[Vec, Vec], f: tuple[Vec, Vec]) -> tuple[Vec, Vec]:
    """``a x* f`` of a motion ``[v; w]`` and a force ``[f; n]``."""
    return _cross(a[1], f[0]), _vadd(_cross(a[1], f[1]), _cross(a[0], f[0]))


def _base_motion(
    R: Mat, twist: Sequence[Scalar], accel: Sequence[Scalar] | None, gravity: Sequence[float]
) -> tuple[tuple[Vec, Vec], tuple[Vec, Vec]]:
    """``(nu_p, a_p)``: the platform's spatial velocity and acceleration in ``Fp``, gravity
    as a base acceleration (``accel`` None: zero)."""
    vl, wl = _mtv(R, twist[:3]), _mtv(R, twist[3:])
    g = [float(x) + 0.0 for x in gravity]
    lin = [_sub(0.0, x) for x in g] if accel is None else [_sub(accel[i], g[i]) for i in range(3)]
    a_lin = _vsub(_mtv(R, lin), _cross(wl, vl))
    a_ang = [0.0, 0.0, 0.0] if accel is None else _mtv(R, accel[3:])
    return (vl, wl), (a_lin, a_ang)


def _to_world(R: Mat, f: tuple[Vec, Vec]) -> list[Scalar]:
    return [*_mv(R, f[0]), *_mv(R, f[1])]


def arm_rnea(
    joints: Sequence[ArmJoint],
    base: tuple[float, Vec, Mat],
    gravity: Sequence[float],
    R: Mat,
    twist: Sequence[Scalar],
    accel: Sequence[Scalar] | None,
    q: Sequence[Scalar],
    qd: Sequence[Scalar],
    qdd: Sequence[Scalar] | None,
    links: Sequence[_Link] | None = None,
) -> tuple[list[Scalar], list[Scalar]]:
    """``(W (6), tau (nv))``: the wrench ``[f; n]`` the platform applies to the payload
    (F0, about O_p) and the payload's joint torques, by Newton-Euler at the platform's
    rotation ``R`` (3x3, F0), twist and classical acceleration ``accel`` (F0; None: zero),
    joint state ``q, qd, qdd`` (``qdd`` None: zero)."""
    links = _links(joints, q) if links is None else links
    nu, a0 = _base_motion(R, twist, accel, gravity)
    v: list[tuple[Vec, Vec]] = []
    a: list[tuple[Vec, Vec]] = []
    f: list[tuple[Vec, Vec]] = []
    for k, j in enumerate(joints):
        vp, ap = (nu, a0) if j.parent < 0 else (v[j.parent], a[j.parent])
        S = _subspace(j)
        Sv = (_vscale(S[0], qd[j.idx_v]), _vscale(S[1], qd[j.idx_v]))
        vk = links[k].act_inv_motion(vp)
        vk = (_vadd(vk[0], Sv[0]), _vadd(vk[1], Sv[1]))
        ak = links[k].act_inv_motion(ap)
        vxS = _motion_cross(vk, Sv)
        ak = (_vadd(ak[0], vxS[0]), _vadd(ak[1], vxS[1]))
        if qdd is not None:
            Sa = (_vscale(S[0], qdd[j.idx_v]), _vscale(S[1], qdd[j.idx_v]))
            ak = (_vadd(ak[0], Sa[0]), _vadd(ak[1], Sa[1]))
        v.append(vk)
        a.append(ak)
        body = (j.mass, list(j.first_moment), [list(r) for r in j.inertia])
        Ia = _inertia_times(body, ak)
        bias = _force_cross(vk, _inertia_times(body, vk))
        f.append((_vadd(Ia[0], bias[0]), _vadd(Ia[1], bias[1])))
    fb = _inertia_times(base, a0)
    bb = _force_cross(nu, _inertia_times(base, nu))
    f0 = (_vadd(fb[0], bb[0]), _vadd(fb[1], bb[1]))
    tau: list[Scalar] = [0.0] * len(joints)
    for k in reversed(range(len(joints))):
        j = joints[k]
        S = _subspace(j)
        t = _add(_dot(S[0], f[k][0]), _dot(S[1], f[k][1]))
        if qdd is not None and j.armature != 0.0:
            t = _add(t, mul(j.armature, qdd[j.idx_v]))
        tau[j.idx_v] = t
        fp = links[k].act_force(f[k])
        if j.parent < 0:
            f0 = (_vadd(f0[0], fp[0]), _vadd(f0[1], fp[1]))
        else:
            g = f[j.parent]
            f[j.parent] = (_vadd(g[0], fp[0]), _vadd(g[1], fp[1]))
    return _to_world(R, f0), tau


def _act_inertia(link: _Link, body: tuple[Scalar, Vec, Mat]) -> tuple[Scalar, Vec, Mat]:
    """A body's ``(m, m c, I_O)`` carried from the child's frame to the parent's:
    ``h' = R h + m p``, ``I' = R I R^T - [Rh]x[p]x - [p]x[Rh]x - m [p]x^2``."""
    m, h, I = body
    R, p = link.R, link.p
    Rh = _mv(R, h)
    RI = _matmul(R, I)
    RIRt = [[_dot(RI[i], R[j]) for j in range(3)] for i in range(3)]
    out: Mat = [[0.0] * 3 for _ in range(3)]
    pp = _dot(p, p)
    ph = _dot(p, Rh)
    for i in range(3):
        for j in range(3):
            # -[a]x[b]x = (a.b) I - b a^T: -[Rh]x[p]x - [p]x[Rh]x = 2 (p.Rh) I - p Rh^T -
            # Rh p^T, and -m [p]x^2 = m (p.p I - p p^T)
            cross_terms = _sub(
                mul(2.0, ph) if i == j else 0.0, _add(mul(p[i], Rh[j]), mul(Rh[i], p[j]))
            )
            par = mul(m, _sub(pp if i == j else 0.0, mul(p[i], p[j])))
            out[i][j] = _add(_add(RIRt[i][j], cross_terms), par)
    for i in range(3):  # symmetric: one expression per pair
        for j in range(i):
            out[i][j] = out[j][i]
    return m, _vadd(Rh, _vscale(p, m)), out


def arm_crba(
    joints: Sequence[ArmJoint],
    base: tuple[float, Vec, Mat],
    R: Mat,
    q: Sequence[Scalar],
    links: Sequence[_Link] | None = None,
) -> tuple[list[list[Scalar]], list[list[Scalar]], list[list[Scalar]]]:
    """``(K_ff (6x6), K_fj (6 x nv), M_jj (nv x nv))``: the payload's blocks of the coupled
    mass matrix in the platform's coordinates (classical acceleration in F0, wrenches in F0
    about O_p), by the composite-rigid-body algorithm (armature on ``M_jj``'s diagonal)."""
    links = _links(joints, q) if links is None else links
    n = len(joints)
    nv = max((j.idx_v for j in joints), default=-1) + 1
    comp: list[tuple[Scalar, Vec, Mat]] = [
        (j.mass, list(j.first_moment), [list(r) for r in j.inertia]) for j in joints
    ]
    total: tuple[Scalar, Vec, Mat] = (base[0], list(base[1]), [list(r) for r in base[2]])

    def plus(a: tuple[Scalar, Vec, Mat], b: tuple[Scalar, Vec, Mat]) -> tuple[Scalar, Vec, Mat]:
        return (
            _add(a[0], b[0]),
            _vadd(a[1], b[1]),
            [[_add(a[2][i][j], b[2][i][j]) for j in range(3)] for i in range(3)],
        )

    for k in reversed(range(n)):
        moved = _act_inertia(links[k], comp[k])
        if joints[k].parent < 0:
            total = plus(total, moved)
        else:
            comp[joints[k].parent] = plus(comp[joints[k].parent], moved)
    M: list[list[Scalar]] = [[0.0] * nv for _ in range(nv)]
    Kfj: list[list[Scalar]] = [[0.0] * nv for _ in range(6)]
    for k in range(n):
        j = joints[k]
        F = _inertia_times(comp[k], _subspace(j))
        S = _subspace(j)
        M[j.idx_v][j.idx_v] = _add(_add(_dot(S[0], F[0]), _dot(S[1], F[1])), j.armature)
        b = k
        while True:
            F = links[b].act_force(F)
            parent = joints[b].parent
            if parent < 0:
                break
            Sp = _subspace(joints[parent])
            e = _add(_dot(Sp[0], F[0]), _dot(Sp[1], F[1]))
            M[joints[parent].idx_v][j.idx_v] = M[j.idx_v][joints[parent].idx_v] = e
            b = parent
        col = _to_world(R, F)
        for r in range(6):
            Kfj[r][j.idx_v] = col[r]
    m, h, I_O = total
    Rh = _mv(R, h)
    RI = _matmul(R, I_O)
    I0 = [[_dot(RI[i], R[j]) for j in range(3)] for i in range(3)]
    Hx = [
        [0.0, _sub(0.0, Rh[2]), Rh[1]],
        [Rh[2], 0.0, _sub(0.0, Rh[0])],
        [_sub(0.0, Rh[1]), Rh[0], 0.0],
    ]
    Kff: list[list[Scalar]] = [[0.0] * 6 for _ in range(6)]
    for r in range(3):
        for c in range(3):
            Kff[r][c] = m if r == c else 0.0
            Kff[r][3 + c] = _sub(0.0, Hx[r][c])
            Kff[3 + r][c] = Hx[r][c]
            Kff[3 + r][3 + c] = I0[r][c]
    return Kff, Kfj, M


# ---------------------------------------------------------------------------- coupled models
@dataclass(frozen=True)
class PayloadModels:
    """The coupled models of a hexapod and its payload (see the module docstring).

    Attributes:
        idm, ddm, pddm: the CasADi SX functions (common sub-expressions eliminated).
        layout: the hexapod's aux layout (:class:`~.leg_chain_symbolic.AuxLayout`), which
            the three ``aux`` outputs follow; the DDM's extra pivots start at
            ``layout.ddm_size``.
        nq, nv: the payload's. unit_pairs: the ``q`` indices of each unbounded revolute
            joint's ``(cos, sin)`` pair.
    """

    idm: cs.Function
    ddm: cs.Function
    pddm: cs.Function
    layout: AuxLayout
    nq: int
    nv: int
    unit_pairs: tuple[int, ...]


def _hexapod(desc: RobotDescription) -> tuple[Any, list[float]]:
    """The hexapod's generated models with their DDM stages (the generic leg-chain models
    are generated again with them) and the numbers of their base-parameter input (the
    6-UPS closed forms'; none for the others)."""
    models = generate_models(desc)
    if models.ddm_stages is None:
        models = build_general_models(desc, stages=True)[0]
    return models, [float(x) for x in models.constants.parameter_values]


def payload_models(desc: RobotDescription, payload: Payload, layout: AuxLayout) -> PayloadModels:
    """The coupled IDM, torque-driven DDM and prescribed DDM of the hexapod ``desc``
    carrying ``payload`` (the hexapod's gravity), every number baked in; ``layout``: the
    aux layout of the hexapod's models (:func:`stewart_pin.codegen.compiled.model_layout`),
    which their ``aux`` outputs keep.

    Raises:
        PayloadError: a payload joint the generator does not take (:func:`arm_joints`).
    """
    joints, base = arm_joints(payload)
    gravity = [float(x) for x in desc.gravity]
    models, chi_values = _hexapod(desc)
    chi = cs.SX(chi_values) if chi_values else cs.SX(0, 1)
    nq, nv = payload.nq, payload.nv
    x_pose, x_twist = cs.SX.sym("pose", 16), cs.SX.sym("twist", 6)
    x_accel, x_gamma = cs.SX.sym("accel", 6), cs.SX.sym("gamma", 6)
    x_q, x_qd = cs.SX.sym("q", nq), cs.SX.sym("qd", nv)
    x_qdd, x_tau = cs.SX.sym("qdd", nv), cs.SX.sym("tau", nv)
    _, R = pose_from_input(x_pose, "matrix")
    tw, q, qd = split(x_twist), split(x_q), split(x_qd)
    links = _links(joints, q)

    # ---- IDM: the hexapod's closure with W added to the wrench Jp^T maps
    _, aux = models.idm_guarded(x_pose, x_twist, x_accel, chi)
    aux = split(aux)
    W, tau = arm_rnea(joints, base, gravity, R, tw, split(x_accel), q, qd, split(x_qdd), links)
    jinv = aux[layout.jinv : layout.jinv + 36]
    rows = [jinv[6 * i : 6 * i + 6] for i in range(6)]
    F = [aux[layout.idm_f + k] + W[k] for k in range(6)]
    Hz = aux[layout.idm_hz : layout.idm_hz + 6]
    gamma = idm_closure(rows, [], Hz, F, models.pivots)[0]
    idm_aux = [*aux[: layout.idm_f], *F, *aux[layout.idm_f + 6 :]]
    arm_in = [("q", x_q), ("qd", x_qd)]
    idm = function(
        "payload_idm",
        [("pose", x_pose), ("twist", x_twist), ("accel", x_accel), *arm_in, ("qdd", x_qdd)],
        [("out", [*gamma, *tau]), ("aux", idm_aux)],
    )

    # ---- the hexapod's A_robot and Jp^-T Gamma - h_robot, from its DDM stages
    stages = models.ddm_stages
    legs = []
    for k, leg in enumerate(stages.legs):
        args = {"pose": x_pose, "twist": x_twist, "gamma": x_gamma[k]}
        if "base_parameters" in leg.name_in():
            args["base_parameters"] = chi
        legs.append({name: split(v) for name, v in leg.call(args).items()})
    plat_args = {"pose": x_pose, "twist": x_twist}
    if "base_parameters" in stages.platform.name_in():
        plat_args["base_parameters"] = chi
    plat = {name: split(v) for name, v in stages.platform.call(plat_args).items()}
    A_up = list(plat["Ip"])
    rhs_r = [-h for h in plat["hp"]]
    for lg in legs:
        A_up = [A_up[m] + lg["block"][m] for m in range(21)]
        rhs_r = [rhs_r[j] + lg["wrench"][j] for j in range(6)]
    A_r: list[list[Scalar]] = [[0.0] * 6 for _ in range(6)]
    for m, (i, j) in enumerate(UPPER6):
        A_r[i][j] = A_r[j][i] = A_up[m]
    djinv = [x for lg in legs for x in lg["row"]]
    # the hexapod DDM's aux around its pivots: the 6-UPS leg lengths and distances to
    # the U-joint axes (q3^2, rho^2) then Jp^-1, or Jp^-1 and the general legs' slacks
    lengths = [lg[key][0] for key in ("q3sq", "rho2") if key in legs[0] for lg in legs]
    pre = [*lengths, *djinv]
    post: list[Scalar] = [s for lg in legs for s in lg.get("slack", ())]
    assert len(pre) == layout.ddm_d and len(post) == layout.n_slack

    Kff, Kfj, Mjj = arm_crba(joints, base, R, q, links)
    ddm_in = [("pose", x_pose), ("twist", x_twist), ("gamma", x_gamma), *arm_in]

    # ---- torque-driven DDM: the coupled mass matrix
    b_f, b_j = arm_rnea(joints, base, gravity, R, tw, None, q, qd, None, links)
    n = 6 + nv
    K: list[list[Scalar]] = [[0.0] * n for _ in range(n)]
    for i in range(6):
        for j in range(6):
            K[i][j] = A_r[i][j] + Kff[i][j]
        for j in range(nv):
            K[i][6 + j] = K[6 + j][i] = Kfj[i][j]
    for i in range(nv):
        for j in range(nv):
            K[6 + i][6 + j] = Mjj[i][j]
    tau_in = split(x_tau)
    rhs = [rhs_r[i] - b_f[i] for i in range(6)] + [tau_in[i] - b_j[i] for i in range(nv)]
    x, D = ldlt_solve(K, rhs)
    ddm = function(
        "payload_ddm",
        [*ddm_in, ("tau", x_tau)],
        [("out", x), ("aux", [*pre, *D[:6], *post, *D[6:]])],
    )

    # ---- prescribed DDM: the platform's row, then the torques
    Wq, tauq = arm_rnea(joints, base, gravity, R, tw, None, q, qd, split(x_qdd), links)
    Kp = [[A_r[i][j] + Kff[i][j] for j in range(6)] for i in range(6)]
    accel, Dp = ldlt_solve(Kp, [rhs_r[i] - Wq[i] for i in range(6)])
    torques = [tauq[j] + _dot([Kfj[i][j] for i in range(6)], accel) for j in range(nv)]
    pddm = function(
        "payload_pddm",
        [*ddm_in, ("qdd", x_qdd)],
        [("out", [*accel, *torques]), ("aux", [*pre, *Dp, *post])],
    )
    pairs = tuple(j.idx_q for j in joints if j.kind == "U")
    return PayloadModels(idm, ddm, pddm, layout, nq, nv, pairs)
