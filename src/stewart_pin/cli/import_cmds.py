"""``import``: a robot from its MJCF, URDF or SDF, printed and written as a description."""

from __future__ import annotations

import argparse
import warnings

from stewart_pin.cli._common import check_output, positive_finite_float, report_stream, written
from stewart_pin.exceptions import InputError


def _import(args: argparse.Namespace) -> int:
    from stewart_pin.importers import import_mjcf, import_sdf, import_urdf, model_format
    from stewart_pin.robot import StewartRobot

    out = (
        check_output(args.output, (".toml", ".json"), [args.model], stdout=True)
        if args.output
        else None
    )
    report = report_stream(out)
    options: dict[str, object] = {
        "platform": args.platform,
        "name": args.name,
        "closure_tolerance": args.closure_tolerance,
        "rod_spin": args.rod_spin,
        "approximate_legs": args.approximate_legs,
    }
    kind = model_format(args.model)  # one line for a format not read
    ignored = [
        (option, formats)
        for option, value, formats in (
            ("--keyframe", args.keyframe, ("mjcf",)),
            ("--closures", args.closures, ("urdf",)),
            ("--closure-pairs", args.closure_pairs, ("urdf",)),
            ("--actuated", args.actuated, ("urdf", "sdf")),
        )
        if value is not None and kind not in formats
    ]
    if ignored:
        names = {"urdf": "URDF", "mjcf": "MJCF", "sdf": "SDF"}
        option, formats = ignored[0]
        then = " and ".join(names[f] for f in formats)
        raise InputError(
            f"{option} only applies to {then} files, and {args.model} is "
            f"{'a' if kind == 'urdf' else 'an'} {names[kind]} model (by its suffix): leave it out"
        )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if kind == "sdf":
            result = import_sdf(args.model, args.actuated, **options)  # type: ignore[arg-type]
        elif kind == "urdf":
            closures = args.closures
            if args.closure_pairs:
                closures = [tuple(pair.split("=", 1)) for pair in args.closure_pairs]
            result = import_urdf(args.model, closures, args.actuated, **options)  # type: ignore[arg-type]
        else:
            text: str | None = args.keyframe
            keyframe: str | int | None = text
            if text is not None and text.isdigit():
                keyframe = int(text)
            result = import_mjcf(args.model, keyframe=keyframe, **options)  # type: ignore[arg-type]
        robot = StewartRobot(result.description)  # the home pose checked as for any robot
        if result.report.approximations:  # their effect on the efforts, in the report
            from stewart_pin.check.import_effects import import_effects

            import_effects(result, robot)
    print(result.report, file=report)
    for w in caught:
        print(f"warning: {' '.join(str(w.message).split())}", file=report)
    if out is not None:
        with written(out, "robot.toml") as path:
            robot.write(path)
        print(f"wrote {out}", file=report)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "import",
        help="import a robot from its MJCF, URDF or SDF: print what was recognised, write it",
        description="Reads MODEL (MJCF .xml through MuJoCo, URDF .urdf with its loop "
        "closures, or Gazebo SDF .sdf / .world), recognises the base, the platform and six "
        "legs, prints the legs, joints, actuated joints, lumped bodies, loop residuals and "
        "joint terms, and with -o writes the robot description (docs/importing.md).",
    )
    p.add_argument("model", help="the model file: MJCF (.xml), URDF (.urdf) or SDF (.sdf)")
    p.add_argument(
        "-o",
        "--output",
        help="the description to write (.toml or .json); - writes the TOML to standard "
        "output (the report then goes to standard error)",
    )
    p.add_argument("--name", help="the robot's name (default: the model's, made valid)")
    p.add_argument("--platform", help="the body whose frame is Fp (default: found)")
    p.add_argument(
        "--keyframe", help="MJCF: the reference keyframe, a name or an index (default: home)"
    )
    p.add_argument("--closures", help="URDF: the closure sidecar (default: <stem>.closures.json)")
    p.add_argument(
        "--closure-pairs",
        nargs="+",
        metavar="LINK1=LINK2",
        help="URDF: loop closures as pairs of links or frames whose origins coincide",
    )
    p.add_argument(
        "--actuated",
        nargs=6,
        metavar="JOINT",
        help="URDF, SDF: actuated joints, leg order (SDF default: each leg's one revolute or "
        "prismatic joint, in file order)",
    )
    p.add_argument(
        "--closure-tolerance",
        type=positive_finite_float,
        default=1e-2,
        help="largest loop residual at the reference, relative to the platform's size",
    )
    p.add_argument(
        "--rod-spin",
        choices=("error", "warn"),
        default="error",
        help="an S-S rod not symmetric about its axis: refuse, or import it with a warning",
    )
    p.add_argument(
        "--approximate-legs",
        action="store_true",
        help="take three hinges that nearly meet (a spin + U-joint top, massive links) as an "
        "ideal ball, their masses and joint terms dropped, instead of reading the leg as it "
        "is (a chain leg); reported with its effect on the efforts",
    )
    p.set_defaults(func=_import)
