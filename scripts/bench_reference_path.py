"""Time the reference (``backend="pinocchio"``) models and check them against a saved
run.

Medians [us per state] of one-state and batch IDM / DDM through ``StewartRobot`` on a
preset, beside ``pin.constraintDynamics`` on the closed-loop tree in the same run (the
ratio column), with the helpers of :mod:`stewart_pin.apps.bench`.

``--save FILE`` writes the IDM and DDM outputs of 200 random states of the 6-UPS
simulator, desktop, paper and random-1 presets and of the general-leg ``ups-offset``,
``rus``, ``pus`` and ``random-custom-0`` (``.npz``); ``--compare FILE`` recomputes them and
prints the largest relative difference to the saved ones (to show a rewrite changes
nothing but round-off).

Usage: ``python scripts/bench_reference_path.py [--preset simulator] [--batch 10000]
[--repeats 300] [--save before.npz | --compare before.npz]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.apps.bench import constraint_dynamics_call, median_us

PRESETS = (
    "simulator",
    "desktop",
    "paper",
    "random-1",
    "ups-offset",
    "rus",
    "pus",
    "random-custom-0",
)
REF = "pinocchio"  # the reference path (the default backend="auto" is the compiled one)


def timings(preset: str, batch: int, repeats: int) -> dict[str, float]:
    robot = StewartRobot.from_preset(preset)
    poses, twists, accels = robot.sample_states(batch, 0)
    gammas = robot.inverse_dynamics(poses, twists, accels, backend=REF)
    T, V, A, G = poses[0], twists[0], accels[0], gammas[0]
    reps = max(3, min(repeats, 5))
    return {
        "pin.constraintDynamics (raw call)": median_us(
            constraint_dynamics_call(robot, T, V, G), repeats
        ),
        "IDM single": median_us(lambda: robot.inverse_dynamics(T, V, A, backend=REF), repeats),
        "DDM single": median_us(lambda: robot.direct_dynamics(T, V, G, backend=REF), repeats),
        f"IDM batch {batch}": median_us(
            lambda: robot.inverse_dynamics(poses, twists, accels, backend=REF), reps, batch
        ),
        f"DDM batch {batch}": median_us(
            lambda: robot.direct_dynamics(poses, twists, gammas, backend=REF), reps, batch
        ),
    }


def outputs() -> dict[str, np.ndarray]:
    """IDM and DDM of 200 random states per preset (the DDM given the IDM's forces plus a
    perturbation, so that it does not merely return the accelerations)."""
    out = {}
    rng = np.random.default_rng(7)
    for name in PRESETS:
        robot = StewartRobot.from_preset(name)
        poses, twists, accels = robot.sample_states(200, 3)
        gammas = robot.inverse_dynamics(poses, twists, accels, backend=REF)
        gammas2 = gammas + rng.normal(size=gammas.shape) * np.abs(gammas).mean()
        out[f"{name}/idm"] = gammas
        out[f"{name}/idm1"] = np.array(
            [
                robot.inverse_dynamics(*s, backend=REF)
                for s in zip(poses, twists, accels, strict=True)
            ]
        )
        out[f"{name}/ddm"] = robot.direct_dynamics(poses, twists, gammas2, backend=REF)
        out[f"{name}/ddm1"] = np.array(
            [
                robot.direct_dynamics(*s, backend=REF)
                for s in zip(poses, twists, gammas2, strict=True)
            ]
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="simulator")
    parser.add_argument("--batch", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=300)
    parser.add_argument("--save", type=Path, help="write the outputs of 200 states here")
    parser.add_argument("--compare", type=Path, help="compare the outputs with this file")
    args = parser.parse_args()
    if args.save or args.compare:
        now = outputs()
        if args.save:
            np.savez(args.save, **now)  # a measurement artefact, not a project file
            print(f"wrote {args.save}")
        if args.compare:
            before = np.load(args.compare)
            for key, x in now.items():
                y = before[key]
                rel = np.max(np.abs(x - y)) / np.max(np.abs(y))
                print(f"{key:24s} max |after - before| / max |before| = {rel:.2e}")
        return
    rows = timings(args.preset, args.batch, args.repeats)
    ref = rows["pin.constraintDynamics (raw call)"]
    print(
        f"preset '{args.preset}', median time per state [us] and ratio to pin.constraintDynamics"
    )
    for name, t in rows.items():
        print(f"{name:40s} {t:10.2f} {t / ref:8.2f}")


if __name__ == "__main__":
    main()
