"""The dynamic regressor and the base parameters.

References: the inverse dynamic model (Pinocchio RNEA on the legs, the closure layer's own
platform Newton-Euler) for ``W chi``; the numerical rank of the stacked regressor (SVD) for
the base set; principal angles between the analytic and numerical base spaces.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import rel_error

from stewart_pin import StewartRobot, random_robot
from stewart_pin.description.inertia import random_physical_khalil
from stewart_pin.dynamics.regressor import (
    STANDARD_NAMES,
    standard_parameters,
    with_standard_parameters,
)
from stewart_pin.kinematics.workspace import sample_states


@pytest.fixture(scope="module")
def robot(parameter_robot) -> StewartRobot:
    return parameter_robot


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
    assert rel_error(W @ standard_parameters(robot.description), gamma) < 1e-10
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
        assert rel_error(W @ standard_parameters(other), gamma) < 1e-10


def test_with_standard_parameters_round_trip():
    desc = random_robot(2)
    chi = standard_parameters(desc)
    again = with_standard_parameters(desc, chi)
    np.testing.assert_array_equal(standard_parameters(again), chi)
