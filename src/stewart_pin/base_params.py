"""Base inertial parameters (paper section VI): the identifiable combinations of the 190.

Two routes to the same space:

- :func:`numerical_base_parameters`: QR with column pivoting of the regressor stacked over
  random states (Gautier 1991). Ground truth for the rank on any geometry.
- :func:`analytic_base_parameters`: the paper's grouping rules, for any frame placement:
  per leg (eq. 44-50) link 3's inertia groups into link 2 (prismatic joint), YY2, MZ2 and
  M2 into links 2 and 1 (revolute), link 1 keeps ZZ1R, MX1, MY1R (revolute on the base);
  then the loop groups each M3i into the platform as a point mass at P_i (eq. 56-66, with
  every term of the sums kept since Fp need not sit at P_1). 13 per leg + 10 = 88.

Both return a :class:`BaseParameters`: names, the linear map ``K`` (nb x 190) with
``chi_b = K chi``, the regressor columns they keep (``W_b = W[:, kept]`` for the analytic
set; ``W_b = W[:, kept]`` too for the numerical one, whose ``K`` folds the others in).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.linalg

from .description import RobotDescription
from .exceptions import StewartPinError
from .regressor import N_STANDARD, STANDARD_NAMES, standard_parameters

#: Default numerical rank tolerance, relative to the largest |R_kk| of the column-normalised
#: stacked regressor.
RANK_TOLERANCE = 1e-8


@dataclass(frozen=True)
class BaseParameters:
    """A set of base parameters ``chi_b = K chi`` with ``W chi = W[:, kept] chi_b``.

    Attributes:
        names: one name per base parameter.
        K: (nb, 190) map from the standard parameters.
        kept: (nb,) the regressor columns (standard parameters) the base set keeps.
        values: (nb,) the robot's base parameter values ``K chi``.
    """

    names: tuple[str, ...]
    K: np.ndarray
    kept: np.ndarray
    values: np.ndarray
    robot: Any = field(default=None, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.names)

    def from_standard(self, chi: np.ndarray) -> np.ndarray:
        """Base parameter values of any standard vector ``chi`` (190,)."""
        return self.K @ np.asarray(chi, dtype=float)

    def reduce(self, W: np.ndarray) -> np.ndarray:
        """The base regressor ``W_b`` from the full one (..., 6, 190) -> (..., 6, nb)."""
        return np.asarray(W)[..., self.kept]

    def regressor(self, pose: Any, twist: Any, accel: Any) -> np.ndarray:
        """The base regressor ``W_b`` with ``Gamma = W_b chi_b``: (6, nb) or (N, 6, nb)."""
        if self.robot is None:
            raise StewartPinError("these base parameters are bound to no robot")
        return self.reduce(self.robot.regressor(pose, twist, accel))

    def table(self) -> str:
        """A readable table: name, value, and the grouping relation."""
        lines = [f"{'base parameter':>16s} {'value':>14s}   grouping"]
        for name, value, row in zip(self.names, self.values, self.K, strict=True):
            lines.append(f"{name:>16s} {value:14.6g}   {_relation(row)}")
        return "\n".join(lines)


def _relation(row: np.ndarray) -> str:
    terms = []
    for k in np.flatnonzero(np.abs(row) > 1e-15):
        c = row[k]
        name = STANDARD_NAMES[k]
        if c == 1.0:
            terms.append(f"+ {name}")
        elif c == -1.0:
            terms.append(f"- {name}")
        else:
            terms.append(f"{'+' if c > 0 else '-'} {abs(c):.6g} {name}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text


def _index(name: str) -> int:
    return STANDARD_NAMES.index(name)


def analytic_base_parameters(desc: RobotDescription) -> BaseParameters:
    """The paper's 88 base parameters, generalised to any platform frame.

    Per leg i (names ``..._i``): ZZ1R, MX1, MY1R, XX2R, XY2R, XZ2R, YZ2R, ZZ2R, MX2, MY2,
    MX3, MY3, MZ3 with (eq. 44-50)::

        ZZ1R = ZZ1 + YY2 + ZZ3        MY1R = MY1 - MZ2
        XX2R = XX2 + XX3 - YY2 - ZZ3  XY2R = XY2 - XZ3   XZ2R = XZ2 + XY3
        YZ2R = YZ2 - YZ3              ZZ2R = ZZ2 + YY3

    Platform (eq. 56-66, with ``l = pL_i`` = P_i in Fp; all six terms of each sum)::

        XX_RP = XX_P + sum M3i (l_y^2 + l_z^2)   XY_RP = XY_P - sum M3i l_x l_y   ...
        MX_RP = MX_P + sum M3i l_x  ...          M_RP = M_P + sum M3i

    Special geometry (a vertical first axis, symmetric legs) can make some of these
    unidentifiable; :func:`numerical_base_parameters` tells.
    """
    rows: list[np.ndarray] = []
    names: list[str] = []
    kept: list[int] = []

    def add(name: str, terms: Sequence[tuple[float, str]]) -> None:
        row = np.zeros(N_STANDARD)
        for coef, std in terms:
            row[_index(std)] += coef
        rows.append(row)
        names.append(name)
        kept.append(_index(terms[0][1]))

    for i in range(1, 7):

        def s(p: str, j: int, i: int = i) -> str:
            return f"{p}{j}_{i}"

        add(f"ZZ1R_{i}", [(1, s("ZZ", 1)), (1, s("YY", 2)), (1, s("ZZ", 3))])
        add(f"MX1_{i}", [(1, s("MX", 1))])
        add(f"MY1R_{i}", [(1, s("MY", 1)), (-1, s("MZ", 2))])
        add(f"XX2R_{i}", [(1, s("XX", 2)), (1, s("XX", 3)), (-1, s("YY", 2)), (-1, s("ZZ", 3))])
        add(f"XY2R_{i}", [(1, s("XY", 2)), (-1, s("XZ", 3))])
        add(f"XZ2R_{i}", [(1, s("XZ", 2)), (1, s("XY", 3))])
        add(f"YZ2R_{i}", [(1, s("YZ", 2)), (-1, s("YZ", 3))])
        add(f"ZZ2R_{i}", [(1, s("ZZ", 2)), (1, s("YY", 3))])
        for p, j in (("MX", 2), ("MY", 2), ("MX", 3), ("MY", 3), ("MZ", 3)):
            add(f"{p}{j}_{i}", [(1, s(p, j))])

    L = desc.platform_points  # P_i in Fp, from O_p
    lx, ly, lz = L[:, 0], L[:, 1], L[:, 2]
    m3 = [f"M3_{i}" for i in range(1, 7)]
    point_mass = {
        "XX": ly**2 + lz**2,
        "XY": -lx * ly,
        "XZ": -lx * lz,
        "YY": lx**2 + lz**2,
        "YZ": -ly * lz,
        "ZZ": lx**2 + ly**2,
        "MX": lx,
        "MY": ly,
        "MZ": lz,
        "M": np.ones(6),
    }
    for p, coefs in point_mass.items():
        add(f"{p}_RP", [(1, f"{p}_P"), *zip(coefs, m3, strict=True)])
    K = np.array(rows)
    return BaseParameters(tuple(names), K, np.array(kept), K @ standard_parameters(desc))


@dataclass(frozen=True)
class RankReport:
    """How the numerical rank was decided.

    Attributes:
        rank: the numerical rank of the stacked regressor.
        n_states: states stacked (6 rows each).
        tolerance: relative threshold on the singular values / |R_kk|.
        smallest_kept, largest_dropped: singular values either side of the cut, relative to
            the largest (of the column-normalised stacked regressor).
    """

    rank: int
    n_states: int
    tolerance: float
    smallest_kept: float
    largest_dropped: float

    def __str__(self) -> str:
        return (
            f"rank {self.rank} of {N_STANDARD} from {self.n_states} states "
            f"(tolerance {self.tolerance:g}; relative singular values: smallest kept "
            f"{self.smallest_kept:.3g}, largest dropped {self.largest_dropped:.3g})"
        )


def stacked_regressor(robot: Any, n_states: int = 60, seed: int = 0) -> np.ndarray:
    """``W`` stacked over ``n_states`` random workspace states: (6 n_states, 190)."""
    from .workspace import sample_states

    poses, twists, accels = sample_states(robot.description, n_states, seed)
    return robot.regressor(poses, twists, accels).reshape(-1, N_STANDARD)


def numerical_base_parameters(
    robot: Any, n_states: int = 60, seed: int = 0, tolerance: float = RANK_TOLERANCE
) -> tuple[BaseParameters, RankReport]:
    """Base parameters by QR with column pivoting of the stacked regressor.

    Columns are normalised to unit norm (zero columns stay zero) before the decomposition so
    that the rank decision does not depend on units. With ``W P = Q [R1 R2]`` and rank r,
    ``W_2 = W_1 beta`` with ``beta = R1^-1 R2``, so ``chi_b = chi_1 + beta chi_2``.
    Names are those of the kept standard parameters with a ``*`` suffix when others are
    folded into them.
    """
    W = stacked_regressor(robot, n_states, seed)
    norms = np.linalg.norm(W, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    Wn = W / scale
    sv = np.linalg.svd(Wn, compute_uv=False)
    _, R, perm = scipy.linalg.qr(Wn, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > tolerance * diag[0]))
    if rank == 0:
        raise StewartPinError("the stacked regressor is zero: no parameter is identifiable")
    R1, R2 = R[:rank, :rank], R[:rank, rank:]
    beta_n = scipy.linalg.solve_triangular(R1, R2)  # in normalised columns
    kept, folded = perm[:rank], perm[rank:]
    # Back to physical units: W1 = Wn1 D1, W2 = Wn2 D2 -> beta = D1^-1 beta_n D2.
    beta = beta_n * scale[folded][None, :] / scale[kept][:, None]
    beta[np.abs(beta) < 1e-10 * max(1.0, np.abs(beta).max())] = 0.0
    K = np.zeros((rank, N_STANDARD))
    K[np.arange(rank), kept] = 1.0
    K[:, folded] = beta
    order = np.argsort(kept)  # present in the standard order
    K, kept = K[order], kept[order]
    names = tuple(
        STANDARD_NAMES[k] + ("*" if np.count_nonzero(row) > 1 else "")
        for k, row in zip(kept, K, strict=True)
    )
    report = RankReport(
        rank,
        n_states,
        tolerance,
        float(sv[rank - 1] / sv[0]),
        float(sv[rank] / sv[0]) if rank < len(sv) else 0.0,
    )
    chi = standard_parameters(robot.description)
    return BaseParameters(names, K, kept, K @ chi, robot), report


def base_parameters(robot: Any, method: str = "analytic", **kwargs: Any) -> BaseParameters:
    """The base parameters of ``robot`` (a :class:`~stewart_pin.StewartRobot`), bound to it.

    Args:
        method: ``"analytic"`` (the paper's named 88) or ``"numerical"`` (QR; ``kwargs``
            go to :func:`numerical_base_parameters`).
    """
    if method == "analytic":
        bp = analytic_base_parameters(robot.description)
    elif method == "numerical":
        bp, _ = numerical_base_parameters(robot, **kwargs)
    else:
        raise StewartPinError(f"unknown method '{method}': 'analytic' or 'numerical'")
    return replace(bp, robot=robot)


@dataclass(frozen=True)
class EssentialParameters:
    """A subset of the base parameters that predicts the forces within ``threshold``.

    Attributes:
        names: the essential parameters kept (a subset of the base names).
        values: their base values.
        index: their positions in the base set.
        relative_error: ``||Gamma - W_e chi_e|| / ||Gamma||`` over those states.
        removal_order: the base parameters removed, first removed first, with the relative
            force error after each removal.
        threshold, n_states: the criterion and the number of states it was evaluated on.
    """

    names: tuple[str, ...]
    values: np.ndarray
    index: np.ndarray
    relative_error: float
    removal_order: tuple[tuple[str, float], ...]
    threshold: float
    n_states: int

    def __len__(self) -> int:
        return len(self.names)


def essential_parameters(
    robot: Any,
    threshold: float = 0.01,
    n_states: int = 100,
    seed: int = 0,
    base: BaseParameters | None = None,
) -> EssentialParameters:
    """The essential parameters: the base parameters left when those whose removal changes
    the predicted forces by less than ``threshold`` are removed.

    The change is ``||sum_removed W_k chi_k|| / ||Gamma||`` (2-norms over ``n_states``
    random workspace states with random twists and accelerations, a broad excitation),
    the other parameters keeping their values. Greedy: at each step the parameter whose
    removal keeps that change smallest goes, until the next would pass the threshold.
    Parameters that vanish by symmetry (as the paper's symmetric links make many) go
    first, at zero cost. ``values`` are the robot's base values of the kept parameters.
    """
    bp = base if base is not None else analytic_base_parameters(robot.description)
    W = bp.reduce(stacked_regressor(robot, n_states, seed))
    parts = W * bp.values  # column k: the forces parameter k accounts for
    gamma = parts.sum(axis=1)
    norm = np.linalg.norm(gamma)
    if norm == 0:
        raise StewartPinError("the robot's forces are zero over the states: nothing to keep")
    active = list(range(len(bp)))
    removed: list[tuple[str, float]] = []
    dropped = np.zeros_like(gamma)
    while len(active) > 1:
        trials = np.linalg.norm(dropped[:, None] + parts[:, active], axis=0) / norm
        best = int(np.argmin(trials))
        if trials[best] > threshold:
            break
        dropped += parts[:, active[best]]
        removed.append((bp.names[active[best]], float(trials[best])))
        del active[best]
    idx = np.array(active)
    return EssentialParameters(
        tuple(bp.names[k] for k in idx),
        bp.values[idx],
        idx,
        float(np.linalg.norm(dropped) / norm),
        tuple(removed),
        threshold,
        n_states,
    )


#: The paper's Table III per leg (read from the OCR text, whose table is partly garbled):
#: with symmetric links, and links 1 and 2 forming one real body, these 7 per leg and the
#: platform's 10 remain: 6 x 7 + 10 = 52.
PAPER_ESSENTIAL_PER_LEG = ("ZZ1R", "XX2R", "ZZ2R", "MY2", "MX3", "MY3", "MZ3")


def paper_essential_parameters(
    robot: Any, n_states: int = 100, seed: int = 0
) -> EssentialParameters:
    """The paper's 52 essential parameters (Table III), with the relative force error of
    keeping only them (zero to round-off for a robot meeting the paper's assumptions)."""
    bp = analytic_base_parameters(robot.description)
    keep = [f"{p}_{i}" for i in range(1, 7) for p in PAPER_ESSENTIAL_PER_LEG]
    keep += [n for n in bp.names if n.endswith("_RP")]
    idx = np.array(sorted(bp.names.index(n) for n in keep))
    W = bp.reduce(stacked_regressor(robot, n_states, seed))
    parts = W * bp.values
    gamma = parts.sum(axis=1)
    dropped = np.setdiff1d(np.arange(len(bp)), idx)
    error = float(np.linalg.norm(parts[:, dropped].sum(axis=1)) / np.linalg.norm(gamma))
    return EssentialParameters(
        tuple(bp.names[k] for k in idx),
        bp.values[idx],
        idx,
        error,
        tuple((bp.names[k], float("nan")) for k in dropped),
        0.0,
        n_states,
    )
