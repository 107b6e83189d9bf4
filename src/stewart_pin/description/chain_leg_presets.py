"""Robots with chain legs (:class:`~stewart_pin.description.chain_leg.ChainLeg`) for tests
and examples, every link massive and every joint with its terms (armature, viscous and
Coulomb friction, spring, damper):

- :func:`welded_ups`: a 6-UPS whose spherical joint is a spin hinge plus a U-joint whose
  axes miss each other by ``offset`` (0.5 mm), welded to the platform: U(2) + P + spin +
  U(2), six joints, weld closure.
- :func:`mixed_chain_robot`: legs 1, 3, 5 three-joint U-P-S legs closed by a ball, legs 2,
  4, 6 the six-joint welded legs above.

The geometry is :func:`~stewart_pin.description.presets.random_robot`'s (asymmetric,
tilted home pose). A welded leg's platform attachment (``P_i`` and its orientation in Fp)
is its attachment frame at the home pose, the leg's joints at chosen home values: the
robot closes exactly at its home pose.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from functools import partial

import numpy as np

from stewart_pin.description.chain_leg import ChainLeg
from stewart_pin.description.inertia import khalil_from_urdf_inertial, random_physical_khalil
from stewart_pin.description.leg_architecture import (
    Joint,
    JointDynamics,
    prismatic,
    revolute,
    ups,
)
from stewart_pin.description.leg_chain_presets import random_joint_dynamics, rus_preset
from stewart_pin.description.presets import random_robot
from stewart_pin.description.robot_description import RobotDescription

#: The miss distance of the upper U-joint's axes in :func:`welded_ups` [m].
UPPER_U_OFFSET = 5e-4


def _ups_angles(R0: np.ndarray, B: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``(q1, q2, q3)`` of a U-P-S leg (q2 in (0, pi)) reaching P from B."""
    u = R0.T @ (P - B)
    length = float(np.linalg.norm(u))
    u = u / length
    return np.array([math.atan2(u[1], u[0]), math.acos(-u[2]), length])


def _leg_dynamics(rng: np.random.Generator, kinds: str, joint_terms: bool) -> list[JointDynamics]:
    if not joint_terms:
        return [JointDynamics() for _ in kinds]
    return [random_joint_dynamics(rng, "revolute" if k == "R" else "prismatic") for k in kinds]


def welded_joints(rng: np.random.Generator, offset: float, joint_terms: bool) -> tuple[Joint, ...]:
    """U(2) + P + spin + U(2) with the upper U-joint's axes ``offset`` [m] apart."""
    dyn = _leg_dynamics(rng, "RRPRRR", joint_terms)
    return (
        revolute(dynamics=dyn[0]),
        revolute(alpha=math.pi / 2, dynamics=dyn[1]),
        prismatic(alpha=math.pi / 2, lower=0.2, upper=2.0, dynamics=dyn[2]),
        revolute(lower=0.0, upper=2.0 * math.pi, dynamics=dyn[3]),  # the spin: a full turn
        revolute(alpha=math.pi / 2, dynamics=dyn[4]),
        revolute(alpha=math.pi / 2, d=offset, dynamics=dyn[5]),
    )


def _links(rng: np.random.Generator, masses: list[float]) -> np.ndarray:
    return np.array([random_physical_khalil(rng, m, 0.03, 0.02) for m in masses])


def _welded_leg(
    rng: np.random.Generator,
    base: RobotDescription,
    k: int,
    offset: float,
    joint_terms: bool,
    spin: float,
    wrist: float,
) -> tuple[ChainLeg, np.ndarray]:
    """Leg k welded, and its platform attachment ``P_k`` in Fp (spin, upper U-joint's
    first angle and second angle at home: ``spin``, ``wrist``, -0.4 rad)."""
    H = base.home_pose
    P0 = H[:3, :3] @ base.platform_points[k] + H[:3, 3]
    q_home = np.concatenate(
        [_ups_angles(base.leg_base_rotations[k], base.base_points[k], P0), [spin, wrist, -0.4]]
    )
    joints = welded_joints(rng, offset, joint_terms)
    tip = np.array([0.012, -0.008, 0.02])
    tip_rotation = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(0.3), -math.sin(0.3)],
            [0.0, math.sin(0.3), math.cos(0.3)],
        ]
    )
    masses = [0.05, 0.08, 1.2, 0.03, 0.015, 0.09]
    leg = ChainLeg(joints, 3, "weld", _links(rng, masses), tip, tip_rotation, guess=q_home)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = base.leg_base_rotations[k], base.base_points[k]
    for joint, qj in zip(joints, q_home, strict=True):
        T = T @ joint.transform(float(qj))
    T = T @ leg.attachment()
    P_local = H[:3, :3].T @ (T[:3, 3] - H[:3, 3])
    R_local = H[:3, :3].T @ T[:3, :3]
    return leg.replace(platform_rotation=R_local), P_local


def _ball_leg(
    rng: np.random.Generator, base: RobotDescription, k: int, joint_terms: bool
) -> ChainLeg:
    """A three-joint U-P-S leg with a ball, massive links and joint terms."""
    dyn = _leg_dynamics(rng, "RRP", joint_terms)
    leg = ups((0.2, 2.0), dynamics=dyn)
    H = base.home_pose
    P0 = H[:3, :3] @ base.platform_points[k] + H[:3, 3]
    chain = ChainLeg.from_architecture(leg, _links(rng, [0.4, 2.5, 1.5]))
    return chain.replace(guess=_ups_angles(base.leg_base_rotations[k], base.base_points[k], P0))


def _robot(
    name: str,
    welded: tuple[int, ...],
    seed: int,
    offset: float,
    joint_terms: bool,
    spin: float = 0.3,
    wrist: float = 1.7,
) -> RobotDescription:
    base = random_robot(seed)
    rng = np.random.default_rng(1000 + seed)
    legs, points = [], base.platform_points.copy()
    for k in range(6):
        if k in welded:
            leg, points[k] = _welded_leg(rng, base, k, offset, joint_terms, spin, wrist)
        else:
            leg = _ball_leg(rng, base, k, joint_terms)
        legs.append(leg)
    return RobotDescription(
        base_points=base.base_points,
        platform_points=points,
        leg_base_rotations=base.leg_base_rotations,
        stroke=None,
        leg_inertia=np.zeros((6, 3, 10)),
        platform_inertia=base.platform_inertia,
        gravity=base.gravity,
        name=name,
        home_pose=base.home_pose,
        chain_legs=tuple(legs),
    )


def rss_robot(symmetric: bool = True, joint_terms: bool = True, seed: int = 0) -> RobotDescription:
    """A 6-RSS: the ``rus`` preset's geometry (servo cranks, 10 cm rods) with each rod on a
    spherical joint at the crank tip, modelled as a U-joint (joints 2, 3) plus the rod's
    spin about its ball-to-ball line (joint 4, the leg's ``idle_joint``: the rod along z4
    from the U-joint centre to the ball at ``tip = [0, 0, rod]``). Every link massive; the
    rod ``symmetric`` about its line (a solid cylinder) or not (an off-axis centre of mass
    and a full inertia tensor); ``joint_terms``: every joint's terms on (the spin's too).
    """
    base = rus_preset()
    rng = np.random.default_rng(2000 + seed)
    legs = []
    for k, leg in enumerate(base.legs):
        crank_joint, u1 = leg.joints[0], leg.joints[1]
        rod = float(leg.tip[0])
        dyn = _leg_dynamics(rng, "RRRR", joint_terms)
        scaled = [  # a desktop robot's joints: 1/1000 of random_joint_dynamics' terms
            JointDynamics(
                armature=d.armature * 1e-3,
                viscous=d.viscous * 1e-3,
                coulomb=d.coulomb * 1e-3,
                stiffness=d.stiffness * 1e-3,
                rest_position=d.rest_position,
                damping=d.damping * 1e-3,
            )
            for d in dyn
        ]
        joints = (
            replace(crank_joint, dynamics=scaled[0]),
            replace(u1, dynamics=scaled[1]),
            revolute(alpha=math.pi / 2, theta=math.pi / 2, dynamics=scaled[2]),
            revolute(alpha=math.pi / 2, dynamics=scaled[3]),  # the spin: z4 along the rod
        )
        if symmetric:
            rod_link = _cylinder(0.008, 0.002, rod)
        else:
            c, s = math.cos(0.3), math.sin(0.3)  # principal axes tilted off the rod's line
            R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
            I_c = R @ np.diag([6e-6, 7e-6, 1.5e-6]) @ R.T
            rod_link = khalil_from_urdf_inertial(0.008, np.array([0.003, -0.002, rod / 2]), I_c)
        inertia = np.array(
            [
                base.leg_inertia[k, 0],
                khalil_from_urdf_inertial(0.002, np.zeros(3), 3e-8 * np.eye(3)),
                khalil_from_urdf_inertial(0.0015, np.array([0.001, 0.0, 0.0]), 2e-8 * np.eye(3)),
                rod_link,
            ]
        )
        q = leg.guess
        legs.append(
            ChainLeg(
                joints,
                1,
                "ball",
                inertia,
                np.array([0.0, 0.0, rod]),
                guess=np.array([q[0], q[1], q[2], 0.2 * (k - 2.5)]),
                idle_joint=4,
            )
        )
    return RobotDescription(
        base_points=base.base_points,
        platform_points=base.platform_points,
        leg_base_rotations=base.leg_base_rotations,
        stroke=None,
        leg_inertia=np.zeros((6, 3, 10)),
        platform_inertia=base.platform_inertia,
        gravity=base.gravity,
        name=f"rss-{'symmetric' if symmetric else 'asymmetric'}",
        home_pose=base.home_pose,
        chain_legs=tuple(legs),
    )


def _cylinder(mass: float, radius: float, length: float) -> np.ndarray:
    """A solid cylinder along z from 0 to ``length`` [m]: symmetric about its axis."""
    axial = 0.5 * mass * radius**2
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    return khalil_from_urdf_inertial(
        mass, np.array([0.0, 0.0, length / 2]), np.diag([transverse, transverse, axial])
    )


def welded_ups(
    seed: int = 0,
    offset: float = UPPER_U_OFFSET,
    joint_terms: bool = True,
    spin: float = 0.3,
    wrist: float = 1.7,
) -> RobotDescription:
    """Six welded six-joint legs (module docstring); ``offset`` [m] the upper U-joint's
    axis miss distance; ``spin`` and ``wrist`` [rad] the spin and the upper U-joint's
    first angle at the home pose (``wrist = 0``: the spin and the U-joint's second axis
    aligned, a singular leg)."""
    return _robot(f"welded-ups-{seed}", tuple(range(6)), seed, offset, joint_terms, spin, wrist)


def mixed_chain_robot(
    seed: int = 0, offset: float = UPPER_U_OFFSET, joint_terms: bool = True
) -> RobotDescription:
    """Legs 1, 3, 5 U-P-S with a ball, legs 2, 4, 6 welded six-joint legs."""
    return _robot(f"mixed-chain-{seed}", (1, 3, 5), seed, offset, joint_terms)


#: The chain-leg robots the benchmark and the operation counts name (``stewart-pin bench
#: --architectures welded-ups``): name -> description (seed 0, joint terms on).
CHAIN_PRESETS: dict[str, Callable[[], RobotDescription]] = {
    "welded-ups": welded_ups,
    "mixed-chain": mixed_chain_robot,
    "rss-asymmetric": partial(rss_robot, symmetric=False),  # idle freedoms: the rod spins
}


__all__ = [
    "CHAIN_PRESETS",
    "UPPER_U_OFFSET",
    "mixed_chain_robot",
    "rss_robot",
    "welded_joints",
    "welded_ups",
]
