"""Start-up times of a new process (issue 24, item 4).

Median wall-clock time [s] of whole fresh Python processes (``time.perf_counter`` around
``subprocess.run``, interpreter start-up included), each figure beside its aim:

- ``import stewart_pin`` (aim: under 0.3 s);
- ``stewart-pin --help`` (``python -m stewart_pin.cli --help``; aim: under 0.5 s);
- a new process's first call on a cached robot: ``import stewart_pin``, the preset's robot,
  one ``inverse_dynamics`` call at its home pose with ``backend="auto"`` whose compiled
  library is already in the cache (aim: under 0.5 s in all). The cache is a temporary
  folder filled once before timing (the compilation is not timed).

For reference, a bare ``python -c pass`` is timed too (the interpreter's own start-up),
and each figure's CPU time (user + system, of the child process): on a loaded machine the
wall-clock time includes the time spent waiting for a core, the CPU time does not.
The processes run with this checkout's ``src`` first on ``PYTHONPATH``.

Usage: ``python scripts/bench_startup.py [--runs 7] [--preset simulator] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from stewart_pin.apps.bench_sections import startup_figures


def load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not on every system
        return "unknown"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7, help="fresh processes per figure")
    ap.add_argument("--preset", default="simulator", help="the robot of the first call")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures here")
    a = ap.parse_args()
    load_before = load()
    figures = startup_figures(a.runs, a.preset)
    print(f"start-up, medians of {a.runs} fresh processes ({sys.executable})")
    print(f"load average (1, 5, 15 min): before {load_before}, after {load()}")
    for label, f in figures.items():
        aim = f["aim_s"]
        verdict = ""
        if aim is not None:
            met = "met" if (f["median_s"] or 0.0) < aim else "NOT met"
            verdict = f"  aim < {aim:.1f} s: {met}"
        print(
            f"  {label:62s} {f['median_s']:6.3f} s (min {f['min_s']:.3f}, CPU "
            f"{f['cpu_median_s']:.3f}){verdict}"
        )
    if a.json:
        from stewart_pin._io import write_text_atomic

        write_text_atomic(a.json, json.dumps({"load": load(), "figures": figures}, indent=2))


if __name__ == "__main__":
    main()
