"""A robot on the platform (issue 15): payloads from example-robot-data, the coupled
inverse and direct models, and their check against the whole constrained tree.

Independent references:

- Pinocchio's constrained dynamics of the WHOLE tree (six legs, platform, payload appended
  with ``pin.appendModel``, six loop closures): ``stewart_pin.check.payload``, which shares
  no algebra with ``stewart_pin.dynamics`` (import-linter's contract);
- a payload held still is a rigid part of the platform: its ten inertial parameters are
  lumped into the platform's *here*, from Pinocchio's forward kinematics of the payload
  model and the spatial inertias of its bodies, and the plain hexapod model (and the
  6-UPS constrained tree without a payload) must give the same efforts and accelerations;
- round trips of the models (DDM after IDM);
- the files of example-robot-data read from disk and counted by Pinocchio.

Tolerances: 1e-9 relative (exact algebra; the observed errors are 1e-15..1e-11, the
larger for the torque-driven direct model of arms with light wrists, whose coupled mass
matrix is ill-conditioned).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import sys
import types

import numpy as np
import pinocchio as pin
import pytest
from conftest import needs_example_robot_data

from stewart_pin import (
    InputError,
    MissingDependencyError,
    PayloadError,
    StewartRobot,
    UnknownPayloadError,
)
from stewart_pin.check import payload as check
from stewart_pin.check.constrained_dynamics import (
    constrained_forward_dynamics,
    constrained_inverse_dynamics,
    relative_error,
)
from stewart_pin.cli import main
from stewart_pin.models import payload as payload_module
from stewart_pin.models.payload import (
    Payload,
    example_robot_names,
    example_robot_urdf,
    load_payload,
)
from stewart_pin.payload_robot import PayloadRobot

TOL = 1e-9


needs_erd = needs_example_robot_data()

#: The hexapods: ideal 6-UPS (simulator) and general legs (rus: cranks; pus: slides).
HEXAPODS = ("simulator", "rus", "pus")
#: The arms of example-robot-data compared with the whole tree.
ARMS = ("ur5", "panda")
#: A tilted, offset mount: T_p_b.
MOUNT = pin.SE3(pin.rpy.rpyToMatrix(0.2, -0.1, 0.4), np.array([0.05, -0.03, 0.02])).homogeneous

_ROBOTS: dict[str, StewartRobot] = {}


def hexapod(name: str) -> StewartRobot:
    if name not in _ROBOTS:
        _ROBOTS[name] = StewartRobot.from_preset(name)
    return _ROBOTS[name]


def arm_on(preset: str, arm: str, placement=MOUNT) -> PayloadRobot:
    return hexapod(preset).with_payload(arm, placement)


def states(robot: PayloadRobot, n: int = 12, seed: int = 3):
    return robot.sample_states(n, seed)


# ---------------------------------------------------------------------------- loading
@needs_erd
def test_example_robot_data_names_locate_the_installed_files():
    names = example_robot_names()
    assert {"ur5", "panda", "so101"} <= set(names)
    dist = importlib.metadata.distribution("example-robot-data")
    installed = {str(dist.locate_file(f)) for f in dist.files or ()}
    for name, nv, file in (("ur5", 6, "ur5_robot.urdf"), ("panda", 9, "panda.urdf")):
        path = example_robot_urdf(name)
        assert path.name == file and str(path) in installed
        assert pin.buildModelFromUrdf(str(path)).nv == nv
        p = load_payload(name)
        assert (p.name, p.nv, p.urdf) == (name, nv, path)
        assert p.visual_model() is not None  # the meshes resolve through package://


@needs_erd
def test_home_is_the_srdf_reference_posture_where_the_arm_has_one():
    """The Panda's home was the middle of its joints' ranges (the elbow and wrist folded
    down towards the platform); example-robot-data's SRDF gives its ready pose, read here
    from the file with the standard library. The UR5's SRDF has no posture: the middle of
    its ranges as before. The sweeps about home stay within the limits."""
    import xml.etree.ElementTree as ET

    from stewart_pin.motion.payload import JointMotion

    panda = load_payload("panda")
    urdf = example_robot_urdf("panda")
    root = ET.parse(urdf.parent.parent / "srdf" / "panda.srdf").getroot()
    state = next(s for s in root.iter("group_state") if s.get("name") == "default")
    values = {j.get("name"): float(j.get("value")) for j in state.iter("joint")}
    q = panda.home_configuration()
    for jid, name in enumerate(panda.model.names[1:], start=1):
        expected = values.get(name, 0.0)  # a joint the state leaves out: neutral
        assert q[panda.model.joints[jid].idx_q] == pytest.approx(expected, abs=1e-12), name
    assert q[3] == pytest.approx(-2.35619) and q[5] == pytest.approx(1.5707)
    ur5 = load_payload("ur5")
    lo, hi = ur5.model.lowerPositionLimit, ur5.model.upperPositionLimit
    np.testing.assert_allclose(ur5.home_configuration(), 0.5 * (lo + hi), atol=1e-15)
    np.testing.assert_allclose(ur5.room(), ur5.half_ranges(), atol=1e-15)
    for p in (panda, ur5, panda.scaled(2.0, 8.0)):
        JointMotion.sweep(p, 1.0, 1.0).check_limits()  # the whole room, both ways


@needs_erd
def test_unknown_payload_name_lists_the_robots():
    with pytest.raises(UnknownPayloadError, match="ur5") as info:
        load_payload("no-such-arm")
    assert info.value.name == "no-such-arm"
    assert "panda" in info.value.available and "ur5" in str(info.value)


def _hide_example_robot_data(monkeypatch, module: types.ModuleType | None = None) -> None:
    """Neither the distribution nor (unless given) the python module is installed."""
    real = importlib.metadata.distribution

    def distribution(name):
        if name == "example-robot-data":
            raise importlib.metadata.PackageNotFoundError(name)
        return real(name)

    monkeypatch.setattr(importlib.metadata, "distribution", distribution)
    if module is None:
        monkeypatch.setitem(sys.modules, "example_robot_data", None)  # import fails
        monkeypatch.setitem(sys.modules, "example_robot_data.robots_loader", None)
    else:
        monkeypatch.setitem(sys.modules, "example_robot_data", types.ModuleType("erd"))
        monkeypatch.setitem(sys.modules, "example_robot_data.robots_loader", module)
    payload_module._library.cache_clear()


@pytest.fixture
def no_cache():
    payload_module._library.cache_clear()
    yield
    payload_module._library.cache_clear()


def test_missing_example_robot_data_says_how_to_install(monkeypatch, no_cache, capsys):
    _hide_example_robot_data(monkeypatch)
    with pytest.raises(MissingDependencyError, match=r'pip install "stewart-pin\[payload\]"'):
        load_payload("ur5")
    with pytest.raises(ImportError):  # a MissingDependencyError is an ImportError too
        example_robot_names()
    assert main(["validate", "--preset", "desktop", "--payload", "ur5", "--states", "2"]) == 2
    err = capsys.readouterr().err
    assert 'pip install "stewart-pin[payload]"' in err and len(err.strip().splitlines()) == 1


URDF = """<robot name="stick">
  <link name="base"><inertial><mass value="1.0"/><origin xyz="0 0 0.01"/>
    <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="0.5"/><origin xyz="0.1 0 0"/>
    <inertia ixx="1e-4" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>
"""


def test_the_python_loader_of_example_robot_data_is_used_when_importable(
    monkeypatch, no_cache, tmp_path
):
    """Without the distribution's file list, the module's ROBOTS table and getModelPath
    (conda, robotpkg installs) give the names and files."""
    (tmp_path / "stick_description" / "urdf").mkdir(parents=True)
    (tmp_path / "stick_description" / "urdf" / "stick.urdf").write_text(URDF)

    class StickLoader:
        path, urdf_subpath, urdf_filename = "stick_description", "urdf", "stick.urdf"

    loader = types.ModuleType("example_robot_data.robots_loader")
    loader.ROBOTS = {"my_stick": StickLoader}
    loader.getModelPath = lambda rel: str(tmp_path)
    _hide_example_robot_data(monkeypatch, loader)
    assert "my_stick" in example_robot_names()
    p = load_payload("my_stick")
    assert (p.nv, p.urdf) == (1, tmp_path / "stick_description" / "urdf" / "stick.urdf")


def test_payload_from_a_urdf_file_and_from_a_model(tmp_path):
    path = tmp_path / "stick.urdf"
    path.write_text(URDF)
    p = load_payload(path, MOUNT)
    assert (p.name, p.nq, p.nv) == ("stick", 1, 1)
    assert p.mass == pytest.approx(1.5, rel=1e-15)
    np.testing.assert_array_equal(p.placement, MOUNT)
    q = load_payload(p.model)
    assert q.model is not p.model and q.nv == 1  # the payload owns a copy
    np.testing.assert_array_equal(q.placement, np.eye(4))


def test_a_floating_base_is_refused(tmp_path):
    path = tmp_path / "stick.urdf"
    path.write_text(URDF)
    floating = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    with pytest.raises(PayloadError, match="fixed base"):
        Payload.from_model(floating)
    with pytest.raises(PayloadError, match="not a file"):
        load_payload(tmp_path / "missing.urdf")
    with pytest.raises(InputError, match="robot name, a URDF path"):
        load_payload(3.0)


def test_a_file_that_is_no_urdf_is_one_message(tmp_path, capfd):
    """Empty, malformed or non-URDF files are refused before Pinocchio's parser, which
    would print its own lines on stderr (the command line must print one)."""
    files = {"empty.urdf": "", "broken.urdf": "<robot name='x'><link", "scene.xml": "<mujoco/>"}
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    with pytest.raises(PayloadError, match="not well-formed XML"):
        load_payload(tmp_path / "empty.urdf")
    with pytest.raises(PayloadError, match="not well-formed XML"):
        load_payload(tmp_path / "broken.urdf")
    with pytest.raises(PayloadError, match=r"root element is <mujoco>, not <robot>"):
        load_payload(tmp_path / "scene.xml")
    capfd.readouterr()
    argv = ["validate", "--preset", "desktop", "--payload", str(tmp_path / "scene.xml")]
    assert main(argv) == 2
    err = capfd.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "not <robot>" in err, err


@needs_erd
def test_scaled_payload_scales_mass_centre_of_mass_and_inertia():
    p = load_payload("so101")
    s = p.scaled(length=2.0, mass=8.0)
    q = p.random_configurations(1, 0)[0]
    data, data_s = p.model.createData(), s.model.createData()
    com = pin.centerOfMass(p.model, data, q)
    com_s = pin.centerOfMass(s.model, data_s, q)
    assert s.mass == pytest.approx(8.0 * p.mass, rel=1e-14)
    np.testing.assert_allclose(com_s, 2.0 * com, rtol=1e-13, atol=1e-15)
    # the joint-space inertia scales by mass * length^2 (no gravity, no velocity)
    M = pin.crba(p.model, data, q)
    M_s = pin.crba(s.model, data_s, q)
    np.testing.assert_allclose(M_s, 32.0 * M, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------------------- the models
def _reference(robot: PayloadRobot, P, V, A, q, qd, qdd):
    solver = check.PayloadTreeSolver(robot.robot, robot.payload)
    gamma, tau = check.reference_inverse_dynamics(solver, P, V, A, q, qd, qdd)
    return solver, gamma, tau


@needs_erd
@pytest.mark.parametrize("preset", HEXAPODS)
@pytest.mark.parametrize("arm", ARMS)
def test_inverse_dynamics_with_a_moving_payload_equals_the_whole_constrained_tree(preset, arm):
    robot = arm_on(preset, arm)
    P, V, A, q, qd, qdd = states(robot)
    _, gamma_ref, tau_ref = _reference(robot, P, V, A, q, qd, qdd)
    gamma, tau = robot.inverse_dynamics(P, V, A, q, qd, qdd)
    assert relative_error(gamma, gamma_ref) < TOL
    assert relative_error(tau, tau_ref) < TOL
    # the payload matters: its share is far above the tolerance
    plain = hexapod(preset).inverse_dynamics(P, V, A)
    assert relative_error(plain, gamma_ref) > 1e-3


@needs_erd
@pytest.mark.parametrize("preset", HEXAPODS)
@pytest.mark.parametrize("arm", ARMS)
def test_direct_dynamics_with_a_moving_payload_equals_the_whole_constrained_tree(preset, arm):
    robot = arm_on(preset, arm)
    P, V, A, q, qd, qdd = states(robot, seed=5)
    solver, gamma_ref, tau_ref = _reference(robot, P, V, A, q, qd, qdd)
    # torque-driven: pin.constraintDynamics on the whole tree
    accel_ref, qdd_ref = check.reference_direct_dynamics(solver, P, V, gamma_ref, q, qd, tau_ref)
    out = robot.direct_dynamics(P, V, gamma_ref, q, qd, tau=tau_ref)
    assert relative_error(out.accel, accel_ref) < TOL
    assert relative_error(out.qdd, qdd_ref) < TOL
    np.testing.assert_array_equal(out.tau, tau_ref)
    # prescribed joint motion: the tree's KKT solve with the joint accelerations given
    accel_pres, tau_pres = check.reference_prescribed_dynamics(solver, P, V, gamma_ref, q, qd, qdd)
    out = robot.direct_dynamics(P, V, gamma_ref, q, qd, qdd)
    assert relative_error(out.accel, accel_pres) < TOL
    assert relative_error(out.tau, tau_pres) < TOL
    # and the reference agrees with itself (its direct models undo its inverse one)
    assert relative_error(accel_ref, A) < TOL and relative_error(accel_pres, A) < TOL


@needs_erd
@pytest.mark.parametrize("preset", ("simulator", "pus"))
def test_ddm_after_idm_returns_the_motion(preset):
    robot = arm_on(preset, "panda")
    P, V, A, q, qd, qdd = states(robot, seed=7)
    gamma, tau = robot.inverse_dynamics(P, V, A, q, qd, qdd)
    out = robot.direct_dynamics(P, V, gamma, q, qd, tau=tau)
    assert relative_error(out.accel, A) < TOL and relative_error(out.qdd, qdd) < TOL
    out = robot.direct_dynamics(P, V, gamma, q, qd, qdd)
    assert relative_error(out.accel, A) < TOL and relative_error(out.tau, tau) < TOL
    # one state in, one state out
    one = robot.inverse_dynamics(P[0], V[0], A[0], q[0], qd[0], qdd[0])
    np.testing.assert_allclose(one.gamma, gamma[0], rtol=1e-13, atol=0)
    back = robot.direct_dynamics(P[0], V[0], one.gamma, q[0], qd[0], tau=one.tau)
    assert back.accel.shape == (6,) and back.qdd.shape == (robot.nv,)


def _lumped_parameters(payload: Payload, q: np.ndarray) -> np.ndarray:
    """The payload at configuration ``q`` as ten inertial parameters of one rigid body in
    Fp, Khalil's order ``XX XY XZ YY YZ ZZ MX MY MZ M`` about O_p (by hand: every body's
    spatial inertia, the welded base's included, carried to Fp and summed)."""
    model = payload.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    T_p_b = pin.SE3(payload.placement)
    total = np.zeros((6, 6))
    for j in range(model.njoints):  # j = 0: the links welded to the base
        total += (T_p_b * data.oMi[j]).act(model.inertias[j]).matrix()
    mass = total[0, 0]
    mc = np.array([total[5, 1], total[3, 2], total[4, 0]])  # [m c]^ in the lower-left block
    I_O = total[3:, 3:]
    return np.array([I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *mc, mass])


@needs_erd
@pytest.mark.parametrize("preset", ("simulator", "rus"))
@pytest.mark.parametrize("arm", ARMS)
def test_a_payload_held_still_is_the_same_payload_lumped_into_the_platform(preset, arm):
    robot = arm_on(preset, arm)
    P, V, A, q, _, _ = states(robot, n=6, seed=11)
    desc = robot.description
    lumped = StewartRobot(
        desc.replace(
            platform_inertia=desc.platform_inertia + _lumped_parameters(robot.payload, q[0]),
            name=f"{desc.name}-lumped",
        )
    )
    q = np.repeat(q[:1], len(P), axis=0)
    zero = np.zeros((len(P), robot.nv))
    gamma, tau = robot.inverse_dynamics(P, V, A, q, zero, zero)
    gamma_lumped = lumped.inverse_dynamics(P, V, A)
    assert relative_error(gamma, gamma_lumped) < TOL
    out = robot.direct_dynamics(P, V, gamma_lumped, q, zero, zero)
    assert relative_error(out.accel, lumped.direct_dynamics(P, V, gamma_lumped)) < TOL
    assert relative_error(out.tau, tau) < TOL  # the torques holding the arm still
    held = robot.direct_dynamics(P, V, gamma_lumped, q, zero, tau=tau)
    assert relative_error(held.accel, out.accel) < TOL
    assert np.abs(held.qdd).max() < TOL * np.abs(held.accel).max()
    if desc.is_ideal_ups:  # the 6-UPS constrained tree of the lumped robot (no payload)
        assert relative_error(gamma, constrained_inverse_dynamics(lumped, P, V, A)[0]) < TOL
        ref = constrained_forward_dynamics(lumped, P, V, gamma_lumped)
        assert relative_error(out.accel, ref) < TOL


@needs_erd
def test_the_payload_wrench_and_shares_add_up():
    robot = arm_on("simulator", "ur5")
    P, V, A, q, qd, qdd = states(robot, n=4)
    d = robot.inverse_dynamics(P, V, A, q, qd, qdd, details=True)
    np.testing.assert_allclose(d.gamma, d.hexapod_gamma + d.payload_gamma, rtol=1e-14)
    np.testing.assert_allclose(d.hexapod_gamma, hexapod("simulator").inverse_dynamics(P, V, A))
    J_inv = hexapod("simulator").inverse_jacobian(P)
    # Jp^-T maps the efforts' payload share back to the payload's wrench on the platform
    np.testing.assert_allclose(
        np.einsum("nji,nj->ni", J_inv, d.payload_gamma), d.wrench, rtol=1e-10, atol=1e-9
    )
    # at rest, the platform holds the arm's weight: -m g at its centre of mass c
    zero6, zero = np.zeros((4, 6)), np.zeros((4, robot.nv))
    w = robot.inverse_dynamics(P, zero6, zero6, q, zero, zero, details=True).wrench
    weight = -robot.payload.mass * robot.description.gravity
    model = robot.payload.model
    data = model.createData()
    for k in range(4):
        # by hand: pin.centerOfMass leaves out the links welded to the base (universe)
        pin.forwardKinematics(model, data, q[k])
        c_b = (
            sum(
                model.inertias[j].mass * data.oMi[j].act(model.inertias[j].lever)
                for j in range(model.njoints)
            )
            / robot.payload.mass
        )
        c_0 = (P[k] @ robot.payload.placement @ np.append(c_b, 1.0))[:3]
        expected = np.concatenate([weight, np.cross(c_0 - P[k][:3, 3], weight)])
        np.testing.assert_allclose(w[k], expected, rtol=0, atol=1e-12 * np.abs(expected).max())


@needs_erd
def test_coupled_mass_matrix_is_symmetric_positive_definite_and_matches_the_tree():
    robot = arm_on("pus", "ur5")
    P, V, _, q, _, _ = states(robot, n=3)
    K = robot.mass_matrix(P, V, q)
    assert K.shape == (3, 6 + robot.nv, 6 + robot.nv)
    np.testing.assert_array_equal(K, np.swapaxes(K, 1, 2))
    assert np.all(np.linalg.eigvalsh(K) > 0)
    # Its columns are the effort/torque increments of unit accelerations (IDM differences)
    zero = np.zeros((3, robot.nv))
    base = robot.inverse_dynamics(P, V, np.zeros((3, 6)), q, zero, zero)
    J_inv = hexapod("pus").inverse_jacobian(P)
    for k in range(6 + robot.nv):
        A = np.zeros((3, 6))
        qdd = np.zeros((3, robot.nv))
        (A if k < 6 else qdd)[:, k if k < 6 else k - 6] = 1.0
        out = robot.inverse_dynamics(P, V, A, q, zero, qdd)
        col = np.concatenate(
            [np.einsum("nji,nj->ni", J_inv, out.gamma - base.gamma), out.tau - base.tau], axis=1
        )
        np.testing.assert_allclose(col, K[:, :, k], rtol=1e-9, atol=1e-9 * np.abs(K).max())


@needs_erd
def test_bad_payload_inputs_are_named():
    robot = arm_on("simulator", "ur5")
    T, z6, z = robot.home_pose, np.zeros(6), np.zeros(6)
    with pytest.raises(InputError, match="exactly one"):
        robot.direct_dynamics(T, z6, z6, z, z)
    with pytest.raises(InputError, match="exactly one"):
        robot.direct_dynamics(T, z6, z6, z, z, z, tau=z)
    with pytest.raises(InputError, match=r"payload qd must have shape \(6,\)"):
        robot.inverse_dynamics(T, z6, z6, z, np.zeros(5), z)
    with pytest.raises(InputError, match="to match the states"):
        robot.inverse_dynamics(T[None], z6[None], z6[None], z, z, z)
    with pytest.raises(InputError, match="non-finite"):
        robot.inverse_dynamics(T, z6, z6, np.full(6, np.nan), z, z)
    with pytest.raises(PayloadError, match="no frame"):
        robot.frame_pose(T, z, "nope")


@needs_erd
def test_continuous_joints_take_unit_cos_sin_pairs():
    robot = arm_on("simulator", "kinova")  # three continuous joints: nq = 9, nv = 6
    assert (robot.nq, robot.nv) == (9, 6)
    q = robot.home_configuration()
    q[0] = 2.0
    with pytest.raises(PayloadError, match="unit norm"):
        robot.gravity_compensation(robot.home_pose, q)
    P, V, A, q, qd, qdd = states(robot, n=4)
    _, gamma_ref, tau_ref = _reference(robot, P, V, A, q, qd, qdd)
    gamma, tau = robot.inverse_dynamics(P, V, A, q, qd, qdd)
    assert relative_error(gamma, gamma_ref) < TOL and relative_error(tau, tau_ref) < TOL


# ---------------------------------------------------------------------------- the check
@needs_erd
def test_validate_payload_report_passes_on_two_arms():
    for arm in ARMS:
        report = check.validate_payload(arm_on("simulator", arm), n_states=8)
        assert report.passed(), str(report)
        assert report.n_states == 8 and "PASSED" in str(report)


@needs_erd
def test_validate_payload_refuses_bad_counts():
    robot = arm_on("simulator", "ur5")
    for bad in (0, 2.5, True, "3", float("nan")):
        with pytest.raises(InputError, match="n_states"):
            check.validate_payload(robot, n_states=bad)
    with pytest.raises(InputError, match="seed"):
        check.validate_payload(robot, n_states=1, seed=-1)


@needs_erd
def test_cli_validate_with_a_payload_exits_0(capsys):
    assert main(["validate", "--preset", "simulator", "--payload", "ur5", "--states", "6"]) == 0
    out = capsys.readouterr().out
    assert "simulator+ur5" in out and "PASSED" in out


@needs_erd
def test_cli_unknown_payload_is_one_line_exit_2(capsys):
    assert main(["validate", "--preset", "desktop", "--payload", "no-such-arm"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no robot 'no-such-arm'" in err and "ur5" in err


@pytest.mark.parametrize(
    "old, new, named",
    [
        ('<mass value="0.5"/>', '<mass value="nan"/>', "<mass> of link 'arm' has value='nan'"),
        ('ixx="1e-4"', 'ixx="inf"', "<inertia> of link 'arm' has ixx='inf'"),
        ('<origin xyz="0 0 0.05"/>', '<origin xyz="0 NaN 0.05"/>',
         "<origin> of joint 'j1' has xyz='0 NaN 0.05'"),
    ],
)  # fmt: skip
def test_non_finite_numbers_of_a_payload_urdf_are_named(tmp_path, capfd, old, new, named):
    """A NaN or an infinity in a payload URDF: a PayloadError naming the element and the
    value (a NaN mass used to load, then fail in Pinocchio's words); one line on the
    command line, exit 2."""
    path = tmp_path / "stick.urdf"
    assert old in URDF
    path.write_text(URDF.replace(old, new))
    with pytest.raises(PayloadError, match="every number must be finite") as info:
        load_payload(path)
    assert named in str(info.value)
    capfd.readouterr()
    assert main(["validate", "--preset", "desktop", "--payload", str(path)]) == 2
    err = capfd.readouterr().err
    assert len(err.strip().splitlines()) == 1 and named in err, err
