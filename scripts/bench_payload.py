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
from functools import partial

import numpy as np
import pinocchio as pin

from stewart_pin import StewartRobot
from stewart_pin.apps.bench import constraint_dynamics_call, median_us
from stewart_pin.check.payload import PayloadTreeSolver
from stewart_pin.codegen.payload_compiled import payload_backend


def whole_tree_call(arm, T, V, G, q, qd, tau):
    """One raw ``pin.constraintDynamics`` on the whole tree (legs, platform, payload)."""
    s = PayloadTreeSolver(arm.robot, arm.payload)
    q_legs = np.asarray(arm.robot.inverse_geometry(T, check_limits=False))
    x, v, _ = s.state(T, V, q_legs, q, qd)
    t = -s.tree.joint_torques(x, v)
    t[s.tree.v_act] += G
    t[s.v_p] += tau
    args = (s.model, s.data, x, v, t, s.tree.cmodels, s.tree.cdatas, s.tree.settings)
    return partial(pin.constraintDynamics, *args)


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
    arm = StewartRobot.from_preset(args.preset).with_payload(args.payload)
    hexapod = arm.robot
    P, V, A, q, qd, qdd = arm.sample_states(args.batch, 0)
    gamma, tau = arm.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio")
    fast = payload_backend(arm, "compiled")  # built (or found in the cache) before timing
    one = (P[0], V[0], A[0], q[0], qd[0], qdd[0])
    reps, breps = args.repeats, max(3, min(args.repeats, 5))
    reps_c = max(reps, 2000)  # a compiled call takes microseconds
    m = -(-args.compiled_batch // args.batch)
    big = [np.ascontiguousarray(np.tile(x, (m,) + (1,) * (x.ndim - 1))[: args.compiled_batch])
           for x in (P, V, A, q, qd, qdd, gamma, tau)]  # fmt: skip
    Pb, Vb, Ab, qb, qdb, qddb, gb, taub = big
    nb = len(Pb)
    rows: dict[str, float] = {
        "pin.constraintDynamics, whole tree with the payload (raw call)": median_us(
            whole_tree_call(arm, P[0], V[0], gamma[0], q[0], qd[0], tau[0]), reps_c
        ),
        "pin.constraintDynamics, hexapod tree (raw call)": median_us(
            constraint_dynamics_call(hexapod, P[0], V[0], gamma[0]), reps_c
        ),
        "hexapod alone, inverse, compiled, one state": median_us(
            lambda: hexapod.inverse_dynamics(*one[:3], backend="compiled"), reps_c
        ),
    }
    for backend, r in (("pinocchio", reps), ("compiled", reps_c)):
        rows[f"payload robot, inverse, {backend}, one state"] = median_us(
            lambda b=backend: arm.inverse_dynamics(*one, backend=b), r
        )
        rows[f"payload robot, direct (prescribed qdd), {backend}, one state"] = median_us(
            lambda b=backend: arm.direct_dynamics(
                P[0], V[0], gamma[0], q[0], qd[0], qdd[0], backend=b
            ),
            r,
        )
        rows[f"payload robot, direct (torques), {backend}, one state"] = median_us(
            lambda b=backend: arm.direct_dynamics(
                P[0], V[0], gamma[0], q[0], qd[0], tau=tau[0], backend=b
            ),
            r,
        )
    n = args.batch
    rows[f"payload robot, inverse, pinocchio, batch of {n}"] = median_us(
        lambda: arm.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio"), breps, n
    )
    rows[f"payload robot, direct (torques), pinocchio, batch of {n}"] = median_us(
        lambda: arm.direct_dynamics(P, V, gamma, q, qd, tau=tau, backend="pinocchio"), breps, n
    )
    creps = max(5, breps)
    rows[f"payload robot, inverse, compiled, batch of {nb}"] = median_us(
        lambda: arm.inverse_dynamics(Pb, Vb, Ab, qb, qdb, qddb, backend="compiled"), creps, nb
    )
    rows[f"payload robot, direct (prescribed qdd), compiled, batch of {nb}"] = median_us(
        lambda: arm.direct_dynamics(Pb, Vb, gb, qb, qdb, qddb, backend="compiled"), creps, nb
    )
    rows[f"payload robot, direct (torques), compiled, batch of {nb}"] = median_us(
        lambda: arm.direct_dynamics(Pb, Vb, gb, qb, qdb, tau=taub, backend="compiled"), creps, nb
    )
    ref = rows["pin.constraintDynamics, whole tree with the payload (raw call)"]
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(
        f"{arm.name}: medians [us per state]; ratio to the whole tree's constraintDynamics "
        f"(compiled batches on {fast.threads} threads; load average {load})"
    )
    for name, us in rows.items():
        print(f"  {name:<72} {us:10.3f}  {us / ref:8.4f}")


if __name__ == "__main__":
    main()
