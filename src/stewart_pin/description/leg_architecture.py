"""Leg architectures: any leg that is a chain of three 1-dof joints ending in a passive
spherical joint on the platform (``docs``: ``general-legs.md``; Khalil & Ibrahim 2007).

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
import pinocchio as pin

from stewart_pin._checks import check_array, project_rotation
from stewart_pin.description.inertia import (
    check_physical,
    khalil_from_urdf_inertial,
    random_physical_khalil,
)
from stewart_pin.exceptions import (
    ArchitectureError,
    DescriptionError,
    InputError,
    JointDynamicsError,
)

#: Names of the architectures; all but ``custom`` have a closed-form inverse geometry.
ARCHITECTURES = ("ups", "ups-offset", "rus", "pus", "custom")
#: Joint kinds.
REVOLUTE, PRISMATIC = "revolute", "prismatic"
#: Tolerance on the structural parameters a named architecture fixes (alpha = pi/2...).
STRUCTURE_TOLERANCE = 1e-12


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
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
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
                or not isinstance(value, (int, float, np.floating))
                or not math.isfinite(value)
                or value <= 0
            ):
                raise JointDynamicsError(
                    f"joint dynamics {name} must be a positive finite number, got {value!r}",
                    name,
                    value,
                )
            object.__setattr__(self, name, float(value))

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
        lower, upper: limits of the joint value [rad or m] (infinite: none).
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
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
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


def revolute(alpha: float = 0.0, d: float = 0.0, theta: float = 0.0, r: float = 0.0, **kw: Any):
    """A revolute :class:`Joint` (keyword arguments ``lower``, ``upper``, ``dynamics``)."""
    return Joint(REVOLUTE, alpha, d, theta, r, **kw)


def prismatic(alpha: float = 0.0, d: float = 0.0, theta: float = 0.0, r: float = 0.0, **kw: Any):
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
        joints = self.joints
        if isinstance(joints, Joint) or not isinstance(joints, Sequence):
            raise ArchitectureError(
                f"a leg is a sequence of three 1-dof joints, got {type(joints).__name__}",
                "joints",
                joints,
            )
        joints = tuple(joints)
        if len(joints) != 3 or not all(isinstance(j, Joint) for j in joints):
            raise ArchitectureError(
                f"a leg must be a chain of exactly three 1-dof joints (Joint), got "
                f"{len(joints)} item(s) of types {[type(j).__name__ for j in joints]}",
                "joints",
                joints,
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

    # ------------------------------------------------------------------ derived
    @property
    def kinds(self) -> tuple[str, str, str]:
        return tuple(j.kind for j in self.joints)  # type: ignore[return-value]

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
    actuated prismatic q3 = |B_i P_i|, P_i at the origin of frame 3i.

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


def _ups_like(name, offset, stroke, u_limits, dynamics, branch) -> LegArchitecture:
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


# ---------------------------------------------------------------------------- the robot
@dataclass(frozen=True, eq=False)
class GeneralHexapod:
    """A Gough-Stewart robot with general three-joint legs.

    Attributes:
        base_points: (6, 3) B_i, origin of leg frame 0i in F0 [m].
        leg_base_rotations: (6, 3, 3) orientation of frame 0i in F0.
        platform_points: (6, 3) P_i in Fp [m].
        legs: six :class:`LegArchitecture`.
        leg_inertia: (6, 3, 10) Khalil's parameters of link j of leg i in frame ji.
        platform_inertia: (10,) the platform's, in Fp about O_p.
        gravity: (3,) in F0 [m/s^2].
        home_pose: (4, 4) 0Tp, a reachable pose (forward geometry's default guess).
        name: the robot's name.
    """

    base_points: np.ndarray
    leg_base_rotations: np.ndarray
    platform_points: np.ndarray
    legs: tuple[LegArchitecture, ...]
    leg_inertia: np.ndarray
    platform_inertia: np.ndarray
    gravity: np.ndarray
    home_pose: np.ndarray
    name: str = "general"

    def __post_init__(self) -> None:
        shapes = {
            "base_points": (6, 3),
            "leg_base_rotations": (6, 3, 3),
            "platform_points": (6, 3),
            "leg_inertia": (6, 3, 10),
            "platform_inertia": (10,),
            "gravity": (3,),
            "home_pose": (4, 4),
        }
        for key, shape in shapes.items():
            try:
                value = check_array(getattr(self, key), shape, key)
            except InputError as e:
                raise DescriptionError(f"general hexapod '{self.name}': {e}") from e
            if key == "leg_base_rotations":
                value = np.array(
                    [project_rotation(R, f"leg_base_rotations[{i}]") for i, R in enumerate(value)]
                )
            if key == "home_pose":
                value = value.copy()
                value[:3, :3] = project_rotation(value[:3, :3], "home_pose rotation block")
            value.flags.writeable = False
            object.__setattr__(self, key, value)
        legs = tuple(self.legs) if isinstance(self.legs, Sequence) else ()
        if len(legs) != 6 or not all(isinstance(leg, LegArchitecture) for leg in legs):
            raise ArchitectureError(
                "a general hexapod needs six LegArchitecture legs", "legs", self.legs
            )
        object.__setattr__(self, "legs", legs)
        for i in range(6):
            for j in range(3):
                check_physical(self.leg_inertia[i, j], f"leg {i + 1} link {j + 1}")
        check_physical(self.platform_inertia, "platform")

    # ------------------------------------------------------------------ derived data
    @property
    def actuated(self) -> np.ndarray:
        """The actuated joint of each leg, 0-based, shape (6,)."""
        return np.array([leg.actuated - 1 for leg in self.legs])

    @property
    def leg_base_poses(self) -> np.ndarray:
        """(6, 4, 4) the poses of the leg frames 0i in F0."""
        T = np.tile(np.eye(4), (6, 1, 1))
        T[:, :3, :3], T[:, :3, 3] = self.leg_base_rotations, self.base_points
        return T

    @property
    def architecture(self) -> str:
        """The legs' common architecture name, or ``"mixed"``."""
        names = {leg.name for leg in self.legs}
        return names.pop() if len(names) == 1 else "mixed"

    @property
    def size(self) -> float:
        """A length scale: the mean platform-point distance to their centroid [m]."""
        P = self.platform_points
        r = float(np.linalg.norm(P - P.mean(0), axis=1).mean())
        return r if r > 0 else float(np.linalg.norm(self.base_points.std(0)))

    def replace(self, **changes: Any) -> GeneralHexapod:
        return replace(self, **changes)

    def with_joint_dynamics(self, dynamics: Any) -> GeneralHexapod:
        """A copy with every joint's dynamics set: ``dynamics[i][j]`` for joint j of leg i."""
        legs = tuple(leg.with_dynamics(d) for leg, d in zip(self.legs, dynamics, strict=True))
        return self.replace(legs=legs)


def general_from_description(desc: Any) -> GeneralHexapod:
    """The :class:`GeneralHexapod` of a 6-UPS :class:`RobotDescription` (:func:`ups` legs
    with the description's stroke and U-joint limits, no joint dynamics): the same robot."""
    legs = []
    for i in range(6):
        lim = None if desc.u_joint_limits is None else desc.u_joint_limits[i]
        legs.append(ups(tuple(desc.stroke), lim))
    return GeneralHexapod(
        base_points=desc.base_points,
        leg_base_rotations=desc.leg_base_rotations,
        platform_points=desc.platform_points,
        legs=tuple(legs),
        leg_inertia=desc.leg_inertia,
        platform_inertia=desc.platform_inertia,
        gravity=desc.gravity,
        home_pose=desc.home_pose,
        name=desc.name,
    )


# ---------------------------------------------------------------------------- generators
def random_joint_dynamics(
    rng: np.random.Generator, kind: str, scale: float = 1.0, transmission: bool = False
) -> JointDynamics:
    """Random joint dynamics with every term non-zero (``scale`` multiplies them)."""
    u = lambda lo, hi: float(rng.uniform(lo, hi)) * scale  # noqa: E731
    extra: dict[str, float] = {}
    if transmission:
        if kind == REVOLUTE:
            extra = {"gear_ratio": float(rng.uniform(5, 50)), "rotor_inertia": u(1e-6, 1e-5)}
        else:
            extra = {"screw_lead": float(rng.uniform(0.002, 0.01)), "rotor_inertia": u(1e-6, 1e-5)}
    return JointDynamics(
        armature=u(0.001, 0.01) if kind == REVOLUTE else u(0.05, 0.5),
        viscous=u(0.01, 0.1) if kind == REVOLUTE else u(1.0, 10.0),
        coulomb=u(0.01, 0.1) if kind == REVOLUTE else u(0.5, 5.0),
        stiffness=u(0.1, 1.0) if kind == REVOLUTE else u(10.0, 100.0),
        rest_position=float(rng.uniform(-0.5, 0.5)),
        damping=u(0.01, 0.1) if kind == REVOLUTE else u(1.0, 10.0),
        **extra,
    )


def _rot(rng: np.random.Generator, amount: float) -> np.ndarray:
    return pin.exp3(rng.uniform(-amount, amount, 3))


def _frame_from_zx(z: np.ndarray, x: np.ndarray) -> np.ndarray:
    z = z / np.linalg.norm(z)
    x = x - (x @ z) * z
    x = x / np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _assemble(
    name: str,
    base_points: np.ndarray,
    rotations: np.ndarray,
    legs: list[LegArchitecture],
    q_home: np.ndarray,
    leg_inertia: np.ndarray,
    platform_inertia: np.ndarray,
    gravity: np.ndarray,
    R_home: np.ndarray,
    p_home: np.ndarray,
) -> GeneralHexapod:
    """A robot whose platform points are the legs' tips at ``q_home`` (6, 3); each leg's
    branch is the one of its home configuration."""
    T0 = np.tile(np.eye(4), (6, 1, 1))
    T0[:, :3, :3], T0[:, :3, 3] = rotations, base_points
    P_home = np.array([leg.tip_position(q, T) for leg, q, T in zip(legs, q_home, T0, strict=True)])
    legs = [
        leg.replace(branch=leg.branch_at(q), guess=q) for leg, q in zip(legs, q_home, strict=True)
    ]
    home = np.eye(4)
    home[:3, :3], home[:3, 3] = R_home, p_home
    return GeneralHexapod(
        base_points=base_points,
        leg_base_rotations=rotations,
        platform_points=(P_home - p_home) @ R_home,
        legs=tuple(legs),
        leg_inertia=leg_inertia,
        platform_inertia=platform_inertia,
        gravity=gravity,
        home_pose=home,
        name=name,
    )


def _crank_rod_measure(leg: LegArchitecture, q: Any) -> float:
    """``(P - C) . (z1 x (C - O1))`` normalised by the rod and crank lengths: 1 with the rod
    along the crank tip's velocity, 0 at the reach limit (rod and crank aligned)."""
    T1, T2, _ = leg.transforms(q)
    P, C, O1, z1 = leg.tip_position(q), T2[:3, 3], T1[:3, 3], T1[:3, 2]
    arm = np.cross(z1, C - O1)
    return float((P - C) @ arm / (np.linalg.norm(P - C) * np.linalg.norm(arm)))


def _ring(radius: float, angles_deg: Sequence[float], z: float = 0.0) -> np.ndarray:
    a = np.radians(np.asarray(angles_deg, float))
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.full(len(a), z)])


def random_hexapod(kind: str, seed: int = 0, joint_terms: bool = True) -> GeneralHexapod:
    """A general asymmetric robot of architecture ``kind`` (``ups``, ``ups-offset``,
    ``rus``, ``pus``) for tests: perturbed placements and joint parameters, a rotated
    platform frame away from the centroid, full inertia tensors and offset first moments
    on every body, and (``joint_terms``) every joint dynamics term non-zero, with gear and
    screw transmissions on the actuated joints."""
    rng = np.random.default_rng(seed)

    def dyn(kind_: str, transmission: bool = False) -> JointDynamics:
        if not joint_terms:
            return JointDynamics()
        return random_joint_dynamics(rng, kind_, transmission=transmission)

    if kind in ("ups", "ups-offset"):
        B = _ring(0.5, [-10, 10, 110, 130, 230, 250]) + rng.uniform(-0.04, 0.04, (6, 3))
        P0 = _ring(0.32, [-46, 46, 74, 166, 194, 286], 0.7) + rng.uniform(-0.03, 0.03, (6, 3))
        rotations, q_home, legs = [], [], []
        for b, p in zip(B, P0, strict=True):
            dvec = p - b
            axis = np.cross([0.0, 0.0, 1.0], dvec)
            axis = axis / np.linalg.norm(axis) + rng.uniform(-0.3, 0.3, 3)
            R = _frame_from_zx(axis, dvec + rng.uniform(-0.3, 0.3, 3))
            rotations.append(R)
            offset = float(rng.uniform(0.01, 0.04)) if kind == "ups-offset" else 0.0
            dyns = [dyn(REVOLUTE), dyn(REVOLUTE), dyn(PRISMATIC, True)]
            leg = _ups_like(kind, offset, (0.0, math.inf), None, dyns, 1)
            # home joint values: solve the U-joint for the direction, then the length.
            u = R.T @ dvec
            q1 = math.atan2(u[1], u[0])
            rho = math.hypot(u[0], u[1])
            q2 = math.atan2(rho - offset, -u[2])
            q3 = math.hypot(rho - offset, u[2])
            q_home.append([q1, q2, q3])
            legs.append(leg)
        link_sizes = ((0.2, 0.6, 0.05, 0.03), (2.0, 5.0, 0.25, 0.15), (1.0, 3.0, 0.25, 0.15))
        platform = random_physical_khalil(rng, rng.uniform(10.0, 30.0), 0.3, 0.1)
        centre = np.array([0.03, -0.02, 0.75])
    elif kind == "rus":
        B = _ring(0.09, [-20, 20, 100, 140, 220, 260]) + rng.uniform(-0.006, 0.006, (6, 3))
        rotations, q_home, legs = [], [], []
        for k, b in enumerate(B):
            radial = np.array([b[0], b[1], 0.0]) / np.hypot(b[0], b[1])
            tangent = np.cross([0.0, 0.0, 1.0], radial) * (1 if k % 2 else -1)
            R = _frame_from_zx(radial + rng.uniform(-0.2, 0.2, 3), tangent)
            rotations.append(R)
            s = 1 if k % 2 else -1
            for _ in range(100):  # redraw until crank and rod are well apart (reach margin)
                crank = float(rng.uniform(0.025, 0.035))
                rod = float(rng.uniform(0.09, 0.11))
                leg = rus(crank, rod, dynamics=[dyn(REVOLUTE, True), dyn(REVOLUTE), dyn(REVOLUTE)])
                j1, j2, j3 = leg.joints
                leg = leg.replace(
                    joints=(
                        replace(
                            j1, alpha=float(rng.uniform(-0.2, 0.2)), d=float(rng.uniform(0, 0.01))
                        ),
                        replace(
                            j2,
                            alpha=float(rng.uniform(-0.3, 0.3)),
                            theta=float(rng.uniform(-0.3, 0.3)),
                            r=float(rng.uniform(-0.01, 0.01)),
                        ),
                        replace(
                            j3,
                            alpha=math.pi / 2 + float(rng.uniform(-0.3, 0.3)),
                            theta=float(rng.uniform(-0.3, 0.3)),
                        ),
                    ),
                    tip=np.array([rod, *rng.uniform(-0.01, 0.01, 2)]),
                )
                # crank outwards-horizontal-ish, rod up and inwards.
                qh = [
                    float(rng.uniform(-0.2, 0.2)),
                    s * (math.pi / 2 - 0.4) + float(rng.uniform(-0.15, 0.15)),
                    -0.3 + float(rng.uniform(-0.1, 0.1)),
                ]
                if abs(_crank_rod_measure(leg, qh)) > 0.7:
                    break
            q_home.append(qh)
            legs.append(leg)
        link_sizes = (
            (0.01, 0.03, 0.015, 0.01),
            (0.002, 0.01, 0.01, 0.005),
            (0.01, 0.03, 0.05, 0.04),
        )
        platform = random_physical_khalil(rng, rng.uniform(0.8, 1.2), 0.06, 0.02)
        centre = np.array([0.005, -0.003, 0.1])
    elif kind == "pus":
        B = _ring(0.4, [-15, 15, 105, 135, 225, 255]) + rng.uniform(-0.02, 0.02, (6, 3))
        rotations, q_home, legs = [], [], []
        for k, b in enumerate(B):
            radial = np.array([b[0], b[1], 0.0]) / np.hypot(b[0], b[1])
            R = _frame_from_zx(np.array([0.0, 0.0, 1.0]) + rng.uniform(-0.2, 0.2, 3), -radial)
            rotations.append(R)
            rod = float(rng.uniform(0.35, 0.45))
            leg = pus(
                rod,
                float(rng.uniform(-0.2, 0.2)),
                dynamics=[dyn(PRISMATIC, True), dyn(REVOLUTE), dyn(REVOLUTE)],
            )
            j1, j2, j3 = leg.joints
            leg = leg.replace(
                joints=(
                    replace(j1, theta=float(rng.uniform(-0.3, 0.3))),
                    replace(
                        j2,
                        alpha=math.pi / 2 + float(rng.uniform(-0.2, 0.2)),
                        d=float(rng.uniform(0, 0.02)),
                        r=float(rng.uniform(-0.02, 0.02)),
                    ),
                    replace(
                        j3,
                        alpha=math.pi / 2 + float(rng.uniform(-0.2, 0.2)),
                        theta=float(rng.uniform(-0.3, 0.3)),
                    ),
                ),
                tip=np.array([rod, *rng.uniform(-0.02, 0.02, 2)]),
            )
            # slide mid-height; rod inwards and up at about 45 degrees, tilted sideways.
            side = (1 if k % 2 else -1) * 0.3
            q_home.append(
                [
                    float(rng.uniform(0.15, 0.25)),
                    float(rng.uniform(0.8, 1.1)),
                    side + float(rng.uniform(-0.1, 0.1)),
                ]
            )
            legs.append(leg)
        link_sizes = ((0.5, 1.5, 0.05, 0.03), (0.1, 0.3, 0.03, 0.02), (0.3, 0.8, 0.2, 0.15))
        platform = random_physical_khalil(rng, rng.uniform(5.0, 15.0), 0.2, 0.05)
        centre = None
    else:
        raise ArchitectureError(
            f"no random generator for architecture {kind!r}; choose one of "
            "'ups', 'ups-offset', 'rus', 'pus'",
            "name",
            kind,
        )
    rotations = np.array(rotations)
    q_home = np.array(q_home)
    leg_inertia = np.array(
        [
            [
                random_physical_khalil(rng, rng.uniform(lo, hi), size, off)
                for lo, hi, size, off in link_sizes
            ]
            for _ in range(6)
        ]
    )
    T0 = np.tile(np.eye(4), (6, 1, 1))
    T0[:, :3, :3], T0[:, :3, 3] = rotations, B
    P_home = np.array([leg.tip_position(q, T) for leg, q, T in zip(legs, q_home, T0, strict=True)])
    if centre is None:
        centre = P_home.mean(0) + rng.uniform(-0.02, 0.02, 3)
    R_home = _rot(rng, 0.15)
    gravity = np.array([0.0, 0.0, -9.81]) + rng.uniform(-0.5, 0.5, 3)
    return _assemble(
        f"random-{kind}-{seed}",
        B,
        rotations,
        legs,
        q_home,
        leg_inertia,
        platform,
        gravity,
        R_home,
        centre,
    )


# ---------------------------------------------------------------------------- presets
def _rod_params(mass: float, radius: float, length: float, axis: np.ndarray, start: float):
    """Khalil parameters of a solid cylinder along ``axis`` (unit) centred at
    ``(start + length / 2) axis``."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    I_c = transverse * np.eye(3) + (axial - transverse) * np.outer(axis, axis)
    return khalil_from_urdf_inertial(mass, (start + 0.5 * length) * axis, I_c)


def _sphere_params(mass: float, radius: float) -> np.ndarray:
    return khalil_from_urdf_inertial(mass, np.zeros(3), 0.4 * mass * radius**2 * np.eye(3))


def ups_offset_preset(offset: float = 0.004) -> GeneralHexapod:
    """``ups-offset``: the ``desktop`` 6-UPS hexapod with U-joint axes offset by
    ``offset`` [m] (4 mm), servo-like joint dynamics on the prismatic joints."""
    from stewart_pin.description.presets import desktop

    desc = desktop()
    base = general_from_description(desc)
    lead = JointDynamics(
        armature=0.02, viscous=20.0, coulomb=1.0, screw_lead=0.002, rotor_inertia=2e-6
    )
    small = JointDynamics(viscous=1e-3, coulomb=1e-3)
    legs, q_home = [], []
    T = desc.home_pose
    P0 = desc.platform_points @ T[:3, :3].T + T[:3, 3]
    for i in range(6):
        leg = ups_offset(offset, tuple(desc.stroke), dynamics=(small, small, lead))
        u = desc.leg_base_rotations[i].T @ (P0[i] - desc.base_points[i])
        rho = math.hypot(u[0], u[1])
        q_home.append(
            [
                math.atan2(u[1], u[0]),
                math.atan2(rho - offset, -u[2]),
                math.hypot(rho - offset, u[2]),
            ]
        )
        legs.append(leg)
    return _assemble(
        "ups-offset",
        desc.base_points,
        desc.leg_base_rotations,
        legs,
        np.array(q_home),
        base.leg_inertia,
        desc.platform_inertia,
        desc.gravity,
        T[:3, :3],
        T[:3, 3],
    )


def rus_preset() -> GeneralHexapod:
    """``rus``: a desktop animatronic head on six hobby servos: base radius 8 cm, cranks
    3 cm (servo horns, about radial axes, horizontal at home), rods 10 cm, a 1 kg head."""
    B = _ring(0.08, [-15, 15, 105, 135, 225, 255])
    crank, rod = 0.03, 0.10
    servo = JointDynamics(
        armature=0.0, viscous=0.002, coulomb=0.005, gear_ratio=300.0, rotor_inertia=1e-8
    )
    legs, rotations, q_home = [], [], []
    for k, b in enumerate(B):
        radial = np.array([b[0], b[1], 0.0]) / np.hypot(b[0], b[1])
        s = -1 if k % 2 == 0 else 1
        tangent = s * np.cross([0.0, 0.0, 1.0], radial)
        rotations.append(_frame_from_zx(radial, tangent))  # crank axis radial, crank tangential
        legs.append(
            rus(
                crank,
                rod,
                (-math.pi / 2, math.pi / 2),
                dynamics=(servo, JointDynamics(), JointDynamics()),
            )
        )
        # q1 = 0: crank horizontal; q2: the rod up (frame 2's x along the crank, y2 = z x x)
        q_home.append([0.0, s * math.pi / 2 * 1.0, 0.0])
    rotations = np.array(rotations)
    q_home = np.array(q_home)
    # tilt each rod inwards by 0.25 rad about the crank-tip U joint: q2 only moves it in the
    # crank plane (tangential), so incline it with q3 (out of the crank plane, radially)
    q_home[:, 1] -= np.sign(q_home[:, 1]) * 0.35
    q_home[:, 2] = -0.25
    T0 = np.tile(np.eye(4), (6, 1, 1))
    T0[:, :3, :3], T0[:, :3, 3] = rotations, B
    P_home = np.array([leg.tip_position(q, T) for leg, q, T in zip(legs, q_home, T0, strict=True)])
    link1 = _rod_params(0.005, 0.003, crank, np.array([1.0, 0.0, 0.0]), 0.0)
    link2 = _sphere_params(0.002, 0.004)
    link3 = _rod_params(0.008, 0.002, rod, np.array([1.0, 0.0, 0.0]), 0.0)
    leg_inertia = np.tile(np.stack([link1, link2, link3]), (6, 1, 1))
    head = khalil_from_urdf_inertial(1.0, np.array([0.0, 0.0, 0.04]), np.diag([4e-3, 4e-3, 3e-3]))
    centre = np.array([0.0, 0.0, P_home[:, 2].mean()])
    return _assemble(
        "rus",
        B,
        rotations,
        legs,
        q_home,
        leg_inertia,
        head,
        np.array([0.0, 0.0, -9.81]),
        np.eye(3),
        centre,
    )


def pus_preset() -> GeneralHexapod:
    """``pus``: a hexaglide-like positioner: six vertical rails on a 0.4 m circle, slides
    on ball screws (5 mm lead), rods of 0.45 m to a 0.2 m platform of 8 kg."""
    B = _ring(0.4, [-12, 12, 108, 132, 228, 252])
    rod = 0.45
    screw = JointDynamics(
        armature=0.5, viscous=50.0, coulomb=5.0, screw_lead=0.005, rotor_inertia=3e-5
    )
    legs, rotations, q_home = [], [], []
    for k, b in enumerate(B):
        radial = np.array([b[0], b[1], 0.0]) / np.hypot(b[0], b[1])
        rotations.append(_frame_from_zx(np.array([0.0, 0.0, 1.0]), -radial))
        legs.append(pus(rod, 0.0, (0.0, 0.5), dynamics=(screw, JointDynamics(), JointDynamics())))
        q_home.append([0.25, 1.0, 0.35 * (1 if k % 2 == 0 else -1)])
    rotations = np.array(rotations)
    q_home = np.array(q_home)
    T0 = np.tile(np.eye(4), (6, 1, 1))
    T0[:, :3, :3], T0[:, :3, 3] = rotations, B
    P_home = np.array([leg.tip_position(q, T) for leg, q, T in zip(legs, q_home, T0, strict=True)])
    slide = _sphere_params(1.0, 0.04)
    cross_ = _sphere_params(0.1, 0.015)
    rod_p = _rod_params(0.4, 0.01, rod, np.array([1.0, 0.0, 0.0]), 0.0)
    leg_inertia = np.tile(np.stack([slide, cross_, rod_p]), (6, 1, 1))
    plate = khalil_from_urdf_inertial(8.0, np.array([0.0, 0.0, 0.03]), np.diag([0.1, 0.1, 0.18]))
    centre = np.array([0.0, 0.0, P_home[:, 2].mean()])
    return _assemble(
        "pus",
        B,
        rotations,
        legs,
        q_home,
        leg_inertia,
        plate,
        np.array([0.0, 0.0, -9.81]),
        np.eye(3),
        centre,
    )


#: The general-leg presets (to be registered with the existing ones at integration).
GENERAL_PRESETS = {"ups-offset": ups_offset_preset, "rus": rus_preset, "pus": pus_preset}
