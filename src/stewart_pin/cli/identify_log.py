"""``identify --log FILE``: identification from a log of actuator positions and efforts.

The lab workflow (``docs/identification.md``): read and check the log, estimate the
platform states (filter, forward geometry, derivatives), accumulate the parallel-decimated
equations chunk by chunk with a progress bar, solve by weighted least squares, then
(``--physical``) fit physically consistent standard parameters, report both estimates'
effort prediction error on a validation log, and write the identified robot.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from stewart_pin._extras import require
from stewart_pin._io import write_text_atomic
from stewart_pin.cli._common import (
    add_progress_arg,
    check_output,
    positive_finite_float,
    positive_int,
    progress_bar,
)
from stewart_pin.cli._common import robot_from_args as _robot
from stewart_pin.exceptions import InputError, PhysicalFitError


def _outputs(args: argparse.Namespace, inputs: list[str | None]) -> dict[str, Path | None]:
    """Every output path, checked before the work starts."""
    out: dict[str, Path | None] = {"report": None, "description": None, "urdf": None, "mjcf": None}
    if args.output:
        out["report"] = check_output(args.output, (), inputs, "-o")
    if args.write_description:
        out["description"] = check_output(
            args.write_description, (".toml", ".json"), inputs, "--write-description"
        )
    if args.write_urdf:
        out["urdf"] = check_output(args.write_urdf, (".urdf",), inputs, "--write-urdf")
    if args.write_mjcf:
        out["mjcf"] = check_output(args.write_mjcf, (".xml",), inputs, "--write-mjcf")
    if any(out[k] for k in ("description", "urdf", "mjcf")) and not args.physical:
        raise InputError(
            "--write-description, --write-urdf and --write-mjcf write the physically "
            "consistent robot: add --physical"
        )
    return out


def max_relative_std(args: argparse.Namespace) -> float:
    """``--max-relative-std`` [%], default
    :data:`~stewart_pin.parameters.identification.MAX_RELATIVE_STD`."""
    from stewart_pin.parameters.identification import MAX_RELATIVE_STD

    return MAX_RELATIVE_STD if args.max_relative_std is None else args.max_relative_std


def run(args: argparse.Namespace) -> int:
    """The ``identify --log`` command."""
    from stewart_pin.formats.mjcf import write_mjcf
    from stewart_pin.formats.urdf import write_urdf
    from stewart_pin.parameters.base import base_parameters
    from stewart_pin.parameters.identification import (
        base_without,
        identify_log,
        log_prediction_error,
    )
    from stewart_pin.parameters.logs import read_log
    from stewart_pin.parameters.state_estimation import design_filters

    if args.csv:
        raise InputError("give --log (actuator log) or --csv (measurement CSV), not both")
    inputs = [args.log, args.validation_log, args.description]
    outputs = _outputs(args, inputs)
    if args.physical:  # the ident extra before the work
        require("identify --physical", "ident", "cvxpy")
    robot = _robot(args)
    log = read_log(args.log, robot)
    base = base_parameters(robot, args.method)
    if args.assume_zero:
        base = base_without(base, [s.strip() for s in args.assume_zero.split(",") if s.strip()])
    design = design_filters(log, args.cutoff, args.decimation, args.filter)
    lines = [
        f"robot '{robot.name}' ({robot.architecture}): {len(base)} base parameters"
        + (f" (assumed zero: {args.assume_zero})" if args.assume_zero else "")
    ]
    with progress_bar(1.0, "of the log", enabled=not args.no_progress) as bar:
        ident = identify_log(
            robot,
            log,
            base,
            design=design,
            weighted=not args.ols,
            progress=lambda done, total: bar.to(done / total),
        )
    result = ident.result
    lines += [ident.report(max_relative_std=max_relative_std(args)), ""]
    physical = None
    if args.physical:
        from stewart_pin.parameters.physical import physically_consistent

        try:
            physical = physically_consistent(robot, ident)
        except PhysicalFitError:  # the least-squares report still shown; nothing written
            print("\n".join(lines))
            raise
        lines += [
            "physically consistent estimate (every body's pseudo-inertia positive definite, "
            f"joint terms non-negative; solver {physical.solver}): weighted residual "
            f"+{100 * physical.fit_loss:.3g} % over least squares, Mahalanobis distance "
            f"{physical.mahalanobis:.4g} ({len(base)} parameters)",
            f"{'parameter':>12s} {'least squares':>14s} {'physical':>14s}",
        ]
        for name, a, b in zip(base.names, result.estimate, physical.base_values, strict=True):
            lines.append(f"{name:>12s} {a:14.6g} {b:14.6g}")
        lines.append("")
    if args.validation_log:
        validation = read_log(args.validation_log, robot)
        err = log_prediction_error(robot, validation, result.estimate, base, design)
        lines.append(
            f"validation on {args.validation_log}: relative RMS effort error (filtered, "
            f"decimated) {100 * err:.4g} % (least squares)"
        )
        if physical is not None:
            err_p = log_prediction_error(robot, validation, physical.base_values, base, design)
            lines.append(
                f"{'':>{len('validation on ' + args.validation_log) + 2}}"
                f"{100 * err_p:.4g} % (physically consistent)"
            )
    else:
        lines.append("validation: give --validation-log FILE (a second log) to measure it")
    if physical is not None:
        desc = physical.description
        if outputs["description"]:
            lines.append(f"wrote {desc.write(outputs['description'])}")
        if outputs["urdf"]:
            urdf, sidecar = write_urdf(desc, outputs["urdf"])
            lines.append(f"wrote {urdf} and {sidecar}")
        if outputs["mjcf"]:
            lines.append(f"wrote {write_mjcf(desc, outputs['mjcf'])}")
    text = "\n".join(lines)
    print(text)
    if outputs["report"]:
        write_text_atomic(outputs["report"], text + "\n")
        print(f"wrote {outputs['report']}")
    return 0


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The ``--log`` options of ``identify``."""
    g = p.add_argument_group("from an actuator log (docs/identification.md)")
    g.add_argument(
        "--log",
        help="actuator log: t, l1..l6 (actuated joint positions), gamma1..gamma6 (efforts), "
        "optionally x y z qx qy qz qw (tracker)",
    )
    g.add_argument("--validation-log", help="a second actuator log to validate the prediction on")
    g.add_argument(
        "--cutoff",
        type=positive_finite_float,
        help="state filter cut-off [Hz] (default: 10 times the excitation bandwidth)",
    )
    g.add_argument(
        "--decimation",
        type=positive_int,
        help="decimation factor (default: from the bandwidth; 1: none)",
    )
    g.add_argument(
        "--filter",
        choices=("butterworth", "savgol"),
        default="butterworth",
        help="the zero-phase state filter",
    )
    g.add_argument(
        "--method",
        choices=("analytic", "numerical"),
        default="analytic",
        help="base parameters by the grouping rules or by QR",
    )
    g.add_argument(
        "--assume-zero",
        help="standard parameters known to be zero, comma-separated: names (K2_4), joint "
        "terms of every joint (K, OF, IA, FV, FC) or of the passive ones (FV@passive)",
    )
    g.add_argument(
        "--physical",
        action="store_true",
        help="also fit physically consistent standard parameters (needs cvxpy: the ident extra)",
    )
    g.add_argument("--write-description", help="write the identified robot (.toml or .json)")
    g.add_argument("--write-urdf", help="write the identified robot as URDF (+ sidecar)")
    g.add_argument("--write-mjcf", help="write the identified robot as MJCF (.xml)")
    add_progress_arg(g)
