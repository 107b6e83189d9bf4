"""Property-based checks (hypothesis): round trips hold on every pose and state drawn."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stewart_pin import StewartRobot
from stewart_pin.description.inertia import (
    khalil_from_pin_inertia,
    khalil_from_urdf_inertial,
    pin_inertia_from_khalil,
    random_physical_khalil,
    urdf_inertial_from_khalil,
)

ROBOT = StewartRobot.from_preset("random-3")
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
small = st.floats(-1.0, 1.0, allow_nan=False)


def pose_from(offset: list[float]) -> np.ndarray:
    """A pose within 6 % of the mid-stroke and 0.15 rad of home."""
    T = ROBOT.home_pose
    s = ROBOT.description.stroke_mid
    T[:3, 3] += 0.06 * s * np.array(offset[:3])
    T[:3, :3] = pin.exp3(0.15 * np.array(offset[3:])) @ T[:3, :3]
    return T


@SETTINGS
@given(st.lists(small, min_size=6, max_size=6))
def test_forward_geometry_inverts_inverse_geometry(offset):
    T = pose_from(offset)
    q = ROBOT.inverse_geometry(T)
    T_back = ROBOT.forward_geometry(q[:, 2])
    assert np.abs(T_back - T).max() < 1e-10


@SETTINGS
@given(st.lists(small, min_size=18, max_size=18))
def test_direct_model_inverts_inverse_model(x):
    T = pose_from(x[:6])
    twist = np.array(x[6:12]) * [0.5, 0.5, 0.5, 1.0, 1.0, 1.0]
    accel = np.array(x[12:18]) * [3.0, 3.0, 3.0, 5.0, 5.0, 5.0]
    gamma = ROBOT.inverse_dynamics(T, twist, accel)
    back = ROBOT.direct_dynamics(T, twist, gamma)
    assert np.abs(back - accel).max() <= 1e-10 * max(1.0, np.abs(accel).max())


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.floats(1e-3, 1e3), st.floats(1e-3, 1.0))
def test_inertial_conversions_round_trip(seed, mass, size):
    params = random_physical_khalil(np.random.default_rng(seed), mass, size, 0.5 * size)
    scale = np.abs(params).max()
    back = khalil_from_pin_inertia(pin_inertia_from_khalil(params))
    assert np.abs(back - params).max() <= 1e-12 * scale
    m, com, I_c = urdf_inertial_from_khalil(params)
    assert np.abs(khalil_from_urdf_inertial(m, com, I_c) - params).max() <= 1e-12 * scale
