"""The closed-form models exported as a standalone C99 library (``robot.export_c``).

:func:`export_c` writes, into a folder of its own, a library with no CasADi, no Python
and no heap allocation (see ``docs/export_c.md``):

- ``PREFIX.h`` / ``PREFIX.c``: ``PREFIX_inverse_geometry``, ``PREFIX_forward_geometry``
  (bounded Newton on SE(3) in C, from the generated inverse geometry and ``Jp^-1``),
  ``PREFIX_inverse_jacobian``, ``PREFIX_inverse_dynamics``, ``PREFIX_direct_dynamics``:
  CasADi's generated code for the guarded models (:mod:`.symbolic` /
  :mod:`.leg_chain_symbolic`, every number of the robot baked in) and an inverse geometry
  function, behind the state guards of :mod:`._csource`. Each function returns 0 or a
  negative error code (:data:`._cexport.ERROR_CODES`) and writes NaN on an error: a
  state the guard flags (where the Python path would ask its reference checks) is an
  error here, so the C never returns a number the reference path would refuse;
- ``PREFIX_reference.h``: random states and their values by the reference path
  (``backend="pinocchio"``; the inverse geometry, ``Jp^-1`` and forward geometry of the
  Python kinematics), embedded as numbers;
- ``PREFIX_test.c`` (checks every function against them to 1e-12 relative, and the error
  codes of an out-of-reach and an invalid pose), ``PREFIX_bench.c`` (the median time per
  call of each function), ``PREFIX_control_loop.cpp`` (a computed-torque loop shaped as a
  ``ros2_control`` controller's ``update()``, C++17, no ROS), ``CMakeLists.txt`` and
  ``README.md``.

Only numbers and the prefix (a C identifier, :data:`PREFIX_PATTERN`) reach the files:
no name or other text from the robot's description.
"""

from __future__ import annotations

import importlib.metadata
import math
import os
import re
import stat
from collections.abc import Sequence
from pathlib import Path
from string import Template
from typing import Any

import casadi as cs
import numpy as np

from stewart_pin._checks import ROTATION_TOLERANCE
from stewart_pin._io import write_text_atomic
from stewart_pin._so3 import so3_exp
from stewart_pin.codegen import _cexport, _cexport_programs, _csource
from stewart_pin.codegen._architecture import codegen_kind, generate_models
from stewart_pin.codegen._sx_common import function
from stewart_pin.codegen.compiled import leg_checks_source, model_layout, singularity_length
from stewart_pin.codegen.derivatives import symbolic_derivatives
from stewart_pin.codegen.symbolic import pose_from_input
from stewart_pin.description.actuator_convention import (
    ActuatorConvention,
    actuator_convention_of,
)
from stewart_pin.exceptions import ExportError, StewartPinError
from stewart_pin.kinematics.forward_geometry import FORWARD_MAX_ITERATIONS, FORWARD_TOLERANCE
from stewart_pin.protocols import RobotLike

#: A prefix: a letter, then letters, digits or underscores (at most 40 characters).
PREFIX_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,39}")
#: Random states embedded in the test program by default.
SAMPLES = 8
#: Relative tolerance of the test program (max-norm of the difference over the max-norm
#: of the reference, per output).
TOLERANCE = 1e-12
#: The test program's tolerance for a robot with a ``custom`` leg, whose inverse geometry
#: iterates in both paths (the reference's Newton stops at ``LEG_TOLERANCE``, 1e-13 m,
#: the generated code runs its steps out): they agree to about 1e-11.
CUSTOM_TOLERANCE = 1e-10
#: The perturbation of the forward geometry's guesses from the solution [m, rad].
GUESS_OFFSET = 1e-3


def check_prefix(prefix: Any) -> str:
    """``prefix`` if it is a C identifier of :data:`PREFIX_PATTERN`, else
    :class:`~stewart_pin.exceptions.ExportError`."""
    if not isinstance(prefix, str) or PREFIX_PATTERN.fullmatch(prefix) is None:
        shown = repr(prefix)[:60] if isinstance(prefix, str) else type(prefix).__name__
        raise ExportError(
            f"prefix {shown} is not a C identifier: a letter, then letters, digits or "
            "underscores, at most 40 characters (it names the files and the C functions)"
        )
    return prefix


def file_names(prefix: str) -> tuple[str, ...]:
    """The files :func:`export_c` writes for ``prefix``."""
    return (
        f"{prefix}.h",
        f"{prefix}.c",
        f"{prefix}_reference.h",
        f"{prefix}_test.c",
        f"{prefix}_bench.c",
        f"{prefix}_control_loop.cpp",
        "CMakeLists.txt",
        "README.md",
    )


def check_folder(folder: str | os.PathLike[str], prefix: str) -> Path:
    """The output folder as a :class:`Path`: absent (created by :func:`export_c` once
    the library is generated), or a folder (not a symbolic link) holding nothing but the
    files of an export with this prefix (overwritten); anything else is an
    :class:`~stewart_pin.exceptions.ExportError`."""
    out = Path(folder)
    try:
        mode = os.lstat(out).st_mode
    except FileNotFoundError:
        return out
    except OSError as e:
        raise ExportError(f"output folder {out}: cannot inspect it: {e}") from e
    if not stat.S_ISDIR(mode):
        raise ExportError(
            f"output folder {out} exists and is not a folder (or is a symbolic link): give a "
            "new folder, or one holding only a previous export"
        )
    ours = set(file_names(prefix))
    others = sorted(p.name for p in out.iterdir() if p.name not in ours)
    if others:
        shown = ", ".join(others[:3]) + (" ..." if len(others) > 3 else "")
        raise ExportError(
            f"output folder {out} exists and holds other files ({shown}): give a new folder, "
            "or one holding only a previous export with this prefix"
        )
    return out


# ---------------------------------------------------------------------------- the C source
def geometry_function(desc: Any, name: str) -> tuple[cs.Function, int, int]:
    """``name(pose) -> (q_act (6), aux)``: the actuated joint values and, in ``aux``,
    ``Jp^-1`` row-major and the leg checks' inputs (the 6-UPS: ``q3^2`` and ``rho^2``
    where its IDM has them; general legs: the slacks of the generated models). Returns
    the function and the offsets of ``Jp^-1`` and of the slacks in ``aux``."""
    return codegen_kind(desc).geometry_function(desc, name)


def newton_function(desc: Any, name: str) -> cs.Function:
    """``name(pose, target) -> (yx (12), J_inv (36))``: the forward geometry's residual
    without a trigonometric call. ``target`` holds per leg ``[cos q_a, sin q_a]`` of a
    revolute actuated joint's wanted value ``q_a``, else ``[q_a, 0]``; then per leg
    ``y = sin(q_a - q)``, ``x = cos(q_a - q)`` (revolute; the error is ``atan2(y, x)``,
    wrapped into (-pi, pi] as the reference wraps it) or ``y = q_a - q``, ``x = 1``
    (prismatic), ``q`` the joint's value at ``pose``; and ``Jp^-1`` row-major. No guard
    slack: the converged pose is checked by :func:`geometry_function`'s."""
    x_pose = cs.SX.sym("pose", 16)
    x_target = cs.SX.sym("target", 12)
    t = [x_target[i] for i in range(12)]
    p, R = pose_from_input(x_pose, "matrix")
    ys, xs, jinv = codegen_kind(desc).newton_rows(desc, p, R, t)
    return function(
        name, [("pose", x_pose), ("target", x_target)], [("yx", [*ys, *xs]), ("J_inv", jinv)]
    )


def actuated_revolute(desc: Any) -> list[int]:
    """1 for each leg whose actuated joint is revolute, else 0 (leg order)."""
    return codegen_kind(desc).actuated_revolute(desc)


def _version() -> str:
    """stewart-pin's version, as installed (``unknown`` when it is not)."""
    try:
        return importlib.metadata.version("stewart-pin")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover - run from a checkout
        return "unknown"


def _number(x: float) -> str:
    """A finite float as a C literal that reads back exactly."""
    x = float(x)
    if not math.isfinite(x):
        raise ExportError(f"a non-finite number ({x}) cannot be exported")
    text = repr(x)
    return text if any(ch in text for ch in ".en") else f"{text}.0"


def c_library(
    robot: RobotLike, prefix: str, derivatives: bool = False
) -> tuple[str, str, dict[str, Any]]:
    """The header, the source and the numbers of the exported library of ``robot``
    (``derivatives``: with ``PREFIX_inverse_dynamics_derivatives``)."""
    desc = robot.description
    codegen_kind(desc).check_exportable(desc)
    models = generate_models(desc, parameters="numeric")
    fi = models.idm_guarded
    fd = models.ddm_guarded
    geo, geo_jinv, geo_slack = geometry_function(desc, f"{prefix}_cg_geo")
    funcs = {
        f"{prefix}_cg_geo": geo,
        f"{prefix}_cg_newton": newton_function(desc, f"{prefix}_cg_newton"),
        f"{prefix}_cg_idm": cs.Function(f"{prefix}_cg_idm", fi.sx_in(), fi.call(fi.sx_in())),
        f"{prefix}_cg_ddm": cs.Function(f"{prefix}_cg_ddm", fd.sx_in(), fd.call(fd.sx_in())),
    }
    if derivatives:
        fdi = symbolic_derivatives(models).idm_flat
        name = f"{prefix}_cg_didm"
        funcs[name] = cs.Function(name, fdi.sx_in(), fdi.call(fdi.sx_in()))
    if any(f.sz_iw() for f in funcs.values()):
        raise ExportError("this robot's generated models need integer work: cannot export")
    cg = cs.CodeGenerator(
        f"{prefix}_cg",
        {
            "with_header": False,
            "with_export": False,
            "casadi_real": "double",
            "casadi_int": "long long int",
        },
    )
    for f in funcs.values():
        cg.add(f)
    generated = cg.dump()
    layout = model_layout(desc)
    check_legs = leg_checks_source(desc, layout)
    revolute = actuated_revolute(desc)
    length = singularity_length(desc)
    guards = _csource.GUARDS % {
        "check_legs": check_legs,
        "rotation_tol": ROTATION_TOLERANCE * (1.0 - 1e-3),
        "growth_limit": _csource.GROWTH_LIMIT,
        "inv_length": 1.0 / length,
    }
    naux = {"geo": geo.size1_out(1), "idm": layout.idm_size, "ddm": layout.ddm_size}
    naux["newton"] = 48
    if derivatives:
        naux["didm"] = 108
    sz_w = max(f.sz_w() for f in funcs.values())
    numbers: dict[str, Any] = {
        "P": prefix,
        "PU": prefix.upper(),
        "version": _version(),
        "work_size": max(naux.values()) + sz_w + 1,
        "rotation_tol": f"{ROTATION_TOLERANCE:g}",
        "max_condition": _number(robot.max_condition),
        "singularity_length": _number(length),
        "forward_tol": _number(FORWARD_TOLERANCE),
        "forward_max_iterations": int(FORWARD_MAX_ITERATIONS),
        "n_arg": max(f.sz_arg() for f in funcs.values()) + 1,
        "n_res": max(f.sz_res() for f in funcs.values()) + 1,
        "geo_naux": naux["geo"],
        "geo_jinv": geo_jinv,
        "geo_slack": geo_slack,
        "idm_naux": layout.idm_size,
        "ddm_naux": layout.ddm_size,
        **_csource.layout_numbers(layout),
        "revolute": ", ".join(str(r) for r in revolute),
        **_convention_numbers(robot),
        **_cexport.ERROR_CODES,
    }
    numbers["derivatives_readme"] = (
        f"\nWith `{prefix}_inverse_dynamics_derivatives` (`{numbers['PU']}_HAS_DERIVATIVES`): "
        "Gamma and its Jacobians\n(6x6 row-major) in the pose chart `[dp, dtheta]` (F0), the "
        "twist and the acceleration.\n"
        if derivatives
        else ""
    )
    numbers["ref_tolerance"] = f"{reference_tolerance(robot):g}"
    numbers["newton_readme"] = (
        "\nA leg's inverse geometry here is a fixed number of guarded Newton steps on its "
        "joint chain:\na pose they do not solve (reachable, but far from where they start) is "
        f"`{prefix.upper()}_ERR_RANGE`,\nwhere the Python path may still solve it.\n"
        if codegen_kind(desc).has_custom_leg(desc)
        else ""
    )
    numbers["derivatives_decl"] = (
        Template(_cexport.DERIVATIVES_DECL).substitute(numbers) if derivatives else ""
    )
    header = Template(_cexport.HEADER).substitute(numbers)
    source = (
        Template(_cexport.SOURCE_HEAD).substitute(numbers)
        + generated
        + _cexport.SOURCE_TAIL
        + guards
        + Template(_cexport.FUNCTIONS).substitute(numbers)
        + (Template(_cexport.DERIVATIVES).substitute(numbers) if derivatives else "")
    )
    return header, source, numbers


def _convention_numbers(robot: RobotLike) -> dict[str, str]:
    """The C arrays of the robot's actuator convention (``sp_sign``, ``sp_offset``,
    ``sp_wrap``, ``sp_wrap_on``; the identity 1, 0, no wrap) and the README's paragraph."""
    conv = actuator_convention_of(robot)
    wrap_on = conv.revolute & (not conv.identity)
    return {
        "signs": ", ".join(_number(x) for x in conv.signs),
        "offsets": ", ".join(_number(x) for x in conv.offsets),
        "wraps": ", ".join(_number(x) for x in conv.wraps),
        "wrap_on": ", ".join(str(int(w)) for w in wrap_on),
        "convention_readme": convention_readme(conv),
    }


def convention_readme(convention: ActuatorConvention) -> str:
    """The README's paragraph on an imported robot's actuator convention (numbers only:
    no name from the file), ``""`` for the identity."""
    if convention.identity:
        return ""
    rows = "\n".join(
        f"| {i + 1} | {convention.signs[i]:+.0f} | {float(convention.offsets[i])!r} | "
        + (f"{float(convention.wraps[i])!r}" if convention.revolute[i] else "-")
        + " |"
        for i in range(6)
    )
    return (
        "\nThe robot was imported from a model file whose actuated joints are zeroed or\n"
        "pointed otherwise than its named architecture's: these functions speak the\n"
        "file's joint convention (as the Python robot does), `q_act` its joint values\n"
        "(a revolute one in `[wrap, wrap + 2 pi)`), `gamma` along its axes. The\n"
        "architecture's own values are `q = s q_act + o`, `gamma_model = s gamma`:\n\n"
        "| actuator | s | o [m or rad] | wrap [rad] |\n| --- | --- | --- | --- |\n"
        f"{rows}\n"
    )


# ---------------------------------------------------------------------------- references
def _perturbed(T: np.ndarray, rng: np.random.Generator, offset: float) -> np.ndarray:
    """``T`` moved by up to ``offset`` [m] and turned by up to ``offset`` [rad]."""
    out = T.copy()
    out[:3, :3] = so3_exp(rng.uniform(-offset, offset, (1, 3)))[0] @ T[:3, :3]
    out[:3, 3] += rng.uniform(-offset, offset, 3)
    return out


def reference_values(
    robot: Any, n: int, seed: int, derivatives: bool = False
) -> dict[str, np.ndarray]:
    """``n`` random states of ``robot`` and the reference path's values at them: the
    actuated joint values, ``Jp^-1``, the IDM and the DDM (``backend="pinocchio"``), the
    forward geometry from a guess :data:`GUESS_OFFSET` off the solution; an out-of-reach
    pose and a pose whose rotation block is not a rotation; ``derivatives``: the IDM's
    Jacobians (``ref_didm``, the three 6x6 blocks row-major one after the other) by the
    Python path's generated expression (:mod:`.derivatives`, in CasADi's virtual
    machine)."""
    rng = np.random.default_rng(seed)
    poses, twists, accels = robot.sample_states(n, rng)
    q = np.asarray(robot.actuator_positions(poses, check_limits=True))
    jinv = np.asarray(robot.inverse_jacobian(poses)).reshape(n, 36)
    gamma = np.asarray(robot.inverse_dynamics(poses, twists, accels, backend="pinocchio"))
    scale = float(np.abs(gamma).max())
    gamma_in = gamma + rng.uniform(-0.1, 0.1, gamma.shape) * scale
    accel = np.asarray(robot.direct_dynamics(poses, twists, gamma_in, backend="pinocchio"))
    guesses = np.empty((n, 4, 4))
    fg = np.empty((n, 4, 4))
    for k in range(n):  # a guess the reference iterates from (redrawn, closer, if not)
        for attempt in range(20):
            guesses[k] = _perturbed(poses[k], rng, GUESS_OFFSET / 2**attempt)
            try:
                fg[k] = robot.forward_geometry(q[k], guesses[k])
                break
            except StewartPinError:
                continue
        else:  # pragma: no cover - a state the Newton iteration cannot even polish
            raise ExportError(f"the reference forward geometry fails at sampled state {k}")
    far = np.array(robot.home_pose, dtype=float)
    far[2, 3] += 10.0 * singularity_length(robot.description)
    bad = np.array(robot.home_pose, dtype=float)
    bad[0, 0] *= 1.01
    out = {
        "poses": poses.reshape(n, 16),
        "twists": twists,
        "accels": accels,
        "gammas_in": gamma_in,
        "ref_q": q,
        "ref_jinv": jinv,
        "ref_gamma": gamma,
        "ref_accel": accel,
        "guesses": guesses.reshape(n, 16),
        "ref_pose": fg.reshape(n, 16),
        "far_pose": far.reshape(16),
        "bad_pose": bad.reshape(16),
        "home_pose": np.array(robot.home_pose, dtype=float).reshape(16),
        "prismatic": np.array([1.0 - r for r in actuated_revolute(robot.description)]),
    }
    if derivatives:
        f = symbolic_derivatives(generate_models(robot.description)).idm_flat
        chi = codegen_kind(robot.description).base_parameters(robot.description)[1]
        didm = np.array(
            [
                np.array(f(T.reshape(16), V, A, chi)).ravel()
                for T, V, A in zip(poses, twists, accels, strict=True)
            ]
        )  # the description's: each block's rows in the robot's actuator convention
        signs = actuator_convention_of(robot).signs
        out["ref_didm"] = (didm.reshape(n, 3, 6, 6) * signs[:, None]).reshape(n, 108)
    return out


def _c_array(name: str, values: np.ndarray) -> str:
    a = np.asarray(values, dtype=float)
    dims = "".join(f"[{d}]" for d in a.shape)
    if a.ndim == 1:
        body = ", ".join(_number(x) for x in a)
        return f"static const double {name}{dims} = {{{body}}};\n"
    rows = ",\n  ".join("{" + ", ".join(_number(x) for x in row) + "}" for row in a)
    return f"static const double {name}{dims} = {{\n  {rows}}};\n"


def reference_header(
    numbers: dict[str, Any], values: dict[str, np.ndarray], tolerance: float = TOLERANCE
) -> str:
    """``PREFIX_reference.h``: the states and the reference values as C arrays, and the
    test program's relative ``tolerance``."""
    P, PU = numbers["P"], numbers["PU"]
    n = values["poses"].shape[0]
    parts = [
        f"/* {P}_reference.h: {n} random states of the robot and the values of the Python\n"
        f"   reference path at them (stewart-pin {numbers['version']}, backend pinocchio). */\n",
        f"#ifndef {PU}_REFERENCE_H\n#define {PU}_REFERENCE_H\n\n",
        f"#define {PU}_REF_N {n}\n",
        f"#define {PU}_REF_TOLERANCE {_number(tolerance)}\n",
        f"#define {PU}_REF_HAS_PRISMATIC {int(values['prismatic'].any())}\n\n",
    ]
    parts += [_c_array(f"{P}_{key}", values[key]) for key in values]
    parts.append(f"\n#endif /* {PU}_REFERENCE_H */\n")
    return "".join(parts)


# ---------------------------------------------------------------------------- the export
def reference_tolerance(robot: Any) -> float:
    """The test program's relative tolerance: :data:`TOLERANCE`, or
    :data:`CUSTOM_TOLERANCE` for a robot with a ``custom`` leg."""
    desc = robot.description
    if codegen_kind(desc).has_custom_leg(desc):
        return CUSTOM_TOLERANCE
    return TOLERANCE


def export_c(
    robot: Any,
    folder: str | os.PathLike[str],
    prefix: str,
    samples: int = SAMPLES,
    seed: int = 0,
    derivatives: bool = False,
) -> list[Path]:
    """Write the standalone C99 library of ``robot``'s models into ``folder``.

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` (any leg architecture).
        folder: the output folder: absent (created) or holding only a previous export
            with this prefix.
        prefix: a C identifier (:data:`PREFIX_PATTERN`): the files' names and the
            functions' prefix (``PREFIX_inverse_dynamics``...); upper-cased for the macros.
        samples: random states embedded in the test program (at least 1).
        seed: the seed of their random generator.
        derivatives: also export ``PREFIX_inverse_dynamics_derivatives`` (Gamma and its
            Jacobians in the pose chart, the twist and the acceleration; a longer source:
            several seconds more to compile).

    Returns:
        The paths written (:func:`file_names`).

    Raises:
        ExportError: a prefix that is not a C identifier, an output folder that exists
            with other files, a robot that cannot export.
    """
    prefix = check_prefix(prefix)
    if not isinstance(samples, int) or isinstance(samples, bool) or not 1 <= samples <= 1000:
        raise ExportError(f"samples must be an integer in [1, 1000], got {samples!r}")
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ExportError(f"seed must be an integer >= 0, got {seed!r}")
    check_folder(folder, prefix)  # before the work
    header, source, numbers = c_library(robot, prefix, derivatives)
    values = reference_values(robot, samples, seed, derivatives)
    out = check_folder(folder, prefix)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ExportError(f"output folder {out}: cannot create it: {e}") from e
    texts: Sequence[str] = (
        header,
        source,
        reference_header(numbers, values, reference_tolerance(robot)),
        Template(_cexport_programs.TEST).substitute(numbers),
        Template(_cexport_programs.BENCH).substitute(numbers),
        Template(_cexport_programs.CONTROL_LOOP).substitute(numbers),
        Template(_cexport_programs.CMAKE).substitute(numbers),
        Template(_cexport_programs.README).substitute(numbers),
    )
    paths = []
    for name, text in zip(file_names(prefix), texts, strict=True):
        path = out / name
        write_text_atomic(path, text)
        paths.append(path)
    return paths


__all__ = [
    "CUSTOM_TOLERANCE",
    "PREFIX_PATTERN",
    "SAMPLES",
    "TOLERANCE",
    "c_library",
    "check_folder",
    "check_prefix",
    "export_c",
    "file_names",
    "geometry_function",
    "newton_function",
    "reference_tolerance",
    "reference_values",
]
