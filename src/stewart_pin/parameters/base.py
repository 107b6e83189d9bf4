"""Base parameters (paper section VI): the identifiable combinations of the standard ones
(the 190 inertial parameters of the ideal 6-UPS robot; for general legs the 280 with the
joint terms, :mod:`stewart_pin.dynamics.regressor`).

Two routes to the same space:

- :func:`numerical_base_parameters`: QR with column pivoting of the regressor stacked over
  random states (Gautier 1991). Ground truth for the rank on any geometry.
- :func:`analytic_base_parameters`: the paper's grouping rules, for any frame placement,
  with the special cases of gravity decided per leg from the geometry. Per leg (eq. 44-50)
  link 3's inertia groups into link 2 (prismatic joint), YY2, MZ2 and M2 into links 2 and
  1 (revolute), link 1 keeps ZZ1R, MX1, MY1R (revolute on the base); then the loop groups
  each M3i into the platform as a point mass at P_i (eq. 56-66, with every term of the
  sums kept since Fp need not sit at P_1). 13 per leg + 10 = 88 on a general robot;
  fewer when gravity is parallel to a leg's first axis or zero (see
  :func:`analytic_base_parameters`).
- :func:`grouped_parameters`: the paper's 88 on every geometry (minimal on a general one),
  the fixed layout of the generated code.
- General legs (``ups``, ``ups-offset``, ``rus``, ``pus``): the analytic set of
  :mod:`stewart_pin.parameters.leg_chain_base` (Khalil's rules per leg, the loop grouping at
  P_i, the joint terms); ``custom`` legs get the numerical set
  (:func:`base_parameters` says so with a :class:`BaseParameterWarning`).

All return a :class:`BaseParameters`: names, the linear map ``K`` (nb x n) with
``chi_b = K chi``, the regressor columns they keep (``W_b = W[:, kept]`` for the analytic
set; ``W_b = W[:, kept]`` too for the numerical one, whose ``K`` folds the others in).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar
from stewart_pin.architectures import IdealUpsPath, LegChainPath, reference_path
from stewart_pin.description import RobotDescription
from stewart_pin.dynamics.regressor import (
    JOINT_TERMS_START,
    N_STANDARD,
    STANDARD_NAMES,
    parameter_groups,
    standard_parameter_names,
    standard_parameters,
)
from stewart_pin.exceptions import (
    BaseParameterWarning,
    IdentificationError,
    InputError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics.chain_legs import idle_legs
from stewart_pin.parameters.leg_chain_base import general_grouping, uncovered_legs
from stewart_pin.protocols import RobotLike

#: Default numerical rank tolerance, relative to the largest singular value of the stacked
#: regressor with its columns made dimensionless (see :func:`numerical_base_parameters`):
#: each architecture's path holds its own (``rank_tolerance``), this the ideal 6-UPS's.
RANK_TOLERANCE = IdealUpsPath.rank_tolerance
#: The same for general legs (:attr:`stewart_pin.architectures.LegChainPath.rank_tolerance`,
#: where the reason for 1e-11 is given).
GENERAL_RANK_TOLERANCE = LegChainPath.rank_tolerance
#: A numerical rank is flagged (:class:`BaseParameterWarning`) when a singular value lies
#: within this factor of the tolerance on either side.
RANK_MARGIN = 100.0

#: Standard gravity [m/s^2]: the scale of the gravity tolerances below.
STANDARD_GRAVITY = 9.80665
#: Gravity tolerance of the analytic rules, relative to standard gravity: a leg's first
#: U-joint axis z1i counts as parallel to gravity when ``|g x z1i| / g0`` (the sine of the
#: angle between them, under Earth's gravity) is at most this, and gravity counts as zero
#: when ``|g| / g0`` is.
GRAVITY_TOLERANCE = 1e-9
#: Above :data:`GRAVITY_TOLERANCE` and below this, the gravity-only parameters are kept
#: (they are identifiable in exact arithmetic) with a :class:`BaseParameterWarning`: their
#: forces are that small a fraction of gravity's, and the numerical rank at its default
#: tolerance may or may not count them.
WEAK_GRAVITY = 1e-5

#: Standard parameters that are >= 0 on every physical robot: a body's mass (``M2_3``,
#: ``M_P``), the diagonal terms of its inertia tensor about any point (``XX YY ZZ``: a
#: positive semi-definite tensor), and a joint's armature, viscous and Coulomb friction
#: and stiffness (``IA FV FC K``; :mod:`stewart_pin.dynamics.regressor`).
NONNEGATIVE_PATTERN = re.compile(r"(?:XX|YY|ZZ|M|IA|FV|FC|K)(?:\d+_\d+|_P)")

#: Per leg, in order: name, grouping (coefficient, standard parameter prefix and link),
#: and which gravity condition the parameter needs to act on the forces ("lateral": a
#: gravity component perpendicular to z1i; "gravity": a non-zero gravity; None: always).
_LEG_GROUPING: tuple[tuple[str, tuple[tuple[float, str, int], ...], str | None], ...] = (
    ("ZZ1R", ((1, "ZZ", 1), (1, "YY", 2), (1, "ZZ", 3)), None),
    ("MX1", ((1, "MX", 1),), "lateral"),
    ("MY1R", ((1, "MY", 1), (-1, "MZ", 2)), "lateral"),
    ("XX2R", ((1, "XX", 2), (1, "XX", 3), (-1, "YY", 2), (-1, "ZZ", 3)), None),
    ("XY2R", ((1, "XY", 2), (-1, "XZ", 3)), None),
    ("XZ2R", ((1, "XZ", 2), (1, "XY", 3)), None),
    ("YZ2R", ((1, "YZ", 2), (-1, "YZ", 3)), None),
    ("ZZ2R", ((1, "ZZ", 2), (1, "YY", 3)), None),
    ("MX2", ((1, "MX", 2),), "gravity"),
    ("MY2", ((1, "MY", 2),), "gravity"),
    ("MX3", ((1, "MX", 3),), None),
    ("MY3", ((1, "MY", 3),), None),
    ("MZ3", ((1, "MZ", 3),), None),
)


@dataclass(frozen=True)
class BaseParameters:
    """A set of base parameters ``chi_b = K chi`` with ``W chi = W[:, kept] chi_b``.

    Attributes:
        names: one name per base parameter.
        K: (nb, n) map from the n standard parameters (190; 280 for general legs).
        kept: (nb,) the regressor columns (standard parameters) the base set keeps.
        values: (nb,) the robot's base parameter values ``K chi``.
        robot: the robot the set is bound to (:func:`base_parameters`), or ``None``.
        standard_names: the n standard parameters' names
            (:func:`~stewart_pin.dynamics.regressor.standard_parameter_names`).
    """

    names: tuple[str, ...]
    K: np.ndarray
    kept: np.ndarray
    values: np.ndarray
    robot: RobotLike | None = field(default=None, repr=False, compare=False)
    standard_names: tuple[str, ...] = field(default=STANDARD_NAMES, repr=False)

    def __len__(self) -> int:
        return len(self.names)

    def from_standard(self, chi: np.ndarray) -> np.ndarray:
        """Base parameter values of any standard vector ``chi`` (n,)."""
        return self.K @ np.asarray(chi, dtype=float)

    def reduce(self, W: np.ndarray) -> np.ndarray:
        """The base regressor ``W_b`` from the full one (..., 6, n) -> (..., 6, nb)."""
        return np.asarray(W)[..., self.kept]

    def regressor(self, pose: Any, twist: Any, accel: Any, idle: Any = None) -> np.ndarray:
        """The base regressor ``W_b`` with ``Gamma = W_b chi_b``: (6, nb) or (N, 6, nb)
        (``idle``: the idle joints' ``(values, rates, accelerations)`` of a robot with
        idle freedoms, :meth:`~stewart_pin.StewartRobot.regressor`)."""
        if self.robot is None:
            raise InputError("these base parameters are bound to no robot")
        if idle is None:
            return self.reduce(self.robot.regressor(pose, twist, accel))
        return self.reduce(self.robot.regressor(pose, twist, accel, idle=idle))

    def table(self) -> str:
        """A readable table: name, value, and the grouping relation."""
        lines = [f"{'base parameter':>16s} {'value':>14s}   grouping"]
        first_joint = self.joint_terms[0] if len(self.joint_terms) else -1
        for k, (name, value, row) in enumerate(zip(self.names, self.values, self.K, strict=True)):
            if k == first_joint:
                lines.append(
                    "  -- joint terms: IA armature, FV viscous friction, FC Coulomb friction, "
                    "K stiffness, OF offset (constant effort) --"
                )
            lines.append(f"{name:>16s} {value:14.6g}   {_relation(row, self.standard_names)}")
        return "\n".join(lines)

    def relation(self, k: int) -> str:
        """Base parameter ``k`` as its grouping of standard parameters, e.g.
        ``"ZZ1_1 + YY2_1 + ZZ3_1"``."""
        return _relation(np.asarray(self.K)[k], self.standard_names)

    @property
    def nonnegative(self) -> np.ndarray:
        """(nb,) bool: the base parameters that are >= 0 on every physical robot, so that
        a negative estimate of one is physically impossible: those whose grouping has only
        positive coefficients on standard parameters that are never negative
        (:data:`NONNEGATIVE_PATTERN`: a mass, a diagonal term of an inertia tensor, an
        armature, a viscous or Coulomb friction, a stiffness), e.g. ``ZZ1R = ZZ1 + YY2 +
        ZZ3`` or ``M_RP = M_P + sum M3i``. Others (first moments, products of inertia,
        differences such as ``XX2R = XX2 + XX3 - YY2 - ZZ3``, offsets) may take either
        sign and are never flagged."""
        K = np.asarray(self.K)
        sign_definite = np.array(
            [NONNEGATIVE_PATTERN.fullmatch(n) is not None for n in self.standard_names]
        )
        ok = (K == 0) | (sign_definite[None, :] & (K > 0))
        return np.all(ok, axis=1) & np.any(K != 0, axis=1)

    @property
    def joint_terms(self) -> np.ndarray:
        """Indices (into the base set) of the base parameters kept from joint terms
        (``IA FV FC K OF``; empty for the ideal 6-UPS robot)."""
        if len(self.standard_names) == N_STANDARD:
            return np.zeros(0, dtype=int)
        return np.flatnonzero(self.kept >= JOINT_TERMS_START)


def _relation(row: np.ndarray, names: Sequence[str] = STANDARD_NAMES) -> str:
    terms = []
    for k in np.flatnonzero(np.abs(row) > 1e-15):
        c = row[k]
        name = names[int(k)]
        if c == 1.0:
            terms.append(f"+ {name}")
        elif c == -1.0:
            terms.append(f"- {name}")
        else:
            terms.append(f"{'+' if c > 0 else '-'} {abs(c):.6g} {name}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text


def _index(name: str) -> int:
    return STANDARD_NAMES.index(name)


def gravity_ratios(desc: RobotDescription) -> tuple[np.ndarray, float]:
    """The two dimensionless gravity measures the analytic rules decide on.

    Returns:
        ``(lateral, total)``: ``lateral`` (6,) is ``|g x z1i| / g0`` for each leg, with
        ``z1i`` its first U-joint axis in F0 (the z column of ``leg_base_rotations[i]``),
        ``g`` the description's gravity in F0 and ``g0`` :data:`STANDARD_GRAVITY`: under
        Earth's gravity, the sine of the angle between the axis and the vertical.
        ``total`` is ``|g| / g0``.
    """
    g = desc.gravity
    z1 = desc.leg_base_rotations[:, :, 2]
    z1 = z1 / np.linalg.norm(z1, axis=1, keepdims=True)
    lateral = np.linalg.norm(np.cross(z1, g), axis=1) / STANDARD_GRAVITY
    return lateral, float(np.linalg.norm(g) / STANDARD_GRAVITY)


def _grouping(desc: RobotDescription, lateral: np.ndarray, gravity: bool) -> BaseParameters:
    """The grouped parameters, without the gravity-only ones of the legs whose ``lateral``
    flag is False (MX1, MY1R) and, when ``gravity`` is False, of every leg (MX2, MY2)."""
    rows: list[np.ndarray] = []
    names: list[str] = []
    kept: list[int] = []

    def add(name: str, terms: Sequence[tuple[float, str]]) -> None:
        row = np.zeros(N_STANDARD)
        for coef, std in terms:
            row[_index(std)] += coef
        rows.append(row)
        names.append(name)
        kept.append(_index(terms[0][1]))

    for i in range(1, 7):
        for name, terms, needs in _LEG_GROUPING:
            if needs == "lateral" and not lateral[i - 1]:
                continue
            if needs == "gravity" and not gravity:
                continue
            add(f"{name}_{i}", [(c, f"{p}{j}_{i}") for c, p, j in terms])

    L = desc.platform_points  # P_i in Fp, from O_p
    lx, ly, lz = L[:, 0], L[:, 1], L[:, 2]
    m3 = [f"M3_{i}" for i in range(1, 7)]
    point_mass = {
        "XX": ly**2 + lz**2,
        "XY": -lx * ly,
        "XZ": -lx * lz,
        "YY": lx**2 + lz**2,
        "YZ": -ly * lz,
        "ZZ": lx**2 + ly**2,
        "MX": lx,
        "MY": ly,
        "MZ": lz,
        "M": np.ones(6),
    }
    for p, coefs in point_mass.items():
        add(f"{p}_RP", [(1, f"{p}_P"), *zip(coefs, m3, strict=True)])
    K = np.array(rows)
    return BaseParameters(tuple(names), K, np.array(kept), K @ standard_parameters(desc))


def grouped_parameters(desc: RobotDescription) -> BaseParameters:
    """The paper's 88 grouped parameters on every geometry: 13 per leg and 10 platform.

    ``W chi = W[:, kept] (K chi)`` holds on every robot, and on a general one they are the
    base parameters. When gravity is parallel to a leg's first axis (or zero) some of them
    (MX1_i, MY1R_i; MX2_i, MY2_i) have no effect and :func:`analytic_base_parameters`
    drops them; this fixed layout is the one the generated code takes as its input.
    Ideal 6-UPS robots only (:class:`UnsupportedArchitectureError` for general legs).
    """
    desc.ideal_stroke("the paper's 88 grouped parameters")
    return _grouping(desc, np.ones(6, dtype=bool), True)


def analytic_base_parameters(desc: RobotDescription) -> BaseParameters:
    """The base parameters by grouping rules, decided per leg from the geometry.

    General legs (``ups``, ``ups-offset``, ``rus``, ``pus``): the rules of
    :mod:`stewart_pin.parameters.leg_chain_base` (a
    :class:`~stewart_pin.exceptions.BaseParameterWarning` names a rule decided within a
    hair of its tolerance); :class:`UnsupportedArchitectureError` for ``custom`` legs. The
    ideal 6-UPS robot: the paper's rules, as follows.

    Per leg i (names ``..._i``), on a general geometry: ZZ1R, MX1, MY1R, XX2R, XY2R, XZ2R,
    YZ2R, ZZ2R, MX2, MY2, MX3, MY3, MZ3 with (eq. 44-50)::

        ZZ1R = ZZ1 + YY2 + ZZ3        MY1R = MY1 - MZ2
        XX2R = XX2 + XX3 - YY2 - ZZ3  XY2R = XY2 - XZ3   XZ2R = XZ2 + XY3
        YZ2R = YZ2 - YZ3              ZZ2R = ZZ2 + YY3

    Platform (eq. 56-66, with ``l = pL_i`` = P_i in Fp; all six terms of each sum)::

        XX_RP = XX_P + sum M3i (l_y^2 + l_z^2)   XY_RP = XY_P - sum M3i l_x l_y   ...
        MX_RP = MX_P + sum M3i l_x  ...          M_RP = M_P + sum M3i

    That is 13 x 6 + 10 = 88. Gravity's rules, per leg (measures of
    :func:`gravity_ratios`, tolerance :data:`GRAVITY_TOLERANCE` = 1e-9):

    - **First axis parallel to gravity** (``|g x z1i| / g0 <= 1e-9``): link 1 turns about
      a fixed vertical axis through B_i, so its potential energy ``-g . R1(q1i) MS1`` no
      longer depends on q1i; its kinetic energy is ``ZZ1 q1i'^2 / 2``. Only ZZ1R remains
      of link 1 (Khalil's rule for a first revolute joint along gravity): MX1_i and MY1R_i
      (with the MZ2 grouped into it) are dropped. 11 parameters for that leg.
    - **No gravity** (``|g| / g0 <= 1e-9``): the origin of frame 2i is the fixed point
      B_i, so MX2 and MY2 act only through gravity; MX1, MY1R, MX2, MY2 are dropped on
      every leg: 9 per leg, 64 in all.
    - Otherwise every one of the 13 acts (MX1, MY1 through the gravity component across
      z1i, MX2, MY2 through gravity).

    No other geometry lowers the rank: the loop closure groups each M3i as a point mass at
    P_i for any attachment points (planar, symmetric or not), and the tests check the set
    against the numerical rank and span on general, symmetric, planar, vertical-axis,
    mixed and zero-gravity robots. So the set is minimal on every valid description and
    there is no fallback. The one grey zone is a gravity measure just above the
    tolerance: between 1e-9 and :data:`WEAK_GRAVITY` (1e-5) the parameters are kept (they
    act in exact arithmetic) but their forces are that small a fraction of gravity's, so
    a :class:`~stewart_pin.exceptions.BaseParameterWarning` names the legs: the numerical
    rank may or may not count them, and identification will not resolve them.
    """
    return reference_path(desc).analytic_base_parameters(_RULES, desc)


def _paper_analytic(desc: RobotDescription) -> BaseParameters:
    """:func:`analytic_base_parameters` for the ideal 6-UPS robot (the paper's rules)."""
    lateral, total = gravity_ratios(desc)
    weak = [
        f"leg {i + 1} (|g x z1| / g0 = {lateral[i]:.3g})"
        for i in range(6)
        if GRAVITY_TOLERANCE < lateral[i] < WEAK_GRAVITY
    ]
    if weak:
        warnings.warn(
            "first U-joint axis nearly parallel to gravity on "
            + ", ".join(weak)
            + f": MX1 and MY1R of these legs are kept (above the {GRAVITY_TOLERANCE:g} "
            "tolerance) but barely act on the forces; make the axis exactly vertical to drop "
            "them, or compare with method='numerical'",
            BaseParameterWarning,
            stacklevel=5,
        )
    if GRAVITY_TOLERANCE < total < WEAK_GRAVITY:
        warnings.warn(
            f"gravity |g| = {total * STANDARD_GRAVITY:.3g} m/s^2 is nearly zero: MX2 and MY2 "
            f"of every leg are kept (above the {GRAVITY_TOLERANCE:g} g0 tolerance) but "
            "barely act on the forces; set gravity to 0 to drop them",
            BaseParameterWarning,
            stacklevel=5,
        )
    return _grouping(desc, lateral > GRAVITY_TOLERANCE, total > GRAVITY_TOLERANCE)


def _general_analytic(desc: RobotDescription) -> BaseParameters:
    """:func:`analytic_base_parameters` for general legs."""
    grouping = general_grouping(desc, GRAVITY_TOLERANCE, STANDARD_GRAVITY)
    if grouping.weak:
        where = sorted({w for w, _ in grouping.weak})
        warnings.warn(
            "a grouping rule was decided within a hair of its tolerance on "
            + ", ".join(where)
            + " (an axis nearly parallel to another or to gravity, a near-zero gravity): "
            "the parameters it keeps barely act on the forces; make the geometry exact to "
            "drop them, or compare with method='numerical'",
            BaseParameterWarning,
            stacklevel=5,
        )
    names = standard_parameter_names(desc)
    K = grouping.K
    return BaseParameters(
        grouping.names, K, grouping.kept, K @ standard_parameters(desc), None, names
    )


class _AnalyticRules:
    """The two sets of grouping rules; each architecture's path chooses its own
    (:meth:`stewart_pin.architectures.LegChainPath.analytic_base_parameters`)."""

    def paper_rules(self, desc: RobotDescription) -> BaseParameters:
        return _paper_analytic(desc)

    def leg_chain_rules(self, desc: RobotDescription) -> BaseParameters:
        return _general_analytic(desc)

    def chain_leg_rules(self, desc: RobotDescription) -> BaseParameters:
        raise UnsupportedArchitectureError(
            f"robot '{desc.name}' has chain legs: no grouping rules foresee an arbitrary "
            "chain; base_parameters(robot, 'numerical') gives the numerical base set",
            "analytic_base_parameters",
            desc.architecture,
        )


_RULES = _AnalyticRules()


@dataclass(frozen=True)
class RankReport:
    """How the numerical rank was decided.

    Attributes:
        rank: the numerical rank of the stacked regressor.
        n_states: states stacked (6 rows each).
        tolerance: relative threshold on the singular values.
        smallest_kept, largest_dropped: singular values either side of the cut, relative to
            the largest (of the stacked regressor with dimensionless columns).
        n_standard: the number of standard parameters (190; 280 for general legs).
    """

    rank: int
    n_states: int
    tolerance: float
    smallest_kept: float
    largest_dropped: float
    n_standard: int = N_STANDARD

    def __str__(self) -> str:
        return (
            f"rank {self.rank} of {self.n_standard} from {self.n_states} states "
            f"(tolerance {self.tolerance:g}; relative singular values: smallest kept "
            f"{self.smallest_kept:.3g}, largest dropped {self.largest_dropped:.3g})"
        )


def stacked_regressor(robot: RobotLike, n_states: int = 60, seed: int = 0) -> np.ndarray:
    """``W`` stacked over ``n_states`` random workspace states (``robot.sample_states``):
    (6 n_states, n)."""
    n_states = int(check_scalar(n_states, "n_states", integer=True))
    if n_states < 1:
        raise InputError(f"n_states must be an integer >= 1, got {n_states}")
    poses, twists, accels = robot.sample_states(n_states, seed)
    idle = random_idle_state(robot.description, n_states, seed)
    if idle is None:
        W = robot.regressor(poses, twists, accels)
    else:
        W = robot.regressor(poses, twists, accels, idle=idle)
    return W.reshape(-1, W.shape[-1])


def random_idle_state(
    desc: RobotDescription, n: int, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Random idle joints' ``(values, rates, accelerations)``, each (n, 6), for a robot
    with idle freedoms (chain legs with ``idle_joint``: an R-S-S rod's spin), ``None``
    for another: values uniform in [-pi, pi) [rad], rates in [-5, 5] [1/s],
    accelerations in [-50, 50] [1/s^2] (rad or m per unit time), from ``seed``. The spin
    accelerations are given, so the efforts are linear in the parameters; random ones
    excite the spin's inertia independently of the platform's motion."""
    if not idle_legs(desc):
        return None
    rng = np.random.default_rng([int(seed), 7_101])
    return (
        rng.uniform(-math.pi, math.pi, (n, 6)),
        rng.uniform(-5.0, 5.0, (n, 6)),
        rng.uniform(-50.0, 50.0, (n, 6)),
    )


#: Powers of the characteristic length that make each of a body's 10 regressor columns
#: dimensionless (Khalil's order XX XY XZ YY YZ ZZ [kg m^2], MX MY MZ [kg m], M [kg]).
_LENGTH_POWERS = np.tile(np.array([2, 2, 2, 2, 2, 2, 1, 1, 1, 0]), N_STANDARD // 10)
#: Powers of the length L and of the time T = sqrt(L / g0) in the unit of each joint term
#: per kg (``IA FV FC K OF``), revolute ([kg m^2], [N m s], [N m], [N m], [N m]) and
#: prismatic ([kg], [N s/m], [N], [N/m], [N]).
_JOINT_POWERS = {
    True: ((2, 0), (2, -1), (2, -2), (2, -2), (2, -2)),
    False: ((0, 0), (0, -1), (1, -2), (0, -2), (1, -2)),
}


def dimensionless_scales(desc: RobotDescription) -> tuple[np.ndarray, np.ndarray]:
    """``(columns (n,), rows (6,))``: ``W * columns[None] * rows[:, None]`` (per state) has
    every column in the same unit, so that the numerical rank does not depend on units.

    With ``L`` the robot's size (:attr:`RobotDescription.size` [m]) and ``T = sqrt(L / g0)``
    [s], a parameter's column is multiplied by the unit of that parameter per kg in
    powers of L and T: ``L^2`` (inertia, armature of a revolute joint), ``L`` (first
    moment), 1 (mass, a slide's armature), ``L^2 / T`` (a revolute joint's viscous
    friction), ``L^2 / T^2`` (its Coulomb friction, stiffness, offset), ``1 / T``,
    ``L / T^2``, ``1 / T^2``, ``L / T^2`` for a slide's. Rows of revolute actuators [N m]
    are divided by L, so that every row is a force [N]; the ideal 6-UPS robot's rows
    are forces already.
    """
    L = float(desc.size)
    T = math.sqrt(L / STANDARD_GRAVITY)
    groups = parameter_groups(desc)  # the regressor's layout: bodies (10 each), joints (5)
    columns = L ** np.tile(_LENGTH_POWERS[:10], len(groups.bodies)).astype(float)
    joints = [  # the regressor's joint-term columns (none for the ideal 6-UPS's 190)
        L**a * T**b for joint in groups.joints for a, b in _JOINT_POWERS[joint.kind == "revolute"]
    ]
    actuated = [leg.joints[leg.actuated - 1] for leg in desc.joint_legs]
    rows = np.array([1.0 / L if joint.revolute else 1.0 for joint in actuated])
    return np.concatenate([columns, joints]), rows


def numerical_base_parameters(
    robot: RobotLike, n_states: int = 60, seed: int = 0, tolerance: float | None = None
) -> tuple[BaseParameters, RankReport]:
    """Base parameters by QR with column pivoting of the stacked regressor (any robot:
    general legs with their joint terms too).

    The columns are made dimensionless before the decomposition: a parameter's column is
    multiplied by ``L^2`` (inertia, kg m^2), ``L`` (first moment, kg m) or 1 (mass), with
    ``L`` the robot's size (``description.size`` [m]), so all are forces per kg and the
    rank decision does not depend on units (general legs: the joint terms too, and the
    rows of revolute actuators, :func:`dimensionless_scales`). (Scaling each column to
    unit norm instead magnifies round-off: the column of a parameter that nothing
    excites, e.g. MX1 of a leg whose first axis is vertical, is round-off of 1e-16 of the
    others, which unit norm turned into an independent column: rank 94 where the true
    one is 76.)

    The rank r is the number of singular values above ``tolerance`` (default
    :data:`RANK_TOLERANCE`, 1e-8; :data:`GENERAL_RANK_TOLERANCE`, 1e-11, for general
    legs) times the largest;
    the QR's pivots choose the r kept columns. With ``W P = Q [R1 R2]``, ``W_2 = W_1
    beta`` with ``beta = R1^-1 R2``, so ``chi_b = chi_1 + beta chi_2``. Names are those
    of the kept standard parameters with a ``*`` suffix when others are folded into them.
    A :class:`~stewart_pin.exceptions.BaseParameterWarning` says when a singular value
    lies within a factor :data:`RANK_MARGIN` of the threshold (an ill-determined rank:
    some parameter barely acts on these states).
    """
    desc = robot.description
    if tolerance is None:
        tolerance = reference_path(desc).rank_tolerance
    real = isinstance(tolerance, (int, float, np.integer, np.floating))
    if isinstance(tolerance, bool) or not real or not 0.0 < float(tolerance) < 1.0:
        raise InputError(
            f"rank tolerance must be a number in (0, 1) (relative to the largest singular "
            f"value; default {RANK_TOLERANCE:g}, {GENERAL_RANK_TOLERANCE:g} for general "
            f"legs), got {tolerance!r}"
        )
    tol = float(tolerance)
    W = stacked_regressor(robot, n_states, seed)
    n = W.shape[1]
    columns, rows = dimensionless_scales(desc)
    scale = 1.0 / columns
    Wn = (W.reshape(-1, 6, n) * rows[:, None]).reshape(-1, n) / scale
    sv = np.linalg.svd(Wn, compute_uv=False)
    if not sv[0] > 0:
        raise IdentificationError(
            "the stacked regressor is zero: no parameter is identifiable", rank=0
        )
    rel = sv / sv[0]
    rank = int(np.sum(rel > tol))
    if rank >= Wn.shape[0] and rank < n:
        raise InputError(
            f"{n_states} states give {Wn.shape[0]} regressor rows, all independent: the rank "
            "is limited by the number of states, not by the robot, so no base set can be "
            f"read from them; use more states (6 x n_states above the {n} standard "
            f"parameters: n_states >= {n // 6 + 1})"
        )
    import scipy.linalg  # here: importing the module stays cheap (a new process's first call)

    _, R, perm = scipy.linalg.qr(Wn, mode="economic", pivoting=True)
    R1, R2 = R[:rank, :rank], R[:rank, rank:]
    beta_n = scipy.linalg.solve_triangular(R1, R2)  # in scaled columns
    kept, folded = perm[:rank], perm[rank:]
    # Back to physical units: W1 = Wn1 D1, W2 = Wn2 D2 -> beta = D1^-1 beta_n D2.
    beta = beta_n * scale[folded][None, :] / scale[kept][:, None]
    beta[np.abs(beta) < 1e-10 * max(1.0, np.abs(beta).max())] = 0.0
    K = np.zeros((rank, n))
    K[np.arange(rank), kept] = 1.0
    K[:, folded] = beta
    order = np.argsort(kept)  # present in the standard order
    K, kept = K[order], kept[order]
    standard = standard_parameter_names(desc)
    names = tuple(
        standard[k] + ("*" if np.count_nonzero(row) > 1 else "")
        for k, row in zip(kept, K, strict=True)
    )
    report = RankReport(
        rank,
        n_states,
        tol,
        float(rel[rank - 1]),
        float(rel[rank]) if rank < len(rel) else 0.0,
        n,
    )
    if report.smallest_kept < RANK_MARGIN * tol or report.largest_dropped > tol / RANK_MARGIN:
        warnings.warn(
            f"ill-determined numerical {report}: a singular value lies within a factor "
            f"{RANK_MARGIN:g} of the tolerance, so some parameters barely act on the forces "
            "of these states (an axis nearly parallel to gravity, a weak excitation); the "
            "rank may change with the tolerance or the states",
            BaseParameterWarning,
            stacklevel=2,
        )
    chi = standard_parameters(desc)
    return BaseParameters(names, K, kept, K @ chi, robot, standard), report


def base_parameters(robot: RobotLike, method: str = "analytic", **kwargs: Any) -> BaseParameters:
    """The base parameters of ``robot`` (a :class:`~stewart_pin.StewartRobot`), bound to it.

    Args:
        method: ``"analytic"`` (named parameters with their grouping relations: the
            paper's 88 on a general ideal 6-UPS robot, fewer when gravity is parallel to
            first U-joint axes or zero; general legs with their joint terms: see
            :func:`analytic_base_parameters`) or ``"numerical"`` (QR; ``kwargs`` go to
            :func:`numerical_base_parameters`).

    A robot with ``custom`` legs, which the analytic rules do not cover, gets the
    numerical set for ``"analytic"`` too, with a :class:`BaseParameterWarning` saying so.
    """
    if method not in ("analytic", "numerical"):
        raise InputError(f"unknown method '{method}': 'analytic' or 'numerical'")
    desc = robot.description
    if method == "analytic" and not reference_path(desc).analytic_rules:
        warnings.warn(
            f"the analytic base parameters have no rules for {desc.architecture} legs: robot "
            f"'{desc.name}' gets the numerical base parameters (QR of the stacked "
            "regressor) instead",
            BaseParameterWarning,
            stacklevel=2,
        )
        method = "numerical"
    if method == "analytic" and uncovered_legs(desc):
        warnings.warn(
            f"the analytic base parameters cover the legs ups, ups-offset, rus and pus; "
            f"robot '{desc.name}' has custom legs {uncovered_legs(desc)}: using the "
            "numerical base parameters (QR of the stacked regressor) instead",
            BaseParameterWarning,
            stacklevel=2,
        )
        method = "numerical"
    if method == "analytic":
        bp = analytic_base_parameters(desc)
    else:
        bp, _ = numerical_base_parameters(robot, **kwargs)
    return replace(bp, robot=robot)


@dataclass(frozen=True)
class EssentialParameters:
    """A subset of the base parameters that predicts the forces within ``threshold``.

    Attributes:
        names: the essential parameters kept (a subset of the base names).
        values: their base values.
        index: their positions in the base set.
        relative_error: ``||Gamma - W_e chi_e|| / ||Gamma||`` over those states.
        removal_order: the base parameters removed, first removed first, with the relative
            force error after each removal.
        threshold, n_states: the criterion and the number of states it was evaluated on.
    """

    names: tuple[str, ...]
    values: np.ndarray
    index: np.ndarray
    relative_error: float
    removal_order: tuple[tuple[str, float], ...]
    threshold: float
    n_states: int

    def __len__(self) -> int:
        return len(self.names)


def essential_parameters(
    robot: RobotLike,
    threshold: float = 0.01,
    n_states: int = 100,
    seed: int = 0,
    base: BaseParameters | None = None,
) -> EssentialParameters:
    """The essential parameters: the base parameters left when those whose removal changes
    the predicted forces by less than ``threshold`` are removed.

    The change is ``||sum_removed W_k chi_k|| / ||Gamma||`` (2-norms over ``n_states``
    random workspace states with random twists and accelerations, a broad excitation),
    the other parameters keeping their values. Greedy: at each step the parameter whose
    removal keeps that change smallest goes, until the next would pass the threshold.
    Parameters that vanish by symmetry (as the paper's symmetric links make many) go
    first, at zero cost. ``values`` are the robot's base values of the kept parameters.
    """
    threshold = check_scalar(threshold, "threshold", positive=True)
    bp = base if base is not None else base_parameters(robot)
    W = bp.reduce(stacked_regressor(robot, n_states, seed))
    parts = W * bp.values  # column k: the forces parameter k accounts for
    gamma = parts.sum(axis=1)
    norm = np.linalg.norm(gamma)
    if norm == 0:
        raise IdentificationError("the robot's forces are zero over the states: nothing to keep")
    active = list(range(len(bp)))
    removed: list[tuple[str, float]] = []
    dropped = np.zeros_like(gamma)
    while len(active) > 1:
        trials = np.linalg.norm(dropped[:, None] + parts[:, active], axis=0) / norm
        best = int(np.argmin(trials))
        if trials[best] > threshold:
            break
        dropped += parts[:, active[best]]
        removed.append((bp.names[active[best]], float(trials[best])))
        del active[best]
    idx = np.array(active)
    return EssentialParameters(
        tuple(bp.names[k] for k in idx),
        bp.values[idx],
        idx,
        float(np.linalg.norm(dropped) / norm),
        tuple(removed),
        threshold,
        n_states,
    )


#: The paper's Table III per leg (read from the OCR text, whose table is partly garbled):
#: with symmetric links, and links 1 and 2 forming one real body, these 7 per leg and the
#: platform's 10 remain: 6 x 7 + 10 = 52.
PAPER_ESSENTIAL_PER_LEG = ("ZZ1R", "XX2R", "ZZ2R", "MY2", "MX3", "MY3", "MZ3")


def paper_essential_parameters(
    robot: RobotLike, n_states: int = 100, seed: int = 0
) -> EssentialParameters:
    """The paper's 52 essential parameters (Table III), with the relative force error of
    keeping only them (zero to round-off for a robot meeting the paper's assumptions).
    Taken from the paper's 88 (:func:`grouped_parameters`) on every geometry (ideal
    6-UPS robots only)."""
    bp = grouped_parameters(robot.description)
    keep = [f"{p}_{i}" for i in range(1, 7) for p in PAPER_ESSENTIAL_PER_LEG]
    keep += [n for n in bp.names if n.endswith("_RP")]
    idx = np.array(sorted(bp.names.index(n) for n in keep))
    W = bp.reduce(stacked_regressor(robot, n_states, seed))
    parts = W * bp.values
    gamma = parts.sum(axis=1)
    dropped = np.setdiff1d(np.arange(len(bp)), idx)
    error = float(np.linalg.norm(parts[:, dropped].sum(axis=1)) / np.linalg.norm(gamma))
    return EssentialParameters(
        tuple(bp.names[k] for k in idx),
        bp.values[idx],
        idx,
        error,
        tuple((bp.names[k], float("nan")) for k in dropped),
        0.0,
        n_states,
    )
