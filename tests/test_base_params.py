"""Base and essential inertial parameters.

References: the numerical rank of the stacked regressor (SVD), principal angles between
the analytic and numerical base spaces, the null space of the grouping map, and the
inverse dynamic model for the forces the reduced sets predict.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from helpers import rel_error

from stewart_pin import StewartRobot, random_robot
from stewart_pin.base_params import (
    analytic_base_parameters,
    base_parameters,
    essential_parameters,
    numerical_base_parameters,
    paper_essential_parameters,
    stacked_regressor,
)
from stewart_pin.workspace import sample_states

ROBOTS = ["simulator", "paper", "random-1", "random-6"]


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request) -> StewartRobot:
    return StewartRobot.from_preset(request.param)


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
