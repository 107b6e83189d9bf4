"""Time integration of the direct dynamic model, with the platform pose on SE(3).

The state is the pose 0Tp and the twist ``[v, w]`` (velocity of O_p and angular velocity,
both in F0); its derivative is ``dp/dt = v``, ``dR/dt = w^ R`` and the classical
acceleration from :meth:`StewartRobot.direct_dynamics`. Each step integrates in the chart
``R = exp(xi^) R_n`` around the step's start (Runge-Kutta-Munthe-Kaas), where
``dxi/dt = J_l(xi)^-1 w``, and maps back with the exponential: the rotation stays on
SO(3) to round-off, with no drift off the manifold.

- ``method="rk4"``: classical fixed-step RK4 (order 4) on the grid ``k * dt`` (each grid
  time computed, never accumulated: one sample per grid time).
- ``method="adaptive"``: Dormand-Prince 5(4) with error control on the position [m],
  rotation [rad] and twist, ``rtol`` / ``atol`` as in ``scipy.integrate.solve_ivp``.

Actuator forces come from ``forces(t, pose, twist) -> Gamma (6,)`` [N]: a time function
or a controller, a :class:`~stewart_pin.motion.force_tables.ForceTable` or a constant.
With ``control_period`` the forces are sampled at that period and held
(zero-order hold, as a digital controller does): sampled at the accepted state at the
start of each period, never at a trial stage.

Every step is a *trial* until accepted: it is rejected, and the step shrinks, when a stage
or its end state leaves the stroke or a U-joint's limits, passes ``robot.max_condition``
on cond(Jp^-1), or has a sign of det Jp^-1 other than the step's start (a parallel
singularity stepped over). Repeated halving locates the event: the run stops with
:class:`SimulationError` at the last accepted state, within :data:`LIMIT_TOLERANCE` of
the stroke end or U-joint limit (a singularity: within the shortest step). The error
keeps the part already simulated, accepted states only, in ``.result``, and chains the
named error (``__cause__``). Whatever the forces function or the progress callback
raises stops the run the same way.

The compiled loop (``integrator="auto"``, the default, or ``"compiled"``): when the
robot's direct model is compiled and the run has no ``dynamics`` (but that of
:func:`stewart_pin.motion.payload.simulate_payload` on rk4: the payload's compiled model,
its joints sampled at the stage times), the steps run in C
(:mod:`stewart_pin.codegen.simulator`) with this module's arithmetic, forces as data (a
``ForceTable``, a constant, the
:class:`~stewart_pin.motion.control.ComputedTorqueController` on a compiled model, its
reference a Fourier series, sinusoids or minimum-jerk knots evaluated in C at every stage;
any other reference on the adaptive method with a ``control_period``) or a Python
function called once per
``control_period``. rk4: the same trajectory to round-off (1e-10 and less); adaptive: the
same accepted steps, their times within about 1e-9 of a step where the error control
alone sets them (a few ulps in a stage move the error estimate, a difference of two
solutions). Any step that meets an event or a state the compiled guard flags is taken by
the Python loop, so events stop the run as above; ``progress`` is called after each
chunk of C steps (up to 4096) instead of after each step. With ``output_dt`` the C loop
cuts its steps at the output times and keeps the rows as this loop does (only the
states at the output times); the computed-torque controller without a control period
leaves a step cut off the ``dt`` grid, and the step back onto it, to the Python loop
(its reference is sampled at the grid's stage times). The guard is still checked at
every stage, in both loops. The compiled loop evaluates the initial state too (unless a
Python function gives the forces), takes the signs of det Jp^-1 from the compiled direct
model's own condition check (the reference's signs wherever it decides them, see
:mod:`stewart_pin.codegen._simsource`; else the reference's), and the actuated joint
positions of its rows from the robot's compiled closed forms (general legs; the 6-UPS's
from the direct model's ``q3^2``): equal to ``robot.actuator_positions`` to round-off.

Bounds (checked before the run): durations, steps, tolerances and periods finite and
positive, no step below :data:`MIN_STEP`, at most :data:`MAX_STEPS` steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, check_pose, check_scalar
from stewart_pin._io import atomic_open
from stewart_pin._so3 import so3_left_jacobian_inverse
from stewart_pin.exceptions import (
    ConvergenceError,
    FileFormatError,
    InputError,
    SimulationError,
    SimulationInterrupted,
    SingularityError,
    StewartPinError,
    WorkspaceError,
)
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    FORCE_SLICE,
    LENGTH_COLUMNS,
    LENGTH_SLICE,
    STATE_COLUMNS,
    read_csv,
    read_npz,
    state_table,
    states_from_table,
    write_csv,
)
from stewart_pin.motion.control import check_backend
from stewart_pin.motion.force_tables import ForceTable
from stewart_pin.protocols import RobotLike

ForceFunction = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
#: ``accel = dynamics(t, pose, twist, gamma)``: a direct model that depends on time (a
#: payload running its own joint trajectory, :mod:`stewart_pin.motion.payload`).
DirectModel = Callable[[float, np.ndarray, np.ndarray, np.ndarray], np.ndarray]

__all__ = [
    "INTEGRATORS",
    "LIMIT_TOLERANCE",
    "MAX_STEPS",
    "MIN_STEP",
    "SimulationError",
    "SimulationResult",
    "simulate",
]

#: The most steps one run may take (rk4: ``duration / dt``, refused before the run;
#: adaptive: accepted steps, the run stops past it; either: ``duration / control_period``).
MAX_STEPS = 10**8
#: The shortest step [s]: a smaller ``dt`` is refused, and the adaptive method stops when
#: its error control asks for less (or for less than 16 eps * duration, the clock's
#: resolution). Events are located down to this step.
MIN_STEP = 1e-12
#: A joint limit is located to this unit-free margin (``robot.limit_margin``): a 6-UPS leg's
#: stroke end to this fraction of the longest stroke length (1e-6 * 2.8 m = 2.8 um for the
#: simulator preset), a U-joint or revolute joint limit to this many radians, a prismatic
#: joint of general legs to this fraction of ``RobotDescription.stroke_mid``.
LIMIT_TOLERANCE = 1e-6
#: Slack when a ratio of times is rounded to an integer (t / period, period / dt,
#: duration / dt): round-off in the division must not add or drop a sample.
_RATIO_SLACK = 1e-9
#: ``simulate(integrator=...)``: ``"auto"`` (the compiled loop where it applies, else the
#: Python one), ``"compiled"`` (the compiled loop, or an InputError saying why not),
#: ``"python"``.
INTEGRATORS = ("auto", "compiled", "python")
#: Status of a compiled stepper's run (:mod:`stewart_pin.codegen._simsource`): done, the
#: next step for the Python loop, the end state's forces from Python.
_FAST_DONE, _FAST_BAIL, _FAST_FORCE = 0, 1, 2
_F64 = np.dtype(np.float64)
#: The most rows one call of the compiled loop writes (its buffers').
_FAST_ROWS = 4096

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


@dataclass(frozen=True)
class SimulationResult:
    """A simulated motion, one row per output time.

    Attributes:
        t: (K,) [s]; poses: (K, 4, 4) 0Tp; twists: (K, 6) ``[v, w]`` in F0;
        accels: (K, 6) classical ``[dv/dt, dw/dt]`` in F0; gammas: (K, 6) actuator forces
        [N] (general legs: the actuated joints' efforts [N or N m]); lengths: (K, 6) the
        actuated joint positions (``robot.actuator_positions``): leg lengths [m] for a
        6-UPS robot, crank angles [rad] for RUS legs, slide positions [m] for PUS legs
        (the name, and the CSV columns ``l1 .. l6``, are kept for compatibility; the
        alias :attr:`actuator_positions` says what they are).
    """

    t: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray
    lengths: np.ndarray

    @property
    def actuator_positions(self) -> np.ndarray:
        """(K, 6) the actuated joint positions [m or rad]: :attr:`lengths` by its name."""
        return self.lengths

    #: Columns of the CSV form (see :mod:`stewart_pin.formats.csv_tables`); ``l1 .. l6``
    #: hold :attr:`actuator_positions` (crank angles [rad] for RUS legs).
    CSV_COLUMNS = STATE_COLUMNS + FORCE_COLUMNS + LENGTH_COLUMNS

    def save(self, path: str | Path) -> Path:
        """Write ``.npz`` (arrays as named here) or ``.csv`` (:data:`CSV_COLUMNS`: time,
        O_p position, quaternion of 0Rp (x, y, z, w), twist, classical acceleration, forces
        (actuated joint efforts), actuated joint positions ``l1 .. l6``: leg lengths for
        6-UPS, crank angles [rad] for RUS, slide positions for PUS; SI units)."""
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
        raise _unknown_suffix(path)

    @classmethod
    def load(cls, path: str | Path) -> SimulationResult:
        """Read a result written by :meth:`save`."""
        path = Path(path)
        if path.suffix == ".npz":
            return cls(**read_npz(path, _NPZ_SHAPES))
        if path.suffix == ".csv":
            rows = read_csv(path, cls.CSV_COLUMNS)
            return cls(*states_from_table(rows), rows[:, FORCE_SLICE], rows[:, LENGTH_SLICE])
        raise _unknown_suffix(path)


def _unknown_suffix(path: Path) -> FileFormatError:
    """The error for a result file that is neither ``.npz`` nor ``.csv``."""
    return FileFormatError(f"unknown result file type '{path.suffix}' (.npz, .csv)")


_FIELDS = ("t", "poses", "twists", "accels", "gammas", "lengths")
#: Shapes of the ``.npz`` arrays (K samples).
_NPZ_SHAPES = {
    "t": (None,),
    "poses": (None, 4, 4),
    **{k: (None, 6) for k in ("twists", "accels", "gammas", "lengths")},
}


def _chart_pose(T0: np.ndarray, y: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = pin.exp3(y[3:6]) @ T0[:3, :3]
    T[:3, 3] = y[:3]
    return T


def _chart_state(T: np.ndarray, V: np.ndarray) -> np.ndarray:
    """The chart state ``[p, xi = 0, v, w]`` (12,) of ``(T, V)`` around its own rotation."""
    return np.concatenate([T[:3, 3], np.zeros(3), V])


@dataclass(frozen=True)
class _State:
    """An accepted state: time [s], pose, twist, chart derivative at xi = 0 (12,), the
    forces applied from it [N], and the sign of det Jp^-1 there."""

    t: float
    T: np.ndarray
    V: np.ndarray
    dy: np.ndarray
    gamma: np.ndarray
    sign: float


class _Failure(Exception):
    """A trial step met a limit (a stage or its end outside the stroke / U-joint limits,
    cond(Jp^-1) past its threshold, or det Jp^-1 changing sign): shrink the step."""

    def __init__(self, error: StewartPinError) -> None:
        super().__init__(str(error))
        self.error = error


class _CallbackError(Exception):
    """The user's forces function or progress callback raised ``error``."""

    def __init__(self, what: str, t: float, error: Exception) -> None:
        super().__init__(f"{what} raised {type(error).__name__} at t = {t:.9g} s: {error}")
        self.error = error


#: Errors that reject a trial step (the step shrinks to locate the event) instead of
#: stopping the run at once.
_LIMIT_ERRORS = (WorkspaceError, SingularityError)
#: The start of the message of a sign change of det Jp^-1 within a trial.
_SIGN_CHANGE = "det Jp^-1 changes sign"


class _Integrator:
    def __init__(
        self,
        robot: RobotLike,
        forces: ForceFunction,
        control_period: float | None,
        backend: str,
        dynamics: DirectModel | None = None,
    ):
        self.robot, self.forces, self.period, self.backend = robot, forces, control_period, backend
        self.held: tuple[int, np.ndarray] | None = None
        self.dynamics = dynamics

    def period_index(self, t: float) -> int:
        """Index of the control period holding ``t`` (0 without a control period)."""
        return 0 if self.period is None else math.floor(t / self.period + _RATIO_SLACK)

    def gamma(self, t: float, T: np.ndarray, V: np.ndarray, k: int) -> np.ndarray:
        """Forces at stage time ``t``; with a control period, the value sampled at the
        start of period ``k`` (an accepted state), held through the period."""
        if self.period is not None and self.held is not None and self.held[0] == k:
            return self.held[1]
        try:
            g = self.forces(t, T, V)
        except _LIMIT_ERRORS:
            raise  # a controller's own workspace check at a trial stage: shrink the step
        except Exception as e:
            raise _CallbackError("forces(t, pose, twist)", t, e) from e
        if (
            type(g) is np.ndarray
            and g.shape == (6,)
            and g.dtype == _F64
            and math.isfinite(g.dot(g))  # all finite (an overflow takes check_array)
        ):
            g = g.copy()  # what check_array returns for it, without its other checks' cost
        else:
            g = check_array(g, (6,), "forces(t, pose, twist)")
        if self.period is not None:
            self.held = (k, g)
        return g

    def f(
        self, t: float, T0: np.ndarray, y: np.ndarray, k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Derivative of the chart state y = [p, xi, v, w] around the rotation of T0, the
        forces and the pose; ``k`` is the control period of the step."""
        T = _chart_pose(T0, y)
        V = y[6:]
        g = self.gamma(t, T, V, k)
        if self.dynamics is None:
            acc = self.robot.direct_dynamics(T, V, g, backend=self.backend)
        else:
            acc = check_array(self.dynamics(t, T, V, g), (6,), "dynamics(t, pose, twist, gamma)")
        dy = np.concatenate([V[:3], so3_left_jacobian_inverse(y[3:6]) @ V[3:], acc])
        return dy, g, T

    def det_signs(self, poses: np.ndarray) -> np.ndarray:
        """Signs of det Jp^-1 at poses (N, 4, 4)."""
        return np.sign(np.linalg.det(self.robot.inverse_jacobian(poses)))

    def state(self, t: float, T: np.ndarray, V: np.ndarray, sign: float | None = None) -> _State:
        """Evaluate an accepted (or candidate) state: raises the dynamics' errors. ``sign``:
        of det Jp^-1 at T, when known."""
        dy, g, _ = self.f(t, T, _chart_state(T, V), self.period_index(t))
        if sign is None:
            sign = float(self.det_signs(T[None])[0])
        return _State(t, T, V, dy, g, sign)

    def trial(
        self, s: _State, h: float, t_new: float, method: str, rtol: float, atol: float
    ) -> tuple[_State | None, float]:
        """One trial step of ``h`` [s] from ``s`` to ``t_new``: ``(new state, error norm)``,
        the state ``None`` when the adaptive error control rejects it.

        Raises :class:`_Failure` when a stage or the end state meets a limit or the sign
        of det Jp^-1 differs from the start's at any of them; the held forces are then
        restored, so a rejected trial leaves no trace.
        """
        held = self.held
        try:
            new, err = self._trial(s, h, t_new, method, rtol, atol)
        except _LIMIT_ERRORS as e:
            self.held = held
            raise _Failure(e) from e
        except BaseException:
            self.held = held
            raise
        return new, err

    def _trial(
        self, s: _State, h: float, t_new: float, method: str, rtol: float, atol: float
    ) -> tuple[_State | None, float]:
        k = self.period_index(s.t)
        y0 = _chart_state(s.T, s.V)
        if method == "rk4":
            k2, _, T2 = self.f(s.t + h / 2, s.T, y0 + h / 2 * s.dy, k)
            k3, _, T3 = self.f(s.t + h / 2, s.T, y0 + h / 2 * k2, k)
            k4, _, T4 = self.f(t_new, s.T, y0 + h * k3, k)
            y1 = y0 + h / 6 * (s.dy + 2 * k2 + 2 * k3 + k4)
            poses, err, last = np.array([T2, T3, T4, _chart_pose(s.T, y1)]), 0.0, None
        else:
            K, stages = [s.dy], []
            for c, a in zip(_DP_C[1:], _DP_A[1:], strict=True):
                y = y0 + h * sum(ai * ki for ai, ki in zip(a, K, strict=False))
                dy, g, T = self.f(s.t + c * h, s.T, y, k)
                K.append(dy)
                stages.append(T)
            y1 = y  # FSAL: the last stage is the fifth-order solution
            scale = atol + rtol * np.maximum(np.abs(y0), np.abs(y1))
            # The difference of the two solutions summed stage by stage, in order (not a
            # BLAS product, whose order depends on the machine's kernel): the compiled
            # loop (codegen/_simsource.py) sums it the same way.
            diff = sum(e * k for e, k in zip(_DP_E, K, strict=True))
            err = float(np.sqrt(np.mean((h * diff / scale) ** 2)))
            if not err <= 1.0:
                return None, err
            poses, last = np.array(stages), (K[-1], g)
        signs = self.det_signs(poses)
        if np.any(signs != s.sign):
            n = int(np.argmax(signs != s.sign))
            raise SingularityError(
                f"{_SIGN_CHANGE} between t = {s.t:.9g} s and {t_new:.9g} s: the platform "
                "crosses a parallel singularity",
                float(self.robot.condition_number(poses[n])),
                float(self.robot.max_condition),
            )
        T1, V1 = poses[-1], y1[6:].copy()
        if last is not None and self.period_index(t_new) == k:
            # The last Dormand-Prince stage is the end state: reuse it (no new sample of
            # the forces within the same control period).
            dy, g = last
            dy = np.concatenate([V1[:3], V1[3:], dy[6:]])
            return _State(t_new, T1, V1, dy, g, s.sign), err
        return self.state(t_new, T1, V1, s.sign), err


def simulate(
    robot: RobotLike,
    duration: float,
    pose: Any = None,
    twist: Any = None,
    forces: ForceFunction | ForceTable | Any = None,
    method: str = "rk4",
    dt: float = 1e-3,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    control_period: float | None = None,
    output_dt: float | None = None,
    progress: Callable[[float], None] | None = None,
    backend: str = "auto",
    dynamics: DirectModel | None = None,
    integrator: str = "auto",
) -> SimulationResult:
    """Integrate the direct dynamic model from ``(pose, twist)`` for ``duration`` [s].

    Args:
        robot: a :class:`~stewart_pin.StewartRobot`.
        duration: simulated time [s], finite and positive.
        pose: initial 0Tp (default the home pose); twist: initial ``[v, w]`` (default 0).
        forces: ``Gamma = forces(t, pose, twist)`` [N], a
            :class:`~stewart_pin.motion.force_tables.ForceTable` or a constant (6,);
            default zero (free motion).
        method: ``"rk4"`` (fixed step ``dt``) or ``"adaptive"`` (Dormand-Prince 5(4);
            ``dt`` is the first trial step).
        dt: step [s], at least :data:`MIN_STEP`; for rk4, ``duration / dt`` is at most
            :data:`MAX_STEPS`.
        rtol, atol: the adaptive method's relative and absolute tolerances (positive).
        control_period: sample-and-hold period of ``forces`` [s] (``None``: continuous).
            The forces are sampled at accepted states only, at the start of each period,
            and held over it; no step crosses a period boundary.
        output_dt: spacing of the returned samples [s]: no step crosses an output time,
            so the samples lie at ``k * output_dt`` exactly (and at ``duration``); default:
            every step (rk4: the grid ``k * dt``; adaptive: its accepted steps).
        progress: called with the simulated time [s] after each accepted step (a progress
            bar's hook).
        backend: the direct model's backend: ``"auto"`` (default: compiled where a C
            compiler is available), ``"pinocchio"`` or ``"compiled"`` (see
            :meth:`StewartRobot.direct_dynamics`).
        dynamics: ``accel = dynamics(t, pose, twist, gamma)`` (6,), a direct model used
            instead of ``robot.direct_dynamics`` (``robot`` still gives the limits and
            singularities): e.g. a payload running its own joint trajectory
            (:func:`stewart_pin.motion.payload.simulate_payload`).
        integrator: ``"auto"`` (default: the compiled loop when the robot's direct model
            is compiled and the run is one it reproduces, module docstring), ``"compiled"``
            (that loop or :class:`InputError` saying why not) or ``"python"``.

    Raises:
        InputError: a duration, step, tolerance or period that is not finite and
            positive, a step below :data:`MIN_STEP`, or more than :data:`MAX_STEPS` steps;
            an unknown backend.
        SimulationError: the run stopped; ``.result`` holds the accepted states up to
            then and ``__cause__`` the named error. Stops: a leg reaching its stroke end or
            a U-joint its limit (located to :data:`LIMIT_TOLERANCE`), cond(Jp^-1) passing
            ``robot.max_condition`` or det Jp^-1 changing sign (a parallel singularity,
            located to the step resolution), a leg singularity, the adaptive step falling
            below the minimum, more than :data:`MAX_STEPS` accepted steps, or ``forces`` /
            ``progress`` raising.
        SimulationInterrupted: a ``KeyboardInterrupt`` (Ctrl-C, or raised by ``forces``
            or ``progress``) during the run; ``.result`` holds the accepted states.
    """
    return prepare_run(
        robot,
        duration,
        pose,
        twist,
        forces,
        method,
        dt,
        rtol,
        atol,
        control_period,
        output_dt,
        progress,
        backend,
        dynamics,
        integrator,
    ).go()


def prepare_run(
    robot: RobotLike,
    duration: float,
    pose: Any = None,
    twist: Any = None,
    forces: Any = None,
    method: str = "rk4",
    dt: float = 1e-3,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    control_period: float | None = None,
    output_dt: float | None = None,
    progress: Callable[[float], None] | None = None,
    backend: str = "auto",
    dynamics: DirectModel | None = None,
    integrator: str = "auto",
) -> _Run:
    """:func:`simulate`'s arguments checked, its loop ready: ``.go()`` runs it (the
    batches of :func:`stewart_pin.codegen.simulator.simulate_batch` start many)."""
    duration = check_scalar(duration, "duration", positive=True, unit="s")
    dt = check_scalar(dt, "dt", positive=True, unit="s")
    rtol, atol = (
        check_scalar(rtol, "rtol", positive=True),
        check_scalar(atol, "atol", positive=True),
    )
    if control_period is not None:
        control_period = check_scalar(control_period, "control_period", positive=True, unit="s")
    if output_dt is not None:
        output_dt = check_scalar(output_dt, "output_dt", positive=True, unit="s")
    if method not in ("rk4", "adaptive"):
        raise InputError(f"unknown method '{method}': 'rk4' or 'adaptive'")
    check_backend(robot, backend, "simulate")
    if integrator not in INTEGRATORS:
        raise InputError(
            f"unknown integrator {integrator!r}: 'auto' (the default), 'compiled' or 'python'"
        )
    if forces is not None and not callable(forces):
        forces = ForceTable.constant(forces)
    for fn, name in ((forces, "forces"), (progress, "progress"), (dynamics, "dynamics")):
        if fn is not None and not callable(fn):
            raise InputError(f"{name} must be a function, got {type(fn).__name__}")
    if dt < MIN_STEP:
        raise InputError(
            f"dt = {dt:g} s is below the smallest step {MIN_STEP:g} s: give a larger dt"
        )
    if method == "rk4" and duration / dt > MAX_STEPS:
        raise InputError(
            f"duration / dt = {duration:g} s / {dt:g} s = {duration / dt:.3g} steps, more than "
            f"the bound {MAX_STEPS:.0e}: give a larger dt or a shorter duration"
        )
    if control_period is not None:
        if duration / control_period > MAX_STEPS:
            raise InputError(
                f"duration / control_period = {duration / control_period:.3g} periods, more "
                f"than the bound {MAX_STEPS:.0e} on the steps: give a larger control_period"
            )
        if method == "rk4":
            ratio = control_period / dt
            if abs(ratio - round(ratio)) > _RATIO_SLACK or round(ratio) < 1:
                raise InputError(
                    f"control_period {control_period} s must be a whole multiple of dt {dt} s"
                )
    T = check_pose(robot.home_pose if pose is None else pose, "pose")
    V = np.zeros(6) if twist is None else check_array(twist, (6,), "twist")
    integ = _Integrator(
        robot, forces or (lambda t, T, V: np.zeros(6)), control_period, backend, dynamics
    )
    run = _Run(robot, integ, duration, method, dt, rtol, atol, output_dt, progress, T, V)
    if integrator != "python":
        got = _compiled_stepper(
            robot,
            backend,
            forces,
            method,
            dt,
            duration,
            control_period,
            output_dt,
            dynamics,
            run.n_grid,
            rtol,
            atol,
            run.h_min,
        )
        if isinstance(got, str):
            if integrator == "compiled":
                raise InputError(f"integrator='compiled' cannot run this simulation: {got}")
        else:
            run.fast = got
    return run


def _compiled_stepper(robot: RobotLike, backend: str, *args: Any) -> Any:
    """The compiled loop for this run (``robot.simulation_stepper``: the robot's compiled
    models, :mod:`stewart_pin.codegen.simulator`), or why there is none."""
    make = getattr(robot, "simulation_stepper", None)
    if make is None:
        return "the robot has no compiled simulation loop"
    return make(backend, *args)


def grid_times(dt: float, duration: float, n_grid: int) -> np.ndarray:
    """The rk4 grid ``n * dt`` (n < n_grid) and ``duration`` (n_grid), (n_grid + 1,) [s]:
    the times the Python loop computes (:meth:`_Run._grid`)."""
    grid = np.arange(n_grid + 1) * dt
    grid[-1] = duration
    return grid


@dataclass(frozen=True)
class _Block:
    """Accepted states of the compiled loop: times (m,) [s], poses (m, 4, 4), twists,
    accelerations, forces and the actuated joint positions (m, 6) (None: computed with the
    result); ``t`` the last time."""

    times: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray
    lengths: np.ndarray | None = None

    @property
    def t(self) -> float:
        return float(self.times[-1])


class _Run:
    """The stepping loop of :func:`simulate` (validated arguments)."""

    def __init__(
        self,
        robot: RobotLike,
        integ: _Integrator,
        duration: float,
        method: str,
        dt: float,
        rtol: float,
        atol: float,
        output_dt: float | None,
        progress: Callable[[float], None] | None,
        T: np.ndarray | None = None,
        V: np.ndarray | None = None,
    ) -> None:
        self.T0, self.V0 = T, V
        #: The compiled loop (a stepper of :mod:`stewart_pin.codegen.simulator`) or None.
        self.fast: Any = None
        self.fast_from = 0  # the compiled loop takes grid steps from this index on
        self.fast_state: _State | None = None  # the state loaded in self.fast
        self.resume: tuple[_State, int] | None = None  # (state, grid index) to go on from
        self.robot, self.integ, self.duration, self.method = robot, integ, duration, method
        self.dt, self.rtol, self.atol, self.output_dt = dt, rtol, atol, output_dt
        self.progress = progress
        self.rows: list[_State | _Block] = []
        self.last: _State | None = None
        self.n_output = 0  # output_dt: the index of the next output time
        # Step resolution: no step shorter than MIN_STEP, nor than the clock's resolution.
        self.h_min = max(MIN_STEP, 16 * np.finfo(float).eps * duration)
        self.n_grid = max(1, int(np.ceil(duration / dt - _RATIO_SLACK))) if method == "rk4" else 0

    # ------------------------------------------------------------------ output
    def record(self, s: _State, final: bool = False) -> None:
        """Keep an accepted state (every ``output_dt``; always when ``final``)."""
        if self.fast is not None and self.fast.has_rows():
            self.absorb(s)  # the compiled loop's rows (its initial state) come first
        self.last = s
        if self.rows and self.rows[-1].t == s.t:
            return
        out = self.output_dt
        if out is not None:
            if not final and s.t < self._output_time(self.n_output) - self.h_min:
                return
            self.n_output = int(np.floor(s.t / out + _RATIO_SLACK)) + 1
        self.rows.append(s)

    def _output_time(self, k: int) -> float:
        """The k-th output time ``k * output_dt`` [s] (``duration`` past the end): computed,
        never accumulated, so the samples lie on the grid."""
        assert self.output_dt is not None
        t = k * self.output_dt
        return self.duration if t > self.duration - self.h_min else t

    def result(self) -> SimulationResult:
        if not self.rows:
            empty = np.zeros((0, 6))
            return SimulationResult(np.zeros(0), np.zeros((0, 4, 4)), empty, empty, empty, empty)
        parts: list[_Block] = []
        states: list[_State] = []
        for row in [*self.rows, None]:
            if isinstance(row, _State):
                states.append(row)
                continue
            if states:
                parts.append(
                    _Block(
                        np.array([s.t for s in states]),
                        np.array([s.T for s in states]),
                        np.array([s.V for s in states]),
                        np.array([s.dy[6:] for s in states]),
                        np.array([s.gamma for s in states]),
                    )
                )
                states = []
            if row is not None:
                parts.append(row)
        t, P, V, A, G = (
            getattr(parts[0], k)
            if len(parts) == 1
            else np.concatenate([getattr(p, k) for p in parts])
            for k in ("times", "poses", "twists", "accels", "gammas")
        )
        if all(p.lengths is None for p in parts):
            L = self.robot.actuator_positions(P)
        elif len(parts) == 1 and parts[0].lengths is not None:
            L = parts[0].lengths
        else:  # the compiled loop's actuator positions, the rest computed as it does
            L = np.concatenate(
                [
                    self._actuator_positions(p.poses) if p.lengths is None else p.lengths
                    for p in parts
                ]
            )
        return SimulationResult(t, P, V, A, G, L)

    def _actuator_positions(self, poses: np.ndarray) -> np.ndarray:
        """The actuated joint values of poses the Python loop accepted, in a result that
        has rows of the compiled loop: computed as that loop computes its rows (the same
        values to round-off as ``robot.actuator_positions``, without its per-call cost)."""
        got = None if self.fast is None else self.fast.actuator_positions(poses)
        return self.robot.actuator_positions(poses) if got is None else got

    def stop(self, message: str, t: float) -> SimulationError:
        """The error to stop with; the result ends with the last accepted state."""
        if self.last is not None:
            self.record(self.last, final=True)
        return SimulationError(f"simulation stopped at t = {t:.9g} s: {message}", t, self.result())

    # ------------------------------------------------------------------ events
    def located(self, s: _State, failure: _Failure, h: float) -> SimulationError | None:
        """The error to stop with when the event after ``s`` is located (``None``: not yet).

        A stroke end (U-joint limit) is located when the last accepted state lies within
        ``LIMIT_TOLERANCE`` times the longest stroke length (``LIMIT_TOLERANCE`` rad) of it;
        any event when the failing step is down to the shortest step."""
        e = failure.error
        if isinstance(e, WorkspaceError):
            margin, what = self.robot.limit_margin(s.T, e)
            if margin <= LIMIT_TOLERANCE:
                return self._stop(what, s.t, e)
            if h <= self.h_min:  # not this limit (a controller's own check, say)
                return self._stop(f"{e} (within the next {h:.2g} s)", s.t, e)
            return None
        if h > self.h_min:
            return None
        if isinstance(e, SingularityError) and e.leg is not None:
            what = (
                f"leg {e.leg} reaches a leg singularity within the next {h:.2g} s "
                f"(threshold {e.threshold:g})"
            )
        else:
            cond = float(self.robot.condition_number(s.T))
            if str(e).startswith(_SIGN_CHANGE):
                how = _SIGN_CHANGE
            elif isinstance(e, SingularityError) and e.threshold == self.robot.max_condition:
                how = f"cond(Jp^-1) passes its threshold {self.robot.max_condition:g}"
            else:
                how = str(e)
            what = (
                f"the platform reaches a parallel singularity: cond(Jp^-1) = {cond:.4g} here, "
                f"and {how} within the next {h:.2g} s"
            )
        return self._stop(what, s.t, e)

    def _stop(self, what: str, t: float, cause: BaseException) -> SimulationError:
        err = self.stop(what, t)
        err.__cause__ = cause
        return err

    # ------------------------------------------------------------------ loop
    def begin(self) -> _State:
        """The initial state, evaluated and recorded (once)."""
        if self.resume is None:
            assert self.T0 is not None and self.V0 is not None
            if self.fast is not None and self.fast.start(self.T0, self.V0):
                # Evaluated in C with this loop's arithmetic (forces, direct model), the
                # sign of det Jp^-1 from the model's cheap condition check, which decides
                # it as the reference does (else the C loop leaves it to the lines below).
                # Its row stays in the C buffer, handed over with the next steps' rows.
                fast = self.fast
                t, T, V, dy, g = fast.state()
                s = _State(t, T, V, dy, g, fast.sign())
                self.integ.held = fast.held()
                self.last = self.fast_state = s
                self.resume = (s, 0)
                return s
            # The compiled loop: the sign of det Jp^-1 as it computes its stages' (equal to
            # the reference's wherever its check decides; else None: the reference's).
            sign = None if self.fast is None else self.fast.det_sign(self.T0)
            s = self.integ.state(0.0, self.T0, self.V0, sign)
            self.record(s)
            self.resume = (s, 0)
        return self.resume[0]

    def go(self) -> SimulationResult:
        try:
            self.begin()
            assert self.resume is not None
            self._loop(*self.resume)
            assert self.last is not None  # _loop accepted s at least
            self.record(self.last, final=True)
        except _Located as done:
            raise done.error from done.error.__cause__
        except _CallbackError as e:
            raise self.stop(str(e), self._time()) from e.error
        except StewartPinError as e:
            raise self.stop(str(e), self._time()) from e
        except Exception as e:  # not a named error: keep what was simulated all the same
            raise self.stop(f"{type(e).__name__}: {e}", self._time()) from e
        except KeyboardInterrupt as e:  # Ctrl-C: still an interrupt, with the states so far
            if isinstance(e, SimulationInterrupted):
                raise
            if self.last is not None:
                self.record(self.last, final=True)
            raise SimulationInterrupted(self._time(), self.result()) from e
        return self.result()

    def _time(self) -> float:
        """The time [s] of the last accepted state (0 before the first)."""
        return 0.0 if self.last is None else self.last.t

    def _grid(self, n: int) -> float:
        """rk4: the n-th grid time [s] (``duration`` for the last)."""
        return self.duration if n >= self.n_grid else n * self.dt

    def _on_grid(self, s: _State, n: int) -> bool:
        """rk4: whether the compiled loop may take the next step from ``s`` (grid index
        ``n``): at a grid time, or with ``output_dt`` anywhere (a state cut at an output
        time; the next step ends at the next grid or output time, in either loop)."""
        return s.t == self._grid(n) or self.output_dt is not None

    def _loop(self, s: _State, n: int = 0) -> None:
        integ, duration, rk4 = self.integ, self.duration, self.method == "rk4"
        # n, rk4: the last grid time reached
        h_cur = self.dt
        t_bad: float | None = None  # end of the last failed trial still ahead: the event
        steps = 0
        while s.t < duration:
            if (
                self.fast is not None
                and t_bad is None
                and steps < MAX_STEPS - _FAST_ROWS
                and (
                    (rk4 and n >= self.fast_from and h_cur == self.dt and self._on_grid(s, n))
                    or (not rk4 and steps >= self.fast_from)
                )
            ):
                s, n, h_next, taken, bailed = self.fast_steps(s, n, h_cur)
                steps += taken
                if not rk4:
                    h_cur = h_next
                if bailed or taken == 0:  # the Python loop takes the next (grid) step
                    self.fast_from = n + 1 if rk4 else steps + 1
                continue
            if rk4:
                target = self._grid(n + 1)
            else:
                target = duration
                if integ.period is not None:
                    target = min(target, (integ.period_index(s.t) + 1) * integ.period)
            if self.output_dt is not None:  # no step crosses an output time
                target = min(target, self._output_time(self.n_output))
            if t_bad is not None:
                target = min(target, t_bad)
            # A step that reaches the target to round-off (a few ulps of the time) lands on
            # it exactly: no sliver left to step over (one sample per grid time). The
            # allowance is below half the shortest step, so a halved trial never snaps.
            if target - s.t <= h_cur + 4 * np.spacing(target):
                h, t_new = target - s.t, target
            else:
                h, t_new = h_cur, s.t + h_cur
            try:
                new, err = integ.trial(s, h, t_new, self.method, self.rtol, self.atol)
            except _Failure as failure:
                stop = self.located(s, failure, h)
                if stop is not None:
                    raise _Located(stop) from None
                t_bad, h_cur = t_new, h / 2
                continue
            if new is None:  # the adaptive error control rejects the step
                h_cur = h * max(0.2, 0.9 * err ** (-1 / 5))
                if h_cur < self.h_min:
                    failed = ConvergenceError(
                        f"the adaptive step fell below {self.h_min:.3g} s (error "
                        f"{err:.3g} times the tolerance): the forces may be discontinuous "
                        "or the motion too stiff; loosen rtol/atol or use rk4",
                        None,
                        err,
                    )
                    raise _Located(self._stop(str(failed), s.t, failed))
                continue
            s = new
            steps += 1
            self.record(s)
            if self.progress is not None:
                try:
                    self.progress(s.t)
                except Exception as e:
                    raise _CallbackError("progress(t)", s.t, e) from e
            if steps >= MAX_STEPS and s.t < duration:
                raise _Located(
                    self.stop(
                        f"{steps} accepted steps, the bound MAX_STEPS: give a shorter "
                        "duration or looser tolerances",
                        s.t,
                    )
                )
            if t_bad is not None and s.t >= t_bad:
                t_bad = None  # the failure was a trial artefact: the motion went past it
            if not rk4:
                h_cur = h * (5.0 if err == 0 else min(5.0, 0.9 * err ** (-1 / 5)))
            elif s.t == self._grid(n + 1):
                n, h_cur = n + 1, self.dt
            elif t_bad is None:
                h_cur = min(2 * h_cur, self.dt)

    # ------------------------------------------------------------------ compiled loop
    def fast_steps(self, s: _State, n: int, h: float) -> tuple[_State, int, float, int, bool]:
        """Steps of the compiled loop from ``s`` (rk4: grid index ``n``; adaptive: next
        trial step ``h`` [s]) until its buffer is full, the end, or a step it leaves to
        the Python loop: ``(state, n, next trial step, accepted steps, bailed)``."""
        fast, integ = self.fast, self.integ
        if self.fast_state is not s or fast.step() != h:
            fast.load(s.t, s.T, s.V, s.dy, s.gamma, s.sign, integ.held, n, h, self.n_output)
        try:
            while True:
                status = fast.run(self.n_grid)
                if status != _FAST_FORCE:
                    break
                t, T, V = fast.pending()
                held = integ.held
                try:
                    integ.gamma(t, T, V, integ.period_index(t))
                except _LIMIT_ERRORS:  # a controller's own check: the Python loop decides
                    integ.held = held
                    fast.drop_pending()
                    status = _FAST_BAIL
                    break
                except BaseException:
                    integ.held = held
                    fast.drop_pending()
                    raise
                fast.hold(integ.held)
        finally:
            s, taken = self.absorb(s)
        if taken and self.progress is not None:
            try:
                self.progress(s.t)
            except Exception as e:
                raise _CallbackError("progress(t)", s.t, e) from e
        return s, fast.n, fast.step(), taken, status == _FAST_BAIL

    def absorb(self, s: _State) -> tuple[_State, int]:
        """Keep the rows the compiled loop wrote (with ``output_dt``: its states at the
        output times): its last state (``s`` if none) and how many steps it took."""
        fast = self.fast
        times, P, V, A, G, L = fast.rows()
        taken = fast.steps()
        if self.output_dt is not None:
            self.n_output = fast.output_index()
        if times.size == 0 and taken == 0:
            self.fast_state = s
            return s, 0
        if times.size:
            self.rows.append(_Block(times, P, V, A, G, L))
        t, T, Vl, dy, g = fast.state()
        s = _State(t, T, Vl, dy, g, s.sign)
        self.integ.held = fast.held()
        self.last = self.fast_state = s
        self.resume = (s, fast.n)
        return s, taken


class _Located(Exception):
    """Carries the SimulationError of a located event out of the loop."""

    def __init__(self, error: SimulationError) -> None:
        super().__init__(str(error))
        self.error = error
