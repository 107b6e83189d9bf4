"""Random reachable states: poses around the home pose, twists and accelerations."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin.description import RobotDescription
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.exceptions import InputError, StewartPinError, WorkspaceError
from stewart_pin.kinematics import chain_legs
from stewart_pin.kinematics.geometry import admissible_poses, inverse_geometry_batch
from stewart_pin.kinematics.jacobians import (
    MAX_CONDITION,
    check_condition,
    condition_number_batch,
    inverse_jacobian_batch,
)
from stewart_pin.kinematics.leg_chains import (
    admissible_poses as general_admissible_poses,
)
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


#: Candidate poses decided together at most (memory: a few kB each for general legs).
CHUNK = 8192


def _draw_poses(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None,
    translation: float | None,
    rotation: float,
    max_draws: int,
    accept: Callable[[np.ndarray], object],
    admissible: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray:
    """The sampling loop of :func:`sample_poses` and :func:`sample_general_poses`: draws
    around the home pose until ``n`` are accepted.

    ``accept(T[None])`` decides one pose (it raises a :class:`StewartPinError` to
    reject); ``admissible(T)`` (m, 4, 4) -> (m,) bool decides a batch the same way (or
    raises ``FloatingPointError``, and ``accept`` decides that batch pose by pose).

    The draws are those of one pose at a time, in the same order from the same
    generator: six numbers each (the translation, then the rotation vector), the first
    ``n`` accepted kept. Candidates are drawn and decided in batches of at most
    :data:`CHUNK`; the generator is then set back to the state right after the last
    draw used, so that the poses and the generator's state afterwards are those of
    drawing and deciding one pose at a time.
    """
    rng = _rng(rng)
    half = (
        0.15 * desc.stroke_mid if translation is None else _range(translation, "translation", "m")
    )
    rotation = _range(rotation, "rotation", "rad")
    home = desc.home_pose
    low = np.array([-half] * 3 + [-rotation] * 3)
    budget = max_draws * max(n, 1)
    out: list[np.ndarray] = []
    found = draws = 0
    while found < n:
        if draws >= budget:
            raise WorkspaceError(
                f"only {found} of {n} poses reachable after {draws} draws; reduce the "
                f"translation ({half:g} m) or rotation ({rotation:g} rad) range"
            )
        rate = max(found, 1) / draws if draws else 1.0  # acceptance so far
        m = int(min(budget - draws, CHUNK, np.ceil((n - found) / rate * 1.1) + 8))
        state = rng.bit_generator.state
        # rng.uniform(-half, half, 3) then rng.uniform(-rotation, rotation, 3), m times
        u = rng.uniform(low, -low, (m, 6))
        T = np.broadcast_to(home, (m, 4, 4)).copy()
        T[:, :3, 3] += u[:, :3]
        T[:, :3, :3] = np.array([pin.exp3(w) for w in u[:, 3:]]).reshape(m, 3, 3) @ home[:3, :3]
        try:
            ok = admissible(T)
        except FloatingPointError:
            ok = np.array([_accepts(accept, Ti) for Ti in T], dtype=bool)
        kept = np.flatnonzero(ok)[: n - found]
        used = m if kept.size < n - found else int(kept[-1]) + 1
        if used < m:  # the generator as after `used` draws
            rng.bit_generator.state = state
            rng.uniform(low, -low, (used, 6))
        out.append(T[kept])
        found += kept.size
        draws += used
    return np.concatenate(out).reshape(n, 4, 4) if out else np.empty((0, 4, 4))


def _accepts(accept: Callable[[np.ndarray], object], T: np.ndarray) -> bool:
    """Whether ``accept(T[None])`` accepts the pose T (4, 4) (raises no
    :class:`StewartPinError`)."""
    try:
        accept(T[None])
    except StewartPinError:
        return False
    return True


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
    finite and >= 0 (:class:`InputError`). The same generator state gives the same poses
    (the draws are decided in batches, with the decision and the order of one at a time:
    :func:`_draw_poses`).
    """

    def accept(T: np.ndarray) -> None:
        inverse_geometry_batch(desc, T)
        check_condition(inverse_jacobian_batch(desc, T), max_condition, desc)

    def admissible(T: np.ndarray) -> np.ndarray:
        ok = admissible_poses(desc, T)
        fine = np.flatnonzero(ok)
        ok[fine] = condition_number_batch(desc, T[fine]) <= max_condition
        return ok

    return _draw_poses(desc, n, rng, translation, rotation, max_draws, accept, admissible)


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
    draw = partial(sample_poses, desc, n, **pose_kwargs)
    return _states(desc, n, rng, speed, angular_speed, draw)


def _states(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None,
    speed: float | None,
    angular_speed: float,
    draw_poses: Callable[[np.random.Generator], np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body of :func:`sample_states` and its twins for general and chain legs:
    ``draw_poses(rng)`` (the legs' own pose sampler, (n, 4, 4)), then random twists and
    accelerations (n, 6) from the same generator."""
    rng = _rng(rng)
    poses = draw_poses(rng)
    s = desc.stroke_mid if speed is None else _range(speed, "speed", "m/s")
    angular_speed = _range(angular_speed, "angular_speed", "rad/s")
    scale = np.array([s, s, s, angular_speed, angular_speed, angular_speed])
    twists = rng.uniform(-1, 1, (n, 6)) * scale
    accels = rng.uniform(-1, 1, (n, 6)) * scale * 3.0
    return poses, twists, accels


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

    def admissible(T: np.ndarray) -> np.ndarray:
        return general_admissible_poses(robot, T, max_condition)

    return _draw_poses(desc, n, rng, translation, rotation, max_draws, accept, admissible)


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
    draw = partial(sample_general_poses, desc, robot, n, **pose_kwargs)
    return _states(desc, n, rng, speed, angular_speed, draw)


def sample_chain_poses(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None = None,
    translation: float | None = None,
    rotation: float = 0.25,
    max_condition: float = MAX_CONDITION,
    max_draws: int = 100,
) -> np.ndarray:
    """:func:`sample_poses` for a robot with chain legs (``desc.chain_legs``): draws whose
    legs do not reach, leave a joint's limits, meet a leg singularity or pass
    ``max_condition`` are redrawn (:func:`stewart_pin.kinematics.chain_legs.admissible_poses`)."""

    def accept(T: np.ndarray) -> None:
        states = chain_legs.leg_states(desc, T, np.zeros((1, 6)), check_limits=True)
        chain_legs.check_parallel(desc, chain_legs.inverse_jacobian(desc, states), max_condition)

    def admissible(T: np.ndarray) -> np.ndarray:
        return chain_legs.admissible_poses(desc, T, max_condition)

    return _draw_poses(desc, n, rng, translation, rotation, max_draws, accept, admissible)


def sample_chain_states(
    desc: RobotDescription,
    n: int,
    rng: np.random.Generator | int | None = None,
    speed: float | None = None,
    angular_speed: float = 1.0,
    **pose_kwargs: Any,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sample_states` for chain legs (:func:`sample_chain_poses`)."""
    draw = partial(sample_chain_poses, desc, n, **pose_kwargs)
    return _states(desc, n, rng, speed, angular_speed, draw)
