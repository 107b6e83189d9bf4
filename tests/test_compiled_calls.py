"""The compiled backend's call paths (issue 14, item 3): the single-state entry and the
batch split across threads give the reference's results and errors."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from conftest import get_robot, use_compile_cache
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.codegen import CompiledDynamics
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen._csource import FLAG_NAMES
from stewart_pin.exceptions import InputError, StrokeLimitError
from stewart_pin.kinematics.workspace import sample_states

COND, REPIVOTED = FLAG_NAMES["COND"], FLAG_NAMES["REPIVOTED"]
TOL = 1e-10  # relative to the largest value of the batch (as in test_codegen.py)


@pytest.fixture(scope="module", autouse=True)
def cache_dir(shared_compile_cache):
    """The session's shared cache folder (the same robots compile once for the suite)."""
    yield from use_compile_cache(shared_compile_cache)


def test_threaded_batch_matches_reference_and_one_thread() -> None:
    robot = get_robot("simulator")
    n = 4 * compiled_module.THREAD_MIN_STATES + 3  # uneven slices
    P, V, A = sample_states(robot.description, n, 5)
    reference = robot.inverse_dynamics(P, V, A)  # Pinocchio legs + closure layer
    one, two = CompiledDynamics(robot, threads=1), CompiledDynamics(robot, threads=2)
    assert (one.threads, two.threads) == (1, 2)
    G1, G2 = one.inverse_dynamics(P, V, A), two.inverse_dynamics(P, V, A)
    assert rel_error(G2, reference) < TOL
    np.testing.assert_array_equal(G1, G2)  # same C per state, whatever the slice
    D2 = two.direct_dynamics(P, V, reference)
    assert rel_error(D2, A) < 1e-8
    np.testing.assert_array_equal(D2, one.direct_dynamics(P, V, reference))


def test_threaded_batch_error_in_a_later_slice_is_the_reference_error() -> None:
    robot = get_robot("simulator")
    n = 2 * compiled_module.THREAD_MIN_STATES
    P, V, A = sample_states(robot.description, n, 6)
    P = P.copy()
    P[n - 1, 2, 3] += 10.0  # the last state, in the second thread's slice: legs too long
    with pytest.raises(StrokeLimitError) as ref:
        robot.inverse_dynamics(P, V, A)
    with pytest.raises(StrokeLimitError) as got:
        CompiledDynamics(robot, threads=2).inverse_dynamics(P, V, A)
    assert str(got.value) == str(ref.value)


def test_single_state_entry_matches_reference() -> None:
    robot = get_robot("paper")
    P, V, A = sample_states(robot.description, 20, 7)
    backend = CompiledDynamics(robot)
    for k in range(20):
        reference = robot.inverse_dynamics(P[k], V[k], A[k])
        assert rel_error(backend.inverse_dynamics(P[k], V[k], A[k]), reference) < TOL
        # non-contiguous and float32 inputs take the other paths, same values
        assert rel_error(backend.inverse_dynamics(P[k].T.T, V[k], A[k]), reference) < TOL
        Pt = np.asfortranarray(P[k])
        assert rel_error(backend.inverse_dynamics(Pt, V[k], A[k]), reference) < TOL


def test_threads_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(compiled_module.THREADS_ENV, "3")
    assert compiled_module.default_threads() == 3
    monkeypatch.setenv(compiled_module.THREADS_ENV, "zero")
    with pytest.raises(InputError, match="threads"):
        compiled_module.default_threads()
    monkeypatch.delenv(compiled_module.THREADS_ENV)
    assert compiled_module.default_threads() >= 1
    with pytest.raises(InputError, match="threads"):
        CompiledDynamics(get_robot("simulator"), threads=0)


@pytest.mark.parametrize("name", ["simulator", "rus", "pus", "ups-offset", "random-custom-0"])
def test_vector_batch_equals_the_scalar_path(name: str) -> None:
    """The batch loop runs SP_WIDTH states at a time (four with AVX2, two elsewhere)
    through the vector copy of the generated code (codegen/_simd.py) and the vector screen
    of the guards: every state's result and flag equal those of the same C called on that
    state alone (the scalar path) to 1e-13, whichever lane it takes, with invalid states
    (out of reach, not finite, not a rotation) in every lane, an uneven count (the last
    states scalar) and, with a low ``max_condition``, states the screen leaves to the
    scalar guards (flagged or not); the valid states also equal the reference path.
    Custom legs' Newton steps are calls of a step function: its vector copy is called
    (issue 20; the welded chain legs: tests/test_chain_legs_compiled.py)."""
    robot = get_robot(name)
    n = 43
    P, V, A = (np.ascontiguousarray(a) for a in robot.sample_states(n, 8))
    source = (CompiledDynamics(robot).library.parent / "stewart_models.c").read_text()
    assert "#define SP_VEC_IDM 1" in source and "#define SP_VEC_DDM 1" in source
    G = np.ascontiguousarray(robot.inverse_dynamics(P, V, A, backend="pinocchio"))
    cond = robot.condition_number(P)
    P[6, 2, 3] += 10.0 * robot.description.size  # lane 2 (of 4): out of reach
    V[11, 0] = np.nan  # lane 3: not finite
    P[12, 0, 1] += 1e-3  # lane 0: not a rotation
    A[17, 2] = np.inf  # lane 1: not finite (the inverse model's input)
    G[17, 2] = np.inf  # (the direct model's)
    valid = np.ones(n, dtype=bool)
    valid[[6, 11, 12, 17]] = False
    low = [m * float(np.median(cond)) for m in np.geomspace(1.2, 4.0, 12)]
    partly_flagged = 0
    for max_condition in (robot.max_condition, *low):
        backend = CompiledDynamics(StewartRobot(robot.description, max_condition), threads=1)
        chi = np.ascontiguousarray(backend.base_values, dtype=np.float64)
        for which, X, ref in (("idm", A, G), ("ddm", G, A)):
            out, flags = np.empty((n, 6)), np.zeros(n, dtype=np.int32)
            backend._call_batch(which, n, P, V, X, chi, out, flags)
            assert np.all(flags[~valid] != 0)
            if max_condition == robot.max_condition:
                assert not np.any(flags[valid] & ~REPIVOTED)
                assert rel_error(out[valid], ref[valid]) < 1e-8
            elif 0 < np.count_nonzero(flags[valid] & COND) < np.count_nonzero(valid):
                partly_flagged += 1  # some flagged for their condition, some not
            else:
                continue
            for k in range(n):
                one, flag = np.empty((1, 6)), np.zeros(1, dtype=np.int32)
                x = X[k : k + 1]
                backend._call_batch(which, 1, P[k : k + 1], V[k : k + 1], x, chi, one, flag)
                assert flag[0] == flags[k], (which, k)
                if valid[k]:
                    assert np.max(np.abs(out[k] - one[0])) <= 1e-13 * np.max(np.abs(one[0]))
    assert partly_flagged >= 2


@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_large_batch_is_split_across_threads(name: str) -> None:
    """A batch of 2 * THREAD_MIN_STATES + 1 states on 2 threads runs as two slices of the C
    loop in two threads, leg-chain robots as the 6-UPS (the decision, not the timing: the
    slices' C calls are recorded), with the one-thread results."""
    robot = get_robot(name)
    n = 2 * compiled_module.THREAD_MIN_STATES + 1
    P, V, A = (np.ascontiguousarray(a) for a in robot.sample_states(n, 9))
    backend = CompiledDynamics(robot, threads=2)
    calls: list[tuple[int, int]] = []
    for which in ("idm", "ddm"):
        fn = backend._c[which]

        def recorded(m: int, *args: object, fn: object = fn) -> int:
            calls.append((threading.get_ident(), m))
            return fn(m, *args)  # type: ignore[operator]

        backend._c[which] = recorded  # type: ignore[assignment]
    G = backend.inverse_dynamics(P, V, A)
    assert sorted(m for _, m in calls) == [n // 2, n - n // 2]
    assert len({t for t, _ in calls}) == 2
    np.testing.assert_array_equal(G, CompiledDynamics(robot, threads=1).inverse_dynamics(P, V, A))
    calls.clear()
    backend.direct_dynamics(P, V, G)
    assert len(calls) == 2 and len({t for t, _ in calls}) == 2
