"""The hand-written C around the CasADi-generated models: batch loops and state guards.

For each state, the batch loop calls the generated function with its CasADi signature
(``arg``/``res`` pointer arrays, ``iw``, ``w``, ``mem``; the work arrays live on the stack)
and then ``guard``, which sets bits of the state's flag (:data:`FLAG_NAMES`):

- ``INPUT``: a non-finite number, a last pose row other than ``[0, 0, 0, 1]``, a rotation
  block off orthonormal (``max |R^T R - I|`` past just under the reference's tolerance) or
  a reflection;
- ``GEOMETRY``: for the paper's 6-UPS models (:data:`CHECK_LEGS_UPS`), a leg shorter than
  (or within 1e-6 of) the minimum leg length, as close to its first U-joint axis as the
  threshold, outside (or within 1e-9 of the ends of) its stroke, or a U-joint angle
  outside (or within 1e-9 rad of) its limits (:data:`CHECK_U_JOINTS_UPS`; thresholds of
  :mod:`stewart_pin.kinematics.geometry`); for general legs (:data:`CHECK_LEGS_GENERAL`), a
  slack of the generated code not positive (a leg out of reach or near it, near a serial
  singularity, a joint at or near its limits, a custom leg's Newton residual: see
  :mod:`stewart_pin.codegen.leg_chain_symbolic`);
- ``COND``: the upper bound ``2 / |det S| (||S||_F^2 / 6)^3`` of cond(S) (Guggenheimer,
  Edelman & Johnson 1995), ``S = Jp^-1 diag(1, 1, 1, 1/l, 1/l, 1/l)`` the singularity
  measure's matrix (``l`` the characteristic length), passes half the threshold, and so
  does the tighter ``||S||_F ||S^-1||_F`` (``S^-1`` from an LU with partial pivoting): the
  caller computes the exact measure of those states only. The determinant comes from the
  generated code's static-pivot LU (IDM) or, first, from an LU of ``S`` without pivoting
  whose multipliers stay within ``GROWTH_LIMIT`` (DDM; else the pivoted one);
- ``REPIVOTED`` (IDM): the static-pivot LU of the generated code met a multiplier larger
  than ``GROWTH_LIMIT``; the state was solved again here with partial pivoting (not an
  error);
- ``NOT_PD`` (DDM): a pivot of ``A_robot = L D L^T`` is not positive;
- ``NONFINITE``: a non-finite result.

Where the generated function is plain straight-line code (every model but custom legs,
whose generated code calls sub-functions), the batch loop runs ``SP_WIDTH`` states at a
time (:mod:`._simd`: four with AVX2, when the processor has it, else the scalar loop on
x86; two on other processors; ``SP_VEC_IDM`` / ``SP_VEC_DDM`` defined): their inputs
gathered into a structure of arrays, the vector copy of the generated code, then a vector
screen of the guards (``sp_v_idm_ok`` / ``sp_v_ddm_ok``: the lanes whose scalar guard would
return 0, computed with the same operations) and the scalar guards (``sp_idm_after`` /
``sp_ddm_after``) only for the lanes the screen does not pass; the last states (fewer
than ``SP_WIDTH``) take the scalar function. The flags and results equal the scalar
path's (tests/test_compiled_calls.py).

``sp_ddm_aux`` runs one direct-dynamics state and returns its by-products too (the
compiled simulator, :mod:`._simsource`, reads ``Jp^-1`` there). It and ``sp_idm_sim`` (the
simulator's computed-torque controller) run the AVX2+FMA copy of the generated code
(:data:`AVX2_COPY`) where the processor has both: results within a few units in the last
place of the batch and single-state calls', which never take it.

``sp_idm_one`` / ``sp_ddm_one`` run one state packed in one read-only input block (the
single-state call from Python passes the bytes of its three arrays, no numpy buffer
addresses to take). The batch loops keep no state between calls, so
disjoint slices of a batch run concurrently (the caller's thread pool: ctypes releases the
GIL around each call).

The margins make the guard flag generously: a flagged state is decided by the reference
checks in Python (for general legs, computed by the reference path), so the compiled path
raises exactly what the reference path raises.
"""

from __future__ import annotations

from typing import Any

FLAG_NAMES = {
    "INPUT": 1,
    "GEOMETRY": 2,
    "COND": 4,
    "REPIVOTED": 8,
    "NOT_PD": 16,
    "NONFINITE": 32,
}
#: Largest static-pivot multiplier trusted before solving again with partial pivoting.
GROWTH_LIMIT = 16.0

#: The leg checks of the paper's 6-UPS models: leg lengths and leg singularities from the
#: ``q3^2`` and ``rho^2 = (q3 sin q2)^2`` of the generated code (``slack`` unused).
CHECK_LEGS_UPS = r"""
static const double sp_stroke_lo2 = %(lo2)r;  /* stroke ends squared, with margins */
static const double sp_stroke_hi2 = %(hi2)r;
static const double sp_min_length2 = %(min_length2)r;
static const double sp_min_sin2 = %(min_sin2)r;

/* Leg lengths and leg singularities from q3^2 and rho^2 = (q3 sin q2)^2. */
static int sp_check_legs(const double* aux, int slack) {
  const double* q3sq = aux + %(q3sq)d;
  const double* rho2 = aux + %(rho2)d;
  int k;
  (void)slack;
  for (k = 0; k < 6; ++k) {
    if (!(q3sq[k] >= sp_stroke_lo2 && q3sq[k] <= sp_stroke_hi2)) return SP_GEOMETRY;
    if (!(q3sq[k] > sp_min_length2)) return SP_GEOMETRY;
    if (!(rho2[k] > sp_min_sin2 * q3sq[k])) return SP_GEOMETRY;
  }
%(u_joint_check)s  return 0;
}
#ifdef SP_WIDTH
/* The lanes sp_check_legs passes (all ones), aux a structure of arrays. */
SP_VTARGET static sp_ivec sp_v_legs_ok(const sp_vec* aux, int slack) {
  sp_ivec ok = SP_ALL;
  int k;
  (void)slack;
  SP_UNROLL for (k = 0; k < 6; ++k) {
    sp_vec q = aux[%(q3sq)d + k], r = aux[%(rho2)d + k];
    ok &= (q >= sp_bcast(sp_stroke_lo2)) & (q <= sp_bcast(sp_stroke_hi2));
    ok &= (q > sp_bcast(sp_min_length2)) & (r > sp_bcast(sp_min_sin2) * q);
  }
  return ok;
}
#endif
"""

#: The U-joint limits of the paper's 6-UPS (``desc.u_joint_limits``), inserted in
#: :data:`CHECK_LEGS_UPS` when the robot has them: the angles ``q1i = atan2(u_y, u_x)``,
#: ``q2i = atan2(hypot(u_x, u_y), -u_z)`` of the leg direction ``u = R_i^T a_i`` in the
#: leg's base frame (``a_i`` the first three entries of row i of ``Jp^-1`` in ``aux``,
#: :func:`stewart_pin.kinematics.geometry.inverse_geometry_batch`'s arithmetic), each
#: within its limits narrowed by 1e-9 rad (the margin: a flagged state is decided by the
#: reference). Runs after the length and singularity checks (``a_i`` finite then).
CHECK_U_JOINTS_UPS = r"""  {
    /* R_i row-major (leg base frame -> F0), then [q1 lo, q1 hi, q2 lo, q2 hi] [rad] */
    static const double R[6][9] = {%(rotations)s};
    static const double lim[6][4] = {%(limits)s};
    const double* a;
    double u0, u1, u2, q1, q2;
    for (k = 0; k < 6; ++k) {
      a = aux + %(jinv)d + 6 * k;
      u0 = R[k][0] * a[0] + R[k][3] * a[1] + R[k][6] * a[2];
      u1 = R[k][1] * a[0] + R[k][4] * a[1] + R[k][7] * a[2];
      u2 = R[k][2] * a[0] + R[k][5] * a[1] + R[k][8] * a[2];
      q1 = atan2(u1, u0);
      q2 = atan2(sqrt(u0 * u0 + u1 * u1), -u2);
      if (!(q1 >= lim[k][0] && q1 <= lim[k][1])) return SP_GEOMETRY;
      if (!(q2 >= lim[k][2] && q2 <= lim[k][3])) return SP_GEOMETRY;
    }
  }
"""

#: The leg checks of the general-leg models: every slack of the generated code (reach,
#: serial singularity, levers, joint limits, Newton's residual) must be positive.
CHECK_LEGS_GENERAL = r"""
/* Every slack aux[slack .. slack + n) of the general-leg models is positive. */
static int sp_check_legs(const double* aux, int slack) {
  int k;
  for (k = 0; k < %(n_slack)d; ++k) if (!(aux[slack + k] > 0.0)) return SP_GEOMETRY;
  return 0;
}
#ifdef SP_WIDTH
/* The lanes sp_check_legs passes (all ones), aux a structure of arrays. */
SP_VTARGET static sp_ivec sp_v_legs_ok(const sp_vec* aux, int slack) {
  sp_ivec ok = SP_ALL;
  int k;
  SP_UNROLL for (k = 0; k < %(n_slack)d; ++k) ok &= aux[slack + k] > sp_bcast(0.0);
  return ok;
}
#endif
"""

#: The state guards (validity of the inputs, the leg checks, the condition bound, the
#: partial-pivoting solve): shared by the batch loops (:data:`TEMPLATE`) and the exported
#: library of :mod:`.c_export`.
GUARDS = r"""
/* ---- stewart-pin: state guards (hand-written, see _csource.py) ---- */
#include <math.h>

#define SP_INPUT 1
#define SP_GEOMETRY 2
#define SP_COND 4
#define SP_REPIVOTED 8
#define SP_NOT_PD 16
#define SP_NONFINITE 32

static const double sp_rotation_tol = %(rotation_tol)r;
static const double sp_growth_limit = %(growth_limit)r;
static const double sp_inv_length = %(inv_length)r;  /* 1 / characteristic length [1/m] */

/* Validity of a pose (row-major 4x4) and two 6-vectors. */
static int sp_check_inputs(const double* T, const double* x, const double* y) {
  int i, j, k;
  double err = 0.0, det;
  for (k = 0; k < 16; ++k) if (!isfinite(T[k])) return SP_INPUT;
  for (k = 0; k < 6; ++k) if (!isfinite(x[k]) || !isfinite(y[k])) return SP_INPUT;
  if (T[12] != 0.0 || T[13] != 0.0 || T[14] != 0.0 || T[15] != 1.0) return SP_INPUT;
  for (i = 0; i < 3; ++i) {
    for (j = i; j < 3; ++j) {
      double s = T[i] * T[j] + T[4 + i] * T[4 + j] + T[8 + i] * T[8 + j];
      double e = fabs(s - (i == j ? 1.0 : 0.0));
      if (e > err) err = e;
    }
  }
  if (!(err <= sp_rotation_tol)) return SP_INPUT;
  det = T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8])
      + T[2] * (T[4] * T[9] - T[5] * T[8]);
  if (!(det > 0.0)) return SP_INPUT;
  return 0;
}

%(check_legs)s
/* The condition bound 2 / |det S| (||S||_F^2 / 6)^3 (Guggenheimer et al. 1995). */
static int sp_cond_bound(double det, double fro2, double max_cond) {
  double t = fro2 * (1.0 / 6.0);  /* products only: the vector screen's roundings */
  return (2.0 * (t * t * t) <= 0.5 * max_cond * fabs(det)) ? 0 : SP_COND;
}

/* LU with partial pivoting of A = S^T (column i = row i of Jp^-1, J row-major; rows 3-5,
   the angular columns of Jp^-1, divided by the characteristic length), the condition
   bound, and (if rhs) the solution of Jp^-T y = rhs (rows 3-5 of rhs scaled alike). When
   the determinant bound passes half the threshold, the tighter ||S||_F ||S^-1||_F >=
   cond(S) from the LU decides (S^-1 column by column). */
static int sp_check_cond(const double* J, double max_cond, const double* rhs, double* y) {
  double A[6][6], b[6], z[6], x[6], fro2 = 0.0, det = 1.0, inv2 = 0.0, t, lim;
  int i, j, k, p, c, perm[6];
  for (i = 0; i < 6; ++i) {
    perm[i] = i;
    for (j = 0; j < 6; ++j) {
      A[i][j] = i < 3 ? J[6 * j + i] : J[6 * j + i] * sp_inv_length;
      fro2 += A[i][j] * A[i][j];
    }
  }
  for (i = 0; i < 6; ++i) b[i] = rhs ? (i < 3 ? rhs[i] : rhs[i] * sp_inv_length) : 0.0;
  for (k = 0; k < 6; ++k) {
    p = k;
    for (i = k + 1; i < 6; ++i) if (fabs(A[i][k]) > fabs(A[p][k])) p = i;
    if (p != k) {
      for (j = 0; j < 6; ++j) { t = A[k][j]; A[k][j] = A[p][j]; A[p][j] = t; }
      t = b[k]; b[k] = b[p]; b[p] = t;
      c = perm[k]; perm[k] = perm[p]; perm[p] = c;
    }
    det *= A[k][k];
    if (A[k][k] == 0.0) return SP_COND;
    for (i = k + 1; i < 6; ++i) {
      double l = A[i][k] / A[k][k];
      A[i][k] = l;  /* the multiplier, below the diagonal */
      for (j = k + 1; j < 6; ++j) A[i][j] -= l * A[k][j];
      b[i] -= l * b[k];
    }
  }
  if (rhs) {
    for (i = 5; i >= 0; --i) {
      double s = b[i];
      for (j = i + 1; j < 6; ++j) s -= A[i][j] * y[j];
      y[i] = s / A[i][i];
    }
  }
  if (sp_cond_bound(det, fro2, max_cond) == 0) return 0;
  for (c = 0; c < 6; ++c) {  /* column c of S^-T: solve P^T L U x = e_c */
    for (i = 0; i < 6; ++i) {
      double s = perm[i] == c ? 1.0 : 0.0;
      for (j = 0; j < i; ++j) s -= A[i][j] * z[j];
      z[i] = s;
    }
    for (i = 5; i >= 0; --i) {
      double s = z[i];
      for (j = i + 1; j < 6; ++j) s -= A[i][j] * x[j];
      x[i] = s / A[i][i];
      inv2 += x[i] * x[i];
    }
  }
  lim = max_cond * (1.0 - 1e-6);
  return (fro2 * inv2 <= lim * lim) ? 0 : SP_COND;
}

static int sp_finite6(const double* x) {
  int k;
  for (k = 0; k < 6; ++k) if (!isfinite(x[k])) return 0;
  return 1;
}
"""

#: The direct models' cheap condition check (after :data:`GUARDS`; the batch loops of
#: :data:`TEMPLATE` and of :mod:`.payload_compiled`).
STATIC_COND = r"""
/* The direct model's cheap condition check: 1 if the LU of S (as sp_check_cond builds
   it) without pivoting has every multiplier within the growth limit (its determinant
   accurate) and the bound passes with that determinant (cond(S) <= bound <= half the
   threshold: the reference accepts the state); else 0 (sp_check_cond decides). Cheaper
   than the pivoted LU, and the vector screen sp_v_static_cond_ok does the same
   operations in the same order, so the two paths flag alike. sp_static_cond_det also
   gives that determinant (of S: det Jp^-1 / l^3, the sign of det Jp^-1 when the check
   passes). */
#if defined(__GNUC__)
#define SP_UNROLL6 _Pragma("GCC unroll 6")  /* unrolled: the same operations, scheduled */
#else
#define SP_UNROLL6
#endif
static int sp_static_cond_det(const double* J, double max_cond, double* det_out) {
  double A[6][6], fro2 = 0.0, det = 1.0, r, l;
  int i, j, k, ok = 1;
  SP_UNROLL6 for (i = 0; i < 6; ++i) {
    SP_UNROLL6 for (j = 0; j < 6; ++j) {
      A[i][j] = i < 3 ? J[6 * j + i] : J[6 * j + i] * sp_inv_length;
      fro2 += A[i][j] * A[i][j];
    }
  }
  SP_UNROLL6 for (k = 0; k < 6; ++k) {
    det *= A[k][k];
    r = 1.0 / A[k][k];
    SP_UNROLL6 for (i = k + 1; i < 6; ++i) {
      l = A[i][k] * r;
      ok &= fabs(l) <= sp_growth_limit;
      SP_UNROLL6 for (j = k + 1; j < 6; ++j) A[i][j] -= l * A[k][j];
    }
  }
  *det_out = det;
  return ok && sp_cond_bound(det, fro2, max_cond) == 0;
}

static int sp_static_cond_ok(const double* J, double max_cond) {
  double det;
  return sp_static_cond_det(J, max_cond, &det);
}
"""

#: The AVX2+FMA copy of a generated model the simulator runs (``sp_ddm_aux``, ``sp_idm_sim``)
#: where the processor has both AVX2 and FMA (:func:`.compiled.avx2_copy`): compiled with
#: ``target("avx2,fma")`` and contraction allowed (GCC's default in GNU C,
#: ``-ffp-contract=fast``; Clang's through the pragma the copy opens with), so a product
#: and a sum may round once instead of twice: the results differ from the baseline copy's
#: (the batch and single-state calls') by a few units in the last place
#: (tests/test_compiled_simulation.py bounds the difference at 1e-13 relative, and the
#: simulator's trajectories stay within 1e-10 of the Python loop's).
AVX2_COPY = r"""
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#ifndef SP_AVX2
#define SP_AVX2 __attribute__((target("avx2,fma")))
static int sp_avx2_ready = 0;  /* the processor has AVX2 and FMA: set when loaded */
__attribute__((constructor)) static void sp_avx2_init(void) {
  __builtin_cpu_init();
  sp_avx2_ready = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? 1 : 0;
}
#endif
#define %(flag)s 1
%(code)s
#endif
"""

#: The actuated joint values of poses (after :data:`TEMPLATE`, for the models whose kind
#: has ``compiled_actuators``: the compiled simulator's output rows).
ACTUATORS = r"""
/* The actuated joint values (n x 6) of poses (n x 16, row-major 0Tp): the generated
   stewart_act, state by state (no guard: the poses are the simulator's accepted ones). */
SP_EXPORT void sp_act_batch(long long n, const double* pose, double* out) {
  const casadi_real* arg[%(sz_arg)d + 1];
  casadi_real* res[%(sz_res)d + 1];
  casadi_int iw[%(sz_iw)d + 1];
  casadi_real w[%(sz_w)d + 1];
  long long s;
  for (s = 0; s < n; ++s) {
    arg[0] = pose + 16 * s;
    res[0] = out + 6 * s;
    %(act)s(arg, res, iw, w, 0);
  }
}
"""

#: The inverse model's guards of one state after the generated code ran (C, the %-keys of
#: the model layout ``idm_slack``, ``growth``, ``jinv``, ``idm_f``, ``idm_hz``, ``det``,
#: ``fro2``): with ``f`` the flag so far, ``aux`` the state's by-products, ``g`` its Gamma
#: (6), ``y`` a scratch (6) and ``k`` an int, the leg and condition flags ORed into ``f``
#: and a repivoted state's Gamma solved again (the hexapod's, the payload's and the idle
#: models' guards).
IDM_GUARDS = r"""  f |= sp_check_legs(aux, %(idm_slack)d);
  if (!(aux[%(growth)d] <= sp_growth_limit)) {
    f |= sp_check_cond(aux + %(jinv)d, max_cond, aux + %(idm_f)d, y) | SP_REPIVOTED;
    for (k = 0; k < 6; ++k) g[k] = aux[%(idm_hz)d + k] + y[k];
  } else if (sp_cond_bound(aux[%(det)d], aux[%(fro2)d], max_cond)) {
    /* the static LU's determinant bound passed half the threshold: the tighter one */
    f |= sp_check_cond(aux + %(jinv)d, max_cond, 0, 0);
  }
"""


def layout_numbers(layout: Any) -> dict[str, int]:
    """The %-keys of :data:`IDM_GUARDS` and the direct model's guards from a model's
    by-product layout (an :class:`~.leg_chain_symbolic.AuxLayout`): the slacks, the
    offsets ``jinv``, ``idm_f``, ``idm_hz``, ``ddm_d``, ``growth``, ``det``, ``fro2``."""
    return {
        "idm_slack": layout.idm_slack,
        "ddm_slack": layout.ddm_slack,
        "jinv": layout.jinv,
        "idm_f": layout.idm_f,
        "idm_hz": layout.idm_hz,
        "ddm_d": layout.ddm_d,
        "growth": layout.growth,
        "det": layout.det,
        "fro2": layout.fro2,
    }


#: The compiled simulator's direct-model guard (``sp_ddm_after_sim``, with
#: ``sp_check_inputs_flat`` and ``sp_static_cond_sim``; %-keys ``jinv``, ``ddm_d``):
#: the robot library's (in :data:`TEMPLATE`, where the AVX2+FMA copy of the direct model
#: runs) and the legs-as-lanes library's screen (:mod:`.lanes`).
DDM_SIM_GUARD = r"""#ifdef SP_DDM_AVX2
/* ---- the compiled simulator's guard (sp_ddm_aux where the AVX2+FMA copy runs) ---- */
/* sp_check_inputs's decision without its early exits (the same tests: |x| <= DBL_MAX iff
   x is finite, then each orthogonality error within the tolerance, the pose's entries
   finite by then). */
static int sp_check_inputs_flat(const double* T, const double* x, const double* y) {
  const double big = 1.7976931348623157e308;
  int ok = 1, i, j, k;
  double det;
  for (k = 0; k < 16; ++k) ok &= fabs(T[k]) <= big;
  for (k = 0; k < 6; ++k) ok &= (fabs(x[k]) <= big) & (fabs(y[k]) <= big);
  ok &= (T[12] == 0.0) & (T[13] == 0.0) & (T[14] == 0.0) & (T[15] == 1.0);
  if (!ok) return SP_INPUT;
  for (i = 0; i < 3; ++i) {
    for (j = i; j < 3; ++j) {
      double s = T[i] * T[j] + T[4 + i] * T[4 + j] + T[8 + i] * T[8 + j];
      ok &= fabs(s - (i == j ? 1.0 : 0.0)) <= sp_rotation_tol;
    }
  }
  det = T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8])
      + T[2] * (T[4] * T[9] - T[5] * T[8]);
  ok &= det > 0.0;
  return ok ? 0 : SP_INPUT;
}

/* sp_static_cond_det with ||S||_F^2 summed by columns (six short chains, not one of 36
   additions), compiled for AVX2+FMA: the same test up to rounding. Where it passes,
   cond(S) <= half the threshold (to rounding): the reference accepts the state, as the
   Python loop's guard (or the reference checks it defers to) does; where it fails, the
   pivoted LU decides as there. The determinant's sign is det Jp^-1's as well. */
SP_AVX2 static int sp_static_cond_sim(const double* J, double max_cond, double* det_out) {
  double A[6][6], f[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, fro2, det = 1.0, r, l;
  int i, j, k, ok = 1;
  SP_UNROLL6 for (i = 0; i < 6; ++i) {
    SP_UNROLL6 for (j = 0; j < 6; ++j) {
      A[i][j] = i < 3 ? J[6 * j + i] : J[6 * j + i] * sp_inv_length;
      f[j] += A[i][j] * A[i][j];
    }
  }
  fro2 = ((f[0] + f[1]) + (f[2] + f[3])) + (f[4] + f[5]);
  SP_UNROLL6 for (k = 0; k < 6; ++k) {
    det *= A[k][k];
    r = 1.0 / A[k][k];
    SP_UNROLL6 for (i = k + 1; i < 6; ++i) {
      l = A[i][k] * r;
      ok &= fabs(l) <= sp_growth_limit;
      SP_UNROLL6 for (j = k + 1; j < 6; ++j) A[i][j] -= l * A[k][j];
    }
  }
  *det_out = det;
  return ok && sp_cond_bound(det, fro2, max_cond) == 0;
}

/* sp_ddm_after_det through the two functions above (the same flags but at the rounding
   margins of the cheap screen, where the reference accepts either way). */
SP_AVX2 static int sp_ddm_after_sim(const double* T, const double* tw, const double* gam,
                                    const double* a, const double* aux, double max_cond,
                                    double* det) {
  int k, f = sp_check_inputs_flat(T, tw, gam);
  f |= sp_check_legs(aux, SP_DDM_SLACK);
  if (!sp_static_cond_sim(aux + %(jinv)d, max_cond, det)) {
    *det = 0.0;
    f |= sp_check_cond(aux + %(jinv)d, max_cond, 0, 0);
  }
  for (k = 0; k < 6; ++k) if (!(aux[%(ddm_d)d + k] > 0.0)) f |= SP_NOT_PD;
  if (!sp_finite6(a)) f |= SP_NONFINITE;
  return f;
}
#endif
"""

TEMPLATE = (
    GUARDS
    + STATIC_COND
    + r"""
/* ---- stewart-pin: batch loops (hand-written, see _csource.py) ---- */
#ifndef SP_EXPORT
#define SP_EXPORT __attribute__((visibility("default")))
#endif

#define SP_IDM_NAUX %(idm_naux)d
#define SP_DDM_NAUX %(ddm_naux)d
#define SP_IDM_SLACK %(idm_slack)d
#define SP_DDM_SLACK %(ddm_slack)d

/* The guards of one inverse-dynamics state after the generated code ran (g: its Gamma,
   aux: its by-products): the state's flag; a repivoted state's Gamma solved again. */
static int sp_idm_after(const double* T, const double* tw, const double* acc, double* g,
                        const double* aux, double max_cond) {
  double y[6];
  int k, f = sp_check_inputs(T, tw, acc);
"""
    + IDM_GUARDS
    + r"""  if (!sp_finite6(g)) f |= SP_NONFINITE;
  return f;
}

/* The guards of one direct-dynamics state after the generated code ran; *det: the
   determinant of S from the cheap condition check when it decided (0.0 when the pivoted
   LU had to). */
static int sp_ddm_after_det(const double* T, const double* tw, const double* gam,
                            const double* a, const double* aux, double max_cond, double* det) {
  int k, f = sp_check_inputs(T, tw, gam);
  f |= sp_check_legs(aux, SP_DDM_SLACK);
  if (!sp_static_cond_det(aux + %(jinv)d, max_cond, det)) {  /* the cheap screen, the LU */
    *det = 0.0;
    f |= sp_check_cond(aux + %(jinv)d, max_cond, 0, 0);
  }
  for (k = 0; k < 6; ++k) if (!(aux[%(ddm_d)d + k] > 0.0)) f |= SP_NOT_PD;
  if (!sp_finite6(a)) f |= SP_NONFINITE;
  return f;
}

/* The guards of one direct-dynamics state after the generated code ran. */
static int sp_ddm_after(const double* T, const double* tw, const double* gam, const double* a,
                        const double* aux, double max_cond) {
  double det;
  return sp_ddm_after_det(T, tw, gam, a, aux, max_cond, &det);
}

"""
    + DDM_SIM_GUARD
    + r"""
#ifdef SP_WIDTH
/* ---- the vector screens: the lanes (all ones) whose scalar guard would return 0 ---- */
#define SP_BIG 1.7976931348623157e308  /* DBL_MAX: |x| <= SP_BIG iff x is finite */

/* The lanes sp_check_inputs passes: t the poses (16 vectors), x, y two 6-vectors. */
SP_VTARGET static sp_ivec sp_v_inputs_ok(const sp_vec* t, const sp_vec* x, const sp_vec* y) {
  sp_vec s, e, det;
  sp_ivec ok = SP_ALL;
  int i, j, k;
  SP_UNROLL for (k = 0; k < 16; ++k) ok &= sp_v_fabs(t[k]) <= sp_bcast(SP_BIG);
  SP_UNROLL for (k = 0; k < 6; ++k) {
    ok &= sp_v_fabs(x[k]) <= sp_bcast(SP_BIG);
    ok &= sp_v_fabs(y[k]) <= sp_bcast(SP_BIG);
  }
  ok &= (t[12] == sp_bcast(0.0)) & (t[13] == sp_bcast(0.0)) & (t[14] == sp_bcast(0.0));
  ok &= t[15] == sp_bcast(1.0);
  SP_UNROLL for (i = 0; i < 3; ++i) {
    SP_UNROLL for (j = i; j < 3; ++j) {
      s = t[i] * t[j] + t[4 + i] * t[4 + j] + t[8 + i] * t[8 + j];
      e = sp_v_fabs(s - sp_bcast(i == j ? 1.0 : 0.0));
      ok &= e <= sp_bcast(sp_rotation_tol);
    }
  }
  det = t[0] * (t[5] * t[10] - t[6] * t[9]) - t[1] * (t[4] * t[10] - t[6] * t[8])
      + t[2] * (t[4] * t[9] - t[5] * t[8]);
  return ok & (det > sp_bcast(0.0));
}

/* The lanes sp_cond_bound passes. */
SP_VTARGET static sp_ivec sp_v_bound_ok(sp_vec det, sp_vec fro2, double max_cond) {
  sp_vec t = fro2 * sp_bcast(1.0 / 6.0);
  return sp_bcast(2.0) * (t * t * t) <= sp_bcast(0.5 * max_cond) * sp_v_fabs(det);
}

/* sp_static_cond_ok lane by lane (J: 36 vectors). */
SP_VTARGET static sp_ivec sp_v_static_cond_ok(const sp_vec* J, double max_cond) {
  sp_vec A[6][6], fro2 = sp_bcast(0.0), det = sp_bcast(1.0), r, l;
  sp_ivec ok = SP_ALL;
  int i, j, k;
  SP_UNROLL for (i = 0; i < 6; ++i) {
    SP_UNROLL for (j = 0; j < 6; ++j) {
      A[i][j] = i < 3 ? J[6 * j + i] : J[6 * j + i] * sp_bcast(sp_inv_length);
      fro2 += A[i][j] * A[i][j];
    }
  }
  SP_UNROLL for (k = 0; k < 6; ++k) {
    det *= A[k][k];
    r = sp_bcast(1.0) / A[k][k];
    SP_UNROLL for (i = k + 1; i < 6; ++i) {
      l = A[i][k] * r;
      ok &= sp_v_fabs(l) <= sp_bcast(sp_growth_limit);
      SP_UNROLL for (j = k + 1; j < 6; ++j) A[i][j] -= l * A[k][j];
    }
  }
  return ok & sp_v_bound_ok(det, fro2, max_cond);
}

/* The lanes whose 6 results (6 per state from x) are finite. */
SP_VTARGET static sp_ivec sp_v_finite6(const double* x) {
  sp_ivec ok = SP_ALL;
  int k;
  SP_UNROLL for (k = 0; k < 6; ++k) ok &= sp_v_fabs(SP_STRIDED(x, 6, k)) <= sp_bcast(SP_BIG);
  return ok;
}

/* The lanes sp_idm_after returns 0 for (as it computes them). */
SP_VTARGET static sp_ivec sp_v_idm_ok(const sp_vec* in, const double* g, const sp_vec* aux,
                                      double max_cond) {
  sp_ivec ok = sp_v_inputs_ok(in, in + 16, in + 22) & sp_v_legs_ok(aux, SP_IDM_SLACK);
  ok &= aux[%(growth)d] <= sp_bcast(sp_growth_limit);
  ok &= sp_v_bound_ok(aux[%(det)d], aux[%(fro2)d], max_cond);
  return ok & sp_v_finite6(g);
}

/* The lanes sp_ddm_after returns 0 for. */
SP_VTARGET static sp_ivec sp_v_ddm_ok(const sp_vec* in, const double* a, const sp_vec* aux,
                                      double max_cond) {
  sp_ivec ok = sp_v_inputs_ok(in, in + 16, in + 22) & sp_v_legs_ok(aux, SP_DDM_SLACK);
  int k;
  ok &= sp_v_static_cond_ok(aux + %(jinv)d, max_cond);
  SP_UNROLL for (k = 0; k < 6; ++k) ok &= aux[%(ddm_d)d + k] > sp_bcast(0.0);
  return ok & sp_v_finite6(a);
}

/* SP_WIDTH states at a time (from state 0, as long as SP_WIDTH remain): their inputs
   gathered into a structure of arrays (in: pose 16, twist 6, X 6 vectors), VFN, the
   vector copy of the generated code (codegen/_simd.py; its by-products in aux, a
   structure of arrays), the screen VOK, and AFTER's scalar guards for the lanes the
   screen does not pass (their by-products copied out). Returns the first state left;
   ORs the flags into *any. */
#define SP_VEC_LOOP(NAME, VFN, VOK, AFTER, NAUX)                                         \
  SP_VTARGET static long long NAME(long long n, const double* pose, const double* twist, \
                                   const double* X, const double* chi, double max_cond,  \
                                   double* out, int* flags, int* any) {                  \
    sp_vec in[28], aux[NAUX];                                                            \
    const sp_vec* argv[4] = {in, in + 16, in + 22, 0};                                   \
    const double* shared[4] = {0, 0, 0, chi};                                            \
    double* rv[SP_WIDTH][2];                                                             \
    double* const* resv[SP_WIDTH];                                                       \
    double auxl[NAUX];                                                                   \
    sp_ivec ok;                                                                          \
    long long s;                                                                         \
    int l, k, f, acc = 0;                                                                \
    for (l = 0; l < SP_WIDTH; ++l) { resv[l] = rv[l]; rv[l][1] = 0; }                    \
    for (s = 0; s + SP_WIDTH <= n; s += SP_WIDTH) {                                      \
      for (k = 0; k < 16; ++k) in[k] = SP_STRIDED(pose + 16 * s, 16, k);                 \
      for (k = 0; k < 6; ++k) in[16 + k] = SP_STRIDED(twist + 6 * s, 6, k);              \
      for (k = 0; k < 6; ++k) in[22 + k] = SP_STRIDED(X + 6 * s, 6, k);                  \
      for (l = 0; l < SP_WIDTH; ++l) rv[l][0] = out + 6 * (s + l);                       \
      VFN(argv, shared, resv, aux);                                                      \
      ok = VOK(in, out + 6 * s, aux, max_cond);                                          \
      for (l = 0; l < SP_WIDTH; ++l) {                                                   \
        f = 0;                                                                           \
        if (!ok[l]) {                                                                    \
          for (k = 0; k < NAUX; ++k) auxl[k] = aux[k][l];                                \
          f = AFTER(pose + 16 * (s + l), twist + 6 * (s + l), X + 6 * (s + l), rv[l][0], \
                    auxl, max_cond);                                                     \
        }                                                                                \
        flags[s + l] = f;                                                                \
        acc |= f;                                                                        \
      }                                                                                  \
    }                                                                                    \
    *any |= acc;                                                                         \
    return s;                                                                            \
  }
#endif
#ifdef SP_VEC_IDM
SP_VEC_LOOP(sp_idm_vloop, sp_idm_vec, sp_v_idm_ok, sp_idm_after, SP_IDM_NAUX)
#endif
#ifdef SP_VEC_DDM
SP_VEC_LOOP(sp_ddm_vloop, sp_ddm_vec, sp_v_ddm_ok, sp_ddm_after, SP_DDM_NAUX)
#endif

/* Inverse dynamics of n states: pose (n x 16), twist, accel (n x 6), chi (88) -> gamma
   (n x 6), flags (n). Returns the OR of the flags. With SP_VEC_IDM, SP_WIDTH states at a
   time through the vector copy of the generated code (codegen/_simd.py), the rest one
   by one. */
SP_EXPORT int sp_idm_batch(long long n, const double* pose, const double* twist,
                           const double* accel, const double* chi, double max_cond,
                           double* gamma, int* flags) {
  const casadi_real* arg[%(idm_sz_arg)d + 1];
  casadi_real* res[%(idm_sz_res)d + 1];
  casadi_int iw[%(idm_sz_iw)d + 1];
  casadi_real w[%(idm_sz_w)d + 1];
  double aux[SP_IDM_NAUX];
  int any = 0, f;
  long long s = 0;
#ifdef SP_VEC_IDM
  if (n >= SP_WIDTH && SP_VEC_READY())
    s = sp_idm_vloop(n, pose, twist, accel, chi, max_cond, gamma, flags, &any);
#endif
  for (; s < n; ++s) {
    arg[0] = pose + 16 * s; arg[1] = twist + 6 * s; arg[2] = accel + 6 * s; arg[3] = chi;
    res[0] = gamma + 6 * s; res[1] = aux;
    %(idm)s(arg, res, iw, w, 0);
    f = sp_idm_after(arg[0], arg[1], arg[2], res[0], aux, max_cond);
    flags[s] = f;
    any |= f;
  }
  return any;
}

/* Direct dynamics of n states: pose, twist, gamma, chi -> accel (n x 6), flags. */
SP_EXPORT int sp_ddm_batch(long long n, const double* pose, const double* twist,
                           const double* gam, const double* chi, double max_cond,
                           double* accel, int* flags) {
  const casadi_real* arg[%(ddm_sz_arg)d + 1];
  casadi_real* res[%(ddm_sz_res)d + 1];
  casadi_int iw[%(ddm_sz_iw)d + 1];
  casadi_real w[%(ddm_sz_w)d + 1];
  double aux[SP_DDM_NAUX];
  int any = 0, f;
  long long s = 0;
#ifdef SP_VEC_DDM
  if (n >= SP_WIDTH && SP_VEC_READY())
    s = sp_ddm_vloop(n, pose, twist, gam, chi, max_cond, accel, flags, &any);
#endif
  for (; s < n; ++s) {
    arg[0] = pose + 16 * s; arg[1] = twist + 6 * s; arg[2] = gam + 6 * s; arg[3] = chi;
    res[0] = accel + 6 * s; res[1] = aux;
    %(ddm)s(arg, res, iw, w, 0);
    f = sp_ddm_after(arg[0], arg[1], arg[2], res[0], aux, max_cond);
    flags[s] = f;
    any |= f;
  }
  return any;
}

/* Inverse dynamics of n states as sp_idm_batch's scalar loop, through the AVX2+FMA copy
   of the generated code where the processor has both (within a few units in the last
   place of the baseline's): the compiled simulator's controller (codegen/_simsource.py). */
SP_EXPORT int sp_idm_sim(long long n, const double* pose, const double* twist,
                         const double* accel, const double* chi, double max_cond,
                         double* gamma, int* flags) {
  const casadi_real* arg[%(idm_sz_arg)d + 1];
  casadi_real* res[%(idm_sz_res)d + 1];
  casadi_int iw[%(idm_sz_iw)d + 1];
  casadi_real w[%(idm_sz_w)d + 1];
  double aux[SP_IDM_NAUX];
  int any = 0, f;
  long long s;
  for (s = 0; s < n; ++s) {
    arg[0] = pose + 16 * s; arg[1] = twist + 6 * s; arg[2] = accel + 6 * s; arg[3] = chi;
    res[0] = gamma + 6 * s; res[1] = aux;
#ifdef SP_IDM_AVX2
    if (sp_avx2_ready)
      sp_idm_avx2(arg, res, iw, w, 0);
    else
#endif
      %(idm)s(arg, res, iw, w, 0);
    f = sp_idm_after(arg[0], arg[1], arg[2], res[0], aux, max_cond);
    flags[s] = f;
    any |= f;
  }
  return any;
}

/* One state packed in one input buffer (the single-state call from Python, which passes
   the bytes of the pose (16, row-major), the twist (6) and the accel or gamma (6) in one
   read-only block): the result (6) goes to out. Returns the state's flag. */
SP_EXPORT int sp_idm_one(const double* in, const double* chi, double max_cond, double* out) {
  int f;
  sp_idm_batch(1, in, in + 16, in + 22, chi, max_cond, out, &f);
  return f;
}

SP_EXPORT int sp_ddm_one(const double* in, const double* chi, double max_cond, double* out) {
  int f;
  sp_ddm_batch(1, in, in + 16, in + 22, chi, max_cond, out, &f);
  return f;
}

/* One direct-dynamics state with its by-products (aux, SP_DDM_NAUX values: Jp^-1 among
   them): the compiled simulator's entry (codegen/_simsource.py), which takes the sign of
   det Jp^-1 from *det (the determinant of S the cheap condition check computed; 0.0 when
   the pivoted LU decided). The scalar path of sp_ddm_batch, or where the processor has
   AVX2 and FMA the AVX2+FMA copy of the model and sp_ddm_after_sim (results within a few
   units in the last place). Returns the state's flag. */
SP_EXPORT int sp_ddm_aux(const double* pose, const double* twist, const double* gam,
                         const double* chi, double max_cond, double* accel, double* aux,
                         double* det) {
  const casadi_real* arg[%(ddm_sz_arg)d + 1];
  casadi_real* res[%(ddm_sz_res)d + 1];
  casadi_int iw[%(ddm_sz_iw)d + 1];
  casadi_real w[%(ddm_sz_w)d + 1];
  arg[0] = pose; arg[1] = twist; arg[2] = gam; arg[3] = chi;
  res[0] = accel; res[1] = aux;
#ifdef SP_DDM_AVX2
  if (sp_avx2_ready) {
    sp_ddm_avx2(arg, res, iw, w, 0);
    return sp_ddm_after_sim(pose, twist, gam, accel, aux, max_cond, det);
  }
#endif
  %(ddm)s(arg, res, iw, w, 0);
  return sp_ddm_after_det(pose, twist, gam, accel, aux, max_cond, det);
}

/* sp_ddm_aux's guard alone, for a direct model computed elsewhere (the legs-as-lanes
   library of codegen/lanes.py, which calls it through a pointer): the same flags and
   *det from the model's outputs (accel, aux). */
SP_EXPORT int sp_ddm_guard_sim(const double* pose, const double* twist, const double* gam,
                               double max_cond, const double* accel, const double* aux,
                               double* det) {
#ifdef SP_DDM_AVX2
  if (sp_avx2_ready) return sp_ddm_after_sim(pose, twist, gam, accel, aux, max_cond, det);
#endif
  return sp_ddm_after_det(pose, twist, gam, accel, aux, max_cond, det);
}

/* sp_idm_sim's guard alone, for an inverse model computed elsewhere (the lanes): the
   state's flag from its outputs (gamma, aux; a repivoted state's gamma solved again). */
SP_EXPORT int sp_idm_guard_sim(const double* pose, const double* twist, const double* accel,
                               double* gamma, const double* aux, double max_cond) {
  return sp_idm_after(pose, twist, accel, gamma, aux, max_cond);
}
"""
)
