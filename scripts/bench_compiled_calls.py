"""Overhead of the compiled backend's calls from Python (issue 14, item 3).

Median wall-clock time [us] per state, all in one run, on one preset (default
``simulator``; also the chain-leg robots ``welded-ups``, ``mixed-chain``):

- ``pin.constraintDynamics`` on the 24-dof closed-loop tree (raw C++ call, q, v, tau
  prepared beforehand): the reference for the ratios;
- the C function itself: ``sp_idm_batch`` / ``sp_ddm_batch`` called through ctypes on
  prepared buffers with one state (the floor of any call from Python) and, per state, on
  1000 states in one thread (the C work alone, the call's cost spread out);
- one state through ``CompiledDynamics.inverse_dynamics`` / ``direct_dynamics`` and through
  the facade ``robot.inverse_dynamics(..., backend="compiled")`` / ``direct_dynamics``;
- the single-state entry ``sp_idm_one`` / ``sp_ddm_one`` called on prepared arguments
  (what ``CompiledDynamics`` calls for one state);
- per state at batches of 10 000 and 100 000 states, with the backend's thread count
  (``STEWART_PIN_THREADS``, default ``os.cpu_count()``) and with one thread; and for the
  batches of 100 000, the process's CPU time per state (all threads: what the batch costs
  whatever the machine's load; on otherwise idle cores the wall time on ``t`` threads
  is about this divided by ``t``, on a loaded machine the slices wait for a CPU).

Usage: ``python scripts/bench_compiled_calls.py [--preset simulator] [--repeats 2000]
[--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from stewart_pin._io import write_text_atomic
from stewart_pin.apps.bench import machine
from stewart_pin.apps.bench_sections import compiled_call_rows


def run(preset: str, repeats: int) -> dict[str, object]:
    rows, kind, threads = compiled_call_rows(preset, repeats)
    reference = rows["pin.constraintDynamics (raw call)"]
    return {
        "preset": preset,
        "repeats": repeats,
        "threads": threads,
        "kind": kind,
        "machine": machine(),
        "median_us_per_state": rows,
        "ratio_to_pin_constraintDynamics": {k: t / reference for k, t in rows.items()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="simulator")
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = run(args.preset, args.repeats)
    print(
        f"preset {args.preset}, compiled backend {result['kind']}, "
        f"{result['threads']} threads, {result['machine']}"
    )
    rows = result["median_us_per_state"]
    ratios = result["ratio_to_pin_constraintDynamics"]
    assert isinstance(rows, dict) and isinstance(ratios, dict)
    print(f"{'median time per state':62s} {'[us]':>8s} {'/ pin.cD':>9s}")
    for name, t in rows.items():
        print(f"{name:62s} {t:8.3f} {ratios[name]:9.3f}")
    if args.json:
        write_text_atomic(args.json, json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
