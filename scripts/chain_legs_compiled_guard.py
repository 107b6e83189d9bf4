"""Measure the guard of the compiled chain-leg models (``codegen/chain_leg_symbolic.py``):
how many sampled states the unrolled Newton (``NEWTON_ITERATIONS`` steps from each leg's
home configuration) leaves flagged, to be decided by the reference path, and the largest
relative disagreement ``max_k |a_k - b_k| / max_k |b_k|`` of the inverse model on the
states it passes, against the reference path (``backend="pinocchio"``).

For the welded 6-UPS (``welded_ups()``) and the mixed robot (``mixed_chain_robot()``), on
the default sampled states and on a wider workspace (translations up to 0.6 of the
robot's size, rotations up to 0.6 rad). The models run in CasADi's virtual machine (the
same expressions as the compiled C; nothing is compiled).

Run from the repository root (a minute: the reference path takes ~11 ms per state)::

    PYTHONPATH=src python scripts/chain_legs_compiled_guard.py [--states 1000]
"""

from __future__ import annotations

import argparse

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.codegen.chain_leg_symbolic import NEWTON_ITERATIONS, build_chain_models
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups
from stewart_pin.kinematics import chain_legs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=1000)
    n = parser.parse_args().states
    print(f"{NEWTON_ITERATIONS} Newton steps per leg; {n} states per row")
    print(f"{'robot':16s} {'workspace':10s} {'flagged':>8s} {'max rel. error (passed)':>24s}")
    for desc in (welded_ups(), mixed_chain_robot()):
        robot = StewartRobot(desc)
        size = chain_legs.robot_size(desc)
        models, layout = build_chain_models(desc)
        for label, kw in (("default", {}), ("wide", {"translation": 0.6 * size, "rotation": 0.6})):
            T, V, A = robot.sample_states(n, rng=11, **kw)
            gamma, aux = models.idm_guarded(T.reshape(-1, 16).T, V.T, A.T, np.zeros(0))
            gamma, aux = np.array(gamma).T, np.array(aux).T
            passed = np.all(aux[:, layout.idm_slack :] > 0.0, axis=1)
            ref = np.array(
                [robot.inverse_dynamics(T[k], V[k], A[k], backend="pinocchio") for k in range(n)]
            )
            err = np.abs(gamma - ref).max(axis=1) / np.abs(ref).max(axis=1)
            worst = err[passed].max() if passed.any() else float("nan")
            print(f"{desc.name:16s} {label:10s} {int((~passed).sum()):8d} {worst:24.2e}")


if __name__ == "__main__":
    main()
