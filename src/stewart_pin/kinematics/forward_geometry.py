"""Forward geometric model: the platform pose from the six leg lengths (paper section II).

Apart from :mod:`.geometry` because it needs the Jacobian (:mod:`.jacobians`), which
itself builds on the inverse geometry.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_array, check_pose, check_scalar
from stewart_pin._typing import ArrayLike, Pose
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import ConvergenceError, SingularityError, StrokeLimitError
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
    residual = np.inf
    for iteration in range(max_iterations + 1):
        d, _ = leg_vectors(desc, T[None])
        error = target - np.linalg.norm(d[0], axis=-1)
        residual = float(np.abs(error).max())
        if residual <= tol:
            return T
        if iteration == max_iterations:
            break
        J_inv = inverse_jacobian_batch(desc, T[None])[0]
        try:
            step = np.linalg.solve(J_inv, error)
        except np.linalg.LinAlgError as e:
            raise SingularityError(
                f"forward geometry met a singular Jp^-1 at iteration {iteration}"
            ) from e
        T[:3, 3] += step[:3]
        T[:3, :3] = pin.exp3(step[3:]) @ T[:3, :3]
    raise ConvergenceError(
        f"forward geometry did not converge in {max_iterations} iterations (largest leg-length "
        f"error {residual:.3g} m > tol {tol:g} m); give a guess closer to the solution",
        max_iterations,
        residual,
    )
