"""``base-params`` and ``identify``."""

from __future__ import annotations

import argparse

import numpy as np

from stewart_pin._argtypes import BYTES_PER_REGRESSOR_STATE, count_within_memory
from stewart_pin._io import write_text_atomic
from stewart_pin._safe import file_in_folder
from stewart_pin.cli import identify_log
from stewart_pin.cli._common import (
    add_robot_args,
    check_output,
    non_negative_finite_float,
    non_negative_int,
    positive_finite_float,
    positive_int,
)
from stewart_pin.cli._common import robot_from_args as _robot
from stewart_pin.exceptions import UnsupportedArchitectureError


def _cmd_base_params(args: argparse.Namespace) -> int:
    from stewart_pin.parameters.base import base_parameters, numerical_base_parameters
    from stewart_pin.parameters.leg_chain_base import uncovered_legs

    robot = _robot(args)
    numerical, rank = numerical_base_parameters(robot, n_states=args.states, seed=args.seed)
    desc = robot.description
    method = args.method
    from stewart_pin.architectures import reference_path  # heavy (Pinocchio): at run time

    if method == "analytic" and not reference_path(desc).analytic_rules:
        print(
            f"note: robot '{robot.name}' has {desc.architecture} legs, which the analytic "
            "grouping rules "
            "do not cover: showing the numerical base parameters"
        )
        method = "numerical"
    if method == "analytic" and uncovered_legs(desc):
        print(
            f"note: robot '{robot.name}' has custom legs {uncovered_legs(desc)}, which the "
            "analytic grouping rules do not cover: showing the numerical base parameters"
        )
        method = "numerical"
    bp = numerical if method == "numerical" else base_parameters(robot, "analytic")
    n = len(bp.standard_names)
    print(f"robot '{robot.name}': {len(bp)} {method} base parameters of {n} standard")
    print(bp.table())
    if len(bp.joint_terms):
        print(
            f"\njoint terms: {len(bp.joint_terms)} base parameters are joint terms of their "
            "own (IA armature [kg m^2 or kg], FV viscous friction, FC Coulomb friction, "
            "K stiffness, OF offset: a constant effort, -K q0 of a spring); the others may "
            "hold some too (an armature grouped into ZZ, a slide's mass into IA and OF)"
        )
    print(f"\nnumerical rank: {rank}")
    from stewart_pin.parameters.base import essential_parameters, paper_essential_parameters

    ess = essential_parameters(
        robot, args.threshold, n_states=args.states, seed=args.seed, base=bp
    )
    print(
        f"\n{n} standard -> {len(bp)} base -> {len(ess)} essential parameters (those left when "
        f"the base parameters changing the forces by less than {args.threshold:g} relative "
        f"are removed; the kept set predicts the forces to {ess.relative_error:.3g}):"
    )
    for name, value in zip(ess.names, ess.values, strict=True):
        print(f"{name:>16s} {value:14.6g}")
    try:  # the paper's set is made of its 88 grouped parameters (R-R-P legs only)
        paper = paper_essential_parameters(robot, n_states=args.states, seed=args.seed)
    except UnsupportedArchitectureError:
        paper = None
    if paper is not None:
        print(
            f"the paper's Table III set ({len(paper)} parameters: 7 per leg + 10) predicts "
            f"the forces of this robot to {paper.relative_error:.3g} relative"
        )
    if rank.rank != len(bp):
        print(
            f"warning: the numerical rank {rank.rank} differs from the {len(bp)} {method} "
            "base parameters: this geometry makes some of them unidentifiable (or the "
            "tolerance is off); use --method numerical"
        )
    return 0


def _cmd_identify(args: argparse.Namespace) -> int:
    if args.log:  # from an actuator log: stewart_pin.cli.identify_log
        return identify_log.run(args)
    from stewart_pin.parameters.base import base_parameters
    from stewart_pin.parameters.identification import (
        exciting_trajectory,
        identify,
        read_measurements_csv,
        simulate_measurements,
        validation_error,
        write_measurements_csv,
    )

    inputs = [args.csv, args.validation_csv, args.description, args.model]
    out = check_output(args.output, (), inputs, "-o") if args.output else None
    from stewart_pin.parameters.leg_chain_base import uncovered_legs

    robot = _robot(args)
    if not args.csv:  # the simulated measurements are written: check where, up front
        stem = out.with_name(out.stem + "_measurements.csv") if out else None
        measurements_path = check_output(
            stem or file_in_folder(".", f"{robot.name}_measurements.csv"),
            (".csv",),
            inputs,
            "measurements",
        )
    lines: list[str] = []
    desc = robot.description
    if uncovered_legs(desc):  # custom legs: no analytic rules
        base = base_parameters(robot, "numerical")
        lines.append(
            f"note: robot '{robot.name}' has custom legs {uncovered_legs(desc)}, which the "
            "analytic grouping rules do not cover: identifying the numerical base parameters"
        )
    else:
        base = base_parameters(robot, "analytic")
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
            base=base,
            max_evaluations=args.evaluations,
        )
        clean = simulate_measurements(robot, trajectory)
        rms = float(np.sqrt(np.mean(clean.gammas**2)))
        noise = 0.01 * rms if args.noise is None else args.noise
        measurements = simulate_measurements(robot, trajectory, noise, args.seed)
        csv_path = write_measurements_csv(measurements_path, measurements)
        lines.append(
            f"simulated measurements: exciting trajectory ({args.harmonics} harmonics of "
            f"{args.frequency:g} Hz, {len(trajectory)} samples, condition number {cond:.4g}), "
            f"force noise std {noise:.4g} N ({100 * noise / rms:.3g} % of the RMS force "
            f"{rms:.4g} N); written to {csv_path}"
        )
        label = "true"
    result = identify(robot, measurements, base, weighted=not args.ols)
    table = result.report(base.values, label, identify_log.max_relative_std(args))
    lines += ["", table, ""]
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
            base=base,
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
        write_text_atomic(out, text + "\n")
        print(f"wrote {out}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("base-params", help="the base inertial parameters and the numerical rank")
    add_robot_args(p)
    p.add_argument(
        "--method",
        choices=("analytic", "numerical"),
        default="analytic",
        help="the paper's grouping rules (analytic) or QR of the stacked regressor",
    )
    p.add_argument(
        "--states",
        type=count_within_memory(BYTES_PER_REGRESSOR_STATE, "state"),
        default=60,
        help="random states stacked for the rank (at most what this machine's memory holds, "
        "about 36 kB each)",
    )
    p.add_argument(
        "--threshold",
        type=positive_finite_float,
        default=0.01,
        help="essential parameters: largest relative force change allowed (0.01: 1 %%)",
    )
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the random states")
    p.set_defaults(func=_cmd_base_params)

    p = sub.add_parser(
        "identify",
        help="identify the base parameters from a CSV log, or from simulated measurements",
        description="Without --csv: optimise an exciting trajectory, simulate noisy forces "
        "(written as CSV, the format --csv reads: docs/identification.md), identify and "
        "compare with the true values. With --csv: identify from the log. With --log: from "
        "a log of actuator positions and efforts (what a robot measures): state "
        "estimation, parallel decimation, weighted least squares in bounded memory, and "
        "with --physical a physically consistent robot.",
    )
    add_robot_args(p)
    p.add_argument("--csv", help="measurement log (t,x,y,z,qx,qy,qz,qw,...,gamma6; SI units)")
    p.add_argument("--validation-csv", help="a second log to validate the prediction on")
    p.add_argument(
        "--noise",
        type=non_negative_finite_float,
        help="force noise std [N] (default: 1 %% of the RMS force)",
    )
    p.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of the trajectory and the noise"
    )
    p.add_argument(
        "--samples",
        type=count_within_memory(BYTES_PER_REGRESSOR_STATE, "sample"),
        default=200,
        help="samples of the trajectory (at most what this machine's memory holds, about "
        "36 kB each)",
    )
    p.add_argument("--duration", type=positive_finite_float, help="[s] (default: one period)")
    p.add_argument("--harmonics", type=positive_int, default=5, help="Fourier harmonics per axis")
    p.add_argument(
        "--frequency", type=positive_finite_float, default=0.2, help="base frequency [Hz]"
    )
    p.add_argument(
        "--evaluations",
        type=non_negative_int,
        default=300,
        help="cost evaluations of the optimiser (0: the best random draw)",
    )
    p.add_argument("--ols", action="store_true", help="ordinary instead of weighted LS")
    p.add_argument(
        "--max-relative-std",
        type=positive_finite_float,
        metavar="PERCENT",
        help="flag a base parameter whose std exceeds this percentage of its estimate as "
        "poorly identified (default 20); a physically impossible value (a negative mass "
        "or diagonal inertia) is flagged whatever it is",
    )
    p.add_argument(
        "-o",
        "--output",
        help="write the report there too (and the CSV beside; a file: not -, the report is "
        "on standard output already)",
    )
    identify_log.add_arguments(p)
    p.set_defaults(func=_cmd_identify)
