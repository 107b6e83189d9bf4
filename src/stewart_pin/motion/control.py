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

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array
from stewart_pin.protocols import RobotLike

Reference = Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]


def pose_error(T_ref: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``[p_ref - p, log(R_ref R^T)]`` (6,) [m, rad], the rotation error in F0."""
    return np.concatenate([T_ref[:3, 3] - T[:3, 3], pin.log3(T_ref[:3, :3] @ T[:3, :3].T)])


@dataclass
class ComputedTorqueController:
    """Inverse dynamic model plus PD on the pose error; call it as ``forces(t, T, V)``.

    Args:
        model: the :class:`~stewart_pin.StewartRobot` whose inverse model the controller
            uses (its inertial parameters may differ from the plant's).
        reference: ``t -> (T_ref (4, 4), V_ref (6,), A_ref (6,))``.
        kp, kd: stiffness [1/s^2] and damping [1/s] gains, scalars or (6,) per axis
            (linear x, y, z then angular); default a critically damped 10 Hz loop.
        backend: the inverse model's backend, ``"pinocchio"`` or ``"compiled"``.
    """

    model: RobotLike
    reference: Reference
    kp: np.ndarray | float = (2 * np.pi * 10.0) ** 2
    kd: np.ndarray | float = 2 * (2 * np.pi * 10.0)
    backend: str = "pinocchio"

    def __post_init__(self) -> None:
        self.kp = check_array(np.broadcast_to(self.kp, (6,)), (6,), "kp")
        self.kd = check_array(np.broadcast_to(self.kd, (6,)), (6,), "kd")

    def command(self, t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        """The commanded classical acceleration ``A_cmd`` (6,)."""
        T_ref, V_ref, A_ref = self.reference(t)
        return A_ref + self.kd * (V_ref - V) + self.kp * pose_error(T_ref, T)

    def __call__(self, t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Actuator forces Gamma (6,) [N] at time ``t`` [s] for the measured state."""
        return self.model.inverse_dynamics(T, V, self.command(t, T, V), backend=self.backend)


def tracking_errors(
    reference: Reference, times: np.ndarray, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position error norms [m] and rotation error angles [rad], each (K,), of a motion."""
    errors = np.array([pose_error(reference(t)[0], T) for t, T in zip(times, poses, strict=True)])
    return np.linalg.norm(errors[:, :3], axis=1), np.linalg.norm(errors[:, 3:], axis=1)
