"""Time the design studies (issue 22): a 6-UPS workspace from 10^6 states, and a geometry
sweep on a 2-worker Dask ``LocalCluster`` against the same sweep serial.

Prints the workspace's time [s] and volume, the sweep's serial and parallel times, the
speed-up and parallel efficiency (speed-up / workers), and whether the two tables are
identical (their CSV text). Run on an idle machine; report the load (``uptime``).

Usage: ``python scripts/bench_design.py [--preset desktop] [--states 1000000]
[--geometries 200] [--workers 2] [--resolution 24] [--samples 1000]
[--backend pinocchio]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot, design


def bench_workspace(preset: str, states: int) -> None:
    robot = StewartRobot.from_preset(preset)
    warm = design.workspace(robot, resolution=8)  # warm-up (imports, first calls)
    # the resolution (cells on the box's longest side) that gives about ``states`` cells
    span = warm.upper - warm.lower
    side = round((states * span.max() ** 3 / np.prod(span)) ** (1 / 3))
    t = time.perf_counter()
    ws = design.workspace(robot, resolution=side, box=(warm.lower, warm.upper))
    dt = time.perf_counter() - t
    n = ws.inside.size
    print(
        f"workspace ({preset}, {n} states on a {ws.shape} grid, the box of a first coarse "
        f"estimate): {dt:.2f} s, volume {ws.volume:.6g} +- "
        f"{ws.volume_error:.2g} m^3"
    )


def bench_sweep(
    geometries: int, workers: int, backend: str, resolution: int, samples: int
) -> None:
    rng = np.random.default_rng(0)
    geoms = [
        {
            "base_radius": float(rng.uniform(0.08, 0.12)),
            "platform_radius": float(rng.uniform(0.05, 0.09)),
            "home_height": float(rng.uniform(0.13, 0.17)),
        }
        for _ in range(geometries)
    ]
    from dask.distributed import Client, LocalCluster

    settings = design.SweepSettings(resolution=resolution, samples=samples, backend=backend)
    t = time.perf_counter()
    serial = design.sweep(geoms, settings, scheduler="serial", progress=False)
    t_serial = time.perf_counter() - t
    t = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)
    client = Client(cluster)
    design.sweep(geoms[:workers], settings, client=client, progress=False)  # workers' imports
    t_start = time.perf_counter() - t
    t = time.perf_counter()
    parallel = design.sweep(geoms, settings, client=client, progress=False)
    t_par = time.perf_counter() - t
    client.close()
    cluster.close()
    with tempfile.TemporaryDirectory() as folder:
        a = serial.write_csv(Path(folder) / "a.csv").read_text()
        b = parallel.write_csv(Path(folder) / "b.csv").read_text()
    speedup = t_serial / t_par
    failed = sum(1 for r in serial.rows if r["error"])
    print(
        f"sweep of {geometries} geometries ({failed} failed rows; resolution {resolution}, "
        f"{samples} samples, backend {backend}): serial {t_serial:.1f} s, LocalCluster of "
        f"{workers} processes {t_par:.1f} s (+ {t_start:.1f} s to start it and import in "
        f"the workers), speed-up {speedup:.2f}, parallel efficiency "
        f"{speedup / workers:.0%}, identical tables: {a == b}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", default="desktop")
    parser.add_argument("--states", type=int, default=1_000_000)
    parser.add_argument("--geometries", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--resolution", type=int, default=24, help="workspace cells")
    parser.add_argument("--samples", type=int, default=1000, help="states per geometry")
    parser.add_argument(
        "--backend", default="pinocchio", help="the sweep's inverse dynamics backend"
    )
    args = parser.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} cores")
    # the sweep first: the workspace's large arrays would stay in this process's heap
    bench_sweep(args.geometries, args.workers, args.backend, args.resolution, args.samples)
    bench_workspace(args.preset, args.states)


if __name__ == "__main__":
    main()
