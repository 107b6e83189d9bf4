"""``robot.tree``, ``leg_models`` and ``legs_model`` of chain-leg robots: Pinocchio's
``constraintDynamics`` on the facade's tree (3D loops at the balls, 6D at the welds), driven
by the actuated efforts of the robot's inverse dynamics less the joint terms (written out
here), gives back the platform acceleration asked for; the leg models are ChainDynamics'."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.kinematics import chain_legs


@pytest.fixture(scope="module", params=["welded", "mixed"])
def robot(request: pytest.FixtureRequest) -> StewartRobot:
    desc = welded_ups(seed=1) if request.param == "welded" else mixed_chain_robot(seed=2)
    return StewartRobot(desc)


def _joint_torques(robot: StewartRobot, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Friction, damper and spring efforts of every leg joint at the tree's ``q``, ``v``."""
    tree = robot.tree
    tau = np.zeros(tree.model.nv)
    for k, leg in enumerate(robot.description.chain_legs or ()):
        for j, joint in enumerate(leg.joints):
            d = joint.dynamics
            x, xd = q[tree.leg_q_index[k, j]], v[tree.leg_v_index[k, j]]
            tau[tree.leg_v_index[k, j]] = (
                (d.viscous + d.damping) * xd
                + d.coulomb * coulomb_sign(np.array(xd))
                + d.stiffness * (x - d.rest_position)
            )
    return tau


def test_constraint_dynamics_on_the_tree_returns_the_asked_acceleration(
    robot: StewartRobot,
) -> None:
    tree = robot.tree
    model, data = tree.model, tree.model.createData()
    assert len(tree.constraints) == 6
    legs = robot.description.chain_legs or ()
    for cm, leg in zip(tree.constraints, legs, strict=True):
        kind = pin.ContactType.CONTACT_6D if leg.closure == "weld" else pin.ContactType.CONTACT_3D
        assert cm.type == kind
    n_joints = [leg.n_joints for leg in legs]
    assert model.nv == 6 + sum(n_joints)
    assert all(np.all(tree.leg_v_index[k, n:] == -1) for k, n in enumerate(n_joints))
    T, V, A = robot.sample_states(3, rng=5)
    gamma = robot.inverse_dynamics(T, V, A)
    cdatas = [cm.createData() for cm in tree.constraints]
    pin.initConstraintDynamics(model, data, tree.constraints, cdatas)
    settings = pin.ProximalSettings(1e-14, 0.0, 1)
    for n in range(T.shape[0]):
        R = T[n, :3, :3]
        qs = chain_legs.inverse_geometry(robot.description, T[n][None], False)
        _, qd, _ = robot.leg_kinematics(T[n], V[n])
        q, v = np.zeros(model.nq), np.zeros(model.nv)
        q[tree.platform_q_index] = pin.SE3ToXYZQUAT(pin.SE3(R, T[n, :3, 3]))
        v[tree.platform_v_index] = np.concatenate([R.T @ V[n, :3], R.T @ V[n, 3:]])
        for k, x in enumerate(qs):
            q[tree.leg_q_index[k, : x.shape[1]]] = x[0]
            v[tree.leg_v_index[k, : x.shape[1]]] = qd[k, : x.shape[1]]
        pin.forwardKinematics(model, data, q)
        for cm in tree.constraints:  # the loops are closed (orientations at the welds)
            c1 = data.oMi[cm.joint1_id] * cm.joint1_placement
            c2 = data.oMi[cm.joint2_id] * cm.joint2_placement
            gap = pin.log6(c1.inverse() * c2).vector
            weld = cm.type == pin.ContactType.CONTACT_6D
            assert np.linalg.norm(gap if weld else c1.translation - c2.translation) < 1e-9
        tau = -_joint_torques(robot, q, v)
        tau[tree.actuated_v_index] += gamma[n]
        ddq = pin.constraintDynamics(model, data, q, v, tau, tree.constraints, cdatas, settings)
        a = ddq[tree.platform_v_index]
        vl, wl = v[tree.platform_v_index[:3]], v[tree.platform_v_index[3:]]
        acc = np.concatenate([R @ (a[:3] + np.cross(wl, vl)), R @ a[3:]])
        assert np.abs(acc - A[n]).max() <= 1e-9 * np.abs(A[n]).max()


def test_leg_models_are_the_models_of_chain_dynamics(robot: StewartRobot) -> None:
    T, V, A = robot.sample_states(2, rng=6)
    q, qd, qdd = robot.leg_kinematics(T, V, A)
    legs = robot.chain_dynamics.legs
    big, index = robot.legs_model
    big_data = big.createData()
    for k, model in enumerate(robot.leg_models):
        n = model.nv
        assert np.array_equal(model.armature, legs.legs[k].armature)
        M, h = legs.mass_and_bias(k, q[:, k, :n], qd[:, k, :n])
        h -= legs.terms[k].efforts(q[:, k, :n], qd[:, k, :n])
        assert np.all(index[k, n:] == -1)
        for s in range(q.shape[0]):
            tau = pin.rnea(model, model.createData(), q[s, k, :n], qd[s, k, :n], qdd[s, k, :n])
            ref = M[s] @ qdd[s, k, :n] + h[s]
            assert np.allclose(tau, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
            qb, vb, ab = np.zeros(big.nq), np.zeros(big.nv), np.zeros(big.nv)
            qb[index[k, :n]], vb[index[k, :n]], ab[index[k, :n]] = (
                q[s, k, :n],
                qd[s, k, :n],
                qdd[s, k, :n],
            )
            assert np.allclose(pin.rnea(big, big_data, qb, vb, ab)[index[k, :n]], tau, atol=1e-12)


def test_actuator_limits_of_chain_legs_are_the_actuated_joints_limits() -> None:
    """``actuator_limits`` reads each leg's actuated joint (any chain), as it is described."""
    desc = welded_ups(seed=1)
    got = StewartRobot(desc).actuator_limits
    for k, leg in enumerate(desc.chain_legs):
        joint = leg.joints[leg.actuated - 1]
        assert got[k].tolist() == [joint.lower, joint.upper]
