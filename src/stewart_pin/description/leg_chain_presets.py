"""Generators and presets of general-leg robots (:class:`GeneralHexapod`).

- :func:`random_hexapod` : general asymmetric robots per architecture for tests (random
  placements, full inertia tensors, offset first moments, every joint term non-zero,
  gear and screw transmissions on the actuated joints).
- Presets (to be registered with the 6-UPS ones): ``ups-offset`` (the ``desktop`` hexapod
  with offset U-joint axes), ``rus`` (a desktop animatronic head: 3 cm servo cranks,
  10 cm rods, a 1 kg head) and ``pus`` (a hexaglide-like positioner on vertical rails):
  :data:`GENERAL_PRESETS`.

Each robot's platform points are its legs' tips at chosen home joint values, so the
home pose is reachable by construction, and each leg's branch is its home
configuration's (:meth:`LegArchitecture.branch_at`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from stewart_pin.description.inertia import khalil_from_urdf_inertial, random_physical_khalil
from stewart_pin.description.leg_architecture import (
    PRISMATIC,
    REVOLUTE,
    JointDynamics,
    LegArchitecture,
    pus,
    rus,
    ups,
    ups_offset,
)
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.description.symmetric_presets import desktop
from stewart_pin.exceptions import ArchitectureError


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
    import pinocchio as pin  # imported when used: the package imports without it

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
    ``rus``, ``pus``, or ``custom``: P-R-R legs with non-intersecting U axes, solved by
    Newton's method) for tests: perturbed placements and joint parameters, a rotated
    platform frame away from the centroid, full inertia tensors and offset first moments
    on every body, and (``joint_terms``) every joint dynamics term non-zero, with gear and
    screw transmissions on the actuated joints."""
    rng = np.random.default_rng(seed)

    def dyn(kind_: str, transmission: bool = False) -> JointDynamics:
        if not joint_terms:
            return JointDynamics()
        return random_joint_dynamics(rng, kind_, transmission=transmission)

    rotations: Any
    q_home: Any
    legs: list[LegArchitecture]
    if kind == "custom":
        # A P-R-R leg whose last two axes do not intersect (d3, r3 != 0): no closed form.
        base = random_hexapod("pus", seed, joint_terms)
        legs = []
        for leg in base.legs:
            j1, j2, j3 = leg.joints
            j3 = replace(j3, d=float(rng.uniform(0.005, 0.015)), r=float(rng.uniform(-0.01, 0.01)))
            legs.append(leg.replace(name="custom", joints=(j1, j2, j3)))
        T = base.home_pose
        return _assemble(
            f"random-custom-{seed}",
            base.base_points,
            base.leg_base_rotations,
            legs,
            np.array([leg.guess for leg in base.legs]),
            base.leg_inertia,
            base.platform_inertia,
            base.gravity,
            T[:3, :3],
            T[:3, 3],
        )
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
            leg = ups_offset(offset, dynamics=dyns) if offset else ups(dynamics=dyns)
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
            "'ups', 'ups-offset', 'rus', 'pus', 'custom'",
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
def _rod_params(
    mass: float, radius: float, length: float, axis: np.ndarray, start: float
) -> np.ndarray:
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
    desc = desktop()
    base = general_from_description(desc)
    lead = JointDynamics(
        armature=0.02, viscous=20.0, coulomb=1.0, screw_lead=0.002, rotor_inertia=2e-6
    )
    small = JointDynamics(viscous=1e-3, coulomb=1e-3)
    legs: list[LegArchitecture] = []
    q_home: Any = []
    T = np.asarray(desc.home_pose)
    P0 = desc.platform_points @ T[:3, :3].T + T[:3, 3]
    for i in range(6):
        stroke = desc.ideal_stroke("ups_offset_preset")
        leg = ups_offset(offset, (stroke[0], stroke[1]), dynamics=(small, small, lead))
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
    rotations: Any = []
    q_home: Any = []
    legs: list[LegArchitecture] = []
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
    rotations: Any = []
    q_home: Any = []
    legs: list[LegArchitecture] = []
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


__all__ = [
    "GENERAL_PRESETS",
    "pus_preset",
    "random_hexapod",
    "random_joint_dynamics",
    "rus_preset",
    "ups_offset_preset",
]
