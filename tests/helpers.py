"""Independent references for the tests: small re-derivations from first principles.

They share no code with stewart_pin beyond reading a description's arrays.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from stewart_pin import RobotDescription
from stewart_pin.exceptions import StewartPinError


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


# --- any MuJoCo model of a hexapod: loop-consistent states and an exact KKT solve -------------


def _mujoco_equality(m, data):
    """MuJoCo's equality rows at the current state: ``(efc_pos, efc_J)`` of the rows of type
    equality (``mj_fwdPosition`` computed)."""
    import mujoco

    eq = np.asarray(data.efc_type) == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    J = np.asarray(data.efc_J).reshape(data.nefc, m.nv)[eq]
    return np.asarray(data.efc_pos)[eq], J


def _rotvec(R: np.ndarray) -> np.ndarray:
    return np.asarray(pin.log3(R))


def mujoco_closed_state(
    m, data, body: str, T: np.ndarray, V: np.ndarray, guess=None, no_spin=()
) -> None:
    """Put ``data`` in a loop-consistent state of any MuJoCo hexapod, by MuJoCo's own
    constraint definitions: Gauss-Newton on ``qpos`` (``mj_integratePos`` steps) until the
    equality rows' ``efc_pos`` vanish and ``body`` is at the pose ``T`` (4x4, F0), then
    ``qvel`` with the equality rows' velocity 0 and ``body``'s twist ``V = [v of its origin,
    w]`` in F0. ``no_spin``: ``(body name, axis in that body)`` of rods between two
    spherical joints, whose angular velocity about their axis is set to 0 (the state the
    equivalent universal-joint leg describes; else the minimum-norm rate)."""
    import mujoco

    data.qpos[:] = m.qpos0 if guess is None else guess
    data.qvel[:] = 0.0
    bid = m.body(body).id
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for _ in range(60):
        mujoco.mj_fwdPosition(m, data)
        r_eq, J_eq = _mujoco_equality(m, data)
        mujoco.mj_jacBody(m, data, jacp, jacr, bid)
        R = data.xmat[bid].reshape(3, 3)
        r = np.r_[r_eq, data.xpos[bid] - T[:3, 3], _rotvec(R @ T[:3, :3].T)]
        if np.abs(r).max() < 1e-14:
            break
        step = np.linalg.lstsq(np.r_[J_eq, jacp, jacr], -r, rcond=None)[0]
        mujoco.mj_integratePos(m, data.qpos, step, 1.0)
    else:
        raise AssertionError(f"no loop-consistent state: residual {np.abs(r).max():.3g}")
    mujoco.mj_fwdPosition(m, data)
    _, J_eq = _mujoco_equality(m, data)
    mujoco.mj_jacBody(m, data, jacp, jacr, bid)
    spins = []
    for name, axis in no_spin:
        rod = m.body(name).id
        jr = np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, data, None, jr, rod)
        spins.append((data.xmat[rod].reshape(3, 3) @ np.asarray(axis, float)) @ jr)
    rows = np.vstack([J_eq, jacp, jacr, *spins]) if spins else np.r_[J_eq, jacp, jacr]
    rhs = np.r_[np.zeros(len(J_eq)), V, np.zeros(len(spins))]
    data.qvel[:] = np.linalg.lstsq(rows, rhs, rcond=None)[0]


def mujoco_constraint_rows(m, data) -> tuple[np.ndarray, np.ndarray]:
    """``(J, Jdot qvel)`` of every active ``connect`` (3 rows) and ``weld`` (6 rows) from
    ``mj_jac`` / ``mj_jacDot`` at the anchor points (both bodies), at the current state
    (``mj_forward`` done); their row space is checked against MuJoCo's ``efc_J``."""
    import mujoco

    rows, drift = [], []
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    dp, dr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for e in range(m.neq):
        if not data.eq_active[e]:
            continue
        d = m.eq_data[e]
        if m.eq_objtype[e] == mujoco.mjtObj.mjOBJ_SITE:
            s1, s2 = m.eq_obj1id[e], m.eq_obj2id[e]
            b1, b2 = m.site_bodyid[s1], m.site_bodyid[s2]
            p1, p2 = data.site_xpos[s1].copy(), data.site_xpos[s2].copy()
        else:
            b1, b2 = m.eq_obj1id[e], m.eq_obj2id[e]
            p1 = data.xpos[b1] + data.xmat[b1].reshape(3, 3) @ d[0:3]
            p2 = data.xpos[b2] + data.xmat[b2].reshape(3, 3) @ d[3:6]
        if m.eq_type[e] == mujoco.mjtEq.mjEQ_WELD:
            p1 = p2 = data.xpos[b2] + data.xmat[b2].reshape(3, 3) @ d[0:3]
        blocks = []
        for p, b, sign in ((p1, b1, 1.0), (p2, b2, -1.0)):
            mujoco.mj_jac(m, data, jp, jr, p, b)
            mujoco.mj_jacDot(m, data, dp, dr, p, b)
            blocks.append((sign * jp.copy(), sign * jr.copy(), sign * dp.copy(), sign * dr.copy()))
        (a_p, a_r, a_dp, a_dr), (b_p, b_r, b_dp, b_dr) = blocks
        rows.append(a_p + b_p)
        drift.append((a_dp + b_dp) @ data.qvel)
        if m.eq_type[e] == mujoco.mjtEq.mjEQ_WELD:
            rows.append(a_r + b_r)
            drift.append((a_dr + b_dr) @ data.qvel)
    J, Jd = np.vstack(rows), np.concatenate(drift)
    _, efc = _mujoco_equality(m, data)
    rank = np.linalg.matrix_rank
    assert rank(np.r_[J, efc]) == rank(J) == rank(efc), "rows differ from MuJoCo's efc_J"
    return J, Jd


def mujoco_kkt(m, data, body: str, A=None, gamma=None) -> np.ndarray:
    """An exact KKT solve on MuJoCo's own model at the current (consistent) state: the mass
    matrix ``mj_fullM`` (armature included), ``qfrc_bias``, ``qfrc_passive`` (damping,
    springs), Coulomb friction ``frictionloss * sign(qvel)`` with the project's dead band
    (MuJoCo's own is a constraint of its soft solver), the loops of
    :func:`mujoco_constraint_rows` as hard constraints, the actuators' joint transmissions
    with their gears. With ``A`` (the classical acceleration ``[a of body's origin, dw/dt]``
    in F0): the actuator forces (nu,) (inverse dynamics); with ``gamma`` (nu,): ``A``."""
    import mujoco

    from stewart_pin.description.leg_architecture import coulomb_sign

    mujoco.mj_forward(m, data)
    nv = m.nv
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, data, M)
    c = data.qfrc_bias - data.qfrc_passive + m.dof_frictionloss * coulomb_sign(data.qvel)
    J, Jd = mujoco_constraint_rows(m, data)
    bid = m.body(body).id
    jp, jr, dp, dr = (np.zeros((3, nv)) for _ in range(4))
    mujoco.mj_jac(m, data, jp, jr, data.xpos[bid], bid)
    mujoco.mj_jacDot(m, data, dp, dr, data.xpos[bid], bid)
    Jb, Jbd = np.r_[jp, jr], np.r_[dp, dr] @ data.qvel
    S = np.zeros((m.nu, nv))
    for u in range(m.nu):
        S[u, m.jnt_dofadr[m.actuator_trnid[u, 0]]] = m.actuator_gear[u, 0]
    nr, nu = len(J), m.nu
    if A is not None:
        K = np.zeros((nv + nr + 6, nv + nu + nr))
        K[:nv, :nv], K[:nv, nv : nv + nu], K[:nv, nv + nu :] = M, -S.T, -J.T
        K[nv : nv + nr, :nv] = J
        K[nv + nr :, :nv] = Jb
        rhs = np.r_[-c, -Jd, np.asarray(A) - Jbd]
        return np.linalg.solve(K, rhs)[nv : nv + nu]
    K = np.zeros((nv + nr, nv + nr))
    K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = M, -J.T, J
    x = np.linalg.solve(K, np.r_[S.T @ np.asarray(gamma) - c, -Jd])
    return Jb @ x[:nv] + Jbd


def fuzz_pose(robot, x: list[float], reach: float) -> np.ndarray:
    """Home moved by up to ``reach`` times the mid-stroke and turned by up to twice
    ``reach`` rad (at 0.4: mostly beyond the stroke, sometimes near a singularity)."""
    T = robot.home_pose
    T[:3, 3] += reach * robot.description.stroke_mid * np.array(x[:3])
    T[:3, :3] = pin.exp3(2.0 * reach * np.array(x[3:])) @ T[:3, :3]
    return T


def outcome(call):
    """``(result, None)`` or ``(None, error)`` for a named error; anything else propagates."""
    try:
        return call(), None
    except StewartPinError as e:
        return None, e


def same_outcome(ref_call, got_call):
    """Both raise the same named error (returns None), or both return finite arrays."""
    ref, ref_err = outcome(ref_call)
    got, got_err = outcome(got_call)
    if ref_err is not None or got_err is not None:
        assert type(got_err) is type(ref_err), (ref_err, got_err)
        assert str(got_err) == str(ref_err)
        return None
    assert np.all(np.isfinite(ref)) and np.all(np.isfinite(got))
    return ref, got


def backends_agree_or_raise_the_same_named_error(
    robot, backend, hold: float, agree: float, r, x, v, a, g, kv, ka, kg
) -> bool:
    """The fuzz property of the compiled backends: at the drawn state (pose
    :func:`fuzz_pose`, twist, acceleration and forces scaled by the mid-stroke, the holding
    force ``hold`` and powers of ten), ``backend`` and the reference path
    (``backend="pinocchio"``) both raise the same named error or agree to ``agree``: the IDM
    relative to its largest force, the DDM relative to the largest of the acceleration and
    its two parts. Returns whether the IDM accepted the state."""
    s = robot.description.stroke_mid
    T = fuzz_pose(robot, x, r)
    V = np.array(v) * [s, s, s, 1.0, 1.0, 1.0] * 10.0**kv
    A = np.array(a) * [s, s, s, 1.0, 1.0, 1.0] * 3.0 * 10.0**ka
    G = np.array(g) * hold * 10.0**kg
    # IDM.
    pair = same_outcome(
        lambda: robot.inverse_dynamics(T, V, A, backend="pinocchio"),
        lambda: backend.inverse_dynamics(T, V, A),
    )
    if pair is not None:
        ref, got = pair
        assert np.abs(got - ref).max() <= agree * np.abs(ref).max()
    # DDM on the drawn forces and (if the IDM accepted the state) on the IDM's.
    forces = [G] if pair is None else [G, pair[0]]
    for F in forces:
        result = same_outcome(
            lambda F=F: robot.direct_dynamics(T, V, F, backend="pinocchio"),
            lambda F=F: backend.direct_dynamics(T, V, F),
        )
        if result is None:
            continue
        ref, got = result
        free = robot.direct_dynamics(T, V, np.zeros(6), backend="pinocchio")
        scale = max(np.abs(ref).max(), np.abs(free).max(), np.abs(ref - free).max())
        assert np.abs(got - ref).max() <= agree * scale
    return pair is not None


def urdf_weights(model, path, links) -> list[tuple[int, float, np.ndarray]]:
    """``(joint, mass, centre of mass in the joint's frame)`` of the URDF ``links`` (read
    from the file at ``path``) in the Pinocchio ``model`` built from it: the weights a
    reference removes for links without gravity (:func:`weight_removal_torques`)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    out = []
    for name in links:
        inertial = root.find(f"link[@name='{name}']/inertial")
        origin = inertial.find("origin")
        xyz = np.zeros(3) if origin is None else np.array(origin.get("xyz").split(), float)
        frame = model.frames[model.getFrameId(name)]
        out.append(
            (
                frame.parentJoint,
                float(inertial.find("mass").get("value")),
                frame.placement.act(xyz),
            )
        )
    return out


def weight_removal_torques(model, data, q, weights) -> np.ndarray:
    """``J^T f`` (nv,) of the forces ``f = -m g`` at the centres of mass of ``weights``
    (:func:`urdf_weights`) at ``q``: the joint torques removing those weights (the
    difference of ``pin.rnea`` at rest without and with them as external forces)."""
    pin.forwardKinematics(model, data, q)
    g = np.array(model.gravity.linear)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for jid, mass, com in weights:
        f = data.oMi[jid].rotation.T @ (-mass * g)
        fext[jid] = fext[jid] + pin.Force(f, np.cross(com, f))
    zero = np.zeros(model.nv)
    return pin.rnea(model, data, q, zero, zero) - pin.rnea(model, data, q, zero, zero, fext)
