"""The MJCF: MuJoCo loads it, its loops close at the inverse geometry, its bodies carry the
description's inertia, and its dynamics are the URDF tree's (Pinocchio). The Pinocchio
layout loads in Pinocchio as the same closed-loop robot. MuJoCo's accelerations
(``mj_forward`` with the stiff loop parameters) match the exact direct model to the
accuracy docs/closures.md states, also for robots with massless or degenerate bodies,
which MuJoCo refuses as described."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from helpers import mujoco_set_loop_state

from stewart_pin import StewartRobot
from stewart_pin.description.inertia import khalil_from_urdf_inertial, urdf_inertial_from_khalil
from stewart_pin.description.presets import preset
from stewart_pin.exceptions import ApproximationWarning
from stewart_pin.formats.mjcf import (
    LOOP_SOLIMP,
    LOOP_SOLREF,
    mjcf_string,
    mujoco_inertials,
    write_mjcf,
)
from stewart_pin.formats.urdf import urdf_string
from stewart_pin.kinematics.geometry import inverse_geometry
from stewart_pin.kinematics.workspace import sample_states

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
    (written out here, independently of stewart_pin.description.inertia)."""
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


# --- Accelerations against the exact model -----------------------------------------------

#: The accuracy docs/closures.md states for ``mj_forward`` at a consistent state:
#: ``max |A_mujoco - A| <= 3e-4 * max(max |A|, |g|)`` (A the classical platform acceleration
#: [m/s^2, rad/s^2], g gravity; measured up to 2.1e-4 over 1000 states on each preset and
#: random-0..8). MuJoCo's default soft loops are 10 % off or worse.
ACCURACY = 3e-4
ACCURACY_ROBOTS = ["simulator", "desktop", "paper", "random-0", "random-1", "random-2"]


def set_state(m, data, desc, T: np.ndarray, V: np.ndarray) -> None:
    """A consistent MuJoCo state: qpos from the inverse geometry, the free joint's velocity
    ``[v of O_p in F0, w in Fp]`` from the twist, and the 18 leg rates from MuJoCo's own
    site Jacobians (leg tip minus P_i velocity = 0 on each loop)."""
    mujoco_set_loop_state(m, data, mujoco_qpos(desc, T), T, V)


def mujoco_accelerations(desc, xml: str, poses, twists, gammas) -> np.ndarray:
    """The classical platform accelerations ``[dv/dt, dw/dt]`` in F0 from ``mj_forward``
    with the actuator forces ``gammas``: MuJoCo's free-joint ``qacc`` is ``[dv/dt in F0,
    dw/dt in Fp]``, and ``d(R w_p)/dt = R dw_p/dt``."""
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    out = np.empty((len(poses), 6))
    for n, (T, V, G) in enumerate(zip(poses, twists, gammas, strict=True)):
        set_state(m, data, desc, T, V)
        data.ctrl[:] = G
        mujoco.mj_forward(m, data)
        loops = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        assert np.abs(data.efc_vel[loops]).max() < 1e-12 * (1.0 + np.abs(V).max())  # [m/s]
        out[n] = np.r_[data.qacc[18:21], T[:3, :3] @ data.qacc[21:24]]
    return out


def acceleration_error(desc, A_mj: np.ndarray, A_ref: np.ndarray) -> float:
    """``max |A_mj - A_ref| / max(max |A_ref|, |g|)`` over the states."""
    g = np.linalg.norm(desc.gravity)
    scale = np.maximum(np.abs(A_ref).max(axis=1), g)
    return float((np.abs(A_mj - A_ref).max(axis=1) / scale).max())


def check_accelerations(desc, n: int, seed: int, xml: str | None = None) -> float:
    """MuJoCo's accelerations at ``n`` random states against the direct model's; returns
    the error of :func:`acceleration_error`, asserted within :data:`ACCURACY`."""
    robot = StewartRobot(desc)
    poses, twists, accels = sample_states(desc, n, seed)
    gammas = robot.inverse_dynamics(poses, twists, accels)
    A_ref = robot.direct_dynamics(poses, twists, gammas)
    A_mj = mujoco_accelerations(desc, xml or mjcf_string(desc), poses, twists, gammas)
    error = acceleration_error(desc, A_mj, A_ref)
    assert error <= ACCURACY, f"{desc.name}: MuJoCo accelerations {error:.2e} off"
    return error


def test_loops_carry_stiff_constraint_parameters():
    m = mujoco.MjModel.from_xml_string(mjcf_string(preset("paper")))
    np.testing.assert_array_equal(m.eq_solref, np.tile(LOOP_SOLREF, (6, 1)))
    np.testing.assert_array_equal(m.eq_solimp, np.tile(LOOP_SOLIMP, (6, 1)))


@pytest.mark.parametrize("name", ACCURACY_ROBOTS)
def test_mj_forward_accelerations_match_direct_model(name):
    """Fails with MuJoCo's default soft loops (errors of 0.1 to 1 on these states)."""
    check_accelerations(preset(name), n=6, seed=3)


def without(desc, links=(), platform=False):
    """The robot with the given leg links (0-based, in every leg) and/or the platform
    massless (all ten parameters zero)."""
    leg = desc.leg_inertia.copy()
    leg[:, list(links)] = 0.0
    return desc.replace(
        leg_inertia=leg, platform_inertia=np.zeros(10) if platform else desc.platform_inertia
    )


def test_massless_u_joint_cross_loads_with_exact_accelerations():
    """The U-joint crosses (link 1) massless: MuJoCo refused the MJCF ("inertia must have
    positive eigenvalues"); now the joints q1 sit on link 2's body and the accelerations
    are the direct model's of the massless-cross robot, not of the original one."""
    desc = preset("random-0")
    light = without(desc, links=[0])
    xml = mjcf_string(light)
    m = mujoco.MjModel.from_xml_string(xml)
    assert (m.nq, m.nv, m.neq, m.nu) == (25, 24, 6, 6)
    assert [m.joint(j).name for j in range(m.njnt)] == [*LEG_JOINTS, "platform_joint"]
    bodies = {m.body(b).name for b in range(m.nbody)}
    assert not any(f"leg{i}_link1" in bodies for i in range(1, 7))
    for i in range(1, 7):  # q1 and q2 on one body, q1 first
        assert m.joint(f"leg{i}_q1").bodyid == m.joint(f"leg{i}_q2").bodyid
        assert m.body(f"leg{i}_link2").jntadr == m.joint(f"leg{i}_q1").id
    error = check_accelerations(light, n=6, seed=5)
    # The cross's inertia matters far more than that: the original robot's accelerations
    # are off the massless-cross MJCF's by much more than the accuracy.
    robot = StewartRobot(desc)
    poses, twists, accels = sample_states(light, 6, 5)
    gammas = StewartRobot(light).inverse_dynamics(poses, twists, accels)
    A_mj = mujoco_accelerations(light, xml, poses, twists, gammas)
    assert acceleration_error(desc, A_mj, robot.direct_dynamics(poses, twists, gammas)) > 10 * max(
        error, ACCURACY
    )


def point_mass(params: np.ndarray) -> np.ndarray:
    """The same mass and centre of mass, no inertia about it."""
    mass, com, _ = urdf_inertial_from_khalil(params)
    return khalil_from_urdf_inertial(mass, com, np.zeros((3, 3)))


def thin_rod(params: np.ndarray) -> np.ndarray:
    """The same mass and centre of mass, inertia of a thin rod along the frame's z."""
    mass, com, I_c = urdf_inertial_from_khalil(params)
    return khalil_from_urdf_inertial(mass, com, np.diag([1.0, 1.0, 0.0]) * np.trace(I_c) / 2)


def flat_plate(params: np.ndarray, rotation=(1.0, 0.5, -0.7)) -> np.ndarray:
    """The same mass and centre of mass, a flat plate (principal moments a, b, a + b) turned
    by ``exp3(rotation)`` from the frame's axes (this one MuJoCo refused as described:
    "inertia must satisfy A + B >= C", its eigenvalues rounded the other way)."""
    mass, com, I_c = urdf_inertial_from_khalil(params)
    a, b = 0.2 * np.trace(I_c), 0.3 * np.trace(I_c)
    R = pin.exp3(np.asarray(rotation, dtype=float))
    return khalil_from_urdf_inertial(mass, com, R @ np.diag([a, b, a + b]) @ R.T)


def with_links(desc, j: int, make) -> object:
    leg = desc.leg_inertia.copy()
    leg[:, j] = [make(p) for p in leg[:, j]]
    return desc.replace(leg_inertia=leg)


DEGENERATE = {
    "massless link 2": lambda d: without(d, links=[1]),
    "massless links 1 and 2": lambda d: without(d, links=[0, 1]),
    "massless rods": lambda d: without(d, links=[2]),
    "massless legs": lambda d: without(d, links=[0, 1, 2]),
    "massless platform": lambda d: without(d, platform=True),
    "point-mass crosses": lambda d: with_links(d, 0, point_mass),
    "point-mass rods": lambda d: with_links(d, 2, point_mass),
    "thin-rod rods": lambda d: with_links(d, 2, thin_rod),
    "point-mass platform": lambda d: d.replace(platform_inertia=point_mass(d.platform_inertia)),
    "flat-plate platform": lambda d: d.replace(platform_inertia=flat_plate(d.platform_inertia)),
}


@pytest.mark.parametrize("case", sorted(DEGENERATE))
def test_degenerate_bodies_load_with_accurate_accelerations(case):
    """Every kind of body MuJoCo refuses as described (no mass, or a vanishing principal
    moment about the centre of mass, or principal moments at the triangle inequality)
    exports loadably, silently (the changes are exact or negligible), and accurately."""
    desc = DEGENERATE[case](preset("paper"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ApproximationWarning)
        xml = mjcf_string(desc)
    check_accelerations(desc, n=3, seed=9, xml=xml)


def test_flat_platform_loads_at_any_orientation():
    """MuJoCo refuses about a third of randomly turned flat plates as described."""
    desc = preset("desktop")
    rng = np.random.default_rng(4)
    for _ in range(30):
        plate = flat_plate(desc.platform_inertia, rng.uniform(-np.pi, np.pi, 3))
        mujoco.MjModel.from_xml_string(mjcf_string(desc.replace(platform_inertia=plate)))


def described(desc, inertials) -> object:
    """The description with the MuJoCo layout's inertials (a link without a body massless)."""
    return desc.replace(leg_inertia=inertials.leg, platform_inertia=inertials.platform)


@pytest.mark.parametrize(
    "case", ["massless links 1 and 2", "light rods", "massless platform", "point-mass rods"]
)
def test_mujoco_inertials_keep_the_closed_loop_dynamics(case):
    """The changes ``mujoco_inertials`` calls exact leave the direct model's accelerations
    as they are (1e-12); the approximate ones (raised principal moments) change them by
    less than 1e-8, far below MuJoCo's own accuracy."""
    desc = preset("paper")
    if case == "light rods":  # 1/1000 of the platform's mass per leg: a point mass moves in
        leg = desc.leg_inertia.copy()
        leg[:, 2] *= 1e-3 * desc.platform_inertia[9] / 6 / leg[:, 2, 9, None]
        desc = desc.replace(leg_inertia=leg)
    else:
        desc = DEGENERATE[case](desc)
    inertials = mujoco_inertials(desc)
    assert inertials.doubtful == ()
    robot, changed = StewartRobot(desc), StewartRobot(described(desc, inertials))
    poses, twists, accels = sample_states(desc, 4, 2)
    gammas = robot.inverse_dynamics(poses, twists, accels)
    A, A_changed = (
        robot.direct_dynamics(poses, twists, gammas),
        changed.direct_dynamics(poses, twists, gammas),
    )
    error = np.abs(A_changed - A).max() / np.abs(A).max()
    if inertials.approximate:
        assert case in ("massless platform", "point-mass rods")
        assert error < 1e-8
    else:
        assert inertials.exact and error < 1e-12
    if case == "light rods":  # the platform gave each rod a point mass at P_i
        assert inertials.leg[0, 2, 9] > 10 * desc.leg_inertia[0, 2, 9]
        assert inertials.platform[9] < desc.platform_inertia[9]


def test_tiny_robot_loads_with_a_warning():
    """A centimetre-scale copy of the desktop robot (masses scaled by 1e-6): its links'
    principal moments fall below MuJoCo's bounds, which the MJCF raises, with a warning
    naming the bodies."""
    desc, s = preset("desktop"), 1e-2
    scale = np.r_[np.full(6, s**5), np.full(3, s**4), s**3]  # moments, first moments, mass
    T = desc.home_pose.copy()
    T[:3, 3] *= s
    tiny = desc.replace(
        base_points=desc.base_points * s,
        platform_points=desc.platform_points * s,
        stroke=desc.stroke * s,
        home_pose=T,
        leg_inertia=desc.leg_inertia * scale,
        platform_inertia=desc.platform_inertia * scale,
    )
    with pytest.warns(ApproximationWarning, match="leg 1 link 1: mass"):
        xml = mjcf_string(tiny)
    mujoco.MjModel.from_xml_string(xml)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ApproximationWarning)
        mjcf_string(tiny, pinocchio_layout=True)  # Pinocchio takes it as described
