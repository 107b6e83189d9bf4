"""Stacked least squares accumulated in chunks: memory that does not grow with the log.

The identification model stacks ``Gamma = W_b chi_b`` over N samples: 6 N equations in nb
unknowns, a (6 N, nb) matrix (2.5 GB for 600 000 samples and 88 parameters). Everything
the estimation needs is kept instead in six small triangular factors, one per actuator j:
the R factor of the augmented matrix ``[W_j | y_j]`` (``W_j`` the N rows of actuator j,
``y_j`` its N measured efforts), an (nb+1, nb+1) upper-triangular matrix ``R_j`` with

    [W_j | y_j] = Q_j R_j,   Q_j with orthonormal columns.

Adding a chunk of rows ``[W_c | y_c]`` replaces ``R_j`` by the R factor of ``[R_j; W_c |
y_c]`` (Householder QR, ``numpy.linalg.qr``): an incremental QR. Because ``Q_j`` has
orthonormal columns, every quantity of the stacked problem follows exactly from the
factors, for any parameter vector ``x`` and weights ``w_j``:

- residual norms: ``|y_j - W_j x| = |R_j [x; -1]|``;
- column norms: ``|W[:, k]|^2 = sum_j |R_j[:, k]|^2``;
- the weighted problem: the R factor of ``[w_1 R_1; ...; w_6 R_6]`` is that of the
  weighted stacked matrix, so its solution, singular values and residual are those of
  the full problem;
- leverages: ``h_j = |w_j R_j[:nb, :nb] S^-1 V diag(1/s)|_F^2`` with ``W_w S^-1 = U diag(s)
  V^T`` (``S`` the column scaling).

Accuracy: Householder QR is backward stable column by column, whatever the order and
size of the chunks: the factors are those of a matrix within a few ``eps`` (relative, per
column) of the stacked one, the accuracy of a QR of the whole matrix at once. The
estimates then carry the usual bound ``~ eps cond(W S^-1)`` relative. No normal
equations are formed (they would square the condition number). The tests check the
chunked result against the SVD of the full stacked matrix to 1e-10 relative.

Memory: ``6 (nb+1)^2`` floats (0.4 MB for nb = 88) plus one chunk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stewart_pin._checks import check_array
from stewart_pin.exceptions import IdentificationError, InputError

#: Default numerical rank tolerance of the stacked base regressor, relative to its largest
#: singular value with the columns scaled to unit norm (as
#: :data:`stewart_pin.parameters.base.RANK_TOLERANCE`).
RANK_TOLERANCE = 1e-8
#: Weighted least squares: relative change of the sigma_j that ends the reweighting, and
#: the cap on the iterations.
REWEIGHTING_TOLERANCE = 1e-3
REWEIGHTING_ITERATIONS = 20


@dataclass(frozen=True, eq=False)
class LeastSquaresSolution:
    """The (weighted) least-squares estimate from the accumulated factors.

    Attributes:
        estimate: (nb,) the final estimate (weighted, or OLS when ``weighted`` is False).
        ols_estimate: (nb,) the ordinary least-squares estimate.
        covariance: (nb, nb) ``kappa sigma^2 (W_w^T W_w)^-1`` of the final problem, with
            ``sigma^2 = |r_w|^2 / (6 N - nb)`` and ``kappa`` the noise-correlation factor.
        sigma: (6,) per-actuator noise std from the residuals of the final fit.
        weights: (6,) the weight of each actuator's equations (1 for OLS).
        iterations: reweighting iterations (0 for OLS).
        residual_rms: (6,) RMS residual per actuator of the final estimate.
        condition_number: of the stacked regressor with unit-norm columns.
        rank: its numerical rank (== nb, else :class:`IdentificationError`).
        n_samples: samples accumulated.
        weighted_rss: ``|r_w|^2``, the weighted residual sum of squares of the estimate.
        fit_factor: (nb, nb) upper-triangular ``F`` with ``F^T F = W_w^T W_w`` (the
            weighted problem's R factor, physical units): the weighted residual of any
            ``x`` is ``weighted_rss + |F (x - estimate)|^2``.
        noise_correlation: ``kappa`` (1 for white noise), see
            :meth:`StackedLeastSquares.solve`.
    """

    estimate: np.ndarray
    ols_estimate: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray
    weights: np.ndarray
    iterations: int
    residual_rms: np.ndarray
    condition_number: float
    rank: int
    n_samples: int
    weighted_rss: float
    fit_factor: np.ndarray
    noise_correlation: float = 1.0

    def weighted_residual(self, x: np.ndarray) -> float:
        """``|r_w(x)|^2``, the weighted residual sum of squares of any ``x`` (nb,)."""
        d = self.fit_factor @ (np.asarray(x, dtype=float) - self.estimate)
        return float(self.weighted_rss + d @ d)


def _r_factor(A: np.ndarray) -> np.ndarray:
    """The (..., n, n) R factor of ``A`` (..., m, n), zero-padded when m < n."""
    R: np.ndarray = np.asarray(np.linalg.qr(A, mode="r"))
    n = A.shape[-1]
    if R.shape[-2] < n:
        pad = np.zeros((*R.shape[:-2], n - R.shape[-2], n))
        R = np.concatenate([R, pad], axis=-2)
    return R


class StackedLeastSquares:
    """``Gamma = W chi`` stacked over samples, accumulated chunk by chunk.

    Args:
        n_parameters: nb, the number of unknowns.
        names: optional names of the unknowns (for the rank-deficiency message).
        n_outputs: equations per sample (the 6 actuators).

    Call :meth:`add` with each chunk, then :meth:`solve`.
    """

    def __init__(
        self, n_parameters: int, names: tuple[str, ...] | None = None, n_outputs: int = 6
    ) -> None:
        if int(n_parameters) < 1 or int(n_outputs) < 1:
            raise InputError(
                f"n_parameters and n_outputs must be >= 1, got {n_parameters}, {n_outputs}"
            )
        self.nb, self.n_outputs = int(n_parameters), int(n_outputs)
        self.names = names if names is not None else tuple(f"p{k}" for k in range(self.nb))
        self.factors = np.zeros((self.n_outputs, self.nb + 1, self.nb + 1))
        self.n_samples = 0

    def add(self, W: np.ndarray, y: np.ndarray) -> None:
        """Add a chunk: ``W`` (n, 6, nb) the regressor rows, ``y`` (n, 6) the efforts."""
        W = check_array(W, (None, self.n_outputs, self.nb), "W")
        y = check_array(y, (W.shape[0], self.n_outputs), "y")
        if W.shape[0] == 0:
            return
        rows = np.concatenate([W, y[:, :, None]], axis=2).transpose(1, 0, 2)  # (6, n, nb+1)
        self.factors = _r_factor(np.concatenate([self.factors, rows], axis=1))
        self.n_samples += W.shape[0]

    def merge(self, other: StackedLeastSquares) -> None:
        """Add the equations accumulated in ``other`` (same nb and outputs)."""
        if (other.nb, other.n_outputs) != (self.nb, self.n_outputs):
            raise InputError("merge: the accumulators differ in size")
        self.factors = _r_factor(np.concatenate([self.factors, other.factors], axis=1))
        self.n_samples += other.n_samples

    # ------------------------------------------------------------------ solution
    def _combined(self, weights: np.ndarray) -> np.ndarray:
        """The (nb+1, nb+1) R factor of the weighted stacked ``[W | y]``."""
        return _r_factor((self.factors * weights[:, None, None]).reshape(-1, self.nb + 1))

    def residual_norms(self, x: np.ndarray) -> np.ndarray:
        """``|y_j - W_j x|`` (6,) for each actuator."""
        v = np.append(np.asarray(x, dtype=float), -1.0)
        return np.asarray(np.linalg.norm(self.factors @ v, axis=1), dtype=float)

    def solve(
        self,
        weighted: bool = True,
        noise_correlation: float = 1.0,
        rank_tolerance: float = RANK_TOLERANCE,
    ) -> LeastSquaresSolution:
        """Ordinary, then (``weighted``) Gautier's weighted least squares.

        The OLS residuals give each actuator's noise ``sigma_j^2 = |r_j|^2 / (N - h_j)``
        (``h_j`` the leverage of its N equations, about nb/6); its equations are divided by
        ``sigma_j`` and the problem solved again, the sigma_j re-estimated from the new
        residuals, until they settle (:data:`REWEIGHTING_TOLERANCE`, at most
        :data:`REWEIGHTING_ITERATIONS` passes). Solves use the SVD of the factor with
        its columns scaled to the unit norm of the stacked (unweighted) matrix's.

        Args:
            noise_correlation: ``kappa``, the ratio of the noise's long-run variance (its
                spectral density at low frequency, times the bandwidth) to its variance:
                1 for white noise; for noise that a filter of taps ``h`` and a decimation
                by D made coloured, ``sum_l sum_k h_k h_(k+lD) / sum_k h_k^2``
                (:func:`stewart_pin.parameters.state_estimation.noise_correlation`). The
                covariance is multiplied by it: for regressors that vary slowly compared
                with the noise's correlation time, the estimate's variance is that of white
                noise of the long-run variance.
            rank_tolerance: relative singular value below which the stacked regressor
                (unit-norm columns) counts as rank deficient.

        Raises:
            IdentificationError: at most nb equations, or a rank below nb.
        """
        nb, n = self.nb, self.n_samples
        if self.n_outputs * n <= nb:
            raise IdentificationError(
                f"{n} samples give {self.n_outputs * n} equations for {nb} base parameters; "
                f"at least {nb // self.n_outputs + 1} samples are needed (more than {nb} "
                "equations)",
                n_parameters=nb,
            )
        kappa = float(noise_correlation)
        if not (math.isfinite(kappa) and kappa > 0):
            raise InputError(f"noise_correlation must be positive, got {noise_correlation}")
        F = self.factors
        norms = np.sqrt(np.sum(F[:, :, :nb] ** 2, axis=(0, 1)))
        scale = np.where(norms > 0, norms, 1.0)
        y_norm2 = float(np.sum(F[:, :, nb] ** 2))

        def factor(weights: np.ndarray) -> tuple[np.ndarray, ...]:
            Rc = self._combined(weights)
            U, s, Vt = np.linalg.svd(Rc[:nb, :nb] / scale)
            x = (Vt.T @ ((U.T @ Rc[:nb, nb]) / s)) / scale if s[-1] > 0 else None
            return Rc, U, s, Vt, x  # type: ignore[return-value]

        ones = np.ones(self.n_outputs)
        Rc, _, s, Vt, x = factor(ones)
        rank = int(np.sum(s > rank_tolerance * s[0])) if s[0] > 0 else 0
        if rank < nb or x is None:
            weakest = np.argsort(-np.abs(Vt[-1]))[:4]
            raise IdentificationError(
                f"the stacked base regressor ({self.n_outputs * n} x {nb}) has rank {rank} < "
                f"{nb}: the trajectory does not excite every base parameter (the least "
                f"excited direction involves {', '.join(self.names[k] for k in weakest)}); "
                "use a richer trajectory (exciting_trajectory) or fewer parameters",
                rank=rank,
                n_parameters=nb,
            )
        cond = float(s[0] / s[-1])

        def noise(x: np.ndarray, s: np.ndarray, Vt: np.ndarray, weights: np.ndarray) -> np.ndarray:
            """sigma_j^2 = |r_j|^2 / (N - h_j), h_j the leverage of actuator j's rows."""
            G = (Vt.T / s) / scale[:, None]  # (nb, nb): S^-1 V diag(1/s)
            leverage = np.sum((weights[:, None, None] * (F[:, :nb, :nb] @ G)) ** 2, axis=(1, 2))
            r2 = self.residual_norms(x) ** 2
            return np.asarray(np.sqrt(r2 / np.maximum(n - leverage, 1e-12)), dtype=float)

        ols = x
        sigma = noise(x, s, Vt, ones)
        weights, iterations = ones, 0
        if weighted:
            floor = 1e-12 * math.sqrt(y_norm2 / (self.n_outputs * n)) or 1e-300
            for iterations in range(1, REWEIGHTING_ITERATIONS + 1):  # noqa: B007
                weights = 1.0 / np.maximum(sigma, floor)
                Rc, _, s, Vt, x = factor(weights)
                if x is None:  # pragma: no cover - the weights keep the rank
                    raise IdentificationError("the weighted problem lost rank", n_parameters=nb)
                new = noise(x, s, Vt, weights)
                converged = np.all(np.abs(new - sigma) <= REWEIGHTING_TOLERANCE * sigma + floor)
                sigma = new
                if converged:
                    break
        r = self.residual_norms(x)
        rss_w = float(np.sum((weights * r) ** 2))
        s2 = rss_w / (self.n_outputs * n - nb)
        Vs = Vt.T / s
        covariance = kappa * s2 * (Vs @ Vs.T) / np.outer(scale, scale)
        return LeastSquaresSolution(
            estimate=x,
            ols_estimate=ols,
            covariance=covariance,
            sigma=sigma,
            weights=weights,
            iterations=iterations,
            residual_rms=r / math.sqrt(n),
            condition_number=cond,
            rank=rank,
            n_samples=n,
            weighted_rss=rss_w,
            fit_factor=Rc[:nb, :nb].copy(),
            noise_correlation=kappa,
        )


__all__ = [
    "REWEIGHTING_ITERATIONS",
    "REWEIGHTING_TOLERANCE",
    "LeastSquaresSolution",
    "StackedLeastSquares",
]
