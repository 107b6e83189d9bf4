"""The StewartRobot facade (stewart_pin.robot)."""

from __future__ import annotations

import numpy as np
import pytest

from stewart_pin import DescriptionError, RobotDescription, StewartRobot, preset


def test_constructors_agree(tmp_path):
    desc = preset("random-4")
    a = StewartRobot(desc)
    b = StewartRobot.from_preset("random-4")
    c = StewartRobot.from_dict(desc.to_dict())
    d = StewartRobot.from_file(desc.write(tmp_path / "r.json"))
    T = a.home_pose
    for other in (b, c, d):
        assert other.name == "random-4"
        np.testing.assert_array_equal(other.inverse_geometry(T), a.inverse_geometry(T))
    assert repr(a) == "StewartRobot('random-4')"


def test_constructor_rejects_other_types():
    with pytest.raises(TypeError, match="takes a RobotDescription, got dict"):
        StewartRobot(preset("desktop").to_dict())


def test_home_pose_is_a_copy(desktop):
    T = desktop.home_pose
    T[0, 3] += 1.0  # [m]
    assert desktop.home_pose[0, 3] == desktop.description.home_pose[0, 3]
    assert desktop.home_pose[0, 3] != T[0, 3]


def test_write_and_urdf(desktop, tmp_path):
    path = desktop.write(tmp_path / "d.toml")
    assert isinstance(RobotDescription.read(path), RobotDescription)
    assert desktop.urdf().startswith('<?xml version="1.0"?>')
    urdf, sidecar = desktop.write_urdf(tmp_path / "d.urdf")
    assert urdf.read_text() == desktop.urdf()
    assert sidecar.exists()
    assert desktop.to_dict()["name"] == "desktop"


def test_unknown_preset():
    with pytest.raises(DescriptionError, match="unknown preset"):
        StewartRobot.from_preset("nope")


def test_leg_jacobians_single_and_batch(paper):
    poses = paper.sample_poses(3, 0)
    J = paper.leg_jacobians(poses)
    assert J.shape == (3, 6, 3, 3)
    np.testing.assert_array_equal(J[1], paper.leg_jacobians(poses[1]))
