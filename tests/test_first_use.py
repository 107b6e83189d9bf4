"""First use and start-up (issue 24, items 3-5): the vectorised rotation logarithm the
chain-leg sampling relies on, and a new process's first call on a cached robot importing
no more than it needs. The times are measured by ``scripts/bench_*.py``, not here."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import stewart_pin
from stewart_pin._so3 import so3_log


def _rotation_vectors(angles: list[float], per: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(len(angles) * per, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    return axes * np.repeat(angles, per)[:, None]


@pytest.mark.parametrize(
    "angle", [0.0, 1e-12, 1e-8, 1e-4, 0.3, 1.0, 1.9, 2.1, 3.0, np.pi - 1e-4, np.pi - 1e-9]
)
def test_so3_log_inverts_pinocchio_exp3(angle):
    """``so3_log(exp3(w)) = w`` for angles in [0, pi) (Pinocchio's exponential the
    reference), to 1e-15 absolute plus 1e-13 relative; the largest error of
    ``pin.log3`` itself on these is about 1e-11 near pi."""
    w = _rotation_vectors([angle], 50)
    R = np.array([pin.exp3(x) for x in w])
    got = so3_log(R)
    assert got.shape == (50, 3)
    assert np.max(np.abs(got - w)) <= 1e-15 + 1e-13 * angle


def test_so3_log_at_half_a_turn_is_a_rotation_by_pi():
    """At exactly pi (the sign of the axis is free) the result is a rotation vector of
    length pi whose exponential is R (1e-15)."""
    w = _rotation_vectors([np.pi], 20, seed=1)
    R = np.array([pin.exp3(x) for x in w])
    got = so3_log(R)
    assert np.allclose(np.linalg.norm(got, axis=1), np.pi, rtol=0, atol=1e-15)
    back = np.array([pin.exp3(x) for x in got])
    assert np.max(np.abs(back - R)) <= 1e-15
    # and the single-matrix form
    assert so3_log(R[0]).shape == (1, 3)


# ---------------------------------------------------------------------------- start-up
CACHED_CALL = """
import sys
import numpy as np
import stewart_pin
robot = stewart_pin.StewartRobot.from_preset({name!r})
gamma = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6))
backend = robot._stewart_pin_auto_backend[1]
heavy = "casadi" in sys.modules or "pinocchio" in sys.modules
print(backend.kind, backend.compiled_now, heavy, gamma.tolist())
"""


@pytest.mark.skipif(
    __import__("stewart_pin.codegen.compiled", fromlist=["find_compiler"]).find_compiler() is None,
    reason="no C compiler on this machine",
)
def test_a_cached_robot_answers_without_importing_casadi_or_pinocchio(tmp_path):
    """A new process whose robot's library is in the cache answers the inverse model
    without importing CasADi or Pinocchio (the process that compiled it imported CasADi);
    the value is the reference path's (Pinocchio, 1e-9 relative)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([src, *sys.path]),
        "STEWART_PIN_CACHE": str(tmp_path / "cache"),
        "STEWART_PIN_BACKEND": "auto",
    }

    def run() -> list[str]:
        code = CACHED_CALL.format(name="simulator")
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
        )
        assert out.returncode == 0, out.stderr
        return out.stdout.split(maxsplit=3)

    assert run()[:3] == ["compiled", "True", "True"]  # compiled here: CasADi wrote the C
    kind, compiled_now, heavy, gamma = run()
    assert (kind, compiled_now, heavy) == ("compiled", "False", "False")
    robot = stewart_pin.StewartRobot.from_preset("simulator")
    reference = robot.inverse_dynamics(
        robot.home_pose, np.zeros(6), np.zeros(6), backend="pinocchio"
    )
    got = np.array(json.loads(gamma))
    assert np.max(np.abs(got - reference)) <= 1e-9 * np.max(np.abs(reference))


DERIVATIVES_CALL = """
import sys
import numpy as np
import stewart_pin
from stewart_pin.codegen import derivatives

if {forbid!r}:
    def forbidden(*args, **kwargs):
        raise AssertionError("the symbolic models were generated")

    derivatives.symbolic_models_for = forbidden
robot = stewart_pin.StewartRobot.from_preset("simulator")
P, V, A = robot.sample_states(1, 3)
d = robot.inverse_dynamics_derivatives(P[0], V[0], A[0])
backend = derivatives.derivatives_backend(robot)
print(backend.kind, backend.compiled_now, d.pose.tolist())
"""


@pytest.mark.skipif(
    __import__("stewart_pin.codegen.compiled", fromlist=["find_compiler"]).find_compiler() is None,
    reason="no C compiler on this machine",
)
def test_cached_derivatives_load_without_generating(tmp_path):
    """A new process whose robot's derivative library is cached loads it without
    generating the symbolic models (the first process generated and compiled them), and
    gives the same Jacobians (bit for bit: the same library)."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([src, *sys.path]),
        "STEWART_PIN_CACHE": str(tmp_path / "cache"),
        "STEWART_PIN_BACKEND": "auto",
    }

    def run(forbid: bool) -> list[str]:
        code = DERIVATIVES_CALL.format(forbid=forbid)
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
        )
        assert out.returncode == 0, out.stderr
        return out.stdout.split(maxsplit=2)

    first = run(False)
    assert first[:2] == ["compiled", "True"]
    again = run(True)
    assert again[:2] == ["compiled", "False"]
    assert json.loads(again[2]) == json.loads(first[2])


@pytest.mark.skipif(
    __import__("stewart_pin.codegen.compiled", fromlist=["find_compiler"]).find_compiler() is None,
    reason="no C compiler on this machine",
)
def test_a_large_derivative_library_compiles_in_the_background(tmp_path, monkeypatch, capfd):
    """Past ``BACKGROUND_INSTRUCTIONS`` (lowered here to take the 6-UPS) the first use
    answers from CasADi's virtual machine while the library compiles in a thread, announced
    on stderr; afterwards the calls take the library. Both give the derivatives of the
    reference model: the acceleration Jacobian equals central differences of the
    Pinocchio path's Gamma, affine in the acceleration (1e-7 relative), and the two agree
    to 1e-12 relative."""
    from stewart_pin.codegen import derivatives

    monkeypatch.setattr(derivatives, "BACKGROUND_INSTRUCTIONS", 0)
    robot = stewart_pin.StewartRobot.from_preset("simulator")
    backend = derivatives.CompiledDerivatives(robot, cache_dir=tmp_path / "cache")
    assert backend.reason == "compiling in the background"  # as the constructor returned
    P, V, A = robot.sample_states(3, 5)
    first = backend.inverse_dynamics_derivatives(P, V, A)
    assert backend.wait(600)
    assert backend.kind == "compiled" and backend.compiled_now and backend.library is not None
    err = capfd.readouterr().err
    assert "exact derivatives of robot 'simulator' in the background" in err
    again = backend.inverse_dynamics_derivatives(P, V, A)
    for x in ("gamma", "pose", "twist", "accel"):
        a, b = getattr(first, x), getattr(again, x)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))
    h = 1e-3
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        up = robot.inverse_dynamics(P, V, A + step, backend="pinocchio")
        down = robot.inverse_dynamics(P, V, A - step, backend="pinocchio")
        column = (up - down) / (2 * h)
        assert np.max(np.abs(first.accel[:, :, j] - column)) <= 1e-7 * np.max(np.abs(column))


def test_a_lazy_module_reads_the_modules_names_at_each_use(monkeypatch):
    """A stand-in (``_lazy.lazy_module``) gives the module's attribute as it is when read,
    not a copy taken at first use: a name rebound later (by the module itself, or replaced
    by a test) is what callers through the stand-in get."""
    from stewart_pin._lazy import lazy_module
    from stewart_pin.kinematics import workspace

    stand_in = lazy_module("stewart_pin.kinematics.workspace")
    assert stand_in.sample_states is workspace.sample_states  # imported on this first read

    def replaced(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("not called")

    monkeypatch.setattr(workspace, "sample_states", replaced)
    assert stand_in.sample_states is replaced
