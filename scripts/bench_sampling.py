"""Time ``StewartRobot.sample_states`` on every leg architecture (issue 24, item 5).

Median wall-clock time [s] of ``robot.sample_states(n, seed)`` (default n = 10 000) per
preset: the ideal 6-UPS ``simulator`` and the general legs ``ups-offset``, ``rus``,
``pus`` and a random custom robot (``random-custom-0``), with the fraction of draws the
sampler accepted (the rest leave a limit or come too near a singularity). The aim is
under 1 s for 10 000 states on every architecture. The robot is built (and its caches
warmed by one small call) before timing.

Usage: ``python scripts/bench_sampling.py [--n 10000] [--repeats 3] [--presets simulator rus]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from stewart_pin import StewartRobot

PRESETS = ("simulator", "ups-offset", "rus", "pus", "random-custom-0")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000, help="states per call")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per preset")
    parser.add_argument("--presets", nargs="+", default=list(PRESETS))
    args = parser.parse_args()
    print(f"{'preset':<18}{'median [s]':>12}{'per state [us]':>16}{'accepted':>10}")
    for name in args.presets:
        robot = StewartRobot.from_preset(name)
        robot.sample_states(10, 0)  # warm-up: the robot's cached views and constants
        times = []
        for seed in range(args.repeats):
            t0 = time.perf_counter()
            poses, _, accels = robot.sample_states(args.n, seed)
            times.append(time.perf_counter() - t0)
            assert poses.shape == (args.n, 4, 4) and np.all(np.isfinite(accels))
        med = statistics.median(times)
        rate = _acceptance(robot, min(args.n, 2000))
        print(f"{name:<18}{med:>12.3f}{med / args.n * 1e6:>16.1f}{rate:>10.0%}")


def _acceptance(robot: StewartRobot, n: int) -> float:
    """The fraction of draws accepted while sampling ``n`` poses: each draw takes six
    numbers from the generator, so the draws are counted by stepping a twin generator
    until it reaches the sampler's state."""
    rng = np.random.default_rng(12345)
    robot.sample_poses(n, rng)
    probe = np.random.default_rng(12345)
    draws = 0
    while probe.bit_generator.state != rng.bit_generator.state and draws <= 1000 * n:
        probe.random(6)
        draws += 1
    return n / max(draws, 1)


if __name__ == "__main__":
    main()
