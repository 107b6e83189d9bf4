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
- DDM(IDM): the direct model on the inverse model's forces against the acceleration put in;
- for the 6-RSS (``rss_robot(symmetric)``: each rod's spin about its ball-to-ball line an
  idle joint, part of the state: random spin angles and rates), the same through
  ``robot.chain_dynamics`` with ``idle=``, the spin accelerations included (``spin``
  column: the inverse model's against the tree's KKT unknowns, the direct model's against
  ``pin.constraintDynamics``'s).

Run from the repository root (a few seconds)::

    PYTHONPATH=src python scripts/chain_legs_validation.py [--seeds 3] [--states 10]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, rss_robot, welded_ups
from stewart_pin.kinematics import chain_legs


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def measure(robot: StewartRobot, states: int, seed: int) -> tuple[float, float, float, float]:
    T, V, A = robot.sample_states(states, rng=seed)
    desc = robot.description
    tree = ChainTreeSolver(desc)
    rng = np.random.default_rng(seed)
    idle = None
    spin_q = spin_v = None
    if any(leg.idle_joint is not None for leg in desc.chain_legs or ()):
        spin_q, spin_v = rng.uniform(-1, 1, (states, 6)), rng.uniform(-5, 5, (states, 6))
        idle = (spin_q, spin_v)
    dyn = robot.chain_dynamics
    res = dyn.inverse_dynamics(T, V, A, details=True, idle=idle)
    qs = chain_legs.inverse_geometry(desc, T, False, spin_q)
    idm = ddm = spin = 0.0
    for n in range(states):
        q = [x[n] for x in qs]
        rate = None if spin_v is None else spin_v[n]
        ref, ref_sigma = tree.inverse_idle_one(T[n], V[n], A[n], q, rate)
        idm = max(idm, _rel(res.gamma[n], ref))
        one = None if idle is None else (spin_q[n], spin_v[n])  # type: ignore[index]
        acc, sigma = dyn.direct_dynamics_idle(T[n], V[n], ref, idle=one)
        # the tree at the configuration the direct model solved (two solves of the same
        # pose from different starts differ by ~5e-14 rad on the 6-RSS, which its
        # direct model amplifies to ~1e-10: docs/legs.md, "Validation")
        q_ddm = [s.q[0] for s in dyn.cartesian_dynamics(T[n], V[n], idle=one).legs]
        ref_acc, ref_acc_sigma = tree.forward_idle_one(T[n], V[n], ref, q_ddm, rate)
        ddm = max(ddm, _rel(acc, ref_acc))
        if idle is not None:
            spin = max(spin, _rel(res.idle_accel[n], ref_sigma), _rel(sigma, ref_acc_sigma))
    back = dyn.direct_dynamics(T, V, res.gamma, idle=idle)
    round_trip = max(_rel(back[n], A[n]) for n in range(states))
    return idm, ddm, round_trip, spin


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--states", type=int, default=10)
    args = parser.parse_args()
    start = time.perf_counter()
    print("| robots | IDM vs tree | DDM vs tree | DDM(IDM) vs Vdot | spin accelerations |")
    print("|---|---|---|---|---|")
    builds = {
        "welded 6-UPS": welded_ups,
        "mixed": mixed_chain_robot,
        "6-RSS, symmetric rods": lambda seed: rss_robot(True, seed=seed),
        "6-RSS, asymmetric rods": lambda seed: rss_robot(False, seed=seed),
    }
    for name, build in builds.items():
        worst = np.zeros(4)
        for seed in range(args.seeds):
            robot = StewartRobot(build(seed=seed))
            worst = np.maximum(worst, measure(robot, args.states, 100 + seed))
        spin = f"{worst[3]:.1e}" if "RSS" in name else "-"
        print(f"| {name} | {worst[0]:.1e} | {worst[1]:.1e} | {worst[2]:.1e} | {spin} |")
    print(f"({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
