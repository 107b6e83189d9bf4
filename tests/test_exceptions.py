"""One exception hierarchy (stewart_pin.exceptions): every error and warning class of the
package lives there, derives from the package's base, is exported, and is the one library
code raises; attributes are honest (``None`` where a value is unknown)."""

from __future__ import annotations

import ast
import importlib
import inspect
import math
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import stewart_pin
from stewart_pin import StewartRobot, exceptions
from stewart_pin.exceptions import (
    ConvergenceError,
    InputError,
    InputTypeError,
    NumericalError,
    SingularityError,
    StewartPinError,
    StewartPinWarning,
)

SRC = Path(stewart_pin.__file__).parent

#: Private control-flow signals of the simulation loop: raised and caught inside
#: stewart_pin.motion.simulation, never seen by a caller (each carries a named error out of
#: the stepping loop). Any other exception class outside stewart_pin.exceptions fails.
PRIVATE_SIGNALS = {
    "stewart_pin.motion.simulation._Failure",
    "stewart_pin.motion.simulation._CallbackError",
    "stewart_pin.motion.simulation._Located",
    "stewart_pin.codegen.derivatives._NotCached",
}

#: Standard exceptions library code must not raise for bad input or a failure a user can
#: meet (they carry no attributes and escape ``except StewartPinError``); nor the bare base.
BARE = {
    "ValueError",
    "RuntimeError",
    "TypeError",
    "KeyError",
    "IndexError",
    "ArithmeticError",
    "Exception",
    "StewartPinError",
}


def _classes(module) -> list[type]:
    members = inspect.getmembers(module, inspect.isclass)
    return [c for _, c in members if c.__module__ == module.__name__]


def _package_modules() -> list[str]:
    return [m.name for m in pkgutil.walk_packages(stewart_pin.__path__, "stewart_pin.")]


def test_every_error_derives_from_the_base_and_every_warning_from_the_warning_base():
    errors = [c for c in _classes(exceptions) if issubclass(c, BaseException)]
    assert errors, "no exception classes found"
    for cls in errors:
        if issubclass(cls, Warning):
            assert issubclass(cls, StewartPinWarning) and issubclass(cls, UserWarning), cls
        elif issubclass(cls, KeyboardInterrupt):  # an interrupt carrying a partial result
            assert not issubclass(cls, Exception), cls  # `except Exception` lets it through
        else:
            assert issubclass(cls, StewartPinError), cls
    # nothing else in the module: only exception and warning classes
    public = {n for n in vars(exceptions) if not n.startswith("_")} - {"annotations", "Path"}
    assert public == {c.__name__ for c in errors}


def test_every_exception_is_exported_from_the_package():
    for cls in _classes(exceptions):
        assert cls.__name__ in stewart_pin.__all__, cls.__name__
        assert getattr(stewart_pin, cls.__name__) is cls


def test_standard_library_bases_kept():
    """``except ValueError`` / ``TypeError`` / ``RuntimeError`` keep working."""
    from stewart_pin import (
        CompilationError,
        DescriptionError,
        FileFormatError,
        IdentificationError,
        ViewerError,
        WorkspaceError,
    )

    for cls in (InputError, DescriptionError, FileFormatError, WorkspaceError):
        assert issubclass(cls, ValueError)
    for cls in (SingularityError, IdentificationError):
        assert issubclass(cls, ValueError)
    assert issubclass(InputTypeError, TypeError) and issubclass(InputTypeError, InputError)
    for cls in (ConvergenceError, CompilationError, ViewerError):
        assert issubclass(cls, RuntimeError)
    assert issubclass(NumericalError, ArithmeticError)


def test_no_exception_class_is_defined_outside_the_exceptions_module():
    stray = []
    for name in _package_modules():
        module = importlib.import_module(name)
        if module is exceptions:
            continue
        for cls in _classes(module):
            qualified = f"{name}.{cls.__name__}"
            if issubclass(cls, BaseException) and qualified not in PRIVATE_SIGNALS:
                stray.append(qualified)
    assert stray == []


def test_old_import_paths_still_work():
    from stewart_pin.codegen import CompilationError, UnsafeCacheError
    from stewart_pin.motion.simulation import SimulationError

    assert CompilationError is exceptions.CompilationError
    assert UnsafeCacheError is exceptions.UnsafeCacheError
    assert SimulationError is exceptions.SimulationError


def _raises(path: Path):
    """``(line, name)`` of every ``raise Name(...)`` / ``raise Name`` in a source file."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name):
                yield node.lineno, exc.id


def test_library_code_raises_no_bare_standard_exception_nor_the_base():
    bad = [
        f"{path.relative_to(SRC)}:{line} raises {name}"
        for path in sorted(SRC.rglob("*.py"))
        for line, name in _raises(path)
        if name in BARE
    ]
    assert bad == []


def test_parallel_singularity_attributes_are_honest(desktop):
    """A parallel singularity: no leg, the measure and its threshold both finite."""
    strict = StewartRobot(desktop.description, max_condition=1.0)
    zeros = np.zeros(6)
    with pytest.raises(SingularityError) as info:
        strict.inverse_dynamics(strict.home_pose, zeros, zeros)
    e = info.value
    assert e.leg is None
    assert math.isfinite(e.value) and e.threshold == 1.0 and e.value > e.threshold


def test_leg_singularity_names_its_leg(desktop):
    T = desktop.home_pose.copy()
    desc = desktop.description
    # platform point 3 on base point 3: leg 3 of zero length
    T[:3, 3] = desc.base_points[2] - T[:3, :3] @ desc.platform_points[2]
    with pytest.raises(SingularityError) as info:
        desktop.inverse_geometry(T)
    e = info.value
    assert e.leg == 3
    assert math.isfinite(e.value) and math.isfinite(e.threshold)


def test_unknown_values_are_none():
    e = SingularityError.not_positive_definite()
    assert (e.value, e.threshold, e.leg) == (None, None, None)
    assert "A_robot is not positive definite" in str(e)
    assert SingularityError("somewhere singular").value is None
    n = NumericalError("x", None)
    assert (n.index, n.n_bad, n.n_states) == (None, None, None)
    assert ConvergenceError("stuck", None, None).iterations is None


def test_input_type_error(desktop):
    with pytest.raises(InputTypeError, match="takes a RobotDescription"):
        StewartRobot({"name": "x"})
    with pytest.raises(InputTypeError, match="no method 'inverse_dynamics'"):
        stewart_pin.validate(object(), n_states=1)


def test_the_compiled_backend_raises_numerical_error_itself(desktop):
    """The compiled backend names the output and the state itself (the facade no longer
    parses its message), with the reference's message."""
    from stewart_pin.codegen import compiled_backend

    backend = compiled_backend(desktop)
    T = np.repeat(desktop.home_pose[None], 3, axis=0)
    twists, accels = np.zeros((3, 6)), np.zeros((3, 6))
    accels[1] = 1e308  # finite, overflows
    with np.errstate(over="ignore", invalid="ignore"):
        with pytest.raises(NumericalError) as info:
            backend.inverse_dynamics(T, twists, accels)
    e = info.value
    assert (e.output, e.index) == ("inverse dynamics Gamma", 1)
    assert str(e).startswith("inverse dynamics Gamma is not finite at state 1")


# ---------------------------------------------------------------------- errors in a batch
def _lifted(robot: StewartRobot, dz: list[float]) -> np.ndarray:
    """Home poses raised by ``dz`` [m] each, (N, 4, 4)."""
    T = np.repeat(robot.home_pose[None], len(dz), axis=0)
    T[:, 2, 3] += dz
    return T


def test_a_stroke_error_in_a_batch_names_the_first_failing_state_and_the_count(desktop):
    """Six-UPS batch: states 2 and 4 leave the stroke, 4 further. The error named no state;
    it names state 2 (the first), with its leg length, and that 2 of 5 states fail."""
    from helpers import leg_lengths_by_hand

    from stewart_pin import StrokeLimitError

    hi = desktop.description.stroke[1]
    T = _lifted(desktop, [0.0, 0.0, 0.05, 0.0, 0.1])
    lengths = leg_lengths_by_hand(desktop.description, T[2])
    assert lengths.max() > hi and leg_lengths_by_hand(desktop.description, T[4]).min() > hi
    with pytest.raises(StrokeLimitError) as info:
        desktop.inverse_geometry(T)
    e = info.value
    assert (e.state, e.n_bad, e.n_states) == (2, 2, 5)
    leg = int(np.argmax(lengths > hi))
    assert e.leg == leg + 1 and e.value == pytest.approx(lengths[leg], rel=1e-12)
    assert str(e).endswith("(first failing state 2; 2 of 5 states fail)")
    with pytest.raises(StrokeLimitError) as one:  # one state: no batch location
        desktop.inverse_geometry(T[4])
    assert one.value.state is None and "failing state" not in str(one.value)


def test_a_leg_reach_error_names_the_first_failing_state_not_the_worst():
    """RUS cranks: state 1 just out of reach, state 3 far out. The error named the worst
    (state 3, by the largest |cos|); it names the first and the count."""
    from stewart_pin import LegReachError

    rus = StewartRobot.from_preset("rus")
    size = rus.description.size
    T = _lifted(rus, [0.0, 0.3 * size, 0.0, 1.0 * size])
    with pytest.raises(LegReachError) as first:
        rus.inverse_geometry(T[1], check_limits=False)
    with pytest.raises(LegReachError) as worst:
        rus.inverse_geometry(T[3], check_limits=False)
    assert first.value.value < worst.value.value
    with pytest.raises(LegReachError) as info:
        rus.inverse_geometry(T, check_limits=False)
    e = info.value
    assert (e.state, e.n_bad, e.n_states) == (1, 2, 4)
    assert (e.leg, e.value) == (first.value.leg, first.value.value)
    assert "(first failing state 1; 2 of 4 states fail)" in str(e)


def test_a_parallel_singularity_in_a_batch_names_the_first_failing_state(desktop):
    """Rotations about z of 0, 0.4, 0.1 and 0.5 rad, the threshold between the measures at
    0.1 and 0.4 rad: states 1 and 3 fail (the measure grows with the twist of the legs)."""
    import pinocchio as pin

    T = np.repeat(desktop.home_pose[None], 4, axis=0)
    for k, angle in enumerate([0.0, 0.4, 0.1, 0.5]):
        T[k, :3, :3] = pin.exp3(np.array([0.0, 0.0, angle])) @ T[k, :3, :3]
    cond = np.array([desktop.condition_number(P) for P in T])  # one pose at a time
    assert cond[0] < cond[2] < cond[1] < cond[3]
    strict = StewartRobot(desktop.description, max_condition=0.5 * (cond[2] + cond[1]))
    zeros = np.zeros((4, 6))
    with pytest.raises(SingularityError) as info:
        strict.inverse_dynamics(T, zeros, zeros, backend="pinocchio")
    e = info.value
    assert (e.state, e.n_bad, e.n_states) == (1, 2, 4) and e.value == pytest.approx(cond[1])
    assert "(first failing state 1; 2 of 4 states fail)" in str(e)


def test_a_bad_rotation_in_a_batch_names_the_first_not_the_worst(desktop):
    T = np.repeat(desktop.home_pose[None], 3, axis=0)
    T[1, 0, 0] += 1e-3  # not a rotation
    T[2, 0, 0] += 0.5  # much worse
    with pytest.raises(InputError, match=r"pose\[1\] rotation .* \(2 of 3 poses fail\)"):
        desktop.inverse_geometry(T)


def test_a_batch_not_positive_definite_names_the_first_failing_state():
    from stewart_pin.dynamics.closed_loop import closure_direct_dynamics

    A = np.array([np.eye(6), -np.eye(6), np.eye(6), -np.eye(6)])
    J = np.repeat(np.eye(6)[None], 4, axis=0)
    with pytest.raises(SingularityError, match="not positive definite") as info:
        closure_direct_dynamics(A, np.zeros((4, 6)), J, np.zeros((4, 6)))
    assert (info.value.state, info.value.n_bad, info.value.n_states) == (1, 2, 4)
