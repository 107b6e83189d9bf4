"""Fast evaluation of the generated models: C compiled once per robot, or CasADi's VM.

:class:`CompiledDynamics` turns the symbolic models of :mod:`.symbolic` into a shared
library: CasADi writes the C of the guarded IDM and DDM, :mod:`._csource` adds a loop over
N states and a guard per state, the system C compiler builds it (``-O2``, no
``-march=native``, so a cached library stays valid on any machine of the same kind), and
:mod:`ctypes` loads it. Compiling takes a few seconds (up to half a minute for the largest
chain legs); ``$STEWART_PIN_BUILD=quick`` (:func:`model_cflags`) builds without
optimisation instead, 3-7x sooner, for calls 1.4-3.5x slower one at a time and 4-9x slower
per state in batches: for a study that meets many geometries and evaluates each a few
thousand times.

The cache. Libraries are kept under ``$STEWART_PIN_CACHE`` (default
``~/.cache/stewart-pin``), one folder per :func:`cache_key`: the SHA-256 of what the
library is made from, the compiler (resolved path and ``--version`` output) and the flags.
What it is made from is, for a robot, :func:`._identity.library_identity`: the
description's canonical serialisation (every field, name excepted: the numbers baked into
the C) and :func:`._identity.generator_version` (a digest of the generator's source files
and CasADi's version, computed once per process), so that a new process finds its library
without regenerating the C source, and a change of the robot or of the code that writes
the C gives another key (robots that differ only in their name share a library; no text
from a description or an argument enters the source). A description that cannot be
serialised so is keyed by its generated C source itself. Integrity rules:

- the cache folder, each key folder and every file in them must belong to the current
  user and not be writable by group or others (no symbolic links): otherwise
  :class:`UnsafeCacheError` is raised and nothing is loaded (fix the permissions, or point
  ``$STEWART_PIN_CACHE`` at a private folder). Folders are created ``0700``, files
  ``0644`` / ``0755``, whatever the umask;
- a library is loaded only after its SHA-256 and size match its manifest
  (``manifest.json``, written when it was built, naming the key); a missing, truncated,
  replaced (e.g. copied from another robot) or unreadable library is rebuilt, with a
  :class:`RuntimeWarning` saying so;
- a build compiles into a temporary file in the key folder, then renames the library and
  its manifest into place (``os.replace``); verification and build hold an exclusive
  ``fcntl`` lock on the key folder's ``.lock`` file, so concurrent processes neither see a
  half-written library nor build it twice.

Calls. A single state (native float64 arrays) is passed to ``sp_idm_one`` / ``sp_ddm_one``
as the bytes of its three arrays in one block, the result written into a preallocated
buffer per backend whose address is taken once (a plain ctypes call on prepared
arguments); the C guard does the validation (the Python checks run only for a state it
flags, to raise the reference's error). A batch of N states runs the C loop on
:attr:`CompiledDynamics.threads` threads (``$STEWART_PIN_THREADS``, default
``os.cpu_count()``; pass ``threads=`` to the constructor), each on a contiguous slice of at
least :data:`THREAD_MIN_STATES` states; ctypes releases the GIL around each call, so the
slices run in parallel (process-wide pool, the calling thread takes the first slice).

Without a C compiler (or when compiling or loading fails), the same functions run in
CasADi's virtual machine: correct, slower, with one warning giving the reason.

Validation. The results are those of the reference path (``StewartRobot.inverse_dynamics``
/ ``direct_dynamics``), errors included: the C guard checks each state cheaply (finite
inputs, orthonormal rotation, leg lengths within the stroke and away from the leg
singularities from the generated code's ``q3^2`` and ``rho^2``, U-joint angles within their
limits (if any) from the rows of ``Jp^-1``, and an upper bound of the
singularity measure); any state it flags sends the batch through the reference checks
(:func:`stewart_pin._checks.check_poses`,
:func:`stewart_pin.kinematics.geometry.inverse_geometry_batch`,
:func:`stewart_pin.kinematics.jacobians.check_condition` on the flagged states), which raise
:class:`~stewart_pin.exceptions.InputError`, :class:`~stewart_pin.exceptions.StrokeLimitError`,
:class:`~stewart_pin.exceptions.JointLimitError` or
:class:`~stewart_pin.exceptions.SingularityError` with the reference's messages. The
IDM's static-pivot LU is backed by a partial-pivoting solve in C when a multiplier grows
past :data:`._csource.GROWTH_LIMIT`.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import json
import math
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from stewart_pin._checks import ROTATION_TOLERANCE, check_array, check_states
from stewart_pin._lazy import casadi as cs  # imported on first use
from stewart_pin.codegen import _csource, _simd
from stewart_pin.codegen._architecture import UPS_AUX_LAYOUT as UPS_AUX_LAYOUT  # its old home
from stewart_pin.codegen._architecture import codegen_kind, generate_models
from stewart_pin.codegen._csource import FLAG_NAMES, GROWTH_LIMIT
from stewart_pin.codegen._identity import library_identity
from stewart_pin.codegen.leg_chain_symbolic import (
    GENERAL_GENERATOR_VERSION,
    AuxLayout,
)
from stewart_pin.codegen.symbolic import (
    GENERATOR_VERSION,
)
from stewart_pin.exceptions import (
    CompilationError,
    InputError,
    UnsafeCacheError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics.jacobians import (
    scaled_inverse_jacobian,
)
from stewart_pin.protocols import RobotLike

if TYPE_CHECKING:
    from concurrent.futures import ThreadPoolExecutor

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: no lock (one process at a time)
    fcntl = None  # type: ignore[assignment]

#: Environment variable overriding the cache folder.
CACHE_ENV = "STEWART_PIN_CACHE"
#: Compiler flags (no -march=native: the cached library must run on any x86-64 of the kind).
CFLAGS = (
    "-O2",
    "-fno-math-errno",
    "-freciprocal-math",  # x / y with a shared y -> x * (1 / y): CasADi writes divisions
    "-fPIC",
    "-shared",
    "-fvisibility=hidden",
)
#: The flags of a library built for its first use in seconds rather than for speed: no
#: optimisation (the register allocation of -O1/-O2 grows faster than linearly with the
#: size of CasADi's one straight-line function: on the exact derivatives, about 2.7 s at
#: -O0 against 17 s at -O1 and 45-50 s at -O2; the calls take about 2x longer).
QUICK_CFLAGS = ("-O0", *CFLAGS[1:])
#: Environment variable: how the models' libraries are compiled (:func:`model_cflags`).
BUILD_ENV = "STEWART_PIN_BUILD"
#: The values of ``$STEWART_PIN_BUILD`` and their flags.
BUILD_FLAGS = {"optimised": CFLAGS, "quick": QUICK_CFLAGS}
#: Libraries linked (after the source).
LDLIBS = ("-lm",)
#: Environment variable: the longest a compilation may take [s] (default
#: :data:`COMPILE_TIMEOUT`); past it the compiler is stopped and the build fails.
COMPILE_TIMEOUT_ENV = "STEWART_PIN_COMPILE_TIMEOUT"
#: The longest a compilation may take by default [s].
COMPILE_TIMEOUT = 600.0
#: While an announced compilation runs, a line on stderr every this many seconds [s].
PROGRESS_EVERY = 15.0
#: Environment variable: threads sharing a compiled batch (default ``os.cpu_count()``).
THREADS_ENV = "STEWART_PIN_THREADS"
#: Fewest states per thread for a batch to be split (below, the hand-off costs more).
THREAD_MIN_STATES = 512
#: States per CasADi VM call in the fallback.
VM_CHUNK = 4096

_GEOMETRY, _COND = FLAG_NAMES["GEOMETRY"], FLAG_NAMES["COND"]
_NOT_PD, _NONFINITE = FLAG_NAMES["NOT_PD"], FLAG_NAMES["NONFINITE"]
_REPIVOTED = FLAG_NAMES["REPIVOTED"]
_LIB_NAME = "libstewart_models.so"
_SOURCE_NAME = "stewart_models.c"
_MANIFEST_NAME = "manifest.json"
_LOCK_NAME = ".lock"
_WARNED: set[str] = set()
_COMPILER_IDS: dict[str, str] = {}


def cache_root() -> Path:
    """The cache folder: ``$STEWART_PIN_CACHE`` or ``~/.cache/stewart-pin``."""
    env = os.environ.get(CACHE_ENV)
    return Path(env).expanduser() if env else Path.home() / ".cache" / "stewart-pin"


def find_compiler() -> str | None:
    """The C compiler: ``$CC`` if it is on the PATH, else ``cc``, ``gcc`` or ``clang``."""
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name:
            path = shutil.which(name)
            if path:
                return path
    return None


def compiler_identity(compiler: str) -> str:
    """The compiler as it enters the cache key: its resolved path and the output of
    ``compiler --version`` (empty when that fails); cached per process."""
    path = os.path.realpath(shutil.which(compiler) or compiler)
    if path not in _COMPILER_IDS:
        try:
            run = subprocess.run(
                [path, "--version"],
                capture_output=True,
                text=True,
                timeout=min(60.0, compile_timeout()),
                check=False,
            )
            version = run.stdout.strip() if run.returncode == 0 else ""
        except (OSError, subprocess.SubprocessError):
            version = ""
        _COMPILER_IDS[path] = f"{path}\n{version}"
    return _COMPILER_IDS[path]


def compile_timeout() -> float:
    """The longest a compilation may take [s]: ``$STEWART_PIN_COMPILE_TIMEOUT`` if set (a
    positive number of seconds; anything else raises
    :class:`~stewart_pin.exceptions.InputError`), else :data:`COMPILE_TIMEOUT`."""
    env = (os.environ.get(COMPILE_TIMEOUT_ENV) or "").strip()
    if not env:
        return COMPILE_TIMEOUT
    try:
        value = float(env)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise InputError(
            f"${COMPILE_TIMEOUT_ENV} must be a positive number of seconds (how long a "
            f"compilation may take), got {env[:40]!r}; unset it for {COMPILE_TIMEOUT:g} s"
        )
    return value


def model_cflags() -> tuple[str, ...]:
    """The compiler flags of the models' libraries, from ``$STEWART_PIN_BUILD``:
    ``optimised`` (the default, :data:`CFLAGS`) or ``quick`` (:data:`QUICK_CFLAGS`: no
    optimisation; on this project's 2-core machine a library builds 3-7x sooner, 4.5 s
    against 31 s for the 1.8 MB of C of ``welded-ups``, and a call takes 1.4-3.5x longer
    for one state, 4-9x per state in a batch: ``scripts/bench_build_flags.py``). Part of
    the cache key: both builds of a robot are kept.
    Anything else raises :class:`~stewart_pin.exceptions.InputError`. The exact
    derivatives are always built quick (:mod:`.derivatives`), the simulator always
    optimised (:mod:`.simulator`)."""
    env = (os.environ.get(BUILD_ENV) or "").strip()
    if not env:
        return CFLAGS
    if env not in BUILD_FLAGS:
        raise InputError(
            f"${BUILD_ENV} must be 'optimised' (the default) or 'quick' (libraries built "
            f"without optimisation, 3-7x sooner), got {env[:40]!r}"
        )
    return BUILD_FLAGS[env]


def cache_key(source: str, compiler: str, cflags: tuple[str, ...] | None = None) -> str:
    """The name of a library's cache folder: the SHA-256 (first 32 hex digits) of the C
    ``source`` (:func:`c_source`) or of what it is made from (:func:`library_identity`),
    the compiler (:func:`compiler_identity`) and the flags (``cflags``, default
    :func:`model_cflags`; and :data:`LDLIBS`)."""
    cflags = model_cflags() if cflags is None else cflags
    h = hashlib.sha256()
    for part in (source, compiler_identity(compiler), " ".join(cflags), " ".join(LDLIBS)):
        data = part.encode()
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()[:32]


def model_layout(desc: Any) -> AuxLayout:
    """Where the guarded models of ``desc`` put their by-products
    (:data:`UPS_AUX_LAYOUT` for the paper's 6-UPS robot)."""
    return codegen_kind(desc).model_layout(desc)


def singularity_length(desc: Any) -> float:
    """The length the parallel singularity measure divides ``Jp^-1``'s angular columns by:
    the characteristic length (6-UPS), the platform radius ``GeneralHexapod.size``
    (general legs), as the reference path does."""
    return codegen_kind(desc).singularity_length(desc)


def leg_checks_source(desc: Any, layout: AuxLayout) -> str:
    """The C of ``sp_check_legs`` for ``desc``: the 6-UPS leg lengths and leg
    singularities (:data:`._csource.CHECK_LEGS_UPS`, the thresholds of
    :mod:`stewart_pin.kinematics.geometry` with margins), or every slack of the general
    models positive (:data:`._csource.CHECK_LEGS_GENERAL`)."""
    return codegen_kind(desc).leg_checks_source(desc, layout)


def guard_numbers(desc: Any, layout: AuxLayout) -> dict[str, Any]:
    """The %-keys of :data:`._csource.GUARDS` for ``desc`` (``check_legs``: the C of
    :func:`leg_checks_source`, the rotation tolerance, the pivot growth limit and 1 / the
    singularity measure's length [1/m]): the robot library's and the legs-as-lanes
    library's guards (:mod:`.lanes`)."""
    return {
        "check_legs": leg_checks_source(desc, layout),
        "rotation_tol": ROTATION_TOLERANCE * (1.0 - 1e-3),
        "growth_limit": GROWTH_LIMIT,
        "inv_length": 1.0 / singularity_length(desc),
    }


def c_source(desc: Any) -> str:
    """The C source of a robot's library: CasADi's generated IDM and DDM (guarded
    variants) followed by the batch loops and guards of :mod:`._csource` (the leg checks
    of the 6-UPS models, or the general models' slacks).

    Only numbers enter it (the geometry, the thresholds): no name or other text from the
    description."""
    models = generate_models(desc)
    cg = cs.CodeGenerator(
        _SOURCE_NAME,
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    cg.add(models.idm_guarded)
    cg.add(models.ddm_guarded)
    kind = codegen_kind(desc)
    act = actuated_positions_function(desc) if kind.compiled_actuators else None
    if act is not None:
        cg.add(act)
    layout = model_layout(desc)
    fi, fd = models.idm_guarded, models.ddm_guarded
    wrapper = _csource.TEMPLATE % {
        **guard_numbers(desc, layout),
        "idm_naux": layout.idm_size,
        "ddm_naux": layout.ddm_size,
        **_csource.layout_numbers(layout),
        "idm": fi.name(),
        "ddm": fd.name(),
        **{f"idm_sz_{k}": getattr(fi, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
        **{f"ddm_sz_{k}": getattr(fd, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
    }
    code = cg.dump()
    vec, written = _simd.vector_source(
        code, {fi.name(): "sp_idm_vec", fd.name(): "sp_ddm_vec"}, shared=frozenset({3})
    )
    defines = "".join(f"#define SP_VEC_{v[3:6].upper()} 1\n" for v in sorted(written))
    defines += avx2_copy(code, fd.name(), "sp_ddm_avx2", "SP_DDM_AVX2")
    defines += avx2_copy(code, fi.name(), "sp_idm_avx2", "SP_IDM_AVX2")
    if act is not None:
        wrapper += _csource.ACTUATORS % {
            "act": act.name(),
            **{f"sz_{k}": getattr(act, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
        }
    return (
        f"/* Generated by stewart-pin (see codegen/_csource.py). */\n{code}\n{vec}\n"
        f"{defines}{wrapper}"
    )


def avx2_copy(source: str, name: str, new: str, flag: str) -> str:
    """The C of ``new``, a copy of the CasADi function the exported ``name`` of ``source``
    calls, compiled for AVX2 and FMA with contraction allowed (a product and a sum may
    round once: results within a few units in the last place of the baseline copy's, in
    fewer instructions), defining ``flag`` and ``sp_avx2_ready`` (whether the processor
    has AVX2 and FMA; :data:`._csource.AVX2_COPY`); "" where the function is not one
    straight-line body (it calls sub-functions). Where the compiler is not a GNU one on
    x86, the copy is left out by the preprocessor."""
    m = re.search(
        r"int " + re.escape(name) + r"\(const casadi_real\*\* arg[^{]*\{\s*return (casadi_f\d+)\(",
        source,
    )
    if m is None:
        return ""
    body = re.search(
        r"\nstatic int " + m.group(1) + r"\(const casadi_real\*\* arg.*?\n\}\n", source, re.S
    )
    if body is None or re.search(r"\bcasadi_f\d+\(", body.group(0)[body.group(0).index("{") :]):
        return ""
    code = body.group(0).replace(f"static int {m.group(1)}(", f"SP_AVX2 static int {new}(", 1)
    brace = code.index("{") + 1  # Clang contracts within a statement only, unless told
    code = (
        f"{code[:brace]}\n#ifdef __clang__\n#pragma clang fp contract(fast)\n#endif{code[brace:]}"
    )
    return _csource.AVX2_COPY % {"code": code, "flag": flag}


def actuated_positions_function(desc: Any) -> cs.Function:
    """``stewart_act(pose) -> q_a``: the six actuated joint values [m or rad] of a pose
    (0Tp row-major, 16), :meth:`~._architecture.CodegenKind.actuator_function`'s values
    (the reference's: a revolute joint taken into its limits) without the rates."""
    f = codegen_kind(desc).actuator_function(desc)
    x = cs.SX.sym("pose", 16)
    q_a = f(x, cs.SX.zeros(6))[0]
    return cs.Function("stewart_act", [x], [q_a], ["pose"], ["q_a"])


# ---------------------------------------------------------------------------- the cache
def _check_private(path: Path, kind: str, follow: bool = False) -> os.stat_result | None:
    """The ``os.stat`` of ``path`` (None if absent) after checking that it is a ``kind``
    (``"dir"`` or ``"file"``) of the current user that group and others cannot write, and
    (unless ``follow``) not a symbolic link. Raises :class:`UnsafeCacheError`."""
    try:
        st = os.stat(path) if follow else os.lstat(path)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(st.st_mode):
        raise UnsafeCacheError(path, "it is a symbolic link")
    if kind == "dir" and not stat.S_ISDIR(st.st_mode):
        raise UnsafeCacheError(path, "it is not a folder")
    if kind == "file" and not stat.S_ISREG(st.st_mode):
        raise UnsafeCacheError(path, "it is not a regular file")
    if os.name != "posix":  # pragma: no cover - no owners or group bits to check
        return st
    uid = os.geteuid()
    if st.st_uid != uid:
        raise UnsafeCacheError(path, f"it belongs to user id {st.st_uid}, not to you ({uid})")
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise UnsafeCacheError(
            path, f"it is writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
        )
    return st


def _private_dir(path: Path, follow: bool = False) -> None:
    """Create ``path`` (mode 0700) if absent; check it is private (:func:`_check_private`)."""
    if _check_private(path, "dir", follow) is None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(FileExistsError):  # another process made it meanwhile
            path.mkdir(mode=0o700)
        _check_private(path, "dir", follow)


@contextlib.contextmanager
def _locked(folder: Path) -> Iterator[bool]:
    """An exclusive lock on ``folder/.lock`` (blocking) for the duration of the block;
    yields whether the folder can be written. A folder that cannot be written (a
    read-only cache: its mode, a read-only file system) is read under a shared lock when
    its ``.lock`` exists, else without one (no process can build in it either)."""
    if fcntl is None:  # pragma: no cover
        yield True
        return
    lock = folder / _LOCK_NAME
    nofollow = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    writable = True
    try:
        fd: int | None = os.open(lock, os.O_RDWR | os.O_CREAT | nofollow, 0o600)
    except OSError as e:
        if e.errno not in (errno.EACCES, errno.EPERM, errno.EROFS) or _can_write(folder):
            raise
        writable = False
        try:
            fd = os.open(lock, os.O_RDONLY | nofollow)
        except FileNotFoundError:
            fd = None
    try:
        if fd is not None:
            _check_private(lock, "file")
            fcntl.flock(fd, fcntl.LOCK_EX if writable else fcntl.LOCK_SH)
        yield writable
    finally:
        if fd is not None:
            os.close(fd)  # releases the lock


def _can_write(folder: Path) -> bool:
    """Whether files can be created in ``folder`` (its mode, and a writable file system)."""
    if not os.access(folder, os.W_OK):
        return False
    with contextlib.suppress(OSError, AttributeError):
        if os.statvfs(folder).f_flag & os.ST_RDONLY:
            return False
    return True


#: The temporary files of a build in a key folder (:func:`_write_private`, :func:`_build`).
_TEMP_PREFIXES = tuple(f".{name}." for name in (_SOURCE_NAME, _LIB_NAME, _MANIFEST_NAME))


def _sweep_temporaries(folder: Path) -> None:
    """Remove the temporary files a killed build left in ``folder``. Called under the
    folder's exclusive lock, which every build holds from its first temporary file to its
    last rename: any temporary there now belongs to no running build."""
    with os.scandir(folder) as entries:
        stale = [
            e.path
            for e in entries
            if e.name.startswith(_TEMP_PREFIXES)
            and e.name.endswith(".tmp")
            and not e.is_dir(follow_symlinks=False)
        ]
    for path in stale:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)


def _sha256(path: Path) -> tuple[str, int]:
    h, size = hashlib.sha256(), 0
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return h.hexdigest(), size


def _verified(folder: Path, key: str) -> str | None:
    """Why the library of ``folder`` cannot be used as it is (``None``: it matches its
    manifest). Raises :class:`UnsafeCacheError` for a file others could have written."""
    lib, manifest = folder / _LIB_NAME, folder / _MANIFEST_NAME
    lib_st = _check_private(lib, "file")
    man_st = _check_private(manifest, "file")
    if lib_st is None:
        return "no library" if man_st is None else "the library is missing"
    if man_st is None:
        return "the library has no manifest"
    try:
        meta = json.loads(manifest.read_text(encoding="utf-8"))
        expected, size = str(meta["sha256"]), int(meta["size"])
        if meta.get("key") != key:
            return "its manifest names another key"
    except (OSError, ValueError, KeyError, TypeError):
        return "its manifest is unreadable"
    try:
        digest, actual = _sha256(lib)
    except OSError as e:
        return f"the library is unreadable ({e.strerror})"
    if actual != size or digest != expected:
        return (
            f"the library does not match its manifest (SHA-256 {digest[:12]}..., {actual} "
            f"bytes; recorded {expected[:12]}..., {size} bytes): corrupt, truncated or replaced"
        )
    return None


def _write_private(folder: Path, name: str, data: bytes, mode: int) -> Path:
    """``data`` into a new temporary file of ``folder`` with ``mode``; returns its path."""
    fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return Path(tmp)


def _build(
    folder: Path,
    source: str,
    compiler: str,
    key: str,
    announce: str | None = None,
    cflags: tuple[str, ...] = CFLAGS,
) -> None:
    """Compile ``source`` into ``folder`` with ``cflags`` (temporary files, then renamed
    into place); ``announce``: what is compiled, for the progress lines (:func:`_compile`)."""
    temps: list[Path] = []
    try:
        tmp_c = _write_private(folder, _SOURCE_NAME, source.encode(), 0o644)
        temps.append(tmp_c)
        fd, name = tempfile.mkstemp(prefix=f".{_LIB_NAME}.", suffix=".tmp", dir=folder)
        os.close(fd)
        tmp_so = Path(name)
        temps.append(tmp_so)
        # -x c: the temporary name does not end in .c.
        cmd = [compiler, *cflags, "-o", str(tmp_so), "-x", "c", str(tmp_c), *LDLIBS]
        code, output = _compile(cmd, announce)
        if code != 0 or not tmp_so.is_file() or tmp_so.stat().st_size == 0:
            first = output.strip().splitlines()
            raise CompilationError(
                f"{os.path.basename(compiler)} failed ({code}): "
                f"{first[0] if first else 'no output'}"
            )
        os.chmod(tmp_so, 0o755)
        digest, size = _sha256(tmp_so)
        meta = {
            "key": key,
            "sha256": digest,
            "size": size,
            "compiler": compiler_identity(compiler).splitlines()[0],
            "cflags": list(cflags),
            "casadi": cs.__version__,  # type: ignore[attr-defined]  # missing from its stubs
            "generator": GENERATOR_VERSION,
            "general_generator": GENERAL_GENERATOR_VERSION,
        }
        tmp_m = _write_private(
            folder, _MANIFEST_NAME, (json.dumps(meta, indent=2) + "\n").encode(), 0o644
        )
        temps.append(tmp_m)
        os.replace(tmp_c, folder / _SOURCE_NAME)
        os.replace(tmp_so, folder / _LIB_NAME)  # then the manifest: a reader holding the
        os.replace(tmp_m, folder / _MANIFEST_NAME)  # lock sees both or rebuilds
    finally:
        for t in temps:
            with contextlib.suppress(OSError):
                os.unlink(t)


def _compile(cmd: list[str], announce: str | None) -> tuple[int, str]:
    """Run the compiler ``cmd``: ``(exit status, its stderr or else stdout)``. Past
    :func:`compile_timeout` the compiler (its whole process group) is killed and
    :class:`CompilationError` raised; with ``announce`` (what is compiled), one line on
    stderr every :data:`PROGRESS_EVERY` seconds while it runs."""
    timeout = compile_timeout()
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        start_new_session=os.name == "posix",  # its own group: killed with its children
    )
    start = time.monotonic()
    try:
        while True:
            elapsed = time.monotonic() - start
            wait = min(PROGRESS_EVERY, timeout - elapsed) if announce else timeout - elapsed
            try:
                out, err = proc.communicate(timeout=max(wait, 0.0))
                break
            except subprocess.TimeoutExpired:
                elapsed = time.monotonic() - start
                if elapsed >= timeout:
                    raise CompilationError(
                        f"{os.path.basename(cmd[0])} did not finish within {timeout:g} s "
                        f"(${COMPILE_TIMEOUT_ENV}); it was stopped"
                    ) from None
                print(
                    f"stewart-pin: still compiling {announce} ({elapsed:.0f} s so far; "
                    f"stopped at {timeout:g} s, ${COMPILE_TIMEOUT_ENV})",
                    file=sys.stderr,
                    flush=True,
                )
    finally:
        if proc.returncode is None:  # timed out or interrupted: stop it and its children
            _kill(proc)
    return proc.returncode, err or out or ""


def _kill(proc: subprocess.Popen[str]) -> None:
    with contextlib.suppress(OSError):
        if os.name == "posix":
            os.killpg(proc.pid, signal.SIGKILL)
        else:  # pragma: no cover
            proc.kill()
    with contextlib.suppress(OSError, subprocess.SubprocessError):
        proc.communicate(timeout=10)


def build_seconds(source: str, cflags: tuple[str, ...] = CFLAGS) -> float:
    """About how long the system compiler takes on ``source`` with ``cflags`` [s]
    (measured on this project's 2-core machine with gcc -O2, before the models had their
    vector copy (:mod:`._simd`, about 1.5x the source and 2-2.5x the time): 1 s for
    the 6-UPS models, 1.3 s for 6-RUS, 3.4 s for a random 6-RUS with every joint term, 10 s
    for custom legs;
    with :data:`QUICK_CFLAGS`, linear: 2.5-2.8 s for the 1.2-1.5 MB of the exact
    derivatives)."""
    n = len(source)
    if "-O0" in cflags:
        return 2e-6 * n
    return 8e-6 * n + (n / 3.5e5) ** 2


def build_library(
    desc: Any,
    cache_dir: str | Path | None = None,
    compiler: str | None = None,
    load: Any = None,
    announce: bool = False,
) -> tuple[Path, bool]:
    """Build (or find, verified, in the cache) a robot's shared library.

    Returns ``(path, compiled_now)``; ``load(path)``, if given, is called while the key
    folder is still locked (the file loaded is the one just verified). ``announce``: say
    on stderr, in one line, that it compiles and about how long it takes (only when it
    does). Raises :class:`UnsafeCacheError` when the cache folder or a file in it could
    have been written by someone else, and :class:`CompilationError` when no compiler is
    found or the compilation fails. See the module docstring for the cache's rules.
    """
    what = f"the dynamic models of robot '{printable_name(desc)}'" if announce else None
    return build_source_library(
        lambda: c_source(desc), cache_dir, compiler, load, what, library_identity(desc, "models")
    )


def build_source_library(
    source_of: Callable[[], str],
    cache_dir: str | Path | None = None,
    compiler: str | None = None,
    load: Any = None,
    announce: str | None = None,
    identity: str | None = None,
    cflags: tuple[str, ...] | None = None,
) -> tuple[Path, bool]:
    """:func:`build_library` for any generated C source (``source_of()``): the same cache
    folder, key, integrity rules, lock and build (the exact derivatives of
    :mod:`.derivatives` use it). ``announce``: what is compiled, said in one line on stderr
    with about how long it takes (only when it compiles), or None. ``identity``: what the
    source is made from (:func:`library_identity`), keyed instead of the source, which is
    then generated only to be compiled; None: the source is generated (once a compiler is
    found) and keyed. ``cflags``: the compiler flags (part of the key; None:
    :func:`model_cflags`, :data:`CFLAGS` unless ``$STEWART_PIN_BUILD`` says otherwise)."""
    cflags = model_cflags() if cflags is None else cflags
    compiler = compiler or find_compiler()
    if not compiler:
        raise CompilationError("no C compiler found (cc, gcc, clang or $CC)")
    root = Path(cache_dir) if cache_dir is not None else cache_root()
    source = source_of() if identity is None else None
    key = cache_key(source if source is not None else identity or "", compiler, cflags)
    folder = root / key
    try:
        _private_dir(root, follow=True)
        _private_dir(folder)
        with _locked(folder) as writable:
            if writable:
                _sweep_temporaries(folder)
            why = _verified(folder, key)
            if why is not None and not writable:
                raise CompilationError(
                    f"the cache folder {folder} is read-only and holds no valid library "
                    f"({why}); make it writable or point ${CACHE_ENV} at a writable folder"
                )
            if why is not None:
                if why != "no library":
                    warnings.warn(
                        f"stewart-pin: rebuilding the cached library in {folder}: {why}",
                        RuntimeWarning,
                        stacklevel=3,
                    )
                if source is None:
                    source = source_of()
                if announce:
                    seconds = max(1, round(build_seconds(source, cflags)))
                    print(
                        f"stewart-pin: compiling {announce} (first use of this geometry, "
                        f"about {seconds} s, stopped at {compile_timeout():g} s; cached in "
                        f"{root})",
                        file=sys.stderr,
                        flush=True,
                    )
                _build(folder, source, compiler, key, announce, cflags)
            if load is not None:
                try:
                    load(folder / _LIB_NAME)
                except OSError as e:
                    raise CompilationError(f"cannot load {folder / _LIB_NAME}: {e}") from e
    except (OSError, subprocess.SubprocessError) as e:
        if isinstance(e, OSError) and _cache_not_writable(e, root, folder):
            raise CompilationError(
                f"the cache folder {root} cannot be written ({e.strerror}) and holds no "
                f"library for this robot; make it writable or point ${CACHE_ENV} at a "
                "writable folder"
            ) from e
        raise CompilationError(f"cannot build the library in {folder}: {e}") from e
    return folder / _LIB_NAME, why is not None


def _cache_not_writable(e: OSError, root: Path, folder: Path) -> bool:
    """Whether ``e`` is the refusal to create the cache folder ``root`` (or an ancestor)
    or its key folder ``folder``: a read-only cache without this robot's library."""
    if e.errno not in (errno.EROFS, errno.EACCES, errno.EPERM) or e.filename is None:
        return False
    path = Path(os.fsdecode(e.filename))
    return path in (root, folder) or path in root.parents


def printable_name(desc: Any) -> str:
    """The robot's name for a message: printable characters only, at most 60."""
    name = "".join(ch for ch in str(getattr(desc, "name", "")) if ch.isprintable())
    return name[:57] + "..." if len(name) > 60 else name


def positive_threads(value: Any) -> int:
    try:
        n = int(value)
    except (TypeError, ValueError):
        n = 0
    if n < 1 or (isinstance(value, float) and value != n):
        raise InputError(f"threads must be a positive integer, got {value!r}")
    return n


def default_threads() -> int:
    """Threads sharing a compiled batch: ``$STEWART_PIN_THREADS`` if set (a positive
    integer; anything else raises :class:`~stewart_pin.exceptions.InputError`), else
    ``os.cpu_count()`` (1 when unknown)."""
    env = os.environ.get(THREADS_ENV)
    if env is not None and env.strip():
        return positive_threads(env.strip())
    return os.cpu_count() or 1


_POOLS: dict[int, ThreadPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def _pool(threads: int) -> ThreadPoolExecutor:
    """A process-wide pool of ``threads - 1`` workers (the caller runs one slice itself)."""
    with _POOLS_LOCK:
        pool = _POOLS.get(threads)
        if pool is None:
            from concurrent.futures import ThreadPoolExecutor  # on first use: start-up

            pool = ThreadPoolExecutor(threads - 1, thread_name_prefix="stewart-pin-c")
            _POOLS[threads] = pool
        return pool


def warn_vm_once(what: str, reason: str, warned: set[str], stacklevel: int) -> None:
    """Warn once per ``reason`` (remembered in ``warned``, the calling module's set) that
    the compiled ``what`` is unavailable and CasADi's VM answers instead; ``stacklevel``
    as for :func:`warnings.warn` (1: this function)."""
    if reason not in warned:
        warned.add(reason)
        warnings.warn(
            f"stewart-pin compiled {what} unavailable ({reason}); using CasADi's virtual "
            "machine instead (same results, slower)",
            RuntimeWarning,
            stacklevel=stacklevel,
        )


def build_or_vm(
    build: Callable[[str | None], tuple[Path, bool]],
    compiler: str | bool | None,
    vm_fallback: bool,
) -> tuple[str, str | None, Path | None, bool]:
    """``(kind, reason, library, compiled_now)`` of a backend whose library ``build(cc)``
    builds (``cc``: the compiler named by ``compiler``, or None to find one):
    ``("compiled", None, path, compiled_now)``, or ``("vm", reason, None, False)`` when
    ``compiler`` is False or the build fails and ``vm_fallback`` is set (unset: a
    :class:`CompilationError`). An :class:`UnsafeCacheError` always propagates."""
    if compiler is False:
        return "vm", "compiler disabled", None, False
    try:
        library, compiled_now = build(compiler if isinstance(compiler, str) else None)
    except UnsafeCacheError:
        raise
    except (CompilationError, OSError, AttributeError) as e:
        if not vm_fallback:
            if isinstance(e, CompilationError):
                raise
            raise CompilationError(str(e) or type(e).__name__) from e
        return "vm", str(e).splitlines()[0] if str(e) else type(e).__name__, None, False
    return "compiled", None, library, compiled_now


_F64 = np.dtype(np.float64)
_ONE_SHAPES = ((4, 4), (6,), (6,))
_BATCH_OF_ONE_SHAPES = ((1, 4, 4), (1, 6), (1, 6))


def _as_c(x: Any) -> np.ndarray | None:
    """``x`` as a C-contiguous float64 array, or None when it is not a numeric ndarray."""
    if isinstance(x, np.ndarray):
        if x.dtype == _F64 and x.flags.c_contiguous:
            return x
        if x.dtype.kind not in "fiu":
            return None
        return np.ascontiguousarray(x, dtype=np.float64)
    return None  # lists and anything else: check_states validates them (a boolean in a list)


class CompiledDynamics:
    """The generated IDM and DDM of a robot, compiled to C (or in CasADi's VM).

    Any robot: the paper's 6-UPS closed forms (:mod:`.symbolic`, the 88 base parameters an
    input) or, for general legs, the generic models of :mod:`.leg_chain_symbolic` (every
    number of the robot compiled in; the actuated joints' efforts, joint side).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` (its description and
            ``max_condition`` are used; the description's geometry is compiled in).
        cache_dir: the cache folder (default :func:`cache_root`).
        compiler: the C compiler to use (default :func:`find_compiler`); ``False`` forces
            the virtual machine.
        threads: threads sharing a batch (default :func:`default_threads`:
            ``$STEWART_PIN_THREADS``, else ``os.cpu_count()``); batches of fewer than
            :data:`THREAD_MIN_STATES` states per thread, and single states, run in the
            calling thread.
        vm_fallback: when building or loading fails, run in the virtual machine (with a
            warning); ``False``: raise :class:`CompilationError` instead (what
            ``backend="auto"`` uses to fall back to the reference path).
        announce: say on stderr, in one line, when the library is compiled
            (:func:`build_library`).

    Raises:
        UnsafeCacheError: the cache folder or a file in it could have been written by
            someone else (no fallback: fix the cache; see the module docstring). Any
            other failure to build or load falls back to the virtual machine.

    Methods (one state: ``pose`` (4, 4) / ``pin.SE3``, vectors (6,); a batch: (N, 4, 4) and
    (N, 6); the result has the same form):

    - ``inverse_dynamics(pose, twist, accel, base_values=None)`` -> Gamma [N];
    - ``direct_dynamics(pose, twist, gamma, base_values=None)`` -> the classical platform
      acceleration ``[dv/dt, dw/dt]`` in F0;
    - ``inverse_dynamics_stream(chunks)`` / ``direct_dynamics_stream(chunks)``: an iterator
      of results over an iterable of ``(pose, twist, x)`` batches, for data larger than
      memory.

    ``base_values`` (88,) replaces the robot's base parameters (names in
    :attr:`parameter_names`, e.g. identified values); default the description's (general
    legs: none, their parameters are compiled in). Conventions and errors are those of
    ``StewartRobot.inverse_dynamics`` / ``direct_dynamics`` (see the module docstring).

    Attributes:
        threads: the threads a large batch is split across (see ``threads`` above).
        kind: ``"compiled"`` or ``"vm"``. reason: why the VM is used (``None`` if compiled).
        library: the shared library's path. compiled_now: whether this construction
            compiled it (``False``: found in the cache).
        parameter_names, base_values: the 88 base parameters and the robot's values
            (empty for general legs).
        general: whether the robot has general legs (the generic models).
    """

    def __init__(
        self,
        robot: RobotLike,
        cache_dir: str | Path | None = None,
        compiler: str | bool | None = None,
        threads: int | None = None,
        vm_fallback: bool = True,
        announce: bool = False,
    ) -> None:
        _check_compilable(robot.description)
        self.robot = robot
        self.cache_dir = cache_dir  # where its libraries are (the simulator's lanes too)
        self.threads = default_threads() if threads is None else positive_threads(threads)
        desc = robot.description
        self._desc = desc
        kind = codegen_kind(desc)
        self.general = kind.generic_models  # public; nothing here branches on it
        self.parameter_names, self.base_values = kind.base_parameters(desc)
        self.base_values.flags.writeable = False
        self._length = singularity_length(desc)
        self._resolution = kind.resolution(desc)
        self._vm_idm = self._vm_ddm = None
        self.library: Path | None
        self.kind, self.reason, self.library, self.compiled_now = build_or_vm(
            lambda cc: build_library(desc, cache_dir, cc, self._load, announce),
            compiler,
            vm_fallback,
        )
        if self.kind == "vm":
            warn_vm_once("backend", self.reason or "unknown", _WARNED, stacklevel=3)

    def __repr__(self) -> str:
        return f"CompiledDynamics({self.robot!r}, kind={self.kind!r})"

    # ------------------------------------------------------------------ loading
    def _load(self, path: Path) -> None:
        lib = ctypes.CDLL(str(path))
        argtypes = [
            ctypes.c_longlong,
            *[ctypes.c_void_p] * 4,
            ctypes.c_double,
            ctypes.c_void_p,
            ctypes.c_void_p,
        ]
        for name in ("sp_idm_batch", "sp_ddm_batch"):
            fn = getattr(lib, name)
            fn.argtypes = argtypes
            fn.restype = ctypes.c_int
        self._lib = lib
        self._c = {"idm": lib.sp_idm_batch, "ddm": lib.sp_ddm_batch}
        # The single-state entries are called without argument types (ctypes converts
        # nothing then: the fastest call): a bytes block (passed as a pointer to its own
        # read-only storage, without a copy; the C side only reads it) and prepared
        # c_void_p / c_double objects.
        one = {name: lib[f"sp_{name}_one"] for name in ("idm", "ddm")}
        for fn in one.values():
            fn.restype = ctypes.c_int
        self._c_one = one
        # The single-state result buffer with its address taken once (numpy's .ctypes.data
        # costs about a microsecond per array); a lock makes it safe across threads.
        self._lock = threading.Lock()
        self._one_out = np.zeros(6)
        self._one_out_ptr = ctypes.c_void_p(self._one_out.ctypes.data)
        self._chi_ptr = ctypes.c_void_p(self.base_values.ctypes.data)
        self._max_cond = (math.nan, ctypes.c_double(math.nan))

    # ------------------------------------------------------------------ public API
    def inverse_dynamics(
        self, pose: Any, twist: Any, accel: Any, base_values: Any = None
    ) -> np.ndarray:
        """Actuator forces Gamma [N], (6,) or (N, 6) (eq. 31); see the class docstring."""
        return self._run("idm", pose, twist, accel, "accel", base_values)

    def direct_dynamics(
        self, pose: Any, twist: Any, gamma: Any, base_values: Any = None
    ) -> np.ndarray:
        """Classical platform acceleration in F0, (6,) or (N, 6) (eq. 35)."""
        return self._run("ddm", pose, twist, gamma, "gamma", base_values)

    def inverse_dynamics_stream(
        self, chunks: Iterable[tuple[Any, Any, Any]], base_values: Any = None
    ) -> Iterator[np.ndarray]:
        """Gamma for each ``(poses, twists, accels)`` batch of ``chunks``, lazily."""
        for pose, twist, accel in chunks:
            yield self._run("idm", pose, twist, accel, "accel", base_values)

    def direct_dynamics_stream(
        self, chunks: Iterable[tuple[Any, Any, Any]], base_values: Any = None
    ) -> Iterator[np.ndarray]:
        """The acceleration for each ``(poses, twists, gammas)`` batch of ``chunks``."""
        for pose, twist, gamma in chunks:
            yield self._run("ddm", pose, twist, gamma, "gamma", base_values)

    # ------------------------------------------------------------------ internals
    def checked_base_values(self, base_values: Any) -> np.ndarray:
        """The base parameters a call uses: the robot's (``None``) or ``base_values``
        checked (``(len(parameter_names),)``, finite), C-contiguous float64."""
        if base_values is None:
            return self.base_values
        if not self.parameter_names:
            raise InputError(
                f"base_values: robot '{self._desc.name}' has general legs, whose compiled "
                "models have their inertial parameters built in (no base-parameter input); "
                "make a robot with the new values instead"
            )
        chi = check_array(base_values, (len(self.parameter_names),), "base_values")
        return np.ascontiguousarray(chi)

    def _run(
        self, which: str, pose: Any, twist: Any, x: Any, name: str, base_values: Any
    ) -> np.ndarray:
        if self.kind != "compiled":
            return self._run_vm(which, pose, twist, x, name, self.checked_base_values(base_values))
        try:  # native float64 arrays (anything else takes the general path below)
            native = pose.dtype is _F64 and twist.dtype is _F64 and x.dtype is _F64
        except AttributeError:
            native = False
        if native and isinstance(pose, np.ndarray):
            shapes = (pose.shape, twist.shape, x.shape)
            if shapes == _ONE_SHAPES:
                return self._run_one(which, pose, twist, x, name, base_values)
            if shapes == _BATCH_OF_ONE_SHAPES:
                out = self._run_one(which, pose[0], twist[0], x[0], name, base_values, True)
                return out[None]
        chi = self.checked_base_values(base_values)
        T, V, X = _as_c(pose), _as_c(twist), _as_c(x)
        if T is not None and V is not None and X is not None:
            if T.shape == (4, 4) and V.shape == (6,) and X.shape == (6,):
                batched = False
            elif (
                T.ndim == 3
                and T.shape[1:] == (4, 4)
                and V.shape == (T.shape[0], 6)
                and X.shape == (T.shape[0], 6)
            ):
                batched = True
            else:
                T = None
        if T is None or V is None or X is None:
            batched, T, V, X = check_states(pose, (twist, "twist"), (x, name))
        n = 1 if not batched else T.shape[0]
        out = np.empty((n, 6))
        flags = np.empty(n, dtype=np.int32)
        any_flag = self._call_batch(which, n, T, V, X, chi, out, flags)
        if any_flag & ~_REPIVOTED:
            self._resolve(which, flags, (pose, twist, x, name), T, V, X, out)
        return out if batched else out[0]

    def _call_batch(
        self,
        which: str,
        n: int,
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        chi: np.ndarray,
        out: np.ndarray,
        flags: np.ndarray,
    ) -> int:
        """The C loop over ``n`` states (C-contiguous float64 buffers); a batch of at least
        :data:`THREAD_MIN_STATES` states per thread is split into :attr:`threads` slices
        that run concurrently (ctypes releases the GIL during each call). Returns the OR of
        the flags."""
        fn = self._c[which]
        pT, pV, pX, pc = T.ctypes.data, V.ctypes.data, X.ctypes.data, chi.ctypes.data
        po, pf = out.ctypes.data, flags.ctypes.data
        max_cond = self.robot.max_condition

        def call(s: int, m: int) -> int:  # states s .. s + m - 1
            return int(
                fn(
                    m,
                    pT + 128 * s,
                    pV + 48 * s,
                    pX + 48 * s,
                    pc,
                    max_cond,
                    po + 48 * s,
                    pf + 4 * s,
                )
            )

        return split_batch(n, self.threads, THREAD_MIN_STATES, call)

    def _run_one(
        self,
        which: str,
        pose: np.ndarray,
        twist: np.ndarray,
        x: np.ndarray,
        name: str,
        base_values: Any,
        batch: bool = False,
    ) -> np.ndarray:
        """One state given as native float64 arrays: their bytes go to the C function in one
        block, the result comes back through the preallocated buffer (``batch``: it came as
        a batch of one, for the error messages)."""
        chi_ptr = self._chi_ptr
        if base_values is not None:
            chi = self.checked_base_values(base_values)
            chi_ptr = ctypes.c_void_p(chi.ctypes.data)
        block = pose.tobytes() + twist.tobytes() + x.tobytes()  # float64, C order
        max_cond = self.robot.max_condition
        if max_cond != self._max_cond[0]:
            self._max_cond = (max_cond, ctypes.c_double(max_cond))
        c_max_cond = self._max_cond[1]
        with self._lock:
            flag = self._c_one[which](block, chi_ptr, c_max_cond, self._one_out_ptr)
            out = self._one_out.copy()
        if flag & ~_REPIVOTED:
            T = np.frombuffer(block, count=16).reshape(1, 4, 4).copy()
            args = (pose[None], twist[None], x[None]) if batch else (pose, twist, x)
            flags = np.array([flag], dtype=np.int32)
            self._resolve(which, flags, (*args, name), T, twist[None], x[None], out[None])
        return out

    def _resolve(
        self,
        which: str,
        flags: np.ndarray,
        args: tuple[Any, Any, Any, str],
        T: np.ndarray,
        V: np.ndarray,
        X: np.ndarray,
        out: np.ndarray,
    ) -> None:
        """The flagged states as the architecture resolves them
        (:mod:`._resolution`: the reference's checks, or its results into ``out``);
        ``args`` the call's ``(pose, twist, x, name)``."""
        self._resolution.resolve(which, flags, args, T, V, X, out, self.robot.max_condition)

    # ------------------------------------------------------------------ virtual machine
    def _vm_function(self, which: str) -> cs.Function:
        attr = f"_vm_{which}"
        if getattr(self, attr) is None:
            models = generate_models(self._desc)
            setattr(self, attr, models.idm_guarded if which == "idm" else models.ddm_guarded)
        return getattr(self, attr)

    def _run_vm(
        self, which: str, pose: Any, twist: Any, x: Any, name: str, chi: np.ndarray
    ) -> np.ndarray:
        """The models in CasADi's VM: the architecture's checks first
        (:meth:`._resolution.Resolution.before_vm`), then the C guard's flags computed
        from ``aux`` in numpy (the slacks, the exact singularity measure, the pivots,
        finite results) and resolved as the compiled path resolves them."""
        batched, T, V, X = check_states(pose, (twist, "twist"), (x, name))
        self._resolution.before_vm(T, self.robot.max_condition)
        f = self._vm_function(which)
        n = T.shape[0]
        out = np.empty((n, 6))
        aux = np.empty((n, f.size1_out(1)))
        for s in range(0, n, VM_CHUNK):
            e = min(n, s + VM_CHUNK)
            r, a = f(T[s:e].reshape(-1, 16).T, V[s:e].T, X[s:e].T, chi)
            out[s:e], aux[s:e] = np.array(r).T, np.array(a).T
        layout = model_layout(self._desc)
        start = layout.idm_slack if which == "idm" else layout.ddm_slack
        flags = np.zeros(n, dtype=np.int32)
        with np.errstate(invalid="ignore"):
            flags[~np.all(aux[:, start : start + layout.n_slack] > 0.0, axis=1)] |= _GEOMETRY
            J = aux[:, layout.jinv : layout.jinv + 36].reshape(n, 6, 6)
            ok = np.all(np.isfinite(J), axis=(1, 2))
            cond = np.full(n, np.inf)
            cond[ok] = np.linalg.cond(scaled_inverse_jacobian(J[ok], self._length))
            flags[~(cond <= self.robot.max_condition)] |= _COND
            if which == "idm":
                grown = np.flatnonzero(~(aux[:, layout.growth] <= GROWTH_LIMIT) & ok)
                for k in grown:  # static pivots off: solve again with partial pivoting
                    hz = aux[k, layout.idm_hz : layout.idm_hz + 6]
                    F = aux[k, layout.idm_f : layout.idm_f + 6]
                    out[k] = hz + np.linalg.solve(J[k].T, F)
            else:
                D = aux[:, layout.ddm_d : layout.ddm_d + 6]
                flags[~np.all(D > 0.0, axis=1)] |= _NOT_PD
            flags[~np.all(np.isfinite(out), axis=1)] |= _NONFINITE
        if np.any(flags):
            self._resolve(which, flags, (pose, twist, x, name), T, V, X, out)
        return out if batched else out[0]


#: The attributes under which a robot keeps its backends (the robot and its backend live
#: and die together; ``StewartRobot`` leaves them out when pickled).
COMPILED_ATTR = "_stewart_pin_compiled_backend"
AUTO_ATTR = "_stewart_pin_auto_backend"


def _memo(robot: Any, attr: str) -> Any:
    d = getattr(robot, "__dict__", None)
    return None if d is None else d.get(attr)


def _remember(robot: Any, attr: str, value: Any) -> None:
    d = getattr(robot, "__dict__", None)
    if d is not None:
        d[attr] = value


def compiled_backend(robot: RobotLike, **kwargs: Any) -> CompiledDynamics:
    """The :class:`CompiledDynamics` of ``robot``, built on first use and kept with it
    (keyword arguments go to the constructor on that first call)."""
    backend = _memo(robot, COMPILED_ATTR)
    if backend is None or backend._desc is not robot.description:
        backend = CompiledDynamics(robot, **kwargs)
        _remember(robot, COMPILED_ATTR, backend)
    return backend


def split_batch(n: int, threads: int, min_states: int, call: Callable[[int, int], int]) -> int:
    """Run ``call(start, count)`` over ``n`` states, split into at most ``threads`` slices of
    at least ``min_states`` states each, on the process-wide pool (the calling thread takes
    the first slice); returns the OR of the slices' flags."""
    parts = min(threads, n // min_states)
    if parts <= 1:
        return call(0, n)
    bounds = [n * k // parts for k in range(parts + 1)]
    pool = _pool(threads)
    futures = [pool.submit(call, bounds[k], bounds[k + 1] - bounds[k]) for k in range(1, parts)]
    any_flag = call(0, bounds[1])
    for f in futures:
        any_flag |= f.result()
    return any_flag


# ---------------------------------------------------------------------------- backend="auto"
#: Environment variable: what ``backend="auto"`` (the default of the dynamic models) does:
#: ``auto`` (default: the compiled models where a C compiler is available, else the
#: reference path) or ``pinocchio`` (always the reference path: nothing is compiled; the
#: test suite sets it). Read once per robot, on its first dynamics call.
BACKEND_ENV = "STEWART_PIN_BACKEND"
AUTO_CHOICES = ("auto", "pinocchio")
_WARNED_AUTO: set[str] = set()


def auto_backend(robot: RobotLike) -> CompiledDynamics | None:
    """What ``backend="auto"`` runs for ``robot``: its compiled models, or ``None`` for
    the reference path. Decided on the robot's first call and kept with it (weakly):

    - ``$STEWART_PIN_BACKEND=pinocchio``: ``None``;
    - no C compiler (:func:`find_compiler`), or building or loading the library fails
      (including a cache that others could have written, :class:`UnsafeCacheError`):
      ``None``, with one :class:`RuntimeWarning` per reason and process;
    - else the :class:`CompiledDynamics`, built on first use (one line on stderr says so,
      and about how long it takes) or found in the cache.
    """
    hit = _memo(robot, AUTO_ATTR)  # (description, choice), kept on the robot
    if hit is not None and hit[0] is robot.description:
        return hit[1]
    choice = _auto_choice(robot)
    _remember(robot, AUTO_ATTR, (robot.description, choice))
    return choice


def auto_env() -> str:
    """``$STEWART_PIN_BACKEND`` (:data:`BACKEND_ENV`), one of :data:`AUTO_CHOICES`
    (default ``"auto"``); anything else raises :class:`InputError`."""
    env = (os.environ.get(BACKEND_ENV) or "auto").strip().lower()
    if env not in AUTO_CHOICES:
        raise InputError(
            f"${BACKEND_ENV} must be one of {AUTO_CHOICES} (what backend='auto' does), got "
            f"{env!r}; unset it for the default 'auto'"
        )
    return env


def _auto_choice(robot: RobotLike) -> CompiledDynamics | None:
    if auto_env() == "pinocchio":
        return None
    if not _compilable(robot.description):  # legs with idle joints: the idle-state models
        return None  # (codegen/idle_compiled.py), which robot.py calls with idle=
    existing = _memo(robot, COMPILED_ATTR)
    if existing is not None and existing._desc is robot.description:
        if existing.kind == "compiled":
            return existing
    compiler = find_compiler()
    if compiler is None:
        warn_reference("no C compiler found (cc, gcc, clang or $CC)")
        return None
    try:
        backend = CompiledDynamics(robot, compiler=compiler, vm_fallback=False, announce=True)
    except (CompilationError, UnsafeCacheError) as e:
        warn_reference(str(e).splitlines()[0] if str(e) else type(e).__name__)
        return None
    _remember(robot, COMPILED_ATTR, backend)
    return backend


def _compilable(desc: Any) -> bool:
    """Whether the compiled models take ``desc`` (:meth:`CodegenKind.not_compiled`)."""
    return codegen_kind(desc).not_compiled(desc) is None


def _check_compilable(desc: Any) -> None:
    reason = codegen_kind(desc).not_compiled(desc)
    if reason is not None:
        raise UnsupportedArchitectureError(
            f"robot '{desc.name}' has {reason}: CompiledDynamics has no such input; "
            "use the idle-state models (or backend='pinocchio', the reference path)",
            "backend",
            desc.architecture,
        )


def warn_reference(reason: str) -> None:
    if reason not in _WARNED_AUTO:
        _WARNED_AUTO.add(reason)
        warnings.warn(
            f"stewart-pin: backend='auto' takes the reference path (Pinocchio, about 100 "
            f"times slower than the compiled models): {reason}; install a C compiler (cc, "
            f"gcc or clang, or set $CC) to get the compiled models",
            RuntimeWarning,
            stacklevel=4,
        )
