"""The ``stewart-pin`` command.

Units and frames everywhere: SI (m, rad, N, kg); poses 0Tp of the platform frame Fp in the
base frame F0; twists [v, w] of the origin of Fp in F0; classical accelerations.
Errors in inputs exit with code 2 and a one-line message (``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from .exceptions import StewartPinError
from .robot import StewartRobot


def _robot(args: argparse.Namespace) -> StewartRobot:
    if getattr(args, "description", None):
        return StewartRobot.from_file(args.description)
    return StewartRobot.from_preset(args.preset)


def _pose(values: Sequence[float] | None, robot: StewartRobot) -> np.ndarray:
    """A pose from ``x y z roll pitch yaw`` [m, rad] relative to the home pose, in F0."""
    T = robot.home_pose
    if values is not None:
        T[:3, 3] += values[:3]
        T[:3, :3] = pin.rpy.rpyToMatrix(*values[3:]) @ T[:3, :3]
    return T


def _cmd_urdf(args: argparse.Namespace) -> int:
    robot = _robot(args)
    out = Path(args.output or f"{robot.name}.urdf")
    urdf, sidecar = robot.write_urdf(out)
    print(f"wrote {urdf} and {sidecar}")
    return 0


def _cmd_ik(args: argparse.Namespace) -> int:
    robot = _robot(args)
    T = _pose(args.pose, robot)
    q = robot.inverse_geometry(T)
    np.set_printoptions(precision=6, suppress=True)
    print(f"pose 0Tp:\n{T}")
    print("leg   q1 [rad]     q2 [rad]     q3 [m]")
    for i, row in enumerate(q, 1):
        print(f"{i:3d} {row[0]:12.6f} {row[1]:12.6f} {row[2]:12.6f}")
    print(f"Jp^-1 (rows [a_i, L_i x a_i]), cond = {robot.condition_number(T):.4g}:")
    print(robot.inverse_jacobian(T))
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    run_demo(args.preset, Path(args.output))
    return 0


def _cmd_base_params(args: argparse.Namespace) -> int:
    from .base_params import base_parameters, numerical_base_parameters

    robot = _robot(args)
    numerical, rank = numerical_base_parameters(robot, n_states=args.states, seed=args.seed)
    bp = numerical if args.method == "numerical" else base_parameters(robot, "analytic")
    print(f"robot '{robot.name}': {len(bp)} {args.method} base parameters of 190 standard")
    print(bp.table())
    print(f"\nnumerical rank: {rank}")
    if rank.rank != len(bp):
        print(
            f"warning: the numerical rank {rank.rank} differs from the {len(bp)} {args.method} "
            "base parameters: this geometry makes some of them unidentifiable (or the "
            "tolerance is off); use --method numerical"
        )
    return 0


def _cmd_identify(args: argparse.Namespace) -> int:
    from .base_params import base_parameters
    from .identification import (
        exciting_trajectory,
        identify,
        read_measurements_csv,
        simulate_measurements,
        validation_error,
        write_measurements_csv,
    )

    robot = _robot(args)
    base = base_parameters(robot, "analytic")
    out = Path(args.output) if args.output else None
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
    lines: list[str] = []
    if args.csv:
        measurements = read_measurements_csv(args.csv, min_rows=len(base) // 6 + 1)
        lines.append(f"measurements: {args.csv} ({len(measurements)} samples)")
        label = "nominal"
    else:
        trajectory, cond = exciting_trajectory(
            robot,
            args.duration,
            args.harmonics,
            args.frequency,
            args.seed,
            args.samples,
            max_evaluations=args.evaluations,
        )
        clean = simulate_measurements(robot, trajectory)
        rms = float(np.sqrt(np.mean(clean.gammas**2)))
        noise = 0.01 * rms if args.noise is None else args.noise
        measurements = simulate_measurements(robot, trajectory, noise, args.seed)
        stem = out.with_name(out.stem + "_measurements.csv") if out else None
        csv_path = write_measurements_csv(
            stem or Path(f"{robot.name}_measurements.csv"), measurements
        )
        lines.append(
            f"simulated measurements: exciting trajectory ({args.harmonics} harmonics of "
            f"{args.frequency:g} Hz, {len(trajectory)} samples, condition number {cond:.4g}), "
            f"force noise std {noise:.4g} N ({100 * noise / rms:.3g} % of the RMS force "
            f"{rms:.4g} N); written to {csv_path}"
        )
        label = "true"
    result = identify(robot, measurements, base, weighted=not args.ols)
    lines += ["", result.report(base.values, label=label), ""]
    if args.validation_csv:
        validation = read_measurements_csv(args.validation_csv)
        error = validation_error(result, robot, validation)
        lines.append(
            f"validation on {args.validation_csv}: relative RMS force error {100 * error:.4g} %"
        )
    elif not args.csv:
        trajectory, _ = exciting_trajectory(
            robot,
            args.duration,
            args.harmonics,
            args.frequency,
            args.seed + 1,
            args.samples,
            optimise=False,
        )
        clean = simulate_measurements(robot, trajectory)
        validation = simulate_measurements(robot, trajectory, noise, args.seed + 1)
        error = validation_error(result, robot, validation)
        floor = np.linalg.norm(validation.gammas - clean.gammas) / np.linalg.norm(
            validation.gammas
        )
        lines.append(
            f"validation on a fresh trajectory (seed {args.seed + 1}, same noise): relative "
            f"RMS force error {100 * error:.4g} % (the noise alone: {100 * floor:.4g} %)"
        )
    else:
        lines.append("validation: give --validation-csv FILE (a second log) to measure it")
    text = "\n".join(lines)
    print(text)
    if out:
        out.write_text(text + "\n")
        print(f"wrote {out}")
    return 0


def _add_robot_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--preset", default="simulator", help="simulator, desktop, paper, random-<seed>"
    )
    g.add_argument("--description", help="a robot description file (.toml or .json)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stewart-pin",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("urdf", help="write the URDF and its loop-closure sidecar")
    _add_robot_args(p)
    p.add_argument("-o", "--output", help="URDF path (default <name>.urdf)")
    p.set_defaults(func=_cmd_urdf)

    p = sub.add_parser("ik", help="inverse geometry and Jp^-1 at a pose")
    _add_robot_args(p)
    p.add_argument(
        "--pose",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
        help="offset from the home pose [m, m, m, rad, rad, rad], rotation applied in F0",
    )
    p.set_defaults(func=_cmd_ik)

    p = sub.add_parser("base-params", help="the base inertial parameters and the numerical rank")
    _add_robot_args(p)
    p.add_argument(
        "--method",
        choices=("analytic", "numerical"),
        default="analytic",
        help="the paper's grouping rules (default) or QR of the stacked regressor",
    )
    p.add_argument("--states", type=int, default=60, help="random states stacked for the rank")
    p.add_argument("--seed", type=int, default=0, help="seed of the random states")
    p.set_defaults(func=_cmd_base_params)

    p = sub.add_parser(
        "identify",
        help="identify the base parameters from a CSV log, or from simulated measurements",
        description="Without --csv: optimise an exciting trajectory, simulate noisy forces "
        "(written as CSV, the format --csv reads: docs/identification.md), identify and "
        "compare with the true values. With --csv: identify from the log.",
    )
    _add_robot_args(p)
    p.add_argument("--csv", help="measurement log (t,x,y,z,qx,qy,qz,qw,...,gamma6; SI units)")
    p.add_argument("--validation-csv", help="a second log to validate the prediction on")
    p.add_argument(
        "--noise", type=float, help="force noise std [N] (default 1 %% of the RMS force)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the trajectory and the noise")
    p.add_argument("--samples", type=int, default=200, help="samples of the trajectory")
    p.add_argument("--duration", type=float, help="[s] (default one period)")
    p.add_argument("--harmonics", type=int, default=5, help="Fourier harmonics per axis")
    p.add_argument("--frequency", type=float, default=0.2, help="base frequency [Hz]")
    p.add_argument(
        "--evaluations", type=int, default=300, help="cost evaluations of the optimiser"
    )
    p.add_argument("--ols", action="store_true", help="ordinary instead of weighted LS")
    p.add_argument("-o", "--output", help="write the report there too (and the CSV beside)")
    p.set_defaults(func=_cmd_identify)

    p = sub.add_parser("demo", help="the main demo: URDF, geometry and kinematics of a preset")
    p.add_argument("--preset", default="simulator")
    p.add_argument("-o", "--output", default="out", help="output folder")
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (StewartPinError, OSError) as e:
        if args.debug:
            raise
        print(f"stewart-pin {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
