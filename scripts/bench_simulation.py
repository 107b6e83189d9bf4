"""Time ``simulate`` per RK4 step beside MuJoCo's own RK4 step on the same robot (issue 24,
item 1): the compiled loop with forces as data, with the computed-torque controller, with a
Python force function per step, the Python loop, ``mj_step`` with ``opt.integrator = RK4``
and ``pin.constraintDynamics``, all in this one run (the rows take turns), with the ratios
(see :mod:`stewart_pin.apps.bench_simulation`). ``stewart-pin bench`` shows the same rows
for its ``--preset``.

Usage: ``python scripts/bench_simulation.py [--presets simulator rus] [--repeats 7]
[--duration 1.0] [--dt 1e-3]``.
"""

from __future__ import annotations

import argparse

from stewart_pin.apps.bench_simulation import simulation_rows, simulation_table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", default=["simulator", "rus"])
    parser.add_argument("--repeats", type=int, default=7, help="timed runs per row")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time [s]")
    parser.add_argument("--dt", type=float, default=1e-3, help="RK4 step [s]")
    args = parser.parse_args()
    results = {
        name: simulation_rows(name, args.repeats, False, args.duration, args.dt)
        for name in args.presets
    }
    print("\n".join(simulation_table(results)))


if __name__ == "__main__":
    main()
