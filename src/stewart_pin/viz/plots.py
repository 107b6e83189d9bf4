"""Figures of a motion: actuator efforts, leg lengths against the stroke, tracking error,
mechanical energy (free motion) and the work-energy balance (driven motion).

Each ``plot_*`` function takes arrays and returns a ``matplotlib.figure.Figure`` built
without pyplot (no global state, no display: it saves through the Agg canvas).
:func:`save_figures` writes them as PNG files for a
:class:`~stewart_pin.motion.simulation.SimulationResult`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from stewart_pin._checks import check_array, check_poses
from stewart_pin._extras import install_hint, require
from stewart_pin._io import atomic_open
from stewart_pin.exceptions import InputError
from stewart_pin.motion.control import tracking_errors

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from stewart_pin.motion.simulation import SimulationResult
    from stewart_pin.robot import StewartRobot

#: Install hint of the optional figure dependency.
INSTALL_HINT = install_hint("viz")
#: Size of every figure [inch].
FIGSIZE = (8.0, 4.5)
LEG_LABELS = tuple(f"leg {i}" for i in range(1, 7))


def require_matplotlib() -> type[Figure]:
    """matplotlib's ``Figure`` class, or :class:`~stewart_pin.exceptions.MissingDependencyError`
    with the install hint (the command line checks it before the work that ends in figures).
    """
    (module,) = require("the figures", "viz", "matplotlib.figure")
    return module.Figure


def _figure(nrows: int = 1) -> tuple[Figure, list[Any]]:
    Figure = require_matplotlib()
    height = FIGSIZE[1] if nrows == 1 else FIGSIZE[1] * 0.8 * nrows
    fig = Figure(figsize=(FIGSIZE[0], height), layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=True, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    return fig, list(axes)


def _legend_right(ax: Any) -> None:
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small")


def _series(t: Any, values: Any, width: int | None, name: str) -> tuple[np.ndarray, np.ndarray]:
    t = check_array(t, (None,), "t")
    values = check_array(values, (len(t),) if width is None else (len(t), width), name)
    return t, values


#: What an actuator's effort is called, by its unit (``RobotDescription.effort_unit``).
_EFFORT_NAMES = {"N": "force", "N m": "torque"}


def plot_forces(t: Any, gammas: Any, unit: str = "N") -> Figure:
    """The six actuator efforts against time.

    Args:
        t: shape (K,) [s]; gammas: shape (K, 6), positive extending the leg (a prismatic
            actuator) or turning its joint positively (a revolute one).
        unit: the efforts' unit, ``robot.description.effort_unit``: ``"N"`` (forces),
            ``"N m"`` (torques: RUS cranks) or ``"N or N m"`` (mixed legs).
    """
    t, gammas = _series(t, gammas, 6, "gammas")
    fig, (ax,) = _figure()
    for i in range(6):
        ax.plot(t, gammas[:, i], label=LEG_LABELS[i])
    name = _EFFORT_NAMES.get(unit, "effort")
    ax.set_ylabel(f"actuator {name} [{unit}]")
    ax.set_title(f"Actuator {name}s")
    _legend_right(ax)
    return fig


def plot_lengths(t: Any, lengths: Any, stroke: Any = None) -> Figure:
    """The six leg lengths against time, with the stroke limits as dashed lines.

    Args:
        t: shape (K,) [s]; lengths: shape (K, 6) [m].
        stroke: ``[lower, upper]`` shape (2,) [m] (``robot.description.stroke``), or
            ``None`` for no limit lines.
    """
    t, lengths = _series(t, lengths, 6, "lengths")
    fig, (ax,) = _figure()
    for i in range(6):
        ax.plot(t, lengths[:, i], label=LEG_LABELS[i])
    if stroke is not None:
        lower, upper = check_array(stroke, (2,), "stroke")
        for value, name in ((lower, "stroke min"), (upper, "stroke max")):
            ax.axhline(value, color="black", linestyle="--", linewidth=1.0, label=name)
    ax.set_ylabel("leg length [m]")
    ax.set_title("Leg lengths")
    _legend_right(ax)
    return fig


def plot_tracking_error(t: Any, poses: Any, reference: Any) -> Figure:
    """Tracking error against time: position [mm] (top) and rotation [deg] (bottom),
    the three components in F0 and the norm (see
    :func:`~stewart_pin.motion.control.tracking_errors`: actual minus reference).

    Args:
        t: shape (K,) [s]; poses, reference: shape (K, 4, 4), 0Tp and its reference.
    """
    t = check_array(t, (None,), "t")
    e_p, e_r = tracking_errors(reference, t, poses)
    fig, (ax_p, ax_r) = _figure(2)
    for ax, err in ((ax_p, 1e3 * e_p), (ax_r, np.degrees(e_r))):
        for k, axis in enumerate("xyz"):
            ax.plot(t, err[:, k], label=axis)
        ax.plot(t, np.linalg.norm(err, axis=1), color="black", linewidth=1.0, label="norm")
        ax.legend(ncols=4, fontsize="small")
    ax_p.set_ylabel("position error [mm]")
    ax_r.set_ylabel("rotation error [deg]")
    ax_p.set_title("Tracking error")
    return fig


def plot_energy(t: Any, energy: Any) -> Figure:
    """Total mechanical energy against time (its drift shows in the title).

    Args:
        t: shape (K,) [s]; energy: shape (K,) [J] (``robot.energy(poses, twists)``).
    """
    t, energy = _series(t, energy, None, "energy")
    fig, (ax,) = _figure()
    ax.plot(t, energy, label="kinetic + potential")
    ax.set_ylabel("energy [J]")
    drift = float(np.max(np.abs(energy - energy[0]))) if len(energy) else 0.0
    ax.set_title(f"Mechanical energy (max |E - E(0)| = {drift:.3g} J)")
    ax.legend(fontsize="small")
    return fig


def actuator_work(gammas: Any, positions: Any) -> np.ndarray:
    """The actuators' work since the first sample [J], shape (K,).

    ``W_K = sum_k Gamma_k . (q_a,k+1 - q_a,k)``, each sample's efforts held until the
    next (exact for the zero-order hold of ``simulate(control_period=...)``, whose
    samples record the efforts applied from them; first order in the step for efforts
    that vary within a step).

    Args:
        gammas: shape (K, 6), the actuators' efforts [N or N m].
        positions: shape (K, 6), the actuated joint positions [m or rad]
            (``SimulationResult.actuator_positions``).
    """
    gammas = check_array(gammas, (None, 6), "gammas")
    positions = check_array(positions, (len(gammas), 6), "positions")
    steps = np.sum(gammas[:-1] * np.diff(positions, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def plot_energy_balance(t: Any, energy: Any, work: Any, dissipated: Any = None) -> Figure:
    """The work-energy balance of a driven motion: the change of the mechanical energy,
    the actuators' work and the joints' losses (top), and the balance's residual
    ``E - E(0) + losses - work``, ~0 up to the integration error (bottom, in the title).

    Args:
        t: shape (K,) [s]; energy: shape (K,) [J] (``robot.energy(poses, twists)``);
        work: shape (K,) [J] the actuators' work since ``t[0]`` (:func:`actuator_work`);
        dissipated: shape (K,) [W] the power lost in the joints
            (``robot.dissipated_power(poses, twists)``), ``None`` for none.
    """
    t, energy = _series(t, energy, None, "energy")
    work = check_array(work, (len(t),), "work")
    losses = np.zeros(len(t))
    if dissipated is not None:
        power = check_array(dissipated, (len(t),), "dissipated")
        losses[1:] = np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))
    change = energy - energy[0] if len(energy) else energy
    residual = change + losses - work
    fig, (ax, ax_r) = _figure(2)
    ax.plot(t, change, label="E - E(0) (kinetic + potential)")
    ax.plot(t, work, "--", label="actuators' work")
    if dissipated is not None:
        ax.plot(t, losses, ":", label="joint losses")
    ax.set_ylabel("energy [J]")
    ax.legend(fontsize="small")
    ax_r.plot(t, residual, color="black", linewidth=1.0)
    ax_r.set_ylabel("residual [J]")
    worst = float(np.max(np.abs(residual))) if len(residual) else 0.0
    scale = float(np.max(np.abs(work))) if len(work) else 0.0
    relative = f" ({worst / scale:.2g} of the work)" if scale > 0 else ""
    ax.set_title(  # two lines: one is wider than the figure
        f"Work-energy balance: max |E - E(0) + losses - work|\n= {worst:.3g} J{relative}"
    )
    return fig


def reference_poses(reference: Any, times: Any) -> np.ndarray:
    """The reference poses at ``times`` (K,) [s], shape (K, 4, 4), from either

    - poses (K, 4, 4) already at ``times``;
    - a motion with ``sample(times)`` returning an object with ``.poses``
      (:mod:`stewart_pin.motion.trajectories`);
    - a function ``t [s] -> 0Tp (4, 4)`` or ``-> (0Tp, twist, accel)`` (a controller's
      reference).
    """
    t = check_array(times, (None,), "times")
    if hasattr(reference, "sample"):
        poses = reference.sample(t).poses
    elif callable(reference):
        values = [reference(float(tk)) for tk in t]
        poses = [v[0] if isinstance(v, tuple) else v for v in values]
    else:
        poses = reference
    T, _ = check_poses(np.asarray(poses, dtype=float), "reference")
    if len(T) != len(t):
        raise InputError(f"reference has {len(T)} poses for {len(t)} times: give one per time")
    return T


def save_figures(
    result: SimulationResult,
    folder: str | Path,
    reference: Any = None,
    robot: StewartRobot | None = None,
    dpi: int = 100,
    effort_unit: str | None = None,
) -> dict[str, Path]:
    """Write the figures of a simulated motion as PNG files in ``folder``.

    Always ``forces.png`` and ``lengths.png``; ``tracking_error.png`` with a
    ``reference``; ``energy.png`` with the ``robot`` (which also draws the stroke limits):
    the work-energy balance (:func:`plot_energy_balance`), whose residual is ~0 for a
    driven motion as for a free one.

    Args:
        result: the motion.
        folder: created when missing.
        reference: the reference motion, as :func:`reference_poses` takes it.
        robot: the simulated robot.
        effort_unit: the unit of ``result.gammas`` (default: the robot's
            ``description.effort_unit``, ``"N"`` without a robot).

    Returns:
        ``{"forces": path, ...}`` of the files written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    desc = None if robot is None else robot.description
    if effort_unit is None:
        effort_unit = "N" if desc is None else desc.effort_unit
    figures = {
        "forces": plot_forces(result.t, result.gammas, effort_unit),
        # the shared stroke's lines (the ideal 6-UPS's; each leg's own limits: none)
        "lengths": plot_lengths(result.t, result.lengths, None if desc is None else desc.stroke),
    }
    if desc is not None:  # the actuated joint values (lengths [m], slides [m], cranks [rad])
        (ax,) = figures["lengths"].axes
        ax.set_ylabel(desc.position_label)
        ax.set_title(desc.positions_title)
    if reference is not None:
        reference = reference_poses(reference, result.t)
        figures["tracking_error"] = plot_tracking_error(result.t, result.poses, reference)
    if robot is not None:
        figures["energy"] = plot_energy_balance(
            result.t,
            robot.energy(result.poses, result.twists),
            actuator_work(result.gammas, result.lengths),
            robot.dissipated_power(result.poses, result.twists),
        )
    paths = {}
    for name, fig in figures.items():
        paths[name] = folder / f"{name}.png"
        with atomic_open(paths[name], "wb") as handle:
            fig.savefig(handle, format="png", dpi=dpi)
    return paths
