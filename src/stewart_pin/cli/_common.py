"""What the subcommands share: the robot arguments, poses from the command line, progress,
the number types of the options and the output-path checks.

The number types (``type=`` of ``add_argument``) refuse bad values while the arguments are
parsed, so a bad number is one line on stderr and exit code 2, before any work (they live
in :mod:`stewart_pin._argtypes`, which the applications use too): :func:`positive_int`,
:func:`non_negative_int`, :func:`finite_float`, :func:`positive_finite_float`,
:func:`non_negative_finite_float`, :func:`fraction_of_one`.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from stewart_pin._argtypes import (
    finite_float,
    fraction_of_one,
    non_negative_finite_float,
    non_negative_int,
    positive_finite_float,
    positive_int,
)
from stewart_pin._io import check_destination
from stewart_pin.exceptions import InputError

if TYPE_CHECKING:  # imported where used: the command parses its arguments first
    from stewart_pin.robot import StewartRobot

__all__ = [
    "add_payload_args",
    "add_progress_arg",
    "add_robot_args",
    "check_output",
    "finite_float",
    "fraction_of_one",
    "is_stdout",
    "non_negative_finite_float",
    "non_negative_int",
    "payload_robot_from_args",
    "pose_from_args",
    "positive_finite_float",
    "positive_int",
    "progress_bar",
    "report_stream",
    "robot_from_args",
    "written",
]

#: The output path that means standard output (``-o -``), for the commands whose output
#: is one table or text (idm, simulate, import).
STDOUT = "-"


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()
    except OSError:
        return False


def is_stdout(path: str | Path | None) -> bool:
    """Whether ``path`` is ``-``: standard output."""
    return path is not None and str(path) == STDOUT


def check_output(
    path: str | Path,
    suffixes: Sequence[str] = (),
    inputs: Sequence[str | Path | None] = (),
    what: str = "output",
    stdout: bool = False,
) -> Path:
    """The output path ``path``, checked before any long computation.

    Refuses (:class:`InputError`) a suffix not in ``suffixes`` (when given), a path that
    is a folder or exists and is not a regular file (a symbolic link, a FIFO, a device:
    :func:`stewart_pin._io.check_destination`), a path naming the same file as one of
    ``inputs`` (``None`` entries skipped), and a folder that cannot be created or written.
    A missing folder is created here, up front (as the writers always did), so that a run
    never ends on it. ``-`` (standard output) is accepted with ``stdout`` (the command's
    output is one table or text: :func:`written` then writes it there), refused
    otherwise.
    """
    if is_stdout(path):
        if not stdout:
            raise InputError(
                f"{what} - (standard output) takes only a table or text output (idm, "
                "simulate, import); this output is a file of its own: give a file name"
            )
        return Path(STDOUT)
    out = Path(path)
    if suffixes and out.suffix not in suffixes:
        raise InputError(
            f"{what} {out} must end in {' or '.join(suffixes)}, got "
            f"'{out.suffix or 'no suffix'}'; choose a file name with one of those suffixes"
        )
    if out.is_dir():
        raise InputError(f"{what} {out} is a folder; give a file name")
    for source in inputs:
        if source is not None and _same_file(out, Path(source)):
            raise InputError(
                f"{what} {out} is the input file {source}: writing it would destroy the "
                "input; give another output path"
            )
    folder = out.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"{what} {out}: cannot create the folder {folder}: {e}") from e
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{what} {out}: the folder {folder} is not writable")
    return check_destination(out, what)


@contextmanager
def written(out: Path, name: str) -> Iterator[Path]:
    """The path to write an output to: ``out`` itself, or for ``-`` a file ``name`` (its
    suffix chooses the format) in a private temporary folder, copied to standard output
    once the ``with`` block succeeds (nothing is written there on an error)."""
    if not is_stdout(out):
        yield out
        return
    with tempfile.TemporaryDirectory(prefix="stewart-pin-") as folder:
        path = Path(folder) / name
        yield path
        sys.stdout.flush()
        with open(path, "rb") as handle:
            shutil.copyfileobj(handle, sys.stdout.buffer)
        sys.stdout.buffer.flush()


def report_stream(out: Path | None) -> Any:
    """Where a command prints its summary: standard error when its output goes to
    standard output (``-o -``), else standard output."""
    return sys.stderr if out is not None and is_stdout(out) else sys.stdout


#: The help of every ``--preset`` option: each name :func:`~stewart_pin.preset` takes.
PRESET_HELP = (
    "simulator, desktop, paper, random-<seed> (ideal 6-UPS); ups-offset, rus, pus, "
    "random-<kind>-<seed> with kind ups, ups-offset, rus, pus or custom (general legs)"
)


def add_robot_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--preset", default="simulator", help=PRESET_HELP)
    g.add_argument("--description", help="a robot description file (.toml or .json)")
    g.add_argument(
        "--model",
        help="a robot model file to import: MJCF (.xml), URDF (.urdf, its loop closures "
        "from the sidecar or closing_<k>_1/_2 frames) or Gazebo SDF (.sdf); see "
        "`stewart-pin import`",
    )


def robot_from_args(args: argparse.Namespace) -> StewartRobot:
    """The robot of ``--preset`` / ``--description`` / ``--model`` (imported): every
    command takes every leg architecture."""
    from stewart_pin.robot import StewartRobot

    if getattr(args, "description", None):
        robot = StewartRobot.from_file(args.description)
    elif getattr(args, "model", None):
        robot = _imported_robot(args)
    else:
        robot = StewartRobot.from_preset(args.preset)
    return robot


#: The short import notes already printed in this process (each said once).
_NOTES_SAID: set[str] = set()


def _imported_robot(args: argparse.Namespace) -> StewartRobot:
    """The robot of ``--model``; the importer's warnings (rounded loops, nearly parallel
    axes...) printed as one line each on stderr rather than as Python warnings with a
    source line. A warning with a short form (the loops' residual, which every ``--model``
    command would repeat) is a short note, once per process, pointing at ``stewart-pin
    import``, which prints it whole."""
    from stewart_pin.exceptions import ModelImportWarning
    from stewart_pin.importers import import_model
    from stewart_pin.robot import StewartRobot

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = StewartRobot(import_model(args.model).description)
    command = getattr(args, "command", None) or "stewart-pin"
    for w in caught:
        if not issubclass(w.category, ModelImportWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            continue
        short = getattr(w.message, "short", None)
        if short is None:
            message = " ".join(str(w.message).split())
            print(f"stewart-pin {command}: warning: {message}", file=sys.stderr)
        elif short not in _NOTES_SAID:
            _NOTES_SAID.add(short)
            print(
                f"stewart-pin {command}: note: {short} (`stewart-pin import` says more)",
                file=sys.stderr,
            )
    return robot


def pose_from_args(values: Sequence[float] | None, robot: StewartRobot) -> np.ndarray:
    """A pose from ``x y z roll pitch yaw`` [m, rad] relative to the home pose, in F0."""
    import pinocchio as pin

    T = robot.home_pose
    if values is not None:
        T[:3, 3] += values[:3]
        T[:3, :3] = pin.rpy.rpyToMatrix(*values[3:]) @ T[:3, :3]
    return T


class _DeprecatedFlag(argparse.Action):
    """A flag kept under an old name: sets ``dest`` as the new flag does, with a one-line
    warning on stderr naming the new one."""

    def __init__(self, option_strings: Sequence[str], dest: str, new: str, **kwargs: Any):
        super().__init__(option_strings, dest, nargs=0, default=False, **kwargs)
        self.new = new

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        print(
            f"{parser.prog}: warning: {option_string} is deprecated, use {self.new}",
            file=sys.stderr,
        )
        setattr(namespace, self.dest, True)


def add_progress_arg(p: Any) -> None:
    """``--no-progress`` (``args.no_progress``): no progress bar. ``--quiet``, which meant
    the same on ``simulate``, is kept as a deprecated alias (a warning on stderr)."""
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--quiet",
        dest="no_progress",
        action=_DeprecatedFlag,
        new="--no-progress",
        help=argparse.SUPPRESS,
    )


@contextmanager
def progress_bar(total: float, unit: str, enabled: bool = True) -> Iterator[Any]:
    """A tqdm bar over ``total`` (e.g. simulated seconds) whose ``.to(x)`` moves it to x."""
    from tqdm import tqdm

    fmt = "{l_bar}{bar}| {n:.3g}/{total:.3g} {unit} [{elapsed}<{remaining}]"
    with tqdm(total=total, unit=unit, disable=not enabled, leave=False, bar_format=fmt) as bar:

        def to(x: float) -> None:
            bar.update(min(x, total) - bar.n)

        bar.to = to
        yield bar


def add_payload_args(p: argparse.ArgumentParser) -> None:
    """``--payload NAME`` and ``--payload-placement x y z roll pitch yaw``."""
    p.add_argument(
        "--payload",
        metavar="NAME",
        help="a robot carried on the platform: a name of example-robot-data (ur5, panda, "
        'so101...; pip install "stewart-pin[payload]") or a URDF file',
    )
    p.add_argument(
        "--payload-placement",
        type=finite_float,
        nargs=6,
        metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
        help="the payload's base frame in the platform frame Fp [m, rad] (default: on the "
        "platform's deck, 0.1 x the robot's size above the centroid of the platform joints, "
        "axes along Fp's)",
    )


def payload_robot_from_args(args: argparse.Namespace, robot: StewartRobot) -> Any:
    """The :class:`~stewart_pin.payload_robot.PayloadRobot` of ``--payload`` on ``robot``,
    or ``None`` without ``--payload``."""
    name = getattr(args, "payload", None)
    if not name:
        options = ("placement", "fraction", "period")
        given = [
            f"--payload-{o}" for o in options if getattr(args, f"payload_{o}", None) is not None
        ]
        if getattr(args, "payload_shapes", False):
            given.append("--payload-shapes")
        if given:
            raise InputError(
                f"{', '.join(given)} {'needs' if len(given) == 1 else 'need'} --payload"
            )
        return None
    placement = None
    values = getattr(args, "payload_placement", None)
    if values is not None:
        import pinocchio as pin

        placement = np.eye(4)
        placement[:3, :3] = pin.rpy.rpyToMatrix(*values[3:])
        placement[:3, 3] = values[:3]
    return robot.with_payload(name, placement)
