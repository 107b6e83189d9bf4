"""Geometry and kinematics of general three-joint legs (``general-legs.md``), batched.

Leg i is the chain of :class:`~stewart_pin.description.leg_architecture.LegArchitecture`
placed at frame 0i (``[R_i, B_i]`` in F0). Arrays carry a leading batch axis N, then the
leg (6) and the joint (3): joint values ``q`` (N, 6, 3) [rad or m].

- :func:`leg_forward` : the joint frames and P_i in F0 from ``q``.
- :func:`leg_jacobians` : ``J_i`` (3x3 in F0), ``V_Pi = J_i qdot_i``; columns
  ``z_j x (P_i - O_j)`` (revolute) or ``z_j`` (prismatic).
- :func:`leg_drift` : ``Jdot_i qdot_i``, the acceleration of P_i at ``qddot_i = 0``.
- :func:`inverse_geometry` : closed forms for ``ups``, ``ups-offset`` (the leg's line
  through the second U axis: exact), ``rus`` (crank equation ``A cos + B sin = K``, two
  solutions), ``pus`` (a quadratic along the rail, two solutions), and Newton's method
  (:func:`solve_leg`) for ``custom`` legs; the branch of each leg is in its description.
- :func:`leg_kinematics` : ``qdot_i = J_i^-1 G_i V_p``,
  ``qddot_i = J_i^-1 (G_i Vdot_p + w x (w x L_i) - Jdot_i qdot_i)``, ``G_i = [I3, -L_i^]``.
- :func:`inverse_jacobian` : rows ``e_ai^T J_i^-1 G_i = [m_i^T, (L_i x m_i)^T]`` with
  ``m_i = J_i^-T e_ai``.
- :func:`forward_geometry` : the pose from the six actuated joint values (Newton on
  SE(3), the correction twist from ``Jp^-1``).
- :func:`admissible_poses` : the decision of the raising checks below on every pose of a
  batch at once (the sampler's), each state computed as it would be alone.

Singularities: serial (a leg's ``J_i``), measured by the smallest singular value of
``J_i`` with each revolute column divided by its lever arm ``|P_i - O_j|`` (unit-free; for
6-UPS it is ``sin q2i``, today's measure), refused under :data:`LEG_SINGULARITY`; parallel
(``Jp^-1``), its condition number with the angular columns divided by the platform
radius, refused over :data:`MAX_CONDITION`. Both raise :class:`SingularityError`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from stewart_pin._checks import check_array, check_pose, check_poses, check_states, in_batch
from stewart_pin._so3 import cross
from stewart_pin.description.leg_architecture import LegArchitecture, wrap_into_limits
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.exceptions import (
    ConvergenceError,
    LegJointLimitError,
    LegReachError,
    NumericalError,
    SingularityError,
)
from stewart_pin.kinematics._se3_newton import newton_se3
from stewart_pin.kinematics.geometry import LEG_MIN_LENGTH_RATIO

#: Serial singularity threshold on the normalised smallest singular value of ``J_i``
#: (``sin q2i`` for 6-UPS: the value of ``kinematics.geometry.LEG_SINGULARITY_SIN``).
LEG_SINGULARITY = 2e-2
#: Parallel singularity threshold on the unit-free condition number of ``Jp^-1``
#: (``kinematics.jacobians.MAX_CONDITION``).
MAX_CONDITION = 1e4
#: Newton's method on a leg (custom legs): tolerance on ``|P_i error|`` [m] and iteration cap.
LEG_TOLERANCE = 1e-13
LEG_MAX_ITERATIONS = 50
#: Forward geometry: tolerance on the actuated joint values [m or rad], iteration cap.
FORWARD_TOLERANCE = 1e-12
FORWARD_MAX_ITERATIONS = 50


# ---------------------------------------------------------------------------- constants
V = TypeVar("V")


@dataclass(frozen=True)
class ChainConstants:
    """The six legs' joint parameters as arrays (6, 3), for batched evaluation."""

    alpha: np.ndarray
    d: np.ndarray
    theta: np.ndarray
    r: np.ndarray
    revolute: np.ndarray  # bool (6, 3)
    tip: np.ndarray  # (6, 3)
    T0: np.ndarray  # (6, 4, 4) frame 0i in F0
    actuated: np.ndarray  # (6,) 0-based
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def of(cls, robot: GeneralHexapod) -> ChainConstants:
        get = lambda name: np.array(  # noqa: E731
            [[getattr(j, name) for j in leg.joints] for leg in robot.legs], dtype=float
        )
        return cls(
            alpha=get("alpha"),
            d=get("d"),
            theta=get("theta"),
            r=get("r"),
            revolute=np.array([[j.revolute for j in leg.joints] for leg in robot.legs]),
            tip=np.array([leg.tip for leg in robot.legs]),
            T0=robot.leg_base_poses,
            actuated=robot.actuated,
            lower=get("lower"),
            upper=get("upper"),
        )


class _ByIdentity(Generic[V]):
    """A cache keyed by an object's identity: its ``id``, checked against the object kept
    beside the value (so a new object at a reused address is not a hit); past ``size``
    entries, the oldest is dropped."""

    def __init__(self, size: int = 64) -> None:
        self.size = size
        self._items: dict[int, tuple[object, V]] = {}

    def get(self, key: object, build: Callable[[], V]) -> V:
        hit = self._items.get(id(key))
        if hit is None or hit[0] is not key:
            hit = (key, build())
            self._items[id(key)] = hit
            if len(self._items) > self.size:
                self._items.pop(next(iter(self._items)))
        return hit[1]


_CONSTANTS: _ByIdentity[ChainConstants] = _ByIdentity()


def constants(robot: GeneralHexapod) -> ChainConstants:
    """The (cached) :class:`ChainConstants` of ``robot``."""
    return _CONSTANTS.get(robot, lambda: ChainConstants.of(robot))


def _mdh(alpha: Any, d: Any, theta: Any, r: Any) -> np.ndarray:
    """Batched ``Rx(alpha) Tx(d) Rz(theta) Tz(r)``: (..., 4, 4)."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    shape = np.broadcast_shapes(np.shape(alpha), np.shape(theta), np.shape(r), np.shape(d))
    T = np.zeros((*shape, 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, d
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = ca * st, ca * ct, -sa, -r * sa
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa * st, sa * ct, ca, r * ca
    T[..., 3, 3] = 1.0
    return T


# ---------------------------------------------------------------------------- forward
@dataclass(frozen=True)
class LegFrames:
    """Joint frames of the legs in F0.

    Attributes:
        T: (N, 6, 3, 4, 4) frames 1i, 2i, 3i in F0.
        P: (N, 6, 3) the spherical-joint centres P_i in F0 [m].
    """

    T: np.ndarray
    P: np.ndarray

    @property
    def origins(self) -> np.ndarray:
        return self.T[..., :3, 3]

    @property
    def axes(self) -> np.ndarray:
        return self.T[..., :3, 2]


def leg_forward(robot: GeneralHexapod, q: np.ndarray) -> LegFrames:
    """Frames and tips of the legs at joint values ``q`` (N, 6, 3)."""
    c = constants(robot)
    theta = c.theta + np.where(c.revolute, q, 0.0)
    r = c.r + np.where(c.revolute, 0.0, q)
    local = _mdh(c.alpha, c.d, theta, r)  # (N, 6, 3, 4, 4)
    T = np.empty_like(local)
    T[:, :, 0] = c.T0 @ local[:, :, 0]
    T[:, :, 1] = T[:, :, 0] @ local[:, :, 1]
    T[:, :, 2] = T[:, :, 1] @ local[:, :, 2]
    P = np.einsum("nkij,kj->nki", T[:, :, 2, :3, :3], c.tip) + T[:, :, 2, :3, 3]
    return LegFrames(T, P)


def leg_jacobians(robot: GeneralHexapod, frames: LegFrames) -> np.ndarray:
    """``J_i`` (N, 6, 3, 3) in F0: ``V_Pi = J_i qdot_i``."""
    c = constants(robot)
    z, O = frames.axes, frames.origins
    lever = frames.P[:, :, None, :] - O
    cols = np.where(c.revolute[..., None], cross(z, lever), z)  # (N, 6, 3 joints, 3)
    return np.swapaxes(cols, -1, -2)


def leg_drift(robot: GeneralHexapod, frames: LegFrames, qdot: np.ndarray) -> np.ndarray:
    """``Jdot_i qdot_i`` (N, 6, 3) [m/s^2]: the acceleration of P_i at ``qddot_i = 0``.

    Outward from the fixed frame 0i, joint by joint: the angular velocity ``w`` and
    acceleration ``wdot`` of the links, and the acceleration of the next origin
    ``acc += wdot x r + w x (w x r)``, plus ``2 qdot w x z`` past a prismatic joint and
    ``qdot w x z`` in ``wdot`` past a revolute one. (Joint 1 moves from rest: its terms
    are zero and skipped.)"""
    c = constants(robot)
    z, O = frames.axes, frames.origins
    rev = c.revolute[..., None]  # (6, 3, 1)
    w = np.where(rev[:, 0], qdot[:, :, 0, None] * z[:, :, 0], 0.0)
    wdot = np.zeros(frames.P.shape)
    acc = np.zeros(frames.P.shape)
    for j in (1, 2):
        rj = O[:, :, j] - O[:, :, j - 1]
        acc = acc + cross(wdot, rj) + cross(w, cross(w, rj))
        w_z = qdot[:, :, j, None] * cross(w, z[:, :, j])
        acc = acc + np.where(rev[:, j], 0.0, 2.0 * w_z)
        wdot = wdot + np.where(rev[:, j], w_z, 0.0)
        w = w + np.where(rev[:, j], qdot[:, :, j, None] * z[:, :, j], 0.0)
    rj = frames.P - O[:, :, 2]
    return acc + cross(wdot, rj) + cross(w, cross(w, rj))


def serial_measure(robot: GeneralHexapod, frames: LegFrames, J: np.ndarray) -> np.ndarray:
    """Each leg's unit-free distance to a serial singularity (N, 6): the smallest
    singular value of ``J_i`` with revolute columns divided by ``|P_i - O_j|``."""
    c = constants(robot)
    lever = np.linalg.norm(frames.P[:, :, None, :] - frames.origins, axis=-1)
    scale = np.where(c.revolute, np.where(lever > 0, lever, 1.0), 1.0)
    return np.linalg.svd(J / scale[:, :, None, :], compute_uv=False)[..., -1]


def serial_admissible(robot: GeneralHexapod, frames: LegFrames, J: np.ndarray) -> np.ndarray:
    """(N,) bool: the states :func:`check_serial` accepts (its tests, state by state)."""
    c = constants(robot)
    P0 = np.asarray(robot.platform_points)
    radius = float(np.linalg.norm(P0 - P0.mean(axis=0), axis=1).mean())
    lever = np.linalg.norm(frames.P[:, :, None, :] - frames.origins, axis=-1)
    short = c.revolute & ~(lever >= LEG_MIN_LENGTH_RATIO * radius) & (radius > 0)
    s = serial_measure(robot, frames, J)
    return ~np.any(short, axis=(1, 2)) & np.all(s >= LEG_SINGULARITY, axis=1)


def check_serial(robot: GeneralHexapod, frames: LegFrames, J: np.ndarray) -> None:
    """:class:`SingularityError` when a leg is at (or too near) a serial singularity: its
    normalised Jacobian (:func:`serial_measure`) below :data:`LEG_SINGULARITY`, or a
    vanishing lever, P_i closer to a revolute joint's origin than
    :data:`~stewart_pin.kinematics.geometry.LEG_MIN_LENGTH_RATIO` of the platform radius
    (for 6-UPS: a leg shorter than 5 % of it, today's rule; the normalised measure alone
    would not see it, being ``|sin q2|`` whatever the length)."""
    c = constants(robot)
    P0 = np.asarray(robot.platform_points)
    radius = float(np.linalg.norm(P0 - P0.mean(axis=0), axis=1).mean())
    lever = np.linalg.norm(frames.P[:, :, None, :] - frames.origins, axis=-1)
    short = c.revolute & ~(lever >= LEG_MIN_LENGTH_RATIO * radius)
    if radius > 0 and np.any(short):
        n, k, j = np.argwhere(short)[0]  # the first failing state
        raise in_batch(
            SingularityError(
                f"leg {k + 1} is at or too near a serial singularity: P_{k + 1} is "
                f"{lever[n, k, j]:.3g} m from the origin of its revolute joint {j + 1}, less "
                f"than {LEG_MIN_LENGTH_RATIO:g} of the platform radius {radius:.3g} m (a "
                "vanishing leg: its joint rates grow without bound)",
                float(lever[n, k, j] / radius),
                LEG_MIN_LENGTH_RATIO,
                leg=int(k + 1),
            ),
            short,
        )
    s = serial_measure(robot, frames, J)
    bad = ~(s >= LEG_SINGULARITY)
    if np.any(bad):
        n, k = np.argwhere(bad)[0]  # the first failing state
        raise in_batch(
            SingularityError(
                f"leg {k + 1} is at or too near a serial singularity (normalised smallest "
                f"singular value of its Jacobian {s[n, k]:.3g} < {LEG_SINGULARITY:g}): e.g. "
                "crank and rod aligned, or a leg along its first U-joint axis",
                float(s[n, k]),
                LEG_SINGULARITY,
                leg=int(k + 1),
            ),
            bad,
        )


# ---------------------------------------------------------------------------- inverse
def _wrap(x: np.ndarray) -> np.ndarray:
    return np.arctan2(np.sin(x), np.cos(x))


@dataclass(frozen=True)
class ClosedForms:
    """The closed-form inverse geometry of some legs of one named architecture, their
    constants stacked along a leg axis (m,), so that one pass of array operations solves
    all of them (:func:`_closed_form`).

    Attributes:
        name: the architecture, ``ups``, ``ups-offset``, ``rus`` or ``pus``.
        legs: (m,) the legs' 0-based indices in the robot.
        R1, t1: (m, 3, 3), (m, 3): joint 1's ``Rx(alpha1) Tx(d1)``.
        r1, theta1: (m,) joint 1's constant offsets [m], [rad].
        branch: (m,) the closed form's solution, +1 or -1; ``phase`` (m,) 0 or pi with it.
        d2: (m,) joint 2's offset [m] (the U-joint offset of ``ups-offset``).
        c, cc: (m, 3), (m,): the origin of frame 2 in frame 1 (the U-joint centre), and
            ``c . c``.
        rail: (m, 3): ``Rz(theta1) c + r1 z`` (``pus``).
        ell2: (m,) the squared rod length ``|tip|^2`` [m^2].
        Rx2, Rz1: (m, 3, 3): ``Rx(alpha2)`` and ``Rz(theta1)``.
        theta2, theta3, sa3, ca3: (m,) joint 2's and 3's offsets, ``sin``/``cos alpha3``.
        tip: (m, 3) the spherical-joint centre in frame 3 [m].
        finite: whether every constant is finite (a length of 1e300 overflows ``c . c``:
            :func:`_closed_form` then raises the floating-point exception).
    """

    name: str
    legs: np.ndarray
    R1: np.ndarray
    t1: np.ndarray
    r1: np.ndarray
    theta1: np.ndarray
    branch: np.ndarray
    phase: np.ndarray
    d2: np.ndarray
    c: np.ndarray
    cc: np.ndarray
    rail: np.ndarray
    ell2: np.ndarray
    Rx2: np.ndarray
    Rz1: np.ndarray
    theta2: np.ndarray
    theta3: np.ndarray
    sa3: np.ndarray
    ca3: np.ndarray
    tip: np.ndarray
    finite: bool

    @classmethod
    def of(cls, legs: list[tuple[int, LegArchitecture]]) -> ClosedForms:
        """The group of ``legs``: (index, leg) pairs, all of one named architecture (not
        custom: :class:`LegGroups` sorts them)."""
        each = [leg for _, leg in legs]
        j1 = [leg.joints[0] for leg in each]
        A1 = np.array([_mdh(j.alpha, j.d, 0.0, 0.0) for j in j1])
        c = np.array([leg.joints[1].placement()[:3, 3] for leg in each])
        Rz1 = np.array([_mdh(0.0, 0.0, j.theta, 0.0)[:3, :3] for j in j1])
        r1 = np.array([j.r for j in j1])
        tip = np.array([leg.tip for leg in each])
        branch = np.array([leg.branch for leg in each], dtype=float)
        alpha3 = np.array([leg.joints[2].alpha for leg in each])
        with np.errstate(all="ignore"):  # an overflow is refused when the group is used
            cc, ell2 = np.einsum("ki,ki->k", c, c), np.einsum("ki,ki->k", tip, tip)
            rail = np.einsum("kij,kj->ki", Rz1, c) + r1[:, None] * np.array([0.0, 0.0, 1.0])
        return cls(
            name=each[0].name,
            legs=np.array([k for k, _ in legs]),
            R1=A1[:, :3, :3],
            t1=A1[:, :3, 3],
            r1=r1,
            theta1=np.array([j.theta for j in j1]),
            branch=branch,
            phase=np.where(branch > 0, 0.0, np.pi),
            d2=np.array([leg.joints[1].d for leg in each]),
            c=c,
            cc=cc,
            rail=rail,
            ell2=ell2,
            Rx2=np.array([_mdh(leg.joints[1].alpha, 0.0, 0.0, 0.0)[:3, :3] for leg in each]),
            Rz1=Rz1,
            theta2=np.array([leg.joints[1].theta for leg in each]),
            theta3=np.array([leg.joints[2].theta for leg in each]),
            sa3=np.sin(alpha3),
            ca3=np.cos(alpha3),
            tip=tip,
            finite=bool(np.isfinite(np.concatenate([cc, ell2, rail.ravel()])).all()),
        )


@dataclass(frozen=True)
class LegGroups:
    """Six legs sorted for their inverse geometry over a batch.

    Attributes:
        closed_forms: the named legs, one :class:`ClosedForms` per architecture (in the
            order of their first leg).
        custom: the 0-based indices of the custom legs (Newton's method, leg by leg).
        revolute: (6, 3) bool; lower, upper: (6, 3) the joint limits [rad or m].
    """

    closed_forms: tuple[ClosedForms, ...]
    custom: tuple[int, ...]
    revolute: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def of(cls, legs: tuple[LegArchitecture, ...]) -> LegGroups:
        names = dict.fromkeys(leg.name for leg in legs if leg.name != "custom")
        return cls(
            closed_forms=tuple(
                ClosedForms.of([(k, leg) for k, leg in enumerate(legs) if leg.name == name])
                for name in names
            ),
            custom=tuple(k for k, leg in enumerate(legs) if leg.name == "custom"),
            revolute=np.array([[j.revolute for j in leg.joints] for leg in legs]),
            lower=np.array([leg.limits[:, 0] for leg in legs]),
            upper=np.array([leg.limits[:, 1] for leg in legs]),
        )


_GROUPS: _ByIdentity[LegGroups] = _ByIdentity()


def leg_groups(legs: tuple[LegArchitecture, ...]) -> LegGroups:
    """The (cached) :class:`LegGroups` of a robot's ``legs``."""
    return _GROUPS.get(legs, lambda: LegGroups.of(legs))


def _each_leg(v: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Row vectors ``v`` (N, m, 3) times each leg's matrix ``M`` (m, 3, 3): ``v_nk M_k``
    (a batched product per leg: on large N, 30x sooner than the equivalent einsum)."""
    return np.matmul(v.transpose(1, 0, 2), M).transpose(1, 0, 2)


def _rotated(R: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The points (k, 3) rotated by each of ``R`` (N, 3, 3): ``R_n p_k`` (N, k, 3) (one
    matrix product, where the equivalent einsum takes 20x longer on large N)."""
    return (R.reshape(-1, 3) @ points.T).reshape(R.shape[0], 3, len(points)).transpose(0, 2, 1)


def _reach_error(leg_index: int, value: np.ndarray, bad: np.ndarray, what: str) -> LegReachError:
    """The error of leg ``leg_index`` out of reach where ``bad`` (N,), naming the first
    failing state (not the worst) with its ``value`` (N,), and how many states fail."""
    n = int(np.argmax(bad))
    return in_batch(
        LegReachError(
            f"leg {leg_index + 1} cannot reach its platform point: {what}; choose a pose closer "
            "to the workspace centre (or longer cranks / rods)",
            leg_index + 1,
            float(value[n]),
        ),
        bad,
    )


def _unreachable(
    forms: ClosedForms,
    bad: np.ndarray,
    value: Callable[[], np.ndarray],
    what: str,
    out: np.ndarray | None,
) -> np.ndarray:
    """``bad`` (N, m), the states each leg of ``forms`` cannot reach: a
    :class:`LegReachError` for the first leg of the group with one (``value()`` (N, m) the
    measure it reports) when ``out`` is None, else marked in ``out`` (N, m)."""
    if out is None:
        if np.any(bad):
            j = int(np.argmax(np.any(bad, axis=0)))
            raise _reach_error(int(forms.legs[j]), value()[:, j], bad[:, j], what)
    else:
        out |= bad
    return bad


def _solve_u(
    forms: ClosedForms, w: np.ndarray, unreachable: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The universal joint (joints 2, 3 with intersecting axes): ``q2, q3`` (N, m) such
    that ``Rz(psi2) Rx(alpha3) Rz(psi3) tip = w`` (w (N, m, 3) in frame 1 rotated by
    ``Rx(alpha2)``). ``unreachable``: see :func:`_closed_form`."""
    t = forms.tip
    sa, ca = forms.sa3, forms.ca3
    a, b = sa * t[:, 1], sa * t[:, 0]
    k = w[..., 2] - ca * t[:, 2]
    ratio = k / np.hypot(a, b)
    _unreachable(
        forms,
        np.abs(ratio) > 1.0 + 1e-12,
        lambda: np.abs(ratio),
        "the universal joint cannot point the rod there",
        unreachable,
    )
    psi3 = np.arctan2(b, a) - np.arccos(np.clip(ratio, -1.0, 1.0))
    c3, s3 = np.cos(psi3), np.sin(psi3)
    vx = c3 * t[:, 0] - s3 * t[:, 1]
    vy = ca * (s3 * t[:, 0] + c3 * t[:, 1]) - sa * t[:, 2]
    psi2 = np.arctan2(w[..., 1], w[..., 0]) - np.arctan2(vy, vx)
    return _wrap(psi2 - forms.theta2), _wrap(psi3 - forms.theta3)


def _inverse_leg(
    leg: LegArchitecture, P0i: np.ndarray, k: int, guess: np.ndarray | None
) -> np.ndarray:
    """Closed form (named legs) or Newton (custom) for one leg: P0i (N, 3) -> q (N, 3)."""
    if leg.name == "custom":
        n = P0i.shape[0]
        start = np.broadcast_to(leg.guess if guess is None else guess, (n, 3))
        return solve_leg(leg, np.eye(4), P0i, start, leg_index=k)
    try:  # an overflow (e.g. a length of 1e300) is a named error, never a RuntimeWarning
        with np.errstate(over="raise", divide="raise", invalid="raise"):
            q = _closed_form(ClosedForms.of([(k, leg)]), P0i[:, None, :])[:, 0]
    except FloatingPointError:
        raise NumericalError(f"leg {k + 1} inverse geometry q", None) from None
    if not np.all(np.isfinite(q)):
        bad = ~np.all(np.isfinite(q), axis=1)
        raise NumericalError(
            f"leg {k + 1} inverse geometry q", int(np.argmax(bad)), int(bad.sum()), int(bad.size)
        )
    return q


def leg_inverse_geometry(leg: LegArchitecture, P0i: Any) -> np.ndarray:
    """One leg's joint values (N, 3) reaching the points ``P0i`` (N, 3) given in its frame
    0i [m]: the named architecture's closed form on the leg's branch (Newton from its
    ``guess`` for ``custom``); limits not checked. The importer checks with it that a
    leg's closed form gives the file's configuration."""
    return _inverse_leg(leg, np.atleast_2d(np.asarray(P0i, dtype=float)), 0, None)


def _closed_form(
    forms: ClosedForms, P: np.ndarray, unreachable: np.ndarray | None = None
) -> np.ndarray:
    """The closed forms of a group of named legs: joint values (N, m, 3) placing each
    leg's tip at ``P`` (N, m, 3), the points P_i in the legs' frames 0i [m].

    ``unreachable``: None, a :class:`LegReachError` for a state a leg cannot reach (one
    leg per group then: with several, the checks run joint by joint over the group, so
    the error may not be the one of the first failing leg); else a bool array (N, m)
    where those states are marked (their values are then meaningless but computed
    without a floating-point exception: the square root and arc-cosine arguments of the
    marked states are clamped).

    Raises:
        FloatingPointError: constants that overflowed (:attr:`ClosedForms.finite`), and
            under ``np.errstate(... "raise")`` an overflow on the way.
    """
    if not forms.finite:
        raise FloatingPointError("overflow in a leg's constants")
    q = np.empty(P.shape)
    b = forms.branch
    p = _each_leg(P - forms.t1, forms.R1)  # P before joint 1's Rz Tz
    if forms.name in ("ups", "ups-offset"):
        p[..., 2] -= forms.r1
        phi = np.arctan2(p[..., 1], p[..., 0]) + forms.phase
        rho = b * np.hypot(p[..., 0], p[..., 1]) - forms.d2
        q[..., 0] = _wrap(phi - forms.theta1)
        q[..., 1] = np.arctan2(rho, -p[..., 2])
        q[..., 2] = np.hypot(rho, p[..., 2])
        return q
    c = forms.c
    if forms.name == "rus":
        p[..., 2] -= forms.r1
        A = p[..., 0] * c[:, 0] + p[..., 1] * c[:, 1]
        B = p[..., 1] * c[:, 0] - p[..., 0] * c[:, 1]
        K = 0.5 * (np.einsum("nki,nki->nk", p, p) + forms.cc - forms.ell2) - p[..., 2] * c[:, 2]
        R = np.hypot(A, B)

        def ratio() -> np.ndarray:
            with np.errstate(divide="ignore", over="ignore"):  # |K| / 0 = inf: unreachable
                return np.where(np.abs(K) > R, np.abs(K) / R, 0.0)

        bad = _unreachable(
            forms,
            np.abs(K) > R,
            ratio,
            "the crank equation has no solution (|cos| > 1)",
            unreachable,
        )
        if unreachable is not None:
            K, R = np.where(bad, 0.0, K), np.where(bad, 1.0, R)
        phi = np.arctan2(B, A) - b * np.arccos(K / R)
        q[..., 0] = _wrap(phi - forms.theta1)
        cp, sp = np.cos(phi), np.sin(phi)
        # w = Rx(alpha2)^T (Rz(-phi) p - c)
        local = np.stack(
            [cp * p[..., 0] + sp * p[..., 1], -sp * p[..., 0] + cp * p[..., 1], p[..., 2]], -1
        )
        w = _each_leg(local - c, forms.Rx2)
    else:  # pus
        e = p - forms.rail
        disc = forms.ell2 - e[..., 0] ** 2 - e[..., 1] ** 2
        bad = _unreachable(
            forms,
            disc < 0,
            lambda: -disc,
            "the rod is too short to reach from the rail",
            unreachable,
        )
        q[..., 0] = e[..., 2] - b * np.sqrt(np.where(bad, 0.0, disc))
        e[..., 2] -= q[..., 0]  # P - C in the rotated frame
        w = _each_leg(_each_leg(e, forms.Rz1), forms.Rx2)
    q[..., 1], q[..., 2] = _solve_u(forms, w, unreachable)
    return q


def _leg_tip(
    leg: LegArchitecture, T_0_0i: np.ndarray, q: np.ndarray
) -> tuple[list[np.ndarray], np.ndarray]:
    """The frames 0i, 1i, 2i, 3i (each (N, 4, 4), the first ``T_0_0i``) and the tip (N, 3)
    of one leg at joint values ``q`` (N, 3)."""
    Ts = [T_0_0i]
    for joint, qj in zip(leg.joints, q.T, strict=True):
        theta = joint.theta + (qj if joint.revolute else 0.0)
        r = joint.r + (0.0 if joint.revolute else qj)
        Ts.append(Ts[-1] @ _mdh(joint.alpha, joint.d, theta, r))
    return Ts, Ts[-1][:, :3, :3] @ leg.tip + Ts[-1][:, :3, 3]


def _leg_tip_jacobian(leg: LegArchitecture, Ts: list[np.ndarray], tip: np.ndarray) -> np.ndarray:
    """``J_i`` (N, 3, 3) of one leg from :func:`_leg_tip`'s frames and tip."""
    cols = []
    for joint, T in zip(leg.joints, Ts[1:], strict=True):
        z = T[:, :3, 2]
        cols.append(np.cross(z, tip - T[:, :3, 3]) if joint.revolute else z)
    return np.stack(cols, -1)


def solve_leg(
    leg: LegArchitecture,
    T_0_0i: np.ndarray,
    P: np.ndarray,
    guess: np.ndarray,
    tol: float = LEG_TOLERANCE,
    max_iterations: int = LEG_MAX_ITERATIONS,
    leg_index: int = 0,
) -> np.ndarray:
    """Newton's method for one leg: joint values (N, 3) placing the tip at ``P`` (N, 3).

    Each step solves ``J_i dq = P - P(q)`` (F0 of ``T_0_0i``); it stops when
    ``|P - P(q)| <= tol`` [m] for every state.

    Raises:
        ConvergenceError: after ``max_iterations`` (an unreachable point, or a guess on
            another branch's side of a singularity).
        SingularityError: a singular ``J_i`` on the way.
    """
    q = np.array(guess, dtype=float, copy=True)
    P = np.asarray(P, dtype=float)
    residual = np.inf
    for iteration in range(max_iterations + 1):
        Ts, tip = _leg_tip(leg, T_0_0i, q)
        err = P - tip
        residual = float(np.linalg.norm(err, axis=-1).max())
        if residual <= tol:
            return q
        if iteration == max_iterations:
            break
        J = _leg_tip_jacobian(leg, Ts, tip)
        try:
            q += np.linalg.solve(J, err[..., None])[..., 0]
        except np.linalg.LinAlgError as e:
            raise SingularityError(
                f"the numerical inverse geometry of leg {leg_index + 1} met a singular leg "
                f"Jacobian at iteration {iteration}",
                None,
                LEG_SINGULARITY,
                leg=leg_index + 1,
            ) from e
    raise ConvergenceError(
        f"the numerical inverse geometry of leg {leg_index + 1} did not converge in "
        f"{max_iterations} iterations (tip error {residual:.3g} m > tol {tol:g} m): the point "
        "may be out of reach, or the guess too far",
        max_iterations,
        residual,
    )


def _solve_leg_each(
    leg: LegArchitecture,
    P: np.ndarray,
    guess: np.ndarray,
    tol: float = LEG_TOLERANCE,
    max_iterations: int = LEG_MAX_ITERATIONS,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`solve_leg` (frame 0i the identity) state by state over a batch: ``(q (N, 3),
    converged (N,) bool)``. Each state stops at the first iterate within ``tol``, as
    :func:`solve_leg` on that state alone would; a state that does not converge or meets
    a singular ``J_i`` is marked False (its values are meaningless)."""
    q = np.array(guess, dtype=float, copy=True)
    P = np.asarray(P, dtype=float)
    converged = np.zeros(q.shape[0], dtype=bool)
    active = np.arange(q.shape[0])
    eye = np.eye(4)
    for iteration in range(max_iterations + 1):
        Ts, tip = _leg_tip(leg, eye, q[active])
        err = P[active] - tip
        done = np.linalg.norm(err, axis=-1) <= tol
        converged[active[done]] = True
        active, err, tip = active[~done], err[~done], tip[~done]
        if active.size == 0 or iteration == max_iterations:
            break
        Ts = [T if T.ndim == 2 else T[~done] for T in Ts]
        J = _leg_tip_jacobian(leg, Ts, tip)
        regular = np.ones(active.size, dtype=bool)
        try:
            step = np.linalg.solve(J, err[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a singular J_i refuses the whole batch: one by one
            step = np.zeros_like(err)
            for i in range(active.size):
                try:
                    step[i] = np.linalg.solve(J[i], err[i])
                except np.linalg.LinAlgError:
                    regular[i] = False
        q[active] += step
        active = active[regular]
    return q, converged


def _leg_points(robot: GeneralHexapod, poses: np.ndarray) -> np.ndarray:
    """P_i in the frames 0i (N, 6, 3) [m] for validated poses (N, 4, 4)."""
    P = _rotated(poses[:, :3, :3], robot.platform_points) + poses[:, None, :3, 3]
    return _each_leg(P - robot.base_points, robot.leg_base_rotations)


def _inverse_legs(robot: GeneralHexapod, P0i: np.ndarray) -> np.ndarray:
    """Joint values (N, 6, 3) placing each leg's tip at ``P0i`` (N, 6, 3), its frame 0i.

    The named legs of one architecture are solved together (:class:`ClosedForms`); when
    one of them cannot reach or meets a floating-point exception at some state, the legs
    are solved again one by one in their order, so that the error raised is the first
    failing leg's, as named by :func:`_inverse_leg`."""
    groups = leg_groups(robot.legs)
    q = np.empty(P0i.shape)
    solved = True
    with np.errstate(over="raise", divide="raise", invalid="raise"):
        try:
            for forms in groups.closed_forms:
                marked = np.zeros((P0i.shape[0], forms.legs.size), dtype=bool)
                qk = _closed_form(forms, P0i[:, forms.legs], marked)
                q[:, forms.legs] = qk
                solved = solved and not np.any(marked) and bool(np.all(np.isfinite(qk)))
        except FloatingPointError:
            solved = False
    if not solved:
        for k, leg in enumerate(robot.legs):
            q[:, k] = _inverse_leg(leg, P0i[:, k], k, None)
        return q
    for k in groups.custom:
        q[:, k] = _inverse_leg(robot.legs[k], P0i[:, k], k, None)
    return q


def inverse_geometry_batch(
    robot: GeneralHexapod, poses: np.ndarray, check_limits: bool = True
) -> np.ndarray:
    """Joint values (N, 6, 3) of validated poses (N, 4, 4), each leg on its branch.

    Raises:
        LegReachError: a leg cannot reach. LegJointLimitError: a joint outside its limits
        (``check_limits``). ConvergenceError, SingularityError: from a custom leg's Newton.
    """
    q = _inverse_legs(robot, _leg_points(robot, poses))
    g = leg_groups(robot.legs)  # revolute values modulo 2 pi
    q = wrap_into_limits(q, g.revolute, g.lower, g.upper)
    if check_limits:
        check_joint_limits(robot, q)
    return q


def check_joint_limits(robot: GeneralHexapod, q: np.ndarray) -> None:
    """:class:`LegJointLimitError` for joint values (N, 6, 3) outside their limits."""
    c = constants(robot)
    bad = (q < c.lower) | (q > c.upper)
    if np.any(bad):
        n, k, j = np.argwhere(bad)[0]  # the first failing state
        raise in_batch(
            LegJointLimitError(
                int(k + 1),
                int(j + 1),
                float(q[n, k, j]),
                float(c.lower[k, j]),
                float(c.upper[k, j]),
            ),
            bad,
        )


def inverse_geometry(robot: GeneralHexapod, pose: Any, check_limits: bool = True) -> np.ndarray:
    """Joint values for one pose -> (6, 3), or a batch of poses -> (N, 6, 3)."""
    T, batched = check_poses(pose)
    q = inverse_geometry_batch(robot, T, check_limits)
    return q if batched else q[0]


def actuator_positions(robot: GeneralHexapod, pose: Any, check_limits: bool = True) -> np.ndarray:
    """The six actuated joint values (leg lengths for UPS, crank angles for RUS, slide
    positions for PUS) [m or rad]: shape (6,) or (N, 6)."""
    T, batched = check_poses(pose)
    q = inverse_geometry_batch(robot, T, check_limits)
    qa = np.take_along_axis(q, constants(robot).actuated[None, :, None], axis=2)[..., 0]
    return qa if batched else qa[0]


# ---------------------------------------------------------------------------- first, second order
@dataclass(frozen=True)
class LegKinematics:
    """The legs' state from the platform's (general-legs.md), batched.

    Attributes:
        q, qdot, qddot: (N, 6, 3) joint values, rates, accelerations (qddot zero when no
            platform acceleration was given).
        J, J_inv: (N, 6, 3, 3) ``J_i`` and its inverse, in F0.
        drift: (N, 6, 3) ``Jdot_i qdot_i``.
        L: (N, 6, 3) ``L_i = 0Rp pL_i``, from O_p to P_i in F0.
        frames: the :class:`LegFrames`.
    """

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    J: np.ndarray
    J_inv: np.ndarray
    drift: np.ndarray
    L: np.ndarray
    frames: LegFrames


def leg_state(
    robot: GeneralHexapod,
    poses: np.ndarray,
    twists: np.ndarray,
    accels: np.ndarray | None = None,
    check_limits: bool = False,
) -> LegKinematics:
    """The legs' joint values, rates and accelerations for validated batches."""
    q = inverse_geometry_batch(robot, poses, check_limits)
    frames = leg_forward(robot, q)
    J = leg_jacobians(robot, frames)
    check_serial(robot, frames, J)
    J_inv = np.linalg.inv(J)
    L = _rotated(poses[:, :3, :3], robot.platform_points)
    v, w = twists[:, None, :3], twists[:, None, 3:]
    qdot = np.einsum("nkij,nkj->nki", J_inv, v + cross(w, L))
    drift = leg_drift(robot, frames, qdot)
    if accels is None:
        qddot = np.zeros_like(q)
    else:
        vd, wd = accels[:, None, :3], accels[:, None, 3:]
        aP = vd + cross(wd, L) + cross(w, cross(w, L))
        qddot = np.einsum("nkij,nkj->nki", J_inv, aP - drift)
    return LegKinematics(q, qdot, qddot, J, J_inv, drift, L, frames)


def leg_kinematics(
    robot: GeneralHexapod, pose: Any, twist: Any, accel: Any = None
) -> LegKinematics:
    """:func:`leg_state` from one state or a batch (checked inputs; limits not checked)."""
    if accel is None:
        _, T, V = check_states(pose, (twist, "twist"))
        return leg_state(robot, T, V)
    _, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
    return leg_state(robot, T, V, A)


def inverse_jacobian_from_legs(
    robot: GeneralHexapod, J_inv: np.ndarray, L: np.ndarray
) -> np.ndarray:
    """``Jp^-1`` (N, 6, 6) from the legs' ``J_i^-1`` and ``L_i``: rows
    ``[m_i, L_i x m_i]``, ``m_i = J_i^-T e_ai``."""
    a = constants(robot).actuated
    m = np.take_along_axis(J_inv, a[None, :, None, None], axis=2)[:, :, 0, :]
    return np.concatenate([m, cross(L, m)], axis=-1)


def inverse_jacobian_batch(robot: GeneralHexapod, poses: np.ndarray) -> np.ndarray:
    """``Jp^-1`` (N, 6, 6) for validated poses: ``qdot_a = Jp^-1 V_p``."""
    ks = leg_state(robot, poses, np.zeros((poses.shape[0], 6)))
    return inverse_jacobian_from_legs(robot, ks.J_inv, ks.L)


def inverse_jacobian(robot: GeneralHexapod, pose: Any) -> np.ndarray:
    """``Jp^-1``: (6, 6) for one pose, (N, 6, 6) for a batch."""
    T, batched = check_poses(pose)
    J = inverse_jacobian_batch(robot, T)
    return J if batched else J[0]


def _outside_limits(robot: GeneralHexapod, q: np.ndarray) -> np.ndarray:
    """(N, 6, 3) bool: joint values (N, 6, 3) outside their limits."""
    c = constants(robot)
    return (q < c.lower) | (q > c.upper)


def admissible_poses(
    robot: GeneralHexapod, poses: np.ndarray, max_condition: float = MAX_CONDITION
) -> np.ndarray:
    """(N,) bool: the validated poses (N, 4, 4) that the raising checks accept, decided
    for the whole batch at once: every leg reaches (closed forms, or Newton state by
    state for custom legs), every joint within its limits (:func:`inverse_geometry_batch`
    with ``check_limits``), no serial singularity (:func:`check_serial`) and the
    condition number of ``Jp^-1`` at most ``max_condition`` (:func:`check_parallel`).

    The computation of each state is the one :func:`leg_state` and :func:`check_parallel`
    make on that state alone, so the decision is theirs.

    Raises:
        FloatingPointError: a closed form met an overflow, a division by zero or an
            invalid operation at some state (where :func:`inverse_geometry_batch` raises a
            :class:`NumericalError`); the caller decides the batch state by state.
    """
    c, groups = constants(robot), leg_groups(robot.legs)
    P0i = _leg_points(robot, poses)
    q = np.zeros(P0i.shape)
    ok = np.ones(poses.shape[0], dtype=bool)
    for forms in groups.closed_forms:  # the legs of each group on the states the others reach
        rows = np.flatnonzero(ok)
        cells = np.ix_(rows, forms.legs)
        marked = np.zeros((rows.size, forms.legs.size), dtype=bool)
        with np.errstate(over="raise", divide="raise", invalid="raise"):
            qk = _closed_form(forms, P0i[cells], marked)
        good = ~marked & np.all(np.isfinite(qk), axis=-1)
        q[cells] = np.where(good[..., None], qk, 0.0)
        ok[rows[~np.all(good, axis=1)]] = False
    for k in groups.custom:  # Newton state by state, on the states the named legs reach
        idx1 = np.flatnonzero(ok)
        qk, converged = _solve_leg_each(
            robot.legs[k], P0i[idx1, k], np.broadcast_to(robot.legs[k].guess, (idx1.size, 3))
        )
        q[idx1, k] = np.where(converged[:, None], qk, 0.0)
        ok[idx1[~converged]] = False
    q = wrap_into_limits(q, c.revolute, c.lower, c.upper)
    ok &= ~np.any(_outside_limits(robot, q), axis=(1, 2))
    idx = np.flatnonzero(ok)
    frames = leg_forward(robot, q[idx])
    J = leg_jacobians(robot, frames)
    regular = serial_admissible(robot, frames, J)
    ok[idx[~regular]] = False
    idx = idx[regular]
    L = _rotated(poses[idx, :3, :3], robot.platform_points)
    J_inv = inverse_jacobian_from_legs(robot, np.linalg.inv(J[regular]), L)
    ok[idx] = condition_number_batch(robot, J_inv) <= max_condition
    return ok


def condition_number_batch(robot: GeneralHexapod, J_inv: np.ndarray) -> np.ndarray:
    """Unit-free condition number of ``Jp^-1`` (N,): angular columns over the size."""
    return scaled_condition_number(J_inv, robot.size)


def scaled_condition_number(J_inv: np.ndarray, size: float) -> np.ndarray:
    """Condition number (N,) of ``Jp^-1`` (N, 6, 6) with its angular columns divided by
    the length ``size`` [m]."""
    scaled = J_inv.copy()
    scaled[..., 3:] /= size
    s = np.linalg.svd(scaled, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)


def check_parallel(
    robot: GeneralHexapod, J_inv: np.ndarray, max_condition: float = MAX_CONDITION
) -> None:
    """:class:`SingularityError` (``leg=None``) at a parallel singularity."""
    check_condition(condition_number_batch(robot, J_inv), max_condition)


def check_condition(cond: np.ndarray, max_condition: float) -> None:
    """:class:`SingularityError` (``leg=None``) where the condition numbers ``cond`` (N,)
    pass ``max_condition``."""
    bad = ~(cond <= max_condition)
    if np.any(bad):
        n = int(np.argmax(bad))  # the first failing state
        raise in_batch(
            SingularityError(
                f"parallel singularity: the condition number of Jp^-1 {cond[n]:.3g} exceeds "
                f"{max_condition:g}",
                float(cond[n]),
                max_condition,
                leg=None,
            ),
            bad,
        )


# ---------------------------------------------------------------------------- forward geometry
def forward_geometry(
    robot: GeneralHexapod,
    actuated: Any,
    guess: Any = None,
    tol: float = FORWARD_TOLERANCE,
    max_iterations: int = FORWARD_MAX_ITERATIONS,
) -> np.ndarray:
    """The pose 0Tp (4x4) whose actuated joint values are ``actuated`` (6,) [m or rad].

    Newton on SE(3) from ``guess`` (default the home pose): the correction twist solves
    ``Jp^-1 dV = actuated - q_a(T)``, applied as ``p += dv``, ``R <- exp(dw) R``.

    Raises:
        ConvergenceError: no convergence within ``max_iterations``.
        SingularityError, LegReachError: met on the way (a bad guess or unassemblable values).
    """
    target = check_array(actuated, (6,), "actuated")
    T = check_pose(robot.home_pose if guess is None else guess, "guess").copy()
    a = constants(robot).actuated
    revolute = constants(robot).revolute[np.arange(6), a]

    def evaluate(T: np.ndarray) -> tuple[np.ndarray, Callable[[], np.ndarray]]:
        ks = leg_state(robot, T[None], np.zeros((1, 6)))
        error = target - ks.q[0, np.arange(6), a]
        return np.where(revolute, _wrap(error), error), lambda: inverse_jacobian_from_legs(
            robot, ks.J_inv, ks.L
        )[0]

    return newton_se3(T, evaluate, tol, max_iterations, "actuated joint error")


__all__ = [
    "FORWARD_MAX_ITERATIONS",
    "FORWARD_TOLERANCE",
    "LEG_MAX_ITERATIONS",
    "LEG_SINGULARITY",
    "LEG_TOLERANCE",
    "MAX_CONDITION",
    "ChainConstants",
    "ClosedForms",
    "LegFrames",
    "LegGroups",
    "LegKinematics",
    "actuator_positions",
    "admissible_poses",
    "check_condition",
    "check_joint_limits",
    "check_parallel",
    "check_serial",
    "condition_number_batch",
    "forward_geometry",
    "inverse_geometry",
    "inverse_geometry_batch",
    "inverse_jacobian",
    "inverse_jacobian_batch",
    "inverse_jacobian_from_legs",
    "leg_drift",
    "leg_forward",
    "leg_groups",
    "leg_inverse_geometry",
    "leg_jacobians",
    "leg_kinematics",
    "leg_state",
    "scaled_condition_number",
    "serial_admissible",
    "serial_measure",
    "solve_leg",
]
