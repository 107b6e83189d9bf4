"""Benchmark the paper's dynamic models against Pinocchio's constrained dynamics.

Median wall-clock time per state [us], all measured in this one run:

- the inverse (IDM) and direct (DDM) models of stewart-pin (Pinocchio leg dynamics plus
  the closure layer), one state per call and a batch of N states per call;
- ``pin.constraintDynamics`` on the 24-dof closed-loop tree (the raw C++ call, with q, v
  and tau prepared beforehand) and the whole reference path of
  ``stewart_pin.validation`` (state conversion included) for the direct and inverse models.

Usage: ``python scripts/bench_dynamics.py [--preset simulator] [--batch 10000]
[--repeats 300] [--json bench.json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

import stewart_pin
from stewart_pin import StewartRobot
from stewart_pin.validation import (
    _solver,
    constrained_forward_dynamics,
    constrained_inverse_dynamics,
    tree_state,
)
from stewart_pin.workspace import sample_states


def median_us(fn: Callable[[], object], repeats: int, per: int = 1) -> float:
    """Median over ``repeats`` calls of ``fn``, divided by ``per`` states per call [us]."""
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) / per * 1e6


def machine() -> dict[str, object]:
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "numpy": np.__version__,
        "pinocchio": pin.__version__,
        "stewart_pin": stewart_pin.__version__,
    }


def run(preset: str, batch: int, repeats: int) -> dict[str, object]:
    robot = StewartRobot.from_preset(preset)
    poses, twists, accels = sample_states(robot.description, batch, 0)
    gammas = robot.inverse_dynamics(poses, twists, accels)
    T, V, A, G = poses[0], twists[0], accels[0], gammas[0]
    solver = _solver(robot)
    q, v = tree_state(robot, T, V)
    tau = np.zeros(solver.nv)
    tau[solver.v_act] = G
    batch_repeats = max(3, min(repeats, 5))
    rows = {
        "IDM single": median_us(lambda: robot.inverse_dynamics(T, V, A), repeats),
        "DDM single": median_us(lambda: robot.direct_dynamics(T, V, G), repeats),
        f"IDM batch {batch}": median_us(
            lambda: robot.inverse_dynamics(poses, twists, accels), batch_repeats, batch
        ),
        f"DDM batch {batch}": median_us(
            lambda: robot.direct_dynamics(poses, twists, gammas), batch_repeats, batch
        ),
        "pin.constraintDynamics (raw call)": median_us(
            lambda: pin.constraintDynamics(
                solver.model,
                solver.data,
                q,
                v,
                tau,
                solver.cmodels,
                solver.cdatas,
                solver.settings,
            ),
            repeats,
        ),
        "pin.rnea on the 24-dof tree (raw call)": median_us(
            lambda: pin.rnea(solver.model, solver.data, q, v, np.zeros(solver.nv)), repeats
        ),
        "constrained forward dynamics (reference path)": median_us(
            lambda: constrained_forward_dynamics(robot, T, V, G), repeats
        ),
        "constrained inverse dynamics (reference path)": median_us(
            lambda: constrained_inverse_dynamics(robot, T, V, A), repeats
        ),
    }
    reference = rows["pin.constraintDynamics (raw call)"]
    return {
        "preset": preset,
        "batch": batch,
        "repeats": repeats,
        "machine": machine(),
        "median_us_per_state": rows,
        "ratio_to_pin_constraintDynamics": {k: t / reference for k, t in rows.items()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="simulator")
    parser.add_argument("--batch", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=300)
    parser.add_argument("--json", type=Path, help="write the results as JSON here")
    args = parser.parse_args()
    result = run(args.preset, args.batch, args.repeats)
    print(f"stewart-pin {stewart_pin.__version__}, preset '{args.preset}', {result['machine']}")
    print(f"{'median time per state':48s} {'[us]':>10s} {'/ pin.constraintDynamics':>26s}")
    for name, t in result["median_us_per_state"].items():
        ratio = result["ratio_to_pin_constraintDynamics"][name]
        print(f"{name:48s} {t:10.2f} {ratio:26.2f}")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
