"""The symmetric triangle-triangle 6-6 hexapods: ``simulator`` and ``desktop`` (ideal
6-UPS), and the builders they share with the other presets (:mod:`.presets`, which
re-exports them, and :mod:`.leg_chain_presets`, whose ``ups-offset`` is the desktop with
offset U-joints).
"""

from __future__ import annotations

import numpy as np

from stewart_pin.description.inertia import khalil_from_urdf_inertial
from stewart_pin.description.robot_description import RobotDescription, leg_base_rotation_from_axis

GRAVITY = np.array([0.0, 0.0, -9.81])  # [m/s^2]


def _triangle_points(radius: float, angles_deg: list[float], z: float = 0.0) -> np.ndarray:
    a = np.radians(angles_deg)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.full(6, z)])


def symmetric_geometry(rb: float, rp: float, db: float, dp: float) -> tuple[np.ndarray, ...]:
    """Base and platform points of the classic triangle-triangle 6-6 hexapod.

    Leg i joins the base point at ``120 k +/- db`` to the platform point at ``120 k +/- 60
    -/+ dp`` degrees, so adjacent base points feed different platform pairs.
    """
    B = _triangle_points(rb, [-db, db, 120 - db, 120 + db, 240 - db, 240 + db])
    P = _triangle_points(rp, [-60 + dp, 60 - dp, 60 + dp, 180 - dp, 180 + dp, 300 - dp])
    return B, P


def cylinder_link(
    mass: float, radius: float, length: float, axis: np.ndarray, start: float
) -> np.ndarray:
    """Khalil parameters of a solid cylinder along ``axis`` (unit, in the link frame) whose
    centre is at ``(start + length / 2) * axis``."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    I_c = transverse * np.eye(3) + (axial - transverse) * np.outer(axis, axis)
    return khalil_from_urdf_inertial(mass, (start + 0.5 * length) * axis, I_c)


def _axes_and_rotations(B: np.ndarray, P_home_in_0: np.ndarray) -> np.ndarray:
    """Horizontal first axes, perpendicular to each leg at home (q2i = pi/2 there)."""
    rotations = []
    for b, p in zip(B, P_home_in_0, strict=True):
        d = p - b
        axis = np.cross([0.0, 0.0, 1.0], d)
        rotations.append(leg_base_rotation_from_axis(axis, d))
    return np.array(rotations)


def symmetric_robot(
    name: str,
    rb: float,
    rp: float,
    db: float,
    dp: float,
    stroke: tuple[float, float],
    platform_mass: float,
    platform_com_height: float,
    platform_gyration: tuple[float, float, float],
    link_masses: tuple[float, float, float],
    cylinder_length: float,
    rod_length: float,
    radius: float,
) -> RobotDescription:
    B, P = symmetric_geometry(rb, rp, db, dp)
    m1, m2, m3 = link_masses
    # Link 1 (U-joint cross): a small sphere-like body at B_i.
    I1 = 0.4 * m1 * (1.5 * radius) ** 2
    link1 = khalil_from_urdf_inertial(m1, np.zeros(3), I1 * np.eye(3))
    # Link 2 (cylinder body): along -y2 (the leg direction in frame 2), from B_i upwards.
    link2 = cylinder_link(m2, 1.4 * radius, cylinder_length, np.array([0.0, -1.0, 0.0]), 0.0)
    # Link 3 (piston rod): along z3, ending at P_i (origin of frame 3).
    link3 = cylinder_link(m3, radius, rod_length, np.array([0.0, 0.0, 1.0]), -rod_length)
    leg = np.stack([link1, link2, link3])
    kx, ky, kz = platform_gyration
    I_c = platform_mass * np.diag([kx**2, ky**2, kz**2])
    platform = khalil_from_urdf_inertial(
        platform_mass, np.array([0.0, 0.0, platform_com_height]), I_c
    )
    draft = RobotDescription(
        base_points=B,
        platform_points=P,
        leg_base_rotations=np.tile(np.eye(3), (6, 1, 1)),
        stroke=np.array(stroke),
        leg_inertia=np.tile(leg, (6, 1, 1)),
        platform_inertia=platform,
        gravity=GRAVITY,
        name=name,
    )
    T = draft.home_pose
    rotations = _axes_and_rotations(B, P @ T[:3, :3].T + T[:3, 3])
    return draft.replace(leg_base_rotations=rotations)


def simulator() -> RobotDescription:
    """A symmetric 6-6 motion-simulator hexapod: 1.8 m / 1.2 m attachment radii, stroke
    2.0-2.8 m, a 1200 kg cockpit platform, 2 + 45 + 18 kg per leg."""
    return symmetric_robot(
        "simulator",
        rb=1.8,
        rp=1.2,
        db=10.0,
        dp=12.0,
        stroke=(2.0, 2.8),
        platform_mass=1200.0,
        platform_com_height=0.5,
        platform_gyration=(0.9, 0.9, 1.05),
        link_masses=(2.0, 45.0, 18.0),
        cylinder_length=1.5,
        rod_length=1.5,
        radius=0.06,
    )


def desktop() -> RobotDescription:
    """A small desktop hexapod: 10 cm / 7.5 cm radii, stroke 13-19 cm, 0.6 kg platform."""
    return symmetric_robot(
        "desktop",
        rb=0.10,
        rp=0.075,
        db=12.0,
        dp=15.0,
        stroke=(0.13, 0.19),
        platform_mass=0.6,
        platform_com_height=0.01,
        platform_gyration=(0.05, 0.05, 0.06),
        link_masses=(0.005, 0.04, 0.02),
        cylinder_length=0.1,
        rod_length=0.1,
        radius=0.006,
    )


__all__ = [
    "GRAVITY",
    "cylinder_link",
    "desktop",
    "simulator",
    "symmetric_geometry",
    "symmetric_robot",
]
