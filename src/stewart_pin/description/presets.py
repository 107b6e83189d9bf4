"""Named robots, and a generator of general asymmetric robots for tests.

- ``simulator``: a symmetric 6-6 motion-simulator hexapod (1.8 m base radius, 1.2 t payload).
- ``desktop``: a small symmetric desktop hexapod (10 cm base radius).
- ``paper``: a hexapod placed with the paper's frames (F0 at B_1, x0 along B_1B_2,
  (x0, y0) the plane of B_1, B_2, B_6; Fp at P_1, xp along P_1P_2, (xp, yp) the plane of
  P_1, P_2, P_6), with an asymmetric platform.
- :func:`random_robot`: general asymmetric robots (non-planar attachment points, oblique
  U-joint axes, full inertia tensors and offset first moments on every link).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from stewart_pin._so3 import rotation_from_quaternion_wxyz
from stewart_pin.description.inertia import random_physical_khalil, transform_khalil
from stewart_pin.description.leg_chain_presets import GENERAL_PRESETS, random_hexapod
from stewart_pin.description.robot_description import RobotDescription, leg_base_rotation_from_axis
from stewart_pin.description.symmetric_presets import (
    GRAVITY,
    desktop,
    simulator,
    symmetric_geometry,
    symmetric_robot,
)
from stewart_pin.exceptions import DescriptionError


def paper() -> RobotDescription:
    """A hexapod with the paper's frame placement (F0 at B_1, Fp at P_1, fig. 2).

    A mid-size symmetric geometry re-expressed in those frames, with an asymmetric
    platform (full inertia tensor, offset centre of mass).
    """
    sym = symmetric_robot(
        "paper",
        rb=0.6,
        rp=0.4,
        db=8.0,
        dp=14.0,
        stroke=(0.75, 1.15),
        platform_mass=40.0,
        platform_com_height=0.08,
        platform_gyration=(0.25, 0.27, 0.33),
        link_masses=(0.5, 6.0, 3.0),
        cylinder_length=0.5,
        rod_length=0.5,
        radius=0.03,
    )
    R0, p0 = _paper_frame(sym.base_points)
    Rp, pp = _paper_frame(sym.platform_points)
    platform = transform_khalil(sym.platform_inertia, Rp.T, -Rp.T @ pp)
    # An asymmetric payload: a 5 kg box offset from the platform centre.
    rng = np.random.default_rng(2003)
    payload = random_physical_khalil(rng, mass=5.0, size=0.1, com_offset=0.05)
    platform = platform + transform_khalil(payload, np.eye(3), np.array([0.25, 0.12, 0.1]))
    T = sym.home_pose
    home = np.eye(4)
    home[:3, :3] = R0.T @ T[:3, :3] @ Rp
    home[:3, 3] = R0.T @ (T[:3, :3] @ pp + T[:3, 3] - p0)
    return RobotDescription(
        base_points=(sym.base_points - p0) @ R0,
        platform_points=(sym.platform_points - pp) @ Rp,
        leg_base_rotations=np.einsum("ji,njk->nik", R0, sym.leg_base_rotations),
        stroke=sym.stroke,
        leg_inertia=sym.leg_inertia,
        platform_inertia=platform,
        gravity=R0.T @ sym.gravity,
        name="paper",
        home_pose=home,
    )


def _paper_frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's frame on six points: origin at point 1, x along 1->2, (x, y) plane
    through points 1, 2 and 6. Returns its orientation and origin in the current frame."""
    x = points[1] - points[0]
    x /= np.linalg.norm(x)
    z = np.cross(x, points[5] - points[0])
    z /= np.linalg.norm(z)
    return np.column_stack([x, np.cross(z, x), z]), points[0].copy()


def random_robot(seed: int = 0) -> RobotDescription:
    """A general asymmetric robot for tests: perturbed non-planar attachment points, a
    platform frame away from the platform centre and rotated, oblique U-joint axes (q2i
    away from pi/2), full inertia tensors and offset first moments on every body."""
    rng = np.random.default_rng(seed)
    B, P = symmetric_geometry(0.5, 0.32, 10.0, 14.0)
    B = B + rng.uniform(-0.04, 0.04, (6, 3))
    P = P + rng.uniform(-0.03, 0.03, (6, 3))
    height = 0.7
    P_home_in_0 = P + np.array([0.0, 0.0, height])
    # Platform frame: origin offset from the centroid, orientation tilted.
    q = rng.normal(size=4)
    R_home = rotation_from_quaternion_wxyz(q)
    R_home = _slerp_identity(R_home, 0.15)
    p_home = np.array([0.03, -0.02, height + 0.05])
    P_local = (P_home_in_0 - p_home) @ R_home
    lengths = np.linalg.norm(P_home_in_0 - B, axis=1)
    rotations = []
    for b, p in zip(B, P_home_in_0, strict=True):
        d = p - b
        axis = np.cross([0.0, 0.0, 1.0], d)
        axis = axis / np.linalg.norm(axis) + rng.uniform(-0.3, 0.3, 3)
        rotations.append(leg_base_rotation_from_axis(axis, d + rng.uniform(-0.3, 0.3, 3)))
    legs = np.array(
        [
            [
                random_physical_khalil(rng, rng.uniform(0.2, 0.6), 0.05, 0.03),
                random_physical_khalil(rng, rng.uniform(2.0, 5.0), 0.25, 0.15),
                random_physical_khalil(rng, rng.uniform(1.0, 3.0), 0.25, 0.15),
            ]
            for _ in range(6)
        ]
    )
    home = np.eye(4)
    home[:3, :3], home[:3, 3] = R_home, p_home
    gravity = GRAVITY + rng.uniform(-0.5, 0.5, 3)
    return RobotDescription(
        base_points=B,
        platform_points=P_local,
        leg_base_rotations=np.array(rotations),
        stroke=np.array([lengths.min() * 0.75, lengths.max() * 1.3]),
        leg_inertia=legs,
        platform_inertia=random_physical_khalil(rng, rng.uniform(10.0, 30.0), 0.3, 0.1),
        gravity=gravity,
        name=f"random-{seed}",
        home_pose=home,
    )


def _slerp_identity(R: np.ndarray, fraction: float) -> np.ndarray:
    """The rotation ``fraction`` of the way from the identity to ``R``."""
    import pinocchio as pin  # here: reading a description needs no Pinocchio

    return pin.exp3(fraction * pin.log3(R))


PRESETS: dict[str, Callable[[], RobotDescription]] = {
    "simulator": simulator,
    "desktop": desktop,
    "paper": paper,
}


def _general(name: str) -> Callable[[], RobotDescription]:
    def build() -> RobotDescription:
        return GENERAL_PRESETS[name]().to_description()

    build.__name__ = name.replace("-", "_")
    build.__doc__ = f"The general-leg preset ``{name}`` as a description with ``legs``."
    return build


#: The general-leg presets (:mod:`stewart_pin.description.leg_chain_presets`): a 6-UPS with
#: offset U-joint axes, a 6-RUS desktop head, a 6-PUS positioner. Kept apart from
#: :data:`PRESETS` (the ideal 6-UPS robots, whose robot files are committed in
#: ``models/urdf``); :func:`preset` takes both.
LEG_PRESETS: dict[str, Callable[[], RobotDescription]] = {
    name: _general(name) for name in ("ups-offset", "rus", "pus")
}
#: Kinds of ``random-<kind>-<seed>``
#: (:func:`~stewart_pin.description.leg_chain_presets.random_hexapod`).
RANDOM_KINDS = ("ups", "ups-offset", "rus", "pus", "custom")
#: Every preset name :func:`preset` takes, beside ``random-<seed>`` and
#: ``random-<kind>-<seed>``.
PRESET_NAMES = (*PRESETS, *LEG_PRESETS)


def preset(name: str) -> RobotDescription:
    """A named preset (``simulator``, ``desktop``, ``paper``: ideal 6-UPS; ``ups-offset``,
    ``rus``, ``pus``: general legs with joint dynamics), ``random-<seed>`` (an asymmetric
    ideal 6-UPS) or ``random-<kind>-<seed>`` with a kind of :data:`RANDOM_KINDS` (e.g.
    ``random-rus-3``: an asymmetric general robot with every joint term non-zero)."""
    if not isinstance(name, str):
        raise DescriptionError(f"a preset name is a string, got {type(name).__name__}")
    if name in PRESETS:
        return PRESETS[name]()
    if name in LEG_PRESETS:
        return LEG_PRESETS[name]()
    if name.startswith("random-") and name[7:].isdigit():
        return random_robot(int(name[7:]))
    if name.startswith("random-"):
        kind, _, seed = name[7:].rpartition("-")
        if kind in RANDOM_KINDS and seed.isdigit() and len(seed) <= 9:
            return random_hexapod(kind, int(seed)).to_description()
    raise DescriptionError(
        f"unknown preset '{name}'; choose one of {list(PRESET_NAMES)}, 'random-<seed>' or "
        f"'random-<kind>-<seed>' with a kind of {list(RANDOM_KINDS)}"
    )
