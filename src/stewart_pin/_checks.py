"""Input validators: each returns a clean float64 array or raises :class:`InputError`."""

from __future__ import annotations

from typing import Any

import numpy as np

from .exceptions import InputError

#: Tolerance on ``R^T R - I`` for a rotation matrix given by a user.
ROTATION_TOLERANCE = 1e-9


def check_array(value: Any, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """Return ``value`` as a float64 array of ``shape`` (``None`` = any size), all finite."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
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


def check_batch(value: Any, tail: tuple[int, ...], name: str) -> tuple[np.ndarray, bool]:
    """Accept one item of shape ``tail`` or a batch ``(N, *tail)``.

    Returns the array with a leading batch axis, and whether the input was a batch.
    """
    arr = np.asarray(value)
    batched = np.ndim(arr) == len(tail) + 1
    arr = check_array(arr, ((None,) if batched else ()) + tail, name)
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


def check_pose(pose: Any, name: str = "pose") -> np.ndarray:
    """Return a pose 0Tp as a 4x4 float64 homogeneous matrix (``pin.SE3`` accepted)."""
    if _is_se3(pose):
        pose = pose.homogeneous
    T = check_array(pose, (4, 4), name)
    if np.abs(T[3] - (0.0, 0.0, 0.0, 1.0)).max() > 0.0:
        raise InputError(f"{name} last row must be [0, 0, 0, 1], got {T[3]}")
    check_rotation(T[:3, :3], f"{name} rotation block")
    return T


def check_poses(poses: Any, name: str = "pose") -> tuple[np.ndarray, bool]:
    """Accept one pose (4x4 or SE3) or a batch (N,4,4) / list of SE3; validate each rotation."""
    if _is_se3(poses):
        return check_pose(poses, name)[None], False
    if isinstance(poses, (list, tuple)) and poses and _is_se3(poses[0]):
        return np.stack([check_pose(p, name) for p in poses]), True
    arr = np.asarray(poses)
    batched = arr.ndim == 3
    T = check_array(arr, ((None,) if batched else ()) + (4, 4), name)
    T = T if batched else T[None]
    if np.abs(T[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(initial=0.0) > 0.0:
        raise InputError(f"{name}: the last row of every pose must be [0, 0, 0, 1]")
    R = T[:, :3, :3]
    err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    if np.any(err > ROTATION_TOLERANCE):
        k = int(np.argmax(err))
        raise InputError(
            f"{name}[{k}] rotation block is not a rotation: max |R^T R - I| = {err[k]:.3g}"
        )
    det = np.linalg.det(R)
    if np.any(det < 0):
        k = int(np.argmax(det < 0))
        raise InputError(
            f"{name}[{k}] rotation block is a reflection (det = {det[k]:.6g}), not a rotation"
        )
    return T, batched


def _is_se3(x: Any) -> bool:
    return hasattr(x, "homogeneous") and hasattr(x, "rotation")


def _fmt(shape: tuple[int | None, ...]) -> str:
    dims = ["N" if s is None else str(s) for s in shape]
    return "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"


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
