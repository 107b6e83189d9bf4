"""Benchmark the paper's dynamic models against Pinocchio's constrained dynamics.

Median wall-clock time per state [us], all measured in this one run:

- for each architecture (``--architectures``, default the 6-UPS ``simulator``, the
  6-RUS ``rus`` and the 6-PUS ``pus`` presets and ``welded-ups``, six welded six-joint
  chain legs): the default backend (``backend="auto"``:
  the compiled models) of ``StewartRobot.inverse_dynamics`` / ``direct_dynamics``, one
  state per call and batches of 10 000 and 100 000 states (threads stated), beside one
  ``pin.constraintDynamics`` call on that robot's closed-loop tree (the ratios' yardstick);
- for ``--preset``: the reference path of the inverse (IDM) and direct (DDM) models
  (``backend="pinocchio"``: Pinocchio leg dynamics plus the closure layer; rows ``IDM
  single``...), one state per call and a batch of N states per call;
- ``pin.constraintDynamics`` on the 24-dof closed-loop tree (the raw C++ call, with q, v
  and tau prepared beforehand) and the whole reference path of
  ``stewart_pin.check.constrained_dynamics`` (state conversion included) for the direct and
  inverse models;
- the generated models compiled to C (``stewart_pin.codegen.CompiledDynamics``, paper
  section VII), from Python: one state per call, and batches of N = 1, 100, 10 000 and
  1 000 000 states per call (the last streamed as 100 chunks of 10 000; ``--quick`` skips
  it, and times the architectures' batches at ``--batch`` states only);
- MuJoCo's ``mj_forward`` on the MJCF of the same robot, when ``import mujoco`` works (soft
  loop constraints: a timing reference, not an exact solution);
- ``simulate`` per RK4 step at 1 ms on ``--preset`` (:mod:`.bench_simulation`): the
  compiled loop with forces as data, with the computed-torque controller and with a Python
  force function per step, the Python loop, and MuJoCo's own RK4 step (``mj_step``) on the
  same robot, with the ratios to that step and to ``pin.constraintDynamics``;
- the other figures of issue 24, one section each with the issue's aim
  (:mod:`.bench_sections`, the same functions as ``scripts/bench_*.py``): a ``--preset``
  robot carrying a UR5 (reference and compiled, also as ratios to ``pin.constraintDynamics``
  on the whole tree), the first exact-derivatives call in a new process with an empty cache
  (every preset; ``--quick``: ``--preset`` only), a new process's start-up (7 fresh
  processes per figure; ``--quick``: 1), ``sample_states`` on every architecture (10 000
  states; ``--quick``: at most ``--batch``) and the compiled batches of 100 000 states on
  every thread and on one (``--quick``: ``--batch`` states). Fresh processes use a
  temporary cache folder.

Usage: ``stewart-pin bench [--preset simulator] [--architectures simulator,rus,pus,welded-ups]
[--batch 10000] [--repeats 300] [--quick] [--json bench.json]`` (or
``python scripts/bench_dynamics.py`` with the same options).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, cast

import casadi
import numpy as np
import pinocchio as pin

import stewart_pin
from stewart_pin import StewartRobot
from stewart_pin._io import write_text_atomic
from stewart_pin.apps._timing import median_us
from stewart_pin.apps.bench_args import ARCHITECTURES, add_arguments
from stewart_pin.check.constrained_dynamics import (
    constrained_forward_dynamics,
    constraint_dynamics_call,
    reference_actuator_efforts,
    tree_solver,
    tree_state,
)
from stewart_pin.codegen import CompiledDynamics, cost_dict
from stewart_pin.codegen.compiled import BUILD_ENV, CFLAGS, find_compiler, model_cflags
from stewart_pin.description.chain_leg_presets import CHAIN_PRESETS
from stewart_pin.kinematics.chain_legs import idle_home, idle_legs


def machine() -> dict[str, object]:
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "numpy": np.__version__,
        "pinocchio": pin.__version__,
        "stewart_pin": stewart_pin.__version__,
        "casadi": casadi.__version__,  # type: ignore[attr-defined]  # missing from its stubs
        "cpu_model": cpu_model(),
        "load_average_1min": os.getloadavg()[0],
    }


def cpu_model() -> str:
    """The CPU's model name (Linux), else the platform's processor string."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def compiled_rows(
    robot: StewartRobot,
    poses: np.ndarray,
    twists: np.ndarray,
    accels: np.ndarray,
    gammas: np.ndarray,
    repeats: int,
    quick: bool,
) -> tuple[dict[str, float], dict[str, object]]:
    """Rows of the compiled backend (one state, then batches of N states per call)."""
    backend = CompiledDynamics(robot)
    T, V, A, G = poses[0], twists[0], accels[0], gammas[0]
    rows = {
        f"compiled IDM single ({backend.kind})": median_us(
            lambda: backend.inverse_dynamics(T, V, A), max(repeats, 1000)
        ),
        f"compiled DDM single ({backend.kind})": median_us(
            lambda: backend.direct_dynamics(T, V, G), max(repeats, 1000)
        ),
    }
    m = poses.shape[0]
    for n, reps in ((1, max(repeats, 1000)), (100, 200), (10_000, 20)):
        idx = np.arange(n) % m
        P, Vn, An, Gn = poses[idx], twists[idx], accels[idx], gammas[idx]
        rows[f"compiled IDM batch {n}"] = median_us(
            partial(backend.inverse_dynamics, P, Vn, An), reps, n
        )
        rows[f"compiled DDM batch {n}"] = median_us(
            partial(backend.direct_dynamics, P, Vn, Gn), reps, n
        )
    if not quick:
        n, chunk = 1_000_000, 10_000
        idx = np.arange(chunk) % m
        P, Vn, An, Gn = poses[idx], twists[idx], accels[idx], gammas[idx]

        def stream(x: np.ndarray, method: Callable) -> None:
            for _ in method((P, Vn, x) for _ in range(n // chunk)):
                pass

        rows[f"compiled IDM batch {n} (streamed)"] = median_us(
            lambda: stream(An, backend.inverse_dynamics_stream), 3, n
        )
        rows[f"compiled DDM batch {n} (streamed)"] = median_us(
            lambda: stream(Gn, backend.direct_dynamics_stream), 3, n
        )
    info: dict[str, object] = {
        "kind": backend.kind,
        "reason": backend.reason,
        "library": str(backend.library) if backend.library else None,
        "compiler": find_compiler(),
        "cflags": list(model_cflags()),
    }
    return rows, info


def mujoco_rows(
    robot: StewartRobot, T: np.ndarray, G: np.ndarray, repeats: int
) -> dict[str, float]:
    """``mj_forward`` on the robot's MJCF (when MuJoCo imports)."""
    try:
        import mujoco
    except ImportError:
        return {}
    from stewart_pin.formats.mjcf import mujoco_qpos, write_mjcf

    with tempfile.TemporaryDirectory() as tmp:
        path = write_mjcf(robot.description, Path(tmp) / "robot.xml")
        model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    data.qpos[:] = mujoco_qpos(robot.description, T)
    data.ctrl[:] = G
    return {
        f"MuJoCo {mujoco.__version__} mj_forward (soft constraints)": median_us(
            lambda: mujoco.mj_forward(model, data), repeats
        )
    }


#: The operation counts of the JSON: the ideal 6-UPS's models with the 88 base and the 52
#: essential parameters as inputs; general legs' with every value baked in (``numeric``).
_COUNT_KEYS = ("base", "essential", "numeric", "critical_path")
#: The batch sizes of the default-backend rows.
ARCHITECTURE_BATCHES = (10_000, 100_000)


def architecture_rows(
    name: str, repeats: int, batches: tuple[int, ...] = ARCHITECTURE_BATCHES
) -> dict[str, object]:
    """The default backend (``backend="auto"``) of one preset: one state per call and
    batches of ``batches`` states [us per state], and the ``pin.constraintDynamics`` call
    on its tree; with the ratios to that call, the backend that ran and its threads."""
    chain = CHAIN_PRESETS.get(name)  # a chain-leg robot (welded-ups) or a preset
    robot = StewartRobot(chain()) if chain else StewartRobot.from_preset(name)
    poses, twists, accels = robot.sample_states(min(max(batches), 10_000), 0)
    spins = idle_legs(robot.description)  # idle freedoms (R-S-S): at home, at rest

    def idle_of(n: int | None) -> Any:
        if not spins:
            return None
        s = idle_home(robot.description)
        return (s, np.zeros(6)) if n is None else (np.tile(s, (n, 1)), np.zeros((n, 6)))

    one, many = idle_of(None), idle_of(poses.shape[0])
    gammas = robot.inverse_dynamics(poses, twists, accels, idle=many)  # compiles on first use
    T, V, A, G = poses[0], twists[0], accels[0], gammas[0]
    rows = {
        "pin.constraintDynamics (raw call)": median_us(
            constraint_dynamics_call(robot, T, V, G), repeats
        ),
        "IDM single": median_us(
            lambda: robot.inverse_dynamics(T, V, A, idle=one), max(repeats, 1000)
        ),
        "DDM single": median_us(
            lambda: robot.direct_dynamics(T, V, G, idle=one), max(repeats, 1000)
        ),
    }
    for n in batches:
        idx = np.arange(n) % poses.shape[0]
        P, Vn, An, Gn = poses[idx], twists[idx], accels[idx], gammas[idx]
        reps = 20 if n <= 10_000 else 5
        idle = idle_of(n)
        idm = partial(robot.inverse_dynamics, P, Vn, An, idle=idle)
        ddm = partial(robot.direct_dynamics, P, Vn, Gn, idle=idle)
        rows[f"IDM batch {n}"] = median_us(idm, reps, n)
        rows[f"DDM batch {n}"] = median_us(ddm, reps, n)
    from stewart_pin.codegen.compiled import auto_backend
    from stewart_pin.codegen.idle_compiled import auto_idle_backend

    fast: Any = auto_idle_backend(robot) if spins else auto_backend(robot)
    reference = rows["pin.constraintDynamics (raw call)"]
    return {
        "architecture": robot.architecture,
        "backend": "reference (pinocchio)" if fast is None else f"compiled ({fast.kind})",
        "threads": 1 if fast is None else fast.threads,
        "median_us_per_state": rows,
        "ratio_to_pin_constraintDynamics": {k: t / reference for k, t in rows.items()},
    }


def run(
    preset: str,
    batch: int,
    repeats: int,
    quick: bool = False,
    architectures: tuple[str, ...] = ARCHITECTURES,
    progress: Callable[[str], None] | None = None,
) -> dict[str, object]:
    """Every timing, as a JSON-ready dict; ``progress(message)`` is told each stage as it
    starts (a run takes minutes)."""
    say = progress or (lambda message: None)
    from stewart_pin.apps.bench_sections import AIMS, bench_sections, with_ratios

    stages = len(architectures) + 4 + len(AIMS)
    batches = (batch,) if quick else ARCHITECTURE_BATCHES
    arch = {}
    for k, name in enumerate(architectures, 1):
        say(f"[{k}/{stages}] '{name}': the default backend (compiled on first use)")
        arch[name] = architecture_rows(name, repeats, batches)
    base = len(architectures) + 1
    say(f"[{base}/{stages}] '{preset}': the reference path and pin.constraintDynamics")
    robot = StewartRobot.from_preset(preset)  # any architecture
    poses, twists, accels = robot.sample_states(batch, 0)
    gammas = robot.inverse_dynamics(poses, twists, accels, backend="pinocchio")
    T, V, A, G = poses[0], twists[0], accels[0], gammas[0]
    solver = tree_solver(robot)
    q, v = tree_state(robot, T, V)
    batch_repeats = max(3, min(repeats, 5))
    ref = "pinocchio"
    rows = {
        "IDM single": median_us(lambda: robot.inverse_dynamics(T, V, A, backend=ref), repeats),
        "DDM single": median_us(lambda: robot.direct_dynamics(T, V, G, backend=ref), repeats),
        f"IDM batch {batch}": median_us(
            lambda: robot.inverse_dynamics(poses, twists, accels, backend=ref),
            batch_repeats,
            batch,
        ),
        f"DDM batch {batch}": median_us(
            lambda: robot.direct_dynamics(poses, twists, gammas, backend=ref),
            batch_repeats,
            batch,
        ),
        "pin.constraintDynamics (raw call)": median_us(
            constraint_dynamics_call(robot, T, V, G), repeats
        ),
        "pin.rnea on the 24-dof tree (raw call)": median_us(
            lambda: pin.rnea(solver.model, solver.data, q, v, np.zeros(solver.nv)), repeats
        ),
        "constrained forward dynamics (reference path)": median_us(
            lambda: constrained_forward_dynamics(robot, T, V, G), repeats
        ),
        "constrained inverse dynamics (reference path)": median_us(
            lambda: reference_actuator_efforts(robot, T, V, A), repeats
        ),
    }
    say(f"[{base + 1}/{stages}] '{preset}': the compiled models (CompiledDynamics)")
    more, compiled_info = compiled_rows(robot, poses, twists, accels, gammas, repeats, quick)
    rows.update(more)
    say(f"[{base + 2}/{stages}] '{preset}': MuJoCo mj_forward (when MuJoCo imports)")
    rows.update(mujoco_rows(robot, T, G, repeats))
    say(f"[{base + 3}/{stages}] '{preset}': simulate per RK4 step, and MuJoCo's RK4 step")
    from stewart_pin.apps.bench_simulation import simulation_rows

    simulation = {preset: simulation_rows(preset, 3 if quick else 7, quick)}
    reference = rows["pin.constraintDynamics (raw call)"]
    sections = bench_sections(preset, batch, repeats, quick, say, base + 4, stages)
    counts = cost_dict(robot)
    return {
        "preset": preset,
        "batch": batch,
        "repeats": repeats,
        "machine": machine(),
        "architectures": arch,
        "compiled_backend": compiled_info,
        "operation_counts": {  # general legs: no parameter input, every value baked in
            m: {k: counts[m][k] for k in _COUNT_KEYS if k in counts[m]} for m in ("IDM", "DDM")
        },
        "median_us_per_state": rows,
        "ratio_to_pin_constraintDynamics": {k: t / reference for k, t in rows.items()},
        "simulation": simulation,
        "sections": {k: with_ratios(v, reference) for k, v in sections.items()},
    }


def machine_line(info: object) -> str:
    """The machine of a run in one readable line (``machine()``'s dict)."""
    if not isinstance(info, dict):
        return str(info)
    load = info.get("load_average_1min")
    return (
        f"{info.get('cpu_model')} ({info.get('cpus')} CPUs, load {load:.2f}), "
        f"{info.get('platform')}; Python {info.get('python')}, Pinocchio "
        f"{info.get('pinocchio')}, NumPy {info.get('numpy')}, CasADi {info.get('casadi')}"
        if isinstance(load, float)
        else ", ".join(f"{k} {v}" for k, v in info.items())
    )


def table(result: dict[str, object], preset: str) -> list[str]:
    """One table of every timing: the robot, the backend that ran (the default-backend
    rows) or ``every path`` (the ``--preset`` rows), the row, the median time per state
    [us] and its ratio to the ``pin.constraintDynamics`` call on that robot."""
    lines: list[tuple[str, str, str, float, float]] = []
    archs = cast(dict[str, dict[str, object]], result.get("architectures", {}))
    for name, entry in archs.items():
        backend = f"auto: {entry['backend']}, {entry['threads']} thread(s)"
        times = cast(dict[str, float], entry["median_us_per_state"])
        ratios = cast(dict[str, float], entry["ratio_to_pin_constraintDynamics"])
        lines += [(name, backend, row, t, ratios[row]) for row, t in times.items()]
    times = cast(dict[str, float], result["median_us_per_state"])
    ratios = cast(dict[str, float], result["ratio_to_pin_constraintDynamics"])
    lines += [(preset, "every path", row, t, ratios[row]) for row, t in times.items()]
    w_robot = max([5, *(len(r[0]) for r in lines)])
    w_backend = max([7, *(len(r[1]) for r in lines)])
    w_row = max([6, *(len(r[2]) for r in lines)])
    head = (
        f"{'robot':{w_robot}s}  {'backend':{w_backend}s}  {'timing':{w_row}s}  "
        f"{'[us/state]':>10s}  {'/ pin.constraintDynamics':>24s}"
    )
    return [head] + [
        f"{r:{w_robot}s}  {b:{w_backend}s}  {n:{w_row}s}  {t:10.3f}  {q:24.3f}"
        for r, b, n, t, q in lines
    ]


def report(args: argparse.Namespace) -> dict[str, object]:
    """Run the benchmark with progress lines on stderr (unless ``--no-progress``), then
    print one table (and write the JSON) as ``args`` say."""
    archs = getattr(args, "architectures", ARCHITECTURES)

    def progress(message: str) -> None:
        print(f"bench: {message}...", file=sys.stderr, flush=True)

    quiet = getattr(args, "no_progress", False)
    result = run(
        args.preset, args.batch, args.repeats, args.quick, archs, None if quiet else progress
    )
    quick = model_cflags() != CFLAGS  # the figures are not the default build's
    note = f"; models built without optimisation (${BUILD_ENV}=quick)" if quick else ""
    print(f"stewart-pin {stewart_pin.__version__} on {machine_line(result['machine'])}{note}")
    print("\n".join(table(result, args.preset)))
    if result.get("simulation"):
        from stewart_pin.apps.bench_sections import SIMULATION_AIM
        from stewart_pin.apps.bench_simulation import simulation_table

        print()
        print(f"simulation: aim {SIMULATION_AIM}")
        print(
            "\n".join(simulation_table(cast(dict[str, dict[str, object]], result["simulation"])))
        )
    if result.get("sections"):
        from stewart_pin.apps.bench_sections import sections_table

        print("\n".join(sections_table(cast(dict[str, dict[str, object]], result["sections"]))))
    if args.json:
        write_text_atomic(args.json, json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")
    return result


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_arguments(parser)
    report(parser.parse_args())


if __name__ == "__main__":
    main()
