"""Physically consistent parameters: a robot a simulator can run, fitted to the data.

The least-squares base estimate ``chi_b`` is what the data determine; it says nothing
about each body, and the standard parameters behind it may be impossible (a negative
mass, an inertia no body has). :func:`physically_consistent` finds standard parameters
``chi`` that

- are physically realisable: each body's 4x4 pseudo-inertia matrix (Wensing, Kim,
  Slotine 2017)::

      J = [[Sigma, h], [h^T, m]],  Sigma = tr(I) / 2 * 1 - I,  h = [MX, MY, MZ],  m = M

  (``I`` the inertia tensor about the body frame's origin, ``Sigma`` the second moments
  of its mass distribution) is positive definite, ``J >= margin * m0 diag(L^2, L^2, L^2,
  1)`` (``m0`` the body's prior mass, ``L`` the robot's size; this is exactly the
  existence of a non-negative mass density, so a positive mass and the triangle
  inequalities of the principal moments, the description's own check, follow); the
  joint terms armature IA, viscous FV and Coulomb FC friction and stiffness K are
  non-negative, and each offset ``|OF| <= R K`` (a spring's ``-K q0`` with
  ``|q0| <= R``: 2 pi rad for revolute joints, 10 robot sizes for prismatic ones), so
  the result is a valid description;
- reproduce the base parameters as closely as the data allow. First, when the
  least-squares estimate ``chi_b`` is itself realisable (some ``chi`` with ``K chi =
  chi_b`` meets the constraints), that ``chi`` nearest to the prior (default the robot's
  own description, e.g. its CAD values) in the scaled norm ``|D^-1 (chi -
  chi_prior)|``: the base values are the estimate's, exactly (``chi = D (R_b u_b + N
  w)``, the row space of ``K D`` fixed, its null space ``N`` free). Otherwise the
  maximum a posteriori estimate over realisable robots: the Mahalanobis distance to the
  estimate ``|F (K chi - chi_b)|^2 / (kappa sigma^2)`` (``F`` the weighted problem's R
  factor, :attr:`~stewart_pin.parameters.least_squares.LeastSquaresSolution.fit_factor`,
  so this is the increase of the weighted residual sum of squares in units of the
  noise) plus a weak Gaussian prior ``|D^-1 (chi - chi_prior)|^2 / width^2`` (width
  :data:`PRIOR_WIDTH` = 10 scaled units): it decides the directions the data do not or
  barely see (without it the least-determined directions of a noisy estimate would be
  fitted by absurd bodies, and the null space would be undetermined).

Both are semidefinite programs solved by cvxpy (the ``ident`` extra: ``pip install
"stewart-pin[ident]"``) with CLARABEL (interior point; SCS as a fallback), each answer
checked here against the constraints. The variables are scaled to order one: a body's
inertia entries by ``m0 L^2``, first moments by ``m0 L``, mass by ``m0``; a joint term
by the inverse of its column's norm in ``F K`` (its effect on the fit), or by the
prior's magnitude where the data do not see it.

On noise-free data from a robot whose bodies satisfy the margin, the estimate is the
truth's base projection and is realisable, so the first problem returns it exactly
(the tests check 1e-9 relative).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._extras import require
from stewart_pin.description import RobotDescription
from stewart_pin.description.inertia import inertia_tensor
from stewart_pin.dynamics.regressor import (
    parameter_groups,
    standard_parameters,
    with_standard_parameters,
)
from stewart_pin.exceptions import (
    IdentificationError,
    InputError,
    PhysicalFitError,
    StewartPinError,
)
from stewart_pin.parameters.base import BaseParameters
from stewart_pin.protocols import RobotLike

#: Smallest eigenvalue of each body's scaled pseudo-inertia ``J / (m0 diag(L^2, L^2,
#: L^2, 1))`` (a fraction of the prior mass): strictly realisable bodies, with a margin
#: the description's own check (1e-10 relative) passes whatever the solver's round-off.
PHYSICAL_MARGIN = 1e-6
#: Solver attempts, in order, until one reports "optimal": tolerances tighter than the
#: defaults first (the fit is anisotropic: its least-determined directions need the extra
#: digits), then looser ones, then SCS. Every answer is checked here against the
#: constraints (to half the margin); of those that pass, the best objective is kept (a
#: tight "optimal_inaccurate" answer is often more accurate than a loose "optimal" one).
SOLVER_ATTEMPTS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("CLARABEL", {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12, "max_iter": 400}),
    ("CLARABEL", {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10, "max_iter": 400}),
    ("CLARABEL", {}),
    ("SCS", {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 20000}),
)
#: Width of the prior, in scaled units (10: a standard deviation of ten times a body's
#: prior mass, ten times ``m0 L^2`` for its inertia...): a weak pull that only decides
#: directions the data barely see.
PRIOR_WIDTH = 10.0
#: Least weight of the prior relative to the fit (``|F|`` normalised to 1), for a fit
#: with (nearly) zero residuals: it keeps the problem well posed.
PRIOR_FLOOR = 1e-12
#: Bound on a spring's rest position behind an offset: revolute [rad], prismatic [robot
#: sizes].
REST_RANGE_REVOLUTE = 2 * math.pi
REST_RANGE_PRISMATIC = 10.0
#: A physical fit is not credible (:class:`PhysicalFitError`) when both its weighted
#: residual exceeds the least-squares one by more than this fraction of it (1: the
#: residual sum of squares doubled; the least-squares residual per equation estimates the
#: noise, so this is an increase of one noise variance per equation; the lab tests
#: measure 0.36 to 0.43 with model and filter errors)...
MAX_FIT_LOSS = 1.0
#: ...and it misses more than this fraction of the weighted efforts' energy ``|W y|^2``
#: beyond least squares (1e-4: an RMS effort error of 1 % of the efforts; this keeps
#: noise-free data, whose least-squares residual is round-off, credible: they lose
#: 5e-23; the lab tests lose 1e-5 to 2e-5, a log with negated efforts 3e-2, fitted by
#: springs and offsets as far as they go).
MAX_SIGNAL_LOSS = 1e-4


def pseudo_inertia(params: Any) -> np.ndarray:
    """The 4x4 pseudo-inertia ``[[tr(I)/2 1 - I, h], [h^T, m]]`` of Khalil's 10 parameters
    (about the body frame's origin) [kg m^2, kg m, kg]: positive semi-definite exactly
    when a non-negative mass density has these moments."""
    p = np.asarray(params, dtype=float)
    I = inertia_tensor(p)
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(I) * np.eye(3) - I
    J[:3, 3] = J[3, :3] = p[6:9]
    J[3, 3] = p[9]
    return J


@dataclass(frozen=True, eq=False)
class PhysicalEstimate:
    """Standard parameters that every body and joint can have, fitted to the data.

    Attributes:
        standard: (n,) the standard parameters (names:
            :func:`~stewart_pin.dynamics.regressor.standard_parameter_names`).
        base_values: (nb,) their base parameters ``K chi``.
        description: the robot description holding them (validated: every body
            realisable, every joint term valid).
        rss: the weighted residual sum of squares of ``base_values``.
        rss_least_squares: that of the least-squares estimate (the smallest possible).
        fit_loss: ``rss / rss_least_squares - 1``, the fraction of fit lost to physical
            consistency (``inf`` when the least-squares fit is exact and this one is not).
        mahalanobis: ``(x - chi_b)^T C^-1 (x - chi_b)``, the distance of ``base_values``
            from the estimate in units of its covariance ``C`` (chi-square with nb
            degrees of freedom when the truth is realisable and the noise Gaussian).
        min_eigenvalues: (19,) smallest eigenvalue of each body's scaled pseudo-inertia.
        solver: the solver and its status of the last problem solved.
    """

    standard: np.ndarray
    base_values: np.ndarray
    description: RobotDescription
    rss: float
    rss_least_squares: float
    fit_loss: float
    mahalanobis: float
    min_eigenvalues: np.ndarray
    solver: str


def _cvxpy() -> Any:
    """The ``cvxpy`` module, or :class:`MissingDependencyError` with the install hint."""
    (cvxpy,) = require("physically consistent parameters", "ident", "cvxpy")
    return cvxpy


def physically_consistent(
    robot: RobotLike,
    result: Any,
    prior: RobotDescription | None = None,
    *,
    margin: float = PHYSICAL_MARGIN,
    solver: str | None = None,
) -> PhysicalEstimate:
    """Physically consistent standard parameters fitted to an identification (module
    docstring).

    Args:
        robot: the robot identified (its geometry and layout of standard parameters).
        result: an :class:`~stewart_pin.parameters.identification.IdentificationResult`
            (or a :class:`~stewart_pin.parameters.identification.LogIdentification`) with
            its least-squares solution.
        prior: the description whose parameters break the ties (default the robot's).
        margin: :data:`PHYSICAL_MARGIN`.
        solver: a cvxpy solver name (default CLARABEL, then SCS if it fails).

    Raises:
        ImportError: cvxpy missing (install the ``ident`` extra).
        IdentificationError: the solver fails, or its answer does not pass the
            description's checks.
        PhysicalFitError: the fit is not credible: its residual is more than
            :data:`MAX_FIT_LOSS` over the least-squares one and it misses more than
            :data:`MAX_SIGNAL_LOSS` of the efforts' weighted energy (e.g. efforts logged
            with the wrong sign: no robot with positive masses makes them).
    """
    cp = _cvxpy()
    result = getattr(result, "result", result)  # a LogIdentification
    sol = getattr(result, "solution", None)
    base: BaseParameters = result.base
    if sol is None:
        raise InputError(
            "physically_consistent needs a result with its least-squares solution "
            "(from identify or identify_log)"
        )
    desc = robot.description
    prior = desc if prior is None else prior
    groups = parameter_groups(desc)
    n = groups.n
    K = np.asarray(base.K, dtype=float)
    if K.shape != (len(base), n):
        raise InputError(
            f"the base parameters map {K.shape[1]} standard parameters, the robot has {n}"
        )
    chi0 = standard_parameters(prior)
    if chi0.shape != (n,):
        raise InputError(f"the prior has {chi0.shape[0]} standard parameters, expected {n}")
    x_ls = np.asarray(result.estimate, dtype=float)
    F = np.asarray(sol.fit_factor, dtype=float)
    big = float(np.linalg.norm(F, 2)) or 1.0
    Fn = F / big
    L = float(desc.size)

    # Scales D: chi = D z.
    scale = np.ones(n)
    masses = np.array([chi0[b.index][9] for b in groups.bodies])
    positive = masses[masses > 0]
    fallback = float(positive.mean()) if positive.size else 1.0
    body_mass = np.where(masses > 0, masses, fallback)
    powers = np.array([2, 2, 2, 2, 2, 2, 1, 1, 1, 0], dtype=float)
    for b, m0 in zip(groups.bodies, body_mass, strict=True):
        scale[b.index] = m0 * L**powers
    columns = np.linalg.norm(Fn @ K, axis=0)
    for jp in groups.joints:
        for k in range(jp.index.start, jp.index.stop):
            seen = columns[k] > 1e-9 * columns.max()
            scale[k] = 1.0 / columns[k] if seen else max(abs(chi0[k]), 1e-6)
    A = Fn @ K * scale  # (nb, n): fit in z
    b = Fn @ x_ls
    z0 = chi0 / scale

    def constraints_of(z: Any, margin: float) -> list[Any]:
        """The realisability constraints on the scaled standard parameters ``z``."""
        out = []
        for body, m0 in zip(groups.bodies, body_mass, strict=True):
            zb = z[body.index]
            s = scale[body.index]
            XX, XY, XZ, YY, YZ, ZZ = (zb[k] * (s[k] / (m0 * L**2)) for k in range(6))
            MX, MY, MZ = (zb[k] * (s[k] / (m0 * L)) for k in (6, 7, 8))
            M = zb[9] * (s[9] / m0)
            tr = 0.5 * (XX + YY + ZZ)
            J = cp.bmat(
                [
                    [tr - XX, -XY, -XZ, MX],
                    [-XY, tr - YY, -YZ, MY],
                    [-XZ, -YZ, tr - ZZ, MZ],
                    [MX, MY, MZ, M],
                ]
            )
            out.append(0.5 * (J + J.T) >> margin * np.eye(4))
        for jp in groups.joints:
            for k in jp.nonnegative:
                out.append(z[k] >= 0)
            R = REST_RANGE_REVOLUTE if jp.kind == "revolute" else REST_RANGE_PRISMATIC * L
            of, k_ = jp.offset, jp.stiffness
            out.append(cp.abs(z[of] * scale[of]) <= R * scale[k_] * z[k_])
        return out

    def feasible(zv: np.ndarray, margin: float) -> bool:
        chi = zv * scale
        for body, m0 in zip(groups.bodies, body_mass, strict=True):
            S = np.diag([1 / L, 1 / L, 1 / L, 1.0])
            J = S @ pseudo_inertia(chi[body.index]) @ S / m0
            if np.linalg.eigvalsh(J)[0] < margin:
                return False
        return all(chi[k] >= -1e-12 * abs(scale[k]) for k in groups.nonnegative)

    attempts = [(solver, {})] if solver else list(SOLVER_ATTEMPTS)

    def solve(problem: Any, value: Any, objective: Any, margin: float) -> tuple[np.ndarray, str]:
        """Run the attempts; the best answer ``z`` (by ``value()`` after each solve) that
        meets the constraints to ``margin``."""
        last, best = "", None
        for attempt, (name, options) in enumerate(attempts):
            if best is not None and attempt >= 2:
                break  # a checked answer from the tight attempts: enough
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # "inaccurate": checked below
                    problem.solve(solver=name, **options)
            except Exception as e:  # cvxpy.SolverError and the solvers' own
                last = f"{name}: {type(e).__name__}: {e}"
                continue
            last = f"{name}: {problem.status}"
            if problem.status in ("infeasible", "infeasible_inaccurate") and best is None:
                break  # a certificate of infeasibility: no other attempt will do better
            zv = value()
            if zv is None or problem.status not in ("optimal", "optimal_inaccurate"):
                continue
            if not feasible(zv, margin):
                continue
            obj = float(objective(zv))
            if best is None or obj < best[0]:
                best = (obj, zv, f"{name} ({problem.status})")
            if problem.status == "optimal":
                break
        if best is not None:
            return best[1], best[2]
        raise IdentificationError(
            f"the physically consistent fit failed ({last}); the base estimate may be far "
            "from any realisable robot (check the log and the description)"
        )

    # z = Rb u + N w: u the base (row-space) coordinates, w the null space of K D.
    _, sv, Vt = np.linalg.svd(K * scale)
    rank = int(np.sum(sv > 1e-12 * sv[0]))
    Rb, N = Vt[:rank].T, Vt[rank:].T
    u_ls = np.linalg.lstsq(A @ Rb, b, rcond=None)[0]  # the estimate's own coordinates
    w0 = N.T @ z0
    zs: np.ndarray | None = None
    used = ""
    # 1. Is the least-squares estimate itself realisable? Nearest to the prior if so.
    if N.shape[1]:
        w = cp.Variable(N.shape[1])
        exact = cp.Problem(
            cp.Minimize(cp.sum_squares(w - w0)), constraints_of(Rb @ u_ls + N @ w, margin)
        )
        try:
            zs, used = solve(
                exact,
                lambda: None if w.value is None else Rb @ u_ls + N @ np.array(w.value),
                lambda zv: np.sum((N.T @ zv - w0) ** 2),
                0.5 * margin,
            )
        except IdentificationError:
            zs = None
    # 2. Otherwise the maximum a posteriori estimate over realisable robots: the
    # Mahalanobis distance plus the prior's weak pull |z - z0|^2 / width^2.
    if zs is None:
        dof = max(6 * sol.n_samples - len(base), 1)
        s2 = sol.weighted_rss / dof * sol.noise_correlation
        weight = max(s2 / (big**2 * PRIOR_WIDTH**2), PRIOR_FLOOR)
        z = cp.Variable(n)
        best = cp.Problem(
            cp.Minimize(cp.sum_squares(A @ z - b) + weight * cp.sum_squares(z - z0)),
            constraints_of(z, margin),
        )
        zs, used = solve(
            best,
            lambda: None if z.value is None else np.array(z.value, dtype=float),
            lambda zv: np.sum((A @ zv - b) ** 2) + weight * np.sum((zv - z0) ** 2),
            0.5 * margin,
        )
    chi = zs * scale
    for jp in groups.joints:  # the solvers' round-off: tiny negatives are zeros
        for k in jp.nonnegative:
            chi[k] = max(chi[k], 0.0)
        if chi[jp.stiffness] == 0.0:
            chi[jp.offset] = 0.0
    try:
        description = with_standard_parameters(desc, chi)
    except StewartPinError as e:
        raise IdentificationError(
            f"the physically consistent parameters do not pass the description's checks: {e}"
        ) from e
    x = K @ chi
    rss_ls = float(sol.weighted_rss)
    rss = sol.weighted_residual(x)
    fit_loss = rss / rss_ls - 1.0 if rss_ls > 0 else (0.0 if rss == 0 else math.inf)
    d = x - x_ls
    try:
        mahal = float(d @ np.linalg.solve(result.covariance, d))
    except np.linalg.LinAlgError:
        mahal = math.inf
    signal = sol.weighted_residual(np.zeros_like(x_ls))  # |W y|^2, the efforts' energy
    signal_loss = (rss - rss_ls) / signal if signal > 0 else 0.0
    if fit_loss > MAX_FIT_LOSS and signal_loss > MAX_SIGNAL_LOSS:
        raise PhysicalFitError(
            f"no physically consistent robot explains the data: the best one found "
            f"({used}) leaves a weighted residual {fit_loss + 1:.4g} times the least-squares "
            f"one (Mahalanobis distance {mahal:.4g} for {len(x_ls)} parameters) and misses "
            f"{100 * signal_loss:.3g} % of the efforts' weighted energy (credible: at most "
            f"{MAX_FIT_LOSS + 1:g} times and {100 * MAX_SIGNAL_LOSS:g} %); check the "
            "efforts' sign and units, the column order and the robot description",
            fit_loss,
            signal_loss,
            mahal,
            used,
        )
    eig = []
    for body, m0 in zip(groups.bodies, body_mass, strict=True):
        S = np.diag([1 / L, 1 / L, 1 / L, 1.0])
        eig.append(float(np.linalg.eigvalsh(S @ pseudo_inertia(chi[body.index]) @ S / m0)[0]))
    return PhysicalEstimate(
        standard=chi,
        base_values=x,
        description=description,
        rss=rss,
        rss_least_squares=rss_ls,
        fit_loss=fit_loss,
        mahalanobis=mahal,
        min_eigenvalues=np.array(eig),
        solver=used,
    )


__all__ = [
    "MAX_FIT_LOSS",
    "MAX_SIGNAL_LOSS",
    "PHYSICAL_MARGIN",
    "PhysicalEstimate",
    "physically_consistent",
    "pseudo_inertia",
]
