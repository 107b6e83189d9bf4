"""Number types for ``argparse`` options (``type=`` of ``add_argument``): each refuses a
bad value while the arguments are parsed (one line on stderr, exit code 2). Shared by
the command line (:mod:`stewart_pin.cli`) and the applications' own parsers."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any

__all__ = [
    "finite_float",
    "fraction_of_one",
    "non_negative_finite_float",
    "non_negative_int",
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
