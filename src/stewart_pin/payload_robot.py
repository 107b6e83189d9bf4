"""``PayloadRobot``: a hexapod carrying a payload (a robot arm, a camera head...) on its
platform. ``robot.with_payload("ur5")`` builds one.

The payload is a fixed-base Pinocchio model (:mod:`stewart_pin.models.payload`: a
``pin.Model``, a URDF, or a robot of example-robot-data by name) mounted at ``T_p_b`` in
``Fp``. Its joint state ``(q, qd, qdd)`` joins the platform's; the models
(:mod:`stewart_pin.dynamics.payload`) are

- inverse: ``Gamma = Gamma_hexapod + Jp^T W`` and the payload's joint torques ``tau``,
  ``W`` the wrench the platform applies to the payload (Pinocchio's RNEA on the payload
  with the platform's motion as its base motion);
- direct, the payload's joints either **prescribed** (``qdd`` given: the arm runs its own
  trajectory, whatever torque that takes) or **torque-driven** (``tau`` given: the
  coupled mass matrix of platform and payload solved for both accelerations).

Conventions as :class:`~stewart_pin.robot.StewartRobot` (pose 0Tp, twist ``[v, w]`` and
classical acceleration in F0, one state or a batch with a leading N axis), plus the
payload's Pinocchio configuration ``q`` (nq,), rates, accelerations and torques (nv,).
Both leg paths (ideal 6-UPS and general legs) work. ``backend="auto"`` (the default of
the models) runs the coupled models compiled to C
(:mod:`stewart_pin.codegen.payload_compiled`: the hexapod's closed form and the payload's
Newton-Euler generated together, built on first use and cached) where a C compiler is
available, as :class:`~stewart_pin.robot.StewartRobot` does; ``backend="pinocchio"`` the
reference path (Pinocchio's RNEA and CRBA on the payload), ``"compiled"`` the compiled
models always.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_poses, check_states
from stewart_pin._typing import ArrayLike, FloatArray, Pose
from stewart_pin.description import RobotDescription
from stewart_pin.dynamics.closed_loop import check_finite
from stewart_pin.dynamics.payload import (
    PayloadAcceleration,
    PayloadDynamics,
    PayloadEfforts,
    PayloadInverseDynamics,
    coupled_direct_dynamics,
    coupled_mass_matrix,
    prescribed_direct_dynamics,
)
from stewart_pin.exceptions import InputError, InputTypeError, PayloadError
from stewart_pin.models.payload import Payload, load_payload

if TYPE_CHECKING:
    from stewart_pin.robot import StewartRobot

__all__ = ["PayloadRobot", "PayloadStates", "default_placement"]


class PayloadStates(NamedTuple):
    """Random states of a hexapod and its payload: ``poses`` (N, 4, 4), ``twists`` and
    ``accels`` (N, 6) (classical, F0), the payload's ``q`` (N, nq), ``qd`` and ``qdd``
    (N, nv)."""

    poses: FloatArray
    twists: FloatArray
    accels: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray


#: Height of the default mount above the platform joints' plane, a fraction of the
#: robot's size: the top face of the platform as the viewer draws it.
DECK_HEIGHT = 0.1


def default_placement(description: RobotDescription) -> FloatArray:
    """``T_p_b`` (4, 4) of a payload mounted on the platform's deck: origin above the
    centroid of the platform joints ``P_i``, by :data:`DECK_HEIGHT` times the robot's
    size along ``Fp``'s z axis (the top face of the drawn platform), axes along
    ``Fp``'s."""
    T = np.eye(4)
    T[:3, 3] = np.asarray(description.platform_points, dtype=float).mean(axis=0)
    T[2, 3] += DECK_HEIGHT * float(description.size)
    return T


#: The backends of the coupled models (as :data:`stewart_pin.robot.BACKENDS`).
BACKENDS = ("pinocchio", "compiled", "auto")
#: Where a PayloadRobot keeps its compiled backends
#: (:data:`stewart_pin.codegen.payload_compiled.PAYLOAD_ATTR`).
_BACKENDS_ATTR = "_stewart_pin_payload_backends"


def _quiet() -> np.errstate:
    return np.errstate(over="ignore", invalid="ignore")


class PayloadRobot:
    """A hexapod with a payload on its platform.

    Args:
        robot: the hexapod (a :class:`~stewart_pin.StewartRobot`).
        payload: a :class:`~stewart_pin.models.payload.Payload`, a ``pin.Model`` with a
            fixed base, a URDF path, or a robot name of example-robot-data (``"ur5"``).
        placement: ``T_p_b`` (4, 4) or ``pin.SE3``, the payload's base frame in ``Fp``
            (default: a :class:`Payload` keeps its own; anything else is mounted at
            :func:`default_placement`, on the platform's deck above the centroid of the
            platform joints, axes along ``Fp``'s).

    Example::

        arm = StewartRobot.from_preset("simulator").with_payload("ur5")
        gamma, tau = arm.inverse_dynamics(T, V, A, q, qd, qdd)
        accel, qdd, tau = arm.direct_dynamics(T, V, gamma, q, qd, tau=tau)
    """

    def __init__(self, robot: StewartRobot, payload: Any, placement: Any = None) -> None:
        if not hasattr(robot, "inverse_dynamics") or not hasattr(robot, "description"):
            raise InputTypeError(f"PayloadRobot takes a StewartRobot, got {type(robot).__name__}")
        # the coupled models are the description's: the hexapod speaks its description's
        # actuator convention here (an imported one's file convention is not carried over)
        own = getattr(robot, "description_convention", None)
        self.robot = own() if callable(own) else robot
        if placement is None and not isinstance(payload, Payload):
            placement = default_placement(robot.description)
        self.payload: Payload = load_payload(payload, placement)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without its compiled backends (loaded libraries; found again in the
        cache on first use) nor the Pinocchio data of its reference path."""
        skip = (_BACKENDS_ATTR, "dynamics")
        return {k: v for k, v in self.__dict__.items() if k not in skip}

    def __repr__(self) -> str:
        return f"PayloadRobot('{self.robot.name}', {self.payload!r})"

    # ------------------------------------------------------------------ the parts
    @cached_property
    def dynamics(self) -> PayloadDynamics:
        """Pinocchio's RNEA and CRBA on the payload on a free-flyer (the hexapod's
        gravity)."""
        return PayloadDynamics(self.payload, self.robot.description.gravity)

    @property
    def description(self) -> RobotDescription:
        """The hexapod's description."""
        return self.robot.description

    @property
    def max_condition(self) -> float:
        return self.robot.max_condition

    @property
    def name(self) -> str:
        return f"{self.robot.name}+{self.payload.name}"

    @property
    def home_pose(self) -> Pose:
        return self.robot.home_pose

    @property
    def nq(self) -> int:
        return self.payload.nq

    @property
    def nv(self) -> int:
        return self.payload.nv

    def home_configuration(self) -> FloatArray:
        """The payload's home configuration (nq,): Pinocchio's neutral one, inside the
        joint limits."""
        return self.payload.home_configuration()

    def with_placement(self, placement: Any) -> PayloadRobot:
        """The same hexapod and payload, mounted at another ``T_p_b``."""
        return PayloadRobot(self.robot, self.payload, placement)

    # ------------------------------------------------------------------ inputs
    def _joints(
        self, n: int, batched: bool, q: Any, *rates: tuple[Any, str]
    ) -> tuple[FloatArray, ...]:
        Q, b = self.payload.check_configurations(q)
        if b != batched or Q.shape[0] != n:
            want = f"a batch ({n}, {self.nq})" if batched else f"one vector ({self.nq},)"
            raise InputError(f"payload q must be {want} to match the states, got {np.shape(q)}")
        return (Q, *(self.payload.check_rates(v, name, n, batched) for v, name in rates))

    # ------------------------------------------------------------------ geometry
    def base_pose(self, pose: ArrayLike) -> FloatArray:
        """``T_0_b``: the payload's base frame in F0, (4, 4) or (N, 4, 4)."""
        T, batched = check_poses(pose)
        out = T @ np.asarray(self.payload.placement)
        return out if batched else out[0]

    def frame_pose(self, pose: ArrayLike, q: ArrayLike, frame: str) -> FloatArray:
        """The pose in F0 (4, 4) (or (N, 4, 4)) of the payload's frame ``frame`` (a frame
        of its Pinocchio model: a link or a tool frame) at platform pose ``pose`` and
        payload configuration ``q``."""
        T, batched = check_poses(pose)
        (Q,) = self._joints(len(T), batched, q)
        model = self.payload.model
        if not model.existFrame(frame):
            names = ", ".join(f.name for f in model.frames)
            raise PayloadError(f"payload '{self.payload.name}' has no frame '{frame}': {names}")
        fid = model.getFrameId(frame)
        data = model.createData()
        out = np.empty((len(T), 4, 4))
        base = T @ np.asarray(self.payload.placement)
        for k in range(len(T)):
            pin.framesForwardKinematics(model, data, Q[k])
            out[k] = base[k] @ data.oMf[fid].homogeneous
        return out if batched else out[0]

    # ------------------------------------------------------------------ dynamics
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        qdd: ArrayLike,
        details: bool = False,
        backend: str = "auto",
    ) -> PayloadEfforts | PayloadInverseDynamics:
        """The hexapod's actuator efforts and the payload's joint torques realising the
        platform's motion and the payload's joint motion.

        Args:
            pose: 0Tp (4, 4) or (N, 4, 4). twist: ``[v, w]`` in F0, (6,) or (N, 6).
            accel: classical ``[dv/dt, dw/dt]`` in F0, (6,) or (N, 6).
            q: the payload's configuration (nq,) or (N, nq); qd, qdd: its joint rates and
                accelerations (nv,) or (N, nv).
            details: return the :class:`~stewart_pin.dynamics.payload.PayloadInverseDynamics`
                (batches) with the payload's wrench and each share of Gamma.
            backend: ``"auto"`` (default: the compiled coupled models where a C compiler is
                available, else the reference path; ``details=True`` takes the reference
                path), ``"pinocchio"`` (the reference: Pinocchio's RNEA on the payload, the
                hexapod's own reference model) or ``"compiled"`` (the coupled models
                compiled to C, :mod:`stewart_pin.codegen.payload_compiled`; same results
                and errors).

        Returns:
            ``PayloadEfforts(gamma, tau)``: gamma (6,) or (N, 6) [N or N m], tau (nv,) or
            (N, nv) [N m or N].
        """
        fast = self._fast_backend(backend, details)
        if fast is not None:
            return fast.inverse_dynamics(pose, twist, accel, q, qd, qdd)
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        Q, Qd, Qdd = self._joints(len(T), batched, q, (qd, "payload qd"), (qdd, "payload qdd"))
        hexapod = "pinocchio" if backend == "pinocchio" else "auto"
        gamma_hex = np.asarray(self.robot.inverse_dynamics(T, V, A, backend=hexapod))
        with _quiet():
            W, tau = self.dynamics.inverse(T, V, A, Q, Qd, Qdd)
            J_inv = np.asarray(self.robot.inverse_jacobian(T)).reshape(-1, 6, 6)
            share = np.asarray(
                np.linalg.solve(np.swapaxes(J_inv, 1, 2), W[..., None])[..., 0], dtype=np.float64
            )
            gamma = check_finite(gamma_hex + share, "inverse dynamics Gamma")
        if details:
            return PayloadInverseDynamics(gamma, tau, W, gamma_hex, share)
        if batched:
            return PayloadEfforts(gamma, tau)
        return PayloadEfforts(gamma[0], tau[0])

    def direct_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        gamma: ArrayLike,
        q: ArrayLike,
        qd: ArrayLike,
        qdd: ArrayLike = None,
        *,
        tau: ArrayLike = None,
        backend: str = "auto",
    ) -> PayloadAcceleration:
        """The platform's classical acceleration under the actuator efforts ``gamma``,
        with the payload's joints either following ``qdd`` (prescribed motion) or driven
        by the torques ``tau`` (give exactly one).

        Args:
            pose, twist: the platform's state (one or a batch). gamma: (6,) or (N, 6).
            q, qd: the payload's configuration and joint rates.
            qdd: prescribed joint accelerations (nv,) or (N, nv); or
            tau: the payload's joint torques (nv,) or (N, nv).
            backend: ``"auto"`` (default), ``"pinocchio"`` or ``"compiled"``, as in
                :meth:`inverse_dynamics`.

        Returns:
            ``PayloadAcceleration(accel, qdd, tau)``: the platform's acceleration (6,) or
            (N, 6), the joint accelerations (given or computed) and the joint torques
            (given, or those the prescribed motion takes).

        Raises:
            InputError: neither or both of ``qdd`` and ``tau``.
            SingularityError: a singular pose, or a coupled mass matrix that is not
                positive definite.
        """
        if (qdd is None) == (tau is None):
            raise InputError(
                "give the payload's joint accelerations qdd (prescribed motion) or its joint "
                "torques tau (keyword), exactly one"
            )
        fast = self._fast_backend(backend)
        if fast is not None:
            return fast.direct_dynamics(pose, twist, gamma, q, qd, qdd, tau)
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        given = (qdd, "payload qdd") if tau is None else (tau, "payload tau")
        Q, Qd, X = self._joints(len(T), batched, q, (qd, "payload qd"), given)
        cd = self.robot.cartesian_dynamics(T, V)
        with _quiet():
            terms = self.dynamics.coupled_terms(T, V, Q, Qd)
            if tau is None:
                accel, torques = prescribed_direct_dynamics(
                    cd.A_robot, cd.h_robot, cd.J_inv, G, terms, X
                )
                out = PayloadAcceleration(accel, X, torques)
            else:
                accel, joint_accel = coupled_direct_dynamics(
                    cd.A_robot, cd.h_robot, cd.J_inv, G, terms, X
                )
                out = PayloadAcceleration(accel, joint_accel, X)
        if batched:
            return out
        return PayloadAcceleration(out.accel[0], out.qdd[0], out.tau[0])

    def _fast_backend(self, backend: str, details: bool = False) -> Any:
        """The compiled coupled models serving a call, or ``None`` for the reference path
        (:func:`stewart_pin.codegen.payload_compiled.payload_backend`); an unknown backend,
        or ``details=True`` with ``"compiled"``, raises :class:`InputError`."""
        memo = self.__dict__.get(_BACKENDS_ATTR)
        if memo is not None and not details and type(backend) is str and backend in memo:
            return memo[backend]
        if backend not in BACKENDS:
            raise InputError(f"unknown backend '{backend}': choose one of {BACKENDS}")
        if backend == "pinocchio" or (details and backend == "auto"):
            return None
        if details:
            raise InputError(
                "details=True needs backend='pinocchio' (the compiled models return the "
                "efforts and torques)"
            )
        from stewart_pin.codegen.payload_compiled import payload_backend

        return payload_backend(self, backend)

    def mass_matrix(self, pose: ArrayLike, twist: ArrayLike, q: ArrayLike) -> FloatArray:
        """The coupled mass matrix of platform and payload, (6 + nv, 6 + nv) or
        (N, 6 + nv, 6 + nv): ``[[A_robot + X^T M_ff X, X^T M_fj], [M_jf X, M_jj]]``
        acting on ``[A (classical, F0); qdd]`` (see :mod:`stewart_pin.dynamics.payload`;
        it depends on the twist only through the legs' ``A_robot``, which does not)."""
        batched, T, V = check_states(pose, (twist, "twist"))
        (Q,) = self._joints(len(T), batched, q)
        cd = self.robot.cartesian_dynamics(T, V)
        terms = self.dynamics.coupled_terms(T, V, Q, np.zeros((len(T), self.nv)))
        K = coupled_mass_matrix(cd.A_robot, terms)
        return K if batched else K[0]

    def gravity_compensation(self, pose: ArrayLike, q: ArrayLike) -> PayloadEfforts:
        """The efforts and joint torques holding platform and payload still."""
        T, batched = check_poses(pose)
        n = len(T)
        zero6, zero = np.zeros((n, 6)), np.zeros((n, self.nv))
        (Q,) = self._joints(n, batched, q)
        out = self.inverse_dynamics(T, zero6, zero6, Q, zero, zero)
        assert isinstance(out, PayloadEfforts)
        return out if batched else PayloadEfforts(out.gamma[0], out.tau[0])

    # ------------------------------------------------------------------ sampling
    def sample_states(
        self,
        n: int,
        rng: np.random.Generator | int | None = None,
        translation: float | None = None,
        rotation: float = 0.25,
        joint_rate: float = 1.0,
        joint_accel: float = 3.0,
    ) -> PayloadStates:
        """``n`` random states: the hexapod's (:meth:`StewartRobot.sample_states`) and the
        payload's configurations uniform within its joint limits, rates and accelerations
        uniform within ``+-joint_rate`` [rad/s or m/s] and ``+-joint_accel``
        [rad/s^2 or m/s^2]."""
        rng = np.random.default_rng(rng)
        poses, twists, accels = self.robot.sample_states(
            n, rng, translation=translation, rotation=rotation
        )
        q = self.payload.random_configurations(n, rng)
        qd = rng.uniform(-joint_rate, joint_rate, size=(n, self.nv))
        qdd = rng.uniform(-joint_accel, joint_accel, size=(n, self.nv))
        return PayloadStates(poses, twists, accels, q, qd, qdd)
