"""Newton's method on SE(3) for the forward geometry, shared by the ideal 6-UPS
(:mod:`.forward_geometry`) and the general legs (:mod:`.leg_chains`).

Free of :mod:`.jacobians` so that the general legs, which the independent check uses,
do not pull the 6-UPS Jacobians in.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._typing import FloatArray
from stewart_pin.exceptions import ConvergenceError, SingularityError

#: ``evaluate(T) -> (error (6,), jacobian)``: the actuated-coordinate error
#: ``target - q_a(T)`` and a function giving ``Jp^-1`` (6x6) at ``T`` (called only when a
#: step is needed, so that a converged pose does not pay for it).
Evaluate = Callable[[FloatArray], tuple[FloatArray, Callable[[], FloatArray]]]


def newton_se3(
    T: FloatArray,
    evaluate: Evaluate,
    tol: float,
    max_iterations: int,
    error_name: str,
    unit: str = "",
) -> FloatArray:
    """Iterate from ``T`` (4x4, modified in place and returned) until every entry of the
    error is within ``tol``: the correction twist ``dV = [dv; dw]`` (F0) solves
    ``Jp^-1 dV = error``, applied as ``p += dv``, ``R <- exp(dw) R`` (on SE(3), no drift
    off the manifold).

    Raises:
        ConvergenceError: not within ``tol`` after ``max_iterations`` steps (the message
            names ``error_name`` and ``unit``).
        SingularityError: a singular ``Jp^-1`` on the way.
    """
    residual = np.inf
    for iteration in range(max_iterations + 1):
        error, jacobian = evaluate(T)
        residual = float(np.abs(error).max())
        if residual <= tol:
            return T
        if iteration == max_iterations:
            break
        try:
            step = np.linalg.solve(jacobian(), error)
        except np.linalg.LinAlgError as e:
            raise SingularityError(
                f"forward geometry met a singular Jp^-1 at iteration {iteration}"
            ) from e
        T[:3, 3] += step[:3]
        T[:3, :3] = pin.exp3(step[3:]) @ T[:3, :3]
    u = f" {unit}" if unit else ""
    raise ConvergenceError(
        f"forward geometry did not converge in {max_iterations} iterations (largest "
        f"{error_name} {residual:.3g}{u} > tol {tol:g}{u}); give a guess closer to the "
        "solution",
        max_iterations,
        residual,
    )
