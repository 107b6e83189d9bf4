"""Array type aliases for the shapes that recur in the public signatures.

numpy's type system does not carry shapes, so each alias names its shape and units here
and in its name; at run time every one is a float64 ndarray (``npt.NDArray[np.float64]``).
Functions that *accept* arrays take :data:`ArrayLike` (anything ``np.asarray`` turns into
floats, including ``pin.SE3`` for a pose) and check the shape themselves (``_checks``).
"""

from __future__ import annotations

from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

__all__ = [
    "Accel",
    "Accels",
    "ArrayLike",
    "FloatArray",
    "Forces",
    "IntArray",
    "JointValues",
    "Pose",
    "Poses",
    "Twist",
    "Twists",
    "Vector3",
    "Vector6",
]

#: Any float64 array.
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: Any integer array (indices).
IntArray: TypeAlias = npt.NDArray[np.intp]
#: An input the checks turn into a float array (lists, arrays, ``pin.SE3``...).
ArrayLike: TypeAlias = Any

#: A 3-vector, shape (3,).
Vector3: TypeAlias = FloatArray
#: A 6-vector, shape (6,): linear part then angular part (Pinocchio's order).
Vector6: TypeAlias = FloatArray
#: A pose 0Tp, homogeneous matrix of shape (4, 4) [m].
Pose: TypeAlias = FloatArray
#: A batch of poses, shape (N, 4, 4) [m].
Poses: TypeAlias = FloatArray
#: A twist ``[v, w]`` of O_p in F0, shape (6,) [m/s, rad/s]; (N, 6) for a batch.
Twist: TypeAlias = FloatArray
#: A batch of twists, shape (N, 6) [m/s, rad/s].
Twists: TypeAlias = FloatArray
#: A classical acceleration ``[dv/dt, dw/dt]`` in F0, shape (6,) [m/s^2, rad/s^2].
Accel: TypeAlias = FloatArray
#: A batch of accelerations, shape (N, 6) [m/s^2, rad/s^2].
Accels: TypeAlias = FloatArray
#: Actuator forces Gamma, shape (6,) or (N, 6) [N].
Forces: TypeAlias = FloatArray
#: Leg joint values ``q1i, q2i`` [rad], ``q3i`` [m], shape (6, 3) or (N, 6, 3).
JointValues: TypeAlias = FloatArray
