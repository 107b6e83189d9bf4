"""``StewartRobot``: the object users hold. It owns a validated description, builds the
Pinocchio models on first use, and delegates to the model modules.

Conventions (see ``docs/conventions.md``): a pose is 0Tp as a 4x4 matrix (``pin.SE3``
accepted); a twist is ``[v, w]`` (6,) of the origin of Fp in F0 [m/s, rad/s]; an
acceleration is classical ``[dv/dt, dw/dt]`` in F0 [m/s^2, rad/s^2]; ``Gamma_3i`` [N] is
positive when it extends leg i. Every method takes one state or a batch with a leading
N axis, and returns the same.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_poses, check_scalar, check_states
from stewart_pin._typing import (
    Accels,
    ArrayLike,
    FloatArray,
    Forces,
    IntArray,
    JointValues,
    Pose,
    Poses,
    Twists,
)
from stewart_pin.description import RobotDescription
from stewart_pin.description.presets import preset
from stewart_pin.dynamics import closed_loop as closure
from stewart_pin.dynamics.closed_loop import CartesianDynamics, InverseDynamicsResult, check_finite
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.exceptions import InputError, InputTypeError, NumericalError
from stewart_pin.formats.urdf import urdf_string, write_urdf
from stewart_pin.kinematics import geometry, workspace
from stewart_pin.kinematics import jacobians as kinematics
from stewart_pin.kinematics.forward_geometry import forward_geometry
from stewart_pin.kinematics.jacobians import MAX_CONDITION, leg_state
from stewart_pin.models.pinocchio_models import (
    TreeModel,
    build_leg_models,
    build_legs_model,
    build_tree,
)


class StewartRobot:
    """A Gough-Stewart robot: description, Pinocchio models, geometry and kinematics.

    Args:
        description: the validated robot description.
        max_condition: the singularity measure (cond(Jp^-1), its angular columns divided by
            the platform radius) past which a pose counts as singular.
    """

    def __init__(self, description: RobotDescription, max_condition: float = MAX_CONDITION):
        if not isinstance(description, RobotDescription):
            raise InputTypeError(
                f"StewartRobot takes a RobotDescription, got {type(description).__name__}; "
                "use StewartRobot.from_dict / from_file / from_preset"
            )
        self.description = description
        self.max_condition = check_scalar(max_condition, "max_condition", positive=True)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_dict(cls, d: dict[str, Any], **kwargs: Any) -> StewartRobot:
        """From the dictionary form (keys in
        :data:`stewart_pin.description.robot_description.REQUIRED_KEYS`)."""
        return cls(RobotDescription.from_dict(d), **kwargs)

    @classmethod
    def from_file(cls, path: str | Path, **kwargs: Any) -> StewartRobot:
        """From a ``.toml`` or ``.json`` description file."""
        return cls(RobotDescription.read(path), **kwargs)

    @classmethod
    def from_preset(cls, name: str, **kwargs: Any) -> StewartRobot:
        """From a preset: ``simulator``, ``desktop``, ``paper`` or ``random-<seed>``."""
        return cls(preset(name), **kwargs)

    def to_dict(self) -> dict[str, Any]:
        """The description's dictionary form."""
        return self.description.to_dict()

    def write(self, path: str | Path) -> Path:
        """Write the description (``.toml`` or ``.json``)."""
        return self.description.write(path)

    def __repr__(self) -> str:
        return f"StewartRobot('{self.name}')"

    @property
    def name(self) -> str:
        return self.description.name

    @property
    def home_pose(self) -> Pose:
        """The workspace centre 0Tp (4x4), a copy."""
        return self.description.home_pose.copy()

    # ------------------------------------------------------------------ files and models
    def urdf(self) -> str:
        """The URDF text of the tree."""
        return urdf_string(self.description)

    def write_urdf(self, path: str | Path) -> tuple[Path, Path]:
        """Write the URDF and its loop-closure sidecar ``*.closures.json``."""
        return write_urdf(self.description, path)

    @cached_property
    def tree(self) -> TreeModel:
        """The 24-dof Pinocchio tree with its six 3D loop-closure constraints."""
        return build_tree(self.description)

    @cached_property
    def leg_models(self) -> list[pin.Model]:
        """The six 3-dof leg models."""
        return build_leg_models(self.description)

    @cached_property
    def legs_model(self) -> tuple[pin.Model, IntArray]:
        """The six legs as one 18-dof fixed-base model, and its (6, 3) velocity index."""
        return build_legs_model(self.description)

    # ------------------------------------------------------------------ geometry
    def inverse_geometry(self, pose: ArrayLike, check_limits: bool = True) -> JointValues:
        """Leg joint values (6, 3) (or (N, 6, 3)): columns q1i, q2i [rad], q3i [m]."""
        return geometry.inverse_geometry(self.description, pose, check_limits)

    def leg_lengths(self, pose: ArrayLike) -> FloatArray:
        """Leg lengths [m], (6,) or (N, 6), without stroke checks."""
        return geometry.leg_lengths(self.description, pose)

    def forward_geometry(self, lengths: ArrayLike, guess: ArrayLike = None, **kwargs: Any) -> Pose:
        """The pose 0Tp (4x4) with leg lengths ``lengths`` [m] (Newton-Raphson from ``guess``,
        default the home pose); see
        :func:`stewart_pin.kinematics.forward_geometry.forward_geometry`."""
        return forward_geometry(self.description, lengths, guess, **kwargs)

    # ------------------------------------------------------------------ kinematics
    def inverse_jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp^-1`` (6, 6): ``qdot_a = Jp^-1 [v, w]`` (eq. 13)."""
        return kinematics.inverse_jacobian(self.description, pose)

    def jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp`` (6, 6); raises :class:`SingularityError` past ``max_condition``."""
        return kinematics.jacobian(self.description, pose, self.max_condition)

    def condition_number(self, pose: ArrayLike) -> float | FloatArray:
        """The singularity measure: cond(Jp^-1), its angular columns divided by the platform
        radius (unit-free; see :func:`stewart_pin.kinematics.jacobians.condition_number`)."""
        return kinematics.condition_number(self.description, pose)

    def leg_jacobians(self, pose: ArrayLike) -> FloatArray:
        """Each leg's Jacobian ``J_3i`` at P_i in F0, (6, 3, 3) (or (N, 6, 3, 3))."""
        q = self.inverse_geometry(pose)
        J = kinematics.leg_jacobians(self.description, np.reshape(q, (-1, 6, 3)))
        return J if q.ndim == 3 else J[0]

    def leg_kinematics(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None = None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        """``(q, qdot, qddot)`` of the legs, each (6, 3) or (N, 6, 3) (eq. 14-19)."""
        return kinematics.leg_kinematics(self.description, pose, twist, accel)

    def sample_poses(
        self,
        n: int,
        rng: np.random.Generator | int | None = None,
        translation: float | None = None,
        rotation: float = 0.25,
    ) -> FloatArray:
        """``n`` random reachable poses around the home pose, (n, 4, 4).

        Translations uniform in a cube of half-side ``translation`` [m] (default 15 % of the
        mid-stroke), rotations ``exp(w)`` with ``|w_k| <= rotation`` [rad]; poses outside
        the stroke, the U-joint limits or past ``max_condition`` are redrawn.
        """
        return workspace.sample_poses(
            self.description, n, rng, translation, rotation, self.max_condition
        )

    def sample_states(
        self,
        n: int,
        rng: np.random.Generator | int | None = None,
        translation: float | None = None,
        rotation: float = 0.25,
    ) -> tuple[Poses, Twists, Accels]:
        """``(poses (n, 4, 4), twists (n, 6), accels (n, 6))``: :meth:`sample_poses` with
        random twists and accelerations
        (:func:`stewart_pin.kinematics.workspace.sample_states`)."""
        return workspace.sample_states(
            self.description,
            n,
            rng,
            translation=translation,
            rotation=rotation,
            max_condition=self.max_condition,
        )

    # ------------------------------------------------------------------ dynamics
    @cached_property
    def leg_dynamics(self) -> LegDynamics:
        """Pinocchio's RNEA / CRBA on the six legs (``H_i``, ``A_i``, ``h_i``)."""
        return LegDynamics(self.description)

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: Literal[False] = False,
        backend: str = "pinocchio",
    ) -> Forces: ...

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: Literal[True],
        backend: str = "pinocchio",
    ) -> InverseDynamicsResult: ...

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool = False,
        backend: str = "pinocchio",
    ) -> Forces | InverseDynamicsResult: ...

    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool = False,
        backend: str = "pinocchio",
    ) -> Forces | InverseDynamicsResult:
        """Actuator forces ``Gamma = Jp^T (F_p + F_leg)`` (eq. 31) [N].

        Args:
            pose: 0Tp, (4, 4) / ``pin.SE3``, or a batch (N, 4, 4).
            twist: ``[v, w]`` of O_p in F0, (6,) or (N, 6) [m/s, rad/s].
            accel: classical ``[dv/dt, dw/dt]`` in F0, (6,) or (N, 6) [m/s^2, rad/s^2].
            details: return the :class:`~stewart_pin.dynamics.closed_loop.InverseDynamicsResult`
                (batch arrays) with the leg forces on the platform, each leg's share...
            backend: ``"pinocchio"`` (the reference: Pinocchio's RNEA on the legs and the
                closure layer) or ``"compiled"`` (the generated closed-form model compiled
                to C, :mod:`stewart_pin.codegen`; same checks, ~7 us per state).

        Returns:
            Gamma (6,) or (N, 6); positive extends the leg.

        Raises:
            NumericalError: finite inputs whose Gamma overflows (both backends).
        """
        if _compiled(backend, details):
            from stewart_pin.codegen import compiled_backend

            return compiled_backend(self).inverse_dynamics(pose, twist, accel)
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        with _quiet_overflow():
            res = closure.inverse_dynamics(
                self.description, self.leg_dynamics, T, V, A, self.max_condition
            )
        if details:
            return res
        return res.gamma if batched else res.gamma[0]

    def direct_dynamics(
        self, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike, backend: str = "pinocchio"
    ) -> FloatArray:
        """Classical platform acceleration ``[dv/dt, dw/dt]`` in F0 (eq. 35):
        ``A_robot Vdot_p = Jp^-T Gamma - h_robot``, solved by Cholesky.

        Args:
            pose: 0Tp (4, 4) or (N, 4, 4); twist: (6,) or (N, 6); gamma: actuator forces
                (6,) or (N, 6) [N].
            backend: ``"pinocchio"`` (reference) or ``"compiled"`` (generated C).

        Raises:
            NumericalError: finite inputs whose acceleration overflows (both backends).
        """
        if _compiled(backend):
            from stewart_pin.codegen import compiled_backend

            return compiled_backend(self).direct_dynamics(pose, twist, gamma)
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        with _quiet_overflow():
            accel, _ = closure.direct_dynamics(
                self.description, self.leg_dynamics, T, V, G, self.max_condition
            )
        return accel if batched else accel[0]

    def cartesian_dynamics(self, pose: ArrayLike, twist: ArrayLike) -> CartesianDynamics:
        """``A_robot`` (N, 6, 6) and ``h_robot`` (N, 6) of eq. 36-37 (always batch arrays);
        :class:`NumericalError` when either is not finite."""
        _, T, V = check_states(pose, (twist, "twist"))
        with _quiet_overflow():
            cd = closure.cartesian_dynamics(
                self.description, self.leg_dynamics, T, V, self.max_condition
            )
        check_finite(cd.A_robot, "cartesian dynamics A_robot")
        check_finite(cd.h_robot, "cartesian dynamics h_robot")
        return cd

    def gravity_compensation(self, pose: ArrayLike) -> FloatArray:
        """The static inverse dynamic model: Gamma holding the robot still at ``pose`` [N]."""
        T, batched = check_poses(pose)
        zeros = np.zeros((T.shape[0], 6))
        try:
            gamma = self.inverse_dynamics(T, zeros, zeros)
        except NumericalError as e:
            raise NumericalError("gravity compensation Gamma", e.index, e.n_bad, e.n_states) from e
        return gamma if batched else gamma[0]

    def energy(self, pose: ArrayLike, twist: ArrayLike) -> FloatArray | float:
        """Total mechanical energy of platform + legs [J]: kinetic plus gravitational
        potential (zero with every centre of mass at the origin of F0)."""
        batched, T, V = check_states(pose, (twist, "twist"))
        with _quiet_overflow():
            legs = leg_state(self.description, T, V, check_limits=False)
            kin, pot = self.leg_dynamics.energy(legs.q, legs.qdot)
            kin_p, pot_p = closure.platform_energy(self.description, T, V)
            total = check_finite(kin + pot + kin_p + pot_p, "energy")
        return total if batched else float(total[0])

    def regressor(self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike) -> FloatArray:
        """The dynamic regressor ``W`` with ``Gamma = W chi``: (6, 190) or (N, 6, 190).

        Columns: leg 1 link 1 (10, Khalil order), leg 1 link 2, ..., leg 6 link 3, platform;
        names in :data:`stewart_pin.dynamics.regressor.STANDARD_NAMES`.
        """
        from stewart_pin.dynamics.regressor import regressor_batch

        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        with _quiet_overflow():
            W = regressor_batch(self.description, self.leg_dynamics, T, V, A, self.max_condition)
        return W if batched else W[0]


BACKENDS = ("pinocchio", "compiled")


def _quiet_overflow() -> np.errstate:
    """No RuntimeWarning for overflow or invalid operations: the outputs are checked
    (:func:`stewart_pin.dynamics.closed_loop.check_finite`), and a non-finite one raises
    :class:`NumericalError` instead."""
    return np.errstate(over="ignore", invalid="ignore")


def _compiled(backend: str, details: bool = False) -> bool:
    """Whether ``backend`` is the compiled one; raises on unknown names."""
    if backend not in BACKENDS:
        raise InputError(f"unknown backend '{backend}': choose one of {BACKENDS}")
    if backend == "compiled" and details:
        raise InputError(
            "details=True needs backend='pinocchio' (the compiled model returns Gamma)"
        )
    return backend == "compiled"
