"""Every feature on every leg architecture (issue 19, item 3): the paper's 6-UPS
(``simulator``), offset U-joints (``ups-offset``), cranks (``rus``), slides (``pus``), a
random ``custom`` robot (Newton's inverse geometry) and a ``mixed`` one (legs 1-3 PUS,
4-6 custom).

Independent references: Pinocchio's constrained dynamics on the robot's own closed-loop
tree (``pin.constraintDynamics``, the check module's KKT), Pinocchio's forward
kinematics on the leg models, MuJoCo's model of the written MJCF in an exact KKT solve
(tests/helpers.py), forward-after-inverse geometry round trips and the whole constrained
tree of a robot carrying a payload (:mod:`stewart_pin.check.payload`). The planner is in
test_point_to_point.py, the derivatives in test_derivatives.py, identification from
states, ``bench --preset`` and ``simulate --model-error`` on the command line below.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_robot
from helpers import leg_lengths_by_hand, mujoco_kkt, mujoco_set_loop_state

from stewart_pin import StewartRobot
from stewart_pin.check import payload as check_payload
from stewart_pin.check.constrained_dynamics import (
    constrained_forward_dynamics,
    constrained_inverse_dynamics,
    relative_error,
    tree_state,
)
from stewart_pin.check.constrained_dynamics import energy as check_energy
from stewart_pin.check.leg_chain_tree import GeneralTreeSolver
from stewart_pin.cli import main
from stewart_pin.formats.mjcf import mujoco_qpos
from stewart_pin.models.payload import load_payload
from stewart_pin.models.pinocchio_models import load_tree

#: The architectures (robots by :func:`robot_of`).
ARCHITECTURES = ("simulator", "ups-offset", "rus", "pus", "random-custom-0", "mixed")
TOL = 1e-9

_ROBOTS: dict[str, StewartRobot] = {}


def robot_of(name: str) -> StewartRobot:
    """A shared robot of each architecture; ``mixed``: ``random-pus-4`` with legs 4-6
    declared ``custom`` (the same chains, Newton's inverse geometry on those)."""
    if name not in _ROBOTS:
        if name == "mixed":
            desc = get_robot("random-pus-4").description
            legs = tuple(
                leg if k < 3 else leg.replace(name="custom") for k, leg in enumerate(desc.legs)
            )
            _ROBOTS[name] = StewartRobot(desc.replace(legs=legs))
        else:
            _ROBOTS[name] = get_robot(name)
    return _ROBOTS[name]


def test_the_architectures_are_the_ones_named():
    kinds = {name: robot_of(name).architecture for name in ARCHITECTURES}
    assert kinds == {
        "simulator": "ups",
        "ups-offset": "ups-offset",
        "rus": "rus",
        "pus": "pus",
        "random-custom-0": "custom",
        "mixed": "mixed",
    }


def _tree_accelerations(robot: StewartRobot, P, V, G) -> np.ndarray:
    """``pin.constraintDynamics`` on ``robot.tree`` (general legs: with the joint terms
    of the check module's solver, fed that tree)."""
    if robot.is_ideal_ups:  # the check's TreeSolver is built on robot.tree
        return constrained_forward_dynamics(robot, P, V, G)
    solver = GeneralTreeSolver(robot.general, robot.tree)
    q_legs = robot.inverse_geometry(P, check_limits=False)
    return np.array([solver.forward_one(*s) for s in zip(P, V, G, q_legs, strict=True)])


# ---------------------------------------------------------------------------- the tree
@pytest.mark.parametrize("name", ARCHITECTURES)
def test_the_tree_closes_the_loops_and_gives_the_direct_model(name):
    """``robot.tree`` on every robot: 24 dof, six loop closures that the tree states of
    the inverse geometry close (Pinocchio's forward kinematics), and its constrained
    dynamics equal the reference direct model."""
    robot = robot_of(name)
    tree = robot.tree
    assert (tree.model.nq, tree.model.nv, len(tree.constraints)) == (25, 24, 6)
    assert np.asarray(tree.actuated_v_index).shape == (6,)
    P, V, A = robot.sample_states(3, 7)
    q, v = tree_state(robot, P, V)
    data = tree.model.createData()
    for n in range(3):
        pin.forwardKinematics(tree.model, data, q[n], v[n])
        for cm in tree.constraints:
            p1 = data.oMi[cm.joint1_id] * cm.joint1_placement
            p2 = data.oMi[cm.joint2_id] * cm.joint2_placement
            assert np.abs(p1.translation - p2.translation).max() < 1e-9 * robot.description.size
    G = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    assert relative_error(_tree_accelerations(robot, P, V, G), A) < 1e-8


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_the_checks_inverse_model_balances_the_platform(name):
    """``constrained_inverse_dynamics`` on every robot: the reference Gamma, and leg
    forces on the platform that satisfy its Newton equation ``sum f_i + m g = m a_G``
    (``a_G`` the classical acceleration of its centre of mass); the check's energy is the
    facade's."""
    robot = robot_of(name)
    P, V, A = robot.sample_states(3, 9)
    gamma, forces = constrained_inverse_dynamics(robot, P, V, A)
    assert relative_error(gamma, robot.inverse_dynamics(P, V, A, backend="pinocchio")) < TOL
    chi = robot.description.platform_inertia
    m, c = chi[9], chi[6:9] / chi[9]
    g = robot.description.gravity
    for n in range(3):
        c0 = P[n][:3, :3] @ c
        w, wd = V[n][3:], A[n][3:]
        a_G = A[n][:3] + np.cross(wd, c0) + np.cross(w, np.cross(w, c0))
        np.testing.assert_allclose(
            forces[n].sum(axis=0), m * (a_G - g), rtol=1e-9, atol=1e-9 * m * np.abs(g).max()
        )
    kinetic, potential = check_energy(robot, P, V)
    np.testing.assert_allclose(kinetic + potential, robot.energy(P, V), rtol=1e-10)


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_leg_models_put_each_tip_at_its_platform_point(name):
    """``robot.leg_models``: Pinocchio's forward kinematics of leg i at the inverse
    geometry puts its tip at P_i; ``robot.legs_model`` holds the same six chains (its
    mass matrix is theirs, block by block)."""
    robot = robot_of(name)
    T = robot.sample_states(1, 3)[0][0]
    q = robot.inverse_geometry(T, check_limits=False)
    P_i = robot.description.platform_points @ T[:3, :3].T + T[:3, 3]
    legs, index = robot.legs_model
    q18 = np.empty(18)
    q18[np.asarray(index).ravel()] = q.ravel()
    M = pin.crba(legs, legs.createData(), q18)
    for k, model in enumerate(robot.leg_models):
        tip = f"leg{k + 1}_tip" if model.existFrame(f"leg{k + 1}_tip") else f"leg{k + 1}_link3"
        data = model.createData()
        pin.framesForwardKinematics(model, data, q[k])
        np.testing.assert_allclose(data.oMf[model.getFrameId(tip)].translation, P_i[k], atol=1e-12)
        M_k = pin.crba(model, data, q[k])
        np.testing.assert_allclose(M[np.ix_(index[k], index[k])], M_k, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("name", ARCHITECTURES)
def test_leg_lengths_are_the_actuator_positions_and_forward_geometry_inverts_them(name):
    robot = robot_of(name)
    P, _, _ = robot.sample_states(4, 11)
    q_a = robot.leg_lengths(P)
    np.testing.assert_array_equal(q_a, robot.actuator_positions(P))
    q = robot.inverse_geometry(P, check_limits=False)
    actuated = [leg.actuated - 1 for leg in robot.general.legs]
    np.testing.assert_allclose(q_a, q[:, np.arange(6), actuated], rtol=0, atol=1e-12)
    if name == "simulator":  # the 6-UPS's name says what they are: |B_i P_i|
        expected = np.array([leg_lengths_by_hand(robot.description, T) for T in P])
        np.testing.assert_allclose(q_a, expected, rtol=0, atol=1e-12)
    for n in range(len(P)):  # Newton from a guess 0.5 % of the mid-stroke and 5 mrad off
        guess = P[n].copy()
        guess[:3, 3] += 0.005 * robot.description.stroke_mid * np.array([1.0, -1.0, 0.5])
        guess[:3, :3] = pin.exp3(np.array([0.005, 0.0, -0.0025])) @ guess[:3, :3]
        back = robot.forward_geometry(q_a[n], guess=guess)
        np.testing.assert_allclose(back, P[n], rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------- files
try:
    import mujoco
except ImportError:  # pragma: no cover - MuJoCo is a test extra
    mujoco = None


@pytest.mark.skipif(mujoco is None, reason="MuJoCo is optional: pip install mujoco")
@pytest.mark.parametrize("name", ARCHITECTURES)
def test_write_mjcf_on_the_facade_gives_mujoco_the_same_forces(name, tmp_path):
    """``robot.write_mjcf``: MuJoCo's own model of the file (mass matrix, bias, passive
    forces, loop rows) in an exact KKT solve gives the reference inverse model's
    forces."""
    robot = robot_of(name)
    path = robot.write_mjcf(tmp_path / "robot.xml")
    assert path.read_text() == robot.mjcf()
    m = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(m)
    P, V, A = robot.sample_states(3, 5)
    expected = robot.inverse_dynamics(P, V, A, backend="pinocchio")
    for n in range(3):
        mujoco_set_loop_state(m, data, mujoco_qpos(robot.description, P[n]), P[n], V[n])
        got = mujoco_kkt(m, data, "platform", A=A[n])
        assert relative_error(got, expected[n]) < 1e-8


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_write_urdf_and_xacro_on_the_facade(name, tmp_path):
    """The URDF and its sidecar load back as a 24-dof tree with six closures and the
    legs' armatures; the xacro arguments name the source that renders them."""
    robot = robot_of(name)
    urdf, sidecar = robot.write_urdf(tmp_path / "robot.urdf")
    assert sidecar.exists() and urdf.read_text() == robot.urdf()
    tree = load_tree(urdf)
    assert (tree.model.nq, len(tree.constraints)) == (25, 6)
    armature = [j.dynamics.total_armature for leg in robot.general.legs for j in leg.joints]
    assert float(tree.model.armature.sum()) == pytest.approx(sum(armature), rel=1e-12, abs=0)
    args = robot.write_xacro_args(tmp_path / "robot.yaml").read_text()
    source = "stewart.urdf.xacro" if robot.is_ideal_ups else "stewart_general.urdf.xacro"
    assert f"models/urdf/{source}" in args


# ---------------------------------------------------------------------------- payload
def _stick() -> pin.Model:
    """A one-joint payload: a 1.5 kg link on a hinge about y, centre of mass off the axis."""
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "hinge")
    inertia = pin.Inertia(1.5, np.array([0.04, 0.01, 0.08]), np.diag([0.01, 0.02, 0.015]))
    model.appendBodyToJoint(j, inertia, pin.SE3.Identity())
    return model


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_the_payload_robot_equals_the_whole_constrained_tree(name):
    robot = robot_of(name).with_payload(load_payload(_stick()))
    P, V, A, q, qd, qdd = robot.sample_states(3, 2)
    solver = check_payload.PayloadTreeSolver(robot.robot, robot.payload)
    gamma_ref, tau_ref = check_payload.reference_inverse_dynamics(solver, P, V, A, q, qd, qdd)
    gamma, tau = robot.inverse_dynamics(P, V, A, q, qd, qdd)
    assert relative_error(gamma, gamma_ref) < TOL and relative_error(tau, tau_ref) < TOL
    out = robot.direct_dynamics(P, V, gamma_ref, q, qd, tau=tau_ref)
    assert relative_error(out.accel, A) < 1e-8 and relative_error(out.qdd, qdd) < 1e-8


# ---------------------------------------------------------------------------- command line
def test_identify_from_states_on_general_legs(tmp_path, capsys, monkeypatch):
    """``identify`` on a 6-PUS from simulated states: the identified model predicts the
    forces of a fresh trajectory within a few times the noise (the report's own
    validation, against the reference inverse model's noisy forces)."""
    monkeypatch.chdir(tmp_path)
    assert main(["identify", "--preset", "pus", "--evaluations", "0"]) == 0
    out = capsys.readouterr().out
    found = re.search(r"force error ([0-9.e+-]+) % \(the noise alone: ([0-9.e+-]+) %\)", out)
    assert found is not None
    error, noise = float(found[1]), float(found[2])
    assert error < 10 * noise
    assert (tmp_path / "pus_measurements.csv").exists()


def test_identify_on_custom_legs_takes_the_numerical_base_set(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = ["identify", "--preset", "random-custom-0", "--evaluations", "0", "--samples", "150"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "identifying the numerical base parameters" in out and "validation on" in out


def test_simulate_with_a_model_error_on_general_legs(tmp_path, capsys):
    """``simulate --model-error``: the controller's model off by 20 %, tracking still
    close; the result file's forces are the reference inverse model's along the motion
    plus what the controller adds (checked: finite, and the run completes)."""
    out = tmp_path / "run.npz"
    args = ["simulate", "--preset", "rus", "--motion", "minimum-jerk", "--duration", "0.2"]
    assert main([*args, "--model-error", "0.2", "-o", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "tracking error" in text and out.exists()
    assert main([*args, "-o", str(tmp_path / "exact.npz"), "--no-progress"]) == 0
    exact = capsys.readouterr().out
    worse = float(text.split("tracking error: max ")[1].split()[0])
    better = float(exact.split("tracking error: max ")[1].split()[0])
    assert worse > better  # the model error shows in the tracking
    from stewart_pin.motion.simulation import SimulationResult

    run = SimulationResult.load(out)
    assert run.t[-1] == pytest.approx(0.2) and np.all(np.isfinite(run.gammas))
    # the forces drive the exact robot along the recorded motion: the reference direct
    # model at the recorded states and forces is the recorded motion's acceleration
    robot = StewartRobot.from_preset("rus")
    k = len(run.t) // 3  # mid-acceleration (at the middle it crosses zero)
    acc = robot.direct_dynamics(run.poses[k], run.twists[k], run.gammas[k], backend="pinocchio")
    dt = run.t[k + 1] - run.t[k - 1]
    fd = (run.twists[k + 1] - run.twists[k - 1]) / dt
    assert np.allclose(acc, fd, rtol=0.05, atol=0.05 * np.abs(fd).max() + 1e-6)


def test_bench_preset_times_a_general_robot(tmp_path, capsys, shared_compile_cache, monkeypatch):
    """``bench --preset rus``: the main table's rows of every path (reference, compiled,
    MuJoCo), the simulation rows and the operation counts of a general robot. The
    sections (payload, first use in a new process, start-up, sampling, batches) are run
    and checked by test_cli.py's JSON test: here they are replaced by a record of the
    preset they are given; the default-backend rows on the cheap ``simulator`` (the
    suite runs the reference path, 1000 calls per single-state row)."""
    import json

    from stewart_pin.apps import bench_sections
    from stewart_pin.codegen import compiled as compiled_module

    monkeypatch.setenv(compiled_module.CACHE_ENV, str(shared_compile_cache))
    given: list[str] = []
    monkeypatch.setattr(
        bench_sections, "bench_sections", lambda preset, *a: given.append(preset) or {}
    )
    path = tmp_path / "bench.json"
    args = ["bench", "--preset", "rus", "--architectures", "simulator", "--quick", "--batch", "20"]
    assert main([*args, "--repeats", "2", "--json", str(path), "--no-progress"]) == 0
    assert given == ["rus"]
    data = json.loads(path.read_text())
    rows = data["median_us_per_state"]
    assert "constrained inverse dynamics (reference path)" in rows
    assert any(k.startswith("compiled IDM single") for k in rows)
    assert "compiled DDM batch 100" in rows
    assert all(t > 0 for t in rows.values())
    assert set(data["operation_counts"]["IDM"]) == {"numeric", "critical_path"}
    sim = data["simulation"]["rus"]["median_us_per_step"]
    assert sim and all(np.isfinite(v) and v > 0 for v in sim.values())
