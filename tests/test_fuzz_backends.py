"""Fuzzing both backends (issue 9): on random robots and states drawn by hypothesis (poses
well beyond the workspace, twists, accelerations and forces over six orders of magnitude),
the compiled backend and the reference (Pinocchio) path either both raise the same named
error (a :class:`StewartPinError`, same type and message), or both return finite results
that agree to ``AGREE``. Never NaN, never a silent disagreement.

Agreement: the IDM relative to its largest force; the DDM relative to the largest of the
acceleration and its two parts (that of the forces, and that of gravity and the velocity
terms, i.e. the DDM at zero force), since the model subtracts them: forces that nearly
hold the robot give a small acceleration known only relative to those parts.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import use_compile_cache
from helpers import backends_agree_or_raise_the_same_named_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stewart_pin import StewartRobot
from stewart_pin.codegen import CompiledDynamics

AGREE = 1e-9
SEEDS = (0, 1, 4, 7)  # a library compiled for each (hypothesis draws among them)
SETTINGS = settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
unit = st.floats(-1.0, 1.0, allow_nan=False)
vec6 = st.lists(unit, min_size=6, max_size=6)
exponent = st.integers(-3, 3)  # magnitudes 1e-3 .. 1e3 times the robot's scale
reach = st.sampled_from([0.05, 0.15, 0.4])

_ROBOTS: dict[int, tuple[StewartRobot, CompiledDynamics, float]] = {}


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    """The session's shared cache folder (the same robots compile once for the suite)."""
    yield from use_compile_cache(shared_compile_cache)
    _ROBOTS.clear()


def robot_of(seed: int) -> tuple[StewartRobot, CompiledDynamics, float]:
    """The random robot ``random-<seed>``, its compiled backend and the force holding it."""
    if seed not in _ROBOTS:
        robot = StewartRobot.from_preset(f"random-{seed}")
        backend = CompiledDynamics(robot)
        assert backend.kind == "compiled", backend.reason
        hold = np.abs(robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6))).max()
        _ROBOTS[seed] = (robot, backend, float(hold))
    return _ROBOTS[seed]


MIN_ACCEPTED = 0.3  # share of the drawn states that the IDM must accept


def test_backends_agree_or_raise_the_same_named_error():
    """The property below, over ``SETTINGS.max_examples`` draws; at least
    :data:`MIN_ACCEPTED` of them are accepted by the IDM (so that the agreement is checked
    on many states, not only the refusals)."""
    counts = {"drawn": 0, "accepted": 0}
    agree_or_raise_the_same_named_error(counts)
    assert counts["drawn"] >= 50, counts
    assert counts["accepted"] >= MIN_ACCEPTED * counts["drawn"], counts


@SETTINGS
@given(st.sampled_from(SEEDS), reach, vec6, vec6, vec6, vec6, exponent, exponent, exponent)
def agree_or_raise_the_same_named_error(counts, seed, r, x, v, a, g, kv, ka, kg):
    robot, backend, hold = robot_of(seed)
    counts["drawn"] += 1
    if backends_agree_or_raise_the_same_named_error(
        robot, backend, hold, AGREE, r, x, v, a, g, kv, ka, kg
    ):
        counts["accepted"] += 1
