"""Build time against call time: the models' libraries optimised (``-O2``, the default) and
quick (``$STEWART_PIN_BUILD=quick``, ``-O0``).

For each robot (default ``simulator``, ``rus``, ``random-rus-0``, ``welded-ups``), in a
fresh temporary cache per build: the wall time of ``CompiledDynamics(robot)`` (compiling
and loading; the symbolic models are generated beforehand, outside the timing) and the
median time per state [us] of the compiled IDM and DDM on one thread, for one state per
call and for a batch of 10 000 states.

Usage: ``python scripts/bench_build_flags.py [--robots simulator,rus] [--repeats 200]
[--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from stewart_pin._io import write_text_atomic
from stewart_pin.apps._timing import median_us
from stewart_pin.apps.bench import machine
from stewart_pin.apps.bench_sections import bench_robot
from stewart_pin.codegen import compiled

BATCH = 10_000


def one_mode(robot: Any, mode: str, states: tuple[Any, ...], repeats: int) -> dict[str, float]:
    """The build time [s] and call times [us per state] of ``robot`` built ``mode``."""
    P, V, A = states
    os.environ[compiled.BUILD_ENV] = mode
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        backend = compiled.CompiledDynamics(robot, cache_dir=cache, threads=1)
        build = time.perf_counter() - t0
        G = backend.inverse_dynamics(P, V, A)
        T, v, a, g = P[0], V[0], A[0], G[0]
        return {
            "build [s]": build,
            "IDM one state [us]": median_us(lambda: backend.inverse_dynamics(T, v, a), repeats),
            "DDM one state [us]": median_us(lambda: backend.direct_dynamics(T, v, g), repeats),
            f"IDM batch {BATCH} [us/state]": median_us(
                lambda: backend.inverse_dynamics(P, V, A), 5, BATCH
            ),
            f"DDM batch {BATCH} [us/state]": median_us(
                lambda: backend.direct_dynamics(P, V, G), 5, BATCH
            ),
        }


def measure(name: str, repeats: int) -> dict[str, dict[str, float]]:
    robot = bench_robot(name)
    compiled.c_source(robot.description)  # the symbolic models, generated once
    states = robot.sample_states(BATCH, 0)
    return {mode: one_mode(robot, mode, states, repeats) for mode in compiled.BUILD_FLAGS}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="simulator,rus,random-rus-0,welded-ups")
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    results = {}
    print(machine())
    for name in args.robots.split(","):
        results[name] = measure(name, args.repeats)
        opt, quick = results[name]["optimised"], results[name]["quick"]
        print(name)
        for key in opt:
            print(f"  {key:32s} optimised {opt[key]:9.3f}   quick {quick[key]:9.3f}")
    if args.json:
        report = {"machine": machine(), "results": results}
        write_text_atomic(args.json, json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
