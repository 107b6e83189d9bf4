"""The exceptions stewart-pin raises.

Every error the package raises on bad input derives from :class:`StewartPinError`.
The input-validation errors also derive from :class:`ValueError`, so code written
against the standard library's conventions keeps working. Each exception keeps the
offending values as attributes (``leg``, ``value``, ``lower``, ``upper``...) so that
callers can react programmatically, and its message says what was expected, what was
received and how to fix it.
"""

from __future__ import annotations


class StewartPinError(Exception):
    """Base class of every error raised by stewart-pin."""


class InputError(StewartPinError, ValueError):
    """An argument has the wrong shape, type, or holds NaN / infinite values."""


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


class FileFormatError(StewartPinError, ValueError):
    """A description, URDF, closure or measurement file is malformed."""


class WorkspaceError(StewartPinError, ValueError):
    """A pose the robot cannot reach (base class of the more specific errors)."""


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


class SingularityError(StewartPinError, ValueError):
    """A configuration at or too near a singularity.

    Attributes:
        value: the measure that crossed its threshold (condition number, sin q2i, ...).
        threshold: the threshold it crossed.
        leg: the leg concerned (1-based) or ``None`` for the parallel (platform) singularity.
    """

    def __init__(
        self, message: str, value: float, threshold: float, leg: int | None = None
    ) -> None:
        super().__init__(message)
        self.value, self.threshold, self.leg = value, threshold, leg


class ConvergenceError(StewartPinError, RuntimeError):
    """An iterative solver (forward geometry) did not converge.

    Attributes:
        iterations: iterations performed; residual: the last residual norm.
    """

    def __init__(self, message: str, iterations: int, residual: float) -> None:
        super().__init__(message)
        self.iterations, self.residual = iterations, residual


class IdentificationError(StewartPinError, ValueError):
    """Measurements that cannot identify the base parameters: too few equations, or a
    stacked base regressor of deficient rank (a trajectory that does not excite them all).

    Attributes:
        rank: the numerical rank of the stacked base regressor (``None`` when not computed).
        n_parameters: the number of base parameters.
    """

    def __init__(
        self, message: str, rank: int | None = None, n_parameters: int | None = None
    ) -> None:
        super().__init__(message)
        self.rank, self.n_parameters = rank, n_parameters


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
    """

    def __init__(
        self,
        output: str,
        index: int | None = 0,
        n_bad: int | None = None,
        n_states: int | None = None,
    ) -> None:
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
