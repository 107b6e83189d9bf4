"""Time the coupled models of a hexapod carrying a payload: reference and compiled.

Medians [us per state] of one-state and batch calls of ``PayloadRobot``'s inverse model
and its direct models (prescribed joint accelerations, and joint torques), on the
reference path (``backend="pinocchio"``: Pinocchio's RNEA and CRBA on the payload, the
hexapod's reference model) and compiled (``backend="compiled"``: the coupled models of
:mod:`stewart_pin.codegen.payload_compiled`, batches on every thread), the hexapod alone,
and ``pin.constraintDynamics`` in the same run: on the hexapod's closed-loop tree
(:func:`stewart_pin.apps.bench.constraint_dynamics_call`) and on the WHOLE tree with the
payload appended (:class:`stewart_pin.check.payload.PayloadTreeSolver`), whose time the
ratio column divides by. The compiled batch tiles the sampled states to
``--compiled-batch`` states.

Usage: ``python scripts/bench_payload.py [--preset simulator] [--payload ur5]
[--batch 1000] [--compiled-batch 100000] [--repeats 200]``.
"""

from __future__ import annotations

import argparse
import os

from stewart_pin.apps.bench_sections import PAYLOAD_YARDSTICK, payload_rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", default="simulator")
    parser.add_argument("--payload", default="ur5")
    parser.add_argument("--batch", type=int, default=1000, help="states of a reference batch")
    parser.add_argument(
        "--compiled-batch", type=int, default=100_000, help="states of a compiled batch"
    )
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    rows, threads = payload_rows(
        args.preset, args.payload, args.batch, args.compiled_batch, args.repeats
    )
    ref = rows[PAYLOAD_YARDSTICK]
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(
        f"{args.preset}+{args.payload}: medians [us per state]; ratio to the whole tree's "
        "constraintDynamics "
        f"(compiled batches on {threads} threads; load average {load})"
    )
    for name, us in rows.items():
        print(f"  {name:<72} {us:10.3f}  {us / ref:8.4f}")


if __name__ == "__main__":
    main()
