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
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"

FIRST_CALL = """
import numpy as np
import stewart_pin
robot = stewart_pin.StewartRobot.from_preset({preset!r})
gamma = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6))
backend = robot._stewart_pin_auto_backend[1]
assert backend is not None and backend.kind == "compiled" and not backend.compiled_now
assert np.all(np.isfinite(gamma))
"""

#: (label, python arguments, aim [s] or None)
CASES = (
    ("python -c pass", ["-c", "pass"], None),
    ("import stewart_pin", ["-c", "import stewart_pin"], 0.3),
    ("stewart-pin --help", ["-m", "stewart_pin.cli", "--help"], 0.5),
)


def environment(cache: str) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC), env.get("PYTHONPATH")]))
    env["STEWART_PIN_CACHE"] = cache
    env["STEWART_PIN_BACKEND"] = "auto"
    return env


def timed(args: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall-clock and CPU (user + system) seconds of one fresh process ``python *args``
    (which must succeed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu


def run(runs: int, preset: str) -> dict[str, dict[str, float | None]]:
    with tempfile.TemporaryDirectory(prefix="stewart-pin-startup-") as tmp:
        cache = os.path.join(tmp, "cache")
        env = environment(cache)
        first = FIRST_CALL.format(preset=preset)
        # fill the cache (compiles once, not timed): the build's own process
        fill = first.replace("and not backend.compiled_now", "")
        subprocess.run([sys.executable, "-c", fill], env=env, check=True)
        cases = [*CASES, (f"first call on a cached robot ({preset})", ["-c", first], 0.5)]
        out: dict[str, dict[str, float | None]] = {}
        for label, args, aim in cases:
            timed(args, env)  # warm the file-system cache
            wall, cpu = zip(*(timed(args, env) for _ in range(runs)), strict=True)
            out[label] = {
                "median_s": statistics.median(wall),
                "min_s": min(wall),
                "cpu_median_s": statistics.median(cpu),
                "aim_s": aim,
            }
    return out


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
    figures = run(a.runs, a.preset)
    print(f"start-up, medians of {a.runs} fresh processes ({sys.executable})")
    print(f"load average (1, 5, 15 min): before {load_before}, after {load()}")
    for label, f in figures.items():
        aim = f["aim_s"]
        verdict = ""
        if aim is not None:
            met = "met" if (f["median_s"] or 0.0) < aim else "NOT met"
            verdict = f"  aim < {aim:.1f} s: {met}"
        print(
            f"  {label:45s} {f['median_s']:6.3f} s (min {f['min_s']:.3f}, CPU "
            f"{f['cpu_median_s']:.3f}){verdict}"
        )
    if a.json:
        from stewart_pin._io import write_text_atomic

        write_text_atomic(a.json, json.dumps({"load": load(), "figures": figures}, indent=2))


if __name__ == "__main__":
    main()
