"""Memory of reading an actuator log: peak and kept bytes per sample.

Writes a log of ``--samples`` samples (t, six positions, six efforts: the 13 columns
of ``docs/identification.md``), reads it with :func:`stewart_pin.parameters.logs.read_log`
under ``tracemalloc`` (numpy's and Python's allocations), and prints the peak during the
read and the memory the returned :class:`~stewart_pin.parameters.logs.ActuatorLog` keeps,
each divided by the number of samples, beside the documented 13 floats (104 bytes) plus
the line number (8 bytes) kept per sample. The text of the file is never held whole
(the reader streams it), so neither figure grows with the line length.

Usage: ``python scripts/bench_log_memory.py [--samples 200000] [--preset simulator]``.
"""

from __future__ import annotations

import argparse
import tempfile
import tracemalloc
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.parameters.logs import LOG_COLUMNS, read_log


def write_plain_log(path: Path, samples: int, centre: np.ndarray) -> None:
    """A log of ``samples`` samples at 1 kHz: smooth positions within 0.01 of ``centre``
    (6,) [m or rad] and efforts
    about 100 N, written with ``repr`` as :func:`~stewart_pin.parameters.logs.write_log`
    does (without building the whole table in memory)."""
    rng = np.random.default_rng(0)
    with open(path, "w") as f:
        f.write(",".join(LOG_COLUMNS) + "\n")
        chunk = 10_000
        for start in range(0, samples, chunk):
            t = np.arange(start, min(samples, start + chunk)) / 1000.0  # [s]
            q = centre + 0.01 * np.sin(t[:, None] + np.arange(6))  # [m or rad]
            g = 100.0 * np.cos(t[:, None] + np.arange(6)) + rng.normal(size=q.shape)  # [N]
            for row in np.column_stack([t, q, g]):
                f.write(",".join(repr(float(v)) for v in row) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200_000, help="samples in the log")
    parser.add_argument(
        "--preset",
        help="check the positions against this robot's limits too (positions about its "
        "home pose's)",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        robot = StewartRobot.from_preset(args.preset) if args.preset else None
        centre = np.full(6, 0.5) if robot is None else robot.actuator_positions(robot.home_pose)
        write_plain_log(path, args.samples, centre)
        size = path.stat().st_size
        tracemalloc.start()
        log = read_log(path, robot, clip_run=0)
        _, peak = tracemalloc.get_traced_memory()
        kept, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    n = len(log)
    arrays = log.times.nbytes + log.positions.nbytes + log.efforts.nbytes
    arrays += 0 if log.lines is None else log.lines.nbytes
    print(f"{n} samples, file {size / n:.0f} bytes per line")
    print(f"peak while reading: {peak / n:.1f} bytes per sample")
    print(f"kept by the log:    {kept / n:.1f} bytes per sample (arrays {arrays / n:.0f})")
    print("documented:         104 bytes per sample (13 floats) + 8 (the line number)")


if __name__ == "__main__":
    main()
