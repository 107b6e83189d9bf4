"""The main demo: what the README's first command runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from .robot import StewartRobot


def run_demo(preset: str, out: Path) -> None:
    """Generate the URDF of a preset and print its geometry and kinematics at a few poses."""
    robot = StewartRobot.from_preset(preset)
    out.mkdir(parents=True, exist_ok=True)
    urdf, sidecar = robot.write_urdf(out / f"{robot.name}.urdf")
    description = robot.write(out / f"{robot.name}.toml")
    np.set_printoptions(precision=5, suppress=True, linewidth=110)
    print(f"robot '{robot.name}': URDF {urdf}, closures {sidecar}, description {description}")
    offsets = {
        "home": (np.zeros(3), np.zeros(3)),
        "heave +5% stroke, roll 5 deg": (
            np.array([0.0, 0.0, 0.05 * robot.description.stroke_mid]),
            np.radians([5.0, 0.0, 0.0]),
        ),
        "surge -5% stroke, yaw -8 deg": (
            np.array([-0.05 * robot.description.stroke_mid, 0.0, 0.0]),
            np.radians([0.0, 0.0, -8.0]),
        ),
    }
    for label, (dp, rpy) in offsets.items():
        T = robot.home_pose
        T[:3, 3] += dp
        T[:3, :3] = pin.rpy.rpyToMatrix(rpy) @ T[:3, :3]
        q = robot.inverse_geometry(T)
        back = robot.forward_geometry(q[:, 2])
        print(f"\n== {label}: O_p = {T[:3, 3]} m")
        print("   inverse geometry, rows = legs, [q1 rad, q2 rad, q3 m]:")
        print(q)
        print(f"   Jp^-1 (cond {robot.condition_number(T):.3g}):")
        print(robot.inverse_jacobian(T))
        print(f"   forward geometry from the six lengths: pose error {np.abs(back - T).max():.2e}")
