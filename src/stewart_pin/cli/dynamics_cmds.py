"""``idm``, ``validate``, ``cost`` and ``bench``."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from stewart_pin._argtypes import BYTES_PER_STATE, count_within_memory
from stewart_pin.check.tolerances import DDM_TOLERANCE, IDM_TOLERANCE
from stewart_pin.cli._common import (
    add_payload_args,
    add_robot_args,
    check_output,
    non_negative_finite_float,
    non_negative_int,
    payload_robot_from_args,
    report_stream,
    robot_from_args,
    written,
)
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    STATE_COLUMNS,
    read_csv,
    states_from_table,
    write_csv,
)


def _idm(args: argparse.Namespace) -> int:
    out = check_output(
        args.output, (".csv",), [args.trajectory, args.description, args.model], stdout=True
    )
    robot = robot_from_args(args)
    rows = read_csv(args.trajectory, STATE_COLUMNS)
    times, poses, twists, accels = states_from_table(rows)
    gamma = robot.inverse_dynamics(poses, twists, accels)  # NumericalError if not finite
    with written(out, "forces.csv") as path:
        write_csv(path, ("t", *FORCE_COLUMNS), np.column_stack([times, gamma]))
    peak = np.abs(gamma).max(axis=0)
    unit = robot.description.effort_unit
    print(
        f"inverse dynamics of {len(times)} states of {args.trajectory} on '{robot.name}': "
        f"peak |Gamma_i| = {np.array2string(peak, precision=5)} {unit}; wrote {out}",
        file=report_stream(out),
    )
    return 0


def _validate(args: argparse.Namespace) -> int:
    from stewart_pin.check.constrained_dynamics import validate

    robot = robot_from_args(args)
    carrier = payload_robot_from_args(args, robot)
    report: Any
    if carrier is not None:
        from stewart_pin.check.payload import validate_payload

        report = validate_payload(
            carrier,
            n_states=args.states,
            seed=args.seed,
            translation_range=args.translation,
            rotation_range=args.rotation,
        )
    else:
        report = validate(
            robot,
            n_states=args.states,
            seed=args.seed,
            translation_range=args.translation,
            rotation_range=args.rotation,
        )
    print(report.summary(args.tol_idm, args.tol_ddm))  # one verdict, at these tolerances
    return 0 if report.passed(args.tol_idm, args.tol_ddm) else 1


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "idm",
        help="inverse dynamics along a platform trajectory: CSV in, actuator forces CSV out",
        description="Reads a trajectory CSV with columns "
        + ",".join(STATE_COLUMNS)
        + " (time [s]; O_p in F0 [m]; quaternion of 0Rp; twist [v, w] in F0 [m/s, rad/s]; "
        "classical acceleration in F0 [m/s^2, rad/s^2]) and writes t,gamma1..gamma6, the "
        "actuator efforts: forces [N] for prismatic actuators (positive extends the leg), "
        "torques [N m] for revolute ones (RUS cranks), joint side.",
    )
    add_robot_args(p)
    p.add_argument("--trajectory", required=True, help="platform trajectory CSV")
    p.add_argument(
        "-o",
        "--output",
        default="forces.csv",
        help="forces CSV to write; - writes it to standard output (the summary then goes to "
        "standard error)",
    )
    p.set_defaults(func=_idm)

    p = sub.add_parser(
        "validate",
        help="compare the paper's models with Pinocchio's constrained dynamics",
        description="Random workspace states: the inverse model against the constrained "
        "inverse dynamics of the 24-dof tree with six loop closures, the direct model "
        "against pin.constraintDynamics. With --payload, the coupled models of the hexapod "
        "and the robot it carries against the whole tree (legs, platform and payload, six "
        "loop closures). Exit code 1 when a tolerance is exceeded.",
    )
    add_robot_args(p)
    add_payload_args(p)
    p.add_argument(
        "--states",
        type=count_within_memory(BYTES_PER_STATE, "state"),
        default=200,
        help="random states (at most what this machine's memory holds, about 8 kB each)",
    )
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the states")
    p.add_argument(
        "--translation",
        type=non_negative_finite_float,
        metavar="M",
        help="half-side [m] of the cube (along F0's axes) in which the platform's origin is "
        "drawn around the home pose (default: 15 %% of the mid-stroke)",
    )
    p.add_argument(
        "--rotation",
        type=non_negative_finite_float,
        default=0.25,
        metavar="RAD",
        help="largest component [rad] of the rotation vector applied to the home orientation",
    )
    p.add_argument(
        "--tol-idm",
        type=non_negative_finite_float,
        default=IDM_TOLERANCE,
        help="relative tolerance, inverse",
    )
    p.add_argument(
        "--tol-ddm",
        type=non_negative_finite_float,
        default=DDM_TOLERANCE,
        help="relative tolerance, direct",
    )
    p.set_defaults(func=_validate)
    register_performance(sub)


def _cost(args: argparse.Namespace) -> int:
    from stewart_pin.codegen.opcount import architecture_table, cost_table

    if args.architectures:
        print(architecture_table())
        return 0
    print(cost_table(robot_from_args(args)))
    return 0


def _bench(args: argparse.Namespace) -> int:
    from stewart_pin.apps.bench import report
    from stewart_pin.description.presets import preset

    if args.json is not None:
        check_output(args.json, (".json",), what="--json")
    preset(args.preset)  # an unknown preset: one line, before any timing
    report(args)
    return 0


def register_performance(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "cost",
        help="operation counts of the generated closed-form models beside the paper's Table IV",
    )
    add_robot_args(p)
    p.add_argument(
        "--architectures",
        action="store_true",
        help="compare the architectures (6-UPS, offset U joints, 6-RUS, 6-PUS, every joint "
        "term, custom legs) in one table instead",
    )
    p.set_defaults(func=_cost)

    from stewart_pin.apps.bench_args import add_arguments

    p = sub.add_parser(
        "bench",
        help="median time per state: the models, compiled C, pin.constraintDynamics, MuJoCo",
    )
    add_arguments(p)
    p.set_defaults(func=_bench)
