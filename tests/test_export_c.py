"""The standalone C export (issue 23): the exported library built with strict C99 flags,
its test program against the reference path's values (backend="pinocchio", embedded as
numbers), error codes, sanitizers, no allocation, no writable global, and the exporter's
refusals."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stewart_pin import StewartRobot
from stewart_pin._so3 import so3_exp
from stewart_pin.cli import main
from stewart_pin.codegen.c_export import file_names
from stewart_pin.exceptions import ExportError, WorkspaceError

STRICT = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
GCC = shutil.which("gcc")
pytestmark = pytest.mark.skipif(GCC is None, reason="gcc is not installed")

#: The libm functions the library may call: nothing else (no malloc, no stdio).
#: The name of the exported rus robot: it must reach no file.
NAME = "zq_robot_name"
MATH = {
    "sqrt",
    "sin",
    "cos",
    "sincos",
    "atan2",
    "fabs",
    "fmax",
    "fmin",
    "floor",
    "fmod",
    "pow",
    "exp",
}


def _run(cmd: list[str], cwd: Path, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)


def _build(folder: Path, prefix: str, program: str, out: str, *flags: str) -> Path:
    run = _run(
        [GCC, *STRICT, *flags, f"{prefix}.c", program, "-lm", "-o", out],  # type: ignore[list-item]
        folder,
    )
    assert run.returncode == 0, run.stderr
    return folder / out


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    """The 6-UPS ``simulator`` exported by the command line, ``rus`` by the facade."""
    root = tmp_path_factory.mktemp("export_c")
    out = {}
    folder = root / "ups"
    assert main(["export-c", "--preset", "simulator", "--prefix", "sim", "-o", str(folder)]) == 0
    out["simulator"] = (folder, "sim")
    folder = root / "rus"
    d = StewartRobot.from_preset("rus").to_dict()
    d["name"] = NAME
    paths = StewartRobot.from_dict(d).export_c(folder, prefix="rus6", samples=6, seed=3)
    assert [p.name for p in paths] == list(file_names("rus6"))
    out["rus"] = (folder, "rus6")
    return out


def _object(folder: Path, prefix: str, *flags: str) -> Path:
    """The exported library ``PREFIX.c`` compiled with the strict flags and ``flags`` into
    ``PREFIX.o`` in ``folder``."""
    run = _run([GCC, *STRICT, *flags, "-c", f"{prefix}.c", "-o", f"{prefix}.o"], folder)  # type: ignore[list-item]
    assert run.returncode == 0, run.stderr
    return folder / f"{prefix}.o"


def _link(folder: Path, prefix: str, program: str, out: str, *flags: str) -> Path:
    """``program`` compiled with ``flags`` and linked with the library's object
    (:func:`objects`: built once per module)."""
    run = _run(
        [GCC, *STRICT, *flags, program, f"{prefix}.o", "-lm", "-o", out],  # type: ignore[list-item]
        folder,
    )
    assert run.returncode == 0, run.stderr
    return folder / out


@pytest.fixture(scope="module")
def objects(exported: dict[str, tuple[Path, str]]) -> dict[str, Path]:
    """Each exported library compiled once with the strict flags at -O2 (``PREFIX.o`` in
    its folder): the programs of the tests below link it."""
    return {name: _object(folder, prefix, "-O2") for name, (folder, prefix) in exported.items()}


@pytest.fixture(scope="module")
def test_programs(
    exported: dict[str, tuple[Path, str]], objects: dict[str, Path]
) -> dict[str, Path]:
    return {
        name: _link(folder, prefix, f"{prefix}_test.c", "check", "-O2")
        for name, (folder, prefix) in exported.items()
    }


@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_strict_build_equals_the_reference_path(
    exported: dict[str, tuple[Path, str]], test_programs: dict[str, Path], name: str
) -> None:
    """Built with -std=c99 -Wall -Wextra -Werror -pedantic, every function equals the
    reference path (Pinocchio; the Python kinematics) to 1e-12 relative on the random
    states, and the out-of-reach / invalid poses give their error codes."""
    run = _run([str(test_programs[name])], exported[name][0])
    assert run.returncode == 0, run.stdout + run.stderr
    errors = re.findall(r"(\w+) +largest relative error (\S+)", run.stdout)
    assert len(errors) == 5
    assert all(float(e) <= 1e-12 for _, e in errors), run.stdout
    assert "passed: 0 failure(s)" in run.stdout


def test_the_test_program_can_fail(
    exported: dict[str, tuple[Path, str]], objects: dict[str, Path], tmp_path: Path
) -> None:
    """A reference value off by 1e-10 (relative) makes the test program fail."""
    folder, prefix = exported["rus"]
    copy = tmp_path / "tampered"
    shutil.copytree(folder, copy)
    ref = copy / f"{prefix}_reference.h"
    text = ref.read_text()
    head, body = text.split(f"{prefix}_ref_gamma[6][6] = {{\n  {{", 1)
    first, rest = body.split(",", 1)
    ref.write_text(
        f"{head}{prefix}_ref_gamma[6][6] = {{\n  {{{float(first) * (1 + 1e-10)!r},{rest}"
    )
    program = _link(copy, prefix, f"{prefix}_test.c", "check", "-O2")
    run = _run([str(program)], copy)
    assert run.returncode == 1
    assert "FAIL inverse_dynamics state 0" in run.stdout


def test_out_of_reach_pose_refused_by_both_paths(exported: dict[str, tuple[Path, str]]) -> None:
    """The pose the test program expects ERR_RANGE for is refused by the reference path
    too (so the error code is the reference's verdict, not an artefact of the guard)."""
    for name in ("simulator", "rus"):
        robot = StewartRobot.from_preset(name)
        folder, prefix = exported[name]
        text = (folder / f"{prefix}_reference.h").read_text()
        body = text.split(f"{prefix}_far_pose[16] = {{", 1)[1].split("}", 1)[0]
        far = np.array([float(x) for x in body.split(",")]).reshape(4, 4)
        with pytest.raises(WorkspaceError):
            robot.inverse_dynamics(far, np.zeros(6), np.zeros(6), backend="pinocchio")


def test_sanitizers(exported: dict[str, tuple[Path, str]], tmp_path: Path) -> None:
    """The test program under AddressSanitizer and UndefinedBehaviorSanitizer."""
    flags = ("-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all")
    probe = tmp_path / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    if _run([GCC, *flags, "probe.c", "-o", "probe"], tmp_path).returncode != 0:  # type: ignore[list-item]
        pytest.skip("the AddressSanitizer / UBSan runtime is not installed")
    folder, prefix = exported["rus"]
    program = _build(folder, prefix, f"{prefix}_test.c", "check_san", *flags)
    run = _run([str(program)], folder)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "runtime error" not in run.stderr


def test_no_allocation_no_stdio_no_writable_global(
    exported: dict[str, tuple[Path, str]], objects: dict[str, Path]
) -> None:
    """The library's object calls nothing but libm (no malloc, no stdio) and defines no
    writable data (no .data or .bss symbol)."""
    if shutil.which("nm") is None:
        pytest.skip("nm (binutils) is not installed")
    for name, (folder, prefix) in exported.items():
        symbols = _run(["nm", str(objects[name])], folder).stdout.split("\n")
        undefined = {s.split()[-1] for s in symbols if s.strip().startswith("U ")}
        assert undefined <= MATH, undefined - MATH
        kinds = {s.split()[-2] for s in symbols if len(s.split()) == 3}
        assert not kinds & set("BbDdCGgSs"), kinds
        assert "malloc" not in (folder / f"{prefix}.c").read_text()


HARNESS = r"""#include "PREFIX.h"
#include "PREFIX_reference.h"
int main(void) {
  double work[PU_WORK_SIZE], out[36];
  int s, bad = 0;
  for (s = 0; s < PU_REF_N; ++s) {
    bad |= PREFIX_inverse_geometry(PREFIX_poses[s], out, work);
    bad |= PREFIX_inverse_jacobian(PREFIX_poses[s], out, work);
    bad |= PREFIX_forward_geometry(PREFIX_ref_q[s], PREFIX_guesses[s], out, work);
    bad |= PREFIX_inverse_dynamics(PREFIX_poses[s], PREFIX_twists[s], PREFIX_accels[s], out,
                                   work);
    bad |= PREFIX_direct_dynamics(PREFIX_poses[s], PREFIX_twists[s], PREFIX_gammas_in[s], out,
                                  work);
  }
  return bad ? 1 : 0;
}
"""


def test_no_heap_allocation_at_run_time(
    exported: dict[str, tuple[Path, str]], objects: dict[str, Path]
) -> None:
    """Every function run under valgrind by a program without stdio: no heap block."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed")
    folder, prefix = exported["simulator"]
    harness = HARNESS.replace("PREFIX", prefix).replace("PU_", prefix.upper() + "_")
    (folder / "harness.c").write_text(harness)
    try:
        program = _link(folder, prefix, "harness.c", "harness", "-O2")
        run = _run(["valgrind", "--error-exitcode=3", str(program)], folder)
    finally:
        (folder / "harness.c").unlink()
    assert run.returncode == 0, run.stderr
    assert "total heap usage: 0 allocs" in run.stderr, run.stderr


def test_control_loop_example(
    exported: dict[str, tuple[Path, str]], objects: dict[str, Path]
) -> None:
    """The C++17 control-loop example builds and tracks its trajectory (50 steps)."""
    gxx = shutil.which("g++")
    if gxx is None:
        pytest.skip("g++ is not installed")
    folder, prefix = exported["simulator"]
    run = _run(
        [
            gxx,
            "-std=c++17",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            f"{prefix}_control_loop.cpp",
            str(objects["simulator"]),
            "-lm",
            "-o",
            "loop",
        ],
        folder,
    )
    assert run.returncode == 0, run.stderr
    run = _run(["./loop", "50"], folder)
    assert run.returncode == 0, run.stdout
    assert re.search(r"update\(\) median [\d.]+ us", run.stdout)
    assert "0 failed calls" in run.stdout


# ---------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    "prefix", ["", "1abc", "a-b", "a b", "x;system", "_x", "é", "a" * 41, "a\nb", None]
)
def test_prefix_not_a_c_identifier(tmp_path: Path, prefix: object) -> None:
    robot = StewartRobot.from_preset("simulator")
    with pytest.raises(ExportError, match="C identifier"):
        robot.export_c(tmp_path / "out", prefix=prefix)  # type: ignore[arg-type]
    assert not (tmp_path / "out").exists()


def test_folder_with_other_files(tmp_path: Path) -> None:
    robot = StewartRobot.from_preset("simulator")
    (tmp_path / "mine.txt").write_text("keep")
    with pytest.raises(ExportError, match="other files"):
        robot.export_c(tmp_path, prefix="sim")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(ExportError, match="not a folder"):
        robot.export_c(tmp_path / "file", prefix="sim")


def test_cli_refusals_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export-c", "--prefix", "no-no", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "C identifier" in err
    (tmp_path / "y").mkdir()
    (tmp_path / "y" / "other.c").write_text("")
    assert main(["export-c", "--prefix", "ok", "-o", str(tmp_path / "y")]) == 2
    assert "other files" in capsys.readouterr().err


U_JOINT_HARNESS = r"""#include <stdio.h>
#include "PREFIX.h"
static const double poses[NSTATES][16] = {POSES};
int main(void) {
  double work[PU_WORK_SIZE], out[6], zero[6] = {0, 0, 0, 0, 0, 0};
  int s;
  for (s = 0; s < NSTATES; ++s) {
    int a = PREFIX_inverse_geometry(poses[s], out, work);
    int b = PREFIX_inverse_dynamics(poses[s], zero, zero, out, work);
    int c = PREFIX_direct_dynamics(poses[s], zero, zero, out, work);
    printf("%d %d %d\n", a, b, c);
  }
  return 0;
}
"""


def test_u_joint_limits_exported_decide_as_the_reference(tmp_path: Path) -> None:
    """The ideal 6-UPS with U-joint limits exports (issue 19): its C refuses with ERR_RANGE
    (-2) exactly the poses whose U-joint angles the reference path (Pinocchio) refuses
    with a JointLimitError, and computes the others; limits cut through the sampled
    angles of q1 of leg 2 and q2 of leg 5 (both angles checked)."""
    from stewart_pin.exceptions import JointLimitError

    base = StewartRobot.from_preset("simulator")
    poses = base.sample_poses(16, np.random.default_rng(11), rotation=0.3)
    q = np.asarray(base.inverse_geometry(poses))[..., :2]  # (16, 6, 2) [rad]
    limits = np.stack([q.min(axis=0) - 0.05, q.max(axis=0) + 0.05], -1)  # (6, 2, 2)
    limits[1, 0, 1] = np.quantile(q[:, 1, 0], 0.7)  # upper limit of q1 of leg 2
    limits[4, 1, 0] = np.quantile(q[:, 4, 1], 0.3)  # lower limit of q2 of leg 5
    robot = StewartRobot(base.description.replace(u_joint_limits=limits))
    refused = []
    for T in poses:
        try:
            robot.inverse_dynamics(T, np.zeros(6), np.zeros(6), backend="pinocchio")
            refused.append(False)
        except JointLimitError:
            refused.append(True)
    assert 4 <= sum(refused) <= 12  # both decisions met
    robot.export_c(tmp_path, prefix="uj", samples=2)
    rows = ", ".join("{" + ", ".join(repr(float(x)) for x in T.ravel()) + "}" for T in poses)
    harness = U_JOINT_HARNESS.replace("PREFIX", "uj").replace("PU_", "UJ_")
    (tmp_path / "harness.c").write_text(harness.replace("NSTATES", "16").replace("POSES", rows))
    program = _build(tmp_path, "uj", "harness.c", "harness", "-O0")
    out = _run([str(program)], tmp_path).stdout
    codes = [tuple(map(int, line.split())) for line in out.split("\n") if line]
    assert codes == [(-2, -2, -2) if r else (0, 0, 0) for r in refused]


def test_only_numbers_from_the_description(exported: dict[str, tuple[Path, str]]) -> None:
    """The robot's name reaches no exported file (only numbers and the prefix do)."""
    folder, _ = exported["rus"]
    texts = [p.read_text() for p in folder.iterdir() if p.suffix in (".c", ".h", ".cpp", ".md")]
    assert len(texts) == 7
    assert not any(NAME in text for text in texts)


def test_derivatives(tmp_path: Path) -> None:
    """``--derivatives``: ``PREFIX_inverse_dynamics_derivatives`` equals its embedded
    reference to 1e-12, and that reference is checked here against central differences
    of the Pinocchio reference path (the pose perturbed in the chart p + dp,
    R <- exp(dtheta^) R)."""
    import pinocchio as pin

    robot = StewartRobot.from_preset("simulator")
    folder = tmp_path / "d"
    argv = ["export-c", "--prefix", "sd", "-o", str(folder), "--samples", "2", "--derivatives"]
    assert main(argv) == 0
    assert "sd_inverse_dynamics_derivatives" in (folder / "sd.h").read_text()
    program = _build(folder, "sd", "sd_test.c", "check", "-O1")
    run = _run([str(program)], folder)
    assert run.returncode == 0, run.stdout
    assert re.search(r"derivatives +largest relative error", run.stdout)
    from stewart_pin.codegen.c_export import reference_values

    values = reference_values(robot, 2, 0, derivatives=True)
    T = values["poses"][0].reshape(4, 4)
    V, A = values["twists"][0], values["accels"][0]
    D = values["ref_didm"][0].reshape(3, 6, 6)

    def idm(T: np.ndarray, V: np.ndarray, A: np.ndarray) -> np.ndarray:
        return np.asarray(robot.inverse_dynamics(T, V, A, backend="pinocchio"))

    h = 1e-6
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        moved = []
        for sign in (1.0, -1.0):
            Tm = T.copy()
            Tm[:3, 3] += sign * e[:3]
            Tm[:3, :3] = pin.exp3(sign * e[3:]) @ T[:3, :3]
            moved.append(idm(Tm, V, A))
        columns = (
            (moved[0] - moved[1]) / (2 * h),
            (idm(T, V + e, A) - idm(T, V - e, A)) / (2 * h),
            (idm(T, V, A + e) - idm(T, V, A - e)) / (2 * h),
        )
        for b, column in enumerate(columns):
            scale = np.abs(D[b]).max()
            np.testing.assert_allclose(D[b][:, j], column, atol=1e-6 * scale, rtol=0)


@pytest.mark.parametrize("preset", ["paper", "ups-offset", "pus", "random-custom-3"])
def test_every_architecture_exports(tmp_path: Path, preset: str) -> None:
    """The other leg architectures (a custom leg's Newton steps included): the strict
    build (-O0, quick to compile) equals the reference path to 1e-12 on their states."""
    robot = StewartRobot.from_preset(preset)
    robot.export_c(tmp_path, prefix="arch", samples=3, seed=1)
    program = _build(tmp_path, "arch", "arch_test.c", "check", "-O0")
    run = _run([str(program)], tmp_path)
    assert run.returncode == 0, run.stdout
    assert "passed: 0 failure(s)" in run.stdout


def test_benchmark_program(exported: dict[str, tuple[Path, str]]) -> None:
    """The benchmark builds with the strict flags and prints a median time per call of
    each function (a few calls: what it measures is not checked here)."""
    folder, prefix = exported["rus"]
    program = _build(folder, prefix, f"{prefix}_bench.c", "bench", "-O0")
    run = _run([str(program), "3"], folder)
    assert run.returncode == 0, run.stdout
    names = re.findall(r"^(\w+) +[\d.]+ us$", run.stdout, re.M)
    assert names == [
        "inverse_geometry",
        "inverse_jacobian",
        "forward_geometry",
        "inverse_dynamics",
        "direct_dynamics",
    ]


SINGULAR_HARNESS = r"""#include <stdio.h>
#include "PREFIX.h"
static const double poses[NSTATES][16] = {POSES};
int main(void) {
  double work[PU_WORK_SIZE], out[6], zero[6] = {0, 0, 0, 0, 0, 0};
  int s;
  for (s = 0; s < NSTATES; ++s) {
    int a = PREFIX_inverse_dynamics(poses[s], zero, zero, out, work);
    int b = PREFIX_direct_dynamics(poses[s], zero, zero, out, work);
    printf("%d %d\n", a, b);
  }
  return 0;
}
"""


def test_singular_code_where_the_reference_refuses(tmp_path: Path) -> None:
    """A robot whose max_condition lies amid its poses' condition numbers: the C returns
    ERR_SINGULAR (-3) exactly for the poses the reference path refuses with a
    SingularityError (the cheap bounds flag more poses: the exact measure decides)."""
    from stewart_pin.codegen.compiled import singularity_length
    from stewart_pin.exceptions import SingularityError

    base = StewartRobot.from_preset("simulator")
    poses = base.sample_poses(12, np.random.default_rng(5), rotation=0.6)
    cond = np.asarray(base.condition_number(poses))
    limit = float(np.sort(cond)[5] + np.sort(cond)[6]) / 2
    robot = StewartRobot(base.description, max_condition=limit)
    robot.export_c(tmp_path, prefix="sg", samples=2)
    rows = ", ".join("{" + ", ".join(repr(float(x)) for x in T.ravel()) + "}" for T in poses)
    harness = SINGULAR_HARNESS.replace("PREFIX", "sg").replace("PU_", "SG_")
    (tmp_path / "harness.c").write_text(harness.replace("NSTATES", "12").replace("POSES", rows))
    program = _build(tmp_path, "sg", "harness.c", "harness", "-O0")
    codes = [
        tuple(map(int, line.split()))
        for line in _run([str(program)], tmp_path).stdout.split("\n")
        if line
    ]
    refused = []
    for T in poses:
        try:
            robot.inverse_dynamics(T, np.zeros(6), np.zeros(6), backend="pinocchio")
            refused.append(False)
        except SingularityError:
            refused.append(True)
    assert sum(refused) == 6
    # the accepted poses pass the Frobenius bound ||S||_F ||S^-1||_F: the C's exact
    # 2-norm measure (Jacobi) accepts them, not the cheap bounds
    S = np.asarray(base.inverse_jacobian(poses))
    S[:, :, 3:] /= singularity_length(base.description)
    bound = np.linalg.norm(S, axis=(1, 2)) * np.linalg.norm(np.linalg.inv(S), axis=(1, 2))
    assert np.all(bound[~np.array(refused)] > limit)
    assert [c == (-3, -3) for c in codes] == refused
    assert all(c in ((0, 0), (-3, -3)) for c in codes)


@pytest.mark.parametrize("seed", ["x", -1, 1.5, True])
def test_a_bad_seed_is_an_export_error(tmp_path, seed):
    """``int(seed)`` gave a ValueError for "x" and cut 1.5 to 1 silently."""
    with pytest.raises(ExportError, match="seed"):
        StewartRobot.from_preset("desktop").export_c(tmp_path / "out", prefix="hexa", seed=seed)


def test_the_c_forward_geometry_stops_as_the_python_one():
    """The exported Newton's tolerance and step budget are the Python path's (the C
    and the reference forward geometry stop at the same residual)."""
    from stewart_pin.codegen import c_export
    from stewart_pin.kinematics import leg_chains

    assert c_export.FORWARD_TOLERANCE == leg_chains.FORWARD_TOLERANCE
    assert c_export.FORWARD_MAX_ITERATIONS == leg_chains.FORWARD_MAX_ITERATIONS


# ---------------------------------------------------------------------------- chain legs
def _rus_as_chain_legs() -> StewartRobot:
    """The ``rus`` preset with its legs written as chain legs (crank, U-joint, ball): a
    revolute actuated joint on the chain-leg path."""
    from stewart_pin.description import RobotDescription
    from stewart_pin.description.chain_leg import ChainLeg

    b = StewartRobot.from_preset("rus").description
    assert b.legs is not None
    legs = tuple(
        ChainLeg(
            tuple(leg.joints),
            leg.actuated,
            "ball",
            np.asarray(b.leg_inertia[k]),
            np.asarray(leg.tip),
            guess=np.asarray(leg.guess),
        )
        for k, leg in enumerate(b.legs)
    )
    desc = RobotDescription(
        base_points=b.base_points,
        platform_points=b.platform_points,
        leg_base_rotations=b.leg_base_rotations,
        stroke=None,
        leg_inertia=np.zeros((6, 3, 10)),
        platform_inertia=b.platform_inertia,
        gravity=b.gravity,
        name="rus-chain",
        home_pose=b.home_pose,
        chain_legs=legs,
    )
    return StewartRobot(desc)


def _chain_robot(name: str) -> StewartRobot:
    from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups

    if name == "welded-ups":
        return StewartRobot(welded_ups())
    if name == "mixed-chain":
        return StewartRobot(mixed_chain_robot(seed=2))
    return _rus_as_chain_legs()


CHAIN_ROBOTS = ("welded-ups", "mixed-chain", "rus-chain")


@pytest.fixture(scope="module")
def chain_exported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, Path]]:
    """Robots with chain legs exported (3 states each; the welded one by the command line
    from a description file), each library compiled with the strict flags at -O0 (the
    welded legs' Newton steps make a 1 MB source) into ``cl.o``, and their test programs
    linked with it."""
    root = tmp_path_factory.mktemp("export_c_chain")
    out = {}
    for name in CHAIN_ROBOTS:
        folder = root / name
        if name == "welded-ups":
            path = _chain_robot(name).write(root / "welded.json")
            argv = ["--description", str(path), "--prefix", "cl", "--samples", "3"]
            assert main(["export-c", *argv, "-o", str(folder)]) == 0
        else:
            _chain_robot(name).export_c(folder, prefix="cl", samples=3, seed=1)
        _object(folder, "cl", "-O0")
        out[name] = (folder, _link(folder, "cl", "cl_test.c", "check", "-O0"))
    return out


@pytest.mark.parametrize("name", CHAIN_ROBOTS)
def test_chain_legs_export_equals_the_reference_path(
    chain_exported: dict[str, tuple[Path, Path]], name: str
) -> None:
    """Chain legs (issue 20): the welded 6-UPS (six joints, weld closures), the mixed robot
    (ball and weld legs) and the rus legs as chain legs (a revolute actuated joint: the
    forward geometry's wrapped error) export; their strict build equals the reference path
    (Pinocchio on each leg's chain, the reference's Newton) on the random states to the
    header's tolerance (1e-10, the Newton legs' CUSTOM_TOLERANCE: the reference stops at
    1e-13 m, the C runs its 7 steps out; measured about 3e-14), and the out-of-reach and
    invalid poses give their error codes."""
    folder, program = chain_exported[name]
    assert "#define CL_REF_TOLERANCE 1e-10" in (folder / "cl_reference.h").read_text()
    readme = (folder / "README.md").read_text()
    assert "(1e-10 relative)" in readme and "fixed number of guarded Newton steps" in readme
    run = _run([str(program)], folder)
    assert run.returncode == 0, run.stdout + run.stderr
    errors = re.findall(r"(\w+) +largest relative error (\S+)", run.stdout)
    assert len(errors) == 5
    assert all(float(e) <= 1e-10 for _, e in errors), run.stdout
    assert "passed: 0 failure(s)" in run.stdout
    # the pose the program expects ERR_RANGE for is refused by the reference path too
    text = (folder / "cl_reference.h").read_text()
    body = text.split("cl_far_pose[16] = {", 1)[1].split("}", 1)[0]
    far = np.array([float(x) for x in body.split(",")]).reshape(4, 4)
    with pytest.raises(WorkspaceError):
        _chain_robot(name).inverse_dynamics(far, np.zeros(6), np.zeros(6), backend="pinocchio")


def test_chain_legs_library_calls_only_libm(chain_exported: dict[str, tuple[Path, Path]]) -> None:
    """The welded robot's library (its legs' Newton steps are static functions of their
    own): nothing but libm called, no writable data, every external symbol prefixed."""
    if shutil.which("nm") is None:
        pytest.skip("nm (binutils) is not installed")
    folder, _ = chain_exported["welded-ups"]
    symbols = [s.split() for s in _run(["nm", "cl.o"], folder).stdout.split("\n") if s.strip()]
    undefined = {s[-1] for s in symbols if s[0] == "U"}
    assert undefined <= MATH, undefined - MATH
    assert not {s[-2] for s in symbols if len(s) == 3} & set("BbDdCGgSs")
    assert all(s[-1].startswith("cl_") for s in symbols if len(s) == 3 and s[-2] == "T")


def test_rus_as_chain_legs_is_the_rus_robot() -> None:
    """The reference values embedded for the rus-as-chain-legs robot are those of the rus
    robot's own (three-joint leg) models, a different code path: the chain-leg export's
    revolute case is checked against an independent model (1e-12 relative)."""
    from stewart_pin.codegen.c_export import reference_values

    chain = reference_values(_rus_as_chain_legs(), 3, 1)
    rus = reference_values(StewartRobot.from_preset("rus"), 3, 1)
    assert np.array_equal(chain["poses"], rus["poses"])
    for key in ("ref_q", "ref_jinv", "ref_gamma", "ref_accel", "ref_pose"):
        scale = np.abs(rus[key]).max()
        assert np.abs(chain[key] - rus[key]).max() <= 1e-12 * scale, key


CHAIN_HARNESS = r"""#include <math.h>
#include <stdio.h>
#include "PREFIX.h"
static const double poses[NSTATES][16] = {POSES};
int main(void) {
  double work[PU_WORK_SIZE], out[6], zero[6] = {0, 0, 0, 0, 0, 0};
  int s;
  for (s = 0; s < NSTATES; ++s) {
    int a = PREFIX_inverse_geometry(poses[s], out, work);
    int b = PREFIX_inverse_dynamics(poses[s], zero, zero, out, work);
    int c = PREFIX_direct_dynamics(poses[s], zero, zero, out, work);
    printf("%d %d %d %d\n", a, b, c, isnan(out[0]) ? 1 : 0);
  }
  return 0;
}
"""


def test_chain_leg_guard_decides_as_the_compiled_path(tmp_path: Path) -> None:
    """The exported guard of chain legs (issue 20): on the welded 6-UPS with a passive
    joint's limits (leg 2, joint 5) cutting through the sampled poses, the C refuses with
    ERR_RANGE (-2, NaN outputs) exactly the poses the reference path refuses with a
    LegJointLimitError and computes the others; a reachable pose the legs' 7 Newton steps
    from home do not solve (the compiled guard flags it, the reference's continuation
    solves it) is ERR_RANGE too: the C never returns a number it cannot vouch for."""
    from stewart_pin.description.chain_leg_presets import welded_ups
    from stewart_pin.exceptions import LegJointLimitError
    from stewart_pin.kinematics import chain_legs

    base = welded_ups()
    poses = StewartRobot(base).sample_poses(16, np.random.default_rng(11))
    q5 = chain_legs.inverse_geometry(base, poses, check_limits=False)[1][:, 4]
    home = chain_legs.home_configuration(base)[1][4]
    legs = list(base.chain_legs or ())
    joints = list(legs[1].joints)
    s = np.sort(q5)  # a limit midway between two sampled values (home inside)
    if home < np.median(q5):
        joints[4] = replace(joints[4], lower=-math.pi, upper=float(s[9] + s[10]) / 2)
    else:
        joints[4] = replace(joints[4], lower=float(s[5] + s[6]) / 2, upper=math.pi)
    legs[1] = legs[1].replace(joints=tuple(joints))
    robot = StewartRobot(base.replace(chain_legs=tuple(legs)))
    refused = []
    for T in poses:
        try:
            robot.inverse_dynamics(T, np.zeros(6), np.zeros(6), backend="pinocchio")
            refused.append(False)
        except LegJointLimitError:
            refused.append(True)
    assert 4 <= sum(refused) <= 12  # both decisions met
    # the compiled test's pose: reachable, not solved by the Newton steps from home
    H = base.home_pose
    size = chain_legs.robot_size(base)
    far = H.copy()
    far[:3, 3] += np.array([1.05, -0.9, 0.45]) * size
    far[:3, :3] = so3_exp(np.array([[0.75, -0.9, 1.05]]))[0] @ H[:3, :3]
    ref = StewartRobot(base).inverse_dynamics(far, np.zeros(6), np.zeros(6), backend="pinocchio")
    assert np.all(np.isfinite(ref))
    robot.export_c(tmp_path, prefix="cg", samples=1)
    rows = ", ".join(
        "{" + ", ".join(repr(float(x)) for x in T.ravel()) + "}" for T in [*poses, far]
    )
    harness = CHAIN_HARNESS.replace("PREFIX", "cg").replace("PU_", "CG_")
    (tmp_path / "harness.c").write_text(harness.replace("NSTATES", "17").replace("POSES", rows))
    program = _build(tmp_path, "cg", "harness.c", "harness", "-O0")
    out = _run([str(program)], tmp_path).stdout
    codes = [tuple(map(int, line.split())) for line in out.split("\n") if line]
    assert codes == [(-2, -2, -2, 1) if r else (0, 0, 0, 0) for r in [*refused, True]]


def test_chain_legs_with_an_idle_joint_are_refused_before_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An R-S-S leg's idle spin (its state is not an input of the exported functions):
    an ExportError naming the leg and the reason, and nothing written."""
    from stewart_pin.description.chain_leg_presets import rss_robot

    with pytest.raises(ExportError, match=r"leg 1 has an idle joint \(joint 4.*spin state"):
        StewartRobot(rss_robot(symmetric=False)).export_c(tmp_path / "out", prefix="rss")
    assert not (tmp_path / "out").exists()
    # the command line (a description file): one line, exit code 2
    path = StewartRobot(rss_robot()).write(tmp_path / "rss.json")
    argv = ["export-c", "--description", str(path), "--prefix", "rss", "-o", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "idle joint" in err
    assert not (tmp_path / "o").exists()
