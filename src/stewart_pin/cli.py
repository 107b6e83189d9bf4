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
