"""The six legs as vector lanes: the compiled simulator's direct model (issue 24).

A state's direct model (:mod:`.leg_chain_symbolic` for general legs, :mod:`.symbolic` for
the paper's 6-UPS) is mostly six independent leg computations followed by a closure (the
legs' 6x6 blocks summed with the platform's, an ``L D L^T`` solve). Where the six legs
have the same structure and differ only in their numbers, the leg code is one function of
the leg's numbers: this module writes it once (the generator's own leg code) with every
number that differs between the legs as an input (general legs: the rotation ``R_i`` of
frame 0i, ``B_i``, ``P_i``, gravity in frame 0i, the branch, the joints' numbers; the
6-UPS: ``P_i``, ``B_i``, the first U-joint's axis ``z1i``; numbers equal in all six legs
stay baked in, so that their zeros and ones fold as in the robot's library), and for the
6-UPS the leg's 13 base parameters as a second input, gathered per lane from the models'
``chi`` input at each call (:data:`.symbolic.LEG_PARAMETERS`; the platform's are read by
the closure), turns it into four-lane AVX2+FMA code with :mod:`._simd` (lanes = legs:
legs 1-4 in one vector, 5-6 and two idle lanes in another, the two interleaved statement
by statement in one function) and follows it by the closure, a scalar CasADi function
compiled for AVX2+FMA too, reading the legs' outputs where the lanes wrote them and
writing the robot library's by-products (its layout: the general legs' or the 6-UPS
``q3^2``, ``rho^2``, ``Jp^-1``, ``D``...).

The entry ``sp_ddm_lanes`` has ``sp_ddm_aux``'s signature and outputs (the robot
library's, :mod:`._csource`) and its flag: a screen compiled here from the robot
library's guard code and numbers (:func:`guard_keys`: the inputs, four at a time; the leg
checks, general legs' slacks four at a time; the ``L D L^T`` pivots; the cheap condition
check) passes the states every test of the library's guard passes, and the library's
guard (``sp_ddm_guard_sim``, bound once by ``sp_lanes_bind``) decides the others. At the
state of the last single-state ``sp_idm_lanes`` call on the thread (the same pose, twist
and the forces it returned: the computed-torque controller's state, whose direct model
the C loop runs next), the screen takes the inputs' validity from that call's guard and,
where its static-pivot LU's multipliers stayed within the growth limit, the condition
bound's determinant and norm of ``S`` (at the direct model's own threshold; the
determinant's sign corrected by the pivot order's parity, ``LaneModels.parity``)
instead of computing the cheap condition check again: the same numbers up to rounding.
``sp_idm_lanes`` screens its states alike before the library's ``sp_idm_guard_sim``.
The compiled simulator (:mod:`.simulator`) calls them in
place of ``sp_ddm_aux`` where the processor has AVX2 and FMA and the robot's legs are
lane-compatible (:func:`lane_models`: the paper's 6-UPS, or general legs that are not
``custom`` with the same architecture, joints, tip and actuated joint in every leg);
elsewhere the robot library's entry. ``sp_idm_lanes`` does the same for ``sp_idm_sim``
(the computed-torque controller's inverse model). The
lanes compute the operations of the scalar model in the same order but for products by the
placement numbers that the scalar model folds (by 0, 1 or -1: exact) and for FMA
contraction (as the simulator's AVX2+FMA copy of the flat model): within a few units in
the last place of the robot library's direct model (tests/test_lanes.py).

The library is small (the leg code once, the closure) and compiled on the simulator's
first use of a robot, cached as the robot library is (:func:`.compiled.build_source_library`).
"""

from __future__ import annotations

import ctypes
import dataclasses
import re
import threading
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin.codegen import _simd
from stewart_pin.codegen._sx_common import (
    Mat,
    Scalar,
    Vec,
    column,
    ddm_legs_closure,
    ddm_platform,
    function,
    idm_platform,
    idm_shared,
    is_zero,
    pivot_order,
    pose_from_input,
    split,
    vcross,
)
from stewart_pin.codegen.leg_chain_symbolic import (
    LegConst,
    ddm_leg_outputs,
    general_robot,
    idm_closure_and_aux,
    idm_leg_outputs,
    leg_constants,
    leg_kinematics,
)
from stewart_pin.codegen.symbolic import (
    LEG_PARAMETERS,
    LegNumbers,
    leg_geometry,
    leg_numbers,
    model_constants,
    platform_parameters,
    static_pivots,
)
from stewart_pin.codegen.symbolic import ddm_closure_and_aux as ups_ddm_closure
from stewart_pin.codegen.symbolic import ddm_leg_outputs as ups_ddm_leg
from stewart_pin.codegen.symbolic import idm_leg_outputs as ups_idm_leg
from stewart_pin.codegen.symbolic import idm_legs_closure as ups_idm_closure
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import CompilationError
from stewart_pin.kinematics import leg_chains
from stewart_pin.kinematics.geometry import characteristic_length

#: Lanes per vector (AVX2: four doubles) and vectors of legs (six legs in eight lanes).
WIDTH = 4
GROUPS = 2
#: The generator's version (in the library's identity).
LANES_VERSION = "3"
_VAR = re.compile(r"\ba\d+\b")


@dataclass(frozen=True)
class LaneModels:
    """The legs-as-lanes direct and inverse models of a robot.

    Attributes:
        leg: ``leg(pose (16), twist (6), gamma (1), prm (n_prm), lp (n_lp)) -> out
            (n_out)``: one leg's outputs at the leg numbers ``prm`` and the leg's base
            parameters ``lp`` (6-UPS: its 13 of ``chi``; none for general legs): ``row``
            (6, its row of ``Jp^-1``), ``block`` (21, the upper triangle of its 6x6 share
            of the mass matrix), ``wrench`` (6), then general legs' slacks or the 6-UPS
            ``q3^2``, ``rho^2``.
        closure: ``closure(pose (16), twist (6), X (8 n_out), chi) -> (accel (6), aux)``,
            ``X`` the legs' outputs as the lanes write them (element ``i`` of leg ``k`` at
            ``(k // 4) 4 n_out + 4 i + k % 4``), ``chi`` the robot library's
            ``base_parameters`` input (6-UPS: the platform's are read), ``aux`` the robot
            library's direct-model by-products (:class:`~.leg_chain_symbolic.AuxLayout`,
            :data:`~.compiled.UPS_AUX_LAYOUT`).
        prm: (6, n_prm) the legs' numbers.
        chi_index: (6, n_lp) where each leg's ``lp`` are in ``chi``.
        idm_leg, idm_closure, ni_out: the same for the inverse model:
            ``idm_leg(pose, twist, accel (6), prm, lp) -> out (ni_out)`` (``row``,
            ``wrench`` (6), ``Hz`` (1), then the slacks or ``q3^2``, ``rho^2``),
            ``idm_closure(pose, twist, accel, X, chi) -> (gamma, aux)`` with the robot
            library's static pivots.
        parity: the sign of the inverse model's static pivot order (the rows' and the
            columns' permutations): its ``det`` (the product of the static-pivot LU's
            pivots) times ``parity`` is the determinant of ``S`` the direct model's guard
            computes.
        guard: the %-keys of the guards on the lanes (:data:`ENTRY`, :func:`guard_keys`;
            empty where ``lane_models`` was given a general robot, not a description: no
            library, :func:`lanes_source` is "").
    """

    leg: cs.Function
    closure: cs.Function
    prm: np.ndarray
    n_out: int
    idm_leg: cs.Function
    idm_closure: cs.Function
    ni_out: int
    chi_index: np.ndarray
    parity: float = 1.0
    guard: dict[str, Any] = dataclasses.field(default_factory=dict)


#: The numbers of a joint that may differ between the lanes (arithmetic only in the leg
#: code: no Python-level branch reads them but :func:`.leg_chain_symbolic.joint_terms`'s
#: zero tests, which keep a term some leg has), besides ``inertia``; ``theta`` too but
#: where :func:`.leg_chain_symbolic.limit_slacks` takes its cosine in Python.
_JOINT_LANES = (
    "ca",
    "sa",
    "d",
    "theta",
    "ct",
    "st",
    "r",
    "armature",
    "viscous",
    "coulomb",
    "stiffness",
    "rest",
)
#: A joint's fields that branch the generator (or are thresholds of the guard): equal in
#: every leg, else the robot keeps the library's direct model.
_JOINT_SAME = ("revolute", "lower", "upper", "gravcomp", "coulomb_smoothing")


def _theta_in_python(j: Any) -> bool:
    """Whether :func:`.leg_chain_symbolic.limit_slacks` takes ``cos(theta + mid)`` of
    joint ``j`` in Python (a revolute joint with a range shorter than 2 pi)."""
    lo, hi = j.lower, j.upper
    return bool(j.revolute and np.isfinite(lo) and np.isfinite(hi) and hi - lo < 2.0 * np.pi)


def _lane_compatible(legs: list[LegConst]) -> bool:
    """Whether the six legs differ only in numbers the lanes take as inputs: the same
    architecture (not ``custom``: its Newton steps are a called function of the leg's
    numbers), actuated joint, guard scale and joints' kinds, limits and options."""
    first = legs[0]
    if first.name == "custom":
        return False
    same = ("name", "actuated", "radius", "inline_newton")
    if any(getattr(lc, f) != getattr(first, f) for lc in legs[1:] for f in same):
        return False
    for j, j0 in enumerate(first.joints):
        fields = _JOINT_SAME + (("theta",) if _theta_in_python(j0) else ())
        if any(getattr(lc.joints[j], f) != getattr(j0, f) for lc in legs[1:] for f in fields):
            return False
    return True


def _lane_legs(robot: Any) -> list[LegConst] | None:
    """The six legs' numbers (:func:`.leg_chain_symbolic.leg_constants`) if they are
    lane-compatible, else None."""
    legs = [leg_constants(robot, k) for k in range(6)]
    return legs if _lane_compatible(legs) else None


#: A leg's outputs, by field, as the family's leg code returns them.
_Outputs = dict[str, list[Scalar]]


@dataclass
class _Family:
    """What a family of legs (general legs, the paper's 6-UPS) puts on the lanes.

    ``ddm_leg(p, R, twist, gamma, lp)`` and ``idm_leg(p, R, twist, accel, lp)`` (``lp``
    the leg's base parameters, ``p, R`` the pose, lists of SX) are one leg's outputs with
    the lane numbers as symbols; ``ddm_fields`` / ``idm_fields`` their fields in the
    order the lanes write them; ``ddm_closure(p, R, twist, chi, legs) -> (accel,
    aux)`` and ``idm_closure(p, R, twist, accel, chi, legs) -> (gamma, aux)`` the closures
    (``legs``: six dicts of the fields), as the robot library computes them."""

    numbers: _LaneNumbers
    ddm_leg: Callable[..., _Outputs]
    ddm_fields: tuple[str, ...]
    ddm_closure: Callable[..., tuple[list[Scalar], list[Scalar]]]
    idm_leg: Callable[..., _Outputs]
    idm_fields: tuple[str, ...]
    idm_closure: Callable[..., tuple[list[Scalar], list[Scalar]]]
    n_chi: int = 0
    chi_index: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((6, 0), int))
    pivots: tuple[tuple[int, int], ...] = ()


class _LaneNumbers:
    """The lane inputs of a leg's code: :meth:`lane` of the six legs' values of a number
    is that number where the six legs share it (baked: its zeros and ones fold as in the
    robot's library), else a new input of the leg function (one per lane)."""

    def __init__(self) -> None:
        self.columns: list[list[float]] = []
        self.symbols: list[Scalar] = []

    def lane(self, values: Sequence[float]) -> Scalar:
        if all(v == values[0] for v in values):
            return values[0]
        self.columns.append([float(v) for v in values])
        s = cs.SX.sym(f"prm_{len(self.symbols)}")
        self.symbols.append(s)
        return s

    def vector(self, rows: Sequence[Sequence[float]]) -> list[Scalar]:
        """:meth:`lane` of each element of the legs' vectors ``rows`` (6, n)."""
        return [self.lane([r[i] for r in rows]) for i in range(len(rows[0]))]

    @property
    def prm(self) -> np.ndarray:
        return np.array(self.columns, dtype=float).T.reshape(6, len(self.columns))


def _split_legs(X: cs.SX, fields: Sequence[tuple[str, int]]) -> list[_Outputs]:
    """The six legs' outputs in the lanes' layout ``X`` (:class:`LaneModels`)."""
    n = sum(size for _, size in fields)
    legs = []
    for k in range(6):
        base = (k // WIDTH) * WIDTH * n + k % WIDTH
        v = [X[base + WIDTH * i] for i in range(n)]
        leg, at = {}, 0
        for name, size in fields:
            leg[name], at = v[at : at + size], at + size
        legs.append(leg)
    return legs


def _general_family(desc: Any) -> _Family | None:
    """General legs (:mod:`.leg_chain_symbolic`), or None where the six differ in more
    than their numbers."""
    robot = general_robot(desc)
    found = _lane_legs(robot)
    if not found:
        return None
    legs = found
    nums = _LaneNumbers()
    R = tuple(tuple(nums.vector([lc.R[i] for lc in legs])) for i in range(3))
    B = tuple(nums.vector([lc.B for lc in legs]))
    pL = tuple(nums.vector([lc.pL for lc in legs]))
    g = tuple(nums.vector([lc.gravity for lc in legs]))
    branch = nums.lane([float(lc.branch) for lc in legs])
    tip = tuple(nums.vector([lc.tip for lc in legs]))
    joints = []
    for j, j0 in enumerate(legs[0].joints):
        numbers: dict[str, Any] = {
            f: nums.lane([getattr(lc.joints[j], f) for lc in legs]) for f in _JOINT_LANES
        }
        numbers["inertia"] = tuple(nums.vector([lc.joints[j].inertia for lc in legs]))
        joints.append(dataclasses.replace(j0, **numbers))
    sym_lc = dataclasses.replace(
        legs[0], R=R, B=B, pL=pL, gravity=g, branch=branch, tip=tip, joints=tuple(joints)
    )
    Pp = [float(x) for x in robot.platform_inertia]
    gravity = np.asarray(robot.gravity, dtype=float)
    g_platform = (1.0 - robot.platform_gravcomp) * gravity

    def ddm_leg(p: Vec, Rp: Mat, tw: list[Scalar], gamma: Scalar, lp: list[Scalar]) -> _Outputs:
        return ddm_leg_outputs(sym_lc, p, Rp, tw[:3], tw[3:], gamma)

    def idm_leg(p: Vec, Rp: Mat, tw: list[Scalar], ac: list[Scalar], lp: list[Scalar]) -> _Outputs:
        K, _ = idm_shared(tw, ac, g_platform)
        return idm_leg_outputs(sym_lc, p, Rp, tw[:3], tw[3:], ac[:3], K)

    def ddm_closure(
        p: Vec, Rp: Mat, tw: list[Scalar], chi: list[Scalar], dlegs: list[_Outputs]
    ) -> tuple[list[Scalar], list[Scalar]]:
        Ip, hp = ddm_platform(Rp, tw[3:], Pp, g_platform)
        accel, D = ddm_legs_closure(dlegs, Ip, hp)
        aux = [*(x for lg in dlegs for x in lg["row"]), *D]
        return accel, [*aux, *(s for lg in dlegs for s in lg["slack"])]

    # the robot library's static pivots: from the structural zeros of its (baked) rows
    zero: list[Scalar] = [0.0, 0.0, 0.0]
    sp, sR = pose_from_input(cs.SX.sym("pose", 16), "matrix")
    rows = [leg_kinematics(lc, sp, sR, zero, zero).row for lc in legs]
    nonzero = np.array([[not is_zero(rows[i][c]) for i in range(6)] for c in range(6)])
    home_rows = leg_chains.inverse_jacobian_batch(robot, robot.home_pose[None])[0]
    pivots = tuple(pivot_order(home_rows.T, nonzero))

    def idm_closure(
        p: Vec,
        Rp: Mat,
        tw: list[Scalar],
        ac: list[Scalar],
        chi: list[Scalar],
        ilegs: list[_Outputs],
    ) -> tuple[list[Scalar], list[Scalar]]:
        K, vdg = idm_shared(tw, ac, g_platform)
        F_p = idm_platform(Rp, tw[3:], ac[3:], vdg, K, Pp)
        gamma, iaux, _, _ = idm_closure_and_aux(ilegs, F_p, home_rows, 1.0 / robot.size, pivots)
        return gamma, iaux

    return _Family(
        numbers=nums,
        ddm_leg=ddm_leg,
        ddm_fields=("row", "block", "wrench", "slack"),
        ddm_closure=ddm_closure,
        idm_leg=idm_leg,
        idm_fields=("row", "wrench", "Hz", "slack"),
        idm_closure=idm_closure,
        pivots=pivots,
    )


def _ups_family(desc: Any) -> _Family:
    """The paper's 6-UPS (:mod:`.symbolic`): its leg code with ``P_i``, ``B_i`` and the
    first U-joint's axis as lane numbers (where the legs differ), the leg's 13 base
    parameters (:data:`~.symbolic.LEG_PARAMETERS`) from ``chi``, the platform's in the
    closures."""
    c = model_constants(desc)
    names = list(c.parameter_names)
    legs = [leg_numbers(c, k) for k in range(6)]
    nums = _LaneNumbers()
    sym = LegNumbers(
        pL=nums.vector([n.pL for n in legs]),
        B=nums.vector([n.B for n in legs]),
        z1=nums.vector([n.z1 for n in legs]),
        gravity=nums.vector([n.gravity for n in legs]),
    )
    chi_index = np.array(
        [[names.index(f"{q}_{k + 1}") for q in LEG_PARAMETERS] for k in range(6)], dtype=int
    )

    def params(lp: list[Scalar]) -> dict[str, Scalar]:
        return dict(zip(LEG_PARAMETERS, lp, strict=True))

    def ddm_leg(p: Vec, Rp: Mat, tw: list[Scalar], gamma: Scalar, lp: list[Scalar]) -> _Outputs:
        return ups_ddm_leg(sym, p, Rp, tw[:3], tw[3:], gamma, params(lp))

    def idm_leg(p: Vec, Rp: Mat, tw: list[Scalar], ac: list[Scalar], lp: list[Scalar]) -> _Outputs:
        K, vdg = idm_shared(tw, ac, c.gravity)
        return ups_idm_leg(sym, p, Rp, tw[:3], tw[3:], K, vdg, params(lp))

    def ddm_closure(
        p: Vec, Rp: Mat, tw: list[Scalar], chi: list[Scalar], dlegs: list[_Outputs]
    ) -> tuple[list[Scalar], list[Scalar]]:
        Ip, hp = ddm_platform(Rp, tw[3:], platform_parameters(chi, names), c.gravity)
        return ups_ddm_closure(dlegs, Ip, hp)

    # the robot library's static pivots: from the structural zeros of its (baked) rows
    sp, sR = pose_from_input(cs.SX.sym("pose", 16), "matrix")
    rows = [[*g.a, *vcross(g.L, g.a)] for g in (leg_geometry(c, k, sp, sR) for k in range(6))]
    pivots = static_pivots(desc, rows)
    inv_l = 1.0 / characteristic_length(desc)

    def idm_closure(
        p: Vec,
        Rp: Mat,
        tw: list[Scalar],
        ac: list[Scalar],
        chi: list[Scalar],
        ilegs: list[_Outputs],
    ) -> tuple[list[Scalar], list[Scalar]]:
        K, vdg = idm_shared(tw, ac, c.gravity)
        F_p = idm_platform(Rp, tw[3:], ac[3:], vdg, K, platform_parameters(chi, names))
        return ups_idm_closure(ilegs, F_p, pivots, inv_l)

    return _Family(
        numbers=nums,
        ddm_leg=ddm_leg,
        ddm_fields=("row", "block", "wrench", "q3sq", "rho2"),
        ddm_closure=ddm_closure,
        idm_leg=idm_leg,
        idm_fields=("row", "wrench", "Hz", "q3sq", "rho2"),
        idm_closure=idm_closure,
        n_chi=len(names),
        chi_index=chi_index,
        pivots=tuple(pivots),
    )


def _is_ups(desc: Any) -> bool:
    """Whether ``desc`` (a description, or a general robot) takes the paper's 6-UPS
    models (:mod:`.symbolic`)."""
    from stewart_pin.codegen._architecture import PaperUpsCodegen, codegen_kind

    return isinstance(desc, RobotDescription) and isinstance(codegen_kind(desc), PaperUpsCodegen)


def lane_models(desc: Any) -> LaneModels | None:
    """The legs-as-lanes models of a robot: the paper's 6-UPS, or general legs that
    differ only in their numbers; None where its legs differ in more than their numbers
    (or a leg is ``custom``): the simulator then runs the robot library's models."""
    family = _ups_family(desc) if _is_ups(desc) else _general_family(desc)
    if family is None:
        return None
    guard = guard_keys(desc) if isinstance(desc, RobotDescription) else {}
    return dataclasses.replace(_assemble(family), parity=_parity(family.pivots), guard=guard)


def _parity(pivots: Sequence[tuple[int, int]]) -> float:
    """The sign of the static pivot order ``pivots`` ``(row, col)``: the rows' permutation's
    sign times the columns' (the determinant of the permuted matrix over the matrix's)."""
    sign = 1.0
    for order in ([r for r, _ in pivots], [c for _, c in pivots]):
        for i in range(len(order)):
            for j in range(i + 1, len(order)):
                if order[i] > order[j]:
                    sign = -sign
    return sign


def guard_keys(desc: Any) -> dict[str, Any]:
    """The %-keys of the direct model's guard on the lanes (:data:`ENTRY`): the robot
    library's guards (:data:`._csource.GUARDS`, :data:`._csource.STATIC_COND`,
    :data:`._csource.DDM_SIM_GUARD`: the same text, the same numbers) and the screen's leg
    check ``lane_legs`` (general legs: every slack positive, four at a time; the 6-UPS: the
    library's ``sp_check_legs``)."""
    from stewart_pin.codegen import _csource
    from stewart_pin.codegen.compiled import guard_numbers, model_layout

    layout = model_layout(desc)
    keys = {**guard_numbers(desc, layout), **_csource.layout_numbers(layout)}
    text = (
        f"#define SP_DDM_SLACK {layout.ddm_slack}\n"
        + _csource.GUARDS % keys
        + _csource.STATIC_COND
        + (_csource.DDM_SIM_GUARD % keys).replace("#ifdef SP_DDM_AVX2\n", "", 1)
    )
    text = text[: text.rindex("#endif")]  # DDM_SIM_GUARD's
    if _is_ups(desc):
        legs = "return sp_check_legs(aux, slack) == 0;"
    else:
        legs = LANE_SLACKS % {"n_slack": layout.n_slack}
    return {**keys, "guards": text, "lane_legs": legs, "n_slack": layout.n_slack}


def _assemble(fam: _Family) -> LaneModels:
    """The four functions of :class:`LaneModels` from a family's leg code and closures."""
    syms = fam.numbers.symbols
    x_prm = column(syms) if syms else cs.SX.sym("prm", 0)
    x_lp = cs.SX.sym("lp", fam.chi_index.shape[1])
    x_pose, x_twist = cs.SX.sym("pose", 16), cs.SX.sym("twist", 6)
    x_gamma, x_accel = cs.SX.sym("g", 1), cs.SX.sym("accel", 6)
    p, Rp = pose_from_input(x_pose, "matrix")
    tw, lp = split(x_twist), split(x_lp)
    y_pose, y_twist, y_accel = cs.SX.sym("pose", 16), cs.SX.sym("twist", 6), cs.SX.sym("accel", 6)
    y_chi = cs.SX.sym("chi", fam.n_chi)
    yp, Ry = pose_from_input(y_pose, "matrix")
    models: list[Any] = []
    for idm in (False, True):
        fields = fam.idm_fields if idm else fam.ddm_fields
        out = (
            fam.idm_leg(p, Rp, tw, split(x_accel), lp)
            if idm
            else fam.ddm_leg(p, Rp, tw, x_gamma[0], lp)
        )
        sizes = [(f, len(out[f])) for f in fields]
        flat = [x for f in fields for x in out[f]]
        third = ("accel", x_accel) if idm else ("gamma", x_gamma)
        leg = function(
            "sp_lane_idm_leg" if idm else "sp_lane_leg",
            [("pose", x_pose), ("twist", x_twist), third, ("prm", x_prm), ("lp", x_lp)],
            [("out", flat)],
        )
        X = cs.SX.sym("X", GROUPS * WIDTH * len(flat))
        legs = _split_legs(X, sizes)
        ins = [("pose", y_pose), ("twist", y_twist)]
        if idm:
            res = fam.idm_closure(yp, Ry, split(y_twist), split(y_accel), split(y_chi), legs)
            ins.append(("accel", y_accel))
        else:
            res = fam.ddm_closure(yp, Ry, split(y_twist), split(y_chi), legs)
        closure = function(
            "sp_lane_idm_closure" if idm else "sp_lane_closure",
            [*ins, ("X", X), ("chi", y_chi)],
            [("gamma" if idm else "accel", res[0]), ("aux", res[1])],
        )
        models.append((leg, closure, len(flat)))
    (leg, closure, n_out), (idm_leg, idm_closure, ni_out) = models
    return LaneModels(
        leg, closure, fam.numbers.prm, n_out, idm_leg, idm_closure, ni_out, fam.chi_index
    )


#: The general legs' check of the lanes' guards (:func:`guard_keys`): every slack
#: ``aux[slack:slack + n_slack]`` positive (``sp_check_legs``'s decision, four at a
#: time and without its early exit).
LANE_SLACKS = r"""const double* s = aux + slack;
  sp_ivec m = SP_ALL;
  int k, ok = 1;
  for (k = 0; k + 4 <= %(n_slack)d; k += 4) {
    sp_vec v;
    __builtin_memcpy(&v, s + k, sizeof v);
    m &= v > sp_bcast(0.0);
  }
  for (; k < %(n_slack)d; ++k) ok &= s[k] > 0.0;
  return ok && m[0] && m[1] && m[2] && m[3];"""

#: The entry after the generated code (``%`` fields: the sizes, the legs' numbers, the
#: guards' text and numbers).
ENTRY = r"""
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__) && \
    defined(SP_LANE_CLOSURE) && defined(SP_LANE_IDM_CLOSURE)
#define SP_EXPORT __attribute__((visibility("default")))
/* the robot library's sp_ddm_guard_sim (codegen/_csource.py), bound by sp_lanes_bind */
typedef int (*sp_guard_fn)(const double*, const double*, const double*, double, const double*,
                           const double*, double*);
static sp_guard_fn sp_lane_guard = 0;
/* the legs' numbers, [vector][number][lane] (legs 5 and 6 repeated in the idle lanes) */
static const double sp_lane_prm[%(groups)d][%(n_prm)d][%(width)d] __attribute__((aligned(32))) = {
%(prm)s};
/* where each lane's base parameters are in chi, [vector][parameter][lane] */
static const int sp_lane_chi[%(groups)d][%(n_lp1)d][%(width)d] = {
%(lp)s};

/* The lanes' base parameters from chi (lp: %(groups)d x %(n_lp)d vectors). */
SP_AVX2 static inline void sp_lane_gather(const double* chi, sp_vec* lp) {
  int i, l;
  for (i = 0; i < %(groups)d * %(n_lp)d; ++i)
    for (l = 0; l < %(width)d; ++l) lp[i][l] = chi[sp_lane_chi[i / %(n_lp1)d][i %% %(n_lp1)d][l]];
}

/* ---- the direct model's guard (the robot library's, codegen/_csource.py) ---- */
%(guards)s
/* The inputs checks of the guards' screens: sp_check_inputs_flat's tests (every number
   finite, the last pose row [0, 0, 0, 1], each orthogonality error of the rotation within
   the tolerance, the same sums of products, and its determinant positive), four at a
   time; 1 where the state passes them. */
SP_AVX2 static int sp_lane_inputs_ok(const double* T, const double* x, const double* y) {
  const sp_vec big = sp_bcast(1.7976931348623157e308), tol = sp_bcast(sp_rotation_tol);
  sp_vec r0, r1, r2, r3, a = {x[0], x[1], x[2], x[3]}, b = {x[4], x[5], y[0], y[1]},
         c = {y[2], y[3], y[4], y[5]}, d, p0, p1, p2, e;
  sp_ivec m;
  double det;
  __builtin_memcpy(&r0, T, sizeof r0);
  __builtin_memcpy(&r1, T + 4, sizeof r1);
  __builtin_memcpy(&r2, T + 8, sizeof r2);
  __builtin_memcpy(&r3, T + 12, sizeof r3);
  m = (sp_v_fabs(r0) <= big) & (sp_v_fabs(r1) <= big) & (sp_v_fabs(r2) <= big);
  m &= (sp_v_fabs(a) <= big) & (sp_v_fabs(b) <= big) & (sp_v_fabs(c) <= big);
  m &= r3 == (sp_vec){0.0, 0.0, 0.0, 1.0};
  if (!(m[0] && m[1] && m[2] && m[3])) return 0;
  /* lanes j < 3: column j with itself (minus 1), then with column (j + 1) mod 3 */
  d = (r0 * r0 + r1 * r1) + r2 * r2;
  p0 = (sp_vec){r0[1], r0[2], r0[0], 0.0};
  p1 = (sp_vec){r1[1], r1[2], r1[0], 0.0};
  p2 = (sp_vec){r2[1], r2[2], r2[0], 0.0};
  e = (r0 * p0 + r1 * p1) + r2 * p2;
  m = (sp_v_fabs(d - sp_bcast(1.0)) <= tol) & (sp_v_fabs(e) <= tol);
  if (!(m[0] && m[1] && m[2])) return 0;
  det = T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8])
      + T[2] * (T[4] * T[9] - T[5] * T[8]);
  return det > 0.0;
}

/* The leg checks of the guards' screens: the state passes sp_check_legs(aux, slack). */
SP_AVX2 static int sp_lane_legs_ok(const double* aux, int slack) {
  %(lane_legs)s
}

/* The last state of sp_idm_lanes on this thread (a single state, the controller's): its
   pose, twist and Gamma (memo_in), and what its guard established there: 1 the inputs
   valid and Gamma finite (flag 0 or REPIVOTED alone), 2 also its static-pivot LU's
   multipliers within the growth limit (flag 0), so that its det and fro2 are the
   condition bound's; 0 nothing. */
static __thread double sp_lane_memo_in[28];
static __thread int sp_lane_memo = 0;
static __thread double sp_lane_memo_det = 0.0, sp_lane_memo_fro2 = 0.0;
/* The sign of the inverse model's static pivot order: memo det times it is det S. */
static const double sp_lane_parity = %(parity)r;

/* sp_ddm_guard_sim's flag and det for the lanes' direct model (the same signature): a
   screen first, the robot library's guard (sp_lane_guard) where the screen does not pass.
   The screen passes a state only where every test of the library's guard passes (its
   inputs valid, sp_check_legs, the L D L^T pivots positive, the acceleration finite, and
   the cheap condition check sp_static_cond_sim with its det), so the flag is the
   library's; at the state of the last sp_idm_lanes call (the computed-torque controller's,
   the same pose, twist and the Gamma it returned: the C loop's direct model at the
   state whose forces it just computed), the inputs are valid already, and where that
   call's static-pivot LU had its multipliers within the growth limit its det and fro2 give
   the condition bound (at this max_cond) and the sign: the same determinant and norm of
   S up to rounding (cond(S) <= max_cond / 2, the reference accepts the state, as with
   sp_static_cond_sim's own). */
SP_AVX2 static int sp_lane_ddm_guard(const double* pose, const double* twist, const double* gam,
                                     double max_cond, const double* accel, const double* aux,
                                     double* det) {
  const double big = 1.7976931348623157e308;
  int memo = 0, ok, k;
  if (sp_lane_memo && __builtin_memcmp(sp_lane_memo_in, pose, 16 * sizeof(double)) == 0
      && __builtin_memcmp(sp_lane_memo_in + 16, twist, 6 * sizeof(double)) == 0
      && __builtin_memcmp(sp_lane_memo_in + 22, gam, 6 * sizeof(double)) == 0)
    memo = sp_lane_memo;
  ok = memo || sp_lane_inputs_ok(pose, twist, gam);
  ok = ok && sp_lane_legs_ok(aux, %(ddm_slack)d);
  for (k = 0; k < 6; ++k) ok &= (aux[%(ddm_d)d + k] > 0.0) & (fabs(accel[k]) <= big);
  if (ok) {
    if (memo == 2 && sp_cond_bound(sp_lane_memo_det, sp_lane_memo_fro2, max_cond) == 0) {
      *det = sp_lane_parity * sp_lane_memo_det;
      return 0;
    }
    if (sp_static_cond_sim(aux + %(jinv)d, max_cond, det)) return 0;
  }
  return sp_lane_guard(pose, twist, gam, max_cond, accel, aux, det);
}

/* The length of aux (the robot library's SP_DDM_NAUX). */
SP_EXPORT int sp_lanes_naux(void) { return %(naux)d; }

/* Binds the robot library's guard; returns 1 where the processor runs the lanes (AVX2
   and FMA), else 0 (then sp_ddm_lanes must not be called). */
SP_EXPORT int sp_lanes_bind(void* guard) {
  sp_lane_guard = (sp_guard_fn)guard;
  return sp_avx2_ready;
}

/* sp_ddm_aux of the robot library (the same signature, outputs and flag), the legs as
   lanes: legs 1-4 in one vector, 5-6 in the next, then the closure and the guard. */
SP_EXPORT SP_AVX2 int sp_ddm_lanes(const double* pose, const double* twist, const double* gam,
                                   const double* chi, double max_cond, double* accel,
                                   double* aux, double* det) {
  sp_vec X[%(groups)d * %(n_out)d], lp[%(groups)d * %(n_lp1)d];
  sp_vec g0 = {gam[0], gam[1], gam[2], gam[3]}, g1 = {gam[4], gam[5], gam[4], gam[5]};
  const double* sh[2] = {pose, twist};
  const sp_vec* a0[5] = {0, 0, &g0, (const sp_vec*)sp_lane_prm[0], lp};
  const sp_vec* a1[5] = {0, 0, &g1, (const sp_vec*)sp_lane_prm[1], lp + %(n_lp)d};
  sp_vec* r0[1] = {X};
  sp_vec* r1[1] = {X + %(n_out)d};
  const double* carg[%(c_arg)d + 1];
  double* cres[%(c_res)d + 1];
  long long int iw[%(c_iw)d + 1];
  double w[%(c_w)d + 1];
  sp_lane_gather(chi, lp);
  sp_vlane_legs(a0, a1, sh, r0, r1);
  carg[0] = pose; carg[1] = twist; carg[2] = (const double*)X; carg[3] = chi;
  cres[0] = accel; cres[1] = aux;
  sp_lane_closure_avx2(carg, cres, iw, w, 0);
  return sp_lane_ddm_guard(pose, twist, gam, max_cond, accel, aux, det);
}

/* the robot library's sp_idm_guard_sim, bound by sp_lanes_bind_idm */
typedef int (*sp_iguard_fn)(const double*, const double*, const double*, double*, const double*,
                            double);
static sp_iguard_fn sp_lane_iguard = 0;

/* The length of the inverse model's aux (the robot library's SP_IDM_NAUX). */
SP_EXPORT int sp_lanes_idm_naux(void) { return %(inaux)d; }

/* Binds the robot library's inverse-model guard; returns sp_lanes_bind's answer. */
SP_EXPORT int sp_lanes_bind_idm(void* guard) {
  sp_lane_iguard = (sp_iguard_fn)guard;
  return sp_avx2_ready;
}

/* sp_idm_guard_sim's flag for the lanes' inverse model (the same signature): 0 where
   every test of the library's guard (sp_idm_after) passes (the inputs valid,
   sp_check_legs, the static-pivot LU's multipliers within the growth limit and its
   condition bound, Gamma finite), else the library's guard decides (and solves a
   repivoted state again). */
SP_AVX2 static int sp_lane_idm_guard(const double* pose, const double* twist,
                                     const double* accel, double* gamma, const double* aux,
                                     double max_cond) {
  const double big = 1.7976931348623157e308;
  int ok, k;
  ok = sp_lane_inputs_ok(pose, twist, accel) && sp_lane_legs_ok(aux, %(idm_slack)d);
  ok = ok && aux[%(growth)d] <= sp_growth_limit
       && sp_cond_bound(aux[%(det)d], aux[%(fro2)d], max_cond) == 0;
  for (k = 0; k < 6; ++k) ok &= fabs(gamma[k]) <= big;
  return ok ? 0 : sp_lane_iguard(pose, twist, accel, gamma, aux, max_cond);
}

/* sp_idm_sim of the robot library (n states; the same signature, outputs and flags), the
   legs as lanes. */
SP_EXPORT SP_AVX2 int sp_idm_lanes(long long n, const double* pose, const double* twist,
                                   const double* accel, const double* chi, double max_cond,
                                   double* gamma, int* flags) {
  sp_vec X[%(groups)d * %(ni_out)d], lp[%(groups)d * %(n_lp1)d];
  double aux[%(inaux)d];
  const sp_vec* a0[5] = {0, 0, 0, (const sp_vec*)sp_lane_prm[0], lp};
  const sp_vec* a1[5] = {0, 0, 0, (const sp_vec*)sp_lane_prm[1], lp + %(n_lp)d};
  sp_vec* r0[1] = {X};
  sp_vec* r1[1] = {X + %(ni_out)d};
  const double* carg[%(i_arg)d + 1];
  double* cres[%(i_res)d + 1];
  long long int iw[%(i_iw)d + 1];
  double w[%(i_w)d + 1];
  int any = 0, f = 0;
  long long s;
  sp_lane_gather(chi, lp);
  for (s = 0; s < n; ++s) {
    const double* sh[3] = {pose + 16 * s, twist + 6 * s, accel + 6 * s};
    sp_vilane_legs(a0, a1, sh, r0, r1);
    carg[0] = sh[0]; carg[1] = sh[1]; carg[2] = sh[2]; carg[3] = (const double*)X;
    carg[4] = chi;
    cres[0] = gamma + 6 * s; cres[1] = aux;
    sp_lane_idm_closure_avx2(carg, cres, iw, w, 0);
    f = sp_lane_idm_guard(sh[0], sh[1], sh[2], gamma + 6 * s, aux, max_cond);
    flags[s] = f;
    any |= f;
  }
  sp_lane_memo = 0;
  if (n == 1 && (f & ~SP_REPIVOTED) == 0) {  /* what the direct model's guard may reuse */
    __builtin_memcpy(sp_lane_memo_in, pose, 16 * sizeof(double));
    __builtin_memcpy(sp_lane_memo_in + 16, twist, 6 * sizeof(double));
    __builtin_memcpy(sp_lane_memo_in + 22, gamma, 6 * sizeof(double));
    sp_lane_memo = f == 0 ? 2 : 1;
    sp_lane_memo_det = aux[%(det)d];
    sp_lane_memo_fro2 = aux[%(fro2)d];
  }
  return any;
}
#endif
"""


def _interleaved(lines: list[str]) -> list[str]:
    """The vector body of one leg function (:func:`._simd.vector_lines`, called form)
    for two vectors of legs at once, statement by statement (``aNNN`` the first's,
    ``bNNN`` the second's; inputs ``argv0``, ``argv1``, outputs ``resv0``, ``resv1``): two
    independent chains the processor overlaps (measured on ``rus``: about 13 % less time
    per direct model than two calls)."""
    out: list[str] = []
    for line in lines:
        second = _VAR.sub(lambda v: "b" + v.group(0)[1:], line)
        if line.lstrip().startswith("sp_vec "):
            out += [line, second]
            continue
        out.append(line.replace("argv[", "argv0[").replace("resv[", "resv0["))
        out.append(second.replace("argv[", "argv1[").replace("resv[", "resv1["))
    return out


def lanes_source(m: LaneModels) -> str:
    """The C of the legs-as-lanes library of :func:`lane_models`'s ``m`` ("" where ``m``
    has no guard keys: :func:`lane_models` of a general robot, not a description)."""
    from stewart_pin.codegen.compiled import avx2_copy

    if not m.guard:
        return ""
    cg = cs.CodeGenerator(
        "sp_lanes.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    for f in (m.leg, m.closure, m.idm_leg, m.idm_closure):
        cg.add(f)
    code = cg.dump()
    used: set[str] = set()
    bodies = []
    for f, vname, shared in ((m.leg, "sp_vlane_legs", 2), (m.idm_leg, "sp_vilane_legs", 3)):
        internal = _simd.internal_name(code, f.name())
        lines = (
            None
            if internal is None
            else _simd.vector_lines(
                code, internal, used, frozenset(range(shared)), {}, called=True
            )
        )
        if lines is None or any("vw" in ln for ln in lines):
            return ""
        bodies.append(
            f"SP_VTARGET static void {vname}(const sp_vec* const* argv0, "
            "const sp_vec* const* argv1, const double* const* shared, sp_vec* const* resv0, "
            "sp_vec* const* resv1) {\n"
            "#ifdef __clang__\n#pragma clang fp contract(fast)\n#endif\n"
            + "\n".join(_interleaved(lines))
            + "\n  (void)argv0; (void)argv1; (void)shared; (void)resv0; (void)resv1;\n}\n"
        )
    closure = avx2_copy(code, m.closure.name(), "sp_lane_closure_avx2", "SP_LANE_CLOSURE")
    iclosure = avx2_copy(
        code, m.idm_closure.name(), "sp_lane_idm_closure_avx2", "SP_LANE_IDM_CLOSURE"
    )
    if not closure or not iclosure:
        return ""
    vec = "\n".join(bodies)
    preamble = _simd.PREAMBLE.replace('target("avx2")', 'target("avx2,fma")')
    n_prm = max(m.prm.shape[1], 1)
    prm = np.zeros((GROUPS, n_prm, WIDTH))
    for k, leg in enumerate((0, 1, 2, 3, 4, 5, 4, 5)):
        prm[k // WIDTH, : m.prm.shape[1], k % WIDTH] = m.prm[leg]
    rows = ",\n".join(
        "{" + ", ".join("{" + ", ".join(repr(float(x)) for x in lanes) + "}" for lanes in g) + "}"
        for g in prm
    )
    n_lp = m.chi_index.shape[1]
    index = np.zeros((GROUPS, max(n_lp, 1), WIDTH), dtype=int)
    for k, leg in enumerate((0, 1, 2, 3, 4, 5, 4, 5)):
        index[k // WIDTH, :n_lp, k % WIDTH] = m.chi_index[leg]
    lp = ",\n".join(
        "{" + ", ".join("{" + ", ".join(str(int(x)) for x in lanes) + "}" for lanes in g) + "}"
        for g in index
    )
    c = m.closure
    entry = ENTRY % {
        "groups": GROUPS,
        "width": WIDTH,
        "n_prm": n_prm,
        "n_out": m.n_out,
        "prm": rows,
        "n_lp": n_lp,
        "n_lp1": max(n_lp, 1),
        "lp": lp,
        "c_arg": c.sz_arg(),
        "c_res": c.sz_res(),
        "c_iw": c.sz_iw(),
        "c_w": c.sz_w(),
        "naux": c.size1_out(1),
        "ni_out": m.ni_out,
        "i_arg": m.idm_closure.sz_arg(),
        "i_res": m.idm_closure.sz_res(),
        "i_iw": m.idm_closure.sz_iw(),
        "i_w": m.idm_closure.sz_w(),
        "inaux": m.idm_closure.size1_out(1),
        "parity": m.parity,
        **m.guard,
    }
    return (
        "/* Generated by stewart-pin (see codegen/lanes.py). */\n"
        "#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)\n"
        f"{code}\n{preamble}\n{_simd.lane_helpers(used)}\n{vec}\n#endif\n{closure}\n"
        f"{iclosure}\n{entry}"
    )


_ENTRIES: weakref.WeakKeyDictionary[Any, tuple[int, int, Any]] = weakref.WeakKeyDictionary()
_ENTRIES_LOCK = threading.Lock()


def lanes_entries(models: Any) -> tuple[int, int]:
    """The addresses of ``sp_ddm_lanes`` and ``sp_idm_lanes`` for the robot of ``models``
    (a compiled :class:`~.compiled.CompiledDynamics`: the paper's 6-UPS or general legs),
    bound to its library's guards: built (or found) in the cache on first use, once per
    models object; ``(0, 0)`` where the lanes do not apply (chain legs, legs that differ in
    more than their numbers, a processor without AVX2 and FMA, a library that cannot be
    built): the caller then calls the robot library's ``sp_ddm_aux`` and ``sp_idm_sim``."""
    with _ENTRIES_LOCK:
        got = _ENTRIES.get(models)
        if got is None:
            got = _ENTRIES[models] = _entry(models)
        return got[0], got[1]


def _entry(models: Any) -> tuple[int, int, Any]:
    from stewart_pin.codegen._architecture import UPS_AUX_LAYOUT, codegen_kind
    from stewart_pin.codegen._identity import library_identity
    from stewart_pin.codegen.compiled import build_source_library, model_layout, printable_name

    desc = models.robot.description
    lib = getattr(models, "_lib", None)
    guards = [getattr(lib, f"sp_{x}_guard_sim", None) for x in ("ddm", "idm")]
    if guards[0] is None or guards[1] is None:
        return 0, 0, None
    layout = model_layout(desc)
    if _is_ups(desc):  # the paper's models: the lanes write their layout
        if layout != UPS_AUX_LAYOUT:
            return 0, 0, None
    elif not codegen_kind(desc).generic_models or desc.has_chain_legs:
        return 0, 0, None
    elif _lane_legs(general_robot(desc)) is None:
        return 0, 0, None
    elif (layout.jinv, layout.ddm_d, layout.ddm_slack) != (0, 36, 42):
        return 0, 0, None

    def source() -> str:
        m = lane_models(desc)
        return "" if m is None else lanes_source(m)

    identity = library_identity(desc, f"lanes {LANES_VERSION}")
    loaded: list[Any] = []
    try:
        build_source_library(
            source,
            getattr(models, "cache_dir", None),
            load=lambda path: loaded.append(ctypes.CDLL(str(path))),
            announce=f"the legs-as-lanes models of robot '{printable_name(desc)}'",
            identity=identity,
        )
    except CompilationError:
        return 0, 0, None
    lanes = loaded[0]
    try:
        bind, bind_idm = lanes["sp_lanes_bind"], lanes["sp_lanes_bind_idm"]
        naux, inaux = lanes["sp_lanes_naux"], lanes["sp_lanes_idm_naux"]
    except AttributeError:  # not an x86 GNU compiler: the preprocessor left them out
        return 0, 0, lanes
    if naux() != layout.ddm_size or inaux() != layout.idm_size:
        return 0, 0, lanes
    for f in (bind, bind_idm):
        f.argtypes, f.restype = [ctypes.c_void_p], ctypes.c_int
    ok = bind(ctypes.cast(guards[0], ctypes.c_void_p))
    ok &= bind_idm(ctypes.cast(guards[1], ctypes.c_void_p))
    if not ok:
        return 0, 0, lanes
    ddm, idm = (
        int(ctypes.cast(lanes[name], ctypes.c_void_p).value or 0)
        for name in ("sp_ddm_lanes", "sp_idm_lanes")
    )
    return ddm, idm, lanes
