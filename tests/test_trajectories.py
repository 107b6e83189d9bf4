"""Platform motions: exact derivatives (against finite differences on SE(3)), rest-to-rest
endpoints, and the workspace check before a run."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot, StrokeLimitError
from stewart_pin.exceptions import InputError
from stewart_pin.motion.trajectories import MinimumJerkKnots, Sinusoids, minimum_jerk, washout


@pytest.fixture(scope="module")
def robot() -> StewartRobot:
    return StewartRobot.from_preset("simulator")


def motions(robot):
    T0 = robot.home_pose
    return [
        minimum_jerk(T0, [0.1, -0.05, 0.08, 0.05, -0.04, 0.1], 1.5),
        washout(T0, surge=0.2, tilt=0.08),
        Sinusoids(
            T0,
            [0.05, 0.04, 0.03, 0.03, 0.02, 0.05],
            [0.5, 0.7, 0.9, 0.4, 0.6, 0.3],
            [0, 1, 2, 0.5, 1.5, 2.5],
        ),
    ]


@pytest.mark.parametrize("k", [0, 1, 2])
def test_twist_and_acceleration_match_finite_differences(robot, k):
    motion = motions(robot)[k]
    h = 1e-5
    for t in np.linspace(0.05, motion.duration - 0.05, 7):
        tr = motion.sample(np.array([t - h, t, t + h]))
        T_m, _, T_p = tr.poses
        v = (T_p[:3, 3] - T_m[:3, 3]) / (2 * h)
        w = pin.log3(T_p[:3, :3] @ T_m[:3, :3].T) / (2 * h)  # angular velocity in F0
        np.testing.assert_allclose(tr.twists[1], np.concatenate([v, w]), atol=1e-8)
        acc = (tr.twists[2] - tr.twists[0]) / (2 * h)  # classical: d/dt of [v, w]
        np.testing.assert_allclose(tr.accels[1], acc, atol=1e-6)


def test_minimum_jerk_is_rest_to_rest(robot):
    goal = np.array([0.1, -0.05, 0.08, 0.05, -0.04, 0.1])
    m = minimum_jerk(robot.home_pose, goal, 1.5)
    tr = m.sample(np.array([0.0, 1.5, 2.0]))
    np.testing.assert_allclose(tr.poses[0], robot.home_pose, atol=1e-15)
    np.testing.assert_allclose(tr.poses[1][:3, 3], robot.home_pose[:3, 3] + goal[:3], atol=1e-15)
    np.testing.assert_allclose(
        tr.poses[1][:3, :3], pin.exp3(goal[3:]) @ robot.home_pose[:3, :3], atol=1e-15
    )
    assert np.abs(tr.twists).max() < 1e-15 and np.abs(tr.accels).max() < 1e-15
    np.testing.assert_allclose(tr.poses[2], tr.poses[1], atol=1e-15)  # holds the goal


def test_minimum_jerk_knots_are_copied_as_doubles(robot):
    """Knots given as lists of float32 numbers: the motion keeps tuples of Python floats
    (a later change of the lists does not move it) and computes in double precision (the
    closed-form quintic on the float32 numbers' exact values, to 1e-14; in float32 the
    slope ``dv / h`` was off by ~1e-8, and the compiled simulator's C, reading the knots
    as doubles, off the Python loop by as much)."""
    t1, v1 = np.float32(0.3), np.float32(0.1)
    axis = [[np.float32(0.0), np.float32(0.0)], [t1, v1]]
    m = MinimumJerkKnots(robot.home_pose, ([*axis], (), (), (), (), ()))
    axis[1][1] = np.float32(5.0)  # after construction: ignored
    assert m.knots[0] == ((0.0, 0.0), (float(t1), float(v1)))
    assert all(type(x) is float for knot in m.knots[0] for x in knot)
    t = 0.1
    x, xd, xdd = (a[0, 0] for a in m.coordinates(np.array([t])))
    s, h, dv = t / float(t1), float(t1), float(v1)
    want = (
        dv * (10 * s**3 - 15 * s**4 + 6 * s**5),
        dv / h * 30 * s**2 * (1 - s) ** 2,
        dv / h**2 * 60 * s * (1 - s) * (1 - 2 * s),
    )
    np.testing.assert_allclose([x, xd, xdd], want, rtol=1e-14, atol=0)
    for bad, match in (
        ((0.0, np.nan), "finite"),
        ((np.inf, 1.0), "finite"),
        ((0.1,), "pairs of numbers"),
        ((0.1, "a"), "pairs of numbers"),
    ):
        with pytest.raises(InputError, match=match):
            MinimumJerkKnots(robot.home_pose, ([(-1.0, 0.0), bad], (), (), (), (), ()))


def test_washout_returns_to_the_centre(robot):
    m = washout(robot.home_pose, surge=0.2, tilt=0.08)
    end = m.sample(np.array([m.duration]))
    np.testing.assert_allclose(end.poses[0], robot.home_pose, atol=1e-15)
    peak = m.sample(np.array([0.5])).poses[0]
    assert peak[0, 3] - robot.home_pose[0, 3] == pytest.approx(0.2, abs=1e-15)


def test_the_standard_washout_lasts_the_duration_asked(robot):
    """``simulate --motion washout --duration 3`` simulated 4.5 s: the cue's phases scale
    with the duration; it starts and ends at home, the surge peaking at 0.5 / 4.5 of it."""
    from stewart_pin.motion.trajectories import standard_motion

    s = robot.description.stroke_mid
    for duration in (3.0, 4.5, 1.5):
        m = standard_motion(robot, "washout", duration)
        assert m.duration == pytest.approx(duration, rel=1e-15)
        ends = m.sample(np.array([0.0, duration])).poses
        np.testing.assert_allclose(ends, [robot.home_pose] * 2, atol=1e-15)
        peak = m.sample(np.array([duration * 0.5 / 4.5])).poses[0]
        assert peak[0, 3] - robot.home_pose[0, 3] == pytest.approx(0.08 * s, abs=1e-15)


def test_workspace_checked_before_a_run(robot):
    for motion in motions(robot):
        motion.check_workspace(robot)  # all reachable
    too_far = minimum_jerk(robot.home_pose, [0, 0, 1.0, 0, 0, 0], 2.0)
    with pytest.raises(StrokeLimitError, match=r"leaves the workspace at t = [\d.]+ s: leg") as e:
        too_far.check_workspace(robot)
    # the sample's own error: no note of a batch state counted inside the sampled chunk
    assert "failing state" not in str(e.value) and e.value.state is None


def test_callable_reference_equals_sampling(robot):
    m = motions(robot)[2]
    T, V, A = m(0.37)
    tr = m.sample(np.array([0.37]))
    np.testing.assert_array_equal(T, tr.poses[0])
    np.testing.assert_array_equal(V, tr.twists[0])
    np.testing.assert_array_equal(A, tr.accels[0])
