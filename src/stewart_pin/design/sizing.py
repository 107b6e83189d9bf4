"""Actuator sizing: loads along motions, the worst state of a box of states, the dynamic
capability, and a report.

- :func:`actuator_loads`: each actuator's effort ``Gamma`` [N or N m], speed ``qdot_a =
  Jp^-1 V`` [m/s or rad/s] and power ``Gamma qdot_a`` [W] at given states (a trajectory's
  samples, a payload's motion), with their peaks and RMS values (:meth:`ActuatorLoads.table`).
- :class:`StateBox` and :func:`worst_case`: the states around the home pose within bounds
  on the displacement, rotation, twist and acceleration; per actuator, the largest
  ``|Gamma_i|`` found by L-BFGS-B (gradients by central differences, one batched call per
  gradient) started from the worst of the sampled states; never below the sampled worst.
- :func:`wrench_capability`: at one pose, at rest, the largest force (or moment) the
  platform exerts along each direction under the effort limits.
- :func:`dynamic_capability`: at one state, the largest linear acceleration of O_p in each
  direction under the effort limits ``|Gamma_i| <= limit_i``: efforts are affine in the
  acceleration at a given pose and twist, so each direction is a small linear program
  (``scipy.optimize.linprog``).
- :func:`write_report`: the tables as CSV and JSON in a folder (written atomically).

Every state passed to the dynamics is first checked with
:func:`~stewart_pin.design.feasibility.feasible`: the optimiser never leaves the robot's
limits.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar, check_states
from stewart_pin._extras import require
from stewart_pin._io import atomic_open
from stewart_pin.design.feasibility import check_directions, feasible
from stewart_pin.exceptions import EmptyWorkspaceError, InputError

#: Relative step of the central differences of :func:`worst_case` (of each half-width).
FD_STEP = 1e-6


@dataclass(frozen=True)
class ActuatorLoads:
    """Loads of the six actuators at N states, each (N, 6): ``efforts`` [N or N m],
    ``speeds`` [m/s or rad/s], ``powers`` [W] (positive: the actuator delivers power)."""

    efforts: np.ndarray
    speeds: np.ndarray
    powers: np.ndarray

    def table(self) -> list[dict[str, float | int]]:
        """One row per actuator (1-based ``actuator``): ``peak_effort``, ``rms_effort``,
        ``peak_speed``, ``rms_speed``, ``peak_power`` (largest power delivered),
        ``rms_power``, and ``worst_state``, the index of the peak effort."""
        rows: list[dict[str, float | int]] = []
        for i in range(6):
            g, s, p = self.efforts[:, i], self.speeds[:, i], self.powers[:, i]
            rows.append(
                {
                    "actuator": i + 1,
                    "peak_effort": float(np.abs(g).max()),
                    "rms_effort": float(np.sqrt(np.mean(g**2))),
                    "peak_speed": float(np.abs(s).max()),
                    "rms_speed": float(np.sqrt(np.mean(s**2))),
                    "peak_power": float(p.max()),
                    "rms_power": float(np.sqrt(np.mean(p**2))),
                    "worst_state": int(np.argmax(np.abs(g))),
                }
            )
        return rows


def actuator_loads(
    robot: Any, poses: Any, twists: Any, accels: Any, backend: str = "auto"
) -> ActuatorLoads:
    """The actuators' efforts, speeds and powers at states ``(poses (N, 4, 4), twists
    (N, 6), accels (N, 6))`` (0Tp, ``[v, w]`` of O_p in F0 [m/s, rad/s], classical
    accelerations [m/s^2, rad/s^2]); ``backend`` as :meth:`StewartRobot.inverse_dynamics`."""
    _, T, V, A = check_states(poses, (twists, "twists"), (accels, "accels"))
    T = T.reshape(-1, 4, 4)
    V, A = V.reshape(-1, 6), A.reshape(-1, 6)
    if T.shape[0] == 0:
        raise InputError("actuator_loads needs at least one state")
    gamma = np.asarray(robot.inverse_dynamics(T, V, A, backend=backend)).reshape(-1, 6)
    J_inv = np.asarray(robot.inverse_jacobian(T)).reshape(-1, 6, 6)
    speeds = np.einsum("nij,nj->ni", J_inv, V)
    return ActuatorLoads(gamma, speeds, gamma * speeds)


# ---------------------------------------------------------------------------- worst case
def _half(value: Any, name: str, unit: str) -> np.ndarray:
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise InputError(f"{name} must be finite and >= 0 [{unit}], got {value!r}")
    return v


@dataclass(frozen=True)
class StateBox:
    """States around the home pose: O_p displaced by ``|dp_k| <= translation_k`` [m]
    along F0's axes, rotated to ``exp(w) R_home`` with ``|w_k| <= rotation_k`` [rad], the
    twist within ``speed`` [m/s] and ``angular_speed`` [rad/s] per component, the
    acceleration within ``accel`` [m/s^2] and ``angular_accel`` [rad/s^2]. Each bound is a
    number or a 3-vector."""

    translation: Any = 0.0
    rotation: Any = 0.0
    speed: Any = 0.0
    angular_speed: Any = 0.0
    accel: Any = 0.0
    angular_accel: Any = 0.0

    @property
    def half_widths(self) -> np.ndarray:
        """The 18 half-widths ``[dp, w, v, omega, a, alpha]``."""
        names = ("translation", "rotation", "speed", "angular_speed", "accel", "angular_accel")
        units = ("m", "rad", "m/s", "rad/s", "m/s^2", "rad/s^2")
        return np.concatenate(
            [_half(getattr(self, n), n, u) for n, u in zip(names, units, strict=True)]
        )

    def states(self, robot: Any, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(poses (M, 4, 4), twists (M, 6), accels (M, 6))`` at the normalised points
        ``x`` (M, 18) in ``[-1, 1]^18``."""
        from pinocchio import exp3

        y = np.atleast_2d(x) * self.half_widths
        home = robot.home_pose
        T = np.tile(home, (y.shape[0], 1, 1))
        T[:, :3, 3] += y[:, :3]
        T[:, :3, :3] = np.array([exp3(w) for w in y[:, 3:6]]) @ home[:3, :3]
        return T, y[:, 6:12], y[:, 12:18]

    def sample(
        self, robot: Any, n: int, rng: np.random.Generator | int | None = None
    ) -> np.ndarray:
        """``n`` normalised points (n, 18) drawn uniformly in the box whose poses are
        feasible (redrawn up to 100 n times, then :class:`EmptyWorkspaceError`)."""
        n = int(check_scalar(n, "n", integer=True, nonnegative=True))
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        kept: list[np.ndarray] = []
        count = 0
        for _ in range(100):
            x = gen.uniform(-1.0, 1.0, (max(n, 1) * 2, 18))
            x = x[feasible(robot, self.states(robot, x)[0])]
            kept.append(x)
            count += x.shape[0]
            if count >= n:
                return np.concatenate(kept)[:n]
        raise EmptyWorkspaceError(
            f"only {count} of {n} states of the box are feasible after 100 rounds; "
            "shrink the translation and rotation bounds"
        )


@dataclass(frozen=True)
class WorstCase:
    """The worst state found for one actuator: ``effort`` (signed) [N or N m] at
    ``pose`` (4, 4), ``twist`` (6,), ``accel`` (6,); ``sampled`` the worst ``|effort|``
    among the samples it started from (``|effort| >= sampled``)."""

    actuator: int
    effort: float
    sampled: float
    pose: np.ndarray
    twist: np.ndarray
    accel: np.ndarray

    def row(self) -> dict[str, Any]:
        """A flat row for the report: ``x, y, z`` [m] of O_p, ``rx, ry, rz`` the rotation
        vector of 0Rp [rad], the twist ``vx..wz`` and the acceleration ``dvx..dwz``."""
        from pinocchio import log3

        r = log3(self.pose[:3, :3])
        cols = ["vx", "vy", "vz", "wx", "wy", "wz"]
        row: dict[str, Any] = {
            "actuator": self.actuator,
            "effort": self.effort,
            "sampled": self.sampled,
            **dict(zip(("x", "y", "z"), map(float, self.pose[:3, 3]), strict=True)),
            **dict(zip(("rx", "ry", "rz"), map(float, r), strict=True)),
            **dict(zip(cols, map(float, self.twist), strict=True)),
            **{f"d{c}": float(a) for c, a in zip(cols, self.accel, strict=True)},
        }
        return row


def worst_case(
    robot: Any,
    box: StateBox,
    *,
    samples: int = 2000,
    actuators: Sequence[int] | None = None,
    rng: np.random.Generator | int | None = 0,
    max_iterations: int = 100,
    backend: str = "auto",
    gradient: str = "differences",
) -> list[WorstCase]:
    """Per actuator (1-based indices, default all six), the state of ``box`` with the
    largest ``|Gamma_i|``: the worst of ``samples`` feasible states drawn in the box, then
    L-BFGS-B on ``sign * Gamma_i`` over the box (infeasible states are refused by a
    penalty).

    ``gradient``: ``"differences"`` (central differences, one batched inverse dynamics
    call per gradient) or ``"exact"`` (:meth:`StewartRobot.inverse_dynamics_derivatives`,
    the compiled exact Jacobians, built on first use: seconds once per robot; the
    rotation's chart ``exp(w) R_home`` mapped through the left Jacobian of SO(3))."""
    from scipy.optimize import minimize

    if gradient not in ("differences", "exact"):
        raise InputError(f"gradient must be 'differences' or 'exact', got {gradient!r}")

    n = int(check_scalar(samples, "samples", positive=True, integer=True))
    acts = list(range(1, 7)) if actuators is None else list(actuators)
    if not acts or any(isinstance(a, bool) or a not in range(1, 7) for a in acts):
        raise InputError(f"actuators must be indices in 1..6, got {actuators!r}")
    _ = box.half_widths  # checks the bounds before sampling
    x0s = box.sample(robot, n, rng)
    g0 = np.asarray(robot.inverse_dynamics(*box.states(robot, x0s), backend=backend))
    out: list[WorstCase] = []
    for a in acts:
        k = a - 1
        best = int(np.argmax(np.abs(g0[:, k])))
        sign = 1.0 if g0[best, k] >= 0 else -1.0
        sampled = float(abs(g0[best, k]))
        penalty = 10.0 * sampled + 1.0

        def fun(x: np.ndarray, k: int = k, sign: float = sign, penalty: float = penalty) -> Any:
            if gradient == "exact":
                return _exact_value_and_gradient(robot, box, x, k, sign, penalty)
            return _value_and_gradient(robot, box, x, k, sign, penalty, backend)

        res = minimize(
            fun,
            x0s[best],
            jac=True,
            method="L-BFGS-B",
            bounds=[(-1.0, 1.0)] * 18,
            options={"maxiter": max_iterations},
        )
        x = x0s[best]
        if res.fun < -sampled and bool(feasible(robot, box.states(robot, res.x)[0])[0]):
            x = res.x
        T, V, A = box.states(robot, x)
        effort = float(np.asarray(robot.inverse_dynamics(T, V, A, backend=backend))[0, k])
        out.append(WorstCase(a, effort, sampled, T[0], V[0], A[0]))
    return out


def _value_and_gradient(
    robot: Any,
    box: StateBox,
    x: np.ndarray,
    k: int,
    sign: float,
    penalty: float,
    backend: str,
) -> tuple[float, np.ndarray]:
    """``-sign * Gamma_k`` and its gradient at ``x`` (18,) by central differences (one
    batched call; a one-sided difference where the other side is infeasible); outside
    the feasible set, ``penalty`` with a zero gradient (the line search backs off)."""
    h = FD_STEP
    steps = np.vstack([np.zeros(18), h * np.eye(18), -h * np.eye(18)])
    xs = np.clip(x + steps, -1.0, 1.0)
    T, V, A = box.states(robot, xs)
    ok = feasible(robot, T)
    if not ok[0]:
        return penalty, np.zeros(18)
    g = np.full(xs.shape[0], np.nan)
    g[ok] = np.asarray(robot.inverse_dynamics(T[ok], V[ok], A[ok], backend=backend))[:, k]
    f0, fp, fm = g[0], g[1:19], g[19:]
    dp, dm = xs[1:19] - x, x - xs[19:]
    dp, dm = np.diag(dp), np.diag(dm)
    with np.errstate(invalid="ignore", divide="ignore"):
        central = (fp - fm) / (dp + dm)
        forward = (fp - f0) / dp
        backward = (f0 - fm) / dm
    grad = np.where(
        np.isfinite(central), central, np.where(np.isfinite(forward), forward, backward)
    )
    grad = np.where(np.isfinite(grad), grad, 0.0)
    return float(-sign * f0), -sign * grad


def _exact_value_and_gradient(
    robot: Any, box: StateBox, x: np.ndarray, k: int, sign: float, penalty: float
) -> tuple[float, np.ndarray]:
    """:func:`_value_and_gradient` from the exact Jacobians: ``D.pose`` is with respect to
    ``[dp, dtheta]`` (``R <- exp(dtheta^) R``, F0), and ``exp(w + dw) = exp(J_l(w) dw)
    exp(w)`` to first order (``J_l(w) = J_r(-w)``, pinocchio's ``Jexp3``)."""
    from pinocchio import Jexp3

    T, V, A = box.states(robot, x)
    if not bool(feasible(robot, T)[0]):
        return penalty, np.zeros(18)
    D = robot.inverse_dynamics_derivatives(T[0], V[0], A[0])
    w = np.atleast_2d(x)[0, 3:6] * box.half_widths[3:6]
    row = np.concatenate([D.pose[k, :3], D.pose[k, 3:] @ Jexp3(-w), D.twist[k], D.accel[k]])
    return float(-sign * D.gamma[k]), -sign * row * box.half_widths


# ---------------------------------------------------------------------------- capability
@dataclass(frozen=True)
class Capability:
    """The largest linear accelerations of O_p under the effort limits at one state:
    ``directions`` (K, 3) unit vectors in F0, ``accel`` (K,) [m/s^2] (the magnitude along
    each), ``angular`` (K, 3) the angular acceleration that goes with it [rad/s^2] (zero
    unless free), ``limiting`` (K,) the 1-based actuator at its limit."""

    directions: np.ndarray
    accel: np.ndarray
    angular: np.ndarray
    limiting: np.ndarray

    def table(self) -> list[dict[str, float | int]]:
        """One row per direction: ``dx, dy, dz``, ``accel`` [m/s^2], ``limiting``."""
        return [
            {
                "dx": float(d[0]),
                "dy": float(d[1]),
                "dz": float(d[2]),
                "accel": float(a),
                "limiting": int(i),
            }
            for d, a, i in zip(self.directions, self.accel, self.limiting, strict=True)
        ]


#: The default directions of :func:`dynamic_capability`: +-x, +-y, +-z of F0.
AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _effort_limits(robot: Any, effort_limits: Any, what: str) -> np.ndarray:
    """The effort limits (6,) [N or N m]: ``effort_limits`` or the description's, checked."""
    lim_src = robot.description.effort_limits if effort_limits is None else effort_limits
    if lim_src is None:
        raise InputError(
            f"{what} needs effort limits: pass effort_limits (6,) [N or N m] or "
            "set effort_limits in the robot description"
        )
    lim = np.broadcast_to(np.asarray(lim_src, dtype=float), (6,))
    if not np.all(np.isfinite(lim)) or np.any(lim <= 0):
        raise InputError(f"effort_limits must be finite and > 0, got {lim_src!r}")
    return lim


def _holds(g0: np.ndarray, lim: np.ndarray) -> None:
    """Refuse a state whose efforts ``g0`` at zero acceleration pass the limits."""
    if np.any(np.abs(g0) > lim):
        i = int(np.argmax(np.abs(g0) / lim))
        raise InputError(
            f"actuator {i + 1} needs {g0[i]:.6g} at zero acceleration, beyond its limit "
            f"{lim[i]:.6g}: the robot cannot hold this state"
        )


def dynamic_capability(
    robot: Any,
    effort_limits: Any = None,
    *,
    pose: Any = None,
    twist: Any = None,
    directions: Any = None,
    free_rotation: bool = False,
    backend: str = "auto",
) -> Capability:
    """The largest acceleration ``s`` [m/s^2] of O_p along each unit direction ``d``
    (K, 3) in F0 (default :data:`AXES`) with ``|Gamma_i| <= effort_limits_i`` (6,) [N or
    N m] (default the description's ``effort_limits``), at ``pose`` (default home) and
    ``twist`` (default rest). The angular acceleration is zero, or free (chosen by the
    linear program to help) with ``free_rotation``.

    ``Gamma = Gamma_0 + G a`` at a fixed pose and twist; ``G`` (6, 6) from seven batched
    inverse dynamics calls; then per direction ``max s`` subject to
    ``-lim <= Gamma_0 + G [s d, alpha] <= lim``, by ``scipy.optimize.linprog`` (HiGHS).

    Raises:
        InputError: no effort limits, or limits the robot already exceeds at zero
            acceleration (it cannot hold the platform at that state).
    """
    from scipy.optimize import linprog

    lim = _effort_limits(robot, effort_limits, "dynamic_capability")
    T = robot.home_pose if pose is None else np.asarray(pose, dtype=float)
    V = np.zeros(6) if twist is None else np.asarray(twist, dtype=float).reshape(6)
    D = check_directions(AXES if directions is None else directions)
    accels = np.vstack([np.zeros(6), np.eye(6)])
    g = np.asarray(
        robot.inverse_dynamics(np.tile(T, (7, 1, 1)), np.tile(V, (7, 1)), accels, backend=backend)
    )
    g0, G = g[0], (g[1:] - g[0]).T  # Gamma = g0 + G a
    _holds(g0, lim)
    out_s, out_alpha, out_i = [], [], []
    bounds = [(0.0, None)] + [(None, None) if free_rotation else (0.0, 0.0)] * 3
    for d in D:
        M = np.column_stack([G[:, :3] @ d, G[:, 3:]])  # Gamma - g0 = M [s, alpha]
        res = linprog(
            c=[-1.0, 0.0, 0.0, 0.0],
            A_ub=np.vstack([M, -M]),
            b_ub=np.concatenate([lim - g0, lim + g0]),
            bounds=bounds,
            method="highs",
        )
        if res.status == 3:  # unbounded: no actuator opposes this direction
            raise InputError(f"the acceleration along {d} is unbounded under the limits")
        s, alpha = float(res.x[0]), np.asarray(res.x[1:])
        gamma = g0 + M @ res.x
        out_s.append(s)
        out_alpha.append(alpha)
        out_i.append(int(np.argmax(np.abs(gamma) / lim)) + 1)
    return Capability(D, np.array(out_s), np.array(out_alpha), np.array(out_i))


@dataclass(frozen=True)
class WrenchCapability:
    """The largest static wrench the platform can exert under the effort limits at one
    pose: ``directions`` (K, 3) unit vectors in F0, ``kind`` ``"force"`` (a force at O_p
    along each direction [N], no moment) or ``"moment"`` (a moment about each direction
    [N m], no force), ``magnitude`` (K,) and ``limiting`` (K,) the 1-based actuator at its
    limit."""

    directions: np.ndarray
    kind: str
    magnitude: np.ndarray
    limiting: np.ndarray

    def table(self) -> list[dict[str, float | int | str]]:
        """One row per direction: ``dx, dy, dz``, ``kind``, ``magnitude``, ``limiting``."""
        return [
            {
                "dx": float(d[0]),
                "dy": float(d[1]),
                "dz": float(d[2]),
                "kind": self.kind,
                "magnitude": float(m),
                "limiting": int(i),
            }
            for d, m, i in zip(self.directions, self.magnitude, self.limiting, strict=True)
        ]


def wrench_capability(
    robot: Any,
    effort_limits: Any = None,
    *,
    pose: Any = None,
    directions: Any = None,
    kind: str = "force",
    backend: str = "auto",
) -> WrenchCapability:
    """The largest static wrench the platform can exert on its surroundings along each unit
    direction ``d`` (K, 3) in F0 (default :data:`AXES`) with ``|Gamma_i| <=
    effort_limits_i`` (6,) [N or N m] (default the description's ``effort_limits``), at
    ``pose`` (default home), at rest, its own weight and the legs' held: a force ``s d``
    at O_p [N] (``kind="force"``) or a moment ``s d`` [N m] (``kind="moment"``).

    At rest the actuators' efforts beyond those holding the robot, ``Gamma - Gamma_0``,
    balance the wrench ``w = [f, m]`` the surroundings exert back on the platform through
    the virtual work ``Gamma . qdot_a = w_act . [v, w]``: ``J_inv^T (Gamma - Gamma_0) = w``
    (``J_inv`` the inverse Jacobian, ``qdot_a = J_inv [v, w]``), so ``Gamma = Gamma_0 +
    J_inv^-T w`` and per direction ``max s`` subject to ``-lim <= Gamma <= lim`` by
    ``scipy.optimize.linprog`` (HiGHS).

    Raises:
        InputError: no effort limits, limits the robot already exceeds at rest, a ``kind``
            other than ``"force"`` or ``"moment"``, or a direction no actuator opposes.
    """
    from scipy.optimize import linprog

    if kind not in ("force", "moment"):
        raise InputError(f"kind must be 'force' or 'moment', got {kind!r}")
    lim = _effort_limits(robot, effort_limits, "wrench_capability")
    T = robot.home_pose if pose is None else np.asarray(pose, dtype=float)
    D = check_directions(AXES if directions is None else directions)
    g0 = np.asarray(robot.inverse_dynamics(T, np.zeros(6), np.zeros(6), backend=backend))
    _holds(g0, lim)
    K = np.linalg.solve(np.asarray(robot.inverse_jacobian(T)).T, np.eye(6))  # J_inv^-T
    cols = K[:, :3] if kind == "force" else K[:, 3:]
    out_s, out_i = [], []
    for d in D:
        m = cols @ d  # Gamma - g0 = m s
        res = linprog(
            c=[-1.0],
            A_ub=np.concatenate([m, -m])[:, None],
            b_ub=np.concatenate([lim - g0, lim + g0]),
            bounds=[(0.0, None)],
            method="highs",
        )
        if res.status == 3:  # unbounded: no actuator takes this wrench
            raise InputError(f"the {kind} along {d} is unbounded under the limits")
        s = float(res.x[0])
        out_s.append(s)
        out_i.append(int(np.argmax(np.abs(g0 + m * s) / lim)) + 1)
    return WrenchCapability(D, kind, np.array(out_s), np.array(out_i))


# ---------------------------------------------------------------------------- report
def _write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    import csv

    with atomic_open(path) as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        for row in rows:
            w.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})


def write_report(
    folder: str | Path,
    loads: ActuatorLoads | None = None,
    worst: Sequence[WorstCase] | None = None,
    capability: Capability | None = None,
    html: bool = False,
) -> list[Path]:
    """Write the given tables into ``folder`` (created): ``loads.csv``, ``worst_case.csv``,
    ``capability.csv`` and all of them in ``report.json``; with ``html``, also
    ``report.html``, one standalone page with the tables and their plots (PNG embedded;
    needs matplotlib, the viz extra). Returns the paths written."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    tables: dict[str, list[dict[str, Any]]] = {}
    if loads is not None:
        tables["loads"] = [dict(r) for r in loads.table()]
    if worst:
        tables["worst_case"] = [w.row() for w in worst]
    if capability is not None:
        tables["capability"] = [dict(r) for r in capability.table()]
    written = []
    for name, rows in tables.items():
        _write_csv(out / f"{name}.csv", rows)
        written.append(out / f"{name}.csv")
    with atomic_open(out / "report.json") as f:
        json.dump(tables, f, indent=1)
        f.write("\n")
    written.append(out / "report.json")
    if html:
        with atomic_open(out / "report.html") as f:
            f.write(_html(tables, loads, capability))
        written.append(out / "report.html")
    return written


def _png(fig: Any) -> str:
    import base64
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _html(
    tables: dict[str, list[dict[str, Any]]],
    loads: ActuatorLoads | None,
    capability: Capability | None,
) -> str:
    """The standalone page of :func:`write_report` (every cell escaped)."""
    from html import escape

    (figure,) = require("the HTML report's plots", "viz", "matplotlib.figure")
    Figure = figure.Figure
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        "<title>stewart-pin actuator sizing</title></head><body>",
        "<h1>Actuator sizing</h1>",
    ]
    if loads is not None:
        fig = Figure(figsize=(8, 3.5), layout="constrained")
        ax = fig.subplots()
        rows = tables["loads"]
        x = np.arange(1, 7)
        ax.bar(x - 0.2, [r["peak_effort"] for r in rows], 0.4, label="peak")
        ax.bar(x + 0.2, [r["rms_effort"] for r in rows], 0.4, label="RMS")
        ax.set_xlabel("actuator")
        ax.set_ylabel("effort [N or N m]")
        ax.legend()
        parts.append(f"<img alt='efforts' src='data:image/png;base64,{_png(fig)}'>")
    if capability is not None:
        fig = Figure(figsize=(8, 3.5), layout="constrained")
        ax = fig.subplots()
        labels = [f"({d[0]:.2g}, {d[1]:.2g}, {d[2]:.2g})" for d in capability.directions]
        ax.bar(labels, capability.accel)
        ax.set_xlabel("direction in F0")
        ax.set_ylabel("largest acceleration [m/s^2]")
        parts.append(f"<img alt='capability' src='data:image/png;base64,{_png(fig)}'>")
    for name, rows in tables.items():
        parts.append(f"<h2>{escape(name.replace('_', ' '))}</h2><table border='1'><tr>")
        parts += [f"<th>{escape(str(k))}</th>" for k in rows[0]]
        parts.append("</tr>")
        for row in rows:
            cells = (f"{v:.6g}" if isinstance(v, float) else str(v) for v in row.values())
            parts.append("<tr>" + "".join(f"<td>{escape(c)}</td>" for c in cells) + "</tr>")
        parts.append("</table>")
    parts.append("</body></html>\n")
    return "\n".join(parts)
