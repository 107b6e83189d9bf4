"""Design studies, singularity-free regions (issue 22 item 2): the largest sphere touches
the bound and holds none of its violations inside (dense sampling written here)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot

from stewart_pin import InputError, SingularityError, design


def _ball(rng, n, radius):
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    return u * radius * rng.uniform(0, 1, (n, 1)) ** (1 / 3)


def test_largest_sphere_touches_the_bound_and_is_free_inside():
    robot = get_robot("desktop")
    home = robot.home_pose
    Rs = np.array([pin.rpy.rpyToMatrix(0, 0, a) @ home[:3, :3] for a in (-0.1, 0.1)])
    bound = 6.0
    reg = design.singularity_free_region(robot, orientations=Rs, max_condition=bound)
    assert reg.bounded and 0 < reg.half_side
    # touches: the measure at the touching point is the bound
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = reg.touch_orientation, reg.touch
    assert robot.condition_number(T) == pytest.approx(bound, rel=1e-6)
    assert np.linalg.norm(reg.touch - reg.center) == pytest.approx(reg.radius, abs=1e-9)
    # free inside: dense sampling of the ball (and of its surface) at each orientation
    rng = np.random.default_rng(5)
    pts = _ball(rng, 20_000, reg.radius * (1 - 1e-6))
    surface = rng.normal(size=(5000, 3))
    surface *= reg.radius * (1 - 1e-6) / np.linalg.norm(surface, axis=1)[:, None]
    for R in Rs:
        P = reg.center + np.vstack([pts, surface])
        T = np.tile(np.eye(4), (len(P), 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R, P
        assert np.max(robot.condition_number(T)) <= bound
    # the cube: no sampled point of it exceeds the bound either
    cube = reg.center + rng.uniform(-1, 1, (20_000, 3)) * reg.half_side * (1 - 1e-6)
    T = np.tile(np.eye(4), (len(cube), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = Rs[0], cube
    assert np.max(robot.condition_number(T)) <= bound


def test_singularity_map_and_errors():
    robot = get_robot("desktop")
    m, extent = design.singularity_map(robot, resolution=9)
    assert m.shape == (9, 9) and extent[1] > extent[0]
    assert m[4, 4] == pytest.approx(robot.condition_number(robot.home_pose))
    with pytest.raises(SingularityError, match="centre"):
        design.singularity_free_region(robot, max_condition=1.5)


def test_an_unbounded_region_claims_only_what_was_probed():
    """No crossing within ``reach``: the sphere is the searched one and the cube the one
    inscribed in it (its corners were probed), not a cube of half-side ``reach``."""
    robot = get_robot("desktop")
    reg = design.singularity_free_region(robot, reach=1e-4, directions=6, steps=4)
    assert not reg.bounded
    assert reg.radius == pytest.approx(1e-4)
    assert reg.half_side * np.sqrt(3.0) == pytest.approx(1e-4)
    with pytest.raises(InputError, match="steps"):
        design.singularity_free_region(robot, reach=1e-4, steps=0)
    with pytest.raises(InputError, match="tol"):
        design.singularity_free_region(robot, reach=1e-4, tol=-1.0)
