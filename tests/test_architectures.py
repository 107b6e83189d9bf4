"""The reference path of each architecture (:mod:`stewart_pin.architectures`, issue 19):
chosen once when a robot is built, so that the facade asks no architecture question; a
pickle holds no path.

References: the source text of ``robot.py`` (no branch on the architecture), the
description's own flag, the original robot's results (a pickled copy)."""

from __future__ import annotations

import ast
import pickle
from pathlib import Path

import pytest

import stewart_pin
from stewart_pin import StewartRobot
from stewart_pin.architectures import IdealUpsPath, LegChainPath, reference_path
from stewart_pin.description.presets import preset


def test_the_facade_asks_no_architecture_question():
    """``robot.py`` has no ``if``/conditional expression on ``is_ideal_ups`` or
    ``is_general``: each method calls the path chosen when the robot is built."""
    tree = ast.parse((Path(stewart_pin.__file__).parent / "robot.py").read_text())
    tests = [n.test for n in ast.walk(tree) if isinstance(n, (ast.If, ast.IfExp))]
    asked = [ast.unparse(t) for t in tests if "is_ideal_ups" in ast.unparse(t)]
    asked += [ast.unparse(t) for t in tests if "is_general" in ast.unparse(t)]
    assert asked == []


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("simulator", IdealUpsPath),
        ("paper", IdealUpsPath),
        ("rus", LegChainPath),
        ("pus", LegChainPath),
        ("ups-offset", LegChainPath),
    ],
)
def test_the_path_follows_the_architecture(name, kind):
    """The ideal 6-UPS (the paper's closed forms) and every other robot (leg chains)."""
    desc = preset(name)
    assert type(reference_path(desc)) is kind
    assert reference_path(desc).is_ideal_ups == desc.is_ideal_ups


@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_a_pickled_robot_chooses_its_path_again(name):
    """A pickle holds no path (one written before the paths existed, without ``_kind``,
    loads too); the copy's results are the original's."""
    robot = StewartRobot.from_preset(name)
    state = robot.__getstate__()
    assert "_kind" not in state
    copy = pickle.loads(pickle.dumps(robot))
    assert copy._kind is reference_path(robot.description)
    old = StewartRobot.__new__(StewartRobot)
    old.__setstate__(state)
    T = robot.home_pose
    assert (old.actuator_positions(T) == robot.actuator_positions(T)).all()
    assert (copy.inverse_jacobian(T) == robot.inverse_jacobian(T)).all()


@pytest.mark.parametrize("name", ["simulator", "ups-offset", "rus", "pus", "random-custom-0"])
def test_admissible_poses_is_the_decision_of_the_checked_calls(name):
    """``robot.admissible_poses`` (the whole batch at once, no exception) against the
    raising calls state by state: the inverse geometry with limits, then the measure."""
    import numpy as np

    from stewart_pin.exceptions import StewartPinError

    robot = StewartRobot.from_preset(name)
    rng = np.random.default_rng(7)
    T = robot.sample_poses(40, rng)
    wide = np.tile(robot.home_pose, (60, 1, 1))  # mostly outside the limits
    wide[:, :3, 3] += rng.uniform(-1.0, 1.0, (60, 3)) * robot.description.size
    T = np.concatenate([T, wide])
    bound = 0.5 * robot.max_condition

    def checked(pose):
        try:
            robot.inverse_geometry(pose, check_limits=True)
            return bool(robot.condition_number(pose) <= bound)
        except StewartPinError:
            return False

    expected = np.array([checked(p) for p in T])
    assert 0 < expected.sum() < len(T)  # both kinds of pose are met
    assert np.array_equal(robot.admissible_poses(T, bound), expected)
    assert robot.admissible_poses(T[0]).shape == (1,)
