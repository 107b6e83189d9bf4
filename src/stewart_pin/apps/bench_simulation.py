"""Time ``simulate`` per RK4 step beside MuJoCo's own RK4 step on the same robot.

Median wall-clock time per step [us] of one ``simulate(robot, duration, ...)`` run at
``dt`` (default 1 s at 1 ms: 1000 steps; set-up, the reference's sampling and the result's
assembly included), all measured in this one run:

- ``C RK4, forces as data``: the compiled loop (:mod:`stewart_pin.codegen.simulator`) with
  a :class:`~stewart_pin.motion.force_tables.ForceTable` (linear, 11 rows);
- ``C RK4, forces as data, output_dt = 10 dt``: the same run keeping every tenth state
  (``output_dt = 10 * dt``: the C loop cuts and selects the rows as the Python loop);
- ``C RK4, computed torque per step``: the
  :class:`~stewart_pin.motion.control.ComputedTorqueController` on the ``sinusoid`` motion
  at ``control_period = dt`` (a digital controller: one inverse model per step), the law
  and the reference evaluated in C; ``per stage``: without a control period (the law at
  each of the four RK4 evaluations, the reference at each of the two stage times);
- ``C RK4, Python force function per step``: ``forces=f, control_period=dt`` (the C loop
  runs one period per call, Python gives the next forces);
- ``C RK4 batch of 16 runs``: :func:`~stewart_pin.codegen.simulator.simulate_batch` of 16
  initial twists with the same table, on the compiled models' threads (per run);
- ``Python RK4, forces as data``: ``integrator="python"`` (the compiled direct model, the
  loop in Python), the path before the compiled loop;
- ``MuJoCo RK4 step``: ``mj_step`` with ``opt.integrator = RK4`` and the same ``dt`` on
  the MJCF of the same robot (:func:`stewart_pin.formats.mjcf.write_mjcf`), actuators
  holding the platform (when ``import mujoco`` works);
- ``pin.constraintDynamics (raw call)``: the yardstick of the other bench figures.

Each row's ratio to MuJoCo's step (the aims: at most 1/15 for forces as data, 1/5 for a
Python function per step) and to ``pin.constraintDynamics``.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.codegen.simulator import simulate_batch
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.force_tables import ForceTable
from stewart_pin.motion.simulation import simulate
from stewart_pin.motion.trajectories import standard_motion

#: The yardstick row's name (as in :mod:`.bench`).
YARDSTICK = "pin.constraintDynamics (raw call)"
MUJOCO_ROW = "MuJoCo RK4 step (mj_step)"
#: Runs of the batch row (``simulate_batch``: initial twists drawn at random, one table).
BATCH_RUNS = 16


def _medians_per_step(
    runs: dict[str, Callable[[], Any]], steps: int, repeats: int
) -> dict[str, float]:
    """Median over ``repeats`` runs of each ``runs[name]()`` divided by ``steps`` [us per
    step]. The runs take turns (one of each per round), so that a machine whose load
    changes during the benchmark slows them alike and their ratios hold."""
    for run in runs.values():
        run()  # warm-up (compiles on first use)
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            t0 = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - t0)
    return {name: statistics.median(t) / steps * 1e6 for name, t in times.items()}


def mujoco_rk4_step(robot: StewartRobot, gamma: np.ndarray, dt: float, steps: int) -> Any:
    """A function running ``steps`` RK4 steps of ``dt`` of MuJoCo on the robot's MJCF from
    its home pose with actuator forces ``gamma`` (None when MuJoCo does not import)."""
    try:
        import mujoco
    except ImportError:
        return None
    from stewart_pin.formats.mjcf import mujoco_qpos, write_mjcf

    with tempfile.TemporaryDirectory() as tmp:
        path = write_mjcf(robot.description, Path(tmp) / "robot.xml")
        model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    qpos = mujoco_qpos(robot.description, robot.home_pose)

    def run() -> None:
        mujoco.mj_resetData(model, data)
        data.qpos[:] = qpos
        data.ctrl[:] = gamma
        for _ in range(steps):
            mujoco.mj_step(model, data)

    return run


def simulation_rows(
    name: str, repeats: int = 5, quick: bool = False, duration: float = 1.0, dt: float = 1e-3
) -> dict[str, object]:
    """The rows of one preset (module docstring) as a JSON-ready dict: medians per step
    [us], their ratios to MuJoCo's RK4 step and to ``pin.constraintDynamics``. ``quick``:
    runs of a tenth of ``duration``; the Python loop's row always is (its time per step
    hardly depends on the run's length)."""
    from stewart_pin.apps._timing import median_us
    from stewart_pin.check.constrained_dynamics import constraint_dynamics_call

    robot = StewartRobot.from_preset(name)
    if quick:
        duration /= 10
    steps = round(duration / dt)
    hover = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6), backend="compiled")
    rng = np.random.default_rng(0)
    table = ForceTable(
        np.linspace(0.0, duration, 11),
        hover * (1.0 + 0.002 * rng.standard_normal((11, 6))),
        "linear",
    )
    motion = standard_motion(robot, "sinusoid", duration)
    T0, V0, _ = motion(0.0)
    controller = ComputedTorqueController(robot, motion, backend="compiled")

    def force(t: float, T: np.ndarray, V: np.ndarray) -> np.ndarray:
        return hover

    def sim(integrator: str, length: float = duration, **kwargs: Any) -> Callable[[], Any]:
        return lambda: simulate(
            robot, length, dt=dt, integrator=integrator, backend="compiled", **kwargs
        )

    runs: dict[str, Callable[[], Any]] = {
        "C RK4, forces as data": sim("compiled", forces=table),
        "C RK4, forces as data, output_dt = 10 dt": sim(
            "compiled", forces=table, output_dt=10 * dt
        ),
        "C RK4, computed torque per step": sim(
            "compiled", forces=controller, pose=T0, twist=V0, control_period=dt
        ),
        "C RK4, computed torque per stage": sim("compiled", forces=controller, pose=T0, twist=V0),
        "C RK4, Python force function per step": sim("compiled", forces=force, control_period=dt),
        "Python RK4, forces as data": sim("python", duration / 10, forces=table),
    }
    twists = 1e-3 * rng.standard_normal((BATCH_RUNS, 6))
    batch_row = f"C RK4 batch of {BATCH_RUNS} runs, forces as data (per run)"
    runs[batch_row] = lambda: simulate_batch(
        robot, duration, twists=twists, forces=table, dt=dt, backend="compiled"
    )
    mj = mujoco_rk4_step(robot, hover, dt, steps)
    if mj is not None:
        runs[MUJOCO_ROW] = mj
    python = runs.pop("Python RK4, forces as data")
    rows = _medians_per_step(runs, steps, repeats)
    rows[batch_row] /= BATCH_RUNS
    rows.update(_medians_per_step({"Python RK4, forces as data": python}, steps // 10, 3))
    T = robot.home_pose
    rows[YARDSTICK] = median_us(constraint_dynamics_call(robot, T, np.zeros(6), hover), 300)
    yardstick = rows[YARDSTICK]
    return {
        "duration_s": duration,
        "dt_s": dt,
        "median_us_per_step": rows,
        "ratio_to_mujoco_rk4_step": (
            {k: t / rows[MUJOCO_ROW] for k, t in rows.items()} if MUJOCO_ROW in rows else {}
        ),
        "ratio_to_pin_constraintDynamics": {k: t / yardstick for k, t in rows.items()},
    }


def simulation_table(results: dict[str, dict[str, object]]) -> list[str]:
    """The simulator's rows of every preset: median per step [us] and the two ratios."""
    head = (
        f"{'robot':10s}  {'simulate, per step':50s}  {'[us/step]':>10s}  "
        f"{'/ MuJoCo RK4 step':>17s}  {'/ pin.constraintDynamics':>24s}"
    )
    lines = [head]
    for name, entry in results.items():
        times = entry["median_us_per_step"]
        mj = entry["ratio_to_mujoco_rk4_step"]
        pin_ratio = entry["ratio_to_pin_constraintDynamics"]
        assert isinstance(times, dict) and isinstance(mj, dict) and isinstance(pin_ratio, dict)
        for row, t in times.items():
            to_mj = f"{mj[row]:17.3f}" if row in mj else f"{'-':>17s}"
            lines.append(f"{name:10s}  {row:50s}  {t:10.2f}  {to_mj}  {pin_ratio[row]:24.3f}")
    return lines
