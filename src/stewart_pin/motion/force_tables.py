"""Actuator forces given as data: a table over time, held or interpolated.

A :class:`ForceTable` is a ``forces(t, pose, twist)`` function of
:func:`~stewart_pin.motion.simulation.simulate` that ignores the state, so the compiled
simulator can run it in C (as it runs a constant and the computed-torque controller):
the same numbers either way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_increasing_times, check_scalar
from stewart_pin.exceptions import InputError

#: The interpolations of a :class:`ForceTable`.
INTERPOLATIONS = ("hold", "linear")
#: The largest magnitude of a table's value [N or N m]: the interpolation's difference of
#: two rows stays finite (far above any actuator's force), in Python and in C alike.
MAX_TABLE_VALUE = 1e150


@dataclass(frozen=True, eq=False)
class ForceTable:
    """Actuator forces [N] (general legs: the actuated joints' efforts [N or N m]) at
    ``times`` [s], shape (K, 6), between them held or interpolated.

    ``interpolation="hold"`` (piecewise constant, a zero-order hold): ``values[i]`` from
    ``times[i]`` until ``times[i + 1]``; ``"linear"``: ``values[i] + w (values[i + 1] -
    values[i])``, ``w = (t - times[i]) / (times[i + 1] - times[i])``. Before ``times[0]``
    the first row, after ``times[-1]`` the last. Arrays copied and made read-only.

    Values are finite with magnitudes at most :data:`MAX_TABLE_VALUE`, and the times
    finite with a finite span ``times[-1] - times[0]``, so that the interpolation neither
    overflows nor loses its weight (:class:`InputError` otherwise).
    """

    times: np.ndarray
    values: np.ndarray
    interpolation: str = "hold"

    def __post_init__(self) -> None:
        t = check_array(self.times, (None,), "times").copy()
        if t.size == 0:
            raise InputError("times: a force table needs at least one row")
        check_increasing_times(t)
        span = float(t[-1] - t[0])
        if not np.isfinite(span):
            raise InputError(
                f"times: the span times[-1] - times[0] = {span!r} s must be finite "
                f"(times from {float(t[0])!r} to {float(t[-1])!r} s)"
            )
        g = check_array(self.values, (t.size, 6), "values").copy()
        big = np.abs(g) > MAX_TABLE_VALUE
        if np.any(big):
            k, j = (int(x) for x in np.argwhere(big)[0])
            raise InputError(
                f"values[{k}, {j}] = {float(g[k, j])!r}: a force table's values must be at "
                f"most {MAX_TABLE_VALUE:g} [N or N m] in magnitude"
            )
        if self.interpolation not in INTERPOLATIONS:
            raise InputError(f"unknown interpolation {self.interpolation!r}: 'hold' or 'linear'")
        t.flags.writeable = False
        g.flags.writeable = False
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", g)

    @classmethod
    def constant(cls, gamma: Any) -> ForceTable:
        """The same forces (6,) at every time."""
        return cls(np.zeros(1), check_array(gamma, (6,), "forces")[None])

    def __call__(self, t: float, pose: Any = None, twist: Any = None) -> np.ndarray:
        """The forces (6,) at time ``t`` [s] (``pose`` and ``twist`` are ignored)."""
        t = check_scalar(t, "t", unit="s")
        times, values = self.times, self.values
        i = int(np.searchsorted(times, t, side="right")) - 1
        if i < 0:
            return values[0].copy()
        if self.interpolation == "hold" or i >= times.size - 1:
            return values[i].copy()
        w = (t - times[i]) / (times[i + 1] - times[i])
        return values[i] + w * (values[i + 1] - values[i])
