"""Identification of the base inertial parameters: the workflow a lab runs on a hexapod.

1. :func:`exciting_trajectory`: a periodic platform motion (a finite Fourier series per
   axis, :class:`~stewart_pin.motion.trajectories.FourierTrajectory`) whose coefficients minimise
   the condition number of the stacked base regressor, inside the workspace.
2. Measurements: run it, log poses, twists, accelerations and actuator forces
   (:class:`Measurements`; CSV format in ``docs/identification.md``,
   :func:`write_measurements_csv` / :func:`read_measurements_csv`), or simulate them with
   :func:`simulate_measurements`.
3. :func:`identify`: ordinary, then weighted least squares (Gautier 1991) of
   ``Gamma = W_b chi_b`` stacked over the samples; estimates with standard deviations.
4. :func:`validation_error`: the relative RMS force prediction error on another trajectory.

From a real robot's log of actuator positions and efforts
(:class:`~stewart_pin.parameters.logs.ActuatorLog`), :func:`identify_log` estimates the
states (:mod:`stewart_pin.parameters.state_estimation`), filters and decimates both
sides of the model alike and accumulates the equations chunk by chunk
(:class:`~stewart_pin.parameters.least_squares.StackedLeastSquares`: bounded memory);
:func:`log_prediction_error` validates on another log; :func:`base_without` drops terms
the model does not have; :mod:`stewart_pin.parameters.physical` fits physically
consistent parameters. Every architecture (joint terms included).

Every condition number here is that of the stacked base regressor with its columns scaled
to unit norm (so it does not depend on units), the 2-norm ratio of its extreme singular
values.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import scipy.optimize

from stewart_pin._checks import check_array, check_scalar, freeze_fields
from stewart_pin.description.leg_architecture import wrap_into_limits
from stewart_pin.dynamics.regressor import N_STANDARD
from stewart_pin.exceptions import (
    FileFormatError,
    InputError,
    LogError,
    StewartPinError,
    WorkspaceError,
)
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    FORCE_SLICE,
    MAX_MAGNITUDE,
    STATE_COLUMNS,
    read_csv,
    state_table,
    states_from_table,
    write_csv,
)
from stewart_pin.motion.trajectories import FourierTrajectory, Trajectory
from stewart_pin.parameters.base import BaseParameters, base_parameters
from stewart_pin.parameters.least_squares import (
    LeastSquaresSolution,
    StackedLeastSquares,
)
from stewart_pin.parameters.logs import ActuatorLog, check_log
from stewart_pin.parameters.state_estimation import (
    FilterDesign,
    PolyphaseDecimator,
    StateStream,
    design_filters,
)
from stewart_pin.protocols import RobotLike

# ====================================================================== exciting trajectories


def _base_of(robot: RobotLike, base: BaseParameters | None) -> BaseParameters:
    """``base`` (default the analytic set) bound to ``robot``."""
    if base is None:
        return base_parameters(robot, "analytic")
    return base if base.robot is robot else replace(base, robot=robot)


def base_without(base: BaseParameters, zero: Any) -> BaseParameters:
    """The base parameters of a model in which some standard parameters are known to be
    zero (a joint without a spring, a sensor without an offset): ``W chi = W_b K chi``
    with those entries of ``chi`` zero keeps the rows of ``K`` that still have a term,
    and the regressor columns of the others drop out (exact: the forces of every ``chi``
    with those entries zero are unchanged).

    Args:
        base: the full base set.
        zero: standard parameter names (``"K2_4"``), or joint-term kinds (``"K"``,
            ``"OF"``, ``"IA"``, ``"FV"``, ``"FC"``) meaning that term of every joint, or
            ``"K@passive"`` (``"OF@passive"``...) meaning it for the passive joints only.

    Raises:
        InputError: an unknown name, or a base set whose remaining rows are dependent.
    """
    names = base.standard_names
    n = len(names)
    mask = np.zeros(n, dtype=bool)
    kinds = ("IA", "FV", "FC", "K", "OF")
    robot = base.robot
    passive: set[int] = set()
    if robot is not None:  # the joints' terms (none on the ideal 6-UPS: no joint terms)
        from stewart_pin.dynamics.regressor import parameter_groups

        for jp in parameter_groups(robot.description).joints:
            if not jp.actuated:
                passive.update(range(jp.index.start, jp.index.stop))
    for item in [zero] if isinstance(zero, str) else list(zero):
        kind, _, where = str(item).partition("@")
        if kind in kinds and where in ("", "passive"):
            hits = [k for k in range(N_STANDARD, n) if _term_kind(names[k]) == kind]
            if where == "passive":
                hits = [k for k in hits if k in passive]
            mask[hits] = True
        elif item in names:
            mask[names.index(item)] = True
        else:
            raise InputError(
                f"unknown standard parameter or joint term {item!r}: give names such as "
                f"'K2_4', kinds {kinds}, or 'K@passive'"
            )
    K = np.where(mask[None, :], 0.0, base.K)
    rows = np.flatnonzero(np.any(K != 0.0, axis=1))
    K = K[rows]
    if np.linalg.matrix_rank(K) < len(rows):  # pragma: no cover - the rules keep them apart
        raise InputError("the remaining base parameters are dependent; use method='numerical'")
    chi_true = None
    if robot is not None:
        from stewart_pin.dynamics.regressor import standard_parameters

        chi_true = standard_parameters(robot.description)
    values = K @ chi_true if chi_true is not None else base.values[rows]
    return replace(
        base,
        names=tuple(base.names[k] for k in rows),
        K=K,
        kept=np.asarray(base.kept)[rows],
        values=values,
    )


def _term_kind(name: str) -> str:
    """``"K"`` of ``"K2_4"``, ``"IA"`` of ``"IA1R_3"``, ``""`` for an inertial name."""
    for kind in ("IA", "FV", "FC", "OF", "K"):
        rest = name[len(kind) :]
        if name.startswith(kind) and rest[:1].isdigit():
            return kind
    return ""


def _stacked(
    base: BaseParameters, robot: RobotLike, poses: Any, twists: Any, accels: Any
) -> np.ndarray:
    """The base regressor stacked over the samples: (6 N, nb), rows sample-major."""
    W = base.reduce(robot.regressor(poses, twists, accels))
    return W.reshape(-1, W.shape[-1])


def _svd(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Thin SVD ``A = U diag(s) Vt`` of a tall matrix through its QR factorisation (the SVD
    of the small square R), which multithreaded LAPACK runs much faster on tall matrices."""
    Q, R = np.linalg.qr(A)
    Ur, s, Vt = np.linalg.svd(R)
    return Q @ Ur, s, Vt


def _scaled_singular_values(W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values of ``W`` (rows >= columns) with unit-norm columns, and the norms."""
    norms = np.linalg.norm(W, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    if W.shape[0] < W.shape[1]:
        return np.linalg.svd(W / scale, compute_uv=False), norms
    R = np.linalg.qr(W / scale, mode="r")
    return np.linalg.svd(R, compute_uv=False), norms


def regressor_condition_number(W: np.ndarray) -> float:
    """The condition number of a stacked regressor (rows, nb) with unit-norm columns
    (``inf`` when a column is zero or the matrix is rank deficient)."""
    s, norms = _scaled_singular_values(np.asarray(W, dtype=float))
    if np.any(norms == 0) or s[-1] <= 0 or W.shape[0] < W.shape[1]:
        return math.inf
    return float(s[0] / s[-1])


@dataclass(frozen=True)
class ActuatorLimits:
    """Bounds on the six actuated joints an exciting trajectory must respect (each (6,)
    or ``None`` for none): ``effort`` [N or N m, joint side], ``velocity`` [m/s or
    rad/s], ``acceleration`` [m/s^2 or rad/s^2]."""

    effort: np.ndarray | None = None
    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None

    @classmethod
    def of(cls, robot: RobotLike) -> ActuatorLimits:
        """The limits of the robot's description (``effort_limits``, ...)."""
        d = robot.description
        return cls(d.effort_limits, d.velocity_limits, d.acceleration_limits)

    @property
    def any(self) -> bool:
        return any(x is not None for x in (self.effort, self.velocity, self.acceleration))


class _Workspace:
    """How far a Fourier trajectory leaves the allowed workspace (0 when inside): every
    joint of every leg a ``margin`` (fraction of its range) inside its limits, cond(Jp^-1)
    below ``max_condition``, and the actuated joints' efforts, velocities and
    accelerations within ``1 - margin`` of their limits."""

    def __init__(
        self,
        robot: RobotLike,
        times: np.ndarray,
        max_condition: float,
        margin: float,
        limits: ActuatorLimits,
    ):
        desc = robot.description
        legs = desc.leg_architectures
        self.robot, self.times, self.max_condition = robot, times, max_condition
        self.margin, self.limits = margin, limits
        lower = np.array([[j.lower for j in leg.joints] for leg in legs])
        upper = np.array([[j.upper for j in leg.joints] for leg in legs])
        self.revolute = np.array([[j.revolute for j in leg.joints] for leg in legs])
        self.lower, self.upper = lower, upper
        finite = np.isfinite(lower) & np.isfinite(upper)
        width = np.where(finite, upper - lower, 1.0)
        unit = np.where(self.revolute, 1.0, float(desc.stroke_mid))
        pad = np.where(finite, margin * width, margin * unit)
        with np.errstate(invalid="ignore"):
            self.lo, self.hi = lower + pad, upper - pad
        self.scale = np.where(finite, width, unit)
        self.actuated = np.array([leg.actuated - 1 for leg in legs])

    def violation(self, traj: FourierTrajectory) -> float:
        s = traj.sample(self.times)
        robot = self.robot
        try:
            q = robot.inverse_geometry(s.poses, check_limits=False)
        except StewartPinError:
            return math.inf
        q = wrap_into_limits(q, self.revolute, self.lower, self.upper)
        with np.errstate(invalid="ignore"):
            out = np.maximum(0.0, self.lo - q) + np.maximum(0.0, q - self.hi)
        v = float(np.sum(np.where(np.isfinite(out), out, 0.0) / self.scale))
        try:  # a leg at a serial singularity on the way: outside
            cond = np.asarray(robot.condition_number(s.poses), dtype=float)
        except StewartPinError:
            return math.inf
        v += float(np.sum(np.maximum(0.0, cond - self.max_condition)) / self.max_condition)
        if v == 0.0 and self.limits.any:
            v = self._actuator_violation(s)
        return v if math.isfinite(v) else math.inf

    def _actuator_violation(self, s: Trajectory) -> float:
        robot, lim, keep = self.robot, self.limits, 1.0 - self.margin
        legs = np.arange(6)
        v = 0.0
        try:
            if lim.velocity is not None:
                qd = np.einsum("nij,nj->ni", robot.inverse_jacobian(s.poses), s.twists)
                v += float(np.sum(np.maximum(0.0, np.abs(qd) / (keep * lim.velocity) - 1.0)))
            if lim.acceleration is not None:
                _, _, qdd = robot.leg_kinematics(s.poses, s.twists, s.accels)
                assert qdd is not None
                qdd_a = qdd[:, legs, self.actuated]
                v += float(
                    np.sum(np.maximum(0.0, np.abs(qdd_a) / (keep * lim.acceleration) - 1.0))
                )
            if lim.effort is not None:
                gamma = robot.inverse_dynamics(s.poses, s.twists, s.accels)
                v += float(np.sum(np.maximum(0.0, np.abs(gamma) / (keep * lim.effort) - 1.0)))
        except StewartPinError:
            return math.inf
        return v


def actuator_peaks(robot: RobotLike, trajectory: Trajectory) -> dict[str, np.ndarray]:
    """The largest ``|effort|``, ``|velocity|`` and ``|acceleration|`` of each actuated
    joint along ``trajectory`` (6,) each [N or N m, m/s or rad/s, m/s^2 or rad/s^2], with
    the robot's own parameters: what to compare with the actuators' limits."""
    legs = robot.description.leg_architectures
    actuated = np.array([leg.actuated - 1 for leg in legs])
    qd = np.einsum("nij,nj->ni", robot.inverse_jacobian(trajectory.poses), trajectory.twists)
    _, _, qdd = robot.leg_kinematics(trajectory.poses, trajectory.twists, trajectory.accels)
    assert qdd is not None
    gamma = robot.inverse_dynamics(trajectory.poses, trajectory.twists, trajectory.accels)
    return {
        "effort": np.abs(gamma).max(axis=0),
        "velocity": np.abs(qd).max(axis=0),
        "acceleration": np.abs(qdd[:, np.arange(6), actuated]).max(axis=0),
    }


def exciting_trajectory(
    robot: RobotLike,
    duration: float | None = None,
    n_harmonics: int = 5,
    base_frequency: float = 0.2,
    seed: int | None = 0,
    n_samples: int = 200,
    optimise: bool = True,
    *,
    base: BaseParameters | None = None,
    max_condition: float | None = None,
    margin: float = 0.05,
    n_candidates: int = 8,
    max_evaluations: int = 300,
    n_grid: int = 30,
    limits: ActuatorLimits | None = None,
) -> tuple[Trajectory, float]:
    """An exciting trajectory for identification, and its condition number.

    The platform follows a :class:`~stewart_pin.motion.trajectories.FourierTrajectory` about the
    home pose (three translations of O_p along F0's axes, a rotation vector in F0, each a
    Fourier series of ``n_harmonics`` harmonics of ``base_frequency``). Random coefficients
    (amplitudes decreasing as ``1/l`` with the harmonic l) are shrunk onto the workspace
    boundary; the best of ``n_candidates`` draws is then refined by Powell's method on
    ``log cond(W_b)`` (``W_b`` stacked on ``n_grid`` samples of one period, columns scaled
    to unit norm; for general legs it holds the joint terms' columns too), with a penalty
    outside what the robot can run: every one of 300 samples of a period keeps every
    joint of every leg ``margin`` (a fraction of its range; of the mid-stroke for a
    one-sided limit) inside its limits (the stroke, the U-joint limits, a general leg's
    joint limits), cond(Jp^-1) below ``max_condition``, and the actuated joints' efforts
    (inverse dynamics with the robot's own parameters), velocities and accelerations
    below ``1 - margin`` times their limits (``limits``, default the description's
    ``effort_limits``, ``velocity_limits``, ``acceleration_limits``; none when absent).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot`.
        duration: length of the returned samples [s] (default one period, ``1 /
            base_frequency``).
        n_harmonics: harmonics per axis.
        base_frequency: [Hz]; frequencies ``l * base_frequency``, l = 1..n_harmonics.
        seed: seeds the random draws.
        n_samples: samples returned, evenly spaced in ``[0, duration)``.
        optimise: ``False`` returns the first random draw, shrunk into the workspace.
        base: the base parameters to excite (default the analytic set: 88 for a general
            6-UPS robot; joint terms included for general legs).
        max_condition: bound on cond(Jp^-1) (default twice its value at the home pose).
        margin: joint-limit margin, a fraction of each joint's range, kept at both ends;
            the actuator limits are kept to ``1 - margin`` of their values.
        limits: the actuators' limits (default :meth:`ActuatorLimits.of` the robot).
        n_candidates, max_evaluations, n_grid: the optimiser's effort: random draws,
            then at most ``max_evaluations`` cost evaluations of Powell's method, each on
            ``n_grid`` samples (about 10 ms each; the default takes a few seconds).

    Returns:
        ``(trajectory, condition_number)``: the samples (``trajectory.fourier`` holds the
        coefficients, to resample at a controller's rate) and the condition number of the
        stacked base regressor on them.
    """
    base = _base_of(robot, base)
    f = float(base_frequency)
    if not (np.isfinite(f) and f > 0):
        raise InputError(f"base_frequency must be a positive number of Hz, got {base_frequency}")
    period = 1.0 / f
    duration = period if duration is None else float(duration)
    if not (np.isfinite(duration) and duration > 0):
        raise InputError(f"duration must be a positive number of seconds, got {duration}")
    if int(n_harmonics) < 1 or int(n_samples) < 1:
        raise InputError(
            f"n_harmonics and n_samples must be >= 1, got {n_harmonics} and {n_samples}"
        )
    n_harmonics, n_samples = int(n_harmonics), int(n_samples)
    home = robot.home_pose
    if max_condition is None:
        max_condition = 2.0 * float(robot.condition_number(home))
    span = min(period, duration)
    limits = ActuatorLimits.of(robot) if limits is None else limits
    workspace = _Workspace(
        robot, np.linspace(0.0, span, 300, endpoint=False), float(max_condition), margin, limits
    )
    grid = np.linspace(0.0, span, max(int(n_grid), 1), endpoint=False)
    rng = np.random.default_rng(seed)

    def make(x: np.ndarray) -> FourierTrajectory:
        return FourierTrajectory.from_vector(home, f, x)

    def cost(x: np.ndarray) -> float:
        traj = make(x)
        v = workspace.violation(traj)
        if v > 0:
            return 1e3 + min(v, 1e6)
        s = traj.sample(grid)
        try:
            W = _stacked(base, robot, s.poses, s.twists, s.accels)
        except StewartPinError:
            return 1e3
        return math.log(regressor_condition_number(W))

    desc = robot.description
    if desc.stroke is not None:
        half = 0.5 * float(desc.stroke[1] - desc.stroke[0])  # [m]
    else:  # general legs: a quarter of the mean |B_i P_i| at home
        P = home[:3, :3] @ desc.platform_points.T + home[:3, 3:]
        half = 0.25 * float(np.mean(np.linalg.norm(P.T - desc.base_points, axis=1)))
    amplitude = np.array([half] * 3 + [min(0.5, half / desc.size)] * 3)  # [m, rad]
    harmonic = 1.0 / np.arange(1, n_harmonics + 1)

    def draw() -> np.ndarray:
        sine, cosine = (
            rng.normal(size=(6, n_harmonics)) * amplitude[:, None] * harmonic / n_harmonics
            for _ in range(2)
        )
        x = FourierTrajectory(home, f, np.zeros(6), sine, cosine).to_vector()
        if workspace.violation(make(x)) == 0:
            return x
        lo, hi = 0.0, 1.0  # the zero motion (home pose) is inside
        for _ in range(20):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if workspace.violation(make(mid * x)) == 0 else (lo, mid)
        return 0.95 * lo * x

    if workspace.violation(make(np.zeros(6 + 12 * n_harmonics))) > 0:
        raise WorkspaceError(
            "the home pose itself violates the workspace constraints (joint-limit margin "
            f"{margin:g}, cond(Jp^-1) <= {max_condition:g}, or an actuator limit at rest); "
            "lower margin, raise max_condition or check the actuator limits"
        )
    if optimise:
        candidates = [draw() for _ in range(max(int(n_candidates), 1))]
        costs = [cost(x) for x in candidates]
        x = candidates[int(np.argmin(costs))]
        if max_evaluations > 0:
            res = scipy.optimize.minimize(
                cost,
                x,
                method="Powell",
                options={"maxfev": int(max_evaluations), "xtol": 1e-3, "ftol": 1e-4},
            )
            if res.fun <= min(costs) and workspace.violation(make(res.x)) == 0:
                x = res.x
    else:
        x = draw()
    times = np.linspace(0.0, duration, n_samples, endpoint=False)
    traj = make(x).sample(times)
    robot.inverse_geometry(traj.poses)  # the samples themselves: raise if outside
    cond = regressor_condition_number(_stacked(base, robot, traj.poses, traj.twists, traj.accels))
    return traj, cond


# ====================================================================== measurements

#: Columns of a measurement CSV file, in the order :func:`write_measurements_csv` writes.
CSV_COLUMNS: tuple[str, ...] = STATE_COLUMNS + FORCE_COLUMNS
#: Samples whose regressor :func:`identify` builds at once (bounded memory).
IDENTIFY_CHUNK = 2000


@dataclass(frozen=True, eq=False)
class Measurements:
    """Logged (or simulated) samples: platform states and actuator forces.

    Attributes:
        times: shape (N,), strictly increasing [s].
        poses: 0Tp, shape (N, 4, 4) [m].
        twists: ``[v, w]`` of O_p in F0, shape (N, 6) [m/s, rad/s].
        accels: classical ``[dv/dt, dw/dt]`` in F0, shape (N, 6) [m/s^2, rad/s^2].
        gammas: actuator forces, shape (N, 6) [N], positive extending the leg.
    """

    times: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray

    def __post_init__(self) -> None:
        traj = Trajectory(self.times, self.poses, self.twists, self.accels)  # validates
        values = {
            "times": traj.times,
            "poses": traj.poses,
            "twists": traj.twists,
            "accels": traj.accels,
            "gammas": check_array(self.gammas, (len(traj), 6), "gammas"),
        }
        freeze_fields(self, values)

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def trajectory(self) -> Trajectory:
        """The states without the forces."""
        return Trajectory(self.times, self.poses, self.twists, self.accels)


def simulate_measurements(
    robot: RobotLike,
    trajectory: Trajectory,
    noise_std: float | Any = 0.0,
    seed: int | None = None,
) -> Measurements:
    """Measurements of ``trajectory`` by the inverse dynamic model, plus Gaussian noise.

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` (its description holds the true
            parameters).
        trajectory: the states.
        noise_std: standard deviation of the force noise [N], one value or one per
            actuator (6,); zero-mean, independent across samples and actuators.
        seed: seeds the noise.
    """
    std = np.broadcast_to(check_array(np.atleast_1d(noise_std), (None,), "noise_std"), (6,))
    if np.any(std < 0):
        raise InputError(f"noise_std must be >= 0 [N], got {noise_std}")
    gammas = robot.inverse_dynamics(trajectory.poses, trajectory.twists, trajectory.accels)
    rng = np.random.default_rng(seed)
    gammas = gammas + rng.normal(size=gammas.shape) * std
    return Measurements(
        trajectory.times, trajectory.poses, trajectory.twists, trajectory.accels, gammas
    )


def write_measurements_csv(path: str | Path, measurements: Measurements) -> Path:
    """Write measurements as CSV (header :data:`CSV_COLUMNS`, SI units, ``repr`` floats so
    that reading them back gives the same numbers; format in ``docs/identification.md``)."""
    m = measurements
    table = np.column_stack([state_table(m.times, m.poses, m.twists, m.accels), m.gammas])
    return write_csv(path, CSV_COLUMNS, table)


def read_measurements_csv(path: str | Path, min_rows: int = 1) -> Measurements:
    """Read a measurement CSV file (format in ``docs/identification.md``).

    Columns may come in any order; blank lines and lines starting with ``#`` are skipped.
    Quaternions within :data:`~stewart_pin.formats.csv_tables.QUATERNION_TOLERANCE` of unit norm
    are
    renormalised.

    Raises:
        FileFormatError: a missing, unknown or repeated column, a row with the wrong number
            of fields, a non-numeric or non-finite value, a value beyond
            :data:`~stewart_pin.formats.csv_tables.MAX_MAGNITUDE` (1e9, SI units), a
            non-unit quaternion, a time
            that does not increase, or fewer than ``min_rows`` rows; the message names the
            line.
        OSError: the file cannot be read.
    """
    rows = read_csv(path, CSV_COLUMNS, min_rows, max_magnitude=MAX_MAGNITUDE)
    try:
        return Measurements(*states_from_table(rows), rows[:, FORCE_SLICE])
    except InputError as e:  # pragma: no cover - read_csv's checks cover the format
        raise FileFormatError(f"{path}: {e}") from e


# ====================================================================== estimation

#: Default threshold of :meth:`IdentificationResult.poorly_identified`: a base parameter
#: whose standard deviation exceeds this percentage of its estimate's magnitude [%] is not
#: determined by the data (a common rule of thumb: well identified parameters have
#: relative standard deviations of a few percent; above 10-20 %, values of the same order
#: fit the forces as well, within the noise).
MAX_RELATIVE_STD = 20.0

#: What to do about poorly identified parameters, printed under a report that has some.
POOR_IDENTIFICATION_ADVICE = (
    "These estimates are not to be trusted: the measurements do not determine them. "
    "Record a longer or richer excitation (an optimised exciting trajectory: more "
    "harmonics, larger amplitudes, more periods or samples; a longer log), or fit "
    "physically consistent parameters (identify --log FILE --physical; "
    "stewart_pin.parameters.physical.physically_consistent), which keeps every body's "
    "mass and inertia physical. A parameter with a large relative std may also just "
    "barely act on the forces (near zero, or a weak effect): the essential parameters "
    "(stewart-pin base-params) leave such ones out."
)


@dataclass(frozen=True)
class ParameterFlag:
    """A base parameter that an identification did not determine
    (:meth:`IdentificationResult.poorly_identified`).

    Attributes:
        name: the base parameter.
        index: its index in the base set.
        estimate: its estimate [SI].
        std: its standard deviation [SI].
        relative_std: ``100 std / |estimate|`` [%].
        uncertain: the relative std is over the threshold.
        impossible: the estimate is negative although the parameter is >= 0 on every
            physical robot (:attr:`~stewart_pin.parameters.base.BaseParameters.nonnegative`).
        relation: its grouping of standard parameters (``"ZZ1_1 + YY2_1 + ZZ3_1"``).
    """

    name: str
    index: int
    estimate: float
    std: float
    relative_std: float
    uncertain: bool
    impossible: bool
    relation: str

    def __str__(self) -> str:
        why = []
        if self.impossible:
            why.append(
                f"physically impossible: {self.name} = {self.relation} is >= 0 on every "
                "physical robot"
            )
        if self.uncertain:
            why.append(f"relative std {self.relative_std:.3g} %")
        return f"{self.name} = {self.estimate:.6g} +- {self.std:.3g}: " + "; ".join(why)


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """Estimated base parameters with their uncertainty.

    Attributes:
        names: the base parameters' names (nb,).
        estimate: the (weighted) least-squares estimate (nb,), SI units.
        std: standard deviations of the estimate (nb,): the square roots of the diagonal of
            ``sigma^2 (W^T W)^-1`` in the (weighted) problem.
        covariance: (nb, nb) covariance of the estimate.
        ols_estimate: the ordinary least-squares estimate (nb,).
        sigma: per-actuator noise standard deviation estimated from the residuals of the
            final fit (6,) [N]: ``sigma_j^2 = |r_j|^2 / (N - h_j)`` with ``h_j`` the
            leverage (hat-matrix trace) of actuator j's equations.
        iterations: reweighting iterations of the weighted least squares (0 for OLS).
        residual_rms: per-actuator RMS residual of the final estimate (6,) [N].
        condition_number: of the stacked base regressor, columns scaled to unit norm.
        rank: its numerical rank (== nb).
        n_samples: samples used (6 equations each).
        weighted: whether the estimate is the weighted one.
        base: the :class:`~stewart_pin.parameters.base.BaseParameters` identified.
        solution: the least-squares solution it was made from (its weighted fit factor
            gives the weighted residual of any parameter vector:
            :meth:`~stewart_pin.parameters.least_squares.LeastSquaresSolution.weighted_residual`).
    """

    names: tuple[str, ...]
    estimate: np.ndarray
    std: np.ndarray
    covariance: np.ndarray
    ols_estimate: np.ndarray
    sigma: np.ndarray
    iterations: int
    residual_rms: np.ndarray
    condition_number: float
    rank: int
    n_samples: int
    weighted: bool
    base: BaseParameters = field(repr=False)
    solution: LeastSquaresSolution | None = field(default=None, repr=False)

    @property
    def relative_std(self) -> np.ndarray:
        """``100 std / |estimate|`` [%] (nb,) (``inf`` for a zero estimate)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.estimate != 0, 100.0 * self.std / np.abs(self.estimate), np.inf)

    def poorly_identified(
        self, max_relative_std: float = MAX_RELATIVE_STD
    ) -> tuple[ParameterFlag, ...]:
        """The base parameters the data did not determine, in the base set's order: those
        whose relative standard deviation :attr:`relative_std` exceeds
        ``max_relative_std`` [%], and those whose estimate is physically impossible (a
        negative value of a parameter that is >= 0 on every physical robot: a mass, a
        diagonal inertia, or a sum of them with positive coefficients such as ``ZZ1R``;
        :attr:`~stewart_pin.parameters.base.BaseParameters.nonnegative`). Parameters that
        may take either sign are flagged only by their relative std.

        Raises:
            InputError: ``max_relative_std`` not a positive number.
        """
        threshold = check_scalar(max_relative_std, "max_relative_std", positive=True, unit="%")
        rel = self.relative_std
        uncertain = rel > threshold
        impossible = self.base.nonnegative & (self.estimate < 0)
        return tuple(
            ParameterFlag(
                name=self.names[k],
                index=int(k),
                estimate=float(self.estimate[k]),
                std=float(self.std[k]),
                relative_std=float(rel[k]),
                uncertain=bool(uncertain[k]),
                impossible=bool(impossible[k]),
                relation=self.base.relation(int(k)),
            )
            for k in np.flatnonzero(uncertain | impossible)
        )

    def confidence_interval(self, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` (nb,) each: the two-sided interval ``estimate +- z std`` with
        ``z`` the normal quantile of ``level`` (Gaussian noise, the estimated covariance)."""
        if not 0.0 < level < 1.0:
            raise InputError(f"level must be in (0, 1), got {level}")
        import scipy.stats

        z = float(scipy.stats.norm.ppf(0.5 + level / 2))
        return self.estimate - z * self.std, self.estimate + z * self.std

    def relative_errors(self, true_values: Any, atol: float | None = None) -> np.ndarray:
        """``(estimate - true) / |true|`` (nb,), a fraction.

        Where ``|true| <= atol`` (default ``1e-9`` times the largest ``|true|``) the error
        is relative to the largest ``|true|`` instead, so that zero parameters (symmetric
        robots) give finite numbers.
        """
        true = check_array(true_values, (len(self.names),), "true_values")
        big = float(np.abs(true).max(initial=0.0))
        atol = 1e-9 * big if atol is None else float(atol)
        denom = np.where(np.abs(true) > atol, np.abs(true), big if big > 0 else 1.0)
        return (self.estimate - true) / denom

    def predict(self, poses: Any, twists: Any, accels: Any, idle: Any = None) -> np.ndarray:
        """Actuator forces ``W_b chi_b`` from the estimate [N]: (6,) or (N, 6) (``idle``:
        a robot with idle freedoms, :func:`identify`)."""
        return self.base.regressor(poses, twists, accels, idle) @ self.estimate

    def report(
        self,
        true_values: Any | None = None,
        label: str = "true",
        max_relative_std: float = MAX_RELATIVE_STD,
    ) -> str:
        """A readable table: estimate, std, relative std [%], with ``true_values`` (nb,)
        the ``label`` values and the relative errors [%], and a flag column: ``?`` for a
        relative std over ``max_relative_std`` [%], ``!`` for a physically impossible
        value (:meth:`poorly_identified`), the flagged parameters listed under the table
        with what to do about them."""
        flags = {f.index: f for f in self.poorly_identified(max_relative_std)}
        what = "weighted least squares" if self.weighted else "ordinary least squares"
        unit = "N" if self.base.robot is None else self.base.robot.description.effort_unit
        lines = [
            f"{len(self.names)} base parameters by {what} from {self.n_samples} samples "
            f"({6 * self.n_samples} equations)",
            f"condition number of the scaled base regressor: {self.condition_number:.4g}",
            f"per-actuator noise std (from the residuals) [{unit}]: "
            + " ".join(f"{s:.4g}" for s in self.sigma),
            f"per-actuator residual RMS (final) [{unit}]: "
            + " ".join(f"{s:.4g}" for s in self.residual_rms),
            "",
        ]
        head = f"{'parameter':>12s} {'estimate':>14s} {'std':>11s} {'std %':>9s} flag"
        true = None
        if true_values is not None:
            true = check_array(true_values, (len(self.names),), "true_values")
            errors = 100.0 * self.relative_errors(true)
            head += f" {label:>14s} {'error %':>10s}"
        lines.append(head)
        for k, name in enumerate(self.names):
            flag = flags.get(k)
            mark = (
                ""
                if flag is None
                else ("!" if flag.impossible else "") + ("?" if flag.uncertain else "")
            )
            row = (
                f"{name:>12s} {self.estimate[k]:14.6g} {self.std[k]:11.3g} "
                f"{self.relative_std[k]:9.3g} {mark:>4s}"
            )
            if true is not None:
                row += f" {true[k]:14.6g} {errors[k]:10.3g}"
            lines.append(row)
        if true is not None:
            lines.append(
                "(error % is relative to |true|, or to the largest |true| where true is ~0)"
            )
        lines += self._flag_lines(tuple(flags.values()), max_relative_std)
        return "\n".join(lines)

    def _flag_lines(self, flags: tuple[ParameterFlag, ...], threshold: float) -> list[str]:
        """The report's paragraph on the flagged parameters (none when all are fine)."""
        if not flags:
            return [
                f"every base parameter is well identified (relative std <= {threshold:g} %, "
                "no physically impossible value)"
            ]
        n_unc = sum(f.uncertain for f in flags)
        n_imp = sum(f.impossible for f in flags)
        lines = [
            "",
            f"POORLY IDENTIFIED: {len(flags)} of {len(self.names)} base parameters "
            f"({n_unc} with a relative std over {threshold:g} % (?), {n_imp} physically "
            f"impossible (!); condition number {self.condition_number:.3g}):",
        ]
        lines += [f"  {f}" for f in flags if f.impossible]
        uncertain = [f.name for f in flags if f.uncertain and not f.impossible]
        wrap = textwrap.TextWrapper(width=88, initial_indent="  ", subsequent_indent="    ")
        if uncertain:
            lines += wrap.wrap("relative std over the threshold: " + ", ".join(uncertain))
        wrap.subsequent_indent = "  "
        return lines + wrap.wrap(POOR_IDENTIFICATION_ADVICE)


def _idle_rows(idle: Any, n: int, sl: slice) -> Any:
    """The samples ``sl`` of an idle state ``(values, rates, accelerations)``, each
    (n, 6) (:class:`InputError` otherwise, naming it); ``None`` stays ``None``."""
    if idle is None:
        return None
    try:
        parts = tuple(idle)
    except TypeError as e:
        raise InputError("idle must be (values, rates, accelerations), each (N, 6)") from e
    if len(parts) != 3:
        raise InputError(
            f"idle must be (values, rates, accelerations), each (N, 6); got {len(parts)} items"
        )
    names = ("idle values", "idle rates", "idle accelerations")
    return tuple(check_array(x, (n, 6), name)[sl] for x, name in zip(parts, names, strict=True))


def identify(
    robot: RobotLike,
    measurements: Measurements,
    base: BaseParameters | None = None,
    weighted: bool = True,
    idle: Any = None,
) -> IdentificationResult:
    """Estimate the base parameters from measurements.

    Stacks ``Gamma = W_b chi_b`` over the N samples (6 equations each) and solves by
    ordinary least squares. With ``weighted``, Gautier's weighted least squares: the
    residuals give each actuator's noise ``sigma_j^2 = |r_j|^2 / (N - h_j)`` (``h_j`` the
    leverage of its N equations, about nb/6), the equations of actuator j are divided by
    ``sigma_j`` and the system is solved again; the ``sigma_j`` are then re-estimated
    from the weighted fit's residuals and the solve repeated until they settle (to
    :data:`REWEIGHTING_TOLERANCE`, at most :data:`REWEIGHTING_ITERATIONS` times): with
    equal noise on the actuators one pass suffices, with very unequal noise the OLS
    residuals of a noisy actuator leak into the others' and the iteration removes that.
    The covariance is ``sigma^2 (W^T W)^-1`` of the final (weighted) problem with
    ``sigma^2 = |r|^2 / (6 N - nb)``. The equations are accumulated :data:`IDENTIFY_CHUNK`
    samples at a time in per-actuator R factors (an incremental QR,
    :class:`~stewart_pin.parameters.least_squares.StackedLeastSquares`: memory bounded
    whatever N), and solved by the SVD of the column-scaled factor.

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` (its geometry; the inertial
            parameters it holds play no part).
        measurements: the samples.
        base: the base parameters to identify (default the analytic 88 of ``robot``).
        weighted: weighted (default) or ordinary least squares.
        idle: a robot with idle freedoms (chain legs with ``idle_joint``, an R-S-S rod's
            spin): the idle joints' ``(values, rates, accelerations)`` of every sample,
            each (N, 6) [rad or m, /s, /s^2] (measured, or a simulation's:
            :func:`~stewart_pin.motion.idle_simulation.simulate_idle`); with them given
            the efforts are linear in the parameters
            (:meth:`~stewart_pin.StewartRobot.regressor`). Required there, refused
            elsewhere (:class:`~stewart_pin.exceptions.InputError`). The spin joints' own
            equations (``null^T H_i = 0``, no measured effort) are not stacked.

    Raises:
        IdentificationError: fewer than ``nb + 1`` equations, or a stacked base regressor
            of rank below nb (the trajectory does not excite every base parameter).
        InputError: ``idle`` missing, given to a robot without idle joints, or not three
            (N, 6) arrays.
    """
    base = _base_of(robot, base)
    m = measurements
    acc = StackedLeastSquares(len(base), base.names)
    for k in range(0, len(m), IDENTIFY_CHUNK):
        sl = slice(k, k + IDENTIFY_CHUNK)
        W = base.regressor(m.poses[sl], m.twists[sl], m.accels[sl], _idle_rows(idle, len(m), sl))
        acc.add(W, m.gammas[sl])
    return _result(acc.solve(weighted=bool(weighted)), base, bool(weighted))


def _result(
    sol: LeastSquaresSolution, base: BaseParameters, weighted: bool
) -> IdentificationResult:
    """The :class:`IdentificationResult` of a solved :class:`StackedLeastSquares`."""
    return IdentificationResult(
        names=base.names,
        estimate=sol.estimate,
        std=np.sqrt(np.diag(sol.covariance)),
        covariance=sol.covariance,
        ols_estimate=sol.ols_estimate,
        sigma=sol.sigma,
        iterations=sol.iterations,
        residual_rms=sol.residual_rms,
        condition_number=sol.condition_number,
        rank=sol.rank,
        n_samples=sol.n_samples,
        weighted=weighted,
        base=base,
        solution=sol,
    )


def validation_error(
    result: IdentificationResult, robot: RobotLike, measurements: Measurements, idle: Any = None
) -> float:
    """The relative RMS force prediction error on ``measurements`` (another trajectory):
    ``|Gamma_measured - Gamma_predicted| / |Gamma_measured|`` over all samples and
    actuators (Frobenius norms), a fraction (``idle``: a robot with idle freedoms, the
    samples' idle state as in :func:`identify`)."""
    m = measurements
    W = robot.regressor(m.poses, m.twists, m.accels, idle=_idle_rows(idle, len(m), slice(None)))
    predicted = result.base.reduce(W) @ result.estimate
    denom = float(np.linalg.norm(m.gammas))
    if denom == 0:
        raise InputError("the measured forces are all zero: the relative error is undefined")
    return float(np.linalg.norm(m.gammas - predicted) / denom)


# ====================================================================== from actuator logs

#: Raw samples whose regressor :func:`identify_log` builds at once (with the FIR windows'
#: overlap): bounded memory whatever the log's length.
LOG_CHUNK = 2000

Progress = Callable[[int, int], None]


def log_equations(
    robot: RobotLike,
    log: ActuatorLog,
    base: BaseParameters,
    design: FilterDesign,
    progress: Progress | None = None,
    chunk: int = LOG_CHUNK,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The parallel-decimated equations ``F Gamma = (F W_b) chi_b`` of a log, in chunks.

    Yields ``(centres, W, gamma, poses)``: the log samples the decimated equations are
    centred on (m,), the filtered and decimated base regressor (m, 6, nb), the filtered
    and decimated efforts (m, 6), and the estimated poses at the centres (m, 4, 4)
    (:mod:`stewart_pin.parameters.state_estimation`, steps 1-5: the efforts and the
    actuated joints' Coulomb columns through the state filter, then both sides through
    the decimation filter). ``progress(done,
    total)`` is called after each chunk with the decimated samples done and in all.
    The regressor is built ``chunk`` raw samples at a time, each sample once, and the
    FIR filter accumulated as the samples arrive
    (:class:`~stewart_pin.parameters.state_estimation.PolyphaseDecimator`): the working
    memory is one chunk's regressor whatever the decimation.
    """
    stream = StateStream(robot, log, design)
    centres = stream.centres
    total = len(centres)
    if total == 0:
        raise LogError(
            f"{log.source}: {len(log)} samples leave no decimated equation (the filters drop "
            f"{design.edge + design.half} samples at each end); record a longer log",
        )
    coulomb = _actuated_coulomb(robot, base)
    fir = PolyphaseDecimator(design.taps, centres)
    poses_at = np.empty((total, 4, 4))
    first, stop = int(centres[0]) - design.half, int(centres[-1]) + design.half + 1
    for a, poses, V, A, efforts, signs in stream.batches(first, stop, chunk):
        W = base.regressor(poses, V, A)
        for column, leg in coulomb:  # the filtered signs of the raw velocities
            W[:, :, column] = 0.0
            W[:, leg, column] = signs[:, leg]
        inside = (centres >= a) & (centres < a + len(poses))
        poses_at[inside] = poses[centres[inside] - a]
        idx, (Wd, gd) = fir.push(a, W, efforts)
        if len(idx):
            yield centres[idx], Wd, gd, poses_at[idx]
            if progress is not None:
                progress(int(idx[-1]) + 1, total)


def _actuated_coulomb(robot: RobotLike, base: BaseParameters) -> list[tuple[int, int]]:
    """``(base column, leg)`` of every base parameter that is an actuated joint's Coulomb
    friction alone (``K`` row with the single entry 1 at its FC): its column is
    ``sign(qdot_a)`` on that actuator's row (none on the ideal 6-UPS: no joint terms)."""
    from stewart_pin.dynamics.regressor import parameter_groups

    K = np.asarray(base.K)
    out: list[tuple[int, int]] = []
    for jp in parameter_groups(robot.description).joints:
        if not jp.actuated:
            continue
        for row in np.flatnonzero(K[:, jp.coulomb]):
            if np.count_nonzero(K[row]) == 1 and K[row, jp.coulomb] == 1.0:
                out.append((int(row), jp.leg - 1))
    return out


@dataclass(frozen=True, eq=False)
class LogIdentification:
    """Base parameters identified from an actuator log.

    Attributes:
        result: the :class:`IdentificationResult` of the decimated equations (its
            ``n_samples`` counts decimated samples, 6 equations each; its covariance
            includes the noise correlation factor ``design.kappa``).
        design: the filters used (:class:`~stewart_pin.parameters.state_estimation.FilterDesign`).
        n_log: samples in the log.
        tracker_error: RMS distance between the forward-geometry poses and the tracker's
            at the equations' samples, ``(position [m], angle [rad])``, or ``None``
            without a tracker.
        source: the log's source.
    """

    result: IdentificationResult
    design: FilterDesign
    n_log: int
    tracker_error: tuple[float, float] | None
    source: str

    def report(
        self,
        true_values: Any | None = None,
        label: str = "true",
        max_relative_std: float = MAX_RELATIVE_STD,
    ) -> str:
        """The filters, the tracker's agreement and the result's table, its poorly
        identified parameters flagged (:meth:`IdentificationResult.report`)."""
        lines = [
            f"log {self.source}: {self.n_log} samples -> {self.result.n_samples} decimated "
            f"samples ({6 * self.result.n_samples} equations)",
            "filters: " + self.design.describe(),
        ]
        if self.tracker_error is not None:
            lines.append(
                f"forward geometry vs tracker (RMS): {self.tracker_error[0]:.3g} m, "
                f"{self.tracker_error[1]:.3g} rad"
            )
        table = self.result.report(true_values, label, max_relative_std)
        return "\n".join([*lines, "", table])


def identify_log(
    robot: RobotLike,
    log: ActuatorLog,
    base: BaseParameters | None = None,
    *,
    design: FilterDesign | None = None,
    cutoff: float | None = None,
    decimation: int | None = None,
    method: str = "butterworth",
    weighted: bool = True,
    progress: Progress | None = None,
    chunk: int = LOG_CHUNK,
) -> LogIdentification:
    """Identify the base parameters from a log of actuator positions and efforts.

    The platform states come from the positions (filter, forward geometry, derivatives),
    the regressor and the efforts go through the same FIR filter and decimation (Gautier's
    parallel decimation), and the decimated equations are accumulated ``chunk`` raw
    samples at a time into the incremental QR of :class:`StackedLeastSquares`: memory does
    not grow with the log beyond the positions' three filtered copies. Then weighted least
    squares as :func:`identify`, with the covariance multiplied by the noise correlation
    factor of the decimation (see :mod:`stewart_pin.parameters.state_estimation`).

    Args:
        robot: the robot's geometry (its inertial parameters play no part).
        log: an :class:`~stewart_pin.parameters.logs.ActuatorLog` (checked:
            :func:`~stewart_pin.parameters.logs.check_log`).
        base: the base parameters (default: analytic where the architecture has them).
        design: the filters (default :func:`design_filters` with ``cutoff``,
            ``decimation``, ``method``).
        weighted: weighted (default) or ordinary least squares.
        progress: ``progress(done, total)`` after each chunk (decimated samples).
        chunk: raw samples per chunk.

    Raises:
        LogError (and subclasses): a log the checks refuse, or one too short for its filters.
        IdentificationError: too few equations, or a rank-deficient regressor.
    """
    check_log(log, robot)
    base = _base_of(robot, base)
    design = design or design_filters(log, cutoff, decimation, method)
    acc = StackedLeastSquares(len(base), base.names)
    sq_p = sq_r = 0.0
    for centres, W, gamma, poses in log_equations(robot, log, base, design, progress, chunk):
        acc.add(W, gamma)
        if log.tracker_poses is not None:
            tracked = log.tracker_poses[centres]
            sq_p += float(np.sum((poses[:, :3, 3] - tracked[:, :3, 3]) ** 2))
            rel = np.einsum("nij,nkj->nik", poses[:, :3, :3], tracked[:, :3, :3])
            cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
            sq_r += float(np.sum(np.arccos(cos) ** 2))
    sol = acc.solve(weighted=weighted, noise_correlation=design.kappa)
    n = sol.n_samples
    tracker = None if log.tracker_poses is None else (math.sqrt(sq_p / n), math.sqrt(sq_r / n))
    return LogIdentification(
        _result(sol, base, bool(weighted)), design, len(log), tracker, log.source
    )


def log_prediction_error(
    robot: RobotLike,
    log: ActuatorLog,
    values: Any,
    base: BaseParameters,
    design: FilterDesign,
) -> float:
    """The relative RMS effort prediction error of base parameter ``values`` (nb,) on a
    log: ``|F Gamma - (F W_b) values| / |F Gamma|`` over the decimated samples and the six
    actuators (Frobenius norms), with the filters ``design`` (e.g. the identification's,
    re-designed for this log's sample rate when it differs: same cut-off and decimation
    ratio). A fraction; compare it with the noise: the decimated effort noise over the
    decimated efforts."""
    check_log(log, robot)
    base = _base_of(robot, base)
    x = check_array(values, (len(base),), "values")
    if abs(design.sample_rate - log.sample_rate) > 1e-6 * design.sample_rate:
        design = design_filters(log, design.cutoff, None, design.method)
    num = den = 0.0
    for _, W, gamma, _ in log_equations(robot, log, base, design):
        r = gamma - W @ x
        num += float(np.sum(r**2))
        den += float(np.sum(gamma**2))
    if den == 0:
        raise InputError("the logged efforts are all zero: the relative error is undefined")
    return math.sqrt(num / den)


__all__ = [
    "CSV_COLUMNS",
    "MAX_RELATIVE_STD",
    "ActuatorLimits",
    "IdentificationResult",
    "LogIdentification",
    "Measurements",
    "ParameterFlag",
    "actuator_peaks",
    "base_without",
    "exciting_trajectory",
    "identify",
    "identify_log",
    "log_equations",
    "log_prediction_error",
    "read_measurements_csv",
    "regressor_condition_number",
    "simulate_measurements",
    "validation_error",
    "write_measurements_csv",
]
