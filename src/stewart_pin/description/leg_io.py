"""The ``legs`` array of a description file (``docs/description.md``): six tables, one
per leg, each with its three joint tables; to and from plain dictionaries and TOML.

A leg table: ``architecture`` (one of
:data:`~stewart_pin.description.leg_architecture.ARCHITECTURES`), ``actuated`` (1, 2 or
3), ``tip`` (P_i in frame 3i [m]), optional ``branch`` (+1 / -1, default +1) and
``guess`` (start of a ``custom`` leg's Newton solve, default zeros), and ``joints``
(three tables). A joint table: ``kind`` (``revolute`` / ``prismatic``), ``alpha``, ``d``,
``theta``, ``r`` (modified DH from the previous joint frame [rad, m]; omitted = 0),
``lower``, ``upper`` (limits [rad or m]; omitted = none) and the joint dynamics
``armature``, ``viscous``, ``coulomb``, ``stiffness``, ``rest_position``, ``damping``,
``rotor_inertia`` (omitted = 0), ``gear_ratio`` or ``screw_lead`` (omitted = none); see
:class:`~stewart_pin.description.leg_architecture.JointDynamics` for the units.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

from stewart_pin.description.leg_architecture import Joint, JointDynamics, LegArchitecture
from stewart_pin.exceptions import ArchitectureError, JointDynamicsError

#: Keys of a leg table (``joints`` and ``architecture`` required, ``actuated`` too).
LEG_KEYS = ("architecture", "actuated", "tip", "branch", "guess", "joints")
#: Keys of a joint table: placement and limits.
JOINT_KEYS = ("kind", "alpha", "d", "theta", "r", "lower", "upper")
#: Keys of a joint table: the joint dynamics (omitted = 0, transmissions omitted = none).
DYNAMICS_KEYS = tuple(f.name for f in dataclasses.fields(JointDynamics))


def joint_to_dict(j: Joint) -> dict[str, Any]:
    """A joint as plain Python values: infinite limits, zero joint terms and absent
    transmissions are left out (they are the defaults)."""
    jd: dict[str, Any] = {"kind": j.kind, "alpha": j.alpha, "d": j.d, "theta": j.theta}
    jd["r"] = j.r
    for key in ("lower", "upper"):
        if math.isfinite(getattr(j, key)):
            jd[key] = getattr(j, key)
    for key in DYNAMICS_KEYS:
        value = getattr(j.dynamics, key)
        if value is not None and value != 0.0:
            jd[key] = value
    return jd


def leg_to_dict(leg: LegArchitecture) -> dict[str, Any]:
    """A leg as plain Python values: infinite limits, zero joint terms and absent
    transmissions are left out (they are the defaults)."""
    joints = [joint_to_dict(j) for j in leg.joints]
    d: dict[str, Any] = {
        "architecture": leg.name,
        "actuated": leg.actuated,
        "tip": leg.tip.tolist(),
        "branch": leg.branch,
    }
    if np.any(leg.guess):
        d["guess"] = leg.guess.tolist()
    d["joints"] = joints
    return d


def _where(i: int, j: int | None = None) -> str:
    return f"leg {i + 1}" + ("" if j is None else f" joint {j + 1}")


def _number(
    value: Any, where: str, key: str, error: type[ArchitectureError | JointDynamicsError]
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{where}: {key} must be a number, got {value!r}", key, value)
    return float(value)


def joint_from_dict(d: Any, i: int, j: int) -> Joint:
    """Joint ``j`` of leg ``i`` (0-based) from its table; errors name the leg and joint."""
    where = _where(i, j)
    if not isinstance(d, dict):
        raise ArchitectureError(
            f"{where}: a joint is a table (kind, alpha, d, theta, r, lower, upper and the "
            f"joint dynamics), got {type(d).__name__}",
            "joints",
            d,
        )
    unknown = [k for k in d if k not in JOINT_KEYS + DYNAMICS_KEYS]
    if unknown:
        raise ArchitectureError(
            f"{where}: unknown joint keys {unknown}; expected {list(JOINT_KEYS)} and "
            f"{list(DYNAMICS_KEYS)}",
            "joints",
            unknown,
        )
    if "kind" not in d:
        raise ArchitectureError(
            f"{where}: missing 'kind' ('revolute' or 'prismatic')", "kind", None
        )
    dyn: dict[str, Any] = {}
    for key in DYNAMICS_KEYS:
        if key in d:
            dyn[key] = _number(d[key], where, key, JointDynamicsError)
    place: dict[str, Any] = {}
    for key in JOINT_KEYS[1:]:
        if key in d:
            place[key] = _number(d[key], where, key, ArchitectureError)
    try:
        dynamics = JointDynamics(**dyn)
        return Joint(d["kind"], dynamics=dynamics, **place)
    except JointDynamicsError as e:
        raise JointDynamicsError(f"{where}: {e}", e.field, e.value) from e
    except ArchitectureError as e:
        raise ArchitectureError(f"{where}: {e}", e.field, e.value) from e


def leg_from_dict(d: Any, i: int) -> LegArchitecture:
    """Leg ``i`` (0-based) from its table; errors name the leg (and joint)."""
    where = _where(i)
    if not isinstance(d, dict):
        raise ArchitectureError(
            f"{where}: a leg is a table ({', '.join(LEG_KEYS)}), got {type(d).__name__}",
            "legs",
            d,
        )
    unknown = [k for k in d if k not in LEG_KEYS]
    missing = [k for k in ("architecture", "actuated", "joints") if k not in d]
    if unknown or missing:
        raise ArchitectureError(
            f"{where}: leg keys: missing {missing}, unknown {unknown}; expected "
            f"{list(LEG_KEYS)} (branch, guess and tip optional)",
            "legs",
            d,
        )
    joints = d["joints"]
    if not isinstance(joints, list) or len(joints) != 3:
        n = len(joints) if isinstance(joints, list) else type(joints).__name__
        raise ArchitectureError(
            f"{where}: a leg must be a chain of exactly three 1-dof joints, got {n}",
            "joints",
            joints,
        )
    parsed = tuple(joint_from_dict(jd, i, j) for j, jd in enumerate(joints))
    kwargs: dict[str, Any] = {"actuated": d["actuated"], "name": d["architecture"]}
    for key in ("tip", "guess"):
        if key in d:
            kwargs[key] = d[key]
    if "branch" in d:
        kwargs["branch"] = d["branch"]
    elif d["architecture"] != "custom":
        # Two assembly modes reach the same P_i with different forces: a silent default
        # could pick the one the robot is not built in. (custom legs follow their guess.)
        raise ArchitectureError(
            f"{where}: 'branch' is required (+1 or -1) for a {d['architecture']!r} leg: its "
            "closed-form inverse geometry has two solutions and the file must say which the "
            "robot is assembled in (see docs/legs.md, 'Branches')",
            "branch",
            None,
        )
    try:
        return LegArchitecture(parsed, **kwargs)
    except ArchitectureError as e:
        raise ArchitectureError(f"{where}: {e}", e.field, e.value) from e


def legs_from_value(value: Any) -> tuple[LegArchitecture, ...]:
    """Six legs from a sequence of :class:`LegArchitecture` or of leg tables."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__len__"):
        raise ArchitectureError(
            f"legs must be a list of six legs, got {type(value).__name__}", "legs", value
        )
    items = list(value)
    if len(items) != 6:
        raise ArchitectureError(
            f"legs must list six legs (one per leg of the hexapod), got {len(items)}",
            "legs",
            value,
        )
    return tuple(
        item if isinstance(item, LegArchitecture) else leg_from_dict(item, i)
        for i, item in enumerate(items)
    )


def legs_toml(legs: list[dict[str, Any]], key: str = "legs") -> str:
    """TOML arrays of tables ``[[legs]]`` / ``[[legs.joints]]`` for :func:`leg_to_dict`
    values (floats as ``repr``: ``tomllib`` reads them back exactly); ``key`` names the
    array (``chain_legs`` for :mod:`.chain_leg_io`)."""

    def value(x: Any) -> str:
        if isinstance(x, str):
            return json.dumps(x)
        if isinstance(x, bool):
            return "true" if x else "false"
        if isinstance(x, int):
            return str(x)
        if isinstance(x, float):
            return repr(x)
        return "[" + ", ".join(value(v) for v in x) + "]"

    out = []
    for i, leg in enumerate(legs):
        out.append(f"\n# leg {i + 1}\n[[{key}]]\n")
        out.extend(f"{k} = {value(v)}\n" for k, v in leg.items() if k != "joints")
        for joint in leg["joints"]:
            out.append(f"[[{key}.joints]]\n")
            out.extend(f"{k} = {value(v)}\n" for k, v in joint.items())
    return "".join(out)


__all__ = [
    "DYNAMICS_KEYS",
    "JOINT_KEYS",
    "LEG_KEYS",
    "joint_from_dict",
    "joint_to_dict",
    "leg_from_dict",
    "leg_to_dict",
    "legs_from_value",
    "legs_toml",
]
