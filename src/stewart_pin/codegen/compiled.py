"""Fast evaluation of the generated models: C compiled once per robot, or CasADi's VM.

:class:`CompiledDynamics` turns the symbolic models of :mod:`.symbolic` into a shared
library: CasADi writes the C of the guarded IDM and DDM, :mod:`._csource` adds a loop over
N states and a guard per state, the system C compiler builds it (``-O2``, no
``-march=native``, so a cached library stays valid on any machine of the same kind), and
:mod:`ctypes` loads it. The library is cached per robot under
``$STEWART_PIN_CACHE`` (default ``~/.cache/stewart-pin``), in a folder named after a hash
of the geometry (what is compiled in: robots that differ only in inertial parameters,
name or U-joint limits share a library; the base parameters are a run-time input), the
CasADi version, the generator and the compiler flags. Compiling takes a few seconds.

Without a C compiler (or when compiling or loading fails), the same functions run in
CasADi's virtual machine: correct, slower, with one warning giving the reason.

Validation. The results are those of the reference path (``StewartRobot.inverse_dynamics``
/ ``direct_dynamics``), errors included: the C guard checks each state cheaply (finite
inputs, orthonormal rotation, leg lengths within the stroke and away from the leg
singularities from the generated code's ``q3^2`` and ``rho^2``, and an upper bound of
cond(Jp^-1)); any state it flags sends the batch through the reference checks
(:func:`stewart_pin._checks.check_poses`, :func:`stewart_pin.geometry.inverse_geometry_batch`,
:func:`stewart_pin.kinematics.check_condition` on the flagged states), which raise
:class:`~stewart_pin.exceptions.InputError`, :class:`~stewart_pin.exceptions.StrokeLimitError`
or :class:`~stewart_pin.exceptions.SingularityError` with the reference's messages. A robot
with U-joint limits always runs the reference inverse geometry (the guard does not know
the angles). The IDM's static-pivot LU is backed by a partial-pivoting solve in C when a
multiplier grows past :data:`._csource.GROWTH_LIMIT`.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import threading
import warnings
import weakref
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import casadi as cs
import numpy as np

from .._checks import check_array, check_states
from ..base_params import grouped_parameters
from ..exceptions import SingularityError, StewartPinError
from ..geometry import LEG_MIN_LENGTH, LEG_SINGULARITY_SIN, inverse_geometry_batch
from ..kinematics import check_condition, inverse_jacobian_batch
from . import _csource
from ._csource import FLAG_NAMES, GROWTH_LIMIT
from .symbolic import (
    AUX_DDM_D,
    AUX_IDM_DET,
    AUX_IDM_F,
    AUX_IDM_FRO2,
    AUX_IDM_GROWTH,
    AUX_IDM_HZ,
    AUX_IDM_SIZE,
    AUX_JINV,
    GENERATOR_VERSION,
    generate_models,
)

#: Environment variable overriding the cache folder.
CACHE_ENV = "STEWART_PIN_CACHE"
#: Compiler flags (no -march=native: the cached library must run on any x86-64 of the kind).
CFLAGS = ("-O2", "-fno-math-errno", "-fPIC", "-shared", "-fvisibility=hidden")
#: States per CasADi VM call in the fallback.
VM_CHUNK = 4096

_INPUT, _GEOMETRY, _COND = FLAG_NAMES["INPUT"], FLAG_NAMES["GEOMETRY"], FLAG_NAMES["COND"]
_NOT_PD, _NONFINITE = FLAG_NAMES["NOT_PD"], FLAG_NAMES["NONFINITE"]
_LIB_NAME = "libstewart_models.so"
_WARNED: set[str] = set()
#: Reference rotation tolerance (``stewart_pin._checks``), flagged just under it.
_ROTATION_TOLERANCE = 1e-9


class CompilationError(StewartPinError, RuntimeError):
    """The C library could not be built or loaded (the fallback says why)."""


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


#: The description fields the library depends on: the inertial parameters are an input
#: (base parameters), the name and the U-joint limits are not compiled in.
COMPILED_FIELDS = (
    "base_points",
    "platform_points",
    "leg_base_rotations",
    "stroke",
    "gravity",
    "home_pose",
)


def _sources_hash() -> str:
    """A hash of the generator's own source (a stale library is never loaded)."""
    h = hashlib.sha256()
    for name in ("symbolic.py", "_csource.py"):
        h.update((Path(__file__).parent / name).read_bytes())
    return h.hexdigest()[:16]


def cache_key(desc: Any, compiler: str) -> str:
    """The hash naming a robot's cache folder: of the compiled part of the description
    (:data:`COMPILED_FIELDS`; robots differing only in inertia, name or U-joint limits
    share a library), the CasADi version, the generator (version and source), the
    compiler and its flags."""
    d = desc.to_dict()
    text = json.dumps(
        {
            "description": {k: d[k] for k in COMPILED_FIELDS},
            "casadi": cs.__version__,
            "generator": GENERATOR_VERSION,
            "wrapper": _csource.WRAPPER_VERSION,
            "sources": _sources_hash(),
            "cflags": CFLAGS,
            "compiler": os.path.basename(compiler),
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def c_source(desc: Any) -> str:
    """The C source of a robot's library: CasADi's generated IDM and DDM (guarded
    variants) followed by the batch loops and guards of :mod:`._csource`."""
    models = generate_models(desc)
    cg = cs.CodeGenerator(
        "stewart_models.c",
        {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"},
    )
    cg.add(models.idm_guarded)
    cg.add(models.ddm_guarded)
    lo, hi = (float(x) for x in desc.stroke)
    fi, fd = models.idm_guarded, models.ddm_guarded
    wrapper = _csource.TEMPLATE % {
        "lo2": lo * lo * (1.0 + 1e-9),
        "hi2": hi * hi * (1.0 - 1e-9),
        "min_length2": LEG_MIN_LENGTH**2 * (1.0 + 1e-6),
        "min_sin2": LEG_SINGULARITY_SIN**2 * (1.0 + 1e-6),
        "rotation_tol": _ROTATION_TOLERANCE * (1.0 - 1e-3),
        "growth_limit": GROWTH_LIMIT,
        "idm_naux": AUX_IDM_SIZE,
        "ddm_naux": fd.size1_out(1),
        "growth": AUX_IDM_GROWTH,
        "det": AUX_IDM_DET,
        "fro2": AUX_IDM_FRO2,
        "idm": fi.name(),
        "ddm": fd.name(),
        **{f"idm_sz_{k}": getattr(fi, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
        **{f"ddm_sz_{k}": getattr(fd, f"sz_{k}")() for k in ("arg", "res", "iw", "w")},
    }
    return f"/* Generated by stewart-pin for robot '{desc.name}'. */\n{cg.dump()}\n{wrapper}"


def build_library(
    desc: Any, cache_dir: str | Path | None = None, compiler: str | None = None
) -> tuple[Path, bool]:
    """Build (or find in the cache) a robot's shared library.

    Returns ``(path, compiled_now)``. Raises :class:`CompilationError` when no compiler is
    found or the compilation fails.
    """
    compiler = compiler or find_compiler()
    if not compiler:
        raise CompilationError("no C compiler found (cc, gcc, clang or $CC)")
    folder = Path(cache_dir) if cache_dir is not None else cache_root()
    folder = folder / cache_key(desc, compiler)
    lib = folder / _LIB_NAME
    if lib.is_file():
        return lib, False
    try:
        folder.mkdir(parents=True, exist_ok=True)
        source = folder / "stewart_models.c"
        with tempfile.TemporaryDirectory(dir=folder) as tmp:
            tmp_c = Path(tmp) / "stewart_models.c"
            tmp_so = Path(tmp) / _LIB_NAME
            tmp_c.write_text(c_source(desc))
            cmd = [compiler, *CFLAGS, "-o", str(tmp_so), str(tmp_c), "-lm"]
            run = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            if run.returncode != 0 or not tmp_so.is_file():
                first = (run.stderr or run.stdout or "").strip().splitlines()
                raise CompilationError(
                    f"{os.path.basename(compiler)} failed ({run.returncode}): "
                    f"{first[0] if first else 'no output'}"
                )
            os.replace(tmp_c, source)
            os.replace(tmp_so, lib)
        meta = {
            "robot": desc.name,
            "casadi": cs.__version__,
            "cflags": CFLAGS,
            "compiler": compiler,
            "generator": GENERATOR_VERSION,
        }
        (folder / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    except (OSError, subprocess.SubprocessError) as e:
        raise CompilationError(f"cannot build the library in {folder}: {e}") from e
    return lib, True


def _warn_once(reason: str) -> None:
    if reason not in _WARNED:
        _WARNED.add(reason)
        warnings.warn(
            f"stewart-pin compiled backend unavailable ({reason}); using CasADi's virtual "
            "machine instead (same results, slower)",
            RuntimeWarning,
            stacklevel=3,
        )


_F64 = np.dtype(np.float64)


def _as_c(x: Any) -> np.ndarray | None:
    """``x`` as a C-contiguous float64 array, or None when it is not a plain numeric array."""
    if isinstance(x, np.ndarray):
        if x.dtype == _F64 and x.flags.c_contiguous:
            return x
        if x.dtype.kind not in "fiu":
            return None
        return np.ascontiguousarray(x, dtype=np.float64)
    if isinstance(x, (list, tuple)):
        try:
            arr = np.array(x, dtype=np.float64)
        except (TypeError, ValueError):
            return None
        return arr
    return None


class CompiledDynamics:
    """The generated IDM and DDM of a robot, compiled to C (or in CasADi's VM).

    Args:
        robot: a :class:`~stewart_pin.StewartRobot` (its description and
            ``max_condition`` are used; the description's geometry is compiled in).
        cache_dir: the cache folder (default :func:`cache_root`).
        compiler: the C compiler to use (default :func:`find_compiler`); ``False`` forces
            the virtual machine.

    Methods (one state: ``pose`` (4, 4) / ``pin.SE3``, vectors (6,); a batch: (N, 4, 4) and
    (N, 6); the result has the same form):

    - ``inverse_dynamics(pose, twist, accel, base_values=None)`` -> Gamma [N];
    - ``direct_dynamics(pose, twist, gamma, base_values=None)`` -> the classical platform
      acceleration ``[dv/dt, dw/dt]`` in F0;
    - ``inverse_dynamics_stream(chunks)`` / ``direct_dynamics_stream(chunks)``: an iterator
      of results over an iterable of ``(pose, twist, x)`` batches, for data larger than
      memory.

    ``base_values`` (88,) replaces the robot's base parameters (names in
    :attr:`parameter_names`, e.g. identified values); default the description's.
    Conventions and errors are those of ``StewartRobot.inverse_dynamics`` /
    ``direct_dynamics`` (see the module docstring).

    Attributes:
        kind: ``"compiled"`` or ``"vm"``. reason: why the VM is used (``None`` if compiled).
        library: the shared library's path. compiled_now: whether this construction
            compiled it (``False``: found in the cache).
        parameter_names, base_values: the 88 base parameters and the robot's values.
    """

    def __init__(
        self, robot: Any, cache_dir: str | Path | None = None, compiler: str | bool | None = None
    ) -> None:
        self.robot = robot
        desc = robot.description
        self._desc = desc
        bp = grouped_parameters(desc)
        self.parameter_names: tuple[str, ...] = bp.names
        self.base_values = np.ascontiguousarray(bp.values, dtype=np.float64)
        self.base_values.flags.writeable = False
        self._limits = desc.u_joint_limits is not None
        self.kind, self.reason = "vm", None
        self.library: Path | None = None
        self.compiled_now = False
        self._vm_idm = self._vm_ddm = None
        if compiler is False:
            self.reason = "compiler disabled"
        else:
            try:
                self.library, self.compiled_now = build_library(
                    desc, cache_dir, compiler if isinstance(compiler, str) else None
                )
                self._load(self.library)
                self.kind = "compiled"
            except (CompilationError, OSError, AttributeError) as e:
                self.reason = str(e).splitlines()[0] if str(e) else type(e).__name__
        if self.kind == "vm":
            _warn_once(self.reason or "unknown")

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
        # Single-state buffers with their addresses taken once (numpy's .ctypes.data costs
        # about a microsecond per array); a lock makes them safe across threads.
        self._lock = threading.Lock()
        self._one = np.zeros(16 + 6 + 6 + 6)
        self._one_T = self._one[:16].reshape(4, 4)
        self._one_V, self._one_X, self._one_out = (
            self._one[16:22],
            self._one[22:28],
            self._one[28:34],
        )
        self._one_flag = np.zeros(1, dtype=np.int32)
        base = self._one.ctypes.data
        self._one_ptr = (base, base + 16 * 8, base + 22 * 8, base + 28 * 8)
        self._one_flag_ptr = self._one_flag.ctypes.data
        self._chi_ptr = self.base_values.ctypes.data

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
    def _chi(self, base_values: Any) -> np.ndarray:
        if base_values is None:
            return self.base_values
        chi = check_array(base_values, (len(self.parameter_names),), "base_values")
        return np.ascontiguousarray(chi)

    def _run(self, which: str, pose: Any, twist: Any, x: Any, name: str, base_values: Any):
        if self.kind != "compiled":
            return self._run_vm(which, pose, twist, x, name, self._chi(base_values))
        if (
            type(pose) is np.ndarray
            and type(twist) is np.ndarray
            and type(x) is np.ndarray
            and pose.dtype.kind == twist.dtype.kind == x.dtype.kind == "f"
        ):
            if pose.shape == (4, 4) and twist.shape == (6,) and x.shape == (6,):
                return self._run_one(which, pose, twist, x, name, base_values)
            if pose.shape == (1, 4, 4) and twist.shape == (1, 6) and x.shape == (1, 6):
                out = self._run_one(which, pose[0], twist[0], x[0], name, base_values, True)
                return out[None]
        chi = self._chi(base_values)
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
        any_flag = self._c[which](
            n,
            T.ctypes.data,
            V.ctypes.data,
            X.ctypes.data,
            chi.ctypes.data,
            self.robot.max_condition,
            out.ctypes.data,
            flags.ctypes.data,
        )
        if any_flag or self._limits:
            self._resolve(which, flags, pose, twist, x, name, T.reshape(-1, 4, 4))
        return out if batched else out[0]

    def _run_one(
        self, which: str, pose, twist, x, name: str, base_values: Any, batch: bool = False
    ) -> np.ndarray:
        """One state given as float arrays, copied into the preallocated buffers (``batch``:
        it came as a batch of one, for the error messages)."""
        chi_ptr = self._chi_ptr
        if base_values is not None:
            chi = self._chi(base_values)
            chi_ptr = chi.ctypes.data
        pT, pV, pX, pout = self._one_ptr
        with self._lock:
            self._one_T[...] = pose
            self._one_V[...] = twist
            self._one_X[...] = x
            any_flag = self._c[which](
                1, pT, pV, pX, chi_ptr, self.robot.max_condition, pout, self._one_flag_ptr
            )
            out = self._one_out.copy()
            flags = self._one_flag.copy()
            T = self._one_T.copy() if any_flag or self._limits else None
        if T is not None:
            if batch:
                pose, twist, x = pose[None], twist[None], x[None]
            self._resolve(which, flags, pose, twist, x, name, T[None])
        return out

    def _resolve(self, which, flags, pose, twist, x, name, T) -> None:
        """Raise the reference's error for flagged states (or accept them)."""
        bits = int(np.bitwise_or.reduce(flags)) if flags.size else 0
        desc = self._desc
        if bits & _INPUT:
            check_states(pose, (twist, "twist"), (x, name))
        if bits & _GEOMETRY or self._limits:
            inverse_geometry_batch(desc, T)
        max_condition = self.robot.max_condition
        if bits & _COND:
            idx = np.flatnonzero(flags & _COND)
            c = np.linalg.cond(inverse_jacobian_batch(desc, T[idx]))
            if np.any(~(c <= max_condition)):
                check_condition(inverse_jacobian_batch(desc, T), max_condition)
        if bits & _NOT_PD:
            raise SingularityError(
                "A_robot is not positive definite (massless robot or singular leg)", np.nan, 0.0
            )
        if bits & _NONFINITE:
            n = int(np.argmax(flags & _NONFINITE != 0))
            raise StewartPinError(
                f"the compiled {which.upper()} gave a non-finite result at state {n} (check "
                "base_values)"
            )

    # ------------------------------------------------------------------ virtual machine
    def _vm_function(self, which: str) -> cs.Function:
        attr = f"_vm_{which}"
        if getattr(self, attr) is None:
            models = generate_models(self._desc)
            setattr(self, attr, models.idm_guarded if which == "idm" else models.ddm_guarded)
        return getattr(self, attr)

    def _run_vm(self, which: str, pose: Any, twist: Any, x: Any, name: str, chi: np.ndarray):
        batched, T, V, X = check_states(pose, (twist, "twist"), (x, name))
        desc = self._desc
        inverse_geometry_batch(desc, T)
        check_condition(inverse_jacobian_batch(desc, T), self.robot.max_condition)
        f = self._vm_function(which)
        n = T.shape[0]
        out = np.empty((n, 6))
        aux = np.empty((n, f.size1_out(1)))
        for s in range(0, n, VM_CHUNK):
            e = min(n, s + VM_CHUNK)
            r, a = f(T[s:e].reshape(-1, 16).T, V[s:e].T, X[s:e].T, chi)
            out[s:e], aux[s:e] = np.array(r).T, np.array(a).T
        if which == "idm":
            bad = np.flatnonzero(~(aux[:, AUX_IDM_GROWTH] <= GROWTH_LIMIT))
            for k in bad:  # static pivots off: solve again with partial pivoting
                J = aux[k, AUX_JINV].reshape(6, 6)
                out[k] = aux[k, AUX_IDM_HZ] + np.linalg.solve(J.T, aux[k, AUX_IDM_F])
        elif np.any(~(aux[:, AUX_DDM_D] > 0.0)):
            raise SingularityError(
                "A_robot is not positive definite (massless robot or singular leg)", np.nan, 0.0
            )
        if not np.all(np.isfinite(out)):
            n_bad = int(np.argmax(~np.all(np.isfinite(out), axis=1)))
            raise StewartPinError(
                f"the {which.upper()} gave a non-finite result at state {n_bad} (check "
                "base_values)"
            )
        return out if batched else out[0]


_BACKENDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def compiled_backend(robot: Any, **kwargs: Any) -> CompiledDynamics:
    """The :class:`CompiledDynamics` of ``robot``, built on first use and kept with it
    (keyword arguments go to the constructor on that first call)."""
    backend = _BACKENDS.get(robot)
    if backend is None or backend._desc is not robot.description:
        backend = CompiledDynamics(robot, **kwargs)
        _BACKENDS[robot] = backend
    return backend
