"""The arguments of ``stewart-pin bench`` (:mod:`.bench`), apart from the benchmark itself so
that the command's ``--help`` and argument parsing import no numerical library."""

from __future__ import annotations

import argparse
from pathlib import Path

from stewart_pin._argtypes import BYTES_PER_STATE, count_within_memory, positive_int

__all__ = ["ARCHITECTURES", "add_arguments"]

#: The architectures' presets of the default-backend rows (``welded-ups``: six welded
#: six-joint chain legs, :data:`~stewart_pin.description.chain_leg_presets.CHAIN_PRESETS`).
ARCHITECTURES = ("simulator", "rus", "pus", "welded-ups")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--preset",
        default="simulator",
        help="any preset: simulator, desktop, paper, random-<seed>, ups-offset, rus, pus, "
        "random-<kind>-<seed>",
    )
    parser.add_argument(
        "--architectures",
        type=_preset_list,
        default=ARCHITECTURES,
        help="comma-separated presets of the default-backend rows (one per architecture; "
        "also welded-ups, mixed-chain, rss-asymmetric: chain-leg robots)",
    )
    parser.add_argument(
        "--batch",
        type=count_within_memory(BYTES_PER_STATE, "state"),
        default=10_000,
        help="states per batch (at most what this machine's memory holds, about 8 kB each)",
    )
    parser.add_argument(
        "--repeats", type=positive_int, default=300, help="timed calls (the median is shown)"
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a short run: skip the 1 000 000-state batch; time the architectures, the "
        "compiled batches and the sampling at --batch states, the first derivatives call "
        "on --preset only, fewer repeats",
    )
    parser.add_argument("--json", type=Path, help="write the results as JSON here")
    parser.add_argument("--no-progress", action="store_true", help="no progress lines (on stderr)")


def _preset_list(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError("give at least one preset name")
    return names
