"""What the compiled models do with the states their C guard flags (issue 19): the one
behaviour of :class:`~stewart_pin.codegen.compiled.CompiledDynamics` that differs between
architectures, held by each architecture's codegen strategy
(:meth:`~stewart_pin.codegen._architecture.CodegenKind.resolution`), so that the compiled
backend asks it instead of asking which architecture it holds.

- :class:`ReferenceChecks` (the paper's ideal 6-UPS): a flagged state is decided by the
  reference checks (poses, inverse geometry with every limit, the exact singularity
  measure), which raise the reference's error or accept the compiled result;
- :class:`ReferenceResults` (leg chains): a flagged state is computed by the reference
  path (:class:`~stewart_pin.dynamics.leg_chain_dynamics.GeneralDynamics`, joint limits
  checked), whose result replaces the compiled one; if it refuses one, the whole batch
  goes through it to raise its error as it would.

Flags are those of :data:`stewart_pin.codegen._csource.FLAG_NAMES`; ``REPIVOTED`` alone
is no reason to resolve (the C solved the state again).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from stewart_pin._checks import check_states, in_batch
from stewart_pin.codegen._csource import FLAG_NAMES
from stewart_pin.codegen.leg_chain_symbolic import general_robot
from stewart_pin.description import RobotDescription
from stewart_pin.dynamics.chain_leg_dynamics import ChainDynamics
from stewart_pin.dynamics.closed_loop import DDM_OUTPUT, IDM_OUTPUT
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.exceptions import NumericalError, SingularityError, StewartPinError
from stewart_pin.kinematics import chain_legs, leg_chains
from stewart_pin.kinematics.geometry import inverse_geometry_batch
from stewart_pin.kinematics.jacobians import (
    check_condition,
    inverse_jacobian_batch,
    scaled_inverse_jacobian,
)

__all__ = [
    "OUTPUTS",
    "ChainReferenceResults",
    "ReferenceChecks",
    "ReferenceResults",
    "Resolution",
]

_INPUT, _GEOMETRY, _COND = FLAG_NAMES["INPUT"], FLAG_NAMES["GEOMETRY"], FLAG_NAMES["COND"]
_NOT_PD, _NONFINITE = FLAG_NAMES["NOT_PD"], FLAG_NAMES["NONFINITE"]
_REPIVOTED = FLAG_NAMES["REPIVOTED"]
#: The result each model checks, named as the reference names it in its NumericalError.
OUTPUTS = {"idm": IDM_OUTPUT, "ddm": DDM_OUTPUT}


class Resolution(Protocol):
    """What a compiled backend does with flagged states. ``which`` is ``"idm"`` or
    ``"ddm"``; ``pose, twist, x`` the call's arguments as given (for the reference's own
    errors), ``name`` the third one's name; ``T, V, X`` the validated buffers (N, 4, 4) /
    (N, 16), (N, 6), (N, 6); ``flags`` (N,) int32; ``out`` (N, 6) the compiled results,
    changed in place; ``max_condition`` the robot's current threshold."""

    def before_vm(self, T: np.ndarray, max_condition: float) -> None:
        """The checks the virtual machine's fallback runs before its models (it has no C
        guard for the leg checks the generated code does not hold as slacks)."""
        ...

    def resolve(
        self,
        which: str,
        flags: np.ndarray,
        args: tuple[Any, Any, Any, str],
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        out: np.ndarray,
        max_condition: float,
    ) -> None:
        """Raise the reference's error for the flagged states, or accept them (with the
        reference's results where this architecture takes them). ``args`` is
        ``(pose, twist, x, name)``."""
        ...


class ReferenceChecks:
    """The ideal 6-UPS: the reference checks decide a flagged state; the compiled result
    stands when they accept it (its guard knows every limit: stroke, leg singularities,
    U-joint angles)."""

    def __init__(self, desc: RobotDescription, length: float) -> None:
        self._desc = desc
        self._length = length  # [m] the singularity measure's length

    def before_vm(self, T: np.ndarray, max_condition: float) -> None:
        desc = self._desc
        inverse_geometry_batch(desc, T)
        check_condition(inverse_jacobian_batch(desc, T), max_condition, desc)

    def resolve(
        self,
        which: str,
        flags: np.ndarray,
        args: tuple[Any, Any, Any, str],
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        out: np.ndarray,
        max_condition: float,
    ) -> None:
        bits = int(np.bitwise_or.reduce(flags)) if flags.size else 0
        desc = self._desc
        T = T.reshape(-1, 4, 4)
        pose, twist, x, name = args
        if bits & _INPUT:
            check_states(pose, (twist, "twist"), (x, name))
        if bits & _GEOMETRY:
            inverse_geometry_batch(desc, T)
        if bits & _COND:
            idx = np.flatnonzero(flags & _COND)
            J = scaled_inverse_jacobian(inverse_jacobian_batch(desc, T[idx]), self._length)
            if np.any(~(np.linalg.cond(J) <= max_condition)):
                check_condition(inverse_jacobian_batch(desc, T), max_condition, desc)
        if bits & _NOT_PD:
            raise in_batch(SingularityError.not_positive_definite(), flags & _NOT_PD)
        if bits & _NONFINITE:
            bad = (flags & _NONFINITE) != 0
            raise NumericalError(
                OUTPUTS[which], int(np.argmax(bad)), int(bad.sum()), int(bad.size)
            )


class ReferenceResults:
    """Leg chains: a flagged state is computed by the reference path, whose result
    replaces the compiled one (the guard's slacks flag generously)."""

    def __init__(self, desc: RobotDescription) -> None:
        self._desc = desc
        self._hexapod: Any = general_robot(desc)
        self._models: Any = None

    def before_vm(self, T: np.ndarray, max_condition: float) -> None:
        """Nothing: the slacks, in the VM's ``aux``, are its flags."""

    def _reference_models(self) -> Any:
        return GeneralDynamics(self._hexapod, check_limits=True)

    def _reference(self, which: str, max_condition: float) -> Callable[[Any, Any, Any], Any]:
        """The reference path (:class:`GeneralDynamics`, joint limits checked, the
        robot's current ``max_condition``), as ``StewartRobot`` runs it."""
        if self._models is None:
            self._models = self._reference_models()
        ref = self._models
        ref.max_condition = max_condition
        return ref.inverse_dynamics if which == "idm" else ref.direct_dynamics

    def _exact_condition(self, T: np.ndarray) -> np.ndarray:
        """The reference's parallel singularity measure at poses ``T`` (N, 4, 4)."""
        J = leg_chains.inverse_jacobian_batch(self._hexapod, T)
        return np.asarray(leg_chains.condition_number_batch(self._hexapod, J))

    def resolve(
        self,
        which: str,
        flags: np.ndarray,
        args: tuple[Any, Any, Any, str],
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        out: np.ndarray,
        max_condition: float,
    ) -> None:
        """The flagged states (but ``REPIVOTED`` alone) through the reference path; only
        flagged by the cheap singularity bound, the exact measure decides first; if the
        reference refuses one, the whole batch goes through it to raise its error exactly
        as it would (the state index counts in the whole batch)."""
        bad = np.flatnonzero(flags & ~_REPIVOTED)
        if bad.size == 0:
            return
        only_cond = (flags[bad] & ~_REPIVOTED) == _COND
        if np.any(only_cond):  # the cheap bound passed the threshold: the exact measure
            idx = bad[only_cond]
            cond = self._exact_condition(T.reshape(-1, 4, 4)[idx])
            bad = np.setdiff1d(bad, idx[cond <= max_condition])
            if bad.size == 0:
                return
        ref = self._reference(which, max_condition)
        pose, twist, x, _ = args
        with np.errstate(over="ignore", invalid="ignore"):
            try:
                values = ref(
                    T.reshape(-1, 4, 4)[bad], V.reshape(-1, 6)[bad], X.reshape(-1, 6)[bad]
                )
            except StewartPinError:
                ref(pose, twist, x)  # raises the reference's error for the whole batch
                raise  # pragma: no cover - the subset failed, so the whole batch does
        out.reshape(-1, 6)[bad] = values


class ChainReferenceResults(ReferenceResults):
    """Chain legs: as :class:`ReferenceResults`, the reference path being
    :class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics` (joint limits
    checked) and its singularity measure
    :func:`stewart_pin.kinematics.chain_legs.condition_number`."""

    def __init__(self, desc: RobotDescription) -> None:
        self._desc = desc
        self._hexapod = None
        self._models = None

    def _reference_models(self) -> Any:
        return ChainDynamics(self._desc, check_limits=True)

    def _exact_condition(self, T: np.ndarray) -> np.ndarray:
        desc = self._desc
        states = chain_legs.leg_states(desc, T, np.zeros((T.shape[0], 6)))
        return np.asarray(
            chain_legs.condition_number(desc, chain_legs.inverse_jacobian(desc, states))
        )
