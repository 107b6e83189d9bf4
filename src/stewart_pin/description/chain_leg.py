"""Chain legs: a leg as any serial chain of 1-dof joints closed at the platform by a ball
(3 constraints) or a weld (6 constraints), every link massive (Khalil & Ibrahim 2007;
``docs/legs.md``, section "Chain legs and welds").

Frames and units (SI) as :mod:`stewart_pin.description.leg_architecture`: frame ``0i`` of
leg i is placed by the robot (``B_i``, ``R_i`` in F0); joint j places frame j from frame
j-1 as ``Rx(alpha_j) Tx(d_j) Rz(theta_j) Tz(r_j)`` (modified DH), its value added to
``theta_j`` (revolute) or ``r_j`` (prismatic); link j's ten inertial parameters (Khalil's
order ``XX XY XZ YY YZ ZZ MX MY MZ M``) are in frame j about its origin; its gravity
compensation ``gravcomp[j]`` (MJCF ``gravcomp``, 1 for an SDF link without gravity) is the
fraction of its weight removed: its weight is ``(1 - c_j) m_j g`` at its centre of mass.

The closure of leg i:

- ``"ball"``: the point ``tip`` of the last link (in its frame n) is the platform point
  ``P_i`` (``platform_points[i]`` in Fp); 3 constraints.
- ``"weld"``: the attachment frame ``(tip, tip_rotation)`` of the last link (in frame n)
  coincides with the platform's attachment frame ``(P_i, platform_rotation)`` (in Fp);
  6 constraints: the leg's tip orientation is fixed by the platform's pose.

Mobility: with its actuated joint free, a leg must give the platform its six degrees of
freedom, so a leg has as many joints as its closure has constraints (``n = 3`` ball,
``n = 6`` weld) and its Jacobian is regular at the home pose (checked when the robot is
built). Fewer joints leave the platform short of freedoms; one more is an idle freedom
(the spin of an R-S-S rod about its ball-to-ball line), accepted when ``idle_joint`` names
the joint that is its coordinate (part of the robot's state:
:class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`); more are extra
freedoms. The others are refused with :class:`~stewart_pin.exceptions.LegMobilityError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_items, project_rotation
from stewart_pin.description.inertia import check_physical_bodies
from stewart_pin.description.leg_architecture import Joint, LegArchitecture
from stewart_pin.exceptions import (
    ArchitectureError,
    GravityCompensationError,
    InputError,
    LegMobilityError,
)

#: The closures and the number of constraints each imposes.
CLOSURES = {"ball": 3, "weld": 6}
#: The architecture name of every chain leg.
CHAIN = "chain"


@dataclass(frozen=True, eq=False)
class ChainLeg:
    """A leg: any serial chain of 1-dof joints, one actuated, closed by a ball or a weld.

    Attributes:
        joints: n :class:`~stewart_pin.description.leg_architecture.Joint` from the base.
        actuated: the actuated joint, 1..n.
        closure: ``"ball"`` (3 constraints) or ``"weld"`` (6).
        inertia: (n, 10) Khalil's parameters of links 1..n, each in its frame about its
            origin [kg, kg m, kg m^2].
        tip: (3,) the ball centre / the attachment frame's origin in frame n [m].
        tip_rotation: (3, 3) the attachment frame's orientation in frame n (weld).
        platform_rotation: (3, 3) the platform-side attachment frame's orientation in Fp
            (weld; its origin is ``P_i``).
        guess: (n,) joint values [rad or m] near the home pose's: the start of the leg's
            Newton at the home pose (for an idle joint: its value at home).
        name: :data:`CHAIN`.
        idle_joint: for a leg with one joint more than its closure's constraints (an idle
            freedom, e.g. an R-S-S rod's spin about its ball-to-ball line), the joint
            (1..n, not the actuated one) whose value and rate are part of the robot's
            state: the idle freedom's coordinate; ``None`` otherwise.
        gravcomp: (n,) each link's gravity compensation, the fraction of its weight
            removed (finite, in [0, 1]; ``None``: zeros, every link its full weight).
    """

    joints: tuple[Joint, ...]
    actuated: int
    closure: str = "ball"
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((0, 10)))
    tip: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tip_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    platform_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    # None (zeros) is accepted at construction; __post_init__ stores an (n,) array
    guess: np.ndarray = None  # type: ignore[assignment]
    name: str = CHAIN
    idle_joint: int | None = None
    # None (zeros) is accepted at construction; __post_init__ stores an (n,) array
    gravcomp: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        joints = check_items(
            self.joints,
            Joint,
            None,
            ("a chain leg", "chain", "1-dof joints"),
            lambda message: ArchitectureError(message, "joints", self.joints),
        )
        object.__setattr__(self, "joints", joints)
        n = len(joints)
        if self.closure not in CLOSURES:
            raise ArchitectureError(
                f"closure must be one of {tuple(CLOSURES)}, got {self.closure!r}",
                "closure",
                self.closure,
            )
        a = self.actuated
        if isinstance(a, bool) or not isinstance(a, (int, np.integer)) or not 1 <= a <= n:
            raise ArchitectureError(
                f"the actuated joint index must be 1..{n}, got {a!r}", "actuated", a
            )
        object.__setattr__(self, "actuated", int(a))
        i = self.idle_joint
        if i is not None:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 1 <= i <= n:
                raise ArchitectureError(
                    f"the idle joint index must be 1..{n} or None, got {i!r}", "idle_joint", i
                )
            if i == self.actuated:
                raise ArchitectureError(
                    f"the idle joint ({i}) cannot be the actuated joint", "idle_joint", i
                )
            object.__setattr__(self, "idle_joint", int(i))
        if self.name != CHAIN:
            raise ArchitectureError(
                f"a chain leg's name is '{CHAIN}', got {self.name!r}", "name", self.name
            )
        arrays = {"tip": (3,), "inertia": (n, 10), "guess": (n,)}
        for key, shape in arrays.items():
            value = getattr(self, key)
            if key == "guess" and value is None:
                value = np.zeros(n)
            try:
                value = check_array(value, shape, key)
            except InputError as e:
                raise ArchitectureError(f"chain leg: {e}", key, getattr(self, key)) from e
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        for key in ("tip_rotation", "platform_rotation"):
            try:
                R = project_rotation(check_array(getattr(self, key), (3, 3), key), key)
            except InputError as e:
                raise ArchitectureError(f"chain leg: {e}", key, getattr(self, key)) from e
            R.flags.writeable = False
            object.__setattr__(self, key, R)
        check_physical_bodies(self.inertia, lambda j: f"chain leg link {j + 1}")
        self._check_gravcomp(n)

    def _check_gravcomp(self, n: int) -> None:
        """``gravcomp``: ``None`` (zeros) or n factors, each :func:`gravcomp_factor`."""
        value = self.gravcomp
        out = np.zeros(n)
        if value is not None:
            rows = value.tolist() if isinstance(value, np.ndarray) else value
            if not isinstance(rows, (list, tuple)) or len(rows) != n:
                raise GravityCompensationError(
                    f"a chain leg's gravcomp must be {n} factors (one per link, links "
                    f"1..{n}), got {_short(value)}",
                    "gravcomp",
                    value,
                )
            for j, x in enumerate(rows):
                out[j] = gravcomp_factor(x, f"chain leg link {j + 1}")
        out.flags.writeable = False
        object.__setattr__(self, "gravcomp", out)

    def check_mobility(self, leg: int) -> None:
        """As many joints as constraints, else :class:`LegMobilityError` naming ``leg``
        (1-based) and the missing or extra freedoms (the robot checks it)."""
        n, c = len(self.joints), self.constraints
        closure = f"a {self.closure} ({c} constraints)"
        if n == c + 1 and self.idle_joint is not None:
            return
        if self.idle_joint is not None:
            raise LegMobilityError(
                f"leg {leg}: idle_joint = {self.idle_joint} names an idle freedom, but a chain "
                f"of {n} joints closed by {closure} has none (an idle freedom needs {c + 1} "
                "joints): leave idle_joint out",
                leg,
            )
        if n == c:
            return
        if n < c:
            raise LegMobilityError(
                f"leg {leg}: a chain of {n} joints closed by {closure} leaves the platform "
                f"{c - n} freedom(s) short of six: give the leg {c} joints",
                leg,
                missing=c - n,
            )
        if n == c + 1:
            raise LegMobilityError(
                f"leg {leg}: a chain of {n} joints closed by {closure} has one idle freedom "
                "(e.g. an R-S-S or S-P-S rod spinning about its ball-to-ball line): name the "
                "joint whose value and rate are its coordinate (idle_joint, part of the "
                f"robot's state), or give the leg {c} joints",
                leg,
                extra=1,
            )
        raise LegMobilityError(
            f"leg {leg}: a chain of {n} joints closed by {closure} has {n - c} extra "
            f"freedoms: the actuators would not hold the platform; give the leg {c} joints",
            leg,
            extra=n - c,
        )

    # ------------------------------------------------------------------ derived
    @property
    def constraints(self) -> int:
        """3 (ball) or 6 (weld)."""
        return CLOSURES[self.closure]

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def has_idle(self) -> bool:
        """Whether the leg has an idle freedom (``idle_joint``)."""
        return self.idle_joint is not None

    @property
    def revolute(self) -> np.ndarray:
        """(n,) bool, the revolute joints."""
        return np.array([j.revolute for j in self.joints])

    @property
    def limits(self) -> np.ndarray:
        """Joint limits, shape (n, 2) ``[lower, upper]``."""
        return np.array([[j.lower, j.upper] for j in self.joints])

    @property
    def armature(self) -> np.ndarray:
        """Joint-side armatures (rotor inertia reflected), shape (n,)."""
        return np.array([j.dynamics.total_armature for j in self.joints])

    @property
    def effort_unit(self) -> str:
        """``"N"`` for a prismatic actuated joint, ``"N m"`` for a revolute one."""
        return "N m" if self.joints[self.actuated - 1].revolute else "N"

    @property
    def position_unit(self) -> str:
        return "rad" if self.joints[self.actuated - 1].revolute else "m"

    def attachment(self) -> np.ndarray:
        """The attachment frame (ball: only its origin matters) in frame n, 4x4."""
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.tip_rotation, self.tip
        return T

    def replace(self, **changes: Any) -> ChainLeg:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def from_architecture(cls, leg: LegArchitecture, inertia: Any) -> ChainLeg:
        """A three-joint ball :class:`LegArchitecture` (closed forms, today's model) as a
        chain leg with its three links' parameters ``inertia`` (3, 10): for robots that mix
        such legs with welded ones. Its ``guess`` is the leg's (give the home configuration's
        with :meth:`replace` when the leg is named: closed forms need none)."""
        return cls(leg.joints, leg.actuated, "ball", np.asarray(inertia), leg.tip, guess=leg.guess)


def check_chain_legs(value: Any) -> tuple[ChainLeg, ...]:
    """Six :class:`ChainLeg`, each with as many joints as constraints
    (:class:`ArchitectureError`, :class:`LegMobilityError` otherwise)."""
    legs = check_items(
        value,
        ChainLeg,
        6,
        ("chain_legs", "list", "legs"),
        lambda message: ArchitectureError(message, "chain_legs", value),
    )
    for i, leg in enumerate(legs):
        leg.check_mobility(i + 1)
    return legs


def gravcomp_factor(value: Any, body: str) -> float:
    """A body's gravity compensation: a finite number in [0, 1] (the fraction of its
    weight removed), else :class:`GravityCompensationError` naming the body."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise GravityCompensationError(
            f"gravity compensation of the {body} must be a number in [0, 1] (the fraction of "
            f"its weight removed), got {_short(value)}",
            body,
            value,
        )
    c = float(value)
    if not (math.isfinite(c) and 0.0 <= c <= 1.0):
        raise GravityCompensationError(
            f"gravity compensation of the {body} must be in [0, 1] (the fraction of its "
            f"weight removed: 0 none, 1 all), got {c!r}",
            body,
            value,
        )
    return c + 0.0  # -0.0 as 0.0


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def full_turn(lower: Any, upper: Any) -> Any:
    """Whether a revolute range ``[lower, upper]`` [rad] spans a full turn (CAD exports
    write ``0..2 pi``): such a hinge limits nothing, its angle is taken modulo 2 pi."""
    return np.asarray(upper) - np.asarray(lower) >= 2.0 * math.pi - 1e-9


__all__ = ["CHAIN", "CLOSURES", "ChainLeg", "check_chain_legs", "full_turn", "gravcomp_factor"]
