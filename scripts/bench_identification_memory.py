"""Peak memory and time of identification from a long actuator log.

Writes a log of ``--samples`` samples (default 600 000: ten minutes at 1 kHz) of an
exciting trajectory (five harmonics of 0.2 Hz, resampled at ``--rate``): the actuator
positions of the exact motion quantised to 1 um (or 2^-16 rad for revolute actuators),
the efforts of the inverse dynamic model plus 1 % Gaussian noise; then runs
``stewart-pin identify --log FILE`` on it in a child process and reports the child's
peak resident memory (``getrusage(RUSAGE_CHILDREN).ru_maxrss``) and wall-clock seconds,
with the report's first lines.

The log is written to a temporary folder (about 230 bytes a line: 140 MB for 600 000
samples) and removed afterwards unless ``--keep``.

Usage: ``python scripts/bench_identification_memory.py [--preset random-2]
[--samples 600000] [--rate 1000] [--keep]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.parameters.identification import exciting_trajectory

CHUNK = 20_000  # samples generated at once [-]


def write_bench_log(robot: StewartRobot, path: Path, samples: int, rate: float) -> None:
    """The log of the module docstring, generated and written chunk by chunk."""
    traj, _ = exciting_trajectory(robot, seed=0, max_evaluations=50, n_samples=10)
    fourier = traj.fourier
    legs = robot.description.leg_architectures
    revolute = np.array([leg.joints[leg.actuated - 1].revolute for leg in legs])
    resolution = np.where(revolute, 2.0**-16, 1e-6)  # [rad or m]
    rng = np.random.default_rng(0)
    t0 = np.arange(min(samples, 2000)) / rate
    s0 = fourier.sample(t0)
    rms = np.sqrt(np.mean(robot.inverse_dynamics(s0.poses, s0.twists, s0.accels) ** 2, axis=0))
    with open(path, "w") as f:
        f.write("# efforts: sample\n")
        f.write("t,l1,l2,l3,l4,l5,l6,gamma1,gamma2,gamma3,gamma4,gamma5,gamma6\n")
        for start in range(0, samples, CHUNK):
            t = np.arange(start, min(samples, start + CHUNK)) / rate
            s = fourier.sample(t)
            q = robot.actuator_positions(s.poses)
            q = np.round(q / resolution) * resolution
            gamma = robot.inverse_dynamics(s.poses, s.twists, s.accels)
            gamma = gamma + rng.normal(size=gamma.shape) * 0.01 * rms
            for row in np.column_stack([t, q, gamma]):
                f.write(",".join(repr(float(v)) for v in row) + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="random-2")
    parser.add_argument("--samples", type=int, default=600_000)
    parser.add_argument("--rate", type=float, default=1000.0, help="[Hz]")
    parser.add_argument("--keep", action="store_true", help="keep the log file")
    args = parser.parse_args()
    robot = StewartRobot.from_preset(args.preset)
    folder = Path(tempfile.mkdtemp(prefix="stewart-pin-bench-"))
    path = folder / f"{robot.name}_{args.samples}.csv"
    t = time.perf_counter()
    write_bench_log(robot, path, args.samples, args.rate)
    print(
        f"wrote {path} ({args.samples} samples at {args.rate:g} Hz, "
        f"{path.stat().st_size / 1e6:.1f} MB) in {time.perf_counter() - t:.1f} s"
    )
    command = [
        sys.executable,
        "-c",
        "import sys; from stewart_pin.cli import main; sys.exit(main(sys.argv[1:]))",
        "identify",
        "--preset",
        args.preset,
        "--log",
        str(path),
        "--no-progress",
    ]
    t = time.perf_counter()
    child = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
    seconds = time.perf_counter() - t
    peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss  # Linux: kB
    if child.returncode != 0:
        print(child.stderr, file=sys.stderr)
        return child.returncode
    print("\n".join(child.stdout.splitlines()[:4]))
    print(
        f"\nstewart-pin identify --log: {args.samples} samples, peak RSS "
        f"{peak_kb / 1024:.0f} MB, {seconds:.1f} s"
    )
    if not args.keep:
        path.unlink()
        folder.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
