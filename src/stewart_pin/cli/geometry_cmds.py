"""``urdf`` and ``ik``."""

from __future__ import annotations

import argparse

import numpy as np

from stewart_pin._safe import file_in_folder
from stewart_pin.cli._common import (
    add_robot_args,
    check_output,
    finite_float,
    pose_from_args,
    robot_from_args,
)


def _urdf(args: argparse.Namespace) -> int:
    robot = robot_from_args(args)
    # The default name comes from the robot: checked to stay in the working folder.
    out = (
        check_output(args.output, (), [args.description, args.model], "-o")
        if args.output
        else file_in_folder(".", f"{robot.name}.urdf")
    )
    urdf, sidecar = robot.write_urdf(out)
    print(f"wrote {urdf} and {sidecar}")
    return 0


def _ik(args: argparse.Namespace) -> int:
    robot = robot_from_args(args)
    T = pose_from_args(args.pose, robot)
    q = robot.inverse_geometry(T)
    source = robot.description.source
    if source is not None and not robot.actuator_convention.identity:
        # an imported robot speaks its file's joint convention (robot.actuator_convention)
        three = robot.description.leg_architectures
        q = source.file_joint_values(q, [[j.revolute for j in leg.joints] for leg in three])
        print("joint values in the model file's convention (its zeros and directions)")
    np.set_printoptions(precision=6, suppress=True)
    print(f"pose 0Tp:\n{T}")
    desc = robot.description
    legs = desc.joint_legs  # chain legs: n joints each
    actuated = {leg.actuated for leg in legs}
    shared = f"q{actuated.pop()}" if len(actuated) == 1 else "* marks it"
    print(
        f"{robot.architecture} legs; joint values [rad revolute, m prismatic]; actuated: {shared}"
    )
    print("leg " + "".join(f"  q{j + 1:<11d}" for j in range(q.shape[1])).rstrip())
    for i, (row, leg) in enumerate(zip(q, legs, strict=True), 1):
        n = len(leg.joints)  # chain legs: fewer joints than the widest leg's are blank
        mark = [" "] * n if shared.startswith("q") else [" "] * (leg.actuated - 1) + ["*"]
        mark += [" "] * (n - len(mark))
        cells = [f"{v:12.6f}{mark[j]}" if j < n else " " * 13 for j, v in enumerate(row)]
        print(f"{i:3d} {''.join(cells)}".rstrip())
    print(f"Jp^-1 (rows e_ai^T J_i^-1 G_i), cond = {robot.condition_number(T):.4g}:")
    print(robot.inverse_jacobian(T))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("urdf", help="write the URDF and its loop-closure sidecar")
    add_robot_args(p)
    p.add_argument(
        "-o",
        "--output",
        help="URDF path (default: <name>.urdf; a file, not -: the sidecar is written beside)",
    )
    p.set_defaults(func=_urdf)

    p = sub.add_parser("ik", help="inverse geometry and Jp^-1 at a pose")
    add_robot_args(p)
    p.add_argument(
        "--pose",
        nargs=6,
        type=finite_float,
        metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
        help="offset from the home pose [m, m, m, rad, rad, rad], rotation applied in F0",
    )
    p.set_defaults(func=_ik)
