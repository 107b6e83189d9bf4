"""Shared robots for the test suite (independent reference helpers: ``helpers.py``).

The robots are session-scoped: a :class:`StewartRobot` builds its Pinocchio models once, on
first use, and the tests only read from them.
"""

from __future__ import annotations

import os

# One BLAS thread per process: the suite's matrices are small, and on a shared 2-core
# machine OpenBLAS' thread pool made the identification tests' SVDs ~6x slower. Set before
# NumPy is imported (a user's own setting wins).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

# The dynamic models' default backend="auto" compiles each robot geometry it meets (a
# second or more each, dozens of robots here): the suite runs it as the reference path
# unless STEWART_PIN_BACKEND is set already (e.g. to "auto" in a CI job with a warm cache).
# Tests of the reference path say backend="pinocchio"; tests of the compiled and "auto"
# paths ask for them explicitly (test_auto_backend.py, test_general_codegen.py).
os.environ.setdefault("STEWART_PIN_BACKEND", "pinocchio")
# The models' libraries build without optimisation ($STEWART_PIN_BUILD=quick: 3-7x sooner,
# the suite's largest cost was ~100 gcc -O2 builds of as many geometries); the optimised
# build of each kind of library is checked against the quick one and against the
# independent references in test_build_flags.py.
os.environ.setdefault("STEWART_PIN_BUILD", "quick")

from stewart_pin import StewartRobot
from stewart_pin.codegen import compiled as compiled_module

#: The test files whose tests take longest in all (sums of the test times of a run with
#: ``--junitxml``, this project's 2-core machine, 2026-12-03), longest first. They are
#: collected first, and ``--no-loadscope-reorder`` (pyproject's addopts) keeps that order
#: under ``--dist loadfile``: a worker takes the next file when it is nearly done with
#: its own, so the long files start early, the short ones fill in at the end and the
#: workers finish together. (xdist's own order, by number of tests, put the notebooks,
#: 7 tests and 90-100 s, among the last files: one worker ran on alone.)
SLOWEST_FILES = (
    "test_notebooks.py",
    "test_general_codegen.py",
    "test_export_c.py",
    "test_point_to_point.py",
    "test_viz.py",
    "test_compiled_simulation.py",
    "test_cli.py",
    "test_singularities.py",
    "test_build_flags.py",
    "test_lanes.py",
    "test_chain_legs_compiled.py",
    "test_chain_legs_idle_compiled.py",
    "test_docs_snippets.py",
    "test_payload_motion.py",
    "test_identification_lab.py",
    "test_every_architecture.py",
    "test_codegen_cache.py",
    "test_general_regressor.py",
    "test_derivatives.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files of :data:`SLOWEST_FILES` first, in that order; the others after them
    as collected (the tests of each file in their order)."""
    rank = {name: k for k, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


#: Seeds of the general asymmetric robots used throughout.
RANDOM_SEEDS = (0, 1, 2)
#: Every robot a "for all robots" test runs on.
ALL_ROBOTS = ("simulator", "desktop", "paper", *(f"random-{s}" for s in RANDOM_SEEDS))

_CACHE: dict[str, StewartRobot] = {}


def get_robot(name: str) -> StewartRobot:
    """A shared robot by preset name (``simulator``, ``desktop``, ``paper``, ``random-<seed>``)."""
    if name not in _CACHE:
        _CACHE[name] = StewartRobot.from_preset(name)
    return _CACHE[name]


@pytest.fixture(scope="session")
def simulator() -> StewartRobot:
    return get_robot("simulator")


@pytest.fixture(scope="session")
def desktop() -> StewartRobot:
    return get_robot("desktop")


@pytest.fixture(scope="session")
def paper() -> StewartRobot:
    return get_robot("paper")


@pytest.fixture(scope="session")
def random_robot() -> Callable[[int], StewartRobot]:
    """A factory: ``random_robot(seed)`` is the shared general asymmetric robot of that seed."""
    return lambda seed: get_robot(f"random-{seed}")


@pytest.fixture(scope="session", params=ALL_ROBOTS)
def any_robot(request: pytest.FixtureRequest) -> StewartRobot:
    """Each preset and each random robot in turn."""
    return get_robot(request.param)


@pytest.fixture(scope="session", params=("paper", *(f"random-{s}" for s in RANDOM_SEEDS)))
def general_robot(request: pytest.FixtureRequest) -> StewartRobot:
    """The robots without symmetry: the paper preset (asymmetric platform) and the random
    robots (oblique U-joint axes, full inertia tensors, offset first moments)."""
    return get_robot(request.param)


#: The robots of the regressor and base-parameter tests.
PARAMETER_ROBOTS = ("simulator", "paper", "random-1", "random-6")


@pytest.fixture(scope="module", params=PARAMETER_ROBOTS)
def parameter_robot(request: pytest.FixtureRequest) -> StewartRobot:
    """Each of :data:`PARAMETER_ROBOTS`, built afresh for the module."""
    return StewartRobot.from_preset(request.param)


@pytest.fixture(scope="session")
def shared_compile_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One fresh cache folder for the session's compiled libraries (each build takes
    seconds, and the cache key is the description: the modules that compile the same
    robot share one build). Under pytest-xdist the workers share it too (the folder of
    the run, beside the workers' own: the cache's lock on each key folder makes a second
    worker wait for the first one's build and load it). Tests of the cache's own rules use
    folders of their own."""
    if "PYTEST_XDIST_WORKER" not in os.environ:  # one process
        return tmp_path_factory.mktemp("stewart-pin-shared-cache")
    path = tmp_path_factory.getbasetemp().parent / "stewart-pin-shared-cache"
    path.mkdir(mode=0o700, exist_ok=True)
    return path


@pytest.fixture(scope="session", autouse=True)
def session_compile_cache(shared_compile_cache: Path) -> Iterator[Path]:
    """Every compiled library of the session builds into :func:`shared_compile_cache`
    (never into the user's ``~/.cache/stewart-pin``): the modules that set no cache
    folder share the builds too."""
    yield from use_compile_cache(shared_compile_cache)


def use_compile_cache(path: Path) -> Iterator[Path]:
    """Body of a module's autouse fixture: the compiled backends build into ``path``
    (the environment variable set meanwhile)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(compiled_module.CACHE_ENV, str(path))
        yield path


@pytest.fixture
def rng() -> np.random.Generator:
    """A fresh generator with a fixed seed for each test."""
    return np.random.default_rng(20030917)


def needs_example_robot_data() -> pytest.MarkDecorator:
    """A skip mark for tests of payloads by name, when example-robot-data (the ``payload``
    extra) is not installed."""
    from stewart_pin.exceptions import MissingDependencyError
    from stewart_pin.models.payload import example_robot_names

    try:
        example_robot_names()
        missing = False
    except MissingDependencyError:
        missing = True
    return pytest.mark.skipif(
        missing, reason='example-robot-data is not installed (pip install "stewart-pin[payload]")'
    )
