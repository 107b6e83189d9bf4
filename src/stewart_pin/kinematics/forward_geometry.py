"""Forward geometric model: the platform pose from the six leg lengths (paper section II).

Apart from :mod:`.geometry` because it needs the Jacobian (:mod:`.jacobians`), which
itself builds on the inverse geometry.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from stewart_pin._checks import check_array, check_pose, check_scalar
from stewart_pin._typing import ArrayLike, FloatArray, Pose
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import StrokeLimitError
from stewart_pin.kinematics._se3_newton import newton_se3
from stewart_pin.kinematics.geometry import leg_vectors
from stewart_pin.kinematics.jacobians import inverse_jacobian_batch

#: Forward geometry: leg-length tolerance [m] and iteration cap of Newton-Raphson.
FORWARD_TOLERANCE = 1e-12
FORWARD_MAX_ITERATIONS = 50


def forward_geometry(
    desc: RobotDescription,
    lengths: ArrayLike,
    guess: ArrayLike = None,
    tol: float = FORWARD_TOLERANCE,
    max_iterations: int = FORWARD_MAX_ITERATIONS,
) -> Pose:
    """The platform pose 0Tp (4x4) whose leg lengths are ``lengths`` (shape (6,) [m]).

    Newton-Raphson on the closure equations ``|B_i P_i(T)| = lengths_i``: the correction
    twist ``dV`` solves ``Jp^-1 dV = lengths - |B_i P_i|``, applied as ``p += dv``,
    ``R <- exp(dw) R`` (on SE(3), no drift off the manifold). It starts from ``guess``
    (default: the description's home pose) and stops when every leg length is within
    ``tol`` [m], raising :class:`ConvergenceError` after ``max_iterations``.

    Raises:
        StrokeLimitError: a requested length outside the stroke.
        ConvergenceError: no convergence (the lengths may be unassemblable from the guess).
        SingularityError: the iteration met a singular configuration.
    """
    tol = check_scalar(tol, "tol", positive=True, unit="m")
    max_iterations = int(
        check_scalar(max_iterations, "max_iterations", integer=True, nonnegative=True)
    )
    target = check_array(lengths, (6,), "lengths")
    lo, hi = desc.ideal_stroke("the 6-UPS forward geometry")
    for k, value in enumerate(target):
        if not lo <= value <= hi:
            raise StrokeLimitError(k + 1, float(value), float(lo), float(hi))
    T = check_pose(desc.home_pose if guess is None else guess, "guess").copy()

    def evaluate(T: Pose) -> tuple[FloatArray, Callable[[], FloatArray]]:
        d, _ = leg_vectors(desc, T[None])
        return target - np.linalg.norm(d[0], axis=-1), lambda: inverse_jacobian_batch(
            desc, T[None]
        )[0]

    return newton_se3(T, evaluate, tol, max_iterations, "leg-length error", "m")
