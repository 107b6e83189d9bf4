"""Leg architectures: any leg that is a chain of three 1-dof joints ending in a passive
spherical joint on the platform (``general-legs.md``; Khalil & Ibrahim 2007):
:class:`JointDynamics`, :class:`Joint`, :class:`LegArchitecture` and the builders
:func:`ups`, :func:`ups_offset`, :func:`rus`, :func:`pus`. The robot that holds six legs is
:class:`~stewart_pin.description.leg_chain_hexapod.GeneralHexapod`; generators and presets
are in :mod:`stewart_pin.description.leg_chain_presets`.

Frames (Khalil-Kleinfinger modified DH, SI units):

- Frame ``0i`` of leg i is placed by the robot: origin ``B_i`` and orientation
  ``R_i = leg_base_rotations[i]`` in F0 (for 6-UPS: the first U-joint frame at q1i = 0,
  exactly today's convention ``0T1i = [R_i, B_i] Rz(q1i)``).
- Joint j of the leg places frame j from frame j-1 as
  ``Rx(alpha_j) Tx(d_j) Rz(theta_j) Tz(r_j)``, with the joint value q_j added to
  ``theta_j`` (revolute) or ``r_j`` (prismatic): the joint axis is z_j.
- ``tip`` is the spherical-joint centre P_i in the last joint's frame 3i.
- A link's 10 inertial parameters (Khalil's order) are given in its own frame j, about
  its origin, as in :mod:`stewart_pin.description.robot_description`.

Joint and actuator dynamics (:class:`JointDynamics`) add to joint j's effort
``Ia qddot + Fv qdot + Fc sign(qdot) + K (q - q0) + D qdot``; ``sign(0) = 0``: at zero
velocity the Coulomb term is zero (no stiction model), in the inverse and the direct model.

Branches of the closed-form inverse geometry (``LegArchitecture.branch``, +1 or -1):

- ``ups``, ``ups-offset``: +1 when P_i has a positive coordinate along x1i (for 6-UPS:
  ``q2i`` in (0, pi), today's default), -1 for the other U-joint solution (q1i + pi).
- ``rus``: +1 when ``(P_i - C_i) . (z1i x (C_i - O1i)) > 0``: the rod points along the
  crank tip's velocity for a positive crank rate (C_i the universal-joint centre).
- ``pus``: +1 when ``(P_i - C_i) . z1i > 0``: P_i ahead of the slide along the rail.

For ``rus`` and ``pus`` the universal joint (joints 2, 3) always takes the solution
``psi3 = atan2(b, a) - acos(k / hypot(a, b))`` of its equation (see
:mod:`stewart_pin.kinematics.leg_chains`): for the builders' rods (along x3, alpha3 = pi/2)
the one with ``|q3i| <= pi/2``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_items
from stewart_pin.exceptions import (
    ArchitectureError,
    InputError,
    JointDynamicsError,
)

#: Names of the architectures; all but ``custom`` have a closed-form inverse geometry.
ARCHITECTURES = ("ups", "ups-offset", "rus", "pus", "custom")
#: Joint kinds.
REVOLUTE, PRISMATIC = "revolute", "prismatic"
#: Joint rates [rad/s or m/s] at or below this magnitude count as zero for the Coulomb
#: term ``Fc sign(qdot)``: a rate that is zero in exact arithmetic (a joint at rest in a
#: symmetric motion) comes out of the kinematics as round-off (~1e-17), and its sign must
#: not decide a full +-Fc. Used by the model and by the independent check alike.
COULOMB_DEAD_BAND = 1e-12


def coulomb_sign(qdot: np.ndarray) -> np.ndarray:
    """``sign(qdot)`` with rates within :data:`COULOMB_DEAD_BAND` of zero counted as zero."""
    qdot = np.asarray(qdot, dtype=float)
    return np.where(np.abs(qdot) <= COULOMB_DEAD_BAND, 0.0, np.sign(qdot))


#: Tolerance on the structural parameters a named architecture fixes (alpha = pi/2...).
STRUCTURE_TOLERANCE = 1e-12


def wrap_into_limits(
    q: np.ndarray, revolute: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """Revolute joint values taken modulo 2 pi into their limits.

    A revolute joint value ``q`` [rad] outside ``[lower, upper]`` is replaced by its
    representative ``q + 2 pi k`` inside the interval when one exists (the smallest one
    above ``lower``; with ``lower = -inf``, the largest below ``upper``), else by the
    representative nearest the interval (so that a refusal names the nearest limit).
    Values inside their limits, prismatic joints and joints without limits are unchanged.

    Args:
        q: joint values, shape (..., 6, 3) [rad or m].
        revolute: bool, shape (6, 3). lower, upper: limits, shape (6, 3) [rad or m].

    Returns:
        the values, shape of ``q``.
    """
    q = np.asarray(q, dtype=float)
    lower, upper = np.broadcast_to(lower, q.shape), np.broadcast_to(upper, q.shape)
    outside = revolute & ((q < lower) | (q > upper))
    if not np.any(outside):  # the common case: nothing to wrap (np.mod is slow)
        return q.copy()  # a new array, as when some value is wrapped
    x, lo, up = q[outside], lower[outside], upper[outside]
    two_pi = 2.0 * math.pi
    with np.errstate(invalid="ignore"):  # inf - inf for joints without limits: not used
        rep = np.where(np.isfinite(lo), lo + np.mod(x - lo, two_pi), up - np.mod(up - x, two_pi))
        below = rep - two_pi
        rep = np.where((rep > up) & (lo - below < rep - up), below, rep)
    out = q.copy()
    out[outside] = np.where(np.isfinite(rep), rep, x)
    return out


def _is_real(value: Any) -> bool:
    """A real number (Python or numpy), not a boolean."""
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))


# ---------------------------------------------------------------------------- transforms
def mdh_transform(alpha: float, d: float, theta: float, r: float) -> np.ndarray:
    """``Rx(alpha) Tx(d) Rz(theta) Tz(r)`` as a 4x4 matrix (Khalil-Kleinfinger)."""
    ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(theta), math.sin(theta)
    return np.array(
        [
            [ct, -st, 0.0, d],
            [ca * st, ca * ct, -sa, -r * sa],
            [sa * st, sa * ct, ca, r * ca],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


# ---------------------------------------------------------------------------- joint terms
@dataclass(frozen=True)
class JointDynamics:
    """A joint's own dynamics and its actuator's transmission (all >= 0, SI units).

    Attributes:
        armature: ``Ia`` added to the joint's inertia [kg m^2 revolute, kg prismatic].
        viscous: viscous friction ``Fv`` [N m s/rad or N s/m].
        coulomb: Coulomb friction ``Fc`` [N m or N]; the effort ``Fc sign(qdot)`` is 0 at
            ``qdot = 0`` (no stiction).
        stiffness: spring ``K`` [N m/rad or N/m] about ``rest_position`` [rad or m].
        damping: damper ``D`` [N m s/rad or N s/m] (adds to ``viscous``).
        gear_ratio: ``N`` of a gear (joint rate = motor rate / N), or ``None``.
        screw_lead: lead of a ball screw [m/rev] (joint rate = lead / (2 pi) motor
            rate), or ``None``; at most one of the two.
        rotor_inertia: the motor rotor's inertia [kg m^2], reflected to the joint as
            ``N^2 J`` (gear) or ``(2 pi / lead)^2 J`` (screw), ``J`` without transmission.
    """

    armature: float = 0.0
    viscous: float = 0.0
    coulomb: float = 0.0
    stiffness: float = 0.0
    rest_position: float = 0.0
    damping: float = 0.0
    gear_ratio: float | None = None
    screw_lead: float | None = None
    rotor_inertia: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "armature",
            "viscous",
            "coulomb",
            "stiffness",
            "rest_position",
            "damping",
            "rotor_inertia",
        ):
            value = getattr(self, name)
            if not _is_real(value):
                raise JointDynamicsError(
                    f"joint dynamics {name} must be a real number, got {value!r}", name, value
                )
            if not math.isfinite(value):
                raise JointDynamicsError(
                    f"joint dynamics {name} must be finite, got {value!r}", name, value
                )
            if name != "rest_position" and value < 0:
                raise JointDynamicsError(
                    f"joint dynamics {name} = {value!r} is negative: a real joint's "
                    f"{name} is zero or positive (a negative one would create energy)",
                    name,
                    value,
                )
            object.__setattr__(self, name, float(value))
        if self.gear_ratio is not None and self.screw_lead is not None:
            raise JointDynamicsError(
                "give a gear_ratio or a screw_lead, not both", "screw_lead", self.screw_lead
            )
        for name in ("gear_ratio", "screw_lead"):
            value = getattr(self, name)
            if value is None:
                continue
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float, np.integer, np.floating))
                or not math.isfinite(value)
                or value <= 0
            ):
                raise JointDynamicsError(
                    f"joint dynamics {name} must be a positive finite number, got {value!r}",
                    name,
                    value,
                )
            object.__setattr__(self, name, float(value))
        try:
            reflected = self.transmission_ratio**2 * self.rotor_inertia
        except OverflowError:
            reflected = math.inf
        if not math.isfinite(self.armature + reflected):
            raise JointDynamicsError(
                f"joint dynamics: the reflected rotor inertia ratio^2 * rotor_inertia "
                f"(ratio {self.transmission_ratio:.3g}, rotor_inertia {self.rotor_inertia:.3g}) "
                "overflows; give a realistic gear_ratio / screw_lead",
                "rotor_inertia",
                self.rotor_inertia,
            )

    @property
    def transmission_ratio(self) -> float:
        """Motor rate per joint rate: ``N``, ``2 pi / lead`` [rad/m], or 1 without one."""
        if self.gear_ratio is not None:
            return self.gear_ratio
        if self.screw_lead is not None:
            return 2.0 * math.pi / self.screw_lead
        return 1.0

    @property
    def total_armature(self) -> float:
        """``armature + ratio^2 rotor_inertia`` [kg m^2 or kg]: the joint-side armature."""
        return self.armature + self.transmission_ratio**2 * self.rotor_inertia

    @property
    def has_transmission(self) -> bool:
        return self.gear_ratio is not None or self.screw_lead is not None

    def motor_effort(self, joint_effort: Any) -> Any:
        """Motor torque [N m] from the joint-side effort [N m or N] through an ideal
        transmission: ``effort / ratio`` (the rotor's inertia is in the joint-side effort
        already, reflected)."""
        return np.asarray(joint_effort, dtype=float) / self.transmission_ratio

    @property
    def is_zero(self) -> bool:
        return (
            self.total_armature == 0.0
            and self.viscous == 0.0
            and self.coulomb == 0.0
            and self.stiffness == 0.0
            and self.damping == 0.0
        )


# ---------------------------------------------------------------------------- joints
@dataclass(frozen=True)
class Joint:
    """One 1-dof joint of a leg: its kind, MDH placement from the previous joint frame,
    limits and dynamics.

    Attributes:
        kind: ``"revolute"`` or ``"prismatic"``.
        alpha, d, theta, r: ``Rx(alpha) Tx(d) Rz(theta) Tz(r)`` [rad, m, rad, m]; the
            joint value adds to ``theta`` (revolute) or ``r`` (prismatic).
        lower, upper: limits of the joint value [rad or m] (infinite: none). A revolute
            joint's value is an angle, compared with its limits modulo 2 pi (see
            :func:`wrap_into_limits`): limits such as ``[3.0, 3.4]`` rad, outside the
            inverse geometry's ``(-pi, pi]``, are allowed.
        dynamics: the joint's :class:`JointDynamics`.
    """

    kind: str
    alpha: float = 0.0
    d: float = 0.0
    theta: float = 0.0
    r: float = 0.0
    lower: float = -math.inf
    upper: float = math.inf
    dynamics: JointDynamics = field(default_factory=JointDynamics)

    def __post_init__(self) -> None:
        if self.kind not in (REVOLUTE, PRISMATIC):
            raise ArchitectureError(
                f"joint kind must be '{REVOLUTE}' or '{PRISMATIC}' (a 1-dof joint), got "
                f"{self.kind!r}",
                "kind",
                self.kind,
            )
        for name in ("alpha", "d", "theta", "r", "lower", "upper"):
            value = getattr(self, name)
            if not _is_real(value):
                raise ArchitectureError(
                    f"joint {name} must be a real number, got {value!r}", name, value
                )
            if name not in ("lower", "upper") and not math.isfinite(value):
                raise ArchitectureError(f"joint {name} must be finite, got {value!r}", name, value)
            object.__setattr__(self, name, float(value))
        if math.isnan(self.lower) or math.isnan(self.upper) or not self.lower < self.upper:
            raise ArchitectureError(
                f"joint limits must satisfy lower < upper, got [{self.lower}, {self.upper}]",
                "lower",
                (self.lower, self.upper),
            )
        if not isinstance(self.dynamics, JointDynamics):
            raise ArchitectureError(
                f"joint dynamics must be a JointDynamics, got {type(self.dynamics).__name__}",
                "dynamics",
                self.dynamics,
            )

    @property
    def revolute(self) -> bool:
        return self.kind == REVOLUTE

    def placement(self) -> np.ndarray:
        """The constant part of the joint's transform (q = 0), 4x4."""
        return mdh_transform(self.alpha, self.d, self.theta, self.r)

    def transform(self, q: float) -> np.ndarray:
        """Frame j in frame j-1 at joint value ``q``, 4x4."""
        if self.revolute:
            return mdh_transform(self.alpha, self.d, self.theta + q, self.r)
        return mdh_transform(self.alpha, self.d, self.theta, self.r + q)


def revolute(
    alpha: float = 0.0, d: float = 0.0, theta: float = 0.0, r: float = 0.0, **kw: Any
) -> Joint:
    """A revolute :class:`Joint` (keyword arguments ``lower``, ``upper``, ``dynamics``)."""
    return Joint(REVOLUTE, alpha, d, theta, r, **kw)


def prismatic(
    alpha: float = 0.0, d: float = 0.0, theta: float = 0.0, r: float = 0.0, **kw: Any
) -> Joint:
    """A prismatic :class:`Joint` (keyword arguments ``lower``, ``upper``, ``dynamics``)."""
    return Joint(PRISMATIC, alpha, d, theta, r, **kw)


# ---------------------------------------------------------------------------- the leg
@dataclass(frozen=True, eq=False)
class LegArchitecture:
    """A leg: three 1-dof joints from the base to the spherical joint, one actuated.

    Attributes:
        joints: three :class:`Joint`.
        actuated: the actuated joint, 1, 2 or 3.
        tip: shape (3,), the spherical-joint centre P_i in frame 3i [m].
        branch: +1 or -1, the closed-form inverse geometry's solution (module docstring).
        name: one of :data:`ARCHITECTURES`; a named architecture's structure is checked.
        guess: shape (3,), start of the numerical inverse geometry (``custom``).
    """

    joints: tuple[Joint, ...]
    actuated: int
    tip: np.ndarray = field(default_factory=lambda: np.zeros(3))
    branch: int = 1
    name: str = "custom"
    guess: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        joints = check_items(
            self.joints,
            Joint,
            3,
            ("a leg", "chain", "1-dof joints"),
            lambda message: ArchitectureError(message, "joints", self.joints),
        )
        object.__setattr__(self, "joints", joints)
        a = self.actuated
        if isinstance(a, bool) or not isinstance(a, (int, np.integer)) or a not in (1, 2, 3):
            raise ArchitectureError(
                f"the actuated joint index must be 1, 2 or 3, got {a!r}", "actuated", a
            )
        object.__setattr__(self, "actuated", int(a))
        if self.branch not in (1, -1) or isinstance(self.branch, bool):
            raise ArchitectureError(
                f"branch must be +1 or -1, got {self.branch!r}", "branch", self.branch
            )
        object.__setattr__(self, "branch", int(self.branch))
        for key in ("tip", "guess"):
            try:
                value = check_array(getattr(self, key), (3,), key)
            except InputError as e:
                raise ArchitectureError(str(e), key, getattr(self, key)) from e
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        if self.name not in ARCHITECTURES:
            raise ArchitectureError(
                f"architecture name must be one of {ARCHITECTURES}, got {self.name!r}",
                "name",
                self.name,
            )
        self._check_structure()

    def _check_structure(self) -> None:
        """The structure the named architecture's closed form relies on."""
        kinds = tuple(j.kind[0].upper() for j in self.joints)
        _, j2, j3 = self.joints
        tol = STRUCTURE_TOLERANCE

        def need(ok: bool, what: str) -> None:
            if not ok:
                raise ArchitectureError(
                    f"a '{self.name}' leg needs {what} (use name='custom' for another chain)",
                    "joints",
                    self.joints,
                )

        if self.name in ("ups", "ups-offset"):
            need(kinds == ("R", "R", "P"), "joints R, R, P")
            need(abs(j2.alpha - math.pi / 2) <= tol, "alpha2 = pi/2")
            need(j2.theta == 0.0 and j2.r == 0.0, "theta2 = r2 = 0")
            need(abs(j3.alpha - math.pi / 2) <= tol, "alpha3 = pi/2")
            need(j3.d == 0.0 and j3.theta == 0.0 and j3.r == 0.0, "d3 = theta3 = r3 = 0")
            need(not np.any(self.tip), "the tip at the origin of frame 3")
            if self.name == "ups":
                need(j2.d == 0.0, "intersecting U-joint axes (d2 = 0; else 'ups-offset')")
        elif self.name in ("rus", "pus"):
            need(
                kinds == (("R",) if self.name == "rus" else ("P",)) + ("R", "R"),
                "joints R, R, R" if self.name == "rus" else "joints P, R, R",
            )
            need(j3.d == 0.0 and j3.r == 0.0, "intersecting U-joint axes (d3 = r3 = 0)")
            need(abs(math.sin(j3.alpha)) > 1e-6, "non-parallel U-joint axes (sin alpha3 != 0)")
            need(bool(np.linalg.norm(self.tip) > 0.0), "a rod of non-zero length (tip != 0)")
            # a rod along the second U-joint axis (z3) is not pointed by that joint
            need(
                math.hypot(self.tip[0], self.tip[1]) > 1e-6 * float(np.linalg.norm(self.tip)),
                "a rod not along its second U-joint axis (tip_x, tip_y not both 0)",
            )

    # ------------------------------------------------------------------ derived
    @property
    def kinds(self) -> tuple[str, str, str]:
        return tuple(j.kind for j in self.joints)  # type: ignore[return-value]

    @property
    def effort_unit(self) -> str:
        """The unit of the actuator's effort: ``"N"`` for a prismatic actuated joint (a
        force), ``"N m"`` for a revolute one (a torque; joint side)."""
        return "N m" if self.joints[self.actuated - 1].revolute else "N"

    @property
    def position_unit(self) -> str:
        """The unit of the actuated joint's position: ``"m"`` (prismatic) or ``"rad"``."""
        return "rad" if self.joints[self.actuated - 1].revolute else "m"

    @property
    def limits(self) -> np.ndarray:
        """Joint limits, shape (3, 2) ``[lower, upper]``."""
        return np.array([[j.lower, j.upper] for j in self.joints])

    @property
    def armature(self) -> np.ndarray:
        """Joint-side armatures (rotor inertia reflected), shape (3,)."""
        return np.array([j.dynamics.total_armature for j in self.joints])

    def replace(self, **changes: Any) -> LegArchitecture:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def with_dynamics(self, dynamics: Sequence[JointDynamics]) -> LegArchitecture:
        """A copy with the three joints' dynamics replaced."""
        joints = tuple(
            replace(j, dynamics=dyn) for j, dyn in zip(self.joints, dynamics, strict=True)
        )
        return self.replace(joints=joints)

    def transforms(self, q: Any, T_0_0i: Any = None) -> list[np.ndarray]:
        """Frames 1i, 2i, 3i at joint values ``q`` (3,), in frame 0i (or in F0 given
        ``T_0_0i``, the pose of frame 0i in F0): three 4x4 matrices."""
        q = check_array(q, (3,), "q")
        T = np.eye(4) if T_0_0i is None else np.asarray(T_0_0i, float)
        out = []
        for joint, qj in zip(self.joints, q, strict=True):
            T = T @ joint.transform(qj)
            out.append(T)
        return out

    def tip_position(self, q: Any, T_0_0i: Any = None) -> np.ndarray:
        """P_i at joint values ``q`` (3,), in frame 0i (or F0 given ``T_0_0i``) [m]."""
        T = self.transforms(q, T_0_0i)[-1]
        return T[:3, :3] @ self.tip + T[:3, 3]

    def branch_at(self, q: Any) -> int:
        """The branch (+1 / -1, module docstring) of configuration ``q`` (3,); +1 for
        ``custom``."""
        T1, T2, _ = self.transforms(q)
        P = self.tip_position(q)
        if self.name in ("ups", "ups-offset"):
            s = (P - T1[:3, 3]) @ T1[:3, 0]
        elif self.name == "rus":
            C, O1, z1 = T2[:3, 3], T1[:3, 3], T1[:3, 2]
            s = (P - C) @ np.cross(z1, C - O1)
        elif self.name == "pus":
            s = (P - T2[:3, 3]) @ T1[:3, 2]
        else:
            return 1
        return 1 if s >= 0 else -1


# ---------------------------------------------------------------------------- builders
def _three(dynamics: Sequence[JointDynamics] | None) -> tuple[JointDynamics, ...]:
    if dynamics is None:
        return (JointDynamics(),) * 3
    dynamics = tuple(dynamics)
    if len(dynamics) != 3:
        raise ArchitectureError(
            f"give the dynamics of the three joints, got {len(dynamics)}", "dynamics", dynamics
        )
    return dynamics


def ups(
    stroke: tuple[float, float] = (0.0, math.inf),
    u_limits: Any = None,
    dynamics: Sequence[JointDynamics] | None = None,
    branch: int = 1,
) -> LegArchitecture:
    """The paper's U-P-S leg: ``R(q1)``, ``R(alpha pi/2, q2)``, ``P(alpha pi/2, q3)``,
    actuated prismatic ``q3 = |B_i P_i|``, P_i at the origin of frame 3i.

    Args:
        stroke: ``[min, max]`` of q3 [m]. u_limits: (2, 2) limits of q1, q2 [rad].
        dynamics: three :class:`JointDynamics` (default none).
    """
    return _ups_like("ups", 0.0, stroke, u_limits, dynamics, branch)


def ups_offset(
    offset: float,
    stroke: tuple[float, float] = (0.0, math.inf),
    u_limits: Any = None,
    dynamics: Sequence[JointDynamics] | None = None,
    branch: int = 1,
) -> LegArchitecture:
    """A U-P-S leg whose U-joint axes do not intersect: common normal of length
    ``offset`` [m] along x1 (``d2 = offset``); the leg's line passes through the
    second axis."""
    return _ups_like("ups-offset", float(offset), stroke, u_limits, dynamics, branch)


def _ups_like(
    name: str,
    offset: float,
    stroke: Any,
    u_limits: Any,
    dynamics: Sequence[JointDynamics] | None,
    branch: int,
) -> LegArchitecture:
    d1, d2, d3 = _three(dynamics)
    lim = np.array([[-math.inf, math.inf]] * 2) if u_limits is None else np.asarray(u_limits)
    joints = (
        revolute(lower=lim[0, 0], upper=lim[0, 1], dynamics=d1),
        revolute(alpha=math.pi / 2, d=offset, lower=lim[1, 0], upper=lim[1, 1], dynamics=d2),
        prismatic(alpha=math.pi / 2, lower=stroke[0], upper=stroke[1], dynamics=d3),
    )
    return LegArchitecture(joints, 3, np.zeros(3), branch, name)


def rus(
    crank: float,
    rod: float,
    crank_limits: tuple[float, float] = (-math.inf, math.inf),
    dynamics: Sequence[JointDynamics] | None = None,
    branch: int = 1,
) -> LegArchitecture:
    """A R-U-S leg: an actuated crank of length ``crank`` [m] about z of frame 0i (the
    crank along x1), a universal joint at the crank tip (first axis parallel to the
    crank axis, second along -y2, perpendicular to it), a rod of length ``rod`` [m]
    along x3 to P_i."""
    d1, d2, d3 = _three(dynamics)
    joints = (
        revolute(lower=crank_limits[0], upper=crank_limits[1], dynamics=d1),
        revolute(d=crank, dynamics=d2),
        revolute(alpha=math.pi / 2, dynamics=d3),
    )
    return LegArchitecture(joints, 1, np.array([rod, 0.0, 0.0]), branch, "rus")


def pus(
    rod: float,
    rail_tilt: float = 0.0,
    slide_limits: tuple[float, float] = (-math.inf, math.inf),
    dynamics: Sequence[JointDynamics] | None = None,
    branch: int = 1,
) -> LegArchitecture:
    """A P-U-S leg: an actuated slide along a fixed rail (z of frame 0i tilted by
    ``rail_tilt`` [rad] about x0i: vertical or inclined as the robot's leg base rotation
    and the tilt place it), a universal joint on the slide (first axis perpendicular to
    the rail, ``alpha2 = pi/2``; second ``alpha3 = pi/2``), a rod of length ``rod`` [m]
    along x3 to P_i."""
    d1, d2, d3 = _three(dynamics)
    joints = (
        prismatic(alpha=rail_tilt, lower=slide_limits[0], upper=slide_limits[1], dynamics=d1),
        revolute(alpha=math.pi / 2, dynamics=d2),
        revolute(alpha=math.pi / 2, dynamics=d3),
    )
    return LegArchitecture(joints, 1, np.array([rod, 0.0, 0.0]), branch, "pus")


__all__ = [
    "ARCHITECTURES",
    "PRISMATIC",
    "REVOLUTE",
    "STRUCTURE_TOLERANCE",
    "Joint",
    "JointDynamics",
    "LegArchitecture",
    "mdh_transform",
    "prismatic",
    "pus",
    "revolute",
    "rus",
    "ups",
    "ups_offset",
]
