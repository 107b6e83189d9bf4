"""The payload demo: an arm from example-robot-data makes a fast move on a hexapod that
keeps the arm's base still.

The arm (default: a Panda, 17 kg, on the ``paper`` preset's 45 kg platform) swings from
its home configuration (its SRDF's ready pose, clear of the platform) to a reach configuration by a
minimum-jerk move, then holds. The hexapod's reference is its home pose, held:

- **efforts**: the actuator efforts that hold the platform still while the arm moves
  (the coupled inverse model with the arm's ``q, qd, qdd``) against those that hold it
  with the arm passing through the same configurations at rest (``qd = qdd = 0``): the
  difference is the arm's dynamic reaction;
- **compensation**: two simulations of the platform under computed torque, one whose
  model knows the arm's motion (:class:`~stewart_pin.motion.payload.PayloadComputedTorque`
  with the arm's trajectory) and one that takes the arm for still at its start; the
  arm's base (the platform) stays put with the first and is shaken with the second.

``stewart-pin demo --preset paper --payload panda -o out`` writes the figure, the arrays
and an HTML animation; ``notebooks/payload.ipynb`` shows the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from stewart_pin._io import atomic_open
from stewart_pin.models.payload import Payload, load_payload
from stewart_pin.motion.payload import JointMotion, PayloadComputedTorque, simulate_payload
from stewart_pin.payload_robot import PayloadRobot
from stewart_pin.robot import StewartRobot
from stewart_pin.viz.plots import LEG_LABELS, require_matplotlib
from stewart_pin.viz.viewer import require_meshcat

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "PayloadDemo",
    "payload_demo",
    "plot_payload_demo",
    "reach_motion",
    "run_payload_demo",
]


def reach_motion(
    payload: Payload, duration: float, hold: float = 0.0, fraction: float = 0.5
) -> JointMotion:
    """From the home configuration (the SRDF's reference posture where the arm has one,
    else the middle of each joint's range) to a reach configuration, each joint moved by
    ``fraction`` of its room there (:meth:`Payload.room`: the distance to its nearer
    limit, at most its half-range), alternately up and down, by a minimum-jerk move of
    ``duration`` [s], then held for ``hold`` [s]."""
    signs = np.where(np.arange(payload.nv) % 2 == 0, 1.0, -1.0)
    home = payload.home_configuration()
    goal = np.asarray(pin.integrate(payload.model, home, fraction * signs * payload.room(home)))
    return JointMotion.point_to_point(payload, home, goal, duration, hold)


@dataclass(frozen=True)
class PayloadDemo:
    """The demo's results, sampled at ``t`` (K,) [s].

    Attributes:
        robot: the hexapod and its arm. joints: the arm's joint motion.
        q, tau: (K, nq), (K, nv) the arm's configurations and its joint torques (the
            platform held still).
        gamma_moving: (K, 6) the efforts holding the platform still while the arm moves.
        gamma_still: (K, 6) the same with the arm at rest in each configuration.
        base_error: (K,) [m] the arm base's (the platform origin's) distance from its
            reference under computed torque that compensates the arm's motion.
        base_error_ignorant: (K,) [m] the same with a model that takes the arm for still.
        poses: (K, 4, 4) the compensated run's platform poses (for the animation).
    """

    robot: PayloadRobot
    joints: JointMotion
    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    gamma_moving: np.ndarray
    gamma_still: np.ndarray
    base_error: np.ndarray
    base_error_ignorant: np.ndarray
    poses: np.ndarray

    def summary(self) -> str:
        react = np.abs(self.gamma_moving - self.gamma_still).max()
        unit = self.robot.robot.description.effort_unit
        return (
            f"'{self.robot.name}': the arm ({self.robot.payload.mass:.3g} kg, "
            f"{self.robot.nv} joints) moves in {self.joints.duration:.3g} s; its motion "
            f"changes the efforts by up to {react:.4g} {unit} (peak |Gamma| "
            f"{np.abs(self.gamma_moving).max():.4g} {unit}); the arm's base moves by "
            f"{1e3 * self.base_error.max():.3g} mm when the hexapod compensates, "
            f"{1e3 * self.base_error_ignorant.max():.3g} mm when it does not"
        )


def payload_demo(
    preset: str = "paper",
    payload: Any = "panda",
    duration: float = 0.6,
    hold: float = 0.2,
    fraction: float = 0.5,
    dt: float = 2e-3,
) -> PayloadDemo:
    """Compute the demo (module docstring): ``payload`` on ``preset``'s platform (a name of
    example-robot-data, a URDF, a ``pin.Model`` or a :class:`Payload`, e.g. a scaled one),
    moving by :func:`reach_motion` in ``duration`` [s] then holding ``hold`` [s];
    simulations by RK4 with step and control period ``dt`` [s]."""
    robot = StewartRobot.from_preset(preset).with_payload(payload)
    joints = reach_motion(robot.payload, duration, hold, fraction)
    T0 = robot.home_pose
    zero6 = np.zeros(6)

    def reference(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return T0, zero6, zero6

    def run(model_joints: JointMotion) -> Any:
        ctl = PayloadComputedTorque(robot, reference, joints=model_joints)
        return simulate_payload(
            robot, joints.duration, joints, forces=ctl, dt=dt, control_period=dt
        )

    aware = run(joints)
    ignorant = run(JointMotion.still(robot.payload, joints.q0))
    t = aware.result.t
    q, qd, qdd = joints.sample(t)
    n = len(t)
    P, Z6, Z = np.tile(T0, (n, 1, 1)), np.zeros((n, 6)), np.zeros((n, robot.nv))
    moving = robot.inverse_dynamics(P, Z6, Z6, q, qd, qdd)
    still = robot.inverse_dynamics(P, Z6, Z6, q, Z, Z)

    def error(sim: Any) -> np.ndarray:
        return np.linalg.norm(sim.result.poses[:, :3, 3] - T0[:3, 3], axis=1)

    return PayloadDemo(
        robot,
        joints,
        t,
        q,
        np.asarray(moving.tau),
        np.asarray(moving.gamma),
        np.asarray(still.gamma),
        error(aware),
        np.interp(t, ignorant.result.t, error(ignorant)),
        aware.result.poses,
    )


def plot_payload_demo(demo: PayloadDemo) -> Figure:
    """Three panels: the efforts with the arm moving (solid) and at rest in the same
    configurations (dashed); their difference, the arm's dynamic reaction; the arm base's
    displacement with and without compensation [mm]."""
    Figure = require_matplotlib()
    unit = demo.robot.robot.description.effort_unit
    fig = Figure(figsize=(8.0, 9.0), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    colours = [f"C{i}" for i in range(6)]
    for i in range(6):
        ax1.plot(demo.t, demo.gamma_moving[:, i], color=colours[i], label=LEG_LABELS[i])
        ax1.plot(demo.t, demo.gamma_still[:, i], color=colours[i], ls="--", lw=0.8)
        ax2.plot(demo.t, demo.gamma_moving[:, i] - demo.gamma_still[:, i], color=colours[i])
    ax1.set_ylabel(f"Gamma [{unit}]")
    ax1.set_title(
        f"{demo.robot.name}: efforts holding the platform, arm moving (solid) / at rest (dashed)"
    )
    ax1.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small")
    ax2.set_ylabel(f"arm's reaction [{unit}]")
    ax2.set_title("the difference: the efforts the arm's motion takes")
    ax3.plot(demo.t, 1e3 * demo.base_error, label="compensated (coupled model)")
    ax3.plot(demo.t, 1e3 * demo.base_error_ignorant, label="arm taken for still (at its start)")
    ax3.set_ylabel("arm base displacement [mm]")
    ax3.set_xlabel("time [s]")
    ax3.set_title("computed torque: the arm's base (platform origin) off its reference")
    ax3.legend(fontsize="small")
    for ax in (ax1, ax2, ax3):
        ax.grid(True, alpha=0.3)
    return fig


def run_payload_demo(
    preset: str, payload: Any, out: Path, animation: bool = True, **kwargs: Any
) -> dict[str, Path]:
    """Run :func:`payload_demo` and write into ``out``: ``payload_demo.png`` (the figure),
    ``payload_demo.npz`` (the arrays) and, with ``animation``, ``payload_demo.html`` (the
    arm's meshes on the platform); returns the files by role."""
    require_matplotlib()  # the extras before the work (MissingDependencyError)
    if animation:
        require_meshcat()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if animation:  # a mesh the page may not carry (PayloadMeshError): before the run
        payload = load_payload(payload)
        payload.visual_model()
    demo = payload_demo(preset, payload, **kwargs)
    print(demo.summary())
    files: dict[str, Path] = {}
    fig = plot_payload_demo(demo)
    files["figure"] = out / "payload_demo.png"
    with atomic_open(files["figure"], "wb") as handle:
        fig.savefig(handle, format="png", dpi=100)
    files["arrays"] = out / "payload_demo.npz"
    with atomic_open(files["arrays"], "wb") as handle:
        np.savez(
            handle,
            t=demo.t,
            q=demo.q,
            tau=demo.tau,
            gamma_moving=demo.gamma_moving,
            gamma_still=demo.gamma_still,
            base_error=demo.base_error,
            base_error_ignorant=demo.base_error_ignorant,
        )
    if animation:
        from stewart_pin.viz.payload_scene import PayloadViewer

        files["animation"] = PayloadViewer(demo.robot).export_html(
            out / "payload_demo.html", demo.poses, demo.t, demo.q
        )
    for role, path in files.items():
        print(f"  {role}: {path}")
    return files
