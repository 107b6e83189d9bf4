"""The dynamic regressor and the base parameters.

References: the inverse dynamic model (Pinocchio RNEA on the legs, the closure layer's own
platform Newton-Euler) for ``W chi``; the numerical rank of the stacked regressor (SVD) for
the base set; principal angles between the analytic and numerical base spaces.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from stewart_pin import StewartRobot, random_robot
from stewart_pin.base_parameters import (
    analytic_base_parameters,
    base_parameters,
    numerical_base_parameters,
    stacked_regressor,
)
from stewart_pin.inertia import random_physical_khalil
from stewart_pin.regressor import STANDARD_NAMES, standard_parameters, with_standard_parameters
from stewart_pin.workspace import sample_states

ROBOTS = ["simulator", "paper", "random-1", "random-6"]


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request) -> StewartRobot:
    return StewartRobot.from_preset(request.param)


def _rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_names_and_order():
    assert len(STANDARD_NAMES) == 190 and len(set(STANDARD_NAMES)) == 190
    assert STANDARD_NAMES[:3] == ("XX1_1", "XY1_1", "XZ1_1")
    assert STANDARD_NAMES[10] == "XX2_1" and STANDARD_NAMES[30] == "XX1_2"
    assert STANDARD_NAMES[179] == "M3_6" and STANDARD_NAMES[180:][-1] == "M_P"
    desc = random_robot(3)
    chi = standard_parameters(desc)
    assert chi[STANDARD_NAMES.index("MZ2_4")] == desc.leg_inertia[3, 1, 8]
    assert chi[STANDARD_NAMES.index("XY_P")] == desc.platform_inertia[1]


def test_regressor_times_parameters_is_inverse_dynamics(robot):
    poses, twists, accels = sample_states(robot.description, 200, 21)
    W = robot.regressor(poses, twists, accels)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    assert W.shape == (200, 6, 190)
    assert _rel(W @ standard_parameters(robot.description), gamma) < 1e-10
    single = robot.regressor(poses[0], twists[0], accels[0])
    np.testing.assert_allclose(single, W[0], rtol=0, atol=1e-12 * np.abs(W[0]).max())


def test_regressor_is_linear_in_any_inertial_parameters():
    """Same geometry, twelve random physical parameter sets: one W predicts them all."""
    desc = random_robot(9)
    poses, twists, accels = sample_states(desc, 20, 2)
    W = StewartRobot(desc).regressor(poses, twists, accels)
    rng = np.random.default_rng(0)
    for _ in range(12):
        legs = np.array(
            [
                [random_physical_khalil(rng, rng.uniform(0.1, 5), 0.2, 0.1) for _ in range(3)]
                for _ in range(6)
            ]
        )
        other = desc.replace(
            leg_inertia=legs, platform_inertia=random_physical_khalil(rng, 20.0, 0.3, 0.1)
        )
        gamma = StewartRobot(other).inverse_dynamics(poses, twists, accels)
        assert _rel(W @ standard_parameters(other), gamma) < 1e-10


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
        assert _rel(Wb @ bp.values, gamma) < 1e-10


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


def test_with_standard_parameters_round_trip():
    desc = random_robot(2)
    chi = standard_parameters(desc)
    again = with_standard_parameters(desc, chi)
    np.testing.assert_array_equal(standard_parameters(again), chi)
