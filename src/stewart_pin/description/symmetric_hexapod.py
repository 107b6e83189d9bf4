"""A builder for the common symmetric hexapods: :func:`symmetric_hexapod`.

The classic layout of motion simulators and positioners: the six base joints ``B_i`` on
a circle of radius ``base_radius`` in the plane ``z0 = 0``, in three pairs 120 degrees
apart, the two joints of a pair ``base_pair_angle`` apart; the six platform joints
``P_i`` likewise on a circle of radius ``platform_radius`` in the plane ``zp = 0``, their
pairs turned 60 degrees from the base pairs, so that each platform pair joins two
neighbouring base pairs (the legs zig-zag around the robot). Angles from ``x0`` (``xp``)
about ``z0`` (``zp``), leg i numbered from 1 counter-clockwise::

    B_i at 120 k -/+ a_b / 2 (i = 2k+1, 2k+2)     P_i at 120 k - 60 + a_p / 2,
                                                        120 k + 60 - a_p / 2 (the same)

A platform pair angle of 0 makes the platform joints pairwise coincident: the 6-3
hexapod (legs 2 and 3, 4 and 5, 6 and 1 share a spherical joint centre; ideal spherical
joints make that a valid robot, whose home pose assembles like any other; the
description's validation allows at most three legs per point). A base pair angle of 0
gives the 3-6, both 0 the 3-3 (octahedral) hexapod.

At home, ``Fp`` is parallel to ``F0``, its origin ``home_height`` above ``O_0`` on
``z0``: every leg has the same length ``sqrt(rb^2 + rp^2 - 2 rb rp cos(delta) + h^2)``
(``delta`` the angle between ``B_i`` and ``P_i`` about ``z0``), which must lie inside
the stroke.

``architecture="ups"``: the paper's ideal 6-UPS legs, their first U-joint axes
horizontal and perpendicular to each leg at home (so ``q2i = pi/2`` there: the U-joint
as far from its singularity as it can be), with uniform-solid links: link 1 (the U-joint
cross) a sphere of radius ``1.5 leg_radius`` at ``B_i``, link 2 (the cylinder body) a
solid cylinder of radius ``1.4 leg_radius`` and length ``cylinder_length`` from ``B_i``
along the leg, link 3 (the piston rod) a solid cylinder of radius ``leg_radius`` and
length ``rod_length`` ending at ``P_i``.

``architecture="rus"``: ``rus`` legs (general legs, ``RobotDescription.legs``): at each
``B_i`` a crank of length ``crank_length`` turning about the radial axis (the servo's
shaft), horizontal and tangential at home (crank angle 0), pointing away from its pair
partner; a universal joint at the crank tip ``C_i``; a rod from ``C_i`` to ``P_i``,
whose length ``|P_i - C_i|`` at home follows from the home height (the same for every
leg, by symmetry). Links: the crank and the rod solid cylinders of radius
``leg_radius``, the universal joint's cross a sphere of radius ``1.5 leg_radius`` at
``C_i``; no joint dynamics.

``architecture="pus"``: ``pus`` legs (general legs): a vertical rail through each
``B_i`` (frame 0i: z up, x towards the axis of the robot), a slide on it at height
``q1`` (the actuated joint, limited by ``stroke``), a universal joint on the slide, a
rod of ``rod_length`` to ``P_i``; the slides' home height ``h - sqrt(l^2 - d^2)`` (``d``
the horizontal distance from the rail to ``P_i``) follows from the rod length. Links: the
slide a sphere of radius ``3 leg_radius``, the cross one of ``1.5 leg_radius``, the rod a
solid cylinder of radius ``leg_radius``; no joint dynamics.

Other bodies or joint terms: ``RobotDescription.replace`` afterwards.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_scalar
from stewart_pin.description.inertia import khalil_from_urdf_inertial
from stewart_pin.description.leg_architecture import pus, rus
from stewart_pin.description.robot_description import (
    RobotDescription,
    leg_base_rotation_from_axis,
)
from stewart_pin.description.symmetric_presets import GRAVITY, cylinder_link
from stewart_pin.exceptions import DescriptionError, InputError

#: The largest pair angle [rad]: at 120 degrees the joints of neighbouring pairs meet.
MAX_PAIR_ANGLE = 2.0 * math.pi / 3.0
#: Each architecture's own options of :func:`symmetric_hexapod` (beside the common ones).
OPTIONS = {
    "ups": ("stroke", "cylinder_length", "rod_length", "u_joint_limits"),
    "rus": ("crank_length", "crank_limits"),
    "pus": ("stroke", "rod_length"),
}
#: The largest condition number of the 6-UPS inverse Jacobian at home (rows
#: ``[u_i, (L_i x u_i) / r_p]``, eq. 13, the angular part made unit-free by the platform
#: radius), as the kinematics' ``MAX_CONDITION``: beyond, the home pose is (nearly) a
#: parallel singularity and the builder refuses the geometry.
MAX_HOME_CONDITION = 1e4


def attachment_points(
    base_radius: float,
    platform_radius: float,
    base_pair_angle: float,
    platform_pair_angle: float,
) -> tuple[np.ndarray, np.ndarray]:
    """``(B_i in F0, P_i in Fp)``, shape (6, 3) each [m], of the layout in the module
    docstring (radii [m], pair angles [rad]). Each joint is its pair's centre point turned
    by half the pair angle, so the joints of a pair with angle 0 are equal bit for bit."""

    def pairs(radius: float, centres_deg: tuple[float, ...], angle: float) -> np.ndarray:
        c, s = math.cos(0.5 * angle), math.sin(0.5 * angle)
        out = []
        for centre in np.radians(centres_deg):
            x, y = radius * math.cos(centre), radius * math.sin(centre)
            out += [[c * x + s * y, c * y - s * x, 0.0], [c * x - s * y, c * y + s * x, 0.0]]
        return np.array(out)

    B = pairs(base_radius, (0.0, 120.0, 240.0), base_pair_angle)  # legs 1-2, 3-4, 5-6
    P = pairs(platform_radius, (60.0, 180.0, 300.0), platform_pair_angle)  # 2-3, 4-5, 6-1
    return B, np.roll(P, 1, axis=0)


def _number(value: Any, name: str, unit: str, **kind: bool) -> float:
    try:
        return check_scalar(value, name, unit=unit, **kind)
    except InputError as e:
        raise DescriptionError(f"symmetric_hexapod: {e}") from e


def symmetric_hexapod(
    base_radius: float,
    platform_radius: float,
    base_pair_angle: float,
    platform_pair_angle: float,
    home_height: float,
    stroke: Any = None,
    *,
    architecture: str = "ups",
    crank_length: float | None = None,
    crank_limits: Any = (-math.pi / 2, math.pi / 2),
    platform_mass: float,
    platform_inertia: Any = None,
    platform_com: Any = (0.0, 0.0, 0.0),
    leg_masses: Any = (0.0, 0.0, 0.0),
    leg_radius: float | None = None,
    cylinder_length: float | None = None,
    rod_length: float | None = None,
    u_joint_limits: Any = None,
    gravity: Any = GRAVITY,
    name: str = "symmetric",
) -> RobotDescription:
    """A symmetric 6-6 or 6-3 hexapod, 6-UPS, 6-RUS or 6-PUS (layout, frames and links in
    the module docstring).

    Args:
        base_radius: radius of the base joints' circle, ``|B_i|`` [m], > 0.
        platform_radius: radius of the platform joints' circle, ``|P_i|`` [m], > 0.
        base_pair_angle: angle between the two joints of a base pair, seen from ``O_0``
            [rad], in ``[0, 2 pi / 3)``.
        platform_pair_angle: the same on the platform [rad]; 0 for a 6-3 hexapod.
        home_height: height of ``O_p`` above ``O_0`` at home (``Fp`` parallel to ``F0``)
            [m], > 0.
        stroke: the actuators' travel ``(min, max)`` [m], the home position strictly
            inside: 6-UPS (required) the leg length ``|B_i P_i|``; 6-PUS (required) the
            slide's height on its rail above ``B_i``.
        architecture: ``"ups"`` (the paper's ideal 6-UPS: prismatic actuators),
            ``"rus"`` (cranks on rotary actuators) or ``"pus"`` (slides on vertical
            rails); the last two have general legs.
        crank_length: 6-RUS (required): the crank's length [m], > 0.
        crank_limits: 6-RUS: ``(lower, upper)`` crank angle [rad] about its radial axis,
            from the horizontal home position (must hold 0).
        platform_mass: [kg], >= 0.
        platform_inertia: about the platform's centre of mass, in ``Fp`` axes [kg m^2]:
            a (3, 3) tensor or its (3,) principal moments along ``xp, yp, zp``; default a
            uniform thin disc of radius ``platform_radius``
            (``m r^2 / 4, m r^2 / 4, m r^2 / 2``).
        platform_com: the platform's centre of mass in ``Fp``, shape (3,) [m].
        leg_masses: the three links of every leg [kg], >= 0: 6-UPS ``(U-joint cross,
            cylinder body, piston rod)``, 6-RUS ``(crank, U-joint cross, rod)``, 6-PUS
            ``(slide, U-joint cross, rod)`` (default massless legs).
        leg_radius: the rod's radius [m] (default ``stroke[0] / 40``, 6-RUS
            ``crank_length / 10``, 6-PUS ``rod_length / 40``).
        cylinder_length: 6-UPS: the cylinder body's length from ``B_i`` [m] (default
            ``0.75 stroke[0]``).
        rod_length: 6-UPS: the piston rod's length, ending at ``P_i`` [m] (default
            ``0.75 stroke[0]``); 6-PUS (required): the rod's length from the slide's
            universal joint to ``P_i`` [m]. (A 6-RUS rod's length follows from the home
            height.)
        u_joint_limits: 6-UPS, optional: ``[[q1min, q1max], [q2min, q2max]]`` [rad], or
            (6, 2, 2).
        gravity: in ``F0``, shape (3,) [m/s^2].
        name: the robot's name (:data:`~stewart_pin.description.robot_description.NAME_RULE`).

    Returns:
        the :class:`RobotDescription` (``StewartRobot(description)`` builds the robot;
        for 6-RUS it checks that the home pose is away from the legs' singularities).

    Raises:
        DescriptionError: a bad number (named), a pair angle outside ``[0, 2 pi / 3)``,
            a home leg length outside the stroke (the message gives the length and the
            height range that fits), an option of the other architecture;
            :class:`~stewart_pin.exceptions.InertiaError` for a non-physical platform
            inertia; the description's own rules (:class:`RobotDescription`).
    """
    if architecture not in OPTIONS:
        raise DescriptionError(
            f"symmetric_hexapod: architecture must be one of {list(OPTIONS)}, got {architecture!r}"
        )
    given = {
        "stroke": stroke,
        "crank_length": crank_length,
        "cylinder_length": cylinder_length,
        "rod_length": rod_length,
        "u_joint_limits": u_joint_limits,
    }
    foreign = [k for k, v in given.items() if v is not None and k not in OPTIONS[architecture]]
    if foreign:
        raise DescriptionError(
            f"symmetric_hexapod: {', '.join(foreign)} do not apply to a "
            f"6-{architecture.upper()} hexapod; its options: "
            f"{', '.join(OPTIONS[architecture])}"
        )
    rb = _number(base_radius, "base_radius", "m", positive=True)
    rp = _number(platform_radius, "platform_radius", "m", positive=True)
    ab = _number(base_pair_angle, "base_pair_angle", "rad", nonnegative=True)
    ap = _number(platform_pair_angle, "platform_pair_angle", "rad", nonnegative=True)
    for key, value in (("base_pair_angle", ab), ("platform_pair_angle", ap)):
        if value >= MAX_PAIR_ANGLE:
            raise DescriptionError(
                f"symmetric_hexapod: {key} = {value:.9g} rad must be below 2 pi / 3 "
                f"({MAX_PAIR_ANGLE:.9g} rad): wider, a joint of one pair passes the "
                "neighbouring pair's"
            )
    h = _number(home_height, "home_height", "m", positive=True)
    B, P = attachment_points(rb, rp, ab, ap)
    home = np.eye(4)
    home[2, 3] = h
    platform = _platform(platform_mass, platform_inertia, platform_com, rp)
    try:
        masses = check_array(leg_masses, (3,), "leg_masses")
    except InputError as e:
        raise DescriptionError(f"symmetric_hexapod: {e}") from e
    if np.any(masses < 0):
        raise DescriptionError(
            f"symmetric_hexapod: leg_masses must be >= 0 [kg], got {masses.tolist()}"
        )
    common = {
        "base_points": B,
        "platform_points": P,
        "platform_inertia": platform,
        "gravity": gravity,
        "name": name,
        "home_pose": home,
    }
    if architecture == "rus":
        return _rus(B, P + home[:3, 3], crank_length, crank_limits, masses, leg_radius, common)
    lo, hi = _stroke(stroke, architecture)
    if architecture == "pus":
        return _pus(B, P + home[:3, 3], (lo, hi), rod_length, masses, leg_radius, common)
    across = float(np.linalg.norm(P[0] - B[0]))  # the same for every leg, by symmetry
    length = math.hypot(across, h)
    if not lo < length < hi:
        fits = [math.sqrt(max(x**2 - across**2, 0.0)) for x in (lo, hi)]
        raise DescriptionError(
            f"symmetric_hexapod: at home_height {h:.9g} m the legs are {length:.9g} m long, "
            f"outside the stroke [{lo:.9g}, {hi:.9g}] m; choose a home height in "
            f"({fits[0]:.9g}, {fits[1]:.9g}) m, or another stroke"
        )
    radius = _number(
        lo / 40.0 if leg_radius is None else leg_radius, "leg_radius", "m", positive=True
    )
    cylinder = _number(
        0.75 * lo if cylinder_length is None else cylinder_length,
        "cylinder_length",
        "m",
        positive=True,
    )
    rod = _number(
        0.75 * lo if rod_length is None else rod_length, "rod_length", "m", positive=True
    )
    m1, m2, m3 = masses
    link1 = _sphere(m1, 1.5 * radius)
    link2 = cylinder_link(m2, 1.4 * radius, cylinder, np.array([0.0, -1.0, 0.0]), 0.0)
    link3 = cylinder_link(m3, radius, rod, np.array([0.0, 0.0, 1.0]), -rod)
    u = (P + home[:3, 3] - B) / length  # unit leg directions at home
    s = np.linalg.svd(np.hstack([u, np.cross(P, u) / rp]), compute_uv=False)
    if s[-1] <= s[0] / MAX_HOME_CONDITION:
        raise DescriptionError(
            f"symmetric_hexapod: the home pose is a parallel singularity (condition number "
            f"of the inverse Jacobian {s[0] / s[-1]:.3g} > {MAX_HOME_CONDITION:g}): the "
            "platform could move with the legs locked; change the pair angles, the radii or "
            "the home height"
        )
    rotations = []
    for b, p in zip(B, P + home[:3, 3], strict=True):
        leg = p - b
        axis = np.cross([0.0, 0.0, 1.0], leg)
        if np.linalg.norm(axis) <= 1e-9 * length:  # a vertical leg: a tangential axis
            axis = np.cross([0.0, 0.0, 1.0], b)
        rotations.append(leg_base_rotation_from_axis(axis, leg))
    return RobotDescription(
        leg_base_rotations=np.array(rotations),
        stroke=np.array([lo, hi]),
        leg_inertia=np.tile(np.stack([link1, link2, link3]), (6, 1, 1)),
        u_joint_limits=u_joint_limits,
        **common,
    )


def _stroke(stroke: Any, architecture: str) -> tuple[float, float]:
    """The actuator's travel ``(min, max)`` [m], checked (6-UPS: ``0 < min < max``)."""
    if stroke is None:
        raise DescriptionError(
            f"symmetric_hexapod: a 6-{architecture.upper()} hexapod needs its stroke (min, max)"
        )
    try:
        lo, hi = check_array(stroke, (2,), "stroke")
    except InputError as e:
        raise DescriptionError(f"symmetric_hexapod: {e}") from e
    if not (0.0 if architecture == "ups" else -math.inf) < lo < hi:
        rule = "0 < min < max" if architecture == "ups" else "min < max"
        raise DescriptionError(
            f"symmetric_hexapod: stroke must satisfy {rule}, got [{lo:.9g}, {hi:.9g}] m"
        )
    return float(lo), float(hi)


def _sphere(mass: float, radius: float) -> np.ndarray:
    """Khalil parameters of a uniform solid sphere centred at the frame origin."""
    return khalil_from_urdf_inertial(mass, np.zeros(3), 0.4 * mass * radius**2 * np.eye(3))


def _platform(mass: Any, inertia: Any, com: Any, radius: float) -> np.ndarray:
    """The platform's Khalil parameters from the builder's arguments (checked)."""
    m = _number(mass, "platform_mass", "kg", nonnegative=True)
    try:
        c = check_array(com, (3,), "platform_com")
        if inertia is None:
            I_c = m * radius**2 * np.diag([0.25, 0.25, 0.5])
        elif np.ndim(np.asarray(inertia, dtype=object)) == 1:
            I_c = np.diag(check_array(inertia, (3,), "platform_inertia"))
        else:
            I_c = check_array(inertia, (3, 3), "platform_inertia")
        if not np.allclose(I_c, I_c.T, rtol=0.0, atol=1e-12 * np.abs(I_c).max(initial=0.0)):
            raise InputError(f"platform_inertia must be symmetric, got {I_c.tolist()}")
    except InputError as e:
        raise DescriptionError(f"symmetric_hexapod: {e}") from e
    return khalil_from_urdf_inertial(m, c, I_c)


def _rus(
    B: np.ndarray,
    P_home: np.ndarray,
    crank_length: Any,
    crank_limits: Any,
    masses: np.ndarray,
    leg_radius: Any,
    common: dict[str, Any],
) -> RobotDescription:
    """The 6-RUS robot of :func:`symmetric_hexapod`: each crank about the radial axis at
    ``B_i``, horizontal at home and pointing away from its pair partner (tangentially),
    the rod from the crank tip ``C_i`` to ``P_i`` at home (so its length follows from the
    home height). Home joint values in closed form: frame 3i's x axis, the rod, is
    ``(cos q2 cos q3, sin q2 cos q3, sin q3)`` in frame 1i's axes (``rus`` legs)."""
    if crank_length is None:
        raise DescriptionError("symmetric_hexapod: a 6-RUS hexapod needs its crank_length")
    crank = _number(crank_length, "crank_length", "m", positive=True)
    try:
        lower, upper = check_array(crank_limits, (2,), "crank_limits")
    except InputError as e:
        raise DescriptionError(f"symmetric_hexapod: {e}") from e
    if not lower < 0.0 < upper:
        raise DescriptionError(
            f"symmetric_hexapod: crank_limits must hold the horizontal home position 0, got "
            f"[{lower:.9g}, {upper:.9g}] rad"
        )
    radius = _number(
        crank / 10.0 if leg_radius is None else leg_radius, "leg_radius", "m", positive=True
    )
    rotations, legs = [], []
    for k, (b, p) in enumerate(zip(B, P_home, strict=True)):
        radial = np.array([b[0], b[1], 0.0]) / math.hypot(b[0], b[1])
        x1 = (1.0 if k % 2 else -1.0) * np.cross([0.0, 0.0, 1.0], radial)
        R = np.column_stack([x1, np.cross(radial, x1), radial])
        rod_vector = R.T @ (p - (b + crank * x1))  # in frame 1i's axes at q1 = 0
        rod = float(np.linalg.norm(rod_vector))
        u = rod_vector / rod
        q = np.array([0.0, math.atan2(u[1], u[0]), math.asin(np.clip(u[2], -1.0, 1.0))])
        leg = rus(crank, rod, (float(lower), float(upper)))
        legs.append(leg.replace(branch=leg.branch_at(q), guess=q))
        rotations.append(R)
    m1, m2, m3 = masses
    x = np.array([1.0, 0.0, 0.0])
    link1 = cylinder_link(m1, radius, crank, x, 0.0)
    link2 = _sphere(m2, 1.5 * radius)
    link3 = cylinder_link(m3, radius, legs[0].tip[0], x, 0.0)
    return RobotDescription(
        leg_base_rotations=np.array(rotations),
        stroke=None,
        leg_inertia=np.tile(np.stack([link1, link2, link3]), (6, 1, 1)),
        legs=tuple(legs),
        **common,
    )


def _pus(
    B: np.ndarray,
    P_home: np.ndarray,
    stroke: tuple[float, float],
    rod_length: Any,
    masses: np.ndarray,
    leg_radius: Any,
    common: dict[str, Any],
) -> RobotDescription:
    """The 6-PUS robot of :func:`symmetric_hexapod`: vertical rails through ``B_i``, a
    slide at height ``q1`` on each, a universal joint on the slide, a rod of
    ``rod_length`` to ``P_i``; the slides' home height follows from the rod length (the
    same for every leg, by symmetry) and must lie inside the stroke. Home joint values in
    closed form: frame 3i's x axis, the rod, is ``(cos q2 cos q3, -sin q3, sin q2 cos
    q3)`` in frame 1i's axes (``pus`` legs, no rail tilt)."""
    if rod_length is None:
        raise DescriptionError("symmetric_hexapod: a 6-PUS hexapod needs its rod_length")
    rod = _number(rod_length, "rod_length", "m", positive=True)
    across = float(np.linalg.norm((P_home - B)[0, :2]))  # horizontal, the same for all
    if rod <= across:
        raise DescriptionError(
            f"symmetric_hexapod: the rods ({rod:.9g} m) cannot reach the platform joints "
            f"{across:.9g} m away horizontally from the rails; lengthen them"
        )
    slide = float(P_home[0, 2]) - math.sqrt(rod**2 - across**2)
    if not stroke[0] < slide < stroke[1]:
        raise DescriptionError(
            f"symmetric_hexapod: at home the slides are at {slide:.9g} m on their rails, "
            f"outside the stroke [{stroke[0]:.9g}, {stroke[1]:.9g}] m; change the stroke, "
            "the rod length or the home height"
        )
    radius = _number(
        rod / 40.0 if leg_radius is None else leg_radius, "leg_radius", "m", positive=True
    )
    rotations, legs = [], []
    for b, p in zip(B, P_home, strict=True):
        inward = -np.array([b[0], b[1], 0.0]) / math.hypot(b[0], b[1])
        R = np.column_stack([inward, np.cross([0.0, 0.0, 1.0], inward), [0.0, 0.0, 1.0]])
        u = R.T @ (p - b - np.array([0.0, 0.0, slide])) / rod  # the rod in frame 1i's axes
        q = np.array([slide, math.atan2(u[2], u[0]), -math.asin(np.clip(u[1], -1.0, 1.0))])
        leg = pus(rod, 0.0, stroke)
        legs.append(leg.replace(branch=leg.branch_at(q), guess=q))
        rotations.append(R)
    m1, m2, m3 = masses
    link3 = cylinder_link(m3, radius, rod, np.array([1.0, 0.0, 0.0]), 0.0)
    return RobotDescription(
        leg_base_rotations=np.array(rotations),
        stroke=None,
        leg_inertia=np.tile(
            np.stack([_sphere(m1, 3.0 * radius), _sphere(m2, 1.5 * radius), link3]), (6, 1, 1)
        ),
        legs=tuple(legs),
        **common,
    )


__all__ = [
    "MAX_HOME_CONDITION",
    "MAX_PAIR_ANGLE",
    "OPTIONS",
    "attachment_points",
    "symmetric_hexapod",
]
