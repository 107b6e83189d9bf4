"""Operation counts of the generated models, beside the paper's Table IV (section VII).

Counting rules (walking a CasADi SX function's instructions after common sub-expression
elimination, :func:`count_operations`):

- multiplications ``x``: ``OP_MUL`` and ``OP_SQ`` (``x^2`` is one multiplication);
  multiplications by a constant count like any other (after SX simplification, no
  multiplication by 0, 1 or -1 is left);
- additions ``+``: ``OP_ADD``, ``OP_SUB`` and ``OP_TWICE`` (``2x`` is ``x + x``);
- divisions (``OP_DIV``, ``OP_INV``) in a column of their own, and in the total: SX
  folds ``x * (1/y)`` into ``x / y``, so where a hand-written program computes one
  reciprocal and multiplies, the generated code divides (the LU and ``L D L^T`` pivots);
  the total ``x + / + +`` therefore counts a division like a multiplication, as the
  paper's two-column counts must have;
- counted apart, and not in the total: square roots (two per leg: ``1/q3`` and
  ``1/rho``), trigonometric calls (none), negations (``OP_NEG``: a sign flip, which a
  hand-written program folds into the next ``+``/``-``); comparisons and absolute values
  (``OP_FABS``, ``OP_FMAX``..., only in the guarded variants);
- not operations: loading an input or a constant, storing an output.

What is counted: the models start from the pose as the 4x4 matrix 0Tp (position and
rotation matrix; the ``quaternion`` variant adds the 9 x and 15 + of the rotation from a
unit quaternion), the twist, and the acceleration (IDM) or the actuator forces (DDM); the
leg inverse geometry (no trigonometry: ``q3`` and ``q3 sin q2`` are two square roots, and
every sine and cosine the models need is a ratio of them), the first- and second-order
kinematics, and everything up to Gamma (IDM) or the platform acceleration (DDM) are in
the count. The base inertial parameters are inputs (``"base"``: all 88 symbolic; Table
IV's 2078 uses the 52 essential parameters, our ``"essential"`` row).

The critical path with the six legs in parallel is ``shared + max(leg) + platform +
closure`` (legs on six processors, then the platform and the closure on one; the paper's
seven-processor figure lets the platform run beside the legs: ``shared + max(max(leg),
platform) + closure``, given too).

Robots with general legs (:mod:`.leg_chain_symbolic`) have every parameter value baked in
(the ``"numeric"`` rows; no base or essential parameters), and their leg inverse geometry
uses square roots and, for a joint with a spring, one ``atan2`` (``trig``); a ``custom``
leg's Newton steps are counted written out (:data:`~.leg_chain_symbolic.NEWTON_ITERATIONS`
of them, with their sines and cosines). :func:`architecture_table` compares the
architectures.
"""

from __future__ import annotations

import copy
import functools
from dataclasses import asdict, dataclass
from typing import Any

import casadi as cs

from stewart_pin.codegen._architecture import codegen_kind
from stewart_pin.codegen.symbolic import Stages, description_key
from stewart_pin.description import RobotDescription
from stewart_pin.protocols import RobotLike

_MUL = {cs.OP_MUL, cs.OP_SQ}
_ADD = {cs.OP_ADD, cs.OP_SUB, cs.OP_TWICE}
_DIV = {cs.OP_DIV, cs.OP_INV}
_TRIG = {
    cs.OP_SIN,
    cs.OP_COS,
    cs.OP_TAN,
    cs.OP_ASIN,
    cs.OP_ACOS,
    cs.OP_ATAN,
    cs.OP_ATAN2,
}
_FREE = {cs.OP_INPUT, cs.OP_OUTPUT, cs.OP_CONST, cs.OP_ASSIGN, cs.OP_PARAMETER}

#: The paper's Table IV and section VII figures: (multiplications, additions, total).
PAPER_TABLE_IV: dict[str, tuple[int | None, int | None, int]] = {
    "IDM, essential parameters (Khalil & Guegan)": (1290, 788, 2078),
    "IDM, base parameters (Khalil & Guegan)": (1374, 908, 2282),
    "DDM (Khalil & Guegan)": (1823, 1120, 2943),
    "IDM, Gosselin 1993": (1302, 848, 2150),
    "IDM, Dasgupta 1998": (None, None, 4489),
}
#: The paper's critical paths on seven processors: (multiplications, additions).
PAPER_CRITICAL_PATH = {"IDM": (300, 226), "DDM": (414, 387)}


@dataclass(frozen=True)
class OperationCount:
    """Operation counts of one function (see the module docstring for the rules).

    Attributes:
        mul: multiplications (incl. squares). add: additions and subtractions.
        div: divisions and reciprocals. sqrt: square roots. trig: trigonometric calls.
        neg: negations. other: comparisons, absolute values, anything else.
    """

    mul: int = 0
    add: int = 0
    div: int = 0
    sqrt: int = 0
    trig: int = 0
    neg: int = 0
    other: int = 0

    @property
    def total(self) -> int:
        """Multiplications, divisions and additions: comparable with the paper's total."""
        return self.mul + self.div + self.add

    def __add__(self, other: OperationCount) -> OperationCount:
        return OperationCount(
            *(a + b for a, b in zip(_astuple(self), _astuple(other), strict=True))
        )

    def as_dict(self) -> dict[str, int]:
        return {**asdict(self), "total": self.total}


def _astuple(c: OperationCount) -> tuple[int, ...]:
    return (c.mul, c.add, c.div, c.sqrt, c.trig, c.neg, c.other)


def _max(counts: list[OperationCount]) -> OperationCount:
    """The count of the longest of parallel branches (by total, then divisions)."""
    return max(counts, key=lambda c: (c.total, c.sqrt))


def count_operations(f: cs.Function) -> OperationCount:
    """Count the operations of a CasADi SX function by walking its instructions."""
    n = {"mul": 0, "add": 0, "div": 0, "sqrt": 0, "trig": 0, "neg": 0, "other": 0}
    for k in range(f.n_instructions()):
        op = f.instruction_id(k)
        if op in _FREE:
            continue
        if op in _MUL:
            n["mul"] += 1
        elif op in _ADD:
            n["add"] += 1
        elif op in _DIV:
            n["div"] += 1
        elif op == cs.OP_SQRT:
            n["sqrt"] += 1
        elif op in _TRIG:
            n["trig"] += 1
        elif op == cs.OP_NEG:
            n["neg"] += 1
        else:
            n["other"] += 1
    return OperationCount(**n)


@dataclass(frozen=True)
class StageCounts:
    """Counts of a model's stages and the critical paths."""

    shared: OperationCount
    legs: tuple[OperationCount, ...]
    platform: OperationCount
    closure: OperationCount

    @property
    def critical_path(self) -> OperationCount:
        """Six legs in parallel, then the platform and the closure."""
        return self.shared + _max(list(self.legs)) + self.platform + self.closure

    @property
    def critical_path_7(self) -> OperationCount:
        """Seven processors: the platform beside the legs, then the closure."""
        return self.shared + _max([*self.legs, self.platform]) + self.closure

    @property
    def total(self) -> OperationCount:
        out = self.shared + self.platform + self.closure
        for leg in self.legs:
            out = out + leg
        return out


def stage_counts(stages: Stages) -> StageCounts:
    """Count each stage of a model."""
    return StageCounts(
        OperationCount() if stages.shared is None else count_operations(stages.shared),
        tuple(count_operations(f) for f in stages.legs),
        count_operations(stages.platform),
        count_operations(stages.closure),
    )


def _robot_description(robot: RobotLike | RobotDescription) -> RobotDescription:
    return robot if isinstance(robot, RobotDescription) else robot.description


def cost_dict(robot: RobotLike | RobotDescription) -> dict[str, Any]:
    """The operation counts of a robot's generated models (a :class:`StewartRobot` or a
    description), as plain data.

    Keys ``"IDM"`` and ``"DDM"``, each with ``"base"`` (88 symbolic base parameters),
    ``"essential"`` (the paper's 52), ``"quaternion"`` (base parameters, pose as position
    + unit quaternion), ``"numeric"`` (parameter values baked in), ``"critical_path"``
    / ``"critical_path_7"`` (base parameters, six legs in parallel, see the module
    docstring) and the same with ``"_essential"``; each a dict of counts (``mul``,
    ``add``, ``div``, ``sqrt``, ``trig``, ``neg``, ``other``, ``total``). ``"robot"`` is
    its name; ``"paper"`` Table IV.
    """
    desc = _robot_description(robot)
    key = description_key(desc)
    if key not in _COSTS:
        _COSTS[key] = _count(desc)
    return copy.deepcopy(_COSTS[key])


#: :func:`cost_dict` per description, kept for the process (generating the general legs'
#: staged models takes seconds).
_COSTS: dict[str, dict[str, Any]] = {}


def _count(desc: RobotDescription) -> dict[str, Any]:
    """Count the models the robot's codegen strategy names
    (:meth:`~._architecture.CodegenKind.cost_models`)."""
    counted = codegen_kind(desc).cost_models(desc)
    out: dict[str, Any] = {"robot": desc.name, **counted.extra}
    for model in ("IDM", "DDM"):
        attr = model.lower()
        entry: dict[str, Any] = {
            p: count_operations(getattr(m, attr)).as_dict() for p, m in counted.models.items()
        }
        for suffix, variant in counted.staged.items():
            stage_models = getattr(counted.models[variant], f"{attr}_stages")
            assert stage_models is not None
            stages = stage_counts(stage_models)
            entry[f"critical_path{suffix}"] = stages.critical_path.as_dict()
            entry[f"critical_path_7{suffix}"] = stages.critical_path_7.as_dict()
            if suffix == "":
                entry["stages"] = {
                    "shared": stages.shared.as_dict(),
                    "leg_max": _max(list(stages.legs)).as_dict(),
                    "platform": stages.platform.as_dict(),
                    "closure": stages.closure.as_dict(),
                }
        out[model] = entry
    out["paper"] = {
        "table_iv": {k: list(v) for k, v in PAPER_TABLE_IV.items()},
        "critical_path_7": {k: list(v) for k, v in PAPER_CRITICAL_PATH.items()},
    }
    return out


def _row(label: str, c: dict[str, int]) -> str:
    return (
        f"{label:50s} {c['mul']:6d} {c['div']:4d} {c['add']:6d} {c['total']:6d}   "
        f"{c['sqrt']:4d} {c['trig']:4d} {c['neg']:4d}"
    )


def cost_table(robot: RobotLike | RobotDescription) -> str:
    """The operation counts of a robot's generated IDM and DDM beside Table IV, as text."""
    d = cost_dict(robot)
    head = (
        f"{'operations (' + d['robot'] + ')':50s} {'x':>6s} {'/':>4s} {'+':>6s} {'total':>6s}   "
        f"{'sqrt':>4s} {'trig':>4s} {'neg':>4s}"
    )
    lines = [head, "-" * len(head)]
    if "architecture" in d:  # general legs: every value baked in
        labels = {
            "numeric": "parameter values baked in",
            "quaternion": "values baked in, pose with quaternion",
            "critical_path": "critical path, 6 legs parallel",
            "critical_path_7": "critical path, 7 processors",
        }
    else:
        labels = {
            "base": "88 base parameters",
            "essential": "52 essential parameters",
            "quaternion": "88 base parameters, pose with quaternion",
            "numeric": "parameter values baked in",
            "critical_path": "critical path, 6 legs parallel (base)",
            "critical_path_7": "critical path, 7 processors (base)",
            "critical_path_essential": "critical path, 6 legs parallel (essential)",
            "critical_path_7_essential": "critical path, 7 processors (essential)",
        }
    for model in ("IDM", "DDM"):
        for key, label in labels.items():
            lines.append(_row(f"{model}, {label}", d[model][key]))
    lines.extend(_paper_rows(len(head)))
    return "\n".join(lines)


def _paper_rows(width: int) -> list[str]:
    lines = ["-" * width, "Khalil & Guegan 2004, Table IV and section VII:"]
    for label, (m, a, t) in PAPER_TABLE_IV.items():
        ms = "" if m is None else str(m)
        as_ = "" if a is None else str(a)
        lines.append(f"  {label:48s} {ms:>6s} {'':>4s} {as_:>6s} {t:6d}")
    for model, (m, a) in PAPER_CRITICAL_PATH.items():
        label = model + " critical path, 7 processors"
        lines.append(f"  {label:48s} {m:6d} {'':>4s} {a:6d} {m + a:6d}")
    return lines


#: The robots :func:`architecture_table` compares, one per architecture: the paper's closed
#: forms (6-UPS), and the general models of each leg architecture's preset.
ARCHITECTURE_ROBOTS = (
    ("6-UPS, the paper's closed forms", "simulator"),
    ("6-UPS as general ups legs", "simulator"),
    ("6-UPS, offset U joints", "ups-offset"),
    ("6-RUS", "rus"),
    ("6-PUS", "pus"),
    ("6-UPS, every joint term", "random-ups-0"),
    ("custom legs (Newton)", "random-custom-0"),
    ("chain legs, welded, 6 joints", "welded-ups"),
)


def architecture_dict() -> dict[str, Any]:
    """The operation counts of each architecture's models (:data:`ARCHITECTURE_ROBOTS`):
    per label, the robot and the totals of the IDM and DDM with the parameter values baked
    in and their critical paths (six legs in parallel). Counted once per process."""
    return copy.deepcopy(_architecture_dict())


@functools.lru_cache(maxsize=1)
def _architecture_dict() -> dict[str, Any]:
    from stewart_pin.codegen.leg_chain_symbolic import build_general_models
    from stewart_pin.description.chain_leg_presets import CHAIN_PRESETS
    from stewart_pin.description.presets import preset

    out: dict[str, Any] = {}
    for label, name in ARCHITECTURE_ROBOTS:
        chain = CHAIN_PRESETS.get(name)
        desc = chain() if chain else preset(name)
        if label == "6-UPS as general ups legs":
            models = build_general_models(desc, stages=True, inline_newton=True)[0]
            d: dict[str, Any] = {}
            for model in ("IDM", "DDM"):
                attr = model.lower()
                stage_models = getattr(models, f"{attr}_stages")
                assert stage_models is not None
                d[model] = {
                    "numeric": count_operations(getattr(models, attr)).as_dict(),
                    "critical_path": stage_counts(stage_models).critical_path.as_dict(),
                }
        else:
            d = cost_dict(desc)
        out[label] = {
            "robot": name,
            **{m: {k: d[m][k] for k in ("numeric", "critical_path")} for m in ("IDM", "DDM")},
        }
    return out


def architecture_table() -> str:
    """:func:`architecture_dict` as text, beside Table IV: the totals (``x + / + +``) of
    the IDM and DDM with the values baked in, their critical paths (six legs parallel; for
    the paper's closed forms with the 88 base parameters symbolic), square roots and
    trigonometric calls."""
    d = architecture_dict()
    head = (
        f"{'operations (values baked in)':34s} {'robot':>16s} {'IDM':>6s} {'DDM':>6s} "
        f"{'IDM cp':>7s} {'DDM cp':>7s} {'sqrt':>5s} {'trig':>5s}"
    )
    lines = [head, "-" * len(head)]
    for label, row in d.items():
        i, dd = row["IDM"], row["DDM"]
        lines.append(
            f"{label:34s} {row['robot']:>16s} {i['numeric']['total']:6d} "
            f"{dd['numeric']['total']:6d} {i['critical_path']['total']:7d} "
            f"{dd['critical_path']['total']:7d} {dd['numeric']['sqrt']:5d} "
            f"{dd['numeric']['trig']:5d}"
        )
    lines.extend(_paper_rows(len(head)))
    return "\n".join(lines)
