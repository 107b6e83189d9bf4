"""Benchmark the dynamic models against Pinocchio's constrained dynamics (and MuJoCo).

The same as ``stewart-pin bench``; the measurement code lives in ``stewart_pin.apps.bench``.
Usage: ``python scripts/bench_dynamics.py [--preset simulator] [--batch 10000]
[--repeats 300] [--quick] [--json bench.json]``.
"""

from stewart_pin.apps.bench import main

if __name__ == "__main__":
    main()
