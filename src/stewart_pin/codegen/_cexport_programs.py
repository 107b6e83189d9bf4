"""The programs, build file and README of an exported library (:mod:`.c_export`).

:class:`string.Template` texts (``$$`` is a literal ``$``, as CMake needs): ``P`` the
prefix, ``PU`` upper-cased, numbers otherwise.
"""

from __future__ import annotations

TEST = r"""/* ${P}_test.c: every function of ${P}.h against the values of the Python reference
   path (${P}_reference.h), to ${PU}_REF_TOLERANCE relative (max-norm of the difference
   over the max-norm of the reference), and the error codes. Exit code 0 when all pass. */
#include "${P}.h"
#include "${P}_reference.h"

#include <math.h>
#include <stdio.h>

static int failures = 0;

/* Compare n outputs; returns the relative error (or prints the failure). */
static double compare(const char* what, int state, int rc, const double* got,
                      const double* ref, int n) {
  double diff = 0.0, size = 0.0, err;
  int k;
  for (k = 0; k < n; ++k) {
    double d = fabs(got[k] - ref[k]);
    if (!(d <= diff)) diff = d; /* NaN propagates */
    if (fabs(ref[k]) > size) size = fabs(ref[k]);
  }
  err = size > 0.0 ? diff / size : diff;
  if (rc != ${PU}_OK || !(err <= ${PU}_REF_TOLERANCE)) {
    printf("FAIL %s state %d: return %d, relative error %.3g\n", what, state, rc, err);
    ++failures;
  }
  return err;
}

static void expect(const char* what, int rc, int code) {
  if (rc != code) {
    printf("FAIL %s: return %d, expected %d\n", what, rc, code);
    ++failures;
  }
}

int main(void) {
  double work[${PU}_WORK_SIZE];
  double out[36], worst[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
  const char* names[5] = {"inverse_geometry", "inverse_jacobian", "forward_geometry",
                          "inverse_dynamics", "direct_dynamics"};
  double e;
  int s, k;
  for (s = 0; s < ${PU}_REF_N; ++s) {
    const double* T = ${P}_poses[s];
    e = compare(names[0], s, ${P}_inverse_geometry(T, out, work), out, ${P}_ref_q[s], 6);
    if (e > worst[0]) worst[0] = e;
    e = compare(names[1], s, ${P}_inverse_jacobian(T, out, work), out, ${P}_ref_jinv[s], 36);
    if (e > worst[1]) worst[1] = e;
    e = compare(names[2], s, ${P}_forward_geometry(${P}_ref_q[s], ${P}_guesses[s], out, work),
                out, ${P}_ref_pose[s], 16);
    if (e > worst[2]) worst[2] = e;
    e = compare(names[3], s,
                ${P}_inverse_dynamics(T, ${P}_twists[s], ${P}_accels[s], out, work), out,
                ${P}_ref_gamma[s], 6);
    if (e > worst[3]) worst[3] = e;
    e = compare(names[4], s,
                ${P}_direct_dynamics(T, ${P}_twists[s], ${P}_gammas_in[s], out, work), out,
                ${P}_ref_accel[s], 6);
    if (e > worst[4]) worst[4] = e;
  }
  for (k = 0; k < 5; ++k)
    printf("%-18s largest relative error %.3g over %d states\n", names[k], worst[k],
           ${PU}_REF_N);
#ifdef ${PU}_HAS_DERIVATIVES
  {
    static const char* blocks[3] = {"d_pose", "d_twist", "d_accel"};
    double g[6], d[108], worst_d = 0.0;
    int b;
    for (s = 0; s < ${PU}_REF_N; ++s) {
      int rc = ${P}_inverse_dynamics_derivatives(${P}_poses[s], ${P}_twists[s], ${P}_accels[s],
                                                 g, d, d + 36, d + 72, work);
      for (b = 0; b < 3; ++b) {
        e = compare(blocks[b], s, rc, d + 36 * b, ${P}_ref_didm[s] + 36 * b, 36);
        if (e > worst_d) worst_d = e;
      }
    }
    printf("%-18s largest relative error %.3g over %d states\n", "derivatives", worst_d,
           ${PU}_REF_N);
  }
#endif
  /* a pose out of reach, a matrix that is not a pose: error codes and NaN outputs */
  expect("inverse_geometry out of reach",
         ${P}_inverse_geometry(${P}_far_pose, out, work), ${PU}_ERR_RANGE);
  if (!isnan(out[0])) {
    printf("FAIL inverse_geometry out of reach: the output is not NaN\n");
    ++failures;
  }
  expect("inverse_jacobian out of reach",
         ${P}_inverse_jacobian(${P}_far_pose, out, work), ${PU}_ERR_RANGE);
  expect("inverse_dynamics out of reach",
         ${P}_inverse_dynamics(${P}_far_pose, ${P}_twists[0], ${P}_accels[0], out, work),
         ${PU}_ERR_RANGE);
  expect("direct_dynamics out of reach",
         ${P}_direct_dynamics(${P}_far_pose, ${P}_twists[0], ${P}_gammas_in[0], out, work),
         ${PU}_ERR_RANGE);
  expect("inverse_dynamics not a rotation",
         ${P}_inverse_dynamics(${P}_bad_pose, ${P}_twists[0], ${P}_accels[0], out, work),
         ${PU}_ERR_INPUT);
  expect("forward_geometry guess not a rotation",
         ${P}_forward_geometry(${P}_ref_q[0], ${P}_bad_pose, out, work), ${PU}_ERR_INPUT);
  {
    double q[6];
    for (k = 0; k < 6; ++k) q[k] = ${P}_ref_q[0][k];
    q[0] = NAN;
    expect("forward_geometry NaN", ${P}_forward_geometry(q, ${P}_home_pose, out, work),
           ${PU}_ERR_INPUT);
#if ${PU}_REF_HAS_PRISMATIC
    {
      int rc;
      /* every prismatic actuated joint 1 km out: out of its range, wherever Newton ends */
      for (k = 0; k < 6; ++k) q[k] = ${P}_ref_q[0][k] + 1e3 * ${P}_prismatic[k];
      rc = ${P}_forward_geometry(q, ${P}_home_pose, out, work);
      if (rc >= 0) {
        printf("FAIL forward_geometry of unreachable values returned %d\n", rc);
        ++failures;
      }
    }
#endif
  }
  printf("%s: %d failure(s)\n", failures ? "FAILED" : "passed", failures);
  return failures ? 1 : 0;
}
"""

BENCH = r"""/* ${P}_bench.c: the median time per call of each function of ${P}.h, cycling over the
   states of ${P}_reference.h (forward geometry from guesses 1e-3 m / 1e-3 rad off). */
#define _POSIX_C_SOURCE 199309L
#include "${P}.h"
#include "${P}_reference.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define ROUNDS 101

static volatile double sink;

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int by_value(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

static int call(int which, int s, double* out, double* work) {
  switch (which) {
    case 0: return ${P}_inverse_geometry(${P}_poses[s], out, work);
    case 1: return ${P}_inverse_jacobian(${P}_poses[s], out, work);
    case 2: return ${P}_forward_geometry(${P}_ref_q[s], ${P}_guesses[s], out, work);
    case 3:
      return ${P}_inverse_dynamics(${P}_poses[s], ${P}_twists[s], ${P}_accels[s], out, work);
    case 4:
      return ${P}_direct_dynamics(${P}_poses[s], ${P}_twists[s], ${P}_gammas_in[s], out, work);
    default: {
#ifdef ${PU}_HAS_DERIVATIVES
      double d[108];
      return ${P}_inverse_dynamics_derivatives(${P}_poses[s], ${P}_twists[s], ${P}_accels[s],
                                               out, d, d + 36, d + 72, work);
#else
      return 0;
#endif
    }
  }
}

int main(int argc, char** argv) {
  static const char* names[6] = {"inverse_geometry", "inverse_jacobian", "forward_geometry",
                                 "inverse_dynamics", "direct_dynamics", "derivatives"};
#ifdef ${PU}_HAS_DERIVATIVES
  const int functions = 6;
#else
  const int functions = 5;
#endif
  double work[${PU}_WORK_SIZE], out[36], times[ROUNDS];
  int calls = argc > 1 ? atoi(argv[1]) : 2000, which, r, c;
  if (calls < 1) calls = 1;
  printf("median time per call over %d rounds of %d calls\n", ROUNDS, calls);
  for (which = 0; which < functions; ++which) {
    for (r = 0; r < ROUNDS; ++r) {
      double t0 = now();
      for (c = 0; c < calls; ++c) {
        if (call(which, c % ${PU}_REF_N, out, work) != 0) {
          printf("%s failed\n", names[which]);
          return 1;
        }
        sink = out[0];
      }
      times[r] = (now() - t0) / calls;
    }
    qsort(times, ROUNDS, sizeof(double), by_value);
    printf("%-18s %9.3f us\n", names[which], 1e6 * times[ROUNDS / 2]);
  }
  return 0;
}
"""

CONTROL_LOOP = r"""// ${P}_control_loop.cpp: a fixed-rate computed-torque loop with the exported
// inverse dynamic model, written the way a ros2_control controller is (on_configure allocates,
// update(time, period) runs at the loop rate and allocates nothing). Plain C++17, no ROS:
// the "hardware" is the exported direct dynamic model, integrated at the loop rate.
//
//   ${P}_control_loop [steps=1000] [rate_hz=1000]
//
// Prints the median and the largest time of update() and the tracking error.
#include "${P}.h"
#include "${P}_reference.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

namespace {

using Pose = std::array<double, 16>;
using Vec6 = std::array<double, 6>;

// R <- exp(w^) R on the rotation block of a row-major 4x4 pose (Rodrigues).
void rotate(const double w[3], double* T) {
  const double th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  const double th = std::sqrt(th2);
  const double a = th2 < 1e-12 ? 1.0 : std::sin(th) / th;
  const double b = th2 < 1e-12 ? 0.5 : (1.0 - std::cos(th)) / th2;
  const double K[3][3] = {{0, -w[2], w[1]}, {w[2], 0, -w[0]}, {-w[1], w[0], 0}};
  double E[3][3], R[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double kk = 0;
      for (int m = 0; m < 3; ++m) kk += K[i][m] * K[m][j];
      E[i][j] = (i == j ? 1.0 : 0.0) + a * K[i][j] + b * kk;
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      R[i][j] = E[i][0] * T[j] + E[i][1] * T[4 + j] + E[i][2] * T[8 + j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) T[4 * i + j] = R[i][j];
}

// The shape of a controller_interface::ControllerInterface: state interfaces (pose,
// twist), command interfaces (the six actuator efforts).
class ComputedTorqueController {
 public:
  bool on_configure(const Pose& set_point) {
    work_.assign(${PU}_WORK_SIZE, 0.0);  // the only allocation
    set_point_ = set_point;
    return true;
  }

  // One control period: the reference trajectory (a vertical sine about the set point),
  // the PD law on the pose error, gamma = IDM(pose, twist, accel_cmd). Returns the
  // model's code (0, or a negative ${PU}_ERR_*: then hold the previous command).
  int update(double time, double /*period*/, const Pose& pose, const Vec6& twist,
             Vec6& gamma) {
    const double w = 2.0 * 3.14159265358979 * frequency_;
    double p_d[3] = {set_point_[3], set_point_[7],
                     set_point_[11] + amplitude_ * std::sin(w * time)};
    double v_d[3] = {0.0, 0.0, amplitude_ * w * std::cos(w * time)};
    double a_d[3] = {0.0, 0.0, -amplitude_ * w * w * std::sin(w * time)};
    double accel[6];
    for (int i = 0; i < 3; ++i) {
      accel[i] = a_d[i] + kd_ * (v_d[i] - twist[i]) + kp_ * (p_d[i] - pose[4 * i + 3]);
    }
    // orientation error: the vee of the skew part of Rd R^T (small angles), Rd = set point
    double M[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        M[i][j] = set_point_[4 * i] * pose[4 * j] + set_point_[4 * i + 1] * pose[4 * j + 1] +
                  set_point_[4 * i + 2] * pose[4 * j + 2];
    const double e_r[3] = {0.5 * (M[2][1] - M[1][2]), 0.5 * (M[0][2] - M[2][0]),
                           0.5 * (M[1][0] - M[0][1])};
    for (int i = 0; i < 3; ++i) accel[3 + i] = kp_ * e_r[i] - kd_ * twist[3 + i];
    double out[6];
    const int rc = ${P}_inverse_dynamics(pose.data(), twist.data(), accel, out, work_.data());
    if (rc == ${PU}_OK) std::copy(out, out + 6, gamma.begin());
    return rc;
  }

  double target_z(double time) const {
    return set_point_[11] + amplitude_ * std::sin(2.0 * 3.14159265358979 * frequency_ * time);
  }

 private:
  std::vector<double> work_;
  Pose set_point_{};
  double amplitude_ = 0.002;  // [m]
  double frequency_ = 1.0;    // [Hz]
  double kp_ = 400.0;         // [1/s^2]
  double kd_ = 40.0;          // [1/s]
};

}  // namespace

int main(int argc, char** argv) {
  const int steps = argc > 1 ? std::max(1, std::atoi(argv[1])) : 1000;
  const double rate = argc > 2 ? std::max(1.0, std::atof(argv[2])) : 1000.0;
  const double dt = 1.0 / rate;
  Pose pose;
  std::copy(${P}_home_pose, ${P}_home_pose + 16, pose.begin());
  Vec6 twist{}, gamma{};
  ComputedTorqueController controller;
  controller.on_configure(pose);
  std::vector<double> plant_work(${PU}_WORK_SIZE);
  std::vector<double> update_us(static_cast<size_t>(steps));
  double worst_error = 0.0;
  int failures = 0;
  using clock = std::chrono::steady_clock;
  auto next = clock::now();
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const auto t0 = clock::now();
    const int rc = controller.update(t, dt, pose, twist, gamma);
    const auto t1 = clock::now();
    update_us[static_cast<size_t>(k)] = std::chrono::duration<double, std::micro>(t1 - t0).count();
    if (rc != ${PU}_OK) ++failures;
    // the plant: the direct dynamic model, semi-implicit Euler on SE(3)
    double accel[6];
    if (${P}_direct_dynamics(pose.data(), twist.data(), gamma.data(), accel, plant_work.data()) !=
        ${PU}_OK) {
      std::printf("the plant left the workspace at step %d\n", k);
      return 1;
    }
    for (size_t i = 0; i < 6; ++i) twist[i] += dt * accel[i];
    for (size_t i = 0; i < 3; ++i) pose[4 * i + 3] += dt * twist[i];
    const double w[3] = {dt * twist[3], dt * twist[4], dt * twist[5]};
    rotate(w, pose.data());
    worst_error = std::max(worst_error, std::fabs(pose[11] - controller.target_z(t + dt)));
    next += std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(dt));
    std::this_thread::sleep_until(next);
  }
  std::vector<double> sorted = update_us;
  std::sort(sorted.begin(), sorted.end());
  std::printf("%d steps at %g Hz: update() median %.3f us, max %.3f us; "
              "largest |z - z_d| %.3g m; %d failed calls\n",
              steps, rate, sorted[sorted.size() / 2], sorted.back(), worst_error, failures);
  return failures ? 1 : 0;
}
"""

CMAKE = r"""# The exported library of stewart-pin ${version} (export-c), its test program, its
# benchmark and the C++ control-loop example.
#   cmake -S . -B build && cmake --build build && ctest --test-dir build
cmake_minimum_required(VERSION 3.10)
project(${P} C)

if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release)
endif()

add_library(${P} ${P}.c)
set_target_properties(${P} PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF
                                        POSITION_INDEPENDENT_CODE ON)
target_include_directories(${P} PUBLIC $${CMAKE_CURRENT_SOURCE_DIR})
if(UNIX)
  target_link_libraries(${P} PUBLIC m)
endif()
# sqrt and the other math calls inline (the library never reads errno; the results are
# the same: a negative sqrt still gives NaN, which the guards catch), and the library's
# calls to its own functions direct in position-independent code (no interposition).
if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
  target_compile_options(${P} PRIVATE -fno-math-errno -fno-semantic-interposition)
endif()

add_executable(${P}_test ${P}_test.c)
target_link_libraries(${P}_test PRIVATE ${P})
set_target_properties(${P}_test PROPERTIES C_STANDARD 99 C_EXTENSIONS OFF)

add_executable(${P}_bench ${P}_bench.c)
target_link_libraries(${P}_bench PRIVATE ${P})
set_target_properties(${P}_bench PROPERTIES C_STANDARD 99 C_EXTENSIONS OFF)

# The C++ example, where a C++ compiler is found (the library itself is C only).
include(CheckLanguage)
check_language(CXX)
if(CMAKE_CXX_COMPILER)
  enable_language(CXX)
  find_package(Threads REQUIRED)
  add_executable(${P}_control_loop ${P}_control_loop.cpp)
  target_link_libraries(${P}_control_loop PRIVATE ${P} Threads::Threads)
  set_target_properties(${P}_control_loop PROPERTIES CXX_STANDARD 17 CXX_STANDARD_REQUIRED ON)
endif()

enable_testing()
add_test(NAME ${P}_test COMMAND ${P}_test)
"""

README = r"""# ${P}: the hexapod's models in standalone C99

Exported by stewart-pin ${version} (`robot.export_c(folder, prefix="${P}")` or
`stewart-pin export-c --prefix ${P} -o folder`). No CasADi, no Python, no heap
allocation, no global written: every function is reentrant, its work memory
(`${PU}_WORK_SIZE` doubles) the caller's.

| file | what |
| --- | --- |
| `${P}.h`, `${P}.c` | the library |
| `${P}_reference.h` | random states and the Python reference path's values at them |
| `${P}_test.c` | every function against them (${ref_tolerance} relative), the error codes |
| `${P}_bench.c` | the median time per call of each function |
| `${P}_control_loop.cpp` | a computed-torque loop shaped as a `ros2_control` controller (C++17) |

Build and check:

```sh
cmake -S . -B build && cmake --build build && ctest --test-dir build
./build/${P}_bench
# or without CMake
cc -std=c99 -O2 -fno-math-errno ${P}.c ${P}_test.c -lm -o ${P}_test && ./${P}_test
```

## Conventions

SI units. `pose`: 0Tp, the platform frame in the base frame F0, a row-major 4x4
homogeneous matrix (`pose[4 * i + j]`, last row `0 0 0 1`). `twist`: `[v, w]`, the
velocity of the platform origin O_p and the angular velocity, both in F0 [m/s, rad/s].
`accel`: classical `[dv/dt, dw/dt]` in F0 [m/s^2, rad/s^2]. `q_act`, `gamma`: actuator
order (leg 1 to 6): actuated joint values [m or rad] and efforts on the joint side [N or
N m]. `J_inv`: Jp^-1 row-major, `q_act_dot = J_inv twist`.
${convention_readme}
```c
int ${P}_inverse_geometry(const double pose[16], double q_act[6], double *work);
int ${P}_forward_geometry(const double q_act[6], const double pose_guess[16],
                          double pose[16], double *work);
int ${P}_inverse_jacobian(const double pose[16], double J_inv[36], double *work);
int ${P}_inverse_dynamics(const double pose[16], const double twist[6],
                          const double accel[6], double gamma[6], double *work);
int ${P}_direct_dynamics(const double pose[16], const double twist[6],
                         const double gamma[6], double accel[6], double *work);
```
${derivatives_readme}
## Error codes

Every function returns `${PU}_OK` (0) or a negative code, and on an error writes NaN to
its outputs:

- `${PU}_ERR_INPUT` (${ERR_INPUT}): a non-finite input, or a matrix that is not a pose;
- `${PU}_ERR_RANGE` (${ERR_RANGE}): out of the stroke, a joint's range or a leg's reach,
  or near a leg's serial singularity;
- `${PU}_ERR_SINGULAR` (${ERR_SINGULAR}): the condition number of Jp^-1 past
  `${PU}_MAX_CONDITION` (${max_condition}), or a mass matrix not positive definite;
- `${PU}_ERR_NO_CONVERGENCE` (${ERR_NO_CONVERGENCE}): forward geometry, not converged in
  `${PU}_FORWARD_MAX_ITERATIONS` steps;
- `${PU}_ERR_NUMERICAL` (${ERR_NUMERICAL}): finite inputs, a non-finite result.

The guards are those of stewart-pin's compiled models, with small margins: a state
within about 1e-9 (relative) of a joint limit, or 1e-6 of a leg's serial-singularity
threshold, is refused here where the Python path would decide it exactly.
${newton_readme}"""
