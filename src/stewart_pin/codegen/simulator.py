"""The compiled simulator: :func:`~stewart_pin.motion.simulation.simulate`'s integrators
(fixed-step RK4 and the adaptive Dormand-Prince 5(4)) run in C around a robot's compiled
direct model (:mod:`._simsource`).

:func:`compiled_stepper` gives :func:`~stewart_pin.motion.simulation.simulate` a
:class:`Stepper` when the robot's direct model is compiled and the run's options are ones
the C loop reproduces (else the reason it cannot): no ``dynamics`` but
:func:`~stewart_pin.motion.payload.simulate_payload`'s on rk4 (the payload library's
``sp_ppdm_sim``, the joints sampled at every stage time before the run), a robot without the
6-UPS U-joint limits (the reference inverse geometry checks them), and forces that are

- ``None`` (zero), a :class:`~stewart_pin.motion.force_tables.ForceTable` (constant, held
  or interpolated table), computed in C;
- a :class:`~stewart_pin.motion.control.ComputedTorqueController` whose model's inverse
  model is compiled too, the law in C. Its reference, a
  :class:`~stewart_pin.motion.trajectories.FourierTrajectory`,
  :class:`~stewart_pin.motion.trajectories.Sinusoids` or
  :class:`~stewart_pin.motion.trajectories.MinimumJerkKnots`, is evaluated in C at every
  time the loop asks (``sp_ref_eval``: the formulas of
  :func:`~stewart_pin.motion.trajectories.states_at`, equal to round-off), with or without
  a ``control_period`` on either method; any other reference is sampled once, before the
  run, at the times the Python loop asks for it (rk4: every stage time, or every control
  period's start; the adaptive method: every period's start, so it needs a
  ``control_period``);
- any other function with a ``control_period``: called from Python once per period (the C
  loop stops at the period's end state and goes on with the forces it returns).

With ``output_dt`` the C loop cuts the steps at the output times and writes only the rows
the Python loop keeps (``_Run.record``'s rule; the output index travels with the state
block); a call takes at most as many steps as its buffers hold rows.

The trajectories are those of the Python loop (same arithmetic, see :mod:`._simsource`);
any step the C loop does not take (an event, a state the guard flags) the Python loop
takes, then the C loop goes on. :func:`simulate_batch` runs many initial states or force
tables in one call across threads.

The simulator's library does not depend on the robot (the models are called through
function pointers): it is compiled once per machine into the cache of
:mod:`.compiled` (about a second).
"""

from __future__ import annotations

import ctypes
import itertools
import threading
import weakref
from collections.abc import Sequence
from typing import Any

import numpy as np

from stewart_pin.codegen import _simsource as S
from stewart_pin.codegen._architecture import codegen_kind
from stewart_pin.codegen.compiled import (
    CFLAGS,
    CompiledDynamics,
    build_source_library,
    model_layout,
    split_batch,
)
from stewart_pin.codegen.lanes import lanes_entries
from stewart_pin.codegen.leg_chain_symbolic import AuxLayout
from stewart_pin.exceptions import CompilationError, InputError, SimulationError
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.motion.force_tables import ForceTable
from stewart_pin.motion.simulation import SimulationResult, grid_times, prepare_run
from stewart_pin.motion.trajectories import (
    CoordinateMotion,
    FourierTrajectory,
    MinimumJerkKnots,
    Sinusoids,
    states_at,
)
from stewart_pin.protocols import RobotLike

#: The simulator's compiler flags: the models' without ``-freciprocal-math`` (the divisions
#: as written, as NumPy and Pinocchio do them), at ``-O3`` (a small library; no
#: ``-march``: the cached library runs on any x86-64).
SIM_CFLAGS = tuple("-O3" if f == "-O2" else f for f in CFLAGS if f != "-freciprocal-math")
#: Rows of the output buffers of one C call (then Python keeps them and the loop goes on).
CHUNK_ROWS = 4096

_LIB: list[Any] = []
_LIB_LOCK = threading.Lock()
_P = ctypes.c_void_p
#: Ids of the references evaluated in C, unique in the process (``sp_sim.ref_id``: the key
#: of a thread's last evaluation in the C loop).
_REF_IDS = itertools.count(1)


class _Sim(ctypes.Structure):
    """``sp_sim`` of :mod:`._simsource` (every field 8 bytes)."""

    _fields_ = [
        ("ddm", _P),
        ("chi", _P),
        ("max_cond", ctypes.c_double),
        ("naux", ctypes.c_longlong),
        ("jinv", ctypes.c_longlong),
        ("dt", ctypes.c_double),
        ("duration", ctypes.c_double),
        ("period", ctypes.c_double),
        ("n_grid", ctypes.c_longlong),
        ("kind", ctypes.c_longlong),
        ("g_const", _P),
        ("n_tab", ctypes.c_longlong),
        ("tab_t", _P),
        ("tab_g", _P),
        ("idm", _P),
        ("idm_chi", _P),
        ("idm_max_cond", ctypes.c_double),
        ("ref_per_period", ctypes.c_longlong),
        ("n_ref", ctypes.c_longlong),
        ("ref_t", _P),
        ("ref_T", _P),
        ("ref_V", _P),
        ("ref_A", _P),
        ("kp", _P),
        ("kd", _P),
        ("rows", ctypes.c_longlong),
        ("t_out", _P),
        ("P_out", _P),
        ("V_out", _P),
        ("A_out", _P),
        ("G_out", _P),
        ("q3sq", ctypes.c_longlong),
        ("L_out", _P),
        ("adaptive", ctypes.c_longlong),
        ("rtol", ctypes.c_double),
        ("atol", ctypes.c_double),
        ("h_min", ctypes.c_double),
        ("act", _P),
        ("ref_kind", ctypes.c_longlong),
        ("ref_pose", _P),
        ("ref_n", ctypes.c_longlong),
        ("ref_data", _P),
        ("ref_id", ctypes.c_longlong),
        ("output_dt", ctypes.c_double),
        ("n_pay", ctypes.c_longlong),
        ("pay_t", _P),
        ("pay_x", _P),
        ("pay_nx", ctypes.c_longlong),
    ]


def simulator_library() -> Any:
    """The simulator's shared library (built once per machine, loaded once per process)."""
    with _LIB_LOCK:
        if not _LIB:
            loaded: list[Any] = []
            build_source_library(
                lambda: S.SOURCE,
                load=lambda path: loaded.append(ctypes.CDLL(str(path))),
                announce="the compiled simulator",
                cflags=SIM_CFLAGS,
            )
            lib = loaded[0]
            lib.sp_sim_run.argtypes = [_P, _P, ctypes.c_longlong]
            lib.sp_sim_run.restype = ctypes.c_int
            raw = lib["sp_sim_run"]  # another function object: called without conversions
            raw.restype = ctypes.c_int
            lib.sp_sim_run_raw = raw
            lib.sp_sim_many.argtypes = [
                ctypes.c_longlong,
                _P,
                _P,
                ctypes.c_longlong,
                ctypes.c_longlong,
                _P,
            ]
            lib.sp_sim_many.restype = ctypes.c_int
            _LIB.append(lib)
        return _LIB[0]


#: ``sp_ddm_aux``'s C type (the robot library's, or ``sp_ddm_lanes``; arguments as
#: ``c_void_p`` and ``c_double`` objects).
_DDM_AUX = ctypes.CFUNCTYPE(ctypes.c_int, _P, _P, _P, _P, ctypes.c_double, _P, _P, _P)


def _address(lib: Any, name: str) -> int:
    return int(ctypes.cast(getattr(lib, name), ctypes.c_void_p).value or 0)


_LAYOUTS: weakref.WeakKeyDictionary[CompiledDynamics, AuxLayout] = weakref.WeakKeyDictionary()


def _layout(models: CompiledDynamics, robot: RobotLike) -> AuxLayout:
    """The by-products' layout of ``models`` (computed once per models object: a general
    robot's regenerates its symbolic models' key)."""
    layout = _LAYOUTS.get(models)
    if layout is None:
        layout = _LAYOUTS[models] = model_layout(robot.description)
    return layout


def _compiled(robot: RobotLike, backend: str) -> CompiledDynamics | str:
    """The robot's compiled models serving ``backend``, or why there are none."""
    fast = getattr(robot, "_fast_backend", None)
    models = fast(backend) if fast is not None else None
    if not isinstance(models, CompiledDynamics) or models.kind != "compiled":
        return f"the direct model of backend={backend!r} is not compiled"
    return models


class _Forces:
    """The force arrays of one run, kept alive with the ``_Sim`` pointing at them."""

    def __init__(
        self,
        forces: Any,
        period: float | None,
        dt: float,
        duration: float,
        n_grid: int,
        adaptive: bool = False,
    ) -> None:
        self.keep: list[Any] = []
        self.fields: dict[str, Any] = {}
        self.reason: str | None = None
        if forces is None:
            forces = ForceTable.constant(np.zeros(6))
        if isinstance(forces, ForceTable):
            if forces.times.size == 1:
                self._set(kind=S.KIND_CONSTANT, g_const=self._arr(forces.values[0]))
            else:
                kind = S.KIND_HOLD if forces.interpolation == "hold" else S.KIND_LINEAR
                self._set(
                    kind=kind,
                    n_tab=forces.times.size,
                    tab_t=self._arr(forces.times),
                    tab_g=self._arr(forces.values),
                )
        elif (  # not a subclass's own law (the payload's computed torque, its own
            # command, one set on the instance): a function
            isinstance(forces, ComputedTorqueController)
            and type(forces).__call__ is ComputedTorqueController.__call__
            and type(forces).command is ComputedTorqueController.command
            and "command" not in getattr(forces, "__dict__", {})
        ):
            if adaptive and period is None and _reference_data(forces.reference) is None:
                self.reason = (
                    "the computed-torque controller without control_period on the adaptive "
                    f"method with a reference of type {type(forces.reference).__name__} (its "
                    "stage times are not known before the run; the C loop evaluates a "
                    "FourierTrajectory, Sinusoids or MinimumJerkKnots itself)"
                )
            else:
                self._controller(forces, period, dt, duration, n_grid, adaptive)
        elif period is not None:
            self._set(kind=S.KIND_EXTERNAL)
        else:
            self.reason = (
                "a forces function without control_period (called at every stage: give a "
                "control_period, a ForceTable or the ComputedTorqueController)"
            )

    def _arr(self, x: Any) -> int:
        a = np.ascontiguousarray(x, dtype=np.float64)
        self.keep.append(a)
        return int(a.ctypes.data)

    def _set(self, **fields: Any) -> None:
        self.fields.update(fields)

    def _controller(
        self,
        c: ComputedTorqueController,
        period: float | None,
        dt: float,
        duration: float,
        n_grid: int,
        adaptive: bool = False,
    ) -> None:
        model = _compiled(c.model, c.backend)
        if isinstance(model, str):
            self.reason = f"the controller's model: {model.replace('direct', 'inverse')}"
            return
        try:  # the gains as the law applies them (kp, kd may be set after __post_init__)
            kp, kd = (np.broadcast_to(np.asarray(g, dtype=np.float64), (6,)) for g in (c.kp, c.kd))
        except (TypeError, ValueError):
            self.reason = "the controller's gains kp, kd are not scalars or (6,)"
            return
        self.keep.append(model)
        self._set(
            kind=S.KIND_CT,
            # the legs as vector lanes where they apply (codegen/lanes.py)
            idm=lanes_entries(model)[1] or _address(model._lib, "sp_idm_sim"),
            idm_chi=int(model.base_values.ctypes.data),
            idm_max_cond=float(c.model.max_condition),
            kp=self._arr(kp),
            kd=self._arr(kd),
        )
        data = _reference_data(c.reference)
        if data is not None:  # evaluated in C at every time the loop asks
            ref_kind, ref_n, values, pose = data
            self._set(
                ref_kind=ref_kind,
                ref_pose=self._arr(pose),
                ref_n=ref_n,
                ref_data=self._arr(values),
                ref_id=next(_REF_IDS),
            )
            return
        grid = grid_times(dt, duration, n_grid)
        if adaptive:  # the periods' starts (k + 1) * period, where the steps end
            assert period is not None
            grid = np.arange(int(np.floor(duration / period + 1e-9)) + 1) * float(period)
        if period is None:  # every stage time: t_n, t_n + h/2 (k2, k3), t_n+1 (k4, end)
            times = rows = _stage_times(grid)
        else:  # the start of each period (the accepted state sampled there)
            k = np.floor(grid / period + 1e-9).astype(np.int64)
            first = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
            rows = np.full(int(k[-1]) + 1, np.nan)
            rows[k[first]] = grid[first]
            times = grid[first]
        T, V, A = _sample(c.reference, times)
        if period is not None and first.size < rows.size:  # periods without a grid time
            full = np.full((rows.size, 4, 4), np.nan)
            full[k[first]] = T
            T = full
            Vf, Af = np.full((rows.size, 6), np.nan), np.full((rows.size, 6), np.nan)
            Vf[k[first]], Af[k[first]] = V, A
            V, A = Vf, Af
        self._set(
            ref_kind=S.REF_TABLE,
            ref_per_period=int(period is not None),
            n_ref=rows.size,
            ref_t=self._arr(rows),
            ref_T=self._arr(T),
            ref_V=self._arr(V),
            ref_A=self._arr(A),
        )


def _stage_times(grid: np.ndarray) -> np.ndarray:
    """The rk4 stage times of the grid ``grid`` (n + 1,) [s], (2 n + 1,): row ``2 n`` the
    grid time ``t_n`` (k1; k4 and the end state of the step before), row ``2 n + 1`` the
    midpoint ``t_n + h/2`` (k2, k3), computed as the C loop computes it."""
    times = np.empty(2 * grid.size - 1)
    times[0::2] = grid
    times[1::2] = grid[:-1] + (grid[1:] - grid[:-1]) / 2
    return times


def _reference_data(reference: Any) -> tuple[int, int, np.ndarray, np.ndarray] | None:
    """``(ref_kind, ref_n, ref_data, ref_pose)`` of a reference the C loop evaluates itself (the
    exact types :class:`~stewart_pin.motion.trajectories.FourierTrajectory`,
    :class:`~stewart_pin.motion.trajectories.Sinusoids` and
    :class:`~stewart_pin.motion.trajectories.MinimumJerkKnots`: their coordinates, the
    products their ``coordinates`` computes first, as ``sp_ref_coordinates`` of
    :mod:`._simsource` reads them), else None (sampled before the run)."""
    kind = type(reference)
    if kind is FourierTrajectory:
        n = reference.n_harmonics
        w = reference.angular_frequencies  # coordinates()'s
        parts = [w, reference.offsets, reference.sine.ravel(), reference.cosine.ravel()]
        return S.REF_FOURIER, n, np.concatenate(parts), reference.reference
    if kind is Sinusoids:
        om = reference.angular_frequencies  # coordinates()'s
        phases = reference.phases
        parts = [om, phases, reference.amplitudes, np.sin(phases)]
        return S.REF_SINUSOIDS, 6, np.concatenate(parts).astype(np.float64), reference.reference
    if kind is MinimumJerkKnots:
        counts = [len(axis) for axis in reference.knots]
        parts = [np.array(counts, dtype=np.float64)]
        for axis in reference.knots:
            parts.append(np.array([float(t) for t, _ in axis], dtype=np.float64))
            parts.append(np.array([float(v) for _, v in axis], dtype=np.float64))
        return S.REF_MINIMUM_JERK, sum(counts), np.concatenate(parts), reference.reference
    return None


#: The ``__call__`` methods :func:`~stewart_pin.motion.trajectories.states_at` computes
#: (``_states`` of the motion's ``coordinates``, one time or many).
_COORDINATE_CALLS = (CoordinateMotion.__call__, FourierTrajectory.__call__)


def _sample(reference: Any, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference's ``(T, V, A)`` at ``times`` as the Python loop's ``reference(t)``
    gives them: :func:`~stewart_pin.motion.trajectories.states_at` for a motion of
    :mod:`stewart_pin.motion.trajectories` whose ``__call__`` is its class's (the same
    arithmetic, vectorised), else one call per time (a subclass's own ``__call__``, which
    its inherited ``sample`` would not follow)."""
    increasing = times.size > 1 and bool(np.all(np.diff(times) > 0))
    if increasing and type(reference).__call__ in _COORDINATE_CALLS:
        return states_at(reference, times)
    T, V, A = np.empty((times.size, 4, 4)), np.empty((times.size, 6)), np.empty((times.size, 6))
    for i, t in enumerate(times):
        T[i], V[i], A[i] = reference(float(t))
    return T, V, A


class Stepper:
    """One run's compiled loop (the object :func:`simulate` drives): a state block, the
    ``sp_sim`` record and output buffers of :data:`CHUNK_ROWS` rows."""

    def __init__(
        self,
        robot: RobotLike,
        models: CompiledDynamics,
        forces: _Forces,
        dt: float,
        duration: float,
        period: float | None,
        n_grid: int,
        adaptive: tuple[float, float] | None = None,
        output_dt: float | None = None,
        h_min: float = 0.0,
        payload: _Payload | None = None,
    ) -> None:
        self.lib = simulator_library()
        self.external = forces.fields.get("kind") == S.KIND_EXTERNAL
        layout = _layout(models, robot)
        # Output rows per call: the whole rk4 run when it is shorter than a chunk.
        self.capacity = CHUNK_ROWS if adaptive is not None else min(CHUNK_ROWS, n_grid + 1)
        # The 6-UPS leg lengths from the direct model's q3^2; general legs: the actuated
        # joint values from the library's sp_act_batch (chain legs: computed by
        # robot.actuator_positions afterwards, as the Python loop does).
        kind = codegen_kind(robot.description)
        q3sq = kind.leg_length_squares
        self._act = kind.compiled_actuators
        act = _address(models._lib, "sp_act_batch") if self._act and q3sq is None else 0
        if payload is not None:  # the actuator positions computed with the result
            q3sq, act, self._act = None, 0, False
        self._ups = q3sq is not None or act != 0  # the rows carry the actuator positions
        self._models = models
        self._payload = payload
        self.st = np.zeros(S.ST_SIZE)
        # Views of the state block taken once (a Python forces function's hot path).
        self._held_g = self.st[S.ST_HELD_G : S.ST_HELD_G + 6]
        self._pend_T = self.st[S.ST_PEND_POSE : S.ST_PEND_POSE + 16].reshape(4, 4)
        self._pend_V = self.st[S.ST_PEND_TWIST : S.ST_PEND_TWIST + 6]
        self._keep = (models, forces)
        model: dict[str, Any] = {
            # the legs as vector lanes where they apply (codegen/lanes.py), else the library's
            "ddm": (payload is None and lanes_entries(models)[0])
            or _address(models._lib, "sp_ddm_aux"),
            "chi": int(models.base_values.ctypes.data),
            "naux": layout.ddm_size,
            "jinv": layout.jinv,
        }
        if payload is not None:  # the payload's direct model, its joints as inputs
            model.update(payload.fields)
        self._ddm = _DDM_AUX(model["ddm"])
        sim = _Sim(
            max_cond=float(robot.max_condition),
            dt=dt,
            duration=duration,
            period=0.0 if period is None else period,
            n_grid=n_grid,
            q3sq=q3sq.start if q3sq is not None else -1,
            adaptive=int(adaptive is not None),
            rtol=adaptive[0] if adaptive else 0.0,
            atol=adaptive[1] if adaptive else 0.0,
            h_min=h_min,
            act=act or None,
            output_dt=0.0 if output_dt is None else output_dt,
            **forces.fields,
            **model,
        )
        self.sim = sim
        self._buffers()
        self._args = (ctypes.byref(sim), ctypes.c_void_p(self.st.ctypes.data))
        self._n_stop = (n_grid, ctypes.c_longlong(n_grid))
        self._run = self.lib.sp_sim_run_raw  # no argument types: prepared arguments

    def _buffers(self) -> None:
        """New output buffers (the rows handed out by :meth:`rows` keep the old ones)."""
        m = self.capacity
        self.t = np.empty(m)
        self.P = np.empty((m, 4, 4))
        self.V, self.A, self.G = (np.empty((m, 6)) for _ in range(3))
        self.L = np.empty((m, 6)) if self._ups else None
        sim = self.sim
        sim.rows = m
        sim.t_out, sim.P_out = self.t.ctypes.data, self.P.ctypes.data
        sim.V_out, sim.A_out, sim.G_out = (a.ctypes.data for a in (self.V, self.A, self.G))
        sim.L_out = None if self.L is None else self.L.ctypes.data
        self._handed = False

    def ready(self) -> None:
        """New buffers if the last rows were handed out (before a call of the C loop)."""
        if self._handed:
            self._buffers()

    def load(
        self,
        t: float,
        T: np.ndarray,
        V: np.ndarray,
        dy: np.ndarray,
        gamma: np.ndarray,
        sign: float,
        held: tuple[int, np.ndarray] | None,
        n: int,
        h: float = 0.0,
        n_output: int = 0,
    ) -> None:
        """Start from an accepted state at grid index ``n`` (``held``: the forces held
        over the current control period; ``h``: the adaptive method's next trial step;
        ``n_output``: with ``output_dt``, the index of the next output time)."""
        st = self.st
        written = st[S.ST_ROW]  # rows not handed out yet (the initial state's) stay
        st[:] = 0.0
        st[S.ST_ROW] = written
        st[S.ST_T] = t
        st[S.ST_POSE : S.ST_POSE + 16] = T.ravel()
        st[S.ST_TWIST : S.ST_TWIST + 6] = V
        st[S.ST_DY : S.ST_DY + 12] = dy
        st[S.ST_GAMMA : S.ST_GAMMA + 6] = gamma
        st[S.ST_SIGN] = sign
        self.hold(held)
        st[S.ST_N] = n
        st[S.ST_H] = h
        st[S.ST_OUT_K] = n_output

    def start(self, T: np.ndarray, V: np.ndarray) -> bool:
        """Evaluate the initial state ``(0, T, V)`` in C as the Python loop's first state
        (row 0; the forces, the direct model and the sign of det Jp^-1): True, or False
        when the Python loop must (forces from a Python function, a state the guard flags,
        a sign the cheap condition check does not decide)."""
        if self.external:
            return False
        st = self.st
        st[:] = 0.0
        st[S.ST_POSE : S.ST_POSE + 16] = T.ravel()
        st[S.ST_TWIST : S.ST_TWIST + 6] = V
        st[S.ST_HELD_K] = -1.0
        st[S.ST_H] = self.sim.dt
        st[S.ST_PENDING] = S.PENDING_START
        if self.run(0) != S.DONE or st[S.ST_ROW] != 1.0:
            st[S.ST_ROW] = 0.0
            return False
        return True

    def has_rows(self) -> bool:
        """Whether rows were written since the last :meth:`rows`."""
        return bool(self.st[S.ST_ROW] > 0.0)

    def sign(self) -> float:
        """The sign of det Jp^-1 of the state block's run."""
        return float(self.st[S.ST_SIGN])

    def hold(self, held: tuple[int, np.ndarray] | None) -> None:
        """The forces held over control period ``held[0]``."""
        if held is None:
            self.st[S.ST_HELD_K] = -1.0
        else:
            self.st[S.ST_HELD_K] = held[0]
            self._held_g[:] = held[1]

    def run(self, n_stop: int) -> int:
        """Grid steps up to ``n_stop``: the status (:data:`._simsource.DONE`, ``BAIL`` or
        ``NEED_FORCE``)."""
        self.ready()
        if n_stop != self._n_stop[0]:
            self._n_stop = (n_stop, ctypes.c_longlong(n_stop))
        status: int = self._run(*self._args, self._n_stop[1])
        return status

    def steps(self) -> int:
        """The steps accepted since the last call (with ``output_dt`` more than the rows
        written: only the states at the output times are)."""
        taken = int(self.st[S.ST_STEPS])
        self.st[S.ST_STEPS] = 0.0
        return taken

    def output_index(self) -> int:
        """With ``output_dt``: the index of the next output time (``_Run.n_output``)."""
        return int(self.st[S.ST_OUT_K])

    @property
    def n(self) -> int:
        """The grid index of the state in the block (rk4)."""
        return int(self.st[S.ST_N])

    def rows(self) -> tuple[np.ndarray | None, ...]:
        """The rows written since the last call (times, poses, twists, accelerations,
        forces, and the 6-UPS leg lengths or None): views of the buffers, which are handed
        over (the next run writes into new ones), or copies of a few rows (a quarter of the
        buffers or less: ``output_dt``'s sparse rows keep no whole buffer alive)."""
        m = int(self.st[S.ST_ROW])
        self.st[S.ST_ROW] = 0.0
        if m == 0:
            return (np.zeros(0),) * 5 + (None,)
        few = 4 * m <= self.capacity
        self._handed = self._handed or not few
        arrays = (self.t, self.P, self.V, self.A, self.G, self.L)
        return tuple(None if a is None else a[:m].copy() if few else a[:m] for a in arrays)

    def state(self) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The last accepted state: ``(t, T, V, dy, gamma)`` (copies)."""
        st = self.st
        return (
            float(st[S.ST_T]),
            st[S.ST_POSE : S.ST_POSE + 16].reshape(4, 4).copy(),
            st[S.ST_TWIST : S.ST_TWIST + 6].copy(),
            st[S.ST_DY : S.ST_DY + 12].copy(),
            st[S.ST_GAMMA : S.ST_GAMMA + 6].copy(),
        )

    def step(self) -> float:
        """The adaptive method's next trial step [s]."""
        return float(self.st[S.ST_H])

    def det_sign(self, T: np.ndarray) -> float | None:
        """The sign of det Jp^-1 at pose ``T`` from the compiled direct model (the
        determinant of its cheap condition check, as the C loop takes its stages' signs),
        or None where that check does not decide it (the caller computes it)."""
        if self.sim.max_cond > S.STATIC_SIGN_COND or self._payload is not None:
            return None
        aux = np.empty(self.sim.naux)
        out, det = np.empty(6), ctypes.c_double(0.0)
        T = np.ascontiguousarray(T, dtype=np.float64)
        zero = np.zeros(6)
        flag = self._ddm(
            *(ctypes.c_void_p(a.ctypes.data) for a in (T, zero, zero)),
            ctypes.c_void_p(self.sim.chi),
            ctypes.c_double(self.sim.max_cond),
            *(ctypes.c_void_p(a.ctypes.data) for a in (out, aux)),
            ctypes.byref(det),
        )
        d = det.value
        return None if flag != 0 or d == 0.0 else (1.0 if d > 0.0 else -1.0)

    def actuator_positions(self, poses: np.ndarray) -> np.ndarray | None:
        """The actuated joint values (N, 6) of poses (N, 4, 4) from the library's
        ``sp_act_batch`` (general legs: as the C loop writes them in its rows; 6-UPS: the
        leg lengths in closed form), or None where the robot has none."""
        if not self._act:
            return None
        P = np.ascontiguousarray(poses, dtype=np.float64)
        out = np.empty((P.shape[0], 6))
        self._models._lib.sp_act_batch(
            ctypes.c_longlong(P.shape[0]),
            ctypes.c_void_p(P.ctypes.data),
            ctypes.c_void_p(out.ctypes.data),
        )
        return out

    def held(self) -> tuple[int, np.ndarray] | None:
        k = self.st[S.ST_HELD_K]
        return None if k < 0 else (int(k), self.st[S.ST_HELD_G : S.ST_HELD_G + 6].copy())

    def pending(self) -> tuple[float, np.ndarray, np.ndarray]:
        """The end state waiting for its forces: ``(t, T, V)`` (copies)."""
        return float(self.st[S.ST_PEND_T]), self._pend_T.copy(), self._pend_V.copy()

    def drop_pending(self) -> None:
        self.st[S.ST_PENDING] = 0.0


def compiled_stepper(
    robot: RobotLike,
    backend: str,
    forces: Any,
    method: str,
    dt: float,
    duration: float,
    control_period: float | None,
    output_dt: float | None,
    dynamics: Any,
    n_grid: int,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    h_min: float = 1e-12,
) -> Stepper | str:
    """A :class:`Stepper` for this run of :func:`simulate`, or the reason the compiled
    loop cannot run it (module docstring)."""
    payload = None
    if dynamics is not None:
        payload = _payload(dynamics, method, dt, duration, n_grid)
        if isinstance(payload, str):
            return payload
    models = _compiled(robot, backend)
    if isinstance(models, str):
        return models
    adaptive = method == "adaptive"
    data = _Forces(forces, control_period, dt, duration, n_grid, adaptive)
    if data.reason is not None:
        return data.reason
    try:
        simulator_library()
    except CompilationError as e:
        return f"the simulator's library: {str(e).splitlines()[0] if str(e) else e}"
    tolerances = (rtol, atol) if adaptive else None
    return Stepper(
        robot,
        models,
        data,
        dt,
        duration,
        control_period,
        n_grid,
        tolerances,
        output_dt,
        h_min,
        payload,
    )


class _Payload:
    """A payload's compiled prescribed direct model in the C loop (``sp_ppdm_sim`` of its
    library, :mod:`.payload_compiled`) and its joints ``[q, qd, qdd]`` sampled at every
    rk4 stage time (rows ``2 n``: the grid times, ``2 n + 1``: the midpoints, as the
    computed-torque controller's reference), kept alive with the ``_Sim``."""

    def __init__(self, models: Any, times: np.ndarray, x: np.ndarray) -> None:
        entry, naux, jinv = models.sim_entry
        self.keep = (models, times, x)
        self.fields = {
            "ddm": entry,
            "chi": None,
            "naux": naux,
            "jinv": jinv,
            "n_pay": times.size,
            "pay_t": int(times.ctypes.data),
            "pay_x": int(x.ctypes.data),
            "pay_nx": x.shape[1],
        }


def _payload(dynamics: Any, method: str, dt: float, duration: float, n_grid: int) -> Any:
    """The compiled payload of ``simulate``'s ``dynamics`` (that of
    :func:`~stewart_pin.motion.payload.simulate_payload`), or why the C loop cannot run
    it."""
    compiled = getattr(dynamics, "compiled_payload", None)
    if compiled is None:
        return "a dynamics function"
    if method != "rk4":
        return "a payload on the adaptive method (its stage times are not known before the run)"
    models = compiled()
    if getattr(models, "sim_entry", None) is None:
        return "the payload's direct model is not compiled"
    times = _stage_times(grid_times(dt, duration, n_grid))
    try:
        x = dynamics.joints_at(times)
    except Exception as e:  # the Python loop meets it at its time and stops there
        return f"the payload's joints: {type(e).__name__}: {e}"
    return _Payload(models, times, x)


def simulate_batch(
    robot: RobotLike,
    duration: float,
    poses: Any = None,
    twists: Any = None,
    forces: Any = None,
    dt: float = 1e-3,
    control_period: float | None = None,
    backend: str = "auto",
    threads: int | None = None,
) -> list[SimulationResult]:
    """Many fixed-step RK4 runs of :func:`simulate` in one call, on threads.

    Args:
        robot, duration, dt, control_period, backend: as :func:`simulate`'s (method
            ``"rk4"``).
        poses: initial 0Tp, (N, 4, 4) (default: N home poses, N from ``twists`` or
            ``forces``); twists: (N, 6) (default zeros).
        forces: one for every run or a sequence of N: ``None`` (zero), a (6,) constant,
            a :class:`~stewart_pin.motion.force_tables.ForceTable`, or a
            :class:`~stewart_pin.motion.control.ComputedTorqueController`.
        threads: threads sharing the runs (default the compiled models').

    Returns:
        N :class:`~stewart_pin.motion.simulation.SimulationResult`, each equal to
        ``simulate(robot, duration, poses[k], twists[k], forces[k], dt=dt, ...)``'s (a run
        that meets an event is finished by the Python loop, as ``simulate`` does; without
        a compiled direct model every run is, one after the other).

    Raises:
        InputError: mismatched counts, or forces that are not data.
        SimulationError: a run stopped (the message names it; ``.result`` its states).
    """
    per_run = isinstance(forces, Sequence) and not isinstance(forces, str | bytes)
    if isinstance(forces, np.ndarray) and forces.ndim == 2:
        forces, per_run = list(forces), True
    counts = {len(x) for x, ok in ((poses, poses is not None), (twists, twists is not None)) if ok}
    if per_run:
        counts.add(len(forces))
    if len(counts) != 1:
        raise InputError(
            f"simulate_batch: poses, twists and per-run forces must count the same runs, got "
            f"{sorted(counts) or 'none'}"
        )
    n = counts.pop()
    run_forces = [_as_data(f) for f in (forces if per_run else [forces] * n)]
    P = np.repeat(robot.home_pose[None], n, 0) if poses is None else np.asarray(poses, float)
    V = np.zeros((n, 6)) if twists is None else np.asarray(twists, float)
    runs = [
        prepare_run(
            robot,
            duration,
            P[k],
            V[k],
            run_forces[k],
            dt=dt,
            control_period=control_period,
            backend=backend,
        )
        for k in range(n)
    ]
    active = []
    for run in runs:
        if run.fast is None:  # the C loop cannot take it: run.go() below, in Python
            continue
        try:
            s = run.begin()
        except Exception:  # run.go() below raises it as simulate does
            continue
        run.fast.load(s.t, s.T, s.V, s.dy, s.gamma, s.sign, run.integ.held, 0)
        run.fast_state = s
        active.append(run)
    lib = simulator_library()
    models = _compiled(robot, backend)
    n_threads = threads or (models.threads if isinstance(models, CompiledDynamics) else 1)
    while active:
        status = np.zeros(len(active), dtype=np.int32)
        for run in active:
            run.fast.ready()

        def call(s: int, m: int, todo: list[Any] = active, status: np.ndarray = status) -> int:
            out = 0
            for j in range(s, s + m):
                status[j] = lib.sp_sim_run(*todo[j].fast._args, todo[j].n_grid)
                out |= int(status[j])
            return out

        split_batch(len(active), n_threads, 1, call)
        going = []
        for j, run in enumerate(active):
            assert run.resume is not None
            state, taken = run.absorb(run.resume[0])
            if status[j] == S.DONE and state.t < run.duration and taken > 0:
                going.append(run)
            elif state.t < run.duration:  # an event ahead: the Python loop's next step
                run.fast_from = run.fast.n + 1
        active = going
    results = []
    for k, run in enumerate(runs):
        try:
            results.append(run.go())
        except SimulationError as e:
            raise SimulationError(f"run {k}: {e}", e.time, e.result) from e.__cause__
    return results


def _as_data(forces: Any) -> Any:
    """A run's forces as the compiled loop takes them (a constant as a ForceTable)."""
    if forces is None or isinstance(forces, ForceTable | ComputedTorqueController):
        return forces
    if callable(forces):
        raise InputError(
            "simulate_batch takes forces as data (None, a (6,) constant, a ForceTable or "
            "the ComputedTorqueController); run a forces function with simulate"
        )
    return ForceTable.constant(forces)


__all__ = ["SimulationError", "Stepper", "compiled_stepper", "simulate_batch"]
