"""Minimum-effort point-to-point motions, optimised on the exact closed-form model.

:func:`optimal_point_to_point` moves the platform from rest at ``start_pose`` to rest at
``goal_pose`` in a given ``duration`` with the least actuator effort
``int sum_i (Gamma_i / Gamma_max_i)^2 dt``, under

- actuator effort limits ``|Gamma_i| <= max_effort_i`` [N, or N m for a revolute
  actuated joint] (on the controls),
- actuator velocity limits ``|qdot_ai| <= max_speed_i`` [m/s or rad/s] (at the nodes),
- the workspace: every actuated joint within its limits, ``margin`` inside each end (at
  the nodes): the leg lengths within the stroke for a 6-UPS, each leg's own actuated
  joint limits for any other architecture (crank angles of a 6-RUS, slide positions of
  a 6-PUS; an infinite limit is no constraint).

Transcription: direct multiple shooting on ``intervals`` equal intervals. The controls
are the actuator forces, held over each interval (zero-order hold, as a digital controller
applies them and as ``simulate(..., control_period=...)`` does); the state is
``[p, q, v, w]`` (position of O_p, unit quaternion ``[x, y, z, w]`` of 0Rp, twist in F0),
integrated over each interval by ``substeps`` classical RK4 steps of ``dp/dt = v``,
``dq/dt = 1/2 [w; 0] (x) q`` and ``d[v, w]/dt = DDM(pose, twist, Gamma)``, the quaternion
renormalised at the end of each interval. The DDM is the robot's generated closed form
(:func:`stewart_pin.codegen.derivatives.symbolic_models_for`, the CasADi SX function
itself, inlined), so the constraint Jacobians IPOPT receives are CasADi's algorithmic
derivatives of the exact model, the same as ``robot.direct_dynamics_derivatives``. IPOPT
(shipped with CasADi) solves the NLP from a quintic (minimum-jerk-like) interpolation of
the poses with its inverse-dynamics forces, with a limited-memory Hessian by default.

Coulomb friction: its sign jumps where a joint starts from rest or turns back, and IPOPT
stopped on fine transcriptions of such robots (``pus``, ``ups-offset``: 10 or 20
intervals). The NLP optimises on a smooth model instead, ``Fc tanh(qd / eps)`` with
``eps = coulomb_smoothing`` (default :data:`COULOMB_SMOOTHING`, 1e-2 m/s or rad/s;
:func:`stewart_pin.codegen.derivatives.symbolic_models_for`), and the result reports the
exact inverse model's efforts of the motion found at the nodes
(:attr:`OptimalMotion.exact_efforts`) beside the smooth model's held forces.

The actuated joint values and rates at the nodes are the SX function of
:func:`stewart_pin.codegen.derivatives.symbolic_actuators_for` (the 6-UPS's leg lengths in
closed form; the generated models' leg code for every other architecture).

Checks on the answer: the poses reached at the nodes are checked by the robot's inverse
geometry (every joint's limits, the passive ones included) and singularity measure, and
the open-loop simulation (:meth:`OptimalMotion.simulate`, the project's
:func:`~stewart_pin.motion.simulation.simulate` with the reference direct model)
reproduces the optimised motion: with the transcription's step to 1e-6 m and 1e-6 rad
(the same RK4 order, a different SO(3) integration: about 1e-9 measured), and with a step
twenty times finer to 1e-5 m and 1e-5 rad (the transcription's own error: about 2e-7 on a
one-second motion with the defaults); the test suite holds it to these tolerances.

Every leg architecture (the DDM is generated for each: ``ups``, ``ups-offset``, ``rus``,
``pus``, custom, mixed).
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType
from typing import Any

import casadi as cs
import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_pose, check_scalar
from stewart_pin._so3 import quaternions_xyzw_from_rotations, rotation_rows_from_quaternion_xyzw
from stewart_pin.codegen.derivatives import symbolic_actuators_for, symbolic_models_for
from stewart_pin.description.actuator_convention import actuator_convention_of
from stewart_pin.exceptions import ConvergenceError, InputError, SingularityError
from stewart_pin.motion.simulation import SimulationResult, simulate
from stewart_pin.protocols import RobotLike

__all__ = ["COULOMB_SMOOTHING", "OptimalMotion", "optimal_point_to_point"]

#: Statuses of IPOPT accepted as a solution.
_SOLVED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
#: Slack when a time is turned into an interval index (round-off in ``t / period``).
_INDEX_SLACK = 1e-9
#: The default ``eps`` of the smooth Coulomb sign ``tanh(qd / eps)`` the NLP optimises
#: on [m/s for a prismatic joint, rad/s for a revolute one].
COULOMB_SMOOTHING = 1e-2


@dataclass(frozen=True)
class OptimalMotion:
    """An optimised point-to-point motion, sampled at the ``intervals + 1`` nodes.

    Attributes:
        t: (K+1,) node times [s], ``K = intervals``.
        poses: (K+1, 4, 4) 0Tp at the nodes. twists: (K+1, 6) ``[v, w]`` in F0.
        accels: (K+1, 6) classical accelerations in F0 at the nodes (the direct model
            under the force held from that node; the last under the last interval's).
        gammas: (K, 6) the actuator efforts [N or N m], held over ``[t_k, t_k+1)``.
            Efforts, positions, rates and bounds in the robot's actuator convention
            (``robot.actuator_convention``: an imported robot's file's).
        leg_lengths: (K+1, 6) the actuated joint values (leg lengths [m] of a UPS robot;
            :attr:`actuator_positions` is the same array); actuator_speeds: (K+1, 6) their
            rates [m/s or rad/s].
        max_effort: (6,) [N or N m]; max_speed: (6,) [m/s or rad/s];
        actuator_bounds: (6, 2) each actuated joint's values allowed (its limits less the
            margin) [m or rad]: the limits the motion satisfies (:attr:`length_bounds`:
            the bounds all six share, the 6-UPS's stroke less the margin).
        cost: the objective ``int sum_i (Gamma_i / scale_i)^2 dt`` [s] (``scale`` the
            effort limits; without one, the largest force of the initial guess + 1 N).
        status: IPOPT's return status; iterations: its iteration count; solve_time [s].
        substeps: RK4 steps per interval in the transcription.
        exact_efforts: (K+1, 6) the exact inverse model's efforts [N or N m] at the nodes'
            states and accelerations (Coulomb's exact sign), in the robot's actuator
            convention as :attr:`gammas`: what the actuators apply to follow the found
            motion; :attr:`gammas` are the smooth model's.
        coulomb_smoothing: the ``eps`` of the smooth Coulomb sign ``tanh(qd / eps)`` the
            NLP optimised on [m/s or rad/s].
    """

    t: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    gammas: np.ndarray
    leg_lengths: np.ndarray
    actuator_speeds: np.ndarray
    max_effort: np.ndarray
    max_speed: np.ndarray
    actuator_bounds: np.ndarray
    cost: float
    status: str
    iterations: int
    solve_time: float
    substeps: int
    exact_efforts: np.ndarray
    coulomb_smoothing: float

    @property
    def actuator_positions(self) -> np.ndarray:
        """The actuated joint values at the nodes, (K+1, 6) [m or rad] (:attr:`leg_lengths`)."""
        return self.leg_lengths

    @property
    def length_bounds(self) -> np.ndarray:
        """``[lower, upper]`` (2,) that every actuated joint's values allowed share (the
        6-UPS: the stroke less the margin [m]); per leg: :attr:`actuator_bounds`."""
        return np.array([self.actuator_bounds[:, 0].max(), self.actuator_bounds[:, 1].min()])

    @property
    def duration(self) -> float:
        """The motion's duration [s]."""
        return float(self.t[-1])

    @property
    def control_period(self) -> float:
        """The interval over which each force is held [s]."""
        return float(self.t[-1] / len(self.gammas))

    def forces(self, t: float, pose: Any = None, twist: Any = None) -> np.ndarray:
        """The force held at time ``t`` [s] (the open-loop schedule; ``pose`` and ``twist``
        are ignored): ``simulate``'s ``forces`` argument."""
        t = check_scalar(t, "t", unit="s")
        k = int(np.floor(t / self.control_period + _INDEX_SLACK))
        return self.gammas[min(max(k, 0), len(self.gammas) - 1)].copy()

    def simulate(
        self, robot: RobotLike, substeps: int | None = None, backend: str = "pinocchio"
    ) -> SimulationResult:
        """The open-loop simulation of the optimised forces from the start state: RK4 with
        ``substeps`` steps per interval (default the transcription's), forces sampled and
        held every :attr:`control_period` (:func:`~stewart_pin.motion.simulation.simulate`;
        ``backend`` its direct model's, by default the reference path, which shares no
        code with the generated model the optimisation used). On a robot with Coulomb
        friction the simulator's friction has the exact sign, the optimisation's the
        smooth one (:attr:`coulomb_smoothing`): the replay departs from the motion
        (measured: 2-4 mm and 0.01-0.04 rad on the ``pus`` and ``ups-offset`` 1 s moves
        of the tests); :attr:`exact_efforts` are the efforts that follow it."""
        n = self.substeps if substeps is None else _integer(substeps, "substeps", 1)
        period = self.control_period
        return simulate(
            robot,
            self.duration,
            self.poses[0],
            self.twists[0],
            forces=self.forces,
            method="rk4",
            dt=period / n,
            control_period=period,
            backend=backend,
        )

    def deviation(self, result: SimulationResult) -> tuple[float, float]:
        """The largest distance between a simulation's states at the nodes and the
        optimised ones: ``(position [m], rotation angle [rad])``."""
        k = np.rint(result.t / self.control_period).astype(int)
        on = np.abs(result.t / self.control_period - k) < 1e-6
        k = k[on]
        if not np.array_equal(np.unique(k), np.arange(len(self.t))):
            raise InputError("the simulation does not sample every node of the motion")
        P, ref = result.poses[on], self.poses[k]
        dp = float(np.abs(P[:, :3, 3] - ref[:, :3, 3]).max())
        rel = np.einsum("nij,nkj->nik", P[:, :3, :3], ref[:, :3, :3])
        dr = max(float(np.linalg.norm(pin.log3(r))) for r in rel)
        return dp, dr


# ---------------------------------------------------------------------------- symbolic
def _rotation(q: cs.SX) -> cs.SX:
    """0Rp of a quaternion ``[x, y, z, w]`` (normalised first), SX 3x3."""
    qn = q / cs.sqrt(cs.sumsqr(q))
    rows = rotation_rows_from_quaternion_xyzw(qn[0], qn[1], qn[2], qn[3])
    return cs.vertcat(*[cs.horzcat(*r) for r in rows])


def _pose16(p: cs.SX, R: cs.SX) -> cs.SX:
    """The generated models' pose input: 0Tp row-major (16)."""
    return cs.vertcat(*[cs.vertcat(R[i, 0], R[i, 1], R[i, 2], p[i]) for i in range(3)], 0, 0, 0, 1)


def _quaternion_product(a: Any, b: Any) -> Any:
    """``a (x) b`` of quaternions ``[x, y, z, w]``."""
    av, aw, bv, bw = a[0:3], a[3], b[0:3], b[3]
    return cs.vertcat(aw * bv + bw * av + cs.cross(av, bv), aw * bw - cs.dot(av, bv))


def _functions(
    robot: RobotLike, period: float, substeps: int, eps: float
) -> tuple[cs.Function, cs.Function, cs.Function, cs.Function]:
    """``step(x, Gamma) -> x+`` (one interval), ``legs(x) -> (q_a, qdot_a)`` (the
    actuated joint values and rates) and ``accel(x, Gamma) -> Vdot`` on the smooth model
    (Coulomb's sign as ``tanh(qd / eps)``), and ``efforts(x, Vdot) -> Gamma`` on the
    exact model, SX functions of the state ``[p, q, v, w]`` (13)."""
    exact = symbolic_models_for(robot)
    models = symbolic_models_for(robot, eps) if eps > 0.0 else exact
    chi = np.asarray(models.constants.parameter_values, dtype=float)
    actuators = symbolic_actuators_for(robot)
    x = cs.SX.sym("x", 13)
    u = cs.SX.sym("gamma", 6)

    def accel(x: cs.SX, u: cs.SX) -> cs.SX:
        return models.ddm(_pose16(x[0:3], _rotation(x[3:7])), x[7:13], u, chi)

    def rate(x: cs.SX, u: cs.SX) -> cs.SX:
        q, w = x[3:7], x[10:13]
        dq = 0.5 * _quaternion_product(cs.vertcat(w, 0), q)
        return cs.vertcat(x[7:10], dq, accel(x, u))

    h = period / substeps
    y = x
    for _ in range(substeps):
        k1 = rate(y, u)
        k2 = rate(y + h / 2 * k1, u)
        k3 = rate(y + h / 2 * k2, u)
        k4 = rate(y + h * k3, u)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    y = cs.vertcat(y[0:3], y[3:7] / cs.sqrt(cs.sumsqr(y[3:7])), y[7:13])
    step = cs.Function("step", [x, u], [y], ["x", "gamma"], ["x_next"])

    positions, rates = actuators(_pose16(x[0:3], _rotation(x[3:7])), x[7:13])
    legs = cs.Function("legs", [x], [positions, rates])
    a = cs.SX.sym("accel", 6)
    pose = _pose16(x[0:3], _rotation(x[3:7]))
    exact_chi = np.asarray(exact.constants.parameter_values, dtype=float)
    efforts = cs.Function("efforts", [x, a], [exact.idm(pose, x[7:13], a, exact_chi)])
    return step, legs, cs.Function("accel", [x, u], [accel(x, u)]), efforts


# ---------------------------------------------------------------------------- the NLP
def _state(T: np.ndarray, V: np.ndarray) -> np.ndarray:
    q = quaternions_xyzw_from_rotations(T[None, :3, :3])[0]
    return np.concatenate([T[:3, 3], q, V])


def _integer(value: Any, name: str, least: int) -> int:
    """``value`` as an int >= ``least`` (an integral float too), else InputError."""
    n = int(check_scalar(value, name, integer=True))
    if n < least:
        raise InputError(f"{name} must be an integer >= {least}, got {value!r}")
    return n


def _limits(value: Any, name: str) -> np.ndarray:
    if value is None:
        return np.full(6, np.inf)
    error = InputError(
        f"{name} must be a positive number or six positive numbers (inf: no limit), got {value!r}"
    )
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise error
    try:
        arr = np.asarray(value)
        if arr.dtype.kind not in "iuf":  # booleans, strings, objects
            raise error
        arr = arr.astype(float)
    except (TypeError, ValueError) as e:
        raise error from e
    if arr.ndim == 0:
        arr = np.full(6, float(arr))
    if arr.shape != (6,) or np.isnan(arr).any() or not (arr > 0).all():
        raise error
    return arr


def _actuator_bounds(robot: RobotLike, margin: Any) -> np.ndarray:
    """Each actuated joint's limits less ``margin`` (default 1 % of its range; none
    within an infinite limit), (6, 2) [m or rad]; InputError for a margin not in
    ``[0, half the narrowest range)``."""
    legs = robot.description.joint_legs  # three-joint or chain legs; the 6-UPS's: its stroke
    limits = np.array([leg.limits[leg.actuated - 1] for leg in legs], dtype=float)
    width = limits[:, 1] - limits[:, 0]
    if margin is None:
        m = 0.01 * np.where(np.isfinite(width), width, 0.0)
    else:
        value = check_scalar(margin, "margin")
        if not 0.0 <= value < 0.5 * width.min():
            raise InputError(
                f"margin must be in [0, {0.5 * width.min():g}) (m or rad: half the narrowest "
                f"actuated joint range), got {value:g}"
            )
        m = np.full(6, value)
    return np.stack([limits[:, 0] + m, limits[:, 1] - m], axis=1)


def _initial_guess(
    robot: RobotLike, T0: np.ndarray, T1: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of the quintic rest-to-rest interpolation ``p0 + s dp``, ``exp(s theta) R0``
    and the reference inverse model's forces (averaged over each interval)."""
    tau = t / t[-1]
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    sd = (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / t[-1]
    sdd = (60 * tau - 180 * tau**2 + 120 * tau**3) / t[-1] ** 2
    dp = T1[:3, 3] - T0[:3, 3]
    theta = pin.log3(T1[:3, :3] @ T0[:3, :3].T)
    poses = np.tile(np.eye(4), (len(t), 1, 1))
    poses[:, :3, 3] = T0[:3, 3] + s[:, None] * dp
    poses[:, :3, :3] = [pin.exp3(sk * theta) @ T0[:3, :3] for sk in s]
    twists = np.concatenate([sd[:, None] * dp, sd[:, None] * theta], axis=1)
    accels = np.concatenate([sdd[:, None] * dp, sdd[:, None] * theta], axis=1)
    gammas = np.asarray(robot.inverse_dynamics(poses, twists, accels), dtype=float)
    gammas = actuator_convention_of(robot).efforts_to_description(gammas)  # the NLP's
    X = np.array([_state(T, V) for T, V in zip(poses, twists, strict=True)])
    return X, 0.5 * (gammas[:-1] + gammas[1:])


@contextmanager
def _interrupts_recorded() -> Iterator[list[int]]:
    """Record SIGINT during the block (the list gets the signal number), the previous
    handler still run: CasADi turns the ``KeyboardInterrupt`` that handler raises into an
    IPOPT status, and the caller raises it again from the record. Outside the main
    thread (no handler can be set there) nothing is recorded."""
    seen: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):  # SIG_IGN (ignored: nothing to record) or SIG_DFL
        yield seen
        return

    def record(signum: int, frame: FrameType | None) -> Any:
        seen.append(signum)
        return previous(signum, frame)

    signal.signal(signal.SIGINT, record)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def optimal_point_to_point(
    robot: RobotLike,
    start_pose: Any,
    goal_pose: Any,
    duration: float,
    *,
    max_effort: Any = None,
    max_speed: Any = None,
    margin: float | None = None,
    intervals: int = 30,
    substeps: int = 1,
    hessian: str = "limited-memory",
    tol: float = 1e-8,
    max_iterations: int = 500,
    verbose: bool = False,
    coulomb_smoothing: float = COULOMB_SMOOTHING,
) -> OptimalMotion:
    """The minimum-effort rest-to-rest motion from ``start_pose`` to ``goal_pose``.

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` of any leg architecture.
        start_pose, goal_pose: 0Tp (4, 4) or ``pin.SE3``; the platform is at rest at both.
        duration: the motion's duration [s].
        max_effort: the actuator effort limit [N, N m for a revolute actuated joint]: a
            number or (6,), ``None`` / ``inf`` for none.
        max_speed: the actuated joint rate limit [m/s or rad/s], likewise; enforced at
            the nodes.
        margin: the distance kept from each end of each actuated joint's limits [m or
            rad] (default 1 % of each finite range: the 6-UPS's stroke); enforced at the
            nodes.
        intervals: number of control intervals (>= 2); substeps: RK4 steps per interval.
        hessian: ``"limited-memory"`` (L-BFGS, the default: cheaper here) or ``"exact"``
            (CasADi's second derivatives of the model).
        tol: IPOPT's tolerance; max_iterations: its iteration limit.
        verbose: print IPOPT's iterations.
        coulomb_smoothing: ``eps`` [m/s for a prismatic joint, rad/s for a revolute one]
            of the smooth Coulomb sign ``tanh(qd / eps)`` the NLP optimises on (the exact
            ``sign`` jumps where a joint starts from rest or turns back, which stops IPOPT
            on fine transcriptions); the motion's exact efforts are reported beside
            (:attr:`OptimalMotion.exact_efforts`); 0: the exact sign (a coarse
            transcription may converge with it). No effect on a robot without Coulomb
            friction.

    Returns:
        the :class:`OptimalMotion`.

    Raises:
        KeyboardInterrupt: Ctrl-C during the solve (CasADi stops IPOPT and reports a
            failed status: that is an interrupt, not a ConvergenceError).
        InputError: a bad argument, or a start or goal pose outside the actuated joints'
            limits less the margin. WorkspaceError / SingularityError: a start or goal pose
            the robot cannot take, or an optimised node outside a passive joint's limits
            or past ``robot.max_condition`` (not constraints of the NLP).
        ConvergenceError: IPOPT did not find an optimal motion (its status in the message,
            ``.iterations`` and ``.residual`` the last constraint violation): the limits
            may not allow the motion in this duration.
    """
    T0 = check_pose(start_pose, "start_pose")
    T1 = check_pose(goal_pose, "goal_pose")
    duration = check_scalar(duration, "duration", positive=True, unit="s")
    intervals = _integer(intervals, "intervals", 2)
    substeps = _integer(substeps, "substeps", 1)
    max_iterations = _integer(max_iterations, "max_iterations", 1)
    if hessian not in ("limited-memory", "exact"):
        raise InputError(f"hessian must be 'limited-memory' or 'exact', got {hessian!r}")
    tol = check_scalar(tol, "tol", positive=True)
    eps = check_scalar(coulomb_smoothing, "coulomb_smoothing", nonnegative=True)
    effort, speed = _limits(max_effort, "max_effort"), _limits(max_speed, "max_speed")
    # the NLP in the description's actuator convention, its outputs in the robot's
    conv = actuator_convention_of(robot)
    bounds = _actuator_bounds(robot, margin)
    step, legs, accel, efforts = _functions(robot, duration / intervals, substeps, eps)
    for T, name in ((T0, "start_pose"), (T1, "goal_pose")):
        robot.inverse_geometry(T)  # reachable, inside every joint's limits
        at_rest = np.asarray(legs(_state(T, np.zeros(6)))[0]).ravel()
        out = np.flatnonzero((at_rest < bounds[:, 0]) | (at_rest > bounds[:, 1]))
        if len(out):
            k = int(out[0])
            at_rest = conv.positions_from_description(at_rest)
            shown = conv.limits_from_description(bounds)
            raise InputError(
                f"{name} has leg lengths (actuated joint values) outside the limits less the "
                f"margin: leg {k + 1} at {at_rest[k]:.6g}, allowed "
                f"[{shown[k, 0]:.6g}, {shown[k, 1]:.6g}] (m or rad): move it inside or give "
                "a smaller margin"
            )
    K = intervals
    t = np.linspace(0.0, duration, K + 1)
    X_guess, U_guess = _initial_guess(robot, T0, T1, t)
    scale = np.where(np.isfinite(effort), effort, np.abs(U_guess).max() + 1.0)
    U_guess = np.clip(U_guess, -effort, effort)

    X = cs.MX.sym("X", 13, K + 1)
    U = cs.MX.sym("Gamma", 6, K)
    defects = step.map(K)(X[:, :K], U) - X[:, 1:]
    lengths, rates = legs.map(K + 1)(X)
    x0, x1 = _state(T0, np.zeros(6)), _state(T1, np.zeros(6))
    q1_conj = cs.DM([-x1[3], -x1[4], -x1[5], x1[6]])
    attitude = _quaternion_product(q1_conj, X[3:7, K])[0:3]  # zero at the goal (or -q)
    equalities = cs.vertcat(
        cs.vec(defects), X[:, 0] - x0, X[0:3, K] - x1[0:3], attitude, X[7:13, K]
    )
    g = cs.vertcat(equalities, cs.vec(lengths), cs.vec(rates))
    n_eq = equalities.size1()
    lbg = np.concatenate([np.zeros(n_eq), np.tile(bounds[:, 0], K + 1), np.tile(-speed, K + 1)])
    ubg = np.concatenate([np.zeros(n_eq), np.tile(bounds[:, 1], K + 1), np.tile(speed, K + 1)])
    period = duration / K
    cost = period * cs.sumsqr(U / cs.repmat(cs.DM(scale), 1, K))
    w = cs.vertcat(cs.vec(X), cs.vec(U))
    lbw = np.concatenate([np.full(13 * (K + 1), -np.inf), np.tile(-effort, K)])
    ubw = np.concatenate([np.full(13 * (K + 1), np.inf), np.tile(effort, K)])
    options = {
        "print_time": False,
        "ipopt.print_level": 5 if verbose else 0,
        "ipopt.sb": "yes",
        "ipopt.hessian_approximation": hessian,
        "ipopt.tol": tol,
        "ipopt.bound_relax_factor": 0.0,  # the limits exactly, not 1e-8 relative past them
        "ipopt.max_iter": int(max_iterations),
    }
    solver = cs.nlpsol("optimal_point_to_point", "ipopt", {"x": w, "f": cost, "g": g}, options)
    w0 = np.concatenate([X_guess.ravel(), U_guess.ravel()])
    started = time.perf_counter()
    with _interrupts_recorded() as interrupted:
        sol = solver(x0=w0, lbx=lbw, ubx=ubw, lbg=lbg, ubg=ubg)
    if interrupted:  # CasADi catches Ctrl-C in IPOPT and returns a failed status
        raise KeyboardInterrupt
    elapsed = time.perf_counter() - started
    stats = solver.stats()
    status = str(stats.get("return_status", "unknown"))
    iterations = int(stats.get("iter_count", -1))
    if status not in _SOLVED or not stats.get("success", False):
        residual = stats.get("iterations", {}).get("inf_pr", [None])[-1]
        raise ConvergenceError(
            f"IPOPT found no optimal motion ({status} after {iterations} iterations, "
            f"constraint violation {residual if residual is not None else 'unknown'}): the "
            "effort, speed and joint limits may not allow this motion in "
            f"{duration:g} s; give a longer duration, looser limits or more intervals",
            iterations,
            None if residual is None else float(residual),
        )
    z = np.asarray(sol["x"], dtype=float).ravel()
    Xs = z[: 13 * (K + 1)].reshape(K + 1, 13)
    Us = z[13 * (K + 1) :].reshape(K, 6)
    poses = np.tile(np.eye(4), (K + 1, 1, 1))
    poses[:, :3, 3] = Xs[:, 0:3]
    q = Xs[:, 3:7] / np.linalg.norm(Xs[:, 3:7], axis=1, keepdims=True)
    poses[:, :3, :3] = np.stack(
        [np.stack(r, -1) for r in rotation_rows_from_quaternion_xyzw(*q.T)], -2
    )
    held = np.vstack([Us, Us[-1:]])
    accels = np.asarray(accel.map(K + 1)(Xs.T, held.T)).T
    exact = np.asarray(efforts.map(K + 1)(Xs.T, accels.T)).T
    lens, speeds = (np.asarray(a).T for a in legs.map(K + 1)(Xs.T))
    robot.inverse_geometry(poses)  # every joint's limits at the nodes
    cond = np.asarray(robot.condition_number(poses))
    if np.any(~(cond <= robot.max_condition)):
        k = int(np.argmax(~(cond <= robot.max_condition)))
        raise SingularityError(
            f"the optimised motion passes the singularity threshold at node {k} "
            f"(t = {t[k]:.6g} s, measure {cond[k]:.6g} > {robot.max_condition:.6g}): "
            "choose other poses or a longer duration",
            float(cond[k]),
            robot.max_condition,
        )
    return OptimalMotion(
        t=t,
        poses=poses,
        twists=Xs[:, 7:13].copy(),
        accels=accels,
        gammas=conv.efforts_from_description(Us),
        leg_lengths=conv.positions_from_description(lens),
        actuator_speeds=conv.rates_from_description(speeds),
        max_effort=effort,
        max_speed=speed,
        actuator_bounds=conv.limits_from_description(bounds),
        cost=float(sol["f"]),
        status=status,
        iterations=iterations,
        solve_time=elapsed,
        substeps=int(substeps),
        exact_efforts=conv.efforts_from_description(exact),
        coulomb_smoothing=eps,
    )
