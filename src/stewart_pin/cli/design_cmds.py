"""``workspace``, ``size`` and ``sweep``: the design studies of :mod:`stewart_pin.design`.

The library (and Dask) are imported inside the commands: ``--help`` parses without them.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from stewart_pin._argtypes import (
    non_negative_finite_float,
    non_negative_int,
    positive_finite_float,
    positive_int,
)
from stewart_pin.cli._common import add_robot_args, check_output, finite_float, robot_from_args


def _float_list(text: str) -> list[float]:
    """``0.1,0.12,0.14`` -> finite floats."""
    try:
        values = [float(t) for t in text.split(",")]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected comma-separated finite numbers, got {text!r}")
    return values


def _stroke_list(text: str) -> list[tuple[float, float]]:
    """``0.13:0.19,0.12:0.2`` -> (min, max) pairs [m]."""
    out = []
    for item in text.split(","):
        parts = item.split(":")
        try:
            lo, hi = (float(p) for p in parts)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected MIN:MAX pairs separated by commas, got {text!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise argparse.ArgumentTypeError(f"expected finite strokes, got {text!r}")
        out.append((lo, hi))
    return out


def _orientation(args: argparse.Namespace, robot: Any) -> Any:
    import pinocchio as pin

    R = robot.home_pose[:3, :3]
    return R if args.orientation is None else pin.rpy.rpyToMatrix(*args.orientation) @ R


def _workspace(args: argparse.Namespace) -> int:
    out = check_output(args.output, (".csv",), [args.description, args.model], "-o")
    boundary = (
        check_output(args.boundary, (".csv",), [args.description, args.model], "--boundary")
        if args.boundary
        else None
    )
    import numpy as np
    import pinocchio as pin

    from stewart_pin._io import atomic_open
    from stewart_pin.design import dexterous_workspace, orientation_workspace, workspace

    robot = robot_from_args(args)
    common = {
        "resolution": args.resolution,
        "max_condition": args.max_condition,
        "min_leg_distance": args.min_leg_distance,
        "rng": args.seed,
    }
    R = _orientation(args, robot)
    if args.kind == "orientation":
        ws = orientation_workspace(robot, max_angle=args.max_angle, **common)
        header, unit = "roll,pitch,yaw", "rad^3"
    elif args.kind == "dexterous":
        a = args.max_angle
        grid = [(r, p, y) for r in (-a, 0, a) for p in (-a, 0, a) for y in (-a, 0, a)]
        Rs = np.array([pin.rpy.rpyToMatrix(*rpy) @ R for rpy in grid])
        ws = dexterous_workspace(robot, Rs, **common)
        header, unit = "x,y,z", "m^3"
    else:
        ws = workspace(robot, R, **common)
        header, unit = "x,y,z", "m^3"
    with atomic_open(out) as f:
        np.savetxt(f, ws.inside_points, delimiter=",", header=header, comments="", fmt="%.17g")
    print(
        f"{ws.kind} workspace volume {ws.volume:.6g} {unit} +- {ws.volume_error:.2g} (one "
        f"standard error), {int(ws.inside.sum())} of {ws.inside.size} cells {ws.shape}; "
        f"wrote {out}"
    )
    if ws.touches_box:
        print("note: the workspace touches the box; pass a larger box to the library call")
    if boundary is not None:
        b = ws.boundary()
        with atomic_open(boundary) as f:
            np.savetxt(f, b, delimiter=",", header=header, comments="", fmt="%.17g")
        print(f"wrote {len(b)} boundary points to {boundary}")
    return 0


def _size(args: argparse.Namespace) -> int:
    from pathlib import Path

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        from stewart_pin.exceptions import InputError

        raise InputError(f"-o {out} is a file; give a folder for the report's tables")
    from stewart_pin.design import (
        StateBox,
        actuator_loads,
        dynamic_capability,
        worst_case,
        write_report,
    )

    robot = robot_from_args(args)
    box = StateBox(
        args.translation,
        args.rotation,
        args.speed,
        args.angular_speed,
        args.accel,
        args.angular_accel,
    )
    if args.trajectory:  # the loads along a given motion; no box to search
        from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv, states_from_table

        _, poses, twists, accels = states_from_table(read_csv(args.trajectory, STATE_COLUMNS))
        loads = actuator_loads(robot, poses, twists, accels)
        worst = []
    else:
        x = box.sample(robot, args.samples, args.seed)
        loads = actuator_loads(robot, *box.states(robot, x))
        worst = (
            []
            if args.no_optimise
            else worst_case(
                robot, box, samples=args.samples, rng=args.seed, gradient=args.gradient
            )
        )
    limits = args.effort_limit
    cap = None
    if limits is not None or robot.description.effort_limits is not None:
        cap = dynamic_capability(robot, limits)
    paths = write_report(out, loads, worst, cap, html=args.html)
    print("actuator  peak effort   rms effort   peak speed   peak power  worst (optimised)")
    for k, row in enumerate(loads.table()):
        w = f"{worst[k].effort:12.6g}" if worst else "           -"
        print(
            f"{row['actuator']:8d} {row['peak_effort']:12.6g} {row['rms_effort']:12.6g} "
            f"{row['peak_speed']:12.6g} {row['peak_power']:12.6g} {w}"
        )
    if cap is not None:
        print(
            "max accel [m/s^2] along +x -x +y -y +z -z: " + " ".join(f"{a:.4g}" for a in cap.accel)
        )
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


_GEOMETRY_KEYS = (
    "base_radius",
    "platform_radius",
    "base_pair_angle",
    "platform_pair_angle",
    "home_height",
)


def _sweep(args: argparse.Namespace) -> int:
    out = check_output(args.output, (".csv",), (), "-o")
    plot = (
        check_output(args.pareto, (".png", ".svg", ".pdf"), (), "--pareto")
        if args.pareto
        else None
    )
    from stewart_pin.design import SweepSettings, grid, sweep

    axes: dict[str, Any] = {k: getattr(args, k) for k in _GEOMETRY_KEYS if getattr(args, k)}
    if args.stroke:
        axes["stroke"] = args.stroke
    geometries = grid(**axes) if axes else [{}]
    settings = SweepSettings(
        resolution=args.resolution, samples=args.samples, seed=args.seed, backend=args.backend
    )
    result = sweep(
        geometries,
        settings,
        scheduler="serial" if args.serial else args.scheduler,
        workers=args.workers,
        processes=not args.threads,
        progress=not args.quiet,
        timeout=args.timeout,
    )
    result.write_csv(out)
    failed = sum(1 for r in result.rows if r["error"])
    print(f"swept {len(result.rows)} geometries ({failed} failed); wrote {out}")
    if plot is not None:
        result.plot_pareto(plot)
        print(f"wrote the Pareto plot {plot}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "workspace",
        help="constant-orientation workspace: volume with its standard error, cells, boundary",
    )
    add_robot_args(p)
    p.add_argument(
        "--orientation",
        nargs=3,
        type=finite_float,
        metavar=("ROLL", "PITCH", "YAW"),
        help="rotation applied in F0 to the home orientation [rad] (default: home)",
    )
    p.add_argument(
        "--kind",
        choices=("position", "orientation", "dexterous"),
        default="position",
        help="position: O_p at a fixed orientation; orientation: roll, pitch, yaw within "
        "--max-angle at the home position; dexterous: positions reaching every rotation "
        "of the grid {-A, 0, A}^3 (A = --max-angle) of roll, pitch, yaw",
    )
    p.add_argument(
        "--max-angle",
        type=positive_finite_float,
        default=0.1,
        help="the orientation box's half-width / the dexterous set's angle [rad]",
    )
    p.add_argument(
        "--min-leg-distance",
        type=non_negative_finite_float,
        help="no two legs closer than this [m] (leg-leg interference; default: not checked)",
    )
    p.add_argument("--resolution", type=positive_int, default=40, help="cells on the longest side")
    p.add_argument("--max-condition", type=positive_finite_float, help="singularity bound")
    p.add_argument("--seed", type=non_negative_int, default=0, help="the jitter's seed")
    p.add_argument("-o", "--output", default="workspace.csv", help="CSV of the cells' states")
    p.add_argument("--boundary", help="CSV of boundary points (bisection along 26 rays)")
    p.set_defaults(func=_workspace)

    p = sub.add_parser(
        "size",
        help="actuator sizing: peak/RMS effort, speed, power; worst case; capability",
    )
    add_robot_args(p)
    for name, unit, default in (
        ("translation", "m", 0.01),
        ("rotation", "rad", 0.05),
        ("speed", "m/s", 0.1),
        ("angular-speed", "rad/s", 0.5),
        ("accel", "m/s^2", 2.0),
        ("angular-accel", "rad/s^2", 5.0),
    ):
        p.add_argument(
            f"--{name}",
            type=non_negative_finite_float,
            default=default,
            help=f"half-width of the box of states, per component [{unit}]",
        )
    p.add_argument(
        "--trajectory",
        help="a platform trajectory CSV (the columns of `idm --trajectory`): the loads "
        "along it instead of over the box of states (no worst-case search)",
    )
    p.add_argument("--samples", type=positive_int, default=2000, help="states sampled")
    p.add_argument("--seed", type=non_negative_int, default=0, help="the sampling seed")
    p.add_argument("--no-optimise", action="store_true", help="skip the worst-case search")
    p.add_argument(
        "--gradient",
        choices=("differences", "exact"),
        default="differences",
        help="the worst-case search's gradients (exact: compiled Jacobians, built once)",
    )
    p.add_argument(
        "--effort-limit",
        type=positive_finite_float,
        help="every actuator's effort limit [N or N m] for the dynamic capability "
        "(default: the description's effort_limits; none: no capability table)",
    )
    p.add_argument("--html", action="store_true", help="also report.html with the plots")
    p.add_argument("-o", "--output", default="sizing", help="folder of the report's tables")
    p.set_defaults(func=_size)

    p = sub.add_parser("sweep", help="geometry sweep on Dask: a table and a Pareto plot")
    for key in _GEOMETRY_KEYS:
        unit = "rad" if "angle" in key else "m"
        p.add_argument(
            f"--{key.replace('_', '-')}",
            dest=key,
            type=_float_list,
            help=f"values, comma-separated [{unit}]",
        )
    p.add_argument("--stroke", type=_stroke_list, help="MIN:MAX pairs, comma-separated [m]")
    p.add_argument("--resolution", type=positive_int, default=16, help="workspace cells")
    p.add_argument("--samples", type=positive_int, default=200, help="states per geometry")
    p.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of every geometry's draws"
    )
    p.add_argument(
        "--scheduler",
        help="a Dask scheduler's address, e.g. tcp://host:8786 (default: a LocalCluster)",
    )
    p.add_argument("--workers", type=positive_int, default=2, help="LocalCluster workers")
    p.add_argument("--threads", action="store_true", help="LocalCluster of threads")
    p.add_argument("--serial", action="store_true", help="evaluate in this process, no Dask")
    p.add_argument(
        "--timeout", type=positive_finite_float, default=10.0, help="scheduler timeout [s]"
    )
    p.add_argument(
        "--backend",
        choices=("auto", "pinocchio", "compiled"),
        default="auto",
        help="inverse dynamics backend (auto: each geometry compiled once, where it runs)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("-o", "--output", default="sweep.csv", help="the table (CSV)")
    p.add_argument("--pareto", help="the Pareto plot (.png, .svg or .pdf; needs the viz extra)")
    p.set_defaults(func=_sweep)
