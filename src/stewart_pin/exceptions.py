"""The exceptions and warnings stewart-pin raises, all of them and nothing else.

Every error the package raises derives from :class:`StewartPinError`; the base itself is
never raised, always one of its subclasses. Each also derives from the standard exception
of its kind (``ValueError``, ``TypeError``, ``RuntimeError``, ``ArithmeticError``), so code
written against the standard library's conventions keeps working. Each keeps the offending
values as attributes (``leg``, ``value``, ``lower``, ``upper``...; ``None`` where a value is
unknown) so that callers can react programmatically, and its message says what was
expected, what was received and how to fix it::

    StewartPinError
    ├── InputError (ValueError)              a bad argument: shape, type, NaN, range
    │   └── InputTypeError (TypeError)       an argument of the wrong kind of object
    ├── DescriptionError (ValueError)        an inconsistent robot description
    │   ├── InertiaError                     inertial parameters no rigid body can have
    │   ├── ArchitectureError                a leg that is not three 1-dof joints as named
    │   │   ├── UnsupportedArchitectureError what one architecture's physics cannot have
    │   │   └── LegMobilityError             a chain leg not giving the platform 6 dof
    │   ├── JointDynamicsError               non-physical joint terms (negative friction...)
    │   ├── GravityCompensationError         a gravity compensation outside [0, 1]
    │   └── RobotNameError                   a name outside the safe set
    ├── FileFormatError (ValueError)         a malformed file
    │   ├── ModelImportError                 a model file that is not a six-legged platform
    │   │   ├── LoopClosureError             loops that do not close at the reference
    │   │   └── RodSpinError                 an S-S rod whose spin cannot be removed exactly
    │   └── LogError                         a measurement log unfit for identification
    │       ├── LogValueError                a non-numeric or non-finite value
    │       ├── LogTimeError                 time stamps that do not increase, or irregular
    │       ├── LogGapError                  a gap in the time stamps (samples missing)
    │       ├── LogSaturationError           an effort at its actuator's limit (clipped)
    │       └── LogLimitError                a position outside the stroke / joint limits
    ├── WorkspaceError (ValueError)          a pose the robot cannot reach
    │   ├── StrokeLimitError                 a leg length outside its stroke
    │   ├── JointLimitError                  a U-joint angle outside its limits
    │   ├── LegReachError                    a general leg that cannot reach its P_i
    │   ├── LegJointLimitError               a general leg's joint outside its limits
    │   └── EmptyWorkspaceError              no feasible state: an empty workspace, an
    │                                        unreachable orientation set
    ├── SingularityError (ValueError)        at or too near a singularity
    ├── NumericalError (ArithmeticError)     finite inputs, non-finite result
    ├── ConvergenceError (RuntimeError)      an iteration that did not converge
    ├── SimulationError                      a simulation stopped before its end
    ├── IdentificationError (ValueError)     measurements that identify nothing
    │   └── PhysicalFitError                 no realisable robot explains the data
    ├── CompilationError (RuntimeError)      the C library not built or loaded
    │   └── UnsafeCacheError                 a cache others could write to
    ├── ViewerError (RuntimeError)           the 3-D viewer's server did not start
    ├── SchedulerError (ConnectionError)     a Dask scheduler that cannot be reached
    ├── PayloadError (ValueError)            a payload model that cannot be mounted
    │   ├── UnknownPayloadError              a payload name no installed package knows
    │   └── PayloadMeshError                 a mesh file outside the payload's folders
    └── MissingDependencyError (ImportError) an optional package is not installed

    StewartPinWarning (UserWarning)          input accepted after a correction
    ├── BaseParameterWarning                 base parameters that barely act
    ├── ApproximationWarning                 an export that changes the robot
    └── ModelImportWarning                   an import that corrected or ignored something

    KeyboardInterrupt
    └── SimulationInterrupted                Ctrl-C during a simulation, with its states
"""

from __future__ import annotations

from pathlib import Path


class StewartPinError(Exception):
    """Base class of every error raised by stewart-pin (never raised itself)."""


# ---------------------------------------------------------------------------- input
class InputError(StewartPinError, ValueError):
    """An argument has the wrong shape, type, or holds NaN / infinite values."""


class InputTypeError(InputError, TypeError):
    """An argument that is not the kind of object expected (e.g. a dict where a
    :class:`~stewart_pin.description.robot_description.RobotDescription` is needed)."""


# ---------------------------------------------------------------------------- description
class DescriptionError(StewartPinError, ValueError):
    """A robot description is inconsistent (geometry, frames, strokes, gravity)."""


class InertiaError(DescriptionError):
    """Inertial parameters that no rigid body can have.

    Attributes:
        body: name of the offending body (e.g. ``"leg 3 link 2"``, ``"platform"``).
    """

    def __init__(self, message: str, body: str = "") -> None:
        super().__init__(message)
        self.body = body


class ArchitectureError(DescriptionError):
    """A leg architecture that stewart-pin cannot model: a chain that is not three 1-dof
    joints (revolute or prismatic), an actuated index outside 1..3, a branch other than
    +1 / -1, or joint placements that do not fit the named architecture's closed form.

    Attributes:
        field: the offending field (``"joints"``, ``"actuated"``, ``"branch"``...).
        value: the offending value, as received.
    """

    def __init__(self, message: str, field: str = "", value: object = None) -> None:
        super().__init__(message)
        self.field, self.value = field, value


class UnsupportedArchitectureError(ArchitectureError):
    """What belongs to one architecture asked of a robot of another: the paper's 88
    grouped parameters and Table III (the ideal 6-UPS's R-R-P legs), the analytic base
    parameters of ``custom`` legs (no grouping rules foresee an arbitrary chain: the
    numerical base set works), a 6-UPS closed form called on other legs. Every feature of
    the facade and the command line takes every architecture; the message names the
    physical reason and what works instead.

    Attributes:
        field: the feature. value: the robot's architecture (``"rus"``, ``"mixed"``...).
    """


class LegMobilityError(ArchitectureError):
    """A chain leg whose joints with its closure do not give the platform its six degrees
    of freedom: fewer joints than the closure's constraints (ball 3, weld 6), one more (an
    idle freedom such as an R-S-S rod's spin) without ``idle_joint`` naming its coordinate,
    or more, a Jacobian that is singular at the home pose, or an idle joint that does not
    move the idle freedom or whose motion moves the actuator
    (:mod:`stewart_pin.description.chain_leg`).

    Attributes:
        leg: leg index (1-based). missing: freedoms the platform lacks. extra: freedoms too
        many. rank: the rank of the leg's Jacobian at the home pose (``None`` if not
        computed).
    """

    def __init__(
        self,
        message: str,
        leg: int,
        missing: int = 0,
        extra: int = 0,
        rank: int | None = None,
    ) -> None:
        super().__init__(message, "chain_legs", leg)
        self.leg, self.missing, self.extra, self.rank = leg, missing, extra, rank


class JointDynamicsError(DescriptionError):
    """Joint or actuator dynamics that no real joint has: a negative armature, friction,
    stiffness or damping, a non-positive gear ratio or screw lead, both a gear ratio and
    a screw lead.

    Attributes:
        field: the offending parameter (``"armature"``, ``"coulomb"``...); value: its value.
    """

    def __init__(self, message: str, field: str = "", value: object = None) -> None:
        super().__init__(message)
        self.field, self.value = field, value


class GravityCompensationError(DescriptionError):
    """A per-body gravity compensation (the fraction of a body's weight removed,
    ``platform_gravcomp``, ``leg_gravcomp``, a chain leg's ``gravcomp``) that is not a
    finite number in [0, 1], a ``leg_gravcomp`` that is not one list per leg with one
    factor per link (or is given beside ``chain_legs``), or a chain leg's ``gravcomp``
    that is not one factor per link.

    Attributes:
        body: the body (``"platform"``, ``"leg 2 link 3"``) or the key when the shape is
            wrong.
        value: the offending value, as received.
    """

    def __init__(self, message: str, body: str = "", value: object = None) -> None:
        super().__init__(message)
        self.body, self.value = body, value


class RobotNameError(DescriptionError):
    """A robot name outside the safe set (``stewart_pin.description.NAME_RULE``): it would
    name files outside their folder or break the markup written for the robot.

    Attributes:
        value: the refused name (any type, as received).
    """

    def __init__(self, message: str, value: object) -> None:
        super().__init__(message)
        self.value = value


class FileFormatError(StewartPinError, ValueError):
    """A description, URDF, closure or measurement file is malformed."""


# ---------------------------------------------------------------------------- workspace
class WorkspaceError(StewartPinError, ValueError):
    """A pose the robot cannot reach (base class of the more specific errors).

    Every subclass carries ``state``, in a batch the first failing state (0-based;
    ``None`` for one state or when unknown), and ``n_bad`` / ``n_states``, how many states
    fail of how many (``None`` when unknown); the message then says "(first failing state
    n; k of N states fail)".
    """

    state: int | None = None
    n_bad: int | None = None
    n_states: int | None = None


class StrokeLimitError(WorkspaceError):
    """A leg length outside the actuator's stroke.

    Attributes:
        leg: leg index, 1-based as in the paper.
        value: the leg length [m].
        lower, upper: the stroke limits [m].
    """

    def __init__(self, leg: int, value: float, lower: float, upper: float) -> None:
        super().__init__(
            f"leg {leg} length {value:.9g} m is outside its stroke [{lower:.9g}, {upper:.9g}] m; "
            "choose a pose closer to the workspace centre or widen the stroke"
        )
        self.leg, self.value, self.lower, self.upper = leg, value, lower, upper


class JointLimitError(WorkspaceError):
    """A universal-joint angle outside its limits.

    Attributes:
        leg: leg index (1-based); joint: 1 or 2 (q1i or q2i); value, lower, upper [rad].
    """

    def __init__(self, leg: int, joint: int, value: float, lower: float, upper: float) -> None:
        super().__init__(
            f"leg {leg} U-joint angle q{joint}{leg} = {value:.9g} rad is outside its limits "
            f"[{lower:.9g}, {upper:.9g}] rad"
        )
        self.leg, self.joint, self.value, self.lower, self.upper = leg, joint, value, lower, upper


class LegReachError(WorkspaceError):
    """A leg that cannot reach its platform point: the closed-form inverse geometry has
    no real solution (a crank or slide too short or too far, a rod too short).

    Attributes:
        leg: leg index (1-based); value: the unreachable measure (e.g. ``|cos|`` > 1 of
        the crank equation, or the negative discriminant of the slide's) [-].
    """

    def __init__(self, message: str, leg: int, value: float) -> None:
        super().__init__(message)
        self.leg, self.value = leg, value


class LegJointLimitError(WorkspaceError):
    """A joint of a general leg outside its limits.

    Attributes:
        leg: leg index (1-based); joint: 1, 2 or 3; value, lower, upper [rad or m].
    """

    def __init__(self, leg: int, joint: int, value: float, lower: float, upper: float) -> None:
        super().__init__(
            f"leg {leg} joint {joint} value {value:.9g} is outside its limits "
            f"[{lower:.9g}, {upper:.9g}] (rad for a revolute joint, m for a prismatic one); "
            "choose a pose closer to the workspace centre or widen the limits"
        )
        self.leg, self.joint, self.value, self.lower, self.upper = leg, joint, value, lower, upper


class EmptyWorkspaceError(WorkspaceError):
    """A design study with no feasible state to work on: an empty workspace (no state of
    the box satisfies every limit), a start (the home position, the home orientation)
    that is itself infeasible, an orientation set the platform cannot reach
    (:mod:`stewart_pin.design`)."""


class SingularityError(StewartPinError, ValueError):
    """A configuration at or too near a singularity.

    Attributes:
        value: the measure that crossed its threshold (condition number, sin q2i, ...),
            ``None`` when none was computed.
        threshold: the threshold it crossed, ``None`` when there is none.
        leg: the leg concerned (1-based) or ``None`` for the parallel (platform) singularity.
        state, n_bad, n_states: in a batch, the first failing state (0-based) and how many
            states fail, of how many (``None`` for one state or when unknown), as
            :class:`WorkspaceError`.
    """

    state: int | None = None
    n_bad: int | None = None
    n_states: int | None = None

    def __init__(
        self,
        message: str,
        value: float | None = None,
        threshold: float | None = None,
        leg: int | None = None,
    ) -> None:
        super().__init__(message)
        self.value, self.threshold, self.leg = value, threshold, leg

    @classmethod
    def not_positive_definite(cls) -> SingularityError:
        """``A_robot`` of eq. 36 is not positive definite (its Cholesky factorisation or
        pivots failed): no measure is computed, ``value`` and ``threshold`` are ``None``."""
        return cls("A_robot is not positive definite (massless robot or singular leg)")


# ---------------------------------------------------------------------------- numerical
class NumericalError(StewartPinError, ArithmeticError):
    """A finite input gave a non-finite result: the computation overflowed double precision.

    The dynamic models check their outputs instead of returning NaN or infinity (e.g. a
    twist of 1e160 m/s, whose square overflows, or forces of 1e308 N).

    Attributes:
        output: which result is not finite (e.g. ``"inverse dynamics Gamma"``).
        index: the first state of the batch (0-based) with a non-finite value, 0 for one
            state, ``None`` when unknown.
        n_bad: how many states are not finite (``None`` when unknown).
        n_states: the number of states computed (``None`` when unknown).

    ``message`` (keyword) replaces the overflow's text when the number is refused for
    another reason: the exact derivatives at a state where the legs' unrolled Newton steps
    from home did not converge (:mod:`stewart_pin.codegen.derivatives`).
    """

    def __init__(
        self,
        output: str,
        index: int | None = 0,
        n_bad: int | None = None,
        n_states: int | None = None,
        message: str | None = None,
    ) -> None:
        if message is not None:  # not an overflow: the caller's account of the number
            super().__init__(message)
            self.output, self.index, self.n_bad, self.n_states = output, index, n_bad, n_states
            return
        where = "" if index is None else f" at state {index}"
        count = (
            ""
            if n_bad is None or not n_states or n_states < 2
            else f" ({n_bad} of {n_states} states)"
        )
        super().__init__(
            f"{output} is not finite{where}{count}: expected a finite result from finite "
            "inputs, but the computation overflowed double precision: the state (twist, "
            "acceleration, forces) or the robot's parameters are far outside any physical "
            "range; give values of physical magnitude"
        )
        self.output, self.index, self.n_bad, self.n_states = output, index, n_bad, n_states


class ConvergenceError(StewartPinError, RuntimeError):
    """An iterative computation did not converge: the forward geometry's Newton iteration,
    or the adaptive step control of a simulation (the step fell below its minimum).

    Attributes:
        iterations: iterations performed (``None`` when not counted); residual: the last
            residual (forward geometry: the largest leg-length error [m]; step control: the
            error estimate in units of the tolerance), ``None`` when unknown.
    """

    def __init__(self, message: str, iterations: int | None, residual: float | None) -> None:
        super().__init__(message)
        self.iterations, self.residual = iterations, residual


# ---------------------------------------------------------------------------- simulation
class SimulationError(StewartPinError):
    """A simulation stopped before its end: a leg reached its stroke end or a U-joint its
    limit, the robot reached a singularity, the step control failed, or the forces
    function (a controller) or the progress callback raised.

    The named error that stopped it is chained as ``__cause__`` (a
    :class:`StrokeLimitError`, :class:`JointLimitError`, :class:`SingularityError`, a
    :class:`ConvergenceError` of the step control, or the callback's own exception;
    ``None`` for the bound on the number of steps).

    Attributes:
        time: the simulated time [s] of the last accepted state (where it stopped).
        result: the ``SimulationResult`` up to and including that state (accepted
            states only; empty when the initial state itself is refused).
    """

    def __init__(self, message: str, time: float, result: object) -> None:
        super().__init__(message)
        self.time, self.result = time, result


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C (``KeyboardInterrupt``) during a simulation, with what was simulated until
    then. A ``KeyboardInterrupt``, not a :class:`StewartPinError`: ``except Exception``
    and ``except StewartPinError`` let it through, as any interrupt.

    Attributes:
        time: the simulated time [s] of the last accepted state.
        result: the ``SimulationResult`` up to and including that state (accepted
            states only; empty when the interrupt came before the first).
    """

    def __init__(self, time: float, result: object) -> None:
        super().__init__(f"simulation interrupted at t = {time:.9g} s (simulated time)")
        self.time, self.result = time, result


# ---------------------------------------------------------------------------- identification
class IdentificationError(StewartPinError, ValueError):
    """Measurements that cannot identify the base parameters: too few equations, or a
    stacked base regressor of deficient rank (a trajectory that does not excite them all).

    Attributes:
        rank: the numerical rank of the stacked base regressor (``None`` when not computed).
        n_parameters: the number of base parameters (``None`` when not known).
    """

    def __init__(
        self, message: str, rank: int | None = None, n_parameters: int | None = None
    ) -> None:
        super().__init__(message)
        self.rank, self.n_parameters = rank, n_parameters


class PhysicalFitError(IdentificationError):
    """A physically consistent fit whose residual is not credible: far worse than least
    squares (more than :data:`~stewart_pin.parameters.physical.MAX_FIT_LOSS` of its
    residual in the noise's units) and losing a large part of the efforts (more than
    :data:`~stewart_pin.parameters.physical.MAX_SIGNAL_LOSS` of their weighted energy):
    no realisable robot explains the data (efforts of the wrong sign, a wrong robot, a
    wrong unit), so none is written.

    Attributes:
        fit_loss: ``rss / rss_least_squares - 1``.
        signal_loss: ``(rss - rss_least_squares) / |W y|^2``, the fraction of the
            weighted efforts' energy the physical fit misses beyond least squares.
        mahalanobis: the distance of the physical fit from the estimate in units of its
            covariance.
        solver: the solver and its status.
    """

    def __init__(
        self,
        message: str,
        fit_loss: float,
        signal_loss: float,
        mahalanobis: float,
        solver: str,
    ) -> None:
        super().__init__(message)
        self.fit_loss, self.signal_loss = fit_loss, signal_loss
        self.mahalanobis, self.solver = mahalanobis, solver


# ---------------------------------------------------------------------------- codegen, viz
class CompilationError(StewartPinError, RuntimeError):
    """The C library could not be built or loaded (the fallback says why)."""


class UnsafeCacheError(CompilationError):
    """The cache folder, or a file in it, could be written by someone else (another owner,
    group- or world-writable, or a symbolic link): nothing is loaded from it.

    Attributes:
        path: the offending folder or file. reason: what is wrong with it.
    """

    def __init__(self, path: Path, reason: str) -> None:
        super().__init__(
            f"refusing the compiled-model cache {path}: {reason}; code is loaded only from "
            "folders and files that are yours alone (chmod go-w, or set "
            "$STEWART_PIN_CACHE to a private folder)"
        )
        self.path, self.reason = path, reason


class ExportError(InputError):
    """The C exporter refuses (``robot.export_c``, ``stewart-pin export-c``): a prefix that
    is not a C identifier, an output folder that exists with other files, a robot that
    cannot export."""


class ViewerError(StewartPinError, RuntimeError):
    """The 3-D viewer's meshcat server did not start (timed out or exited early)."""


class SchedulerError(StewartPinError, ConnectionError):
    """A Dask scheduler (``--scheduler tcp://host:port``) that cannot be reached or that
    refused the connection (:func:`stewart_pin.design.sweep`).

    Attributes:
        address: the scheduler's address, as given.
    """

    def __init__(self, message: str, address: str) -> None:
        super().__init__(message)
        self.address = address


# ---------------------------------------------------------------------------- warnings


class StewartPinWarning(UserWarning):
    """Base class of stewart-pin's warnings; raised itself for input accepted after a
    documented correction (e.g. a rotation given to a few significant digits, projected
    onto SO(3)).

    Attributes:
        field: the corrected input (e.g. ``"leg_base_rotations[2]"``), ``""`` if none.
        correction: the size of the correction (e.g. ``max |R_projected - R|``), or ``None``.
    """

    def __init__(self, message: str, field: str = "", correction: float | None = None) -> None:
        super().__init__(message)
        self.field, self.correction = field, correction


class BaseParameterWarning(StewartPinWarning):
    """Base parameters that are identifiable in exact arithmetic but barely act on the
    forces (a first U-joint axis within a hair of gravity, a near-zero gravity, joint axes
    a hair off parallel), a numerical rank decided within a narrow margin of its
    tolerance, or the numerical set given for an analytic one (``custom`` legs)."""


class ApproximationWarning(StewartPinWarning):
    """An export that cannot hold the robot exactly and changes it (e.g. the MJCF of a
    body MuJoCo refuses as described: see :func:`stewart_pin.formats.mjcf.mujoco_inertials`)."""


# ---------------------------------------------------------------------------- payloads
class PayloadError(StewartPinError, ValueError):
    """A payload (a robot mounted on the platform, :mod:`stewart_pin.models.payload`) that
    cannot be used: a model with a floating base, a URDF Pinocchio cannot parse, a joint
    state of the wrong size or outside the configuration space."""


class UnknownPayloadError(PayloadError):
    """A payload name that is neither a file nor a robot of example-robot-data.

    Attributes:
        name: the name given.
        available: the robot names example-robot-data provides (sorted).
    """

    def __init__(self, message: str, name: str = "", available: tuple[str, ...] = ()) -> None:
        super().__init__(message)
        self.name, self.available = name, available


class PayloadMeshError(PayloadError):
    """A payload URDF's visual mesh whose real path (symbolic links resolved) lies outside
    the URDF's folder and its package directories (an absolute path, ``../``, ``file://``,
    a symbolic link shipped with the URDF): the drawing would copy that file into an HTML
    page made to be shared, or hand it to the viewer's server. Nothing is drawn.

    Attributes:
        mesh: the mesh path as the URDF resolves it. real: its real path.
        allowed: the real folders a mesh may lie under.
    """

    def __init__(self, message: str, mesh: str, real: str, allowed: tuple[str, ...]) -> None:
        super().__init__(message)
        self.mesh, self.real, self.allowed = mesh, real, tuple(allowed)


class MissingDependencyError(StewartPinError, ImportError):
    """An optional package a feature needs is not installed; the message names the extra
    that brings it (e.g. ``pip install "stewart-pin[payload]"``).

    Attributes:
        package: the missing distribution (e.g. ``"example-robot-data"``).
        extra: the stewart-pin extra that installs it (e.g. ``"payload"``).
    """

    def __init__(self, message: str, package: str = "", extra: str = "") -> None:
        super().__init__(message)
        self.package, self.extra = package, extra


# ---------------------------------------------------------------------------- importers
class ModelImportError(FileFormatError):
    """A model file (MJCF, URDF) that stewart-pin cannot read as a six-legged platform:
    not six legs, a leg whose joints and closure do not give the platform six freedoms (a
    ball leg of two joints, a leg of three joints welded where a ball should be), an
    actuator on a passive joint or none on a leg, a floating base, extra moving bodies, an
    unsupported element (see ``docs/importing.md``).

    Attributes:
        bodies: the names of the bodies involved, as written in the file (a tuple).
        joints: the names of the joints (or constraints, actuators) involved (a tuple).
    """

    def __init__(
        self, message: str, bodies: tuple[str, ...] = (), joints: tuple[str, ...] = ()
    ) -> None:
        super().__init__(message)
        self.bodies, self.joints = tuple(bodies), tuple(joints)


class LoopClosureError(ModelImportError):
    """Loops that do not close at the file's reference configuration (``qpos0``, a
    keyframe, the URDF's zero configuration) within the import's tolerance.

    Attributes:
        residuals: the distance [m] between the two sides of each leg's spherical joint,
            in leg order (a tuple of six floats).
        tolerance: the largest residual accepted [m].
    """

    def __init__(
        self,
        message: str,
        residuals: tuple[float, ...],
        tolerance: float,
        bodies: tuple[str, ...] = (),
    ) -> None:
        super().__init__(message, bodies)
        self.residuals, self.tolerance = tuple(residuals), tolerance


class RodSpinError(ModelImportError):
    """A rod between two spherical joints (R-S-S, P-S-S, S-P-S legs) whose inertia is not
    symmetric about its axis: the equivalent universal-joint leg would not be exact.

    Attributes:
        asymmetry: the relative asymmetry found (see ``docs/importing.md``).
        tolerance: the largest asymmetry accepted.
    """

    def __init__(
        self, message: str, asymmetry: float, tolerance: float, bodies: tuple[str, ...] = ()
    ) -> None:
        super().__init__(message, bodies)
        self.asymmetry, self.tolerance = asymmetry, tolerance


class ModelImportWarning(StewartPinWarning):
    """An import that proceeded after a correction or by ignoring something the file holds
    (loops assembled from a small residual, an S-S rod's asymmetric spin inertia accepted
    by option, a spherical joint's limits): the message says what and how much.

    Attributes:
        short: the same in a few words, or ``None``: what the robot commands that take
            ``--model`` print, once (``stewart-pin import`` prints the whole message).
    """

    def __init__(self, message: str, short: str | None = None) -> None:
        super().__init__(message)
        self.short = short


# ---------------------------------------------------------------------------- logs
class LogError(FileFormatError):
    """A measurement log (actuator positions and efforts) that identification cannot use
    as it is; the message names the file and line.

    Attributes:
        line: the line of the file (1-based; for a log built in memory, the sample index
            + 2, as if written with a header), or ``None``.
        column: the column's name (``"t"``, ``"l3"``, ``"gamma2"``...), or ``None``.
        value: the offending value, or ``None``.
    """

    def __init__(
        self,
        message: str,
        line: int | None = None,
        column: str | None = None,
        value: object = None,
    ) -> None:
        super().__init__(message)
        self.line, self.column, self.value = line, column, value


class LogValueError(LogError):
    """A field that is not a number, or a non-finite one (``nan``, ``inf``)."""


class LogTimeError(LogError):
    """Time stamps that do not increase, or a step far below the median (irregular
    sampling the filters cannot take as uniform)."""


class LogGapError(LogError):
    """A gap in the time stamps: a step longer than the allowed multiple of the median
    (samples were lost; split the log there)."""


class LogSaturationError(LogError):
    """An actuator effort at its limit, or stuck at its extreme value over consecutive
    samples: a drive or sensor that clipped, so the logged effort is not the applied one."""


class LogLimitError(LogError):
    """An actuator position outside its stroke or joint limits (a wrong offset, unit or
    column order, or a robot description that does not match the log)."""
