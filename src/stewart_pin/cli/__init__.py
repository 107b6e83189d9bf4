"""The ``stewart-pin`` command.

Units and frames everywhere: SI (m, rad, N, kg, s). A pose is 0Tp, the platform frame Fp
in the base frame F0; a twist [v, w] is the velocity of the origin of Fp and the angular
velocity, both in F0; accelerations are classical (d/dt of [v, w]). Gamma_i [N] is the
force of actuator i, positive when it extends the leg.

Bad inputs exit with code 2 and a one-line message (``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from stewart_pin.cli import dynamics_cmds, geometry_cmds, motion_cmds, parameters_cmds
from stewart_pin.exceptions import StewartPinError


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line, exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="stewart-pin",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (geometry_cmds, dynamics_cmds, parameters_cmds, motion_cmds):
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (StewartPinError, OSError) as e:
        if args.debug:
            raise
        message = " ".join(str(e).split())  # one line
        print(f"stewart-pin {args.command}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
