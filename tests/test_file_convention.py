"""A robot imported from a model file speaks that file's joint convention (issue 21, item 3).

Files: the project's presets written by its MJCF writer, then edited the way hand-written
models are (``convention_models.rezeroed``): inverted slides with ``ref`` offsets and
every hinge axis flipped (the ideal 6-UPS), every joint of offset-U legs with a ``ref``
offset and flipped, RUS cranks zeroed at home, turned round, given a CAD export's
full-turn range (revolute actuators whose angles the file gives in ``[0, 2 pi)``).

Independent reference: MuJoCo's own model of each edited file. Its ``qpos`` / ``qvel`` of
the actuated joints at loop-consistent states put together by MuJoCo's constraint
residuals (``helpers.mujoco_closed_state``), its exact KKT solve
(``helpers.mujoco_kkt``): the actuator forces of an acceleration, the acceleration of
actuator forces, and (both being affine) their exact differences for the derivatives.
The robot's actuator positions, rates, efforts in and out, regressor, derivatives,
simulation, controller, planner, log identification and command line must be MuJoCo's
numbers on the file, sign and zero included.
"""

from __future__ import annotations

import math
import pickle
import shutil
import subprocess

import numpy as np
import pytest
from convention_models import rezeroed
from helpers import mujoco_closed_state, mujoco_kkt, rel_error
from test_import_conventions import LEG_JOINTS, _import, _xml
from test_import_mjcf import states

from stewart_pin import InputError, StewartRobot
from stewart_pin.description.actuator_convention import ActuatorConvention
from stewart_pin.dynamics.regressor import standard_parameters

mujoco = pytest.importorskip("mujoco")

CRANKS = {f"leg{i}_q1" for i in range(1, 7)}
#: name -> (preset, rezeroed options, workspace ranges around home [m, rad])
FILES = {
    # inverted slides with ref offsets, every hinge flipped: the ideal 6-UPS
    "ups": (
        "simulator",
        {"mode": {n: "ref" for n in LEG_JOINTS if n.endswith("q3")}, "flip": set(LEG_JOINTS)},
        (0.05, 0.05),
    ),
    # every joint with a ref offset and flipped: offset-U legs (the leg chains' path)
    "ups-offset": (
        "ups-offset",
        {"mode": dict.fromkeys(LEG_JOINTS, "ref"), "flip": set(LEG_JOINTS)},
        (0.01, 0.05),
    ),
    # cranks zeroed at home, turned round, with a CAD export's full-turn range: the crank
    # axis and zero are the RUS description's own, the angles given in [0, 2 pi)
    "rus": (
        "rus",
        {"mode": dict.fromkeys(CRANKS, "baked"), "flip": CRANKS, "full_turn": CRANKS},
        (0.003, 0.03),
    ),
}


class FileCase:
    """An edited file, its MuJoCo model, the imported robot and MuJoCo states."""

    def __init__(self, name: str):
        self.name = name
        preset_name, options, ranges = FILES[name]
        self.xml = rezeroed(_xml(preset_name), **options)
        self.m = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.m)
        assert np.all(self.m.actuator_gear[:, 0] == 1.0)  # joint side = actuator side
        self.robot = _import(self.xml)
        src = self.robot.description.source
        self.platform = src.platform
        self.joints = [self.m.actuator_trnid[self.m.actuator(leg.actuator).id, 0]
                       for leg in src.legs]  # fmt: skip
        self.qadr = np.array([self.m.jnt_qposadr[j] for j in self.joints])
        self.dadr = np.array([self.m.jnt_dofadr[j] for j in self.joints])
        self.revolute = self.m.jnt_type[self.joints] == mujoco.mjtJoint.mjJNT_HINGE
        self.states = states(self.robot, ranges, 2, seed=11)

    def at(self, T, V) -> None:
        """MuJoCo's data at the loop-consistent state of platform pose ``T``, twist ``V``."""
        home = self.m.key_qpos[0] if self.m.nkey else self.m.qpos0
        mujoco_closed_state(self.m, self.data, self.platform, T, V, guess=home)

    def kkt(self, A=None, gamma=None) -> np.ndarray:
        return mujoco_kkt(self.m, self.data, self.platform, A=A, gamma=gamma)


@pytest.fixture(scope="module", params=list(FILES))
def case(request) -> FileCase:
    return FileCase(request.param)


def _wrapped(a, b, revolute) -> np.ndarray:
    d = np.asarray(a) - b
    return np.where(revolute, np.remainder(d + math.pi, 2 * math.pi) - math.pi, d)


def test_the_files_convention_is_not_the_descriptions(case):
    """The edits give actuators against the description's axes and away from its zeros
    (else nothing here could fail); the accessor shows the mapping."""
    conv = case.robot.actuator_convention
    assert conv.name == "file" and not conv.identity
    if case.name == "rus":  # the wrap only: angles in [0, 2 pi)
        assert np.all(conv.wraps == 0.0) and np.all(conv.revolute)
        q = case.robot.actuator_positions([T for T, _, _ in case.states])
        assert np.all((q >= 0.0) & (q < 2 * math.pi)) and np.any(q > math.pi)
    else:
        assert np.all(conv.signs < 0) and np.all(conv.offsets != 0)
        assert "s = -1" in str(conv)
    assert "actuator 6" in str(conv)
    assert case.robot.description_convention().actuator_convention.identity
    back = pickle.loads(pickle.dumps(case.robot))
    assert back.actuator_convention.to_dict() == conv.to_dict()


def test_positions_rates_and_efforts_are_mujocos_on_the_file(case):
    """At MuJoCo's own states: actuator positions = ``qpos``, ``Jp^-1 V`` = ``qvel``, the
    inverse model = the KKT actuator forces (1e-10), the regressor's ``W chi`` too, the
    forward geometry of MuJoCo's ``qpos`` = the pose."""
    robot = case.robot
    chi = standard_parameters(robot.description)
    for T, V, A in case.states:
        case.at(T, V)
        qpos, qvel = case.data.qpos[case.qadr], case.data.qvel[case.dadr]
        assert np.abs(_wrapped(robot.actuator_positions(T), qpos, case.revolute)).max() < 1e-9
        assert rel_error(robot.inverse_jacobian(T) @ V, qvel) < 1e-9
        assert rel_error(np.linalg.solve(robot.jacobian(T), V), qvel) < 1e-9
        gamma_mj = case.kkt(A=A)
        gamma = robot.inverse_dynamics(T, V, A)
        assert rel_error(gamma, gamma_mj) < 1e-10, f"IDM {rel_error(gamma, gamma_mj):.2e}"
        assert rel_error(robot.regressor(T, V, A) @ chi, gamma_mj) < 1e-9
        pose = robot.forward_geometry(qpos, robot.home_pose)
        assert np.abs(pose - T).max() < 1e-9
        case.at(T, np.zeros(6))
        assert rel_error(robot.gravity_compensation(T), case.kkt(A=np.zeros(6))) < 1e-10
    # batches: the same conversion row by row
    Ts, Vs, As = (np.array(x) for x in zip(*case.states, strict=True))
    np.testing.assert_allclose(
        robot.inverse_dynamics(Ts, Vs, As),
        [robot.inverse_dynamics(T, V, A) for T, V, A in case.states],
        rtol=1e-13,
        atol=0,
    )
    # the description's convention: the same efforts, the file's signs undone
    desc = robot.description_convention()
    T, V, A = case.states[0]
    np.testing.assert_allclose(
        desc.inverse_dynamics(T, V, A) * robot.actuator_convention.signs,
        robot.inverse_dynamics(T, V, A),
        rtol=1e-14,
    )


def test_direct_model_and_simulation_take_the_files_efforts(case):
    """Efforts in the file's convention: the direct model, and a simulation holding them,
    give MuJoCo's KKT acceleration at t = 0 (1e-9); the simulation records them and the
    file's positions; ``direct(inverse(A)) = A``."""
    from stewart_pin import simulate

    robot = case.robot
    T, V, A = case.states[0]
    assert rel_error(robot.direct_dynamics(T, V, robot.inverse_dynamics(T, V, A)), A) < 1e-9
    case.at(T, V)
    gamma = case.kkt(A=A) * np.linspace(0.8, 1.2, 6)  # the file's efforts, not a model's
    accel_mj = case.kkt(gamma=gamma)
    assert rel_error(robot.direct_dynamics(T, V, gamma), accel_mj) < 1e-9
    run = simulate(robot, 1e-3, T, V, forces=lambda t, T, V: gamma, dt=1e-3, backend="pinocchio")
    assert rel_error(run.accels[0], accel_mj) < 1e-9
    np.testing.assert_array_equal(run.gammas[0], gamma)
    qpos = case.data.qpos[case.qadr]
    assert np.abs(_wrapped(run.lengths[0], qpos, case.revolute)).max() < 1e-9


def test_computed_torque_commands_the_files_efforts(case):
    """The computed-torque controller on the imported robot, on its reference: MuJoCo's
    KKT forces of the reference acceleration."""
    from stewart_pin.motion.control import ComputedTorqueController

    T, V, A = case.states[1]
    ctc = ComputedTorqueController(case.robot, lambda t: (T, V, A), backend="pinocchio")
    case.at(T, V)
    assert rel_error(ctc(0.0, T, V), case.kkt(A=A)) < 1e-10


@pytest.mark.parametrize("name", ["ups", "ups-offset"])  # signed (RUS: the wrap only)
def test_derivatives_are_mujocos_exact_differences(name, monkeypatch):
    """``dGamma/dVdot`` and ``dVdot/dGamma`` in the file's convention: the IDM is affine in
    the acceleration and the DDM in the efforts, so MuJoCo's KKT differences are exact
    (CasADi's virtual machine: nothing compiled)."""
    import warnings

    import stewart_pin.robot as robot_module
    from stewart_pin.codegen.derivatives import CompiledDerivatives

    case = FileCase(name)
    robot = case.robot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        vm = CompiledDerivatives(robot, compiler=False)
    monkeypatch.setattr(robot_module, "_derivatives", lambda r: vm)
    T, V, A = case.states[0]
    case.at(T, V)
    g0 = case.kkt(A=A)
    d = robot.inverse_dynamics_derivatives(T, V, A)
    assert rel_error(d.gamma, g0) < 1e-10
    by_accel = np.column_stack([case.kkt(A=A + e) - g0 for e in np.eye(6)])
    assert rel_error(d.accel, by_accel) < 1e-8
    a0 = case.kkt(gamma=g0)
    dd = robot.direct_dynamics_derivatives(T, V, g0)
    assert rel_error(dd.accel, a0) < 1e-9
    scale = np.abs(g0).max()
    by_gamma = np.column_stack([(case.kkt(gamma=g0 + scale * e) - a0) / scale for e in np.eye(6)])
    assert rel_error(dd.gamma, by_gamma) < 1e-8


def test_identity_and_bad_convention():
    """A robot not imported converts nothing; a convention that is neither is refused."""
    robot = StewartRobot.from_preset("simulator")
    assert robot.actuator_convention.identity
    assert robot.description_convention() is robot
    np.testing.assert_array_equal(robot.actuator_limits, [[2.0, 2.8]] * 6)
    with pytest.raises(InputError, match="convention must be one of"):
        StewartRobot(robot.description, convention="mujoco")
    with pytest.raises(InputError, match="convention must be one of"):
        ActuatorConvention.of(robot.description, "")


@pytest.fixture(scope="module")
def ups() -> FileCase:
    return FileCase("ups")


def test_the_planner_gives_the_files_efforts_positions_and_rates(ups):
    """An optimal motion on the imported 6-UPS: at its nodes, the efforts (held and exact)
    are MuJoCo's KKT forces of the nodes' accelerations, the positions and rates MuJoCo's
    ``qpos`` and ``qvel``, within the bounds it reports."""
    from stewart_pin.planning.point_to_point import optimal_point_to_point

    robot = ups.robot
    goal = robot.home_pose
    goal[:3, 3] += [0.02, -0.01, 0.03]
    motion = optimal_point_to_point(robot, robot.home_pose, goal, 0.5, intervals=6)
    lo, hi = motion.actuator_bounds.T
    assert np.all((motion.leg_lengths >= lo - 1e-9) & (motion.leg_lengths <= hi + 1e-9))
    assert np.all(motion.leg_lengths < 0)  # the file's inverted slides
    for k in (1, 4):
        ups.at(motion.poses[k], motion.twists[k])
        kkt = ups.kkt(A=motion.accels[k])
        assert rel_error(motion.gammas[k], kkt) < 1e-8
        assert rel_error(motion.exact_efforts[k], kkt) < 1e-8
        assert np.abs(motion.leg_lengths[k] - ups.data.qpos[ups.qadr]).max() < 1e-9
        assert rel_error(motion.actuator_speeds[k], ups.data.qvel[ups.dadr]) < 1e-8


def test_identification_from_a_log_in_the_files_convention(ups):
    """A log of the file's actuator positions and efforts (MuJoCo's, checked at its first
    sample): its decimated equations on the imported robot hold the true base parameters
    (to 1e-6 of the efforts), and it identifies; read in the description's convention,
    the same log is outside the strokes."""
    from stewart_pin import LogLimitError
    from stewart_pin.motion.trajectories import FourierTrajectory
    from stewart_pin.parameters.base import base_parameters
    from stewart_pin.parameters.identification import identify_log, log_equations
    from stewart_pin.parameters.logs import ActuatorLog
    from stewart_pin.parameters.state_estimation import design_filters

    robot = ups.robot
    desc = robot.description_convention()
    rng = np.random.default_rng(3)
    amp = np.array([0.05 * robot.description.size] * 3 + [0.05] * 3)[:, None]
    motion = FourierTrajectory(
        robot.home_pose, 0.5, np.zeros(6), rng.uniform(-1, 1, (6, 4)) * amp / 4,
        rng.uniform(-1, 1, (6, 4)) * amp / 4,
    )  # fmt: skip
    t = np.arange(1200) / 200.0
    s = motion.sample(t)
    # the file's values by the importer's record of its joints (description.source)
    source = robot.description.source
    positions = source.file_actuator_positions(
        desc.actuator_positions(s.poses), [3] * 6, [False] * 6
    )
    efforts = source.file_efforts(desc.inverse_dynamics(s.poses, s.twists, s.accels), [3] * 6)
    ups.at(s.poses[0], s.twists[0])
    assert np.abs(positions[0] - ups.data.qpos[ups.qadr]).max() < 1e-9
    assert rel_error(efforts[0], ups.kkt(A=s.accels[0])) < 1e-10
    log = ActuatorLog(t, positions, efforts)
    base = base_parameters(robot)
    design = design_filters(log)
    r = np.concatenate(
        [g - W @ base.values for _, W, g, _ in log_equations(robot, log, base, design)]
    )  # the decimated equations hold the true parameters (filters and differences only)
    assert np.sqrt(np.mean(r**2)) <= 1e-6 * np.sqrt(np.mean(efforts**2))
    result = identify_log(robot, log, base).result
    assert result.n_samples > 0 and np.all(np.isfinite(result.estimate))
    with pytest.raises(LogLimitError, match="outside"):
        identify_log(desc, log, base)


def test_the_command_line_with_a_model_speaks_the_file(ups, tmp_path, capsys):
    """``--model``: ``ik`` prints the file's joint values (MuJoCo's ``qpos`` at home),
    ``idm`` writes the file's efforts (MuJoCo's KKT), ``validate`` passes."""
    from stewart_pin.cli import main
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv, state_table, write_csv

    path = tmp_path / "hexapod.xml"
    path.write_text(ups.xml)
    assert main(["ik", "--model", str(path)]) == 0
    text = capsys.readouterr().out
    assert "the model file's convention (its zeros and directions)" in text
    rows = [line.split() for line in text.splitlines() if line[:3].strip() in list("123456")]
    got = np.array([[float(x) for x in row[1:4]] for row in rows[:6]])
    home = ups.m.key_qpos[0]
    src = ups.robot.description.source
    qpos = np.array([[home[ups.m.joint(n).qposadr[0]] for n in leg.joints] for leg in src.legs])
    np.testing.assert_allclose(got, qpos, atol=2e-6)  # printed to 6 decimals

    T, V, A = ups.states[0]
    states = write_csv(tmp_path / "s.csv", STATE_COLUMNS, state_table(np.zeros(1), T[None],
                       V[None], A[None]))  # fmt: skip
    out = tmp_path / "forces.csv"
    assert main(["idm", "--model", str(path), "--trajectory", str(states), "-o", str(out)]) == 0
    gamma = read_csv(out, ("t", *(f"gamma{i}" for i in range(1, 7))))[0, 1:]
    ups.at(T, V)
    assert rel_error(gamma, ups.kkt(A=A)) < 1e-10
    capsys.readouterr()
    assert main(["validate", "--model", str(path), "--states", "4"]) == 0
    assert "PASSED" in capsys.readouterr().out


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
@pytest.mark.parametrize("name", ["ups", "rus"])
def test_c_export_speaks_the_files_convention(name, tmp_path):
    """The exported C speaks the file's convention: its test program (built -O0, quick)
    checks every function, the derivatives included, against the robot's values, which
    are MuJoCo's here (the first state checked again below); its README gives each
    actuator's sign and offset."""
    case = FileCase(name)
    robot = case.robot
    paths = robot.export_c(tmp_path, "hexa", samples=2, derivatives=name == "ups")
    readme = (tmp_path / "README.md").read_text()
    conv = robot.actuator_convention
    for i in range(6):
        wrap = f"{float(conv.wraps[i])!r}" if conv.revolute[i] else "-"
        row = f"| {i + 1} | {conv.signs[i]:+.0f} | {float(conv.offsets[i])!r} | {wrap} |"
        assert row in readme
    build = subprocess.run(
        ["gcc", "-std=c99", "-O0", "hexa.c", "hexa_test.c", "-lm", "-o", "check"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert build.returncode == 0, build.stderr
    run = subprocess.run(["./check"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and "passed: 0 failure(s)" in run.stdout, run.stdout
    from stewart_pin.codegen.c_export import reference_values

    values = reference_values(robot, 2, 0, derivatives=False)  # what the program checks
    T, V, A = values["poses"][0].reshape(4, 4), values["twists"][0], values["accels"][0]
    case.at(T, V)
    qpos = case.data.qpos[case.qadr]
    assert np.abs(_wrapped(values["ref_q"][0], qpos, case.revolute)).max() < 1e-9
    assert rel_error(values["ref_gamma"][0], case.kkt(A=A)) < 1e-10
    assert len(paths) == 8


def test_bad_efforts_and_positions_of_an_imported_robot_are_named(ups):
    """The conversion checks what it converts, with the models' own errors."""
    robot = ups.robot
    T, V, _ = ups.states[0]
    for bad, match in (([1.0] * 5, "gamma"), ([True] + [1.0] * 5, "boolean"),
                       ([1j] + [1.0] * 5, "gamma")):  # fmt: skip
        with pytest.raises(InputError, match=match):
            robot.direct_dynamics(T, V, bad)
    with pytest.raises(InputError, match="gamma must be a batch"):
        robot.direct_dynamics(T[None], V[None], np.zeros(6))
    with pytest.raises(InputError, match="lengths"):
        robot.forward_geometry([2.0] * 5)
