"""Independent references for the tests: small re-derivations from first principles.

They share no code with stewart_pin beyond reading a description's arrays.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from stewart_pin import RobotDescription


def points_in_base(desc: RobotDescription, T: np.ndarray) -> np.ndarray:
    """P_i in F0 for one pose 0Tp, (6, 3) [m]: P_i = R pP_i + p."""
    return desc.platform_points @ T[:3, :3].T + T[:3, 3]


def leg_lengths_by_hand(desc: RobotDescription, T: np.ndarray) -> np.ndarray:
    """|B_i P_i| for one pose, (6,) [m]."""
    return np.linalg.norm(points_in_base(desc, T) - desc.base_points, axis=1)


def rot_z(angle: float) -> np.ndarray:
    """4x4 homogeneous rotation about z [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def rot_x(angle: float) -> np.ndarray:
    """4x4 homogeneous rotation about x [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    """4x4 homogeneous translation [m]."""
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix (QR of a Gaussian matrix, sign-fixed)."""
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q @ np.diag(np.sign(np.diag(R)))
    return Q if np.linalg.det(Q) > 0 else -Q


def random_motion_states(n: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    """``(times, poses, twists, accels)`` of ``n`` random platform states (no robot: any
    rotation, position, twist and acceleration), times 0.01 s apart."""
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (n, 1, 1))
    for T in poses:
        T[:3, :3] = pin.exp3(rng.normal(size=3))
        T[:3, 3] = rng.normal(size=3)
    return np.arange(n) * 0.01, poses, rng.normal(size=(n, 6)), rng.normal(size=(n, 6))


def tip_frame(i: int) -> str:
    """Name of leg i's tip frame (0-based i): frame 3i, whose origin should be P_i."""
    return f"leg{i + 1}_link3"


def frame_position(model: pin.Model, q: np.ndarray, frame: str) -> np.ndarray:
    """World position of ``frame`` at ``q`` by Pinocchio's forward kinematics, (3,) [m]."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    return data.oMf[model.getFrameId(frame)].translation.copy()


def tree_configuration(model: pin.Model, T: np.ndarray, q_legs: np.ndarray) -> np.ndarray:
    """The tree's q (25,) for a platform pose 0Tp and leg joint values (6, 3), placed by
    joint name through Pinocchio's own index tables."""
    q = pin.neutral(model)
    ff = model.getJointId("platform_joint")
    q[model.idx_qs[ff] : model.idx_qs[ff] + 7] = pin.SE3ToXYZQUAT(pin.SE3(T[:3, :3], T[:3, 3]))
    for i in range(6):
        for j in range(3):
            q[model.idx_qs[model.getJointId(f"leg{i + 1}_q{j + 1}")]] = q_legs[i, j]
    return q


def rel_error(a: np.ndarray, b: np.ndarray) -> float:
    """``max |a - b| / max |b|``: the relative error the tests state their tolerances in."""
    return float(np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), 1e-300))


def mujoco_leg_dofs(m) -> np.ndarray:
    """The 18 leg joints' velocity indices of an exported MJCF, leg by leg (``leg{i}_q{j}``)."""
    return np.array([m.joint(f"leg{i}_q{j}").dofadr[0] for i in range(1, 7) for j in (1, 2, 3)])


def mujoco_set_loop_state(m, data, qpos: np.ndarray, T: np.ndarray, V: np.ndarray) -> np.ndarray:
    """A consistent MuJoCo state of an exported hexapod: ``qpos`` (from the inverse
    geometry), the free joint's velocity ``[v of O_p in F0, w in Fp]`` from the twist ``V``
    (6,) in F0, and the 18 leg rates from MuJoCo's own site Jacobians (leg tip minus P_i
    velocity = 0 on each loop: ``Jc qvel = 0``). Returns ``Jc`` (18, nv)."""
    import mujoco

    data.qpos[:] = qpos
    ff = m.joint("platform_joint").dofadr[0]
    data.qvel[:] = 0.0
    data.qvel[ff : ff + 3], data.qvel[ff + 3 : ff + 6] = V[:3], T[:3, :3].T @ V[3:]
    mujoco.mj_kinematics(m, data)
    mujoco.mj_comPos(m, data)
    Jc = np.zeros((18, m.nv))
    tip, point = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for k in range(6):
        mujoco.mj_jacSite(m, data, tip, None, m.site(f"leg{k + 1}_tip").id)
        mujoco.mj_jacSite(m, data, point, None, m.site(f"platform_p{k + 1}").id)
        Jc[3 * k : 3 * k + 3] = tip - point
    legs, F = mujoco_leg_dofs(m), np.arange(ff, ff + 6)
    data.qvel[legs] = np.linalg.solve(Jc[:, legs], -Jc[:, F] @ data.qvel[F])
    return Jc
