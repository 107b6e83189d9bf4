"""The CSV tables shared by trajectories, measurements and simulation results."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from helpers import random_motion_states

from stewart_pin import FileFormatError
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    STATE_COLUMNS,
    quaternions_from_rotations,
    read_csv,
    rotations_from_quaternions,
    state_table,
    states_from_table,
    write_csv,
)


def test_quaternions_match_pinocchio():
    _, poses, _, _ = random_motion_states(20)
    q = quaternions_from_rotations(poses[:, :3, :3])
    assert np.all(q[:, 3] >= 0)
    for qi, T in zip(q, poses, strict=True):
        R = pin.Quaternion(qi[3], *qi[:3]).toRotationMatrix()
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-15)
    np.testing.assert_allclose(rotations_from_quaternions(q), poses[:, :3, :3], atol=1e-15)


def test_state_round_trip(tmp_path):
    states = random_motion_states(12)
    gammas = np.random.default_rng(1).normal(size=(12, 6)) * 100
    columns = STATE_COLUMNS + FORCE_COLUMNS
    path = write_csv(tmp_path / "s.csv", columns, np.column_stack([state_table(*states), gammas]))
    rows = read_csv(path, columns)
    np.testing.assert_array_equal(rows[:, 20:], gammas)  # repr floats: exact
    for back, ref in zip(states_from_table(rows), states, strict=True):
        np.testing.assert_allclose(back, ref, rtol=0, atol=1e-15)


def test_wrong_columns_and_values(tmp_path):
    path = write_csv(tmp_path / "s.csv", STATE_COLUMNS, state_table(*random_motion_states(3)))
    with pytest.raises(FileFormatError, match="missing columns 'gamma1'"):
        read_csv(path, STATE_COLUMNS + FORCE_COLUMNS)
    text = path.read_text().splitlines()
    text[2] = text[2].replace(text[2].split(",")[1], "abc", 1)
    path.write_text("\n".join(text))
    with pytest.raises(FileFormatError, match="line 3, column 'x': 'abc' is not a number"):
        read_csv(path, STATE_COLUMNS)
