"""``simulate``, ``animate``, ``view`` and ``demo``."""

from __future__ import annotations

import argparse
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from stewart_pin._argtypes import BYTES_PER_ANIMATION_SECOND, duration_within_memory
from stewart_pin.cli._common import (
    PRESET_HELP,
    add_payload_args,
    add_progress_arg,
    add_robot_args,
    check_output,
    finite_float,
    fraction_of_one,
    is_stdout,
    payload_robot_from_args,
    positive_finite_float,
    progress_bar,
    report_stream,
    robot_from_args,
    written,
)
from stewart_pin.exceptions import (
    InputError,
    SimulationError,
    SimulationInterrupted,
    StewartPinError,
)
from stewart_pin.motion.trajectories import MOTION_KINDS

if TYPE_CHECKING:  # imported where used, to keep the command quick to start
    from stewart_pin.motion.simulation import SimulationResult
    from stewart_pin.robot import StewartRobot


def partial_path(out: Path) -> Path:
    """Where ``simulate`` saves the result of a run that stopped early:
    ``<stem>.partial<suffix>`` beside the requested output."""
    return out.with_name(f"{out.stem}.partial{out.suffix}")


def _save_states(result: SimulationResult, out: Path) -> str:
    """Save a run's accepted states ``result`` beside ``out`` (:func:`partial_path`,
    atomically as every write); what was done, as a clause of the one-line message."""
    if len(result.t) == 0:
        return "no state was accepted, nothing saved"
    if is_stdout(out):
        return "nothing written to standard output (-o -): give a file name to keep them"
    path = partial_path(out)
    try:
        result.save(path)
    except (OSError, StewartPinError) as e:
        return f"the partial result could not be saved to {path}: {e}"
    return (
        f"partial result ({len(result.t)} samples, t = {result.t[0]:g} to "
        f"{result.t[-1]:.6g} s) saved to {path}"
    )


def _save_partial(error: SimulationError, out: Path) -> SimulationError:
    """Save a stopped run's accepted states beside ``out``; the error to report, naming
    the file (one line)."""
    result = cast("SimulationResult", error.result)  # simulate attaches its partial result
    return SimulationError(f"{error}; {_save_states(result, out)}", error.time, result)


def _save_interrupted(interrupt: SimulationInterrupted, out: Path) -> KeyboardInterrupt:
    """Save an interrupted run's accepted states beside ``out``; the interrupt to raise
    again, naming the file (the command line prints it, one line, and exits with 130)."""
    result = cast("SimulationResult", interrupt.result)
    return KeyboardInterrupt(f"{interrupt}; {_save_states(result, out)}")


def _simulate(args: argparse.Namespace) -> int:
    from stewart_pin.dynamics.regressor import standard_parameters, with_standard_parameters
    from stewart_pin.motion.control import (
        ComputedTorqueController,
        check_backend,
        tracking_errors,
    )
    from stewart_pin.motion.simulation import simulate
    from stewart_pin.motion.trajectories import standard_motion

    out = check_output(args.output, (".npz", ".csv"), stdout=True)
    if is_stdout(out) and args.payload:
        raise InputError(
            "simulate --payload writes two files (the states and the payload's joints "
            "beside them): -o - (standard output) takes one table; give a file name"
        )
    if args.plots and Path(args.plots).exists() and not Path(args.plots).is_dir():
        raise InputError(f"--plots {args.plots} is a file; give a folder for the PNG plots")
    if args.plots:  # the viz extra before the run, not after it
        from stewart_pin.viz.plots import require_matplotlib

        require_matplotlib()
    robot = robot_from_args(args)
    check_backend(robot, args.backend, "simulate")  # before the run starts, one line
    carrier = payload_robot_from_args(args, robot)
    if carrier is not None:
        return _simulate_payload(args, carrier, out)
    if args.motion == "free":
        forces, motion, duration = None, None, args.duration
        start: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
    else:
        motion = standard_motion(robot, args.motion, args.duration)
        motion.check_workspace(robot)
        model = robot
        if args.model_error:  # every standard parameter, joint terms included
            chi = standard_parameters(robot.description) * (1.0 + args.model_error)
            model = type(robot)(with_standard_parameters(robot.description, chi))
        forces = ComputedTorqueController(model, motion, backend=args.backend)
        duration = motion.duration
        T0, V0, _ = motion(0.0)
        start = (T0, V0)
    try:
        with progress_bar(duration, "s", not args.no_progress) as bar:
            result = simulate(
                robot,
                duration,
                *start,
                forces=forces,
                method=args.method,
                dt=args.dt,
                control_period=args.control_period if forces is not None else None,
                progress=bar.to,
                backend=args.backend,
                integrator=args.integrator,
            )
    except SimulationError as e:
        raise _save_partial(e, out) from e
    except SimulationInterrupted as e:
        raise _save_interrupted(e, out) from e
    with written(out, "simulation.csv") as path:
        result.save(path)
    lines = [f"simulated {duration:g} s of '{robot.name}' ({args.motion}, {args.method}): {out}"]
    if motion is not None:
        pos, rot = (
            np.linalg.norm(e, axis=1) for e in tracking_errors(motion, result.t, result.poses)
        )
        lines.append(
            f"tracking error: max {1e3 * pos.max():.4g} mm, {np.degrees(rot.max()):.4g} deg"
        )
    desc = robot.description
    what = desc.actuator_position_name
    lines.append(
        f"peak |Gamma| {np.abs(result.gammas).max():.5g} {desc.effort_unit}; {what} "
        f"[{result.lengths.min():.5g}, {result.lengths.max():.5g}] {desc.position_unit}"
    )
    if args.plots:
        from stewart_pin.viz.plots import save_figures

        paths = save_figures(result, Path(args.plots), reference=motion, robot=robot)
        lines.append("plots: " + ", ".join(str(p) for p in paths.values()))
    print("\n".join(lines), file=report_stream(out))
    return 0


#: The payload's joint sweep of the command line: the fraction of each joint's half-range
#: and the period [s] (``--payload-fraction``, ``--payload-period``).
PAYLOAD_FRACTION = 0.25
PAYLOAD_PERIOD = 1.0


def _sweep(args: argparse.Namespace) -> tuple[float, float]:
    """``(fraction, period)`` of ``--payload-fraction`` / ``--payload-period``."""
    fraction = PAYLOAD_FRACTION if args.payload_fraction is None else args.payload_fraction
    period = PAYLOAD_PERIOD if args.payload_period is None else args.payload_period
    return fraction, period


def _payload_joints(args: argparse.Namespace, carrier: Any, duration: float) -> Any:
    """The payload's joint motion of the command line: every joint sweeping a quarter of
    its room about its home posture (``JointMotion.sweep``)."""
    from stewart_pin.motion.payload import JointMotion

    return JointMotion.sweep(carrier.payload, *_sweep(args), duration)


def _simulate_payload(args: argparse.Namespace, carrier: Any, out: Path) -> int:
    """``simulate --payload``: the hexapod under computed torque with the coupled inverse
    model while the payload runs its own joint motion (prescribed)."""
    from stewart_pin.motion.control import tracking_errors
    from stewart_pin.motion.payload import (
        PayloadComputedTorque,
        payload_path,
        simulate_payload,
    )
    from stewart_pin.motion.trajectories import standard_motion

    robot = carrier.robot
    if args.model_error:
        raise InputError("simulate --payload takes no --model-error (the model is exact)")
    if args.motion == "free":
        motion, duration = None, args.duration
        start: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
    else:
        motion = standard_motion(robot, args.motion, args.duration)
        motion.check_workspace(robot)
        duration = motion.duration
        T0, V0, _ = motion(0.0)
        start = (T0, V0)
    joints = _payload_joints(args, carrier, duration)
    forces = (
        None
        if motion is None
        else PayloadComputedTorque(carrier, motion, backend=args.backend, joints=joints)
    )
    side = payload_path(out)
    try:
        with progress_bar(duration, "s", not args.no_progress) as bar:
            sim = simulate_payload(
                carrier,
                duration,
                joints,
                *start,
                forces=forces,
                method=args.method,
                dt=args.dt,
                control_period=args.control_period if forces is not None else None,
                progress=bar.to,
                integrator=args.integrator,
            )
    except SimulationError as e:
        raise _save_partial(e, out) from e
    except SimulationInterrupted as e:
        raise _save_interrupted(e, out) from e
    sim.save(out)
    fraction, period = _sweep(args)
    lines = [
        f"simulated {duration:g} s of '{carrier.name}' ({args.motion}, {args.method}; the "
        f"payload's {carrier.nv} joints sweeping {fraction:g} of their range "
        f"every {period:g} s): {out}, payload joints in {side}"
    ]
    if motion is not None:
        pos, rot = (
            np.linalg.norm(e, axis=1)
            for e in tracking_errors(motion, sim.result.t, sim.result.poses)
        )
        lines.append(
            f"tracking error: max {1e3 * pos.max():.4g} mm, {np.degrees(rot.max()):.4g} deg"
        )
    lines.append(
        f"peak |Gamma| {np.abs(sim.result.gammas).max():.5g} {robot.description.effort_unit}; "
        f"peak |payload torque| {np.abs(sim.tau).max(initial=0.0):.5g} (N m, N for slides)"
    )
    if args.plots:
        from stewart_pin.viz.plots import save_figures

        paths = save_figures(
            sim.result,
            Path(args.plots),
            reference=motion,
            effort_unit=robot.description.effort_unit,
        )
        lines.append("plots: " + ", ".join(str(p) for p in paths.values()))
    print("\n".join(lines), file=report_stream(out))
    return 0


def _motion_samples(
    args: argparse.Namespace, robot: StewartRobot
) -> tuple[np.ndarray, np.ndarray]:
    """``(poses, times)`` of a simulation result file, or of a standard motion."""
    from stewart_pin.motion.simulation import SimulationResult
    from stewart_pin.motion.trajectories import standard_motion

    if args.result:
        result = SimulationResult.load(args.result)
        return result.poses, result.t
    motion = standard_motion(robot, args.motion, args.duration)
    traj = motion.check_workspace(robot, n_samples=max(2, int(motion.duration * 60) + 1))
    return traj.poses, traj.times


def _payload_samples(
    args: argparse.Namespace, carrier: Any, times: np.ndarray
) -> np.ndarray | None:
    """The payload's configurations at ``times``: from the result's payload sidecar, or
    the command line's joint motion; ``None`` (home, held) for a result without one."""
    from stewart_pin.motion.payload import PayloadSimulation, payload_path

    if args.result:
        if not payload_path(args.result).is_file():
            print(f"note: no {payload_path(args.result)}: the payload is drawn at home")
            return None
        t, q = PayloadSimulation.load_joints(args.result, carrier.payload)
        if len(t) != len(times) or not np.allclose(t, times, rtol=0, atol=1e-12):
            raise InputError(
                f"{payload_path(args.result)} does not match {args.result}: another run's"
            )
        return q
    joints = _payload_joints(args, carrier, float(times[-1] - times[0]) or 1.0)
    return joints.sample(times - times[0])[0]


def _animate(args: argparse.Namespace) -> int:
    from stewart_pin.viz.viewer import Viewer, require_meshcat

    require_meshcat()  # the viz extra before the work
    path = check_output(args.output, (".html", ".htm"), [args.result])
    robot = robot_from_args(args)
    carrier = payload_robot_from_args(args, robot)
    poses, times = _motion_samples(args, robot)
    if carrier is not None:
        from stewart_pin.viz.payload_scene import PayloadViewer

        q = _payload_samples(args, carrier, times)
        viewer = PayloadViewer(carrier, meshes=not args.payload_shapes)
        out = viewer.export_html(path, poses, times, q, fps=args.fps)
    else:
        out = Viewer(robot).export_html(path, poses, times, fps=args.fps)
    print(f"wrote {out} ({times[-1] - times[0]:.3g} s of motion): open it in a web browser")
    return 0


def _view(args: argparse.Namespace) -> int:
    import time

    from stewart_pin.viz.payload_scene import PayloadViewer
    from stewart_pin.viz.viewer import Viewer, require_meshcat

    require_meshcat()  # the viz extra before the work
    robot = robot_from_args(args)
    carrier = payload_robot_from_args(args, robot)
    if carrier is not None:
        viewer: Viewer = PayloadViewer(carrier, meshes=not args.payload_shapes)
    else:
        viewer = Viewer(robot)
    with _exit_on_hangup(), viewer:
        url = viewer.start(open=args.open)
        print(f"meshcat viewer at {url} (local only); Ctrl-C to stop", flush=True)
        viewer.display(robot.home_pose)
        if args.result or args.motion != "none":
            if args.motion == "none":
                args.motion = "sinusoid"
            poses, times = _motion_samples(args, robot)
            if not args.no_wait:
                viewer.wait()
            if isinstance(viewer, PayloadViewer):
                viewer.play(poses, times, _payload_samples(args, carrier, times))
            else:
                viewer.play(poses, times)
        if args.no_wait:
            return 0
        try:
            while True:
                time.sleep(0.5)
        except KeyboardInterrupt:
            print("stopped")
    return 0


@contextmanager
def _exit_on_hangup() -> Iterator[None]:
    """SIGTERM and SIGHUP end the command like Ctrl-C does, closing the viewer's server
    (the server also dies on its own with this process: see viz._meshcat_server)."""

    def stop(signum: int, frame: object) -> None:
        raise SystemExit(128 + signum)

    signals = [getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, stop) for sig in signals}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _demo(args: argparse.Namespace) -> int:
    if is_stdout(args.output):
        raise InputError(
            "demo -o - : the demo writes a folder of files, not one table for standard "
            "output; give a folder name"
        )
    if args.payload:
        from stewart_pin.apps.payload_demo import run_payload_demo

        run_payload_demo(args.preset, args.payload, Path(args.output))
        return 0
    from stewart_pin.apps.demo import run_demo

    run_demo(args.preset, Path(args.output))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="integrate the direct model: computed-torque tracking of a motion, or free",
        description="Integrates the direct dynamic model on SE(3). A motion (about the home "
        "pose, scaled on the robot) is tracked by computed-torque control (inverse model "
        "plus PD) sampled at --control-period; 'free' runs with zero actuator force. "
        "Results: .npz or .csv (t, pose, twist, classical acceleration, actuator efforts "
        "[N, or N m for revolute actuators], actuated joint positions [m or rad]). "
        "A run that stops early (a leg at its stroke end, a U-joint at its limit, a "
        "singularity, the controller failing) exits with code 2 and saves the states "
        "simulated so far beside the output, as <stem>.partial<suffix>.",
    )
    add_robot_args(p)
    p.add_argument(
        "--motion",
        choices=(*MOTION_KINDS, "free"),
        default="sinusoid",
        help="the motion tracked, or free (zero actuator force)",
    )
    p.add_argument("--duration", type=positive_finite_float, default=2.0, help="[s]")
    p.add_argument(
        "--method", choices=("rk4", "adaptive"), default="rk4", help="the integrator on SE(3)"
    )
    p.add_argument(
        "--dt", type=positive_finite_float, default=1e-3, help="step [s] (first step if adaptive)"
    )
    p.add_argument(
        "--control-period",
        type=positive_finite_float,
        default=1e-3,
        help="controller period [s]",
    )
    p.add_argument(
        "--integrator",
        choices=("auto", "compiled", "python"),
        default="auto",
        help="the stepping loop: auto (in C around the compiled direct model when it can "
        "run this simulation, else Python), compiled (in C, or an error saying why not) or "
        "python",
    )
    p.add_argument(
        "--model-error",
        type=finite_float,
        default=0.0,
        help="relative error of every inertial parameter in the controller's model",
    )
    p.add_argument(
        "--backend",
        choices=("auto", "compiled", "pinocchio"),
        default="auto",
        help="dynamic models: auto (the generated C where a C compiler is available, "
        "compiled on first use and cached, else the Pinocchio reference path), compiled "
        "(the generated C; CasADi's virtual machine without a compiler) or pinocchio (the "
        "reference path)",
    )
    p.add_argument(
        "-o",
        "--output",
        default="simulation.npz",
        help=".npz or .csv; - writes the CSV to standard output (the summary then goes to "
        "standard error; not with --payload, which writes two files)",
    )
    add_payload_motion_args(p)
    p.add_argument("--plots", help="folder for PNG plots")
    add_progress_arg(p)
    p.set_defaults(func=_simulate)

    p = sub.add_parser(
        "animate",
        help="export a standalone HTML animation (opens in a browser without a server)",
    )
    add_robot_args(p)
    p.add_argument("--result", help="a simulation result (.npz or .csv) to play")
    p.add_argument("--motion", choices=MOTION_KINDS, default="sinusoid", help="else this motion")
    p.add_argument(
        "--duration",
        type=duration_within_memory(BYTES_PER_ANIMATION_SECOND),
        default=4.0,
        help="[s] of the motion (at most what this machine's memory holds, about 0.7 MB per s)",
    )
    p.add_argument("--fps", type=positive_finite_float, default=30.0, help="key frames per second")
    p.add_argument(
        "-o",
        "--output",
        default="animation.html",
        help="HTML file to write (a file: not - for standard output)",
    )
    add_payload_motion_args(p, drawing=True)
    p.set_defaults(func=_animate)

    p = sub.add_parser("view", help="the robot live in meshcat (a local server on 127.0.0.1)")
    add_robot_args(p)
    p.add_argument("--result", help="a simulation result (.npz or .csv) to play")
    p.add_argument(
        "--motion",
        choices=(*MOTION_KINDS, "none"),
        default="none",
        help="else this motion (none: the robot at rest)",
    )
    p.add_argument(
        "--duration",
        type=duration_within_memory(BYTES_PER_ANIMATION_SECOND),
        default=4.0,
        help="[s] of the motion (at most what this machine's memory holds, about 0.7 MB per s)",
    )
    p.add_argument("--open", action="store_true", help="open the page in the web browser")
    p.add_argument("--no-wait", action="store_true", help="show, then exit (no waiting)")
    add_payload_motion_args(p, drawing=True)
    p.set_defaults(func=_view)

    p = sub.add_parser("demo", help="the main demo: the whole workflow on a preset")
    p.add_argument("--preset", default="simulator", help=PRESET_HELP)
    p.add_argument("-o", "--output", default="out", help="output folder (not -)")
    p.add_argument(
        "--payload",
        metavar="NAME",
        help="instead, the payload demo: this arm of example-robot-data (e.g. panda, with "
        "--preset paper) makes a fast move on the hexapod, which keeps its base still",
    )
    p.set_defaults(func=_demo)


def add_payload_motion_args(p: argparse.ArgumentParser, drawing: bool = False) -> None:
    """``--payload`` and the payload's joint motion (and, to draw, ``--payload-shapes``)."""
    add_payload_args(p)
    p.add_argument(
        "--payload-fraction",
        type=fraction_of_one,
        help="the payload's joints sweep this fraction of their half-range, in (0, 1] "
        f"(default: {PAYLOAD_FRACTION:g}; needs --payload)",
    )
    p.add_argument(
        "--payload-period",
        type=positive_finite_float,
        help=f"period [s] of the payload's joint sweep (default: {PAYLOAD_PERIOD:g}; needs "
        "--payload)",
    )
    if drawing:
        p.add_argument(
            "--payload-shapes",
            action="store_true",
            help="draw the payload with simple shapes, not its meshes (a smaller HTML page; "
            "needs --payload)",
        )
