"""The compiled-model cache (issue 9, items 1 and 2): no text from a description reaches the
generated C; the cache key is the hash of the source itself; a library is loaded only
after its digest matches its manifest (otherwise it is rebuilt, atomically, safely under
concurrent processes); a cache others can write is refused.

Libraries are tampered with in a private cache folder per test, as copies of the key
folders of the session's shared cache (:func:`prebuilt`; a file there may be mapped by
this process, its copy never is) or built there with ``build_library(..., load=None)``
(nothing loaded into this process), so that a corrupted file can never be mapped by the
test process itself; the truncated library is loaded in a subprocess."""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import get_robot
from helpers import rel_error

import stewart_pin
from stewart_pin import StewartRobot
from stewart_pin.codegen import CompiledDynamics, UnsafeCacheError
from stewart_pin.codegen import _architecture as codegen_architecture
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


@pytest.fixture
def prebuilt(cache: Path, shared_compile_cache: Path) -> Callable[[Any], Path]:
    """``prebuilt(desc)``: ``desc``'s library, as :func:`build_library` makes it, in the
    private ``cache``: built (or found) in the session's shared cache and its key folder
    copied (each build takes seconds; these tests are of the cache's rules, and the
    library's numbers are tested where it is built). Returns the library's path in
    ``cache``."""

    def make(desc: Any) -> Path:
        lib, _ = build_library(desc, shared_compile_cache)
        cache.mkdir(mode=0o700, exist_ok=True)
        folder = shutil.copytree(lib.parent, cache / lib.parent.name)
        return Path(folder) / lib.name

    return make


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
def test_name_with_comment_close_cannot_inject_c(cache, prebuilt, tmp_path):
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
    prebuilt(plain)  # the same source: the same library
    backend = CompiledDynamics(StewartRobot(desc))
    assert backend.kind == "compiled", backend.reason
    assert not marker.exists()
    _, P, V, A, G = _states("paper")
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    # The same geometry under any name shares the library.
    assert CompiledDynamics(StewartRobot(_with_name(plain, "other"))).library == backend.library


def test_cache_key_is_what_shapes_the_source(cache, prebuilt, monkeypatch):
    """Everything that shapes the source is in the key: the description's numbers and the
    generator's version (its source files, whose constants are compiled into the guard;
    a code change is simulated by another version string), without the source being
    generated to find a cached library (issue 24)."""
    desc = get_robot("random-1").description
    lib = prebuilt(desc)
    assert lib.parent.name == compiled_module.cache_key(
        identity.library_identity(desc, "models"), compiled_module.find_compiler()
    )
    monkeypatch.setattr(compiled_module, "c_source", _no_source)
    again, built = build_library(desc)
    assert (again, built) == (lib, False)
    monkeypatch.undo()
    monkeypatch.setenv(compiled_module.CACHE_ENV, str(cache))
    monkeypatch.setattr(codegen_architecture, "LEG_SINGULARITY_SIN", 0.5)  # the 6-UPS guard's
    version = identity.generator_version()
    monkeypatch.setattr(identity, "_GENERATOR_VERSION", [version + " edited"])
    other, built = build_library(desc)
    assert built and other.parent != lib.parent
    assert "0.25" in (other.parent / "stewart_models.c").read_text()  # 0.5^2, compiled in


def _no_source(desc):
    raise AssertionError("the C source was generated to find a cached library")


# ---------------------------------------------------------------------------- item 2
def test_library_copied_from_another_geometry_is_rebuilt(cache, prebuilt):
    """The library (and manifest) of another robot copied over this robot's: the mismatch is
    detected and the library rebuilt; the forces are right (they were 100x off)."""
    robot, P, V, A, G = _states("random-1")
    mine = prebuilt(robot.description)
    theirs = prebuilt(get_robot("simulator").description)
    for name in ("libstewart_models.so", "manifest.json"):
        shutil.copyfile(theirs.parent / name, mine.parent / name)
    with pytest.warns(RuntimeWarning, match="manifest names another key"):
        backend = CompiledDynamics(robot)
    assert backend.kind == "compiled" and backend.compiled_now
    assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
    assert rel_error(backend.direct_dynamics(P, V, G), robot.direct_dynamics(P, V, G)) < TOL
    # Only the library copied (its own manifest kept): the digest no longer matches.
    other = prebuilt(get_robot("desktop").description)
    shutil.copyfile(theirs, other)
    with pytest.warns(RuntimeWarning, match="does not match its manifest"):
        _, built = build_library(get_robot("desktop").description)
    assert built
    manifest = json.loads((other.parent / "manifest.json").read_text())
    assert manifest["sha256"] == compiled_module._sha256(other)[0]


def test_truncated_library_is_rebuilt_without_sigbus(cache, prebuilt):
    """A library cut short (a full disk, a killed copy) killed every later run with SIGBUS;
    now it is detected before loading and rebuilt (checked in a subprocess)."""
    lib = prebuilt(get_robot("paper").description)
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
def test_cache_writable_by_others_is_refused(cache, prebuilt, target):
    """A cache folder or file that group or others can write is refused with a named error
    (it used to be loaded): nothing is loaded, no fallback hides it."""
    robot = StewartRobot(get_robot("paper").description)
    lib = prebuilt(robot.description)
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


def test_cache_of_another_user_or_a_symlink_is_refused(cache, prebuilt, monkeypatch, tmp_path):
    """(Another owner is simulated: the effective user id is patched.)"""
    robot = StewartRobot(get_robot("paper").description)
    lib = prebuilt(robot.description)
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


# ---------------------------------------------------------------------------- issue 25
@pytest.fixture
def read_only(monkeypatch):
    """``read_only(folder)``: ``folder`` made read-only (mode 0500). The superuser ignores
    modes, so under root the kernel's answer to a non-root user is reproduced: creating or
    opening for writing a file in the folder fails with EACCES, and ``os.access`` says the
    folder is not writable."""

    def make(folder: Path) -> None:
        os.chmod(folder, 0o500)
        if os.geteuid() != 0:
            return
        real_open, real_access = os.open, os.access
        writes = os.O_WRONLY | os.O_RDWR | os.O_CREAT

        def fake_open(path, flags, *args, **kwargs):
            if Path(path).parent == folder and flags & writes:
                raise PermissionError(13, "Permission denied", str(path))
            return real_open(path, flags, *args, **kwargs)

        def fake_access(path, mode, *args, **kwargs):
            if Path(path) == folder and mode & os.W_OK:
                return False
            return real_access(path, mode, *args, **kwargs)

        def fake_mkdir(path, *args, **kwargs):
            if Path(path).parent == folder:
                raise PermissionError(13, "Permission denied", str(path))
            return real_mkdir(path, *args, **kwargs)

        real_mkdir = os.mkdir
        monkeypatch.setattr(os, "open", fake_open)
        monkeypatch.setattr(os, "access", fake_access)
        monkeypatch.setattr(os, "mkdir", fake_mkdir)

    yield make


def test_read_only_cache_with_a_valid_library_is_used(cache, prebuilt, read_only):
    """A read-only key folder holding a verified library: loaded (the lock's O_RDWR open
    failed, and the backend fell back to the virtual machine); without a valid library,
    or in a read-only cache without the key folder, the error says the folder is
    read-only; the safety checks still hold."""
    robot, P, V, A, G = _states("paper")
    lib = prebuilt(robot.description)
    (lib.parent / ".lock").unlink()  # as a cache copied without its lock file
    read_only(lib.parent)
    try:
        backend = CompiledDynamics(robot)
        assert (backend.kind, backend.compiled_now, backend.library) == ("compiled", False, lib)
        assert rel_error(backend.inverse_dynamics(P, V, A), G) < TOL
        other = StewartRobot(get_robot("desktop").description)
        other_lib = prebuilt(other.description)
        read_only(other_lib.parent)
        os.chmod(other_lib.parent, 0o700)
        other_lib.unlink()
        os.chmod(other_lib.parent, 0o500)
        with pytest.raises(compiled_module.CompilationError, match="read-only and holds no"):
            CompiledDynamics(other, vm_fallback=False)
        read_only(cache)  # a read-only cache without the robot's key folder
        third = StewartRobot(get_robot("simulator").description)
        with pytest.raises(compiled_module.CompilationError, match=r"cannot be written .* no lib"):
            CompiledDynamics(third, vm_fallback=False)
        os.chmod(lib.parent, 0o520)  # group-writable: refused, read-only or not
        with pytest.raises(UnsafeCacheError, match="writable by group or others"):
            CompiledDynamics(robot)
    finally:
        os.chmod(cache, 0o700)
        for folder in cache.iterdir():
            os.chmod(folder, 0o700)


def _fake_compiler(tmp_path: Path, seconds: float) -> tuple[Path, Path]:
    """A "compiler" that answers ``--version`` and otherwise sleeps ``seconds`` (its pid in
    the second path returned)."""
    pid = tmp_path / "cc.pid"
    script = tmp_path / "slow-cc"
    script.write_text(
        "#!/bin/sh\n"
        'if [ "$1" = "--version" ]; then echo slow-cc 1.0; exit 0; fi\n'
        f'echo $$ > "{pid}"\n'
        f"exec sleep {seconds}\n"
    )
    script.chmod(0o755)
    return script, pid


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return (
        Path(f"/proc/{pid}").exists()
        and "zombie" not in Path(f"/proc/{pid}/status").read_text().lower()
    )


def test_hanging_compiler_is_announced_and_stopped(cache, tmp_path, monkeypatch, capsys):
    """A compiler that hangs blocked the first call for 600 s after a line saying "about
    1 s": the line gives the timeout ($STEWART_PIN_COMPILE_TIMEOUT), a line follows every
    PROGRESS_EVERY seconds, and at the timeout the compiler is killed and the build fails
    by name (backend='auto' then takes the reference path); no temporary is left."""
    cc, pid_file = _fake_compiler(tmp_path, 60)
    monkeypatch.setenv(compiled_module.COMPILE_TIMEOUT_ENV, "1.2")
    monkeypatch.setattr(compiled_module, "PROGRESS_EVERY", 0.3)
    desc = get_robot("paper").description
    with pytest.raises(compiled_module.CompilationError, match=r"did not finish within 1.2 s"):
        build_library(desc, compiler=str(cc), announce=True)
    err = capsys.readouterr().err.splitlines()
    assert "stopped at 1.2 s" in err[0] and re.search(r"about \d+ s", err[0]), err
    progress = [line for line in err if "still compiling" in line]
    assert len(progress) >= 2, err
    assert not _alive(int(pid_file.read_text()))
    folder = next(p for p in cache.iterdir() if p.is_dir())
    assert not [p.name for p in folder.iterdir() if p.name.endswith(".tmp")]
    for bad in ("0", "-1", "nan", "soon"):
        monkeypatch.setenv(compiled_module.COMPILE_TIMEOUT_ENV, bad)
        with pytest.raises(stewart_pin.InputError, match="STEWART_PIN_COMPILE_TIMEOUT"):
            build_library(desc, compiler=str(cc))


def test_temporaries_of_a_killed_build_are_swept(cache, tmp_path):
    """A build killed mid-way (SIGKILL: no clean-up runs) left its temporary source and
    library in the key folder for ever; the next use of the folder removes them (under
    its lock, which every build holds while its temporaries exist), and nothing else."""
    pid_file = tmp_path / "cc.pid"
    cc = tmp_path / "cc-wrapper"  # the system compiler, or a hang when $SP_HANG is set
    cc.write_text(
        "#!/bin/sh\n"
        'if [ -n "$SP_HANG" ] && [ "$1" != --version ]; then\n'
        f'  echo $$ > "{pid_file}"; exec sleep 60\n'
        "fi\n"
        f'exec "{compiled_module.find_compiler()}" "$@"\n'
    )
    cc.chmod(0o755)
    script = textwrap.dedent(
        f"""
        from stewart_pin.description.presets import preset
        from stewart_pin.codegen.compiled import build_library
        build_library(preset("paper"), compiler={str(cc)!r})
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC, compiled_module.CACHE_ENV: str(cache), "SP_HANG": "1"}
    proc = subprocess.Popen([sys.executable, "-c", script], env=env)
    try:
        for _ in range(600):  # until the compiler runs (its pid written), at most 60 s
            if pid_file.exists() and pid_file.read_text().strip():
                break
            proc.poll()
            assert proc.returncode is None, "the build ended early"
            time.sleep(0.1)
        proc.kill()
        proc.wait(timeout=30)
    finally:
        with contextlib.suppress(Exception):
            os.kill(int(pid_file.read_text()), 9)
    folder = next(p for p in cache.iterdir() if p.is_dir())
    stale = sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))
    assert any(n.startswith(".libstewart_models.so.") for n in stale), stale
    (folder / "notes.tmp").write_text("not a build's")
    lib, built = build_library(get_robot("paper").description, compiler=str(cc))
    assert built and lib.parent == folder
    left = sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))
    assert left == ["notes.tmp"]
