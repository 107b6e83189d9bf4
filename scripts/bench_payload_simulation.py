"""Time ``simulate_payload`` per RK4 step on the compiled loop and on the Python loop, in
one run taking turns (issue 24, items 1-2): a robot carrying an arm whose joints sweep
(``JointMotion.sweep(payload, 0.3, 1.0)``), 1 s at ``dt = 1 ms``, forces from a
``ForceTable`` (data, in C) or the ``PayloadComputedTorque`` holding the platform at
``control_period = dt`` (a Python function per step). Medians of ``--repeats`` runs
[us per step], set-up, sampling of the joints and the result's torques included.

Usage: ``python scripts/bench_payload_simulation.py [--preset simulator] [--arm ur5]
[--repeats 5]`` (the arms need example-robot-data).
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.motion.force_tables import ForceTable
from stewart_pin.motion.payload import JointMotion, PayloadComputedTorque, simulate_payload


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="simulator")
    parser.add_argument("--arm", default="ur5")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per row")
    args = parser.parse_args()
    robot = StewartRobot.from_preset(args.preset).with_payload(args.arm)
    joints = JointMotion.sweep(robot.payload, 0.3, 1.0)
    T0 = robot.home_pose
    hold = PayloadComputedTorque(robot, lambda t: (T0, np.zeros(6), np.zeros(6)), joints=joints)
    gamma = robot.inverse_dynamics(T0, np.zeros(6), np.zeros(6), *joints(0.0)).gamma
    table = ForceTable([0.0, 1.0], [gamma, gamma], "linear")
    dt, duration = 1e-3, 1.0
    rows: dict[str, dict[str, Any]] = {}
    for integrator in ("compiled", "python"):
        rows[f"{integrator} loop, ForceTable"] = {"forces": table, "integrator": integrator}
        rows[f"{integrator} loop, PayloadComputedTorque per step"] = {
            "forces": hold,
            "control_period": dt,
            "integrator": integrator,
        }
    for kwargs in rows.values():  # warm-up (compiles on first use)
        simulate_payload(robot, 0.1, joints, dt=dt, **kwargs)
    times: dict[str, list[float]] = {name: [] for name in rows}
    for _ in range(args.repeats):
        for name, kwargs in rows.items():
            t0 = time.perf_counter()
            simulate_payload(robot, duration, joints, dt=dt, **kwargs)
            times[name].append(time.perf_counter() - t0)
    steps = round(duration / dt)
    for name, t in times.items():
        us = statistics.median(t) / steps * 1e6
        print(f"{args.preset}+{args.arm}  {name:45s}  {us:9.1f} us/step")


if __name__ == "__main__":
    main()
