"""Exact derivatives of the closed-form models in the platform state, generated and compiled.

For the inverse model ``Gamma = IDM(x, V, Vdot)`` and the direct model
``Vdot = DDM(x, V, Gamma)`` this module gives the (6, 6) Jacobians with respect to the
pose ``x``, the twist ``V = [v, w]`` (velocity of O_p and angular velocity, F0) and the third
argument (the classical acceleration ``Vdot = [dv/dt, dw/dt]`` in F0, or the actuator
efforts Gamma).

The pose derivative is taken in the chart ``delta = [dp, dtheta]`` (6,) in F0 [m, rad]::

    p <- p + dp,    R <- exp(dtheta^) R

the frame of the twist, so that along any motion ``d delta / dt = [v, w]`` (``dp/dt = v``,
``dR/dt = w^ R``) and ``dV/dt = Vdot`` (the classical acceleration is the time derivative
of the twist's components). Along a motion, then::

    dGamma/dt = D.pose @ V + D.twist @ Vdot + D.accel @ dVdot/dt     (IDM)
    dVdot/dt  = D.pose @ V + D.twist @ Vdot + D.gamma @ dGamma/dt    (DDM)

How. The perturbation is injected symbolically into the generated model's pose input
(:func:`perturbed_pose`: ``p + dp`` and ``(I + dtheta^) R``, which has the same first
derivative at ``delta = 0`` as ``exp(dtheta^) R``), CasADi's algorithmic differentiation
(reverse mode: six sweeps over the straight-line code) gives the Jacobian with respect to
``[delta, V, Vdot]``, evaluated at ``delta = 0`` by substitution (SX folds the zeros), and
common sub-expressions are eliminated. Nothing here knows the robot's architecture: it
takes any :class:`~.symbolic.SymbolicModels` whose ``idm`` / ``ddm`` have the signature
``(pose (16, row-major 0Tp), twist (6), accel | gamma (6), base_parameters) -> (6)``.
Which robots have such models is decided in one place, :func:`symbolic_models_for`.

Compiled. :class:`CompiledDerivatives` compiles each Jacobian function into a shared
library of its own per robot (the inverse model's on construction, the direct model's on
its first call: a first use generates and compiles one model only) through
:func:`.compiled.build_source_library` (the cache, its key, its integrity rules, lock and
build of :mod:`.compiled`), with a batch loop in C that flags non-finite results; a library
found in the cache is loaded without generating anything. A large one (more than
:data:`BACKGROUND_INSTRUCTIONS` instructions: chain legs) compiles in a background thread,
started once the first call has its answer, while CasADi's virtual machine answers
(:meth:`CompiledDerivatives.wait` waits for it). It is compiled without
optimisation (:data:`.compiled.QUICK_CFLAGS`): the first use takes seconds (about 0.7 s to
differentiate and generate, 1.3-1.8 s to compile the 6-UPS inverse model's, announced on
stderr) instead of 20-50 s at -O2, for calls about 2x slower
(``scripts/bench_derivatives.py --first-use`` measures both). It runs batches on
:attr:`CompiledDerivatives.threads` threads (the process-wide pool of :mod:`.compiled`).
Without a C compiler it evaluates the same functions in CasADi's virtual machine, with one
warning.

Guards. Each call first evaluates the value (``.gamma`` / ``.accel``) with the compiled
value model of the robot (:func:`~.compiled.compiled_backend`), which raises exactly what
the reference path raises for the state (bad input, stroke or joint limits, leg or parallel
singularities, a direct model that is not positive definite, overflow); only then are the
derivatives computed, and a non-finite one raises
:class:`~stewart_pin.exceptions.NumericalError`.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import threading
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as cs
import numpy as np

from stewart_pin._checks import check_states
from stewart_pin.codegen._architecture import codegen_kind, generate_models
from stewart_pin.codegen._csource import FLAG_NAMES
from stewart_pin.codegen._identity import library_identity
from stewart_pin.codegen._sx_common import SymbolicModels
from stewart_pin.codegen.compiled import (
    QUICK_CFLAGS,
    CompiledDynamics,
    build_source_library,
    compiled_backend,
    model_layout,
    printable_name,
    split_batch,
    warn_vm_once,
)
from stewart_pin.exceptions import (
    CompilationError,
    InputError,
    NumericalError,
    UnsafeCacheError,
    UnsupportedArchitectureError,
)
from stewart_pin.protocols import RobotLike

__all__ = [
    "CompiledDerivatives",
    "DirectDynamicsDerivatives",
    "InverseDynamicsDerivatives",
    "LibraryStatus",
    "ModelLibraries",
    "ModelLibrariesOwner",
    "SymbolicDerivatives",
    "derivatives_backend",
    "derivatives_c_source",
    "functions_c_source",
    "newton_not_converged",
    "perturbed_pose",
    "symbolic_actuators_for",
    "symbolic_derivative",
    "symbolic_derivatives",
    "symbolic_models_for",
]

#: Fewest states per thread for a batch of derivatives to be split (a state costs about
#: ten value evaluations, so fewer than the value models' threshold).
THREAD_MIN_STATES = 64
#: States per CasADi VM call in the fallback.
VM_CHUNK = 1024
#: A model's Jacobians with more CasADi instructions than this are compiled in a background
#: thread on first use while CasADi's VM answers (about 3 s of compilation at -O0 and
#: more: chain legs about 140 000, custom legs 41 000 to 57 000; the 6-UPS and the named
#: three-joint legs 19 000 to 42 000).
BACKGROUND_INSTRUCTIONS = 40_000
#: Numbers per state of the compiled output: the three (6, 6) Jacobians, row-major.
_NOUT = 108
_GEOMETRY = FLAG_NAMES["GEOMETRY"]


def newton_not_converged(
    output: str,
    residual: tuple[tuple[int, int], ...],
    slacks: np.ndarray,
    index: np.ndarray,
    n_states: int,
) -> NumericalError | None:
    """The error for the exact derivatives at states where a leg's unrolled Newton steps
    from home did not converge, or None.

    Args:
        output: what was asked (``"inverse dynamics derivatives"``).
        residual: the Newton residuals among the slacks, ``(offset, leg)``
            (:attr:`~.leg_chain_symbolic.AuxLayout.residual`).
        slacks: (m, n_slack) the guarded value model's slacks at ``m`` states.
        index: (m,) those states' indices in the call's batch.
        n_states: the states of the call.
    """
    if not residual or not len(index):
        return None
    cols = [c for c, _ in residual]
    with np.errstate(invalid="ignore"):
        bad = ~(slacks[:, cols] > 0.0)  # NaN: not converged either
    rows = np.flatnonzero(bad.any(axis=1))
    if not rows.size:
        return None
    first = rows[np.argmin(index[rows])]
    state = int(index[first])
    found = sorted({residual[c][1] for c in np.flatnonzero(bad[first])})
    legs = ("leg " if len(found) == 1 else "legs ") + ", ".join(map(str, found))
    return NumericalError(
        output,
        state,
        int(rows.size),
        n_states,
        message=(
            f"{output}: the legs' Newton steps from home did not converge at state {state} "
            f"({legs}; {rows.size} of {n_states} states): the exact derivatives of the "
            "unrolled model would be inexact there (a pose near the edge of the legs' reach "
            "or far from home; its values come from the reference path)"
        ),
    )


_NAMES = {"idm": "sp_idm_derivatives", "ddm": "sp_ddm_derivatives"}
_OUTPUTS = {"idm": "inverse dynamics derivatives", "ddm": "direct dynamics derivatives"}
_WARNED: set[str] = set()


class _NotCached(Exception):
    """A library is not in the cache (the probe of :meth:`ModelLibraries.seek`)."""


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class InverseDynamicsDerivatives:
    """The inverse model and its Jacobians at a state (or a batch: a leading N axis).

    Attributes:
        gamma: Gamma (6,) [N] (general legs: joint-side efforts [N or N m]).
        pose: ``dGamma/d delta`` (6, 6) [N/m | N/rad], ``delta = [dp, dtheta]`` in F0 (see
            the module docstring).
        twist: ``dGamma/dV`` (6, 6) [N s/m | N s/rad].
        accel: ``dGamma/dVdot`` (6, 6) [N s^2/m | N s^2/rad] (the inertia seen by the
            actuators, ``Jp^T A_robot``).
    """

    gamma: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    accel: np.ndarray


@dataclass(frozen=True)
class DirectDynamicsDerivatives:
    """The direct model and its Jacobians at a state (or a batch: a leading N axis).

    Attributes:
        accel: the classical acceleration ``Vdot = [dv/dt, dw/dt]`` (6,) in F0.
        pose: ``dVdot/d delta`` (6, 6), ``delta = [dp, dtheta]`` in F0.
        twist: ``dVdot/dV`` (6, 6).
        gamma: ``dVdot/dGamma`` (6, 6) (``A_robot^-1 Jp^-T``).
    """

    accel: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    gamma: np.ndarray


# ---------------------------------------------------------------------------- symbolic
def perturbed_pose(pose: cs.SX, delta: cs.SX) -> cs.SX:
    """The pose input (16, row-major 0Tp) moved by ``delta = [dp, dtheta]`` in F0, to first
    order: ``p + dp`` and ``(I + dtheta^) R`` (the same derivative at ``delta = 0`` as
    ``exp(dtheta^) R``; only that derivative is used)."""
    T = cs.reshape(pose, 4, 4).T  # CasADi reshapes column-major: the transpose is 0Tp
    R, p = T[:3, :3], T[:3, 3]
    moved = cs.SX.zeros(4, 4)
    moved[:3, :3] = R + cs.mtimes(cs.skew(delta[3:]), R)
    moved[:3, 3] = p + delta[:3]
    moved[3, :] = T[3, :]
    return cs.reshape(moved.T, 16, 1)


@dataclass(frozen=True)
class SymbolicDerivatives:
    """The Jacobians of a robot's generated models as CasADi SX functions.

    Attributes:
        idm: ``(pose, twist, accel, base_parameters) -> (d_pose, d_twist, d_accel)``, each
            (6, 6): the derivatives of Gamma (see :class:`InverseDynamicsDerivatives`).
        ddm: ``(pose, twist, gamma, base_parameters) -> (d_pose, d_twist, d_gamma)``: those
            of the classical acceleration.
        idm_flat, ddm_flat: the same with one output (108,), the three Jacobians row-major
            one after the other (what gets compiled).
        models: the models they differentiate.
    """

    idm: cs.Function
    ddm: cs.Function
    idm_flat: cs.Function
    ddm_flat: cs.Function
    models: SymbolicModels


def _jacobians(model: cs.Function, name: str) -> tuple[cs.Function, cs.Function]:
    n_in = model.n_in()
    if n_in != 4 or model.size1_in(0) != 16 or any(model.size1_in(k) != 6 for k in (1, 2)):
        raise InputError(
            f"{model.name()} must take (pose (16, row-major 0Tp), twist (6), 6-vector, "
            f"parameters), got sizes {[model.size1_in(k) for k in range(n_in)]}: generate "
            "the models with pose='matrix'"
        )
    names = [model.name_in(k) for k in range(4)]
    x = [cs.SX.sym(n, model.size1_in(k)) for k, n in enumerate(names)]
    delta = cs.SX.sym("delta", 6)
    out = model(perturbed_pose(x[0], delta), x[1], x[2], x[3])
    J = cs.jacobian(out, cs.vertcat(delta, x[1], x[2]))
    J = cs.substitute(J, delta, cs.DM.zeros(6))
    blocks = [J[:, 6 * k : 6 * k + 6] for k in range(3)]
    out_names = ["d_pose", "d_twist", f"d_{names[2]}"]
    flat = cs.cse(cs.vertcat(*[cs.vec(b.T) for b in blocks]))  # row-major blocks
    # the matrices from the flat entries (one elimination of common sub-expressions)
    split = [cs.reshape(flat[36 * k : 36 * k + 36], 6, 6).T for k in range(3)]
    return (
        cs.Function(f"{name}_matrices", x, split, names, out_names),
        cs.Function(name, x, [flat], names, ["derivatives"]),
    )


_SYMBOLIC: dict[tuple[int, str], tuple[SymbolicModels, cs.Function, cs.Function]] = {}
_SYMBOLIC_SIZE = 32


def symbolic_derivative(models: SymbolicModels, which: str) -> tuple[cs.Function, cs.Function]:
    """The Jacobians of one of ``models``' functions (``which``: ``"idm"`` or ``"ddm"``)
    as :class:`SymbolicDerivatives` has them (the matrices, then the flat output), built
    once per models object and model: a first use builds only the model it needs."""
    key = (id(models), which)
    found = _SYMBOLIC.get(key)
    if found is not None and found[0] is models:
        return found[1], found[2]
    if len(_SYMBOLIC) >= _SYMBOLIC_SIZE:
        _SYMBOLIC.pop(next(iter(_SYMBOLIC)))
    matrices, flat = _jacobians(models.idm if which == "idm" else models.ddm, _NAMES[which])
    _SYMBOLIC[key] = (models, matrices, flat)
    return matrices, flat


def symbolic_derivatives(models: SymbolicModels) -> SymbolicDerivatives:
    """The Jacobians of ``models`` (any architecture's, with a matrix pose input), built
    once per models object (:func:`symbolic_derivative`)."""
    idm, idm_flat = symbolic_derivative(models, "idm")
    ddm, ddm_flat = symbolic_derivative(models, "ddm")
    return SymbolicDerivatives(idm, ddm, idm_flat, ddm_flat, models)


def symbolic_models_for(robot: RobotLike, coulomb_smoothing: float = 0.0) -> SymbolicModels:
    """The generated closed-form models the derivatives of ``robot`` are built from
    (``coulomb_smoothing`` > 0, ``eps`` [m/s for a prismatic joint, rad/s for a revolute
    one]: every Coulomb sign ``sign(qd)`` of the models smoothed as ``tanh(qd / eps)``,
    the planner's smooth model; built anew on each call).

    This is the one place that says which architectures have them: every robot, through
    :func:`~.symbolic.generate_models` (the ideal 6-UPS: the paper's models with the 88
    base parameters as an input; general legs, ``ups-offset``, ``rus``, ``pus``, custom,
    mixed: the generic models of :mod:`.leg_chain_symbolic`, every number baked in and an
    empty ``base_parameters`` input, so that the derivatives take an empty parameter
    vector).
    """
    if coulomb_smoothing > 0.0:
        return codegen_kind(robot.description).smooth_models(robot.description, coulomb_smoothing)
    return generate_models(robot.description)


def symbolic_actuators_for(robot: RobotLike) -> cs.Function:
    """``actuators(pose, twist) -> (q_a, qdot_a)``, SX: the actuated joint values (6,)
    and their rates (6,) at a platform state (pose 0Tp row-major (16), twist ``[v, w]``
    in F0), the companion of :func:`symbolic_models_for` (the planner's limits).

    The ideal 6-UPS keeps its closed form, the leg lengths ``l_i = |p + R P_i - B_i|``
    [m] and their rates ``a_i . (v + w x L_i)`` (eq. 13); every other robot takes the
    generated models' leg code
    (:func:`~stewart_pin.codegen.leg_chain_symbolic.actuator_function`)."""
    return codegen_kind(robot.description).actuator_function(robot.description)


# ---------------------------------------------------------------------------- C source
_TEMPLATE = r"""
/* ---- stewart-pin: batch loops of the exact derivatives (see codegen/derivatives.py) ---- */
#include <math.h>

#ifndef SP_EXPORT
#define SP_EXPORT __attribute__((visibility("default")))
#endif

#define SP_NONFINITE 32
#define SP_NOUT %(nout)d

/* n states: pose (n x 16), twist (n x 6), x (n x 6),%(idle_doc)s chi -> out (n x SP_NOUT),
   flags (n). Returns the OR of the flags (SP_NONFINITE: a non-finite derivative). */
#define SP_DERIVATIVE_BATCH(NAME, FN, SZ_ARG, SZ_RES, SZ_IW, SZ_W)                      \
SP_EXPORT int NAME(long long n, const double* pose, const double* twist,                 \
                   const double* x,%(idle_param)s const double* chi, double* out, int* flags) { \
  const casadi_real* arg[SZ_ARG + 1];                                                    \
  casadi_real* res[SZ_RES + 1];                                                          \
  casadi_int iw[SZ_IW + 1];                                                              \
  casadi_real w[SZ_W + 1];                                                               \
  int any = 0, k, f;                                                                     \
  long long s;                                                                           \
  for (s = 0; s < n; ++s) {                                                              \
    double* o = out + (long long)SP_NOUT * s;                                            \
    arg[0] = pose + 16 * s; arg[1] = twist + 6 * s; arg[2] = x + 6 * s; arg[3] = chi;    \
%(idle_arg)s    res[0] = o;                                                             \
    FN(arg, res, iw, w, 0);                                                              \
    f = 0;                                                                               \
    for (k = 0; k < SP_NOUT; ++k) if (!isfinite(o[k])) { f = SP_NONFINITE; break; }      \
    flags[s] = f;                                                                        \
    any |= f;                                                                            \
  }                                                                                      \
  return any;                                                                            \
}

"""
#: One model's batch loop and single-state entry (``which``: ``idm`` or ``ddm``).
_ENTRIES = r"""
SP_DERIVATIVE_BATCH(sp_%(which)s_derivatives_batch, %(fn)s, %(sz_arg)d, %(sz_res)d,
                    %(sz_iw)d, %(sz_w)d)

/* One state packed in one read-only block (pose 16 row-major, twist 6, x 6): the
   single-state call from Python, as compiled.py's sp_idm_one. Returns the state's flag. */
SP_EXPORT int sp_%(which)s_derivatives_one(const double* in, const double* chi, double* out) {
  int f;
  sp_%(which)s_derivatives_batch(1, in, in + 16, in + 22, chi, out, &f);
  return f;
}
"""


def derivative_batch_c(nout: int, n_idle: int = 0) -> str:
    """The C header and ``SP_DERIVATIVE_BATCH(NAME, FN, SZ_ARG, SZ_RES, SZ_IW, SZ_W)``, the
    batch loop of a flat Jacobian function ``FN`` with ``nout`` outputs a state; with
    ``n_idle`` > 0 the loop also takes ``idle`` (n x ``n_idle``), after ``x``, as ``FN``'s
    fifth input (the idle freedoms' models of :mod:`.idle_compiled`)."""
    idle = n_idle > 0
    return _TEMPLATE % {
        "nout": nout,
        "idle_doc": f" idle (n x {n_idle})," if idle else "",
        "idle_param": " const double* idle," if idle else "",
        "idle_arg": f"    arg[4] = idle + {n_idle} * s; \\\n" if idle else "",
    }


def derivatives_c_source(derivs: SymbolicDerivatives) -> str:
    """The C source of a robot's derivative library: CasADi's code of ``idm_flat`` and
    ``ddm_flat`` and the batch loops above (numbers only: no text from a description)."""
    return functions_c_source({"idm": derivs.idm_flat, "ddm": derivs.ddm_flat})


def functions_c_source(flat: dict[str, cs.Function]) -> str:
    """The C source of the flat Jacobian functions ``flat`` (``"idm"`` / ``"ddm"`` -> the
    function): CasADi's code and each one's batch loop and single-state entry (the
    library of one model holds one)."""
    cg = cs.CodeGenerator(
        "stewart_derivatives.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    for f in flat.values():
        cg.add(f)
    entries = "".join(
        _ENTRIES
        % {
            "which": which,
            "fn": f.name(),
            **{f"sz_{k}": getattr(f, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
        }
        for which, f in flat.items()
    )
    wrapper = derivative_batch_c(_NOUT)
    return (
        f"/* Generated by stewart-pin (codegen/derivatives.py). */\n{cg.dump()}\n{wrapper}"
        f"{entries}"
    )


# ---------------------------------------------------------------------------- backend
_F64 = np.dtype(np.float64)


def _native(pose: Any, twist: Any, x: Any) -> tuple[bool, Any, Any, Any] | None:
    """``(batched, pose, twist, x)`` when all three are float64 arrays of one state's or one
    batch's shapes (what the value model has just validated), else None."""
    if not all(type(a) is np.ndarray and a.dtype is _F64 for a in (pose, twist, x)):
        return None
    if pose.shape == (4, 4) and twist.shape == (6,) and x.shape == (6,):
        return False, pose, twist, x
    n = pose.shape[0] if pose.ndim == 3 else -1
    if pose.shape[1:] == (4, 4) and twist.shape == (n, 6) and x.shape == (n, 6):
        return True, pose, twist, x
    return None


@dataclass(frozen=True)
class LibraryStatus:
    """Where one model's Jacobians run: ``kind`` (``"compiled"`` or ``"vm"``), ``reason``
    (why the VM), ``library`` (the shared library's path) and ``compiled_now`` (whether
    this process compiled it)."""

    kind: str
    reason: str | None = None
    library: Path | None = None
    compiled_now: bool = False


class ModelLibraries:
    """One shared library per model (``"idm"``, ``"ddm"``) of a robot's exact derivatives,
    sought on the first call that needs it: the first use of :class:`CompiledDerivatives`
    and of :class:`~.idle_compiled.CompiledIdleDerivatives`.

    A library found in the cache is loaded without generating anything (the cache is probed
    by the library's identity, :func:`~._identity.library_identity`). Otherwise the model's
    flat Jacobian function is generated; one with more than :data:`BACKGROUND_INSTRUCTIONS`
    instructions is compiled in a background thread (announced on stderr; not a daemon: a
    process that ends meanwhile waits for it and the library is cached), started by
    :meth:`start_builds` once the first call has its answer, while CasADi's virtual machine
    answers; a smaller one is compiled at once. The libraries are compiled without
    optimisation (:data:`.compiled.QUICK_CFLAGS`). The VM is used (``warn`` told the reason
    once) when a library cannot be built or loaded, or ``compiler`` is False.

    Args:
        desc: the robot's description (its identity keys the cache).
        library_name: the library's name in that identity (``"derivatives"``); the model's
            name is appended.
        subject: what is compiled, for the announcement (``"the exact derivatives"``).
        flat: ``flat(which)``: the model's flat Jacobian function (generated on first need).
        source: ``source(which, function)``: the C source of a library of that function.
        load: ``load(which, path)``: loads a built library.
        warn: ``warn(reason)``: the VM's warning.
        cache_dir, compiler: as for :class:`~.compiled.CompiledDynamics`.

    Attributes:
        status: each sought model's :class:`LibraryStatus`.
    """

    def __init__(
        self,
        desc: Any,
        library_name: str,
        subject: str,
        flat: Callable[[str], cs.Function],
        source: Callable[[str, cs.Function], str],
        load: Callable[[str, Path], None],
        warn: Callable[[str], None],
        cache_dir: str | Path | None = None,
        compiler: str | bool | None = None,
    ) -> None:
        self._desc, self._library_name, self._subject = desc, library_name, subject
        self._flat, self._source, self._load, self._warn = flat, source, load, warn
        self._cache_dir, self._compiler = cache_dir, compiler
        self.status: dict[str, LibraryStatus] = {}
        self.lock = threading.Lock()  # held while a library is sought or a status set
        self._builders: dict[str, threading.Thread] = {}

    def kind(self, which: str) -> str:
        """The kind of one model's Jacobians, its library sought on first use."""
        found = self.status.get(which)
        if found is None:
            with self.lock:
                found = self.status.get(which) or self.seek(which)
        return found.kind

    def seek(self, which: str) -> LibraryStatus:
        """Find in the cache (or build, or start building) and load the library of one
        model's Jacobians (the caller holds :attr:`lock`)."""
        if self._compiler is False:
            return self._vm(which, "compiler disabled")
        what = "" if which == "idm" else "the direct model's "
        subject = self._subject if which == "idm" else self._subject.removeprefix("the ")
        announce = f"{what}{subject} of robot '{printable_name(self._desc)}'"
        identity = library_identity(self._desc, f"{self._library_name} {which}")

        def not_cached() -> str:
            raise _NotCached

        try:
            try:  # the cache first: nothing generated for a library found there
                return self._done(which, *self._build(which, not_cached, announce, identity))
            except _NotCached:
                pass
            flat = self._flat(which)
            if flat.n_instructions() > BACKGROUND_INSTRUCTIONS:
                return self._in_background(which, flat, announce, identity)
            library, now = self._build(
                which, lambda: self._source(which, flat), announce, identity
            )
            return self._done(which, library, now)
        except UnsafeCacheError:
            raise
        except (CompilationError, OSError, AttributeError) as e:
            return self._vm(which, str(e).splitlines()[0] if str(e) else type(e).__name__)

    def _build(
        self, which: str, source_of: Callable[[], str], announce: str, identity: str | None
    ) -> tuple[Path, bool]:
        return build_source_library(
            source_of,
            self._cache_dir,
            self._compiler if isinstance(self._compiler, str) else None,
            lambda path: self._load(which, path),
            announce,
            identity,
            QUICK_CFLAGS,
        )

    def _done(self, which: str, library: Path, now: bool) -> LibraryStatus:
        self.status[which] = LibraryStatus("compiled", None, library, now)
        return self.status[which]

    def _vm(self, which: str, reason: str) -> LibraryStatus:
        self._warn(reason)
        self.status[which] = LibraryStatus("vm", reason)
        return self.status[which]

    def _in_background(
        self, which: str, flat: cs.Function, announce: str, identity: str | None
    ) -> LibraryStatus:
        """Prepare the thread that compiles one model's library (announced on stderr like
        any build) while the VM answers; once loaded, the model's status is compiled."""

        def build() -> None:
            try:
                library, now = self._build(
                    which,
                    lambda: self._source(which, flat),
                    f"{announce} in the background (CasADi's virtual machine answers meanwhile)",
                    identity,
                )
            except Exception as e:  # a failed build leaves the VM, said once
                self._warn(str(e).splitlines()[0] if str(e) else type(e).__name__)
                return
            with self.lock:
                self._done(which, library, now)

        # started once the first call has its answer (CasADi's code generator holds the GIL)
        thread = threading.Thread(target=build, name=f"stewart-pin-{which}-derivatives")
        self._builders[which] = thread
        self.status[which] = LibraryStatus("vm", "compiling in the background")
        return self.status[which]

    def start_builds(self) -> None:
        """Start the background builds not started yet."""
        for thread in list(self._builders.values()):
            if thread.ident is None:
                with contextlib.suppress(RuntimeError):  # started meanwhile by another call
                    thread.start()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the libraries compiling in the background (at most ``timeout`` seconds
        each); whether none is still compiling."""
        self.start_builds()
        for thread in list(self._builders.values()):
            thread.join(timeout)
        return not any(t.is_alive() for t in self._builders.values())


class ModelLibrariesOwner:
    """What a backend whose Jacobians are a :class:`ModelLibraries` (``self._models``)
    says of them: :attr:`kinds`, the inverse model's :attr:`kind`, :attr:`reason`,
    :attr:`library` and :attr:`compiled_now`, and :meth:`wait`."""

    _models: ModelLibraries

    @property
    def kinds(self) -> dict[str, str]:
        """Each model's kind (``"compiled"`` / ``"vm"``), once its library was sought."""
        return {which: st.kind for which, st in self._models.status.items()}

    @property
    def kind(self) -> str:
        """The inverse model's kind: ``"compiled"`` or ``"vm"``."""
        return self._models.status["idm"].kind

    @property
    def reason(self) -> str | None:
        """Why the inverse model's Jacobians run in the VM (None when compiled)."""
        return self._models.status["idm"].reason

    @property
    def library(self) -> Path | None:
        """The inverse model's library (None in the VM)."""
        return self._models.status["idm"].library

    @property
    def compiled_now(self) -> bool:
        """Whether this process compiled the inverse model's library."""
        return self._models.status["idm"].compiled_now

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the libraries compiling in the background (at most ``timeout`` seconds
        each); whether none is still compiling."""
        return self._models.wait(timeout)


class CompiledDerivatives(ModelLibrariesOwner):
    """The exact derivatives of a robot's inverse and direct models, compiled to C (or in
    CasADi's virtual machine).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot`, ideal 6-UPS or with general legs
            (its models from :func:`symbolic_models_for`).
        cache_dir, compiler, threads: as for :class:`~.compiled.CompiledDynamics` (the value
            models that guard each call are built with the same settings).

    Methods (one state: ``pose`` (4, 4) / ``pin.SE3``, vectors (6,); a batch: (N, 4, 4) and
    (N, 6); results with the same leading axis):

    - ``inverse_dynamics_derivatives(pose, twist, accel, base_values=None)`` ->
      :class:`InverseDynamicsDerivatives`;
    - ``direct_dynamics_derivatives(pose, twist, gamma, base_values=None)`` ->
      :class:`DirectDynamicsDerivatives`.

    ``base_values`` replaces the robot's base parameters (as for the value models; a robot
    with general legs has them built in: its parameter vector is empty, and ``base_values``
    other than ``None`` is an :class:`~stewart_pin.exceptions.InputError`).
    Errors: those of the value models for the state, then
    :class:`~stewart_pin.exceptions.NumericalError` for a non-finite derivative.

    Each model's Jacobians are a library of their own, generated and compiled on the first
    call that needs them (the inverse model's on construction, the direct model's on the
    first ``direct_dynamics_derivatives``): a first use waits for one model only. A
    library found in the cache is loaded without generating anything; a large one compiles
    in the background while CasADi's VM answers (:class:`ModelLibraries`, :meth:`wait`).
    :attr:`kind`, :attr:`reason`, :attr:`library` and :attr:`compiled_now` are the inverse
    model's (:attr:`kinds` has each model's kind).

    Attributes:
        threads: the threads of a batch.
    """

    def __init__(
        self,
        robot: RobotLike,
        cache_dir: str | Path | None = None,
        compiler: str | bool | None = None,
        threads: int | None = None,
    ) -> None:
        self.robot = robot
        if cache_dir is None and compiler is None and threads is None:
            self._values = compiled_backend(robot)
        else:
            self._values = CompiledDynamics(robot, cache_dir, compiler, threads)
        self.threads: int = self._values.threads  # checked there
        self._desc = robot.description
        self._cache_dir, self._compiler = cache_dir, compiler
        self._c: dict[str, Any] = {}
        self._c_one: dict[str, Any] = {}
        self._libs: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._one_out = np.zeros(_NOUT)
        self._one_out_ptr = ctypes.c_void_p(self._one_out.ctypes.data)
        self._chi_ptr = ctypes.c_void_p(self._values.base_values.ctypes.data)
        self._models = ModelLibraries(
            self._desc,
            "derivatives",
            "the exact derivatives",
            self._flat,
            lambda which, flat: functions_c_source({which: flat}),
            self._load,
            lambda reason: warn_vm_once("derivatives", reason, _WARNED, stacklevel=4),
            cache_dir,
            compiler,
        )
        with self._models.lock:  # a background build's result is set after this
            self._models.seek("idm")

    def __repr__(self) -> str:
        return f"CompiledDerivatives({self.robot!r}, kind={self.kind!r})"

    @functools.cached_property
    def symbolic(self) -> SymbolicDerivatives:
        """Both models' Jacobians as CasADi functions (generated on first use)."""
        return symbolic_derivatives(symbolic_models_for(self.robot))

    def _flat(self, which: str) -> cs.Function:
        """The flat Jacobian function of one model (generated on first use)."""
        if "symbolic" in self.__dict__:
            return self.symbolic.idm_flat if which == "idm" else self.symbolic.ddm_flat
        return symbolic_derivative(symbolic_models_for(self.robot), which)[1]

    def _load(self, which: str, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        argtypes: list[Any] = [ctypes.c_longlong, *[ctypes.c_void_p] * 6]
        fn = lib[f"{_NAMES[which]}_batch"]
        fn.argtypes = argtypes
        fn.restype = ctypes.c_int
        # The single-state entry without argument types (the fastest ctypes call): a bytes
        # block and prepared pointers; the result buffer's address taken once, a lock
        # making it safe across threads (as compiled.py does).
        one = lib[f"{_NAMES[which]}_one"]
        one.restype = ctypes.c_int
        self._libs[which], self._c[which], self._c_one[which] = lib, fn, one

    # ------------------------------------------------------------------ public API
    def inverse_dynamics_derivatives(
        self, pose: Any, twist: Any, accel: Any, base_values: Any = None
    ) -> InverseDynamicsDerivatives:
        """Gamma and its Jacobians (see :class:`InverseDynamicsDerivatives`)."""
        gamma = self._values.inverse_dynamics(pose, twist, accel, base_values)
        d = self._run("idm", pose, twist, accel, "accel", base_values)
        return InverseDynamicsDerivatives(gamma, *d)

    def direct_dynamics_derivatives(
        self, pose: Any, twist: Any, gamma: Any, base_values: Any = None
    ) -> DirectDynamicsDerivatives:
        """The classical acceleration and its Jacobians (see
        :class:`DirectDynamicsDerivatives`)."""
        accel = self._values.direct_dynamics(pose, twist, gamma, base_values)
        d = self._run("ddm", pose, twist, gamma, "gamma", base_values)
        return DirectDynamicsDerivatives(accel, *d)

    # ------------------------------------------------------------------ internals
    def _run(
        self, which: str, pose: Any, twist: Any, x: Any, name: str, base_values: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The three Jacobians of a state or batch the value model has accepted."""
        chi = self._values.checked_base_values(base_values)
        st = self._models.status.get(which)
        kind = st.kind if st is not None else self._models.kind(which)
        arrays = _native(pose, twist, x)  # already checked by the value model
        if arrays is None:
            batched, T, V, X = check_states(pose, (twist, "twist"), (x, name))
        else:
            batched, T, V, X = arrays
            if not batched and kind == "compiled":
                return self._run_one(which, T, V, X, base_values, chi)
        T, V, X = (np.ascontiguousarray(a, dtype=np.float64) for a in (T, V, X))
        n = T.size // 16
        self._check_newton(which, n, T, V, X, chi)
        out = np.empty((n, _NOUT))
        flags = np.zeros(n, dtype=np.int32)
        if kind == "compiled":
            any_flag = self._call_batch(which, n, T, V, X, chi, out, flags)
        else:
            any_flag = self._run_vm(which, n, T, V, X, chi, out, flags)
            self._models.start_builds()
        if any_flag:
            bad = flags != 0
            raise NumericalError(_OUTPUTS[which], int(np.argmax(bad)), int(bad.sum()), n)
        blocks = out.reshape(n, 3, 6, 6)
        if not batched:
            return blocks[0, 0], blocks[0, 1], blocks[0, 2]
        return blocks[:, 0], blocks[:, 1], blocks[:, 2]

    def _run_one(
        self,
        which: str,
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        base_values: Any,
        chi: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One state of native float64 arrays through the single-state entry."""
        self._check_newton(which, 1, T, V, X, chi)
        chi_ptr = self._chi_ptr if base_values is None else ctypes.c_void_p(chi.ctypes.data)
        block = T.tobytes() + V.tobytes() + X.tobytes()  # float64, C order
        with self._lock:
            flag = self._c_one[which](block, chi_ptr, self._one_out_ptr)
            out = self._one_out.copy()
        if flag:
            raise NumericalError(_OUTPUTS[which], 0, 1, 1)
        blocks = out.reshape(3, 6, 6)
        return blocks[0], blocks[1], blocks[2]

    @functools.cached_property
    def _layout(self) -> Any:
        return model_layout(self._desc)

    def _check_newton(
        self, which: str, n: int, T: np.ndarray, V: np.ndarray, X: np.ndarray, chi: np.ndarray
    ) -> None:
        """Raise :func:`newton_not_converged`'s error when a leg's unrolled Newton steps
        from home did not converge at one of the ``n`` states (their Jacobians are the
        unrolled model's, not the converged solution's): the states the value guard flags
        (GEOMETRY; all of them in the VM) through the guarded value model in CasADi's VM,
        their Newton residual slacks read (a joint limit's or another slack: the
        Jacobians stand, as today)."""
        layout = self._layout
        if not layout.residual:
            return
        T, V, X = T.reshape(n, 16), V.reshape(n, 6), X.reshape(n, 6)
        if self._values.kind == "compiled":
            out, flags = np.empty((n, 6)), np.empty(n, dtype=np.int32)
            if not self._values._call_batch(which, n, T, V, X, chi, out, flags) & _GEOMETRY:
                return
            index = np.flatnonzero(flags & _GEOMETRY)
        else:
            index = np.arange(n)
        f = self._values._vm_function(which)
        start = layout.idm_slack if which == "idm" else layout.ddm_slack
        slacks = np.empty((index.size, layout.n_slack))
        for s in range(0, index.size, VM_CHUNK):
            k = index[s : s + VM_CHUNK]
            aux = np.array(f(T[k].T, V[k].T, X[k].T, chi)[1]).T
            slacks[s : s + k.size] = aux[:, start : start + layout.n_slack]
        error = newton_not_converged(_OUTPUTS[which], layout.residual, slacks, index, n)
        if error is not None:
            raise error

    def _call_batch(
        self,
        which: str,
        n: int,
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        chi: np.ndarray,
        out: np.ndarray,
        flags: np.ndarray,
    ) -> int:
        """The C loop over ``n`` states, split into :attr:`threads` slices of at least
        :data:`THREAD_MIN_STATES` states (ctypes releases the GIL during each call)."""
        fn = self._c[which]
        pT, pV, pX, pc = T.ctypes.data, V.ctypes.data, X.ctypes.data, chi.ctypes.data
        po, pf = out.ctypes.data, flags.ctypes.data

        def call(s: int, m: int) -> int:  # states s .. s + m - 1
            return int(
                fn(m, pT + 128 * s, pV + 48 * s, pX + 48 * s, pc, po + 8 * _NOUT * s, pf + 4 * s)
            )

        return split_batch(n, self.threads, THREAD_MIN_STATES, call)

    def _run_vm(
        self,
        which: str,
        n: int,
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        chi: np.ndarray,
        out: np.ndarray,
        flags: np.ndarray,
    ) -> int:
        f = self._flat(which)
        T2 = T.reshape(n, 16)
        V2, X2 = V.reshape(n, 6), X.reshape(n, 6)
        for s in range(0, n, VM_CHUNK):
            e = min(n, s + VM_CHUNK)
            out[s:e] = np.array(f(T2[s:e].T, V2[s:e].T, X2[s:e].T, chi)).T
        flags[:] = np.where(np.isfinite(out).all(axis=1), 0, 32)
        return int(flags.any())


_BACKENDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_BACKENDS_LOCK = threading.Lock()


def derivatives_backend(robot: RobotLike) -> CompiledDerivatives:
    """The :class:`CompiledDerivatives` of ``robot``, built on first use and kept with it
    (a weak reference: the robot stays picklable)."""
    reason = codegen_kind(robot.description).not_compiled(robot.description)
    if reason is not None:
        raise UnsupportedArchitectureError(
            f"robot '{robot.description.name}' has {reason}: its exact derivatives take "
            "the idle state too (robot.inverse_dynamics_derivatives(..., idle=...): "
            "stewart_pin.codegen.idle_compiled.CompiledIdleDerivatives)",
            "derivatives",
            robot.description.architecture,
        )
    with _BACKENDS_LOCK:
        backend = _BACKENDS.get(robot)
        if backend is None or backend._desc is not robot.description:
            backend = CompiledDerivatives(robot)
            _BACKENDS[robot] = backend
        return backend
