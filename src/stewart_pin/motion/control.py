"""Computed-torque control of the platform in Cartesian space.

The law, with the reference pose ``T_ref(t)``, twist ``V_ref`` and classical acceleration
``A_ref`` (all in F0)::

    e_p = p_ref - p                      position error of O_p [m]
    e_R = log(R_ref R^T)                 rotation error, in F0 [rad]
    A_cmd = A_ref + Kd (V_ref - V) + Kp [e_p; e_R]
    Gamma = IDM_model(T, V, A_cmd)       the inverse dynamic model of the *model* robot

With an exact model the closed loop is ``e'' + Kd e' + Kp e = 0`` for each axis (to first
order in the rotation error). The model robot may carry wrong inertial parameters (as a
real controller's does): pass it separately from the simulated plant.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, check_poses
from stewart_pin._so3 import so3_log
from stewart_pin.exceptions import InputError
from stewart_pin.protocols import RobotLike

Reference = Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]


def pose_error(T_ref: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``[p_ref - p, log(R_ref R^T)]`` (6,) [m, rad], the rotation error in F0."""
    return np.concatenate([T_ref[:3, 3] - T[:3, 3], pin.log3(T_ref[:3, :3] @ T[:3, :3].T)])


#: The dynamic models' backends (``StewartRobot.inverse_dynamics``): ``"auto"`` (the
#: default: compiled where a C compiler is available, else the reference), ``"pinocchio"``
#: (the reference) and ``"compiled"``.
BACKENDS = ("pinocchio", "compiled", "auto")


def check_backend(robot: RobotLike, backend: str, what: str) -> None:
    """Refuse, before anything runs, an unknown backend name (:class:`InputError`). Every
    robot takes every backend (general legs too: their models are compiled as well)."""
    if backend not in BACKENDS:
        raise InputError(
            f"{what}: unknown backend {backend!r}: 'auto' (the default), 'pinocchio' or 'compiled'"
        )


@dataclass
class ComputedTorqueController:
    """Inverse dynamic model plus PD on the pose error; call it as ``forces(t, T, V)`` (or
    ``forces(t, T, V, idle)`` on a robot whose legs have idle freedoms).

    Args:
        model: the :class:`~stewart_pin.StewartRobot` whose inverse model the controller
            uses (its inertial parameters may differ from the plant's).
        reference: ``t -> (T_ref (4, 4), V_ref (6,), A_ref (6,))``.
        kp, kd: stiffness [1/s^2] and damping [1/s] gains, scalars or (6,) per axis
            (linear x, y, z then angular); default a critically damped 10 Hz loop.
        backend: the inverse model's backend: ``"auto"`` (default), ``"pinocchio"`` or
            ``"compiled"`` (see :meth:`StewartRobot.inverse_dynamics`).
    """

    model: RobotLike
    reference: Reference
    kp: np.ndarray | float = (2 * np.pi * 10.0) ** 2
    kd: np.ndarray | float = 2 * (2 * np.pi * 10.0)
    backend: str = "auto"

    def __post_init__(self) -> None:
        check_backend(self.model, self.backend, "the computed-torque controller")
        self.kp = check_array(np.broadcast_to(self.kp, (6,)), (6,), "kp")
        self.kd = check_array(np.broadcast_to(self.kd, (6,)), (6,), "kd")

    def command(self, t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        """The commanded classical acceleration ``A_cmd`` (6,)."""
        T_ref, V_ref, A_ref = self.reference(t)
        return A_ref + self.kd * (V_ref - V) + self.kp * pose_error(T_ref, T)

    def __call__(self, t: float, T: np.ndarray, V: np.ndarray, idle: Any = None) -> np.ndarray:
        """Actuator forces Gamma (6,) [N] at time ``t`` [s] for the measured state.

        Args:
            t: time [s]; T: the measured pose 0Tp (4, 4); V: the measured twist ``[v, w]``
                (6,) in F0 [m/s, rad/s].
            idle: a robot whose legs have idle freedoms (``ChainLeg.idle_joint``, an
                R-S-S rod's spin): the measured idle joints' ``(values, rates)``, each (6,)
                [rad or m, /s], part of its state (the model's inverse dynamics requires it
                there and refuses it elsewhere: :class:`InputError`). The spins are passive:
                ``A_cmd`` is unchanged and the inverse model at the measured spin state
                gives the efforts (:func:`stewart_pin.motion.idle_simulation.simulate_idle`
                passes it).
        """
        A_cmd = self.command(t, T, V)
        if idle is None:
            return self.model.inverse_dynamics(T, V, A_cmd, backend=self.backend)
        if not isinstance(idle, tuple | list) or len(idle) != 2:
            raise InputError(
                "the computed-torque controller: idle must be the idle joints' "
                f"(values, rates), each (6,); got {type(idle).__name__}"
                + (f" of length {len(idle)}" if isinstance(idle, tuple | list) else "")
            )
        spin = tuple(
            check_array(x, (6,), f"the computed-torque controller's idle {name}")
            for x, name in zip(idle, ("values", "rates"), strict=True)
        )
        return self.model.inverse_dynamics(T, V, A_cmd, backend=self.backend, idle=spin)


def tracking_errors(
    reference: Reference | np.ndarray, times: np.ndarray, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Tracking errors of a motion, actual minus reference (the one definition of them).

    Args:
        reference: ``t -> (T_ref (4, 4), V_ref (6,), A_ref (6,))`` (a motion or a
            :data:`Reference`), or the reference poses 0Tp_ref, shape (K, 4, 4).
        times: shape (K,) [s], the instants of ``poses`` (where ``reference`` is called).
        poses: shape (K, 4, 4), the actual platform poses 0Tp.

    Returns:
        ``(e_p, e_r)``, each (K, 3) in F0: ``e_p = p - p_ref`` [m] and
        ``e_r = log3(R R_ref^T)`` [rad], the rotation vector turning the reference into the
        actual orientation. Their norms (``np.linalg.norm(e, axis=1)``) are the position
        error [m] and the rotation angle [rad]. (The control law's :func:`pose_error` is the
        opposite, reference minus actual.)
    """
    T, _ = check_poses(poses, "poses")
    t = check_array(times, (T.shape[0],), "times")
    if callable(reference):
        T_ref = np.array([reference(float(tk))[0] for tk in t]).reshape(-1, 4, 4)
    else:
        T_ref, _ = check_poses(reference, "reference")
        if T_ref.shape != T.shape:
            raise InputError(
                f"reference has shape {T_ref.shape} but poses {T.shape}: give one each"
            )
    e_p = T[:, :3, 3] - T_ref[:, :3, 3]
    e_r = so3_log(T[:, :3, :3] @ np.swapaxes(T_ref[:, :3, :3], 1, 2))
    return e_p, e_r
