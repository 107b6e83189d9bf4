"""The ``stewart-pin`` command.

Units and frames everywhere: SI (m, rad, N, kg, s). A pose is 0Tp, the platform frame Fp
in the base frame F0; a twist [v, w] is the velocity of the origin of Fp and the angular
velocity, both in F0; accelerations are classical (d/dt of [v, w]). Gamma_i is the
effort of actuator i from its joint type: a force [N] for a prismatic actuator (positive
when it extends the leg), a torque [N m] for a revolute one (RUS cranks), joint side.

Bad inputs exit with code 2 and a one-line message (``--debug`` shows the traceback);
Ctrl-C with code 130 and one line (``simulate`` saves the states so far first). Every
``--help`` shows the options' defaults. Output piped into a reader that stops early
(``stewart-pin base-params | head``) ends the command quietly with code 141 (128 + SIGPIPE,
what a shell reports for a Unix tool ended by the closed pipe).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import Any

from stewart_pin import __version__
from stewart_pin.cli import (
    design_cmds,
    dynamics_cmds,
    export_cmds,
    geometry_cmds,
    import_cmds,
    motion_cmds,
    parameters_cmds,
)
from stewart_pin.exceptions import StewartPinError

#: The exit code after Ctrl-C (128 + SIGINT, as a shell reports it).
INTERRUPTED = 130


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions as written; ``(default: X)`` after the help of every option that takes a
    value and has a default (without one, the help says what happens: "default: one period").
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        help = action.help
        if (
            help is None
            or "%(default)" in help
            or not action.option_strings
            or action.nargs == 0  # flags (--no-progress) and --help / --version
            or action.default is None
            or action.default is argparse.SUPPRESS
        ):
            return help
        return f"{help} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line, exit code 2; defaults shown in every ``--help`` (the
    subcommands' parsers are of this class too)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="stewart-pin",
        description=__doc__,
    )
    parser.add_argument("--version", action="version", version=f"stewart-pin {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    modules = (
        geometry_cmds,
        dynamics_cmds,
        parameters_cmds,
        motion_cmds,
        import_cmds,
        export_cmds,
        design_cmds,
    )
    for module in modules:
        module.register(sub)
    return parser


#: Exit code when the reader of the standard output goes away (``| head``): 128 + SIGPIPE,
#: as a shell reports a Unix tool ended by the closed pipe.
EXIT_BROKEN_PIPE = 141


def _stdout_to_devnull() -> None:
    """Point the standard output at /dev/null, so that the interpreter's flush at exit
    writes nowhere instead of reporting the closed pipe again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    finally:
        os.close(devnull)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code: int = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not at the interpreter's exit
        return code
    except BrokenPipeError:  # the reader stopped early (| head): quietly, as Unix tools
        _stdout_to_devnull()
        return EXIT_BROKEN_PIPE
    except (StewartPinError, OSError) as e:
        if args.debug:
            raise
        message = " ".join(str(e).split())  # one line
        print(f"stewart-pin {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:  # Ctrl-C: one line, the shell's code for SIGINT
        if args.debug:
            raise
        note = " ".join(str(e).split()) or "interrupted"
        print(f"stewart-pin {args.command}: {note}", file=sys.stderr)
        return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
