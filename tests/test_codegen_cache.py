"""The compiled-model cache (issue 9, items 1 and 2): no text from a description reaches the
generated C; the cache key is the hash of the source itself; a library is loaded only
after its digest matches its manifest (otherwise it is rebuilt, atomically, safely under
concurrent processes); a cache others can write is refused.

Libraries are built here with ``build_library(..., load=None)`` (nothing loaded into this
process) before being tampered with, so that a corrupted file can never be mapped by the
test process itself; the truncated library is loaded in a subprocess."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from conftest import get_robot
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.codegen import CompiledDynamics, UnsafeCacheError
from stewart_pin.codegen import _identity as identity
from stewart_pin.codegen import compiled as compiled_module
from stewart_pin.codegen.compiled import build_library, c_source
from stewart_pin.kinematics.workspace import sample_states

TOL = 1e-10  # relative, compiled against the reference path
SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh private cache folder, also the default for the code under test."""
    path = tmp_path / "cache"
    monkeypatch.setenv(compiled_module.CACHE_ENV, str(path))
    return path


def _states(name: str, n: int = 10):
    robot = get_robot(name)
    P, V, A = sample_states(robot.description, n, 3)
    return robot, P, V, A, robot.inverse_dynamics(P, V, A)


def _with_name(desc, name: str):
    """``desc`` under ``name``, even one the description's validation would refuse (the
    generator must not depend on that validation)."""
    copy = desc.replace()
    object.__setattr__(copy, "name", name)
    return copy


# ---------------------------------------------------------------------------- item 1
def test_name_with_comment_close_cannot_inject_c(cache, tmp_path):
    """A robot name closing the C comment and defining a constructor used to run code when
    the library loaded; no text of the description reaches the source now."""
    marker = tmp_path / "injected"
    evil = (
        "x */ extern int creat(const char*, unsigned); __attribute__((constructor)) "
        f'static void sp_evil(void) {{ creat("{marker}", 0600); }} /* y'
    )
    plain = get_robot("paper").description
    desc = _with_name(plain, evil)
    source = c_source(desc)
    assert source == c_source(plain)  # the name shapes nothing
    assert "*/ extern" not in source and "creat" not in source and "sp_evil" not in source
    backend = CompiledDynamics(StewartRobot(desc))
    assert backend.kind == "compiled", backend.reason
    assert not marker.exists()
    _, P, V, A, G = _states("paper")
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    # The same geometry under any name shares the library.
    assert CompiledDynamics(StewartRobot(_with_name(plain, "other"))).library == backend.library


def test_cache_key_is_what_shapes_the_source(cache, monkeypatch):
    """Everything that shapes the source is in the key: the description's numbers and the
    generator's version (its source files, whose constants are compiled into the guard;
    a code change is simulated by another version string), without the source being
    generated to find a cached library (issue 24)."""
    desc = get_robot("random-1").description
    lib, built = build_library(desc)
    assert built
    assert lib.parent.name == compiled_module.cache_key(
        identity.library_identity(desc, "models"), compiled_module.find_compiler()
    )
    monkeypatch.setattr(compiled_module, "c_source", _no_source)
    again, built = build_library(desc)
    assert (again, built) == (lib, False)
    monkeypatch.undo()
    monkeypatch.setenv(compiled_module.CACHE_ENV, str(cache))
    monkeypatch.setattr(compiled_module, "LEG_SINGULARITY_SIN", 0.5)
    version = identity.generator_version()
    monkeypatch.setattr(identity, "_GENERATOR_VERSION", [version + " edited"])
    other, built = build_library(desc)
    assert built and other.parent != lib.parent
    assert "0.25" in (other.parent / "stewart_models.c").read_text()  # 0.5^2, compiled in


def _no_source(desc):
    raise AssertionError("the C source was generated to find a cached library")


# ---------------------------------------------------------------------------- item 2
def test_library_copied_from_another_geometry_is_rebuilt(cache):
    """The library (and manifest) of another robot copied over this robot's: the mismatch is
    detected and the library rebuilt; the forces are right (they were 100x off)."""
    robot, P, V, A, G = _states("random-1")
    mine, _ = build_library(robot.description)
    theirs, _ = build_library(get_robot("simulator").description)
    for name in ("libstewart_models.so", "manifest.json"):
        shutil.copyfile(theirs.parent / name, mine.parent / name)
    with pytest.warns(RuntimeWarning, match="manifest names another key"):
        backend = CompiledDynamics(robot)
    assert backend.kind == "compiled" and backend.compiled_now
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    assert rel_error(backend.direct_dynamics(P, V, G), robot.direct_dynamics(P, V, G)) < TOL
    # Only the library copied (its own manifest kept): the digest no longer matches.
    other, _ = build_library(get_robot("desktop").description)
    shutil.copyfile(theirs, other)
    with pytest.warns(RuntimeWarning, match="does not match its manifest"):
        _, built = build_library(get_robot("desktop").description)
    assert built
    manifest = json.loads((other.parent / "manifest.json").read_text())
    assert manifest["sha256"] == compiled_module._sha256(other)[0]


def test_truncated_library_is_rebuilt_without_sigbus(cache):
    """A library cut short (a full disk, a killed copy) killed every later run with SIGBUS;
    now it is detected before loading and rebuilt (checked in a subprocess)."""
    lib, _ = build_library(get_robot("paper").description)
    size = lib.stat().st_size
    with open(lib, "r+b") as f:
        f.truncate(size // 2)
    script = textwrap.dedent(
        """
        import warnings
        import numpy as np
        from stewart_pin import StewartRobot
        from stewart_pin.codegen import CompiledDynamics
        robot = StewartRobot.from_preset("paper")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            backend = CompiledDynamics(robot)
        T = robot.home_pose
        V, A = np.full(6, 0.1), np.full(6, 0.2)
        g = backend.inverse_dynamics(T, V, A)
        ref = robot.inverse_dynamics(T, V, A)
        print(backend.kind, backend.compiled_now, float(np.abs(g - ref).max() / np.abs(ref).max()))
        print(" | ".join(str(w.message) for w in caught))
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC, compiled_module.CACHE_ENV: str(cache)}
    run = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300
    )
    assert run.returncode == 0, run.stderr[-2000:]
    kind, compiled_now, err = run.stdout.splitlines()[0].split()
    assert (kind, compiled_now) == ("compiled", "True")
    assert float(err) < TOL
    assert "does not match its manifest" in run.stdout
    assert lib.stat().st_size == size


@pytest.mark.parametrize("target", ["root", "folder", "library", "manifest"])
def test_cache_writable_by_others_is_refused(cache, target):
    """A cache folder or file that group or others can write is refused with a named error
    (it used to be loaded): nothing is loaded, no fallback hides it."""
    robot = StewartRobot(get_robot("paper").description)
    lib, _ = build_library(robot.description)
    path = {
        "root": cache,
        "folder": lib.parent,
        "library": lib,
        "manifest": lib.parent / "manifest.json",
    }[target]
    os.chmod(path, path.stat().st_mode | 0o022)
    with pytest.raises(UnsafeCacheError, match="writable by group or others") as e:
        CompiledDynamics(robot)
    assert e.value.path == path
    with pytest.raises(UnsafeCacheError):
        robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6), backend="compiled")
    os.chmod(path, path.stat().st_mode & ~0o022)
    assert CompiledDynamics(robot).kind == "compiled"


def test_cache_of_another_user_or_a_symlink_is_refused(cache, monkeypatch, tmp_path):
    """(Another owner is simulated: the effective user id is patched.)"""
    robot = StewartRobot(get_robot("paper").description)
    lib, _ = build_library(robot.description)
    with monkeypatch.context() as mp:
        mp.setattr(compiled_module.os, "geteuid", lambda: os.getuid() + 1)
        with pytest.raises(UnsafeCacheError, match="belongs to user id"):
            CompiledDynamics(robot)
    elsewhere = tmp_path / "elsewhere.so"
    shutil.move(lib, elsewhere)
    os.symlink(elsewhere, lib)
    with pytest.raises(UnsafeCacheError, match="symbolic link"):
        CompiledDynamics(robot)


def test_new_cache_folders_and_files_are_private(tmp_path):
    """Whatever the umask, the cache is created 0700 and its files without group or other
    write permission (a permissive umask must not make the next run refuse it)."""
    old = os.umask(0o002)
    try:
        lib, built = build_library(get_robot("paper").description, tmp_path / "new" / "cache")
    finally:
        os.umask(old)
    assert built
    for path in (lib.parent.parent, lib.parent):
        assert path.stat().st_mode & 0o777 == 0o700
    for path in lib.parent.iterdir():
        assert path.stat().st_mode & 0o022 == 0, path


def test_concurrent_processes_build_once(cache):
    """Two processes asking for the same library at once: one compiles, the other waits on
    the lock and loads the verified result; neither sees a partial file."""
    script = textwrap.dedent(
        """
        from stewart_pin import StewartRobot
        from stewart_pin.codegen import CompiledDynamics
        robot = StewartRobot.from_preset("random-2")
        b = CompiledDynamics(robot)
        print(b.kind, b.compiled_now)
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC, compiled_module.CACHE_ENV: str(cache)}
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", script],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for _ in range(2)
    ]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e[-2000:] for _, e in outs]
    results = sorted(o.split()[-2:][1] for o, _ in outs)
    assert [o.split()[-2] for o, _ in outs] == ["compiled", "compiled"]
    assert results == ["False", "True"]
    folders = [p for p in cache.iterdir() if p.is_dir()]
    assert len(folders) == 1
    leftovers = [p.name for p in folders[0].iterdir() if p.name.endswith(".tmp")]
    assert not leftovers
