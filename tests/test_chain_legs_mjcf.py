"""The MJCF of robots with chain legs (ball loops as ``<connect>``, welds as ``<weld>``),
loaded in MuJoCo: its model (mass matrix with the armature ``mj_fullM``, bias and passive
forces ``qfrc_bias`` / ``qfrc_passive``: damping and springs) in a hard-constraint KKT
solve, the loops' Jacobians from MuJoCo's site Jacobians (position, and rotation for a
weld; their drift from ``mj_jacDot``), checked to span the rows MuJoCo's own equality
constraints impose, equals the chain-leg inverse model to 1e-9 relative. MuJoCo's
``frictionloss`` is a constraint of its soft solver, not ``Fc sign(qdot)``: the Coulomb
coefficients are 0 here (every other joint term is on)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from stewart_pin import StewartRobot
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, rss_robot, welded_ups
from stewart_pin.exceptions import UnsupportedArchitectureError

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")


def without_coulomb(desc):  # type: ignore[no-untyped-def]
    legs = tuple(
        leg.replace(
            joints=tuple(replace(j, dynamics=replace(j.dynamics, coulomb=0.0)) for j in leg.joints)
        )
        for leg in desc.chain_legs
    )
    return desc.replace(chain_legs=legs)


def loop_jacobian(m, data, robot: StewartRobot) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """``Jc`` (sum c_i, nv) and its drift ``Jdot qvel`` in F0 from MuJoCo's site
    Jacobians: leg tip minus platform point (position; and rotation for a weld)."""
    rows, drift = [], []
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for k, leg in enumerate(robot.description.chain_legs, start=1):
        parts = []
        for site in (f"leg{k}_tip", f"platform_p{k}"):
            sid = m.site(site).id
            mujoco.mj_jacSite(m, data, jp, jr, sid)
            J = np.vstack([jp, jr])
            mujoco.mj_jacDot(m, data, jp, jr, data.site_xpos[sid], m.site_bodyid[sid])
            parts.append((J, np.vstack([jp, jr]) @ data.qvel))
        c = leg.constraints
        rows.append((parts[0][0] - parts[1][0])[:c])
        drift.append((parts[0][1] - parts[1][1])[:c])
    return np.vstack(rows), np.concatenate(drift)


def mujoco_kkt_inverse_dynamics(m, data, robot: StewartRobot, T, V, A, idle=None):  # type: ignore[no-untyped-def]
    """Gamma (6,) and the idle joints' accelerations (6,) by the KKT solve (module
    docstring); ``idle``: the idle joints' (values, rates), each (6,), for such legs (the
    leg accelerations are unknowns, the idle ones among them: the system stays square)."""
    from stewart_pin.formats.mjcf import mujoco_qpos, quaternion_wxyz
    from stewart_pin.kinematics import chain_legs

    legs = robot.description.chain_legs
    L = np.array(
        [
            m.joint(f"leg{k}_q{j}").dofadr[0]
            for k, leg in enumerate(legs, 1)
            for j in range(1, leg.n_joints + 1)
        ]
    )
    ff = m.joint("platform_joint").dofadr[0]
    F = np.arange(ff, ff + 6)
    idle_dofs = [
        m.joint(f"leg{k}_q{leg.idle_joint}").dofadr[0]
        for k, leg in enumerate(legs, 1)
        if leg.idle_joint is not None
    ]
    E = (np.array(idle_dofs, dtype=int)[:, None] == L[None, :]).astype(float)
    if idle is None:
        data.qpos[:] = mujoco_qpos(robot.description, T)
        rates = np.zeros(len(idle_dofs))
    else:
        qs = chain_legs.inverse_geometry(robot.description, T[None], False, idle[0][None])
        data.qpos[:] = np.concatenate([*(q[0] for q in qs), T[:3, 3], quaternion_wxyz(T[:3, :3])])
        rates = np.array([idle[1][k] for k, leg in enumerate(legs) if leg.idle_joint])
    data.qvel[:] = 0.0
    data.qvel[F] = np.r_[V[:3], T[:3, :3].T @ V[3:]]
    mujoco.mj_forward(m, data)
    Jc, _ = loop_jacobian(m, data, robot)
    data.qvel[L] = np.linalg.solve(
        np.vstack([Jc[:, L], E]), np.r_[-Jc[:, F] @ data.qvel[F], rates]
    )
    mujoco.mj_forward(m, data)
    Jc, drift = loop_jacobian(m, data, robot)
    # MuJoCo's equality rows constrain the same motions as Jc
    eq = np.asarray(data.efc_J).reshape(data.nefc, m.nv)[
        data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    ]
    assert eq.shape[0] == Jc.shape[0]
    assert np.linalg.matrix_rank(np.vstack([eq, Jc]), tol=1e-9 * np.abs(Jc).max()) == Jc.shape[0]
    nv, nc = m.nv, Jc.shape[0]
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, data, M)
    S = np.zeros((6, nv))
    for k, leg in enumerate(legs):
        S[k, m.joint(f"leg{k + 1}_q{leg.actuated}").dofadr[0]] = 1.0
    a_F = np.r_[A[:3], T[:3, :3].T @ A[3:]]
    n_legs = len(L)
    K = np.zeros((nv + nc, n_legs + 6 + nc))
    K[:nv, :n_legs], K[:nv, n_legs : n_legs + 6], K[:nv, n_legs + 6 :] = M[:, L], -S.T, -Jc.T
    K[nv:, :n_legs] = Jc[:, L]
    rhs = np.r_[-M[:, F] @ a_F - data.qfrc_bias + data.qfrc_passive, -Jc[:, F] @ a_F - drift]
    x = np.linalg.solve(K, rhs)
    sigma = np.zeros(6)
    sigma[[k for k, leg in enumerate(legs) if leg.idle_joint is not None]] = E @ x[:n_legs]
    return x[n_legs : n_legs + 6], sigma


@pytest.mark.parametrize("build", [welded_ups, mixed_chain_robot])
def test_mujoco_kkt_inverse_dynamics(build) -> None:  # type: ignore[no-untyped-def]
    robot = StewartRobot(without_coulomb(build(seed=4)))
    m = mujoco.MjModel.from_xml_string(robot.mjcf())
    data = mujoco.MjData(m)
    welds = sum(leg.closure == "weld" for leg in robot.description.chain_legs)
    assert m.neq == 6 and int(np.sum(m.eq_type == mujoco.mjtEq.mjEQ_WELD)) == welds
    # the home keyframe closes the loops
    mujoco.mj_resetDataKeyframe(m, data, m.key("home").id)
    mujoco.mj_forward(m, data)
    for k in range(1, 7):
        assert (
            np.abs(data.site(f"leg{k}_tip").xpos - data.site(f"platform_p{k}").xpos).max() < 1e-12
        )
    T, V, A = robot.sample_states(3, rng=5)
    expected = robot.inverse_dynamics(T, V, A)
    for n in range(3):
        got, _ = mujoco_kkt_inverse_dynamics(m, data, robot, T[n], V[n], A[n])
        assert np.abs(got - expected[n]).max() <= 1e-9 * np.abs(expected[n]).max()


@pytest.mark.parametrize("symmetric", [True, False])
def test_mujoco_kkt_with_spinning_rods(symmetric: bool) -> None:
    """6-RSS: the rods' spins are MuJoCo hinges; the KKT solve gives Gamma and the spin
    accelerations the chain-leg inverse model returns for the same spin state."""
    robot = StewartRobot(without_coulomb(rss_robot(symmetric)))
    m = mujoco.MjModel.from_xml_string(robot.mjcf())
    data = mujoco.MjData(m)
    assert m.nv == 6 + 6 * 4 and m.neq == 6
    T, V, A = robot.sample_states(3, rng=6)
    rng = np.random.default_rng(1)
    spin, rate = rng.uniform(-1.0, 1.0, (3, 6)), rng.uniform(-5.0, 5.0, (3, 6))
    res = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    for n in range(3):
        got, sigma = mujoco_kkt_inverse_dynamics(
            m, data, robot, T[n], V[n], A[n], (spin[n], rate[n])
        )
        assert np.abs(got - res.gamma[n]).max() <= 1e-9 * np.abs(res.gamma[n]).max()
        ref = res.idle_accel[n]
        assert np.abs(sigma - ref).max() <= 1e-9 * np.abs(ref).max()


def test_the_pinocchio_layout_is_refused() -> None:
    robot = StewartRobot(welded_ups(seed=1, joint_terms=False))
    with pytest.raises(UnsupportedArchitectureError, match="Pinocchio layout"):
        robot.mjcf(pinocchio_layout=True)
