"""The coupled models of a hexapod carrying a payload, compiled to C (issue 24).

:mod:`.payload_symbolic` writes the coupled inverse model, the torque-driven and the
prescribed direct models of a :class:`~stewart_pin.payload_robot.PayloadRobot` (the
hexapod's closed form and the payload's Newton-Euler, every number baked in); CasADi
writes their C, :data:`TEMPLATE` adds the batch loops and the state guards (those of the
hexapod's library, :mod:`._csource`, plus finite payload inputs and unit ``(cos, sin)``
pairs), and the library is built, cached and loaded exactly as the hexapod's
(:func:`.compiled.build_source_library`: same cache folder, integrity rules and lock; the
key is :func:`._identity.library_identity` of the description with the payload's joints
and bodies, :func:`.payload_symbolic.payload_identity`).

Calls. :class:`CompiledPayloadDynamics` runs one state given as native float64 arrays
through ``sp_p*_one`` (their bytes in one block), a batch through ``sp_p*_batch`` on
:attr:`~CompiledPayloadDynamics.threads` threads (:func:`.compiled.split_batch`). A state
the guard flags (any bit but ``REPIVOTED``: the static-pivot LU redone with partial
pivoting in C) is computed again by the reference path (``PayloadRobot``'s methods with
``backend="pinocchio"``), whose result replaces the compiled one; if the reference
refuses one, it runs on the whole call to raise its own error (same type, message and
state index). So the results and errors are the reference path's. ``sp_ppdm_sim`` is the
compiled simulator's entry (:mod:`.simulator`): one prescribed direct-dynamics state with
its by-products and the sign-giving determinant, as the hexapod's ``sp_ddm_aux``.
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import casadi as cs
import numpy as np

from stewart_pin._checks import ROTATION_TOLERANCE, check_states
from stewart_pin.codegen import _csource, _simd
from stewart_pin.codegen._csource import FLAG_NAMES, GROWTH_LIMIT
from stewart_pin.codegen._identity import library_identity
from stewart_pin.codegen.compiled import (
    THREAD_MIN_STATES,
    auto_env,
    build_source_library,
    default_threads,
    find_compiler,
    leg_checks_source,
    model_layout,
    positive_threads,
    printable_name,
    singularity_length,
    split_batch,
    warn_reference,
)
from stewart_pin.codegen.payload_symbolic import (
    PayloadModels,
    arm_joints,
    payload_identity,
    payload_models,
)
from stewart_pin.dynamics.payload import PayloadAcceleration, PayloadEfforts
from stewart_pin.exceptions import (
    CompilationError,
    InputError,
    PayloadError,
    StewartPinError,
    UnsafeCacheError,
)

__all__ = ["TEMPLATE", "CompiledPayloadDynamics", "payload_backend", "payload_c_source"]

_REPIVOTED = FLAG_NAMES["REPIVOTED"]
_F64 = np.dtype(np.float64)
_POSE, _SIX = (4, 4), (6,)
#: Largest ``| |(cos, sin)| - 1 |`` of an unbounded revolute joint's pair the guard lets
#: through (just under the reference's 1e-9, :meth:`Payload.check_configurations`).
UNIT_TOLERANCE = 1e-9 * (1.0 - 1e-3)

#: The C around the generated coupled models: :data:`._csource.GUARDS` (the hexapod's
#: input, leg and condition checks), the payload's input checks, three batch loops and
#: their single-state entries.
TEMPLATE = (
    _csource.GUARDS
    + _csource.STATIC_COND
    + r"""
/* ---- stewart-pin: payload models' batch loops (hand-written, payload_compiled.py) ---- */
#ifndef SP_EXPORT
#define SP_EXPORT __attribute__((visibility("default")))
#endif

#define SP_NQ %(nq)d
#define SP_NV %(nv)d
#define SP_NOUT (6 + SP_NV)

/* The payload's inputs finite, its (cos, sin) pairs of unit norm. */
static int sp_arm_inputs(const double* q, const double* qd, const double* x) {
  int k;
  for (k = 0; k < SP_NQ; ++k) if (!isfinite(q[k])) return SP_INPUT;
  for (k = 0; k < SP_NV; ++k) if (!isfinite(qd[k]) || !isfinite(x[k])) return SP_INPUT;
%(unit_pairs)s  return 0;
}

static int sp_finite_n(const double* x, int n) {
  int k;
  for (k = 0; k < n; ++k) if (!isfinite(x[k])) return 0;
  return 1;
}

/* The inverse model's guards of one state after the generated code ran (o: [Gamma, tau],
   aux: its by-products): the state's flag; a repivoted state's Gamma solved again. */
static int sp_pidm_after(const double** arg, double* o, const double* aux,
                         double max_cond) {
  double y[6], *g = o;  /* Gamma: o's first six */
  int k, f = sp_check_inputs(arg[0], arg[1], arg[2]) | sp_arm_inputs(arg[3], arg[4], arg[5]);
"""
    + _csource.IDM_GUARDS
    + r"""  if (!sp_finite_n(o, SP_NOUT)) f |= SP_NONFINITE;
  return f;
}

/* The direct models' guards: inputs, legs, the singularity measure, every pivot of the
   L D L^T (the first six at ddm_d, then npiv - 6 at ddm_size), finite results. */
static int sp_direct_after(const double** arg, const double* o, const double* aux,
                           int npiv, double max_cond) {
  int k, f = sp_check_inputs(arg[0], arg[1], arg[2]) | sp_arm_inputs(arg[3], arg[4], arg[5]);
  f |= sp_check_legs(aux, %(ddm_slack)d);
  if (!sp_static_cond_ok(aux + %(jinv)d, max_cond))  /* the cheap screen, then the LU */
    f |= sp_check_cond(aux + %(jinv)d, max_cond, 0, 0);
  for (k = 0; k < 6; ++k) if (!(aux[%(ddm_d)d + k] > 0.0)) f |= SP_NOT_PD;
  for (k = 6; k < npiv; ++k) if (!(aux[%(ddm_size)d + k - 6] > 0.0)) f |= SP_NOT_PD;
  if (!sp_finite_n(o, SP_NOUT)) f |= SP_NONFINITE;
  return f;
}

static int sp_pddm_after(const double** arg, double* o, const double* aux,
                         double max_cond) {
  return sp_direct_after(arg, o, aux, 6 + SP_NV, max_cond);
}

static int sp_ppdm_after(const double** arg, double* o, const double* aux,
                         double max_cond) {
  return sp_direct_after(arg, o, aux, 6, max_cond);
}

/* The arguments of state s: pose, twist, accel or gamma, q, qd, qdd or tau. */
#define SP_ARGS(A, S)                                                                    \
  A[0] = pose + 16 * (S); A[1] = twist + 6 * (S); A[2] = x + 6 * (S);                   \
  A[3] = q + SP_NQ * (S); A[4] = qd + SP_NV * (S); A[5] = y + SP_NV * (S);

/* SP_WIDTH states at a time through VFN (the vector copy of the generated code,
   codegen/_simd.py: the inputs gathered into a structure of arrays, the by-products in
   soa, a structure of arrays, copied out per state), then AFTER's guards per state. */
#define SP_VEC_LOOP(VFN, AFTER, NAUX)                                                    \
  {                                                                                      \
    const double* av[SP_WIDTH][6];                                                       \
    double* rv[SP_WIDTH][2];                                                             \
    double* const* resv[SP_WIDTH];                                                       \
    double auxv[SP_WIDTH][NAUX];                                                         \
    sp_vec soa[NAUX], in[28 + SP_NQ + 2 * SP_NV];                                        \
    const sp_vec* argv[6] = {in, in + 16, in + 22, in + 28, in + 28 + SP_NQ,             \
                             in + 28 + SP_NQ + SP_NV};                                   \
    int l, k;                                                                            \
    for (l = 0; l < SP_WIDTH; ++l) { resv[l] = rv[l]; rv[l][1] = 0; }                    \
    for (; s + SP_WIDTH <= n; s += SP_WIDTH) {                                           \
      for (l = 0; l < SP_WIDTH; ++l) {                                                   \
        SP_ARGS(av[l], s + l)                                                            \
        rv[l][0] = out + SP_NOUT * (s + l);                                              \
      }                                                                                  \
      for (k = 0; k < 16; ++k) in[k] = SP_STRIDED(av[0][0], 16, k);                      \
      for (k = 0; k < 6; ++k) in[16 + k] = SP_STRIDED(av[0][1], 6, k);                   \
      for (k = 0; k < 6; ++k) in[22 + k] = SP_STRIDED(av[0][2], 6, k);                   \
      for (k = 0; k < SP_NQ; ++k) in[28 + k] = SP_STRIDED(av[0][3], SP_NQ, k);           \
      for (k = 0; k < SP_NV; ++k) {                                                      \
        in[28 + SP_NQ + k] = SP_STRIDED(av[0][4], SP_NV, k);                             \
        in[28 + SP_NQ + SP_NV + k] = SP_STRIDED(av[0][5], SP_NV, k);                     \
      }                                                                                  \
      VFN(argv, 0, resv, soa);                                                           \
      for (l = 0; l < SP_WIDTH; ++l) {                                                   \
        for (k = 0; k < NAUX; ++k) auxv[l][k] = soa[k][l];                               \
        f = AFTER(av[l], rv[l][0], auxv[l], max_cond);                                   \
        flags[s + l] = f;                                                                \
        any |= f;                                                                        \
      }                                                                                  \
    }                                                                                    \
  }

/* A batch loop: n states (pose n x 16; twist, x n x 6; q n x nq; qd, y n x nv) -> out
   (n x (6 + nv)), flags (n); returns the OR of the flags. */
#define SP_BATCH(NAME, FN, VEC, VFN, AFTER, SZ_ARG, SZ_RES, SZ_IW, SZ_W, NAUX)            \
  SP_EXPORT int NAME(long long n, const double* pose, const double* twist,                 \
                     const double* x, const double* q, const double* qd, const double* y,  \
                     double max_cond, double* out, int* flags) {                           \
    const casadi_real* arg[SZ_ARG + 1];                                                    \
    casadi_real* res[SZ_RES + 1];                                                          \
    casadi_int iw[SZ_IW + 1];                                                              \
    casadi_real w[SZ_W + 1];                                                               \
    double aux[NAUX];                                                                      \
    int any = 0, f;                                                                        \
    long long s = 0;                                                                       \
    if (VEC && SP_VEC_READY()) SP_VEC_LOOP(VFN, AFTER, NAUX)                               \
    for (; s < n; ++s) {                                                                   \
      SP_ARGS(arg, s)                                                                      \
      res[0] = out + SP_NOUT * s; res[1] = aux;                                            \
      FN(arg, res, iw, w, 0);                                                              \
      f = AFTER(arg, res[0], aux, max_cond);                                               \
      flags[s] = f;                                                                        \
      any |= f;                                                                            \
    }                                                                                      \
    return any;                                                                            \
  }

%(vec_stubs)s
/* Coupled inverse dynamics: pose, twist, accel, q, qd, qdd -> [Gamma, tau]. */
SP_BATCH(sp_pidm_batch, %(idm)s, SP_VEC_IDM, sp_pidm_vec, sp_pidm_after, %(idm_sz_arg)d,
         %(idm_sz_res)d, %(idm_sz_iw)d, %(idm_sz_w)d, %(idm_naux)d)
/* Torque-driven direct dynamics: pose, twist, gamma, q, qd, tau -> [A, qdd]. */
SP_BATCH(sp_pddm_batch, %(ddm)s, SP_VEC_DDM, sp_pddm_vec, sp_pddm_after, %(ddm_sz_arg)d,
         %(ddm_sz_res)d, %(ddm_sz_iw)d, %(ddm_sz_w)d, %(ddm_naux)d)
/* Prescribed direct dynamics: pose, twist, gamma, q, qd, qdd -> [A, tau]. */
SP_BATCH(sp_ppdm_batch, %(pddm)s, SP_VEC_PDM, sp_ppdm_vec, sp_ppdm_after, %(pddm_sz_arg)d,
         %(pddm_sz_res)d, %(pddm_sz_iw)d, %(pddm_sz_w)d, %(pddm_naux)d)

/* One state packed in one read-only block (pose 16, twist 6, accel or gamma 6, q, qd,
   the third joint vector): [.., ..] (6 + nv) to out; the state's flag. */
#define SP_ONE(NAME, BATCH)                                                              \
  SP_EXPORT int NAME(const double* in, double max_cond, double* out) {                   \
    int f;                                                                               \
    BATCH(1, in, in + 16, in + 22, in + 28, in + 28 + SP_NQ, in + 28 + SP_NQ + SP_NV,    \
          max_cond, out, &f);                                                            \
    return f;                                                                            \
  }
SP_ONE(sp_pidm_one, sp_pidm_batch)
SP_ONE(sp_pddm_one, sp_pddm_batch)
SP_ONE(sp_ppdm_one, sp_ppdm_batch)

/* The compiled simulator's entry (codegen/_simsource.py, the signature of the hexapod's
   sp_ddm_aux): one prescribed direct-dynamics state, the payload's joints
   x = [q, qd, qdd]; the platform's acceleration (6) to accel, the by-products to aux
   (SP_PPDM_NAUX values, Jp^-1 at SP_PPDM_JINV), *det the determinant of S the cheap
   condition check computed (0.0 where it did not decide). The scalar path of
   sp_ppdm_batch (the single-state calls' arithmetic). Returns the state's flag. */
#define SP_PPDM_NAUX %(pddm_naux)d
#define SP_PPDM_JINV %(jinv)d
SP_EXPORT int sp_ppdm_sim(const double* pose, const double* twist, const double* gam,
                          const double* x, double max_cond, double* accel, double* aux,
                          double* det) {
  const casadi_real* arg[%(pddm_sz_arg)d + 1];
  casadi_real* res[%(pddm_sz_res)d + 1];
  casadi_int iw[%(pddm_sz_iw)d + 1];
  casadi_real w[%(pddm_sz_w)d + 1];
  double o[SP_NOUT];
  int f, k;
  arg[0] = pose; arg[1] = twist; arg[2] = gam;
  arg[3] = x; arg[4] = x + SP_NQ; arg[5] = x + SP_NQ + SP_NV;
  res[0] = o; res[1] = aux;
  %(pddm)s(arg, res, iw, w, 0);
  f = sp_ppdm_after(arg, o, aux, max_cond);
  if (!sp_static_cond_det(aux + SP_PPDM_JINV, max_cond, det)) *det = 0.0;
  for (k = 0; k < 6; ++k) accel[k] = o[k];
  return f;
}

/* sp_ppdm_sim's layout: out[0] the by-products' count, out[1] the offset of Jp^-1. */
SP_EXPORT void sp_ppdm_sim_layout(long long* out) {
  out[0] = SP_PPDM_NAUX;
  out[1] = SP_PPDM_JINV;
}
"""
)


def _unit_pairs_source(pairs: tuple[int, ...]) -> str:
    """The C lines checking each unbounded revolute joint's ``(cos, sin)`` at ``q[i]``,
    ``q[i + 1]``."""
    lines = []
    for i in pairs:
        lines.append(
            f"  if (!(fabs(sqrt(q[{i}] * q[{i}] + q[{i + 1}] * q[{i + 1}]) - 1.0) <= "
            f"{UNIT_TOLERANCE!r})) return SP_INPUT;\n"
        )
    return "".join(lines)


def _sizes(prefix: str, f: cs.Function) -> dict[str, int]:
    return {f"{prefix}_sz_{k}": int(getattr(f, f"sz_{k}")()) for k in ("arg", "res", "iw", "w")}


def payload_c_source(
    desc: Any, payload: Any, models: PayloadModels | None = None, vector: bool = True
) -> str:
    """The C source of the coupled models of ``desc`` carrying ``payload``: CasADi's
    generated functions, their copies several states at a time (:mod:`._simd`, unless
    ``vector`` is false) and :data:`TEMPLATE` (only numbers enter it)."""
    m = payload_models(desc, payload, model_layout(desc)) if models is None else models
    cg = cs.CodeGenerator(
        "stewart_payload.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    for f in (m.idm, m.ddm, m.pddm):
        cg.add(f)
    lay = m.layout
    code = cg.dump()
    names = {
        m.idm.name(): "sp_pidm_vec",
        m.ddm.name(): "sp_pddm_vec",
        m.pddm.name(): "sp_ppdm_vec",
    }
    vec, written = _simd.vector_source(code, names) if vector else ("", set())
    flags = {"sp_pidm_vec": "SP_VEC_IDM", "sp_pddm_vec": "SP_VEC_DDM", "sp_ppdm_vec": "SP_VEC_PDM"}
    # a model without its vector copy: its flag 0 and a stub the dead branch names
    stubs = "".join(
        f"#define {flag} 1\n"
        if v in written
        else f"#define {flag} 0\n#define {v}(a, b, r, s) ((void)(a), (void)(r), (void)(s))\n"
        for v, flag in flags.items()
    )
    if not written:
        stubs = (
            "#define SP_WIDTH 1\n#define SP_VEC_READY() 0\n#define SP_STRIDED(p, d, k) 0\n"
            "typedef double sp_vec __attribute__((vector_size(8)));\n" + stubs
        )
    wrapper = TEMPLATE % {
        "vec_stubs": stubs,
        "check_legs": leg_checks_source(desc, lay),
        "rotation_tol": ROTATION_TOLERANCE * (1.0 - 1e-3),
        "growth_limit": GROWTH_LIMIT,
        "inv_length": 1.0 / singularity_length(desc),
        "nq": m.nq,
        "nv": m.nv,
        "unit_pairs": _unit_pairs_source(m.unit_pairs),
        "idm": m.idm.name(),
        "ddm": m.ddm.name(),
        "pddm": m.pddm.name(),
        "idm_naux": m.idm.size1_out(1),
        "ddm_naux": m.ddm.size1_out(1),
        "pddm_naux": m.pddm.size1_out(1),
        **_csource.layout_numbers(lay),
        "ddm_size": lay.ddm_size,
        **_sizes("idm", m.idm),
        **_sizes("ddm", m.ddm),
        **_sizes("pddm", m.pddm),
    }
    return (
        f"/* Generated by stewart-pin (codegen/payload_compiled.py). */\n{code}\n{vec}\n{wrapper}"
    )


class CompiledPayloadDynamics:
    """The coupled models of a hexapod carrying a payload, compiled to C.

    Args:
        robot: a :class:`~stewart_pin.payload_robot.PayloadRobot` (its hexapod's
            description and ``max_condition``, its payload; its reference path decides
            the states the guard flags).
        cache_dir: the cache folder (default :func:`.compiled.cache_root`).
        compiler: the C compiler (default :func:`.compiled.find_compiler`).
        threads: threads sharing a batch (default :func:`.compiled.default_threads`).
        announce: say on stderr, in one line, when the library is compiled.

    Raises:
        PayloadError: a payload joint the generator does not take (neither revolute nor
            prismatic about one axis). CompilationError: no compiler, or the build fails.
        UnsafeCacheError: a cache folder others could have written.

    Methods ``inverse_dynamics`` and ``direct_dynamics`` take the arguments of
    ``PayloadRobot``'s (one state or a batch) and return the same
    :class:`~stewart_pin.dynamics.payload.PayloadEfforts` /
    :class:`~stewart_pin.dynamics.payload.PayloadAcceleration`.

    Attributes:
        library: the shared library's path. compiled_now: whether this construction
            compiled it. threads: see above.
    """

    def __init__(
        self,
        robot: Any,
        cache_dir: str | Path | None = None,
        compiler: str | None = None,
        threads: int | None = None,
        announce: bool = False,
    ) -> None:
        self.robot = robot
        self.threads = default_threads() if threads is None else positive_threads(threads)
        desc = robot.robot.description
        self._desc = desc
        payload = robot.payload
        self.nq, self.nv = payload.nq, payload.nv
        self._shape_q, self._shape_v = (self.nq,), (self.nv,)
        arm_joints(payload)  # refuses a joint it cannot generate, before anything else
        identity = library_identity(
            desc, "payload models\n" + payload_identity(payload, desc.gravity)
        )
        what = (
            f"the payload models of robot '{printable_name(desc)}' carrying "
            f"'{printable_name(payload)}'"
            if announce
            else None
        )
        self.library, self.compiled_now = build_source_library(
            lambda: payload_c_source(desc, payload),
            cache_dir,
            compiler,
            self._load,
            what,
            identity,
        )

    def __repr__(self) -> str:
        return f"CompiledPayloadDynamics({self.robot!r})"

    def _load(self, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        self._lib = lib
        batch_types: list[Any] = [ctypes.c_longlong, *[ctypes.c_void_p] * 6, ctypes.c_double]
        batch_types += [ctypes.c_void_p, ctypes.c_void_p]
        self._batch: dict[str, Any] = {}
        self._one: dict[str, Any] = {}
        for which in ("pidm", "pddm", "ppdm"):
            fn = lib[f"sp_{which}_batch"]
            fn.argtypes = batch_types
            fn.restype = ctypes.c_int
            self._batch[which] = fn
            one = lib[f"sp_{which}_one"]  # called without argtypes: the fastest call
            one.restype = ctypes.c_int
            self._one[which] = one
        layout = (ctypes.c_longlong * 2)()
        lib.sp_ppdm_sim_layout(layout)
        #: The compiled simulator's entry ``sp_ppdm_sim`` (address), its by-products'
        #: count and the offset of ``Jp^-1`` among them.
        self.sim_entry = (
            int(ctypes.cast(lib.sp_ppdm_sim, ctypes.c_void_p).value or 0),
            int(layout[0]),
            int(layout[1]),
        )
        self._lock = threading.Lock()
        self._out = np.zeros(6 + self.nv)
        self._out_ptr = ctypes.c_void_p(self._out.ctypes.data)
        self._max_cond = (float("nan"), ctypes.c_double(float("nan")))

    # ------------------------------------------------------------------ public API
    def inverse_dynamics(
        self, pose: Any, twist: Any, accel: Any, q: Any, qd: Any, qdd: Any
    ) -> PayloadEfforts:
        """``PayloadEfforts(gamma, tau)``, as ``PayloadRobot.inverse_dynamics``."""
        out, batched, _ = self._run("pidm", pose, twist, accel, q, qd, qdd, "accel", "payload qdd")
        if batched:
            return PayloadEfforts(out[:, :6], out[:, 6:])
        return PayloadEfforts(out[:6], out[6:])

    def direct_dynamics(
        self, pose: Any, twist: Any, gamma: Any, q: Any, qd: Any, qdd: Any = None, tau: Any = None
    ) -> PayloadAcceleration:
        """``PayloadAcceleration(accel, qdd, tau)``, as ``PayloadRobot.direct_dynamics``
        (give exactly one of ``qdd``, ``tau``)."""
        if (qdd is None) == (tau is None):
            raise InputError(
                "give the payload's joint accelerations qdd (prescribed motion) or its joint "
                "torques tau (keyword), exactly one"
            )
        if tau is None:
            out, _, given = self._run(
                "ppdm", pose, twist, gamma, q, qd, qdd, "gamma", "payload qdd"
            )
            return PayloadAcceleration(out[..., :6], given, out[..., 6:])
        out, _, given = self._run("pddm", pose, twist, gamma, q, qd, tau, "gamma", "payload tau")
        return PayloadAcceleration(out[..., :6], out[..., 6:], given)

    # ------------------------------------------------------------------ internals
    def _run(
        self,
        which: str,
        pose: Any,
        twist: Any,
        x: Any,
        q: Any,
        qd: Any,
        y: Any,
        x_name: str,
        y_name: str,
    ) -> tuple[np.ndarray, bool, np.ndarray]:
        """``(out (6 + nv) or (N, 6 + nv), batched, y)`` of the model ``which``, ``y`` the
        third joint vector checked (the input itself when it is a native array)."""
        args = (pose, twist, x, q, qd, y)
        try:  # one state as native float64 arrays: the hot path, no generic checks
            native = (
                pose.dtype is _F64
                and twist.dtype is _F64
                and x.dtype is _F64
                and q.dtype is _F64
                and qd.dtype is _F64
                and y.dtype is _F64
                and pose.shape == _POSE
                and twist.shape == _SIX
                and x.shape == _SIX
                and q.shape == self._shape_q
                and qd.shape == self._shape_v
                and y.shape == self._shape_v
            )
        except AttributeError:
            native = False
        if native:
            block = (
                pose.tobytes() + twist.tobytes() + x.tobytes()
                + q.tobytes() + qd.tobytes() + y.tobytes()
            )  # fmt: skip
            max_cond = self.robot.max_condition
            if max_cond != self._max_cond[0]:
                self._max_cond = (max_cond, ctypes.c_double(max_cond))
            c_max_cond = self._max_cond[1]
            with self._lock:
                flag = self._one[which](block, c_max_cond, self._out_ptr)
                out = self._out.copy()
            if flag & ~_REPIVOTED:
                self._resolve(which, np.array([flag]), args, out[None])
            return out, False, y
        nq, nv = self.nq, self.nv
        n = _native_batch(args, nq, nv)
        if n:  # a batch of C-contiguous float64 arrays: the C guard checks the values
            batched, Y, arrays = True, y, list(args)
        else:
            batched, T, V, X = check_states(pose, (twist, "twist"), (x, x_name))
            Q, Qd, Y = self.robot._joints(len(T), batched, q, (qd, "payload qd"), (y, y_name))
            n = T.shape[0]
            arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (T, V, X, Q, Qd, Y)]
        out = np.empty((n, 6 + nv))
        flags = np.empty(n, dtype=np.int32)
        fn = self._batch[which]
        ptrs = [a.ctypes.data for a in arrays]
        sizes = (128, 48, 48, 8 * nq, 8 * nv, 8 * nv)
        po, pf = out.ctypes.data, flags.ctypes.data
        max_cond = float(self.robot.max_condition)
        nout = 8 * (6 + nv)

        def call(s: int, m: int) -> int:
            return int(
                fn(
                    m,
                    *(p + z * s for p, z in zip(ptrs, sizes, strict=True)),
                    max_cond,
                    po + nout * s,
                    pf + 4 * s,
                )
            )

        any_flag = split_batch(n, self.threads, THREAD_MIN_STATES, call)
        if any_flag & ~_REPIVOTED:
            self._resolve(which, flags, args, out, arrays)
        return (out, True, Y) if batched else (out[0], False, Y[0])

    def _reference(self, which: str) -> Callable[..., Any]:
        robot = self.robot
        if which == "pidm":
            return lambda *a: robot.inverse_dynamics(*a, backend="pinocchio")
        if which == "pddm":
            return lambda T, V, G, q, qd, t: robot.direct_dynamics(
                T, V, G, q, qd, tau=t, backend="pinocchio"
            )
        return lambda T, V, G, q, qd, a: robot.direct_dynamics(
            T, V, G, q, qd, a, backend="pinocchio"
        )

    def _resolve(
        self,
        which: str,
        flags: np.ndarray,
        args: tuple[Any, ...],
        out: np.ndarray,
        arrays: list[np.ndarray] | None = None,
    ) -> None:
        """The flagged states (but ``REPIVOTED`` alone, solved already) computed by the
        reference path into ``out`` (N, 6 + nv); a state it refuses: the reference on the
        whole call, which raises its error (the guard checks every leg limit, a 6-UPS's
        U-joint angles too)."""
        ref = self._reference(which)
        if arrays is None:  # one native state
            arrays = [np.asarray(a)[None] for a in args]
        bad = np.flatnonzero(flags & ~_REPIVOTED)
        if bad.size == 0:
            return
        with np.errstate(over="ignore", invalid="ignore"):
            try:
                r = ref(*(a[bad] for a in arrays))
            except StewartPinError:
                ref(*args)  # raises the reference's error for the whole call
                raise  # pragma: no cover - the subset failed, so the whole call does
        first = r.gamma if which == "pidm" else r.accel
        second = r.tau if which in ("pidm", "ppdm") else r.qdd
        out[bad, :6] = first
        out[bad, 6:] = second


def _native_batch(args: tuple[Any, ...], nq: int, nv: int) -> int:
    """The number of states when ``args`` (pose, twist, x, q, qd, y) are a batch of
    C-contiguous float64 ndarrays of the shapes (N, 4, 4), (N, 6), (N, 6), (N, nq),
    (N, nv), (N, nv), N > 0 (the C guard then checks their values, and a state it flags
    goes through the reference path, which raises the reference's error); else 0."""
    first = args[0]
    if type(first) is not np.ndarray or first.ndim != 3 or first.shape[0] == 0:
        return 0
    n = first.shape[0]
    shapes = ((n, 4, 4), (n, 6), (n, 6), (n, nq), (n, nv), (n, nv))
    for a, shape in zip(args, shapes, strict=True):
        if not (
            type(a) is np.ndarray and a.dtype is _F64 and a.shape == shape and a.flags.c_contiguous
        ):
            return 0
    return n


# ---------------------------------------------------------------------------- backends
#: The attribute under which a PayloadRobot keeps its backend choices.
PAYLOAD_ATTR = "_stewart_pin_payload_backends"


def payload_backend(robot: Any, backend: str) -> CompiledPayloadDynamics | None:
    """The compiled coupled models serving ``robot`` (a ``PayloadRobot``) for
    ``backend``, decided on its first call with that backend and kept with it:

    - ``"compiled"``: :class:`CompiledPayloadDynamics`, built on first use (one line on
      stderr says so) or found in the cache; its errors propagate (no compiler:
      :class:`CompilationError`; a joint it cannot generate: :class:`PayloadError`);
    - ``"auto"``: the same, or ``None`` (the reference path) under
      ``$STEWART_PIN_BACKEND=pinocchio``, without a C compiler, or when building fails or
      a joint cannot be generated (one :class:`RuntimeWarning` per reason and process).
    """
    memo = robot.__dict__.setdefault(PAYLOAD_ATTR, {})
    if backend in memo:
        return memo[backend]
    if backend == "compiled":
        if memo.get("auto") is not None:
            choice: CompiledPayloadDynamics | None = memo["auto"]
        else:
            choice = CompiledPayloadDynamics(robot, announce=True)
    else:
        choice = _auto_choice(robot, memo)
    memo[backend] = choice
    return choice


def _auto_choice(robot: Any, memo: dict[str, Any]) -> CompiledPayloadDynamics | None:
    if auto_env() == "pinocchio":
        return None
    if memo.get("compiled") is not None:
        return memo["compiled"]
    compiler = find_compiler()
    if compiler is None:
        warn_reference("no C compiler found (cc, gcc, clang or $CC)")
        return None
    try:
        return CompiledPayloadDynamics(robot, compiler=compiler, announce=True)
    except (CompilationError, UnsafeCacheError, PayloadError) as e:
        warn_reference(str(e).splitlines()[0] if str(e) else type(e).__name__)
        return None
