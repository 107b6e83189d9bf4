"""General three-joint legs through the description and the facade (issue 11).

References: Pinocchio's constrained tree with ``model.armature`` and the joint torques
(:mod:`stewart_pin.check.leg_chain_tree`, which imports none of the dynamics or the leg
kinematics it checks; it is given the leg joint *positions* of the facade's inverse
geometry and checks with Pinocchio's forward kinematics that they close the loops), and
for the ideal 6-UPS the existing closed-form path.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from stewart_pin import (
    ArchitectureError,
    DescriptionError,
    FileFormatError,
    InputError,
    JointDynamicsError,
    NumericalError,
    RobotDescription,
    StewartRobot,
    UnsupportedArchitectureError,
    preset,
    validate,
)
from stewart_pin.check.constrained_dynamics import relative_error
from stewart_pin.check.leg_chain_tree import (
    GeneralTreeSolver,
    reference_direct_dynamics,
    reference_energy,
    reference_inverse_dynamics,
)
from stewart_pin.cli import main
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.description.leg_chain_hexapod import general_from_description

PRESETS = ("ups-offset", "rus", "pus")
#: Random asymmetric robots with every joint term non-zero (gear and screw transmissions).
RANDOM = ("random-ups-1", "random-ups-offset-2", "random-rus-3", "random-pus-4", "random-custom-5")
TOL = 1e-9  # relative, against the constrained tree


@pytest.fixture(scope="module", params=PRESETS + RANDOM)
def robot(request) -> StewartRobot:
    return StewartRobot.from_preset(request.param)


def _reference(robot: StewartRobot) -> GeneralTreeSolver:
    return GeneralTreeSolver(general_from_description(robot.description))


# ---------------------------------------------------------------------- description
def test_presets_are_general_descriptions():
    for name in PRESETS + RANDOM:
        d = preset(name)
        assert isinstance(d, RobotDescription) and d.name == name
        assert not d.is_ideal_ups and d.stroke is None and d.u_joint_limits is None
        assert len(d.leg_architectures) == 6
    assert preset("rus").architecture == "rus"
    assert preset("random-custom-5").architecture == "custom"
    desktop = preset("desktop")
    assert desktop.is_ideal_ups and desktop.architecture == "ups" and desktop.legs is None
    assert [leg.name for leg in desktop.leg_architectures] == ["ups"] * 6
    lo, hi = desktop.stroke
    assert all(leg.limits[2].tolist() == [lo, hi] for leg in desktop.leg_architectures)
    with pytest.raises(DescriptionError, match="random-<kind>-<seed>"):
        preset("random-crank-3")


def test_random_robots_have_every_joint_term():
    for name in RANDOM:
        for leg in preset(name).legs:
            for joint in leg.joints:
                d = joint.dynamics
                assert min(d.armature, d.viscous, d.coulomb, d.stiffness, d.damping) > 0
            assert leg.joints[leg.actuated - 1].dynamics.has_transmission


@pytest.mark.parametrize("name", PRESETS + RANDOM)
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_file_round_trip(name, suffix, tmp_path):
    d = preset(name)
    path = d.write(tmp_path / f"robot{suffix}")
    e = RobotDescription.read(path)
    assert e.to_dict() == d.to_dict()
    for a, b in zip(d.legs, e.legs, strict=True):
        assert (a.name, a.actuated, a.branch) == (b.name, b.actuated, b.branch)
        np.testing.assert_array_equal(a.tip, b.tip)
        np.testing.assert_array_equal(a.guess, b.guess)
        assert a.joints == b.joints  # frozen dataclasses: kind, MDH, limits, dynamics
    # the same robot: the same inverse dynamics, bit for bit
    r1, r2 = StewartRobot(d), StewartRobot(e)
    P, V, A = r1.sample_states(3, 0)
    np.testing.assert_array_equal(r1.inverse_dynamics(P, V, A), r2.inverse_dynamics(P, V, A))


def test_ideal_ups_file_unchanged(tmp_path):
    """A description without legs writes exactly what it wrote before (no legs key)."""
    d = preset("paper")
    assert "legs" not in d.to_dict() and "stroke" in d.to_dict()
    text = d.write(tmp_path / "p.toml").read_text()
    assert "[[legs]]" not in text and "legs:" not in text


@pytest.mark.parametrize("name", ["rus", "pus", "ups-offset"])
def test_general_file_header_fits_the_robot(name, tmp_path):
    """The TOML header of a robot with general legs neither lists ``stroke`` nor
    ``u_joint_limits`` as keys of the file (they must be left out) and says the home pose
    is required; the 6-UPS header still describes them."""
    text = preset(name).write(tmp_path / "g.toml").read_text()
    header = text[: text.index("name = ")]
    assert "# stroke:" not in header and "Optional: u_joint_limits" not in header
    assert "No stroke nor u_joint_limits" in header and "home_pose (required)" in header
    ups = preset("paper").write(tmp_path / "p.toml").read_text()
    assert "# stroke: [min, max] leg length" in ups


def test_explicit_ups_legs_equal_the_ideal_path():
    """The ideal 6-UPS with explicit ups() legs and zero joint terms goes through the
    general path and gives today's closed-form results."""
    ideal = preset("random-3")
    legs = ideal.leg_architectures
    explicit = ideal.replace(stroke=None, u_joint_limits=None, legs=legs)
    a, b = StewartRobot(ideal), StewartRobot(explicit)
    assert a.is_ideal_ups and not b.is_ideal_ups and b.architecture == "ups"
    P, V, A = a.sample_states(20, 1)
    tol = 1e-12
    np.testing.assert_allclose(b.inverse_geometry(P), a.inverse_geometry(P), rtol=0, atol=tol)
    np.testing.assert_allclose(b.actuator_positions(P), a.leg_lengths(P), rtol=0, atol=tol)
    np.testing.assert_allclose(b.inverse_jacobian(P), a.inverse_jacobian(P), rtol=0, atol=tol)
    g_a, g_b = a.inverse_dynamics(P, V, A), b.inverse_dynamics(P, V, A)
    assert relative_error(g_b, g_a) < tol
    assert relative_error(b.direct_dynamics(P, V, g_a), a.direct_dynamics(P, V, g_a)) < tol
    assert relative_error(b.gravity_compensation(P), a.gravity_compensation(P)) < tol
    e_a, e_b = a.energy(P, V), b.energy(P, V)
    np.testing.assert_allclose(e_b, e_a, rtol=tol, atol=tol * np.abs(e_a).max())
    np.testing.assert_array_equal(b.dissipated_power(P, V), 0.0)
    np.testing.assert_array_equal(a.dissipated_power(P, V), 0.0)


# ---------------------------------------------------------------------- dynamics
def test_idm_ddm_equal_the_constrained_tree(robot):
    P, V, A = robot.sample_states(12, 7)
    solver = _reference(robot)
    q = robot.inverse_geometry(P, check_limits=False)
    gamma_ref = reference_inverse_dynamics(solver, P, V, A, q)
    gamma = robot.inverse_dynamics(P, V, A)
    assert relative_error(gamma, gamma_ref) < TOL
    accel_ref = reference_direct_dynamics(solver, P, V, gamma_ref, q)
    assert relative_error(robot.direct_dynamics(P, V, gamma_ref), accel_ref) < TOL
    # one state at a time: the same, unbatched shapes
    g0 = robot.inverse_dynamics(P[0], V[0], A[0])
    assert g0.shape == (6,)
    assert relative_error(g0[None], gamma_ref[:1]) < TOL
    # gravity compensation: the tree at rest
    zero = np.zeros((len(P), 6))
    g_static = reference_inverse_dynamics(solver, P, zero, zero, q)
    assert relative_error(robot.gravity_compensation(P), g_static) < TOL


def test_energy_and_dissipation_equal_the_tree(robot):
    P, V, _ = robot.sample_states(6, 3)
    kinetic, potential, power = reference_energy(
        _reference(robot), P, V, robot.inverse_geometry(P, check_limits=False)
    )
    total = kinetic + potential
    e = robot.energy(P, V)
    np.testing.assert_allclose(e, total, rtol=TOL, atol=TOL * np.abs(total).max())
    np.testing.assert_allclose(robot.dissipated_power(P, V), power, rtol=TOL, atol=1e-12)
    assert isinstance(robot.energy(P[0], V[0]), float)


def test_details_and_motor_side(robot):
    P, V, A = robot.sample_states(4, 11)
    r = robot.inverse_dynamics(P, V, A, details=True, backend="pinocchio")
    act = np.array([leg.actuated - 1 for leg in robot.description.legs])
    np.testing.assert_array_equal(r.joint_efforts[:, np.arange(6), act], r.gamma)
    passive = np.ones((6, 3), bool)
    passive[np.arange(6), act] = False
    np.testing.assert_array_equal(r.joint_efforts[:, passive], 0.0)
    ratio = np.array(
        [
            leg.joints[leg.actuated - 1].dynamics.transmission_ratio
            for leg in robot.description.legs
        ]
    )
    motor = robot.inverse_dynamics(P, V, A, motor=True, backend="pinocchio")
    np.testing.assert_allclose(motor * ratio, r.gamma, rtol=1e-14, atol=0)


def test_kinematics_through_the_facade(robot):
    P = robot.sample_poses(5, 2)
    h = 1e-6
    J_inv = robot.inverse_jacobian(P)
    # Jp^-1 against central differences of the actuated joint values along each twist axis
    for n in range(2):
        fd = np.empty((6, 6))
        for k in range(6):
            Tp, Tm = P[n].copy(), P[n].copy()
            if k < 3:
                Tp[k, 3] += h
                Tm[k, 3] -= h
            else:
                import pinocchio as pin

                w = np.zeros(3)
                w[k - 3] = h
                Tp[:3, :3] = pin.exp3(w) @ P[n][:3, :3]
                Tm[:3, :3] = pin.exp3(-w) @ P[n][:3, :3]
            fd[:, k] = (robot.actuator_positions(Tp) - robot.actuator_positions(Tm)) / (2 * h)
        np.testing.assert_allclose(J_inv[n], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    np.testing.assert_allclose(
        robot.jacobian(P) @ J_inv, np.broadcast_to(np.eye(6), J_inv.shape), atol=1e-9
    )
    assert robot.condition_number(P[0]) >= 1.0
    # forward geometry inverts the actuator positions (from a nearby guess)
    qa = robot.actuator_positions(P[0])
    guess = P[0].copy()
    guess[:3, 3] += 1e-3 * robot.description.stroke_mid
    T = robot.forward_geometry(qa, guess)
    np.testing.assert_allclose(T, P[0], atol=1e-9)
    q, qd, qdd = robot.leg_kinematics(P[0], np.zeros(6), np.zeros(6))
    assert q.shape == qd.shape == qdd.shape == (6, 3)
    assert robot.leg_jacobians(P).shape == (5, 6, 3, 3)


def test_validate_passes_on_general_presets():
    for name in PRESETS:
        report = validate(StewartRobot.from_preset(name), n_states=20)
        assert report.passed(), str(report)
        assert report.idm_error < TOL


# ---------------------------------------------------------------------- motion
def test_computed_torque_tracks_on_rus():
    import pinocchio as pin

    from stewart_pin.motion.control import ComputedTorqueController, tracking_errors
    from stewart_pin.motion.simulation import simulate

    robot = StewartRobot.from_preset("rus")
    home = robot.home_pose
    amp, rot, w = 0.004, 0.05, 2 * np.pi * 2.0  # [m], [rad], [rad/s]

    def reference(t):
        T = home.copy()
        T[2, 3] += amp * np.sin(w * t)
        T[:3, :3] = pin.exp3(np.array([rot * np.sin(w * t), 0.0, 0.0])) @ home[:3, :3]
        V = np.array([0, 0, amp * w * np.cos(w * t), rot * w * np.cos(w * t), 0, 0])
        A = np.array([0, 0, -amp * w**2 * np.sin(w * t), -rot * w**2 * np.sin(w * t), 0, 0])
        return T, V, A

    T0, V0, _ = reference(0.0)
    result = simulate(
        robot, 0.25, T0, V0, forces=ComputedTorqueController(robot, reference), dt=2e-3
    )
    e_p, e_r = tracking_errors(reference, result.t, result.poses)
    assert np.linalg.norm(e_p, axis=1).max() < 1e-6  # [m], of a 4 mm motion
    assert np.linalg.norm(e_r, axis=1).max() < 1e-5  # [rad], of a 0.05 rad motion
    np.testing.assert_allclose(result.lengths, robot.actuator_positions(result.poses))
    # the stored "lengths" are the crank angles [rad] (home at -pi/2 .. pi/2), by their name
    assert result.actuator_positions is result.lengths
    assert np.abs(result.lengths).max() < np.pi / 2


def test_simulation_stops_at_a_joint_limit():
    from stewart_pin.exceptions import SimulationError
    from stewart_pin.motion.simulation import simulate

    robot = StewartRobot.from_preset("pus")  # slides on [0, 0.5] m, home at 0.25 m
    with pytest.raises(SimulationError, match="lower limit") as info:
        simulate(robot, 3.0, forces=lambda t, T, V: np.full(6, -2000.0), dt=5e-3)
    result = info.value.result
    assert result.t[-1] < 3.0
    # The limit is located: at the last state some slide is within 1e-4 m of its lower
    # limit (0 m; measured 4.4e-7 m), none beyond it (the slides recomputed from the pose).
    legs = robot.description.legs
    lower = min(leg.joints[leg.actuated - 1].lower for leg in legs)
    assert lower == 0.0
    q = robot.actuator_positions(result.poses[-1])
    assert q.min() >= lower
    assert q.min() - lower <= 1e-4
    np.testing.assert_allclose(result.lengths[-1], q, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------- refusals
def test_the_shared_stroke_is_the_ideal_six_ups_s_alone():
    """A general robot has no shared stroke (each leg its own limits): the 6-UPS's
    closed forms that need one say why (the features take every architecture:
    tests/test_every_architecture.py)."""
    robot = StewartRobot.from_preset("rus")
    with pytest.raises(UnsupportedArchitectureError, match="limits are per leg"):
        robot.description.ideal_stroke("x")


def test_bad_general_descriptions():
    d = preset("rus")
    with pytest.raises(DescriptionError, match="stroke must be left out"):
        d.replace(stroke=[0.1, 0.2])
    with pytest.raises(DescriptionError, match="explicit home_pose"):
        RobotDescription(**{**_kwargs(d), "home_pose": None})
    with pytest.raises(ArchitectureError, match="six legs"):
        d.replace(legs=d.legs[:5])
    far = d.home_pose.copy()
    far[2, 3] += 0.2  # [m]: the 3 cm cranks and 10 cm rods cannot reach
    with pytest.raises(ArchitectureError, match="home pose is not a valid pose"):
        StewartRobot(d.replace(home_pose=far))


def _kwargs(d: RobotDescription) -> dict:
    keys = (
        "base_points platform_points leg_base_rotations stroke leg_inertia platform_inertia "
        "gravity u_joint_limits name home_pose legs"
    ).split()
    return {k: getattr(d, k) for k in keys}


def _broken(d: dict, case: str) -> dict:
    legs = d["legs"]
    if case == "two joints":
        legs[0]["joints"] = legs[0]["joints"][:2]
    elif case == "actuated 4":
        legs[2]["actuated"] = 4
    elif case == "negative armature":
        legs[1]["joints"][0]["armature"] = -0.1
    elif case == "unknown kind":
        legs[0]["joints"][1]["kind"] = "spherical"
    elif case == "unknown key":
        legs[0]["joints"][1]["friction"] = 1.0
    elif case == "stroke beside legs":
        d["stroke"] = [0.1, 0.2]
    return d


BAD = {
    "two joints": (ArchitectureError, "leg 1: a leg must be a chain of exactly three"),
    "actuated 4": (ArchitectureError, r"leg 3: .*actuated joint index must be 1, 2 or 3"),
    "negative armature": (JointDynamicsError, "leg 2 joint 1: joint dynamics armature"),
    "unknown kind": (ArchitectureError, "leg 1 joint 2: joint kind must be"),
    "unknown key": (ArchitectureError, "leg 1 joint 2: unknown joint keys"),
    "stroke beside legs": (DescriptionError, "stroke must be left out"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_leg_files(case, tmp_path, capsys):
    error, message = BAD[case]
    d = _broken(preset("rus").to_dict(), case)
    with pytest.raises(error, match=message):
        RobotDescription.from_dict(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(FileFormatError, match=message):
        RobotDescription.read(path)
    capsys.readouterr()
    assert main(["validate", "--description", str(path), "--states", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err


def test_bad_toml_leg(tmp_path):
    path = preset("pus").write(tmp_path / "pus.toml")
    text = path.read_text()
    assert "actuated = 1" in text
    path.write_text(text.replace("actuated = 1", "actuated = 4", 1))
    with pytest.raises(FileFormatError, match=r"leg 1: .*actuated joint index"):
        RobotDescription.read(path)


# ---------------------------------------------------------------------- CLI
def test_cli_validate_and_ik_on_rus(capsys):
    assert main(["validate", "--preset", "rus", "--states", "10"]) == 0
    assert "PASSED" in capsys.readouterr().out
    assert main(["ik", "--preset", "rus", "--pose", "0", "0", "0.002", "0", "0.02", "0"]) == 0
    out = capsys.readouterr().out
    assert "rus legs" in out and "cond" in out


def test_cli_idm_on_rus(tmp_path, capsys):
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv, state_table, write_csv

    robot = StewartRobot.from_preset("rus")
    P, V, A = robot.sample_states(8, 5)
    traj = write_csv(
        tmp_path / "traj.csv", STATE_COLUMNS, state_table(np.arange(8) * 0.01, P, V, A)
    )
    out = tmp_path / "forces.csv"
    assert main(["idm", "--preset", "rus", "--trajectory", str(traj), "-o", str(out)]) == 0
    rows = read_csv(out, ("t", *(f"gamma{i}" for i in range(1, 7))))
    # the CSV stores the states to 17 significant digits: the reference reads them back
    from stewart_pin.formats.csv_tables import states_from_table

    _, P2, V2, A2 = states_from_table(read_csv(traj, STATE_COLUMNS))
    ref = reference_inverse_dynamics(
        _reference(robot), P2, V2, A2, robot.inverse_geometry(P2, check_limits=False)
    )
    assert relative_error(rows[:, 1:], ref) < TOL


def test_cli_urdf_of_general_legs_loads_with_its_joint_terms(tmp_path, monkeypatch):
    """`stewart-pin urdf --preset rus` writes the chains and the sidecar; Pinocchio's URDF
    parser (through load_tree) builds the 25-dof tree whose armatures are the legs' own
    (the sidecar carries what URDF cannot)."""
    from stewart_pin.models.pinocchio_models import load_tree

    monkeypatch.chdir(tmp_path)
    assert main(["urdf", "--preset", "rus", "-o", "rus.urdf"]) == 0
    tree = load_tree(tmp_path / "rus.urdf")
    desc = preset("rus")
    expected = np.array([j.dynamics.total_armature for leg in desc.legs for j in leg.joints])
    assert tree.model.nq == 25
    flyer = np.zeros(6)  # the platform's free-flyer has no armature
    np.testing.assert_allclose(
        np.sort(tree.model.armature), np.sort(np.r_[expected, flyer]), rtol=1e-15, atol=0
    )


# ---------------------------------------------------------------------- review fixes
def test_the_papers_grouped_parameters_refuse_general_legs():
    """The paper's 88 grouped parameters and Table III assume its R-R-P legs: a RUS robot
    gets a named error, not 88 wrongly grouped parameters (its base parameters are
    tests/test_general_base_params.py's; its compiled models test_general_codegen.py's)."""
    from stewart_pin.parameters.base import grouped_parameters, paper_essential_parameters

    robot = StewartRobot.from_preset("rus")
    for call in (
        lambda: grouped_parameters(robot.description),
        lambda: paper_essential_parameters(robot),
    ):
        with pytest.raises(UnsupportedArchitectureError, match="ideal 6-UPS architecture"):
            call()


def test_a_leg_file_must_say_its_branch(tmp_path):
    """Both solutions of a RUS leg reach the same P_i with different forces: a file that
    leaves the branch out is refused rather than silently assembled in +1."""
    path = tmp_path / "rus.json"
    preset("rus").write(path)
    data = json.loads(path.read_text())
    del data["legs"][2]["branch"]
    path.write_text(json.dumps(data))
    with pytest.raises(FileFormatError, match=r"leg 3.*'branch' is required"):
        RobotDescription.read(path)


def test_general_outputs_that_overflow_are_named_errors():
    """Finite inputs whose result overflows: NumericalError, never NaN (issue 9 item 5)."""
    import warnings

    robot = StewartRobot.from_preset("rus")
    T, huge = robot.home_pose, np.full(6, 1e200)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning escapes either
        with pytest.raises(NumericalError, match="dissipated power"):
            robot.dissipated_power(T, huge)
        with pytest.raises(NumericalError, match="leg joint"):
            robot.leg_kinematics(T, huge, np.zeros(6))


def test_an_overflowing_transmission_is_a_joint_dynamics_error():
    with pytest.raises(JointDynamicsError, match="overflows"):
        JointDynamics(gear_ratio=1e200, rotor_inertia=1e-6)
    assert JointDynamics(gear_ratio=np.int64(300), rotor_inertia=1e-8).total_armature == (
        pytest.approx(300**2 * 1e-8, rel=1e-15)
    )


def test_coulomb_friction_at_a_joint_at_rest_does_not_follow_round_off():
    """Pure heave of the RUS head from its symmetric home pose: joints at rest in exact
    arithmetic come out as round-off rates; with Coulomb friction on every joint the model
    and the constrained tree (each with its own kinematics) must agree, which they do only
    if such a rate counts as zero (COULOMB_DEAD_BAND)."""
    d = preset("rus")
    legs = tuple(
        leg.with_dynamics([replace(j.dynamics, coulomb=0.5) for j in leg.joints]) for leg in d.legs
    )
    robot = StewartRobot(d.replace(legs=legs))
    T, V, A = robot.home_pose, np.array([0, 0, 0.05, 0, 0, 0.0]), np.zeros(6)
    gamma = robot.inverse_dynamics(T, V, A)
    ref = reference_inverse_dynamics(
        _reference(robot), T[None], V[None], A[None], robot.inverse_geometry(T)[None]
    )[0]
    assert relative_error(gamma, ref) < TOL


# ---------------------------------------------------------------------- one-line CLI errors
BAD_TOML_LEGS = {
    # a 1e300 crank: |c|^2 overflows in the closed form (was RuntimeWarnings, then an error)
    "rus crank of 1e300 m": ("rus", "d = 0.03", "d = 1e300", "leg 1 inverse geometry q"),
    # a rod along z3, the second U-joint axis: |tip_xy| sin(alpha3) == 0 (was a divide by
    # zero warning, then a misleading 'cannot reach')
    "rus rod along z3": (
        "rus",
        "tip = [0.1, 0.0, 0.0]",
        "tip = [0.0, 0.0, 0.1]",
        "a 'rus' leg needs a rod not along its second U-joint axis",
    ),
    "pus rod along z3": (
        "pus",
        "tip = [0.45, 0.0, 0.0]",
        "tip = [0.0, 0.0, 0.45]",
        "a 'pus' leg needs a rod not along its second U-joint axis",
    ),
}


@pytest.mark.parametrize("case", BAD_TOML_LEGS)
def test_cli_bad_leg_is_one_line(case, tmp_path, capsys):
    """Overflowing or degenerate legs: exactly one stderr line, exit 2, no RuntimeWarning."""
    import warnings

    name, old, new, message = BAD_TOML_LEGS[case]
    path = preset(name).write(tmp_path / f"{name}.toml")
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["validate", "--description", str(path), "--states", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err and message in err, err
    assert "Warning" not in err


def test_rod_along_the_second_u_axis_is_refused():
    from stewart_pin.description.leg_architecture import rus

    leg = rus(crank=0.03, rod=0.1)
    with pytest.raises(ArchitectureError, match="rod not along its second U-joint axis"):
        leg.replace(tip=np.array([0.0, 0.0, 0.1]))


def test_simulate_unknown_backend_is_refused_before_the_run(tmp_path, capsys):
    """An unknown backend is refused before the run starts: one line, exit 2 (argparse's
    choices), no partial result file; the library functions raise InputError. (General
    legs take every backend now: ``--backend compiled`` on them is test_general_codegen's.)"""
    from stewart_pin.motion.control import ComputedTorqueController
    from stewart_pin.motion.simulation import simulate

    out = tmp_path / "sim.npz"
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--preset", "rus", "--backend", "fast", "--no-progress", "-o", str(out)])
    assert exit_info.value.code == 2
    assert not list(tmp_path.iterdir())  # nothing run, nothing saved
    robot = StewartRobot.from_preset("rus")
    with pytest.raises(InputError, match="unknown backend 'fast'"):
        simulate(robot, 0.1, backend="fast")
    with pytest.raises(InputError, match="unknown backend 'fast'"):
        ComputedTorqueController(
            robot, lambda t: (robot.home_pose, np.zeros(6), np.zeros(6)), backend="fast"
        )


def test_revolute_limits_are_compared_modulo_two_pi():
    """The same RUS robot with its cranks' zero turned by -3.2 rad (theta1 - 3.2, limits
    + 3.2: [1.63, 4.77] rad, past pi): the inverse geometry wraps to (-pi, pi], and used to
    refuse the home pose; the crank angles are now the originals + 3.2 (in the limits) and
    the dynamics are the original robot's (the same physical robot)."""
    from dataclasses import replace as dc_replace

    from stewart_pin.description.leg_architecture import wrap_into_limits

    d = preset("rus")
    shift = 3.2
    legs = []
    for leg in d.legs:
        j1, j2, j3 = leg.joints
        j1 = dc_replace(j1, theta=j1.theta - shift, lower=j1.lower + shift, upper=j1.upper + shift)
        guess = np.asarray(leg.guess) + np.array([shift, 0.0, 0.0])
        legs.append(leg.replace(joints=(j1, j2, j3), guess=guess))
    original, turned = StewartRobot(d), StewartRobot(d.replace(legs=tuple(legs)))
    P, V, A = original.sample_states(6, 2)
    q0 = original.actuator_positions(P)
    q = turned.actuator_positions(P)
    assert q.max() > np.pi  # values the (-pi, pi] wrap used to refuse
    np.testing.assert_allclose(q, q0 + shift, rtol=0, atol=1e-12)
    G0 = original.inverse_dynamics(P, V, A)
    np.testing.assert_allclose(
        turned.inverse_dynamics(P, V, A), G0, rtol=0, atol=1e-9 * np.abs(G0).max()
    )
    # the rule itself: inside unchanged; outside, the representative in (or nearest) the limits
    rev = np.ones((6, 3), bool)
    lo, hi = np.full((6, 3), 3.0), np.full((6, 3), 3.4)
    x = np.full((6, 3), -3.0)  # = 3.283 rad
    np.testing.assert_allclose(wrap_into_limits(x, rev, lo, hi), x + 2 * np.pi)
    x = np.full((6, 3), 0.5)  # 2.5 rad below the limits, 0.5 + 2 pi 3.38 above: kept
    np.testing.assert_array_equal(wrap_into_limits(x, rev, lo, hi), x)
    x = np.full((6, 3), -2.8)  # = 3.483: nearest the upper limit
    np.testing.assert_allclose(wrap_into_limits(x, rev, lo, hi), x + 2 * np.pi)
    assert np.array_equal(wrap_into_limits(x, ~rev, lo, hi), x)  # prismatic: unchanged
    inf = np.full((6, 3), np.inf)
    np.testing.assert_array_equal(wrap_into_limits(x, rev, -inf, inf), x)  # no limits
    np.testing.assert_allclose(wrap_into_limits(x, rev, lo, inf), x + 2 * np.pi)  # lower only
