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
import ctypes
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin._io import write_text_atomic
from stewart_pin.apps.bench import constraint_dynamics_call, machine, median_us
from stewart_pin.codegen import CompiledDynamics, compiled_backend
from stewart_pin.description.chain_leg_presets import CHAIN_PRESETS


def raw_call(
    backend: object, which: str, n: int, T: np.ndarray, V: np.ndarray, X: np.ndarray
) -> tuple[object, tuple[object, ...]]:
    """The C batch function and its arguments for ``n`` states (buffers prepared)."""
    fn = backend._c[which]  # type: ignore[attr-defined]
    out = np.empty((n, 6))
    flags = np.empty(n, dtype=np.int32)
    chi = backend.base_values  # type: ignore[attr-defined]
    keep = (T, V, X, out, flags, chi)
    args = (
        n,
        T.ctypes.data,
        V.ctypes.data,
        X.ctypes.data,
        chi.ctypes.data,
        backend.robot.max_condition,
        out.ctypes.data,
        flags.ctypes.data,
    )  # type: ignore[attr-defined]
    return fn, (args, keep)


def median_cpu_us(fn: Callable[[], object], repeats: int, per: int) -> float:
    """Median over ``repeats`` calls of ``fn`` of the process's CPU time (all its threads),
    divided by ``per`` states per call [us]."""
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times) / per * 1e6


def run(preset: str, repeats: int) -> dict[str, object]:
    chain = CHAIN_PRESETS.get(preset)  # a chain-leg robot (welded-ups) or a preset
    robot = StewartRobot(chain()) if chain else StewartRobot.from_preset(preset)
    big = 100_000
    poses, twists, accels = robot.sample_states(2000, 0)  # any architecture
    idx = np.arange(big) % poses.shape[0]
    P, V, A = (np.ascontiguousarray(a[idx]) for a in (poses, twists, accels))
    backend = compiled_backend(robot)
    serial = CompiledDynamics(robot, threads=1)
    G = backend.inverse_dynamics(P, V, A)
    T0, V0, A0, G0 = P[0].copy(), V[0].copy(), A[0].copy(), G[0].copy()
    rows: dict[str, float] = {}
    rows["pin.constraintDynamics (raw call)"] = median_us(
        constraint_dynamics_call(robot, T0, V0, G0), repeats
    )
    for which, X, X0 in (("idm", A, A0), ("ddm", G, G0)):
        name = which.upper()
        for n, label in ((1, "1 state"), (1000, "1000 states, per state")):
            fn, (args, _keep) = raw_call(backend, which, n, P[:n], V[:n], X[:n])
            rows[f"{name} C function via ctypes, {label}"] = median_us(
                lambda fn=fn, args=args: fn(*args), repeats if n == 1 else 200, n
            )
        one = backend._c_one[which]  # type: ignore[attr-defined]
        block = T0.tobytes() + V0.tobytes() + X0.tobytes()
        args1 = (block, backend._chi_ptr, ctypes.c_double(1e4), backend._one_out_ptr)  # type: ignore[attr-defined]
        rows[f"{name} single-state C entry via ctypes (prepared arguments)"] = median_us(
            lambda f=one, a=args1: f(*a), repeats
        )
        method = backend.inverse_dynamics if which == "idm" else backend.direct_dynamics
        facade = robot.inverse_dynamics if which == "idm" else robot.direct_dynamics
        rows[f"{name} single, CompiledDynamics"] = median_us(
            lambda m=method, x=X0: m(T0, V0, x), repeats
        )
        rows[f"{name} single, robot facade backend='compiled'"] = median_us(
            lambda f=facade, x=X0: f(T0, V0, x, backend="compiled"), repeats
        )
        rows[f"{name} single, robot facade default backend='auto'"] = median_us(
            lambda f=facade, x=X0: f(T0, V0, x), repeats
        )
        for n, reps in ((10_000, 50), (100_000, 10)):
            for b in (backend, serial):
                m = b.inverse_dynamics if which == "idm" else b.direct_dynamics
                rows[f"{name} batch {n}, per state ({b.threads} threads)"] = median_us(
                    lambda m=m, n=n, x=X: m(P[:n], V[:n], x[:n]), reps, n
                )
                if n == big:
                    rows[f"{name} batch {n}, CPU time per state ({b.threads} threads)"] = (
                        median_cpu_us(lambda m=m, n=n, x=X: m(P[:n], V[:n], x[:n]), reps, n)
                    )
    reference = rows["pin.constraintDynamics (raw call)"]
    return {
        "preset": preset,
        "repeats": repeats,
        "threads": getattr(backend, "threads", 1),
        "kind": backend.kind,
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
