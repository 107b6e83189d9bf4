"""Measure the chain-leg models (any 1-dof joints, ball or weld closures) against the
independent constrained tree (``check.chain_legs_tree.ChainTreeSolver``: 3D and 6D loop
constraints, exact KKT solves).

Prints, for the welded 6-UPS (``welded_ups(seed)``: U(2) + P + spin + U(2) with the upper
U-joint's axes 0.5 mm apart, welded) and the mixed robot (``mixed_chain_robot(seed)``:
three U-P-S ball legs, three welded legs), every link massive and every joint term on,
the largest per-state relative error ``max_k |a_k - b_k| / max_k |b_k|`` of:

- IDM: ``StewartRobot.inverse_dynamics`` against the tree's KKT solve;
- DDM: ``StewartRobot.direct_dynamics`` against ``pin.constraintDynamics`` on the tree,
  for the tree's forces;
- DDM(IDM): the direct model on the inverse model's forces against the acceleration put in.

Run from the repository root (a few seconds)::

    PYTHONPATH=src python scripts/chain_legs_validation.py [--seeds 3] [--states 10]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups
from stewart_pin.kinematics import chain_legs


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def measure(robot: StewartRobot, states: int, seed: int) -> tuple[float, float, float]:
    T, V, A = robot.sample_states(states, rng=seed)
    tree = ChainTreeSolver(robot.description)
    gamma = robot.inverse_dynamics(T, V, A, backend="pinocchio")
    idm = ddm = 0.0
    for n in range(states):
        q = [x[0] for x in chain_legs.inverse_geometry(robot.description, T[n : n + 1], False)]
        ref = tree.inverse_one(T[n], V[n], A[n], q)
        idm = max(idm, _rel(gamma[n], ref))
        acc = robot.direct_dynamics(T[n], V[n], ref, backend="pinocchio")
        ddm = max(ddm, _rel(acc, tree.forward_one(T[n], V[n], ref, q)))
    back = robot.direct_dynamics(T, V, gamma, backend="pinocchio")
    round_trip = max(_rel(back[n], A[n]) for n in range(states))
    return idm, ddm, round_trip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--states", type=int, default=10)
    args = parser.parse_args()
    start = time.perf_counter()
    print("| robots | IDM vs tree | DDM vs tree | DDM(IDM) vs Vdot |")
    print("|---|---|---|---|")
    for name, build in (("welded 6-UPS", welded_ups), ("mixed", mixed_chain_robot)):
        worst = np.zeros(3)
        for seed in range(args.seeds):
            robot = StewartRobot(build(seed=seed))
            worst = np.maximum(worst, measure(robot, args.states, 100 + seed))
        print(f"| {name} | {worst[0]:.1e} | {worst[1]:.1e} | {worst[2]:.1e} |")
    print(f"({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
