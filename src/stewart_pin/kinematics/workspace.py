"""Random reachable states: poses around the home pose, twists and accelerations."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin.description import RobotDescription
from stewart_pin.description.general_hexapod import GeneralHexapod
from stewart_pin.exceptions import InputError, StewartPinError, WorkspaceError
from stewart_pin.kinematics.geometry import inverse_geometry_batch
from stewart_pin.kinematics.jacobians import MAX_CONDITION, check_condition, inverse_jacobian_batch
from stewart_pin.kinematics.leg_chains import (
    check_parallel,
    inverse_jacobian_from_legs,
    leg_state,
)


def _rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def _range(value: object, name: str, unit: str) -> float:
    """``value`` as a finite float >= 0, else :class:`InputError`."""
    x: float | None = None
    if not isinstance(value, (bool, str, bytes)):
        with contextlib.suppress(TypeError, ValueError):
            x = float(value)  # type: ignore[arg-type]
    if x is None:
        raise InputError(f"{name} must be a number >= 0 [{unit}], got {value!r}")
    if not (np.isfinite(x) and x >= 0.0):
        raise InputError(f"{name} must be a finite number >= 0 [{unit}], got {value!r}")
    return x


def _draw_poses(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None,
    translation: float | None,
    rotation: float,
    max_draws: int,
    accept: Callable[[np.ndarray], object],
) -> np.ndarray:
    """The sampling loop of :func:`sample_poses` and :func:`sample_general_poses`: draws
    around the home pose until ``n`` pass ``accept(T[None])`` (which raises a
    :class:`StewartPinError` to reject)."""
    rng = _rng(rng)
    half = (
        0.15 * desc.stroke_mid if translation is None else _range(translation, "translation", "m")
    )
    rotation = _range(rotation, "rotation", "rad")
    home = desc.home_pose
    out: list[np.ndarray] = []
    draws = 0
    while len(out) < n:
        if draws >= max_draws * max(n, 1):
            raise WorkspaceError(
                f"only {len(out)} of {n} poses reachable after {draws} draws; reduce the "
                f"translation ({half:g} m) or rotation ({rotation:g} rad) range"
            )
        draws += 1
        T = home.copy()
        T[:3, 3] += rng.uniform(-half, half, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-rotation, rotation, 3)) @ home[:3, :3]
        try:
            accept(T[None])
        except StewartPinError:
            continue
        out.append(T)
    return np.array(out).reshape(n, 4, 4)


def sample_poses(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None = None,
    translation: float | None = None,
    rotation: float = 0.25,
    max_condition: float = MAX_CONDITION,
    max_draws: int = 100,
) -> np.ndarray:
    """``n`` reachable poses 0Tp (n, 4, 4) drawn around ``desc.home_pose``.

    The displacement is uniform in a cube of half-side ``translation`` [m] (default 15 % of
    the mid-stroke) along F0's axes, the rotation ``exp(w) R_home`` with each ``w_k``
    uniform in ``[-rotation, rotation]`` [rad]. Draws that leave the stroke or the U-joint
    limits, or pass ``max_condition``, are rejected; after ``max_draws * n`` draws the
    function raises :class:`WorkspaceError`. ``translation`` and ``rotation`` must be
    finite and >= 0 (:class:`InputError`).
    """

    def accept(T: np.ndarray) -> None:
        inverse_geometry_batch(desc, T)
        check_condition(inverse_jacobian_batch(desc, T), max_condition, desc)

    return _draw_poses(desc, n, rng, translation, rotation, max_draws, accept)


def sample_states(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None = None,
    speed: float | None = None,
    angular_speed: float = 1.0,
    **pose_kwargs: Any,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(poses (n,4,4), twists (n,6), accels (n,6))``: random reachable poses with twists
    and classical accelerations drawn uniformly (linear parts up to ``speed`` [m/s],
    default the mid-stroke per second, and ``speed`` per second; angular parts up to
    ``angular_speed`` [rad/s] and that per second)."""
    rng = _rng(rng)
    poses = sample_poses(desc, n, rng, **pose_kwargs)
    return poses, *_motion(desc, n, rng, speed, angular_speed)


def _motion(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator,
    speed: float | None,
    angular_speed: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Random twists and accelerations (n, 6) for :func:`sample_states`."""
    s = desc.stroke_mid if speed is None else _range(speed, "speed", "m/s")
    angular_speed = _range(angular_speed, "angular_speed", "rad/s")
    scale = np.array([s, s, s, angular_speed, angular_speed, angular_speed])
    twists = rng.uniform(-1, 1, (n, 6)) * scale
    accels = rng.uniform(-1, 1, (n, 6)) * scale * 3.0
    return twists, accels


# ---------------------------------------------------------------------------- general legs
def sample_general_poses(
    desc: RobotDescription,
    robot: GeneralHexapod,
    n: int,
    rng: np.random.Generator | int | None = None,
    translation: float | None = None,
    rotation: float = 0.25,
    max_condition: float = MAX_CONDITION,
    max_draws: int = 100,
) -> np.ndarray:
    """:func:`sample_poses` for a robot with general legs (``robot``, the
    :class:`GeneralHexapod` view of ``desc``): draws whose legs cannot reach, leave a
    joint's limits, come within
    :data:`~stewart_pin.kinematics.leg_chains.LEG_SINGULARITY` of a serial singularity or
    pass ``max_condition`` (parallel) are redrawn. The default ``translation`` is 15 % of
    :attr:`RobotDescription.stroke_mid` (for general legs the mean ``|B_i P_i|`` at home)."""
    zero = np.zeros((1, 6))

    def accept(T: np.ndarray) -> None:
        legs = leg_state(robot, T, zero, check_limits=True)
        check_parallel(robot, inverse_jacobian_from_legs(robot, legs.J_inv, legs.L), max_condition)

    return _draw_poses(desc, n, rng, translation, rotation, max_draws, accept)


def sample_general_states(
    desc: RobotDescription,
    robot: GeneralHexapod,
    n: int,
    rng: np.random.Generator | int | None = None,
    speed: float | None = None,
    angular_speed: float = 1.0,
    **pose_kwargs: Any,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sample_states` for general legs (:func:`sample_general_poses`)."""
    rng = _rng(rng)
    poses = sample_general_poses(desc, robot, n, rng, **pose_kwargs)
    return poses, *_motion(desc, n, rng, speed, angular_speed)
