"""Which generated model each architecture gets: the one place codegen chooses (issue 19).

:func:`codegen_kind` picks, once from a description, one of two strategies that every
module of :mod:`stewart_pin.codegen` asks instead of asking the architecture:

- :class:`PaperUpsCodegen`: the paper's ideal 6-UPS and its hand-derived models
  (:mod:`.symbolic`: the 88 base parameters a symbolic input, the leg checks on ``q3^2``
  and ``rho^2``, the leg lengths in closed form): the models that beat Table IV's
  operation counts;
- :class:`LegChainCodegen`: every other robot (``ups-offset``, ``rus``, ``pus``, custom
  and mixed legs) and its generic models (:mod:`.leg_chain_symbolic`: every number baked
  in, joint terms included, the guard's slacks, a custom leg's Newton steps);
- :class:`ChainLegCodegen`: robots with chain legs (``description.chain_legs``: any 1-dof
  joints closed by a ball or a weld) and their models (:mod:`.chain_leg_symbolic`: each
  leg's Newton steps from its home configuration, the guard's slacks).

:func:`generate_models` (the symbolic models of any robot, cached per description) is
here too: it is the first question codegen asks the strategy. The strategies hold no
state (one instance each).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin.codegen import _csource
from stewart_pin.codegen._resolution import (
    ChainReferenceResults,
    ReferenceChecks,
    ReferenceResults,
    Resolution,
)
from stewart_pin.codegen._sx_common import SymbolicModels, function, pose_from_input, vcross
from stewart_pin.codegen.chain_leg_symbolic import (
    build_chain_models,
    build_idle_models,
    chain_actuator_function,
    chain_constants,
    chain_kinematics,
)
from stewart_pin.codegen.leg_chain_symbolic import (
    AuxLayout,
    actuator_function,
    aux_layout,
    build_general_models,
    general_robot,
    leg_constants,
    leg_kinematics,
)
from stewart_pin.codegen.symbolic import (
    AUX_DDM_D,
    AUX_DDM_SIZE,
    AUX_IDM_DET,
    AUX_IDM_F,
    AUX_IDM_FRO2,
    AUX_IDM_GROWTH,
    AUX_IDM_HZ,
    AUX_IDM_SIZE,
    AUX_JINV,
    AUX_Q3SQ,
    AUX_RHO2,
    build,
    description_key,
    leg_geometry,
    model_constants,
)
from stewart_pin.description import RobotDescription
from stewart_pin.exceptions import ExportError, InputError
from stewart_pin.kinematics.chain_legs import robot_size
from stewart_pin.kinematics.geometry import (
    LEG_MIN_LENGTH_RATIO,
    LEG_SINGULARITY_SIN,
    characteristic_length,
)
from stewart_pin.parameters.base import grouped_parameters

__all__ = [
    "UPS_AUX_LAYOUT",
    "ChainLegCodegen",
    "CodegenKind",
    "CostModels",
    "LegChainCodegen",
    "PaperUpsCodegen",
    "codegen_kind",
    "generate_models",
]

#: The aux layout of the paper's 6-UPS models (:mod:`.symbolic`'s ``AUX_*``): their leg
#: checks read ``q3^2`` and ``rho^2``, no slacks.
UPS_AUX_LAYOUT = AuxLayout(
    jinv=AUX_JINV.start,
    idm_f=AUX_IDM_F.start,
    idm_hz=AUX_IDM_HZ.start,
    growth=AUX_IDM_GROWTH,
    det=AUX_IDM_DET,
    fro2=AUX_IDM_FRO2,
    idm_slack=AUX_IDM_SIZE,
    ddm_d=AUX_DDM_D.start,
    ddm_slack=AUX_DDM_SIZE,
    n_slack=0,
)


@dataclass(frozen=True)
class CostModels:
    """What :func:`~.opcount.cost_dict` counts for a robot: ``models`` (each variant's
    models, in the table's order), ``staged`` (critical-path key suffix -> the variant
    whose stages give it; the suffix ``""`` also gives ``"stages"``) and ``extra`` (keys
    of the dictionary beside ``"robot"``, ``"IDM"``, ``"DDM"``)."""

    models: dict[str, SymbolicModels]
    staged: dict[str, str]
    extra: dict[str, Any] = field(default_factory=dict)


class CodegenKind(Protocol):
    """What codegen asks of an architecture. ``desc`` is the robot's description; shapes
    and units as the callers' (:mod:`.compiled`, :mod:`.c_export`, :mod:`.derivatives`,
    :mod:`.opcount`)."""

    #: Whether the models have every parameter value baked in (no base-parameter input)
    #: and a flagged state goes through the leg-chain reference (slacks, joint limits).
    generic_models: bool
    #: Where the direct model's by-products hold the squared actuated leg lengths (the
    #: 6-UPS's ``q3^2``: its actuator positions come out of the compiled simulator), or
    #: ``None`` (the simulator's caller computes the actuator positions afterwards).
    leg_length_squares: slice | None
    #: True: the robot's library exports ``sp_act_batch``, the actuated joint values of
    #: poses from :meth:`actuator_function`'s generated code (the compiled simulator's
    #: output rows of general legs, where the 6-UPS's come from ``q3^2``; the rows of
    #: either that the Python loop adds to a compiled run).
    compiled_actuators: bool

    def model_parameters(self, desc: RobotDescription, parameters: str) -> str:
        """The ``parameters`` variant the models are built with (or InputError)."""
        ...

    def build_models(self, desc: RobotDescription, pose: str, parameters: str) -> SymbolicModels:
        """The symbolic IDM and DDM (uncached: see :func:`generate_models`)."""
        ...

    def model_layout(self, desc: RobotDescription) -> AuxLayout:
        """Where the guarded models put their by-products."""
        ...

    def resolution(self, desc: RobotDescription) -> Resolution:
        """What the compiled backend does with the states its guard flags (a new object:
        it may cache the reference models)."""
        ...

    def smooth_models(self, desc: RobotDescription, eps: float) -> SymbolicModels:
        """The models with every Coulomb sign ``sign(qd)`` as ``tanh(qd / eps)`` (``eps``
        [m/s or rad/s] > 0), for optimisers (uncached)."""
        ...

    def singularity_length(self, desc: RobotDescription) -> float:
        """The length [m] dividing ``Jp^-1``'s angular columns in the singularity measure."""
        ...

    def leg_checks_source(self, desc: RobotDescription, layout: AuxLayout) -> str:
        """The C of ``sp_check_legs``."""
        ...

    def base_parameters(self, desc: RobotDescription) -> tuple[tuple[str, ...], np.ndarray]:
        """The names and values of the models' ``base_parameters`` input."""
        ...

    def actuator_function(self, desc: RobotDescription) -> cs.Function:
        """``actuators(pose, twist) -> (q_a, qdot_a)`` (SX)."""
        ...

    def cost_models(self, desc: RobotDescription) -> CostModels:
        """The models the operation counts count."""
        ...

    def geometry_function(self, desc: RobotDescription, name: str) -> tuple[cs.Function, int, int]:
        """The exported inverse geometry (see :func:`~.c_export.geometry_function`)."""
        ...

    def newton_rows(
        self, desc: RobotDescription, p: Any, R: Any, t: list[Any]
    ) -> tuple[list[Any], list[Any], list[Any]]:
        """The exported forward geometry's residual ``(ys, xs, Jp^-1 rows)`` (see
        :func:`~.c_export.newton_function`)."""
        ...

    def actuated_revolute(self, desc: RobotDescription) -> list[int]:
        """1 for each leg whose actuated joint is revolute, else 0."""
        ...

    def check_exportable(self, desc: RobotDescription) -> None:
        """ExportError if the standalone C library cannot hold the robot's checks."""
        ...

    def not_compiled(self, desc: RobotDescription) -> str | None:
        """Why the compiled models (and their exact derivatives) do not take ``desc``, or
        ``None`` when they do."""
        ...

    def has_custom_leg(self, desc: RobotDescription) -> bool:
        """Whether a leg is ``custom`` (an inverse geometry by Newton)."""
        ...


class PaperUpsCodegen:
    """The paper's ideal 6-UPS: its hand-derived models (:mod:`.symbolic`)."""

    def not_compiled(self, desc: RobotDescription) -> str | None:
        return None

    generic_models = False
    leg_length_squares: slice | None = AUX_Q3SQ
    compiled_actuators = True

    def model_parameters(self, desc: RobotDescription, parameters: str) -> str:
        return parameters

    def build_models(self, desc: RobotDescription, pose: str, parameters: str) -> SymbolicModels:
        return build(desc, pose, parameters, "stewart_")

    def model_layout(self, desc: RobotDescription) -> AuxLayout:
        return UPS_AUX_LAYOUT

    def resolution(self, desc: RobotDescription) -> Resolution:
        """The reference checks decide; the compiled results stand."""
        return ReferenceChecks(desc, self.singularity_length(desc))

    def smooth_models(self, desc: RobotDescription, eps: float) -> SymbolicModels:
        """Its own models: the ideal 6-UPS has no friction to smooth."""
        return generate_models(desc)

    def singularity_length(self, desc: RobotDescription) -> float:
        return characteristic_length(desc)

    def leg_checks_source(self, desc: RobotDescription, layout: AuxLayout) -> str:
        """The 6-UPS leg lengths, leg singularities and U-joint limits if any
        (:data:`._csource.CHECK_LEGS_UPS`, :data:`._csource.CHECK_U_JOINTS_UPS`, the
        thresholds of :mod:`stewart_pin.kinematics.geometry` with margins)."""
        lo, hi = (float(x) for x in desc.ideal_stroke("the 6-UPS leg checks"))
        min_length = LEG_MIN_LENGTH_RATIO * characteristic_length(desc)
        return _csource.CHECK_LEGS_UPS % {
            "lo2": lo * lo * (1.0 + 1e-9),
            "hi2": hi * hi * (1.0 - 1e-9),
            "min_length2": min_length**2 * (1.0 + 1e-6),
            "min_sin2": LEG_SINGULARITY_SIN**2 * (1.0 + 1e-6),
            "q3sq": AUX_Q3SQ.start,
            "rho2": AUX_RHO2.start,
            "u_joint_check": _u_joint_check(desc, layout.jinv),
        }

    def base_parameters(self, desc: RobotDescription) -> tuple[tuple[str, ...], np.ndarray]:
        bp = grouped_parameters(desc)
        return bp.names, np.ascontiguousarray(bp.values, dtype=np.float64)

    def actuator_function(self, desc: RobotDescription) -> cs.Function:
        """The leg lengths ``l_i = |p + R P_i - B_i|`` [m] and their rates
        ``a_i . (v + w x L_i)`` (eq. 13), in closed form."""
        x_pose = cs.SX.sym("pose", 16)
        x_twist = cs.SX.sym("twist", 6)
        p = cs.vertcat(x_pose[3], x_pose[7], x_pose[11])
        R = cs.vertcat(
            *[cs.horzcat(x_pose[4 * i], x_pose[4 * i + 1], x_pose[4 * i + 2]) for i in range(3)]
        )
        v, w = x_twist[0:3], x_twist[3:6]
        lengths, rates = [], []
        for i in range(6):
            L = cs.mtimes(R, desc.platform_points[i])
            d = p + L - desc.base_points[i]
            length = cs.sqrt(cs.sumsqr(d))
            lengths.append(length)
            rates.append(cs.dot(d, v + cs.cross(w, L)) / length)
        return cs.Function(
            "actuators",
            [x_pose, x_twist],
            [cs.vertcat(*lengths), cs.vertcat(*rates)],
            ["pose", "twist"],
            ["q_a", "qdot_a"],
        )

    def cost_models(self, desc: RobotDescription) -> CostModels:
        """The 88 base parameters symbolic, the paper's 52 essential ones, the values baked
        in, the pose as a quaternion; critical paths of the first two."""
        models = {p: generate_models(desc, parameters=p) for p in ("base", "essential", "numeric")}
        models["quaternion"] = generate_models(desc, pose="quaternion")
        return CostModels(models, {"": "base", "_essential": "essential"})

    def geometry_function(self, desc: RobotDescription, name: str) -> tuple[cs.Function, int, int]:
        """``q_act`` the leg lengths; ``aux`` as the IDM's (``q3^2``, ``rho^2``, ``Jp^-1``)."""
        x_pose = cs.SX.sym("pose", 16)
        p, R = pose_from_input(x_pose, "matrix")
        c = model_constants(desc)
        legs = [leg_geometry(c, k, p, R) for k in range(6)]
        q = [cs.sqrt(g.q3sq) for g in legs]
        rows = [[*g.a, *vcross(g.L, g.a)] for g in legs]
        aux: list[Any] = [0.0] * AUX_JINV.stop
        aux[AUX_Q3SQ] = [g.q3sq for g in legs]
        aux[AUX_RHO2] = [g.rho2 for g in legs]
        aux[AUX_JINV] = [x for r in rows for x in r]
        return function(name, [("pose", x_pose)], [("q_act", q), ("aux", aux)]), AUX_JINV.start, 0

    def newton_rows(
        self, desc: RobotDescription, p: Any, R: Any, t: list[Any]
    ) -> tuple[list[Any], list[Any], list[Any]]:
        c = model_constants(desc)
        ys: list[Any] = []
        xs: list[Any] = []
        jinv: list[Any] = []
        for k in range(6):
            g = leg_geometry(c, k, p, R)
            ys.append(t[2 * k] - cs.sqrt(g.q3sq))
            xs.append(1.0)
            jinv += [*g.a, *vcross(g.L, g.a)]
        return ys, xs, jinv

    def actuated_revolute(self, desc: RobotDescription) -> list[int]:
        return [0] * 6

    def check_exportable(self, desc: RobotDescription) -> None:
        """Every 6-UPS exports (its stroke and U-joint limits are in the guard)."""

    def has_custom_leg(self, desc: RobotDescription) -> bool:
        return False


#: The margin [rad] narrowing each U-joint limit in the C guard (a flagged state is
#: decided by the reference; the exported C refuses within it).
U_JOINT_MARGIN = 1e-9


def _u_joint_check(desc: RobotDescription, jinv: int) -> str:
    """The C checking the 6-UPS's U-joint angles against ``desc.u_joint_limits`` (each
    narrowed by :data:`U_JOINT_MARGIN`; ``jinv`` where ``Jp^-1`` starts in ``aux``), or
    nothing for a robot without U-joint limits."""
    if desc.u_joint_limits is None:
        return ""
    rows = ", ".join(
        "{" + ", ".join(repr(float(x)) for x in R.ravel()) + "}" for R in desc.leg_base_rotations
    )
    lim = np.asarray(desc.u_joint_limits, dtype=np.float64)
    narrowed = lim + np.array([U_JOINT_MARGIN, -U_JOINT_MARGIN])
    limits = ", ".join(
        "{" + ", ".join(repr(float(x)) for x in leg.ravel()) + "}" for leg in narrowed
    )
    return _csource.CHECK_U_JOINTS_UPS % {
        "rotations": rows,
        "limits": limits,
        "jinv": jinv,
    }


def _actuated_residual(J: Any, t0: Any, t1: Any) -> tuple[Any, Any]:
    """The forward geometry's residual ``(y, x)`` of one leg's actuated joint state ``J``
    against its target ``(t0, t1)`` (see :func:`~.c_export.newton_function`): revolute,
    ``sin`` and ``cos`` of ``q_a - q`` (``cos``, ``sin`` of ``q`` from those of
    ``theta + q``); prismatic, ``q_a - q`` and 1."""
    if J.k.revolute:
        cq = J.c * J.k.ct + J.s * J.k.st
        sq = J.s * J.k.ct - J.c * J.k.st
        return t1 * cq - t0 * sq, t0 * cq + t1 * sq
    return t0 - J.value(), 1.0


class LegChainCodegen:
    """Every robot but the ideal 6-UPS: the generic models of its leg chains
    (:mod:`.leg_chain_symbolic`)."""

    def not_compiled(self, desc: RobotDescription) -> str | None:
        return None

    generic_models = True
    leg_length_squares: slice | None = None
    compiled_actuators = True

    def model_parameters(self, desc: RobotDescription, parameters: str) -> str:
        if parameters not in ("base", "numeric"):
            raise InputError(
                f"robot '{desc.name}' has general legs: its models have every parameter value "
                f"baked in (parameters 'base' or 'numeric'), got {parameters!r}"
            )
        return "numeric"

    def build_models(self, desc: RobotDescription, pose: str, parameters: str) -> SymbolicModels:
        return build_general_models(desc, pose)[0]

    def model_layout(self, desc: RobotDescription) -> AuxLayout:
        return aux_layout(generate_models(desc))

    def resolution(self, desc: RobotDescription) -> Resolution:
        """The reference path computes the flagged states."""
        return ReferenceResults(desc)

    def smooth_models(self, desc: RobotDescription, eps: float) -> SymbolicModels:
        return build_general_models(desc, coulomb_smoothing=eps)[0]

    def singularity_length(self, desc: RobotDescription) -> float:
        return general_robot(desc).size  # the platform radius, as the reference path

    def leg_checks_source(self, desc: RobotDescription, layout: AuxLayout) -> str:
        """Every slack of the generic models positive (:data:`._csource.CHECK_LEGS_GENERAL`)."""
        return _csource.CHECK_LEGS_GENERAL % {"n_slack": layout.n_slack}

    def base_parameters(self, desc: RobotDescription) -> tuple[tuple[str, ...], np.ndarray]:
        return (), np.zeros(0)  # compiled in

    def actuator_function(self, desc: RobotDescription) -> cs.Function:
        return actuator_function(desc)

    def cost_models(self, desc: RobotDescription) -> CostModels:
        """The values baked in (stages split, a custom leg's Newton steps written out) and
        the pose as a quaternion; the critical path of the first."""
        models = {
            "numeric": build_general_models(desc, stages=True, inline_newton=True)[0],
            "quaternion": build_general_models(desc, "quaternion", inline_newton=True)[0],
        }
        return CostModels(models, {"": "numeric"}, {"architecture": desc.architecture})

    def geometry_function(self, desc: RobotDescription, name: str) -> tuple[cs.Function, int, int]:
        """``q_act`` the actuated joint values; ``aux`` ``Jp^-1`` then the slacks."""
        x_pose = cs.SX.sym("pose", 16)
        p, R = pose_from_input(x_pose, "matrix")
        robot = general_robot(desc)
        zero = [0.0, 0.0, 0.0]
        q, jinv, slacks = [], [], []
        for k in range(6):
            lc = leg_constants(robot, k, inline_newton=False)
            kin = leg_kinematics(lc, p, R, zero, zero)
            q.append(kin.geo.joints[lc.actuated].value())
            jinv += kin.row
            slacks += kin.slacks
        f = function(name, [("pose", x_pose)], [("q_act", q), ("aux", [*jinv, *slacks])])
        return f, 0, 36

    def newton_rows(
        self, desc: RobotDescription, p: Any, R: Any, t: list[Any]
    ) -> tuple[list[Any], list[Any], list[Any]]:
        robot = general_robot(desc)
        zero = [0.0, 0.0, 0.0]
        ys: list[Any] = []
        xs: list[Any] = []
        jinv: list[Any] = []
        for k in range(6):
            lc = leg_constants(robot, k, inline_newton=False)
            kin = leg_kinematics(lc, p, R, zero, zero)
            y, x = _actuated_residual(kin.geo.joints[lc.actuated], t[2 * k], t[2 * k + 1])
            ys.append(y)
            xs.append(x)
            jinv += kin.row
        return ys, xs, jinv

    def actuated_revolute(self, desc: RobotDescription) -> list[int]:
        return [int(leg.joints[leg.actuated - 1].revolute) for leg in general_robot(desc).legs]

    def check_exportable(self, desc: RobotDescription) -> None:
        """Every leg chain exports (its joint limits are in the guard's slacks)."""

    def has_custom_leg(self, desc: RobotDescription) -> bool:
        return any(leg.name == "custom" for leg in general_robot(desc).legs)


class ChainLegCodegen(LegChainCodegen):
    """Robots with chain legs: the models of :mod:`.chain_leg_symbolic` (the standalone C
    export too, but for legs with an idle joint: :class:`ExportError`)."""

    compiled_actuators = False  # the simulator's caller computes them (the reference's)

    def build_models(self, desc: RobotDescription, pose: str, parameters: str) -> SymbolicModels:
        return build_chain_models(desc, pose)[0]

    def smooth_models(self, desc: RobotDescription, eps: float) -> SymbolicModels:
        return build_chain_models(desc, coulomb_smoothing=eps)[0]

    def singularity_length(self, desc: RobotDescription) -> float:
        return robot_size(desc)  # as the reference path (chain_legs.condition_number)

    def not_compiled(self, desc: RobotDescription) -> str | None:
        """Legs with idle joints (an R-S-S spin as state): these models have no idle
        input; the compiled models taking it are :mod:`.idle_compiled`'s."""
        if any(leg.idle_joint is not None for leg in desc.chain_legs or ()):
            return (
                "chain legs with idle joints, whose models take the idle state (give "
                "idle=(values, rates): stewart_pin.codegen.idle_compiled)"
            )
        return None

    def resolution(self, desc: RobotDescription) -> Resolution:
        """The chain legs' reference path computes the flagged states."""
        return ChainReferenceResults(desc)

    def actuator_function(self, desc: RobotDescription) -> cs.Function:
        return chain_actuator_function(desc)

    def cost_models(self, desc: RobotDescription) -> CostModels:
        """The values baked in (stages split, the Newton steps written out) and the pose
        as a quaternion; the critical path of the first. Legs with idle joints: the idle
        models (:func:`.chain_leg_symbolic.build_idle_models`, Newton written out), no
        stages (no critical path)."""
        if self.not_compiled(desc) is not None:
            idle = build_idle_models(desc, inline_newton=True)
            return CostModels({"numeric": idle}, {}, {"architecture": desc.architecture})  # type: ignore[dict-item]
        models = {
            "numeric": build_chain_models(desc, stages=True, inline_newton=True)[0],
            "quaternion": build_chain_models(desc, "quaternion", inline_newton=True)[0],
        }
        return CostModels(models, {"": "numeric"}, {"architecture": desc.architecture})

    def geometry_function(self, desc: RobotDescription, name: str) -> tuple[cs.Function, int, int]:
        """``q_act`` the actuated joint values (each leg's guarded Newton from its home
        configuration, as the compiled models); ``aux`` ``Jp^-1`` then the slacks (the
        Newton residual, the leg LU's growth, the joint limits)."""
        x_pose = cs.SX.sym("pose", 16)
        p, R = pose_from_input(x_pose, "matrix")
        zero = [0.0, 0.0, 0.0]
        q, jinv, slacks = [], [], []
        for k in range(6):
            lc = chain_constants(desc, k, inline_newton=False)
            ck = chain_kinematics(lc, p, R, zero, zero)
            q.append(ck.joints[lc.actuated].value())
            jinv += ck.row
            slacks += ck.slacks
        f = function(name, [("pose", x_pose)], [("q_act", q), ("aux", [*jinv, *slacks])])
        return f, 0, 36

    def newton_rows(
        self, desc: RobotDescription, p: Any, R: Any, t: list[Any]
    ) -> tuple[list[Any], list[Any], list[Any]]:
        """The legs' Newton from home at each forward-geometry iterate (no guard: the
        converged pose is checked by :meth:`geometry_function`'s slacks)."""
        zero = [0.0, 0.0, 0.0]
        ys: list[Any] = []
        xs: list[Any] = []
        jinv: list[Any] = []
        for k in range(6):
            lc = chain_constants(desc, k, inline_newton=False)
            ck = chain_kinematics(lc, p, R, zero, zero)
            y, x = _actuated_residual(ck.joints[lc.actuated], t[2 * k], t[2 * k + 1])
            ys.append(y)
            xs.append(x)
            jinv += ck.row
        return ys, xs, jinv

    def actuated_revolute(self, desc: RobotDescription) -> list[int]:
        return [int(leg.revolute[leg.actuated - 1]) for leg in desc.chain_legs or ()]

    def check_exportable(self, desc: RobotDescription) -> None:
        """ExportError for a leg with an idle joint (its spin state is not an input of
        the exported functions); every other chain leg exports (its Newton's residual,
        LU growth and joint limits are in the guard's slacks)."""
        for k, leg in enumerate(desc.chain_legs or ()):
            if leg.idle_joint is not None:
                raise ExportError(
                    f"robot '{desc.name}': leg {k + 1} has an idle joint (joint "
                    f"{leg.idle_joint}, an idle freedom such as a rod's spin about its "
                    "ball-to-ball line): the standalone C library does not take it (the spin "
                    "state is not an input of the exported functions); use the Python robot"
                )

    def has_custom_leg(self, desc: RobotDescription) -> bool:
        return True  # every leg by Newton


#: The strategies (stateless: one instance each).
_PAPER_UPS, _LEG_CHAINS, _CHAIN_LEGS = PaperUpsCodegen(), LegChainCodegen(), ChainLegCodegen()


def codegen_kind(desc: RobotDescription) -> CodegenKind:
    """The codegen strategy of ``desc``'s architecture: the one place codegen chooses."""
    if desc.has_chain_legs:
        return _CHAIN_LEGS
    return _PAPER_UPS if desc.is_ideal_ups else _LEG_CHAINS


_CACHE: dict[tuple[str, str, str], SymbolicModels] = {}
_CACHE_SIZE = 16


def generate_models(
    desc: RobotDescription, pose: str = "matrix", parameters: str = "base"
) -> SymbolicModels:
    """Generate the symbolic IDM and DDM of a robot (cached per description).

    A robot with general legs (``desc.legs`` set) gets the generic models of
    :mod:`stewart_pin.codegen.leg_chain_symbolic`: every number of the robot baked in, an
    empty ``base_parameters`` input (``parameters`` ``"base"`` or ``"numeric"``), no
    stages; the ideal 6-UPS the paper's models (:mod:`.symbolic`).

    Args:
        desc: the robot description; its geometry is baked in as numbers.
        pose: ``"matrix"`` (the pose input is 0Tp row-major, 16 numbers) or
            ``"quaternion"`` (``[x, y, z, qx, qy, qz, qw]``).
        parameters: ``"base"`` (the 88 base parameters are a symbolic input),
            ``"essential"`` (the paper's 52 essential parameters symbolic, the other 36
            zero, as in the paper's operation counts) or ``"numeric"`` (every value baked
            in: zeros of a symmetric robot propagate too).
    """
    kind = codegen_kind(desc)
    parameters = kind.model_parameters(desc, parameters)
    key = (description_key(desc), pose, parameters)
    if key not in _CACHE:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = kind.build_models(desc, pose, parameters)
    return _CACHE[key]
