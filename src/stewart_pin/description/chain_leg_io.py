"""The ``chain_legs`` array of a description file (``docs/legs.md``, "Chain legs and
welds"): six tables, one per :class:`~stewart_pin.description.chain_leg.ChainLeg`, each
with its joint tables; to and from plain dictionaries.

A chain leg table: ``actuated`` (1..n), ``closure`` (``"ball"`` or ``"weld"``),
``inertia`` (n rows of 10: Khalil's parameters of each link in its frame [kg, kg m,
kg m^2]), ``joints`` (n joint tables, as for three-joint legs:
:func:`~stewart_pin.description.leg_io.joint_from_dict`), and optionally ``tip`` (3,)
[m], ``tip_rotation`` and ``platform_rotation`` (3 x 3, weld), ``guess`` (n,),
``idle_joint`` and ``gravcomp`` (n,): each link's gravity compensation, the fraction of its
weight removed (in [0, 1]; left out when every link has its full weight).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from stewart_pin.description.chain_leg import ChainLeg, check_chain_legs
from stewart_pin.description.leg_io import joint_from_dict, joint_to_dict
from stewart_pin.exceptions import ArchitectureError, GravityCompensationError

#: Keys of a chain leg table (``actuated``, ``closure``, ``inertia`` and ``joints``
#: required).
CHAIN_LEG_KEYS = (
    "actuated",
    "closure",
    "inertia",
    "tip",
    "tip_rotation",
    "platform_rotation",
    "guess",
    "idle_joint",
    "gravcomp",
    "joints",
)
_REQUIRED = ("actuated", "closure", "inertia", "joints")


def chain_leg_to_dict(leg: ChainLeg) -> dict[str, Any]:
    """A chain leg as plain Python values (identity rotations, a zero guess, no idle
    joint and no gravity compensation left out: the defaults)."""
    d: dict[str, Any] = {
        "actuated": leg.actuated,
        "closure": leg.closure,
        "tip": leg.tip.tolist(),
        "inertia": leg.inertia.tolist(),
    }
    for key in ("tip_rotation", "platform_rotation"):
        R = getattr(leg, key)
        if not np.array_equal(R, np.eye(3)):
            d[key] = R.tolist()
    if np.any(leg.guess):
        d["guess"] = leg.guess.tolist()
    if leg.idle_joint is not None:
        d["idle_joint"] = leg.idle_joint
    if np.any(leg.gravcomp):
        d["gravcomp"] = leg.gravcomp.tolist()
    d["joints"] = [joint_to_dict(j) for j in leg.joints]
    return d


def chain_leg_from_dict(d: Any, i: int) -> ChainLeg:
    """Chain leg ``i`` (0-based) from its table; errors name the leg (and joint)."""
    where = f"chain leg {i + 1}"
    if not isinstance(d, dict):
        raise ArchitectureError(
            f"{where}: a chain leg is a table ({', '.join(CHAIN_LEG_KEYS)}), got "
            f"{type(d).__name__}",
            "chain_legs",
            d,
        )
    unknown = [k for k in d if k not in CHAIN_LEG_KEYS]
    missing = [k for k in _REQUIRED if k not in d]
    if unknown or missing:
        raise ArchitectureError(
            f"{where}: keys: missing {missing}, unknown {unknown}; expected "
            f"{list(CHAIN_LEG_KEYS)} ({', '.join(_REQUIRED)} required)",
            "chain_legs",
            d,
        )
    joints = d["joints"]
    if not isinstance(joints, list) or not joints:
        raise ArchitectureError(
            f"{where}: 'joints' must be a non-empty list of joint tables", "joints", joints
        )
    parsed = tuple(joint_from_dict(jd, i, j) for j, jd in enumerate(joints))
    kwargs = {k: d[k] for k in CHAIN_LEG_KEYS[:-1] if k in d}
    try:
        return ChainLeg(parsed, **kwargs)
    except ArchitectureError as e:
        raise ArchitectureError(f"{where}: {e}", e.field, e.value) from e
    except GravityCompensationError as e:
        body = e.body.replace("chain leg", where) if e.body != "gravcomp" else where
        error = GravityCompensationError(f"{where}: {e}", body, e.value)
        error.key = "chain_legs"  # type: ignore[attr-defined] # read() quotes its line
        raise error from e


def chain_legs_from_value(value: Any) -> tuple[ChainLeg, ...]:
    """Six chain legs from :class:`ChainLeg` or leg tables, each checked for its mobility
    (:func:`~stewart_pin.description.chain_leg.check_chain_legs`)."""
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)):
        items = list(value)
        if len(items) == 6:
            value = [
                item if isinstance(item, ChainLeg) else chain_leg_from_dict(item, i)
                for i, item in enumerate(items)
            ]
    return check_chain_legs(value)


__all__ = ["CHAIN_LEG_KEYS", "chain_leg_from_dict", "chain_leg_to_dict", "chain_legs_from_value"]
