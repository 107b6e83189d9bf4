"""The MJCF: MuJoCo loads it, its loops close at the inverse geometry, its bodies carry the
description's inertia, and its dynamics are the URDF tree's (Pinocchio). The Pinocchio
layout loads in Pinocchio as the same closed-loop robot."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin.geometry import inverse_geometry
from stewart_pin.mjcf import mjcf_string, write_mjcf
from stewart_pin.presets import preset
from stewart_pin.urdf import urdf_string

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")

ROBOTS = ["simulator", "desktop", "paper", "random-0", "random-7"]
LEG_JOINTS = [f"leg{i}_q{j}" for i in range(1, 7) for j in (1, 2, 3)]


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    """``(description, MjModel)`` for each robot."""
    desc = preset(request.param)
    return desc, mujoco.MjModel.from_xml_string(mjcf_string(desc))


def random_poses(desc, seed: int, n: int = 3) -> list[np.ndarray]:
    """Poses 0Tp near home: home composed with a random twist of a few cm and degrees."""
    rng = np.random.default_rng(seed)
    scale = np.r_[np.full(3, 0.04 * desc.size), np.full(3, 0.08)]
    return [desc.home_pose @ pin.exp6(rng.uniform(-1, 1, 6) * scale).homogeneous for _ in range(n)]


def quat_wxyz(R: np.ndarray) -> np.ndarray:
    x, y, z, w = pin.Quaternion(R).coeffs()
    return np.array([w, x, y, z])


def mujoco_qpos(desc, T: np.ndarray) -> np.ndarray:
    """qpos from the inverse geometry: 18 leg joints, then the free joint [p, quat wxyz]."""
    q_legs = inverse_geometry(desc, T, check_limits=False)
    return np.concatenate([q_legs.ravel(), T[:3, 3], quat_wxyz(T[:3, :3])])


def com_and_inertia(params: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia about it from Khalil's XX XY XZ YY YZ ZZ MX MY MZ M
    (written out here, independently of stewart_pin.inertia)."""
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = params
    I_O = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    c = np.array([MX, MY, MZ]) / M
    return M, c, I_O - M * (c @ c * np.eye(3) - np.outer(c, c))


def test_structure(robot):
    desc, m = robot
    assert (m.nq, m.nv, m.njnt, m.neq, m.nu, m.nkey) == (25, 24, 19, 6, 6, 1)
    names = [m.joint(j).name for j in range(m.njnt)]
    assert names == [*LEG_JOINTS, "platform_joint"]
    hinge, slide = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE
    assert list(m.jnt_type) == [hinge, hinge, slide] * 6 + [mujoco.mjtJoint.mjJNT_FREE]
    assert m.body_parentid[m.body("platform").id] == 0  # the free body hangs from the world
    np.testing.assert_array_equal(m.opt.gravity, desc.gravity)
    for k in range(6):
        q3 = m.joint(f"leg{k + 1}_q3")
        np.testing.assert_array_equal(q3.range, desc.stroke)
        assert m.actuator(k).trnid[0] == q3.id
    assert all(m.eq_type == mujoco.mjtEq.mjEQ_CONNECT)
    assert desc.u_joint_limits is None  # the presets: the URDF writer's default U-joint range
    for i in range(1, 7):
        np.testing.assert_array_equal(m.joint(f"leg{i}_q1").range, [-np.pi, np.pi])
        np.testing.assert_array_equal(m.joint(f"leg{i}_q2").range, [0.0, np.pi])


def test_u_joint_limits_become_ranges():
    lim = np.array([[-0.5, 0.7], [0.3, 2.9]])  # [rad]
    desc = preset("random-4").replace(u_joint_limits=lim)
    m = mujoco.MjModel.from_xml_string(mjcf_string(desc))
    for i in range(1, 7):
        np.testing.assert_array_equal(m.joint(f"leg{i}_q1").range, lim[0])
        np.testing.assert_array_equal(m.joint(f"leg{i}_q2").range, lim[1])


def test_loops_closed_at_inverse_geometry(robot):
    desc, m = robot
    data = mujoco.MjData(m)
    for T in random_poses(desc, seed=11):
        data.qpos[:] = mujoco_qpos(desc, T)
        mujoco.mj_forward(m, data)
        eq = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        assert eq.sum() == 18
        assert np.abs(data.efc_pos[eq]).max() < 1e-12
        P_in_0 = desc.platform_points @ T[:3, :3].T + T[:3, 3]
        for k in range(6):
            tip = data.site(f"leg{k + 1}_tip").xpos
            np.testing.assert_allclose(tip, P_in_0[k], rtol=0, atol=1e-12)
            np.testing.assert_allclose(data.site(f"platform_p{k + 1}").xpos, P_in_0[k], atol=1e-12)
        np.testing.assert_allclose(data.body("platform").xpos, T[:3, 3], atol=1e-14)


def test_home_keyframe(robot):
    desc, m = robot
    data = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, data, m.key("home").id)
    np.testing.assert_allclose(data.qpos, mujoco_qpos(desc, desc.home_pose), rtol=0, atol=1e-15)
    mujoco.mj_forward(m, data)
    eq = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert np.abs(data.efc_pos[eq]).max() < 1e-12
    # The platform body is placed at home, so qpos0 is the home pose too.
    np.testing.assert_allclose(m.qpos0[18:21], desc.home_pose[:3, 3], atol=1e-15)


def test_inertials_match_description(robot):
    desc, m = robot
    bodies = [
        (f"leg{i + 1}_link{j + 1}", desc.leg_inertia[i, j]) for i in range(6) for j in range(3)
    ]
    for name, params in [*bodies, ("platform", desc.platform_inertia)]:
        body = m.body(name)
        mass, com, I_c = com_and_inertia(params)
        assert body.mass[0] == pytest.approx(mass, rel=1e-15), name
        np.testing.assert_allclose(body.ipos, com, rtol=0, atol=1e-15 * desc.size, err_msg=name)
        # MuJoCo stores principal moments and the principal axes' orientation.
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, body.iquat)
        R = R.reshape(3, 3)
        I_mj = R @ np.diag(body.inertia) @ R.T
        np.testing.assert_allclose(I_mj, I_c, rtol=0, atol=1e-12 * np.abs(I_c).max(), err_msg=name)
    assert m.body("base_link").mass[0] == 0.0


def test_dynamics_match_urdf_tree(robot):
    """MuJoCo's mass matrix and gravity forces equal Pinocchio's on the URDF tree, once the
    free-joint velocities are mapped: MuJoCo's [v in F0, w in Fp], Pinocchio's
    [R^T v, w in Fp]."""
    desc, m = robot
    model = pin.buildModelFromXML(urdf_string(desc))
    model.gravity.linear = desc.gravity
    pdata = model.createData()
    data = mujoco.MjData(m)
    # Pinocchio velocity index of each MuJoCo dof.
    ff = model.getJointId("platform_joint")
    order = [model.idx_vs[model.getJointId(n)] for n in LEG_JOINTS]
    order += list(range(model.idx_vs[ff], model.idx_vs[ff] + 6))
    for T in random_poses(desc, seed=5, n=2):
        data.qpos[:] = mujoco_qpos(desc, T)
        mujoco.mj_forward(m, data)
        M_mj = np.zeros((m.nv, m.nv))
        if int(mujoco.__version__.split(".")[0]) >= 4:
            mujoco.mj_fullM(m, data, M_mj)
        else:  # MuJoCo 3: mj_fullM(m, dst, qM)
            mujoco.mj_fullM(m, M_mj, data.qM)

        q = pin.neutral(model)
        q_legs = inverse_geometry(desc, T, check_limits=False)
        for n, value in zip(LEG_JOINTS, q_legs.ravel(), strict=True):
            q[model.idx_qs[model.getJointId(n)]] = value
        q[model.idx_qs[ff] : model.idx_qs[ff] + 7] = pin.SE3ToXYZQUAT(pin.SE3(T))
        M_pin = pin.crba(model, pdata, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        g_pin = pin.computeGeneralizedGravity(model, pdata, q)
        # v_pin = S v_mj (reordered), with the platform's linear part rotated by R^T.
        S = np.eye(24)[order]
        S[order[18:21], 18:21] = T[:3, :3].T
        M_expected = S.T @ M_pin @ S
        np.testing.assert_allclose(M_mj, M_expected, rtol=0, atol=1e-10 * np.abs(M_pin).max())
        np.testing.assert_allclose(
            data.qfrc_bias, S.T @ g_pin, rtol=0, atol=1e-10 * np.abs(g_pin).max()
        )


def test_mujoco_refuses_pinocchio_layout():
    with pytest.raises(ValueError, match="free joint"):
        mujoco.MjModel.from_xml_string(mjcf_string(preset("desktop"), pinocchio_layout=True))


@pytest.mark.parametrize("name", ROBOTS)
def test_pinocchio_layout_loads_in_pinocchio(name, tmp_path):
    desc = preset(name)
    path = write_mjcf(desc, tmp_path / f"{name}.xml", pinocchio_layout=True)
    model, anchors, frame_anchors = pin.buildModelAndConstraintsFromMJCF(str(path))
    ref = pin.buildModelFromXML(urdf_string(desc))
    assert (model.nq, model.nv, len(anchors), len(frame_anchors)) == (25, 24, 6, 0)
    assert sorted(model.names) == sorted(ref.names)
    for j in range(1, ref.njoints):
        n = ref.names[j]
        k = model.getJointId(n)
        assert model.joints[k].shortname() == ref.joints[j].shortname(), n
        np.testing.assert_allclose(
            model.jointPlacements[k].homogeneous, ref.jointPlacements[j].homogeneous, atol=1e-12
        )
        a, b = model.inertias[k], ref.inertias[j]
        assert a.mass == pytest.approx(b.mass, rel=1e-15), n
        np.testing.assert_allclose(a.lever, b.lever, rtol=0, atol=1e-14, err_msg=n)
        np.testing.assert_allclose(
            a.inertia, b.inertia, rtol=0, atol=1e-12 * np.abs(b.inertia).max()
        )
        if n != "platform_joint":  # Pinocchio's MJCF free joint gets |p| <= 1.01 m limits
            for limit in ("lowerPositionLimit", "upperPositionLimit"):
                a_lim = getattr(model, limit)[model.idx_qs[k]]
                b_lim = getattr(ref, limit)[ref.idx_qs[j]]
                assert a_lim == b_lim, f"{n} {limit}"

    # The point anchors: origin of frame 3i on leg i's prismatic joint, P_i on the platform.
    ff = model.getJointId("platform_joint")
    for k, c in enumerate(anchors):
        assert model.names[c.joint1_id] == f"leg{k + 1}_q3"
        assert c.joint2_id == ff
        np.testing.assert_array_equal(c.joint1_placement.translation, np.zeros(3))
        np.testing.assert_allclose(
            c.joint2_placement.translation, desc.platform_points[k], atol=1e-15
        )

    # The keyframe (Pinocchio converts its quaternion to x, y, z, w), and closed loops there
    # and at random poses.
    data = model.createData()
    poses = [desc.home_pose, *random_poses(desc, seed=3, n=2)]
    for n, T in enumerate(poses):
        q = np.concatenate(
            [inverse_geometry(desc, T, check_limits=False).ravel(), pin.SE3ToXYZQUAT(pin.SE3(T))]
        )
        if n == 0:
            np.testing.assert_allclose(model.referenceConfigurations["home"], q, atol=1e-15)
        pin.forwardKinematics(model, data, q)
        for c in anchors:
            p1 = data.oMi[c.joint1_id].act(c.joint1_placement.translation)
            p2 = data.oMi[c.joint2_id].act(c.joint2_placement.translation)
            np.testing.assert_allclose(p1, p2, rtol=0, atol=1e-12)
