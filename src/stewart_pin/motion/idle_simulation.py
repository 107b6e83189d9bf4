"""Time integration of robots whose legs have idle freedoms (``ChainLeg.idle_joint``: an
R-S-S rod's spin), the idle joints' values and rates integrated with the platform.

The state is the pose 0Tp, the twist ``[v, w]`` (F0) and the idle joints' values and rates
(6,) each (entries of legs without an idle joint stay 0); its derivative comes from
:meth:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics.direct_dynamics_idle`: the
platform's classical acceleration and the idle joints' accelerations. Classical RK4 with a
fixed step ``dt`` on the grid ``k dt``, the rotation in the chart ``R = exp(xi^) R_n``
around each step's start (as :mod:`stewart_pin.motion.simulation`, whose event location,
adaptive steps and control periods this first version does not have: a limit or a
singularity met stops the run with the error of the model).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from stewart_pin._checks import check_array, check_pose, check_scalar
from stewart_pin._so3 import so3_exp, so3_left_jacobian_inverse
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics.chain_legs import idle_home

#: ``Gamma = forces(t, pose, twist)`` [N or N m], joint side.
ForceFunction = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
#: ``Gamma = forces(t, pose, twist, idle)``: also sees the idle joints' state
#: ``idle = (values, rates)``, each (6,) (``None`` on a robot without idle joints).
IdleForceFunction = Callable[
    [float, np.ndarray, np.ndarray, "tuple[np.ndarray, np.ndarray] | None"], np.ndarray
]
#: Most steps of one run.
MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class IdleSimulationResult:
    """Samples at ``t`` (K,) [s]: poses (K, 4, 4), twists, accels (classical, F0), gammas
    (K, 6); the idle joints' values, rates and accelerations ``idle_q``, ``idle_v``,
    ``idle_a`` (K, 6) [rad, rad/s, rad/s^2 or m...]."""

    t: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray
    idle_q: np.ndarray
    idle_v: np.ndarray
    idle_a: np.ndarray


def _pose(T0: np.ndarray, y: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = so3_exp(y[None, 3:6])[0] @ T0[:3, :3]
    T[:3, 3] = y[:3]
    return T


def takes_idle(forces: Callable[..., Any]) -> bool:
    """Whether ``forces`` accepts the idle state as a fourth positional argument (the rule of
    :func:`simulate_idle`: its signature binds four positional arguments)."""
    try:
        inspect.signature(forces).bind(0.0, None, None, None)
    except (TypeError, ValueError):  # refuses four, or no signature to read
        return False
    return True


def _four_arguments(forces: ForceFunction | IdleForceFunction | None) -> IdleForceFunction:
    """``forces`` as a function of ``(t, pose, twist, idle)`` (:func:`takes_idle`)."""
    if forces is None:
        return lambda t, T, V, idle: np.zeros(6)
    if takes_idle(forces):
        return cast(IdleForceFunction, forces)
    three = cast(ForceFunction, forces)
    return lambda t, T, V, idle: three(t, T, V)


def simulate_idle(
    robot: Any,
    duration: float,
    pose: Any = None,
    twist: Any = None,
    idle: Any = None,
    forces: ForceFunction | IdleForceFunction | None = None,
    dt: float = 1e-3,
    backend: str = "auto",
) -> IdleSimulationResult:
    """Integrate a robot with idle freedoms (module docstring).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` with chain legs.
        duration: [s], finite and positive. dt: the RK4 step [s].
        pose: initial 0Tp (default the home pose); twist: initial ``[v, w]`` (default 0).
        idle: initial idle joints' ``(values, rates)``, each (6,) (default their home
            values, at rest; a robot without idle joints refuses one: :class:`InputError`).
        forces: ``Gamma = forces(t, pose, twist)`` or ``forces(t, pose, twist, idle)``;
            default zero. The rule: a function whose signature binds four positional
            arguments (``inspect.signature(forces).bind(t, pose, twist, idle)`` succeeds:
            a fourth parameter, with or without a default, or ``*args``) receives the
            idle joints' state ``idle = (values, rates)``, each (6,), at every
            evaluation (``None`` on a robot without idle joints); any other (or one
            without an introspectable signature) is called with three. A
            :class:`~stewart_pin.motion.control.ComputedTorqueController` takes four:
            its inverse model then runs at the simulated spin state.
        backend: the direct model's (``robot.direct_dynamics_idle``): ``"auto"`` (the
            compiled idle-state models where a C compiler is available), ``"compiled"``
            or ``"pinocchio"`` (the reference); a robot without idle joints takes the
            reference's ``direct_dynamics_idle``.
    """
    duration = check_scalar(duration, "duration", positive=True)
    dt = check_scalar(dt, "dt", positive=True)
    steps = int(np.ceil(duration / dt - 1e-9))
    if steps > MAX_STEPS:
        raise InputError(f"duration / dt = {steps} steps exceeds {MAX_STEPS}")
    desc = robot.description
    T = check_pose(desc.home_pose if pose is None else pose, "pose")
    V = np.zeros(6) if twist is None else check_array(twist, (6,), "twist")
    dyn = robot.chain_dynamics
    if idle is None:
        s, sd = idle_home(desc), np.zeros(6)
    elif not dyn.idle_legs:
        raise InputError(
            f"robot '{desc.name}' has no idle joints (ChainLeg.idle_joint): give idle=None"
        )
    else:
        s, sd = (
            check_array(x, (6,), name)
            for x, name in zip(idle, ("idle values", "idle rates"), strict=True)
        )
    force = _four_arguments(forces)
    idle_of = (lambda y: (y[12:18], y[18:24])) if dyn.idle_legs else (lambda y: None)

    def f(
        t: float, T0: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        Tt, Vt = _pose(T0, y), y[6:12]
        g = check_array(force(t, Tt, Vt, idle_of(y)), (6,), "forces(t, pose, twist)")
        if dyn.idle_legs:
            acc, sigma = robot.direct_dynamics_idle(Tt, Vt, g, (y[12:18], y[18:24]), backend)
        else:  # they stay 0
            acc, sigma = dyn.direct_dynamics_idle(Tt, Vt, g, idle=None)
        dy = np.concatenate(
            [Vt[:3], so3_left_jacobian_inverse(y[3:6]) @ Vt[3:], acc, y[18:24], sigma]
        )
        return dy, g, acc, sigma

    rows: list[tuple[Any, ...]] = []
    t = 0.0
    for k in range(steps + 1):
        y0 = np.concatenate([T[:3, 3], np.zeros(3), V, s, sd])
        k1, g, acc, sigma = f(t, T, y0)
        rows.append((t, T, V, acc, g, s, sd, sigma))
        if k == steps:
            break
        t_new = min((k + 1) * dt, duration)
        h = t_new - t
        k2 = f(t + h / 2, T, y0 + h / 2 * k1)[0]
        k3 = f(t + h / 2, T, y0 + h / 2 * k2)[0]
        k4 = f(t_new, T, y0 + h * k3)[0]
        y1 = y0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        T, V, s, sd, t = _pose(T, y1), y1[6:12], y1[12:18], y1[18:24], t_new
    cols = list(zip(*rows, strict=True))
    return IdleSimulationResult(*(np.array(c) for c in cols))


__all__ = [
    "ForceFunction",
    "IdleForceFunction",
    "IdleSimulationResult",
    "simulate_idle",
    "takes_idle",
]
