"""Time integration of the direct dynamic model, with the platform pose on SE(3).

The state is the pose 0Tp and the twist ``[v, w]`` (velocity of O_p and angular velocity,
both in F0); its derivative is ``dp/dt = v``, ``dR/dt = w^ R`` and the classical
acceleration from :meth:`StewartRobot.direct_dynamics`. Each step integrates in the chart
``R = exp(xi^) R_n`` around the step's start (Runge-Kutta-Munthe-Kaas), where
``dxi/dt = J_l(xi)^-1 w``, and maps back with the exponential: the rotation stays on
SO(3) to round-off, with no drift off the manifold.

- ``method="rk4"``: classical fixed-step RK4 (order 4).
- ``method="adaptive"``: Dormand-Prince 5(4) with error control on the position [m],
  rotation [rad] and twist, ``rtol`` / ``atol`` as in ``scipy.integrate.solve_ivp``.

Actuator forces come from ``forces(t, pose, twist) -> Gamma (6,)`` [N]: a time function
or a controller. With ``control_period`` the forces are sampled at that period and held
(zero-order hold, as a digital controller does). A leg leaving its stroke or the robot
nearing a singularity stops the run with :class:`SimulationError`, which keeps the part
already simulated in ``.result``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ._checks import check_array, check_pose, check_scalar
from ._io import atomic_open
from .exceptions import FileFormatError, InputError, StewartPinError
from .tables import (
    FORCE_COLUMNS,
    LENGTH_COLUMNS,
    STATE_COLUMNS,
    read_csv,
    read_npz,
    state_table,
    states_from_table,
    write_csv,
)

ForceFunction = Callable[[float, np.ndarray, np.ndarray], np.ndarray]

# Dormand-Prince 5(4) tableau.
_DP_C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1])
_DP_A = [
    [],
    [1 / 5],
    [3 / 40, 9 / 40],
    [44 / 45, -56 / 15, 32 / 9],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
]
_DP_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0])
_DP_E = _DP_B - np.array(
    [5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]
)


class SimulationError(StewartPinError):
    """The simulation stopped: the robot left its workspace or met a singularity.

    Attributes:
        time: the simulated time [s] where it stopped.
        result: the :class:`SimulationResult` up to the last accepted step.
    """

    def __init__(self, message: str, time: float, result: SimulationResult) -> None:
        super().__init__(message)
        self.time, self.result = time, result


@dataclass(frozen=True)
class SimulationResult:
    """A simulated motion, one row per output time.

    Attributes:
        t: (K,) [s]; poses: (K, 4, 4) 0Tp; twists: (K, 6) ``[v, w]`` in F0;
        accels: (K, 6) classical ``[dv/dt, dw/dt]`` in F0; gammas: (K, 6) actuator forces
        [N]; lengths: (K, 6) leg lengths [m].
    """

    t: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray
    lengths: np.ndarray

    #: Columns of the CSV form (see :mod:`stewart_pin.tables`).
    CSV_COLUMNS = STATE_COLUMNS + FORCE_COLUMNS + LENGTH_COLUMNS

    def save(self, path: str | Path) -> Path:
        """Write ``.npz`` (arrays as named here) or ``.csv`` (:data:`CSV_COLUMNS`: time,
        O_p position, quaternion of 0Rp (x, y, z, w), twist, classical acceleration, forces,
        leg lengths; SI units)."""
        path = Path(path)
        if path.suffix == ".npz":
            with atomic_open(path, "wb") as handle:
                np.savez(handle, **{k: getattr(self, k) for k in _FIELDS})
            return path
        if path.suffix == ".csv":
            states = state_table(self.t, self.poses, self.twists, self.accels)
            return write_csv(
                path, self.CSV_COLUMNS, np.column_stack([states, self.gammas, self.lengths])
            )
        raise FileFormatError(f"unknown result file type '{path.suffix}' (.npz, .csv)")

    @classmethod
    def load(cls, path: str | Path) -> SimulationResult:
        """Read a result written by :meth:`save`."""
        path = Path(path)
        if path.suffix == ".npz":
            return cls(**read_npz(path, _NPZ_SHAPES))
        if path.suffix == ".csv":
            rows = read_csv(path, cls.CSV_COLUMNS)
            return cls(*states_from_table(rows), rows[:, 20:26], rows[:, 26:32])
        raise FileFormatError(f"unknown result file type '{path.suffix}' (.npz, .csv)")


_FIELDS = ("t", "poses", "twists", "accels", "gammas", "lengths")
#: Shapes of the ``.npz`` arrays (K samples).
_NPZ_SHAPES = {
    "t": (None,),
    "poses": (None, 4, 4),
    **{k: (None, 6) for k in ("twists", "accels", "gammas", "lengths")},
}


def _left_jacobian_inverse(xi: np.ndarray) -> np.ndarray:
    """``J_l(xi)^-1`` of SO(3): ``dxi/dt = J_l^-1 w`` for ``R = exp(xi^) R_0``, w in F0."""
    # J_l(xi) = J_r(-xi) = J_r(xi)^T, and pin.Jlog3(exp3(xi)) = J_r(xi)^-1.
    return pin.Jlog3(pin.exp3(xi)).T


class _Integrator:
    def __init__(
        self, robot: Any, forces: ForceFunction, control_period: float | None, backend: str
    ):
        self.robot, self.forces, self.period, self.backend = robot, forces, control_period, backend
        self.held: tuple[int, np.ndarray] | None = None

    def gamma(self, t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        if self.period is None:
            g = self.forces(t, T, V)
        else:
            k = int(np.floor(t / self.period + 1e-9))
            if self.held is None or self.held[0] != k:
                self.held = (k, np.asarray(self.forces(t, T, V), dtype=float))
            g = self.held[1]
        return check_array(g, (6,), "forces(t, pose, twist)")

    def f(self, t: float, T0: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Derivative of the chart state y = [p, xi, v, w] around the rotation of T0."""
        T = _chart_pose(T0, y)
        V = y[6:]
        g = self.gamma(t, T, V)
        acc = self.robot.direct_dynamics(T, V, g, backend=self.backend)
        dy = np.concatenate([V[:3], _left_jacobian_inverse(y[3:6]) @ V[3:], acc])
        return dy, g


def _chart_pose(T0: np.ndarray, y: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = pin.exp3(y[3:6]) @ T0[:3, :3]
    T[:3, 3] = y[:3]
    return T


def simulate(
    robot: Any,
    duration: float,
    pose: Any = None,
    twist: Any = None,
    forces: ForceFunction | None = None,
    method: str = "rk4",
    dt: float = 1e-3,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    control_period: float | None = None,
    output_dt: float | None = None,
    progress: Callable[[float], None] | None = None,
    backend: str = "pinocchio",
) -> SimulationResult:
    """Integrate the direct dynamic model from ``(pose, twist)`` for ``duration`` [s].

    Args:
        robot: a :class:`~stewart_pin.StewartRobot`.
        pose: initial 0Tp (default the home pose); twist: initial ``[v, w]`` (default 0).
        forces: ``Gamma = forces(t, pose, twist)`` [N]; default zero (free motion).
        method: ``"rk4"`` (fixed step ``dt``) or ``"adaptive"`` (Dormand-Prince 5(4);
            ``dt`` is the first trial step).
        control_period: sample-and-hold period of ``forces`` [s] (``None``: continuous).
        output_dt: spacing of the returned samples [s] (default: every step for rk4 and
            for the adaptive method, its accepted steps).
        progress: called with the simulated time [s] after each accepted step (a progress
            bar's hook).
        backend: the direct model's backend, ``"pinocchio"`` or ``"compiled"`` (see
            :meth:`StewartRobot.direct_dynamics`).

    Raises:
        SimulationError: a leg left its stroke, a U-joint its limits, or the robot came
            too close to a singularity; ``.result`` holds the motion up to then.
    """
    if not duration > 0 or not dt > 0:
        raise InputError(f"duration and dt must be positive, got {duration} s and {dt} s")
    if method not in ("rk4", "adaptive"):
        raise InputError(f"unknown method '{method}': 'rk4' or 'adaptive'")
    rtol = check_scalar(rtol, "rtol", positive=True)
    atol = check_scalar(atol, "atol", positive=True)
    for value, label in ((control_period, "control_period"), (output_dt, "output_dt")):
        if value is not None:
            check_scalar(value, label, positive=True, unit="s")
    if control_period is not None and method == "rk4":
        ratio = control_period / dt
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise InputError(
                f"control_period {control_period} s must be a whole multiple of dt {dt} s"
            )
    T = check_pose(robot.home_pose if pose is None else pose, "pose")
    V = np.zeros(6) if twist is None else check_array(twist, (6,), "twist")
    integ = _Integrator(robot, forces or (lambda t, T, V: np.zeros(6)), control_period, backend)
    rows: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    next_output = 0.0

    def record(t: float, T: np.ndarray, V: np.ndarray) -> None:
        nonlocal next_output
        if output_dt is not None and t < next_output - 1e-12 and t < duration - 1e-12:
            return
        y0 = np.concatenate([T[:3, 3], np.zeros(3), V])
        dy, g = integ.f(t, T, y0)
        rows.append((t, T.copy(), V.copy(), dy[6:].copy(), g.copy()))
        if output_dt is not None:
            next_output += output_dt

    def result() -> SimulationResult:
        if not rows:
            empty = np.zeros((0, 6))
            return SimulationResult(np.zeros(0), np.zeros((0, 4, 4)), empty, empty, empty, empty)
        t, P, Vs, A, G = (np.array(x) for x in zip(*rows, strict=True))
        return SimulationResult(t, P, Vs, A, G, robot.leg_lengths(P))

    t, h = 0.0, float(dt)
    try:
        record(t, T, V)
        while t < duration - 1e-12:
            h = min(h, duration - t)
            if method == "rk4":
                T, V = _rk4_step(integ, t, T, V, h)
                t += h
            else:
                T, V, t, h = _dp_step(integ, t, T, V, h, rtol, atol)
            record(t, T, V)
            if progress is not None:
                progress(t)
    except SimulationError:
        raise
    except StewartPinError as e:
        raise SimulationError(f"simulation stopped at t = {t:.6g} s: {e}", t, result()) from e
    return result()


def _rk4_step(integ: _Integrator, t: float, T: np.ndarray, V: np.ndarray, h: float):
    y0 = np.concatenate([T[:3, 3], np.zeros(3), V])
    k1, _ = integ.f(t, T, y0)
    k2, _ = integ.f(t + h / 2, T, y0 + h / 2 * k1)
    k3, _ = integ.f(t + h / 2, T, y0 + h / 2 * k2)
    k4, _ = integ.f(t + h, T, y0 + h * k3)
    y = y0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return _chart_pose(T, y), y[6:]


def _dp_step(integ, t, T, V, h, rtol, atol, max_tries: int = 50):
    """One accepted Dormand-Prince step: returns (T, V, t, next step)."""
    y0 = np.concatenate([T[:3, 3], np.zeros(3), V])
    for _ in range(max_tries):
        k = []
        for c, a in zip(_DP_C, _DP_A, strict=True):
            y = y0 + h * sum(ai * ki for ai, ki in zip(a, k, strict=False)) if a else y0
            k.append(integ.f(t + c * h, T, y)[0])
        K = np.array(k)
        y1 = y0 + h * (_DP_B @ K)
        err_vec = h * (_DP_E @ K)
        scale = atol + rtol * np.maximum(np.abs(y0), np.abs(y1))
        err = float(np.sqrt(np.mean((err_vec / scale) ** 2)))
        if err <= 1.0:
            factor = 5.0 if err == 0 else min(5.0, 0.9 * err ** (-1 / 5))
            return _chart_pose(T, y1), y1[6:], t + h, h * factor
        h *= max(0.2, 0.9 * err ** (-1 / 5))
    raise InputError(f"adaptive step failed {max_tries} times at t = {t} s (step {h} s)")
