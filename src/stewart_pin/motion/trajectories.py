"""Platform trajectories: sampled states, and the finite Fourier series identification uses.

A :class:`Trajectory` is a sampled platform motion: times [s], poses 0Tp (N, 4, 4), twists
``[v, w]`` of O_p in F0 (N, 6) [m/s, rad/s] and classical accelerations ``[dv/dt, dw/dt]``
in F0 (N, 6) [m/s^2, rad/s^2] — the states :meth:`StewartRobot.inverse_dynamics` takes.

A :class:`FourierTrajectory` moves the platform about a reference pose ``T_ref`` (the
robot's home pose by default) along six coordinates ``x = [d, r]``, each a finite Fourier
series of base frequency ``f`` (period ``1/f``)::

    x_k(t) = c_k + sum_{l=1..n} (a_kl sin(2 pi l f t) + b_kl cos(2 pi l f t))

    p(t) = p_ref + d(t)                 (O_p in F0: a translation along F0's axes)
    R(t) = exp3(r(t)) R_ref             (r: a rotation vector in F0)

Its derivatives are exact: ``v = d'``, ``dv/dt = d''``, and with the left Jacobian of SO(3)
``J_l(r) = I + (1 - cos t)/t^2 [r]x + (t - sin t)/t^3 [r]x^2`` (``t = |r|``), which maps the
rotation vector's rate to the angular velocity in F0 (``R' R^T = [J_l(r) r']x``)::

    w = J_l(r) r'
    dw/dt = J_l(r) r'' + (dJ_l/dt) r'
          = J_l(r) r'' + (r . r') (a'(t)/t  r x r' + b'(t)/t  r x (r x r')) + b(t) r' x (r x r')

with ``a(t) = (1 - cos t)/t^2``, ``b(t) = (t - sin t)/t^3``; near ``t = 0`` the functions
use their Taylor series, so the formulas hold at and around the reference pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np

from stewart_pin._checks import (
    check_array,
    check_increasing_times,
    check_pose,
    check_poses,
    check_scalar,
)
from stewart_pin._so3 import (
    so3_coefficients,
    so3_exp,
    so3_left_jacobian,
    so3_left_jacobian_rate,
)
from stewart_pin.exceptions import InputError, SingularityError, WorkspaceError
from stewart_pin.protocols import RobotLike


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled platform motion (arrays copied and made read-only).

    Attributes:
        times: shape (N,), strictly increasing [s].
        poses: 0Tp, shape (N, 4, 4).
        twists: ``[v, w]`` of O_p in F0, shape (N, 6) [m/s, rad/s].
        accels: classical ``[dv/dt, dw/dt]`` in F0, shape (N, 6) [m/s^2, rad/s^2].
        fourier: the :class:`FourierTrajectory` it was sampled from, if any (to resample
            it at a controller's rate: ``trajectory.fourier.sample(times)``).
    """

    times: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    fourier: FourierTrajectory | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        times = check_array(self.times, (None,), "times")
        n = times.shape[0]
        poses, _ = check_poses(np.asarray(self.poses), "poses")
        arrays = {
            "times": times,
            "poses": poses,
            "twists": check_array(self.twists, (n, 6), "twists"),
            "accels": check_array(self.accels, (n, 6), "accels"),
        }
        if poses.shape[0] != n:
            raise InputError(f"poses holds {poses.shape[0]} states but times has {n}")
        check_increasing_times(times)
        for key, value in arrays.items():
            value = np.array(value)  # a copy we own
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    def __len__(self) -> int:
        return int(self.times.shape[0])


@dataclass(frozen=True, eq=False)
class FourierTrajectory:
    """Six finite Fourier series about a reference pose (see the module docstring).

    Attributes:
        reference: ``T_ref``, the pose 0Tp the coordinates are measured from, (4, 4).
        base_frequency: ``f`` [Hz]; the motion has period ``1/f``.
        offsets: ``c``, shape (6,) [m, m, m, rad, rad, rad].
        sine: ``a``, shape (6, n) (same units), harmonic l in column l - 1.
        cosine: ``b``, shape (6, n).
    """

    reference: np.ndarray
    base_frequency: float
    offsets: np.ndarray
    sine: np.ndarray
    cosine: np.ndarray

    def __post_init__(self) -> None:
        f = float(self.base_frequency)
        if not np.isfinite(f) or f <= 0:
            raise InputError(f"base_frequency must be a positive number of Hz, got {f}")
        object.__setattr__(self, "base_frequency", f)
        sine = check_array(self.sine, (6, None), "sine")
        values = {
            "reference": check_pose(self.reference, "reference"),
            "offsets": check_array(self.offsets, (6,), "offsets"),
            "sine": sine,
            "cosine": check_array(self.cosine, (6, sine.shape[1]), "cosine"),
        }
        for key, value in values.items():
            value = np.array(value)
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_harmonics(self) -> int:
        return int(self.sine.shape[1])

    @property
    def period(self) -> float:
        """``1/f`` [s]."""
        return 1.0 / self.base_frequency

    # ------------------------------------------------------------ the optimiser's view
    def to_vector(self) -> np.ndarray:
        """The coefficients as one vector ``[c, a.ravel(), b.ravel()]``, (6 + 12 n,)."""
        return np.concatenate([self.offsets, self.sine.ravel(), self.cosine.ravel()])

    @classmethod
    def from_vector(cls, reference: Any, base_frequency: float, vector: Any) -> FourierTrajectory:
        """The inverse of :meth:`to_vector`."""
        x = np.asarray(vector, dtype=float)
        n = (x.size - 6) // 12
        if x.ndim != 1 or x.size != 6 + 12 * n or n < 1:
            raise InputError(f"a coefficient vector has 6 + 12 n entries (n >= 1), got {x.shape}")
        return cls(
            reference,
            base_frequency,
            x[:6],
            x[6 : 6 + 6 * n].reshape(6, n),
            x[6 + 6 * n :].reshape(6, n),
        )

    # ------------------------------------------------------------ evaluation
    def coordinates(self, times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x, x', x'')`` of the six coordinates, each (N, 6)."""
        t = check_array(times, (None,), "times")
        w = 2.0 * np.pi * self.base_frequency * np.arange(1, self.n_harmonics + 1)  # [rad/s]
        s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))  # (N, n)
        x = self.offsets + s @ self.sine.T + c @ self.cosine.T
        xd = (c * w) @ self.sine.T - (s * w) @ self.cosine.T
        xdd = -(s * w**2) @ self.sine.T - (c * w**2) @ self.cosine.T
        return x, xd, xdd

    def sample(self, times: Any) -> Trajectory:
        """The poses, twists and classical accelerations at ``times`` (N,) [s]."""
        t = check_array(times, (None,), "times")
        return trajectory_from_coordinates(self.reference, t, *self.coordinates(t), fourier=self)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(T, V, A)`` at one time ``t`` [s] (a controller's reference)."""
        return _at(self, t)


def trajectory_from_coordinates(
    reference: np.ndarray,
    t: np.ndarray,
    x: np.ndarray,
    xd: np.ndarray,
    xdd: np.ndarray,
    fourier: FourierTrajectory | None = None,
) -> Trajectory:
    """States from the six coordinates ``x = [d, r]`` about ``reference`` and their first
    and second time derivatives (each (N, 6)): ``p = p_ref + d``, ``R = exp3(r) R_ref``,
    ``v = d'``, ``w = J_l(r) r'``, exact classical accelerations (module docstring)."""
    return Trajectory(t, *_states(reference, x, xd, xdd), fourier=fourier)


def _states(
    reference: np.ndarray, x: np.ndarray, xd: np.ndarray, xdd: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r, rd, rdd = x[:, 3:], xd[:, 3:], xdd[:, 3:]
    coefs = so3_coefficients(r)  # shared by the exponential and the Jacobians
    poses = np.tile(np.eye(4), (x.shape[0], 1, 1))
    poses[:, :3, :3] = so3_exp(r, coefs) @ reference[:3, :3]
    poses[:, :3, 3] = reference[:3, 3] + x[:, :3]
    J = so3_left_jacobian(r, coefs)
    w = np.einsum("nij,nj->ni", J, rd)
    wd = np.einsum("nij,nj->ni", J, rdd) + so3_left_jacobian_rate(r, rd, coefs)
    twists = np.concatenate([xd[:, :3], w], axis=1)
    accels = np.concatenate([xdd[:, :3], wd], axis=1)
    return poses, twists, accels


def states_at(motion: Any, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(poses (N, 4, 4), twists (N, 6), accels (N, 6))`` of a motion given by coordinates
    (a :class:`CoordinateMotion` or :class:`FourierTrajectory`) at validated ``times``
    (N,) [s]: the arrays of its ``sample(times)`` (the same arithmetic) without building
    and validating a :class:`Trajectory` (the compiled simulator's reference table, for a
    motion its C does not evaluate itself)."""
    return _states(motion.reference, *motion.coordinates(times))


def _at(motion: Any, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One state, without building a validated :class:`Trajectory` (a controller's hot path)."""
    poses, twists, accels = _states(motion.reference, *motion.coordinates(np.array([float(t)])))
    return poses[0], twists[0], accels[0]


class CoordinateMotion:
    """A platform motion given by its six coordinates about a reference pose.

    Subclasses define ``reference`` (4, 4), ``duration`` [s] and ``coordinates(times) ->
    (x, x', x'')``; they get :meth:`sample` (a :class:`Trajectory`), ``motion(t)`` (one
    state, for a controller) and :meth:`check_workspace`.
    """

    reference: np.ndarray
    duration: float

    def coordinates(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def sample(self, times: Any) -> Trajectory:
        """The poses, twists and classical accelerations at ``times`` (N,) [s]."""
        t = check_array(times, (None,), "times")
        return trajectory_from_coordinates(self.reference, t, *self.coordinates(t))

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(T, V, A)`` at one time ``t`` [s] (a controller's reference)."""
        return _at(self, t)

    def check_workspace(self, robot: RobotLike, n_samples: int = 500) -> Trajectory:
        """Sample the whole motion and raise :class:`WorkspaceError` (stroke, U-joint
        limits) or :class:`SingularityError` at the first sample that leaves the
        workspace, naming its time; returns the samples when all are reachable."""
        traj = self.sample(np.linspace(0.0, self.duration, n_samples))
        for k in range(0, len(traj), 100):
            chunk = slice(k, k + 100)
            try:
                robot.inverse_geometry(traj.poses[chunk])
                robot.jacobian(traj.poses[chunk])
            except (WorkspaceError, SingularityError) as e:
                bad, error = _first_bad(robot, traj.poses[chunk])
                # The first failing sample's own error (type and attributes; no batch
                # note), its message prefixed with the time.
                error = error or e
                error.args = (
                    f"the motion leaves the workspace at t = {traj.times[k + bad]:.4g} s: {error}",
                )
                raise error from None
        return traj


def _first_bad(
    robot: RobotLike, poses: np.ndarray
) -> tuple[int, WorkspaceError | SingularityError | None]:
    """The first pose of ``poses`` out of the workspace, and its error."""
    for n, T in enumerate(poses):
        try:
            robot.inverse_geometry(T)
            robot.jacobian(T)
        except (WorkspaceError, SingularityError) as e:
            return n, e
    return 0, None


def _quintic(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum-jerk profile ``10 s^3 - 15 s^4 + 6 s^5`` on [0, 1] and its derivatives."""
    s = np.clip(s, 0.0, 1.0)
    return (
        s**3 * (10 - 15 * s + 6 * s**2),
        30 * s**2 * (1 - s) ** 2,
        60 * s * (1 - s) * (1 - 2 * s),
    )


@dataclass(frozen=True, eq=False)
class MinimumJerkKnots(CoordinateMotion):
    """Each coordinate moves through rest-to-rest minimum-jerk segments between knots.

    Attributes:
        reference: the pose the coordinates are measured from (4, 4).
        knots: six lists of ``(time [s], value [m or rad])``, times increasing, one list
            per coordinate ``[dx, dy, dz, rx, ry, rz]`` (empty: the coordinate stays 0);
            the value holds before the first and after the last knot.
    """

    reference: np.ndarray
    knots: tuple[tuple[tuple[float, float], ...], ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "reference", check_pose(self.reference, "reference"))
        if len(self.knots) != 6:
            raise InputError(
                f"knots must hold 6 lists (one per coordinate), got {len(self.knots)}"
            )
        for k, axis in enumerate(self.knots):
            times = np.array([float(t) for t, _ in axis])
            check_increasing_times(times, f"knot times of coordinate {k}")

    @property
    def duration(self) -> float:  # type: ignore[override]
        return max((axis[-1][0] for axis in self.knots if axis), default=0.0)

    def coordinates(self, times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = check_array(times, (None,), "times")
        out = np.zeros((3, t.shape[0], 6))
        for k, axis in enumerate(self.knots):
            if not axis:
                continue
            out[0, :, k] = axis[0][1]
            for (t0, v0), (t1, v1) in pairwise(axis):
                h = t1 - t0
                f, fd, fdd = _quintic((t - t0) / h)
                inside = t >= t0
                out[0, inside, k] = v0 + (v1 - v0) * f[inside]
                out[1, inside, k] = (v1 - v0) / h * fd[inside]
                out[2, inside, k] = (v1 - v0) / h**2 * fdd[inside]
        return out[0], out[1], out[2]


def minimum_jerk(
    reference: Any, goal: Any, duration: float, start: Any = None
) -> MinimumJerkKnots:
    """Rest-to-rest point-to-point motion from ``start`` to ``goal`` in ``duration`` [s].

    ``start``, ``goal``: coordinates ``[dx, dy, dz, rx, ry, rz]`` about ``reference``
    [m, rad] (a translation in F0 and a rotation vector in F0); ``start`` defaults to 0.
    """
    goal = check_array(goal, (6,), "goal")
    start = np.zeros(6) if start is None else check_array(start, (6,), "start")
    if not duration > 0:
        raise InputError(f"duration must be positive, got {duration} s")
    knots = tuple(
        ((0.0, float(a)), (float(duration), float(b))) for a, b in zip(start, goal, strict=True)
    )
    return MinimumJerkKnots(reference, knots)


def washout(
    reference: Any,
    surge: float,
    tilt: float,
    onset: float = 0.5,
    hold: float = 1.5,
    washout_time: float = 2.5,
) -> MinimumJerkKnots:
    """A motion-simulator style cue, washout-like: a quick surge of ``surge`` [m] along x0
    (the onset cue, in ``onset`` s), then a slow return to the centre below the perception
    threshold (``washout_time`` s); meanwhile the platform pitches by ``tilt`` [rad] (tilt
    coordination: gravity felt as a sustained acceleration), holds it ``hold`` s and
    levels out."""
    t1, t2 = onset, onset + hold
    knots = (
        ((0.0, 0.0), (t1, surge), (t2 + washout_time, 0.0)),
        (),
        (),
        (),
        ((0.0, 0.0), (2 * t1, tilt), (t2 + t1, tilt), (t2 + washout_time, 0.0)),
        (),
    )
    return MinimumJerkKnots(reference, knots)


@dataclass(frozen=True, eq=False)
class Sinusoids(CoordinateMotion):
    """Multi-axis sinusoids: ``x_k = A_k (sin(2 pi f_k t + phi_k) - sin(phi_k))`` about the
    reference (so the motion starts at the reference), for ``duration`` [s].

    Attributes:
        amplitudes: (6,) [m, m, m, rad, rad, rad]; frequencies: (6,) [Hz]; phases: (6,)
        [rad].
    """

    reference: np.ndarray
    amplitudes: np.ndarray
    frequencies: np.ndarray
    phases: np.ndarray
    duration: float = 2.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "reference", check_pose(self.reference, "reference"))
        for name in ("amplitudes", "frequencies", "phases"):
            object.__setattr__(self, name, check_array(getattr(self, name), (6,), name))

    def coordinates(self, times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = check_array(times, (None,), "times")[:, None]
        om = 2 * np.pi * self.frequencies
        arg = om * t + self.phases
        A, s = self.amplitudes, np.sin(arg)
        return (A * (s - np.sin(self.phases)), A * om * np.cos(arg), -A * om**2 * s)


#: The length [s] of :func:`washout` at its default phases (onset, hold, washout).
WASHOUT_DURATION = 4.5
#: The kinds :func:`standard_motion` builds.
MOTION_KINDS = ("sinusoid", "minimum-jerk", "washout")


def standard_motion(
    robot: RobotLike, kind: str = "sinusoid", duration: float = 2.0
) -> CoordinateMotion:
    """A demonstration motion about the home pose, scaled on the robot's mid-stroke ``s``:

    - ``sinusoid``: multi-axis sinusoids (4 % of s, 3 deg, 0.4-0.9 Hz) for ``duration``;
    - ``minimum-jerk``: to ``[5, -4, 6] % s`` and ``[3, -2, 4] deg`` in ``duration``;
    - ``washout``: a 8 % s surge with a 4 deg tilt, washed out in ``duration`` (the cue's
      phases, 0.5 s onset, 1.5 s hold and 2.5 s washout at :data:`WASHOUT_DURATION`,
      scaled in time to last ``duration``).
    """
    s = robot.description.stroke_mid
    T0 = robot.home_pose
    if kind == "sinusoid":
        return Sinusoids(
            T0,
            np.array([0.04 * s, 0.035 * s, 0.03 * s, *np.radians([3.0, 2.5, 3.0])]),
            np.array([0.5, 0.7, 0.9, 0.4, 0.6, 0.8]),
            np.array([0.0, 1.0, 2.0, 0.5, 1.5, 2.5]),
            duration,
        )
    if kind == "minimum-jerk":
        goal = [0.05 * s, -0.04 * s, 0.06 * s, *np.radians([3.0, -2.0, 4.0])]
        return minimum_jerk(T0, goal, duration)
    if kind == "washout":
        c = check_scalar(duration, "duration", positive=True, unit="s") / WASHOUT_DURATION
        return washout(
            T0,
            surge=0.08 * s,
            tilt=np.radians(4.0),
            onset=0.5 * c,
            hold=1.5 * c,
            washout_time=2.5 * c,
        )
    raise InputError(f"unknown motion '{kind}'; choose one of {MOTION_KINDS}")
