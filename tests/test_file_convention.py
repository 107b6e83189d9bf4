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


def test_derivatives_are_mujocos_exact_differences(case, monkeypatch):
    """``dGamma/dVdot`` and ``dVdot/dGamma`` in the file's convention: the IDM is affine in
    the acceleration and the DDM in the efforts, so MuJoCo's KKT differences are exact
    (CasADi's virtual machine: nothing compiled)."""
    import warnings

    import stewart_pin.robot as robot_module
    from stewart_pin.codegen.derivatives import CompiledDerivatives

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
