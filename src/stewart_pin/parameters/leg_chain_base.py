"""Analytic base parameters of robots with general legs (``ups``, ``ups-offset``, ``rus``,
``pus``): Khalil's grouping rules for each leg as a serial chain, the loop grouping of
each leg's last link into the platform at P_i, and the joint terms.

The standard vector is that of :mod:`stewart_pin.dynamics.regressor` (280 parameters: the
18 links and the platform, then ``IA FV FC K OF`` per joint). A *relation* says that one
standard parameter's regressor column is a fixed combination of others',
``W_p = sum_k c_k W_k``; eliminating ``p`` then adds ``c_k chi_p`` to each ``chi_k``. The
relations below are applied to each leg from its last link to its first (rules 2 to 6),
then the loop (rule 1), so that every parameter a relation adds to is still in the set;
what remains is the base set, with
``chi_b = K chi`` and ``W chi = W[:, kept] chi_b``.

Relations (leg i, link j in its MDH frame ``ji`` about its origin ``O_j``; ``A_j`` the
linear map of a body's parameters from frame j to frame j-1 at ``q_j = 0``, Khalil's
``Rx(alpha_j) Tx(d_j) Rz(theta_j) Tz(r_j)``, i.e.
:func:`~stewart_pin.description.inertia.transform_khalil`):

1. **Loop.** Link 3 holds the spherical joint's centre P_i at ``t`` (the leg's ``tip``)
   in frame 3, and P_i moves with the platform: a unit point mass at P_i is part of link
   3 (parameters ``v = (|t|^2 I - t t^T, t, 1)`` in frame 3 about O3) or of the platform
   (``u`` likewise with the platform point ``l``, in Fp about O_p), so
   ``W_3 v = W_platform u``. Applied after the leg's other rules, this relation
   eliminates M3 when it is still there (``ups`` legs, ``t = 0``: the paper's eq. 56-66,
   ``XX_RP = XX_P + sum M3 (l_y^2 + l_z^2)``, ..., ``M_RP = M_P + sum M3``), else the
   first moment of link 3 along the rod (``rus``, ``pus``: their M3 went to link 2 by
   rule 2, and a rod along x3 of length ``t_x`` gives ``M_RP = M_P + sum MX3 / t_x``,
   ``XX_RP = XX_P + sum (l_y^2 + l_z^2) MX3 / t_x``, ...).
2. **Revolute joint j** (Khalil's general rule): the body ``Delta`` (``XX = YY = YY_j``,
   ``MZ_j``, ``M_j``) is invariant under rotations about z_j, so it moves with link j-1:
   ``W_YYj = -W_XXj + W_{j-1} A_j (e_XX + e_YY)``, ``W_MZj = W_{j-1} A_j e_MZ``,
   ``W_Mj = W_{j-1} A_j e_M``; on the base (j = 1) these columns are zero. E.g.
   ``XXRj = XXj - YYj``, ``MYR(j-1) = MY(j-1) - sin(alpha_j) (MZj + r_j Mj)``,
   ``MXR(j-1) = MX(j-1) + d_j Mj``, ``MR(j-1) = M(j-1) + Mj``...
3. **Prismatic joint j**: link j turns with link j-1, so its tensor groups into link
   j-1's (rotated by ``A_j``): ``W_{XXj..ZZj} = W_{j-1} A_j e_{XX..ZZ}``; zero on the base.
4. **Armature.** ``IA_j`` (the energy ``IA qdot_j^2 / 2``) groups into ``ZZ_j`` (the energy
   ``ZZ_j (w_j . z_j)^2 / 2``) when joint j is revolute and the angular velocity of link
   j-1 is always perpendicular to z_j (``w_{j-1} . z_j = 0``): a first revolute joint; a
   revolute joint after a slide; a U-joint's second axis (``alpha = pi/2``) after a first
   revolute one; a rod axis perpendicular to two parallel axes (``rus`` built with
   ``alpha2 = 0``, ``alpha3 = pi/2``). Then ``ZZjR = ZZj + ... + IAj``.
5. **A first slide** (prismatic joint 1): link 1 translates along the fixed z1, so its
   first moments have no effect, and its mass (with what the other rules grouped into
   it) has the kinetic energy of an armature and the weight of a constant effort:
   ``W_M1 = W_IA1 - (g . z1) W_OF1``: ``IA1R = IA1 + M1R``, ``OF1R = OF1 - (g . z1) M1R``.
6. **Particular cases** (Khalil's parameters without effect): a link's tensor enters the
   dynamics through its kinetic energy ``w_j^T J w_j / 2`` only, and its first moments
   through ``v_Oj . (w_j x R_j MS)`` and the weight ``-g . R_j MS``; combinations that
   make these identically zero over the leg's joint space are dropped (or grouped):
   the XX, XY, XZ, YZ of a link turning about a fixed direction (a first revolute joint,
   a revolute joint after a slide, parallel revolute axes), the MX, MY of a link whose
   origin is fixed (a first revolute joint; a U-joint's second link) when gravity is
   along its axis or zero, the first moments of a translating link... These conditions
   are decided for each link from its own energy functions, sampled at
   :data:`N_SAMPLES` seeded joint configurations and rates of the leg alone (exact for
   these trigonometric identities; not the robot's regressor), with the tolerance
   :data:`GEOMETRY_TOLERANCE` on the kinetic part and the gravity tolerance on the weight;
   a decision within :data:`WEAK_GEOMETRY` of the tolerance is flagged (a
   :class:`~stewart_pin.exceptions.BaseParameterWarning`: an axis a hair off parallel).

The viscous and Coulomb friction of every joint, and its stiffness and offset (unless
rule 5 groups into the offset), are base parameters (dissipative terms, and the
potentials ``K q^2 / 2`` and ``OF q`` that no link has). Nothing else lowers the rank of
the named architectures: the tests check the set against the numerical rank and span on
general robots, the presets and special geometries (axes parallel to gravity, zero
gravity, parallel joint axes, planar or symmetric attachment points). ``custom`` legs are
not covered (any chain: the particular cases are open-ended) and go to the numerical
set (:func:`stewart_pin.parameters.base.base_parameters`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import transform_khalil
from stewart_pin.description.leg_architecture import LegArchitecture
from stewart_pin.dynamics.regressor import GENERAL_STANDARD_NAMES, joint_index, parameter_groups
from stewart_pin.exceptions import UnsupportedArchitectureError

#: Tolerance of the particular cases on the (dimensionless) kinetic energy functions: a
#: combination of a link's parameters whose function stays below this (relative to the
#: link's angular and linear velocity) over the samples has no effect.
GEOMETRY_TOLERANCE = 1e-9
#: A decision with a singular value between the tolerance and this is flagged.
WEAK_GEOMETRY = 1e-5
#: Joint configurations (and rates) sampled per leg for the particular cases.
N_SAMPLES = 24
#: Architectures the analytic rules cover.
COVERED = ("ups", "ups-offset", "rus", "pus")

_XX, _XY, _XZ, _YY, _YZ, _ZZ, _MX, _MY, _MZ, _M = range(10)
_TENSOR = (_XX, _XY, _XZ, _YY, _YZ, _ZZ)
_MOMENTS = (_MX, _MY, _MZ)


def _link(i: int, j: int, p: int) -> int:
    """Standard index of parameter ``p`` (Khalil's order) of link j (1..3) of leg i (1..6)."""
    return 30 * (i - 1) + 10 * (j - 1) + p


def _platform(p: int) -> int:
    return 180 + p


@dataclass
class _Grouping:
    """The elimination state: ``chi_b = E[alive] chi`` with
    ``W chi = sum_{k alive} W_k (E chi)_k``."""

    E: np.ndarray
    alive: np.ndarray

    @classmethod
    def start(cls, n: int) -> _Grouping:
        return cls(np.eye(n), np.ones(n, dtype=bool))

    def relate(self, p: int, coefficients: dict[int, float]) -> None:
        """``W_p = sum_k c_k W_k``: eliminate p (every k must still be in the set; a p
        already eliminated, e.g. by a particular case, is left as it is)."""
        if not self.alive[p]:
            return
        for k, c in coefficients.items():
            if c == 0.0 or k == p:
                continue
            assert self.alive[k], (GENERAL_STANDARD_NAMES[p], GENERAL_STANDARD_NAMES[k])
            self.E[k] += c * self.E[p]
        self.E[p] = 0.0
        self.alive[p] = False


@dataclass(frozen=True)
class _Samples:
    """A leg's frames at sampled joint values: rotations R (S, 3, 3, 3) of frames 1..3
    in F0, origins O (S, 3, 3), axes z (S, 3, 3), rates qd (S, 3), and the rotations at a
    reference configuration R_ref (3, 3, 3)."""

    R: np.ndarray
    O: np.ndarray
    z: np.ndarray
    qd: np.ndarray
    R_ref: np.ndarray


def _samples(leg: LegArchitecture, T0: np.ndarray, rng: np.random.Generator) -> _Samples:
    scale = max(1.0, float(np.linalg.norm(leg.tip)))
    q = np.where(
        [j.revolute for j in leg.joints],
        rng.uniform(-np.pi, np.pi, (N_SAMPLES + 1, 3)),
        rng.uniform(-scale, scale, (N_SAMPLES + 1, 3)),
    )
    frames = np.array([leg.transforms(qs, T0) for qs in q])  # (S + 1, 3, 4, 4)
    R, O = frames[:, :, :3, :3], frames[:, :, :3, 3]
    return _Samples(R[1:], O[1:], R[1:, :, :, 2], rng.normal(size=(N_SAMPLES, 3)), R[0])


def _angular_velocity(leg: LegArchitecture, s: _Samples, j: int) -> np.ndarray:
    """(S, 3) angular velocity of link j (1..3) in F0."""
    w = np.zeros((N_SAMPLES, 3))
    for k in range(j):
        if leg.joints[k].revolute:
            w += s.qd[:, k, None] * s.z[:, k]
    return w


def _origin_velocity(leg: LegArchitecture, s: _Samples, j: int) -> np.ndarray:
    """(S, 3) velocity of O_j (the origin of frame j) in F0."""
    v = np.zeros((N_SAMPLES, 3))
    for k in range(j):
        if leg.joints[k].revolute:
            v += s.qd[:, k, None] * np.cross(s.z[:, k], s.O[:, j - 1] - s.O[:, k])
        else:
            v += s.qd[:, k, None] * s.z[:, k]
    return v


def _null_combinations(rows: np.ndarray, tolerance: float, weak: list[float]) -> np.ndarray:
    """An orthonormal basis (c, r) of the combinations of the columns of ``rows`` that are
    zero on every row, the rank decided on the singular values over sqrt(rows) (each row
    is O(1)); singular values between the tolerance and :data:`WEAK_GEOMETRY` are
    appended to ``weak``."""
    _, sv, Vt = np.linalg.svd(rows)
    sv = np.concatenate([sv, np.zeros(rows.shape[1] - len(sv))]) / np.sqrt(rows.shape[0])
    small = sv <= tolerance
    weak.extend(float(x) for x in sv if tolerance < x < WEAK_GEOMETRY)
    return np.asarray(Vt[small].T)


def _eliminate_null(g: _Grouping, params: list[int], null: np.ndarray) -> None:
    """Eliminate one parameter per null combination (pivoted, in ``params`` order: the
    first ones go first), each expressed by the others left."""
    if null.shape[1] == 0:
        return
    # Reduced row echelon form of the null basis: each pivot's column is a combination
    # of the non-pivot columns (zero when the null space is spanned by unit vectors).
    M = null.T.copy()
    pivots: list[int] = []
    r = 0
    for c in range(M.shape[1]):
        if r == M.shape[0]:
            break
        k = r + int(np.argmax(np.abs(M[r:, c])))
        if abs(M[k, c]) < 1e-6:
            continue
        M[[r, k]] = M[[k, r]]
        M[r] /= M[r, c]
        for other in range(M.shape[0]):
            if other != r:
                M[other] -= M[other, c] * M[r]
        pivots.append(c)
        r += 1
    M[np.abs(M) < 1e-12] = 0.0
    for row, c in zip(M, pivots, strict=False):
        # sum_k row_k W_k = 0 with row_c = 1: W_c = -sum_{k != c} row_k W_k
        g.relate(params[c], {params[k]: -row[k] for k in range(len(params)) if k != c})


def _transform_matrix(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(10, 10): a body's parameters in frame b -> in frame a (``R``, ``p``: frame b in a)."""
    return np.column_stack([transform_khalil(np.eye(10)[k], R, p) for k in range(10)])


def _point_mass(t: np.ndarray) -> np.ndarray:
    """A unit point mass at ``t`` as the 10 parameters of its frame about the origin."""
    I = t @ t * np.eye(3) - np.outer(t, t)
    return np.array([I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2], *t, 1.0])


def _leg_rules(
    g: _Grouping,
    desc: RobotDescription,
    i: int,
    rng: np.random.Generator,
    gravity_tolerance: float,
    g0: float,
    weak: list[tuple[str, float]],
) -> None:
    """Apply the relations of the module docstring to leg i (1..6)."""
    leg = desc.leg_architectures[i - 1]
    T0 = np.eye(4)
    T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[i - 1], desc.base_points[i - 1]
    s = _samples(leg, T0, rng)
    gravity = desc.gravity
    for j in (3, 2, 1):
        joint = leg.joints[j - 1]
        A = _transform_matrix(joint.placement()[:3, :3], joint.placement()[:3, 3])

        def to_parent(x: np.ndarray, j: int = j, A: np.ndarray = A) -> dict[int, float]:
            """Columns of link j-1 times ``A x`` (nothing on the base)."""
            if j == 1:
                return {}
            y = A @ x
            return {_link(i, j - 1, k): float(y[k]) for k in range(10) if y[k] != 0.0}

        e = np.eye(10)
        w = _angular_velocity(leg, s, j)
        if joint.revolute:
            # 4. armature with ZZ_j when w_{j-1} . z_j = 0
            w_prev = _angular_velocity(leg, s, j - 1)
            along = np.einsum("si,si->s", w_prev, s.z[:, j - 1])[:, None]
            norm = np.linalg.norm(s.qd, axis=1)[:, None]
            found_a: list[float] = []
            perpendicular = _null_combinations(along / norm, GEOMETRY_TOLERANCE, found_a)
            weak.extend((f"leg {i} joint {j} (armature)", x) for x in found_a)
            if perpendicular.shape[1]:
                g.relate(joint_index(i, j, "IA"), {_link(i, j, _ZZ): 1.0})
            # 2. YY_j, MZ_j, M_j into link j-1
            g.relate(_link(i, j, _YY), {_link(i, j, _XX): -1.0, **to_parent(e[_XX] + e[_YY])})
            g.relate(_link(i, j, _MZ), to_parent(e[_MZ]))
            g.relate(_link(i, j, _M), to_parent(e[_M]))
        else:
            # 3. the tensor into link j-1
            for p in _TENSOR:
                g.relate(_link(i, j, p), to_parent(e[p]))
        # 6. particular cases: the tensor's kinetic energy w^T J w / 2 (in frame j)
        tensor = [p for p in _TENSOR if g.alive[_link(i, j, p)]]
        if tensor:
            wl = np.einsum("sij,si->sj", s.R[:, j - 1], w)
            quad = (
                np.stack(
                    [
                        wl[:, 0] ** 2 / 2,
                        wl[:, 0] * wl[:, 1],
                        wl[:, 0] * wl[:, 2],
                        wl[:, 1] ** 2 / 2,
                        wl[:, 1] * wl[:, 2],
                        wl[:, 2] ** 2 / 2,
                    ],
                    axis=1,
                )
                / np.maximum(np.linalg.norm(wl, axis=1) ** 2, 1e-300)[:, None]
            )
            found: list[float] = []
            null = _null_combinations(quad[:, tensor], GEOMETRY_TOLERANCE, found)
            weak.extend((f"leg {i} link {j} (kinetic)", x) for x in found)
            _eliminate_null(g, [_link(i, j, p) for p in tensor], null)
        # ... and the first moments' v_O . (w x R MS) and -g . R MS
        moments = [p for p in _MOMENTS if g.alive[_link(i, j, p)]]
        if moments:
            vo = _origin_velocity(leg, s, j)
            kin = np.einsum("sij,si->sj", s.R[:, j - 1], np.cross(vo, w))
            size = np.linalg.norm(vo, axis=1) * np.linalg.norm(w, axis=1)
            kin = np.where(size[:, None] > 0, kin / np.maximum(size, 1e-300)[:, None], 0.0)
            R_ref = s.R_ref[j - 1]
            pot = -(np.einsum("sij,i->sj", s.R[:, j - 1], gravity) - R_ref.T @ gravity) / g0
            cols = [p - _MX for p in moments]
            found_k: list[float] = []
            found_g: list[float] = []
            null_k = _null_combinations(kin[:, cols], GEOMETRY_TOLERANCE, found_k)
            null_g = _null_combinations(pot[:, cols], gravity_tolerance, found_g)
            weak.extend((f"leg {i} link {j} (kinetic)", x) for x in found_k)
            weak.extend((f"leg {i} link {j} (gravity)", x) for x in found_g)
            # combinations null for both: the intersection of the two null spaces
            if null_k.shape[1] and null_g.shape[1]:
                both = _intersection(null_k, null_g)
                _eliminate_null(g, [_link(i, j, p) for p in moments], both)
        # 5. a first slide: its mass is an armature and a constant effort
        if j == 1 and not joint.revolute:
            z1 = T0[:3, :3] @ joint.placement()[:3, 2]
            g.relate(
                _link(i, 1, _M),
                {joint_index(i, 1, "IA"): 1.0, joint_index(i, 1, "OF"): -float(gravity @ z1)},
            )

    # 1. loop: a point mass at P_i is part of link 3 (at its tip) or of the platform; the
    # difference of the two, through the rules above, is one more relation.
    u, v = _point_mass(desc.platform_points[i - 1]), _point_mass(np.asarray(leg.tip))
    x = np.zeros(g.E.shape[0])
    x[[_link(i, 3, k) for k in range(10)]] = v
    x[[_platform(k) for k in range(10)]] -= u
    y = g.E @ x  # sum over the set of y_k W_k = W x = 0
    y[np.abs(y) <= 1e-15 * np.abs(y).max()] = 0.0
    pivot = _loop_pivot(g, i, y)
    g.relate(pivot, {int(k): -y[k] / y[pivot] for k in np.flatnonzero(y) if k != pivot})


def _loop_pivot(g: _Grouping, i: int, y: np.ndarray) -> int:
    """The parameter the loop relation eliminates: M3 when it is still in the set (the
    paper's M3 grouped into the platform: ``ups`` legs), else the first moment of link 3
    along the rod (MX3 or MY3, the larger coefficient: ``rus``, ``pus``, whose M3 went to
    link 2), else the leg's largest coefficient."""
    for options in ([_link(i, 3, _M)], [_link(i, 3, _MX), _link(i, 3, _MY)]):
        options = [k for k in options if g.alive[k] and y[k] != 0.0]
        if options:
            return max(options, key=lambda k: abs(y[k]))
    leg = [k for k in np.flatnonzero(y) if 30 * (i - 1) <= k < 30 * i or k >= 190]
    return int(max(leg, key=lambda k: abs(y[k])))


def _intersection(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the intersection of the spans of the orthonormal columns
    of ``a`` and ``b``."""
    sv_u, sv, _ = np.linalg.svd(a.T @ b)
    return np.asarray(a @ sv_u[:, sv > 1 - 1e-9])


@dataclass(frozen=True)
class GeneralGrouping:
    """The analytic base set of a general robot: ``names``, ``K`` (nb, 280) with
    ``chi_b = K chi``, ``kept`` (nb,) standard indices, and ``weak``: the decisions taken
    within :data:`WEAK_GEOMETRY` of their tolerance (where, singular value)."""

    names: tuple[str, ...]
    K: np.ndarray
    kept: np.ndarray
    weak: tuple[tuple[str, float], ...]


def uncovered_legs(desc: RobotDescription) -> list[int]:
    """The legs (1..6) the analytic rules do not cover (``custom``; none on the ideal
    6-UPS, which has the paper's rules)."""
    legs = desc.leg_architectures
    return [i + 1 for i, leg in enumerate(legs) if leg.name not in COVERED]


def general_grouping(
    desc: RobotDescription, gravity_tolerance: float, g0: float
) -> GeneralGrouping:
    """The analytic base parameters of a robot with general legs (module docstring).

    Raises:
        UnsupportedArchitectureError: a ``custom`` leg (use the numerical base set).
    """
    if not parameter_groups(desc).joints:  # the rules index the joint-term columns
        raise UnsupportedArchitectureError(
            "general_grouping indexes the joint terms of the leg chains' regressor; robot "
            f"'{desc.name}' has the paper's 190 standard parameters (the ideal 6-UPS) and "
            "the paper's grouping (analytic_base_parameters)",
            "general_grouping",
            "ups",
        )
    bad = uncovered_legs(desc)
    if bad:
        raise UnsupportedArchitectureError(
            f"the analytic base parameters cover the legs {COVERED}; robot "
            f"'{desc.name}' has custom legs {bad}, whose chains the grouping rules cannot "
            "all foresee: use method='numerical' (QR of the stacked regressor)",
            "analytic base parameters",
            desc.architecture,
        )
    g = _Grouping.start(len(GENERAL_STANDARD_NAMES))
    rng = np.random.default_rng(20240613)
    weak: list[tuple[str, float]] = []
    for i in range(1, 7):
        _leg_rules(g, desc, i, rng, gravity_tolerance, g0, weak)
    kept = np.flatnonzero(g.alive)
    K = g.E[kept]
    K[np.abs(K) < 1e-15 * np.maximum(1.0, np.abs(K).max(axis=1, keepdims=True))] = 0.0
    names = tuple(
        _grouped_name(GENERAL_STANDARD_NAMES[k], bool(np.count_nonzero(row) > 1))
        for k, row in zip(kept, K, strict=True)
    )
    return GeneralGrouping(names, K, kept, tuple(weak))


def _grouped_name(name: str, grouped: bool) -> str:
    """``ZZ1_3`` -> ``ZZ1R_3``, ``XX_P`` -> ``XX_RP`` when others are grouped into it."""
    if not grouped:
        return name
    head, tail = name.split("_")
    return f"{head}_RP" if tail == "P" else f"{head}R_{tail}"


__all__ = [
    "COVERED",
    "GEOMETRY_TOLERANCE",
    "N_SAMPLES",
    "WEAK_GEOMETRY",
    "GeneralGrouping",
    "general_grouping",
    "uncovered_legs",
]
