"""The symmetric-hexapod builder (``stewart_pin.symmetric_hexapod``): 6-6 and 6-3,
6-UPS, 6-RUS and 6-PUS.

Independent references: the attachment points from the layout's definition (angles and
radii, written out here), the home leg (6-UPS) and rod (6-RUS) lengths and the slides'
heights (6-PUS) by Pythagoras, the platform inertia of a uniform disc moved by the
parallel-axis theorem (written out here), the U-joint angle ``q2 = pi/2`` at home (the
axes are perpendicular to the legs), the crank angles 0 at home (the cranks horizontal),
and the dynamics of the built robots against Pinocchio's constrained dynamics of the
closed-loop tree (``stewart_pin.validate``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stewart_pin import (
    DescriptionError,
    InertiaError,
    RobotDescription,
    StewartRobot,
    symmetric_hexapod,
    validate,
)
from stewart_pin.check.constrained_dynamics import DDM_TOLERANCE, IDM_TOLERANCE

RB, RP = 0.5, 0.35  # [m]
AB, AP = math.radians(20.0), math.radians(30.0)  # [rad]
HEIGHT, STROKE = 0.6, (0.55, 0.85)  # [m]
MASSES = (0.5, 4.0, 2.0)  # [kg]


def build(platform_pair_angle: float = AP, **kwargs) -> RobotDescription:
    args = {"platform_mass": 30.0, "leg_masses": MASSES, **kwargs}
    return symmetric_hexapod(RB, RP, AB, platform_pair_angle, HEIGHT, STROKE, **args)


def expected_points(radius: float, angles_deg: list[float]) -> np.ndarray:
    a = np.radians(angles_deg)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(6)])


@pytest.mark.parametrize("ap_deg", [30.0, 0.0], ids=["6-6", "6-3"])
def test_attachment_points_at_the_stated_radii_and_angles(ap_deg: float) -> None:
    desc = build(math.radians(ap_deg))
    b, p = 10.0, ap_deg / 2  # half pair angles [deg]
    B = expected_points(RB, [-b, b, 120 - b, 120 + b, 240 - b, 240 + b])
    P = expected_points(RP, [-60 + p, 60 - p, 60 + p, 180 - p, 180 + p, 300 - p])
    np.testing.assert_allclose(desc.base_points, B, rtol=0, atol=1e-15)  # [m], round-off
    np.testing.assert_allclose(desc.platform_points, P, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(desc.base_points, axis=1), RB, rtol=1e-15)
    pair = desc.base_points[0] @ desc.base_points[1] / RB**2
    assert math.acos(pair) == pytest.approx(AB, abs=1e-12)  # [rad]
    if ap_deg == 0.0:  # 6-3: the platform joints pairwise coincident
        for a, c in ((1, 2), (3, 4), (5, 0)):
            np.testing.assert_array_equal(desc.platform_points[a], desc.platform_points[c])


@pytest.mark.parametrize("ap", [AP, 0.0], ids=["6-6", "6-3"])
def test_home_pose_reaches_the_stated_height_inside_the_stroke(ap: float) -> None:
    desc = build(ap)
    robot = StewartRobot(desc)
    T = robot.home_pose
    np.testing.assert_array_equal(T[:3, :3], np.eye(3))
    assert T[:3, 3].tolist() == [0.0, 0.0, HEIGHT]
    # Pythagoras: the horizontal distance between B_1 and P_1 (law of cosines) and the height
    delta = math.radians(-60 + math.degrees(ap) / 2 + 10)  # angle of P_1 minus angle of B_1
    across2 = RB**2 + RP**2 - 2 * RB * RP * math.cos(delta)
    lengths = robot.leg_lengths(T)
    np.testing.assert_allclose(lengths, math.sqrt(across2 + HEIGHT**2), rtol=1e-14)
    assert np.all((lengths > STROKE[0]) & (lengths < STROKE[1]))
    q = robot.inverse_geometry(T)  # (6, 3): the U-joint axes perpendicular to the legs
    np.testing.assert_allclose(q[:, 1], math.pi / 2, atol=1e-12)
    assert robot.condition_number(T) < 10.0  # far from a parallel singularity at home


@pytest.mark.parametrize("ap", [AP, 0.0], ids=["6-6", "6-3"])
def test_dynamics_agree_with_pinocchio_constrained_dynamics(ap: float) -> None:
    desc = build(ap, platform_com=(0.01, -0.02, 0.05))
    report = validate(StewartRobot(desc), n_states=20, seed=3)
    assert report.passed(IDM_TOLERANCE, DDM_TOLERANCE), str(report)


def test_platform_inertia_default_disc_and_given_tensor() -> None:
    m, c = 30.0, np.array([0.01, -0.02, 0.05])  # [kg], [m]
    desc = build(platform_com=c)
    # uniform thin disc about its centre, then the parallel-axis theorem to O_p
    I_c = m * RP**2 * np.diag([0.25, 0.25, 0.5])
    I_O = I_c + m * (c @ c * np.eye(3) - np.outer(c, c))
    expected = [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *(m * c), m]
    np.testing.assert_allclose(desc.platform_inertia, expected, rtol=1e-14, atol=1e-16)
    given = build(platform_inertia=[1.0, 2.0, 2.5], platform_com=(0, 0, 0))
    np.testing.assert_allclose(given.platform_inertia[:6], [1.0, 0, 0, 2.0, 0, 2.5])
    assert given.leg_masses.tolist() == [list(MASSES)] * 6


def test_massless_legs_by_default_and_round_trip(tmp_path) -> None:
    desc = symmetric_hexapod(RB, RP, AB, 0.0, HEIGHT, STROKE, platform_mass=10.0)
    assert not np.any(desc.leg_inertia)
    back = RobotDescription.read(desc.write(tmp_path / "six-three.toml"))
    np.testing.assert_array_equal(back.platform_points, desc.platform_points)
    np.testing.assert_array_equal(back.home_pose, desc.home_pose)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"home_height": 0.9}, r"legs are 0\.9\d+ m long, outside the stroke .* home height in"),
        ({"home_height": -0.1}, "home_height"),
        ({"base_radius": 0.0}, "base_radius"),
        ({"platform_radius": float("nan")}, "platform_radius"),
        ({"base_pair_angle": math.radians(120.0)}, r"base_pair_angle .* below 2 pi / 3"),
        ({"platform_pair_angle": -0.1}, "platform_pair_angle"),
        ({"stroke": (0.9, 0.5)}, r"0 < min < max"),
        ({"stroke": (0.5,)}, "stroke"),
        ({"platform_mass": -1.0}, "platform_mass"),
        ({"leg_masses": (1.0, -2.0, 1.0)}, "leg_masses must be >= 0"),
        ({"platform_inertia": [[1, 2, 0], [0, 1, 0], [0, 0, 1]]}, "must be symmetric"),
        ({"leg_radius": 0.0}, "leg_radius"),
        ({"name": "../x"}, "robot name"),
        # pair angles adding to 120 degrees on equal radii: every P_i straight above its
        # B_i, every leg vertical: nothing holds the platform across, singular (and nearly)
        (
            {"platform_radius": RB, "base_pair_angle": math.radians(120.0) - AP},
            "the home pose is a parallel singularity",
        ),
        (
            {"platform_radius": RB, "base_pair_angle": math.radians(120.0 + 1e-4) - AP},
            "the home pose is a parallel singularity",
        ),
    ],
)
def test_bad_input_named(change: dict, match: str) -> None:
    args = {
        "base_radius": RB,
        "platform_radius": RP,
        "base_pair_angle": AB,
        "platform_pair_angle": AP,
        "home_height": HEIGHT,
        "stroke": STROKE,
        "platform_mass": 30.0,
        **change,
    }
    with pytest.raises(DescriptionError, match=match):
        symmetric_hexapod(**args)


def build_rus(platform_pair_angle: float) -> RobotDescription:
    """A desktop 6-RUS head: 8 cm / 6 cm radii, 3 cm cranks, 10 cm home height."""
    return symmetric_hexapod(
        0.08,
        0.06,
        math.radians(30.0),
        platform_pair_angle,
        0.1,
        architecture="rus",
        crank_length=0.03,
        platform_mass=1.0,
        leg_masses=(0.005, 0.002, 0.008),
        platform_com=(0.002, 0.0, 0.01),
    )


@pytest.mark.parametrize("ap", [math.radians(20.0), 0.0], ids=["6-6", "6-3"])
def test_rus_cranks_horizontal_at_home_and_dynamics_agree_with_pinocchio(ap: float) -> None:
    desc = build_rus(ap)
    assert desc.architecture == "rus" and desc.stroke is None
    robot = StewartRobot(desc)  # checks the home pose: reachable, away from singularities
    T = robot.home_pose
    assert T[:3, 3].tolist() == [0.0, 0.0, 0.1]
    np.testing.assert_allclose(robot.actuator_positions(T), 0.0, atol=1e-12)  # [rad]
    # the rod joins the crank tip C_i (3 cm along the tangent, away from the pair partner)
    # to P_i at home: its length by Pythagoras from the layout
    b, p = 15.0, math.degrees(ap) / 2  # half pair angles [deg]
    beta, phi = math.radians(-b), math.radians(-60 + p)  # B_1, P_1
    tangent = -np.array([-math.sin(beta), math.cos(beta), 0.0])  # leg 1: clockwise
    C = 0.08 * np.array([math.cos(beta), math.sin(beta), 0.0]) + 0.03 * tangent
    P = np.array([0.06 * math.cos(phi), 0.06 * math.sin(phi), 0.1])
    for leg in desc.legs:
        assert leg.tip[0] == pytest.approx(float(np.linalg.norm(P - C)), rel=1e-14)
    report = validate(robot, n_states=20, seed=3)
    assert report.passed(IDM_TOLERANCE, DDM_TOLERANCE), str(report)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"stroke": (0.1, 0.2)}, "stroke do not apply to a 6-RUS"),
        ({"crank_length": None}, "needs its crank_length"),
        ({"crank_limits": (0.1, 1.0)}, "must hold the horizontal home position"),
        ({"architecture": "sps"}, r"must be one of \['ups', 'rus', 'pus'\]"),
    ],
)
def test_rus_bad_input_named(change: dict, match: str) -> None:
    args = {"architecture": "rus", "crank_length": 0.03, "platform_mass": 1.0, **change}
    with pytest.raises(DescriptionError, match=match):
        symmetric_hexapod(0.08, 0.06, 0.5, 0.3, 0.1, **args)
    with pytest.raises(DescriptionError, match="crank_length do not apply to a 6-UPS"):
        symmetric_hexapod(RB, RP, AB, AP, HEIGHT, STROKE, platform_mass=1.0, crank_length=0.1)


def build_pus(platform_pair_angle: float, **kwargs) -> RobotDescription:
    """A hexaglide-like positioner: rails on a 0.4 m circle, 0.45 m rods, 0.6 m home."""
    args = {"rod_length": 0.45, "platform_mass": 8.0, "leg_masses": (1.0, 0.1, 0.4), **kwargs}
    return symmetric_hexapod(
        0.4,
        0.2,
        math.radians(24.0),
        platform_pair_angle,
        0.6,
        (0.0, 0.5),
        architecture="pus",
        **args,
    )


@pytest.mark.parametrize("ap", [math.radians(20.0), 0.0], ids=["6-6", "6-3"])
def test_pus_slides_at_the_height_the_rods_give_and_dynamics_agree_with_pinocchio(ap):
    desc = build_pus(ap, platform_com=(0.0, 0.01, 0.02))
    assert desc.architecture == "pus"
    robot = StewartRobot(desc)
    # P_1 at home, and its horizontal distance to the rail through B_1 (law of cosines)
    delta = math.radians(-60 + math.degrees(ap) / 2 + 12)  # angle of P_1 minus B_1's
    across = math.sqrt(0.4**2 + 0.2**2 - 2 * 0.4 * 0.2 * math.cos(delta))
    slide = 0.6 - math.sqrt(0.45**2 - across**2)  # [m] on the rail, below P_1
    np.testing.assert_allclose(robot.actuator_positions(robot.home_pose), slide, rtol=1e-13)
    report = validate(robot, n_states=20, seed=3)
    assert report.passed(IDM_TOLERANCE, DDM_TOLERANCE), str(report)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"rod_length": 0.1}, r"rods \(0\.1 m\) cannot reach"),
        ({"rod_length": 0.8}, r"slides are at -0\.1\d* m on their rails, outside the stroke"),
        ({"rod_length": None}, "needs its rod_length"),
        ({"crank_length": 0.1}, "crank_length do not apply to a 6-PUS"),
    ],
)
def test_pus_bad_input_named(change: dict, match: str) -> None:
    with pytest.raises(DescriptionError, match=match):
        build_pus(0.3, **change)


def test_non_physical_platform_inertia_refused() -> None:
    with pytest.raises(InertiaError, match=r"platform: .*triangle inequality"):
        build(platform_inertia=[1.0, 1.0, 3.0])
