"""Fuzzing the compiled models of general legs (issue 14, item 2: the same guards and
errors as the reference): on the named general presets and random robots with every joint
term, states drawn by hypothesis (poses well beyond the workspace and near the reach, joint
limits and singularities, twists, accelerations and forces over six orders of magnitude),
the compiled backend and the reference path (``backend="pinocchio"``) either both raise
the same named error (same type and message), or both return finite results that agree to
:data:`AGREE` (the DDM relative to the largest of the acceleration and its two parts, as
in test_fuzz_backends.py). Never NaN, never a silent disagreement."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import get_robot, use_compile_cache
from helpers import backends_agree_or_raise_the_same_named_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fuzz_backends import MIN_ACCEPTED

from stewart_pin import StewartRobot
from stewart_pin.codegen import CompiledDynamics

AGREE = 1e-9
NAMES = ("rus", "pus", "ups-offset", "random-custom-0", "random-rus-0")
SETTINGS = settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
unit = st.floats(-1.0, 1.0, allow_nan=False)
vec6 = st.lists(unit, min_size=6, max_size=6)
exponent = st.integers(-3, 3)
reach = st.sampled_from([0.02, 0.08, 0.3])

_ROBOTS: dict[str, tuple[StewartRobot, CompiledDynamics, float]] = {}


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    yield from use_compile_cache(shared_compile_cache)
    _ROBOTS.clear()


def robot_of(name: str) -> tuple[StewartRobot, CompiledDynamics, float]:
    if name not in _ROBOTS:
        robot = get_robot(name)
        backend = CompiledDynamics(robot)
        assert backend.kind == "compiled", backend.reason
        zero = np.zeros(6)
        hold = robot.inverse_dynamics(robot.home_pose, zero, zero, backend="pinocchio")
        _ROBOTS[name] = (robot, backend, float(np.abs(hold).max()))
    return _ROBOTS[name]


def test_general_backends_agree_or_raise_the_same_named_error():
    counts = {"drawn": 0, "accepted": 0}
    agree_or_raise_the_same_named_error(counts)
    assert counts["drawn"] >= 50, counts
    assert counts["accepted"] >= MIN_ACCEPTED * counts["drawn"], counts


@SETTINGS
@given(st.sampled_from(NAMES), reach, vec6, vec6, vec6, vec6, exponent, exponent, exponent)
def agree_or_raise_the_same_named_error(counts, name, r, x, v, a, g, kv, ka, kg):
    robot, backend, hold = robot_of(name)
    counts["drawn"] += 1
    if backends_agree_or_raise_the_same_named_error(
        robot, backend, hold, AGREE, r, x, v, a, g, kv, ka, kg
    ):
        counts["accepted"] += 1
