"""The sections of ``stewart-pin bench`` beyond the main table (issue 24): a payload robot,
the first use of the exact derivatives, a new process's start-up, state sampling and the
compiled batches on every thread. Each function returns medians (its unit stated) and is
also what the matching ``scripts/bench_*.py`` prints.

A section is a dict: ``aim`` (the issue's aim, one line), ``unit`` (``us`` per state or
``s``), ``median`` (row -> median in that unit) and, filled by :func:`with_ratios`,
``ratio_to_pin_constraintDynamics`` (row -> median [us] / the run's
``pin.constraintDynamics`` call [us]).
"""

from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import cast

import numpy as np

from stewart_pin import StewartRobot
from stewart_pin.apps._timing import median_us
from stewart_pin.check.constrained_dynamics import constraint_dynamics_call

#: This checkout's ``src`` (first on the fresh processes' ``PYTHONPATH``).
SRC = Path(__file__).resolve().parents[2]
#: Seconds to microseconds.
_US = {"us": 1.0, "s": 1e6}


def with_ratios(section: dict[str, object], yardstick_us: float) -> dict[str, object]:
    """``section`` with ``ratio_to_pin_constraintDynamics`` (median [us] / ``yardstick_us``)."""
    scale = _US[str(section["unit"])]
    rows = section["median"]
    assert isinstance(rows, dict)
    section["ratio_to_pin_constraintDynamics"] = {
        k: t * scale / yardstick_us for k, t in rows.items()
    }
    return section


# --- a payload robot (scripts/bench_payload.py) ---------------------------------------

PAYLOAD_YARDSTICK = "pin.constraintDynamics, whole tree with the payload (raw call)"


def whole_tree_call(arm, T, V, G, q, qd, tau):  # type: ignore[no-untyped-def]
    """One raw ``pin.constraintDynamics`` on the whole tree (legs, platform, payload)."""
    import pinocchio as pin

    from stewart_pin.check.payload import PayloadTreeSolver

    s = PayloadTreeSolver(arm.robot, arm.payload)
    q_legs = np.asarray(arm.robot.inverse_geometry(T, check_limits=False))
    x, v, _ = s.state(T, V, q_legs, q, qd)
    t = -s.tree.joint_torques(x, v)
    t[s.tree.v_act] += G
    t[s.v_p] += tau
    args = (s.model, s.data, x, v, t, s.tree.cmodels, s.tree.cdatas, s.tree.settings)
    return partial(pin.constraintDynamics, *args)


def payload_rows(
    preset: str, payload: str, batch: int, compiled_batch: int, repeats: int
) -> tuple[dict[str, float], int]:
    """Medians [us per state] of ``PayloadRobot``'s models, reference and compiled (one
    state, batches of ``batch`` and ``compiled_batch`` states), the hexapod alone and
    ``pin.constraintDynamics`` on the whole tree and on the hexapod's; with the compiled
    batches' threads."""
    from stewart_pin.codegen.payload_compiled import payload_backend

    arm = StewartRobot.from_preset(preset).with_payload(payload)
    hexapod = arm.robot
    P, V, A, q, qd, qdd = arm.sample_states(batch, 0)
    reference = arm.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio")
    gamma, tau = reference.gamma, reference.tau
    fast = payload_backend(arm, "compiled")  # built (or found in the cache) before timing
    one = (P[0], V[0], A[0], q[0], qd[0], qdd[0])
    reps, breps = repeats, max(3, min(repeats, 5))
    reps_c = max(reps, 2000) if repeats >= 100 else reps  # a compiled call takes us
    m = -(-compiled_batch // batch)
    big = [np.ascontiguousarray(np.tile(x, (m,) + (1,) * (x.ndim - 1))[:compiled_batch])
           for x in (P, V, A, q, qd, qdd, gamma, tau)]  # fmt: skip
    Pb, Vb, Ab, qb, qdb, qddb, gb, taub = big
    nb = len(Pb)
    rows: dict[str, float] = {
        PAYLOAD_YARDSTICK: median_us(
            whole_tree_call(arm, P[0], V[0], gamma[0], q[0], qd[0], tau[0]), reps_c
        ),
        "pin.constraintDynamics, hexapod tree (raw call)": median_us(
            constraint_dynamics_call(hexapod, P[0], V[0], gamma[0]), reps_c
        ),
        "hexapod alone, inverse, compiled, one state": median_us(
            lambda: hexapod.inverse_dynamics(*one[:3], backend="compiled"), reps_c
        ),
    }
    for backend, r in (("pinocchio", reps), ("compiled", reps_c)):
        rows[f"payload robot, inverse, {backend}, one state"] = median_us(
            partial(arm.inverse_dynamics, *one, backend=backend), r
        )
        rows[f"payload robot, direct (prescribed qdd), {backend}, one state"] = median_us(
            partial(
                arm.direct_dynamics, P[0], V[0], gamma[0], q[0], qd[0], qdd[0], backend=backend
            ),
            r,
        )
        rows[f"payload robot, direct (torques), {backend}, one state"] = median_us(
            partial(
                arm.direct_dynamics, P[0], V[0], gamma[0], q[0], qd[0], tau=tau[0], backend=backend
            ),
            r,
        )
    n = batch
    rows[f"payload robot, inverse, pinocchio, batch of {n}"] = median_us(
        lambda: arm.inverse_dynamics(P, V, A, q, qd, qdd, backend="pinocchio"), breps, n
    )
    rows[f"payload robot, direct (torques), pinocchio, batch of {n}"] = median_us(
        lambda: arm.direct_dynamics(P, V, gamma, q, qd, tau=tau, backend="pinocchio"), breps, n
    )
    creps = max(5, breps)
    rows[f"payload robot, inverse, compiled, batch of {nb}"] = median_us(
        lambda: arm.inverse_dynamics(Pb, Vb, Ab, qb, qdb, qddb, backend="compiled"), creps, nb
    )
    rows[f"payload robot, direct (prescribed qdd), compiled, batch of {nb}"] = median_us(
        lambda: arm.direct_dynamics(Pb, Vb, gb, qb, qdb, qddb, backend="compiled"), creps, nb
    )
    rows[f"payload robot, direct (torques), compiled, batch of {nb}"] = median_us(
        lambda: arm.direct_dynamics(Pb, Vb, gb, qb, qdb, tau=taub, backend="compiled"), creps, nb
    )
    return rows, getattr(fast, "threads", 1)


# --- the compiled calls and batches (scripts/bench_compiled_calls.py) -----------------


def bench_robot(name: str) -> StewartRobot:
    """The robot of a preset name: :func:`StewartRobot.from_preset`'s, or a chain-leg
    preset (``welded-ups``, ``mixed-chain``:
    :data:`~stewart_pin.description.chain_leg_presets.CHAIN_PRESETS`)."""
    from stewart_pin.description.chain_leg_presets import CHAIN_PRESETS

    chain = CHAIN_PRESETS.get(name)
    return StewartRobot(chain()) if chain else StewartRobot.from_preset(name)


def raw_call(
    backend: object, which: str, n: int, T: np.ndarray, V: np.ndarray, X: np.ndarray
) -> tuple[object, tuple[object, ...]]:
    """The C batch function and its arguments for ``n`` states (buffers prepared)."""
    fn = backend._c[which]  # type: ignore[attr-defined]
    out = np.empty((n, 6))
    flags = np.empty(n, dtype=np.int32)
    chi = backend.base_values  # type: ignore[attr-defined]
    keep = (T, V, X, out, flags, chi)
    args = (
        n,
        T.ctypes.data,
        V.ctypes.data,
        X.ctypes.data,
        chi.ctypes.data,
        backend.robot.max_condition,  # type: ignore[attr-defined]
        out.ctypes.data,
        flags.ctypes.data,
    )
    return fn, (args, keep)


def median_cpu_us(fn: Callable[[], object], repeats: int, per: int) -> float:
    """Median over ``repeats`` calls of ``fn`` of the process's CPU time (all its threads),
    divided by ``per`` states per call [us]."""
    return median_us(fn, repeats, per, clock=time.process_time)


def compiled_call_rows(
    preset: str, repeats: int, batches: tuple[int, ...] = (10_000, 100_000), raw: bool = True
) -> tuple[dict[str, float], str, int]:
    """Medians [us per state] of the compiled backend's calls: the C functions through
    ctypes (``raw``), one state through ``CompiledDynamics`` and the facade, and batches of
    ``batches`` states on the backend's threads and on one (the CPU time per state too for
    the largest); with ``pin.constraintDynamics`` first. Also the backend's kind and
    threads."""
    import ctypes

    from stewart_pin.codegen import CompiledDynamics, compiled_backend

    robot = bench_robot(preset)
    big = max(batches)
    poses, twists, accels = robot.sample_states(min(2000, big), 0)  # any architecture
    idx = np.arange(big) % poses.shape[0]
    P, V, A = (np.ascontiguousarray(a[idx]) for a in (poses, twists, accels))
    backend = compiled_backend(robot)
    serial = CompiledDynamics(robot, threads=1)
    G = backend.inverse_dynamics(P, V, A)
    T0, V0, A0, G0 = P[0].copy(), V[0].copy(), A[0].copy(), G[0].copy()
    rows: dict[str, float] = {}
    rows["pin.constraintDynamics (raw call)"] = median_us(
        constraint_dynamics_call(robot, T0, V0, G0), repeats
    )
    for which, X, X0 in (("idm", A, A0), ("ddm", G, G0)):
        name = which.upper()
        if raw:
            for n, label in ((1, "1 state"), (1000, "1000 states, per state")):
                fn, (args, _keep) = raw_call(backend, which, n, P[:n], V[:n], X[:n])
                rows[f"{name} C function via ctypes, {label}"] = median_us(
                    partial(cast(Callable[..., object], fn), *cast(tuple[object, ...], args)),
                    repeats if n == 1 else 200,
                    n,
                )
            one = backend._c_one[which]
            block = T0.tobytes() + V0.tobytes() + X0.tobytes()
            args1 = (block, backend._chi_ptr, ctypes.c_double(1e4), backend._one_out_ptr)
            rows[f"{name} single-state C entry via ctypes (prepared arguments)"] = median_us(
                partial(one, *args1), repeats
            )
            method = backend.inverse_dynamics if which == "idm" else backend.direct_dynamics
            facade = robot.inverse_dynamics if which == "idm" else robot.direct_dynamics
            rows[f"{name} single, CompiledDynamics"] = median_us(
                partial(method, T0, V0, X0), repeats
            )
            rows[f"{name} single, robot facade backend='compiled'"] = median_us(
                partial(facade, T0, V0, X0, backend="compiled"), repeats
            )
            rows[f"{name} single, robot facade default backend='auto'"] = median_us(
                partial(facade, T0, V0, X0), repeats
            )
        for n in batches:
            reps = 50 if n <= 10_000 else 10
            for b in (backend, serial):
                m = b.inverse_dynamics if which == "idm" else b.direct_dynamics
                rows[f"{name} batch {n}, per state ({b.threads} threads)"] = median_us(
                    partial(m, P[:n], V[:n], X[:n]), reps, n
                )
                if n == big:
                    rows[f"{name} batch {n}, CPU time per state ({b.threads} threads)"] = (
                        median_cpu_us(partial(m, P[:n], V[:n], X[:n]), reps, n)
                    )
    return rows, backend.kind, getattr(backend, "threads", 1)


# --- state sampling (scripts/bench_sampling.py) ---------------------------------------

SAMPLING_PRESETS = (
    "simulator",
    "ups-offset",
    "rus",
    "pus",
    "random-custom-0",
    "welded-ups",
    "mixed-chain",
)


def sampling_seconds(name: str, n: int, repeats: int) -> float:
    """Median [s] of ``robot.sample_states(n, seed)`` over the seeds 0 to ``repeats - 1``
    (the robot built and warmed by a small call before timing)."""
    robot = bench_robot(name)
    robot.sample_states(10, 0)  # warm-up: the robot's cached views and constants
    times = []
    for seed in range(repeats):
        t0 = time.perf_counter()
        poses, _, accels = robot.sample_states(n, seed)
        times.append(time.perf_counter() - t0)
        assert poses.shape == (n, 4, 4) and np.all(np.isfinite(accels))
    return statistics.median(times)


def acceptance(robot: StewartRobot, n: int) -> float:
    """The fraction of draws accepted while sampling ``n`` poses: each draw takes six
    numbers from the generator, so the draws are counted by stepping a twin generator
    until it reaches the sampler's state."""
    rng = np.random.default_rng(12345)
    robot.sample_poses(n, rng)
    probe = np.random.default_rng(12345)
    draws = 0
    while probe.bit_generator.state != rng.bit_generator.state and draws <= 1000 * n:
        probe.random(6)
        draws += 1
    return n / max(draws, 1)


# --- fresh processes: start-up (scripts/bench_startup.py) -----------------------------

FIRST_CALL = """
import numpy as np
import stewart_pin
robot = stewart_pin.StewartRobot.from_preset({preset!r})
gamma = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6))
backend = robot._stewart_pin_auto_backend[1]
assert backend is not None and backend.kind == "compiled" and not backend.compiled_now
assert np.all(np.isfinite(gamma))
"""

#: (label, python arguments, aim [s] or None)
STARTUP_CASES = (
    ("python -c pass", ["-c", "pass"], None),
    ("import stewart_pin", ["-c", "import stewart_pin"], 0.3),
    ("stewart-pin --help", ["-m", "stewart_pin.cli", "--help"], 0.5),
)


def environment(cache: str, pycache: str | None = None) -> dict[str, str]:
    """The fresh processes' environment: this checkout's ``src`` first, ``cache`` as the
    library cache, the default backend ``auto``; with ``pycache``, Python's bytecode cache
    there (``PYTHONPYCACHEPREFIX``, ``PYTHONDONTWRITEBYTECODE`` unset): the package's
    modules are then compiled once, as an installed package's are, instead of in every
    process when bytecode is not written (about 0.3 s of each new process here)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC), env.get("PYTHONPATH")]))
    env["STEWART_PIN_CACHE"] = cache
    env["STEWART_PIN_BACKEND"] = "auto"
    if pycache is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = pycache
    return env


#: Prepended to a script run by :func:`seed_cache`: at exit, the process prints the
#: folders of the libraries it has mapped from its cache (Linux's ``/proc/self/maps``;
#: elsewhere nothing, and the timed processes build their own).
_PRINT_LOADED = """
import atexit, os
def _print_loaded():
    root = os.path.realpath(os.environ["STEWART_PIN_CACHE"]) + os.sep
    try:
        with open("/proc/self/maps") as maps:
            fields = [line.split(None, 5) for line in maps]
    except OSError:
        return
    files = {f[5].strip() for f in fields if len(f) == 6}
    print("\\n".join(sorted({os.path.dirname(f) for f in files if f.startswith(root)})))
atexit.register(_print_loaded)
"""


def seed_cache(cache: str, script: str, *argv: str) -> int:
    """Fill the empty ``cache`` folder with what ``python -c script *argv`` loads: the
    script runs once on this process's own cache (:func:`.compiled.cache_root`, where it
    builds each library once, or finds it), and the key folders of the libraries it mapped
    are copied into ``cache`` (the timed processes then find them as they would in the
    user's cache: verified against their manifests). Copying the folders instead of
    building them again in ``cache`` saves a build of seconds per library; a folder not
    found (another platform), or a script that fails on the user's cache, leaves the
    building to the timed processes, as before. Returns how many key folders were
    copied."""
    from stewart_pin.codegen.compiled import cache_root

    root = Path(os.path.realpath(cache_root()))
    env = environment(str(root))
    run = subprocess.run(
        [sys.executable, "-c", _PRINT_LOADED + script, *argv],
        env=env,
        check=False,
        capture_output=True,
        text=True,
    )
    os.makedirs(cache, mode=0o700, exist_ok=True)
    if run.returncode != 0:  # the timed processes build, and report a failure themselves
        return 0
    copied = 0
    for line in run.stdout.splitlines():
        folder = Path(line)
        # a key folder of the cache (nothing else is copied), as a folder, not a link
        key = folder.parent == root and not folder.is_symlink()
        if key and (folder / "manifest.json").is_file():
            shutil.copytree(folder, Path(cache) / folder.name, dirs_exist_ok=True)
            copied += 1
    return copied


def timed(args: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall-clock and CPU (user + system) seconds of one fresh process ``python *args``
    (which must succeed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu


def startup_figures(runs: int, preset: str) -> dict[str, dict[str, float | None]]:
    """Per case (:data:`STARTUP_CASES` and the first call on a cached ``preset``), the
    median, minimum and median CPU seconds of ``runs`` fresh processes, and its aim [s]; the
    cache a temporary folder filled once before timing. The processes keep Python's
    bytecode in a temporary folder (:func:`environment`), filled by a first, untimed run of
    each case, as an installed package has it; the first call is also timed without it
    (every module of the package compiled in each process: a checkout run with
    ``PYTHONDONTWRITEBYTECODE``)."""
    with tempfile.TemporaryDirectory(prefix="stewart-pin-startup-") as tmp:
        cache = os.path.join(tmp, "cache")
        env = environment(cache, pycache=os.path.join(tmp, "pycache"))
        bare = environment(cache)
        bare["PYTHONDONTWRITEBYTECODE"] = "1"
        first = FIRST_CALL.format(preset=preset)
        # fill the cache (not timed): the libraries of the first call, copied from the
        # user's cache (built there once, if they were not)
        fill = first.replace("and not backend.compiled_now", "")
        if not seed_cache(cache, fill):  # built here, by a process of its own
            subprocess.run([sys.executable, "-c", fill], env=env, check=True, capture_output=True)
        label = f"first call on a cached robot ({preset})"
        cases = [
            *((*case, env) for case in STARTUP_CASES),
            (label, ["-c", first], 0.5, env),
            (f"{label}, no bytecode cache", ["-c", first], None, bare),
        ]
        out: dict[str, dict[str, float | None]] = {}
        for label, args, aim, case_env in cases:
            timed(args, case_env)  # warm the file-system and bytecode caches
            wall, cpu = zip(*(timed(args, case_env) for _ in range(runs)), strict=True)
            out[label] = {
                "median_s": statistics.median(wall),
                "min_s": min(wall),
                "cpu_median_s": statistics.median(cpu),
                "aim_s": aim,
            }
    return out


# --- fresh processes: first use of the derivatives (scripts/bench_derivatives.py) -----

#: The presets timed by ``--first-use``: every named preset, every leg preset, a random
#: robot with custom legs and the chain-leg presets (``rss-asymmetric``: idle freedoms, its
#: calls given the idle state at home and at rest).
FIRST_USE_PRESETS = (
    "simulator",
    "desktop",
    "paper",
    "ups-offset",
    "rus",
    "pus",
    "random-custom-0",
    "welded-ups",
    "mixed-chain",
    "rss-asymmetric",
)
#: What runs in the new process: a value call first (its library cached by an earlier
#: process, as it stands after any use of the robot), then the timed first derivatives
#: call (``sys.argv[2]``: "time"; else only the value call, to fill the cache).
_FIRST_USE = """
import sys, time
from stewart_pin.apps.bench_sections import bench_robot
from stewart_pin.codegen import compiled
from stewart_pin.kinematics import chain_legs
robot = bench_robot(sys.argv[1])
P, V, A = robot.sample_states(1, 0)
kw = {}
if chain_legs.idle_legs(robot.description):  # idle freedoms: the idle state at home, at rest
    kw["idle"] = (chain_legs.idle_home(robot.description), V[0] * 0.0)
    robot.inverse_dynamics_idle(P[0], V[0], A[0], kw["idle"], backend="compiled")
else:
    robot.inverse_dynamics(P[0], V[0], A[0], backend="compiled")
if sys.argv[2] != "time":
    sys.exit(0)
calls = []
original = compiled._compile
def timed(*args, **kwargs):
    t = time.perf_counter()
    try:
        return original(*args, **kwargs)
    finally:
        calls.append(time.perf_counter() - t)
compiled._compile = timed
t = time.perf_counter()
robot.inverse_dynamics_derivatives(P[0], V[0], A[0], **kw)
total = time.perf_counter() - t
t = time.perf_counter()
robot.inverse_dynamics_derivatives(P[0], V[0], A[0], **kw)
print(total, sum(calls), time.perf_counter() - t)
"""


def first_use(preset: str) -> dict[str, object]:
    """The first derivatives call of ``preset`` in a new process with an empty cache:
    seconds in all, compiling, and for the second call; the load average just before."""
    with tempfile.TemporaryDirectory(prefix="stewart-pin-first-use-") as cache:
        env = environment(cache)
        # the value models' libraries, as after any use of the robot: copied from the
        # user's cache (built there once if they were not), else built by a value step here
        seeded = seed_cache(cache, _FIRST_USE, preset, "values")
        for step in ("time",) if seeded else ("values", "time"):
            load = os.getloadavg()[0]
            run = subprocess.run(
                [sys.executable, "-c", _FIRST_USE, preset, step],
                capture_output=True,
                text=True,
                env=env,
                check=False,
            )
            if run.returncode != 0:
                break
    if run.returncode != 0:
        raise SystemExit(f"{preset}: {run.stderr.strip().splitlines()[-1:]}")
    total, compiling, second = (float(x) for x in run.stdout.split())
    announced = [ln for ln in run.stderr.splitlines() if "exact derivatives" in ln]
    return {
        "preset": preset,
        "first_call_s": total,
        "compiling_s": compiling,
        "second_call_us": 1e6 * second,
        "announced": announced[0] if announced else "",
        "load_average_1min": load,
    }


# --- the sections of ``stewart-pin bench`` ---------------------------------------------

#: The sections' names and the issue's aim of each (issue 24, "What to build").
AIMS = {
    "payload": "one state under pin.constraintDynamics on the whole tree; batches under 0.1 of it",
    "derivatives first use": "under 5 s on every preset (fresh process, empty cache)",
    "start-up": "import stewart_pin < 0.3 s; stewart-pin --help < 0.5 s; first call on a "
    "cached robot < 0.5 s in all",
    "sampling": "sample_states(10 000) under 1 s on every architecture",
    "batches": "IDM <= 0.1 us per state, DDM <= 0.15 us, on 2 threads at N = 10^5",
}
#: The aim of the simulation section (:mod:`.bench_simulation`).
SIMULATION_AIM = (
    "per step, forces as data <= 1/15 of MuJoCo's RK4 step; a Python force function per "
    "step <= 1/5"
)


def bench_sections(
    preset: str,
    batch: int,
    repeats: int,
    quick: bool,
    say: Callable[[str], None],
    first_stage: int,
    stages: int,
) -> dict[str, dict[str, object]]:
    """Every section of :data:`AIMS` on ``preset`` (``quick``: fewer repeats, ``batch``
    states at most, the first uses on ``preset`` alone), each told to ``say`` as stage
    ``first_stage``... of ``stages``; medians only (:func:`with_ratios` adds the ratios)."""
    out: dict[str, dict[str, object]] = {}
    k = iter(range(first_stage, stages + 1))

    def section(name: str, unit: str, rows: dict[str, float], **more: object) -> None:
        out[name] = {"aim": AIMS[name], "unit": unit, "median": rows, **more}

    say(f"[{next(k)}/{stages}] '{preset}' carrying 'ur5': the payload models")
    small = min(batch, 100) if quick else 1000
    rows, threads = payload_rows(
        preset,
        "ur5",
        small,
        max(batch, 1000) if quick else 100_000,
        min(repeats, 50) if quick else repeats,
    )
    whole = rows[PAYLOAD_YARDSTICK]
    section(
        "payload",
        "us",
        rows,
        payload="ur5",
        threads=threads,
        ratio_to_whole_tree={r: t / whole for r, t in rows.items()},
    )
    presets = (preset,) if quick else FIRST_USE_PRESETS
    listed = ", ".join(presets)
    say(f"[{next(k)}/{stages}] first derivatives call in a new process, empty cache: {listed}")
    rows = {}
    for p in presets:
        r = first_use(p)
        rows[f"{p}: first inverse_dynamics_derivatives call"] = float(r["first_call_s"])  # type: ignore[arg-type]
        rows[f"{p}:   of which compiling"] = float(r["compiling_s"])  # type: ignore[arg-type]
    section("derivatives first use", "s", rows)
    runs = 1 if quick else 7
    say(f"[{next(k)}/{stages}] start-up: fresh processes ({runs} per figure), a new cache")
    figures = startup_figures(runs, preset)
    section("start-up", "s", {label: float(f["median_s"] or 0.0) for label, f in figures.items()})
    n = min(batch, 10_000) if quick else 10_000
    say(f"[{next(k)}/{stages}] sample_states({n}) on {', '.join(SAMPLING_PRESETS)}")
    section(
        "sampling",
        "s",
        {
            f"{p}: sample_states({n})": sampling_seconds(p, n, 1 if quick else 5)
            for p in SAMPLING_PRESETS
        },
    )
    sizes = (batch,) if quick else (100_000,)
    say(f"[{next(k)}/{stages}] '{preset}': compiled batches of {sizes[0]} states")
    rows, kind, threads = compiled_call_rows(
        preset, min(repeats, 50) if quick else repeats, sizes, raw=False
    )
    rows.pop("pin.constraintDynamics (raw call)")  # the main table's
    section("batches", "us", rows, kind=kind, threads=threads)
    return out


def sections_table(sections: dict[str, dict[str, object]]) -> list[str]:
    """Each section: its name and aim, then its rows: median (in its unit), ratio to the
    run's ``pin.constraintDynamics`` (and to the whole tree's for the payload)."""
    lines: list[str] = []
    for name, entry in sections.items():
        rows = entry["median"]
        ratios = entry["ratio_to_pin_constraintDynamics"]
        whole = entry.get("ratio_to_whole_tree", {})
        assert isinstance(rows, dict) and isinstance(ratios, dict) and isinstance(whole, dict)
        unit = f"[{entry['unit']}]" if entry["unit"] == "s" else "[us/state]"
        extra = f"  {'/ whole tree':>12s}" if whole else ""
        width = max([len(name), *(len(r) for r in rows)])
        lines += [
            "",
            f"{name}: aim {entry['aim']}",
            f"{'':{width}s}  {unit:>12s}  {'/ pin.constraintDynamics':>24s}{extra}",
        ]
        for row, t in rows.items():
            more = f"  {whole[row]:12.4f}" if whole else ""
            lines.append(f"{row:{width}s}  {t:12.4g}  {ratios[row]:24.4g}{more}")
    return lines
