"""The C of the compiled simulator (:mod:`.simulator`): the integrators of
:func:`stewart_pin.motion.simulation.simulate` on SE(3) around a robot's compiled direct
model, forces given as data.

The library is robot-independent: it calls the robot's generated models through function
pointers (``sp_ddm_aux``, the direct model with its by-products, and ``sp_idm_sim``, the
controller's inverse model, of the robots' own libraries, :mod:`._csource`; or a
payload's ``sp_ppdm_sim``, :mod:`.payload_compiled`, whose last input is the payload's
joints sampled at the stage's time instead of the base values). One call
runs steps of ``simulate`` and writes one row per accepted state (with ``output_dt``:
the steps cut at the output times, rows at those times only, as the Python loop's
``_Run.record`` keeps them), with the Python integrator's arithmetic: the chart
``R = exp3(xi) R_n`` around each step's start;
``method="rk4"``: the grid steps ``n .. n_stop``, the stages ``y0 + h/2 k1``,
``y0 + h/2 k2``, ``y0 + h k3``, ``y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4)``;
``method="adaptive"``: Dormand-Prince 5(4) with its error control, first-same-as-last
stage and step updates; ``dxi/dt = Jlog3(exp3(xi))^T w`` as Pinocchio computes it (its
``exp3``, ``log3`` and ``Jlog3`` written out here in the same operations), the forces
sampled at the same times and held over a control period as
:class:`~stewart_pin.motion.simulation._Integrator` holds them.

Anything the Python loop would look at more closely stops the call *before* the step
(status :data:`BAIL`), the state left at the last accepted one: a state the direct or
inverse model's guard flags (a leg near its stroke end or a singularity, a U-joint near its
limit, a non-positive pivot, a non-finite result: the reference checks decide), a sign of
``det Jp^-1`` other than the step's start, a step that
does not land on the grid, a controller reference sampled before the run at another time
(a reference evaluated here, ``sp_ref_eval``, is evaluated at the time asked), a rotation
error near pi. The Python loop then takes that one step (halving, locating the event, raising),
and the compiled loop goes on from the next grid time. Status :data:`NEED_FORCE`: the
step's end state starts a new control period whose forces come from a Python function; the
pending state is kept in the state block and the next call evaluates it with the held
forces the caller wrote there. A state block marked :data:`PENDING_START` asks for the
initial state instead: evaluated as the Python loop's first state (forces, direct model,
the sign of det Jp^-1 where the cheap condition check decides it, else a bail) and
written as row 0.

The sign of ``det Jp^-1`` of each stage and state comes from the determinant the direct
model's guard computed anyway (``sp_ddm_aux``'s ``det``: the LU without pivoting of its
cheap condition check, ``S = Jp^-T diag(1, 1, 1, 1/l, 1/l, 1/l)``, so the same sign; on
the legs-as-lanes at the computed-torque controller's state, the controller's inverse
model's static-pivot LU's, :mod:`.lanes`):
where that check decides, cond(S) is at most half of ``max_condition``, so for a threshold
up to :data:`STATIC_SIGN_COND` the determinant's relative error is far below 1 and its
sign is the one ``np.linalg.det`` gives the reference's ``Jp^-1`` (the Python loop's);
elsewhere an LU with partial pivoting of the model's ``Jp^-1`` (as before). The 6-UPS leg
lengths of the rows come from the model's ``q3^2``; general legs' actuated joint values
from the robot library's ``sp_act_batch`` (:data:`._csource.ACTUATORS`: the generated
closed forms of the reference's values, equal to round-off).

Built at ``-O3`` without ``-freciprocal-math`` (unlike the models): the divisions are the
ones written, as in NumPy and Pinocchio.
"""

from __future__ import annotations

#: Status of ``sp_sim_run``: the grid steps up to ``n_stop`` (or the end) done.
DONE = 0
#: The next step needs the Python loop (the state is the last accepted one).
BAIL = 1
#: The step's end state needs forces from Python (pending in the state block).
NEED_FORCE = 2

#: ``st[ST_PENDING]`` asking ``sp_sim_run`` to evaluate the initial state (``begin``).
PENDING_START = 2.0

#: Up to this ``max_condition`` the sign of det Jp^-1 comes from the determinant of the direct
#: model's cheap condition check (``SP_STATIC_SIGN_COND`` of the C).
STATIC_SIGN_COND = 1e8

#: Force kinds of ``sp_sim.kind``.
KIND_CONSTANT, KIND_HOLD, KIND_LINEAR, KIND_CT, KIND_EXTERNAL = 0, 1, 2, 3, 4

#: Reference kinds of ``sp_sim.ref_kind`` (the computed-torque controller's): sampled before
#: the run (a table of rows at the times the loop asks), or evaluated in C at every time it
#: asks, a :class:`~stewart_pin.motion.trajectories.FourierTrajectory`,
#: :class:`~stewart_pin.motion.trajectories.Sinusoids` or
#: :class:`~stewart_pin.motion.trajectories.MinimumJerkKnots`.
REF_TABLE, REF_FOURIER, REF_SINUSOIDS, REF_MINIMUM_JERK = 0, 1, 2, 3

#: Offsets in the state block (doubles) shared with Python.
ST_T, ST_POSE, ST_TWIST, ST_DY, ST_GAMMA, ST_SIGN = 0, 1, 17, 23, 35, 41
ST_HELD_K, ST_HELD_G, ST_PENDING, ST_PEND_T, ST_PEND_POSE, ST_PEND_TWIST = 42, 43, 49, 50, 51, 67
ST_N, ST_STEPS, ST_ROW, ST_LEN, ST_H, ST_H_PEND, ST_OUT_K, ST_SIZE = 73, 74, 75, 76, 82, 83, 84, 85

SOURCE = r"""
/* Generated by stewart-pin (see codegen/_simsource.py). */
#include <math.h>
#include <string.h>

#define SP_EXPORT __attribute__((visibility("default")))

typedef int (*sp_ddm_fn)(const double*, const double*, const double*, const double*, double,
                         double*, double*, double*);
typedef void (*sp_act_fn)(long long, const double*, double*);
typedef int (*sp_idm_fn)(long long, const double*, const double*, const double*,
                         const double*, double, double*, int*);

/* Every field 8 bytes (the ctypes Structure of simulator.py mirrors it). */
typedef struct {
  sp_ddm_fn ddm; const double* chi; double max_cond; long long naux; long long jinv;
  double dt; double duration; double period; long long n_grid;
  long long kind; const double* g_const;
  long long n_tab; const double* tab_t; const double* tab_g;
  sp_idm_fn idm; const double* idm_chi; double idm_max_cond;
  long long ref_per_period; long long n_ref; const double* ref_t; const double* ref_T;
  const double* ref_V; const double* ref_A; const double* kp; const double* kd;
  long long rows; double* t_out; double* P_out; double* V_out; double* A_out; double* G_out;
  long long q3sq; double* L_out;
  long long adaptive; double rtol; double atol; double h_min;
  sp_act_fn act;
  long long ref_kind; const double* ref_pose; long long ref_n; const double* ref_data;
  long long ref_id;
  double output_dt;
  long long n_pay; const double* pay_t; const double* pay_x; long long pay_nx;
} sp_sim;

#define ST_T 0
#define ST_POSE 1
#define ST_TWIST 17
#define ST_DY 23
#define ST_GAMMA 35
#define ST_SIGN 41
#define ST_HELD_K 42
#define ST_HELD_G 43
#define ST_PENDING 49
#define ST_PEND_T 50
#define ST_PEND_POSE 51
#define ST_PEND_TWIST 67
#define ST_N 73
#define ST_STEPS 74
#define ST_ROW 75
#define ST_LEN 76
#define ST_H 82
#define ST_H_PEND 83
#define ST_OUT_K 84

#define SP_DONE 0
#define SP_BAIL 1
#define SP_NEED_FORCE 2
#define SP_START 2.0  /* st[ST_PENDING]: the initial state to evaluate */
#define SP_MAX_AUX 16384
#define SP_RATIO_SLACK 1e-9
/* Up to this max_cond the determinant of the direct model's cheap condition check gives
   the sign of det Jp^-1 (cond(S) <= max_cond / 2 there: its relative error is far below
   1); above it, sp_det_sign's LU. */
#define SP_STATIC_SIGN_COND 1e8

static const double sp_eps = 2.220446049250313e-16;
/* Pinocchio's TaylorSeriesExpansion precisions eps^(1/3) and eps^(1/4), computed once
   (the same value whichever thread writes it first). */
static double sp_prec2_v = 0.0, sp_prec3_v = 0.0;
static double sp_prec2(void) {
  if (sp_prec2_v == 0.0) sp_prec2_v = pow(sp_eps, 1.0 / 3.0);
  return sp_prec2_v;
}
static double sp_prec3(void) {
  if (sp_prec3_v == 0.0) sp_prec3_v = pow(sp_eps, 1.0 / 4.0);
  return sp_prec3_v;
}

/* Pinocchio's exp3 (spatial/explog.hxx), same operations. */
static void sp_exp3(const double* v, double* R) {
  double prec = sp_prec3();
  double t2 = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + sp_eps * sp_eps;
  double t = sqrt(t2), st = sin(t), ct = cos(t), a2, a1;
  int i, j;
  a2 = t > prec ? (1 - ct) / t2 : 1.0 / 2.0 - t2 / 24;
  a1 = t > prec ? st / t : 1.0 - t2 / 6;
  for (i = 0; i < 3; ++i) for (j = 0; j < 3; ++j) R[3 * i + j] = a2 * v[i] * v[j];
  R[1] -= a1 * v[2]; R[3] += a1 * v[2];
  R[2] += a1 * v[1]; R[6] -= a1 * v[1];
  R[5] -= a1 * v[0]; R[7] += a1 * v[0];
  ct = t > prec ? ct : 1.0 - t2 / 2;
  R[0] += ct; R[4] += ct; R[8] += ct;
}

/* Pinocchio's log3 (spatial/log.hxx) of R (row-major 3x3) away from pi: theta, its sine
   and cosine (sc, for Jlog3: one sincos call) and the rotation vector; returns 0 near pi
   (the caller bails). */
static int sp_log3(const double* Rin, double* theta, double* sc, double* w) {
  double R[9], n0, n1, tr, c, prec = sp_prec2(), ae, th, n2, t, st, ct;
  int i;
  n0 = sqrt(Rin[0] * Rin[0] + Rin[3] * Rin[3] + Rin[6] * Rin[6]);
  n1 = sqrt(Rin[1] * Rin[1] + Rin[4] * Rin[4] + Rin[7] * Rin[7]);
  for (i = 0; i < 3; ++i) { R[3 * i] = Rin[3 * i] / n0; R[3 * i + 1] = Rin[3 * i + 1] / n1; }
  /* col2 = col0 x col1, then col0 = col1 x col2 */
  R[2] = R[3] * R[7] - R[6] * R[4];
  R[5] = R[6] * R[1] - R[0] * R[7];
  R[8] = R[0] * R[4] - R[3] * R[1];
  {
    double c0 = R[4] * R[8] - R[7] * R[5], c1 = R[7] * R[2] - R[1] * R[8],
           c2 = R[1] * R[5] - R[4] * R[2];
    R[0] = c0; R[3] = c1; R[6] = c2;
  }
  tr = R[0] + R[4] + R[8];
  c = (tr - 1.0) / 2.0;
  if (!(c >= -1.0 + prec)) return 0;
  ae = sqrt(2.0 * (1.0 - c) + sp_eps * sp_eps);
  th = tr <= 3.0 - prec ? acos(c) : ae;  /* tr >= -1 + prec holds here */
  w[0] = 0.5 * (R[7] - R[5]);
  w[1] = 0.5 * (R[2] - R[6]);
  w[2] = 0.5 * (R[3] - R[1]);
  n2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  st = sin(th);
  ct = cos(th);
  t = th >= prec ? th / st : 1.0 + n2 / 6.0 + n2 * n2 * 3.0 / 40.0;
  for (i = 0; i < 3; ++i) w[i] = t * w[i];
  *theta = th;
  sc[0] = st;
  sc[1] = ct;
  return 1;
}

/* dxi/dt = Jlog3(exp3(xi))^T w (E = exp3(xi)), as simulation.py computes it through
   Pinocchio (so3_left_jacobian_inverse). Returns 0 near pi. */
static int sp_dxi(const double* E, const double* w, double* out) {
  double th, l[3], sc[2], st, ct, s1, prec = sp_prec3(), alpha, d, J[9];
  int i, j;
  if (!sp_log3(E, &th, sc, l)) return 0;
  st = sc[0]; ct = sc[1];
  s1 = st / (1.0 - ct);
  alpha = th < prec ? 1.0 / 12.0 + th * th / 720.0 : 1.0 / (th * th) - s1 / (2.0 * th);
  d = th < prec ? 0.5 * (2.0 - th * th / 6.0) : 0.5 * (th * s1);
  for (i = 0; i < 3; ++i) for (j = 0; j < 3; ++j) J[3 * i + j] = alpha * l[i] * l[j];
  J[0] += d; J[4] += d; J[8] += d;
  J[1] -= 0.5 * l[2]; J[3] += 0.5 * l[2];
  J[2] += 0.5 * l[1]; J[6] -= 0.5 * l[1];
  J[5] -= 0.5 * l[0]; J[7] += 0.5 * l[0];
  for (i = 0; i < 3; ++i)  /* J^T w */
    out[i] = J[i] * w[0] + J[3 + i] * w[1] + J[6 + i] * w[2];
  return 1;
}

/* The pose of chart point y around the rotation R0 (row-major 4x4 in T0):
   R = exp3(y[3:6]) R0 (E: that exp3), p = y[0:3]. */
static void sp_chart_pose(const double* T0, const double* y, const double* E, double* T) {
  int i, j;
  for (i = 0; i < 3; ++i) {
    for (j = 0; j < 3; ++j)
      T[4 * i + j] = E[3 * i] * T0[j] + E[3 * i + 1] * T0[4 + j] + E[3 * i + 2] * T0[8 + j];
    T[4 * i + 3] = y[i];
  }
  T[12] = 0.0; T[13] = 0.0; T[14] = 0.0; T[15] = 1.0;
}

/* Sign of the determinant of a 6x6 row-major matrix (LU with partial pivoting). */
static double sp_det_sign(const double* J) {
  double A[36], s = 1.0, t;
  int i, j, k, p;
  memcpy(A, J, sizeof A);
  for (k = 0; k < 6; ++k) {
    p = k;
    for (i = k + 1; i < 6; ++i) if (fabs(A[6 * i + k]) > fabs(A[6 * p + k])) p = i;
    if (A[6 * p + k] == 0.0 || !isfinite(A[6 * p + k])) return 0.0;
    if (p != k) {
      for (j = 0; j < 6; ++j) { t = A[6 * k + j]; A[6 * k + j] = A[6 * p + j]; A[6 * p + j] = t; }
      s = -s;
    }
    if (A[6 * k + k] < 0) s = -s;
    t = 1.0 / A[6 * k + k];  /* one division per column: only the sign is kept */
    for (i = k + 1; i < 6; ++i) {
      double l = A[6 * i + k] * t;
      for (j = k + 1; j < 6; ++j) A[6 * i + j] -= l * A[6 * k + j];
    }
  }
  return s;
}

static long long sp_period_index(const sp_sim* sim, double t) {
  return sim->period > 0 ? (long long)floor(t / sim->period + SP_RATIO_SLACK) : 0;
}

static double sp_grid(const sp_sim* sim, long long n) {
  return n >= sim->n_grid ? sim->duration : (double)n * sim->dt;
}

/* The controller's reference evaluated here (sim->ref_kind != SP_REF_TABLE), as
   motion/trajectories.py evaluates it: the six coordinates x = [d, r] (a Fourier series,
   sinusoids or minimum-jerk knots; ref_data laid out by simulator.py's _reference_data),
   then p = p_ref + d, R = exp3(r) R_ref, v = d', w = J_l(r) r', the exact classical
   accelerations (_so3.py's so3_coefficients, so3_exp, so3_left_jacobian(_rate)). */
#define SP_REF_TABLE 0
#define SP_REF_FOURIER 1
#define SP_REF_SINUSOIDS 2
#define SP_REF_MINIMUM_JERK 3
#define SP_SERIES_ANGLE 0.1
#define SP_PI 3.141592653589793

static double sp_horner(double t2, const double* c) {  /* _so3.py's _series, 4 terms */
  double out = 0.0;
  int i;
  for (i = 3; i >= 0; --i) out = out * t2 + c[i];
  return out;
}

/* sin t / t, a, b, a'/t, b'/t at t = |r| (_so3.py's so3_coefficients). */
static void sp_so3_coefs(const double* r, double* co) {
  static const double ca[4] = {1.0 / 2, -1.0 / 24, 1.0 / 720, -1.0 / 40320};
  static const double cb[4] = {1.0 / 6, -1.0 / 120, 1.0 / 5040, -1.0 / 362880};
  static const double cda[4] = {-1.0 / 12, 1.0 / 180, -1.0 / 6720, 1.0 / 453600};
  static const double cdb[4] = {-1.0 / 60, 1.0 / 1260, -1.0 / 60480, 1.0 / 4989600};
  double t = sqrt((r[0] * r[0] + r[1] * r[1]) + r[2] * r[2]), t2 = t * t, x, y;
  x = t / SP_PI;  /* np.sinc(t / pi) */
  y = SP_PI * (x == 0.0 ? 1.0e-20 : x);
  co[0] = sin(y) / y;
  if (t < SP_SERIES_ANGLE) {
    co[1] = sp_horner(t2, ca);
    co[2] = sp_horner(t2, cb);
    co[3] = sp_horner(t2, cda);
    co[4] = sp_horner(t2, cdb);
  } else {
    double s = sin(t), c = cos(t);
    co[1] = (1 - c) / (t * t);
    co[2] = (t - s) / pow(t, 3.0);
    co[3] = (t * s - 2 * (1 - c)) / pow(t, 4.0);
    co[4] = ((1 - c) * t - 3 * (t - s)) / pow(t, 5.0);
  }
}

static void sp_cross(const double* a, const double* b, double* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/* The minimum-jerk profile 10 s^3 - 15 s^4 + 6 s^5 and its derivatives (_quintic). */
static void sp_quintic(double s, double* f) {
  s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
  f[0] = pow(s, 3.0) * ((10 - 15 * s) + 6 * (s * s));
  f[1] = (30 * (s * s)) * ((1 - s) * (1 - s));
  f[2] = ((60 * s) * (1 - s)) * (1 - 2 * s);
}

/* The coordinates x, x', x'' (6 each) of the reference at t. */
static void sp_ref_coordinates(const sp_sim* sim, double t, double* x, double* xd, double* xdd) {
  const double* d = sim->ref_data;
  long long n = sim->ref_n, l;
  int k;
  if (sim->ref_kind == SP_REF_FOURIER) {  /* d: w (n), offsets (6), sine (6, n), cosine */
    const double *w = d, *a = d + n + 6, *b = d + n + 6 + 6 * n;
    for (k = 0; k < 6; ++k) {
      double sa = 0.0, cb = 0.0, ca = 0.0, sb = 0.0, sa2 = 0.0, cb2 = 0.0;
      for (l = 0; l < n; ++l) {
        double s = sin(t * w[l]), c = cos(t * w[l]), w2 = w[l] * w[l];
        sa += s * a[k * n + l];
        cb += c * b[k * n + l];
        ca += (c * w[l]) * a[k * n + l];
        sb += (s * w[l]) * b[k * n + l];
        sa2 += (-(s * w2)) * a[k * n + l];
        cb2 += (c * w2) * b[k * n + l];
      }
      x[k] = (d[n + k] + sa) + cb;
      xd[k] = ca - sb;
      xdd[k] = sa2 - cb2;
    }
  } else if (sim->ref_kind == SP_REF_SINUSOIDS) {  /* d: om, phases, amplitudes, sin(phases) */
    for (k = 0; k < 6; ++k) {
      double arg = d[k] * t + d[6 + k], s = sin(arg), A = d[12 + k];
      x[k] = A * (s - d[18 + k]);
      xd[k] = (A * d[k]) * cos(arg);
      xdd[k] = ((-A) * (d[k] * d[k])) * s;
    }
  } else {  /* minimum-jerk knots; d: six counts m_k, then each axis's m_k times, m_k values */
    const double* axis = d + 6;
    for (k = 0; k < 6; ++k) {
      long long m = (long long)d[k], seg = -1;
      const double *tk = axis, *vk = axis + m;
      x[k] = m > 0 ? vk[0] : 0.0;
      xd[k] = 0.0;
      xdd[k] = 0.0;
      for (l = 0; l + 1 < m; ++l)
        if (t >= tk[l]) seg = l;
      if (seg >= 0) {
        double h = tk[seg + 1] - tk[seg], dv = vk[seg + 1] - vk[seg], f[3];
        sp_quintic((t - tk[seg]) / h, f);
        x[k] = vk[seg] + dv * f[0];
        xd[k] = dv / h * f[1];
        xdd[k] = dv / (h * h) * f[2];
      }
      axis += 2 * m;
    }
  }
}

/* The reference's pose T (row-major 4x4), twist V and classical acceleration A at t
   (states_at of motion/trajectories.py, the same formulas). */
SP_EXPORT void sp_ref_eval(const sp_sim* sim, double t, double* T, double* V, double* A) {
  double x[6], xd[6], xdd[6], co[5], K[9], KK[9], E[9], J[9], rxr[3], rrr[3], drr[3], rdr;
  const double *r = x + 3, *rd = xd + 3, *rdd = xdd + 3, *P = sim->ref_pose;
  int i, j;
  sp_ref_coordinates(sim, t, x, xd, xdd);
  sp_so3_coefs(r, co);
  K[0] = 0.0; K[1] = -r[2]; K[2] = r[1];
  K[3] = r[2]; K[4] = 0.0; K[5] = -r[0];
  K[6] = -r[1]; K[7] = r[0]; K[8] = 0.0;
  for (i = 0; i < 3; ++i)
    for (j = 0; j < 3; ++j)
      KK[3 * i + j] = (K[3 * i] * K[j] + K[3 * i + 1] * K[3 + j]) + K[3 * i + 2] * K[6 + j];
  for (i = 0; i < 9; ++i) {
    double id = (i % 4 == 0) ? 1.0 : 0.0;
    E[i] = (id + co[0] * K[i]) + co[1] * KK[i];
    J[i] = (id + co[1] * K[i]) + co[2] * KK[i];
  }
  for (i = 0; i < 3; ++i) {
    for (j = 0; j < 3; ++j)
      T[4 * i + j] = (E[3 * i] * P[j] + E[3 * i + 1] * P[4 + j]) + E[3 * i + 2] * P[8 + j];
    T[4 * i + 3] = P[4 * i + 3] + x[i];
  }
  T[12] = 0.0; T[13] = 0.0; T[14] = 0.0; T[15] = 1.0;
  rdr = (r[0] * rd[0] + r[1] * rd[1]) + r[2] * rd[2];
  sp_cross(r, rd, rxr);
  sp_cross(r, rxr, rrr);
  sp_cross(rd, rxr, drr);
  for (i = 0; i < 3; ++i) {
    V[i] = xd[i];
    A[i] = xdd[i];
    V[3 + i] = (J[3 * i] * rd[0] + J[3 * i + 1] * rd[1]) + J[3 * i + 2] * rd[2];
    A[3 + i] = ((J[3 * i] * rdd[0] + J[3 * i + 1] * rdd[1]) + J[3 * i + 2] * rdd[2])
               + (((rdr * co[3]) * rxr[i] + (rdr * co[4]) * rrr[i]) + co[2] * drr[i]);
  }
}

/* The reference's last evaluation on this thread: (T, V, A) of run ref_id at time t. */
static __thread long long sp_ref_last_id = 0;
static __thread double sp_ref_last_t = 0.0, sp_ref_last[28];

/* output_dt: the k-th output time k * output_dt (duration past the end), simulation.py's
   _Run._output_time; no step crosses it. */
static double sp_out_time(const sp_sim* sim, double k) {
  double t = k * sim->output_dt;
  return t > sim->duration - sim->h_min ? sim->duration : t;
}

/* The direct model's last input at stage time t, reference row r: the robot's base values,
   or a payload's joints [q, qd, qdd] sampled there (NULL: not sampled at t, bail). */
static const double* sp_chi(const sp_sim* sim, long long r, double t) {
  if (sim->n_pay == 0) return sim->chi;
  if (r < 0 || r >= sim->n_pay || sim->pay_t[r] != t) return 0;
  return sim->pay_x + r * sim->pay_nx;
}

/* The step's target cut at the next output time (with output_dt). */
static double sp_cut(const sp_sim* sim, const double* st, double target) {
  double o;
  if (sim->output_dt <= 0) return target;
  o = sp_out_time(sim, st[ST_OUT_K]);
  return o < target ? o : target;
}

/* The computed-torque law of motion/control.py, the reference evaluated at t (or, a
   reference sampled before the run, its row r, which must be t's):
   Gamma = IDM(T, V, A_ref + kd (V_ref - V) + kp [p_ref - p; log3(R_ref R^T)]). */
static int sp_ct(const sp_sim* sim, long long r, double t, const double* T, const double* V,
                 double* g) {
  const double *Tr, *Vr, *Ar;
  double E[9], e[6], th, sc[2], A[6], Tb[16], Vb[6], Ab[6];
  int i, j, flag;
  if (sim->ref_kind != SP_REF_TABLE && sim->ref_id > 0) {
    /* rk4 asks twice at t + h/2 and twice at t + h: this thread's last evaluation, kept
       with the run's reference id (unique in the process) and its time */
    if (sp_ref_last_id != sim->ref_id || sp_ref_last_t != t) {
      sp_ref_eval(sim, t, sp_ref_last, sp_ref_last + 16, sp_ref_last + 22);
      sp_ref_last_id = sim->ref_id;
      sp_ref_last_t = t;
    }
    Tr = sp_ref_last; Vr = sp_ref_last + 16; Ar = sp_ref_last + 22;
  } else if (sim->ref_kind != SP_REF_TABLE) {
    sp_ref_eval(sim, t, Tb, Vb, Ab);
    Tr = Tb; Vr = Vb; Ar = Ab;
  } else {
    if (r < 0 || r >= sim->n_ref || sim->ref_t[r] != t) return 0;
    Tr = sim->ref_T + 16 * r; Vr = sim->ref_V + 6 * r; Ar = sim->ref_A + 6 * r;
  }
  for (i = 0; i < 3; ++i) {
    e[i] = Tr[4 * i + 3] - T[4 * i + 3];
    for (j = 0; j < 3; ++j)
      E[3 * i + j] = Tr[4 * i] * T[4 * j] + Tr[4 * i + 1] * T[4 * j + 1]
                   + Tr[4 * i + 2] * T[4 * j + 2];
  }
  if (!sp_log3(E, &th, sc, e + 3)) return 0;
  for (i = 0; i < 6; ++i) A[i] = (Ar[i] + sim->kd[i] * (Vr[i] - V[i])) + sim->kp[i] * e[i];
  sim->idm(1, T, V, A, sim->idm_chi, sim->idm_max_cond, g, &flag);
  return (flag & ~8) == 0;  /* REPIVOTED alone: solved, not an error */
}

/* The forces at (t, T, V): held over a control period k (held_k, held_g updated when a new
   period starts); r: the reference row of a continuous computed-torque controller.
   Returns 0 when the Python loop must decide (bail), 2 when Python must give them. */
static int sp_forces(const sp_sim* sim, double t, const double* T, const double* V, long long k,
                     long long r, double* held_k, double* held_g, double* g) {
  int i;
  if (sim->period > 0 && *held_k == (double)k) {
    memcpy(g, held_g, 6 * sizeof(double));
    return 1;
  }
  switch (sim->kind) {
    case 0:
      memcpy(g, sim->g_const, 6 * sizeof(double));
      break;
    case 1: case 2: {
      long long lo = 0, hi = sim->n_tab, mid, K = sim->n_tab;  /* i = #(tab_t <= t) - 1 */
      while (lo < hi) {
        mid = (lo + hi) / 2;
        if (sim->tab_t[mid] <= t) lo = mid + 1; else hi = mid;
      }
      mid = lo - 1;
      if (mid < 0) { memcpy(g, sim->tab_g, 6 * sizeof(double)); break; }
      if (sim->kind == 1 || mid >= K - 1) {
        memcpy(g, sim->tab_g + 6 * (mid < K - 1 ? mid : K - 1), 6 * sizeof(double));
        break;
      }
      {
        double w = (t - sim->tab_t[mid]) / (sim->tab_t[mid + 1] - sim->tab_t[mid]);
        const double *a = sim->tab_g + 6 * mid, *b = a + 6;
        for (i = 0; i < 6; ++i) g[i] = a[i] + w * (b[i] - a[i]);
      }
      break;
    }
    case 3:
      if (!sp_ct(sim, sim->ref_per_period ? k : r, t, T, V, g)) return 0;
      break;
    default:
      return 2;
  }
  if (sim->period > 0) { *held_k = (double)k; memcpy(held_g, g, 6 * sizeof(double)); }
  return 1;
}

/* The sign of det Jp^-1 of a state the direct model passed: from det, the determinant of
   S = Jp^-T diag(1, 1, 1, 1/l, 1/l, 1/l) of its cheap condition check (non-zero when that
   check decided), else from an LU of Jp^-1 (aux). */
static double sp_sign_of(const sp_sim* sim, double det, const double* aux) {
  if (det != 0.0 && sim->max_cond <= SP_STATIC_SIGN_COND) return det > 0.0 ? 1.0 : -1.0;
  return sp_det_sign(aux + sim->jinv);
}

/* One evaluation of the chart derivative at y (around T0's rotation): pose T, forces g,
   dy = [v, dxi/dt, accel], sign of det Jp^-1. Returns 1, 0 (bail) or 2 (forces from
   Python). */
static int sp_eval(const sp_sim* sim, double t, const double* T0, const double* y, long long k,
                   long long r, double* held_k, double* held_g, double* aux, double* T,
                   double* dy, double* g, double* sign, double* det_out) {
  double E[9], det;
  const double* chi = sp_chi(sim, r, t);
  int ok, zero = y[3] == 0.0 && y[4] == 0.0 && y[5] == 0.0;
  if (!chi) return 0;
  /* At xi = 0 (a state, not a stage) exp3 is I and Jlog3 is I, exactly (Pinocchio's
     formulas at theta = eps): the pose is T0's rotation and dxi/dt is w, no rounding. */
  if (zero) {
    memcpy(T, T0, 16 * sizeof(double));
    T[3] = y[0]; T[7] = y[1]; T[11] = y[2];
  } else {
    sp_exp3(y + 3, E);
    sp_chart_pose(T0, y, E, T);
  }
  ok = sp_forces(sim, t, T, y + 6, k, r, held_k, held_g, g);
  if (ok != 1) return ok;
  if (sim->ddm(T, y + 6, g, chi, sim->max_cond, dy + 6, aux, &det) != 0) return 0;
  if (zero) {
    dy[3] = y[9]; dy[4] = y[10]; dy[5] = y[11];
  } else if (!sp_dxi(E, y + 9, dy + 3)) {
    return 0;
  }
  dy[0] = y[6]; dy[1] = y[7]; dy[2] = y[8];
  *sign = sp_sign_of(sim, det, aux);
  if (det_out) *det_out = det;
  return 1;
}

/* The state block's state as the next output row; with output_dt only a state at (or
   within h_min before) the next output time, as simulation.py's _Run.record keeps it. */
static void sp_write_row(const sp_sim* sim, double* st) {
  long long m = (long long)st[ST_ROW];
  if (sim->output_dt > 0) {
    if (st[ST_T] < sp_out_time(sim, st[ST_OUT_K]) - sim->h_min) return;
    st[ST_OUT_K] = floor(st[ST_T] / sim->output_dt + SP_RATIO_SLACK) + 1;
  }
  sim->t_out[m] = st[ST_T];
  memcpy(sim->P_out + 16 * m, st + ST_POSE, 16 * sizeof(double));
  memcpy(sim->V_out + 6 * m, st + ST_TWIST, 6 * sizeof(double));
  memcpy(sim->A_out + 6 * m, st + ST_DY + 6, 6 * sizeof(double));
  memcpy(sim->G_out + 6 * m, st + ST_GAMMA, 6 * sizeof(double));
  if (sim->act)  /* general legs: the actuated joint values of the row's pose */
    sim->act(1, sim->P_out + 16 * m, sim->L_out + 6 * m);
  else if (sim->L_out)
    memcpy(sim->L_out + 6 * m, st + ST_LEN, 6 * sizeof(double));
  st[ST_ROW] = (double)(m + 1);
}

/* Accept the end state (t, T with xi = 0, V) as the state block's new state; aux: the
   direct model's by-products there (the 6-UPS leg lengths squared at sim->q3sq, if >= 0). */
static void sp_accept(const sp_sim* sim, double* st, double t, const double* T, const double* V,
                      const double* dy, const double* g, double held_k, const double* held_g,
                      const double* aux) {
  int i;
  if (sim->q3sq >= 0) for (i = 0; i < 6; ++i) st[ST_LEN + i] = sqrt(aux[sim->q3sq + i]);
  st[ST_T] = t;
  memcpy(st + ST_POSE, T, 16 * sizeof(double));
  memcpy(st + ST_TWIST, V, 6 * sizeof(double));
  memcpy(st + ST_DY, dy, 12 * sizeof(double));
  memcpy(st + ST_GAMMA, g, 6 * sizeof(double));
  st[ST_HELD_K] = held_k;
  memcpy(st + ST_HELD_G, held_g, 6 * sizeof(double));
  if (sim->adaptive || t == sp_grid(sim, (long long)st[ST_N] + 1)) st[ST_N] += 1;
  st[ST_STEPS] += 1;
}

/* Evaluate the end state (t, T1, V1) of a step; 1 accepted, 0 bail, 2 forces from Python. */
static int sp_end_state(const sp_sim* sim, double* st, double t, const double* T1,
                        const double* V1, double* aux) {
  double y[12], dy[12], T[16], g[6], hk = st[ST_HELD_K], hg[6], sign, det;
  long long k = sp_period_index(sim, t), n1 = (long long)st[ST_N] + 1;
  int ok;
  memcpy(hg, st + ST_HELD_G, sizeof hg);
  y[0] = T1[3]; y[1] = T1[7]; y[2] = T1[11];
  y[3] = 0.0; y[4] = 0.0; y[5] = 0.0;
  memcpy(y + 6, V1, 6 * sizeof(double));
  ok = sp_eval(sim, t, T1, y, k, 2 * n1, &hk, hg, aux, T, dy, g, &sign, 0);
  if (ok == 2) {  /* forces from Python: the end state's sign and guard from a direct model
                     call with the forces held so far (Jp^-1 does not depend on them) */
    const double* chi = sp_chi(sim, 2 * n1, t);
    if (!chi || sim->ddm(T, y + 6, st + ST_HELD_G, chi, sim->max_cond, dy + 6, aux, &det) != 0)
      return 0;
    if (sp_sign_of(sim, det, aux) != st[ST_SIGN]) return 0;
    st[ST_PENDING] = 1.0;
    st[ST_PEND_T] = t;
    memcpy(st + ST_PEND_POSE, T, 16 * sizeof(double));
    memcpy(st + ST_PEND_TWIST, V1, 6 * sizeof(double));
    return 2;
  }
  if (ok != 1 || sign != st[ST_SIGN]) return 0;
  sp_accept(sim, st, t, T, y + 6, dy, g, hk, hg, aux);
  return 1;
}

/* Dormand-Prince 5(4) (simulation.py's _DP_*). */
static const double sp_dp_c[7] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
static const double sp_dp_a[7][6] = {
  {0},
  {1.0 / 5},
  {3.0 / 40, 9.0 / 40},
  {44.0 / 45, -56.0 / 15, 32.0 / 9},
  {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
  {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
  {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84},
};
static const double sp_dp_b[7] = {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192,
                                  -2187.0 / 6784, 11.0 / 84, 0.0};
static const double sp_dp_bh[7] = {5179.0 / 57600, 0.0, 7571.0 / 16695, 393.0 / 640,
                                   -92097.0 / 339200, 187.0 / 2100, 1.0 / 40};

/* The adaptive loop of simulation.py (method="adaptive"): trial steps of h_cur (st[ST_H])
   towards the end or the control period's end, rejected and shrunk by the error control,
   accepted ones written as rows. Bails (SP_BAIL) before any trial the Python loop must
   take (a flagged state, a sign change, a step below the minimum), st and its h_cur left
   as they were before it. */
static int sp_adaptive(const sp_sim* sim, double* st, double* aux) {
  double K[7][12], y0[12], y[12], T[7][16], g[6], hk, hg[6], sgn, e[12], scale, err;
  int i, j, ok;
  while (st[ST_T] < sim->duration && (long long)st[ST_ROW] < sim->rows
         && (long long)st[ST_STEPS] < sim->rows) {
    double t = st[ST_T], h_cur = st[ST_H], target = sim->duration, h, t_new, sum = 0.0;
    long long k = sp_period_index(sim, t);
    const double* T0 = st + ST_POSE;
    if (sim->period > 0) {
      double end = (double)(k + 1) * sim->period;
      if (end < target) target = end;
    }
    target = sp_cut(sim, st, target);
    if (target - t <= h_cur + 4 * (nextafter(target, INFINITY) - target)) {
      h = target - t; t_new = target;
    } else {
      h = h_cur; t_new = t + h_cur;
    }
    hk = st[ST_HELD_K];
    memcpy(hg, st + ST_HELD_G, sizeof hg);
    y0[0] = T0[3]; y0[1] = T0[7]; y0[2] = T0[11];
    y0[3] = 0.0; y0[4] = 0.0; y0[5] = 0.0;
    memcpy(y0 + 6, st + ST_TWIST, 6 * sizeof(double));
    memcpy(K[0], st + ST_DY, 12 * sizeof(double));
    for (j = 1; j < 7; ++j) {
      for (i = 0; i < 12; ++i) {
        double acc = 0.0;
        int l;
        for (l = 0; l < j; ++l) acc = acc + sp_dp_a[j][l] * K[l][i];
        y[i] = y0[i] + h * acc;
      }
      if (sp_eval(sim, t + sp_dp_c[j] * h, T0, y, k, -1, &hk, hg, aux, T[j], K[j], g, &sgn, 0)
          != 1)
        return SP_BAIL;
      if (sgn != st[ST_SIGN]) return SP_BAIL;
    }
    for (i = 0; i < 12; ++i) {  /* the error estimate of simulation.py */
      double d = 0.0, m;
      for (j = 0; j < 7; ++j) d += (sp_dp_b[j] - sp_dp_bh[j]) * K[j][i];
      m = fabs(y0[i]) > fabs(y[i]) ? fabs(y0[i]) : fabs(y[i]);
      scale = sim->atol + sim->rtol * m;
      e[i] = h * d / scale;
      e[i] = e[i] * e[i];
    }
    /* np.mean of the 12 values: NumPy's pairwise sum (the first 8 pairwise, the rest in
       turn) over 12 */
    sum = ((e[0] + e[1]) + (e[2] + e[3])) + ((e[4] + e[5]) + (e[6] + e[7]));
    for (i = 8; i < 12; ++i) sum += e[i];
    err = sqrt(sum / 12.0);
    if (!(err <= 1.0)) {
      double h_new = h * fmax(0.2, 0.9 * pow(err, -1.0 / 5));
      if (h_new < sim->h_min) return SP_BAIL;  /* the Python loop stops there */
      st[ST_H] = h_new;
      continue;
    }
    h_cur = h * (err == 0 ? 5.0 : fmin(5.0, 0.9 * pow(err, -1.0 / 5)));
    if (sp_period_index(sim, t_new) == k) {  /* FSAL: the last stage is the end state */
      double dy[12];
      dy[0] = y[6]; dy[1] = y[7]; dy[2] = y[8];
      dy[3] = y[9]; dy[4] = y[10]; dy[5] = y[11];
      memcpy(dy + 6, K[6] + 6, 6 * sizeof(double));
      sp_accept(sim, st, t_new, T[6], y + 6, dy, g, hk, hg, aux);
    } else {
      st[ST_H_PEND] = h_cur;
      ok = sp_end_state(sim, st, t_new, T[6], y + 6, aux);
      if (ok == 0) return SP_BAIL;
      if (ok == 2) return SP_NEED_FORCE;
    }
    st[ST_H] = h_cur;
    sp_write_row(sim, st);
  }
  return SP_DONE;
}

/* Grid steps from the state block st (at grid index st[ST_N]) up to n_stop, or until the
   output buffers (sim->rows rows) are full: one row per accepted state at st[ST_ROW].
   Returns SP_DONE, SP_BAIL or SP_NEED_FORCE (see _simsource.py). */
SP_EXPORT int sp_sim_run(const sp_sim* sim, double* st, long long n_stop) {
  double aux[SP_MAX_AUX];
  double y0[12], y[12], k2[12], k3[12], k4[12], y1[12], T2[16], T3[16], T4[16], T1[16];
  double g[6], hk, hg[6], sign, dt = sim->dt;
  int i, ok;
  if (sim->naux > SP_MAX_AUX) return SP_BAIL;
  if ((long long)st[ST_ROW] >= sim->rows) return SP_DONE;
  if (st[ST_PENDING] == SP_START) {  /* the initial state (simulation.py's begin()) */
    double dy[12], det;
    double* T0 = st + ST_POSE;
    st[ST_PENDING] = 0.0;
    if (sim->max_cond > SP_STATIC_SIGN_COND) return SP_BAIL;
    y[0] = T0[3]; y[1] = T0[7]; y[2] = T0[11];
    y[3] = 0.0; y[4] = 0.0; y[5] = 0.0;
    memcpy(y + 6, st + ST_TWIST, 6 * sizeof(double));
    hk = -1.0;
    memset(hg, 0, sizeof hg);
    ok = sp_eval(sim, st[ST_T], T0, y, sp_period_index(sim, st[ST_T]), 0, &hk, hg, aux, T1, dy,
                 g, &sign, &det);
    if (ok != 1 || det == 0.0) return SP_BAIL;  /* the sign as the reference's: decided */
    st[ST_SIGN] = sign;
    sp_accept(sim, st, st[ST_T], T1, y + 6, dy, g, hk, hg, aux);
    st[ST_N] = 0.0;  /* the state of grid index 0, no step */
    st[ST_STEPS] -= 1;
    sp_write_row(sim, st);
    return SP_DONE;
  }
  if (st[ST_PENDING] != 0.0) {  /* the pending end state with the forces Python gave */
    double* Tp = st + ST_PEND_POSE;
    double dy[12];
    long long k = sp_period_index(sim, st[ST_PEND_T]);
    st[ST_PENDING] = 0.0;
    if (st[ST_HELD_K] != (double)k) return SP_BAIL;
    y[0] = Tp[3]; y[1] = Tp[7]; y[2] = Tp[11];
    y[3] = 0.0; y[4] = 0.0; y[5] = 0.0;
    memcpy(y + 6, st + ST_PEND_TWIST, 6 * sizeof(double));
    hk = st[ST_HELD_K];
    memcpy(hg, st + ST_HELD_G, sizeof hg);
    memcpy(T1, Tp, sizeof T1);
    ok = sp_eval(sim, st[ST_PEND_T], T1, y, k, sim->adaptive ? -1 : 2 * (long long)st[ST_N] + 2,
                 &hk, hg, aux, T2, dy, g, &sign, 0);
    if (ok != 1 || sign != st[ST_SIGN]) return SP_BAIL;
    sp_accept(sim, st, st[ST_PEND_T], T2, y + 6, dy, g, hk, hg, aux);
    st[ST_H] = st[ST_H_PEND];
    sp_write_row(sim, st);
  }
  if (sim->adaptive) return sp_adaptive(sim, st, aux);
  while ((long long)st[ST_N] < n_stop && st[ST_T] < sim->duration
         && (long long)st[ST_ROW] < sim->rows && (long long)st[ST_STEPS] < sim->rows) {
    long long n = (long long)st[ST_N], k = sp_period_index(sim, st[ST_T]);
    double t = st[ST_T], target = sp_cut(sim, st, sp_grid(sim, n + 1)), h, sgn;
    const double* T0 = st + ST_POSE;
    const double* k1 = st + ST_DY;
    if (!(target - t <= dt + 4 * (nextafter(target, INFINITY) - target))) return SP_BAIL;
    h = target - t;
    hk = st[ST_HELD_K];
    memcpy(hg, st + ST_HELD_G, sizeof hg);
    y0[0] = T0[3]; y0[1] = T0[7]; y0[2] = T0[11];
    y0[3] = 0.0; y0[4] = 0.0; y0[5] = 0.0;
    memcpy(y0 + 6, st + ST_TWIST, 6 * sizeof(double));
    for (i = 0; i < 12; ++i) y[i] = y0[i] + h / 2 * k1[i];
    if (sp_eval(sim, t + h / 2, T0, y, k, 2 * n + 1, &hk, hg, aux, T2, k2, g, &sgn, 0) != 1)
      return SP_BAIL;
    if (sgn != st[ST_SIGN]) return SP_BAIL;
    for (i = 0; i < 12; ++i) y[i] = y0[i] + h / 2 * k2[i];
    if (sp_eval(sim, t + h / 2, T0, y, k, 2 * n + 1, &hk, hg, aux, T3, k3, g, &sgn, 0) != 1)
      return SP_BAIL;
    if (sgn != st[ST_SIGN]) return SP_BAIL;
    for (i = 0; i < 12; ++i) y[i] = y0[i] + h * k3[i];
    if (sp_eval(sim, target, T0, y, k, 2 * n + 2, &hk, hg, aux, T4, k4, g, &sgn, 0) != 1)
      return SP_BAIL;
    if (sgn != st[ST_SIGN]) return SP_BAIL;
    for (i = 0; i < 12; ++i)
      y1[i] = y0[i] + h / 6 * (((k1[i] + 2 * k2[i]) + 2 * k3[i]) + k4[i]);
    sp_exp3(y1 + 3, T2);  /* T2 free again: the exp3 of the step's end */
    sp_chart_pose(T0, y1, T2, T1);
    ok = sp_end_state(sim, st, target, T1, y1 + 6, aux);
    if (ok == 0) return SP_BAIL;
    if (ok == 2) return SP_NEED_FORCE;
    sp_write_row(sim, st);
  }
  return SP_DONE;
}

/* Many runs one after the other (a slice of a batch; the caller's threads run slices
   concurrently): run j from its state block st + j * ST_SIZE to n_stop with sims[j] (its
   own output buffers); status[j] as sp_sim_run's. Returns the OR of the statuses. */
SP_EXPORT int sp_sim_many(long long runs, const sp_sim* sims, double* st, long long st_size,
                          long long n_stop, int* status) {
  long long j;
  int any = 0;
  for (j = 0; j < runs; ++j) {
    status[j] = sp_sim_run(sims + j, st + j * st_size, n_stop);
    any |= status[j];
  }
  return any;
}
"""
