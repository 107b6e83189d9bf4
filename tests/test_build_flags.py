"""The models' libraries as users get them by default: built optimised (``gcc -O2``,
:data:`~stewart_pin.codegen.compiled.CFLAGS`).

The rest of the suite builds them quick (``$STEWART_PIN_BUILD=quick``, set in conftest.py:
no optimisation, 3-7x sooner). Here each kind of library is built optimised, and its
results are compared with:

- the independent references, to the tolerances the rest of the suite uses: the reference
  (Pinocchio) path, Pinocchio's constrained tree, and for the simulator the Python
  integrator on the same models;
- the quick build of the same robot, to 1e-12 relative. Both compile the same C, and
  neither is built with ``-ffast-math``. They can differ only by rounding: ``-O2`` turns a
  division into a product with a reciprocal (``-freciprocal-math``) and contracts
  ``a * b + c`` into one FMA in the AVX2 copies. These tests would catch code whose result
  depends on the optimiser, such as undefined behaviour.

The kinds of library: the paper's 6-UPS models (``simulator``), general legs (``rus``:
cranks, gears, friction), legs with idle freedoms (an asymmetric 6-RSS), a payload on a
hexapod (``simulator`` carrying a three-joint arm), and the compiled simulator's models
with its legs as vector lanes (``simulator``). Chain legs without idle joints
(``welded-ups``, ``mixed``) are not built here: their optimised build takes 17-30 s. Their
models come from the same chain-leg generator (``codegen/chain_leg_symbolic.py``) as the
idle legs' library built here, and their guards from the same ``codegen/_csource.py``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot, use_compile_cache
from test_payload_compiled import three_joint_arm

from stewart_pin import StewartRobot
from stewart_pin.check.payload import PayloadTreeSolver, reference_inverse_dynamics
from stewart_pin.cli import main as cli_main
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.compiled import CompiledDynamics
from stewart_pin.codegen.idle_compiled import CompiledIdleDynamics
from stewart_pin.codegen.payload_compiled import CompiledPayloadDynamics
from stewart_pin.description.chain_leg_presets import rss_robot
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics import chain_legs
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.simulation import prepare_run
from stewart_pin.motion.trajectories import standard_motion

#: Relative agreement of the optimised and the quick build (max |difference| over a
#: batch, relative to its largest output).
SAME = 1e-12
#: Relative agreement with the references: the rest of the suite's tolerances.
TOL = 1e-9
#: States per batch: more than two slices of THREAD_MIN_STATES (the threaded loop).
N = 1200


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache: Path) -> Iterator[Path]:
    yield from use_compile_cache(shared_compile_cache)


def built(mode: str, make: Callable[[], Any], monkeypatch: pytest.MonkeyPatch) -> Any:
    """``make()`` with ``$STEWART_PIN_BUILD=mode``; its library's manifest names the flags
    of that mode."""
    monkeypatch.setenv(compiled_module.BUILD_ENV, mode)
    backend = make()
    monkeypatch.delenv(compiled_module.BUILD_ENV)
    assert getattr(backend, "kind", "compiled") == "compiled", getattr(backend, "reason", "")
    manifest = json.loads((Path(backend.library).parent / "manifest.json").read_text())
    assert manifest["cflags"] == list(compiled_module.BUILD_FLAGS[mode])
    return backend


def rel(got: np.ndarray, ref: np.ndarray) -> float:
    return float(np.abs(got - ref).max() / np.abs(ref).max())


# ---------------------------------------------------------------------------- the setting
def test_the_setting_picks_the_flags_and_refuses_anything_else(monkeypatch):
    monkeypatch.delenv(compiled_module.BUILD_ENV, raising=False)
    assert compiled_module.model_cflags() == compiled_module.CFLAGS
    assert "-O2" in compiled_module.CFLAGS
    monkeypatch.setenv(compiled_module.BUILD_ENV, " quick ")
    assert compiled_module.model_cflags() == compiled_module.QUICK_CFLAGS
    assert "-O0" in compiled_module.QUICK_CFLAGS
    monkeypatch.setenv(compiled_module.BUILD_ENV, "optimised")
    assert compiled_module.model_cflags() == compiled_module.CFLAGS
    monkeypatch.setenv(compiled_module.BUILD_ENV, "-O3")
    with pytest.raises(InputError, match=r"\$STEWART_PIN_BUILD must be 'optimised'.*'-O3'"):
        compiled_module.model_cflags()
    with pytest.raises(InputError, match="STEWART_PIN_BUILD"):
        CompiledDynamics(get_robot("simulator"))


def test_the_cli_says_a_bad_setting_in_one_line(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv(compiled_module.BUILD_ENV, "fast")
    argv = ["simulate", "--duration", "0.01", "--backend", "compiled", "--no-progress"]
    assert cli_main([*argv, "-o", str(tmp_path / "run.npz")]) == 2
    assert not list(tmp_path.iterdir())
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "$STEWART_PIN_BUILD must be" in err, err


# ---------------------------------------------------------------------------- the models
@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_optimised_models_equal_the_reference_and_the_quick_build(name, monkeypatch):
    robot = get_robot(name)
    fast = built("optimised", lambda: CompiledDynamics(robot), monkeypatch)
    quick = built("quick", lambda: CompiledDynamics(robot), monkeypatch)
    assert fast.library != quick.library
    P, V, A = robot.sample_states(N, rng=11)
    G = fast.inverse_dynamics(P, V, A)
    acc = fast.direct_dynamics(P, V, 1.1 * G)
    assert rel(G, quick.inverse_dynamics(P, V, A)) <= SAME
    assert rel(acc, quick.direct_dynamics(P, V, 1.1 * G)) <= SAME
    k = slice(0, 8)
    ref = robot.inverse_dynamics(P[k], V[k], A[k], backend="pinocchio")
    assert rel(G[k], ref) <= TOL
    assert rel(acc[k], robot.direct_dynamics(P[k], V[k], 1.1 * G[k], backend="pinocchio")) <= TOL
    for i in range(3):  # the single-state entries
        assert rel(fast.inverse_dynamics(P[i], V[i], A[i]), G[i]) <= SAME
        assert rel(fast.direct_dynamics(P[i], V[i], 1.1 * G[i]), acc[i]) <= SAME


def test_optimised_idle_models_equal_the_reference_and_the_quick_build(monkeypatch):
    robot = StewartRobot(rss_robot(symmetric=False))
    fast = built("optimised", lambda: CompiledIdleDynamics(robot), monkeypatch)
    quick = built("quick", lambda: CompiledIdleDynamics(robot), monkeypatch)
    P, V, A = robot.sample_states(N, rng=12)
    rng = np.random.default_rng(12)
    idle = (
        chain_legs.idle_home(robot.description) + rng.uniform(-0.6, 0.6, (N, 6)),
        rng.uniform(-5.0, 5.0, (N, 6)),
    )
    G, spin_acc = fast.inverse_dynamics(P, V, A, idle)
    acc, spin_acc2 = fast.direct_dynamics(P, V, 1.1 * G, idle)
    G_q, spin_acc_q = quick.inverse_dynamics(P, V, A, idle)
    acc_q, spin_acc2_q = quick.direct_dynamics(P, V, 1.1 * G, idle)
    for got, other in ((G, G_q), (spin_acc, spin_acc_q), (acc, acc_q), (spin_acc2, spin_acc2_q)):
        assert rel(got, other) <= SAME
    k = slice(0, 6)
    ref = robot.chain_dynamics.inverse_dynamics(
        P[k], V[k], A[k], details=True, idle=(idle[0][k], idle[1][k])
    )
    assert rel(G[k], ref.gamma) <= TOL
    assert rel(spin_acc[k], ref.idle_accel) <= TOL


def test_optimised_payload_models_equal_the_constrained_tree_and_the_quick_build(monkeypatch):
    mount = pin.SE3(pin.rpy.rpyToMatrix(0.2, -0.1, 0.4), np.array([0.05, -0.03, 0.02]))
    robot = StewartRobot.from_preset("simulator").with_payload(
        three_joint_arm(), mount.homogeneous
    )
    fast = built("optimised", lambda: CompiledPayloadDynamics(robot), monkeypatch)
    quick = built("quick", lambda: CompiledPayloadDynamics(robot), monkeypatch)
    P, V, A, q, qd, qdd = robot.sample_states(N, 13)
    out = fast.inverse_dynamics(P, V, A, q, qd, qdd)
    out_q = quick.inverse_dynamics(P, V, A, q, qd, qdd)
    assert rel(out.gamma, out_q.gamma) <= SAME and rel(out.tau, out_q.tau) <= SAME
    fwd = fast.direct_dynamics(P, V, out.gamma, q, qd, tau=out.tau)
    fwd_q = quick.direct_dynamics(P, V, out.gamma, q, qd, tau=out.tau)
    assert rel(fwd.accel, fwd_q.accel) <= SAME and rel(fwd.qdd, fwd_q.qdd) <= SAME
    assert rel(fwd.accel, A) <= TOL and rel(fwd.qdd, qdd) <= TOL  # the models invert
    k = slice(0, 6)
    solver = PayloadTreeSolver(robot.robot, robot.payload)
    gamma_ref, tau_ref = reference_inverse_dynamics(solver, P[k], V[k], A[k], q[k], qd[k], qdd[k])
    assert rel(out.gamma[k], gamma_ref) <= TOL and rel(out.tau[k], tau_ref) <= TOL


# ---------------------------------------------------------------------------- the simulator
def test_the_c_loop_on_optimised_models_equals_the_python_loop_and_the_quick_build(monkeypatch):
    """The C loop (its legs as vector lanes where the processor has AVX2 and FMA) under the
    computed-torque controller, on the optimised models: the Python loop's trajectory on
    the same models to 1e-10 (as test_compiled_simulation.py on the quick ones), and the
    quick models' C loop to 1e-10."""

    def run(mode: str, integrator: str) -> Any:
        monkeypatch.setenv(compiled_module.BUILD_ENV, mode)
        robot = StewartRobot.from_preset("simulator")  # its own backends, under ``mode``
        motion = standard_motion(robot, "sinusoid", 0.1)
        T0, V0, _ = motion(0.0)
        ct = ComputedTorqueController(robot, motion, backend="compiled")
        kwargs = {"dt": 1e-3, "forces": ct, "pose": T0, "twist": V0}
        go = prepare_run(robot, 0.1, backend="compiled", integrator=integrator, **kwargs)
        library = None if go.fast is None else go.fast._models.library  # the C loop's
        return go.go(), library

    fast, lib = run("optimised", "compiled")
    slow, _ = run("optimised", "python")
    quick, lib_q = run("quick", "compiled")
    monkeypatch.delenv(compiled_module.BUILD_ENV)
    assert lib is not None and lib_q is not None and lib != lib_q
    for name in ("poses", "twists", "accels", "gammas"):
        x = getattr(fast, name)
        scale = max(1.0, float(np.abs(x).max()))
        assert np.abs(x - getattr(slow, name)).max() <= 1e-10 * scale, name
        assert np.abs(x - getattr(quick, name)).max() <= 1e-10 * scale, name
