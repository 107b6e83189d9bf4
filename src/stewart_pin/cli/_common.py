"""What the subcommands share: the robot arguments, poses from the command line, progress."""

from __future__ import annotations

import argparse
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
import pinocchio as pin

from ..robot import StewartRobot


def add_robot_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--preset", default="simulator", help="simulator, desktop, paper, random-<seed>"
    )
    g.add_argument("--description", help="a robot description file (.toml or .json)")


def robot_from_args(args: argparse.Namespace) -> StewartRobot:
    if getattr(args, "description", None):
        return StewartRobot.from_file(args.description)
    return StewartRobot.from_preset(args.preset)


def pose_from_args(values: Sequence[float] | None, robot: StewartRobot) -> np.ndarray:
    """A pose from ``x y z roll pitch yaw`` [m, rad] relative to the home pose, in F0."""
    T = robot.home_pose
    if values is not None:
        T[:3, 3] += values[:3]
        T[:3, :3] = pin.rpy.rpyToMatrix(*values[3:]) @ T[:3, :3]
    return T


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
