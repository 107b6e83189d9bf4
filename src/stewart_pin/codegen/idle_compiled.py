"""The compiled models of robots whose legs have idle freedoms (issue 20 item 4: an R-S-S
rod's spin), the idle joints' values and rates an input of the C functions.

The models are :func:`~.chain_leg_symbolic.build_idle_models`'s (each leg's Newton steps
with its idle joint at the given value, the reference's idle equations): the IDM takes
``(pose, twist, accel, idle)`` and returns the actuated efforts and the idle joints'
accelerations; the DDM takes ``(pose, twist, gamma, idle)`` and returns the platform's
classical acceleration and the idle joints' accelerations. ``idle`` is
``(values, rates)``, each (6,) or (N, 6) [rad or m, /s], entries of legs without an idle
joint ignored, as the reference
(:class:`~stewart_pin.dynamics.chain_leg_dynamics.ChainDynamics`) takes it.

The library is built and cached as :mod:`.compiled`'s (:func:`.compiled.build_source_library`:
the same cache, key, integrity rules and lock), from CasADi's C of the guarded models and
batch loops written here around :mod:`._csource`'s state guards (:data:`._csource.GUARDS`:
the inputs, every slack of the chain-leg models, the condition bound, the IDM's
partial-pivoting solve, the DDM's ``L D L^T`` pivots, finite results), plus finite idle
inputs. A flagged state goes to the reference path
(``ChainDynamics(check_limits=True)``) with the same idle state; if the reference refuses
one, the whole batch goes through it to raise its error as it would.

:class:`CompiledIdleDerivatives`: the exact Jacobians of both models in the platform state
(the pose chart of :mod:`.derivatives`), the third argument and the idle state, one library
per model compiled without optimisation (:data:`.compiled.QUICK_CFLAGS`), in the background
while CasADi's virtual machine answers (:class:`.derivatives.ModelLibraries`: the first use
of :class:`.derivatives.CompiledDerivatives`).
"""

from __future__ import annotations

import ctypes
import math
import threading
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as cs
import numpy as np

from stewart_pin._checks import check_states
from stewart_pin.codegen import _csource
from stewart_pin.codegen._identity import library_identity
from stewart_pin.codegen.chain_leg_symbolic import IDLE_INPUT, IdleModels, build_idle_models
from stewart_pin.codegen.compiled import (
    auto_env,
    build_or_vm,
    build_source_library,
    default_threads,
    find_compiler,
    positive_threads,
    printable_name,
    split_batch,
    warn_reference,
    warn_vm_once,
)
from stewart_pin.codegen.derivatives import (
    ModelLibraries,
    ModelLibrariesOwner,
    derivative_batch_c,
    newton_not_converged,
    perturbed_pose,
)
from stewart_pin.dynamics.chain_leg_dynamics import ChainDynamics
from stewart_pin.exceptions import (
    CompilationError,
    InputError,
    NumericalError,
    StewartPinError,
    UnsafeCacheError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics import chain_legs
from stewart_pin.kinematics.jacobians import scaled_inverse_jacobian
from stewart_pin.protocols import RobotLike

__all__ = [
    "CompiledIdleDerivatives",
    "CompiledIdleDynamics",
    "IdleDirectDerivatives",
    "IdleInverseDerivatives",
    "auto_idle_backend",
    "idle_backend",
    "idle_c_source",
    "idle_derivatives_backend",
    "idle_derivatives_c_source",
    "idle_models",
]

#: Fewest states per thread for a batch to be split.
THREAD_MIN_STATES = 256
#: States per CasADi VM call in the fallback.
VM_CHUNK = 1024
_FLAGS = _csource.FLAG_NAMES
_REPIVOTED, _COND = _FLAGS["REPIVOTED"], _FLAGS["COND"]
_GEOMETRY = _FLAGS["GEOMETRY"]
_NAMES = {"idm": "inverse dynamics", "ddm": "direct dynamics"}
_WARNED: set[str] = set()

_MODELS: weakref.WeakKeyDictionary[Any, IdleModels] = weakref.WeakKeyDictionary()


def idle_models(desc: Any) -> IdleModels:
    """The symbolic idle models of ``desc`` (cached per description)."""
    found = _MODELS.get(desc)
    if found is None:
        found = build_idle_models(desc)
        _MODELS[desc] = found
    return found


def has_idle_joints(desc: Any) -> bool:
    """Whether ``desc`` has chain legs with idle joints."""
    return bool(chain_legs.idle_legs(desc))


# ---------------------------------------------------------------------------- C source
_LOOPS = (
    r"""
/* ---- stewart-pin: batch loops of the idle models (see codegen/idle_compiled.py) ---- */
#ifndef SP_EXPORT
#define SP_EXPORT __attribute__((visibility("default")))
#endif

#define SP_IDM_NAUX %(idm_naux)d
#define SP_DDM_NAUX %(ddm_naux)d

static int sp_idle_inputs(const double* idle) {
  int k;
  for (k = 0; k < %(n_idle)d; ++k) if (!isfinite(idle[k])) return SP_INPUT;
  return 0;
}

static int sp_idm_after(const double* T, const double* tw, const double* acc, double* g,
                        const double* sigma, const double* aux, double max_cond) {
  double y[6];
  int k, f = sp_check_inputs(T, tw, acc);
"""
    + _csource.IDM_GUARDS
    + r"""  if (!sp_finite6(g) || !sp_finite6(sigma)) f |= SP_NONFINITE;
  return f;
}

static int sp_ddm_after(const double* T, const double* tw, const double* gam, const double* a,
                        const double* sigma, const double* aux, double max_cond) {
  int k, f = sp_check_inputs(T, tw, gam);
  f |= sp_check_legs(aux, %(ddm_slack)d);
  if (!sp_static_cond_ok(aux + %(jinv)d, max_cond))
    f |= sp_check_cond(aux + %(jinv)d, max_cond, 0, 0);
  for (k = 0; k < 6; ++k) if (!(aux[%(ddm_d)d + k] > 0.0)) f |= SP_NOT_PD;
  if (!sp_finite6(a) || !sp_finite6(sigma)) f |= SP_NONFINITE;
  return f;
}

/* n states: pose (n x 16), twist, x (n x 6), idle (n x 12: values, rates), chi -> out
   (n x 6), sigma (n x 6: the idle accelerations), flags (n). Returns the OR of the flags. */
#define SP_IDLE_BATCH(NAME, FN, AFTER, NAUX, SZ_ARG, SZ_RES, SZ_IW, SZ_W)                \
SP_EXPORT int NAME(long long n, const double* pose, const double* twist, const double* x, \
                   const double* idle, const double* chi, double max_cond, double* out,   \
                   double* sigma, int* flags) {                                           \
  const casadi_real* arg[SZ_ARG + 1];                                                     \
  casadi_real* res[SZ_RES + 1];                                                           \
  casadi_int iw[SZ_IW + 1];                                                               \
  casadi_real w[SZ_W + 1];                                                                \
  double aux[NAUX];                                                                       \
  int any = 0, f;                                                                         \
  long long s;                                                                            \
  for (s = 0; s < n; ++s) {                                                               \
    arg[0] = pose + 16 * s; arg[1] = twist + 6 * s; arg[2] = x + 6 * s; arg[3] = chi;     \
    arg[4] = idle + %(n_idle)d * s;                                                       \
    res[0] = out + 6 * s; res[1] = aux; res[2] = sigma + 6 * s;                           \
    f = sp_idle_inputs(arg[4]);                                                           \
    if (!f) {                                                                             \
      FN(arg, res, iw, w, 0);                                                             \
      f = AFTER(arg[0], arg[1], arg[2], res[0], res[2], aux, max_cond);                   \
    }                                                                                     \
    flags[s] = f;                                                                         \
    any |= f;                                                                             \
  }                                                                                       \
  return any;                                                                             \
}

SP_IDLE_BATCH(sp_idle_idm_batch, %(idm)s, sp_idm_after, SP_IDM_NAUX, %(idm_sz_arg)d,
              %(idm_sz_res)d, %(idm_sz_iw)d, %(idm_sz_w)d)
SP_IDLE_BATCH(sp_idle_ddm_batch, %(ddm)s, sp_ddm_after, SP_DDM_NAUX, %(ddm_sz_arg)d,
              %(ddm_sz_res)d, %(ddm_sz_iw)d, %(ddm_sz_w)d)

/* One state in one read-only block (pose 16, twist 6, x 6, idle 12): out (12) = the
   result then the idle accelerations. Returns the state's flag. */
SP_EXPORT int sp_idle_idm_one(const double* in, const double* chi, double max_cond,
                              double* out) {
  int f;
  sp_idle_idm_batch(1, in, in + 16, in + 22, in + 28, chi, max_cond, out, out + 6, &f);
  return f;
}

SP_EXPORT int sp_idle_ddm_one(const double* in, const double* chi, double max_cond,
                              double* out) {
  int f;
  sp_idle_ddm_batch(1, in, in + 16, in + 22, in + 28, chi, max_cond, out, out + 6, &f);
  return f;
}
"""
)


def idle_c_source(desc: Any) -> str:
    """The C source of the idle models' library (numbers only: no text from the
    description)."""
    models = idle_models(desc)
    cg = cs.CodeGenerator(
        "stewart_idle_models.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    fi, fd = models.idm_guarded, models.ddm_guarded
    cg.add(fi)
    cg.add(fd)
    layout = models.layout
    guards = (_csource.GUARDS + _csource.STATIC_COND) % {
        "check_legs": _csource.CHECK_LEGS_GENERAL % {"n_slack": layout.n_slack},
        "rotation_tol": _csource_rotation_tol(),
        "growth_limit": _csource.GROWTH_LIMIT,
        "inv_length": 1.0 / chain_legs.robot_size(desc),
    }
    loops = _LOOPS % {
        "idm_naux": layout.idm_size,
        "ddm_naux": layout.ddm_size,
        **_csource.layout_numbers(layout),
        "n_idle": IDLE_INPUT,
        "idm": fi.name(),
        "ddm": fd.name(),
        **{f"idm_sz_{k}": getattr(fi, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
        **{f"ddm_sz_{k}": getattr(fd, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
    }
    return (
        f"/* Generated by stewart-pin (codegen/idle_compiled.py). */\n{cg.dump()}\n{guards}{loops}"
    )


def _csource_rotation_tol() -> float:
    from stewart_pin._checks import ROTATION_TOLERANCE

    return ROTATION_TOLERANCE * (1.0 - 1e-3)


# ---------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class _Inputs:
    batched: bool
    T: np.ndarray  # (N, 4, 4)
    V: np.ndarray  # (N, 6)
    X: np.ndarray  # (N, 6)
    idle: np.ndarray  # (N, 12)


def _inputs(dyn: ChainDynamics, pose: Any, twist: Any, x: Any, name: str, idle: Any) -> _Inputs:
    """The validated, C-contiguous float64 inputs (the reference's checks and messages)."""
    batched, T, V, X = check_states(pose, (twist, "twist"), (x, name))
    n = T.shape[0]
    state = dyn.idle_state(idle, n)
    if state is None:  # pragma: no cover - the backend is made for robots with idle legs
        raise InputError(f"robot '{dyn.desc.name}' has no idle joints")
    both = np.ascontiguousarray(np.concatenate([state.q, state.qdot], axis=1))
    c = np.ascontiguousarray
    return _Inputs(batched, c(T, dtype=np.float64), c(V), c(X), both)


_F64 = np.dtype(np.float64)


def _one_state(pose: Any, twist: Any, x: Any, idle: Any) -> bytes | None:
    """The single-state block (pose 16, twist 6, x 6, idle values 6, rates 6) when every
    input is a float64 array of one state's shape, else None (the general path)."""
    if type(idle) is not tuple or len(idle) != 2:
        return None
    values, rates = idle
    for a in (pose, twist, x, values, rates):
        if type(a) is not np.ndarray or a.dtype is not _F64:
            return None
    if pose.shape != (4, 4) or twist.shape != (6,) or x.shape != (6,):
        return None
    if values.shape != (6,) or rates.shape != (6,):
        return None
    return pose.tobytes() + twist.tobytes() + x.tobytes() + values.tobytes() + rates.tobytes()


# ---------------------------------------------------------------------------- backend
class CompiledIdleDynamics:
    """The compiled IDM and DDM of a robot with idle freedoms (module docstring).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` whose chain legs have idle joints.
        cache_dir, compiler, threads, vm_fallback, announce: as for
            :class:`~.compiled.CompiledDynamics`.

    Methods (one state: ``pose`` (4, 4), vectors (6,), ``idle`` ``(values, rates)`` each
    (6,); a batch: (N, 4, 4), (N, 6), idle each (N, 6) or (6,)):

    - ``inverse_dynamics(pose, twist, accel, idle)`` -> ``(gamma, idle_accel)``;
    - ``direct_dynamics(pose, twist, gamma, idle)`` -> ``(accel, idle_accel)``.

    Results and errors are those of ``ChainDynamics(check_limits=True)``'s
    ``inverse_dynamics(..., details=True)`` (``gamma``, ``idle_accel``) and
    ``direct_dynamics_idle``.

    Attributes:
        kind: ``"compiled"`` or ``"vm"``; reason; library; compiled_now; threads.
    """

    def __init__(
        self,
        robot: RobotLike,
        cache_dir: str | Path | None = None,
        compiler: str | bool | None = None,
        threads: int | None = None,
        vm_fallback: bool = True,
        announce: bool = False,
    ) -> None:
        desc = robot.description
        if not has_idle_joints(desc):
            raise UnsupportedArchitectureError(
                f"robot '{desc.name}' has no legs with idle joints: its compiled models are "
                "CompiledDynamics'",
                "backend",
                desc.architecture,
            )
        self.robot = robot
        self._desc = desc
        self.threads = default_threads() if threads is None else positive_threads(threads)
        self._reference = ChainDynamics(desc, check_limits=True)
        self._length = chain_legs.robot_size(desc)
        what = f"the idle-state models of robot '{printable_name(desc)}'" if announce else None
        self.library: Path | None
        self.kind, self.reason, self.library, self.compiled_now = build_or_vm(
            lambda cc: build_source_library(
                lambda: idle_c_source(desc),
                cache_dir,
                cc,
                self._load,
                what,
                library_identity(desc, "idle-models"),
            ),
            compiler,
            vm_fallback,
        )
        if self.kind == "vm":
            warn_vm_once("idle models", self.reason or "unknown", _WARNED, stacklevel=4)

    def __repr__(self) -> str:
        return f"CompiledIdleDynamics({self.robot!r}, kind={self.kind!r})"

    def _load(self, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        argtypes: list[Any] = [
            ctypes.c_longlong,
            *[ctypes.c_void_p] * 5,
            ctypes.c_double,
            *[ctypes.c_void_p] * 3,
        ]
        self._c = {}
        self._c_one = {}
        for which in ("idm", "ddm"):
            fn = lib[f"sp_idle_{which}_batch"]
            fn.argtypes = argtypes
            fn.restype = ctypes.c_int
            self._c[which] = fn
            one = lib[f"sp_idle_{which}_one"]
            one.restype = ctypes.c_int
            self._c_one[which] = one
        self._lib = lib
        self._lock = threading.Lock()
        self._one_out = np.zeros(12)
        self._one_out_ptr = ctypes.c_void_p(self._one_out.ctypes.data)
        self._chi = np.zeros(1)
        self._chi_ptr = ctypes.c_void_p(self._chi.ctypes.data)
        self._max_cond = (math.nan, ctypes.c_double(math.nan))

    # ------------------------------------------------------------------ public API
    def inverse_dynamics(
        self, pose: Any, twist: Any, accel: Any, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """The actuated joint-side efforts and the idle joints' accelerations, each (6,) or
        (N, 6)."""
        return self._run("idm", pose, twist, accel, "accel", idle)

    def direct_dynamics(
        self, pose: Any, twist: Any, gamma: Any, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """The platform's classical acceleration and the idle joints' accelerations, each
        (6,) or (N, 6)."""
        return self._run("ddm", pose, twist, gamma, "gamma", idle)

    # ------------------------------------------------------------------ internals
    def _run(
        self, which: str, pose: Any, twist: Any, x: Any, name: str, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        max_cond = self.robot.max_condition
        if self.kind == "compiled":
            block = _one_state(pose, twist, x, idle)
            if block is not None:
                if max_cond != self._max_cond[0]:
                    self._max_cond = (max_cond, ctypes.c_double(max_cond))
                with self._lock:
                    flag = self._c_one[which](
                        block, self._chi_ptr, self._max_cond[1], self._one_out_ptr
                    )
                    out = self._one_out.copy()
                if not flag & ~_REPIVOTED:
                    return out[:6], out[6:]
        inp = _inputs(self._reference, pose, twist, x, name, idle)
        n = inp.T.shape[0]
        out6, sigma = np.empty((n, 6)), np.empty((n, 6))
        flags = np.zeros(n, dtype=np.int32)
        if self.kind == "compiled":
            self._call_batch(which, inp, max_cond, out6, sigma, flags)
        else:
            self._run_vm(which, inp, max_cond, out6, sigma, flags)
        bad = np.flatnonzero(flags & ~_REPIVOTED)
        if bad.size:
            self._resolve(which, bad, (pose, twist, x, idle), inp, out6, sigma, max_cond)
        return (out6, sigma) if inp.batched else (out6[0], sigma[0])

    def _call_batch(
        self,
        which: str,
        inp: _Inputs,
        max_cond: float,
        out: np.ndarray,
        sigma: np.ndarray,
        flags: np.ndarray,
    ) -> int:
        fn = self._c[which]
        pT, pV, pX = inp.T.ctypes.data, inp.V.ctypes.data, inp.X.ctypes.data
        pI, pc = inp.idle.ctypes.data, self._chi.ctypes.data
        po, ps, pf = out.ctypes.data, sigma.ctypes.data, flags.ctypes.data

        def call(s: int, m: int) -> int:
            return int(
                fn(
                    m,
                    pT + 128 * s,
                    pV + 48 * s,
                    pX + 48 * s,
                    pI + 8 * IDLE_INPUT * s,
                    pc,
                    max_cond,
                    po + 48 * s,
                    ps + 48 * s,
                    pf + 4 * s,
                )
            )

        return split_batch(inp.T.shape[0], self.threads, THREAD_MIN_STATES, call)

    def _run_vm(
        self,
        which: str,
        inp: _Inputs,
        max_cond: float,
        out: np.ndarray,
        sigma: np.ndarray,
        flags: np.ndarray,
    ) -> None:
        """The guarded models in CasADi's VM; a state the C guard would flag (a slack, the
        exact singularity measure, the pivots, ``L D L^T``, non-finite) flagged here."""
        models = idle_models(self._desc)
        f = models.idm_guarded if which == "idm" else models.ddm_guarded
        layout = models.layout
        n = inp.T.shape[0]
        aux = np.empty((n, f.size1_out(1)))
        chi = np.zeros(0)
        for s in range(0, n, VM_CHUNK):
            e = min(n, s + VM_CHUNK)
            r, a, g = f(
                inp.T[s:e].reshape(-1, 16).T, inp.V[s:e].T, inp.X[s:e].T, chi, inp.idle[s:e].T
            )
            out[s:e], aux[s:e], sigma[s:e] = np.array(r).T, np.array(a).T, np.array(g).T
        start = layout.idm_slack if which == "idm" else layout.ddm_slack
        with np.errstate(invalid="ignore"):
            bad = ~np.all(aux[:, start : start + layout.n_slack] > 0.0, axis=1)
            J = aux[:, layout.jinv : layout.jinv + 36].reshape(n, 6, 6)
            ok = np.all(np.isfinite(J), axis=(1, 2))
            cond = np.full(n, np.inf)
            cond[ok] = np.linalg.cond(scaled_inverse_jacobian(J[ok], self._length))
            bad |= ~(cond <= max_cond)
            if which == "idm":
                bad |= ~(aux[:, layout.growth] <= _csource.GROWTH_LIMIT)
            else:
                bad |= ~np.all(aux[:, layout.ddm_d : layout.ddm_d + 6] > 0.0, axis=1)
            bad |= ~np.all(np.isfinite(out), axis=1) | ~np.all(np.isfinite(sigma), axis=1)
        flags[bad] = _COND

    def _resolve(
        self,
        which: str,
        bad: np.ndarray,
        args: tuple[Any, Any, Any, Any],
        inp: _Inputs,
        out: np.ndarray,
        sigma: np.ndarray,
        max_cond: float,
    ) -> None:
        """The flagged states through the reference path with their idle state; if it
        refuses one, the whole batch goes through it to raise its error as it would."""
        ref = self._reference
        ref.max_condition = max_cond
        state = chain_legs.IdleState(inp.idle[bad, :6], inp.idle[bad, 6:])
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                g, s = self._reference_values(which, inp.T[bad], inp.V[bad], inp.X[bad], state)
        except StewartPinError:
            pose, twist, x, idle = args
            with np.errstate(over="ignore", invalid="ignore"):  # its error, no warning
                self._reference_values(which, pose, twist, x, idle)
            raise  # pragma: no cover - the subset failed, so the whole batch does
        out[bad], sigma[bad] = g, s

    def _reference_values(
        self, which: str, pose: Any, twist: Any, x: Any, idle: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        ref = self._reference
        if which == "idm":
            r = ref.inverse_dynamics(pose, twist, x, details=True, idle=idle)
            return r.gamma, r.idle_accel
        return ref.direct_dynamics_idle(pose, twist, x, idle=idle)


_BACKENDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_BACKENDS_LOCK = threading.Lock()


def idle_backend(robot: RobotLike, **kwargs: Any) -> CompiledIdleDynamics:
    """The :class:`CompiledIdleDynamics` of ``robot``, built on first use and kept (weakly)
    with it (keyword arguments go to the constructor on that first call)."""
    with _BACKENDS_LOCK:
        backend = _BACKENDS.get(robot)
        if backend is None or backend._desc is not robot.description:
            backend = CompiledIdleDynamics(robot, **kwargs)
            _BACKENDS[robot] = backend
        return backend


_AUTO: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def auto_idle_backend(robot: RobotLike) -> CompiledIdleDynamics | None:
    """What ``backend="auto"`` runs for a robot with idle freedoms: its
    :class:`CompiledIdleDynamics`, or ``None`` for the reference path, decided on the
    robot's first call as :func:`.compiled.auto_backend` decides
    (``$STEWART_PIN_BACKEND=pinocchio``, no C compiler, a failed build: ``None``, with
    one warning per reason)."""
    hit = _AUTO.get(robot)
    if hit is not None and hit[0] is robot.description:
        return hit[1]
    choice: CompiledIdleDynamics | None = None
    if auto_env() != "pinocchio":
        compiler = find_compiler()
        if compiler is None:
            warn_reference("no C compiler found (cc, gcc, clang or $CC)")
        else:
            try:
                choice = idle_backend(robot, compiler=compiler, vm_fallback=False, announce=True)
            except (CompilationError, UnsafeCacheError) as e:
                warn_reference(str(e).splitlines()[0] if str(e) else type(e).__name__)
    _AUTO[robot] = (robot.description, choice)
    return choice


# ---------------------------------------------------------------------------- derivatives
@dataclass(frozen=True)
class IdleInverseDerivatives:
    """The inverse model of a robot with idle freedoms and its Jacobians (a batch: a
    leading N axis). Rows of each Jacobian (12): the six efforts Gamma then the six idle
    accelerations; columns (6) as named.

    Attributes:
        gamma, idle_accel: (6,) each.
        pose: with respect to ``delta = [dp, dtheta]`` in F0 (:mod:`.derivatives`).
        twist, accel: with respect to ``[v, w]`` and the classical acceleration.
        idle_values, idle_rates: with respect to the idle joints' values and rates.
    """

    gamma: np.ndarray
    idle_accel: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    accel: np.ndarray
    idle_values: np.ndarray
    idle_rates: np.ndarray


@dataclass(frozen=True)
class IdleDirectDerivatives:
    """The direct model of a robot with idle freedoms and its Jacobians; rows (12): the
    platform's classical acceleration then the six idle accelerations."""

    accel: np.ndarray
    idle_accel: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    gamma: np.ndarray
    idle_values: np.ndarray
    idle_rates: np.ndarray


#: Numbers per state of the compiled derivatives: (12, 30) row-major.
_NOUT = 12 * 30


def _jacobian_function(model: cs.Function, name: str) -> cs.Function:
    """``(pose, twist, x, base_parameters, idle) -> (12, 30)`` row-major: the Jacobian of
    the flat model in ``[delta, twist, x, idle]``."""
    x = [cs.SX.sym(model.name_in(k), model.size1_in(k)) for k in range(5)]
    delta = cs.SX.sym("delta", 6)
    out = model(perturbed_pose(x[0], delta), x[1], x[2], x[3], x[4])
    J = cs.jacobian(out, cs.vertcat(delta, x[1], x[2], x[4]))
    J = cs.substitute(J, delta, cs.DM.zeros(6))
    flat = cs.cse(cs.vec(cs.densify(J).T))  # dense: every entry written, zeros included
    return cs.Function(name, x, [flat], [model.name_in(k) for k in range(5)], ["d"])


#: One model's batch loop (``which``: ``idm`` or ``ddm``), after
#: :func:`~.derivatives.derivative_batch_c`'s macro.
_DERIV_ENTRY = r"""
SP_DERIVATIVE_BATCH(sp_idle_%(which)s_derivatives, %(fn)s, %(sz_arg)d, %(sz_res)d, %(sz_iw)d,
                    %(sz_w)d)
"""


def idle_derivatives_c_source(which: str, function: cs.Function) -> str:
    """The C source of the library of one model's flat Jacobian function (``which``:
    ``"idm"`` or ``"ddm"``): CasADi's code and its batch loop
    ``sp_idle_<which>_derivatives`` (numbers only: no text from a description)."""
    cg = cs.CodeGenerator(
        "stewart_idle_derivatives.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    cg.add(function)
    loops = derivative_batch_c(_NOUT, IDLE_INPUT) + _DERIV_ENTRY % {
        "which": which,
        "fn": function.name(),
        **{f"sz_{k}": getattr(function, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
    }
    return f"/* Generated by stewart-pin (codegen/idle_compiled.py). */\n{cg.dump()}\n{loops}"


class CompiledIdleDerivatives(ModelLibrariesOwner):
    """The exact Jacobians of :class:`CompiledIdleDynamics`'s models, compiled (or in
    CasADi's VM; ``compiler=False``: the VM, nothing compiled). Each call first evaluates
    the values with the compiled idle models (which raise what the reference raises for
    the state), then the Jacobians (:class:`~stewart_pin.exceptions.NumericalError` for a
    non-finite one).

    - ``inverse_dynamics_derivatives(pose, twist, accel, idle)`` ->
      :class:`IdleInverseDerivatives`;
    - ``direct_dynamics_derivatives(pose, twist, gamma, idle)`` ->
      :class:`IdleDirectDerivatives`.

    First use as :class:`~.derivatives.CompiledDerivatives`'s (the same
    :class:`~.derivatives.ModelLibraries`): one library per model, the inverse model's
    sought on construction and the direct model's on its first call; a library found in
    the cache is loaded without generating anything; a large one (both models of a 6-RSS:
    about 63 000 and 135 000 instructions) compiles in the background, announced on
    stderr, while CasADi's VM answers (:meth:`wait` waits for it). :attr:`kind`,
    :attr:`reason`, :attr:`library` and :attr:`compiled_now` are the inverse model's.

    Args:
        robot: a robot whose chain legs have idle joints.
        values: its :class:`CompiledIdleDynamics` (default: :func:`idle_backend`'s).
        compiler, cache_dir: as for :class:`~.compiled.CompiledDynamics`.
    """

    def __init__(
        self,
        robot: RobotLike,
        values: CompiledIdleDynamics | None = None,
        compiler: str | bool | None = None,
        cache_dir: str | Path | None = None,
    ) -> None:
        self.robot = robot
        self._desc = robot.description
        self._values = values if values is not None else idle_backend(robot)
        self.threads = self._values.threads
        self._f: dict[str, cs.Function] = {}
        self._c: dict[str, Any] = {}
        self._libs: dict[str, Any] = {}
        self._models = ModelLibraries(
            self._desc,
            "idle-derivatives",
            "the exact derivatives with idle freedoms",
            self._flat,
            idle_derivatives_c_source,
            self._load,
            lambda reason: warn_vm_once("idle derivatives", reason, _WARNED, stacklevel=4),
            cache_dir,
            compiler,
        )
        with self._models.lock:  # a background build's result is set after this
            self._models.seek("idm")

    def __repr__(self) -> str:
        return f"CompiledIdleDerivatives({self.robot!r}, kind={self.kind!r})"

    def _flat(self, which: str) -> cs.Function:
        """One model's flat Jacobian function, generated on first use."""
        found = self._f.get(which)
        if found is None:
            models = idle_models(self._desc)
            model = models.flat_idm if which == "idm" else models.flat_ddm
            found = _jacobian_function(model, f"sp_idle_{which}_jac")
            self._f[which] = found
        return found

    def _load(self, which: str, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        fn = lib[f"sp_idle_{which}_derivatives"]
        fn.argtypes = [ctypes.c_longlong, *[ctypes.c_void_p] * 7]
        fn.restype = ctypes.c_int
        self._libs[which], self._c[which] = lib, fn

    def inverse_dynamics_derivatives(
        self, pose: Any, twist: Any, accel: Any, idle: Any
    ) -> IdleInverseDerivatives:
        gamma, sigma = self._values.inverse_dynamics(pose, twist, accel, idle)
        return IdleInverseDerivatives(gamma, sigma, *self._run("idm", pose, twist, accel, idle))

    def direct_dynamics_derivatives(
        self, pose: Any, twist: Any, gamma: Any, idle: Any
    ) -> IdleDirectDerivatives:
        accel, sigma = self._values.direct_dynamics(pose, twist, gamma, idle)
        return IdleDirectDerivatives(accel, sigma, *self._run("ddm", pose, twist, gamma, idle))

    def _run(self, which: str, pose: Any, twist: Any, x: Any, idle: Any) -> list[np.ndarray]:
        name = "accel" if which == "idm" else "gamma"
        inp = _inputs(self._values._reference, pose, twist, x, name, idle)
        n = inp.T.shape[0]
        self._check_newton(which, inp)
        out = np.empty((n, _NOUT))
        flags = np.zeros(n, dtype=np.int32)
        chi = np.zeros(1)
        if self._models.kind(which) == "compiled":
            fn = self._c[which]
            pT, pV, pX, pI = (a.ctypes.data for a in (inp.T, inp.V, inp.X, inp.idle))
            pc, po, pf = chi.ctypes.data, out.ctypes.data, flags.ctypes.data

            def call(s: int, m: int) -> int:
                return int(
                    fn(
                        m,
                        pT + 128 * s,
                        pV + 48 * s,
                        pX + 48 * s,
                        pI + 8 * IDLE_INPUT * s,
                        pc,
                        po + 8 * _NOUT * s,
                        pf + 4 * s,
                    )
                )

            split_batch(n, self.threads, 64, call)
        else:
            f = self._flat(which)
            for s in range(0, n, VM_CHUNK):
                e = min(n, s + VM_CHUNK)
                args = (inp.T[s:e].reshape(-1, 16).T, inp.V[s:e].T, inp.X[s:e].T)
                out[s:e] = np.array(f(*args, np.zeros(0), inp.idle[s:e].T)).T
            flags[:] = np.where(np.isfinite(out).all(axis=1), 0, 32)
            self._models.start_builds()  # once the first call has its answer
        if np.any(flags):
            bad = flags != 0
            raise NumericalError(
                f"{_NAMES[which]} derivatives (idle state)", int(np.argmax(bad)), int(bad.sum()), n
            )
        J = out.reshape(n, 12, 30)
        blocks = [J[:, :, 6 * k : 6 * k + 6] for k in range(5)]
        return [b if inp.batched else b[0] for b in blocks]

    def _check_newton(self, which: str, inp: _Inputs) -> None:
        """Raise :func:`~.derivatives.newton_not_converged`'s error when a leg's 12
        unrolled Newton steps from home did not converge at one of the states (their
        Jacobians are the unrolled model's): the states the value guard flags (GEOMETRY;
        all of them in the VM) through the guarded value model in CasADi's VM, their
        Newton residual slacks read (a joint limit's or another slack: the Jacobians
        stand, as before)."""
        models = idle_models(self._desc)
        layout = models.layout
        if not layout.residual:
            return
        n = inp.T.shape[0]
        if self._values.kind == "compiled":
            out, sigma = np.empty((n, 6)), np.empty((n, 6))
            flags = np.zeros(n, dtype=np.int32)
            max_cond = self.robot.max_condition
            if not self._values._call_batch(which, inp, max_cond, out, sigma, flags) & _GEOMETRY:
                return
            index = np.flatnonzero(flags & _GEOMETRY)
        else:
            index = np.arange(n)
        f = models.idm_guarded if which == "idm" else models.ddm_guarded
        start = layout.idm_slack if which == "idm" else layout.ddm_slack
        slacks = np.empty((index.size, layout.n_slack))
        T = inp.T.reshape(n, 16)
        for s in range(0, index.size, VM_CHUNK):
            k = index[s : s + VM_CHUNK]
            aux = np.array(f(T[k].T, inp.V[k].T, inp.X[k].T, np.zeros(0), inp.idle[k].T)[1]).T
            slacks[s : s + k.size] = aux[:, start : start + layout.n_slack]
        output = f"{_NAMES[which]} derivatives (idle state)"
        error = newton_not_converged(output, layout.residual, slacks, index, n)
        if error is not None:
            raise error


_DERIVATIVES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def idle_derivatives_backend(robot: RobotLike) -> CompiledIdleDerivatives:
    """The :class:`CompiledIdleDerivatives` of ``robot``, built on first use and kept."""
    with _BACKENDS_LOCK:
        found = _DERIVATIVES.get(robot)
    if found is None or found._desc is not robot.description:
        found = CompiledIdleDerivatives(robot, idle_backend(robot))
        with _BACKENDS_LOCK:
            _DERIVATIVES[robot] = found
    return found
