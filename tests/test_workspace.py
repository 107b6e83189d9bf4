"""Random reachable states (stewart_pin.kinematics.workspace)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from helpers import leg_lengths_by_hand

from stewart_pin import WorkspaceError
from stewart_pin.kinematics.workspace import sample_poses, sample_states


def test_sample_poses_are_reachable_and_within_the_ranges(general_robot):
    desc = general_robot.description
    half, rotation = 0.1 * desc.stroke_mid, 0.2  # [m], [rad]
    poses = sample_poses(desc, 30, 0, translation=half, rotation=rotation)
    assert poses.shape == (30, 4, 4)
    home = desc.home_pose
    for T in poses:
        lengths = leg_lengths_by_hand(desc, T)
        assert np.all((desc.stroke[0] <= lengths) & (lengths <= desc.stroke[1]))
        assert np.abs(T[:3, 3] - home[:3, 3]).max() <= half
        w = pin.log3(T[:3, :3] @ home[:3, :3].T)  # the drawn rotation vector, in F0
        assert np.abs(w).max() <= rotation + 1e-12
        np.testing.assert_array_equal(T[3], [0.0, 0.0, 0.0, 1.0])
        np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), rtol=0, atol=1e-14)


def test_sampling_is_reproducible(paper):
    a = sample_poses(paper.description, 5, 42)
    b = sample_poses(paper.description, 5, np.random.default_rng(42))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(paper.sample_poses(5, 42), a)
    assert not np.array_equal(a, sample_poses(paper.description, 5, 43))


def test_sample_poses_gives_up_with_workspace_error(desktop):
    with pytest.raises(WorkspaceError, match=r"only 0 of 3 poses reachable after 30 draws"):
        sample_poses(desktop.description, 3, 0, translation=10.0, max_draws=10)  # [m]


def test_sample_states_ranges(paper):
    desc = paper.description
    poses, twists, accels = sample_states(desc, 40, 1, speed=0.2, angular_speed=0.5)
    assert (poses.shape, twists.shape, accels.shape) == ((40, 4, 4), (40, 6), (40, 6))
    assert np.abs(twists[:, :3]).max() <= 0.2 and np.abs(twists[:, 3:]).max() <= 0.5
    assert np.abs(accels[:, :3]).max() <= 0.6 and np.abs(accels[:, 3:]).max() <= 1.5
    # they do fill the ranges (not all zero)
    assert np.abs(twists[:, :3]).max() > 0.1 and np.abs(accels[:, 3:]).max() > 0.75
