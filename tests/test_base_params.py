"""Base and essential inertial parameters.

References: the numerical rank of the stacked regressor (SVD), principal angles between
the analytic and numerical base spaces, the null space of the grouping map, and the
inverse dynamic model for the forces the reduced sets predict.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import pytest
import scipy.linalg
from helpers import rel_error

from stewart_pin import RobotDescription, StewartRobot, random_robot
from stewart_pin.description.presets import preset
from stewart_pin.description.robot_description import leg_base_rotation_from_axis
from stewart_pin.dynamics.regressor import STANDARD_NAMES
from stewart_pin.exceptions import BaseParameterWarning, InputError
from stewart_pin.kinematics.workspace import sample_states
from stewart_pin.parameters.base import (
    analytic_base_parameters,
    base_parameters,
    essential_parameters,
    grouped_parameters,
    numerical_base_parameters,
    paper_essential_parameters,
    stacked_regressor,
)


@pytest.fixture(scope="module")
def robot(parameter_robot) -> StewartRobot:
    return parameter_robot


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_rank_is_88_for_general_robots(seed):
    robot = StewartRobot(random_robot(seed))
    W = stacked_regressor(robot, 50, seed)
    W = W / np.maximum(np.linalg.norm(W, axis=0), 1e-300)
    sv = np.linalg.svd(W, compute_uv=False)
    # A wide gap: the kept singular values are > 1e-4 of the largest, the dropped < 1e-13.
    assert sv[87] / sv[0] > 1e-4
    assert sv[88] / sv[0] < 1e-13
    _, report = numerical_base_parameters(robot, n_states=50, seed=seed)
    assert report.rank == 88
    assert report.smallest_kept > 1e4 * report.largest_dropped


def test_analytic_and_numerical_base_sets_span_the_same_space(robot):
    analytic = base_parameters(robot, "analytic")
    numerical = base_parameters(robot, "numerical", n_states=50, seed=3)
    assert len(analytic) == len(numerical) == 88
    W = stacked_regressor(robot, 40, 17)  # states neither set was built from
    angles = scipy.linalg.subspace_angles(
        scipy.linalg.orth(analytic.reduce(W)), scipy.linalg.orth(W)
    )
    assert angles.max() < 1e-9
    assert np.linalg.matrix_rank(analytic.reduce(W)) == 88
    # The directions the analytic set declares unidentifiable leave every force unchanged.
    null = scipy.linalg.null_space(analytic.K)
    assert null.shape[1] == 190 - 88
    assert np.abs(W @ null).max() < 1e-10 * np.abs(W).max()


def test_base_regressor_reproduces_inverse_dynamics(robot):
    poses, twists, accels = sample_states(robot.description, 100, 8)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    for method in ("analytic", "numerical"):
        bp = base_parameters(robot, method)
        Wb = bp.regressor(poses, twists, accels)
        assert Wb.shape == (100, 6, 88)
        assert rel_error(Wb @ bp.values, gamma) < 1e-10


def test_analytic_values_follow_the_paper_relations():
    """Spot-check eq. 44-50 and the M3 grouping on explicit numbers."""
    desc = random_robot(5)
    bp = analytic_base_parameters(desc)
    v = dict(zip(bp.names, bp.values, strict=True))
    leg = desc.leg_inertia[2]  # leg 3
    XX, XY, XZ, YY, YZ, ZZ, _MX, MY, MZ, M = range(10)
    assert v["ZZ1R_3"] == pytest.approx(leg[0, ZZ] + leg[1, YY] + leg[2, ZZ], rel=1e-14)
    assert v["MY1R_3"] == pytest.approx(leg[0, MY] - leg[1, MZ], rel=1e-14)
    assert v["XX2R_3"] == pytest.approx(
        leg[1, XX] + leg[2, XX] - leg[1, YY] - leg[2, ZZ], rel=1e-14
    )
    assert v["XZ2R_3"] == pytest.approx(leg[1, XZ] + leg[2, XY], rel=1e-14)
    m3 = desc.leg_inertia[:, 2, M]
    L = desc.platform_points
    assert v["M_RP"] == pytest.approx(desc.platform_inertia[M] + m3.sum(), rel=1e-14)
    assert v["YZ_RP"] == pytest.approx(
        desc.platform_inertia[YZ] - (m3 * L[:, 1] * L[:, 2]).sum(), rel=1e-14
    )


def _essential_force_error(robot, ess, n=50, seed=99) -> float:
    """Relative 2-norm force error of the kept essential parameters against the IDM."""
    bp = base_parameters(robot)
    poses, twists, accels = sample_states(robot.description, n, seed)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    predicted = bp.regressor(poses, twists, accels)[..., ess.index] @ ess.values
    return float(np.linalg.norm(predicted - gamma) / np.linalg.norm(gamma))


def test_essential_parameters_of_a_symmetric_robot_are_exact():
    """The paper preset has links symmetric about their axes: 5 per leg + 10 remain with
    no loss (the other base parameters are zero)."""
    robot = StewartRobot.from_preset("paper")
    ess = essential_parameters(robot, threshold=1e-12, n_states=40)
    assert len(ess) == 40
    assert all(error == 0.0 for _, error in ess.removal_order)
    assert _essential_force_error(robot, ess) < 1e-12
    # The paper's Table III set (52) holds these 40 and two more first moments per leg.
    paper = paper_essential_parameters(robot, n_states=40)
    assert len(paper) == 52 and set(ess.names) <= set(paper.names)
    assert paper.relative_error < 1e-12 and _essential_force_error(robot, paper) < 1e-12


@pytest.mark.parametrize("threshold", [1e-3, 1e-2])
def test_essential_parameters_respect_the_threshold(threshold):
    robot = StewartRobot(random_robot(4))
    ess = essential_parameters(robot, threshold=threshold, n_states=80, seed=1)
    assert len(ess) < 88
    assert ess.relative_error <= threshold
    # On states it was not chosen on, the kept set still predicts the forces closely.
    assert _essential_force_error(robot, ess) < 3 * threshold


def test_paper_essential_set_loses_accuracy_on_a_general_robot():
    """A robot breaking the paper's assumptions (asymmetric links) needs more than 52."""
    robot = StewartRobot(random_robot(4))
    assert paper_essential_parameters(robot, n_states=40).relative_error > 1e-3


# ------------------------------------------------------------------ special geometries
def _ring(radius: float, degrees: Sequence[float], z: Sequence[float] | float = 0.0):
    a = np.radians(degrees)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.broadcast_to(z, 6)])


#: Planar attachment points in the classic triangle-triangle pattern (another spacing than
#: the presets'), and the same platform points moved off their plane symmetrically.
PLANAR_B = _ring(1.8, [-10, 10, 110, 130, 230, 250])
PLANAR_P = _ring(1.2, [-50, 50, 70, 170, 190, 290])
SYMMETRIC_P = _ring(1.2, [-50, 50, 70, 170, 190, 290], [0.1, -0.1, 0.1, -0.1, 0.1, -0.1])


def special_robot(
    name: str,
    axes: str = "preset",
    legs: Sequence[int] = range(6),
    tilt: float = 0.0,
    gravity: Sequence[float] | None = None,
    points: tuple[np.ndarray, np.ndarray] | None = None,
) -> StewartRobot:
    """A preset with special geometry.

    Args:
        name: the preset to start from.
        axes: ``"preset"`` (keep the first U-joint axes), ``"vertical"`` (first axis of each
            leg in ``legs`` along -gravity, i.e. parallel to it, tilted by ``tilt`` [rad]
            towards the leg; F0's z when gravity is zero) or ``"horizontal"``
            (perpendicular to gravity and to the leg at home).
        gravity: replaces the gravity vector [m/s^2] (in F0).
        points: ``(B, P)`` replace the attachment points (the home pose is recomputed).
    """
    desc = preset(name)
    if gravity is not None:
        desc = desc.replace(gravity=np.asarray(gravity, dtype=float))
    if points is not None:
        desc = desc.replace(base_points=points[0], platform_points=points[1], home_pose=None)
        axes = "horizontal" if axes == "preset" else axes
    if axes != "preset":
        T = desc.home_pose
        P0 = desc.platform_points @ T[:3, :3].T + T[:3, 3]
        g = desc.gravity
        up = -g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 0.0, 1.0])
        rotations = np.array(desc.leg_base_rotations)
        for i in legs:
            d = P0[i] - desc.base_points[i]
            if axes == "vertical":
                across = d - (d @ up) * up
                axis = np.cos(tilt) * up + np.sin(tilt) * across / np.linalg.norm(across)
            else:
                axis = np.cross(up, d)
            rotations[i] = leg_base_rotation_from_axis(axis, d)
        desc = desc.replace(leg_base_rotations=rotations)
    return StewartRobot(desc)


def _dimensionless(W: np.ndarray, desc: RobotDescription) -> np.ndarray:
    """The regressor's columns times L^2 (inertia), L (first moments) or 1 (masses), L the
    robot's size: all in m/s^2, so round-off in a column that should be zero stays small."""
    powers = np.tile([2, 2, 2, 2, 2, 2, 1, 1, 1, 0], 19)
    return W * desc.size**powers


#: (label, builder arguments, expected number of base parameters).
SPECIAL = [
    ("simulator-vertical-axes", dict(name="simulator", axes="vertical"), 76),
    ("random-1-vertical-axes", dict(name="random-1", axes="vertical"), 76),
    ("paper-legs-1-3-5-vertical", dict(name="paper", axes="vertical", legs=[0, 2, 4]), 82),
    ("random-1-axes-1e-12-off-vertical", dict(name="random-1", axes="vertical", tilt=1e-12), 76),
    ("random-6-axes-1e-3-off-vertical", dict(name="random-6", axes="vertical", tilt=1e-3), 88),
    ("random-6-zero-gravity", dict(name="random-6", gravity=[0.0, 0.0, 0.0]), 64),
    (
        "desktop-zero-gravity-vertical",
        dict(name="desktop", axes="vertical", gravity=[0.0, 0.0, 0.0]),
        64,
    ),
    ("simulator-horizontal-gravity", dict(name="simulator", gravity=[9.81, 0.0, 0.0]), 88),
    ("planar-points", dict(name="simulator", points=(PLANAR_B, PLANAR_P)), 88),
    (
        "planar-points-vertical",
        dict(name="simulator", points=(PLANAR_B, PLANAR_P), axes="vertical"),
        76,
    ),
    (
        "symmetric-points-vertical",
        dict(name="simulator", points=(PLANAR_B, SYMMETRIC_P), axes="vertical"),
        76,
    ),
]


@pytest.mark.parametrize(("label", "build", "expected"), SPECIAL, ids=[c[0] for c in SPECIAL])
def test_analytic_base_set_is_minimal_on_special_geometries(label, build, expected):
    """On every geometry the analytic set has the numerical rank and spans the regressor.

    Reference: the SVD of the stacked regressor with dimensionless columns (a gap of at
    least 1e6 between kept and dropped singular values around the 1e-8 cut).
    """
    robot = special_robot(**build)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseParameterWarning)  # no grey zone on these
        analytic = base_parameters(robot, "analytic")
        numerical, report = numerical_base_parameters(robot, n_states=50, seed=3)
    W_raw = stacked_regressor(robot, 40, 17)  # states neither set was built from
    W = _dimensionless(W_raw, robot.description)
    sv = np.linalg.svd(W, compute_uv=False) / np.linalg.norm(W, 2)
    rank = int(np.sum(sv > 1e-8))
    assert rank == expected
    assert sv[rank - 1] > 1e-6 and sv[rank] < 1e-11
    assert len(analytic) == report.rank == len(numerical) == expected
    assert report.smallest_kept > 1e6 * report.largest_dropped
    # Same span, and the kept columns are independent (dimensionless, so a column of
    # round-off would show as a tiny singular value).
    Wb = analytic.reduce(W)
    angles = scipy.linalg.subspace_angles(scipy.linalg.orth(Wb), scipy.linalg.orth(W))
    assert angles.max() < 1e-9
    sb = np.linalg.svd(Wb, compute_uv=False)
    assert sb[-1] > 1e-6 * sb[0]
    null = scipy.linalg.null_space(analytic.K)
    assert null.shape[1] == 190 - expected
    assert np.abs(W_raw @ null).max() < 1e-10 * np.abs(W_raw).max()


@pytest.mark.parametrize("method", ["analytic", "numerical"])
def test_minimal_sets_reproduce_inverse_dynamics_with_vertical_axes(method):
    robot = special_robot("random-1", axes="vertical")
    poses, twists, accels = sample_states(robot.description, 30, 8)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    bp = base_parameters(robot, method)
    assert len(bp) == 76
    assert rel_error(bp.regressor(poses, twists, accels) @ bp.values, gamma) < 1e-10


def test_vertical_first_axis_leaves_only_zz1r_of_link_1():
    """Legs 1, 3, 5 vertical: their MX1, MY1R go (link 1 keeps ZZ1R), the others keep them;
    the regressor columns of MX1, MY1, MZ2 of a vertical leg are zero to round-off."""
    robot = special_robot("paper", axes="vertical", legs=[0, 2, 4])
    names = set(base_parameters(robot).names)
    for i in (1, 3, 5):
        assert {f"MX1_{i}", f"MY1R_{i}"}.isdisjoint(names)
        assert {f"ZZ1R_{i}", f"MX2_{i}", f"MY2_{i}", f"XX2R_{i}"} <= names
    for i in (2, 4, 6):
        assert {f"ZZ1R_{i}", f"MX1_{i}", f"MY1R_{i}"} <= names
    W = _dimensionless(stacked_regressor(robot, 20, 2), robot.description)
    scale = np.abs(W).max()
    for i in (1, 3, 5):
        for p in ("MX1", "MY1", "MZ2"):
            assert np.abs(W[:, STANDARD_NAMES.index(f"{p}_{i}")]).max() < 1e-14 * scale
    assert np.abs(W[:, STANDARD_NAMES.index("MX1_2")]).max() > 1e-3 * scale


def test_zero_gravity_drops_the_moments_only_gravity_excites():
    robot = special_robot("random-6", gravity=[0.0, 0.0, 0.0])
    bp = base_parameters(robot)
    assert len(bp) == 64
    for i in range(1, 7):
        leg = [n[: -len(f"_{i}")] for n in bp.names if n.endswith(f"_{i}")]
        assert leg == ["ZZ1R", "XX2R", "XY2R", "XZ2R", "YZ2R", "ZZ2R", "MX3", "MY3", "MZ3"]
    W = stacked_regressor(robot, 20, 2)
    for p in ("MX1", "MY1", "MX2", "MY2"):
        assert not W[:, STANDARD_NAMES.index(f"{p}_4")].any()
    # The paper's Table III set is taken from its 88 on every geometry.
    assert len(paper_essential_parameters(robot, n_states=20)) == 52


def test_axis_barely_off_vertical_is_flagged_not_silently_decided():
    """1e-7 rad off vertical: MX1, MY1R act in exact arithmetic (kept: 88) but their
    forces are 1e-9 of the others, so both routes warn; likewise a gravity of 1e-7 m/s^2."""
    robot = special_robot("random-1", axes="vertical", tilt=1e-7)
    with pytest.warns(BaseParameterWarning, match="leg 1 .*leg 6"):
        analytic = analytic_base_parameters(robot.description)
    assert len(analytic) == 88
    with pytest.warns(BaseParameterWarning, match="ill-determined"):
        numerical_base_parameters(robot, n_states=40)
    weak = random_robot(1).replace(gravity=[0.0, 0.0, -1e-7])
    with pytest.warns(BaseParameterWarning) as record:
        assert len(analytic_base_parameters(weak)) == 88
    assert any("nearly zero" in str(w.message) for w in record)


def test_numerical_rank_is_not_fooled_by_round_off_columns():
    """Unit-norm column scaling made round-off columns (MX1 of a vertical leg, 1e-16 of the
    others) count: rank 94. Dimensionless columns give 76 with a wide gap."""
    robot = special_robot("simulator", axes="vertical")
    _, report = numerical_base_parameters(robot, n_states=50, seed=1)
    assert report.rank == 76
    assert report.smallest_kept > 1e-5 and report.largest_dropped < 1e-13
    for bad in (-1.0, 0.0, float("nan"), "1e-8", True):
        with pytest.raises(InputError, match="tolerance"):
            numerical_base_parameters(robot, tolerance=bad)


def test_grouped_parameters_keep_the_papers_88_for_the_generated_code():
    """The generated code's fixed layout stays valid on a vertical-axis robot."""
    from stewart_pin.codegen import CompiledDynamics

    robot = special_robot("random-1", axes="vertical")
    grouped = grouped_parameters(robot.description)
    assert len(grouped) == 88
    poses, twists, accels = sample_states(robot.description, 20, 4)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    W = robot.regressor(poses, twists, accels)
    assert rel_error(grouped.reduce(W) @ grouped.values, gamma) < 1e-10
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # "no compiler: using the VM"
        vm = CompiledDynamics(robot, compiler=False)
    assert vm.parameter_names == grouped.names
    assert rel_error(vm.inverse_dynamics(poses, twists, accels), gamma) < 1e-10
