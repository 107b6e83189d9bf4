"""The main demo, what the README's first command runs: the whole workflow on a preset.

description -> URDF, closures, MJCF -> a motion -> inverse dynamics along it ->
computed-torque simulation -> validation against Pinocchio's constrained dynamics ->
plots -> HTML animation, every file in one output folder.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stewart_pin._io import atomic_open
from stewart_pin.check.constrained_dynamics import (
    constrained_forward_dynamics,
    reference_actuator_efforts,
)
from stewart_pin.formats.csv_tables import FORCE_COLUMNS, STATE_COLUMNS, state_table, write_csv
from stewart_pin.formats.robot_files import write_robot_files
from stewart_pin.motion.control import ComputedTorqueController, tracking_errors
from stewart_pin.motion.simulation import simulate
from stewart_pin.motion.trajectories import standard_motion
from stewart_pin.robot import StewartRobot
from stewart_pin.viz.plots import require_matplotlib, save_figures
from stewart_pin.viz.viewer import Viewer, require_meshcat


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-state relative error max|a - b| / max|b| (N,)."""
    return np.abs(a - b).max(axis=1) / np.maximum(np.abs(b).max(axis=1), 1e-300)


def _validation_figure(
    path: Path, t_idm: np.ndarray, err_idm: np.ndarray, t_ddm: np.ndarray, err_ddm: np.ndarray
) -> Path:
    Figure = require_matplotlib()

    fig = Figure(figsize=(8, 3.5), layout="constrained")
    ax = fig.add_subplot()
    ax.semilogy(
        t_idm, np.maximum(err_idm, 1e-17), ".", ms=3, label="inverse model vs constrained ID"
    )
    ax.semilogy(
        t_ddm,
        np.maximum(err_ddm, 1e-17),
        ".",
        ms=3,
        label="direct model vs pin.constraintDynamics",
    )
    ax.axhline(1e-9, color="k", lw=0.8, ls="--", label="test tolerance (1e-9)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("relative difference")
    ax.set_title("The paper's models against Pinocchio's closed-loop tree")
    ax.legend(fontsize=8)
    with atomic_open(path, "wb") as handle:
        fig.savefig(handle, format="png", dpi=110)
    return path


def run_demo(
    preset: str, out: Path, motion_kind: str = "sinusoid", duration: float = 4.0
) -> dict[str, Path]:
    """Run the workflow on ``preset``, writing into ``out``; returns the files by role.

    Raises:
        MissingDependencyError: matplotlib or meshcat (the viz extra) is not installed,
            before any work.
    """
    require_matplotlib()
    require_meshcat()
    robot = StewartRobot.from_preset(preset)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    say = print

    desc = robot.description
    say(f"== robot '{robot.name}': {desc.legs_summary}, platform {desc.platform_inertia[9]:g} kg")
    backend = "auto"  # the compiled models where a C compiler is available (every robot)
    for path in write_robot_files(robot.description, out):
        files[path.name] = path

    motion = standard_motion(robot, motion_kind, duration)
    traj = motion.check_workspace(robot, n_samples=int(100 * motion.duration) + 1)
    table = state_table(traj.times, traj.poses, traj.twists, traj.accels)
    files["trajectory"] = write_csv(out / "trajectory.csv", STATE_COLUMNS, table)
    say(f"== {motion_kind} motion, {motion.duration:g} s at 100 Hz, inside the workspace")

    gamma = robot.inverse_dynamics(traj.poses, traj.twists, traj.accels)
    files["forces"] = write_csv(
        out / "forces.csv", ("t", *FORCE_COLUMNS), np.column_stack([traj.times, gamma])
    )
    say(
        f"== inverse dynamics along it: peak |Gamma| = {np.abs(gamma).max():.4g} "
        f"{desc.effort_unit}"
    )

    T0, V0, _ = motion(0.0)
    ctrl = ComputedTorqueController(robot, motion, backend=backend)
    result = simulate(
        robot, motion.duration, T0, V0, ctrl, dt=1e-3, control_period=1e-3, backend=backend
    )
    files["simulation"] = result.save(out / "simulation.npz")
    pos, rot = (np.linalg.norm(e, axis=1) for e in tracking_errors(motion, result.t, result.poses))
    say(
        f"== computed-torque simulation (1 kHz): tracking error {1e3 * pos.max():.3g} mm, "
        f"{np.degrees(rot.max()):.3g} deg"
    )

    every = max(1, len(traj) // 100)
    ref_gamma = reference_actuator_efforts(
        robot, traj.poses[::every], traj.twists[::every], traj.accels[::every]
    )
    err_idm = _relative(gamma[::every], ref_gamma)
    sim = slice(None, None, max(1, len(result.t) // 100))
    ref_acc = constrained_forward_dynamics(
        robot, result.poses[sim], result.twists[sim], result.gammas[sim]
    )
    acc = robot.direct_dynamics(result.poses[sim], result.twists[sim], result.gammas[sim])
    err_ddm = _relative(acc, ref_acc)
    say(
        f"== against Pinocchio's constrained dynamics: inverse {err_idm.max():.2e}, direct "
        f"{err_ddm.max():.2e} (largest relative difference)"
    )
    files["validation figure"] = _validation_figure(
        out / "validation.png", traj.times[::every], err_idm, result.t[sim], err_ddm
    )
    for name, path in save_figures(result, out / "plots", reference=motion, robot=robot).items():
        files[f"plot {name}"] = path

    files["animation"] = Viewer(robot).export_html(out / "animation.html", result.poses, result.t)
    say(f"\nfiles in {out}/:")
    width = max(len(k) for k in files)
    for role, path in files.items():
        say(f"  {role:<{width}s}  {path}")
    say(f"\nopen the animation: a web browser on file://{files['animation'].resolve()}")
    return files
