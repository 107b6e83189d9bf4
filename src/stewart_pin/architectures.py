"""The reference path of each architecture, chosen once when a robot is built.

:class:`~stewart_pin.robot.StewartRobot` holds one of these (``robot._kind``, from
:func:`reference_path`) and calls it for geometry, kinematics, sampling and the reference
dynamics; no method of the facade asks which architecture it holds.

- :class:`LegChainPath`: any robot, its legs as three-joint chains
  (:mod:`stewart_pin.kinematics.leg_chains`,
  :class:`~stewart_pin.dynamics.leg_chain_dynamics.GeneralDynamics`, joint terms
  included): the path of ``ups-offset``, ``rus``, ``pus``, custom and mixed robots.
- :class:`ChainLegPath`: robots with chain legs (``description.chain_legs``: any 1-dof
  joints closed by a ball or a weld; :mod:`stewart_pin.kinematics.chain_legs`,
  :class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`).
- :class:`IdealUpsPath`: the paper's ideal 6-UPS, overriding it with its closed forms
  (eq. 13-19, :mod:`stewart_pin.kinematics.geometry`,
  :mod:`stewart_pin.kinematics.jacobians`) and its Pinocchio leg models
  (:class:`~stewart_pin.dynamics.leg_dynamics.LegDynamics`, the closure layer of
  :mod:`stewart_pin.dynamics.closed_loop`).

The paths hold no state (the models they use are cached on the robot, which each method
takes as its first argument: a :class:`PathOwner`), so a robot keeps no reference cycle
and pickles as before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from stewart_pin._checks import check_poses, check_states
from stewart_pin._lazy import lazy_module
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._typing import (
    Accels,
    ArrayLike,
    FloatArray,
    JointValues,
    Pose,
    Poses,
    Twists,
)
from stewart_pin.description import RobotDescription
from stewart_pin.description.chain_leg import full_turn
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.dynamics import closed_loop as closure
from stewart_pin.dynamics.chain_leg_dynamics import (
    ChainCartesianDynamics,
    ChainDynamics,
    ChainInverseDynamics,
)
from stewart_pin.dynamics.closed_loop import CartesianDynamics, InverseDynamicsResult, check_finite
from stewart_pin.dynamics.leg_chain_dynamics import (
    GeneralCartesianDynamics,
    GeneralDynamics,
    GeneralInverseDynamics,
)
from stewart_pin.dynamics.leg_dynamics import LegDynamics
from stewart_pin.exceptions import (
    ArchitectureError,
    JointLimitError,
    StewartPinError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics import chain_legs, geometry, leg_chains
from stewart_pin.kinematics import jacobians as kinematics
from stewart_pin.kinematics.forward_geometry import forward_geometry
from stewart_pin.kinematics.jacobians import leg_state
from stewart_pin.models.chain_legs import build_chain_leg, build_chain_legs, build_chain_tree
from stewart_pin.models.leg_chains import build_general_tree, build_leg_chain, build_leg_chains
from stewart_pin.models.pinocchio_models import (
    TreeModel,
    build_leg_models,
    build_legs_model,
    build_tree,
)

if TYPE_CHECKING:
    from stewart_pin.kinematics import workspace
else:  # the sampling (Pinocchio's exponential) on first use
    workspace = lazy_module("stewart_pin.kinematics.workspace")

__all__ = [
    "ChainLegPath",
    "IdealUpsPath",
    "LegChainPath",
    "PathOwner",
    "closed_loop_tree",
    "leg_models",
    "legs_model",
    "reference_path",
]


class PathOwner(Protocol):
    """What a path needs from the robot holding it: its description, its singularity
    threshold (read at each call: it may change) and the models it caches."""

    description: RobotDescription
    max_condition: float

    @property
    def general(self) -> GeneralHexapod: ...

    @property
    def general_dynamics(self) -> GeneralDynamics: ...

    @property
    def leg_dynamics(self) -> LegDynamics: ...

    @property
    def chain_dynamics(self) -> ChainDynamics: ...

    @property
    def _motor_ratio(self) -> FloatArray: ...


def quiet_overflow() -> np.errstate:
    """No RuntimeWarning for overflow or invalid operations: the outputs are checked
    (:func:`stewart_pin.dynamics.closed_loop.check_finite`), and a non-finite one raises
    :class:`NumericalError` instead."""
    return np.errstate(over="ignore", invalid="ignore")


_Result = TypeVar("_Result", covariant=True)


class AnalyticRules(Protocol[_Result]):
    """The sets of grouping rules of the base parameters
    (:func:`stewart_pin.parameters.base.analytic_base_parameters`, a layer above): each
    path picks its architecture's (:meth:`LegChainPath.analytic_base_parameters`)."""

    def paper_rules(self, desc: RobotDescription) -> _Result:
        """The paper's rules (eq. 44-66): the ideal 6-UPS's 88."""
        ...

    def leg_chain_rules(self, desc: RobotDescription) -> _Result:
        """The rules of the leg chains (:mod:`stewart_pin.parameters.leg_chain_base`)."""
        ...

    def chain_leg_rules(self, desc: RobotDescription) -> _Result:
        """Chain legs of any joints: no analytic rules (the error saying so)."""
        ...


class LegChainPath:
    """Every robot as six three-joint leg chains, joint terms included: the path of every
    architecture but the ideal 6-UPS, which overrides it with its closed forms
    (:class:`IdealUpsPath`). Arguments, shapes and units as the
    :class:`~stewart_pin.robot.StewartRobot` methods of the same names; each method takes
    the robot holding the path first."""

    #: Whether this is the paper's ideal 6-UPS path.
    is_ideal_ups: bool = False
    #: The numerical rank tolerance of the stacked regressor (relative to its largest
    #: singular value, columns made dimensionless; see
    #: :func:`stewart_pin.parameters.base.numerical_base_parameters`): the joint terms and
    #: small passive links (the 2 g cross of a servo's universal joint) act down to about
    #: 1e-8 of the largest singular value (the kept ones measure 1e-8 to 1e-5 on the random
    #: robots and the presets), while round-off stays below 1e-15; 1e-11 sits between.
    rank_tolerance: float = 1e-11
    #: Whether the closed-loop tree comes from the robot's URDF with its visuals, which
    #: the viewer then draws (:func:`stewart_pin.viz.leg_scene.general_robot`); else the
    #: viewer draws the leg chains.
    urdf_visuals: bool = False
    #: Whether grouping rules give this architecture's analytic base parameters (else
    #: ``base_parameters(..., "analytic")`` falls back to the numerical set, with a warning).
    analytic_rules: bool = True

    def analytic_base_parameters(
        self, rules: AnalyticRules[_Result], desc: RobotDescription
    ) -> _Result:
        """The base parameters by the grouping rules of this architecture: the leg
        chains' (``custom`` legs: their own error)."""
        return rules.leg_chain_rules(desc)

    def closed_loop_tree(self, desc: RobotDescription) -> TreeModel:
        """The 24-dof closed-loop tree: the six chains (``model.armature`` set), the
        platform as a free-flyer, six 3D loop closures at the ``P_i``."""
        return build_general_tree(general_from_description(desc))

    def leg_models(self, desc: RobotDescription) -> list[pin.Model]:
        """The six 3-dof chains (``model.armature`` set)."""
        robot = general_from_description(desc)
        return [build_leg_chain(robot, k) for k in range(6)]

    def legs_model(self, desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
        """The six chains on a fixed base (18 dof) and the (6, 3) velocity index."""
        return build_leg_chains(general_from_description(desc))

    def limit_margin(
        self, r: PathOwner, pose: ArrayLike, error: BaseException | None
    ) -> tuple[float, str]:
        """The smallest distance of a joint to its limits at one pose, unit-free (revolute
        joints in rad, prismatic ones divided by ``RobotDescription.stroke_mid``; negative
        outside), and the sentence naming it (``error``, the limit error met, unused)."""
        T = check_poses(pose)[0][0]
        q = leg_chains.inverse_geometry(r.general, T, check_limits=False)
        limits = np.array([leg.limits for leg in r.general.legs])  # (6, 3, 2)
        revolute = np.array([[j.revolute for j in leg.joints] for leg in r.general.legs])
        scale = np.where(revolute, 1.0, r.description.stroke_mid)
        with np.errstate(invalid="ignore"):
            lo, hi = (q - limits[..., 0]) / scale, (limits[..., 1] - q) / scale
        m = np.minimum(lo, hi)
        k, j = np.unravel_index(int(np.argmin(m)), m.shape)
        end = "lower" if lo[k, j] <= hi[k, j] else "upper"
        unit = "rad" if revolute[k, j] else "m"
        return float(m[k, j]), (
            f"leg {k + 1} joint {j + 1} = {q[k, j]:.9g} {unit} reached its {end} limit "
            f"[{limits[k, j, 0]:.9g}, {limits[k, j, 1]:.9g}] {unit}"
        )

    def check_home(self, r: PathOwner) -> None:
        """A general robot's home pose must be reachable, inside the joint limits and away
        from both singularities (:class:`ArchitectureError` naming the cause)."""
        T = r.description.home_pose[None]
        try:
            legs = leg_chains.leg_state(r.general, T, np.zeros((1, 6)), check_limits=True)
            J_inv = leg_chains.inverse_jacobian_from_legs(r.general, legs.J_inv, legs.L)
            leg_chains.check_parallel(r.general, J_inv, r.max_condition)
        except StewartPinError as e:
            raise ArchitectureError(
                f"robot '{r.description.name}': the home pose is not a valid pose of its "
                f"legs: {e}",
                "home_pose",
                type(e).__name__,
            ) from e

    def inverse_geometry(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> JointValues:
        return leg_chains.inverse_geometry(r.general, pose, check_limits)

    def actuator_positions(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> FloatArray:
        return leg_chains.actuator_positions(r.general, pose, check_limits)

    def forward_geometry(
        self, r: PathOwner, lengths: ArrayLike, guess: ArrayLike, **kwargs: Any
    ) -> Pose:
        return leg_chains.forward_geometry(r.general, lengths, guess, **kwargs)

    def inverse_jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        return leg_chains.inverse_jacobian(r.general, pose)

    def jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        T, batched = check_poses(pose)
        J_inv = leg_chains.inverse_jacobian_batch(r.general, T)
        leg_chains.check_parallel(r.general, J_inv, r.max_condition)
        J = np.asarray(np.linalg.inv(J_inv), dtype=np.float64)
        return J if batched else J[0]

    def condition_number(self, r: PathOwner, pose: ArrayLike) -> float | FloatArray:
        T, batched = check_poses(pose)
        J_inv = leg_chains.inverse_jacobian_batch(r.general, T)
        c = leg_chains.condition_number_batch(r.general, J_inv)
        return c if batched else float(c[0])

    def leg_jacobians(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        T, batched = check_poses(pose)
        J = leg_chains.leg_kinematics(r.general, T, np.zeros((T.shape[0], 6)), None).J
        return J if batched else J[0]

    def leg_kinematics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        ks = leg_chains.leg_kinematics(r.general, pose, twist, accel)
        return ks.q, ks.qdot, None if accel is None else ks.qddot

    def admissible_poses(self, r: PathOwner, T: FloatArray, max_condition: float) -> np.ndarray:
        return leg_chains.admissible_poses(r.general, T, max_condition)

    def sample_poses(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> FloatArray:
        return workspace.sample_general_poses(
            r.description, r.general, n, rng, translation, rotation, r.max_condition
        )

    def sample_states(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> tuple[Poses, Twists, Accels]:
        return workspace.sample_general_states(
            r.description,
            r.general,
            n,
            rng,
            translation=translation,
            rotation=rotation,
            max_condition=r.max_condition,
        )

    def leg_dynamics(self, r: PathOwner) -> LegDynamics:
        return r.general_dynamics.legs

    def motor_side(self, r: PathOwner, gamma: Any) -> Any:
        return gamma / r._motor_ratio

    def _models(self, r: PathOwner) -> Any:
        """The robot's dynamic models this path runs (:class:`GeneralDynamics`)."""
        return r.general_dynamics

    def inverse_dynamics(
        self,
        r: PathOwner,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool,
        motor: bool,
    ) -> FloatArray | InverseDynamicsResult | GeneralInverseDynamics | ChainInverseDynamics:
        with quiet_overflow():
            res = self._models(r).inverse_dynamics(pose, twist, accel, details=True)
        if details:
            return res
        out = check_finite(res.motor if motor else res.gamma, "inverse dynamics Gamma")
        return out if check_poses(pose)[1] else out[0]

    def direct_dynamics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike
    ) -> FloatArray:
        with quiet_overflow():
            return self._models(r).direct_dynamics(pose, twist, gamma)

    def cartesian_dynamics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike
    ) -> CartesianDynamics | GeneralCartesianDynamics | ChainCartesianDynamics:
        with quiet_overflow():
            return self._models(r).cartesian_dynamics(pose, twist)

    def energy(self, r: PathOwner, pose: ArrayLike, twist: ArrayLike) -> FloatArray | float:
        with quiet_overflow():
            k, u = self._models(r).energy(pose, twist)
        if np.ndim(k) == 0:
            return float(check_finite(np.array([k + u]), "energy")[0])
        return check_finite(np.asarray(k) + np.asarray(u), "energy")

    def dissipated_power(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike
    ) -> FloatArray | float:
        with quiet_overflow():  # overflow: NumericalError below
            power = np.asarray(self._models(r).dissipated_power(pose, twist), dtype=float)
        checked = check_finite(np.atleast_1d(power), "dissipated power")
        return checked if power.ndim else float(checked[0])

    def regressor(self, r: PathOwner, T: FloatArray, V: FloatArray, A: FloatArray) -> FloatArray:
        from stewart_pin.dynamics.regressor import general_regressor_batch

        with quiet_overflow():
            return general_regressor_batch(
                r.general, r.general_dynamics.legs, T, V, A, r.max_condition, True
            )


class IdealUpsPath(LegChainPath):
    """The paper's ideal 6-UPS: its closed forms (eq. 13-19) and its Pinocchio leg models
    in place of the chains' Newton steps and joint terms (it has none)."""

    is_ideal_ups = True
    #: The paper's 88 grouped parameters and its rigid bodies: nothing acts below 1e-8.
    rank_tolerance = 1e-8
    urdf_visuals = True

    def analytic_base_parameters(
        self, rules: AnalyticRules[_Result], desc: RobotDescription
    ) -> _Result:
        """The paper's rules (its 88 grouped parameters, dropped as gravity allows)."""
        return rules.paper_rules(desc)

    def closed_loop_tree(self, desc: RobotDescription) -> TreeModel:
        """The tree parsed from its URDF (the paper's joint names and frames)."""
        return build_tree(desc)

    def leg_models(self, desc: RobotDescription) -> list[pin.Model]:
        return build_leg_models(desc)

    def legs_model(self, desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
        return build_legs_model(desc)

    def limit_margin(
        self, r: PathOwner, pose: ArrayLike, error: BaseException | None
    ) -> tuple[float, str]:
        """The stroke ends (leg lengths over the longest length of the stroke) or, for a
        :class:`JointLimitError` on a robot with U-joint limits, the U-joint angles [rad]."""
        desc = r.description
        T = check_poses(pose)[0][0]
        q = geometry.inverse_geometry_batch(desc, T[None], check_limits=False)[0]
        lim = desc.u_joint_limits
        if isinstance(error, JointLimitError) and lim is not None:
            m = np.minimum(q[:, :2] - lim[:, :, 0], lim[:, :, 1] - q[:, :2])
            k, j = np.unravel_index(int(np.argmin(m)), m.shape)
            end = "lower" if q[k, j] - lim[k, j, 0] <= lim[k, j, 1] - q[k, j] else "upper"
            return float(m[k, j]), (
                f"leg {k + 1} U-joint angle q{j + 1}{k + 1} = {q[k, j]:.9g} rad reached its "
                f"{end} limit [{lim[k, j, 0]:.9g}, {lim[k, j, 1]:.9g}] rad"
            )
        lo, hi = (float(x) for x in desc.ideal_stroke("the stroke ends"))
        m_length = np.minimum(q[:, 2] - lo, hi - q[:, 2])
        i = int(np.argmin(m_length))
        end = "lower" if q[i, 2] - lo <= hi - q[i, 2] else "upper"
        return float(m_length[i]) / hi, (
            f"leg {i + 1} length {q[i, 2]:.9g} m reached the {end} end of its stroke "
            f"[{lo:.9g}, {hi:.9g}] m"
        )

    def check_home(self, r: PathOwner) -> None:
        """Nothing to check: the description's validation covers the stroke and U-joints."""

    def inverse_geometry(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> JointValues:
        return geometry.inverse_geometry(r.description, pose, check_limits)

    def actuator_positions(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> FloatArray:
        if check_limits:
            q = geometry.inverse_geometry(r.description, pose, True)
            return np.asarray(q[..., 2], dtype=np.float64)
        return geometry.leg_lengths(r.description, pose)

    def forward_geometry(
        self, r: PathOwner, lengths: ArrayLike, guess: ArrayLike, **kwargs: Any
    ) -> Pose:
        return forward_geometry(r.description, lengths, guess, **kwargs)

    def inverse_jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        return kinematics.inverse_jacobian(r.description, pose)

    def jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        return kinematics.jacobian(r.description, pose, r.max_condition)

    def condition_number(self, r: PathOwner, pose: ArrayLike) -> float | FloatArray:
        return kinematics.condition_number(r.description, pose)

    def leg_jacobians(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        q = self.inverse_geometry(r, pose, True)
        J = kinematics.leg_jacobians(r.description, np.reshape(q, (-1, 6, 3)))
        return J if q.ndim == 3 else J[0]

    def leg_kinematics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        q, qd, qdd = kinematics.leg_kinematics(r.description, pose, twist, accel)
        q, qd = np.reshape(q, (-1, 6, 3)), np.reshape(qd, (-1, 6, 3))
        return q, qd, None if qdd is None else np.reshape(qdd, (-1, 6, 3))

    def admissible_poses(self, r: PathOwner, T: FloatArray, max_condition: float) -> np.ndarray:
        ok = geometry.admissible_poses(r.description, T)
        if np.any(ok):
            with np.errstate(all="ignore"):
                c = kinematics.condition_number_batch(r.description, T[ok])
            ok[ok] = c <= max_condition
        return ok

    def sample_poses(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> FloatArray:
        return workspace.sample_poses(
            r.description, n, rng, translation, rotation, r.max_condition
        )

    def sample_states(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> tuple[Poses, Twists, Accels]:
        return workspace.sample_states(
            r.description,
            n,
            rng,
            translation=translation,
            rotation=rotation,
            max_condition=r.max_condition,
        )

    def leg_dynamics(self, r: PathOwner) -> LegDynamics:
        return LegDynamics(r.description)

    def motor_side(self, r: PathOwner, gamma: Any) -> Any:
        return gamma  # no transmission on the ideal 6-UPS

    def inverse_dynamics(
        self,
        r: PathOwner,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool,
        motor: bool,
    ) -> FloatArray | InverseDynamicsResult | GeneralInverseDynamics | ChainInverseDynamics:
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        with quiet_overflow():
            res = closure.inverse_dynamics(r.description, r.leg_dynamics, T, V, A, r.max_condition)
        if details:
            return res
        return res.gamma if batched else res.gamma[0]

    def direct_dynamics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike
    ) -> FloatArray:
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        with quiet_overflow():
            accel, _ = closure.direct_dynamics(
                r.description, r.leg_dynamics, T, V, G, r.max_condition
            )
        return accel if batched else accel[0]

    def cartesian_dynamics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike
    ) -> CartesianDynamics:
        _, T, V = check_states(pose, (twist, "twist"))
        with quiet_overflow():
            return closure.cartesian_dynamics(r.description, r.leg_dynamics, T, V, r.max_condition)

    def energy(self, r: PathOwner, pose: ArrayLike, twist: ArrayLike) -> FloatArray | float:
        batched, T, V = check_states(pose, (twist, "twist"))
        with quiet_overflow():
            legs = leg_state(r.description, T, V, check_limits=False)
            kin, pot = r.leg_dynamics.energy(legs.q, legs.qdot)
            kin_p, pot_p = closure.platform_energy(r.description, T, V)
            total = check_finite(kin + pot + kin_p + pot_p, "energy")
        return total if batched else float(total[0])

    def dissipated_power(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike
    ) -> FloatArray | float:
        batched, T, _ = check_states(pose, (twist, "twist"))
        return np.zeros(T.shape[0]) if batched else 0.0  # frictionless

    def regressor(self, r: PathOwner, T: FloatArray, V: FloatArray, A: FloatArray) -> FloatArray:
        from stewart_pin.dynamics.regressor import regressor_batch

        with quiet_overflow():
            return regressor_batch(r.description, r.leg_dynamics, T, V, A, r.max_condition)


class ChainLegPath(LegChainPath):
    """Robots with chain legs (``description.chain_legs``: any 1-dof joints, ball or weld
    closures; :mod:`stewart_pin.kinematics.chain_legs`,
    :class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`). Joint values of the
    legs come as (N, 6, max n_i) arrays, zero past a leg's last joint. The Pinocchio
    models (the tree, the leg models) are those of :mod:`stewart_pin.models.chain_legs`;
    what is built on three-joint legs only raises :class:`UnsupportedArchitectureError`."""

    analytic_rules = False

    def analytic_base_parameters(
        self, rules: AnalyticRules[_Result], desc: RobotDescription
    ) -> _Result:
        """No grouping rules foresee an arbitrary chain (the rules' error)."""
        return rules.chain_leg_rules(desc)

    def closed_loop_tree(self, desc: RobotDescription) -> TreeModel:
        """The tree of the six chains (``model.armature`` set) and the platform as a
        free-flyer, with a 3D loop closure at each ball centre and a 6D one at each weld
        (:func:`~stewart_pin.models.chain_legs.build_chain_tree`; leg indices (6, max n),
        ``-1`` past a leg's last joint)."""
        return build_chain_tree(desc)

    def leg_models(self, desc: RobotDescription) -> list[pin.Model]:
        """The six serial chains (n_i dof each, ``model.armature`` set): the models of
        :class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`."""
        return [build_chain_leg(desc, k) for k in range(6)]

    def legs_model(self, desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
        """The six chains on a fixed base and the (6, max n) velocity index of joint j of
        leg i (``-1`` past a leg's last joint)."""
        return build_chain_legs(desc)

    def check_home(self, r: PathOwner) -> None:
        """Each leg reaches its attachment at the home pose from its guess, inside its
        limits, with a regular Jacobian of full rank (:class:`LegMobilityError` naming the
        leg otherwise), away from parallel singularities."""
        desc = r.description
        try:
            chain_legs.check_mobility_at_home(desc)
            T = desc.home_pose[None]
            states = chain_legs.leg_states(desc, T, np.zeros((1, 6)), check_limits=True)
            chain_legs.check_parallel(
                desc, chain_legs.inverse_jacobian(desc, states), r.max_condition
            )
        except ArchitectureError:
            raise
        except StewartPinError as e:
            raise ArchitectureError(
                f"robot '{desc.name}': the home pose is not a valid pose of its legs: {e}",
                "home_pose",
                type(e).__name__,
            ) from e

    def inverse_geometry(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> JointValues:
        T, batched = check_poses(pose)
        q = chain_legs.padded(chain_legs.inverse_geometry(r.description, T, check_limits))
        return q if batched else q[0]

    def actuator_positions(self, r: PathOwner, pose: ArrayLike, check_limits: bool) -> FloatArray:
        T, batched = check_poses(pose)
        qs = chain_legs.inverse_geometry(r.description, T, check_limits)
        legs = r.description.chain_legs or ()
        q = np.stack([x[:, leg.actuated - 1] for x, leg in zip(qs, legs, strict=True)], 1)
        return q if batched else q[0]

    def forward_geometry(
        self, r: PathOwner, lengths: ArrayLike, guess: ArrayLike, **kwargs: Any
    ) -> Pose:
        return chain_legs.forward_geometry(r.description, lengths, guess, **kwargs)

    def limit_margin(
        self, r: PathOwner, pose: ArrayLike, error: BaseException | None
    ) -> tuple[float, str]:
        """The smallest distance of a joint to its limits (full turns excluded): revolute
        in rad, prismatic over ``stroke_mid``; the sentence naming it."""
        desc = r.description
        T = check_poses(pose)[0][:1]
        qs = chain_legs.inverse_geometry(desc, T, check_limits=False)
        best: tuple[float, str] = (np.inf, "no joint has limits")
        for k, (leg, q) in enumerate(zip(desc.chain_legs or (), qs, strict=True)):
            lim = leg.limits
            free = leg.revolute & full_turn(lim[:, 0], lim[:, 1])
            scale = np.where(leg.revolute, 1.0, desc.stroke_mid)
            with np.errstate(invalid="ignore"):
                lo, hi = (q[0] - lim[:, 0]) / scale, (lim[:, 1] - q[0]) / scale
            m = np.where(free, np.inf, np.minimum(lo, hi))
            j = int(np.argmin(m))
            if m[j] < best[0]:
                end = "lower" if lo[j] <= hi[j] else "upper"
                unit = "rad" if leg.revolute[j] else "m"
                best = (
                    float(m[j]),
                    f"leg {k + 1} joint {j + 1} = {q[0, j]:.9g} {unit} reached its {end} "
                    f"limit [{lim[j, 0]:.9g}, {lim[j, 1]:.9g}] {unit}",
                )
        return best

    def _J_inv(self, r: PathOwner, T: FloatArray) -> FloatArray:
        states = chain_legs.leg_states(r.description, T, np.zeros((T.shape[0], 6)))
        return chain_legs.inverse_jacobian(r.description, states)

    def inverse_jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        T, batched = check_poses(pose)
        J_inv = self._J_inv(r, T)
        return J_inv if batched else J_inv[0]

    def jacobian(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        T, batched = check_poses(pose)
        J_inv = self._J_inv(r, T)
        chain_legs.check_parallel(r.description, J_inv, r.max_condition)
        J = np.asarray(np.linalg.inv(J_inv), dtype=np.float64)
        return J if batched else J[0]

    def condition_number(self, r: PathOwner, pose: ArrayLike) -> float | FloatArray:
        T, batched = check_poses(pose)
        c = chain_legs.condition_number(r.description, self._J_inv(r, T))
        return c if batched else float(c[0])

    def leg_jacobians(self, r: PathOwner, pose: ArrayLike) -> FloatArray:
        """(N, 6, 6, max n_i): ``J_i`` in its first c_i rows and n_i columns, zero
        elsewhere."""
        T, batched = check_poses(pose)
        states = chain_legs.leg_states(r.description, T, np.zeros((T.shape[0], 6)))
        width = max(s.J.shape[2] for s in states)
        J = np.zeros((T.shape[0], 6, 6, width))
        for k, s in enumerate(states):
            J[:, k, : s.J.shape[1], : s.J.shape[2]] = s.J
        return J if batched else J[0]

    def leg_kinematics(
        self, r: PathOwner, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        if accel is None:
            _, T, V = check_states(pose, (twist, "twist"))
            A = None
        else:
            _, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        states = chain_legs.leg_states(r.description, T, V, A, check_limits=True)
        q = chain_legs.padded([s.q for s in states])
        qd = chain_legs.padded([s.qdot for s in states])
        qdd = None if A is None else chain_legs.padded([s.qddot for s in states])
        return q, qd, qdd

    def admissible_poses(self, r: PathOwner, T: FloatArray, max_condition: float) -> np.ndarray:
        return chain_legs.admissible_poses(r.description, T, max_condition)

    def sample_poses(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> FloatArray:
        return workspace.sample_chain_poses(
            r.description, n, rng, translation, rotation, r.max_condition
        )

    def sample_states(
        self,
        r: PathOwner,
        n: int,
        rng: np.random.Generator | int | None,
        translation: float | None,
        rotation: float,
    ) -> tuple[Poses, Twists, Accels]:
        return workspace.sample_chain_states(
            r.description,
            n,
            rng,
            translation=translation,
            rotation=rotation,
            max_condition=r.max_condition,
        )

    def _unsupported(self, r: PathOwner, what: str) -> UnsupportedArchitectureError:
        return UnsupportedArchitectureError(
            f"{what} is built on three-joint legs: robot '{r.description.name}' has chain "
            "legs (inverse and direct models, kinematics, energy and simulation take them)",
            what,
            r.description.architecture,
        )

    def leg_dynamics(self, r: PathOwner) -> LegDynamics:
        raise self._unsupported(r, "leg_dynamics (the three-joint leg models)")

    def motor_side(self, r: PathOwner, gamma: Any) -> Any:
        return gamma / r.chain_dynamics.ratio

    def _models(self, r: PathOwner) -> Any:
        """:class:`ChainDynamics` (same calls as :class:`GeneralDynamics`)."""
        return r.chain_dynamics

    def regressor(self, r: PathOwner, T: FloatArray, V: FloatArray, A: FloatArray) -> FloatArray:
        """Columns: :func:`~stewart_pin.dynamics.chain_leg_dynamics.chain_parameters`."""
        with quiet_overflow():
            return check_finite(r.chain_dynamics.regressor_batch(T, V, A), "regressor")


#: The three paths (stateless: one instance each).
_IDEAL_UPS, _LEG_CHAINS, _CHAIN_LEGS = IdealUpsPath(), LegChainPath(), ChainLegPath()


def reference_path(description: RobotDescription) -> LegChainPath:
    """The path of ``description``'s architecture: the one place the choice is made."""
    if description.has_chain_legs:
        return _CHAIN_LEGS
    return _IDEAL_UPS if description.is_ideal_ups else _LEG_CHAINS


def closed_loop_tree(desc: RobotDescription) -> TreeModel:
    """The 24-dof closed-loop tree of any robot (six leg chains, the platform as a
    free-flyer, six 3D loop closures at P_i): the ideal 6-UPS's from its URDF
    (:func:`~stewart_pin.models.pinocchio_models.build_tree`), every other robot's from
    its chains (:func:`~stewart_pin.models.leg_chains.build_general_tree`,
    ``model.armature`` set). ``StewartRobot.tree`` is this, cached."""
    return reference_path(desc).closed_loop_tree(desc)


def leg_models(desc: RobotDescription) -> list[pin.Model]:
    """The six 3-dof leg models of any robot (model ``i`` has leg i+1's joints from the
    base, in order; general legs: ``model.armature`` set)."""
    return reference_path(desc).leg_models(desc)


def legs_model(desc: RobotDescription) -> tuple[pin.Model, np.ndarray]:
    """The six legs of any robot on a fixed base (18 dof) and the (6, 3) velocity index
    of joint j of leg i."""
    return reference_path(desc).legs_model(desc)
