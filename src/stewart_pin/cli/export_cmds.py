"""``export-c``: the closed-form models as a standalone C99 library."""

from __future__ import annotations

import argparse

from stewart_pin.cli._common import add_robot_args, positive_int, robot_from_args


def _export_c(args: argparse.Namespace) -> int:
    from stewart_pin.codegen.c_export import check_folder, check_prefix

    check_prefix(args.prefix)  # before building the robot
    check_folder(args.output, args.prefix)
    robot = robot_from_args(args)
    paths = robot.export_c(
        args.output, prefix=args.prefix, samples=args.samples, derivatives=args.derivatives
    )
    folder = paths[0].parent
    print(f"wrote {len(paths)} files to {folder}: {', '.join(p.name for p in paths)}")
    print(
        f"build and check: cmake -S {folder} -B {folder}/build && cmake --build "
        f"{folder}/build && ctest --test-dir {folder}/build"
    )
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export-c",
        help="write the models as a standalone C99 library (no Python, no allocation)",
        description="Write PREFIX.h / PREFIX.c (inverse and forward geometry, Jp^-1, "
        "inverse and direct dynamics; no CasADi, no Python, no heap allocation), a test "
        "program with reference values of the Python path, a benchmark, a C++ control-loop "
        "example, CMakeLists.txt and README.md into a new folder (see docs/export_c.md).",
    )
    add_robot_args(p)
    p.add_argument(
        "--prefix",
        required=True,
        help="a C identifier (letter, then letters, digits, _): the files' and functions' prefix",
    )
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="the output folder: new, or holding only a previous export with this prefix",
    )
    p.add_argument(
        "--samples",
        type=positive_int,
        default=8,
        help="random states embedded in the test program with their reference values "
        "(at most 1000)",
    )
    p.add_argument(
        "--derivatives",
        action="store_true",
        help="also export PREFIX_inverse_dynamics_derivatives (Gamma's Jacobians in the "
        "pose chart, the twist and the acceleration; a longer source to compile)",
    )
    p.set_defaults(func=_export_c)
