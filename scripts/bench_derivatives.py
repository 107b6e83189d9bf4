"""Speed of the exact derivatives against Pinocchio's constrained-dynamics derivatives
(issue 14, item 5).

Median wall-clock time [us] per state, all in one run, on one preset (default
``simulator``):

- ``pin.constraintDynamics`` on the 24-dof closed-loop tree (raw C++ call, q, v, tau
  prepared beforehand): the yardstick of every other benchmark, for the ratios;
- ``pin.constraintDynamics`` followed by ``pin.computeConstraintDynamicsDerivatives``
  (which needs it) on the same tree, q, v, tau prepared: the tree's derivatives with
  respect to q, v and tau (24 x 24 each), *not yet* mapped to the platform state; one
  state per call, and per state over a Python loop of 1000 prepared states (Pinocchio has
  no batch call);
- the same mapped to the platform state by
  :func:`stewart_pin.check.dynamics_derivatives.constrained_direct_dynamics_derivatives`
  (the test's reference: tree state, kinematic maps, chain rule), one state;
- stewart-pin's ``robot.inverse_dynamics_derivatives`` / ``direct_dynamics_derivatives``
  (value and the three 6x6 Jacobians, compiled), one state per call, and per state in a
  batch of 10 000 states, with the backend's threads (``STEWART_PIN_THREADS``, default
  ``os.cpu_count()``) and with one thread.

Ratios are given to ``pin.constraintDynamics`` and to the raw Pinocchio derivatives call.
The first run compiles the derivative library (a few seconds; cached afterwards).

``--first-use`` (issue 24, item 3) times instead, per preset (default: every preset of
:data:`FIRST_USE_PRESETS`), the first call of ``robot.inverse_dynamics_derivatives`` in a
new process with a fresh, empty cache folder (the value library compiled and cached
beforehand in that folder, by another process, as a user who has already used the robot
would have it): the wall-clock time of the call from the robot's construction (import
excluded), and its share spent compiling. The stderr line announcing the build is shown.

Usage: ``python scripts/bench_derivatives.py [--preset simulator] [--repeats 1000]
[--batch 10000] [--json out.json]`` or ``python scripts/bench_derivatives.py --first-use
[--preset rus] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin._io import write_text_atomic
from stewart_pin.apps.bench import constraint_dynamics_call, machine, machine_line, median_us
from stewart_pin.apps.bench_sections import FIRST_USE_PRESETS, first_use
from stewart_pin.check.dynamics_derivatives import (
    constrained_direct_dynamics_derivatives,
    tree_derivatives_call,
)
from stewart_pin.codegen.derivatives import CompiledDerivatives, derivatives_backend

PIN_VALUE = "pin.constraintDynamics (raw call)"
PIN_DERIVATIVES = "pin.constraintDynamics + computeConstraintDynamicsDerivatives (raw calls)"


def run(preset: str, repeats: int, batch: int) -> dict[str, object]:
    robot = StewartRobot.from_preset(preset)
    poses, twists, accels = robot.sample_states(1000, 0)
    idx = np.arange(batch) % poses.shape[0]
    P, V, A = (np.ascontiguousarray(a[idx]) for a in (poses, twists, accels))
    backend = derivatives_backend(robot)  # compiles on the first run
    serial = CompiledDerivatives(robot, threads=1)
    G = robot.inverse_dynamics(P, V, A, backend="compiled")
    T0, V0, A0, G0 = P[0].copy(), V[0].copy(), A[0].copy(), G[0].copy()
    rows: dict[str, float] = {}
    rows[PIN_VALUE] = median_us(constraint_dynamics_call(robot, T0, V0, G0), repeats)
    rows[PIN_DERIVATIVES] = median_us(tree_derivatives_call(robot, T0, V0, G0), repeats)
    calls = [tree_derivatives_call(robot, P[k], V[k], G[k]) for k in range(1000)]

    def loop() -> None:
        for c in calls:
            c()

    rows["  the same, per state over 1000 prepared states"] = median_us(
        loop, max(repeats // 100, 5), 1000
    )
    rows["  mapped to the platform state (check.dynamics_derivatives), one state"] = median_us(
        lambda: constrained_direct_dynamics_derivatives(robot, T0, V0, G0),
        max(repeats // 10, 20),
    )
    rows["IDM derivatives, one state (robot.inverse_dynamics_derivatives)"] = median_us(
        lambda: robot.inverse_dynamics_derivatives(T0, V0, A0), repeats
    )
    rows["DDM derivatives, one state (robot.direct_dynamics_derivatives)"] = median_us(
        lambda: robot.direct_dynamics_derivatives(T0, V0, G0), repeats
    )
    for b in (backend, serial):
        rows[f"IDM derivatives, batch {batch}, per state ({b.threads} threads)"] = median_us(
            lambda b=b: b.inverse_dynamics_derivatives(P, V, A), 10, batch
        )
        rows[f"DDM derivatives, batch {batch}, per state ({b.threads} threads)"] = median_us(
            lambda b=b: b.direct_dynamics_derivatives(P, V, G), 10, batch
        )
    return {
        "preset": preset,
        "repeats": repeats,
        "batch": batch,
        "threads": backend.threads,
        "kind": backend.kind,
        "machine": machine(),
        "median_us_per_state": rows,
        "ratio_to_pin_constraintDynamics": {k: t / rows[PIN_VALUE] for k, t in rows.items()},
        "ratio_to_pin_derivatives": {k: t / rows[PIN_DERIVATIVES] for k, t in rows.items()},
    }


def main_first_use(presets: list[str], out: Path | None) -> None:
    print(f"first derivatives call, fresh cache, new process; {machine_line(machine())}")
    print(
        f"{'preset':12s} {'first call [s]':>15s} {'compiling [s]':>14s} "
        f"{'2nd call [us]':>14s} {'load':>6s}"
    )
    results = []
    for preset in presets:
        r = first_use(preset)
        results.append(r)
        print(
            f"{preset:12s} {r['first_call_s']:15.2f} {r['compiling_s']:14.2f} "
            f"{r['second_call_us']:14.1f} {r['load_average_1min']:6.2f}",
            flush=True,
        )
        print(f"  stderr: {r['announced']}", flush=True)
    if out:
        write_text_atomic(out, json.dumps({"machine": machine(), "first_use": results}, indent=2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default=None, help="default: simulator (--first-use: all)")
    parser.add_argument("--first-use", action="store_true", help="time the first call")
    parser.add_argument("--repeats", type=int, default=1000)
    parser.add_argument("--batch", type=int, default=10_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.first_use:
        main_first_use([args.preset] if args.preset else list(FIRST_USE_PRESETS), args.json)
        return
    args.preset = args.preset or "simulator"
    result = run(args.preset, args.repeats, args.batch)
    print(
        f"preset {args.preset}, derivatives {result['kind']}, {result['threads']} threads, "
        f"{result['machine']}"
    )
    rows = result["median_us_per_state"]
    r_value = result["ratio_to_pin_constraintDynamics"]
    r_deriv = result["ratio_to_pin_derivatives"]
    assert isinstance(rows, dict) and isinstance(r_value, dict) and isinstance(r_deriv, dict)
    print(f"{'median time per state':76s} {'[us]':>8s} {'/ pin.cD':>9s} {'/ pin.dcD':>9s}")
    for name, t in rows.items():
        print(f"{name:76s} {t:8.2f} {r_value[name]:9.3f} {r_deriv[name]:9.3f}")
    if args.json:
        write_text_atomic(args.json, json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
