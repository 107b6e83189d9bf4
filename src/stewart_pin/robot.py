"""``StewartRobot``: the object users hold. It owns a validated description, builds the
Pinocchio models on first use, and delegates to the model modules.

Conventions (see ``docs/conventions.md``): a pose is 0Tp as a 4x4 matrix (``pin.SE3``
accepted); a twist is ``[v, w]`` (6,) of the origin of Fp in F0 [m/s, rad/s]; an
acceleration is classical ``[dv/dt, dw/dt]`` in F0 [m/s^2, rad/s^2]; ``Gamma_3i`` [N] is
positive when it extends leg i. Every method takes one state or a batch with a leading
N axis, and returns the same. A robot imported from a model file speaks that file's joint
convention for its actuators (positions, rates, efforts: :attr:`StewartRobot.actuator_convention`,
one conversion at the boundary; ``convention="description"`` for the named architecture's).

Two reference paths, chosen once when the robot is built
(:func:`stewart_pin.architectures.reference_path`; the facade's methods call the path and
never ask which architecture they hold): the paper's ideal
6-UPS robot keeps its closed forms and its Pinocchio leg models; a robot with general
three-joint legs (``legs`` in its description: ``ups-offset``, ``rus``, ``pus``, custom,
mixed) goes through :mod:`stewart_pin.kinematics.leg_chains` and
:class:`stewart_pin.dynamics.leg_chain_dynamics.GeneralDynamics` (joint dynamics included). On
such a robot the actuator efforts are the actuated joints' (N for a prismatic joint, N m
for a revolute one, joint side). Every feature takes every architecture: the tree
(:attr:`StewartRobot.tree`), the leg models, the model files (URDF, xacro, MJCF), the
actuator positions (:meth:`StewartRobot.leg_lengths` is the 6-UPS's name for
:meth:`StewartRobot.actuator_positions`), the forward geometry and the derivatives.

The inverse and direct dynamic models of every robot take ``backend="auto"`` by default:
the compiled closed-form models (:mod:`stewart_pin.codegen`) where a C compiler is
available, built on first use and cached, else the reference path above with one warning
(``$STEWART_PIN_BACKEND=pinocchio`` for the reference path always; ``backend="pinocchio"``
for one call).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np

from stewart_pin._checks import check_array, check_poses, check_scalar, check_states
from stewart_pin._lazy import pinocchio as pin  # imported on first use
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
from stewart_pin.architectures import quiet_overflow, reference_path
from stewart_pin.description import RobotDescription
from stewart_pin.description.actuator_convention import ActuatorConvention
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod, general_from_description
from stewart_pin.description.presets import preset
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
    InputError,
    InputTypeError,
    NumericalError,
)
from stewart_pin.formats.mjcf import mjcf_string, write_mjcf
from stewart_pin.formats.urdf import urdf_string, write_urdf
from stewart_pin.formats.xacro import write_xacro_args
from stewart_pin.kinematics import leg_chains
from stewart_pin.kinematics.chain_legs import idle_legs as leg_chains_idle
from stewart_pin.kinematics.jacobians import MAX_CONDITION
from stewart_pin.models import leg_chains as models
from stewart_pin.models.pinocchio_models import TreeModel

if TYPE_CHECKING:
    from stewart_pin.payload_robot import PayloadRobot


class StewartRobot:
    """A Gough-Stewart robot: description, Pinocchio models, geometry and kinematics.

    Args:
        description: the validated robot description.
        max_condition: the singularity measure (cond(Jp^-1), its angular columns divided by
            the platform radius) past which a pose counts as singular.
        convention: the actuators' convention at the robot's boundary: ``"file"`` (the
            default: a robot imported from a model file reports and takes actuator
            positions, rates and efforts in that file's joint convention, sign and zero,
            ``description.source``; a description without a source has no other) or
            ``"description"`` (the named architecture's); see :attr:`actuator_convention`
            and ``docs/conventions.md``.
    """

    def __init__(
        self,
        description: RobotDescription,
        max_condition: float = MAX_CONDITION,
        convention: str = "file",
    ):
        if not isinstance(description, RobotDescription):
            raise InputTypeError(
                f"StewartRobot takes a RobotDescription, got {type(description).__name__}; "
                "use StewartRobot.from_dict / from_file / from_preset"
            )
        self.description = description
        self.max_condition = check_scalar(max_condition, "max_condition", positive=True)
        self._set_convention(ActuatorConvention.of(description, convention))
        #: The reference path of the robot's architecture (chosen here, once).
        self._kind = reference_path(description)
        self._kind.check_home(self)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without its compiled backends (loaded libraries; found again in the
        cache on first use)."""
        skip = ("_stewart_pin_", "_kind")
        return {k: v for k, v in self.__dict__.items() if not k.startswith(skip)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled: the path of its architecture chosen again (a pickle holds no path, so
        one written before the paths existed loads too)."""
        self.__dict__.update(state)
        self._kind = reference_path(self.description)
        if "_convention" not in state:  # pickled before the actuator conventions
            self._set_convention(ActuatorConvention.of(self.description))

    # ------------------------------------------------------------------ actuator convention
    def _set_convention(self, convention: ActuatorConvention) -> None:
        #: The one conversion layer of the actuators' values at the boundary
        #: (``_actuators`` is ``None`` for the identity: nothing converted on the hot path).
        self._convention = convention
        self._actuators = None if convention.identity else convention

    @property
    def actuator_convention(self) -> ActuatorConvention:
        """The mapping between the robot's actuator values and its description's
        (:class:`~stewart_pin.description.actuator_convention.ActuatorConvention`: per
        actuator the sign, the offset [m or rad], the wrap of a revolute one; ``str()``
        prints it): ``q_robot = s (q_description - o)``, ``Gamma_robot = s
        Gamma_description``. The identity for a robot not imported, or built with
        ``convention="description"``."""
        return self._convention

    def description_convention(self) -> StewartRobot:
        """This robot speaking its description's (the named architecture's) actuator
        convention: a new :class:`StewartRobot` on the same description with
        ``convention="description"`` (itself when the two agree: not imported, or
        already the description's)."""
        if self._actuators is None:
            return self
        return StewartRobot(self.description, self.max_condition, convention="description")

    @property
    def actuator_limits(self) -> FloatArray:
        """Each actuated joint's limits ``[lower, upper]`` (6, 2) [m or rad] in the
        robot's convention (:attr:`actuator_convention`; infinite: none)."""
        legs = self.description.joint_legs
        lim = np.array([[leg.joints[leg.actuated - 1].lower, leg.joints[leg.actuated - 1].upper]
                        for leg in legs], dtype=float)  # fmt: skip
        return lim if self._actuators is None else self._actuators.limits_from_description(lim)

    def _efforts_in(self, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike) -> tuple[Any, ...]:
        """A state with efforts in the robot's convention -> checked, with the efforts in
        the description's (the models' own check on the arrays: the same errors)."""
        assert self._actuators is not None
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        G = self._actuators.efforts_to_description(G)
        return (T, V, G) if batched else (T[0], V[0], G[0])

    def _compiled_backend(self) -> Any:
        """The robot's :class:`~stewart_pin.codegen.CompiledDynamics` (kept on the robot by
        :func:`~stewart_pin.codegen.compiled_backend`, left out when pickled); the import is
        done once per process."""
        if not _COMPILED_BACKEND:
            from stewart_pin.codegen import compiled_backend

            _COMPILED_BACKEND.append(compiled_backend)
        return _COMPILED_BACKEND[0](self)

    # ------------------------------------------------------------------ architecture
    @property
    def is_ideal_ups(self) -> bool:
        """Whether the robot is the paper's ideal 6-UPS (the closed-form, compiled path)."""
        return self._kind.is_ideal_ups

    @property
    def architecture(self) -> str:
        """``"ups"``, ``"ups-offset"``, ``"rus"``, ``"pus"``, ``"custom"`` or ``"mixed"``."""
        return self.description.architecture

    @cached_property
    def general(self) -> GeneralHexapod:
        """The robot as general three-joint legs (for the ideal 6-UPS: its ``ups`` legs)."""
        return general_from_description(self.description)

    @cached_property
    def general_dynamics(self) -> GeneralDynamics:
        """The closure layer on general legs with joint dynamics (joint limits checked)."""
        return GeneralDynamics(self.general, self.max_condition, check_limits=True)

    @cached_property
    def chain_dynamics(self) -> ChainDynamics:
        """The models of a robot with chain legs (``description.chain_legs``; joint limits
        checked): its reference path's (:class:`~stewart_pin.architectures.ChainLegPath`)."""
        return ChainDynamics(self.description, self.max_condition, check_limits=True)

    @cached_property
    def general_tree(self) -> TreeModel:
        """The 24-dof Pinocchio tree of the robot's legs taken as general chains
        (``model.armature`` set) with its six 3D loop closures (for a general robot the
        same as :attr:`tree`; for the ideal 6-UPS its ``ups`` legs built as chains)."""
        return models.build_general_tree(self.general)

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
        """From a preset: ``simulator``, ``desktop``, ``paper``, ``random-<seed>`` (ideal
        6-UPS), ``ups-offset``, ``rus``, ``pus`` or ``random-<kind>-<seed>`` (general legs;
        :func:`stewart_pin.description.presets.preset`)."""
        return cls(preset(name), **kwargs)

    @classmethod
    def from_mjcf(cls, source: Any, convention: str = "file", **options: Any) -> StewartRobot:
        """From an MJCF model: a path, the XML text or a ``mujoco.MjModel``, read through
        MuJoCo (options and conventions: :func:`stewart_pin.importers.import_mjcf`,
        ``docs/importing.md``). F0 is the model's world, Fp the platform body's frame.
        ``convention``: the actuators' (see :class:`StewartRobot`; default the file's)."""
        from stewart_pin.importers import import_mjcf

        return cls(import_mjcf(source, **options).description, convention=convention)

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        closures: Any = None,
        actuated: Any = None,
        armature: dict[str, float] | None = None,
        convention: str = "file",
        **options: Any,
    ) -> StewartRobot:
        """From a URDF and its loop closures (a sidecar, ``closing_<k>_1`` /
        ``closing_<k>_2`` frames, or pairs of names), the actuated joints (default the
        sidecar's or the ``<transmission>`` elements) and the armatures URDF cannot hold
        (:func:`stewart_pin.importers.import_urdf`, ``docs/importing.md``);
        ``convention``: the actuators' (see :class:`StewartRobot`; default the file's)."""
        from stewart_pin.importers import import_urdf

        desc = import_urdf(path, closures, actuated, armature, **options).description
        return cls(desc, convention=convention)

    @classmethod
    def from_sdf(
        cls, path: str | Path, actuated: Any = None, convention: str = "file", **options: Any
    ) -> StewartRobot:
        """From a Gazebo SDF file (SDFormat 1.4 to 1.11: one ``<model>``, or a ``<world>``
        holding it); SDF has no actuators: each leg's one revolute or prismatic joint by
        default, else ``actuated=[...]`` in leg order
        (:func:`stewart_pin.importers.import_sdf`, ``docs/importing.md``). F0 is the
        file's world, Fp the platform link's frame. ``convention``: the actuators' (see
        :class:`StewartRobot`; default the file's)."""
        from stewart_pin.importers import import_sdf

        return cls(import_sdf(path, actuated, **options).description, convention=convention)

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
        """The URDF text of the tree (general legs: their chains, see
        :mod:`stewart_pin.formats.urdf`)."""
        return urdf_string(self.description)

    def write_urdf(self, path: str | Path) -> tuple[Path, Path]:
        """Write the URDF and its loop-closure sidecar ``*.closures.json`` (general legs:
        the sidecar also holds the joint terms URDF cannot)."""
        return write_urdf(self.description, path)

    def mjcf(self, pinocchio_layout: bool = False) -> str:
        """The MJCF text of the closed-loop robot (MuJoCo equality constraints close the
        six loops; general legs: their chains, :mod:`stewart_pin.formats.mjcf`).
        ``pinocchio_layout``: the layout Pinocchio's parser reads (MuJoCo refuses it)."""
        return mjcf_string(self.description, pinocchio_layout)

    def write_mjcf(self, path: str | Path, pinocchio_layout: bool = False) -> Path:
        """Write the MJCF (:meth:`mjcf`) atomically to ``path``; returns the path."""
        return write_mjcf(self.description, path, pinocchio_layout)

    def write_xacro_args(self, path: str | Path) -> Path:
        """Write the YAML arguments of the package's xacro model for this robot
        (``stewart.urdf.xacro`` for the ideal 6-UPS, ``stewart_chain.urdf.xacro`` for chain
        legs, ``stewart_general.urdf.xacro`` otherwise: the header names it); returns the
        path."""
        return write_xacro_args(self.description, path)

    @cached_property
    def tree(self) -> TreeModel:
        """The 24-dof closed-loop Pinocchio tree of the robot: six leg chains, the
        platform as a free-flyer, six 3D loop-closure constraints at the ``P_i``
        (:func:`stewart_pin.architectures.closed_loop_tree`: the ideal 6-UPS's from its
        URDF, every other robot's from its chains with ``model.armature`` set; chain legs:
        6 + sum n_i dof, 3D loops at the balls, 6D at the welds, leg indices (6, max n)
        with ``-1`` past a leg's last joint)."""
        return self._kind.closed_loop_tree(self.description)

    @cached_property
    def leg_models(self) -> list[pin.Model]:
        """The six 3-dof leg models (joints from the base in order; chain legs: n_i dof)."""
        return self._kind.leg_models(self.description)

    @cached_property
    def legs_model(self) -> tuple[pin.Model, IntArray]:
        """The six legs as one 18-dof fixed-base model, and its (6, 3) velocity index
        (chain legs: sum n_i dof, (6, max n), ``-1`` past a leg's last joint)."""
        return self._kind.legs_model(self.description)

    # ------------------------------------------------------------------ geometry
    def inverse_geometry(self, pose: ArrayLike, check_limits: bool = True) -> JointValues:
        """Leg joint values (6, 3) (or (N, 6, 3)): for 6-UPS columns q1i, q2i [rad], q3i
        [m]; for general legs the three joints' values from the base [rad or m], each leg
        on its branch (:func:`stewart_pin.kinematics.leg_chains.inverse_geometry`)."""
        return self._kind.inverse_geometry(self, pose, check_limits)

    def leg_lengths(self, pose: ArrayLike) -> FloatArray:
        """The 6-UPS's name for :meth:`actuator_positions` (without limit checks): leg
        lengths [m] of a UPS robot, (6,) or (N, 6); on any other robot its actuated joint
        values (crank angles [rad] for RUS, slide positions [m] for PUS)."""
        return self.actuator_positions(pose)

    def actuator_positions(self, pose: ArrayLike, check_limits: bool = False) -> FloatArray:
        """The six actuated joint values, (6,) or (N, 6): leg lengths [m] for UPS (for the
        ideal 6-UPS exactly :meth:`leg_lengths`), crank angles [rad] for RUS, slide
        positions [m] for PUS. ``check_limits``: :class:`~stewart_pin.exceptions.WorkspaceError`
        outside a joint's limits (default off, as :meth:`leg_lengths`). In the robot's
        :attr:`actuator_convention` (an imported robot: the file's joint values)."""
        q = self._kind.actuator_positions(self, pose, check_limits)
        return q if self._actuators is None else self._actuators.positions_from_description(q)

    def forward_geometry(self, lengths: ArrayLike, guess: ArrayLike = None, **kwargs: Any) -> Pose:
        """The pose 0Tp (4x4) with actuated joint values ``lengths`` (6,) (leg lengths [m]
        for 6-UPS; :meth:`actuator_positions` in general), by Newton-Raphson from ``guess``,
        default the home pose; see
        :func:`stewart_pin.kinematics.forward_geometry.forward_geometry` and
        :func:`stewart_pin.kinematics.leg_chains.forward_geometry`. ``lengths`` in the
        robot's :attr:`actuator_convention`."""
        if self._actuators is not None:
            lengths = self._actuators.positions_to_description(
                check_array(lengths, (6,), "lengths")
            )
        return self._kind.forward_geometry(self, lengths, guess, **kwargs)

    def limit_margin(
        self, pose: ArrayLike, error: BaseException | None = None
    ) -> tuple[float, str]:
        """The smallest distance of a joint to its limits at one pose, unit-free, and the
        sentence naming it; negative outside. General legs: revolute joints in rad,
        prismatic ones divided by :attr:`RobotDescription.stroke_mid`; the ideal 6-UPS:
        the leg lengths to the stroke ends over the stroke's longest length or, when
        ``error`` is a :class:`~stewart_pin.exceptions.JointLimitError` and the robot has
        U-joint limits, the U-joint angles [rad]. The simulator locates a limit with it."""
        return self._kind.limit_margin(self, pose, error)

    # ------------------------------------------------------------------ kinematics
    def inverse_jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp^-1`` (6, 6): ``qdot_a = Jp^-1 [v, w]`` (eq. 13; general legs: rows
        ``e_ai^T J_i^-1 G_i``); ``qdot_a`` in the robot's :attr:`actuator_convention`."""
        J_inv = self._kind.inverse_jacobian(self, pose)
        return J_inv if self._actuators is None else self._actuators.rows(J_inv)

    def jacobian(self, pose: ArrayLike) -> FloatArray:
        """``Jp`` (6, 6) (``[v, w] = Jp qdot_a``, ``qdot_a`` in the robot's
        :attr:`actuator_convention`); raises :class:`SingularityError` past
        ``max_condition``."""
        J = self._kind.jacobian(self, pose)
        return J if self._actuators is None else self._actuators.columns(J)

    def condition_number(self, pose: ArrayLike) -> float | FloatArray:
        """The singularity measure: cond(Jp^-1), its angular columns divided by the platform
        radius (unit-free; see :func:`stewart_pin.kinematics.jacobians.condition_number`;
        general legs: :func:`stewart_pin.kinematics.leg_chains.condition_number_batch`)."""
        return self._kind.condition_number(self, pose)

    def admissible_poses(self, poses: ArrayLike, max_condition: float | None = None) -> np.ndarray:
        """(N,) bool: which poses (N, 4, 4) (or one, (4, 4): N = 1) the robot can take,
        decided for the whole batch at once without raising: every leg reaches, every joint
        within its limits (strokes, actuated and passive ranges), no leg (serial)
        singularity, and the singularity measure (:meth:`condition_number`) at most
        ``max_condition`` (default :attr:`max_condition`). The decision of the checked calls
        (:meth:`inverse_geometry` with limits, then the measure) on each state alone; a
        state whose closed form meets a floating-point fault is decided alone."""
        T, _ = check_poses(poses)
        bound = (
            self.max_condition
            if max_condition is None
            else check_scalar(max_condition, "max_condition", positive=True)
        )
        try:
            with np.errstate(over="raise", divide="raise", invalid="raise"):
                return self._kind.admissible_poses(self, T, bound)
        except FloatingPointError:
            out = np.zeros(T.shape[0], dtype=bool)
            for i in range(T.shape[0]):
                try:
                    with np.errstate(over="raise", divide="raise", invalid="raise"):
                        out[i] = bool(self._kind.admissible_poses(self, T[i : i + 1], bound)[0])
                except FloatingPointError:
                    out[i] = False
            return out

    def leg_state(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None = None
    ) -> leg_chains.LegKinematics:
        """The legs' joint values, rates, accelerations, ``J_i`` and their inverses (batch
        arrays, N = 1 for one state), for any robot, through the general leg chains
        (:func:`stewart_pin.kinematics.leg_chains.leg_kinematics`; limits not checked)."""
        return leg_chains.leg_kinematics(self.general, pose, twist, accel)

    def leg_jacobians(self, pose: ArrayLike) -> FloatArray:
        """Each leg's Jacobian ``J_3i`` at P_i in F0, (6, 3, 3) (or (N, 6, 3, 3))."""
        return self._kind.leg_jacobians(self, pose)

    def leg_kinematics(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike | None = None
    ) -> tuple[JointValues, JointValues, JointValues | None]:
        """``(q, qdot, qddot)`` of the legs, each (6, 3) or (N, 6, 3) (eq. 14-19)."""
        with np.errstate(over="ignore", invalid="ignore"):  # overflow: NumericalError below
            batched = check_poses(pose)[1]
            q, qd, qdd = self._kind.leg_kinematics(self, pose, twist, accel)
        check_finite(qd, "leg joint rates")
        if qdd is not None:
            check_finite(qdd, "leg joint accelerations")
        if batched:
            return q, qd, qdd
        return q[0], qd[0], None if qdd is None else qdd[0]

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
        the stroke, the U-joint limits or past ``max_condition`` are redrawn (general legs:
        :func:`stewart_pin.kinematics.workspace.sample_general_poses`, the default
        translation 15 % of the mean ``|B_i P_i|`` at home; unreachable poses, joint
        limits and both singularities redrawn).
        """
        return self._kind.sample_poses(self, n, rng, translation, rotation)

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
        return self._kind.sample_states(self, n, rng, translation, rotation)

    # ------------------------------------------------------------------ dynamics
    @cached_property
    def leg_dynamics(self) -> LegDynamics:
        """Pinocchio's RNEA / CRBA on the six legs (``H_i``, ``A_i``, ``h_i``); general
        legs: :attr:`general_dynamics`'s, with the joint terms (armature, friction,
        springs)."""
        return self._kind.leg_dynamics(self)

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: Literal[False] = False,
        backend: str = "auto",
        motor: bool = False,
        idle: Any = None,
    ) -> Forces: ...

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: Literal[True],
        backend: str = "auto",
        motor: bool = False,
        idle: Any = None,
    ) -> InverseDynamicsResult | GeneralInverseDynamics | ChainInverseDynamics: ...

    @overload
    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool = False,
        backend: str = "auto",
        motor: bool = False,
        idle: Any = None,
    ) -> Forces | InverseDynamicsResult | GeneralInverseDynamics | ChainInverseDynamics: ...

    def inverse_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        details: bool = False,
        backend: str = "auto",
        motor: bool = False,
        idle: Any = None,
    ) -> Forces | InverseDynamicsResult | GeneralInverseDynamics | ChainInverseDynamics:
        """Actuator forces ``Gamma = Jp^T (F_p + F_leg)`` (eq. 31) [N].

        Args:
            pose: 0Tp, (4, 4) / ``pin.SE3``, or a batch (N, 4, 4).
            twist: ``[v, w]`` of O_p in F0, (6,) or (N, 6) [m/s, rad/s].
            accel: classical ``[dv/dt, dw/dt]`` in F0, (6,) or (N, 6) [m/s^2, rad/s^2].
            details: return the :class:`~stewart_pin.dynamics.closed_loop.InverseDynamicsResult`
                (batch arrays) with the leg forces on the platform, each leg's share...
            backend: ``"auto"`` (the default: the compiled model where a C compiler is
                available, built on first use and cached, else the reference path with one
                warning; ``details=True`` takes the reference path; see :data:`BACKENDS`),
                ``"pinocchio"`` (the reference: Pinocchio's RNEA on the legs and the closure
                layer) or ``"compiled"`` (the generated closed-form model compiled to C,
                :mod:`stewart_pin.codegen`; same results and errors, about 2 us per state;
                CasADi's virtual machine without a compiler).
            motor: general legs with a transmission (gear or screw) on an actuated joint:
                the motor-side torque ``Gamma / ratio`` [N m] (joint side where there is
                none); the ideal 6-UPS has none, so ``motor`` changes nothing there.
            idle: chain legs with idle joints (an R-S-S rod's spin,
                ``ChainLeg.idle_joint``): the idle joints' ``(values, rates)``, each (6,)
                or (N, 6) [rad or m, /s], part of such a robot's state (required there,
                refused elsewhere: :class:`InputError`); their accelerations come with
                :meth:`inverse_dynamics_idle` (or ``details=True``).

        Returns:
            Gamma (6,) or (N, 6); positive extends the leg. General legs: the actuated
            joints' efforts, joint side [N or N m]. In the robot's
            :attr:`actuator_convention` (an imported robot: along the file's joint axes).
            ``details=True`` gives the
            :class:`~stewart_pin.dynamics.leg_chain_dynamics.GeneralInverseDynamics` (its
            ``joint_efforts`` (N, 6, 3): Gamma on the actuated joints, 0 on the passive
            ones; ``H`` each leg's own joint efforts, joint terms included), in the
            description's convention as every leg joint value.

        Raises:
            NumericalError: finite inputs whose Gamma overflows (every backend).
            InputError: an unknown backend, or ``details=True`` with ``"compiled"``.
        """
        if idle is not None:
            if details:
                _compiled(backend, details)  # the backend's name checked
                return self._idle_reference().details(pose, twist, accel, idle)
            out = self._idle_models(backend).inverse_dynamics(pose, twist, accel, idle)[0]
            return out if self._actuators is None and not motor else self._efforts_out(out, motor)
        if backend == "auto" and not details and _AUTO_BACKEND:
            fast = _AUTO_BACKEND[0](self)  # the hot path: one look-up
        else:
            fast = self._fast_backend(backend, details)
        if fast is not None:
            out = fast.inverse_dynamics(pose, twist, accel)
        else:
            out = self._kind.inverse_dynamics(self, pose, twist, accel, details, False)
            if details:
                return out
        if self._actuators is None and not motor:
            return out
        return self._efforts_out(out, motor)

    def _efforts_out(self, gamma: Any, motor: bool) -> Any:
        """The one conversion of the description's joint-side efforts to the robot's
        boundary: the motor side (``Gamma / ratio``, the path's :meth:`motor_side`) and
        the actuator convention's signs (:attr:`actuator_convention`)."""
        if motor:
            gamma = self._kind.motor_side(self, gamma)
        a = self._actuators
        return gamma if a is None else a.efforts_from_description(gamma)

    def direct_dynamics(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        gamma: ArrayLike,
        backend: str = "auto",
        idle: Any = None,
    ) -> FloatArray:
        """Classical platform acceleration ``[dv/dt, dw/dt]`` in F0 (eq. 35):
        ``A_robot Vdot_p = Jp^-T Gamma - h_robot``, solved by Cholesky.

        Args:
            pose: 0Tp (4, 4) or (N, 4, 4); twist: (6,) or (N, 6); gamma: actuator forces
                (6,) or (N, 6) [N].
            backend: ``"auto"`` (default: compiled where a C compiler is available, else
                the reference), ``"pinocchio"`` (reference) or ``"compiled"`` (generated C);
                see :meth:`inverse_dynamics`.
            idle: the idle joints' ``(values, rates)`` of a robot with idle freedoms (as
                :meth:`inverse_dynamics`; their accelerations: :meth:`direct_dynamics_idle`).

        General legs: ``gamma`` are the actuated joints' joint-side efforts [N or N m];
        Coulomb friction is ``Fc sign(qdot)``, zero at zero joint velocity (no stiction).
        ``gamma`` in the robot's :attr:`actuator_convention`.

        Raises:
            NumericalError: finite inputs whose acceleration overflows (every backend).
            InputError: an unknown backend.
        """
        if idle is not None:
            return self.direct_dynamics_idle(pose, twist, gamma, idle, backend)[0]
        if backend == "auto" and _AUTO_BACKEND:
            fast = _AUTO_BACKEND[0](self)  # the hot path: one look-up
        else:
            fast = self._fast_backend(backend)
        if self._actuators is not None:
            pose, twist, gamma = self._efforts_in(pose, twist, gamma)
        if fast is not None:
            return fast.direct_dynamics(pose, twist, gamma)
        return self._kind.direct_dynamics(self, pose, twist, gamma)

    # ------------------------------------------------------------------ idle freedoms
    def inverse_dynamics_idle(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        accel: ArrayLike,
        idle: Any,
        backend: str = "auto",
        motor: bool = False,
    ) -> tuple[FloatArray, FloatArray]:
        """A robot with idle freedoms (chain legs with ``idle_joint``, an R-S-S rod's
        spin): the actuated efforts (as :meth:`inverse_dynamics`) and the idle joints'
        accelerations (6,) or (N, 6) [rad/s^2 or m/s^2, 0 for a leg without one], at the
        idle joints' ``idle = (values, rates)``, each (6,) or (N, 6). ``backend``: as
        :meth:`inverse_dynamics` (compiled: :mod:`stewart_pin.codegen.idle_compiled`)."""
        gamma, sigma = self._idle_models(backend).inverse_dynamics(pose, twist, accel, idle)
        if self._actuators is not None or motor:
            gamma = self._efforts_out(gamma, motor)
        return gamma, sigma

    def direct_dynamics_idle(
        self,
        pose: ArrayLike,
        twist: ArrayLike,
        gamma: ArrayLike,
        idle: Any,
        backend: str = "auto",
    ) -> tuple[FloatArray, FloatArray]:
        """A robot with idle freedoms: the platform's classical acceleration (as
        :meth:`direct_dynamics`) and the idle joints' accelerations (6,) or (N, 6) at the
        idle joints' ``idle = (values, rates)``; ``backend`` as :meth:`direct_dynamics`."""
        models = self._idle_models(backend)
        if self._actuators is not None:
            pose, twist, gamma = self._efforts_in(pose, twist, gamma)
        return models.direct_dynamics(pose, twist, gamma, idle)

    def _idle_reference(self) -> _IdleReference:
        self._check_idle()
        return _IdleReference(self.chain_dynamics)

    def _check_idle(self) -> None:
        """:class:`InputError` for an idle state given to a robot without idle joints (the
        answer kept with the robot, per description)."""
        memo = self.__dict__.get("_idle_memo")
        if memo is None or memo[0] is not self.description:
            memo = (self.description, bool(leg_chains_idle(self.description)))
            self.__dict__["_idle_memo"] = memo
        if not memo[1]:
            raise InputError(
                f"robot '{self.name}' has no idle joints (ChainLeg.idle_joint): give "
                "idle=None (its state is the pose and twist only)"
            )

    def _idle_models(self, backend: str) -> Any:
        """The models taking the idle state: the compiled ones
        (:func:`stewart_pin.codegen.idle_compiled.idle_backend`) or the reference
        (:class:`_IdleReference`), as ``backend`` chooses (see :meth:`_fast_backend`)."""
        self._check_idle()
        if backend == "auto":
            if not _AUTO_IDLE:
                from stewart_pin.codegen.idle_compiled import auto_idle_backend

                _AUTO_IDLE.append(auto_idle_backend)
            fast = _AUTO_IDLE[0](self)
            return fast if fast is not None else _IdleReference(self.chain_dynamics)
        if backend == "pinocchio":
            return _IdleReference(self.chain_dynamics)
        if _compiled(backend):
            from stewart_pin.codegen.idle_compiled import idle_backend

            return idle_backend(self)
        return None  # pragma: no cover - _compiled raised

    # ------------------------------------------------------------------ derivatives
    def inverse_dynamics_derivatives(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike, idle: Any = None
    ) -> InverseDynamicsDerivatives | IdleInverseDerivatives:
        """Gamma and its exact Jacobians ``.pose``, ``.twist``, ``.accel`` (6, 6) (or
        (N, 6, 6)) in the platform state, from CasADi's differentiation of the compiled
        closed form (:mod:`stewart_pin.codegen.derivatives`; built on first use).

        ``.pose`` is with respect to ``delta = [dp, dtheta]`` in F0 (``p + dp``,
        ``R <- exp(dtheta^) R``), so that along a motion
        ``dGamma/dt = D.pose @ [v, w] + D.twist @ Vdot + D.accel @ dVdot/dt`` (Vdot the
        classical acceleration). Arguments and errors as :meth:`inverse_dynamics`
        (general legs included: their Gamma is the actuated joints' efforts), Gamma in the
        robot's :attr:`actuator_convention`.

        A robot with idle freedoms takes ``idle = (values, rates)`` (as
        :meth:`inverse_dynamics_idle`) and returns an
        :class:`~stewart_pin.codegen.idle_compiled.IdleInverseDerivatives`: the efforts
        and the idle accelerations (rows: 6 + 6) differentiated in the pose, twist,
        acceleration and the idle joints' values and rates."""
        if idle is not None:
            self._idle_reference()  # a robot without idle joints refuses one
            di = _idle_derivatives(self).inverse_dynamics_derivatives(pose, twist, accel, idle)
            a = self._actuators
            if a is None:
                return di
            sign = np.concatenate([a.signs, np.ones(6)])[:, None]
            return replace(
                di,
                gamma=a.efforts_from_description(di.gamma),
                pose=sign * di.pose,
                twist=sign * di.twist,
                accel=sign * di.accel,
                idle_values=sign * di.idle_values,
                idle_rates=sign * di.idle_rates,
            )
        self._no_idle_state()
        d = _derivatives(self).inverse_dynamics_derivatives(pose, twist, accel)
        a = self._actuators
        if a is None:
            return d
        return replace(
            d,
            gamma=a.efforts_from_description(d.gamma),
            pose=a.rows(d.pose),
            twist=a.rows(d.twist),
            accel=a.rows(d.accel),
        )

    def direct_dynamics_derivatives(
        self, pose: ArrayLike, twist: ArrayLike, gamma: ArrayLike, idle: Any = None
    ) -> DirectDynamicsDerivatives | IdleDirectDerivatives:
        """The classical acceleration ``.accel`` and its exact Jacobians ``.pose``,
        ``.twist``, ``.gamma`` (6, 6) (or (N, 6, 6)); the pose chart as in
        :meth:`inverse_dynamics_derivatives`. Arguments and errors as
        :meth:`direct_dynamics` (``gamma`` and ``.gamma`` in the robot's
        :attr:`actuator_convention`); ``idle`` as
        :meth:`inverse_dynamics_derivatives` (an
        :class:`~stewart_pin.codegen.idle_compiled.IdleDirectDerivatives`)."""
        a = self._actuators
        if idle is not None:
            self._idle_reference()
            if a is not None:
                pose, twist, gamma = self._efforts_in(pose, twist, gamma)
            di = _idle_derivatives(self).direct_dynamics_derivatives(pose, twist, gamma, idle)
            return di if a is None else replace(di, gamma=a.columns(di.gamma))
        self._no_idle_state()
        if a is None:
            return _derivatives(self).direct_dynamics_derivatives(pose, twist, gamma)
        d = _derivatives(self).direct_dynamics_derivatives(*self._efforts_in(pose, twist, gamma))
        return replace(d, gamma=a.columns(d.gamma))

    def cartesian_dynamics(
        self, pose: ArrayLike, twist: ArrayLike
    ) -> CartesianDynamics | GeneralCartesianDynamics | ChainCartesianDynamics:
        """``A_robot`` (N, 6, 6) and ``h_robot`` (N, 6) of eq. 36-37 (always batch arrays);
        :class:`NumericalError` when either is not finite. General legs: a
        :class:`~stewart_pin.dynamics.leg_chain_dynamics.GeneralCartesianDynamics`."""
        cd = self._kind.cartesian_dynamics(self, pose, twist)
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
        potential (zero with every centre of mass at the origin of F0); general legs: the
        armatures' kinetic energy and the joint springs' potential included."""
        return self._kind.energy(self, pose, twist)

    def dissipated_power(self, pose: ArrayLike, twist: ArrayLike) -> FloatArray | float:
        """Power lost in the joints' friction and dampers [W]:
        ``sum (Fv + D) qdot^2 + Fc |qdot|`` over the 18 joints; 0 for the ideal 6-UPS
        (frictionless). With it the power balance reads
        ``Gamma . qdot_a = dE/dt + dissipated_power``."""
        return self._kind.dissipated_power(self, pose, twist)

    def simulation_stepper(self, backend: str, *args: Any) -> Any:
        """The compiled loop of one :func:`~stewart_pin.motion.simulation.simulate` run
        (:func:`stewart_pin.codegen.simulator.compiled_stepper`), or the sentence saying why
        it cannot run it (the Python loop then does)."""
        from stewart_pin.codegen.simulator import compiled_stepper

        return compiled_stepper(self, backend, *args)

    def _fast_backend(self, backend: str, details: bool = False) -> Any:
        """The compiled backend serving a dynamics call, or ``None`` for the reference
        path: ``"auto"`` (:func:`stewart_pin.codegen.compiled.auto_backend`; the reference
        for what the compiled models cannot serve: ``details=True``), ``"compiled"``
        (:meth:`_compiled_backend`), ``"pinocchio"``; :class:`InputError` otherwise."""
        if backend == "auto":
            if details:
                return None
            if not _AUTO_BACKEND:
                from stewart_pin.codegen.compiled import auto_backend

                _AUTO_BACKEND.append(auto_backend)
            return _AUTO_BACKEND[0](self)
        if backend == "pinocchio":
            return None
        if _compiled(backend, details):
            self._no_idle_state()
            return self._compiled_backend()
        return None  # pragma: no cover - _compiled raised

    def _no_idle_state(self) -> None:
        """:class:`InputError` (the reference's) for a robot with idle freedoms called
        without their state: its models need ``idle=(values, rates)``."""
        if leg_chains_idle(self.description):
            self.chain_dynamics.idle_state(None, 1)

    @cached_property
    def _motor_ratio(self) -> FloatArray:
        """The actuated joints' transmission ratios (6,) (``Gamma / ratio`` is the motor
        side)."""
        legs = self.general.legs
        return np.array([leg.joints[leg.actuated - 1].dynamics.transmission_ratio for leg in legs])

    def regressor(
        self, pose: ArrayLike, twist: ArrayLike, accel: ArrayLike, idle: Any = None
    ) -> FloatArray:
        """The dynamic regressor ``W`` with ``Gamma = W chi``: (6, n) or (N, 6, n).

        Columns: leg 1 link 1 (10, Khalil order), leg 1 link 2, ..., leg 6 link 3, platform
        (n = 190 for the ideal 6-UPS robot); general legs add each joint's five terms
        ``IA FV FC K OF`` (n = 280; joint-side efforts, joint limits checked as in
        :meth:`inverse_dynamics`). Names in
        :func:`stewart_pin.dynamics.regressor.standard_parameter_names`. Rows in the
        robot's :attr:`actuator_convention` (``W chi`` is :meth:`inverse_dynamics`).

        Chain legs with idle joints (an R-S-S rod's spin, ``ChainLeg.idle_joint``):
        ``idle=(values, rates, accelerations)``, each (6,) or (N, 6) [rad or m, /s,
        /s^2], required there and refused elsewhere (:class:`InputError`). With the spin
        accelerations given (measured, or a simulation's:
        :func:`~stewart_pin.motion.idle_simulation.simulate_idle`), Gamma is linear in the
        parameters: ``W chi`` is :meth:`inverse_dynamics_idle`'s Gamma when they are the
        spin accelerations it returns
        (:meth:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics.regressor_batch`).
        """
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        if idle is None and not leg_chains_idle(self.description):
            W = self._kind.regressor(self, T, V, A)
        else:  # idle given or required: the chain legs' regressor checks it
            if not self.description.has_chain_legs:
                raise InputError(
                    f"robot '{self.name}' has no idle joints (ChainLeg.idle_joint): give "
                    "idle=None (its state is the pose and twist only)"
                )
            with quiet_overflow():
                W = check_finite(self.chain_dynamics.regressor_batch(T, V, A, idle), "regressor")
        if self._actuators is not None:
            W = self._actuators.rows(W)
        return W if batched else W[0]

    # ------------------------------------------------------------------ C export
    def export_c(
        self,
        folder: str | Path,
        prefix: str,
        samples: int = 8,
        seed: int = 0,
        derivatives: bool = False,
    ) -> list[Path]:
        """Write the closed-form models as a standalone C99 library into ``folder``:
        ``PREFIX.h``, ``PREFIX.c`` (no CasADi, no Python, no heap allocation), a test
        program with reference values of this robot's Python path, a benchmark, a C++
        control-loop example, ``CMakeLists.txt`` and ``README.md`` (``docs/export_c.md``;
        :func:`stewart_pin.codegen.c_export.export_c`).

        Args:
            folder: absent (created) or holding only a previous export with this prefix.
            prefix: a C identifier naming the files and functions (``PREFIX_inverse_dynamics``).
            samples: random states embedded in the test program. seed: their seed.
            derivatives: also ``PREFIX_inverse_dynamics_derivatives`` (Gamma's Jacobians).

        Returns:
            The paths written.

        Raises:
            ExportError: a prefix that is not a C identifier, an output folder that exists
                with other files, a robot that cannot export.

        The exported C speaks the robot's :attr:`actuator_convention` (an imported
        robot's: its file's; the mapping to the named architecture's is in the export's
        ``README.md``).
        """
        from stewart_pin.codegen.c_export import export_c

        return export_c(self, folder, prefix, samples=samples, seed=seed, derivatives=derivatives)

    # ------------------------------------------------------------------ payload
    def with_payload(self, payload: Any, placement: Any = None) -> PayloadRobot:
        """This hexapod carrying ``payload`` on its platform: a
        :class:`~stewart_pin.payload_robot.PayloadRobot` (see ``docs/payloads.md``).

        Args:
            payload: a robot name of example-robot-data (``"ur5"``, ``"panda"``; needs
                ``pip install "stewart-pin[payload]"``), a URDF path, a fixed-base
                ``pin.Model`` or a :class:`~stewart_pin.models.payload.Payload`.
            placement: ``T_p_b`` (4, 4) or ``pin.SE3``, the payload's base frame in
                ``Fp`` (default: on the platform's deck above the centroid of the platform
                joints, axes along ``Fp``'s; a ``Payload`` keeps its own).
        """
        from stewart_pin.payload_robot import PayloadRobot

        return PayloadRobot(self, payload, placement)


class _IdleReference:
    """The reference path's models of a robot with idle freedoms, with the compiled idle
    models' calls (:class:`~stewart_pin.codegen.idle_compiled.CompiledIdleDynamics`)."""

    def __init__(self, dynamics: ChainDynamics) -> None:
        self._dyn = dynamics

    def inverse_dynamics(
        self, pose: Any, twist: Any, accel: Any, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        with quiet_overflow():  # overflow: NumericalError below
            r = self._dyn.inverse_batch(T, V, A, idle)
        gamma = check_finite(r.gamma, "inverse dynamics Gamma")
        return (gamma, r.idle_accel) if batched else (gamma[0], r.idle_accel[0])

    def details(self, pose: Any, twist: Any, accel: Any, idle: Any) -> ChainInverseDynamics:
        with quiet_overflow():  # overflow: the reference's NumericalError
            return self._dyn.inverse_dynamics(pose, twist, accel, details=True, idle=idle)

    def direct_dynamics(
        self, pose: Any, twist: Any, gamma: Any, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        with quiet_overflow():  # overflow: the reference's NumericalError
            return self._dyn.direct_dynamics_idle(pose, twist, gamma, idle)


#: The backends of the dynamic models: ``"auto"`` is the default (compiled where a C
#: compiler is available, else the reference; ``$STEWART_PIN_BACKEND=pinocchio`` makes it
#: the reference: :func:`stewart_pin.codegen.compiled.auto_backend`).
BACKENDS = ("pinocchio", "compiled", "auto")
#: :func:`stewart_pin.codegen.compiled_backend`, imported on first use (saves the import
#: statement on every compiled call).
_COMPILED_BACKEND: list[Any] = []
#: :func:`stewart_pin.codegen.compiled.auto_backend`, imported on first use.
_AUTO_BACKEND: list[Any] = []
#: :func:`stewart_pin.codegen.idle_compiled.auto_idle_backend`, imported on first use.
_AUTO_IDLE: list[Any] = []


def _compiled(backend: str, details: bool = False) -> bool:
    """Whether ``backend`` is the compiled one; raises on unknown names."""
    if backend not in BACKENDS:
        raise InputError(f"unknown backend '{backend}': choose one of {BACKENDS}")
    if backend == "compiled" and details:
        raise InputError(
            "details=True needs backend='pinocchio' (the compiled model returns Gamma)"
        )
    return backend == "compiled"


if TYPE_CHECKING:
    from stewart_pin.codegen.derivatives import (
        DirectDynamicsDerivatives,
        InverseDynamicsDerivatives,
    )
    from stewart_pin.codegen.idle_compiled import IdleDirectDerivatives, IdleInverseDerivatives


def _idle_derivatives(robot: StewartRobot) -> Any:
    """The robot's :class:`~stewart_pin.codegen.idle_compiled.CompiledIdleDerivatives`."""
    from stewart_pin.codegen.idle_compiled import idle_derivatives_backend

    return idle_derivatives_backend(robot)


def _derivatives(robot: StewartRobot) -> Any:
    """The robot's :class:`~stewart_pin.codegen.derivatives.CompiledDerivatives`."""
    from stewart_pin.codegen.derivatives import derivatives_backend

    return derivatives_backend(robot)
