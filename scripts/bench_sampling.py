"""Time ``StewartRobot.sample_states`` on every leg architecture (issue 24, item 5).

Median wall-clock time [s] of ``robot.sample_states(n, seed)`` (default n = 10 000) per
preset: the ideal 6-UPS ``simulator`` and the general legs ``ups-offset``, ``rus``,
``pus``, a random custom robot (``random-custom-0``) and the chain legs ``welded-ups`` and
``mixed-chain``, with the fraction of draws the
sampler accepted (the rest leave a limit or come too near a singularity). The aim is
under 1 s for 10 000 states on every architecture. The robot is built (and its caches
warmed by one small call) before timing.

Usage: ``python scripts/bench_sampling.py [--n 10000] [--repeats 3] [--presets simulator rus]``.
"""

from __future__ import annotations

import argparse

from stewart_pin.apps.bench_sections import (
    SAMPLING_PRESETS,
    acceptance,
    bench_robot,
    sampling_seconds,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000, help="states per call")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per preset")
    parser.add_argument("--presets", nargs="+", default=list(SAMPLING_PRESETS))
    args = parser.parse_args()
    print(f"{'preset':<18}{'median [s]':>12}{'per state [us]':>16}{'accepted':>10}")
    for name in args.presets:
        med = sampling_seconds(name, args.n, args.repeats)
        rate = acceptance(bench_robot(name), min(args.n, 2000))
        print(f"{name:<18}{med:>12.3f}{med / args.n * 1e6:>16.1f}{rate:>10.0%}")


if __name__ == "__main__":
    main()
