"""Input validators: each returns a clean float64 array or raises :class:`InputError`.

Arrays are accepted when every element is a real number: Python ``int`` / ``float`` or a
NumPy integer or floating value. Booleans, strings (even ``"1.5"``), complex numbers (whose
imaginary part a float conversion would drop) and other objects are refused with an
:class:`InputError` naming the element, as are ragged nested lists, NaN and infinities.
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from stewart_pin.exceptions import (
    FileFormatError,
    InputError,
    SingularityError,
    StewartPinError,
    StewartPinWarning,
    WorkspaceError,
)

#: Tolerance on ``R^T R - I`` for a rotation matrix given by a user.
ROTATION_TOLERANCE = 1e-9
#: Largest ``max |R^T R - I|`` of a rotation that :func:`project_rotation` corrects (onto
#: SO(3), with a :class:`StewartPinWarning`) instead of refusing: entries written to 6
#: significant digits (as CAD tools print them) are off by up to 5e-7, which makes
#: ``R^T R - I`` of order 1e-6; 1e-4 leaves room for 4-5 digits and still refuses a matrix
#: that is not meant to be a rotation.
ROTATION_PROJECTION_TOLERANCE = 1e-4

#: NumPy dtype kinds holding real numbers (signed, unsigned integers, floats).
_REAL_KINDS = "iuf"
#: What a refused dtype kind holds, for the messages.
_KIND_NAMES = {
    "b": "booleans",
    "c": "complex numbers (a float conversion would drop the imaginary part)",
    "U": "strings",
    "S": "byte strings",
    "M": "dates",
    "m": "time differences",
    "V": "structured records",
}


def _what(x: Any) -> str | None:
    """``None`` when ``x`` is a real number, else what it is (for a message)."""
    if isinstance(x, (bool, np.bool_)):
        return f"the boolean {x!r}"
    if isinstance(x, (str, bytes, np.str_, np.bytes_)):
        return f"the string {str(x)!r}" if isinstance(x, str) else f"the bytes {x!r}"
    if isinstance(x, (complex, np.complexfloating)):
        return f"the complex number {x!r} (its imaginary part would be dropped)"
    if isinstance(x, (numbers.Real, np.integer, np.floating)):
        return None
    if x is None:
        return "None"
    return f"a {type(x).__name__}"


def _index(name: str, index: tuple[int, ...]) -> str:
    return name + "".join(f"[{i}]" for i in index)


def _first_not_real(value: Any, depth: int, name: str) -> str | None:
    """The first problem of ``value`` as nested lists / tuples / arrays of real numbers
    expected ``depth`` levels deep: an element that is not a real number, a list where a
    number is expected, or ragged rows. A message, or ``None`` when there is none."""
    stack: list[tuple[Any, tuple[int, ...]]] = [(value, ())]
    # per nesting level: (the list length there, or -1 for a number; the first index)
    levels: dict[int, tuple[int, tuple[int, ...]]] = {}
    while stack:
        x, index = stack.pop()
        at = _index(name, index)
        if isinstance(x, np.ndarray):
            kind = x.dtype.kind
            if kind == "O":
                for k in np.ndindex(x.shape):
                    what = _what(x[k])
                    if what is not None:
                        return f"{_index(name, index + k)} is {what}, not a real number"
            elif kind not in _REAL_KINDS:
                return f"{at} holds {_KIND_NAMES.get(kind, x.dtype.name)}"
            if not index:
                continue
            signature = x.shape[0] if x.ndim else -1  # rows beside lists of other lengths
        elif isinstance(x, (list, tuple)):
            if len(index) >= depth:
                return f"{at} is a list where a number is expected"
            signature = len(x)
            stack.extend((v, (*index, k)) for k, v in reversed(list(enumerate(x))))
        else:
            what = _what(x)
            if what is not None:
                if isinstance(x, (str, bytes, bool, complex, np.generic)) or x is None:
                    return f"{at} is {what}, not a real number"
                try:  # an array-like (range, memoryview, __array__): look inside
                    arr = np.asarray(x)
                except Exception:  # any failure: not an array of numbers
                    arr = np.empty((), dtype=object)
                if arr.dtype.kind == "O" and arr.ndim == 0:
                    return f"{at} is {what}, not a real number"
                stack.append((arr, index))
                continue
            signature = -1
        first = levels.setdefault(len(index), (signature, index))
        if first[0] != signature:
            (n, i), m = first, signature

            def describe(count: int) -> str:
                return "a number" if count < 0 else f"a row of {count}"

            return f"ragged rows: {_index(name, i)} is {describe(n)} but {at} is {describe(m)}"
    return None


def check_array(value: Any, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """Return ``value`` as a float64 array of ``shape`` (``None`` = any size), all finite.

    Raises:
        InputError: an element that is not a real number (boolean, string, complex,
            object), ragged nesting, the wrong shape, or a NaN / infinite value.
    """
    if not (isinstance(value, np.ndarray) and value.dtype.kind in _REAL_KINDS):
        problem = _first_not_real(value, len(shape), name)
        if problem is not None:
            raise InputError(f"{name} must be a numeric array of shape {_fmt(shape)}: {problem}")
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as e:
        raise InputError(f"{name} must be a numeric array of shape {_fmt(shape)}: {e}") from e
    if arr.ndim != len(shape) or any(
        s is not None and s != n for s, n in zip(shape, arr.shape, strict=True)
    ):
        raise InputError(f"{name} must have shape {_fmt(shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InputError(
            f"{name} holds a non-finite value {arr[tuple(bad)]} at index "
            f"{tuple(int(i) for i in bad)}"
        )
    return arr


def check_scalar(
    value: Any,
    name: str,
    *,
    positive: bool = False,
    nonnegative: bool = False,
    integer: bool = False,
    unit: str = "",
) -> float:
    """Return ``value`` as a finite float (or an int when ``integer``), refusing booleans,
    strings, NaN, infinities and, as asked, zero or negative values.

    Raises:
        InputError: naming ``name``, the value received and what is expected.
    """
    what = _what(value)
    if what is not None and isinstance(value, np.ndarray) and value.ndim == 0:
        return check_scalar(
            value.item(),
            name,
            positive=positive,
            nonnegative=nonnegative,
            integer=integer,
            unit=unit,
        )
    kind = "an integer" if integer else "a real number"
    if what is not None:
        raise InputError(f"{name} must be {kind}, got {what}")
    u = f" {unit}" if unit else ""
    if integer:
        if not isinstance(value, (numbers.Integral, np.integer)):
            if not (isinstance(value, (float, np.floating)) and float(value).is_integer()):
                raise InputError(f"{name} must be an integer, got {value!r}")
        out: float = int(value)
    else:
        out = float(value)
        if not math.isfinite(out):
            raise InputError(f"{name} must be finite, got {out!r}{u}")
    if positive and not out > 0:
        raise InputError(f"{name} must be positive, got {out!r}{u}")
    if nonnegative and not out >= 0:
        raise InputError(f"{name} must be zero or positive, got {out!r}{u}")
    return out


def check_batch(value: Any, tail: tuple[int, ...], name: str) -> tuple[np.ndarray, bool]:
    """Accept one item of shape ``tail`` or a batch ``(N, *tail)``.

    Returns the array with a leading batch axis, and whether the input was a batch.
    """
    batched = nested_ndim(value) == len(tail) + 1
    arr = check_array(value, ((None,) if batched else ()) + tail, name)
    return (arr if batched else arr[None]), batched


def check_rotation(R: Any, name: str, tol: float = ROTATION_TOLERANCE) -> np.ndarray:
    """Return ``R`` as a 3x3 rotation matrix, raising when it is not orthonormal."""
    R = check_array(R, (3, 3), name)
    err = np.abs(R.T @ R - np.eye(3)).max()
    if err > tol:
        raise InputError(f"{name} is not orthonormal: max |R^T R - I| = {err:.3g} > {tol:g}")
    if np.linalg.det(R) < 0:
        raise InputError(f"{name} is a reflection (det = {np.linalg.det(R):.6g}), not a rotation")
    return R


def project_rotation(
    R: Any, name: str, tol: float = ROTATION_PROJECTION_TOLERANCE, stacklevel: int = 2
) -> np.ndarray:
    """Return ``R`` (3x3) unchanged when orthonormal within :data:`ROTATION_TOLERANCE`,
    else its nearest rotation (the orthogonal polar factor ``U V^T`` of ``R = U S V^T``)
    with a :class:`StewartPinWarning` naming ``name`` and the correction
    ``max |R_projected - R|``, when ``max |R^T R - I| <= tol`` and ``det R > 0``.

    Meant for rotations typed or exported with few significant digits.

    Raises:
        InputError: ``R`` is further from SO(3) than ``tol``, or a reflection.
    """
    R = check_array(R, (3, 3), name)
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if not det > 0:
        raise InputError(f"{name} is a reflection or singular (det = {det:.6g}), not a rotation")
    if err <= ROTATION_TOLERANCE:
        return R
    if err > tol:
        raise InputError(
            f"{name} is not orthonormal: max |R^T R - I| = {err:.3g} > {tol:g} (the largest "
            "deviation projected onto SO(3)); give unit, orthogonal columns"
        )
    U, _, Vt = np.linalg.svd(R)
    projected = U @ Vt
    correction = float(np.abs(projected - R).max())
    warnings.warn(
        StewartPinWarning(
            f"{name} is not orthonormal to {ROTATION_TOLERANCE:g} (max |R^T R - I| = "
            f"{err:.3g}); projected onto SO(3), max |R_projected - R| = {correction:.3g}",
            name,
            correction,
        ),
        stacklevel=stacklevel,
    )
    return projected


def check_pose(pose: Any, name: str = "pose") -> np.ndarray:
    """Return a pose 0Tp as a 4x4 float64 homogeneous matrix (``pin.SE3`` accepted)."""
    if is_se3(pose):
        pose = pose.homogeneous
    T = check_array(pose, (4, 4), name)
    if np.abs(T[3] - (0.0, 0.0, 0.0, 1.0)).max() > 0.0:
        raise InputError(f"{name} last row must be [0, 0, 0, 1], got {T[3]}")
    check_rotation(T[:3, :3], f"{name} rotation block")
    return T


def check_poses(poses: Any, name: str = "pose") -> tuple[np.ndarray, bool]:
    """Accept one pose (4x4 or SE3) or a batch (N,4,4) / list of SE3; validate each rotation."""
    if is_se3(poses):
        return check_pose(poses, name)[None], False
    if isinstance(poses, (list, tuple)) and poses and is_se3(poses[0]):
        return np.stack([check_pose(p, name) for p in poses]), True
    batched = nested_ndim(poses) == 3
    T = check_array(poses, ((None,) if batched else ()) + (4, 4), name)
    T = T if batched else T[None]
    if np.abs(T[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(initial=0.0) > 0.0:
        raise InputError(f"{name}: the last row of every pose must be [0, 0, 0, 1]")
    R = T[:, :3, :3]
    err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    bad = ~(err <= ROTATION_TOLERANCE)
    if np.any(bad):
        k = int(np.argmax(bad))  # the first failing pose, not the worst
        raise InputError(
            f"{name}[{k}] rotation block is not a rotation: max |R^T R - I| = {err[k]:.3g}"
            + _how_many(bad)
        )
    det = np.linalg.det(R)
    if np.any(det < 0):
        k = int(np.argmax(det < 0))
        raise InputError(
            f"{name}[{k}] rotation block is a reflection (det = {det[k]:.6g}), not a rotation"
            + _how_many(det < 0)
        )
    return T, batched


BatchError = TypeVar("BatchError", bound=WorkspaceError | SingularityError)


def in_batch(error: BatchError, bad: Any) -> BatchError:
    """``error`` located in its batch: ``bad`` (N,) or (N, ...) marks the failing states
    (any entry along the trailing axes). For a batch of more than one state, sets
    ``error.state`` (the first failing state, not the worst), ``n_bad`` and ``n_states``,
    and appends "(first failing state n; k of N states fail)" to the message; one state
    is left as it is (``None`` each)."""
    bad = np.asarray(bad, dtype=bool)
    per_state = bad.reshape(len(bad), -1).any(axis=1) if bad.ndim else bad[None]
    if per_state.size < 2 or not per_state.any():
        return error
    error.state = int(np.argmax(per_state))
    error.n_bad, error.n_states = int(per_state.sum()), int(per_state.size)
    where = f" (first failing state {error.state}; {error.n_bad} of {error.n_states} states fail)"
    error.args = (f"{error.args[0] if error.args else ''}{where}", *error.args[1:])
    return error


def cholesky_failures(A: np.ndarray) -> np.ndarray:
    """(N,) whether the Cholesky factorisation of each matrix of ``A`` (N, n, n) fails (not
    positive definite): which states a failed batched factorisation stands for."""
    failed = np.zeros(len(A), dtype=bool)
    for k, matrix in enumerate(A):
        try:
            np.linalg.cholesky(matrix)
        except np.linalg.LinAlgError:
            failed[k] = True
    return failed


def _how_many(bad: np.ndarray) -> str:
    """``" (k of N poses fail)"`` for a batch (N > 1) whose poses ``bad`` (N,) fail."""
    return f" ({int(bad.sum())} of {bad.size} poses fail)" if bad.size > 1 else ""


def is_se3(x: Any) -> bool:
    """Whether ``x`` looks like a ``pin.SE3`` (has ``homogeneous`` and ``rotation``)."""
    return hasattr(x, "homogeneous") and hasattr(x, "rotation")


def nested_ndim(value: Any) -> int:
    """``np.ndim(value)``; for ragged nested lists, the depth along the first elements
    (:func:`check_array` then names the ragged rows)."""
    try:
        return int(np.ndim(value))
    except ValueError:
        n, x = 0, value
        while isinstance(x, (list, tuple, np.ndarray)) and len(x):
            n, x = n + 1, x[0]
        return n


def _fmt(shape: tuple[int | None, ...]) -> str:
    dims = ["N" if s is None else str(s) for s in shape]
    return "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"


def check_increasing_times(
    times: np.ndarray,
    name: str = "times",
    *,
    label: Callable[[int], str] | None = None,
    prefix: str = "",
    error: type[StewartPinError] = InputError,
) -> None:
    """Raise ``error`` unless ``times`` (N,) [s] is strictly increasing (the one check of it).

    The message names the first sample ``k`` not after its predecessor as ``label(k)``
    (default ``name[k]``), after ``prefix`` (say the file's path).
    """
    bad = np.flatnonzero(~(np.diff(times) > 0))
    if bad.size:
        k = int(bad[0]) + 1
        at = label or (lambda i: f"{name}[{i}]")
        raise error(
            f"{prefix}{at(k)} = {float(times[k])!r} s does not increase ({at(k - 1)} = "
            f"{float(times[k - 1])!r} s); {name} must be strictly increasing"
        )


def check_states(pose: Any, *vectors: tuple[Any, str]) -> tuple[Any, ...]:
    """Validate a pose (or batch) and 6-vectors ``(value, name)`` of matching form.

    Returns ``(batched, T (N, 4, 4), *arrays (N, 6))``: one state gives N = 1.
    """
    T, batched = check_poses(pose)
    out = []
    for value, name in vectors:
        arr, b = check_batch(value, (6,), name)
        if b != batched:
            raise InputError(
                f"{name} must be {'a batch (N, 6)' if batched else 'one 6-vector'} to match "
                f"the pose{'s' if batched else ''}, got shape {np.shape(value)}"
            )
        if arr.shape[0] != T.shape[0]:
            raise InputError(
                f"{name} holds {arr.shape[0]} states but pose holds {T.shape[0]}; give one "
                "row per pose"
            )
        out.append(arr)
    return (batched, T, *out)


def decode_utf8(data: bytes, path: str | Path) -> str:
    """``data`` decoded as UTF-8 (a leading byte-order mark dropped), or
    :class:`FileFormatError` naming ``path`` and the line of the first invalid byte."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise FileFormatError(
            f"{path}, line {line}: not UTF-8 text (byte 0x{data[e.start]:02x} at offset "
            f"{e.start}); save the file as UTF-8"
        ) from None


def freeze_fields(obj: Any, values: dict[str, Any]) -> None:
    """Set each ``values`` entry on the frozen dataclass ``obj`` as a read-only copy (a
    ``np.array`` the caller cannot change through its own reference)."""
    for key, value in values.items():
        value = np.array(value)
        value.flags.writeable = False
        object.__setattr__(obj, key, value)


Item = TypeVar("Item")
#: Counts spelled out in the messages of :func:`check_items`.
_COUNT_WORDS = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}


def check_items(
    value: Any,
    kind: type[Item],
    count: int | None,
    nouns: tuple[str, str, str],
    error: Callable[[str], Exception],
) -> tuple[Item, ...]:
    """``value``, a sequence of exactly ``count`` instances of ``kind`` (``None``: one or
    more), as a tuple; else ``error(message)`` is raised.

    ``nouns`` are the message's ``(whole, form, items)``, as in "a leg must be a chain of
    exactly three 1-dof joints (Joint)". A string, bytes, a dict or a single ``kind`` is
    refused; the message gives what was received: its type, or the count and types of
    the items.
    """
    whole, form, items = nouns
    how_many = "one or more" if count is None else f"exactly {_COUNT_WORDS.get(count, count)}"
    wanted = f"{whole} must be a {form} of {how_many} {items} ({kind.__name__})"
    if isinstance(value, (str, bytes, dict, kind)) or not isinstance(value, Sequence):
        raise error(f"{wanted} in a list or tuple, got a {type(value).__name__}")
    out = tuple(value)
    if (not out if count is None else len(out) != count) or not all(
        isinstance(x, kind) for x in out
    ):
        raise error(f"{wanted}, got {len(out)} item(s) of types {[type(x).__name__ for x in out]}")
    return out
