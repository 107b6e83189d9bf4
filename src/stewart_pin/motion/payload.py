"""Motion with a payload on the platform: the payload's joint trajectory, computed-torque
control of the hexapod that accounts for it, and the simulation of both.

The payload's joints follow a :class:`JointMotion` (prescribed: the arm runs its own
trajectory under its own controller, whatever torque that takes), while the hexapod's
platform obeys the coupled direct model
(:meth:`~stewart_pin.payload_robot.PayloadRobot.direct_dynamics` with ``qdd`` given)
under the hexapod's actuator efforts. :class:`PayloadComputedTorque` is the hexapod's
computed-torque law with the coupled inverse model: it compensates the arm's reaction
(with an exact model, the platform tracks its reference whatever the arm does).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, check_scalar
from stewart_pin._io import atomic_open
from stewart_pin.exceptions import FileFormatError, InputError, PayloadError
from stewart_pin.formats.csv_tables import read_npz
from stewart_pin.models.payload import Payload
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.simulation import ForceFunction, SimulationResult, simulate
from stewart_pin.protocols import PayloadRobotLike

__all__ = [
    "JointMotion",
    "PayloadComputedTorque",
    "PayloadSimulation",
    "simulate_payload",
]

#: ``s(t) -> (s, sd, sdd)``, each (nv,): the joint displacement from ``q0`` and its rates.
Displacement = Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]


def _minimum_jerk(tau: float) -> tuple[float, float, float]:
    """``10 t^3 - 15 t^4 + 6 t^5`` and its first two derivatives, ``t`` clipped to [0, 1]."""
    if tau <= 0.0:
        return 0.0, 0.0, 0.0
    if tau >= 1.0:
        return 1.0, 0.0, 0.0
    return (
        tau**3 * (10 - 15 * tau + 6 * tau**2),
        30 * tau**2 * (1 - tau) ** 2,
        60 * tau * (1 - tau) * (1 - 2 * tau),
    )


@dataclass(frozen=True)
class JointMotion:
    """The payload's joint trajectory ``q(t) = integrate(q0, s(t))``,
    ``qd = ds/dt``, ``qdd = d^2 s/dt^2`` (exact for joints of one degree of freedom or
    translations, which are all the payload may have here).

    Attributes:
        payload: the payload. q0: (nq,) the configuration at zero displacement.
        displacement: ``t -> (s, sd, sdd)`` each (nv,). duration: [s].
    """

    payload: Payload
    q0: np.ndarray
    displacement: Displacement = field(repr=False)
    duration: float

    def __post_init__(self) -> None:
        model = self.payload.model
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nv > 1 and joint.nq != joint.nv:
                raise PayloadError(
                    f"joint '{model.names[j]}' ({joint.shortname()}) turns in 3-D: a "
                    "JointMotion is defined for joints of one degree of freedom and "
                    "translations"
                )
        q0, _ = self.payload.check_configurations(self.q0, "q0")
        object.__setattr__(self, "q0", q0[0])
        check_scalar(self.duration, "duration", positive=True, unit="s")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def still(cls, payload: Payload, q: Any = None, duration: float = 1.0) -> JointMotion:
        """The payload held at ``q`` (default its home configuration)."""
        zero = np.zeros(payload.nv)
        q0 = payload.home_configuration() if q is None else q
        return cls(payload, q0, lambda t: (zero, zero, zero), duration)

    @classmethod
    def sinusoid(
        cls,
        payload: Payload,
        amplitude: Any,
        period: float,
        duration: float | None = None,
        q0: Any = None,
    ) -> JointMotion:
        """``s_k(t) = a_k sin(2 pi t / period)`` about ``q0`` (default the home
        configuration); ``amplitude`` (nv,) or a scalar [rad or m]."""
        a = check_array(np.broadcast_to(amplitude, (payload.nv,)), (payload.nv,), "amplitude")
        T = check_scalar(period, "period", positive=True, unit="s")
        w = 2 * np.pi / T

        def s(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            return a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)

        q = payload.home_configuration() if q0 is None else q0
        return cls(payload, q, s, T if duration is None else duration)

    @classmethod
    def sweep(
        cls,
        payload: Payload,
        fraction: float = 0.25,
        period: float = 1.0,
        duration: float | None = None,
    ) -> JointMotion:
        """Every joint swinging about the home configuration by ``fraction`` of its room
        there (:meth:`Payload.room`: the distance to its nearer limit, at most its
        half-range and pi; at the middle of the range, the half-range) in a sinusoid of
        ``period`` [s], joint k ahead by ``k / nv`` of a period (already moving at t = 0):
        within the limits by construction (``fraction`` in (0, 1])."""
        f = check_scalar(fraction, "fraction", positive=True)
        if f > 1.0:
            raise InputError(f"fraction must be in (0, 1], got {fraction}")
        T = check_scalar(period, "period", positive=True, unit="s")
        nv = payload.nv
        a = f * payload.room()
        w = 2 * np.pi / T
        phase = 2 * np.pi * np.arange(nv) / max(nv, 1)

        def s(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            x = w * t + phase
            return (
                a * np.sin(x),
                a * w * np.cos(x),
                -a * w * w * np.sin(x),
            )

        return cls(payload, payload.home_configuration(), s, T if duration is None else duration)

    @classmethod
    def point_to_point(
        cls,
        payload: Payload,
        start: Any,
        goal: Any,
        duration: float,
        hold: float = 0.0,
    ) -> JointMotion:
        """From ``start`` to ``goal`` (configurations (nq,)) by a minimum-jerk profile of
        ``duration`` [s] (zero rate and acceleration at both ends), then held for
        ``hold`` [s]."""
        model = payload.model
        q_start, _ = payload.check_configurations(start, "start")
        q_goal, _ = payload.check_configurations(goal, "goal")
        delta = np.asarray(pin.difference(model, q_start[0], q_goal[0]))
        T = check_scalar(duration, "duration", positive=True, unit="s")
        if not hold >= 0:
            raise InputError(f"hold must be >= 0 s, got {hold}")

        def s(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            x, xd, xdd = _minimum_jerk(t / T)
            return delta * x, delta * xd / T, delta * xdd / T**2

        return cls(payload, q_start[0], s, T + hold)

    # ------------------------------------------------------------------ evaluation
    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q (nq,), qd (nv,), qdd (nv,))`` at time ``t`` [s]."""
        s, sd, sdd = self.displacement(float(t))
        q = np.asarray(pin.integrate(self.payload.model, self.q0, np.asarray(s, dtype=float)))
        return q, np.asarray(sd, dtype=float), np.asarray(sdd, dtype=float)

    def sample(self, times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q (K, nq), qd (K, nv), qdd (K, nv))`` at ``times`` (K,) [s]."""
        t = check_array(times, (None,), "times")
        out = [self(tk) for tk in t]
        K, nq, nv = len(t), self.payload.nq, self.payload.nv  # nq = nv = 0: a fixed tool
        return (
            np.array([o[0] for o in out]).reshape(K, nq),
            np.array([o[1] for o in out]).reshape(K, nv),
            np.array([o[2] for o in out]).reshape(K, nv),
        )

    def check_limits(self, n_samples: int = 201) -> None:
        """:class:`PayloadError` naming the first joint the motion takes outside its
        position limits (sampled at ``n_samples`` instants)."""
        q, _, _ = self.sample(np.linspace(0.0, self.duration, n_samples))
        model = self.payload.model
        lo, hi = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
        bad = (q < lo - 1e-12) | (q > hi + 1e-12)
        if bad.any():
            k, i = np.argwhere(bad)[0]
            name = next(
                model.names[j]
                for j in range(1, model.njoints)
                if model.joints[j].idx_q <= i < model.joints[j].idx_q + model.joints[j].nq
            )
            raise PayloadError(
                f"the payload's joint '{name}' reaches {q[k, i]:.6g}, outside its limits "
                f"[{lo[i]:.6g}, {hi[i]:.6g}]: reduce the motion's amplitude"
            )


@dataclass
class PayloadComputedTorque(ComputedTorqueController):
    """The hexapod's computed-torque law with the coupled inverse model:
    ``Gamma = IDM(T, V, A_cmd, q(t), qd(t), qdd(t))`` (the arm's reaction compensated).

    Args (besides :class:`~stewart_pin.motion.control.ComputedTorqueController`'s):
        joints: the payload's joint trajectory the controller expects (its model's).
    """

    #: the hexapod carrying the payload (a PayloadRobotLike), whose coupled inverse
    #: model the law uses
    model: Any
    joints: JointMotion | None = None

    def __call__(self, t: float, T: np.ndarray, V: np.ndarray, idle: Any = None) -> np.ndarray:
        if idle is not None:
            raise InputError(
                "PayloadComputedTorque takes no idle state: a payload on a robot whose legs "
                "have idle freedoms is not modelled"
            )
        if self.joints is None:
            raise InputError("PayloadComputedTorque needs the payload's joints (a JointMotion)")
        q, qd, qdd = self.joints(t)
        carrier: Any = self.model  # a PayloadRobotLike
        out = carrier.inverse_dynamics(
            T, V, self.command(t, T, V), q, qd, qdd, backend=self.backend
        )
        return np.asarray(out.gamma, dtype=float)


# ---------------------------------------------------------------------------- simulation
_FIELDS = ("q", "qd", "qdd", "tau")


@dataclass(frozen=True)
class PayloadSimulation:
    """A simulated motion of hexapod and payload.

    Attributes:
        result: the hexapod's :class:`~stewart_pin.motion.simulation.SimulationResult`
            (platform states, actuator efforts, actuator positions).
        q: (K, nq) the payload's configurations at ``result.t``; qd, qdd: (K, nv) its
            joint rates and accelerations; tau: (K, nv) the joint torques they took.
    """

    result: SimulationResult
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray

    def save(self, path: str | Path) -> tuple[Path, Path]:
        """Write the hexapod's result to ``path`` (``.npz`` or ``.csv``) and the payload's
        joints to the sidecar :func:`payload_path` (``<stem>.payload.npz``: t, q, qd, qdd,
        tau); returns both paths."""
        path = Path(path)
        self.result.save(path)
        side = payload_path(path)
        with atomic_open(side, "wb") as handle:
            np.savez(handle, t=self.result.t, **{k: getattr(self, k) for k in _FIELDS})
        return path, side

    @staticmethod
    def load_joints(path: str | Path, payload: Payload) -> tuple[np.ndarray, np.ndarray]:
        """``(t (K,), q (K, nq))`` of ``payload`` from a sidecar written by :meth:`save`
        (give the sidecar or the result file beside it)."""
        path = Path(path)
        side = path if path.name.endswith(".payload.npz") else payload_path(path)
        if not side.is_file():
            raise FileFormatError(f"no payload joints beside {path}: {side} is missing")
        arrays = read_npz(side, {"t": (None,), "q": (None, payload.nq)})
        q, _ = payload.check_configurations(arrays["q"])
        return arrays["t"], q


def payload_path(result_path: str | Path) -> Path:
    """Where the payload's joints of a simulation saved to ``result_path`` go:
    ``<stem>.payload.npz`` beside it."""
    p = Path(result_path)
    return p.with_name(f"{p.stem}.payload.npz")


class _PrescribedJoints:
    """:func:`simulate_payload`'s direct model (``simulate``'s ``dynamics``): the coupled
    direct model with the payload's joints following ``joints`` (its default backend);
    :meth:`compiled_payload` gives the compiled simulator
    (:mod:`stewart_pin.codegen.simulator`) the same model and the joints at given times."""

    def __init__(self, robot: PayloadRobotLike, joints: JointMotion) -> None:
        self.robot, self.joints = robot, joints

    def __call__(self, t: float, T: np.ndarray, V: np.ndarray, gamma: np.ndarray) -> np.ndarray:
        q, qd, qdd = self.joints(t)
        return np.asarray(self.robot.direct_dynamics(T, V, gamma, q, qd, qdd).accel, dtype=float)

    def compiled_payload(self) -> Any:
        """The compiled coupled models :meth:`__call__` runs (``None``: the reference
        path's)."""
        fast = getattr(self.robot, "_fast_backend", None)
        return None if fast is None else fast("auto")

    def joints_at(self, times: np.ndarray) -> np.ndarray:
        """``[q, qd, qdd]`` (K, nq + 2 nv) at ``times`` (K,) [s], as :meth:`__call__` takes
        them: the displacement evaluated on all times at once where it broadcasts (the
        motions of :class:`JointMotion`'s constructors but the minimum-jerk one) and
        ``q0`` integrated joint by joint as ``pin.integrate`` does (to round-off), else one
        call of ``joints`` per time."""
        out = _joints_at_once(self.joints, times)
        if out is None:
            q, qd, qdd = self.joints.sample(times)
            out = np.hstack([q, qd, qdd])
        return np.ascontiguousarray(out, dtype=np.float64)


def _joints_at_once(motion: JointMotion, times: np.ndarray) -> np.ndarray | None:
    """``[q, qd, qdd]`` (K, nq + 2 nv) of ``motion`` at ``times`` in array operations, or
    None where its displacement does not broadcast over ``times[:, None]`` or a joint is
    none of those integrated here (one degree of freedom: ``q0 + s``; an unbounded
    revolute's ``(cos, sin)`` turned by ``s``, renormalised as Pinocchio does)."""
    model, K, nv = motion.payload.model, times.size, motion.payload.nv
    try:
        at_times: Any = motion.displacement  # called with (K, 1) times: broadcasts or fails
        parts = [np.asarray(a, dtype=float) for a in at_times(times[:, None])]
    except Exception:
        return None
    if len(parts) != 3 or any(a.shape != (K, nv) for a in parts):
        return None
    s = parts[0]
    q = np.repeat(motion.q0[None], K, 0)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        iq, iv = joint.idx_q, joint.idx_v
        if joint.nq == joint.nv == 1:
            q[:, iq] = motion.q0[iq] + s[:, iv]
        elif joint.nq == 2 and joint.nv == 1 and joint.shortname().startswith("JointModelRUB"):
            c0, s0 = motion.q0[iq], motion.q0[iq + 1]
            cw, sw = np.cos(s[:, iv]), np.sin(s[:, iv])
            c1, s1 = c0 * cw - s0 * sw, s0 * cw + c0 * sw
            scale = (3.0 - (c1 * c1 + s1 * s1)) / 2.0
            q[:, iq], q[:, iq + 1] = c1 * scale, s1 * scale
        else:
            return None
    return np.hstack([q, parts[1], parts[2]])


def simulate_payload(
    robot: PayloadRobotLike,
    duration: float,
    joints: JointMotion,
    pose: Any = None,
    twist: Any = None,
    forces: ForceFunction | None = None,
    **kwargs: Any,
) -> PayloadSimulation:
    """Integrate the platform's motion under the hexapod's efforts ``forces(t, T, V)``
    while the payload's joints follow ``joints`` (prescribed): the coupled direct model
    with ``qdd`` given (:meth:`PayloadRobot.direct_dynamics`). The other arguments are
    :func:`~stewart_pin.motion.simulation.simulate`'s (``robot.robot`` gives the limits
    and singularities); a run that stops raises its ``SimulationError`` as ``simulate``.

    With ``method="rk4"`` and the payload's compiled models the steps run in the compiled
    simulator (:mod:`stewart_pin.codegen.simulator`; ``integrator`` as ``simulate``'s).

    Returns:
        the :class:`PayloadSimulation`: the hexapod's result, and the payload's joints and
        torques at its times (torques from the coupled inverse model at the simulated
        states, equal to the direct model's).
    """
    if joints.payload is not robot.payload:
        raise InputError("joints must be a JointMotion of this robot's payload")
    dynamics = _PrescribedJoints(robot, joints)
    result = simulate(robot.robot, duration, pose, twist, forces, dynamics=dynamics, **kwargs)
    q, qd, qdd = joints.sample(result.t)
    if len(result.t):
        tau = robot.inverse_dynamics(result.poses, result.twists, result.accels, q, qd, qdd).tau
    else:
        tau = np.zeros((0, robot.payload.nv))
    return PayloadSimulation(result, q, qd, qdd, np.asarray(tau, dtype=float))
