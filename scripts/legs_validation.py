"""Measure the general-leg models against the independent constrained tree.

Prints, per architecture, on random asymmetric robots with every joint term non-zero
(``random_hexapod(kind, seed)``) and on the presets, the largest per-state relative
errors of:

- IDM: ``GeneralDynamics.inverse_dynamics`` against the KKT solve on Pinocchio's
  constrained tree (``check.leg_chain_tree.reference_inverse_dynamics``);
- DDM: ``GeneralDynamics.direct_dynamics`` against ``pin.constraintDynamics`` on the
  tree, for the reference's forces;
- DDM(IDM): the direct model on the inverse model's forces against the acceleration put in;
- power: ``|Gamma . qdot_a - dE/dt - P_lost| / (|Gamma . qdot_a| + |dE/dt| + |P_lost|)``,
  ``dE/dt`` by five-point central differences (step 1e-3 s) of the tree's energy along an
  exact SE(3) trajectory through the state, ``P_lost`` the tree's dissipated power.

Relative error of a state: ``max_k |a_k - b_k| / max_k |b_k|``. Run from the repository
root (a few seconds)::

    PYTHONPATH=src python scripts/legs_validation.py [--seeds 3] [--states 10]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import pinocchio as pin

from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_energy,
    reference_inverse_dynamics,
)
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.description.leg_chain_presets import GENERAL_PRESETS, random_hexapod
from stewart_pin.dynamics.leg_chain_dynamics import GeneralDynamics
from stewart_pin.exceptions import LegReachError
from stewart_pin.kinematics import leg_chains as lc
from stewart_pin.kinematics.leg_chains import inverse_geometry_batch

#: Translation [m] and rotation [rad] ranges about the home pose, per architecture.
RANGES = {
    "ups": (0.03, 0.1),
    "ups-offset": (0.03, 0.1),
    "rus": (0.003, 0.03),
    "pus": (0.02, 0.1),
    "custom": (0.02, 0.1),
}
PRESET_RANGES = {"ups-offset": (0.01, 0.05), "rus": (0.005, 0.05), "pus": (0.02, 0.1)}


def states(
    h: GeneralHexapod, n: int, seed: int, tr: float, rot: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random poses about home, twists and classical accelerations of matching scales."""
    rng = np.random.default_rng(seed)
    T = np.array([h.home_pose] * n)
    for k in range(n):
        T[k, :3, 3] += rng.uniform(-tr, tr, 3)
        T[k, :3, :3] = pin.exp3(rng.uniform(-rot, rot, 3)) @ T[k, :3, :3]
    scale = np.r_[[tr] * 3, [rot] * 3]
    return T, 5 * scale * rng.normal(size=(n, 6)), 30 * scale * rng.normal(size=(n, 6))


def rel(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    return float((np.abs(a - b).max(axis=1) / np.abs(b).max(axis=1)).max())


def left_jacobian(phi: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(phi))
    S = pin.skew(phi)
    if th < 1e-8:
        return np.eye(3) + 0.5 * S
    return np.eye(3) + (1 - math.cos(th)) / th**2 * S + (th - math.sin(th)) / th**3 * S @ S


def power_residual(
    h: GeneralHexapod,
    g: GeneralDynamics,
    solver: GeneralTreeSolver,
    T0: np.ndarray,
    V0: np.ndarray,
    A0: np.ndarray,
) -> float:
    R0, p0 = T0[:3, :3], T0[:3, 3]

    def energy(t: float) -> float:
        phi = V0[3:] * t + 0.5 * A0[3:] * t**2
        T = np.eye(4)
        T[:3, :3] = pin.exp3(phi) @ R0
        T[:3, 3] = p0 + V0[:3] * t + 0.5 * A0[:3] * t**2
        V = np.r_[V0[:3] + A0[:3] * t, left_jacobian(phi) @ (V0[3:] + A0[3:] * t)]
        k, u, _ = reference_energy(solver, T[None], V[None], inverse_geometry_batch(h, T[None]))
        return float(k[0] + u[0])

    dt = 1e-3
    dE = (8 * (energy(dt) - energy(-dt)) - (energy(2 * dt) - energy(-2 * dt))) / (12 * dt)
    _, _, lost = reference_energy(solver, T0[None], V0[None], inverse_geometry_batch(h, T0[None]))
    power = float(g.inverse_dynamics(T0, V0, A0) @ g.actuator_rates(T0, V0))
    return abs(power - dE - lost[0]) / (abs(power) + abs(dE) + abs(lost[0]))


def measure(h: GeneralHexapod, n: int, seed: int, tr: float, rot: float) -> list[float]:
    g, solver = GeneralDynamics(h), GeneralTreeSolver(h)
    T, V, A = states(h, n, seed, tr, rot)
    q = inverse_geometry_batch(h, T)
    gamma = g.inverse_dynamics(T, V, A)
    gamma_ref = reference_inverse_dynamics(solver, T, V, A, q)
    accel_ref = reference_direct_dynamics(solver, T, V, gamma_ref, q)
    power = max(power_residual(h, g, solver, T[k], V[k], A[k]) for k in range(n))
    return [
        rel(gamma, gamma_ref),
        rel(g.direct_dynamics(T, V, gamma_ref), accel_ref),
        rel(g.direct_dynamics(T, V, gamma), A),
        power,
    ]


def serial_sweep(n: int) -> list[tuple[float, float, float]]:
    """The ``rus`` preset lifted towards its reach limit (a crank and its rod aligned):
    ``(serial measure, IDM error, DDM(IDM) error)`` at measures 0.1 .. 1e-4, the threshold
    ``LEG_SINGULARITY`` lowered to reach them."""
    h = GENERAL_PRESETS["rus"]()
    g, solver = GeneralDynamics(h), GeneralTreeSolver(h)

    def lifted(dz: float) -> np.ndarray:
        T = h.home_pose.copy()
        T[2, 3] += dz
        return T

    def measure_at(dz: float) -> float:
        try:
            q = inverse_geometry_batch(h, lifted(dz)[None], check_limits=False)
        except LegReachError:
            return 0.0
        frames = lc.leg_forward(h, q)
        return float(lc.serial_measure(h, frames, lc.leg_jacobians(h, frames)).min())

    saved, lc.LEG_SINGULARITY = lc.LEG_SINGULARITY, 0.0
    out = []
    try:
        for target in (1e-1, 2e-2, 1e-2, 1e-3, 1e-4):
            lo, hi = 0.0, 0.1  # measure(lo) > target >= measure(hi)
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if measure_at(mid) > target else (lo, mid)
            T = np.array([lifted(lo)] * n)
            _, V, A = states(h, n, 11, 0.005, 0.05)
            q = inverse_geometry_batch(h, T, check_limits=False)
            gamma = g.inverse_dynamics(T, V, A)
            ref = reference_inverse_dynamics(solver, T, V, A, q)
            out.append((measure_at(lo), rel(gamma, ref), rel(g.direct_dynamics(T, V, gamma), A)))
    finally:
        lc.LEG_SINGULARITY = saved
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="random robots per architecture")
    parser.add_argument("--states", type=int, default=20, help="random states per robot")
    args = parser.parse_args()
    start = time.perf_counter()
    print(
        f"{'robot':<22}{'robots':>7}{'states':>7}{'IDM':>10}{'DDM':>10}{'DDM(IDM)':>10}"
        f"{'power':>10}"
    )
    rows: list[tuple[str, int, list[float]]] = []
    for kind, (tr, rot) in RANGES.items():
        worst = np.max(
            [
                measure(random_hexapod(kind, s), args.states, 100 + s, tr, rot)
                for s in range(args.seeds)
            ],
            axis=0,
        )
        rows.append((f"random {kind}", args.seeds, list(worst)))
    for name, (tr, rot) in PRESET_RANGES.items():
        rows.append(
            (f"preset {name}", 1, measure(GENERAL_PRESETS[name](), args.states, 7, tr, rot))
        )
    for label, robots, e in rows:
        print(f"{label:<22}{robots:>7}{args.states:>7}" + "".join(f"{x:>10.1e}" for x in e))
    print("\nrus preset lifted to a serial singularity (crank and rod aligned):")
    print(f"{'measure':>10}{'IDM':>10}{'DDM(IDM)':>10}")
    for m, e_idm, e_rt in serial_sweep(args.states):
        print(f"{m:>10.1e}{e_idm:>10.1e}{e_rt:>10.1e}")
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
