"""Geometry sweeps (dimensional synthesis) on Dask: a family of symmetric hexapods, each
evaluated on its workspace and actuator loads, in parallel.

:func:`sweep` maps :func:`evaluate_geometry` over the geometries on a
``dask.distributed`` cluster: a ``LocalCluster`` on this machine by default, or an
existing scheduler given by its address (``tcp://host:8786``); ``scheduler="serial"``
evaluates in this process (the reference the parallel tables equal). Each geometry is
built, and its model compiled when the backend compiles, once, on the worker that
evaluates it. A geometry that fails (one that cannot assemble, an empty workspace) is a
row with its error, never a failed sweep. The result is a table (:class:`SweepResult`:
CSV, the Pareto front and its plot).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_scalar
from stewart_pin._extras import require
from stewart_pin._io import atomic_open
from stewart_pin.exceptions import InputError, SchedulerError

#: The geometry every sweep starts from (a desktop-size 6-UPS, SI units); a sweep's
#: geometries override some of these keys (see :func:`stewart_pin.symmetric_hexapod`).
BASE_GEOMETRY: dict[str, Any] = {
    "base_radius": 0.10,
    "platform_radius": 0.07,
    "base_pair_angle": math.radians(20.0),
    "platform_pair_angle": math.radians(20.0),
    "home_height": 0.15,
    "stroke": (0.13, 0.19),
    "platform_mass": 1.0,
}
#: The metric columns of a sweep's table, after the geometry's keys and before ``error``.
METRICS = ("volume", "volume_error", "peak_effort", "peak_speed", "peak_power")


@dataclass(frozen=True)
class SweepSettings:
    """What :func:`evaluate_geometry` computes for each geometry: the constant-orientation
    workspace at the home orientation on a grid of ``resolution`` cells along its longest
    side, and the loads at ``samples`` states drawn (seed ``seed``) in the box of states
    ``|dp_k| <= translation * stroke_mid`` [m] (a fraction of the mid-stroke),
    ``|w_k| <= rotation`` [rad], ``speed`` [m/s], ``angular_speed`` [rad/s], ``accel``
    [m/s^2], ``angular_accel`` [rad/s^2]; ``backend`` as :meth:`StewartRobot.inverse_dynamics`."""

    resolution: int = 16
    samples: int = 200
    seed: int = 0
    translation: float = 0.08
    rotation: float = 0.05
    speed: float = 0.1
    angular_speed: float = 0.5
    accel: float = 2.0
    angular_accel: float = 5.0
    backend: str = "auto"

    def __post_init__(self) -> None:
        for name in ("resolution", "samples"):
            check_scalar(getattr(self, name), f"SweepSettings.{name}", positive=True, integer=True)
        check_scalar(self.seed, "SweepSettings.seed", nonnegative=True, integer=True)
        for name in ("translation", "rotation", "speed", "angular_speed", "accel"):
            check_scalar(getattr(self, name), f"SweepSettings.{name}", nonnegative=True)
        check_scalar(self.angular_accel, "SweepSettings.angular_accel", nonnegative=True)
        if self.backend not in ("auto", "compiled", "pinocchio"):
            raise InputError(
                f"SweepSettings.backend must be auto, compiled or pinocchio, got {self.backend!r}"
            )


def grid(**axes: Sequence[Any]) -> list[dict[str, Any]]:
    """The Cartesian product of the given values per key, e.g.
    ``grid(base_radius=[0.1, 0.12], home_height=[0.14, 0.16])`` -> four geometries."""
    for key, values in axes.items():
        if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
            raise InputError(f"grid: {key} must be a sequence of values, got {values!r}")
    keys = list(axes)
    return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*axes.values())]


def _one_line(e: BaseException) -> str:
    return f"{type(e).__name__}: " + " ".join(str(e).split())


def evaluate_geometry(
    geometry: Mapping[str, Any],
    settings: SweepSettings | None = None,
    metrics: Callable[[Any], Mapping[str, float]] | None = None,
) -> dict[str, Any]:
    """One row of a sweep: the geometry's keys (over :data:`BASE_GEOMETRY`), the
    :data:`METRICS` (workspace ``volume`` and ``volume_error`` [m^3], the largest
    ``peak_effort`` [N], ``peak_speed`` [m/s] and ``peak_power`` [W] of any actuator over
    the sampled states) and ``error`` (``""``, or the error's class and one-line message,
    the metrics then NaN).

    ``metrics``: a function of the built :class:`~stewart_pin.robot.StewartRobot`
    returning the row's metrics (name -> number) instead of :data:`METRICS` (a module-level
    function, so that Dask can send it to the workers); any exception it raises becomes
    the row's ``error``."""
    from stewart_pin.description.symmetric_hexapod import symmetric_hexapod
    from stewart_pin.design.sizing import StateBox, actuator_loads
    from stewart_pin.design.workspace import workspace
    from stewart_pin.robot import StewartRobot

    s = SweepSettings() if settings is None else settings
    params = {**BASE_GEOMETRY, **geometry}
    row: dict[str, Any] = {k: geometry[k] for k in geometry}
    if metrics is None:
        row.update(dict.fromkeys(METRICS, math.nan))
    row["error"] = ""
    try:
        robot = StewartRobot(symmetric_hexapod(**params))
        if metrics is not None:
            values = {str(k): float(v) for k, v in metrics(robot).items()}
            row.pop("error")
            row.update(values)
            row["error"] = ""
            return row
        ws = workspace(robot, resolution=s.resolution, rng=s.seed)
        box = StateBox(
            s.translation * robot.description.stroke_mid,
            s.rotation,
            s.speed,
            s.angular_speed,
            s.accel,
            s.angular_accel,
        )
        x = box.sample(robot, s.samples, s.seed)
        loads = actuator_loads(robot, *box.states(robot, x), backend=s.backend)
        row.update(
            volume=ws.volume,
            volume_error=ws.volume_error,
            peak_effort=float(np.abs(loads.efforts).max()),
            peak_speed=float(np.abs(loads.speeds).max()),
            peak_power=float(loads.powers.max()),
        )
    except Exception as e:  # any failure is the row's, never the sweep's
        # the package's errors (a geometry that cannot assemble, an empty workspace), an
        # unknown geometry key (TypeError), whatever a custom metrics function raises
        row["error"] = _one_line(e)
    return row


@dataclass(frozen=True)
class SweepResult:
    """A sweep's table: ``rows`` in the order of the geometries, ``columns`` their keys."""

    rows: list[dict[str, Any]]
    columns: list[str] = field(default_factory=list)

    def column(self, name: str) -> np.ndarray:
        """One metric column as floats (N,) (NaN where the geometry failed)."""
        if name not in self.columns:
            raise InputError(f"no column {name!r}; the columns are {self.columns}")
        return np.array([float(r[name]) for r in self.rows])

    def write_csv(self, path: str | Path) -> Path:
        """Write the table as CSV (floats with every digit, atomically); returns the path."""
        import csv

        out = Path(path)
        with atomic_open(out) as f:
            w = csv.DictWriter(f, fieldnames=self.columns, lineterminator="\n")
            w.writeheader()
            for row in self.rows:
                w.writerow({k: _cell(row.get(k, "")) for k in self.columns})
        return out

    def pareto(self, minimise: str = "peak_effort", maximise: str = "volume") -> np.ndarray:
        """Indices of the rows on the Pareto front: no other row has a smaller or equal
        ``minimise`` and a larger or equal ``maximise``, one of them strictly (failed rows
        excluded), sorted by ``minimise``."""
        a, b = self.column(minimise), self.column(maximise)
        ok = np.flatnonzero(np.isfinite(a) & np.isfinite(b))
        front = [
            i
            for i in ok
            if not np.any((a[ok] <= a[i]) & (b[ok] >= b[i]) & ((a[ok] < a[i]) | (b[ok] > b[i])))
        ]
        return np.array(sorted(front, key=lambda i: a[i]), dtype=int)

    def plot_pareto(
        self,
        path: str | Path | None = None,
        minimise: str = "peak_effort",
        maximise: str = "volume",
    ) -> Any:
        """Every geometry and the Pareto front (:meth:`pareto`) in a Matplotlib figure,
        saved to ``path`` when given; returns the figure (needs the viz extra)."""
        (matplotlib,) = require("the Pareto plot", "viz", "matplotlib")
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        a, b = self.column(minimise), self.column(maximise)
        front = self.pareto(minimise, maximise)
        fig, ax = plt.subplots()
        ax.scatter(a, b, s=12, color="0.6", label="geometries")
        ax.plot(a[front], b[front], "o-", color="C3", label="Pareto front")
        ax.set_xlabel(minimise)
        ax.set_ylabel(maximise)
        ax.legend()
        if path is not None:
            with atomic_open(path, "wb") as f:
                fig.savefig(f, format=Path(path).suffix.lstrip(".") or "png")
            plt.close(fig)
        return fig


def _cell(v: Any) -> Any:
    return repr(v) if isinstance(v, float) else v


def _require_dask() -> None:
    """dask.distributed, or :class:`MissingDependencyError` with the install hint."""
    require('geometry sweeps on Dask (or scheduler="serial")', "design", "dask.distributed")


def _client(scheduler: str | None, workers: int, processes: bool, timeout: float) -> Any:
    """A ``dask.distributed.Client``: on a new ``LocalCluster`` (``scheduler`` None) or
    on the scheduler at that address (:class:`SchedulerError` when it cannot be
    reached)."""
    _require_dask()
    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,
        )
        return Client(cluster)
    try:
        return Client(scheduler, timeout=f"{timeout}s")
    except (OSError, TimeoutError, ValueError, TypeError) as e:
        raise SchedulerError(
            f"cannot reach the Dask scheduler at {scheduler!r} within {timeout:g} s "
            f"({type(e).__name__}); start one (`dask scheduler`) or omit --scheduler for "
            "a local cluster",
            scheduler,
        ) from e


def sweep(
    geometries: Sequence[Mapping[str, Any]],
    settings: SweepSettings | None = None,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    progress: bool = True,
    timeout: float = 10.0,
    client: Any = None,
    metrics: Callable[[Any], Mapping[str, float]] | None = None,
) -> SweepResult:
    """Evaluate each geometry (:func:`evaluate_geometry`) and return the table.

    Args:
        geometries: mappings of :func:`stewart_pin.symmetric_hexapod` keyword arguments
            overriding :data:`BASE_GEOMETRY` (e.g. from :func:`grid`).
        settings: what each evaluation computes (:class:`SweepSettings`).
        scheduler: ``None`` (a ``LocalCluster`` of ``workers`` single-threaded workers,
            processes unless ``processes=False``), a scheduler address
            (``"tcp://host:8786"``), or ``"serial"`` (this process, no Dask).
        progress: a tqdm bar over the geometries.
        timeout: seconds to wait for a scheduler given by address.
        metrics: what to compute for each robot instead of :data:`METRICS`
            (:func:`evaluate_geometry`); the table's columns are the union of the rows'
            keys, a failed row's missing metrics NaN.
        client: an open ``dask.distributed.Client`` to run on (then ``scheduler``,
            ``workers`` and ``processes`` are not used, and the client stays open).

    Raises:
        SchedulerError: the scheduler cannot be reached.
        InputError: no geometries, or a geometry that is not a mapping.
    """
    from tqdm import tqdm

    geoms = list(geometries)
    if not geoms:
        raise InputError("sweep needs at least one geometry")
    for k, g in enumerate(geoms):
        if not isinstance(g, Mapping):
            raise InputError(f"geometry {k} must be a mapping of keyword arguments, got {g!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"workers must be an integer >= 1, got {workers!r}")
    s = SweepSettings() if settings is None else settings
    rows: list[dict[str, Any] | None] = [None] * len(geoms)
    with tqdm(total=len(geoms), unit="geometry", disable=not progress, leave=False) as bar:
        if scheduler == "serial":
            for k, g in enumerate(geoms):
                rows[k] = evaluate_geometry(g, s, metrics)
                bar.update(1)
        else:
            _require_dask()
            from dask.distributed import as_completed

            own = client is None
            if own:
                client = _client(scheduler, workers, processes, timeout)
            try:
                futures = client.map(
                    evaluate_geometry, geoms, settings=s, metrics=metrics, pure=False
                )
                index = {f.key: k for k, f in enumerate(futures)}
                for f in as_completed(futures):
                    rows[index[f.key]] = f.result()
                    bar.update(1)
            finally:
                if own:
                    cluster = client.cluster if scheduler is None else None
                    client.close()
                    if cluster is not None:
                        cluster.close()
    done = [r for r in rows if r is not None]
    names: list[str] = []  # the geometries' keys, in order of appearance
    for g in geoms:
        names += [key for key in g if key not in names]
    measured: list[str] = list(METRICS) if metrics is None else []
    for r in done:
        measured += [c for c in r if c not in names and c not in measured and c != "error"]
    for r in done:  # a failed row's metrics: NaN
        for name in measured:
            r.setdefault(name, math.nan)
    return SweepResult(done, [*names, *measured, "error"])
