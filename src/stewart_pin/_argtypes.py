"""Number types for ``argparse`` options (``type=`` of ``add_argument``): each refuses a
bad value while the arguments are parsed (one line on stderr, exit code 2). Shared by
the command line (:mod:`stewart_pin.cli`) and the applications' own parsers."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from typing import Any

__all__ = [
    "count_within_memory",
    "duration_within_memory",
    "finite_float",
    "fraction_of_one",
    "non_negative_finite_float",
    "non_negative_int",
    "physical_memory",
    "positive_finite_float",
    "positive_int",
]


def _parser(
    convert: Callable[[str], Any], accept: Callable[[Any], bool], expected: str
) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        try:
            value = convert(text)
        except ValueError:
            value = None
        if value is None or not accept(value):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    parse.__name__ = expected
    return parse


#: An integer >= 1 (a count: states, samples, repeats...).
positive_int = _parser(int, lambda x: x >= 1, "an integer >= 1")
#: An integer >= 0 (a seed, a budget that may be zero).
non_negative_int = _parser(int, lambda x: x >= 0, "an integer >= 0")
#: A finite number (no nan, no inf).
finite_float = _parser(float, math.isfinite, "a finite number")
#: A finite number > 0 (a duration, a period, a frequency...).
positive_finite_float = _parser(
    float, lambda x: math.isfinite(x) and x > 0.0, "a finite number > 0"
)
#: A finite number >= 0 (a tolerance, a noise level, a range).
non_negative_finite_float = _parser(
    float, lambda x: math.isfinite(x) and x >= 0.0, "a finite number >= 0"
)
#: A number in (0, 1] (a fraction of a range).
fraction_of_one = _parser(float, lambda x: 0.0 < x <= 1.0, "a number in (0, 1]")


#: Memory a command holds per unit of its size option [bytes], measured with
#: ``tracemalloc`` (peak, between two sizes, 6-UPS ``simulator`` preset; ``docs/errors.md``)
#: and rounded up: ``validate`` and ``bench`` about 8 kB per state, ``base-params`` and
#: ``identify`` (simulated) about 36 kB per state or sample, ``animate`` about 630 kB per
#: second of motion (60 frames).
BYTES_PER_STATE = 10_000
BYTES_PER_REGRESSOR_STATE = 40_000
BYTES_PER_ANIMATION_SECOND = 700_000


def physical_memory() -> int | None:
    """This machine's physical memory [bytes] (``os.sysconf``), ``None`` where unknown."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _memory_problem(value: float, bytes_each: float, unit: str) -> str | None:
    """Why ``value`` units of ``bytes_each`` [bytes] do not fit in physical memory, or
    ``None`` when they do (or the memory is unknown)."""
    total = physical_memory()
    need = value * bytes_each
    if total is None or need <= total:
        return None
    return (
        f"{value:g} {unit}s need about {need / 1e9:.3g} GB of memory ({bytes_each / 1e3:g} kB "
        f"per {unit}), more than this machine's {total / 1e9:.3g} GB: give at most "
        f"{math.floor(total / bytes_each):d}"
    )


def count_within_memory(bytes_each: float, unit: str) -> Callable[[str], int]:
    """An integer >= 1 (a count of ``unit``s) whose memory, about ``bytes_each`` [bytes]
    per ``unit``, fits in this machine's physical memory (:func:`physical_memory`)."""
    base = positive_int

    def parse(text: str) -> int:
        value = int(base(text))
        problem = _memory_problem(value, bytes_each, unit)
        if problem is not None:
            raise argparse.ArgumentTypeError(problem)
        return value

    parse.__name__ = f"an integer >= 1 ({unit}s)"
    parse.within_memory = True  # type: ignore[attr-defined]
    return parse


def duration_within_memory(bytes_per_second: float) -> Callable[[str], float]:
    """A finite duration > 0 [s] whose memory, about ``bytes_per_second`` [bytes] per
    second, fits in this machine's physical memory (:func:`physical_memory`)."""

    def parse(text: str) -> float:
        value = float(positive_finite_float(text))
        problem = _memory_problem(value, bytes_per_second, "second")
        if problem is not None:
            raise argparse.ArgumentTypeError(problem)
        return value

    parse.__name__ = "a finite duration > 0 [s]"
    parse.within_memory = True  # type: ignore[attr-defined]
    return parse
