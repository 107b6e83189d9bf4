"""Time the coupled models of a hexapod carrying a payload.

Medians [us per state] of one-state and batch calls of ``PayloadRobot`` (the inverse
model with the hexapod's share on the reference and, for the ideal 6-UPS, the compiled
backend; the direct models, prescribed and torque-driven), the hexapod alone, and
``pin.constraintDynamics`` on the closed-loop tree in the same run (the ratio column,
:func:`stewart_pin.apps.bench.constraint_dynamics_call`), plus that call on the WHOLE tree
with the payload appended (:class:`stewart_pin.check.payload.PayloadTreeSolver`).

Usage: ``python scripts/bench_payload.py [--preset simulator] [--payload ur5]
[--batch 1000] [--repeats 200]``.
"""

from __future__ import annotations

import argparse
from functools import partial

import numpy as np
import pinocchio as pin

from stewart_pin import StewartRobot
from stewart_pin.apps.bench import constraint_dynamics_call, median_us
from stewart_pin.check.payload import PayloadTreeSolver


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
    parser.add_argument("--batch", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    arm = StewartRobot.from_preset(args.preset).with_payload(args.payload)
    hexapod = arm.robot
    P, V, A, q, qd, qdd = arm.sample_states(args.batch, 0)
    gamma, tau = arm.inverse_dynamics(P, V, A, q, qd, qdd)
    one = (P[0], V[0], A[0], q[0], qd[0], qdd[0])
    reps, breps = args.repeats, max(3, min(args.repeats, 5))
    rows = {
        "pin.constraintDynamics, hexapod tree (raw call)": median_us(
            constraint_dynamics_call(hexapod, P[0], V[0], gamma[0]), reps
        )
        if hexapod.is_ideal_ups
        else float("nan"),
        "pin.constraintDynamics, whole tree with the payload (raw call)": median_us(
            whole_tree_call(arm, P[0], V[0], gamma[0], q[0], qd[0], tau[0]), reps
        ),
        "hexapod alone, inverse, one state": median_us(
            lambda: hexapod.inverse_dynamics(*one[:3]), reps
        ),
        "payload robot, inverse, one state": median_us(lambda: arm.inverse_dynamics(*one), reps),
        "payload robot, direct (prescribed qdd), one state": median_us(
            lambda: arm.direct_dynamics(P[0], V[0], gamma[0], q[0], qd[0], qdd[0]), reps
        ),
        "payload robot, direct (torques), one state": median_us(
            lambda: arm.direct_dynamics(P[0], V[0], gamma[0], q[0], qd[0], tau=tau[0]), reps
        ),
        f"payload robot, inverse, batch of {args.batch}": median_us(
            lambda: arm.inverse_dynamics(P, V, A, q, qd, qdd), breps, args.batch
        ),
        f"payload robot, direct (torques), batch of {args.batch}": median_us(
            lambda: arm.direct_dynamics(P, V, gamma, q, qd, tau=tau), breps, args.batch
        ),
    }
    if hexapod.is_ideal_ups:
        rows["payload robot, inverse, hexapod share compiled, one state"] = median_us(
            lambda: arm.inverse_dynamics(*one, backend="compiled"), reps
        )
    ref = rows["pin.constraintDynamics, whole tree with the payload (raw call)"]
    print(f"{arm.name}: medians [us per state]; ratio to the whole tree's constraintDynamics")
    for name, us in rows.items():
        print(f"  {name:<66} {us:10.1f}  {us / ref:7.2f}")


if __name__ == "__main__":
    main()
