"""``backend="auto"``, the new default of the dynamic models (issue 14, item 1): the
compiled models where a C compiler is available, built on first use (one line on stderr)
and cached; else the reference path with one warning. The first build, the cache hit (in
this process and in a new one), the fallbacks (no compiler, a failing compiler, an unsafe
cache), ``$STEWART_PIN_BACKEND``, and who takes the default (simulate, the controller,
identification, the CLI).

The suite sets ``STEWART_PIN_BACKEND=pinocchio`` (conftest.py); the ``auto`` fixture
undoes it, as a user's environment has it, with a fresh private cache."""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.cli import main
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.compiled import BACKEND_ENV, CACHE_ENV, auto_backend
from stewart_pin.dynamics.leg_chain_dynamics import GeneralInverseDynamics
from stewart_pin.exceptions import InputError
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.simulation import simulate
from stewart_pin.parameters.identification import simulate_measurements

TOL = 1e-12
SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.fixture
def auto(monkeypatch, tmp_path) -> Path:
    """``backend="auto"`` as a user gets it: ``$STEWART_PIN_BACKEND`` unset, a fresh
    private cache (returned), the once-per-process warnings forgotten."""
    monkeypatch.delenv(BACKEND_ENV, raising=False)
    cache = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(cache))
    monkeypatch.setattr(compiled_module, "_WARNED_AUTO", set())
    return cache


def _states(robot: StewartRobot, n: int = 20):
    return robot.sample_states(n, 4)


def _compiling_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if "compiling the dynamic models" in line]


@pytest.mark.parametrize("name", ["pus", "desktop"])
def test_auto_is_the_default_and_builds_on_first_use(name, auto, capsys):
    """The first call compiles (one line on stderr saying so and about how long), the
    result is the reference's; later calls, and another robot of the same geometry, use
    the library (no line)."""
    robot = StewartRobot.from_preset(name)
    P, V, A = _states(robot)
    capsys.readouterr()
    G = robot.inverse_dynamics(P, V, A)
    lines = _compiling_lines(capsys.readouterr().err)
    assert len(lines) == 1, lines
    assert f"'{name}'" in lines[0] and " s; cached in " in lines[0] and str(auto) in lines[0]
    fast = auto_backend(robot)
    assert fast is not None and fast.kind == "compiled" and fast.compiled_now
    assert rel_error(G, robot.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL
    acc = robot.direct_dynamics(P, V, G)
    assert rel_error(acc, robot.direct_dynamics(P, V, G, backend="pinocchio")) < 1e-10
    g1 = robot.inverse_dynamics(P[0], V[0], A[0])
    assert g1.shape == (6,) and rel_error(g1, G[0]) < TOL
    again = StewartRobot.from_preset(name)
    again.inverse_dynamics(P, V, A)
    assert not _compiling_lines(capsys.readouterr().err)
    hit = auto_backend(again)
    assert hit is not None and not hit.compiled_now and hit.library == fast.library


def test_cache_hit_in_a_new_process(auto, capsys):
    """A new process finds the verified library: no build, no line on stderr."""
    robot = StewartRobot.from_preset("pus")
    robot.inverse_dynamics(*(x[0] for x in _states(robot)))
    assert len(_compiling_lines(capsys.readouterr().err)) == 1
    code = (
        "from stewart_pin import StewartRobot\n"
        "from stewart_pin.codegen.compiled import auto_backend\n"
        "r = StewartRobot.from_preset('pus')\n"
        "T, V, A = (x[0] for x in r.sample_states(1, 4))\n"
        "r.inverse_dynamics(T, V, A)\n"
        "b = auto_backend(r)\n"
        "print(b.kind, b.compiled_now)\n"
    )
    env = {**os.environ, "PYTHONPATH": SRC, CACHE_ENV: str(auto)}
    env.pop(BACKEND_ENV, None)
    run = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["compiled", "False"]
    assert not _compiling_lines(run.stderr)


def test_without_a_compiler_auto_takes_the_reference_with_one_warning(auto, monkeypatch, tmp_path):
    """``$CC`` naming a missing program and no cc, gcc or clang on the PATH: the reference
    path (the very same numbers), one warning for the process, nothing built."""
    empty = tmp_path / "bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    monkeypatch.setenv("CC", str(tmp_path / "missing-cc"))
    assert compiled_module.find_compiler() is None
    robot = StewartRobot.from_preset("rus")
    P, V, A = _states(robot)
    with pytest.warns(RuntimeWarning, match=r"reference path .*no C compiler found"):
        G = robot.inverse_dynamics(P, V, A)
    np.testing.assert_array_equal(G, robot.inverse_dynamics(P, V, A, backend="pinocchio"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per process: no second warning
        other = StewartRobot.from_preset("pus")
        Po, Vo, Ao = _states(other, 3)
        np.testing.assert_array_equal(
            other.direct_dynamics(Po, Vo, Ao), other.direct_dynamics(Po, Vo, Ao, "pinocchio")
        )
    assert auto_backend(robot) is None and not auto.exists()


def test_a_failing_compiler_falls_back(auto, monkeypatch, tmp_path):
    """A compiler that fails: ``auto`` warns and takes the reference path;
    ``backend="compiled"`` keeps its own fallback, CasADi's virtual machine."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "broken-cc"
    fake.write_text("#!/bin/sh\necho 'broken-cc: cannot compile' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    monkeypatch.setattr(compiled_module, "_WARNED", set())
    robot = StewartRobot.from_preset("pus")
    P, V, A = _states(robot, 5)
    with pytest.warns(RuntimeWarning, match=r"reference path .*broken-cc failed"):
        G = robot.inverse_dynamics(P, V, A)
    np.testing.assert_array_equal(G, robot.inverse_dynamics(P, V, A, backend="pinocchio"))
    assert auto_backend(robot) is None
    with pytest.warns(RuntimeWarning, match="virtual machine"):
        g = StewartRobot.from_preset("pus").inverse_dynamics(P, V, A, backend="compiled")
    assert rel_error(g, G) < TOL


def test_an_unsafe_cache_is_not_loaded_by_auto(auto):
    """A cache folder others can write: ``auto`` loads nothing from it, warns and takes
    the reference path (``backend="compiled"`` raises UnsafeCacheError:
    test_codegen_cache.py)."""
    auto.mkdir(mode=0o700)
    os.chmod(auto, 0o777)
    robot = StewartRobot.from_preset("pus")
    P, V, A = _states(robot, 3)
    with pytest.warns(RuntimeWarning, match=r"reference path .*writable by group or others"):
        G = robot.inverse_dynamics(P, V, A)
    np.testing.assert_array_equal(G, robot.inverse_dynamics(P, V, A, backend="pinocchio"))
    assert list(auto.iterdir()) == []


def test_environment_makes_auto_the_reference(monkeypatch, capsys, tmp_path):
    """``STEWART_PIN_BACKEND=pinocchio``: nothing compiled, the reference's numbers;
    another value is refused, naming the variable."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setenv(BACKEND_ENV, "pinocchio")
    robot = StewartRobot.from_preset("pus")
    P, V, A = _states(robot, 3)
    capsys.readouterr()
    np.testing.assert_array_equal(
        robot.inverse_dynamics(P, V, A), robot.inverse_dynamics(P, V, A, backend="pinocchio")
    )
    assert auto_backend(robot) is None and not capsys.readouterr().err
    monkeypatch.setenv(BACKEND_ENV, "fast")
    with pytest.raises(InputError, match=BACKEND_ENV):
        StewartRobot.from_preset("pus").inverse_dynamics(P, V, A)


def test_what_compiled_models_cannot_serve_takes_the_reference_silently(auto, capsys):
    """``details=True`` with the default backend: the reference's result object, no
    build and no warning (the compiled models return Gamma only); ``motor=True`` is
    served compiled (the transmission ratios)."""
    robot = StewartRobot.from_preset("rus")
    P, V, A = _states(robot, 5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = robot.inverse_dynamics(P, V, A, details=True)
    assert isinstance(r, GeneralInverseDynamics)
    assert not _compiling_lines(capsys.readouterr().err) and not auto.exists()
    motor = robot.inverse_dynamics(P, V, A, motor=True)
    assert len(_compiling_lines(capsys.readouterr().err)) == 1
    assert rel_error(motor, r.motor) < TOL
    with pytest.raises(InputError, match="details=True needs backend='pinocchio'"):
        robot.inverse_dynamics(P, V, A, details=True, backend="compiled")


def test_simulate_the_controller_identification_and_the_cli_take_auto(auto, capsys, tmp_path):
    """Every caller of the dynamic models defaults to ``auto``."""
    for fn in (simulate, ComputedTorqueController, StewartRobot.inverse_dynamics):
        assert inspect.signature(fn).parameters["backend"].default == "auto"
    assert inspect.signature(StewartRobot.direct_dynamics).parameters["backend"].default == "auto"
    robot = StewartRobot.from_preset("desktop")
    capsys.readouterr()
    result = simulate(robot, 0.005)
    assert len(_compiling_lines(capsys.readouterr().err)) == 1
    assert auto_backend(robot) is not None and result.t[-1] == pytest.approx(0.005)
    traj_robot = StewartRobot.from_preset("desktop")
    P, V, A = _states(traj_robot, 4)
    from stewart_pin.motion.trajectories import Trajectory

    m = simulate_measurements(traj_robot, Trajectory(np.arange(4) * 0.01, P, V, A))
    assert auto_backend(traj_robot) is not None  # identification's forces, compiled
    assert rel_error(m.gammas, traj_robot.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL
    out = tmp_path / "sim.npz"
    argv = ["simulate", "--preset", "pus", "--duration", "0.01", "--no-progress", "-o", str(out)]
    assert main(argv) == 0
    assert len(_compiling_lines(capsys.readouterr().err)) == 1  # pus: built here, on first use


def test_a_robot_keeps_its_backend_and_is_still_pickled_and_freed(
    auto, monkeypatch, shared_compile_cache
):
    """The compiled backend lives on its robot: a pickled robot leaves it out (and finds
    the library again), a dropped robot is freed with it (no process-wide registry keeps
    it alive). (No first build under test here: the session's shared cache.)"""
    import gc
    import pickle
    import weakref

    monkeypatch.setenv(CACHE_ENV, str(shared_compile_cache))
    robot = StewartRobot.from_preset("pus")
    P, V, A = _states(robot, 3)
    G = robot.inverse_dynamics(P, V, A)
    assert auto_backend(robot) is not None
    copy = pickle.loads(pickle.dumps(robot))
    np.testing.assert_array_equal(copy.inverse_dynamics(P, V, A), G)
    assert auto_backend(copy) is not auto_backend(robot)
    gone = weakref.ref(robot)
    del robot
    gc.collect()
    assert gone() is None
